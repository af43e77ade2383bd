"""Figures drawn from tables: styles, shared scales, the error-with-CI figure."""

import numpy as np
import pandas as pd
import pytest

from diffbench import methods
from diffbench.bench.report import figures


def _table():
    """Five settings of three methods, as tables.wide_table names them (one NaN mean, one NaN
    half-width)."""
    return pd.DataFrame(
        {
            "method": ["jacobi", "jacobi", "butterworth", "finite_difference", "butterworth"],
            "setting": [
                "preset (paper)",
                "oracle-tuned for ẍ",
                "preset (paper)",
                "preset (paper)",
                "no-truth-tuned for ẋ (f_c 20 Hz)",
            ],
            "RMSE ẋ interior mean": [4.8, 3.7, 3.8, 197.0, np.nan],
            "RMSE ẋ interior ci95": [0.33, 0.31, 0.31, 3.6, np.nan],
            "RMSE ẍ interior mean": [504.0, 400.0, 450.0, 5.4e5, 271.0],
            "RMSE ẍ interior ci95": [36.0, 30.0, 36.0, 8.2e3, np.nan],
            "seeds": [20, 20, 20, 20, 20],
        }
    )


def test_every_registered_method_has_its_own_colour_and_line_style():
    names = methods.available()
    styles = figures.method_styles(names)
    assert set(styles) == set(names)
    assert len({s.color for s in styles.values()}) == len(names)
    assert len({str(s.linestyle) for s in styles.values()}) == len(names)
    # a method keeps its style whichever others are drawn with it
    assert figures.method_styles(names[-1:])[names[-1]] == styles[names[-1]]


def test_error_scales_put_a_dwarfing_method_on_its_own_range():
    # median RMSE 4: 200 is 50x it, off-scale; the shared range covers the others' peaks
    rmse = {"a": 3.5, "b": 4.0, "c": 4.5, "fd": 200.0}
    peak = {"a": 9.0, "b": 12.0, "c": 10.0, "fd": 560.0}
    scales = figures.error_scales(rmse, peak)
    assert scales.off_scale == ("fd",)
    assert scales.shared == pytest.approx(1.1 * 12.0)
    assert scales.own["fd"] == pytest.approx(1.1 * 560.0)
    assert scales.ratio["fd"] == pytest.approx(200.0 / 4.25)
    assert figures.error_scales({"a": 1.0, "b": 2.9}, {"a": 1.0, "b": 5.0}).off_scale == ()


def test_error_figure_data_sorts_each_panel_best_first_and_skips_nan_means():
    points = figures.error_figure_data(_table())
    first = points[points["derivative"] == "ẋ"]
    assert list(first["label"]) == [
        "jacobi — oracle-tuned for ẍ",
        "butterworth — preset (paper)",
        "jacobi — preset (paper)",
        "finite_difference — preset (paper)",
    ]
    assert list(first["rank"]) == [0, 1, 2, 3]
    second = points[points["derivative"] == "ẍ"]
    assert second["label"].iloc[0] == "butterworth — no-truth-tuned for ẋ (f_c 20 Hz)"
    assert second["mean"].is_monotonic_increasing and len(second) == 5
    presets = dict(zip(second["label"], second["preset"], strict=True))
    assert presets["jacobi — preset (paper)"] and not presets["jacobi — oracle-tuned for ẍ"]


def test_error_figure_data_reads_the_stored_origin_when_there_is_one():
    table = _table().assign(origin=["tuned", "tuned", "preset", "preset", "tuned"])
    points = figures.error_figure_data(table)
    first = points[points["derivative"] == "ẋ"].set_index("label")
    assert not first.loc["jacobi — preset (paper)", "preset"]  # the stored origin wins


def test_write_error_figure_writes_a_png(tmp_path):
    path = figures.write_error_figure(_table(), tmp_path / "sub" / "errors.png", "test table")
    assert path == tmp_path / "sub" / "errors.png"
    assert path.stat().st_size > 10_000


@pytest.mark.parametrize("column", figures.ERROR_FIGURE_COLUMNS)
def test_write_error_figure_refuses_a_table_without_a_required_column(tmp_path, column):
    with pytest.raises(ValueError, match=f"lacks the column\\(s\\) '{column}'"):
        figures.write_error_figure(_table().drop(columns=column), tmp_path / "e.png", "t")
    assert not (tmp_path / "e.png").exists()


def test_write_error_figure_refuses_an_empty_table(tmp_path):
    with pytest.raises(ValueError, match="no rows"):
        figures.write_error_figure(_table().iloc[:0], tmp_path / "e.png", "t")
