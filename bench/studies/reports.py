"""The reports of each kind of task, rendered from stored rows only (see :mod:`bench.tasks`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench.bench.core.roles import ORDER_SYMBOLS
from diffbench.bench.core.stats import ranking
from diffbench.bench.report import tables
from diffbench.bench.report.figures import write_error_figure, write_online_figure
from diffbench.bench.studies import loop, online, paper
from diffbench.bench.studies.online import pareto_front
from diffbench.bench.studies.robot import (
    NESTED_VARIANT,
    lab_reference,
    parameter_names,
    setting_of,
    well_excited,
)
from diffbench.signals import robot2r

INTERIOR_NOTE = (
    "- **interior**: the task's common interior, the same samples for every method; **whole**: "
    "every sample of the record the method estimates (its own valid samples; the coverage "
    "columns give the fraction of the record they are). Cells: mean ± 95 % confidence "
    "half-width over the noise seeds (std in the CSV)."
)
REGION_HEADINGS = {"interior": "interior", "valid": "whole record"}
WHOLE_RANK_NOTE = (
    "On the **whole record** an entry is ranked by its RMSE over every sample it estimates, "
    f"and only if these cover at least {tables.WHOLE_COVERAGE:.0%} of the record on every seed "
    "(an entry that leaves out its ends would otherwise rank on its middle)."
)


def _seeds_phrase(rows: pd.DataFrame) -> str:
    counts = rows.groupby(tables.ENTRY_KEYS)["seed"].nunique()
    low, high = int(counts.min()), int(counts.max())
    return f"{low} noise seeds" if low == high else f"{low}–{high} noise seeds"


def signal_report(
    task: str, description: str, cells: pd.DataFrame, tunings: pd.DataFrame, directory: Path
) -> list[Path]:
    """``rmse``, ``ranking``, ``decomposition`` (linear methods), ``tuning`` (if tuned) tables
    and the error figure of a signal task."""

    wide = tables.wide_table(cells, tables.RMSE_COLUMNS)
    title = f"`{task}`: RMSE per method and setting (mean ± 95 % CI over {_seeds_phrase(cells)})"
    written = tables.write_report(
        directory,
        "rmse",
        wide,
        tables.display_frame(wide, tables.RMSE_COLUMNS),
        title,
        f"{description}\n\n{tables.legend(cells, INTERIOR_NOTE)}",
    )
    written.append(write_error_figure(wide, directory / "errors.png", title))
    written += ranking_report(cells, directory)
    if cells["metric"].isin(["bias_rmse", "noise_rmse"]).any():
        linear = cells[
            cells.groupby(tables.ENTRY_KEYS)["metric"].transform(
                lambda m: m.isin(["bias_rmse"]).any()
            )
        ]
        parts = tables.wide_table(linear, tables.DECOMPOSITION_COLUMNS)
        written += tables.write_report(
            directory,
            "decomposition",
            parts,
            tables.display_frame(parts, tables.DECOMPOSITION_COLUMNS),
            f"`{task}`: error decomposition of the linear methods (interior RMS)",
            "For a linear method D, D(x + e) − x⁽ⁿ⁾ = [D(x) − x⁽ⁿ⁾] + D(e): **bias** = the "
            "method on the clean signal minus the truth, **noise** = the method on the noise "
            "alone; total² = bias² + noise² + 2·cross term.",
        )
    mine = tunings[tunings["task"] == task] if len(tunings) else tunings
    if len(mine):
        written += tuning_report(cells, mine, directory)
    return written


def ranking_report(cells: pd.DataFrame, directory: Path) -> list[Path]:
    """``ranking.md``/``.csv``: entries ranked by RMSE of ẋ and of ẍ, on the interior and on
    the whole record (entries covering at least :data:`tables.WHOLE_COVERAGE` of it), each
    compared with the next by a paired t-test over the common seeds, with the smallest
    difference that test detects 80 % of the time."""
    frames, parts = [], []
    for order in (1, 2):
        for region in ("interior", "valid"):
            rows = cells if region == "interior" else tables.covering_whole(cells, order)
            chosen = rows[
                (rows["metric"] == "rmse") & (rows["order"] == order) & (rows["region"] == region)
            ]
            if chosen.empty:
                continue
            table = ranking(chosen, "rmse", order, region, keys=tuple(tables.ENTRY_KEYS))
            table = table.merge(tables.entries(chosen), on=tables.ENTRY_KEYS, how="left")
            labelled = tables.label_entries(table).sort_values("mean", kind="stable")
            labelled.insert(0, "derivative", ORDER_SYMBOLS[order])
            labelled.insert(1, "region", REGION_HEADINGS[region])
            frames.append(labelled)
            parts.append(
                f"## {ORDER_SYMBOLS[order]}, {REGION_HEADINGS[region]}\n\n"
                f"{tables.markdown_table(_ranking_shown(labelled))}\n"
            )
    text = (
        "# Rankings by RMSE on the interior and on the whole record\n\n"
        + "\n".join(parts)
        + "\n**better than next?**: the two-sided paired t-test over the common seeds of the "
        "difference with the next row (p < 0.05: yes). **detectable (80 %)**: the smallest true "
        "difference in mean RMSE that this test would find 80 % of the time with these seeds; a "
        "'no' next to a difference smaller than it says the run is too small to tell, not that "
        f"the methods are equal. {WHOLE_RANK_NOTE}\n"
    )
    return [
        tables.write_text(directory / "ranking.md", text),
        tables.write_csv(directory / "ranking.csv", pd.concat(frames)),
    ]


def _ranking_shown(labelled: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "rank": range(1, len(labelled) + 1),
            "method": labelled["method"],
            "package": labelled["package"],
            "ẍ": [tables.xddot_source(m) for m in labelled["method"]],
            "setting": labelled["setting"],
            "parameters": labelled["parameters"],
            "RMSE": [
                tables.plus_minus(m, h)
                for m, h in zip(labelled["mean"], labelled["ci95"], strict=True)
            ],
            "better than next?": [_verdict(row) for _, row in labelled.iterrows()],
            "detectable (80 %)": [
                tables.nan_to_dash(v, 2) for v in labelled["detectable_difference_80"]
            ],
        }
    )


def _verdict(row) -> str:
    if pd.isna(row["significant_vs_next"]):
        return "—"
    word = "yes" if row["significant_vs_next"] else "no"
    return f"{word} (p = {row['vs_next_t_p']:.2g})" if np.isfinite(row["vs_next_t_p"]) else word


# The tunings a tuning table compares: (column, criterion, seeds the loss averages, region it
# is taken on).
TUNING_VARIANTS = (
    ("oracle", "oracle", 1, "interior"),
    ("oracle 10 seeds", "oracle", 10, "interior"),
    ("oracle 10 seeds whole", "oracle", 10, "whole"),
    ("no-truth", "no-truth", 1, "interior"),
    ("pynumdiff", "pynumdiff", 1, "interior"),
)


def tuning_table(cells: pd.DataFrame, tunings: pd.DataFrame) -> pd.DataFrame:
    """Per method, derivative n and scoring region (interior, whole record), the mean RMSE on
    the scoring seeds of the preset and of each tuned setting of :data:`TUNING_VARIANTS`, the
    seconds each tuning took, the no-truth / oracle ratio, and (whole record) the least
    coverage of the record among these settings."""
    chosen = cells[cells["metric"].isin(["rmse", "coverage"])]
    group_keys = [
        "method",
        "origin",
        "criterion",
        "tuned_order",
        "tuning_seeds",
        "tuned_region",
        "order",
        "region",
        "metric",
    ]
    means = chosen.groupby(group_keys, dropna=False)["value"].mean()
    least = chosen.groupby(group_keys, dropna=False)["value"].min()
    records = []
    for (method, order), group in tunings.groupby(["method", "order"], sort=True):
        order = int(order)
        for region in ("interior", "valid"):
            record = {
                "method": method,
                "n": ORDER_SYMBOLS[order],
                "scored on": REGION_HEADINGS[region],
            }
            presets = chosen[
                (chosen["method"] == method)
                & (chosen["origin"] == "preset")
                & (chosen["order"] == order)
                & (chosen["region"] == region)
            ]
            rmse = presets[presets["metric"] == "rmse"]["value"]
            record["preset"] = rmse.mean() if len(rmse) else float("nan")
            coverages = list(presets[presets["metric"] == "coverage"]["value"])
            for column, criterion, seeds, tuned_region in TUNING_VARIANTS:
                hit = group[
                    (group["criterion"] == criterion)
                    & (group["tuning_seeds"] == seeds)
                    & (group["region"] == tuned_region)
                ]
                key = (method, "tuned", criterion, order, seeds, tuned_region, order, region)
                record[column] = (
                    means.get((*key, "rmse"), float("nan")) if len(hit) else float("nan")
                )
                record[f"{column} s"] = float(hit["seconds"].iloc[0]) if len(hit) else float("nan")
                if len(hit):
                    coverages.append(least.get((*key, "coverage"), float("nan")))
            oracle = record["oracle"]
            record["no-truth / oracle"] = (
                record["no-truth"] / oracle if oracle > 0 else float("nan")
            )
            known = [c for c in coverages if np.isfinite(c)]
            record["least coverage"] = min(known) if region == "valid" and known else float("nan")
            records.append(record)
    return pd.DataFrame(records)


def tuning_report(cells: pd.DataFrame, tunings: pd.DataFrame, directory: Path) -> list[Path]:
    """``tuning.md``/``.csv``: :func:`tuning_table`, the columns no tuning filled left out; the
    seconds each tuning took in the ``.csv`` only (they change from run to run and machine to
    machine, so the tracked ``.md`` stays the same when a rerun reproduces the numbers)."""
    frame = tuning_table(cells, tunings)
    frame = frame[
        [c for c in frame.columns if c in ("method", "n", "scored on") or frame[c].notna().any()]
    ]
    shown = frame[[c for c in frame.columns if not c.endswith(" s")]].copy()
    for column in shown.columns[3:]:
        shown[column] = [tables.nan_to_dash(v, 4) for v in frame[column]]
    return tables.write_report(
        directory,
        "tuning",
        frame,
        shown,
        "Tuning: RMSE on the scoring seeds, on the interior and on the whole record, of the "
        "preset and of each tuned setting",
        "Each tuned setting is tuned for the derivative n on its tuning seeds (never scored): "
        "**oracle**, **no-truth**, **pynumdiff**: one seed, loss on the interior; **oracle 10 "
        "seeds**: the loss averaged over ten seeds; **whole**: the loss taken on every sample. "
        "no-truth / oracle near 1 means the data-only criterion finds what the truth would; "
        "tuning.csv also gives the seconds each tuning took. **whole record**: RMSE over each "
        "setting's own valid samples; **least coverage**: the smallest fraction of the record "
        "they cover among the row's settings (under 1: some ends are masked).",
    )


def influence_report(cells: pd.DataFrame, directory: Path) -> list[Path]:
    """Table I of the paper measured: bias and noise parts of the Jacobi error per variant."""
    wide = tables.wide_table(cells, tables.DECOMPOSITION_COLUMNS)
    shown = tables.display_frame(wide, tables.DECOMPOSITION_COLUMNS)
    return tables.write_report(
        directory,
        "table1",
        wide,
        shown,
        "Table I of the paper, measured: bias and noise parts of the Jacobi error on "
        f"`paper-signal` (interior RMS, mean ± 95 % CI over {_seeds_phrase(cells)})",
        "Base preset κ = μ = 12, q = 6, T = 0.21 s (trapezoid rule, paper sec. III.C); each "
        "variant changes one design parameter. The paper's table I predicts: κ = μ or q up → "
        "noise up, bias down; T up → noise down, bias up.",
    )


IDENTIFICATION_SUMMARY = [
    ("‖X̂−X‖/‖X‖ (well excited)", "param_error_norm", 0, "identification"),
    ("τ RMSE joint 1 (N·m)", "torque_rmse.joint1", 0, "identification"),
    ("τ RMSE joint 2 (N·m)", "torque_rmse.joint2", 0, "identification"),
    ("q̇ RMSE (rad/s)", "derivative_rmse", 1, "identification"),
    ("q̈ RMSE (rad/s²)", "derivative_rmse", 2, "identification"),
    ("whole: q̇ RMSE", "whole_derivative_rmse", 1, "identification"),
    ("whole: q̈ RMSE", "whole_derivative_rmse", 2, "identification"),
    ("whole record estimated (q̈)", "whole_coverage", 2, "identification"),
    ("σ_ρ (N·m)", "sigma_rho", 0, "identification"),
    ("cond(W)", "cond_W", 0, "identification"),
    ("equations", "equations", 0, "identification"),
]
DFKI_SUMMARY = [
    ("τ RMSE joint 1 (N·m)", "torque_rmse.joint1", 0, "identification"),
    ("τ RMSE joint 2 (N·m)", "torque_rmse.joint2", 0, "identification"),
    ("lab τ RMSE joint 1", "lab_torque_rmse.joint1", 0, "identification"),
    ("lab τ RMSE joint 2", "lab_torque_rmse.joint2", 0, "identification"),
    ("whole: τ RMSE joint 1", "whole_torque_rmse.joint1", 0, "identification"),
    ("whole: τ RMSE joint 2", "whole_torque_rmse.joint2", 0, "identification"),
    ("whole: lab joint 1", "whole_lab_torque_rmse.joint1", 0, "identification"),
    ("whole: lab joint 2", "whole_lab_torque_rmse.joint2", 0, "identification"),
    ("whole record estimated", "whole_coverage", 0, "identification"),
    ("filtered: τ RMSE joint 1", "filtered_torque_rmse.joint1", 0, "identification"),
    ("filtered: τ RMSE joint 2", "filtered_torque_rmse.joint2", 0, "identification"),
    ("filtered: lab joint 1", "lab_filtered_torque_rmse.joint1", 0, "identification"),
    ("filtered: lab joint 2", "lab_filtered_torque_rmse.joint2", 0, "identification"),
    ("interior estimated", "coverage", 0, "identification"),
    ("cond(W)", "cond_W", 0, "identification"),
]


def identification_table(
    cells: pd.DataFrame, names, truth=None, reference: tuple[str, np.ndarray] | None = None
) -> pd.DataFrame:
    """The paper's table II layout: one row per parameter; per entry the mean over seeds of
    X̂, of its one-sigma σ_X and of %σ_Xr, and (with ``truth``) the relative error in %
    (mean and std over seeds). Column names ``<method> — <setting> X̂`` etc."""
    summary = tables.summarise(cells).set_index([*tables.ENTRY_KEYS, "metric", "region", "order"])
    labelled = tables.label_entries(tables.entries(cells))
    records = []
    for index, name in enumerate(names):
        record = {"parameter": name}
        if truth is not None:
            record["true"] = float(truth[index])
        if reference is not None:
            record[reference[0]] = float(reference[1][index])
        for _, entry in labelled.iterrows():
            head = f"{entry['method']} — {entry['setting']}"

            def get(metric, statistic="mean", entry=entry):
                index = (
                    entry["method"],
                    entry["params"],
                    entry["role"],
                    metric,
                    "identification",
                    0,
                )
                return summary[statistic].get(index, float("nan"))

            record[f"{head} X̂"] = get(f"estimate.{name}")
            record[f"{head} σ"] = get(f"sigma.{name}")
            record[f"{head} %σXr"] = get(f"rel_sigma_pct.{name}")
            if truth is not None:
                record[f"{head} error % mean"] = 100 * get(f"rel_error.{name}")
                record[f"{head} error % std"] = 100 * get(f"rel_error.{name}", "std")
        records.append(record)
    return pd.DataFrame(records)


def identification_shown(table: pd.DataFrame, reference: str | None) -> pd.DataFrame:
    heads = [c[: -len(" X̂")] for c in table.columns if c.endswith(" X̂")]
    shown = pd.DataFrame({"parameter": table["parameter"]})
    if reference and reference in table:
        shown[reference] = [f"{v:.4g}" for v in table[reference]]
    for head in heads:
        texts = []
        for _, row in table.iterrows():
            text = f"{row[f'{head} X̂']:.4g} (σ {row[f'{head} σ']:.2g}, {row[f'{head} %σXr']:.3g} %)"
            if f"{head} error % mean" in table:
                text += (
                    f"; err {row[f'{head} error % mean']:+.2f} ± {row[f'{head} error % std']:.2f} %"
                )
            texts.append(text)
        shown[head] = texts
    return shown


def robot_sim_report(scenario, cells: pd.DataFrame, directory: Path) -> list[Path]:
    """``table2`` (the paper's table II layout with the truth), ``summary`` and fig. 5."""

    table = identification_table(cells, robot2r.PARAMETER_NAMES, scenario.true_parameters)
    written = tables.write_report(
        directory,
        "table2",
        table,
        identification_shown(table, "true"),
        f"Base parameters of `{scenario.name}` identified with each differentiator (IDIM-LS; "
        "the paper's table II layout; means over seeds)",
        "X̂: mean estimate; σ: one standard deviation σ_X from σ_ρ²(WᵀW)⁻¹ (the paper's table "
        "II column 'σ' is about 2σ); %σXr = 100 σ/|X̂|; err: (X̂ − X)/X in %, mean ± std over "
        "seeds. L = 0.5 m.",
    )
    mask = well_excited(scenario)
    excited = ", ".join(n for n, w in zip(robot2r.PARAMETER_NAMES, mask, strict=True) if w)
    wide = tables.wide_table(cells, IDENTIFICATION_SUMMARY)
    written += tables.write_report(
        directory,
        "summary",
        wide,
        tables.display_frame(wide, IDENTIFICATION_SUMMARY),
        f"Identification on `{scenario.name}`: parameter error, torque prediction on a fresh "
        f"trajectory, derivative errors (mean ± 95 % CI over {_seeds_phrase(cells)})",
        "‖X̂−X‖/‖X‖ over the parameters identified to < 10 % relative σ with exact derivatives "
        f"({excited}). q̇, q̈ RMSE: on the samples identified on (the interior); whole: on every "
        "sample the method estimates, ends included (its share of the record for q̈: whole "
        f"record estimated).\n\n{tables.legend(cells)}",
    )
    written += paper.write_figure5(directory, scenario.name)
    return written


def dfki_report(cells: pd.DataFrame, directory: Path, spec) -> list[Path]:
    """``summary`` (held-out measured torque, raw and filtered, beside the lab's model, ranked by
    joint 1), ``settings`` (what nested cross-validation chose on each fold) and ``table2``
    (parameters beside the lab's)."""

    folds = len(spec.records)
    wide = tables.wide_table(cells, DFKI_SUMMARY)
    shown = tables.display_frame(wide, DFKI_SUMMARY)
    nested = wide["variant"] == NESTED_VARIANT
    shown.loc[nested.to_numpy(), "parameters"] = "chosen per fold (settings.md)"
    order = np.argsort(wide["τ RMSE joint 1 (N·m) mean"].to_numpy(), kind="stable")
    names = ", ".join(str(r) for r in spec.records)
    written = tables.write_report(
        directory,
        "summary",
        wide.iloc[order],
        shown.iloc[order],
        f"DFKI double pendulum: measured torque of the held-out run at its logged time stamps, "
        f"predicted by the model identified on the other runs (mean ± 95 % CI over the "
        f"{folds} leave-one-run-out folds whose joint is actuated; best joint 1 first)",
        f"Runs: {names} (open-loop torque excitations; a joint whose commanded torque is zero is "
        "passive and not scored: joint 1 in runs 3 and 4, joint 2 in run 5). τ RMSE: the "
        f"identified model (IDIM-LS, A4 tied to A6 by l1 = {spec.model.values['l1']:g} m and g, "
        "both sides decimated "
        f"alike with F_p = {spec.passband_hz:g} Hz) fed with the method's q, q̇, q̈ at the logged "
        "time stamps, against the measured torque as logged, on the samples "
        f"{spec.interior_margin_s:g} s inside each end; lab: the lab's published model fed with "
        "the same derivatives. whole: the same on every sample of the held-out run the method "
        "estimates (its share: whole record estimated; the ends are where they differ). "
        "filtered: the same after decimating prediction and measurement "
        "alike (the earlier comparison; it hides the noise a differentiator passes on). "
        f"**{NESTED_VARIANT}**: on each fold the setting is chosen among the preset and "
        f"{spec.candidates} Sobol draws of the method's tuning ranges by leave-one-run-out over "
        "the other runs (raw torque), never on the run scored. No velocity score: the recorded "
        "velocity is the backward difference of the recorded positions.\n\n"
        f"{tables.legend(cells)}",
    )
    settings = cells[
        (cells["variant"] == NESTED_VARIANT) & cells["metric"].str.startswith("setting.")
    ]
    rows = []
    inner = cells[cells["metric"] == "inner_raw_torque_rmse"]
    for (method, seed), group in settings.groupby(["method", "seed"], sort=True):
        values = {
            m.removeprefix("setting."): v
            for m, v in zip(group["metric"], group["value"], strict=True)
        }
        loss = inner[(inner["method"] == method) & (inner["seed"] == seed)]["value"]
        rows.append(
            {
                "method": method,
                "held-out run": spec.records[int(seed)],
                "chosen setting": tables.readable_params(
                    method, json.dumps(setting_of(method, values))
                ),
                "inner LORO τ RMSE (N·m)": float(loss.iloc[0]) if len(loss) else float("nan"),
            }
        )
    if rows:
        frame = pd.DataFrame(rows)
        column = "inner LORO τ RMSE (N·m)"
        written += tables.write_report(
            directory,
            "settings",
            frame,
            frame.assign(**{column: [f"{v:.4g}" for v in frame[column]]}),
            "DFKI double pendulum: the setting nested cross-validation chose for each held-out "
            "run (never seeing it), and its pooled raw-torque RMSE over the other runs",
            "Chosen among the method's preset and Sobol draws of its tuning ranges "
            "(bench/studies/robot.py: candidate_settings).",
        )
    identified = parameter_names(spec)
    table = identification_table(cells, identified, reference=("lab", lab_reference(spec)))
    written += tables.write_report(
        directory,
        "table2",
        table,
        identification_shown(table, "lab"),
        "DFKI double pendulum base parameters identified with each differentiator (mean over "
        f"the {folds} leave-one-run-out fits; column 'lab' holds the lab's published model)",
        "X̂ (σ one standard deviation, %σXr); A4 = A6·l1/g (tied); see signals/dfki.py for the "
        "base parameters.",
    )
    return written


ONLINE_COLUMNS = (
    ("delay (ms)", "delay_s", 1e3),
    ("phase delay (ms)", "phase_delay_s", 1e3),
    ("RMSE at the time", "rmse", 1.0),
    ("RMSE delay-compensated", "aligned_rmse", 1.0),
    ("noise gain", "noise_gain", 1.0),
    ("interior estimated", "coverage", 1.0),
)
ONLINE_LEGEND = (
    "**RMSE at the time**: the online estimate at t_k against x⁽ⁿ⁾(t_k) on the interior; "
    "**delay**: the shift of the truth that best matches the estimate (whole steps within "
    f"±{online.MAX_SHIFT_S:g} s, refined by a parabola); **RMSE delay-compensated**: the error "
    f"at that shift; **phase delay** (linear methods): the lag at "
    f"{online.PHASE_FREQUENCY_FRACTION * 100:g} % of Nyquist, from the frequency "
    "response; **noise gain**: RMS of (method on the noisy record − method on the clean "
    "one) / RMS of the noise. A **front** point is one that no other setting of the same "
    "method beats in both delay and delay-compensated RMSE. Means over the seeds."
)


def online_table(cells: pd.DataFrame) -> pd.DataFrame:
    """One row per entry and derivative order (1, 2): the means over seeds of the online
    scores, and ``front`` (on its method's Pareto front of |delay| and compensated RMSE)."""

    summary = tables.summarise(cells)
    labelled = tables.label_entries(tables.entries(cells))
    records = []
    for order in (1, 2):
        mine = summary[summary["order"] == order].set_index([*tables.ENTRY_KEYS, "metric"])
        for _, entry in labelled.iterrows():
            key = (entry["method"], entry["params"], entry["role"])
            record = {
                "method": entry["method"],
                "setting": entry["setting"].removeprefix("variant: "),
                "order": ORDER_SYMBOLS[order],
            }
            for label, metric, scale in ONLINE_COLUMNS:
                row = (*key, metric)
                record[label] = (
                    float(mine.loc[row, "mean"]) * scale if row in mine.index else (float("nan"))
                )
            record["seeds"] = (
                int(mine.loc[(*key, "rmse"), "seeds"]) if (*key, "rmse") in (mine.index) else 0
            )
            records.append(record)
    table = pd.DataFrame(records)
    table["front"] = False
    for _, group in table.groupby(["method", "order"]):
        scored = group.dropna(subset=["delay (ms)", "RMSE delay-compensated"])
        front = pareto_front(scored["delay (ms)"], scored["RMSE delay-compensated"])
        table.loc[scored.index[front], "front"] = True
    return table


def _shown(table: pd.DataFrame, keys: list[str], columns) -> pd.DataFrame:
    """``keys`` as they are, then each of ``columns`` (its label first) to 3 significant
    digits, ``—`` where there is no number."""
    shown = table[keys].copy()
    for label, *_ in columns:
        shown[label] = [f"{v:.3g}" if np.isfinite(v) else "—" for v in table[label]]
    return shown


def _online_shown(table: pd.DataFrame) -> pd.DataFrame:
    return _shown(table, ["method", "setting", "order"], ONLINE_COLUMNS)


def online_report(task: str, description: str, cells: pd.DataFrame, directory: Path) -> list[Path]:
    """``sweep`` (every setting), ``front`` (each method's Pareto front), ``best`` (each
    method's least RMSE at the time) and the error-against-delay figure of an online task."""

    table = online_table(cells)
    seeds = _seeds_phrase(cells)
    written = tables.write_report(
        directory,
        "sweep",
        table,
        _online_shown(table),
        f"`{task}`: every setting of each causal method (means over {seeds})",
        f"{description}\n\n{ONLINE_LEGEND}",
    )
    front = table[table["front"]].sort_values(["order", "method", "delay (ms)"])
    written += tables.write_report(
        directory,
        "front",
        front,
        _online_shown(front),
        f"`{task}`: the error-against-delay front of each causal method (means over {seeds})",
        ONLINE_LEGEND,
    )
    scored = table.dropna(subset=["RMSE at the time"])
    best = scored.loc[scored.groupby(["order", "method"])["RMSE at the time"].idxmin()]
    best = best.sort_values(["order", "RMSE at the time"])
    written += tables.write_report(
        directory,
        "best",
        best,
        _online_shown(best),
        f"`{task}`: each causal method at its setting of least error at the time of the "
        f"estimate (means over {seeds})",
        "The online choice: a controller acts on the estimate when it is made, so its error "
        f"then is what counts. {ONLINE_LEGEND}",
    )
    written.append(
        write_online_figure(
            table, directory / "error_vs_delay.png", f"`{task}`: error against delay ({seeds})"
        )
    )
    return written


LOOP_COLUMNS = (
    ("q₁ tracking RMSE (rad)", "tracking_rmse", 1),
    ("q₂ tracking RMSE (rad)", "tracking_rmse", 2),
    ("q₁ tracking / exact", "tracking_ratio", 1),
    ("q₂ tracking / exact", "tracking_ratio", 2),
    ("τ₁ noise (N·m)", "torque_noise_rms", 1),
    ("τ₂ noise (N·m)", "torque_noise_rms", 2),
)
LOOP_TRACKING_MARGIN = 0.1
"""A loop's best setting tracks within this fraction of the exact controller on both joints."""
LOOP_LEGEND = (
    f"**tracking RMSE**: q − q_d after the first {loop.LoopSpec.settle_s:g} s; **/ exact**: "
    "over the same controller fed the exact q̇ (same encoder readings); **τ noise**: RMS of "
    "the torque less that controller's. **loop**: stable on every seed, or lost (tracking "
    f"error past {loop.LoopSpec.lost_rad:g} rad) on k of n seeds at the times given; the scores "
    "of a lost loop are left out. **best**: per method, the setting stable on every seed "
    f"whose tracking is within {LOOP_TRACKING_MARGIN * 100:g} % of the exact controller's on both "
    "joints, of least τ₁ noise."
)


def loop_table(cells: pd.DataFrame) -> pd.DataFrame:
    """One row per entry: stability over the seeds and the means of the loop scores."""
    summary = tables.summarise(cells).set_index([*tables.ENTRY_KEYS, "metric", "order"])
    labelled = tables.label_entries(tables.entries(cells))
    records = []
    for _, entry in labelled.iterrows():
        key = (entry["method"], entry["params"], entry["role"])
        mine = cells[
            (cells["method"] == key[0]) & (cells["params"] == key[1]) & (cells["role"] == key[2])
        ]
        stable = mine[(mine["metric"] == "stable") & (mine["order"] == 1)]
        lost = mine[(mine["metric"] == "lost_at_s") & (mine["order"] == 1)]["value"].dropna()
        record = {
            "method": entry["method"],
            "setting": entry["setting"].removeprefix("variant: "),
            "seeds": len(stable),
        }
        if lost.empty:
            record["loop"] = "stable"
        else:
            times = ", ".join(f"{v:.2f}" for v in sorted(lost))
            record["loop"] = f"lost on {len(lost)} of {len(stable)} seeds (at {times} s)"
        for label, metric, joint in LOOP_COLUMNS:
            row = (*key, metric, joint)
            record[label] = float(summary.loc[row, "mean"]) if row in summary.index else np.nan
        records.append(record)
    return pd.DataFrame(records)


def _loop_shown(table: pd.DataFrame) -> pd.DataFrame:
    return _shown(table, ["method", "setting", "loop"], LOOP_COLUMNS)


def loop_report(task: str, description: str, cells: pd.DataFrame, directory: Path) -> list[Path]:
    """``loop`` (every setting, stable or not) and ``loop_best`` (each method's best stable
    setting, or why it has none) of the in-the-loop task."""
    table = loop_table(cells)
    seeds = _seeds_phrase(cells)
    written = tables.write_report(
        directory,
        "loop",
        table,
        _loop_shown(table),
        f"`{task}`: every setting of each causal method in the loop ({seeds})",
        f"{description}\n\n{LOOP_LEGEND}",
    )
    best = []
    for name, group in table.groupby("method", sort=True):
        limit = 1 + LOOP_TRACKING_MARGIN
        usable = group[
            (group["loop"] == "stable")
            & (group["q₁ tracking / exact"] <= limit)
            & (group["q₂ tracking / exact"] <= limit)
        ]
        if len(usable):
            best.append(usable.loc[usable["τ₁ noise (N·m)"].idxmin()])
        else:
            stable = int((group["loop"] == "stable").sum())
            best.append(
                pd.Series(
                    {
                        "method": name,
                        "setting": "—",
                        "seeds": group["seeds"].max(),
                        "loop": f"no usable setting: {stable} of {len(group)} "
                        "settings stable, none tracking within "
                        f"{LOOP_TRACKING_MARGIN * 100:g} %"
                        if stable
                        else f"unstable at all {len(group)} settings",
                    }
                )
            )
    best = pd.DataFrame(best).sort_values("τ₁ noise (N·m)", na_position="last")
    written += tables.write_report(
        directory,
        "loop_best",
        best,
        _loop_shown(best),
        f"`{task}`: each causal method at its best setting in the loop ({seeds})",
        LOOP_LEGEND,
    )
    return written
