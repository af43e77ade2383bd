"""The peers' adapters (methods/peers/) give exactly what calling the peer library directly
gives, state how they obtain ẍ and which package runs, and their absence is explained."""

import os
import subprocess
import sys

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods.peers import PEERS_EXTRA

pynumdiff = pytest.importorskip("pynumdiff")
derivative = pytest.importorskip("derivative")

DT = 0.002
T = np.arange(400) * DT
X = np.sin(2 * np.pi * 3 * T) + 0.3 * T**2 + 0.01 * np.random.default_rng(5).standard_normal(T.size)


def _pynumdiff_direct(function, *args, **kwargs):
    """x̂, ẋ from one call, ẍ from the same call on that ẋ: PyNumDiff as a user calls it."""
    smoothed, first = function(X, DT, *args, **kwargs)
    return smoothed, first, function(first, DT, *args, **kwargs)[1]


def _derivative_direct(make):
    smoothed, first = make().x(X, T, axis=0), make().d(X, T, axis=0)
    return smoothed, first, make().d(first, T, axis=0)


DIRECT = {
    ("pynumdiff.spectraldiff", (("cutoff_freq", 0.05), ("extension", "none"))): lambda: (
        _pynumdiff_direct(pynumdiff.spectraldiff, 0.05, extension=None)
    ),
    ("pynumdiff.spectraldiff", (("cutoff_freq", 0.08), ("extension", "odd"))): lambda: (
        _pynumdiff_direct(pynumdiff.spectraldiff, 0.08, extension="odd")
    ),
    (
        "pynumdiff.spectraldiff",
        (("cutoff_freq", 0.06), ("extension", "even"), ("pad_to_flat", 1)),
    ): lambda: _pynumdiff_direct(pynumdiff.spectraldiff, 0.06, extension="even", pad_to_flat=True),
    (
        "pynumdiff.butterdiff",
        (("filter_order", 3), ("cutoff_freq", 0.1), ("num_iterations", 2)),
    ): lambda: _pynumdiff_direct(pynumdiff.butterdiff, 3, 0.1, 2),
    ("pynumdiff.savgoldiff", (("degree", 2), ("window_size", 21), ("smoothing_win", 15))): lambda: (
        _pynumdiff_direct(pynumdiff.savgoldiff, 2, 21, 15)
    ),
    ("pynumdiff.polydiff", (("degree", 3), ("window_size", 25), ("kernel", "gaussian"))): lambda: (
        _pynumdiff_direct(pynumdiff.polydiff, 3, 25, kernel="gaussian")
    ),
    ("pynumdiff.splinediff", (("degree", 4), ("s", 2.0))): lambda: _pynumdiff_direct(
        pynumdiff.splinediff, 4, 2.0
    ),
    ("pynumdiff.rtsdiff", (("order", 2), ("log_qr_ratio", 12.0), ("forwardbackward", 1))): lambda: (
        _pynumdiff_direct(pynumdiff.rtsdiff, 2, 12.0, forwardbackward=True)
    ),
    ("pynumdiff.tvrdiff", (("order", 2), ("gamma", 0.05))): lambda: _pynumdiff_direct(
        pynumdiff.tvrdiff, 2, 0.05
    ),
    (
        "pynumdiff.kerneldiff",
        (("kernel", "gaussian"), ("window_size", 11), ("num_iterations", 2)),
    ): lambda: _pynumdiff_direct(pynumdiff.kerneldiff, "gaussian", 11, 2),
    ("pynumdiff.rbfdiff", (("sigma", 0.01), ("lmbd", 0.05))): lambda: _pynumdiff_direct(
        pynumdiff.rbfdiff, 0.01, 0.05
    ),
    ("derivative.spectral", (("cutoff_hz", 12.0),)): lambda: _derivative_direct(
        lambda: derivative.Spectral(filter=lambda f: (np.abs(f) < 12.0).astype(float))
    ),
    ("derivative.spline", (("s", 0.05), ("order", 4))): lambda: _derivative_direct(
        lambda: derivative.Spline(0.05, order=4)
    ),
    ("derivative.kernel", (("sigma", 0.03), ("lmbd", 0.01))): lambda: _derivative_direct(
        lambda: derivative.Kernel(sigma=0.03, lmbd=0.01)
    ),
    ("derivative.kalman", (("alpha", 1e-4),)): lambda: _derivative_direct(
        lambda: derivative.Kalman(alpha=1e-4)
    ),
    ("derivative.savitzky_golay", (("order", 2), ("window_s", 0.04))): lambda: _derivative_direct(
        lambda: derivative.SavitzkyGolay(order=2, left=0.02, right=0.02)
    ),
}


@pytest.mark.parametrize(("name", "params"), list(DIRECT), ids=[n for n, _ in DIRECT])
def test_the_adapter_equals_calling_the_peer_directly(name, params):
    expected = DIRECT[(name, params)]()
    estimate = methods.get(name, **dict(params))(X, DT)
    for order in (0, 1, 2):
        assert estimate.valid[order].all()
        np.testing.assert_allclose(
            estimate[order], expected[order], rtol=1e-12, atol=1e-9, err_msg=f"{name} order {order}"
        )


def test_every_required_peer_method_is_registered_and_covered_here():
    required = {
        f"pynumdiff.{n}"
        for n in (
            "spectraldiff",
            "butterdiff",
            "savgoldiff",
            "polydiff",
            "splinediff",
            "rtsdiff",
            "tvrdiff",
            "kerneldiff",
            "rbfdiff",
        )
    }
    required |= {
        f"derivative.{n}" for n in ("spectral", "spline", "kernel", "kalman", "savitzky_golay")
    }
    registered = {n for n in methods.available() if n.split(".")[0] in ("pynumdiff", "derivative")}
    assert required <= registered
    assert registered == {name for name, _ in DIRECT}


@pytest.mark.parametrize("name", sorted({n for n, _ in DIRECT}))
def test_a_peer_row_names_its_package_and_how_it_gets_xddot(name):
    package = name.split(".")[0]
    from importlib import metadata

    assert methods.package_of(name) == f"{package} {metadata.version(package)}"
    assert "differentiated again" in methods.method_class(name).second_derivative


def test_builtins_run_diffbench_and_compute_xddot_themselves():
    from importlib import metadata

    assert methods.package_of("spectral") == f"diffbench {metadata.version('diffbench')}"
    assert methods.method_class("spectral").second_derivative == "native"


def test_a_dense_peer_refuses_a_record_beyond_its_cost_cap():
    method = methods.get("derivative.kernel")
    with pytest.raises(ValueError, match=r"at most 2000 .*O\(N³\)"):
        method(np.zeros(2001), DT)


def test_a_peer_channel_matrix_is_differentiated_per_channel():
    two = np.column_stack([X, 2 * X])
    estimate = methods.get("pynumdiff.spectraldiff", cutoff_freq=0.05)(two, DT)
    one = methods.get("pynumdiff.spectraldiff", cutoff_freq=0.05)(X, DT)
    np.testing.assert_allclose(estimate[2][:, 1], 2 * one[2], rtol=1e-10, atol=1e-8)


HIDE_PEERS = """
import importlib.util, sys
real = importlib.util.find_spec
hide = lambda name, *a: None if name.split('.')[0] in {hidden} else real(name, *a)
importlib.util.find_spec = hide
from diffbench.bench.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("hidden", [("pynumdiff",), ("pynumdiff", "derivative")])
def test_without_the_peers_everything_else_works_and_the_cli_says_how_to_get_them(hidden, tmp_path):
    script = HIDE_PEERS.format(hidden=set(hidden))

    def cli(*argv):
        return subprocess.run(
            [sys.executable, "-c", script, *argv],
            capture_output=True,
            text=True,
            env=dict(os.environ),
            timeout=300,
        )

    listed = cli("list")
    assert listed.returncode == 0, listed.stderr
    assert "  spectral  (linear; runs diffbench" in listed.stdout
    assert "pynumdiff." not in listed.stdout.replace("pynumdiff.*", "")
    assert f"pynumdiff.*  not available: PyNumDiff is not installed ({PEERS_EXTRA})" in (
        listed.stdout
    )
    refused = cli(
        "run",
        "paper-signal",
        "--methods",
        "pynumdiff.spectraldiff",
        "--seeds",
        "1",
        "--no-progress",
        "--out",
        str(tmp_path),
    )
    assert refused.returncode == 2
    assert refused.stderr.strip().splitlines() == [
        "diffbench: error: --methods: unknown method 'pynumdiff.spectraldiff'; pynumdiff's "
        "methods are "
        f"not installed: PyNumDiff is not installed ({PEERS_EXTRA})"
    ]
