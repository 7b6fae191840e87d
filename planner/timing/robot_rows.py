"""Joint torques and the tool's speed as constraints of the timing NLP (``nlp.py``).

Neither is a polynomial of the NLP's variables: torque is Pinocchio's RNEA,
tau(q, q', q'') = M(q) q'' + c(q, q') + g(q), and the tool's linear and angular
speeds are |J_v(q) q'| and |J_w(q) q'|. Each round of the NLP (``TimingNLP.solve``) therefore uses a model
frozen at the previous round's trajectory, at ``SAMPLES_PER_SEGMENT`` points
s = m / SAMPLES_PER_SEGMENT (m = 0 .. SAMPLES_PER_SEGMENT - 1) of every segment,
at positions, velocities and accelerations (q0, v0, a0) there:

    tau ~ M(q0) q'' + sum_a q'_a C_a(q0) q' + g(q0) + dtau/dq (q - q0),
    v   ~ J_v(q0) q' + dv/dq (q - q0),   |v|^2 <= V^2,
    w   ~ J_w(q0) q' + dw/dq (q - q0),   |w|^2 <= W^2,

with q, q', q'' the spline's at the same point (expressions of the durations
and knot states), C_a = C(q0, e_a) Pinocchio's Coriolis matrix for the unit
velocity of joint a (c(q, q') = C(q, q') q' is linear in q' through C, so
quadratic in q'), dtau/dq from ``computeRNEADerivatives`` and dv/dq, dw/dq from
``getFrameVelocityDerivatives`` (the tool's twist in its LOCAL frame), all exact, at (q0, v0, a0). The model is
exact in q' and q'' at the frozen positions (a duration change scales q' and
q'' but keeps positions, so the first round already sees the right slow-down)
and first-order in q. At a trajectory equal to the one it was frozen at, the
model and its derivatives equal the true torque and speed and theirs: where the
rounds settle, the NLP's optimality conditions are those of the true problem.
Rounds stop once the model agrees with the true values at the solved
trajectory to ``MODEL_TOLERANCE`` of the limits (the gap shrinks about
twofold per round late on; the dense check below closes what is left).

A family whose via-point states are the NLP's own (``hermite7``) can move the
positions at the samples by radians in one round, far beyond where a
first-order model holds, and the rounds then need not settle (a UR5 task with a
0.25 m/s tool cap: off by 0.5 to 2.6 of the cap in every one of 12 rounds). Its
rounds therefore get a trust region in position once the model fails to settle:
|q(s_m) - q0(s_m)| <= r at every sample, r half the last round's largest move
wherever the model ended more than ``nlp.TRUST_SHRINK_GAP`` off and not half as
far off as the round before, and doubled where the model held well
(``nlp.TimingNLP.solve``). Where the rounds settle without it (the PUMA paper
task with torque binding: moves of 3 rad, then 0.04 rad, the model within 1e-5),
it never starts.

The rows: one CasADi function of a single sample point (``point_rows``, in
scalar form), mapped over all of them, with the frozen model's numbers as the
NLP's parameters (``parameters``), so a new round changes numbers, not the
program; IPOPT gets their Jacobian and Hessian from the point's own symbolic
ones, mapped likewise (``point_derivatives``). The samples' q, q', q'' are
variables of the NLP of their own, each held equal to the spline's there by an
equality row (``nlp._Program``): the rows then depend on them alone, and the
chain from the durations and knot states to the samples is differentiated once,
in those equalities, rather than through every row. On
``scripts/bench_robot_limits.py`` (median of 3, 2026-12-07, against
the same code without them): PUMA with torque binding 1.23 -> 0.88 s, with the
0.25 m/s and 30 deg/s tool caps 1.60 -> 1.39 s and 1.50 -> 1.44 s, UR5 with torque
binding 1.12 -> 1.01 s; every total the same; ``hermite7``'s cases 1.3 to 1.9
times faster. Their equalities' multipliers start at zero in a later round's
program (``carried``): they carry the robot rows' gradients of the model the
round refits, and carried over they took a UR5 round with a tool cap to IPOPT's
iteration cap.

Eight samples per segment, where the segment's q'' (a polynomial of low
degree) makes torque and speed smooth. After the solve the trajectory is
checked densely (``dynamics.meet_robot_limits``, 1 kHz) and slowed down
uniformly by what the samples missed: on the bundled tasks nothing (UR5,
torque), 0.2 % (UR5, 0.25 m/s tool speed) and 2 % (PUMA paper task, 0.25 m/s,
segments of several seconds); above ``pipeline.RETIMED_SLOW_DOWN`` the NLP times
it once more with these limits tightened by that slow-down. The kinematic limits
stay exact; these stay sampled.

Arms whose configuration has more coordinates than velocities (continuous
joints as cos/sin pairs) are not modelled here: ``supported`` says so, and the
planner then only slows the kinematic optimum down.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..dynamics import joint_torques, tool_twists
from ..read_only import ReadOnlyArrays, freeze_arrays
from ..robot import Robot
from ..splines import segment_values

#: Torque and tool-speed samples per segment in the NLP (module docstring).
SAMPLES_PER_SEGMENT = 8
#: Rounds stop when the frozen model is within this fraction of each limit of the true values.
MODEL_TOLERANCE = 1e-3


@dataclass(frozen=True)
class RobotConstraints(ReadOnlyArrays):
    """The robot-aware limits the NLP imposes.

    Attributes:
        robot: the robot (its Pinocchio model, its tool frame).
        torque: (J,) torque limits [N m], or None.
        tool_speed: the tool frame's largest linear speed [m/s], or None.
        tool_angular_speed: its largest angular speed [rad/s], or None.
    """

    robot: Robot
    torque: np.ndarray | None
    tool_speed: float | None
    tool_angular_speed: float | None = None

    def __post_init__(self):
        freeze_arrays(self)

    @property
    def supported(self) -> bool:
        """Whether the NLP can model this robot (one coordinate per velocity) and a limit is given."""
        return self.robot.model.nq == self.robot.model.nv and (
            self.torque is not None or bool(self.speed_limits))

    @property
    def speed_limits(self) -> list[tuple[slice, float]]:
        """The tool speeds limited: (rows of the tool's twist (linear 0:3, angular 3:6), limit [m/s or rad/s])."""
        given = ((slice(0, 3), self.tool_speed), (slice(3, 6), self.tool_angular_speed))
        return [(rows, float(limit)) for rows, limit in given if limit is not None]

    @property
    def speed_parts(self) -> list[tuple[slice, float]]:
        """Each speed limit's three rows among ``twist_rows`` (in their order) and its limit."""
        return [(slice(3 * k, 3 * k + 3), limit) for k, (_, limit) in enumerate(self.speed_limits)]

    @property
    def twist_rows(self) -> np.ndarray:
        """The rows of the tool's twist (linear 0..2, angular 3..5) the speed limits use, in their order."""
        return np.concatenate([np.arange(6)[rows] for rows, _ in self.speed_limits]) if self.speed_limits \
            else np.zeros(0, dtype=int)


@dataclass(frozen=True)
class FrozenModel(ReadOnlyArrays):
    """The model of the module docstring at P sample points (arrays over the points first).

    Attributes:
        q: (P, J) positions [rad] it was frozen at.
        mass: (P, J, J) M(q0); coriolis: (P, J, J, J) C_a(q0) indexed [point, a, row, column].
        torque_offset: (P, J) g(q0) - dtau/dq q0 [N m]; torque_position: (P, J, J) dtau/dq.
        speed_velocity: (P, K, J) the rows ``RobotConstraints.twist_rows`` (K = 3 or 6) of the
            tool's Jacobian at q0; speed_position: (P, K, J) their derivatives in q;
            speed_offset: (P, K) -speed_position q0 [m/s, rad/s]. None without a tool-speed limit.
    """

    q: np.ndarray
    mass: np.ndarray | None
    coriolis: np.ndarray | None
    torque_offset: np.ndarray | None
    torque_position: np.ndarray | None
    speed_velocity: np.ndarray | None
    speed_position: np.ndarray | None
    speed_offset: np.ndarray | None

    def __post_init__(self):
        freeze_arrays(self)


def sample_points(segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(segment, s) of every sample of ``segments`` (K,), segment-major: (K * SAMPLES_PER_SEGMENT,) each."""
    s = np.arange(SAMPLES_PER_SEGMENT) / SAMPLES_PER_SEGMENT
    return np.repeat(segments, SAMPLES_PER_SEGMENT), np.tile(s, len(segments))


def spline_states(coefficients: np.ndarray, durations: np.ndarray, segments: np.ndarray,
                  s: np.ndarray, basis: str = "power") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(P, J) q, q', q'' of a spline (coefficients (S, J, C) in local time of the ``basis``, durations (S,)
    [s]) at normalised time ``s`` of ``segments`` (P,)."""
    h = durations[segments]
    q, qd, qdd = (segment_values(coefficients[segments], h, s * h, order, basis) for order in range(3))
    return q, qd, qdd


def freeze(constraints: RobotConstraints, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> FrozenModel:
    """The model (module docstring) at P points: positions (P, J) [rad], velocities, accelerations."""
    robot = constraints.robot
    model, data = robot.model, robot.model.createData()
    points, joints = q.shape
    mass = coriolis = torque_offset = torque_position = None
    speed_velocity = speed_position = speed_offset = None
    if constraints.torque is not None:
        mass, coriolis = np.zeros((points, joints, joints)), np.zeros((points, joints, joints, joints))
        torque_offset, torque_position = np.zeros((points, joints)), np.zeros((points, joints, joints))
        unit = np.eye(joints)
        for p in range(points):
            dq, _, dqdd = (np.reshape(d, (joints, joints)) for d in
                           pin.computeRNEADerivatives(model, data, q[p], qd[p], qdd[p]))
            mass[p] = np.triu(dqdd) + np.triu(dqdd, 1).T  # Pinocchio fills the upper triangle
            torque_position[p] = dq
            torque_offset[p] = pin.computeGeneralizedGravity(model, data, q[p]) - dq @ q[p]
            for a in range(joints):
                coriolis[p, a] = np.reshape(pin.computeCoriolisMatrix(model, data, q[p], unit[a]), (joints, joints))
    if constraints.speed_limits:
        rows = constraints.twist_rows
        speed_velocity, speed_position = np.zeros((points, len(rows), joints)), np.zeros((points, len(rows), joints))
        frame, local = robot.tool_frame_id, pin.ReferenceFrame.LOCAL
        for p in range(points):
            pin.computeForwardKinematicsDerivatives(model, data, q[p], qd[p], qdd[p])
            dv_dq, dv_dv = pin.getFrameVelocityDerivatives(model, data, frame, local)
            # (one joint: the binding returns (6,) vectors, not (6, 1) matrices)
            speed_position[p], speed_velocity[p] = (np.reshape(d, (6, joints))[rows] for d in (dv_dq, dv_dv))
        speed_offset = -np.einsum("pij,pj->pi", speed_position, q)
    return FrozenModel(q, mass, coriolis, torque_offset, torque_position, speed_velocity, speed_position,
                       speed_offset)


def modelled(frozen: FrozenModel, q: np.ndarray, qd: np.ndarray,
             qdd: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The model's torques (P, J) [N m] and tool twists (P, K) (the rows ``twist_rows``) [m/s, rad/s] at
    (P, J) q, q', q'' (numeric)."""
    torque = velocity = None
    if frozen.mass is not None:
        assert frozen.coriolis is not None and frozen.torque_position is not None
        torque = (np.einsum("pij,pj->pi", frozen.mass, qdd) + np.einsum("pa,paib,pb->pi", qd, frozen.coriolis, qd)
                  + frozen.torque_offset + np.einsum("pij,pj->pi", frozen.torque_position, q))
    if frozen.speed_velocity is not None:
        assert frozen.speed_position is not None
        velocity = (np.einsum("pij,pj->pi", frozen.speed_velocity, qd) + frozen.speed_offset
                    + np.einsum("pij,pj->pi", frozen.speed_position, q))
    return torque, velocity


def true_values(constraints: RobotConstraints, q: np.ndarray, qd: np.ndarray,
                qdd: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """RNEA torques (P, J) [N m] (``dynamics.joint_torques``) and the rows ``twist_rows`` (P, K) of the
    tool's twist [m/s, rad/s] in its LOCAL frame, as the model has them (``dynamics.tool_twists``), at
    (P, J) q, q', q''."""
    robot = constraints.robot
    torque = joint_torques(robot, q, qd, qdd) if constraints.torque is not None else None
    rows = constraints.twist_rows
    velocity = tool_twists(robot, q, qd)[:, rows] if constraints.speed_limits else None
    return torque, velocity


def model_error(constraints: RobotConstraints, frozen: FrozenModel, q: np.ndarray, qd: np.ndarray,
                qdd: np.ndarray) -> float:
    """The largest gap between model and truth at (P, J) q, q', q'', as a fraction of the limit."""
    model_torque, model_velocity = modelled(frozen, q, qd, qdd)
    torque, velocity = true_values(constraints, q, qd, qdd)
    gap = 0.0
    if torque is not None and model_torque is not None and constraints.torque is not None:
        gap = max(gap, float(np.max(np.abs(torque - model_torque) / constraints.torque)))
    if velocity is not None and model_velocity is not None:
        for part, limit in constraints.speed_parts:
            gap = max(gap, float(np.max(np.linalg.norm(velocity[:, part] - model_velocity[:, part], axis=1))) / limit)
    return gap


def parameters(frozen: FrozenModel) -> np.ndarray:
    """(K, P) the model's numbers at each of its P points, one column per point, in the order
    ``point_rows`` reads them: mass, Coriolis, torque offset and position terms, then the tool's."""
    columns = [frozen.mass, frozen.coriolis, frozen.torque_offset, frozen.torque_position,
               frozen.speed_velocity, frozen.speed_position, frozen.speed_offset]
    points = frozen.q.shape[0]
    return np.vstack([value.reshape(points, -1).T for value in columns if value is not None])


def point_rows(ca, constraints: RobotConstraints, joints: int):
    """A CasADi function (q, q', q'', model) -> rows of one sample point, each to lie in ``row_bounds``:
    tau_j / L_j, then |v|^2 / V^2 and |w|^2 / W^2 for the speeds limited (module docstring; ``model``
    is a column of ``parameters``). Built once in scalar form, it is mapped over the points
    (``Function.map``).

    ``model`` is declared not differentiable: the NLP differentiates in q, q', q'' only, and CasADi
    otherwise builds and evaluates every derivative of the map in the model's numbers as well (294 per
    point with torque limits on six joints). On the PUMA paper task with torque binding
    (``scripts/bench_robot_limits.py``): a program's build 0.48 -> 0.11 s, the Hessian's and
    Jacobian's evaluations over its 67 IPOPT iterations 1.96 -> 0.59 s, the robot-limit stage
    3.3 -> 1.2 s."""
    q, qd, qdd = (ca.SX.sym(name, joints) for name in ("q", "qd", "qdd"))
    sizes = []
    if constraints.torque is not None:
        sizes += [joints * joints, joints ** 3, joints, joints * joints]
    twist = len(constraints.twist_rows)
    if twist:
        sizes += [twist * joints, twist * joints, twist]
    model = ca.SX.sym("model", sum(sizes))
    parts = ca.vertsplit(model, np.cumsum([0, *sizes]).tolist())
    found = []
    if constraints.torque is not None:
        mass, coriolis, offset, position = parts[:4]
        mass, position = ca.reshape(mass, joints, joints).T, ca.reshape(position, joints, joints).T
        tau = mass @ qdd + offset + position @ q
        for a in range(joints):  # C_a, stored row-major at [a * J * J, (a + 1) * J * J)
            tau += qd[a] * (ca.reshape(coriolis[a * joints * joints:(a + 1) * joints * joints], joints, joints).T @ qd)
        found.append(tau / ca.DM(np.asarray(constraints.torque, dtype=float)))
        parts = parts[4:]
    if twist:
        jacobian, position, offset = parts
        velocity = ca.reshape(jacobian, joints, twist).T @ qd + ca.reshape(position, joints, twist).T @ q + offset
        for part, limit in constraints.speed_parts:
            found.append(ca.sumsqr(velocity[part]) / limit ** 2)
    return ca.Function("robot_rows", [q, qd, qdd, model], [ca.vertcat(*found)],
                       {"is_diff_in": [True, True, True, False]})


def point_derivatives(ca, function) -> tuple:
    """``point_rows``' ``function`` differentiated in scalar form, once: (Jacobian, Hessian), CasADi functions
    of one sample point, (q, q', q'', model) -> the rows' Jacobian in x = (q, q', q'') (rows x 3J) and
    (q, q', q'', model, multipliers) -> the upper triangle of sum_r lambda_r d^2 row_r / dx^2 (3J x 3J),
    each with its own sparsity (torque is linear in q and q'', so its Hessian has the q' block alone).

    The NLP maps them over the samples and places their entries itself (``nlp._robot_derivative_functions``):
    CasADi's AD of the mapped rows ran one directional derivative of the map per colour of the whole
    constraint Jacobian (21 on the PUMA paper task), far more arithmetic than the rows' own symbolic
    Jacobian (1380 operations a point). On the PUMA paper task with torque binding (72 samples;
    ``scripts/bench_robot_limits.py``), an evaluation of the program's constraint Jacobian took 3.0 ->
    0.54 ms and of its Lagrangian Hessian 2.1 -> 0.25 ms, IPOPT's time in them over the robot rounds
    212 -> 69 ms, and planning 0.88 -> 0.67 s."""
    inputs = function.sx_in()
    rows = function(*inputs)
    state = ca.vertcat(*inputs[:3])
    multipliers = ca.SX.sym("multipliers", rows.shape[0])
    hessian = ca.triu(ca.hessian(ca.dot(multipliers, rows), state)[0])
    return (ca.Function("robot_rows_jacobian", inputs, [ca.jacobian(rows, state)]),
            ca.Function("robot_rows_hessian", [*inputs, multipliers], [hessian]))


def row_bounds(constraints: RobotConstraints, joints: int) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) of ``point_rows``' rows."""
    lower, upper = [], []
    if constraints.torque is not None:
        lower += [-1.0] * joints
        upper += [1.0] * joints
    lower += [-np.inf] * len(constraints.speed_limits)
    upper += [1.0] * len(constraints.speed_limits)
    return np.array(lower), np.array(upper)
