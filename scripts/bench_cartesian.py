"""Benchmark: Cartesian tasks in ``joint`` and ``linear`` path mode, and the IK branch rules.

For each bundled Cartesian task: the total time and the largest tool deviation
from the straight segments in ``joint`` mode; in ``linear`` mode (1 mm, 0.5
deg) the poses inserted, the total time, the largest deviation and the planning
wall time (median of ``--repeats`` in-process runs, after a warm-up), or the
error when a straight segment cannot be followed. Then, without hints, the
total time of the ``optimal`` and ``continuous`` branch rules.

    python scripts/bench_cartesian.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import yaml

from planner import PlannerError
from planner.pipeline import plan
from planner.task import parse_task

TASKS = Path(__file__).resolve().parent / "tasks"
CARTESIAN = ("puma560_paper_cartesian.yaml", "ur5_pick_and_place.yaml")


def planned(data: dict, source: Path, repeats: int):
    """The plan of ``data`` and its median wall time [s] (or the error and None)."""
    walls, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        try:
            result = plan(parse_task(data, source=source))
        except PlannerError as exc:
            return exc, None
        walls.append(time.perf_counter() - start)
    return result, statistics.median(walls)


def describe(result) -> str:
    segments = result.path
    return (f"total {result.trajectory.total_time:.4f} s, inserted {int(segments.inserted.sum())} poses, "
            f"largest deviation {1e3 * segments.max_distance_m.max():.3f} mm, "
            f"{np.rad2deg(segments.max_angle_rad.max()):.3f} deg")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    plan(TASKS / CARTESIAN[1])  # warm-up: imports, robot loading
    for name in CARTESIAN:
        source = TASKS / name
        data = yaml.safe_load(source.read_text())
        print(name)
        for mode in ("joint", "linear"):
            tolerances = {"tolerance_m": 0.001, "tolerance_deg": 0.5} if mode == "linear" else {}
            result, wall = planned({**data, "path": {"mode": mode, **tolerances}}, source, args.repeats)
            if wall is None:
                print(f"  {mode}: fails: {result}")
            else:
                print(f"  {mode}: {describe(result)}, plan wall {wall:.3f} s")
        bare = yaml.safe_load(source.read_text())
        for waypoint in bare["waypoints"]["cartesian"]:
            waypoint.pop("hint_deg", None)
        for rule in ("optimal", "continuous"):
            result, wall = planned({**bare, "ik": {"branch": rule}}, source, 1)
            text = f"total {result.trajectory.total_time:.4f} s" if wall is not None else f"fails: {result}"
            print(f"  no hints, branch {rule}: {text}")


if __name__ == "__main__":
    main()
