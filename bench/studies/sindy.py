"""SINDy discovery: which differentiator lets sparse regression find the right equations.

Each system of :mod:`diffbench.signals.dynamics` is measured at a noise level (a fraction of
each state's standard deviation), from one initial condition or from several sharing one
trajectory's duration (:data:`STARTS`), and given to pysindy's SINDy with the
system's polynomial library and sequentially thresholded least squares (STLSQ at the
system's stated threshold, without ridge: :func:`_optimizer`), so that only the derivative
changes from one entry to the next:

* ``truth``: what a perfect differentiator gives, the exact ẋ and the clean states the
  library is evaluated on (the reference: SINDy recovers the equations to rounding);
* ``oracle``: a diffbench method (or a wrapped peer) tuned by the truth for ẋ on a noise seed
  never scored, the loss the mean ẋ RMSE over the states on the middle of the record
  (:data:`INTERIOR_MARGIN` left out at each end), its trusted ẋ and smoothed states given to
  SINDy, the library evaluated on the latter, the samples it does not trust left out (the
  model pysindy fits with :class:`diffbench.methods.for_pysindy.Differentiation`, which marks
  them NaN for pysindy to leave out);
* ``recommend``: the same at the setting ``diffbench recommend`` chooses for each state from
  the measurement of that tuning seed alone (no truth; :func:`recommended_params`);
* ``preset``: the same at the method's :data:`PRESET` (its windows snapped to the step);
* ``pysindy``: pysindy's own differentiation, ``FiniteDifference`` (SINDy's default) and
  ``SmoothedFiniteDifference`` at their defaults, and derivative's methods through
  ``SINDyDerivative`` at the settings of derivative's README (:data:`DERIVATIVE_README`);
* ``weak form``: the weak (integral) form of SINDy, ``WeakPDELibrary`` over time, which
  needs no pointwise derivative: the anchor a differentiator must beat. At its defaults, and
  with its number of test functions K chosen by the truth on the tuning seed
  (:func:`weak_form_params`); its random subdomains drawn with the measurement's seed.

Scores per seed (:func:`entry_rows`): the coefficient error
:math:`\\|\\hat\\Xi - \\Xi\\|_F / \\|\\Xi\\|_F` over the library; the support's precision,
recall and whether it is exact; and the discovered model simulated from the system's held-out
initial conditions over its horizon, its error the RMS over time and states of
:math:`(\\hat x_i - x_i)/\\sigma_i` (σ_i the state's spread over the measured trajectory), or
the time it diverged (left :data:`BLOWUP` times the true trajectory's largest magnitude, or the
integration failed).

References
----------
S. L. Brunton, J. L. Proctor, J. N. Kutz, PNAS 113 (2016) 3932-3937 (SINDy, STLSQ);
D. A. Messenger, D. M. Bortz, "Weak SINDy: Galerkin-based data-driven model selection",
Multiscale Model. Simul. 19 (2021) 1474-1497; B. M. de Silva et al., JOSS 5 (2020) 2104 and
A. A. Kaptanoglu et al., JOSS 7 (2022) 3994 (pysindy).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from diffbench import methods
from diffbench.bench.core import search_space, tuning
from diffbench.bench.studies import recommend as advice
from diffbench.signals.dynamics import Measurement, PolynomialSystem, get_system

ORDER = 1
"""SINDy regresses ẋ."""

NOISE_LEVELS = (0.001, 0.01, 0.05, 0.1)
"""Noise levels, fractions of each state's standard deviation over the measured trajectory."""

STEPS = (1, 5)
"""The sampling steps, in multiples of each system's own (every sample of the trajectory, or
every fifth)."""

STARTS = (1, 3)
"""The numbers of trajectories (initial conditions) a record holds, each over the system's
duration divided by their number: one long trajectory, or three a third as long, which SINDy
fits together (the usual remedy for a library a single trajectory leaves ill-conditioned)."""

INTERIOR_MARGIN = 0.05
"""The share of the record left out at each end of the oracle's tuning loss."""

BLOWUP = 100.0
"""A simulated model has diverged once a state leaves this many times the true trajectory's
largest magnitude."""

MAX_RHS_CALLS = 200_000
"""A simulation that needs more evaluations of the discovered model (a stiff or exploding
model) is stopped and counted as diverged at the time it reached."""

SIMULATION_TOLERANCE = 1e-9
"""Relative and absolute tolerance of the held-out simulations (DOP853)."""

DERIVATIVE_README: dict[str, dict[str, Any]] = {
    "finite_difference": {"k": 1},
    "savitzky_golay": {"left": 0.5, "right": 0.5, "order": 3},
    "spectral": {},
}
"""derivative's methods at the settings its README shows them with (derivative 0.6), given to
SINDy through pysindy's ``SINDyDerivative``. Left out for their cost on these records (a
state of Lorenz, 5001 samples, one call): ``trend_filtered`` (45 s), ``kalman`` (17 s),
``spline`` at its README's ``s = 1e-2`` (4 s: FITPACK's smoothing spline all but
interpolating the noise, half of this study's time at 14de891) and ``kernel`` (dense in the
record's length)."""

PRESET = "paper-signal"
"""The preset of the ``preset`` entries: the paper signal's (at 1 ms), which every offline
method declares."""

WEAK_FORM_K = (50, 100, 200, 400, 800)
"""The numbers of test functions (subdomains) the weak form's K is chosen among (pysindy's
default: 100)."""

WEAK_FORM_TUNED = "WeakPDELibrary (K tuned)"
"""The name of the weak form's entry with K chosen by the truth."""

PYSINDY_DEFAULTS = ("FiniteDifference", "SmoothedFiniteDifference")
"""pysindy's own differentiation classes, at their defaults."""


SCORES = (
    "coefficient_error",
    "precision",
    "recall",
    "exact_support",
    "simulation_error",
    "diverged",
    "diverged_at_s",
)
"""The scores of a seed's row (NaN in the row of a seed that gave no model)."""


class _TooManyCalls(Exception):
    """A held-out simulation needed more than :data:`MAX_RHS_CALLS` evaluations."""


def _pysindy():
    import pysindy

    return pysindy


def _library(system: PolynomialSystem):
    return _pysindy().PolynomialLibrary(degree=system.degree)


def _optimizer(system: PolynomialSystem):
    """Sequentially thresholded least squares as Brunton et al. (2016) wrote it: plain least
    squares (no ridge, ``alpha=0``) at the system's threshold. pysindy's default ridge
    (``alpha=0.05``) is not invariant to the library's scale, which differs between the
    pointwise and the weak form: with it, the weak form missed Rössler's terms at 0.1 %
    noise (coefficient error 0.83-0.89 over three seeds, against 0.0002-0.0004 without), and
    the spectral preset Lotka-Volterra's (0.59 against 3e-5)."""
    return _pysindy().STLSQ(threshold=system.threshold, alpha=0.0)


def _pysindy_differentiation(entry: dict[str, Any]):
    """pysindy's differentiation object of a ``pysindy`` entry."""
    ps = _pysindy()
    if entry["method"] in PYSINDY_DEFAULTS:
        return getattr(ps, entry["method"])()
    kind = entry["method"].removeprefix("SINDyDerivative.")
    return ps.SINDyDerivative(kind=kind, **entry["params"])


def discover(
    system: PolynomialSystem, runs: Sequence[Measurement], entry: dict[str, Any]
) -> tuple[np.ndarray, np.ndarray]:
    """The coefficients Ξ̂ (states by library features, the library's own order) SINDy finds
    on the measured trajectories ``runs`` (one fit over all of them, each differentiated on
    its own) with ``entry``'s derivative (see the module docstring), and the library's
    monomials: ``(coefficients, powers)``."""
    ps = _pysindy()
    first = runs[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pysindy's convergence and ill-conditioning remarks
        if entry["source"] == "weak form":
            # its subdomains are drawn from numpy's global generator when the library is
            # built: seeded by the measurement's seed (and given back), so a run reproduces
            state = np.random.get_state()  # noqa: NPY002 (pysindy's generator, not ours)
            np.random.seed(first.seed)  # noqa: NPY002
            try:
                function_library = _library(system)
                library = ps.WeakPDELibrary(
                    function_library=function_library,
                    spatiotemporal_grid=first.t,
                    is_uniform=True,
                    **entry["params"],
                )
                model = ps.SINDy(feature_library=library, optimizer=_optimizer(system))
                model.fit([run.x for run in runs], t=[run.t for run in runs])
            finally:
                np.random.set_state(state)  # noqa: NPY002
            powers = function_library.powers_
        else:
            library = _library(system)
            if entry["source"] == "pysindy":
                model = ps.SINDy(
                    feature_library=library,
                    optimizer=_optimizer(system),
                    differentiation_method=_pysindy_differentiation(entry),
                )
                model.fit([run.x for run in runs], t=first.dt_s)
            else:
                model = ps.SINDy(feature_library=library, optimizer=_optimizer(system))
                states, rates = [], []
                for run in runs:
                    if entry["source"] == "truth":  # a perfect differentiator's
                        found, found_rates = run.truth.x, run.truth.x_dot
                    else:
                        found, found_rates = _estimated(run, entry)
                    kept = np.isfinite(found).all(axis=1) & np.isfinite(found_rates).all(axis=1)
                    states.append(found[kept])
                    rates.append(found_rates[kept])
                model.fit(states, t=first.dt_s, x_dot=rates)
            powers = library.powers_
    return np.asarray(model.coefficients(), dtype=float), np.asarray(powers, dtype=int)


def _estimated(measurement, entry: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """The smoothed states and ẋ ``entry``'s method trusts (NaN elsewhere): at its one
    setting for every state, or (``recommend``) each state divided by its scale at its own
    setting, multiplied back."""
    if entry["source"] != "recommend":
        method = methods.get(entry["method"], **entry["params"])
        estimate = method(measurement.x, measurement.dt_s, orders=(0, ORDER))
        return estimate.trusted(0), estimate.trusted(ORDER)
    states, rates = np.empty_like(measurement.x), np.empty_like(measurement.x)
    chosen = zip(entry["params"]["states"], entry["params"]["scales"], strict=True)
    for i, (params, scale) in enumerate(chosen):
        method = methods.get(entry["method"], **params)
        estimate = method(measurement.x[:, i] / scale, measurement.dt_s, orders=(0, ORDER))
        states[:, i], rates[:, i] = scale * estimate.trusted(0), scale * estimate.trusted(ORDER)
    return states, rates


def coefficient_scores(found: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """``coefficient_error`` (‖Ξ̂ − Ξ‖_F / ‖Ξ‖_F), the support's ``precision`` (true terms
    among those found; 0 when none is found), ``recall`` (found among the true ones) and
    ``exact_support`` (1.0 when the terms found are exactly the true ones)."""
    found_terms, true_terms = found != 0, truth != 0
    hits = int(np.sum(found_terms & true_terms))
    return {
        "coefficient_error": float(np.linalg.norm(found - truth) / np.linalg.norm(truth)),
        "precision": hits / int(found_terms.sum()) if found_terms.any() else 0.0,
        "recall": hits / int(true_terms.sum()),
        "exact_support": float(np.array_equal(found_terms, true_terms)),
    }


def simulate(
    system: PolynomialSystem, found: np.ndarray, powers: np.ndarray, initial, spread
) -> tuple[float, float]:
    """The discovered model ẋ = Θ(x) Ξ̂ᵀ from ``initial`` over the system's horizon against
    the true trajectory: ``(error, diverged_at_s)``, the error the RMS over time and states of
    the difference over each state's ``spread`` (inf if it diverged), ``diverged_at_s`` the
    time it diverged (NaN if it did not)."""
    truth = system.trajectory(initial, system.horizon_s)
    limit = BLOWUP * float(np.abs(truth.x).max())
    calls = [0]

    def rhs(_t, state):
        calls[0] += 1
        if calls[0] > MAX_RHS_CALLS:
            raise _TooManyCalls(_t)
        return np.prod(state[None, :] ** powers, axis=1) @ found.T

    def escaped(_t, state):
        return limit - float(np.abs(state).max())

    escaped.terminal = True
    try:
        solution = solve_ivp(
            rhs,
            (0.0, truth.t[-1]),
            np.asarray(initial, dtype=float),
            method="DOP853",
            t_eval=truth.t,
            events=escaped,
            rtol=SIMULATION_TOLERANCE,
            atol=SIMULATION_TOLERANCE,
        )
    except _TooManyCalls as stopped:
        return math.inf, float(stopped.args[0])
    if solution.status == 1:  # the escape event ended it
        return math.inf, float(solution.t_events[0][0])
    if solution.status != 0:  # the integration failed: at the last time it reached
        return math.inf, float(solution.t[-1]) if solution.t.size else 0.0
    difference = (solution.y.T - truth.x) / spread
    return float(np.sqrt(np.mean(difference**2))), math.nan


def _channels(
    runs: Sequence[Measurement], margin: float = INTERIOR_MARGIN
) -> list[SimpleNamespace]:
    """Each state of each measured trajectory as a realisation the tuner reads (samples, step,
    the middle of the trajectory as the interior, the exact ẋ as the truth)."""
    channels = []
    for run in runs:
        n = run.x.shape[0]
        cut = math.ceil(margin * n)
        interior = np.zeros(n, dtype=bool)
        interior[cut : n - cut] = True
        channels += [
            SimpleNamespace(
                x=run.x[:, i],
                dt_s=run.dt_s,
                interior=interior,
                truth={ORDER: run.truth.x_dot[:, i]},
            )
            for i in range(run.x.shape[1])
        ]
    return channels


def oracle_params(
    system_name: str, level: float, method: str, every: int = 1, starts: int = 1
) -> dict:
    """``method`` tuned by the truth for ẋ on the measurement at
    :data:`~diffbench.bench.core.tuning.TUNING_SEED` (never scored): the mean over the
    trajectories and states of the ẋ RMSE on each trajectory's middle (:func:`_channels`).
    Returns ``{"params", "loss"}``."""
    system = get_system(system_name)
    runs = system.measure_runs(level, tuning.TUNING_SEED, every, starts)
    result = tuning.tune(method, _channels(runs), ORDER, "oracle")
    if not math.isfinite(result.loss):
        raise ValueError(f"{method} has no setting that estimates {system_name}'s middle")
    return {"params": result.params, "loss": result.loss}


def recommended_params(
    system_name: str, level: float, method: str, every: int = 1, starts: int = 1
) -> dict:
    """``method``'s setting for each state as ``diffbench recommend`` chooses it from the
    measurement at :data:`~diffbench.bench.core.tuning.TUNING_SEED` alone (no truth; ẋ over
    the record less 5 % at each end), of its first trajectory when it has several (a user
    asks once, on one record): ``{"states": [params, ...], "scales": [...]}``, each setting
    for its state divided by its scale (:func:`advice.record_scale`), and every trajectory's
    state divided by the same."""
    system = get_system(system_name)
    measurement = system.measure_runs(level, tuning.TUNING_SEED, every, starts)[0]
    states, scales = [], []
    for i in range(measurement.x.shape[1]):
        found = advice.recommend(measurement.x[:, i], measurement.dt_s, [method], (ORDER,))
        states.append(found.best(ORDER)[1])  # ValueError when the method failed there
        scales.append(found.scale)
    return {"states": states, "scales": scales}


def weak_form_params(
    system_name: str, level: float, every: int = 1, starts: int = 1
) -> dict[str, Any]:
    """The weak form's number of test functions K (:data:`WEAK_FORM_K`) with the least
    coefficient error on the measurement at :data:`~diffbench.bench.core.tuning.TUNING_SEED`
    (never scored): the weak form's best, as the oracle gives the differentiators theirs.
    Returns ``{"K": K}``."""
    system = get_system(system_name)
    runs = system.measure_runs(level, tuning.TUNING_SEED, every, starts)
    errors = {}
    for count in WEAK_FORM_K:
        entry = {"source": "weak form", "params": {"K": count}}
        found, powers = discover(system, runs, entry)
        truth = system.coefficient_matrix(powers)
        errors[count] = coefficient_scores(found, truth)["coefficient_error"]
    return {"K": min(errors, key=errors.get)}


def preset_params(method: str, dt: float) -> dict[str, Any]:
    """The parameters of ``method``'s :data:`PRESET`, its windows snapped to whole even
    numbers of steps ``dt``; a ``ValueError`` naming the preset if the method has none."""
    params = methods.preset(method, PRESET).params()
    return search_space.snap(params, dt, methods.params_of(methods.method_class(method)))


def entry_rows(
    system_name: str,
    level: float,
    entry: dict[str, Any],
    seeds: int,
    every: int = 1,
    starts: int = 1,
) -> list[dict]:
    """Per seed 0..seeds-1: ``entry`` (``source``, ``method``, ``params``) on ``system_name``
    measured at ``level`` from ``starts`` initial conditions
    (:meth:`~diffbench.signals.dynamics.PolynomialSystem.measure_runs`), every
    ``every``-th sample, scored (:func:`coefficient_scores`;
    the held-out simulations' mean ``simulation_error`` and the earliest ``diverged_at_s``,
    with ``diverged`` the count of those that diverged); ``failure`` says why an entry gave
    no model (empty otherwise)."""
    system = get_system(system_name)
    spread = system.trajectory().x.std(axis=0)
    rows = []
    for seed in range(seeds):
        runs = system.measure_runs(level, seed, every, starts)
        row: dict[str, Any] = {"seed": seed, "failure": ""}
        try:
            found, powers = discover(system, runs, entry)
        except ValueError as error:  # a setting the record refuses, or no trusted sample
            rows.append({**row, **dict.fromkeys(SCORES, math.nan), "failure": str(error)})
            continue
        row.update(coefficient_scores(found, system.coefficient_matrix(powers)))
        runs = [simulate(system, found, powers, start, spread) for start in system.held_out]
        errors, times = zip(*runs, strict=True)
        row["simulation_error"] = float(np.mean(errors))
        row["diverged"] = int(sum(math.isfinite(t) for t in times))
        row["diverged_at_s"] = float(np.nanmin(times)) if row["diverged"] else math.nan
        rows.append(row)
    return rows
