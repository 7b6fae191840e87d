"""Lukacs' forms (planner/timing/sos.py): against dense evaluation of the Gram matrices they stand for."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from planner import paper
from planner.timing import TimingProblem
from planner.timing.nlp import TimingNLP
from planner.timing.sos import (
    SOS_DEGREES,
    factor_count,
    factor_lower_bounds,
    gram_sizes,
    sos_forms,
    sos_residuals,
    sos_start,
)
from planner.timing.starts import start_shapes

GRID = np.linspace(0.0, 1.0, 2001)
ROOT = Path(__file__).resolve().parents[1]


def _chebyshev_row(size: int, s: np.ndarray) -> np.ndarray:
    """(size, len(s)) T_i(2 s - 1), by numpy's own Chebyshev series."""
    return np.array([np.polynomial.chebyshev.chebval(2 * s - 1, np.eye(size)[i]) for i in range(size)])


def _gram_value(z: np.ndarray, degree: int, s: np.ndarray) -> np.ndarray:
    """b' L L' b w_A + b' M M' b w_B at s, the factors filled row by row from z (the module's layout)."""
    values, offset = np.zeros_like(s), 0
    weights = (np.ones_like(s), s * (1 - s)) if degree % 2 == 0 else (s, 1 - s)
    for size, weight in zip(gram_sizes(degree), weights):
        factor = np.zeros((size, size))
        rows, columns = np.tril_indices(size)
        factor[rows, columns] = z[offset:offset + len(rows)]
        offset += len(rows)
        basis = _chebyshev_row(size, s)
        values += weight * np.sum((factor.T @ basis) ** 2, axis=0)
    return values


@pytest.mark.parametrize("degree", SOS_DEGREES)
@settings(max_examples=25, deadline=None)
@given(data=st.data())
def test_the_forms_are_the_gram_matrices_polynomial(degree, data):
    """For any factors z, sum_k (z' H_k z) T_k(2 s - 1) equals the Lukacs form of L L' and M M' evaluated
    directly, so it is >= 0 on [0, 1]; and c(p) inverts the change of basis (a polynomial's own Chebyshev
    coefficients give back its values)."""
    z = data.draw(arrays(float, factor_count(degree), elements=st.floats(-3, 3)))
    to_chebyshev, forms = sos_forms(degree)
    coefficients = np.einsum("kuv,u,v->k", forms, z, z)
    direct = _gram_value(z, degree, GRID)
    assert np.polynomial.chebyshev.chebval(2 * GRID - 1, coefficients) == pytest.approx(direct, abs=1e-9)
    assert direct.min() >= 0
    p = data.draw(arrays(float, degree + 1, elements=st.floats(-5, 5)))
    assert np.polynomial.chebyshev.chebval(2 * GRID - 1, to_chebyshev @ p) == pytest.approx(
        np.polynomial.polynomial.polyval(GRID, p), abs=1e-9)


@pytest.mark.parametrize("degree", SOS_DEGREES)
def test_the_start_fits_positive_polynomials_and_not_negative_ones(degree):
    """Random polynomials (fixed seed) shifted to a minimum of 0.05 on [0, 1] are fitted exactly in 60
    iterations, 100 at degree 8 (25 entries), residual rows below 1e-7 (the default 30, the NLP's start,
    within 1e-3, with a median below 1e-8, 1e-5 at degree 8) with diagonals >= 0, as the NLP's bounds ask;
    shifted to a minimum of -0.05 they cannot be (a form is >= 0 on [0, 1])."""
    iterations, median = (100, 1e-5) if degree == 8 else (60, 1e-8)
    rng = np.random.default_rng(degree)
    p = rng.normal(size=(degree + 1, 40))
    lowest = np.array([np.polynomial.polynomial.polyval(GRID, column).min() for column in p.T])
    for floor, fits in ((0.05, True), (-0.05, False)):
        shifted = p.copy()
        shifted[0] += floor - lowest
        z = sos_start(shifted, degree, iterations=iterations)
        residual = np.abs(np.array(sos_residuals(list(shifted), list(z), degree))).max(axis=0)
        assert np.all(z >= factor_lower_bounds(degree)[:, None])
        if fits:
            assert residual.max() < 1e-7
            near = sos_start(shifted, degree)  # the NLP's start: close, IPOPT solves the rest
            residual = np.abs(np.array(sos_residuals(list(shifted), list(near), degree))).max(axis=0)
            assert np.median(residual) < median and residual.max() < 1e-3
        else:
            assert residual.min() > 1e-4


def test_hermite7_bounds_its_derivatives_exactly_in_one_round():
    """hermite7 on the paper case: velocity, acceleration and jerk inside segments are certified by
    Lukacs' forms, so one round reaches the optimum (16.4723 s, an independent computation; within 1e-4)
    where cuts took 12 rounds, and the solved spline meets its limits without repair."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    problem = TimingProblem(via, "hermite7", paper.paper_limits())
    start = problem.evaluate(start_shapes(problem)["cruise"][None]).durations[0]
    outcome = TimingNLP(problem, start).solve(start)
    assert outcome.rounds == 1 and outcome.status == "Solve_Succeeded"
    assert outcome.durations.sum() == pytest.approx(16.4723, rel=1e-4)
    checked = problem.evaluate_states(outcome.durations[None], outcome.states[None])
    assert checked.feasible[0] and checked.durations[0].sum() == pytest.approx(outcome.durations.sum(), rel=1e-8)


def test_trigonometric_bounds_its_derivatives_exactly_in_one_round():
    """trigonometric on the paper case: its velocity, acceleration and jerk, through t = tan(phi / 2) degree-8
    polynomials, are certified by Lukacs' forms, so one round reaches the optimum that 12 rounds of cuts
    approached from below (their last program's total 16.715612 s: cuts relax the limits, so a lower bound)
    within 1e-7 (IPOPT's tolerance with forms, 1e-8), and the solved spline meets its limits without repair."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    problem = TimingProblem(via, "trigonometric", paper.paper_limits())
    start = problem.evaluate(start_shapes(problem)["cruise"][None]).durations[0]
    nlp = TimingNLP(problem, start)
    outcome = nlp.solve(start)
    assert outcome.rounds == 1 and outcome.status == "Solve_Succeeded"
    assert 16.715612 <= outcome.durations.sum() <= 16.715612 * (1 + 1e-7)
    checked = problem.evaluate_states(outcome.durations[None], outcome.states[None])
    assert checked.feasible[0] and checked.durations[0].sum() == pytest.approx(outcome.durations.sum(), rel=1e-8)
    certificates, _ = nlp._certify([], problem.coefficients(start[None])[0], start, everywhere=True)
    assert {c.kind for c in certificates if c.order >= 1} == {"sos8"}
    assert all(c.half_angle for c in certificates if c.order >= 1)


def test_beside_robot_rows_hermite7_is_certified_by_cuts():
    """The robot rows' rounds refit their model up to 12 times; with Lukacs' forms each solved the whole
    program again (several times slower), so a TimingNLP with robot rows certifies hermite7 by cuts, and
    without them by forms: the same start, the same places."""
    from planner.robot import Robot
    from planner.timing.robot_rows import RobotConstraints

    via = np.deg2rad(paper.VIA_POINTS_DEG)
    problem = TimingProblem(via, "hermite7", paper.paper_limits())
    start = problem.evaluate(start_shapes(problem)["cruise"][None]).durations[0]
    coefficients = problem.coefficients(start[None])[0]
    robot = RobotConstraints(Robot.from_urdf(ROOT / "robots" / "puma560.urdf", "tool"), None, 0.25)
    alone, _ = TimingNLP(problem, start)._certify([], coefficients, start, everywhere=True)
    beside, _ = TimingNLP(problem, start, robot)._certify([], coefficients, start, everywhere=True)
    assert {c.kind for c in alone if c.order >= 1} == {"sos4", "sos5", "sos6"}
    assert {c.kind for c in beside if c.order >= 1} == {"cut"}
    assert {c.place for c in alone} == {c.place for c in beside}
