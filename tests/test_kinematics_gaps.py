"""Gaps in the tests of planner/kinematics.py found by mutation testing (mutmut)."""

import pickle
import re

import numpy as np
import pytest

from planner import InputError, JointLimits, get_family, paper
from planner.kinematics import (
    ROUNDING_ULPS,
    KinematicFigures,
    column_roots,
    continuity_breaks,
    segment_extrema,
    segment_ranges,
    via_point_misses,
)
from planner.limits import FEASIBILITY_TOLERANCE
from planner.splines import PiecewisePolynomial

P = np.polynomial.polynomial


def test_eigen_roots_floor_the_leading_coefficient_per_polynomial_not_per_batch():
    """A degree-5 column (companion eigenvalues) holding a polynomial 1e14 times larger than its
    neighbour: each one's leading coefficient is compared with its own coefficients, so the small
    one keeps its roots (numpy's polyroots, independently)."""
    small = P.polyfromroots([0.3, 0.6, 2.0, 3.0, 4.0])           # leading coefficient 1, others up to 42
    large = 1e14 * P.polyfromroots([0.2, 0.9, -2.0, 5.0, 6.0])
    found = column_roots(np.stack((large, small))[None, None])[0, 0]
    for row, coefficients in zip(found, (large, small)):
        roots = P.polyroots(coefficients).real
        expected = np.sort(roots[(roots >= 0) & (roots <= 1)])
        np.testing.assert_allclose(np.sort(row[~np.isnan(row)]), expected, atol=1e-9)


def _figures(joints=2):
    """Figures set by hand: |v|, |a|, |jerk| maxima and a position range per joint."""
    max_abs = np.ones((3, joints))
    return KinematicFigures(max_abs, max_abs / 2, np.zeros(joints), np.zeros(joints), np.zeros(joints), 1.0)


def test_ratios_reject_limits_of_another_kind_or_joint_count_as_input_errors():
    figures = _figures(joints=4)
    with pytest.raises(InputError, match="limits must be a JointLimits for 4 joints, got str$"):
        figures.ratios("limits")
    with pytest.raises(InputError, match="limits must be a JointLimits for 4 joints, got 3 joints$"):
        figures.ratios(JointLimits.create(3, velocity=[1.0, 1.0, 1.0]))


def test_a_figure_exactly_at_the_feasibility_tolerance_is_no_violation():
    """The one definition of feasibility: ratio <= 1 + tolerance and position within tolerance [rad]
    of its range hold with equality (limits 1 and the bounds reached 0: the differences are exact in floats)."""
    from planner.limits import FEASIBILITY_TOLERANCE as TOL
    at = 1.0 + TOL
    figures = KinematicFigures(np.full((3, 2), at), np.zeros((3, 2)), np.array([-TOL, 0.0]),
                               np.array([0.0, TOL]), np.zeros(2), 1.0)
    limits = JointLimits.create(2, lower=[0.0, -1.0], upper=[1.0, 0.0], velocity=[1.0, 1.0],
                                acceleration=[1.0, 1.0], jerk=[1.0, 1.0])
    assert figures.ratios(limits).max() == at
    assert figures.violations(limits) == []
    beyond = np.nextafter(at, 2.0)
    over = KinematicFigures(np.full((3, 2), beyond), np.zeros((3, 2)), np.array([np.nextafter(-TOL, -1), 0.0]),
                            np.array([0.0, np.nextafter(TOL, 1)]), np.zeros(2), 1.0)
    assert len(over.violations(limits)) == 3 * 2 + 2


def _dense(coefficients, durations, order, samples=4001):
    """(S, J) min and max of q^(order) on each segment by dense sampling of numpy's polyval."""
    s = np.linspace(0.0, 1.0, samples)
    low, high = [], []
    for c, h in zip(coefficients, durations):
        values = np.stack([P.polyval(s * h, P.polyder(c[j], order)) for j in range(c.shape[0])])
        low.append(values.min(axis=1))
        high.append(values.max(axis=1))
    return np.array(low), np.array(high)


@pytest.mark.parametrize("joints", [2, 6])
@pytest.mark.parametrize("name", ["cubic", "hybrid", "quintic"])
def test_segment_extrema_hold_the_extremes_of_every_segment(name, joints):
    """segment_extrema (the NLP's certificates read it) against numpy and dense sampling: every
    candidate lies in [0, 1], its value is q^(d)(s h), and the candidates' min and max are the
    segment's extremes (equal to segment_ranges')."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)[:5, :joints]
    family = get_family(name)
    durations = np.random.default_rng(3).uniform(0.5, 3.0, family.segment_count(len(via)))
    trajectory = family.build(via, durations)
    c, h = trajectory.coefficients[None], trajectory.durations[None]
    orders = (0, 1, 2, 3)
    locations, values = segment_extrema(c, h, orders)
    low, high = segment_ranges(c, h, orders)
    assert locations.shape[:4] == values.shape[:4] == (4, 1, trajectory.segment_count, trajectory.joint_count)
    assert np.all((locations >= 0.0) & (locations <= 1.0))
    for k, order in enumerate(orders):
        for seg in range(trajectory.segment_count):
            for j in range(trajectory.joint_count):
                derivative = P.polyder(trajectory.coefficients[seg, j], order)
                expected = P.polyval(locations[k, 0, seg, j] * trajectory.durations[seg], derivative)
                scale = max(np.abs(expected).max(), 1e-12)
                np.testing.assert_allclose(values[k, 0, seg, j], expected, rtol=0, atol=1e-9 * scale)
        dense_low, dense_high = _dense(trajectory.coefficients, trajectory.durations, order)
        scale = np.maximum(np.abs(dense_low), np.abs(dense_high)).max()
        np.testing.assert_allclose(values[k, 0].min(axis=-1), dense_low, rtol=0, atol=1e-6 * scale)
        np.testing.assert_allclose(values[k, 0].max(axis=-1), dense_high, rtol=0, atol=1e-6 * scale)
        assert np.all(values[k, 0].min(axis=-1) <= dense_low + 1e-12 * scale)
        assert np.all(values[k, 0].max(axis=-1) >= dense_high - 1e-12 * scale)
        np.testing.assert_allclose(values[k, 0].min(axis=-1), low[k, 0], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(values[k, 0].max(axis=-1), high[k, 0], rtol=0, atol=1e-12 * scale)


# Cubics with three real roots in [0, 1], two of them 1e-9 to 1e-8 apart: the trigonometric method's
# arccos argument 3 Q / (P r) rounds to just beyond +1 or -1 (found by a random search), so only its
# clipping to [-1, 1] keeps the roots, among them the simple one (an extreme of the segment).
NEAR_DOUBLE_CUBICS = [
    ("-0x1.a4173db361897p-5", "0x1.3388ae1f4d17ep-1", "-0x1.0a2874742feb2p+1", "0x1.c80bb9e58ae40p+0"),  # +1
    ("-0x1.b53569cd4fb2ap-5", "0x1.894d076a9e0b2p-2", "-0x1.a2e0c944f69a3p-1", "0x1.16b4d084fe0c0p-1"),  # -1
]


@pytest.mark.parametrize("hex_coefficients", NEAR_DOUBLE_CUBICS)
def test_cubic_roots_keep_every_root_where_the_arccos_argument_rounds_past_one(hex_coefficients):
    from planner.kinematics import _cubic_roots
    p = np.array([float.fromhex(x) for x in hex_coefficients])
    d, c, b, a = p
    big_b, big_c, big_d = b / a, c / a, d / a
    pp = big_c - big_b * big_b / 3.0
    qq = 2.0 * big_b ** 3 / 27.0 - big_b * big_c / 3.0 + big_d
    assert 4.0 * pp ** 3 + 27.0 * qq * qq < 0.0 and abs(3.0 * qq / (pp * 2.0 * np.sqrt(-pp / 3.0))) > 1.0
    expected = np.sort(P.polyroots(p).real)
    assert np.all((expected > 0) & (expected < 1))
    for found in (_cubic_roots(p), column_roots(p[None, None, None])[0, 0, 0]):
        assert not np.isnan(found).any()
        np.testing.assert_allclose(np.sort(found), expected, atol=1e-7)  # the close pair to about sqrt(eps)


@pytest.mark.parametrize("lead", [2e-7, 5e-7, 9e-7])
def test_a_dropped_leading_coefficient_is_corrected_by_the_newton_step(lead):
    """-0.3 + 1.7 s - 2 s^2 + lead s^3 with lead below 1e-6 of the largest coefficient: the closed form
    solves the quadratic (roots 0.25 and 0.6, about 1e-7 off), and the Newton step on the full cubic
    brings them to numpy's roots within 1e-11."""
    from planner.kinematics import _cubic_roots
    p = np.array([-0.3, 1.7, -2.0, lead])
    expected = P.polyroots(p).real
    expected = np.sort(expected[(expected > 0) & (expected < 1)])
    assert len(expected) == 2 and abs(expected[1] - 0.6) > 1e-8  # the quadratic's root is measurably off
    for found in (_cubic_roots(p), column_roots(p[None, None, None])[0, 0, 0]):
        inside = np.sort(found[(found > 0) & (found < 1)])
        np.testing.assert_allclose(inside, expected, rtol=0, atol=1e-11)


@pytest.mark.parametrize("layout", ["batch", "columns", "joints"])
def test_column_roots_deflate_a_root_at_one_by_each_polynomials_own_scale(layout):
    """A root at s = 1 is divided out where p(1 - u)'s low coefficients are negligible against the
    polynomial's own coefficients. Beside a polynomial 1e6 times larger with a triple root at 1 (in
    the same batch, column or joint set), a unit-sized one with a root 1e-6 from 1 keeps that root:
    its value at 1, 5.6e-6, is not negligible for it (mutmut: the scale taken over the batch, the
    columns or the joints lost it). Independent: numpy's roots of each polynomial."""
    large = 1e6 * P.polyfromroots([1, 1, 1, 0.5, -2])
    small = P.polyfromroots([1 - 1e-6, 0.3, 0.6, -3, -4])
    axis = {"batch": 0, "columns": 1, "joints": 2}[layout]
    shape = [1, 1, 1, len(small)]
    shape[axis] = 2
    p = np.moveaxis(np.stack((large, small))[:, None, None, :], 0, axis).reshape(shape)
    found = np.moveaxis(column_roots(p), axis, 0)[1].ravel()
    found = np.sort(found[np.isfinite(found)])
    expected = np.sort([r.real for r in np.roots(small[::-1]) if abs(r.imag) < 1e-12 and 0 <= r.real <= 1])
    assert found.shape == expected.shape == (3,)
    assert np.allclose(found, expected, rtol=0, atol=1e-9)


# Found by a mutation run (mutmut 3.8.1, session 49): continuity_breaks' tolerance knot by knot, Break's pickling,
# via_point_misses' fields.

P = np.polynomial.polynomial
EPS = np.finfo(float).eps


def _allowances(coefficients, durations):
    """The tolerance continuity_breaks documents, computed here from its docstring: per order d (0, 1, 2),
    FEASIBILITY_TOLERANCE times the order's scale (the largest sum_i |c_i^(d)| h^i over segments and
    joints, at least 1 rad for positions) plus ROUNDING_ULPS eps |q|_j / h^d, with |q|_j the joint's largest
    |c_0| and h the shorter segment at a knot (the first segment at the start, the last at the end).
    Returns {d: (S + 1, J)}: at the start, each interior knot, the end."""
    segments, joints, _ = coefficients.shape
    magnitude = np.abs(coefficients[..., 0]).max(axis=0)
    at = np.r_[durations[0], np.minimum(durations[:-1], durations[1:]), durations[-1]]
    found = {}
    for d in range(3):
        bound = max(np.sum(np.abs(P.polyder(coefficients[k, j], d)) * durations[k] ** np.arange(
            coefficients.shape[-1] - d)) for k in range(segments) for j in range(joints))
        scale = max(bound, 1.0) if d == 0 else bound
        found[d] = FEASIBILITY_TOLERANCE * scale + ROUNDING_ULPS * EPS * magnitude[None, :] / at[:, None] ** d
    return found


def _lines(trajectory):
    """{(joint, quantity, where): Break}, where a knot index or 'start' / 'end'."""
    found = {}
    for line in continuity_breaks(trajectory):
        knot = re.search(r"at knot (\d+) ", line)
        where = int(knot.group(1)) if knot else ("start" if "at the start" in line else "end")
        assert line.joint == f"joint{line.joint_index + 1}"
        found[(line.joint_index, line.quantity, where)] = line
    return found


def test_each_break_is_held_to_the_rounding_of_its_own_knot():
    """A small motion 100 rad from zero in segments of 0.05, 0.01, 0.4 and 1 s: the rounding term,
    eps |q| / h^d, dominates every velocity and acceleration tolerance, and differs from knot to knot (the
    start's h is not knot 1's, nor the end's the last knot's). Joint 1 jumps at knot 1, joint 0 first at
    knot 2 (its second segment continues its first to the second derivative), and both move at the start
    and the end: each break's tolerance is that of its own knot, or end, and its value the jump."""
    durations = np.array([0.05, 0.01, 0.4, 1.0])
    rng = np.random.default_rng(11)
    coefficients = np.zeros((4, 2, 6))
    coefficients[..., 1:] = rng.uniform(-1e-6, 1e-6, (4, 2, 5))
    coefficients[..., 0] = 100.0 + rng.uniform(-1e-4, 1e-4, (4, 2))       # position jumps: 1e-9 of 100 rad
    coefficients[0, :, 1:3] = [[1e-5, -1e-5], [-2e-5, 1.5e-5]]                # moving at the start
    # joint 0, segment 1: segment 0's polynomial from tau = h_0 on, plus powers 3 and up (C2 at knot 1)
    coefficients[1, 0, :3] = [P.polyval(durations[0], P.polyder(coefficients[0, 0], d)) / np.prod(np.arange(1, d + 1))
                              for d in range(3)]
    trajectory = PiecewisePolynomial(durations, coefficients, np.array([0, 1, 2, 3, 4]))
    allowed = _allowances(coefficients, durations)
    lines = _lines(trajectory)
    names = ("position", "velocity", "acceleration")
    expected = {(1, q, 1) for q in names} | {(0, q, 2) for q in names} | {
        (j, q, w) for j in (0, 1) for q in names[1:] for w in ("start", "end")}
    assert set(lines) == expected
    for (joint, quantity, where), line in lines.items():
        d = names.index(quantity)
        if where == "start":
            value, limit = coefficients[0, joint, d] * np.prod(np.arange(1, d + 1)), allowed[d][0, joint]
        elif where == "end":
            value = P.polyval(durations[-1], P.polyder(coefficients[-1, joint], d))
            limit = allowed[d][-1, joint]
        else:
            k = where
            value = P.polyval(durations[k - 1], P.polyder(coefficients[k - 1, joint], d)) - \
                coefficients[k, joint, d] * np.prod(np.arange(1, d + 1))
            limit = allowed[d][k, joint]
        assert abs(line.value) == pytest.approx(abs(value), rel=1e-6, abs=1e-13), (joint, quantity, where)
        assert line.limit == pytest.approx(limit, rel=1e-9), (joint, quantity, where)
        assert abs(value) > 10 * limit  # a break, far from its tolerance either way


@pytest.mark.parametrize("order, jump, is_break", [
    (0, 0.5e-9, False), (0, 2e-9, True),        # positions: 1e-9 of at least 1 rad, whatever the motion
    (1, 1e-10, True), (2, 1e-10, True),         # a slow motion's velocity and acceleration: 1e-9 of theirs
])
def test_a_small_motion_near_zero_is_held_to_its_own_scale_but_positions_to_at_least_1_rad(order, jump, is_break):
    """Positions within 1e-3 rad of zero, velocities and accelerations about 1e-3: a position jump is
    measured against 1e-9 rad (the 1 rad floor), a velocity or acceleration jump against 1e-9 of the
    motion's own (no floor)."""
    durations = np.array([1.0, 1.0])
    coefficients = np.zeros((2, 1, 4))
    coefficients[0, 0] = [0.0, 0.0, 1e-3, -5e-4]
    # the second segment continues the first (to its second derivative) at knot 1
    coefficients[1, 0] = [P.polyval(1.0, coefficients[0, 0]), P.polyval(1.0, P.polyder(coefficients[0, 0])),
                          P.polyval(1.0, P.polyder(coefficients[0, 0], 2)) / 2, 2e-4]
    quantity = ("position", "velocity", "acceleration")[order]
    assert (0, quantity, 1) not in _lines(PiecewisePolynomial(durations, coefficients, np.array([0, 1, 2])))
    coefficients[1, 0, order] += jump / np.prod(np.arange(1, order + 1))
    lines = _lines(PiecewisePolynomial(durations, coefficients, np.array([0, 1, 2])))
    assert ((0, quantity, 1) in lines) == is_break
    if is_break:
        assert lines[(0, quantity, 1)].limit == pytest.approx(_allowances(coefficients, durations)[order][1, 0],
                                                              rel=1e-9)


def test_a_break_pickles_whole():
    """A check run in a worker process returns its lines whole: the text with the fields."""
    coefficients = np.zeros((2, 1, 2))
    coefficients[:, 0, 0] = [0.0, 0.5]
    (line,) = continuity_breaks(PiecewisePolynomial(np.ones(2), coefficients, np.array([0, 1, 2])))
    copy = pickle.loads(pickle.dumps(line))
    assert str(copy) == str(line) == "joint joint1 position jumps by 28.6479 deg at knot 1 (t = 1 s)"
    fields = ("joint", "joint_index", "quantity", "value", "limit")
    assert [getattr(copy, field) for field in fields] == [getattr(line, field) for field in fields]


def test_a_missed_via_point_is_named_once_per_joint_with_its_fields_against_2e_9_of_at_least_1_rad():
    """Linear segments through 0.5, -0.5 and 5 rad at 0, 1 and 3 s; the via-points given are moved off
    them: joint 0 by 1.5e-9 rad at via-point 1 (within 2e-9 of 1 rad, the floor under |0.5 rad|), joint 1
    by 3e-9 rad at via-point 1 (a miss) and by 5e-9 rad at via-point 2, which a 5 rad via-point allows (1e-8)."""
    coefficients = np.zeros((2, 2, 2))
    coefficients[0, :, 0], coefficients[0, :, 1] = [0.5, 0.5], [-1.0, -1.0]        # 0.5 -> -0.5 in 1 s
    coefficients[1, :, 0], coefficients[1, :, 1] = [-0.5, -0.5], [2.75, 2.75]      # -0.5 -> 5 in 2 s
    trajectory = PiecewisePolynomial(np.array([1.0, 2.0]), coefficients, np.array([0, 1, 2]))
    via = trajectory.evaluate(trajectory.via_times)                              # exactly on the trajectory
    np.testing.assert_allclose(via, [[0.5, 0.5], [-0.5, -0.5], [5.0, 5.0]], rtol=1e-15)
    assert via_point_misses(trajectory, via) == []
    via[1, 0] += 1.5e-9
    via[1, 1] += 3e-9
    via[2, 1] += 5e-9
    (line,) = via_point_misses(trajectory, via.tolist())
    assert str(line) == f"joint joint2 misses via-point 1 by {np.rad2deg(3e-9):.6g} deg (t = 1 s)"
    assert (line.joint, line.joint_index, line.quantity) == ("joint2", 1, "position")
    assert line.value == pytest.approx(3e-9, rel=1e-6) and line.limit == pytest.approx(2e-9, rel=1e-12)
    assert [str(m) for m in via_point_misses(trajectory, via, ["a", "b"])] == [str(line).replace("joint2", "b")]
    via[1, 1] = -0.5 + 1e-9                                                      # joint 1 now misses at 2 only
    via[2, 1] = 5.0 + 2e-8
    (line,) = via_point_misses(trajectory, via)
    assert line.startswith("joint joint2 misses via-point 2 by ") and line.limit == pytest.approx(1e-8, rel=1e-12)
