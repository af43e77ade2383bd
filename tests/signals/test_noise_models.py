"""Noise models: statistics with a fixed seed, exact deterministic values, composition, checks."""

import dataclasses
import math

import numpy as np
import pytest

from diffbench.signals import Gaussian, NoiseStack, Poisson, Quantisation, Sinusoid

N = 200_000
T = np.arange(N) * 1e-3
ZEROS = np.zeros(N)


def rng(seed=12345):
    return np.random.default_rng(seed)


# --- Gaussian -------------------------------------------------------------------------------


def test_gaussian_has_the_requested_standard_deviation_and_zero_mean():
    noise = Gaussian(std=0.2).sample(T, ZEROS, rng())
    # Standard errors of the sample std and mean of N normal draws: σ/√(2N) and σ/√N.
    assert abs(noise.std() - 0.2) < 3 * 0.2 / math.sqrt(2 * N)
    assert abs(noise.mean()) < 3 * 0.2 / math.sqrt(N)
    # Normal tails: about 4.55 % of draws beyond 2σ (binomial standard error ≈ 0.047 %).
    beyond = np.mean(np.abs(noise) > 0.4)
    assert abs(beyond - 0.0455) < 4 * math.sqrt(0.0455 * 0.9545 / N)


def test_gaussian_noise_does_not_depend_on_the_signal():
    x = np.sin(T)
    np.testing.assert_array_equal(
        Gaussian(std=0.2).sample(T, x, rng(7)), Gaussian(std=0.2).sample(T, ZEROS, rng(7))
    )


def test_gaussian_is_std_times_standard_normal_draws():
    expected = 0.2 * rng(3).standard_normal(10)
    np.testing.assert_array_equal(Gaussian().sample(T[:10], ZEROS[:10], rng(3)), expected)


# --- Poisson --------------------------------------------------------------------------------


def test_poisson_literal_reading_mean_and_fraction_of_jumps():
    noise = Poisson(rate=0.1, amplitude=0.2).sample(T, ZEROS, rng())
    counts = noise / 0.2
    np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-12)
    assert counts.min() == 0
    # Mean a·λ = 0.02, standard error √(a²λ/N).
    assert abs(noise.mean() - 0.02) < 4 * math.sqrt(0.2**2 * 0.1 / N)
    # P(K > 0) = 1 - e^{-λ}; binomial standard error.
    p_jump = 1 - math.exp(-0.1)
    assert abs(np.mean(noise > 0) - p_jump) < 4 * math.sqrt(p_jump * (1 - p_jump) / N)
    # P(K = 1) = λ e^{-λ}: most jumps are a single step of +0.2.
    p_one = 0.1 * math.exp(-0.1)
    assert abs(np.mean(np.isclose(noise, 0.2)) - p_one) < 4 * math.sqrt(p_one * (1 - p_one) / N)


def test_poisson_centered_has_zero_mean_and_shifted_values():
    noise = Poisson(rate=0.1, amplitude=0.2, centered=True).sample(T, ZEROS, rng())
    assert abs(noise.mean()) < 4 * math.sqrt(0.2**2 * 0.1 / N)
    counts = noise / 0.2 + 0.1
    np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-12)
    assert np.isclose(noise.min(), -0.02)


def test_poisson_centered_is_uncentered_minus_the_mean_for_the_same_draws():
    raw = Poisson().sample(T[:1000], ZEROS[:1000], rng(5))
    centered = Poisson(centered=True).sample(T[:1000], ZEROS[:1000], rng(5))
    np.testing.assert_allclose(centered, raw - 0.02, rtol=0, atol=1e-15)


# --- Sinusoid -------------------------------------------------------------------------------


def test_sinusoid_exact_values_at_quarter_periods():
    t = np.arange(5) / 800.0  # 200 Hz: quarter periods, phases 0, π/2, π, 3π/2, 2π
    noise = Sinusoid(amplitude=0.2, frequency_hz=200.0).sample(t, np.zeros(5), rng())
    np.testing.assert_allclose(noise, [0.0, 0.2, 0.0, -0.2, 0.0], rtol=0, atol=1e-15)
    shifted = Sinusoid(amplitude=0.5, frequency_hz=200.0, phase_rad=np.pi / 2)
    np.testing.assert_allclose(
        shifted.sample(t, np.zeros(5), rng()), [0.5, 0.0, -0.5, 0.0, 0.5], rtol=0, atol=1e-15
    )


def test_sinusoid_uses_no_randomness_and_broadcasts_over_channels():
    generator = rng()
    state = generator.bit_generator.state
    x = np.zeros((4, 3))
    noise = Sinusoid(amplitude=1.0, frequency_hz=0.25).sample([0.0, 1.0, 2.0, 3.0], x, generator)
    assert generator.bit_generator.state == state
    assert noise.shape == (4, 3)
    for column in noise.T:
        np.testing.assert_allclose(column, [0.0, 1.0, 0.0, -1.0], rtol=0, atol=1e-15)


# --- Quantisation ---------------------------------------------------------------------------


def test_quantisation_by_hand():
    noise = Quantisation(step=0.5).sample(np.zeros(4), [0.3, 1.1, -0.74, 2.0], rng())
    np.testing.assert_allclose(noise, [0.2, -0.1, 0.24, 0.0], rtol=0, atol=1e-15)


def test_quantisation_lands_on_the_grid_within_half_a_step():
    step = 2 * np.pi / 4096
    x = 3 * np.sin(2 * np.pi * 1.3 * T[:20_000]) + 0.01 * rng().standard_normal(20_000)
    noise = Quantisation(step=step).sample(T[:20_000], x, rng())
    levels = (x + noise) / step
    np.testing.assert_allclose(levels, np.round(levels), rtol=0, atol=1e-9)
    assert np.max(np.abs(noise)) <= step / 2 * (1 + 1e-12)
    # Quantisation error of a busy signal is close to uniform: variance Δ²/12.
    assert noise.var() == pytest.approx(step**2 / 12, rel=0.05)


# --- describe -------------------------------------------------------------------------------


def test_describe_labels():
    assert Gaussian(std=0.2).describe() == "gaussian(std=0.2)"
    assert Sinusoid().describe() == "sinusoid(amplitude=0.2, frequency_hz=200.0, phase_rad=0.0)"
    assert Poisson().describe() == "poisson(rate=0.1, amplitude=0.2)"
    assert Poisson(centered=True).describe() == "poisson(rate=0.1, amplitude=0.2, centered=True)"
    assert Quantisation(step=0.001).describe() == "quantisation(step=0.001)"
    assert NoiseStack().describe() == "none"
    assert NoiseStack((Gaussian(), Quantisation(step=0.5))).describe() == (
        "gaussian(std=0.2) + quantisation(step=0.5)"
    )


# --- NoiseStack -----------------------------------------------------------------------------

PAPER = NoiseStack((Gaussian(std=0.2), Sinusoid(), Poisson()))
T_SHORT = np.arange(1001) * 1e-3
X_SHORT = np.sin(2 * np.pi * 4 * T_SHORT)


def test_stack_is_bit_reproducible_for_a_seed_and_differs_across_seeds():
    noisy_a, noise_a = PAPER.apply(T_SHORT, X_SHORT, rng(42))
    noisy_b, noise_b = PAPER.apply(T_SHORT, X_SHORT, rng(42))
    assert np.array_equal(noisy_a, noisy_b)
    assert np.array_equal(noise_a, noise_b)
    _, noise_c = PAPER.apply(T_SHORT, X_SHORT, rng(43))
    assert not np.allclose(noise_a, noise_c)
    assert np.array_equal(noisy_a - X_SHORT, noise_a)


def test_stack_follows_its_documented_algorithm_bit_for_bit():
    children = rng(9).spawn(3)
    y = X_SHORT.copy()
    for model, child in zip(PAPER.models, children, strict=True):
        y = y + model.sample(T_SHORT, y, child)
    noisy, noise = PAPER.apply(T_SHORT, X_SHORT, rng(9))
    assert np.array_equal(noisy, y)
    assert np.array_equal(noise, y - X_SHORT)


def test_gaussian_part_is_unchanged_when_a_model_is_appended():
    # Child k of rng.spawn(K) does not depend on K, so appending models keeps earlier draws.
    _, alone = NoiseStack((Gaussian(),)).apply(T_SHORT, X_SHORT, rng(1))
    _, with_poisson = NoiseStack((Gaussian(), Poisson())).apply(T_SHORT, X_SHORT, rng(1))
    _, with_sinusoid = NoiseStack((Gaussian(), Sinusoid())).apply(T_SHORT, X_SHORT, rng(1))
    gaussian_part = with_sinusoid - Sinusoid().sample(T_SHORT, X_SHORT, rng())
    np.testing.assert_allclose(gaussian_part, alone, rtol=0, atol=1e-14)
    poisson_part = with_poisson - alone
    counts = poisson_part / 0.2
    np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-9)


def test_a_component_does_not_depend_on_how_much_randomness_the_others_draw():
    # Both first models add exactly zero, but Gaussian(std=0) consumes 1001 normal draws and
    # Sinusoid(amplitude=0) none: with one shared stream the Poisson draws would differ.
    first_draws = NoiseStack((Gaussian(std=0.0), Poisson()))
    first_draws_nothing = NoiseStack((Sinusoid(amplitude=0.0), Poisson()))
    _, a = first_draws.apply(T_SHORT, X_SHORT, rng(2))
    _, b = first_draws_nothing.apply(T_SHORT, X_SHORT, rng(2))
    assert np.count_nonzero(a) > 50
    assert np.array_equal(a, b)


def test_a_component_depends_on_its_position():
    # What does not hold: moving a model to another slot gives it another child stream.
    _, first = NoiseStack((Poisson(), Gaussian(std=0.0))).apply(T_SHORT, X_SHORT, rng(2))
    _, second = NoiseStack((Gaussian(std=0.0), Poisson())).apply(T_SHORT, X_SHORT, rng(2))
    assert not np.array_equal(first, second)


def test_repeated_apply_on_one_generator_gives_fresh_noise():
    generator = rng(4)
    _, first = PAPER.apply(T_SHORT, X_SHORT, generator)
    _, second = PAPER.apply(T_SHORT, X_SHORT, generator)
    assert not np.allclose(first, second)


def test_quantisation_last_quantises_the_noisy_signal():
    stack = NoiseStack((Gaussian(std=0.05), Quantisation(step=1e-2)))
    noisy, noise = stack.apply(T_SHORT, X_SHORT, rng(8))
    levels = noisy / 1e-2
    np.testing.assert_allclose(levels, np.round(levels), rtol=0, atol=1e-9)
    assert np.std(noise) == pytest.approx(0.05, rel=0.1)


def test_empty_stack_adds_nothing_and_draws_nothing():
    generator = rng(6)
    state = generator.bit_generator.seed_seq.n_children_spawned
    noisy, noise = NoiseStack().apply(T_SHORT, X_SHORT, generator)
    assert np.array_equal(noisy, X_SHORT)
    assert not noise.any()
    assert generator.bit_generator.seed_seq.n_children_spawned == state


def test_stack_accepts_a_list_and_stores_a_tuple():
    assert NoiseStack([Gaussian()]).models == (Gaussian(),)


# --- validation -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("cls", "params", "message"),
    [
        (Gaussian, {"std": -0.1}, "`std` must be >= 0, got -0.1"),
        (Gaussian, {"std": math.nan}, "`std` must be a finite number, got nan"),
        (Sinusoid, {"frequency_hz": -1.0}, "`frequency_hz` must be > 0, got -1.0"),
        (Sinusoid, {"amplitude": math.inf}, "`amplitude` must be a finite number"),
        (Sinusoid, {"phase_rad": None}, "`phase_rad` must be a real number"),
        (Poisson, {"rate": -0.1}, "`rate` must be >= 0, got -0.1"),
        (Poisson, {"amplitude": -0.2}, "`amplitude` must be >= 0, got -0.2"),
        (Poisson, {"centered": 1}, "`centered` must be True or False"),
        (Quantisation, {"step": 0.0}, "`step` must be > 0, got 0.0"),
        (Quantisation, {"step": math.inf}, "`step` must be a finite number"),
    ],
)
def test_bad_noise_parameters_are_rejected_by_name(cls, params, message):
    with pytest.raises(ValueError, match=message):
        cls(**params)


def test_quantisation_needs_a_step_and_models_are_frozen():
    with pytest.raises(TypeError, match="step"):
        Quantisation()
    with pytest.raises(dataclasses.FrozenInstanceError):
        Gaussian().std = 1.0


@pytest.mark.parametrize("bad_rng", [None, 0, np.random.RandomState(0), np.random.PCG64(0)])
@pytest.mark.parametrize("model", [Gaussian(), Sinusoid(), Poisson(), Quantisation(step=0.1)])
def test_sample_requires_a_generator(model, bad_rng):
    with pytest.raises(TypeError, match="`rng`"):
        model.sample(T[:3], ZEROS[:3], bad_rng)


def test_stack_requires_a_generator():
    with pytest.raises(TypeError, match="`rng`"):
        PAPER.apply(T[:3], ZEROS[:3], 42)


def test_sample_rejects_mismatched_or_bad_samples():
    with pytest.raises(ValueError, match="`x` must have the 3 samples of `t`"):
        Gaussian().sample(T[:3], ZEROS[:4], rng())
    with pytest.raises(ValueError, match="`x` holds 1 NaN or inf"):
        Gaussian().sample(T[:3], [0.0, math.nan, 0.0], rng())
    with pytest.raises(ValueError, match="`t` must be 1-D"):
        Gaussian().sample(np.zeros((3, 1)), ZEROS[:3], rng())
    with pytest.raises(ValueError, match="`x` must have the 3 samples"):
        PAPER.apply(T[:3], 0.0, rng())


def test_stack_rejects_non_models():
    with pytest.raises(ValueError, match=r"`models\[1\]` must be a noise model"):
        NoiseStack((Gaussian(), "poisson"))
    with pytest.raises(ValueError, match="`models` must be a tuple of noise models"):
        NoiseStack(Gaussian())
    with pytest.raises(ValueError, match="`models` must be a tuple of noise models"):
        NoiseStack(3)
