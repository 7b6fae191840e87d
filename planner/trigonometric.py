"""Trigonometric Hermite segments of order 4 (Simon & Isik 1991), the ``trigonometric`` family's pieces.

A segment of duration h [s] is, in its local time tau in [0, h] and theta = pi tau / h in [0, pi],

    q(tau) = a_0 + a_1 cos theta + a_2 sin theta + a_3 cos 2 theta + a_4 sin 2 theta
             + a_5 cos 3 theta + a_6 sin 3 theta + a_7 sin 4 theta,

eight functions (``BASIS``) fixed by position, velocity, acceleration and jerk at both ends (a
Hermite segment): the segments of a trajectory that share their via-point states are C3, and no
linear system couples them. The interval and the eighth function are chosen for conditioning: on
theta in [0, pi] with sin 4 theta the 8 x 8 system that maps the end states to the coefficients
has condition number 73.7 (``HERMITE_CONDITION``); with cos 4 theta on [0, pi/2] it is singular.
Time derivatives are theta derivatives times (pi / h)^d.

Exact figures, no sampling. Written with z = exp(i theta), q is sum_{k=-4..4} c_k z^k (``_complex``),
so d/dtheta multiplies c_k by i k, and the critical points of q^(d) in theta are among the
arguments of the roots of the degree-8 polynomial z^4 q^(d+1) (eigenvalues of its companion
matrix): q^(d) at those arguments that fall in [0, pi] and at both ends bounds it from both sides.
The integral of q'''^2 is a quadratic form in the coefficients whose matrix
(``JERK_GRAM``) follows from integral_0^pi exp(i m theta) dtheta = pi (m = 0) or
((-1)^m - 1) / (i m).
"""

from __future__ import annotations

import numpy as np

#: The basis functions of theta, in coefficient order: (frequency k, ``cos`` or ``sin``).
BASIS: tuple[tuple[int, str], ...] = ((0, "cos"), (1, "cos"), (1, "sin"), (2, "cos"), (2, "sin"), (3, "cos"),
                                      (3, "sin"), (4, "sin"))
#: The highest frequency.
ORDER = 4
_FREQUENCIES = np.arange(-ORDER, ORDER + 1)  # k of the complex coefficients c_k, in storage order


def _to_complex() -> np.ndarray:
    """(2 ORDER + 1, 8) the map from the real coefficients a to the complex c_k (k = -ORDER .. ORDER):
    cos k theta = (z^k + z^-k) / 2, sin k theta = (z^k - z^-k) / (2 i)."""
    matrix = np.zeros((2 * ORDER + 1, len(BASIS)), dtype=complex)
    for column, (k, kind) in enumerate(BASIS):
        if k == 0:
            matrix[ORDER, column] = 1.0
        elif kind == "cos":
            matrix[ORDER + k, column] = matrix[ORDER - k, column] = 0.5
        else:
            matrix[ORDER + k, column], matrix[ORDER - k, column] = -0.5j, 0.5j
    return matrix


_COMPLEX = _to_complex()


def _complex(coefficients: np.ndarray, order: int = 0) -> np.ndarray:
    """(..., 2 ORDER + 1) the complex coefficients of d^order q / dtheta^order for real ones (..., 8)."""
    return (coefficients @ _COMPLEX.T) * (1j * _FREQUENCIES) ** order


def _theta_values(coefficients: np.ndarray, theta: np.ndarray, order: int) -> np.ndarray:
    """d^order q / dtheta^order at ``theta`` (..., P) for coefficients (..., 8): (..., P)."""
    c = _complex(coefficients, order)
    waves = np.exp(1j * theta[..., None] * _FREQUENCIES)  # (..., P, 2 ORDER + 1)
    return np.real(np.einsum("...pk,...k->...p", waves, c))


def _hermite_matrix() -> np.ndarray:
    """(8, 8) the theta derivatives 0..3 of the basis at theta = 0 (rows 0-3) and pi (rows 4-7)."""
    rows = [_theta_values(np.eye(len(BASIS)), np.array([end]), d)[:, 0] for end in (0.0, np.pi) for d in range(4)]
    return np.array(rows)


_HERMITE = _hermite_matrix()
#: The 2-norm condition number of the map from end states (in theta) to coefficients.
HERMITE_CONDITION = float(np.linalg.cond(_HERMITE))
_HERMITE_INVERSE = np.linalg.inv(_HERMITE)


def hermite_coefficients(start: np.ndarray, end: np.ndarray, h) -> np.ndarray:
    """(..., 8) the coefficients of the segment with states ``start`` and ``end`` (..., 4) (position [rad],
    velocity [rad/s], acceleration, jerk at tau = 0 and tau = h) and durations ``h`` [s], broadcastable
    to start[..., 0]: the theta states (tau derivative d times (h / pi)^d) through the inverse of the
    Hermite matrix."""
    scale = (np.asarray(h, dtype=float)[..., None] / np.pi) ** np.arange(4)
    theta_states = np.concatenate((start * scale, end * scale), axis=-1)
    return theta_states @ _HERMITE_INVERSE.T


def values(coefficients: np.ndarray, h, tau: np.ndarray, order: int = 0) -> np.ndarray:
    """q^(order)(tau) [rad/s^order] at local times ``tau`` (..., P) [s] of segments (..., 8) of durations
    ``h`` (...) [s]: (..., P)."""
    h = np.asarray(h, dtype=float)
    theta = np.pi * np.asarray(tau, dtype=float) / h[..., None]
    return _theta_values(coefficients, theta, order) * (np.pi / h[..., None]) ** order


def critical_angles(coefficients: np.ndarray, order: int) -> np.ndarray:
    """(..., 2 ORDER + 2) angles in [0, pi] where d^order q / dtheta^order may take its extremes: both
    ends, and the arguments of the roots of z^ORDER q^(order + 1) clipped to [0, pi] (a superset of
    the critical points inside; where that polynomial vanishes entirely, the ends only)."""
    polynomial = _complex(coefficients, order + 1)  # (..., 9): coefficients of z^0 .. z^8
    shape = polynomial.shape[:-1]
    flat = polynomial.reshape(-1, polynomial.shape[-1])
    size = np.abs(flat).max(axis=1)
    divisor = np.where(size > 0, size, 1.0)[:, None]  # largest coefficient 1 (no overflow below); real and
    flat = flat.real / divisor + 1j * (flat.imag / divisor)  # imaginary apart (numpy's complex division overflows)
    roots = np.zeros((flat.shape[0], 2 * ORDER), dtype=complex)
    leading = np.abs(flat[:, -1]) > 1e-12
    if leading.any():  # the batch whose degree is 2 ORDER: eigenvalues of the companion matrices
        monic = flat[leading, :-1] / flat[leading, -1:]
        companion = np.zeros((monic.shape[0], 2 * ORDER, 2 * ORDER), dtype=complex)
        companion[:, 1:, :-1] = np.eye(2 * ORDER - 1)
        companion[:, :, -1] = -monic
        roots[leading] = np.linalg.eigvals(companion)
    for row in np.flatnonzero(~leading & (size > 0)):  # a lower degree (no sin 4 theta): numpy strips it
        found = np.roots(flat[row, ::-1])
        roots[row, :len(found)] = found
    angles = np.clip(np.angle(roots), 0.0, np.pi)
    ends = np.broadcast_to(np.array([0.0, np.pi]), (flat.shape[0], 2))
    return np.concatenate((ends, angles), axis=1).reshape(*shape, 2 * ORDER + 2)


def extremes(coefficients: np.ndarray, h, order: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Exact (min, max) of q^(order) [rad/s^order] over segments (..., 8) of durations ``h`` (...) [s],
    each (...): q^(order) at ``critical_angles``."""
    angles = critical_angles(coefficients, order)
    found = _theta_values(coefficients, angles, order) * (np.pi / np.asarray(h, dtype=float)[..., None]) ** order
    return found.min(axis=-1), found.max(axis=-1)


def _jerk_gram() -> np.ndarray:
    """(8, 8) G with integral_0^pi (d^3 q / dtheta^3)^2 dtheta = a^T G a."""
    m = _FREQUENCIES[:, None] + _FREQUENCIES[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        integral = np.where(m == 0, np.pi, ((-1.0) ** m - 1) / (1j * m))
    third = _COMPLEX * ((1j * _FREQUENCIES) ** 3)[:, None]  # (9, 8): a -> complex coefficients of q'''
    gram = third.T @ integral @ third
    return np.real((gram + gram.T) / 2)


#: ``_jerk_gram``: integral_0^pi (d^3 q / dtheta^3)^2 dtheta = a^T JERK_GRAM a.
JERK_GRAM = _jerk_gram()


def jerk_energy(coefficients: np.ndarray, h) -> np.ndarray:
    """integral_0^h q'''(tau)^2 dtau [rad^2/s^5] of segments (..., 8) of durations ``h`` (...) [s]:
    (pi / h)^5 a^T ``JERK_GRAM`` a (dtau = h / pi dtheta, q''' = (pi / h)^3 d^3q/dtheta^3)."""
    h = np.asarray(h, dtype=float)
    return np.einsum("...i,ij,...j->...", coefficients, JERK_GRAM, coefficients) * (np.pi / h) ** 5
