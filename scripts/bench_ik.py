"""Benchmark: IK time per waypoint (median) on the bundled Cartesian tasks.

For each task and branch rule (``optimal``, ``continuous``), solves its waypoint
sequence repeatedly (as ``planner plan`` does: hints where the task gives them)
and, for the PUMA, also without hints; reports the median wall time per
waypoint [ms] and the largest residual.

    python scripts/bench_ik.py [--repeats 10]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from planner.ik import BRANCH_RULES, pose_from_position_quaternion, solve_waypoints
from planner.robot import load_robot
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10)
    args = parser.parse_args()
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
