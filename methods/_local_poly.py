"""Local least-squares polynomial filters (Savitzky-Golay and weighted variants), computed in a
well-conditioned basis.

``scipy.signal.savgol_coeffs`` solves the raw Vandermonde system on integer offsets; in
scipy 1.17 its coefficients lose all accuracy for long windows with high degrees (e.g. 211
samples, degree 7: the smoothing taps sum to 6.5e-7 instead of 1; scipy issue #20825). Here the
offsets are scaled to [-1, 1] and the fit is done in the Legendre basis with a QR
factorisation, which stays at rounding level for the windows and degrees this project uses;
scipy remains the test oracle where it is accurate.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.polynomial import legendre

from diffbench.methods._fir import apply_central_fir, fft_correlate
from diffbench.methods._validation import samples_in_span


def local_polynomial_weights(
    half_width: int,
    degree: int,
    order: int,
    at: np.ndarray,
    dt: float = 1.0,
    sample_weights: np.ndarray | None = None,
) -> np.ndarray:
    """Weights giving the ``order``-th derivative, at offsets ``at``, of the (weighted)
    least-squares polynomial of ``degree`` fitted to ``2*half_width + 1`` samples.

    .. math::
        \\hat p = \\arg\\min_{\\deg p \\le d} \\sum_{j=-m}^{m} w_j (x_j - p(j\\,\\Delta t))^2,
        \\qquad \\hat p^{(n)}(a\\,\\Delta t) = \\sum_j W_{a,j} x_j

    Returns ``W`` with shape ``(len(at), 2m+1)``. With unit sample weights and ``at = [0]``
    this is the Savitzky-Golay filter (``scipy.signal.savgol_coeffs(2m+1, d, deriv=n,
    delta=dt, use="dot")``). Exact on sampled polynomials of degree <= ``degree``.
    """
    if half_width < 1:
        raise ValueError(f"`half_width` must be >= 1, got {half_width}")
    if not 0 <= degree <= 2 * half_width:
        raise ValueError(f"`degree` must be in [0, {2 * half_width}], got {degree}")
    q, r, root_w = _weighted_fit(half_width, degree, sample_weights)
    at_u = np.atleast_1d(np.asarray(at, dtype=np.float64)) / half_width
    # p(u) = basis(u) c, with c = R^{-1} Q^T sqrt(w) x; du/dt = 1/(m dt).
    weights = _evaluation(r, at_u, degree, order) @ q.T * root_w[np.newaxis, :]
    return weights / (half_width * dt) ** order


def _weighted_fit(half_width: int, degree: int, sample_weights: np.ndarray | None):
    """QR factors of the sqrt-weighted Legendre Vandermonde matrix on the offsets scaled to
    [-1, 1], and the sqrt of the sample weights: the fit's coefficients are
    R^{-1} Q^T (sqrt(w) x)."""
    offsets = np.arange(-half_width, half_width + 1) / half_width  # u in [-1, 1]
    basis = legendre.legvander(offsets, degree)
    root_w = np.ones_like(offsets) if sample_weights is None else np.sqrt(sample_weights)
    q, r = np.linalg.qr(basis * root_w[:, np.newaxis])
    return q, r, root_w


def _evaluation(r: np.ndarray, at_u: np.ndarray, degree: int, order: int) -> np.ndarray:
    """Rows mapping Q^T (sqrt(w) x) to the ``order``-th derivative (in u) of the fitted
    polynomial at each of ``at_u``: shape ``(len(at_u), degree + 1)``."""
    # Column k: d^n/du^n of the Legendre polynomial P_k at each evaluation point (column k
    # of legder(I) holds the Legendre coefficients of P_k^(n)).
    if order > degree:
        derivative_rows = np.zeros((at_u.size, degree + 1))
    elif at_u.size == 1:
        derivative_rows = _derivative_rows_at(float(at_u[0]), degree, order)
    else:
        derivative_rows = _derivative_rows(at_u, degree, order)
    return np.linalg.solve(r.T, derivative_rows.T).T


def _derivative_rows(at_u: np.ndarray, degree: int, order: int) -> np.ndarray:
    """The ``order``-th derivative (in u) of each Legendre polynomial P_0..P_``degree`` at each
    of ``at_u``: shape ``(len(at_u), degree + 1)``."""
    return legendre.legvander(at_u, degree - order) @ _legendre_derivatives(degree, order)


@functools.lru_cache(maxsize=256)
def _legendre_derivatives(degree: int, order: int) -> np.ndarray:
    """``legder(I, order)``: column k holds the Legendre coefficients of the ``order``-th
    derivative of P_k, k = 0..``degree`` (read-only; a tuning asks for the same few)."""
    matrix = legendre.legder(np.eye(degree + 1), order)
    matrix.setflags(write=False)
    return matrix


@functools.lru_cache(maxsize=256)
def _derivative_rows_at(at_u: float, degree: int, order: int) -> np.ndarray:
    """:func:`_derivative_rows` at one point (the centre, for every central filter): cached,
    read-only, the same numbers as computed afresh."""
    rows = _derivative_rows(np.array([at_u]), degree, order)
    rows.setflags(write=False)
    return rows


def end_evaluators(
    half_width: int,
    degree: int,
    order: int,
    dt: float,
    sample_weights: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Factors of the shifted (one-sided) estimates at the ends of a record.

    The first ``m = half_width`` samples get the ``order``-th derivative, at their own offsets
    -m..-1 from the centre of the first full window, of the (weighted) least-squares polynomial
    of ``degree`` fitted to that window; the last ``m`` samples likewise from the last window,
    at offsets 1..m. Returns ``(left, right, project)``: the left-end estimates are
    ``left @ (project @ x[:2m+1])`` and the right-end ones ``right @ (project @ x[-2m-1:])``,
    ``left`` and ``right`` of shape ``(m, degree + 1)`` and ``project`` of shape
    ``(degree + 1, 2m + 1)`` (never the ``m x (2m+1)`` weight matrix, which would take gigabytes
    for windows of tens of thousands of samples). Exact on sampled polynomials of ``degree``.
    Unweighted factors are cached (read-only): a tuning asks for the same ones at every setting.
    """
    if sample_weights is None:
        return _unweighted_end_evaluators(half_width, degree, order, float(dt))
    return _end_evaluators(half_width, degree, order, dt, sample_weights)


@functools.lru_cache(maxsize=256)
def _unweighted_end_evaluators(half_width: int, degree: int, order: int, dt: float):
    factors = _end_evaluators(half_width, degree, order, dt, None)
    for factor in factors:
        factor.setflags(write=False)
    return factors


def _end_evaluators(half_width, degree, order, dt, sample_weights):
    q, r, root_w = _weighted_fit(half_width, degree, sample_weights)
    scale = 1.0 / (half_width * dt) ** order
    offsets = np.arange(1, half_width + 1) / half_width
    left = _evaluation(r, -offsets[::-1], degree, order) * scale
    right = _evaluation(r, offsets, degree, order) * scale
    return left, right, q.T * root_w[np.newaxis, :]


def apply_fir_with_ends(
    x: np.ndarray,
    taps: np.ndarray,
    ends: tuple[np.ndarray, np.ndarray, np.ndarray],
    filtered: np.ndarray | None = None,
) -> np.ndarray:
    """The central FIR filter ``taps`` (2c + 1 of them) on the interior of ``x`` (time on axis
    0) and the shifted estimates of :func:`end_evaluators` (a window of 2m + 1 >= 2c + 1
    samples) on the first and last c samples, where the central window does not fit.
    ``filtered``: the central filter's output already computed (it is completed in place)."""
    left, right, project = ends
    m, c = left.shape[0], taps.size // 2
    n, window = x.shape[0], 2 * m + 1
    if n < window or c > m:
        raise ValueError(f"`x` has {n} samples, fewer than the window's {window}")
    y = apply_central_fir(x, taps)[0] if filtered is None else filtered
    if c == 0:
        return y
    flat = x.reshape(n, -1)
    out = y.reshape(n, -1)
    out[:c] = left[:c] @ (project @ flat[:window])
    out[n - c :] = right[m - c :] @ (project @ flat[n - window :])
    return y


@functools.lru_cache(maxsize=256)
def central_weights(half_width: int, degree: int, order: int, dt: float) -> np.ndarray:
    """:func:`local_polynomial_weights` at the window's centre (the Savitzky-Golay filter's
    taps); cached (a tuning calls a setting's taps again and again), read-only: the same
    numbers as computed afresh."""
    taps = local_polynomial_weights(half_width, degree, order, np.array([0.0]), dt)[0]
    taps.flags.writeable = False
    return taps


def savitzky_golay_filter(
    x: np.ndarray,
    half_width: int,
    degree: int,
    order: int,
    dt: float,
    filtered: np.ndarray | None = None,
) -> np.ndarray:
    """Savitzky-Golay estimate of the ``order``-th derivative of ``x`` along axis 0.

    Interior samples use the central weights; the first and last ``half_width`` samples use the
    polynomial fitted to the first/last full window (scipy's ``mode="interp"``). ``filtered``:
    the central filter's output already computed (completed in place).
    """
    if order > degree:
        return np.zeros_like(x)
    central = central_weights(half_width, degree, order, float(dt))
    ends = end_evaluators(half_width, degree, order, dt)
    return apply_fir_with_ends(x, central, ends, filtered=filtered)


def window_samples(window_s: float, degree: int, dt: float) -> int:
    """Sample count ``2m + 1`` of a window spanning ``window_s = 2m * dt`` seconds that can hold
    a polynomial of ``degree``; ``ValueError`` naming ``window_s`` or ``degree`` otherwise."""
    samples = samples_in_span("window_s", window_s, dt, odd=True, least=degree) + 1
    if degree >= samples:
        shortest = 2 * math.ceil(degree / 2) * dt
        raise ValueError(
            f"`degree`={degree} must be below the window's {samples} samples "
            f"(window_s={window_s!r} s at dt={dt!r} s): lower it, or make `window_s` at "
            f"least {shortest:.10g} s"
        )
    return samples


def local_polynomial_at(
    x: np.ndarray, times: np.ndarray, window_s: float, degree: int, orders
) -> dict[int, np.ndarray]:
    """Savitzky-Golay at irregular times: at each time :math:`t_k`, the least-squares
    polynomial of ``degree`` through the samples in the window
    :math:`[t_k - T/2, t_k + T/2]` (``T = window_s``), moved inside :math:`[t_0, t_{n-1}]`
    where it would stick out (the shifted end fits of the uniform filter), differentiated at
    :math:`t_k`:

    .. math:: \\hat x^{(n)}_k = \\hat p_k^{(n)}(t_k), \\qquad
        \\hat p_k = \\arg\\min_{\\deg p \\le d} \\sum_{t_j \\in W_k} (x_j - p(t_j))^2 .

    On uniform times with ``window_s`` an even number of steps the windows hold the same
    samples as the uniform filter's, so the estimates agree with it. The fit is in the
    variable :math:`(t - t_k)/T` (conditioning). Returns ``{order: values}``.

    Raises ``ValueError`` naming ``t`` and ``window_s`` when a window holds fewer than
    ``degree + 1`` samples (a gap longer than the window).
    """
    n = times.size
    span = times[-1] - times[0]
    slack = 1e-9 * window_s
    values = {order: np.zeros(x.shape) for order in orders}
    flat = x.reshape(n, -1)
    factorials = {order: math.factorial(order) for order in orders}
    for k, centre in enumerate(times):
        lo = centre - window_s / 2
        if window_s >= span:
            lo = times[0]
        elif lo < times[0]:
            lo = times[0]
        elif lo + window_s > times[-1]:
            lo = times[-1] - window_s
        first = int(np.searchsorted(times, lo - slack, side="left"))
        last = int(np.searchsorted(times, lo + window_s + slack, side="right"))
        if last - first < degree + 1:
            raise ValueError(
                f"`t` has {last - first} samples in the window of `window_s`={window_s!r} s "
                f"around t={float(centre)!r} s; a polynomial of degree {degree} needs "
                f"{degree + 1}: use a longer `window_s` or a lower `degree`"
            )
        u = (times[first:last] - centre) / window_s
        vander = np.vander(u, degree + 1, increasing=True)
        coefficients = np.linalg.lstsq(vander, flat[first:last], rcond=None)[0]
        for order in orders:
            row = coefficients[order] if order <= degree else 0.0
            values[order][k] = np.reshape(row * factorials[order] / window_s**order, x.shape[1:])
    return values


def sample_spans(times: np.ndarray) -> np.ndarray:
    """The span of time each of ``times`` stands for: half the gaps to its two neighbours, the
    whole gap to its only neighbour at the record's ends (equal spans on a uniform grid)."""
    gaps = np.diff(times)
    spans = np.empty(times.size)
    spans[1:-1] = (gaps[:-1] + gaps[1:]) / 2
    spans[0], spans[-1] = gaps[0], gaps[-1]
    return spans


def kernel_weighted_fit_at(
    x: np.ndarray,
    times: np.ndarray,
    at: np.ndarray,
    reach_s: float,
    degree: int,
    order: int,
    kernel,
    centres_s: np.ndarray | None = None,
) -> np.ndarray:
    r"""Local polynomial regression with a kernel centred on each evaluation time: at each
    :math:`a` of ``at`` (indices into ``times``), the polynomial of ``degree`` fitted to the
    samples within ``reach_s`` of :math:`t_a` that the record holds (the window truncated at
    the record's ends, not moved), by least squares weighted with the kernel of the offset and
    the span of time each sample stands for (:func:`sample_spans`), differentiated at
    :math:`t_a`:

    .. math:: \hat p_a = \arg\min_{\deg p \le d} \sum_{|t_j - t_a| \le r}
        K(t_j - t_a)\, s_j\, (x_j - p(t_j - t_a))^2, \qquad \hat x^{(n)}_a = \hat p_a^{(n)}(0)

    ``kernel`` maps offsets in seconds to weights. Near a record's end the truncated window
    makes this the boundary-corrected estimate of local polynomial regression (J. Fan, I.
    Gijbels, *Local Polynomial Modelling and Its Applications*, Chapman & Hall, 1996, sec.
    3.2.5): exact on polynomials of ``degree`` wherever it is evaluated. The fit is in the
    Legendre basis of the offset over ``reach_s`` by QR, as :func:`local_polynomial_weights`.
    Returns the estimates at ``at`` (time on axis 0).

    ``centres_s`` (one time per evaluation, optional) centres each window and its kernel
    there instead of at :math:`t_a` (offsets :math:`t_j - c_a`), and the fitted polynomial is
    differentiated at :math:`t_a - c_a`: the shifted windows of Mboup, Join & Fliess (2009) at
    the actual time stamps, a window moved inside the record for a sample near its end.

    Raises ``ValueError`` naming ``t`` when a window holds fewer than ``degree + 1`` samples.
    """
    n = times.size
    flat = x.reshape(n, -1)
    out = np.empty((np.size(at), flat.shape[1]))
    blocks = _kernel_fit_blocks(times, at, reach_s, degree, order, kernel, centres_s)
    for rows, index, root, q, z in blocks:
        # the estimate is e^T R^{-1} Q^T sqrt(w) x, with e the derivative's row at the sample
        projected = np.swapaxes(q, 1, 2) @ (root[..., None] * flat[index])
        out[rows] = (np.swapaxes(z, 1, 2) @ projected)[:, 0]
    return out / reach_s**order


def kernel_weighted_weights_at(
    times: np.ndarray, at: np.ndarray, reach_s: float, degree: int, order: int, kernel
) -> np.ndarray:
    r"""The weights of :func:`kernel_weighted_fit_at`: the matrix ``W`` (``at.size`` by
    ``times.size``) with :math:`\hat x^{(n)}_a = \sum_j W_{aj} x_j`, row a being
    :math:`\sqrt{w}\, Q R^{-\top} e / r^n` of the same QR factorisation (zero outside the
    window). The fit is linear in the data, so a caller that applies it to many records at
    the same times computes these once (one matrix product a record instead of a QR a
    sample); the two agree to rounding."""
    at = np.asarray(at, dtype=np.intp)
    n = times.size
    weights = np.zeros((at.size, n + 1))  # the last column takes the windows' padding
    for rows, index, root, q, z in _kernel_fit_blocks(times, at, reach_s, degree, order, kernel):
        columns = np.where(root > 0, index, n)
        weights[np.arange(at.size)[rows, None], columns] = root * (q @ z)[..., 0]
    return weights[:, :n] / reach_s**order


def _kernel_fit_blocks(times, at, reach_s, degree, order, kernel, centres_s=None):
    """The QR factorisations of :func:`kernel_weighted_fit_at`, a block of evaluation times
    at a time: yields (rows of ``at``, the windows' sample indices, sqrt of their weights, Q,
    and z = R^{-T} e), the windows padded to the widest with weight 0; windows and kernels
    centred on ``centres_s`` when given (else on the evaluation times)."""
    n = times.size
    at = np.asarray(at, dtype=np.intp)
    centres = times[at] if centres_s is None else np.asarray(centres_s, dtype=np.float64)
    spans = sample_spans(times)
    slack = 1e-9 * reach_s
    first = np.searchsorted(times, centres - reach_s - slack, side="left")
    last = np.searchsorted(times, centres + reach_s + slack, side="right")
    counts = last - first
    if at.size and counts.min() < degree + 1:
        worst = int(np.argmin(counts))
        raise ValueError(
            f"`t` has {counts[worst]} samples within {reach_s!r} s of "
            f"t={float(centres[worst])!r} s; a local polynomial of degree {degree} needs "
            f"{degree + 1}: use a wider kernel"
        )
    if centres_s is None:  # d^n/du^n of P_0..P_d at u = 0, the same row for every window
        evaluate = _derivative_rows_at(0.0, degree, order)[0]
    else:  # at each sample's own offset from its window's centre
        evaluate = _derivative_rows(np.clip((times[at] - centres) / reach_s, -1, 1), degree, order)
    width = int(counts.max()) if at.size else 0
    chunk = max(1, KERNEL_FIT_CHUNK_ELEMENTS // max(1, width * (degree + 1)))
    offsets_in_window = np.arange(width)
    for start in range(0, at.size, chunk):
        rows = slice(start, start + chunk)
        # each window's samples, padded to the widest with weight 0 (rows of zeros change no fit)
        index = np.minimum(first[rows, None] + offsets_in_window, n - 1)
        inside = offsets_in_window < counts[rows, None]
        offsets = times[index] - centres[rows, None]
        weight = np.where(inside, kernel(offsets) * spans[index], 0.0)
        root = np.sqrt(weight)
        u = np.clip(offsets / reach_s, -1.0, 1.0)
        q, r = np.linalg.qr(legendre.legvander(u, degree) * root[..., None])
        rows_evaluated = evaluate if evaluate.ndim == 1 else evaluate[rows]
        z = np.linalg.solve(
            np.swapaxes(r, 1, 2), np.broadcast_to(rows_evaluated, r.shape[:2])[..., None]
        )
        yield rows, index, root, q, z


KERNEL_FIT_CHUNK_ELEMENTS = 2_000_000
"""How many basis entries (windows x samples x coefficients) :func:`kernel_weighted_fit_at`
factors at once: about 16 MB a block."""


END_MATRIX_UP_TO = 1024
"""Half widths up to which :func:`kernel_end_fits` applies the end fits as one cached matrix
(m × 2m: at most 16 MiB); wider windows correlate the record instead."""


def kernel_end_fits(
    x: np.ndarray, half_width: int, dt: float, degree: int, order: int, weights: np.ndarray
) -> np.ndarray:
    r""":func:`kernel_weighted_fit_at` on a uniform grid at the first ``m = half_width``
    samples, whose windows the record's start truncates, for every channel: the estimates at
    samples 0..m-1 (time on axis 0), linear in the first 2m samples.

    With :math:`s` the offset in steps, :math:`g(s)` = ``weights`` (:math:`|s| \le m`) and the
    Legendre basis :math:`P_a(s/m)`, the fit at sample k solves the normal equations
    :math:`M_k c = b_k`,

    .. math:: M_k = \sum_{s=-k}^{m} g(s) P(s/m) P(s/m)^T, \qquad
        b_k = \sum_{s=-k}^{m} g(s) P(s/m)\, x_{k+s},

    and returns :math:`e^T M_k^{-1} b_k / (m\Delta t)^n` with :math:`e` the n-th derivatives of
    the :math:`P_a` at 0: the same fit as the QR of :func:`kernel_weighted_fit_at`, with its
    condition squared (normal equations). As a matrix E (m × 2m) of the first 2m samples,
    :math:`E_{k,k+s} = \sum_a (M_k^{-1} e)_a\, g(s) P_a(s/m)` (:func:`_kernel_end_matrix`,
    cached by setting: one product a call), up to :data:`END_MATRIX_UP_TO`; beyond, the
    :math:`b_k` are the record's correlations with :math:`g P_a` (FFTs sharing its
    transform), in O(m log m) rather than O(m²) per channel. The record needs 2m samples.
    """
    m = half_width
    flat = x.reshape(x.shape[0], -1)
    weights = np.ascontiguousarray(weights, dtype=float)
    if m <= END_MATRIX_UP_TO:
        matrix = _kernel_end_matrix(m, float(dt), degree, order, weights.tobytes())
        return matrix @ flat[: 2 * m]
    solved, weighted = _kernel_end_factors(m, degree, order, weights)
    padded = np.concatenate([np.zeros((m, flat.shape[1])), flat[: 2 * m]])  # x_j = 0 for j < 0
    out = np.zeros((m, flat.shape[1]))
    # b_k[a] = sum_s g(s) P_a(s/m) padded[k + m + s]: the centred correlations with g P_a at
    # samples m..2m-1, every a sharing the record's transform (the degree + 1 kernels at once)
    correlations = fft_correlate(padded, [weighted[:, a] for a in range(degree + 1)])
    for a, correlated in enumerate(correlations):
        out += solved[:, a, None] * correlated[m : 2 * m]
    return out / (m * dt) ** order


def _kernel_end_factors(m: int, degree: int, order: int, weights: np.ndarray):
    """:func:`kernel_end_fits`' data-independent factors: :math:`M_k^{-1} e` (m, degree + 1)
    for k = 0..m-1, and :math:`g(s) P_a(s/m)` (2m + 1, degree + 1) for s = -m..m."""
    basis = legendre.legvander(np.arange(-m, m + 1) / m, degree)  # rows s = -m..m
    weighted = weights[:, None] * basis
    products = weighted[:, :, None] * basis[:, None, :]
    suffix = np.cumsum(products[::-1], axis=0)[::-1]  # suffix[i]: the sum from row i on
    normal = suffix[m - np.arange(m)]  # M_k: rows s >= -k, i.e. from row m - k
    evaluate = _derivative_rows_at(0.0, degree, order)[0]
    solved = np.linalg.solve(normal, np.broadcast_to(evaluate, (m, degree + 1))[..., None])[..., 0]
    return solved, weighted


@functools.lru_cache(maxsize=64)
def _kernel_end_matrix(m: int, dt: float, degree: int, order: int, weights: bytes) -> np.ndarray:
    """:func:`kernel_end_fits`' matrix E (m × 2m) for the ``weights`` g(s), s = -m..m (their
    float64 bytes); cached, read-only."""
    solved, weighted = _kernel_end_factors(m, degree, order, np.frombuffer(weights))
    rows = solved @ weighted.T  # rows[k, s + m] = sum_a (M_k^-1 e)_a g(s) P_a(s/m)
    matrix = np.zeros((m, 2 * m))
    for k in range(m):  # sample k reads x_{k+s} for s = -k..m
        matrix[k, : k + m + 1] = rows[k, m - k :]
    matrix /= (m * dt) ** order
    matrix.flags.writeable = False
    return matrix
