"""Irregular sampling: the time stamps a real logger gives instead of the nominal grid.

Each model is a small frozen dataclass whose :meth:`SamplingModel.times` turns the nominal
grid :math:`t_i = i\\,\\Delta t` into measured time stamps, drawing only from the generator it
is given. A scenario applies its models in order (:class:`diffbench.signals.Scenario`); the
truth and the noise are then taken at the measured times, so a method is scored against the
exact derivatives where the samples really are.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np

from diffbench.signals._checks import check_real, check_rng, check_times


class SamplingModel(abc.ABC):
    """Base of every sampling model (frozen dataclass, keyword parameters)."""

    def times(self, t: np.ndarray, dt: float, rng: np.random.Generator) -> np.ndarray:
        """The measured time stamps from the times ``t`` (nominal step ``dt``): strictly
        increasing, the first and last kept, so the record spans the same interval."""
        return self._times(check_times(t), float(dt), check_rng(rng))

    @abc.abstractmethod
    def _times(self, t: np.ndarray, dt: float, rng: np.random.Generator) -> np.ndarray: ...

    @abc.abstractmethod
    def describe(self) -> str: ...


@dataclass(frozen=True, kw_only=True)
class Jitter(SamplingModel):
    """Each inner time stamp moved by :math:`u_i\\,f\\,\\Delta t`, :math:`u_i \\sim U(-1, 1)`
    independent (the first and last stay put). ``fraction`` f in [0, 0.5) keeps the stamps
    strictly increasing."""

    fraction: float

    def __post_init__(self) -> None:
        value = check_real("fraction", self.fraction, ge=0)
        if not value < 0.5:
            raise ValueError(
                f"`fraction` must be below 0.5 (more can reorder the stamps), got {value!r}"
            )
        object.__setattr__(self, "fraction", value)

    def _times(self, t, dt, rng):
        shift = rng.uniform(-1.0, 1.0, t.size) * self.fraction * dt
        shift[0] = shift[-1] = 0.0
        return t + shift

    def describe(self) -> str:
        return f"jitter ±{self.fraction:.0%} of the step"


@dataclass(frozen=True, kw_only=True)
class Dropout(SamplingModel):
    """A fraction of the inner samples lost, chosen uniformly without replacement (the first
    and last kept): ``round(fraction * (n - 2))`` of them, ``fraction`` in [0, 0.9]."""

    fraction: float

    def __post_init__(self) -> None:
        value = check_real("fraction", self.fraction, ge=0)
        if not value <= 0.9:
            raise ValueError(f"`fraction` must be at most 0.9, got {value!r}")
        object.__setattr__(self, "fraction", value)

    def _times(self, t, dt, rng):
        inner = t.size - 2
        lost = rng.choice(inner, size=round(self.fraction * inner), replace=False) + 1
        keep = np.ones(t.size, dtype=bool)
        keep[lost] = False
        return t[keep]

    def describe(self) -> str:
        return f"{self.fraction:.0%} of the samples dropped"
