"""Input checks shared by the signals package: done once, at the boundary, with messages that
name the argument and say what is allowed (e.g. "`frequency_hz` must be > 0, got -1.0")."""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable

import numpy as np


def check_real(
    name: str,
    value: object,
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
) -> float:
    """Return ``value`` as a finite float within the given bounds, or raise ``ValueError``.

    ``gt``/``ge`` are the open/closed lower bounds and ``lt`` the open upper bound; the message
    names ``name`` and shows the offending value.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ValueError(f"`{name}` must be a real number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"`{name}` must be a finite number, got {number!r}")
    if gt is not None and not number > gt:
        raise ValueError(f"`{name}` must be > {gt:g}, got {number!r}")
    if ge is not None and not number >= ge:
        raise ValueError(f"`{name}` must be >= {ge:g}, got {number!r}")
    if lt is not None and not number < lt:
        raise ValueError(f"`{name}` must be < {lt:g}, got {number!r}")
    return number


def check_real_tuple(name: str, values: object, *, gt: float | None = None) -> tuple[float, ...]:
    """Return ``values`` (a non-empty sequence of finite reals) as a tuple of floats."""
    if (
        isinstance(values, (str, bytes))
        or not isinstance(values, Iterable)
        or (isinstance(values, np.ndarray) and values.ndim != 1)
    ):
        raise ValueError(f"`{name}` must be a non-empty sequence of real numbers, got {values!r}")
    items = tuple(values.tolist() if isinstance(values, np.ndarray) else values)
    if not items:
        raise ValueError(f"`{name}` must be a non-empty sequence of real numbers, got {values!r}")
    return tuple(check_real(f"{name}[{i}]", item, gt=gt) for i, item in enumerate(items))


def check_whole(name: str, value: object, *, ge: int) -> int:
    """Return ``value`` if it is a whole number (Python or NumPy integer, not a bool) of at
    least ``ge``, else raise ``ValueError`` naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise ValueError(f"`{name}` must be a whole number >= {ge}, got {value!r}")
    if value < ge:
        raise ValueError(f"`{name}` must be a whole number >= {ge}, got {value!r}")
    return int(value)


def check_bool(name: str, value: object) -> bool:
    """Return ``value`` if it is a bool (Python or NumPy), else raise ``ValueError``."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"`{name}` must be True or False, got {value!r}")
    return bool(value)


def check_times(t: object, name: str = "t") -> np.ndarray:
    """Return sample times as a 1-D float64 array; reject non-numeric, empty, non-1-D or
    non-finite input with a ``ValueError`` naming ``name``."""
    try:
        array = np.asarray(t, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be an array of real numbers, got {t!r}") from None
    if array.ndim != 1:
        raise ValueError(f"`{name}` must be 1-D (shape (n,)), got shape {array.shape}")
    if array.size == 0:
        raise ValueError(f"`{name}` must hold at least one sample, got an empty array")
    if not np.all(np.isfinite(array)):
        bad = int(np.count_nonzero(~np.isfinite(array)))
        raise ValueError(f"`{name}` holds {bad} NaN or inf values")
    return array


def check_samples(x: object, n: int, name: str = "x") -> np.ndarray:
    """Return samples as a float64 array with ``n`` samples on axis 0 (time), all finite."""
    try:
        array = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be an array of real numbers, got {x!r}") from None
    if array.ndim == 0 or array.shape[0] != n:
        raise ValueError(
            f"`{name}` must have the {n} samples of `t` on axis 0, got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        bad = int(np.count_nonzero(~np.isfinite(array)))
        raise ValueError(f"`{name}` holds {bad} NaN or inf values")
    return array


def check_rng(rng: object) -> np.random.Generator:
    """Return ``rng`` if it is a ``numpy.random.Generator``, else raise ``TypeError``."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            "`rng` must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)), "
            f"got {type(rng).__name__}"
        )
    return rng


def check_seed(seed: object) -> int:
    """Return ``seed`` as a Python int if it is a non-negative integer, else ``ValueError``."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise ValueError(f"`seed` must be a non-negative integer, got {seed!r}")
    if seed < 0:
        raise ValueError(f"`seed` must be a non-negative integer, got {seed!r}")
    return int(seed)


def read_only(array: np.ndarray) -> np.ndarray:
    """Return a read-only float64 copy of ``array`` (frozen results stay frozen)."""
    out = np.array(array, dtype=np.float64, copy=True)
    out.setflags(write=False)
    return out


def unknown_choice_hint(name: object, choices: Iterable[str]) -> str:
    """What to say after "unknown ... {name!r}; ": the close names ("did you mean ...?") or
    every one. The one definition is the methods package's
    (:func:`diffbench.methods.unknown_choice_hint`), imported when a name is unknown: loading
    the signals does not load the methods."""
    from diffbench.methods._validation import unknown_choice_hint as hint

    return hint(name, choices)
