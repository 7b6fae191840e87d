"""Benchmark of the timing optimizers on the paper case (issue targets, measured).

Reports, for the hybrid family on Table II / Table III:

1. with the paper's bounds [3, 5] s: Cuckoo Search's total time (paper budget);
2. without bounds: CS alone (paper budget, no refinement), median total time over
   10 seeds, relative to the best total time any of our optimizers finds;
   the default planner's total time per seed, relative to the same best;
3. median wall time in-process after warm-up: CS with the paper's budget, and
   the default planner's optimization;
4. that every returned trajectory passes the exact limit checks.

    python scripts/benchmark.py [--seeds 10]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from planner import kinematic_figures, paper
from planner.timing import TimingProblem, optimize


def timed(function):
    start = time.perf_counter()
    value = function()
    return value, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    limits = paper.paper_limits()
    bounded = TimingProblem(via, "hybrid", limits, bounds=paper.BOUNDS_S)
    free = TimingProblem(via, "hybrid", limits)
    optimize(free, "cuckoo", iterations=3, polish=False)  # warm-up
    checked = []

    bounded_results = [optimize(bounded, "cuckoo", seed=s) for s in range(3)]
    checked += [(bounded, r) for r in bounded_results]
    print("1. bounds [3, 5] s, CS paper budget: total time "
          + ", ".join(f"{r.total_time:.3f}" for r in bounded_results) + " s (paper: 38.311 s)")

    plain, plain_wall = zip(*(timed(lambda s=s: optimize(free, "cuckoo", seed=s, polish=False))
                              for s in range(args.seeds)))
    default, default_wall = zip(*(timed(lambda s=s: optimize(free, "default", seed=s)) for s in range(args.seeds)))
    polished = [optimize(free, "cuckoo", seed=s) for s in range(3)]
    slsqp = optimize(free, "slsqp", seed=0)
    checked += [(free, r) for r in (*plain, *default, *polished, slsqp)]
    best = min(r.total_time for r in (*plain, *default, *polished, slsqp))
    plain_times = np.array([r.total_time for r in plain])
    default_times = np.array([r.total_time for r in default])
    print(f"2. no bounds: best total time found by any optimizer {best:.4f} s")
    print(f"   CS alone (paper budget, {args.seeds} seeds): median {np.median(plain_times):.4f} s, "
          f"{100 * (np.median(plain_times) / best - 1):.2f} % above best (target <= 1 %); "
          f"range {plain_times.min():.4f} .. {plain_times.max():.4f}")
    print(f"   default planner ({args.seeds} seeds): worst {default_times.max():.4f} s, "
          f"{100 * (default_times.max() / best - 1):.3f} % above best (target <= 0.1 % every seed)")
    print(f"3. wall time, median: CS paper budget {1000 * np.median(plain_wall):.1f} ms (target <= 50 ms); "
          f"default planner {1000 * np.median(default_wall):.1f} ms (target <= 100 ms)")
    failures = sum(bool(kinematic_figures(p.trajectory(r.durations)).violations(p.limits)) or not r.feasible
                   for p, r in checked)
    print(f"4. exact checks: {len(checked) - failures} of {len(checked)} returned trajectories pass")


if __name__ == "__main__":
    main()
