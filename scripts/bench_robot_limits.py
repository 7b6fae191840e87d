"""Benchmark: torque and tool-speed limits (``planner.dynamics``) on the bundled robot tasks.

For the UR5 pick-and-place and the PUMA paper Cartesian task, it plans each case in-process (median
wall time of ``--repeats`` runs after a warm-up):

* ``kinematic``: the task's own limits;
* ``torque urdf`` and ``torque halved``: ``limits.torque_nm`` the URDF's efforts, and half of them;
* ``tool 0.25 m/s``: ``limits.tool_speed_m_s: 0.25``; ``tool 30 deg/s``: ``limits.tool_speed_deg_s: 30``;
* ``binding``: acceleration and jerk limits 10 times the task's (or the robot's), and per joint a
  torque limit ``BINDING_SHARE`` of the way from the largest gravity torque on the path to the
  largest torque the plan reaches under those limits alone (both by RNEA at 1 kHz; the effort where
  the two differ by less than 1e-3 of it), so that torque rather than the kinematic limits decides on
  every task, and holding still stays possible (a fixed
  0.4 of the efforts bound the UR5 but left the PUMA at 0.51 of them; with the efforts halved the
  UR5's torques stay within 92 % of them).

For each it reports the total time, the slow-down, the total time of slowing the kinematic optimum
down uniformly instead (where the NLP timed the case again), the planning wall time, and an
independent dense check of the result: Pinocchio's RNEA at 1 kHz on a grid offset by half a period
from the planner's own samples (the largest torque ratio over joints), and the tool's linear and
angular speeds there by central differences of forward kinematics (positions, and the rotation
between poses through SO(3)'s log). With ``--toppra`` (``pip install .[bench]``) it also
time-parametrizes the same geometric path (a cubic spline through the planned trajectory's
positions at 200 Hz, in s = t / T) under the same velocity, acceleration and torque limits, and
gives TOPP-RA's duration and wall time beside the planner's (no jerk limit there).

``--family NAME`` plans every case with that spline family instead of the task's own (``hybrid``).

    python scripts/bench_robot_limits.py [--repeats 3] [--toppra] [--family hermite7]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml

from planner import plan

ROOT = Path(__file__).resolve().parents[1]
#: Where the ``binding`` case's torque limits lie between gravity's torques and those of the plan without them.
BINDING_SHARE = 0.8
TASKS = {"ur5 pick-and-place": ROOT / "scripts" / "tasks" / "ur5_pick_and_place.yaml",
         "puma paper": ROOT / "scripts" / "tasks" / "puma560_paper_cartesian.yaml"}


def cases(document: dict, kinematic) -> dict[str, dict]:
    """The task document of each case (module docstring); ``kinematic``: the plan of the task as it is."""
    def with_limits(**limits) -> dict:
        changed = yaml.safe_load(yaml.safe_dump(document))
        changed.setdefault("limits", {}).update(limits)
        return changed
    efforts = np.asarray(kinematic.robot.model.effortLimit, dtype=float)
    faster = {"acceleration_deg_s2": np.rad2deg(10 * kinematic.limits.acceleration).tolist(),
              "jerk_deg_s3": np.rad2deg(10 * kinematic.limits.jerk).tolist()}
    gravity, reached = torque_peaks(plan(with_limits(**faster)))
    dynamic = reached - gravity > 1e-3 * efforts  # a joint whose torque barely moves keeps its effort
    binding = np.where(dynamic, gravity + BINDING_SHARE * (reached - gravity), efforts)
    return {"kinematic": with_limits(), "torque urdf": with_limits(torque_nm="urdf"),
            "torque halved": with_limits(torque_nm=(efforts / 2).tolist()),
            "tool 0.25 m/s": with_limits(tool_speed_m_s=0.25), "tool 30 deg/s": with_limits(tool_speed_deg_s=30),
            f"binding ({(binding / efforts)[dynamic].min():.2f}-{(binding / efforts)[dynamic].max():.2f} x efforts)":
                with_limits(torque_nm=binding.tolist(), **faster)}


def torque_peaks(result) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, the largest |gravity torque| on the planned path and the largest |torque| [N m], by
    RNEA at 1 kHz."""
    robot, trajectory = result.robot, result.trajectory
    times = np.arange(0.0, trajectory.total_time, 0.001)
    q, qd, qdd = (trajectory.evaluate(times, order) for order in range(3))
    data = robot.model.createData()
    gravity = np.array([pin.computeGeneralizedGravity(robot.model, data, a) for a in q])
    torque = np.array([pin.rnea(robot.model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])
    return np.abs(gravity).max(axis=0), np.abs(torque).max(axis=0)


def dense_check(result, torque_limit: np.ndarray | None) -> tuple[float, float, float]:
    """Largest torque ratio (RNEA), tool speed [m/s] and angular speed [deg/s] (forward-kinematics
    differences) at 1 kHz, half a period off the planner's grid."""
    robot, trajectory = result.robot, result.trajectory
    times = np.arange(0.0005, trajectory.total_time, 0.001)
    q, qd, qdd = (trajectory.evaluate(times, order) for order in range(3))
    model, data = robot.model, robot.model.createData()
    ratio = float("nan")
    if torque_limit is not None:
        torque = np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])
        ratio = float((np.abs(torque) / torque_limit).max())
    step = 1e-6
    ahead = [robot.forward_kinematics(a) for a in trajectory.evaluate(times + step)]
    behind = [robot.forward_kinematics(a) for a in trajectory.evaluate(times - step)]
    linear = max(np.linalg.norm(a.translation - b.translation) for a, b in zip(ahead, behind)) / (2 * step)
    angular = max(np.linalg.norm(pin.log3(a.rotation @ b.rotation.T)) for a, b in zip(ahead, behind)) / (2 * step)
    return ratio, float(linear), float(np.degrees(angular))


def toppra_peer(result, torque_limit: np.ndarray | None) -> tuple[float, float]:
    """TOPP-RA's duration [s] and wall time [s] on the planned path under the same velocity, acceleration
    and torque limits."""
    import toppra
    import toppra.algorithm
    import toppra.constraint

    toppra.setup_logging("WARNING")
    trajectory, limits, robot = result.trajectory, result.limits, result.robot
    times = np.linspace(0.0, trajectory.total_time, max(int(trajectory.total_time * 200), 50))
    model, data = robot.model, robot.model.createData()
    start = time.perf_counter()
    path = toppra.SplineInterpolator(times / trajectory.total_time, trajectory.evaluate(times))
    constraints = [toppra.constraint.JointVelocityConstraint(np.vstack((-limits.velocity, limits.velocity)).T),
                   toppra.constraint.JointAccelerationConstraint(
                       np.vstack((-limits.acceleration, limits.acceleration)).T)]
    if torque_limit is not None:
        constraints.append(toppra.constraint.JointTorqueConstraint(
            lambda q, qd, qdd: pin.rnea(model, data, q, qd, qdd), np.vstack((-torque_limit, torque_limit)).T,
            np.zeros(robot.dof)))
    parametrized = toppra.algorithm.TOPPRA(constraints, path, parametrizer="ParametrizeConstAccel") \
        .compute_trajectory()
    return float(parametrized.duration), time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--toppra", action="store_true", help="TOPP-RA on the same path (extra [bench])")
    parser.add_argument("--family", help="the spline family of every case (default: the task's)")
    args = parser.parse_args()
    if args.toppra:
        try:
            import toppra  # noqa: F401
        except ImportError:
            parser.error("--toppra needs TOPP-RA, the bench extra: pip install '.[bench]'")
    print(f"median of {args.repeats} runs in-process after a warm-up"
          f"{f', family {args.family}' if args.family else ''}\n")
    header = ("| task | case | total time [s] | slow-down | uniform slow-down [s] | plan wall [s] | dense torque ratio "
              "| dense tool speed [m/s] | dense tool speed [deg/s] |")
    if args.toppra:
        header += " TOPP-RA duration [s] | TOPP-RA wall [s] |"
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for task_name, task_file in TASKS.items():
        document = yaml.safe_load(task_file.read_text())
        if "urdf" in document.get("robot", {}):
            document["robot"]["urdf"] = str((task_file.parent / document["robot"]["urdf"]).resolve())
        if args.family:
            document.setdefault("trajectory", {})["family"] = args.family
        for case, changed in cases(document, plan(document)).items():  # that first plan is the warm-up
            walls = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                result = plan(changed)
                walls.append(time.perf_counter() - start)
            met = result.robot_limits
            torque_limit = None if met is None else met.torque_limit
            ratio, speed, angular = dense_check(result, torque_limit)
            uniform = None if met is None else met.uniform_total_s
            row = (f"| {task_name} | {case} | {result.trajectory.total_time:.4f} | "
                   f"{1.0 if met is None else met.slow_down:.4f} | {'-' if uniform is None else f'{uniform:.4f}'} | "
                   f"{statistics.median(walls):.3f} | {'-' if torque_limit is None else f'{ratio:.4f}'} | "
                   f"{speed:.4f} | {angular:.2f} |")
            if args.toppra and case.startswith("tool"):
                row += " - | - |"  # TOPP-RA has no tool-speed constraint of its own
            elif args.toppra:
                duration, wall = toppra_peer(result, torque_limit)
                row += f" {duration:.4f} | {wall:.3f} |"
            print(row, flush=True)


if __name__ == "__main__":
    main()
