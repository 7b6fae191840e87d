"""Closed-form inverse kinematics of 6R arms, detected from the model's joint axes.

The geometry is read as screw axes, never from a robot's name: at q = 0 the
world-frame Jacobian column of revolute joint i is the twist (v_i, w_i) of a
unit rotation about the line with direction w_i through r_i = w_i x v_i (the
point of the line nearest the origin). With M = T(0), the tool pose at q = 0
(so the tool frame's fixed placement on the last link is included), the
forward kinematics is the product of exponentials

    T(q) = exp(xi_1 q_1) ... exp(xi_6 q_6) M,

and a target T gives g = T M^-1 = exp(xi_1 q_1) ... exp(xi_6 q_6). Two classes
reduce to the Paden-Kahan subproblems (``_rotation_angle``: one rotation taking
a point to another; ``_two_rotations``: two rotations about intersecting axes;
``_rotations_to_distance``: one rotation reaching a distance from a point):

* ``spherical wrist`` (PUMA 560 type): axes 1 and 2 meet at a point s, axes 4,
  5 and 6 meet at the wrist centre c. The wrist joints leave c fixed and joints
  1, 2 leave s fixed, so |exp(xi_3 q_3) c - s| = |g c - s| gives q_3 (two
  solutions), exp(xi_1 q_1) exp(xi_2 q_2) (exp(xi_3 q_3) c) = g c gives (q_1, q_2)
  (two), and with h = (e_1 e_2 e_3)^-1 g, a point p on axis 6 other than c gives
  (q_4, q_5) from exp(xi_4 q_4) exp(xi_5 q_5) p = h p (two) and q_6 from a point
  off axis 6 (one): up to 8 solutions.
* ``three parallel axes`` (UR type): axes 2, 3, 4 are parallel with direction u,
  axes 5 and 6 meet at a point c. Rotations about axes parallel to u keep the
  component along u, so (R_1(q_1) u) . (g c - r_1) = u . (c - r_1) gives q_1
  (two solutions, a cos q_1 + b sin q_1 = d); the same for directions,
  u . R_5(q_5) w_6 = (R_1 u) . R_g w_6 gives q_5 (two). With A = R_1^T R_g =
  Rot(u, q_2 + q_3 + q_4) R_5 R_6, u^T A = u^T R_5 R_6 gives q_6 and then the
  sum q_2 + q_3 + q_4; a point p on axis 4 gives q_3 from |exp(xi_3 q_3) p - r_2| =
  |h p - r_2| with h = e_1^-1 g e_6^-1 e_5^-1 (two) and q_2 from
  exp(xi_2 q_2) (exp(xi_3 q_3) p) = h p: up to 8 solutions.

Singular poses (a wrist or elbow stretched, a point on an axis) give repeated or
approximate solutions; the caller refines them with Newton steps and drops those
that do not converge. ``analytic_solver`` self-checks every solver it builds on
random configurations, so a wrongly detected arm falls back to None.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from .robot import Robot

#: Geometric tolerance [m or rad, relative to the arm's size] for intersecting and parallel axes.
_GEOMETRY = 1e-9
#: Largest forward-kinematics mismatch [m and rad] of a solution in the self-check.
SELF_CHECK_TOLERANCE = 1e-9
#: Random configurations (seeded) of the self-check.
_SELF_CHECKS = 8
_SELF_CHECK_SEED = 20240601
#: Most random configurations the self-check draws to find ``_SELF_CHECKS`` away from singularities.
_SELF_CHECK_DRAWS = 1000

Solver = Callable[[pin.SE3], np.ndarray]


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """3x3 rotation by ``angle`` [rad] about the unit vector ``axis`` (Rodrigues)."""
    return pin.exp3(axis * angle)


def _rotation_angle(axis: np.ndarray, u: np.ndarray, v: np.ndarray) -> float:
    """Subproblem 1: the angle [rad] of the rotation about ``axis`` taking vector ``u`` towards ``v``
    (their components normal to ``axis`` aligned): theta = atan2(w . (u' x v'), u' . v')."""
    u_normal, v_normal = u - axis * (axis @ u), v - axis * (axis @ v)
    return float(np.arctan2(axis @ np.cross(u_normal, v_normal), u_normal @ v_normal))


def _two_rotations(axis1: np.ndarray, axis2: np.ndarray, u: np.ndarray, v: np.ndarray) -> list[tuple[float, float]]:
    """Subproblem 2: the (theta_1, theta_2) with Rot(axis1, theta_1) Rot(axis2, theta_2) u = v, about axes
    through the origin that are not parallel: the intermediate vector z = Rot(axis2, theta_2) u =
    Rot(axis1, -theta_1) v = alpha w_1 + beta w_2 + gamma (w_1 x w_2) has w_1 . z = w_1 . v and
    w_2 . z = w_2 . u, and |z| = |u| gives gamma = +-sqrt(...). No solution when gamma^2 < 0 clearly
    (the target out of reach); |u| = |v| is assumed, not checked."""
    cosine = axis1 @ axis2
    normal = np.cross(axis1, axis2)
    alpha = (cosine * (axis2 @ u) - axis1 @ v) / (cosine**2 - 1)
    beta = (cosine * (axis1 @ v) - axis2 @ u) / (cosine**2 - 1)
    square = (u @ u - alpha**2 - beta**2 - 2 * alpha * beta * cosine) / (normal @ normal)
    if square < -_GEOMETRY * max(u @ u, 1.0):
        return []
    gamma = np.sqrt(max(square, 0.0))
    pairs = []
    for sign in (1.0, -1.0):
        z = alpha * axis1 + beta * axis2 + sign * gamma * normal
        pairs.append((_rotation_angle(axis1, z, v), _rotation_angle(axis2, u, z)))
    return pairs


def _rotations_to_distance(axis: np.ndarray, point: np.ndarray, p: np.ndarray, q: np.ndarray,
                           distance: float) -> list[float]:
    """Subproblem 3: the angles [rad] of the rotations about the line (``axis``, through ``point``) taking
    ``p`` to ``distance`` [m] from ``q``. In the plane normal to the axis, with u', v' the projections of
    p - point and q - point and delta'^2 = distance^2 - (w . (p - q))^2:
    theta = angle(u', v') +- arccos((|u'|^2 + |v'|^2 - delta'^2) / (2 |u'| |v'|))."""
    u, v = p - point, q - point
    u_normal, v_normal = u - axis * (axis @ u), v - axis * (axis @ v)
    planar = distance**2 - (axis @ (p - q)) ** 2
    lengths = np.linalg.norm(u_normal) * np.linalg.norm(v_normal)
    if lengths == 0.0:
        return []
    cosine = (u_normal @ u_normal + v_normal @ v_normal - planar) / (2 * lengths)
    if abs(cosine) > 1 + 1e-9:
        return []
    base = _rotation_angle(axis, u_normal, v_normal)
    spread = float(np.arccos(np.clip(cosine, -1.0, 1.0)))
    return [base + spread, base - spread]


class _Screws:
    """The joint axes of a chain at q = 0: unit directions ``w`` (n, 3) and points ``r`` (n, 3) [m]
    in the world frame, the tool pose ``home`` = T(0), ``size`` [m], the arm's size, and ``scale`` [m],
    that size but at least 1 m (the geometric tolerances' unit)."""

    def __init__(self, robot: Robot):
        model, data = robot.model, robot.model.createData()
        q0 = np.zeros(model.nq)
        twists = pin.computeJointJacobians(model, data, q0)  # WORLD frame: (v, w) of each joint
        self.w = twists[3:].T.copy()
        self.w /= np.linalg.norm(self.w, axis=1, keepdims=True)
        self.r = np.cross(self.w, twists[:3].T)
        self.home = robot.forward_kinematics(q0)
        #: The arm's size [m]: its axes' and tool's largest distance from the base along an axis.
        self.size = max(float(np.abs(self.r).max()), float(np.abs(self.home.translation).max()))
        self.scale = max(1.0, self.size)

    def motion(self, joint: int, angle: float) -> pin.SE3:
        """exp(xi_joint angle): the rigid motion of turning ``joint`` by ``angle`` [rad] about its line."""
        rotation = _rotation(self.w[joint], angle)
        return pin.SE3(rotation, self.r[joint] - rotation @ self.r[joint])

    def parallel(self, i: int, j: int) -> bool:
        return bool(np.linalg.norm(np.cross(self.w[i], self.w[j])) <= _GEOMETRY)

    def meeting_point(self, i: int, j: int) -> np.ndarray | None:
        """The point where non-parallel axes i and j meet, or None if they do not."""
        if self.parallel(i, j):
            return None
        # Closest points r_i + s w_i and r_j + t w_j: least squares on s w_i - t w_j = r_j - r_i.
        (s, t), *_ = np.linalg.lstsq(np.stack([self.w[i], -self.w[j]], axis=1), self.r[j] - self.r[i], rcond=None)
        a, b = self.r[i] + s * self.w[i], self.r[j] + t * self.w[j]
        return (a + b) / 2 if np.linalg.norm(a - b) <= _GEOMETRY * self.scale else None

    def on_axis(self, point: np.ndarray, joint: int) -> bool:
        offset = point - self.r[joint]
        return bool(np.linalg.norm(offset - self.w[joint] * (self.w[joint] @ offset)) <= _GEOMETRY * self.scale)


def _spherical_wrist_solver(screws: _Screws) -> Solver | None:
    """The solver of an arm whose axes 1, 2 meet and axes 4, 5, 6 meet (module docstring), or None."""
    shoulder, wrist = screws.meeting_point(0, 1), screws.meeting_point(3, 4)
    if shoulder is None or wrist is None or not screws.on_axis(wrist, 5) or screws.parallel(4, 5):
        return None
    w = screws.w
    # A point on axis 6 away from the wrist centre, and one off axis 6 (for q_6).
    on_six = wrist + w[5] * screws.scale
    off_six = wrist + np.cross(w[5], w[4]) / np.linalg.norm(np.cross(w[5], w[4])) * screws.scale

    def solve(target: pin.SE3) -> np.ndarray:
        g = target * screws.home.inverse()
        reached = g.act(wrist)
        solutions = []
        for q3 in _rotations_to_distance(w[2], screws.r[2], wrist, shoulder, float(np.linalg.norm(reached - shoulder))):
            elbow = screws.motion(2, q3).act(wrist)
            for q1, q2 in _two_rotations(w[0], w[1], elbow - shoulder, reached - shoulder):
                h = (screws.motion(0, q1) * screws.motion(1, q2) * screws.motion(2, q3)).inverse() * g
                for q4, q5 in _two_rotations(w[3], w[4], on_six - wrist, h.act(on_six) - wrist):
                    rest = (screws.motion(3, q4) * screws.motion(4, q5)).inverse() * h
                    q6 = _rotation_angle(w[5], off_six - wrist, rest.act(off_six) - wrist)
                    solutions.append([q1, q2, q3, q4, q5, q6])
        return np.array(solutions).reshape(-1, 6)
    return solve


def _angles_solving(a: float, b: float, d: float) -> list[float]:
    """The angles x [rad] with a cos x + b sin x = d (none, or two that may coincide)."""
    radius = np.hypot(a, b)
    if radius == 0.0 or abs(d) > radius * (1 + 1e-9):
        return []
    base, spread = np.arctan2(b, a), float(np.arccos(np.clip(d / radius, -1.0, 1.0)))
    return [base + spread, base - spread]


def _cosine_sine_terms(axis: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[float, float, float]:
    """(a, b, c) with u . Rot(axis, x) v = a cos x + b sin x + c (Rodrigues)."""
    along = axis @ v
    return float(u @ (v - axis * along)), float(u @ np.cross(axis, v)), float((u @ axis) * along)


def _parallel_axes_solver(screws: _Screws) -> Solver | None:
    """The solver of an arm whose axes 2, 3, 4 are parallel and axes 5, 6 meet (module docstring), or None."""
    centre = screws.meeting_point(4, 5)
    if centre is None or not (screws.parallel(1, 2) and screws.parallel(1, 3)) or screws.parallel(0, 1):
        return None
    w, r = screws.w, screws.r
    u = w[1]
    height = u @ (centre - r[0])  # the component along u that joints 2-6 keep
    # A point on axis 4, and a vector normal to u (turned by the sum q_2 + q_3 + q_4 only).
    on_four = r[3]
    normal = np.cross(u, w[0]) / np.linalg.norm(np.cross(u, w[0]))
    turns = [1.0 if u @ w[j] > 0 else -1.0 for j in (1, 2, 3)]  # axes 3, 4 may point against axis 2

    def solve(target: pin.SE3) -> np.ndarray:
        g = target * screws.home.inverse()
        reached = g.act(centre) - r[0]
        solutions = []
        a1, b1, c1 = _cosine_sine_terms(w[0], reached, u)  # (R_1 u) . reached = u . R_1^T reached
        for q1 in _angles_solving(a1, b1, height - c1):
            rotation1 = _rotation(w[0], q1)
            a5, b5, c5 = _cosine_sine_terms(w[4], u, w[5])
            for q5 in _angles_solving(a5, b5, (rotation1 @ u) @ g.rotation @ w[5] - c5):
                rotation5 = _rotation(w[4], q5)
                across = rotation1.T @ g.rotation  # Rot(u, q2 + q3 + q4) R_5 R_6
                q6 = _rotation_angle(w[5], across.T @ u, rotation5.T @ u)
                elbow_sum = _rotation_angle(u, normal, across @ _rotation(w[5], q6).T @ rotation5.T @ normal)
                h = screws.motion(0, q1).inverse() * g * screws.motion(5, q6).inverse() * screws.motion(4, q5).inverse()
                goal = h.act(on_four)
                for q3 in _rotations_to_distance(w[2], r[2], on_four, r[1], float(np.linalg.norm(goal - r[1]))):
                    q2 = _rotation_angle(w[1], screws.motion(2, q3).act(on_four) - r[1], goal - r[1])
                    # Rot(u, elbow_sum) = Rot(w_2, q2) Rot(w_3, q3) Rot(w_4, q4) with w_j = turns[j] u.
                    q4 = turns[2] * (elbow_sum - turns[0] * q2 - turns[1] * q3)
                    solutions.append([q1, q2, q3, q4, q5, q6])
        return np.array(solutions).reshape(-1, 6)
    return solve


def _wrapped(q: np.ndarray) -> np.ndarray:
    return (q + np.pi) % (2 * np.pi) - np.pi


def _self_check(robot: Robot, solve: Solver, size: float) -> bool:
    """Whether, on seeded random configurations away from singularities, the solutions of each one's pose
    include it (up to 2 pi turns) and all reach that pose to ``SELF_CHECK_TOLERANCE``. Away from
    singularities: the Jacobian's smallest singular value at least 1e-2, its linear rows in units of the
    arm's ``size`` [m] where that is below 1 m. False if ``_SELF_CHECK_DRAWS`` draws do not find
    ``_SELF_CHECKS`` such configurations (a chain singular everywhere: zero-length links, an axis
    repeated; the numeric search handles it)."""
    rng = np.random.default_rng(_SELF_CHECK_SEED)
    unit = np.array([1 / min(1.0, size)] * 3 + [1.0] * 3)[:, None] if size > 0 else np.ones((6, 1))
    checked = 0
    for _ in range(_SELF_CHECK_DRAWS):
        if checked == _SELF_CHECKS:
            break
        q = rng.uniform(-np.pi, np.pi, 6)
        if np.linalg.svd(unit * robot.frame_jacobian(q), compute_uv=False)[-1] < 1e-2:
            continue
        checked += 1
        target = robot.forward_kinematics(q)
        solutions = solve(target)
        if not len(solutions) or np.min(np.abs(_wrapped(solutions - q)).max(axis=1)) > 1e-6:
            return False
        for solution in solutions:
            error = pin.log6(robot.forward_kinematics(solution).actInv(target)).vector
            if max(np.linalg.norm(error[:3]), np.linalg.norm(error[3:])) > SELF_CHECK_TOLERANCE:
                return False
    return checked == _SELF_CHECKS


def analytic_solver(robot: Robot) -> Solver | None:
    """A closed-form solver of ``robot``'s tool poses, or None if the arm fits no class or fails the self-check.

    The solver maps a target pose to every solution it finds, an (K, 6) array [rad] (K <= 8, angles in
    [-pi, pi), before any range filtering; near singularities they are approximate and may repeat).
    """
    if robot.model.nq != 6 or robot.model.nv != 6 or not robot.revolute.all():
        return None
    screws = _Screws(robot)
    for build in (_spherical_wrist_solver, _parallel_axes_solver):
        solve = build(screws)
        if solve is not None:
            wrapped = _wrapped_solver(solve)
            if _self_check(robot, wrapped, screws.size):
                return wrapped
    return None


def _wrapped_solver(solve: Solver) -> Solver:
    """``solve`` with its angles wrapped into [-pi, pi)."""
    return lambda target: _wrapped(solve(target))
