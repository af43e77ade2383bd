"""The results explorer: one static HTML page per folder of results, working offline from
files (no server), with sortable, filterable tables and interactive figures.

A page holds, for each Markdown table the benchmark wrote in the folder, the table itself
(click a column's header to sort by it, numerically where its cells start with a number;
type in the filter box to keep the rows holding that text) and, where the table has
``mean ± interval`` columns, the ranking with its intervals (a menu picks the column; clicking
a method in the legend hides or shows it). Figures read the CSVs beside the tables when
they are there: the error against position in the record (``error_vs_position.csv``, one
line per method), the online error-against-delay front (``sweep.csv`` with its delay and
delay-compensated RMSE), and each method's error against the noise level and against the
step over the grid (``errors.csv``, a menu picking the rest of the cell). The figures are
Plotly's (the ``plotly.min.js`` the page loads from ``assets/``, written once beside the
pages, offline).

``make docs`` writes a page per results folder into the site (``results/<folder>/explorer.html``,
through :mod:`~diffbench.bench.report.docs_site`); :func:`write_explorer` writes one anywhere.
"""

from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path

import pandas as pd

PLOTLY_JS = "plotly.min.js"
"""The file the pages load Plotly from, in the site's ``assets/`` folder."""

_FLOAT = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_MEAN_AND_INTERVAL = re.compile(rf"^\s*({_FLOAT})\s*±\s*({_FLOAT})\s*$")

SCRIPT = """
function sortBy(th) {
  const table = th.closest('table'), body = table.tBodies[0];
  const column = Array.from(th.parentNode.children).indexOf(th);
  const ascending = th.dataset.order !== 'ascending';
  th.parentNode.querySelectorAll('th').forEach(h => delete h.dataset.order);
  th.dataset.order = ascending ? 'ascending' : 'descending';
  const key = row => {
    const text = row.cells[column].textContent.trim();
    const number = parseFloat(text);
    return isNaN(number) ? text : number;
  };
  const rows = Array.from(body.rows).sort((a, b) => {
    const x = key(a), y = key(b);
    if (typeof x === 'number' && typeof y === 'number') return ascending ? x - y : y - x;
    if (typeof x === 'number') return -1;
    if (typeof y === 'number') return 1;
    return ascending ? x.localeCompare(y) : y.localeCompare(x);
  });
  rows.forEach(row => body.appendChild(row));
}
function filterRows(input) {
  const text = input.value.toLowerCase();
  const table = document.getElementById(input.dataset.table);
  Array.from(table.tBodies[0].rows).forEach(row => {
    row.hidden = text !== '' && !row.textContent.toLowerCase().includes(text);
  });
}
"""

STYLE = """
body { font-family: sans-serif; margin: 1.5em; }
table { border-collapse: collapse; font-size: 0.85em; margin-bottom: 2em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: left; }
th { cursor: pointer; background: #f0f0f0; }
th[data-order=ascending]::after { content: ' ▲'; }
th[data-order=descending]::after { content: ' ▼'; }
input.filter { margin: 0.5em 0; width: 20em; }
.figure { width: 100%; }
"""


def markdown_tables(text: str) -> list[tuple[str, pd.DataFrame]]:
    """The pipe tables of a Markdown text, each with the heading above it (its title), as
    frames of strings (the cells as written)."""
    tables, title, block = [], "", []
    for line in [*text.splitlines(), ""]:
        if line.startswith("|"):
            block.append(line)
            continue
        if len(block) >= 2:
            rows = [[cell.strip() for cell in row.strip().strip("|").split("|")] for row in block]
            header, body = _unique(rows[0]), [row for row in rows[2:] if len(row) == len(rows[0])]
            tables.append((title, pd.DataFrame(body, columns=header)))
        block = []
        if line.startswith("#"):
            title = line.lstrip("#").strip()
    return tables


def _unique(names: list[str]) -> list[str]:
    """Column names made unique (a repeated one gets `` (2)``, `` (3)``...)."""
    seen: dict[str, int] = {}
    unique = []
    for name in names:
        seen[name] = seen.get(name, 0) + 1
        unique.append(name if seen[name] == 1 else f"{name} ({seen[name]})")
    return unique


def interval_columns(table: pd.DataFrame) -> list[str]:
    """The columns whose cells are ``mean ± interval`` (most of them, at least)."""
    found = []
    for column in table.columns:
        cells = table[column].astype(str)
        if len(cells) and cells.map(lambda c: bool(_MEAN_AND_INTERVAL.match(c))).mean() > 0.5:
            found.append(column)
    return found


def _finite(values) -> list[float | None]:
    """Numbers for a figure: each value as a float, ``None`` (a gap) where it is not a finite
    number."""
    numbers = pd.to_numeric(pd.Series(values), errors="coerce").astype(float)
    return [float(v) if math.isfinite(v) else None for v in numbers]


def _mean_and_interval(cell: str) -> tuple[float | None, float | None]:
    match = _MEAN_AND_INTERVAL.match(str(cell))
    if not match:
        return None, None
    mean, interval = float(match.group(1)), float(match.group(2))
    return (mean if math.isfinite(mean) else None), (interval if math.isfinite(interval) else None)


def ranking_figure(table: pd.DataFrame) -> dict | None:
    """A Plotly figure (as a dict) of each row's ``mean ± interval`` for the first interval
    column, a menu switching to the others; one trace per method (the legend toggles it);
    ``None`` for a table without a ``method`` column or interval columns."""
    columns = interval_columns(table)
    if "method" not in table.columns or not columns:
        return None
    labels = [
        " · ".join(str(row[c]) for c in ("method", "setting", "role") if c in table.columns)
        for _, row in table.iterrows()
    ]
    rows_of = {}  # each method's rows, in the table's order: one trace each
    for i, method in enumerate(table["method"]):
        rows_of.setdefault(method, []).append(i)
    parsed = {column: [_mean_and_interval(cell) for cell in table[column]] for column in columns}

    def points(column: str, rows: list[int]) -> dict:
        """A trace's means and intervals in ``column``."""
        cells = [parsed[column][i] for i in rows]
        return {
            "x": [c[0] for c in cells],
            "error_x": {"type": "data", "array": [c[1] for c in cells]},
        }

    traces = [
        {
            "type": "scatter",
            "mode": "markers",
            "name": method,
            "y": [labels[i] for i in rows],
            **points(columns[0], rows),
        }
        for method, rows in rows_of.items()
    ]
    buttons = []
    for column in columns:
        shown = [points(column, rows) for rows in rows_of.values()]
        restyle = {"x": [t["x"] for t in shown], "error_x": [t["error_x"] for t in shown]}
        relayout = {"xaxis": {"title": {"text": column}, "type": "log"}}
        buttons.append({"label": column, "method": "update", "args": [restyle, relayout]})
    layout = {
        "xaxis": {"title": {"text": columns[0]}, "type": "log"},
        "yaxis": {"automargin": True},
        "height": max(360, 18 * len(labels) + 120),
        "updatemenus": [{"buttons": buttons, "x": 1.0, "y": 1.12, "xanchor": "right"}],
        "margin": {"t": 60},
    }
    return {"data": traces, "layout": layout}


def position_figure(frame: pd.DataFrame) -> dict | None:
    """The RMS error of ẋ against position in the record, one trace per method (log scale),
    from an ``error_vs_position`` table; ``None`` for another table."""
    suffix = "_velocity_rms_error"
    columns = [c for c in frame.columns if c.endswith(suffix)]
    if "position" not in frame.columns or not columns:
        return None
    traces = [
        {
            "type": "scattergl",
            "mode": "lines",
            "name": column[: -len(suffix)],
            "x": _finite(frame["position"]),
            "y": _finite(frame[column]),
        }
        for column in columns
    ]
    layout = {
        "xaxis": {"title": {"text": "position in the record"}},
        "yaxis": {"title": {"text": "RMS error of ẋ over the seeds"}, "type": "log"},
        "height": 520,
    }
    return {"data": traces, "layout": layout}


def delay_figure(frame: pd.DataFrame) -> dict | None:
    """The online track's error against delay for ẋ: each causal method's settings (delay,
    RMSE once the delay is compensated), one trace per method; ``None`` for another table."""
    needed = {"method", "delay (ms)", "RMSE delay-compensated"}
    if not needed <= set(frame.columns):
        return None
    if "order" in frame.columns:
        frame = frame[frame["order"] == "ẋ"]
    frame = frame.assign(
        **{c: pd.to_numeric(frame[c], errors="coerce") for c in needed - {"method"}}
    )
    frame = frame[frame["delay (ms)"] > 0]  # a log axis; a lead is not on the front
    traces = []
    for method, rows in frame.groupby("method", sort=False):
        traces.append(
            {
                "type": "scatter",
                "mode": "markers",
                "name": method,
                "x": _finite(rows["delay (ms)"]),
                "y": _finite(rows["RMSE delay-compensated"]),
                "text": rows.get("setting", pd.Series([""] * len(rows))).astype(str).tolist(),
            }
        )
    layout = {
        "xaxis": {"title": {"text": "delay (ms)"}, "type": "log"},
        "yaxis": {"title": {"text": "RMSE once the delay is compensated"}, "type": "log"},
        "height": 520,
    }
    return {"data": traces, "layout": layout}


GRID_AXES = {"level": "noise level", "step_ms": "sampling step (ms)"}
"""The axes :func:`grid_errors_figure` plots the grid's errors against (its ``along``)."""


def grid_errors_figure(frame: pd.DataFrame, along: str) -> dict | None:
    """Each method's RMSE against the grid's noise level (``along="level"``) or step
    (``"step_ms"``), one line per method (the legend toggles it), log scales; a menu picks
    the rest of the grid cell: the noise kind, the other of level and step, the derivative
    order and the region. From the grid study's ``errors.csv``; ``None`` for another table."""
    needed = {"noise", "level", "step_ms", "method", "order", "region", "rmse"}
    if along not in GRID_AXES or not needed <= set(frame.columns):
        return None
    other = "step_ms" if along == "level" else "level"
    keys = ["noise", other, "order", "region"]
    symbols = {1: "ẋ", 2: "ẍ"}
    groups = list(frame.groupby(keys, sort=False))
    methods_shown = sorted(set(frame["method"]))
    traces, entries = [], []  # entries: each menu entry's label and its traces' range
    for index, (key, group) in enumerate(groups):
        noise, fixed, order, region = key
        fixed_text = f"{fixed:g} ms" if other == "step_ms" else f"level {fixed:g}"
        label = f"{noise}, {fixed_text}, {symbols.get(order, order)}, {region}"
        first = len(traces)
        for method in methods_shown:
            rows = group[group["method"] == method].sort_values(along)
            if rows.empty:
                continue
            traces.append(
                {
                    "type": "scatter",
                    "mode": "lines+markers",
                    "name": method,
                    "x": _finite(rows[along]),
                    "y": _finite(rows["rmse"]),
                    "visible": index == 0,
                }
            )
        entries.append((label, range(first, len(traces))))
    buttons = [
        {
            "label": label,
            "method": "update",
            "args": [{"visible": [i in shown for i in range(len(traces))]}],
        }
        for label, shown in entries
    ]
    if not traces:
        return None
    layout = {
        "xaxis": {"title": {"text": GRID_AXES[along]}, "type": "log"},
        "yaxis": {"title": {"text": "RMSE (mean over the scored seeds)"}, "type": "log"},
        "height": 560,
        "updatemenus": [{"buttons": buttons, "x": 1.0, "y": 1.15, "xanchor": "right"}],
        "margin": {"t": 80},
    }
    return {"data": traces, "layout": layout}


def _heading(text: str) -> str:
    """A Markdown heading as HTML: escaped, its `code` spans as <code>."""
    return re.sub(r"`([^`]*)`", r"<code>\1</code>", html.escape(text))


def _table_html(table: pd.DataFrame, table_id: str) -> str:
    head = "".join(f'<th onclick="sortBy(this)">{html.escape(str(c))}</th>' for c in table.columns)
    rows = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in row) + "</tr>"
        for row in table.itertuples(index=False)
    )
    return (
        f'<input class="filter" placeholder="filter rows" data-table="{table_id}" '
        f'oninput="filterRows(this)">\n'
        f'<table id="{table_id}"><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>'
    )


def _figure_html(figure: dict, figure_id: str) -> str:
    # the figure once, as data; "</" escaped so that no text in it can close the script
    spec = json.dumps(figure, allow_nan=False, default=str).replace("</", "<\\/")
    height = int(figure["layout"].get("height", 480))
    return (
        f'<div class="figure" id="{figure_id}" style="height: {height}px"></div>\n'
        f"<script>(function () {{ const spec = {spec}; "
        f"Plotly.newPlot('{figure_id}', spec.data, spec.layout, {{responsive: true}}); }})();"
        "</script>"
    )


def explorer_page(folder: Path, title: str, assets: str = "assets") -> str:
    """The explorer page of one results ``folder`` (its Markdown tables and the CSVs the
    figures read), loading Plotly from ``assets`` (a path relative to the page)."""
    parts = []
    extra = [
        ("error_vs_position.csv", "ẋ's error against position in the record", position_figure),
        ("sweep.csv", "ẋ's error against delay, every setting swept", delay_figure),
        ("errors.csv", "Each method's error against the noise level", grid_errors_figure, "level"),
        ("errors.csv", "Each method's error against the step", grid_errors_figure, "step_ms"),
    ]
    for name, heading, build, *arguments in extra:
        path = folder / name
        figure = build(pd.read_csv(path), *arguments) if path.exists() else None
        if figure is not None:
            figure_id = "-".join(["figure", Path(name).stem, *arguments]).replace("_", "-")
            parts.append(f"<h2>{html.escape(heading)}</h2>")
            parts.append(_figure_html(figure, figure_id))
    count = 0
    for path in sorted(folder.glob("*.md")):
        for heading, table in markdown_tables(path.read_text(encoding="utf-8")):
            count += 1
            parts.append(f"<h2>{_heading(heading or path.stem)}</h2>")
            figure = ranking_figure(table)
            if figure is not None:  # named after its table: figure-of-table-N
                parts.append(_figure_html(figure, f"figure-of-table-{count}"))
            parts.append(_table_html(table, f"table-{count}"))
    body = "\n".join(parts)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style>
<script src="{assets}/{PLOTLY_JS}"></script>
<script>{SCRIPT}</script></head>
<body><h1>{html.escape(title)}</h1>
{body}
</body></html>
"""


def plotly_js() -> str:
    """Plotly's JavaScript bundle, as the installed ``plotly`` package carries it."""
    from plotly.offline import get_plotlyjs

    return get_plotlyjs()


def write_explorer(folder: Path, out: Path, title: str | None = None) -> list[Path]:
    """Write ``out/explorer.html`` for results ``folder`` and ``out/assets/plotly.min.js``."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "assets").mkdir(exist_ok=True)
    script = out / "assets" / PLOTLY_JS
    script.write_text(plotly_js(), encoding="utf-8")
    page = out / "explorer.html"
    page.write_text(explorer_page(folder, title or folder.name), encoding="utf-8")
    return [page, script]
