"""Trigonometric Hermite segments of order 4 (Simon & Isik 1991), the ``trigonometric`` family's pieces.

A segment of duration h [s] is, in its local time tau in [0, h] and theta = SPAN tau / h in [0, SPAN],
SPAN = 3 pi / 4,

    q(tau) = a_0 + a_1 cos theta + a_2 sin theta + a_3 cos 2 theta + a_4 sin 2 theta
             + a_5 cos 3 theta + a_6 sin 3 theta + a_7 cos 4 theta,

eight functions (``BASIS``) fixed by position, velocity, acceleration and jerk at both ends (a
Hermite segment): the segments of a trajectory that share their via-point states are C3, and no
linear system couples them. The interval and the eighth function are chosen for conditioning: the 8 x 8
system that maps the end states to the coefficients has condition number 38.5 (``HERMITE_CONDITION``) with
cos 4 theta on [0, 3 pi / 4], the smallest over the intervals [0, c pi], c = 0.55 .. 1 in steps of 0.05,
with either (sin 4 theta on [0, pi]: 73.7; cos 4 theta on [0, pi / 2] or sin 4 theta on [0, 3 pi / 4]:
singular). The choice also sets the family's shapes: through the paper's via-points under its limits the
time-optimal trajectory takes about 16.7 s with this basis and 18.1 s with sin 4 theta on [0, pi] (the
hybrid's: 17.3 s). Time derivatives are theta derivatives times (SPAN / h)^d.

Exact figures, no sampling. Written with z = exp(i theta), q is sum_{k=-4..4} c_k z^k (``_complex``),
so d/dtheta multiplies c_k by i k, and the critical points of q^(d) in theta are among the
arguments of the roots of the degree-8 polynomial z^4 q^(d+1) (eigenvalues of its companion
matrix): q^(d) at those arguments that fall in [0, SPAN] and at both ends bounds it from both sides.
The integral of q'''^2 is a quadratic form in the coefficients whose matrix
(``JERK_GRAM``) follows from integral_0^SPAN exp(i m theta) dtheta = SPAN (m = 0) or
(exp(i m SPAN) - 1) / (i m).
"""

from __future__ import annotations

import functools

import numpy as np

#: The basis functions of theta, in coefficient order: (frequency k, ``cos`` or ``sin``).
BASIS: tuple[tuple[int, str], ...] = ((0, "cos"), (1, "cos"), (1, "sin"), (2, "cos"), (2, "sin"), (3, "cos"),
                                      (3, "sin"), (4, "cos"))
#: The highest frequency.
ORDER = 4
#: theta's range on a segment, [0, SPAN] (module docstring).
SPAN = 3 * np.pi / 4
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


@functools.cache
def _real_derivative(order: int) -> np.ndarray:
    """(2 ORDER + 1, 8) the map from the real coefficients a to those of d^order q / dtheta^order in the
    basis 1, cos k theta (k = 1 .. ORDER), sin k theta (k = 1 .. ORDER): q^(order) is real, so c_-k =
    conj(c_k) and it is c_0 + sum_k 2 (Re c_k cos k theta - Im c_k sin k theta) (``_complex``)."""
    complex_map = _COMPLEX[ORDER:] * ((1j * _FREQUENCIES[ORDER:]) ** order)[:, None]  # rows c_0 .. c_ORDER
    return np.concatenate((complex_map[:1].real, 2 * complex_map[1:].real, -2 * complex_map[1:].imag))


def _theta_values(coefficients: np.ndarray, theta: np.ndarray, order: int) -> np.ndarray:
    """d^order q / dtheta^order at ``theta`` (..., P) for coefficients (..., 8): (..., P), from its real
    coefficients (``_real_derivative``), cos k theta and sin k theta by the angle-sum recurrence from one
    cosine and one sine per point (within a few units of the last place of exp(i k theta) evaluated for
    each k, and 4 to 5 times faster)."""
    real = (coefficients @ _real_derivative(order).T)[..., None]  # (..., 2 ORDER + 1, 1)
    cos, sin = np.cos(theta), np.sin(theta)
    cos_k, sin_k = cos, sin
    result = real[..., 0, :] + real[..., 1, :] * cos_k + real[..., ORDER + 1, :] * sin_k
    for k in range(2, ORDER + 1):
        cos_k, sin_k = cos_k * cos - sin_k * sin, sin_k * cos + cos_k * sin
        result = result + real[..., k, :] * cos_k + real[..., ORDER + k, :] * sin_k
    return result


def _hermite_matrix() -> np.ndarray:
    """(8, 8) the theta derivatives 0..3 of the basis at theta = 0 (rows 0-3) and SPAN (rows 4-7)."""
    rows = [_theta_values(np.eye(len(BASIS)), np.array([end]), d)[:, 0] for end in (0.0, SPAN) for d in range(4)]
    return np.array(rows)


_HERMITE = _hermite_matrix()
#: The 2-norm condition number of the map from end states (in theta) to coefficients.
HERMITE_CONDITION = float(np.linalg.cond(_HERMITE))
_HERMITE_INVERSE = np.linalg.inv(_HERMITE)


def hermite_coefficients(start: np.ndarray, end: np.ndarray, h) -> np.ndarray:
    """(..., 8) the coefficients of the segment with states ``start`` and ``end`` (..., 4) (position [rad],
    velocity [rad/s], acceleration, jerk at tau = 0 and tau = h) and durations ``h`` [s], broadcastable
    to start[..., 0]: the theta states (tau derivative d times (h / SPAN)^d) through the inverse of the
    Hermite matrix."""
    scale = (np.asarray(h, dtype=float)[..., None] / SPAN) ** np.arange(4)
    theta_states = np.concatenate((start * scale, end * scale), axis=-1)
    return theta_states @ _HERMITE_INVERSE.T


def values(coefficients: np.ndarray, h, tau: np.ndarray, order: int = 0) -> np.ndarray:
    """q^(order)(tau) [rad/s^order] at local times ``tau`` (..., P) [s] of segments (..., 8) of durations
    ``h`` (...) [s]: (..., P)."""
    h = np.asarray(h, dtype=float)
    theta = SPAN * np.asarray(tau, dtype=float) / h[..., None]
    return _theta_values(coefficients, theta, order) * (SPAN / h[..., None]) ** order


def zero_angles(coefficients: np.ndarray, order: int) -> np.ndarray:
    """(..., 2 ORDER + 2) angles in [0, SPAN]: both ends, and the arguments of the roots of z^ORDER q^(order)
    (q's ``order``-th theta derivative) clipped to [0, SPAN], a superset of the zeros of q^(order) inside (where
    that polynomial vanishes entirely, the ends only). Extra angles (roots off the unit circle) do no harm
    to the callers: they only add points at which the function is evaluated or split."""
    polynomial = _complex(coefficients, order)  # (..., 9): coefficients of z^0 .. z^8
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
    angles = np.clip(np.angle(roots), 0.0, SPAN)
    ends = np.broadcast_to(np.array([0.0, SPAN]), (flat.shape[0], 2))
    return np.concatenate((ends, angles), axis=1).reshape(*shape, 2 * ORDER + 2)


def critical_angles(coefficients: np.ndarray, order: int) -> np.ndarray:
    """(..., 2 ORDER + 2) angles in [0, SPAN] where d^order q / dtheta^order may take its extremes: both
    ends, and the arguments of the roots of z^ORDER q^(order + 1) clipped to [0, SPAN] (``zero_angles``)."""
    return zero_angles(coefficients, order + 1)


def extremes(coefficients: np.ndarray, h, order: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Exact (min, max) of q^(order) [rad/s^order] over segments (..., 8) of durations ``h`` (...) [s],
    each (...): q^(order) at ``critical_angles``."""
    angles = critical_angles(coefficients, order)
    found = _theta_values(coefficients, angles, order) * (SPAN / np.asarray(h, dtype=float)[..., None]) ** order
    return found.min(axis=-1), found.max(axis=-1)


def segment_extrema(coefficients: np.ndarray, durations: np.ndarray, orders=(0,)):
    """``kinematics.segment_extrema`` for trigonometric segments: where q^(d) may take its extremes on every
    segment (normalised time s = theta / SPAN, ``critical_angles``) and its values there.

    Args:
        coefficients: (B, S, J, 8) each segment's coefficients in theta.
        durations: (B, S) [s].
        orders: the derivative orders d (0: position).

    Returns:
        (locations, values), each (len(orders), B, S, J, 2 ORDER + 2): s in [0, 1] and q^(d)(s h) [SI units].
    """
    h = np.asarray(durations, dtype=float)[..., None, None]  # (B, S, 1, 1)
    locations, values = [], []
    for order in orders:
        angles = critical_angles(coefficients, order)
        locations.append(angles / SPAN)
        values.append(_theta_values(coefficients, angles, order) * (SPAN / h) ** order)
    return np.stack(locations), np.stack(values)


def segment_ranges(coefficients: np.ndarray, durations: np.ndarray, orders=(0,)):
    """``kinematics.segment_ranges`` for trigonometric segments (B, S, J, 8), durations (B, S) [s]: the
    exact (low, high) of q^(d) on every segment, each (len(orders), B, S, J)."""
    _, values = segment_extrema(coefficients, durations, orders)
    return values.min(axis=-1), values.max(axis=-1)


def integral_abs(coefficients: np.ndarray, durations: np.ndarray, order: int) -> np.ndarray:
    """(B, J) exact integral of |q^(order)(t)| dt over trajectories of segments (B, S, J, 8), durations
    (B, S) [s], for ``order`` >= 1: on each segment q^(order) keeps its sign between its zeros
    (``zero_angles``), and its antiderivative is q^(order - 1), so the integral is the sum of
    |q^(order - 1)(b) - q^(order - 1)(a)| over consecutive breakpoints a < b."""
    if order < 1:
        raise ValueError(f"integral_abs needs a derivative order >= 1, got {order}")
    h = np.asarray(durations, dtype=float)
    breaks = np.sort(zero_angles(coefficients, order), axis=-1)
    below = _theta_values(coefficients, breaks, order - 1) * (SPAN / h[..., None, None]) ** (order - 1)
    return np.abs(np.diff(below, axis=-1)).sum(axis=-1).sum(axis=1)


def _jerk_gram() -> np.ndarray:
    """(8, 8) G with integral_0^SPAN (d^3 q / dtheta^3)^2 dtheta = a^T G a."""
    m = _FREQUENCIES[:, None] + _FREQUENCIES[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        integral = np.where(m == 0, SPAN, (np.exp(1j * m * SPAN) - 1) / (1j * m))
    third = _COMPLEX * ((1j * _FREQUENCIES) ** 3)[:, None]  # (9, 8): a -> complex coefficients of q'''
    gram = third.T @ integral @ third
    return np.real((gram + gram.T) / 2)


#: ``_jerk_gram``: integral_0^SPAN (d^3 q / dtheta^3)^2 dtheta = a^T JERK_GRAM a.
JERK_GRAM = _jerk_gram()


def segment_jerk_energy(coefficients: np.ndarray, h) -> np.ndarray:
    """integral_0^h q'''(tau)^2 dtau [rad^2/s^5] of segments (..., 8) of durations ``h`` (...) [s]:
    (SPAN / h)^5 a^T ``JERK_GRAM`` a (dtau = h / SPAN dtheta, q''' = (SPAN / h)^3 d^3q/dtheta^3)."""
    h = np.asarray(h, dtype=float)
    return np.einsum("...i,ij,...j->...", coefficients, JERK_GRAM, coefficients) * (SPAN / h) ** 5


def jerk_energy(coefficients: np.ndarray, durations: np.ndarray) -> np.ndarray:
    """``kinematics.jerk_energy`` for trigonometric segments (B, S, J, 8), durations (B, S) [s]: (B, J) the
    integral of q'''(t)^2 dt over each trajectory [rad^2/s^5] (``segment_jerk_energy`` summed)."""
    return segment_jerk_energy(coefficients, np.asarray(durations, dtype=float)[..., None]).sum(axis=1)


def normalised_weights(s: np.ndarray, order: int) -> np.ndarray:
    """(8, M) W with h^order q^(order)(s h) = sum_i W[i, m] a_i at normalised times s (M,) in [0, 1]: the
    basis' theta derivative at theta = SPAN s times SPAN^order (the polynomial families' counterpart is
    i! / (i - d)! s^(i - d)). The NLP writes its cuts and samples with them."""
    theta = SPAN * np.asarray(s, dtype=float)
    return _theta_values(np.eye(len(BASIS)), theta[None, :], order) * SPAN ** order


#: t = tan(phi / 2) at the ends of a segment, phi = theta - SPAN / 2 (``half_angle_map``).
HALF_ANGLE_BOUND = float(np.tan(SPAN / 4))


def _half_angle_powers() -> np.ndarray:
    """(2 ORDER + 1, 2 ORDER + 1) column p: the coefficients of t^p in powers of u, t = HALF_ANGLE_BOUND (2 u - 1)."""
    out = np.zeros((2 * ORDER + 1, 2 * ORDER + 1))
    for power in range(2 * ORDER + 1):
        column = np.polynomial.polynomial.polypow([-HALF_ANGLE_BOUND, 2 * HALF_ANGLE_BOUND], power)
        out[:len(column), power] = column
    return out


_HALF_ANGLE_POWERS = _half_angle_powers()


@functools.cache
def half_angle_map(order: int) -> np.ndarray:
    """(2 ORDER + 1, 8) the map from a segment's coefficients a to those, in powers of u in [0, 1], of the
    polynomial (1 + t^2)^ORDER d^order q / dtheta^order, where theta = SPAN / 2 + phi and t = tan(phi / 2) =
    HALF_ANGLE_BOUND (2 u - 1): u runs over [0, 1] as theta runs over [0, SPAN].

    cos k phi + i sin k phi = (1 + i t)^(2 k) / (1 + t^2)^k, so (1 + t^2)^ORDER cos k phi is the polynomial
    Re (1 + i t)^(2 k) (1 + t^2)^(ORDER - k) (sin: Im), of degree 2 ORDER, and cos k theta, sin k theta follow
    by the angle sums with k SPAN / 2. The factor (1 + t^2)^ORDER (``HALF_ANGLE_DENOMINATOR``) is positive, so
    the derivative is >= 0 on the segment exactly where this polynomial is >= 0 on [0, 1]: the NLP certifies
    it with Lukacs' form of degree 8 (``timing/sos.py``). Centred on the segment, 1 + t^2 stays within
    [1, 1.45] (the factor within [1, 4.38]); t = tan(theta / 2) would take it to 6.8 (2,200)."""
    polynomial = np.polynomial.polynomial
    in_t = np.zeros((2 * ORDER + 1, 2 * ORDER + 1))  # columns: 1, cos k theta (k = 1 .. ORDER), sin k theta
    for k in range(ORDER + 1):
        rotation = polynomial.polypow([1.0, 1j], 2 * k)
        rest = polynomial.polypow([1.0, 0.0, 1.0], ORDER - k)
        cos_phi, sin_phi = (np.pad(part, (0, 2 * ORDER + 1 - len(part))) for part in
                            (polynomial.polymul(rotation.real, rest), polynomial.polymul(rotation.imag, rest)))
        cos_centre, sin_centre = np.cos(k * SPAN / 2), np.sin(k * SPAN / 2)
        in_t[:, k] = cos_centre * cos_phi - sin_centre * sin_phi
        if k > 0:
            in_t[:, ORDER + k] = sin_centre * cos_phi + cos_centre * sin_phi
    return _HALF_ANGLE_POWERS @ in_t @ _real_derivative(order)


#: (2 ORDER + 1,) the coefficients of (1 + t^2)^ORDER in powers of u (``half_angle_map``).
HALF_ANGLE_DENOMINATOR = _HALF_ANGLE_POWERS @ np.polynomial.polynomial.polypow([1.0, 0.0, 1.0], ORDER)


#: (8, 8) G with integral_0^1 (h^3 q'''(s h))^2 ds = a^T G a: SPAN^5 ``JERK_GRAM``; the jerk energy of a
#: segment is h^-5 times it.
NORMALISED_JERK_GRAM = SPAN ** 5 * JERK_GRAM


#: Grid points on [0, SPAN] at which ``trajectory_ranges`` bounds every segment before it solves for the exact
#: extremes of those that can hold the trajectory's.
GRID_POINTS = 33
_GRID = np.linspace(0.0, SPAN, GRID_POINTS)
_FREQUENCY_OF = np.array([k for k, _ in BASIS], dtype=float)


def trajectory_ranges(coefficients: np.ndarray, durations: np.ndarray, orders=(0,)):
    """Exact (low, high) of q^(d) over whole trajectories, each (len(orders), B, J), for segments (B, S, J, 8)
    of durations (B, S) [s]: ``segment_ranges`` reduced over the segments, solved only where needed.

    On each segment q^(d) is sampled at ``GRID_POINTS`` angles (spacing delta); between two neighbours it
    exceeds their larger value by at most M delta^2 / 8, M >= max |d^2 q^(d) / dtheta^2| (sum_i k_i^(d + 2)
    |a_i|, in theta units). The samples' extremes over all segments are reached, so a segment whose bound
    does not pass them cannot hold the trajectory's extreme; only the others are solved exactly
    (``critical_angles``). Exact, as ``segment_ranges`` is, and several times faster on many segments."""
    h = np.asarray(durations, dtype=float)
    delta = _GRID[1] - _GRID[0]
    lows, highs = [], []
    for order in orders:
        scale = (SPAN / h)[..., None] ** order  # (B, S, 1): theta derivatives to time derivatives
        grid = coefficients @ (_theta_values(np.eye(len(BASIS)), _GRID[None, :], order)) * scale[..., None]
        slack = (np.abs(coefficients) @ _FREQUENCY_OF ** (order + 2)) * scale * delta ** 2 / 8  # (B, S, J)
        top, bottom = grid.max(axis=-1), grid.min(axis=-1)  # (B, S, J)
        high, low = top.max(axis=1), bottom.min(axis=1)  # (B, J): reached, so bounds from inside
        open_high = top + slack > high[:, None, :]
        open_low = bottom - slack < low[:, None, :]
        chosen = open_high | open_low
        if chosen.any():
            b, s, j = np.nonzero(chosen)
            found_low, found_high = extremes(coefficients[b, s, j], h[b, s], order)
            np.maximum.at(high, (b, j), np.where(open_high[b, s, j], found_high, -np.inf))
            np.minimum.at(low, (b, j), np.where(open_low[b, s, j], found_low, np.inf))
        lows.append(low)
        highs.append(high)
    return np.stack(lows), np.stack(highs)
