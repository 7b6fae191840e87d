import pickle
from math import factorial

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.integrate import quad

from conftest import via_and_durations
from planner import JointLimits, get_family, kinematic_figures, paper, time_scale_factor
from planner.kinematics import batch_scale_factors, column_roots, continuity_breaks, max_abs
from planner.limits import in_degrees_apart, seconds_text
from planner.splines import PiecewisePolynomial

# Reference maxima, computed independently of this code: hybrid spline, Table II via-points, Table IV
# durations [deg/s^k].
REFERENCE_MAX = np.array([
    [32.110, 22.713, 33.579, 49.996, 27.922, 20.286],
    [12.854, 11.525, 17.546, 28.088, 15.536, 8.544],
    [5.866, 5.482, 8.256, 14.109, 7.564, 3.222],
])
REFERENCE_MEAN_VELOCITY = np.array([8.245, 5.697, 15.237, 13.370, 10.534, 6.182])


def test_spec_reference_table(paper_via):
    figures = kinematic_figures(get_family("hybrid").build(paper_via, paper.DURATIONS_S))
    np.testing.assert_allclose(np.rad2deg(figures.max_abs), REFERENCE_MAX, atol=1e-3 / 2 + 1e-9)
    np.testing.assert_allclose(np.rad2deg(figures.mean_abs[0]), REFERENCE_MEAN_VELOCITY, atol=1e-3 / 2 + 1e-9)


def test_spec_ratios_of_paper_and_all_three_seconds(paper_via, paper_limits):
    family = get_family("hybrid")
    paper_ratios = kinematic_figures(family.build(paper_via, paper.DURATIONS_S)).ratios(paper_limits)
    assert paper_ratios.max() <= 0.40 + 5e-3
    threes = kinematic_figures(family.build(paper_via, np.full(9, 3.0))).ratios(paper_limits)
    assert threes.max() == pytest.approx(0.827, abs=5e-4)


def dense_extrema(pp, per_segment=20001):
    """Sampled max |q^(d)| (3, J) and position range with many samples on every segment."""
    s = np.linspace(0.0, 1.0, per_segment)
    knots = pp.knot_times
    times = np.concatenate([knots[k] + s * pp.durations[k] for k in range(pp.segment_count)])
    values = [pp.evaluate(np.minimum(times, pp.total_time), order) for order in range(4)]
    return np.stack([np.abs(v).max(axis=0) for v in values[1:]]), values[0].min(axis=0), values[0].max(axis=0)


@pytest.mark.parametrize("name", ["cubic", "hybrid", "quintic"])
@given(data=via_and_durations("cubic", max_points=6))
def test_exact_extrema_bound_dense_sampling(name, data):
    via, _ = data
    family = get_family(name)
    h = np.random.default_rng(len(via) * 7).uniform(0.3, 4.0, family.segment_count(len(via)))
    pp = family.build(via, h)
    figures = kinematic_figures(pp)
    sampled, low, high = dense_extrema(pp)
    exact = figures.max_abs
    scale = exact.max(axis=1, keepdims=True)
    assert np.all(sampled <= exact + 1e-9 * scale)
    assert np.all(sampled >= exact - 1e-6 * np.maximum(exact, 1e-3 * scale))
    assert np.all(low >= figures.position_min - 1e-9) and np.all(high <= figures.position_max + 1e-9)
    np.testing.assert_allclose(low, figures.position_min, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(high, figures.position_max, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("name", ["cubic", "hybrid", "quintic"])
def test_mean_magnitudes_and_jerk_energy_match_quadrature(name, paper_via):
    family = get_family(name)
    h = np.random.default_rng(5).uniform(1.0, 4.0, family.segment_count(len(paper_via)))
    pp = family.build(paper_via, h)
    figures = kinematic_figures(pp)
    knots = pp.knot_times
    for j in (0, 3):
        for order in (1, 2, 3):
            total = sum(quad(lambda t: abs(pp.evaluate([t], order)[0, j]), knots[k], knots[k + 1],
                             limit=200, epsabs=1e-13, epsrel=1e-12)[0] for k in range(pp.segment_count))
            assert figures.mean_abs[order - 1, j] == pytest.approx(total / pp.total_time, rel=1e-8)
        energy = sum(quad(lambda t: pp.evaluate([t], 3)[0, j] ** 2, knots[k], knots[k + 1],
                          epsabs=1e-13, epsrel=1e-12)[0] for k in range(pp.segment_count))
        assert figures.jerk_energy[j] == pytest.approx(energy, rel=1e-8)


@given(st.floats(0.2, 5.0))
def test_time_scaling_divides_ratios_by_powers_of_s(scale):
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    limits = paper.paper_limits()
    h = np.random.default_rng(2).uniform(1, 4, 9)
    base = kinematic_figures(get_family("hybrid").build(via, h)).ratios(limits)
    scaled = kinematic_figures(get_family("hybrid").build(via, scale * h)).ratios(limits)
    np.testing.assert_allclose(scaled * scale ** np.array([1, 2, 3])[:, None], base, rtol=1e-8)


def test_scale_factor_makes_trajectory_feasible_and_tight(paper_via, paper_limits):
    family = get_family("hybrid")
    durations = np.random.default_rng(4).uniform(0.2, 6.0, (10, 9))
    ratios, factors = batch_scale_factors(family.build_batch(paper_via, durations), durations, paper_limits)
    assert factors.shape == (10,)
    for h, s in zip(durations, factors):
        repaired = kinematic_figures(family.build(paper_via, s * h)).ratios(paper_limits)
        assert repaired.max() == pytest.approx(1.0, rel=1e-9)
    np.testing.assert_allclose(time_scale_factor(ratios), factors)


def test_absent_limits_give_zero_ratio(paper_via):
    limits = JointLimits.create(6, velocity=np.ones(6))
    c = get_family("cubic").build_batch(paper_via, np.ones((1, 9)))
    ratios = limits.ratios(max_abs(c, np.ones((1, 9))))
    assert np.all(ratios[0, 1:] == 0) and np.all(ratios[0, 0] > 0)


@st.composite
def roots_in_and_out(draw):
    """(roots inside [0.02, 0.98], roots in [1.5, 3]) of a polynomial of degree 1 to 6, drawn as arrays."""
    degree = draw(st.integers(1, 6))
    count = draw(st.integers(0, degree))
    inside = draw(hnp.arrays(float, count, elements=st.floats(0.02, 0.98)))
    return inside, draw(hnp.arrays(float, degree - count, elements=st.floats(1.5, 3.0)))


@given(roots_in_and_out(), st.integers(0, 3), st.booleans(), st.floats(0.5, 2.0))
def test_column_roots_match_numpy(roots, rest_multiplicity, at_one, factor):
    """Roots in [0, 1], also with a multiple root at an end (the deflation path): every root inside is
    found, and nothing else. A root of multiplicity m (drawn roots that coincide, or nearly) is found to
    about the m-th root of the rounding (double precision: 1.5e-8 for m = 2, 6e-6 for m = 3), and once
    at least: for extremes, its place is what counts (a triple root found once was taken for a miss)."""
    inside, others = roots
    ends = np.full(rest_multiplicity, 1.0 if at_one else 0.0)
    coefficients = np.polynomial.polynomial.polyfromroots(np.concatenate((inside, others, ends)))
    found = column_roots((coefficients * factor)[None, None, None])[0, 0, 0]
    found = found[~np.isnan(found)]
    found = found[(found > 1e-6) & (found < 1 - 1e-6)]  # end points are candidates anyway

    def tolerance(root: float) -> float:
        multiplicity = int(np.sum(np.abs(inside - root) < 1e-3))
        return 1e-7 if multiplicity <= 1 else 10 * np.finfo(float).eps ** (1 / multiplicity)
    for root in inside:
        assert np.abs(found - root).min(initial=np.inf) <= tolerance(root), (root, found)
    for root in found:
        nearest = inside[np.argmin(np.abs(inside - root))] if len(inside) else np.nan
        assert abs(root - nearest) <= tolerance(nearest), (root, inside)


def test_violations_name_joint_quantity_value_and_limit_in_degrees(paper_via):
    names = ("waist", "shoulder", "elbow", "wrist1", "wrist2", "wrist3")
    limits = JointLimits.create(6, velocity=np.full(6, 0.1), lower=np.full(6, -1.0), upper=np.full(6, 3.0),
                                names=names)
    trajectory = get_family("hybrid").build(paper_via, np.full(9, 3.0))
    found = kinematic_figures(trajectory).violations(limits)
    lines = [str(violation) for violation in found]
    for violation in found:  # the structured fields say what the line says
        assert violation.joint == names[violation.index] and violation.joint in str(violation)
        assert (abs(violation.value) > violation.limit) if violation.order else \
            (violation.value < violation.limit if violation.side == "lower" else violation.value > violation.limit)
    dense = np.linspace(0.0, trajectory.total_time, 200_001)  # an independent, sampled maximum
    fastest = np.rad2deg(np.abs(trajectory.evaluate(dense, 1)).max(axis=0))
    lowest = np.rad2deg(trajectory.evaluate(dense).min(axis=0))
    for j, name in enumerate(names):
        if fastest[j] > np.rad2deg(0.1):
            line = next(line for line in lines if line.startswith(f"joint {name} velocity"))
            value = float(line.split()[3])
            assert value == pytest.approx(fastest[j], rel=1e-5) and line.endswith("exceeds its limit 5.72958 deg/s")
        if lowest[j] < -np.rad2deg(1.0):
            line = next(line for line in lines if line.startswith(f"joint {name} position"))
            assert float(line.split()[3]) == pytest.approx(lowest[j], rel=1e-5)
            assert line.endswith("is below its lower limit -57.2958 deg")
    assert len(lines) == np.sum(fastest > np.rad2deg(0.1) * (1 + 1e-9)) + np.sum(lowest < -np.rad2deg(1.0)) + \
        np.sum(np.rad2deg(trajectory.evaluate(dense).max(axis=0)) > np.rad2deg(3.0))


@pytest.mark.parametrize("kwargs, message", [
    ({"velocity": [1, 0, 1]}, "velocity limit of joint joint2 is 0 deg/s"),
    ({"jerk": [1, 1, -1]}, "jerk limit of joint joint3 is -57.2958 deg/s"),
    ({"acceleration": [1, 1]}, "need 3 values"),
    ({"velocity": [1, np.nan, 1]}, r"velocity limits\[1\] is NaN"),
    ({"lower": [0, 0, 0], "upper": [1, -1, 1]}, "joint joint2 position range"),
])
def test_bad_limits(kwargs, message):
    from planner import InputError
    with pytest.raises(InputError, match=message):
        JointLimits.create(3, **kwargs)


@pytest.mark.parametrize("call, message", [
    (lambda: JointLimits.create(2, velocity="fast"), "velocity limits must be numeric"),
    (lambda: JointLimits.create(-1), "joint count must be a whole number from 1 to 10000, got -1"),
    (lambda: JointLimits.create("3"), "joint count must be a whole number from 1 to 10000, got '3'"),
    (lambda: JointLimits.create(2, velocity=[1, 1]).ratios(np.ones((3, 5))), r"shape \(\.\.\., 3, 2\)"),
    (lambda: time_scale_factor(np.ones(3)), r"shape \(\.\.\., 3, J\)"),
    (lambda: time_scale_factor(np.ones((3, 0))), r"shape \(\.\.\., 3, J\)"),
    (lambda: time_scale_factor("abc"), "ratios must be numeric"),
    (lambda: time_scale_factor(np.full((3, 2), np.nan)), "numbers >= 0, got nan"),
    (lambda: time_scale_factor(-np.ones((3, 2))), "numbers >= 0, got -1"),
    (lambda: kinematic_figures("x"), "takes a PiecewisePolynomial, not str"),
])
def test_bad_arguments_from_python_are_input_errors(call, message):
    from planner import InputError
    with pytest.raises(InputError, match=message):
        call()


@pytest.mark.parametrize("excess", [1e-6, 0.01, 0.5])
def test_a_limit_exceeded_by_any_margin_is_a_violation(paper_via, excess):
    """Limits at the exact maxima hold; limits a fraction below them are each reported."""
    trajectory = get_family("hybrid").build(paper_via, np.full(9, 3.0))
    figures = kinematic_figures(trajectory)
    exact = JointLimits.create(6, lower=figures.position_min, upper=figures.position_max,
                               velocity=figures.max_abs[0], acceleration=figures.max_abs[1], jerk=figures.max_abs[2])
    assert figures.violations(exact) == []
    shrink = 1 - excess
    centre = (figures.position_min + figures.position_max) / 2
    half = (figures.position_max - figures.position_min) / 2 * shrink
    tight = JointLimits.create(6, lower=centre - half, upper=centre + half, velocity=figures.max_abs[0] * shrink,
                               acceleration=figures.max_abs[1] * shrink, jerk=figures.max_abs[2] * shrink)
    lines = figures.violations(tight)
    assert len(lines) == 5 * 6  # three magnitudes and both sides of the range, every joint


def test_the_quantity_table_agrees_with_the_maths_and_the_outputs(paper_via, tmp_path):
    """Each quantity's order is the power by which time scaling divides it; its names are the ones
    task files, summary.json and trajectory.csv use."""
    from planner.export import write_trajectory_csv
    from planner.limits import LIMITED, PROFILE_QUANTITIES
    trajectory = get_family("hybrid").build(paper_via, np.full(9, 3.0))
    slower = get_family("hybrid").build(paper_via, np.full(9, 6.0))
    times = np.linspace(0.0, trajectory.total_time, 2001)
    for quantity in PROFILE_QUANTITIES:
        fast = np.abs(trajectory.evaluate(times, quantity.order)).max()
        slow = np.abs(slower.evaluate(2 * times, quantity.order)).max()
        assert slow == pytest.approx(fast / 2 ** quantity.order, rel=1e-9)
        assert quantity.key == f"{quantity.name}_{quantity.degree_unit.replace('/', '_').replace('^', '')}"
    assert [q.name for q in LIMITED] == ["velocity", "acceleration", "jerk"]
    write_trajectory_csv(tmp_path / "t.csv", trajectory, 10.0, ["a", "b", "c", "d", "e", "f"])
    header = (tmp_path / "t.csv").read_text().splitlines()[0].split(",")
    assert header[1::6] == [f"{q.column}_a_{q.key_unit}" for q in PROFILE_QUANTITIES]  # joint a of each block


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5, 6])
@pytest.mark.parametrize("scale", [1e-6, 1e-3, 1.0, 1e3])
def test_column_roots_do_not_depend_on_the_polynomials_scale(degree, scale):
    """Roots of k p are those of p, however small or large k (a joint that barely moves)."""
    rng = np.random.default_rng(degree)
    inside = np.sort(rng.uniform(0.05, 0.95, max(degree - 1, 1)))[:degree]
    p = np.polynomial.polynomial.polyfromroots(np.concatenate((inside, rng.uniform(2, 3, degree - len(inside)))))
    found = column_roots((p * scale)[None, None, None])[0, 0, 0]
    np.testing.assert_allclose(np.sort(found[~np.isnan(found)]), inside, atol=1e-7)


@pytest.mark.parametrize("real_root", [0.35, 0.8])
def test_column_roots_with_complex_conjugate_pairs(real_root):
    """A cubic (closed form) and a quintic (eigenvalues) with one real root in [0, 1] and complex pairs."""
    for roots in ([real_root, 1.2 + 0.05j, 1.2 - 0.05j], [real_root, 0.5 + 0.3j, 0.5 - 0.3j, -1 + 2j, -1 - 2j]):
        p = np.polynomial.polynomial.polyfromroots(roots).real
        found = column_roots(p[None, None, None])[0, 0, 0]
        np.testing.assert_allclose(found[~np.isnan(found)], [real_root], atol=1e-9)


def test_column_roots_of_mixed_degrees_in_one_column():
    """Cubic, quadratic, linear and constant polynomials side by side (joints of one column), each
    compared with numpy's roots."""
    cubic = np.polynomial.polynomial.polyfromroots([0.2, 0.6, 2.0])
    quadratic = np.concatenate((np.polynomial.polynomial.polyfromroots([0.45, -1.0]), [0.0]))
    linear = np.array([-0.7, 1.0, 0.0, 0.0])
    constant = np.array([2.0, 0.0, 0.0, 0.0])
    found = column_roots(np.stack((cubic, quadratic, linear, constant))[None, None])[0, 0]
    for roots, expected in zip(found, ([0.2, 0.6], [0.45], [0.7], [])):
        np.testing.assert_allclose(np.sort(roots[~np.isnan(roots)]), expected, atol=1e-9)


def test_extremes_of_segments_of_mixed_degree_match_dense_sampling():
    """A constant first segment, then a cubic, then an all-zero one: max |q'|, |q''|, |q'''| and the
    position range agree with dense sampling."""
    from conftest import dense_extremes
    from planner.splines import PiecewisePolynomial
    coefficients = np.zeros((3, 2, 4))
    coefficients[0, :, 0] = [0.5, -0.2]
    coefficients[1, :, :] = [[0.5, 0.0, 0.9, -0.4], [-0.2, 0.3, -0.1, 0.05]]
    trajectory = PiecewisePolynomial(np.array([1.0, 2.0, 0.5]), coefficients, np.array([0, 1, 2, 3]))
    figures = kinematic_figures(trajectory)
    largest, low, high = dense_extremes(trajectory, per_segment=20001)  # a sample at a knot takes the next segment
    assert np.all(figures.max_abs >= largest * (1 - 1e-9)) and np.all(figures.max_abs <= largest * 1.001)
    assert np.all(figures.position_min <= low + 1e-12) and np.all(figures.position_min >= low - 1e-3)
    assert np.all(figures.position_max >= high - 1e-12) and np.all(figures.position_max <= high + 1e-3)


def test_a_position_violation_reads_above_or_below_and_the_tolerance_is_exact(paper_via):
    trajectory = get_family("hybrid").build(paper_via, paper.DURATIONS_S)
    figures = kinematic_figures(trajectory)
    top = figures.position_max[2]
    for beyond, expected in ((0.75e-9, []), (1.5e-9, ["upper"])):
        limits = JointLimits.create(6, upper=np.where(np.arange(6) == 2, top - beyond, np.inf))
        found = figures.violations(limits)
        assert [v.side for v in found] == expected
    (violation,) = found
    assert (violation.quantity, violation.order, violation.index) == ("position", 0, 2)
    value, limit = in_degrees_apart(top, top - 1.5e-9, 0)  # as many digits as it takes to tell them apart
    assert str(violation) == f"joint joint3 position {value} is above its upper limit {limit}"
    assert value != limit


def test_a_duration_reads_with_its_digits_however_short():
    """Total times print to 4 decimals, but a 9.9e-6 s trajectory read "T = 0.0000 s" (sweep 21)."""
    assert [seconds_text(t) for t in (17.31280004, 0.5, 0.001, 9.9e-6)] == ["17.3128", "0.5000", "0.0010", "9.9e-06"]
    assert seconds_text(2.5e-4, 3) == "0.00025" and seconds_text(0.0125, 3) == "0.013"


# ------------------------------------------------------------ roots against numpy's (from a mutation run)

def _inside(found: np.ndarray) -> np.ndarray:
    """The real roots strictly inside (0, 1), sorted."""
    found = np.sort(found[~np.isnan(found)])
    return found[(found > 1e-9) & (found < 1 - 1e-9)]


def test_a_linear_column_beside_a_cubic_has_its_own_root():
    """Slope 2 (a slope of 1 hid a multiplication where the root divides)."""
    cubic = np.polynomial.polynomial.polyfromroots([0.2, 0.6, 2.0])
    found = column_roots(np.stack((cubic, [-1.4, 2.0, 0.0, 0.0]))[None, None])[0, 0]
    np.testing.assert_allclose(_inside(found[0]), [0.2, 0.6], atol=1e-9)
    np.testing.assert_allclose(_inside(found[1]), [0.7], atol=1e-12)


def test_a_column_of_mixed_degrees_with_a_still_joint_first():
    """A joint that never moves (all zero) before a quintic and a quadratic padded to width 6: each keeps
    exactly its own roots (the floor and scale of the eigenvalue solver are per joint)."""
    quintic = np.polynomial.polynomial.polyfromroots([0.2, 0.5, 0.7, 2.0, -1.0]) * -0.8
    quadratic = np.concatenate((np.polynomial.polynomial.polyfromroots([0.35, -2.0]) * 3.0, np.zeros(3)))
    found = column_roots(np.stack((np.zeros(6), quintic, quadratic))[None, None])[0, 0]
    for roots, expected in zip(found, ([], [0.2, 0.5, 0.7], [0.35])):
        np.testing.assert_allclose(_inside(roots), expected, atol=1e-9)


@pytest.mark.parametrize("roots, expected", [([0.3, 1, 1, 1, 1], [0.3]), ([0.3, 0.8, 1, 1, 1, 1], [0.3, 0.8])])
def test_roots_at_the_segment_end_are_divided_out_down_to_a_linear_factor(roots, expected):
    polynomial = np.polynomial.polynomial.polyfromroots(roots) * 1.7
    np.testing.assert_allclose(_inside(column_roots(polynomial[None, None, None])[0, 0, 0]), expected, atol=1e-7)


@pytest.mark.parametrize("scale", [1e-9, 1e-12, 1e-15])
@pytest.mark.parametrize("degree", [4, 5, 6])
def test_tiny_polynomials_keep_their_roots(scale, degree):
    """The roots do not depend on the polynomial's scale, down to 1e-15."""
    rng = np.random.default_rng(degree)
    inside = np.sort(rng.uniform(0.05, 0.95, degree - 1))
    polynomial = np.polynomial.polynomial.polyfromroots(np.concatenate((inside, rng.uniform(2, 3, 1)))) * scale
    np.testing.assert_allclose(_inside(column_roots(polynomial[None, None, None])[0, 0, 0]), inside, atol=1e-7)


def test_figures_of_a_still_joint_raise_no_floating_point_warning():
    """A joint that never moves gives all-zero columns: the root finders divide by their zeros on purpose."""
    import warnings

    via = np.deg2rad([[15, 10, 5], [15, 40, -20], [15, -5, 30], [15, 20, 10]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in ("cubic", "hybrid", "quintic", "hermite7", "trigonometric"):
            family = get_family(name)
            kinematic_figures(family.build(via, np.full(family.segment_count(len(via)), 1.5)))


def test_total_time_and_the_lower_position_tolerance():
    via = np.deg2rad([[0, 10], [30, -20], [-10, 40]])
    trajectory = get_family("hybrid").build(via, np.full(4, 1.25))
    figures = kinematic_figures(trajectory)
    assert figures.total_time == pytest.approx(trajectory.durations.sum(), rel=1e-15)
    for beyond, sides in ((0.75e-9, []), (1.5e-9, ["lower"])):  # the tolerance is 1e-9 rad, as on the upper side
        limits = JointLimits.create(2, lower=[-np.inf, figures.position_min[1] + beyond])
        assert [v.side for v in figures.violations(limits)] == sides


@given(st.lists(st.floats(-2.0, 2.0), min_size=2 * (4 + 6 + 3), max_size=2 * (4 + 6 + 3)),
       st.lists(st.floats(0.2, 3.0), min_size=3, max_size=3))
def test_figures_of_segments_of_rising_then_falling_degree_match_independent_ones(values, durations):
    """A cubic segment, then a quintic, then a quadratic (two joints, padded to one width, the lower degree
    first), with coefficients and durations hypothesis draws: max |q^(d)| against dense sampling, the
    time-averaged |q^(d)| against scipy's quadrature (a mutation that dropped an axis in the choice of each
    segment's degree survived every other test)."""
    from planner.splines import PiecewisePolynomial
    coefficients = np.zeros((3, 2, 6))
    rest = np.array(values)
    for segment, degree in enumerate((3, 5, 2)):
        coefficients[segment, :, :degree + 1] = rest[:2 * (degree + 1)].reshape(2, degree + 1)
        rest = rest[2 * (degree + 1):]
    trajectory = PiecewisePolynomial(np.array(durations), coefficients, np.array([0, 1, 2, 3]))
    figures = kinematic_figures(trajectory)
    # Each segment sampled on its own closed interval, by numpy's polynomial algebra (a sample at a knot
    # through evaluate would take the next segment's value).
    largest = np.zeros((3, 2))
    for k, h in enumerate(durations):
        tau = np.linspace(0.0, h, 4001)
        for j in range(2):
            polynomial = np.polynomial.Polynomial(coefficients[k, j])
            for order in (1, 2, 3):
                largest[order - 1, j] = max(largest[order - 1, j], np.abs(polynomial.deriv(order)(tau)).max())
    scale = np.maximum(largest, 1e-9)
    assert np.all(figures.max_abs >= largest - 1e-9 * scale)
    assert np.all(figures.max_abs <= largest + 1e-3 * scale + 1e-9)
    knots = trajectory.knot_times
    for j in range(2):
        for order in (1, 2, 3):
            total = sum(quad(lambda t: abs(trajectory.evaluate([t], order)[0, j]), knots[k], knots[k + 1],
                             limit=200, epsabs=1e-12, epsrel=1e-10)[0] for k in range(3))
            assert figures.mean_abs[order - 1, j] == pytest.approx(total / trajectory.total_time, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("name", ["cubic", "hybrid", "quintic", "hermite7", "trigonometric"])
def test_extrema_with_a_via_point_at_the_zero_configuration_match_dense_sampling(name, paper_via):
    """Every joint at exactly 0 at one via-point (zero coefficients in patterns the root finder must not
    take for a lower degree)."""
    via = paper_via.copy()
    via[3] = 0.0
    family = get_family(name)
    trajectory = family.build(via, np.random.default_rng(11).uniform(1.0, 3.0, family.segment_count(len(via))))
    figures = kinematic_figures(trajectory)
    sampled, low, high = dense_extrema(trajectory)
    scale = figures.max_abs.max(axis=1, keepdims=True)
    assert np.all(sampled <= figures.max_abs + 1e-9 * scale)
    assert np.all(sampled >= figures.max_abs - 1e-6 * np.maximum(figures.max_abs, 1e-3 * scale))
    np.testing.assert_allclose(low, figures.position_min, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(high, figures.position_max, rtol=1e-6, atol=1e-9)


def test_a_figure_that_is_not_a_number_is_a_violation():
    """nan compares false with everything: it once passed every limit as feasible."""
    from planner.kinematics import KinematicFigures
    nan = np.full((3, 1), np.nan)
    figures = KinematicFigures(nan, nan, np.array([np.nan]), np.array([np.nan]), np.zeros(1), 1.0)
    limits = JointLimits.create(1, lower=[-1.0], upper=[1.0], velocity=[1.0], acceleration=[1.0], jerk=[1.0])
    found = figures.violations(limits)
    assert {v.quantity for v in found} == {"velocity", "acceleration", "jerk", "position"}


def test_a_cubic_with_a_leading_coefficient_near_rounding_keeps_its_roots():
    """v = 2 s - 4 s^3 + 5e-9 s^4 (a quintic's velocity): the closed-form cubic for its sign changes
    lost the root 1/sqrt(2) to cancellation, and the mean |v| came out as 3.3e-10 for 1/6 (hypothesis)."""
    from scipy.integrate import quad

    from planner.kinematics import _cubic_roots
    from planner.splines import PiecewisePolynomial
    for ratio in (1e-10, 1e-9, 3e-9, 1e-8, 3e-8, 1e-7, 1e-6, 1e-5):
        found = _cubic_roots(np.array([2.0, 0.0, -4.0, 4.0 * ratio]))
        true = np.roots([4.0 * ratio, -4.0, 0.0, 2.0]).real
        inside = true[(true > 0) & (true < 1)]
        assert np.nanmin(np.abs(found - inside[0])) < 1e-8, ratio
    coefficients = np.zeros((1, 1, 6))
    coefficients[0, 0, 2:] = [1.0, 0.0, -1.0, 1e-9]
    trajectory = PiecewisePolynomial(np.ones(1), coefficients, np.array([0, 1]))
    exact = quad(lambda t: abs(2 * t - 4 * t ** 3 + 5e-9 * t ** 4), 0, 1, points=[2 ** -0.5])[0]
    assert kinematic_figures(trajectory).mean_abs[0, 0] == pytest.approx(exact, rel=1e-9)


def test_a_violation_names_its_value_and_limit_apart():
    """A value a hair beyond its limit is printed with the digits that show it (1.3e-9 rad past a
    range read "25.5301 deg is above its upper limit 25.5301 deg"); a magnitude keeps its sign."""
    from planner.kinematics import Violation

    position = str(Violation("joint1", 0, "position", 0, 0.44558371809602954, 0.44558371678566416, "upper"))
    assert position == "joint joint1 position 25.5300665 deg is above its upper limit 25.5300664 deg"
    jerk = str(Violation("j", 0, "jerk", 3, -np.deg2rad(1e-4) * (1 + 1e-8), np.deg2rad(1e-4)))
    assert jerk == "joint j jerk -0.000100000001 deg/s^3 exceeds its limit 0.0001 deg/s^3"


@pytest.mark.parametrize("family", ["cubic", "hybrid", "quintic", "hermite7", "trigonometric"])
@given(data=st.data())
def test_every_family_is_continuous_and_rests_at_both_ends(family, data):
    """``continuity_breaks`` finds nothing in any family's spline (the exact check calls it: no false alarm)."""
    via, durations = data.draw(via_and_durations(family))
    assert continuity_breaks(get_family(family).build(via, durations)) == []


@pytest.mark.parametrize("change, said", [
    ((1, 0, 0, 0.5), "joint joint1 position jumps by 28.6479 deg at knot 1 (t = 1 s)"),
    ((2, 1, 1, 0.2), "joint joint2 velocity jumps by 11.4592 deg/s at knot 2 (t = 2 s)"),
    ((2, 1, 2, -0.4), "joint joint2 acceleration jumps by 45.8366 deg/s^2 at knot 2 (t = 2 s)"),
    ((0, 0, 1, 1e-3), "joint joint1 velocity is 0.0572958 deg/s at the start, where every trajectory rests"),
    ((3, 1, 3, 1e-3), "joint joint2 acceleration is 0.343775 deg/s^2 at the end, where every trajectory rests"),
])
def test_a_jump_at_a_knot_or_motion_at_an_end_is_named(change, said):
    """One coefficient changed: the trajectory jumps at a knot, or moves at an end (every family rests there).
    The exact check's limits bound each segment alone and did not see it."""
    trajectory = get_family("cubic").build([[0.0, 0.0], [0.5, -1.0], [1.0, 0.5]], [1.0] * 4)
    segment, joint, power, delta = change
    coefficients = np.array(trajectory.coefficients)
    coefficients[segment, joint, power] += delta
    broken = PiecewisePolynomial(trajectory.durations, coefficients, trajectory.via_knots)
    assert said in continuity_breaks(broken)
    assert continuity_breaks(trajectory) == []
    line = next(b for b in continuity_breaks(broken) if b == said)  # the fields an InfeasibleError carries
    quantity = said.split()[2]
    order = ("position", "velocity", "acceleration").index(quantity)
    assert (line.joint, line.joint_index, line.quantity) == (f"joint{joint + 1}", joint, quantity)
    assert 0 <= line.limit < abs(line.value)
    assert abs(line.value) == pytest.approx(abs(delta) * factorial(power) / factorial(power - order), rel=1e-9)
    assert pickle.loads(pickle.dumps(line)).value == line.value


@pytest.mark.parametrize("offset_deg, step_deg, limit_deg", [(170.0, 1e-7, 60.0), (99_999.0, 1e-4, 1e-4)])
def test_rounding_of_a_tiny_motion_far_from_zero_is_not_a_jump(offset_deg, step_deg, limit_deg):
    """Coefficients of order d carry rounding of about eps |q| / h^d: 1e-7 deg moves at 170 deg in 1 ms
    segments jumped 8e-12 deg/s, more than 1e-9 of their velocity, and the plan was refused (sweep 16).
    A real jump of the same trajectory, 1e-3 of its velocity scale, is still named."""
    from planner import plan
    from planner.task import make_task

    steps = np.array([[0, 0, 0], [1, -1, 1], [-1, 0.5, 2], [0, 0, 0]])
    task = make_task(joints_deg=(offset_deg * np.array([1, -1, 1]) + step_deg * steps).tolist(),
                     limits={key: [limit_deg] * 3 for key in ("velocity_deg_s", "acceleration_deg_s2", "jerk_deg_s3")})
    trajectory = plan(task).trajectory
    assert continuity_breaks(trajectory) == []
    coefficients = np.array(trajectory.coefficients)
    velocity_scale = np.abs(coefficients[..., 1]).max()
    coefficients[1, 0, 1] += 1e-3 * velocity_scale
    broken = PiecewisePolynomial(trajectory.durations, coefficients, trajectory.via_knots)
    assert any(line.startswith("joint joint1 velocity jumps by") for line in continuity_breaks(broken))


def test_a_constant_spline_has_no_extremes_inside_its_segments():
    """Polynomials of one coefficient (a forged recording's) made ``column_roots`` take the argmax of an
    empty array: an internal ValueError in ``replay --check`` (sweep 16)."""
    constant = PiecewisePolynomial(np.array([1.0, 1.0]), np.full((2, 1, 1), 0.3), np.array([0, 2]))
    figures = kinematic_figures(constant)
    np.testing.assert_array_equal(figures.max_abs, [[0.0], [0.0], [0.0]])
    assert column_roots(np.zeros((1, 2, 1, 0))).shape == (1, 2, 1, 0)
