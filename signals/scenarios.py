"""Named scenarios: a clean signal, a noise stack, a sampling grid and a common interior.

A :class:`Scenario` is everything a benchmark cell needs besides the method: it is realised
for one seed into a :class:`Realisation` (noisy samples plus the exact truth), bit-for-bit
reproducibly. Every method is scored on the same ``interior`` mask, so rankings do not depend
on how far each method's window reaches towards the ends.

References
----------
.. [1] Q. Guo, M. Gautier, D.-Y. Liu, W. Perruquetti, "Identification of robot dynamic
   parameters using Jacobi differentiator", IEEE/ASME AIM 2015, section III.C.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from diffbench.signals._checks import (
    check_real,
    check_seed,
    check_times,
    read_only,
    unknown_choice_hint,
)
from diffbench.signals.clean import (
    Chirp,
    DampedOscillation,
    PaperSines,
    Polynomial,
    Signal,
    SmoothedKink,
    Truth,
)
from diffbench.signals.noise import Gaussian, NoiseStack, Poisson, Quantisation, Sinusoid
from diffbench.signals.stochastic import BandLimited, IntegratedWhiteNoise, Matern
from diffbench.signals.timing import Dropout, Jitter, SamplingModel

_STEPS_RTOL = 1e-9
"""Relative tolerance on ``duration_s / dt_s`` being a whole number of steps."""

_REGISTRY: dict[str, Scenario] = {}


@dataclass(frozen=True, eq=False)
class Realisation:
    """One seeded draw of a scenario: noisy samples, the noise, and the exact truth.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times in seconds: ``dt_s * arange(n)``, or the measured time stamps of a
        scenario with irregular sampling (``uniform`` is then false).
    dt_s : float
        Sampling step in seconds (the nominal one when the sampling is irregular).
    x : numpy.ndarray, shape (n,)
        Noisy samples, ``truth[0] + noise``.
    truth : Truth
        The clean samples and their exact derivatives.
    noise : numpy.ndarray, shape (n,)
        The noise added, ``x - truth[0]`` (bit-exact).
    seed : int
        The seed it was drawn with.
    interior : numpy.ndarray of bool, shape (n,)
        The samples every method is scored on.

    Notes
    -----
    The arrays are stored as read-only copies.
    """

    t: np.ndarray
    dt_s: float
    x: np.ndarray
    truth: Truth
    noise: np.ndarray
    seed: int
    interior: np.ndarray

    def __post_init__(self) -> None:
        t = read_only(check_times(self.t))
        n = t.shape[0]
        for name in ("x", "noise"):
            array = np.asarray(getattr(self, name), dtype=np.float64)
            if array.shape != (n,):
                raise ValueError(f"`{name}` must have shape ({n},), got {array.shape}")
            object.__setattr__(self, name, read_only(array))
        if not isinstance(self.truth, Truth) or self.truth.t.shape != (n,):
            raise ValueError(f"`truth` must be a Truth on the {n} samples of `t`")
        interior = np.array(self.interior, copy=True)
        if interior.dtype != np.bool_ or interior.shape != (n,):
            raise ValueError(
                f"`interior` must be a boolean mask of shape ({n},), "
                f"got {interior.dtype} {interior.shape}"
            )
        interior.setflags(write=False)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "dt_s", check_real("dt_s", self.dt_s, gt=0))
        object.__setattr__(self, "seed", check_seed(self.seed))
        object.__setattr__(self, "interior", interior)

    def stretch(self, cut: slice, interior: np.ndarray) -> Realisation:
        """The samples ``cut`` of this realisation (its times, samples, noise and truth), scored
        on ``interior`` (a boolean mask over the stretch)."""
        t = self.t[cut]
        truth = Truth(t=t, derivatives=tuple(d[cut] for d in self.truth.derivatives))
        return dataclasses.replace(
            self, t=t, x=self.x[cut], noise=self.noise[cut], truth=truth, interior=interior
        )

    @functools.cached_property
    def uniform(self) -> bool:
        """True when the samples lie on the grid ``t[0] + dt_s * arange(n)`` (to 1e-9 dt).
        Computed once (``t`` is read-only): a tuner asks at every setting."""
        grid = self.t[0] + self.dt_s * np.arange(self.t.shape[0])
        return bool(np.max(np.abs(self.t - grid)) <= 1e-9 * self.dt_s)


@dataclass(frozen=True, kw_only=True)
class Scenario:
    r"""A named test case: signal, noise, sampling grid and scoring interior.

    The samples are taken at :math:`t_i = i\,\Delta t`, :math:`i = 0, \dots, N-1`, with
    :math:`N = D / \Delta t + 1` (both ends included). The interior is the set of samples
    at least :math:`m` (``interior_margin_s``) from both ends,
    :math:`m \le t_i \le D - m` (up to :math:`10^{-9}\,\Delta t` of rounding).

    Parameters
    ----------
    name : str
        Registry key, non-empty.
    signal : Signal
        The clean signal (with exact derivatives); a random one
        (:mod:`diffbench.signals.stochastic`) is drawn for each seed from the generator
        ``default_rng([2, seed])``, apart from the noise's and the sampling's.
    noise : NoiseStack
        The noise added to it (an empty stack for a clean scenario).
    dt_s : float
        Sampling step in seconds, finite and > 0.
    duration_s : float
        :math:`D`, finite and > 0, a whole number of steps (within 1e-9 relative).
    interior_margin_s : float
        :math:`m`, finite, >= 0 and < ``duration_s / 2``.
    description : str
        One or two sentences for reports, citing the source.
    preset : str
        Key of the method presets to use on this scenario (``"paper-signal"`` or
        ``"default"``); non-empty.
    sampling : tuple of SamplingModel
        Irregular sampling (:mod:`diffbench.signals.timing`: jitter, dropouts) applied to the
        grid in order, from the generator ``default_rng([1, seed])`` (apart from the noise's,
        so a scenario without it draws exactly the noise it always drew); empty: the grid.

    Examples
    --------
    >>> scenario = get_scenario("paper-signal")
    >>> scenario.t.shape, int(scenario.realise(seed=0).interior.sum())
    ((1001,), 701)
    """

    name: str
    signal: Signal
    noise: NoiseStack
    dt_s: float
    duration_s: float
    interior_margin_s: float
    description: str
    preset: str
    sampling: tuple[SamplingModel, ...] = ()

    def __post_init__(self) -> None:
        if not all(isinstance(model, SamplingModel) for model in self.sampling):
            raise ValueError(f"`sampling` must be a tuple of SamplingModel, got {self.sampling!r}")
        object.__setattr__(self, "sampling", tuple(self.sampling))
        for label in ("name", "description", "preset"):
            value = getattr(self, label)
            if not isinstance(value, str) or not value:
                raise ValueError(f"`{label}` must be a non-empty string, got {value!r}")
        if not isinstance(self.signal, Signal):
            raise ValueError(f"`signal` must be a signals.Signal instance, got {self.signal!r}")
        if not isinstance(self.noise, NoiseStack):
            raise ValueError(f"`noise` must be a NoiseStack, got {self.noise!r}")
        dt_s = check_real("dt_s", self.dt_s, gt=0)
        duration_s = check_real("duration_s", self.duration_s, gt=0)
        steps = duration_s / dt_s
        if abs(steps - round(steps)) > _STEPS_RTOL * steps or round(steps) < 1:
            raise ValueError(
                f"`duration_s` must be a whole number of steps of `dt_s` = {dt_s!r}, "
                f"got {duration_s!r} ({steps!r} steps)"
            )
        margin = check_real("interior_margin_s", self.interior_margin_s, ge=0)
        if not margin < duration_s / 2:
            raise ValueError(
                f"`interior_margin_s` must be < half of `duration_s` ({duration_s / 2!r}), "
                f"got {margin!r}"
            )
        object.__setattr__(self, "dt_s", dt_s)
        object.__setattr__(self, "duration_s", duration_s)
        object.__setattr__(self, "interior_margin_s", margin)

    @property
    def n_samples(self) -> int:
        """:math:`N = D / \\Delta t + 1`."""
        return round(self.duration_s / self.dt_s) + 1

    @property
    def t(self) -> np.ndarray:
        """Sample times in seconds, ``dt_s * arange(n_samples)``."""
        return self.dt_s * np.arange(self.n_samples)

    @property
    def interior(self) -> np.ndarray:
        """The samples of the uniform times :attr:`t` scored as the interior: at least
        ``interior_margin_s`` from both ends."""
        return self._interior(self.t)

    def _interior(self, t: np.ndarray) -> np.ndarray:
        slack = 1e-9 * self.dt_s
        end = t[-1]
        margin = self.interior_margin_s
        return (t - t[0] >= margin - slack) & (end - t >= margin - slack)

    def realise(self, seed: int) -> Realisation:
        """Draw the noisy samples for ``seed``: bit-for-bit the same for the same seed.

        Parameters
        ----------
        seed : int
            Non-negative; the noise comes from ``numpy.random.default_rng(seed)``.

        Returns
        -------
        Realisation

        Raises
        ------
        ValueError
            If ``seed`` is not a non-negative integer.
        """
        seed = check_seed(seed)
        if self.n_samples <= CACHED_SAMPLES:
            return _cached_draw(self, seed)
        return self._draw(seed)

    def _draw(self, seed: int) -> Realisation:
        t = self.t
        if self.sampling:
            rng = np.random.default_rng([1, seed])
            for model in self.sampling:
                t = model.times(t, self.dt_s, rng)
        if getattr(self.signal, "random", False):  # a realisation of its own, apart from the noise
            truth = self.signal.draw(t, np.random.default_rng([2, seed]))
        else:
            truth = self.signal.evaluate(t)
        noisy, noise = self.noise.apply(t, truth[0], np.random.default_rng(seed))
        return Realisation(
            t=t,
            dt_s=self.dt_s,
            x=noisy,
            truth=truth,
            noise=noise,
            seed=seed,
            interior=self._interior(t),
        )


CACHED_SAMPLES = 20_000
"""Records up to this many samples are kept once drawn (:func:`_cached_draw`)."""

CACHED_REALISATIONS = 64
"""How many drawn realisations are kept: a study's every seed of a few scenarios."""


@functools.lru_cache(maxsize=CACHED_REALISATIONS)
def _cached_draw(scenario: Scenario, seed: int) -> Realisation:
    """``scenario``'s realisation for ``seed``, drawn once for every cell and tuning that asks
    (its arrays are read-only, so one object serves them all): a random signal's path costs
    10-130 ms to draw (the limit study's Gauss-Markov recursions and band-limited sums),
    asked for again by each of its methods and roles. At most ``CACHED_REALISATIONS`` records
    of at most ``CACHED_SAMPLES`` samples: under 70 MB."""
    return scenario._draw(seed)


def register_scenario(scenario: Scenario) -> Scenario:
    """Add ``scenario`` to the registry under its name; ``ValueError`` if the name is taken."""
    if not isinstance(scenario, Scenario):
        raise ValueError(f"`scenario` must be a Scenario, got {scenario!r}")
    if scenario.name in _REGISTRY:
        raise ValueError(f"a scenario named {scenario.name!r} is already registered")
    _REGISTRY[scenario.name] = scenario
    return scenario


def available_scenarios() -> list[str]:
    """Names of the registered scenarios, sorted."""
    return sorted(_REGISTRY)


def get_scenario(name: str) -> Scenario:
    """The scenario registered under ``name``; ``ValueError`` listing the valid names if none."""
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        hint = unknown_choice_hint(name, available_scenarios())
        raise ValueError(f"unknown scenario {name!r}; {hint}") from None


_PAPER_NOISE = (
    Gaussian(std=0.2),
    Sinusoid(amplitude=0.2, frequency_hz=200.0, phase_rad=0.0),
    Poisson(rate=0.1, amplitude=0.2),
)
_PAPER_SOURCE = "Guo et al., AIM 2015, section III.C"

register_scenario(
    Scenario(
        name="paper-signal",
        signal=PaperSines(frequencies_hz=(4.0, 9.0, 15.0), amplitude=1.0),
        noise=NoiseStack(_PAPER_NOISE),
        dt_s=1e-3,
        duration_s=1.0,
        interior_margin_s=0.15,
        description=(
            "sin(2π·4t) + sin(2π·9t) + sin(2π·15t) sampled at 1 ms for 1 s, plus 0.2·N(0,1) "
            "+ 0.2·sin(2π·200t) + 0.2·Poisson(λ=0.1) noise: the test case of "
            f"{_PAPER_SOURCE}."
        ),
        preset="paper-signal",
    )
)


def _paper_record(name: str, duration_s: float, description: str) -> Scenario:
    """The paper's signal and noise, step and presets, over ``duration_s``."""
    return Scenario(
        name=name,
        signal=PaperSines(frequencies_hz=(4.0, 9.0, 15.0), amplitude=1.0),
        noise=NoiseStack(_PAPER_NOISE),
        dt_s=1e-3,
        duration_s=duration_s,
        interior_margin_s=0.15,
        description=description,
        preset="paper-signal",
    )


register_scenario(
    _paper_record(
        "paper-signal-4937ms",
        4.937,
        "paper-signal over 4.937 s, not a whole number of periods of 4, 9 and 15 Hz: a "
        "record whose ends do not meet, as a measured one (spectral methods cannot lean on "
        "periodicity).",
    )
)
register_scenario(
    _paper_record(
        "paper-signal-999ms",
        0.999,
        "paper-signal with 1000 samples (0 to 0.999 s) instead of 1001: its last sample is "
        "not the zero every component has at 1 s, so its ends do not meet and an odd "
        "extension is no longer exact there.",
    )
)
register_scenario(
    Scenario(
        name="kink",
        signal=SmoothedKink(kink_s=0.5, width_s=0.005, amplitude=1.0),
        noise=NoiseStack(_PAPER_NOISE),
        dt_s=1e-3,
        duration_s=1.0,
        interior_margin_s=0.15,
        description=(
            "|t - 0.5| smoothed by a Gaussian of 5 ms standard deviation (its slope turns from "
            "-1 to 1 within about 20 ms) sampled at 1 ms for 1 s, with the noise of "
            "paper-signal: a sharp feature in a smooth record, which a global low-pass blurs "
            "and a local fit rings around."
        ),
        preset="default",
    )
)
register_scenario(
    Scenario(
        name="paper-signal-clean",
        signal=PaperSines(frequencies_hz=(4.0, 9.0, 15.0), amplitude=1.0),
        noise=NoiseStack(()),
        dt_s=1e-3,
        duration_s=1.0,
        interior_margin_s=0.15,
        description=(
            "The signal of paper-signal without noise (the bias of each method alone); "
            f"{_PAPER_SOURCE}."
        ),
        preset="paper-signal",
    )
)
register_scenario(
    Scenario(
        name="paper-signal-quantised",
        signal=PaperSines(frequencies_hz=(4.0, 9.0, 15.0), amplitude=1.0),
        noise=NoiseStack((*_PAPER_NOISE, Quantisation(step=1e-3))),
        dt_s=1e-3,
        duration_s=1.0,
        interior_margin_s=0.15,
        description=(
            "paper-signal whose noisy samples are then quantised with a step of 1e-3 "
            f"(an encoder); extends {_PAPER_SOURCE}."
        ),
        preset="paper-signal",
    )
)
register_scenario(
    Scenario(
        name="chirp-gaussian",
        signal=Chirp(start_hz=1.0, rate_hz_per_s=9.5, amplitude=1.0, phase_rad=0.0),
        noise=NoiseStack((Gaussian(std=0.05),)),
        dt_s=1e-3,
        duration_s=2.0,
        interior_margin_s=0.2,
        description=(
            "Linear chirp sweeping 1 Hz to 20 Hz over 2 s, sampled at 1 ms, with Gaussian "
            "noise of standard deviation 0.05: how each method tracks a rising frequency."
        ),
        preset="default",
    )
)
register_scenario(
    Scenario(
        name="damped-gaussian",
        signal=DampedOscillation(natural_hz=5.0, damping_ratio=0.1, amplitude=1.0, phase_rad=0.0),
        noise=NoiseStack((Gaussian(std=0.02),)),
        dt_s=1e-3,
        duration_s=2.0,
        interior_margin_s=0.2,
        description=(
            "Free oscillation of a 5 Hz second-order system with damping ratio 0.1, sampled "
            "at 1 ms for 2 s, with Gaussian noise of standard deviation 0.02."
        ),
        preset="default",
    )
)
register_scenario(
    Scenario(
        name="pendulum-500hz-jitter",
        signal=DampedOscillation(natural_hz=1.5, damping_ratio=0.03, amplitude=1.0, phase_rad=0.0),
        noise=NoiseStack((Gaussian(std=0.01),)),
        dt_s=2e-3,
        duration_s=5.0,
        interior_margin_s=0.25,
        sampling=(Jitter(fraction=0.3),),
        description=(
            "A record a user would have: 5 s of a lightly damped 1.5 Hz oscillation (damping "
            "ratio 0.03) logged at 500 Hz with stamps jittered by up to 30 % of the step, "
            "with Gaussian noise of standard deviation 0.01 (the example of `recommend`)."
        ),
        preset="default",
    )
)
register_scenario(
    Scenario(
        name="polynomial-clean",
        signal=Polynomial(coefficients=(0.5, 1.0, -1.5, 0.5)),
        noise=NoiseStack(()),
        dt_s=1e-2,
        duration_s=2.0,
        interior_margin_s=0.2,
        description=(
            "The cubic 0.5 + t - 1.5t² + 0.5t³ sampled at 10 ms for 2 s, without noise: "
            "every method exact on cubics must reproduce it to rounding."
        ),
        preset="default",
    )
)


# --- the scenario grid: noise type x noise level x sampling step ---------------------------
GRID_NOISE_LEVELS = (0.02, 0.2, 0.5)
GRID_STEPS_S = (1e-4, 1e-3, 1e-2)
GRID_NOISE_TYPES = ("gaussian", "sinusoid", "poisson", "combined")


def _grid_noise(kind: str, level: float) -> NoiseStack:
    models = {
        "gaussian": (Gaussian(std=level),),
        "sinusoid": (Sinusoid(amplitude=level, frequency_hz=200.0),),
        "poisson": (Poisson(rate=0.1, amplitude=level),),
    }
    if kind == "combined":
        return NoiseStack(models["gaussian"] + models["sinusoid"] + models["poisson"])
    return NoiseStack(models[kind])


def grid_scenario_name(kind: str, level: float, step_s: float) -> str:
    """The name of a grid scenario, e.g. ``grid-sinusoid-0.2-10ms``."""
    return f"grid-{kind}-{level:g}-{step_s * 1e3:g}ms"


GRID_SAMPLINGS = {"jitter": Jitter(fraction=0.3), "dropout": Dropout(fraction=0.1)}
"""Irregular sampling in the grid: the stamps jittered by ±30 % of the step, or 10 % of the
samples dropped; with Gaussian noise of level :data:`GRID_SAMPLING_LEVEL` at the steps of
:data:`GRID_SAMPLING_STEPS_S`."""
GRID_SAMPLING_LEVEL = 0.2
GRID_SAMPLING_STEPS_S = (1e-3, 1e-2)


def grid_sampling_name(sampling: str, step_s: float) -> str:
    """The name of an irregular-sampling grid scenario, e.g. ``grid-gaussian-0.2-1ms-jitter``."""
    return f"{grid_scenario_name('gaussian', GRID_SAMPLING_LEVEL, step_s)}-{sampling}"


def grid_scenario_names() -> list[str]:
    """Every scenario of the grid (noise type x level x step, then the irregular sampling)."""
    return [
        grid_scenario_name(kind, level, step)
        for kind in GRID_NOISE_TYPES
        for level in GRID_NOISE_LEVELS
        for step in GRID_STEPS_S
    ] + [
        grid_sampling_name(sampling, step)
        for sampling in GRID_SAMPLINGS
        for step in GRID_SAMPLING_STEPS_S
    ]


def vanishing_disturbances(scenario: Scenario) -> list[str]:
    """The sinusoidal disturbances of ``scenario`` that sampling at its step aliases to 0 Hz
    (constant samples, so no noise at all): e.g. 200 Hz at Ts = 10 ms."""
    return [
        model.describe()
        for model in scenario.noise.models
        if isinstance(model, Sinusoid) and model.aliased_frequency_hz(scenario.dt_s) == 0.0
    ]


for _kind in GRID_NOISE_TYPES:
    for _level in GRID_NOISE_LEVELS:
        for _step in GRID_STEPS_S:
            register_scenario(
                Scenario(
                    name=grid_scenario_name(_kind, _level, _step),
                    signal=PaperSines(frequencies_hz=(4.0, 9.0, 15.0), amplitude=1.0),
                    noise=_grid_noise(_kind, _level),
                    dt_s=_step,
                    duration_s=0.93,
                    interior_margin_s=0.15,
                    description=(
                        f"The paper's 4/9/15 Hz signal with {_kind} noise of amplitude {_level:g}"
                        f" (the paper's kinds: 200 Hz sinusoid, Poisson rate 0.1), sampled every "
                        f"{_step * 1e3:g} ms for 0.93 s (not a whole number of periods)."
                    ),
                    preset="default",
                )
            )

for _sampling, _model in GRID_SAMPLINGS.items():
    for _step in GRID_SAMPLING_STEPS_S:
        register_scenario(
            Scenario(
                name=grid_sampling_name(_sampling, _step),
                signal=PaperSines(frequencies_hz=(4.0, 9.0, 15.0), amplitude=1.0),
                noise=_grid_noise("gaussian", GRID_SAMPLING_LEVEL),
                dt_s=_step,
                duration_s=0.93,
                interior_margin_s=0.15,
                description=(
                    f"The paper's 4/9/15 Hz signal with gaussian noise of amplitude "
                    f"{GRID_SAMPLING_LEVEL:g}, sampled every {_step * 1e3:g} ms for 0.93 s with "
                    f"{_model.describe()}: scored at the measured times."
                ),
                preset="default",
                sampling=(_model,),
            )
        )


# --- random signals with a known spectrum, where the least possible error is known ----------
LIMIT_NOISE_LEVELS = (0.001, 0.01, 0.1)
"""Standard deviations of the white Gaussian noise of the limit scenarios."""
LIMIT_SIGNALS = {
    "matern52": Matern(smoothness=2.5, length_scale_s=0.1, std=1.0),
    "matern72": Matern(smoothness=3.5, length_scale_s=0.1, std=1.0),
    "iwn2": IntegratedWhiteNoise(times=2, intensity=1e2),
    "iwn3": IntegratedWhiteNoise(times=3, intensity=1e6),
    "band20": BandLimited(band_hz=20.0, std=1.0, lines=600),
}
"""The random signals of the limit scenarios (:mod:`diffbench.signals.stochastic`): at 1 ms
and these noise levels the optimal smoother's half-gain bandwidth lies between about 5 and 90 Hz
(the band-limited one's is its band, 20 Hz: its signal stands far above the noise inside it).
"""
LIMIT_DT_S, LIMIT_DURATION_S, LIMIT_MARGIN_S = 1e-3, 3.0, 1.0


def limit_scenario_name(family: str, noise_std: float) -> str:
    """The name of a limit scenario, e.g. ``limit-matern52-0.01``."""
    return f"limit-{family}-{noise_std:g}"


def limit_scenario_names() -> list[str]:
    """Every limit scenario (signal family x noise level)."""
    return [
        limit_scenario_name(family, level)
        for family in LIMIT_SIGNALS
        for level in LIMIT_NOISE_LEVELS
    ]


for _family, _signal in LIMIT_SIGNALS.items():
    for _level in LIMIT_NOISE_LEVELS:
        register_scenario(
            Scenario(
                name=limit_scenario_name(_family, _level),
                signal=_signal,
                noise=NoiseStack((Gaussian(std=_level),)),
                dt_s=LIMIT_DT_S,
                duration_s=LIMIT_DURATION_S,
                interior_margin_s=LIMIT_MARGIN_S,
                description=(
                    f"A new realisation of {_signal.describe()} for each seed, sampled every "
                    f"{LIMIT_DT_S * 1e3:g} ms for {LIMIT_DURATION_S:g} s, plus white Gaussian "
                    f"noise of standard deviation {_level:g}; scored on the middle "
                    f"{LIMIT_DURATION_S - 2 * LIMIT_MARGIN_S:g} s, where the least error any "
                    + (
                        "method can reach is the exact posterior's on this record"
                        if isinstance(_signal, BandLimited)
                        else "method can reach is the infinite record's"
                    )
                    + " (diffbench.signals.stochastic)."
                ),
                preset="default",
            )
        )
