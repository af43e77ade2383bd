"""A synthetic design-A.0-like double pendulum with known parameters, its exact motion and
torques, written as the DFKI lab writes its records and models (for the robot-model tests).

The robot: the lab's design A.0 geometry (l1 = r1 = 0.3 m, l2 = 0.2 m; its published
model_2.0 masses, inertias, gear ratio and rotor inertia) with larger, distinct friction, so
that every base parameter is well away from zero. The motion is a sum of sines per joint
(known q, q̇, q̈ in closed form); the torques follow from the lab's equations of motion
(τ = M q̈ + C q̇ − G + F, written out here independently of ``diffbench.signals.dfki``) plus
seeded white noise of ``TORQUE_NOISE_NM`` standard deviation. Positions are written with 17
significant digits (exact to rounding: no encoder quantisation), time stamps uniform at 2 ms.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

DESIGN_A_PARAMETERS = {
    "I1": 0.053470810264216295,
    "I2": 0.02392374528789766,
    "Ir": 7.659297952841183e-05,
    "b1": 0.02,
    "b2": 0.012,
    "cf1": 0.09,
    "cf2": 0.07,
    "g": 9.81,
    "gr": 6.0,
    "l1": 0.3,
    "l2": 0.2,
    "m1": 0.5593806151425046,
    "m2": 0.6043459469186889,
    "r1": 0.3,
    "r2": 0.18377686083653508,
    "tl1": 10.0,
    "tl2": 10.0,
}
"""The synthetic robot's physical parameters (the lab's design A.0 model_2.0 but friction)."""

TORQUE_NOISE_NM = 0.02
STEP_S = 0.002
COULOMB_SLOPE = 100.0


def true_base_parameters(p=DESIGN_A_PARAMETERS) -> np.ndarray:
    """X = [A1 .. A6, b1, cf1, b2, cf2] written out (module docstring of signals/dfki.py)."""
    return np.array(
        [
            p["I1"] + p["I2"] + p["m2"] * p["l1"] ** 2 + (p["gr"] ** 2 + 1) * p["Ir"],
            p["I2"] + p["gr"] ** 2 * p["Ir"],
            p["I2"] - p["gr"] * p["Ir"],
            p["m2"] * p["l1"] * p["r2"],
            p["g"] * (p["m1"] * p["r1"] + p["m2"] * p["l1"]),
            p["g"] * p["m2"] * p["r2"],
            p["b1"],
            p["cf1"],
            p["b2"],
            p["cf2"],
        ]
    )


def inverse_dynamics(q, qd, qdd, p=DESIGN_A_PARAMETERS) -> np.ndarray:
    """τ = M(q) q̈ + C(q, q̇) q̇ − G(q) + F(q̇), the lab's equations, sample by sample."""
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    s1, s12 = np.sin(q[:, 0]), np.sin(q[:, 0] + q[:, 1])
    k = p["m2"] * p["l1"] * p["r2"]
    m11 = p["I1"] + p["I2"] + p["m2"] * p["l1"] ** 2 + 2 * k * c2 + (p["gr"] ** 2 + 1) * p["Ir"]
    m12 = p["I2"] + k * c2 - p["gr"] * p["Ir"]
    m22 = p["I2"] + p["gr"] ** 2 * p["Ir"]
    coriolis1 = -k * s2 * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2)
    coriolis2 = k * s2 * qd[:, 0] ** 2
    gravity1 = (
        p["g"] * (p["m1"] * p["r1"] + p["m2"] * p["l1"]) * s1 + p["g"] * p["m2"] * p["r2"] * s12
    )
    gravity2 = p["g"] * p["m2"] * p["r2"] * s12
    friction = np.array([p["b1"], p["b2"]]) * qd + np.array([p["cf1"], p["cf2"]]) * np.arctan(
        COULOMB_SLOPE * qd
    )
    tau = np.empty_like(q)
    tau[:, 0] = m11 * qdd[:, 0] + m12 * qdd[:, 1] + coriolis1 + gravity1
    tau[:, 1] = m12 * qdd[:, 0] + m22 * qdd[:, 1] + coriolis2 + gravity2
    return tau + friction


@dataclass(frozen=True)
class SyntheticRecord:
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau_exact: np.ndarray
    tau: np.ndarray  # with noise


def motion(seed: int, duration_s: float = 8.0, p=DESIGN_A_PARAMETERS) -> SyntheticRecord:
    """Sums of four sines per joint (0.15-1.2 Hz, random phases from ``seed``); joint 1
    swings about ±1.6 rad, joint 2 about ±2 rad."""
    rng = np.random.default_rng(seed)
    t = STEP_S * np.arange(round(duration_s / STEP_S) + 1)
    q, qd, qdd = (np.zeros((t.size, 2)) for _ in range(3))
    for joint, amplitude in ((0, 0.4), (1, 0.5)):
        for frequency_hz in (0.15, 0.35, 0.7, 1.2):
            omega = 2 * np.pi * frequency_hz * rng.uniform(0.9, 1.1)
            phase = rng.uniform(0, 2 * np.pi)
            q[:, joint] += amplitude * np.sin(omega * t + phase)
            qd[:, joint] += amplitude * omega * np.cos(omega * t + phase)
            qdd[:, joint] -= amplitude * omega**2 * np.sin(omega * t + phase)
    exact = inverse_dynamics(q, qd, qdd, p)
    noisy = exact + TORQUE_NOISE_NM * rng.standard_normal(exact.shape)
    return SyntheticRecord(t=t, q=q, qd=qd, qdd=qdd, tau_exact=exact, tau=noisy)


def write_record(path: Path, record: SyntheticRecord) -> Path:
    """The lab's CSV layout (its column names, velocity columns included, other order)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    header = "time,pos_meas1,pos_meas2,vel_meas1,vel_meas2,tau_con1,tau_con2,tau_meas1,tau_meas2"
    columns = np.column_stack([record.t, record.q, record.qd, record.tau_exact, record.tau])
    lines = [",".join(f"{v:.17g}" for v in row) for row in columns]
    path.write_text(header + "\n" + "\n".join(lines) + "\n")
    return path


def write_model(path: Path, p=DESIGN_A_PARAMETERS) -> Path:
    """``key: number`` lines, as the lab's model_parameters.yml."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(f"{key}: {value!r}\n" for key, value in sorted(p.items())))
    return path


def lab_tree(root: Path, seeds=(1, 2, 3), duration_s: float = 8.0):
    """Records and model where the lab's repository keeps them: ``(records, model, motions)``
    with records under ``data/experiment_records/design_A.0/20990101/sys_id/`` and the model
    at ``data/system_identification/identified_parameters/design_A.0/model_9.0/``."""
    folder = root / "data" / "experiment_records" / "design_A.0" / "20990101" / "sys_id"
    motions = [motion(seed, duration_s) for seed in seeds]
    records = [write_record(folder / f"trajectory_{k:02d}.csv", m) for k, m in enumerate(motions)]
    model = write_model(
        root
        / "data"
        / "system_identification"
        / "identified_parameters"
        / "design_A.0"
        / "model_9.0"
        / "model_parameters.yml"
    )
    return records, model, motions
