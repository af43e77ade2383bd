"""The Gaussian kernel taps against the continuous Gaussian and their moment conditions."""

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods.gaussian_kernel import gaussian_kernel_taps

DT = 1e-3


@pytest.mark.parametrize("sigma_s", [0.002, 0.0064, 0.03])
def test_moments_are_exact_and_the_shape_is_the_gaussians_derivative(sigma_s):
    for order in (0, 1, 2):
        taps = gaussian_kernel_taps(order, sigma_s, DT)
        u = (np.arange(taps.size) - taps.size // 2) * DT
        moments = [np.sum(taps * u**k) for k in range(5)]
        # the estimate of the derivative of `order` of u^k / k! at 0 is sum(taps * u^k) / k!
        expected = {0: [1, 0, None, 0, None], 1: [0, 1, 0, None, 0], 2: [0, 0, 2, 0, None]}
        for k, value in enumerate(expected[order]):
            if value is not None:
                assert moments[k] == pytest.approx(value, abs=1e-9 * DT**-order), (order, k)
    # for a wide kernel the taps follow the continuous Gaussian derivatives closely
    sigma = 0.03
    u = (np.arange(gaussian_kernel_taps(1, sigma, DT).size) - 120) * DT
    gauss = np.exp(-0.5 * (u / sigma) ** 2) / (sigma * np.sqrt(2 * np.pi))
    np.testing.assert_allclose(
        gaussian_kernel_taps(0, sigma, DT) / DT, gauss, atol=2e-3 * gauss.max()
    )
    derivative = u / sigma**2 * gauss  # -g'(u): correlation taps of the derivative
    np.testing.assert_allclose(
        gaussian_kernel_taps(1, sigma, DT) / DT, derivative, atol=2e-3 * derivative.max()
    )


def test_the_response_is_the_gaussians():
    method = methods.get("gaussian_kernel", sigma_s=0.01)
    f = np.array([2.0, 10.0, 20.0])
    gain = np.abs(method.frequency_response(f, DT, 0))
    np.testing.assert_allclose(gain, np.exp(-0.5 * (2 * np.pi * f * 0.01) ** 2), rtol=1e-3)


@pytest.mark.parametrize("sigma_s", [0.0005, 20.0])
def test_a_sigma_outside_one_step_to_the_window_cap_is_refused(sigma_s):
    with pytest.raises(ValueError, match="`sigma_s` must be in"):
        methods.get("gaussian_kernel", sigma_s=sigma_s)(np.zeros(100), DT)
