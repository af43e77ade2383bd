"""The 2R robot identification benchmark: each differentiator feeds IDIM-LS, and is scored by
the parameters it lets IDIM-LS find (the truth is known in simulation) and by the torques the
identified model predicts on a fresh trajectory."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from diffbench.bench.identification import (
    Identification,
    decimation_factor,
    idim_ls,
    parallel_decimation,
)
from diffbench.methods import Method
from diffbench.signals import robot2r

EDGE_SAMPLES = 4  # decimated samples dropped at each end (start-up of the decimation filter)
PASSBAND_PER_BANDWIDTH = 5.0  # F_p = 5 x the position-loop bandwidth (the paper's rule)


def estimate_states(method: Method, q: np.ndarray, dt: float, interior: np.ndarray):
    """(q_f, q̇, q̈) from ``method`` on the measured q (n, 2), restricted to the longest run of
    samples valid for every order and inside ``interior``; returns them and that slice."""
    estimate = method(q, dt)
    valid = interior & estimate.valid[0] & estimate.valid[1] & estimate.valid[2]
    if not valid.any():
        raise ValueError(f"`method` {method.name!r} leaves no valid sample inside the interior")
    indices = np.flatnonzero(valid)
    chosen = slice(int(indices[0]), int(indices[-1]) + 1)
    if not valid[chosen].all():
        raise ValueError("the valid samples of the estimate are not contiguous")
    return estimate[0][chosen], estimate[1][chosen], estimate[2][chosen], chosen


def identify(method: Method, realisation, scenario) -> tuple[Identification, tuple]:
    """IDIM-LS of the base parameters with q̇, q̈ (and the filtered q) from ``method``.

    The identification assumes the simulation's friction law (viscous plus the continuous
    Coulomb (2/π)·atan(α q̇), α = ``scenario.coulomb_slope``); Y and W are decimated together
    with F_p = 5 × the closed-loop bandwidth.
    """
    q, qd, qdd, chosen = estimate_states(method, realisation.q, realisation.dt_s,
                                         realisation.interior)  # fmt: skip
    observation = robot2r.regressor(q, qd, qdd, scenario.link1_length_m, scenario.coulomb_slope)
    factor = decimation_factor(1 / realisation.dt_s,
                               PASSBAND_PER_BANDWIDTH * scenario.bandwidth_hz)  # fmt: skip
    result = idim_ls(observation, realisation.tau[chosen], robot2r.PARAMETER_NAMES, factor,
                     EDGE_SAMPLES)  # fmt: skip
    return result, (q, qd, qdd, chosen)


@functools.lru_cache(maxsize=8)
def well_excited(scenario) -> tuple[bool, ...]:
    """Parameters identified to better than 10 % relative standard deviation with the exact
    velocities and accelerations (noise seed 0): the paper's rule for essential parameters,
    applied once per scenario so that every method is scored on the same set."""
    realisation = scenario.realise(0)
    truth, inside = realisation.truth, realisation.interior
    observation = robot2r.regressor(truth.q[inside], truth.qd[inside], truth.qdd[inside],
                                    scenario.link1_length_m, scenario.coulomb_slope)  # fmt: skip
    factor = decimation_factor(1 / realisation.dt_s,
                               PASSBAND_PER_BANDWIDTH * scenario.bandwidth_hz)  # fmt: skip
    result = idim_ls(observation, realisation.tau[inside], robot2r.PARAMETER_NAMES, factor,
                     EDGE_SAMPLES)  # fmt: skip
    return tuple(bool(v) for v in result.relative_sigma_pct < 10.0)


def _add_row(rows: list, metric: str, value, order: int = 0) -> None:
    rows.append({"order": order, "region": "identification", "metric": metric,
                 "value": float(value)})  # fmt: skip


def _parameter_rows(result: Identification) -> list[dict[str, Any]]:
    """Rows of X̂, σ_X and %σ_Xr per parameter, cond(W) and the number of equations."""
    rows: list[dict[str, Any]] = []
    for index, name in enumerate(result.names):
        _add_row(rows, f"estimate.{name}", result.estimate[index])
        _add_row(rows, f"sigma.{name}", result.sigma[index])
        _add_row(rows, f"rel_sigma_pct.{name}", result.relative_sigma_pct[index])
    _add_row(rows, "cond_W", result.condition)
    _add_row(rows, "equations", result.equations)
    return rows


def score_identification(method: Method, scenario, seed: int) -> list[dict[str, Any]]:
    """Tidy rows of one identification cell (region ``identification``, order 0)."""
    realisation = scenario.realise(seed)
    result, (_, qd, qdd, chosen) = identify(method, realisation, scenario)
    truth = scenario.true_parameters
    rows = _parameter_rows(result)
    add = functools.partial(_add_row, rows)
    for index, name in enumerate(result.names):
        add(f"rel_error.{name}", (result.estimate[index] - truth[index]) / abs(truth[index]))
    mask = np.array(well_excited(scenario))
    add(
        "param_error_norm",
        np.linalg.norm((result.estimate - truth)[mask]) / np.linalg.norm(truth[mask]),
    )
    add("sigma_rho", result.sigma_rho)
    fresh = scenario.motion(validation=True)
    predicted = robot2r.regressor(fresh.q, fresh.qd, fresh.qdd, scenario.link1_length_m,
                                  scenario.coulomb_slope) @ result.estimate  # fmt: skip
    for joint in (0, 1):
        error = predicted[:, joint] - fresh.tau[:, joint]
        rms = np.sqrt(np.mean(fresh.tau[:, joint] ** 2))
        add(f"torque_rmse.joint{joint + 1}", np.sqrt(np.mean(error**2)))
        add(f"torque_rel_rmse.joint{joint + 1}", np.sqrt(np.mean(error**2)) / rms)
    exact = realisation.truth
    for order, values in ((1, qd), (2, qdd)):
        reference = (exact.qd if order == 1 else exact.qdd)[chosen]
        add("derivative_rmse", np.sqrt(np.mean((values - reference) ** 2)), order=order)
    return rows


# --- the real robot: DFKI double pendulum, cross-validated over its six runs ---------------
@dataclass(frozen=True)
class DfkiCrossValidation:
    """Leave-one-run-out identification on the DFKI double pendulum recordings.

    A cell's "seed" is the held-out run: the base parameters are identified (IDIM-LS) on the
    five other runs with q̇, q̈ from the method, then the identified model predicts the measured
    torque of the held-out run (both decimated alike, F_p = ``passband_hz``), on the joints that
    are actuated in that run (a joint whose commanded torque is identically zero is passive:
    its "measured" torque is only the driver's noise). The lab's own model (its published
    parameters) is scored on the same samples with the same derivatives.
    """

    name: str = "dfki-cv"
    description: str = (
        "DFKI double pendulum (real 2R, vertical plane): identify on 5 runs, predict the "
        "measured torque of the sixth (leave-one-run-out), resampled to 2 ms."
    )
    preset: str = "robot"
    dt_s: float = 0.002
    passband_hz: float = 5.0
    interior_margin_s: float = 0.6


def _dfki_equations(method: Method, run, spec: DfkiCrossValidation):
    from diffbench.signals import dfki

    interior = (run.t >= run.t[0] + spec.interior_margin_s) & (
        run.t <= run.t[-1] - spec.interior_margin_s
    )
    q, qd, qdd, chosen = estimate_states(method, run.q, run.dt_s, interior)
    return dfki.pendulum_regressor(q, qd, qdd), run.tau[chosen], (q, qd, qdd, chosen)


@functools.lru_cache(maxsize=8)
def dfki_run(index: int, dt_s: float):
    from diffbench.signals import dfki

    return dfki.load_dfki_run(index, dt_s)


def score_dfki_fold(method: Method, spec: DfkiCrossValidation, held_out: int):
    """Rows of one leave-one-run-out fold (region ``identification``)."""
    from diffbench.signals import dfki

    if not 0 <= held_out < dfki.DFKI_RUNS:
        raise ValueError(f"the held-out run (seed) must be in 0..{dfki.DFKI_RUNS - 1}, "
                         f"got {held_out}")  # fmt: skip
    factor = decimation_factor(1 / spec.dt_s, spec.passband_hz)
    training_w, training_y = [], []
    for index in range(dfki.DFKI_RUNS):
        if index == held_out:
            continue
        observation, torques, _ = _dfki_equations(method, dfki_run(index, spec.dt_s), spec)
        training_w.append(parallel_decimation(observation, factor)[EDGE_SAMPLES:-EDGE_SAMPLES])
        training_y.append(parallel_decimation(torques, factor)[EDGE_SAMPLES:-EDGE_SAMPLES])
    result = idim_ls(np.concatenate(training_w), np.concatenate(training_y),
                     dfki.PENDULUM_PARAMETER_NAMES)  # fmt: skip
    run = dfki_run(held_out, spec.dt_s)
    observation, torques, (q, qd, qdd, chosen) = _dfki_equations(method, run, spec)
    measured = parallel_decimation(torques, factor)[EDGE_SAMPLES:-EDGE_SAMPLES]
    predicted = parallel_decimation(observation @ result.estimate, factor)
    lab = parallel_decimation(dfki.lab_model_torques(q, qd, qdd), factor)
    predicted, lab = predicted[EDGE_SAMPLES:-EDGE_SAMPLES], lab[EDGE_SAMPLES:-EDGE_SAMPLES]
    rows = _parameter_rows(result)
    add = functools.partial(_add_row, rows)
    active = np.any(run.tau_commanded != 0, axis=0)
    for joint in (0, 1):
        if not active[joint]:
            continue
        add(
            f"torque_rmse.joint{joint + 1}",
            np.sqrt(np.mean((predicted[:, joint] - measured[:, joint]) ** 2)),
        )
        add(
            f"lab_torque_rmse.joint{joint + 1}",
            np.sqrt(np.mean((lab[:, joint] - measured[:, joint]) ** 2)),
        )
    add("velocity_rmse_vs_driver", np.sqrt(np.mean((qd - run.velocity_driver[chosen]) ** 2)),
        order=1)  # fmt: skip
    return rows
