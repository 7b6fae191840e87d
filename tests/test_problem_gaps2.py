"""Gaps in the tests of planner/timing/problem.py found by mutation testing (mutmut 3.8.1, run of 2026-12-07)."""

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from planner import JointLimits
from planner.errors import InputError
from planner.timing import TimingProblem

VIA = np.radians([[0.0, 0.0], [40.0, -20.0], [90.0, 10.0]])
LIMITS = JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0], jerk=[10.0, 10.0])
LOOSE = JointLimits.create(2, velocity=[50.0, 50.0], acceleration=[500.0, 500.0], jerk=[5000.0, 5000.0])


def test_evaluate_states_names_its_durations_and_asks_for_the_states():
    """``evaluate_states`` refuses bad durations naming them, and no states with what it needs (a family with
    free states: hermite7)."""
    problem = TimingProblem(VIA, "hermite7", LIMITS)
    states = np.zeros((1, *problem.via_points.shape, 3))
    with pytest.raises(InputError, match=r"^durations\[0, 1\] is -1\.0 s; durations must be > 0$"):
        problem.evaluate_states(np.array([[1.0, -1.0]]), states)
    with pytest.raises(InputError, match="^" + re.escape("evaluate_states needs the via-point states (B, n, J, 3); "
                                                         "evaluate repairs durations alone") + "$"):
        problem.evaluate_states(np.array([[1.0, 1.0]]), None)


def test_bounds_too_short_between_two_via_points_say_how_many_segments_there_last_how_long():
    """Joint 0 must move 2 rad at most 1 rad/s between via-points 0 and 1, at most 0.5 s a segment: quintic puts
    one segment between them ("the 1 segment between them lasts"), cubic two where a via-point follows (its
    knots 0, 2, 4: "the 2 segments between them last")."""
    from planner import InfeasibleError
    limits = JointLimits.create(2, velocity=[1.0, 1.0])
    with pytest.raises(InfeasibleError, match=r"from via-point 0 to via-point 1 within its velocity, acceleration "
                                              r"and jerk limits, and the 1 segment between them lasts at most 0\.5 s$"):
        TimingProblem([[0.0, 0.0], [2.0, 0.1]], "quintic", limits, bounds=(0.1, 0.5))
    with pytest.raises(InfeasibleError, match=r"from via-point 0 to via-point 1 within its velocity, acceleration "
                                              r"and jerk limits, and the 2 segments between them last at most 1 s$"):
        TimingProblem([[0.0, 0.0], [2.0, 0.1], [2.1, 0.2]], "cubic", limits, bounds=(0.1, 0.5))


def test_bounds_that_are_not_finite_numbers_are_named():
    limits = JointLimits.create(2, velocity=[1.0, 1.0])
    with pytest.raises(InputError, match=r"^bounds\[0\] is nan, not a finite number$"):
        TimingProblem(VIA, "cubic", limits, bounds=(np.nan, 1.0))
    with pytest.raises(InputError, match=r"^bounds\[1\] is inf, not a finite number$"):
        TimingProblem(VIA, "cubic", limits, bounds=(0.1, np.inf))


def test_via_points_all_the_same_are_refused_saying_there_is_no_motion():
    limits = JointLimits.create(2, velocity=[1.0, 1.0])
    same = [[0.3, -0.2], [0.3, -0.2 + 4e-10], [0.3 + 8e-10, -0.2]]  # each within 1e-9 rad of the first
    with pytest.raises(InputError, match=r"^all 3 via-points are the same joint position \(within 1e-09 rad\): "
                                         r"there is no motion to time$"):
        TimingProblem(same, "quintic", limits)


@settings(max_examples=15)
@given(hnp.arrays(float, (3, 2), elements=st.floats(0.5, 2.0)))  # shapes within 1:4: no limit reached
def test_time_jerk_repair_with_bounds_takes_each_candidate_to_its_best_scaling_within_h_max(x):
    """Loose limits and a heavy jerk weight: along each candidate's ray the objective K_t s T + K_j E / s^5 falls up
    to where its longest segment reaches h_max = 2 s. Each row of a batch is repaired to that scaling of its own
    shape, whatever the other rows' (brute force over the ray, durations evaluated exactly as given)."""
    problem = TimingProblem(VIA, "quintic", LOOSE, bounds=(0.01, 2.0), objective="time-jerk", weights=(1.0, 10.0))
    repaired = problem.evaluate(x)
    assert repaired.feasible.all()
    np.testing.assert_allclose(repaired.durations, x * (2.0 / x.max(axis=1))[:, None], rtol=1e-12)
    scales = np.linspace(0.2, 1.0, 17)  # up to the longest segment on h_max
    rays = (x * (2.0 / x.max(axis=1))[:, None])[:, None, :] * scales[None, :, None]  # (3, 17, 2)
    ray = problem.evaluate_durations(rays.reshape(-1, 2))
    objective = np.where(ray.feasible, ray.objective, np.inf).reshape(3, -1)
    assert np.all(repaired.objective <= objective.min(axis=1) * (1 + 1e-12))


def test_durations_above_h_max_are_not_feasible_even_within_every_limit():
    problem = TimingProblem(VIA, "quintic", LOOSE, bounds=(0.1, 1.0))
    evaluation = problem.evaluate_durations(np.array([[0.5, 1.5], [0.5, 1.0]]))
    assert evaluation.ratios.max() < 1.0
    np.testing.assert_array_equal(evaluation.feasible, [False, True])


def test_a_trajectory_beyond_a_position_range_is_penalised_by_how_far():
    """A cubic through 0, 1, 0 rad with unequal durations overshoots the upper range bound of 1 rad: the position
    excess is the overshoot (dense sampling), and the objective is the time plus a penalty growing with it, never
    less than the time."""
    limits = JointLimits.create(1, velocity=[50.0], lower=[-2.0], upper=[1.0])
    problem = TimingProblem([[0.0], [1.0], [0.0]], "cubic", limits)
    h = np.array([[0.5, 1.0, 3.0, 0.5], [0.5, 1.0, 2.0, 0.5], [0.5, 1.0, 1.2, 0.5]])
    evaluation = problem.evaluate_durations(h)
    overshoot = []
    for row in h:
        trajectory = problem.trajectory(row)
        overshoot.append(trajectory.evaluate(np.linspace(0.0, trajectory.total_time, 200_001)).max() - 1.0)
    assert min(overshoot) > 1e-3
    np.testing.assert_allclose(evaluation.position_excess, overshoot, rtol=1e-6)
    assert not evaluation.feasible.any() and evaluation.ratios.max() < 1.0
    penalty = evaluation.objective - h.sum(axis=1)
    assert np.all(penalty > 0)
    assert np.all(np.diff(penalty / (1 + h.sum(axis=1))) * np.diff(overshoot) > 0)  # larger excess, larger penalty


def test_the_penalty_of_a_broken_limit_vanishes_as_the_limit_is_just_met():
    """Durations that just meet a limit (the repair's), then sped up by 0.01 % and 0.02 %: each breaks it, by about
    as much, and its objective is the time plus a penalty proportional to the excess (no jump at the limit)."""
    problem = TimingProblem(VIA, "quintic", LIMITS)
    tight = problem.evaluate(np.array([[1.0, 1.5]])).durations[0]
    faster = tight / np.array([[1.0], [1.0001], [1.0002]])
    evaluation = problem.evaluate_durations(faster)
    np.testing.assert_array_equal(evaluation.feasible, [True, False, False])
    penalty = evaluation.objective - faster.sum(axis=1)
    assert penalty[0] == 0.0 and 0.0 < penalty[1] < 1.0
    assert penalty[2] == pytest.approx(2 * penalty[1], rel=1e-2)
