"""Gaps in the tests of planner/timing/sos.py found by a hand mutation-testing run: each test kills a mutant
that survived the existing tests, checked against the Lukacs form evaluated densely (numpy's Chebyshev
series, the factors filled from z row by row) rather than against the module's own forms."""

import numpy as np
import pytest

from planner.timing.sos import SOS_DEGREES, factor_lower_bounds, gram_sizes, sos_start

GRID = np.linspace(0.0, 1.0, 1001)
P = np.polynomial.polynomial


def _form_values(z: np.ndarray, degree: int) -> np.ndarray:
    """(len(GRID), N) b' L L' b w_A + b' M M' b w_B on GRID for each column of z, T_i(2 s - 1) by numpy."""
    s = GRID[:, None]
    weights = (np.ones_like(s), s * (1 - s)) if degree % 2 == 0 else (s, 1 - s)
    values, offset = np.zeros((len(GRID), z.shape[1])), 0
    for size, weight in zip(gram_sizes(degree), weights):
        basis = np.polynomial.chebyshev.chebvander(2 * GRID - 1, size - 1)  # (G, size)
        rows, columns = np.tril_indices(size)
        factors = np.zeros((z.shape[1], size, size))
        factors[:, rows, columns] = z[offset:offset + len(rows)].T
        offset += len(rows)
        values += weight * np.sum(np.einsum("gi,nic->gnc", basis, factors) ** 2, axis=2)
    return values


def _fit_error(p: np.ndarray, z: np.ndarray, degree: int) -> np.ndarray:
    """(N,) max over GRID of |form - p|, relative to max |p| there."""
    values = P.polyval(GRID, p, tensor=True).T  # (G, N)
    return np.abs(_form_values(z, degree) - values).max(axis=0) / np.abs(values).max(axis=0)


def _touching(degree: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """(d + 1, count) q(s)^2 (times s or 1 - s at odd degree), q with its d // 2 roots inside (0, 1), scaled to
    a maximum of 1 on [0, 1] (as the NLP's p = 1 - v / v_max): >= 0 there and 0 at those roots, so their only
    certificates have rank-deficient Gram matrices."""
    columns = []
    for _ in range(count):
        q = P.polyfromroots(rng.uniform(0.05, 0.95, size=degree // 2))
        p = P.polymul(q, q)
        if degree % 2:
            p = P.polymul(p, [0.0, 1.0] if rng.random() < 0.5 else [1.0, -1.0])
        columns.append(np.pad(p, (0, degree + 1 - len(p))) / P.polyval(GRID, p).max())
    return np.array(columns).T


@pytest.mark.parametrize("degree", SOS_DEGREES)
def test_the_start_stays_finite_on_polynomials_that_touch_zero(degree):
    """A polynomial that touches 0 inside (0, 1) (the NLP's start at a solved spline whose limit binds there)
    has only rank-deficient certificates, where the Gauss-Newton normal matrix J J' becomes singular as the fit
    converges: the damping keeps every step defined, so sos_start returns finite factors, diagonals >= 0, whose
    form matches p (dense evaluation) within 1e-2 in the NLP's 30 iterations and 1e-3 in 200 (undamped,
    np.linalg.solve raised LinAlgError at degrees 4 and 5 within 200 iterations; fixed seed)."""
    p = _touching(degree, 20, np.random.default_rng(degree))
    for iterations, tolerance in ((30, 1e-2), (200, 1e-3)):
        z = sos_start(p, degree, iterations=iterations)
        assert np.isfinite(z).all()
        assert np.all(z >= factor_lower_bounds(degree)[:, None])
        assert _fit_error(p, z, degree).max() < tolerance


@pytest.mark.parametrize("degree", SOS_DEGREES)
def test_turning_the_columns_keeps_the_fitted_form(degree):
    """Each factor column whose diagonal ended < 0 is negated whole (L L' and M M' unchanged): polynomials
    large enough that the damping does not slow the fit (random, fixed seed, minimum 5 on [0, 1], coefficients
    ~100) are fitted to 1e-9 relative by the NLP's start (dense evaluation of the form from the returned z;
    degree 8, 25 entries, in 100 iterations rather than 30), with diagonals >= 0. Turning only the diagonal
    entry changes the form wherever a column with entries below its diagonal ended negative (relative error up
    to 1e-2 here)."""
    rng = np.random.default_rng(100 + degree)
    p = rng.normal(size=(degree + 1, 200))
    p[0] += 0.05 - P.polyval(GRID, p, tensor=True).min(axis=1)
    p *= 100
    z = sos_start(p, degree, iterations=100 if degree == 8 else 30)
    assert np.all(z >= factor_lower_bounds(degree)[:, None])
    assert _fit_error(p, z, degree).max() < 1e-9
