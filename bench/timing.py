"""Throughput of every registered method (at its paper-signal preset) against signal length."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods
from diffbench.bench.runner import preset_entry

DT = 1e-3

SIZE_CAPS = {
    "derivative.savitzky_golay": (10_000, "a Python loop over samples: ~0.13 s per 1e3"),
    "pynumdiff.tvrdiff": (10_000, "a cvxpy problem per call: ~0.1 s per 1e3, superlinear"),
    "pynumdiff.polydiff": (100_000, "~0.09 s per 1e3 samples"),
    "pynumdiff.rtsdiff": (100_000, "a Python loop over samples: ~0.05 s per 1e3"),
    "derivative.spline": (100_000, "~0.04 s per 1e3: 3.8 s at 1e5"),
    "pynumdiff.splinediff": (10_000, "scipy's make_splrep knot search: 4.4 s at 1e4, 96 s at 3e4"),
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


def throughput(sizes=(10_000, 100_000, 1_000_000), repeats: int = 3, names=None) -> pd.DataFrame:
    """Samples per second of each method on a seeded noisy 4 Hz sine of each size (the best of
    ``repeats`` runs after a warm-up; orders 0, 1, 2 estimated), and the growth of the time per
    sample from the smallest to the largest size timed (1 = linear). Sizes past a method's
    cap are left out (NaN), see :func:`timed_sizes`. ``names``: the methods timed (default:
    every registered one)."""
    records = []
    for name in methods.available() if names is None else names:
        method = timing_instance(name)
        timed = timed_sizes(name, sizes)
        method(np.zeros(min(5000, timed[0] // 4)), DT)  # warm-up: lazy imports, kernel caches
        times = {}
        for size in timed:
            t = np.arange(size) * DT
            x = np.sin(2 * np.pi * 4 * t) + 0.01 * np.random.default_rng(size).standard_normal(size)
            best = np.inf
            for _ in range(repeats if size < 1_000_000 else max(1, repeats - 1)):
                start = time.perf_counter()
                method(x, DT)
                best = min(best, time.perf_counter() - start)
            times[size] = best
            records.append({"method": name, "package": methods.package_of(name),
                            "samples": size, "seconds": best,
                            "samples_per_s": size / best})  # fmt: skip
        growth = (times[timed[-1]] / timed[-1]) / (times[timed[0]] / timed[0])
        for record in records[-len(timed) :]:
            record["growth_per_sample"] = growth
    return pd.DataFrame(records)


def write_throughput(directory: Path, table: pd.DataFrame) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    csv, markdown = directory / "throughput.csv", directory / "throughput.md"
    table.to_csv(csv, index=False)
    sizes = sorted(table["samples"].unique())
    lines = ["# Throughput (samples/s, orders 0-2, paper-signal presets or class defaults, best "
             "of repeats)", "",
             "Time per sample at the largest size timed over that at the smallest: 1 is linear "
             "growth (— where one size only was timed). — in a size column: not timed at that "
             "size (see the caps below).",
             "", "| method | package | " + " | ".join(f"{s:.0e}" for s in sizes) + " | growth |",
             "|---|---|" + "---|" * (len(sizes) + 1)]  # fmt: skip
    caps = []
    for name, group in table.groupby("method"):
        rates = group.set_index("samples")["samples_per_s"]
        cells = " | ".join(f"{rates[s]:.3g}" if s in rates.index else "—" for s in sizes)
        package = group["package"].iloc[0]
        growth = f"{group['growth_per_sample'].iloc[0]:.2f}" if len(rates) > 1 else "—"
        lines.append(f"| {name} | {package} | {cells} | {growth} |")
        cap, why = size_cap(name)
        if cap is not None and cap < max(sizes):
            caps.append(f"- {name}: timed up to {cap:g} samples ({why})")
    if caps:
        lines += ["", "Capped:", *caps]
    markdown.write_text("\n".join([*lines, ""]), encoding="utf-8")
    return [markdown, csv]
