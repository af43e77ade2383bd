"""What there is: every registered method described, every task listed (``diffbench list``,
``api.list_methods`` / ``api.list_tasks``)."""

from __future__ import annotations

from diffbench import methods
from diffbench.bench.tasks import available_tasks, get_task

STAMPS_SHOWN = {"uniform": "uniform only"}
"""How a method's handling of time stamps is worded, where not its own name."""


def list_methods() -> list[str]:
    """Every registered method described (kind, package, reference, time stamps; each
    parameter's range, tuning range and default; its presets), and the peers not available;
    the lines ``diffbench list`` prints."""
    lines = []
    plugins = methods.loaded_plugins()
    for name in methods.available(causal=None):
        cls = methods.method_class(name)
        shipped = [p for p in plugins if f"{cls.__module__}.".startswith(f"{p.module}.")]
        origin = f"; plugin {shipped[0].label}" if shipped else ""
        kind = ("linear" if cls.linear else "nonlinear") + (", causal" if cls.causal else "")
        lines.append(
            f"  {name}  ({kind}; runs {methods.package_of(name)}; {cls.reference}{origin}; "
            f"time stamps: {STAMPS_SHOWN.get(cls.time_stamps, cls.time_stamps)})"
        )
        if cls.second_derivative != "native":
            lines.append(f"      ẍ: {cls.second_derivative}")
        for spec in methods.params_of(cls):
            tuned = ""
            if spec.tune_low is not None:
                scale = ", log" if spec.log else ""
                tuned = f" [tune {spec.tune_low:g}..{spec.tune_high:g}{scale}]"
            lines.append(
                f"      {spec.name}: {spec.describe_range()}{tuned} default {spec.default!r}"
                f"  - {spec.doc}"
            )
        for key, chosen in cls.presets.items():
            values = ", ".join(f"{k}={v!r}" for k, v in chosen.values.items())
            lines.append(f"      preset {key} (by {chosen.by}): {values}  ({chosen.source})")
    for prefix, why in methods.missing_peers().items():
        lines.append(f"  {prefix}.*  not available: {why}")
    return lines


def list_tasks() -> list[str]:
    """Every listed task with its kind and description, and a count of the unlisted ones (the
    grid's and limit's parts); the lines ``diffbench list`` prints."""
    lines = []
    for name in available_tasks(listed_only=True):
        task = get_task(name)
        lines.append(f"  {name} [{task.kind}]: {task.description}")
    unlisted = [n for n in available_tasks() if not get_task(n).listed]
    for prefix, kind, how in (
        ("grid-", "grid", "diffbench grid"),
        ("limit-", "limit (random signals, known least error)", "diffbench run TASK"),
    ):
        names = [n for n in unlisted if n.startswith(prefix)]
        if names:
            lines.append(f"  ... and {len(names)} {kind} tasks ({names[0]} ... {names[-1]}; {how})")
    return lines
