"""Provenance of a run: package versions and the git revision of the code that ran."""

from __future__ import annotations

import functools
import platform
import subprocess
from importlib import metadata
from pathlib import Path

PACKAGES = ("diffbench", "numpy", "scipy", "pandas", "pysindy", "filterpy")


@functools.cache
def provenance() -> dict[str, str]:
    """``{"versions": "python=3.11.7;numpy=...", "git_rev": "<sha>[+dirty]"}``."""
    versions = [f"python={platform.python_version()}"]
    for package in PACKAGES:
        try:
            versions.append(f"{package}={metadata.version(package)}")
        except metadata.PackageNotFoundError:
            versions.append(f"{package}=absent")
    return {"versions": ";".join(versions), "git_rev": git_revision()}


def git_revision(directory: Path | None = None) -> str:
    """The checked-out commit of the diffbench sources, ``+dirty`` if tracked files outside
    ``results/`` changed; ``unknown`` outside a git checkout."""
    where = directory or Path(__file__).resolve().parent.parent
    try:
        sha = subprocess.run(
            ["git", "-C", str(where), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
        changed = subprocess.run(
            [
                "git",
                "-C",
                str(where),
                "status",
                "--porcelain",
                "--untracked-files=no",
                "--",
                ".",
                ":(exclude)results",
            ],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return sha + ("+dirty" if changed else "")
