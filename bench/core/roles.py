"""What a row of a table is: the role of a parameter set (a preset, tuned, a variant), as data.

A :class:`Role` is stored with every cell as columns (``origin``, ``preset``, ``by``,
``criterion``, ``tuned_order``, ``tuning_seed``, ``cutoff_hz``, ``variant``, and
``tuning_seeds`` and ``tuned_region`` when they are not 1 and ``"interior"``); tables read
those columns and print :meth:`Role.label`, never parse prose.
"""

from __future__ import annotations

import dataclasses
from typing import Any

ORDER_SYMBOLS = {0: "x", 1: "ẋ", 2: "ẍ"}
TUNED_REGIONS = ("interior", "whole")
# fields stored only when they differ from these defaults (older records lack them)
OPTIONAL_DEFAULTS = {"tuning_seeds": 1, "tuned_region": "interior", "tuned_on": ""}
CRITERION_NAMES = {
    "oracle": "oracle",
    "no-truth": "no-truth",
    "pynumdiff": "PyNumDiff-loss",
    "surrogate": "surrogate",
}
CRITERION_LEGEND = {
    "oracle": "minimises the interior (or whole-record) RMSE against the truth on the tuning seed",
    "no-truth": "minimises a data-only spectral estimate of that RMSE, from a bandlimit guess "
    "f_c (linear methods only)",
    "pynumdiff": "minimises PyNumDiff's data-only loss (re-integration RMSE + γ·TV, γ from f_c)",
    "surrogate": "data only: minimises the RMSE on surrogate records drawn from the tuning "
    "record's own spectrum, whose truth is known (the procedure of diffbench recommend)",
}


@dataclasses.dataclass(frozen=True)
class Role:
    """Where a parameter set comes from.

    Parameters
    ----------
    origin : {"preset", "tuned", "variant"}
    preset : str
        The preset key (``"paper-signal"``, ``"robot"``, ``"default"``) for a preset or the
        base of a variant; empty for tuned parameters.
    by : str
        Who chose the preset: ``"paper"``, ``"diffbench"`` or ``"defaults"``.
    criterion : str
        Tuning criterion (``"oracle"``, ``"no-truth"``, ``"pynumdiff"``); empty otherwise.
    tuned_order : int or None
        The derivative order tuned for.
    tuning_seed : int or None
        The (first) noise seed tuned on (never a scored seed).
    cutoff_hz : float or None
        The bandlimit guess of a data-only criterion.
    variant : str
        What a variant changes from its base preset (e.g. ``"q = 2"``).
    tuning_seeds : int
        How many consecutive noise seeds, from ``tuning_seed`` on, the tuning averaged its loss
        over (1: one seed, and the field is left out of :meth:`as_dict`, so the identity of a
        one-seed tuning's cells is what it was before the field existed).
    tuned_region : {"interior", "whole"}
        The samples the tuning loss was taken on (left out of :meth:`as_dict` when
        ``"interior"``, likewise).
    tuned_on : str
        The task whose realisations the setting was tuned on, when it is not the task scored
        (``diffbench tune --tuned-on``: a setting carried from one record to another of the
        same step); empty, and left out of :meth:`as_dict`, when it is the task scored.
    """

    origin: str
    preset: str = ""
    by: str = ""
    criterion: str = ""
    tuned_order: int | None = None
    tuning_seed: int | None = None
    cutoff_hz: float | None = None
    variant: str = ""
    tuning_seeds: int = 1
    tuned_region: str = "interior"
    tuned_on: str = ""

    def __post_init__(self) -> None:
        if self.origin not in ("preset", "tuned", "variant"):
            raise ValueError(f"`origin` must be preset, tuned or variant, got {self.origin!r}")
        if self.origin == "tuned" and (
            self.criterion not in CRITERION_NAMES or self.tuned_order not in (1, 2)
        ):
            raise ValueError("a tuned role needs a criterion and a tuned_order of 1 or 2")
        if isinstance(self.tuning_seeds, bool) or not (
            isinstance(self.tuning_seeds, int) and self.tuning_seeds >= 1
        ):
            raise ValueError(f"`tuning_seeds` must be an integer >= 1, got {self.tuning_seeds!r}")
        if self.tuned_region not in TUNED_REGIONS:
            raise ValueError(
                f"`tuned_region` must be one of {', '.join(TUNED_REGIONS)}, got "
                f"{self.tuned_region!r}"
            )
        if self.origin != "tuned" and (self.tuning_seeds, self.tuned_region, self.tuned_on) != (
            1,
            "interior",
            "",
        ):
            raise ValueError("only a tuned role has tuning seeds, a tuned region and a tuned task")
        if not isinstance(self.tuned_on, str):
            raise ValueError(f"`tuned_on` must be a task name, got {self.tuned_on!r}")

    @classmethod
    def of_preset(cls, key: str, by: str) -> Role:
        return cls(origin="preset", preset=key, by=by)

    @classmethod
    def tuned(
        cls,
        criterion: str,
        order: int,
        seed: int,
        cutoff_hz: float | None = None,
        seeds: int = 1,
        region: str = "interior",
        tuned_on: str = "",
    ) -> Role:
        return cls(
            origin="tuned",
            criterion=criterion,
            tuned_order=int(order),
            tuning_seed=int(seed),
            cutoff_hz=None if cutoff_hz is None else float(cutoff_hz),
            tuning_seeds=seeds,
            tuned_region=region,
            tuned_on=tuned_on,
        )

    def as_dict(self) -> dict[str, Any]:
        """The stored fields; ``tuning_seeds``, ``tuned_region`` and ``tuned_on`` only when
        they are not 1, ``"interior"`` and empty."""
        fields = dataclasses.asdict(self)
        for name, default in OPTIONAL_DEFAULTS.items():
            if fields[name] == default:
                del fields[name]
        return fields

    @property
    def label(self) -> str:
        """``preset (paper)``, ``oracle-tuned for ẍ``, ``no-truth-tuned for ẋ (f_c 20 Hz)``,
        ``oracle-tuned for ẋ (whole record, 5 seeds)``, ``oracle-tuned for ẋ (whole record, on
        paper-signal-999ms)``, ``variant: q = 2``."""
        if self.origin == "preset":
            return "class defaults" if self.by == "defaults" else f"preset ({self.by})"
        if self.origin == "variant":
            return f"variant: {self.variant}" if self.variant else "base preset"
        text = f"{CRITERION_NAMES[self.criterion]}-tuned for {ORDER_SYMBOLS[self.tuned_order]}"
        details = [f"f_c {self.cutoff_hz:.4g} Hz"] if self.cutoff_hz is not None else []
        if self.tuned_region == "whole":
            details.append("whole record")
        if self.tuning_seeds > 1:
            details.append(f"{self.tuning_seeds} seeds")
        if self.tuned_on:
            details.append(f"on {self.tuned_on}")
        return text + (f" ({', '.join(details)})" if details else "")

    @property
    def sort_key(self) -> tuple:
        """Presets first, then variants, then tuned by criterion and order."""
        rank = {"preset": 0, "variant": 1, "tuned": 2}[self.origin]
        criterion = list(CRITERION_NAMES).index(self.criterion) if self.criterion else -1
        return (
            rank,
            criterion,
            self.tuned_order or 0,
            self.tuned_region == "whole",
            self.tuning_seeds,
            self.tuned_on,
            self.variant,
            self.tuning_seed or 0,
        )
