"""Output folders and files: checked before any work, locked, published in one step, never lose a file."""

import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

import planner.outputs as outputs
from planner.cli import main
from planner.errors import OutputError
from planner.outputs import MARKER, STAGING_MARKER, atomic_file, output_folder

ROOT = Path(__file__).resolve().parents[1]
PAPER_JOINT = ROOT / "scripts" / "tasks" / "puma560_paper_joint.yaml"


def write_outputs(path, texts: dict[str, str], **options) -> None:
    with output_folder(path, **options) as staging:
        for name, text in texts.items():
            (staging / name).write_text(text)


def contents(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in folder.iterdir()}


def leftovers(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if ".staging-" in p.name or p.name.endswith(".lock")
                  or ".old-" in p.name)


@pytest.fixture
def task(tmp_path) -> Path:
    data = yaml.safe_load(PAPER_JOINT.read_text())
    data["optimizer"] = {"algorithm": "cuckoo", "iterations": 3, "seed": 0, "bounds_s": [3, 5]}
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture
def no_planning(monkeypatch):
    """Fail the test if the planner starts computing (path errors must come first)."""
    import planner.pipeline as pipeline

    def forbidden(*args, **kwargs):
        raise AssertionError("planning started before the output path was checked")
    monkeypatch.setattr(pipeline, "plan", forbidden)


# ---------------------------------------------------------------- the rules


@pytest.mark.parametrize("empty", ["", "   "])
def test_empty_path_is_refused_and_nothing_is_written(tmp_path, monkeypatch, empty, no_planning, task, capsys):
    monkeypatch.chdir(tmp_path)
    before = sorted(os.listdir(tmp_path))
    with pytest.raises(OutputError, match="empty"):
        write_outputs(empty, {"a.txt": "x"})
    assert main(["plan", str(task), "--out", empty]) == 2
    assert "output folder is empty" in capsys.readouterr().err
    assert sorted(os.listdir(tmp_path)) == before


def test_existing_file_or_path_under_a_file_is_refused_before_planning(tmp_path, no_planning, task, capsys):
    afile = tmp_path / "notes.txt"
    afile.write_text("mine")
    for out, message in ((afile, "is an existing file"), (afile / "sub", "lies under"),
                         (afile / "a" / "b", "lies under")):
        assert main(["plan", str(task), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err and str(afile) in err
    assert afile.read_text() == "mine"


@pytest.mark.skipif(sys.platform != "linux", reason="names of any bytes: Linux file systems")
def test_a_path_that_is_not_utf8_is_refused_before_planning_and_reading(tmp_path, no_planning, task, capsys):
    from planner.errors import RecordingError
    from planner.recording import read_recording
    odd = os.fsdecode(os.fsencode(str(tmp_path)) + b"/o\xff")  # what Python makes of bytes that are not UTF-8
    for arguments in (["plan", str(task), "--out", odd], ["replay", str(task), "--export-csv", odd + ".csv"]):
        assert main(arguments) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "the path holds bytes that are not UTF-8" in err and "o\\udcff" in err
    with open(os.fsencode(odd), "wb") as file:  # a recording at such a path exists, and is named
        file.write(b"x")
    with pytest.raises(RecordingError, match=r"o\\udcff.: the path holds bytes that are not UTF-8 .* rename or link"):
        read_recording(odd)
    assert sorted(os.listdir(tmp_path)) == sorted(["task.yaml", os.fsdecode(b"o\xff")])


@pytest.mark.skipif(sys.platform != "linux", reason="the C locale's ASCII filesystem encoding")
def test_utf8_paths_under_an_ascii_filesystem_encoding_are_refused_for_that_reason(tmp_path, task):
    """With LC_ALL=C and PYTHONUTF8=0 Python cannot show a UTF-8 name: the output folder was refused as
    'bytes that are not UTF-8', and a task's existing non-ASCII URDF as 'file not found' (sweep 10, F3).
    Both now say that the encoding is the cause and how to change it; nothing is written."""
    import subprocess
    folder = tmp_path / "dossier_é"
    folder.mkdir()
    (folder / "pümä.urdf").write_text((Path(__file__).parents[1] / "robots" / "puma560.urdf").read_text())
    with_urdf = folder / "task.yaml"
    data = yaml.safe_load(task.read_text())
    data["robot"] = {"urdf": "pümä.urdf", "tool_frame": "tool"}
    with_urdf.write_text(yaml.safe_dump(data, allow_unicode=True), encoding="utf-8")
    environment = {**os.environ, "LC_ALL": "C", "PYTHONUTF8": "0"}
    for arguments in ([str(task), "--out", str(folder / "sortie")], [str(with_urdf), "--out", str(tmp_path / "o")]):
        done = subprocess.run([sys.executable, "-m", "planner.cli", "plan", *arguments], capture_output=True,
                              env=environment, timeout=120)
        err = done.stderr.decode("ascii", "backslashreplace")
        assert done.returncode == 2 and err.count("\n") == 1, err
        assert "filesystem encoding here is 'ascii'" in err and "PYTHONUTF8=1" in err, err
        assert "not UTF-8" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["dossier_é", "task.yaml"])
    assert sorted(p.name for p in folder.iterdir()) == ["pümä.urdf", "task.yaml"]


def test_an_output_file_ending_with_a_separator_is_refused_as_a_folder(tmp_path):
    for name in ("new/", "new" + os.sep):
        with pytest.raises(OutputError, match="ends with a path separator, which names a folder"):
            outputs.check_output_file(str(tmp_path / "x") + "/" + name)
    assert list(tmp_path.iterdir()) == []


def test_folder_of_other_files_is_refused_unless_forced(tmp_path):
    out = tmp_path / "results"
    out.mkdir()
    (out / "summary.json").write_text("the user's own")
    (out / "thesis.tex").write_text("keep me")
    with pytest.raises(OutputError, match=r"did not write \('summary.json, thesis.tex'\).*--force"):
        write_outputs(out, {"summary.json": "new"})
    assert contents(out) == {"summary.json": "the user's own", "thesis.tex": "keep me"}
    write_outputs(out, {"summary.json": "new", "trajectory.csv": "t"}, force=True)
    assert contents(out) | {MARKER: ""} == {"summary.json": "new", "trajectory.csv": "t", "thesis.tex": "keep me",
                                            MARKER: ""}
    assert leftovers(tmp_path) == []


def tree(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): p.read_text() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_folder_where_an_output_file_goes_is_refused_and_nothing_is_merged(tmp_path, no_planning, task, capsys):
    """--force merges file by file: a folder named like an output would stop the merge half done.
    Refused before planning when the names are known, and at publishing, before any move, when not."""
    out = tmp_path / "results"
    (out / "trajectory.rrd").mkdir(parents=True)
    (out / "trajectory.rrd" / "inner.txt").write_text("mine")
    (out / "notes.txt").write_text("keep me")
    before = tree(out)
    assert main(["plan", str(task), "--out", str(out), "--force"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds a folder named 'trajectory.rrd'" in err
    with pytest.raises(OutputError, match="holds a folder named 'trajectory.rrd'"):
        write_outputs(out, {"summary.json": "new", "trajectory.rrd": "new"}, force=True)
    assert tree(out) == before and leftovers(tmp_path) == []


def test_a_run_into_the_folder_of_another_runs_output_does_not_delete_it(tmp_path):
    """Run A writes DIR; while it works, run B publishes DIR/sub. A must not swap DIR out whole (B's
    outputs would go with it): refused, or merged file by file with --force."""
    out = tmp_path / "o"
    write_outputs(out, {"a.txt": "old"})
    with pytest.raises(OutputError, match="did not write \\('sub'\\)"):
        with output_folder(out) as staging:
            (staging / "a.txt").write_text("new")
            write_outputs(out / "sub", {"b.txt": "B's"})
    assert (out / "sub" / "b.txt").read_text() == "B's" and (out / "a.txt").read_text() == "old"
    with output_folder(out, force=True) as staging:
        (staging / "a.txt").write_text("new")
        write_outputs(out / "sub2", {"c.txt": "C's"})
    assert (out / "sub2" / "c.txt").read_text() == "C's" and (out / "a.txt").read_text() == "new"
    assert leftovers(tmp_path) == [] and leftovers(out) == []


def test_staging_left_inside_a_forced_folder_by_a_killed_run_is_removed_by_the_next(tmp_path):
    out = tmp_path / "results"
    out.mkdir()
    (out / "thesis.tex").write_text("keep me")
    (out / ".results.staging-0badc0de").mkdir()  # what a SIGKILL during a --force run leaves
    (out / ".results.staging-0badc0de" / STAGING_MARKER).touch()
    write_outputs(out, {"summary.json": "new"}, force=True)
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "summary.json", "thesis.tex"]


def test_a_plan_writes_exactly_its_declared_files(tmp_path, task):
    from planner.pipeline import OUTPUT_FILES, plan
    plan(task).save(tmp_path / "out")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted((MARKER, *OUTPUT_FILES))


def test_planner_folder_is_replaced_whole_in_one_step(tmp_path):
    out = tmp_path / "out"
    write_outputs(out, {"a.txt": "1", "b.txt": "1"})
    inode = out.stat().st_ino
    write_outputs(out, {"a.txt": "2", "c.txt": "2"})
    assert contents(out) == {"a.txt": "2", "c.txt": "2", MARKER: (out / MARKER).read_text()}
    assert out.stat().st_ino != inode  # a new folder took the old one's place: no file-by-file moves
    assert leftovers(tmp_path) == [] and sorted(os.listdir(tmp_path)) == ["out"]


def _staged(path, texts: dict[str, str], **options) -> dict[str, int]:
    """``write_outputs``, returning the inode of the staging folder (key ".") and of each file written."""
    with output_folder(path, **options) as staging:
        for name, text in texts.items():
            (staging / name).write_text(text)
        return {".": staging.stat().st_ino} | {name: (staging / name).stat().st_ino for name in texts}


@pytest.mark.parametrize("before", ["none", "planner's", "forced"])
def test_what_is_published_is_what_was_staged_moved_not_copied(tmp_path, before):
    """Publishing moves the staged folder (a new or a planner's folder: the folder itself) or its files
    (``--force`` into a folder of the user's) by renames: the same inodes, so nothing was copied, and a
    reader never sees a half-copied file. Copies passed every test before: the cleanup removes whatever
    they leave (#20's audit)."""
    out = tmp_path / "out"
    if before == "planner's":
        write_outputs(out, {"a.txt": "0"})
    elif before == "forced":
        out.mkdir()
        (out / "mine.txt").write_text("user")
    staged = _staged(out, {"a.txt": "1", "b.txt": "2"}, force=before == "forced")
    assert contents(out) | {MARKER: ""} == {"a.txt": "1", "b.txt": "2", MARKER: ""} | (
        {"mine.txt": "user"} if before == "forced" else {})
    assert {name: (out / name).stat().st_ino for name in ("a.txt", "b.txt")} == \
        {name: staged[name] for name in ("a.txt", "b.txt")}
    if before != "forced":
        assert out.stat().st_ino == staged["."]
    assert leftovers(tmp_path) == [] and leftovers(out) == []


@pytest.mark.parametrize("existing", [False, True])
def test_a_single_file_is_published_by_one_rename(tmp_path, existing):
    """``atomic_file`` (``--export-csv``, ``--screenshot``) renames its temporary file onto the target:
    the same inode, nothing else left in the folder."""
    target = tmp_path / "x.csv"
    if existing:
        target.write_text("old")
    with atomic_file(target, force=existing) as temporary:
        temporary.write_text("new")
        inode = temporary.stat().st_ino
    assert target.read_text() == "new" and target.stat().st_ino == inode
    assert sorted(os.listdir(tmp_path)) == ["x.csv"]


def test_another_commands_outputs_are_kept_as_a_users_files(tmp_path):
    """A reproduction into a plan's folder replaced it whole: the plan's outputs were deleted without a
    word, --force or not (sweep 17). A run that names its files now refuses the planner's files of other
    names, and --force writes beside them, keeping them (and the marker keeps them the planner's)."""
    out = tmp_path / "out"
    plan_files, report_files = ("summary.json", "trajectory.csv"), ("reproduction.md",)
    write_outputs(out, {"summary.json": "plan", "trajectory.csv": "t"}, files=plan_files)
    with pytest.raises(OutputError, match=r"holds outputs the planner wrote that this run does not write "
                                          r"\('summary.json, trajectory.csv': another command's.*--force \(force=True "
                                          r"from Python\) to write beside them"):
        write_outputs(out, {"reproduction.md": "report"}, files=report_files)
    assert contents(out) | {MARKER: ""} == {"summary.json": "plan", "trajectory.csv": "t", MARKER: ""}
    write_outputs(out, {"reproduction.md": "report"}, files=report_files, force=True)
    assert contents(out) | {MARKER: ""} == {"summary.json": "plan", "trajectory.csv": "t", "reproduction.md": "report",
                                            MARKER: ""}
    write_outputs(out, {"summary.json": "plan 2", "trajectory.csv": "t2"}, files=plan_files, force=True)
    assert contents(out) | {MARKER: ""} == {"summary.json": "plan 2", "trajectory.csv": "t2",
                                            "reproduction.md": "report", MARKER: ""}
    assert outputs._planner_files(out) == {"summary.json", "trajectory.csv", "reproduction.md"}
    write_outputs(out, {"summary.json": "plan 3", "x.csv": "x"}, files=("summary.json", "x.csv"),
                  force=True)  # a plan file this run does not write is the planner's of another name: kept
    assert (out / "trajectory.csv").read_text() == "t2"
    # Another command's file deleted by the user drops out of the marker at the next write beside it.
    (out / "reproduction.md").unlink()
    write_outputs(out, {"summary.json": "plan 4"}, files=("summary.json",), force=True)
    assert outputs._planner_files(out) == {"summary.json", "trajectory.csv", "x.csv"}
    # A run that does not name its files replaces the planner's whole (--force): the marker lists only its own.
    write_outputs(out, {"a.txt": "a"}, force=True)
    assert outputs._planner_files(out) == set(contents(out)) - {MARKER}
    assert leftovers(tmp_path) == []


def test_a_refusal_of_many_of_another_commands_outputs_names_five_and_says_there_are_more(tmp_path):
    out = tmp_path / "out"
    many = {f"file{k}.csv": str(k) for k in range(7)}
    write_outputs(out, many, files=tuple(many))
    with pytest.raises(OutputError, match=r"\('file0.csv, file1.csv, file2.csv, file3.csv, file4.csv, \.\.\.': "
                                          r"another command's"):
        write_outputs(out, {"report.md": "r"}, files=("report.md",))


def test_the_plan_command_writes_to_out_and_the_task_files_name_by_default(tmp_path, monkeypatch, task, capsys):
    """``plan``'s default folder was ``out``, in which ``reproduce``'s default ``out/reproduce`` then
    stood as a foreign file: plan, reproduce, plan was refused (sweep 17)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out" / "reproduce").mkdir(parents=True)  # as reproduce leaves it (its content is its own)
    assert main(["plan", str(task), "--quiet"]) == 0
    assert (tmp_path / "out" / "task" / "summary.json").is_file()
    assert main(["plan", str(task), "--quiet"]) == 0  # its own folder: replaced whole


def test_a_file_added_by_the_user_to_a_planner_folder_is_never_deleted(tmp_path):
    out = tmp_path / "out"
    write_outputs(out, {"a.txt": "1"})
    (out / "my_notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="my_notes.txt"):
        write_outputs(out, {"a.txt": "2"})
    assert (out / "my_notes.txt").read_text() == "mine" and (out / "a.txt").read_text() == "1"


def test_empty_existing_folder_and_missing_parents_are_fine(tmp_path):
    (tmp_path / "empty").mkdir()
    write_outputs(tmp_path / "empty", {"a.txt": "1"})
    write_outputs(tmp_path / "x" / "y" / "z", {"a.txt": "1"})
    assert (tmp_path / "empty" / "a.txt").exists() and (tmp_path / "x" / "y" / "z" / "a.txt").exists()


def test_current_folder_is_written_in_place_and_stays_usable(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_outputs(".", {"a.txt": "1"})
    write_outputs(".", {"a.txt": "2", "b.txt": "2"})
    assert Path.cwd().samefile(tmp_path) and (tmp_path / "a.txt").read_text() == "2"
    write_outputs(".", {"b.txt": "3"})
    assert not (tmp_path / "a.txt").exists()  # the planner's own stale file goes, as in a whole swap
    assert leftovers(tmp_path) == []


# ---------------------------------------------------------------- faults


def test_failure_inside_the_block_keeps_the_old_outputs(tmp_path):
    out = tmp_path / "out"
    write_outputs(out, {"a.txt": "old"})
    with pytest.raises(RuntimeError):
        with output_folder(out) as staging:
            (staging / "a.txt").write_text("new")
            raise RuntimeError("disk full")
    assert (out / "a.txt").read_text() == "old" and leftovers(tmp_path) == []


def test_failed_run_removes_the_parents_it_made(tmp_path):
    (tmp_path / "a").mkdir()
    with pytest.raises(RuntimeError):
        with output_folder(tmp_path / "a" / "b" / "c" / "out"):
            raise RuntimeError("infeasible")
    assert sorted(os.listdir(tmp_path)) == ["a"] and os.listdir(tmp_path / "a") == []


@pytest.mark.parametrize("exchange_available", [True, False])
def test_failing_publish_keeps_the_old_outputs(tmp_path, monkeypatch, exchange_available):
    out = tmp_path / "out"
    write_outputs(out, {"a.txt": "old"})
    real_rename = os.rename

    def failing_exchange(first, second):
        raise OSError(5, "Input/output error")

    def failing_second_rename(source, target):
        if ".staging-" in str(source):
            raise OSError(5, "Input/output error")
        real_rename(source, target)
    if exchange_available:
        monkeypatch.setattr(outputs, "_exchange", failing_exchange)
    else:
        monkeypatch.setattr(outputs, "_exchange", lambda first, second: False)
        monkeypatch.setattr(outputs.os, "rename", failing_second_rename)
    with pytest.raises(OutputError, match=r"cannot write the outputs \(Input/output error\)"):
        write_outputs(out, {"a.txt": "new"})
    assert contents(out) == {"a.txt": "old", MARKER: (out / MARKER).read_text()}
    monkeypatch.undo()
    assert leftovers(tmp_path) == []


def test_without_exchange_the_fallback_still_publishes_whole(tmp_path, monkeypatch):
    monkeypatch.setattr(outputs, "_exchange", lambda first, second: False)
    out = tmp_path / "out"
    write_outputs(out, {"a.txt": "1"})
    write_outputs(out, {"b.txt": "2"})
    assert sorted(os.listdir(out)) == [MARKER, "b.txt"] and leftovers(tmp_path) == []


def test_a_second_writer_is_refused_while_the_first_holds_the_folder(tmp_path, task, capsys):
    out = tmp_path / "out"
    with output_folder(out) as staging:
        (staging / "a.txt").write_text("first")
        assert main(["plan", str(task), "--out", str(out)]) == 2
        assert "being written by another planner process" in capsys.readouterr().err
        with pytest.raises(OutputError, match="another planner process"):
            write_outputs(out, {"a.txt": "second"})
    assert (out / "a.txt").read_text() == "first" and leftovers(tmp_path) == []


def test_staging_left_by_a_killed_run_is_removed_by_the_next(tmp_path):
    stale = tmp_path / ".out.staging-deadbeef"
    stale.mkdir()
    (stale / STAGING_MARKER).touch()
    (stale / "half.csv").write_text("1,2")
    (tmp_path / ".out.staging-0badc0de").mkdir()  # emptied, marker and all, by a run whose folder turned read-only
    write_outputs(tmp_path / "out", {"a.txt": "1"})
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("name", [".out.staging-mine", ".out.staging-deadbeef", ".out.staging-deadbeef0"])
def test_a_folder_named_like_staging_is_kept_unless_the_planner_made_it(tmp_path, name):
    """Only ``.out.staging-`` and 8 hex digits holding the staging marker is a killed run's: a user's
    folder of a similar name, or of that name without the marker, is kept with its files."""
    mine = tmp_path / name
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    write_outputs(tmp_path / "out", {"a.txt": "1"})
    assert (mine / "notes.txt").read_text() == "keep me"


def test_an_output_folder_name_is_not_a_glob_pattern(tmp_path):
    """``--out 'o[u]'`` must not match, and delete, the staging folder of a run writing ``ou``."""
    other = tmp_path / ".ou.staging-12345678"
    other.mkdir()
    (other / STAGING_MARKER).touch()
    write_outputs(tmp_path / "o[u]", {"a.txt": "1"})
    assert other.is_dir() and (tmp_path / "o[u]" / "a.txt").read_text() == "1"


def test_a_marker_that_is_a_folder_is_not_the_planners(tmp_path):
    out = tmp_path / "out"
    (out / MARKER).mkdir(parents=True)
    (out / MARKER / "notes.txt").write_text("keep me")
    with pytest.raises(OutputError, match="did not write"):
        write_outputs(out, {"a.txt": "1"})
    assert (out / MARKER / "notes.txt").read_text() == "keep me"


@pytest.mark.parametrize("kind", ["pipe", "link to /dev/zero", "too large"])
def test_a_marker_that_is_no_small_regular_file_is_not_read(tmp_path, kind):
    """A pipe named as the marker hung the run, a link to /dev/zero read until memory ran out (sweep 26): the
    marker is read without following a link or waiting, and only where it is a regular file of at most
    ``MAX_MARKER_BYTES``; else the folder is not the planner's."""
    out = tmp_path / "out"
    out.mkdir()
    if kind == "pipe":
        os.mkfifo(out / MARKER)
    elif kind == "too large":
        (out / MARKER).write_text('{"files": {}}' + " " * outputs.MAX_MARKER_BYTES)
    else:
        (out / MARKER).symlink_to("/dev/zero")
    started = time.monotonic()
    with pytest.raises(OutputError, match="did not write"):
        write_outputs(out, {"a.txt": "1"})
    assert time.monotonic() - started < 10 and sorted(os.listdir(out)) == [MARKER]
    write_outputs(out, {"a.txt": "1"}, force=True)
    assert (out / "a.txt").read_text() == "1" and (out / MARKER).is_file() and not (out / MARKER).is_symlink()


def test_a_folder_whose_parent_is_not_writable_is_written_in_place_and_locked_inside(tmp_path, monkeypatch):
    """A container's bind mount (``docker run --user 1000 -v $PWD/out:/out``): the folder is writable, its
    parent is not, and the lock and staging folder beside it were refused (sweep 26). Root may write anywhere,
    so the parent's permission is what ``_writable_parent`` reports here."""
    parent = tmp_path / "readonly"
    out = parent / "out"
    out.mkdir(parents=True)
    monkeypatch.setattr(outputs, "_writable_parent", lambda folder: folder.parent != parent)
    with output_folder(out) as staging:
        assert staging.parent == out and (out / outputs.INSIDE_LOCK).is_file()
        with pytest.raises(OutputError, match=f"output folder {re.escape(str(out))} is being written by another"):
            with output_folder(out):
                pass
        (staging / "a.txt").write_text("1")
    assert sorted(os.listdir(out)) == [MARKER, "a.txt"] and os.listdir(parent) == ["out"]
    write_outputs(out, {"a.txt": "2"})  # the planner's own folder again
    assert contents(out) == {"a.txt": "2", MARKER: (out / MARKER).read_text()} and os.listdir(parent) == ["out"]
    with pytest.raises(OutputError, match="cannot write in"):  # an absent folder there cannot be made
        monkeypatch.setattr(outputs.os, "access", lambda path, mode: Path(path) != parent)
        write_outputs(parent / "new", {"a.txt": "1"})


def test_a_lock_file_holding_data_is_refused_and_kept(tmp_path):
    lock = tmp_path / ".out.lock"
    lock.write_text("my data")
    with pytest.raises(OutputError, match="not a planner lock file"):
        write_outputs(tmp_path / "out", {"a.txt": "1"})
    assert lock.read_text() == "my data" and not (tmp_path / "out").exists()


def test_sigterm_while_planning_cleans_up_and_exits_143(tmp_path, task):
    out = tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "planner.cli", "plan", str(task), "--out", str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 30
    while not list(tmp_path.glob(".out.staging-*")) and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    assert process.poll() is None, "the plan finished before it could be interrupted"
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143 and err == "terminated\n"
    assert not out.exists() and leftovers(tmp_path) == []


def test_output_on_another_filesystem(tmp_path):
    shm = Path("/dev/shm")
    if not shm.is_dir() or not os.access(shm, os.W_OK) or shm.stat().st_dev == tmp_path.stat().st_dev:
        pytest.skip("no second writable filesystem")
    out = shm / f"planner-test-{os.getpid()}"
    try:
        write_outputs(out, {"a.txt": "1"})
        write_outputs(out, {"a.txt": "2"})
        assert (out / "a.txt").read_text() == "2"
        assert not [p for p in shm.iterdir() if p.name.startswith(f".{out.name}.")]
    finally:
        import shutil
        shutil.rmtree(out, ignore_errors=True)


# ---------------------------------------------------------------- permissions and single files


def test_published_files_and_folder_follow_the_umask(tmp_path):
    previous = os.umask(0o022)
    try:
        write_outputs(tmp_path / "out", {"a.txt": "1"})
        with atomic_file(tmp_path / "export.csv") as staging:
            staging.write_text("t\n")
    finally:
        os.umask(previous)
    assert stat.S_IMODE((tmp_path / "out").stat().st_mode) == 0o755
    assert stat.S_IMODE((tmp_path / "out" / "a.txt").stat().st_mode) == 0o644
    assert stat.S_IMODE((tmp_path / "export.csv").stat().st_mode) == 0o644


def test_atomic_file_refuses_folders_and_paths_under_files(tmp_path):
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("mine")
    for target, message in ((tmp_path / "folder", "existing folder"), (tmp_path / "file" / "x.csv", "lies under"),
                            ("", "empty")):
        with pytest.raises(OutputError, match=message):
            with atomic_file(target):
                raise AssertionError("the block must not run")
    assert sorted(os.listdir(tmp_path)) == ["file", "folder"] and (tmp_path / "file").read_text() == "mine"


def test_python_api_save_follows_the_same_rules(tmp_path, task):
    from planner import plan
    result = plan(task)
    with pytest.raises(OutputError, match="empty"):
        result.save("")
    (tmp_path / "theirs").mkdir()
    (tmp_path / "theirs" / "x").write_text("x")
    with pytest.raises(OutputError, match="--force"):
        result.save(tmp_path / "theirs")
    result.save(tmp_path / "theirs", force=True)
    assert (tmp_path / "theirs" / "x").read_text() == "x" and (tmp_path / "theirs" / "summary.json").exists()


def test_a_file_the_marker_lists_that_changed_since_is_the_users(tmp_path):
    """The marker keeps each published file's size and modification time: a file edited since, or one
    a copied or hand-written marker lists, is not the planner's and is never replaced or removed
    without force."""
    out = tmp_path / "out"
    write_outputs(out, {"a.txt": "1", "b.txt": "1"})
    write_outputs(out, {"a.txt": "2", "b.txt": "2"})  # unchanged since: the planner's, replaced whole
    os.utime(out / "b.txt", ns=(0, 0))  # touched by the user (same size, another time)
    with pytest.raises(OutputError, match=r"did not write \('b.txt'\)"):
        write_outputs(out, {"a.txt": "3"})
    write_outputs(out, {"a.txt": "3"}, force=True)  # b.txt is neither the planner's output nor stale
    assert contents(out) == {"a.txt": "3", "b.txt": "2", MARKER: (out / MARKER).read_text()}

    other = tmp_path / "other"
    other.mkdir()
    (other / "a.txt").write_text("the user's")
    shutil.copy(out / MARKER, other / MARKER)  # a marker copied beside a file of a listed name
    with pytest.raises(OutputError, match=r"did not write \('a.txt'\)"):
        write_outputs(other, {"a.txt": "4"})
    (other / MARKER).write_text('{"written_by": "planner", "files": ["a.txt"]}')  # an older planner's, or by hand
    with pytest.raises(OutputError, match="written by an older version of the planner.*--force"):
        write_outputs(other, {"a.txt": "4"})
    for text in ("[1, 2]", '"files"', "null"):  # a marker that holds no object is nobody's
        (other / MARKER).write_text(text)
        with pytest.raises(OutputError, match="did not write"):
            write_outputs(other, {"a.txt": "4"})
    assert (other / "a.txt").read_text() == "the user's"


def test_a_forged_marker_cannot_reach_outside_the_folder(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / MARKER).write_text('{"files": ["../victim.txt", "notes.txt"]}')
    with pytest.raises(OutputError, match="did not write"):  # the marker is not the planner's
        write_outputs(out, {"a.txt": "1"})
    write_outputs(out, {"a.txt": "1"}, force=True)
    assert victim.read_text() == "keep me" and (out / "notes.txt").read_text() == "mine"


def test_special_files_are_never_replaced(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for target in (Path("/dev/null"), fifo):
        with pytest.raises(OutputError, match="not a regular file"):
            with atomic_file(target):
                raise AssertionError("the block must not run")
    assert Path("/dev/null").is_char_device() and stat.S_ISFIFO(fifo.stat().st_mode)


@pytest.mark.parametrize("path, message", [
    ("/proc/planner-test-out", "cannot write there"),
    ("x" * 300, "File name too long"),
    (42, "must be a path"),
    (b"out", "must be a path"),
    ("a\0b", "NUL"),
    ("/", "is the filesystem's root"),
])
def test_unusable_output_paths_are_output_errors(tmp_path, monkeypatch, path, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(OutputError, match=message):
        write_outputs(path, {"a.txt": "1"})
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_is_an_output_error_and_leaves_the_folder_as_it_was(tmp_path):
    import errno

    out = tmp_path / "out"
    write_outputs(out, {"a.txt": "first"})
    with pytest.raises(OutputError, match=r"output folder .*: cannot write the outputs \(No space left on device\)"):
        with output_folder(out) as staging:
            (staging / "a.txt").write_text("second")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert contents(out) == {"a.txt": "first", MARKER: (out / MARKER).read_text()} and leftovers(tmp_path) == []
    with pytest.raises(OutputError, match=r"export.csv'?: cannot write it \(No space left on device\)"):
        with atomic_file(tmp_path / "export.csv") as staging:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert not (tmp_path / "export.csv").exists() and not list(tmp_path.glob(".export.csv.*"))


def test_a_single_file_where_no_file_can_be_made_is_an_output_error():
    with pytest.raises(OutputError, match=r"/proc/planner-test.csv'?: cannot write it"):
        with atomic_file("/proc/planner-test.csv"):
            pass


def test_an_existing_file_is_replaced_only_with_force(tmp_path):
    target = tmp_path / "export.csv"
    target.write_text("precious")
    with pytest.raises(OutputError, match="exists; add --force to replace it"):
        with atomic_file(target) as staging:
            staging.write_text("new")
    assert target.read_text() == "precious"
    with atomic_file(target, force=True) as staging:
        staging.write_text("new")
    assert target.read_text() == "new"


@pytest.mark.parametrize("length", [238, 240, 249, 250, 255])
def test_a_name_too_long_for_its_staging_folder_says_how_long_it_may_be(tmp_path, length):
    """A new folder of 238-255 bytes is a valid name, but the staging folder beside it is 18 bytes
    longer (and its lock 6 bytes: from 250 bytes on, the lock failed first, without the hint; sweep 18):
    the message says so, and a name of 237 bytes is written."""
    with pytest.raises(OutputError, match=r"File name too long\); the planner locks it as \.NAME\.lock and stages "
                                          r"its outputs as \.NAME\.staging-XXXXXXXX, up to 18 bytes longer than its "
                                          r"name: shorten it to at most 237 bytes$"):
        with outputs.output_folder(tmp_path / ("n" * length), files=["a.txt"]):
            pass
    assert not any(tmp_path.iterdir())
    with outputs.output_folder(tmp_path / ("n" * 237), files=["a.txt"]) as staging:
        (staging / "a.txt").write_text("written")
    assert (tmp_path / ("n" * 237) / "a.txt").read_text() == "written"


def test_a_lock_file_the_run_cannot_remove_is_named_beside_the_refusal(tmp_path, monkeypatch):
    """A folder made read-only during a run: the pre-publish check's refusal was replaced by the lock file's
    PermissionError (an internal error, exit 1), and the lock file and staging folder were left unsaid (sweep 22)."""
    real = os.unlink

    def unlink(path, *args, **kwargs):
        if str(path).endswith(".lock"):
            raise PermissionError(13, "Permission denied", str(path))
        return real(path, *args, **kwargs)

    monkeypatch.setattr(os, "unlink", unlink)
    with pytest.raises(OutputError) as refusal:
        with output_folder(tmp_path / "out"):
            raise OutputError("the run's own refusal")
    assert str(refusal.value) == (f"the run's own refusal; the run's '{tmp_path / '.out.lock'}' could not be removed "
                                  f"(Permission denied): remove it once the folder is writable again")
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.lock"]  # the staging folder went
    with output_folder(tmp_path / "out2") as staging:  # published: the empty lock file stays, unsaid
        (staging / "a.txt").write_text("kept")
    assert (tmp_path / "out2" / "a.txt").read_text() == "kept"


def _interrupted_after_first(monkeypatch, name: str):
    """Make ``os.<name>`` record a Ctrl-C (as the command line's handler does) after its first call."""
    from planner import interrupts
    real, calls = getattr(os, name), []

    def moved(*args, **kwargs):
        real(*args, **kwargs)
        calls.append(args)
        if len(calls) == 1:
            interrupts.request(KeyboardInterrupt())
    monkeypatch.setattr(os, name, moved)
    return calls


@pytest.mark.parametrize("way", ["in place", "renamed aside"])
def test_an_interruption_while_publishing_waits_until_the_folder_is_whole(way, tmp_path, monkeypatch):
    """A Ctrl-C between two of publishing's renames left half the folder new (in place, beside a user's file),
    or the folder gone (where the system has no atomic exchange: renamed aside, then the staging folder in;
    sweep 22). It now waits for the end of publishing, after which the work is done and it changes nothing."""
    from planner import interrupts
    interrupts.reset()
    folder = tmp_path / "o"
    names = ("a.txt", "b.txt")
    with output_folder(folder, files=names) as staging:
        for name in names:
            (staging / name).write_text("old")
    if way == "in place":
        (folder / "notes.txt").write_text("the user's")
    else:
        monkeypatch.setattr(outputs, "_exchange", lambda first, second: False)
    interrupts.reset()
    calls = _interrupted_after_first(monkeypatch, "replace" if way == "in place" else "rename")
    try:
        with output_folder(folder, force=True, files=names) as staging:
            for name in names:
                (staging / name).write_text("new")
        assert len(calls) >= 2  # the interruption came between two renames
        assert [(folder / name).read_text() for name in names] == ["new", "new"]
        interrupts.check()  # published: it changes nothing now
    finally:
        interrupts.reset()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


def test_an_interruption_before_publishing_publishes_nothing(tmp_path):
    from planner import interrupts
    interrupts.reset()
    try:
        with pytest.raises(KeyboardInterrupt):
            with output_folder(tmp_path / "o") as staging:
                (staging / "a.txt").write_text("new")
                with interrupts.deferred():  # recorded, and raised as the block ends
                    interrupts.request(KeyboardInterrupt())
    finally:
        interrupts.reset()
    assert list(tmp_path.iterdir()) == []


def test_a_file_is_abandoned_only_once_unlocked_and_a_minute_unchanged(tmp_path):
    """What a run killed outright leaves (a temporary output file, the viewer's scratch folder's lock) is
    removed by later runs only when no process holds its lock and it is a minute old (sweep 22)."""
    import fcntl
    path = tmp_path / ".x.png.0123abcd.tmp"
    path.write_bytes(b"")
    assert not outputs.abandoned(path)  # just made: its maker may not hold the lock yet
    long_ago = time.time() - outputs.ABANDONED_AFTER_S - 1
    os.utime(path, (long_ago, long_ago))
    held = os.open(path, os.O_RDONLY)
    fcntl.flock(held, fcntl.LOCK_EX)
    try:
        assert not outputs.abandoned(path)  # a live run's
    finally:
        os.close(held)
    assert outputs.abandoned(path) and not outputs.abandoned(tmp_path / "missing")
    with atomic_file(tmp_path / "x.png") as temporary:  # a new run of the same file removes it
        temporary.write_bytes(b"png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.png"]


def test_outputs_go_into_folders_1500_deep(tmp_path):
    """``Path.mkdir(parents=True)`` recurses once per level: a path 1500 folders deep (legal on Linux) was a
    ``RecursionError``, said by the command line as an internal error. The folders are made, and the files
    written there."""
    deep = tmp_path.joinpath(*["d"] * 1500)
    try:
        write_outputs(deep / "out", {"a.txt": "x"})
        assert contents(deep / "out") == {"a.txt": "x", MARKER: (deep / "out" / MARKER).read_text()}
        with atomic_file(deep / "more" / "b.csv") as temporary:
            temporary.write_text("y")
        assert (deep / "more" / "b.csv").read_text() == "y"
    finally:  # removed level by level (shutil.rmtree recurses as deep as the tree)
        for folder in (deep / "out", deep / "more"):
            for entry in folder.iterdir() if folder.is_dir() else ():
                entry.unlink()
            folder.rmdir() if folder.is_dir() else None
        while deep != tmp_path and deep.is_dir():
            deep.rmdir()
            deep = deep.parent
