"""The ``diffbench`` command line: a thin layer over the Python API.

User errors print one line on stderr and exit with code 2 (never a traceback); an interrupted
run keeps every finished cell and exits with code 130; the same command resumes it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import pandas as pd
from diffbench import methods, signals
from diffbench.bench import runner, tables
from diffbench.bench.provenance import provenance
from diffbench.bench.store import ResultStore

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


class UsageError(Exception):
    """A mistake in the command line (reported in one line, exit code 2)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # argparse would print usage and exit itself
        raise UsageError(message)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="diffbench", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    commands.add_parser("list", help="methods (parameters, ranges, presets), signals, scenarios")

    run = commands.add_parser("run", help="run every method at its preset on a scenario")
    run.add_argument("scenario", help="scenario name (see `diffbench list`)")
    run.add_argument(
        "--seeds", type=_positive_int, default=10, help="number of noise seeds 0..N-1 (default 10)"
    )
    run.add_argument(
        "--out", type=Path, default=Path("results"), help="results directory (default results/)"
    )
    run.add_argument(
        "--methods", default=None, help="comma-separated method names (default: all registered)"
    )
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument(
        "--jobs",
        type=_positive_int,
        default=1,
        help="local processes (results identical to a serial run)",
    )

    figures = commands.add_parser(
        "paper-figures",
        help="the paper's figures 1-3 (PNG + CSV), the frequency table and table I, measured",
    )
    figures.add_argument(
        "--out", type=Path, default=Path("results"), help="results directory (default results/)"
    )
    figures.add_argument(
        "--seeds", type=_positive_int, default=10, help="noise seeds for table I (default 10)"
    )
    figures.add_argument("--no-progress", action="store_true", help="no progress bar")
    figures.add_argument("--jobs", type=_positive_int, default=1, help="local processes")

    identify = commands.add_parser(
        "identify", help="identify the 2R robot's base parameters with every method (IDIM-LS)"
    )
    identify.add_argument(
        "target", choices=["sim", "dfki"],
        help="sim: the simulated paper robot; dfki: the real DFKI double pendulum "
        "(leave-one-run-out over its 6 runs)",
    )  # fmt: skip
    identify.add_argument("--scenario", default="robot-sim", help="robot scenario (sim)")
    identify.add_argument(
        "--seeds", type=_positive_int, default=10, help="noise seeds 0..N-1 (default 10)"
    )
    identify.add_argument("--out", type=Path, default=Path("results"))
    identify.add_argument("--methods", default=None, help="comma-separated method names")
    identify.add_argument("--no-progress", action="store_true", help="no progress bar")
    identify.add_argument("--jobs", type=_positive_int, default=1, help="local processes")

    tune = commands.add_parser(
        "tune", help="tune a method (or all) on a scenario's tuning seed, score on other seeds"
    )
    tune.add_argument("method", help="method name, or 'all'")
    tune.add_argument("scenario", help="scenario name (see `diffbench list`)")
    criterion = tune.add_mutually_exclusive_group()
    criterion.add_argument(
        "--oracle",
        dest="criterion",
        action="store_const",
        const="oracle",
        help="minimise the RMSE against the truth (default)",
    )
    criterion.add_argument(
        "--no-truth",
        dest="criterion",
        action="store_const",
        const="no-truth",
        help="data-only spectral risk (needs --cutoff-hz)",
    )
    criterion.add_argument(
        "--pynumdiff",
        dest="criterion",
        action="store_const",
        const="pynumdiff",
        help="PyNumDiff's data-only loss",
    )
    tune.set_defaults(criterion="oracle")
    tune.add_argument(
        "--order", type=int, choices=[1, 2], default=2, help="derivative to tune for (default 2)"
    )
    tune.add_argument(
        "--cutoff-hz",
        type=float,
        default=20.0,
        help="bandlimit guess for the data-only criteria (default 20)",
    )
    tune.add_argument(
        "--tuning-seed",
        type=int,
        default=10_000,
        help="noise seed tuned on (default 10000; never scored)",
    )
    tune.add_argument(
        "--seeds", type=_positive_int, default=20, help="scoring seeds 0..N-1 (default 20)"
    )
    tune.add_argument("--out", type=Path, default=Path("results"))
    tune.add_argument("--no-progress", action="store_true", help="no progress bar")
    tune.add_argument("--jobs", type=_positive_int, default=1, help="local processes")

    grid = commands.add_parser(
        "grid", help="tune every method on the noise x level x step grid and find the winners"
    )
    grid.add_argument("--seeds", type=_positive_int, default=10, help="scoring seeds 0..N-1")
    grid.add_argument("--orders", default="1,2", help="derivatives tuned for (default 1,2)")
    grid.add_argument("--out", type=Path, default=Path("results"))
    grid.add_argument("--jobs", type=_positive_int, default=1, help="local processes")
    grid.add_argument("--no-progress", action="store_true", help="no progress bar")

    timing = commands.add_parser("timing", help="throughput of every method vs signal length")
    timing.add_argument("--out", type=Path, default=Path("results"))

    table = commands.add_parser("table", help="render the tables of a stored run again")
    table.add_argument("scenario")
    table.add_argument("--out", type=Path, default=Path("results"))
    return parser


def _cmd_list() -> None:
    print("methods (name: parameter range [tuning range] default; presets)")
    for name in methods.available():
        cls = methods.method_class(name)
        print(f"  {name}  ({'linear' if cls.linear else 'nonlinear'}; {cls.reference})")
        for spec in methods.params_of(cls):
            tune = ""
            if spec.tune_low is not None:
                scale = ", log" if spec.log else ""
                tune = f" [tune {spec.tune_low:g}..{spec.tune_high:g}{scale}]"
            print(
                f"      {spec.name}: {spec.describe_range()}{tune} default {spec.default!r}"
                f"  - {spec.doc}"
            )
        for key, chosen in cls.presets.items():
            values = ", ".join(f"{k}={v!r}" for k, v in chosen.values.items())
            print(f"      preset {key}: {values}  ({chosen.source})")
    print("signals")
    for name in signals.available_signals():
        print(f"  {name}: {signals.get_signal(name)!r}")
    print("scenarios (diffbench run)")
    for name in signals.available_scenarios():
        scenario = signals.get_scenario(name)
        print(f"  {name}: {scenario.description}")
    print("robot scenarios (diffbench identify sim --scenario NAME)")
    for name in signals.robot2r.available_robot_scenarios():
        print(f"  {name}: {signals.robot2r.get_robot_scenario(name).description}")
    from diffbench.bench.robot import DfkiCrossValidation

    print(f"real robot (diffbench identify dfki)\n  {DfkiCrossValidation().description}")


def _scenario_dir(out: Path, scenario: str) -> Path:
    return out / scenario


def _render(store: ResultStore, directory: Path, scenario: str) -> list[Path]:
    rows = store.load()
    if rows.empty:
        raise UsageError(f"no stored results in {store.path}; run `diffbench run {scenario}`")
    return tables.write_run_tables(rows, directory, scenario)


def _progress(enabled: bool):
    if not enabled:
        return None

    def wrap(items, total):
        from tqdm import tqdm

        return tqdm(items, total=total, unit="cell", file=sys.stderr, dynamic_ncols=True)

    return wrap


def _method_names(args: argparse.Namespace) -> list[str] | None:
    """The comma-separated ``--methods``, or None for every registered method."""
    if not args.methods:
        return None
    return [name.strip() for name in args.methods.split(",") if name.strip()]


def _cmd_run(args: argparse.Namespace) -> None:
    cells = runner.preset_cells(args.scenario, range(args.seeds), _method_names(args))
    directory = _scenario_dir(args.out, args.scenario)
    store = ResultStore(directory / "cells.csv")
    summary = _run_cells(cells, store, args)
    written = _render(store, directory, args.scenario)
    print(
        f"{summary.computed} cells computed, {summary.skipped} already stored; "
        f"wrote {', '.join(str(p) for p in written)}"
    )
    revisions = set(store.load()["git_rev"]) - {provenance()["git_rev"]}
    if revisions:
        print(
            "note: some stored cells were computed by other code revisions "
            f"({', '.join(sorted(r[:12] for r in revisions))}); delete {directory} to "
            "recompute them all",
            file=sys.stderr,
        )


def _cmd_paper_figures(args: argparse.Namespace) -> None:
    from diffbench.bench import paper

    directory = args.out / "paper-figures"
    directory.mkdir(parents=True, exist_ok=True)
    written = paper.write_figure1(directory) + paper.write_figure2(directory)
    written += paper.write_figure3(directory) + paper.write_frequency_table(directory)
    influence = args.out / "jacobi-influence"
    store = ResultStore(influence / "cells.csv")
    _run_cells(paper.influence_cells(range(args.seeds)), store, args)
    written += tables.write_table(
        tables.wide_table(store.load(), tables.DECOMPOSITION_COLUMNS),
        influence,
        "table1",
        "Table I of the paper, measured: bias and noise parts of the Jacobi error on "
        "`paper-signal` as κ = μ, q and T move from the preset (interior RMS, mean ± 95 % CI)",
        "Preset κ = μ = 12, q = 6, T = 0.21 s (trapezoid rule); one parameter changed per row.",
    )
    for path in written:
        print(path)


def _run_cells(cells, store: ResultStore, args: argparse.Namespace) -> runner.RunSummary:
    try:
        return runner.run(cells, store, progress=_progress(not args.no_progress), jobs=args.jobs)
    except KeyboardInterrupt:
        stored = len(store.completed_keys())
        print(
            f"diffbench: interrupted; {stored} cells are stored in {store.path}; "
            "run the same command to resume",
            file=sys.stderr,
        )
        raise SystemExit(EXIT_INTERRUPTED) from None


def _cmd_identify(args: argparse.Namespace) -> None:
    from diffbench.bench import paper
    from diffbench.bench.robot import well_excited
    from diffbench.signals import robot2r

    names = _method_names(args)
    if args.target == "dfki":
        _identify_dfki(args, names)
        return
    scenario = robot2r.get_robot_scenario(args.scenario)
    cells = runner.preset_cells(args.scenario, range(args.seeds), names)
    directory = args.out / f"identify-{args.scenario}"
    store = ResultStore(directory / "cells.csv")
    summary = _run_cells(cells, store, args)
    rows = store.load()
    table = tables.identification_table(rows, robot2r.PARAMETER_NAMES, scenario.true_parameters)
    written = tables.write_identification_table(
        table, directory,
        f"Base parameters of `{args.scenario}` identified with each differentiator (IDIM-LS; "
        "the paper's table II layout; means over seeds)",
        "X̂: mean estimate; σ: one standard deviation σ_X from σ_ρ²(WᵀW)⁻¹ (the paper's table "
        "II column 'σ' is about 2σ); %σXr = 100 σ/|X̂|; err: (X̂ − X)/X in %, mean ± std over "
        "seeds. Robot presets of each method; L = 0.5 m.",
    )  # fmt: skip
    mask = well_excited(scenario)
    excited = ", ".join(n for n, w in zip(robot2r.PARAMETER_NAMES, mask, strict=True) if w)
    written += tables.write_table(
        tables.wide_table(rows, tables.IDENTIFICATION_SUMMARY), directory, "summary",
        f"Identification on `{args.scenario}`: parameter error, torque prediction on a fresh "
        "trajectory, derivative errors (mean ± 95 % CI of the mean over seeds)",
        "‖X̂−X‖/‖X‖ over the parameters identified to < 10 % relative σ with exact derivatives "
        f"({excited}).",
    )  # fmt: skip
    written += paper.write_figure5(directory, args.scenario)
    print(f"{summary.computed} cells computed, {summary.skipped} already stored")
    for path in written:
        print(path)


def _identify_dfki(args: argparse.Namespace, names) -> None:
    from diffbench.signals import dfki

    cells = runner.preset_cells("dfki-cv", range(dfki.DFKI_RUNS), names)
    directory = args.out / "identify-dfki"
    store = ResultStore(directory / "cells.csv")
    summary = _run_cells(cells, store, args)
    rows = store.load()
    written = tables.write_table(
        tables.wide_table(rows, tables.DFKI_SUMMARY), directory, "summary",
        "DFKI double pendulum: measured-torque prediction on the held-out run after "
        "identification on the other five (mean ± 95 % CI over the 6 folds)",
        "τ RMSE: identified model vs measured torque, both decimated alike (F_p = 5 Hz), on "
        "the actuated joints of the held-out run; lab: the lab's published model with the same "
        "derivatives; q̇ vs driver: RMSE against the motor driver's own velocity estimate.",
    )  # fmt: skip
    table = tables.identification_table(rows, dfki.PENDULUM_PARAMETER_NAMES)
    table.insert(1, "lab", dfki.lab_base_parameters())
    written += tables.write_identification_table(
        table, directory,
        "DFKI double pendulum base parameters identified with each differentiator (mean over "
        "the 6 leave-one-run-out fits; column 'lab' holds the lab's published model)",
        "X̂ (σ one standard deviation, %σXr); see signals/dfki.py for the base parameters.",
        reference="lab",
    )  # fmt: skip
    print(f"{summary.computed} cells computed, {summary.skipped} already stored")
    for path in written:
        print(path)


def _cmd_tune(args: argparse.Namespace) -> None:
    from diffbench.bench import tuning

    if args.tuning_seed < args.seeds:
        raise UsageError(f"--tuning-seed {args.tuning_seed} is among the scored seeds "
                         f"0..{args.seeds - 1}; choose one >= {args.seeds}")  # fmt: skip
    scenario = signals.get_scenario(args.scenario)
    names = (
        methods.available() if args.method == "all" else [methods.method_class(args.method).name]
    )
    realisation = scenario.realise(args.tuning_seed)
    directory = _scenario_dir(args.out, args.scenario)
    cells, records = [], []
    for name in names:
        if args.criterion == "no-truth" and not methods.method_class(name).linear:
            print(f"{name}: not linear, skipped for --no-truth", file=sys.stderr)
            continue
        result = tuning.tune(name, realisation, args.order, args.criterion, args.cutoff_hz)
        label = (f"tuned: {args.criterion} for {tables.ORDER_LABELS[args.order]} on seed "
                 f"{args.tuning_seed}")  # fmt: skip
        params = {**methods.get(name).params(), **result.params}
        cells += [runner.Cell(name, params, args.scenario, seed, preset=label)
                  for seed in range(args.seeds)]  # fmt: skip
        records.append({"method": name, "criterion": args.criterion, "order": args.order,
                        "tuning_seed": args.tuning_seed, "loss": result.loss,
                        "evaluations": result.evaluations, "seconds": round(result.seconds, 3),
                        "params": json.dumps(params, sort_keys=True)})  # fmt: skip
        print(
            f"{name}: {result.params} (loss {result.loss:.4g}, {result.evaluations} "
            f"evaluations, {result.seconds:.2f} s)"
        )
    store = ResultStore(directory / "cells.csv")
    summary = _run_cells(cells, store, args)
    log = directory / "tuning.csv"
    frame = pd.DataFrame(records)
    frame.to_csv(log, mode="a", header=not log.exists(), index=False)
    written = [*_render(store, directory, args.scenario), log]
    written += tables.write_tuning_summary(store.load(), pd.read_csv(log), directory)
    print(f"{summary.computed} cells computed, {summary.skipped} already stored")
    for path in written:
        print(path)


def _cmd_grid(args: argparse.Namespace) -> None:
    from diffbench.bench import grid

    try:
        orders = tuple(int(o) for o in args.orders.split(","))
    except ValueError:
        raise UsageError(f"--orders must be a comma-separated list of 1 and 2, got "
                         f"{args.orders!r}") from None  # fmt: skip
    if not set(orders) <= {1, 2}:
        raise UsageError(f"--orders must hold 1 and/or 2, got {args.orders!r}")
    directory = args.out / "grid"
    store = ResultStore(directory / "cells.csv")
    cells = grid.grid_cells(range(args.seeds), orders, jobs=args.jobs)
    summary = _run_cells(cells, store, args)
    print(f"{summary.computed} cells computed, {summary.skipped} already stored")
    for path in grid.write_winners(store.load(), directory):
        print(path)


def _cmd_table(args: argparse.Namespace) -> None:
    signals.get_scenario(args.scenario)
    directory = _scenario_dir(args.out, args.scenario)
    path = directory / "cells.csv"
    if not path.exists():
        raise UsageError(f"no results at {path}; run `diffbench run {args.scenario}` first")
    for written in _render(ResultStore(path), directory, args.scenario):
        print(written)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``diffbench`` console script; returns the exit code."""
    try:
        args = build_parser().parse_args(argv)
        if args.command == "list":
            _cmd_list()
        elif args.command == "run":
            _cmd_run(args)
        elif args.command == "paper-figures":
            _cmd_paper_figures(args)
        elif args.command == "identify":
            _cmd_identify(args)
        elif args.command == "tune":
            _cmd_tune(args)
        elif args.command == "grid":
            _cmd_grid(args)
        elif args.command == "timing":
            from diffbench.bench import timing

            for path in timing.write_throughput(args.out / "timing", timing.throughput()):
                print(path)
        elif args.command == "table":
            _cmd_table(args)
    except (UsageError, ValueError) as error:
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        print(f"diffbench: error: {message}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:  # e.g. an --out directory that cannot be written
        print(f"diffbench: error: {error.strerror or error}: {error.filename}", file=sys.stderr)
        return EXIT_USAGE
    except SystemExit as stop:
        return int(stop.code or 0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
