"""The named edge cases of edge_cases.yaml, each planned end to end and checked independently."""

from pathlib import Path

import numpy as np
import pytest
import yaml

import planner
from conftest import assert_plan_holds
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
    trajectory = result.trajectory
    assert_plan_holds(result)
    if "total_time_s" in expect:
        low_time, high_time = expect["total_time_s"]
        assert low_time <= trajectory.total_time <= high_time
