"""Dynamical systems with known equations: the truth of the SINDy discovery task family.

Each system's right-hand side is a polynomial in its state,

.. math:: \\dot x_i = \\sum_{\\alpha} \\xi_{i\\alpha}\\, x^{\\alpha}, \\qquad
   x^{\\alpha} = \\prod_j x_j^{\\alpha_j},

so its equations are a sparse coefficient matrix Ξ over any polynomial library that holds its
monomials (:meth:`PolynomialSystem.coefficient_matrix`), the quantity sparse model discovery
(SINDy) estimates. Trajectories are integrated by an 8th-order Runge-Kutta method (DOP853) at
a relative and absolute tolerance of 1e-12, and the exact derivative of each sample is the
right-hand side at it: ẋ = f(x) holds to rounding on the samples returned, whatever the
integration error, so a regression of the exact ẋ on the library recovers Ξ to rounding.
Measurements add Gaussian noise of a given fraction of each state's standard deviation over
the trajectory (seeded).

References
----------
S. L. Brunton, J. L. Proctor, J. N. Kutz, "Discovering governing equations from data by sparse
identification of nonlinear dynamical systems", PNAS 113 (2016) 3932-3937 (the systems and
their parameters: Lorenz, the linear and cubic oscillators, Van der Pol); E. Hairer,
S. P. Nørsett, G. Wanner, *Solving Ordinary Differential Equations I*, Springer, 1993 (DOP853).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from diffbench.signals._checks import (
    check_real,
    check_seed,
    check_whole,
    read_only,
    unknown_choice_hint,
)

TOLERANCE = 1e-12
"""Relative and absolute tolerance of the integration (DOP853)."""

Monomial = tuple[int, ...]
"""The exponents of the state variables in one monomial (the constant: all zero)."""


@dataclass(frozen=True)
class Trajectory:
    """Samples of a system's trajectory with their exact derivatives.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times, seconds (uniform, from 0).
    x : numpy.ndarray, shape (n, d)
        The states.
    x_dot : numpy.ndarray, shape (n, d)
        Their exact time derivatives, the right-hand side at each sample.
    """

    t: np.ndarray
    x: np.ndarray
    x_dot: np.ndarray


@dataclass(frozen=True)
class Measurement:
    """A noisy measurement of a trajectory, with the truth beside it.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times, seconds.
    dt_s : float
        The sampling step.
    x : numpy.ndarray, shape (n, d)
        The measured states, ``truth.x + noise``.
    truth : Trajectory
        The clean states and their exact derivatives.
    noise_std : numpy.ndarray, shape (d,)
        The standard deviation of the noise added to each state.
    seed : int
        The seed the noise was drawn with.
    """

    t: np.ndarray
    dt_s: float
    x: np.ndarray
    truth: Trajectory
    noise_std: np.ndarray
    seed: int


@dataclass(frozen=True)
class PolynomialSystem:
    """An ordinary differential equation with a polynomial right-hand side, and how it is
    measured for the discovery task.

    Parameters
    ----------
    name : str
        Registered name.
    states : tuple of str
        The state variables' names.
    terms : tuple of mapping
        One per state: its equation, monomial exponents → coefficient (the nonzero ones).
    initial : tuple of float
        The initial condition of the measured trajectory.
    starts : tuple of tuple of float
        Further initial conditions, for a measurement of several trajectories
        (:meth:`measure_runs`): ``initial`` and then these, in order.
    held_out : tuple of tuple of float
        Initial conditions the discovered model is simulated from and scored on (never
        measured).
    dt_s, duration_s : float
        The measured trajectory's step and length, seconds.
    horizon_s : float
        The length of the held-out simulations, seconds.
    threshold : float
        The sequentially thresholded least squares' threshold: below the smallest true
        coefficient, so that the exact derivatives recover the true equations.
    degree : int
        The degree of the polynomial library the equations are sought in.
    reference : str
        Where the system and its parameters come from.
    """

    name: str
    states: tuple[str, ...]
    terms: tuple[Mapping[Monomial, float], ...]
    initial: tuple[float, ...]
    starts: tuple[tuple[float, ...], ...]
    held_out: tuple[tuple[float, ...], ...]
    dt_s: float
    duration_s: float
    horizon_s: float
    threshold: float
    degree: int = 3
    reference: str = ""
    _monomials: np.ndarray = field(init=False, repr=False, compare=False)
    _matrix: np.ndarray = field(init=False, repr=False, compare=False)
    _trajectories: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        size = len(self.states)
        initials = (self.initial, *self.starts, *self.held_out)
        if len(self.terms) != size or any(len(start) != size for start in initials):
            raise ValueError(f"{self.name}: one equation and one initial value per state")
        if len(set(initials)) != len(initials):
            raise ValueError(f"{self.name}: the measured and held-out starts must differ")
        monomials = sorted({m for equation in self.terms for m in equation})
        if any(len(m) != size or sum(m) > self.degree for m in monomials):
            raise ValueError(f"{self.name}: a monomial has the wrong size or degree")
        matrix = np.zeros((size, len(monomials)))
        for i, equation in enumerate(self.terms):
            for monomial, value in equation.items():
                matrix[i, monomials.index(monomial)] = value
        exponents = np.array(monomials, dtype=int)
        exponents.setflags(write=False)
        object.__setattr__(self, "_monomials", exponents)
        object.__setattr__(self, "_matrix", read_only(matrix))
        object.__setattr__(self, "_trajectories", {})

    @property
    def dimension(self) -> int:
        """The number of states."""
        return len(self.states)

    def rhs(self, x: np.ndarray) -> np.ndarray:
        """The right-hand side f(x) at states ``x`` (shape (..., d)): Σ_α ξ_iα x^α."""
        x = np.asarray(x, dtype=np.float64)
        features = np.prod(x[..., None, :] ** self._monomials, axis=-1)
        return features @ self._matrix.T

    def trajectory(
        self, initial: tuple[float, ...] | None = None, duration_s: float | None = None
    ) -> Trajectory:
        """The trajectory from ``initial`` (default: the measured one's) over ``duration_s``
        (default: the measured length) at the system's step, and its exact derivatives;
        integrated once per start and length (its arrays are read-only, so every caller
        shares them: a study measures one trajectory many times over).

        Raises
        ------
        ValueError
            If the integration fails (the solver's message), e.g. a state that escapes.
        """
        initial = self.initial if initial is None else initial
        duration_s = self.duration_s if duration_s is None else duration_s
        check_real("duration_s", duration_s, gt=0)
        key = (tuple(float(v) for v in initial), float(duration_s))
        if key in self._trajectories:
            return self._trajectories[key]
        t = self.dt_s * np.arange(round(duration_s / self.dt_s) + 1)
        solution = solve_ivp(
            lambda _t, state: self.rhs(state),
            (0.0, t[-1]),
            np.asarray(initial, dtype=np.float64),
            method="DOP853",
            t_eval=t,
            rtol=TOLERANCE,
            atol=TOLERANCE,
        )
        if not solution.success:
            raise ValueError(f"{self.name} from {initial}: {solution.message}")
        x = solution.y.T
        found = Trajectory(read_only(t), read_only(x), read_only(self.rhs(x)))
        self._trajectories[key] = found
        return found

    @property
    def max_starts(self) -> int:
        """How many trajectories a measurement can hold: ``initial`` and the ``starts``."""
        return 1 + len(self.starts)

    def measure(self, noise_level: float, seed: int, every: int = 1) -> Measurement:
        """The measured trajectory, every ``every``-th sample of it (a step ``every`` times
        the system's), with Gaussian noise of ``noise_level`` times each state's standard
        deviation over those samples, drawn with ``numpy.random.default_rng(seed)``: the
        one-start :meth:`measure_runs`."""
        return self.measure_runs(noise_level, seed, every)[0]

    def measure_runs(
        self, noise_level: float, seed: int, every: int = 1, starts: int = 1
    ) -> tuple[Measurement, ...]:
        """A measurement of ``starts`` trajectories, from ``initial`` and the first
        ``starts - 1`` of :attr:`starts`, each over ``duration_s / starts`` (one trajectory's
        duration shared among them: its samples, and one more for each further start), every
        ``every``-th sample of each kept.

        Each state's noise has ``noise_level`` times its standard deviation over every
        sample kept (all trajectories together), drawn with
        ``numpy.random.default_rng(seed)`` for one trajectory after the other: one start is
        :meth:`measure` exactly.

        Raises
        ------
        ValueError
            For a negative level, a bad seed, an ``every`` that is not a whole number
            >= 1, or ``starts`` outside 1..:attr:`max_starts`.
        """
        check_real("noise_level", noise_level, ge=0)
        every, starts = check_whole("every", every, ge=1), check_whole("starts", starts, ge=1)
        if starts > self.max_starts:
            raise ValueError(
                f"`starts` must be in 1..{self.max_starts} ({self.name} declares "
                f"{self.max_starts} initial conditions), got {starts}"
            )
        rng = np.random.default_rng(check_seed(seed))
        duration_s = self.duration_s / starts
        runs = []
        for initial in (self.initial, *self.starts)[:starts]:
            truth = self.trajectory(initial, duration_s)
            if every > 1:
                truth = Trajectory(
                    read_only(truth.t[::every]),
                    read_only(truth.x[::every]),
                    read_only(truth.x_dot[::every]),
                )
            runs.append(truth)
        spread = np.concatenate([truth.x for truth in runs]).std(axis=0)
        return tuple(
            Measurement(
                truth.t,
                self.dt_s * every,
                read_only(truth.x + noise_level * spread * rng.standard_normal(truth.x.shape)),
                truth,
                read_only(noise_level * spread),
                seed,
            )
            for truth in runs
        )

    def coefficient_matrix(self, powers: np.ndarray) -> np.ndarray:
        """Ξ over a library whose features are the monomials ``powers`` (shape (p, d), one
        row of exponents per feature, as pysindy's ``PolynomialLibrary.powers_``): shape
        (d, p), zero where the system has no term.

        Raises
        ------
        ValueError
            If a monomial of the system is not among ``powers``.
        """
        powers = np.asarray(powers, dtype=int)
        matrix = np.zeros((self.dimension, powers.shape[0]))
        for k, monomial in enumerate(self._monomials):
            found = np.flatnonzero((powers == monomial).all(axis=1))
            if found.size != 1:
                exponents = tuple(int(e) for e in monomial)
                raise ValueError(f"{self.name}'s monomial {exponents} is not in the library once")
            matrix[:, found[0]] = self._matrix[:, k]
        return matrix


def _terms(*equations: dict[str, float], states: str) -> tuple[dict[Monomial, float], ...]:
    """Equations written as {"x*z": -1.0, "1": 0.2} over the one-letter ``states``."""
    out = []
    for equation in equations:
        terms = {}
        for word, value in equation.items():
            exponents = [0] * len(states)
            for factor in word.split("*") if word != "1" else ():
                name, _, power = factor.partition("^")
                exponents[states.index(name)] += int(power or 1)
            terms[tuple(exponents)] = float(value)
        out.append(terms)
    return tuple(out)


SYSTEMS: dict[str, PolynomialSystem] = {
    system.name: system
    for system in (
        PolynomialSystem(
            "lorenz",
            ("x", "y", "z"),
            _terms(
                {"x": -10.0, "y": 10.0},
                {"x": 28.0, "x*z": -1.0, "y": -1.0},
                {"x*y": 1.0, "z": -8.0 / 3.0},
                states="xyz",
            ),
            initial=(-8.0, 8.0, 27.0),
            starts=((-5.0, -10.0, 30.0), (10.0, 12.0, 25.0)),
            held_out=((5.0, -5.0, 20.0), (-2.0, 3.0, 15.0)),
            dt_s=0.002,
            duration_s=10.0,
            horizon_s=1.0,
            threshold=0.5,
            reference="Lorenz (1963), σ = 10, ρ = 28, β = 8/3 (Brunton et al. 2016)",
        ),
        PolynomialSystem(
            "rossler",
            ("x", "y", "z"),
            _terms(
                {"y": -1.0, "z": -1.0},
                {"x": 1.0, "y": 0.2},
                {"1": 0.2, "x*z": 1.0, "z": -5.7},
                states="xyz",
            ),
            initial=(1.0, 1.0, 0.0),
            starts=((0.0, -3.0, 0.1), (-4.0, 0.0, 0.2)),
            held_out=((-2.0, 2.0, 0.1), (3.0, -1.0, 0.5)),
            dt_s=0.01,
            duration_s=50.0,
            horizon_s=5.0,
            threshold=0.05,
            reference="Rössler (1976), a = b = 0.2, c = 5.7",
        ),
        PolynomialSystem(
            "van-der-pol",
            ("x", "y"),
            _terms({"y": 1.0}, {"x": -1.0, "y": 2.0, "x^2*y": -2.0}, states="xy"),
            initial=(2.0, 0.0),
            starts=((0.0, 3.0), (-3.0, -1.0)),
            held_out=((-1.0, 1.0), (0.5, -2.0)),
            dt_s=0.01,
            duration_s=20.0,
            horizon_s=5.0,
            threshold=0.1,
            reference="Van der Pol oscillator, μ = 2 (Brunton et al. 2016)",
        ),
        PolynomialSystem(
            "duffing",
            ("x", "y"),
            _terms({"y": 1.0}, {"x": -1.0, "y": -0.1, "x^3": -5.0}, states="xy"),
            initial=(1.0, 0.0),
            starts=((0.0, 1.5), (-1.2, 0.0)),
            held_out=((-0.8, 0.5), (0.5, 1.0)),
            dt_s=0.01,
            duration_s=20.0,
            horizon_s=5.0,
            threshold=0.05,
            reference="damped Duffing oscillator, δ = 0.1, α = 1, β = 5",
        ),
        PolynomialSystem(
            "lotka-volterra",
            ("x", "y"),
            _terms({"x": 1.0, "x*y": -0.5}, {"x*y": 0.5, "y": -1.0}, states="xy"),
            initial=(3.0, 1.0),
            starts=((1.0, 1.0), (4.0, 2.5)),
            held_out=((1.5, 2.5), (1.0, 3.0)),
            dt_s=0.01,
            duration_s=20.0,
            horizon_s=5.0,
            threshold=0.1,
            reference="Lotka-Volterra predator-prey, α = γ = 1, β = δ = 0.5",
        ),
        PolynomialSystem(
            "linear-oscillator",
            ("x", "y"),
            _terms({"x": -0.1, "y": 2.0}, {"x": -2.0, "y": -0.1}, states="xy"),
            initial=(2.0, 0.0),
            starts=((-2.0, 1.0), (1.0, 2.5)),
            held_out=((0.0, 2.0), (-1.0, -1.0)),
            dt_s=0.01,
            duration_s=25.0,
            horizon_s=5.0,
            threshold=0.05,
            reference="damped linear oscillator (Brunton et al. 2016, fig. 2)",
        ),
    )
}
"""Every system of the discovery task family, by name."""


def get_system(name: str) -> PolynomialSystem:
    """The system registered as ``name`` (:data:`SYSTEMS`).

    Raises
    ------
    ValueError
        For an unknown name, with the close names.
    """
    if name not in SYSTEMS:
        raise ValueError(f"unknown system {name!r}; {unknown_choice_hint(name, SYSTEMS)}")
    return SYSTEMS[name]
