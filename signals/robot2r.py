r"""The paper's planar 2R robot: base-parameter model, closed-loop simulation, scenarios.

Khalil–Kleinfinger modified DH, joint axes vertical (the robot moves in a horizontal plane: no
gravity), direct drive, each rotor counted in its link. Link 1 has length L (not given in the
paper: we fix L = 0.5 m; MX2 and MY2 only ever appear multiplied by L). The dynamics are
linear in the 8 base parameters

.. math:: X = [ZZ_{1R}, ZZ_2, MX_2, MY_2, FV_1, FC_1, FV_2, FC_2], \qquad
          ZZ_{1R} = ZZ_1 + M_2 L^2

Derivation. With :math:`c_2 = \cos q_2`, :math:`s_2 = \sin q_2` and the first moments of link 2
in its own frame, the kinetic energy is

.. math:: E = \tfrac12 ZZ_{1R}\dot q_1^2 + \tfrac12 ZZ_2(\dot q_1+\dot q_2)^2
          + L\dot q_1(\dot q_1+\dot q_2)(MX_2 c_2 - MY_2 s_2)

so :math:`M_{11} = ZZ_{1R} + ZZ_2 + 2L(MX_2 c_2 - MY_2 s_2)`,
:math:`M_{12} = ZZ_2 + L(MX_2 c_2 - MY_2 s_2)`, :math:`M_{22} = ZZ_2`; Lagrange's equations
:math:`\Gamma = \frac{d}{dt}\frac{\partial E}{\partial\dot q} - \frac{\partial E}{\partial q}
+ \Gamma_f` give the regressor rows (Γ = D(q, q̇, q̈) X)

.. math::
    D_1 = [\ddot q_1,\ \ddot q_1+\ddot q_2,\ L(c_2(2\ddot q_1+\ddot q_2) - s_2(2\dot q_1\dot q_2
          + \dot q_2^2)),\ L(-s_2(2\ddot q_1+\ddot q_2) - c_2(2\dot q_1\dot q_2+\dot q_2^2)),
          \ \dot q_1,\ \phi(\dot q_1),\ 0,\ 0]

    D_2 = [0,\ \ddot q_1+\ddot q_2,\ L(c_2\ddot q_1 + s_2\dot q_1^2),\
          L(-s_2\ddot q_1 + c_2\dot q_1^2),\ 0,\ 0,\ \dot q_2,\ \phi(\dot q_2)]

with the Coulomb law :math:`\phi(v) = \operatorname{sign} v`, or the paper's continuous
:math:`\phi(v) = \frac{2}{\pi}\arctan(\alpha v)` (``coulomb_slope`` α). The tests check D·X
against an independent Lagrangian computation (complex-step derivatives of E).

References
----------
Q. Guo, M. Gautier, D.-Y. Liu, W. Perruquetti, IEEE/ASME AIM 2015, sec. II and IV;
M. Gautier, W. Khalil, "Direct calculation of minimum set of inertial parameters of serial
robots", IEEE Trans. Robot. Autom. 6(3) (1990) 368-373.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from diffbench.signals._checks import unknown_choice_hint

PARAMETER_NAMES = ("ZZ1R", "ZZ2", "MX2", "MY2", "FV1", "FC1", "FV2", "FC2")
#: The paper's table II (Jacobi column), used as the true parameters of the simulation.
PAPER_PARAMETERS = np.array([3.496, 0.059, 0.124, 0.0019, 0.248, 0.431, 0.0144, 0.1268])
LINK1_LENGTH_M = 0.5
COULOMB_SLOPE = 500.0  # alpha of the continuous Coulomb law, s/rad


def _check_states(q, qd, qdd=None) -> tuple[np.ndarray, ...]:
    arrays = []
    for name, value in (("q", q), ("qd", qd), ("qdd", qdd)):
        if value is None:
            continue
        array = np.asarray(value, dtype=float)
        if array.ndim == 1 and array.shape == (2,):
            array = array[np.newaxis, :]
        if array.ndim != 2 or array.shape[1] != 2:
            raise ValueError(f"`{name}` must have shape (n, 2), got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise ValueError(f"`{name}` holds NaN or inf values")
        arrays.append(array)
    if len({a.shape[0] for a in arrays}) != 1:
        raise ValueError(
            "`q`, `qd` and `qdd` must have the same number of samples, got "
            + ", ".join(str(a.shape[0]) for a in arrays)
        )
    return tuple(arrays)


def coulomb(velocity: np.ndarray, slope: float | None) -> np.ndarray:
    """The Coulomb friction shape φ(v): ``sign(v)`` if ``slope`` is None, else
    (2/π)·atan(slope·v)."""
    if slope is None:
        return np.sign(velocity)
    return (2 / math.pi) * np.arctan(slope * velocity)


def regressor(
    q, qd, qdd, link1_length_m: float = LINK1_LENGTH_M, coulomb_slope: float | None = COULOMB_SLOPE
) -> np.ndarray:
    """D(q, q̇, q̈) of shape (n, 2, 8): joint torques are ``regressor(...) @ X``.

    ``q``, ``qd``, ``qdd`` have shape (n, 2) (joint 1, joint 2). See the module docstring for
    the rows; ``coulomb_slope`` None uses sign(q̇).
    """
    q, qd, qdd = _check_states(q, qd, qdd)
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    a1, a2 = qdd[:, 0], qdd[:, 1]
    v1, v2 = qd[:, 0], qd[:, 1]
    length = link1_length_m
    rows = np.zeros((q.shape[0], 2, 8))
    centripetal = 2 * v1 * v2 + v2**2
    rows[:, 0, 0] = a1
    rows[:, 0, 1] = a1 + a2
    rows[:, 0, 2] = length * (c2 * (2 * a1 + a2) - s2 * centripetal)
    rows[:, 0, 3] = length * (-s2 * (2 * a1 + a2) - c2 * centripetal)
    rows[:, 0, 4] = v1
    rows[:, 0, 5] = coulomb(v1, coulomb_slope)
    rows[:, 1, 1] = a1 + a2
    rows[:, 1, 2] = length * (c2 * a1 + s2 * v1**2)
    rows[:, 1, 3] = length * (-s2 * a1 + c2 * v1**2)
    rows[:, 1, 6] = v2
    rows[:, 1, 7] = coulomb(v2, coulomb_slope)
    return rows


def mass_matrix(q, parameters=PAPER_PARAMETERS, link1_length_m: float = LINK1_LENGTH_M):
    """M(q) of shape (n, 2, 2) (symmetric, positive definite for admissible parameters)."""
    (q,) = _check_states(q, np.zeros_like(np.asarray(q, dtype=float)))[:1]
    zz1r, zz2, mx2, my2 = parameters[:4]
    coupling = link1_length_m * (mx2 * np.cos(q[:, 1]) - my2 * np.sin(q[:, 1]))
    matrix = np.empty((q.shape[0], 2, 2))
    matrix[:, 0, 0] = zz1r + zz2 + 2 * coupling
    matrix[:, 0, 1] = matrix[:, 1, 0] = zz2 + coupling
    matrix[:, 1, 1] = zz2
    return matrix


def bias_torques(
    q,
    qd,
    parameters=PAPER_PARAMETERS,
    link1_length_m: float = LINK1_LENGTH_M,
    coulomb_slope: float | None = COULOMB_SLOPE,
) -> np.ndarray:
    """Coriolis, centrifugal and friction torques h(q, q̇) (n, 2): Γ = M(q) q̈ + h."""
    q, qd = _check_states(q, qd)
    return regressor(q, qd, np.zeros_like(q), link1_length_m, coulomb_slope) @ np.asarray(
        parameters, dtype=float
    )


# --- trajectories and closed-loop simulation -----------------------------------------------
@dataclass(frozen=True)
class PointToPoint:
    """Successive quintic point-to-point moves through ``waypoints`` (k, 2) [rad], each move
    lasting ``move_s[i]`` and followed by a rest of ``rest_s``; zero velocity and acceleration
    at every waypoint (the classical 5th-order polynomial trajectory generator)."""

    waypoints: np.ndarray
    move_s: np.ndarray
    rest_s: float

    @property
    def duration_s(self) -> float:
        return float(np.sum(self.move_s) + self.rest_s * len(self.move_s))

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Desired q, q̇, q̈ (each (n, 2)) at times ``t`` (held at the last waypoint after the
        end)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        starts = np.concatenate([[0.0], np.cumsum(self.move_s + self.rest_s)[:-1]])
        segment = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.move_s) - 1)
        duration = self.move_s[segment]
        s = np.clip((t - starts[segment]) / duration, 0.0, 1.0)
        moving = (t - starts[segment]) < duration
        shape = 10 * s**3 - 15 * s**4 + 6 * s**5
        rate = np.where(moving, (30 * s**2 - 60 * s**3 + 30 * s**4) / duration, 0.0)
        curve = np.where(moving, (60 * s - 180 * s**2 + 120 * s**3) / duration**2, 0.0)
        step = self.waypoints[segment + 1] - self.waypoints[segment]
        start = self.waypoints[segment]
        return (start + shape[:, None] * step, rate[:, None] * step, curve[:, None] * step)


def random_point_to_point(
    seed: int,
    duration_s: float,
    q1_range=(-3.0, 3.0),
    q2_range=(-2.0, 2.0),
    peak_velocity_rad_s: float = 2.0,
    peak_acceleration_rad_s2: float = 2.0,
    rest_s: float = 0.5,
) -> PointToPoint:
    """Random waypoints (uniform in the joint ranges), each move as short as the peak velocity
    and acceleration allow for the joint that moves farthest (a quintic over distance D in
    time T peaks at 15D/8T in velocity and 10D/(√3 T²) in acceleration), until ``duration_s``
    is filled. The defaults give moves like the paper's fig. 5 (|q̇| ≤ 2 rad/s,
    |q̈| ≤ 2 rad/s²)."""
    rng = np.random.default_rng(seed)
    waypoints = [np.zeros(2)]
    moves = []
    total = 0.0
    while total < duration_s:
        target = np.array([rng.uniform(*q1_range), rng.uniform(*q2_range)])
        distance = float(np.max(np.abs(target - waypoints[-1])))
        move = max(
            15 * distance / (8 * peak_velocity_rad_s),
            math.sqrt(10 * distance / (math.sqrt(3) * peak_acceleration_rad_s2)),
            0.5,
        )
        waypoints.append(target)
        moves.append(move)
        total += move + rest_s
    return PointToPoint(np.array(waypoints), np.array(moves), rest_s)


@dataclass(frozen=True)
class Motion:
    """Exact closed-loop motion sampled on ``t``: q, q̇, q̈ and the applied torque, (n, 2)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray


def joint_accelerations(
    q1: float,
    q2: float,
    v1: float,
    v2: float,
    tau1: float,
    tau2: float,
    parameters,
    link1_length_m: float,
    coulomb_slope: float,
) -> tuple[float, float]:
    """q̈ = M(q)⁻¹ (τ − h(q, q̇)) for one state, in scalar arithmetic (the simulators' inner
    loop: :func:`mass_matrix` and :func:`bias_torques` written out, Cramer's rule for the
    2×2 solve). ``parameters``: the 8 base parameters as floats."""
    zz1r, zz2, mx2, my2, fv1, fc1, fv2, fc2 = parameters
    c2, s2 = math.cos(q2), math.sin(q2)
    coupling = link1_length_m * (mx2 * c2 - my2 * s2)
    skew = link1_length_m * (mx2 * s2 + my2 * c2)  # -d(coupling)/dq2
    m11, m12, m22 = zz1r + zz2 + 2 * coupling, zz2 + coupling, zz2
    two_over_pi = 2 / math.pi
    h1 = (
        -skew * (2 * v1 * v2 + v2 * v2)
        + fv1 * v1
        + fc1 * two_over_pi * math.atan(coulomb_slope * v1)
    )
    h2 = skew * v1 * v1 + fv2 * v2 + fc2 * two_over_pi * math.atan(coulomb_slope * v2)
    r1, r2 = tau1 - h1, tau2 - h2
    det = m11 * m22 - m12 * m12
    return (m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det


def simulate_pd(
    trajectory: PointToPoint,
    parameters,
    link1_length_m: float,
    coulomb_slope: float,
    bandwidth_hz: float,
    step_s: float,
    sample_every: int,
    initial_velocity=(0.0, 0.0),
) -> Motion:
    """Integrate the robot under PD position control with fixed-step RK4 at ``step_s``.

    τ = Kp (q_d − q) + Kd (q̇_d − q̇), per joint Kp = J ω², Kd = 2 J ω (critically damped, closed
    loop bandwidth ω = 2π·``bandwidth_hz`` for the nominal inertias J = diag M(0)). Returned
    every ``sample_every`` steps, with the true q̈ = M⁻¹(τ − h) and τ at those instants.
    ``bandwidth_hz`` 0 switches the control off (free motion from ``initial_velocity``).
    """
    inertia = np.diagonal(mass_matrix(np.zeros((1, 2)), parameters, link1_length_m)[0])
    omega = 2 * math.pi * bandwidth_hz
    kp, kd = inertia * omega**2, 2 * inertia * omega
    steps = round(trajectory.duration_s / step_s)
    # The reference at every step and half step, computed once (vectorised).
    desired, rate, _ = trajectory(np.arange(2 * steps + 1) * (step_s / 2))
    values = tuple(float(v) for v in parameters)
    length, slope = float(link1_length_m), float(coulomb_slope)
    kp1, kp2, kd1, kd2 = float(kp[0]), float(kp[1]), float(kd[0]), float(kd[1])

    def derivative(index, q1, q2, v1, v2):
        # Scalar arithmetic: the RK4 loop runs 4 of these per step.
        tau1 = kp1 * (desired[index, 0] - q1) + kd1 * (rate[index, 0] - v1)
        tau2 = kp2 * (desired[index, 1] - q2) + kd2 * (rate[index, 1] - v2)
        a1, a2 = joint_accelerations(q1, q2, v1, v2, tau1, tau2, values, length, slope)
        return v1, v2, a1, a2

    q1, q2 = (float(v) for v in trajectory.waypoints[0])
    v1, v2 = (float(v) for v in initial_velocity)
    samples = steps // sample_every + 1
    out = np.empty((samples, 4))
    out[0] = (q1, q2, v1, v2)
    half = step_s / 2
    for step in range(steps):
        i = 2 * step
        a = derivative(i, q1, q2, v1, v2)
        b = derivative(
            i + 1, q1 + half * a[0], q2 + half * a[1], v1 + half * a[2], v2 + half * a[3]
        )
        c = derivative(
            i + 1, q1 + half * b[0], q2 + half * b[1], v1 + half * b[2], v2 + half * b[3]
        )
        d = derivative(
            i + 2, q1 + step_s * c[0], q2 + step_s * c[1], v1 + step_s * c[2], v2 + step_s * c[3]
        )
        sixth = step_s / 6
        q1 += sixth * (a[0] + 2 * b[0] + 2 * c[0] + d[0])
        q2 += sixth * (a[1] + 2 * b[1] + 2 * c[1] + d[1])
        v1 += sixth * (a[2] + 2 * b[2] + 2 * c[2] + d[2])
        v2 += sixth * (a[3] + 2 * b[3] + 2 * c[3] + d[3])
        if (step + 1) % sample_every == 0:
            out[(step + 1) // sample_every] = (q1, q2, v1, v2)
    t = np.arange(samples) * step_s * sample_every
    desired, rate, _ = trajectory(t)
    tau = kp * (desired - out[:, :2]) + kd * (rate - out[:, 2:])
    mass = mass_matrix(out[:, :2], parameters, link1_length_m)
    bias = bias_torques(out[:, :2], out[:, 2:], parameters, link1_length_m, coulomb_slope)
    qdd = np.linalg.solve(mass, (tau - bias)[:, :, None])[:, :, 0]
    return Motion(t=t, q=out[:, :2], qd=out[:, 2:], qdd=qdd, tau=tau)


# --- scenarios ------------------------------------------------------------------------------
@dataclass(frozen=True)
class RobotRealisation:
    """One noisy measurement of a simulated motion: measured q (quantised) and τ (with noise
    and ripple) at ``dt_s``, and the exact motion ``truth``."""

    t: np.ndarray
    dt_s: float
    q: np.ndarray
    tau: np.ndarray
    truth: Motion
    seed: int
    interior: np.ndarray


@dataclass(frozen=True, kw_only=True)
class RobotScenario:
    """A simulated identification experiment on the paper's 2R robot.

    Parameters
    ----------
    name, description : str
    duration_s : float
        Length of the excitation (successive quintic moves), seconds.
    trajectory_seed : int
        Seed of the waypoints (the motion is the same for every noise seed).
    validation_seed : int
        Seed of a second, fresh trajectory for torque prediction.
    sample_dt_s : float
        Measurement step (the paper: 100 Hz).
    step_s : float
        RK4 integration step (a whole fraction of ``sample_dt_s``).
    bandwidth_hz : float
        Closed-loop bandwidth of the PD position loops.
    encoder_step_rad : float
        Encoder quantisation of the measured q.
    torque_noise_std : tuple
        Standard deviation of white torque noise per joint, N·m.
    ripple_amplitude : tuple
        Amplitude of a position-periodic torque ripple a·sin(ripple_periods·q + φ) per joint,
        N·m (φ drawn from the seed).
    ripple_periods : float
        Ripple periods per radian.
    interior_margin_s : float
        Samples this close to either end are left out of the identification (central windows
        and filters cannot reach them).
    """

    name: str
    description: str
    duration_s: float
    trajectory_seed: int = 2015
    validation_seed: int = 2016
    sample_dt_s: float = 0.01
    step_s: float = 0.001
    bandwidth_hz: float = 0.5
    encoder_step_rad: float = 2 * math.pi / 2**16
    torque_noise_std: tuple = (0.2, 0.03)
    ripple_amplitude: tuple = (0.1, 0.02)
    ripple_periods: float = 16.0
    interior_margin_s: float = 0.6
    parameters: tuple = tuple(PAPER_PARAMETERS)
    link1_length_m: float = LINK1_LENGTH_M
    coulomb_slope: float = COULOMB_SLOPE
    preset: str = "robot"

    def __post_init__(self) -> None:
        for label in ("duration_s", "sample_dt_s", "step_s", "bandwidth_hz", "encoder_step_rad"):
            value = getattr(self, label)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"`{label}` must be a finite number > 0, got {value!r}")
        ratio = self.sample_dt_s / self.step_s
        if abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ValueError(
                f"`step_s` must divide `sample_dt_s` a whole number of times, got "
                f"{self.step_s!r} and {self.sample_dt_s!r}"
            )

    @property
    def true_parameters(self) -> np.ndarray:
        return np.array(self.parameters, dtype=float)

    def trajectory(self, validation: bool = False) -> PointToPoint:
        seed = self.validation_seed if validation else self.trajectory_seed
        return random_point_to_point(seed, self.duration_s)

    def motion(self, validation: bool = False) -> Motion:
        """The exact closed-loop motion (cached: the same for every noise seed)."""
        return _simulate_cached(self, validation)

    def realise(self, seed: int) -> RobotRealisation:
        """Measurements of the identification motion with noise drawn from ``seed``."""
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"`seed` must be a non-negative integer, got {seed!r}")
        truth = self.motion()
        rng = np.random.default_rng(seed)
        noise_rng, ripple_rng = rng.spawn(2)
        step = self.encoder_step_rad
        q = step * np.round(truth.q / step)
        std = np.asarray(self.torque_noise_std, dtype=float)
        phase = ripple_rng.uniform(0, 2 * math.pi, size=2)
        ripple = np.asarray(self.ripple_amplitude) * np.sin(self.ripple_periods * truth.q + phase)
        tau = truth.tau + ripple + std * noise_rng.standard_normal(truth.tau.shape)
        margin = self.interior_margin_s
        interior = (truth.t >= margin - 1e-9) & (truth.t <= truth.t[-1] - margin + 1e-9)
        return RobotRealisation(
            t=truth.t,
            dt_s=self.sample_dt_s,
            q=q,
            tau=tau,
            truth=truth,
            seed=int(seed),
            interior=interior,
        )


@functools.lru_cache(maxsize=8)
def _simulate_cached(scenario: RobotScenario, validation: bool) -> Motion:
    every = round(scenario.sample_dt_s / scenario.step_s)
    return simulate_pd(
        scenario.trajectory(validation),
        scenario.true_parameters,
        scenario.link1_length_m,
        scenario.coulomb_slope,
        scenario.bandwidth_hz,
        scenario.step_s,
        every,
    )


_ROBOT_SCENARIOS: dict[str, RobotScenario] = {}


def register_robot_scenario(scenario: RobotScenario) -> RobotScenario:
    if scenario.name in _ROBOT_SCENARIOS:
        raise ValueError(f"a robot scenario named {scenario.name!r} is already registered")
    _ROBOT_SCENARIOS[scenario.name] = scenario
    return scenario


def available_robot_scenarios() -> list[str]:
    return sorted(_ROBOT_SCENARIOS)


def get_robot_scenario(name: str) -> RobotScenario:
    try:
        return _ROBOT_SCENARIOS[name]
    except KeyError:
        hint = unknown_choice_hint(name, available_robot_scenarios())
        raise ValueError(f"unknown robot scenario {name!r}; {hint}") from None


register_robot_scenario(
    RobotScenario(
        name="robot-sim",
        description="The paper's 2R robot (table II parameters, L = 0.5 m) under PD control "
        "(0.5 Hz closed-loop bandwidth) on 30 s of successive quintic moves (|q̇| <= 2 rad/s, "
        "|q̈| <= 2 rad/s² as in its fig. 5), measured at 100 Hz with a 16-bit encoder, torque noise "
        "and ripple (Guo et al., AIM 2015, sec. IV).",
        duration_s=30.0,
    )
)
register_robot_scenario(
    RobotScenario(
        name="robot-sim-short",
        description="robot-sim on 12 s of motion: a quick version for tests.",
        duration_s=12.0,
    )
)
register_robot_scenario(
    RobotScenario(
        name="robot-sim-200hz",
        description="robot-sim measured at 200 Hz instead of 100 Hz.",
        duration_s=30.0,
        sample_dt_s=0.005,
    )
)
