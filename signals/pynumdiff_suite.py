r"""PyNumDiff's own test signals as diffbench scenarios, with their exact derivatives.

PyNumDiff 0.3 (``pynumdiff/tests/test_diff_methods.py``) tests every differentiator on six
functions sampled at :math:`t_i = 0.1\,i`, :math:`i = 0..30` (31 samples, 0 to 3 s inclusive),
with one draw of white Gaussian noise of standard deviation 0.05 (``np.random.seed(7)``):

* f0: :math:`x = 1`
* f1: :math:`x = 2t + 1`
* f2: :math:`x = t^2 - t + 1`
* f3: :math:`x = \sin 3t + 1/2`
* f4: :math:`x = e^t \sin 5t`
* f5: :math:`x = \sin 8t \,/\, (t + 0.1)^{3/2}`

and the methods that take time stamps on f0-f5 at the 31 stamps
:math:`t_i = 3\,(i/30)^{3/2}` (about 8 times denser at the start than at the end). An earlier
revision of its repository drew the irregular stamps instead as the grid jostled by
:math:`U(-\Delta t/3, \Delta t/3)`, drawn from the same legacy generator right after the noise.

The functions are written here from these formulas (first and second derivatives analytic).
The scenarios keep PyNumDiff's grid and noise level; the noise is drawn for each seed as every
diffbench scenario draws it (``numpy.random.default_rng(seed)``), so a table is a mean over
seeds, not PyNumDiff's one draw. The scored region is the whole record
(``interior_margin_s`` = 0): PyNumDiff's tests take the error over all samples.

The scenarios are not registered (:func:`diffbench.signals.get_scenario` lists the project's
own); :func:`get` gives them by name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from diffbench.signals._checks import check_real, unknown_choice_hint
from diffbench.signals.clean import Polynomial, Signal
from diffbench.signals.noise import Gaussian, NoiseStack
from diffbench.signals.scenarios import Scenario
from diffbench.signals.timing import SamplingModel

DT_S = 0.1
"""PyNumDiff's test step, s."""
DURATION_S = 3.0
"""PyNumDiff's test record, s (31 samples, both ends included)."""
NOISE_STD = 0.05
"""Standard deviation of PyNumDiff's test noise."""
SOURCE = "PyNumDiff 0.3, pynumdiff/tests/test_diff_methods.py"


@dataclass(frozen=True, kw_only=True)
class OffsetSine(Signal):
    r""":math:`x = A \sin(\omega t) + b` (PyNumDiff's f3 at A = 1, ω = 3 rad/s, b = 1/2).

    .. math:: \dot x = A\omega\cos\omega t, \quad \ddot x = -A\omega^2 \sin\omega t
    """

    name: ClassVar[str] = "offset_sine"
    amplitude: float = 1.0
    angular_rad_s: float = 3.0
    offset: float = 0.5

    def __post_init__(self) -> None:
        for field in ("amplitude", "angular_rad_s", "offset"):
            object.__setattr__(self, field, check_real(field, getattr(self, field)))

    def _derivatives(self, t):
        a, w = self.amplitude, self.angular_rad_s
        return a * np.sin(w * t) + self.offset, a * w * np.cos(w * t), -a * w**2 * np.sin(w * t)


@dataclass(frozen=True, kw_only=True)
class GrowingSine(Signal):
    r""":math:`x = e^{a t} \sin(\omega t)` (PyNumDiff's f4 at a = 1 /s, ω = 5 rad/s).

    .. math::
        \dot x = e^{at}(a \sin\omega t + \omega\cos\omega t), \quad
        \ddot x = e^{at}\big((a^2 - \omega^2)\sin\omega t + 2a\omega\cos\omega t\big)
    """

    name: ClassVar[str] = "growing_sine"
    growth_per_s: float = 1.0
    angular_rad_s: float = 5.0

    def __post_init__(self) -> None:
        for field in ("growth_per_s", "angular_rad_s"):
            object.__setattr__(self, field, check_real(field, getattr(self, field)))

    def _derivatives(self, t):
        a, w = self.growth_per_s, self.angular_rad_s
        grow, s, c = np.exp(a * t), np.sin(w * t), np.cos(w * t)
        return grow * s, grow * (a * s + w * c), grow * ((a * a - w * w) * s + 2 * a * w * c)


@dataclass(frozen=True, kw_only=True)
class SteepSine(Signal):
    r""":math:`x = \sin(\omega t)\,(t + c)^{-p}` (PyNumDiff's f5 at ω = 8 rad/s, c = 0.1 s,
    p = 3/2), for :math:`t > -c`. With :math:`u = t + c`:

    .. math::
        \dot x = \omega\cos(\omega t)\,u^{-p} - p\sin(\omega t)\,u^{-p-1}, \\
        \ddot x = -\omega^2\sin(\omega t)\,u^{-p} - 2p\omega\cos(\omega t)\,u^{-p-1}
        + p(p+1)\sin(\omega t)\,u^{-p-2}
    """

    name: ClassVar[str] = "steep_sine"
    angular_rad_s: float = 8.0
    shift_s: float = 0.1
    power: float = 1.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "angular_rad_s", check_real("angular_rad_s", self.angular_rad_s))
        object.__setattr__(self, "shift_s", check_real("shift_s", self.shift_s))
        object.__setattr__(self, "power", check_real("power", self.power))

    def _derivatives(self, t):
        u = t + self.shift_s
        if np.any(u <= 0):
            raise ValueError(f"`t` must exceed -shift_s = {-self.shift_s!r} s")
        w, p = self.angular_rad_s, self.power
        s, c = np.sin(w * t), np.cos(w * t)
        x = s * u**-p
        dx = w * c * u**-p - p * s * u ** (-p - 1)
        ddx = -(w**2) * s * u**-p - 2 * p * w * c * u ** (-p - 1) + p * (p + 1) * s * u ** (-p - 2)
        return x, dx, ddx


@dataclass(frozen=True, kw_only=True)
class PowerStamps(SamplingModel):
    r"""Stamps :math:`t_0 + T\,(i/(n-1))^{q}` over the record's span T (PyNumDiff 0.3's
    irregular test: q = 3/2, denser at the start). Deterministic: the generator is unused."""

    exponent: float = 1.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "exponent", check_real("exponent", self.exponent, gt=0))

    def _times(self, t, dt, rng):
        span = t[-1] - t[0]
        return t[0] + span * np.linspace(0.0, 1.0, t.size) ** self.exponent

    def describe(self) -> str:
        return f"stamps spaced as (i/(n-1))^{self.exponent:g} over the record"


@dataclass(frozen=True, kw_only=True)
class LegacyJostle(SamplingModel):
    r"""The grid moved by :math:`U(-f\Delta t, f\Delta t)` per stamp, the ends too, drawn from
    ``numpy.random.RandomState(seed)`` after ``skipped_normals`` standard normals (an earlier
    PyNumDiff test's stamps: seed 7, 31 normals for its noise, f = 1/3). Fixed: the generator
    a scenario hands it is unused, so every seed has the same stamps."""

    seed: int = 7
    skipped_normals: int = 31
    fraction: float = 1.0 / 3.0

    def _times(self, t, dt, rng):
        legacy = np.random.RandomState(self.seed)
        legacy.randn(self.skipped_normals)
        return t + legacy.uniform(-self.fraction * dt, self.fraction * dt, t.size)

    def describe(self) -> str:
        return f"the grid jostled by U(±{self.fraction:.3g} dt), RandomState({self.seed})"


FUNCTIONS: dict[str, tuple[Signal, str]] = {
    "f0": (Polynomial(coefficients=(1.0,)), "x = 1"),
    "f1": (Polynomial(coefficients=(1.0, 2.0)), "x = 2t + 1"),
    "f2": (Polynomial(coefficients=(1.0, -1.0, 1.0)), "x = t² − t + 1"),
    "f3": (OffsetSine(amplitude=1.0, angular_rad_s=3.0, offset=0.5), "x = sin 3t + 1/2"),
    "f4": (GrowingSine(growth_per_s=1.0, angular_rad_s=5.0), "x = eᵗ sin 5t"),
    "f5": (SteepSine(angular_rad_s=8.0, shift_s=0.1, power=1.5), "x = sin 8t / (t + 0.1)^1.5"),
}
"""PyNumDiff's test functions f0-f5: (signal, formula)."""


def _scenario(function: str, suffix: str = "", sampling=(), how: str = "") -> Scenario:
    signal, formula = FUNCTIONS[function]
    return Scenario(
        name=f"pynumdiff-{function}{suffix}",
        signal=signal,
        noise=NoiseStack((Gaussian(std=NOISE_STD),)),
        dt_s=DT_S,
        duration_s=DURATION_S,
        interior_margin_s=0.0,
        sampling=tuple(sampling),
        description=(
            f"PyNumDiff's test function {function}, {formula}, at 31 samples over 0..3 s "
            f"{how or 'every 0.1 s'}, plus Gaussian noise of standard deviation {NOISE_STD:g} "
            f"({SOURCE}); scored over every sample."
        ),
        preset="default",
    )


SCENARIOS: dict[str, Scenario] = {
    scenario.name: scenario
    for scenario in (
        *(_scenario(function) for function in FUNCTIONS),
        _scenario(
            "f4",
            "-irregular",
            (PowerStamps(exponent=1.5),),
            "at the stamps 3(i/30)^1.5 (PyNumDiff 0.3's irregular test)",
        ),
        _scenario(
            "f4",
            "-jostled",
            (LegacyJostle(),),
            "at the grid jostled by U(±0.1/3 s) drawn by RandomState(7) after its noise (an "
            "earlier revision of PyNumDiff's irregular test)",
        ),
    )
}
"""PyNumDiff's test records by name: ``pynumdiff-f0`` … ``pynumdiff-f5``,
``pynumdiff-f4-irregular`` (0.3's stamps) and ``pynumdiff-f4-jostled`` (the earlier ones)."""


def names() -> list[str]:
    """The record names, in PyNumDiff's order."""
    return list(SCENARIOS)


def get(name: str) -> Scenario:
    """The scenario ``name`` (:data:`SCENARIOS`); ``ValueError`` listing the valid names."""
    try:
        return SCENARIOS[name]
    except (KeyError, TypeError):
        hint = unknown_choice_hint(name, SCENARIOS)
        raise ValueError(f"unknown PyNumDiff test record {name!r}; {hint}") from None
