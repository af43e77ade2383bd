"""diffbench signals: clean test signals with exact derivatives, seeded noise models, and the
named scenarios every method is benchmarked on (Guo et al., AIM 2015, section III.C); the
paper's 2R robot (``signals.robot2r``: model, regressor, closed-loop simulation) and the real
DFKI double pendulum recordings (``signals.dfki``: loader and model); random signals with
known spectra and the bound on any differentiator's error on them (``signals.stochastic``).

This package imports only NumPy, SciPy and the standard library; its only I/O is reading the
recordings packaged with it (``signals/data``, BSD-3, licence beside the data).
"""

from diffbench.signals import dfki, dynamics, robot2r, stochastic
from diffbench.signals.clean import (
    Chirp,
    DampedOscillation,
    PaperSines,
    Polynomial,
    Signal,
    SmoothedKink,
    Truth,
    available_signals,
    get_signal,
    register_signal,
    signal_class,
)
from diffbench.signals.noise import (
    Gaussian,
    NoiseModel,
    NoiseStack,
    Poisson,
    Quantisation,
    Sinusoid,
)
from diffbench.signals.scenarios import (
    Realisation,
    Scenario,
    available_scenarios,
    get_scenario,
    register_scenario,
)
from diffbench.signals.stochastic import BandLimited, IntegratedWhiteNoise, Matern, RandomSignal
from diffbench.signals.timing import Dropout, Jitter, SamplingModel

__all__ = [
    "BandLimited",
    "Chirp",
    "DampedOscillation",
    "Dropout",
    "Gaussian",
    "IntegratedWhiteNoise",
    "Jitter",
    "Matern",
    "NoiseModel",
    "NoiseStack",
    "PaperSines",
    "Poisson",
    "Polynomial",
    "Quantisation",
    "RandomSignal",
    "Realisation",
    "SamplingModel",
    "Scenario",
    "Signal",
    "Sinusoid",
    "SmoothedKink",
    "Truth",
    "available_scenarios",
    "available_signals",
    "dfki",
    "dynamics",
    "get_scenario",
    "get_signal",
    "register_scenario",
    "register_signal",
    "robot2r",
    "signal_class",
    "stochastic",
]
