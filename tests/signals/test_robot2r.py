"""The 2R robot model and simulator against independent computations."""

import math

import numpy as np
import pytest

from diffbench.signals import robot2r

L = robot2r.LINK1_LENGTH_M
X = robot2r.PAPER_PARAMETERS


def _kinetic_energy(q, qd, parameters):
    """E = 1/2 ZZ1R q1'^2 + 1/2 ZZ2 (q1'+q2')^2 + L q1'(q1'+q2')(MX2 c2 - MY2 s2), written
    from the link geometry, independently of the regressor (works on complex numbers)."""
    zz1r, zz2, mx2, my2 = parameters[:4]
    c2, s2 = np.cos(q[1]), np.sin(q[1])
    return (
        0.5 * zz1r * qd[0] ** 2
        + 0.5 * zz2 * (qd[0] + qd[1]) ** 2
        + L * qd[0] * (qd[0] + qd[1]) * (mx2 * c2 - my2 * s2)
    )


def _lagrangian_torque(q, qd, qdd, parameters, slope):
    """τ = d/dt ∂E/∂q̇ − ∂E/∂q + friction, from the energy alone: ∂E/∂q̇ by a central
    difference in q̇ (exact up to rounding, E being quadratic in q̇), its q-derivatives and
    ∂E/∂q by complex steps (exact to rounding)."""
    h, delta = 1e-30, 1.0  # E is quadratic in q̇: any step is exact; a large one rounds least
    unit = np.eye(2)

    def momentum(qq):  # p_i = ∂E/∂q̇_i at (qq, qd); qq may be complex
        return np.array(
            [
                (
                    _kinetic_energy(qq, qd + delta * unit[i], parameters)
                    - _kinetic_energy(qq, qd - delta * unit[i], parameters)
                )
                / (2 * delta)
                for i in range(2)
            ]
        )

    # d/dt p = Σ_k ∂p/∂q_k q̇_k + ∂p/∂q̇ q̈, with ∂p/∂q̇ = M(q) = Hessian of E in q̇
    dp_dq = np.array([np.imag(momentum(q + 1j * h * unit[k])) / h for k in range(2)]).T
    hessian = np.array(
        [
            (
                momentum_at_velocity(q, qd + delta * unit[j], parameters)
                - momentum_at_velocity(q, qd - delta * unit[j], parameters)
            )
            / (2 * delta)
            for j in range(2)
        ]
    ).T
    de_dq = np.array(
        [np.imag(_kinetic_energy(q + 1j * h * unit[k], qd, parameters)) / h for k in range(2)]
    )
    friction = np.array(
        [
            parameters[4] * qd[0] + parameters[5] * 2 / math.pi * math.atan(slope * qd[0]),
            parameters[6] * qd[1] + parameters[7] * 2 / math.pi * math.atan(slope * qd[1]),
        ]
    )
    return dp_dq @ qd + hessian @ qdd - de_dq + friction


def momentum_at_velocity(q, velocity, parameters, delta=1.0):
    unit = np.eye(2)
    return np.array(
        [
            (
                _kinetic_energy(q, velocity + delta * unit[i], parameters)
                - _kinetic_energy(q, velocity - delta * unit[i], parameters)
            )
            / (2 * delta)
            for i in range(2)
        ]
    )


def test_regressor_times_parameters_equals_an_independent_lagrangian():
    rng = np.random.default_rng(1)
    q = rng.uniform(-3, 3, (20, 2))
    qd = rng.uniform(-2, 2, (20, 2))
    qdd = rng.uniform(-5, 5, (20, 2))
    for parameters in (X, rng.uniform(0.05, 2.0, 8)):
        torques = robot2r.regressor(q, qd, qdd) @ parameters
        for k in range(20):
            reference = _lagrangian_torque(q[k], qd[k], qdd[k], parameters, robot2r.COULOMB_SLOPE)
            np.testing.assert_allclose(torques[k], reference, rtol=1e-10, atol=1e-10)


def test_mass_matrix_is_symmetric_positive_definite_and_matches_the_energy():
    q = np.random.default_rng(2).uniform(-3, 3, (50, 2))
    mass = robot2r.mass_matrix(q, X)
    np.testing.assert_array_equal(mass[:, 0, 1], mass[:, 1, 0])
    assert np.all(np.linalg.eigvalsh(mass) > 0)
    qd = np.array([0.7, -1.3])
    energy = 0.5 * np.einsum("i,nij,j->n", qd, mass, qd)
    expected = [_kinetic_energy(qk, qd, X) for qk in q]
    np.testing.assert_allclose(energy, expected, rtol=1e-13)


def test_coulomb_laws():
    velocity = np.array([-1.0, 0.0, 1e-3, 1.0])
    np.testing.assert_array_equal(robot2r.coulomb(velocity, None), [-1, 0, 1, 1])
    smooth = robot2r.coulomb(velocity, 500.0)
    assert smooth[1] == 0.0 and abs(smooth[3] - 1) < 2e-3
    assert smooth[2] == pytest.approx(2 / math.pi * math.atan(0.5))


def test_kinetic_energy_is_conserved_without_friction_and_control():
    frictionless = X.copy()
    frictionless[4:] = 0.0
    trajectory = robot2r.PointToPoint(np.array([[0.3, -0.5], [0.3, -0.5]]), np.array([4.0]), 0.0)
    motion = robot2r.simulate_pd(
        trajectory,
        frictionless,
        L,
        robot2r.COULOMB_SLOPE,
        bandwidth_hz=0.0,
        step_s=1e-3,
        sample_every=10,
        initial_velocity=(1.5, -2.0),
    )
    mass = robot2r.mass_matrix(motion.q, frictionless)
    energy = 0.5 * np.einsum("ni,nij,nj->n", motion.qd, mass, motion.qd)
    assert np.ptp(motion.q[:, 1]) > 1.0  # it really moves
    assert np.max(np.abs(energy - energy[0])) < 1e-9 * energy[0]


def test_simulated_motion_satisfies_the_dynamics_and_tracks_the_reference():
    scenario = robot2r.get_robot_scenario("robot-sim-short")
    motion = scenario.motion()
    torque = robot2r.regressor(motion.q, motion.qd, motion.qdd) @ scenario.true_parameters
    np.testing.assert_allclose(torque, motion.tau, rtol=0, atol=1e-10)
    # q̇ is the derivative of q: compare with central differences of the 100 Hz samples
    # (Taylor: the central difference errs by at most h²/6 max|q⃛|; q⃛ from the true q̈)
    h = scenario.sample_dt_s
    slope = (motion.q[2:] - motion.q[:-2]) / (2 * h)
    jerk = np.max(np.abs(np.diff(motion.qdd, axis=0))) / h
    assert np.max(np.abs(slope - motion.qd[1:-1])) <= 1.5 * h**2 / 6 * jerk
    assert np.max(np.abs(slope - motion.qd[1:-1])) < 0.01 * np.max(np.abs(motion.qd))
    desired, _, _ = scenario.trajectory()(motion.t)
    assert np.max(np.abs(desired - motion.q)) < 0.6  # PD tracking at 0.5 Hz
    assert np.max(np.abs(motion.qd)) <= 2.5 and np.max(np.abs(motion.qdd)) <= 4.0


def test_realisations_are_seeded_quantised_and_noisy():
    scenario = robot2r.get_robot_scenario("robot-sim-short")
    first, again, other = scenario.realise(3), scenario.realise(3), scenario.realise(4)
    np.testing.assert_array_equal(first.tau, again.tau)
    assert not np.array_equal(first.tau, other.tau)
    steps = first.q / scenario.encoder_step_rad
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    assert np.max(np.abs(first.q - first.truth.q)) <= scenario.encoder_step_rad / 2 + 1e-12
    residual = first.tau - first.truth.tau
    assert np.std(residual[:, 0]) == pytest.approx(np.hypot(0.2, 0.1 / np.sqrt(2)), rel=0.15)


def test_quintic_moves_rest_at_the_waypoints():
    trajectory = robot2r.random_point_to_point(7, 20.0)
    ends = np.cumsum(trajectory.move_s + trajectory.rest_s) - trajectory.rest_s / 2
    q, qd, qdd = trajectory(ends)
    np.testing.assert_allclose(q, trajectory.waypoints[1:], atol=1e-12)
    np.testing.assert_allclose(qd, 0.0, atol=1e-12)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"q": np.zeros((5, 3))}, r"`q` must have shape \(n, 2\)"),
        ({"qd": np.zeros((4, 2))}, r"same number of samples"),
        ({"qdd": np.full((5, 2), np.nan)}, r"`qdd` holds NaN"),
    ],
)
def test_regressor_bad_input(kwargs, message):
    arguments = {"q": np.zeros((5, 2)), "qd": np.zeros((5, 2)), "qdd": np.zeros((5, 2))}
    arguments.update(kwargs)
    with pytest.raises(ValueError, match=message):
        robot2r.regressor(**arguments)


def test_unknown_robot_scenario_lists_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown robot scenario 'robot'.*robot-sim"):
        robot2r.get_robot_scenario("robot")
