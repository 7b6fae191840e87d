"""Gaps in the tests of planner/timing/starts.py found by mutation testing (mutmut)."""

import numpy as np
import pytest

from planner import JointLimits
from planner.timing import TimingProblem
from planner.timing.starts import DIFFERENCE, REGION_MARGIN, chord_segments, recombined, start_shapes


def test_a_taken_region_reaches_margin_segments_on_both_sides():
    """Neighbours that differ by less than DIFFERENCE still come from the solution a region is taken from,
    REGION_MARGIN (2) segments on each side of the segment that differs."""
    assert REGION_MARGIN == 2
    first = np.full(16, 2.0)
    other = first * (1 + DIFFERENCE / 10)  # below the threshold everywhere...
    other[8] = 1.0                          # ...but much shorter on segment 8
    other[14] = 4.0                         # and longer on 14, so longer in all
    assert other.sum() > first.sum()
    result = recombined([first, other])
    expected = first.copy()
    expected[6:11] = other[6:11]
    np.testing.assert_array_equal(result, expected)


def test_solutions_differ_by_a_relative_not_an_absolute_amount():
    """Durations of 10 s that differ by 0.5e-4 of their value (5e-4 s) do not differ; by 2e-4, they do."""
    first = np.full(12, 10.0)
    close = first.copy()
    close[11], close[5] = 11.0, 10.0 * (1 - DIFFERENCE / 2)  # longer on 11 (a region not taken)
    assert recombined([first, close]) is None
    far = first.copy()
    far[11], far[5] = 11.0, 10.0 * (1 - 2 * DIFFERENCE)
    expected = first.copy()
    expected[5] = far[5]
    np.testing.assert_array_equal(recombined([first, far]), expected)


def test_every_region_is_taken_on_its_own_however_many_there_are():
    """Three regions: shorter in the first two (both taken), longer in the third (kept from the shortest)."""
    first = np.full(24, 2.0)
    other = first.copy()
    other[3], other[10], other[18] = 1.5, 1.5, 4.0
    assert other.sum() > first.sum()
    expected = first.copy()
    expected[3], expected[10] = 1.5, 1.5
    np.testing.assert_array_equal(recombined([first, other]), expected)
    np.testing.assert_array_equal(recombined([other, first]), expected)


def test_a_region_that_reaches_the_last_segment_is_taken():
    first = np.full(10, 2.0)
    other = first.copy()
    other[9], other[2] = 1.0, 4.0  # shorter on the last segment, longer on segment 2
    expected = first.copy()
    expected[9] = 1.0
    np.testing.assert_array_equal(recombined([first, other]), expected)


# ---------------------------------------------------------------- added by the second mutation run (/tmp/mut38):
# chord_segments, _spread and start_shapes

VIA = np.array([[0.0, 0.0], [1.0, 0.5], [1.5, -0.5], [3.0, -0.2]])
VELOCITY = np.array([1.0, 0.25])


def _chord_times(via, velocity):
    """max_j D_j / V_j per chord, by explicit loops."""
    return [max(abs(via[c + 1, j] - via[c, j]) / velocity[j] for j in range(via.shape[1]))
            for c in range(len(via) - 1)]


@pytest.mark.parametrize("family", ["cubic", "hybrid"])
def test_the_cubic_families_give_the_first_and_last_chords_two_segments(family):
    """Cubic families: knots 0, 2, .., n - 1, n + 1 are the via-points (1 and n are virtual), so segments
    0 and 1 belong to chord 0 and the last two to the last chord."""
    problem = TimingProblem(VIA, family, JointLimits.create(2, velocity=VELOCITY))
    np.testing.assert_array_equal(chord_segments(problem), [0, 0, 1, 2, 2])


@pytest.mark.parametrize("family", ["quintic", "hermite7"])
def test_a_family_with_every_knot_a_via_point_has_one_segment_per_chord(family):
    problem = TimingProblem(VIA, family, JointLimits.create(2, velocity=VELOCITY))
    np.testing.assert_array_equal(chord_segments(problem), [0, 1, 2])


def test_a_chords_time_is_split_evenly_among_its_segments():
    """Velocity limits only: both shapes are D / V per chord (rest-to-rest is D / V too), halved on the
    cubic family's two-segment chords."""
    problem = TimingProblem(VIA, "cubic", JointLimits.create(2, velocity=VELOCITY))
    first, middle, last = _chord_times(VIA, VELOCITY)
    expected = [first / 2, first / 2, middle, last / 2, last / 2]
    for shape in start_shapes(problem).values():
        np.testing.assert_allclose(shape, expected, rtol=1e-12)


def test_a_short_chord_is_kept_above_a_thousandth_of_the_longest():
    """A chord of 1e-7 rad: its time D / V is raised to 1e-3 of the longest chord's."""
    via = np.array([[0.0], [2.0], [2.0 + 1e-7], [3.0]])
    problem = TimingProblem(via, "hermite7", JointLimits.create(1, velocity=[0.5]))
    for shape in start_shapes(problem).values():
        np.testing.assert_allclose(shape, [2.0 / 0.5, 1e-3 * 2.0 / 0.5, (via[3, 0] - via[2, 0]) / 0.5], rtol=1e-12)


def test_without_velocity_limits_the_cruise_shape_is_the_rest_to_rest_time():
    """No velocity limit: ``cruise`` falls back to rest-to-rest, max_j 2 sqrt(D_j / A_j) under acceleration
    limits alone."""
    acceleration = np.array([2.0, 0.5])
    problem = TimingProblem(VIA, "hermite7", JointLimits.create(2, acceleration=acceleration))
    expected = [max(2 * np.sqrt(abs(VIA[c + 1, j] - VIA[c, j]) / acceleration[j]) for j in range(2))
                for c in range(3)]
    shapes = start_shapes(problem)
    np.testing.assert_allclose(shapes["cruise"], expected, rtol=1e-12)
    np.testing.assert_allclose(shapes["stop-at-turns"], expected, rtol=1e-12)


def test_without_any_limit_every_chord_gets_the_same_time():
    """Duration bounds and no limit: every chord's estimate is 0, so each gets the unit floor (1 s), split
    among its segments."""
    problem = TimingProblem(VIA, "cubic", JointLimits.create(2), bounds=(0.1, 5.0))
    for shape in start_shapes(problem).values():
        np.testing.assert_allclose(shape, [0.5, 0.5, 1.0, 0.5, 0.5], rtol=1e-12)
