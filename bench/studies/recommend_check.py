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
from diffbench.bench.studies.recommend import (
    INTERVAL,
    REGION,
    _settings,
    interval_cells,
    recommend,
)

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


EXPECTED_DRAWS = 32
"""Further noise draws of a scenario (the seeds after the record's) on which the recommended
setting and the oracle's are scored too: the error to expect, which a prediction is of, and
how far one record's own error lies from it."""

CLOSE = 0.2
"""A prediction within this fraction of the truth counts as close (the ±20 % of the summary
lines)."""


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
    (``pynumdiff_*`` columns). Both ratios to the best known: :func:`with_best_known`.

    Against the error to expect: the recommended setting and the best oracle-tuned one scored
    on :data:`EXPECTED_DRAWS` further noise draws of the scenario (``expected_rmse`` with its
    standard deviation ``expected_spread``, and ``oracle_expected_rmse``), with the predicted
    interval ``low``..``high`` for the record's own error."""

    drawn = signals.get_scenario(scenario)
    realisation = drawn.realise(seed)
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
    further = [drawn.realise(seed + 1 + k) for k in range(EXPECTED_DRAWS)]
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
                )
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
        best = min(oracle, key=lambda candidate: oracle[candidate].loss)
        true = _true_rmse(realisation, name, params, order)
        expected = [_true_rmse(other, name, params, order) for other in further]
        oracle_expected = [_true_rmse(other, best, oracle[best].params, order) for other in further]
        row = {
            "scenario": scenario,
            "seed": seed,
            "order": order,
            "band_hz": guess_hz,
            "noise_std": advice.noise_std,
            "recommended": name,
            "params": _settings(params),
            "predicted_rmse": predicted["predicted_rmse"],
            "low": predicted["low"],
            "high": predicted["high"],
            "true_rmse": true,
            "expected_rmse": float(np.mean(expected)),
            "expected_spread": float(np.std(expected)),
            "oracle_best": best,
            "oracle_rmse": oracle[best].loss,
            "oracle_expected_rmse": float(np.mean(oracle_expected)),
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


def _finite(ratios: pd.Series) -> pd.Series:
    """``ratios`` less the infinite and NaN ones (a method that left a scored sample out)."""
    return ratios.replace([np.inf, -np.inf], np.nan).dropna()


def _close(ratios: pd.Series) -> int:
    """How many of ``ratios`` (predicted over true) are within :data:`CLOSE` of 1."""
    return int(np.count_nonzero((ratios >= 1 - CLOSE) & (ratios <= 1 + CLOSE)))


def _expectation_line(symbol: str, group: pd.DataFrame) -> str:
    """The summary line of one order against the error to expect: the prediction over it,
    the record's own error over it (the closest a prediction of it can come to each record),
    the predicted interval's hold on the record's own error (records whose every noise draw
    is the same, and so every surrogate, have an interval of no width: counted apart), and
    the recommended setting over the oracle's, both over the further draws."""
    expected = group["expected_rmse"]
    predicted = _finite(group["predicted_rmse"] / expected)
    own = _finite(group["true_rmse"] / expected)
    fixed = group["expected_spread"] == 0  # every draw the same record
    noisy = group[~fixed]
    held = int(
        np.count_nonzero(
            (noisy["low"] <= noisy["true_rmse"]) & (noisy["true_rmse"] <= noisy["high"])
        )
    )
    off = (group.loc[fixed, "predicted_rmse"] / group.loc[fixed, "true_rmse"] - 1).abs()
    over_oracle = _finite(expected / group["oracle_expected_rmse"])
    close = f"±{CLOSE * 100:.0f} %"
    line = (
        f"- {symbol} against the error to expect (the mean over {EXPECTED_DRAWS} further "
        f"noise draws of the scenario): predicted over expected {predicted.min():.3g} to "
        f"{predicted.max():.3g} (median {predicted.median():.3g}), within {close} on "
        f"{_close(predicted)} of {len(predicted)}; the record's own error within {close} "
        f"of its expected on {_close(own)} of {len(own)} (what a perfect prediction of the "
        f"error to expect would reach); the predicted {INTERVAL * 100:.0f} % interval holds the "
        f"record's own error on {held} of {len(noisy)} records"
    )
    if len(off):
        line += (
            f"; {len(off)} more, whose noise is the same in every draw (and so every "
            f"surrogate's), are predicted to within {off.max() * 100:.2g} %"
        )
    if len(over_oracle):
        worst = over_oracle.idxmax()
        line += (
            f"; the recommended setting over the oracle's, both over the further draws: "
            f"median {over_oracle.median():.3g}, worst {over_oracle.max():.3g} "
            f"({group.loc[worst, 'scenario']})"
        )
    return line


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
        finite = _finite(accuracy[group.index])
        if len(finite):
            within = _close(finite)
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
        if "expected_rmse" in group:
            lines.append(_expectation_line(symbol, group))
    expected = frame.get("expected_rmse", pd.Series(np.nan, index=frame.index))
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
            f"{INTERVAL * 100:.0f} % interval": interval_cells(
                frame.get("low", expected * np.nan), frame.get("high", expected * np.nan)
            ),
            "expected": expected.map("{:.4g}".format),
            "predicted / expected": (frame["predicted_rmse"] / expected).map("{:.3g}".format),
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
        "and ratio to the same best known. **expected**: the recommended setting's mean "
        f"true RMSE over {EXPECTED_DRAWS} further noise draws of the scenario (the error to "
        "expect, which the prediction is of); **interval**: where `recommend` predicts the "
        f"record's own error lies for {INTERVAL * 100:.0f} % of records like it. "
        "Methods offered: " + ", ".join(names) + "."
    )
    (out / "validation.md").write_text(
        "\n".join(lines) + "\n\n" + markdown_table(shown) + "\n\n" + note + "\n"
    )
    return [out / "validation.md", out / "validation.csv"]
