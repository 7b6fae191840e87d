"""Robot-aware limits on a timed trajectory: joint torques and the tool frame's speed.

Joint torques come from Pinocchio's recursive Newton-Euler algorithm,
tau = M(q) q'' + C(q, q') q' + g(q) (``pinocchio.rnea``; rigid bodies as the
URDF's ``<inertial>`` give them, plus the rotor inertia Pinocchio's model holds,
``model.armature``, on M's diagonal: zero from a URDF, set by example-robot-data
from some robots' SRDF; no friction); the tool's
linear and angular speeds from its frame Jacobian, |J_v(q) q'| and |J_w(q) q'|
(``Robot.frame_jacobians``). Neither is a polynomial in time, so both are checked
at samples, not exactly: at ``SAMPLE_RATE_HZ`` and at least
``MIN_SAMPLES_PER_SEGMENT`` per segment (both segment ends included), at most
``MAX_SAMPLES`` in all (a longer trajectory is sampled more sparsely, evenly),
and at the peak of the parabola through each local maximum of a limited quantity
(|tau_j| / L_j, a speed) and its two neighbours (``peak_times``): between samples
a quantity can rise above the largest sample by about its curvature times the
spacing squared over 8 (the UR5 task with a 0.25 m/s tool cap: 2e-8 of the cap at
1 kHz, half a period off the samples), and the parabola's peak leaves a remainder
of the spacing's third power.

Meeting them by slowing down (the slowed trajectory is checked at the same
samples, slowed too, where the law below holds exactly, and at its own peaks:
a torque's peaks move as it slows, gravity staying, and a peak above a limit
joins the samples the slow-down meets, ``PEAK_ROUNDS``). Running the whole trajectory k >= 1 times slower
(every duration times k) keeps its path and divides q' by k and q'' by k^2:

* the tool's speeds are divided by k, so k = largest speed / limit meets them;
* the torque becomes tau_k = g(q) + (tau - g(q)) / k^2 (gravity stays), so
  with x = 1 / k^2 in (0, 1] each sample and joint needs
  -L <= g + x (tau - g) <= L, bounds on x that are exact at the samples
  (``torque_slow_down``). Where gravity alone exceeds the limit, only the motion's
  own torque holds the joint within it: slowing down weakens that, so such a sample
  bounds k from above, and where the joint rests there no timing helps. Where no k
  meets every sample, that is an ``InfeasibleError`` naming the joint and where.

The kinematic limits only become slacker when slowing down, so the kinematic
optimum, slowed by the smallest such k, meets every limit: feasible, though not
time-optimal under torque (a uniform slow-down, not a re-timing). Where it has
to slow down, the planner also times the trajectory again with these limits as
constraints of the NLP (``timing.robot_rows``) and keeps the faster of the two,
each made to meet the limits here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .errors import InfeasibleError, MissingLimitError, RobotFileError, TaskError
from .limits import TORQUE_RANGE_NM, ratio_exceeded
from .read_only import ReadOnlyArrays, freeze_arrays
from .robot import MAX_PLACEMENT_M, Robot
from .splines import PiecewisePolynomial

#: Samples per second of the torque and tool-speed checks [Hz].
SAMPLE_RATE_HZ = 1000.0
#: Fewest samples per segment, both ends included (short segments are sampled densely too).
MIN_SAMPLES_PER_SEGMENT = 32
#: Most samples in all: RNEA and gravity cost about 5 us per sample here (PUMA paper task: 17,317 samples, 0.08 s).
MAX_SAMPLES = 200_000
#: The slow-down is raised by this relative margin, so that rounding cannot leave a sample a hair above its limit.
SLOW_DOWN_MARGIN = 1e-9
#: Most rounds of sampling a slowed trajectory's own peaks (``meet_robot_limits``): slowing down moves a torque's
#: peaks (gravity stays), and each round adds those found above a limit to the samples the slow-down meets.
PEAK_ROUNDS = 3


@dataclass(frozen=True)
class RobotLimitCheck(ReadOnlyArrays):
    """Torques and tool speeds of a trajectory at its check samples.

    Attributes:
        times: (K,) sample times [s].
        torque: (K, J) joint torques [N m], or None without torque limits.
        tool_speed: (K,) the tool frame's linear speed [m/s], or None without a linear limit.
        tool_angular_speed: (K,) its angular speed [rad/s], or None without an angular limit.
    """

    times: np.ndarray
    torque: np.ndarray | None
    tool_speed: np.ndarray | None
    tool_angular_speed: np.ndarray | None

    def __post_init__(self):
        freeze_arrays(self)


def peak_times(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Times [s] of the peaks of the parabolas through each interior local maximum of every column of
    ``values`` (K, M) at ``times`` (K,) (increasing) and its two neighbours, each within its neighbours'
    times; none where the three samples are not concave. In time u = t - t_i about the maximum's sample,
    y = y_i + b u + a u^2 through (u_0, y_0) and (u_2, y_2) peaks at u = -b / (2 a) for a < 0."""
    if len(times) < 3:
        return np.zeros(0)
    y0, y1, y2 = values[:-2], values[1:-1], values[2:]
    u0, u2 = (times[:-2] - times[1:-1])[:, None], (times[2:] - times[1:-1])[:, None]
    determinant = u0 * u2 * (u2 - u0)
    a = ((y2 - y1) * u0 - (y0 - y1) * u2) / determinant
    b = ((y0 - y1) * u2 ** 2 - (y2 - y1) * u0 ** 2) / determinant
    peak = (y1 >= y0) & (y1 >= y2) & (a < 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.clip(-b / (2 * a), u0, u2)
    return np.unique((times[1:-1, None] + offset)[peak])


def check_times(trajectory: PiecewisePolynomial) -> np.ndarray:
    """(K,) sample times [s]: ``SAMPLE_RATE_HZ``, at least ``MIN_SAMPLES_PER_SEGMENT`` per segment
    (its ends included), at most ``MAX_SAMPLES`` (then spread evenly over the segments' share of time)."""
    durations = trajectory.durations
    counts = np.maximum(np.ceil(durations * SAMPLE_RATE_HZ).astype(int) + 1, MIN_SAMPLES_PER_SEGMENT)
    if counts.sum() > MAX_SAMPLES:
        share = durations / durations.sum() * (MAX_SAMPLES - 2 * len(durations))
        counts = np.maximum(share.astype(int), 0) + 2
    starts = trajectory.knot_times[:-1]
    times = np.concatenate([start + np.linspace(0.0, h, count) for start, h, count in zip(starts, durations, counts)])
    return np.unique(times)


def joint_torques(robot: Robot, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """(K, J) inverse dynamics tau = M q'' + C q' + g [N m] of (K, J) positions [rad], velocities
    [rad/s] and accelerations [rad/s^2] (``pinocchio.rnea``)."""
    model, data = robot.model, robot.data
    return np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd)]).reshape(len(q), model.nv)


def gravity_torques(robot: Robot, q: np.ndarray) -> np.ndarray:
    """(K, J) the torques g(q) [N m] that hold (K, J) positions [rad] still."""
    model, data = robot.model, robot.data
    return np.array([pin.computeGeneralizedGravity(model, data, a) for a in q]).reshape(len(q), model.nv)


def tool_twists(robot: Robot, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """(K, 6) the tool frame's twist J(q) q' in its LOCAL frame [m/s, then rad/s] at (K, J) positions
    [rad] and velocities [rad/s] (``Robot.frame_jacobians``)."""
    return np.einsum("kij,kj->ki", robot.frame_jacobians(q), qd)


def tool_speeds(robot: Robot, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K,) linear [m/s] and (K,) angular [rad/s] speed of the tool frame's origin, the norms of
    ``tool_twists`` (a norm does not depend on the axes it is expressed in)."""
    twists = tool_twists(robot, q, qd)
    return np.linalg.norm(twists[:, :3], axis=1), np.linalg.norm(twists[:, 3:], axis=1)


def torque_limits(robot: Robot, given: np.ndarray | str) -> np.ndarray:
    """(J,) torque limits [N m]: ``given``, or (``"urdf"``) the robot's URDF efforts.

    Raises:
        RobotFileError: a robot without inertial parameters (every torque would be 0), or with an inertia no
            body can have (``_check_inertias``).
        MissingLimitError: ``urdf`` for a robot whose URDF gives a joint no effort (0).
        TaskError: a list of the wrong length.
    """
    if not any(inertia.mass > 0 or inertia.inertia.any() for inertia in robot.model.inertias):
        raise RobotFileError(f"robot {robot.name!r} has no inertial parameters (no <inertial> in {robot.urdf_path}): "
                             f"torque limits need its masses and inertias", path=robot.urdf_path)
    _check_inertias(robot)
    if isinstance(given, str):
        efforts = np.asarray(robot.model.effortLimit, dtype=float)
        missing = np.flatnonzero(~(efforts > 0))
        if missing.size:
            joint = robot.joint_names[missing[0]]
            raise MissingLimitError(f"limits.torque_nm: urdf: robot {robot.name!r} gives joint {joint!r} no effort "
                                    f"(effort = {efforts[missing[0]]:g}); give the torque limits as a list",
                                    joint=joint, quantity="torque", key="limits.torque_nm")
        low, high = TORQUE_RANGE_NM
        odd = np.flatnonzero((efforts < low) | (efforts > high))
        if odd.size:  # as a task's own list is (an effort of 1e300 overflowed, one of 1e-300 held nothing up)
            joint = robot.joint_names[odd[0]]
            raise RobotFileError(f"limits.torque_nm: urdf: robot {robot.name!r} gives joint {joint!r} an effort of "
                                 f"{efforts[odd[0]]:.6g} N m ({robot.urdf_path}); the planner takes {low:g} to "
                                 f"{high:g} N m: give the torque limits as a list, or correct the URDF",
                                 path=robot.urdf_path)
        return efforts
    limits = np.asarray(given, dtype=float)
    if len(limits) != robot.dof:
        raise TaskError("limits.torque_nm", f"must have {robot.dof} values for robot {robot.name!r}, got {len(limits)}")
    return limits


def bodies_without_inertia(robot: Robot) -> list[str]:
    """The joints whose moved body has neither mass nor rotational inertia (its links hold no <inertial>, or a
    zero one; Pinocchio merges fixed links into the body): torques leave that body out. A virtual link
    between two joints can be one; none of example-robot-data's arms has one."""
    model = robot.model
    return [str(model.names[j]) for j in range(1, model.njoints)
            if model.inertias[j].mass == 0 and not np.any(model.inertias[j].inertia)]


#: A body's rotational inertia may fall below positive semidefinite by this fraction of the robot's largest
#: principal moment (rounding in a URDF's printed inertias), and no more.
INERTIA_TOLERANCE = 1e-6


def _check_inertias(robot: Robot) -> None:
    """Every body's inertial parameters are ones a body can have: finite, its centre of mass within
    ``MAX_PLACEMENT_M`` of its joint along each axis, its radius of gyration sqrt(I_max / m) too, and its rotational
    inertia (about the centre of mass) positive semidefinite within ``INERTIA_TOLERANCE``. Pinocchio
    takes them as they are, and the torques computed from them would be another robot's (a centre of
    mass 1e160 m away made its inertia NaN; a moment of 1e300 kg m^2 overflowed the timing).

    Raises:
        RobotFileError: naming the body's joint and the value (the smallest principal moment and the
            robot's largest, for an indefinite inertia).
    """
    def refuse(index: int, problem: str) -> RobotFileError:
        return RobotFileError(f"the body moved by joint {robot.model.names[index]!r} has {problem}: torque limits "
                              f"need true inertial parameters; fix its <inertial> in {robot.urdf_path}",
                              path=robot.urdf_path)

    inertias = list(robot.model.inertias)
    for index, inertia in enumerate(inertias):
        farthest = float(np.max(np.abs(inertia.lever)))
        if not farthest <= MAX_PLACEMENT_M:  # a far centre of mass makes the inertia about it NaN too
            raise refuse(index, f"its centre of mass {farthest:.4g} m along an axis from the joint "
                                f"(<inertial><origin>); at most {MAX_PLACEMENT_M:.0e} m is taken")
        if not np.all(np.isfinite(np.append(inertia.inertia.ravel(), inertia.mass))):
            raise refuse(index, f"a mass ({inertia.mass:.4g} kg) or an inertia that is not a finite number")
    moments = [np.linalg.eigvalsh(inertia.inertia) for inertia in inertias]
    largest = max(float(m.max()) for m in moments)
    for index, (inertia, values) in enumerate(zip(inertias, moments)):
        if values.min() < -INERTIA_TOLERANCE * max(largest, 1e-300):
            raise refuse(index, f"an inertia no body can have (a principal moment of {values.min():.4g} kg m^2; the "
                                f"robot's largest is {largest:.4g})")
        if inertia.mass > 0 and math.sqrt(max(float(values.max()), 0.0) / inertia.mass) > MAX_PLACEMENT_M:
            raise refuse(index, f"a principal moment of {values.max():.4g} kg m^2 for {inertia.mass:.4g} kg, a "
                                f"radius of gyration above {MAX_PLACEMENT_M:.0e} m")


def torque_slow_down(torque: np.ndarray, gravity: np.ndarray, limit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lowest, highest), each (K, J): the slow-downs k >= 1 after which each sample's torque is within
    +-limit form the interval [lowest, highest] (lowest = inf: none does).

    Slowed k times, a sample's torque is g + x (tau - g), x = 1 / k^2 in (0, 1]. With d = tau - g,
    -L <= g + x d <= L bounds x on both sides: x <= (L - g) / d and x >= (-L - g) / d where d > 0,
    the reverse where d < 0, nothing where d = 0 (then |g| <= L decides). Where |g| <= L, x -> 0 is
    inside (any slower pace serves: highest = inf); where gravity alone exceeds the limit only a
    pace fast enough for the motion's own torque to hold it back can (highest finite), and none at
    rest (d = 0). k = 1 / sqrt(x).

    Args:
        torque: (K, J) tau [N m].
        gravity: (K, J) g(q) [N m].
        limit: (J,) L [N m].
    """
    difference = torque - gravity
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a ratio past float range is inf
        upper, lower = (limit - gravity) / difference, (-limit - gravity) / difference
        x_high = np.where(difference > 0, upper, np.where(difference < 0, lower, np.inf))
        x_low = np.where(difference > 0, lower, np.where(difference < 0, upper, -np.inf))
        x_high, x_low = np.minimum(x_high, 1.0), np.maximum(x_low, 0.0)
        empty = (x_low > x_high) | (x_high <= 0) | ((difference == 0) & (np.abs(gravity) > limit))
        lowest = np.where(empty, np.inf, 1.0 / np.sqrt(np.where(empty, 1.0, x_high)))
        highest = np.where(empty, 0.0, 1.0 / np.sqrt(np.where(empty | (x_low == 0), 1.0, x_low)))
        highest = np.where(~empty & (x_low == 0), np.inf, highest)
    return lowest, highest


def check_robot_limits(robot: Robot, trajectory: PiecewisePolynomial, torque_limit: np.ndarray | None,
                       tool_speed: float | None, tool_angular_speed: float | None,
                       times: np.ndarray | None = None) -> RobotLimitCheck:
    """Torques and tool speeds of ``trajectory`` at ``times`` [s] (default: ``check_times`` and the
    ``peak_times`` of the limited quantities there), for the limits that are given."""
    def at(times: np.ndarray) -> RobotLimitCheck:
        q, qd = trajectory.evaluate(times), trajectory.evaluate(times, 1)
        torque = joint_torques(robot, q, qd, trajectory.evaluate(times, 2)) if torque_limit is not None else None
        linear, angular = (tool_speeds(robot, q, qd) if (tool_speed, tool_angular_speed) != (None, None)
                           else (None, None))
        return RobotLimitCheck(times, torque, None if tool_speed is None else linear,
                               None if tool_angular_speed is None else angular)

    if times is not None:
        return at(times)
    check = at(check_times(trajectory))
    if all(limit is None for limit in (torque_limit, tool_speed, tool_angular_speed)):
        return check
    peaks = _unsampled_peaks(check)
    return _merged(check, at(peaks)) if peaks.size else check


def _merged(first: RobotLimitCheck, second: RobotLimitCheck) -> RobotLimitCheck:
    """The samples of two checks of the same limits, in time order."""
    order = np.argsort(np.concatenate((first.times, second.times)), kind="stable")

    def joined(a: np.ndarray | None, b: np.ndarray | None) -> np.ndarray | None:
        return None if a is None or b is None else np.concatenate((a, b))[order]

    times = joined(first.times, second.times)
    assert times is not None
    return RobotLimitCheck(times, joined(first.torque, second.torque), joined(first.tool_speed, second.tool_speed),
                           joined(first.tool_angular_speed, second.tool_angular_speed))


@dataclass(frozen=True)
class RobotLimitOutcome(ReadOnlyArrays):
    """How a trajectory was made to meet its robot-aware limits.

    Attributes:
        torque_limit: (J,) [N m], tool_speed [m/s], tool_angular_speed [rad/s]: the limits (None: not given).
        slow_down: the factor k >= 1 every duration was multiplied by (1: none needed).
        check: the torques and tool speeds of the final trajectory at its samples.
        kinematic_total_s: the total time [s] of the trajectory the robot-aware limits were checked
            on, before they lengthened it (the kinematic optimum's).
        uniform_total_s: where the NLP timed the trajectory again with these limits as constraints
            (``timing.robot_rows``) and that was faster, the total time [s] slowing the kinematic
            optimum down took instead (the slow-down is then the re-timed trajectory's); else None.
    """

    torque_limit: np.ndarray | None
    tool_speed: float | None
    tool_angular_speed: float | None
    slow_down: float
    check: RobotLimitCheck
    kinematic_total_s: float
    uniform_total_s: float | None = None

    def __post_init__(self):
        freeze_arrays(self)

    def _peaks(self) -> dict[str, tuple]:
        """Each limited quantity's largest magnitude at the samples and its limit: ``torque`` ((J,) per
        joint [N m]), ``tool_speed`` [m/s], ``tool_angular_speed`` [rad/s], for the limits given."""
        check = self.check
        peaks: dict[str, tuple] = {}
        if check.torque is not None and self.torque_limit is not None:
            peaks["torque"] = (np.abs(check.torque).max(axis=0), self.torque_limit)
        if check.tool_speed is not None and self.tool_speed is not None:
            peaks["tool_speed"] = (float(check.tool_speed.max()), self.tool_speed)
        if check.tool_angular_speed is not None and self.tool_angular_speed is not None:
            peaks["tool_angular_speed"] = (float(check.tool_angular_speed.max()), self.tool_angular_speed)
        return peaks

    def largest_ratios(self) -> dict[str, float]:
        """The largest ratio to its limit of each limited quantity at the samples: ``torque`` (over the
        joints), ``tool_speed``, ``tool_angular_speed``."""
        return {quantity: float(np.max(peak / limit)) for quantity, (peak, limit) in self._peaks().items()}

    def summary(self) -> dict[str, object]:
        """The largest |torque| per joint [N m] and its ratio to the limit, and the largest tool
        speeds and their ratios (for the limits given), the slow-down, whether the NLP timed the
        trajectory again with these limits (and then the uniform slow-down's total time) and the sampling."""
        figures: dict[str, object] = {"slow_down": self.slow_down, "kinematic_total_time_s": self.kinematic_total_s,
                                      "retimed_in_nlp": self.uniform_total_s is not None,
                                      "uniform_slow_down_total_time_s": self.uniform_total_s,
                                      "samples": len(self.check.times),
                                      "sampling": f"{SAMPLE_RATE_HZ:g} Hz, at least {MIN_SAMPLES_PER_SEGMENT} per "
                                                  f"segment, at most {MAX_SAMPLES} in all, and each local "
                                                  f"maximum's parabola peak"}
        peaks = self._peaks()
        if "torque" in peaks:
            peak, limit = peaks["torque"]
            figures.update(torque_limit_nm=limit, max_abs_torque_nm=peak, torque_ratio=peak / limit)
        if "tool_speed" in peaks:
            peak, limit = peaks["tool_speed"]
            figures.update(tool_speed_limit_m_s=limit, max_tool_speed_m_s=peak, tool_speed_ratio=peak / limit)
        if "tool_angular_speed" in peaks:
            peak, limit = peaks["tool_angular_speed"]
            figures.update(tool_speed_limit_deg_s=math.degrees(limit), max_tool_speed_deg_s=math.degrees(peak),
                           tool_angular_speed_ratio=peak / limit)
        return figures


def _where(times: np.ndarray, sample, waypoint_times: np.ndarray) -> str:
    """``t = ... s (nearest waypoint w)`` of check sample ``sample`` (an index)."""
    waypoint = int(np.argmin(np.abs(waypoint_times - times[sample])))
    return f"t = {times[sample]:.4g} s (nearest waypoint {waypoint})"


def _gravity_beyond(robot: Robot, check: RobotLimitCheck, gravity: np.ndarray, limit: np.ndarray,
                    hopeless: np.ndarray, waypoint_times: np.ndarray) -> InfeasibleError:
    """The error where some (K, J) samples (``hopeless``) meet a torque limit at no slow-down: gravity alone
    exceeds it there, and either the joint rests (no timing helps) or its motion does not hold gravity
    back at the plan's pace or a slower one. A resting sample is named first, then the largest excess."""
    assert check.torque is not None
    resting = hopeless & (np.abs(check.torque - gravity) <= 1e-9 * np.maximum(np.abs(gravity), 1.0))
    chosen = resting if resting.any() else hopeless
    k, joint = np.unravel_index(int(np.argmax(np.where(chosen, np.abs(gravity) / limit, -np.inf))), gravity.shape)
    reason = ("it rests there: no timing helps" if resting.any() else
              f"the motion's own torque there ({check.torque[k, joint]:.4g} N m in all) does not hold it within the "
              f"limit at this pace or any slower one: no slow-down helps")
    return _held_still_beyond(robot, int(joint), float(gravity[k, joint]), float(limit[joint]),
                              _where(check.times, k, waypoint_times),
                              f"; {reason}; raise limits.torque_nm or move the waypoints")


def _held_still_beyond(robot: Robot, joint: int, gravity: float, limit: float, where: str,
                       then: str) -> InfeasibleError:
    """The error "joint ... needs g N m just to hold still at ``where``, beyond its torque limit ...",
    followed by ``then`` (why no timing helps, and what to change)."""
    return InfeasibleError(f"joint {robot.joint_names[joint]!r} needs {gravity:.4g} N m just to hold still at "
                           f"{where}, beyond its torque limit {limit:.4g} N m{then}", joint=robot.joint_names[joint],
                           joint_index=joint, quantity="torque",
                           value=gravity, limit=limit)


def holds_still(robot: Robot, torque_limit: np.ndarray, q: np.ndarray) -> bool:
    """Whether the torque limits (J,) [N m] hold the arm still at positions q (J,) [rad] against gravity."""
    return not bool(np.any(np.abs(gravity_torques(robot, np.asarray(q, dtype=float)[None])[0]) > torque_limit))


def check_resting_ends(robot: Robot, torque_limit: np.ndarray, via_points: np.ndarray,
                       remedy: Callable[[int], str] | None = None) -> None:
    """Refuse via-points (n, J) [rad] at whose first or last the torque limits (J,) [N m] cannot hold the
    arm: every family starts and ends at rest, so the torque there is gravity's alone, g(q), whatever
    the timing (checked before it, not after). ``remedy(i)``, for the via-point i refused (0 or n - 1),
    says what to change (default: the limit or the waypoint).

    Raises:
        InfeasibleError: naming the joint, the waypoint (first or last), g and the limit of the end
            furthest beyond a limit (relative to it), and the other end too where it is beyond one.
    """
    gravity = gravity_torques(robot, via_points[[0, -1]])
    over = np.abs(gravity) > torque_limit
    if not over.any():
        return
    ratio = np.where(over, np.abs(gravity) / torque_limit, -np.inf)
    end, joint = (int(k) for k in np.unravel_index(int(np.argmax(ratio)), over.shape))
    also = ""
    if over[1 - end].any():  # both ends: the other is named too (its remedy once this one is met)
        other = int(np.argmax(ratio[1 - end]))
        also = (f"; the {'first' if end else 'last'} waypoint too (joint {robot.joint_names[other]!r}: "
                f"{gravity[1 - end, other]:.4g} N m, limit {torque_limit[other]:.4g} N m)")
    raise _held_still_beyond(robot, joint, float(gravity[end, joint]), float(torque_limit[joint]),
                             f"the {'first' if end == 0 else 'last'} waypoint, where the trajectory rests",
                             ": no timing helps; " + (remedy(0 if end == 0 else len(via_points) - 1) if remedy else
                                                      "raise limits.torque_nm or move the waypoint") + also)


def _no_common_slow_down(robot: Robot, check: RobotLimitCheck, gravity: np.ndarray, limit: np.ndarray,
                         highest: np.ndarray, needed: float, allowed: float,
                         waypoint_times: np.ndarray) -> InfeasibleError:
    """The error where the limits need a slow-down of ``needed`` while a joint whose gravity torque alone
    exceeds its limit at some sample keeps within it only up to ``allowed`` (the motion's own torque
    holds gravity back there, less the slower it runs)."""
    assert check.torque is not None
    k, joint = np.unravel_index(int(np.argmin(highest)), highest.shape)
    return InfeasibleError(f"no uniform slow-down meets every robot limit: meeting them needs {needed:.6g} times "
                           f"slower, but joint {robot.joint_names[joint]!r} needs {gravity[k, joint]:.4g} N m just to "
                           f"hold still at {_where(check.times, k, waypoint_times)}, beyond its torque limit "
                           f"{limit[joint]:.4g} N m, and its motion holds that back only up to {allowed:.6g} times "
                           f"slower; raise limits.torque_nm or move the waypoints", joint=robot.joint_names[joint],
                           joint_index=int(joint),
                           quantity="torque", value=float(gravity[k, joint]), limit=float(limit[joint]))


def meet_robot_limits(robot: Robot, trajectory: PiecewisePolynomial, torque_limit: np.ndarray | None,
                      tool_speed: float | None, tool_angular_speed: float | None,
                      waypoint_times: np.ndarray) -> tuple[PiecewisePolynomial, RobotLimitOutcome]:
    """``trajectory`` slowed down uniformly by the smallest factor that meets the torque and tool-speed
    limits at the check samples (module docstring), and how; not slowed where every ratio to a limit is
    within the exact check's tolerance (``limits.ratio_exceeded``).

    Args:
        robot: the robot, for its dynamics and tool frame.
        trajectory: the timed joint trajectory.
        torque_limit: (J,) [N m], or None: no torque limit.
        tool_speed: the tool's largest linear speed [m/s], or None.
        tool_angular_speed: the tool's largest angular speed [rad/s], or None.
        waypoint_times: (n,) times [s] of the task's waypoints, to say where a gravity torque fails.

    Raises:
        InfeasibleError: no slow-down meets the limits (gravity alone exceeds a joint's torque limit
            where it rests, or where only a faster pace holds it back; or that bounds the slow-down
            below what the other limits need), naming the joint, the torque, the limit and the
            nearest waypoint.
    """
    limits = (torque_limit, tool_speed, tool_angular_speed)
    check = check_robot_limits(robot, trajectory, *limits)
    slowed, final, factor = trajectory, check, 1.0
    for _ in range(PEAK_ROUNDS):
        factor = _slow_down(robot, trajectory, check, *limits, waypoint_times)
        if factor == 1.0:
            slowed, final = trajectory, check  # its samples hold the peaks already
            break
        slowed = trajectory.slowed(factor)  # the same samples, slowed: the scaling law holds at each
        final = check_robot_limits(robot, slowed, *limits, np.minimum(check.times * factor, slowed.total_time))
        peaks = _unsampled_peaks(final)
        if not peaks.size:
            break
        at_peaks = check_robot_limits(robot, slowed, *limits, peaks)
        final = _merged(final, at_peaks)
        if not _exceeds(at_peaks, *limits):
            break
        check = _merged(check, check_robot_limits(robot, trajectory, *limits, peaks / factor))
    return slowed, RobotLimitOutcome(torque_limit, tool_speed, tool_angular_speed, factor, final, trajectory.total_time)


def _unsampled_peaks(check: RobotLimitCheck) -> np.ndarray:
    """``peak_times`` of the limited quantities' magnitudes (|tau_j|, the speeds) at ``check``'s samples,
    but those already sampled."""
    limited = np.column_stack([np.abs(value) for value in (check.torque, check.tool_speed,
                                                          check.tool_angular_speed) if value is not None])
    return np.setdiff1d(peak_times(check.times, limited), check.times)


def _exceeds(check: RobotLimitCheck, torque_limit: np.ndarray | None, tool_speed: float | None,
             tool_angular_speed: float | None) -> bool:
    """Whether a sample of ``check`` breaks a limit (``limits.ratio_exceeded``)."""
    pairs = ((check.torque, torque_limit), (check.tool_speed, tool_speed), (check.tool_angular_speed,
                                                                           tool_angular_speed))
    return any(bool(ratio_exceeded(np.abs(value) / limit).any()) for value, limit in pairs
               if value is not None and limit is not None)


def _slow_down(robot: Robot, trajectory: PiecewisePolynomial, check: RobotLimitCheck,
               torque_limit: np.ndarray | None, tool_speed: float | None, tool_angular_speed: float | None,
               waypoint_times: np.ndarray) -> float:
    """The smallest slow-down k >= 1 that meets the limits at ``check``'s samples of ``trajectory``,
    raised by ``SLOW_DOWN_MARGIN`` but never past a bound gravity sets (1 where every limit holds
    within the exact check's tolerance).

    Raises:
        InfeasibleError: as ``meet_robot_limits`` says.
    """
    factor, allowed = 1.0, math.inf
    if torque_limit is not None:
        assert check.torque is not None
        gravity = gravity_torques(robot, trajectory.evaluate(check.times))
        lowest, highest = torque_slow_down(check.torque, gravity, torque_limit)
        if not np.all(np.isfinite(lowest)):
            raise _gravity_beyond(robot, check, gravity, torque_limit, np.isinf(lowest), waypoint_times)
        factor, allowed = float(lowest.max()), float(highest.min())
    for speeds, limit in ((check.tool_speed, tool_speed), (check.tool_angular_speed, tool_angular_speed)):
        if speeds is not None and limit is not None:
            factor = max(factor, float(speeds.max()) / limit)
    if factor > allowed:
        assert check.torque is not None and torque_limit is not None
        raise _no_common_slow_down(robot, check, gravity, torque_limit, highest, factor, allowed, waypoint_times)
    if not ratio_exceeded(factor):  # within the exact check's tolerance a limit holds, as the kinematic ones do
        return 1.0
    return min(factor * (1 + SLOW_DOWN_MARGIN), allowed)
