"""Example task script: a UR5 traces a rectangle over a table, its tool pointing down.

The waypoints are computed here (no task file): the corners of a rectangle at a given
height, the tool moving in straight lines between them (``path: linear``). The script
plans, saves the outputs and prints a short report.

    .venv/bin/python scripts/examples/rectangle_ur5.py --out out/rectangle
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import pinocchio as pin

import planner


def rectangle_poses(centre_m, width_m: float, depth_m: float) -> list[pin.SE3]:
    """The four corners of a rectangle in the horizontal plane, and back to the first, tool pointing down."""
    down = pin.rpy.rpyToMatrix(np.pi, 0.0, 0.0)  # the tool's z axis along the world's -z
    x, y = width_m / 2, depth_m / 2
    corners = [(-x, -y), (x, -y), (x, y), (-x, y), (-x, -y)]
    return [pin.SE3(down, np.asarray(centre_m, dtype=float) + [dx, dy, 0.0]) for dx, dy in corners]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/rectangle", help="output folder (default: out/rectangle)")
    parser.add_argument("--height", type=float, default=0.15, help="rectangle height above the base [m]")
    args = parser.parse_args(argv)
    task = planner.make_task(
        name="ur5_rectangle",
        robot={"name": "ur5", "tool_frame": "tool0"},
        poses=rectangle_poses([0.45, 0.0, args.height], width_m=0.30, depth_m=0.20),
        limits={"acceleration_deg_s2": [150, 150, 150, 300, 300, 300],
                "jerk_deg_s3": [600, 600, 600, 1200, 1200, 1200]},
        path={"mode": "linear", "tolerance_m": 0.001, "tolerance_deg": 0.5},
        trajectory={"family": "hybrid", "sample_rate_hz": 100},
    )
    try:
        result = planner.plan(task)
        result.save(args.out, force=False)
    except planner.PlannerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return exc.exit_code
    summary = result.summary()
    print(f"{task.name}: {len(result.via_points)} via-points ({len(task.cartesian_waypoints)} corners, "
          f"{int(result.path.inserted.sum())} poses inserted), total time {result.trajectory.total_time:.4f} s")
    for segment in summary["path"]["segments"]:
        print(f"  side {segment['from_waypoint']} -> {segment['to_waypoint']}: tool within "
              f"{1e3 * segment['max_position_deviation_m']:.3f} mm and "
              f"{segment['max_orientation_deviation_deg']:.3f} deg of the straight line")
    for quantity, ratios in summary["max_ratio"].items():
        print(f"  largest {quantity} ratio {max(ratios):.4f}")
    print(f"outputs in {args.out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
