"""The peers task ``pynumdiff-suite``: PyNumDiff's own test records (f0-f5 at 31 samples and its
irregular f4), every PyNumDiff method diffbench wraps at its tests' parameters, every native
method tuned by the truth, scored over every sample
(:mod:`diffbench.bench.studies.pynumdiff_suite`).

An item study: an item is a method at one setting on one record, computed (tuned, then scored
on every seed) by one worker and stored whole, so ``--jobs``/Dask, resuming and reruns behave as
in every item study. Without PyNumDiff installed only the native rows are computed.
"""

from __future__ import annotations

from dataclasses import dataclass

from diffbench import methods
from diffbench.bench.studies import pynumdiff_suite as suite
from diffbench.bench.tasks.items import Item, ItemStudy, _json
from diffbench.signals import pynumdiff_suite as records

TESTS, ORACLE = "PyNumDiff tests", "oracle"
"""Where an item's setting comes from: PyNumDiff's tests, or the truth on the tuning seed."""


def _package(name: str) -> str:
    return "diffbench" if suite.is_native(name) else name.split(".")[0]


@dataclass(frozen=True, eq=False)
class PyNumDiffSuite(ItemStudy):
    """PyNumDiff's test records (``records``: default every one of
    :data:`diffbench.signals.pynumdiff_suite.SCENARIOS`); with ``tune_peers`` the PyNumDiff
    methods also tuned by the truth, beside their tests' settings."""

    records: tuple[str, ...] = tuple(records.SCENARIOS)
    tune_peers: bool = True
    name: str = "pynumdiff-suite"
    description: str = (
        "PyNumDiff's own test signals f0-f5 (31 samples) and its irregular f4: PyNumDiff's "
        "methods at its tests' parameters, ours tuned by the truth, ẋ RMSE over every sample"
    )
    default_seeds = 10

    def __post_init__(self) -> None:
        for record in self.records:
            records.get(record)  # ValueError naming the valid ones

    def lineup_names(self, method_names) -> list[str]:
        """The methods compared: those named (default every offline one), less the peers
        other than PyNumDiff's."""
        names = list(method_names or methods.available())
        return [n for n in names if suite.is_native(n) or n.startswith("pynumdiff.")]

    def items(self, method_names, seeds):
        count = len(seeds)
        # an oracle's item names the seeds it is tuned on: a store written when it was tuned on
        # one seed is not read as the same item
        oracle = {"source": ORACLE, "seeds": count, "tuning_seeds": suite.TUNING_SEEDS}
        items = []
        for record in self.records:
            for name in self.lineup_names(method_names):
                if suite.is_native(name):
                    items.append(Item(record, {"method": name, **oracle}))
                    continue
                for params in suite.TEST_SETTINGS.get(name, []):
                    setting = {"method": name, "source": TESTS, "params": params, "seeds": count}
                    items.append(Item(record, setting))
                if self.tune_peers or name not in suite.TEST_SETTINGS:
                    items.append(Item(record, {"method": name, **oracle}))
        return items

    def compute(self, item):
        setting = item.setting
        name, record = setting["method"], item.name
        if setting["source"] == ORACLE:
            try:
                tuned = suite.oracle_setting(record, name)
                params, tuned_on = tuned["params"], tuned["tuned_on"]
            except ValueError as error:  # no setting covers enough to be tuned: its defaults
                params, tuned_on = {}, f"defaults, not tuned: {error}"
        else:
            params, tuned_on = setting["params"], "—"
        source = "defaults" if tuned_on.startswith("defaults") else setting["source"]
        scenario = records.get(record)
        stamps = methods.method_class(name).time_stamps if scenario.sampling else "uniform grid"
        described = {
            "record": record,
            "method": name,
            "package": _package(name),
            "source": source,
            "params": params,
            "time_stamps": stamps,
            "tuned_on": tuned_on,
        }
        rows = suite.entry_rows(record, name, params, setting["seeds"])
        return [_json({**described, **row}) for row in rows]

    def write(self, rows, directory):
        flat = [row for found in rows.values() for row in found]
        seeds = max(item.setting["seeds"] for item in rows)
        return suite.write_report(flat, directory, seeds)


def builtin_tasks() -> list:
    """The suite on every record."""
    return [PyNumDiffSuite()]
