"""Exact certificates that a polynomial of degree 4 to 8 is non-negative on [0, 1] (``nlp.py``).

Lukacs' theorem: p of degree d is >= 0 on [0, 1] if and only if

    d = 2m:      p(s) = b_m(s)' A b_m(s) + s (1 - s) b_(m-1)(s)' B b_(m-1)(s),
    d = 2m + 1:  p(s) = s b_m(s)' A b_m(s) + (1 - s) b_m(s)' B b_m(s),

with A, B positive semidefinite and b_k(s) = (T_0(t), ..., T_k(t)), T_i the Chebyshev
polynomials of t = 2 s - 1 (any basis of the polynomials of degree k will do; this one keeps the
matrices well conditioned on [0, 1], where powers of s would make their entries cancel by two
orders of magnitude at degree 6). Writing A = L L' and B = M M' with L, M lower triangular
(every positive semidefinite matrix has such a factor, with a diagonal >= 0), the condition is
d + 1 polynomial equations in p's coefficients and the factors' entries z:

    c_k(p) = z' H_k z,   k = 0 .. d,

c_k(p) the Chebyshev coefficients of p (linear in p) and H_k constant symmetric matrices
(``sos_forms``). These are exact: the NLP's optimum with them is the true one, where a cut (p at
one point) only approaches it over rounds of re-placed cuts. Sizes: degree 4, 9 entries
(L 3 x 3, M 2 x 2); 5, 12; 6, 16; 7, 20; 8, 25.
"""

from __future__ import annotations

import functools

import numpy as np

#: Degrees certified this way (a quadratic or cubic has its own exact certificate, ``nlp.py``; degree 8 is a
#: trigonometric segment's, ``trigonometric.half_angle_map``).
SOS_DEGREES = (4, 5, 6, 7, 8)


def gram_sizes(degree: int) -> tuple[int, int]:
    """Sizes of A and B (module docstring) for a polynomial of ``degree``."""
    m = degree // 2
    return (m + 1, m) if degree % 2 == 0 else (m + 1, m + 1)


def _factor_entries(size: int) -> list[tuple[int, int]]:
    """(row, column) of a lower-triangular factor's entries, row by row: their order in z."""
    return [(i, column) for i in range(size) for column in range(i + 1)]


def factor_count(degree: int) -> int:
    """Entries of z (both factors) for a polynomial of ``degree``."""
    return sum(len(_factor_entries(size)) for size in gram_sizes(degree))


def chebyshev_in_s(count: int) -> np.ndarray:
    """(count, count): column i holds the coefficients of T_i(2 s - 1) in s^0 .. s^(count - 1)."""
    out = np.zeros((count, count))
    for i in range(count):
        coefficients = np.polynomial.Chebyshev.basis(i, domain=[0, 1]).convert(
            kind=np.polynomial.Polynomial, domain=[-1, 1], window=[-1, 1]).coef
        out[:len(coefficients), i] = coefficients
    return out


@functools.cache
def sos_forms(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """(C, H): C (d + 1, d + 1) maps p's coefficients in powers of s to its Chebyshev coefficients in
    t = 2 s - 1, and H (d + 1, V, V) holds the symmetric H_k of the module docstring (V =
    ``factor_count``; z lists L's entries, then M's, each row by row)."""
    power = np.polynomial.polynomial
    # each Gram matrix's multiplier, in powers of s: 1 and s (1 - s), or s and 1 - s
    multipliers = ([np.array([1.0]), np.array([0.0, 1.0, -1.0])] if degree % 2 == 0
                   else [np.array([0.0, 1.0]), np.array([1.0, -1.0])])
    basis = chebyshev_in_s(degree + 1)
    count = factor_count(degree)
    in_powers = np.zeros((degree + 1, count, count))
    offset = 0
    for size, multiplier in zip(gram_sizes(degree), multipliers):
        index = {entry: offset + k for k, entry in enumerate(_factor_entries(size))}
        for i in range(size):
            for j in range(size):
                # (L L')_ij = sum_c L_ic L_jc multiplies T_i T_j times the multiplier
                product = power.polymul(power.polymul(basis[:size, i], basis[:size, j]), multiplier)[:degree + 1]
                for column in range(min(i, j) + 1):
                    u, v = index[i, column], index[j, column]
                    in_powers[:len(product), u, v] += product / 2
                    in_powers[:len(product), v, u] += product / 2
        offset += len(index)
    to_chebyshev = np.linalg.inv(basis)
    return to_chebyshev, np.einsum("kj,juv->kuv", to_chebyshev, in_powers)


def factor_lower_bounds(degree: int) -> np.ndarray:
    """(V,) lower bounds of z's entries: 0 on the factors' diagonals, none elsewhere."""
    return np.concatenate([[0.0 if i == column else -np.inf for i, column in _factor_entries(size)]
                           for size in gram_sizes(degree)])


def sos_residuals(p: list, z: list, degree: int) -> list:
    """The d + 1 rows c_k(p) - z' H_k z, each to equal 0, for columns of certificates side by side:
    ``p`` holds p's coefficients in powers of s (d + 1 columns), ``z`` the factors' entries (V columns);
    numpy arrays or CasADi columns alike."""
    to_chebyshev, forms = sos_forms(degree)
    rows = []
    for k in range(degree + 1):
        row = sum(float(to_chebyshev[k, j]) * p[j] for j in range(degree + 1) if to_chebyshev[k, j] != 0)
        upper = np.triu(forms[k])
        for u, v in zip(*np.nonzero(np.abs(upper) > 1e-14)):
            row = row - float(upper[u, v] * (1 if u == v else 2)) * z[u] * z[v]
        rows.append(row)
    return rows


def sos_start(p: np.ndarray, degree: int, iterations: int = 30) -> np.ndarray:
    """(V, N) factor entries whose forms fit the polynomials ``p`` (d + 1, N) (coefficients in powers of
    s) in least squares, exactly where p > 0 on [0, 1] and the fit converges: damped Gauss-Newton with
    minimum-norm steps from scaled identities, then each factor's columns turned so that its diagonal
    is >= 0 (A and B unchanged). A start for IPOPT, which solves the equations themselves."""
    to_chebyshev, forms = sos_forms(degree)
    target = to_chebyshev @ np.asarray(p, dtype=float)
    sizes = gram_sizes(degree)
    identity = np.concatenate([[float(i == column) for i, column in _factor_entries(size)] for size in sizes])
    z = identity[:, None] * np.sqrt(np.maximum(np.abs(target).max(axis=0), 1e-6) / max(sizes))[None] / 2
    damping = 1e-3 * np.eye(degree + 1)
    for _ in range(iterations):
        residual = target - np.einsum("kuv,un,vn->kn", forms, z, z)
        jacobian = 2 * np.einsum("kuv,vn->nku", forms, z)  # (N, d + 1, V)
        normal = jacobian @ jacobian.transpose(0, 2, 1) + damping[None]
        z = z + (jacobian.transpose(0, 2, 1) @ np.linalg.solve(normal, residual.T[:, :, None]))[:, :, 0].T
    offset = 0
    for size in sizes:
        entries = _factor_entries(size)
        for column in range(size):
            turn = np.where(z[offset + entries.index((column, column))] < 0, -1.0, 1.0)
            for k, (_, c) in enumerate(entries):
                if c == column:
                    z[offset + k] *= turn
        offset += len(entries)
    return z
