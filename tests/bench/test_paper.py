"""The paper's figures and table I: the numbers they must show."""

import numpy as np
import pytest
from diffbench.bench import paper
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


def test_paper_figures_command_writes_everything(tmp_path, capsys):
    assert main(["paper-figures", "--out", str(tmp_path)]) == 0
    for name in ("fig1_errors", "fig2_bode", "fig3_parameters"):
        assert (tmp_path / "paper-figures" / f"{name}.png").stat().st_size > 10_000
        assert (tmp_path / "paper-figures" / f"{name}.csv").exists()
    frequency = (tmp_path / "paper-figures" / "frequency.md").read_text()
    assert "| jacobi | 2 |" in frequency
