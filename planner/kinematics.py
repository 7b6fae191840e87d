"""Exact kinematic figures of piecewise polynomials (README, "The maths": exact limit checks), batched.

Everything here works on coefficients (B, S, J, D+1) in local time with
durations (B, S), and is exact up to floating point: extrema come from the
end points of each segment and the real roots of the next derivative inside
it, integrals of |q^(d)| from the roots of q^(d), and the jerk energy from
the closed-form integral of a squared polynomial. No sampling.

Each segment polynomial p(tau), tau in [0, h], is first normalised to
P(s) = p(s h), s in [0, 1] (coefficients c_i h^i), which keeps the root
finding well conditioned whatever the durations.

Each function takes the coefficients' ``basis`` (``splines.BASES``): ``power`` here, ``trigonometric``
through ``trigonometric.py``'s counterparts (roots of trigonometric polynomials).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from math import comb

import numpy as np

from . import trigonometric
from .errors import InputError
from .limits import (
    FEASIBILITY_TOLERANCE,
    LIMITED,
    JointLimits,
    default_joint_names,
    in_degrees,
    in_degrees_apart,
    range_exceeded,
    ratio_exceeded,
    time_scale_factor,
)
from .read_only import ReadOnlyArrays, freeze_arrays
from .splines import PiecewisePolynomial, derivative_coefficients, polyval, powers

_IMAGINARY_TOLERANCE = 1e-7
_LEADING_FLOOR = 1e-14
_NEGLIGIBLE = 1e-10  # relative size of coefficients treated as zero when deflating at s = 1
#: Relative size of a leading coefficient below which the closed forms drop it. Between 1e-9 and about
#: 5e-8 the cubic formula lost a root in [0, 1] to cancellation (0.641 for 0.7071 at 1e-8, beyond the
#: Newton step's reach); from 1e-6 the worst root error times the slope is 4e-10 of the largest
#: coefficient (16,200 random cubics with ratios 1e-10 to 1e-2).
_DROP_DEGREE = 1e-6


def _cubic_roots(p: np.ndarray) -> np.ndarray:
    """Real roots of polynomials of degree <= 3, ``p`` (..., 4) lowest first, in closed form.

    Per element, a leading coefficient below ``_DROP_DEGREE`` (1e-6) of the largest is dropped
    (cubic -> quadratic -> linear), which moves the polynomial by at most that
    much on [0, 1]. Three real roots by the trigonometric method, one by
    Cardano's formula; each root then takes one Newton step on the full
    polynomial. Returns (..., 3), NaN where there is no real root.
    """
    d, c, b, a = np.moveaxis(p, -1, 0)
    scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), np.maximum(np.abs(c), np.abs(d)))
    tiny = _DROP_DEGREE * scale
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # Cubic: s = t - B/3 gives t^3 + P t + Q.
        big_b, big_c, big_d = b / a, c / a, d / a
        pp = big_c - big_b * big_b / 3.0
        qq = 2.0 * big_b * big_b * big_b / 27.0 - big_b * big_c / 3.0 + big_d
        shift = -big_b / 3.0
        pp_cubed = pp * pp * pp
        three_real = 4.0 * pp_cubed + 27.0 * qq * qq < 0.0
        radius = 2.0 * np.sqrt(np.where(three_real, -pp / 3.0, 0.0))
        angle = np.arccos(np.clip(np.where(three_real, 3.0 * qq / (pp * radius), 0.0), -1.0, 1.0)) / 3.0
        trig = radius[..., None] * np.cos(angle[..., None] - 2.0 * np.pi * np.arange(3) / 3.0)
        root_disc = np.sqrt(np.maximum(qq * qq / 4.0 + pp_cubed / 27.0, 0.0))
        single = np.cbrt(-qq / 2.0 + root_disc) + np.cbrt(-qq / 2.0 - root_disc)
        cardano = np.stack((single, np.full_like(single, np.nan), np.full_like(single, np.nan)), axis=-1)
        cubic = np.where(three_real[..., None], trig, cardano) + shift[..., None]
        # Quadratic b s^2 + c s + d, numerically stable form.
        disc = c * c - 4.0 * b * d
        q = -0.5 * (c + np.copysign(np.sqrt(np.where(disc >= 0, disc, np.nan)), c))
        quadratic = np.stack((q / b, d / q, np.full_like(q, np.nan)), axis=-1)
        linear = np.stack((-d / c, np.full_like(c, np.nan), np.full_like(c, np.nan)), axis=-1)
        roots = np.where((np.abs(a) > tiny)[..., None], cubic,
                         np.where((np.abs(b) > tiny)[..., None], quadratic,
                                  np.where((np.abs(c) > tiny)[..., None], linear, np.nan)))
        value = ((a[..., None] * roots + b[..., None]) * roots + c[..., None]) * roots + d[..., None]
        slope = (3.0 * a[..., None] * roots + 2.0 * b[..., None]) * roots + c[..., None]
        step = value / slope
        roots = np.where(np.isfinite(step) & (np.abs(step) < 1e-3), roots - step, roots)
    return roots


def _eigen_roots(p: np.ndarray) -> np.ndarray:
    """Real roots of polynomials ``p`` (..., k+1) of any degree, from companion eigenvalues.

    A leading coefficient below 1e-14 of the largest is raised to that floor
    (moving P by at most that much on [0, 1]). Returns (..., k), NaN where complex.
    """
    degree = p.shape[-1] - 1
    scale = np.abs(p).max(axis=-1)
    floor = _LEADING_FLOOR * scale
    lead = p[..., -1]
    lead = np.where(np.abs(lead) >= floor, lead, np.where(lead < 0, -floor, floor))
    lead = np.where(scale > 0, lead, 1.0)
    companion = np.zeros(p.shape[:-1] + (degree, degree))
    companion[..., np.arange(1, degree), np.arange(degree - 1)] = 1.0
    companion[..., :, -1] = -p[..., :-1] / lead[..., None]
    eigen = np.linalg.eigvals(companion)
    real = eigen.real
    return np.where(np.abs(eigen.imag) <= _IMAGINARY_TOLERANCE * (1.0 + np.abs(real)), real, np.nan)


def _column_nonzero(p: np.ndarray) -> np.ndarray:
    """(C, k+1): whether coefficient i of column c is nonzero anywhere in p (B, C, J, k+1).

    Reduces along long contiguous rows; numpy's reduction over short or
    strided axes costs tens of microseconds per call on these shapes.
    """
    batch, columns, joints, width = p.shape
    rows = p.transpose(1, 3, 0, 2).reshape(columns * width, batch * joints)
    return np.count_nonzero(rows, axis=1).reshape(columns, width) > 0


def _last_axis_extremes(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Min and max over a short last axis, as running elementwise minimum/maximum."""
    low = values[..., 0].copy()
    high = low.copy()
    for i in range(1, values.shape[-1]):
        np.minimum(low, values[..., i], out=low)
        np.maximum(high, values[..., i], out=high)
    return low, high


def _in_unit_interval(roots: np.ndarray) -> np.ndarray:
    inside = (roots >= -1e-12) & (roots <= 1.0 + 1e-12)
    return np.where(inside, np.clip(roots, 0.0, 1.0), np.nan)


@lru_cache(maxsize=None)
def _binomial_reflection(size: int) -> np.ndarray:
    """R with (p @ R)[i] the coefficients of p(1 - u) in u: (-1)^i sum_k C(k, i) p_k."""
    return np.array([[(-1) ** i * comb(k, i) for i in range(size)] for k in range(size)], dtype=float)


def column_roots(p: np.ndarray) -> np.ndarray:
    """Roots in [0, 1] of polynomials p (B, C, J, k+1) in normalised time, column by column.

    Each column (fixed second index) is analysed over the whole batch and all
    joints: its degree is its highest nonzero power, and a root of multiplicity
    m at s = 0 (m exactly-zero low coefficients) or at s = 1 (m coefficients
    of p(1 - u) below 1e-10 of the largest) is divided out, since end points
    are candidates anyway. The hybrid family's 7th-order end segments, which
    rest at one end, deflate this way to cubics; everything of degree <= 3
    then goes through one closed-form solve, anything else through companion
    eigenvalues.

    Returns:
        (B, C, J, R) roots in [0, 1], NaN padded, R the most roots any column can have.
    """
    batch, columns, joints, width = p.shape
    if width == 0:  # the derivative of a constant: no coefficients, no roots
        return np.full((batch, columns, joints, 0), np.nan)
    nonzero = _column_nonzero(p)
    has_any = nonzero.any(axis=1)
    top = np.where(has_any, width - 1 - np.argmax(nonzero[:, ::-1], axis=1), 0)
    low = np.where(has_any, np.argmax(nonzero, axis=1), 0)
    side = np.zeros(columns, dtype=int)
    reflected: np.ndarray | None = None
    deep = np.flatnonzero(top - low > 3)
    if deep.size:
        reflected = p[:, deep] @ _binomial_reflection(width)
        scale = np.abs(p[:, deep]).max(axis=-1, keepdims=True)
        negligible = np.all(np.abs(reflected) <= _NEGLIGIBLE * scale, axis=(0, 2))  # (deep, k+1)
        zeros_at_one = np.argmin(np.concatenate((negligible, np.zeros((deep.size, 1), bool)), axis=1), axis=1)
        better = zeros_at_one > low[deep]
        side[deep[better]] = 1
        low[deep[better]] = zeros_at_one[better]
    degree = top - low
    result = np.full((batch, columns, joints, max(int(degree.max(initial=0)), 0)), np.nan)
    groups: dict[str, list] = {"linear": [], "cubic": [], "eigen": []}
    for s, lo, hi in sorted(set(zip(side.tolist(), low.tolist(), top.tolist()))):
        if hi - lo < 1:
            continue
        cols = np.flatnonzero((side == s) & (low == lo) & (top == hi))
        source = reflected[:, np.searchsorted(deep, cols)] if s and reflected is not None else p[:, cols]
        kind = "linear" if hi - lo == 1 else "cubic" if hi - lo <= 3 else "eigen"
        groups[kind].append((cols, s, source[..., lo:hi + 1]))

    def store(cols, s, found):
        result[:, cols, :, :found.shape[-1]] = 1.0 - found if s else found

    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a huge root: outside [0, 1]
        for cols, s, x in groups["linear"]:
            store(cols, s, -x[..., :1] / x[..., 1:])
    if groups["cubic"]:
        padded = np.concatenate([np.concatenate((x, np.zeros(x.shape[:-1] + (4 - x.shape[-1],))), axis=-1)
                                 for _, _, x in groups["cubic"]], axis=1)
        roots = _cubic_roots(padded)
        offset = 0
        for cols, s, x in groups["cubic"]:
            store(cols, s, roots[:, offset:offset + len(cols), :, :x.shape[-1] - 1])
            offset += len(cols)
    for cols, s, x in groups["eigen"]:
        store(cols, s, _eigen_roots(x))
    return _in_unit_interval(result)


def _normalised(coefficients: np.ndarray, durations: np.ndarray) -> np.ndarray:
    """P(s) = p(s h): coefficients c_i h^i, shape as ``coefficients``."""
    return coefficients * powers(durations, coefficients.shape[-1])[..., None, :]


def _normalised_derivatives(coefficients: np.ndarray, durations: np.ndarray, orders) -> np.ndarray:
    """P_d(s) = q^(d)(s h) for each order, stacked on the segment axis: (B, len(orders) * S, J, D+1).

    With P(s) = q(s h), P_d = h^(-d) d^d P / ds^d: one normalisation, then
    derivatives in s, padded with zeros to the full width.
    """
    position = _normalised(coefficients, durations)
    inverse = 1.0 / durations[..., None, None]
    parts = []
    for order in orders:
        d = derivative_coefficients(position, order)
        padded = np.zeros(position.shape)
        padded[..., :d.shape[-1]] = d
        for _ in range(order):
            padded *= inverse
        parts.append(padded)
    return np.concatenate(parts, axis=1)


def _degree_blocks(coefficients: np.ndarray) -> list[tuple[np.ndarray, int]]:
    """Segment indices grouped by degree (the highest power nonzero for any candidate or joint)."""
    width = coefficients.shape[-1]
    nonzero = _column_nonzero(coefficients)
    top = np.where(nonzero.any(axis=1), width - 1 - np.argmax(nonzero[:, ::-1], axis=1), 0)
    return [(np.flatnonzero(top == degree), max(int(degree), 1)) for degree in np.unique(top)]


def _block_candidates(coefficients: np.ndarray, durations: np.ndarray, orders):
    """For one block of segments of equal degree: the normalised derivatives P_d, stacked as in
    ``_normalised_derivatives``, and the candidate points of their extremes (..., 2 + R): s = 0,
    s = 1, then the roots of P_d' in [0, 1] (0 where a segment has fewer)."""
    width = coefficients.shape[-1]
    p = _normalised_derivatives(coefficients, durations, orders)
    slope = p[..., 1:] * np.arange(1, width)
    roots = np.nan_to_num(column_roots(slope), nan=0.0)
    ends = np.zeros(p.shape[:-1] + (2,))
    ends[..., 1] = 1.0
    return p, np.concatenate((ends, roots), axis=-1)


def segment_ranges(coefficients: np.ndarray, durations: np.ndarray, orders=(0,), basis: str = "power"):
    """Exact min and max of q^(d) on every segment, for each order d in ``orders``.

    Candidates are the segment ends and the real roots of q^(d+1) inside.
    Segments are handled in blocks of equal degree (the hybrid family's cubic
    interior apart from its 7th-order ends), each at its own width.

    Args:
        coefficients: (B, S, J, D+1) each segment's coefficients in its local time tau [s], lowest first.
        durations: (B, S) [s].
        orders: the derivative orders d (0: position).
        basis: the coefficients' basis (module docstring).

    Returns:
        (low, high), each (len(orders), B, S, J) [SI units of each order].
    """
    if basis == "trigonometric":
        return trigonometric.segment_ranges(coefficients, durations, orders)
    batch, segments, joints, _ = coefficients.shape
    low = np.empty((len(orders), batch, segments, joints))
    high = np.empty_like(low)
    shape = (batch, len(orders), -1, joints)
    for cols, degree in _degree_blocks(coefficients):
        p, points = _block_candidates(coefficients[:, cols, :, :degree + 1], durations[:, cols], orders)
        block_low, block_high = _last_axis_extremes(polyval(p, points))
        low[:, :, cols] = block_low.reshape(shape).swapaxes(0, 1)
        high[:, :, cols] = block_high.reshape(shape).swapaxes(0, 1)
    return low, high


def segment_extrema(coefficients: np.ndarray, durations: np.ndarray, orders=(0,), basis: str = "power"):
    """Where q^(d) may take its extremes on every segment, and its values there.

    The candidates of ``segment_ranges``, kept: the ends s = 0 and s = 1 of
    each segment (normalised time s = tau / h) and the roots of q^(d+1) inside.

    Args:
        coefficients: (B, S, J, D+1) each segment's coefficients in its local time tau [s], lowest first.
        durations: (B, S) [s].
        orders: the derivative orders d (0: position).
        basis: the coefficients' basis (module docstring).

    Returns:
        (locations, values), each (len(orders), B, S, J, C): s in [0, 1] (s = 0
        repeated where a segment has fewer roots) and q^(d)(s h) [SI units of each order].
    """
    if basis == "trigonometric":
        return trigonometric.segment_extrema(coefficients, durations, orders)
    batch, segments, joints, _ = coefficients.shape
    blocks = []
    for cols, degree in _degree_blocks(coefficients):
        p, points = _block_candidates(coefficients[:, cols, :, :degree + 1], durations[:, cols], orders)
        shape = (batch, len(orders), len(cols), joints, points.shape[-1])
        blocks.append((cols, points.reshape(shape).swapaxes(0, 1), polyval(p, points).reshape(shape).swapaxes(0, 1)))
    count = max(points.shape[-1] for _, points, _ in blocks)
    locations = np.zeros((len(orders), batch, segments, joints, count))
    values = np.empty_like(locations)
    for cols, points, found in blocks:
        locations[:, :, cols, :, :points.shape[-1]] = points
        values[:, :, cols] = found[..., :1]
        values[:, :, cols, :, :found.shape[-1]] = found
    return locations, values


def max_abs(coefficients: np.ndarray, durations: np.ndarray, basis: str = "power") -> np.ndarray:
    """(B, 3, J) exact max |velocity|, |acceleration|, |jerk| over the whole trajectory."""
    if basis == "trigonometric":
        low, high = trigonometric.trajectory_ranges(coefficients, durations, (1, 2, 3))
        return np.maximum(-low, high).swapaxes(0, 1)
    low, high = segment_ranges(coefficients, durations, (1, 2, 3), basis)
    return np.maximum(-low, high).max(axis=2).swapaxes(0, 1)


def position_range(coefficients: np.ndarray, durations: np.ndarray,
                   basis: str = "power") -> tuple[np.ndarray, np.ndarray]:
    """(B, J) exact minimum and maximum position [rad] over the whole trajectory."""
    if basis == "trigonometric":
        low, high = trigonometric.trajectory_ranges(coefficients, durations, (0,))
        return low[0], high[0]
    low, high = segment_ranges(coefficients, durations, (0,), basis)
    return low[0].min(axis=1), high[0].max(axis=1)


def integral_abs(coefficients: np.ndarray, durations: np.ndarray, order: int, basis: str = "power") -> np.ndarray:
    """(B, J) exact integral of |q^(order)(t)| dt over the trajectory.

    On each segment, the sign changes of P(s) are the real roots of P in
    [0, 1]; with A the antiderivative of P, the integral is
    h * sum |A(s_{i+1}) - A(s_i)| over the sorted breakpoints 0, roots, 1.
    """
    if basis == "trigonometric":
        return trigonometric.integral_abs(coefficients, durations, order)
    p = _normalised(derivative_coefficients(coefficients, order), durations)
    antiderivative = np.concatenate((np.zeros(p.shape[:-1] + (1,)), p / np.arange(1, p.shape[-1] + 1)),
                                    axis=-1)
    roots = column_roots(p)
    breaks = np.concatenate((np.zeros(p.shape[:-1] + (1,)), np.nan_to_num(roots, nan=1.0),
                             np.ones(p.shape[:-1] + (1,))), axis=-1)
    breaks.sort(axis=-1)
    per_segment = np.abs(np.diff(polyval(antiderivative, breaks), axis=-1)).sum(axis=-1)
    return (per_segment * durations[..., None]).sum(axis=1)


def jerk_energy(coefficients: np.ndarray, durations: np.ndarray, basis: str = "power") -> np.ndarray:
    """(B, J) exact jerk energy, the integral of q'''(t)^2 dt [rad^2/s^5].

    With normalised jerk coefficients J_i = j_i h^i on a segment,
    integral_0^h (sum j_i tau^i)^2 dtau = h * sum_{i,k} J_i J_k / (i + k + 1).
    """
    if basis == "trigonometric":
        return trigonometric.jerk_energy(coefficients, durations)
    jerk = _normalised(derivative_coefficients(coefficients, 3), durations)
    size = jerk.shape[-1]
    hilbert = 1.0 / (np.arange(size)[:, None] + np.arange(size)[None, :] + 1.0)
    per_segment = np.einsum("bsji,ik,bsjk->bsj", jerk, hilbert, jerk)
    return (per_segment * durations[..., None]).sum(axis=1)


@dataclass(frozen=True)
class Violation:
    """A limit a trajectory exceeds.

    Attributes:
        joint: the joint's name; index: its index (0-based).
        quantity: ``position``, ``velocity``, ``acceleration`` or ``jerk``; order: its derivative order.
        value: the trajectory's extreme [SI: rad, rad/s, ...] (the largest magnitude, or for
            ``position`` the lowest or highest position).
        limit: the limit it exceeds [SI]; side: ``lower`` or ``upper`` for a position, else ``""``.
    """

    joint: str
    index: int
    quantity: str
    order: int
    value: float
    limit: float
    side: str = ""

    @property
    def ratio(self) -> float:
        """|value| / limit for a magnitude limit; 0 for a position (which has no ratio)."""
        return abs(self.value) / self.limit if self.order else 0.0

    def __str__(self) -> str:
        if self.order:  # as many digits as the magnitude and the limit take to differ; the value keeps its sign
            magnitude, limit = in_degrees_apart(abs(self.value), self.limit, self.order)
            value = f"-{magnitude}" if self.value < 0 else magnitude
            return f"joint {self.joint} {self.quantity} {value} exceeds its limit {limit}"
        value, limit = in_degrees_apart(self.value, self.limit, 0)
        where = "below its lower" if self.side == "lower" else "above its upper"
        return f"joint {self.joint} position {value} is {where} limit {limit}"


@dataclass(frozen=True)
class KinematicFigures(ReadOnlyArrays):
    """Exact per-joint figures of one trajectory, in SI units.

    Attributes:
        max_abs: (3, J) max |velocity|, |acceleration|, |jerk|.
        mean_abs: (3, J) time-averaged |velocity|, |acceleration|, |jerk| (paper Table VI).
        position_min, position_max: (J,) position range reached [rad].
        jerk_energy: (J,) integral of jerk squared [rad^2/s^5].
        total_time: T [s].
    """

    max_abs: np.ndarray
    mean_abs: np.ndarray
    position_min: np.ndarray
    position_max: np.ndarray
    jerk_energy: np.ndarray
    total_time: float

    def __post_init__(self):
        freeze_arrays(self)

    def ratios(self, limits: JointLimits) -> np.ndarray:
        """(3, J) constraint ratios against ``limits``.

        Raises:
            InputError: ``limits`` is no ``JointLimits``, or is for another number of joints.
        """
        if not isinstance(limits, JointLimits) or limits.joint_count != self.max_abs.shape[-1]:
            raise InputError(f"limits must be a JointLimits for {self.max_abs.shape[-1]} joints, got "
                             f"{limits.joint_count if isinstance(limits, JointLimits) else type(limits).__name__}"
                             f"{' joints' if isinstance(limits, JointLimits) else ''}")
        return limits.ratios(self.max_abs)

    def violations(self, limits: JointLimits) -> list[Violation]:
        """Every limit the trajectory exceeds (magnitudes by order, then positions, each by joint);
        empty when feasible.

        The one definition of feasibility (the optimizers' exact check, ``summary.json``,
        ``replay --check`` use it): every ratio <= 1 + ``FEASIBILITY_TOLERANCE`` and every position
        within ``FEASIBILITY_TOLERANCE`` [rad] of its range (``ratio_exceeded``, ``range_exceeded``: the
        optimizers' batched feasibility applies the same two tests).
        """
        found = []
        ratios = self.ratios(limits)
        for quantity in LIMITED:
            d = quantity.order - 1
            for j in np.flatnonzero(ratio_exceeded(ratios[d])):
                found.append(Violation(limits.names[j], int(j), quantity.name, quantity.order,
                                       float(self.max_abs[d, j]), float(limits.magnitudes[d, j])))
        for side, values, bounds, outside in (("lower", self.position_min, limits.lower, -1.0),
                                              ("upper", self.position_max, limits.upper, 1.0)):
            for j in np.flatnonzero(range_exceeded(outside * (values - bounds))):
                found.append(Violation(limits.names[j], int(j), "position", 0, float(values[j]), float(bounds[j]),
                                       side))
        return found


class Break(str):
    """One line of ``continuity_breaks`` or ``via_point_misses`` (compared and joined as text), with the
    joint's name (``joint``) and index (``joint_index``), the quantity (``position``, ``velocity``,
    ``acceleration``), the value found [SI] and the tolerance it exceeds [SI] as fields, as an
    ``InfeasibleError`` carries them."""

    joint: str
    joint_index: int
    quantity: str
    value: float
    limit: float

    def __new__(cls, text: str, joint: str, joint_index: int, quantity: str, value: float, limit: float) -> "Break":
        """The line ``text`` with its fields (value and limit in SI units)."""
        line = super().__new__(cls, text)
        line.joint, line.joint_index, line.quantity = joint, joint_index, quantity
        line.value, line.limit = float(value), float(limit)
        return line

    def __reduce__(self):
        """Pickle with its fields (a check run in a worker process returns its lines whole)."""
        return Break, (str(self), self.joint, self.joint_index, self.quantity, self.value, self.limit)


#: The derivative orders every family keeps continuous across its knots (position, velocity, acceleration:
#: C2; the cubic families' jerk steps by design), the last two 0 at both ends, where every family rests.
CONTINUOUS_ORDERS = ("position", "velocity", "acceleration")


#: The coefficients' rounding ``continuity_breaks`` allows, in units of eps |q| / h^d (the planner's
#: own splines, every family, tiny motions at up to 1e5 deg: at most 0.74 of it).
ROUNDING_ULPS = 16


def continuity_breaks(trajectory: PiecewisePolynomial,
                      names: tuple[str, ...] | list[str] | None = None) -> list[Break]:
    """Where ``trajectory`` is not a motion the planner makes, one line each (empty: none): a jump of a
    joint's position, velocity or acceleration at a knot (the first per joint and order), or a velocity or
    acceleration other than 0 at the start or the end. A jump counts beyond ``FEASIBILITY_TOLERANCE`` of
    the order's scale, the largest over segments and joints of a bound on |q^(d)| there (sum_i |c_i^(d)| h^i
    for polynomials; for positions, at least 1 rad), plus the coefficients' rounding, ``ROUNDING_ULPS`` eps
    |q| / h^d with |q| the joint's largest position and h the shorter segment at the knot (coefficients
    of order d are differences of positions over h^d: a 1e-9 rad motion at 3 rad, in 1 ms segments,
    jumped 1e-13 rad/s, more than 1e-9 of its velocity); the planner's own trajectories jump by less
    than 1e-12 of the scale.

    On segment k, q^(d) at its start and end, and the bound, are ``PiecewisePolynomial.segment_ends``.
    """
    h = trajectory.durations
    names = names or default_joint_names(trajectory.joint_count)
    knot_times = trajectory.knot_times
    magnitude = np.abs(trajectory.segment_ends(0)[0]).max(axis=0)  # (J,) the largest position of each joint [rad]
    shorter = np.minimum(h[:-1], h[1:])  # (S - 1,) at each interior knot
    breaks = []
    for order, quantity in enumerate(CONTINUOUS_ORDERS):
        start, end, bound = trajectory.segment_ends(order)  # bound: on |q^(d)| over each segment
        scale = max(float(np.max(bound)), 1.0 if order == 0 else 0.0)
        with np.errstate(over="ignore"):
            rounding = ROUNDING_ULPS * np.finfo(float).eps * magnitude / np.concatenate(
                (h[:1], shorter, h[-1:]))[:, None] ** order  # (S + 1, J): at the start, each knot, the end
        allowed = FEASIBILITY_TOLERANCE * scale + rounding
        jumps = np.abs(end[:-1] - start[1:])  # (S - 1, J): knot k + 1
        for j, name in enumerate(names):
            beyond = np.flatnonzero(~(jumps[:, j] <= allowed[1:-1, j]))
            if beyond.size:
                k = int(beyond[0]) + 1
                breaks.append(Break(f"joint {name} {quantity} jumps by {in_degrees(jumps[k - 1, j], order)} at knot "
                                    f"{k} (t = {knot_times[k]:.6g} s)", name, j, quantity, jumps[k - 1, j],
                                    allowed[k, j]))
            for where, value, limit in (("start", start[0, j], allowed[0, j]),
                                        ("end", end[-1, j], allowed[-1, j])) if order else ():
                if not abs(value) <= limit:
                    breaks.append(Break(f"joint {name} {quantity} is {in_degrees(value, order)} at the {where}, "
                                        f"where every trajectory rests", name, j, quantity, value, limit))
    return breaks


def via_point_misses(trajectory: PiecewisePolynomial, via_points: np.ndarray,
                     names: tuple[str, ...] | list[str] | None = None) -> list[Break]:
    """Via-points (n, J) [rad] ``trajectory`` does not pass at its ``via_times``, one line per joint that
    misses one (the first it misses), naming the via-point, the joint and by how much (empty: none). A
    miss counts beyond ``2 FEASIBILITY_TOLERANCE`` of max(1 rad, |via-point|): the planner merges via-points
    within 1e-9 rad of each other into one."""
    via_points = np.asarray(via_points, dtype=float)
    names = names or default_joint_names(trajectory.joint_count)
    times = trajectory.via_times
    miss = np.abs(trajectory.evaluate(times) - via_points)
    allowed = 2 * FEASIBILITY_TOLERANCE * np.maximum(np.abs(via_points), 1.0)
    found = []
    for j, name in enumerate(names):
        beyond = np.flatnonzero(~(miss[:, j] <= allowed[:, j]))
        if beyond.size:
            i = int(beyond[0])
            found.append(Break(f"joint {name} misses via-point {i} by {in_degrees(miss[i, j], 0)} (t = "
                               f"{times[i]:.6g} s)", name, j, "position", miss[i, j], allowed[i, j]))
    return found


def kinematic_figures(trajectory: PiecewisePolynomial) -> KinematicFigures:
    """All exact figures of one trajectory.

    Raises:
        InputError: ``trajectory`` is not a ``PiecewisePolynomial``.
    """
    if not isinstance(trajectory, PiecewisePolynomial):
        raise InputError(f"kinematic_figures takes a PiecewisePolynomial, not {type(trajectory).__name__}")
    c = trajectory.coefficients[None]
    h = trajectory.durations[None]
    basis = trajectory.basis
    total = trajectory.total_time
    low, high = position_range(c, h, basis)
    mean = np.stack([integral_abs(c, h, order, basis)[0] for order in (1, 2, 3)]) / total
    return KinematicFigures(max_abs(c, h, basis)[0], mean, low[0], high[0], jerk_energy(c, h, basis)[0], total)


def batch_scale_factors(coefficients: np.ndarray, durations: np.ndarray, limits: JointLimits, basis: str = "power"):
    """Constraint ratios (B, 3, J) and the time-scale factors s* (B,) of the time-scaling lemma."""
    ratios = limits.ratios(max_abs(coefficients, durations, basis))
    return ratios, time_scale_factor(ratios)
