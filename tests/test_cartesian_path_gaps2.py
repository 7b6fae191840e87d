"""Gaps in the tests of planner/cartesian_path.py found by mutation testing (mutmut 3.8.1, run of 2026-12-07)."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planner.cartesian_path as cp
from conftest import assert_on_segment, puma_segment
from planner import IKError
from planner.robot import load_robot

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def puma():
    return load_robot(ROOT / "robots" / "puma560.urdf", tool_frame="tool")


def test_respacing_keeps_the_configurations_of_the_poses_already_there_exactly(puma):
    """Respacing a segment's poses keeps a pose that is already at one of the new fractions as it is: both ends
    (the waypoints' configurations, which the neighbouring segments share) and an interior pose, bit for bit,
    not solved again by IK (which lands within its tolerance, not on the same numbers)."""
    q0, q1, poses, pose_at = puma_segment(puma)
    middle = cp._pose_between(puma, poses, 0, 0.0, 1.0, q0, q1)
    fractions, configurations = [0.0, 0.5, 1.0], [q0, middle, q1]
    cp._respace(puma, poses, 0, fractions, configurations, 4)
    np.testing.assert_allclose(fractions, [0.0, 0.25, 0.5, 0.75, 1.0], atol=1e-15)
    assert len(configurations) == 5
    for kept, q in ((0, q0), (2, middle), (4, q1)):
        np.testing.assert_array_equal(configurations[kept], q)
    assert_on_segment(puma, pose_at, fractions, configurations)


def test_respacing_where_continuation_fails_solves_each_pose_between_its_old_neighbours(puma, monkeypatch):
    """Where IK continuation along the line fails (forced here), ``_respace`` still puts every new pose on the
    line at its even fraction, from IK seeded between the old poses it falls between (the fallback of
    ``_pose_between``), and keeps both ends."""
    q0, q1, poses, pose_at = puma_segment(puma)
    on_line = [cp.continued(puma, poses, 0, q0, 0.0, u) for u in (1 / 3, 2 / 3)]  # before it is switched off
    monkeypatch.setattr(cp, "continued", lambda *args: None)
    fractions, configurations = [0.0, 1.0], [q0, q1]
    cp._respace(puma, poses, 0, fractions, configurations, 3)
    np.testing.assert_allclose(fractions, [0.0, 1 / 3, 2 / 3, 1.0], atol=1e-15)
    np.testing.assert_array_equal(configurations[0], q0)
    np.testing.assert_array_equal(configurations[-1], q1)
    assert_on_segment(puma, pose_at, fractions, configurations)
    # the branch the line's continuous motion is on
    np.testing.assert_allclose(configurations[1:3], on_line, atol=1e-6)


class _Joints:
    """Stand-in robot for ``_check_continuous``'s messages: two named joints."""

    joint_names = ["steep", "slow"]


def _bisect_along(monkeypatch, motion):
    """``_pose_between`` replaced by the joint motion ``motion(u)`` along the segment (what IK would give)."""
    monkeypatch.setattr(cp, "_pose_between",
                        lambda robot, poses, segment, low, high, before, after: motion((low + high) / 2))


def _check(motion):
    """``_check_continuous`` on path segment 1 (waypoint 1 -> 2), from (1, 0, 0) to (1, 2, 0) m."""
    poses = [pin.SE3(np.eye(3), np.array(p)) for p in ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0])]
    cp._check_continuous(_Joints(), poses, 1, (0.0, 0.5, 1.0), (motion(0.0), motion(0.5), motion(1.0)))


@settings(max_examples=20)
@given(st.floats(0.1, 0.9), st.floats(0.005, 0.05), st.floats(-2.0, 2.0))
def test_a_steep_but_continuous_joint_motion_is_not_refused_as_a_jump(centre, width, offset):
    """A joint that turns by nearly pi within a short stretch of the segment (atan((u - centre) / width)), offset
    by any angle: bisected, its change eventually splits between the halves (a continuous motion's does), well
    before the interval shrinks to MIN_FRACTION, so it is no jump. The other joint moves slowly throughout."""
    def motion(u):
        return np.array([offset + np.arctan((u - centre) / width), 0.01 * u])

    with pytest.MonkeyPatch.context() as monkeypatch:  # not the fixture: one patch per example
        _bisect_along(monkeypatch, motion)
        _check(motion)  # returns: no IKError


@given(st.floats(0.1, 0.9), st.floats(np.deg2rad(3.0), 3.0), st.floats(-2.0, 2.0))
def test_a_joint_that_jumps_is_refused_naming_it_and_where(at, jump, offset):
    """A step of ``jump`` rad (3 deg to 3 rad) in joint "steep" at fraction ``at`` (another branch), from any
    offset: bisected down to MIN_FRACTION the step keeps the whole change, and the refusal names the segment
    (its ``waypoint`` too), the fraction (within MIN_FRACTION) and the position there, the joint and the change."""
    def motion(u):
        return np.array([offset + (jump if u >= at else 0.0), 0.01 * u])

    with pytest.MonkeyPatch.context() as monkeypatch:
        _bisect_along(monkeypatch, motion)
        with pytest.raises(IKError, match=r"^path segment 1 \(waypoint 1 -> 2\) at fraction .*no joint motion "
                                          r"follows the straight line there: the joint motion jumps there \(joint "
                                          r"'steep' by ") as raised:
            _check(motion)
    assert raised.value.waypoint == 1
    message = raised.value.args[0]
    u = float(message.split("fraction ")[1].split(",")[0])
    assert abs(u - at) <= cp.MIN_FRACTION
    position = [float(x) for x in message.split("position [")[1].split("]")[0].split(",")]
    np.testing.assert_allclose(position, [1.0, 2 * u, 0.0], atol=1e-4)
    said = float(message.split("'steep' by ")[1].split(" deg")[0])
    assert said == pytest.approx(np.rad2deg(jump), rel=5e-3)  # 3 digits


def test_why_poses_come_no_closer_names_the_least_duration_that_holds_the_segments():
    """Two closest poses whose joints barely move (0.5 deg), where the timing holds the segments at their least
    duration: the reason names that duration and the task key setting it; without it, the tolerance."""
    before = np.array([0.3, -0.2])
    after = before + np.deg2rad([0.1, -0.5])
    held = cp._why_not_followed(_Joints(), before, after, (0.0125, "trajectory.min_segment_s"))
    assert held.startswith("the joints barely move there (at most 0.5 deg between the two closest poses), and the "
                           "timing holds the segments there at their least duration, 0.0125 s "
                           "(trajectory.min_segment_s): ")
    assert held.endswith("; lower that least duration")
    free = cp._why_not_followed(_Joints(), before, after)
    assert free.startswith("the joints barely move there (at most 0.5 deg between the two closest poses): the "
                           "tolerance is finer than the timed motion keeps")


def test_turns_of_the_first_configuration_are_tried_only_where_the_first_waypoint_has_no_hint(monkeypatch):
    """``track_from_turns``: where the lines cannot be followed from the first configuration, its 2 pi turn
    variants are tried, whatever hints later waypoints have; a hinted first waypoint is never replaced by one.
    Stand-ins: the lines can be followed from one turn only, and the variants are the configuration and it."""
    from types import SimpleNamespace

    first = np.array([0.5, 1.0])
    turned = first + np.array([0.0, -2 * np.pi])
    tried = []

    def track(robot, poses, q, kept):
        tried.append(np.array(q))
        return np.array([q, q]) if np.allclose(q, turned) else None

    monkeypatch.setattr(cp, "track_straight_lines", track)
    monkeypatch.setattr(cp, "turn_variants", lambda robot, q, limits: np.array([first, turned]))
    robot = SimpleNamespace(limits=None)
    reached = cp.track_from_turns(robot, [], first, [None, np.array([0.1, 0.2])])
    assert reached is not None
    np.testing.assert_array_equal(reached[0], turned)
    np.testing.assert_array_equal(tried, [first, turned])
    tried.clear()
    assert cp.track_from_turns(robot, [], first, [first, None]) is None
    np.testing.assert_array_equal(tried, [first])
