"""Where work runs: in this process, on local worker processes that never outlive the run, or
on Dask.

``ordered_map(function, items, jobs)`` yields ``function(item)`` in the order of ``items``;
``completed_map`` yields ``(item, function(item))`` as each finishes (a caller storing results
loses none that finished when it is stopped). With ``jobs`` > 1 they use a
:class:`concurrent.futures.ProcessPoolExecutor`; when the caller stops iterating (an
exception, Ctrl-C, SIGTERM turned into :class:`Terminated`) pending work is cancelled and every
worker is terminated and joined. A worker whose parent dies without that chance (SIGKILL)
notices within a quarter second and exits, so no process is left behind.

With ``jobs`` a :class:`DaskWorkers` the items go to Dask's workers (``client.map``), a
LocalCluster started for the run or a running scheduler (one on a Slurm or PBS cluster through
dask-jobqueue); the results come back to this process as they do from local ones.
"""

from __future__ import annotations

import contextlib
import functools
import math
import multiprocessing
import os
import signal
import threading
import time
import warnings
import weakref
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

from threadpoolctl import threadpool_limits

from diffbench.methods import load_plugin

BLAS_THREADS = 1
"""BLAS threads each item runs with, here (a serial run) or on a local worker: ``--jobs N``
then runs N threads, not N times the cores (two workers of two OpenBLAS threads each on 2
cores spent 30 % more CPU time on ``recommend``, a spectral tuning 6 times its time), and
a serial run and a parallel one compute alike, bit for bit. Dask's workers get the same from
their nannies' environment (``OPENBLAS_NUM_THREADS=1``)."""

PARENT_POLL_S = 0.25
MAX_JOBS = 1024
"""The most worker processes (``--jobs``) a run starts."""


@dataclass(frozen=True)
class DaskWorkers:
    """Where a run goes to Dask (``dask.distributed``, the optional extra ``dask``): the
    scheduler at ``address``, or a :class:`~dask.distributed.LocalCluster` of ``workers``
    single-threaded worker processes started for the run (``processes=False``: threads of this
    process, for tests). Workers compute and return rows; this process alone stores them, so
    the store stays the one source of truth and a killed client resumes as any run does."""

    address: str | None = None
    workers: int = 2
    processes: bool = True
    plugins: tuple[str, ...] = ()  # plugin modules every worker loads before its first item


Workers = int | DaskWorkers
"""Local processes (an int, 1: here) or :class:`DaskWorkers`."""

SCHEDULER_TIMEOUT_S = 10


def _distributed():
    try:
        import dask.distributed
    except ImportError:
        raise ValueError(
            "Dask is not installed: pip install 'diffbench[dask]' (dask.distributed)"
        ) from None
    return dask.distributed


def check(spec: Workers) -> None:
    """Raise ``ValueError`` (saying what to do) unless ``spec`` can run: Dask installed and,
    for an address, a scheduler answering there."""
    if isinstance(spec, DaskWorkers):
        _distributed()
        if spec.address is not None:
            with _dask_client(spec):
                pass


_SHARED: dict[DaskWorkers, Any] = {}
"""The clients :func:`dask_session` keeps open, by their specification."""


@contextlib.contextmanager
def dask_session(spec: Workers):
    """Within it, every map on ``spec`` (a :class:`DaskWorkers`) uses one client and, for a
    local cluster, one cluster, started on entry and closed on exit, instead of one each
    (``recommend`` maps once per channel: a cluster each took seconds to start). Local
    worker counts (ints) need nothing: it does nothing for them."""
    if not isinstance(spec, DaskWorkers) or spec in _SHARED:
        yield
        return
    with _dask_client(spec) as client:
        _SHARED[spec] = client
        try:
            yield
        finally:
            del _SHARED[spec]


@contextlib.contextmanager
def _dask_client(spec: DaskWorkers):
    """A client of ``spec``'s scheduler (a LocalCluster started here and closed after), or
    the one a :func:`dask_session` holds open."""
    if spec in _SHARED:
        yield _SHARED[spec]
        return
    distributed = _distributed()
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    cluster = None
    if spec.address is None:
        cluster = LocalCluster(
            n_workers=spec.workers,
            threads_per_worker=1,
            processes=spec.processes,
            dashboard_address=None,
        )
        client = Client(cluster)
    else:
        try:
            client = Client(spec.address, timeout=SCHEDULER_TIMEOUT_S)
        except (OSError, TimeoutError) as error:
            raise ValueError(
                f"no Dask scheduler answers at {spec.address!r} ({error}); start one "
                "(`dask scheduler`, or dask-jobqueue on a cluster) or fix --scheduler"
            ) from None
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _with_plugins(plugins: tuple[str, ...], function: Callable[[Any], Any], item: Any) -> Any:
    """``function(item)`` on a worker that has loaded ``plugins`` (once per process)."""

    for module in plugins:
        load_plugin(module)
    return function(item)


def _with_warnings_caught(function: Callable[[Any], Any], item: Any) -> tuple[Any, list]:
    """``function(item)`` on a worker process, and the warnings it raised (message, category,
    file, line), each one: the client raises them again (:func:`_raised_again`), so that
    they reach its terminal or its warnings log (``bench.console``) rather than the worker's
    log."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = function(item)
    return result, [(str(w.message), w.category, w.filename, w.lineno) for w in caught]


def _raised_again(returned: tuple[Any, list]) -> Any:
    """The result of :func:`_with_warnings_caught`, its warnings raised here again."""
    result, caught = returned
    for message, category, filename, lineno in caught:
        warnings.warn_explicit(message, category, filename, lineno)
    return result


def _dask_map(function, items, spec: DaskWorkers, ordered: bool):
    from dask.distributed import as_completed as dask_completed

    if not items:
        return
    if spec.plugins:
        function = functools.partial(_with_plugins, spec.plugins, function)
    # workers in other processes keep their warnings in their own logs: bring them back
    # (threads of this process show them here already; catching is not thread-safe)
    elsewhere = spec.processes or spec.address is not None
    if elsewhere:
        function = functools.partial(_with_warnings_caught, function)
    unwrap = _raised_again if elsewhere else (lambda returned: returned)
    with _dask_client(spec) as client:
        futures = client.map(function, list(items), pure=False)
        where = {future.key: item for future, item in zip(futures, items, strict=True)}
        try:
            if ordered:
                for future in futures:
                    yield unwrap(future.result())
            else:
                for future in dask_completed(futures):
                    yield where[future.key], unwrap(future.result())
        finally:
            client.cancel(futures)


class CallTimeout(BaseException):
    """Raised inside a call that outlived its :func:`call_timeout` (a ``BaseException``, so
    that a method's own ``except Exception`` cannot swallow it)."""


@contextlib.contextmanager
def call_timeout(seconds: float | None):
    """Raise :class:`CallTimeout` in the code run inside if it lasts longer than ``seconds``
    (``None``: no limit).

    It uses the process's real-time interval timer (``SIGALRM``), so it works where the work
    runs in a process's main thread: here (a serial run) and on local workers (each runs its
    calls in its main thread, and goes on to the next call). A call is interrupted at the
    next Python instruction: code that stays inside one C call (a library's native loop that
    never returns) is not reached, nor are calls on Dask's worker threads, where the timer
    is not available, nor calls made while the process's timer is already set by the caller
    (those run without a limit).
    """
    if seconds is not None and not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"`timeout_s` must be a finite number > 0, got {seconds!r}")
    here = threading.current_thread() is threading.main_thread()
    if seconds is None or not here or not hasattr(signal, "setitimer"):
        yield
        return
    if signal.getitimer(signal.ITIMER_REAL)[0] > 0:  # the caller's own timer: leave it be
        yield
        return

    def expired(signum, frame):
        raise CallTimeout(seconds)

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


class Terminated(BaseException):
    """Raised in the main process when it receives SIGTERM (see :func:`terminate_on_sigterm`)."""


def terminate_on_sigterm():
    """Turn SIGTERM into a :class:`Terminated` exception in this process, so cleanup code runs;
    returns the handler it replaced (give it back to ``signal.signal`` when done). A process
    forked from this one (a library's own pool, such as PyNumDiff's ``optimize``) gets the
    default SIGTERM back as it starts (:func:`_default_sigterm_in_child`), so the kernel ends
    it whatever its main thread is doing; a Python handler runs only when the main thread
    returns to the interpreter, and a pool worker whose pool was terminating stayed blocked
    once for 998 s."""
    owner = os.getpid()

    def handler(signum, frame):
        if os.getpid() != owner:  # a child started otherwise than by fork
            os._exit(128 + signum)
        raise Terminated

    _OUR_HANDLERS.add(handler)
    return signal.signal(signal.SIGTERM, handler)


_OUR_HANDLERS: weakref.WeakSet = weakref.WeakSet()
"""The SIGTERM handlers :func:`terminate_on_sigterm` installed."""


def _default_sigterm_in_child() -> None:
    """In a freshly forked child: SIGTERM back to the default (termination by the kernel) if
    the handler inherited is ours; any other handler is the forking library's, kept."""
    try:
        if signal.getsignal(signal.SIGTERM) in _OUR_HANDLERS:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
    except ValueError:  # not the main thread of the main interpreter: nothing to change
        pass


os.register_at_fork(after_in_child=_default_sigterm_in_child)


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
    threadpool_limits(BLAS_THREADS, user_api="blas")  # for the worker's life


def forks() -> bool:
    """Whether worker processes are forked (they then inherit what this process registered:
    tasks, plugins); else they start afresh (spawn)."""
    return "fork" in multiprocessing.get_all_start_methods()


class WorkerDied(RuntimeError):
    """A local worker process died while the work ran (killed, out of memory, or code that
    ended the process: ``os._exit`` in a plugin); the results returned before it are kept by
    the caller, the rest are not computed."""

    def __init__(self, exit_code: int | None = None) -> None:
        how = f" (exit code {exit_code})" if exit_code is not None else ""
        super().__init__(
            f"a worker process died{how}: killed, out of memory, or a method ended its process "
            "(os._exit); finished results are stored: run the same command to resume, with "
            "--jobs 1 to see which method"
        )


def _results(futures, pool: ProcessPoolExecutor) -> Iterator:
    """Each future's result in the order given; a dead worker as :class:`WorkerDied`."""
    for future in futures:
        try:
            yield future.result()
        except BrokenProcessPool:
            processes = (getattr(pool, "_processes", None) or {}).values()
            codes = [process.exitcode for process in processes if process.exitcode]
            raise WorkerDied(codes[0] if codes else None) from None


def _context():
    return multiprocessing.get_context("fork" if forks() else "spawn")


def ordered_map(
    function: Callable[[Any], Any], items: Sequence[Any], jobs: Workers = 1
) -> Iterator:
    """``function(item)`` for each item, in order, on ``jobs`` local processes (1: here) or
    on Dask (:class:`DaskWorkers`)."""
    if isinstance(jobs, DaskWorkers):
        yield from _dask_map(function, items, jobs, ordered=True)
        return
    if _serial(items, jobs):
        with threadpool_limits(BLAS_THREADS, user_api="blas"):
            for item in items:
                yield function(item)
        return
    pool = _pool(jobs, len(items))
    try:
        futures = [pool.submit(function, item) for item in items]
        yield from _results(futures, pool)
    finally:
        stop(pool)


def completed_map(
    function: Callable[[Any], Any], items: Sequence[Any], jobs: Workers = 1
) -> Iterator[tuple[Any, Any]]:
    """``(item, function(item))`` for each item as soon as it is done, on ``jobs`` local
    processes (1: here, in order) or on Dask (:class:`DaskWorkers`)."""
    if isinstance(jobs, DaskWorkers):
        yield from _dask_map(function, items, jobs, ordered=False)
        return
    if _serial(items, jobs):
        with threadpool_limits(BLAS_THREADS, user_api="blas"):
            for item in items:
                yield item, function(item)
        return
    pool = _pool(jobs, len(items))
    try:
        futures = {pool.submit(function, item): item for item in items}
        for future in as_completed(futures):
            yield futures[future], next(_results([future], pool))
    finally:
        stop(pool)


def _serial(items: Sequence[Any], jobs: int) -> bool:
    """Whether ``items`` run here (one job, or at most one item); ``jobs`` checked."""
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"`jobs` must be an integer >= 1, got {jobs!r}")
    return jobs == 1 or len(items) <= 1


def _pool(jobs: int, n_items: int) -> ProcessPoolExecutor:
    """Worker processes that ignore Ctrl-C and exit when this process dies."""
    return ProcessPoolExecutor(
        max_workers=min(jobs, n_items),
        mp_context=_context(),
        initializer=_worker_start,
        initargs=(os.getpid(),),
    )


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
