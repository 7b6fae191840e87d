from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from planner import IKError, InputError, paper
from planner.ik import pose_error, pose_from_position_quaternion, solve_pose, solve_waypoints
from planner.robot import Robot

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def puma():
    return Robot.from_urdf(ROOT / "robots" / "puma560.urdf", "tool")


def within_ranges(robot, q):
    return np.all(q >= robot.limits.lower - 1e-12) and np.all(q <= robot.limits.upper + 1e-12)


def test_table_ii_with_hints_recovers_via_points(puma):
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    poses = [puma.forward_kinematics(q) for q in via]
    solutions = solve_waypoints(puma, poses, hints=list(via))
    np.testing.assert_allclose(np.rad2deg([s.q for s in solutions]), paper.VIA_POINTS_DEG, atol=1e-6)


def test_table_ii_without_hints_reaches_every_pose_in_range(puma):
    poses = [puma.forward_kinematics(q) for q in np.deg2rad(paper.VIA_POINTS_DEG)]
    solutions = solve_waypoints(puma, poses)
    for solution, pose in zip(solutions, poses):
        error = pose_error(puma, solution.q, pose)
        assert np.linalg.norm(error[:3]) <= 1e-9 and np.linalg.norm(error[3:]) <= 1e-9
        assert within_ranges(puma, solution.q)
    assert solutions[0].jump == 0 and all(s.jump > 0 for s in solutions[1:])


@pytest.mark.parametrize("name, tool", [("puma", "tool"), ("ur5", "tool0"), ("panda", "panda_hand_tcp")])
def test_random_reachable_poses_solve_to_1e_9(puma, name, tool):
    robot = puma if name == "puma" else Robot.from_example_robot_data(name, tool)
    rng = np.random.default_rng(7)
    lower, upper = robot.limits.lower, robot.limits.upper
    configurations = lower + (upper - lower) * rng.random((8, robot.dof))
    poses = [robot.forward_kinematics(q) for q in configurations]
    for solution, pose in zip(solve_waypoints(robot, poses, seed=3), poses):
        error = pose_error(robot, solution.q, pose)
        assert max(np.linalg.norm(error[:3]), np.linalg.norm(error[3:])) <= 1e-9
        assert within_ranges(robot, solution.q)


def test_single_solve_converges_quadratically(puma):
    q = np.deg2rad(paper.VIA_POINTS_DEG[2])
    solution = solve_pose(puma, puma.forward_kinematics(q), q + 0.05)
    assert solution.residual <= 1e-10 and solution.iterations <= 10


def test_unreachable_pose_names_waypoint_and_residual(puma):
    poses = [puma.forward_kinematics(np.zeros(6)), pin.SE3(np.eye(3), np.array([3.0, 0.0, 1.0]))]
    with pytest.raises(IKError, match=r"waypoint 1: pose not reached .* best residual [\d.e+-]+ m") as info:
        solve_waypoints(puma, poses, restarts=3)
    assert info.value.waypoint == 1 and info.value.residual > 1.0


def test_hint_of_wrong_length(puma):
    pose = puma.forward_kinematics(np.zeros(6))
    with pytest.raises(InputError, match="waypoint 0: hint has 3 values, robot has 6 joints"):
        solve_waypoints(puma, [pose], hints=[np.zeros(3)])


def test_pose_from_quaternion_matches_pinocchio():
    quaternion = np.array([0.1, -0.3, 0.2, 0.9])
    quaternion /= np.linalg.norm(quaternion)
    pose = pose_from_position_quaternion([1, 2, 3], quaternion)
    np.testing.assert_allclose(pin.Quaternion(pose.rotation).coeffs(), quaternion, atol=1e-12)
    np.testing.assert_allclose(pose.translation, [1, 2, 3])
