"""Throughput of every registered method (at its paper-signal preset) against signal length."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods

DT = 1e-3


def throughput(sizes=(10_000, 100_000, 1_000_000), repeats: int = 3) -> pd.DataFrame:
    """Samples per second of each method on a seeded noisy 4 Hz sine of each size (the best of
    ``repeats`` runs after a warm-up; orders 0, 1, 2 estimated), and the growth of the time per
    sample from the smallest to the largest size (1 = linear)."""
    records = []
    for name in methods.available():
        method = methods.preset(name, "paper-signal")
        method(np.zeros(5000), DT)  # warm-up: lazy imports, kernel caches
        times = {}
        for size in sizes:
            t = np.arange(size) * DT
            x = np.sin(2 * np.pi * 4 * t) + 0.01 * np.random.default_rng(size).standard_normal(size)
            best = np.inf
            for _ in range(repeats if size < 1_000_000 else max(1, repeats - 1)):
                start = time.perf_counter()
                method(x, DT)
                best = min(best, time.perf_counter() - start)
            times[size] = best
            records.append({"method": name, "samples": size, "seconds": best,
                            "samples_per_s": size / best})  # fmt: skip
        growth = (times[sizes[-1]] / sizes[-1]) / (times[sizes[0]] / sizes[0])
        for record in records[-len(sizes) :]:
            record["growth_per_sample"] = growth
    return pd.DataFrame(records)


def write_throughput(directory: Path, table: pd.DataFrame) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    csv, markdown = directory / "throughput.csv", directory / "throughput.md"
    table.to_csv(csv, index=False)
    sizes = sorted(table["samples"].unique())
    lines = ["# Throughput (samples/s, orders 0-2, paper-signal presets, best of repeats)", "",
             "Time per sample at the largest size over that at the smallest: 1 is linear growth.",
             "", "| method | " + " | ".join(f"{s:.0e}" for s in sizes) + " | growth |",
             "|---|" + "---|" * (len(sizes) + 1)]  # fmt: skip
    for name, group in table.groupby("method"):
        rates = group.set_index("samples")["samples_per_s"]
        cells = " | ".join(f"{rates[s]:.3g}" for s in sizes)
        lines.append(f"| {name} | {cells} | {group['growth_per_sample'].iloc[0]:.2f} |")
    markdown.write_text("\n".join([*lines, ""]), encoding="utf-8")
    return [markdown, csv]
