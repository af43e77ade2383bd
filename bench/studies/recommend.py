r"""Which differentiator for this record, with which settings, and how wrong: from the data.

:func:`recommend` reads the record's noise floor and signal band from its periodogram
(:mod:`~diffbench.bench.core.spectrum`; nothing typed in), draws surrogate records with the
same spectrum whose truth is known (:mod:`~diffbench.bench.core.surrogates`), tunes every
method on some of them with the oracle criterion, scores the tuned setting on the others, and
ranks the methods by that predicted RMSE (mean ± standard deviation over the scoring
surrogates). Linear or not, native or a peer's: every method is tuned and scored the same way.

The record is divided by its half range first (:func:`record_scale`) and every error scaled
back: the recommendation for ``c·x`` is that for ``x``, its errors ``c`` times as large, from
``c = 1e-300`` to ``1e300`` (unscaled, the periodogram of such a record under- or overflows).
The settings are those for the scaled record: the same for a linear method, and for a method
whose settings depend on the amplitude (a total-variation penalty) those of ``x / scale``; the
estimates written for the record are computed on it that way and scaled back.

The error is predicted over the *scored* samples (default all but the first and last 5 %),
every one as the method estimates it, whether it marks it valid or not (on a record of 16
samples the scored samples are all of them, and every method marks some end samples); the
derivatives file written for a record flags the samples the prediction is for. A method's
marks may keep its last samples while they are many times worse than its middle (a spectral
method's, on a record whose ends do not meet: 10 to 20 times), and the surrogates, whose
ends are not the record's, do not predict them: they are written, but flagged 0 when outside
the scored samples.
"""

from __future__ import annotations

import functools
import math
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from diffbench import methods
from diffbench.bench.core import executor
from diffbench.bench.core.errors import DiffbenchWarning, plugin_failure, timeout_failure
from diffbench.bench.core.scores import error_metrics
from diffbench.bench.core.spectrum import RecordSpectrum, record_spectrum
from diffbench.bench.core.surrogates import default_scored, surrogate_model
from diffbench.bench.core.tuning import tune
from diffbench.bench.report import figures
from diffbench.bench.report.tables import markdown_table

TUNING_SURROGATES = 2
"""Surrogates a method is tuned on (their mean loss: one draw can favour a setting by luck)."""

REGION = "interior-estimated"
"""What the error is predicted over, tuned on and checked against (the tuner's region): the
scored samples, every one as estimated, trusted or not."""

TUNING_SAMPLES = 2048
"""The fewest samples a tuning surrogate is cut to (see :data:`TUNING_BAND_PERIODS`)."""

TUNING_BAND_PERIODS = 30
"""The tuning surrogates of a longer record are cut to their middle :data:`TUNING_SAMPLES`
samples, or :data:`TUNING_BAND_PERIODS` periods of the band's edge if that is longer
(:func:`tuning_length`, :func:`middle_segment`): a setting's cost grows with the record, its
best value with the spectrum, which a segment shares, and a window or time scale tuned on it
may still span a few periods (a third of the segment, the tuner's longest window). The scoring
surrogates stay whole, so the prediction is for the record. On the paper signal over 4.937 s
(4938 samples; a 2048-sample segment is 30 periods of 15 Hz) the recommendation is the same,
its true ẋ RMSE 2.01 against 2.21 tuned on the whole surrogates, in 0.4 of the time."""

SCREENED_CHOICES = 2
"""A method with more combinations of its choice parameters than this (Jacobi's rule and end
treatment: 9) has each screened by one generation of its tuning, and only this many best
tuned in full (the tuner's ``screen_choices``)."""

SCORING_SURROGATES = 16
"""Other surrogates the tuned setting is scored on: the predicted RMSE, its spread and its
interval. The first :data:`SHARED_BATCH_SCORING` are drawn in the tuning surrogates' batch,
the others in a batch of their own (:meth:`~diffbench.bench.core.surrogates.SurrogateModel.
draw`), so that their number leaves the tuning surrogates, and so the settings, as they are.
One surrogate's error varies by a tenth to a fifth of its mean on the validation records:
the mean of four is off by up to a tenth, of sixteen by up to a twentieth."""

SHARED_BATCH_SCORING = 4
"""Scoring surrogates drawn with the tuning ones (see :data:`SCORING_SURROGATES`)."""

INTERVAL = 0.9
"""The probability of the predicted interval ``low``..``high``: the record's own error lies
in it for that share of records like it (the scoring surrogates' errors taken as a
log-normal sample: its prediction interval). A record's error varies from one noise draw
to the next (on the validation records its standard deviation is a tenth to a fifth of its
mean), so a prediction of the error to expect cannot match every record more closely; the
interval says how far it may be (:func:`error_interval`)."""

FAILED = "failed: "
"""How a row of a plugin method that failed begins its ``params`` (the reason follows)."""

PREDICTION_COLUMNS = ("predicted_rmse", "spread", "low", "high", "coverage")
"""The columns of a row that its scoring on the surrogates fills (NaN when it could not)."""

COLUMNS = (
    "order",
    "rank",
    "method",
    "params",
    "predicted_rmse",
    "spread",
    "low",
    "high",
    "coverage",
    "package",
    "seconds",
)


@dataclass(frozen=True)
class Recommendation:
    """The spectrum of the record divided by ``scale`` and one row per (order, method): its
    tuned ``params`` (for the record divided by ``scale``), predicted RMSE over the scored
    samples ``predicted_rmse`` ± ``spread`` (standard deviation over the scoring surrogates;
    in the record's units) and the interval ``low``..``high`` the record's own error lies in
    with probability :data:`INTERVAL` (:func:`error_interval`), its ``coverage`` of the
    record (the fraction it marks valid), and
    its ``rank`` among the methods (1: best; methods that failed have no rank and say why in
    ``params``)."""

    spectrum: RecordSpectrum
    table: pd.DataFrame
    scale: float = 1.0

    @property
    def noise_std(self) -> float:
        """The white-noise standard deviation read off the record, in its units."""
        return self.spectrum.noise_std * self.scale

    def best(self, order: int) -> tuple[str, dict]:
        """The name and settings of the best method for the derivative of ``order``."""
        rows = self.table[(self.table["order"] == order) & (self.table["rank"] == 1)]
        if rows.empty:
            failed = self.table[self.table["order"] == order]
            why = "; ".join(
                f"{name}: {params}"
                for name, params in zip(failed["method"], failed["params"], strict=True)
            )
            raise ValueError(
                f"no method could be recommended for order {order} on this record "
                f"({why or 'no method given'})"
            )
        row = rows.iloc[0]
        return row["method"], row["params"]


def recommend(
    x: np.ndarray,
    dt: float,
    names: list[str] | None = None,
    orders: tuple[int, ...] = (1, 2),
    seed: int = 0,
    max_evaluations: int | None = None,
    scored: np.ndarray | None = None,
    jobs: executor.Workers = 1,
    progress=None,
    timeout_s: float | None = None,
) -> Recommendation:
    """Recommend a method and its settings for the derivatives of ``orders`` of the 1-D
    record ``x`` sampled every ``dt`` seconds (see the module docstring).

    ``names``: the methods to consider (default every registered one); ``max_evaluations``
    bounds each tuning (the tuner's default otherwise); ``scored``: a boolean mask of the
    samples whose derivatives matter, where the error is predicted (default all but the first
    and last 5 %). Each (method, order) is tuned and scored on its own, on ``jobs`` local
    processes or Dask workers (:mod:`~diffbench.bench.core.executor`; the same result as one
    process: each tuning is seeded by ``seed`` alone); ``progress(iterable, total)`` wraps
    their results as they arrive (a progress bar); ``timeout_s`` bounds each call of a method
    (a method that outlives it gets a row saying so, as a failed plugin does).
    """
    samples = np.asarray(x, dtype=np.float64)
    if samples.ndim != 1:
        raise ValueError(f"`x` must be one channel (1-D), got shape {samples.shape}")
    samples, dt = methods.check_signal(samples, dt, min_samples=16)
    scale = record_scale(samples)
    samples = samples / scale
    spectrum, tuning, scoring = surrogate_sets(samples, dt, seed, scored)
    pairs = [
        (name, order)
        for name in (names if names is not None else methods.available())
        for order in orders
    ]
    work = functools.partial(
        _tuned_and_scored_pair,
        tuning=tuning,
        scoring=scoring,
        max_evaluations=max_evaluations,
        seed=seed,
        timeout_s=timeout_s,
    )
    rows = executor.ordered_map(work, pairs, jobs)
    if progress is not None:
        rows = progress(rows, len(pairs))
    table = pd.DataFrame(list(rows), columns=list(COLUMNS))
    for params in table["params"]:
        if isinstance(params, str) and params.startswith(FAILED):
            warnings.warn(params[len(FAILED) :], DiffbenchWarning, stacklevel=2)
    for column in ("predicted_rmse", "spread", "low", "high"):
        table[column] = table[column] * scale
    table["rank"] = table.groupby("order")["predicted_rmse"].rank(method="first", na_option="keep")
    table = table.sort_values(["order", "rank"], na_position="last").reset_index(drop=True)
    return Recommendation(spectrum, table, scale)


def surrogate_sets(
    samples: np.ndarray, dt: float, seed: int = 0, scored: np.ndarray | None = None
) -> tuple[RecordSpectrum, tuple, tuple]:
    """What :func:`recommend` tunes and scores every method on, for the record ``samples``
    (already divided by its scale): its spectrum, the :data:`TUNING_SURROGATES` tuning
    surrogates (cut to :func:`tuning_length`) and the :data:`SCORING_SURROGATES` scoring ones,
    drawn with ``seed``. The same for every method, so kept for the last
    :data:`KEPT_SURROGATE_SETS` records (a study that asks for one method at a time on the
    same record, as the SINDy study does, fits its surrogate model once; measured: 0.3 s of
    the 0.7 s finite differences' recommendation costs on a 5001-sample record); realisations
    are read-only, and a record of other values, step, seed or scored samples gets its own."""
    scored_key = None if scored is None else np.asarray(scored, dtype=bool).tobytes()
    samples = np.ascontiguousarray(samples, dtype=np.float64)
    return _kept_surrogate_sets(samples.tobytes(), samples.shape[0], float(dt), seed, scored_key)


KEPT_SURROGATE_SETS = 8
"""How many records' surrogate sets :func:`surrogate_sets` keeps (up to 4 MB each at 5000
samples): the SINDy study asks for the three states of a record in turn, on each worker."""


@functools.lru_cache(maxsize=KEPT_SURROGATE_SETS)
def _kept_surrogate_sets(samples_bytes: bytes, n: int, dt: float, seed: int, scored_key):
    samples = np.frombuffer(samples_bytes, dtype=np.float64, count=n)
    scored = None if scored_key is None else np.frombuffer(scored_key, dtype=bool, count=n)
    spectrum = record_spectrum(samples, dt)
    model = surrogate_model(spectrum, samples, dt, scored=scored)
    drawn = model.draw(TUNING_SURROGATES + SHARED_BATCH_SCORING, seed)
    length = tuning_length(spectrum.band_hz, dt)
    tuning = [middle_segment(r, length) for r in drawn[:TUNING_SURROGATES]]
    scoring = drawn[TUNING_SURROGATES:] + model.draw(
        SCORING_SURROGATES - SHARED_BATCH_SCORING, seed, batch=1
    )
    return spectrum, tuple(tuning), tuple(scoring)


def tuning_length(band_hz: float, dt: float) -> int:
    """The samples a tuning surrogate is cut to: :data:`TUNING_SAMPLES`, or
    :data:`TUNING_BAND_PERIODS` periods of ``band_hz`` at step ``dt`` if that is more."""
    if not band_hz > 0:
        return TUNING_SAMPLES
    return max(TUNING_SAMPLES, math.ceil(TUNING_BAND_PERIODS / (band_hz * dt)))


def middle_segment(realisation, length: int):
    """``realisation`` cut to ``length`` samples centred on the middle of its scored ones when
    it is longer (else as it is), its scored samples those of the record that lie at least as
    far from the segment's ends as the record's scored samples lie from the record's nearest
    end: a method's treatment of the segment's ends, which the record does not have there, is
    not scored."""
    n = realisation.x.shape[0]
    if n <= length:
        return realisation
    scored = np.asarray(realisation.interior, dtype=bool)
    first, last = int(np.argmax(scored)), int(n - 1 - np.argmax(scored[::-1]))
    start = min(max((first + last + 1) // 2 - length // 2, 0), n - length)
    cut = slice(start, start + length)
    margin = min(first, n - 1 - last)  # the scored samples' least distance from an end
    inside = scored[cut].copy()
    inside[:margin] = False
    inside[length - margin :] = False
    if inside.sum() < 16:
        return realisation
    return realisation.stretch(cut, inside)


def error_interval(errors, probability: float = INTERVAL) -> tuple[float, float]:
    r"""The interval that holds the error of one more record like the surrogates with
    ``probability``, from their ``errors`` (n RMSEs) taken as log-normal: the prediction
    interval of a normal sample for the logarithms,

    .. math:: \exp\Big(m \mp t_{n-1,(1+p)/2}\, s \sqrt{1 + 1/n}\Big),

    m and s the mean and (n − 1) standard deviation of :math:`\ln e` and t Student's
    quantile: it holds a new draw with probability p exactly when the logarithms are normal
    (G. J. Hahn, W. Q. Meeker, *Statistical Intervals*, Wiley 1991, sec. 4.7). An RMSE is
    positive and its spread grows with it, so a normal interval about the mean would reach
    below 0 for a wide one. Errors of 0 (an exact method) count as the smallest positive
    float."""
    logs = np.log(np.maximum(np.asarray(errors, dtype=np.float64), np.finfo(float).tiny))
    count = logs.size
    quantile = float(stats.t.ppf((1 + probability) / 2, count - 1))
    width = quantile * float(np.std(logs, ddof=1)) * math.sqrt(1 + 1 / count)
    centre = float(np.mean(logs))
    return math.exp(centre - width), math.exp(centre + width)


def interval_cells(lows, highs) -> list[str]:
    """Table cells of the intervals ``lows``..``highs`` ("—" where there is none)."""
    return [
        f"{low:.3g} to {high:.3g}" if np.isfinite(low) else "—"
        for low, high in zip(lows, highs, strict=True)
    ]


def record_scale(x: np.ndarray) -> float:
    """Half the range of the finite record ``x``, max/2 − min/2 (no overflow up to the
    largest float); its largest magnitude if that is 0 (a constant), 1 for zeros."""
    half_range = float(np.max(x) / 2 - np.min(x) / 2)
    if half_range > 0:
        return half_range
    largest = float(np.max(np.abs(x)))
    return largest if largest > 0 else 1.0


def scaled_estimate(estimate: methods.Estimate, scale: float) -> methods.Estimate:
    """``estimate`` (of a record divided by ``scale``) multiplied back by ``scale``; a
    ``ValueError`` if a valid value then leaves the floating-point range."""
    values = {order: value * scale for order, value in estimate.values.items()}
    for order, value in values.items():
        if not np.all(np.isfinite(value[estimate.valid[order]])):
            raise ValueError(
                f"the derivative of order {order} of this record exceeds the floating-point "
                f"range (about {np.finfo(np.float64).max:.3g}): give the record in smaller units"
            )
    return methods.Estimate(values, dict(estimate.valid))


def _tuned_and_scored_pair(pair, tuning, scoring, max_evaluations, seed, timeout_s) -> dict:
    """:func:`_tuned_and_scored` of one ``(method name, order)``: the unit of work a worker
    takes."""
    name, order = pair
    return _tuned_and_scored(name, order, tuning, scoring, max_evaluations, seed, timeout_s)


def _tuned_and_scored(name, order, tuning, scoring, max_evaluations, seed, timeout_s) -> dict:
    """The row of ``name`` for ``order``: tuned on the ``tuning`` surrogates, scored on the
    ``scoring`` ones. A method that cannot be tuned, and a plugin method that fails (an
    exception, a wrong output: :func:`~diffbench.bench.core.errors.plugin_failure`), gets a
    row saying why instead of a score; diffbench's own methods' other errors propagate."""
    try:
        return _tuned_and_scored_row(name, order, tuning, scoring, max_evaluations, seed, timeout_s)
    except executor.CallTimeout:
        reason = timeout_failure(name, timeout_s)
    except (Exception, SystemExit) as error:  # a plugin may call sys.exit
        reason = plugin_failure(name, error)
        if reason is None:
            raise
    failed = dict.fromkeys((*PREDICTION_COLUMNS, "seconds"), math.nan)
    row = {"order": order, "method": name, "package": methods.package_of(name)}
    return {**row, **failed, "params": f"{FAILED}{reason}"}


def _tuned_and_scored_row(name, order, tuning, scoring, max_evaluations, seed, timeout_s):
    start = time.perf_counter()
    row = {"order": order, "method": name, "package": methods.package_of(name)}
    try:
        result = tune(
            name,
            tuning,
            order,
            "oracle",
            max_evaluations=max_evaluations,
            seed=seed,
            region=REGION,
            timeout_s=timeout_s,
            screen_choices=SCREENED_CHOICES,
        )
        if not math.isfinite(result.loss):
            raise ValueError(
                "no setting in its tuning range estimates every scored sample of the "
                "surrogates (the record may be too short for it)"
            )
    except ValueError as error:
        failed = dict.fromkeys(PREDICTION_COLUMNS, math.nan)
        return {
            **row,
            **failed,
            "params": f"not tuned: {error}",
            "seconds": time.perf_counter() - start,
        }
    method = methods.get(name, **result.params)
    errors, coverage = [], []
    for realisation in scoring:
        try:
            with executor.call_timeout(timeout_s):
                estimate = method(realisation.x, realisation.dt_s, (order,))
        except ValueError:
            errors.append(math.inf)
            continue
        scored = realisation.interior
        if not estimate.estimated(order)[scored].all():
            errors.append(math.inf)  # the tuner's rule: every scored sample estimated
            continue
        errors.append(error_metrics(estimate[order], realisation.truth[order], scored)["rmse"])
        coverage.append(float(estimate.valid[order].mean()))
    finite = np.isfinite(errors).all()
    low, high = error_interval(errors) if finite else (math.nan, math.nan)
    return {
        **row,
        "params": result.params,
        "predicted_rmse": float(np.mean(errors)) if finite else math.nan,
        "spread": float(np.std(errors)) if finite else math.nan,
        "low": low,
        "high": high,
        "coverage": float(np.mean(coverage)) if coverage else math.nan,
        "seconds": time.perf_counter() - start,
    }


def recommend_record(
    record,
    names=None,
    orders=(1, 2),
    seed=0,
    max_evaluations=None,
    jobs=1,
    progress=None,
    timeout_s=None,
):
    """:func:`recommend` for each channel of a
    :class:`~diffbench.bench.studies.user_data.UserRecord`, and the best method's estimates on
    the record itself (at its time stamps when it has irregular ones; the recommendation then
    runs on the record resampled, as a resampled method's is, onto the grid of its span with the
    step nearest its nominal one), computed on the channel divided by the recommendation's
    ``scale`` and scaled back. Returns ``{channel: (Recommendation, {order: Estimate})}``; a
    ``ValueError`` when no method could be recommended for an order. ``jobs``, ``progress``,
    ``timeout_s``: as for :func:`recommend`.
    """
    irregular = record.t is not None and not record.uniform
    if irregular:  # onto the grid a resampled method would use (methods._time_stamps)
        grid, grid_step = methods.uniform_grid(record.t, record.dt_s)
        on_grid = methods.to_grid(record.x, record.t, grid)
    results = {}
    with executor.dask_session(jobs):  # one Dask cluster for every channel, not one each
        for index, channel in enumerate(record.channels):
            x = record.x[:, index]
            uniform_x, step = (on_grid[:, index], grid_step) if irregular else (x, record.dt_s)
            recommendation = recommend(
                uniform_x,
                step,
                names,
                tuple(orders),
                seed,
                max_evaluations,
                jobs=jobs,
                progress=progress,
                timeout_s=timeout_s,
            )
            estimates = {}
            for order in orders:
                name, params = recommendation.best(order)
                stamps = record.t if irregular else None
                method = methods.get(name, **params)
                scale = recommendation.scale
                estimates[order] = scaled_estimate(
                    method(x / scale, record.dt_s, (0, order), t=stamps), scale
                )
            results[channel] = (recommendation, estimates)
    return results


def write_recommendation(record, results, out: Path) -> list[Path]:
    """``ranking.md``/``.csv`` (every method per channel and order, best first),
    ``derivatives.csv`` (the record's time, and per channel its samples and the best method's
    smoothed signal, ẋ and ẍ, empty where the method estimates nothing, each with its
    ``_valid`` column: 1 on the samples the predicted RMSE is for, the scored ones it estimates
    (marked valid by the method or not); 0 elsewhere, the ends it estimates included) and
    ``recommend.png`` (per channel: the samples and the smoothed signal, ẋ, and the
    periodogram with the noise floor and band) in ``out``. What reading the record warned
    about (``record.notes``) heads ``ranking.md``.
    """

    out.mkdir(parents=True, exist_ok=True)
    frames, header = [], [f"# Recommendation for {record.source}", ""]
    header += [f"**Warning:** {note}" for note in getattr(record, "notes", ())]
    if len(header) > 2:
        header.append("")
    for channel, (recommendation, _) in results.items():
        spectrum = recommendation.spectrum
        scaled = (
            f"; tuned on the record divided by {recommendation.scale:.6g} (an "
            "amplitude-dependent setting, e.g. a TV penalty, is for that)"
            if recommendation.scale != 1.0
            else ""
        )
        header.append(
            f"- `{channel}`: white-noise std {recommendation.noise_std:.4g}, signal band up to "
            f"{spectrum.band_hz:.4g} Hz (from the record's periodogram){scaled}"
        )
        frame = recommendation.table.copy()
        frame.insert(0, "channel", channel)
        frames.append(frame)
    table = pd.concat(frames, ignore_index=True)
    table.to_csv(out / "ranking.csv", index=False)
    shown = pd.DataFrame(
        {
            "channel": table["channel"],
            "n": table["order"].map({1: "ẋ", 2: "ẍ"}),
            "rank": [f"{r:.0f}" if np.isfinite(r) else "—" for r in table["rank"]],
            "method": table["method"],
            "settings": [_settings(p) for p in table["params"]],
            "predicted RMSE": [
                f"{m:.4g} ± {s:.2g}" if np.isfinite(m) else "—"
                for m, s in zip(table["predicted_rmse"], table["spread"], strict=True)
            ],
            f"{INTERVAL * 100:.0f} % of records": interval_cells(table["low"], table["high"]),
            "coverage": [f"{c:.3f}" if np.isfinite(c) else "—" for c in table["coverage"]],
            "package": table["package"],
        }
    )
    note = (
        "Each method tuned on surrogate records with the record's spectrum and a known truth "
        f"({TUNING_SURROGATES}), scored on {SCORING_SURROGATES} others: the predicted RMSE "
        "is their mean ± standard deviation, and the record's own error lies within the "
        f"next column's interval for {INTERVAL * 100:.0f} % of records like it (their "
        "errors' prediction interval, taken as log-normal), on all but the first and last "
        "5 % of the record, "
        "every one as the method estimates it: the samples flagged 1 in derivatives.csv's "
        "`_valid` columns. The others (the ends a "
        "method estimates, often many times worse than its middle) are written but flagged 0: "
        "no error is predicted for them."
    )
    (out / "ranking.md").write_text(
        "\n".join(header) + "\n\n" + markdown_table(shown) + "\n\n" + note + "\n"
    )
    time = record.t if record.t is not None else np.arange(record.x.shape[0]) * record.dt_s
    columns = {"time_s": time}
    scored = _scored(record)
    for index, (channel, (_, estimates)) in enumerate(results.items()):
        columns[channel] = record.x[:, index]
        first = estimates[min(estimates)]
        columns[f"{channel}_smoothed"] = first[0]
        columns[f"{channel}_smoothed_valid"] = (first.estimated(0) & scored).astype(np.int8)
        for order, estimate in estimates.items():
            columns[f"{channel}_d{order}"] = estimate[order]
            predicted = estimate.estimated(order) & scored
            columns[f"{channel}_d{order}_valid"] = predicted.astype(np.int8)
    pd.DataFrame(columns).to_csv(out / "derivatives.csv", index=False)  # exact round trip
    _figure(record, results, time, out / "recommend.png")
    return [out / "ranking.md", out / "ranking.csv", out / "derivatives.csv", out / "recommend.png"]


def _scored(record) -> np.ndarray:
    """The samples of ``record`` the prediction is for: all but ``END_FRACTION`` of
    the record at either end (of the grid it is resampled onto when its stamps are
    irregular)."""
    n_samples = record.x.shape[0]
    if record.t is None or record.uniform:
        return default_scored(n_samples)
    grid, _ = methods.uniform_grid(record.t, record.dt_s)
    inside = grid[default_scored(grid.size)]
    return (record.t >= inside[0]) & (record.t <= inside[-1])


def _settings(params) -> str:
    if not isinstance(params, dict):
        return str(params)
    return ", ".join(
        f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in params.items()
    )


def _figure(record, results, time, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = len(results)
    figure, axes = plt.subplots(rows, 3, figsize=(15, 3.6 * rows), squeeze=False)
    for row, (channel, (recommendation, estimates)) in enumerate(results.items()):
        index = record.channels.index(channel)
        first = estimates[min(estimates)]
        axes[row, 0].plot(time, record.x[:, index], ".", markersize=2, label="samples")
        axes[row, 0].plot(time, first[0], label="smoothed")
        axes[row, 0].set(xlabel="t [s]", ylabel=channel, title=f"{channel}: data")
        axes[row, 0].legend()
        for order, estimate in estimates.items():
            name, _ = recommendation.best(order)
            axes[row, 1].plot(time, estimate[order], label=f"{'ẋẍ'[order - 1]}: {name}")
        axes[row, 1].set(xlabel="t [s]", title="derivatives (recommended methods)")
        axes[row, 1].legend()
        spectrum = recommendation.spectrum
        axes[row, 2].loglog(spectrum.frequency_hz[1:], spectrum.power[1:], linewidth=0.7)
        axes[row, 2].axhline(
            spectrum.noise_floor,
            color="k",
            linestyle="--",
            label=f"noise floor (std {recommendation.noise_std:.3g})",
        )
        axes[row, 2].axvline(spectrum.band_hz, color="r", label=f"band {spectrum.band_hz:.3g} Hz")
        scaled = f" of {channel} / {recommendation.scale:.3g}" if recommendation.scale != 1 else ""
        axes[row, 2].set(xlabel="f [Hz]", ylabel=f"periodogram{scaled}", title="spectrum")
        axes[row, 2].legend()
    figure.tight_layout()
    figure.savefig(path, dpi=110, metadata=figures.PNG_METADATA)
    plt.close(figure)
