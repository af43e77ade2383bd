"""Any registered method as pysindy's ``differentiation_method``.

Imported on its own (``from diffbench.methods.for_pysindy import Differentiation``), not by
``diffbench.methods``: it subclasses pysindy's ``BaseDifferentiation``, and pysindy takes about
2 s to import.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from pysindy.differentiation import BaseDifferentiation

from diffbench.methods._registry import Method, get


class Differentiation(BaseDifferentiation):
    """A diffbench method as pysindy's differentiation method.

    .. math:: \\dot X = D_{\\text{method}}(X), \\qquad X \\in \\mathbb{R}^{n \\times m}

    each of the m columns of the trajectory differentiated on its own (time on axis 0),
    at the step pysindy passes (a float) or at its time stamps (an array: native or resampled
    as the method's ``time_stamps`` says). Samples the method does not mark valid (ends it
    estimates but does not trust) are NaN in ``x_dot`` and, with ``smoothed_x=True``, in
    ``smoothed_x_`` (:meth:`Estimate.trusted`); pysindy's optimisers drop NaN rows before
    fitting, so the regression sees trusted derivatives only.

    Parameters
    ----------
    method : str
        A registered method's name (``diffbench.methods.available()``).
    params : mapping, optional
        Its hyperparameters (the rest at their defaults, adapted to the step where they do not
        fit it: ``Method.at_step``).
    smoothed_x : bool
        Give pysindy the method's own smoothed signal (order 0) as ``smoothed_x_``, so that the
        library is evaluated on it (as pysindy's ``SmoothedFiniteDifference`` does); else the
        data as they are.

    References
    ----------
    B. M. de Silva et al., "PySINDy: a Python package for the sparse identification of
    nonlinear dynamical systems from data", JOSS 5(49) (2020) 2104.

    Examples
    --------
    >>> import pysindy as ps  # doctest: +SKIP
    >>> model = ps.SINDy(differentiation_method=Differentiation("savitzky_golay",
    ...                  {"window_s": 0.05, "degree": 3}))  # doctest: +SKIP
    """

    def __init__(
        self,
        method: str = "savitzky_golay",
        params: Mapping[str, Any] | None = None,
        smoothed_x: bool = True,
    ):
        self.method = method
        self.params = params
        self.smoothed_x = smoothed_x

    def differentiator(self) -> Method:
        """The diffbench method this runs (checked: an unknown name or parameter names it)."""
        return get(self.method, **dict(self.params or {}))

    def _differentiate(self, x, t=1):
        method = self.differentiator()
        x = np.asarray(x, dtype=np.float64)
        if np.ndim(t) == 0:
            estimate = method(x, float(t), orders=(0, 1))
        else:
            estimate = method(x, orders=(0, 1), t=np.asarray(t, dtype=np.float64))
        self.smoothed_x_ = estimate.trusted(0) if self.smoothed_x else x
        return estimate.trusted(1)
