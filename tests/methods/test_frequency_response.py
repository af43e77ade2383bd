"""Each linear method's frequency_response agrees with what it does to a sinusoid."""

import numpy as np
import pytest

from diffbench import methods
from tests.methods.conftest import method_cases

DT = 1e-3
FREQUENCIES_HZ = (3.0, 17.0, 61.0, 210.0)
# A spectral estimate responds exactly H(f) only to sinusoids its extension continues
# periodically (elsewhere the leakage of the record's ends decays over 1 / transition width):
# that exact response is tested in test_spectral.py. A Gaussian process takes the record's
# least-squares line out before a filter passing 0 Hz at H(0) < 1, so a sinusoid comes out as
# H plus (1 - H(0)) times the sinusoid's own line: tested in test_gaussian_process.py.
GLOBAL = {"spectral", "gaussian_process"}


def _linear_cases():
    return [
        case
        for case in method_cases()
        if methods.method_class(case.values[0]).linear and case.values[0] not in GLOBAL
    ]


@pytest.mark.parametrize(("name", "params"), _linear_cases())
def test_response_matches_the_time_domain_on_sinusoids(name, params):
    method = methods.get(name, **params)
    n = max(6001, 3 * method.min_samples(DT))
    t = np.arange(n) * DT
    middle = slice(n // 3, 2 * n // 3)  # > 2 s from the ends: IIR transients have decayed
    for frequency in FREQUENCIES_HZ:
        omega = 2 * np.pi * frequency
        for order in (0, 1, 2):
            response = method.frequency_response([frequency], DT, order)[0]
            for part, x in ((np.real, np.cos(omega * t)), (np.imag, np.sin(omega * t))):
                estimate = method(x, DT, orders=(order,))[order][middle]
                expected = part(response * np.exp(1j * omega * t[middle]))
                scale = max(1.0, omega**order)
                np.testing.assert_allclose(estimate, expected, rtol=0, atol=1e-8 * scale)


@pytest.mark.parametrize("name", ["finite_difference", "savitzky_golay", "jacobi"])
def test_fir_response_is_real_times_i_to_the_n_for_symmetric_taps(name):
    method = methods.preset(name, "paper-signal")
    frequencies = np.linspace(0.5, 400, 50)
    for order in (1, 2):
        response = method.frequency_response(frequencies, DT, order)
        rotated = response / (1j) ** order  # zero phase: H = i^n |H| up to sign
        np.testing.assert_allclose(rotated.imag, 0.0, atol=1e-9 * np.max(np.abs(response)))


def test_nonlinear_methods_say_they_have_no_response():
    class Fake(methods.Method):
        linear = False

    with pytest.raises(NotImplementedError, match="is not linear"):
        Fake.frequency_response(Fake(), [1.0], DT, 1)
