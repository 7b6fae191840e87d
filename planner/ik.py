"""Inverse kinematics: tool poses -> joint configurations on one continuous branch.

``solve_pose`` runs damped least squares on the SE3 error: with
e = log6(T(q)^-1 T_target) (local frame, linear part first) and
J_e = Jlog6(T(q)^-1 T_target) J_local(q), each step is

    dq = J_e^T (J_e J_e^T + lambda I)^-1 e,     lambda = lambda_0 |e|^2,

applied with ``pinocchio.integrate`` and clipped to the joint ranges. The
damping vanishes as the error does, so the last steps are Newton steps and
the error falls below ``TOLERANCE`` (1e-10 m and rad) in a few iterations.

``solve_waypoints`` chooses one solution per waypoint, by one of two rules:

* ``optimal`` (default): ``pose_solutions`` finds every distinct solution of
  each pose within the joint ranges, then every 2 pi turn of a revolute joint
  that stays in range (duplicates up to 2 pi turns removed). For a 6R arm of a
  class with closed-form IK (``analytic_ik``: a spherical wrist, or three
  parallel axes) the solutions come from the closed form, each refined by
  Newton steps, so none is missed; otherwise from damped least squares from
  many random starts, without clipping. ``choose_branches``
  picks one per waypoint by dynamic programming over the sequence, minimising
  the sum of the transition costs: the slowest joint's rest-to-rest time
  (``limits.rest_to_rest_time``) between consecutive configurations. A
  waypoint with a hint has one candidate, the solution seeded by its hint (where
  that solve stalls, the pose's solution nearest the hint); one whose solutions
  have more than ``MAX_CANDIDATES`` turn variants is refused.
  With a start configuration (the robot's, before the task) the motion from it
  to the first waypoint counts too; without one, sequences of equal cost (a
  wrist flip moves the wrist joints by the same amounts) are told apart by the
  first configuration's distance to the middle of the joint ranges.
* ``continuous``: each solve is seeded from the previous solution (or the
  waypoint's hint), restarted from random configurations when it fails, and
  the solution nearest the previous configuration is kept (revolute joints
  whose range allows it are shifted by multiples of 2 pi towards it).

On a redundant arm (nv > 6) a pose has a continuum of solutions; each one found
numerically (without a hint) is moved along the self-motion to the centre of the
joint ranges (``centred``: Newton steps on the barrier
sum_j (q_j - lower_j)^-p + (upper_j - q_j)^-p restricted to the pose; for large p
its minimum approaches the largest smallest distance to a bound) so that it keeps
a margin to the bounds.

Either way each solution reports how many distinct solutions were found, which
was chosen, the joint-space jump from the previous waypoint, and its margin,
the smallest distance of a joint to a bound of its range.
"""

from __future__ import annotations

import logging
import math
import weakref
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import pinocchio as pin

from .analytic_ik import Solver, analytic_solver
from .errors import IKError, InputError
from .limits import FEASIBILITY_TOLERANCE, JointLimits, in_degrees_apart, rest_to_rest_time
from .read_only import ReadOnlyArrays, freeze_arrays
from .robot import Robot

log = logging.getLogger(__name__)

TOLERANCE = 1e-10
_DAMPING = 1e-3
_DAMPING_FLOOR = 1e-12
#: Singular values of the Jacobian below this fraction of the largest count as zero (``_centring_step``).
_SINGULAR = 1e-9
_MAX_ITERATIONS = 100
_ALTERNATIVES = 4
BRANCH_RULES = ("optimal", "continuous")
#: Random starts per pose when enumerating its solutions.
SOLUTION_STARTS = 48
#: Solutions closer than this [rad or m, largest joint difference, up to 2 pi turns] are one.
DISTINCT = 1e-5
#: At most this many distinct solutions per pose are kept (a redundant arm has infinitely many).
MAX_SOLUTIONS = 16
#: Most candidate configurations per waypoint (solutions times their 2 pi turns) the ``optimal`` rule
#: compares: its dynamic programme holds K x K x nq transition times (measured for 6 joints: 1024 take
#: 0.56 s and 0.5 GB per waypoint, 2048 took 3.3 s and 1.9 GB). A UR5's +-360 deg ranges give at most 512.
MAX_CANDIDATES = 1024
#: Weight [s/rad] of the distance to the middle of the ranges, which only separates equal costs.
_TIE_BREAK = 1e-4
#: Newton iterations refining a closed-form solution (it starts within rounding of the pose).
_REFINE_ITERATIONS = 4
#: Power p of the barrier sum (distance to a bound)^-p [rad] that centring minimises.
_BARRIER_POWER = 8
#: Newton steps on the barrier moving a redundant arm's solution to the centre of the ranges.
_CENTRING_STEPS = 80
#: Trust radius [rad] of the first centring step, its shrinking factor per step, the fraction of the way
#: to a bound a step may go, and the step length [rad] at which centring stops.
_CENTRING_STEP = 0.2
_SHRINK = 0.85
_TO_BOUND = 0.9
_CENTRED = 1e-10
#: Fraction of its range by which a joint on a bound is moved inside before centring.
_INSIDE = 1e-4
#: The closed-form solver of each model (None: the arm fits no closed-form class).
_SOLVERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class IKSolution(ReadOnlyArrays):
    """A configuration reaching a pose.

    Attributes:
        q: (nq,) joint positions [rad].
        position_error: |translation error| [m]; orientation_error: |rotation error| [rad].
        iterations: DLS iterations of the accepted solve; attempts: solves tried.
        jump: |q - q_previous| [rad] (0 for the first waypoint).
        solutions: distinct solutions found for the pose (up to 2 pi turns); chosen: which (0-based).
        margin_deg: the smallest distance of a joint to a bound of its range [deg], min_j
            min(q_j - lower_j, upper_j - q_j) (inf if no joint has a bound; negative outside a range).
    """

    q: np.ndarray
    position_error: float
    orientation_error: float
    iterations: int
    attempts: int = 1
    jump: float = 0.0
    solutions: int = 1
    chosen: int = 0
    margin_deg: float = math.inf

    def __post_init__(self):
        freeze_arrays(self)

    @property
    def residual(self) -> float:
        """The larger of the position error [m] and the orientation error [rad]."""
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
    return IKSolution(q, float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:])), iteration,
                      margin_deg=range_margin_deg(q, robot.limits))


def range_margin_deg(q: np.ndarray, limits: JointLimits) -> float:
    """The smallest distance [deg] of a joint of ``q`` [rad] to a bound of its range (inf without bounds)."""
    return float(np.rad2deg(np.min(np.minimum(q - limits.lower, limits.upper - q))))


def closed_form_solver(robot: Robot) -> Solver | None:
    """``analytic_ik.analytic_solver`` of ``robot``'s model, built once per model."""
    if robot.model not in _SOLVERS:
        _SOLVERS[robot.model] = analytic_solver(robot)
    return _SOLVERS[robot.model]


def _barrier(q: np.ndarray, lower: np.ndarray, upper: np.ndarray,
             bounded: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The gradient and diagonal Hessian of b(q) = sum_j (q_j - lower_j)^-p + (upper_j - q_j)^-p over the
    bounded joints (p = ``_BARRIER_POWER``; q inside the ranges); an unbounded joint gets 0 and 1/(2 pi)^2."""
    below, above = np.where(bounded, q - lower, 1.0), np.where(bounded, upper - q, 1.0)
    p = _BARRIER_POWER
    gradient = np.where(bounded, p * (above ** (-p - 1) - below ** (-p - 1)), 0.0)
    hessian = np.where(bounded, p * (p + 1) * (below ** (-p - 2) + above ** (-p - 2)), (2 * np.pi) ** -2)
    return gradient, hessian


def centred(robot: Robot, target: pin.SE3, solution: IKSolution, limits: JointLimits,
            accept: float = 1e-9) -> IKSolution:
    """``solution`` moved along the self-motion of a redundant arm towards the centre of the ranges.

    Minimises the barrier b (``_barrier``; for large p its minimum approaches the configuration whose
    smallest distance to a bound is largest) on the configurations reaching ``target``. With its
    gradient g, diagonal Hessian H, the pose error e and its Jacobian J (as in ``solve_pose``), each
    step is dq = c + m, the sum of

    * the correction c = J^+ e back onto the pose (damped least squares, as in ``solve_pose``), and
    * the self-motion m = N z in the null space N of J (SVD; singular directions, below
      ``_SINGULAR`` of the largest, count as null) minimising g^T dq + dq^T H dq / 2 over z:
      (N^T H N) z = -N^T (g + H c), shortened to a trust radius (``_CENTRING_STEP``, shrinking by
      ``_SHRINK`` per step in the second half of the ``_CENTRING_STEPS``, which damps the
      oscillation the curvature of the self-motion can cause),

    the sum then shortened to ``_TO_BOUND`` of the way to any bound. The correction is never cut by
    the trust radius: cut with the self-motion, the pose drifted away over large steps and the final
    Newton steps landed outside the ranges. (Solving the same problem through its multipliers,
    (J H^-1 J^T) lambda = e + J H^-1 g, fails near a bound: H grows like distance^-(p+2), 1e19 at
    one degree, and J H^-1 J^T is singular to working precision in the directions only such
    joints reach.) A joint on a bound first moves ``_INSIDE`` of its range inside. Newton steps
    (``solve_pose`` without clipping) then bring the residual to ``TOLERANCE``; the result is kept
    if it reaches the pose (``accept``), stays in the ranges and has a margin no smaller than before.
    """
    lower, upper = limits.lower, limits.upper
    bounded = np.isfinite(lower) & np.isfinite(upper)
    if not bounded.any() or not np.all((solution.q >= lower) & (solution.q <= upper)):
        return solution
    inset = np.where(bounded, _INSIDE * (upper - lower), 0.0)
    q = np.clip(solution.q, lower + inset, upper - inset)
    for iteration in range(_CENTRING_STEPS):
        offset = robot.forward_kinematics(q).actInv(target)
        error = pin.log6(offset).vector
        jacobian = pin.Jlog6(offset) @ robot.frame_jacobian(q)
        gradient, hessian = _barrier(q, lower, upper, bounded)
        correction, motion = _centring_step(jacobian, error, gradient, hessian)
        radius = _CENTRING_STEP * _SHRINK ** max(0, iteration - _CENTRING_STEPS // 2)
        step = correction + motion * min(1.0, radius / max(np.abs(motion).max(initial=0.0), 1e-300))
        room = np.where(step < 0, q - lower, upper - q) / np.maximum(np.abs(step), 1e-300)
        step = step * min(1.0, _TO_BOUND * room[bounded].min())
        q = pin.integrate(robot.model, q, step)
        if np.abs(step).max() < _CENTRED:
            break
    moved = solve_pose(robot, target, q, clip=False)
    if (moved.residual <= accept and np.all((moved.q >= lower) & (moved.q <= upper))
            and range_margin_deg(moved.q, limits) >= range_margin_deg(solution.q, limits)):
        return replace(moved, iterations=solution.iterations + moved.iterations)
    return solution


def _centring_step(jacobian: np.ndarray, error: np.ndarray, gradient: np.ndarray,
                   hessian: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``centred``'s correction c = J^+ e (damped) and self-motion m = N z, each (nv,) [rad]."""
    u, singular, vt = np.linalg.svd(jacobian)
    damping = _DAMPING * float(error @ error) + _DAMPING_FLOOR
    correction = vt[:len(singular)].T @ ((u.T @ error) * singular / (singular ** 2 + damping))
    null = vt[int(np.sum(singular > _SINGULAR * singular[0])):].T
    if null.shape[1] == 0:
        return correction, np.zeros_like(correction)
    reduced = null.T @ (hessian[:, None] * null)
    z = np.linalg.lstsq(reduced, -null.T @ (gradient + hessian * correction), rcond=None)[0]
    return correction, null @ z


def nearest_turn(robot: Robot, q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``q`` [rad] with each revolute joint shifted by the multiple of 2 pi that brings it nearest to
    ``reference`` within its range: |q_j + 2 pi k - r_j| is convex in k, so the in-range optimum is
    the unconstrained k = round((r_j - q_j) / 2 pi) clipped to the turns k_min..k_max that stay in
    range. A joint that no turn puts in range keeps its value."""
    lower, upper = robot.limits.lower, robot.limits.upper
    with np.errstate(invalid="ignore"):  # an unbounded side leaves its k unbounded (inf / 2 pi)
        fewest = np.ceil((lower - FEASIBILITY_TOLERANCE - q) / (2 * np.pi))
        most = np.floor((upper + FEASIBILITY_TOLERANCE - q) / (2 * np.pi))
    turns = np.clip(np.round((reference - q) / (2 * np.pi)), fewest, most)
    return np.where(robot.revolute & (fewest <= most), q + 2 * np.pi * turns, q)


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


def _turn_options(robot: Robot, q: np.ndarray, limits: JointLimits) -> list[np.ndarray]:
    """Per joint, the values of ``q_j`` up to 2 pi turns within its range (``turn_variants``); a value within
    ``FEASIBILITY_TOLERANCE`` of a bound is on it, as for via-points (a pose whose solution puts a joint at
    a documented 45 deg, 4e-10 rad past the URDF's 9-decimal bound, was not reached)."""
    lower, upper = limits.lower - FEASIBILITY_TOLERANCE, limits.upper + FEASIBILITY_TOLERANCE
    free = _turns_freely(robot, limits)
    options = []
    for j in range(robot.dof):
        if free[j]:
            values = np.array([_wrapped(robot, q)[j]])
        elif not robot.revolute[j]:
            values = np.array([q[j]] if lower[j] <= q[j] <= upper[j] else [])
        else:
            turns = np.arange(np.ceil((lower[j] - q[j]) / (2 * np.pi)), np.floor((upper[j] - q[j]) / (2 * np.pi)) + 1)
            values = q[j] + 2 * np.pi * turns
        values = np.clip(values, limits.lower[j], limits.upper[j])
        options.append(values)
    return options


def turn_variant_count(robot: Robot, q: np.ndarray, limits: JointLimits) -> int:
    """How many configurations ``turn_variants`` gives (the product of each joint's turns in range)."""
    return math.prod(len(values) for values in _turn_options(robot, q, limits))


def turn_variants(robot: Robot, q: np.ndarray, limits: JointLimits) -> np.ndarray:
    """(m, nq) every configuration equal to ``q`` up to 2 pi turns of revolute joints, within the
    ranges of ``limits`` (m = 0 if none is). A revolute joint without a finite range keeps its
    angle wrapped into [-pi, pi); the branch choice turns it the short way."""
    options = _turn_options(robot, q, limits)
    if not all(len(values) for values in options):
        return np.zeros((0, robot.dof))
    variants = np.zeros((1, 0))
    for values in options:  # the product, last joint fastest (numpy's meshgrid stops at 32 joints)
        variants = np.hstack((np.repeat(variants, len(values), axis=0), np.tile(values, len(variants))[:, None]))
    return variants


def _distinct(robot: Robot, q: np.ndarray, others: list[IKSolution]) -> bool:
    """Whether ``q`` differs from every one of ``others`` by more than ``DISTINCT``, up to 2 pi turns."""
    return all(np.max(np.abs(_wrapped(robot, q - other.q))) > DISTINCT for other in others)


def pose_solutions(robot: Robot, target: pin.SE3, limits: JointLimits, rng: np.random.Generator, *,
                   starts: int = SOLUTION_STARTS, accept: float = 1e-9,
                   closed_form: bool = True) -> tuple[list[IKSolution], IKSolution, int]:
    """The distinct solutions of one pose within the ranges of ``limits``, the best solve (for an error
    message when there is none: of those that reach the pose, the one least outside the ranges, else the
    lowest residual) and the solves used.

    With a closed-form solver (``closed_form_solver``; ``closed_form`` False: the numeric search
    regardless, for comparisons) these are its solutions, each refined
    by Newton steps (one solve). Otherwise, and where none of those reaches the pose within the ranges
    (at a singularity, where the closed form's solutions degenerate: a UR5 with its wrist or elbow
    straight), each of ``starts`` random starts is solved without clipping; a
    converged solution with no 2 pi turn inside the ranges is solved again with clipping from
    its clipped value, and on a redundant arm it is ``centred``. Solutions equal up to 2 pi
    turns (within ``DISTINCT``) are one; at most ``MAX_SOLUTIONS`` are kept.
    """
    solve = closed_form_solver(robot) if closed_form else None
    found: list[IKSolution] = []
    best: tuple | None = None
    used = 0
    if solve is not None:
        used = 1
        for seed in solve(target):
            best = _keep(robot, target, limits, accept, found, best,
                         solve_pose(robot, target, seed, clip=False, max_iterations=_REFINE_ITERATIONS), False)
            if len(found) == MAX_SOLUTIONS:
                break
    if not found:
        lower, upper = _finite_ranges(robot)
        for attempt in range(1, starts + 1):
            seed = lower + (upper - lower) * rng.random(robot.dof)
            best = _keep(robot, target, limits, accept, found, best, solve_pose(robot, target, seed, clip=False), True)
            used += 1
            if len(found) == MAX_SOLUTIONS:
                break
    assert best is not None  # at least one solve
    return found, best[1], used


def _keep(robot: Robot, target: pin.SE3, limits: JointLimits, accept: float, found: list[IKSolution],
          best: tuple | None, solution: IKSolution, numeric: bool) -> tuple:
    """``pose_solutions``' step for one solve: a ``numeric`` one that reaches the pose outside the ranges is
    solved again with clipping; one inside is ``centred`` on a redundant arm and added to ``found`` if
    distinct. Returns the better of ``best`` and this one, as (rank, solution)."""
    inside = solution.residual <= accept and turn_variant_count(robot, solution.q, limits) > 0
    if solution.residual <= accept and not inside and numeric:
        solution = solve_pose(robot, target, solution.q)
        inside = solution.residual <= accept and turn_variant_count(robot, solution.q, limits) > 0
    if inside and robot.model.nv > 6:
        solution = centred(robot, target, _widest_variant(robot, solution, limits), limits, accept)
    rank = (inside, solution.residual <= accept,
            -_range_excess(robot, solution.q, limits)[0] if solution.residual <= accept else 0.0,
            -solution.residual)
    if inside and _distinct(robot, solution.q, found):
        found.append(solution)
    return (rank, solution) if best is None or rank > best[0] else best


def _widest_variant(robot: Robot, solution: IKSolution, limits: JointLimits) -> IKSolution:
    """``solution`` turned (by 2 pi) into the ranges of ``limits``, with the widest margin of its variants."""
    # The margin is the smallest over the joints, so each joint's own widest turn gives the widest.
    lower, upper = limits.lower, limits.upper
    q = np.array([values[np.argmax(np.minimum(values - lower[j], upper[j] - values))]
                  for j, values in enumerate(_turn_options(robot, solution.q, limits))])
    return replace(solution, q=q, margin_deg=range_margin_deg(q, limits))


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
        robot: the robot: its joints' kinds, and the middle of its ranges to break ties without a start.
        limits: the limits that time each transition (``transition_costs``).
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
                    restarts: int = 30, accept: float = 1e-9, seed: int = 0,
                    progress: Callable[[int, int], None] | None = None,
                    rests: Callable[[np.ndarray], bool] | None = None) -> list[IKSolution]:
    """Joint configurations for a sequence of poses (module docstring for the two rules).

    Args:
        robot: the robot whose tool frame reaches the poses.
        poses: target tool poses.
        hints: optional configuration [rad] per waypoint: that waypoint's solution is the one its hint seeds.
        start: the robot's configuration before the task [rad] (``continuous``: the first seed;
            default: the middle of the ranges).
        branch: ``optimal`` or ``continuous``.
        limits: the limits the transition costs use (default: the robot's).
        restarts: random restarts per waypoint when a seeded solve fails (``continuous``).
        accept: largest residual (m and rad) accepted as reached.
        seed: seed of the random starts.
        progress: called as ``progress(done, total)`` after each waypoint solved.
        rests: whether the arm can rest at a configuration [rad] (its torque limits hold it against
            gravity): the ``optimal`` rule chooses the first and last waypoints' solutions among those
            it accepts, where there are any (the trajectory rests there whatever its timing).

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
    report = progress or (lambda done, total: None)
    if branch == "optimal":
        return _optimal_branches(robot, poses, hints, start, limits or robot.limits, rng, accept, report, rests)
    return _continuous_branch(robot, poses, hints, start, limits or robot.limits, rng, restarts, accept, report)


def _range_excess(robot: Robot, q: np.ndarray, limits: JointLimits) -> tuple[float, int, np.ndarray]:
    """How far [rad or m] configuration ``q`` is outside the ranges of ``limits`` (<= 0: inside), the
    joint furthest outside, and ``q`` with each revolute joint turned by 2 pi nearest its range's middle."""
    lower, upper = limits.lower, limits.upper
    finite = np.isfinite(lower) & np.isfinite(upper)
    middle = (np.where(finite, lower, 0.0) + np.where(finite, upper, 0.0)) / 2
    turned = np.where(robot.revolute, q + 2 * np.pi * np.round((middle - q) / (2 * np.pi)), q)
    excess = np.maximum(lower - turned, turned - upper)
    j = int(np.argmax(excess))
    return float(excess[j]), j, turned


def _unreached(robot: Robot, limits: JointLimits, index: int, attempts: int, best: IKSolution,
               accept: float) -> IKError:
    """The error for waypoint ``index`` without a solution in the ranges. Where the best solve reached
    the pose outside them, the joint furthest outside its range (in its nearest turn) is named."""
    said = f"waypoint {index}: pose not reached within the joint ranges after {attempts} attempt{'s' * (attempts > 1)}"
    if best.residual > accept:
        return IKError(f"{said}; best residual {best.position_error:.3g} m, "
                       f"{np.rad2deg(best.orientation_error):.3g} deg", waypoint=index, residual=best.residual)
    lower, upper = limits.lower, limits.upper
    _, j, q = _range_excess(robot, best.q, limits)
    below = q[j] < lower[j]
    value, bound = in_degrees_apart(q[j], lower[j] if below else upper[j], 0)
    side = "lower" if below else "upper"
    return IKError(f"{said}: the pose is reachable, but outside the ranges: the solution found nearest them puts "
                   f"joint "
                   f"{robot.joint_names[j]} at {value}, beyond its {side} limit {bound}", waypoint=index,
                   residual=best.residual)


def _check_candidate_count(robot: Robot, limits: JointLimits, index: int, found: list[IKSolution]) -> None:
    """Refuse a waypoint whose solutions have more variants by 2 pi turns than ``MAX_CANDIDATES``."""
    count = sum(turn_variant_count(robot, solution.q, limits) for solution in found)
    if count <= MAX_CANDIDATES:
        return
    spans = limits.upper - limits.lower
    wide = [f"{name} ({np.rad2deg(span):.6g} deg)" for name, span, revolute
            in zip(robot.joint_names, spans, robot.revolute) if revolute and span > 2 * np.pi]
    raise IKError(f"waypoint {index}: its {len(found)} IK solutions have {count} variants by 2 pi turns within the "
                  f"joint ranges, more than the optimal branch rule compares ({MAX_CANDIDATES}); joints whose range "
                  f"spans more than 360 deg: {', '.join(wide)}. Narrow those ranges (limits.position_deg) or choose "
                  f"ik.branch: continuous", waypoint=index)


def _optimal_branches(robot, poses, hints, start, limits, rng, accept, progress, rests) -> list[IKSolution]:
    """``solve_waypoints`` with the ``optimal`` rule."""
    per_pose, candidates, owners = [], [], []
    for index, (target, hint) in enumerate(zip(poses, hints)):
        if hint is not None:
            found, best, attempts = _hinted(robot, target, np.asarray(hint, dtype=float), limits, rng, accept, index)
        else:
            found, best, attempts = pose_solutions(robot, target, limits, rng, accept=accept)
        if not found:
            assert best is not None  # at least one attempt
            raise _unreached(robot, limits, index, attempts, best, accept)
        if hint is None:
            _check_candidate_count(robot, limits, index, found)
        variants = [s.q[None] if hint is not None else turn_variants(robot, s.q, limits) for s in found]
        if rests is not None and index in (0, len(poses) - 1):
            resting = [v[[rests(q) for q in v]] for v in variants]
            if any(len(v) for v in resting):  # else every one is kept: the timing names the limit
                variants = resting
        per_pose.append((found, attempts))
        candidates.append(np.concatenate(variants))
        owners.append(np.repeat(np.arange(len(found)), [len(v) for v in variants]))
        progress(index + 1, len(poses))
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
                                    attempts, jump, len(found), int(owner[k]), range_margin_deg(q, limits)))
        _log_choice("optimal", len(solutions) - 1, solutions[-1])
        previous = q
    return solutions


def _hinted(robot, target, hint, limits, rng, accept, index) -> tuple[list[IKSolution], IKSolution, int]:
    """The solution of pose ``target`` that ``hint`` (nq,) [rad] seeds, as ``pose_solutions`` returns
    solutions; where the solve from the hint misses the pose (it stalls at a singularity or a range
    bound on its way), the pose's solution (up to 2 pi turns within the ranges) nearest the hint."""
    best = solve_pose(robot, target, hint)
    if best.residual <= accept:
        return [best], best, 1
    every, searched, attempts = pose_solutions(robot, target, limits, rng, accept=accept)
    if not every:
        return [], min((best, searched), key=lambda s: s.residual), 1 + attempts
    q, nearest = min(((q, s) for s in every for q in turn_variants(robot, s.q, limits)),
                     key=lambda pair: float(np.linalg.norm(pair[0] - hint)))
    log.info("waypoint %d: the solve from its hint missed the pose (residual %.2g m, %.2g deg); the nearest of its "
             "%d solutions to the hint is taken, %.3g deg from it", index, best.position_error,
             np.rad2deg(best.orientation_error), len(every), np.rad2deg(np.linalg.norm(q - hint)))
    return [replace(nearest, q=q)], nearest, 1 + attempts


def resting_solutions(robot: Robot, target: pin.SE3, limits: JointLimits, rests: Callable[[np.ndarray], bool],
                      seed: int = 0) -> tuple[np.ndarray, int]:
    """Of the distinct solutions of pose ``target`` within the ranges of ``limits`` (``pose_solutions``),
    those (m, nq) [rad] at which ``rests(q)`` (the arm can rest there), each turned by 2 pi to its widest
    margin to the ranges, and how many solutions there are in all."""
    found, _, _ = pose_solutions(robot, target, limits, np.random.default_rng(seed))
    turned = [_widest_variant(robot, solution, limits).q for solution in found]
    return np.array([q for q in turned if rests(q)]).reshape(-1, robot.dof), len(found)


def described(robot: Robot, poses: list[pin.SE3], configurations: np.ndarray, limits: JointLimits,
              seed: int = 0) -> list[IKSolution]:
    """``IKSolution`` of configurations (n, nq) [rad] found otherwise (``cartesian_path.track_straight_lines``)
    for ``poses``, reported as the ``optimal`` rule reports its choice: the residuals, the jump from
    the previous configuration, and which of the pose's distinct solutions (``pose_solutions``) it
    is (one more where the search did not find it)."""
    rng = np.random.default_rng(seed)
    solutions, previous = [], None
    for index, (target, q) in enumerate(zip(poses, configurations)):
        found, _, attempts = pose_solutions(robot, target, limits, rng)
        which = next((i for i, s in enumerate(found) if not _distinct(robot, q, [s])), len(found))
        error = pose_error(robot, q, target)
        jump = float(np.linalg.norm(q - previous)) if previous is not None else 0.0
        solutions.append(IKSolution(q, float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:])), 0,
                                    attempts, jump, max(len(found), which + 1), which, range_margin_deg(q, limits)))
        _log_choice("tracked", index, solutions[-1])
        previous = q
    return solutions


def _log_choice(rule: str, index: int, solution: IKSolution) -> None:
    log.info("%s rule, waypoint %d: solution %d of %d (%d solve%s), jump %.3g deg, margin to the ranges %.3g deg, "
             "residual %.2g m, %.2g deg", rule, index, solution.chosen + 1, solution.solutions, solution.attempts,
             "s" * (solution.attempts > 1), np.rad2deg(solution.jump), solution.margin_deg,
             solution.position_error, np.rad2deg(solution.orientation_error))


def _continuous_branch(robot, poses, hints, start, limits, rng, restarts, accept, progress) -> list[IKSolution]:
    """``solve_waypoints`` with the ``continuous`` rule."""
    finite_lower, finite_upper = _finite_ranges(robot)
    previous = np.asarray(start, dtype=float) if start is not None else (finite_lower + finite_upper) / 2
    solutions = []
    for index, (target, hint) in enumerate(zip(poses, hints)):
        trial = np.asarray(hint, dtype=float) if hint is not None else previous
        found: list[IKSolution] = []
        best: IKSolution | None = None
        attempts = 0
        # A seeded solve that succeeds is kept; after a failure, restarts gather up to
        # _ALTERNATIVES solutions so the nearest can be chosen.
        while attempts == 0 or (len(found) < _ALTERNATIVES and attempts <= restarts):
            attempts += 1
            solution = solve_pose(robot, target, trial)
            if solution.residual > accept:
                log.debug("waypoint %d: solve %d missed the pose (residual %.2g m, %.2g deg); restarting from a "
                          "random configuration", index, attempts, solution.position_error,
                          np.rad2deg(solution.orientation_error))
            trial = finite_lower + (finite_upper - finite_lower) * rng.random(robot.dof)
            if best is None or solution.residual < best.residual:
                best = solution
            if solution.residual <= accept:
                found.append(centred(robot, target, solution, limits, accept)
                             if hint is None and robot.model.nv > 6 else solution)
                if attempts == 1:
                    break
        if not found:
            assert best is not None  # at least one attempt
            raise _unreached(robot, limits, index, attempts, best, accept)
        distinct = [s for i, s in enumerate(found) if _distinct(robot, s.q, found[:i])]
        chosen = min(distinct, key=lambda s: np.linalg.norm(nearest_turn(robot, s.q, previous) - previous))
        q = nearest_turn(robot, chosen.q, previous) if hint is None else chosen.q
        jump = float(np.linalg.norm(q - previous)) if index else 0.0
        which = next(i for i, s in enumerate(distinct) if s is chosen)
        solutions.append(IKSolution(q, chosen.position_error, chosen.orientation_error, chosen.iterations,
                                    attempts, jump, len(distinct), which, range_margin_deg(q, limits)))
        _log_choice("continuous", index, solutions[-1])
        previous = q
        progress(index + 1, len(poses))
    return solutions
