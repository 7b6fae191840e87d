"""The lower bound on any trajectory's total time (planner.timing.lower_bound): the known optima of
single moves, and never above a trajectory the planner found feasible."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from planner import JointLimits
from planner.timing import TimingProblem, optimize
from planner.timing.lower_bound import time_lower_bound


@pytest.mark.parametrize("distance, expected", [
    (0.5, 2 * np.sqrt(0.5 / 2.0)),          # triangle: the velocity limit is never reached
    (3.0, 3.0 / 1.5 + 1.5 / 2.0),           # trapezoid: cruise at 1.5 rad/s
])
def test_one_move_without_a_jerk_limit_is_the_bang_bang_optimum(distance, expected):
    """From rest to rest under V and A alone, the fastest move is bang-bang in acceleration."""
    limits = JointLimits.create(1, velocity=[1.5], acceleration=[2.0])
    assert time_lower_bound(np.array([[0.0], [distance]]), limits) == pytest.approx(expected, rel=1e-12)


def test_one_move_under_a_jerk_limit_alone_is_the_bang_bang_optimum():
    """Jerk +J, -J, -J, +J in four equal phases covers J T^3 / 32: T = (32 D / J)^(1/3)."""
    limits = JointLimits.create(1, jerk=[7.0])
    assert time_lower_bound(np.array([[1.0], [1.0 + 2.5]]), limits) == pytest.approx((32 * 2.5 / 7.0) ** (1 / 3))


def test_a_turn_stops_the_joint_so_each_side_is_a_move_of_its_own():
    """0 -> 1 -> 0 under V and A: the joint stops at (or beyond) 1, so at least two stop-to-stop moves."""
    limits = JointLimits.create(1, velocity=[10.0], acceleration=[1.0])
    bound = time_lower_bound(np.array([[0.0], [1.0], [0.0]]), limits)
    assert bound == pytest.approx(2 * 2 * np.sqrt(1.0), rel=1e-12)
    # Monotone through the middle via-point: no stop is forced there, one move of 2 rad.
    assert time_lower_bound(np.array([[0.0], [1.0], [2.0]]), limits) == pytest.approx(2 * np.sqrt(2.0), rel=1e-12)


def test_repeats_reversal_and_absent_limits():
    rng = np.random.default_rng(4)
    via = np.cumsum(rng.normal(size=(9, 3)), axis=0)
    limits = JointLimits.create(3, velocity=[1.0, 2.0, np.inf], acceleration=[np.inf, 3.0, 4.0], jerk=[5, np.inf, 9])
    bound = time_lower_bound(via, limits)
    assert bound > 0
    assert time_lower_bound(via[::-1], limits) == pytest.approx(bound, rel=1e-12)  # time runs either way
    assert time_lower_bound(np.repeat(via, 2, axis=0), limits) == pytest.approx(bound, rel=1e-12)
    assert time_lower_bound(via[:1], limits) == 0.0


def test_the_paper_case_bound(paper_via, paper_limits):
    """13.6185 s, below hermite7's independent optimum 16.4723 s (the best jerk-continuous trajectory
    known: the bound is 17 % below it) and the hybrid's 17.3128 s."""
    assert time_lower_bound(paper_via, paper_limits) == pytest.approx(13.6185, abs=1e-4)


limit_values = st.one_of(st.just(np.inf), st.floats(0.3, 30.0))


@given(arrays(float, st.tuples(st.integers(2, 8), st.integers(1, 3)), elements=st.floats(-3, 3)),
       st.lists(st.tuples(limit_values, limit_values, limit_values), min_size=3, max_size=3),
       st.sampled_from(["cubic", "hybrid", "quintic"]))
@settings(max_examples=40)
def test_no_feasible_trajectory_is_faster_than_the_bound(via, drawn, family):
    """Every feasible trajectory the planner finds, of every family, takes at least the bound."""
    joints = via.shape[1]
    velocity, acceleration, jerk = (np.array([drawn[j][k] for j in range(joints)]) for k in range(3))
    if np.ptp(via, axis=0).max() < 1e-3:  # a motion to time
        via[-1, 0] += 1.0
    velocity[np.argmax(np.ptp(via, axis=0))] = 1.0  # a limit on the largest motion: the time is bounded below
    limits = JointLimits.create(joints, velocity=velocity, acceleration=acceleration, jerk=jerk)
    result = optimize(TimingProblem(via, family, limits), "nlp")
    if result.feasible:
        assert time_lower_bound(via, limits) <= result.total_time * (1 + 1e-9)


def test_no_hermite7_trajectory_is_faster_than_the_bound():
    """hermite7 chooses every via-point's velocity, acceleration and jerk: the closest of the families to
    the unrestricted optimum, on random walks too."""
    rng = np.random.default_rng(11)
    via = np.cumsum(rng.uniform(-1, 1, (6, 2)), axis=0)
    limits = JointLimits.create(2, velocity=[1.0, 0.7], acceleration=[2.0, 1.0], jerk=[8.0, 5.0])
    result = optimize(TimingProblem(via, "hermite7", limits), "nlp")
    assert result.feasible and time_lower_bound(via, limits) <= result.total_time


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_via_points_that_are_not_numbers_are_refused_not_bounded_by_nan(bad):
    from planner import InputError

    with pytest.raises(InputError, match=rf"via_points\[0, 1\] is {bad}, not a finite number"):
        time_lower_bound(np.array([[0.0, bad], [1.0, 1.0]]), JointLimits.create(2, velocity=[1, 1]))
    with pytest.raises(InputError, match="limits must be a JointLimits for the via-points' 2 joints"):
        time_lower_bound(np.zeros((3, 2)), JointLimits.create(3, velocity=[1, 1, 1]))
