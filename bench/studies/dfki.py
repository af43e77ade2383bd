"""The real robot: the DFKI double pendulum's recordings, identified with each differentiator
in a nested leave-one-run-out cross-validation over its runs (the settings chosen on the inner
folds, the torques predicted on the held-out run), against the lab's published model."""

from __future__ import annotations

import functools
import math
import numbers
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from diffbench import methods
from diffbench.bench.core import search_space
from diffbench.bench.studies.identification import (
    Identification,
    decimation_factor,
    idim_ls,
    parallel_decimation,
)
from diffbench.bench.studies.robot import (
    EDGE_SAMPLES,
    add_row,
    estimated_samples,
    parameter_rows,
    valid_stretch,
)
from diffbench.methods import Method
from diffbench.signals import dfki
from diffbench.signals.dfki import DFKI_RUNS, PACKAGED_DESIGN, PendulumModel, packaged_model


@dataclass(frozen=True)
class DfkiCrossValidation:
    """Identification on real recordings, scored on the measured torque of unseen runs.

    A cell's "seed" is the held-out run k. Each method gives q (smoothed), q̇, q̈ at the logged
    time stamps of every run (``method(q, nominal_dt_s, t=t)``: natively or through its
    resampling path), on the samples ``interior_margin_s`` inside each end. The base parameters
    are identified by IDIM-LS (both sides of W X = Y decimated alike, F_p = ``passband_hz``:
    Gautier's parallel filtering) on every run but k, with A4 tied to A6 by the robot model's
    l1 and g (``tie_a4``); the identified model then predicts the torque of run k at its logged time
    stamps, and is scored by the RMSE against the **measured torque as logged** (raw), per
    actuated joint (a joint whose commanded torque is identically zero is passive: its measured
    torque is only the driver's noise), on the interior and (``whole_``) on every sample the
    method estimates, ends included. The same prediction and measurement decimated alike are
    a second, labelled score (filtered), as is the lab's published model fed with the same
    derivatives (``lab``: the torques of ``model``).

    ``model`` is the robot the records come from (:class:`diffbench.signals.dfki.PendulumModel`:
    the lab's ``model_parameters.yml`` of its design; default the packaged design C.0 one): it
    gives l1 and g of the tie and the lab model's torques and base parameters. Records of
    another design need that design's model; :func:`check_model_matches` refuses records that
    evidently are not of the model's robot.

    Settings (the ``nested`` variant): every setting in :func:`candidate_settings` (the given
    one and ``candidates`` Sobol points of the method's tuning ranges) is scored by
    leave-one-run-out over the runs other than k (identify on the rest, predict the left-out
    run's raw torque; pooled RMSE over their actuated joints), and the best is used for run k:
    run k never chooses its own settings. Records: packaged runs (numbers) or CSV paths of
    the lab's layout (:func:`diffbench.signals.dfki.read_dfki_record`).
    """

    name: str = "identify-dfki"
    description: str = (
        "DFKI double pendulum (real 2R, vertical plane, open-loop torque excitations): identify "
        "on the other runs, predict the measured torque of the held-out run at its logged time "
        "stamps (leave-one-run-out; settings also chosen by nested cross-validation)."
    )
    preset: str = "robot"
    records: tuple = tuple(range(DFKI_RUNS))
    nominal_dt_s: float = 0.002
    passband_hz: float = 5.0
    interior_margin_s: float = 0.6
    candidates: int = 32
    tie_a4: bool = True
    min_coverage: float = 0.9
    model: PendulumModel = field(default_factory=packaged_model)

    def __post_init__(self) -> None:
        """A path or mapping given as ``model`` is read once
        (:func:`diffbench.signals.dfki.load_pendulum_model`)."""
        if not isinstance(self.model, PendulumModel):
            object.__setattr__(self, "model", dfki.load_pendulum_model(self.model))


NESTED_VARIANT = "settings by nested leave-one-run-out CV"
"""The role variant of a cell whose settings the runs other than the held-out one choose."""


@dataclass(frozen=True)
class _TorqueSums:
    """Per joint, the sums over a set of raw samples that give the squared torque error of any
    parameter vector X (so that every fold's score costs no pass over the samples)."""

    gram: np.ndarray  # (joints, p, p): W_jᵀ W_j
    cross: np.ndarray  # (joints, p): W_jᵀ y_j
    energy: np.ndarray  # (joints,): y_jᵀ y_j
    samples: int
    lab_sse: np.ndarray  # (joints,) the lab model's squared error on the same samples
    coverage: float  # the share of the region's samples these are

    @classmethod
    def of(cls, w, y, lab_torque, coverage: float) -> _TorqueSums:
        return cls(
            gram=np.einsum("njp,njq->jpq", w, w),
            cross=np.einsum("njp,nj->jp", w, y),
            energy=np.einsum("nj,nj->j", y, y),
            samples=int(y.shape[0]),
            lab_sse=np.sum((lab_torque - y) ** 2, axis=0),
            coverage=float(coverage),
        )

    def sse(self, estimate: np.ndarray) -> np.ndarray:
        """:math:`\\sum (y - W X)^2` per joint, from the stored sums."""
        quadratic = np.einsum("p,jpq,q->j", estimate, self.gram, estimate)
        return self.energy - 2 * self.cross @ estimate + quadratic


@dataclass(frozen=True)
class _RunEquations:
    """What a fold needs of one run at one setting: the decimated equations of the interior
    (training and the filtered score), the raw torque sums of the interior (``inside``) and of
    every sample the method estimates (``whole``)."""

    train_w: np.ndarray  # (m, joints, p), decimated, edges dropped
    train_y: np.ndarray  # (m, joints)
    lab_filtered: np.ndarray  # (m, joints) the lab model's torque, decimated like train_y
    inside: _TorqueSums
    whole: _TorqueSums
    active: np.ndarray  # (joints,) bool


@functools.lru_cache(maxsize=16)
def dfki_record(source):

    return dfki.read_dfki_record(source)


def _torque_model(record, estimate, where: np.ndarray, spec: DfkiCrossValidation):
    """W, measured y and the lab's torque on the samples ``where``."""

    q, qd, qdd = (estimate[order][where] for order in (0, 1, 2))
    w = dfki.pendulum_regressor(q, qd, qdd)
    if spec.tie_a4:
        w = spec.model.tie(w)
    return w, record.tau[where], spec.model.torques(q, qd, qdd)


@functools.lru_cache(maxsize=512)
def _run_equations(method: Method, index: int, spec: DfkiCrossValidation) -> _RunEquations:
    """The equations of run ``spec.records[index]`` with q, q̇, q̈ from ``method``; ValueError
    when the method estimates less than ``min_coverage`` of the run's interior."""
    record = dfki_record(spec.records[index])
    t = record.t
    interior = (t >= t[0] + spec.interior_margin_s) & (t <= t[-1] - spec.interior_margin_s)
    estimate = method(record.q, spec.nominal_dt_s, t=t)
    estimated = estimated_samples(estimate)
    chosen = valid_stretch(method, estimate, interior)
    coverage = (chosen.stop - chosen.start) / int(interior.sum())
    if not estimated[chosen].all() or coverage < spec.min_coverage:
        raise ValueError(
            f"`method` {method.name!r} estimates {coverage:.0%} of {record.name}'s interior in "
            f"one stretch; at least {spec.min_coverage:.0%} is needed"
        )
    # the model on every estimated sample once; the stretch is a part of them
    whole = _torque_model(record, estimate, estimated, spec)
    kept = np.flatnonzero(estimated)
    inside = (kept >= chosen.start) & (kept < chosen.stop)
    w, y, lab_torque = (array[inside] for array in whole)
    factor = decimation_factor(1 / spec.nominal_dt_s, spec.passband_hz)
    edges = slice(EDGE_SAMPLES, -EDGE_SAMPLES)
    return _RunEquations(
        train_w=parallel_decimation(w, factor)[edges],
        train_y=parallel_decimation(y, factor)[edges],
        lab_filtered=parallel_decimation(lab_torque, factor)[edges],
        inside=_TorqueSums.of(w, y, lab_torque, coverage),
        whole=_TorqueSums.of(*whole, coverage=estimated.mean()),
        active=record.active_joints,
    )


def parameter_names(spec: DfkiCrossValidation) -> tuple[str, ...]:
    """The base parameters identified: nine with A4 tied to A6, else ten."""

    return dfki.TIED_PARAMETER_NAMES if spec.tie_a4 else dfki.PENDULUM_PARAMETER_NAMES


def lab_reference(spec: DfkiCrossValidation) -> np.ndarray:
    """The base parameters of the records' robot model (``spec.model``), in the order of
    :func:`parameter_names` (A4 left out when tied): the "lab" column of the parameter table."""

    full = dict(zip(dfki.PENDULUM_PARAMETER_NAMES, spec.model.base_parameters(), strict=True))
    return np.array([full[name] for name in parameter_names(spec)])


MISMATCH_RATIO = 4.0
"""A record on which the robot model's torque RMSE exceeds 4 times that of the same equations
fitted to the record (:func:`model_error_ratio`) is refused as not of that robot."""


def model_error_ratio(record, model: PendulumModel, spec: DfkiCrossValidation) -> float | None:
    """How much worse the robot model predicts a record's measured torque than its own
    equations can: :math:`\\rho = \\mathrm{RMSE}(\\tau_{model} - \\tau) /
    \\min_X \\mathrm{RMSE}(D X - \\tau)`.

    Both over the actuated joints (:attr:`DfkiRecord.active_joints`) on the samples
    ``spec.interior_margin_s`` inside each end, with q, q̇, q̈ from Savitzky–Golay (``robot``
    preset) at the logged time stamps; :math:`\\tau_{model}` the model's torques, :math:`D` the
    10-column base-parameter regressor (:func:`diffbench.signals.dfki.pendulum_regressor`, its
    rows of the actuated joints; least squares, minimum norm where a passive joint leaves
    columns empty). The fit is the least error any parameters of this robot family reach on
    the record (the measurement noise and what the equations do not model), so
    :math:`\\rho \\ge 1` and :math:`\\rho` near 1 means the model's parameters fit the record.
    None when it cannot be computed (no actuated joint, no estimated sample inside, the method
    refuses the record): the run itself then says what is wrong.

    Measured (tests/bench/test_identification.py): the packaged model on the six packaged runs,
    1.16-2.66; the lab's design A.0 model (l1 = 0.3 m) on them, 5.1-16.8 on five runs and 1.36
    on run 4 (joint 2 alone, where the designs differ least); the lab's design C.1 model_3.0 on
    them, 2.5-6.9; the packaged model on a simulated design-A.0 robot with 0.02 N·m torque
    noise, about 33."""

    method = methods.preset("savitzky_golay", "robot")
    t = record.t
    interior = (t >= t[0] + spec.interior_margin_s) & (t <= t[-1] - spec.interior_margin_s)
    active = record.active_joints
    try:
        estimate = method(record.q, spec.nominal_dt_s, t=t)
    except ValueError:
        return None
    where = interior & estimated_samples(estimate)
    if not active.any() or not where.any():
        return None
    q, qd, qdd = (estimate[order][where] for order in (0, 1, 2))
    measured = record.tau[where][:, active]
    model_rmse = math.sqrt(np.mean((model.torques(q, qd, qdd)[:, active] - measured) ** 2))
    w = dfki.pendulum_regressor(q, qd, qdd)[:, active, :].reshape(-1, 10)
    fitted, *_ = np.linalg.lstsq(w, measured.reshape(-1), rcond=None)
    fit_rmse = math.sqrt(np.mean((w @ fitted - measured.reshape(-1)) ** 2))
    if fit_rmse == 0:
        return 1.0 if model_rmse == 0 else math.inf
    return model_rmse / fit_rmse


def _design_of(source) -> str | None:
    """The lab design a record is of: C.0 for a packaged run, else what its path names."""

    if isinstance(source, numbers.Integral) and not isinstance(source, (bool, np.bool_)):
        return PACKAGED_DESIGN
    return dfki.design_of_path(source)


FIX = "give the lab's model_parameters.yml of the records' design as the robot model"
"""The fix every refusal of :func:`check_model_matches` names."""


def check_model_matches(spec: DfkiCrossValidation) -> None:
    """Refuse records that evidently are not of ``spec.model``'s robot (one-line ValueError
    naming the record and the fix). The rule, in this order:

    1. Design by path: the lab's repository keeps each design's records under
       ``design_<name>/`` and its models under ``identified_parameters/design_<name>/``
       (:func:`diffbench.signals.dfki.design_of_path`; the packaged runs and model are design
       C.0). A record whose path names a design other than the model's is refused; with a
       model of unknown design (a mapping, a file outside such a folder), records naming
       different designs are refused (one model describes one robot).
    2. Torque by data: a record whose measured torque the model predicts more than
       ``MISMATCH_RATIO`` = 4 times worse (RMSE) than the same equations fitted to the record
       (:func:`model_error_ratio`) is refused, whatever its path. The right model reaches
       1.16-2.66 on the packaged runs, so 4 leaves a margin of 1.5 over the worst legitimate
       record seen; the lab's design A.0 model exceeds it on five of the six.

    A model that passes may still be imperfect: the rule stops evident mismatches only (a
    design's model on a record of another design with little excitation can pass, which is
    why the path's design is checked first).
    """
    model = spec.model
    named = {}
    for source in spec.records:
        design = _design_of(source)
        if design is None:
            continue
        if model.design is not None and design != model.design:
            packaged = isinstance(source, numbers.Integral)
            why = "a packaged run" if packaged else "its path says so"
            raise ValueError(
                f"{dfki_record(source).name} is a record of design {design} ({why}) but the "
                f"robot model is {model.label}: {FIX} (the lab's identified_parameters/"
                f"design_{design}/model_*/model_parameters.yml; CLI --robot-model FILE, API "
                "robot_model=)"
            )
        named.setdefault(design, dfki_record(source).name)
    if len(named) > 1:
        designs = " and ".join(f"{design} ({source})" for design, source in named.items())
        raise ValueError(
            f"the records are of designs {designs} (their paths say so) and one robot model "
            "describes one design: identify each design's records apart, each with its model"
        )
    for source in spec.records:
        record = dfki_record(source)
        ratio = model_error_ratio(record, model, spec)
        if ratio is not None and ratio > MISMATCH_RATIO:
            raise ValueError(
                f"{record.name}: the robot model ({model.label}) predicts its measured torque "
                f"{ratio:.3g} times worse (RMSE) than the same equations fitted to it (more than "
                f"{MISMATCH_RATIO:g}: not that robot's record): {FIX} (CLI --robot-model FILE, "
                "API robot_model=)"
            )


def _identify_on(equations: list[_RunEquations], spec: DfkiCrossValidation) -> Identification:
    return idim_ls(
        np.concatenate([e.train_w for e in equations]),
        np.concatenate([e.train_y for e in equations]),
        parameter_names(spec),
    )


def inner_loss(method: Method, spec: DfkiCrossValidation, held_out: int) -> float:
    """Pooled raw-torque RMSE of ``method`` by leave-one-run-out over the runs other than
    ``held_out`` (identify on the others, predict the one left out; actuated joints only);
    +inf when the method refuses a run or identification fails."""
    runs = [index for index in range(len(spec.records)) if index != held_out]
    try:
        equations = {index: _run_equations(method, index, spec) for index in runs}
        squared, count = 0.0, 0
        for left_out in runs:
            fit = _identify_on([equations[i] for i in runs if i != left_out], spec)
            scored = equations[left_out]
            squared += float(np.sum(scored.inside.sse(fit.estimate)[scored.active]))
            count += scored.inside.samples * int(scored.active.sum())
    except ValueError:
        return math.inf
    return math.sqrt(squared / count)


def candidate_settings(method: Method, spec: DfkiCrossValidation) -> list[Method]:
    """``method`` itself, then ``spec.candidates`` settings drawn by a scrambled Sobol sequence
    (seed 0) over its tuning ranges (:func:`~diffbench.bench.core.search_space.search_space`:
    log scale where declared, choices and small integer ranges value by value, windows
    snapped to the step), the parameters not searched kept at ``method``'s values; settings
    the method refuses are left out. The same list for every fold."""
    from scipy.stats import qmc

    record = dfki_record(spec.records[0])
    dimensions = search_space.search_space(method.name, spec.nominal_dt_s, record.t.size)
    settings = [method]
    if not dimensions or spec.candidates < 1:
        return settings
    power = math.ceil(math.log2(spec.candidates))  # Sobol points come in powers of two
    sobol = qmc.Sobol(len(dimensions), scramble=True, seed=0)
    points = sobol.random_base2(power)[: spec.candidates]
    cls = type(method)
    base = method.params()
    seen = {tuple(sorted(base.items()))}
    for point in points:
        params = dict(base)
        for dimension, u in zip(dimensions, point, strict=True):
            if dimension.kind == "choice":
                params[dimension.name] = dimension.choices[
                    min(int(u * len(dimension.choices)), len(dimension.choices) - 1)
                ]
            else:
                low, high = dimension.bounds()
                params[dimension.name] = dimension.value(low + u * (high - low))
        params = search_space.snap(params, spec.nominal_dt_s, methods.params_of(cls))
        key = tuple(sorted(params.items()))
        if key in seen:
            continue
        seen.add(key)
        try:
            candidate = cls(**params)
            candidate.check_step(spec.nominal_dt_s)
        except ValueError:
            continue
        settings.append(candidate)
    return settings


def choose_setting(method: Method, spec: DfkiCrossValidation, held_out: int):
    """The candidate (:func:`candidate_settings`) with the least :func:`inner_loss` for
    ``held_out``, and that loss (the first on a tie)."""
    best, best_loss = method, math.inf
    for candidate in candidate_settings(method, spec):
        loss = inner_loss(candidate, spec, held_out)
        if loss < best_loss:
            best, best_loss = candidate, loss
    if not math.isfinite(best_loss):
        raise ValueError(f"no setting of {method.name!r} identifies on the runs but {held_out}")
    return best, best_loss


def _setting_rows(method: Method) -> list[dict[str, Any]]:
    """The chosen setting as rows ``setting.<name>``: numbers as they are, a choice that is
    not a number as its index in the parameter's choices."""

    rows: list[dict[str, Any]] = []
    for spec in methods.params_of(type(method)):
        value = getattr(method, spec.name)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            value = list(spec.choices).index(value)
        add_row(rows, f"setting.{spec.name}", value)
    return rows


def setting_of(name: str, values: dict[str, float]) -> dict[str, Any]:
    """The parameters back from :func:`_setting_rows`' values (``setting.<name>`` stripped);
    a parameter the method gained after the rows were stored at its default (a parameter is
    added with a default that keeps the earlier estimates)."""

    params = {}
    for spec in methods.params_of(methods.method_class(name)):
        if spec.name not in values:
            params[spec.name] = spec.default
            continue
        value = values[spec.name]
        if spec.choices is not None and not all(
            isinstance(c, (int, float)) and not isinstance(c, bool) for c in spec.choices
        ):
            value = spec.choices[round(value)]
        elif spec.integer:
            value = round(value)
        params[spec.name] = value
    return params


def score_dfki_fold(
    method: Method, spec: DfkiCrossValidation, held_out: int, nested: bool = False
) -> list[dict[str, Any]]:
    """Rows of one leave-one-run-out fold (region ``identification``): ``method`` as given,
    or (``nested``) at the setting the other runs choose (:func:`choose_setting`)."""
    runs = len(spec.records)
    if not 0 <= held_out < runs:
        raise ValueError(f"the held-out run (seed) must be in 0..{runs - 1}, got {held_out}")
    rows: list[dict[str, Any]] = []
    if nested:
        method, loss = choose_setting(method, spec, held_out)
        rows += _setting_rows(method)
        add_row(rows, "inner_raw_torque_rmse", loss)
    training = [_run_equations(method, i, spec) for i in range(runs) if i != held_out]
    result = _identify_on(training, spec)
    scored = _run_equations(method, held_out, spec)
    rows += parameter_rows(result)
    add = functools.partial(add_row, rows)
    filtered = np.einsum("mjp,p->mj", scored.train_w, result.estimate) - scored.train_y
    lab_filtered = scored.lab_filtered - scored.train_y
    for joint in (0, 1):
        if not scored.active[joint]:
            continue
        name = f"joint{joint + 1}"
        for prefix, sums in (("", scored.inside), ("whole_", scored.whole)):
            sse = max(float(sums.sse(result.estimate)[joint]), 0.0)
            add(f"{prefix}torque_rmse.{name}", math.sqrt(sse / sums.samples))
            add(f"{prefix}lab_torque_rmse.{name}", math.sqrt(sums.lab_sse[joint] / sums.samples))
        add(f"filtered_torque_rmse.{name}", np.sqrt(np.mean(filtered[:, joint] ** 2)))
        add(f"lab_filtered_torque_rmse.{name}", np.sqrt(np.mean(lab_filtered[:, joint] ** 2)))
    add("coverage", scored.inside.coverage)
    add("whole_coverage", scored.whole.coverage)
    return rows
