"""The Kalman smoother beside filterpy's batch_filter + rts_smoother, per sample; a tuning
evaluation at a new setting beside PyNumDiff's rtsdiff.

Equal lengths first (group ``kalman-1e4``: both on 1e4 samples, the length of users'
records and of every tuning; target: the method >= 1000x faster), then per sample on long
records (group ``kalman-per-sample``: filterpy on 2e4 samples, about 1 s, the method on 1e6).
Results are checked after timing; no time is asserted.
"""

import numpy as np
import pytest

from diffbench import methods
from diffbench.bench.studies.ratios import filterpy_smoother
from diffbench.bench.studies.timing import noisy_sine
from diffbench.methods.kalman import initial_state

DT = 1e-3


def _signal(size):
    return noisy_sine(size, 0.05)


@pytest.fixture(scope="module")
def kalman():
    method = methods.preset("kalman", "paper-signal")
    return method


def _filterpy_timed(benchmark, kalman, size, rounds):
    """filterpy's smoother on the first ``size`` samples, timed over ``rounds``: the signal
    and the smoothed states."""
    x = _signal(size)
    model = kalman.model(DT)
    mean0, covariance0 = initial_state(x[:, None], model.per_step_coefficient)
    smoothed = benchmark.pedantic(
        filterpy_smoother,
        args=(x, model, mean0, covariance0),
        rounds=rounds,
        iterations=1,
        warmup_rounds=0,
    )
    benchmark.extra_info["samples"] = x.size
    return x, smoothed


@pytest.mark.benchmark(group="kalman-1e4")
def test_kalman_method_1e4(benchmark, kalman):
    x = _signal(10_000)
    kalman(x, DT)  # the setting's first use: the timed calls then run its transient maps
    estimate = benchmark(kalman, x, DT)
    benchmark.extra_info["samples"] = x.size
    model = kalman.model(DT)
    mean0, covariance0 = initial_state(x[:, None], model.per_step_coefficient)
    smoothed = filterpy_smoother(x, model, mean0, covariance0)
    valid = estimate.valid[0]
    np.testing.assert_allclose(estimate[0][valid], smoothed[valid, 0], rtol=0, atol=1e-9)


@pytest.mark.benchmark(group="kalman-1e4")
def test_filterpy_batch_filter_and_rts_smoother_1e4(benchmark, kalman):
    x, smoothed = _filterpy_timed(benchmark, kalman, 10_000, rounds=3)
    assert smoothed.shape == (x.size, kalman.model(DT).states)


@pytest.mark.benchmark(group="kalman-per-sample")
def test_kalman_method_1e6(benchmark, kalman):
    x = _signal(1_000_000)
    kalman(x[:10_000], DT)
    estimate = benchmark(kalman, x, DT)
    benchmark.extra_info["samples"] = x.size
    middle = slice(1000, -1000)
    velocity = 2 * np.pi * 4 * np.cos(2 * np.pi * 4 * np.arange(x.size) * DT)
    assert np.sqrt(np.mean((estimate[1][middle] - velocity[middle]) ** 2)) < 2.0


@pytest.mark.benchmark(group="kalman-per-sample")
def test_filterpy_batch_filter_and_rts_smoother_2e4(benchmark, kalman):
    x, smoothed = _filterpy_timed(benchmark, kalman, 20_000, rounds=2)
    ours = kalman(x, DT)
    valid = ours.valid[0]  # the ends outside the method's own accuracy are masked
    assert valid.mean() > 0.9
    np.testing.assert_allclose(ours[0][valid], smoothed[valid, 0], rtol=0, atol=1e-9)


NEW_SETTINGS = iter(np.geomspace(20.0, 30.0, 100_000))
"""Bandwidths never used before, one per timed call (no call finds its setting's gains,
steady state or ends check already computed)."""


@pytest.mark.benchmark(group="kalman-new-setting-1000")
def test_kalman_at_a_new_bandwidth_1000(benchmark):
    """One tuning evaluation of a setting not seen before (covariance recursion, steady state,
    ends check and the estimate), on the first 1000 samples of the paper signal's seed 0."""
    from diffbench.bench.studies.ratios import _paper_signal_head

    record = _paper_signal_head(1000, 150)
    x = np.asarray(record.x)
    methods.get("kalman", bandwidth_hz=4.9, model_order=3)(x, DT)  # compiled, imported

    def evaluation():
        return methods.get("kalman", bandwidth_hz=float(next(NEW_SETTINGS)), model_order=3)(x, DT)

    estimate = benchmark(evaluation)
    inside = np.asarray(record.interior)
    assert estimate.valid[1][inside].all()
    error = estimate[1][inside] - np.asarray(record.truth[1])[inside]
    assert np.sqrt(np.mean(error**2)) < 0.2 * np.sqrt(np.mean(record.truth[1][inside] ** 2))


@pytest.mark.benchmark(group="kalman-new-setting-1000")
def test_pynumdiff_rtsdiff_one_call_1000(benchmark):
    pynumdiff = pytest.importorskip("pynumdiff")
    from diffbench.bench.studies.ratios import _paper_signal_head

    record = _paper_signal_head(1000, 150)
    x = np.asarray(record.x)
    _, derivative = benchmark(
        pynumdiff.rtsdiff, x, DT, order=3, log_qr_ratio=8.0, forwardbackward=False
    )
    assert derivative.shape == x.shape and np.isfinite(derivative).all()


def _jittered(size):
    """``size`` time stamps of mean step DT jittered by ±30 % (seeded) and the noisy sine at
    them: the grid's jittered records, the real robot's logger."""
    rng = np.random.default_rng(size)
    t = np.cumsum(DT * (1 + 0.3 * rng.uniform(-1, 1, size)))
    return t, np.sin(2 * np.pi * 4 * t) + 0.05 * rng.standard_normal(size)


def _per_step_start(kalman, x, t):
    from diffbench.methods.kalman import irregular_models

    Fs, Qs, _ = irregular_models(kalman.model_order, t, kalman.bandwidth_hz)
    steps = (t - t[0]) / ((t[-1] - t[0]) / (t.size - 1)) + 1.0
    mean0, covariance0 = initial_state(x[:, None], np.ones(kalman.model_order + 1), steps)
    return Fs, Qs, mean0, covariance0


@pytest.mark.benchmark(group="kalman-time-stamps-1e4")
def test_kalman_method_at_time_stamps_1e4(benchmark, kalman):
    """The method at 1e4 jittered stamps (its per-step models, prior, compiled recursion and
    smoother, ends check), beside filterpy's per-step ``batch_filter`` + ``rts_smoother`` on
    the same models; checked against it after timing."""
    from diffbench.methods.kalman import irregular_smooth

    t, x = _jittered(10_000)
    kalman(x, t=t)  # compiled, imported
    estimate = benchmark(kalman, x, t=t)
    benchmark.extra_info["samples"] = x.size
    Fs, Qs, mean0, covariance0 = _per_step_start(kalman, x, t)
    fast = irregular_smooth(x[:, None], Fs, Qs, 1.0, mean0, covariance0)
    np.testing.assert_array_equal(estimate[0], fast[:, 0, 0])


@pytest.mark.benchmark(group="kalman-time-stamps-1e4")
def test_filterpy_per_step_models_1e4(benchmark, kalman):
    from filterpy.kalman import KalmanFilter

    from diffbench.methods.kalman import irregular_smooth

    t, x = _jittered(10_000)
    Fs, Qs, mean0, covariance0 = _per_step_start(kalman, x, t)

    def filterpy_per_step():
        kf = KalmanFilter(dim_x=Fs.shape[1], dim_z=1)
        kf.x, kf.P = mean0[:, 0].copy(), covariance0.copy()
        kf.H, kf.R = np.eye(1, Fs.shape[1]), np.eye(1)
        means, covariances, _, _ = kf.batch_filter(x, Fs=Fs, Qs=Qs)
        return kf.rts_smoother(means, covariances, Fs=Fs, Qs=Qs)[0]

    smoothed = benchmark.pedantic(filterpy_per_step, rounds=2, iterations=1, warmup_rounds=0)
    benchmark.extra_info["samples"] = x.size
    fast = irregular_smooth(x[:, None], Fs, Qs, 1.0, mean0, covariance0)[:, :, 0]
    # the rounding bound of tests/methods/test_kalman.py's per-step test (eps (cond V + 4n))
    states = Fs.shape[1]
    steps = (t - t[0]) / ((t[-1] - t[0]) / (t.size - 1)) + 1.0
    vandermonde = steps[: 4 * states, None] ** np.arange(states)[None, :]
    allowed = 2 * np.finfo(float).eps * (np.linalg.cond(vandermonde) + 4 * x.size)
    assert np.max(np.abs(fast - smoothed)) <= allowed * np.max(np.abs(x))
