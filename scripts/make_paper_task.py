"""Write scripts/tasks/puma560_paper_cartesian.yaml: the paper's Table II as tool poses.

Each Table II joint via-point is turned into a pose of the PUMA 560's tool frame
by forward kinematics (robots/puma560.urdf); the via-point itself is kept as the
waypoint's IK hint, so planning the Cartesian task recovers Table II.

    python scripts/make_paper_task.py [--out PATH]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pinocchio as pin

from planner import paper
from planner.robot import Robot

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "scripts" / "tasks" / "puma560_paper_cartesian.yaml")
    args = parser.parse_args()
    robot = Robot.from_urdf(ROOT / "robots" / "puma560.urdf", "tool")
    lines = ["# The source paper's Table II as tool poses of the PUMA 560 (written by scripts/make_paper_task.py:",
             "# forward kinematics of each via-point; the via-point is kept as the IK hint).",
             "version: 1", "name: puma560_paper_cartesian",
             "robot: {urdf: ../../robots/puma560.urdf, tool_frame: tool}",
             "waypoints:", "  cartesian:"]
    for q_deg in paper.VIA_POINTS_DEG:
        pose = robot.forward_kinematics(np.deg2rad(q_deg))
        quaternion = pin.Quaternion(pose.rotation).coeffs()  # (x, y, z, w)
        xyz = ", ".join(repr(float(v)) for v in pose.translation)
        quat = ", ".join(repr(float(v)) for v in quaternion)
        hint = ", ".join(f"{v:g}" for v in q_deg)
        lines.append(f"    - {{xyz_m: [{xyz}], quat_xyzw: [{quat}], hint_deg: [{hint}]}}")
    lines += ["trajectory: {family: hybrid}", "optimizer: {algorithm: default, seed: 0}"]
    args.out.write_text("\n".join(lines) + "\n")
    print(f"written {args.out}")


if __name__ == "__main__":
    main()
