"""Example script: read a plan's recording back and compare it with the plan's other outputs.

Checks, without a viewer, that ``trajectory.rrd`` holds the same trajectory as
``coefficients.json`` (evaluated independently here from its normalised
coefficients), that its samples lie on it, and that every recorded limit holds.

    .venv/bin/python scripts/examples/compare_recording.py out/rectangle
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import planner
from planner.recording import read_recording


def evaluate_document(document: dict, times: np.ndarray) -> np.ndarray:
    """Joint positions [rad] (N, J) from a coefficients.json document, in its normalised basis."""
    knots, durations = np.array(document["knot_times_s"]), np.array(document["durations_s"])
    b = np.array(document["normalized_coefficients"])  # (segment, joint, power)
    k = np.clip(np.searchsorted(knots, times, side="right") - 1, 0, len(durations) - 1)
    s = np.clip((times - knots[k]) / durations[k], 0.0, 1.0)
    return np.einsum("njp,np->nj", b[k], s[:, None] ** np.arange(b.shape[-1]))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="a folder written by planner plan (or rectangle_ur5.py)")
    args = parser.parse_args(argv)
    try:
        recorded = read_recording(args.folder / "trajectory.rrd")
        document = json.loads((args.folder / "coefficients.json").read_text())
        summary = json.loads((args.folder / "summary.json").read_text())
    except (OSError, ValueError, planner.PlannerError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    from_file = evaluate_document(document, recorded.times)
    gap_file = float(np.abs(from_file - recorded.positions).max())
    check = recorded.check()
    print(f"{args.folder}: {len(recorded.times)} recorded samples of {len(recorded.joint_names)} joints, "
          f"T = {recorded.trajectory.total_time:.4f} s (summary: {summary['total_time_s']:.4f} s)")
    print(f"  recorded samples vs coefficients.json: {gap_file:.2e} rad")
    print(f"  recorded samples vs recorded trajectory: {check.deviation:.2e} rad (allowed {check.tolerance:.1e})")
    print(f"  limits: {'hold' if not check.findings else '; '.join(check.findings)}")
    agrees = abs(recorded.trajectory.total_time - summary["total_time_s"]) <= 1e-9 * summary["total_time_s"]
    return 0 if check.passed and gap_file <= 1e-8 and agrees else 1


if __name__ == "__main__":
    sys.exit(main())
