"""The named edge cases of edge_cases.yaml, each planned end to end and checked independently."""

from pathlib import Path

import numpy as np
import pytest
import yaml

import planner
from planner.export import coefficients_document
from planner.limits import rest_to_rest_time
from planner.pipeline import plan
from planner.task import parse_task

SUITE = Path(__file__).with_name("edge_cases.yaml")
CASES = yaml.safe_load(SUITE.read_text())


def in_degrees(task: dict) -> dict:
    """A case published in SI units, its joint values and limits converted to the task file's degrees."""
    task = yaml.safe_load(yaml.safe_dump(task))
    task["waypoints"]["joints_deg"] = np.rad2deg(task["waypoints"]["joints_deg"]).tolist()
    for key, values in task.get("limits", {}).items():
        task["limits"][key] = np.rad2deg(values).tolist()
    return task


def dense_extremes(trajectory, per_segment: int = 400):
    """Max |q^(d)| (3, J) and position min, max (J,) from samples in every segment: independent of the
    exact root-finding the planner uses."""
    knots = trajectory.knot_times
    times = np.concatenate([np.linspace(a, b, per_segment) for a, b in zip(knots[:-1], knots[1:]) if b > a])
    positions = trajectory.evaluate(times)
    largest = np.stack([np.abs(trajectory.evaluate(times, order)).max(axis=0) for order in (1, 2, 3)])
    return largest, positions.min(axis=0), positions.max(axis=0)


@pytest.mark.parametrize("case", CASES, ids=[case["name"] for case in CASES])
def test_edge_case(case):
    task_data = in_degrees(case["task"]) if case.get("radians") else case["task"]
    expect = case["expect"]
    if "error" in expect:
        with pytest.raises(getattr(planner, expect["error"]), match=expect["match"]) as info:
            plan(parse_task(task_data, name="edge", source=SUITE))
        assert "\n" not in str(info.value) and len(str(info.value)) <= 600
        return
    result = plan(parse_task(task_data, name="edge", source=SUITE))
    trajectory, limits = result.trajectory, result.limits
    summary = result.summary()
    assert summary["feasible"] is True
    # Every limit holds when sampled densely, and the exact maxima are what the samples approach.
    largest, low, high = dense_extremes(trajectory)
    assert np.all(largest <= limits.magnitudes * (1 + 1e-6))
    assert np.all(low >= limits.lower - 1e-9) and np.all(high <= limits.upper + 1e-9)
    assert np.all(largest <= result.figures.max_abs * (1 + 1e-9) + 1e-12)
    assert np.all(largest >= result.figures.max_abs * (1 - 1e-3) - 1e-12)
    # No segment shorter than the floor; coefficients finite and, normalised, of the motion's size.
    assert trajectory.durations.min() >= result.task.min_segment_s * (1 - 1e-9)
    document = coefficients_document(trajectory)
    normalized = np.asarray(document["normalized_coefficients"])
    assert np.all(np.isfinite(trajectory.coefficients)) and np.all(np.isfinite(normalized))
    motion = float(np.ptp(result.via_points, axis=0).max())
    assert np.abs(normalized[..., 1:]).max() <= 1e3 * motion
    # The total time respects lower bounds that any trajectory through the via-points obeys.
    via = result.via_points
    steps = np.abs(np.diff(via, axis=0))
    assert trajectory.total_time >= (steps / limits.velocity).max(axis=1).sum() * (1 - 1e-9)
    assert trajectory.total_time >= rest_to_rest_time(np.abs(via[-1] - via[0]), limits).max() * (1 - 1e-9)
    if "total_time_s" in expect:
        low_time, high_time = expect["total_time_s"]
        assert low_time <= trajectory.total_time <= high_time
