"""Sampled and coefficient exports: trajectory.csv and coefficients.json."""

from __future__ import annotations

import csv
import json
import shutil
from dataclasses import dataclass
from functools import cached_property, partial
from pathlib import Path
from typing import Callable, TextIO

import numpy as np

from . import trigonometric
from .limits import PROFILE_QUANTITIES, default_joint_names
from .splines import PiecewisePolynomial

_QUANTITY_COLUMNS = tuple((q.column, q.key_unit) for q in PROFILE_QUANTITIES)


def json_ready(value, digits: int | None = None):
    """Plain JSON types from numpy values; non-finite floats (absent limits) become null.

    Args:
        value: a number, array, dict, list or tuple of them, or anything JSON takes as it is.
        digits: significant digits floats keep (``None``: all). A report for people uses 12, which
            removes the float noise of sums (14.999999999999998 -> 15.0) and loses nothing measurable.
    """
    if isinstance(value, dict):
        return {str(k): json_ready(v, digits) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v, digits) for v in value]
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fiu" and digits is None and np.isfinite(value).all():
            return value.tolist()  # already plain: no walk over every entry
        return json_ready(value.tolist(), digits)
    if isinstance(value, (np.floating, float)):
        if not np.isfinite(value):
            return None
        return float(value) if digits is None else float(f"{float(value):.{digits}g}")
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def write_json(path: Path, data, digits: int | None = None, *, value_per_line: bool = False) -> None:
    """``data`` as indented JSON (``json_ready``, with ``digits`` significant digits if given).

    ``value_per_line``: ``data`` is a dict written one key per line, each value on that line
    (for large arrays: Python's C encoder does this several times faster than an indented layout,
    which puts every number on a line of its own and makes the file several times longer).
    """
    ready = json_ready(data, digits)
    if value_per_line:
        text = "{\n" + ",\n".join(f"  {json.dumps(key, ensure_ascii=False)}: {json.dumps(value, ensure_ascii=False)}"
                                   for key, value in ready.items()) + "\n}"
    else:
        text = json.dumps(ready, indent=2, ensure_ascii=False)
    path.write_text(text + "\n", encoding="utf-8")


#: Rows of trajectory.csv sampled and formatted at once (``TrajectoryCsv``): bounds the memory whatever the
#: length, and makes pieces that several processes write side by side (about 0.05 s each with 6 joints).
CSV_PIECE_ROWS = 10_000


@dataclass(frozen=True)
class TrajectoryCsv:
    """trajectory.csv: samples at ``rate_hz`` [Hz] of ``trajectory``: time [s] (15 significant digits),
    then position, velocity, acceleration, jerk per joint [deg-based] (10), and, with ``torques``
    (times (K,) [s] -> (K, J) [N m]), each joint's torque.

    Columns are named ``q_<joint>_deg``, ``v_<joint>_deg_s``, ``a_<joint>_deg_s2``,
    ``j_<joint>_deg_s3`` and ``tau_<joint>_Nm`` (``joint_names`` default to joint1, joint2, ...; a
    header cell is quoted where a name needs it). Written in pieces of ``CSV_PIECE_ROWS`` rows, each
    sampled and formatted on its own: ``write`` writes them in order, here; ``pieces`` gives their
    writers into files of a folder, to run in any process and order, and ``join`` puts those together.
    """

    path: Path
    trajectory: PiecewisePolynomial
    rate_hz: float
    joint_names: list[str] | None = None
    torques: Callable[[np.ndarray], np.ndarray] | None = None

    def pieces(self, folder: Path) -> list[Callable[[], None]]:
        """The writers of the pieces, piece k's rows (no header) into the file ``folder``/k.

        Raises:
            InputError: a rate that is not > 0, or more than ``MAX_SAMPLES`` samples.
        """
        return [partial(self._write_rows, folder / str(k), first) for k, first in enumerate(self._firsts())]

    def join(self, folder: Path) -> None:
        """The header, then the pieces in ``folder`` in order (``pieces``; each removed once copied),
        into ``path``."""
        with self._open() as handle:
            for k in range(len(self._firsts())):
                with (folder / str(k)).open("rb") as piece:
                    shutil.copyfileobj(piece, handle.buffer)
                (folder / str(k)).unlink()

    def write(self) -> None:
        """The header and every piece, here, into ``path``."""
        with self._open() as handle:
            for first in self._firsts():
                handle.write(self._rows(first))

    def _open(self) -> TextIO:
        """``path`` opened for writing, its header written."""
        names = self.joint_names or default_joint_names(self.trajectory.joint_count)
        columns = _QUANTITY_COLUMNS + ((("tau", "Nm"),) if self.torques is not None else ())
        header = ["time_s"] + [f"{quantity}_{name}_{unit}" for quantity, unit in columns for name in names]
        handle = self.path.open("w", newline="", encoding="utf-8")
        csv.writer(handle, lineterminator="\n").writerow(header)
        handle.flush()  # before pieces are copied in underneath the text layer
        return handle

    @cached_property
    def _times(self) -> np.ndarray:
        """(N,) every row's time [s] (``PiecewisePolynomial.sample_times``), once per process."""
        return self.trajectory.sample_times(self.rate_hz)

    def _firsts(self) -> range:
        """The first row of each piece."""
        return range(0, len(self._times), CSV_PIECE_ROWS)

    def _write_rows(self, path: Path, first: int) -> None:
        """The piece from row ``first`` (``_rows``) into ``path``."""
        path.write_text(self._rows(first), encoding="utf-8")

    def _rows(self, first: int) -> str:
        """Rows ``first`` to ``first + CSV_PIECE_ROWS`` (or the last) as text."""
        times = self._times[first:first + CSV_PIECE_ROWS]
        values = list(np.rad2deg(self.trajectory.states(times)))
        if self.torques is not None:
            values.append(self.torques(times))
        table = np.column_stack([times] + values)
        row = ",".join(["%.15g"] + ["%.10g"] * (table.shape[1] - 1)) + "\n"  # times of long plans keep their ms
        return (row * len(table)) % tuple(table.ravel().tolist())


def write_trajectory_csv(path: Path, trajectory: PiecewisePolynomial, rate_hz: float,
                         joint_names: list[str] | None = None,
                         torques: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
    """trajectory.csv (``TrajectoryCsv``) at ``path``, written here."""
    TrajectoryCsv(Path(path), trajectory, rate_hz, joint_names, torques).write()


def read_trajectory_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of ``write_trajectory_csv``: times (N,) [s] and values (4, N, J) [rad-based SI]
    (torque columns, where there are any, are left out)."""
    with path.open(encoding="utf-8", newline="") as handle:
        header = next(csv.reader(handle))
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, encoding="utf-8")
    groups = 5 if header[-1].startswith("tau_") else 4
    joints = (data.shape[1] - 1) // groups
    return data[:, 0], np.deg2rad(data[:, 1:1 + 4 * joints].reshape(len(data), 4, joints).transpose(1, 0, 2))


def coefficients_document(trajectory: PiecewisePolynomial, joint_names: list[str] | None = None) -> dict:
    """The piecewise polynomial for controllers, SI units, in two equivalent bases.

    Segment k covers [knot_times[k], knot_times[k+1]], of duration h_k; joint j there is
    q(t) = sum_i c[k][j][i] (t - knot_times[k])^i [rad]  (``coefficients``, local time), and
    q(t) = sum_i b[k][j][i] s^i with s = (t - knot_times[k]) / h_k in [0, 1]
    (``normalized_coefficients``, b_i = c_i h_k^i). The normalized ones stay of the size of
    the motion [rad] however short a segment is (local-time ones grow like h_k^-i), so they
    are the better-conditioned form to store or send; derivatives are b-based ones divided by h_k^d.

    A ``trigonometric`` trajectory is written as its coefficients a[k][j][i] of the basis functions
    (``trigonometric.BASIS``) in theta = SPAN (t - knot_times[k]) / h_k in [0, SPAN], SPAN = 3 pi / 4 (format
    ``piecewise-trigonometric/v1``): already of the size of the motion, their time derivatives are the
    theta ones times (SPAN / h_k)^d.
    """
    durations = trajectory.durations
    names = joint_names or list(default_joint_names(trajectory.joint_count))
    if trajectory.basis == "trigonometric":
        terms = " + ".join(f"a{i}" if k == 0 else f"a{i} {kind}({'' if k == 1 else f'{k} '}theta)"
                           for i, (k, kind) in enumerate(trigonometric.BASIS))
        return {
            "format": "piecewise-trigonometric/v1",
            "units": {"time": "s", "position": "rad"},
            "basis": f"q(t) = {terms}, theta = 3 pi (t - knot_times[k]) / (4 durations_s[k]) in [0, 3 pi / 4]",
            "joint_names": names,
            "coefficients_axes": ["segment", "joint", "term"],
            "knot_times_s": trajectory.knot_times,
            "durations_s": durations,
            "via_times_s": trajectory.via_times,
            "coefficients": trajectory.coefficients,
        }
    normalized = trajectory.coefficients * durations[:, None, None] ** np.arange(trajectory.coefficients.shape[-1])
    return {
        "format": "piecewise-polynomial/v1",
        "units": {"time": "s", "position": "rad"},
        "basis": "power series in local time tau = t - knot_times[k], lowest order first",
        "normalized_basis": "power series in s = (t - knot_times[k]) / durations_s[k] in [0, 1], lowest order first",
        "joint_names": names,
        "coefficients_axes": ["segment", "joint", "power"],
        "segment_degrees": trajectory.segment_degrees,
        "knot_times_s": trajectory.knot_times,
        "durations_s": durations,
        "via_times_s": trajectory.via_times,
        "coefficients": trajectory.coefficients,
        "normalized_coefficients": normalized,
    }
