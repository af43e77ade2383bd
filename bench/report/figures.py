"""Figures of the benchmark, drawn from tables only, and the pieces every figure shares.

* :func:`method_styles` gives each registered method one colour, line style and marker, the
  same in every figure;
* :func:`error_scales` decides which error curves share one y range and which would flatten
  it and get their own (pure, testable without drawing);
* :func:`error_figure_data` and :func:`write_error_figure`: the benchmark's question itself,
  each method setting's mean interior RMSE of ẋ and ẍ with its 95 % confidence interval.

Matplotlib is imported lazily (Agg backend), only when a figure is drawn.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods

# Tableau 10 without its grey (kept for "outside the interior" shading), then Matplotlib's
# tab20b and tab20c, and as many dash patterns: a method keeps its colour and its line style in
# every figure, and curves differ by both (38 methods before a colour or a pattern repeats).
_COLOURS = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#bcbd22",
    "#17becf",
    "#393b79",
    "#5254a3",
    "#6b6ecf",
    "#9c9ede",
    "#637939",
    "#8ca252",
    "#b5cf6b",
    "#cedb9c",
    "#8c6d31",
    "#bd9e39",
    "#e7ba52",
    "#e7cb94",
    "#843c39",
    "#ad494a",
    "#d6616b",
    "#e7969c",
    "#7b4173",
    "#a55194",
    "#ce6dbd",
    "#de9ed6",
    "#3182bd",
    "#6baed6",
    "#e6550d",
    "#fd8d3c",
    "#31a354",
    "#74c476",
    "#756bb1",
    "#9e9ac8",
    "#636363",
)
_LINESTYLES = (
    "-",
    "--",
    "-.",
    ":",
    (0, (5, 1.5, 1, 1.5, 1, 1.5)),
    (0, (8, 2)),
    (0, (1, 3)),
    (0, (3, 1, 1, 1)),
    (0, (12, 3, 3, 3)),
    (0, (2, 1)),
    (0, (6, 2, 1, 2, 1, 2)),
    (0, (1, 1)),
    *((0, (on, off)) for on in (4, 7, 10, 14) for off in (1.5, 3.5, 5)),
    *((0, (on, 2, 1, 2, 1, 2, 1, 2)) for on in (4, 8, 12)),
    *((0, (on, 1.5, 3, 1.5)) for on in (6, 9, 13)),
    *((0, (1, 2, on, 2)) for on in (5, 9, 15)),
    (0, (2, 4)),
    (0, (16, 4, 2, 4)),
    (0, (3, 3, 3, 6)),
    (0, (20, 5)),
    (0, (6, 3, 6, 6, 1, 3)),
)
_MARKERS = ("o", "s", "^", "v", "P", "X", "h", "<", ">")

#: A method is drawn on its own y range when its RMSE exceeds this multiple of the median RMSE
#: of the methods in the figure (e.g. unfiltered finite differences, ~50x the others on ẋ).
OFF_SCALE_FACTOR = 3.0

#: The columns :func:`write_error_figure` reads.
ERROR_FIGURE_COLUMNS = (
    "method",
    "setting",
    "RMSE ẋ interior mean",
    "RMSE ẋ interior ci95",
    "RMSE ẍ interior mean",
    "RMSE ẍ interior ci95",
    "seeds",
)
# (derivative symbol, its unit given the position unit u)
_ERROR_PANELS = (("ẋ", "{u}/s"), ("ẍ", "{u}/s²"))


@dataclass(frozen=True)
class MethodStyle:
    """How one method is drawn: ``color``, ``linestyle`` (a Matplotlib spec), ``marker``."""

    color: str
    linestyle: str | tuple
    marker: str

    def line(self) -> dict:
        """Keyword arguments of ``Axes.plot`` for a line of this method."""
        return {"color": self.color, "linestyle": self.linestyle}


def method_styles(names: Sequence[str]) -> dict[str, MethodStyle]:
    """A style per name in ``names``, fixed by the name's place among the registered methods
    (then unregistered names, sorted), so a method looks the same in every figure whichever
    others are drawn with it.

    >>> styles = method_styles(["jacobi", "butterworth"])
    >>> styles["butterworth"] == method_styles(["butterworth"])["butterworth"]
    True
    """
    known = methods.available()
    ordered = known + sorted(set(names) - set(known))
    styles = {}
    for name in names:
        k = ordered.index(name)
        styles[name] = MethodStyle(
            color=_COLOURS[k % len(_COLOURS)],
            linestyle=_LINESTYLES[k % len(_LINESTYLES)],
            marker=_MARKERS[k % len(_MARKERS)],
        )
    return styles


@dataclass(frozen=True)
class ErrorScales:
    """Y ranges of a set of error curves: the ``shared`` half-range (symmetric about 0) of the
    curves drawn together, and ``own`` half-ranges of the ``off_scale`` ones, each with its
    ``ratio`` = RMSE / median RMSE."""

    shared: float
    own: Mapping[str, float]
    ratio: Mapping[str, float]

    @property
    def off_scale(self) -> tuple[str, ...]:
        return tuple(self.own)


def error_scales(rmse: Mapping[str, float], peak: Mapping[str, float]) -> ErrorScales:
    """Split error curves into those that share a y range and those that would flatten it.

    A curve is off-scale when its ``rmse`` exceeds :data:`OFF_SCALE_FACTOR` times the median
    ``rmse`` of all curves; the shared half-range is 1.1 x the largest ``peak`` (max |error|
    where it is scored) of the others, an off-scale curve's own half-range 1.1 x its own peak.

    >>> scales = error_scales({"a": 1.0, "b": 1.2, "c": 50.0}, {"a": 3.0, "b": 4.0, "c": 200.0})
    >>> round(scales.shared, 6), scales.off_scale
    (4.4, ('c',))
    """
    if set(rmse) != set(peak) or not rmse:
        raise ValueError("`rmse` and `peak` must name the same, non-empty set of curves")
    finite = [v for v in rmse.values() if np.isfinite(v)]
    median = float(np.median(finite)) if finite else math.nan
    ratio = {name: value / median if median > 0 else math.nan for name, value in rmse.items()}
    off = [name for name in rmse if np.isfinite(ratio[name]) and ratio[name] > OFF_SCALE_FACTOR]
    shared_peaks = [peak[name] for name in rmse if name not in off and np.isfinite(peak[name])]
    shared = 1.1 * max(shared_peaks) if shared_peaks and max(shared_peaks) > 0 else 1.0
    own = {name: 1.1 * peak[name] if peak[name] > 0 else 1.0 for name in off}
    return ErrorScales(shared=shared, own=own, ratio=ratio)


# --- the benchmark's question: mean error with its confidence interval, per method setting ----
def _is_preset(table: pd.DataFrame) -> np.ndarray:
    """Whether each row is a preset: from the stored ``origin`` column when the table has it
    (:func:`diffbench.bench.report.tables.wide_table` keeps it), else from the setting's label
    (``preset (paper)``, ``preset (diffbench)``, ``class defaults``)."""
    if "origin" in table.columns:
        return (table["origin"] == "preset").to_numpy()
    setting = table["setting"].astype(str)
    return (setting.str.startswith("preset") | (setting == "class defaults")).to_numpy()


def error_figure_data(table: pd.DataFrame) -> pd.DataFrame:
    """The points of :func:`write_error_figure`, one row per table row and derivative.

    Columns: ``derivative`` (ẋ, ẍ), ``rank`` (0 = lowest mean RMSE within that derivative),
    ``label`` (``method — setting``), ``method``, ``setting``, ``preset`` (bool), ``mean``,
    ``ci95`` (NaN: no whisker), ``seeds``. Rows whose mean is NaN or not > 0 (a log axis
    cannot show them) are left out.

    Raises ``ValueError`` naming the missing columns if ``table`` lacks one of
    :data:`ERROR_FIGURE_COLUMNS`, or if it has no rows.
    """
    missing = [column for column in ERROR_FIGURE_COLUMNS if column not in table.columns]
    if missing:
        raise ValueError(
            f"`table` lacks the column(s) {', '.join(repr(c) for c in missing)}; "
            f"needed: {', '.join(repr(c) for c in ERROR_FIGURE_COLUMNS)}"
        )
    if table.empty:
        raise ValueError("`table` has no rows")
    base = pd.DataFrame(
        {
            "label": [f"{m} — {s}" for m, s in zip(table["method"], table["setting"], strict=True)],
            "method": table["method"].astype(str).to_numpy(),
            "setting": table["setting"].astype(str).to_numpy(),
            "preset": _is_preset(table),
            "seeds": pd.to_numeric(table["seeds"], errors="coerce").astype(float).to_numpy(),
        }
    )
    parts = []
    for symbol, _ in _ERROR_PANELS:
        part = base.copy()
        part.insert(0, "derivative", symbol)
        part["mean"] = pd.to_numeric(table[f"RMSE {symbol} interior mean"]).astype(float).values
        part["ci95"] = pd.to_numeric(table[f"RMSE {symbol} interior ci95"]).astype(float).values
        part = part[np.isfinite(part["mean"]) & (part["mean"] > 0)]
        part = part.sort_values(["mean", "label"], kind="stable").reset_index(drop=True)
        part.insert(1, "rank", np.arange(len(part)))
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def _significant(value: float, digits: int) -> str:
    """``value`` to ``digits`` significant digits, without an exponent below 1e7
    (``_significant(541234.0, 3) == "541000"``, ``_significant(0.00934, 2) == "0.0093"``)."""
    if value == 0 or not np.isfinite(value) or not 1e-4 <= abs(value) < 1e7:
        return f"{value:.{digits}g}"
    decimals = digits - 1 - math.floor(math.log10(abs(value)))
    value = round(value, decimals)  # 99.96 -> 100.0: one digit more before the point
    decimals = digits - 1 - math.floor(math.log10(abs(value)))
    return f"{round(value, decimals):.{max(decimals, 0)}f}"


def _plus_minus(mean: float, half: float) -> str:
    """``mean ± half`` (3 and 2 significant digits); the mean alone without a half-width."""
    text = _significant(mean, 3)
    return text if not np.isfinite(half) else f"{text} ± {_significant(half, 2)}"


def _log_ticks(axis, decades: float) -> None:
    """Label the decades of a wide log axis (10^k), and 1-2-5 steps of a narrow one as plain
    numbers; minor ticks unlabelled."""
    from matplotlib import ticker

    if decades < 2.5:
        axis.xaxis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0), numticks=30))
        axis.xaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: _significant(v, 1)))
    axis.xaxis.set_minor_formatter(ticker.NullFormatter())


def _seeds_note(seeds: pd.Series) -> str:
    counts = sorted({int(s) for s in seeds if np.isfinite(s)})
    if not counts:
        return "seeds unknown"
    if len(counts) == 1:
        return f"{counts[0]} noise seed{'s' if counts[0] != 1 else ''}"
    return f"{counts[0]}–{counts[-1]} noise seeds per row"


def write_error_figure(
    table: pd.DataFrame, path: Path, title: str, *, position_unit: str = "units"
) -> Path:
    """Dot-and-whisker figure of each method setting's mean interior RMSE of ẋ (left) and ẍ
    (right) with the 95 % confidence interval of the mean, best first in each panel.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per method setting with the columns :data:`ERROR_FIGURE_COLUMNS` (as
        :func:`diffbench.bench.report.tables.wide_table` writes them); NaN means are skipped, NaN
        half-widths drawn without whiskers.
    path : pathlib.Path
        The PNG to write (its folder is created).
    title : str
        First line of the title; the second says what the dots and whiskers are and how many
        seeds they average.
    position_unit : str
        Unit of the differentiated signal: the axes read ``<unit>/s`` and ``<unit>/s²``.

    Returns
    -------
    pathlib.Path
        ``path``.

    Notes
    -----
    Presets are filled diamonds, tuned or other settings open circles, coloured by method
    (:func:`method_styles`). The grey band is the 95 % CI of the best row of the panel: rows
    whose interval overlaps it are not clearly worse (a hint; the paired tests of
    :mod:`diffbench.bench.core.stats` decide). A lower whisker that would reach below a tenth of the
    mean (on a log axis 0 is out of sight) is cut there, and the figure says how many were.
    """
    points = error_figure_data(table)
    path = Path(path)
    rows = max(int((points["derivative"] == s).sum()) for s, _ in _ERROR_PANELS)
    labels = max((len(label) for label in points["label"]), default=10)
    plt = pyplot()
    width = 2 * (3.6 + 0.065 * labels) + 0.6
    fig, axes = plt.subplots(1, 2, figsize=(width, 1.9 + 0.27 * max(rows, 3)))
    styles = method_styles(sorted(set(points["method"])))
    cut = 0
    for axis, (symbol, unit) in zip(axes, _ERROR_PANELS, strict=True):
        unit = unit.format(u=position_unit)
        panel = points[points["derivative"] == symbol]
        if panel.empty:
            axis.text(
                0.5,
                0.5,
                f"no finite RMSE of {symbol}",
                ha="center",
                va="center",
                transform=axis.transAxes,
            )
            axis.set_yticks([])
            axis.set_xlabel(f"RMSE of {symbol} ({unit}), interior")
            continue
        mean, half = panel["mean"].to_numpy(), panel["ci95"].to_numpy()
        whisker = np.where(np.isfinite(half), half, 0.0)
        lower = np.minimum(whisker, 0.9 * mean)
        cut += int(np.sum(whisker > 0.9 * mean))
        y = panel["rank"].to_numpy()
        best = panel.iloc[0]
        if np.isfinite(best["ci95"]):
            axis.axvspan(
                max(best["mean"] - best["ci95"], 0.1 * best["mean"]),
                best["mean"] + best["ci95"],
                color="0.88",
                zorder=0,
                label="95 % CI of the best",
            )
        for k, row in enumerate(panel.itertuples(index=False)):
            style = styles[row.method]
            axis.errorbar(
                row.mean,
                y[k],
                xerr=[[lower[k]], [whisker[k]]],
                fmt="none",
                ecolor=style.color,
                elinewidth=1.4,
                capsize=2.5,
                zorder=2,
            )
            marker = (
                {
                    "marker": "D",
                    "s": 46,
                    "facecolor": style.color,
                    "edgecolor": "black",
                    "linewidth": 0.8,
                }
                if row.preset
                else {
                    "marker": "o",
                    "s": 34,
                    "facecolor": "white",
                    "edgecolor": style.color,
                    "linewidth": 1.4,
                }
            )
            axis.scatter([row.mean], [y[k]], zorder=3, **marker)
            axis.annotate(
                _plus_minus(row.mean, row.ci95),
                (row.mean + whisker[k], y[k]),
                xytext=(7, 0),
                textcoords="offset points",
                va="center",
                fontsize=6.5,
                color="0.25",
            )
        axis.set_xscale("log")
        low, high = float(np.min(mean - lower)), float(np.max(mean + whisker))
        decades = math.log10(high * 1.6 / low)
        axis.set_xlim(low / 1.6, high * 10 ** max(0.3 * decades, 0.6))  # room for the values
        _log_ticks(axis, decades)
        axis.set_yticks(y, panel["label"], fontsize=8)
        for tick, row in zip(axis.get_yticklabels(), panel.itertuples(index=False), strict=True):
            tick.set_fontweight("bold" if row.preset else "normal")
        axis.set_ylim(len(panel) - 0.4, -0.6)  # best on top
        axis.grid(alpha=0.35, which="both", axis="x")
        axis.grid(alpha=0.15, axis="y")
        axis.set_xlabel(f"RMSE of {symbol} ({unit}), interior, mean and 95 % CI")
        axis.set_title(f"{symbol}: best first", fontsize=10)
    # one legend for both panels: the two kinds of row and the band
    handles = [
        plt.Line2D(
            [],
            [],
            marker="D",
            color="none",
            markerfacecolor="0.4",
            markeredgecolor="black",
            markersize=7,
            label="preset (bold label)",
        ),
        plt.Line2D(
            [],
            [],
            marker="o",
            color="none",
            markerfacecolor="white",
            markeredgecolor="0.3",
            markersize=7,
            markeredgewidth=1.4,
            label="tuned / other setting",
        ),
        plt.Rectangle((0, 0), 1, 1, color="0.88", label="95 % CI of the panel's best"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle(
        f"{title}\nmean interior RMSE over {_seeds_note(points['seeds'])}; "
        "whiskers: 95 % confidence interval of the mean (Student t)",
        fontsize=10,
    )
    bottom = 0.45 / fig.get_figheight()
    if cut:
        fig.text(
            0.01,
            0.005,
            f"{cut} interval(s) reach below a tenth of the mean: lower "
            "whisker cut there (log axis).",
            fontsize=7,
        )
    fig.tight_layout(rect=(0, bottom, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, metadata=PNG_METADATA)
    plt.close(fig)
    return path


# --- drawing helpers shared with bench/studies/paper.py ----------------------------------
PNG_METADATA = {"Software": None}
"""What a PNG says of its maker: nothing (matplotlib writes its version by default), so that a
figure's bytes depend on its data and its drawing alone."""


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (imported on first use)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path, *, tight: bool = True) -> Path:
    """Lay out (unless ``tight`` is false), write the PNG at 120 dpi and free the figure."""
    if tight:
        fig.tight_layout()
    fig.savefig(path, dpi=120, metadata=PNG_METADATA)
    pyplot().close(fig)
    return path


def write_online_figure(table: pd.DataFrame, path: Path, title: str) -> Path:
    """Delay-compensated RMSE against delay, one panel per derivative order: every setting of
    each causal method (faint) and its front (joined), from the online task's table
    (:func:`diffbench.bench.tasks.online.online_table`)."""
    plt = pyplot()
    orders = list(dict.fromkeys(table["order"]))
    fig, axes = plt.subplots(1, len(orders), figsize=(6.0 * len(orders), 4.6), squeeze=False)
    styles = method_styles(sorted(set(table["method"])))
    for axis, order in zip(axes[0], orders, strict=True):
        mine = table[table["order"] == order].dropna(subset=["delay (ms)"])
        for name, group in mine.groupby("method"):
            style = styles[name]
            delay = group["delay (ms)"].abs()
            axis.scatter(
                delay,
                group["RMSE delay-compensated"],
                color=style.color,
                marker=style.marker,
                alpha=0.3,
                s=18,
            )
            front = group[group["front"]].assign(delay=delay).sort_values("delay")
            axis.plot(
                front["delay"],
                front["RMSE delay-compensated"],
                marker=style.marker,
                label=name,
                **style.line(),
            )
        axis.set_yscale("log")
        axis.set_xlabel("|delay| (ms)")
        axis.set_ylabel(f"{order} RMSE, delay-compensated")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
    fig.suptitle(title)
    return save_figure(fig, path)
