"""Error scores of an estimate against the exact truth.

Every derivative order is scored on three regions: ``valid``, the samples the method itself
marks valid (trusted: its coverage); ``whole``, every sample it estimates, trusted or not (the
whole record, when it estimates every sample: its ``coverage`` row says the share); and
``interior``, a common set of samples fixed by the scenario (the same for every method of a
comparison, so rankings are fair), taken where the method marks them valid.
"""

from __future__ import annotations

import numpy as np

from diffbench.methods import Estimate

REGIONS = ("valid", "interior", "whole")
ERROR_METRICS = ("rmse", "max_abs", "rel_rmse")


def error_metrics(estimate: np.ndarray, truth: np.ndarray, mask: np.ndarray) -> dict[str, float]:
    """RMSE, max-abs error and RMSE relative to the RMS of the truth, on the masked samples.

    .. math::
        \\mathrm{rmse} = \\sqrt{\\tfrac{1}{|M|}\\sum_{k\\in M} (\\hat y_k - y_k)^2}, \\quad
        \\mathrm{rel\\_rmse} = \\mathrm{rmse} \\Big/ \\sqrt{\\tfrac{1}{|M|}\\sum_{k\\in M} y_k^2}

    ``estimate`` may carry channels on its trailing axes; they are all compared with ``truth``
    broadcast over them. An empty mask raises ``ValueError``.
    """
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        raise ValueError("`mask` selects no samples to score")
    est = np.asarray(estimate)[mask]
    ref = np.asarray(truth)[mask].reshape((-1,) + (1,) * (est.ndim - 1))
    error = est - ref
    rmse = float(np.sqrt(np.mean(error**2)))
    scale = float(np.sqrt(np.mean(np.broadcast_to(ref, est.shape) ** 2)))
    return {
        "rmse": rmse,
        "max_abs": float(np.max(np.abs(error))),
        "rel_rmse": rmse / scale if scale > 0 else float("inf"),
    }


def is_uniform(realisation) -> bool:
    """Whether a realisation is uniformly sampled: its ``uniform`` flag; one without the flag
    (``x``, ``dt_s``, ``interior``, ``truth`` only, as a tuner takes) is."""
    return bool(getattr(realisation, "uniform", True))


def estimate_on(
    method, realisation, samples=None, orders=(0, 1, 2), reads=None, marks: bool = True
) -> Estimate:
    """``method`` on a realisation's samples (or on ``samples`` taken at the same times: the
    clean signal, the noise alone), given its step when the sampling is uniform, and its time
    stamps (``t=``) with the nominal step when it is not. ``reads``: the first and last
    sample the caller reads, when it reads no others; ``marks=False`` when it reads their
    values only, not their valid marks (``Method.estimate_within``)."""
    x = realisation.x if samples is None else samples
    if is_uniform(realisation):
        if reads is not None:
            return method.estimate_within(x, realisation.dt_s, orders, *reads, marks=marks)
        return method(x, realisation.dt_s, orders)
    return method(x, realisation.dt_s, orders, t=realisation.t)


def score_estimate(
    estimate: Estimate, truth, interior: np.ndarray
) -> list[dict[str, float | int | str]]:
    """Tidy score rows (order, region, metric, value) of ``estimate`` against ``truth``.

    ``truth[n]`` is the exact derivative of order n. Besides the error metrics of each order
    on the three regions, each order gets ``coverage`` on each: the fraction of samples the
    method marks valid (``valid``), of the interior it marks valid (``interior``; interior
    errors are taken on that part) and of the record it estimates (``whole``).
    """
    interior = np.asarray(interior, dtype=bool)
    rows: list[dict[str, float | int | str]] = []
    for order in estimate.orders:
        valid = estimate.valid[order]
        regions = {
            "valid": valid,
            "interior": interior & valid,
            "whole": estimate.estimated(order),
        }
        for region in REGIONS:
            if regions[region].any():
                metrics = error_metrics(estimate[order], truth[order], regions[region])
            else:
                metrics = dict.fromkeys(ERROR_METRICS, float("nan"))
            rows += [
                {"order": order, "region": region, "metric": metric, "value": value}
                for metric, value in metrics.items()
            ]
        coverage = {
            "valid": float(np.mean(valid)),
            "interior": float(np.count_nonzero(regions["interior"]) / interior.sum()),
            "whole": float(np.mean(regions["whole"])),
        }
        rows += [
            {"order": order, "region": region, "metric": "coverage", "value": coverage[region]}
            for region in REGIONS
        ]
    return rows
