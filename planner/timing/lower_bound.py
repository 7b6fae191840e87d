"""A lower bound on the total time of any trajectory through the via-points, whatever its family.

Any motion that passes the via-points p_0 .. p_{n-1} in order, from rest to rest,
with |q'| <= V, |q''| <= A and |q'''| <= Jk per joint, passes them at times
0 = t_0 < t_1 < ... < t_{n-1} = T. For a pair i < k and one joint, its values
x_i .. x_k (equal neighbours merged) turn at every strict interior extreme e: the
joint then stops (q' = 0) somewhere between the neighbours of e, at a value at or
beyond e, and these stops come in order. So on [t_i, t_k] the joint covers the
pieces x_i -> e_1 -> ... -> e_r -> x_k, each at least as long as its chord, and

    t_k - t_i >= w(i, k) = first(|e_1 - x_i|) + sum_s turn(|e_{s+1} - e_s|) + last(|x_k - e_r|),

with each piece's shortest time under its end conditions (D [rad] its length):

* between two stops (q' = 0 at both ends, q'' free there):
  turn(D) = max(T_VA(D), T_AJ(D)), T_VA(D) = 2 sqrt(D / A) if D <= V^2 / A,
  else D / V + V / A (bang-bang acceleration, at most the velocity limit);
  T_AJ under the acceleration and jerk limits together: the fastest such motion
  starts at q'' = A, turns it to -A at q''' = -Jk and ends at -A, so in a time
  T >= 2 A / Jk it covers A t^2 + 2 A^2 t / Jk + 2 A^3 / (3 Jk^2), t = T / 2 - A / Jk,
  and below that (q'' never reaching A) q''' = -Jk throughout covers Jk T^3 / 12;
* from where the trajectory starts (q' = q'' = 0) to a stop, or from a stop to
  where it ends: max(T_VA(D), ((12 + 6 sqrt 2) D / Jk)^(1/3)): under the jerk limit
  alone q''' = +Jk until T (1 - 1 / sqrt 2), then -Jk, covers Jk T^3 / (12 + 6 sqrt 2);
* from a passing speed (q' free, at most V) to a stop, or back: half(D) =
  sqrt(2 D / A) if D <= V^2 / (2 A), else D / V + V / (2 A);
* from where the trajectory starts to a passing speed, or back to where it ends:
  max(half(D), (6 D / Jk)^(1/3)) (q' <= Jk t^2 / 2 from rest);
* between two passing speeds: D / V;
* both ends of one piece at rest: max(T_VA(D), (32 D / Jk)^(1/3)).

Each piece bound holds under fewer constraints than the motion has (each drops
some), so each is a true lower bound; the jerk-limited distances are maxima (linear
programs over piecewise-constant jerk approach them from below). Then T >= w(i, k) summed along any chain
0 = i_0 < i_1 < ... < i_m = n - 1 of via-points, for every joint's w on each link
separately (all joints share the times): the longest path through the pairs,
taken over every pair from the first via-point, every pair to the last, and
pairs at most ``WINDOW`` via-points apart (the longest chains of the others add
nothing here that these miss, and all pairs would cost n^2).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..limits import JointLimits
from ..validate import finite_array

#: Pairs of via-points at most this many apart are links of the chains (besides every pair from the
#: first and to the last via-point).
WINDOW = 32


def _turn_to_turn(distance: np.ndarray, limits: JointLimits) -> np.ndarray:
    """(J,) shortest time [s] over ``distance`` (J,) [rad] between two stops, accelerations free: turn(D)
    (module docstring)."""
    return np.maximum(_stop_to_stop_va(distance, limits), _stop_to_stop_aj(distance, limits))


def _stop_to_stop_aj(distance: np.ndarray, limits: JointLimits) -> np.ndarray:
    """T_AJ (module docstring): acceleration and jerk limits only."""
    a, jerk = limits.acceleration, limits.jerk
    with np.errstate(invalid="ignore", divide="ignore"):  # absent limits: inf / inf, 0 inf
        swing = np.nan_to_num(2.0 * a / jerk, nan=0.0)   # turning q'' from A to -A [s]
        jerk_only = np.cbrt(12.0 * distance / jerk)
        # A t^2 + (2 A^2 / Jk) t + 2 A^3 / (3 Jk^2) = D: its positive root t
        linear = 2.0 * a * a / jerk
        constant = 2.0 * a ** 3 / (3.0 * jerk * jerk) - distance
        plateau = (np.sqrt(linear * linear - 4.0 * a * constant) - linear) / (2.0 * a)
        return np.where(jerk_only <= swing, jerk_only, 2.0 * plateau + swing)


def _rest_to_stop(distance: np.ndarray, limits: JointLimits) -> np.ndarray:
    """From where the trajectory starts (q' = q'' = 0) to a stop, or back (module docstring)."""
    return np.maximum(_stop_to_stop_va(distance, limits),
                      np.cbrt((12.0 + 6.0 * np.sqrt(2.0)) * distance / limits.jerk))


def _rest_to_passing(distance: np.ndarray, limits: JointLimits) -> np.ndarray:
    """From where the trajectory starts to a passing speed, or back (module docstring)."""
    return np.maximum(_passing_to_stop(distance, limits), np.cbrt(6.0 * distance / limits.jerk))


def _stop_to_stop_va(distance: np.ndarray, limits: JointLimits) -> np.ndarray:
    """T_VA (module docstring): velocity and acceleration limits only."""
    v, a = limits.velocity, limits.acceleration
    with np.errstate(invalid="ignore"):  # inf / inf and 0 inf where limits are absent: 0 s either way
        return np.where(distance * a <= v * v, 2.0 * np.sqrt(distance / a),
                        np.nan_to_num(distance / v + v / a, nan=0.0))


def _passing_to_stop(distance: np.ndarray, limits: JointLimits) -> np.ndarray:
    """half(D) (module docstring): from a passing speed of at most V to a stop."""
    v, a = limits.velocity, limits.acceleration
    with np.errstate(invalid="ignore"):
        return np.where(2.0 * distance * a <= v * v, np.sqrt(2.0 * distance / a),
                        np.nan_to_num(distance / v + v / (2.0 * a), nan=0.0))


def _rest_to_rest(distance: np.ndarray, limits: JointLimits) -> np.ndarray:
    """Both ends at rest (q' = q'' = 0)."""
    return np.maximum(_stop_to_stop_va(distance, limits), np.cbrt(32.0 * distance / limits.jerk))


def _walk(values: np.ndarray, limits: JointLimits, start_at_rest: np.ndarray, end_index: np.ndarray) -> np.ndarray:
    """(B, K, J) w(0, k) (module docstring) of each joint, for each of B runs of K via-point values
    (B, K, J) [rad] (w(0, 0) = 0); ``start_at_rest`` (B,): the run's first value is where the
    trajectory starts; ``end_index`` (B,): the index in the run where it ends (-1: not in it)."""
    batch, count, joints = values.shape
    rest = np.asarray(start_at_rest, dtype=bool)[:, None]
    anchor = values[:, 0].copy()          # the last stop, or the first value
    stopped = np.zeros((batch, joints), dtype=bool)
    done = np.zeros((batch, joints))      # time of the pieces before the anchor [s]
    direction = np.zeros((batch, joints))
    previous = values[:, 0].copy()
    bounds = np.zeros((batch, count, joints))
    for k in range(1, count):
        step = values[:, k] - previous
        moving = step != 0
        reverses = moving & (direction != 0) & (np.sign(step) != direction)
        if reverses.any():  # previous was a strict extreme: a stop there
            piece = np.abs(previous - anchor)
            to_stop = np.where(stopped, _turn_to_turn(piece, limits),
                               np.where(rest, _rest_to_stop(piece, limits), _passing_to_stop(piece, limits)))
            done = np.where(reverses, done + to_stop, done)
            stopped |= reverses
            anchor = np.where(reverses, previous, anchor)
        direction = np.where(moving, np.sign(step), direction)
        previous = np.where(moving, values[:, k], previous)
        piece = np.abs(values[:, k] - anchor)
        at_rest = (np.asarray(end_index) == k)[:, None]
        last = np.where(stopped, np.where(at_rest, _rest_to_stop(piece, limits), _passing_to_stop(piece, limits)),
                        np.where(rest & at_rest, _rest_to_rest(piece, limits),
                                 np.where(rest | at_rest, _rest_to_passing(piece, limits), piece / limits.velocity)))
        bounds[:, k] = done + last
    return bounds


def _distinct(via_points: np.ndarray, limits: JointLimits) -> tuple[np.ndarray, np.ndarray]:
    """The via-points (n', J) with equal neighbours merged, and (n,) which of the given ones are kept.

    Raises:
        InputError: via-points not finite (n, J), or limits not a JointLimits for J joints.
    """
    values = finite_array("via_points", via_points, 2)
    if not isinstance(limits, JointLimits) or values.shape[1] != limits.joint_count:
        raise InputError(f"limits must be a JointLimits for the via-points' {values.shape[1]} joints, got "
                         f"{limits!r:.80}")
    keep = np.concatenate(([True], np.any(np.diff(values, axis=0) != 0, axis=1)))
    return values[keep], keep


def _links(values: np.ndarray, limits: JointLimits) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """w of each joint (module docstring) for distinct neighbours ``values`` (n, J), n >= 2:
    from_first (n, J) w(0, k) at k, to_last (n, J) w(i, n - 1) at i, and links (n, span, J)
    w(i, i + d) at [i, d] where i + d <= n - 1, span = min(WINDOW, n - 1) + 1."""
    count, last = len(values), len(values) - 1
    whole = _walk(np.stack((values, values[::-1])), limits, np.array([True, True]), np.array([last, last]))
    span = min(WINDOW, last) + 1
    starts = np.arange(count)
    windows = values[np.minimum(starts[:, None] + np.arange(span), last)]  # (n, span, J), the end repeated
    return whole[0], whole[1][::-1], _walk(windows, limits, starts == 0, last - starts)


def pair_lower_bounds(via_points: np.ndarray, limits: JointLimits) -> tuple[np.ndarray, np.ndarray]:
    """Lower bounds on the time between pairs of via-points, for any trajectory that passes
    ``via_points`` (n, J) [rad] in order from rest to rest within ``limits``' velocity, acceleration
    and jerk: the module docstring's w(i, k) of each joint, for every pair from the first via-point,
    every pair to the last and every pair at most ``WINDOW`` apart.

    Returns:
        pairs: (P, 2) indices (i, k), i < k, into ``via_points``: of a run of equal neighbours, the
            last for i and the first for k (the bound holds from any pass of x_i to any later pass
            of x_k, so for the closest two);
        bounds: (P, J) w(i, k) of each joint [s]: t_k - t_i >= bounds[p, j] for every joint j.

    Raises:
        InputError: via-points not finite (n, J), or limits not a JointLimits for J joints.
    """
    values, keep = _distinct(via_points, limits)
    if len(values) < 2:
        return np.zeros((0, 2), dtype=int), np.zeros((0, values.shape[1]))
    firsts = np.flatnonzero(keep)  # each run's first index among the given via-points
    lasts = np.append(firsts[1:] - 1, len(keep) - 1)
    from_first, to_last, links = _links(values, limits)
    last = len(values) - 1
    i, d = np.nonzero((np.arange(links.shape[1]) >= 1) & (np.arange(len(values))[:, None] + np.arange(links.shape[1])
                                                          <= last))
    others = np.arange(1, last + 1)
    pairs = np.concatenate((np.stack((np.zeros_like(others), others), axis=1),
                            np.stack((others - 1, np.full_like(others, last)), axis=1),
                            np.stack((i, i + d), axis=1)))
    bounds = np.concatenate((from_first[1:], to_last[:-1], links[i, d]))
    return np.stack((lasts[pairs[:, 0]], firsts[pairs[:, 1]]), axis=1), bounds


def time_lower_bound(via_points: np.ndarray, limits: JointLimits) -> float:
    """A lower bound [s] on the total time of any trajectory, of any family or none, that passes
    ``via_points`` (n, J) [rad] in order from rest to rest within ``limits``' velocity,
    acceleration and jerk (module docstring); ranges and duration bounds are not used."""
    values, _ = _distinct(via_points, limits)
    count = len(values)
    if count < 2:
        return 0.0
    last = count - 1
    from_first, to_last, links = (w.max(axis=-1, initial=0.0) for w in _links(values, limits))
    span = links.shape[1]
    longest = from_first.copy()  # the chains of one link from the first via-point; w(0, 0) = 0
    for i in range(last):
        reach = min(span, count - i)
        longest[i + 1:i + reach] = np.maximum(longest[i + 1:i + reach], longest[i] + links[i, 1:reach])
        longest[last] = max(longest[last], longest[i] + to_last[i])
    return float(longest[last])
