"""Gaps in the tests of planner/timing/starts.py found by mutation testing (mutmut)."""

import numpy as np

from planner.timing.starts import DIFFERENCE, REGION_MARGIN, recombined


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
