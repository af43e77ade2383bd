"""The Python API (diffbench.bench.api), called directly: it stores what the command line
stores, names the argument of bad input, says what an interrupted run kept, and never prints
to the standard output."""

import inspect
import warnings
from pathlib import Path

import pytest

from diffbench.bench import api, cli, runner
from diffbench.bench.cli import main
from diffbench.bench.core.store import Store

TASK = "paper-signal"
METHODS = ["finite_difference", "butterworth"]
SCORE = ["method", "params", "seed", "role", "order", "region", "metric", "value"]
"""The columns of a stored score that the computation decides (not when or where it ran)."""


def scores(out):
    frame = Store(out / "store").cells_frame(TASK)
    return frame[SCORE].sort_values(SCORE[:-1]).reset_index(drop=True)


def test_run_stores_the_scores_the_command_line_stores_and_resumes(tmp_path, capsys):
    news = []
    result = api.run(TASK, seeds=2, methods=METHODS, out=tmp_path / "api", echo=news.append)
    assert (result.cells.computed, result.cells.skipped, result.tunings) == (4, 0, None)
    assert news == ["4 cells computed, 0 already stored"]
    assert {p.name for p in result.written} >= {"rmse.md", "rmse.csv"}
    assert all(p.is_file() for p in result.written)
    assert capsys.readouterr().out == ""  # the API prints nothing; the CLI prints its news

    argv = ["run", TASK, "--seeds", "2", "--methods", ",".join(METHODS), "--no-progress"]
    assert main([*argv, "--out", str(tmp_path / "cli")]) == 0
    assert "4 cells computed, 0 already stored" in capsys.readouterr().out
    ours, theirs = scores(tmp_path / "api"), scores(tmp_path / "cli")
    assert len(ours) == len(theirs) > 0
    assert ours.equals(theirs)  # the same cells, bit for bit
    assert (tmp_path / "api" / TASK / "rmse.csv").read_text() == (
        tmp_path / "cli" / TASK / "rmse.csv"
    ).read_text()

    # real numbers: on the noisy paper signal, differencing amplifies the noise by 1/dt² in ẍ;
    # the preset low-pass (order 6, 25 Hz) removes most of it
    rmse = ours[(ours.metric == "rmse") & (ours.region == "interior") & (ours.order == 2)]
    by_method = rmse.groupby("method")["value"].max()
    assert by_method["butterworth"] * 10 < by_method["finite_difference"]

    again = api.run(TASK, seeds=3, methods=METHODS, out=tmp_path / "api")
    assert (again.cells.computed, again.cells.skipped) == (2, 4)
    assert api.report(TASK, out=tmp_path / "api") == again.written  # from the store
    assert capsys.readouterr().out == ""


@pytest.mark.parametrize(
    ("call", "named"),
    [
        (lambda out: api.run(TASK, seeds=0, out=out), "seeds: must be a whole number >= 1"),
        (lambda out: api.run(TASK, orders=[3], out=out), "orders: must be 1, 2 or 1,2"),
        (lambda out: api.run(TASK, jobs=0, out=out), "jobs: must be a whole number >= 1"),
        (lambda out: api.run(TASK, timeout_s=-1, out=out), "timeout_s: must be a finite number"),
        (lambda out: api.run(TASK, methods="nosuch", out=out), "--methods: unknown method"),
        (lambda out: api.run("nosuch", out=out), "unknown task 'nosuch'"),
        (lambda out: api.run(TASK, scenarios=["x"], out=out), "scenarios: only the studies limit"),
        (lambda out: api.run("limit", scenarios=["x"], out=out), "`scenarios`: not limit"),
        (lambda out: api.tune("jacobi", TASK, criteria="foo", out=out), "criteria: must be among"),
        (lambda out: api.tune("jacobi", TASK, screen=0, out=out), "screen: must be a whole number"),
        (
            lambda out: api.tune("jacobi", TASK, tuning_seed=1, seeds=3, out=out),
            "--tuning-seed 1 overlaps the scored seeds 0..2; choose a tuning seed >= 3",
        ),
        (lambda out: api.report(TASK, out=out), "no results store in"),
        (lambda out: api.export_scenario(TASK, out / "x.txt"), "unknown format '.txt'"),
        (lambda out: api.timing(largest=5, out=out), "largest: must be a power of ten"),
    ],
)
def test_bad_input_is_a_value_error_naming_its_argument(tmp_path, capsys, call, named):
    out = tmp_path / "out"
    with pytest.raises(ValueError) as caught:
        call(out)
    assert isinstance(caught.value, api.BadInput)
    assert named in str(caught.value)
    assert not (out / "store").exists()  # refused before anything was computed or stored
    assert capsys.readouterr().out == ""


def test_a_bug_deep_inside_is_not_bad_input(tmp_path, monkeypatch):
    def broken(cell):
        raise ValueError("a bug deep inside")

    monkeypatch.setattr(runner, "compute_cell", broken)
    with pytest.raises(ValueError, match="a bug deep inside") as caught:
        api.run(TASK, seeds=1, methods=["jacobi"], out=tmp_path)
    assert not isinstance(caught.value, api.BadInput)


def test_an_interrupted_run_says_what_it_kept_and_the_same_call_resumes(tmp_path, monkeypatch):
    real = runner.compute_cell
    calls = []

    def interrupted_on_third(cell):
        calls.append(cell)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(cell)

    monkeypatch.setattr(runner, "compute_cell", interrupted_on_third)
    with pytest.raises(KeyboardInterrupt) as caught:
        api.run(TASK, seeds=2, methods=METHODS, out=tmp_path)
    assert caught.value.resume.startswith("interrupted; 2 cells are stored in ")
    monkeypatch.setattr(runner, "compute_cell", real)
    result = api.run(TASK, seeds=2, methods=METHODS, out=tmp_path)
    assert (result.cells.computed, result.cells.skipped) == (2, 2)


def test_tune_returns_each_tuning_and_scores_it(tmp_path, capsys):
    news = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = api.tune(
            ["finite_difference", "butterworth"],
            TASK,
            criteria="no-truth",
            orders=[1],
            seeds=2,
            budget=20,
            out=tmp_path,
            echo=news.append,
        )
    # finite_difference is linear too: both tuned, nothing skipped
    assert not [w for w in caught if issubclass(w.category, api.MethodSkipped)]
    assert result.tunings.computed == 2 and len(result.tuned) == 2
    for job, record in result.tuned.items():
        assert job.criterion == "no-truth" and job.order == 1 and record["evaluations"] >= 1
    assert news[0] == "2 tunings computed, 0 reused from the store"
    assert news[-1] == f"{result.cells.computed} cells computed, 0 already stored"
    assert result.cells.computed == 4  # 2 tunings x 2 seeds
    again = api.tune(
        "finite_difference,butterworth",
        TASK,
        criteria="no-truth",
        orders=[1],
        seeds=2,
        budget=20,
        out=tmp_path,
    )
    assert (again.tunings.computed, again.tunings.reused, again.cells.computed) == (0, 2, 0)
    assert capsys.readouterr().out == ""


def test_a_screened_tuning_is_stored_apart_from_the_unscreened_one(tmp_path):
    """``screen``: the tuner screens the method's choice combinations (finite differences:
    3 schemes) down to that many; the tuning is stored under its own key, so the unscreened
    tuning of the same job is computed, not read from it, and neither is recomputed again."""
    common = dict(criteria="oracle", orders=[1], seeds=1, budget=20, out=tmp_path)
    screened = api.tune("finite_difference", TASK, screen=1, **common)
    (job,) = screened.tuned
    assert job.screen == 1 and screened.tunings.computed == 1
    assert screened.tuned[job]["screen"] == 1
    full = api.tune("finite_difference", TASK, **common)
    (plain,) = full.tuned
    assert plain.screen is None and full.tunings.computed == 1
    assert "screen" not in full.tuned[plain]
    again = api.tune("finite_difference", TASK, screen=1, **common)
    assert (again.tunings.computed, again.tunings.reused) == (0, 1)


def test_method_groups_and_listings():
    native = api.method_names("native")
    assert "jacobi" in native and not any("." in name for name in native)
    assert api.method_names(["jacobi", "native"])[0] == "jacobi"
    assert len(api.method_names("jacobi,jacobi")) == 1
    # a leading - leaves a method or a group out of the others, wherever it is written
    assert api.method_names("native,-jacobi") == [n for n in native if n != "jacobi"]
    assert api.method_names(["-jacobi", "native"]) == api.method_names("native,-jacobi")
    everything = api.method_names("all")
    assert api.method_names("all,-native") == [n for n in everything if n not in native]
    for only_out, said in (("-jacobi", "only leaves methods out"), ("native,-native", "no method")):
        with pytest.raises(ValueError, match=f"--methods: .*{said}"):
            api.method_names(only_out)
    assert any(line.startswith("  jacobi  (") for line in api.list_methods())
    assert any(line.startswith(f"  {TASK} [signal]") for line in api.list_tasks())


IGNORED: set[tuple[str, str]] = set()
"""Options a command takes (with the others of --jobs) and its function has no use for."""


def test_every_option_of_every_command_reaches_its_api_function():
    """The command line is wiring only: each command calls one function with its options as
    arguments; an option the function does not take would be dropped without a word."""
    assert len(Path(cli.__file__).read_text().splitlines()) <= 300
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    assert set(commands) == set(cli.COMMANDS)
    for name, command in cli.COMMANDS.items():
        accepted = set(inspect.signature(command.call).parameters)
        given = {a.dest for a in commands[name]._actions if a.dest != "help"}
        lost = given - accepted - set(cli.CLI_ONLY) - {d for c, d in IGNORED if c == name}
        assert not lost, (name, lost)
        assert set(command.fixed) <= accepted


def test_the_readmes_api_example_runs_and_stores_what_it_says(tmp_path, monkeypatch, capsys):
    """The Python block of the README's API section, run as a user would (in a fresh folder):
    the cells, the tuning and the study it names are stored, and the report files exist."""
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme[readme.index("### The Python API") :]
    block = section[section.index("```python\n") + 10 : section.index("```\n", 10)]
    monkeypatch.chdir(tmp_path)
    exec(compile(block, "README.md", "exec"), {})
    printed = capsys.readouterr().out
    assert printed.startswith("4 [")  # 2 methods x 2 seeds computed, then the files
    store = Store(tmp_path / "my-results" / "store")
    assert len(store.cells_frame("paper-signal")[["method", "seed"]].drop_duplicates()) >= 4
    assert {r["method"] for r in store.tunings.records.values()} == {"jacobi"}
    (front,) = store.studies.records.values()
    assert (front["study"], front["item"], front["setting"]) == (
        "pareto",
        "limit-iwn2-0.01",
        "jacobi",
    )
    assert (tmp_path / "my-results" / "limit" / "pareto_limit-iwn2-0.01.md").is_file()


def test_a_rerun_with_nothing_to_compute_draws_no_progress_bar(tmp_path, capsys):
    api.run(TASK, seeds=1, methods=["finite_difference"], out=tmp_path, progress=True)
    assert "cell" in capsys.readouterr().err  # the bar of the cells computed
    api.run(TASK, seeds=1, methods=["finite_difference"], out=tmp_path, progress=True)
    assert "cell" not in capsys.readouterr().err  # nothing computed: no empty bar
