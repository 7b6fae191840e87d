"""Each spline family written for the sparse timing NLP: durations and knot states as variables.

A family's build (``splines.py``) fixes the knot states (velocities,
accelerations, ...) from the durations by a linear solve. The sparse NLP
(``nlp.py``) instead makes them decision variables next to the durations and
imposes the family's continuity conditions as equality constraints. Each of
those involves one segment only, so the constraint Jacobian is banded and the
problem grows linearly with the number of via-points; the solver sees exact
derivatives of smooth expressions.

Conventions: on segment k, s = tau / h_k in [0, 1] is normalised time and
P(s) = q(s h_k) the normalised polynomial, with coefficients b_i = c_i h_k^i,
so that q^(d)(s h_k) = h_k^(-d) P^(d)(s). Variables are scaled to order one:
durations by a time scale [s], and each joint's knot states by that joint's
characteristic velocity, acceleration, jerk and snap (``Scales``).

Expressions are CasADi ``MX`` matrices shaped (segments or knots, joints).
CasADi is imported lazily: importing the planner does not load it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from math import factorial
from typing import Any

import numpy as np

from .. import trigonometric
from ..limits import JointLimits
from ..read_only import ReadOnlyArrays, freeze_arrays
from ..splines import HYBRID_END, HYBRID_END_REFLECTED, SplineFamily, derivative_coefficients, hermite7, segment_ends


def _peak(coefficients: np.ndarray) -> float:
    """max |p(s)| over s in [0, 1] of a numeric polynomial (lowest order first)."""
    polynomial = np.polynomial.Polynomial(coefficients)
    roots = polynomial.deriv().roots()
    candidates = np.concatenate(([0.0, 1.0], roots[(np.abs(roots.imag) < 1e-12) & (roots.real > 0)
                                                   & (roots.real < 1)].real))
    return float(np.abs(polynomial(candidates)).max())


#: max |P'''| of ``HYBRID_END`` on [0, 1]: the end segment's largest jerk is this times |M_1| / h_0.
HYBRID_END_JERK = _peak(derivative_coefficients(HYBRID_END, 3))


#: An acceleration or jerk limit this many times what the reference trajectory reaches, and what its
#: velocity (acceleration) over its mean duration implies, does not set that quantity's scale: the
#: knot states would sit below IPOPT's tolerances (velocity limits of 1e-6 deg/s beside acceleration
#: and jerk limits of the paper: 1e-17 of them, and both starts ended Search_Direction_Becomes_Too_Small
#: 30 % above the optimum).
FAR_ABOVE = 1e3


@dataclass(frozen=True)
class Scales(ReadOnlyArrays):
    """Characteristic magnitudes that scale the NLP's variables and constraints to order one.

    Attributes:
        time: a typical segment duration [s].
        derivatives: (4, J) typical |q^(d)| for d = 1..4 [rad/s^d]: the limit where one is
            given (unless ``FAR_ABOVE`` what the motion reaches), else the reference trajectory's
            peak, else 1; snap is jerk / time.
        segment_times: (S,) the reference trajectory's durations [s].
    """

    time: float
    derivatives: np.ndarray
    segment_times: np.ndarray

    def __post_init__(self):
        freeze_arrays(self)

    @classmethod
    def of(cls, limits: JointLimits, durations: np.ndarray, peaks: np.ndarray) -> "Scales":
        """Scales from the limits and a reference trajectory (durations (S,), peaks (3, J) [SI])."""
        magnitudes = limits.magnitudes
        fallback = np.where(peaks > 0, peaks, 1.0)
        typical = np.where(np.isfinite(magnitudes), magnitudes, fallback)
        time = float(np.mean(durations))
        for d in (1, 2):  # a limit far above what the motion reaches and implies does not set its scale
            reached = np.maximum(typical[d - 1] / time, fallback[d])
            typical[d] = np.where(typical[d] > FAR_ABOVE * reached, reached, typical[d])
        return cls(time, np.vstack((typical, typical[2] / time)), np.asarray(durations, dtype=float))


@dataclass
class SegmentBlock:
    """Segments sharing one polynomial degree, as their normalised coefficients.

    Attributes:
        segments: (K,) segment indices.
        coefficients: D + 1 expressions (K, J): the coefficients b_0 .. b_D of P(s); for the
            ``trigonometric`` basis, the 8 coefficients a_i of ``trigonometric.BASIS`` (D = 7: the NLP bounds
            them as it does a degree-7 polynomial's, by cuts).
        certified: derivative orders (0 = position) whose extremes inside these segments
            the NLP must bound by certificates; the others are bounded exactly by the
            formulation's own constraints.
        basis: ``power`` or ``trigonometric`` (``splines.BASES``).
    """

    segments: np.ndarray
    coefficients: list
    certified: tuple[int, ...] = ()
    basis: str = "power"

    @property
    def degree(self) -> int:
        """D, the polynomial degree of these segments."""
        return len(self.coefficients) - 1

    def weights(self, s: np.ndarray, order: int) -> np.ndarray:
        """(D + 1, M) W with h^order q^(order)(s h) = sum_i W[i, m] b_i at normalised times s (M,): i! / (i -
        order)! s^(i - order) for polynomials, ``trigonometric.normalised_weights`` for the trigonometric basis."""
        s = np.asarray(s, dtype=float)
        if self.basis == "trigonometric":
            return trigonometric.normalised_weights(s, order)
        return np.array([factorial(i) / factorial(i - order) * s ** (i - order) if i >= order else np.zeros_like(s)
                         for i in range(self.degree + 1)])

    def certified_map(self, order: int) -> np.ndarray:
        """(P + 1, D + 1) M whose product with b holds the coefficients, in powers of u in [0, 1] over the
        segment, of w(u) h^order q^(order) with w > 0, the polynomial an exact certificate bounds: for
        polynomials u = s, w = 1 and M[i - order, i] = i! / (i - order)! (P = D - order); for the
        trigonometric basis SPAN^order ``trigonometric.half_angle_map`` (P = 8, w
        ``trigonometric.HALF_ANGLE_DENOMINATOR``)."""
        if self.basis == "trigonometric":
            return trigonometric.SPAN ** order * trigonometric.half_angle_map(order)
        out = np.zeros((self.degree - order + 1, self.degree + 1))
        for i in range(order, self.degree + 1):
            out[i - order, i] = factorial(i) / factorial(i - order)
        return out

    def jerk_gram(self) -> np.ndarray:
        """(D + 1, D + 1) G with integral_0^1 (h^3 q^(3)(s h))^2 ds = b^T G b: for polynomials
        i! / (i - 3)! k! / (k - 3)! / (i + k - 5) (i, k >= 3); ``trigonometric.NORMALISED_JERK_GRAM``."""
        if self.basis == "trigonometric":
            return trigonometric.NORMALISED_JERK_GRAM
        falling = np.array([factorial(i) / factorial(i - 3) if i >= 3 else 0.0 for i in range(self.degree + 1)])
        powers = np.arange(self.degree + 1)
        with np.errstate(divide="ignore"):
            hilbert = np.where(np.add.outer(powers, powers) >= 6, 1.0 / (np.add.outer(powers, powers) - 5.0), 0.0)
        return np.outer(falling, falling) * hilbert


@dataclass
class SymbolicSpline:
    """A family's spline as expressions of the durations and its knot-state variables.

    Attributes:
        states: the scaled knot-state variables (a column).
        lower, upper: their bounds: the exact knot limits (+-inf where none).
        equalities: continuity conditions, each zero at a valid spline.
        constraints: exact limit constraints (expression, lower, upper), scaled to order one.
        blocks: the segments as normalised polynomials.
    """

    states: Any
    lower: np.ndarray
    upper: np.ndarray
    equalities: Any
    constraints: list = field(default_factory=list)
    blocks: list = field(default_factory=list)


class SplineFormulation:
    """The symbolic form of one family for given via-points, limits and scales.

    Attributes:
        limits_by_cuts: whether the family's extremes inside segments are bounded by certificates of degree
            4 and above (degree 5 and above: cuts, whose rounds re-place them, or hermite7's exact forms,
            ``sos.py``, a program many times the size of the spline's), so that an NLP start takes long.
    """

    limits_by_cuts = False

    def __init__(self, family: SplineFamily, via_points: np.ndarray, limits: JointLimits, scales: Scales,
                 longest_total: float = math.inf):
        """``longest_total``: a total time [s] the optimum does not exceed (that of a feasible timing, where
        the objective is time alone; inf where none is known: with jerk energy in the objective, a better
        timing may take longer)."""
        self.family = family
        self.via_points = via_points
        self.limits = limits
        self.scales = scales
        self.longest_total = longest_total

    @property
    def joint_count(self) -> int:
        """J, the number of joints."""
        return self.via_points.shape[1]

    @property
    def relative_via_points(self) -> np.ndarray:
        """(n, J) the via-points relative to the first [rad]. The formulations build every coefficient but
        b_0 (and every continuity condition) from these: from the absolute positions, a constant times a
        joint's position at 720 deg (12.6 rad) minus the same times the next one's rounds at 1e-15 of
        12.6 rad, where a motion of 1e-4 deg (2e-6 rad) needs 1e-10 of it."""
        return self.via_points - self.via_points[0]

    def build(self, h) -> SymbolicSpline:
        """The spline for symbolic durations ``h`` (S x 1) [s]."""
        raise NotImplementedError

    def state_values(self, coefficients: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """The scaled knot states of a built spline (coefficients (S, J, D+1), durations (S,))."""
        raise NotImplementedError

    def via_point_states(self, values: np.ndarray) -> np.ndarray | None:
        """(n, J, 3) velocity, acceleration and jerk at the via-points from the scaled state
        variables' values, for a family whose states are free (``SplineFamily.free_states``);
        None where the durations determine them."""
        return None

    def resting_sides(self) -> np.ndarray:
        """(n, J) +1 / -1 where an interior via-point sits on its joint's upper / lower position bound
        (``JointLimits.bound_sides``: within ``RESTING_DISTANCE``), else 0.

        There the joint must stop (a nonzero velocity leaves the range on one side), so its knot
        velocity is fixed at 0: exact, and it keeps the position certificates of the adjacent
        segments non-degenerate (``nlp.touch_certificate``). Not a joint that never moves
        (``still_joints``): it rests everywhere by itself, and its fixed velocities beside its continuity
        rows and range rows made the constraints linearly dependent (a joint parked on a bound: every start
        ended Error_In_Step_Computation, 7-8 % above the optimum)."""
        sides = self.limits.bound_sides(self.via_points)
        sides[[0, -1]] = 0
        sides[:, self.still_joints] = 0
        return sides

    @property
    def still_joints(self) -> np.ndarray:
        """(J,) whether a joint's via-points are all equal: every family keeps it there for any durations (its
        knot states are linear in the via-points relative to the first; where the states are free, they are
        held at 0), so its range needs no constraint."""
        return np.ptp(self.via_points, axis=0) == 0

    def knot_resting_sides(self) -> np.ndarray:
        """(knots, J) ``resting_sides`` at the family's knots (virtual knots never rest)."""
        raise NotImplementedError

    def _scaled_bounds(self, order: int, count: int) -> np.ndarray:
        """(count * J,) bounds of scaled knot values of derivative ``order``, joint-major."""
        limit = self.limits.magnitudes[order - 1] if order <= 3 else np.full(self.joint_count, np.inf)
        return np.repeat(limit / self.scales.derivatives[order - 1], count)


def _columns(ca, values: np.ndarray):
    """A constant (K, J) matrix for CasADi."""
    return ca.DM(np.asarray(values, dtype=float))


def _per_joint(ca, row: np.ndarray, count: int):
    """The (count, J) constant matrix whose every row is ``row``."""
    return ca.repmat(ca.DM(np.asarray(row, dtype=float).reshape(1, -1)), count, 1)


class CubicFormulation(SplineFormulation):
    """``cubic`` and ``hybrid`` with knot velocities v_k and accelerations M_k.

    Knots k = 0 .. m-1 (m = n + 2), segments k = 0 .. S-1 (S = n + 1); v and M
    vanish at both ends and are variables at the n interior knots. The knot
    positions are the via-points except the virtual knots, which the zero end
    velocity fixes in closed form: y_1 = p_0 + h_0^2 M_1 / 6, y_{m-2} = p_{n-1} + h_{S-1}^2 M_{m-2} / 6.
    Segment k is the cubic with these end states; its conditions are

        v_{k+1} - v_k = h_k (M_k + M_{k+1}) / 2,
        y_{k+1} - y_k = h_k (v_k + v_{k+1}) / 2 - h_k^2 (M_{k+1} - M_k) / 12,

    the second one only on interior segments (on the end segments it repeats the first).

    Exact limits: acceleration is linear on every cubic segment, so |M_k| <= A
    (variable bounds) is exact; velocity at the knots |v_k| <= V (bounds), its
    interior extremes certified by the NLP; jerk (M_{k+1} - M_k) / h_k is
    constant, so |M_{k+1} - M_k| <= Jk h_k is exact; the virtual knots stay in
    the position range, interior position extremes are certified (at a via-point
    on a range bound the knot velocity is fixed at 0, ``resting_sides``). The hybrid's
    7th-order end segments are y_0 + M_1 h_0^2 P(s) (``HYBRID_END``): their
    speed, acceleration and position are monotone up to the knot values, and
    their jerk peaks at 1.3869 |M_1| / h_0, bounded exactly like a cubic's.
    """

    def build(self, h) -> SymbolicSpline:
        """The cubic or hybrid spline for symbolic durations ``h`` (class docstring)."""
        import casadi as ca

        via, scales = self.relative_via_points, self.scales
        n, joints = via.shape
        segments = n + 1
        hybrid = self.family.name == "hybrid"
        states = ca.MX.sym("knot_states", 2 * n * joints)
        velocity = ca.reshape(states[:n * joints], n, joints) * _per_joint(ca, scales.derivatives[0], n)
        acceleration = ca.reshape(states[n * joints:], n, joints) * _per_joint(ca, scales.derivatives[1], n)
        rest = ca.MX.zeros(1, joints)
        v = ca.vertcat(rest, velocity, rest)
        m = ca.vertcat(rest, acceleration, rest)
        duration = ca.repmat(h, 1, joints)
        first = _columns(ca, via[:1]) + h[0] ** 2 * acceleration[0, :] / 6
        last = _columns(ca, via[-1:]) + h[segments - 1] ** 2 * acceleration[n - 1, :] / 6
        y = ca.vertcat(_columns(ca, via[:1]), first, _columns(ca, via[1:-1]), last, _columns(ca, via[-1:]))
        v0, v1, m0, m1 = v[:-1, :], v[1:, :], m[:-1, :], m[1:, :]
        speed_scale = _per_joint(ca, scales.derivatives[0], segments)
        velocity_step = (v1 - v0 - duration * (m0 + m1) / 2) / speed_scale
        inner = slice(1, segments - 1)
        position_step = (y[1:, :] - y[:-1, :] - duration * (v0 + v1) / 2
                         + duration ** 2 * (m1 - m0) / 12)[inner, :] / (speed_scale[inner, :] * scales.time)
        constraints = []
        jerk = self.limits.jerk
        factor = np.ones(segments)
        if hybrid:
            factor[[0, -1]] = HYBRID_END_JERK
        for j in np.flatnonzero(np.isfinite(jerk)).tolist():
            constraints.append((ca.DM(factor) * (m1[:, j] - m0[:, j]) / (jerk[j] * h), -1.0, 1.0))
        origin = self.via_points[0]
        lower, upper = self.limits.lower - origin, self.limits.upper - origin  # of the relative positions
        for j in np.flatnonzero((np.isfinite(lower) | np.isfinite(upper)) & ~self.still_joints).tolist():
            constraints.append((ca.vertcat(first[j], last[j]), lower[j], upper[j]))
        cubic = [y[:-1, :] + _per_joint(ca, origin, segments), v0 * duration, m0 * duration ** 2 / 2,
                 (m1 - m0) * duration ** 2 / 6]
        all_segments = np.arange(segments)
        if hybrid:
            ends = np.array([0, segments - 1])
            inside = all_segments[1:-1]
            blocks = [SegmentBlock(inside, [b[inside.tolist(), :] for b in cubic], (0, 1)),
                      SegmentBlock(ends, self._hybrid_ends(ca, h, acceleration, segments))]
        else:
            blocks = [SegmentBlock(all_segments, cubic, (0, 1))]
        bounds = np.concatenate((self._scaled_bounds(1, n), self._scaled_bounds(2, n)))
        resting = np.concatenate(((self.knot_resting_sides()[1:-1] != 0).T.ravel(), np.zeros(n * joints, bool)))
        bounds = np.where(resting, 0.0, bounds)
        return SymbolicSpline(states, -bounds, bounds, ca.vertcat(ca.vec(velocity_step), ca.vec(position_step)),
                              constraints, blocks)

    def knot_resting_sides(self) -> np.ndarray:
        """Knots p_0, virtual, p_1 .. p_{n-2}, virtual, p_{n-1}: the virtual knots never rest."""
        # Knots: p_0, virtual, p_1 .. p_{n-2}, virtual, p_{n-1}.
        sides = self.resting_sides()
        none = np.zeros((1, self.joint_count), dtype=int)
        return np.vstack((sides[:1], none, sides[1:-1], none, sides[-1:]))

    def _hybrid_ends(self, ca, h, acceleration, segments: int) -> list:
        """Normalised coefficients (2, J) of the hybrid's two 7th-order end segments."""
        via = self.via_points
        gain = ca.vertcat(h[0] ** 2 * acceleration[0, :], h[segments - 1] ** 2 * acceleration[-1, :])
        start = _columns(ca, np.vstack((via[0], via[-1])))
        coefficients = []
        for i in range(len(HYBRID_END)):
            shape = ca.repmat(ca.DM([HYBRID_END[i], HYBRID_END_REFLECTED[i]]), 1, self.joint_count)
            coefficients.append(shape * gain + start if i == 0 else shape * gain)
        return coefficients

    def state_values(self, coefficients: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """Scaled v and M at the n interior knots, joint-major."""
        # Knot k = 1 .. S-1 starts segment k, whose tau = 0 state the hybrid's end segment keeps too.
        interior = coefficients[1:]
        return np.concatenate(((interior[:, :, 1] / self.scales.derivatives[0]).T.ravel(),
                               (2 * interior[:, :, 2] / self.scales.derivatives[1]).T.ravel()))


class QuinticFormulation(SplineFormulation):
    """``quintic`` with knot velocities, accelerations, jerks and snaps.

    Knots are the via-points, segment k joins knots k and k+1 (S = n - 1).
    Velocity and acceleration vanish at both ends; jerk and snap are free there.
    Segment k is the quintic that starts in the knot state (p_k, v_k, a_k,
    j_k, s_k) and ends at p_{k+1}: b_0 .. b_4 = p_k, v_k h, a_k h^2 / 2, j_k h^3 / 6,
    s_k h^4 / 24 and b_5 = p_{k+1} - (b_0 + .. + b_4). Its conditions: velocity,
    acceleration, jerk and snap at its end equal knot k+1's state (C4), written in normalised
    time, P^(d)(1) - x_{k+1} h^d = 0 for d = 1..4, and divided by constants (the typical
    derivative times the reference duration ^ d). Divided by h^d instead, as x's own units
    would suggest, a short segment's rows grow like h^-d as the solver shrinks it: on
    clipped random walks IPOPT then stalled at its iteration cap (n = 256: 446.28 s from the
    start kept, where it now converges to 346.64 s).

    Exact limits: |v|, |a|, |j| at the knots are variable bounds; their interior
    extremes (and the position's) are certified by the NLP (``limits_by_cuts``). Where a via-point
    sits on a position bound, the first derivative that is free there must point back into the range
    (an interior knot's acceleration, its velocity being 0; an end's jerk, its velocity and
    acceleration being 0): variable bounds, necessary conditions, so exact; without them the
    position's cuts closed in on a dip beside the knot only slowly (the paper case with joint 1's
    range at its own extremes ended 2e-8 rad beyond it after 12 rounds; now 2 rounds).
    """

    limits_by_cuts = True

    def build(self, h) -> SymbolicSpline:
        """The quintic spline for symbolic durations ``h`` (class docstring)."""
        import casadi as ca

        via, scales = self.relative_via_points, self.scales
        n, joints = via.shape
        segments = n - 1
        inner, ends = max(n - 2, 0), n
        counts = (inner, inner, ends, ends)  # variables of v, a (interior knots) and j, s (every knot)
        states = ca.MX.sym("knot_states", sum(counts) * joints)
        knots, offset = [], 0
        rest = ca.MX.zeros(1, joints)
        for order, count in enumerate(counts, start=1):
            block = ca.reshape(states[offset:offset + count * joints], count, joints)
            block = block * _per_joint(ca, scales.derivatives[order - 1], count)
            knots.append(ca.vertcat(rest, block, rest) if order <= 2 else block)
            offset += count * joints
        duration = ca.repmat(h, 1, joints)
        powers = [duration ** i for i in range(5)]
        start = [_columns(ca, via[:-1])] + [knots[d - 1][:-1, :] * powers[d] / factorial(d) for d in range(1, 5)]
        coefficients = start + [_columns(ca, via[1:]) - sum(start)]
        equalities = []
        for d in range(1, 5):
            at_end = sum(coefficients[i] * (factorial(i) / factorial(i - d)) for i in range(d, 6))
            reference = ca.repmat(ca.DM(scales.segment_times ** d), 1, joints)
            mismatch = (at_end - knots[d - 1][1:, :] * powers[d]) / (
                reference * _per_joint(ca, scales.derivatives[d - 1], segments))
            equalities.append(ca.vec(mismatch))
        bounds = np.concatenate([self._scaled_bounds(order, count) for order, count in enumerate(counts, start=1)])
        lower, upper = -bounds, bounds.copy()
        resting = self.resting_sides()
        lower[:inner * joints] = np.where((resting[1:-1] != 0).T.ravel(), 0.0, lower[:inner * joints])
        upper[:inner * joints] = np.where((resting[1:-1] != 0).T.ravel(), 0.0, upper[:inner * joints])
        # Where the position sits on a bound, the first free derivative must point back into the range, or the
        # spline leaves it right beside the knot (where cuts close in on the extreme only slowly): an interior
        # knot's acceleration (its velocity is 0) and an end's jerk (velocity and acceleration are 0).
        acceleration = slice(inner * joints, 2 * inner * joints)
        away = resting[1:-1].T.ravel()  # +1 on an upper bound: the acceleration must be <= 0
        lower[acceleration] = np.where(away < 0, 0.0, lower[acceleration])
        upper[acceleration] = np.where(away > 0, 0.0, upper[acceleration])
        sides = self.limits.bound_sides(self.via_points)
        sides[:, self.still_joints] = 0  # it stays on the bound: its states are 0 (and 0 on a bound degenerates)
        jerk = 2 * inner * joints  # the jerks, knot-major within each joint's column of n
        for joint in range(joints):
            # q - bound ~ j t^3 / 6 after the start, j (t - T)^3 / 6 before the end
            for knot, inward in ((0, 1), (n - 1, -1)):
                index = jerk + joint * n + knot
                if sides[knot, joint] * inward < 0:  # on the lower bound at the start, or the upper at the end: j >= 0
                    lower[index] = 0.0
                elif sides[knot, joint] * inward > 0:
                    upper[index] = 0.0
        coefficients[0] = _columns(ca, self.via_points[:-1])  # b_0: each segment starts at its via-point
        return SymbolicSpline(states, lower, upper, ca.vertcat(*equalities),
                              blocks=[SegmentBlock(np.arange(segments), coefficients, (0, 1, 2, 3))])

    def knot_resting_sides(self) -> np.ndarray:
        """Every knot is a via-point."""
        return self.resting_sides()

    def state_values(self, coefficients: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """Scaled v, a (interior knots), then j, s (every knot), joint-major."""
        # Knot states: each segment's start, and the last segment's end for the final knot.
        end = np.stack([np.polynomial.polynomial.polyval(durations[-1], derivative_coefficients(
            coefficients[-1], d).T) for d in range(5)], axis=-1)  # (J, 5)
        states = np.concatenate((coefficients[:, :, :5] * [factorial(d) for d in range(5)], end[None]), axis=0)
        values = []
        for order in range(1, 5):
            knot = states[:, :, order] if order > 2 else states[1:-1, :, order]
            values.append((knot / self.scales.derivatives[order - 1]).T.ravel())
        return np.concatenate(values)


#: (8, 8) the map from a segment's end states, normalised as x = (q, q' h, q'' h^2, q''' h^3) at its start
#: then at its end, to the coefficients b_0 .. b_7 of its normalised 7th-order Hermite polynomial P(s).
HERMITE7_MAP = np.stack([hermite7(unit[:4], unit[4:], np.array(1.0)) for unit in np.eye(8)], axis=1)


class Hermite7Formulation(SplineFormulation):
    """``hermite7`` with free via-point states: velocity, acceleration and jerk at the n - 2 interior
    via-points are variables (zero at both ends); segment k is the Hermite polynomial between the
    states of via-points k and k + 1 (``HERMITE7_MAP``), so there is no continuity condition to
    impose (C3 by construction) and the NLP chooses the states with the durations.

    Exact limits: the knot values |v|, |a|, |j| <= limit are variable bounds (v fixed at 0 where a
    via-point is on its position bound); extremes inside segments (degrees 4 to 7) get cuts.
    """

    limits_by_cuts = True
    #: (8, 8) normalised end states to the segment's coefficients.
    segment_map = HERMITE7_MAP
    #: (g_1, g_2): on a segment of duration h, max |q''| <= g_1 max |q'| / h and max |jerk| <= g_2 max |q''| / h
    #: (``_implied_rows``): Markov's inequality, 2 D^2 for the velocity (degree 6) and acceleration (degree 5).
    derivative_gains = (72.0, 50.0)

    def build(self, h) -> SymbolicSpline:
        """The Hermite segments for symbolic durations ``h`` and the state variables."""
        import casadi as ca

        via, scales = self.relative_via_points, self.scales
        n, joints = via.shape
        inner = n - 2
        states = ca.MX.sym("knot_states", 3 * inner * joints)
        rest = ca.MX.zeros(1, joints)
        knots = []
        for order in range(1, 4):
            block = ca.reshape(states[(order - 1) * inner * joints:order * inner * joints], inner, joints)
            knots.append(ca.vertcat(rest, block * _per_joint(ca, scales.derivatives[order - 1], inner), rest))
        duration = ca.repmat(h, 1, joints)
        powers = [1, duration, duration ** 2, duration ** 3]
        ends = [_columns(ca, via[:-1])] + [knots[d - 1][:-1, :] * powers[d] for d in range(1, 4)]
        ends += [_columns(ca, via[1:])] + [knots[d - 1][1:, :] * powers[d] for d in range(1, 4)]
        mapping = self.segment_map
        coefficients = [sum(mapping[i, c] * ends[c] for c in range(8) if mapping[i, c] != 0) for i in range(8)]
        coefficients[0] = self._absolute(ca, coefficients[0])
        bounds = np.concatenate([self._scaled_bounds(order, inner) for order in range(1, 4)])
        bounds = np.minimum(bounds, self._from_rest(inner))
        bounds[:inner * joints] = np.where((self.resting_sides()[1:-1] != 0).T.ravel(), 0.0, bounds[:inner * joints])
        bounds = np.where(np.tile(np.repeat(self.still_joints, inner), 3), 0.0, bounds)  # (``still_joints``)
        return SymbolicSpline(states, -bounds, bounds, ca.MX(0, 1), self._implied_rows(ca, knots, h),
                              blocks=[SegmentBlock(np.arange(n - 1), coefficients, (0, 1, 2, 3), self.family.basis)])

    def _absolute(self, ca, constant):
        """The constant coefficient (n - 1, J) of segments built from positions relative to the first via-point:
        b_0 is the segment's start, its via-point, exactly."""
        return _columns(ca, self.via_points[:-1])

    def _from_rest(self, count: int) -> np.ndarray:
        """(3 count J,) bounds of the scaled v, a, j states that a trajectory from rest to rest within a
        total time T0 (``longest_total``) meets: |a| <= J T0 / 2 and |v| <= J T0^2 / 8 under a jerk limit J,
        |v| <= A T0 / 2 under an acceleration limit A (each half of the motion starts or ends at rest).
        The optimum is that short, so they cut nothing off (none where T0 is not known)."""
        total = self.longest_total
        velocity, acceleration, jerk = self.limits.magnitudes
        implied = np.vstack((np.minimum(acceleration * total / 2, jerk * total ** 2 / 8), jerk * total / 2,
                             np.full(self.joint_count, np.inf)))
        return np.concatenate([np.repeat(implied[d] / self.scales.derivatives[d], count) for d in range(3)])

    def _implied_rows(self, ca, knots: list, h) -> list:
        """Bounds the limits imply on a via-point's acceleration and jerk where neither is limited itself.

        By Markov's inequality a polynomial p of degree D on an interval of length h has
        max |p'| <= 2 D^2 max |p| / h. On either segment beside a via-point, the velocity (degree 6)
        bounded by V bounds the acceleration there, |a| <= 72 V / h, and the acceleration (degree 5),
        bounded by A or by 72 V / h, the jerk, |j| <= 50 A / h or 3600 V / h^2 (``derivative_gains``).
        Every feasible trajectory meets them, so they cut nothing off; without them a knot state that no
        limit bounds ran off (IPOPT's steps of norm 1e8) between the cuts of one round."""
        limits = self.limits
        first, second = self.derivative_gains
        rows: list = []
        if self.via_points.shape[0] < 3:  # one segment from rest to rest: no via-point state is free
            return rows
        before, after = h[:-1], h[1:]  # the segments on either side of each interior via-point
        for j in range(self.joint_count):
            velocity, acceleration, jerk = (float(limits.magnitudes[d, j]) for d in range(3))
            pairs = []
            if not np.isfinite(acceleration) and np.isfinite(velocity):
                pairs.append((knots[1][1:-1, j], first * velocity, 1))
            if not np.isfinite(jerk):
                if np.isfinite(acceleration):
                    pairs.append((knots[2][1:-1, j], second * acceleration, 1))
                elif np.isfinite(velocity):
                    pairs.append((knots[2][1:-1, j], first * second * velocity, 2))
            for state, bound, power in pairs:
                for side in (before, after):
                    rows.append((state * side ** power / bound, -1.0, 1.0))
        return rows

    def knot_resting_sides(self) -> np.ndarray:
        """Every knot is a via-point."""
        return self.resting_sides()

    def state_values(self, coefficients: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """Scaled v, a, j at the interior via-points (each segment's start, ``segment_ends``), joint-major."""
        return np.concatenate([(segment_ends(coefficients, durations, order, self.family.basis)[0][1:]
                                / self.scales.derivatives[order - 1]).T.ravel() for order in range(1, 4)])

    def via_point_states(self, values: np.ndarray) -> np.ndarray:
        """(n, J, 3) the states the variables hold, unscaled, zero at both ends."""
        n, joints = self.via_points.shape
        inner = values.reshape(3, joints, n - 2).transpose(2, 1, 0) * self.scales.derivatives[:3].T[None]
        return np.concatenate((np.zeros((1, joints, 3)), inner, np.zeros((1, joints, 3))))


#: (8, 8) normalised end states x (as ``HERMITE7_MAP``'s) to the coefficients a of a trigonometric segment.
TRIGONOMETRIC_MAP = np.stack([trigonometric.hermite_coefficients(unit[:4], unit[4:], 1.0) for unit in np.eye(8)],
                             axis=1)


class TrigonometricFormulation(Hermite7Formulation):
    """``trigonometric`` with free via-point states: ``Hermite7Formulation`` with Simon & Isik's segments
    (``TRIGONOMETRIC_MAP``, basis ``trigonometric``), every extreme inside a segment bounded by a certificate
    (Lukacs' forms through ``trigonometric.half_angle_map`` for the velocity, acceleration and jerk, cuts for
    the position and beside robot rows).

    The implied rows' gains are Videnskii's inequality for a trigonometric polynomial t of degree n = 4
    on an interval of length 2 omega = SPAN = 3 pi / 4 in theta: max |t'| <= 2 n^2 cot(omega / 2) max |t|
    = 47.89 max |t|, so max |q''| <= 47.89 SPAN max |q'| / h (d theta / d tau = SPAN / h), and alike for
    the jerk (the constant is reached: a linear program over the degree-4 trigonometric polynomials on a
    fine grid of [0, 3 pi / 4] gives 47.891)."""

    segment_map = TRIGONOMETRIC_MAP
    derivative_gains = (2 * trigonometric.ORDER ** 2 / np.tan(trigonometric.SPAN / 4) * trigonometric.SPAN,) * 2

    def _absolute(self, ca, constant):
        """a_0 plus the first via-point: the constant basis function carries the offset."""
        return constant + _per_joint(ca, self.via_points[0], self.via_points.shape[0] - 1)


FORMULATIONS = {"cubic": CubicFormulation, "hybrid": CubicFormulation, "quintic": QuinticFormulation,
                "hermite7": Hermite7Formulation, "trigonometric": TrigonometricFormulation}
