"""``diffbench studies`` (make studies as data): every step is a valid command line, a step's
attempts are stored with the records they added, and the timing table counts the first pass."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from diffbench.bench.cli import build_parser
from diffbench.bench.studies import steps as studies
from diffbench.bench.studies.steps import Step, record_counts, run_steps, studies_timing

ONE_CELL = ("run", "paper-signal", "--seeds", "1", "--methods", "finite_difference")


def test_every_step_is_a_command_line_diffbench_parses(tmp_path):
    parser = build_parser()
    every = studies.studies_steps(seeds=20, jobs=2)
    for step in every:
        argv = studies._resolved(step, tmp_path)[3:]
        assert "{out}" not in " ".join(argv)
        parser.parse_args(argv)  # argparse exits (SystemExit 2) on a bad command line
    # each step once: paper-signal's 7 (the GP's tuned on paper-signal-999ms), 6 for each of
    # two variants, 3 for paper-signal-999ms (no several-seed protocols), 12 others
    assert len({step.command for step in every}) == len(every) == 34
    assert {step.study for step in every} >= {"grid", "limit", "sindy", "identify-dfki"}


def test_each_tasks_report_is_written_once_by_its_last_step():
    """Every run or tune step but a task's last carries ``--no-report``; the last writes the
    report of all the task's steps; the other commands (recommend-check, export, recommend)
    are left as they are."""
    every = studies.studies_steps(seeds=20, jobs=2)

    def task(step):
        where = studies.REPORTING.get(step.argv[0])
        return None if where is None else step.argv[where]

    tasks = [task(step) for step in every]
    for index, (step, name) in enumerate(zip(every, tasks, strict=True)):
        quiet = "--no-report" in step.argv
        assert quiet == (name is not None and name in tasks[index + 1 :]), step.command
    last = {name: index for index, name in enumerate(tasks) if name is not None}
    assert every[last["paper-signal"]].argv[:2] == ("tune", "gaussian_process,pynumdiff.rbfdiff")
    quiet = sum("--no-report" in step.argv for step in every)
    assert quiet == 17  # the paper-signal records' 21 steps, less the last of each of the 4


def test_the_gaussian_process_is_tuned_once_for_the_three_paper_signal_records():
    """One tuning of the Gaussian process and rbfdiff, on paper-signal-999ms (its samples the
    first 1000 of paper-signal's, the same draws), scored on all three records; the dense
    peers are left out of the peers' oracle tuning by name."""
    every = studies.studies_steps(seeds=20, jobs=2)
    gp = [s for s in every if s.argv[1] == studies.GP_COUNTERPART]
    own = [s for s in gp if "--tuned-on" not in s.argv]
    assert [s.argv[2] for s in own] == [studies.GP_TUNED_ON]
    shared = {s.argv[2]: s.argv[s.argv.index("--tuned-on") + 1] for s in gp if s not in own}
    assert shared == dict.fromkeys(("paper-signal", "paper-signal-4937ms"), studies.GP_TUNED_ON)
    assert every.index(own[0]) < min(every.index(s) for s in gp if s not in own)
    (peers,) = [s for s in every if s.argv[:2] == ("tune", "peers,-derivative.kernel")]
    assert "derivative.kernel" in studies.UNTUNED_PEERS and peers.argv[2] == "paper-signal"
    for record in studies.ONE_SAMPLE_SHORTER:
        assert not any("--tuning-seeds" in s.argv and s.argv[2] == record for s in every)


def test_several_seed_tunings_read_about_the_same_samples_on_every_record():
    """Ten tuning seeds of the 1001-sample records, two of the 4938-sample one (10,000 samples
    a loss); each record's several-seed steps ask for its own count."""
    assert [studies.tuning_seeds_for(task) for task in ("paper-signal", *studies.RECORDS)] == [
        10,
        2,
        10,
        10,
    ]
    for step in studies.studies_steps(seeds=20, jobs=2):
        if "--tuning-seeds" in step.argv:
            count = step.argv[step.argv.index("--tuning-seeds") + 1]
            assert int(count) == studies.tuning_seeds_for(step.argv[2]), step.command


def test_attempts_are_stored_with_the_records_they_added(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a relative output folder, as make studies gives
    steps = [
        Step("paper-signal", (*ONE_CELL, "--no-progress")),
        Step(
            "example", ("export", "pendulum-500hz-jitter", "{out}/example/p.csv"), takes_out=False
        ),
    ]
    first = run_steps(steps, Path("."), echo=lambda line: None)
    assert list(first["status"]) == ["ok", "ok"]
    assert list(first["new_cells"]) == [1, 0]  # one seed of one method: one cell
    assert (tmp_path / "example" / "p.csv").exists()
    assert record_counts(tmp_path / "store")["cells"] == 1
    again = run_steps(steps, Path("."), echo=lambda line: None)
    assert len(again) == 4 and list(again["new_cells"]) == [1, 0, 0, 0]  # resumed: nothing new
    table = studies_timing(again, steps)
    # the first pass only: the rerun's attempts are not the time from an empty store
    assert list(table["attempts"]) == [1, 1]
    assert list(table["wall_s"]) == list(first["wall_s"])
    assert math.isclose(table["share"].sum(), 1.0, rel_tol=4 * 2.2e-16)
    assert bool(again["store_empty_at_start"].iloc[0]) and not again["store_empty_at_start"].iloc[2]


def test_a_failing_step_stops_the_run_and_is_stored_unfinished(tmp_path):
    steps = [
        Step("paper-signal", ("run", "paper-signal", "--methods", "no_such_method")),
        Step("paper-signal", ONE_CELL),
    ]
    with pytest.raises(SystemExit) as stopped:
        run_steps(steps, tmp_path, echo=lambda line: None)
    assert stopped.value.code == 2  # the step's usage error, its exit code
    assert record_counts(tmp_path / "store")["cells"] == 0  # the second step never ran
    attempts = run_steps(steps[:0], tmp_path)  # nothing to run: the stored attempts
    assert list(attempts["status"]) == ["2"]
    table = studies_timing(attempts, steps)
    assert table["wall_s"].isna().all() and list(table["attempts"]) == [1, 0]


def test_no_store_counts_zero(tmp_path: Path):
    assert set(record_counts(tmp_path).values()) == {0}


def test_the_command_line_runs_the_steps_asked_for_and_writes_the_table(tmp_path, capsys):
    from diffbench.bench.cli import main

    timing = tmp_path / "timing"
    argv = ["studies", "--only", "no-such-study", "--out", str(tmp_path / "s")]
    assert main([*argv, "--timing-out", str(timing)]) == 0
    table = (timing / "studies.md").read_text()
    assert "diffbench run grid" in table and (timing / "studies.csv").exists()
    assert capsys.readouterr().out.splitlines() == [
        str(timing / n) for n in ("studies.md", "studies.csv")
    ]


def test_a_step_is_the_same_step_whatever_its_processes():
    import pandas as pd

    ran = Step("grid", ("run", "grid", "--jobs", "2"))
    attempts = pd.DataFrame(
        [
            {"index": 1, "command": ran.command, "status": "interrupted", "wall_s": 60.0},
            {"index": 1, "command": ran.command, "status": "ok", "wall_s": 30.0},
            {"index": 1, "command": ran.command, "status": "ok", "wall_s": 2.0},  # a rerun
        ]
    ).assign(new_cells=[5, 3, 0], new_tunings=0, new_studies=0)
    table = studies_timing(attempts, [Step("grid", ("run", "grid", "--jobs", "1"))])
    # the interrupted attempt and its resumption: the first pass; the rerun is not counted
    assert list(table["wall_s"]) == [90.0] and list(table["new_cells"]) == [8]
    assert list(table["attempts"]) == [2]


def test_a_step_is_credited_with_the_revision_its_own_processes_ran():
    """The checkout may move during a long run: each attempt gets the revision its processes
    wrote in their runs' rows while it ran (not the ``diffbench studies`` process's own, not
    another step's), and keeps its stored one when its processes wrote no row."""
    import pandas as pd

    attempts = pd.DataFrame(
        [
            {"started_utc": "2026-12-07T06:00:00+00:00", "wall_s": 60.0, "git_rev": "parent"},
            {"started_utc": "2026-12-07T06:01:00+00:00", "wall_s": 30.0, "git_rev": "parent"},
        ]
    )
    runs = [
        {
            "started_utc": "2026-12-07T05:59:59+00:00",
            "git_rev": "p",
            "command": "diffbench studies",
        },
        {
            "started_utc": "2026-12-07T06:00:01+00:00",
            "git_rev": "aaa",
            "command": "diffbench run x",
        },
        {
            "started_utc": "2026-12-07T06:00:30+00:00",
            "git_rev": "p2",
            "command": "diffbench studies",
        },
    ]
    revisions = [studies._step_revision(row, runs) for _, row in attempts.iterrows()]
    assert revisions == ["aaa", "parent"]
