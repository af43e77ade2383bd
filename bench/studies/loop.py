"""In the loop: the simulated 2R robot under PD control at 1 kHz, its velocity estimated online
from the quantised, noisy encoder by a causal method, against the same controller fed the
exact velocity.

At each control step k (period :math:`\\Delta t`) the encoder reads
:math:`\\tilde q_k = \\delta\\,\\mathrm{round}((q(t_k) + \\nu_k)/\\delta)` (white noise ν, step
δ); the method's stream gives :math:`\\hat{\\dot q}_k` from :math:`\\tilde q_0..\\tilde q_k`;
the torque

.. math::
    \\tau_k = K_p (q_d(t_k) - \\tilde q_k) + K_d (\\dot q_d(t_k) - \\hat{\\dot q}_k)

(per joint :math:`K_p = J\\omega^2`, :math:`K_d = 2J\\omega`, J the diagonal of M(0), ω the
closed-loop bandwidth; :math:`\\hat{\\dot q}_k = 0` while a method's window is still filling)
is held until the next step while the robot moves (fixed-step RK4,
:func:`diffbench.signals.robot2r.joint_accelerations`). The exact-velocity controller uses
:math:`\\dot q(t_k)` instead of the estimate, with the same encoder readings. A run whose
tracking error passes :data:`LoopSpec.lost_rad`, or whose state leaves the finite numbers, is
**unstable** (scored as such, from the time it was lost).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from diffbench import methods
from diffbench.signals import robot2r


@dataclass(frozen=True)
class LoopSpec:
    """The closed-loop experiment (defaults: 6 s of the paper robot's point-to-point moves,
    5 Hz loops at 1 kHz, a 14-bit encoder with 2e-4 rad of noise)."""

    duration_s: float = 6.0
    control_dt_s: float = 1e-3
    substeps: int = 2
    bandwidth_hz: float = 5.0
    encoder_step_rad: float = 2 * math.pi / 2**14
    encoder_noise_rad: float = 2e-4
    trajectory_seed: int = 2015
    settle_s: float = 0.5
    lost_rad: float = 0.5

    @property
    def name(self) -> str:
        return (
            f"2R PD loop {self.bandwidth_hz:g} Hz at {1 / self.control_dt_s:g} Hz, encoder "
            f"{self.encoder_step_rad:.3g} rad + noise {self.encoder_noise_rad:g} rad"
        )


@dataclass(frozen=True)
class LoopRun:
    """One closed-loop run: time, true q and q̇, desired q, the torque applied and the time
    the loop was lost (None: stable to the end)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_desired: np.ndarray
    tau: np.ndarray
    lost_at_s: float | None


def run_loop(spec: LoopSpec, method: methods.Method | None, seed: int) -> LoopRun:
    """The loop with ``method`` estimating q̇ online (None: the exact velocity)."""
    trajectory = robot2r.random_point_to_point(spec.trajectory_seed, spec.duration_s)
    parameters = tuple(float(v) for v in robot2r.PAPER_PARAMETERS)
    length, slope = float(robot2r.LINK1_LENGTH_M), float(robot2r.COULOMB_SLOPE)
    inertia = np.diagonal(robot2r.mass_matrix(np.zeros((1, 2)))[0])
    omega = 2 * math.pi * spec.bandwidth_hz
    kp, kd = inertia * omega**2, 2 * inertia * omega
    steps = round(spec.duration_s / spec.control_dt_s)
    t = np.arange(steps) * spec.control_dt_s
    desired, rate, _ = trajectory(t)
    noise = spec.encoder_noise_rad * np.random.default_rng(seed).standard_normal((steps, 2))
    stream = (
        None if method is None else method.stream(spec.control_dt_s, orders=(1,), channels=(2,))
    )
    state = np.array([*trajectory.waypoints[0], 0.0, 0.0])
    q, qd, tau = (np.full((steps, 2), np.nan) for _ in range(3))
    h = spec.control_dt_s / spec.substeps
    lost_at = None

    def derivative(s, torque):
        a1, a2 = robot2r.joint_accelerations(
            s[0], s[1], s[2], s[3], torque[0], torque[1], parameters, length, slope
        )
        return np.array([s[2], s[3], a1, a2])

    for k in range(steps):
        q[k], qd[k] = state[:2], state[2:]
        reading = spec.encoder_step_rad * np.round((state[:2] + noise[k]) / spec.encoder_step_rad)
        if stream is None:
            velocity = state[2:]
        else:  # before its window fills, a method gives no estimate: the controller takes 0
            estimate = stream.push(reading[None, :])
            velocity = estimate[1][0] if estimate.valid[1][0] else np.zeros(2)
        tau[k] = kp * (desired[k] - reading) + kd * (rate[k] - velocity)
        if not (np.all(np.isfinite(tau[k])) and np.max(np.abs(q[k] - desired[k])) < spec.lost_rad):
            lost_at = float(t[k])
            break
        for _ in range(spec.substeps):
            a = derivative(state, tau[k])
            b = derivative(state + h / 2 * a, tau[k])
            c = derivative(state + h / 2 * b, tau[k])
            d = derivative(state + h * c, tau[k])
            state = state + h / 6 * (a + 2 * b + 2 * c + d)
    return LoopRun(t=t, q=q, qd=qd, q_desired=desired, tau=tau, lost_at_s=lost_at)


def loop_scores(spec: LoopSpec, method: methods.Method, seed: int) -> list[dict]:
    """Tidy rows (joint as ``order`` 1, 2; region ``loop``) of a method in the loop against
    the exact-velocity controller on the same encoder readings: ``tracking_rmse`` (rad, after
    ``settle_s``), ``tracking_ratio`` (over the exact controller's), ``torque_noise_rms``
    (N·m: RMS of the torque less the exact controller's), ``stable`` (1 or 0) and
    ``lost_at_s`` (NaN when stable)."""
    if not method.causal:
        raise ValueError(f"{method.name} is not causal; the loop needs a causal method")
    exact = _exact_run(spec, seed)
    run = run_loop(spec, method, seed)
    settled = run.t >= spec.settle_s
    rows = []
    for joint in (0, 1):
        lost = float("nan") if run.lost_at_s is None else run.lost_at_s
        values = {"stable": float(run.lost_at_s is None), "lost_at_s": lost}
        if run.lost_at_s is None:
            error = run.q[settled, joint] - run.q_desired[settled, joint]
            reference = exact.q[settled, joint] - exact.q_desired[settled, joint]
            values["tracking_rmse"] = float(np.sqrt(np.mean(error**2)))
            values["tracking_ratio"] = values["tracking_rmse"] / float(
                np.sqrt(np.mean(reference**2))
            )
            difference = run.tau[settled, joint] - exact.tau[settled, joint]
            values["torque_noise_rms"] = float(np.sqrt(np.mean(difference**2)))
        rows += [
            {"order": joint + 1, "region": "loop", "metric": metric, "value": value}
            for metric, value in values.items()
        ]
    return rows


@functools.lru_cache(maxsize=8)
def _exact_run(spec: LoopSpec, seed: int) -> LoopRun:
    return run_loop(spec, None, seed)
