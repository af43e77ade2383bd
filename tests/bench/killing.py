"""Kill a ``diffbench`` command mid-run: shared by the tests that a killed study resumes."""

import os
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from diffbench.bench.core.store import STORE_FILE, Store

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
CLI = [sys.executable, "-m", "diffbench.bench"]

SLOW_METHODS = """
import os
import time

from diffbench.methods import register
from diffbench.methods.savitzky_golay import SavitzkyGolay


@register("slow.savitzky_golay")
class SlowSavitzkyGolay(SavitzkyGolay):
    \"\"\"Savitzky-Golay that takes 50 ms more a call while $DIFFBENCH_TEST_SLOW is set.\"\"\"

    def _estimate(self, x, dt, orders):
        if os.environ.get("DIFFBENCH_TEST_SLOW"):
            time.sleep(0.05)
        return super()._estimate(x, dt, orders)
"""

STOPPABLE_RUN = [
    "run",
    "paper-signal",
    "--seeds",
    "30",
    "--methods",
    "finite_difference,slow.savitzky_golay,butterworth",
    "--plugin",
    "slow_methods",
    "--no-progress",
]
"""90 cells, of which 30 take 50 ms more each while ``DIFFBENCH_TEST_SLOW`` is set (with the
environment of :func:`slow_plugin_env`): at least 0.75 s of work for each of 2 workers, so
that a stop lands while they compute (without the plugin's sleep the 90 cells take 0.3 s)."""


def slow_plugin_env(folder: Path) -> dict[str, str]:
    """The environment that finds the ``slow_methods`` plugin, written into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "slow_methods.py").write_text(SLOW_METHODS)
    return {**ENV, "PYTHONPATH": f"{ROOT}{os.pathsep}{folder}"}


def finish(command: list[str], out: Path, env: dict[str, str]) -> None:
    """Run ``diffbench COMMAND --out OUT`` to its end (exit 0) in a process of its own."""
    result = subprocess.run([*CLI, *command, "--out", str(out)], env=env, capture_output=True)
    assert result.returncode == 0, result.stderr.decode()


def stored_cells(directory: Path) -> int:
    """The distinct cells (task, method, params, seed, role) stored in ``directory``."""
    if not directory.exists():
        return 0
    frame = Store(directory).cells_frame()
    cell = ["task", "method", "params", "seed", "role"]
    return 0 if frame.empty else len(frame[cell].drop_duplicates())


def stored_items(directory: Path) -> int:
    """The items of item studies stored in ``directory`` (read without opening a Store, which
    would create the database while the killed run creates it)."""
    path = directory / STORE_FILE
    if not path.exists():
        return 0
    try:
        with sqlite3.connect(path) as connection:
            return connection.execute("SELECT count(*) FROM studies").fetchone()[0]
    except sqlite3.OperationalError:  # the tables are being created
        return 0


def kill_once_stored(
    command: list[str], out: Path, count: Callable[[Path], int], at_least: int
) -> int:
    """Run ``diffbench COMMAND --out OUT`` as a process, SIGKILL it once ``count(OUT/store)``
    reaches ``at_least``, and return the count then stored."""
    process = subprocess.Popen(
        [*CLI, *command, "--out", str(out)],
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 300
    while count(out / "store") < at_least:
        assert process.poll() is None, "the run ended before it could be killed"
        assert time.monotonic() < deadline, "nothing stored in time"
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=60)
    return count(out / "store")
