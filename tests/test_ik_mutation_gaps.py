"""Gaps in the tests of planner/ik.py found by mutation testing (mutmut 3.8.1)."""

from dataclasses import replace

import numpy as np
import pytest

import planner.ik as ik
from planner.limits import FEASIBILITY_TOLERANCE
from planner.robot import Robot


@pytest.fixture(scope="module")
def ur5():
    return Robot.from_example_robot_data("ur5", "tool0")


def _with_ranges(robot, lower_deg, upper_deg):
    limits = robot.limits.with_overrides(lower=np.deg2rad(lower_deg), upper=np.deg2rad(upper_deg))
    return replace(robot, limits=limits)


# Per joint: +-600 deg, +-360 deg, -90..200 deg, 10..20 deg (narrower than a turn), bounded below only,
# bounded above only.
LOWER_DEG = np.array([-600.0, -360.0, -90.0, 10.0, -100.0, -np.inf])
UPPER_DEG = np.array([600.0, 360.0, 200.0, 20.0, np.inf, 50.0])


def _brute_force_nearest_turn(q, reference, lower, upper):
    """Per joint, q_j + 2 pi k nearest reference_j among the k in -20..20 within the range (to
    FEASIBILITY_TOLERANCE); q_j itself where no turn is in range."""
    out = q.copy()
    for j in range(len(q)):
        options = q[j] + 2 * np.pi * np.arange(-20, 21)
        inside = (options >= lower[j] - FEASIBILITY_TOLERANCE) & (options <= upper[j] + FEASIBILITY_TOLERANCE)
        options = options[inside]
        if len(options):
            out[j] = options[np.argmin(np.abs(options - reference[j]))]
    return out


def test_nearest_turn_is_the_in_range_turn_nearest_the_reference_on_every_kind_of_range(ur5):
    """The 2 pi shift towards the previous configuration (``nearest_turn``), against a brute force over
    the turns, on ranges wider than two turns, of exactly +-1 turn, asymmetric, narrower than a turn (a q
    that no turn puts in range keeps its value) and bounded on one side only, with q and the reference
    drawn over several turns, and q and the reference on or next to the bounds. (tests/test_ik_gaps.py's
    Hypothesis test of this is strict about the bounds, where ``nearest_turn`` allows
    FEASIBILITY_TOLERANCE, and fails on some draws.)"""
    robot = _with_ranges(ur5, LOWER_DEG, UPPER_DEG)
    lower, upper = robot.limits.lower, robot.limits.upper
    finite_lower = np.where(np.isfinite(lower), lower, np.deg2rad(-700.0))
    finite_upper = np.where(np.isfinite(upper), upper, np.deg2rad(700.0))
    rng = np.random.default_rng(7)
    cases = [(rng.uniform(-15.0, 15.0, 6), finite_lower + (finite_upper - finite_lower) * rng.uniform(0, 1, 6))
             for _ in range(300)]
    cases += [(lower.copy() + 2 * np.pi * k, np.where(np.isfinite(upper), upper, 3.0)) for k in (-1, 0, 1, 3)]
    cases += [(np.where(np.isfinite(upper), upper, 1.0) - 1e-10, np.where(np.isfinite(lower), lower, -2.0))]
    cases += [(np.full(6, 1e-9), np.where(np.isfinite(upper), upper, 3.0))]
    kept = 0
    for q, reference in cases:
        q = np.where(np.isfinite(q), q, 0.5)
        shifted = ik.nearest_turn(robot, q, reference)
        expected = _brute_force_nearest_turn(q, reference, lower, upper)
        np.testing.assert_allclose(shifted, expected, rtol=0, atol=1e-9, err_msg=f"q={q!r}, reference={reference!r}")
        kept += int(shifted[3] == q[3])
    assert 0 < kept < len(cases)  # the narrow joint both kept its value and was turned into range


def _tool_placement(robot, q):
    """The tool frame's placement at q by Pinocchio's own forward kinematics (not ``Robot``'s)."""
    import pinocchio as pin
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, np.asarray(q, dtype=float))
    return data.oMf[robot.model.getFrameId(robot.tool_frame)]


@pytest.mark.parametrize("base_deg, turns", [(300.0, +1), (-300.0, -2)])
def test_a_seed_outside_the_ranges_is_clipped_before_the_first_step_even_where_it_already_reaches_the_pose(
        ur5, base_deg, turns):
    """``solve_pose`` clips every iterate to the ranges, the seed included: a seed that reaches the pose
    exactly but lies a whole turn above (or two below) the base's +-360 deg range is not returned as is;
    from its clipped value (the bound, 60 deg from the in-range solution) the solve reaches the pose within
    the ranges, at the in-range solution."""
    lower, upper = ur5.limits.lower, ur5.limits.upper
    q = np.deg2rad([base_deg, -60.0, 80.0, -110.0, -90.0, 30.0])
    target = _tool_placement(ur5, q)
    seed = q.copy()
    seed[0] += turns * 2 * np.pi
    assert not lower[0] <= seed[0] <= upper[0]
    assert np.abs((target.actInv(_tool_placement(ur5, seed))).translation).max() < 1e-12  # the same pose
    solution = ik.solve_pose(ur5, target, seed)
    assert np.all(solution.q >= lower) and np.all(solution.q <= upper)
    assert solution.residual <= 1e-9
    reached = _tool_placement(ur5, solution.q)
    assert np.linalg.norm(reached.translation - target.translation) <= 1e-9
    assert np.linalg.norm(pin_log3(reached.rotation.T @ target.rotation)) <= 1e-9
    np.testing.assert_allclose(solution.q, q, atol=1e-7)


def pin_log3(rotation):
    import pinocchio as pin
    return pin.log3(rotation)


@pytest.mark.parametrize("component", range(6))
def test_the_solve_goes_on_until_every_component_of_the_error_is_within_tolerance(ur5, component):
    """``solve_pose`` stops when both |translation error| and |rotation error| are within ``TOLERANCE``
    (1e-10 m and rad): from the exact solution of a pose moved by 3e-10 m or rad along one axis of the
    tool frame, it goes on to reach the moved pose, whichever component the 3e-10 is in."""
    import pinocchio as pin
    q = np.deg2rad([30.0, -60.0, 80.0, -110.0, -90.0, 30.0])
    offset = np.zeros(6)
    offset[component] = 3e-10
    target = _tool_placement(ur5, q) * pin.exp6(pin.Motion(offset))
    solution = ik.solve_pose(ur5, target, q)
    assert solution.residual <= ik.TOLERANCE
    reached = _tool_placement(ur5, solution.q)
    error = pin.log6(reached.actInv(target)).vector
    assert np.linalg.norm(error[:3]) <= ik.TOLERANCE and np.linalg.norm(error[3:]) <= ik.TOLERANCE


@pytest.mark.parametrize("iterations", [1, 2])
def test_an_unfinished_solve_reports_its_translation_and_rotation_errors_apart(ur5, iterations):
    """A solve stopped after 1 or 2 iterations, far from its pose, reports |translation error| [m] and
    |rotation error| [rad] of the configuration it returns, each from its own three components of
    log6(T(q)^-1 T_target), computed here with Pinocchio's own forward kinematics."""
    import pinocchio as pin
    seed = np.deg2rad([30.0, -60.0, 80.0, -110.0, -90.0, 30.0])
    target = _tool_placement(ur5, np.deg2rad([60.0, -40.0, 60.0, -80.0, -60.0, 90.0]))
    solution = ik.solve_pose(ur5, target, seed, max_iterations=iterations)
    error = pin.log6(_tool_placement(ur5, solution.q).actInv(target)).vector
    assert np.abs(error).min() > 1e-6  # far: every component counts
    assert solution.position_error == pytest.approx(np.linalg.norm(error[:3]), rel=1e-9)
    assert solution.orientation_error == pytest.approx(np.linalg.norm(error[3:]), rel=1e-9)
    assert solution.iterations == iterations


def test_the_optimal_rule_keeps_each_hinted_solution_even_where_a_turn_of_it_is_nearer(ur5):
    """A waypoint with a hint has one candidate, the solution its hint seeds (module docstring), not its
    2 pi turns: UR5 base hinted at 170 deg then -170 deg (both exact solutions) stays at -170 deg, although
    190 deg, in its +-360 deg range, is 20 deg from the first waypoint instead of 340."""
    hints = np.deg2rad([[170.0, -60.0, 80.0, -110.0, -90.0, 0.0], [-170.0, -60.0, 80.0, -110.0, -90.0, 0.0]])
    poses = [_tool_placement(ur5, q) for q in hints]
    solutions = ik.solve_waypoints(ur5, poses, hints=list(hints), branch="optimal")
    np.testing.assert_allclose([s.q for s in solutions], hints, atol=1e-9)
    assert solutions[1].jump == pytest.approx(np.deg2rad(340.0), rel=1e-9)


@pytest.fixture(scope="module")
def ur5_path(ur5):
    """Three UR5 poses and the optimal rule's solutions for them without any resting condition."""
    path = np.deg2rad([[20.0, -70.0, 90.0, -100.0, -80.0, 10.0], [50.0, -60.0, 70.0, -90.0, -70.0, 40.0],
                       [80.0, -50.0, 60.0, -80.0, -60.0, 70.0]])
    poses = [_tool_placement(ur5, q) for q in path]
    return poses, ik.solve_waypoints(ur5, poses, branch="optimal")


def test_the_optimal_rule_reports_each_waypoints_jump_errors_iterations_and_margin(ur5, ur5_path):
    """What each solution of the ``optimal`` rule reports, computed here independently: the jump
    |q_i - q_i-1| (0 at the first waypoint), the translation and rotation errors at q (Pinocchio's own
    forward kinematics), a positive iteration count, which of the pose's solutions was chosen, and the
    margin to the ranges."""
    import pinocchio as pin
    poses, solutions = ur5_path
    lower, upper = ur5.limits.lower, ur5.limits.upper
    previous = None
    for pose, solution in zip(poses, solutions):
        expected_jump = 0.0 if previous is None else np.linalg.norm(solution.q - previous)
        assert solution.jump == pytest.approx(expected_jump, rel=1e-12, abs=0.0)
        error = pin.log6(_tool_placement(ur5, solution.q).actInv(pose)).vector
        assert solution.position_error == pytest.approx(np.linalg.norm(error[:3]), rel=1e-6, abs=1e-14)
        assert solution.orientation_error == pytest.approx(np.linalg.norm(error[3:]), rel=1e-6, abs=1e-14)
        assert solution.residual <= 1e-9
        assert isinstance(solution.iterations, int) and solution.iterations >= 1
        assert isinstance(solution.chosen, int) and 0 <= solution.chosen < solution.solutions
        assert solution.solutions >= 2
        margin = np.rad2deg(np.min(np.minimum(solution.q - lower, upper - solution.q)))
        assert solution.margin_deg == pytest.approx(margin, rel=1e-12)
        previous = solution.q
    assert solutions[1].jump > 0.1


def test_the_optimal_rule_rests_the_first_and_the_last_waypoint_where_rests_allows(ur5, ur5_path):
    """``rests`` restricts the first and the last waypoints' solutions (only they): the unconstrained
    choice turns the base one way (here -140 -> -112 -> -83 deg); with a condition that the base stays
    below halfway between the first two waypoints' bases, which the first waypoint's choice meets and
    the last's does not, the last gets a solution (another branch or turn) that meets it and reaches the
    pose; a condition that only the middle's choice breaks changes nothing."""
    poses, free = ur5_path
    base = [s.q[0] for s in free]
    assert base[0] < base[1] < base[2]
    threshold = (base[0] + base[1]) / 2

    def rests(q):
        return q[0] < threshold

    solutions = ik.solve_waypoints(ur5, poses, branch="optimal", rests=rests)
    assert rests(solutions[0].q) and rests(solutions[-1].q)
    for pose, solution in zip(poses, solutions):
        assert np.linalg.norm(_tool_placement(ur5, solution.q).translation - pose.translation) <= 1e-9
    # A condition that both ends' unconstrained choices meet and the middle's does not: the middle is not
    # restricted, so the choice is the unconstrained one.
    solutions = ik.solve_waypoints(ur5, poses, branch="optimal",
                                   rests=lambda q: q[0] <= base[0] + 1e-6 or q[0] >= base[2] - 1e-6)
    np.testing.assert_allclose([s.q for s in solutions], [s.q for s in free], atol=1e-12)


def test_random_starts_span_minus_pi_to_pi_on_a_side_without_a_bound(ur5):
    """An unbounded side of a range is replaced by -pi (below) or pi (above) for the random starts and
    the middle of the ranges: a UR5 whose base has no range draws its starts from [-pi, pi]."""
    free = replace(ur5, limits=ur5.limits.with_overrides(lower=np.r_[-np.inf, ur5.limits.lower[1:]],
                                                         upper=np.r_[np.inf, ur5.limits.upper[1:]]))
    lower, upper = ik._finite_ranges(free)
    assert (lower[0], upper[0]) == (-np.pi, np.pi)
    np.testing.assert_array_equal(lower[1:], ur5.limits.lower[1:])
    np.testing.assert_array_equal(upper[1:], ur5.limits.upper[1:])
