"""`make bench` on another CPU leaves `git status` clean: the paper suite (`make bench-suite`,
the Makefile's own commands) run from an empty store under OpenBLAS's Haswell kernel (what a
CPU without AVX-512 gets) and its Sandybridge kernel writes every tracked file under its
folders byte for byte as committed, and nothing that git would see as new.

The committed files are what make bench wrote on the machine that committed them (its kernel
on an AVX-512 CPU is SkylakeX): Markdown tables at their printed precision and PNG figures.
The full-precision CSVs beside them move in their last digits with the kernel (up to 1e-5
relative for fitted or optimised quantities) and are not tracked (.gitignore)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SUITE_FOLDERS = ("paper-signal", "jacobi-influence", "paper-figures", "robot-sim")
"""The folders of results/ that `make bench-suite` writes."""
KERNELS = ("Haswell", "Sandybridge")


def _git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)


def _tracked() -> list[str]:
    listed = _git("ls-files", "--", *(f"results/{folder}" for folder in SUITE_FOLDERS))
    return sorted(listed.stdout.split())


def _needs_checkout_make_and_the_console_script() -> Path:
    if shutil.which("git") is None or shutil.which("make") is None:
        pytest.skip("needs git and make on PATH (the README's quick start needs make too)")
    if _git("rev-parse", "--is-inside-work-tree").stdout.strip() != "true":
        pytest.skip(f"{ROOT} is not a git checkout: nothing committed to compare with")
    if not (ROOT / "Makefile").exists():
        pytest.skip(f"no Makefile at {ROOT}")
    script = Path(sys.executable).parent / "diffbench"
    if not script.exists():
        pytest.skip(f"no diffbench console script beside {sys.executable}")
    return script.parent


@pytest.mark.slow
@pytest.mark.kernels
@pytest.mark.parametrize("kernel", KERNELS)
def test_the_paper_suite_under_another_blas_kernel_writes_the_committed_files(kernel, tmp_path):
    bin_dir = _needs_checkout_make_and_the_console_script()
    tracked = _tracked()
    for folder in SUITE_FOLDERS:  # each folder's tables (and figures) are committed
        assert any(p.startswith(f"results/{folder}/") and p.endswith(".md") for p in tracked)
    assert sum(path.endswith(".png") for path in tracked) >= 5, tracked
    out = tmp_path / "results"
    env = {**os.environ, "OPENBLAS_CORETYPE": kernel}
    run = subprocess.run(
        ["make", "-s", "-C", str(ROOT), "bench-suite", f"BIN={bin_dir}", f"BENCH_OUT={out}"],
        capture_output=True,
        text=True,
        env=env,
        timeout=1800,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    changed = [
        path
        for path in tracked
        if not (out / path.removeprefix("results/")).exists()
        or (out / path.removeprefix("results/")).read_bytes() != (ROOT / path).read_bytes()
    ]
    assert not changed, (
        f"under OPENBLAS_CORETYPE={kernel} these differ from the committed: {changed}"
    )
    # every other file the suite wrote is one git ignores (the CSVs, the store)
    written = sorted(
        f"results/{path.relative_to(out)}"
        for folder in SUITE_FOLDERS
        for path in (out / folder).rglob("*")
        if path.is_file()
    )
    untracked = [path for path in written if path not in tracked]
    ignored = _git("check-ignore", "--no-index", "--", *untracked).stdout.split()
    assert sorted(set(untracked) - set(ignored)) == [], "new files git would show"
    assert any(path.endswith(".csv") for path in ignored)  # the CSVs are written, untracked
