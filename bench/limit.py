"""How close to the optimum: the exact optimal estimator of a Gauss–Markov signal
(:mod:`diffbench.signals.stochastic`), which reaches the bound, for the Monte Carlo that checks
the bound and for efficiencies.

The optimal estimate of the state from every sample is the Rauch–Tung–Striebel smoother with
the true model (and from the samples up to t, the Kalman filter). Its gains do not depend on
the data, so many realisations (columns) are filtered at once.

References: H. E. Rauch, F. Tung, C. T. Striebel, "Maximum likelihood estimates of linear
dynamic systems", AIAA J. 3 (1965); Anderson & Moore, *Optimal Filtering* (1979), ch. 7.
"""

from __future__ import annotations

import numpy as np

from diffbench.signals.stochastic import GaussMarkov


def optimal_states(
    signal: GaussMarkov, dt: float, noise_std: float, y: np.ndarray, causal: bool = False
) -> np.ndarray:
    r"""The posterior mean of the state :math:`(x, \dot x, \dots)` at every sample of each
    column of ``y`` (shape ``(n,)`` or ``(n, realisations)``, samples every ``dt`` of
    ``signal`` in white noise of standard deviation ``noise_std``) given every sample (the
    RTS smoother) or, ``causal``, the samples up to each one (the Kalman filter).

    The prior is the signal's own: its stationary law, or for an integrated white noise the
    state known to be 0 at the first sample. Returns shape ``(n, states)`` or
    ``(n, states, realisations)``."""
    y = np.asarray(y, dtype=float)
    columns = y.reshape(y.shape[0], -1)
    n, count = columns.shape
    model = signal.model()
    A, Q = model.discretise(dt)
    states = A.shape[0]
    variance = noise_std**2
    prior_mean = np.zeros((states, count))
    prior = model.stationary_covariance() if model.stationary else np.zeros((states, states))
    means = np.empty((n, states, count))
    covariances = np.empty((n, states, states))
    predicted_covariances = np.empty((n, states, states))
    mean, covariance = prior_mean, prior
    for j in range(n):
        if j:
            mean = A @ mean
            covariance = A @ covariance @ A.T + Q
        predicted_covariances[j] = covariance
        gain = covariance[:, 0] / (covariance[0, 0] + variance)
        mean = mean + np.outer(gain, columns[j] - mean[0])
        covariance = covariance - np.outer(gain, covariance[0])
        means[j], covariances[j] = mean, covariance
    if not causal:
        smoothed = means[-1]
        for j in range(n - 2, -1, -1):
            smoother = covariances[j] @ A.T @ np.linalg.inv(predicted_covariances[j + 1])
            smoothed = means[j] + smoother @ (smoothed - A @ means[j])
            means[j] = smoothed
    return means[:, :, 0] if y.ndim == 1 else means
