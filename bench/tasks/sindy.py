"""The SINDy discovery task family: ``sindy`` (every system of
:mod:`diffbench.signals.dynamics`) and ``sindy-<system>`` (one), each scoring which
differentiator lets sparse regression find the system's equations
(:mod:`diffbench.bench.studies.sindy`).

An item study: an item is one entry (a method and where its setting comes from) on one system
at one noise level, computed (tuned if it is an oracle's, then scored on every seed) by one
worker and stored whole, so ``--jobs``/Dask, resuming and reruns behave as in every item study.
"""

from __future__ import annotations

from dataclasses import dataclass

from diffbench import methods
from diffbench.bench.studies import sindy as study
from diffbench.bench.studies import sindy_report
from diffbench.bench.tasks.items import Item, ItemStudy, _json
from diffbench.signals.dynamics import SYSTEMS, get_system

DEFAULT_METHODS = (
    "spectral",
    "savitzky_golay",
    "jacobi",
    "butterworth",
    "kalman",
    "gaussian_kernel",
    "smoothing_spline",
    "finite_difference",
)
"""The native methods compared by default, each oracle-tuned, recommended from the data and
at its preset: the fast ones (the Gaussian processes and total variation cost seconds a call
on 5000 samples, and a tuning calls a method hundreds of times; ``--methods`` adds them)."""


def _package(source: str, method: str) -> str:
    if source in ("pysindy", "weak form"):
        return "pysindy"
    return methods.package_of(method) if source in ("oracle", "recommend", "preset") else "—"


@dataclass(frozen=True, eq=False)
class SindyStudy(ItemStudy):
    """Discovery on ``systems`` at ``levels``; the entries of the module docstring of
    :mod:`diffbench.bench.studies.sindy` for the methods given (default
    :data:`DEFAULT_METHODS`)."""

    systems: tuple[str, ...] = tuple(SYSTEMS)
    levels: tuple[float, ...] = study.NOISE_LEVELS
    steps: tuple[int, ...] = study.STEPS
    starts: tuple[int, ...] = study.STARTS
    name: str = "sindy"
    description: str = (
        "SINDy discovery on six systems with known equations at two sampling steps, from one "
        "initial condition or three, at four noise levels: the coefficient error and support "
        "each differentiator leads to, against the weak form"
    )
    default_seeds = 5

    def __post_init__(self) -> None:
        if not self.starts or any(
            isinstance(k, bool) or not isinstance(k, int) or k < 1 for k in self.starts
        ):
            raise ValueError(f"`starts` must be whole numbers >= 1, got {self.starts!r}")
        for system in self.systems:
            found = get_system(system)  # ValueError naming the close ones
            if max(self.starts) > found.max_starts:
                raise ValueError(f"`starts` must be at most {found.max_starts} for {system}")

    def entries(self, method_names) -> list[dict]:
        """Every entry compared (source, method, fixed params or None when found per item)."""
        names = list(method_names or DEFAULT_METHODS)
        unknown = [n for n in names if "." not in n and n not in methods.available()]
        if unknown:
            methods.method_class(unknown[0])  # ValueError with the close names
        entries = [{"source": "truth", "method": "exact ẋ", "params": {}}]
        for name in names:
            entries.append({"source": "oracle", "method": name, "params": None})
            entries.append({"source": "recommend", "method": name, "params": None})
            if "." not in name:  # a native method: its preset too
                entries.append({"source": "preset", "method": name, "params": None})
        entries += [
            {"source": "pysindy", "method": n, "params": {}} for n in study.PYSINDY_DEFAULTS
        ]
        entries += [
            {"source": "pysindy", "method": f"SINDyDerivative.{kind}", "params": params}
            for kind, params in study.DERIVATIVE_README.items()
        ]
        entries.append({"source": "weak form", "method": "WeakPDELibrary", "params": {}})
        entries.append({"source": "weak form", "method": study.WEAK_FORM_TUNED, "params": None})
        return entries

    def items(self, method_names, seeds):
        entries = self.entries(method_names)
        items = []
        for system in self.systems:
            for every in self.steps:
                for starts in self.starts:
                    # the system's own step and one start are named by leaving ``every``
                    # and ``starts`` out of the setting (the keys before either existed)
                    record = {} if every == 1 else {"every": every}
                    record |= {} if starts == 1 else {"starts": starts}
                    for level in self.levels:
                        for entry in entries:
                            setting = {**entry, "level": level, "seeds": len(seeds), **record}
                            items.append(Item(system, setting))
        return items

    def compute(self, item):
        setting = dict(item.setting)
        source, method, level = setting["source"], setting["method"], setting["level"]
        every, starts = setting.get("every", 1), setting.get("starts", 1)
        record = (item.name, level)
        tuned_loss = None
        try:
            if source == "oracle":
                found = study.oracle_params(*record, method, every, starts)
                setting["params"], tuned_loss = found["params"], found["loss"]
            elif source == "recommend":
                setting["params"] = study.recommended_params(*record, method, every, starts)
            elif source == "weak form" and setting["params"] is None:
                setting["params"] = study.weak_form_params(*record, every, starts)
            elif source == "preset":
                dt = get_system(item.name).dt_s * every
                setting["params"] = study.preset_params(method, dt)
        except ValueError as error:  # no setting covers the record: one row says why
            failed = {
                "seed": 0,
                **dict.fromkeys(study.SCORES, float("nan")),
                "failure": f"no {source} setting: {error}",
            }
            return [_json({**self._described(item.name, setting), **failed})]
        described = self._described(item.name, setting)
        described["tuned_loss"] = tuned_loss
        rows = study.entry_rows(*record, setting, setting["seeds"], every, starts)
        return [_json({**described, **row}) for row in rows]

    @staticmethod
    def _described(system: str, setting: dict) -> dict:
        return {
            "system": system,
            "step_s": get_system(system).dt_s * setting.get("every", 1),
            "starts": setting.get("starts", 1),
            "level": setting["level"],
            "source": setting["source"],
            "method": setting["method"],
            "package": _package(setting["source"], setting["method"]),
            "params": setting["params"] or {},
        }

    def write(self, rows, directory):
        flat = [row for found in rows.values() for row in found]
        seeds = max(item.setting["seeds"] for item in rows)
        return sindy_report.write_report(flat, directory, seeds)


def builtin_tasks() -> list:
    """``sindy`` on every system, and ``sindy-<system>`` on each."""
    return [SindyStudy()] + [
        SindyStudy(
            systems=(system,),
            name=f"sindy-{system}",
            description=f"SINDy discovery on {system}: {get_system(system).reference}",
        )
        for system in SYSTEMS
    ]
