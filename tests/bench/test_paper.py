"""The paper's figures and table I: the numbers they must show."""

import re

import numpy as np
import pandas as pd
import pytest

from diffbench import methods, signals
from diffbench.bench.studies import paper


def _linear_methods():
    return [name for name in methods.available() if methods.method_class(name).linear]


def test_figure2_gives_the_published_value_at_15_hz():
    data = paper.figure2_data()
    at15 = {
        c: np.interp(np.log(15.0), np.log(data["frequency_hz"]), data[c])
        for c in ("jacobi_db", "butterworth_db", "ideal_db")
    }
    assert at15["ideal_db"] == pytest.approx(20 * np.log10((2 * np.pi * 15) ** 2), abs=1e-3)
    assert at15["jacobi_db"] == pytest.approx(78.5, abs=0.2)  # the paper's data tip
    # far above the band both differentiators cut off by more than 100 dB below the ideal
    high = data["frequency_hz"] > 150
    assert (data.loc[high, "ideal_db"] - data.loc[high, "jacobi_db"] > 100).all()
    assert (data.loc[high, "ideal_db"] - data.loc[high, "butterworth_db"] > 100).all()


def test_bode_curves_stop_where_the_response_is_rounding():
    """Each curve is the method's |H| in dB down to 1e-8 of its peak (160 dB under it) and
    flat there: below, the computed response's rounding moved the curve with the BLAS kernel."""
    data = paper.figure2_data()
    frequency = data["frequency_hz"].to_numpy()
    for name in _linear_methods():
        exact = np.abs(methods.preset(name, "paper-signal").frequency_response(frequency, 1e-3, 2))
        curve = data[f"{name}_db"].to_numpy()
        floor = 20 * np.log10(1e-8 * exact.max())
        resolved = exact >= 1e-8 * exact.max()
        np.testing.assert_array_equal(curve[resolved], 20 * np.log10(exact[resolved]))
        np.testing.assert_array_equal(curve[~resolved], floor)


def test_figure2_draws_every_linear_method():
    columns = set(paper.figure2_data().columns)
    assert columns == {"frequency_hz", "ideal_db", *(f"{n}_db" for n in _linear_methods())}


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


@pytest.fixture(scope="module")
def figure1(tmp_path_factory):
    """Figure 1 written once: (CSV as read back, PNG path)."""
    csv, png = paper.write_figure1(tmp_path_factory.mktemp("fig1"), seed=0)
    return pd.read_csv(csv), png


def test_figure1_has_every_method_and_is_finite_in_the_interior(figure1):
    data, png = figure1
    for name in methods.available():
        assert f"{name}_velocity_error" in data and f"{name}_acceleration_error" in data
    errors = data.filter(regex="_error$")
    assert errors.shape[1] == 2 * len(methods.available())
    interior = data["interior"].to_numpy(dtype=bool)
    assert interior.sum() == 701  # 1 s at 1 ms less 0.15 s at each end, both ends included
    assert np.isfinite(errors[interior].to_numpy()).all()
    # the central window misses 105 samples at each end; the shifted windows estimate them,
    # and the figure shows those the ends check trusts (methods._ends)
    assert 0 < data["jacobi_velocity_error"].isna().sum() < 2 * 105
    assert png.stat().st_size > 10_000


def test_figure1_errors_are_estimate_minus_truth(figure1):
    """Central differences by hand on the CSV's noisy samples, the truth from the paper's
    formula x = sin(2π4t) + sin(2π9t) + sin(2π15t): their difference is the CSV's error."""
    data, _ = figure1
    t, x, dt = data["t_s"].to_numpy(), data["x_noisy"].to_numpy(), 1e-3
    omega = 2 * np.pi * np.array([4.0, 9.0, 15.0])
    for k in (1, 137, 500, 998):
        velocity = np.sum(omega * np.cos(omega * t[k]))
        acceleration = -np.sum(omega**2 * np.sin(omega * t[k]))
        assert data["x_true"][k] == pytest.approx(np.sum(np.sin(omega * t[k])), abs=1e-12)
        first = (x[k + 1] - x[k - 1]) / (2 * dt)
        second = (x[k + 1] - 2 * x[k] + x[k - 1]) / dt**2
        row = data.iloc[k]
        assert row["finite_difference_velocity_error"] == pytest.approx(
            first - velocity, rel=1e-9, abs=1e-9
        )
        assert row["finite_difference_acceleration_error"] == pytest.approx(
            second - acceleration, rel=1e-9, abs=1e-6
        )
    # the end samples, one-sided 3-point differences, pass on a sinusoid but amplify white
    # noise sqrt(26)/2 / (sqrt(2)/2) = 3.6 times the central ones (methods._ends): masked
    assert np.isnan(data["finite_difference_velocity_error"].iloc[[0, -1]]).all()
    assert np.isfinite(data["finite_difference_velocity_error"].iloc[[1, -2]]).all()


def test_figure5_has_every_method_with_a_robot_preset():
    data = paper.figure5_data("robot-sim-short", seed=0)
    expected = [n for n in methods.available() if "robot" in methods.method_class(n).presets]
    assert expected  # the registry has robot presets
    for name in expected:
        for prefix in ("qd1", "qdd1"):
            error = data[f"{prefix}_{name}_error"].to_numpy()
            assert np.isfinite(error[data["interior"].to_numpy()]).all()
    assert data.filter(regex="_error$").shape[1] == 2 * len(expected)
    # the error is estimate - truth: adding the truth back gives the method's estimate
    from diffbench.signals import robot2r

    realisation = robot2r.get_robot_scenario("robot-sim-short").realise(0)
    estimate = methods.preset("kalman", "robot")(realisation.q, realisation.dt_s)
    np.testing.assert_allclose(
        data["qdd1_kalman_error"] + data["qdd1_true"], estimate.trusted(2)[:, 0]
    )


def test_paper_figures_command_writes_everything(tmp_path, capsys):
    from diffbench.bench.cli import main  # imported here: the CLI is rewritten separately

    three = "jacobi,butterworth,finite_difference"  # every method: make bench's paper-figures
    assert main(["paper-figures", "--seeds", "1", "--methods", three, "--out", str(tmp_path)]) == 0
    for name in ("fig1_errors", "fig2_bode", "fig3_parameters", "error_vs_position"):
        assert (tmp_path / "paper-figures" / f"{name}.png").stat().st_size > 10_000
        assert (tmp_path / "paper-figures" / f"{name}.csv").exists()
    frequency = (tmp_path / "paper-figures" / "frequency.md").read_text()
    assert re.search(r"\| jacobi +\| 2 +\|", frequency)


def test_error_profile_is_the_rms_over_seeds_at_each_sample():
    seeds = 3
    sums = {name: paper.squared_error_sums(name, seeds) for name in ("jacobi", "spectral")}
    profile = paper.error_profile_frame(sums, seeds)
    scenario = signals.get_scenario(paper.SCENARIO)
    method = methods.preset("jacobi", "paper-signal")
    squares = 0.0
    for seed in range(seeds):
        realisation = scenario.realise(seed)
        squares = (
            squares
            + (method(realisation.x, realisation.dt_s).trusted(1) - realisation.truth[1]) ** 2
        )
    np.testing.assert_allclose(profile["jacobi_velocity_rms_error"], np.sqrt(squares / seeds))
    # both mark the ends they do not trust (spectral: its wide low-pass's ringing, 101
    # samples at the preset), which the profile leaves out: gaps at both ends, none inside
    for column in ("jacobi_acceleration_rms_error", "spectral_velocity_rms_error"):
        values = profile[column].to_numpy()
        finite = np.flatnonzero(np.isfinite(values))
        assert finite[0] > 0 and finite[-1] < len(values) - 1
        assert len(finite) == finite[-1] - finite[0] + 1
    assert np.flatnonzero(profile["spectral_velocity_rms_error"].notna())[0] == 101


def test_ends_table_splits_start_middle_and_end():
    n = 100
    start, middle, end = np.full(5, 3.0), np.full(90, 1.0), np.full(5, 4.0)
    acceleration = np.r_[np.full(5, np.nan), middle, np.full(5, np.nan)]
    velocity = np.r_[start, middle, end]
    profile = pd.DataFrame(
        {
            "t_s": np.arange(n) * 1e-3,
            "a_velocity_rms_error": velocity,
            "a_acceleration_rms_error": acceleration,
        }
    )
    table = paper.ends_table(profile, end_fraction=0.05).set_index("n")
    assert table.loc["ẋ", ["start", "middle", "end", "worst end / middle"]].tolist() == [3, 1, 4, 4]
    assert table.loc["ẋ", "coverage"] == 1.0
    assert np.isnan(table.loc["ẍ", "start"]) and np.isnan(table.loc["ẍ", "worst end / middle"])
    assert table.loc["ẍ", "coverage"] == 0.9
