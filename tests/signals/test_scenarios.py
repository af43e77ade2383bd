"""Scenarios: the paper's test case, reproducible realisations, the common interior, checks."""

import dataclasses
import math

import numpy as np
import pytest

from diffbench.signals import (
    Chirp,
    DampedOscillation,
    Gaussian,
    NoiseStack,
    PaperSines,
    Poisson,
    Polynomial,
    Quantisation,
    Realisation,
    Scenario,
    Sinusoid,
    available_scenarios,
    get_scenario,
    register_scenario,
)
from diffbench.signals import scenarios as scenarios_module

BUILTIN = [
    "chirp-gaussian",
    "damped-gaussian",
    "kink",
    "paper-signal",
    "paper-signal-4937ms",
    "paper-signal-999ms",
    "paper-signal-clean",
    "paper-signal-quantised",
    "pendulum-500hz-jitter",
    "polynomial-clean",
]


def make(**overrides):
    params = {
        "name": "test",
        "signal": PaperSines(),
        "noise": NoiseStack((Gaussian(std=0.1),)),
        "dt_s": 1e-3,
        "duration_s": 1.0,
        "interior_margin_s": 0.1,
        "description": "a test scenario",
        "preset": "default",
    }
    params.update(overrides)
    return Scenario(**params)


def test_available_scenarios_lists_the_builtins_sorted():
    names = available_scenarios()
    assert names == sorted(names)
    assert [n for n in names if not n.startswith(("grid-", "limit-"))] == BUILTIN
    assert len([n for n in names if n.startswith("grid-")]) == 36 + 4  # + jitter, dropout
    limits = [n for n in names if n.startswith("limit-")]
    assert sorted(limits) == sorted(scenarios_module.limit_scenario_names())
    assert len(limits) == 5 * 3  # signal families x noise levels


def test_unknown_scenario_lists_the_valid_names():
    with pytest.raises(ValueError, match=r"unknown scenario 'paper'.*paper-signal, paper-signal-"):
        get_scenario("paper")


def test_paper_signal_is_the_papers_test_case():
    scenario = get_scenario("paper-signal")
    assert scenario.signal == PaperSines(frequencies_hz=(4.0, 9.0, 15.0), amplitude=1.0)
    assert scenario.noise.models == (
        Gaussian(std=0.2),
        Sinusoid(amplitude=0.2, frequency_hz=200.0, phase_rad=0.0),
        Poisson(rate=0.1, amplitude=0.2, centered=False),
    )
    assert scenario.dt_s == 1e-3
    assert scenario.duration_s == 1.0
    assert scenario.preset == "paper-signal"
    assert "III.C" in scenario.description
    t = scenario.t
    assert t.shape == (1001,)
    assert t[0] == 0.0
    assert t[-1] == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(np.diff(t), 1e-3, rtol=1e-9)


@pytest.mark.parametrize(
    ("name", "samples"), [("paper-signal-999ms", 1000), ("paper-signal-4937ms", 4938)]
)
def test_the_paper_signals_whose_ends_do_not_meet(name, samples):
    """The paper's signal and noise on records that end where they end: the 1001-sample
    record's last sample is at 1 s, where every component (4, 9, 15 Hz) is zero and odd about
    it; these stop elsewhere, so the record's end is neither zero nor a centre of symmetry."""
    paper, scenario = get_scenario("paper-signal"), get_scenario(name)
    assert (scenario.signal, scenario.noise, scenario.dt_s, scenario.preset) == (
        paper.signal,
        paper.noise,
        paper.dt_s,
        paper.preset,
    )
    t = scenario.t
    assert t.shape == (samples,)
    np.testing.assert_allclose(np.diff(t), 1e-3, rtol=1e-9)
    truth = scenario.realise(0).truth
    at_1s = paper.realise(0).truth
    # at 1 s the signal and its curvature vanish (to rounding of sin(2 pi f) at f t = 4, 9, 15)
    assert abs(at_1s[0][-1]) < 1e-12 and abs(at_1s[2][-1]) < 1e-9
    assert abs(truth[0][-1]) > 0.1 and abs(truth[2][-1]) > 100


def test_paper_signal_interior_drops_150_samples_at_each_end():
    realisation = get_scenario("paper-signal").realise(0)
    interior = realisation.interior
    assert interior.dtype == np.bool_
    assert int(interior.sum()) == 701  # t from 0.150 s to 0.850 s inclusive
    assert np.flatnonzero(interior)[[0, -1]].tolist() == [150, 850]
    assert np.all(interior[150:851])


def test_realise_is_bit_reproducible_and_seed_dependent():
    scenario = get_scenario("paper-signal")
    a, b = scenario.realise(seed=7), scenario.realise(seed=7)
    assert np.array_equal(a.x, b.x)
    assert np.array_equal(a.noise, b.noise)
    c = scenario.realise(seed=8)
    assert not np.allclose(a.x, c.x)
    assert (a.seed, c.seed) == (7, 8)


@pytest.mark.parametrize("name", ["paper-signal", "limit-band20-0.01", "limit-iwn3-0.1"])
def test_a_realisation_is_drawn_once_and_is_the_fresh_draw(name):
    """A record of at most CACHED_SAMPLES samples is drawn once a seed (the same read-only
    object for every later call), bit for bit what a fresh draw gives; a longer one is drawn
    at every call."""
    scenario = get_scenario(name)
    kept = scenario.realise(3)
    assert scenario.realise(3) is kept
    fresh = scenario._draw(3)
    for field in ("t", "x", "noise", "interior"):
        np.testing.assert_array_equal(getattr(kept, field), getattr(fresh, field))
        assert not getattr(kept, field).flags.writeable
    for derivative, expected in zip(kept.truth.derivatives, fresh.truth.derivatives, strict=True):
        np.testing.assert_array_equal(derivative, expected)
    long = dataclasses.replace(
        scenario, name=f"{name}-long", duration_s=scenarios_module.CACHED_SAMPLES * scenario.dt_s
    )
    assert long.n_samples > scenarios_module.CACHED_SAMPLES
    first, second = long.realise(3), long.realise(3)
    assert first is not second
    np.testing.assert_array_equal(first.x, second.x)


def test_realise_uses_default_rng_of_the_seed():
    scenario = get_scenario("paper-signal")
    expected_noisy, expected_noise = scenario.noise.apply(
        scenario.t, scenario.signal.evaluate(scenario.t)[0], np.random.default_rng(11)
    )
    realisation = scenario.realise(np.int64(11))
    assert np.array_equal(realisation.x, expected_noisy)
    assert np.array_equal(realisation.noise, expected_noise)
    assert realisation.seed == 11 and type(realisation.seed) is int


@pytest.mark.parametrize("name", BUILTIN)
def test_every_scenario_realises_with_its_exact_truth(name):
    scenario = get_scenario(name)
    realisation = scenario.realise(3)
    n = scenario.t.shape[0]
    assert realisation.x.shape == realisation.noise.shape == realisation.interior.shape == (n,)
    if scenario.sampling:  # jittered stamps: increasing, each within 30 % of a step of its own
        assert np.all(np.diff(realisation.t) > 0)
        assert np.max(np.abs(realisation.t - scenario.t)) <= 0.3 * scenario.dt_s
    else:
        assert np.array_equal(realisation.t, scenario.t)
    assert realisation.dt_s == scenario.dt_s
    assert np.array_equal(realisation.noise, realisation.x - realisation.truth[0])
    truth = scenario.signal.evaluate(realisation.t)
    for order in range(3):
        assert np.array_equal(realisation.truth[order], truth[order])
    assert np.all(np.isfinite(realisation.x))
    assert 0 < realisation.interior.sum() < n
    assert scenario.preset in {"paper-signal", "default"}
    assert scenario.description


def test_paper_signal_noise_statistics_over_seeds():
    # noise - sinusoid = 0.2·N(0,1) + 0.2·Poisson(0.1): mean 0.02, variance 0.04 + 0.004.
    scenario = get_scenario("paper-signal")
    hum = 0.2 * np.sin(2 * np.pi * 200 * scenario.t)
    random_part = np.concatenate([scenario.realise(s).noise - hum for s in range(20)])
    standard_error = math.sqrt(0.044 / random_part.size)
    assert abs(random_part.mean() - 0.02) < 4 * standard_error
    assert random_part.std() == pytest.approx(math.sqrt(0.044), rel=0.03)


def test_paper_signal_clean_has_no_noise():
    realisation = get_scenario("paper-signal-clean").realise(0)
    assert np.array_equal(realisation.x, realisation.truth[0])
    assert not realisation.noise.any()
    assert get_scenario("paper-signal-clean").noise.describe() == "none"


def test_paper_signal_quantised_lands_on_the_grid():
    scenario = get_scenario("paper-signal-quantised")
    assert scenario.noise.models[-1] == Quantisation(step=1e-3)
    assert scenario.noise.models[:-1] == get_scenario("paper-signal").noise.models
    assert scenario.preset == "paper-signal"
    x = scenario.realise(5).x
    np.testing.assert_allclose(x / 1e-3, np.round(x / 1e-3), rtol=0, atol=1e-9)
    # Same seed, same children for the first three models: differs from paper-signal by at
    # most half a step.
    paper = get_scenario("paper-signal").realise(5).x
    assert np.max(np.abs(x - paper)) <= 0.5e-3 * (1 + 1e-9)


def test_other_builtin_scenarios():
    chirp = get_scenario("chirp-gaussian")
    assert chirp.signal == Chirp(start_hz=1.0, rate_hz_per_s=9.5)
    assert chirp.signal.start_hz + chirp.signal.rate_hz_per_s * chirp.duration_s == 20.0
    assert chirp.noise.models == (Gaussian(std=0.05),)
    assert (chirp.dt_s, chirp.duration_s, chirp.interior_margin_s) == (1e-3, 2.0, 0.2)
    assert chirp.preset == "default"
    damped = get_scenario("damped-gaussian")
    assert damped.signal == DampedOscillation(natural_hz=5.0, damping_ratio=0.1)
    assert damped.noise.models == (Gaussian(std=0.02),)
    assert damped.t.shape == (2001,)
    polynomial = get_scenario("polynomial-clean")
    assert isinstance(polynomial.signal, Polynomial)
    assert len(polynomial.signal.coefficients) == 4
    assert polynomial.t.shape == (201,)
    assert polynomial.noise.models == ()


def test_t_is_dt_times_arange():
    scenario = make(dt_s=0.1, duration_s=0.3, interior_margin_s=0.1)  # 0.3 / 0.1 = 2.9999...
    np.testing.assert_array_equal(scenario.t, 0.1 * np.arange(4))
    # The margin equals one step: the first and last samples are out, t = 0.1 and 0.2 in.
    assert scenario.realise(0).interior.tolist() == [False, True, True, False]


def test_zero_margin_keeps_every_sample():
    assert make(interior_margin_s=0.0).realise(0).interior.all()


def test_realisation_is_frozen_and_read_only():
    realisation = get_scenario("paper-signal").realise(0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        realisation.x = np.zeros(1001)
    for array in (realisation.x, realisation.noise, realisation.t, realisation.interior):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0


def test_register_scenario_rejects_duplicates(monkeypatch):
    monkeypatch.setattr(scenarios_module, "_REGISTRY", dict(scenarios_module._REGISTRY))
    scenario = make(name="_test-scenario")
    register_scenario(scenario)
    assert get_scenario("_test-scenario") is scenario
    with pytest.raises(ValueError, match="already registered"):
        register_scenario(make(name="paper-signal"))
    with pytest.raises(ValueError, match="`scenario`"):
        register_scenario("paper-signal")


# --- validation -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"dt_s": 0.0}, "`dt_s` must be > 0, got 0.0"),
        ({"dt_s": math.nan}, "`dt_s` must be a finite number"),
        ({"dt_s": math.inf}, "`dt_s` must be a finite number"),
        ({"duration_s": -1.0}, "`duration_s` must be > 0, got -1.0"),
        ({"duration_s": 1.0005}, "`duration_s` must be a whole number of steps"),
        ({"duration_s": 1e-4}, "`duration_s` must be a whole number of steps"),
        ({"interior_margin_s": -0.1}, "`interior_margin_s` must be >= 0, got -0.1"),
        ({"interior_margin_s": 0.5}, "`interior_margin_s` must be < half of `duration_s`"),
        ({"interior_margin_s": math.nan}, "`interior_margin_s` must be a finite number"),
        ({"signal": "paper_sines"}, "`signal` must be a signals.Signal"),
        ({"noise": (Gaussian(),)}, "`noise` must be a NoiseStack"),
        ({"name": ""}, "`name` must be a non-empty string"),
        ({"preset": None}, "`preset` must be a non-empty string"),
        ({"description": 3}, "`description` must be a non-empty string"),
    ],
)
def test_bad_scenarios_are_rejected_by_name(overrides, message):
    with pytest.raises(ValueError, match=message):
        make(**overrides)


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3", None])
def test_bad_seeds_are_rejected(seed):
    with pytest.raises(ValueError, match="`seed` must be a non-negative integer"):
        get_scenario("paper-signal").realise(seed)


def test_realisation_checks_its_shapes():
    realisation = get_scenario("paper-signal-clean").realise(0)
    fields = {f.name: getattr(realisation, f.name) for f in dataclasses.fields(Realisation)}
    with pytest.raises(ValueError, match="`x` must have shape"):
        Realisation(**{**fields, "x": np.zeros(3)})
    with pytest.raises(ValueError, match="`interior` must be a boolean mask"):
        Realisation(**{**fields, "interior": np.ones(1001)})
    with pytest.raises(ValueError, match="`seed`"):
        Realisation(**{**fields, "seed": -2})


def test_a_stretch_of_a_realisation_is_its_samples_there():
    """Times, samples, noise and every order of the truth cut alike, the new scored mask
    checked like any realisation's (a mask of the wrong length is refused, naming it)."""
    whole = get_scenario("paper-signal").realise(3)
    interior = np.zeros(200, dtype=bool)
    interior[20:180] = True
    part = whole.stretch(slice(100, 300), interior)
    np.testing.assert_array_equal(part.t, whole.t[100:300])
    np.testing.assert_array_equal(part.x, whole.x[100:300])
    np.testing.assert_array_equal(part.noise, whole.noise[100:300])
    for order in (0, 1, 2):
        np.testing.assert_array_equal(part.truth[order], whole.truth[order][100:300])
    np.testing.assert_array_equal(part.interior, interior)
    assert (part.dt_s, part.seed) == (whole.dt_s, whole.seed)
    with pytest.raises(ValueError, match="`interior` must be a boolean mask of shape"):
        whole.stretch(slice(100, 300), np.ones(199, dtype=bool))
