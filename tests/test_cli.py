import json
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from planner import paper
from planner.cli import main
from planner.export import read_trajectory_csv
from planner.progress import TerminalProgress

ROOT = Path(__file__).resolve().parents[1]
PAPER_JOINT = ROOT / "scripts" / "tasks" / "puma560_paper_joint.yaml"


def small_task(tmp_path, **optimizer) -> Path:
    data = yaml.safe_load(PAPER_JOINT.read_text())
    data["optimizer"] = {"algorithm": "cuckoo", "iterations": 5, "seed": 0, **optimizer}
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_plan_writes_consistent_outputs(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["plan", str(small_task(tmp_path, bounds_s=[3, 5])), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".planner-output", "coefficients.json", "profiles.png",
                                                     "summary.json", "trajectory.csv", "trajectory.rrd"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["total_time_s"] == pytest.approx(27.0) and summary["feasible"] is True
    assert summary["optimizer"]["algorithm"] == "cuckoo" and summary["optimizer"]["evaluations"] > 0
    assert len(summary["max_ratio"]["jerk"]) == 6
    assert max(summary["max_ratio"]["acceleration"]) == pytest.approx(0.827, abs=1e-3)
    times, values = read_trajectory_csv(out / "trajectory.csv")
    assert times[-1] == pytest.approx(27.0) and np.allclose(np.diff(times)[:-1], 0.01)
    # The samples pass through the via-points at the via times and respect the summary's maxima.
    for via, t in zip(paper.VIA_POINTS_DEG, summary["via_times_s"]):
        row = int(round(t * 100))
        np.testing.assert_allclose(np.rad2deg(values[0, row]), via, atol=1e-6)
    for d, key in enumerate(("velocity_deg_s", "acceleration_deg_s2", "jerk_deg_s3")):
        assert np.all(np.rad2deg(np.abs(values[d + 1])).max(axis=0) <= np.array(summary["max_abs"][key]) + 1e-6)
    coefficients = json.loads((out / "coefficients.json").read_text())
    assert np.array(coefficients["coefficients"]).shape == (9, 6, 8)
    assert "total time 27.0000 s" in capsys.readouterr().out


def test_bad_task_exits_2_with_one_line_and_no_outputs(tmp_path, capsys):
    data = yaml.safe_load(PAPER_JOINT.read_text())
    data["limits"]["velocity_deg_s"][1] = -5
    task = tmp_path / "bad.yaml"
    task.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["plan", str(task), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "limits.velocity_deg_s[1]: must be >= 1e-12 and <= 1e+15, got -5" in err
    assert not out.exists() and list(tmp_path.iterdir()) == [task]


def test_infeasible_task_exits_2_and_keeps_existing_outputs(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["plan", str(small_task(tmp_path, bounds_s=[3, 5])), "--out", str(out), "--quiet"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    task = small_task(tmp_path, bounds_s=[0.1, 0.5])
    assert main(["plan", str(task), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: infeasible with durations of at most h_max = 0.5 s: joint")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "task.yaml"]


def test_failure_while_writing_leaves_nothing(tmp_path, monkeypatch):
    import planner.pipeline as pipeline

    def broken_plot(*args, **kwargs):
        raise RuntimeError("disk full")
    monkeypatch.setattr(pipeline, "plot_profiles", broken_plot)
    out = tmp_path / "out"
    assert main(["plan", str(small_task(tmp_path, bounds_s=[3, 5])), "--out", str(out)]) == 1
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["task.yaml"]


def test_reproduce_quick_writes_tables_and_figure(tmp_path):
    out = tmp_path / "repro"
    assert main(["reproduce", "--quick", "--quiet", "--out", str(out)]) == 0
    text = (out / "reproduction.md").read_text()
    assert "| [3, 5] s | hybrid | CS (ours: repair + NLP) | 27.0000 |" in text
    assert "| [3, 5] s | hybrid | CS, the paper's Table IV | 38.3114 | 0.4013 |" in text
    assert "| max \\|velocity\\|, paper reports | 16.920 |" in text
    data = json.loads((out / "reproduction.json").read_text())
    unbounded = [r for r in data["runs"] if r["family"] == "hybrid" and r["bounds_s"] is None]
    assert unbounded and all(r["feasible"] for r in unbounded)
    assert min(r["total_time_s"] for r in unbounded) < 17.5
    assert (out / "figure4.png").stat().st_size > 10_000


def test_version_and_help_for_every_option(capsys):
    from planner.cli import build_parser
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0 and capsys.readouterr().out.startswith("planner 0.")
    parser = build_parser()
    commands = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, command in [("planner", parser), *commands.choices.items()]:
        for action in command._actions:
            if action.__class__.__name__ not in ("_HelpAction", "_SubParsersAction"):
                assert action.help, f"{name}: {action.dest} has no help text"


@pytest.mark.parametrize("argv", [["plan"], ["reproduce", "--seed", "-1"], ["reproduce", "--seed", "x"], [],
                                  ["replay"], ["plan", "t.yaml", "--bogus"]])
def test_usage_errors_are_one_line_and_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1 and err.startswith("error: planner")


@pytest.mark.parametrize("argv, said", [(["--bogus"], "unrecognized arguments: --bogus"),
                                        (["--bogus", "plan", "t.yaml"], "unrecognized arguments: --bogus"),
                                        ([], "the following arguments are required: command")])
def test_a_usage_error_names_what_is_wrong(argv, said, capsys):
    """An unknown option before the command was reported as the missing command."""
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2 and said in capsys.readouterr().err


@pytest.mark.parametrize("argv, said", [
    (["plan", "t.yaml", "--out", "a", "--out", "b"], "--out given twice ('a', then 'b'): give it once"),
    (["replay", "t.rrd", "--export-csv", "a.csv", "--export-csv", "b.csv"], "--export-csv given twice ('a.csv', "
                                                                           "then 'b.csv')"),
    (["replay", "t.rrd", "--screenshot", "a.png", "--screenshot", "b.png"], "--screenshot given twice"),
    (["replay", "t.rrd", "--screenshot", "a.png", "--time", "1", "--time", "2"], "--time given twice (1.0, then 2.0)"),
    (["reproduce", "--out", "a", "--out", "b"], "--out given twice"),
    (["reproduce", "--seed", "1", "--seed", "2"], "--seed given twice (1, then 2)"),
])
def test_an_option_given_twice_is_refused_not_overridden(argv, said, tmp_path, monkeypatch, capsys):
    """argparse keeps the last of a repeated option without a word: ``--out A --out B`` wrote to B only."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1 and said in err
    assert list(tmp_path.iterdir()) == []


def test_a_missing_task_file_is_named_before_the_output_folder(tmp_path, monkeypatch, capsys):
    """The default ``out`` holding a user's file was reported for a mistyped task path (the folder is
    checked before any work; a missing task file is cheaper to name and is the real problem)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "notes.txt").write_text("mine")
    assert main(["plan", "nonexistent.yaml"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nonexistent.yaml" in err and "out" not in err.replace("nonexistent", "")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["notes.txt"]


@pytest.mark.parametrize("argv, said", [
    (["plan", ""], "the task file's path is empty"),
    (["plan", "  "], "the task file's path is empty"),
    (["replay", ""], "the recording's path is empty"),
    (["replay", "{recording}", "--export-csv", ""], "output file is empty"),
    (["replay", "{recording}", "--screenshot", " "], "output file is empty"),
])
def test_an_empty_path_is_named_as_empty_not_taken_for_the_current_folder(argv, said, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    recording = tmp_path / "t.rrd"
    recording.write_bytes(b"")
    assert main([a.format(recording=recording) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and said in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.rrd"]


def test_a_python_task_takes_its_urdf_as_a_path_object():
    from planner import make_task
    task = make_task(robot={"urdf": ROOT / "robots" / "puma560.urdf", "tool_frame": "tool"},
                     joints_deg=[[0] * 6, [10] * 6])
    assert task.robot.urdf == (ROOT / "robots" / "puma560.urdf").resolve()


def test_progress_is_plain_lines_when_not_on_a_terminal(tmp_path, capsys):
    """Not on a terminal: one line per stage and per optimizer run on stdout, no control characters,
    nothing on stderr; --quiet prints nothing at all."""
    task = small_task(tmp_path, bounds_s=[3, 5])
    assert main(["plan", str(task), "--out", str(tmp_path / "a")]) == 0
    captured = capsys.readouterr()
    out = captured.out
    assert captured.err == ""
    assert "\r" not in out and "\033" not in out
    assert "timing 8 via-points (hybrid, cuckoo): total time 27 s, feasible" in out
    assert f"writing the outputs to {tmp_path / 'a'}" in out
    assert main(["plan", str(task), "--out", str(tmp_path / "b"), "--quiet"]) == 0
    assert capsys.readouterr() == ("", "")


def test_the_printed_replay_command_runs_as_shown(tmp_path):
    """What `make demo` prints (the command's own path, here .venv/bin/planner) runs in a new shell
    whose PATH does not hold the environment."""
    import os
    import shlex
    import subprocess
    import sys
    script = Path(sys.executable).parent / "planner"
    environment = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH")}
    environment["PATH"] = "/usr/bin:/bin"
    done = subprocess.run([str(script), "plan", str(small_task(tmp_path, bounds_s=[3, 5])), "--out", "out"],
                          cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    line = next(text for text in done.stdout.splitlines() if text.startswith("open the recording with: "))
    command = line.removeprefix("open the recording with: ").split("  (")[0] + " --check"
    assert command.startswith(f"{script} replay ")
    check = subprocess.run(command, shell=True, cwd=tmp_path, env=environment, capture_output=True, text=True,
                           timeout=300)
    assert check.returncode == 0 and "limits hold" in check.stdout, check.stderr
    assert shlex.split(command)[0] == str(script)


def test_verbose_logs_the_ik_choices_on_stderr_and_only_then(tmp_path, capsys):
    task = ROOT / "scripts" / "tasks" / "ur5_pick_and_place.yaml"
    assert main(["-v", "plan", str(task), "--out", str(tmp_path / "a"), "--quiet"]) == 0
    err = capsys.readouterr().err.splitlines()
    waypoints = len(yaml.safe_load(task.read_text())["waypoints"]["cartesian"])
    for rule in ("optimal", "continuous"):
        lines = [line for line in err if line.startswith(f"planner.ik: {rule} rule, waypoint ")]
        assert len(lines) == waypoints and "solution " in lines[0] and "margin to the ranges" in lines[0]
    starts = [line for line in err if line.startswith("planner.timing.nlp: start ")]
    assert starts and all(", feasible, IPOPT Solve_Succeeded, " in line for line in starts)
    assert not any(line.startswith("planner.timing.nlp: round ") for line in err)  # -vv only
    assert main(["plan", str(task), "--out", str(tmp_path / "b"), "--quiet"]) == 0
    assert capsys.readouterr().err == ""  # the handler went with the run


def test_a_live_terminal_sees_counts_and_the_last_one_ends_the_line():
    import io

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    terminal = Terminal()
    progress = TerminalProgress("inverse kinematics", status=terminal, min_interval_s=3600.0)
    for done in range(1, 6):
        progress.count(done, 5, "waypoints")
    progress.label = "timing"
    progress(2, 2, 17.3128)
    assert terminal.getvalue() == ("\rinverse kinematics: 1/5 waypoints\033[K"
                                   "\rinverse kinematics: 5/5 waypoints\033[K\n"
                                   "\rtiming: 2/2 iterations, best objective 17.3128\033[K\n")


def test_an_output_folder_with_a_newline_is_printed_escaped(tmp_path, capsys):
    """A name with a newline broke the success lines in two."""
    out = tmp_path / "o\nx"
    assert main(["plan", str(small_task(tmp_path)), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "o\\nx/: coefficients.json" in said and not any(line.startswith("x/") for line in said.splitlines())
    assert (out / "summary.json").is_file()


def test_a_successful_plan_says_nothing_on_stderr_even_when_matplotlib_cannot_cache(tmp_path):
    """With its cache folder unwritable, matplotlib logged two warning lines about using a temporary one."""
    import os
    import subprocess
    import sys

    environment = {**os.environ, "MPLCONFIGDIR": "/proc/unwritable"}
    done = subprocess.run([sys.executable, "-m", "planner.cli", "plan", str(small_task(tmp_path)), "--out",
                           str(tmp_path / "out"), "--quiet"], capture_output=True, text=True, env=environment,
                          timeout=120)
    assert (done.returncode, done.stderr, done.stdout) == (0, "", "")


@pytest.mark.parametrize("redirect, code", [(">&-", 0), ("2>&-", 0), ("| head -c 10 >/dev/null", 0),
                                            (">/dev/full", 0), ("MISSING 2>/dev/full", 2)])
def test_what_cannot_be_printed_is_dropped_and_the_exit_code_stands(tmp_path, redirect, code):
    """stdout or stderr closed, a pipe closed early, a full device: the plan is written and its exit code
    is its own (each was 'internal error', exit 1); a refused task with stderr full is still exit 2."""
    import shlex
    import subprocess
    import sys

    task = str(tmp_path / "missing.yaml") if redirect.startswith("MISSING") else str(small_task(tmp_path))
    command = (f"{shlex.quote(sys.executable)} -m planner.cli plan {shlex.quote(task)} --out out "
               f"{redirect.removeprefix('MISSING ')}; echo \"exit ${{PIPESTATUS[0]}}\" >&3")
    done = subprocess.run(["bash", "-c", f"exec 3>{shlex.quote(str(tmp_path / 'code'))}; {command}"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert (tmp_path / "code").read_text() == f"exit {code}\n", done.stderr
    assert "error" not in done.stderr and "Traceback" not in done.stderr
    written = sorted(p.name for p in (tmp_path / "out").iterdir()) if code == 0 else []
    assert written == ([] if code else [".planner-output", "coefficients.json", "profiles.png", "summary.json",
                                        "trajectory.csv", "trajectory.rrd"])


def test_a_huge_ratio_prints_in_a_few_characters():
    """``replay --check`` of a forged recording printed a largest ratio of 300 digits (sweep 11)."""
    from planner.cli import _ratio
    assert _ratio(0.99999) == "1.0000" and _ratio(1.23456) == "1.2346" and _ratio(9999.0) == "9999.0000"
    assert _ratio(3.7e300) == "3.7e+300" and _ratio(float("inf")) == "inf"


def test_a_run_the_time_limit_stopped_says_so_in_its_progress_and_result_lines(tmp_path, capsys):
    """The terminal said only "feasible" after a time-limited run (sweep 13), which may be far from optimal."""
    out = tmp_path / "out"
    assert main(["plan", str(small_task(tmp_path, time_limit_s=1e-9)), "--out", str(out)]) == 0
    printed = capsys.readouterr()
    text = printed.out + printed.err
    assert "feasible, stopped by the time limit of 1e-09 s (" in text
    assert "feasible True (stopped by the time limit: the best timing found by then)" in text
    assert main(["plan", str(small_task(tmp_path)), "--out", str(out), "--force"]) == 0
    assert "time limit" not in capsys.readouterr().out


def test_an_output_path_through_a_missing_folder_and_dot_dot_is_where_the_outputs_are_listed(tmp_path, capsys,
                                                                                             monkeypatch):
    """``--out nope/../res`` (no folder nope): the outputs were written to ./res, then listing them through
    the given text failed ("internal error: FileNotFoundError", exit 1) (sweep 21). Now they are listed
    there and the replay command printed names the folder the system reaches."""
    monkeypatch.chdir(tmp_path)
    assert main(["plan", str(small_task(tmp_path)), "--out", "nope/../res"]) == 0
    printed = capsys.readouterr().out
    assert (tmp_path / "res" / "summary.json").is_file() and not (tmp_path / "nope").exists()
    assert f"outputs in {tmp_path / 'res'}/: coefficients.json" in printed
    assert f"replay {tmp_path / 'res' / 'trajectory.rrd'}" in printed


def test_an_output_path_through_a_symbolic_link_and_dot_dot_goes_where_the_system_goes(tmp_path, capsys,
                                                                                       monkeypatch):
    """``link/../res`` with link -> far/sub is far/res to the system; the planner wrote ./res (``..`` taken as
    text before the link was followed) and then could not list it (sweep 21)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "far" / "sub").mkdir(parents=True)
    (tmp_path / "link").symlink_to(tmp_path / "far" / "sub")
    assert main(["plan", str(small_task(tmp_path)), "--out", "link/../res"]) == 0
    assert (tmp_path / "far" / "res" / "summary.json").is_file() and not (tmp_path / "res").exists()
    assert "outputs in link/../res/: coefficients.json" in capsys.readouterr().out


@pytest.mark.parametrize("name", ["...yaml", "..yaml", ".yaml", ".hidden.yaml"])
def test_a_task_file_whose_name_makes_no_output_folder_is_refused(tmp_path, capsys, monkeypatch, name):
    """The default folder out/TASK of a task file named ``...yaml`` was out/.., the current folder (and
    ``..yaml`` out/. , every task's): outputs landed beside the user's files (sweep 21); ``.yaml`` wrote
    to the hidden out/.yaml (sweep 27)."""
    monkeypatch.chdir(tmp_path)
    task = small_task(tmp_path).rename(tmp_path / name)
    assert main(["plan", str(task)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: the task file's name '{name}' names no output folder") and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_a_status_line_stopped_short_is_cleared_before_a_note_or_an_error(monkeypatch):
    """A search the time limit stopped, or an interruption, left the live status line open: the next stage
    note or the one-line error was appended to it ("...best objective 27interrupted", sweep 22)."""
    import io

    import planner.cli as cli

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    terminal, notes = Terminal(), io.StringIO()
    progress = TerminalProgress("timing", status=terminal, notes=notes, min_interval_s=0.0)
    progress(3, 100, 27.0)
    progress.note("timing 8 via-points: stopped by the time limit")
    progress.note("writing")  # nothing left to clear
    assert terminal.getvalue() == "\rtiming: 3/100 iterations, best objective 27\033[K\r\033[K"
    assert notes.getvalue() == "timing 8 via-points: stopped by the time limit\nwriting\n"
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    cli._error_line("interrupted")
    assert stderr.getvalue() == "\r\033[Kinterrupted\n"
