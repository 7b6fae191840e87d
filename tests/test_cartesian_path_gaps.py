"""Tests for behaviour of planner.cartesian_path that no existing test checks.

Found by mutation testing ()."""
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from planner import IKError

ROOT = Path(__file__).resolve().parents[1]
PUMA = ROOT / "robots" / "puma560.urdf"


@pytest.fixture(scope="module")
def puma():
    from planner.robot import load_robot
    return load_robot(PUMA, tool_frame="tool")


def paper_timing(via: np.ndarray):
    """The via-points timed as a plan times them: hybrid, the paper's limits, the default optimizer."""
    from planner import paper
    from planner.timing import TimingProblem, optimize
    problem = TimingProblem(via, "hybrid", paper.paper_limits())
    result = optimize(problem, "default")
    return problem.trajectory(result.durations), None


def turn_in_place(puma):
    """As in test_cartesian_path: a start, the same position turned 50 deg about the tool's x axis, an arm move."""
    from planner.ik import solve_pose
    q0 = np.deg2rad([10.0, -60.0, 150.0, 0.0, -30.0, 10.0])
    a = puma.forward_kinematics(q0)
    b = pin.SE3(a.rotation @ pin.exp3(np.deg2rad(50.0) * np.array([1.0, 0.0, 0.0])), a.translation)
    turned = solve_pose(puma, b, q0)
    assert turned.residual <= 1e-9
    q2 = turned.q + np.deg2rad([15.0, 10.0, -10.0, 0.0, 0.0, 0.0])
    return [a, b, puma.forward_kinematics(q2)], np.array([q0, turned.q, q2])


def test_giving_up_on_a_segment_says_how_far_the_tool_strays(puma, monkeypatch):
    """The give-up message reports the deviation of the interval it gives up on, in mm and deg: here a
    deviation of 0.25 m forced onto the first interval of segment 1 reads '250 mm'."""
    import planner.cartesian_path as cartesian_path
    poses, q = turn_in_place(puma)
    real = cartesian_path.tool_deviation
    seen = {}

    def off_at_the_start_of_segment_1(robot, trajectory, poses, waypoint_via):
        distance, angle, per_distance, per_angle = real(robot, trajectory, poses, waypoint_via)
        distance[waypoint_via[1]] = 0.25
        seen["angle"] = angle[waypoint_via[1]]
        return distance, angle, per_distance, per_angle
    monkeypatch.setattr(cartesian_path, "tool_deviation", off_at_the_start_of_segment_1)
    with pytest.raises(IKError, match=r"however close") as raised:
        cartesian_path.follow_straight_lines(puma, poses, q, paper_timing, tolerance_m=0.01, tolerance_rad=1.0)
    found = re.search(r"the tool strays ([\d.e+-]+) mm and ([\d.e+-]+) deg from the straight line", str(raised.value))
    assert found, str(raised.value)
    assert float(found[1]) == pytest.approx(250.0, rel=1e-3)
    assert float(found[2]) == pytest.approx(np.rad2deg(seen["angle"]), rel=1e-2, abs=1e-3)


def test_inserted_poses_lie_strictly_inside_their_segments(puma):
    """Poses are inserted halfway between neighbours on the segment (fractions in (0, 1)): no inserted
    via-point repeats a waypoint's configuration, and each one's tool lies on its segment strictly
    between the ends (its angle to both end poses is positive and below the segment's 50 deg turn)."""
    from planner.cartesian_path import follow_straight_lines, segment_deviation
    poses, q = turn_in_place(puma)
    path, _ = follow_straight_lines(puma, poses, q, paper_timing, tolerance_m=10.0, tolerance_rad=np.deg2rad(2.0))
    assert path.inserted[0] > 0
    assert np.all(np.linalg.norm(np.diff(path.via_points, axis=0), axis=1) > 1e-6)  # no via-point repeated
    first, last = path.waypoint_via[0], path.waypoint_via[1]
    turn = np.linalg.norm(pin.log3(poses[0].rotation.T @ poses[1].rotation))
    for v in path.via_points[first + 1:last]:
        frame = puma.forward_kinematics(v)
        distance, angle = segment_deviation(poses[0], poses[1], frame.translation[None], frame.rotation[None])
        assert distance[0] <= 1e-8 and angle[0] <= 1e-8
        from_a = np.linalg.norm(pin.log3(poses[0].rotation.T @ frame.rotation))
        from_b = np.linalg.norm(pin.log3(poses[1].rotation.T @ frame.rotation))
        assert 1e-6 < from_a < turn - 1e-6 and 1e-6 < from_b < turn - 1e-6


def test_rounds_and_the_via_point_cap_are_exact(puma, monkeypatch):
    """``rounds`` is the number of timing rounds made (one ``time_via_points`` call each; summary.json
    reports it), and the cap MAX_VIA_POINTS is exact: a path that ends with exactly N via-points is accepted
    under a cap of N (no round ever times more), and refused under a cap of N - 1 without timing more than
    N - 1 via-points."""
    import planner.cartesian_path as cartesian_path
    from planner import TaskError
    poses, q = turn_in_place(puma)
    counts = []

    def timing(via):
        counts.append(len(via))
        return paper_timing(via)
    path, _ = cartesian_path.follow_straight_lines(puma, poses, q, timing, tolerance_m=10.0,
                                                   tolerance_rad=np.deg2rad(2.0))
    assert path.rounds == len(counts) and path.rounds > 1
    n = len(path.via_points)
    assert counts[-1] == n
    counts.clear()
    monkeypatch.setattr(cartesian_path, "MAX_VIA_POINTS", n)
    exact, _ = cartesian_path.follow_straight_lines(puma, poses, q, timing, tolerance_m=10.0,
                                                    tolerance_rad=np.deg2rad(2.0))
    assert len(exact.via_points) == n and max(counts) == n
    counts.clear()
    monkeypatch.setattr(cartesian_path, "MAX_VIA_POINTS", n - 1)
    with pytest.raises(TaskError, match=rf"needs more than {n - 1} via-points"):
        cartesian_path.follow_straight_lines(puma, poses, q, timing, tolerance_m=10.0, tolerance_rad=np.deg2rad(2.0))
    assert max(counts) <= n - 1


def dense_deviation(a, b, positions, rotations, count=2001):
    """Independent (as in test_cartesian_path): distance and angle to the straight segment by a dense grid."""
    from scipy.spatial.transform import Rotation, Slerp
    u = np.linspace(0.0, 1.0, count)
    line = (1 - u)[:, None] * a.translation + u[:, None] * b.translation
    arc = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([a.rotation, b.rotation])))(u)
    distance = np.array([np.linalg.norm(line - p, axis=1).min() for p in positions])
    angle = np.array([(arc.inv() * Rotation.from_matrix(r)).magnitude().min() for r in rotations])
    return distance, angle


def test_each_round_splits_exactly_the_intervals_that_stray(puma):
    """Each round inserts one pose in every via-point interval whose tool strays beyond MARGIN of the
    tolerance, and in no other. Checked round by round with an independent dense deviation (FK at 60
    times per interval, a 2001-point slerp grid); intervals within 20 % of the threshold are not judged."""
    from planner.cartesian_path import MARGIN, follow_straight_lines
    poses, q = turn_in_place(puma)
    tolerance = np.deg2rad(0.5)
    rounds = []

    def timing(via):
        trajectory, extra = paper_timing(via)
        rounds.append((np.array(via), trajectory))
        return trajectory, extra
    follow_straight_lines(puma, poses, q, timing, tolerance_m=10.0, tolerance_rad=tolerance)
    assert len(rounds) >= 3
    judged = 0
    for (via, trajectory), (following, _) in zip(rounds, rounds[1:]):
        # which old intervals received a pose: walk the new list, matching the old via-points in order
        split, j = [], 0
        for k in range(len(via) - 1):
            assert np.allclose(following[j], via[k])
            j += 1
            inserted = 0
            while not np.allclose(following[j], via[k + 1]):
                inserted, j = inserted + 1, j + 1
            split.append(inserted)
        waypoint_via = [int(np.flatnonzero(np.all(np.isclose(via, qi), axis=1))[0]) for qi in q]
        times = trajectory.via_times
        for k in range(len(via) - 1):
            segment = int(np.searchsorted(waypoint_via, k, side="right") - 1)
            frames = [puma.forward_kinematics(x) for x in trajectory.evaluate(np.linspace(times[k], times[k + 1], 60))]
            _, angle = dense_deviation(poses[segment], poses[segment + 1], np.array([f.translation for f in frames]),
                                       np.array([f.rotation for f in frames]))
            if angle.max() > 1.2 * MARGIN * tolerance:
                assert split[k] == 1, (len(via), k, np.rad2deg(angle.max()))
                judged += 1
            elif angle.max() < 0.8 * MARGIN * tolerance:
                assert split[k] == 0, (len(via), k, np.rad2deg(angle.max()))
    assert judged >= 3


@pytest.mark.parametrize("tolerance_m, tolerance_deg", [(10.0, 0.5), (0.002, 30.0)])
def test_running_out_of_rounds_names_the_interval_straying_most_relative_to_its_tolerances(
        puma, monkeypatch, tolerance_m, tolerance_deg):
    """After MAX_ROUNDS the error names the interval whose deviation is largest relative to the tolerances
    (max of distance / tolerance_m and angle / tolerance_rad): its segment ("path segment i (waypoint i ->
    i + 1)") and its deviation in mm and deg. Checked against an independent dense deviation of the last
    round's trajectory, once with the angle and once with the distance deciding."""
    import planner.cartesian_path as cartesian_path
    monkeypatch.setattr(cartesian_path, "MAX_ROUNDS", 2)
    poses, q = turn_in_place(puma)
    tolerance_rad = np.deg2rad(tolerance_deg)
    rounds = []

    def timing(via):
        trajectory, extra = paper_timing(via)
        rounds.append((np.array(via), trajectory))
        return trajectory, extra
    with pytest.raises(IKError) as raised:
        cartesian_path.follow_straight_lines(puma, poses, q, timing, tolerance_m=tolerance_m,
                                             tolerance_rad=tolerance_rad)
    found = re.search(r"^path segment (\d+) \(waypoint (\d+) -> (\d+)\): the tool still strays ([\d.e+-]+) mm and "
                      r"([\d.e+-]+) deg from the straight line after 2 rounds$", str(raised.value))
    assert found, str(raised.value)
    segment, first, second = int(found[1]), int(found[2]), int(found[3])
    assert first == segment and second == segment + 1 and raised.value.waypoint == segment
    via, trajectory = rounds[-1]
    waypoint_via = [int(np.flatnonzero(np.all(np.isclose(via, qi), axis=1))[0]) for qi in q]
    times = trajectory.via_times
    ratios, deviations, segments = [], [], []
    for k in range(len(via) - 1):
        i = int(np.searchsorted(waypoint_via, k, side="right") - 1)
        frames = [puma.forward_kinematics(x) for x in trajectory.evaluate(np.linspace(times[k], times[k + 1], 80))]
        distance, angle = dense_deviation(poses[i], poses[i + 1], np.array([f.translation for f in frames]),
                                          np.array([f.rotation for f in frames]))
        deviations.append((distance.max(), angle.max()))
        ratios.append(max(distance.max() / tolerance_m, angle.max() / tolerance_rad))
        segments.append(i)
    worst = int(np.argmax(ratios))
    others = [r for r, s in zip(ratios, segments) if s != segments[worst]]
    assert not others or max(others) < 0.9 * ratios[worst]  # the case is clear-cut
    assert segment == segments[worst]
    assert float(found[4]) == pytest.approx(1e3 * deviations[worst][0], rel=0.05, abs=1e-3)
    assert float(found[5]) == pytest.approx(np.rad2deg(deviations[worst][1]), rel=0.05, abs=1e-3)
