"""Sampled and coefficient exports: trajectory.csv and coefficients.json."""

from __future__ import annotations

import csv
import json
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
