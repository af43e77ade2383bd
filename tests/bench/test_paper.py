"""The paper's figures and table I: the numbers they must show."""

import numpy as np
import pandas as pd
import pytest
from diffbench.bench import paper, runner
from diffbench.bench.cli import main


def test_figure2_gives_the_published_value_at_15_hz():
    data = paper.figure2_data()
    at15 = {c: np.interp(np.log(15.0), np.log(data["frequency_hz"]), data[c])
            for c in ("jacobi_db", "butterworth_db", "ideal_db")}  # fmt: skip
    assert at15["ideal_db"] == pytest.approx(20 * np.log10((2 * np.pi * 15) ** 2), abs=1e-3)
    assert at15["jacobi_db"] == pytest.approx(78.5, abs=0.2)  # the paper's data tip
    # far above the band both differentiators cut off by more than 100 dB below the ideal
    high = data["frequency_hz"] > 150
    assert (data.loc[high, "ideal_db"] - data.loc[high, "jacobi_db"] > 100).all()
    assert (data.loc[high, "ideal_db"] - data.loc[high, "butterworth_db"] > 100).all()


def test_figure3_shows_the_paper_trends():
    """Paper sec. III.C: raising kappa = mu or q moves the descending point to higher
    frequencies; raising T moves it lower."""
    data = paper.figure3_data()
    frequency = data["frequency_hz"].to_numpy()

    def cutoff(column):  # first frequency 3 dB below the ideal
        gap = data["ideal_db"] - data[column]
        return frequency[np.argmax(gap.to_numpy() > 3)]

    assert cutoff("kappa=mu=0.1_db") < cutoff("kappa=mu=2_db") < cutoff("kappa=mu=12_db")
    assert cutoff("q=2_db") < cutoff("q=6_db") < cutoff("q=12_db")
    assert cutoff("T=0.05_db") > cutoff("T=0.1_db") > cutoff("T=0.2_db")


def test_figure1_errors_are_finite_where_the_methods_estimate():
    data = paper.figure1_data(seed=0)
    middle = (data["t_s"] >= 0.105) & (data["t_s"] <= 0.895)
    assert np.isfinite(data.loc[middle].to_numpy()).all()
    assert data["jacobi_velocity_error"].isna().sum() == 2 * 105


def test_table1_directions_measured():
    """Table I of the paper: kappa=mu up -> noise up, truncation (bias) down; q up -> noise up,
    bias down; T up -> noise down, bias up. Checked on ẋ and ẍ, mean of 2 seeds."""
    rows = []
    for cell in paper.influence_cells(range(2)):
        for row in runner.compute_cell(cell):
            rows.append({"params": tuple(sorted(cell.params.items())), **row})
    frame = pd.DataFrame(rows)
    interior = frame[frame["region"] == "interior"]
    means = interior.groupby(["params", "order", "metric"])["value"].mean()
    base = dict(paper.influence_cells(range(1))[0].params)

    def value(change, order, metric):
        return means[(tuple(sorted({**base, **change}.items())), order, metric)]

    for order in (1, 2):
        for low, high, noise_up in (
            ({"kappa": 6.0, "mu": 6.0}, {"kappa": 24.0, "mu": 24.0}, True),
            ({"q": 2}, {"q": 10}, True),
            (
                {"window_s": 0.1, "accel_window_s": 0.1},
                {"window_s": 0.3, "accel_window_s": 0.3},
                False,
            ),
        ):
            noise_rises = value(high, order, "noise_rmse") > value(low, order, "noise_rmse")
            bias_falls = value(high, order, "bias_rmse") < value(low, order, "bias_rmse")
            assert noise_rises == noise_up and bias_falls == noise_up, (low, high, order)


def test_paper_figures_command_writes_everything(tmp_path, capsys):
    assert main(["paper-figures", "--out", str(tmp_path), "--seeds", "1", "--no-progress"]) == 0
    for name in ("fig1_errors", "fig2_bode", "fig3_parameters"):
        assert (tmp_path / "paper-figures" / f"{name}.png").stat().st_size > 10_000
        assert (tmp_path / "paper-figures" / f"{name}.csv").exists()
    frequency = (tmp_path / "paper-figures" / "frequency.md").read_text()
    assert "| jacobi | 2 |" in frequency
    table = (tmp_path / "jacobi-influence" / "table1.md").read_text()
    assert table.count("| jacobi |") == len(paper.INFLUENCE_VARIANTS)
