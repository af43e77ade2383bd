"""Throughput and peak memory of every registered method (at its paper-signal preset) against
signal length, and the speed ratios against the peers (filterpy's Kalman smoother, scipy's
``oaconvolve``, PyNumDiff's ``optimize``), each measured in one run."""

from __future__ import annotations

import time
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods
from diffbench.bench.core.plan import preset_entry
from diffbench.bench.report import figures

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
