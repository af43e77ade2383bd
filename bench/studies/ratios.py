"""The speed comparisons with the peers (``results/timing/ratios.md``): the Kalman smoother
against filterpy at equal and unequal lengths, every FIR method against
``scipy.signal.oaconvolve``, a Kalman tuning evaluation at a new setting against PyNumDiff's
``rtsdiff``, and oracle tuning against PyNumDiff's ``optimize``, each measured on the same
data in one run."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench.core import tuning
from diffbench.bench.core.scores import estimate_on
from diffbench.bench.studies.timing import DT, _best_seconds, _package, noisy_sine
from diffbench.methods._ends import _trusted, check_reaches, trusted_samples
from diffbench.methods.kalman import initial_state


def filterpy_smoother(x: np.ndarray, model, mean0: np.ndarray, covariance0: np.ndarray):
    """filterpy's ``batch_filter`` + ``rts_smoother`` on the scalar record ``x`` with the
    :class:`~diffbench.methods.kalman.KalmanModel` ``model`` (its F, Q, R; H picks the first
    state) from the prior ``mean0``, ``covariance0``: the smoothed states, shape (n, m)."""
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=model.states, dim_z=1)
    kf.F, kf.Q, kf.R = model.F, model.Q, np.array([[model.R]])
    kf.H = np.eye(1, model.states)
    kf.x, kf.P = mean0.copy(), covariance0.copy()
    means, covariances, _, _ = kf.batch_filter(x)
    return kf.rts_smoother(means, covariances)[0][:, :, 0]


def kalman_against_filterpy(
    samples: int = 1_000_000, filterpy_samples: int = 80_000, repeats: int = 3
) -> dict:
    """The Kalman smoother (paper-signal preset) on ``samples`` against filterpy's
    ``batch_filter`` + ``rts_smoother`` with the same model and prior on the first
    ``filterpy_samples`` of them, per sample (by default filterpy, a Python loop over
    samples, on a shorter record: 80,000 samples; equal lengths compare what a user's record
    costs), and the largest difference of their
    smoothed positions on the samples the method keeps. Each side: the best of ``repeats``
    timings, ours each the mean of as many consecutive calls as make 1e6 samples (at most
    100; one call of filterpy is itself a loop over the samples), so that neither side's
    best is taken over more draws of the machine's noise."""

    kalman = methods.preset("kalman", "paper-signal")
    x = noisy_sine(samples, 0.05)
    kalman(x[:10_000], DT)
    loops = min(100, max(1, 1_000_000 // samples))

    def calls():
        for _ in range(loops):
            kalman(x, DT)

    ours = _best_seconds(calls, repeats) / loops / samples
    short = x[:filterpy_samples]
    model = kalman.model(DT)
    mean0, covariance0 = initial_state(short[:, None], model.per_step_coefficient)
    theirs = (
        _best_seconds(lambda: filterpy_smoother(short, model, mean0, covariance0), repeats)
        / filterpy_samples
    )
    estimate = kalman(short, DT)
    kept = estimate.valid[0]
    smoothed = filterpy_smoother(short, model, mean0, covariance0)
    lengths = (
        f"both {samples:,} samples"
        if samples == filterpy_samples
        else f"ours {samples:,}, filterpy {filterpy_samples:,} samples"
    )
    return {
        "comparison": f"Kalman smoother, per sample ({lengths})",
        "ours": "kalman (paper-signal preset)",
        "peer": "filterpy batch_filter + rts_smoother, same model",
        "peer_package": _package("filterpy"),
        "ours_s": ours,
        "peer_s": theirs,
        "unit": "s per sample",
        "ratio": theirs / ours,
        "target": 1000.0,
        "agreement": float(np.max(np.abs(estimate[0][kept] - smoothed[kept, 0]))),
    }


FIR_METHODS = ("savitzky_golay", "jacobi", "gaussian_kernel", "finite_difference")
"""The FIR methods timed against ``scipy.signal.oaconvolve`` on their own kernels."""

FIR_SIZES = (10_000, 100_000, 1_000_000)


def fir_against_oaconvolve(
    name: str = "jacobi", samples: int = 1_000_000, orders=(0, 1, 2), repeats: int = 7
) -> dict:
    """A FIR method (paper-signal preset) for ``orders`` in one call against one
    ``scipy.signal.oaconvolve`` call ("valid") per order with its kernels, on the same
    samples (interleaved runs, best of ``repeats``; each run of the method estimates every
    sample, its ends included), and the largest difference on the samples both estimate,
    relative to each output's scale. Target: 1 for one order, 1.3 for several."""
    from scipy import signal as sps

    method = methods.preset(name, "paper-signal")
    x = np.random.default_rng(2015).standard_normal(samples)
    method(x[:10_000], DT, orders=orders)
    kernels = [np.array(method.taps(order, DT)[::-1]) for order in orders]
    ours, theirs = np.inf, np.inf
    for _ in range(repeats):
        ours = min(ours, _best_seconds(lambda: method(x, DT, orders=orders), 1))
        theirs = min(
            theirs,
            _best_seconds(
                lambda: [sps.oaconvolve(x, kernel, mode="valid") for kernel in kernels], 1
            ),
        )
    estimate = method(x, DT, orders=orders)
    agreement = 0.0
    for order, kernel in zip(orders, kernels, strict=True):
        reference = sps.oaconvolve(x, kernel, mode="valid")
        half = kernel.size // 2
        inside = estimate[order][half : samples - half]
        agreement = max(
            agreement, float(np.max(np.abs(inside - reference)) / np.max(np.abs(reference)))
        )
    several = len(orders) > 1
    asked = f"orders {orders[0]}-{orders[-1]}, one call" if several else f"order {orders[0]}"
    calls = f"{len(orders)} scipy.signal.oaconvolve calls" if several else "scipy.signal.oaconvolve"
    return {
        "comparison": f"{name} {asked}, {samples:,} samples",
        "ours": f"{name} (paper-signal preset)",
        "peer": f"{calls} with its kernels",
        "peer_package": _package("scipy"),
        "ours_s": ours,
        "peer_s": theirs,
        "unit": f"s per {samples:g} samples",
        "ratio": theirs / ours,
        "target": 1.3 if several else 1.0,
        "agreement": agreement,
    }


TUNING_PEERS = {
    "butterworth": "butterdiff",
    "savitzky_golay": "savgoldiff",
    "kalman": "rtsdiff",
    "spectral": "spectraldiff",
}
"""Our methods and PyNumDiff's functions of the same family, tuned side by side."""


def forget_settings() -> None:
    """Empty the bounded caches of :mod:`diffbench.methods` (filter designs, kernels, end-trust
    masks, end fits: ``functools.lru_cache`` with a ``maxsize``), which hold what was computed
    for given settings; the unbounded ones (the registry, the plugins found) stay."""
    for module in list(sys.modules.values()):
        if not getattr(module, "__name__", "").startswith("diffbench.methods"):
            continue
        for value in vars(module).values():
            if isinstance(value, type):  # a cache's class, not a cache
                continue
            parameters = getattr(value, "cache_parameters", None)
            if parameters is not None and parameters()["maxsize"] is not None:
                value.cache_clear()


def _paper_signal_head(samples: int, margin: int):
    """The first ``samples`` of paper-signal seed 0, scored on ``[margin, samples - margin)``
    (PyNumDiff's ``padding``)."""
    whole = signals.get_scenario("paper-signal").realise(0)
    interior = np.zeros(samples, dtype=bool)
    interior[margin : samples - margin] = True
    return whole.stretch(slice(0, samples), interior)


ENDS_SHARE_SETTINGS = 40
"""The settings of a tuning's history whose evaluations :func:`ends_check_share` times."""


def tuning_against_pynumdiff(
    samples: int = 1000, margin: int = 150, names=None, repeats: int = 3
) -> list[dict]:
    """Oracle tuning for ẋ (RMSE against the exact derivative on ``[margin, samples - margin)``
    of the first ``samples`` of paper-signal seed 0) by :func:`diffbench.bench.core.tuning.tune`
    against PyNumDiff's ``optimize`` (the same objective, its default search space), for each
    pair of :data:`TUNING_PEERS` (``names``: ours, default all). Both sides are warmed up alike,
    by an untimed run of the whole tuning (PyNumDiff's with ``maxiter=1``), so that one-off costs
    of the libraries (scipy loading its Sobol direction numbers: 13 ms) are not timed. Ours is
    then timed ``repeats`` times, each after :func:`forget_settings` (so no run finds the
    settings it evaluates already computed), the best counting; PyNumDiff, which keeps no
    caches, ``repeats - 1`` times serially (at least once) and once with its process pool,
    the fastest counting. Also the RMSE each tuned setting reaches, and the ratio that
    judges the tuning: PyNumDiff's time over ours *to reach* an RMSE at most PyNumDiff's (the
    time of our search's first evaluation that does, :attr:`TuningResult.elapsed`; the best
    of our runs; NaN where none does).

    Needs PyNumDiff (the ``peers`` extra)."""
    import pynumdiff
    from pynumdiff.optimize import optimize

    record = _paper_signal_head(samples, margin)
    x, truth = np.asarray(record.x), np.asarray(record.truth[1])
    inside = np.asarray(record.interior)
    rows = []
    for name in TUNING_PEERS if names is None else names:
        function = getattr(pynumdiff, TUNING_PEERS[name])
        tuning.tune(name, record, 1, "oracle")
        ours_s, runs = np.inf, []
        for _ in range(repeats):
            forget_settings()
            start = time.perf_counter()
            ours = tuning.tune(name, record, 1, "oracle")
            ours_s = min(ours_s, time.perf_counter() - start)
            runs.append(ours)
        function(
            x,
            DT,
            **optimize(
                function, x, DT, dxdt_truth=truth, padding=margin, maxiter=1, parallel=False
            )[0],
        )
        peer = {}
        for parallel in [False] * max(repeats - 1, 1) + [True]:
            start = time.perf_counter()
            params, _ = optimize(
                function, x, DT, dxdt_truth=truth, padding=margin, parallel=parallel
            )
            seconds = time.perf_counter() - start
            if parallel not in peer or seconds < peer[parallel][0]:
                peer[parallel] = (seconds, params)
        fastest = min(peer, key=lambda p: peer[p][0])
        params = peer[fastest][1]
        peer_rmse = float(
            np.sqrt(np.mean((function(x, DT, **params)[1][inside] - truth[inside]) ** 2))
        )
        reach_s = min(_time_to_reach(run, peer_rmse) for run in runs)
        settings = [params for params, _ in ours.history[:ENDS_SHARE_SETTINGS]]
        rows.append(
            {
                "comparison": "oracle tuning for ẋ to PyNumDiff's RMSE, 1000 samples",
                "ours": name,
                "peer": f"pynumdiff.optimize({TUNING_PEERS[name]})",
                "peer_package": _package("pynumdiff"),
                "ours_s": reach_s,
                "peer_s": peer[fastest][0],
                "unit": "s to an RMSE ≤ the peer's",
                "ratio": peer[fastest][0] / reach_s,
                "target": 20.0,
                "tuning_s": ours_s,
                "agreement": float("nan"),
                "peer_serial_s": peer[False][0],
                "peer_pool_s": peer[True][0],
                "ours_rmse": ours.loss,
                "peer_rmse": peer_rmse,
                "ours_params": ours.params,
                "peer_params": params,
                "ours_evaluations": ours.evaluations,
                "ends_check_share": ends_check_share(name, record, settings),
            }
        )
    return rows


def ends_check_share(name: str, record, settings, order: int = 1) -> float:
    """The share of an oracle tuning's evaluation of ``name`` at a new setting that its ends
    check takes (:func:`diffbench.methods._ends.trusted_samples`, which marks the end samples
    a linear method can be trusted on): over ``settings`` (parameter dicts, e.g. a tuning's
    history), the check's seconds over the evaluation's, each evaluation timed as the tuner
    makes it (the interior read, with its valid marks) with the methods' caches emptied
    first, the check timed again alone with only its own cache emptied (the filter design it
    reads already built, as in the evaluation). 0 where the check cannot reach the interior
    read (the evaluation skips it)."""
    cls = methods.method_class(name)
    inside = np.asarray(record.interior, dtype=bool)
    reads = tuning.read_span(inside)
    n, dt = inside.size, record.dt_s
    evaluations, checks = 0.0, 0.0
    for params in settings:
        method = cls(**params)
        forget_settings()
        start = time.perf_counter()
        try:
            estimate_on(method, record, orders=(order,), reads=reads)
        except ValueError:  # a setting the record refuses: the tuner's +inf, no check
            continue
        evaluations += time.perf_counter() - start
        reach = method.end_reach(dt) if cls.linear else None
        if reach and check_reaches(method, n, dt, *reads):
            _trusted.cache_clear()
            start = time.perf_counter()
            trusted_samples(method, n, dt, (order,), skip=method._unread_ends(n, dt, reads))
            checks += time.perf_counter() - start
    return checks / evaluations if evaluations else float("nan")


def _time_to_reach(result: tuning.TuningResult, rmse: float) -> float:
    """Seconds from the start of ``result``'s search to its first evaluation with a loss at
    most ``rmse``; NaN where none reaches it."""
    for (_, loss), seconds in zip(result.history, result.elapsed, strict=True):
        if loss <= rmse:
            return seconds
    return float("nan")


def kalman_new_bandwidth(samples: int = 1000, settings: int = 20, repeats: int = 3) -> dict:
    """What a tuning evaluation of the Kalman smoother costs at a bandwidth not seen before:
    the method called on the first ``samples`` of paper-signal seed 0 at ``settings``
    bandwidths (5-60 Hz, model order 3), its covariance recursion, steady state and ends
    check included (each run after :func:`forget_settings`; the best of ``repeats``), per
    setting; beside it one call of PyNumDiff's ``rtsdiff`` (order 3, its own Kalman smoother,
    which keeps no state between calls) at as many settings, per call. Needs PyNumDiff."""
    import pynumdiff

    x = np.asarray(_paper_signal_head(samples, 0).x)
    bandwidths = np.geomspace(5.0, 60.0, settings)
    methods.get("kalman", bandwidth_hz=30.5, model_order=3)(x, DT)  # lazy imports, compiling

    def ours_once():
        for bandwidth in bandwidths:
            methods.get("kalman", bandwidth_hz=float(bandwidth), model_order=3)(x, DT)

    ours = np.inf
    for _ in range(repeats):
        forget_settings()
        start = time.perf_counter()
        ours_once()
        ours = min(ours, time.perf_counter() - start)
    ratios = np.linspace(2.0, 12.0, settings)

    def theirs_once():
        for log_qr_ratio in ratios:
            pynumdiff.rtsdiff(
                x, DT, order=3, log_qr_ratio=float(log_qr_ratio), forwardbackward=False
            )

    theirs = _best_seconds(theirs_once, repeats)
    return {
        "comparison": f"Kalman smoother, a new setting ({samples:,} samples)",
        "ours": "kalman at a new bandwidth_hz (ends check included)",
        "peer": "pynumdiff.rtsdiff, one call",
        "peer_package": _package("pynumdiff"),
        "ours_s": ours / settings,
        "peer_s": theirs / settings,
        "unit": "s per setting",
        "ratio": theirs / ours,
        "target": float("nan"),
        "agreement": float("nan"),
    }


def speed_ratios(progress=None) -> pd.DataFrame:
    """The speed comparisons of :func:`kalman_against_filterpy` (at equal lengths, 1e4 and
    1e5 samples, and per sample with ours on 1e6), :func:`fir_against_oaconvolve` (each FIR
    method at each of :data:`FIR_SIZES`, one order and orders 0-2),
    :func:`kalman_new_bandwidth` and
    :func:`tuning_against_pynumdiff` (the last two left out, with a line to ``progress``,
    where PyNumDiff is not installed), one row each."""
    rows = [
        kalman_against_filterpy(10_000, 10_000),
        kalman_against_filterpy(100_000, 100_000, repeats=2),
        kalman_against_filterpy(),
    ]
    rows += [
        fir_against_oaconvolve(name, samples, orders, repeats=max(3, 10**6 // samples))
        for name in FIR_METHODS
        for samples in FIR_SIZES
        for orders in ((1,), (0, 1, 2))
    ]
    try:
        import pynumdiff  # noqa: F401
    except ImportError:
        if progress is not None:
            progress("PyNumDiff is not installed (the peers extra): no tuning ratio")
    else:
        rows.append(kalman_new_bandwidth())
        rows += tuning_against_pynumdiff()
    return pd.DataFrame(rows)


def write_ratios(directory: Path, table: pd.DataFrame) -> list[Path]:
    """``ratios.md`` and ``ratios.csv``: each comparison's times, ratio (peer time / ours) and
    target, and how closely the outputs agree."""
    directory.mkdir(parents=True, exist_ok=True)
    csv, markdown = directory / "ratios.csv", directory / "ratios.md"
    table.to_csv(csv, index=False)
    lines = [
        "# Speed against the peers (measured in one run, this machine)",
        "",
        "ratio = the peer's time / ours, on the same data (per sample where the record "
        "lengths differ). Agreement: the largest difference of the outputs (the Kalman "
        "positions on the samples the method keeps; Jacobi's relative to each output's "
        "largest value).",
        "",
        "| comparison | ours | peer | ours (s) | peer (s) | unit | ratio | target | agreement |",
        "|---|---|---|---:|---:|---|---:|---:|---:|",
    ]
    for row in table.itertuples(index=False):
        agreement = f"{row.agreement:.1e}" if np.isfinite(row.agreement) else "—"
        ours = f"{row.ours_s:.3g}" if np.isfinite(row.ours_s) else "not reached"
        ratio = f"{row.ratio:.3g}" if np.isfinite(row.ratio) else "—"
        target = f"{row.target:g}" if np.isfinite(row.target) else "—"
        lines.append(
            f"| {row.comparison} | {row.ours} | {row.peer} ({row.peer_package}) | "
            f"{ours} | {row.peer_s:.3g} | {row.unit} | {ratio} | {target} | {agreement} |"
        )
    tunings = table[table["comparison"].str.startswith("oracle tuning")]
    if len(tunings):
        lines += [
            "",
            "## Oracle tuning against PyNumDiff's optimize",
            "",
            "The first 1000 samples of paper-signal seed 0 (dt = 1 ms), RMSE of ẋ against "
            "the truth on samples 150..849 (PyNumDiff's padding = 150), the same "
            "objective for both, each warmed up by an untimed run. PyNumDiff with its "
            "default search space, twice serially and once with its process pool (the "
            "fastest run counts); ours with its default budget, the end-trust check of "
            "every setting included (PyNumDiff has none), the best of three runs, each "
            "with the methods' caches emptied first. *to PyNumDiff's RMSE*: from the start "
            "of our search to its first setting at least as accurate as PyNumDiff's "
            "result (the time the ratio above takes); *whole*: to the end of our search; "
            f"*ends check*: its share of an evaluation at a new setting (the first "
            f"{ENDS_SHARE_SETTINGS} settings of our search; 0 where the method's ends cannot "
            "reach the samples scored, so the check is skipped).",
            "",
            "| ours | to PyNumDiff's RMSE (s) | whole (s) | evaluations | ends check | RMSE ẋ "
            "| setting | PyNumDiff | serial (s) | pool (s) | RMSE ẋ | setting |",
            "|---|---:|---:|---:|---:|---:|---|---|---:|---:|---:|---|",
        ]
        for row in tunings.itertuples(index=False):
            reach = f"{row.ours_s:.3g}" if np.isfinite(row.ours_s) else "not reached"
            lines.append(
                f"| {row.ours} | {reach} | {row.tuning_s:.3g} | {int(row.ours_evaluations)} | "
                f"{row.ends_check_share:.0%} | {row.ours_rmse:.4g} | "
                f"{_setting(row.ours_params)} | {row.peer} | "
                f"{row.peer_serial_s:.3g} | {row.peer_pool_s:.3g} | "
                f"{row.peer_rmse:.4g} | {_setting(row.peer_params)} |"
            )
    markdown.write_text("\n".join([*lines, ""]), encoding="utf-8")
    return [markdown, csv]


def _setting(params: dict) -> str:
    return ", ".join(
        f"{key} {value:.4g}" if isinstance(value, float) else f"{key} {value}"
        for key, value in params.items()
    )
