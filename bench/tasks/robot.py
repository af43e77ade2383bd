"""Robot tasks: the simulated 2R robot's identification and the DFKI recordings' hold-out."""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from diffbench.bench.core.plan import Entry
from diffbench.bench.core.roles import Role
from diffbench.bench.studies import reports
from diffbench.bench.studies.robot import (
    NESTED_VARIANT,
    DfkiCrossValidation,
    dfki_record,
    score_dfki_fold,
    score_identification,
)
from diffbench.bench.tasks.base import ScenarioTask, Task
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
        return reports.robot_sim_report(self.scenario, cells, directory)


@dataclass(frozen=True, eq=False)
class DfkiTask(Task):
    """Real recordings of the DFKI double pendulum: leave-one-run-out identification (a cell's
    seed is the held-out run), scored by the measured torque of the held-out run at its logged
    time stamps; each method at its preset and at the settings nested cross-validation
    chooses (:class:`diffbench.bench.studies.robot.DfkiCrossValidation`). ``robot_model``: the
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
        return reports.dfki_report(cells, directory, self.spec)
