"""Throughput and peak memory of every registered method (at its paper-signal preset) against
signal length, and the speed ratios against the peers (filterpy's Kalman smoother, scipy's
``oaconvolve``, PyNumDiff's ``optimize``), each measured in one run."""

from __future__ import annotations

import sys
import time
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench.core import tuning
from diffbench.bench.core.plan import preset_entry
from diffbench.bench.report import figures
from diffbench.methods.kalman import initial_state

DT = 1e-3

SIZE_CAPS = {
    "derivative.savitzky_golay": (10_000, "a Python loop over samples: ~0.13 s per 1e3"),
    "pynumdiff.tvrdiff": (10_000, "a cvxpy problem per call: ~0.1 s per 1e3, superlinear"),
    "pynumdiff.polydiff": (100_000, "~0.09 s per 1e3 samples"),
    "pynumdiff.rtsdiff": (100_000, "a Python loop over samples: ~0.05 s per 1e3"),
    "derivative.spline": (100_000, "~0.04 s per 1e3: 3.8 s at 1e5"),
    "pynumdiff.splinediff": (10_000, "scipy's make_splrep knot search: 4.4 s at 1e4, 96 s at 3e4"),
    "levant": (
        1_000_000,
        "a Python loop with an implicit step per sample: 1.8e4 samples/s on "
        "the noisy sine (linear to 1e6), about 9 min at 1e7",
    ),
}
"""Methods timed only up to a record length (and why): the slow ones would take minutes at 1e6
samples. A method's own ``max_samples`` caps it too (the dense O(N³) peers)."""


def size_cap(name: str, dt: float = DT) -> tuple[int | None, str]:
    """The longest record method ``name`` is timed on (None: no cap) and why."""
    method = timing_instance(name)
    own = method.max_samples(dt)
    cap, why = SIZE_CAPS.get(name, (None, ""))
    if own is not None and (cap is None or own < cap):
        return own, method.max_samples_reason
    return cap, why


def timed_sizes(name: str, sizes, dt: float = DT) -> list[int]:
    """The record lengths of ``sizes`` method ``name`` is timed on: those within its
    :func:`size_cap`, or its cap alone when that lies below them all (the dense O(N³) peers),
    so that every method has a figure."""
    cap, _ = size_cap(name, dt)
    return [size for size in sizes if cap is None or size <= cap] or [cap]


def timing_instance(name: str) -> methods.Method:
    """Method ``name`` at its paper-signal preset (its class defaults if it has none, as a
    plugin may)."""
    return methods.get(name, **preset_entry(name, "paper-signal").params)


def noisy_sine(size: int, noise_std: float) -> np.ndarray:
    """A 4 Hz unit sine sampled every ``DT`` seconds, plus white Gaussian noise of standard
    deviation ``noise_std`` seeded by ``size``: the record every timing runs on."""
    t = np.arange(size) * DT
    return np.sin(2 * np.pi * 4 * t) + noise_std * np.random.default_rng(size).standard_normal(size)


SIZES = (10_000, 100_000, 1_000_000, 10_000_000)
"""The record lengths timed: the cost of each method should grow linearly across them."""

_STATUS = Path("/proc/self/status")
_CLEAR_REFS = Path("/proc/self/clear_refs")


def _status_kib(field: str) -> int:
    for line in _STATUS.read_text(encoding="ascii").splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise KeyError(field)


def _reset_peak() -> bool:
    """Reset the kernel's high-water mark of resident memory to the current resident memory
    (``/proc/self/clear_refs`` = 5, Linux >= 4.0); False where it cannot be reset or read."""
    try:
        _CLEAR_REFS.write_text("5", encoding="ascii")
        _status_kib("VmHWM")
    except (OSError, KeyError):
        return False
    return True


def memory_measurable() -> bool:
    """True where the peak resident memory can be reset and read (Linux ``/proc``)."""
    return _reset_peak()


def peak_memory_mib(function, *args, **kwargs) -> tuple[object, float]:
    """Call ``function`` and return its result and its peak resident memory above what the
    process held when it was called, in MiB (NaN where :func:`memory_measurable` is false).

    The kernel's high-water mark is reset first (:func:`_reset_peak`), so the peak is the
    call's own: its outputs and temporaries, not the input."""
    if not _reset_peak():
        return function(*args, **kwargs), float("nan")
    before = _status_kib("VmRSS")
    result = function(*args, **kwargs)
    return result, (_status_kib("VmHWM") - before) / 1024


def throughput(sizes=SIZES, repeats: int = 3, names=None, progress=None) -> pd.DataFrame:
    """Samples per second and peak memory of each method on a seeded noisy 4 Hz sine of each
    size (orders 0, 1, 2 estimated; the best of ``repeats`` runs after a warm-up, one run from
    1e6 samples on), and the growth of the time per sample from the smallest to the largest
    size timed (1 = linear). The peak memory (MiB above the input, :func:`peak_memory_mib`) is
    that of the first timed run. Sizes past a method's cap are left out, see
    :func:`timed_sizes`. ``names``: the methods timed (default: every registered one, offline
    and causal). ``progress``: called with a line after each method."""
    records = []
    for name in methods.available(causal=None) if names is None else names:
        method = timing_instance(name)
        timed = timed_sizes(name, sizes)
        method(np.zeros(min(5000, timed[0] // 4)), DT)  # warm-up: lazy imports, kernel caches
        times = {}
        for size in timed:
            x = noisy_sine(size, 0.01)
            best, peak = np.inf, float("nan")
            for run in range(repeats if size < 1_000_000 else 1):
                start = time.perf_counter()
                if run == 0:
                    estimate, peak = peak_memory_mib(method, x, DT)
                else:
                    estimate = method(x, DT)
                best = min(best, time.perf_counter() - start)
                del estimate
            times[size] = best
            records.append(
                {
                    "method": name,
                    "package": methods.package_of(name),
                    "causal": methods.method_class(name).causal,
                    "samples": size,
                    "seconds": best,
                    "samples_per_s": size / best,
                    "peak_mib": peak,
                }
            )
        growth = (times[timed[-1]] / timed[-1]) / (times[timed[0]] / timed[0])
        for record in records[-len(timed) :]:
            record["growth_per_sample"] = growth
        if progress is not None:
            last = records[-1]
            progress(
                f"{name}: {last['samples_per_s']:.3g} samples/s, "
                f"{last['peak_mib']:.0f} MiB at {last['samples']:g} samples"
            )
    return pd.DataFrame(records)


def write_throughput(directory: Path, table: pd.DataFrame) -> list[Path]:
    """``throughput.md`` (samples/s per method and size, the growth of the time per sample,
    and the peak memory per method and size), ``throughput.csv`` and ``growth.png`` (time per
    sample against record length)."""
    directory.mkdir(parents=True, exist_ok=True)
    csv, markdown = directory / "throughput.csv", directory / "throughput.md"
    table.to_csv(csv, index=False)
    sizes = sorted(table["samples"].unique())
    header = " | ".join(f"{s:.0e}" for s in sizes)
    lines = [
        "# Throughput (samples/s, orders 0-2, paper-signal presets or class defaults, best "
        "of repeats)",
        "",
        "Time per sample at the largest size timed over that at the smallest: 1 is linear "
        "growth (— where one size only was timed). — in a size column: not timed at that "
        "size (see the caps below).",
        "",
        f"| method | package | {header} | growth |",
        "|---|---|" + "---|" * (len(sizes) + 1),
    ]
    memory = [
        "",
        "## Peak memory (MiB above the input, orders 0-2 in one call)",
        "",
        "The resident memory the call adds at its peak (its outputs and temporaries; the "
        "input of 8 bytes a sample is not counted), read from the kernel's high-water "
        "mark reset before the call. Three float64 outputs take 24 bytes a sample "
        "(229 MiB at 1e7). Only memory newly taken from the system counts: on short "
        "records the process mostly reuses memory it freed before, hence the zeros; the "
        "1e7 column is the one to read.",
        "",
        f"| method | {header} |",
        "|---|" + "---|" * len(sizes),
    ]
    caps = []
    for name, group in table.groupby("method"):
        rates = group.set_index("samples")["samples_per_s"]
        cells = " | ".join(f"{rates[s]:.3g}" if s in rates.index else "—" for s in sizes)
        package = group["package"].iloc[0]
        growth = f"{group['growth_per_sample'].iloc[0]:.2f}" if len(rates) > 1 else "—"
        lines.append(f"| {name} | {package} | {cells} | {growth} |")
        if "peak_mib" in group:
            peaks = group.set_index("samples")["peak_mib"]
            memory.append(
                f"| {name} | "
                + " | ".join(
                    f"{peaks[s]:.0f}" if s in peaks.index and np.isfinite(peaks[s]) else "—"
                    for s in sizes
                )
                + " |"
            )
        cap, why = size_cap(name)
        if cap is not None and cap < max(sizes):
            caps.append(f"- {name}: timed up to {cap:g} samples ({why})")
    if caps:
        lines += ["", "Capped:", *caps]
    if "peak_mib" in table:
        lines += memory
    markdown.write_text("\n".join([*lines, ""]), encoding="utf-8")
    return [markdown, csv, write_growth_figure(table, directory / "growth.png")]


def write_growth_figure(table: pd.DataFrame, path: Path) -> Path:
    """Time per sample (µs) against record length, log-log, one line per method: a flat line is
    linear cost; the causal methods dashed panel beside the offline ones."""
    plt = figures.pyplot()
    causal = table["causal"] if "causal" in table else pd.Series(False, index=table.index)
    kinds = [(False, "offline"), (True, "causal")] if causal.any() else [(False, "offline")]
    fig, axes = plt.subplots(1, len(kinds), figsize=(7.5 * len(kinds), 5.2), squeeze=False)
    styles = figures.method_styles(sorted(set(table["method"])))
    for axis, (kind, label) in zip(axes[0], kinds, strict=True):
        for name, group in table[causal == kind].groupby("method"):
            group = group.sort_values("samples")
            axis.plot(
                group["samples"],
                1e6 * group["seconds"] / group["samples"],
                marker=styles[name].marker,
                label=name,
                **styles[name].line(),
            )
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel("samples")
        axis.set_ylabel("µs per sample (orders 0-2)")
        axis.set_title(f"{label} methods: flat = linear cost")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=7, ncol=2)
    return figures.save_figure(fig, path)


# --- speed ratios against the peers, each measured in one run ------------------------------
def _package(name: str) -> str:
    return f"{name} {metadata.version(name)}"


def _best_seconds(function, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


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
    samples, on a shorter record: 80,000 samples, long enough for the smoother's block path,
    :data:`~diffbench.methods.kalman.BLOCKED_FROM`, which it takes on the long record; equal
    lengths compare what a user's record costs), and the largest difference of their
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


def jacobi_against_oaconvolve(samples: int = 1_000_000, repeats: int = 7) -> dict:
    """Jacobi orders 0-2 in one call (paper-signal preset) against three
    ``scipy.signal.oaconvolve`` calls with its kernels, on the same samples (interleaved runs,
    best of ``repeats``), and the largest difference on the samples both estimate, relative to
    each output's scale."""
    from scipy import signal as sps

    jacobi = methods.preset("jacobi", "paper-signal")
    x = np.random.default_rng(2015).standard_normal(samples)
    jacobi(x[:10_000], DT)
    kernels = [jacobi.taps(order, DT)[::-1].copy() for order in (0, 1, 2)]
    ours, theirs = np.inf, np.inf
    for _ in range(repeats):
        ours = min(ours, _best_seconds(lambda: jacobi(x, DT, orders=(0, 1, 2)), 1))
        theirs = min(
            theirs,
            _best_seconds(
                lambda: [sps.oaconvolve(x, kernel, mode="valid") for kernel in kernels], 1
            ),
        )
    estimate = jacobi(x, DT, orders=(0, 1, 2))
    agreement = 0.0
    for order, kernel in zip((0, 1, 2), kernels, strict=True):
        reference = sps.oaconvolve(x, kernel, mode="valid")
        half = kernel.size // 2
        inside = estimate[order][half : samples - half]
        agreement = max(
            agreement, float(np.max(np.abs(inside - reference)) / np.max(np.abs(reference)))
        )
    return {
        "comparison": "Jacobi orders 0-2, one call",
        "ours": "jacobi (paper-signal preset)",
        "peer": "three scipy.signal.oaconvolve calls with its kernels",
        "peer_package": _package("scipy"),
        "ours_s": ours,
        "peer_s": theirs,
        "unit": f"s per {samples:g} samples",
        "ratio": theirs / ours,
        "target": 1.3,
        "agreement": agreement,
    }


TUNING_PEERS = {"butterworth": "butterdiff", "savitzky_golay": "savgoldiff", "kalman": "rtsdiff"}
"""Our methods and PyNumDiff's functions of the same family, tuned side by side."""


def forget_settings() -> None:
    """Empty the bounded caches of :mod:`diffbench.methods` (filter designs, kernels, end-trust
    masks, end fits: ``functools.lru_cache`` with a ``maxsize``), which hold what was computed
    for given settings; the unbounded ones (the registry, the plugins found) stay."""
    for module in list(sys.modules.values()):
        if not getattr(module, "__name__", "").startswith("diffbench.methods"):
            continue
        for value in vars(module).values():
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
    the fastest counting. Also the RMSE each tuned setting reaches.

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
        ours_s = np.inf
        for _ in range(repeats):
            forget_settings()
            start = time.perf_counter()
            ours = tuning.tune(name, record, 1, "oracle")
            ours_s = min(ours_s, time.perf_counter() - start)
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
        rows.append(
            {
                "comparison": "oracle tuning for ẋ, 1000 samples",
                "ours": name,
                "peer": f"pynumdiff.optimize({TUNING_PEERS[name]})",
                "peer_package": _package("pynumdiff"),
                "ours_s": ours_s,
                "peer_s": peer[fastest][0],
                "unit": "s per tuning",
                "ratio": peer[fastest][0] / ours_s,
                "target": 50.0,
                "agreement": float("nan"),
                "peer_serial_s": peer[False][0],
                "peer_pool_s": peer[True][0],
                "ours_rmse": ours.loss,
                "peer_rmse": peer_rmse,
                "ours_params": ours.params,
                "peer_params": params,
                "ours_evaluations": ours.evaluations,
            }
        )
    return rows


def speed_ratios(progress=None) -> pd.DataFrame:
    """The speed comparisons of :func:`kalman_against_filterpy` (at equal lengths, 1e4 and
    1e5 samples, and per sample with ours on 1e6),
    :func:`jacobi_against_oaconvolve` and :func:`tuning_against_pynumdiff` (left out, with a
    line to ``progress``, where PyNumDiff is not installed), one row each."""
    rows = [
        kalman_against_filterpy(10_000, 10_000),
        kalman_against_filterpy(100_000, 100_000, repeats=2),
        kalman_against_filterpy(),
        jacobi_against_oaconvolve(),
    ]
    try:
        import pynumdiff  # noqa: F401
    except ImportError:
        if progress is not None:
            progress("PyNumDiff is not installed (the peers extra): no tuning ratio")
    else:
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
        lines.append(
            f"| {row.comparison} | {row.ours} | {row.peer} ({row.peer_package}) | "
            f"{row.ours_s:.3g} | {row.peer_s:.3g} | {row.unit} | {row.ratio:.3g} | "
            f"{row.target:g} | {agreement} |"
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
            "with the methods' caches emptied first.",
            "",
            "| ours | seconds | evaluations | RMSE ẋ | setting | PyNumDiff | serial (s) "
            "| pool (s) | RMSE ẋ | setting |",
            "|---|---:|---:|---:|---|---|---:|---:|---:|---|",
        ]
        for row in tunings.itertuples(index=False):
            lines.append(
                f"| {row.ours} | {row.ours_s:.3g} | {int(row.ours_evaluations)} | "
                f"{row.ours_rmse:.4g} | {_setting(row.ours_params)} | {row.peer} | "
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
