r"""Tuning every registered method over its declared parameter ranges.

Two criteria:

*oracle*
    the RMSE of the chosen derivative against the truth, on the scenario's interior (or on the
    whole record), for one tuning seed, or averaged over several (scores are then taken on
    other seeds: never on a seed tuned on);
*no-truth*
    a data-only estimate of the same RMSE for linear methods (:func:`spectral_risk`): with a
    bandlimit guess f_c, the (Hann-tapered, detrended) periodogram of the measurement is split
    into signal (below f_c, less the white-noise floor) and noise (above f_c as measured, the
    floor below it), and the expected squared error of the estimate follows from the method's
    frequency response H: Σ |H − (i2πf)ⁿ|² S + |H|² N;
*pynumdiff*
    PyNumDiff's data-only loss (van Breugel, Kutz, Brunton, IEEE Access 8 (2020) 196865):
    integrate the estimated derivative back n times (the n constants fitted by least squares),
    take the RMSE to the measured signal, add γ times the mean absolute step of the derivative,
    with :math:`\ln\gamma = -1.6\ln f_c - 0.71\ln\Delta t - 5.1` (their fitted heuristic).

The search is scipy's differential evolution over the declared tuning ranges (log scale where
declared), integer and choice parameters through its ``integrality`` option, seeded, so a
tuning is reproducible. Windows (parameters declared ``kind="window"``) are snapped to whole
even numbers of steps and frequencies (``kind="frequency"``) kept below 0.45/Δt, so a method
registered later needs nothing extra.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import integrate, optimize

from diffbench import methods
from diffbench.bench.core.executor import call_timeout
from diffbench.bench.core.roles import CRITERION_NAMES
from diffbench.bench.core.scores import estimate_on, is_uniform
from diffbench.bench.core.search_space import fitted_to_record, search_space, snap
from diffbench.bench.core.spectrum import periodogram, record_spectrum
from diffbench.bench.core.surrogates import surrogate_records

CRITERIA = tuple(CRITERION_NAMES)
"""Every tuning criterion (named, labelled and explained in :mod:`~diffbench.bench.core.roles`)."""
DATA_ONLY_CRITERIA = ("no-truth", "pynumdiff")
"""The criteria that need a bandlimit guess ``cutoff_hz`` (they see no truth)."""
COMMAND_CRITERIA = tuple(c for c in CRITERIA if c != "surrogate")
"""The criteria ``diffbench tune`` offers (``surrogate`` is the procedure of ``recommend`` and
of the limit study)."""
TUNING_SEED = 10_000
"""The noise seed tuned on by default, never scored (the scored seeds are 0, 1, ...)."""

SURROGATE_RECORDS = 2
"""Surrogate records drawn from each record tuned on by the surrogate criterion (their mean
loss: one draw can favour a setting by luck)."""


REGIONS = ("interior", "whole", "interior-estimated")


@dataclass(frozen=True)
class NoiseSplit:
    """The measured spectrum split into signal and noise under a bandlimit (see
    :func:`spectral_risk`); computed once per tuning."""

    frequency: np.ndarray
    signal_power: np.ndarray
    noise_power: np.ndarray
    weights: np.ndarray
    samples: int

    @classmethod
    def of(cls, x: np.ndarray, dt: float, cutoff_hz: float) -> NoiseSplit:
        n = np.asarray(x).size
        frequency, power = periodogram(x, dt, "hann")
        above = frequency > cutoff_hz
        if not above.any() or above.all():
            raise ValueError(f"`cutoff_hz`={cutoff_hz} must lie inside (0, {0.5 / dt:g}) Hz")
        floor = float(np.median(power[above]) / math.log(2))
        weights = np.full(frequency.size, 2.0)
        weights[0] = 1.0
        if n % 2 == 0:
            weights[-1] = 1.0
        return cls(
            frequency,
            np.where(above, 0.0, np.maximum(power - floor, 0.0)),
            np.where(above, power, floor),
            weights,
            n,
        )

    def risk(self, method, dt: float, order: int) -> float:
        response = method.frequency_response(self.frequency, dt, order)
        ideal = (2j * math.pi * self.frequency) ** order
        terms = (
            np.abs(response - ideal) ** 2 * self.signal_power
            + np.abs(response) ** 2 * self.noise_power
        )
        return float(math.sqrt(np.sum(self.weights * terms) / self.samples))


def spectral_risk(method, x: np.ndarray, dt: float, order: int, cutoff_hz: float) -> float:
    r"""Data-only estimate of the RMSE of a linear method's derivative of ``order`` on ``x``.

    .. math::
        \widehat{\mathrm{MSE}} = \frac{1}{N}\sum_k w_k \left(|H_k - (i2\pi f_k)^n|^2
        \hat S_k + |H_k|^2 \hat N_k\right)

    over the rfft bins (w_k = 2 except at 0 and Nyquist), with P_k the Hann-tapered periodogram
    of the linearly detrended x (normalised so white noise of variance σ² gives E P_k = σ²),
    the noise floor ν = median(P_k, f_k > f_c) / ln 2 (the median of an exponential variable is
    ln 2 times its mean; robust to disturbance lines above f_c), N_k = ν below f_c and P_k above,
    and S_k = max(P_k − ν, 0) below f_c, 0 above (the bandlimit assumption).
    """
    return NoiseSplit.of(x, dt, cutoff_hz).risk(method, dt, order)


def pynumdiff_gamma(cutoff_hz: float, dt: float) -> float:
    """PyNumDiff's heuristic weight of the roughness term from a bandlimit guess."""
    if not (cutoff_hz > 0 and dt > 0):
        raise ValueError(f"`cutoff_hz` and `dt` must be > 0, got {cutoff_hz}, {dt}")
    return math.exp(-1.6 * math.log(cutoff_hz) - 0.71 * math.log(dt) - 5.1)


def no_truth_loss(
    x: np.ndarray, derivative: np.ndarray, dt: float, order: int, gamma: float
) -> float:
    """Data-only loss of an estimated derivative of ``order`` (1 or 2) of samples ``x``:
    RMSE between x and the derivative integrated ``order`` times (constants fitted by least
    squares), plus ``gamma`` times the mean absolute step of the derivative."""
    if order not in (1, 2):
        raise ValueError(f"`order` must be 1 or 2 for the no-truth loss, got {order}")
    t = np.arange(x.size) * dt
    integral = derivative
    for _ in range(order):
        integral = integrate.cumulative_trapezoid(integral, dx=dt, initial=0.0)
    constants = np.vander(t, order, increasing=True)  # 1 (and t): the integration constants
    coefficients, *_ = np.linalg.lstsq(constants, x - integral, rcond=None)
    residual = x - integral - constants @ coefficients
    rmse = float(np.sqrt(np.mean(residual**2)))
    return rmse + gamma * float(np.mean(np.abs(np.diff(derivative))))


def comparable_loss(value: float, scale: float | None = None) -> float:
    """A loss rounded so that differences that are only floating-point rounding compare equal.

    The BLAS and SIMD kernels numpy picks for the CPU change the last bits of a loss, and some
    candidates tie exactly in exact arithmetic (Savitzky-Golay degrees 2k-1 and 2k have the
    same taps for the first derivative): without rounding, which of two tied candidates wins
    depends on the machine, and so does the tuned result. With ``scale`` (the RMS of the true
    derivative), the loss is rounded to a multiple of 1e-9·scale; without, to 9 significant
    digits. Infinite and NaN losses are returned as they are.
    """
    if not math.isfinite(value):
        return value
    if scale:
        quantum = 1e-9 * scale
        return round(value / quantum) * quantum
    return float(f"{value:.9g}")


@dataclass(frozen=True)
class TuningResult:
    method: str
    params: dict[str, Any]
    loss: float
    criterion: str
    order: int
    evaluations: int
    seconds: float
    history: tuple = field(default=(), repr=False)
    # seconds from the search's start at which each entry of history was evaluated
    elapsed: tuple = field(default=(), repr=False)


def cutoff_range_hz(
    realisation, criterion: str = "no-truth", region: str = "interior"
) -> tuple[float, float]:
    """The bandlimit guesses ``cutoff_hz`` the data-only ``criterion`` can use on
    ``realisation``: from ``1 / duration`` (the lowest non-zero frequency the samples resolve,
    the periodogram's first bin) up to, not including, the Nyquist frequency ``0.5 / dt``.

    The duration is that of the samples the criterion's spectrum is taken on: the scored
    samples (``region``) for the no-truth criterion, the whole record for PyNumDiff's loss.
    A cutoff below the lowest bin leaves the no-truth criterion no signal band (only the mean)
    and PyNumDiff's weight γ, which grows as ``cutoff_hz**-1.6``, a roughness penalty that
    flattens every derivative.

    >>> from types import SimpleNamespace
    >>> cutoff_range_hz(SimpleNamespace(x=np.zeros(1000), dt_s=0.001), "pynumdiff")
    (1.0, 500.0)
    """
    dt = float(realisation.dt_s)
    samples = np.shape(realisation.x)[0]
    if criterion == "no-truth" and region == "interior":
        samples = int(np.count_nonzero(realisation.interior))
    return 1.0 / (samples * dt), 0.5 / dt


def check_cutoff(
    cutoff_hz, realisation, criterion: str = "no-truth", region: str = "interior"
) -> None:
    """Raise ``ValueError`` naming ``cutoff_hz`` and the range that works
    (:func:`cutoff_range_hz`) unless it lies in that range."""
    if cutoff_hz is None:
        raise ValueError(f"the {criterion} criterion needs `cutoff_hz` (a bandlimit guess)")
    low, high = cutoff_range_hz(realisation, criterion, region)
    number = isinstance(cutoff_hz, (int, float)) and not isinstance(cutoff_hz, bool)
    if not (number and low <= cutoff_hz < high):
        raise ValueError(
            f"`cutoff_hz` must lie in [{low:.4g}, {high:.4g}) Hz for the {criterion} criterion: "
            f"from 1/duration ({1 / low:.4g} s of samples, the lowest frequency they resolve) "
            f"to below the Nyquist frequency; got {cutoff_hz!r}"
        )


def read_span(scored: np.ndarray) -> tuple[int, int]:
    """The first and last sample a loss on the samples ``scored`` (a boolean mask) reads."""
    return int(np.argmax(scored)), int(scored.size - 1 - np.argmax(scored[::-1]))


def tune(
    name: str,
    realisations,
    order: int,
    criterion: str = "oracle",
    cutoff_hz: float | None = None,
    max_evaluations: int | None = None,
    seed: int = 0,
    region: str = "interior",
    timeout_s: float | None = None,
    screen_choices: int | None = None,
    share_budget: bool = False,
) -> TuningResult:
    r"""Tune method ``name`` for the derivative of ``order`` on one realisation (samples ``x``,
    step ``dt_s``, ``interior`` and, for the oracle, ``truth``) or a sequence of them.

    On K realisations the loss of a setting θ is the mean of its losses,
    :math:`L(\theta) = \frac1K \sum_k L_k(\theta)` (for the oracle, the mean interior RMSE,
    the quantity the tables report over the scored seeds): one noise draw can favour a setting
    by luck, K draws cut that luck by about √K. The realisations must share step and length.

    ``region``: the samples the loss is taken on, the scenario's ``"interior"`` (every one of
    them valid), the ``"whole"`` record (every sample estimated, valid or not; the
    parameters declared ``ends_only``, edge treatments, are searched too) or the interior
    with every sample estimated, valid or not (``"interior-estimated"``: what ``recommend``
    predicts; a short record's interior reaches samples a method does not trust). The no-truth
    criterion, a spectral estimate that knows no ends, takes the interior only.

    Candidates that a method rejects (e.g. a window longer than the signal) or that leave part
    of the scored samples unestimated (on the interior: not valid) cost +inf. Each combination
    of the choice parameters is searched in turn: by differential evolution over the other
    parameters (``max_evaluations`` bounds each run: default 100 per searched parameter, within
    150..400), or, with at most one other parameter, by a grid refined with Brent's method.
    On a narrow optimum (the spectral low-pass just passing the 15 Hz line of the paper
    signal) the default budget can stop short: `make bench` gives the 10-seed tunings 400.
    ``timeout_s`` bounds each call of the method
    (:func:`~diffbench.bench.core.executor.call_timeout`): one that outlives it raises
    ``CallTimeout`` out of the search. ``screen_choices``: with more combinations of the
    choice parameters than this, each is screened by one generation of its evolution and only
    this many best go on (:func:`_evolution_per_choice`), each with its own budget (faster),
    or with ``share_budget`` sharing the budget of all (deeper); default every combination.
    """
    if hasattr(realisations, "x"):
        realisations = (realisations,)
    realisations = tuple(realisations)
    if not realisations:
        raise ValueError("`realisations` must hold at least one realisation to tune on")
    if len({(r.dt_s, np.shape(r.x)) for r in realisations}) > 1:
        raise ValueError("the `realisations` tuned on together must share step and shape")
    if criterion not in CRITERIA:
        raise ValueError(f"`criterion` must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    if region not in REGIONS:
        raise ValueError(f"`region` must be one of {', '.join(REGIONS)}, got {region!r}")
    if region != "interior" and criterion == "no-truth":
        raise ValueError(
            "the no-truth criterion knows no ends: tune on the whole record with "
            "'oracle' or 'pynumdiff', or on region 'interior'"
        )
    if order not in (1, 2):
        raise ValueError(f"`order` must be 1 or 2, got {order!r}")
    if criterion in DATA_ONLY_CRITERIA:
        check_cutoff(cutoff_hz, realisations[0], criterion, region)
    if criterion != "oracle" and not all(is_uniform(r) for r in realisations):
        raise ValueError(
            f"the {criterion} criterion needs uniform samples; tune irregularly "
            "sampled records with 'oracle'"
        )
    if criterion == "no-truth" and not methods.method_class(name).linear:
        raise ValueError(
            f"the no-truth criterion needs a linear method; use 'pynumdiff' for {name!r}"
        )
    if criterion == "surrogate":
        result = tune(
            name,
            _surrogates(realisations, seed),
            order,
            "oracle",
            max_evaluations=max_evaluations,
            seed=seed,
            region=region,
        )
        return dataclasses.replace(result, criterion="surrogate")
    first = realisations[0]
    dt = first.dt_s
    cls = methods.method_class(name)
    fixed = set(cls.irrelevant_params(order))
    dimensions = [
        d for d in search_space(name, dt, np.shape(first.x)[0], region) if d.name not in fixed
    ]
    gamma = pynumdiff_gamma(cutoff_hz, dt) if criterion == "pynumdiff" else 0.0
    samples = [np.asarray(r.x, dtype=float) for r in realisations]
    # the samples the loss is taken on
    scored = [
        np.ones(np.shape(r.x)[0], dtype=bool)
        if region == "whole"
        else np.asarray(r.interior, dtype=bool)
        for r in realisations
    ]
    splits = (
        [NoiseSplit.of(x[inside], dt, cutoff_hz) for x, inside in zip(samples, scored, strict=True)]
        if criterion == "no-truth"
        else None
    )
    cache: dict[tuple, float] = {}
    history, elapsed = [], []
    # the oracle's losses are compared on a grid of 1e-9 x the RMS of the true derivative
    scale = (
        float(np.sqrt(np.mean(first.truth[order][scored[0]] ** 2)))
        if criterion == "oracle"
        else None
    )

    # the first and last sample each loss reads (the ends check is skipped when it cannot
    # reach them, and on every region but the interior, whose loss reads no valid marks:
    # the same losses, bit for bit, see Method.estimate_within)
    reads = [read_span(inside) for inside in scored]
    reads_marks = region == "interior"  # the interior must be trusted; elsewhere, estimated

    def loss_on(k: int, params: dict[str, Any]) -> float:
        """The loss of ``params`` on realisation ``k``."""
        x, inside = samples[k], scored[k]
        try:
            with call_timeout(timeout_s):  # CallTimeout: the caller's to report
                estimate = estimate_on(
                    cls(**params),
                    realisations[k],
                    x,
                    orders=(order,),
                    reads=reads[k],
                    marks=reads_marks,
                )
        except ValueError:
            return math.inf
        # the interior must be trusted; otherwise the samples scored estimated, trusted or not
        covered = estimate.valid[order] if reads_marks else estimate.estimated(order)
        if not covered[inside].all():
            return math.inf
        if criterion == "oracle":
            error = estimate[order][inside] - realisations[k].truth[order][inside]
            return float(np.sqrt(np.mean(error**2)))
        if criterion == "no-truth":
            return splits[k].risk(cls(**params), dt, order)
        return no_truth_loss(x[inside], estimate[order][inside], dt, order, gamma)

    defaults = fitted_to_record(
        {spec.name: spec.default for spec in methods.params_of(cls)},
        fixed,
        dt,
        np.shape(first.x)[0],
        methods.params_of(cls),
    )

    def without_unused(params: dict[str, Any]) -> dict[str, Any]:
        # parameters the other choices leave unused at their defaults: one evaluation each
        try:
            unused = cls(**params).unused_params()
        except ValueError:
            return params
        return {**params, **{name: defaults[name] for name in unused}}

    def params_of(vector) -> dict[str, Any]:
        # every parameter: the searched ones from the vector, the others at their defaults,
        # windows snapped to the step, the unused ones at their defaults
        params = {
            **defaults,
            **{d.name: d.value(v) for d, v in zip(dimensions, vector, strict=True)},
        }
        return without_unused(snap(params, dt, methods.params_of(cls)))

    def loss(vector) -> float:
        params = params_of(vector)
        key = tuple(sorted(params.items()))
        if key in cache:
            return cache[key]
        value = 0.0
        for k in range(len(realisations)):
            value += loss_on(k, params) / len(realisations)
            if not math.isfinite(value):
                break
        value = comparable_loss(value, scale)
        cache[key] = value
        history.append((params, value))
        elapsed.append(time.perf_counter() - start)
        return value

    start = time.perf_counter()
    searched = [d for d in dimensions if d.kind != "choice"]
    if len(searched) <= 1:
        best = _grid_and_brent(dimensions, loss, params_of)
    else:
        best = _evolution_per_choice(
            dimensions, loss, params_of, max_evaluations, seed, screen_choices, share_budget
        )
    value = cache.get(tuple(sorted(best.items())), math.inf) if best else loss([])
    return TuningResult(
        method=name,
        params=best,
        loss=value,
        criterion=criterion,
        order=order,
        evaluations=len(cache),
        seconds=time.perf_counter() - start,
        history=tuple(history),
        elapsed=tuple(elapsed),
    )


def _surrogates(realisations, seed: int) -> list:
    """:data:`SURROGATE_RECORDS` surrogate records of each realisation's samples (its truth
    unused), from its own spectrum (:func:`diffbench.bench.core.surrogates.surrogate_records`,
    the procedure of ``diffbench recommend``), scored where it is."""

    drawn = []
    for index, realisation in enumerate(realisations):
        x = np.asarray(realisation.x, dtype=np.float64)
        if x.ndim != 1:
            raise ValueError("the surrogate criterion tunes on one channel (1-D `x`)")
        drawn += surrogate_records(
            record_spectrum(x, realisation.dt_s),
            x,
            realisation.dt_s,
            SURROGATE_RECORDS,
            seed=seed + index,
            scored=np.asarray(realisation.interior, dtype=bool),
        )
    return drawn


def _evolution_per_choice(
    dimensions, loss, params_of, max_evaluations, seed, keep: int | None = None, share=False
) -> dict[str, Any]:
    """Every combination of the choice parameters; for each, differential evolution over the
    others (integers through ``integrality``), each run with the full budget (default 100 per
    searched parameter, within 150..400). The best combination wins; the first on a tie.

    One evolution over choices and numbers together spends its few generations on one region
    and can miss a choice that only pays with other numbers (the spectral method's edge
    treatment on the whole record: extension and fit_degree with the cutoff).

    With ``keep`` (and more combinations than that), each combination first gets one
    generation of its evolution, and only the ``keep`` best go on: their first generation is
    the same one again (the same seed), read from the loss's cache, so a screened combination
    costs about two generations instead of all of them. With ``share``, the kept ones share
    the budget of every combination less what screening the dropped ones cost (two
    populations each): the tuning costs what an unscreened one does and searches the
    promising combinations deeper. Measured on the paper signal over 999 ms (Jacobi, ẍ, whole
    record, ten tuning seeds, 400 evaluations, 9 combinations of rule and end treatment):
    every combination in full ends at a loss of 1030 in 3451 evaluations; two kept, sharing,
    at 827 in 3581, and on the 20 scored seeds 676 against 1015."""
    choice_index = [i for i, d in enumerate(dimensions) if d.kind == "choice"]
    free = [i for i, d in enumerate(dimensions) if d.kind != "choice"]
    bounds = [dimensions[i].bounds() for i in free]
    integrality = [dimensions[i].kind == "int" for i in free]
    budget = max_evaluations or min(400, max(150, 100 * len(free)))
    popsize = max(5, min(15, 40 // len(free)))
    # a Sobol initial population is rounded up to a power of two: count what is evaluated
    population = 2 ** math.ceil(math.log2(popsize * len(free)))
    generations = max(2, budget // population - 1)
    options = [range(len(dimensions[i].choices)) for i in choice_index]
    combinations = list(itertools.product(*options))

    def evolve(combination, maxiter: int) -> tuple[list[float], float]:
        def assemble(values) -> list[float]:
            vector = [0.0] * len(dimensions)
            for index, value in zip(choice_index, combination, strict=True):
                vector[index] = float(value)
            for index, value in zip(free, values, strict=True):
                vector[index] = value
            return vector

        result = optimize.differential_evolution(
            lambda values: loss(assemble(values)),
            bounds,
            integrality=integrality,
            seed=seed,
            popsize=popsize,
            maxiter=maxiter,
            tol=1e-4,
            polish=False,
            init="sobol",
            updating="deferred",
        )
        vector = assemble(list(result.x))
        return vector, loss(vector)

    if keep is not None and len(combinations) > keep:
        screened = [evolve(combination, 1)[1] for combination in combinations]
        order = sorted(range(len(combinations)), key=lambda k: screened[k])[:keep]
        if share:
            dropped = len(combinations) - keep
            shared = (budget * len(combinations) - 2 * population * dropped) // keep
            generations = max(generations, shared // population - 1)
        combinations = [combinations[k] for k in sorted(order)]
    best_vector, best_value = None, math.inf
    for combination in combinations:
        vector, value = evolve(combination, generations)
        if value < best_value or best_vector is None:
            best_vector, best_value = vector, value
    return params_of(best_vector)


def _grid_and_brent(dimensions, loss, params_of) -> dict[str, Any]:
    """Every combination of the choice parameters; for each, a 9-point grid on the one
    remaining parameter (if any) refined by bounded Brent search around the best grid point."""
    choice_index = [i for i, d in enumerate(dimensions) if d.kind == "choice"]
    free = [i for i, d in enumerate(dimensions) if d.kind != "choice"]
    best_vector, best_value = None, math.inf
    options = [range(len(dimensions[i].choices)) for i in choice_index]
    for combination in itertools.product(*options):
        vector = [0.0] * len(dimensions)
        for index, value in zip(choice_index, combination, strict=True):
            vector[index] = float(value)
        if not free:
            candidates = [list(vector)]
        else:
            (slot,) = free
            low, high = dimensions[slot].bounds()
            grid = np.linspace(low, high, 9)

            def along(coordinate, vector=vector, slot=slot):
                trial = list(vector)
                trial[slot] = coordinate
                return loss(trial)

            values = [along(g) for g in grid]
            k = int(np.argmin(values))
            lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
            if np.isfinite(values[k]) and hi > lo:
                refined = optimize.minimize_scalar(
                    along,
                    bounds=(lo, hi),
                    method="bounded",
                    options={"xatol": (high - low) * 1e-3, "maxiter": 20},
                )
                coordinate = refined.x if refined.fun <= values[k] else grid[k]
            else:
                coordinate = grid[k]
            trial = list(vector)
            trial[slot] = coordinate
            candidates = [trial]
        for candidate in candidates:
            value = loss(candidate)
            if value < best_value or best_vector is None:
                best_vector, best_value = candidate, value
    return params_of(best_vector) if best_vector is not None else {}
