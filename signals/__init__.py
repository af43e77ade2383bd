"""diffbench signals: clean test signals with exact derivatives, seeded noise models, and the
named scenarios every method is benchmarked on (Guo et al., AIM 2015, section III.C).

This package imports only NumPy, SciPy and the standard library; it does no I/O.
"""

from signals.clean import (
    Chirp,
    DampedOscillation,
    PaperSines,
    Polynomial,
    Signal,
    Truth,
    available_signals,
    get_signal,
    register_signal,
    signal_class,
)
from signals.noise import Gaussian, NoiseModel, NoiseStack, Poisson, Quantisation, Sinusoid
from signals.scenarios import (
    Realisation,
    Scenario,
    available_scenarios,
    get_scenario,
    register_scenario,
)

__all__ = [
    "Chirp",
    "DampedOscillation",
    "Gaussian",
    "NoiseModel",
    "NoiseStack",
    "PaperSines",
    "Poisson",
    "Polynomial",
    "Quantisation",
    "Realisation",
    "Scenario",
    "Signal",
    "Sinusoid",
    "Truth",
    "available_scenarios",
    "available_signals",
    "get_scenario",
    "get_signal",
    "register_scenario",
    "register_signal",
    "signal_class",
]
