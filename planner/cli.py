"""Command line: ``planner plan | reproduce | replay``.

Exit codes: 0 success, 2 any ``PlannerError`` (bad input, an infeasible task, an
unusable output path, a recording or viewer that fails), 1 an internal error or a
failed ``replay --check``, 130 on Ctrl-C, 143 on SIGTERM. Errors
print one line on stderr. What cannot be printed (stdout or stderr closed, a pipe
closed early, a full device) is dropped: the exit code still says how the command
ended. Output paths are checked before any work (``planner.outputs``); the heavy
modules are imported only once the signal handlers are in place, so an
interruption is one line too from then on: within the first few tens of milliseconds, while
Python itself starts and imports this module, Ctrl-C still ends the process Python's own way.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
from contextlib import ExitStack
from pathlib import Path

from . import interrupts
from .errors import OutputError, PlannerError, one_line, shown
from .progress import TerminalProgress


class Terminated(BaseException):
    """SIGTERM (``kill``, ``timeout``, ``docker stop``), raised so that every cleanup runs."""


def _interrupt(signum, frame):
    """Ctrl-C or SIGTERM: raise it, and record it where a library that swallows it is checked."""
    interrupts.request(KeyboardInterrupt() if signum == signal.SIGINT else Terminated())


def _plan(args) -> int:
    from .limits import seconds_text
    from .outputs import output_folder
    from .pipeline import OUTPUT_FILES, output_writers, plan
    from .task import load_task
    progress = TerminalProgress("optimizing", quiet=args.quiet)
    task = load_task(args.task)  # a missing or malformed task is named before the output folder's state
    if args.out is None:  # beside other tasks' outputs and the reproduction's (out/reproduce), not over them
        stem = Path(args.task).stem
        if stem.startswith(".") or not stem:  # out/.. is the current folder, out/. every task's, out/.yaml hidden
            raise OutputError(f"the task file's name {shown(Path(args.task).name)} names no output folder "
                              f"(out/{stem}{' would be hidden' if stem not in ('.', '..') else ''}): give one "
                              f"with --out")
        args.out = str(Path("out") / stem)
    # The writers first: forked before the output folder is locked, they do not hold its lock.
    with output_writers() as writers, output_folder(args.out, force=args.force, files=OUTPUT_FILES) as staging:
        result = plan(task, progress=progress)
        progress.note(f"writing the outputs to {_printable(str(args.out))}")
        result.write(staging, writers=writers)
    interrupts.finish()  # published: a signal from now on changes nothing
    out, folder = _published(args.out)
    if not args.quiet:
        timing = ", ".join(f"{k} {v:.3f} s" for k, v in result.timings_s.items())
        print(f"{result.task.name}: {result.task.family}, total time {seconds_text(result.trajectory.total_time)} s, "
              f"largest ratio {result.max_ratio:.4f}, feasible {result.feasible}"
              + (" (stopped by the time limit: the best timing found by then)" if result.optimization.out_of_time
                 else ""))
        print(f"timings: {timing}")
        print(f"outputs in {_printable(str(out))}/: "
              + ", ".join(sorted(p.name for p in folder.iterdir() if not p.name.startswith("."))))
        print(f"open the recording with: {_command()} replay {_printable(str(out / 'trajectory.rrd'))}  "
              f"(check it without a viewer: add --check)")
    return 0


def _published(out: str) -> tuple[Path, Path]:
    """The output folder ``out`` as the printed messages show it (the text given, or the resolved path where the
    system reaches no folder by the text: nope/../x) and as the writer resolved it (``..`` after a link too)."""
    from .outputs import absolute_path
    folder = absolute_path(out, "output folder")
    return (Path(out) if Path(out).is_dir() else folder), folder


def _reproduce(args) -> int:
    from .outputs import output_folder
    from .reproduce import REPORT_FILES, run_all, write_report
    progress = TerminalProgress("reproduce", quiet=args.quiet)
    with output_folder(args.out, force=args.force, files=REPORT_FILES) as staging:
        runs = run_all(quick=args.quick, seed=args.seed, progress=progress)
        write_report(runs, staging)
    interrupts.finish()
    out, _ = _published(args.out)
    if not args.quiet:
        print((out / "reproduction.md").read_text())
        print(f"written: {out}/reproduction.md, reproduction.json, figure4.png")
    return 0


#: A ``--time`` this far past the recording's end, relative, is its end: the summary and the CSV print the
#: total time to 12 or 13 digits, rounded up half the time.
TIME_END_TOLERANCE = 1e-9


def _replay(args) -> int:
    from .errors import InputError
    from .export import write_trajectory_csv
    from .limits import numbers_apart, seconds_text
    from .outputs import atomic_file, check_output_file
    from .recording import open_in_viewer, read_recording
    if args.time is not None and args.screenshot is None:
        raise InputError("--time says when to take a --screenshot: give --screenshot OUT.png too")
    targets: list[Path] = []
    for option, target in (("--export-csv", args.export_csv), ("--screenshot", args.screenshot)):
        if target is not None:  # checked before reading: a bad target fails fast and leaves nothing
            resolved = check_output_file(target, force=True)
            if resolved == Path(args.recording).resolve():
                raise OutputError(f"{option} {target} is the recording itself")
            if resolved in targets:
                raise OutputError(f"--screenshot and --export-csv name the same file ({resolved}): give two")
            targets.append(resolved)
            check_output_file(target, force=args.force)
    if args.screenshot is not None and Path(args.screenshot).suffix.lower() != ".png":
        raise InputError(f"--screenshot {args.screenshot} writes a PNG image: give a file name ending in .png")
    recorded = read_recording(args.recording)
    target = args.export_csv
    total = recorded.trajectory.total_time
    at = total / 2 if args.time is None else args.time
    if total < at <= total * (1 + TIME_END_TOLERANCE):  # the end as the outputs print it, rounded up
        at = total
    if args.screenshot is not None and not 0.0 <= at <= total:
        given, end = numbers_apart(at, total)  # as many digits as tell a time just past the end from it
        raise InputError(f"--time {given} s is outside the recording's 0 to {end} s")
    if args.check:  # first: exports of a recording that fails its check are not written
        check = recorded.check()
        findings = (["VIOLATIONS: " + "; ".join(check.findings)] if check.findings else []) + (
            ["SAMPLES OFF THE TRAJECTORY"] if check.deviation > check.tolerance else [])
        skipped = [option for option, given in (("--export-csv", target), ("--screenshot", args.screenshot))
                   if given is not None and not check.passed]
        print(f"{args.recording}: {len(recorded.joint_names)} joints, {len(recorded.times)} samples, "
              f"T = {seconds_text(recorded.trajectory.total_time)} s, largest ratio {_ratio(check.largest_ratio)}, "
              f"samples vs trajectory {check.deviation:.3e} rad (allowed {check.tolerance:.3e}), "
              f"{', '.join(findings) or 'kinematic limits hold'}"
              + (f"; {' and '.join(skipped)} not written: the check failed" if skipped else ""))
        if not check.passed:
            return 1
    with ExitStack() as files:  # the CSV and the screenshot are published together, or neither is
        if target is not None:
            staging = files.enter_context(atomic_file(target, force=args.force))
            write_trajectory_csv(staging, recorded.trajectory, recorded.rate_hz, recorded.joint_names)
        if args.screenshot is not None:
            from .screenshot import render_screenshot
            render_screenshot(args.recording, files.enter_context(atomic_file(args.screenshot, force=args.force)), at)
        with interrupts.publishing():  # both renamed, or (interrupted before) neither
            files.close()
    for option, written in (("--export-csv", target), ("--screenshot", args.screenshot)):
        if written is not None:  # published: say where (the command printed nothing on success)
            print(f"written ({option}): {_printable(str(written))}"
                  + (f" (the recording at {at:.6g} s)" if option == "--screenshot" else ""))
    if args.screenshot is None and not args.check and target is None:
        open_in_viewer(args.recording, command=_command())
    return 0


def _ratio(ratio: float) -> str:
    """A limit ratio in a line: 4 decimals, or 4 significant digits where it is huge (a forged recording)."""
    return f"{ratio:.4f}" if abs(ratio) < 1e4 else f"{ratio:.4g}"


def _command() -> str:
    """How this command was typed (``.venv/bin/planner``, ``planner``), so printed commands run as shown."""
    typed = sys.argv[0] if sys.argv and sys.argv[0] else ""
    if Path(typed).name == "planner":
        return typed
    return f"{sys.executable} -m planner.cli"


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("planner")
    except PackageNotFoundError:  # run from a source tree that is not installed
        return "unknown (not installed)"


def _seed(text: str) -> int:
    """A seed argument: a whole number in [0, 2^63)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"must be in [0, 2^63), got {value}")
    return value


class _Once(argparse.Action):
    """Store an option's value and refuse a second one: argparse would keep the last without a word, and
    the first (an output path, say) would be lost."""

    def __call__(self, parser, namespace, values, option_string=None):
        given = namespace.__dict__.setdefault("_given_once", {})
        if self.dest in given:
            parser.error(f"{option_string} given twice ({given[self.dest]!r}, then {values!r}): give it once")
        given[self.dest] = values
        setattr(namespace, self.dest, values)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2), like every other error of the command line."""

    def error(self, message: str):
        self.exit(2, f"error: {self.prog}: {one_line(message)} (see {self.prog} --help)\n")


def _log_to_stderr(verbosity: int) -> logging.Handler | None:
    """With ``--verbose`` (1: INFO, 2 or more: DEBUG), the planner's log lines on stderr; the handler."""
    if not verbosity:
        return None
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    logger = logging.getLogger("planner")
    logger.setLevel(logging.INFO if verbosity == 1 else logging.DEBUG)
    logger.addHandler(handler)
    return handler


def build_parser() -> argparse.ArgumentParser:
    """The ``planner`` argument parser, with its sub-commands."""
    parser = _Parser(prog="planner", description="Time-optimal joint trajectories through via-points.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of unexpected errors")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="log what the stages do on stderr (IK choices, solver starts and rounds); -vv for more")
    # Not required here: an unknown option before the command is named as such (``main`` asks for the command).
    commands = parser.add_subparsers(dest="command")
    plan = commands.add_parser("plan", help="plan a task file and write the outputs")
    plan.add_argument("task", help="YAML task file")
    plan.add_argument("--out", action=_Once,
                      help="output folder (default: out/TASK, TASK the task file's name without its extension); "
                           "created if absent, refused if it holds files the planner did not write (see --force)")
    plan.add_argument("--force", action="store_true",
                      help="write into a folder of other files: the planner's files are replaced, the rest kept")
    plan.add_argument("--quiet", action="store_true", help="print nothing on success")
    plan.set_defaults(run=_plan)
    reproduce = commands.add_parser("reproduce", help="reproduce the source paper's tables and figure")
    reproduce.add_argument("--out", default="out/reproduce", action=_Once,
                           help="output folder (default: out/reproduce)")
    reproduce.add_argument("--force", action="store_true", help="write into a folder of other files (as plan --force)")
    reproduce.add_argument("--quick", action="store_true", help="small optimizer budgets (for tests)")
    reproduce.add_argument("--seed", type=_seed, default=0, action=_Once,
                           help="seed of the stochastic optimizers (default: 0)")
    reproduce.add_argument("--quiet", action="store_true", help="print nothing on success")
    reproduce.set_defaults(run=_reproduce)
    replay = commands.add_parser("replay", help="open a trajectory.rrd in the Rerun viewer (needs a display), "
                                                "or check/export/screenshot it without one")
    replay.add_argument("recording", help="a trajectory.rrd written by planner plan")
    replay.add_argument("--check", action="store_true",
                        help="read it back without a viewer and re-check it against its recorded limits")
    replay.add_argument("--export-csv", metavar="PATH", action=_Once, help="write its joint samples as CSV")
    replay.add_argument("--screenshot", metavar="OUT.png", action=_Once,
                        help="render it with Rerun's headless viewer (no display needed, but a graphics adapter: "
                             "a GPU, or apt-get install mesa-vulkan-drivers) and write a PNG")
    from .screenshot import time_argument  # light: the standard library and planner.errors only
    replay.add_argument("--time", type=time_argument, metavar="T", action=_Once,
                        help="time of the --screenshot [s] (default: half the total time)")
    replay.add_argument("--force", action="store_true", help="replace an existing --export-csv or --screenshot file")
    replay.set_defaults(run=_replay)
    return parser


def main(argv=None, *, keep_signal_handlers: bool = False) -> int:
    """Run the command line; returns the exit code (see the module docstring).

    Ctrl-C and SIGTERM are handled (``_interrupt``) while it runs; the previous handlers come
    back at the end unless ``keep_signal_handlers`` (the installed command keeps them until the
    process exits, so a late signal cannot kill it without a word).
    """
    interrupts.reset()
    in_main_thread = threading.current_thread() is threading.main_thread()  # signals can be set only there
    previous = {number: signal.signal(number, _interrupt) for number in (signal.SIGINT, signal.SIGTERM)} \
        if in_main_thread else {}
    debug, logged = False, None
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.command is None:
            parser.error("the following arguments are required: command")
        debug = args.debug
        logged = _log_to_stderr(args.verbose)
        code = args.run(args)
        interrupts.check()  # one a library swallowed ends the command as interrupted, whatever it did
        return code
    except PlannerError as exc:
        _error_line(f"error: {_printable(str(exc))}")
        return exc.exit_code
    except KeyboardInterrupt:
        _error_line("interrupted")
        return 130
    except Terminated:
        _error_line("terminated")
        return 143
    except Exception as exc:  # one line for the user; --debug for the traceback
        if debug:
            raise
        _error_line(_printable(one_line(f"internal error: {type(exc).__name__}: {exc} (run with --debug for details)")))
        return 1
    finally:
        interrupts.finish()  # the command is over: a signal from now on changes nothing
        if logged is not None:
            logging.getLogger("planner").removeHandler(logged)
        if not keep_signal_handlers:
            for number, handler in previous.items():
                signal.signal(number, handler)


def _error_line(text: str) -> None:
    """``text`` as a line of its own on stderr: on a terminal, a live status line the failure or
    interruption stopped short is cleared first (the error was appended to it)."""
    try:
        clear = "\r\033[K" if sys.stderr.isatty() else ""
    except (AttributeError, ValueError):  # a closed or replaced stderr
        clear = ""
    print(f"{clear}{text}", file=sys.stderr)


#: Exit codes of an interrupted command (Ctrl-C, SIGTERM).
INTERRUPTED_CODES = (130, 143)


def entry() -> None:
    """The installed ``planner`` command (and ``python -m planner.cli``). Once ``main`` returns, Ctrl-C
    and SIGTERM are ignored: Python gives signals back their default action while it shuts down, and
    a late one would end the process by signal instead of with the exit code already printed for.

    An interrupted command, its cleanup done, leaves at once with its code (``os._exit``): when the
    Ctrl-C landed in code a library ran through ``PyRun_String`` during an import, CPython remembers
    it as unhandled although ``main`` caught it, and under ``python -m`` then ends the process by
    SIGINT instead of with exit code 130 (1 run in 3 with Ctrl-C 0.3 s after the start)."""
    _tolerant_standard_streams()
    code = main(keep_signal_handlers=True)
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, signal.SIG_IGN)
    if code in INTERRUPTED_CODES:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


class _Tolerant:
    """A standard stream that drops what cannot be written (a pipe closed early, ``>/dev/full``):
    printing is the command's report, never its work. After the first failure the descriptor is
    pointed at /dev/null, so that the interpreter's own flush at exit fails no more (it would set
    exit code 120)."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except (OSError, ValueError):
            self._drop()
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except (OSError, ValueError):
            self._drop()

    def _drop(self) -> None:
        try:
            sink = os.open(os.devnull, os.O_WRONLY)
            os.dup2(sink, self._stream.fileno())
            os.close(sink)
        except (OSError, ValueError):
            pass

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def _tolerant_standard_streams() -> None:
    """Make stdout and stderr safe to print to (``_Tolerant``), a path the terminal's encoding cannot
    show printed escaped. A closed descriptor (``>&-``) is opened on /dev/null first: else the next
    file the command opens would take its number, and what is printed would land in it."""
    for fd, name in ((1, "stdout"), (2, "stderr")):
        try:
            os.fstat(fd)
        except OSError:
            sink = os.open(os.devnull, os.O_WRONLY)
            if sink != fd:
                os.dup2(sink, fd)
                os.close(sink)
            setattr(sys, name, open(fd, "w", encoding="utf-8", closefd=False))
        stream = getattr(sys, name)
        if stream is None:
            continue
        if hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
        setattr(sys, name, _Tolerant(stream))


def _printable(text: str) -> str:
    """``text`` with control characters (an escape sequence in a path, say) shown as escapes."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


if __name__ == "__main__":
    entry()
