"""Benchmark: the timing optimizer from 8 to 1024 via-points (random walks, paper limits).

Task: a random walk of ``n`` via-points for 6 joints, steps uniform in
+-40 degrees per joint (seed = n), Table III limits, no bounds, objective
``time``. For each family and size it reports the total time, the median
optimizer wall time in-process after a warm-up, the solver iterations, whether
the NLP's starts agree (within 0.01 %), and the exact feasibility check. Then
the paper case (8 via-points, hybrid) with and without bounds [3, 5] s, and
the growth exponent of the wall time from 64 to 1024 via-points.

    python scripts/bench_scale.py [--sizes 8 16 ... 1024] [--families cubic hybrid]
                                  [--repeats 3] [--algorithm default]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from planner import paper
from planner.timing import TimingProblem, optimize

SIZES = (8, 16, 32, 64, 128, 256, 512, 1024)
STEP_DEG = 40.0


def random_walk(count: int, seed: int, joints: int = 6) -> np.ndarray:
    """(count, joints) via-points [rad]: a walk from zero with steps uniform in +-STEP_DEG."""
    steps = np.random.default_rng(seed).uniform(-STEP_DEG, STEP_DEG, (count - 1, joints))
    return np.deg2rad(np.vstack((np.zeros(joints), np.cumsum(steps, axis=0))))


def run(problem: TimingProblem, algorithm: str, repeats: int):
    """The result of the last of ``repeats`` runs and the median wall time [s]."""
    walls = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = optimize(problem, algorithm)
        walls.append(time.perf_counter() - start)
    return result, statistics.median(walls)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--families", nargs="+", default=["cubic", "hybrid"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--algorithm", default="default")
    args = parser.parse_args()
    limits = paper.paper_limits()
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    optimize(TimingProblem(via, "hybrid", limits), args.algorithm)  # warm-up: imports, first build
    print(f"algorithm {args.algorithm}, median of {args.repeats} runs\n")
    for bounds in (None, paper.BOUNDS_S):
        result, wall = run(TimingProblem(via, "hybrid", limits, bounds=bounds), args.algorithm, args.repeats)
        print(f"paper case, hybrid, bounds {bounds}: total {result.total_time:.6f} s, wall {1e3 * wall:.0f} ms, "
              f"feasible {result.feasible}, starts agree {result.starts_agree}")
    print("\n| family | n | total time [s] | wall [s] | iterations | starts | agree | feasible |")
    print("|---|---:|---:|---:|---:|---:|---|---|")
    walls: dict[tuple[str, int], float] = {}
    for family in args.families:
        for n in args.sizes:
            result, wall = run(TimingProblem(random_walk(n, n), family, limits), args.algorithm, args.repeats)
            walls[family, n] = wall
            print(f"| {family} | {n} | {result.total_time:.6f} | {wall:.3f} | {result.solver_iterations} | "
                  f"{len(result.starts)} | {result.starts_agree} | {result.feasible} |", flush=True)
    for family in args.families:
        if (family, 64) in walls and (family, 1024) in walls:
            exponent = math.log(walls[family, 1024] / walls[family, 64]) / math.log(16)
            print(f"\n{family}: wall time grows like n^{exponent:.2f} from 64 to 1024 via-points")


if __name__ == "__main__":
    main()
