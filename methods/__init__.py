"""diffbench methods: WHAT is compared.

Every differentiator is a small frozen class registered by name::

    >>> from diffbench import methods
    >>> sg = methods.get("savitzky_golay", window_s=0.05, degree=3)
    >>> estimate = sg(x, dt=0.001)        # doctest: +SKIP
    >>> estimate[1], estimate.valid[1]    # doctest: +SKIP

``available()`` lists the names, ``method_class(name)`` gives the class with its parameter
specifications (``params_of``) and presets, ``preset(name, key)`` an instance at a preset.
Methods from other packages join the registry as plugins (entry points of the group
``diffbench.methods``, or ``load_plugin(module)``; see ``methods._plugins``).
"""

# Importing the family modules registers their methods (heavy libraries load lazily).
from diffbench.methods import (
    butterworth,
    finite_difference,
    gaussian_kernel,
    gaussian_process,
    high_gain_observer,
    jacobi,
    kalman,
    levant,
    online,
    savitzky_golay,
    sindy,
    smoothing_spline,
    spectral,
    total_variation,
)
from diffbench.methods._causal import CausalMethod, Stream
from diffbench.methods._fir import central_mask
from diffbench.methods._plugins import (
    ENTRY_POINT_GROUP,
    ENV_VARIABLE,
    Plugin,
    load_plugin,
    loaded_plugins,
    missing_peers,
)
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
    package_of,
    param,
    params_of,
    preset,
    preset_spec,
    register,
)
from diffbench.methods._time_stamps import to_grid, uniform_grid
from diffbench.methods._validation import (
    MAX_ORDER,
    MAX_WINDOW_STEPS,
    UNIFORM_TOLERANCE,
    check_dt,
    check_signal,
    check_times,
    did_you_mean,
    is_uniform,
    mean_step,
    samples_in_span,
    uniform_step,
    unknown_choice_hint,
)

__all__ = [
    "DEFAULT_PRESET",
    "ENTRY_POINT_GROUP",
    "ENV_VARIABLE",
    "MAX_ORDER",
    "MAX_WINDOW_STEPS",
    "PARAM_KINDS",
    "UNIFORM_TOLERANCE",
    "CausalMethod",
    "Estimate",
    "FirMethod",
    "Method",
    "Param",
    "Plugin",
    "Preset",
    "Stream",
    "available",
    "butterworth",
    "central_mask",
    "check_dt",
    "check_signal",
    "check_times",
    "did_you_mean",
    "finite_difference",
    "gaussian_kernel",
    "gaussian_process",
    "get",
    "high_gain_observer",
    "is_uniform",
    "jacobi",
    "kalman",
    "levant",
    "load_plugin",
    "loaded_plugins",
    "mean_step",
    "method_class",
    "missing_peers",
    "online",
    "package_of",
    "param",
    "params_of",
    "preset",
    "preset_spec",
    "register",
    "samples_in_span",
    "savitzky_golay",
    "sindy",
    "smoothing_spline",
    "spectral",
    "to_grid",
    "total_variation",
    "uniform_grid",
    "uniform_step",
    "unknown_choice_hint",
]
