"""The results explorer (issue 46, item 3): a static page per results folder with sortable,
filterable tables and interactive figures, working offline from files; tested in a real
browser (headless Chromium driven by Playwright) where one is installed, as CI installs it."""

import contextlib
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest

from diffbench.bench.report import explorer

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "results"
CHROMIUM_ARGS = [
    "--disable-dev-shm-usage",
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def test_markdown_tables_are_read_as_written():
    text = (
        "# A title\n\nintro\n\n| method | RMSE ẋ | RMSE ẋ |\n|:--|:--|:--|\n"
        "| a | 1.5 ± 0.2 | 3 |\n| b | 10 ± 1 | 4 |\n\nafter\n"
    )
    ((title, table),) = explorer.markdown_tables(text)
    assert title == "A title"
    assert list(table.columns) == ["method", "RMSE ẋ", "RMSE ẋ (2)"]  # names made unique
    assert table.values.tolist() == [["a", "1.5 ± 0.2", "3"], ["b", "10 ± 1", "4"]]
    assert explorer.interval_columns(table) == ["RMSE ẋ"]
    figure = explorer.ranking_figure(table)
    assert [trace["name"] for trace in figure["data"]] == ["a", "b"]  # a trace per method
    assert figure["data"][1]["x"] == [10.0] and figure["data"][1]["error_x"]["array"] == [1.0]
    # a cell that is not "number ± number" is no point (a gap), never an error
    odd = pd.DataFrame({"method": ["a", "b", "c"], "RMSE": ["1 ± 2-3", "2 ± 0.5", "3 ± 1"]})
    assert explorer.ranking_figure(odd)["data"][0]["x"] == [None]


def test_the_special_figures_take_non_finite_and_text_values_as_gaps():
    frame = pd.DataFrame(
        {
            "method": ["a", "a", "b"],
            "order": ["ẋ", "ẋ", "ẋ"],
            "delay (ms)": ["1.5", "—", "2"],
            "RMSE delay-compensated": [float("inf"), 3.0, 4.0],
        }
    )
    figure = explorer.delay_figure(frame)
    assert [t["x"] for t in figure["data"]] == [[1.5], [2.0]]  # the text delay left out
    assert figure["data"][0]["y"] == [None]  # inf: a gap
    page = explorer._figure_html(figure, "f")  # and the page's JSON takes it
    assert "Infinity" not in page and "NaN" not in page


def test_a_page_holds_every_table_of_the_folder_and_loads_plotly_from_its_assets():
    folder = RESULTS / "paper-signal"
    page = explorer.explorer_page(folder, "paper-signal", assets="../assets")
    tables = [t for path in folder.glob("*.md") for t in explorer.markdown_tables(path.read_text())]
    assert page.count("<table") == len(tables) >= 3
    assert '<script src="../assets/plotly.min.js"></script>' in page
    assert "http" not in page.split("<body>")[1]  # nothing fetched from a server


def _browser():
    pytest.importorskip("plotly", reason="plotly is not installed (pip install 'diffbench[docs]')")
    sync_api = pytest.importorskip(
        "playwright.sync_api", reason="Playwright is not installed (pip install playwright)"
    )
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("no Chromium on PATH (Debian: apt-get install chromium; .ci/run installs it)")
    return sync_api, chromium


@contextlib.contextmanager
def _opened(sync_api, chromium: str, page_path: Path):
    """The page at ``page_path`` in headless Chromium, and the list its script errors go to."""
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
        page = browser.new_page()
        errors = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(page_path.as_uri())
        try:
            yield page, errors
        finally:
            browser.close()


def test_the_explorer_sorts_filters_toggles_and_draws_in_a_real_browser(tmp_path):
    sync_api, chromium = _browser()
    folder = RESULTS / "paper-signal"
    (page_path, _) = explorer.write_explorer(folder, tmp_path, "paper-signal")
    rmse = explorer.markdown_tables((folder / "rmse.md").read_text())[0][1]
    tables = [
        t for p in sorted(folder.glob("*.md")) for t in explorer.markdown_tables(p.read_text())
    ]
    index = next(i for i, (_, t) in enumerate(tables, 1) if t.equals(rmse))
    column = "RMSE ẋ interior"
    means = [float(cell.split("±")[0]) for cell in rmse[column]]
    with _opened(sync_api, chromium, page_path) as (page, errors):
        page.wait_for_selector(".js-plotly-plot .main-svg")  # a figure rendered
        table = page.locator(f"#table-{index}")
        column_index = list(rmse.columns).index(column)
        first_cell = table.locator("tbody tr").first.locator("td").nth(column_index)
        header = table.locator("th").nth(column_index)
        header.click()  # ascending
        assert float(first_cell.inner_text().split("±")[0]) == min(means)
        header.click()  # descending
        assert float(first_cell.inner_text().split("±")[0]) == max(means)
        page.locator(f'input[data-table="table-{index}"]').fill("kalman")
        shown = table.locator("tbody tr:not([hidden])")
        assert shown.count() == sum("kalman" in " ".join(row) for row in rmse.values.tolist())
        assert all("kalman" in text for text in shown.all_inner_texts())
        # the legend toggles a method's trace in the ranking figure above the rmse table
        figure = f"figure-of-table-{index}"
        name = page.locator("text.legendtext", has_text=re.compile(r"^kalman$"))
        item = page.locator(f"#{figure} g.traces", has=name)
        item.locator("rect.legendtoggle").click()  # what a click on the legend lands on
        # Plotly toggles once its double-click delay has passed (a single click, then)
        hidden = f"document.getElementById('{figure}').data.find(t => t.name == 'kalman')"
        page.wait_for_function(f"{hidden}.visible === 'legendonly'", timeout=10_000)
        traces = page.evaluate(f"document.getElementById('{figure}').data.length")
        assert traces == len(set(rmse["method"]))
        assert errors == []


@pytest.mark.parametrize("folder", ["studies/online", "studies/paper-figures"])
def test_the_special_figures_read_their_csv(folder):
    path = RESULTS / folder
    csv = path / ("sweep.csv" if folder.endswith("online") else "error_vs_position.csv")
    frame = pd.read_csv(csv)
    build = explorer.delay_figure if folder.endswith("online") else explorer.position_figure
    figure = build(frame)
    if folder.endswith("online"):
        swept = frame[(frame["order"] == "ẋ") & (frame["delay (ms)"] > 0)]
        assert sum(len(t["x"]) for t in figure["data"]) == len(swept)
    else:
        methods = [c for c in frame.columns if c.endswith("_velocity_rms_error")]
        assert len(figure["data"]) == len(methods)
        assert all(len(t["y"]) == len(frame) for t in figure["data"])


@pytest.mark.parametrize("along", ["level", "step_ms"])
def test_the_grid_figures_plot_each_methods_error_against_level_and_step(along):
    """Every cell of the grid's ``errors.csv`` is a point, once: a menu entry per rest of the
    cell (noise kind, the other axis, order, region) shows one line per method, whose points
    are that method's rows, in order along the axis."""
    frame = pd.read_csv(RESULTS / "studies" / "grid" / "errors.csv")
    figure = explorer.grid_errors_figure(frame, along)
    other = "step_ms" if along == "level" else "level"
    combos = frame.groupby(["noise", other, "order", "region"], sort=False)
    buttons = figure["layout"]["updatemenus"][0]["buttons"]
    assert len(buttons) == combos.ngroups
    assert sum(len(trace["x"]) for trace in figure["data"]) == len(frame)
    for button, (_, group) in zip(buttons, combos, strict=True):
        flags = button["args"][0]["visible"]
        visible = [t for t, shown in zip(figure["data"], flags, strict=True) if shown]
        assert sorted(t["name"] for t in visible) == sorted(set(group["method"]))
        for trace in visible:
            rows = group[group["method"] == trace["name"]].sort_values(along)
            assert trace["x"] == rows[along].tolist() and trace["y"] == rows["rmse"].tolist()
    first = [t["visible"] for t in figure["data"]]
    assert first == buttons[0]["args"][0]["visible"]  # the page opens on the first entry


def test_the_grid_explorer_switches_its_cell_in_a_real_browser(tmp_path):
    sync_api, chromium = _browser()
    folder = RESULTS / "studies" / "grid"
    (page_path, _) = explorer.write_explorer(folder, tmp_path, "grid")
    figure = explorer.grid_errors_figure(pd.read_csv(folder / "errors.csv"), "level")
    buttons = figure["layout"]["updatemenus"][0]["buttons"]
    first, second = (sum(b["args"][0]["visible"]) for b in buttons[:2])
    with _opened(sync_api, chromium, page_path) as (page, errors):
        page.wait_for_selector("#figure-errors-level .main-svg")
        shown = (
            "document.getElementById('figure-errors-level').data"
            ".filter(t => t.visible === true).length"
        )
        assert page.evaluate(shown) == first
        page.locator("#figure-errors-level .updatemenu-header-group").click()
        page.locator("#figure-errors-level .updatemenu-dropdown-button").nth(1).click()
        page.wait_for_function(f"{shown} === {second}", timeout=10_000)
        assert errors == []
