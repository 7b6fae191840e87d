"""Command line: ``planner plan | reproduce | replay``.

Exit codes: 0 success, 2 bad input (any ``PlannerError`` about the input or
an infeasible task), 1 anything else. Errors print one line on stderr.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .errors import PlannerError
from .progress import TerminalProgress


def _plan(args) -> int:
    from .pipeline import plan
    progress = TerminalProgress("optimizing", quiet=args.quiet)
    result = plan(args.task, progress=progress)
    out = result.save(args.out)
    if not args.quiet:
        timing = ", ".join(f"{k} {v:.3f} s" for k, v in result.timings_s.items())
        print(f"{result.task.name}: {result.task.family}, total time {result.trajectory.total_time:.4f} s, "
              f"largest ratio {result.optimization.max_ratio:.4f}, feasible {result.optimization.feasible}")
        print(f"timings: {timing}")
        print(f"outputs in {out}/: " + ", ".join(sorted(p.name for p in out.iterdir())))
        print(f"open the recording with: planner replay {out / 'trajectory.rrd'}  "
              f"(check it without a viewer: add --check)")
    return 0


def _reproduce(args) -> int:
    from .reproduce import run_all, write_report
    progress = TerminalProgress("reproduce", quiet=args.quiet)
    runs = run_all(quick=args.quick, seed=args.seed, progress=progress)
    out = write_report(runs, args.out)
    if not args.quiet:
        print((out / "reproduction.md").read_text())
        print(f"written: {out}/reproduction.md, reproduction.json, figure4.png")
    return 0


def _replay(args) -> int:
    import os

    from .errors import InputError
    from .export import atomic_file, write_trajectory_csv
    from .recording import open_in_viewer, read_recording
    target = args.export_csv
    if target is not None:  # checked before reading: a bad target fails fast and leaves nothing
        if target.is_dir():
            raise InputError(f"--export-csv {target}: is a folder; give the path of a CSV file")
        above = next(p for p in target.parents if p.exists())  # the last parent, "." or "/", exists
        if not above.is_dir():
            raise InputError(f"--export-csv {target}: {above} is a file, not a folder")
        if not os.access(above, os.W_OK | os.X_OK):
            raise InputError(f"--export-csv {target}: cannot write in the folder {above}")
        if target.resolve() == args.recording.resolve():
            raise InputError(f"--export-csv {target}: is the recording itself")
    recorded = read_recording(args.recording)
    if target is not None:
        with atomic_file(target) as staging:
            write_trajectory_csv(staging, recorded.trajectory, recorded.rate_hz)
            umask = os.umask(0o022)
            os.umask(umask)
            staging.chmod(0o666 & ~umask)  # the usual permissions of a new file, not the temporary file's 0600
    if args.check:
        check = recorded.check()
        print(f"{args.recording}: {len(recorded.joint_names)} joints, {len(recorded.times)} samples, "
              f"T = {recorded.trajectory.total_time:.4f} s, largest ratio {check.largest_ratio:.4f}, "
              f"samples vs trajectory {check.deviation:.2e} rad (allowed {check.tolerance:.1e}), "
              f"{'limits hold' if not check.violations else 'VIOLATIONS: ' + '; '.join(check.violations)}")
        return 0 if check.passed else 1
    if target is None:
        open_in_viewer(args.recording)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="planner", description="Time-optimal joint trajectories through via-points.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of unexpected errors")
    commands = parser.add_subparsers(dest="command", required=True)
    plan = commands.add_parser("plan", help="plan a task file and write the outputs")
    plan.add_argument("task", type=Path, help="YAML task file")
    plan.add_argument("--out", type=Path, default=Path("out"), help="output folder (default: out)")
    plan.add_argument("--quiet", action="store_true", help="print nothing on success")
    plan.set_defaults(run=_plan)
    reproduce = commands.add_parser("reproduce", help="reproduce the source paper's tables and figure")
    reproduce.add_argument("--out", type=Path, default=Path("out/reproduce"))
    reproduce.add_argument("--quick", action="store_true", help="small optimizer budgets (for tests)")
    reproduce.add_argument("--seed", type=int, default=0)
    reproduce.add_argument("--quiet", action="store_true")
    reproduce.set_defaults(run=_reproduce)
    replay = commands.add_parser("replay", help="open a trajectory.rrd in the Rerun viewer (needs a display), "
                                                "or check/export it without one")
    replay.add_argument("recording", type=Path)
    replay.add_argument("--check", action="store_true",
                        help="read it back without a viewer and re-check it against its recorded limits")
    replay.add_argument("--export-csv", type=Path, metavar="PATH", help="write its joint samples as CSV")
    replay.set_defaults(run=_replay)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.run(args)
    except PlannerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # one line for the user; --debug for the traceback
        if args.debug:
            raise
        print(f"internal error: {type(exc).__name__}: {exc} (run with --debug for details)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
