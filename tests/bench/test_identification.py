"""IDIM-LS against known parameters, and its bad-input table."""

import dataclasses
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from diffbench import methods
from diffbench.bench.cli import main
from diffbench.bench.runner import compute_cell, preset_entry
from diffbench.bench.studies import dfki as dfki_study
from diffbench.bench.studies import robot
from diffbench.bench.studies.identification import decimation_factor, idim_ls, parallel_decimation
from diffbench.signals import robot2r
from tests.signals import dfki_synthetic as syn

NAMES = robot2r.PARAMETER_NAMES
ROOT = Path(__file__).resolve().parents[2]


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


def test_robot_derivative_errors_on_the_interior_and_on_the_whole_record(scenario):
    """The whole-record q̇, q̈ errors are those of every sample the method marks valid against
    the exact derivatives, recomputed here; Butterworth estimates the whole record."""
    method = methods.preset("butterworth", "robot")
    (cell,) = preset_entry("butterworth", "robot").cells("robot-sim-short", [0])
    rows = {(r["metric"], r["order"]): r["value"] for r in compute_cell(cell)}
    realisation = scenario.realise(0)
    estimate = method(realisation.q, realisation.dt_s)
    for order, exact in ((1, realisation.truth.qd), (2, realisation.truth.qdd)):
        valid = estimate.valid[order]
        error = estimate[order][valid] - exact[valid]
        assert rows[("whole_coverage", order)] == valid.mean()
        assert rows[("whole_derivative_rmse", order)] == pytest.approx(
            np.sqrt(np.mean(error**2)), rel=1e-12
        )
        inside = realisation.interior
        assert rows[("derivative_rmse", order)] < rows[("whole_derivative_rmse", order)]
        assert valid[inside].all()


def test_each_method_differentiates_a_robot_record_once_and_the_scores_are_unchanged(
    scenario, monkeypatch
):
    """The measured q is the same for every noise seed: the second seed's cell takes the first
    one's estimate; its scores equal those computed afresh, and another record is another
    estimate."""
    method = methods.preset("savitzky_golay", "robot")
    calls = []
    monkeypatch.setattr(robot, "_estimates", robot.OrderedDict())
    original = type(method).__call__

    def counted(self, *args, **kwargs):
        calls.append(self.name)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(type(method), "__call__", counted)
    first = robot.score_identification(method, scenario, 0)
    second = robot.score_identification(method, scenario, 1)
    assert len(calls) == 1
    robot._estimates.clear()
    assert robot.score_identification(method, scenario, 1) == second
    assert len(calls) == 2 and second != first  # the torques' noise differs between seeds

    realisation = scenario.realise(0)
    kept = robot.estimate_of(method, realisation.q, realisation.dt_s)
    assert robot.estimate_of(method, realisation.q.copy(), realisation.dt_s) is kept
    with pytest.raises(ValueError, match="read-only"):
        kept[1][0, 0] = 0.0
    shifted = realisation.q.copy()
    shifted[100, 0] += scenario.encoder_step_rad
    assert robot.estimate_of(method, shifted, realisation.dt_s) is not kept
    other = methods.preset("butterworth", "robot")
    assert robot.estimate_of(other, realisation.q, realisation.dt_s) is not kept
    assert len(calls) == 3  # the shifted record (butterworth is another class)


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
    args = [
        "run",
        "robot-sim-short",
        "--seeds",
        "2",
        "--out",
        str(tmp_path),
        "--methods",
        "jacobi,butterworth",
        "--no-progress",
    ]
    assert main(args) == 0
    table = (tmp_path / "robot-sim-short" / "table2.md").read_text()
    assert "| ZZ1R        | 3.496  |" in table and "σ" in table
    summary = (tmp_path / "robot-sim-short" / "summary.md").read_text()
    assert "| jacobi " in summary and "cond(W)" in summary
    assert (tmp_path / "robot-sim-short" / "fig5_robot_derivatives.png").exists()
    bad = ["run", "robot-sim-short", "--methods", "jacobbi"]
    assert main(bad) == 2
    assert "unknown method 'jacobbi'" in capsys.readouterr().err


def _independent_raw_rmse(method, spec, held_out, estimate_rows):
    """The held-out run's raw-torque RMSE per joint recomputed directly from the method's
    estimate at the logged time stamps and the identified parameters (no stored sums)."""
    from diffbench.signals import dfki

    record = dfki.read_dfki_record(held_out)
    t = record.t
    inside = (t >= t[0] + spec.interior_margin_s) & (t <= t[-1] - spec.interior_margin_s)
    estimate = method(record.q, spec.nominal_dt_s, t=t)
    q, qd, qdd = (estimate[order][inside] for order in (0, 1, 2))
    lab = dfki.lab_parameters()
    w = dfki.tie_a4_to_a6(dfki.pendulum_regressor(q, qd, qdd), lab["l1"], lab["g"])
    x = np.array([estimate_rows[f"estimate.{name}"] for name in dfki.TIED_PARAMETER_NAMES])
    ours = np.sqrt(np.mean((w @ x - record.tau[inside]) ** 2, axis=0))
    theirs = np.sqrt(
        np.mean((dfki.lab_model_torques(q, qd, qdd) - record.tau[inside]) ** 2, axis=0)
    )
    everywhere = estimate.valid[0] & estimate.valid[1] & estimate.valid[2]
    q, qd, qdd = (estimate[order][everywhere] for order in (0, 1, 2))
    w = dfki.tie_a4_to_a6(dfki.pendulum_regressor(q, qd, qdd), lab["l1"], lab["g"])
    whole = np.sqrt(np.mean((w @ x - record.tau[everywhere]) ** 2, axis=0))
    return ours, theirs, whole, everywhere.mean()


def test_dfki_fold_scores_the_measured_torque_at_the_logged_time_stamps():
    """Real data: the model identified on five runs (A4 tied to A6) predicts the sixth run's
    torque as logged; the stored score equals a direct recomputation from the estimate at the
    logged times, is about as good as the lab's published model, and the filtered score (both
    sides decimated) is smaller than the raw one."""
    from diffbench.bench.studies.dfki import DfkiCrossValidation, score_dfki_fold

    spec = DfkiCrossValidation()
    method = methods.preset("savitzky_golay", "robot")
    rows = {r["metric"]: r["value"] for r in score_dfki_fold(method, spec, 2)}
    assert "estimate.A4_m2_l1_r2" not in rows and "velocity_rmse_vs_driver" not in rows
    ours, lab, whole, share = _independent_raw_rmse(method, spec, 2, rows)
    assert rows["whole_coverage"] == share and share > 0.95
    for joint in (1, 2):
        raw = rows[f"torque_rmse.joint{joint}"]
        assert raw == pytest.approx(ours[joint - 1], rel=1e-9)
        assert rows[f"whole_torque_rmse.joint{joint}"] == pytest.approx(whole[joint - 1], rel=1e-9)
        assert rows[f"lab_torque_rmse.joint{joint}"] == pytest.approx(lab[joint - 1], rel=1e-12)
        assert raw < 0.3 and raw < 1.5 * lab[joint - 1]
        assert rows[f"filtered_torque_rmse.joint{joint}"] < raw
    assert rows["coverage"] == 1.0 and rows["cond_W"] < 2000
    with pytest.raises(ValueError, match=r"held-out run \(seed\) must be in 0..5, got 6"):
        score_dfki_fold(method, spec, 6)


def test_dfki_finite_differences_are_worst_on_raw_torque_not_on_filtered():
    """Raw torque separates the methods: finite differences pass the encoder's quantisation
    noise to q̈ (raw joint-1 error 12 N·m on run 2 against 0.12 for Butterworth); decimating
    both sides hides most of it (0.52 against 0.10)."""
    from diffbench.bench.studies.dfki import DfkiCrossValidation, score_dfki_fold

    spec = DfkiCrossValidation()
    scores = {}
    for name in ("finite_difference", "butterworth"):
        rows = score_dfki_fold(methods.preset(name, "robot"), spec, 2)
        scores[name] = {r["metric"]: r["value"] for r in rows}
    fd, bw = scores["finite_difference"], scores["butterworth"]
    assert fd["torque_rmse.joint1"] > 50 * bw["torque_rmse.joint1"]
    assert fd["filtered_torque_rmse.joint1"] < 10 * bw["filtered_torque_rmse.joint1"]


def test_dfki_passive_joints_are_not_scored():
    from diffbench.bench.studies.dfki import DfkiCrossValidation, score_dfki_fold

    method = methods.get("finite_difference")
    metrics = {r["metric"] for r in score_dfki_fold(method, DfkiCrossValidation(), 3)}
    assert "torque_rmse.joint2" in metrics and "torque_rmse.joint1" not in metrics


def _copies(tmp_path, runs):
    from importlib.resources import files

    data = files("diffbench.signals") / "data" / "dfki-double-pendulum"
    paths = []
    for run in runs:
        path = tmp_path / f"trajectory_0{run}.csv.gz"
        path.write_bytes((data / f"trajectory_0{run}.csv.gz").read_bytes())
        paths.append(path)
    return paths


def test_nested_settings_never_see_the_held_out_run(tmp_path):
    """The setting chosen for a held-out run depends on the other runs only: replacing the
    held-out run's torques by garbage changes neither the choice nor its inner loss, and the
    choice is the candidate with the least leave-one-run-out raw-torque error over the others
    (checked by scoring every candidate)."""
    import gzip

    from diffbench.bench.studies.dfki import (
        DfkiCrossValidation,
        candidate_settings,
        choose_setting,
        inner_loss,
    )

    paths = _copies(tmp_path, (0, 1, 2, 4))
    spec = DfkiCrossValidation(records=tuple(paths), candidates=4)
    method = methods.preset("savitzky_golay", "robot")
    chosen, loss = choose_setting(method, spec, 0)
    losses = [inner_loss(c, spec, 0) for c in candidate_settings(method, spec)]
    assert len(losses) == 5 and loss == min(losses) and math.isfinite(loss)
    text = gzip.decompress(paths[0].read_bytes()).decode().splitlines()
    names = text[0].split(",")
    column = names.index("tau_meas1")
    rows = [line.split(",") for line in text[1:]]
    for k, row in enumerate(rows):
        row[column] = str(100.0 * (-1) ** k)
    corrupted = tmp_path / "corrupted.csv"
    corrupted.write_text("\n".join([text[0], *(",".join(r) for r in rows)]) + "\n")
    other = DfkiCrossValidation(records=(corrupted, *paths[1:]), candidates=4)
    again, loss_again = choose_setting(method, other, 0)
    assert again == chosen and loss_again == loss
    assert inner_loss(chosen, other, 1) != inner_loss(chosen, spec, 1)  # it is used elsewhere


def test_run_identify_dfki_cli(tmp_path, capsys):
    args = [
        "run",
        "identify-dfki",
        "--out",
        str(tmp_path),
        "--methods",
        "finite_difference",
        "--no-progress",
    ]
    assert main([*args, "--seeds", "2"]) == 0  # two folds: the report, not the statistics
    summary = (tmp_path / "identify-dfki" / "summary.md").read_text()
    assert "| finite_difference |" in summary and "lab τ RMSE joint 1" in summary
    assert "settings by nested leave-one-run-out CV" in summary and "filtered:" in summary
    settings = (tmp_path / "identify-dfki" / "settings.md").read_text()
    assert settings.count("| finite_difference |") == 2 and "accuracy_order=" in settings
    table = (tmp_path / "identify-dfki" / "table2.md").read_text()
    assert "A5_g_m1r1_m2l1" in table and "A4_m2_l1_r2" not in table
    assert main([*args, "--seeds", "7"]) == 2
    assert "--seeds must be at most 6" in capsys.readouterr().err


def test_run_identify_dfki_on_records_a_user_points_at(tmp_path, capsys):
    paths = [str(p) for p in _copies(tmp_path, (0, 2, 4))]
    out = tmp_path / "out"
    args = [
        "run",
        "identify-dfki",
        "--out",
        str(out),
        "--methods",
        "finite_difference",
        "--no-progress",
        "--records",
        *paths,
    ]
    assert main(args) == 0
    (folder,) = [p for p in out.iterdir() if p.name.startswith("identify-dfki-")]
    summary = (folder / "summary.md").read_text()
    assert paths[0] in summary and "| finite_difference |" in summary
    assert main(["run", "paper-signal", "--out", str(out), "--records", paths[0]]) == 2
    assert "--records is for identify-dfki only" in capsys.readouterr().err
    base = args[:-4]
    assert main([*base, "--records", paths[0], paths[1], str(tmp_path / "none.csv")]) == 2
    assert "none.csv: no such file" in capsys.readouterr().err
    assert main([*base, "--records", paths[0], paths[1]]) == 2
    assert "give at least 3 records" in capsys.readouterr().err


# --- records of another design: identified with that design's model, or refused -------------
@pytest.fixture(scope="module")
def design_a(tmp_path_factory):
    """Three 8 s records of the simulated design-A.0-like robot and its model file, where the
    lab's repository keeps them (tests/signals/dfki_synthetic.py)."""
    return syn.lab_tree(tmp_path_factory.mktemp("lab"))


def _decimated(values, spec):
    factor = decimation_factor(1 / spec.nominal_dt_s, spec.passband_hz)
    return parallel_decimation(values, factor)[robot.EDGE_SAMPLES : -robot.EDGE_SAMPLES]


def test_dfki_records_of_design_a_are_identified_with_their_model(design_a):
    """Exact truth: the fold's X̂ is the least-squares solution of the equations built with the
    model's l1 = 0.3 m: X̂ − X = W⁺ r_d + W⁺ r_n, with r_d = (W_exact − W) X the
    differentiator's error and r_n the torque noise, decimated alike, both known here. The
    tolerance per parameter is |W⁺ r_d|_i + 4 σ_n ‖(W⁺)_i‖ (σ_n the decimated noise's standard
    deviation: 4 of the noise term's own standard deviations), below 1 % of the five inertial
    and gravity parameters and 10 % of the friction ones (measured: at most 0.1 % and 1.5 %).
    The "lab" column is this model's torque error, computed here from the robot's own inverse
    dynamics."""
    from diffbench.bench.tasks import dfki_task
    from diffbench.signals import dfki

    records, model_path, motions = design_a
    spec = dfki_task(records, robot_model=model_path).spec
    assert spec.model.design == "A.0" and spec.model.values["l1"] == 0.3
    method = methods.preset("savitzky_golay", "robot")
    rows = {r["metric"]: r["value"] for r in dfki_study.score_dfki_fold(method, spec, 0)}
    X = syn.true_base_parameters()
    truth = np.delete(X, dfki.PENDULUM_PARAMETER_NAMES.index("A4_m2_l1_r2"))
    estimate = np.array([rows[f"estimate.{name}"] for name in dfki.TIED_PARAMETER_NAMES])
    W, r_d, r_n = [], [], []
    for k in (1, 2):  # the training records of fold 0
        record, exact = dfki_study.dfki_record(records[k]), motions[k]
        np.testing.assert_array_equal(record.q, exact.q)  # 17 digits in the file: exact
        t = record.t
        inside = (t >= t[0] + spec.interior_margin_s) & (t <= t[-1] - spec.interior_margin_s)
        found = method(record.q, spec.nominal_dt_s, t=t)
        assert all(found.valid[order][inside].all() for order in (0, 1, 2))
        states = [found[order][inside] for order in (0, 1, 2)]
        w = dfki.tie_a4_to_a6(dfki.pendulum_regressor(*states), 0.3, 9.81)
        w_exact = dfki.tie_a4_to_a6(
            dfki.pendulum_regressor(exact.q[inside], exact.qd[inside], exact.qdd[inside]),
            0.3,
            9.81,
        )
        noise = record.tau[inside] - w_exact @ truth
        assert abs(np.std(noise) / syn.TORQUE_NOISE_NM - 1) < 0.05
        W.append(_decimated(w, spec))
        r_d.append(_decimated(w_exact - w, spec) @ truth)
        r_n.append(_decimated(noise, spec))
    W = np.concatenate(W).reshape(-1, truth.size)
    r_d, r_n = (np.concatenate(part).reshape(-1) for part in (r_d, r_n))
    pseudo_inverse = np.linalg.pinv(W)
    singular = np.linalg.svd(W, compute_uv=False)
    # QR least squares is backward stable: rounding moves X̂ by at most ~eps·cond(W)·‖X‖
    rounding = 100 * np.finfo(float).eps * (singular[0] / singular[-1]) * np.linalg.norm(truth)
    np.testing.assert_allclose(
        estimate - truth, pseudo_inverse @ (r_d + r_n), rtol=0, atol=rounding
    )
    tolerance = np.abs(pseudo_inverse @ r_d) + 4 * np.std(r_n) * np.linalg.norm(
        pseudo_inverse, axis=1
    )
    assert np.all(np.abs(estimate - truth) <= tolerance + rounding)
    relative = tolerance / np.abs(truth)
    assert np.all(relative[:5] < 0.01) and np.all(relative[5:] < 0.1), relative
    # the lab column: the model's torques (the robot's inverse dynamics), not the packaged ones
    record = dfki_study.dfki_record(records[0])
    t = record.t
    inside = (t >= t[0] + spec.interior_margin_s) & (t <= t[-1] - spec.interior_margin_s)
    found = method(record.q, spec.nominal_dt_s, t=t)
    states = [found[order][inside] for order in (0, 1, 2)]
    for joint in (0, 1):
        error = syn.inverse_dynamics(*states)[:, joint] - record.tau[inside, joint]
        packaged = dfki.lab_model_torques(*states)[:, joint] - record.tau[inside, joint]
        lab = rows[f"lab_torque_rmse.joint{joint + 1}"]
        # the two torques agree to 1e-12 N·m (tests/signals/test_dfki.py), so do their RMSEs
        assert abs(lab - np.sqrt(np.mean(error**2))) < 1e-11
        assert lab < 1.5 * syn.TORQUE_NOISE_NM < 0.1 * np.sqrt(np.mean(packaged**2))


def test_a_wrong_link_length_is_what_the_bound_catches(design_a):
    """The same records identified with the robot's parameters but the packaged l1 = 0.2 m
    (the A4–A6 tie of design C.0): the parameters come out far outside the bound above."""
    from diffbench.signals import dfki

    records, _, _ = design_a
    wrong = {**syn.DESIGN_A_PARAMETERS, "l1": 0.2}  # a mapping is read as a model
    spec = dfki_study.DfkiCrossValidation(records=tuple(records), model=wrong)
    assert spec.model == dfki.load_pendulum_model(wrong) and spec.model.values["l1"] == 0.2
    rows = {
        r["metric"]: r["value"]
        for r in dfki_study.score_dfki_fold(methods.preset("savitzky_golay", "robot"), spec, 0)
    }
    X = syn.true_base_parameters()
    truth = np.delete(X, dfki.PENDULUM_PARAMETER_NAMES.index("A4_m2_l1_r2"))
    estimate = np.array([rows[f"estimate.{name}"] for name in dfki.TIED_PARAMETER_NAMES])
    assert np.max(np.abs(estimate / truth - 1)) > 0.2
    assert rows["torque_rmse.joint1"] > 3 * syn.TORQUE_NOISE_NM


def test_dfki_records_of_another_design_are_refused_without_their_model(design_a, tmp_path):
    """The packaged design C.0 model is never silently used for other records: a record under
    design_A.0/ is refused by its path; the same file elsewhere by its torque (the C.0 model
    predicts it about 33 times worse than the fitted equations, the limit is 4); with the
    design's model file the same records run. On the real packaged runs a design-A.0 model is
    refused likewise (runs named C.0; as a mapping of unknown design, by the torque of run 0,
    ratio 16.8)."""
    from diffbench.bench.tasks import dfki_task

    records, model_path, _ = design_a
    with pytest.raises(
        ValueError,
        match=r"trajectory_00\.csv is a record of design A\.0 \(its "
        r"path says so\) but the robot model is design C\.0 \(packaged with "
        r"diffbench\): give .*design_A\.0/model_\*/model_parameters\.yml; CLI "
        r"--robot-model FILE",
    ):
        dfki_task(records)
    plain = []
    for path in records:
        plain.append(tmp_path / path.name)
        plain[-1].write_bytes(path.read_bytes())
    with pytest.raises(
        ValueError,
        match=r"trajectory_00\.csv: the robot model \(design C\.0 "
        r"\(packaged with diffbench\)\) predicts its measured torque 3\d\.\d "
        r"times worse .* --robot-model FILE",
    ):
        dfki_task(plain)
    assert dfki_task(plain, robot_model=model_path).spec.model.design == "A.0"
    with pytest.raises(ValueError, match=r"run 0 is a record of design C\.0 \(a packaged run\)"):
        dfki_task((0, 1, 2), robot_model=model_path)
    with pytest.raises(
        ValueError,
        match=r"run 0: the robot model \(the given parameters\) "
        r"predicts its measured torque 16\.\d times worse",
    ):
        dfki_task((0, 1, 2), robot_model=syn.DESIGN_A_PARAMETERS)
    with pytest.raises(
        ValueError, match=r"designs A\.0 \(.*trajectory_00\.csv\) and C\.0 \(run 1\)"
    ):
        dfki_task((records[0], 1, 2), robot_model=syn.DESIGN_A_PARAMETERS)


def test_dfki_cache_identity_holds_the_model(tmp_path):
    """The packaged task keeps its name and the packaged model; records with the packaged model
    (given or as a copy of its file) keep the digest they always had; another model is another
    task name, so the store never mixes their cells; a fold's rows with a copy of the packaged
    model file are the default's, bit for bit."""
    import hashlib

    from diffbench.bench.tasks import DfkiTask, get_task
    from diffbench.signals import dfki

    packaged = get_task("identify-dfki")
    assert packaged.name == "identify-dfki" and packaged.spec.model is dfki.packaged_model()
    paths = _copies(tmp_path, (0, 2, 4))
    digest = hashlib.sha256()  # the name's digest as it was before models were an input
    for path in paths:
        record = dfki.read_dfki_record(path)
        for array in (record.t, record.q, record.tau, record.tau_commanded):
            digest.update(np.ascontiguousarray(array).tobytes())
    old_name = f"identify-dfki-{digest.hexdigest()[:10]}"
    copy = tmp_path / "model_parameters.yml"
    copy.write_bytes((dfki._data_file("model_parameters.yml")).read_bytes())
    assert DfkiTask(records=tuple(paths)).name == old_name
    assert DfkiTask(records=tuple(paths), robot_model=copy).name == old_name
    other = DfkiTask(records=tuple(paths), robot_model={**dfki.lab_parameters(), "l1": 0.21})
    assert other.name.startswith("identify-dfki-") and other.name != old_name
    method = methods.preset("savitzky_golay", "robot")
    given = dfki_study.DfkiCrossValidation(model=dfki.load_pendulum_model(copy))
    assert given == dfki_study.DfkiCrossValidation() and given.model.source == str(copy)
    runs = (0, 2, 4)
    default = dfki_study.score_dfki_fold(method, dfki_study.DfkiCrossValidation(records=runs), 1)
    dfki_study._run_equations.cache_clear()  # recompute with the given model, not from the cache
    given = dataclasses.replace(given, records=runs)
    assert dfki_study.score_dfki_fold(method, given, 1) == default


def test_cli_robot_model_option_and_refusal(tmp_path):
    """As a process: records of design A.0 without --robot-model exit 2 with one line naming
    the fix; with it they run; --robot-model without --records exits 2."""
    records, model_path, _ = syn.lab_tree(tmp_path / "lab", duration_s=4.0)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    base = [
        sys.executable,
        "-m",
        "diffbench.bench",
        "run",
        "identify-dfki",
        "--out",
        str(tmp_path / "out"),
        "--methods",
        "finite_difference",
        "--no-progress",
    ]
    refused = subprocess.run(
        [*base, "--records", *map(str, records)], env=env, capture_output=True, text=True
    )
    assert refused.returncode == 2, refused.stderr
    assert refused.stderr.count("\n") == 1 and "Traceback" not in refused.stderr
    assert "is a record of design A.0" in refused.stderr and "--robot-model FILE" in refused.stderr
    done = subprocess.run(
        [*base, "--seeds", "1", "--records", *map(str, records), "--robot-model", str(model_path)],
        env=env,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    (folder,) = [p for p in (tmp_path / "out").iterdir() if p.name.startswith("identify-dfki-")]
    assert "| finite_difference |" in (folder / "summary.md").read_text()
    alone = subprocess.run(
        [*base, "--robot-model", str(model_path)], env=env, capture_output=True, text=True
    )
    assert alone.returncode == 2
    assert "--robot-model is valid with --records only" in alone.stderr


def test_a_nested_setting_reads_back_from_its_rows_and_a_later_parameter_takes_its_default():
    """``setting_of`` inverts ``_setting_rows`` (choices by index, integers rounded); rows
    stored before the method gained a parameter read that parameter at its default."""
    method = methods.get("jacobi", kappa=3.5, q=9, rule="linear", end_exponent=2.5)
    values = {
        row["metric"].removeprefix("setting."): row["value"]
        for row in dfki_study._setting_rows(method)
    }
    assert dfki_study.setting_of("jacobi", values) == method.params()
    del values["end_exponent"]
    assert dfki_study.setting_of("jacobi", values) == {**method.params(), "end_exponent": 0.0}
