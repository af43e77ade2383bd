"""Robot tasks: the simulated 2R robot's identification and the DFKI recordings' hold-out."""

from __future__ import annotations

import functools
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pandas as pd

from diffbench.bench.core.plan import Entry
from diffbench.bench.core.roles import Role
from diffbench.bench.report import tables
from diffbench.bench.studies import paper
from diffbench.bench.studies.dfki import (
    NESTED_VARIANT,
    DfkiCrossValidation,
    dfki_record,
    lab_reference,
    parameter_names,
    score_dfki_fold,
    setting_of,
)
from diffbench.bench.studies.robot import score_identification, well_excited
from diffbench.bench.tasks.base import ScenarioTask, Task
from diffbench.signals import robot2r
from diffbench.signals.dfki import load_pendulum_model, packaged_model


@dataclass(frozen=True, eq=False)
class RobotSimTask(ScenarioTask):
    """A simulated 2R identification (``signals.robot2r``): each method's q̇, q̈ feed IDIM-LS;
    scored by parameter error (the truth is known), torque prediction on a fresh trajectory
    and derivative errors."""

    scenario: object
    listed: bool = True
    kind: ClassVar[str] = "robot (simulated)"

    def score(self, method, seed):
        return score_identification(method, self.scenario, seed)

    def longest_record(self):
        realisation = self.scenario.realise(0)
        return realisation.q.shape[0], realisation.dt_s

    def report(self, cells, tunings, directory):
        return robot_sim_report(self.scenario, cells, directory)


@dataclass(frozen=True, eq=False)
class DfkiTask(Task):
    """Real recordings of the DFKI double pendulum: leave-one-run-out identification (a cell's
    seed is the held-out run), scored by the measured torque of the held-out run at its logged
    time stamps; each method at its preset and at the settings nested cross-validation
    chooses (:class:`diffbench.bench.studies.dfki.DfkiCrossValidation`). ``robot_model``: the
    records' robot (:class:`diffbench.signals.dfki.PendulumModel`), None for the packaged
    design C.0 one."""

    records: tuple | None = None
    listed: bool = True
    kind: ClassVar[str] = "robot (real)"
    robot_model: object = None

    @functools.cached_property
    def spec(self):
        model = load_pendulum_model(self.robot_model)
        if self.records is None:
            return DfkiCrossValidation(model=model)
        return DfkiCrossValidation(records=tuple(self.records), model=model)

    @property
    def default_seeds(self) -> int:  # type: ignore[override]
        return len(self.spec.records)

    @property
    def max_seeds(self) -> int:  # type: ignore[override]
        return len(self.spec.records)

    @functools.cached_property
    def name(self) -> str:
        """``identify-dfki`` on the packaged runs with the packaged model; with other records or
        another model, that name and a digest of the records' contents and of the model's
        parameters when they are not the packaged model's (the store never mixes cells of
        different data or models under one name; records with the packaged model keep the
        digest they always had)."""
        model = self.spec.model
        if self.records is None and model == packaged_model():
            return self.spec.name
        digest = hashlib.sha256()
        for source in self.spec.records:
            record = dfki_record(source)
            for array in (record.t, record.q, record.tau, record.tau_commanded):
                digest.update(np.ascontiguousarray(array).tobytes())
        if model != packaged_model():
            digest.update(b"robot model")
            digest.update(np.array(model.identity, dtype=np.float64).tobytes())
        return f"{self.spec.name}-{digest.hexdigest()[:10]}"

    @property
    def description(self) -> str:
        return self.spec.description

    @property
    def preset(self) -> str:
        return self.spec.preset

    def lineup(self, method_names=None):
        entries = []
        for entry in super().lineup(method_names):
            entries.append(entry)
            nested = Role(
                origin="variant", preset=entry.role.preset, by=entry.role.by, variant=NESTED_VARIANT
            )
            entries.append(Entry(entry.method, entry.params, nested))
        return entries

    def score(self, method, seed):
        return score_dfki_fold(method, self.spec, seed)

    def score_cell(self, method, seed, role):
        if role.variant != NESTED_VARIANT:
            return self.score(method, seed)
        return score_dfki_fold(method, self.spec, seed, nested=True)

    def longest_record(self):
        records = [dfki_record(source) for source in self.spec.records]
        return max(r.t.size for r in records), self.spec.nominal_dt_s

    def report(self, cells, tunings, directory):
        return dfki_report(cells, directory, self.spec)


# --- the report ------------------------------------------------------------------------------


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
        f"trajectory, derivative errors (mean ± 95 % CI over {tables.seeds_phrase(cells)})",
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
            "(bench/studies/dfki.py: candidate_settings).",
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


def builtin_tasks() -> list:
    """A task per simulated robot scenario and the DFKI identification on its packaged
    records."""
    simulated = [
        RobotSimTask(robot2r.get_robot_scenario(name))
        for name in robot2r.available_robot_scenarios()
    ]
    return [*simulated, DfkiTask()]
