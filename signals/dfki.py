r"""Real 2R robot recordings: the DFKI double pendulum, its model and its base parameters.

Six 10 s recordings of a real two-link robot (DFKI RIC Underactuated Robotics Lab, design C.0,
2022-09-14; BSD 3-Clause, see ``data/dfki-double-pendulum/LICENSE`` and ``README.md`` beside
the data) and the lab's own identified model. The runs are open-loop torque excitations: the
commanded torque (``tau_con``) is a prescribed signal on one or both joints (runs 3 and 4 drive
joint 2 only, run 5 joint 1 only), not the output of a tracking controller. The real parameters
are unknown, so on these runs a differentiator is judged by the torque a model predicts from its
:math:`\dot q, \ddot q`. The recorded velocity (``vel_meas``) is no reference: it is exactly
the backward difference of the recorded positions over the recorded time steps (checked on
every row of the six runs), so scoring against it would reward finite differences.

The robot
---------
Two revolute joints with horizontal axes: the links swing in a vertical plane and gravity acts.
:math:`q_1` is measured from the downward vertical, :math:`q_2` relative to link 1. Both joints
are quasi-direct-drive motors (gear ratio :math:`g_r = 6`, rotor inertia :math:`I_r`). The lab's
model (their README and their ``plant.py``), with :math:`c_2 = \cos q_2`, :math:`s_1 = \sin q_1`,
:math:`s_2 = \sin q_2`, :math:`s_{12} = \sin(q_1 + q_2)`:

.. math::

    \tau = M(q)\,\ddot q + C(q, \dot q)\,\dot q - G(q) + F(\dot q),

    M_{11} = I_1 + I_2 + m_2 l_1^2 + 2 m_2 l_1 r_2 c_2 + (g_r^2 + 1) I_r, \quad
    M_{12} = M_{21} = I_2 + m_2 l_1 r_2 c_2 - g_r I_r, \quad
    M_{22} = I_2 + g_r^2 I_r,

    C = m_2 l_1 r_2 s_2 \begin{pmatrix} -2\dot q_2 & -\dot q_2 \\ \dot q_1 & 0 \end{pmatrix},

    G_1 = -g (m_1 r_1 + m_2 l_1) s_1 - g m_2 r_2 s_{12}, \quad G_2 = -g m_2 r_2 s_{12},

    F_j = b_j \dot q_j + c_{f,j} \arctan(100\,\dot q_j).

Derivation of the base parameters
---------------------------------
The kinetic energy is :math:`T = \tfrac12 \dot q^\top M(q) \dot q`; only :math:`M_{11}` and
:math:`M_{12}` depend on :math:`q` (through :math:`q_2`), with
:math:`\partial M_{11}/\partial q_2 = -2 m_2 l_1 r_2 s_2` and
:math:`\partial M_{12}/\partial q_2 = -m_2 l_1 r_2 s_2`. The Christoffel symbols
:math:`c_{ijk} = \tfrac12(\partial_k M_{ij} + \partial_j M_{ik} - \partial_i M_{jk})` give
:math:`c_{112} = c_{121} = c_{122} = -m_2 l_1 r_2 s_2`, :math:`c_{211} = m_2 l_1 r_2 s_2` and
zero otherwise, i.e. :math:`(C\dot q)_1 = -m_2 l_1 r_2 s_2 (2\dot q_1 \dot q_2 + \dot q_2^2)` and
:math:`(C\dot q)_2 = m_2 l_1 r_2 s_2 \dot q_1^2`: exactly the lab's :math:`C\dot q` above. The
potential energy :math:`U = -g (m_1 r_1 + m_2 l_1) \cos q_1 - g m_2 r_2 \cos(q_1 + q_2)` (heights
measured upwards, :math:`q = 0` hanging down) has :math:`\partial U / \partial q = -G`, so the
lab's :math:`-G` is the gravity term of Lagrange's equations
:math:`\tfrac{d}{dt}\partial_{\dot q} T - \partial_q T + \partial_q U = \tau - F`.

Expanding, the torques are linear in ten combinations of the physical parameters,
:math:`\tau = D(q, \dot q, \ddot q)\,X`:

.. math::

    A_1 &= I_1 + I_2 + m_2 l_1^2 + (g_r^2 + 1) I_r \quad (\text{constant part of } M_{11}), \\
    A_2 &= I_2 + g_r^2 I_r \quad (M_{22}), \qquad
    A_3 = I_2 - g_r I_r \quad (\text{constant part of } M_{12}), \\
    A_4 &= m_2 l_1 r_2, \qquad A_5 = g (m_1 r_1 + m_2 l_1), \qquad A_6 = g m_2 r_2,

.. math::

    \tau_1 &= A_1 \ddot q_1 + A_3 \ddot q_2
        + A_4 \big(c_2 (2\ddot q_1 + \ddot q_2) - s_2 (2\dot q_1 \dot q_2 + \dot q_2^2)\big)
        + A_5 s_1 + A_6 s_{12} + b_1 \dot q_1 + c_{f1} \arctan(\alpha \dot q_1), \\
    \tau_2 &= A_3 \ddot q_1 + A_2 \ddot q_2 + A_4 (c_2 \ddot q_1 + s_2 \dot q_1^2)
        + A_6 s_{12} + b_2 \dot q_2 + c_{f2} \arctan(\alpha \dot q_2),

with :math:`X = [A_1, \dots, A_6, b_1, c_{f1}, b_2, c_{f2}]` (the order of
:data:`PENDULUM_PARAMETER_NAMES`) and the lab's Coulomb slope :math:`\alpha = 100` s/rad. The ten
columns of :math:`D` are linearly independent functions of the state (the regressor stacked over
generic states has rank 10, see the tests), so no smaller set of combinations describes the
torques: these are the base parameters. The physical parameters are not identifiable one by one:
:math:`m_1` and :math:`r_1` only appear in :math:`A_5`, :math:`I_1` only in :math:`A_1`.

Other designs
-------------
The lab built several designs of this robot (``design_A.0``, ``B.0``, ``C.0``, ``C.1``, ...:
other link lengths, masses, motors) and keeps each one's records and identified model apart
(``data/experiment_records/design_<name>/`` and
``data/system_identification/identified_parameters/design_<name>/model_<version>/
model_parameters.yml``). The equations above hold for all of them; only the parameters differ.
:func:`load_pendulum_model` reads a design's model file into a :class:`PendulumModel`, which
gives everything the identification takes from the robot (:math:`l_1` and :math:`g` of the
:math:`A_4`-:math:`A_6` tie, the lab model's torques and base parameters); the packaged runs
and model are design C.0 (:func:`packaged_model`), and :func:`design_of_path` reads the design
a path of the lab's layout names.

Resampling
----------
The recorded time stamps are not uniform (nominal 2 ms, with jitter and gaps up to about 8 ms),
while every differentiator of this benchmark assumes a uniform step. :func:`load_dfki_run`
therefore resamples explicitly onto :math:`t_k = t_0 + k\,\Delta t` by linear interpolation
(:func:`resample_uniform`); see there for the error it adds.

References
----------
.. [1] F. Wiebe, S. Kumar, L. J. Shala, S. Vyas, M. Javadi, F. Kirchner, "Open Source
   Dual-Purpose Acrobot and Pendubot Platform: Benchmarking Control Algorithms for
   Underactuated Robotics", IEEE Robotics & Automation Magazine 31(2), 2024.
.. [2] DFKI RIC Underactuated Lab, ``double_pendulum`` repository (commit 1e8544e),
   ``data/experiment_records/design_C.0/20220914/sys_id`` and
   ``data/system_identification/identified_parameters/design_C.0/model_3.0``.
.. [3] W. Khalil, E. Dombre, "Modeling, Identification and Control of Robots", Hermes Penton,
   2002, chapter 12 (base parameters).
"""

from __future__ import annotations

import functools
import gzip
import io
import math
import numbers
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path, PurePath
from typing import TYPE_CHECKING

import numpy as np

from diffbench.signals._checks import check_real, check_samples, check_times, read_only

if TYPE_CHECKING:  # Python >= 3.11; annotations only
    from importlib.resources.abc import Traversable

DFKI_RUNS = 6
"""Number of recordings: runs ``0 .. DFKI_RUNS - 1``."""

DEFAULT_DT_S = 0.002
"""The recorder's nominal step (500 Hz)."""

COULOMB_SLOPE = 100.0
"""The lab's smooth Coulomb law: :math:`c_f \\arctan(100\\,\\dot q)` (``100`` in s/rad)."""

PENDULUM_PARAMETER_NAMES = (
    "A1_M11",
    "A2_M22",
    "A3_M12",
    "A4_m2_l1_r2",
    "A5_g_m1r1_m2l1",
    "A6_g_m2_r2",
    "b1",
    "cf1",
    "b2",
    "cf2",
)
"""The 10 base parameters, in the order of the regressor's last axis.

``A1_M11`` = I1 + I2 + m2 l1² + (gr² + 1) Ir [kg·m²], ``A2_M22`` = I2 + gr² Ir [kg·m²],
``A3_M12`` = I2 − gr Ir [kg·m²], ``A4_m2_l1_r2`` = m2 l1 r2 [kg·m²],
``A5_g_m1r1_m2l1`` = g (m1 r1 + m2 l1) [N·m], ``A6_g_m2_r2`` = g m2 r2 [N·m], ``b1``, ``b2``
viscous [N·m·s/rad], ``cf1``, ``cf2`` Coulomb [N·m] (multiplying ``arctan(100 q̇)``).
"""

_PHYSICAL_NAMES = (
    "I1",
    "I2",
    "Ir",
    "gr",
    "m1",
    "m2",
    "l1",
    "r1",
    "r2",
    "g",
    "b1",
    "b2",
    "cf1",
    "cf2",
)

_DATA = ("data", "dfki-double-pendulum")

# CSV columns read by the loader, in the order they are stacked before resampling.
_COLUMNS = (
    "pos_meas1",
    "pos_meas2",
    "tau_meas1",
    "tau_meas2",
    "tau_con1",
    "tau_con2",
    "vel_meas1",
    "vel_meas2",
)


def _data_file(name: str) -> Traversable:
    """The packaged data file ``name`` (works from a source tree, a wheel or a zip)."""
    folder = files("diffbench.signals")
    for part in _DATA:
        folder = folder / part
    return folder / name


@dataclass(frozen=True, eq=False)
class DfkiRun:
    """One DFKI double-pendulum recording, resampled onto a uniform time grid.

    Parameters
    ----------
    run : int
        Recording number, ``0 .. DFKI_RUNS - 1`` (file ``trajectory_0{run}.csv``).
    t : numpy.ndarray, shape (n,)
        Uniform sample times :math:`t_k = t_0 + k\\,\\Delta t` in seconds (:math:`t_0 = 0`).
    dt_s : float
        The uniform step :math:`\\Delta t` in seconds.
    q : numpy.ndarray, shape (n, 2)
        Joint positions in rad (encoder, about 3.8e-4 rad resolution); ``q[:, 0]`` from the
        downward vertical, ``q[:, 1]`` relative to link 1.
    tau : numpy.ndarray, shape (n, 2)
        Measured joint torques in N·m (the driver's current-based estimate).
    tau_commanded : numpy.ndarray, shape (n, 2)
        Commanded joint torques in N·m.
    velocity_driver : numpy.ndarray, shape (n, 2)
        The recorded velocity in rad/s (column ``vel_meas``): the backward difference of the
        recorded positions (module docstring), not an independent measurement.
    max_gap_s : float
        Largest step between consecutive recorded time stamps, in seconds.
    original_samples : int
        Number of distinct recorded time stamps (rows of the CSV file, exact duplicate time
        stamps counted once).

    Notes
    -----
    The arrays are stored as read-only float64 copies; every array has ``n`` samples on axis 0.
    """

    run: int
    t: np.ndarray
    dt_s: float
    q: np.ndarray
    tau: np.ndarray
    tau_commanded: np.ndarray
    velocity_driver: np.ndarray
    max_gap_s: float
    original_samples: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "run", _check_run(self.run))
        object.__setattr__(self, "dt_s", check_real("dt_s", self.dt_s, gt=0.0))
        t = read_only(check_times(self.t))
        object.__setattr__(self, "t", t)
        for name in ("q", "tau", "tau_commanded", "velocity_driver"):
            array = check_samples(getattr(self, name), t.size, name)
            if array.shape != (t.size, 2):
                raise ValueError(f"`{name}` must have shape ({t.size}, 2), got {array.shape}")
            object.__setattr__(self, name, read_only(array))
        object.__setattr__(self, "max_gap_s", check_real("max_gap_s", self.max_gap_s, gt=0.0))
        samples = self.original_samples
        if isinstance(samples, (bool, np.bool_)) or not isinstance(samples, numbers.Integral):
            raise ValueError(f"`original_samples` must be an integer, got {samples!r}")
        if samples < 2:
            raise ValueError(f"`original_samples` must be >= 2, got {samples!r}")
        object.__setattr__(self, "original_samples", int(samples))


def _check_run(run: object) -> int:
    if (
        isinstance(run, (bool, np.bool_))
        or not isinstance(run, numbers.Integral)
        or not 0 <= run < DFKI_RUNS
    ):
        raise ValueError(f"`run` must be an integer in 0..{DFKI_RUNS - 1}, got {run!r}")
    return int(run)


def resample_uniform(t: np.ndarray, x: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Resample irregularly timed samples onto a uniform grid by linear interpolation.

    Rows whose time stamp exactly repeats the previous one are dropped (the first is kept);
    the remaining times must then be strictly increasing. The grid is

    .. math::

        t_k = t_0 + k\\,\\Delta t, \\qquad k = 0, \\dots, \\lfloor (t_{end} - t_0)/\\Delta t
        \\rfloor,

    covering :math:`[t_0, t_{end}]` without extrapolating, and every channel is interpolated
    linearly between the two recorded samples around each :math:`t_k` (``numpy.interp``); a
    grid point that coincides with a recorded time gets the recorded value exactly.

    Why and how large the error is: every differentiator here assumes a uniform step, so the
    resampling is explicit and done once. On a recorded interval of length :math:`h` the linear
    interpolant of a :math:`C^2` signal errs by at most

    .. math::

        |x(t) - \\hat x(t)| \\le \\frac{h^2}{8} \\max |\\ddot x|,

    e.g. :math:`h` = 8 ms and :math:`|\\ddot q|` = 50 rad/s² give 4e-4 rad, the size of the
    encoder's resolution; on the nominal 2 ms steps it is 16 times smaller. Away from the gaps
    the interpolation is a small sub-sample time shift; its kinks at the recorded times are
    high-frequency content a differentiator must smooth anyway.

    Parameters
    ----------
    t : array_like, shape (m,)
        Recorded times in seconds, finite, non-decreasing, at least two distinct values.
    x : array_like, shape (m, ...)
        Recorded samples, time on axis 0, any further axes are channels; finite.
    dt_s : float
        Uniform step in seconds, > 0 and at most :math:`t_{end} - t_0`.

    Returns
    -------
    t_uniform : numpy.ndarray, shape (n,)
        The grid :math:`t_k`.
    x_uniform : numpy.ndarray, shape (n, ...)
        The interpolated samples.

    Raises
    ------
    ValueError
        If ``t`` is not finite and strictly increasing once exact duplicates are dropped, if
        ``x`` does not have the samples of ``t`` on axis 0 or is not finite, or if ``dt_s`` is
        not a finite number in :math:`(0, t_{end} - t_0]`.

    Examples
    --------
    >>> t_u, x_u = resample_uniform([0.0, 0.3, 0.4, 1.0], [0.0, 3.0, 4.0, 10.0], dt_s=0.25)
    >>> t_u.tolist(), x_u.tolist()
    ([0.0, 0.25, 0.5, 0.75, 1.0], [0.0, 2.5, 5.0, 7.5, 10.0])
    """
    times = check_times(t)
    values = check_samples(x, times.size, "x")
    step = check_real("dt_s", dt_s, gt=0.0)
    keep = np.ones(times.size, dtype=bool)
    keep[1:] = np.diff(times) != 0.0
    times, values = times[keep], values[keep]
    steps = np.diff(times)
    if times.size < 2 or not np.all(steps > 0.0):
        bad = np.flatnonzero(steps <= 0.0)
        where = f" (first at index {int(bad[0]) + 1})" if bad.size else ""
        raise ValueError(
            "`t` must be strictly increasing after dropping exact duplicate time stamps, "
            f"with at least two distinct values{where}"
        )
    span = times[-1] - times[0]
    if step > span:
        raise ValueError(f"`dt_s` must be <= the recording's length {span!r} s, got {step!r}")
    count = math.floor(span / step) + 1
    grid = times[0] + np.arange(count) * step
    if grid[-1] > times[-1]:  # rounding in floor(span / step)
        grid = grid[:-1]
    flat = values.reshape(times.size, -1)
    out = np.empty((grid.size, flat.shape[1]))
    for channel in range(flat.shape[1]):
        out[:, channel] = np.interp(grid, times, flat[:, channel])
    return grid, out.reshape((grid.size, *values.shape[1:]))


def _read_csv(run: int) -> tuple[np.ndarray, np.ndarray]:
    """Recorded time and the :data:`_COLUMNS` (as an (m, 8) array) of run ``run``."""
    with _data_file(f"trajectory_0{run}.csv.gz").open("rb") as raw, gzip.open(raw, "rt") as fh:
        text = fh.read()
    return _parse_csv(text, f"run {run}", _COLUMNS)


def _parse_csv(text: str, label: str, wanted: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The ``time`` column and the ``wanted`` columns of a recording in the lab's CSV layout
    (a header row of names, then comma-separated numbers); one-line errors naming ``label``."""
    header, _, body = text.partition("\n")
    names = [name.strip() for name in header.split(",")]
    missing = [name for name in ("time", *wanted) if name not in names]
    if missing:
        raise ValueError(
            f"{label}: the CSV file lacks the columns {missing} (the lab's layout has a header "
            "row with time, pos_meas1, pos_meas2, tau_meas1, tau_meas2, tau_con1, tau_con2)"
        )
    try:
        table = np.loadtxt(io.StringIO(body), delimiter=",", dtype=np.float64, ndmin=2)
    except ValueError as error:
        reason = str(error).splitlines()[0] if str(error) else "unreadable"
        raise ValueError(f"{label}: not a table of numbers below the header ({reason})") from None
    if table.shape[1] != len(names):
        raise ValueError(f"{label}: {table.shape[1]} numbers per row for {len(names)} columns")
    if not np.isfinite(table).all():
        row = int(np.flatnonzero(~np.isfinite(table).all(axis=1))[0]) + 2
        raise ValueError(f"{label}: line {row} holds NaN or inf; drop or repair that row")
    columns = [names.index(name) for name in wanted]
    return table[:, names.index("time")], table[:, columns]


def load_dfki_run(run: int, dt_s: float = DEFAULT_DT_S) -> DfkiRun:
    """Load one DFKI double-pendulum recording, resampled onto a uniform grid.

    The recorded time stamps are not uniform (nominal 2 ms, jitter, gaps up to about 8 ms), so
    positions, measured and commanded torques and the driver's velocity are resampled onto
    :math:`t_k = t_0 + k\\,\\Delta t` covering the recording by linear interpolation
    (:func:`resample_uniform`, which states the error this adds: at most
    :math:`h^2 \\max|\\ddot q|/8` on a recorded step :math:`h`). ``max_gap_s`` tells how large
    :math:`h` gets.

    Parameters
    ----------
    run : int
        Recording number, ``0 .. DFKI_RUNS - 1``.
    dt_s : float, default 0.002
        Uniform step in seconds, finite and > 0 (the recorder's nominal step by default).

    Returns
    -------
    DfkiRun
        The resampled run (about 10 s: 5000 samples at the default step).

    Raises
    ------
    ValueError
        If ``run`` is not an integer in ``0 .. DFKI_RUNS - 1``, if ``dt_s`` is not a finite
        number > 0 (and at most the recording's length), or if the recorded time is not
        strictly increasing once exact duplicate time stamps are dropped.

    Examples
    --------
    >>> data = load_dfki_run(0)
    >>> data.q.shape, data.dt_s, round(float(data.t[-1]), 3)
    ((5000, 2), 0.002, 9.998)
    """
    run = _check_run(run)
    step = check_real("dt_s", dt_s, gt=0.0)
    time, columns = _read_csv(run)
    grid, values = resample_uniform(time, columns, step)
    distinct = np.unique(time)
    return DfkiRun(
        run=run,
        t=grid,
        dt_s=step,
        q=values[:, 0:2],
        tau=values[:, 2:4],
        tau_commanded=values[:, 4:6],
        velocity_driver=values[:, 6:8],
        max_gap_s=float(np.max(np.diff(distinct))),
        original_samples=int(distinct.size),
    )


RECORD_COLUMNS = ("pos_meas1", "pos_meas2", "tau_meas1", "tau_meas2", "tau_con1", "tau_con2")
"""The columns :func:`read_dfki_record` needs besides ``time`` (others are ignored)."""

MIN_RECORD_SAMPLES = 100
"""Fewest distinct time stamps a recording must have to be identified on."""


@dataclass(frozen=True, eq=False)
class DfkiRecord:
    """One DFKI double-pendulum recording at its logged time stamps (not resampled).

    Parameters
    ----------
    name : str
        ``"run <k>"`` for a packaged run, else the file's path.
    t : numpy.ndarray, shape (n,)
        Logged times in seconds, strictly increasing (rows repeating the previous time stamp
        exactly are dropped, the first kept).
    q, tau, tau_commanded : numpy.ndarray, shape (n, 2)
        Joint positions (rad), measured and commanded torques (N·m), as in :class:`DfkiRun`.
    """

    name: str
    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    tau_commanded: np.ndarray

    @property
    def active_joints(self) -> np.ndarray:
        """Joints whose commanded torque is not identically zero (a passive joint's "measured"
        torque is only the driver's noise)."""
        return np.any(self.tau_commanded != 0, axis=0)


def read_dfki_record(source) -> DfkiRecord:
    """A recording in the lab's CSV layout at its logged time stamps.

    Parameters
    ----------
    source : int or str or os.PathLike
        A packaged run ``0 .. DFKI_RUNS - 1``, or the path of a CSV file (``.csv`` or
        ``.csv.gz``) of the lab's ``double_pendulum`` repository layout: a header row naming at
        least ``time`` and :data:`RECORD_COLUMNS` (any other columns, in any order, are
        ignored), e.g. any ``measured.csv`` / ``trajectory_*.csv`` of its experiment records.

    Returns
    -------
    DfkiRecord

    Raises
    ------
    ValueError
        One line naming the file: a missing file or column, text among the numbers, NaN or
        inf, time stamps that decrease or repeat with other values, fewer than
        ``MIN_RECORD_SAMPLES`` distinct time stamps.
    """

    if isinstance(source, numbers.Integral) and not isinstance(source, (bool, np.bool_)):
        run = _check_run(source)
        label = f"run {run}"
        with _data_file(f"trajectory_0{run}.csv.gz").open("rb") as raw:
            data = raw.read()
    else:
        try:
            path = Path(source)
        except TypeError:
            raise ValueError(
                f"`source` must be a run number 0..{DFKI_RUNS - 1} or the path of a CSV file, "
                f"got {source!r}"
            ) from None
        label = str(path)
        if not path.is_file():
            raise ValueError(f"{label}: no such file (give the path of a recording's CSV file)")
        data = path.read_bytes()
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{label}: not a text (CSV) file") from None
    time, columns = _parse_csv(text, label, RECORD_COLUMNS)
    keep = np.ones(time.size, dtype=bool)
    keep[1:] = np.diff(time) != 0.0
    time, columns = time[keep], columns[keep]
    steps = np.diff(time)
    if steps.size and not np.all(steps > 0):
        row = int(np.flatnonzero(~(steps > 0))[0]) + 1
        raise ValueError(
            f"{label}: the time column decreases at data row {row + 1} (of those left after "
            "dropping exact repeats); sort the rows by time"
        )
    if time.size < MIN_RECORD_SAMPLES:
        raise ValueError(
            f"{label}: {time.size} distinct time stamps, at least {MIN_RECORD_SAMPLES} needed"
        )
    return DfkiRecord(
        name=label,
        t=read_only(time),
        q=read_only(columns[:, 0:2].copy()),
        tau=read_only(columns[:, 2:4].copy()),
        tau_commanded=read_only(columns[:, 4:6].copy()),
    )


TIED_PARAMETER_NAMES = tuple(name for name in PENDULUM_PARAMETER_NAMES if name != "A4_m2_l1_r2")
"""The base parameters once :math:`A_4 = m_2 l_1 r_2` is tied to :math:`A_6 = g m_2 r_2` by the
known :math:`l_1` and :math:`g`: :math:`A_4 = A_6\\, l_1 / g` (:func:`tie_a4_to_a6`)."""


def tie_a4_to_a6(regressor: np.ndarray, link1_length_m: float, gravity_m_s2: float) -> np.ndarray:
    """The regressor of :data:`TIED_PARAMETER_NAMES`: where :math:`l_1` and :math:`g` are known,
    :math:`A_4 = m_2 l_1 r_2 = (l_1/g) A_6`, so

    .. math:: D_{A_4} A_4 + D_{A_6} A_6 = (D_{A_6} + \\tfrac{l_1}{g} D_{A_4})\\, A_6,

    and the column of :math:`A_4` is folded into that of :math:`A_6` (nine parameters left).

    Parameters
    ----------
    regressor : numpy.ndarray, shape (..., 10)
        Columns in the order of :data:`PENDULUM_PARAMETER_NAMES` (:func:`pendulum_regressor`).
    link1_length_m, gravity_m_s2 : float
        :math:`l_1` (m) and :math:`g` (m/s²), > 0 (the lab's: 0.2 and 9.81).

    Returns
    -------
    numpy.ndarray, shape (..., 9)
    """
    regressor = np.asarray(regressor, dtype=float)
    if regressor.shape[-1] != len(PENDULUM_PARAMETER_NAMES):
        raise ValueError(
            f"`regressor` must have {len(PENDULUM_PARAMETER_NAMES)} columns (last axis), got "
            f"{regressor.shape}"
        )
    ratio = check_real("link1_length_m", link1_length_m, gt=0.0) / check_real(
        "gravity_m_s2", gravity_m_s2, gt=0.0
    )
    a4, a6 = (
        PENDULUM_PARAMETER_NAMES.index("A4_m2_l1_r2"),
        PENDULUM_PARAMETER_NAMES.index("A6_g_m2_r2"),
    )
    tied = regressor.copy()
    tied[..., a6] = regressor[..., a6] + ratio * regressor[..., a4]
    return np.delete(tied, a4, axis=-1)


def _parse_model_text(text: str, label: str) -> dict[str, float]:
    """The ``key: number`` lines of a model file (``#`` starts a comment); one-line errors
    naming ``label``."""
    parameters: dict[str, float] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        content = line.split("#", 1)[0].strip()
        if not content:
            continue
        key, sep, value = content.partition(":")
        try:
            if not sep or not key.strip():
                raise ValueError
            parameters[key.strip()] = float(value)
        except ValueError:
            raise ValueError(f"{label} line {number} is not `key: number`: {line!r}") from None
    return parameters


def lab_parameters() -> dict[str, float]:
    """The lab's identified physical parameters (``model_parameters.yml``) as floats.

    Keys: ``m1, m2`` [kg]; ``l1, l2`` link lengths and ``r1, r2`` centre-of-mass distances [m];
    ``I1, I2`` inertias about the joint axes and ``Ir`` rotor inertia [kg·m²]; ``gr`` gear
    ratio; ``b1, b2`` viscous [N·m·s/rad] and ``cf1, cf2`` Coulomb [N·m] friction; ``g``
    [m/s²]; ``tl1, tl2`` torque limits [N·m]. A fresh dict on every call.

    Raises
    ------
    ValueError
        If a line of the file is not ``key: number`` (the packaged file always is).

    Examples
    --------
    >>> lab_parameters()["gr"], lab_parameters()["g"]
    (6.0, 9.81)
    """
    text = _data_file("model_parameters.yml").read_text(encoding="utf-8")
    return _parse_model_text(text, "model_parameters.yml")


PACKAGED_DESIGN = "C.0"
"""The lab's hardware design of the packaged runs and model (``design_C.0`` in its repository)."""

_DESIGN_FOLDER = re.compile(r"design_(.+)")


def design_of_path(path: str | os.PathLike) -> str | None:
    """The lab design a path names, or None: the last folder called ``design_<name>``.

    The lab's ``double_pendulum`` repository keeps every design's files apart:
    ``data/experiment_records/design_A.0/20220815/sys_id/trajectory_03.csv`` (a record) and
    ``data/system_identification/identified_parameters/design_A.0/model_2.0/model_parameters.yml``
    (its identified model) both name design ``A.0``.

    Examples
    --------
    >>> design_of_path("data/experiment_records/design_A.0/20220815/sys_id/trajectory_03.csv")
    'A.0'
    >>> design_of_path("measured.csv") is None
    True
    """
    for part in reversed(PurePath(path).parts[:-1]):
        found = _DESIGN_FOLDER.fullmatch(part)
        if found:
            return found.group(1)
    return None


MODEL_KEYS = _PHYSICAL_NAMES
"""The keys a robot model must give (others, such as ``l2`` or the torque limits ``tl1, tl2``,
are kept but not used by the identification)."""


def _model_number(label: str, name: str, value: object) -> float:
    """``value`` as a float, or a one-line ValueError naming ``label`` and ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ValueError(f"{label}: `{name}` must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{label}: `{name}` must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class PendulumModel:
    """A double pendulum of the lab's family: its physical parameters and, when known, its
    hardware design. Made by :func:`load_pendulum_model`.

    Everything the identification takes from the robot comes from here: the link length
    :math:`l_1` and gravity :math:`g` that tie :math:`A_4` to :math:`A_6`
    (:meth:`tie`), and the lab's model :math:`\\tau = M\\ddot q + C\\dot q - G + F` with
    its masses, lengths, inertias, gear ratio, rotor inertia and friction (:meth:`torques`,
    :meth:`base_parameters`).

    Parameters
    ----------
    parameters : tuple of (str, float)
        Every ``key: number`` of the model, sorted by key; at least :data:`MODEL_KEYS`.
    design : str or None
        The design the model belongs to (``"C.0"`` for the packaged one, else the
        ``design_<name>`` folder of its file's path, :func:`design_of_path`); None if unknown.
    source : str
        Where it came from, for messages.

    Notes
    -----
    Two models are equal (and hash alike) when their :data:`MODEL_KEYS` values are: the
    design and source are labels, and keys the identification does not use do not count.
    """

    parameters: tuple[tuple[str, float], ...] = field(compare=False)
    design: str | None = field(default=None, compare=False)
    source: str = field(default="", compare=False)
    identity: tuple[float, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        values = dict(self.parameters)
        missing = [name for name in MODEL_KEYS if name not in values]
        if missing:
            raise ValueError(
                f"{self.source or 'the robot model'} lacks the keys {missing} (the lab's "
                "model_parameters.yml gives them all)"
            )
        label = self.source or "the robot model"
        for name, value in self.parameters:
            _model_number(label, name, value)
        for name in ("l1", "g"):
            if not values[name] > 0:
                raise ValueError(f"{label}: `{name}` must be > 0, got {values[name]!r}")
        identity = tuple(float(values[name]) for name in MODEL_KEYS)
        object.__setattr__(self, "identity", identity)

    @property
    def values(self) -> dict[str, float]:
        """The parameters as a fresh dict."""
        return dict(self.parameters)

    @property
    def label(self) -> str:
        """``design A.0 (<source>)``, or the source alone when the design is unknown."""
        return f"design {self.design} ({self.source})" if self.design else self.source

    def base_parameters(self) -> np.ndarray:
        """:func:`base_parameters` of this model, shape (10,)."""
        return base_parameters(self.values)

    def tie(self, regressor: np.ndarray) -> np.ndarray:
        """:func:`tie_a4_to_a6` with this model's :math:`l_1` and :math:`g`."""
        values = self.values
        return tie_a4_to_a6(regressor, values["l1"], values["g"])

    def torques(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """:func:`lab_model_torques` with this model's parameters, shape (n, 2)."""
        return lab_model_torques(q, qd, qdd, parameters=self.values)


@functools.cache
def packaged_model() -> PendulumModel:
    """The packaged design C.0 model (:func:`lab_parameters`), made once per process."""
    return PendulumModel(
        parameters=tuple(sorted(lab_parameters().items())),
        design=PACKAGED_DESIGN,
        source="packaged with diffbench",
    )


def load_pendulum_model(source=None) -> PendulumModel:
    """A robot model from the lab's ``model_parameters.yml`` of a design, or a mapping.

    Parameters
    ----------
    source : None or str or os.PathLike or mapping or PendulumModel
        None: the packaged design C.0 model (:func:`packaged_model`). A path: a file of
        ``key: number`` lines as the lab writes them (``identified_parameters/design_<name>/
        model_<version>/model_parameters.yml``); its design is the ``design_<name>`` folder of
        the path, if any (:func:`design_of_path`). A mapping of names to numbers: design
        unknown. A :class:`PendulumModel` is returned as it is.

    Returns
    -------
    PendulumModel

    Raises
    ------
    ValueError
        One line naming the file or key: a missing file, a line that is not ``key: number``, a
        missing key of :data:`MODEL_KEYS`, a value that is not finite, :math:`l_1 \\le 0` or
        :math:`g \\le 0`.

    Examples
    --------
    >>> load_pendulum_model().values["l1"], load_pendulum_model().design
    (0.2, 'C.0')
    >>> model = load_pendulum_model({**lab_parameters(), "l1": 0.3, "r1": 0.3})
    >>> model.design is None, model == load_pendulum_model()
    (True, False)
    """
    if source is None:
        return packaged_model()
    if isinstance(source, PendulumModel):
        return source
    if isinstance(source, Mapping):
        items = []
        for key, value in source.items():
            if not isinstance(key, str):
                raise ValueError(f"the robot model's keys must be names, got {key!r}")
            items.append((key, _model_number("the robot model", key, value)))
        return PendulumModel(tuple(sorted(items)), design=None, source="the given parameters")
    if not isinstance(source, (str, os.PathLike)):
        raise ValueError(
            "the robot model must be None (the packaged design C.0 model), the path of the "
            f"lab's model_parameters.yml or a mapping of its parameters, got {source!r}"
        )
    path = Path(source)
    if not path.is_file():
        raise ValueError(
            f"{path}: no such file (give the lab's model_parameters.yml of the records' design)"
        )
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file of `key: number` lines") from None
    parameters = _parse_model_text(text, str(path))
    return PendulumModel(
        parameters=tuple(sorted(parameters.items())), design=design_of_path(path), source=str(path)
    )


def base_parameters(parameters: Mapping[str, float]) -> np.ndarray:
    """The 10 base parameters :math:`X` of a set of physical parameters.

    .. math::

        X = [I_1 + I_2 + m_2 l_1^2 + (g_r^2 + 1) I_r,\\ I_2 + g_r^2 I_r,\\ I_2 - g_r I_r,\\
        m_2 l_1 r_2,\\ g (m_1 r_1 + m_2 l_1),\\ g m_2 r_2,\\ b_1, c_{f1}, b_2, c_{f2}]

    Parameters
    ----------
    parameters : mapping of str to float
        At least the keys ``I1 I2 Ir gr m1 m2 l1 r1 r2 g b1 b2 cf1 cf2`` (as
        :func:`lab_parameters`), finite numbers.

    Returns
    -------
    numpy.ndarray, shape (10,)
        In the order of :data:`PENDULUM_PARAMETER_NAMES`.

    Raises
    ------
    ValueError
        If ``parameters`` lacks a key or holds a non-finite value.
    """
    if not isinstance(parameters, Mapping):
        raise ValueError(f"`parameters` must be a mapping of names to numbers, got {parameters!r}")
    missing = [name for name in _PHYSICAL_NAMES if name not in parameters]
    if missing:
        raise ValueError(f"`parameters` lacks the keys {missing}")
    p = {name: check_real(f"parameters[{name!r}]", parameters[name]) for name in _PHYSICAL_NAMES}
    return np.array(
        [
            p["I1"] + p["I2"] + p["m2"] * p["l1"] ** 2 + (p["gr"] ** 2 + 1.0) * p["Ir"],
            p["I2"] + p["gr"] ** 2 * p["Ir"],
            p["I2"] - p["gr"] * p["Ir"],
            p["m2"] * p["l1"] * p["r2"],
            p["g"] * (p["m1"] * p["r1"] + p["m2"] * p["l1"]),
            p["g"] * p["m2"] * p["r2"],
            p["b1"],
            p["cf1"],
            p["b2"],
            p["cf2"],
        ]
    )


def lab_base_parameters() -> np.ndarray:
    """The base parameters of the lab's identified model: ``base_parameters(lab_parameters())``.

    Returns
    -------
    numpy.ndarray, shape (10,)
        In the order of :data:`PENDULUM_PARAMETER_NAMES`.
    """
    return base_parameters(lab_parameters())


def _check_states(q: object, qd: object, qdd: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``q, qd, qdd`` as float64 arrays of one shape (n, 2), n >= 1, all finite."""
    arrays = []
    for name, value in (("q", q), ("qd", qd), ("qdd", qdd)):
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"`{name}` must be an array of real numbers, got {value!r}") from None
        if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] == 0:
            raise ValueError(f"`{name}` must have shape (n, 2) with n >= 1, got {array.shape}")
        if not np.all(np.isfinite(array)):
            bad = int(np.count_nonzero(~np.isfinite(array)))
            raise ValueError(f"`{name}` holds {bad} NaN or inf values")
        if arrays and array.shape[0] != arrays[0].shape[0]:
            raise ValueError(
                f"`{name}` must have the {arrays[0].shape[0]} samples of `q`, got {array.shape[0]}"
            )
        arrays.append(array)
    return arrays[0], arrays[1], arrays[2]


def pendulum_regressor(
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    coulomb_slope: float = COULOMB_SLOPE,
) -> np.ndarray:
    """The base-parameter regressor :math:`D(q, \\dot q, \\ddot q)`: ``tau = D @ X``.

    Rows (joints 1 and 2) of each sample, columns in the order of
    :data:`PENDULUM_PARAMETER_NAMES` (derivation in the module docstring):

    .. math::

        D_1 &= [\\ddot q_1,\\ 0,\\ \\ddot q_2,\\
              c_2 (2\\ddot q_1 + \\ddot q_2) - s_2 (2\\dot q_1 \\dot q_2 + \\dot q_2^2),\\
              s_1,\\ s_{12},\\ \\dot q_1,\\ \\arctan(\\alpha \\dot q_1),\\ 0,\\ 0], \\\\
        D_2 &= [0,\\ \\ddot q_2,\\ \\ddot q_1,\\ c_2 \\ddot q_1 + s_2 \\dot q_1^2,\\ 0,\\ s_{12},\\
              0,\\ 0,\\ \\dot q_2,\\ \\arctan(\\alpha \\dot q_2)].

    Parameters
    ----------
    q, qd, qdd : array_like, shape (n, 2)
        Joint positions [rad], velocities [rad/s] and accelerations [rad/s²], finite, with the
        same number ``n >= 1`` of samples.
    coulomb_slope : float, default 100.0
        :math:`\\alpha` in s/rad, finite and > 0 (the lab uses 100).

    Returns
    -------
    numpy.ndarray, shape (n, 2, 10)
        ``D[k, j, i]``: sample ``k``, joint ``j``, base parameter ``i``.

    Raises
    ------
    ValueError
        If an array is not of shape (n, 2), not finite or of another length than ``q`` (the
        message names it), or if ``coulomb_slope`` is not a finite number > 0.

    Examples
    --------
    At rest with link 1 horizontal (:math:`q_1 = \\pi/2`, :math:`q_2 = 0`) only the two gravity
    columns are non-zero, and both are 1 for joint 1:

    >>> D = pendulum_regressor([[np.pi / 2, 0.0]], [[0.0, 0.0]], [[0.0, 0.0]])
    >>> np.round(D[0], 12).tolist()[0]
    [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0]
    """
    q, qd, qdd = _check_states(q, qd, qdd)
    slope = check_real("coulomb_slope", coulomb_slope, gt=0.0)
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    s1, s12 = np.sin(q[:, 0]), np.sin(q[:, 0] + q[:, 1])
    qd1, qd2 = qd[:, 0], qd[:, 1]
    qdd1, qdd2 = qdd[:, 0], qdd[:, 1]
    D = np.zeros((q.shape[0], 2, len(PENDULUM_PARAMETER_NAMES)))
    D[:, 0, 0] = qdd1
    D[:, 0, 2] = qdd2
    D[:, 0, 3] = c2 * (2.0 * qdd1 + qdd2) - s2 * (2.0 * qd1 * qd2 + qd2**2)
    D[:, 0, 4] = s1
    D[:, 0, 5] = s12
    D[:, 0, 6] = qd1
    D[:, 0, 7] = np.arctan(slope * qd1)
    D[:, 1, 1] = qdd2
    D[:, 1, 2] = qdd1
    D[:, 1, 3] = c2 * qdd1 + s2 * qd1**2
    D[:, 1, 5] = s12
    D[:, 1, 8] = qd2
    D[:, 1, 9] = np.arctan(slope * qd2)
    return D


def lab_model_torques(
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    parameters: Mapping[str, float] | None = None,
) -> np.ndarray:
    """Joint torques of the lab's model, :math:`\\tau = M\\ddot q + C\\dot q - G + F`.

    Computed directly from the lab's :math:`M, C, G, F` (module docstring) with
    ``parameters`` (default :func:`lab_parameters`, the packaged design C.0 model),
    independently of :func:`pendulum_regressor`.

    Parameters
    ----------
    q, qd, qdd : array_like, shape (n, 2)
        Joint positions [rad], velocities [rad/s] and accelerations [rad/s²], finite, with the
        same number ``n >= 1`` of samples.
    parameters : mapping of str to float, optional
        Physical parameters with at least the keys of :func:`base_parameters` (as
        :func:`lab_parameters` or :attr:`PendulumModel.values` give them).

    Returns
    -------
    numpy.ndarray, shape (n, 2)
        Torques in N·m.

    Raises
    ------
    ValueError
        If an array is not of shape (n, 2), not finite or of another length than ``q``, or if
        ``parameters`` lacks a key or holds a value that is not finite.

    Examples
    --------
    Hanging still, no torque is needed:

    >>> lab_model_torques(np.zeros((1, 2)), np.zeros((1, 2)), np.zeros((1, 2))).tolist()
    [[0.0, 0.0]]
    """
    q, qd, qdd = _check_states(q, qd, qdd)
    if parameters is None:
        p = lab_parameters()
    else:
        base_parameters(parameters)  # every key present and finite, or a one-line ValueError
        p = {name: float(parameters[name]) for name in _PHYSICAL_NAMES}
    m1, m2, l1, r1, r2 = p["m1"], p["m2"], p["l1"], p["r1"], p["r2"]
    I1, I2, Ir, gr, g = p["I1"], p["I2"], p["Ir"], p["gr"], p["g"]
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    s1, s12 = np.sin(q[:, 0]), np.sin(q[:, 0] + q[:, 1])
    n = q.shape[0]

    M = np.empty((n, 2, 2))
    M[:, 0, 0] = I1 + I2 + m2 * l1**2 + 2.0 * m2 * l1 * r2 * c2 + gr**2 * Ir + Ir
    M[:, 0, 1] = I2 + m2 * l1 * r2 * c2 - gr * Ir
    M[:, 1, 0] = M[:, 0, 1]
    M[:, 1, 1] = I2 + gr**2 * Ir

    h = m2 * l1 * r2 * s2
    C = np.empty((n, 2, 2))
    C[:, 0, 0] = -2.0 * h * qd[:, 1]
    C[:, 0, 1] = -h * qd[:, 1]
    C[:, 1, 0] = h * qd[:, 0]
    C[:, 1, 1] = 0.0

    G = np.empty((n, 2))
    G[:, 0] = -m1 * g * r1 * s1 - m2 * g * (l1 * s1 + r2 * s12)
    G[:, 1] = -m2 * g * r2 * s12

    b = np.array([p["b1"], p["b2"]])
    cf = np.array([p["cf1"], p["cf2"]])
    F = b * qd + cf * np.arctan(COULOMB_SLOPE * qd)

    return np.einsum("nij,nj->ni", M, qdd) + np.einsum("nij,nj->ni", C, qd) - G + F
