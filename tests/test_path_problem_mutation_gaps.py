"""Gaps in the tests of planner/timing/problem.py and planner/cartesian_path.py found by a hand
mutation-testing run: each test kills a mutant that survived the existing focused tests. Feasibility is
checked against the trajectory sampled densely, not against the problem's own ratios."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from conftest import assert_on_segment, puma_segment
from planner import IKError, JointLimits
from planner.cartesian_path import _respace
from planner.errors import InfeasibleError, InputError
from planner.ik import solve_pose
from planner.pipeline import plan
from planner.robot import Robot, load_robot
from planner.task import parse_task
from planner.timing import TimingProblem
from planner.timing.problem import REPEAT_TOLERANCE

VIA = np.radians([[0.0, 0.0], [40.0, -20.0], [90.0, 10.0]])
TIGHT = JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0], jerk=[10.0, 10.0])
LOOSE = JointLimits.create(2, velocity=[50.0, 50.0], acceleration=[500.0, 500.0], jerk=[5000.0, 5000.0])


def _peaks(problem, durations, samples=20001):
    """(3, J) peak |velocity|, |acceleration|, |jerk| of the trajectory sampled densely."""
    trajectory = problem.trajectory(durations)
    t = np.linspace(0.0, trajectory.total_time, samples)
    return np.array([np.abs(trajectory.evaluate(t, order=d)).max(axis=0) for d in (1, 2, 3)])


def _sampled_ratios(problem, durations):
    """(3, J) the sampled peaks over the limits."""
    return _peaks(problem, durations) / problem.limits.magnitudes


# ---------------------------------------------------------------- problem.py: set-up errors

def test_a_limited_joint_standing_still_does_not_bound_a_moving_unlimited_one():
    """Joint 0 has a velocity limit but does not move; joint 1 moves with no limit: the minimum time is
    unbounded below, refused naming the moving joint (a check that any limit, or any motion, suffices
    accepted it)."""
    via = np.array([[0.0, 0.0], [0.0, 1.0]])
    limits = JointLimits.create(2, velocity=[1.0, np.inf])
    with pytest.raises(InputError, match=r"unbounded below \(moving without a limit: " + limits.names[1]):
        TimingProblem(via, "quintic", limits)


def test_equal_duration_bounds_are_accepted_and_fix_every_duration():
    """h_min = h_max is a valid pair of bounds: every repaired duration is exactly it."""
    problem = TimingProblem(VIA, "quintic", LOOSE, bounds=(0.5, 0.5))
    evaluation = problem.evaluate(np.array([[0.5, 0.5]]))
    assert evaluation.feasible[0]
    np.testing.assert_array_equal(evaluation.durations, [[0.5, 0.5]])


def test_a_zero_time_weight_is_refused():
    """K_t must be > 0 (with K_t = 0 the time-jerk objective is least at infinitely slow motion)."""
    with pytest.raises(InputError, match="K_t > 0"):
        TimingProblem(VIA, "quintic", TIGHT, objective="time-jerk", weights=(0.0, 1.0))


def test_durations_fixed_at_h_max_that_break_a_limit_are_refused_naming_the_worst_limit():
    """bounds (1, 1): the quintic rest-to-rest segment of 1 rad in 1 s peaks at 1.875 rad/s (sampled), 1.25
    times joint 0's velocity limit; joint 1's jerk is also exceeded, by less (12 / 11). The lower bound of any
    trajectory (1 / 1.5 s) does not prove it: the fixed rule's check must, naming the worst ratio."""
    via = np.array([[0.0, 0.0], [1.0, 0.2]])
    limits = JointLimits.create(2, velocity=[1.5, 10.0], acceleration=[100.0, 100.0], jerk=[1000.0, 11.0])
    loose = TimingProblem(via, "quintic", JointLimits.create(2, velocity=[100.0, 100.0]))
    sampled = _peaks(loose, np.array([1.0])) / limits.magnitudes
    assert sampled[0, 0] == pytest.approx(1.25, rel=1e-6) and sampled[2, 1] > 1.0
    with pytest.raises(InfeasibleError, match="every duration at h_max") as raised:
        TimingProblem(via, "quintic", limits, bounds=(1.0, 1.0))
    error = raised.value
    assert (error.joint, error.joint_index, error.quantity) == ("joint1", 0, "velocity")
    assert error.value == pytest.approx(sampled[0, 0] * 1.5, rel=1e-6) and error.limit == 1.5


def test_an_out_of_range_via_point_after_repeats_is_named_by_its_given_index():
    """Via-points 0..2 repeat (merged into one): the one outside the range is given as via-point 3."""
    via = np.array([[0.0], [0.0], [0.0], [4.0]])
    limits = JointLimits.create(1, velocity=[1.0], lower=[-3.0], upper=[3.0])
    with pytest.raises(InfeasibleError, match=r"^via-point 3 puts"):
        TimingProblem(via, "quintic", limits)


def test_a_chain_of_small_steps_keeps_every_given_via_point_within_the_tolerance_of_its_merged_one():
    """Steps of 0.6e-9 rad, each within REPEAT_TOLERANCE of the previous, drift beyond it: every given via-point
    must lie within the tolerance of the via-point it is planned through (brute force over all)."""
    steps = np.array([[0.0], [0.6e-9], [1.2e-9], [1.8e-9], [2.4e-9], [1.0]])
    problem = TimingProblem(steps, "quintic", JointLimits.create(1, velocity=[1.0]))
    merged = problem.via_points[problem.via_index]
    assert np.abs(merged - steps).max() <= REPEAT_TOLERANCE


# ---------------------------------------------------------------- problem.py: the repair

def test_unbounded_repair_raises_short_segments_to_the_minimum_duration_and_stays_feasible():
    """Without bounds, a shape whose time-optimal scaling puts a segment below ``min_duration`` is raised to it
    and stays within every limit (sampled), the other segment not shrunk below it either."""
    problem = TimingProblem(VIA, "hermite7", TIGHT, min_duration=1.5)
    evaluation = problem.evaluate(np.array([[1.0, 0.05], [0.05, 1.0]]))
    assert evaluation.feasible.all()
    assert evaluation.durations.min() >= 1.5 * (1 - 1e-12)
    for h in evaluation.durations:
        assert _sampled_ratios(problem, h).max() <= 1 + 1e-6


def test_bounded_repair_keeps_the_minimum_duration_above_h_min():
    """Bounds (0.01, 10) s and ``min_duration`` 0.5 s with loose limits: the time-optimal scale would shrink the
    candidate far below 0.5 s; the repaired durations sit at the floor, not at h_min."""
    problem = TimingProblem(VIA, "hermite7", LOOSE, bounds=(0.01, 10.0), min_duration=0.5)
    evaluation = problem.evaluate(np.array([[1.0, 1.0], [0.5, 3.0]]))
    assert evaluation.feasible.all()
    assert evaluation.durations.min() == pytest.approx(0.5)


def test_bounded_repair_that_clips_h_max_repeats_until_feasible():
    """A cubic candidate whose time-optimal scaling takes segments past h_max = 2 s: clipped, it breaks a limit
    again, and the repair scales and clips again until feasible; the result is within the bounds and within every
    limit by dense sampling."""
    problem = TimingProblem(np.radians([[0.0, 0.0], [40.0, -20.0], [90.0, 10.0], [20.0, 30.0]]), "cubic", TIGHT,
                            bounds=(0.05, 2.0))
    x = np.array([[1.45490077, 1.89890284, 1.45717208, 1.21532373, 0.59284835]])
    evaluation = problem.evaluate(x)
    assert evaluation.feasible[0]
    h = evaluation.durations[0]
    assert h.max() <= 2.0 * (1 + 1e-9) and h.min() >= 0.05
    assert _sampled_ratios(problem, h).max() <= 1 + 1e-6


def test_time_jerk_repair_with_bounds_stops_the_ray_where_the_longest_segment_reaches_h_max():
    """Loose limits and a heavy jerk weight: along the ray the objective falls up to where the longest segment
    reaches h_max = 2 s; the repair keeps the candidate's shape and is no worse than any scaling of it within the
    bounds (brute force over the ray)."""
    problem = TimingProblem(VIA, "quintic", LOOSE, bounds=(0.01, 2.0), objective="time-jerk", weights=(1.0, 10.0))
    x = np.array([[0.5, 1.0]])
    repaired = problem.evaluate(x)
    assert repaired.feasible[0]
    np.testing.assert_allclose(repaired.durations[0], [1.0, 2.0], rtol=1e-12)
    ray = problem.evaluate_durations(x * np.linspace(0.2, 2.0, 37)[:, None])
    assert repaired.objective[0] <= ray.objective[ray.feasible].min() * (1 + 1e-12)


# ---------------------------------------------------------------- cartesian_path.py

def test_a_segment_error_states_the_position_at_the_fraction_it_names():
    """A UR5 line through a wrist singularity (wrist_2 -20 -> +20 deg) is refused at a fraction near, not at,
    the middle: the position the message states is the point of the straight line at that fraction,
    (1 - u) p_A + u p_B, computed here from the end poses by forward kinematics."""
    ur5 = Robot.from_example_robot_data("ur5", "tool0")
    ends = np.deg2rad([[20, -70, 80, -100, -20, 30], [20, -70, 80, -100, 20, 30]])
    poses = [ur5.forward_kinematics(q) for q in ends]
    task = parse_task({"version": 1, "robot": {"name": "ur5", "tool_frame": "tool0"},
                       "waypoints": {"cartesian": [{"xyz_m": p.translation.tolist(),
                                                    "quat_xyzw": pin.Quaternion(p.rotation).coeffs().tolist(),
                                                    "hint_deg": np.rad2deg(q).tolist()}
                                                   for p, q in zip(poses, ends)]},
                       "limits": {"acceleration_deg_s2": [150] * 6, "jerk_deg_s3": [600] * 6},
                       "path": {"mode": "linear"}})
    with pytest.raises(IKError, match=r"^path segment 0 \(waypoint 0 -> 1\) at fraction") as caught:
        plan(task)
    message = caught.value.args[0]
    u = float(message.split("fraction ")[1].split(",")[0])
    stated = np.array([float(x) for x in message.split("position [")[1].split("]")[0].split(",")])
    assert abs(u - 0.5) > 1e-3  # away from the middle, where u and 1 - u would name the same point
    expected = (1 - u) * poses[0].translation + u * poses[1].translation
    np.testing.assert_allclose(stated, expected, atol=1e-4)


def test_respaced_poses_put_the_tool_at_their_even_fractions_along_the_line():
    """Poses at fractions 0, 1/2, 1 of a PUMA segment respaced to three intervals: each new configuration's tool
    (Pinocchio FK) is at fraction k/3 of the straight segment, computed here independently (linear position,
    scipy's slerp), not at the middle of the old poses it falls between."""
    puma = load_robot(Path(__file__).resolve().parents[1] / "robots" / "puma560.urdf", tool_frame="tool")
    q0, q1, poses, pose_at = puma_segment(puma)
    position, rotation = pose_at(0.5)
    middle = solve_pose(puma, pin.SE3(rotation.as_matrix(), position), (q0 + q1) / 2)
    assert middle.residual <= 1e-9
    fractions, configurations = [0.0, 0.5, 1.0], [q0, middle.q, q1]
    _respace(puma, poses, 0, fractions, configurations, 3)
    np.testing.assert_allclose(fractions, [0.0, 1 / 3, 2 / 3, 1.0], atol=1e-15)
    assert_on_segment(puma, pose_at, fractions, configurations)


def test_ik_from_the_middle_that_lands_on_another_branch_is_not_taken(monkeypatch):
    """Where continuation along the line fails (forced here), a pose between two neighbours is solved by IK
    from their linear interpolation first; that can land on another branch, farther from the interpolation
    than the neighbours are apart, and is then not taken: IK from a neighbour gives the configuration of
    the line's continuous motion (computed by continuation before it was switched off)."""
    import planner.cartesian_path as cp
    from planner.ik import nearest_turn

    ur5 = Robot.from_example_robot_data("ur5", "tool0")
    before = np.deg2rad([43.11, 58.55, 92.0, -67.83, -120.72, -9.38])
    after = np.deg2rad([-13.62, -23.88, 164.14, -46.07, -135.44, -71.87])
    data = ur5.model.createData()
    poses = []
    for q in (before, after):
        pin.framesForwardKinematics(ur5.model, data, q)
        poses.append(data.oMf[ur5.model.getFrameId("tool0")].copy())
    on_line = cp.continued(ur5, poses, 0, before, 0.0, 0.5)
    middle = (before + after) / 2
    from_middle = solve_pose(ur5, cp.interpolate_pose(poses[0], poses[1], 0.5), middle)
    assert from_middle.residual <= 1e-9  # the case: reached, but on another branch
    landed = nearest_turn(ur5, from_middle.q, middle)
    assert np.abs(landed - middle).max() > np.abs(after - before).max() and np.abs(landed - on_line).max() > 1
    monkeypatch.setattr(cp, "continued", lambda *args: None)
    q = cp._pose_between(ur5, poses, 0, 0.0, 1.0, before, after)
    np.testing.assert_allclose(q, on_line, atol=1e-6)


def test_a_round_that_cannot_be_timed_searches_the_three_largest_joint_changes_for_a_jump(monkeypatch):
    """Where a round cannot be timed, the intervals of the three largest joint changes above JUMP_RAD are
    bisected for a jump, largest first (a continuous but large motion can come before the jump); none of
    the smaller ones, and none at all once a change is no larger than JUMP_RAD."""
    import planner.cartesian_path as cp

    checked = []
    monkeypatch.setattr(cp, "_pose_between", lambda robot, poses, segment, low, high, before, after: before)
    monkeypatch.setattr(cp, "_check_continuous", lambda robot, poses, segment, fractions, ends:
                        checked.append((segment, fractions[0])))
    degrees = [[0.0, 30.0, 31.0], [31.0, 40.0, 100.0, 100.5], [100.5, 150.0]]  # changes 30, 1, 9, 60, 0.5, 49.5
    configurations = [[np.deg2rad([d, 0.0]) for d in segment] for segment in degrees]
    fractions = [list(np.linspace(0.0, 1.0, len(segment))) for segment in degrees]
    cp._name_jump(None, [], fractions, configurations)
    assert checked == [(1, 1 / 3), (2, 0.0), (0, 0.0)]  # 60, 49.5, 30 deg; not the 9 deg one
    checked.clear()
    small = [[np.deg2rad([d, 0.0]) for d in (0.0, 0.9, 1.8)]]
    cp._name_jump(None, [], [[0.0, 0.5, 1.0]], small)
    assert checked == []


def test_only_segments_whose_even_spacing_adds_poses_are_respaced():
    """A segment whose even count adds no interval (already as fine, or the segment held at its least
    duration itself) is bisected where it strays, not respaced: respaced, it would keep its poses and skip
    the bisection, and the rounds would stall. Nor is one whose even spacing would come closer than twice
    MIN_FRACTION."""
    from planner.cartesian_path import MIN_FRACTION, _respaced

    counts = np.array([4, 2, 3, 1])
    spaced = {0: 4, 1: 5, 2: 2, 3: int(np.floor(1 / (2 * MIN_FRACTION))) + 1}
    assert _respaced(spaced, counts) == {1}
    assert _respaced({3: int(1 / (2 * MIN_FRACTION))}, counts) == {3}
    assert _respaced({}, counts) == set()
