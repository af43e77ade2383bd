"""Frequency-domain scores against independent computations and exact numbers."""

import numpy as np
import pytest
from scipy import optimize

from diffbench import methods, signals
from diffbench.bench.core.scores import estimate_on
from diffbench.bench.studies.frequency import (
    cutoff_hz,
    decompose_error,
    noise_gain,
    relative_response,
)

DT = 1e-3


@pytest.mark.parametrize(
    "name", ["finite_difference", "savitzky_golay", "jacobi", "butterworth", "sindy_smoothing"]
)
@pytest.mark.parametrize("order", [1, 2])
def test_noise_gain_equals_the_energy_of_the_impulse_response(name, order):
    """The output of a unit impulse in the middle of a long zero signal is the impulse
    response; for white noise of unit variance the output variance is its energy."""
    method = methods.preset(name, "paper-signal")
    impulse = np.zeros(8001)
    impulse[4000] = 1.0
    response = method(impulse, DT, orders=(order,))[order]
    energy = np.nansum(response[2000:6001] ** 2)
    assert noise_gain(method, DT, order) == pytest.approx(energy, rel=1e-6)


def test_cutoff_of_the_central_difference_is_where_sinc_falls_to_minus_3_db():
    # H / (i w) = sin(w dt) / (w dt): -3 dB at sin(theta)/theta = 1/sqrt(2)
    theta = optimize.brentq(lambda t: np.sin(t) / t - 1 / np.sqrt(2), 0.5, 2.0)
    method = methods.get("finite_difference", accuracy_order=2)
    assert cutoff_hz(method, DT, 1) == pytest.approx(theta / (2 * np.pi * DT), rel=1e-8)


def test_butterworth_relative_response_at_its_cutoff_is_one_half():
    """|B(fc)|^2 = 1/2 for the forward-backward filter; the central difference scales it by
    sin(w dt)/(w dt)."""
    method = methods.get("butterworth", order=6, cutoff_hz=25.0)
    theta = 2 * np.pi * 25.0 * DT
    gain = abs(relative_response(method, [25.0], DT, 1)[0])
    assert gain == pytest.approx(0.5 * np.sin(theta) / theta, rel=1e-9)


def test_error_decomposition_adds_up_pointwise():
    realisation = signals.get_scenario("paper-signal").realise(4)
    method = methods.preset("jacobi", "paper-signal")
    for order in (1, 2):
        parts = decompose_error(method, realisation, order)
        mask = realisation.interior
        total = method(realisation.x, DT)[order] - realisation.truth[order]
        bias = method(realisation.truth[0], DT)[order] - realisation.truth[order]
        noise = method(realisation.noise, DT)[order]
        np.testing.assert_allclose(
            total[mask], bias[mask] + noise[mask], rtol=0, atol=1e-9 * np.max(np.abs(total[mask]))
        )
        assert parts.total == pytest.approx(np.sqrt(np.mean(total[mask] ** 2)), rel=1e-12)
        assert parts.bias == pytest.approx(np.sqrt(np.mean(bias[mask] ** 2)), rel=1e-12)
        assert abs(parts.bias - parts.noise) <= parts.total <= parts.bias + parts.noise


def test_decomposition_refuses_a_nonlinear_method():
    class Nonlinear(methods.Method):
        linear = False
        name = "nonlinear"

    realisation = signals.get_scenario("paper-signal").realise(0)
    with pytest.raises(ValueError, match="is not linear"):
        decompose_error(Nonlinear(), realisation, 1)


def test_bias_of_jacobi_on_the_clean_paper_signal_matches_its_response():
    """On the clean paper signal the bias is sum_f Im((H(f) - (i w)^n) e^{i w t}): its RMS over
    the interior equals the RMS of that predicted error."""
    realisation = signals.get_scenario("paper-signal").realise(0)
    method = methods.preset("jacobi", "paper-signal")
    t = realisation.t
    mask = realisation.interior
    for order in (1, 2):
        predicted = 0.0
        for frequency in (4.0, 9.0, 15.0):
            omega = 2 * np.pi * frequency
            h = method.frequency_response([frequency], DT, order)[0]
            predicted = predicted + np.imag((h - (1j * omega) ** order) * np.exp(1j * omega * t))
        expected = np.sqrt(np.mean(predicted[mask] ** 2))
        assert decompose_error(method, realisation, order).bias == pytest.approx(expected, rel=1e-8)


@pytest.mark.parametrize("scenario", ["paper-signal", "grid-gaussian-0.2-10ms-jitter"])
def test_the_clean_signal_is_differentiated_once_for_the_seeds_that_share_it(scenario):
    """The bias part of every seed is the method on the clean signal, computed afresh here
    (bit for bit: the same call on the same samples); on a uniform record the seeds share the
    clean signal and its estimate is computed once, on a jittered one each seed's own time
    stamps make it its own. The estimate the caller passes gives the noisy part's valid marks:
    the same parts as without it."""
    from diffbench.bench.studies import frequency as module

    found = signals.get_scenario(scenario)
    method = methods.preset("jacobi", "paper-signal") if scenario == "paper-signal" else None
    method = method or methods.get("savitzky_golay", window_s=0.1, degree=3)
    module._kept_clean_estimate.cache_clear()
    seeds = range(3)
    for seed in seeds:
        realisation = found.realise(seed)
        given = estimate_on(method, realisation)
        for order in (1, 2):
            parts = decompose_error(method, realisation, order, given)
            alone = decompose_error(method, realisation, order)
            assert (parts.bias, parts.noise) == (alone.bias, alone.noise)
            mask = realisation.interior & given.valid[order]
            clean = estimate_on(method, realisation, realisation.truth[0], orders=(order,))
            bias = clean[order] - realisation.truth[order]
            assert parts.bias == float(np.sqrt(np.mean(bias[mask] ** 2)))
            noise = estimate_on(method, realisation, realisation.noise, orders=(order,))[order]
            assert parts.noise == float(np.sqrt(np.mean(noise[mask] ** 2)))
    computed = module._kept_clean_estimate.cache_info().misses
    assert computed == (2 if realisation.uniform else 2 * len(seeds))
