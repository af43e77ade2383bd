"""Irregular sampling: jitter and dropouts, seeded, with the truth at the measured times."""

import numpy as np
import pytest

from diffbench import signals
from diffbench.signals import Dropout, Jitter


def test_jitter_moves_inner_stamps_within_the_fraction_and_keeps_order():
    t = np.arange(1001) * 1e-3
    moved = Jitter(fraction=0.3).times(t, 1e-3, np.random.default_rng(0))
    shift = (moved - t) / 1e-3
    assert shift[0] == 0 and shift[-1] == 0
    assert np.max(np.abs(shift)) <= 0.3 and np.max(np.abs(shift)) > 0.29
    assert np.all(np.diff(moved) > 0.39e-3)
    assert np.mean(shift[1:-1]) == pytest.approx(0.0, abs=0.02)  # U(-1, 1) x 0.3


def test_dropout_loses_the_fraction_of_inner_samples_and_keeps_the_ends():
    t = np.arange(1001) * 1e-3
    kept = Dropout(fraction=0.1).times(t, 1e-3, np.random.default_rng(0))
    assert kept.size == 1001 - round(0.1 * 999)
    assert kept[0] == t[0] and kept[-1] == t[-1]
    assert np.all(np.isin(kept, t)) and np.all(np.diff(kept) > 0)


@pytest.mark.parametrize(
    ("model", "message"),
    [
        (lambda: Jitter(fraction=0.5), "below 0.5"),
        (lambda: Dropout(fraction=0.95), "at most 0.9"),
        (lambda: Jitter(fraction=-0.1), "fraction"),
    ],
)
def test_bad_fractions_are_refused(model, message):
    with pytest.raises(ValueError, match=message):
        model()


def test_irregular_scenarios_are_seeded_and_true_at_the_measured_times():
    scenario = signals.get_scenario("grid-gaussian-0.2-1ms-jitter")
    first, again, other = scenario.realise(4), scenario.realise(4), scenario.realise(5)
    np.testing.assert_array_equal(first.t, again.t)
    np.testing.assert_array_equal(first.x, again.x)
    assert not np.array_equal(first.t, other.t)
    assert not first.uniform and first.dt_s == 1e-3
    t = first.t
    velocity = sum(2 * np.pi * f * np.cos(2 * np.pi * f * t) for f in (4.0, 9.0, 15.0))
    np.testing.assert_allclose(first.truth[1], velocity, rtol=0, atol=1e-9)
    np.testing.assert_allclose(first.x - first.noise, first.truth[0], rtol=0, atol=1e-15)
    dropped = signals.get_scenario("grid-gaussian-0.2-10ms-dropout").realise(4)
    assert dropped.t.size == 94 - round(0.1 * 92) and not dropped.uniform


def test_a_scenario_without_sampling_draws_what_it_always_drew():
    """The sampling draws from its own generator: the grid's regular scenarios are unchanged
    (noise from default_rng(seed) alone)."""
    scenario = signals.get_scenario("grid-gaussian-0.2-1ms")
    realisation = scenario.realise(3)
    assert realisation.uniform
    truth = scenario.signal.evaluate(scenario.t)
    _, expected = scenario.noise.apply(scenario.t, truth[0], np.random.default_rng(3))
    np.testing.assert_array_equal(realisation.t, scenario.t)
    np.testing.assert_array_equal(realisation.noise, expected)
