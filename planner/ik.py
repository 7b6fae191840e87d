"""Inverse kinematics: tool poses -> joint configurations on one continuous branch.

``solve_pose`` runs damped least squares on the SE3 error: with
e = log6(T(q)^-1 T_target) (local frame, linear part first) and
J_e = Jlog6(T(q)^-1 T_target) J_local(q), each step is

    dq = J_e^T (J_e J_e^T + lambda I)^-1 e,     lambda = lambda_0 |e|^2,

applied with ``pinocchio.integrate`` and clipped to the joint ranges. The
damping vanishes as the error does, so the last steps are Newton steps and
the error falls below 1e-9 (m and rad) in a few iterations.

``solve_waypoints`` chooses one solution per waypoint, by one of two rules:

* ``optimal`` (default): ``pose_solutions`` finds every distinct solution of
  each pose within the joint ranges (damped least squares from many random
  starts, without clipping, then every 2 pi turn of a revolute joint that
  stays in range; duplicates up to 2 pi turns removed), and ``choose_branches``
  picks one per waypoint by dynamic programming over the sequence, minimising
  the sum of the transition costs: the slowest joint's rest-to-rest time
  (``limits.rest_to_rest_time``) between consecutive configurations. A
  waypoint with a hint has one candidate, the solution seeded by its hint.
  With a start configuration (the robot's, before the task) the motion from it
  to the first waypoint counts too; without one, sequences of equal cost (a
  wrist flip moves the wrist joints by the same amounts) are told apart by the
  first configuration's distance to the middle of the joint ranges.
* ``continuous``: each solve is seeded from the previous solution (or the
  waypoint's hint), restarted from random configurations when it fails, and
  the solution nearest the previous configuration is kept (revolute joints
  whose range allows it are shifted by multiples of 2 pi towards it).

Either way each solution reports how many distinct solutions were found, which
was chosen, and the joint-space jump from the previous waypoint.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .errors import IKError, InputError
from .limits import JointLimits, rest_to_rest_time
from .robot import Robot

TOLERANCE = 1e-10
_DAMPING = 1e-3
_DAMPING_FLOOR = 1e-12
_MAX_ITERATIONS = 100
_ALTERNATIVES = 4
BRANCH_RULES = ("optimal", "continuous")
#: Random starts per pose when enumerating its solutions.
SOLUTION_STARTS = 48
#: Solutions closer than this [rad or m, largest joint difference, up to 2 pi turns] are one.
DISTINCT = 1e-5
#: At most this many distinct solutions per pose are kept (a redundant arm has infinitely many).
MAX_SOLUTIONS = 16
#: Weight [s/rad] of the distance to the middle of the ranges, which only separates equal costs.
_TIE_BREAK = 1e-4


@dataclass(frozen=True)
class IKSolution:
    """A configuration reaching a pose.

    Attributes:
        q: (nq,) joint positions [rad].
        position_error: |translation error| [m]; orientation_error: |rotation error| [rad].
        iterations: DLS iterations of the accepted solve; attempts: solves tried.
        jump: |q - q_previous| [rad] (0 for the first waypoint).
        solutions: distinct solutions found for the pose (up to 2 pi turns); chosen: which (0-based).
    """

    q: np.ndarray
    position_error: float
    orientation_error: float
    iterations: int
    attempts: int = 1
    jump: float = 0.0
    solutions: int = 1
    chosen: int = 0

    @property
    def residual(self) -> float:
        return max(self.position_error, self.orientation_error)


def pose_from_position_quaternion(position, quaternion_xyzw) -> pin.SE3:
    """SE3 pose from a position [m] and a unit quaternion (x, y, z, w)."""
    x, y, z, w = np.asarray(quaternion_xyzw, dtype=float)
    return pin.SE3(pin.Quaternion(w, x, y, z).normalized().matrix(), np.asarray(position, dtype=float))


def pose_error(robot: Robot, q: np.ndarray, target: pin.SE3) -> np.ndarray:
    """log6(T(q)^-1 T_target) as (6,): translation [m] then rotation [rad], in the tool frame."""
    return pin.log6(robot.forward_kinematics(q).actInv(target)).vector


def solve_pose(robot: Robot, target: pin.SE3, seed: np.ndarray, *, tolerance: float = TOLERANCE,
               max_iterations: int = _MAX_ITERATIONS, clip: bool = True) -> IKSolution:
    """Damped least squares from ``seed``; returns the last iterate (check ``residual``).

    With ``clip`` every iterate is clipped to the joint ranges; without, the
    solve runs free (it converges far more often) and the caller maps the
    result into the ranges.
    """
    lower, upper = (robot.limits.lower, robot.limits.upper) if clip else (-np.inf, np.inf)
    q = np.clip(np.asarray(seed, dtype=float), lower, upper)
    for iteration in range(1, max_iterations + 1):
        current = robot.forward_kinematics(q)
        offset = current.actInv(target)
        error = pin.log6(offset).vector
        if max(np.linalg.norm(error[:3]), np.linalg.norm(error[3:])) <= tolerance:
            break
        jacobian = pin.Jlog6(offset) @ robot.frame_jacobian(q)
        damping = _DAMPING * float(error @ error) + _DAMPING_FLOOR  # the floor keeps J J^T + lambda I invertible
        step = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + damping * np.eye(6), error)
        q = np.clip(pin.integrate(robot.model, q, step), lower, upper)
    error = pose_error(robot, q, target)
    return IKSolution(q, float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:])), iteration)


def _nearest_turn(robot: Robot, q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Shift revolute joints by multiples of 2 pi towards ``reference``, staying within range."""
    turns = np.round((reference - q) / (2 * np.pi))
    shifted = q + 2 * np.pi * turns
    inside = (shifted >= robot.limits.lower) & (shifted <= robot.limits.upper)
    return np.where(inside & robot.revolute, shifted, q)


def _finite_ranges(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """The joint ranges with unbounded sides replaced by -pi and pi (for random starts)."""
    lower, upper = robot.limits.lower, robot.limits.upper
    return np.where(np.isfinite(lower), lower, -np.pi), np.where(np.isfinite(upper), upper, np.pi)


def _wrapped(robot: Robot, difference: np.ndarray) -> np.ndarray:
    """``difference`` with revolute joints' components wrapped into [-pi, pi)."""
    return np.where(robot.revolute, (difference + np.pi) % (2 * np.pi) - np.pi, difference)


def _turns_freely(robot: Robot, limits: JointLimits) -> np.ndarray:
    """(nq,) revolute joints without a finite range (their turns are free)."""
    return robot.revolute & ~(np.isfinite(limits.lower) & np.isfinite(limits.upper))


def turn_variants(robot: Robot, q: np.ndarray, limits: JointLimits) -> np.ndarray:
    """(m, nq) every configuration equal to ``q`` up to 2 pi turns of revolute joints, within the
    ranges of ``limits`` (m = 0 if none is). A revolute joint without a finite range keeps its
    angle wrapped into [-pi, pi); the branch choice turns it the short way."""
    lower, upper = limits.lower, limits.upper
    free = _turns_freely(robot, limits)
    options = []
    for j in range(robot.dof):
        if free[j]:
            values = [float(_wrapped(robot, q)[j])]
        elif not robot.revolute[j]:
            values = [q[j]] if lower[j] - 1e-12 <= q[j] <= upper[j] + 1e-12 else []
        else:
            turns = np.arange(np.ceil((lower[j] - q[j]) / (2 * np.pi) - 1e-12),
                              np.floor((upper[j] - q[j]) / (2 * np.pi) + 1e-12) + 1)
            values = list(np.clip(q[j] + 2 * np.pi * turns, lower[j], upper[j]))
        if not values:
            return np.zeros((0, robot.dof))
        options.append(values)
    grids = np.meshgrid(*options, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1)


def _distinct(robot: Robot, q: np.ndarray, others: list[IKSolution]) -> bool:
    """Whether ``q`` differs from every one of ``others`` by more than ``DISTINCT``, up to 2 pi turns."""
    return all(np.max(np.abs(_wrapped(robot, q - other.q))) > DISTINCT for other in others)


def pose_solutions(robot: Robot, target: pin.SE3, limits: JointLimits, rng: np.random.Generator, *,
                   starts: int = SOLUTION_STARTS,
                   accept: float = 1e-9) -> tuple[list[IKSolution], IKSolution, int]:
    """The distinct solutions of one pose within the ranges of ``limits``, the best solve
    (lowest residual, for an error message when there is none) and the starts used.

    Each random start is solved without clipping; a converged solution with no
    2 pi turn inside the ranges is solved again with clipping from its clipped
    value. Solutions equal up to 2 pi turns (within ``DISTINCT``) are one; at most
    ``MAX_SOLUTIONS`` are kept.
    """
    lower, upper = _finite_ranges(robot)
    found: list[IKSolution] = []
    best = None
    for attempt in range(1, starts + 1):
        solution = solve_pose(robot, target, lower + (upper - lower) * rng.random(robot.dof), clip=False)
        inside = solution.residual <= accept and len(turn_variants(robot, solution.q, limits)) > 0
        if solution.residual <= accept and not inside:
            solution = solve_pose(robot, target, solution.q)
            inside = solution.residual <= accept and len(turn_variants(robot, solution.q, limits)) > 0
        if best is None or (inside, -solution.residual) > (best[0], -best[1].residual):
            best = (inside, solution)
        if inside and _distinct(robot, solution.q, found):
            found.append(solution)
            if len(found) == MAX_SOLUTIONS:
                break
    return found, best[1], attempt


def transition_costs(robot: Robot, limits: JointLimits, before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(K, L) estimated motion time [s] from each of ``before`` (K, nq) to each of ``after`` (L, nq):
    the slowest joint's rest-to-rest time. Revolute joints without a finite range turn the short way."""
    difference = after[None, :, :] - before[:, None, :]
    difference = np.where(_turns_freely(robot, limits), _wrapped(robot, difference), difference)
    return rest_to_rest_time(np.abs(difference), limits).max(axis=-1)


def choose_branches(robot: Robot, limits: JointLimits, candidates: list[np.ndarray],
                    start: np.ndarray | None = None) -> list[int]:
    """One candidate per waypoint minimising the summed transition costs (dynamic programming,
    O(n K^2)); see the module docstring for ``start`` and how equal costs are resolved.

    Args:
        candidates: per waypoint, (K_i, nq) candidate configurations [rad].
        start: the robot's configuration before the first waypoint [rad], or None.
    """
    if start is not None:
        cost = transition_costs(robot, limits, np.asarray(start, dtype=float)[None], candidates[0])[0]
    else:
        lower, upper = _finite_ranges(robot)
        cost = _TIE_BREAK * np.linalg.norm(candidates[0] - (lower + upper) / 2, axis=1)
    back = []
    for before, after in zip(candidates[:-1], candidates[1:]):
        total = cost[:, None] + transition_costs(robot, limits, before, after)
        back.append(np.argmin(total, axis=0))
        cost = total[back[-1], np.arange(len(after))]
    path = [int(np.argmin(cost))]
    for pointers in reversed(back):
        path.append(int(pointers[path[-1]]))
    return path[::-1]


def solve_waypoints(robot: Robot, poses: list[pin.SE3], *, hints: list[np.ndarray | None] | None = None,
                    start: np.ndarray | None = None, branch: str = "optimal", limits: JointLimits | None = None,
                    restarts: int = 30, accept: float = 1e-9, seed: int = 0) -> list[IKSolution]:
    """Joint configurations for a sequence of poses (module docstring for the two rules).

    Args:
        poses: target tool poses.
        hints: optional configuration [rad] per waypoint: that waypoint's solution is the one its hint seeds.
        start: the robot's configuration before the task [rad] (``continuous``: the first seed;
            default: the middle of the ranges).
        branch: ``optimal`` or ``continuous``.
        limits: the limits the transition costs use (default: the robot's).
        restarts: random restarts per waypoint when a seeded solve fails (``continuous``).
        accept: largest residual (m and rad) accepted as reached.
        seed: seed of the random starts.

    Raises:
        IKError: a pose not reached within the joint ranges (naming the waypoint and the best residual).
    """
    hints = hints or [None] * len(poses)
    if len(hints) != len(poses):
        raise InputError(f"{len(hints)} hints for {len(poses)} waypoints")
    if branch not in BRANCH_RULES:
        raise InputError(f"unknown IK branch rule {branch!r}; known: {', '.join(BRANCH_RULES)}")
    for index, hint in enumerate(hints):
        if hint is not None and np.shape(hint) != (robot.dof,):
            raise InputError(f"waypoint {index}: hint has {np.size(hint)} values, robot has {robot.dof} joints")
    if start is not None and np.shape(start) != (robot.dof,):
        raise InputError(f"IK start has {np.size(start)} values, robot has {robot.dof} joints")
    rng = np.random.default_rng(seed)
    if branch == "optimal":
        return _optimal_branches(robot, poses, hints, start, limits or robot.limits, rng, accept)
    return _continuous_branch(robot, poses, hints, start, rng, restarts, accept)


def _optimal_branches(robot, poses, hints, start, limits, rng, accept) -> list[IKSolution]:
    """``solve_waypoints`` with the ``optimal`` rule."""
    per_pose, candidates, owners = [], [], []
    for index, (target, hint) in enumerate(zip(poses, hints)):
        if hint is not None:
            best = solve_pose(robot, target, np.asarray(hint, dtype=float))
            found, attempts = ([best] if best.residual <= accept else []), 1
        else:
            found, best, attempts = pose_solutions(robot, target, limits, rng, accept=accept)
        if not found:
            raise IKError(f"waypoint {index}: pose not reached within the joint ranges after {attempts} "
                          f"attempt{'s' * (attempts > 1)}; best residual {best.position_error:.3g} m, "
                          f"{best.orientation_error:.3g} rad", waypoint=index, residual=best.residual)
        variants = [s.q[None] if hint is not None else turn_variants(robot, s.q, limits) for s in found]
        per_pose.append((found, attempts))
        candidates.append(np.concatenate(variants))
        owners.append(np.repeat(np.arange(len(found)), [len(v) for v in variants]))
    choice = choose_branches(robot, limits, candidates, start)
    free = _turns_freely(robot, limits)
    solutions, previous = [], None
    for (found, attempts), options, owner, k in zip(per_pose, candidates, owners, choice):
        q = options[k]
        if previous is not None:  # revolute joints without a finite range: the short way round
            q = np.where(free, previous + _wrapped(robot, q - previous), q)
        chosen = found[owner[k]]
        jump = float(np.linalg.norm(q - previous)) if previous is not None else 0.0
        solutions.append(IKSolution(q, chosen.position_error, chosen.orientation_error, chosen.iterations,
                                    attempts, jump, len(found), int(owner[k])))
        previous = q
    return solutions


def _continuous_branch(robot, poses, hints, start, rng, restarts, accept) -> list[IKSolution]:
    """``solve_waypoints`` with the ``continuous`` rule."""
    finite_lower, finite_upper = _finite_ranges(robot)
    previous = np.asarray(start, dtype=float) if start is not None else (finite_lower + finite_upper) / 2
    solutions = []
    for index, (target, hint) in enumerate(zip(poses, hints)):
        trial = np.asarray(hint, dtype=float) if hint is not None else previous
        found, best, attempts = [], None, 0
        # A seeded solve that succeeds is kept; after a failure, restarts gather up to
        # _ALTERNATIVES solutions so the nearest can be chosen.
        while attempts == 0 or (len(found) < _ALTERNATIVES and attempts <= restarts):
            attempts += 1
            solution = solve_pose(robot, target, trial)
            trial = finite_lower + (finite_upper - finite_lower) * rng.random(robot.dof)
            if best is None or solution.residual < best.residual:
                best = solution
            if solution.residual <= accept:
                found.append(solution)
                if attempts == 1:
                    break
        if not found:
            raise IKError(f"waypoint {index}: pose not reached within the joint ranges after {attempts} attempts; "
                          f"best residual {best.position_error:.3g} m, {best.orientation_error:.3g} rad",
                          waypoint=index, residual=best.residual)
        distinct = [s for i, s in enumerate(found) if _distinct(robot, s.q, found[:i])]
        chosen = min(distinct, key=lambda s: np.linalg.norm(_nearest_turn(robot, s.q, previous) - previous))
        q = _nearest_turn(robot, chosen.q, previous) if hint is None else chosen.q
        jump = float(np.linalg.norm(q - previous)) if index else 0.0
        solutions.append(IKSolution(q, chosen.position_error, chosen.orientation_error, chosen.iterations,
                                    attempts, jump, len(distinct), next(i for i, s in enumerate(distinct) if s is chosen)))
        previous = q
    return solutions
