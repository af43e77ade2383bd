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
