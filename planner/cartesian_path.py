"""Straight tool motion between Cartesian waypoints, and how far a trajectory's tool strays from it.

The straight segment from pose A to pose B is the curve

    p(u) = (1 - u) p_A + u p_B,     R(u) = R_A exp(u log(R_A^T R_B)),     u in [0, 1]

(position on the line, orientation by slerp). A tool pose (p, R) deviates
from it by two numbers, each exact (``segment_deviation``):

* position: the distance from p to the line segment (closest point, u clamped
  to [0, 1]);
* orientation: the angle from R to the nearest rotation on the slerp arc. With
  Q = R_A^T R as a unit quaternion (w, v) and the arc's axis n and angle phi,
  rotating back by theta about n leaves a rotation whose quaternion has scalar
  part cos(theta/2) w + sin(theta/2) (n . v); its angle is smallest where |.| is
  largest: at theta/2 = atan2(n . v, w) (mod pi), clamped to [0, phi/2], or at an
  end. The angle is computed as 2 atan2(|vector part|, |scalar part|), accurate near 0.

``follow_straight_lines`` makes a joint trajectory follow the segments: it
inserts poses along each segment (IK seeded from the neighbouring
configurations, so the branch is kept), times the via-points, samples the
tool by forward kinematics at ``CHECK_RATE_HZ`` (and at least
``CHECK_SAMPLES`` per via-point interval; a trajectory so long that this
would exceed ``MAX_CHECK_SAMPLES`` is sampled more sparsely, down to that
count), inserts the midpoint of every
interval whose tool strays beyond ``MARGIN`` of a tolerance, and repeats until
none does. The margin covers what lies between samples. Where the timing holds
such an interval's segments at their least duration (``trajectory.min_segment_s``
or h_min), bisecting would crowd slow segments there, which the spline overshoots:
every segment's poses are then spaced evenly instead, as closely (in joint motion)
as half the held segment's spacing (``_even_counts``). Where a round's
via-points cannot be timed, the intervals of largest joint change are bisected by
IK alone (``_name_jump``): a motion that jumps (a singularity on the line) is
then named as the segment's error rather than the timing's.

``track_straight_lines`` finds, by IK continuation along the lines, the
configurations in which the joints arrive at each waypoint from a given first
one: a branch rule may pick, at a waypoint, a solution that the line from the
previous one does not reach, which no insertion of poses can then follow.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, TypeVar

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from .errors import IKError, InfeasibleError, TaskError
from .ik import nearest_turn, solve_pose, turn_variants
from .read_only import ReadOnlyArrays, freeze_arrays
from .robot import Robot
from .splines import PiecewisePolynomial
from .task import MAX_VIA_POINTS

#: Forward-kinematics samples per second of trajectory when checking the deviation.
CHECK_RATE_HZ = 250.0
#: At least this many samples per via-point interval.
CHECK_SAMPLES = 8
#: At most about this many samples at ``CHECK_RATE_HZ`` for the whole trajectory (the rate drops beyond).
MAX_CHECK_SAMPLES = 200_000
#: Poses are inserted until the sampled deviation is within this fraction of each tolerance.
MARGIN = 0.95
#: A segment is given up when two consecutive poses on it are closer than this (fraction of it).
MIN_FRACTION = 1e-3
#: Rounds of insertion before giving up.
MAX_ROUNDS = 25

Timing = TypeVar("Timing")


def interpolate_pose(a: pin.SE3, b: pin.SE3, u: float) -> pin.SE3:
    """The pose at fraction ``u`` of the straight segment from ``a`` to ``b`` (module docstring)."""
    rotation = a.rotation @ pin.exp3(u * pin.log3(a.rotation.T @ b.rotation))
    return pin.SE3(rotation, (1 - u) * a.translation + u * b.translation)


def segment_deviation(a: pin.SE3, b: pin.SE3, positions: np.ndarray,
                      rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance [m] and angle [rad] of tool poses from the straight segment ``a`` -> ``b``.

    Args:
        a: the segment's start pose.
        b: the segment's end pose.
        positions: (N, 3) tool positions [m].
        rotations: (N, 3, 3) tool orientations.

    Returns:
        (N,) distances to the line segment and (N,) angles to the slerp arc.
    """
    chord = b.translation - a.translation
    length2 = float(chord @ chord)
    offset = positions - a.translation
    u = np.clip(offset @ chord / length2, 0.0, 1.0) if length2 > 0 else np.zeros(len(positions))
    distance = np.linalg.norm(offset - u[:, None] * chord, axis=1)

    arc = pin.log3(a.rotation.T @ b.rotation)
    phi = float(np.linalg.norm(arc))
    axis = arc / phi if phi > 0 else np.zeros(3)
    relative = np.einsum("ji,njk->nik", a.rotation, rotations)
    quaternions = Rotation.from_matrix(relative).as_quat()  # (x, y, z, w), either sign
    w, along = quaternions[:, 3], quaternions[:, :3] @ axis
    best = np.mod(np.arctan2(along, w), np.pi)  # theta / 2 of the unconstrained optimum, in [0, pi)
    halves = np.stack([np.zeros_like(w), np.full_like(w, phi / 2), np.clip(best, 0.0, phi / 2)])
    half = halves[np.argmax(np.abs(np.cos(halves) * w + np.sin(halves) * along), axis=0), np.arange(len(w))]
    c, s = np.cos(half)[:, None], np.sin(half)[:, None]
    vector = quaternions[:, :3]
    # The rotation left after turning back by theta about the axis, (c, -s n) * (w, v), in full for accuracy.
    scalar = c[:, 0] * w + s[:, 0] * along
    rest = c * vector - s * w[:, None] * axis - s * np.cross(axis, vector)
    return distance, 2.0 * np.arctan2(np.linalg.norm(rest, axis=1), np.abs(scalar))


def tool_deviation(robot: Robot, trajectory: PiecewisePolynomial, poses: list[pin.SE3],
                   waypoint_via: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """How far the tool strays from the straight segments, sampled by forward kinematics.

    Args:
        robot: the robot whose tool frame is followed.
        trajectory: the timed joint trajectory.
        poses: the n user waypoints' poses.
        waypoint_via: (n,) their indices among the via-points.

    Returns:
        Per via-point interval (m - 1,): the largest distance [m] and angle [rad]; per
        user segment (n - 1,): the same.
    """
    times = trajectory.via_times
    intervals = len(times) - 1
    segment_of = np.searchsorted(waypoint_via, np.arange(intervals), side="right") - 1
    distance, angle = np.zeros(intervals), np.zeros(intervals)
    rate = min(CHECK_RATE_HZ, MAX_CHECK_SAMPLES / trajectory.total_time)
    for k in range(intervals):
        count = max(CHECK_SAMPLES, int(np.ceil((times[k + 1] - times[k]) * rate))) + 1
        q = trajectory.evaluate(np.linspace(times[k], times[k + 1], count))
        i = segment_of[k]
        d, a = segment_deviation(poses[i], poses[i + 1], *robot.tool_placements(q))
        distance[k], angle[k] = d.max(), a.max()
    per_segment = [np.zeros(len(poses) - 1) for _ in range(2)]
    for values, out in zip((distance, angle), per_segment):
        np.maximum.at(out, segment_of, values)
    return distance, angle, per_segment[0], per_segment[1]


@dataclass(frozen=True)
class StraightPath(ReadOnlyArrays):
    """A joint trajectory whose tool follows the straight segments between waypoints.

    Attributes:
        via_points: (m, J) every via-point [rad]: the waypoints' and the inserted poses'.
        waypoint_via: (n,) index of each user waypoint among the via-points.
        inserted: (n - 1,) poses inserted on each segment.
        max_distance_m, max_angle_rad: (n - 1,) the largest sampled deviation per segment.
        rounds: timing rounds made.
    """

    via_points: np.ndarray
    waypoint_via: np.ndarray
    inserted: np.ndarray
    max_distance_m: np.ndarray
    max_angle_rad: np.ndarray
    rounds: int

    def __post_init__(self):
        freeze_arrays(self)


def follow_straight_lines(robot: Robot, poses: list[pin.SE3], waypoint_q: np.ndarray,
                          time_via_points: Callable[[np.ndarray], tuple[PiecewisePolynomial, Timing]],
                          tolerance_m: float, tolerance_rad: float,
                          note: Callable[[str], None] = lambda line: None,
                          least_duration: tuple[float, str] = (0.0, "")) -> tuple[StraightPath, Timing]:
    """Insert poses until the timed trajectory's tool stays on the straight segments.

    Args:
        robot: the robot whose tool frame is followed.
        poses: the n waypoints' poses.
        waypoint_q: (n, J) their configurations [rad].
        time_via_points: times (m, J) via-points; returns the trajectory and whatever
            else the caller keeps (returned with the path, for the final via-points).
        tolerance_m: the largest distance [m] allowed.
        tolerance_rad: the largest angle [rad] allowed.
        note: told one line per round: how far the tool strays and what happens next.
        least_duration: the shortest segment the timing allows [s] and the task key that sets it
            (``trajectory.min_segment_s`` or ``optimizer.bounds_s``): where an interval beyond the
            tolerances has timed segments that last no longer, the poses of every path segment are
            spaced evenly (``_even_counts``, ``_respace``), and where they cannot come closer a refusal
            names it.

    Raises:
        IKError: a segment that leaves the reachable workspace, or that no joint
            motion follows (the deviation does not shrink as poses are inserted, or a round
            cannot be timed where the joints jump between two poses), naming the segment,
            the fraction along it and the position.
        TaskError: following the lines would need more than ``MAX_VIA_POINTS`` via-points.
    """
    # Per segment: the fractions u of its poses and their configurations, both ends included.
    fractions = [[0.0, 1.0] for _ in range(len(poses) - 1)]
    configurations = [[waypoint_q[i], waypoint_q[i + 1]] for i in range(len(poses) - 1)]
    for rounds in range(1, MAX_ROUNDS + 1):
        via = np.array([configurations[0][0]] + [q for segment in configurations for q in segment[1:]])
        counts = np.array([len(f) - 1 for f in fractions])
        waypoint_via = np.concatenate(([0], np.cumsum(counts)))
        try:
            trajectory, timing = time_via_points(via)
        except InfeasibleError:  # the poses may ask for a jump no timing follows: that is the error then
            _name_jump(robot, poses, fractions, configurations)
            raise
        distance, angle, per_distance, per_angle = tool_deviation(robot, trajectory, poses, waypoint_via)
        exceeded = (distance > MARGIN * tolerance_m) | (angle > MARGIN * tolerance_rad)
        outcome = (f"; inserting a pose in each of the {int(exceeded.sum())} intervals beyond the tolerances"
                   if exceeded.any() else ", within the tolerances")
        note(f"straight-line round {rounds}: {int(counts.sum()) - len(counts)} poses inserted, the tool strays up "
             f"to {1e3 * distance.max():.3g} mm and {np.rad2deg(angle.max()):.3g} deg{outcome}")
        if not exceeded.any():
            return StraightPath(via, waypoint_via, counts - 1, per_distance, per_angle, rounds), timing
        if rounds == MAX_ROUNDS:
            break
        found = [(int(np.searchsorted(waypoint_via, k, side="right") - 1), int(k)) for k in np.flatnonzero(exceeded)]
        least_at = {k: _at_least_duration(trajectory, k, least_duration) for _, k in found}
        # path segment: the least duration an interval of it is held at
        held = {i: least for i, k in found if (least := least_at[k]) is not None}
        spaced = _even_counts(configurations, held)
        respaced = _respaced(spaced, counts)
        added = sum(spaced[i] - counts[i] for i in respaced) + sum(i not in respaced for i, _ in found)
        if len(via) + added > MAX_VIA_POINTS:
            raise TaskError("path.tolerance_m", f"following the straight lines within {1e3 * tolerance_m:g} mm and "
                                                f"{np.rad2deg(tolerance_rad):g} deg needs more than {MAX_VIA_POINTS} "
                                                f"via-points ({len(via)} after {rounds} rounds, still straying); "
                                                f"allow larger tolerances or split the task")
        if respaced:
            least = next(iter(held.values()))
            note(f"straight-line round {rounds}: the timed segments of path segment(s) "
                 f"{', '.join(map(str, sorted(held)))} sit at their least duration, {least[0]:.6g} s ({least[1]}): "
                 f"spacing the poses of path segment(s) {', '.join(map(str, sorted(respaced)))} evenly instead, "
                 f"{sum(spaced[i] - 1 for i in respaced)} of them")
        for i in sorted(respaced):
            _respace(robot, poses, i, fractions[i], configurations[i], spaced[i])
        # Segment by segment; within one, backwards, so an insertion keeps the earlier indices valid.
        for i, k in sorted(found, key=lambda item: (item[0], -item[1])):
            if i in respaced:
                continue
            local = k - waypoint_via[i]
            if fractions[i][local + 1] - fractions[i][local] < 2 * MIN_FRACTION:  # no closer pose can help here:
                _name_jump(robot, poses, fractions, configurations)  # a jump elsewhere may be why, not the tolerance
            _insert(robot, poses, i, local, fractions[i], configurations[i], distance[k], angle[k], least_at[k])
    k = int(np.argmax(np.maximum(distance / tolerance_m, angle / tolerance_rad)))
    i = int(np.searchsorted(waypoint_via, k, side="right") - 1)
    raise IKError(f"path segment {i} (waypoint {i} -> {i + 1}): the tool still strays {1e3 * distance[k]:.3g} mm "
                  f"and {np.rad2deg(angle[k]):.3g} deg from the straight line after {MAX_ROUNDS} rounds",
                  waypoint=i)


#: A joint change [rad] between two poses MIN_FRACTION apart beyond which the joint motion jumps there.
JUMP_RAD = np.deg2rad(1.0)


def _at_least_duration(trajectory: PiecewisePolynomial, interval: int,
                       least_duration: tuple[float, str]) -> tuple[float, str] | None:
    """``least_duration`` ([s], its key) where a segment between via-points ``interval`` and
    ``interval + 1`` of ``trajectory`` lasts no longer (to 1e-6 of it), else None."""
    if least_duration[0] <= 0:
        return None
    times = trajectory.via_times
    starts = trajectory.knot_times[:-1]
    inside = (starts >= times[interval]) & (starts < times[interval + 1])
    return least_duration if np.any(trajectory.durations[inside] <= least_duration[0] * (1 + 1e-6)) else None


def _why_not_followed(robot: Robot, before: np.ndarray, after: np.ndarray,
                      held: tuple[float, str] | None = None) -> str:
    """Why no inserted pose brings the tool closer between two neighbouring configurations [rad]:
    the joints jump there (another IK branch or 2 pi turn, a singularity, a range bound), or they
    barely move: the timing holds the segments there at their least duration ``held`` ([s], key; each
    inserted pose adds one, and the spline overshoots the slow, crowded stretch), or the tolerance
    is finer than the timed motion between close via-points can keep."""
    change = np.abs(after - before)
    joint = int(np.argmax(change))
    if change[joint] > JUMP_RAD:
        return (f"the joint motion jumps there (joint {robot.joint_names[joint]!r} by "
                f"{np.rad2deg(change[joint]):.3g} deg between the two closest poses: another IK branch or 2 pi "
                f"turn, a singularity or a joint range bound on the line)")
    said = f"the joints barely move there (at most {np.rad2deg(change[joint]):.3g} deg between the two closest poses)"
    if held is not None:
        return (f"{said}, and the timing holds the segments there at their least duration, {held[0]:.6g} s "
                f"({held[1]}): each pose inserted adds such a segment, and the spline overshoots the slow, crowded "
                f"stretch; lower that least duration")
    return f"{said}: the tolerance is finer than the timed motion keeps; allow a larger path.tolerance_m or " \
           f"path.tolerance_deg"


def _insert(robot: Robot, poses: list[pin.SE3], segment: int, local: int, fractions: list[float],
            configurations: list[np.ndarray], distance: float, angle: float,
            held: tuple[float, str] | None = None) -> None:
    """Insert the pose halfway between poses ``local`` and ``local + 1`` of ``segment`` (``held``: the
    least duration the timing holds the segments there at, or None; ``_why_not_followed``).

    Raises:
        IKError: the poses are already ``MIN_FRACTION`` close, or the line leaves the workspace there.
    """
    low, high = fractions[local], fractions[local + 1]
    before, after = configurations[local], configurations[local + 1]
    if high - low < 2 * MIN_FRACTION:
        raise IKError(f"{_where(poses, segment, (low + high) / 2)}: the tool strays {1e3 * distance:.3g} mm and "
                      f"{np.rad2deg(angle):.3g} deg from the straight line however close the poses; "
                      f"{_why_not_followed(robot, before, after, held)}", waypoint=segment)
    fractions.insert(local + 1, (low + high) / 2)
    configurations.insert(local + 1, _pose_between(robot, poses, segment, low, high, before, after))


def _even_counts(configurations: list[list[np.ndarray]], held: dict[int, tuple[float, str]]) -> dict[int, int]:
    """Per path segment, the intervals that space every segment's poses as closely as half the
    closest spacing of the segments ``held`` at their least duration, in joint motion (the largest
    joint change [rad], summed over a segment's intervals): bisecting there would crowd slow segments
    together, and a segment spaced coarser beside finer ones makes the spline overshoot at the
    waypoint between them. Empty where none is held."""
    if not held:
        return {}
    lengths = [sum(float(np.abs(b - a).max()) for a, b in zip(segment, segment[1:])) for segment in configurations]
    step = min(lengths[i] / (len(configurations[i]) - 1) for i in held) / 2
    return {i: max(len(segment) - 1, int(np.ceil(length / step - 1e-9)) if step > 0 else 1)
            for i, (segment, length) in enumerate(zip(configurations, lengths))}


def _respaced(spaced: dict[int, int], counts: np.ndarray) -> set[int]:
    """The path segments whose poses are spaced evenly this round: those whose even count (``spaced``,
    ``_even_counts``) is above their intervals now (``counts``), and whose spacing 1 / count stays at least
    2 ``MIN_FRACTION``. The others, held or not, have their straying intervals bisected as usual: one
    whose even count adds nothing would otherwise be neither respaced nor bisected, and the rounds
    would stall on it."""
    return {i for i, count in spaced.items() if count > counts[i] and 1 / count >= 2 * MIN_FRACTION}


def _respace(robot: Robot, poses: list[pin.SE3], segment: int, fractions: list[float],
             configurations: list[np.ndarray], count: int) -> None:
    """Replace the poses of ``segment`` (fractions along it and configurations [rad], both ends
    included, changed in place) by ``count`` + 1 evenly spaced ones: a pose already there is kept,
    another is solved between the two it falls between (``_pose_between``), so the branch is kept.

    Raises:
        IKError: as ``_pose_between``.
    """
    old_fractions, old_configurations = np.array(fractions), list(configurations)
    spaced = np.linspace(0.0, 1.0, count + 1)
    solved = []
    for u in spaced:
        j = min(int(np.searchsorted(old_fractions, u, side="right")) - 1, len(old_fractions) - 2)
        there = [m for m in (j, j + 1) if abs(u - old_fractions[m]) <= 1e-12]
        if there:
            solved.append(old_configurations[there[0]])
            continue
        solved.append(_pose_between(robot, poses, segment, old_fractions[j], old_fractions[j + 1],
                                    old_configurations[j], old_configurations[j + 1], u))
    fractions[:], configurations[:] = spaced.tolist(), solved


def _where(poses: list[pin.SE3], segment: int, u: float) -> str:
    """The segment, the fraction ``u`` along it and the position there, in words."""
    target = interpolate_pose(poses[segment], poses[segment + 1], u)
    return (f"path segment {segment} (waypoint {segment} -> {segment + 1}) at fraction {u:.4g}, "
            f"position [{', '.join(f'{x:.4f}' for x in target.translation)}] m")


def _pose_between(robot: Robot, poses: list[pin.SE3], segment: int, low: float, high: float,
                  before: np.ndarray, after: np.ndarray, u: float | None = None) -> np.ndarray:
    """The configuration [rad] of the pose at fraction ``u`` (default: halfway) between fractions
    ``low`` and ``high`` of ``segment``, whose neighbours are ``before`` and ``after``: IK continuation
    along the line from ``before`` (``continued``), the branch ``before`` is on. Where that fails (a
    singularity or a range bound on the way), IK from their linear interpolation at ``u`` (the middle),
    on the 2 pi turns nearest it; where that fails too, or lands farther from the middle than the
    neighbours are apart (another branch), IK from each neighbour, keeping the solution nearest the
    middle. IK from the middle alone could land on another branch where the motion between the
    neighbours is large (a UR5 line whose continuous motion turns the shoulder by 60 deg: its inserted
    poses alternated between branches, and the line was refused as a jump where none is).

    Raises:
        IKError: no configuration reaches the pose from the neighbours' (the line leaves the reachable
            workspace, or the branch followed runs into a range bound).
    """
    u = (low + high) / 2 if u is None else u
    followed = continued(robot, poses, segment, before, low, u)
    if followed is not None:
        return followed
    target = interpolate_pose(poses[segment], poses[segment + 1], u)
    middle = before + (after - before) * (u - low) / (high - low)
    span = np.abs(after - before).max()
    found = []
    for seed in (middle, before, after):
        solution = solve_pose(robot, target, seed)
        q = nearest_turn(robot, solution.q, middle)
        found.append((solution, q, np.abs(q - middle).max()))
        if solution.residual <= 1e-9 and found[-1][2] <= span:
            break
    best, q, _ = min(found, key=lambda option: (option[0].residual > 1e-9, option[2], option[0].residual))
    if best.residual > 1e-9:
        raise IKError(f"{_where(poses, segment, u)}: IK from the neighbouring poses' configurations "
                      f"reaches no configuration there within the joint ranges: the straight line leaves the reachable "
                      f"workspace, or the branch it follows runs into a range bound (best residual "
                      f"{best.position_error:.3g} m, {np.rad2deg(best.orientation_error):.3g} deg)",
                      waypoint=segment, residual=best.residual)
    return q


#: A half interval keeping more than this fraction of its interval's joint change marks a possible jump.
CONCENTRATED = 0.75
#: Intervals, the largest joint changes first, searched for a jump when a round cannot be timed.
JUMP_CANDIDATES = 3


def _name_jump(robot: Robot, poses: list[pin.SE3], fractions: list[list[float]],
               configurations: list[list[np.ndarray]]) -> None:
    """Where a round's via-points cannot be timed, or poses can come no closer, look for a joint motion
    that jumps between two neighbouring poses (a singularity on the line: the timing then fails for a
    joint far from it, or the rounds stall beside it): the ``JUMP_CANDIDATES`` intervals of largest
    joint change, each bisected by ``_check_continuous``. Only where the plan fails anyway: near a
    singularity a fast but continuous motion can look like a jump to the bisection's IK (another
    branch of the wrist), and it times well.

    Raises:
        IKError: the first interval whose motion jumps (``_check_continuous``).
    """
    intervals = [(float(np.abs(ends[k + 1] - ends[k]).max()), segment, k)
                 for segment, ends in enumerate(configurations) for k in range(len(ends) - 1)]
    for change, segment, k in sorted(intervals, reverse=True)[:JUMP_CANDIDATES]:
        if change <= JUMP_RAD:
            return
        low, high = fractions[segment][k], fractions[segment][k + 1]
        before, after = configurations[segment][k], configurations[segment][k + 1]
        q = _pose_between(robot, poses, segment, low, high, before, after)
        _check_continuous(robot, poses, segment, (low, (low + high) / 2, high), (before, q, after))


def _check_continuous(robot: Robot, poses: list[pin.SE3], segment: int, fractions: tuple[float, float, float],
                      configurations: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    """Refuse a joint motion that jumps between two poses of ``segment``.

    A continuous motion's change between two poses shrinks with their distance: halving the
    interval halves it. Where one half keeps more than ``CONCENTRATED`` of the interval's change
    (larger than ``JUMP_RAD``), that half is bisected again by IK alone, down to ``MIN_FRACTION``:
    if the change is still larger than ``JUMP_RAD`` there, the motion jumps (a singularity on the
    line, a wrist flip, another branch) and no timing can follow it. Near, not at, a singularity the
    change eventually splits, and the segment is timed as usual.

    Raises:
        IKError: naming the segment, the fraction and the position, and the joint that jumps.
    """
    (low, mid, high), (before, q, after) = fractions, configurations
    while True:
        change = np.abs(after - before).max()
        halves = ((low, mid, before, q), (mid, high, q, after))
        low, high, before, after = max(halves, key=lambda half: np.abs(half[3] - half[2]).max())
        if change <= JUMP_RAD or np.abs(after - before).max() <= CONCENTRATED * change:
            return
        if high - low < MIN_FRACTION:
            raise IKError(f"{_where(poses, segment, (low + high) / 2)}: no joint motion follows the straight line "
                          f"there: {_why_not_followed(robot, before, after)}", waypoint=segment)
        mid = (low + high) / 2
        q = _pose_between(robot, poses, segment, low, high, before, after)


#: Steps per segment that ``track_straight_lines`` starts with (and never exceeds in length).
TRACK_STEPS = 32
#: The largest joint change [rad] of one step of ``track_straight_lines``: a step beyond it is halved.
TRACK_STEP_RAD = np.deg2rad(5.0)


def continued(robot: Robot, poses: list[pin.SE3], segment: int, q: np.ndarray, start: float,
              end: float) -> np.ndarray | None:
    """The configuration [rad] at fraction ``end`` of ``segment`` reached by IK continuation from ``q`` at
    fraction ``start`` <= ``end``, or None where the line cannot be followed from there: the pose a step
    further (at most 1 / ``TRACK_STEPS`` of the segment) is solved from the last configuration and taken on
    the 2 pi turns nearest it; a step that misses the pose within the ranges, or moves a joint by more than
    ``TRACK_STEP_RAD``, is halved, down to ``MIN_FRACTION`` (a singularity or a range bound on this branch)."""
    q = np.asarray(q, dtype=float)
    u, step = start, 1.0 / TRACK_STEPS
    while u < end:
        step = min(step, end - u)
        target = interpolate_pose(poses[segment], poses[segment + 1], u + step)
        solution = solve_pose(robot, target, q)
        following = nearest_turn(robot, solution.q, q)
        if solution.residual > 1e-9 or np.abs(following - q).max() > TRACK_STEP_RAD:
            if step < MIN_FRACTION:
                return None
            step /= 2
            continue
        q, u, step = following, (end if step == end - u else u + step), min(2 * step, 1.0 / TRACK_STEPS)
    return q


def track_straight_lines(robot: Robot, poses: list[pin.SE3], first: np.ndarray,
                         kept: list[np.ndarray | None]) -> np.ndarray | None:
    """Waypoint configurations (n, J) [rad] joined by joint motions that follow the straight lines,
    from ``first`` [rad] at waypoint 0, or None where the lines cannot be followed from there.

    IK continuation along each segment (``continued``; where it stops, the line runs into a singularity
    or a range bound from this branch: None). The configuration reached at a waypoint is the next segment's start; where
    ``kept[i]`` holds one (a hinted waypoint's), the line must arrive at it (up to 2 pi turns), or
    None. The IK sequences of both branch rules pick each waypoint's solution by the joint motion
    between waypoints, and may pick one that the line from the previous waypoint does not reach.
    """
    q = np.asarray(first, dtype=float)
    reached = [q]
    for segment in range(len(poses) - 1):
        found = continued(robot, poses, segment, q, 0.0, 1.0)
        if found is None:
            return None
        q = found
        required = kept[segment + 1]
        if required is not None:
            if np.abs(nearest_turn(robot, q, required) - required).max() > JUMP_RAD:
                return None
            q = np.asarray(required, dtype=float)
        reached.append(q)
    return np.array(reached)


#: Most 2 pi turn variants of the first configuration ``track_from_turns`` tries.
TRACK_TURN_VARIANTS = 64


def track_from_turns(robot: Robot, poses: list[pin.SE3], first: np.ndarray,
                     kept: list[np.ndarray | None]) -> np.ndarray | None:
    """``track_straight_lines`` from ``first``, or, where the lines cannot be followed from it and the first
    waypoint has no kept (hinted) solution, from the first of its 2 pi turn variants within the ranges
    (``ik.turn_variants``, at most ``TRACK_TURN_VARIANTS``) that follows them: a joint whose range spans
    several turns can run into a bound from one turn and not from another (a UR5 line that turns wrist 3 by
    270 deg, from 89 deg past its 360 deg bound, from -271 deg inside it). None where none does."""
    reached = track_straight_lines(robot, poses, first, kept)
    if reached is not None or kept[0] is not None:
        return reached
    for variant in turn_variants(robot, np.asarray(first, dtype=float), robot.limits)[:TRACK_TURN_VARIANTS]:
        if np.abs(variant - first).max() > JUMP_RAD:  # ``first`` itself was tried
            reached = track_straight_lines(robot, poses, variant, kept)
            if reached is not None:
                return reached
    return None
