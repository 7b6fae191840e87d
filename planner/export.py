"""Sampled and coefficient exports, and writing an output folder with nothing partial on failure."""

from __future__ import annotations

import csv
import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .splines import PiecewisePolynomial

_QUANTITY_COLUMNS = (("q", "deg"), ("v", "deg_s"), ("a", "deg_s2"), ("j", "deg_s3"))


def json_ready(value):
    """Plain JSON types from numpy values; non-finite floats (absent limits) become null."""
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def write_json(path: Path, data) -> None:
    path.write_text(json.dumps(json_ready(data), indent=2) + "\n")


def write_trajectory_csv(path: Path, trajectory: PiecewisePolynomial, rate_hz: float) -> None:
    """Samples at ``rate_hz``: time [s], then position, velocity, acceleration, jerk per joint [deg-based]."""
    times, values = trajectory.sample(rate_hz)
    joints = trajectory.joint_count
    header = ["time_s"] + [f"{name}{j + 1}_{unit}" for name, unit in _QUANTITY_COLUMNS for j in range(joints)]
    table = np.column_stack([times] + [np.rad2deg(values[k]) for k in range(4)])
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows(np.char.mod("%.10g", table).tolist())


def read_trajectory_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of ``write_trajectory_csv``: times (N,) [s] and values (4, N, J) [rad-based SI]."""
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    joints = (data.shape[1] - 1) // 4
    return data[:, 0], np.deg2rad(data[:, 1:].reshape(len(data), 4, joints).transpose(1, 0, 2))


def coefficients_document(trajectory: PiecewisePolynomial, joint_names: list[str] | None = None) -> dict:
    """The piecewise polynomial for controllers, SI units.

    Segment k covers [knot_times[k], knot_times[k+1]]; joint j there is
    q(t) = sum_i c[k][j][i] (t - knot_times[k])^i [rad].
    """
    return {
        "format": "piecewise-polynomial/v1",
        "units": {"time": "s", "position": "rad"},
        "basis": "power series in local time tau = t - knot_times[k], lowest order first",
        "joint_names": joint_names or [f"joint{j + 1}" for j in range(trajectory.joint_count)],
        "knot_times_s": trajectory.knot_times,
        "via_times_s": trajectory.via_times,
        "coefficients": trajectory.coefficients,
    }


@contextmanager
def atomic_file(path):
    """Yield a temporary path beside ``path``; on success rename it to ``path``, else delete it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    os.close(handle)
    try:
        yield Path(temporary)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)


@contextmanager
def atomic_output_folder(out_dir):
    """Yield a fresh temporary folder; on success move its files into ``out_dir``, else delete it.

    Files are written beside ``out_dir`` and each moved with ``os.replace``,
    so a failure leaves ``out_dir`` exactly as it was.
    """
    out_dir = Path(out_dir)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.", dir=out_dir.parent))
    try:
        yield staging
        out_dir.mkdir(exist_ok=True)
        for item in staging.iterdir():
            os.replace(item, out_dir / item.name)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
