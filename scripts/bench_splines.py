"""Benchmark: batched spline build plus exact constraint ratios, per candidate.

Reports the median wall time [us per candidate] of
``family.build_batch`` + ``batch_scale_factors`` for B = 20 candidates on the
paper case (8 via-points, 6 joints) and on random cases of n = 10, 100, 1000
via-points, to show the cost grows linearly with n.

    python scripts/bench_splines.py [--family hybrid] [--repeats 200]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from planner import get_family, paper
from planner.kinematics import batch_scale_factors


def median_us_per_candidate(family, via, limits, batch: int, repeats: int, seed: int = 0) -> float:
    rng = np.random.default_rng(seed)
    durations = rng.uniform(1.0, 5.0, (batch, family.segment_count(len(via))))
    times = []
    for _ in range(repeats + 5):
        start = time.perf_counter()
        batch_scale_factors(family.build_batch(via, durations), durations, limits)
        times.append(time.perf_counter() - start)
    return float(np.median(times[5:])) / batch * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", default="hybrid")
    parser.add_argument("--batch", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    family = get_family(args.family)
    limits = paper.paper_limits()
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    print(f"family {family.name}, B = {args.batch}, median of {args.repeats} runs")
    paper_us = median_us_per_candidate(family, via, limits, args.batch, args.repeats)
    print(f"paper case (n = 8, J = 6): {paper_us:8.1f} us/candidate")
    rng = np.random.default_rng(1)
    for n in (10, 100, 1000):
        via = np.cumsum(rng.uniform(-0.5, 0.5, (n, 6)), axis=0)
        repeats = max(5, args.repeats * 10 // n)
        value = median_us_per_candidate(family, via, limits, args.batch, repeats)
        print(f"n = {n:5d} via-points:        {value:8.1f} us/candidate  ({value / n:6.2f} us per via-point)")


if __name__ == "__main__":
    main()
