"""IDIM-LS: robot dynamic identification from an inverse dynamic model and least squares,
with the velocities and accelerations estimated by any registered differentiator.

Gautier's procedure as Guo et al. (AIM 2015, sec. II.B and IV) use it: estimate q̇, q̈ (and the
filtered q) from the measured q; build the observation matrix W = [D(1); ...; D(n)] and the
torque vector Y; apply the same parallel decimation (zero-phase low-pass F_p, then keep one
sample in ``factor``) to Y and to every column of W; solve W X = Y by least squares (QR);
σ_ρ² = ‖Y − W X̂‖² / (r − c), C = σ_ρ² (WᵀW)⁻¹, σ_X = sqrt(diag C), %σ_Xr = 100 σ_X / |X̂|.

What is printed as σ here is one standard deviation. (The paper's table II column "σ" is about
2σ: 0.032 / 3.496 = 0.92 % while its %σ_Xr reads 0.46 %.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg
from scipy import signal as sps

CONDITION_LIMIT = 1e8


@dataclass(frozen=True)
class Identification:
    """Result of IDIM-LS: X̂, one-sigma σ_X, %σ_Xr, σ_ρ, C, cond(W), equations r."""

    names: tuple[str, ...]
    estimate: np.ndarray
    sigma: np.ndarray
    relative_sigma_pct: np.ndarray
    sigma_rho: float
    covariance: np.ndarray
    condition: float
    equations: int


def decimation_factor(sample_hz: float, passband_hz: float) -> int:
    """The largest factor whose anti-aliasing filter (scipy's Chebyshev I, cutoff 0.8 of the new
    Nyquist frequency) still passes ``passband_hz``: floor(0.8 fs / (2 F_p)), at least 1."""
    if not (passband_hz > 0 and sample_hz > 0):
        raise ValueError(
            f"`passband_hz` and `sample_hz` must be > 0, got {passband_hz}, {sample_hz}"
        )
    return max(1, math.floor(0.8 * sample_hz / (2 * passband_hz)))


def parallel_decimation(values: np.ndarray, factor: int) -> np.ndarray:
    """Zero-phase low-pass and downsampling along axis 0, the same for every column:
    ``scipy.signal.decimate(values, factor, ftype="iir", zero_phase=True, axis=0)`` (an
    order-8 Chebyshev I filter run forward and backward, then every ``factor``-th sample)."""
    if factor == 1:
        return np.asarray(values, dtype=float)
    return sps.decimate(values, factor, ftype="iir", zero_phase=True, axis=0)


def idim_ls(
    observation: np.ndarray,
    torques: np.ndarray,
    names: tuple[str, ...],
    factor: int = 1,
    edge_samples: int = 0,
) -> Identification:
    """Least-squares identification from W (n, joints, p) and Y (n, joints).

    Y and every column of W are decimated by ``factor`` together (:func:`parallel_decimation`);
    ``edge_samples`` decimated samples are then dropped at each end (filter start-up). Raises
    ``ValueError`` on mismatched shapes, NaN/inf rows, too few equations, or a W whose
    condition number exceeds 1e8 (the trajectory does not excite every parameter).
    """
    observation = np.asarray(observation, dtype=float)
    torques = np.asarray(torques, dtype=float)
    if observation.ndim != 3 or torques.ndim != 2:
        raise ValueError(
            f"`observation` must be (n, joints, parameters) and `torques` (n, joints), got "
            f"{observation.shape} and {torques.shape}"
        )
    if observation.shape[:2] != torques.shape:
        raise ValueError(
            f"`observation` {observation.shape[:2]} and `torques` {torques.shape} must have the "
            "same samples and joints (mismatched lengths of q and tau?)"
        )
    if observation.shape[2] != len(names):
        raise ValueError(f"`names` has {len(names)} entries for {observation.shape[2]} columns")
    bad = ~np.isfinite(observation).all(axis=(1, 2)) | ~np.isfinite(torques).all(axis=1)
    if bad.any():
        raise ValueError(
            f"{int(bad.sum())} rows of W or Y hold NaN or inf (first at sample "
            f"{int(np.argmax(bad))}); drop the samples a differentiator did not estimate"
        )
    w = parallel_decimation(observation, factor)
    y = parallel_decimation(torques, factor)
    if edge_samples:
        w, y = w[edge_samples:-edge_samples], y[edge_samples:-edge_samples]
    w = w.reshape(-1, len(names))
    y = y.reshape(-1)
    rows, columns = w.shape
    if rows <= columns:
        raise ValueError(f"{rows} equations for {columns} parameters: record a longer motion")
    condition = float(np.linalg.cond(w))
    if not condition < CONDITION_LIMIT:
        raise ValueError(
            f"the observation matrix is rank deficient: cond(W) = {condition:.3g} > "
            f"{CONDITION_LIMIT:g}; the trajectory does not excite every parameter"
        )
    q, r = linalg.qr(w, mode="economic")
    estimate = linalg.solve_triangular(r, q.T @ y)
    residual = y - w @ estimate
    sigma_rho2 = float(residual @ residual) / (rows - columns)
    r_inverse = linalg.solve_triangular(r, np.eye(columns))
    covariance = sigma_rho2 * (r_inverse @ r_inverse.T)
    sigma = np.sqrt(np.diag(covariance))
    with np.errstate(divide="ignore"):
        relative = 100 * sigma / np.abs(estimate)
    return Identification(
        names=tuple(names),
        estimate=estimate,
        sigma=sigma,
        relative_sigma_pct=relative,
        sigma_rho=math.sqrt(sigma_rho2),
        covariance=covariance,
        condition=condition,
        equations=rows,
    )
