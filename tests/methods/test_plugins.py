"""Methods from outside diffbench: an installed entry point, a module named by --plugin or
$DIFFBENCH_PLUGINS. Each plugin runs in a fresh process (the registry is per process)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "tests" / "plugins" / "example_plugin"
NAME = "example.box_difference"


def _diffbench(*argv, env=None, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "diffbench.bench", *argv],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
        cwd=cwd,
        timeout=300,
    )


def _install_by_hand(site: Path) -> None:
    """What `pip install tests/plugins/example_plugin` leaves in site-packages: the module and
    a .dist-info holding the entry point (written here so the test needs no build backend)."""
    shutil.copytree(EXAMPLE / "diffbench_example_plugin", site / "diffbench_example_plugin")
    info = site / "diffbench_example_plugin-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: diffbench-example-plugin\nVersion: 0.1.0\n"
    )
    (info / "top_level.txt").write_text("diffbench_example_plugin\n")
    (info / "entry_points.txt").write_text(
        "[diffbench.methods]\nexample = diffbench_example_plugin\n"
    )


def test_an_installed_entry_point_is_listed_run_and_stored_with_its_version(tmp_path):
    site = tmp_path / "site"
    _install_by_hand(site)
    env = {"PYTHONPATH": str(site)}
    listed = _diffbench("list", env=env)
    assert listed.returncode == 0, listed.stderr
    assert (
        f"{NAME}  (linear; runs diffbench-example-plugin 0.1.0; Hamming (1989); plugin "
        "diffbench_example_plugin "
    ) in listed.stdout
    assert "(diffbench-example-plugin 0.1.0)" in listed.stdout
    out = tmp_path / "out"
    args = [
        "run",
        "paper-signal",
        "--seeds",
        "2",
        "--methods",
        f"{NAME},butterworth",
        "--no-progress",
        "--out",
        str(out),
    ]
    ran = _diffbench(*args, env=env)
    assert ran.returncode == 0, ran.stderr
    table = (out / "paper-signal" / "rmse.md").read_text()
    assert f"| {NAME} " in table and "preset (example)" in table and "window_s=0.04" in table
    from diffbench.bench.core.store import Store

    (run,) = Store(out / "store").runs.values()
    assert "plugin=diffbench_example_plugin (diffbench-example-plugin 0.1.0)" in run["versions"]
    # without the plugin the stored cells are still read, and the method is unknown to a run
    again = _diffbench(*args)
    assert again.returncode == 2
    assert "unknown method 'example.box_difference'" in again.stderr


def test_a_module_named_by_option_or_environment_joins_one_run(tmp_path):
    env = {"PYTHONPATH": str(EXAMPLE)}
    by_option = _diffbench("list", "--plugin", "diffbench_example_plugin", env=env)
    assert by_option.returncode == 0, by_option.stderr
    assert NAME in by_option.stdout
    assert NAME not in _diffbench("list", env=env).stdout  # only for the run that names it
    by_env = _diffbench(
        "tune",
        NAME,
        "paper-signal",
        "--orders",
        "1",
        "--seeds",
        "2",
        "--no-progress",
        "--out",
        str(tmp_path),
        env={**env, "DIFFBENCH_PLUGINS": "diffbench_example_plugin"},
    )
    assert by_env.returncode == 0, by_env.stderr
    tuned = (tmp_path / "paper-signal" / "tuning.md").read_text()
    assert NAME in tuned


@pytest.mark.parametrize(
    "argv, env, message",
    [
        (["list", "--plugin", "no_such_module"], {}, "--plugin: plugin module 'no_such_module'"),
        (["list", "--plugin", "not a module"], {}, "is not a dotted Python module name"),
        (["list"], {"DIFFBENCH_PLUGINS": "no_such_module"}, "$DIFFBENCH_PLUGINS: plugin module"),
    ],
)
def test_a_missing_plugin_module_is_a_usage_error(argv, env, message):
    result = _diffbench(*argv, env=env)
    assert result.returncode == 2
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_a_broken_installed_plugin_is_skipped_with_a_warning(tmp_path):
    site = tmp_path / "site"
    _install_by_hand(site)
    (site / "diffbench_example_plugin" / "__init__.py").write_text("raise RuntimeError('oops')\n")
    result = _diffbench("list", env={"PYTHONPATH": str(site)})
    assert result.returncode == 0
    assert "plugin 'example'" in result.stderr and "RuntimeError: oops" in result.stderr
    assert "savitzky_golay" in result.stdout


def test_a_plugin_that_fails_to_import_is_one_line_naming_it(tmp_path):
    (tmp_path / "buggy_plugin.py").write_text("import no_such_dependency_of_the_plugin\n")
    result = _diffbench("list", "--plugin", "buggy_plugin", env={"PYTHONPATH": str(tmp_path)})
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert "plugin module 'buggy_plugin' failed to import: ModuleNotFoundError" in result.stderr
    assert "no_such_dependency_of_the_plugin" in result.stderr


def test_the_generated_contract_tests_cover_a_plugin_method():
    """The registry's contract suite (exactness on the claimed polynomials and not one degree
    above, linearity, channels, bad input...) run on the plugin's method like a built-in."""
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "--benchmark-disable",
            str(ROOT / "tests" / "methods" / "test_contract.py"),
            "-k",
            "example",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        env={
            **os.environ,
            "PYTHONPATH": str(EXAMPLE),
            "DIFFBENCH_PLUGINS": "diffbench_example_plugin",
        },
    )
    assert result.returncode == 0, result.stdout[-3000:]
    summary = result.stdout.strip().splitlines()[-1]
    passed = int(summary.split(" passed")[0].split()[-1])
    assert passed >= 10, summary
