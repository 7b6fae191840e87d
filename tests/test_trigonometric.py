"""Trigonometric Hermite segments (planner/trigonometric.py) against independent computations: finite
differences of the basis, dense sampling, numerical quadrature, numpy's polynomial roots."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.integrate import quad, trapezoid

from planner import trigonometric as trig

STATES = arrays(float, (2, 4), elements=st.floats(-5.0, 5.0))
DURATIONS = st.floats(0.05, 20.0)


def basis_derivative(coefficients: np.ndarray, theta: np.ndarray, order: int) -> np.ndarray:
    """d^order q / dtheta^order from the basis as written, term by term: the order-th derivative of cos k theta
    is k^order cos(k theta + order pi / 2), of sin k theta k^order sin(k theta + order pi / 2)."""
    shift = order * np.pi / 2
    return sum(a * k ** order * (np.cos(k * theta + shift) if kind == "cos" else np.sin(k * theta + shift))
               for a, (k, kind) in zip(coefficients, trig.BASIS))


def basis_value(coefficients: np.ndarray, h: float, tau: float) -> float:
    """q(tau) from the basis as written (``trig.BASIS``), term by term (``basis_derivative`` of order 0)."""
    return float(basis_derivative(coefficients, 0.75 * np.pi * tau / h, 0))


def test_the_hermite_system_is_well_conditioned_on_zero_to_three_quarters_pi_with_cos_4_theta():
    assert trig.SPAN == pytest.approx(0.75 * np.pi) and trig.BASIS[-1] == (4, "cos")
    assert trig.HERMITE_CONDITION == pytest.approx(38.5, abs=0.05)


@given(STATES, DURATIONS)
def test_a_segment_meets_its_end_states_in_time(states, h):
    """Position, velocity, acceleration and jerk at tau = 0 and h are the given ones, evaluated by the module
    and, for the position and velocity, from the basis term by term (central differences for the velocity)."""
    a = trig.hermite_coefficients(states[0], states[1], h)
    found = np.array([trig.values(a, h, np.array([0.0, h]), order) for order in range(4)]).T  # (2, 4)
    scale = 1 + np.abs(states).max() * max(1.0, h ** 3)
    np.testing.assert_allclose(found, states, atol=1e-9 * scale)
    assert basis_value(a, h, 0.0) == pytest.approx(states[0, 0], abs=1e-9 * scale)
    assert basis_value(a, h, h) == pytest.approx(states[1, 0], abs=1e-9 * scale)
    step = 1e-6 * h
    middle = h / 2
    difference = (basis_value(a, h, middle + step) - basis_value(a, h, middle - step)) / (2 * step)
    assert trig.values(a, h, np.array([middle]), 1)[0] == pytest.approx(difference, rel=1e-5, abs=1e-5 * scale / h)


@given(arrays(float, 8, elements=st.floats(-3.0, 3.0)), DURATIONS)
def test_each_derivative_is_the_finite_difference_of_the_one_below(a, h):
    tau = np.linspace(0.1, 0.9, 7) * h
    step = 1e-5 * h
    for order in range(1, 4):
        difference = (trig.values(a, h, tau + step, order - 1) - trig.values(a, h, tau - step, order - 1)) / (2 * step)
        scale = np.abs(a).sum() * (4 * np.pi / h) ** order
        np.testing.assert_allclose(trig.values(a, h, tau, order), difference, atol=1e-6 * scale)


@settings(max_examples=60)
@given(STATES, DURATIONS, st.sampled_from([0, 1, 2, 3]))
def test_exact_extremes_bound_dense_samples_and_are_reached(states, h, order):
    a = trig.hermite_coefficients(states[0], states[1], h)
    low, high = trig.extremes(a, h, order)
    sampled = trig.values(a, h, np.linspace(0.0, h, 20001), order)
    scale = max(np.abs(sampled).max(), 1e-300)
    assert sampled.min() >= low - 1e-9 * scale and sampled.max() <= high + 1e-9 * scale
    # within what 20,001 samples can miss near an extreme (the next derivative's largest, half a step)
    reach = np.abs(trig.values(a, h, np.linspace(0.0, h, 20001), order + 1)).max() * h / 40000 + 1e-12 * scale
    assert sampled.min() <= low + reach and sampled.max() >= high - reach


def test_extremes_of_a_segment_without_cos_4_theta_use_the_lower_degree():
    """A segment whose cos 4 theta coefficient is 0 (its critical-point polynomial of degree 6, not 8):
    q = cos theta on [0, 3 pi / 4] has its extremes at the ends, q' = -(3 pi / 4) / h sin theta its minimum
    at theta = pi / 2."""
    a = np.array([0.0, 1.0, 0, 0, 0, 0, 0, 0])
    assert trig.extremes(a, 2.0, 0) == pytest.approx((-np.sqrt(0.5), 1.0))
    assert trig.extremes(a, 2.0, 1) == pytest.approx((-0.75 * np.pi / 2, 0.0), abs=1e-12)
    assert trig.extremes(np.zeros(8), 1.0, 2) == (0.0, 0.0)


@settings(max_examples=30)
@given(STATES, DURATIONS)
def test_jerk_energy_is_the_integral_of_the_squared_jerk(states, h):
    a = trig.hermite_coefficients(states[0], states[1], h)
    integral, _ = quad(lambda tau: trig.values(a, h, np.array([tau]), 3)[0] ** 2, 0.0, h, limit=200,
                       epsabs=0.0, epsrel=1e-11)
    assert trig.segment_jerk_energy(a, h) == pytest.approx(integral, rel=1e-8, abs=1e-12)


def test_batches_of_segments_match_one_at_a_time():
    rng = np.random.default_rng(5)
    starts, ends = rng.uniform(-2, 2, (2, 3, 4, 4))
    h = rng.uniform(0.5, 3.0, (3, 4))
    a = trig.hermite_coefficients(starts, ends, h)
    low, high = trig.extremes(a, h, 1)
    energy = trig.segment_jerk_energy(a, h)
    for i in range(3):
        for j in range(4):
            single = trig.hermite_coefficients(starts[i, j], ends[i, j], h[i, j])
            np.testing.assert_allclose(a[i, j], single)
            assert (low[i, j], high[i, j]) == pytest.approx(trig.extremes(single, h[i, j], 1))
            assert energy[i, j] == pytest.approx(trig.segment_jerk_energy(single, h[i, j]))


# ------------------------------------------------------------------ trajectories of segments (batched)

@st.composite
def trajectories(draw, batch: int = 4, segments: int = 5, joints: int = 3):
    """Coefficients (B, S, J, 8) of C3 trajectories through drawn states (each joint of each trajectory at
    the scale 1 or 1e-3), and durations (B, S) from 0.05 to 20 s: segments of very different sizes, so that
    one segment holds each trajectory's extremes."""
    states = draw(arrays(float, (batch, segments + 1, joints, 4), elements=st.floats(-3.0, 3.0)))
    scales = draw(arrays(float, (batch, 1, joints, 1), elements=st.sampled_from([1.0, 1e-3])))
    h = np.exp(draw(arrays(float, (batch, segments), elements=st.floats(np.log(0.05), np.log(20.0)))))
    states = states * scales
    return trig.hermite_coefficients(states[:, :-1], states[:, 1:], h[..., None]), h


@settings(max_examples=25)
@given(trajectories(), st.sampled_from([(0,), (1, 2, 3), (2,)]))
def test_trajectory_ranges_are_the_segment_ranges_over_every_segment(drawn, orders):
    """The pruned solve (only segments whose sampled bound reaches the trajectory's extremes) gives exactly
    the extremes of solving every segment."""
    a, h = drawn
    low, high = trig.trajectory_ranges(a, h, orders)
    every_low, every_high = trig.segment_ranges(a, h, orders)
    scale = np.maximum(np.abs(every_low).max(axis=2), np.abs(every_high).max(axis=2))
    np.testing.assert_allclose(low, every_low.min(axis=2), rtol=0, atol=1e-13 * scale.max())
    np.testing.assert_allclose(high, every_high.max(axis=2), rtol=0, atol=1e-13 * scale.max())


@settings(max_examples=20)
@given(trajectories(batch=1, segments=3, joints=2))
def test_segment_extrema_values_are_the_function_at_their_locations_and_bound_samples(drawn):
    a, h = drawn
    locations, values = trig.segment_extrema(a, h, (0, 1))
    for o, order in enumerate((0, 1)):
        for s in range(3):
            for j in range(2):
                at = trig.values(a[0, s, j], h[0, s], locations[o, 0, s, j] * h[0, s], order)
                np.testing.assert_allclose(values[o, 0, s, j], at, rtol=1e-12, atol=1e-12 * np.abs(at).max())
                sampled = trig.values(a[0, s, j], h[0, s], np.linspace(0, h[0, s], 4001), order)
                scale = np.abs(sampled).max()
                assert sampled.max() <= values[o, 0, s, j].max() + 1e-9 * scale
                assert sampled.min() >= values[o, 0, s, j].min() - 1e-9 * scale


@settings(max_examples=15)
@given(trajectories(batch=1, segments=2, joints=1), st.sampled_from([1, 2, 3]))
def test_integral_abs_is_the_integral_of_the_magnitude(drawn, order):
    """Against the trapezoidal rule on 400,001 samples per segment (quad misses a sign change 1e-7 s after a
    segment's start)."""
    a, h = drawn
    total = 0.0
    for s in range(2):
        tau = np.linspace(0.0, h[0, s], 400001)
        total += trapezoid(np.abs(trig.values(a[0, s, 0], h[0, s], tau, order)), tau)
    assert trig.integral_abs(a, h, order)[0, 0] == pytest.approx(total, rel=1e-7)


def test_integral_abs_of_the_position_is_refused():
    states = np.ones((1, 3, 1, 4))
    h = np.ones((1, 2))
    a = trig.hermite_coefficients(states[:, :-1], states[:, 1:], h[..., None])
    with pytest.raises(ValueError, match="order >= 1"):
        trig.integral_abs(a, h, 0)


@given(arrays(float, 8, elements=st.floats(-3.0, 3.0)), DURATIONS, st.sampled_from([0, 1, 2, 3]))
def test_normalised_weights_give_the_scaled_derivative(a, h, order):
    """h^d q^(d)(s h) = sum_i W[i] a_i, the NLP's form of a cut or a sample."""
    s = np.linspace(0.0, 1.0, 9)
    expected = h ** order * trig.values(a, h, s * h, order)
    scale = np.abs(a).sum() * (4 * np.pi) ** order
    np.testing.assert_allclose(a @ trig.normalised_weights(s, order), expected, atol=1e-12 * scale)


@given(arrays(float, 8, elements=st.floats(-3.0, 3.0)), DURATIONS)
def test_the_normalised_jerk_gram_gives_the_jerk_energy(a, h):
    expected = trig.segment_jerk_energy(a, h)
    assert a @ trig.NORMALISED_JERK_GRAM @ a / h ** 5 == pytest.approx(expected, rel=1e-10, abs=1e-300)



@given(arrays(float, 8, elements=st.floats(-3.0, 3.0)), st.sampled_from([0, 1, 2, 3]))
def test_the_half_angle_polynomial_is_the_derivative_times_a_positive_factor(a, order):
    """With theta = SPAN / 2 + 2 arctan(HALF_ANGLE_BOUND (2 u - 1)) (u from 0 to 1 takes theta over the
    segment), the degree-8 polynomial of ``half_angle_map`` is the theta derivative written out term by term
    times ``HALF_ANGLE_DENOMINATOR``'s polynomial, which is (1 + t^2)^4: between 1 and 4.38, so the two have
    the same sign (what the NLP's forms certify)."""
    u = np.linspace(0.0, 1.0, 201)
    t = trig.HALF_ANGLE_BOUND * (2 * u - 1)
    theta = trig.SPAN / 2 + 2 * np.arctan(t)
    assert theta[0] == pytest.approx(0.0, abs=1e-15) and theta[-1] == pytest.approx(trig.SPAN)
    factor = np.polynomial.polynomial.polyval(u, trig.HALF_ANGLE_DENOMINATOR)
    np.testing.assert_allclose(factor, (1 + t ** 2) ** 4, rtol=1e-13)
    assert factor.min() == pytest.approx(1.0) and factor.max() == pytest.approx(4.3775, abs=1e-4)
    found = np.polynomial.polynomial.polyval(u, trig.half_angle_map(order) @ a)
    scale = 1 + np.abs(a).sum() * 4 ** order
    np.testing.assert_allclose(found, factor * basis_derivative(a, theta, order), atol=1e-12 * scale)
