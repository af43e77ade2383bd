"""Input checks shared by every method: done once, at the boundary, with messages that name
the argument and say what is allowed."""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Iterable

import numpy as np

MAX_ORDER = 2

MAX_WINDOW_STEPS = 100_000
"""Longest window any method accepts, in sampling steps (100 s at dt = 1 ms). Taps cost time
and memory in proportion to the window (measured at this length, q = 40: 0.4 s for the Jacobi
trapezoid rule, a few seconds for its linear rule); 1e300 s used to overflow."""


CLOSE_MATCH_RATIO = 0.6
"""Least similarity (:class:`difflib.SequenceMatcher` ratio, case ignored) of a known name
to a mistyped one for :func:`did_you_mean` to offer it (difflib's default)."""


def did_you_mean(name: object, choices: Iterable[str], limit: int = 3) -> str:
    """``"did you mean 'jacobi'?"`` (or ``'a', 'b' or 'c'``): the ``choices`` closest to
    ``name`` (at most ``limit``, best first; similarity at least :data:`CLOSE_MATCH_RATIO`,
    case ignored; a choice that differs only in case, alone); ``""`` when none is close.

    Parameters
    ----------
    name : object
        What the user typed (anything that is not a string gets ``""``).
    choices : iterable of str
        The valid names.
    limit : int
        The most names offered.

    Returns
    -------
    str
        The sentence to append to an error message, or ``""``.

    References
    ----------
    Python's :func:`difflib.get_close_matches` (Ratcliff–Obershelp similarity).

    Examples
    --------
    >>> did_you_mean("jacobbi", ["jacobi", "kalman", "causal_jacobi"])
    "did you mean 'jacobi' or 'causal_jacobi'?"
    >>> did_you_mean("Kalman", ["kalman", "kalman_filter"])
    "did you mean 'kalman'?"
    """
    if not isinstance(name, str):
        return ""
    by_folded: dict[str, str] = {}
    for choice in choices:
        by_folded.setdefault(choice.casefold(), choice)
    if name.casefold() in by_folded:  # only the case differs: that one
        return f"did you mean {by_folded[name.casefold()]!r}?"
    close = difflib.get_close_matches(name.casefold(), by_folded, limit, CLOSE_MATCH_RATIO)
    if not close:
        return ""
    names = [repr(by_folded[c]) for c in close]
    listed = names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"
    return f"did you mean {listed}?"


def unknown_choice_hint(name: object, choices: Iterable[str]) -> str:
    """What to say after "unknown ... {name!r}; ": :func:`did_you_mean` when a choice is close
    (the full list of a large registry would bury it), else ``"available: a, b, ..."``."""
    choices = list(choices)
    return did_you_mean(name, choices) or f"available: {', '.join(choices)}"


class DeferredValueError(ValueError):
    """A ``ValueError`` whose message is composed when it is first read (``str``, a
    traceback, pickling), by ``compose()``.

    For refusals whose message searches for the settings that would work (e.g. the shortest
    window a Jacobi design takes, found by computing taps): a tuner catches thousands of
    refusals as +inf and reads none, and paid for every search (a third of a Jacobi tuning).
    The user who reads the error gets the same message as before. Pickled (a worker process's
    error) it becomes a plain ``ValueError`` with the composed message.
    """

    def __init__(self, compose) -> None:
        super().__init__()
        self._compose = compose
        self._message: str | None = None

    def __str__(self) -> str:
        if self._message is None:
            self._message = self._compose()
        return self._message

    def __repr__(self) -> str:
        return f"ValueError({str(self)!r})"

    def __reduce__(self):
        return (ValueError, (str(self),))


class ArgumentTypeError(ValueError, TypeError):
    """An argument of the wrong type (a bool or a string for a step, complex samples, one
    order where a sequence of them is asked for). Both a ``ValueError``, as every bad input
    of the API is (the CLI turns it into a usage error), and a ``TypeError``, as Python's
    convention has it (scikit-learn's ``InvalidParameterError`` does the same)."""


MIN_STEP_S = 1e-30
MAX_STEP_S = 1e30
r"""The sampling steps the methods take, in seconds: :math:`[10^{-30}, 10^{30}]`.

The methods form powers of the step and of its inverse up to the tenth (the finite
differences' :math:`\Delta t^{-2}`, the powers of a Kalman model's discretisation and of a
high-gain observer's gains, Levant's Taylor terms :math:`\Delta t^{j}`); within this range
every such power stays a finite, nonzero float64 (:math:`10^{\pm 300}`). Outside it they
overflow or underflow (``dt=1e-300`` divided by zero, ``dt=1e300`` overflowed): rescale the
time axis (e.g. give the step in other units and scale the derivatives back)."""


def _is_real_number(value) -> bool:
    """A real scalar: a ``numbers.Real`` (Python's or numpy's ints and floats, fractions) or a
    0-d numpy array of ints or floats; not a bool, a string, a complex or a longer array."""
    if isinstance(value, (bool, np.bool_)):
        return False
    if isinstance(value, np.ndarray):
        return value.ndim == 0 and value.dtype.kind in "iuf"
    return isinstance(value, numbers.Real)


def check_dt(dt: float, name: str = "dt") -> float:
    """Return ``dt`` as a float, or raise if it is not a number in
    [:data:`MIN_STEP_S`, :data:`MAX_STEP_S`] seconds: :class:`ArgumentTypeError` for a bool,
    a string, a complex or an array, ``ValueError`` for a value out of range (``name``: how the
    message calls the step)."""
    allowed = f"a number of seconds in [{MIN_STEP_S:g}, {MAX_STEP_S:g}]"
    if not _is_real_number(dt):
        what = "a bool is not a step" if isinstance(dt, (bool, np.bool_)) else "not a number"
        raise ArgumentTypeError(
            f"`{name}` must be {allowed}, got {dt!r} ({what}; give the sampling step as a "
            "float, e.g. 0.001)"
        )
    value = float(dt)
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"`{name}` must be a finite number > 0, i.e. {allowed}, got {value!r}")
    if not MIN_STEP_S <= value <= MAX_STEP_S:
        raise ValueError(
            f"`{name}` must be {allowed}, got {value!r} (the powers of the step the methods form "
            "would overflow or underflow float64; rescale the time axis: give the step in "
            "other units and scale the derivatives back)"
        )
    return value


def check_frequency(
    name: str,
    value_hz: float,
    dt: float,
    *,
    lowest_hz: float = 0.0,
    highest_hz: float | None = None,
    why_low: str = "",
    why_high: str = "",
) -> None:
    """Refuse a frequency parameter ``name`` outside what the step ``dt`` allows: below the
    Nyquist frequency 1/(2 dt) (and at most ``highest_hz`` if given), at least ``lowest_hz``
    (above 0 if that is 0). The message names the parameter, the allowed range at this step and,
    in ``why_low`` / ``why_high``, the reason for a limit that is not Nyquist's."""
    nyquist = 0.5 / dt
    if highest_hz is None or highest_hz >= nyquist:
        upper = f"{nyquist:g})"
        too_high = not value_hz < nyquist
    else:
        upper = f"{highest_hz:.10g}]"
        too_high = value_hz > highest_hz
    lower = f"[{lowest_hz:g}" if lowest_hz > 0 else "(0"
    allowed = f"{lower}, {upper} Hz"
    if too_high:
        reason = f" ({why_high})" if why_high else ""
        raise ValueError(
            f"`{name}` must be below the Nyquist frequency {nyquist:g} Hz for "
            f"dt={dt!r} s, i.e. in {allowed}{reason}, got {value_hz!r}"
        )
    if value_hz < lowest_hz or not value_hz > 0:
        reason = f" ({why_low})" if why_low else ""
        raise ValueError(f"`{name}` must be in {allowed} at dt={dt!r} s{reason}, got {value_hz!r}")


def check_signal(x, dt: float, min_samples: int = 2) -> tuple[np.ndarray, float]:
    """Validate samples and sampling step; return ``(x, dt)`` as float64 array and float.

    Parameters
    ----------
    x : array_like, shape (n,) or (n, ...)
        Samples, time on axis 0; further axes are channels.
    dt : float
        Sampling step in seconds, in [:data:`MIN_STEP_S`, :data:`MAX_STEP_S`].
    min_samples : int
        Least number of samples the caller needs (e.g. its window length).

    Raises
    ------
    ValueError
        If ``x`` is not numeric (complex included: :class:`ArgumentTypeError`), is 0-d, has
        fewer than ``min_samples`` samples on axis 0, or holds NaN or inf; if ``dt`` is not a
        number in [:data:`MIN_STEP_S`, :data:`MAX_STEP_S`] s (:func:`check_dt`).
    """
    dt = check_dt(dt)
    array = as_real_array("x", x, "samples", allow_bool=True)
    if array.ndim == 0:
        raise ValueError("`x` must have time on axis 0 (shape (n,) or (n, channels)), got a scalar")
    if array.shape[0] < min_samples:
        raise ValueError(
            f"`x` has {array.shape[0]} samples on axis 0; at least {min_samples} are needed "
            "(a window longer than the signal?)"
        )
    if array.size and not np.all(np.isfinite(array)):
        bad = int(np.count_nonzero(~np.isfinite(array)))
        raise ValueError(f"`x` holds {bad} NaN or inf values; clean or interpolate them first")
    return array, dt


def check_orders(orders: Iterable[int]) -> tuple[int, ...]:
    """Return the sorted, de-duplicated derivative orders, each an int in 0..MAX_ORDER."""
    if isinstance(orders, (str, bytes)) or not isinstance(orders, Iterable):
        raise ArgumentTypeError(
            f"`orders` must be a sequence of derivative orders in 0..{MAX_ORDER}, e.g. (1,) or "
            f"(0, 1, 2), got {orders!r}"
        )
    result = []
    for order in orders:
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
            raise ValueError(f"`orders` must hold integers 0..{MAX_ORDER}, got {order!r}")
        if not 0 <= order <= MAX_ORDER:
            raise ValueError(f"`orders` must hold integers 0..{MAX_ORDER}, got {int(order)}")
        result.append(int(order))
    if not result:
        raise ValueError(f"`orders` must name at least one derivative order in 0..{MAX_ORDER}")
    return tuple(sorted(set(result)))


def samples_in_span(
    name: str, span_s: float, dt: float, *, odd: bool = False, least: int = 1
) -> int:
    """Number of sampling intervals in ``span_s`` seconds; it must be a whole number.

    A span of ``k`` intervals covers ``k + 1`` samples (node convention: the outer samples lie
    on the ends of the window). With ``odd=True`` the sample count must be odd (``k`` even), as
    a central window needs. ``span_s / dt`` is accepted as whole within 1e-9 relative. At most
    :data:`MAX_WINDOW_STEPS` intervals. The spans an error suggests hold at least ``least``
    intervals (the caller's own minimum, e.g. a polynomial's degree), so that each works.
    """
    ratio = span_s / dt
    if ratio > MAX_WINDOW_STEPS + 0.5:
        raise ValueError(
            f"`{name}` must be in (0, {MAX_WINDOW_STEPS * dt:.6g}] s at dt={dt!r} s (at most "
            f"{MAX_WINDOW_STEPS} sampling steps: the taps cost time and memory in proportion), "
            f"got {span_s!r}"
        )
    intervals = round(ratio)
    if intervals < 1 or abs(ratio - intervals) > 1e-9 * max(1.0, abs(ratio)):
        step = 2 if odd else 1
        fewest = step * math.ceil(max(least, 1) / step)
        nearest = max(fewest, step * round(ratio / step))
        raise ValueError(
            f"`{name}`={span_s!r} s is {ratio:.6g} sampling steps of dt={dt!r} s; it must be a "
            f"whole number of steps{', an even one' if odd else ''}, e.g. {nearest * dt:.10g}"
        )
    if odd and intervals % 2:
        fewest = 2 * math.ceil(max(least, 1) / 2)
        candidates = sorted({max(fewest, intervals - 1), max(fewest, intervals + 1)})
        neighbours = " or ".join(f"{k * dt:.10g}" for k in candidates)
        raise ValueError(
            f"`{name}`={span_s!r} s spans {intervals} steps of dt={dt!r} s, i.e. {intervals + 1} "
            f"samples; a central window needs an odd sample count: use {neighbours}"
        )
    return intervals


UNIFORM_TOLERANCE = 1e-6
"""Time stamps whose steps all lie within this fraction of their mean step are uniform."""


def check_times(t, n: int | None = None) -> np.ndarray:
    """Return time stamps ``t`` as a float64 array, checked: 1-D, at least 2 of them (``n`` if
    given: one per sample of the signal), finite and strictly increasing.

    Raises ``ValueError`` naming ``t`` and the fix otherwise.
    """
    times = as_real_array("t", t, "times")
    if times.ndim != 1 or times.size < 2:
        raise ValueError(f"`t` must be a 1-D array of at least 2 times, got shape {times.shape}")
    if n is not None and times.size != n:
        raise ValueError(
            f"`t` has {times.size} time stamps but `x` has {n} samples on axis 0; give one "
            "time stamp per sample"
        )
    if not np.all(np.isfinite(times)):
        raise ValueError("`t` holds NaN or inf values")
    steps = np.diff(times)
    if np.any(steps <= 0):
        first = int(np.argmax(steps <= 0))
        raise ValueError(
            f"`t` must be strictly increasing; t[{first + 1}]={float(times[first + 1])!r} <= "
            f"t[{first}]={float(times[first])!r} (sort it and drop duplicates)"
        )
    step = mean_step(times)
    if not MIN_STEP_S <= step <= MAX_STEP_S:
        raise ValueError(
            f"`t` must have a mean step in [{MIN_STEP_S:g}, {MAX_STEP_S:g}] s, got {step!r} s "
            "(the powers of the step the methods form would overflow or underflow float64; "
            "rescale the time axis: give the times in other units and scale the derivatives "
            "back)"
        )
    return times


def as_real_array(name: str, value, what: str, allow_bool: bool = False) -> np.ndarray:
    """``value`` as a float64 array, or :class:`ArgumentTypeError` naming ``name`` if it holds
    anything but real numbers (complex, strings, objects; bools unless ``allow_bool``: samples
    of a digital line are 0 and 1, time stamps are never bools)."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        array = None
    if array is not None and np.iscomplexobj(array):
        raise ArgumentTypeError(
            f"`{name}` must hold real {what}, got complex values (give the real and imaginary "
            f"parts separately: `{name}.real`, `{name}.imag`)"
        )
    if array is not None and array.dtype == np.bool_ and not allow_bool:
        raise ArgumentTypeError(
            f"`{name}` must hold real {what}, got booleans (convert them to numbers first if "
            "that is meant)"
        )
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ArgumentTypeError(
            f"`{name}` must be an array of real numbers, got {type(value).__name__}"
        ) from None


def finite_samples(values: np.ndarray) -> np.ndarray:
    """Boolean mask over axis 0 (time) of the samples finite on every channel."""
    values = np.asarray(values)
    return np.isfinite(values).reshape(values.shape[0], -1).all(axis=1)


def mean_step(times: np.ndarray) -> float:
    """The mean step :math:`(t_{n-1} - t_0)/(n - 1)` of checked time stamps."""
    return float((times[-1] - times[0]) / (times.size - 1))


def is_uniform(times: np.ndarray) -> bool:
    """True when every step of checked ``times`` is within :data:`UNIFORM_TOLERANCE` of the
    mean step."""
    step = mean_step(times)
    return float(np.max(np.abs(np.diff(times) - step))) <= UNIFORM_TOLERANCE * step


def uniform_step(t) -> float:
    """Return the sampling step of a uniform, increasing time vector ``t``.

    Raises ``ValueError`` if ``t`` is not 1-D, has fewer than 2 samples, holds NaN/inf, is not
    strictly increasing, or its steps differ by more than 1e-6 relative (pass ``t=`` to a
    method instead: it takes irregular time stamps).
    """
    times = check_times(t)
    dt = mean_step(times)
    spread = float(np.max(np.abs(np.diff(times) - dt)))
    if spread > UNIFORM_TOLERANCE * dt:
        raise ValueError(
            f"`t` is not uniformly sampled (steps differ from the mean {dt!r} s by up to "
            f"{spread:.3g} s); give the time stamps to the method as `t=` instead of `dt`"
        )
    return float(dt)
