"""Gaps in the tests of planner/timing/lower_bound.py found by mutation testing (mutmut)."""

import numpy as np
import pytest

from planner import JointLimits
from planner.timing.lower_bound import time_lower_bound


def test_a_via_point_passed_at_speed_gives_the_bang_bang_time_not_more():
    """One joint from rest at 0 through 0.5 to rest at 1, V = 0.9, A = 0.25, no jerk limit: the fastest motion is
    bang-bang acceleration (V^2 / A = 3.24 > 1: its peak speed 0.5 stays below V), 2 sqrt(D / A) = 4 s,
    passing 0.5 at speed after 2 s. The bound through the via-point, half(0.5) twice with half(D) = sqrt(2 D / A)
    for D <= V^2 / (2 A), is that same 4 s; a bound above it would be no lower bound."""
    limits = JointLimits.create(1, velocity=[0.9], acceleration=[0.25])
    assert time_lower_bound(np.array([[0.0], [0.5], [1.0]]), limits) == pytest.approx(4.0, rel=1e-12)


def test_a_joint_that_does_not_move_adds_nothing_without_velocity_and_acceleration_limits():
    """Jerk limits only; joint 1 stays put. The bound is joint 0's rest-to-rest jerk time (32 D / Jk)^(1/3)
    (0.684 s), whatever the still joint (0 / inf terms are 0 s, not NaN or more)."""
    limits = JointLimits.create(2, jerk=[10.0, 10.0])
    bound = time_lower_bound(np.array([[0.0, 0.3], [0.1, 0.3]]), limits)
    assert bound == pytest.approx(np.cbrt(32 * 0.1 / 10.0), rel=1e-12)
    # through a via-point passed at speed (no velocity or acceleration limit: that chain costs 0 s)
    bound = time_lower_bound(np.array([[0.0, 0.3], [0.1, 0.3], [0.2, 0.3]]), limits)
    assert bound == pytest.approx(np.cbrt(32 * 0.2 / 10.0), rel=1e-12)


def test_joints_that_move_one_after_the_other_add_their_times_through_the_via_point():
    """V = A = 1, no jerk limit. Joint 0 moves 0 -> 4 before via-point 1, joint 1 moves 0 -> 4 after it: each
    move ends (or starts) at a passing speed of at most V at via-point 1, so it takes at least
    D / V + V / (2 A) = 4.5 s (D = 4 > V^2 / (2 A)), and the two moves add up to 9 s, more than either
    joint's rest-to-rest time D / V + V / A = 5 s."""
    limits = JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[1.0, 1.0])
    bound = time_lower_bound(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]]), limits)
    assert bound == pytest.approx(9.0, rel=1e-12)


def test_after_a_turn_the_joint_moves_from_a_stop_not_from_rest():
    """Jerk limit Jk = 1 only; one joint 0 -> 1 -> 0. It stops where it turns, so each piece runs between rest
    and a stop (q'' free at the stop): ((12 + 6 sqrt 2) D / Jk)^(1/3) each, twice in all; the second piece is
    not a rest-to-rest move ((32 D / Jk)^(1/3)), which would claim more than the module proves."""
    limits = JointLimits.create(1, jerk=[1.0])
    bound = time_lower_bound(np.array([[0.0], [1.0], [0.0]]), limits)
    assert bound == pytest.approx(2 * np.cbrt(12.0 + 6.0 * np.sqrt(2.0)), rel=1e-12)

