"""Example diffbench plugin: a moving average followed by central differences.

Importing this module registers ``example.box_difference``. Installed, it is found through
its entry point (group ``diffbench.methods``); on ``PYTHONPATH`` it can be named for one run
with ``diffbench --plugin diffbench_example_plugin`` or ``DIFFBENCH_PLUGINS``.
"""

from __future__ import annotations

import numpy as np

from diffbench.methods import FirMethod, Preset, param, register, samples_in_span

CENTRAL_DIFFERENCE = {1: np.array([-0.5, 0.0, 0.5]), 2: np.array([1.0, -2.0, 1.0])}


def box_difference_taps(order: int, window_steps: int, dt: float) -> np.ndarray:
    r"""Taps of the derivative of ``order`` (0, 1, 2): a centred moving average over
    ``window_steps + 1`` samples, then the second-order central difference.

    .. math:: \hat x^{(n)}_k = \Delta t^{-n} \sum_j (b * d^{(n)})_j \, x_{k+j},
        \quad b = \tfrac{1}{2m+1}\mathbf 1_{2m+1},\ d^{(1)} = (-\tfrac12, 0, \tfrac12),\
        d^{(2)} = (1, -2, 1)

    The symmetric average adds only even-degree terms to a polynomial's lower coefficients, so
    the smoothed signal is exact on degree 1, ẋ on degree 2 and ẍ on degree 3.
    """
    box = np.full(window_steps + 1, 1.0 / (window_steps + 1))
    if order == 0:
        return box
    return np.convolve(box, CENTRAL_DIFFERENCE[order]) / dt**order


@register("example.box_difference")
class BoxDifference(FirMethod):
    """Moving average of ``window_s`` then central differences (see
    :func:`box_difference_taps`). Reference: R. W. Hamming, *Digital Filters*, 3rd ed. (1989),
    ch. 3 (moving averages) and ch. 6 (differentiators)."""

    window_s: float = param(
        0.05,
        low=0.0,
        low_open=True,
        tune_low=0.004,
        tune_high=0.5,
        log=True,
        doc="moving-average span in seconds (odd sample count)",
        kind="window",
    )
    presets = {
        "paper-signal": Preset(
            {"window_s": 0.04},
            "example only: first notch of the average at 25 Hz, above the 15 Hz component",
            by="example",
        )
    }
    reference = "Hamming (1989)"

    def _steps(self, dt: float) -> int:
        return samples_in_span("window_s", self.window_s, dt, odd=True)

    def check_step(self, dt: float) -> None:
        self._steps(dt)

    def min_samples(self, dt: float) -> int:
        return self._steps(dt) + 3

    def exact_degree(self, order: int) -> float | None:
        return {0: 1, 1: 2, 2: 3}.get(order)

    def taps(self, order: int, dt: float) -> np.ndarray:
        return box_difference_taps(order, self._steps(dt), dt)
