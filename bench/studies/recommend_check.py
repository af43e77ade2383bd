"""``recommend-check``: :func:`~diffbench.bench.studies.recommend.recommend` scored against
the truth on the signal scenarios, taken as if unknown but for the samples to be scored: the
recommended setting's true RMSE over the best known for the same methods (their oracle
tunings on the record itself, or a data-only setting where it did better), with PyNumDiff's
data-only tuning of the same methods beside it, against the same best."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench.core.scores import error_metrics
from diffbench.bench.core.tuning import tune
from diffbench.bench.report.tables import markdown_table
from diffbench.bench.studies.recommend import REGION, _settings, recommend

VALIDATION_METHODS = (
    "spectral",
    "savitzky_golay",
    "butterworth",
    "kalman",
    "gaussian_kernel",
    "finite_difference",
)
"""The methods the validation recommends among by default: the native ones that tune in
seconds (the Gaussian processes, Jacobi and the peers take minutes per record)."""


def validation_scenarios() -> list[str]:
    """The scenarios ``recommend-check`` validates on by default: every registered one that is
    sampled uniformly and noisy, less the random signals of the limit study (they have their
    own)."""
    return [
        name
        for name in signals.available_scenarios()
        if not (scenario := signals.get_scenario(name)).sampling
        and scenario.noise.models
        and not name.startswith("limit-")
    ]


def validate(scenario: str, names=VALIDATION_METHODS, seed: int = 0, max_evaluations=150):
    """Rows scoring :func:`recommend` on one uniformly sampled scenario as if its truth were
    unknown: for each order, the recommended method and setting, its predicted RMSE, its true
    interior RMSE on the record, and the best true RMSE any of ``names`` reaches tuned by the
    oracle on the same record (the most a data-only choice could reach).

    Beside it, PyNumDiff's data-only tuning (its loss, :func:`~diffbench.bench.core.tuning.
    no_truth_loss`, with its weight γ from a bandlimit guess: the band ``recommend`` read off
    the periodogram) tunes each of ``names`` and picks the one of lowest loss: its true RMSE
    (``pynumdiff_*`` columns). Both ratios to the best known: :func:`with_best_known`."""

    realisation = signals.get_scenario(scenario).realise(seed)
    if not getattr(realisation, "uniform", True):
        raise ValueError(f"{scenario}: irregular time stamps are not validated yet")
    start = time.perf_counter()
    # the samples to be scored are the user's to say (not the truth): the scenario's interior
    advice = recommend(
        realisation.x,
        realisation.dt_s,
        list(names),
        (1, 2),
        seed,
        max_evaluations,
        scored=realisation.interior,
    )
    guess_hz = advice.spectrum.band_hz
    rows = []
    for order in (1, 2):
        name, params = advice.best(order)
        predicted = advice.table[
            (advice.table["order"] == order) & (advice.table["method"] == name)
        ].iloc[0]
        oracle, by_pynumdiff = {}, {}
        for candidate in names:
            try:
                oracle[candidate] = tune(
                    candidate,
                    realisation,
                    order,
                    "oracle",
                    max_evaluations=max_evaluations,
                    region=REGION,
                ).loss
            except ValueError:
                continue
            if guess_hz > 0:
                try:
                    by_pynumdiff[candidate] = tune(
                        candidate,
                        realisation,
                        order,
                        "pynumdiff",
                        cutoff_hz=guess_hz,
                        max_evaluations=max_evaluations,
                        region=REGION,
                    )
                except ValueError:
                    pass
        best = min(oracle, key=oracle.get)
        true = _true_rmse(realisation, name, params, order)
        row = {
            "scenario": scenario,
            "seed": seed,
            "order": order,
            "band_hz": guess_hz,
            "noise_std": advice.noise_std,
            "recommended": name,
            "params": _settings(params),
            "predicted_rmse": predicted["predicted_rmse"],
            "true_rmse": true,
            "oracle_best": best,
            "oracle_rmse": oracle[best],
            "pynumdiff_choice": "",
            "pynumdiff_params": "",
            "pynumdiff_rmse": math.nan,
        }
        finite = {k: v for k, v in by_pynumdiff.items() if math.isfinite(v.loss)}
        if finite:
            choice = min(finite, key=lambda k: finite[k].loss)
            chosen = _true_rmse(realisation, choice, finite[choice].params, order)
            row.update(
                pynumdiff_choice=choice,
                pynumdiff_params=_settings(finite[choice].params),
                pynumdiff_rmse=chosen,
            )
        row["seconds"] = time.perf_counter() - start
        rows.append(with_best_known(row))
    return rows


def with_best_known(row: dict) -> dict:
    """The row with ``best_rmse``, the lowest true RMSE known for these methods on the record:
    the oracle's tunings, or the recommended or PyNumDiff's setting where one of them beat them
    (the oracle's search is not exhaustive: a 9301-sample record, 150 evaluations), and the
    ratios ``ratio`` and ``pynumdiff_ratio`` to it (never below 1)."""
    known = [row["oracle_rmse"], row["true_rmse"], row.get("pynumdiff_rmse", math.nan)]
    best = min(value for value in known if math.isfinite(value))
    return {
        **row,
        "best_rmse": best,
        "ratio": row["true_rmse"] / best,
        "pynumdiff_ratio": row.get("pynumdiff_rmse", math.nan) / best,
    }


def _true_rmse(realisation, name: str, params: dict, order: int) -> float:
    estimate = methods.get(name, **params)(realisation.x, realisation.dt_s, (order,))
    scored = realisation.interior
    if not estimate.estimated(order)[scored].all():
        return math.inf
    return error_metrics(estimate[order], realisation.truth[order], scored)["rmse"]


def write_validation(rows, out: Path, names=VALIDATION_METHODS) -> list[Path]:
    """``validation.csv`` (every row) and ``validation.md`` (per order: median and worst ratio
    of the recommendation and of PyNumDiff's data-only tuning, then every scenario) in
    ``out``."""

    out.mkdir(parents=True, exist_ok=True)
    rows = [with_best_known(row) for row in rows]
    frame = pd.DataFrame(rows).sort_values(["order", "scenario"]).reset_index(drop=True)
    frame.to_csv(out / "validation.csv", index=False)
    accuracy = frame["predicted_rmse"] / frame["true_rmse"]  # predicted over true, per row
    lines = ["# Data-only recommendation against the truth", ""]
    for order, group in frame.groupby("order"):
        symbol = "ẋ" if order == 1 else "ẍ"
        line = (
            f"- {symbol}: true RMSE of the recommended setting over the best known, median "
            f"{group['ratio'].median():.3g}, worst {group['ratio'].max():.3g} "
            f"({group.loc[group['ratio'].idxmax(), 'scenario']}), over {len(group)} scenarios"
        )
        finite = accuracy[group.index].replace(np.inf, np.nan).dropna()
        if len(finite):
            within = int(np.count_nonzero((finite >= 0.8) & (finite <= 1.2)))
            line += (
                f"; predicted over true RMSE {finite.min():.3g} to {finite.max():.3g} "
                f"(median {finite.median():.3g}), within ±20 % on {within} of {len(finite)}"
            )
        peer = group["pynumdiff_ratio"].dropna()
        if len(peer):
            line += (
                f"; PyNumDiff's data-only tuning: median {peer.median():.3g}, worst "
                f"{peer.max():.3g} ({group.loc[peer.idxmax(), 'scenario']}), over {len(peer)}"
            )
        lines.append(line)
    shown = pd.DataFrame(
        {
            "scenario": frame["scenario"],
            "n": frame["order"].map({1: "ẋ", 2: "ẍ"}),
            "band (Hz)": frame["band_hz"].map("{:.3g}".format),
            "noise std": frame["noise_std"].map("{:.3g}".format),
            "recommended": frame["recommended"],
            "settings": frame["params"],
            "predicted": frame["predicted_rmse"].map("{:.4g}".format),
            "true": frame["true_rmse"].map("{:.4g}".format),
            "predicted / true": accuracy.map("{:.3g}".format),
            "oracle-tuned best": frame["oracle_best"]
            + " "
            + frame["oracle_rmse"].map("{:.4g}".format),
            "ratio": frame["ratio"].map("{:.3g}".format),
        }
    )
    # with_best_known gave every row its pynumdiff_ratio (NaN where PyNumDiff tuned nothing)
    shown["PyNumDiff's choice"] = [
        f"{choice} {rmse:.4g}" if isinstance(choice, str) and choice else "—"
        for choice, rmse in zip(frame["pynumdiff_choice"], frame["pynumdiff_rmse"], strict=True)
    ]
    shown["its ratio"] = [f"{r:.3g}" if np.isfinite(r) else "—" for r in frame["pynumdiff_ratio"]]
    note = (
        "Each scenario's seed-0 record, its truth unknown to `recommend` (band and noise read "
        "off its periodogram, lines fitted, every method tuned on surrogate records) but for "
        "the samples to be scored (the scenario's interior); **oracle-tuned best**: the best "
        "of the same methods tuned by the oracle on the record itself (150 evaluations each); "
        "**ratio**: true / the best known (the oracle-tuned best, or the recommended or "
        "PyNumDiff's setting where it did better: the oracle's search is not exhaustive). "
        "**PyNumDiff's choice**: each method tuned by PyNumDiff's data-only loss (RMSE of the "
        "re-integrated derivative + γ·TV, γ from its heuristic given the band `recommend` "
        "read off the periodogram as the cutoff guess), the one of lowest loss, its true RMSE "
        "and ratio to the same best known. Methods offered: " + ", ".join(names) + "."
    )
    (out / "validation.md").write_text(
        "\n".join(lines) + "\n\n" + markdown_table(shown) + "\n\n" + note + "\n"
    )
    return [out / "validation.md", out / "validation.csv"]
