"""The spectral method against exact answers: sinusoids its extension continues periodically
(every sample, ends included), the polynomial it takes out (against a direct minimisation of
its criterion), the records it refuses; and its lean path for long records (split FFTs,
normal equations) against numpy's FFT and the QR path, with its memory."""

import math

import numpy as np
import pytest
from scipy import linalg

from diffbench import methods
from diffbench.bench.studies import timing
from diffbench.methods import _fft
from diffbench.methods import spectral as spectral_module
from diffbench.methods.spectral import (
    TAPER_REACHES,
    end_basis,
    end_filter,
    extend,
    polynomial_trend,
    raised_cosine_lowpass,
    spectral_derivatives,
    taper_weights,
)
from diffbench.signals.scenarios import get_scenario

DT = 1e-3
N_STEPS = 2000  # (N - 1) dt = 2 s: integer-Hz sinusoids fill whole periods


@pytest.fixture(params=[False, True], ids=["numpy-path", "lean-path"])
def lean(request, monkeypatch):
    """Runs a test on the path of short records, and again with every record taken as long:
    the lean path, its transforms split wherever the half period has a factor of 2 or more."""
    if request.param:
        monkeypatch.setattr(spectral_module, "LEAN_PERIOD", 4)
        monkeypatch.setattr(_fft, "SPLIT_FROM", 4)
        monkeypatch.setattr(_fft, "SHORTEST_FACTOR", 2)
        monkeypatch.setattr(_fft, "BLOCK", 64)  # many blocks, the last ones partial
    return request.param


@pytest.mark.parametrize(
    "extension, wave, n_samples",
    [
        ("none", "cos", N_STEPS),  # n dt = 2 s: periodic as it is
        ("none", "sin", N_STEPS),
        ("even", "cos", N_STEPS + 1),  # mirrored about t = 2 s: cos continues itself
        ("odd", "sin", N_STEPS + 1),  # reflected through (2 s, 0): sin continues itself
    ],
)
@pytest.mark.parametrize("rolloff", [0.0, 0.3])
def test_every_sample_equals_the_response_on_sinusoids_the_extension_continues(
    extension, wave, n_samples, rolloff, lean
):
    """Towards the ends (not for ``none``) the response is the blend of the sharp low-pass's
    and the wide one's (:func:`end_filter`) with the taper's weights; the wide one's own
    ringing, the first and last 1/(r_e f_e) samples, is marked not valid."""
    method = methods.get("spectral", cutoff_hz=40.0, rolloff=rolloff, extension=extension)
    cutoff_end, rolloff_end = end_filter(40.0, rolloff, method.end_rolloff)
    wide = methods.get("spectral", cutoff_hz=cutoff_end, rolloff=rolloff_end)
    reach_end = math.ceil(1 / (rolloff_end * cutoff_end * DT))
    sharp_weight = np.ones(n_samples)
    trusted = np.ones(n_samples, dtype=bool)
    if extension != "none":
        reach = math.ceil(1 / (rolloff * 40.0 * DT)) if rolloff else n_samples
        reach = min(reach, TAPER_REACHES * reach_end)  # the brick wall's: capped
        near, weight = taper_weights(n_samples, reach, reach_end)
        sharp_weight[near] = weight
        trusted[:reach_end] = trusted[-reach_end:] = False
    t = np.arange(n_samples) * DT
    for frequency in (3.0, 17.0, 39.0, 45.0, 210.0):
        omega = 2 * np.pi * frequency
        x = np.cos(omega * t) if wave == "cos" else np.sin(omega * t)
        phase = 0.0 if wave == "cos" else -np.pi / 2
        estimate = method(x, DT)
        for order in (0, 1, 2):
            response = sharp_weight * method.frequency_response([frequency], DT, order)[0]
            response += (1 - sharp_weight) * wide.frequency_response([frequency], DT, order)[0]
            expected = np.real(response * np.exp(1j * (omega * t + phase)))
            scale = max(1.0, omega**order)
            np.testing.assert_allclose(estimate[order], expected, rtol=0, atol=1e-9 * scale)
            np.testing.assert_array_equal(estimate.valid[order], trusted)
    # the gain: passband 1, stopband 0, -6 dB at the cutoff for a smooth roll-off
    gain = raised_cosine_lowpass(np.array([10.0, 40.0, 70.0]), 40.0, rolloff)
    assert gain[0] == 1.0 and gain[2] == 0.0
    assert gain[1] == (1.0 if rolloff == 0 else pytest.approx(0.5))


def test_the_odd_extension_reproduces_lines_to_the_ends_and_even_does_not():
    t = np.arange(1001) * DT
    x = 3.0 - 7.0 * t
    odd = methods.get("spectral", extension="odd")(x, DT)
    np.testing.assert_allclose(odd[0], x, atol=1e-12)
    np.testing.assert_allclose(odd[1], -7.0, atol=1e-9)
    np.testing.assert_allclose(odd[2], 0.0, atol=1e-6)
    even = methods.get("spectral", extension="even")(x, DT)
    assert np.max(np.abs(even[1] + 7.0)) > 1.0  # the mirrored slope flips at the ends


def test_extension_shapes_and_channels(lean):
    x = np.random.default_rng(0).standard_normal((11, 3))
    for extension, period in (("odd-fitted", 20), ("odd", 20), ("even", 20), ("none", 11)):
        extended = extend(x, extension)
        assert extended.shape == (period, 3)
        np.testing.assert_array_equal(extended[:11], x)
    for extension in ("odd-fitted", "odd"):
        method = methods.get("spectral", cutoff_hz=400.0, extension=extension, fit_degree=3)
        np.testing.assert_allclose(method(x, DT)[1][:, 1], method(x[:, 1], DT)[1], atol=1e-12)


@pytest.mark.parametrize("degree", [0, 1, 3])
def test_the_fitted_trend_minimises_the_energy_above_the_cutoff(degree):
    """Against the least-squares solution written with the explicit two-sided DFT matrix."""
    n, cutoff_hz = 301, 40.0
    x = np.random.default_rng(degree).standard_normal(n) + np.linspace(0, 3, n) ** 2
    period = 2 * (n - 1)
    f = np.fft.fftfreq(period, DT)
    stop = 1.0 - raised_cosine_lowpass(f, cutoff_hz, 0.3)
    k = np.arange(period)
    dft = np.exp(-2j * np.pi * np.outer(k, k) / period) * stop[:, None]
    tau = np.linspace(0.0, 1.0, n)
    powers = tau[:, None] ** np.arange(degree + 1)
    design = dft @ extend(powers, "odd")
    target = dft @ extend(x, "odd")
    direct = linalg.lstsq(
        np.vstack([design.real, design.imag]), np.concatenate([target.real, target.imag])
    )[0]
    one_sided = 1.0 - raised_cosine_lowpass(np.fft.rfftfreq(period, DT), cutoff_hz, 0.3)
    fitted = polynomial_trend(x[:, None], "odd-fitted", degree, one_sided)[: degree + 1, 0]
    np.testing.assert_allclose(fitted, direct, rtol=1e-8, atol=1e-8)


def test_the_odd_extensions_reproduce_polynomials_of_their_degree_to_the_ends(lean):
    t = np.arange(1001) * DT
    cubic = np.polynomial.Polynomial([0.5, -2.0, 3.0, 4.0])
    fitted = methods.get("spectral", extension="odd-fitted", fit_degree=3)(cubic(t), DT)
    for order in (0, 1, 2):
        scale = 1e-10 * DT**-order
        np.testing.assert_allclose(fitted[order], cubic.deriv(order)(t), rtol=0, atol=scale)
    line = 3.0 - 7.0 * t
    odd = methods.get("spectral", extension="odd")(line, DT)
    np.testing.assert_allclose(odd[1], -7.0, atol=1e-9)
    # a line taken out does not follow a cubic: far above rounding at the ends
    for extension in ("odd", "odd-fitted"):
        linear = methods.get("spectral", extension=extension, fit_degree=1)(cubic(t), DT)
        assert np.max(np.abs(linear[1] - cubic.deriv()(t))) > 1e-2


def test_passband_sinusoids_are_exact_and_stopband_ones_leak_only_at_the_ends(lean):
    """odd-fitted (no taper: one brick wall) on sines its reflection continues: in the
    passband the fit is zero and every sample is exact; a strong sine just above the cutoff
    moves the fit (its reflected spectrum overlaps the powers'), which shows within a few
    cutoff periods of the ends, the caveat of :func:`polynomial_trend`."""
    method = methods.get(
        "spectral", cutoff_hz=40.0, rolloff=0.0, extension="odd-fitted", end_rolloff=0.0
    )
    t = np.arange(N_STEPS + 1) * DT
    for frequency in (3.0, 17.0, 39.0):
        omega = 2 * np.pi * frequency
        estimate = method(np.sin(omega * t), DT)
        np.testing.assert_allclose(estimate[1], omega * np.cos(omega * t), atol=1e-9 * omega)
    omega = 2 * np.pi * 45.0
    leak = np.abs(method(np.sin(omega * t), DT)[1])
    middle = slice(N_STEPS // 4, 3 * N_STEPS // 4)
    assert np.max(leak[middle]) < 0.02 * omega  # -34 dB of the sine's own derivative
    assert np.max(leak[:20]) > 0.3 * omega  # the caveat: the ends follow the fit


def test_the_fitted_ends_beat_the_end_samples_on_the_paper_signal():
    """The least-squares ends take the noise of two samples out of the whole record: on the
    paper signal (10 seeds) the whole-record RMSE of x' falls by a fifth, the interior gains too."""
    scenario = get_scenario("paper-signal")
    whole, interior = {"odd": [], "odd-fitted": []}, {"odd": [], "odd-fitted": []}
    for seed in range(10):
        draw = scenario.realise(seed=seed)
        for extension in whole:
            estimate = spectral_derivatives(np.asarray(draw.x), DT, (1,), 15.2, 0.0, extension)
            error = estimate[1] - draw.truth[1]
            whole[extension].append(np.sqrt(np.mean(error**2)))
            interior[extension].append(np.sqrt(np.mean(error[draw.interior] ** 2)))
    assert np.mean(whole["odd-fitted"]) < 0.8 * np.mean(whole["odd"])
    assert np.mean(interior["odd-fitted"]) <= np.mean(interior["odd"])


def test_a_record_shorter_than_two_periods_of_the_cutoff_is_refused():
    with pytest.raises(ValueError, match="at least 201 are needed"):
        methods.get("spectral", cutoff_hz=10.0)(np.zeros(200), DT)
    with pytest.raises(ValueError, match="`cutoff_hz` must be at least 2e-06 Hz"):
        methods.get("spectral", cutoff_hz=1e-9)(np.zeros(200), DT)


def test_a_cutoff_at_or_above_nyquist_is_refused():
    with pytest.raises(ValueError, match="`cutoff_hz` must be below the Nyquist frequency 500"):
        methods.get("spectral", cutoff_hz=500.0)(np.zeros(100), DT)
    with pytest.raises(ValueError, match="`extension` must be one of"):
        methods.get("spectral", extension="reflect")


@pytest.mark.parametrize("n_samples", [4097, 4161, 12865, 10101, 2001, 4])
@pytest.mark.parametrize("reflect", [None, -1.0, 1.0])
def test_split_transforms_equal_numpy(n_samples, reflect, monkeypatch):
    """rfft of the record (or its reflection, never formed) and irfft of a spectrum times a
    factor, split into two short transforms, against numpy's on the whole: halves 64 x 64,
    64 x 65, 96 x 134, 100 x 101, 40 x 50 and 3 (prime: numpy's, whole)."""
    monkeypatch.setattr(_fft, "SPLIT_FROM", 4)
    monkeypatch.setattr(_fft, "SHORTEST_FACTOR", 2)
    monkeypatch.setattr(_fft, "BLOCK", 1000)
    rng = np.random.default_rng(n_samples)
    x = rng.standard_normal(n_samples)
    y = x if reflect is None else np.concatenate([x, reflect * x[-2:0:-1]])
    expected = np.fft.rfft(y)
    np.testing.assert_allclose(
        _fft.rfft(x, reflect), expected, rtol=0, atol=2e-15 * np.max(np.abs(expected))
    )
    factor = rng.standard_normal(expected.size) + 1j * rng.standard_normal(expected.size)
    given = expected.copy()
    for keep in {y.size, y.size // 2 + 1, y.size // 2, 3, 2}:
        inverse = np.fft.irfft(expected * factor, y.size)[:keep]  # drops Im at 0 and Nyquist
        np.testing.assert_allclose(
            _fft.irfft(given, y.size, keep, lambda k: factor[k]),
            inverse,
            rtol=0,
            atol=2e-15 * np.max(np.abs(inverse)),
        )
        np.testing.assert_allclose(_fft.irfft(given, y.size, keep), y[:keep], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(given, expected)  # the spectrum given is not written


def test_the_split_takes_the_divisor_nearest_the_root():
    assert _fft.split_of(2 * 9_999_999) == (2151, 4649)  # N = 1e7: 3^2 239 4649
    assert _fft.split_of(2**22) == (1024, 2048)
    assert _fft.split_of(2**22 + 2) == (387, 5419)  # 2,097,153 = 387 x 5419
    assert _fft.split_of(2**22 + 1) is None  # odd
    assert _fft.split_of(2 * 1_000_003) is None  # below SPLIT_FROM
    assert _fft.split_of(2 * 2_097_169) is None  # a prime half: numpy's transform, whole
    assert _fft.split_of(2 * 3 * 1_000_003) is None  # only 3 x 1000003: too lopsided


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_each_end_basis_polynomial_holds_one_end_datum(degree):
    """1 - tau, tau, tau(tau - 1)/2, ...: every even derivative at either end is 0 but one."""
    basis = end_basis(degree)
    for j in range(degree + 1):
        p = np.polynomial.Polynomial(basis[:, j])
        data = [
            p.deriv(d)(end)
            for d in range(0, degree + 1, 2)
            for end in ((0.0, 1.0) if d < degree else (0.0,))
        ]
        np.testing.assert_allclose(data, np.eye(degree + 1)[j], atol=1e-12)


@pytest.mark.parametrize(
    "extension, degree",
    [("odd-fitted", 0), ("odd-fitted", 1), ("odd-fitted", 3), ("odd", 1), ("even", 1), ("none", 1)],
)
def test_the_lean_path_equals_the_qr_path(extension, degree, monkeypatch):
    """The lean path (long records) against the path of short records on the same 2-channel
    record: to rounding, and for the fitted cubic to 1e-7 of ẍ's scale (the powers' weighted
    spectra have condition 1.4e6, which the QR path carries and the normal equations in the
    end basis, condition 6.7, do not)."""
    n = 6001
    t = np.arange(n) * DT
    noise = 0.01 * np.random.default_rng(degree).standard_normal(n)
    x = np.stack([np.sin(2 * np.pi * 3 * t) + 0.3 * t**2 + noise, np.cos(7 * t)], axis=1)
    expected = spectral_derivatives(x, DT, (0, 1, 2), 20.0, 0.2, extension, degree)
    monkeypatch.setattr(spectral_module, "LEAN_PERIOD", 4)
    monkeypatch.setattr(_fft, "SPLIT_FROM", 4)
    lean = spectral_derivatives(x, DT, (0, 1, 2), 20.0, 0.2, extension, degree)
    for order in (0, 1, 2):
        scale = np.max(np.abs(expected[order]))
        tolerance = 1e-7 if degree == 3 else 1e-12
        np.testing.assert_allclose(lean[order], expected[order], rtol=0, atol=tolerance * scale)


@pytest.mark.skipif(not timing.memory_measurable(), reason="needs Linux /proc")
def test_a_long_record_takes_a_quarter_of_the_memory_of_the_whole_transforms():
    """2.4e6 samples (half period 2,400,000 = 1500 x 1600): the lean path's peak, outputs
    included, is under 150 bytes a sample (83 here, 73 at 1e7); numpy's Bluestein transforms and
    the QR fit took 575 bytes a sample at 1e7 (the three outputs: 24)."""
    n = 2_400_001
    x = np.sin(np.arange(n) * 2 * np.pi * 4 * DT)
    method = methods.preset("spectral", "paper-signal")
    estimate, peak_mib = timing.peak_memory_mib(method, x, DT)
    assert peak_mib * 2**20 / n < 150, peak_mib
    t = np.arange(n) * DT
    middle = slice(n // 4, 3 * n // 4)
    omega = 2 * np.pi * 4
    np.testing.assert_allclose(estimate[1][middle], omega * np.cos(omega * t[middle]), atol=1e-6)


@pytest.mark.parametrize(("n", "reach", "reach_end"), [(2001, 383, 100), (301, 383, 100)])
def test_the_taper_weights_rise_from_the_wide_low_pass_to_the_sharp_one(n, reach, reach_end):
    near, weight = taper_weights(n, reach, reach_end)
    full = np.ones(n)
    full[near] = weight
    distance = np.minimum(np.arange(n), np.arange(n)[::-1])
    np.testing.assert_array_equal(full[distance <= reach_end], 0.0)
    np.testing.assert_array_equal(full[distance >= reach], 1.0)
    np.testing.assert_array_equal(full, full[::-1])
    half = full[: n // 2 + 1]
    assert np.all(np.diff(half) >= 0)
    assert np.unique(near).size == near.size  # each sample once, however short the record
