import re

import numpy as np
import pytest

from planner.errors import InputError
from planner.limits import JointLimits, bounds_exceeded, range_exceeded, ratio_exceeded
from planner.validate import float_array


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


@pytest.mark.parametrize("value, said", [(-1e308, "-1e+308 rad/s"), (5e-324, "deg/s"), (0.0, "0 deg/s"),
                                         (1e300, "5.72958e+301 deg/s")])
def test_a_limit_outside_the_planners_range_is_named_in_a_unit_that_holds_it(value, said):
    """A velocity limit of -1e308 rad/s (a hand-edited recording) was said as "-inf deg/s", with an overflow
    warning; 5e-324 rad/s was taken, and its ratios overflowed to 1.8e308."""
    with np.errstate(all="raise"):  # no floating-point warning on the way
        with pytest.raises(InputError, match=f"velocity limit of joint j1 is .*{re.escape(said)}; limits must be "
                                             f"from 1e-12 to 1e\\+15 deg/s, or absent"):
            JointLimits.create(2, velocity=[value, 1.0], names=["j1", "j2"])
    assert JointLimits.create(1, velocity=[np.deg2rad(1e15)], acceleration=[np.deg2rad(1e-12)]).joint_count == 1


@pytest.mark.parametrize("names, problem", [([1, 2], "non-empty texts"), (["a", "a"], "distinct"),
                                            ("ab", "non-empty texts"), (["a", ""], "non-empty texts")])
def test_joint_names_are_distinct_texts(names, problem):
    """Every message names joints by these names: numbers or duplicates made them ambiguous (the recording
    reader already refused them)."""
    with pytest.raises(InputError, match=problem):
        JointLimits.create(2, velocity=[1.0, 1.0], names=names)


@pytest.mark.parametrize("given", [[True, 2.0], [[1.0], [np.True_]], [[1.0, 2.0], (3.0, False)]])
def test_a_boolean_among_numbers_is_no_number(given):
    """NumPy reads [True, 2.0] as [1.0, 2.0]: the limits took True for 1 (and (True, True) was refused)."""
    with pytest.raises(InputError, match="holds a boolean"):
        float_array("velocity limits", given)
