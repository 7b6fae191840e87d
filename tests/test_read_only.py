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
