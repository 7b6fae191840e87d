"""The time-optimal timing problem (README, "The maths"), evaluated in batches.

Given joint via-points, a spline family and limits, find segment durations h
minimising ``time`` (f = sum h) or ``time-jerk`` (f = K_t sum h + K_j sum_j
integral q_j'''^2 dt) subject to every constraint ratio <= 1, the position
range, optional bounds h_min <= h_k <= h_max, and a minimum segment duration
h_k >= h_floor (default 0; the planner passes ``trajectory.min_segment_s``).

Minimum segment duration. Without it the optimum of a tiny motion can put
nanosecond segments (the 7th-order ends of ``hybrid`` reach their jerk
limit within them), far below any controller period. Every optimizer sees
the floor: it is a variable bound of the NLP and of SLSQP, and the repair
below enforces it for the population methods: repaired durations below it
are raised to it and the whole vector is then scaled up until every limit
holds again (scaling up never breaks a limit, by the lemma, and never
breaks the floor).

The time-scaling lemma turns this into an unconstrained search over
*shapes*: any candidate x is repaired in closed form to the feasible, tight
h = s x. For ``time`` the scale is s* (the smallest feasible); for
``time-jerk`` it is max(s*, s_opt), where s_opt = (5 K_j E / (K_t T))^(1/6)
minimises K_t s T + K_j s^-5 E along the ray. With bounds the repaired
durations are clipped to [max(h_min, h_floor), h_max] (h_floor: ``min_duration``)
and the scaling repeated a few times;
what is still infeasible then is penalised.

Repeated via-points. Consecutive via-points equal in every joint (within
``REPEAT_TOLERANCE``) are one stop of the path, passed once: the problem
keeps one of them, so their segment has zero duration and the robot does not
stop there unless the spline makes it. (Keeping a zero-motion segment of
positive duration would force a stop or a loop; its optimal duration tends to
zero anyway.) Via-points equal in only some joints are ordinary: those joints
get a segment with zero net motion, shaped by the spline like any other. A
task whose via-points are all equal has no motion to time and is an error.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import InfeasibleError, InputError
from ..kinematics import Violation, batch_scale_factors, jerk_energy, position_range
from ..limits import (
    LARGEST_POSITION_DEG,
    LIMITED,
    JointLimits,
    bounds_exceeded,
    in_degrees,
    in_degrees_apart,
    range_exceeded,
    ratio_exceeded,
    time_scale_factor,
)
from ..read_only import ReadOnlyArrays, freeze_arrays
from ..splines import FAMILIES, PiecewisePolynomial, SplineFamily, get_family, powers
from ..validate import DURATION_BOUND_RANGE, finite_array, positive_durations
from .lower_bound import pair_lower_bounds

OBJECTIVES = ("time", "time-jerk")
#: Consecutive via-points within this of each other in every joint [rad] are one via-point.
REPEAT_TOLERANCE = 1e-9
_REPAIR_ROUNDS = 6
_PENALTY = 1e3
#: Unbounded problems search shapes in [SHAPE_FLOOR, 1]^S (duration ratios up to 1 / SHAPE_FLOOR).
SHAPE_FLOOR = 0.05


@dataclass(frozen=True)
class Evaluation(ReadOnlyArrays):
    """Batched evaluation of repaired candidates (its arrays read-only copies).

    Attributes:
        durations: (B, S) repaired durations [s].
        objective: (B,) objective value, penalised where infeasible.
        ratios: (B, 3, J) constraint ratios of the repaired durations.
        position_excess: (B,) largest position-range violation [rad] (0 when inside).
        feasible: (B,) all ratios <= 1 (+1e-9), position range held, bounds held.
        states: (B, n, J, 3) the via-point states (velocity, acceleration, jerk) of a family with free
            states, when they were given (``evaluate_states``); None: the family's rule.
    """

    durations: np.ndarray
    objective: np.ndarray
    ratios: np.ndarray
    position_excess: np.ndarray
    feasible: np.ndarray
    states: np.ndarray | None = None

    def __post_init__(self):
        freeze_arrays(self)


class TimingProblem:
    """Via-points, a spline family, limits, optional bounds and an objective.

    Attributes:
        given_via_points: (n, J) the via-points as given [rad].
        via_points: (n', J) the distinct via-points the timing is computed for: repeats merged, and a
            value within ``FEASIBILITY_TOLERANCE`` outside its joint's range (accepted as on the bound: -160
            deg in a task against a URDF bound of -2.792526803 rad) moved onto that bound, so that the
            trajectory, checked against the limits as given, meets them there (left 1e-9 rad outside, the
            spline's rounding at the via-point took it past the tolerance).
        via_index: (n,) the row of ``via_points`` each given via-point is.

    Args:
        via_points: (n, J) joint via-points [rad], n >= 2, not all equal.
        family: a ``SplineFamily`` or its name.
        limits: ``JointLimits`` (SI); at least one magnitude limit, or duration ``bounds``, is needed.
        bounds: optional (h_min, h_max) [s] for every segment duration.
        min_duration: the shortest segment duration allowed [s] (>= 0), with or without bounds.
        objective: ``"time"`` or ``"time-jerk"``.
        weights: (K_t, K_j) of the ``time-jerk`` objective [1/s, s^5/rad^2].

    Raises:
        InputError: malformed via-points (or all equal), bounds, objective or weights.
        InfeasibleError: a via-point outside its joint's range, or bounds with which no timing
            meets the limits, where that is proven (``_check_upper_bound_feasible``).
    """

    def __init__(self, via_points, family: SplineFamily | str, limits: JointLimits, *,
                 bounds: tuple[float, float] | None = None, objective: str = "time",
                 weights: tuple[float, float] = (1.0, 1.0), min_duration: float = 0.0):
        self.family = get_family(family) if isinstance(family, str) else family
        if not isinstance(self.family, SplineFamily):
            raise InputError(f"family must be a family's name ({', '.join(FAMILIES)}) or a SplineFamily, "
                             f"got {type(family).__name__}")
        if not isinstance(limits, JointLimits):
            raise InputError(f"limits must be a JointLimits (JointLimits.create), got {type(limits).__name__}")
        given = finite_array("via_points", via_points, 2)
        largest = np.deg2rad(LARGEST_POSITION_DEG)
        beyond = np.argwhere(~(np.abs(given) <= largest))
        if beyond.size:
            k, j = (int(i) for i in beyond[0])
            raise InputError(f"via-point {k}, joint {j}: {given[k, j]:g} rad is beyond the largest position the "
                             f"planner takes, +-{largest:.6g} rad ({LARGEST_POSITION_DEG:g} deg)")
        given, _ = self.family.check(given, np.ones(self.family.segment_count(len(given))))
        self.given_via_points = given
        self.via_points, self.via_index = _merge_repeats(given)
        if limits.joint_count != self.joint_count:
            raise InputError(f"limits are for {limits.joint_count} joints, via-points have {self.joint_count}")
        if objective not in OBJECTIVES:
            raise InputError(f"unknown objective {objective!r}; known: {', '.join(OBJECTIVES)}")
        self.objective_name = objective
        weights_array = finite_array("weights", weights, 1)
        if weights_array.shape != (2,) or np.any(weights_array < 0) or weights_array[0] <= 0:
            raise InputError(f"weights (K_t, K_j) must be two numbers with K_t > 0, K_j >= 0, got {weights}")
        self.weights = (float(weights_array[0]), float(weights_array[1]))
        self.bounds = None if bounds is None else self._check_bounds(bounds)
        floor = finite_array("min_duration", [min_duration], 1)[0]
        if not 0 <= floor <= DURATION_BOUND_RANGE.high:
            raise InputError(f"min_duration must be >= 0 s and <= {DURATION_BOUND_RANGE.high:g} s, got {floor:g}")
        if self.bounds is not None and floor > self.bounds[1]:
            raise InputError(f"the minimum segment duration {floor:g} s exceeds the upper duration bound "
                             f"{self.bounds[1]:g} s")
        #: Smallest duration of any segment [s]: the larger of h_min and the minimum segment duration.
        self.duration_floor = max(float(floor), self.bounds[0] if self.bounds is not None else 0.0)
        if not np.isfinite(limits.magnitudes).any() and self.bounds is None:
            raise InputError("no velocity, acceleration or jerk limit and no duration bounds: "
                             "the minimum time is unbounded below")
        moving = np.ptp(self.via_points, axis=0) > REPEAT_TOLERANCE
        if self.bounds is None and not np.any(np.isfinite(limits.magnitudes).any(axis=0) & moving):
            free = ", ".join(limits.names[j] for j in np.flatnonzero(moving))
            raise InputError(f"no joint with a velocity, acceleration or jerk limit moves (by more than "
                             f"{REPEAT_TOLERANCE:g} rad) and there are no duration bounds: the minimum time is "
                             f"unbounded below (moving without a limit: {free})")
        self._check_via_points_in_range(limits)
        self.via_points = np.clip(self.via_points, limits.lower, limits.upper)
        self.limits = limits
        if self.bounds is not None:
            self._check_upper_bound_feasible()

    # ------------------------------------------------------------------ set-up checks

    @property
    def joint_count(self) -> int:
        """J, the number of joints."""
        return self.via_points.shape[1]

    @property
    def segment_count(self) -> int:
        """S, the number of segments of the family for the merged via-points."""
        return self.family.segment_count(len(self.via_points))

    def _check_bounds(self, bounds) -> tuple[float, float]:
        array = finite_array("bounds", bounds, 1)
        if array.shape != (2,) or not 0 < array[0] <= array[1]:
            raise InputError(f"bounds must be [h_min, h_max] with 0 < h_min <= h_max, got {list(bounds)}")
        if not (array[0] in DURATION_BOUND_RANGE and array[1] in DURATION_BOUND_RANGE):
            raise InputError(f"bounds [h_min, h_max] must each be {DURATION_BOUND_RANGE} s (no robot moves faster "
                             f"or slower; floating point would not hold the splines), got {list(bounds)}")
        return float(array[0]), float(array[1])

    def _check_via_points_in_range(self, limits: JointLimits) -> None:
        violation = limits.range_violation(self.given_via_points)
        if violation is not None:
            (k, j), side, bound = violation
            outside = Violation(limits.names[j], j, "position", 0, float(self.given_via_points[k, j]), bound, side)
            value, limit = in_degrees_apart(outside.value, bound, 0)
            raise InfeasibleError(f"via-point {k} puts joint {outside.joint} at {value}, outside its {side} limit "
                                  f"{limit}", violation=outside)

    def _check_upper_bound_feasible(self) -> None:
        """Refuse bounds no timing within can meet the limits with, where that is proven.

        That is where:

        * every duration is h_max (h_floor = h_max) and the family's fixed rule then breaks a limit;
        * some joint needs longer between two via-points than the segments between them last at
          h_max, whatever the family (``pair_lower_bounds``: a lower bound for any trajectory).

        Otherwise the optimizers search: durations all at h_max are not the least demanding
        timing of every spline (shortening a segment can lower a neighbour's jerk).
        """
        assert self.bounds is not None
        h_max = self.bounds[1]
        if self.duration_floor >= h_max and not self.family.free_states:
            _, ratios, _ = self._figures(np.full((1, self.segment_count), h_max))
            ratios = ratios[0]
            if ratio_exceeded(ratios).any():
                d, j = (int(i) for i in np.unravel_index(np.argmax(ratios), ratios.shape))
                limit = float(self.limits.magnitudes[d, j])
                limited = LIMITED[d]
                excess = Violation(self.limits.names[j], j, limited.name, limited.order, float(ratios[d, j]) * limit,
                                   limit)
                raise InfeasibleError(
                    f"infeasible with every duration at h_max = {h_max:g} s: joint {excess.joint} "
                    f"{excess.quantity} reaches {in_degrees(excess.value, excess.order)}, limit "
                    f"{in_degrees(limit, excess.order)} "
                    f"({ratios[d, j]:.10g} times it)",
                    violation=excess)
        pairs, needed = pair_lower_bounds(self.via_points, self.limits)
        knots = self.family.via_knots(len(self.via_points))
        allowed = (knots[pairs[:, 1]] - knots[pairs[:, 0]]) * h_max  # (P,) the longest time between them [s]
        excess = needed / allowed[:, None]
        if excess.size and ratio_exceeded(excess.max()):
            p, j = (int(i) for i in np.unravel_index(np.argmax(excess), excess.shape))
            first, last = (int(np.flatnonzero(self.via_index == k)[side]) for k, side in zip(pairs[p], (-1, 0)))
            segments = int(knots[pairs[p, 1]] - knots[pairs[p, 0]])
            raise InfeasibleError(
                f"infeasible with durations of at most h_max = {h_max:g} s: joint {self.limits.names[j]} takes at "
                f"least {needed[p, j]:.6g} s from via-point {first} to via-point {last} within its velocity, "
                f"acceleration and jerk limits, and the {segments} segment{'s' if segments > 1 else ''} between "
                f"them {'last' if segments > 1 else 'lasts'} at most {allowed[p]:.6g} s",
                joint=self.limits.names[j], joint_index=j, quantity="duration", value=float(needed[p, j]),
                limit=float(allowed[p]))

    # ------------------------------------------------------------------ search space

    def search_box(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) corners of the box the optimizers search, each (S,).

        With bounds: [duration_floor, h_max] [s]. Without: shapes in [SHAPE_FLOOR, 1], which
        the repair scales to durations.
        """
        lower, upper = (self.duration_floor, self.bounds[1]) if self.bounds is not None else (SHAPE_FLOOR, 1.0)
        return np.full(self.segment_count, lower), np.full(self.segment_count, upper)

    def to_search_space(self, durations: np.ndarray) -> np.ndarray:
        """Map repaired durations back into the search box (scale to max 1 when unbounded)."""
        durations = self._batch("durations", durations)
        if self.bounds is not None:
            return durations
        return np.clip(durations / durations.max(axis=-1, keepdims=True), SHAPE_FLOOR, 1.0)

    # ------------------------------------------------------------------ evaluation

    def _batch(self, name: str, durations) -> np.ndarray:
        """``durations`` as a (B, S) array of durations [s] > 0 for this problem's S segments.

        Raises:
            InputError: naming ``name``: not numbers, the wrong count, not finite and > 0, or no
                duration vector at all (B = 0).
        """
        batch = np.atleast_2d(positive_durations(name, durations, self.segment_count))
        if not len(batch):
            raise InputError(f"{name} must hold at least one vector of {self.segment_count} segment durations, "
                             f"got none")
        return batch

    def _states(self, states, batch: int) -> np.ndarray | None:
        """Via-point states as a (B, n, J, 3) array of finite numbers, or None.

        Raises:
            InputError: states not of that shape, not finite, or given for a family that fixes them.
        """
        if states is None:
            return None
        if not self.family.free_states:
            raise InputError(f"the {self.family.name} family fixes its via-point states from the durations")
        array = finite_array("states", states, np.ndim(states))
        shape = (batch, *self.via_points.shape, 3)
        if array.shape != shape:
            raise InputError(f"states must have shape {shape} (velocity, acceleration and jerk of every distinct "
                             f"via-point, per duration vector), got {array.shape}")
        return array

    def coefficients(self, durations: np.ndarray, states: np.ndarray | None = None) -> np.ndarray:
        """(B, S, J, D+1) the family's coefficients for durations (B, S) [s], and via-point states
        (B, n, J, 3) where the family's are free (None: its fixed rule).

        Raises:
            InputError: durations or states of the wrong shape or values (``_batch``, ``_states``).
        """
        durations = self._batch("durations", durations)
        return self._coefficients(durations, self._states(states, len(durations)))

    def _coefficients(self, durations: np.ndarray, states: np.ndarray | None) -> np.ndarray:
        """``coefficients`` of checked arrays."""
        if states is None:
            return self.family.batch_coefficients(self.via_points, durations)
        return self.family.coefficients_from_states(self.via_points, durations, states)

    def _figures(self, durations: np.ndarray, states: np.ndarray | None = None):
        """Coefficients, constraint ratios (B, 3, J) and time-scale factors (B,) of durations (B, S)."""
        coefficients = self._coefficients(durations, states)
        return (coefficients, *batch_scale_factors(coefficients, durations, self.limits, self.family.basis))

    def _position_excess(self, coefficients: np.ndarray, durations: np.ndarray) -> np.ndarray:
        if not self.limits.has_position_range:
            return np.zeros(len(durations))
        low, high = position_range(coefficients, durations, self.family.basis)
        return self.limits.range_excess(low, high).max(axis=1)

    @property
    def uses_jerk_energy(self) -> bool:
        """The objective has a jerk-energy term (``time-jerk`` with K_j > 0)."""
        return self.objective_name == "time-jerk" and self.weights[1] > 0

    def _energy(self, coefficients: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """(B,) total jerk energy when the objective uses it, else zeros."""
        if not self.uses_jerk_energy:
            return np.zeros(len(durations))
        return jerk_energy(coefficients, durations, self.family.basis).sum(axis=1)

    def evaluate(self, candidates) -> Evaluation:
        """Repair a batch of candidates (B, S) from the search box and evaluate them.

        Without bounds, one spline build per candidate: by the lemma the
        scaled trajectory's ratios are r_d / s^d, its jerk energy E / s^5 and
        its positions unchanged.
        """
        x = self._batch("candidates", candidates)
        coefficients, ratios, scale = self._figures(x)
        energy = self._energy(coefficients, x)
        scale = self._repair_scale(scale, energy, x)
        h = x * scale[:, None]
        if self.bounds is None:
            if np.all(h >= self.duration_floor):
                power = powers(scale, 6)
                return self._score(h, ratios / power[:, 1:4, None], self._position_excess(coefficients, x),
                                   energy / power[:, 5])
            return self._raise_to_floor(h)
        for _ in range(_REPAIR_ROUNDS):
            h = np.clip(h, self.duration_floor, self.bounds[1])
            coefficients, ratios, scale = self._figures(h)
            if not ratio_exceeded(ratios).any():
                break
            h = h * np.maximum(scale, 1.0)[:, None]
        return self._score(h, ratios, self._position_excess(coefficients, h), self._energy(coefficients, h))

    def _repair_scale(self, scale: np.ndarray, energy: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The repair's factor (B,): the time-scale factor, for ``time-jerk`` no less than the ray's
        optimum s_opt = (5 K_j E / (K_t T))^(1/6); 1 where nothing is limited. With duration bounds, s_opt
        is taken no further than puts the longest segment on h_max: the objective along the ray,
        K_t T s + K_j E / s^5, is convex in s, so within the bounds its best is there (the limits
        permitting); beyond, the repair took a segment past h_max (hermite7's NLP solution to 2.3 times
        it, and the task was refused as if its limits took that long)."""
        if self.uses_jerk_energy:
            k_t, k_j = self.weights
            optimum = np.cbrt(np.sqrt(5.0 * k_j * energy / (k_t * h.sum(axis=1))))
            if self.bounds is not None:
                optimum = np.minimum(optimum, self.bounds[1] / h.max(axis=1))
            scale = np.maximum(scale, optimum)
        return np.where(scale > 0, scale, 1.0)

    def _raise_to_floor(self, h: np.ndarray) -> Evaluation:
        """Durations (B, S) raised to ``duration_floor``, then scaled up until every limit holds."""
        h = np.maximum(h, self.duration_floor)
        _, _, scale = self._figures(h)
        h = h * np.maximum(scale, 1.0)[:, None]
        coefficients, ratios, _ = self._figures(h)
        return self._score(h, ratios, self._position_excess(coefficients, h), self._energy(coefficients, h))

    def _score(self, h, ratios, position_excess, energy) -> Evaluation:
        worst = time_scale_factor(ratios)
        total = h.sum(axis=1)
        value = total if self.objective_name == "time" else self.weights[0] * total + self.weights[1] * energy
        feasible = ~ratio_exceeded(ratios).any(axis=(-2, -1)) & ~range_exceeded(position_excess)
        feasible &= ~bounds_exceeded(h, (self.duration_floor, np.inf if self.bounds is None else self.bounds[1]))
        penalty = _PENALTY * (np.maximum(worst - 1.0, 0.0) + position_excess)
        return Evaluation(h, np.where(feasible, value, value + penalty * (1.0 + total)), ratios,
                          position_excess, feasible)

    def evaluate_durations(self, durations, states: np.ndarray | None = None) -> Evaluation:
        """Evaluate durations (B, S) [s] (and free via-point states (B, n, J, 3)) exactly as given,
        without repair."""
        h = self._batch("durations", durations)
        return self._evaluate_durations(h, self._states(states, len(h)))

    def _evaluate_durations(self, h: np.ndarray, states: np.ndarray | None) -> Evaluation:
        """``evaluate_durations`` of checked arrays. A candidate with free via-point states whose spline
        rounding parts from its via-points (``SplineFamily.rounding_break``: states so large against the
        durations that the coefficients' terms cancel, as an NLP iterate stopped by the time limit can hold)
        is infeasible: its trajectory could not be built."""
        coefficients, ratios, _ = self._figures(h, states)
        evaluation = self._score(h, ratios, self._position_excess(coefficients, h), self._energy(coefficients, h))
        if states is not None:
            knots = self.family.via_knots(len(self.via_points))
            built = np.array([np.isfinite(c).all() and self.family.rounding_break(self.via_points, d, c, knots) is None
                              for d, c in zip(h, coefficients)])
            evaluation = replace(evaluation, feasible=evaluation.feasible & built)
        return replace(evaluation, states=states)

    def evaluate_states(self, durations: np.ndarray, states: np.ndarray) -> Evaluation:
        """Repair durations (B, S) [s] with the free via-point states (B, n, J, 3) of a family that
        has them, by the lemma: durations times s, velocity, acceleration and jerk divided by s, s^2,
        s^3 (``time_scale_factor``; for ``time-jerk`` no less than the ray's optimum), so every limit
        holds and one is reached, but no less than takes the shortest duration to ``duration_floor``
        (a solve whose durations sit on h_min with no limit reached is shrunk no further; shrunk, it
        was refused as below h_min). h_max is not enforced by the repair (the NLP imposes it): a
        result above it is infeasible (its objective not penalised: a search's tracker keeps feasible
        results first)."""
        h = self._batch("durations", durations)
        checked = self._states(states, len(h))
        if checked is None:
            raise InputError("evaluate_states needs the via-point states (B, n, J, 3); evaluate repairs "
                             "durations alone")
        coefficients, _, scale = self._figures(h, checked)
        scale = np.maximum(self._repair_scale(scale, self._energy(coefficients, h), h),
                           self.duration_floor / h.min(axis=1))
        return self._evaluate_durations(h * scale[:, None], checked / powers(scale, 4)[:, None, None, 1:])

    def trajectory(self, durations, states: np.ndarray | None = None) -> PiecewisePolynomial:
        """The family's trajectory for one duration vector (S,) [s] (and, where the family's are free,
        via-point states (n, J, 3); None: its fixed rule); its ``via_knots`` has one entry per given
        via-point (repeated ones share a knot)."""
        built = self.family.build(self.via_points, durations, states)
        return replace(built, via_knots=built.via_knots[self.via_index])


def _merge_repeats(via_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct consecutive via-points (n', J) and the index (n,) of each given one among them: a
    via-point within ``REPEAT_TOLERANCE`` of the last one kept, in every joint, is merged into it (so
    every given via-point is within the tolerance of the one planned through, however long a chain
    of small steps).

    Raises:
        InputError: every via-point is the same (nothing to time).
    """
    kept = [0]
    index = np.zeros(len(via_points), dtype=int)
    for i in range(1, len(via_points)):
        if np.abs(via_points[i] - via_points[kept[-1]]).max() > REPEAT_TOLERANCE:
            kept.append(i)
        index[i] = len(kept) - 1
    if len(kept) < 2:
        raise InputError(f"all {len(via_points)} via-points are the same joint position "
                         f"(within {REPEAT_TOLERANCE:g} rad): there is no motion to time")
    return via_points[kept], index
