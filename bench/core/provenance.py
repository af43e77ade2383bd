"""Provenance of a run: package versions and the git revision of the code that ran."""

from __future__ import annotations

import functools
import platform
import subprocess
from importlib import metadata
from pathlib import Path

from diffbench import methods

PACKAGES = ("diffbench", "numpy", "scipy", "pandas", "pysindy", "filterpy")


SOURCE_ROOT = Path(__file__).resolve().parents[2]
"""The folder holding diffbench's sources (``methods/``, ``signals/``, ``bench/``): the git
checkout in development, the installed ``diffbench`` folder otherwise."""


def provenance() -> dict[str, str]:
    """``{"versions": "python=3.11.7;blas=openblas 0.3.31 SkylakeX;plugin=mod (dist 1.0);
    numpy=...", "git_rev": "<sha>[+dirty]"}``. The BLAS kernel is chosen at run time from the
    CPU and changes the last bits of results (see
    :func:`diffbench.bench.core.tuning.comparable_loss`); plugins are the method modules loaded
    from outside diffbench (see ``diffbench.methods._plugins``)."""

    machine, packages, git_rev = _fixed_provenance()
    plugins = tuple(f"plugin={plugin.label}" for plugin in methods.loaded_plugins())
    return {"versions": ";".join(machine + plugins + packages), "git_rev": git_rev}


@functools.cache
def _fixed_provenance() -> tuple[tuple[str, ...], tuple[str, ...], str]:
    """What cannot change while the process runs: interpreter and BLAS, package versions, and
    the git revision."""
    machine = (f"python={platform.python_version()}", f"blas={blas_kernel()}")
    packages = []
    for package in PACKAGES:
        try:
            packages.append(f"{package}={metadata.version(package)}")
        except metadata.PackageNotFoundError:
            packages.append(f"{package}=absent")
    return machine, tuple(packages), git_revision()


def blas_kernel() -> str:
    """numpy's BLAS library, version and CPU kernel, as threadpoolctl reports them."""
    import numpy  # noqa: F401  (loads the BLAS library threadpoolctl inspects)

    try:
        import threadpoolctl
    except ImportError:
        return "unknown"
    found = [
        f"{info.get('internal_api')} {info.get('version')} {info.get('architecture', '')}".strip()
        for info in threadpoolctl.threadpool_info()
        if info.get("user_api") == "blas"
    ]
    return ",".join(sorted(found)) or "unknown"


def git_revision(directory: Path | None = None) -> str:
    """The checked-out commit of the diffbench sources, ``+dirty`` if tracked files outside
    ``results/`` changed; ``unknown`` outside a git checkout."""
    where = directory or SOURCE_ROOT
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
