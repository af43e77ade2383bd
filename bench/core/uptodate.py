"""Reports already written from the same inputs are not written again.

A report (its tables and figures) is a deterministic function of its inputs: the stored rows it
reads, the command's options and the code (diffbench's files and the versions of what it runs
on). Rerunning ``make bench`` with everything stored would otherwise redraw every figure and
recompute the paper's figures, most of a rerun's time. So each report directory keeps, beside
its files, the key of the inputs it was written from and the list of files written
(:data:`KEY_FILE`, not committed); a rerun whose key matches and whose files all still exist
skips the report and lists the same files.

The key is conservative: any change of diffbench's code or data files, of a package version, of
the options, or of the store tables read (any added row, whatever its task: the store's content
version) writes the report again.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path

from diffbench.bench.core.provenance import SOURCE_ROOT, provenance

KEY_FILE = ".diffbench-report.json"
"""The file, in a report's directory, holding the key and the files of its last writing
(``.diffbench-report-PART.json`` for one of several reports sharing a directory)."""

_PACKAGE_DIRECTORIES = ("methods", "signals", "bench")


@functools.cache
def _source_digest() -> str:
    """SHA-256 over every file of diffbench's packages (relative path and bytes, sorted by
    path; compiled caches left out)."""
    root = SOURCE_ROOT
    digest = hashlib.sha256()
    for directory in _PACKAGE_DIRECTORIES:
        for path in sorted((root / directory).rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                digest.update(str(path.relative_to(root)).encode())
                digest.update(b"\0")
                digest.update(path.read_bytes())
                digest.update(b"\0")
    return digest.hexdigest()


def code_fingerprint() -> str:
    """What the code is: diffbench's files, the interpreter, BLAS, package and plugin
    versions (:func:`diffbench.bench.core.provenance.provenance`)."""
    return f"{_source_digest()};{provenance()['versions']}"


def inputs_key(options: dict, store_version: str = "") -> str:
    """The key of a report written with ``options`` (JSON-able) from the store's content
    ``store_version`` (:meth:`diffbench.bench.core.store.Store.content_version`) by this
    code."""
    content = {"code": code_fingerprint(), "options": options, "store": store_version}
    return hashlib.sha256(json.dumps(content, sort_keys=True, default=str).encode()).hexdigest()


def _key_file(directory: Path, part: str) -> Path:
    name = KEY_FILE if not part else KEY_FILE.replace(".json", f"-{part}.json")
    return Path(directory) / name


def written_before(directory: Path, key: str, part: str = "") -> list[Path] | None:
    """The files of ``directory``'s last report (or of its ``part``, when several reports
    share the directory) if it was written from ``key`` and they all exist; otherwise None."""
    directory = Path(directory)
    try:
        last = json.loads(_key_file(directory, part).read_text())
        files = [directory / path for path in last["files"]]
        same = last["key"] == key
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return files if same and all(path.is_file() for path in files) else None


def remember(directory: Path, key: str, written: list[Path], part: str = "") -> None:
    """Record that ``written`` (files in or under ``directory``) came from ``key`` (written to
    a temporary file first, then renamed: a killed run leaves the old record or the new)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    target = _key_file(directory, part)
    temporary = target.with_name(target.name + ".tmp")
    files = [os.path.relpath(path, directory) for path in written]
    temporary.write_text(json.dumps({"key": key, "files": files}, indent=1))
    os.replace(temporary, target)


def report_once(
    directory: Path, key: str, write: Callable[[], list[Path]], part: str = ""
) -> list[Path]:
    """The files ``write()`` writes into ``directory``, written only when the last report there
    (its ``part``, for one of several reports sharing the directory) did not come from the
    same ``key`` (see the module docstring)."""
    before = written_before(directory, key, part)
    if before is not None:
        return before
    _key_file(directory, part).unlink(missing_ok=True)
    written = list(write())
    remember(directory, key, written, part)
    return written
