"""Closed-form IK (planner.analytic_ik) and the margin of redundant arms' solutions (planner.ik)."""

from pathlib import Path

import numpy as np
import pytest

from planner.analytic_ik import analytic_solver
from planner.ik import closed_form_solver, pose_error, pose_solutions, range_margin_deg, solve_pose, solve_waypoints
from planner.robot import Robot

ROOT = Path(__file__).resolve().parents[1]
PUMA_URDF = ROOT / "robots" / "puma560.urdf"


def load(name):
    return Robot.from_urdf(PUMA_URDF, "tool") if name == "puma" else Robot.from_example_robot_data("ur5", "tool0")


def wrapped(q):
    return (q + np.pi) % (2 * np.pi) - np.pi


def residual(robot, q, target):
    error = pose_error(robot, q, target)
    return max(np.linalg.norm(error[:3]), np.linalg.norm(error[3:]))


@pytest.mark.parametrize("name", ["puma", "ur5"])
def test_closed_form_gives_all_eight_exact_solutions(name):
    robot = load(name)
    solve = analytic_solver(robot)
    assert solve is not None
    rng = np.random.default_rng(1)
    counts = []
    for q in rng.uniform(-np.pi, np.pi, (200, 6)):
        target = robot.forward_kinematics(q)
        solutions = solve(target)
        assert all(residual(robot, s, target) <= 1e-9 for s in solutions)
        assert np.min(np.abs(wrapped(solutions - q)).max(axis=1)) <= 1e-6
        if np.linalg.svd(robot.frame_jacobian(q), compute_uv=False)[-1] > 1e-2:  # away from singularities
            counts.append(len(solutions))
            gaps = np.abs(wrapped(solutions[:, None] - solutions[None])).max(axis=2)
            assert np.all(gaps[~np.eye(len(solutions), dtype=bool)] > 1e-6)  # distinct solutions
    # The PUMA always has 8. For the UR5 a shoulder or wrist branch may leave axis 4 out of the elbow's reach:
    # then 2, 4 or 6 (the numeric search finds no more either, see the next test).
    assert set(counts) == {8} if name == "puma" else set(counts) <= {2, 4, 6, 8}
    assert max(set(counts), key=counts.count) == 8


@pytest.mark.parametrize("name", ["puma", "ur5"])
def test_numeric_search_never_finds_a_solution_the_closed_form_misses(name):
    robot = load(name)
    solve = closed_form_solver(robot)
    rng = np.random.default_rng(2)
    lower, upper = robot.limits.lower, robot.limits.upper
    for q in lower + (upper - lower) * rng.random((12, 6)):
        target = robot.forward_kinematics(q)
        closed = solve(target)
        for start in lower + (upper - lower) * rng.random((48, 6)):
            solution = solve_pose(robot, target, start, clip=False)  # as the numeric search solves
            if solution.residual <= 1e-9:
                assert np.min(np.abs(wrapped(closed - solution.q)).max(axis=1)) <= 1e-6


@pytest.mark.parametrize("name", ["puma", "ur5"])
def test_pose_solutions_use_the_closed_form(name):
    robot = load(name)
    q = np.deg2rad([20, -60, 80, 30, 40, 50])
    target = robot.forward_kinematics(q)
    found, _, attempts = pose_solutions(robot, target, robot.limits, np.random.default_rng(0))
    assert attempts == 1
    assert all(s.residual <= 1e-10 for s in found)
    assert min(np.abs(wrapped(s.q - q)).max() for s in found) <= 1e-9


def test_panda_has_no_closed_form():
    assert analytic_solver(Robot.from_example_robot_data("panda", "panda_hand_tcp")) is None


def perturbed_puma(tmp_path, old, new):
    text = PUMA_URDF.read_text()
    assert text.count(old) == 1
    path = tmp_path / "puma560.urdf"
    path.write_text(text.replace(old, new))
    return Robot.from_urdf(path, "tool")


def test_longer_upper_arm_keeps_a_correct_closed_form(tmp_path):
    robot = perturbed_puma(tmp_path, '<origin xyz="0.4318 0 0" rpy="0 0 0"/>', '<origin xyz="0.47 0 0" rpy="0 0 0"/>')
    solve = analytic_solver(robot)
    assert solve is not None
    q = np.deg2rad([10, -50, 70, 20, 30, 40])
    target = robot.forward_kinematics(q)
    assert all(residual(robot, s, target) <= 1e-9 for s in solve(target))


def test_wrist_that_is_not_spherical_has_no_closed_form(tmp_path):
    joint6 = '<parent link="link5"/><child link="link6"/>\n    '
    robot = perturbed_puma(tmp_path, joint6 + '<origin xyz="0 0 0" rpy="-1.570796327 0 0"/>',
                           joint6 + '<origin xyz="0.02 0 0" rpy="-1.570796327 0 0"/>')
    assert analytic_solver(robot) is None
    q = np.deg2rad([10, -50, 70, 20, 30, 40])  # the numeric search still solves it
    solution = solve_waypoints(robot, [robot.forward_kinematics(q)])[0]
    assert solution.residual <= 1e-9


def test_redundant_arm_solutions_keep_a_margin_to_the_bounds():
    robot = Robot.from_example_robot_data("panda", "panda_hand_tcp")
    lower, upper = robot.limits.lower, robot.limits.upper
    rng = np.random.default_rng(5)
    inset = np.deg2rad(20)  # every generating configuration has a 20 deg margin
    for index, q in enumerate(lower + inset + (upper - lower - 2 * inset) * rng.random((8, robot.dof))):
        target = robot.forward_kinematics(q)
        assert range_margin_deg(q, robot.limits) >= 20 - 1e-9
        for branch in ("optimal", "continuous"):
            solution = solve_waypoints(robot, [target], branch=branch, seed=index)[0]
            assert solution.residual <= 1e-10
            assert solution.margin_deg > 5
            assert solution.margin_deg == pytest.approx(range_margin_deg(solution.q, robot.limits))


def test_margin_is_reported_for_every_arm():
    robot = load("puma")
    q = np.deg2rad([10, -50, 70, 20, 30, 40])
    solution = solve_waypoints(robot, [robot.forward_kinematics(q)], hints=[q])[0]
    # Joint 5 at 30 deg is 70 deg from its bound of 100 deg; joint 2 at -50 deg is 95 deg from 45 deg.
    assert solution.margin_deg == pytest.approx(min(np.rad2deg(np.minimum(q - robot.limits.lower,
                                                                            robot.limits.upper - q))))


def scaled_puma(tmp_path, factor):
    """The PUMA with every placement (joint, tool and inertial origins) multiplied by ``factor``."""
    import re

    def scaled(match):
        return '<origin xyz="' + " ".join(repr(float(v) * factor) for v in match.group(1).split()) + '"'
    path = tmp_path / "puma560.urdf"
    path.write_text(re.sub(r'<origin xyz="([^"]*)"', scaled, PUMA_URDF.read_text()))
    return Robot.from_urdf(path, "tool")


def test_a_small_arm_of_a_known_class_keeps_its_closed_form(tmp_path):
    """The self-check's configurations away from singularities are judged in units of the arm's size: a
    PUMA a hundredth of the size found none under an absolute threshold (and drew forever, sweep 16)."""
    robot = scaled_puma(tmp_path, 0.01)
    solve = analytic_solver(robot)
    assert solve is not None
    q = np.deg2rad([10, -50, 70, 20, 30, 40])
    target = robot.forward_kinematics(q)
    solutions = solve(target)
    assert np.min(np.abs(wrapped(solutions - q)).max(axis=1)) <= 1e-6
    assert all(residual(robot, s, target) <= 1e-9 for s in solutions)


def test_a_chain_singular_everywhere_has_no_closed_form_and_does_not_hang(tmp_path):
    """Every placement at the origin: the tool frame has fewer than 6 degrees of freedom everywhere, so no
    configuration qualifies for the self-check; after ``_SELF_CHECK_DRAWS`` draws the arm gets the numeric
    search (the default IK hung, sweep 16)."""
    import signal

    def hung(*args):
        raise TimeoutError("analytic_solver did not return within 60 s")
    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(60)
    try:
        assert analytic_solver(scaled_puma(tmp_path, 0.0)) is None
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
