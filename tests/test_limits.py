import numpy as np
import pytest

from planner.limits import JointLimits, bounds_exceeded, range_exceeded, ratio_exceeded


def test_a_position_range_holds_up_to_a_nanoradian_and_nan_never_holds():
    """The one test of a position range, as numbers: 1e-9 rad outside holds (rounding), 1.1e-9 does not."""
    np.testing.assert_array_equal(range_exceeded([-1.0, 0.0, 1e-9, 1.1e-9, np.inf, np.nan]),
                                  [False, False, False, True, True, True])


def test_range_excess_is_the_distance_outside_each_joints_range():
    limits = JointLimits.create(3, lower=[-1.0, -np.inf, 0.0], upper=[1.0, 2.0, np.inf])
    low, high = np.array([[-1.5, -100.0, 0.5], [0.0, 0.0, -0.25]]), np.array([[0.5, 2.5, 1e9], [1.0, 2.0, 0.0]])
    np.testing.assert_array_equal(limits.range_excess(low, high), [[0.5, 0.5, 0.0], [0.0, 0.0, 0.25]])


@pytest.mark.parametrize("durations, bounds, exceeded", [
    ([1.0, 2.0], (1.0, 2.0), False),
    ([1.0, 2.0 * (1 + 1e-9)], (1.0, 2.0), False),  # the tolerance of every limit, as a ratio
    ([1.0, 2.0 * (1 + 2e-9)], (1.0, 2.0), True),
    ([1.0 / (1 + 2e-9), 2.0], (1.0, 2.0), True),
    ([1e-300, 1e300], (0.0, np.inf), False),  # no h_min, no h_max
    ([0.5, np.nan], (0.0, np.inf), True),
])
def test_durations_leave_their_bounds_beyond_the_feasibility_tolerance(durations, bounds, exceeded):
    assert bool(bounds_exceeded(np.array(durations), bounds)) == exceeded
    assert bounds_exceeded(np.array([durations, [1.5, 1.5]]), bounds).tolist() == [exceeded, False]


def test_a_ratio_beyond_one_plus_a_nanoth_or_not_a_number_breaks_its_limit():
    np.testing.assert_array_equal(ratio_exceeded([1.0, 1 + 1e-9, 1 + 2e-9, np.nan]), [False, False, True, True])
