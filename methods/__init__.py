"""diffbench methods: WHAT is compared.

Every differentiator is a small frozen class registered by name::

    >>> from diffbench import methods
    >>> sg = methods.get("savitzky_golay", window_s=0.05, degree=3)
    >>> estimate = sg(x, dt=0.001)        # doctest: +SKIP
    >>> estimate[1], estimate.valid[1]    # doctest: +SKIP

``available()`` lists the names, ``method_class(name)`` gives the class with its parameter
specifications (``params_of``) and presets, ``preset(name, key)`` an instance at a preset.
"""

# Importing the family modules registers their methods (heavy libraries load lazily).
from diffbench.methods import butterworth, finite_difference, jacobi, kalman, savitzky_golay, sindy
from diffbench.methods._fir import central_mask
from diffbench.methods._registry import (
    DEFAULT_PRESET,
    PARAM_KINDS,
    Estimate,
    FirMethod,
    Method,
    Param,
    Preset,
    available,
    get,
    method_class,
    param,
    params_of,
    preset,
    preset_spec,
    register,
)
from diffbench.methods._validation import (
    MAX_ORDER,
    MAX_WINDOW_STEPS,
    check_signal,
    uniform_step,
)

__all__ = [
    "DEFAULT_PRESET",
    "MAX_ORDER",
    "MAX_WINDOW_STEPS",
    "PARAM_KINDS",
    "Estimate",
    "FirMethod",
    "Method",
    "Param",
    "Preset",
    "available",
    "butterworth",
    "central_mask",
    "check_signal",
    "finite_difference",
    "get",
    "jacobi",
    "kalman",
    "method_class",
    "param",
    "params_of",
    "preset",
    "preset_spec",
    "register",
    "savitzky_golay",
    "sindy",
    "uniform_step",
]
