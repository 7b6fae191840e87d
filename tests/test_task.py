from pathlib import Path

import numpy as np
import pytest
import yaml

from planner import TaskError, paper
from planner.task import load_task, parse_task

ROOT = Path(__file__).resolve().parents[1]
PAPER_JOINT = ROOT / "scripts" / "tasks" / "puma560_paper_joint.yaml"


def joint_task(**changes) -> dict:
    data = yaml.safe_load(PAPER_JOINT.read_text())
    for path, value in changes.items():
        node = data
        keys = path.split("__")
        for key in keys[:-1]:
            node = node[key]
        if value is ...:
            del node[keys[-1]]
        else:
            node[keys[-1]] = value
    return data


def test_paper_joint_task_loads_in_si_units():
    task = load_task(PAPER_JOINT)
    np.testing.assert_allclose(task.joint_waypoints, np.deg2rad(paper.VIA_POINTS_DEG))
    np.testing.assert_allclose(task.limits["jerk"], np.deg2rad(paper.JERK_LIMITS_DEG))
    assert task.family == "hybrid" and task.name == "puma560_paper_joint"
    assert task.optimizer == {"algorithm": "cuckoo", "seed": 0, "bounds": (3.0, 5.0), "objective": "time",
                              "weights": (1.0, 1.0), "settings": {"nests": 20, "iterations": 150, "pa": 0.25}}


def test_optional_sections_take_defaults():
    task = parse_task(joint_task(trajectory=..., optimizer=...))
    assert task.family == "hybrid" and task.optimizer["algorithm"] == "default"
    assert task.optimizer["bounds"] is None and task.sample_rate_hz == 100.0


@pytest.mark.parametrize("changes, message", [
    ({"extra": 1}, r"^extra: unknown key; expected one of: version, name"),
    ({"version": ...}, r"^version: is required"),
    ({"version": 2}, r"^version: unsupported version 2"),
    ({"waypoints": ...}, r"^waypoints: is required"),
    ({"waypoints__joints_deg": [[1, 2]]}, r"^waypoints.joints_deg: must be a list of at least 2"),
    ({"waypoints__joints_deg": [[1, 2], [1, 2, 3]]}, r"^waypoints.joints_deg\[1\]: must have 2 values, got 3"),
    ({"waypoints__joints_deg": [[1, 2], [1, "x"]]}, r"^waypoints.joints_deg\[1\]\[1\]: must be a number, got 'x'"),
    ({"waypoints__joints_deg": [[1, 2], [1, float("nan")]]}, r"joints_deg\[1\]\[1\]: must be a finite number"),
    ({"limits__velocity_deg_s": [100, 95, -1, 150, 130, 110]}, r"^limits.velocity_deg_s\[2\]: must be > 0, got -1"),
    ({"limits__velocity_deg_s": [100, 95, 0, 150, 130, 110]}, r"^limits.velocity_deg_s\[2\]: must be > 0, got 0"),
    ({"limits__jerk_deg_s3": [60, 66]}, r"^limits.jerk_deg_s3: must have 6 values \(one per joint\), got 2"),
    ({"limits__speed": [1]}, r"^limits.speed: unknown key"),
    ({"limits": ...}, r"^limits: a joint-space task without a robot needs"),
    ({"trajectory__family": "trig"}, r"^trajectory.family: unknown family 'trig'"),
    ({"optimizer__algorithm": "ga"}, r"^optimizer.algorithm: unknown algorithm 'ga'"),
    ({"optimizer__particles": 5}, r"^optimizer.particles: unknown key"),
    ({"optimizer__nests": 2.5}, r"^optimizer.nests: must be a whole number"),
    ({"optimizer__bounds_s": [5, 3]}, r"^optimizer.bounds_s: lower bound 5.0 exceeds upper bound 3.0"),
    ({"optimizer__bounds_s": [0, 3]}, r"^optimizer.bounds_s\[0\]: must be > 0"),
    ({"optimizer__objective": "energy"}, r"^optimizer.objective: unknown objective 'energy'"),
    ({"optimizer__polish": 1}, r"^optimizer.polish: must be true or false"),
])
def test_bad_task_names_key_path(changes, message):
    with pytest.raises(TaskError, match=message):
        parse_task(joint_task(**changes))


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(TaskError, match="cannot read task file"):
        load_task(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("version: 1\nwaypoints: [1, 2\n")
    with pytest.raises(TaskError, match=r"not valid YAML at line \d+"):
        load_task(bad)
    bad.write_text("- 1\n- 2\n")
    with pytest.raises(TaskError, match="must be a mapping, got list"):
        load_task(bad)
