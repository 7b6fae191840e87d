"""The lower bound on any trajectory's total time (planner.timing.lower_bound): the known optima of
single moves, and never above a trajectory the planner found feasible."""

from unittest.mock import patch

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from planner import JointLimits
from planner.timing import TimingProblem, lower_bound, optimize
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
    """14.6212 s, below a motion of piecewise-constant jerk checked exactly (15.6771 s,
    scripts/bracket_optimum.py), hermite7's independent optimum 16.4723 s and the hybrid's 17.3128 s."""
    assert time_lower_bound(paper_via, paper_limits) == pytest.approx(14.6212, abs=1e-4)


def _largest_distance(duration, acceleration, jerk, free_start, free_end, pieces=240):
    """The largest distance [rad] a motion from q' = 0 to q' = 0 covers in ``duration`` [s] under the
    acceleration and jerk limits, q'' at either end free (``free_start``, ``free_end``) or 0: a linear
    program over piecewise-constant jerk on ``pieces`` equal pieces (the acceleration at their ends,
    where it is extreme), whose optimum approaches the true largest distance from below."""
    from scipy.optimize import linprog

    dt = duration / pieces
    # x = (q''(0), jerk of each piece); q'' at the pieces' ends, q'(T) and q(T) are linear in x
    steps = np.tril(np.ones((pieces, pieces))) * dt                     # q'' at the end of piece k
    ends = np.hstack((np.ones((pieces, 1)), steps))
    remaining = duration - dt * np.arange(1, pieces + 1)                  # time after piece k
    velocity = np.concatenate(([duration], dt ** 2 / 2 + dt * remaining))
    distance = np.concatenate(([duration ** 2 / 2], dt ** 3 / 6 + dt ** 2 / 2 * remaining + dt * remaining ** 2 / 2))
    equalities, targets = [velocity], [0.0]
    if not free_end:
        equalities.append(ends[-1])
        targets.append(0.0)
    start = (-acceleration, acceleration) if free_start else (0.0, 0.0)
    found = linprog(-distance, A_ub=np.vstack((ends, -ends)), b_ub=np.full(2 * pieces, acceleration),
                    A_eq=np.array(equalities), b_eq=targets, bounds=[start] + [(-jerk, jerk)] * pieces)
    assert found.status == 0
    return -found.fun


@pytest.mark.parametrize("distance", [0.05, 0.4, 1.0, 3.0])
@pytest.mark.parametrize("ends", ["stop", "rest"])
def test_the_jerk_limited_pieces_are_the_largest_distances_inverted(distance, ends):
    """Between two stops (q'' free at both ends) and from rest (q'' = 0) to a stop, under A = 1.3 and
    Jk = 0.9 (no velocity limit): in the bound's time for ``distance`` no motion covers more than it (a
    linear program over piecewise-constant jerk approaches the largest distance from below); between
    stops, and from rest where the jerk-only motion keeps q'' within A, the program reaches it within
    0.5 % and covers less 1 % sooner: the shortest times, not merely bounds."""
    limits = JointLimits.create(1, acceleration=[1.3], jerk=[0.9])
    piece = lower_bound._turn_to_turn if ends == "stop" else lower_bound._rest_to_stop
    duration = float(piece(np.array([distance]), limits)[0])
    covered = _largest_distance(duration, 1.3, 0.9, ends == "stop", True)
    assert covered <= distance * (1 + 1e-9)
    # From rest the bound is the larger of the (V, A) and the jerk-only times, the shortest time where q''
    # stays within A on the jerk-only motion (its largest |q''| is Jk T (sqrt 2 - 1) at the end)
    if ends == "stop" or 0.9 * duration * (np.sqrt(2) - 1) <= 1.3:
        assert covered >= distance * (1 - 5e-3)
        assert _largest_distance(0.99 * duration, 1.3, 0.9, ends == "stop", True) < distance


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


def _piece_time(distance: float, start: str, end: str, v: float, a: float, jerk: float) -> float:
    """The module docstring's shortest time over one piece, its ends each 'pass' (a passing speed),
    'stop' (q' = 0, q'' free) or 'rest' (q' = q'' = 0), written out per case."""
    def va(d):
        return 2 * np.sqrt(d / a) if d * a <= v * v else d / v + v / a

    def half(d):
        return np.sqrt(2 * d / a) if 2 * d * a <= v * v else d / v + v / (2 * a)

    def turn_aj(d):  # q'' from A to -A: the smallest T whose distance A t^2 + 2 A^2 t / J + 2 A^3 / (3 J^2) is d
        if jerk == np.inf or d <= 2 * a ** 3 / (3 * jerk ** 2):
            return np.cbrt(12 * d / jerk)
        t = np.roots([a, 2 * a * a / jerk, 2 * a ** 3 / (3 * jerk ** 2) - d]).real.max()
        return 2 * t + 2 * a / jerk
    kinds = sorted((start, end))
    if kinds == ["rest", "rest"]:
        return max(va(distance), np.cbrt(32 * distance / jerk))
    if kinds == ["rest", "stop"]:
        return max(va(distance), np.cbrt((12 + 6 * np.sqrt(2)) * distance / jerk))
    if kinds == ["stop", "stop"]:
        return max(va(distance), turn_aj(distance))
    if kinds == ["pass", "rest"]:
        return max(half(distance), np.cbrt(6 * distance / jerk))
    if kinds == ["pass", "stop"]:
        return half(distance)
    return distance / v


def _link_time(x: np.ndarray, i: int, k: int, n: int, v: float, a: float, jerk: float) -> float:
    """w(i, k) of one joint's values x (n,): its run from i to k with equal neighbours merged, cut at
    every strict interior extreme (a stop), each piece timed by ``_piece_time``."""
    run = [x[i]]
    for value in x[i + 1:k + 1]:
        if value != run[-1]:
            run.append(value)
    turns = [run[m] for m in range(1, len(run) - 1) if (run[m] - run[m - 1]) * (run[m + 1] - run[m]) < 0]
    points = [run[0], *turns, run[-1]]
    kinds = ["rest" if i == 0 else "pass", *["stop"] * len(turns), "rest" if k == n - 1 else "pass"]
    return sum(_piece_time(abs(points[m + 1] - points[m]), kinds[m], kinds[m + 1], v, a, jerk)
               for m in range(len(points) - 1))


def _longest_chain(via: np.ndarray, limits: JointLimits, window: int | None) -> float:
    """The longest chain 0 -> ... -> n - 1 over the links w(i, k) = max_j w_j(i, k), by dynamic
    programming over the pairs the module docstring names (``window``: those at most this far apart,
    every pair from the first and every pair to the last; None: every pair)."""
    via = via[np.concatenate(([True], np.any(np.diff(via, axis=0) != 0, axis=1)))]
    n = len(via)
    longest = [0.0] + [-np.inf] * (n - 1)
    for k in range(1, n):
        for i in range(k):
            if window is None or k - i <= window or i == 0 or k == n - 1:
                link = max(_link_time(via[:, j], i, k, n, limits.velocity[j], limits.acceleration[j],
                                      limits.jerk[j]) for j in range(via.shape[1]))
                longest[k] = max(longest[k], longest[i] + link)
    return longest[-1] if n > 1 else 0.0


@settings(max_examples=60, deadline=None)
@given(arrays(np.int8, st.tuples(st.integers(2, 14), st.integers(1, 3)), elements=st.integers(-2, 2)),
       arrays(float, 3, elements=st.floats(0.3, 3.0)), arrays(float, 3, elements=st.floats(0.3, 3.0)),
       arrays(float, 3, elements=st.floats(0.1, 10.0)))
def test_the_bound_is_the_longest_chain_of_the_documented_links(steps, v, a, jerk):
    """Against an independent reading of the module docstring, case by case (turns, stops, rests,
    passing speeds, equal neighbours merged, the links' pair set): the bound is the longest chain, with
    ``WINDOW`` cut to 3 so that 14 via-points exercise it; and no longer than the chain over every pair.
    (Pairs from the first via-point beyond the window were missing: 0.28 % below it on one of 30 walks.)"""
    joints = steps.shape[1]
    via = np.cumsum(steps.astype(float) * 0.25, axis=0)  # steps of -0.5 .. 0.5 rad: turns, rests, repeats
    limits = JointLimits.create(joints, velocity=v[:joints], acceleration=a[:joints], jerk=jerk[:joints])
    with patch.object(lower_bound, "WINDOW", 3):
        bound = time_lower_bound(via, limits)
    assert bound == pytest.approx(_longest_chain(via, limits, 3), rel=1e-12, abs=1e-12)
    assert bound <= _longest_chain(via, limits, None) * (1 + 1e-12) + 1e-12


@settings(max_examples=40, deadline=None)
@given(arrays(np.int8, st.tuples(st.integers(2, 12), st.integers(1, 3)), elements=st.integers(-2, 2)),
       arrays(float, 3, elements=st.floats(0.3, 3.0)), arrays(float, 3, elements=st.floats(0.3, 3.0)),
       arrays(float, 3, elements=st.floats(0.1, 10.0)))
def test_pair_bounds_are_the_documented_links_of_each_joint_at_the_given_indices(steps, v, a, jerk):
    """Each pair's bound is ``_link_time``'s w(i, k) of each joint on the merged via-points; the pairs
    are every one from the first, every one to the last and those at most ``WINDOW`` (cut to 3) apart,
    named by their given indices: the last of a run of equal neighbours for i, the first for k."""
    joints = steps.shape[1]
    via = np.cumsum(steps.astype(float) * 0.25, axis=0)  # zero steps: runs of equal neighbours
    limits = JointLimits.create(joints, velocity=v[:joints], acceleration=a[:joints], jerk=jerk[:joints])
    with patch.object(lower_bound, "WINDOW", 3):
        pairs, bounds = lower_bound.pair_lower_bounds(via, limits)
    kept = np.flatnonzero(np.concatenate(([True], np.any(np.diff(via, axis=0) != 0, axis=1))))
    merged, n = via[kept], len(kept)
    run = np.cumsum(np.isin(np.arange(len(via)), kept)) - 1  # each given via-point's merged index
    expected = {(i, k) for i in range(n) for k in range(i + 1, n) if i == 0 or k == n - 1 or k - i <= 3}
    assert len(pairs) == len(bounds) >= len(expected)
    seen = set()
    for (first, last), bound in zip(pairs, bounds):
        i, k = run[first], run[last]
        assert first == np.flatnonzero(run == i)[-1] and last == np.flatnonzero(run == k)[0]
        seen.add((i, k))
        for j in range(joints):
            assert bound[j] == pytest.approx(_link_time(merged[:, j], i, k, n, v[j], a[j], jerk[j]), rel=1e-12,
                                             abs=1e-15)
    assert seen == expected


@pytest.mark.parametrize("family", ["cubic", "hybrid", "quintic", "hermite7", "trigonometric"])
def test_no_feasible_trajectory_passes_two_via_points_faster_than_their_pair_bound(family):
    """A lower bound between any two via-points, for every family: a planned trajectory's via times."""
    rng = np.random.default_rng(5)
    via = np.cumsum(rng.uniform(-1, 1, (7, 2)), axis=0)
    limits = JointLimits.create(2, velocity=[1.0, 0.7], acceleration=[2.0, 1.0], jerk=[8.0, 5.0])
    problem = TimingProblem(via, family, limits)
    result = optimize(problem, "nlp")
    times = problem.trajectory(result.durations, result.knot_states).via_times
    pairs, bounds = lower_bound.pair_lower_bounds(via, limits)
    assert result.feasible and len({(i, k) for i, k in pairs}) == 7 * 6 // 2  # every pair: within the window
    assert np.all(times[pairs[:, 1]] - times[pairs[:, 0]] >= bounds.max(axis=1) * (1 - 1e-9))
