"""Benchmark: the timing optimizer from 8 to 1024 via-points (random walks, paper limits).

Tasks, for 6 joints under Table III limits, no bounds, objective ``time``:

* ``smooth``: a random walk of ``n`` via-points, steps uniform in +-40 degrees
  per joint (seed = n, and with ``--walks K`` also n + 1000 k for k = 1 .. K - 1);
* ``clipped`` (the hard class): the same kind of walk (seed = n + 1, n + 1 + 1000 k)
  clipped to the PUMA 560's position ranges (``robots/puma560.urdf``), so many
  via-points sit exactly on a range bound, joints rest over whole chords, and
  from n ~ 256 on consecutive via-points coincide (the problem merges them).
  ``--ranges`` also enforces those ranges (with a via-point on a bound the
  spline must stop that joint there, one condition per such via-point on the
  shared durations: more of them than durations is infeasible, and is reported so).

For each family, class and size it reports the total time, how far above
``planner.timing.lower_bound``'s bound for any trajectory through the via-points it is, the median
optimizer wall time in-process after a warm-up (segments of at least 1 ms, as a task
file's default), the solver iterations and IPOPT status per NLP start, whether the starts agree (within 0.01 %), and the
exact feasibility check; with ``--walks K``, a row per walk and then, per
family, class and size, the median and largest wall time and the largest ratio
of a walk's wall time to TOPP-RA's. Then the paper case (8 via-points, hybrid)
with and without bounds [3, 5] s, and the growth exponent of the median wall
time from 64 to 1024 via-points. Timings on a shared machine vary: compare medians.

``--end-to-end`` adds ``planner plan`` on the same via-points as a joint-space
task file (no robot, the same limits), each run a fresh process: the median wall
time of the command and of the stages its summary.json records (setup,
optimization, outputs; the rest is Python's start, imports and publishing).

``--toppra`` adds TOPP-RA (``pip install .[bench]``) as a peer: the median
wall time of a velocity- and acceleration-limited time parametrization (its
automatic grid) of a cubic spline through the same (merged) via-points, and
its duration. It is not the same problem (no jerk limit, no hybrid ends, a
path parametrized by a uniform s): a reference for compute time only.

    python scripts/bench_scale.py [--sizes 8 16 ... 1024] [--families cubic hybrid]
                                  [--classes smooth clipped] [--walks 1] [--ranges] [--toppra]
                                  [--end-to-end] [--repeats 3] [--algorithm default]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from planner import paper
from planner.task import Task
from planner.timing import TimingProblem, optimize
from planner.timing.lower_bound import time_lower_bound

SIZES = (8, 16, 32, 64, 128, 256, 512, 1024)
STEP_DEG = 40.0


def random_walk(count: int, seed: int, joints: int = 6) -> np.ndarray:
    """(count, joints) via-points [rad]: a walk from zero with steps uniform in +-STEP_DEG."""
    steps = np.random.default_rng(seed).uniform(-STEP_DEG, STEP_DEG, (count - 1, joints))
    return np.deg2rad(np.vstack((np.zeros(joints), np.cumsum(steps, axis=0))))


#: The PUMA 560's joint position ranges [deg] (robots/puma560.urdf), which the ``clipped`` class clips to.
PUMA_RANGES_DEG = np.array([[-160.0, -225.0, -45.0, -110.0, -100.0, -266.0],
                            [160.0, 45.0, 225.0, 170.0, 100.0, 266.0]])
CLASSES = ("smooth", "clipped")


def clipped_walk(count: int, seed: int) -> np.ndarray:
    """(count, 6) via-points [rad]: ``random_walk`` clipped to ``PUMA_RANGES_DEG``."""
    low, high = np.deg2rad(PUMA_RANGES_DEG)
    return np.clip(random_walk(count, seed), low, high)


#: The shortest segment [s] of the in-process runs: a task file's default (``trajectory.min_segment_s``), so
#: that they solve the problem ``planner plan`` solves (the floor is never reached at these optima, but
#: it bounds the NLP's variables, and IPOPT's path, and with it its iterations, depends on it).
MIN_SEGMENT_S = Task.min_segment_s
#: Seeds of a class's further walks of one size are this far apart (``--walks``).
WALK_SEED_STEP = 1000


def walk_seed(kind: str, count: int, walk: int) -> int:
    """The seed of walk ``walk`` (0, 1, ...) of ``count`` via-points of class ``kind`` (module docstring)."""
    return count + (kind == "clipped") + WALK_SEED_STEP * walk


def task(kind: str, count: int, ranges: bool, walk: int = 0) -> tuple[np.ndarray, object]:
    """Via-points and limits of one benchmark task (module docstring)."""
    limits = paper.paper_limits()
    seed = walk_seed(kind, count, walk)
    if kind == "smooth":
        return random_walk(count, seed), limits
    if ranges:
        low, high = np.deg2rad(PUMA_RANGES_DEG)
        limits = limits.with_overrides(lower=low, upper=high)
    return clipped_walk(count, seed), limits


def start_summary(result) -> str:
    """Iterations and IPOPT status of each NLP start: ``cruise 23 ok, ...``."""
    short = {"Solve_Succeeded": "ok", "Solved_To_Acceptable_Level": "acceptable"}
    return ", ".join(f"{s.label} {s.iterations} {short.get(s.status, s.status)}" for s in result.starts)


def toppra_peer(via: np.ndarray, limits, repeats: int) -> tuple[float, float]:
    """Median wall time [s] of TOPP-RA's velocity- and acceleration-limited parametrization of a cubic spline
    through ``via`` (repeats merged), and the duration [s] it finds (module docstring)."""
    import toppra
    import toppra.algorithm
    import toppra.constraint

    toppra.setup_logging("WARNING")
    distinct = np.concatenate(([True], np.abs(np.diff(via, axis=0)).max(axis=1) > 1e-9))
    via = via[distinct]
    walls = []
    for _ in range(repeats):
        start = time.perf_counter()
        path = toppra.SplineInterpolator(np.linspace(0.0, 1.0, len(via)), via)
        constraints = [toppra.constraint.JointVelocityConstraint(np.vstack((-limits.velocity, limits.velocity)).T),
                       toppra.constraint.JointAccelerationConstraint(
                           np.vstack((-limits.acceleration, limits.acceleration)).T)]
        trajectory = toppra.algorithm.TOPPRA(constraints, path, parametrizer="ParametrizeConstAccel") \
            .compute_trajectory()
        walls.append(time.perf_counter() - start)
    return statistics.median(walls), float(trajectory.duration)


def plan_end_to_end(via: np.ndarray, limits, family: str, repeats: int) -> tuple[float, dict[str, float]]:
    """Median wall time [s] of ``planner plan`` on a joint-space task of ``via`` and ``limits``, and the
    median of each stage in its summary.json ``timings_s``."""
    limit_keys = {"velocity_deg_s": limits.velocity, "acceleration_deg_s2": limits.acceleration,
                  "jerk_deg_s3": limits.jerk}
    document = {"version": 1, "name": f"bench_{len(via)}", "waypoints": {"joints_deg": np.rad2deg(via).tolist()},
                "limits": {key: np.rad2deg(value).tolist() for key, value in limit_keys.items()},
                "trajectory": {"family": family}}
    if np.isfinite(limits.lower).all() and np.isfinite(limits.upper).all():
        document["limits"]["position_deg"] = np.rad2deg(np.vstack((limits.lower, limits.upper))).T.tolist()
    walls, stages = [], {}
    with tempfile.TemporaryDirectory() as folder:
        task_file = Path(folder) / "task.yaml"
        task_file.write_text(yaml.safe_dump(document))
        for run in range(repeats):
            out = Path(folder) / f"out{run}"
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "planner.cli", "plan", str(task_file), "--out", str(out), "--quiet"],
                           check=True)
            walls.append(time.perf_counter() - start)
            for stage, seconds in json.loads((out / "summary.json").read_text())["timings_s"].items():
                stages.setdefault(stage, []).append(seconds)
    return statistics.median(walls), {stage: statistics.median(values) for stage, values in stages.items()}


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
    parser.add_argument("--classes", nargs="+", default=list(CLASSES), choices=CLASSES)
    parser.add_argument("--walks", type=int, default=1, help="walks (seeds) per class and size")
    parser.add_argument("--ranges", action="store_true", help="enforce the PUMA ranges on the clipped class")
    parser.add_argument("--toppra", action="store_true", help="time TOPP-RA on the same via-points (extra [bench])")
    parser.add_argument("--end-to-end", action="store_true", help="time `planner plan` on the same via-points")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--algorithm", default="default")
    args = parser.parse_args()
    if args.toppra:
        try:
            import toppra  # noqa: F401
        except ImportError:
            parser.error("--toppra needs TOPP-RA, the bench extra: pip install '.[bench]'")
    limits = paper.paper_limits()
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    optimize(TimingProblem(via, "hybrid", limits), args.algorithm)  # warm-up: imports, first build
    print(f"algorithm {args.algorithm}, median of {args.repeats} runs\n")
    for bounds in (None, paper.BOUNDS_S):
        result, wall = run(TimingProblem(via, "hybrid", limits, bounds=bounds), args.algorithm, args.repeats)
        print(f"paper case, hybrid, bounds {bounds}: total {result.total_time:.6f} s, wall {1e3 * wall:.0f} ms, "
              f"feasible {result.feasible}, starts agree {result.starts_agree}")
    peer = " TOPP-RA wall [s] | TOPP-RA duration [s] |" if args.toppra else ""
    plan = " plan wall [s] | setup / optimization / outputs [s] |" if args.end_to_end else ""
    print("\n| family | class | n | seed | total time [s] | above the lower bound | wall [s] | iterations "
          f"| starts (iterations, status) | agree | feasible |{peer}{plan}")
    print("|---|---|---:|---:|---:|---:|---:|---:|---|---|---|" + ("---:|---:|" if args.toppra else "")
          + ("---:|---|" if args.end_to_end else ""))
    walls: dict[tuple[str, str, int], list[float]] = {}
    peers: dict[tuple[str, str, int], list[float]] = {}
    for family in args.families:
        for kind in args.classes:
            for n in args.sizes:
                for walk in range(args.walks):
                    via, limits = task(kind, n, args.ranges, walk)
                    problem = TimingProblem(via, family, limits, min_duration=MIN_SEGMENT_S)
                    result, wall = run(problem, args.algorithm, args.repeats)
                    walls.setdefault((family, kind, n), []).append(wall)
                    above = result.total_time / time_lower_bound(via, limits) - 1
                    row = (f"| {family} | {kind} | {n} | {walk_seed(kind, n, walk)} | {result.total_time:.6f} "
                           f"| {100 * above:.1f} % | {wall:.3f} | {result.solver_iterations} | {start_summary(result)} "
                           f"| {result.starts_agree} | {result.feasible} |")
                    if args.toppra:
                        peer_wall, peer_duration = toppra_peer(via, limits, args.repeats)
                        peers.setdefault((family, kind, n), []).append(peer_wall)
                        row += f" {peer_wall:.3f} | {peer_duration:.3f} |"
                    if args.end_to_end:
                        plan_wall, stages = plan_end_to_end(via, limits, family, args.repeats)
                        split = " / ".join(f"{stages.get(part, 0.0):.2f}"
                                           for part in ("setup", "optimization", "outputs"))
                        row += f" {plan_wall:.2f} | {split} |"
                    print(row, flush=True)
    if args.walks > 1:
        print("\n| family | class | n | walks | median wall [s] | largest wall [s] | largest wall / TOPP-RA's |")
        print("|---|---|---:|---:|---:|---:|---:|")
        for key, times in walls.items():
            ratio = max(w / p for w, p in zip(times, peers[key])) if key in peers else math.nan
            print(f"| {' | '.join(map(str, key))} | {len(times)} | {statistics.median(times):.3f} | {max(times):.3f} "
                  f"| {ratio:.2f} |")
    for (family, kind, n), times in walls.items():
        if n == 1024 and (family, kind, 64) in walls:
            exponent = math.log(statistics.median(times) / statistics.median(walls[family, kind, 64])) / math.log(16)
            print(f"\n{family}, {kind}: the median wall time grows like n^{exponent:.2f} from 64 to 1024 via-points")

if __name__ == "__main__":
    main()
