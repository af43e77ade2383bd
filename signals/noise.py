"""Noise models: composable, seeded, and kept apart from the clean signals.

Each model is a small frozen dataclass whose :meth:`NoiseModel.sample` returns the *additive*
noise for samples ``x`` taken at times ``t``, drawing only from the explicit
``numpy.random.Generator`` it is given. :class:`NoiseStack` adds several models in order, each
from its own child generator, so the draws of one component never depend on how much
randomness the others consumed.

References
----------
.. [1] Q. Guo, M. Gautier, D.-Y. Liu, W. Perruquetti, "Identification of robot dynamic
   parameters using Jacobi differentiator", IEEE/ASME AIM 2015, section III.C.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np

from diffbench.signals._checks import check_bool, check_real, check_rng, check_samples, check_times


class NoiseModel(abc.ABC):
    """Base of every noise model: a frozen dataclass with keyword parameters.

    Subclasses implement :meth:`_sample` on validated input and :meth:`describe`.
    """

    def sample(self, t: np.ndarray, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The additive noise for the samples ``x`` taken at the times ``t``.

        Parameters
        ----------
        t : array_like, shape (n,)
            Sample times in seconds, finite.
        x : array_like, shape (n,) or (n, ...)
            The samples the noise will be added to (time on axis 0), finite.
        rng : numpy.random.Generator
            The only source of randomness (deterministic models ignore it but still require it,
            so every model has one call contract).

        Returns
        -------
        numpy.ndarray
            Noise of the shape of ``x``; the noisy samples are ``x + noise``.

        Raises
        ------
        ValueError
            If ``t`` or ``x`` is malformed or their lengths differ.
        TypeError
            If ``rng`` is not a ``numpy.random.Generator``.
        """
        times = check_times(t)
        samples = check_samples(x, times.shape[0])
        return self._sample(times, samples, check_rng(rng))

    @abc.abstractmethod
    def _sample(self, t: np.ndarray, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The noise, given validated ``t`` (n,), ``x`` (n, ...) and ``rng``."""

    @abc.abstractmethod
    def describe(self) -> str:
        """A short label for result tables, e.g. ``"gaussian(std=0.2)"``."""


def _time_column(values: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Broadcast a per-sample series of shape (n,) to the shape of ``x`` (n, ...)."""
    shaped = values.reshape(values.shape + (1,) * (x.ndim - 1))
    return np.array(np.broadcast_to(shaped, x.shape), dtype=np.float64)


@dataclass(frozen=True, kw_only=True)
class Gaussian(NoiseModel):
    r"""White Gaussian noise, independent from sample to sample.

    .. math:: n_i = \sigma\, \varepsilon_i, \quad \varepsilon_i \sim \mathcal N(0, 1)

    Guo et al. [1]_ add "a normally distributed random noise of amplitude 0.2"; we read
    *amplitude* as the standard deviation, :math:`\sigma = 0.2` (MATLAB's
    ``0.2*randn(...)``), which is the default.

    Parameters
    ----------
    std : float
        :math:`\sigma`, the standard deviation, finite and >= 0 (0 adds nothing).

    References
    ----------
    .. [1] Q. Guo et al., IEEE/ASME AIM 2015, section III.C.

    Examples
    --------
    >>> noise = Gaussian(std=0.2).sample(np.zeros(3), np.ones(3), np.random.default_rng(0))
    >>> noise.shape, bool(np.all(np.abs(noise) < 5 * 0.2))
    ((3,), True)
    """

    std: float = 0.2

    def __post_init__(self) -> None:
        object.__setattr__(self, "std", check_real("std", self.std, ge=0))

    def _sample(self, t: np.ndarray, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return self.std * rng.standard_normal(x.shape)

    def describe(self) -> str:
        return f"gaussian(std={self.std!r})"


@dataclass(frozen=True, kw_only=True)
class Sinusoid(NoiseModel):
    r"""Deterministic sinusoidal disturbance (e.g. a 200 Hz hum); uses no randomness.

    .. math:: n(t) = a \sin(2\pi f t + \varphi)

    Guo et al. [1]_ add "a 200 Hz high frequency sinusoidal wave of amplitude 0.2" (the
    defaults); the paper gives no phase, we take 0.

    Parameters
    ----------
    amplitude : float
        :math:`a`, finite and >= 0 (default 0.2).
    frequency_hz : float
        :math:`f` in Hz, finite and > 0 (default 200).
    phase_rad : float
        :math:`\varphi` in radians, finite (default 0).

    References
    ----------
    .. [1] Q. Guo et al., IEEE/ASME AIM 2015, section III.C.

    Examples
    --------
    >>> noise = Sinusoid(amplitude=0.2, frequency_hz=200.0)
    >>> noise.sample([0.00125], [0.0], np.random.default_rng(0)).round(12).tolist()  # sin(π/2)
    [0.2]
    """

    amplitude: float = 0.2
    frequency_hz: float = 200.0
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "amplitude", check_real("amplitude", self.amplitude, ge=0))
        object.__setattr__(
            self, "frequency_hz", check_real("frequency_hz", self.frequency_hz, gt=0)
        )
        object.__setattr__(self, "phase_rad", check_real("phase_rad", self.phase_rad))

    def _sample(self, t: np.ndarray, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        wave = self.amplitude * np.sin(2.0 * np.pi * self.frequency_hz * t + self.phase_rad)
        return _time_column(wave, x)

    def aliased_frequency_hz(self, dt_s: float) -> float:
        r"""The frequency this sinusoid appears at when sampled every ``dt_s`` seconds.

        .. math:: f_a = \left| f - \frac{1}{\Delta t}\,\mathrm{round}(f\,\Delta t) \right|

        0 means every sample sees the same phase: the disturbance is the constant
        :math:`a \sin\varphi` (nothing at all for :math:`\varphi = 0`), not noise. E.g. 200 Hz
        sampled every 10 ms lands on its own zeros.

        >>> Sinusoid(amplitude=0.2, frequency_hz=200.0).aliased_frequency_hz(0.01)
        0.0
        >>> round(Sinusoid(amplitude=0.2, frequency_hz=200.0).aliased_frequency_hz(0.003), 6)
        133.333333
        """
        dt_s = check_real("dt_s", dt_s, gt=0)
        cycles = self.frequency_hz * dt_s
        folded = abs(cycles - round(cycles))
        return 0.0 if folded < 1e-9 else folded / dt_s

    def describe(self) -> str:
        return (
            f"sinusoid(amplitude={self.amplitude!r}, frequency_hz={self.frequency_hz!r}, "
            f"phase_rad={self.phase_rad!r})"
        )


@dataclass(frozen=True, kw_only=True)
class Poisson(NoiseModel):
    r"""Scaled Poisson counts drawn independently per sample: sparse positive spikes.

    .. math::

        n_i = a\,(K_i - c\,\lambda), \quad K_i \sim \operatorname{Poisson}(\lambda), \quad
        c = 1 \text{ if centered else } 0

    Guo et al. [1]_ add "a Poisson distributed random noise with mean parameter λ = 0.1 of
    amplitude 0.2". We take this literally, as MATLAB's ``0.2*poissrnd(0.1, ...)``: with the
    defaults a sample is 0 with probability :math:`e^{-0.1} \approx 0.905`, jumps by +0.2 with
    probability :math:`0.1\,e^{-0.1} \approx 0.090`, and by +0.4 or more about 0.5 % of the
    time. This noise is **not** zero-mean: its mean is :math:`a\lambda = 0.02` and its
    variance :math:`a^2\lambda = 0.004`. With ``centered=True`` the mean :math:`a\lambda` is
    subtracted, giving a zero-mean variant (not the paper's).

    Parameters
    ----------
    rate : float
        :math:`\lambda`, the Poisson mean per sample, finite and >= 0 (default 0.1).
    amplitude : float
        :math:`a`, the height of one count, finite and >= 0 (default 0.2).
    centered : bool
        Subtract the mean :math:`a\lambda` (default False, the paper's reading).

    References
    ----------
    .. [1] Q. Guo et al., IEEE/ASME AIM 2015, section III.C.
    .. [2] MathWorks, ``poissrnd`` (Statistics and Machine Learning Toolbox).

    Examples
    --------
    >>> Poisson(rate=0.0, amplitude=0.2, centered=True).sample(
    ...     [0.0], [1.0], np.random.default_rng(0)).tolist()
    [0.0]
    """

    rate: float = 0.1
    amplitude: float = 0.2
    centered: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "rate", check_real("rate", self.rate, ge=0))
        object.__setattr__(self, "amplitude", check_real("amplitude", self.amplitude, ge=0))
        object.__setattr__(self, "centered", check_bool("centered", self.centered))

    def _sample(self, t: np.ndarray, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        counts = rng.poisson(self.rate, x.shape).astype(np.float64)
        if self.centered:
            counts -= self.rate
        return self.amplitude * counts

    def describe(self) -> str:
        centered = ", centered=True" if self.centered else ""
        return f"poisson(rate={self.rate!r}, amplitude={self.amplitude!r}{centered})"


@dataclass(frozen=True, kw_only=True)
class Quantisation(NoiseModel):
    r"""Uniform mid-tread quantisation, as by an encoder: the noise it adds to ``x``.

    .. math:: n = \Delta \operatorname{round}(x / \Delta) - x, \quad |n| \le \Delta / 2

    so that ``x + n`` lies on the grid :math:`\Delta\mathbb Z` (ties round to even, as
    ``numpy.round``). Deterministic and dependent on the signal it is applied to: in a
    :class:`NoiseStack` put it last to quantise the already noisy signal.

    Parameters
    ----------
    step : float
        :math:`\Delta`, the quantisation step in the units of ``x``, finite and > 0 (e.g.
        :math:`2\pi/4096` rad for a 12-bit encoder). No default: it is the sensor's.

    References
    ----------
    .. [1] B. Widrow, I. Kollár, *Quantization Noise*, Cambridge University Press, 2008,
       chapter 4.

    Examples
    --------
    >>> Quantisation(step=0.5).sample([0.0, 1.0], [0.3, 1.1], np.random.default_rng(0)).round(
    ...     12).tolist()
    [0.2, -0.1]
    """

    step: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "step", check_real("step", self.step, gt=0))

    def _sample(self, t: np.ndarray, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return self.step * np.round(x / self.step) - x

    def describe(self) -> str:
        return f"quantisation(step={self.step!r})"


@dataclass(frozen=True)
class NoiseStack:
    r"""Several noise models added in order, each drawing from its own child generator.

    .. math::

        y_0 = x, \quad y_k = y_{k-1} + m_k(t, y_{k-1}, g_k), \quad
        \text{noisy} = y_K, \quad \text{noise} = y_K - x

    where :math:`g_1, \dots, g_K` = ``rng.spawn(K)``. Consequences: (i) the draws of model
    :math:`k` depend only on the seed and on its position :math:`k`, not on the other models
    (a Gaussian first in the stack gives the same values whether or not a Poisson follows it,
    and a Poisson in position 2 gives the same counts whatever model is in position 1);
    (ii) models that look at the signal (:class:`Quantisation`) see the noise added before
    them; (iii) an empty stack adds nothing and draws nothing.

    Parameters
    ----------
    models : tuple of NoiseModel
        The models, applied first to last (default: none).

    Examples
    --------
    >>> stack = NoiseStack((Sinusoid(amplitude=1.0, frequency_hz=0.25), Quantisation(step=0.5)))
    >>> noisy, noise = stack.apply([1.0], [0.3], np.random.default_rng(0))
    >>> noisy.tolist(), noise.round(12).tolist()  # round(0.3 + sin(π/2), 0.5) = 1.5
    ([1.5], [1.2])
    """

    models: tuple[NoiseModel, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.models, NoiseModel):
            raise ValueError("`models` must be a tuple of noise models, got a single model")
        try:
            models = tuple(self.models)
        except TypeError:
            raise ValueError(
                f"`models` must be a tuple of noise models, got {self.models!r}"
            ) from None
        for index, model in enumerate(models):
            if not isinstance(model, NoiseModel):
                raise ValueError(
                    f"`models[{index}]` must be a noise model (Gaussian, Sinusoid, Poisson, "
                    f"Quantisation...), got {model!r}"
                )
        object.__setattr__(self, "models", models)

    def apply(
        self, t: np.ndarray, x: np.ndarray, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        """Add every model's noise to ``x``, in order.

        Parameters
        ----------
        t : array_like, shape (n,)
            Sample times in seconds, finite.
        x : array_like, shape (n,) or (n, ...)
            Clean samples (time on axis 0), finite.
        rng : numpy.random.Generator
            Parent generator; ``rng.spawn(len(models))`` gives one child per model (spawning
            advances the parent's spawn counter, so a second call gives fresh noise).

        Returns
        -------
        noisy : numpy.ndarray
            The noisy samples, shape of ``x``.
        noise : numpy.ndarray
            ``noisy - x``.

        Raises
        ------
        ValueError
            If ``t`` or ``x`` is malformed, or ``rng`` cannot spawn children.
        TypeError
            If ``rng`` is not a ``numpy.random.Generator``.
        """
        times = check_times(t)
        clean = check_samples(x, times.shape[0])
        check_rng(rng)
        noisy = clean.copy()
        if self.models:
            try:
                children = rng.spawn(len(self.models))
            except (TypeError, ValueError) as error:
                raise ValueError(
                    f"`rng` cannot spawn independent child generators: {error}"
                ) from None
            for model, child in zip(self.models, children, strict=True):
                noisy = noisy + model.sample(times, noisy, child)
        return noisy, noisy - clean

    def describe(self) -> str:
        """The models' labels joined by ``" + "``, or ``"none"`` for an empty stack."""
        return " + ".join(model.describe() for model in self.models) or "none"
