"""Clean test signals with their exact derivatives.

A signal is one small frozen dataclass registered by name with :func:`register_signal`. Its
keyword parameters carry their units in their names and are validated on construction; its
:meth:`Signal.evaluate` returns a :class:`Truth` holding the samples and the analytic first
and second derivatives (never finite differences), so every error we report is measured
against the exact value.

References
----------
.. [1] Q. Guo, M. Gautier, D.-Y. Liu, W. Perruquetti, "Identification of robot dynamic
   parameters using Jacobi differentiator", IEEE/ASME AIM 2015, Busan, section III.C.
"""

from __future__ import annotations

import abc
import dataclasses
import numbers
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

import numpy as np
from numpy.polynomial import polynomial as npoly
from scipy import special

from diffbench.signals._checks import (
    check_real,
    check_real_tuple,
    check_times,
    read_only,
    unknown_choice_hint,
)

MAX_ORDER = 2
"""Highest derivative order every signal provides exactly."""

_REGISTRY: dict[str, type[Signal]] = {}

SignalT = TypeVar("SignalT", bound="Signal")


@dataclass(frozen=True, eq=False)
class Truth:
    """Exact samples of a clean signal and of its derivatives.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times in seconds.
    derivatives : tuple of numpy.ndarray
        ``(x, dx/dt, d²x/dt²)``, each of shape (n,): orders 0, 1 and 2.

    Notes
    -----
    The arrays are stored as read-only float64 copies. ``truth[k]`` is the derivative of
    order ``k`` (0, 1 or 2).

    Examples
    --------
    >>> truth = Truth(t=np.array([0.0, 1.0]), derivatives=(np.ones(2), np.zeros(2), np.zeros(2)))
    >>> truth[0].tolist(), truth[1].tolist()
    ([1.0, 1.0], [0.0, 0.0])
    """

    t: np.ndarray
    derivatives: tuple[np.ndarray, ...]

    def __post_init__(self) -> None:
        t = read_only(check_times(self.t))
        derivatives = tuple(self.derivatives)
        if len(derivatives) != MAX_ORDER + 1:
            raise ValueError(
                f"`derivatives` must hold the orders 0..{MAX_ORDER} ({MAX_ORDER + 1} arrays), "
                f"got {len(derivatives)}"
            )
        arrays = []
        for order, values in enumerate(derivatives):
            array = np.asarray(values, dtype=np.float64)
            if array.shape != t.shape:
                raise ValueError(
                    f"`derivatives[{order}]` must have the shape of `t` {t.shape}, "
                    f"got {array.shape}"
                )
            arrays.append(read_only(array))
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "derivatives", tuple(arrays))

    def __getitem__(self, order: int) -> np.ndarray:
        if (
            isinstance(order, (bool, np.bool_))
            or not isinstance(order, numbers.Integral)
            or not 0 <= order <= MAX_ORDER
        ):
            raise ValueError(f"`order` must be an integer in 0..{MAX_ORDER}, got {order!r}")
        return self.derivatives[int(order)]


class Signal(abc.ABC):
    """Base of every clean signal: a frozen dataclass with keyword parameters.

    Subclasses implement :meth:`_derivatives` on validated times; :meth:`evaluate` checks ``t``
    and wraps the result in a :class:`Truth`. ``name`` is set by :func:`register_signal`.
    """

    name: ClassVar[str] = ""

    def evaluate(self, t: np.ndarray) -> Truth:
        """Samples and exact first and second derivatives at the times ``t``.

        Parameters
        ----------
        t : array_like, shape (n,)
            Sample times in seconds: 1-D, non-empty, finite (any order, any spacing).

        Returns
        -------
        Truth
            ``x(t)``, ``ẋ(t)`` and ``ẍ(t)``, computed analytically.

        Raises
        ------
        ValueError
            If ``t`` is not a non-empty 1-D array of finite numbers.
        """
        times = check_times(t)
        return Truth(t=times, derivatives=tuple(self._derivatives(times)))

    @abc.abstractmethod
    def _derivatives(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(x, ẋ, ẍ)`` at the validated 1-D float64 times ``t``."""

    def describe(self) -> str:
        """A short label with every parameter, e.g. ``"chirp(start_hz=1.0, ...)"``."""
        values = ", ".join(
            f"{field.name}={getattr(self, field.name)!r}" for field in dataclasses.fields(self)
        )
        return f"{self.name}({values})"


def register_signal(name: str) -> Callable[[type[SignalT]], type[SignalT]]:
    """Class decorator registering a :class:`Signal` dataclass under ``name``.

    Raises
    ------
    ValueError
        If ``name`` is empty or already registered.
    TypeError
        If the decorated class is not a frozen dataclass subclassing :class:`Signal`.
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"`name` must be a non-empty string, got {name!r}")

    def decorate(cls: type[SignalT]) -> type[SignalT]:
        if not (isinstance(cls, type) and issubclass(cls, Signal)):
            raise TypeError(f"signal {name!r} must subclass signals.Signal, got {cls!r}")
        if not (dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen):
            raise TypeError(f"signal {name!r} must be a frozen dataclass")
        if name in _REGISTRY:
            raise ValueError(
                f"a signal named {name!r} is already registered ({_REGISTRY[name].__qualname__})"
            )
        cls.name = name
        _REGISTRY[name] = cls
        return cls

    return decorate


def available_signals() -> list[str]:
    """Names of the registered signals, sorted."""
    return sorted(_REGISTRY)


def signal_class(name: str) -> type[Signal]:
    """The class registered under ``name``; ``ValueError`` listing the valid names if none."""
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        hint = unknown_choice_hint(name, available_signals())
        raise ValueError(f"unknown signal {name!r}; {hint}") from None


def get_signal(name: str, **params: Any) -> Signal:
    """Construct the signal registered under ``name`` with keyword parameters ``params``.

    Raises
    ------
    ValueError
        If ``name`` is unknown (the message lists the valid names), if a parameter is not one
        of the signal's (the message names it and lists the valid ones), or if a value is out
        of range.

    Examples
    --------
    >>> get_signal("polynomial", coefficients=(1.0, 2.0)).evaluate([0.0, 1.0])[0].tolist()
    [1.0, 3.0]
    """
    cls = signal_class(name)
    valid = sorted(field.name for field in dataclasses.fields(cls))
    unknown = sorted(set(params) - set(valid))
    if unknown:
        names = ", ".join(f"`{key}`" for key in unknown)
        raise ValueError(
            f"unknown parameter {names} for signal {name!r}; valid parameters: "
            f"{', '.join(valid) or '(none)'}"
        )
    return cls(**params)


@register_signal("paper_sines")
@dataclass(frozen=True, kw_only=True)
class PaperSines(Signal):
    r"""Sum of equal-amplitude sines: the test signal of Guo et al. [1]_, section III.C.

    .. math::

        x(t) = A \sum_k \sin(2\pi f_k t), \quad
        \dot x(t) = A \sum_k 2\pi f_k \cos(2\pi f_k t), \quad
        \ddot x(t) = -A \sum_k (2\pi f_k)^2 \sin(2\pi f_k t)

    Parameters
    ----------
    frequencies_hz : tuple of float
        The frequencies :math:`f_k` in Hz, each finite and > 0 (default 4, 9 and 15 Hz).
    amplitude : float
        The common amplitude :math:`A`, finite and > 0 (default 1).

    References
    ----------
    .. [1] Q. Guo, M. Gautier, D.-Y. Liu, W. Perruquetti, "Identification of robot dynamic
       parameters using Jacobi differentiator", IEEE/ASME AIM 2015, section III.C.

    Examples
    --------
    At :math:`t = 0` every sine is 0 and :math:`\dot x = 2\pi(4 + 9 + 15) = 56\pi`:

    >>> truth = PaperSines().evaluate([0.0])
    >>> round(float(truth[1][0] / np.pi), 9)
    56.0
    """

    frequencies_hz: tuple[float, ...] = (4.0, 9.0, 15.0)
    amplitude: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "frequencies_hz", check_real_tuple("frequencies_hz", self.frequencies_hz, gt=0)
        )
        object.__setattr__(self, "amplitude", check_real("amplitude", self.amplitude, gt=0))

    def _derivatives(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        omega = 2.0 * np.pi * np.asarray(self.frequencies_hz)[:, None]
        phase = omega * t[None, :]
        sin, cos = np.sin(phase), np.cos(phase)
        a = self.amplitude
        return (
            a * sin.sum(axis=0),
            a * (omega * cos).sum(axis=0),
            -a * (omega**2 * sin).sum(axis=0),
        )


@register_signal("chirp")
@dataclass(frozen=True, kw_only=True)
class Chirp(Signal):
    r"""Linear chirp: a sine whose instantaneous frequency rises linearly with time.

    .. math::

        \theta(t) = 2\pi\left(f_0 t + \tfrac{k}{2} t^2\right) + \varphi, \quad
        x = A \sin\theta, \quad
        \dot x = A \dot\theta \cos\theta, \quad
        \ddot x = A\left(\ddot\theta \cos\theta - \dot\theta^2 \sin\theta\right)

    with :math:`\dot\theta = 2\pi(f_0 + k t)` and :math:`\ddot\theta = 2\pi k`; the
    instantaneous frequency is :math:`f_0 + k t` Hz.

    Parameters
    ----------
    start_hz : float
        :math:`f_0`, the frequency at :math:`t = 0` in Hz, finite and >= 0 (default 1).
    rate_hz_per_s : float
        :math:`k`, the sweep rate in Hz/s, finite, any sign (default 9.5: 1 Hz to 20 Hz in 2 s).
    amplitude : float
        :math:`A`, finite and > 0 (default 1).
    phase_rad : float
        :math:`\varphi` in radians, finite (default 0).

    References
    ----------
    .. [1] A. V. Oppenheim, R. W. Schafer, *Discrete-Time Signal Processing*, 3rd ed.,
       Pearson, 2010 (linear FM / chirp signals); see also ``scipy.signal.chirp``.

    Examples
    --------
    >>> truth = Chirp(start_hz=1.0, rate_hz_per_s=0.0).evaluate([0.25])
    >>> [round(float(v[0]), 12) for v in truth.derivatives]  # sin(π/2) = 1
    [1.0, 0.0, -39.478417604357]
    """

    start_hz: float = 1.0
    rate_hz_per_s: float = 9.5
    amplitude: float = 1.0
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "start_hz", check_real("start_hz", self.start_hz, ge=0))
        object.__setattr__(self, "rate_hz_per_s", check_real("rate_hz_per_s", self.rate_hz_per_s))
        object.__setattr__(self, "amplitude", check_real("amplitude", self.amplitude, gt=0))
        object.__setattr__(self, "phase_rad", check_real("phase_rad", self.phase_rad))

    def _derivatives(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        two_pi = 2.0 * np.pi
        theta = two_pi * (self.start_hz * t + 0.5 * self.rate_hz_per_s * t**2) + self.phase_rad
        theta_dot = two_pi * (self.start_hz + self.rate_hz_per_s * t)
        theta_ddot = two_pi * self.rate_hz_per_s
        sin, cos = np.sin(theta), np.cos(theta)
        a = self.amplitude
        return (
            a * sin,
            a * theta_dot * cos,
            a * (theta_ddot * cos - theta_dot**2 * sin),
        )


@register_signal("polynomial")
@dataclass(frozen=True, kw_only=True)
class Polynomial(Signal):
    r"""Polynomial in increasing powers; derivatives by ``numpy.polynomial.polynomial``.

    .. math::

        x(t) = \sum_{j=0}^{d} c_j t^j, \quad
        x^{(n)}(t) = \sum_{j=n}^{d} \frac{j!}{(j-n)!} c_j t^{j-n}

    Parameters
    ----------
    coefficients : tuple of float
        :math:`(c_0, c_1, \dots, c_d)`, non-empty, finite. The default,
        :math:`0.5 + t - 1.5 t^2 + 0.5 t^3`, is a cubic with turning points at
        :math:`t = 1 \pm 1/\sqrt{3}` s, both inside [0, 2] s.

    References
    ----------
    .. [1] NumPy, ``numpy.polynomial.polynomial.polyder`` and ``polyval``.

    Examples
    --------
    >>> truth = Polynomial(coefficients=(1.0, 2.0, 3.0)).evaluate([2.0])  # 1 + 2t + 3t²
    >>> [float(v[0]) for v in truth.derivatives]
    [17.0, 14.0, 6.0]
    """

    coefficients: tuple[float, ...] = (0.5, 1.0, -1.5, 0.5)

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "coefficients", check_real_tuple("coefficients", self.coefficients)
        )

    def _derivatives(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        c = np.asarray(self.coefficients, dtype=np.float64)
        x, dx, ddx = (
            npoly.polyval(t, npoly.polyder(c, order)) * np.ones_like(t)
            for order in range(MAX_ORDER + 1)
        )
        return x, dx, ddx


@register_signal("damped_oscillation")
@dataclass(frozen=True, kw_only=True)
class DampedOscillation(Signal):
    r"""Under-damped free oscillation of a second-order system.

    .. math::

        x(t) = A e^{-\zeta\omega t} \sin(\omega_d t + \varphi)
             = \operatorname{Im}\left(A e^{s t + i\varphi}\right), \quad
        x^{(n)}(t) = \operatorname{Im}\left(A s^n e^{s t + i\varphi}\right)

    with :math:`\omega = 2\pi f_n`, :math:`\omega_d = \omega\sqrt{1 - \zeta^2}` and
    :math:`s = -\zeta\omega + i\omega_d`.

    Parameters
    ----------
    natural_hz : float
        :math:`f_n`, the undamped natural frequency in Hz, finite and > 0 (default 5).
    damping_ratio : float
        :math:`\zeta`, in [0, 1) (under-damped; 0 is a pure sine) (default 0.1).
    amplitude : float
        :math:`A`, finite and > 0 (default 1).
    phase_rad : float
        :math:`\varphi` in radians, finite (default 0).

    References
    ----------
    .. [1] K. Ogata, *Modern Control Engineering*, 5th ed., Prentice Hall, 2010,
       section 5-3 (second-order systems).

    Examples
    --------
    With :math:`\zeta = 0`, :math:`\varphi = 0`: :math:`\dot x(0) = A\omega`.

    >>> truth = DampedOscillation(natural_hz=1.0, damping_ratio=0.0).evaluate([0.0])
    >>> round(float(truth[1][0] / np.pi), 12)
    2.0
    """

    natural_hz: float = 5.0
    damping_ratio: float = 0.1
    amplitude: float = 1.0
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "natural_hz", check_real("natural_hz", self.natural_hz, gt=0))
        object.__setattr__(
            self, "damping_ratio", check_real("damping_ratio", self.damping_ratio, ge=0, lt=1)
        )
        object.__setattr__(self, "amplitude", check_real("amplitude", self.amplitude, gt=0))
        object.__setattr__(self, "phase_rad", check_real("phase_rad", self.phase_rad))

    def _derivatives(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        omega = 2.0 * np.pi * self.natural_hz
        zeta = self.damping_ratio
        s = complex(-zeta * omega, omega * np.sqrt(1.0 - zeta**2))
        z = self.amplitude * np.exp(s * t + 1j * self.phase_rad)
        return z.imag.copy(), (s * z).imag, (s**2 * z).imag


@register_signal("smoothed_kink")
@dataclass(frozen=True, kw_only=True)
class SmoothedKink(Signal):
    r"""The kink :math:`A|t - t_0|` smoothed by a Gaussian of standard deviation
    :math:`\sigma`: a slope that turns from :math:`-A` to :math:`A` within a few
    :math:`\sigma`, the test of a differentiator's resolution (a global low-pass blurs the
    turn, a local fit rings around it).

    .. math::

        x(t) = A\left(u \operatorname{erf}\frac{u}{\sigma\sqrt 2}
               + \sigma\sqrt{2/\pi}\, e^{-u^2 / 2\sigma^2}\right), \quad
        \dot x(t) = A \operatorname{erf}\frac{u}{\sigma\sqrt 2}, \quad
        \ddot x(t) = \frac{A}{\sigma}\sqrt{2/\pi}\, e^{-u^2 / 2\sigma^2}

    with :math:`u = t - t_0`: :math:`x = A\,\mathbb E|u + \sigma Z|`, Z standard normal.

    Parameters
    ----------
    kink_s : float
        :math:`t_0`, the time of the turn in seconds, finite (default 0.5).
    width_s : float
        :math:`\sigma`, the smoothing's standard deviation in seconds, finite and > 0
        (default 0.1; the ``kink`` scenario's is 0.005).
    amplitude : float
        :math:`A`, finite and > 0 (default 1).

    References
    ----------
    .. [1] M. Abramowitz, I. A. Stegun, *Handbook of Mathematical Functions*, Dover, 1964,
       7.1.1 (erf) and 26.2 (the normal law).

    Examples
    --------
    The turn itself: :math:`\dot x(t_0) = 0`, :math:`\ddot x(t_0) = A\sqrt{2/\pi}/\sigma`.

    >>> truth = SmoothedKink(kink_s=0.5, width_s=0.01).evaluate([0.5])
    >>> float(truth[1][0]), round(float(truth[2][0]), 6)
    (0.0, 79.788456)
    """

    kink_s: float = 0.5
    width_s: float = 0.1
    amplitude: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "kink_s", check_real("kink_s", self.kink_s))
        object.__setattr__(self, "width_s", check_real("width_s", self.width_s, gt=0))
        object.__setattr__(self, "amplitude", check_real("amplitude", self.amplitude, gt=0))

    def _derivatives(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        u = t - self.kink_s
        sigma = self.width_s
        slope = special.erf(u / (sigma * np.sqrt(2.0)))
        bell = np.sqrt(2.0 / np.pi) * np.exp(-0.5 * (u / sigma) ** 2)
        a = self.amplitude
        return a * (u * slope + sigma * bell), a * slope, a * bell / sigma
