import numpy as np
import pytest

from conftest import ROOT
from planner import JointLimits, get_family, kinematic_figures, load_task, paper
from planner.timing import TimingProblem, optimize


def test_frozen_values_hold_read_only_arrays_and_leave_the_callers_alone():
    velocity = np.array([1.0, 2.0])
    limits = JointLimits.create(2, velocity=velocity)
    velocity[0] = 5.0  # the caller's array stays writable and is not shared
    assert limits.velocity[0] == 1.0
    trajectory = get_family("hybrid").build(np.deg2rad(paper.VIA_POINTS_DEG), np.full(9, 3.0))
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    result = optimize(problem, "nlp")
    task = load_task(ROOT / "scripts" / "tasks" / "puma560_paper_cartesian.yaml")
    arrays = [limits.velocity, limits.lower, trajectory.durations, trajectory.coefficients,
              kinematic_figures(trajectory).max_abs, result.durations, result.ratios,
              task.cartesian_waypoints[0].position, task.cartesian_waypoints[0].hint]
    for array in arrays:
        with pytest.raises(ValueError, match="read-only"):
            array[..., 0] = 0.0
        with pytest.raises(ValueError, match="WRITEABLE"):  # an array that owned its data could be (sweep 26)
            array.setflags(write=True)


def test_copies_and_unpickled_values_keep_their_arrays_read_only():
    """NumPy does not keep the flag in a copy and neither pickle nor deepcopy runs __post_init__: a copied
    trajectory could be given negative durations after its checks."""
    import copy
    import pickle
    trajectory = get_family("hybrid").build(np.deg2rad(paper.VIA_POINTS_DEG), np.full(9, 3.0))
    limits = paper.paper_limits()
    for copied in (pickle.loads(pickle.dumps(trajectory)), copy.deepcopy(trajectory)):
        np.testing.assert_array_equal(copied.coefficients, trajectory.coefficients)
        with pytest.raises(ValueError, match="read-only"):
            copied.durations[0] = -1.0
    for copied_limits in (pickle.loads(pickle.dumps(limits)), copy.deepcopy(limits)):
        with pytest.raises(ValueError, match="read-only"):
            copied_limits.velocity[0] = 0.0


def test_the_robot_limit_outcome_holds_read_only_arrays():
    """Writing into the torque limits once changed the summary and a later save."""
    from planner import make_task, plan
    result = plan(make_task(robot={"name": "ur5", "tool_frame": "tool0"},
                            joints_deg=[[0, -90, 90, 0, 90, 0], [30, -60, 60, 10, 80, 20]],
                            limits={"acceleration_deg_s2": [150] * 6, "jerk_deg_s3": [600] * 6, "torque_nm": "urdf"}))
    for array in (result.torque_limit, result.robot_limits.check.times, result.robot_limits.check.torque):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = -1.0


def test_a_tasks_mappings_stay_read_only_in_copies_and_read_as_dicts():
    """``Task.limits`` and ``Task.optimizer`` (sweep 26): pickled or deep-copied they stay read-only, and they
    compare, serialise and copy (``copy()``: a plain, changeable dict) as dicts."""
    import copy
    import json
    import pickle
    task = load_task(ROOT / "scripts" / "tasks" / "ur5_pick_and_place.yaml")
    for copied in (pickle.loads(pickle.dumps(task)), copy.deepcopy(task)):
        assert copied.optimizer == task.optimizer and copied.limits.keys() == task.limits.keys()
        for mapping in (copied.optimizer, copied.limits, copied.optimizer["settings"]):
            with pytest.raises(TypeError, match="cannot be changed"):
                mapping.clear()
        with pytest.raises(ValueError, match="read-only"):
            next(iter(copied.limits.values()))[0] = 0.0
    plain = task.optimizer.copy()
    plain["algorithm"] = "nlp"
    assert type(plain) is dict and task.optimizer["algorithm"] == "default"
    assert json.loads(json.dumps({k: v for k, v in task.optimizer.items() if k != "weights"}))["algorithm"] == "default"
