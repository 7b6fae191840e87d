"""Inverse kinematics: tool poses -> joint configurations on one continuous branch.

``solve_pose`` runs damped least squares on the SE3 error: with
e = log6(T(q)^-1 T_target) (local frame, linear part first) and
J_e = Jlog6(T(q)^-1 T_target) J_local(q), each step is

    dq = J_e^T (J_e J_e^T + lambda I)^-1 e,     lambda = lambda_0 |e|^2,

applied with ``pinocchio.integrate`` and clipped to the joint ranges. The
damping vanishes as the error does, so the last steps are Newton steps and
the error falls below 1e-9 (m and rad) in a few iterations.

``solve_waypoints`` seeds each solve from the previous solution (or the
waypoint's hint), restarts from random configurations when a solve fails,
keeps the solution nearest the previous configuration (revolute joints whose
range allows it are shifted by multiples of 2 pi towards it), and reports the
joint-space jump.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .errors import IKError, InputError
from .robot import Robot

TOLERANCE = 1e-10
_DAMPING = 1e-3
_MAX_ITERATIONS = 100
_ALTERNATIVES = 4


@dataclass(frozen=True)
class IKSolution:
    """A configuration reaching a pose.

    Attributes:
        q: (nq,) joint positions [rad].
        position_error: |translation error| [m]; orientation_error: |rotation error| [rad].
        iterations: DLS iterations of the accepted solve; attempts: solves tried (1 + restarts).
        jump: |q - q_previous| [rad] (0 for the first waypoint).
    """

    q: np.ndarray
    position_error: float
    orientation_error: float
    iterations: int
    attempts: int = 1
    jump: float = 0.0

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
               max_iterations: int = _MAX_ITERATIONS) -> IKSolution:
    """Damped least squares from ``seed``; returns the last iterate (check ``residual``)."""
    lower, upper = robot.limits.lower, robot.limits.upper
    q = np.clip(np.asarray(seed, dtype=float), lower, upper)
    for iteration in range(1, max_iterations + 1):
        current = robot.forward_kinematics(q)
        offset = current.actInv(target)
        error = pin.log6(offset).vector
        if max(np.linalg.norm(error[:3]), np.linalg.norm(error[3:])) <= tolerance:
            break
        jacobian = pin.Jlog6(offset) @ robot.frame_jacobian(q)
        damping = _DAMPING * float(error @ error)
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


def solve_waypoints(robot: Robot, poses: list[pin.SE3], *, hints: list[np.ndarray | None] | None = None,
                    start: np.ndarray | None = None, restarts: int = 30, accept: float = 1e-9,
                    seed: int = 0) -> list[IKSolution]:
    """Joint configurations for a sequence of poses, on one branch where possible.

    Args:
        poses: target tool poses.
        hints: optional configuration [rad] per waypoint, used as that solve's seed.
        start: seed of the first waypoint without a hint (default: mid-range configuration).
        restarts: random restarts per waypoint when the seeded solve fails.
        accept: largest residual (m and rad) accepted as reached.
        seed: seed of the restarts' random generator.

    Raises:
        IKError: a pose not reached within the joint ranges after every restart
            (naming the waypoint and the best residual).
    """
    hints = hints or [None] * len(poses)
    if len(hints) != len(poses):
        raise InputError(f"{len(hints)} hints for {len(poses)} waypoints")
    rng = np.random.default_rng(seed)
    lower, upper = robot.limits.lower, robot.limits.upper
    finite_lower = np.where(np.isfinite(lower), lower, -np.pi)
    finite_upper = np.where(np.isfinite(upper), upper, np.pi)
    previous = np.asarray(start, dtype=float) if start is not None else (finite_lower + finite_upper) / 2
    solutions = []
    for index, (target, hint) in enumerate(zip(poses, hints)):
        if hint is not None and np.shape(hint) != (robot.dof,):
            raise InputError(f"waypoint {index}: hint has {np.size(hint)} values, robot has {robot.dof} joints")
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
        chosen = min(found, key=lambda s: np.linalg.norm(_nearest_turn(robot, s.q, previous) - previous))
        q = _nearest_turn(robot, chosen.q, previous) if hint is None else chosen.q
        jump = float(np.linalg.norm(q - previous)) if index else 0.0
        solutions.append(IKSolution(q, chosen.position_error, chosen.orientation_error, chosen.iterations,
                                    attempts, jump))
        previous = q
    return solutions
