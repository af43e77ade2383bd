"""IDIM-LS against known parameters, and its bad-input table."""

import numpy as np
import pytest

from diffbench import methods
from diffbench.bench import robot
from diffbench.bench.cli import main
from diffbench.bench.identification import decimation_factor, idim_ls, parallel_decimation
from diffbench.bench.runner import compute_cell, preset_entry
from diffbench.signals import robot2r

NAMES = robot2r.PARAMETER_NAMES


@pytest.fixture(scope="module")
def scenario():
    return robot2r.get_robot_scenario("robot-sim-short")


def _exact(scenario):
    motion = scenario.motion()
    return robot2r.regressor(motion.q, motion.qd, motion.qdd), motion.tau


def test_exact_derivatives_and_no_noise_recover_the_parameters(scenario):
    observation, torques = _exact(scenario)
    factor = decimation_factor(100.0, 2.5)
    result = idim_ls(observation, torques, NAMES, factor, edge_samples=4)
    np.testing.assert_allclose(result.estimate, robot2r.PAPER_PARAMETERS, rtol=1e-8)
    assert result.sigma_rho < 1e-10
    assert factor == 16 and result.equations == 2 * (-(-observation.shape[0] // 16) - 8)


def test_decimation_is_applied_identically_to_y_and_every_column_of_w(scenario):
    observation, torques = _exact(scenario)
    w = parallel_decimation(observation, 16)
    y = parallel_decimation(torques, 16)
    # Y = W X holds sample by sample; a linear filter applied alike keeps it exactly
    np.testing.assert_allclose(w @ robot2r.PAPER_PARAMETERS, y, rtol=0, atol=1e-11)
    # and each column is the same scipy decimation as Y's
    from scipy import signal as sps

    column = sps.decimate(observation[:, 1, 2], 16, ftype="iir", zero_phase=True)
    np.testing.assert_array_equal(w[:, 1, 2], column)


def test_sigma_is_one_standard_deviation(scenario):
    """Monte Carlo with white torque noise of one std on both joints (the OLS assumption
    C_ρρ = σ²I) and exact derivatives: the spread of X̂ over seeds matches the reported
    one-sigma σ_X (not 2σ as in the paper's table)."""
    observation, torques = _exact(scenario)
    estimates, sigmas = [], []
    for seed in range(16):
        noise = 0.1 * np.random.default_rng(seed).standard_normal(torques.shape)
        result = idim_ls(observation, torques + noise, NAMES, 16, 4)
        estimates.append(result.estimate)
        sigmas.append(result.sigma)
    ratio = np.std(estimates, axis=0, ddof=1) / np.mean(sigmas, axis=0)
    assert np.all((ratio > 0.55) & (ratio < 1.6)), ratio
    assert 0.8 < np.median(ratio) < 1.25, ratio


def test_every_method_identifies_the_well_excited_parameters_within_a_few_percent(scenario):
    # every method with a robot preset (the peers run robot tasks at their class defaults)
    for name in [n for n in methods.available() if "robot" in methods.method_class(n).presets]:
        (cell,) = preset_entry(name, "robot").cells("robot-sim-short", [0])
        rows = compute_cell(cell)
        values = {row["metric"]: row["value"] for row in rows if row["order"] == 0}
        assert values["param_error_norm"] < 0.05, name
        assert values["cond_W"] < 50
        relative_torque = values["torque_rel_rmse.joint1"]
        assert relative_torque < 0.05, (name, relative_torque)


def test_well_excited_set_leaves_out_the_poorly_identified_parameters(scenario):
    mask = dict(zip(NAMES, robot.well_excited(scenario), strict=True))
    assert mask["ZZ1R"] and mask["FC1"] and not mask["MY2"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ("mismatch", r"same samples and joints \(mismatched lengths of q and tau\?\)"),
        ("nan", r"rows of W or Y hold NaN or inf \(first at sample 7\)"),
        ("still", r"rank deficient: cond\(W\) = .* the trajectory does not excite"),
        ("names", r"`names` has 7 entries for 8 columns"),
        ("short", r"equations for 8 parameters"),
    ],
)
def test_bad_input(scenario, change, message):
    observation, torques = _exact(scenario)
    names = NAMES
    if change == "mismatch":
        torques = torques[:-3]
    elif change == "nan":
        observation = observation.copy()
        observation[7, 0, 2] = np.nan
    elif change == "still":  # joint 2 never moves: its friction columns vanish
        observation = observation.copy()
        observation[:, :, 6:] = 0.0
    elif change == "names":
        names = NAMES[:-1]
    elif change == "short":
        observation, torques = observation[:3], torques[:3]
    with pytest.raises(ValueError, match=message):
        idim_ls(observation, torques, names)


def test_run_robot_sim_writes_the_tables_and_rejects_an_unknown_method(tmp_path, capsys):
    args = ["run", "robot-sim-short", "--seeds", "2", "--out", str(tmp_path), "--methods",
            "jacobi,butterworth", "--no-progress"]  # fmt: skip
    assert main(args) == 0
    table = (tmp_path / "robot-sim-short" / "table2.md").read_text()
    assert "| ZZ1R        | 3.496  |" in table and "σ" in table
    summary = (tmp_path / "robot-sim-short" / "summary.md").read_text()
    assert "| jacobi " in summary and "cond(W)" in summary
    assert (tmp_path / "robot-sim-short" / "fig5_robot_derivatives.png").exists()
    bad = ["run", "robot-sim-short", "--methods", "jacobbi"]
    assert main(bad) == 2
    assert "unknown method 'jacobbi'" in capsys.readouterr().err


def test_dfki_leave_one_run_out_predicts_measured_torque(tmp_path):
    """Real data: the model identified on five runs predicts the sixth run's measured torque
    about as well as the lab's published model (both well below the torque's own RMS)."""
    from diffbench.bench.robot import DfkiCrossValidation, score_dfki_fold

    method = methods.preset("savitzky_golay", "robot")
    rows = {r["metric"]: r["value"] for r in score_dfki_fold(method, DfkiCrossValidation(), 2)}
    for joint in (1, 2):
        ours, lab = rows[f"torque_rmse.joint{joint}"], rows[f"lab_torque_rmse.joint{joint}"]
        assert ours < 0.25 and lab < 0.3
        assert ours < 1.5 * lab
    assert rows["velocity_rmse_vs_driver"] < 0.5
    assert rows["cond_W"] < 2000
    with pytest.raises(ValueError, match=r"held-out run \(seed\) must be in 0..5, got 6"):
        score_dfki_fold(method, DfkiCrossValidation(), 6)


def test_dfki_passive_joints_are_not_scored():
    from diffbench.bench.robot import DfkiCrossValidation, score_dfki_fold

    method = methods.get("finite_difference")
    metrics = {r["metric"] for r in score_dfki_fold(method, DfkiCrossValidation(), 3)}
    assert "torque_rmse.joint2" in metrics and "torque_rmse.joint1" not in metrics


def test_run_dfki_cli(tmp_path, capsys):
    args = ["run", "dfki-cv", "--out", str(tmp_path), "--methods", "finite_difference",
            "--no-progress"]  # fmt: skip
    assert main(args) == 0
    summary = (tmp_path / "dfki-cv" / "summary.md").read_text()
    assert "| finite_difference |" in summary and "lab τ RMSE joint 1" in summary
    table = (tmp_path / "dfki-cv" / "table2.md").read_text()
    assert "A5_g_m1r1_m2l1" in table
    assert main([*args, "--seeds", "7"]) == 2
    assert "--seeds must be at most 6" in capsys.readouterr().err
