"""``make studies`` as data: every step of the long studies, run in order, each one timed.

Each step is one ``diffbench`` command line (:class:`Step`), run as its own process, exactly
as typed in a shell: it resumes from the studies' store like any command, so a rerun after an
interruption computes only what is missing. :func:`run_steps` runs them and stores, for each
attempt at a step, its wall time, its exit status and how many records it added to the store
(cells, tunings, item rows): one item row of the study ``make-studies`` in that same store.
:func:`write_studies_timing` renders them as ``studies.md`` and ``studies.csv`` (the
``studies`` table of ``results/timing/``): each step's wall time, its share of the total, and
whether the store was empty when the first step began (the time *from an empty store*).
"""

from __future__ import annotations

import os
import re
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

import pandas as pd

from diffbench.bench.core.provenance import git_revision
from diffbench.bench.core.records import SCHEMAS, utc_now
from diffbench.bench.core.store import STORE_FILE, Store
from diffbench.bench.report.tables import markdown_table, write_csv, write_text
from diffbench.signals.scenarios import get_scenario

STUDY = "make-studies"
"""The study name under which each step's attempts are stored (the store's ``studies``)."""

GRID_PEERS = (
    "pynumdiff.spectraldiff,pynumdiff.butterdiff,pynumdiff.savgoldiff,pynumdiff.kerneldiff,"
    "derivative.spectral"
)
"""The fast peers (a call costs milliseconds): the grid, the real robot, the paper signal."""
SPECTRAL_PEERS = "pynumdiff.spectraldiff,derivative.spectral"
COUNTERPARTS = "pynumdiff.rtsdiff,pynumdiff.polydiff"
"""PyNumDiff's counterparts of Kalman and Jacobi (issue 45), tuned on the whole record."""
GP_COUNTERPART = "gaussian_process,pynumdiff.rbfdiff"
"""The Gaussian process and rbfdiff (1.3 s a call on 1000 samples: one tuning seed), tuned on
the whole of ``paper-signal-999ms`` once for the three paper-signal records
(:data:`GP_TUNED_ON`)."""
GP_TUNED_ON = "paper-signal-999ms"
"""The record the Gaussian process and rbfdiff are tuned on for every paper-signal record:
its 1000 samples are the first 1000 of ``paper-signal``'s 1001, noise included (the same
draws), so a tuning of its own on ``paper-signal`` (174 s at 14de891, to the same rbfdiff
setting) computed it again; too long for either on the 4938 samples of
``paper-signal-4937ms``."""
UNTUNED_PEERS = ("derivative.kernel",)
"""Peers left out of the oracle tuning of every peer on ``paper-signal`` (scored at their
settings in every ``run``): ``derivative.kernel`` solves a dense system of the record's length
at every call (0.8 s a call for ẋ on 1000 samples, twice that for ẍ), its two tunings 485 s
of CPU at 14de891, half of that step."""
RECORDS = ("paper-signal-4937ms", "paper-signal-999ms", "kink")
"""The paper-signal variants: each with every method at its settings and oracle-tuned
(natives and spectral peers), and but ``paper-signal-999ms`` (:data:`ONE_SAMPLE_SHORTER`)
every tuning protocol of ``paper-signal``."""
ONE_SAMPLE_SHORTER = ("paper-signal-999ms",)
"""The variants that skip the several-seed and the counterparts' tunings: the samples of
``paper-signal-999ms`` are those of ``paper-signal`` but its last, its point the spectral
methods' odd extension no longer exact at its ends, which its oracle tunings show; those
protocols (3.6 min of ``make studies`` at 14de891) repeated ``paper-signal``'s on the
same draws, and ``paper-signal-4937ms`` has ends that do not meet for them."""

TUNING_SAMPLES = 10_000
"""About how many samples the loss of a several-seed tuning reads: ten seeds of the 1001
samples of ``paper-signal``, two of the 4938 of ``paper-signal-4937ms``
(:func:`tuning_seeds_for`): as many noise draws in every record's loss, the signal being the
same. Ten seeds of the longer record (49,380 samples a loss) took 21 % of ``make studies``'
wall time at 7a39896."""


def tuning_seeds_for(task: str) -> int:
    """The tuning seeds a several-seed tuning on the signal task ``task`` averages over: the
    whole number nearest :data:`TUNING_SAMPLES` / its samples, at least one."""
    return max(1, round(TUNING_SAMPLES / get_scenario(task).n_samples))


@dataclass(frozen=True)
class Step:
    """One step of ``make studies``: the folder of ``results/studies`` it writes (``study``)
    and its ``diffbench`` command line without ``--out`` (``argv``; ``out_under``: the
    argument is a folder under the output one, for ``recommend``; ``takes_out=False``: the
    command writes a file it names itself, ``export``)."""

    study: str
    argv: tuple[str, ...]
    out_under: str | None = None
    takes_out: bool = True

    @property
    def command(self) -> str:
        return " ".join(["diffbench", *self.argv])

    def command_line(self, out: Path) -> list[str]:
        """The process's command line, writing under ``out``."""
        argv = list(self.argv)
        if self.takes_out:
            argv += ["--out", str(out / self.out_under if self.out_under else out)]
        return [sys.executable, "-m", "diffbench.bench", *argv]


def _tunings(methods: str, task: str, seeds: int, *extra: str) -> tuple[str, ...]:
    return ("tune", methods, task, "--orders", "1,2", "--seeds", str(seeds), *extra)


def _paper_tunings(task: str, seeds: int) -> list[Step]:
    """The tuning protocols every paper-signal record runs: several tuning seeds
    (:func:`tuning_seeds_for`) on the interior, on the whole record (the choice combinations
    screened to two), PyNumDiff's counterparts on the whole record."""
    several = ("--tuning-seeds", str(tuning_seeds_for(task)), "--budget", "400")
    whole = (*several, "--screen", "2", "--region", "whole")
    return [
        Step(task, _tunings(f"native,{GRID_PEERS}", task, seeds, *several)),
        Step(task, _tunings(f"native,{GRID_PEERS}", task, seeds, *whole)),
        Step(task, _tunings(COUNTERPARTS, task, seeds, *whole)),
    ]


REPORTING = {"run": 1, "tune": 2}
"""The commands whose report a later one on the same task rewrites: the position of the task
in their arguments."""


def _reports_once(steps: list[Step]) -> list[Step]:
    """``steps`` with ``--no-report`` on each ``run`` or ``tune`` whose task a later one runs
    on: each task's report is written once, by its last step, from everything the store then
    holds (a report read the whole store and drew its figures again at every step: 15-20 s a
    step on the paper-signal records)."""

    def task(step: Step) -> str | None:
        where = REPORTING.get(step.argv[0])
        return None if where is None else step.argv[where]

    last = {task(step): index for index, step in enumerate(steps) if task(step) is not None}
    return [
        Step(step.study, (*step.argv, "--no-report"), step.out_under, step.takes_out)
        if task(step) is not None and last[task(step)] != index
        else step
        for index, step in enumerate(steps)
    ]


def studies_steps(seeds: int = 20, jobs: int = 2) -> list[Step]:
    """Every step of ``make studies``, in order, at ``seeds`` scored seeds (the online, grid
    and limit studies keep their own counts) and ``jobs`` worker processes."""
    work = ("--jobs", str(jobs))
    oracle = ("--criteria", "oracle")
    gp_oracle = (*oracle, "--region", "whole")
    everything = f"native,{GRID_PEERS},causal"
    tuned_peers = ",".join(["peers", *(f"-{name}" for name in UNTUNED_PEERS)])
    steps = [
        Step("paper-signal", ("run", "paper-signal", "--seeds", str(seeds))),
        Step(
            "paper-signal",
            _tunings("native", "paper-signal", seeds, "--criteria", "oracle,no-truth,pynumdiff"),
        ),
        Step("paper-signal", _tunings(tuned_peers, "paper-signal", seeds, *oracle)),
        *_paper_tunings("paper-signal", seeds),
    ]
    for record in RECORDS:
        steps += [
            Step(record, ("run", record, "--seeds", str(seeds))),
            Step(record, _tunings(f"native,{SPECTRAL_PEERS}", record, seeds, *oracle)),
            *([] if record in ONE_SAMPLE_SHORTER else _paper_tunings(record, seeds)),
        ]
    steps.append(Step(GP_TUNED_ON, _tunings(GP_COUNTERPART, GP_TUNED_ON, seeds, *gp_oracle)))
    tuned_on = ("--tuned-on", GP_TUNED_ON, *gp_oracle)
    steps += [
        Step(record, _tunings(GP_COUNTERPART, record, seeds, *tuned_on))
        for record in ("paper-signal", "paper-signal-4937ms")
    ]
    steps += [
        Step("paper-figures", ("run", "paper-figures")),
        Step("robot-sim", ("run", "robot-sim", "--seeds", str(seeds))),
        Step("identify-dfki", ("run", "identify-dfki", "--methods", f"native,{GRID_PEERS}")),
        Step("online", ("run", "online-paper-signal", "--seeds", "5")),
        Step("online", ("run", "online-2r-loop", "--seeds", "3")),
        Step("grid", ("run", "grid", "--methods", everything, "--seeds", "10")),
        Step("recommend-validation", ("recommend-check",)),
        Step("limit", ("run", "limit", "--methods", everything, "--seeds", "20")),
        Step("limit", ("run", "pareto", "--methods", "native")),
        Step("pynumdiff-suite", ("run", "pynumdiff-suite")),
        Step("sindy", ("run", "sindy")),
    ]
    steps = _reports_once([Step(s.study, (*s.argv, *work), s.out_under) for s in steps])
    example = "recommend-example"
    record = f"{{out}}/{example}/pendulum.csv"
    advice = ("--time", "t", "--column", "x", "--dt", "0.002", "--methods", f"native,{GRID_PEERS}")
    return [
        *steps,
        Step(example, ("export", "pendulum-500hz-jitter", record), takes_out=False),
        Step(example, ("recommend", record, *advice), out_under=example),
    ]


def record_counts(directory: Path) -> dict[str, int]:
    """How many records each table of the store in ``directory`` holds (zeros where there is
    no store yet), read by a read-only connection (a step's process may be writing)."""
    path = Path(directory) / STORE_FILE
    counts = dict.fromkeys(SCHEMAS, 0)
    if not (path.exists() and path.stat().st_size > 0):
        return counts
    connection = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, timeout=60)
    try:
        for table in counts:
            counts[table] = connection.execute(f'SELECT count(*) FROM "{table}"').fetchone()[0]
    finally:
        connection.close()
    return counts


def _resolved(step: Step, out: Path) -> list[str]:
    return [part.replace("{out}", str(out)) for part in step.command_line(out)]


def _attempts(store: Store) -> pd.DataFrame:
    """Every stored attempt at a step, one row each, in the order they began."""
    rows = [
        {**dict(record["rows"][0]), "step": record["item"]}
        for record in store.studies.records.values()
        if record["study"] == STUDY
    ]
    columns = ["index", "command", "status", "wall_s", "started_utc"]
    columns += [f"new_{table}" for table in SCHEMAS]
    frame = pd.DataFrame(rows, columns=list(dict.fromkeys([*columns, *(rows[0] if rows else ())])))
    frame = frame.sort_values("started_utc", kind="stable", ignore_index=True)
    if len(frame):
        frame["git_rev"] = [
            _step_revision(attempt, store.runs.values()) for _, attempt in frame.iterrows()
        ]
    return frame


def _step_revision(attempt: pd.Series, runs) -> str:
    """The code revision(s) the step's own processes recorded in their runs' rows (those begun
    while the attempt ran, ``diffbench studies`` itself left out): what the step ran, also if
    the checkout moved during a long run; the revision the attempt stored when its processes
    wrote nothing (no run row)."""
    start = datetime.fromisoformat(attempt["started_utc"])
    end = (start + timedelta(seconds=float(attempt["wall_s"]) + 1)).isoformat()
    revisions = [
        run["git_rev"]
        for run in runs
        if attempt["started_utc"] <= str(run.get("started_utc")) <= end
        and not str(run.get("command", "")).startswith("diffbench studies")
    ]
    return ", ".join(dict.fromkeys(revisions)) or str(attempt.get("git_rev", "?"))


def run_steps(
    steps: Sequence[Step],
    out: Path,
    *,
    only: Iterable[str] | None = None,
    echo: Callable[[str], None] = print,
) -> pd.DataFrame:
    """Run ``steps`` in order (those whose study is in ``only``, when given), each as its own
    ``diffbench`` process writing under ``out``; store each attempt (its wall time, exit
    status and the records it added to ``out/store``) and return every stored attempt.
    A step that fails stops the run: its exit code is raised as ``SystemExit`` once the
    attempt is stored (an interrupted one too, then the interruption goes on)."""
    out = Path(out)
    only = None if only is None else set(only)
    empty_at_start = not any(record_counts(out / "store").values())
    for index, step in enumerate(steps, start=1):
        if only is not None and step.study not in only:
            continue
        before = record_counts(out / "store")
        revision = git_revision()  # the checkout the step's process starts from
        started, clock = utc_now(), time.perf_counter()
        echo(f"[{index}/{len(steps)}] {step.command}")
        status, interrupted = None, False
        try:
            status = subprocess.run(_resolved(step, out), check=False).returncode
        except KeyboardInterrupt:
            interrupted = True
        wall_s = time.perf_counter() - clock
        after = record_counts(out / "store")
        attempt = {
            "index": index,
            "study": step.study,
            "command": step.command,
            "started_utc": started,
            "wall_s": round(wall_s, 3),
            "status": "interrupted" if interrupted else ("ok" if status == 0 else str(status)),
            **{f"new_{table}": after[table] - before[table] for table in sorted(after)},
            "store_empty_at_start": empty_at_start,
            "cpus": os.cpu_count(),
            "git_rev": revision,
        }
        store = Store(out / "store")
        store.add_study_rows(STUDY, f"{index:02d} {step.command}", {"started": started}, [attempt])
        store.close()
        if interrupted:
            raise KeyboardInterrupt
        if status != 0:
            raise SystemExit(status if status > 0 else 128 - status)
    store = Store(out / "store")
    try:
        return _attempts(store)
    finally:
        store.close()


def _without_jobs(command: str) -> str:
    """A step's command less its ``--jobs N``: the same step, whatever the processes."""
    return re.sub(r" --jobs \d+", "", command)


def studies_timing(attempts: pd.DataFrame, steps: Sequence[Step]) -> pd.DataFrame:
    """One row per step of ``steps``: the wall time of its first pass, the attempts up to its
    first that finished (an interrupted attempt's time counts: the resumed one did only the
    rest; a later rerun, which computes nothing new, does not), their number, the records they
    added, the step's share of the total. A step not yet finished has no time (NaN)."""
    rows = []
    for index, step in enumerate(steps, start=1):
        same = attempts["command"].map(_without_jobs) == _without_jobs(step.command)
        mine = attempts[(attempts["index"] == index) & same]
        finished = (mine["status"] == "ok").to_numpy().nonzero()[0]
        if len(finished):
            mine = mine.iloc[: finished[0] + 1]
        row = {
            "index": index,
            "study": step.study,
            "command": step.command,
            "wall_s": float(mine["wall_s"].sum()) if len(finished) else float("nan"),
            "attempts": len(mine),
            "git_rev": ", ".join(dict.fromkeys(mine.get("git_rev", pd.Series(dtype=str)))),
        }
        for table in ("cells", "tunings", "studies"):
            row[f"new_{table}"] = int(mine[f"new_{table}"].sum())
        rows.append(row)
    table = pd.DataFrame(rows)
    table["share"] = table["wall_s"] / table["wall_s"].sum()
    return table


def write_studies_timing(
    attempts: pd.DataFrame, steps: Sequence[Step], directory: Path
) -> list[Path]:
    """``studies.md`` and ``studies.csv`` in ``directory``: :func:`studies_timing`, each
    study's total, and the whole run's."""
    table = studies_timing(attempts, steps)
    directory.mkdir(parents=True, exist_ok=True)
    csv = write_csv(directory / "studies.csv", table)
    first = attempts.iloc[0] if len(attempts) else pd.Series(dtype=object)
    empty = bool(first.get("store_empty_at_start", False))
    revisions = ", ".join(dict.fromkeys(attempts["git_rev"])) if len(attempts) else "?"
    jobs = re.search(r"--jobs (\d+)", str(first.get("command", "")))
    finished = table["wall_s"].notna()
    per_study = (
        table.assign(finished=finished)
        .groupby("study", sort=False)
        .agg(steps=("index", "size"), finished=("finished", "sum"), wall_s=("wall_s", "sum"))
        .reset_index()
    )
    per_study["minutes"] = (per_study["wall_s"] / 60).map(lambda m: f"{m:.1f}")
    per_study.loc[per_study["finished"] == 0, "minutes"] = "—"

    def shown(values, text):
        return [text(v) if pd.notna(v) else "—" for v in values]

    steps_shown = table.assign(
        command=table["command"].map(_without_jobs),
        minutes=shown(table["wall_s"] / 60, lambda m: f"{m:.2f}"),
        share=shown(100 * table["share"], lambda p: f"{p:.1f} %"),
        code=[", ".join(r[:7] for r in revs.split(", ") if r) for revs in table["git_rev"]],
    )[
        [
            "index",
            "study",
            "command",
            "minutes",
            "share",
            "attempts",
            "new_cells",
            "new_tunings",
            "code",
        ]
    ]
    lines = [
        "# make studies: each step's wall time",
        "",
        f"`diffbench studies --jobs {jobs.group(1) if jobs else '?'}` (`make studies`) on "
        f"{first.get('cpus', '?')} CPUs, code at {revisions}, "
        + ("from an empty store" if empty else "on a store that already held records")
        + f": {int(finished.sum())} of {len(table)} steps finished, "
        f"{table['wall_s'].sum() / 60:.1f} min of wall time in all"
        + ("" if finished.all() else " (— : a step not finished in this store, no time)")
        + ". A step's time is that of its first pass: its attempts up to the first that "
        "finished (an interrupted one and its resumption). new_cells, new_tunings: the records "
        "the step added to the store; code: the revision its processes ran.",
        "",
        "By study (minutes of the finished steps):",
        "",
        markdown_table(per_study[["study", "steps", "finished", "minutes"]]),
        "",
        "By step:",
        "",
        markdown_table(steps_shown),
        "",
    ]
    return [write_text(directory / "studies.md", "\n".join(lines)), csv]


def run_studies(
    *,
    out: Path = Path("results/studies"),
    timing_out: Path | None = None,
    seeds: int = 20,
    jobs: int = 2,
    only: Iterable[str] | None = None,
    echo: Callable[[str], None] = print,
) -> list[Path]:
    """``make studies``: :func:`studies_steps` run by :func:`run_steps` into ``out``, then
    their timing table (:func:`write_studies_timing`) into ``timing_out`` (default
    ``out/../timing``); returns the table's files."""
    out = Path(out)
    steps = studies_steps(seeds, jobs)
    previous = signal.getsignal(signal.SIGTERM)
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # a killed run stores its step
    try:
        attempts = run_steps(steps, out, only=only, echo=echo)
    finally:
        signal.signal(signal.SIGTERM, previous)
    return write_studies_timing(attempts, steps, Path(timing_out or out.parent / "timing"))
