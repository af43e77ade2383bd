"""Data-only recommendation: surrogates with known truth drawn from a record's spectrum, and
the method they recommend scored against the real truth."""

import numpy as np
import pytest

from diffbench import methods, signals
from diffbench.bench.recommend import recommend
from diffbench.bench.scores import error_metrics
from diffbench.bench.spectrum import periodogram, record_spectrum
from diffbench.bench.surrogates import spectral_lines, surrogate_records
from diffbench.bench.tuning import tune


@pytest.fixture(scope="module")
def paper():
    return signals.get_scenario("paper-signal").realise(0)


def test_the_paper_signal_s_lines_are_found_at_their_frequency_and_amplitude(paper):
    spectrum = record_spectrum(paper.x, paper.dt_s)
    frequency, amplitude, lobes = spectral_lines(spectrum, paper.x.size)
    np.testing.assert_allclose(frequency, [4.0, 9.0, 15.0], atol=0.01)
    np.testing.assert_allclose(amplitude, 1.0, atol=0.02)  # PaperSines: unit amplitudes
    assert lobes.sum() == 15  # five bins of each main lobe


def test_surrogates_carry_the_record_s_lines_and_noise_with_exact_derivatives(paper):
    spectrum = record_spectrum(paper.x, paper.dt_s)
    drawn = surrogate_records(spectrum, paper.x.size, paper.dt_s, count=40, seed=1)
    noise_power = np.mean([periodogram(s.noise, s.dt_s)[1] for s in drawn], axis=0)
    below = (spectrum.frequency_hz > 4) & (spectrum.frequency_hz < spectrum.band_hz)
    above = spectrum.frequency_hz > 2 * spectrum.band_hz
    # the white floor below the band, and the record's own spectrum above (40 draws, ~12 bins
    # below: within 15 %; ~480 bins above, the 200 Hz line among them: within 10 %)
    assert np.mean(noise_power[below]) == pytest.approx(spectrum.noise_floor, rel=0.15)
    assert np.mean(noise_power[above]) == pytest.approx(np.mean(spectrum.power[above]), rel=0.1)
    for surrogate in drawn[:8]:
        t = surrogate.t
        # the derivatives are the signal's: a 6th-order central difference agrees to its error
        h = surrogate.dt_s
        inner = slice(3, -3)
        x = surrogate.truth[0]
        first = (x[6:] - 9 * x[5:-1] + 45 * x[4:-2] - 45 * x[2:-4] + 9 * x[1:-5] - x[:-6]) / (
            60 * h
        )
        scale = np.max(np.abs(surrogate.truth[1]))
        np.testing.assert_allclose(first, surrogate.truth[1][inner], atol=1e-6 * scale)
        # three unit lines and a little continuum: the signal's variance near 1.5
        assert 1.2 < np.var(surrogate.truth[0]) < 1.9
        assert t.size == paper.x.size and surrogate.interior.mean() == pytest.approx(0.9, 0.01)


def test_the_recommended_setting_is_near_the_oracle_s_on_the_paper_signal(paper):
    """No bandlimit given: the band (17 Hz), floor and lines come from the record; each
    method is tuned on 2 surrogates and scored on 4. Measured on seed 0, true interior RMSE of
    the recommended setting over the oracle-best of the same methods tuned on the truth:
    ẋ 2.92 / 1.79 = 1.63 (spectral), ẍ 1.48 (spectral); other surrogate draws gave 1.40 and
    1.30: two tuning surrogates leave the choice noisy. Issue 18 asks 1.25 in the median
    over the grid: not met yet."""
    names = ["spectral", "savitzky_golay", "butterworth"]
    recommendation = recommend(paper.x, paper.dt_s, names=names)
    assert 15.0 <= recommendation.spectrum.band_hz <= 19.0
    table = recommendation.table
    assert set(table["method"]) == set(names) and table["rank"].notna().all()
    for order, bound in ((1, 1.75), (2, 1.75)):
        name, params = recommendation.best(order)
        estimate = methods.get(name, **params)(paper.x, paper.dt_s, (order,))
        scored = paper.interior & estimate.valid[order]
        true = error_metrics(estimate[order], paper.truth[order], scored)["rmse"]
        oracle = min(tune(n, paper, order, "oracle").loss for n in names)
        assert true <= bound * oracle, (order, name, true, oracle)
        predicted = table[(table["order"] == order) & (table["method"] == name)].iloc[0]
        # the prediction is an RMSE of the right size (surrogates: continuum near the band)
        assert 0.5 * true <= predicted["predicted_rmse"] <= 2.0 * true
