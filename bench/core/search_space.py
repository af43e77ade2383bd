"""The search space of a tuning: which parameters of a method are searched, over which
ranges, at a record's step and length (:func:`search_space`), and the windows snapped to whole
steps (:func:`snap`) or fitted to a short record (:func:`fitted_to_record`). The tuner
(:mod:`~diffbench.bench.core.tuning`) searches it."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from diffbench import methods


class NoRoomToTune(ValueError):
    """A method's tuning range leaves nothing to search at this step and record length."""


@dataclass(frozen=True)
class Dimension:
    """One searched parameter: its coordinate in the optimiser and back."""

    name: str
    kind: str  # "float", "int" or "choice"
    low: float
    high: float
    log: bool = False
    choices: tuple = ()

    def bounds(self) -> tuple[float, float]:
        if self.kind == "choice":
            return (0.0, len(self.choices) - 1.0)
        if self.log:
            return (math.log(self.low), math.log(self.high))
        return (self.low, self.high)

    def value(self, coordinate: float) -> Any:
        if self.kind == "choice":
            return self.choices[round(coordinate)]
        number = math.exp(coordinate) if self.log else coordinate
        number = min(max(number, self.low), self.high)
        return round(number) if self.kind == "int" else float(number)


SMALL_INTEGER_RANGE = 4
"""Integer parameters with at most this many values are searched like choices, one by one."""

DURATION_STEPS = 10
"""A time-scale parameter (``kind="duration"``: a kernel's length scale) is searched up to at
least this many steps: the declared ranges are set for records of 0.1-10 ms steps, and on a
coarse record (PyNumDiff's test records: 31 samples, 0.1 s apart) their 0.2-0.3 s tops are
2-3 steps, too short to smooth; the Gaussian process's best length scale on PyNumDiff's
irregular f4 record is 6 steps. Records of steps up to 20-30 ms keep the declared range."""

FREQUENCY_PERIOD_STEPS = 50
"""A frequency parameter (``kind="frequency"``: a cutoff, a bandwidth) is searched down to at
most one period in this many steps, for the same reason as :data:`DURATION_STEPS`: on
PyNumDiff's 0.1 s records the declared 0.5 Hz floors are periods of 20 steps, while a
quadratic over 3 s wants Kalman's bandwidth at 0.2 Hz or below (ẋ RMSE 0.017 there against
0.042 at 0.5 Hz). Records of steps up to 40 ms keep the declared range."""


def search_space(name: str, dt: float, n_samples: int, region: str = "interior") -> list[Dimension]:
    """The dimensions searched for method ``name`` at step ``dt`` on ``n_samples`` samples, by
    a loss taken on ``region`` (parameters declared ``ends_only`` only where it may read
    estimates the method does not trust: ``whole``, ``interior-estimated``)."""
    cls = methods.method_class(name)
    dimensions = []
    for spec in methods.params_of(cls):
        if spec.ends_only and region == "interior":
            continue
        if spec.choices is not None:
            if len(spec.choices) > 1 and not spec.untuned:
                dimensions.append(Dimension(spec.name, "choice", 0, 0, choices=spec.choices))
            continue
        if spec.tune_low is None:
            continue
        low, high = float(spec.tune_low), float(spec.tune_high)
        if spec.kind == "frequency":
            high = min(high, 0.45 / dt)
            low = min(low, 1.0 / (FREQUENCY_PERIOD_STEPS * dt))
        if spec.kind == "duration":
            high = max(high, DURATION_STEPS * dt)
        if spec.kind == "window":
            low, high = window_bounds(low, high, dt, n_samples)
        if low >= high:
            raise NoRoomToTune(
                f"`{spec.name}` has no room to tune at dt={dt!r} s on {n_samples} samples "
                f"(range {spec.tune_low}..{spec.tune_high})"
            )
        if spec.integer and high - low < SMALL_INTEGER_RANGE:  # searched value by value
            values = tuple(range(math.ceil(low), math.floor(high) + 1))
            dimensions.append(Dimension(spec.name, "choice", 0, 0, choices=values))
            continue
        kind = "int" if spec.integer else "float"
        dimensions.append(Dimension(spec.name, kind, low, high, log=spec.log))
    return dimensions


def window_bounds(low: float, high: float, dt: float, n_samples: int) -> tuple[float, float]:
    """A window parameter's range ``low``..``high`` (s) on ``n_samples`` at step ``dt``: at
    least 4 steps, at most a third of the record."""
    return max(low, 4 * dt), min(high, dt * (n_samples // 3))


def fitted_to_record(params: dict[str, Any], names, dt: float, n_samples: int, specs) -> dict:
    """``params`` with the window parameters among ``names`` (those a tuning leaves at their
    defaults, e.g. the ẍ window when ẋ is tuned) brought within 4 steps .. a third of the
    record (:func:`window_bounds`): a default window longer than a short record would fail
    every candidate although it does not change the estimate tuned. Windows already within
    are left as they are."""
    fitted = dict(params)
    low, high = window_bounds(0.0, math.inf, dt, n_samples)
    for spec in specs:
        if spec.name in names and spec.kind == "window" and low <= high:
            fitted[spec.name] = min(max(fitted[spec.name], low), high)
    return fitted


def snap(params: dict[str, Any], dt: float, specs) -> dict[str, Any]:
    """Windows (parameters declared ``kind="window"``) to whole even numbers of steps (odd
    sample counts), at least 2 steps. ``specs``: the method's parameter specifications."""
    windows = {spec.name for spec in specs if spec.kind == "window"}
    snapped = dict(params)
    for key, value in params.items():
        if key in windows:
            snapped[key] = 2 * max(1, round(value / (2 * dt))) * dt
    return snapped
