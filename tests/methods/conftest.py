"""Method instances every contract test runs on: defaults, each preset, and extra settings;
the traced peak memory of a call."""

import tracemalloc

import numpy as np
import pytest

from diffbench import methods

EXTRA = {
    "finite_difference": [{"accuracy_order": 4}, {"accuracy_order": 6}],
    "savitzky_golay": [{"window_s": 0.05, "degree": 2}, {"window_s": 0.03, "degree": 5}],
    "sindy_smoothing": [{"window_s": 0.05, "degree": 5, "accuracy_order": 4}],
    "butterworth": [{"order": 2, "cutoff_hz": 40.0}],
    "gaussian_process": [
        {"length_scale_s": 0.003, "noise_ratio": 1.0},
        {"length_scale_s": 0.3, "noise_ratio": 0.01},
    ],
    "spectral": [
        {"extension": "even", "rolloff": 0.5, "cutoff_hz": 40.0},
        {"extension": "none", "rolloff": 0.3, "cutoff_hz": 80.0},
        {"extension": "odd", "rolloff": 0.0, "cutoff_hz": 40.0},
        {"extension": "odd-fitted", "fit_degree": 3, "cutoff_hz": 30.0},
        {"extension": "odd-fitted", "fit_degree": 0, "cutoff_hz": 30.0},
    ],
    "jacobi": [
        {"rule": "least_squares", "window_s": 0.05, "accel_window_s": 0.08},
        {
            "rule": "least_squares",
            "kappa": 2.0,
            "mu": 5.0,
            "q": 3,
            "window_s": 0.04,
            "accel_window_s": 0.04,
        },
        {
            "rule": "linear",
            "kappa": -0.5,
            "mu": 0.5,
            "q": 2,
            "window_s": 0.06,
            "accel_window_s": 0.1,
        },
        {
            "rule": "least_squares",
            "kappa": 0.0,
            "mu": 0.0,
            "q": 1,
            "window_s": 0.03,
            "accel_window_s": 0.03,
        },
    ],
}


def method_cases():
    cases = []
    for name in methods.available():
        if name.startswith("_test"):
            continue
        cls = methods.method_class(name)
        settings = [("defaults", {})]
        settings += [(f"preset-{key}", dict(p.values)) for key, p in cls.presets.items()]
        settings += [(f"extra{i}", params) for i, params in enumerate(EXTRA.get(name, []))]
        cases += [pytest.param(name, params, id=f"{name}-{label}") for label, params in settings]
    return cases


@pytest.fixture
def peak_arrays():
    """``peak_arrays(method, n)``: the peak memory Python allocates during ``method(x, 1e-3)``
    on a seeded noisy sine of n samples (outputs and temporaries, by tracemalloc), in arrays of
    n float64. A first call on the same record fills the caches (the end check's probes) and is
    not counted. The 1 GB target at 1e7 samples is 12.5 arrays."""

    def measure(method, n: int) -> float:
        rng = np.random.default_rng(0)
        x = np.sin(2 * np.pi * 4 * np.arange(n) * 1e-3) + 0.01 * rng.standard_normal(n)
        method(x, 1e-3)
        tracemalloc.start()
        try:
            method(x, 1e-3)
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        return peak / (8 * n)

    return measure
