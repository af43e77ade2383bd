"""The discovery task family's systems: right-hand sides against hand-written equations,
trajectories against closed forms and invariants, exact derivatives, seeded noise."""

import numpy as np
import pytest

from diffbench.signals.dynamics import SYSTEMS, TOLERANCE, get_system

EPS = np.finfo(float).eps


def _written_out(name, x):
    """Each system's right-hand side written by hand from its reference."""
    if name == "lorenz":
        a, b, c = x.T
        return np.stack([10 * (b - a), a * (28 - c) - b, a * b - 8 / 3 * c], axis=-1)
    if name == "rossler":
        a, b, c = x.T
        return np.stack([-b - c, a + 0.2 * b, 0.2 + c * (a - 5.7)], axis=-1)
    a, b = x.T
    if name == "van-der-pol":
        return np.stack([b, 2 * (1 - a**2) * b - a], axis=-1)
    if name == "duffing":
        return np.stack([b, -0.1 * b - a - 5 * a**3], axis=-1)
    if name == "lotka-volterra":
        return np.stack([a - 0.5 * a * b, 0.5 * a * b - b], axis=-1)
    return np.stack([-0.1 * a + 2 * b, -2 * a - 0.1 * b], axis=-1)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_each_right_hand_side_is_its_written_equations(name):
    """At 200 random states of the trajectory's scale, to rounding: a sum of at most four
    terms, each a product of at most four factors, relative to the largest term."""
    system = get_system(name)
    x = 3 * np.random.default_rng(0).standard_normal((200, system.dimension))
    expected = _written_out(name, x)
    scale = 30 * (1 + np.abs(x).max(axis=1, keepdims=True)) ** system.degree
    assert np.abs(system.rhs(x) - expected).max(axis=None) <= 16 * EPS * scale.max()


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_the_derivatives_are_the_right_hand_side_at_each_sample(name):
    system = get_system(name)
    trajectory = system.trajectory()
    assert trajectory.x.shape == (trajectory.t.size, system.dimension)
    assert trajectory.t[1] == system.dt_s and trajectory.t[-1] == pytest.approx(system.duration_s)
    assert np.array_equal(trajectory.x_dot, system.rhs(trajectory.x))
    np.testing.assert_array_equal(trajectory.x[0], system.initial)


def test_the_linear_oscillator_follows_its_closed_form():
    """x = 2 e^{-t/10} cos 2t, y = -2 e^{-t/10} sin 2t. On a flow that does not expand
    errors, the global error is at most the sum of the local ones, each within the tolerance
    times the state's scale (|x| <= 2): DOP853 takes 241 steps here, bounded by 1000."""
    trajectory = get_system("linear-oscillator").trajectory()
    t = trajectory.t
    exact = 2 * np.exp(-0.1 * t)[:, None] * np.stack([np.cos(2 * t), -np.sin(2 * t)], axis=1)
    assert np.abs(trajectory.x - exact).max() <= 1000 * TOLERANCE * 2


def test_lotka_volterra_keeps_its_invariant():
    """V = δx - γ ln x + βy - α ln y = x/2 - ln x + y/2 - ln y is constant along every orbit:
    its drift is the integration's error times |∇V| = |1/2 - 1/x| + |1/2 - 1/y| (at most 1.4
    on this orbit, x, y in [0.8, 4]), the error within 1000 steps of the tolerance times 4."""
    x, y = get_system("lotka-volterra").trajectory().x.T
    assert min(x.min(), y.min()) >= 0.8 and max(x.max(), y.max()) <= 4
    invariant = x / 2 - np.log(x) + y / 2 - np.log(y)
    assert np.abs(invariant - invariant[0]).max() <= 1.4 * 1000 * TOLERANCE * 4


def test_the_coefficient_matrix_places_each_term_on_its_monomial():
    system = get_system("lorenz")
    powers = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, 0, 1]])
    matrix = system.coefficient_matrix(powers)
    expected = np.array(
        [
            [0, -10, 10, 0, 0, 0],
            [0, 28, -1, 0, 0, -1],
            [0, 0, 0, -8 / 3, 1, 0],
        ]
    )
    np.testing.assert_array_equal(matrix, expected)
    with pytest.raises(ValueError, match=r"monomial \(1, 0, 1\) is not in the library"):
        system.coefficient_matrix(powers[:5])


def test_measurements_add_seeded_noise_of_the_level_of_each_state():
    """The noise's standard deviation per state is the level times the state's spread over
    the trajectory (its sample estimate within 5 standard errors, 1/sqrt(2n)); the same
    seed draws the same noise; level 0 measures the truth."""
    system = get_system("lorenz")
    measured = system.measure(0.05, seed=3)
    spread = measured.truth.x.std(axis=0)
    np.testing.assert_allclose(measured.noise_std, 0.05 * spread)
    noise = measured.x - measured.truth.x
    n = noise.shape[0]
    np.testing.assert_allclose(noise.std(axis=0), 0.05 * spread, rtol=5 / np.sqrt(2 * n))
    assert np.array_equal(system.measure(0.05, seed=3).x, measured.x)
    assert not np.array_equal(system.measure(0.05, seed=4).x, measured.x)
    assert np.array_equal(system.measure(0.0, seed=3).x, measured.truth.x)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_a_measurement_of_several_starts_shares_the_samples_and_one_start_is_measure(name):
    """One start is ``measure`` bit for bit; three are trajectories from ``initial`` and the
    declared starts, each a third of the duration at the system's step, the noise's level
    taken over all of their samples and drawn with the seed's one generator in order."""
    system = get_system(name)
    (one,) = system.measure_runs(0.05, 7)
    # the one-start measurement as written before there were several (the stored results'):
    # the trajectory plus the level times its spread times the seed's normal draws
    truth = system.trajectory()
    noise = 0.05 * truth.x.std(axis=0) * np.random.default_rng(7).standard_normal(truth.x.shape)
    assert np.array_equal(one.x, truth.x + noise)
    assert np.array_equal(one.x, system.measure(0.05, 7).x)
    runs = system.measure_runs(0.05, 7, every=5, starts=3)
    assert len(runs) == 3 and system.max_starts == 3
    third = round(system.duration_s / 3 / system.dt_s)
    for run, start in zip(runs, (system.initial, *system.starts), strict=True):
        np.testing.assert_array_equal(run.truth.x[0], start)
        np.testing.assert_array_equal(run.t, system.dt_s * np.arange(0, third + 1, 5))
        assert run.dt_s == 5 * system.dt_s
    spread = np.concatenate([run.truth.x for run in runs]).std(axis=0)
    np.testing.assert_array_equal(runs[0].noise_std, 0.05 * spread)
    rng = np.random.default_rng(7)
    for run in runs:
        expected = run.truth.x + 0.05 * spread * rng.standard_normal(run.x.shape)
        np.testing.assert_array_equal(run.x, expected)
    with pytest.raises(ValueError, match=r"`starts` must be in 1..3"):
        system.measure_runs(0.05, 7, starts=4)
    with pytest.raises(ValueError, match="`starts` must be a whole number"):
        system.measure_runs(0.05, 7, starts=2.0)
    with pytest.raises(ValueError, match="`starts` must be a whole number >= 1, got 0"):
        system.measure_runs(0.05, 7, starts=0)
    numpy_ints = system.measure_runs(0.05, 7, every=np.int64(5), starts=np.int64(3))
    assert all(np.array_equal(a.x, b.x) for a, b in zip(numpy_ints, runs, strict=True))


def test_a_system_refuses_a_measured_start_that_is_also_held_out():
    import dataclasses

    lorenz = get_system("lorenz")
    with pytest.raises(ValueError, match="the measured and held-out starts must differ"):
        dataclasses.replace(lorenz, starts=(lorenz.held_out[0],))


def test_an_unknown_system_is_named_with_the_close_ones():
    with pytest.raises(ValueError, match="unknown system 'lorenzz'; did you mean 'lorenz'"):
        get_system("lorenzz")
