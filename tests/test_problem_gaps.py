"""Gaps in the tests of planner/timing/problem.py found by mutation testing (mutmut 3.8.1, a partial run)."""

import numpy as np
import pytest

from planner import JointLimits
from planner.errors import InputError
from planner.timing import TimingProblem
from planner.timing.result import SearchTracker

VIA = np.radians([[0.0, 0.0], [40.0, -20.0], [90.0, 10.0]])


def _states(seed, batch, problem):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.05, 0.05, (batch, *problem.via_points.shape, 3))


def test_evaluate_states_with_time_jerk_takes_the_best_scale_along_the_ray():
    # Loose limits: the jerk-energy term, not a limit, sets the scale; K_t s T + K_j E / s^5 is least at s_opt.
    limits = JointLimits.create(2, velocity=[50.0, 50.0], acceleration=[500.0, 500.0], jerk=[5000.0, 5000.0])
    problem = TimingProblem(VIA, "hermite7", limits, objective="time-jerk", weights=(1.0, 0.5))
    h = np.array([[0.4, 0.7]])
    states = _states(0, 1, problem)
    best = problem.evaluate_states(h, states)
    assert best.feasible[0]
    scale = best.durations[0, 0] / h[0, 0]
    for factor in (0.9, 1.1):   # the same shape and states scaled by the lemma, a little faster and slower
        s = scale * factor
        other = problem.evaluate_durations(h * s, states / s ** np.arange(1, 4))
        assert other.feasible[0] and best.objective[0] < other.objective[0]


def test_evaluate_states_of_a_batch_repairs_each_row_as_if_alone():
    limits = JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0], jerk=[10.0, 10.0])
    problem = TimingProblem(VIA, "hermite7", limits, min_duration=1.5)
    h = np.array([[1.0, 2.0], [0.5, 4.0], [3.0, 3.0]])
    states = _states(1, 3, problem)
    batch = problem.evaluate_states(h, states)
    for b in range(3):
        alone = problem.evaluate_states(h[b:b + 1], states[b:b + 1])
        np.testing.assert_allclose(batch.durations[b], alone.durations[0], rtol=1e-12)
        np.testing.assert_allclose(batch.states[b], alone.states[0], rtol=1e-12, atol=1e-15)
        assert batch.durations[b].min() >= 1.5 * (1 - 1e-12)


def test_bounds_too_short_for_a_joint_name_the_given_via_points_and_the_joint():
    import pytest

    from planner import InfeasibleError
    # Given via-points 0..4, merged to 3 (0 = 1, 2 = 3): joint 1 must move 2 rad at most 1 rad/s between given
    # via-points 1 and 2 (the cubic family's two segments between them, at most 1 s); joint 0 stays within its
    # limit everywhere.
    via = [[0.0, 0.0], [0.0, 0.0], [0.1, 2.0], [0.1, 2.0], [0.2, 2.5]]
    limits = JointLimits.create(2, velocity=[1.0, 1.0])
    with pytest.raises(InfeasibleError,
                       match=r"joint joint2 takes at least 2 s from via-point 1 to via-point 2 ") as error:
        TimingProblem(via, "cubic", limits, bounds=(0.1, 0.5))
    assert (error.value.joint, error.value.joint_index, error.value.quantity) == ("joint2", 1, "duration")
    assert error.value.value == pytest.approx(2.0) and error.value.limit == pytest.approx(1.0)


def test_a_lower_bound_below_the_duration_range_is_refused_though_the_upper_one_is_within():
    import pytest

    from planner import InputError
    with pytest.raises(InputError, match=r"bounds \[h_min, h_max\] must each be >= 1e-06 and <= 1e\+06 s"):
        TimingProblem(VIA, "cubic", JointLimits.create(2, velocity=[1.0, 1.0]), bounds=(1e-300, 1.0))


def test_to_search_space_scales_each_row_to_its_longest_and_keeps_shapes_in_the_box():
    problem = TimingProblem(VIA, "cubic", JointLimits.create(2, velocity=[1.0, 1.0]))
    durations = np.array([[0.01, 0.5, 1.0, 2.0], [3.0, 3.0, 1.5, 0.03]])
    shapes = problem.to_search_space(durations)
    lower, upper = problem.search_box()
    np.testing.assert_array_equal(shapes, [[0.05, 0.25, 0.5, 1.0], [1.0, 1.0, 0.5, 0.05]])
    assert np.all(shapes >= lower) and np.all(shapes <= upper)


def test_a_family_is_taken_as_an_object_or_a_name_and_anything_else_is_refused_naming_the_names():
    import re

    import pytest

    from planner import InputError
    from planner.splines import FAMILIES, get_family
    limits = JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0])
    by_object = TimingProblem(VIA, get_family("quintic"), limits)
    by_name = TimingProblem(VIA, "quintic", limits)
    assert by_object.family is by_name.family is FAMILIES["quintic"]
    h = np.array([[0.8, 1.1]])
    np.testing.assert_array_equal(by_object.evaluate_durations(h).ratios, by_name.evaluate_durations(h).ratios)
    expected = re.escape(f"family must be a family's name ({', '.join(FAMILIES)}) or a SplineFamily, got int")
    with pytest.raises(InputError, match=expected):
        TimingProblem(VIA, 3, limits)


def test_weights_need_exactly_two_numbers_and_a_non_negative_jerk_weight():
    import pytest

    from planner import InputError
    limits = JointLimits.create(2, velocity=[1.0, 1.0])
    for weights in [(1.0, -1.0), (1.0, 1.0, 1.0), (1.0,)]:
        with pytest.raises(InputError, match=r"weights \(K_t, K_j\) must be two numbers with K_t > 0, K_j >= 0"):
            TimingProblem(VIA, "cubic", limits, objective="time-jerk", weights=weights)
    assert TimingProblem(VIA, "cubic", limits, objective="time-jerk", weights=(2.0, 0.0)).weights == (2.0, 0.0)


def test_a_minimum_duration_equal_to_the_upper_bound_is_allowed():
    limits = JointLimits.create(2, velocity=[1.0, 1.0])
    problem = TimingProblem(VIA, "cubic", limits, bounds=(0.5, 2.0), min_duration=2.0)
    assert problem.duration_floor == 2.0
    np.testing.assert_array_equal(problem.search_box()[0], np.full(problem.segment_count, 2.0))


def test_an_empty_batch_is_refused_by_every_evaluation_with_an_input_error():
    """A (0, S) batch is no candidate at all: the problem and the search tracker name it (it reached numpy's
    reshape and raised a bare ValueError)."""
    limits = JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0], jerk=[10.0, 10.0])
    problem = TimingProblem(VIA, "hybrid", limits)
    empty = np.zeros((0, problem.segment_count))
    tracker = SearchTracker(problem)
    for evaluate in (problem.evaluate, problem.evaluate_durations, problem.coefficients, tracker.evaluate):
        with pytest.raises(InputError, match="at least one vector of 4 segment durations, got none"):
            evaluate(empty)
