"""Gaps in the tests of planner/cartesian_path.py found by mutation testing (mutmut 3.8.1, run of 2026-12-07 over
the functions an earlier run left unchecked: segment_deviation, tool_deviation, interpolate_pose, _insert)."""

from pathlib import Path

import numpy as np
import pytest

import planner.cartesian_path as cp
from conftest import assert_on_segment, puma_segment
from planner import IKError
from planner.robot import load_robot

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def puma():
    return load_robot(ROOT / "robots" / "puma560.urdf", tool_frame="tool")


@pytest.mark.parametrize("low", [0.0, 0.5])
def test_poses_closer_than_twice_min_fraction_are_refused_wherever_they_sit_on_the_segment(puma, low):
    """``_insert`` gives up on two poses of a segment less than 2 ``MIN_FRACTION`` apart, at its start or halfway
    along it, naming the fraction between them, and changes nothing; poses that far apart or farther get the
    pose halfway between them, on the line (independent slerp), and the others are kept."""
    q0, q1, poses, pose_at = puma_segment(puma)

    def interval(width):
        ends = [low, low + width]
        return ends, [cp.continued(puma, poses, 0, q0, 0.0, u) if u > 0 else q0 for u in ends]

    fractions, configurations = interval(1.5 * cp.MIN_FRACTION)
    before = [np.array(q) for q in configurations]
    with pytest.raises(IKError, match=rf"^path segment 0 \(waypoint 0 -> 1\) at fraction {low + 0.00075:.4g}, "
                                      r".*however close the poses; the joints barely move there") as raised:
        cp._insert(puma, poses, 0, 0, fractions, configurations, 0.01, 0.0)
    assert raised.value.waypoint == 0
    assert fractions == [low, low + 1.5 * cp.MIN_FRACTION] and len(configurations) == 2
    for q, kept in zip(configurations, before):
        np.testing.assert_array_equal(q, kept)
    for width in (2 * cp.MIN_FRACTION, 2.5 * cp.MIN_FRACTION):
        fractions, configurations = interval(width)
        ends = list(configurations)
        cp._insert(puma, poses, 0, 0, fractions, configurations, 0.01, 0.0)
        np.testing.assert_allclose(fractions, [low, low + width / 2, low + width], rtol=0, atol=1e-15)
        assert configurations[0] is ends[0] and configurations[2] is ends[1]
        assert_on_segment(puma, pose_at, fractions, configurations)


def test_a_refusal_of_close_poses_says_how_far_the_tool_strays_and_why(puma):
    """``_insert``'s refusal reports the interval's deviation it is given, in mm and deg to 3 digits (12.449 mm
    reads 12.4), and why no closer pose helps (``_why_not_followed``): the least duration that holds the segments
    and its key, where one does; the joint that jumps between the two poses, named by the robot, where it does."""
    q0, _, poses, _ = puma_segment(puma)
    fractions = [0.5, 0.5 + cp.MIN_FRACTION]
    near = q0 + np.deg2rad([0.0, 0.0, 0.2, 0.0, 0.0, 0.0])
    with pytest.raises(IKError, match=r"the tool strays 12\.4 mm and 3 deg from the straight line however close the "
                                      r"poses; the joints barely move there \(at most 0\.2 deg between the two closest "
                                      r"poses\), and the timing holds the segments there at their least duration, "
                                      r"0\.0125 s \(trajectory\.min_segment_s\): "):
        cp._insert(puma, poses, 0, 0, list(fractions), [q0, near], 0.012449, np.deg2rad(3.0),
                   (0.0125, "trajectory.min_segment_s"))
    jumped = q0 + np.deg2rad([0.0, 0.0, 3.0, 0.0, 0.0, 0.0])
    with pytest.raises(IKError, match=r"however close the poses; the joint motion jumps there \(joint 'joint3' by "
                                      r"3 deg between the two closest poses"):
        cp._insert(puma, poses, 0, 0, list(fractions), [q0, jumped], 0.012449, np.deg2rad(3.0))
