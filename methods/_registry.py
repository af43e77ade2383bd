"""The method registry: a method is one frozen dataclass registered by name with a decorator.

Each hyperparameter is a dataclass field declared with :func:`param`, which records its
admissible range (checked on construction), its tuning range and scale, what kind of quantity
it is (a window length in seconds, a frequency in Hz, or neither) and a description.
Presets (the paper's settings, or ours where the paper has none) are declared on the class.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import metadata
from typing import Any, ClassVar

import numpy as np

from diffbench.methods._ends import check_reaches, trusted_samples, unread_end_samples
from diffbench.methods._fir import apply_central_firs, fir_response
from diffbench.methods._plugins import (
    distributions_of_modules,
    load_automatic_plugins,
    missing_hint,
)
from diffbench.methods._time_stamps import from_grid, to_grid, uniform_grid
from diffbench.methods._validation import (
    MAX_WINDOW_STEPS,
    check_dt,
    check_orders,
    check_signal,
    check_times,
    did_you_mean,
    finite_samples,
    is_uniform,
    mean_step,
    unknown_choice_hint,
)

_REGISTRY: dict[str, type[Method]] = {}

TIME_STAMPS = ("native", "resampled", "uniform")
"""How a method may take irregular time stamps (``Method.time_stamps``): natively, by
resampling, or not at all (uniformly sampled records only)."""

PARAM_KINDS = (None, "window", "frequency", "duration")
"""What a parameter may declare itself to be (``Param.kind``): nothing in particular, a window
length in seconds, a frequency in Hz, or a time scale in seconds of at least one step."""

DEFAULT_NYQUIST_FRACTION = 0.5
"""A frequency left at its class default that the step cannot take is lowered to this fraction
of the Nyquist frequency (:meth:`Method.at_step`)."""

DEFAULT_WINDOW_GROWTH = 1.25
"""A window left at its class default that the method refuses at a step, once snapped to the
step, grows by this factor (at least one step each side) until the method takes it."""

DEFAULT_SHRINK = 0.8
"""Windows and time scales left at their class defaults that a record is too short for shrink
by this factor at a time until the method takes the record (:meth:`Method.at_record`)."""


@dataclass(frozen=True)
class Param:
    """Specification of one hyperparameter.

    ``low``/``high`` bound the admissible values (open or closed ends); ``tune_low`` and
    ``tune_high`` bound the range a tuner searches, on a log scale when ``log`` is true.
    ``kind`` says what the value means, so that no caller guesses it from the name:
    ``"window"`` for a window length in seconds (a whole, even number of sampling steps),
    ``"frequency"`` for a frequency in Hz (below Nyquist), ``"duration"`` for a time scale in
    seconds that must span at least one step (a kernel width, a length scale), ``None``
    otherwise (one of :data:`PARAM_KINDS`, checked at registration); the kind also says how a
    default that does not fit the step is adapted (:meth:`Method.at_step`). Limits that
    depend on the sampling step are checked by the method's ``check_step(dt)``, not here.
    ``untuned`` says why a parameter is not tuned: a numeric one without a tuning range, or one
    with ``choices`` the tuners leave at its value (e.g. one that trades cost for precision).
    ``ends_only``: the parameter changes the estimate only near the ends of the record (an
    edge treatment), so only a loss taken on the whole record tunes it; a loss on the interior
    leaves it at its value.
    """

    name: str
    default: Any
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    integer: bool = False
    choices: tuple | None = None
    tune_low: float | None = None
    tune_high: float | None = None
    log: bool = False
    doc: str = ""
    kind: str | None = None
    untuned: str = ""
    ends_only: bool = False

    def describe_range(self) -> str:
        """The admissible range as text, e.g. ``(0, inf)`` or ``{2, 4, 6}``."""
        if self.choices is not None:
            return "{" + ", ".join(str(c) for c in self.choices) + "}"
        left = "(" if self.low_open or math.isinf(self.low) else "["
        right = ")" if self.high_open or math.isinf(self.high) else "]"
        return f"{left}{_fmt(self.low)}, {_fmt(self.high)}{right}"

    def check(self, value: Any) -> int | float | str:
        """Return ``value`` as a plain int/float (or one of string ``choices``), or raise
        ``ValueError`` naming this parameter."""
        kind = "an integer" if self.integer else "a finite number"
        allowed = f"{kind} in {self.describe_range()}"
        if self.choices is not None:
            allowed = f"one of {self.describe_range()}"
            if all(isinstance(choice, str) for choice in self.choices):
                if value not in self.choices:
                    close = did_you_mean(value, self.choices)
                    raise ValueError(
                        f"`{self.name}` must be {allowed}, got {value!r}"
                        + (f"; {close}" if close else "")
                    )
                return value
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise ValueError(f"`{self.name}` must be {allowed}, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"`{self.name}` must be {allowed}, got {value!r}")
        if self.integer:
            if not float(value).is_integer():
                raise ValueError(f"`{self.name}` must be {allowed}, got {value!r}")
            value = int(value)
        else:
            value = float(value)
        if self.choices is not None:
            if value not in self.choices:
                raise ValueError(f"`{self.name}` must be {allowed}, got {value!r}")
            return value
        too_low = value <= self.low if self.low_open else value < self.low
        too_high = value >= self.high if self.high_open else value > self.high
        if too_low or too_high:
            raise ValueError(f"`{self.name}` must be {allowed}, got {value!r}")
        return value


def _clean(value: float) -> float:
    """``value`` to 12 significant digits: 0.2, not 0.20000000000000001 from 2 * 0.1."""
    return float(f"{value:.12g}")


def _fmt(value: float) -> str:
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:g}"


def param(default: Any, **spec: Any) -> Any:
    """Declare a hyperparameter field of a method class (see :class:`Param` for ``spec``)."""
    return dataclasses.field(default=default, metadata={"param": spec})


@dataclass(frozen=True)
class Preset:
    """A named set of hyperparameter values, who chose them (``by``: ``"paper"`` for the seed
    paper's settings, ``"diffbench"`` for ours, ``"defaults"`` for the class defaults) and
    where they come from (``source``, one line)."""

    values: Mapping[str, Any]
    source: str
    by: str = "diffbench"

    @property
    def label(self) -> str:
        """How tables name a row at this preset: ``preset (paper)``, ``preset (diffbench)``."""
        return "class defaults" if self.by == "defaults" else f"preset ({self.by})"


@dataclass(frozen=True)
class Estimate:
    """What a method returns: the smoothed signal and derivatives, where they exist, and where
    they are trusted.

    ``values[n]`` has the shape of the input; it is finite wherever the method estimates the
    sample (:meth:`estimated`) and NaN where it gives no estimate at all (e.g. where a central
    window does not fit and the method has no end treatment). ``valid[n]``, a boolean mask over
    axis 0 (time), is the trust mark: the samples whose expected error is within a few times the
    interior's (:mod:`~diffbench.methods._ends`). Every valid sample is estimated; an estimated
    sample need not be valid (the ends of a record, a filter's start-up).
    """

    values: Mapping[int, np.ndarray]
    valid: Mapping[int, np.ndarray]

    def __post_init__(self) -> None:
        if set(self.values) != set(self.valid):
            raise ValueError("`values` and `valid` must have the same derivative orders")
        for order, value in self.values.items():
            mask = self.valid[order]
            if mask.shape != value.shape[:1]:
                raise ValueError(f"valid mask of order {order} does not match the time axis")
            if (mask & ~finite_samples(value)).any():
                raise ValueError(f"order {order}: the estimate is not finite on a valid sample")

    @property
    def orders(self) -> tuple[int, ...]:
        return tuple(sorted(self.values))

    def __getitem__(self, order: int) -> np.ndarray:
        if order not in self.values:
            raise ValueError(f"`order` {order!r} was not estimated; available: {self.orders}")
        return self.values[order]

    def coverage(self, order: int) -> float:
        """Fraction of samples on which the derivative of ``order`` is valid (trusted)."""
        return float(np.mean(self.valid[order]))

    def estimated(self, order: int) -> np.ndarray:
        """Boolean mask over axis 0 of the samples where the derivative of ``order`` is
        estimated (finite on every channel), trusted or not."""
        return finite_samples(self[order])

    def trusted(self, order: int) -> np.ndarray:
        """The derivative of ``order`` with NaN on the samples that are not valid."""
        shape = (-1,) + (1,) * (self[order].ndim - 1)
        return np.where(self.valid[order].reshape(shape), self[order], np.nan)


class Method:
    """Base of every registered method: validation and the call contract.

    Subclasses are frozen dataclasses whose fields are declared with :func:`param`; they
    implement ``_estimate(x, dt, orders) -> (values, valid)`` and may override
    ``min_samples(dt)`` (shortest signal they accept; called first, so it must refuse by name
    whatever it cannot compute), ``check_step(dt)`` (checks that depend on the sampling step,
    also run by :meth:`frequency_response`) and ``exact_degree(order)`` (polynomial degree
    reproduced exactly) and ``max_samples(dt)`` (longest signal they accept, for methods whose
    cost grows too fast to run long records).

    ``package`` names the distribution whose implementation runs (``None``: the one that
    registered the class, see :func:`package_of`); ``second_derivative`` says how ẍ is
    obtained when the implementation has no second derivative of its own.
    """

    name: ClassVar[str] = ""
    linear: ClassVar[bool] = True
    time_symmetric: ClassVar[bool] = True
    causal: ClassVar[bool] = False
    """Whether the estimate at a sample uses that sample and earlier ones only (the online
    track, :class:`~diffbench.methods._causal.CausalMethod`)."""
    presets: ClassVar[Mapping[str, Preset]] = {}
    reference: ClassVar[str] = ""
    package: ClassVar[str | None] = None
    second_derivative: ClassVar[str] = "native"

    def __post_init__(self) -> None:
        for spec in params_of(type(self)):
            object.__setattr__(self, spec.name, spec.check(getattr(self, spec.name)))

    def __call__(self, x, dt: float | None = None, orders=(0, 1, 2), *, t=None) -> Estimate:
        """Estimate the derivatives of ``orders`` of samples ``x`` taken every ``dt`` seconds,
        or at the time stamps ``t`` (seconds, one per sample, strictly increasing).

        Give ``dt`` or ``t``. Uniform time stamps (steps within
        :data:`~diffbench.methods._validation.UNIFORM_TOLERANCE` of their mean) take the
        uniform path with ``dt`` = their mean step, so they give exactly what ``dt`` gives.
        Irregular ones are handled natively by a method that defines ``_estimate_at(x, t,
        orders)`` (``time_stamps == "native"``), otherwise by resampling
        (:mod:`diffbench.methods._time_stamps`; ``time_stamps == "resampled"``) onto the grid
        of step ``dt`` when it is given with ``t`` (the nominal step: e.g. 1 ms for a 1 kHz
        logger with jitter or lost samples), else of the step nearest the median step.
        """
        if t is None:
            if dt is None:
                raise ValueError(
                    "give the sampling step `dt` (uniform samples) or the time stamps `t` "
                    "(one per sample)"
                )
            return self._uniform(x, dt, orders)
        nominal = None if dt is None else check_dt(dt)
        x, _ = check_signal(x, 1.0, min_samples=2)
        times = check_times(t, x.shape[0])
        step = mean_step(times)
        if is_uniform(times):
            return self._uniform(x, step, orders)
        orders = check_orders(orders)
        if self.time_stamps == "uniform":
            raise ValueError(
                f"{self.name} {self.uniform_only_reason}; give `dt`, or stamps within 1e-6 of "
                "uniform"
            )
        if self.time_stamps == "native":
            adapted = self.at_record(x.shape[0], step)
            adapted._check_longest(x.shape[0], step)
            values, valid = adapted._estimate_at(x, times, orders)
            return Estimate(values=values, valid=valid)
        grid, grid_step = uniform_grid(times, nominal)
        try:
            on_grid = self._uniform(to_grid(x, times, grid), grid_step, orders)
        except ValueError as error:
            raise ValueError(
                f"{error} (on the uniform grid of step {grid_step!r} s, "
                f"{'nearest `dt`' if nominal else 'nearest the median step of `t`'}: "
                f"{self.name} takes irregular time stamps by resampling them; give `dt`, "
                "the nominal step, with `t`)"
            ) from None
        values, valid = {}, {}
        for order in orders:
            values[order], valid[order] = from_grid(
                on_grid.values[order], on_grid.valid[order], grid, times
            )
        return Estimate(values=values, valid=valid)

    time_stamps: ClassVar[str] = "resampled"
    """How irregular time stamps are handled: ``"native"`` (the method's own
    ``_estimate_at``), ``"resampled"`` (:mod:`diffbench.methods._time_stamps`) or
    ``"uniform"`` (refused, ``uniform_only_reason`` saying why)."""

    uniform_only_reason: ClassVar[str] = "takes uniformly sampled records only"

    def _estimate_at(self, x: np.ndarray, times: np.ndarray, orders) -> tuple[dict, dict]:
        raise NotImplementedError(f"{self.name} has no estimate at irregular times")

    def _check_longest(self, n_samples: int, dt: float) -> None:
        longest = self.max_samples(dt)
        if longest is not None and n_samples > longest:
            raise ValueError(
                f"`x` has {n_samples} samples on axis 0; {self.name} accepts at most {longest} "
                f"({self.max_samples_reason}); split the record or pick another method"
            )

    def at_step(self, dt: float) -> Method:
        """This method as it runs at sampling step ``dt``.

        Itself, unless the step refuses a parameter left at its class default (one the caller,
        or the preset, did not give); then those defaults are adapted by one stated rule, so
        that ``methods.get(name)`` runs at any step:

        - a frequency (``kind="frequency"``) is lowered to :data:`DEFAULT_NYQUIST_FRACTION`
          of the Nyquist frequency :math:`1/(2\\Delta t)`;
        - a duration (``kind="duration"``) is raised to one step;
        - a window (``kind="window"``) is snapped to the nearest whole even number of steps (at
          least two), then, while the method still refuses it, grown by
          :data:`DEFAULT_WINDOW_GROWTH` (at least one step each side) up to
          :data:`~diffbench.methods._validation.MAX_WINDOW_STEPS`.

        Values the caller set are never changed: the step takes them or the call refuses them
        by name. Where the rule finds nothing the method takes, this returns itself and the
        call gives its own error. ``method.at_step(dt).params()`` are the values a call at
        ``dt`` uses.
        """
        dt = check_dt(dt)
        if not dataclasses.is_dataclass(self):  # a Method subclass not (yet) registered
            return self
        defaulted = self._defaulted_kinds()
        if not defaulted or self._takes_step(dt):
            return self
        changes, windows = {}, []
        for spec in defaulted:
            value = getattr(self, spec.name)
            if spec.kind == "frequency":
                changes[spec.name] = min(value, _clean(DEFAULT_NYQUIST_FRACTION * 0.5 / dt))
            elif spec.kind == "duration":
                changes[spec.name] = max(value, dt)
            else:
                windows.append(spec.name)
                changes[spec.name] = max(1, round(value / (2 * dt)))  # half width, in steps
        while True:
            values = {
                name: _clean(2 * value * dt) if name in windows else value
                for name, value in changes.items()
            }
            try:
                adapted = dataclasses.replace(self, **values)
            except ValueError:  # outside the parameter's declared range
                return self
            if adapted._takes_step(dt):
                return adapted
            half_widths = [changes[name] for name in windows]
            if not windows or 2 * max(half_widths) >= MAX_WINDOW_STEPS:
                return self
            for name in windows:
                grown = max(changes[name] + 1, math.ceil(DEFAULT_WINDOW_GROWTH * changes[name]))
                changes[name] = min(grown, MAX_WINDOW_STEPS // 2)

    def at_record(self, n_samples: int, dt: float) -> Method:
        """This method as it runs on a record of ``n_samples`` at step ``dt``:
        :meth:`at_step`, then, when the record is shorter than that needs (``min_samples``),
        the windows and time scales (``kind="window"``, ``"duration"``) left at their class
        defaults shrunk together by :data:`DEFAULT_SHRINK` at a time (a window to whole even
        numbers of steps, at least two; a time scale to at least one step), and frequencies
        (``kind="frequency"``: a cutoff whose periods the record must hold) raised by its
        inverse, up to :data:`DEFAULT_NYQUIST_FRACTION` of Nyquist, until the method takes the
        record, so that ``methods.get(name)`` runs on short records (16 samples of
        a 10 ms logger). Values the caller or a preset set are never changed; where shrinking
        finds nothing, the call gives its own error. ``method.at_record(n, dt).params()`` are
        the values a call on that record uses."""
        adapted = self.at_step(dt)
        if not dataclasses.is_dataclass(self):  # a Method subclass not (yet) registered
            return adapted
        shrinking = self._defaulted_kinds()
        if not shrinking or adapted._takes_record(n_samples, dt):
            return adapted
        scale, top = 1.0, DEFAULT_NYQUIST_FRACTION * 0.5 / dt
        exhausted = {"window": lambda v: v <= 2 * dt, "duration": lambda v: v <= dt}
        while True:
            scale *= DEFAULT_SHRINK
            values = {}
            for spec in shrinking:
                value = getattr(adapted, spec.name) * scale
                if spec.kind == "window":
                    values[spec.name] = _clean(2 * max(1, math.floor(value / (2 * dt))) * dt)
                elif spec.kind == "frequency":
                    values[spec.name] = min(getattr(adapted, spec.name) / scale, top)
                else:
                    values[spec.name] = max(value, dt)
            try:
                shrunk = dataclasses.replace(self, **values)
            except ValueError:  # below a parameter's declared range
                return adapted
            if shrunk._takes_record(n_samples, dt):
                return shrunk
            if all(
                exhausted.get(spec.kind, lambda v: v >= top)(values[spec.name])
                for spec in shrinking
            ):
                return adapted

    def _defaulted_kinds(self) -> list:
        """The parameters with a ``kind`` (window, frequency, duration) left at their class
        defaults: the ones :meth:`at_step` and :meth:`at_record` may adapt."""
        return [
            spec
            for spec in params_of(type(self))
            if spec.kind is not None and spec.name not in getattr(self, "_given", ())
        ]

    def _takes_record(self, n_samples: int, dt: float) -> bool:
        """Whether the settings fit step ``dt`` and a record of ``n_samples``."""
        return self._takes_step(dt) and self.min_samples(dt) <= n_samples

    def _takes_step(self, dt: float) -> bool:
        """Whether the settings fit step ``dt`` (``min_samples`` and ``check_step`` pass)."""
        try:
            self.min_samples(dt)
            self.check_step(dt)
        except ValueError:
            return False
        return True

    def estimate_within(
        self, x, dt: float, orders, first: int, last: int, marks: bool = True
    ) -> Estimate:
        """``self(x, dt, orders)`` for a caller that reads samples ``first`` to ``last``
        (inclusive) only, such as a tuner's loss on a record's interior; with ``marks=False``
        for one that reads their values only, never their valid marks (a loss over every
        estimated sample): the ends check is then skipped wherever it would reach, the values
        are those of the full call, bit for bit, and only the method's own marks are kept.

        The ends check (:func:`~diffbench.methods._ends.trusted_samples`) can mask only the
        first and last ``end_reach(dt)`` samples of a record longer than its probe (``max(2
        reach + 1, min_samples)`` samples); when samples ``first..last`` lie beyond both, it
        is skipped, and so is the end treatment of a method that saves by it
        (:meth:`_estimate_away_from_ends`): the samples read have the values and validity of
        the full call, bit for bit, and the samples outside them come back unchecked (marked
        valid where finite) or, where the end treatment was skipped, NaN and invalid. When
        they reach an end, a method with :attr:`skips_unread_ends` neither fits nor checks the
        end samples nearer the ends than both ``first`` and ``n - 1 - last``
        (:func:`~diffbench.methods._ends.unread_end_samples`): those come back NaN and
        invalid, the samples read as in the full call, bit for bit. Otherwise, and for
        irregular records, this is the full call."""
        return self._uniform(x, dt, orders, reads=(int(first), int(last)), marks=bool(marks))

    def _uniform(
        self, x, dt: float, orders, reads: tuple[int, int] | None = None, marks: bool = True
    ) -> Estimate:
        orders = check_orders(orders)
        dt = check_dt(dt)
        adapted = self.at_record(np.shape(x)[0], dt) if np.ndim(x) else self.at_step(dt)
        if adapted is not self:
            return adapted._uniform(x, dt, orders, reads, marks)
        # the signal's length first: it is cheap, and check_step may build taps
        x, dt = check_signal(x, dt, min_samples=self.min_samples(dt))
        n = x.shape[0]
        self._check_longest(n, dt)
        self.check_step(dt)
        reach = self.end_reach(dt) if self.linear else None
        skip = 0
        if reach and reads is not None and not check_reaches(self, n, dt, *reads):
            # neither the ends check nor the end treatment can reach the samples read
            values, valid = self._estimate_away_from_ends(x, dt, orders)
            reach = None
        elif reach and (skip := self._unread_ends(n, dt, reads)):
            # the end samples nearer an end than those read: neither fitted nor checked
            values, valid = self._estimate_skipping_ends(x, dt, orders, skip)
        else:
            values, valid = self._estimate(x, dt, orders)
        if reach and marks:
            # a record too short for any sample to be within the method's own accuracy keeps
            # its estimates, none of them valid
            trusted = trusted_samples(self, n, dt, orders, skip=skip)
            for order in orders:
                valid[order] = valid[order] & trusted[order]
        return Estimate(values=values, valid=valid)

    def params(self) -> dict[str, Any]:
        """The hyperparameter values of this instance."""
        return {spec.name: getattr(self, spec.name) for spec in params_of(type(self))}

    def min_samples(self, dt: float) -> int:
        return 2

    max_samples_reason: ClassVar[str] = ""

    def max_samples(self, dt: float) -> int | None:
        """Longest signal accepted (``None``: no limit); ``max_samples_reason`` says why."""
        return None

    def check_step(self, dt: float) -> None:
        return None

    def end_reach(self, dt: float) -> int | None:
        """How many samples at each end of a record this (linear) method estimates otherwise
        than its interior, at step ``dt``; ``None`` (the default) when it does not say. A method
        that says has its end estimates checked against its interior response and the ones that
        miss marked not valid (:mod:`methods._ends`); they keep their values."""
        return None

    @classmethod
    def irrelevant_params(cls, order: int) -> tuple[str, ...]:
        """Parameters that do not change the estimate of ``order`` (a tuner leaves them)."""
        return ()

    def unused_params(self) -> tuple[str, ...]:
        """Parameters this instance's other choices leave unused (tables do not print them)."""
        return ()

    def exact_degree(self, order: int) -> float | None:
        """Highest polynomial degree whose derivative of ``order`` is reproduced exactly on the
        valid samples (``math.inf``: any degree; ``None``: not exact for any degree)."""
        return None

    def frequency_response(self, frequency_hz, dt: float, order: int) -> np.ndarray:
        """Complex response :math:`H(f)` of the estimate of ``order`` at ``frequency_hz``
        (the output for :math:`e^{i2\\pi ft}` away from the ends is :math:`H(f)e^{i2\\pi ft}`);
        the ideal is :math:`(i 2\\pi f)^n`. Linear methods only. Arguments are checked here,
        then the method's ``_response(frequency_hz, dt, order)`` computes it."""
        dt = check_dt(dt)
        adapted = self.at_step(dt)
        adapted.check_step(dt)
        check_orders((order,))
        frequency_hz = np.atleast_1d(np.asarray(frequency_hz, dtype=np.float64))
        return adapted._response(frequency_hz, dt, order)

    def _response(self, frequency_hz: np.ndarray, dt: float, order: int) -> np.ndarray:
        raise NotImplementedError(f"{self.name} is not linear: it has no frequency response")

    def _estimate(self, x: np.ndarray, dt: float, orders: tuple[int, ...]):
        raise NotImplementedError

    def _estimate_away_from_ends(self, x: np.ndarray, dt: float, orders: tuple[int, ...]):
        """:meth:`_estimate` for a caller that reads no sample within ``end_reach(dt)`` of
        either end (:meth:`estimate_within`): a method whose end treatment costs may leave
        those samples NaN and invalid, the others bit for bit as :meth:`_estimate` gives
        them. By default the full :meth:`_estimate`."""
        return self._estimate(x, dt, orders)

    skips_unread_ends: ClassVar[bool] = False
    """Whether :meth:`_estimate_skipping_ends` saves: a method whose end estimates cost (fits
    per end sample) and are each independent of the others."""

    def _unread_ends(self, n_samples: int, dt: float, reads: tuple[int, int] | None) -> int:
        """The first and last samples :meth:`estimate_within` neither fits nor checks for a
        caller reading ``reads`` (first, last) of a record of ``n_samples``
        (:func:`~diffbench.methods._ends.unread_end_samples`); 0 without reads or for a
        method without :attr:`skips_unread_ends`."""
        if reads is None or not self.skips_unread_ends:
            return 0
        return unread_end_samples(self, n_samples, dt, *reads)

    def _estimate_skipping_ends(self, x: np.ndarray, dt: float, orders: tuple[int, ...], skip: int):
        """:meth:`_estimate` for a caller that reads no sample among the first and last
        ``skip`` (:meth:`estimate_within`, with :attr:`skips_unread_ends`): those may come
        back NaN and invalid, the others bit for bit as :meth:`_estimate` gives them. By
        default the full :meth:`_estimate`."""
        return self._estimate(x, dt, orders)


class FirMethod(Method):
    """A method that is one centred FIR filter per derivative order (``taps(order, dt)``)."""

    def taps(self, order: int, dt: float) -> np.ndarray:
        raise NotImplementedError

    def _response(self, frequency_hz, dt: float, order: int) -> np.ndarray:
        return fir_response(self.taps(order, dt), frequency_hz, dt)

    def _estimate(self, x, dt, orders):
        filtered = apply_central_firs(x, [self.taps(order, dt) for order in orders])
        values = {order: y for order, (y, _) in zip(orders, filtered, strict=True)}
        valid = {order: mask for order, (_, mask) in zip(orders, filtered, strict=True)}
        return values, valid


@functools.cache
def params_of(cls: type[Method]) -> tuple[Param, ...]:
    """The parameter specifications of a method class, in declaration order (immutable, built
    once per class: every construction and every tuner step reads them)."""
    specs = []
    for field in dataclasses.fields(cls):
        spec = field.metadata.get("param")
        if spec is None:
            raise TypeError(f"{cls.__name__}.{field.name} must be declared with methods.param()")
        specs.append(Param(name=field.name, default=field.default, **spec))
    return tuple(specs)


def register(name: str):
    """Class decorator registering a method under ``name``.

    The class is made a frozen dataclass; a duplicate name, a parameter not declared with
    :func:`param`, a parameter ``kind`` not in :data:`PARAM_KINDS`, a ``time_stamps`` not in
    :data:`TIME_STAMPS` (or "native" without an ``_estimate_at``), or a preset naming an
    unknown parameter or an out-of-range value is an error.
    """

    def decorate(cls: type[Method]) -> type[Method]:
        if name in _REGISTRY:
            raise ValueError(f"a method named {name!r} is already registered")
        if not issubclass(cls, Method):
            raise TypeError(f"{cls.__name__} must subclass methods.Method")
        cls = dataclass(frozen=True)(cls)
        specs = {spec.name: spec for spec in params_of(cls)}
        for spec in specs.values():
            if spec.kind not in PARAM_KINDS:
                kinds = ", ".join(repr(kind) for kind in PARAM_KINDS)
                raise ValueError(
                    f"{name}: parameter `{spec.name}` has kind {spec.kind!r}; "
                    f"it must be one of {kinds}"
                )
        if cls.time_stamps not in TIME_STAMPS:
            raise ValueError(
                f"{name}: time_stamps is {cls.time_stamps!r}; it must be one of {TIME_STAMPS}"
            )
        if cls.time_stamps == "native" and cls._estimate_at is Method._estimate_at:
            raise ValueError(f"{name}: time_stamps 'native' needs an _estimate_at of its own")
        for key, preset in cls.presets.items():
            unknown = set(preset.values) - set(specs)
            if unknown:
                raise ValueError(f"{name}: preset {key!r} names unknown parameters {unknown}")
            for pname, value in preset.values.items():
                specs[pname].check(value)
        _remember_given(cls, tuple(specs))
        cls.name = name
        _REGISTRY[name] = cls
        return cls

    return decorate


def _remember_given(cls: type[Method], names: tuple[str, ...]) -> None:
    """Make instances of ``cls`` remember which parameters their caller gave (``_given``), so
    that :meth:`Method.at_step` adapts only the others (not a field: equality, hashing and
    ``params()`` do not see it)."""
    init = cls.__init__

    @functools.wraps(init)
    def __init__(self, *args, **kwargs):
        init(self, *args, **kwargs)
        object.__setattr__(self, "_given", frozenset(names[: len(args)]) | frozenset(kwargs))

    cls.__init__ = __init__


def package_of(name: str) -> str:
    """The distribution and version whose code computes method ``name``, e.g.
    ``"diffbench 0.1.0"`` or ``"pynumdiff 0.3"`` (a peer run through an adapter)."""
    return _package_of_class(method_class(name))


@functools.cache
def _package_of_class(cls: type[Method]) -> str:
    package = cls.package
    if package is None:
        top = cls.__module__.split(".")[0]
        names = ["diffbench"] if top == "diffbench" else distributions_of_modules().get(top, [])
        package = names[0] if names else top
    try:
        return f"{package} {metadata.version(package)}"
    except metadata.PackageNotFoundError:
        return f"{package} (version unknown)"


def available(causal: bool | None = False) -> list[str]:
    """Names of the registered methods, sorted (plugins included, see ``methods._plugins``).

    ``causal``: False (the default) the offline methods, which the offline benchmarks compare;
    True the causal ones (the online track); None all of them.
    """
    load_automatic_plugins()
    return sorted(n for n, cls in _REGISTRY.items() if causal is None or cls.causal == causal)


def method_class(name: str) -> type[Method]:
    """The class registered as ``name``; an unknown name lists the valid ones."""
    if not isinstance(name, str):
        raise ValueError(f"a method name must be a string, got {name!r}")
    load_automatic_plugins()
    try:
        return _REGISTRY[name]
    except KeyError:
        hint = missing_hint(name) or unknown_choice_hint(name, sorted(_REGISTRY))
        raise ValueError(f"unknown method {name!r}; {hint}") from None


def get(name: str, **params: Any) -> Method:
    """An instance of method ``name`` with the given hyperparameters (the rest at defaults)."""
    cls = method_class(name)
    valid = [spec.name for spec in params_of(cls)]
    unknown = sorted(set(params) - set(valid))
    if unknown:
        close = [f"{u}: {hint}" for u in unknown if (hint := did_you_mean(u, valid))]
        raise ValueError(
            f"unknown parameter(s) {', '.join(unknown)} for method {name!r}; "
            + "".join(f"{hint} " for hint in close)
            + f"valid: {', '.join(valid) or '(none)'}"
        )
    return cls(**params)


DEFAULT_PRESET = "default"
"""The preset key every method has: its class defaults."""


def preset_spec(name: str, key: str) -> Preset:
    """The :class:`Preset` ``key`` of method ``name``; ``"default"`` is the class defaults.

    Raises ``ValueError`` listing the method's preset keys if it has no preset ``key`` (a
    misspelt key is an error, never silently the defaults).
    """
    cls = method_class(name)
    if key == DEFAULT_PRESET:
        defaults = {spec.name: spec.default for spec in params_of(cls)}
        return Preset(defaults, "the class defaults", by="defaults")
    try:
        return cls.presets[key]
    except KeyError:
        hint = unknown_choice_hint(key, [*sorted(cls.presets), DEFAULT_PRESET])
        raise ValueError(f"method {name!r} has no preset {key!r}; {hint}") from None


def preset(name: str, key: str) -> Method:
    """Method ``name`` at its preset ``key`` (see :func:`preset_spec`)."""
    return method_class(name)(**preset_spec(name, key).values)
