"""DFKI double pendulum: packaged data, uniform resampling, the base-parameter regressor against
the lab's M, C, G, F and against an independent Lagrangian, and the lab model on real torques."""

import bisect
import csv
import dataclasses
import gzip
import io
import math
from importlib.resources import files

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from diffbench.signals.dfki import (
    DFKI_RUNS,
    PACKAGED_DESIGN,
    PENDULUM_PARAMETER_NAMES,
    TIED_PARAMETER_NAMES,
    DfkiRun,
    base_parameters,
    design_of_path,
    lab_base_parameters,
    lab_model_torques,
    lab_parameters,
    load_dfki_run,
    load_pendulum_model,
    packaged_model,
    pendulum_regressor,
    read_dfki_record,
    resample_uniform,
    tie_a4_to_a6,
)
from tests.signals import dfki_synthetic as syn

DATA = files("diffbench.signals") / "data" / "dfki-double-pendulum"
RAW_ROWS = (4993, 4974, 4979, 4993, 4999, 4997)  # data rows of trajectory_00..05.csv


@pytest.fixture(scope="module")
def runs():
    return [load_dfki_run(run) for run in range(DFKI_RUNS)]


def raw_csv(run):
    """The packaged CSV read with the csv module (independent of the loader): name -> column."""
    with (DATA / f"trajectory_0{run}.csv.gz").open("rb") as fh:
        text = gzip.decompress(fh.read()).decode("ascii")
    rows = list(csv.DictReader(io.StringIO(text)))
    return {name: np.array([float(row[name]) for row in rows]) for name in rows[0]}


def random_states(rng, n=64):
    q = rng.uniform(-math.pi, math.pi, (n, 2))
    qd = rng.uniform(-8.0, 8.0, (n, 2))
    qdd = rng.uniform(-60.0, 60.0, (n, 2))
    return q, qd, qdd


# ---------------------------------------------------------------------------------------------
# An independent Lagrangian: T = ½ q̇ᵀ M(q) q̇ with the lab's M, U with ∂U/∂q = −G, friction F.
# Derivatives by complex step (f(x + ih) has imaginary part h f'(x) to rounding, for h = 1e-30).


def mass_matrix(q, p):
    c2 = np.cos(q[1])
    m11 = (
        p["I1"]
        + p["I2"]
        + p["m2"] * p["l1"] ** 2
        + 2 * p["m2"] * p["l1"] * p["r2"] * c2
        + p["gr"] ** 2 * p["Ir"]
        + p["Ir"]
    )
    m12 = p["I2"] + p["m2"] * p["l1"] * p["r2"] * c2 - p["gr"] * p["Ir"]
    m22 = p["I2"] + p["gr"] ** 2 * p["Ir"]
    return np.array([[m11, m12], [m12, m22]])


def potential(q, p):
    """Heights measured upwards, q = 0 hanging down: U = −g Σ m_i (height of COM i below)."""
    return -p["g"] * (
        p["m1"] * p["r1"] * np.cos(q[0])
        + p["m2"] * (p["l1"] * np.cos(q[0]) + p["r2"] * np.cos(q[0] + q[1]))
    )


def readme_gravity(q, p):
    """The lab README's G (torque = ... − G)."""
    s1, s12 = math.sin(q[0]), math.sin(q[0] + q[1])
    g1 = -p["g"] * (p["m1"] * p["r1"] + p["m2"] * p["l1"]) * s1 - p["g"] * p["m2"] * p["r2"] * s12
    return np.array([g1, -p["g"] * p["m2"] * p["r2"] * s12])


def complex_step_gradient(f, q, h=1e-30):
    return np.array([np.imag(f(q + 1j * h * np.eye(2)[k])) / h for k in range(2)])


def lagrangian_torque(q, qd, qdd, p, slope=100.0):
    """τ = d/dt ∂T/∂q̇ − ∂T/∂q + ∂U/∂q + F = M q̈ + Ṁ q̇ − ∂T/∂q + ∂U/∂q + F."""
    M = mass_matrix(q, p)
    dM = [np.imag(mass_matrix(q + 1j * 1e-30 * np.eye(2)[k], p)) / 1e-30 for k in range(2)]
    M_dot = qd[0] * dM[0] + qd[1] * dM[1]
    dT_dq = complex_step_gradient(lambda z: 0.5 * qd @ mass_matrix(z, p) @ qd, q)
    dU_dq = complex_step_gradient(lambda z: potential(z, p), q)
    b = np.array([p["b1"], p["b2"]])
    cf = np.array([p["cf1"], p["cf2"]])
    friction = b * qd + cf * np.arctan(slope * qd)
    return M @ qdd + M_dot @ qd - dT_dq + dU_dq + friction


def random_physical_parameters(rng):
    names = ["I1", "I2", "Ir", "m1", "m2", "l1", "r1", "r2", "b1", "b2", "cf1", "cf2"]
    p = {name: float(rng.uniform(0.01, 1.0)) for name in names}
    p["gr"] = float(rng.uniform(1.0, 10.0))
    p["g"] = 9.81
    return p


# ---------------------------------------------------------------------------------------------
# Packaged data


def test_packaged_files_are_present_with_their_licence():
    names = {entry.name for entry in DATA.iterdir()}
    expected = {"LICENSE", "README.md", "model_parameters.yml"}
    expected |= {f"trajectory_0{run}.csv.gz" for run in range(DFKI_RUNS)}
    assert expected <= names
    assert "BSD 3-Clause" in (DATA / "LICENSE").read_text(encoding="utf-8")
    assert DFKI_RUNS == 6


def test_lab_parameters_are_the_yml_as_floats():
    p = lab_parameters()
    assert p["gr"] == 6.0
    assert p["g"] == 9.81
    assert p["I2"] == 0.053878129629650884
    assert p["r2"] == 0.3212669909674605
    assert set(p) == {
        "I1",
        "I2",
        "Ir",
        "b1",
        "b2",
        "cf1",
        "cf2",
        "g",
        "gr",
        "l1",
        "l2",
        "m1",
        "m2",
        "r1",
        "r2",
        "tl1",
        "tl2",
    }
    assert all(type(value) is float for value in p.values())
    p["g"] = 0.0  # a fresh dict each call
    assert lab_parameters()["g"] == 9.81


def test_lab_base_parameters_by_hand():
    p = lab_parameters()
    X = lab_base_parameters()
    assert X.shape == (len(PENDULUM_PARAMETER_NAMES),) == (10,)
    # A2 = I2 + 36 Ir, A3 = I2 − 6 Ir, A6 = g m2 r2, friction as in the file
    assert X[1] == pytest.approx(0.053878129629650884 + 36 * 9.937281205437459e-05, rel=1e-15)
    assert X[2] == pytest.approx(0.053878129629650884 - 6 * 9.937281205437459e-05, rel=1e-15)
    assert X[5] == pytest.approx(9.81 * 0.563935954099688 * 0.3212669909674605, rel=1e-15)
    assert X[4] == pytest.approx(9.81 * (p["m1"] * p["r1"] + p["m2"] * p["l1"]), rel=1e-15)
    assert X[6:].tolist() == [0.001, 0.093, 0.001, 0.078]


# ---------------------------------------------------------------------------------------------
# Model and regressor


def test_regressor_times_lab_base_parameters_is_the_lab_model():
    q, qd, qdd = random_states(np.random.default_rng(0), n=500)
    D = pendulum_regressor(q, qd, qdd)
    assert D.shape == (500, 2, 10)
    direct = lab_model_torques(q, qd, qdd)
    np.testing.assert_allclose(D @ lab_base_parameters(), direct, rtol=0, atol=1e-12)


def test_potential_energy_matches_the_readme_gravity():
    p = lab_parameters()
    rng = np.random.default_rng(1)
    for q in rng.uniform(-math.pi, math.pi, (20, 2)):
        dU = complex_step_gradient(lambda z: potential(z, p), q)
        np.testing.assert_allclose(dU, -readme_gravity(q, p), rtol=0, atol=1e-13)


def test_regressor_matches_an_independent_lagrangian():
    rng = np.random.default_rng(2)
    q, qd, qdd = random_states(rng, n=40)
    for p in [lab_parameters()] + [random_physical_parameters(rng) for _ in range(3)]:
        tau = pendulum_regressor(q, qd, qdd) @ base_parameters(p)
        states = zip(q, qd, qdd, strict=True)
        reference = np.array([lagrangian_torque(*state, p) for state in states])
        np.testing.assert_allclose(tau, reference, rtol=0, atol=1e-9)


def test_coulomb_slope_enters_only_the_coulomb_columns():
    q, qd, qdd = random_states(np.random.default_rng(3), n=10)
    D100 = pendulum_regressor(q, qd, qdd)
    D5 = pendulum_regressor(q, qd, qdd, coulomb_slope=5.0)
    coulomb = [PENDULUM_PARAMETER_NAMES.index("cf1"), PENDULUM_PARAMETER_NAMES.index("cf2")]
    other = [i for i in range(10) if i not in coulomb]
    np.testing.assert_array_equal(D100[:, :, other], D5[:, :, other])
    np.testing.assert_allclose(D5[:, 0, coulomb[0]], np.arctan(5.0 * qd[:, 0]), rtol=1e-15)
    np.testing.assert_allclose(D5[:, 1, coulomb[1]], np.arctan(5.0 * qd[:, 1]), rtol=1e-15)


def test_base_parameters_are_identifiable():
    """The 10 columns are independent: generic states give a full-rank, well-conditioned W."""
    q, qd, qdd = random_states(np.random.default_rng(4), n=200)
    W = pendulum_regressor(q, qd, qdd).reshape(-1, 10)
    singular = np.linalg.svd(W, compute_uv=False)
    assert singular[-1] / singular[0] > 1e-3


def test_mass_matrix_is_symmetric_positive_definite():
    p = lab_parameters()
    for q2 in np.linspace(-math.pi, math.pi, 73):
        assert np.all(np.linalg.eigvalsh(mass_matrix(np.array([0.0, q2]), p)) > 0)


def test_regressor_hand_values():
    # Link 1 horizontal at rest: joint 1 carries both gravity columns, joint 2 only A6's.
    D = pendulum_regressor([[math.pi / 2, 0.0]], [[0.0, 0.0]], [[0.0, 0.0]])
    np.testing.assert_allclose(D[0, 0], [0, 0, 0, 0, 1, 1, 0, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(D[0, 1], [0, 0, 0, 0, 0, 1, 0, 0, 0, 0], atol=1e-15)
    # q = 0, q̈ = (1, 0): τ1 = A1 + 2 A4, τ2 = A3 + A4
    D = pendulum_regressor([[0.0, 0.0]], [[0.0, 0.0]], [[1.0, 0.0]])
    assert D[0, 0].tolist() == [1, 0, 0, 2, 0, 0, 0, 0, 0, 0]
    assert D[0, 1].tolist() == [0, 0, 1, 1, 0, 0, 0, 0, 0, 0]


# ---------------------------------------------------------------------------------------------
# Loading and resampling


def test_runs_are_ten_seconds_on_a_uniform_grid(runs):
    for run, data in enumerate(runs):
        assert isinstance(data, DfkiRun)
        assert data.run == run
        assert data.dt_s == 0.002
        n = data.t.size
        assert n == 5000
        assert data.t[0] == 0.0
        assert 9.99 <= data.t[-1] <= 10.0
        np.testing.assert_allclose(np.diff(data.t), 0.002, rtol=0, atol=1e-12)
        for name in ("q", "tau", "tau_commanded", "velocity_driver"):
            array = getattr(data, name)
            assert array.shape == (n, 2)
            assert np.all(np.isfinite(array))
        assert data.original_samples == RAW_ROWS[run]
        assert 0.002 < data.max_gap_s < 0.009


def test_max_gaps_are_the_largest_recorded_steps(runs):
    for run, data in enumerate(runs):
        assert data.max_gap_s == np.max(np.diff(raw_csv(run)["time"]))


def test_resampled_values_are_the_raw_values_interpolated(runs):
    """At a grid time equal to a recorded time the value is the recorded one; elsewhere it is
    the straight line between the two recorded neighbours (computed here by hand)."""
    columns = {
        "q": ("pos_meas1", "pos_meas2"),
        "tau": ("tau_meas1", "tau_meas2"),
        "tau_commanded": ("tau_con1", "tau_con2"),
        "velocity_driver": ("vel_meas1", "vel_meas2"),
    }
    rng = np.random.default_rng(5)
    for run, data in enumerate(runs):
        raw = raw_csv(run)
        time = raw["time"].tolist()
        for name, (first, second) in columns.items():
            values = np.stack([raw[first], raw[second]], axis=1)
            np.testing.assert_array_equal(getattr(data, name)[0], values[0])  # t0 coincides
            for k in rng.integers(1, data.t.size, 50):
                right = bisect.bisect_right(time, data.t[k])
                left = right - 1
                weight = (data.t[k] - time[left]) / (time[right] - time[left])
                expected = values[left] + weight * (values[right] - values[left])
                np.testing.assert_allclose(getattr(data, name)[k], expected, rtol=0, atol=1e-12)
    # a step equal to the first recorded step puts grid point 1 on recorded sample 1
    raw = raw_csv(0)
    aligned = load_dfki_run(0, dt_s=float(raw["time"][1]))
    assert aligned.t[1] == raw["time"][1]
    np.testing.assert_array_equal(aligned.q[1], [raw["pos_meas1"][1], raw["pos_meas2"][1]])
    np.testing.assert_array_equal(aligned.tau[1], [raw["tau_meas1"][1], raw["tau_meas2"][1]])


def test_other_steps_cover_the_recording():
    data = load_dfki_run(1, dt_s=0.005)
    assert data.dt_s == 0.005
    assert data.t.size == math.floor(9.998297452926636 / 0.005) + 1
    assert data.t[-1] <= 9.998297452926636 < data.t[-1] + 0.005


def test_linear_interpolation_error_is_bounded_by_gap_squared_curvature():
    """x = 0.5 sin(2π·1.5t) + 0.1 sin(2π·4t + 1) rad (|ẍ| up to 108 rad/s², like the runs)
    recorded at jittered times with gaps up to 8 ms: on a recorded step h the linear
    interpolant errs by at most h² max|ẍ| / 8."""
    rng = np.random.default_rng(6)
    steps = 0.002 + rng.uniform(-2e-4, 2e-4, 4999)
    gaps = rng.choice(steps.size, 40, replace=False)
    steps[gaps] = rng.uniform(0.004, 0.008, gaps.size)
    t_raw = np.concatenate([[0.0], np.cumsum(steps)])
    w1, w2 = 2 * math.pi * 1.5, 2 * math.pi * 4

    def x(t):
        return 0.5 * np.sin(w1 * t) + 0.1 * np.sin(w2 * t + 1.0)

    curvature = 0.5 * w1**2 + 0.1 * w2**2  # max |ẍ|
    grid, values = resample_uniform(t_raw, np.stack([x(t_raw), -x(t_raw)], axis=1), 0.002)
    error = np.abs(values - np.stack([x(grid), -x(grid)], axis=1))
    right = np.searchsorted(t_raw, grid, side="right").clip(max=t_raw.size - 1)
    h = t_raw[right] - t_raw[right - 1]
    bound = h**2 * curvature / 8
    assert np.all(error <= bound[:, None] + 1e-15)
    # the bound has the right order: the worst error is a sizeable part of the worst bound
    assert error.max() > 0.2 * bound.max()
    # an 8 ms gap allows at most 8.6e-4 rad (about two encoder steps of 3.8e-4 rad); steps
    # near the nominal 2 ms (here < 2.5 ms) less than 1e-4 rad
    assert bound.max() < 8.7e-4
    assert np.max(error[h < 0.0025]) < 1e-4


def test_resample_drops_exact_duplicate_time_stamps():
    grid, values = resample_uniform([0.0, 1.0, 1.0, 2.0], [0.0, 1.0, 5.0, 2.0], dt_s=0.5)
    assert grid.tolist() == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert values.tolist() == [0.0, 0.5, 1.0, 1.5, 2.0]


@pytest.mark.parametrize(
    ("t", "x", "dt_s", "name"),
    [
        ([0.0, 2.0, 1.0, 3.0], [0.0, 1.0, 2.0, 3.0], 0.5, "`t`"),
        ([1.0, 1.0], [0.0, 1.0], 0.5, "`t`"),
        ([0.0, np.nan, 2.0], [0.0, 1.0, 2.0], 0.5, "`t`"),
        ([0.0, 1.0, 2.0], [0.0, 1.0], 0.5, "`x`"),
        ([0.0, 1.0, 2.0], [0.0, np.inf, 2.0], 0.5, "`x`"),
        ([0.0, 1.0, 2.0], [0.0, 1.0, 2.0], 0.0, "`dt_s`"),
        ([0.0, 1.0, 2.0], [0.0, 1.0, 2.0], 3.0, "`dt_s`"),
    ],
)
def test_resample_rejects_bad_input(t, x, dt_s, name):
    with pytest.raises(ValueError, match=name):
        resample_uniform(t, x, dt_s)


def test_runs_are_frozen_and_read_only(runs):
    data = runs[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        data.dt_s = 0.001
    with pytest.raises(ValueError, match="read-only"):
        data.q[0, 0] = 1.0


# ---------------------------------------------------------------------------------------------
# The lab model on the real torques

CUTOFF_HZ = 5.0  # 99 % of the joint motion's power lies below 2.3 Hz in every run
TRIM_S = 0.2  # filter and difference transients at the ends


def model_torque_rmse(data, parameters):
    """RMSE per joint of D(q, q̇, q̈) X against the measured torque, with q̇, q̈ from central
    differences of the resampled q after a 4th-order zero-phase Butterworth at 5 Hz."""
    sos = butter(4, CUTOFF_HZ, output="sos", fs=1.0 / data.dt_s)
    q = sosfiltfilt(sos, data.q, axis=0)
    qd = np.gradient(q, data.dt_s, axis=0)
    qdd = np.gradient(qd, data.dt_s, axis=0)
    tau = pendulum_regressor(q, qd, qdd) @ parameters
    trim = round(TRIM_S / data.dt_s)
    error = (tau - data.tau)[trim:-trim]
    return np.sqrt(np.mean(error**2, axis=0))


def test_lab_model_predicts_the_measured_torque(runs):
    """Measured (5 Hz, 0.2 s trimmed), N·m: run 0 [0.204, 0.149], 1 [0.139, 0.091],
    2 [0.113, 0.091], 3 [0.104, 0.112], 4 [0.105, 0.077], 5 [0.150, 0.101]. Loose bound only;
    and the model with gravity's sign flipped (q measured from the upward vertical) is far off,
    which pins the sign convention on real data."""
    X = lab_base_parameters()
    flipped = X.copy()
    flipped[4:6] *= -1.0
    for data in runs:
        rmse = model_torque_rmse(data, X)
        assert np.all(rmse < 0.3), (data.run, rmse)
        assert model_torque_rmse(data, flipped).sum() > 2.0 * rmse.sum()


# ---------------------------------------------------------------------------------------------
# Bad input


@pytest.mark.parametrize("run", [6, -1, 1.0, True, "0", None])
def test_bad_run_is_rejected(run):
    with pytest.raises(ValueError, match="`run`"):
        load_dfki_run(run)


@pytest.mark.parametrize("dt_s", [0.0, -0.002, math.nan, math.inf, "0.002", 20.0])
def test_bad_step_is_rejected(dt_s):
    with pytest.raises(ValueError, match="`dt_s`"):
        load_dfki_run(0, dt_s=dt_s)


def test_bad_states_are_rejected():
    good = np.zeros((3, 2))
    nan = good.copy()
    nan[1, 0] = np.nan
    cases = [
        ((nan, good, good), "`q`"),
        ((good, nan, good), "`qd`"),
        ((good, good, nan), "`qdd`"),
        ((np.zeros(2), good, good), "`q`"),
        ((good, np.zeros((3, 3)), good), "`qd`"),
        ((good, good, np.zeros((4, 2))), "`qdd`"),
        ((np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2))), "`q`"),
        ((good, [["a", "b"]] * 3, good), "`qd`"),
    ]
    for function in (pendulum_regressor, lab_model_torques):
        for arguments, name in cases:
            with pytest.raises(ValueError, match=name):
                function(*arguments)
    for slope in (0.0, -1.0, math.nan):
        with pytest.raises(ValueError, match="`coulomb_slope`"):
            pendulum_regressor(good, good, good, coulomb_slope=slope)


def test_bad_physical_parameters_are_rejected():
    p = lab_parameters()
    del p["m1"]
    with pytest.raises(ValueError, match="`parameters`"):
        base_parameters(p)
    p = lab_parameters()
    p["I1"] = math.nan
    with pytest.raises(ValueError, match="parameters\\['I1'\\]"):
        base_parameters(p)


# --- recordings at their logged time stamps, and A4 tied to A6 ------------------------------
def test_tied_regressor_reproduces_the_lab_model_with_nine_parameters():
    """The lab's parameters have A4 = m2 l1 r2 = A6 l1 / g exactly; folding A4's column into
    A6's by l1/g gives the same torques with A4 dropped."""
    p = lab_parameters()
    q, qd, qdd = random_states(np.random.default_rng(5), n=300)
    full = pendulum_regressor(q, qd, qdd)
    tied = tie_a4_to_a6(full, p["l1"], p["g"])
    assert tied.shape == (300, 2, 9) and len(TIED_PARAMETER_NAMES) == 9
    x = lab_base_parameters()
    a4 = PENDULUM_PARAMETER_NAMES.index("A4_m2_l1_r2")
    assert x[a4] == pytest.approx(x[PENDULUM_PARAMETER_NAMES.index("A6_g_m2_r2")] * 0.2 / 9.81)
    np.testing.assert_allclose(tied @ np.delete(x, a4), full @ x, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="`regressor` must have 10 columns"):
        tie_a4_to_a6(full[..., :9], p["l1"], p["g"])
    with pytest.raises(ValueError, match="link1_length_m"):
        tie_a4_to_a6(full, 0.0, p["g"])


def test_a_record_is_the_csv_at_its_logged_times_and_a_copy_reads_the_same(tmp_path):
    raw = raw_csv(4)
    record = read_dfki_record(4)
    keep = np.r_[True, np.diff(raw["time"]) != 0]
    np.testing.assert_array_equal(record.t, raw["time"][keep])
    np.testing.assert_array_equal(record.q[:, 1], raw["pos_meas2"][keep])
    np.testing.assert_array_equal(record.tau[:, 0], raw["tau_meas1"][keep])
    assert record.active_joints.tolist() == [False, True]  # run 4 drives joint 2 only
    packed = tmp_path / "trajectory_04.csv.gz"
    packed.write_bytes((DATA / "trajectory_04.csv.gz").read_bytes())
    plain = tmp_path / "measured.csv"
    plain.write_bytes(gzip.decompress(packed.read_bytes()))
    for copy in (packed, plain):
        again = read_dfki_record(copy)
        assert again.name == str(copy)
        for name in ("t", "q", "tau", "tau_commanded"):
            np.testing.assert_array_equal(getattr(again, name), getattr(record, name))


def _write(path, header, rows):
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


GOOD_HEADER = "time,pos_meas1,pos_meas2,tau_meas1,tau_meas2,tau_con1,tau_con2"


def _good_rows(n=120):
    return [f"{0.002 * k},{k},{-k},0.1,0.2,0.5,0" for k in range(n)]


@pytest.mark.parametrize(
    ("header", "rows", "message"),
    [
        (
            "time,pos_meas1,tau_meas1,tau_meas2,tau_con1,tau_con2",
            None,
            r"lacks the columns \['pos_meas2'\]",
        ),
        (GOOD_HEADER, ["0.0,1,2,3,4,five,6"], "not a table of numbers"),
        (GOOD_HEADER, ["0.0,1,2,3,4,nan,6"], "line 2 holds NaN or inf"),
        (
            GOOD_HEADER,
            [*_good_rows(60), "0.05,1,1,1,1,1,1", *_good_rows(120)[61:]],
            "the time column decreases at data row",
        ),
        (GOOD_HEADER, _good_rows(50), "50 distinct time stamps, at least 100 needed"),
    ],
)
def test_bad_records_are_refused_in_one_line_naming_the_file(tmp_path, header, rows, message):
    path = _write(tmp_path / "bad.csv", header, rows if rows is not None else _good_rows())
    with pytest.raises(ValueError, match=message) as caught:
        read_dfki_record(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_missing_record_file_and_bad_sources_are_refused(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        read_dfki_record(tmp_path / "absent.csv")
    with pytest.raises(ValueError, match=r"`run` must be an integer in 0\.\.5"):
        read_dfki_record(6)
    good = _write(tmp_path / "good.csv", GOOD_HEADER, _good_rows())
    assert read_dfki_record(good).q.shape == (120, 2)


# --- the robot model: the lab's model_parameters.yml of any design ---------------------------
def test_the_packaged_model_is_the_default_and_gives_the_same_bits():
    """The default model is the packaged file; its torques, tie and base parameters are the
    packaged functions' to the last bit (the packaged runs' results cannot move)."""
    model = load_pendulum_model()
    assert model is packaged_model() and model.design == PACKAGED_DESIGN == "C.0"
    assert model.values == lab_parameters()
    q, qd, qdd = random_states(np.random.default_rng(11), n=200)
    np.testing.assert_array_equal(model.torques(q, qd, qdd), lab_model_torques(q, qd, qdd))
    p = lab_parameters()
    full = pendulum_regressor(q, qd, qdd)
    np.testing.assert_array_equal(model.tie(full), tie_a4_to_a6(full, p["l1"], p["g"]))
    np.testing.assert_array_equal(model.base_parameters(), lab_base_parameters())


def test_a_model_file_of_another_design_is_that_robot(tmp_path):
    """A design-A.0-like file where the lab keeps it: its design comes from the path, its
    torques are the robot's own inverse dynamics (written out independently), its base
    parameters regress them, and its tie uses its l1 = 0.3 m, not the packaged 0.2 m."""
    path = syn.write_model(
        tmp_path / "identified_parameters" / "design_A.0" / "model_2.0" / "model_parameters.yml"
    )
    model = load_pendulum_model(path)
    assert model.design == "A.0" and model.source == str(path) and model.values["l1"] == 0.3
    assert model != packaged_model()
    assert model == load_pendulum_model(syn.DESIGN_A_PARAMETERS)  # the same robot
    assert load_pendulum_model(syn.DESIGN_A_PARAMETERS).design is None
    q, qd, qdd = random_states(np.random.default_rng(12), n=300)
    truth = syn.inverse_dynamics(q, qd, qdd)
    # |τ| reaches about 60 N·m here; both sides sum ~10 products each: 1e-12 is 1e4·eps·|τ|
    assert np.max(np.abs(truth)) < 100
    np.testing.assert_allclose(model.torques(q, qd, qdd), truth, rtol=0, atol=1e-12)
    X = syn.true_base_parameters()
    np.testing.assert_allclose(model.base_parameters(), X, rtol=1e-15)
    full = pendulum_regressor(q, qd, qdd)
    np.testing.assert_allclose(full @ X, truth, rtol=0, atol=1e-12)
    a4 = PENDULUM_PARAMETER_NAMES.index("A4_m2_l1_r2")
    np.testing.assert_allclose(model.tie(full) @ np.delete(X, a4), truth, rtol=0, atol=1e-12)
    wrong = tie_a4_to_a6(full, 0.2, 9.81) @ np.delete(X, a4)  # the packaged l1
    assert np.sqrt(np.mean((wrong - truth) ** 2)) > 0.1


def test_design_of_path_reads_the_labs_folders():
    lab = "data/experiment_records/design_A.0/20220815/sys_id/trajectory_03.csv"
    assert design_of_path(lab) == "A.0"
    assert design_of_path("x/identified_parameters/design_hD.0/model_h1.0/m.yml") == "hD.0"
    assert design_of_path("design_B.0/a/design_C.1/measured.csv") == "C.1"  # the nearest
    for plain in ("measured.csv", "my_design_A.0/measured.csv", "design_A.0.csv"):
        assert design_of_path(plain) is None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("I1: 0.1\n", r"lacks the keys \['I2', 'Ir'"),
        ("I1 0.1\n", r"line 1 is not `key: number`"),
        ("I1: one\n", r"line 1 is not `key: number`"),
        (None, r": `l1` must be > 0, got 0\.0"),
        ("nan", r": `I1` must be a finite number, got nan"),
    ],
)
def test_bad_model_files_are_refused_in_one_line_naming_the_file(tmp_path, text, message):
    path = tmp_path / "model_parameters.yml"
    if text is None:
        syn.write_model(path, {**syn.DESIGN_A_PARAMETERS, "l1": 0.0})
    elif text == "nan":
        syn.write_model(path, {**syn.DESIGN_A_PARAMETERS, "I1": math.nan})
    else:
        path.write_text(text)
    with pytest.raises(ValueError, match=message) as caught:
        load_pendulum_model(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_bad_model_sources_are_refused(tmp_path):
    with pytest.raises(ValueError, match=r"absent\.yml: no such file"):
        load_pendulum_model(tmp_path / "absent.yml")
    with pytest.raises(ValueError, match=r"must be None .* got 3"):
        load_pendulum_model(3)
    with pytest.raises(ValueError, match=r"robot model: `g` must be a finite number, got inf"):
        load_pendulum_model({**syn.DESIGN_A_PARAMETERS, "g": math.inf})
    with pytest.raises(ValueError, match=r"lacks the keys \['m2'\]"):
        load_pendulum_model({k: v for k, v in syn.DESIGN_A_PARAMETERS.items() if k != "m2"})
    with pytest.raises(ValueError, match=r"`parameters` lacks the keys \['I2', 'Ir'"):
        lab_model_torques(np.zeros((1, 2)), np.zeros((1, 2)), np.zeros((1, 2)), {"I1": 1.0})
