"""Other packages' warnings go to a log in the output folder, not to the terminal (issue 46,
item 5): PyNumDiff's even-width kernel and scipy's filter design used to fill `make bench`'s
output. The run ends with one line saying how many there were and where; diffbench's own
warnings stay on the terminal, one line each."""

import os
import re
import subprocess
from pathlib import Path

import pytest

from tests.bench.killing import CLI, ROOT

NOISY_METHODS = """
import warnings

from diffbench.methods import register
from diffbench.methods.finite_difference import FiniteDifference


@register("noisy.finite_difference")
class NoisyFiniteDifference(FiniteDifference):
    \"\"\"Finite differences that warn as a third-party library would, on every call.\"\"\"

    def _estimate(self, x, dt, orders):
        warnings.warn("a library's remark nobody asked for", UserWarning, stacklevel=1)
        return super()._estimate(x, dt, orders)
"""

LOG = "diffbench-warnings.log"


def _run(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    (tmp_path / "noisy_methods.py").write_text(NOISY_METHODS)
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{tmp_path}"}
    command = [*CLI, *args, "--plugin", "noisy_methods"]
    return subprocess.run(command, env=env, capture_output=True, text=True)


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_third_party_warning_goes_to_the_log_and_the_run_says_where(tmp_path, jobs):
    out = tmp_path / "out"
    methods = "noisy.finite_difference,finite_difference"
    command = ["run", "paper-signal", "--methods", methods, "--seeds", "2", "--jobs", jobs]
    command += ["--out", str(out), "--no-progress"]
    result = _run(tmp_path, *command)
    assert result.returncode == 0, result.stderr
    assert "remark nobody asked for" not in result.stderr
    lines = (out / LOG).read_text().splitlines()
    # once per process and place (Python's default): the serial run's one process, or each
    # worker that ran a noisy cell
    assert 1 <= len(lines) <= int(jobs)
    for line in lines:
        assert re.fullmatch(
            r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d pid \d+ UserWarning: a library's remark nobody "
            r"asked for \(.*noisy_methods\.py:\d+\)",
            line,
        ), line
    plural = "s" if len(lines) > 1 else ""
    assert result.stderr.strip().splitlines()[-1] == (
        f"diffbench: {len(lines)} warning{plural} from other packages in {out / LOG}"
    )
    # a rerun computes nothing, warns of nothing and says nothing about the log
    again = _run(tmp_path, *command)
    assert again.returncode == 0 and "from other packages" not in again.stderr
    assert len((out / LOG).read_text().splitlines()) == len(lines)


def test_without_third_party_warnings_there_is_no_log_and_diffbench_s_own_still_show(tmp_path):
    out = tmp_path / "out"
    record = tmp_path / "record.csv"
    # a record with a gap of 5 steps: diffbench's own warning about it, on the terminal
    times = [0.001 * i for i in range(300)] + [0.001 * (i + 4) for i in range(300, 600)]
    record.write_text("t,x\n" + "".join(f"{t!r},{t * t!r}\n" for t in times))
    result = _run(
        tmp_path,
        "recommend",
        str(record),
        "--time",
        "t",
        "--methods",
        "finite_difference",
        "--out",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    assert "diffbench: warning:" in result.stderr
    assert not (out / LOG).exists()
    assert "from other packages" not in result.stderr
