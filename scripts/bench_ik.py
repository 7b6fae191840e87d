"""Benchmark: IK time per waypoint (median) on the bundled Cartesian tasks.

For each task and branch rule (``optimal``, ``continuous``), solves its waypoint
sequence repeatedly (as ``planner plan`` does: hints where the task gives them)
and, for the PUMA, also without hints; reports the median wall time per
waypoint [ms] and the largest residual.

Then, for the arms with closed-form IK (PUMA 560, UR5), on ``--poses`` poses of
seeded random configurations within the ranges: the median time per pose [ms]
of ``pose_solutions`` with the closed form and with the numeric search (48
random starts), and the poses where the numeric search missed a solution
(within the ranges, up to 2 pi turns) that the closed form found.

    python scripts/bench_ik.py [--repeats 10] [--poses 100]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from planner.ik import BRANCH_RULES, DISTINCT, pose_from_position_quaternion, pose_solutions, solve_waypoints
from planner.robot import Robot, load_robot
from planner.task import load_task

TASKS = Path(__file__).resolve().parent / "tasks"


def per_waypoint_ms(robot, poses, hints, branch: str, repeats: int) -> tuple[float, float]:
    samples, residual = [], 0.0
    for _ in range(repeats):
        start = time.perf_counter()
        solutions = solve_waypoints(robot, poses, hints=hints, branch=branch)
        samples.append((time.perf_counter() - start) / len(poses))
        residual = max(residual, max(s.residual for s in solutions))
    return 1000 * float(np.median(samples)), residual


def timed_solutions(robot, target, closed_form: bool) -> tuple[float, np.ndarray]:
    """Wall time [ms] of ``pose_solutions`` and its solutions (K, nq), angles wrapped into [-pi, pi)."""
    start = time.perf_counter()
    found, _, _ = pose_solutions(robot, target, robot.limits, np.random.default_rng(0), closed_form=closed_form)
    elapsed = 1000 * (time.perf_counter() - start)
    return elapsed, np.angle(np.exp(1j * np.array([s.q for s in found]).reshape(-1, robot.dof)))


def closed_form_versus_numeric(robot, poses: int) -> None:
    """Print the median ms per pose of both searches and the poses where the numeric one missed a solution."""
    rng = np.random.default_rng(0)
    lower, upper = robot.limits.lower, robot.limits.upper
    closed_ms, numeric_ms, missed, solutions = [], [], 0, 0
    for q in lower + (upper - lower) * rng.random((poses, robot.dof)):
        target = robot.forward_kinematics(q)
        elapsed, closed = timed_solutions(robot, target, True)
        closed_ms.append(elapsed)
        elapsed, numeric = timed_solutions(robot, target, False)
        numeric_ms.append(elapsed)
        solutions += len(closed)
        if len(numeric) == 0:
            missed += len(closed) > 0
            continue
        gaps = np.abs(np.angle(np.exp(1j * (closed[:, None] - numeric[None])))).max(axis=2)
        missed += bool(np.any(gaps.min(axis=1) > DISTINCT))
    print(f"{robot.name}: closed form median {np.median(closed_ms):.3f} ms per pose, numeric search (48 starts) "
          f"median {np.median(numeric_ms):.3f} ms; {solutions / poses:.2f} solutions per pose within the ranges; "
          f"the numeric search missed a solution on {missed} of {poses} poses")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--poses", type=int, default=100)
    args = parser.parse_args()
    for robot in (Robot.from_urdf(TASKS.parents[1] / "robots" / "puma560.urdf", "tool"),
                  Robot.from_example_robot_data("ur5", "tool0")):
        closed_form_versus_numeric(robot, args.poses)
    for name in ("puma560_paper_cartesian", "ur5_pick_and_place"):
        task = load_task(TASKS / f"{name}.yaml")
        robot = load_robot(task.robot.urdf, task.robot.name, task.robot.tool_frame)
        poses = [pose_from_position_quaternion(w.position, w.quaternion_xyzw) for w in task.cartesian_waypoints]
        hints = [w.hint for w in task.cartesian_waypoints]
        cases = [("as planned", hints)] + ([("without hints", None)] if any(h is not None for h in hints) else [])
        for label, case_hints in cases:
            for branch in BRANCH_RULES:
                ms, residual = per_waypoint_ms(robot, poses, case_hints, branch, args.repeats)
                print(f"{name} ({robot.name}, {len(poses)} waypoints, {label}, {branch}): median {ms:.3f} ms "
                      f"per waypoint, largest residual {residual:.1e}")


if __name__ == "__main__":
    main()
