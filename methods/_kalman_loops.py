"""The Kalman filter's and smoother's recursions as compiled loops (numba).

The state recursions of :func:`diffbench.methods.kalman.rts_smooth` run one sample after
the other, and the covariance recursion of
:func:`diffbench.methods.kalman.covariance_recursion` one step after the other. In numpy
each step costs a few array calls (microseconds); the per-sample loop of
``scipy.signal.lfilter``, on which the steady part ran before, costs about 5 ns a sample a
call whatever the filter's order (measured: an order-2 or order-4 all-pole filter of 1e4
samples, 52 us; a smoother call ran four of them and combined their outputs). Compiled, the
filter and the smoother together cost about 10 ns a sample for 3 and 4 states, 19 ns for 5
and 6: the state is held in scalars and each matrix row is summed in a fixed order (pairs,
then their sums), so that the bits depend on neither the CPU's BLAS kernel nor the record's
length. A model is run padded with zeros to 4 or 6 states (:func:`width`: adding a zero
product leaves a sum's bits unchanged). filterpy's ``batch_filter`` + ``rts_smoother`` stay
the tests' oracle.

Loaded on first use (numba takes about 0.2 s to import); the loops are compiled once and
cached beside this file.

References
----------
S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC
workshop (2015).
"""

from __future__ import annotations

import numba
import numpy as np


def width(states: int) -> int:
    """States a model of ``states`` states is run on: 4 up to 4, else 6 (at most 6)."""
    if not 1 <= states <= 6:
        raise ValueError(f"`states` must be in 1..6, got {states}")
    return 4 if states <= 4 else 6


@numba.njit(inline="always")
def _row4(matrix, index, i, s0, s1, s2, s3, s4, s5):
    """Row ``i`` of ``matrix[index]`` (4 states) times the state, summed as (01)(23)."""
    return (matrix[index, i, 0] * s0 + matrix[index, i, 1] * s1) + (
        matrix[index, i, 2] * s2 + matrix[index, i, 3] * s3
    )


@numba.njit(inline="always")
def _row6(matrix, index, i, s0, s1, s2, s3, s4, s5):
    """Row ``i`` of ``matrix[index]`` (6 states) times the state, summed as ((01)(23))(45)."""
    return (
        (matrix[index, i, 0] * s0 + matrix[index, i, 1] * s1)
        + (matrix[index, i, 2] * s2 + matrix[index, i, 3] * s3)
    ) + (matrix[index, i, 4] * s4 + matrix[index, i, 5] * s5)


@numba.njit(inline="always")
def _row(wide, matrix, index, i, s0, s1, s2, s3, s4, s5):
    """Row ``i`` of ``matrix[index]`` times the state: :func:`_row6` where ``wide``, else
    :func:`_row4` (a condition the compiler takes out of the loops: one loop each)."""
    if wide:
        return _row6(matrix, index, i, s0, s1, s2, s3, s4, s5)
    return _row4(matrix, index, i, s0, s1, s2, s3, s4, s5)


@numba.njit(cache=True)
def _loop(wide, z, mean0, transitions, gains, smoothers, mixes, states):  # pragma: no cover
    """:func:`smooth`'s compiled loop, for 6 states (``wide``) or 4, into ``states``."""
    channels, n = z.shape
    last = gains.shape[0] - 1
    for c in range(channels):
        out = states[c]
        s0, s1, s2, s3 = mean0[c, 0], mean0[c, 1], mean0[c, 2], mean0[c, 3]
        s4 = mean0[c, 4] if wide else 0.0
        s5 = mean0[c, 5] if wide else 0.0
        for k in range(n):  # forward: s_k = A_k s_{k-1} + K_k z_k
            e = min(k, last)
            zk = z[c, k]
            p0 = gains[e, 0] * zk + _row(wide, transitions, e, 0, s0, s1, s2, s3, s4, s5)
            p1 = gains[e, 1] * zk + _row(wide, transitions, e, 1, s0, s1, s2, s3, s4, s5)
            p2 = gains[e, 2] * zk + _row(wide, transitions, e, 2, s0, s1, s2, s3, s4, s5)
            p3 = gains[e, 3] * zk + _row(wide, transitions, e, 3, s0, s1, s2, s3, s4, s5)
            if wide:
                p4 = gains[e, 4] * zk + _row(wide, transitions, e, 4, s0, s1, s2, s3, s4, s5)
                p5 = gains[e, 5] * zk + _row(wide, transitions, e, 5, s0, s1, s2, s3, s4, s5)
                s4, s5 = p4, p5
                out[k, 4], out[k, 5] = p4, p5
            s0, s1, s2, s3 = p0, p1, p2, p3
            out[k, 0], out[k, 1], out[k, 2], out[k, 3] = p0, p1, p2, p3
        for k in range(n - 2, -1, -1):  # backward: s~_k = C_k s~_{k+1} + (I - C_k F) s_k
            e = min(k, last)
            f0, f1, f2, f3 = out[k, 0], out[k, 1], out[k, 2], out[k, 3]
            f4 = out[k, 4] if wide else 0.0
            f5 = out[k, 5] if wide else 0.0
            p0 = _row(wide, smoothers, e, 0, s0, s1, s2, s3, s4, s5)
            p0 += _row(wide, mixes, e, 0, f0, f1, f2, f3, f4, f5)
            p1 = _row(wide, smoothers, e, 1, s0, s1, s2, s3, s4, s5)
            p1 += _row(wide, mixes, e, 1, f0, f1, f2, f3, f4, f5)
            p2 = _row(wide, smoothers, e, 2, s0, s1, s2, s3, s4, s5)
            p2 += _row(wide, mixes, e, 2, f0, f1, f2, f3, f4, f5)
            p3 = _row(wide, smoothers, e, 3, s0, s1, s2, s3, s4, s5)
            p3 += _row(wide, mixes, e, 3, f0, f1, f2, f3, f4, f5)
            if wide:
                p4 = _row(wide, smoothers, e, 4, s0, s1, s2, s3, s4, s5)
                p4 += _row(wide, mixes, e, 4, f0, f1, f2, f3, f4, f5)
                p5 = _row(wide, smoothers, e, 5, s0, s1, s2, s3, s4, s5)
                p5 += _row(wide, mixes, e, 5, f0, f1, f2, f3, f4, f5)
                s4, s5 = p4, p5
                out[k, 4], out[k, 5] = p4, p5
            s0, s1, s2, s3 = p0, p1, p2, p3
            out[k, 0], out[k, 1], out[k, 2], out[k, 3] = p0, p1, p2, p3
    return states


def smooth(z, mean0, transitions, gains, smoothers, mixes) -> np.ndarray:
    r"""Filter and smoother over every channel: the smoothed states (channels, n, w), w =
    :func:`width` of the model (the states past the model's are zero).

    Forward (predict, then update: filterpy's order)
    :math:`\hat s_k = A_k \hat s_{k-1} + K_k z_k`, :math:`A_k = (I - K_k H) F`, from
    :math:`\hat s_{-1}` = ``mean0`` (channels, w); backward from
    :math:`\tilde s_{n-1} = \hat s_{n-1}`,
    :math:`\tilde s_k = C_k \tilde s_{k+1} + (I - C_k F) \hat s_k`
    (Rauch, Tung, Striebel 1965). Step k takes the tables' entry min(k, T) (T + 1 entries:
    the transient's T steps, then the steady one): ``transitions`` A (T+1, w, w), ``gains``
    K (T+1, w), ``smoothers`` C (T+1, w, w), ``mixes`` I - CF (T+1, w, w), each padded by
    :func:`padded`. ``z``: (channels, n)."""
    states = np.empty((z.shape[0], z.shape[1], gains.shape[1]))
    wide = gains.shape[1] == 6
    z = np.ascontiguousarray(z, dtype=float)
    return _loop(wide, z, mean0, transitions, gains, smoothers, mixes, states)


@numba.njit(inline="always")
def _update(predicted, R, gain, covariance, update):  # pragma: no cover
    """The measurement update of :func:`covariance_steps` (Joseph's form, H = [1, 0, ...]):
    the gain and the filtered covariance from the predicted one, into ``gain`` and
    ``covariance`` (``update``: scratch, m by m)."""
    m = predicted.shape[0]
    denominator = predicted[0, 0] + R
    for i in range(m):
        gain[i] = predicted[i, 0] / denominator
    for i in range(m):
        for j in range(m):
            update[i, j] = predicted[i, j] - gain[i] * predicted[0, j]
    for i in range(m):
        for j in range(m):
            covariance[i, j] = (update[i, j] - update[i, 0] * gain[j]) + R * (gain[i] * gain[j])


@numba.njit(inline="always")
def _predict(F, Q, covariance, product, predicted):  # pragma: no cover
    """The prediction of :func:`covariance_steps`, :math:`F P F^\\top + Q`, into
    ``predicted`` (``product``: scratch, m by m), each entry summed in index order."""
    m = F.shape[0]
    for i in range(m):  # F P
        for j in range(m):
            total = 0.0
            for k in range(m):
                total += F[i, k] * covariance[k, j]
            product[i, j] = total
    for i in range(m):  # (F P) Fᵀ + Q
        for j in range(m):
            total = 0.0
            for k in range(m):
                total += product[i, k] * F[j, k]
            predicted[i, j] = total + Q[i, j]


@numba.njit(cache=True)
def covariance_steps(
    F,
    Q,
    R,
    predicted,
    target_gain,
    target,
    gain_tolerance,
    tolerance,
    gains,
    covariances,
    predictions,
):  # pragma: no cover
    r"""Steps of the covariance recursion (filterpy's: update in Joseph's form, then predict)
    from the predicted covariance ``predicted`` (m, m; replaced by the last step's), one into
    each row of ``gains`` (steps, m), ``covariances`` and ``predictions`` (steps, m, m), until
    the rows are full or a step's gain and covariance are within the tolerances of the steady
    ones (``gain_tolerance`` on the largest difference of the gain, ``tolerance`` (m, m)
    entry by entry on the covariance). Returns the steps written and whether the last
    converged.

    .. math::
        K = P^-_{\cdot 0} / (P^-_{00} + R), \quad
        P = (I - KH) P^- (I - KH)^\top + R K K^\top, \quad P^-_{next} = F P F^\top + Q

    with the Joseph form's products expanded for H = [1, 0, ...]:
    :math:`((I - KH)P^-)_{ij} = P^-_{ij} - K_i P^-_{0j}`, and
    :math:`(M (I - KH)^\top)_{ij} = M_{ij} - M_{i0} K_j`."""
    m = F.shape[0]
    update = np.empty((m, m))
    product = np.empty((m, m))
    for step in range(gains.shape[0]):
        gain = gains[step]
        covariance = covariances[step]
        _update(predicted, R, gain, covariance, update)
        _predict(F, Q, covariance, product, predicted)
        predictions[step] = predicted
        converged = True
        for i in range(m):
            if abs(gain[i] - target_gain[i]) > gain_tolerance:
                converged = False
            for j in range(m):
                if abs(covariance[i, j] - target[i, j]) > tolerance[i, j]:
                    converged = False
        if converged:
            return step + 1, True
    return gains.shape[0], False


@numba.njit(cache=True)
def varying_covariance_steps(
    Fs, Qs, R, predicted, gains, covariances, predictions
):  # pragma: no cover
    r"""The covariance recursion of :func:`covariance_steps` with each step's own transition
    and process noise (irregular time stamps: ``Fs``, ``Qs`` of shape (n, m, m)), over all n
    steps (no steady state to stop at): from ``predicted`` (step 0's predicted covariance
    :math:`F_0 P_{-1} F_0^\top + Q_0`), step k's gain and filtered covariance into
    ``gains[k]`` and ``covariances[k]``, and the next step's predicted covariance
    :math:`F_{k+1} P_k F_{k+1}^\top + Q_{k+1}` into ``predictions[k]`` (k < n - 1; the
    smoother's :math:`C_k = P_k F_{k+1}^\top (P^-_{k+1})^{-1}`). filterpy's ``batch_filter``
    with ``Fs``, ``Qs`` runs the same equations (predict with step k's model, then update)."""
    n, m = Fs.shape[0], Fs.shape[1]
    update = np.empty((m, m))
    product = np.empty((m, m))
    for step in range(n):
        gain = gains[step]
        covariance = covariances[step]
        _update(predicted, R, gain, covariance, update)
        if step == n - 1:
            break
        _predict(Fs[step + 1], Qs[step + 1], covariance, product, predicted)
        predictions[step] = predicted
    return gains


def padded_tables(transitions, gains, smoothers, mixes, width: int) -> tuple:
    """The four step tables of :func:`smooth` (A, K, C, I - CF), each padded by :func:`padded`
    to ``width`` states."""
    return (
        padded(transitions, 2, width),
        padded(gains, 1, width),
        padded(smoothers, 2, width),
        padded(mixes, 2, width),
    )


def padded(array: np.ndarray, axes: int, size: int) -> np.ndarray:
    """``array`` with its last ``axes`` axes (each of the model's states) padded with zeros
    to ``size``, C-contiguous."""
    shape = array.shape[: array.ndim - axes] + (size,) * axes
    out = np.zeros(shape)
    out[(..., *(slice(0, n) for n in array.shape[array.ndim - axes :]))] = array
    return out
