r"""Gaussian-process regression with a squared-exponential (RBF) kernel, differentiated
analytically through the kernel's derivatives.

Two registered methods share the computation (:func:`posterior_derivatives`):
``gaussian_process`` with its hyperparameters given (linear in the input, with a frequency
response), and ``gaussian_process_ml``, whose hyperparameters the marginal likelihood of the
record chooses (:func:`fit_hyperparameters`; data only, no truth, not linear).

Long records: the posterior mean is computed for the whole record at once, without blocks.
On a uniform grid the covariance matrix is Toeplitz, so :math:`(K + r^2 I)\alpha = y` is
solved by conjugate gradients whose products with K are FFT convolutions, preconditioned by
the circulant matrix of the same kernel (whose inverse is the infinite-grid Wiener filter):
O(n log n) per iteration, 5-40 iterations whatever n. Many right-hand sides at once (the ends
check's probes) are preconditioned by the exact inverse instead, applied by the
Gohberg-Semencul formula from its first column: 2-3 iterations each. Blocks were measured
and set aside: the posterior mean's weights (the equivalent kernel) decay to 1e-6 of their
peak only 10-23 length scales away, to 1e-9 at 15-36 (more for less noise), so exact local
blocks need margins of tens of length scales: thousands of samples at 1 kHz for a ~5 Hz
smoother, too many for dense factorisations.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import fft as sp_fft
from scipy import optimize
from scipy.linalg import cho_solve_banded, cholesky_banded, lapack

from diffbench.methods._ends import trusted_samples, trusted_times
from diffbench.methods._registry import Method, Preset, param, register
from diffbench.methods._time_stamps import to_grid, uniform_grid
from diffbench.methods._validation import mean_step

TRUNCATE = 9.0
"""The kernel and its derivatives are used up to ``TRUNCATE`` length scales each side: beyond,
:math:`e^{-9^2/2} = 2.6 \\cdot 10^{-18}` of the peak, below rounding."""

ALIASES = 3
"""Aliased copies of the spectral density summed each side (:func:`sampled_spectrum`): the
next is below :math:`e^{-2\\pi^2 3.5^2} \\approx 10^{-105}` of the peak for ℓ ≥ Δt."""

SOLVER_TOLERANCE = 1e-14
"""Relative residual at which conjugate gradients stop (rounding limits the residual to about
1e-16 times the condition number, which is at most ~1 + 2.5 ℓ / (Δt r²))."""

SOLVER_MAX_ITERATIONS = 2000
"""Conjugate-gradient iterations allowed; 5-40 were measured over ℓ/Δt in 3..138 and r in
1e-3..1 at n = 1e4 and 1e5."""

EXACT_PRECONDITIONER_COLUMNS = 8
"""Right-hand sides from which a solve is preconditioned by the exact inverse of
:math:`K + r^2 I` (:class:`_GohbergSemencul`) instead of the circulant matrix: its generator
costs one more solve of a single column (by the circulant preconditioner), after which each
column converges in 2-3 iterations instead of 20-70. Measured at n = 9301, 64 columns, ℓ/Δt
in 3..3000, r in 3e-3..1: 2-12 times less time, the same residuals. The ends check's probes
(:mod:`methods._ends`: 64 and 48 columns) take this path; the records scored (one column a
channel) keep the circulant one."""

EXACT_PRECONDITIONER_ITERATIONS = 20
"""Iterations allowed with the exact-inverse preconditioner before the solve starts again with
the circulant one (2-3 were measured: rounding in the generator is all it leaves to do)."""

MIN_NOISE_RATIO = 1e-3
MAX_NOISE_RATIO = 1e3
"""Admissible ``noise_ratio``. Rounding grows as the condition number of :math:`K + r^2 I`,
about 2.5 ℓ/(Δt r²): measured, inputs equal but for the last bit gave estimates 5e-9 apart
at r = 1.4e-3, ℓ = 52 Δt (below 1e-9 at r = 4e-3, where the tuning range starts); below 1e-3
it would pass 1e-8. Above 1e3 the estimate is the straight line to 1e-6."""

END_REACH_LENGTHS = 20.0
"""How far, in length scales, the ends of a record change the posterior mean: its weights (the
equivalent kernel) fall below 1e-6 of their peak 10-23 length scales away (module docstring),
so the samples within this many length scales of an end are the ones the ends check probes
(:mod:`methods._ends`); those estimated worse than twice the interior are masked."""

FITTED_END_ERROR_FACTOR = 1.8
"""The ends check's factor for ``gaussian_process_ml`` (its rule's c, see :mod:`methods._ends`),
probed at the fitted hyperparameters. The rule's 2 kept ẋ end samples at 4.3 times the interior
error on the clean paper signal: the likelihood fits the band to the record's own content, so
the probe's worst in-band case is the signal itself. Measured on clean records (worst valid end
error / worst interior error, ẋ / ẍ; share of samples kept): 1.5 gives 1.24 / 1.11 on the paper
signal but keeps 46 % / 32 % of one period of a sinusoid; 1.8 gives 2.5 / 2.3 on the paper
signal, 1.9 / 1.7 on the grid's 1 ms sinusoid, 1.8 / 1.4 on the 4937 ms paper signal and keeps
72 % / 83 % of the one-period sinusoid (the chirp's ends, at its highest frequency, stay 13 / 9
times its middle with any factor: that is the chirp, not its ends)."""

MAX_LENGTH_STEPS = 1e6
"""Longest ``length_scale_s`` in sampling steps (beyond, the prior is a constant over any record
this benchmark holds, and the estimate the straight line)."""

FIT_SAMPLES = (200, 400, 800)
"""The choices of ``gaussian_process_ml``'s ``fit_samples``: at most this many samples enter
the marginal likelihood (each evaluation is O(m³); a fit takes about 0.03, 0.08 and 0.74 s
on the paper signal): the whole record if it is no longer, else ``FIT_SEGMENTS`` contiguous
segments spread evenly over it (their joint likelihood, cross-covariances included)."""

FIT_SEGMENTS = 2
FIT_RESTARTS = 1
"""Restarts of L-BFGS-B from seeded log-uniform draws in the bounds (the
likelihood of an RBF + noise model has local optima, e.g. noise fitted as signal)."""

FIT_GRID = 0.01
"""Step of the grid (in natural log) the fitted length scale (in sampling steps) and noise
ratio are rounded to before the posterior is formed (:func:`snap_to_grid`): 1 %, far below the
fit's statistical uncertainty. The likelihood is flat at its optimum, so L-BFGS-B's optimum is
only defined to about 1e-7 relative and moves that much with the BLAS kernel's rounding (3e-8
to 8e-7 between OpenBLAS's SkylakeX, Haswell and Sandybridge kernels on the paper signal,
polished or not); rounded, the estimate is the same on every kernel but for optima within that
distance of a grid boundary (about 2e-5 of fits)."""

STRAIGHT = 1e-12
"""A record whose residual from its least-squares line has an RMS below this fraction of the
record's RMS is a straight line to rounding: ``gaussian_process_ml`` returns the line (there
is nothing to fit)."""


def rbf_covariance(lag_s, length_scale_s: float, order: int) -> np.ndarray:
    r"""Cross-covariance of the derivative of ``order`` (0, 1, 2) of a unit-variance RBF process
    with its values, at lags :math:`\tau = t - t'`.

    With :math:`k(t, t') = e^{-\tau^2 / (2\ell^2)}`, differentiation being linear, the
    derivative process :math:`f^{(n)}` has :math:`\operatorname{cov}(f^{(n)}(t), f(t')) =
    \partial^n k / \partial t^n`:

    .. math:: k^{(0)} = e^{-\tau^2/(2\ell^2)}, \quad
        k^{(1)} = -\frac{\tau}{\ell^2} k^{(0)}, \quad
        k^{(2)} = \left(\frac{\tau^2}{\ell^4} - \frac{1}{\ell^2}\right) k^{(0)}

    so the posterior mean's derivatives are :math:`m^{(n)}(t) = \sum_j k^{(n)}(t - t_j)
    \alpha_j`.

    References: C. E. Rasmussen, C. K. I. Williams, *Gaussian Processes for Machine Learning*,
    MIT Press (2006), sec. 9.4 "Derivative observations"; E. Solak, R. Murray-Smith, W. E.
    Leithead, D. J. Leith, C. E. Rasmussen, "Derivative observations in Gaussian process models
    of dynamic systems", NIPS 15 (2003).

    >>> rbf_covariance([0.0, 1.0], 1.0, 1)  # -τ e^{-τ²/2}
    array([-0.        , -0.60653066])
    """
    tau = np.asarray(lag_s, dtype=float)
    u = tau / length_scale_s
    base = np.exp(-0.5 * u**2)
    if order == 0:
        return base
    if order == 1:
        return -u / length_scale_s * base
    if order == 2:
        return (u**2 - 1.0) / length_scale_s**2 * base
    raise ValueError(f"`order` must be 0, 1 or 2, got {order!r}")


def rbf_spectral_density(frequency_hz, length_scale_s: float) -> np.ndarray:
    r"""Spectral density of the unit-variance RBF kernel,
    :math:`S(f) = \int k(\tau) e^{-i2\pi f\tau} d\tau = \sqrt{2\pi}\,\ell\, e^{-2\pi^2\ell^2
    f^2}`."""
    f = np.asarray(frequency_hz, dtype=float)
    return math.sqrt(2 * math.pi) * length_scale_s * np.exp(-2 * (np.pi * length_scale_s * f) ** 2)


def sampled_spectrum(frequency_hz, dt: float, length_scale_s: float, order: int) -> np.ndarray:
    r"""Spectrum of the sampled kernel derivative :math:`k^{(n)}(j\Delta t)`, by Poisson
    summation: :math:`\sum_j k^{(n)}(j\Delta t) e^{-i2\pi f j\Delta t} = \frac{1}{\Delta t}
    \sum_m (i2\pi f_m)^n S(f_m)`, :math:`f_m = f + m/\Delta t`, |m| ≤ ``ALIASES``."""
    f = np.asarray(frequency_hz, dtype=float)
    total = np.zeros(f.shape, dtype=complex)
    for alias in range(-ALIASES, ALIASES + 1):
        shifted = f + alias / dt
        total += (2j * np.pi * shifted) ** order * rbf_spectral_density(shifted, length_scale_s)
    return total / dt


def gaussian_process_response(
    frequency_hz, dt: float, length_scale_s: float, noise_ratio: float, order: int
) -> np.ndarray:
    r"""Response of the posterior mean's derivative of ``order`` at the samples, on an
    infinite uniform grid (a Wiener filter):

    .. math:: H_n(f) = \frac{\sum_m (i2\pi f_m)^n S(f_m)}{\sum_m S(f_m) + r^2\Delta t}
        \approx (i2\pi f)^n \frac{S(f)}{S(f) + r^2 \Delta t}

    with S the kernel's spectral density (:func:`rbf_spectral_density`) and
    :math:`f_m = f + m/\Delta t` its aliases (negligible below Nyquist for ℓ of a few steps).
    The gain is one half where :math:`2\pi^2\ell^2 f^2 = \ln(\sqrt{2\pi}\ell/(r^2\Delta t))`.
    At 0 Hz it is :math:`1/(1 + r^2\Delta t/(\sqrt{2\pi}\ell)) < 1`: a zero-mean process
    shrinks offsets (hence the straight line the methods take out first).

    Reference: Rasmussen & Williams (2006), sec. 7.1 (the equivalent kernel).
    """
    f = np.asarray(frequency_hz, dtype=float)
    smooth = sampled_spectrum(f, dt, length_scale_s, 0).real
    return sampled_spectrum(f, dt, length_scale_s, order) / (smooth + noise_ratio**2)


def _least_squares_line(x: np.ndarray, dt: float):
    """The least-squares line of each column of ``x`` (time on axis 0): values and slopes."""
    n = x.shape[0]
    centred = ((np.arange(n) - (n - 1) / 2) * dt).reshape((n,) + (1,) * (x.ndim - 1))
    mean = x.mean(axis=0)
    denominator = float(np.sum(centred**2))
    slope = (centred * (x - mean)).sum(axis=0) / denominator if denominator else 0.0 * mean
    return mean + slope * centred, slope


class _ToeplitzKernel:
    """The n×n covariance and cross-covariance matrices of a uniform grid as FFT products."""

    def __init__(self, n: int, dt: float, length_scale_s: float, noise_ratio: float):
        self.n = n
        half = int(min(n - 1, math.ceil(TRUNCATE * length_scale_s / dt)))
        self.size = sp_fft.next_fast_len(n + half, real=True)
        self.lags = np.arange(-half, half + 1) * dt
        self.dt, self.length_scale_s, self.noise_variance = dt, length_scale_s, noise_ratio**2
        self.spectra: dict[int, np.ndarray] = {}
        # The preconditioner: the circulant matrix of the same kernel periodised over the FFT
        # length, whose eigenvalues (Poisson summation) are positive.
        frequency = sp_fft.rfftfreq(self.size, dt)
        self.inverse = 1.0 / (
            sampled_spectrum(frequency, dt, length_scale_s, 0).real + self.noise_variance
        )

    def spectrum(self, order: int) -> np.ndarray:
        """FFT of the truncated, wrapped column :math:`k^{(n)}(j\\Delta t)`."""
        if order not in self.spectra:
            column = np.zeros(self.size)
            values = rbf_covariance(self.lags, self.length_scale_s, order)
            half = (values.size - 1) // 2
            column[: half + 1] = values[half:]
            if half:
                column[-half:] = values[:half]
            self.spectra[order] = sp_fft.rfft(column)
        return self.spectra[order]

    def apply(self, vectors: np.ndarray, order: int) -> np.ndarray:
        """:math:`\\sum_j k^{(n)}((i - j)\\Delta t) v_j` for every sample i, of each column of
        ``vectors`` (n,) or (n, k)."""
        return self._convolve(vectors, self.spectrum(order))

    def precondition(self, vectors: np.ndarray) -> np.ndarray:
        """The circulant preconditioner's inverse applied to each column of ``vectors``."""
        return self._convolve(vectors, self.inverse)

    def _convolve(self, vectors: np.ndarray, spectrum: np.ndarray) -> np.ndarray:
        # in place on the transform: one complex array at a time (memory on long records)
        transformed = sp_fft.rfft(vectors, self.size, axis=0)
        transformed *= spectrum.reshape((-1,) + (1,) * (vectors.ndim - 1))
        return sp_fft.irfft(transformed, self.size, axis=0, overwrite_x=True)[: self.n]

    def solve(self, y: np.ndarray, overwrite_y: bool = False) -> np.ndarray:
        """:math:`\\alpha = (K + r^2 I)^{-1} y` for each column of ``y`` (n, k), by
        preconditioned conjugate gradients run on every column at once (``overwrite_y``: the
        residual may take ``y``'s memory, which the caller no longer needs).

        Each column has its own iteration (Hestenes-Stiefel with the preconditioner M, as
        ``scipy.sparse.linalg.cg``, its test oracle): :math:`a = \\rho/(p^\\top Ap)`,
        :math:`x \\mathrel{+}= a p`, :math:`r \\mathrel{-}= a Ap`, :math:`z = Mr`,
        :math:`p = z + (\\rho'/\\rho) p` with :math:`\\rho = r^\\top z`, until
        :math:`\\lVert r\\rVert \\le` ``SOLVER_TOLERANCE`` :math:`\\lVert y\\rVert`; a column
        that has converged stops moving. The products with K and M are FFTs of all the moving
        columns together: one call per iteration instead of one per column (scipy's ``cg``
        takes one right-hand side: 48 probe columns cost 48 solves, most of it call overhead).
        Columns are reduced along time each on its own: a column's result depends on its
        neighbours only through the order of additions (to rounding). M is the circulant
        matrix of the kernel (:meth:`precondition`) for fewer than
        ``EXACT_PRECONDITIONER_COLUMNS`` columns, else the exact inverse
        (:meth:`exact_inverse`), the circulant one again if that has not converged after
        ``EXACT_PRECONDITIONER_ITERATIONS``: both meet the same tolerance.

        Reference: Y. Saad, *Iterative Methods for Sparse Linear Systems*, 2nd ed., SIAM
        (2003), algorithm 9.1.
        """
        y = np.asarray(y, dtype=float)
        peak = np.max(np.abs(y), axis=0) if y.size else np.zeros(y.shape[1:])
        if np.any((peak > 0) & ((peak < 2.0**-400) | (peak > 2.0**400))):
            # columns far from 1 (3e-137 once made r'z underflow to 0/0): solved scaled by a
            # power of two, which changes no rounding, then scaled back
            exponent = np.frexp(np.where(peak > 0, peak, 1.0))[1]
            return np.ldexp(self._solve(np.ldexp(y, -exponent), True), exponent)
        return self._solve(y, overwrite_y)

    def _solve(self, y: np.ndarray, overwrite_y: bool) -> np.ndarray:
        if y.shape[1] >= EXACT_PRECONDITIONER_COLUMNS and self.n > 1:
            exact = self.exact_inverse()
            if exact is not None:
                solution = self._conjugate_gradients(
                    y, False, exact.apply, EXACT_PRECONDITIONER_ITERATIONS
                )
                if solution is not None:
                    return solution
        solution = self._conjugate_gradients(
            y, overwrite_y, self.precondition, SOLVER_MAX_ITERATIONS
        )
        if solution is None:
            raise ValueError(
                f"the Gaussian-process system did not converge in {SOLVER_MAX_ITERATIONS} "
                f"iterations at `length_scale_s`={self.length_scale_s!r} s, `noise_ratio`="
                f"{math.sqrt(self.noise_variance)!r}, dt={self.dt!r} s (raise `noise_ratio`)"
            )
        return solution

    def exact_inverse(self) -> _GohbergSemencul | None:
        """:math:`(K + r^2 I)^{-1}` as :class:`_GohbergSemencul` of its first column (solved
        with the circulant preconditioner; cached), or None when that solve does not give a
        usable generator (not finite, or a first entry that is not positive, which the inverse
        of a positive definite matrix has)."""
        if not hasattr(self, "_exact"):
            unit = np.zeros((self.n, 1))
            unit[0] = 1.0
            first = self._conjugate_gradients(unit, True, self.precondition, SOLVER_MAX_ITERATIONS)
            usable = first is not None and np.all(np.isfinite(first)) and first[0, 0] > 0
            self._exact = _GohbergSemencul(first[:, 0]) if usable else None
        return self._exact

    def _conjugate_gradients(
        self, y: np.ndarray, overwrite_y: bool, precondition, max_iterations: int
    ) -> np.ndarray | None:
        """The solves of :meth:`solve` with the preconditioner ``precondition``; None when a
        column has not converged after ``max_iterations``."""
        target = SOLVER_TOLERANCE * np.sqrt(_column_dots(y, y))
        solution = np.zeros_like(y)
        moving = np.flatnonzero(target > 0)  # a zero column's solution is zero
        if not moving.size:
            return solution
        if moving.size < y.shape[1]:
            x, r = np.zeros((y.shape[0], moving.size)), y[:, moving]
        else:  # every column moves: the solution is built in place, the residual in y
            x, r = solution, (y if overwrite_y else y.copy())
        z = precondition(r)
        rho = _column_dots(r, z)
        direction = z
        for _ in range(max_iterations):
            product = self.apply(direction, 0)
            product += self.noise_variance * direction
            step = rho / _column_dots(direction, product)
            direction_step = step * direction
            x += direction_step
            product *= step
            r -= product
            del product, direction_step
            done = np.sqrt(_column_dots(r, r)) <= target[moving]
            if done.any():
                if x is not solution:
                    solution[:, moving[done]] = x[:, done]
                if done.all():
                    return solution
                keep = ~done
                moving, x, r = moving[keep], x[:, keep], r[:, keep]
                direction, rho = direction[:, keep], rho[keep]
            z = precondition(r)
            following = _column_dots(r, z)
            z += (following / rho) * direction
            direction, rho = z, following
        return None


class _GohbergSemencul:
    r"""The inverse of a symmetric positive definite Toeplitz matrix T (n×n) applied by FFT
    convolutions, from its first column :math:`x = T^{-1} e_1` (the Gohberg-Semencul formula):

    .. math:: T^{-1} = \frac{1}{x_1}\left(L(x) L(x)^\top - L(\tilde x) L(\tilde x)^\top
        \right), \qquad \tilde x = (0, x_n, x_{n-1}, \dots, x_2)

    with :math:`L(v)` the lower triangular Toeplitz matrix of first column v. Each of the four
    triangular products is a linear convolution (:math:`L^\top`: a correlation) of length
    n, by FFTs of at least 2n - 1 points: six transforms per application, whatever T's
    condition. Rounding in the formula grows with T's condition number, so it serves as the
    preconditioner of conjugate gradients, which remove that rounding in 2-3 iterations.

    References
    ----------
    I. C. Gohberg, A. A. Semencul, On the inversion of finite Toeplitz matrices and their
    continuous analogs, Mat. Issled. 7 (1972) 201-223; G. Heinig, K. Rost, *Algebraic Methods
    for Toeplitz-like Matrices and Operators*, Birkhäuser (1984), ch. 1.
    """

    def __init__(self, first_column: np.ndarray):
        n = first_column.size
        self.n, self.first = n, float(first_column[0])
        self.size = sp_fft.next_fast_len(2 * n - 1, real=True)
        shifted = np.zeros(n)
        shifted[1:] = first_column[:0:-1]
        self.spectra = (sp_fft.rfft(first_column, self.size), sp_fft.rfft(shifted, self.size))

    def apply(self, vectors: np.ndarray) -> np.ndarray:
        """:math:`T^{-1} v` for each column of ``vectors`` (n, k)."""
        n, size = self.n, self.size
        transformed = sp_fft.rfft(vectors, size, axis=0)
        total = None
        for spectrum in self.spectra:
            spectrum = spectrum[:, None]
            # L(v)ᵀ w: the correlation, the first n samples of ifft(conj(V) W)
            correlated = sp_fft.irfft(np.conj(spectrum) * transformed, size, axis=0)[:n]
            term = sp_fft.rfft(correlated, size, axis=0)
            term *= spectrum
            if total is None:
                total = term
            else:
                total -= term
        return sp_fft.irfft(total, size, axis=0, overwrite_x=True)[:n] / self.first


@functools.lru_cache(maxsize=2)
def _toeplitz_kernel(n: int, dt: float, length_scale_s: float, noise_ratio: float):
    """:class:`_ToeplitzKernel`, kept for the next call with the same record length and
    setting: the ends check solves its two probes and the record with one kernel, so the
    exact inverse's generator is solved once (its spectra are the same values whichever call
    computes them first)."""
    return _ToeplitzKernel(n, dt, length_scale_s, noise_ratio)


def _column_dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The dot product of each column of ``a`` with the same column of ``b`` (n, k)."""
    return np.einsum("ij,ij->j", a, b)


def posterior_derivatives(
    x: np.ndarray, dt: float, orders, length_scale_s: float, noise_ratio: float
) -> dict[int, np.ndarray]:
    r"""Derivatives of ``orders`` of the GP posterior mean at the samples ``x`` (time on axis 0;
    every column on its own).

    The prior mean is the record's least-squares straight line p(t); the residual is a
    zero-mean process with the RBF kernel (unit variance, length scale ℓ) observed in white
    noise of variance r² (``noise_ratio`` r: noise standard deviation over the prior's signal
    standard deviation; only their ratio changes the mean):

    .. math:: \alpha = (K + r^2 I)^{-1}(x - p), \qquad
        \hat x^{(n)}(t_i) = p^{(n)}(t_i) + \sum_j k^{(n)}(t_i - t_j)\,\alpha_j

    with :math:`K_{ij} = k(t_i - t_j)` and :math:`k^{(n)}` from :func:`rbf_covariance`. The
    whole record is solved at once (see the module docstring): no blocks. (The registered
    methods mask the end samples the ends check finds worse than twice the interior, see
    ``END_REACH_LENGTHS``.) Straight lines are reproduced exactly (their residual is zero).
    """
    n = x.shape[0]
    columns = x.reshape(n, -1)
    kernel = _toeplitz_kernel(n, float(dt), float(length_scale_s), float(noise_ratio))
    line, slope = _least_squares_line(columns, dt)
    alpha = kernel.solve(columns - line, overwrite_y=True)
    results = {}
    for order in orders:
        estimate = kernel.apply(alpha, order)
        if order == 0:
            estimate += line
        elif order == 1:
            estimate += slope
        results[order] = estimate
    return {order: value.reshape(x.shape) for order, value in results.items()}


def _least_squares_line_at(columns: np.ndarray, times: np.ndarray):
    """The least-squares line in time of each column of ``columns`` (n, channels) sampled at
    ``times``: values (n, channels) and slopes (channels,)."""
    centred = times - times.mean()
    mean = columns.mean(axis=0)
    slope = centred @ (columns - mean) / float(centred @ centred)
    return mean + np.outer(centred, slope), slope


BANDED_MAX_ENTRIES = 50_000_000
"""Most entries (400 MB) of the banded covariance :func:`posterior_derivatives_at` factors:
samples times the most samples within ``TRUNCATE`` length scales before one."""


def posterior_derivatives_at(
    x: np.ndarray, times: np.ndarray, orders, length_scale_s: float, noise_ratio: float
) -> dict[int, np.ndarray]:
    r""":func:`posterior_derivatives` at the irregular ``times`` (seconds, increasing): the
    same prior (the least-squares line in time, the RBF residual, white noise of ratio r) and
    the same posterior mean,

    .. math:: \alpha = (K + r^2 I)^{-1}(x - p), \qquad
        \hat x^{(n)}(t_i) = p^{(n)}(t_i) + \sum_j k^{(n)}(t_i - t_j)\,\alpha_j,
        \qquad K_{ij} = k(t_i - t_j),

    with K taken as banded: zero beyond ``TRUNCATE`` length scales (where k is below
    :math:`e^{-40.5}`, 2.6e-18, under rounding next to the diagonal's 1 + r²), so that K + r² I
    is factored by a banded Cholesky (``scipy.linalg.cholesky_banded``) in O(n b²) for b
    samples within reach. Raises ``ValueError`` naming ``t`` when the band would hold more than
    :data:`BANDED_MAX_ENTRIES` entries.

    Reference: Rasmussen & Williams (2006), sec. 2.2 and 9.4.
    """
    n = times.size
    columns = x.reshape(n, -1)
    reach = TRUNCATE * length_scale_s
    band = int(np.max(np.arange(n) - np.searchsorted(times, times - reach, side="left")))
    if (band + 1) * n > BANDED_MAX_ENTRIES:
        raise ValueError(
            f"`t` has {n} samples with up to {band} within {TRUNCATE:g} length scales "
            f"({reach!r} s) of one another: the banded covariance would hold {(band + 1) * n} "
            f"entries, more than {BANDED_MAX_ENTRIES}; use a shorter `length_scale_s` or split "
            "the record"
        )
    line, slope = _least_squares_line_at(columns, times)
    lower = np.zeros((band + 1, n))  # lower[d, j] = K[j + d, j]
    for d in range(band + 1):
        lower[d, : n - d] = rbf_covariance(times[d:] - times[: n - d], length_scale_s, 0)
    lower[0] += noise_ratio**2
    try:
        factor = cholesky_banded(lower, lower=True)
    except np.linalg.LinAlgError:
        raise ValueError(
            f"the covariance at these time stamps is singular to rounding for "
            f"length_scale_s={length_scale_s!r} s, noise_ratio={noise_ratio!r} (raise "
            "`noise_ratio`)"
        ) from None
    alpha = cho_solve_banded((factor, True), columns - line)
    results = {}
    for order in orders:
        estimate = rbf_covariance(0.0, length_scale_s, order) * alpha
        for d in range(1, band + 1):  # the d-th diagonals above and below
            estimate[d:] += (
                rbf_covariance(times[d:] - times[:-d], length_scale_s, order)[:, None] * alpha[:-d]
            )
            estimate[:-d] += (
                rbf_covariance(times[:-d] - times[d:], length_scale_s, order)[:, None] * alpha[d:]
            )
        if order == 0:
            estimate += line
        elif order == 1:
            estimate += slope
        results[order] = estimate.reshape(x.shape)
    return results


LIKELIHOOD_JITTER = 1e-10
"""Added to the diagonal of the likelihood's covariance matrix (scikit-learn's ``alpha``
default) so that its Cholesky factor exists when the fitted noise level is on its floor."""


@dataclass(frozen=True)
class MirroredTimes:
    r"""Sample times symmetric about their middle (:math:`t_i + t_{m-1-i}` the same for every
    i, as :func:`_fit_samples` lays them out), folded into the two halves on which a
    stationary covariance matrix falls apart.

    The reversal P (sample i to m-1-i) maps such times onto themselves, so P commutes with
    every matrix :math:`f(|t_i - t_j|)`: in the orthonormal basis of P's even vectors
    :math:`(e_i + e_{m-1-i})/\sqrt2` (and :math:`e_c`, the middle sample of an odd m) and odd
    vectors :math:`(e_i - e_{m-1-i})/\sqrt2`, i < h = ⌊m/2⌋, it is block diagonal with
    blocks :math:`M_\pm = M_{11} \pm M_{12}J` (:math:`M_{11}` the first half's block,
    :math:`M_{12}J` its block with the mirrored half; the even block bordered by
    :math:`\sqrt2` times the middle column, and its 1 on the diagonal, for odd m). With the
    offsets :math:`s_i = t_i - \bar t` of the first half, the squared lags are
    :math:`(s_i - s_j)^2` within a half and :math:`(s_i + s_j)^2` across (``lags``: the
    first and the second, bordered by :math:`s_i^2` for odd m; ``border``: the weights that
    make the bordered even block).

    Reference: A. Cantoni, P. Butler, "Eigenvalues and eigenvectors of symmetric
    centrosymmetric matrices", Linear Algebra Appl. 13 (1976) 275-288.
    """

    lags: tuple[np.ndarray, np.ndarray]
    border: np.ndarray | None
    half: int

    @classmethod
    def of(cls, times_s) -> MirroredTimes:
        t = np.asarray(times_s, dtype=float)
        m, half = t.size, t.size // 2
        centre = (t[0] + t[-1]) / 2
        span = max(t[-1] - t[0], np.finfo(float).tiny)
        if m < 2 or np.any(np.abs(t + t[::-1] - 2 * centre) > 1e-9 * span):
            raise ValueError(
                "`times_s` must hold at least 2 times symmetric about their middle (t_i + "
                "t_{m-1-i} the same for every i), as fit_hyperparameters' samples are"
            )
        offsets = np.r_[t[:half] - centre, np.zeros(m % 2)]  # the middle sample, for odd m
        within = np.subtract.outer(offsets, offsets) ** 2
        across = np.add.outer(offsets, offsets) ** 2
        border = None
        if m % 2:  # the middle sample (s_c = 0) has the same lags either way
            border = np.ones((half + 1, half + 1))
            border[-1, :] = border[:, -1] = 1 / math.sqrt(2)
            border[-1, -1] = 0.5
        for lag in (within, across):
            lag.setflags(write=False)
        return cls((within, across), border, half)

    def fold(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The even and odd coordinates of ``y`` (length m) in the folded basis."""
        y = np.asarray(y, dtype=float)
        h = self.half
        mirrored = y[::-1][:h]
        even = (y[:h] + mirrored) / math.sqrt(2)
        if self.border is not None:
            even = np.r_[even, y[h]]
        return even, (y[:h] - mirrored) / math.sqrt(2)


def rbf_log_marginal_likelihood(
    log_params: np.ndarray, times_s: np.ndarray, y: np.ndarray
) -> tuple[float, np.ndarray]:
    r"""The log marginal likelihood of ``y`` observed at ``times_s`` (symmetric about their
    middle, see :class:`MirroredTimes`) under an RBF process plus white noise, and its
    gradient in the log-hyperparameters ``log_params`` = (log σ_f², log ℓ, log σ_n²).

    With :math:`E_{ij} = e^{-D_{ij}/(2\ell^2)}`, :math:`D_{ij} = (t_i - t_j)^2`,
    :math:`K = \sigma_f^2 E + (\sigma_n^2 + \epsilon) I` (ε = ``LIKELIHOOD_JITTER``) and
    :math:`\alpha = K^{-1}y`:

    .. math:: \log p(y) = -\tfrac12 y^\top\alpha - \tfrac12\log\lvert K\rvert
        - \tfrac m2 \log 2\pi, \qquad \frac{\partial \log p}{\partial \theta_k} = \tfrac12
        \sum_{ij} W_{ij} \frac{\partial K_{ij}}{\partial \theta_k}, \quad
        W = \alpha\alpha^\top - K^{-1}

    with :math:`\partial K/\partial\log\sigma_f^2 = \sigma_f^2 E`,
    :math:`\partial K/\partial\log\ell = \sigma_f^2 E \circ D/\ell^2` and
    :math:`\partial K/\partial\log\sigma_n^2 = \sigma_n^2 I`. All of them are block diagonal
    in the folded basis (:class:`MirroredTimes`), so every term is the sum of its two blocks',
    each from the Cholesky factor of its block of K (LAPACK ``potrf``, ``potrs``, ``potri``):
    two factorisations of m/2 rows instead of one of m, a quarter of the work. The value is
    -inf (gradient zero) where K is not numerically positive definite.

    scikit-learn's ``GaussianProcessRegressor.log_marginal_likelihood`` with the kernel
    ``ConstantKernel * RBF + WhiteKernel`` computes the same with the whole matrices (its
    test oracle, to rounding: within about eps times the condition number of K).

    Reference: Rasmussen & Williams (2006), sec. 5.4.1, eqs. (5.8)-(5.9).
    """
    mirrored = MirroredTimes.of(times_s)
    return _folded_likelihood(log_params, mirrored, *mirrored.fold(y))


def _folded_likelihood(log_params, mirrored: MirroredTimes, *folded_y) -> tuple[float, np.ndarray]:
    """:func:`rbf_log_marginal_likelihood` from the folded times and the folded ``y``."""
    signal_variance, length_scale_s, noise_variance = np.exp(log_params)
    scale = -0.5 / length_scale_s**2
    within, across = mirrored.lags
    near, far = np.exp(within * scale), np.exp(across * scale)  # e^{-D/2ℓ²}, both halves
    near_lag, far_lag = near * within, far * across  # E∘D
    h, border = mirrored.half, mirrored.border
    even = (near + far, near_lag + far_lag)
    if border is not None:
        even = (even[0] * border, even[1] * border)
    blocks = (even, (near[:h, :h] - far[:h, :h], near_lag[:h, :h] - far_lag[:h, :h]))
    value = -(h + len(folded_y[0])) / 2 * math.log(2 * math.pi)
    sums = np.zeros(3)
    for (correlation, correlation_lag), y in zip(blocks, folded_y, strict=True):
        size = y.shape[0]  # both blocks hold at least one row: MirroredTimes has m >= 2
        covariance = signal_variance * correlation
        covariance.flat[:: size + 1] += noise_variance + LIKELIHOOD_JITTER
        factor, info = lapack.dpotrf(covariance, lower=1, clean=1, overwrite_a=1)
        if info:
            return -math.inf, np.zeros(3)
        alpha, _ = lapack.dpotrs(factor, y, lower=1)
        value -= 0.5 * float(y @ alpha) + float(np.log(factor.diagonal()).sum())
        inverse, _ = lapack.dpotri(factor, lower=1, overwrite_c=1)  # its lower triangle
        diagonal = inverse.diagonal().copy()
        inverse += inverse.T  # the whole symmetric inverse (the upper triangle was zero)
        inverse.flat[:: size + 1] = diagonal
        weights = np.outer(alpha, alpha)
        weights -= inverse
        sums += (
            float(np.vdot(weights, correlation)),
            float(np.vdot(weights, correlation_lag)),
            float(alpha @ alpha - diagonal.sum()),
        )
    gradient = 0.5 * sums * (signal_variance, signal_variance / length_scale_s**2, noise_variance)
    return value, gradient


def likelihood_optimum(
    times_s: np.ndarray, y: np.ndarray, start: np.ndarray, bounds: np.ndarray
) -> optimize.OptimizeResult:
    r"""The log-hyperparameters θ = (log σ_f², log ℓ, log σ_n²) in ``bounds`` (3, 2) that
    maximise :func:`rbf_log_marginal_likelihood` of ``y`` observed at ``times_s``: scipy's
    L-BFGS-B on −log p from ``start`` and from ``FIT_RESTARTS`` starts drawn uniformly in
    ``bounds`` by ``RandomState(0)``; the best of the optima (its ``x``, and ``fun`` = −log p).

    This is scikit-learn's ``GaussianProcessRegressor(ConstantKernel * RBF + WhiteKernel,
    alpha=1e-10, n_restarts_optimizer=FIT_RESTARTS, random_state=0).fit`` step for step (its
    test oracle), with a likelihood about 6 times cheaper at 400 samples (2.9 against 18 ms).
    """
    from threadpoolctl import threadpool_limits  # a dependency of scikit-learn

    mirrored = MirroredTimes.of(times_s)
    folded = mirrored.fold(y)
    draws = np.random.RandomState(0)
    starts = [start] + [draws.uniform(bounds[:, 0], bounds[:, 1]) for _ in range(FIT_RESTARTS)]

    def negative(log_params):
        value, gradient = _folded_likelihood(log_params, mirrored, *folded)
        return -value, -gradient

    # One BLAS thread: factorisations of a few hundred rows gain nothing from threads, and
    # numpy's and scipy's two OpenBLAS copies spinning against each other made each one 20
    # times slower on a shared 2-core machine (measured: 0.13 s against 7 ms at 600 rows).
    with threadpool_limits(limits=1):
        optima = [
            optimize.minimize(negative, start, method="L-BFGS-B", jac=True, bounds=bounds)
            for start in starts
        ]
    return min(optima, key=lambda result: result.fun)


def fit_hyperparameters(x, dt: float, fit_samples: int = 400) -> tuple[float, float, float] | None:
    r"""The length scale (s), noise ratio and noise standard deviation that maximise the
    marginal likelihood of the 1-D record ``x`` less its least-squares line, or None for a
    straight line (nothing to fit).

    The model is an RBF process (signal variance σ_f², length scale ℓ) plus white noise
    (variance σ_n²), fitted to the residual scaled to unit RMS on at most ``fit_samples``
    samples (see ``FIT_SAMPLES``): L-BFGS-B (scipy) maximises
    :func:`rbf_log_marginal_likelihood`

    .. math:: \log p(y \mid \theta) = -\tfrac12 y^\top (K_\theta + \sigma_n^2 I)^{-1} y
        - \tfrac12 \log\lvert K_\theta + \sigma_n^2 I\rvert - \tfrac m2 \log 2\pi

    over θ = (log σ_f², log ℓ, log σ_n²) from (0, log min(10 Δt, span/2), log 0.1) and from
    seeded restarts (:func:`likelihood_optimum`, scikit-learn's fit step for step).
    An optimum on a bound is expected (noise-free data put the noise level on its floor) and
    is clipped below.
    Bounds: ℓ in [Δt, record span], σ_f² in [1e-2, 1e2], σ_n² in [1e-8, 10] (of the scaled
    residual); the noise ratio σ_n/σ_f is clipped to [1e-3, 1e3].

    Reference: Rasmussen & Williams (2006), sec. 5.4.1.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    line, _ = _least_squares_line(x, dt)
    residual = x - line
    scale = float(np.sqrt(np.mean(residual**2)))
    if not scale > STRAIGHT * float(np.sqrt(np.mean(x**2))):
        return None
    samples = _fit_samples(n, fit_samples)
    span = max(2 * dt, (n - 1) * dt)
    bounds = np.log([(1e-2, 1e2), (dt, span), (1e-8, 10.0)])
    start = np.log([1.0, min(10 * dt, span / 2), 0.1])
    best = likelihood_optimum(samples * dt, residual[samples] / scale, start, bounds)
    signal_variance, length_scale_s, noise_variance = (float(v) for v in np.exp(best.x))
    ratio = float(
        np.clip(math.sqrt(noise_variance / signal_variance), MIN_NOISE_RATIO, MAX_NOISE_RATIO)
    )
    return length_scale_s, ratio, math.sqrt(noise_variance) * scale


def _fit_samples(n: int, most: int) -> np.ndarray:
    """Indices of the samples the likelihood sees: all, or ``FIT_SEGMENTS`` evenly spread
    contiguous segments (laid out symmetrically about the record's middle)."""
    if n <= most:
        return np.arange(n)
    length = most // FIT_SEGMENTS
    starts = np.linspace(0, n - length, FIT_SEGMENTS)
    starts = np.where(starts <= (n - length) / 2, np.floor(starts), np.ceil(starts))
    return np.concatenate([np.arange(int(s), int(s) + length) for s in starts])


def _check_length_scale(length_scale_s: float, dt: float) -> None:
    if not dt <= length_scale_s <= MAX_LENGTH_STEPS * dt:
        raise ValueError(
            f"`length_scale_s` must be in [{dt!r}, {MAX_LENGTH_STEPS * dt:g}] s at dt={dt!r} s "
            f"(one sampling step to {MAX_LENGTH_STEPS:g} steps), got {length_scale_s!r}"
        )


@register("gaussian_process")
class GaussianProcess(Method):
    r"""Gaussian-process regression with an RBF kernel and given hyperparameters; the
    derivatives are those of the posterior mean, from the kernel's analytic derivatives (see
    :func:`posterior_derivatives`, :func:`rbf_covariance`).

    The prior mean is the least-squares line of the record, so straight lines are reproduced
    exactly at every order (exact degree 1). Every sample is estimated (the process
    extrapolates smoothly to the ends). Linear in the input and time-symmetric. Away from the
    ends it is the Wiener filter :func:`gaussian_process_response`,
    :math:`S/(S + r^2\Delta t)` times :math:`(i2\pi f)^n`, plus
    :math:`(1 - H_0(0))` times the record's least-squares line (order 0; its slope for
    order 1): the line is taken out before a filter whose gain at 0 Hz is below one.

    Time stamps (``t=``) are handled natively: the same posterior mean with the covariance of
    the actual times (:func:`posterior_derivatives_at`), the ends trusted over the spans of
    time the uniform record of the mean step trusts.

    Parameters
    ----------
    length_scale_s : float in [Δt, 1e6 Δt]
        Length scale ℓ of the kernel :math:`e^{-(t-t')^2/(2\ell^2)}`, seconds.
    noise_ratio : float in [1e-3, 1e3]
        r = σ_n/σ_f, noise standard deviation over the prior's signal standard deviation.

    References
    ----------
    Rasmussen & Williams, *Gaussian Processes for Machine Learning*, MIT Press (2006), sec. 2.2
    and 9.4; Solak et al., NIPS 15 (2003).
    """

    length_scale_s: float = param(
        0.01,
        low=0.0,
        low_open=True,
        tune_low=0.002,
        tune_high=0.3,
        log=True,
        doc="length scale of the RBF kernel, s (in [dt, 1e6 dt])",
        kind="duration",
    )
    noise_ratio: float = param(
        0.1,
        low=MIN_NOISE_RATIO,
        high=MAX_NOISE_RATIO,
        tune_low=0.003,
        tune_high=10.0,
        log=True,
        doc="noise std / prior signal std (dimensionless)",
    )
    presets = {
        "paper-signal": Preset(
            {"length_scale_s": 0.046, "noise_ratio": 0.006},
            "diffbench, not in the paper: least interior ẍ RMSE on the held-out noise seed "
            "10000 over length scales with noise_ratio >= 0.006 (236 against 233 at the oracle's "
            "0.004, where rounding breaks linearity at 1e-9)",
        ),
        "robot": Preset(
            {"length_scale_s": 0.13, "noise_ratio": 0.1},
            "diffbench, not in the paper: half gain at 4.9-5.4 Hz for dt = 2-10 ms, near the "
            "cutoff of the paper's Butterworth (0.1 fs/2, sec. IV)",
        ),
    }
    reference = "Rasmussen & Williams (2006)"
    time_stamps = "native"

    def check_step(self, dt: float) -> None:
        _check_length_scale(self.length_scale_s, dt)

    def min_samples(self, dt: float) -> int:
        return 3

    def end_reach(self, dt: float) -> int | None:
        return math.ceil(END_REACH_LENGTHS * self.length_scale_s / dt)

    def exact_degree(self, order: int) -> float | None:
        return 1

    def _response(self, frequency_hz, dt: float, order: int) -> np.ndarray:
        return gaussian_process_response(
            frequency_hz, dt, self.length_scale_s, self.noise_ratio, order
        )

    def _estimate(self, x, dt, orders):
        values = posterior_derivatives(x, dt, orders, self.length_scale_s, self.noise_ratio)
        valid = {order: np.ones(x.shape[0], dtype=bool) for order in orders}
        return values, valid

    def _estimate_at(self, x, times, orders):
        values = posterior_derivatives_at(x, times, orders, self.length_scale_s, self.noise_ratio)
        # the ends trusted over the spans of time the uniform record of the mean step trusts
        return values, trusted_times(self, times, mean_step(times), orders)


@register("gaussian_process_ml")
class GaussianProcessMarginalLikelihood(Method):
    r"""Gaussian-process regression whose hyperparameters the data choose: the length scale and
    noise ratio of ``gaussian_process`` maximising the marginal likelihood of each channel
    (:func:`fit_hyperparameters`, type-II maximum likelihood). It needs no truth and nothing
    to set but ``fit_samples``, which trades the fit's cost for its precision. The fitted
    length scale and noise ratio are rounded to a 1 % grid (``FIT_GRID``) so that the estimate
    does not move with the BLAS kernel's rounding of the flat likelihood's optimum.

    Not linear (the hyperparameters depend on the input). Straight lines are reproduced
    exactly (exact degree 1). The ends are checked as ``gaussian_process``'s are, at the fitted
    hyperparameters (the posterior mean is linear once they are fixed), with the factor
    ``FITTED_END_ERROR_FACTOR``; a record shorter than the check's reach (a smooth short record,
    whose fitted length scale nears its span) keeps the samples within that factor of its own
    middle sample. With several channels a sample is valid where it is for every channel.
    Time-symmetric: the likelihood runs on the record in a canonical direction (the
    lexicographically smaller of x and its reverse), so that reversing time reverses the
    estimate to rounding rather than to the optimiser's tolerance. Each call costs
    the fit (about 0.08 s per channel at ``fit_samples`` = 400) plus the posterior mean.

    Time stamps (``t=``): the hyperparameters are fitted on the record resampled to its grid
    (the likelihood's layout needs uniform times), the posterior mean taken at the stamps
    themselves (:func:`posterior_derivatives_at`). With 30 % of the samples dropped at 5 ms
    (the paper's signal, noise 0.01, 10 seeds, interior) ẋ 0.66 and ẍ 93 against 1.47 and
    184 resampled throughout; with ±45 % jitter 9-10 % better.

    Parameters
    ----------
    fit_samples : {200, 400, 800}
        Most samples the likelihood sees (``FIT_SAMPLES``).

    References
    ----------
    Rasmussen & Williams, *Gaussian Processes for Machine Learning*, MIT Press (2006),
    sec. 5.4.1; scikit-learn's ``GaussianProcessRegressor``.
    """

    fit_samples: int = param(
        400,
        choices=FIT_SAMPLES,
        integer=True,
        doc="most samples the marginal likelihood sees (cost, not smoothing)",
        untuned="trades the fit's cost for its precision, not a smoothing: a tuner would "
        "pick the slowest",
    )
    presets = {
        "paper-signal": Preset(
            {"fit_samples": 400},
            "data only: the marginal likelihood chooses the smoothing; 400 samples, a 0.08 s fit",
        ),
    }
    reference = "Rasmussen & Williams (2006)"
    linear = False
    time_stamps = "native"

    def min_samples(self, dt: float) -> int:
        return 3

    def exact_degree(self, order: int) -> float | None:
        return 1

    def _estimate(self, x, dt, orders):
        def posterior(column, length_scale_s, ratio):
            return posterior_derivatives(column, dt, orders, length_scale_s, ratio)

        def line(column):
            return _least_squares_line(column, dt)

        def trusted(at_fit):
            return trusted_samples(
                at_fit, x.shape[0], dt, orders, FITTED_END_ERROR_FACTOR, short_record_middle=True
            )

        return self._fitted(x, orders, dt, lambda column: column, posterior, line, trusted)

    def _estimate_at(self, x, times, orders):
        """At irregular ``times``: each channel's hyperparameters fitted on the channel
        resampled to the grid a resampled method would use (the likelihood's sample layout
        needs uniform times), then the posterior mean at the stamps themselves
        (:func:`posterior_derivatives_at`), its ends trusted as the fitted
        ``gaussian_process``'s at the mean step."""
        grid, grid_step = uniform_grid(times)

        def posterior(column, length_scale_s, ratio):
            return posterior_derivatives_at(column, times, orders, length_scale_s, ratio)

        def line(column):
            values, slope = _least_squares_line_at(column[:, None], times)
            return values[:, 0], float(slope[0])

        def trusted(at_fit):
            return trusted_times(
                at_fit,
                times,
                mean_step(times),
                orders,
                factor=FITTED_END_ERROR_FACTOR,
                short_record_middle=True,
            )

        def on_grid(column):
            return to_grid(column, times, grid)

        return self._fitted(x, orders, grid_step, on_grid, posterior, line, trusted)

    def _fitted(self, x, orders, fit_step, on_grid, posterior, line, trusted):
        """The estimate of either path: per channel, the hyperparameters the likelihood picks
        on ``on_grid(channel)`` (step ``fit_step``), snapped to the 1 % grid, then
        ``posterior(channel, length_scale_s, noise_ratio)`` (or, for a straight line, ``line``:
        its values and slope), valid where ``trusted(the fitted gaussian_process)`` says, for
        every channel."""
        n = x.shape[0]
        columns = x.reshape(n, -1)
        values = {order: np.empty_like(columns) for order in orders}
        valid = {order: np.ones(n, dtype=bool) for order in orders}
        for index in range(columns.shape[1]):
            column = columns[:, index]
            fitted = fit_hyperparameters(_canonical(on_grid(column)), fit_step, self.fit_samples)
            if fitted is None:
                values_of_line, slope = line(column)
                estimate = {0: values_of_line, 1: np.full(n, slope), 2: np.zeros(n)}
            else:
                # the grid in steps, so that a record's estimate scales with its step exactly
                scaled = snap_to_grid(fitted[0] / fit_step, 1.0, max(2.0, n - 1.0))
                length_scale_s = fit_step * scaled
                ratio = snap_to_grid(fitted[1], MIN_NOISE_RATIO, MAX_NOISE_RATIO)
                estimate = posterior(column, length_scale_s, ratio)
                at_fit = GaussianProcess(length_scale_s=length_scale_s, noise_ratio=ratio)
                for order, mask in trusted(at_fit).items():
                    valid[order] &= mask
            for order in orders:
                values[order][:, index] = estimate[order]
        for order in orders:
            if not valid[order].any():
                raise ValueError(
                    f"`x` has {n} samples on axis 0: too short for {self.name} to give any "
                    f"estimate of order {order} within its own accuracy at the length scales "
                    "its channels fit; use a longer record, or gaussian_process with settings "
                    "of a shorter reach"
                )
        values = {order: value.reshape(x.shape) for order, value in values.items()}
        return values, valid


def snap_to_grid(value: float, low: float, high: float, step: float = FIT_GRID) -> float:
    r"""``value`` > 0 rounded to the nearest :math:`e^{k\,\mathrm{step}}` (k whole), then
    clipped to [``low``, ``high``]: e.g. ``snap_to_grid(0.0123, 1e-3, 1.0)`` is
    :math:`e^{-4.40}` = 0.012277."""
    return float(np.clip(math.exp(step * round(math.log(value) / step)), low, high))


def _canonical(x: np.ndarray) -> np.ndarray:
    """``x`` or its reverse, whichever is lexicographically smaller (the same array for both)."""
    difference = x - x[::-1]
    differing = np.flatnonzero(difference)
    if differing.size and difference[differing[0]] > 0:
        return x[::-1]
    return x
