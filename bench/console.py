"""How the ``diffbench`` process behaves: exit codes, one-line errors and warnings, an output
that names itself in its errors, SIGTERM, a closed pipe.

Exit codes: 0 done; 2 a usage error (bad input, or a machine that cannot take the output: a
full disk, the file size limit, a read-only folder; one line on stderr, never a traceback); 1 an
internal error (its traceback: a bug, never disguised as a usage error); 130 interrupted by
Ctrl-C, 143 by SIGTERM (every finished result is stored; the same command resumes; no worker
process is left behind); 141 when the reader of the output went away (``diffbench list | head``).
"""

from __future__ import annotations

import argparse
import errno
import functools
import os
import signal
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from diffbench.bench.core.errors import BadInput, DiffbenchWarning
from diffbench.bench.core.executor import Terminated, WorkerDied, terminate_on_sigterm

EXIT_INTERNAL = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141
EXIT_TERMINATED = 143

STDOUT_NAME = "the standard output"


class Parser(argparse.ArgumentParser):
    """An argparse parser whose errors are :class:`BadInput` (one line, exit code 2)."""

    def error(self, message: str):  # argparse would print usage and exit itself
        raise BadInput(message)


def run(dispatch: Callable[[list[str]], None], argv: list[str] | None = None) -> int:
    """``dispatch(argv)`` as the ``diffbench`` process runs it; returns the exit code.

    Parameters
    ----------
    dispatch : callable
        Parses the command line and does what it says.
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code (see the module's documentation).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    previous = terminate_on_sigterm()
    stdout = sys.stdout
    if stdout is not None and stdout is sys.__stdout__:
        sys.stdout = NamedOutput(stdout)  # its OSErrors name it (e.g. `> /dev/full`)
    try:
        with warnings.catch_warnings():  # restores the caller's warning display afterwards
            warnings.showwarning = functools.partial(one_line_warning, warnings.showwarning)
            warnings.simplefilter("always", DiffbenchWarning)  # each one, every time
            try:
                return _run(dispatch, argv)
            finally:
                _third_party_note()
                route_third_party_warnings(None)
    finally:
        # called in-process (a test, a script), the caller keeps its own SIGTERM handling
        signal.signal(signal.SIGTERM, previous)
        sys.stdout = stdout


WARNINGS_LOG = "diffbench-warnings.log"
"""The file in a run's output folder (``--out``) that other packages' warnings go to."""

_third_party: dict = {"log": None, "start": 0}
"""Where this process writes other packages' warnings (None: the terminal), and the log's size
when this run began (a forked worker inherits both)."""


def route_third_party_warnings(log: Path | None) -> None:
    """Send the warnings of other packages (PyNumDiff's even-width kernel, scipy's filter
    design...) to ``log``, one line each, instead of the terminal, where they would bury the
    run's own output; local worker processes started afterwards by forking do the same
    (Dask's workers show them in their own logs). ``None``: the terminal again."""
    log = None if log is None else Path(log)
    start = log.stat().st_size if log is not None and log.is_file() else 0
    _third_party.update(log=log, start=start)


def one_line_warning(fallback, message, category, filename, lineno, file=None, line=None):
    """diffbench's own warnings (about the user's record, a failed cell...) as one line on
    stderr, ``diffbench: warning: ...`` (or the category's ``label``); other packages' into
    the log set by :func:`route_third_party_warnings`, or by ``fallback`` (the usual form)."""
    if category.__module__.startswith("diffbench."):
        label = getattr(category, "label", "warning")
        text = f"diffbench: {label}: {message}" if label else str(message)
        print(text, file=sys.stderr if file is None else file)
    elif _third_party["log"] is not None and _logged(message, category, filename, lineno):
        return
    else:
        fallback(message, category, filename, lineno, file, line)


def _logged(message, category, filename, lineno) -> bool:
    """Append the warning to the log as one line (``time pid category: message (file:line)``);
    False if the log cannot be written (the warning is then shown as usual)."""
    log = _third_party["log"]
    stamp = time.strftime("%Y-%m-%dT%H:%M:%S")
    text = " ".join(str(message).split())
    entry = f"{stamp} pid {os.getpid()} {category.__name__}: {text} ({filename}:{lineno})\n"
    try:
        log.parent.mkdir(parents=True, exist_ok=True)
        with open(log, "a", encoding="utf-8") as handle:  # one write: whole lines from workers
            handle.write(entry)
    except OSError:
        return False
    return True


def _third_party_note() -> None:
    """One line at the end of a run whose log grew (here or in its workers): how many
    warnings, where."""
    log, start = _third_party["log"], _third_party["start"]
    try:
        if log is None or log.stat().st_size <= start:
            return
        with open(log, "rb") as handle:
            handle.seek(start)
            count = handle.read().count(b"\n")
    except OSError:  # the log went away meanwhile: nothing to point to
        return
    plural = "s" if count != 1 else ""
    print(f"diffbench: {count} warning{plural} from other packages in {log}", file=sys.stderr)


class NamedOutput:
    """The standard output, whose ``OSError`` names it as its file (Python's own names none)."""

    def __init__(self, stream) -> None:
        self._stream = stream
        self.error: OSError | None = None

    def _named(self, call, *args):
        try:
            return call(*args)
        except BrokenPipeError:
            raise
        except OSError as error:
            if error.errno is None or error.filename is not None:
                raise
            # kept: a caller may swallow it (argparse's help does), the exit code may not
            self.error = type(error)(error.errno, error.strerror, STDOUT_NAME)
            raise self.error from None

    def write(self, text: str) -> int:
        return self._named(self._stream.write, text)

    def flush(self) -> None:
        return self._named(self._stream.flush)

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def _run(dispatch: Callable[[list[str]], None], argv: list[str]) -> int:
    try:
        dispatch(argv)
    except BadInput as error:
        message = str(error).splitlines()[0] if str(error) else "bad command line"
        _to_stderr(f"diffbench: error: {message}")
        return EXIT_USAGE
    except OSError as error:
        return _os_error(error)
    except (KeyboardInterrupt, Terminated) as stop:
        # a run says what it stored and how to resume (``resume``), as an exit would
        code = EXIT_INTERRUPTED if isinstance(stop, KeyboardInterrupt) else EXIT_TERMINATED
        resume = getattr(stop, "resume", None)
        default = "interrupted" if code == EXIT_INTERRUPTED else "terminated"
        _to_stderr(f"diffbench: {resume or default}")
        return _flushed(code) if resume else code
    except WorkerDied as error:
        _to_stderr(f"diffbench: error: {error}")
        return EXIT_INTERNAL
    except SystemExit as stop:  # argparse's --help and errors, a plugin's sys.exit at import
        code = int(stop.code or 0) if not isinstance(stop.code, str) else EXIT_USAGE
        return _flushed(code)
    return _flushed(0)


def _to_stderr(line: str) -> None:
    """Print ``line`` on the standard error; where that fails too (``2>/dev/full``) there is
    nowhere left to say it, and the exit code alone tells."""
    try:
        print(line, file=sys.stderr)
    except OSError:
        pass


def _flushed(code: int) -> int:
    """``code``, once the standard output is flushed; the flush's ``OSError`` (a full disk
    under ``--help > /dev/full``) as one line and its exit code."""
    try:
        sys.stdout.flush()
    except OSError as error:
        return _os_error(error)
    swallowed = getattr(sys.stdout, "error", None)  # a failed write someone caught
    return _os_error(swallowed) if swallowed is not None else code


def _os_error(error: OSError) -> int:
    """An ``OSError`` the machine gave (the reader of the output gone, a disk full, the file
    size limit, a read-only or unwritable folder): one line naming the file, and the exit
    code; one without an error number is diffbench's bug, raised again (its traceback)."""
    if isinstance(error, BrokenPipeError):
        return _broken_pipe()
    if error.errno is None:
        raise error
    name = error.filename
    if name == STDOUT_NAME:
        _silence_stdout()  # so that Python's own flush at exit does not fail again
    where = f": {name}" if name is not None else " (writing a report or reading input)"
    reason = error.strerror or os.strerror(error.errno)
    if error.errno == errno.ENOTDIR:  # e.g. --out naming a file
        reason += " (a file stands where the path needs a folder: give a folder, e.g. --out)"
    _to_stderr(f"diffbench: error: {reason}{where}")
    return EXIT_USAGE


def _silence_stdout() -> None:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())


def _broken_pipe() -> int:
    # The reader went away (e.g. `| head`): stop quietly, and keep Python's exit-time flush of
    # stdout from failing again (the pattern the Python documentation gives for SIGPIPE).
    _silence_stdout()
    return EXIT_BROKEN_PIPE
