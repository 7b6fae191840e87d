"""Tests for behaviour of planner.ik that no existing test checks (found by mutation testing).

Mostly the ``continuous`` branch rule: hints, restarts after a failed seeded solve, the reported attempts,
the default first seed, and the 2 pi turn it keeps; and the error for a pose reachable only outside
ranges when some joint's range is bounded on one side only."""
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planner.ik as ik
from planner import IKError, paper
from planner.ik import solve_waypoints
from planner.limits import FEASIBILITY_TOLERANCE
from planner.robot import Robot

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def puma():
    return Robot.from_urdf(ROOT / "robots" / "puma560.urdf", "tool")


@pytest.fixture(scope="module")
def panda():
    return Robot.from_example_robot_data("panda", "panda_hand_tcp")


@pytest.fixture(scope="module")
def ur5():
    return Robot.from_example_robot_data("ur5", "tool0")


class CountingSolves:
    """Wraps ik.solve_pose: records (target id, seed, residual) per call; fails loudly instead of looping."""

    def __init__(self, monkeypatch, limit=500):
        self.calls, self.limit, self.solve, self.solved_q = [], limit, ik.solve_pose, {}
        monkeypatch.setattr(ik, "solve_pose", self)

    def __call__(self, robot, target, seed, *args, **kwargs):
        if len(self.calls) >= self.limit:
            raise RuntimeError(f"more than {self.limit} IK solves")
        solution = self.solve(robot, target, seed, *args, **kwargs)
        self.calls.append((id(target), np.array(seed, dtype=float), solution.residual))
        self.solved_q.setdefault(id(target), []).append(np.array(solution.q))
        return solution

    def for_target(self, target):
        return [call for call in self.calls if call[0] == id(target)]


@pytest.mark.parametrize("name", ["puma", "panda", "ur5"])
def test_continuous_rule_keeps_each_hinted_solution(request, name):
    """A hint selects the solution it seeds (module docstring: 'seeded from the previous solution (or the
    waypoint's hint)'): with hints that are exact solutions, the continuous rule returns them unchanged,
    also on a redundant arm (no centring of a hinted solution) and where a 2 pi turn of a joint would be
    nearer the previous configuration (UR5 base from 170 deg to -170 deg: kept at -170)."""
    robot = request.getfixturevalue(name)
    if name == "puma":
        hints = np.deg2rad(paper.VIA_POINTS_DEG)
    elif name == "ur5":
        hints = np.deg2rad([[170.0, -60.0, 80.0, -110.0, -90.0, 0.0], [-170.0, -60.0, 80.0, -110.0, -90.0, 0.0]])
    else:
        lower, upper = robot.limits.lower, robot.limits.upper
        hints = lower + (upper - lower) * np.random.default_rng(1).uniform(0.2, 0.8, (3, robot.dof))
    poses = [robot.forward_kinematics(q) for q in hints]
    solutions = solve_waypoints(robot, poses, hints=list(hints), branch="continuous")
    np.testing.assert_allclose([s.q for s in solutions], hints, atol=1e-9)


@pytest.mark.parametrize("restarts", [0, 1, 3])
def test_continuous_rule_gives_up_after_restarts_plus_one_solves(puma, monkeypatch, restarts):
    """An unreachable waypoint gets the seeded solve and ``restarts`` random restarts, no more, no fewer;
    the error counts them ("1 attempt", "n attempts") and reports the best residual of those solves."""
    solves = CountingSolves(monkeypatch)
    far = pin.SE3(np.eye(3), np.array([3.0, 0.0, 1.0]))
    with pytest.raises(IKError) as raised:
        solve_waypoints(puma, [puma.forward_kinematics(np.zeros(6)), far], branch="continuous", restarts=restarts)
    calls = solves.for_target(far)
    assert len(calls) == restarts + 1
    plural = "s" if restarts + 1 > 1 else ""
    assert re.search(rf"^waypoint 1: pose not reached within the joint ranges after {restarts + 1} attempt{plural}; "
                     r"best residual", str(raised.value)), str(raised.value)
    assert raised.value.waypoint == 1
    assert raised.value.residual == pytest.approx(min(call[2] for call in calls), rel=1e-12)


def test_continuous_rule_reports_the_solves_each_waypoint_used(puma, monkeypatch):
    """What each solution reports: ``attempts``, the solves made for its waypoint (one where the seeded solve
    succeeds); ``solutions``, the distinct solutions those solves found (1 after a seeded success);
    ``iterations``, a positive count; ``jump``, 0 for the first waypoint and |q_i - q_i-1| after; and the
    chosen solution is the one of those found nearest the previous configuration (in its in-range 2 pi
    turn nearest it). Table II without hints: one waypoint needs restarts and finds several solutions."""
    poses = [puma.forward_kinematics(q) for q in np.deg2rad(paper.VIA_POINTS_DEG)]
    solves = CountingSolves(monkeypatch)
    solutions = solve_waypoints(puma, poses, branch="continuous")
    lower, upper = puma.limits.lower, puma.limits.upper
    previous = (lower + upper) / 2
    for index, (pose, solution) in enumerate(zip(poses, solutions)):
        calls = solves.for_target(pose)
        assert solution.attempts == len(calls)
        assert isinstance(solution.iterations, int) and solution.iterations >= 1
        reached = [q for q, residual in zip(solves.solved_q[id(pose)], [c[2] for c in calls]) if residual <= 1e-9]
        distinct = []
        for q in reached:
            if all(np.abs((q - other + np.pi) % (2 * np.pi) - np.pi).max() > 1e-5 for other in distinct):
                distinct.append(q)
        assert solution.solutions == len(distinct)
        if calls[0][2] <= 1e-9:
            assert solution.attempts == 1 and solution.solutions == 1
        nearest = min(np.linalg.norm(in_range_turn_nearest(q, previous, lower, upper) - previous) for q in distinct)
        assert np.linalg.norm(solution.q - previous) == pytest.approx(nearest, abs=1e-9)
        assert solution.jump == (0.0 if index == 0 else pytest.approx(np.linalg.norm(solution.q - previous)))
        previous = solution.q
    assert any(s.attempts > 1 and s.solutions > 1 for s in solutions)  # the restart path is exercised


def in_range_turn_nearest(q, reference, lower, upper):
    """Per joint, the value of q up to 2 pi turns nearest ``reference`` among those in range (brute force)."""
    out = q.copy()
    for j in range(len(q)):
        options = q[j] + 2 * np.pi * np.arange(-4, 5)
        options = options[(options >= lower[j]) & (options <= upper[j])]
        if len(options):
            out[j] = options[np.argmin(np.abs(options - reference[j]))]
    return out


def test_continuous_rule_restarts_from_configurations_spread_over_the_ranges(puma, monkeypatch):
    """Restarts are 'random configurations' over the ranges: each restart seed lies in the ranges, and
    the joints' positions within their ranges are drawn independently (not one fraction for all)."""
    solves = CountingSolves(monkeypatch)
    far = pin.SE3(np.eye(3), np.array([3.0, 0.0, 1.0]))
    with pytest.raises(IKError):
        solve_waypoints(puma, [far], branch="continuous", restarts=6)
    lower, upper = puma.limits.lower, puma.limits.upper
    seeds = np.array([call[1] for call in solves.for_target(far)[1:]])
    assert len(seeds) == 6
    assert np.all(seeds >= lower) and np.all(seeds <= upper)
    fractions = (seeds - lower) / (upper - lower)
    assert np.all(np.ptp(fractions, axis=1) > 1e-6)


def test_continuous_rule_without_a_start_seeds_from_the_middle_of_the_ranges(panda):
    """``start`` defaults to the middle of the ranges (solve_waypoints' docstring): on an arm whose ranges
    are not symmetric about 0, no start and start = middle give the same solution."""
    lower, upper = panda.limits.lower, panda.limits.upper
    q = lower + (upper - lower) * np.random.default_rng(1).uniform(0.2, 0.8, panda.dof)
    pose = panda.forward_kinematics(q)
    default = solve_waypoints(panda, [pose], branch="continuous")
    middle = solve_waypoints(panda, [pose], branch="continuous", start=(lower + upper) / 2)
    np.testing.assert_allclose(default[0].q, middle[0].q, atol=1e-12)


@pytest.fixture(scope="module")
def wide_ur5(ur5):
    """A UR5 whose ranges are +-600 deg (as the pipeline does, the robot carries the task's ranges)."""
    from dataclasses import replace
    half = np.full(6, np.deg2rad(600.0))
    return replace(ur5, limits=ur5.limits.with_overrides(lower=-half, upper=half))


@settings(max_examples=200, derandomize=True, deadline=None)
@given(st.sampled_from([360.0, 600.0]), st.lists(st.floats(-np.pi, np.pi), min_size=6, max_size=6),
       st.lists(st.floats(0.0, 1.0), min_size=6, max_size=6))
def test_nearest_turn_is_the_representative_nearest_the_reference(ur5, wide_ur5, span, q, reference):
    """The 2 pi shift (``nearest_turn``), with ranges of +-360 deg (UR5) and +-600 deg and a reference
    (the previous configuration) in range: the result equals q up to whole turns, stays in range, and is
    the in-range representative of q nearest the reference (brute force over the turns). It once kept q
    itself where the unconstrained nearest turn fell just outside the range."""
    robot = ur5 if span == 360.0 else wide_ur5
    lower, upper = robot.limits.lower, robot.limits.upper
    q, reference = np.array(q), lower + (upper - lower) * np.array(reference)
    shifted = ik.nearest_turn(robot, q, reference)
    # within the ranges to the feasibility tolerance, as designed (a case 1e-9 rad past the UR5's bound)
    assert np.all(shifted >= lower - FEASIBILITY_TOLERANCE) and np.all(shifted <= upper + FEASIBILITY_TOLERANCE)
    turns = (shifted - q) / (2 * np.pi)
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-9)
    for j in range(6):
        options = q[j] + 2 * np.pi * np.arange(-4, 5)
        options = options[(options >= lower[j] - FEASIBILITY_TOLERANCE) & (options <= upper[j] + FEASIBILITY_TOLERANCE)]
        distances = np.sort(np.abs(options - reference[j]))
        assert abs(shifted[j] - reference[j]) == pytest.approx(distances[0], abs=1e-9)


def test_a_pose_outside_ranges_bounded_on_one_side_names_a_finite_bound(ur5):
    """Ranges of +-1 deg, except the last joint, bounded below only: the pose is reachable but outside the
    ranges, and the message names a joint at a finite angle beyond a finite bound it really passes."""
    lower, upper = np.full(6, np.deg2rad(-1.0)), np.full(6, np.deg2rad(1.0))
    upper[5] = np.inf
    limits = ur5.limits.with_overrides(lower=lower, upper=upper)
    pose = ur5.forward_kinematics(np.deg2rad([10.0, -60.0, 80.0, -100.0, -90.0, 30.0]))
    with pytest.raises(IKError) as raised:
        solve_waypoints(ur5, [pose], limits=limits)
    found = re.search(r"joint (\w+) at (-?[\d.]+) deg, beyond its (upper|lower) limit (-?[\d.]+) deg$",
                      str(raised.value))
    assert found, str(raised.value)
    j = ur5.joint_names.index(found[1])
    value, side, bound = float(found[2]), found[3], float(found[4])
    assert bound == pytest.approx(np.rad2deg(lower[j] if side == "lower" else upper[j]))
    assert (value < bound) if side == "lower" else (value > bound)
