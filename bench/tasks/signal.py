"""Signal tasks: a scenario with its exact derivatives (the paper signal, the grid, the limit
study's records, the Jacobi parameter study)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from diffbench import methods, signals
from diffbench.bench.core.plan import Entry
from diffbench.bench.core.roles import Role
from diffbench.bench.core.scores import estimate_on, score_estimate
from diffbench.bench.studies import limit, reports
from diffbench.bench.studies.frequency import decompose_error
from diffbench.bench.tasks.base import ScenarioTask


@dataclass(frozen=True, eq=False)
class SignalTask(ScenarioTask):
    """A signal scenario (``diffbench.signals``): each method differentiates the noisy samples
    and is scored against the exact derivatives, on the common interior and on its own valid
    samples; linear methods also get the bias and noise parts of their error."""

    scenario: signals.Scenario
    listed: bool = True
    kind: ClassVar[str] = "signal"

    def score(self, method, seed):
        realisation = self.scenario.realise(seed)
        estimate = estimate_on(method, realisation)
        rows = score_estimate(estimate, realisation.truth, realisation.interior)
        if method.linear:
            for order in (1, 2):
                parts = decompose_error(method, realisation, order)
                rows += [
                    {"order": order, "region": "interior", "metric": metric, "value": value}
                    for metric, value in (("bias_rmse", parts.bias), ("noise_rmse", parts.noise))
                ]
        return rows

    def tuning_data(self, seed):
        return self.scenario.realise(seed)

    def longest_record(self):
        realisation = self.scenario.realise(0)
        return realisation.x.shape[0], realisation.dt_s

    def refusal(self, method):
        """Also: a causal method on irregular time stamps (it takes uniform sampling only)."""
        if method.causal and self.scenario.sampling:
            return "a causal method takes uniformly sampled records only; this one is not"
        return super().refusal(method)

    def report(self, cells, tunings, directory):
        return reports.signal_report(self.name, self.description, cells, tunings, directory)


@dataclass(frozen=True, eq=False)
class LimitTask(SignalTask):
    """A signal task on a random signal with a known spectrum (the ``limit-*`` scenarios):
    also the efficiency of every entry against the least error any method can reach
    (:mod:`diffbench.bench.studies.limit`)."""

    listed: bool = False

    def score(self, method, seed):
        """Also the interior RMSE of the optimal estimator on the same realisation (metric
        ``optimal_rmse``; the filter's for a causal method): the efficiency is then a paired
        ratio, free of the realisation's own luck
        (:func:`diffbench.bench.studies.limit.efficiency_table`)."""
        rows = super().score(method, seed)
        return rows + limit.optimal_scores(self.scenario, seed, causal=method.causal)

    def report(self, cells, tunings, directory):
        written = super().report(cells, tunings, directory)
        return written + limit.write_efficiency_report(cells, directory)


# Table I of the paper: one parameter raised or lowered from the test-signal preset at a time.
INFLUENCE_VARIANTS = (
    ("", {}),
    ("κ = μ = 6", {"kappa": 6.0, "mu": 6.0}),
    ("κ = μ = 24", {"kappa": 24.0, "mu": 24.0}),
    ("q = 2", {"q": 2}),
    ("q = 10", {"q": 10}),
    ("T = 0.1 s", {"window_s": 0.1, "accel_window_s": 0.1}),
    ("T = 0.3 s", {"window_s": 0.3, "accel_window_s": 0.3}),
)


@dataclass(frozen=True, eq=False)
class JacobiInfluenceTask(SignalTask):
    """The paper's table I measured: the Jacobi preset with one design parameter moved at a
    time, on the paper signal: bias (truncation) and noise parts of the error."""

    listed: bool = True

    @property
    def name(self) -> str:
        return "jacobi-influence"

    @property
    def description(self) -> str:
        return (
            "Table I of the paper measured: bias and noise parts of the Jacobi error on "
            "paper-signal as κ = μ, q and T move from the paper's preset."
        )

    def lineup(self, method_names=None):
        if method_names and list(method_names) != ["jacobi"]:
            raise ValueError("jacobi-influence runs the jacobi method only")
        base = methods.preset("jacobi", "paper-signal").params()
        return [
            Entry(
                "jacobi",
                {**base, **change},
                Role(origin="variant", preset="paper-signal", by="paper", variant=label),
            )
            for label, change in INFLUENCE_VARIANTS
        ]

    def report(self, cells, tunings, directory):
        return reports.influence_report(cells, directory)
