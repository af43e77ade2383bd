"""The paper's figures 1, 2, 3 and 5 and the frequency table, computed (pure functions
returning tidy frames) and written (CSV first, then the PNG drawn from what the CSV holds).

Guo, Gautier, Liu, Perruquetti, IEEE/ASME AIM 2015, sections III.C and IV; where the paper
compares Jacobi with Butterworth + Euler, these compare every registered method:
fig. 1 — errors of ẋ and ẍ over time on the paper signal, one row of panels per method;
fig. 2 — Bode magnitude of the second-order linear differentiators against the ideal s²;
fig. 3 — influence of κ = μ, q and T on the Jacobi Bode magnitude (Ts = 1 ms);
fig. 5 — errors of q̇1 and q̈1 on the simulated robot, one row of panels per method.
A method whose error dwarfs the others' is drawn on its own y range and flagged
(:func:`diffbench.bench.report.figures.error_scales`).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench.report import figures, tables
from diffbench.bench.studies.frequency import cutoff_hz, ideal_response, noise_gain
from diffbench.signals import robot2r

DT = 1e-3
SCENARIO = "paper-signal"
FREQUENCIES_HZ = np.logspace(-1, np.log10(500.0), 600)
# Fig. 3 varies one parameter at a time around kappa = mu = 12, q = 6, T = 0.2 s (the paper
# does not say what the others are held at; we take its section III.C settings). The
# "linear" rule serves every kappa > -1, including the figure's 0.1.
FIG3_BASE = {
    "kappa": 12.0,
    "mu": 12.0,
    "q": 6,
    "window_s": 0.2,
    "accel_window_s": 0.2,
    "rule": "linear",
}
FIG3_SWEEPS = {
    "kappa=mu": [{"kappa": v, "mu": v} for v in (0.1, 2.0, 12.0)],
    "q": [{"q": v} for v in (2, 6, 12)],
    "T": [{"window_s": v, "accel_window_s": v} for v in (0.05, 0.1, 0.2)],
}


def _db(values) -> np.ndarray:
    return 20 * np.log10(np.maximum(np.abs(values), 1e-300))


RESOLVED = 1e-8
"""The least |H|, as a fraction of a response's peak, that a Bode curve draws, as a floor
160 dB under the peak. The computed response carries rounding of about 1e-16 of the peak (a
sum of taps with cancellation): the paper Jacobi's n = 2 response, which falls to 1e-14 of
its peak above 300 Hz, moved there by 1 dB between OpenBLAS kernels, and by 1e-4 dB at 1e-11
of its peak, enough to change a pixel's shade. At 1e-8 of the peak and above the rounding
moves a curve by under 1e-7 dB."""


def _resolved_db(values) -> np.ndarray:
    """|H| in dB, floored at :data:`RESOLVED` times its peak (below, rounding shows)."""
    magnitude = np.abs(values)
    return _db(np.maximum(magnitude, RESOLVED * magnitude.max()))


def figure1_data(seed: int = 0, names=None) -> pd.DataFrame:
    """Errors of ẋ and ẍ over time of every method of ``names`` (default: every registered
    one) at its paper-signal preset, on one noise seed of the paper scenario.

    Columns: ``t_s``, ``x_noisy``, ``x_true``, ``velocity_true``, ``acceleration_true``,
    ``interior`` (the samples every method is scored on) and, per method,
    ``<method>_velocity_error`` and ``<method>_acceleration_error`` = estimate - truth (NaN
    where the method marks no valid estimate).
    """
    realisation = signals.get_scenario(SCENARIO).realise(seed)
    frame = {
        "t_s": realisation.t,
        "x_noisy": realisation.x,
        "x_true": realisation.truth[0],
        "velocity_true": realisation.truth[1],
        "acceleration_true": realisation.truth[2],
        "interior": realisation.interior,
    }
    for name in names or methods.available():
        method = methods.preset(name, "paper-signal")
        estimate = method(realisation.x, realisation.dt_s)
        for order, label in ((1, "velocity"), (2, "acceleration")):
            frame[f"{name}_{label}_error"] = estimate.trusted(order) - realisation.truth[order]
    return pd.DataFrame(frame)


def figure2_data(names=None) -> pd.DataFrame:
    """|H(f)| in dB of the second-order estimate of every linear method of ``names`` (default:
    every registered one) at its paper-signal preset (``<method>_db``, floored at
    :data:`RESOLVED` of its peak) and of the ideal s² (``ideal_db``)."""
    frame = {"frequency_hz": FREQUENCIES_HZ, "ideal_db": _db(ideal_response(FREQUENCIES_HZ, 2))}
    for name in names or methods.available():
        method = methods.preset(name, "paper-signal")
        if method.linear:
            frame[f"{name}_db"] = _resolved_db(method.frequency_response(FREQUENCIES_HZ, DT, 2))
    return pd.DataFrame(frame)


def figure3_data() -> pd.DataFrame:
    """|H(f)| in dB of the second-order Jacobi differentiator for the paper's parameter sweeps.
    Columns ``<parameter>=<value>_db`` (parameter in kappa=mu, q, T) and ``ideal_db``."""
    frame = {"frequency_hz": FREQUENCIES_HZ, "ideal_db": _db(ideal_response(FREQUENCIES_HZ, 2))}
    for parameter, variants in FIG3_SWEEPS.items():
        for change in variants:
            method = methods.get("jacobi", **{**FIG3_BASE, **change})
            value = next(iter(change.values()))
            frame[f"{parameter}={value:g}_db"] = _resolved_db(
                method.frequency_response(FREQUENCIES_HZ, DT, 2)
            )
    return pd.DataFrame(frame)


def frequency_table(dt: float = DT, probe_hz: float = 15.0, names=None) -> pd.DataFrame:
    """Per linear method at its paper-signal preset and order 1, 2: -3 dB cutoff (relative
    to the ideal), white-noise gain, and |H| at ``probe_hz`` against the ideal, in dB."""
    records = []
    for name in names or methods.available():
        method = methods.preset(name, "paper-signal")
        source = methods.preset_spec(name, "paper-signal").source
        if not method.linear:
            continue
        for order in (1, 2):
            response = method.frequency_response([probe_hz], dt, order)[0]
            records.append(
                {
                    "method": name,
                    "order": order,
                    "params": str(method.params()),
                    "cutoff_hz": cutoff_hz(method, dt, order),
                    "noise_gain": noise_gain(method, dt, order),
                    f"gain_db_at_{probe_hz:g}_hz": float(_db(response)),
                    f"ideal_db_at_{probe_hz:g}_hz": float(_db(ideal_response(probe_hz, order))),
                    "preset": source,
                }
            )
    return pd.DataFrame(records)


# --- writing: CSV first, the figure from the CSV ------------------------------------------
_NOTE_BOX = {"facecolor": "white", "alpha": 0.85, "lw": 0, "pad": 1}


def _tick(value, _position) -> str:
    """A y tick: 10000 stays 10000 and 1e+06 is written out, never an offset above the axis."""
    return f"{value:.5g}".replace("-", "−")


def _ticks():
    from matplotlib.ticker import FuncFormatter

    return FuncFormatter(_tick)


def _methods_in(columns, suffix: str) -> list[str]:
    """Method names of the columns ``<method><suffix>``, in column order."""
    return [column[: -len(suffix)] for column in columns if column.endswith(suffix)]


def _shade_outside(axis, t: np.ndarray, interior: np.ndarray) -> None:
    """Grey the samples outside the scored interior."""
    inside = t[interior]
    if inside.size:
        axis.axvspan(t[0], inside[0], color="0.9", zorder=0, lw=0)
        axis.axvspan(inside[-1], t[-1], color="0.9", zorder=0, lw=0)


def _error_rows(fig, grid, first_row: int, data: pd.DataFrame, names, panels, share) -> None:
    """One row per method of ``names``, one column per ``(column template, symbol, unit)`` of
    ``panels`` (the template's ``{}`` is the method): the error curve in the method's colour,
    its interior RMSE, a y range shared within the column unless the method is off that scale
    (then its own range, a red frame and a note)."""
    t = data["t_s"].to_numpy()
    interior = data["interior"].to_numpy(dtype=bool)
    styles = figures.method_styles(names)
    for column, (template, symbol, unit) in enumerate(panels):
        errors = {name: data[template.format(name)].to_numpy() for name in names}
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN interior: NaN, drawn empty
            rmse = {n: float(np.sqrt(np.nanmean(e[interior] ** 2))) for n, e in errors.items()}
            peak = {n: float(np.nanmax(np.abs(e[interior]))) for n, e in errors.items()}
        scales = figures.error_scales(rmse, peak)
        for row, name in enumerate(names):
            axis = fig.add_subplot(grid[first_row + row, column], sharex=share)
            _shade_outside(axis, t, interior)
            axis.axhline(0.0, color="0.5", lw=0.6)
            axis.plot(t, errors[name], lw=0.8, color=styles[name].color)
            limit = scales.own.get(name, scales.shared)
            axis.set_ylim(-limit, limit)
            axis.yaxis.set_major_formatter(_ticks())
            axis.set_ylabel(f"{symbol} error\n({unit})", fontsize=8)
            axis.tick_params(labelsize=7)
            axis.grid(alpha=0.3)
            axis.text(
                0.01,
                0.95,
                f"{name}: interior RMSE {rmse[name]:.3g} {unit}",
                transform=axis.transAxes,
                va="top",
                fontsize=8,
                color=styles[name].color,
                fontweight="bold",
                bbox=_NOTE_BOX,
            )
            if name in scales.own:
                axis.text(
                    0.99,
                    0.05,
                    f"off-scale: own y range ({scales.ratio[name]:.0f}x the median RMSE)",
                    transform=axis.transAxes,
                    va="bottom",
                    ha="right",
                    fontsize=7.5,
                    color="firebrick",
                    bbox=_NOTE_BOX,
                )
                for spine in axis.spines.values():
                    spine.set_edgecolor("firebrick")
                    spine.set_linewidth(1.4)
            if row < len(names) - 1:
                axis.tick_params(labelbottom=False)
            else:
                axis.set_xlabel("time (s)")


def _truth_row(fig, grid, top, t, interior, data: pd.DataFrame, truths) -> None:
    """Row 1 of an error figure: each true derivative ``(column, symbol, unit)`` in ``truths``."""
    for column, (name, symbol, unit) in enumerate(truths):
        axis = fig.add_subplot(grid[1, column], sharex=top)
        _shade_outside(axis, t, interior)
        axis.plot(t, data[name], color="black", lw=1.0)
        axis.set_ylabel(f"true {symbol} ({unit})", fontsize=8)
        axis.tick_params(labelsize=7, labelbottom=False)


def _finish_error_figure(fig, t, interior, heading: str, outside: str) -> None:
    """Grid lines on every panel and the title: ``heading``, then what the grey ends are."""
    for axis in fig.axes:
        axis.grid(alpha=0.3)
    margin = float(t[interior][0] - t[0]) if interior.any() else float("nan")
    fig.suptitle(
        f"{heading}\ngrey: the first and last {margin:g} s, {outside}; each column shares one "
        "y range except the red-framed, off-scale panels",
        fontsize=10,
    )


def _error_figure(n_methods: int, header_rows: int):
    """A figure with ``header_rows`` rows of context above ``n_methods`` error rows, two
    columns."""
    plt = figures.pyplot()
    heights = [1.5] * header_rows + [1.0] * n_methods
    fig = plt.figure(figsize=(11, 1.0 + 1.05 * sum(heights)), layout="constrained")
    grid = fig.add_gridspec(header_rows + n_methods, 2, height_ratios=heights)
    return fig, grid


def write_figure1(directory: Path, seed: int = 0, names=None) -> list[Path]:
    """``fig1_errors.csv`` (:func:`figure1_data`) and ``fig1_errors.png`` drawn from it: the
    signal, the true derivatives, then each method's errors of ẋ and ẍ in its own row."""
    csv = directory / "fig1_errors.csv"
    figure1_data(seed, names).to_csv(csv, index=False)
    data = pd.read_csv(csv)
    names = _methods_in(data.columns, "_velocity_error")
    fig, grid = _error_figure(len(names), header_rows=2)
    t, interior = data["t_s"].to_numpy(), data["interior"].to_numpy(dtype=bool)
    top = fig.add_subplot(grid[0, :])
    _shade_outside(top, t, interior)
    top.plot(t, data["x_noisy"], color="0.55", lw=0.5, label="measured (noisy)")
    top.plot(t, data["x_true"], color="black", lw=1.2, label="true")
    top.set_ylabel("x (units)")
    top.set_xlabel("time (s)", fontsize=8)
    top.tick_params(labelsize=7)
    top.legend(loc="upper right", fontsize=8, ncol=2)
    truths = (("velocity_true", "ẋ", "units/s"), ("acceleration_true", "ẍ", "units/s²"))
    _truth_row(fig, grid, top, t, interior, data, truths)
    panels = (("{}_velocity_error", "ẋ", "units/s"), ("{}_acceleration_error", "ẍ", "units/s²"))
    _error_rows(fig, grid, 2, data, names, panels, share=top)
    _finish_error_figure(
        fig,
        t,
        interior,
        f"Fig. 1: errors (estimate − truth) of every method at its "
        f"paper-signal preset, paper signal, noise seed {seed}",
        "not scored",
    )
    return [csv, figures.save_figure(fig, directory / "fig1_errors.png", tight=False)]


def write_figure2(directory: Path, names=None) -> list[Path]:
    """``fig2_bode.csv`` (:func:`figure2_data`) and ``fig2_bode.png``: |H| of every linear
    method against the ideal s² (the paper's view), and |H| relative to the ideal."""
    csv = directory / "fig2_bode.csv"
    figure2_data(names).to_csv(csv, index=False)
    data = pd.read_csv(csv)
    names = [name for name in _methods_in(data.columns, "_db") if name != "ideal"]
    styles = figures.method_styles(names)
    frequency = data["frequency_hz"]
    plt = figures.pyplot()
    fig, (absolute, relative) = plt.subplots(2, 1, figsize=(8, 9), height_ratios=[1.3, 1])
    absolute.semilogx(
        frequency, data["ideal_db"], color="black", lw=2.2, alpha=0.35, label="ideal s²"
    )
    relative.axhline(0.0, color="black", lw=2.2, alpha=0.35)
    relative.axhline(-3.0, color="0.4", lw=0.8, ls=":", label="-3 dB")
    for name in names:
        style = styles[name].line()
        absolute.semilogx(frequency, data[f"{name}_db"], lw=1.3, label=name, **style)
        relative.semilogx(frequency, data[f"{name}_db"] - data["ideal_db"], lw=1.3, **style)
    if "jacobi_db" in data:
        exact15 = float(
            _db(methods.preset("jacobi", "paper-signal").frequency_response([15.0], DT, 2))[0]
        )
        ideal15 = float(_db(ideal_response(15.0, 2)))
        absolute.plot([15.0], [exact15], "ko", ms=5)
        absolute.annotate(
            f"jacobi at 15 Hz: {exact15:.2f} dB\n(ideal {ideal15:.2f} dB; paper: 78.5 dB)",
            (15.0, exact15),
            (0.3, 150),
            fontsize=8,
            arrowprops={"arrowstyle": "->"},
        )
    absolute.set_ylim(-250, 200)
    absolute.set_ylabel("|H(f)| (dB re 1 s⁻²)")
    absolute.set_xlabel("frequency (Hz)")
    absolute.set_title(
        "|H| of the second-order estimate, each method at its paper-signal "
        "preset (flat 160 dB under its peak: below, rounding)",
        fontsize=9,
    )
    absolute.legend(fontsize=8, loc="lower left", ncol=2)
    relative.set_ylim(-60, 20)
    relative.set_xlim(2.0, 600.0)
    relative.set_ylabel("|H(f)| / |(i2πf)²| (dB)")
    relative.set_xlabel("frequency (Hz)")
    relative.set_title(
        "relative to the ideal (same curves, 2-500 Hz): 0 dB passes, below -3 dB cuts off",
        fontsize=9,
    )
    relative.legend(fontsize=8, loc="lower left")
    for axis in (absolute, relative):
        axis.grid(alpha=0.3, which="both")
    fig.suptitle("Fig. 2: Bode magnitude of the second-order differentiators (Ts = 1 ms)")
    return [csv, figures.save_figure(fig, directory / "fig2_bode.png")]


def write_figure3(directory: Path) -> list[Path]:
    csv = directory / "fig3_parameters.csv"
    figure3_data().to_csv(csv, index=False)
    data = pd.read_csv(csv)
    plt = figures.pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(7, 9), sharex=True)
    titles = {"kappa=mu": "influence of κ = μ", "q": "influence of q", "T": "influence of T (s)"}
    for axis, (parameter, title) in zip(axes, titles.items(), strict=True):
        for column in data.columns:
            if column.startswith(f"{parameter}="):
                axis.semilogx(data["frequency_hz"], data[column], label=column[: -len("_db")])
        axis.semilogx(data["frequency_hz"], data["ideal_db"], "r--", label="ideal")
        axis.set_ylim(-200, 200)
        axis.set_xlim(1, 500)
        axis.set_title(title, fontsize=9)
        axis.set_ylabel("magnitude (dB)")
        axis.legend(fontsize=7, loc="lower left")
        axis.grid(alpha=0.3, which="both")
    axes[-1].set_xlabel("frequency (Hz)")
    fig.suptitle("Fig. 3: Jacobi n = 2, parameters around κ = μ = 12, q = 6, T = 0.2 s")
    return [csv, figures.save_figure(fig, directory / "fig3_parameters.png")]


def write_frequency_table(directory: Path, names=None) -> list[Path]:
    """``frequency.md`` / ``.csv``: cutoff, white-noise gain and gain at 15 Hz per linear
    method at its paper-signal preset (the Markdown from what the CSV holds)."""

    csv = tables.write_csv(directory / "frequency.csv", frequency_table(names=names))
    stored = pd.read_csv(csv)
    shown = pd.DataFrame(
        {
            "method": stored["method"],
            "n": stored["order"].astype(str),
            "cutoff (Hz)": [f"{v:.2f}" for v in stored["cutoff_hz"]],
            "noise gain": [f"{v:.4g}" for v in stored["noise_gain"]],
            "gain at 15 Hz (dB)": [f"{v:.3f}" for v in stored["gain_db_at_15_hz"]],
            "ideal (dB)": [f"{v:.3f}" for v in stored["ideal_db_at_15_hz"]],
        }
    )
    text = (
        "# Frequency-domain scores at the paper-signal presets (Ts = 1 ms)\n\n"
        f"{tables.markdown_table(shown)}\n\n"
        "cutoff: lowest frequency where |H/(i2πf)ⁿ| falls to -3 dB; noise gain: output variance "
        "per unit input variance of white noise; gain at 15 Hz: 20 log10 |H(15 Hz)| against the "
        "ideal |(i2π·15)ⁿ|.\n"
    )
    return [csv, tables.write_text(directory / "frequency.md", text)]


def figure5_data(scenario_name: str = "robot-sim", seed: int = 0) -> pd.DataFrame:
    """Joint 1 of a simulated robot scenario: measured and true position, the true velocity
    and acceleration, and the errors (estimate - truth) of every registered method that has a
    ``robot`` preset (the paper's fig. 5, here against the exact truth).

    Columns: ``t_s``, ``q1_measured``, ``q1_true``, ``qd1_true``, ``qdd1_true``, ``interior``
    (the samples the identification uses) and, per method, ``qd1_<method>_error`` and
    ``qdd1_<method>_error`` (NaN where the method marks no valid estimate).
    """

    scenario = robot2r.get_robot_scenario(scenario_name)
    realisation = scenario.realise(seed)
    truth = realisation.truth
    frame = {
        "t_s": realisation.t,
        "q1_measured": realisation.q[:, 0],
        "q1_true": truth.q[:, 0],
        "qd1_true": truth.qd[:, 0],
        "qdd1_true": truth.qdd[:, 0],
        "interior": realisation.interior,
    }
    for name in methods.available():
        if "robot" not in methods.method_class(name).presets:
            continue
        estimate = methods.preset(name, "robot")(realisation.q, realisation.dt_s)
        frame[f"qd1_{name}_error"] = estimate.trusted(1)[:, 0] - truth.qd[:, 0]
        frame[f"qdd1_{name}_error"] = estimate.trusted(2)[:, 0] - truth.qdd[:, 0]
    return pd.DataFrame(frame)


def write_figure5(directory: Path, scenario_name: str = "robot-sim", seed: int = 0) -> list[Path]:
    """``fig5_robot_derivatives.csv`` (:func:`figure5_data`) and the PNG drawn from it: joint
    1's position, true velocity and acceleration, then each method's errors in its own row."""
    csv = directory / "fig5_robot_derivatives.csv"
    figure5_data(scenario_name, seed).to_csv(csv, index=False)
    data = pd.read_csv(csv)
    names = [
        name[len("qd1_") :]
        for name in _methods_in(data.columns, "_error")
        if name.startswith("qd1_")
    ]
    fig, grid = _error_figure(len(names), header_rows=2)
    t, interior = data["t_s"].to_numpy(), data["interior"].to_numpy(dtype=bool)
    top = fig.add_subplot(grid[0, :])
    _shade_outside(top, t, interior)
    quantisation = float(np.max(np.abs(data["q1_measured"] - data["q1_true"])))
    top.plot(
        t,
        data["q1_true"],
        color="black",
        lw=1.2,
        label=f"true (the measured q1 is within {quantisation:.1e} rad of it)",
    )
    top.legend(loc="upper left", fontsize=8)
    top.set_ylabel("q1 (rad)")
    top.set_xlabel("time (s)", fontsize=8)
    top.tick_params(labelsize=7)
    truths = (("qd1_true", "q̇1", "rad/s"), ("qdd1_true", "q̈1", "rad/s²"))
    _truth_row(fig, grid, top, t, interior, data, truths)
    panels = (("qd1_{}_error", "q̇1", "rad/s"), ("qdd1_{}_error", "q̈1", "rad/s²"))
    _error_rows(fig, grid, 2, data, names, panels, share=top)
    _finish_error_figure(
        fig,
        t,
        interior,
        f"Fig. 5: joint 1 of `{scenario_name}`, errors (estimate − truth) of "
        f"every method at its robot preset, noise seed {seed}",
        "not used",
    )
    return [csv, figures.save_figure(fig, directory / "fig5_robot_derivatives.png", tight=False)]


# --- error against position in the record --------------------------------------------------
END_FRACTION = 0.05
"""Each end of the record, as a fraction of its samples, in the ends-versus-middle table."""


def squared_error_sums(name: str, seeds: int) -> dict[int, np.ndarray]:
    r"""Sums over the noise seeds ``0..seeds-1`` (added in seed order) of the squared errors of
    ẋ and ẍ at every sample of method ``name`` (paper-signal preset) on the paper scenario
    (NaN where it marks no valid estimate): :math:`\sum_s (\hat{x}^{(n)}_{s,i} - x^{(n)}_i)^2`."""
    scenario = signals.get_scenario(SCENARIO)
    method = methods.preset(name, "paper-signal")
    sums = {}
    for seed in range(seeds):
        realisation = scenario.realise(seed)
        estimate = method(realisation.x, realisation.dt_s)
        for order in (1, 2):
            squared = (estimate.trusted(order) - realisation.truth[order]) ** 2
            sums[order] = sums.get(order, np.zeros(len(squared))) + squared
    return sums


def error_profile_frame(sums: dict[str, dict[int, np.ndarray]], seeds: int) -> pd.DataFrame:
    r"""RMS error over ``seeds`` noise seeds at each sample of the paper scenario, for ẋ and ẍ
    of every method of ``sums`` (:func:`squared_error_sums` by method name, in column order).

    At sample :math:`i`, :math:`e_i = \sqrt{\frac{1}{S}\sum_s (\hat{x}^{(n)}_{s,i} -
    x^{(n)}_i)^2}` over the :math:`S` seeds (NaN where the method marks no valid estimate). Columns:
    ``t_s``, ``position`` (:math:`i/(N-1)`), ``interior`` and, per method,
    ``<method>_velocity_rms_error`` and ``<method>_acceleration_rms_error``.
    """
    first = signals.get_scenario(SCENARIO).realise(0)
    n = len(first.t)
    frame = {"t_s": first.t, "position": np.arange(n) / (n - 1), "interior": first.interior}
    for name, squares in sums.items():
        for order, label in ((1, "velocity"), (2, "acceleration")):
            frame[f"{name}_{label}_rms_error"] = np.sqrt(np.asarray(squares[order]) / seeds)
    return pd.DataFrame(frame)


def ends_table(profile: pd.DataFrame, end_fraction: float = END_FRACTION) -> pd.DataFrame:
    """Per method and derivative, the RMS error over the first and the last ``end_fraction``
    of the record and over the middle between them (from :func:`error_profile_frame`), the
    worst end against the middle, and the fraction of the record the method marks valid."""
    n = len(profile)
    k = max(1, round(end_fraction * n))
    parts = {"start": slice(0, k), "middle": slice(k, n - k), "end": slice(n - k, n)}
    records = []
    for name in _methods_in(profile.columns, "_velocity_rms_error"):
        for label, symbol in (("velocity", "ẋ"), ("acceleration", "ẍ")):
            values = profile[f"{name}_{label}_rms_error"].to_numpy()
            record = {"method": name, "n": symbol}
            for part, where in parts.items():
                chunk = values[where]
                chunk = chunk[np.isfinite(chunk)]
                record[part] = float(np.sqrt(np.mean(chunk**2))) if len(chunk) else np.nan
            ends = [v for v in (record["start"], record["end"]) if np.isfinite(v)]
            record["worst end / middle"] = max(ends) / record["middle"] if ends else np.nan
            record["coverage"] = float(np.mean(np.isfinite(values)))
            records.append(record)
    return pd.DataFrame(records)


def write_error_profile(directory: Path, profile: pd.DataFrame, seeds: int) -> list[Path]:
    """``error_vs_position.csv`` (``profile``: :func:`error_profile_frame` over ``seeds``
    noise seeds), ``error_vs_position.png`` drawn from it (RMS error of ẋ and ẍ against
    position, log scale, one line per method) and
    ``ends.md``/``.csv`` (:func:`ends_table`)."""

    csv = directory / "error_vs_position.csv"
    profile.to_csv(csv, index=False)
    data = pd.read_csv(csv)
    names = _methods_in(data.columns, "_velocity_rms_error")
    styles = figures.method_styles(names)
    plt = figures.pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(11, 9), sharex=True)
    t, interior = data["t_s"].to_numpy(), data["interior"].to_numpy(dtype=bool)
    for axis, (label, symbol, unit) in zip(
        axes, (("velocity", "ẋ", "units/s"), ("acceleration", "ẍ", "units/s²")), strict=True
    ):
        _shade_outside(axis, t, interior)
        for name in names:
            axis.plot(
                t, data[f"{name}_{label}_rms_error"], lw=0.9, label=name, **styles[name].line()
            )
        axis.set_yscale("log")
        axis.set_ylabel(f"RMS error of {symbol} ({unit})")
        axis.grid(True, which="major", alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    axes[0].legend(fontsize=7, ncol=4, loc="upper center")
    fig.suptitle(
        f"Error against position in the record: RMS over {seeds} noise seeds of the paper "
        "scenario, each method at its paper-signal preset (grey: outside the common interior; "
        "a gap: samples the method does not estimate)",
        fontsize=9,
    )
    written = [csv, figures.save_figure(fig, directory / "error_vs_position.png")]
    table = ends_table(data)
    shown = table.copy()
    for column in ("start", "middle", "end", "worst end / middle"):
        shown[column] = [tables.nan_to_dash(v, 3) for v in table[column]]
    shown["coverage"] = [f"{v:.3f}" for v in table["coverage"]]
    written += tables.write_report(
        directory,
        "ends",
        table,
        shown,
        f"Ends against the middle: RMS error over the first and last {END_FRACTION:.0%} of the "
        f"record and over the middle, {seeds} noise seeds, paper-signal presets",
        "From `error_vs_position.csv`. **coverage**: the fraction of the record the method "
        "marks valid (the RMS errors are over those samples; the samples it estimates but "
        "does not trust count in the signal tables' whole-record columns).",
    )
    return written
