"""The smoothing spline against scipy called directly, and its response's half-gain point."""

import numpy as np
import pytest
from scipy.interpolate import make_smoothing_spline

from diffbench import methods
from diffbench.methods.smoothing_spline import smoothing_parameter, smoothing_spline_response

DT = 1e-3


def test_equals_scipys_smoothing_spline_with_the_stated_lambda():
    rng = np.random.default_rng(3)
    t = np.arange(1500) * DT
    x = np.sin(2 * np.pi * 4 * t) + 0.5 * t**2 + 0.2 * rng.standard_normal(t.size)
    estimate = methods.get("smoothing_spline", cutoff_hz=12.0)(x, DT)
    spline = make_smoothing_spline(t, x, lam=1.0 / (DT * (2 * np.pi * 12.0) ** 4))
    for order, atol in ((0, 1e-9), (1, 1e-7), (2, 1e-4)):
        valid = estimate.valid[order]  # the ends check masks a few natural-end samples
        assert valid.mean() > 0.9
        np.testing.assert_allclose(
            estimate[order][valid], spline.derivative(order)(t[valid]), atol=atol
        )


def test_the_response_is_one_half_near_the_cutoff_for_slow_sampling():
    assert smoothing_parameter(10.0, DT) == pytest.approx(1 / (DT * (2 * np.pi * 10.0) ** 4))
    gain = smoothing_spline_response([1.0, 2.0], 1e-5, cutoff_hz=1.0, order=0)
    assert abs(gain[0]) == pytest.approx(0.5, abs=1e-6)
    assert abs(gain[1]) == pytest.approx(1 / 17, rel=1e-4)  # 1 / (1 + 2^4)


@pytest.mark.parametrize("cutoff_hz", [500.0, 0.4])
def test_a_cutoff_outside_the_working_range_is_refused(cutoff_hz):
    with pytest.raises(ValueError, match=r"`cutoff_hz` must be .*in \[0\.5, 500\) Hz"):
        methods.get("smoothing_spline", cutoff_hz=cutoff_hz)(np.zeros(100), DT)
