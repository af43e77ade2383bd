"""The 2R robot in the loop: the loop against the independent continuous-PD simulator, a loss
reported, the torque noise against the differentiators' noise gains, and the task."""

import numpy as np
import pandas as pd
import pytest

from diffbench import methods
from diffbench.bench.cli import main
from diffbench.bench.studies import loop
from diffbench.signals import robot2r


def test_the_loop_with_the_exact_velocity_at_a_fine_step_is_the_continuous_pd_simulation():
    spec = loop.LoopSpec(
        duration_s=1.0,
        control_dt_s=1e-4,
        substeps=1,
        bandwidth_hz=5.0,
        encoder_step_rad=1e-12,
        encoder_noise_rad=0.0,
    )
    run = loop.run_loop(spec, None, seed=0)
    assert run.lost_at_s is None
    trajectory = robot2r.random_point_to_point(spec.trajectory_seed, spec.duration_s)
    motion = robot2r.simulate_pd(
        trajectory,
        robot2r.PAPER_PARAMETERS,
        robot2r.LINK1_LENGTH_M,
        robot2r.COULOMB_SLOPE,
        5.0,
        1e-4,
        1,
    )
    n = run.t.size
    # zero-order hold of the torque over 0.1 ms against a torque evaluated continuously:
    # the motions agree to a small fraction of the tracking error itself
    error = np.abs(run.q - motion.q[:n]).max()
    tracking = np.abs(motion.q[:n] - run.q_desired).max()
    assert error < 1e-3 * tracking
    assert tracking > 1e-4  # the moves do start within the first second


def test_a_slow_filter_in_the_loop_is_reported_as_a_loss():
    spec = loop.LoopSpec(duration_s=3.0)
    rows = loop.loop_scores(spec, methods.get("causal_butterworth", order=4, cutoff_hz=5.0), 0)
    values = {(r["order"], r["metric"]): r["value"] for r in rows}
    assert values[(1, "stable")] == 0.0
    assert 0.0 < values[(1, "lost_at_s")] < 3.0
    assert (1, "tracking_rmse") not in values
    exact = loop.run_loop(spec, None, 0)
    assert exact.lost_at_s is None


def test_the_torque_noise_of_backward_differences_follows_their_noise_gain():
    """With the encoder's noise white, the velocity term's noise is Kd times the noise gain
    sqrt(sum b_j^2) / dt of the difference: the torque noise of p = 2 over p = 1 is the ratio
    of their gains (2.55 / 1.41)."""
    spec = loop.LoopSpec(duration_s=3.0)
    noise = {}
    for accuracy in (1, 2):
        method = methods.get("backward_difference", accuracy=accuracy)
        rows = loop.loop_scores(spec, method, 0)
        values = {(r["order"], r["metric"]): r["value"] for r in rows}
        noise[accuracy] = values[(1, "torque_noise_rms")]
    gains = {
        p: np.sqrt(np.sum(methods.get("backward_difference", accuracy=p).taps(1, 1.0) ** 2))
        for p in (1, 2)
    }
    assert noise[2] / noise[1] == pytest.approx(gains[2] / gains[1], rel=0.05)


def test_the_loop_needs_a_causal_method():
    with pytest.raises(ValueError, match="savitzky_golay is not causal"):
        loop.loop_scores(loop.LoopSpec(duration_s=1.0), methods.get("savitzky_golay"), 0)


def test_the_loop_task_reports_every_setting_and_each_method_s_best(tmp_path):
    from diffbench.bench import tasks

    name = "online-2r-loop-2s"
    if name not in tasks.available_tasks():
        tasks.register_task(tasks.LoopTask(name=name, loop=loop.LoopSpec(duration_s=2.0)))
    argv = [
        "run",
        name,
        "--methods",
        "backward_difference",
        "--seeds",
        "1",
        "--out",
        str(tmp_path),
        "--no-progress",
    ]
    assert main(argv) == 0
    table = pd.read_csv(tmp_path / "online" / "loop.csv")
    assert list(table["setting"]) == [f"p = {p}" for p in (1, 2, 3, 4)]
    assert (table["loop"] == "stable").all()
    # more accuracy, more noise: the torque noise grows with p
    assert table["τ₁ noise (N·m)"].is_monotonic_increasing
    best = pd.read_csv(tmp_path / "online" / "loop_best.csv")
    assert list(best["setting"]) == ["p = 1"]
