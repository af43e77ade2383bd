"""The SINDy discovery study: exact truth recovers every system, the scores are taken against
the true library, a diverging model is caught at its analytic blow-up time, every entry runs
as a row (pysindy's defaults and the weak form included), and the report is written."""

import math
import re

import numpy as np
import pandas as pd
import pytest

from diffbench.bench.studies import sindy
from diffbench.bench.tasks.sindy import SindyStudy
from diffbench.signals.dynamics import SYSTEMS, get_system

EPS = np.finfo(float).eps
TRUTH = {"source": "truth", "method": "exact ẋ", "params": {}}


@pytest.mark.parametrize("starts", [1, 3])
@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_the_exact_derivatives_recover_every_system_to_rounding(name, starts):
    """With the exact ẋ and states, of one trajectory or three fitted together, STLSQ at the
    system's threshold keeps exactly the true terms and its least-squares refit on them
    recovers the coefficients: the relative error is within rounding amplified by the
    condition number of the library's true columns."""
    system = get_system(name)
    runs = system.measure_runs(0.1, 1, starts=starts)  # the truth entry reads clean states
    found, powers = sindy.discover(system, runs, TRUTH)
    truth = system.coefficient_matrix(powers)
    scores = sindy.coefficient_scores(found, truth)
    assert scores["exact_support"] == 1.0 and scores["precision"] == scores["recall"] == 1.0
    states = np.concatenate([run.truth.x for run in runs])
    features = np.prod(states[:, None, :] ** powers, axis=2)
    condition = np.linalg.cond(features[:, np.any(truth != 0, axis=0)])
    assert scores["coefficient_error"] <= 100 * EPS * condition
    assert scores["coefficient_error"] <= 1e-6


def test_the_scores_are_taken_against_the_true_library():
    """Lorenz's terms land on pysindy's feature names (x0 x2 in ẏ, x0 x1 in ż); precision,
    recall and the exact support count terms found against the true ones."""
    import pysindy as ps

    system = get_system("lorenz")
    library = ps.PolynomialLibrary(degree=3).fit(np.ones((4, 3)))
    truth = system.coefficient_matrix(library.powers_)
    names = library.get_feature_names()
    assert truth[1, names.index("x0 x2")] == -1 and truth[2, names.index("x0 x1")] == 1
    assert truth[2, names.index("x2")] == pytest.approx(-8 / 3)
    assert np.count_nonzero(truth) == 7
    found = truth.copy()
    found[0, names.index("1")] = 0.5  # one spurious term
    found[2, names.index("x0 x1")] = 0.0  # one term missed
    found[0, names.index("x0")] = -11.0
    scores = sindy.coefficient_scores(found, truth)
    assert scores["precision"] == 6 / 7 and scores["recall"] == 6 / 7
    assert scores["exact_support"] == 0.0
    expected = math.sqrt(0.5**2 + 1**2 + 1**2) / np.linalg.norm(truth)
    assert scores["coefficient_error"] == pytest.approx(expected, rel=4 * EPS)
    assert sindy.coefficient_scores(np.zeros_like(truth), truth)["precision"] == 0.0


def test_a_diverging_model_is_caught_when_it_leaves_the_bound():
    """ẋ = x², y' = 0 from (x0, y0) blows up at 1/x0; it leaves BLOWUP x the true
    trajectory's largest magnitude L at t = 1/x0 - 1/(BLOWUP L): the time reported, to the
    integration's tolerance, with an infinite error. The true model simulates to within its
    tolerance."""
    system = get_system("lotka-volterra")
    powers = np.array([[0, 0], [1, 0], [0, 1], [2, 0], [1, 1]])
    exploding = np.array([[0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0]])
    start = system.held_out[0]
    spread = system.trajectory().x.std(axis=0)
    error, diverged_at = sindy.simulate(system, exploding, powers, start, spread)
    largest = np.abs(system.trajectory(start, system.horizon_s).x).max()
    expected = 1 / start[0] - 1 / (sindy.BLOWUP * largest)
    assert error == math.inf and diverged_at == pytest.approx(expected, rel=1e-6)
    true = system.coefficient_matrix(powers)
    error, diverged_at = sindy.simulate(system, true, powers, start, spread)
    assert math.isnan(diverged_at) and error <= 1e3 * sindy.SIMULATION_TOLERANCE


def test_the_perfect_differentiator_scores_perfectly_and_pysindys_default_runs():
    """The truth entry: no coefficient error beyond rounding, the exact support, held-out
    simulations within the integration's tolerance. pysindy's default
    (SmoothedFiniteDifference) and the weak form give rows with finite scores, reproducibly
    (the weak form's random subdomains are seeded)."""
    perfect = sindy.entry_rows("linear-oscillator", 0.05, TRUTH, 2)
    for row in perfect:
        assert row["coefficient_error"] <= 1e-12 and row["exact_support"] == 1.0
        assert row["simulation_error"] <= 1e3 * sindy.SIMULATION_TOLERANCE
        assert row["diverged"] == 0 and row["failure"] == ""
    for entry in (
        {"source": "pysindy", "method": "SmoothedFiniteDifference", "params": {}},
        {"source": "weak form", "method": "WeakPDELibrary", "params": {}},
    ):
        rows = sindy.entry_rows("linear-oscillator", 0.05, entry, 2)
        assert all(0 < row["coefficient_error"] < 0.1 for row in rows)
        assert rows == sindy.entry_rows("linear-oscillator", 0.05, entry, 2)


def test_the_study_tunes_scores_and_reports_every_entry(tmp_path):
    """One system at one level, one native method: its oracle-tuned and preset entries, the
    truth, pysindy's and derivative's, the weak form; each item's rows, then the report."""
    study = SindyStudy(
        systems=("linear-oscillator",),
        levels=(0.05,),
        steps=(1,),
        starts=(1,),
        name="sindy-test",
    )
    items = study.items(["spectral"], range(2))
    sources = [item.setting["source"] for item in items]
    assert sources.count("oracle") == sources.count("recommend") == sources.count("preset") == 1
    assert sources.count("truth") == 1 and sources.count("weak form") == 2
    assert sources.count("pysindy") == len(sindy.PYSINDY_DEFAULTS) + len(sindy.DERIVATIVE_README)
    rows = {item: study.compute(item) for item in items}
    for item, found in rows.items():
        assert [row["seed"] for row in found] == [0, 1], item
        assert all(row["failure"] == "" for row in found), item
    oracle = next(found for item, found in rows.items() if item.setting["source"] == "oracle")
    assert oracle[0]["params"]["cutoff_hz"] > 0 and oracle[0]["tuned_loss"] > 0
    written = study.write(rows, tmp_path)
    assert {path.name for path in written} >= {
        "summary.md",
        "support.md",
        "linear-oscillator.md",
        "coefficient_error.png",
    }
    summary = pd.read_csv(tmp_path / "summary.csv")
    entries = pd.read_csv(tmp_path / "entries.csv")
    contenders = entries[entries["source"] != "truth"]
    best = contenders.loc[contenders["coefficient_error"].idxmin()]
    assert summary.loc[0, "winner"] == best["entry"]
    weak = entries.loc[entries["source"] == "weak form", "coefficient_error"].min()
    assert summary.loc[0, "weak form's error"] == pytest.approx(weak)


def test_an_unknown_system_or_method_is_named():
    with pytest.raises(ValueError, match="unknown system 'lorenx'"):
        SindyStudy(systems=("lorenx",))
    with pytest.raises(ValueError, match="spectrall"):
        SindyStudy().entries(["spectrall"])


@pytest.mark.parametrize("starts", [1, 3])
def test_a_native_entry_is_what_the_pysindy_adapter_gives(starts):
    """The study gives SINDy a method's trusted ẋ and smoothed states itself, each trajectory
    differentiated on its own: the same model as pysindy fitting the trajectories with
    diffbench's Differentiation adapter, bit for bit."""
    import pysindy as ps

    from diffbench.methods.for_pysindy import Differentiation

    system = get_system("duffing")
    runs = system.measure_runs(0.05, 2, starts=starts)
    params = {"window_s": 0.4, "degree": 3}
    entry = {"source": "preset", "method": "savitzky_golay", "params": params}
    found, _ = sindy.discover(system, runs, entry)
    model = ps.SINDy(
        feature_library=ps.PolynomialLibrary(degree=system.degree),
        optimizer=ps.STLSQ(threshold=system.threshold, alpha=0.0),
        differentiation_method=Differentiation("savitzky_golay", params),
    )
    model.fit([run.x for run in runs], t=system.dt_s)
    assert np.array_equal(found, model.coefficients())


def test_the_recommended_setting_is_chosen_from_the_noisy_data_alone(monkeypatch):
    """recommend's setting for each state is the same when the measurement's truth is
    replaced by NaN: it reads the samples only. Each state gets its own setting and scale."""
    import dataclasses

    from diffbench.signals import dynamics

    first = sindy.recommended_params("van-der-pol", 0.05, "spectral")
    assert len(first["states"]) == len(first["scales"]) == 2
    measure_runs = dynamics.PolynomialSystem.measure_runs

    def blind(self, level, seed, every=1, starts=1):
        runs = []
        for measured in measure_runs(self, level, seed, every, starts):
            nothing = np.full_like(measured.truth.x, np.nan)
            truth = dataclasses.replace(measured.truth, x=nothing, x_dot=nothing)
            runs.append(dataclasses.replace(measured, truth=truth))
        return tuple(runs)

    monkeypatch.setattr(dynamics.PolynomialSystem, "measure_runs", blind)
    assert sindy.recommended_params("van-der-pol", 0.05, "spectral") == first


def test_the_weak_forms_tuned_k_is_at_least_as_good_as_its_default_on_the_tuning_seed():
    """K is chosen among WEAK_FORM_K (the default, 100, among them) by the coefficient error
    on the tuning seed's measurement: there it is no worse than the default."""
    from diffbench.bench.core import tuning

    system = get_system("van-der-pol")
    chosen = sindy.weak_form_params("van-der-pol", 0.05)
    assert chosen["K"] in sindy.WEAK_FORM_K and 100 in sindy.WEAK_FORM_K
    runs = system.measure_runs(0.05, tuning.TUNING_SEED)

    def error(params):
        entry = {"source": "weak form", "params": params}
        found, powers = sindy.discover(system, runs, entry)
        return sindy.coefficient_scores(found, system.coefficient_matrix(powers))

    assert error(chosen)["coefficient_error"] <= error({})["coefficient_error"]


def test_the_coarser_step_keeps_every_fifth_sample_and_the_own_steps_items_their_keys():
    """A measurement every fifth sample: five times the step, the trajectory's samples and
    exact derivatives there, noise of the level times the spread of those samples. The items
    at a system's own step name no step, so the store keys they had before the step was a
    dimension still find them."""
    system = get_system("duffing")
    fine, coarse = system.measure(0.05, seed=3), system.measure(0.05, seed=3, every=5)
    assert coarse.dt_s == 5 * fine.dt_s
    np.testing.assert_array_equal(coarse.truth.x, fine.truth.x[::5])
    np.testing.assert_array_equal(coarse.truth.x_dot, fine.truth.x_dot[::5])
    np.testing.assert_array_equal(coarse.noise_std, 0.05 * fine.truth.x[::5].std(axis=0))
    with pytest.raises(ValueError, match="`every` must be a whole number >= 1"):
        system.measure(0.05, seed=3, every=0)
    study = SindyStudy(systems=("duffing",), levels=(0.05,), starts=(1,))
    items = study.items(["spectral"], range(2))
    own = [item for item in items if "every" not in item.setting]
    fifth = [item for item in items if item.setting.get("every") == 5]
    assert len(own) == len(fifth) == len(items) / 2
    rows = SindyStudy(systems=("duffing",)).compute(fifth[0])
    assert rows[0]["step_s"] == 5 * system.dt_s


def test_the_entries_table_spells_a_setting_one_way_whatever_its_key_order():
    """Rows just computed carry a tuned setting in the method's order, rows read back from
    the store in sorted order: the entries table is the same for both."""
    from diffbench.bench.studies import sindy_report

    row = {
        "system": "duffing",
        "step_s": 0.01,
        "level": 0.05,
        "source": "oracle",
        "method": "butterworth",
        "seed": 0,
        "failure": "",
        **dict.fromkeys(sindy.SCORES, 0.5),
    }
    computed = sindy_report.entries_frame([{**row, "params": {"order": 7, "cutoff_hz": 2.5}}])
    stored = sindy_report.entries_frame([{**row, "params": {"cutoff_hz": 2.5, "order": 7}}])
    pd.testing.assert_frame_equal(computed, stored)
    assert computed.loc[0, "params"] == '{"cutoff_hz":2.5,"order":7}'


def test_three_starts_are_items_of_their_own_and_one_start_keeps_its_keys():
    """The items from one start name no starts (the store keys they had before records had
    several), those from three name them; a three-start item's rows say so, and the truth
    entry recovers the equations there too."""
    items = SindyStudy(systems=("duffing",), levels=(0.05,), steps=(1,)).items([], range(2))
    one = [item for item in items if "starts" not in item.setting]
    three = [item for item in items if item.setting.get("starts") == 3]
    assert len(one) == len(three) == len(items) / 2
    truth = next(item for item in three if item.setting["source"] == "truth")
    rows = SindyStudy(systems=("duffing",)).compute(truth)
    assert [row["starts"] for row in rows] == [3, 3]
    assert all(row["exact_support"] == 1.0 for row in rows)
    with pytest.raises(ValueError, match="`starts` must be at most 3 for duffing"):
        SindyStudy(systems=("duffing",), starts=(1, 4))
    for bad in ((), (0, 1), (1.0,)):
        with pytest.raises(ValueError, match="`starts` must be whole numbers >= 1"):
            SindyStudy(systems=("duffing",), starts=bad)


def test_the_headline_has_a_row_per_number_of_starts_and_old_rows_count_as_one():
    """A row stored before records had several starts (no ``starts``) is a one-start row;
    the headline compares the best pointwise entry with the weak form per number of
    starts."""
    from diffbench.bench.studies import sindy_report

    def row(starts, source, method, error):
        found = {
            "system": "duffing",
            "step_s": 0.01,
            "level": 0.05,
            "source": source,
            "method": method,
            "params": {},
            "seed": 0,
            "failure": "",
            **dict.fromkeys(sindy.SCORES, 0.0),
            "coefficient_error": error,
        }
        return found if starts is None else {**found, "starts": starts}

    rows = [
        row(None, "oracle", "spectral", 0.01),
        row(None, "weak form", "WeakPDELibrary", 0.04),
        row(3, "oracle", "spectral", 0.05),
        row(3, "weak form", "WeakPDELibrary", 0.02),
    ]
    entries = sindy_report.entries_frame(rows)
    assert sorted(entries["starts"]) == [1, 1, 3, 3]
    headline = sindy_report.headline_table(sindy_report.summary_table(entries))
    beats = headline["best pointwise differentiator beats the weak form on"].tolist()
    ratios = headline["its error / the weak form's, median"].tolist()
    assert beats == [1, 0] and ratios == ["0.25×", "2.50×"]


def _evaluated(text: str, state: dict) -> float:
    """A written right-hand side (``-x z + 28 x - y``) at ``state``."""
    total = 0.0
    for signed in re.findall(r"(^-?|[+-] )([^+-]+)", text.strip()):
        sign = -1.0 if signed[0].strip() == "-" else 1.0
        value = sign
        for factor in signed[1].split():
            name, _, power = factor.partition("^")
            value *= state[name] ** int(power or 1) if name in state else float(name)
        total += value
    return total


def test_the_systems_table_writes_each_systems_equations_and_threshold():
    """The equations as written, read back, give each system's right-hand side at a state
    (the coefficients to the four digits written); the threshold is below every true
    coefficient's magnitude."""
    from diffbench.bench.studies import sindy_report

    assert sindy_report.equation_text(get_system("lorenz")) == (
        "x' = -10 x + 10 y; y' = -x z + 28 x - y; z' = x y - 2.667 z"
    )
    table = sindy_report.systems_table(sorted(SYSTEMS))
    state = {"x": 0.7, "y": -1.3, "z": 2.1}
    for _, row in table.iterrows():
        system = get_system(row["system"])
        written = [_evaluated(rhs.split("=")[1], state) for rhs in row["equations"].split("; ")]
        exact = system.rhs(np.array([state[name] for name in system.states]))
        np.testing.assert_allclose(written, exact, rtol=1e-3)
        smallest = min(abs(v) for terms in system.terms for v in terms.values())
        assert row["STLSQ threshold"] == system.threshold < smallest
