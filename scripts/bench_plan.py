"""Benchmark: wall time of ``planner plan`` on the PUMA Cartesian paper task, end to end and split.

Each run is a fresh process, as a user would run it. Reports medians over
``--runs`` runs of: importing the planner, the whole command, and the stages
the command records in summary.json (setup, IK, optimization, outputs).

    python scripts/bench_plan.py [--runs 5]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TASK = Path(__file__).resolve().parent / "tasks" / "puma560_paper_cartesian.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    imports, commands, stages = [], [], {}
    for _ in range(args.runs):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import planner.pipeline"], check=True)
        imports.append(time.perf_counter() - start)
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            command = [sys.executable, "-m", "planner.cli", "plan", str(TASK), "--out", out, "--quiet"]
            subprocess.run(command, check=True)
            commands.append(time.perf_counter() - start)
            for stage, seconds in json.loads((Path(out) / "summary.json").read_text())["timings_s"].items():
                stages.setdefault(stage, []).append(seconds)
    print(f"planner plan {TASK.name}, median of {args.runs} fresh processes:")
    print(f"  whole command          {np.median(commands):7.3f} s (target <= 5 s)")
    print(f"  python start + imports {np.median(imports):7.3f} s")
    for stage, seconds in stages.items():
        print(f"  {stage:<22} {np.median(seconds):7.3f} s")
    ik_and_optimization = np.median(np.add(stages.get("ik", [0.0] * args.runs), stages["optimization"]))
    print(f"  IK + optimization      {ik_and_optimization:7.3f} s (target <= 0.2 s)")


if __name__ == "__main__":
    main()
