"""Where work runs: in this process, or on local worker processes that never outlive the run.

``ordered_map(function, items, jobs)`` yields ``function(item)`` in the order of ``items``;
``completed_map`` yields ``(item, function(item))`` as each finishes (a caller storing results
loses none that finished when it is stopped). With ``jobs`` > 1 they use a
:class:`concurrent.futures.ProcessPoolExecutor`; when the caller stops iterating (an
exception, Ctrl-C, SIGTERM turned into :class:`Terminated`) pending work is cancelled and every
worker is terminated and joined. A worker whose parent dies without that chance (SIGKILL)
notices within a quarter second and exits, so no process is left behind.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

PARENT_POLL_S = 0.25


class Terminated(BaseException):
    """Raised in the main process when it receives SIGTERM (see :func:`terminate_on_sigterm`)."""


def terminate_on_sigterm():
    """Turn SIGTERM into a :class:`Terminated` exception, so cleanup code runs; returns the
    handler it replaced (give it back to ``signal.signal`` when done)."""

    def handler(signum, frame):
        raise Terminated

    return signal.signal(signal.SIGTERM, handler)


def _watch_parent(parent: int) -> None:
    while True:
        if os.getppid() != parent:
            os._exit(1)
        time.sleep(PARENT_POLL_S)


def _worker_start(parent: int) -> None:
    # Ctrl-C reaches the whole process group: the parent handles it and stops the workers.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def forks() -> bool:
    """Whether worker processes are forked (they then inherit what this process registered:
    tasks, plugins); else they start afresh (spawn)."""
    return "fork" in multiprocessing.get_all_start_methods()


def _context():
    return multiprocessing.get_context("fork" if forks() else "spawn")


def ordered_map(function: Callable[[Any], Any], items: Sequence[Any], jobs: int = 1) -> Iterator:
    """``function(item)`` for each item, in order, on ``jobs`` local processes (1: here)."""
    if _serial(items, jobs):
        for item in items:
            yield function(item)
        return
    pool = _pool(jobs, len(items))
    try:
        futures = [pool.submit(function, item) for item in items]
        for future in futures:
            yield future.result()
    finally:
        stop(pool)


def completed_map(
    function: Callable[[Any], Any], items: Sequence[Any], jobs: int = 1
) -> Iterator[tuple[Any, Any]]:
    """``(item, function(item))`` for each item as soon as it is done, on ``jobs`` local
    processes (1: here, in order)."""
    if _serial(items, jobs):
        for item in items:
            yield item, function(item)
        return
    pool = _pool(jobs, len(items))
    try:
        futures = {pool.submit(function, item): item for item in items}
        for future in as_completed(futures):
            yield futures[future], future.result()
    finally:
        stop(pool)


def _serial(items: Sequence[Any], jobs: int) -> bool:
    """Whether ``items`` run here (one job, or at most one item); ``jobs`` checked."""
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"`jobs` must be an integer >= 1, got {jobs!r}")
    return jobs == 1 or len(items) <= 1


def _pool(jobs: int, n_items: int) -> ProcessPoolExecutor:
    """Worker processes that ignore Ctrl-C and exit when this process dies."""
    return ProcessPoolExecutor(max_workers=min(jobs, n_items), mp_context=_context(),
                               initializer=_worker_start, initargs=(os.getpid(),))  # fmt: skip


def stop(pool: ProcessPoolExecutor) -> None:
    """Cancel pending work and terminate and join every worker process of ``pool``."""
    # ProcessPoolExecutor has no public way to stop running workers before Python 3.14
    # (terminate_workers); its process table is the only handle on them.
    processes = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=5)
        if process.is_alive():
            process.kill()
            process.join(timeout=5)
