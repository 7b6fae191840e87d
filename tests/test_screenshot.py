"""``planner replay FILE --screenshot OUT.png [--time T]``: Rerun's headless viewer renders the recording.

The rendering test needs a graphics adapter (a GPU, or Mesa's software Vulkan driver: apt-get install
mesa-vulkan-drivers); where there is none it is skipped, saying why. The failure paths run everywhere.
"""

import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from planner.cli import main
from planner.outputs import atomic_file
from planner.pipeline import plan
from planner.recording import write_recording

ROOT = Path(__file__).resolve().parents[1]
TASKS = ROOT / "scripts" / "tasks"


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("screenshot") / "ur5.rrd"
    write_recording(plan(TASKS / "ur5_pick_and_place.yaml"), path)
    return path


def leftovers(folder: Path, *keep: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p not in keep)


def test_a_screenshot_shows_the_robot_and_drawn_curves(recording, tmp_path, capsys):
    import tempfile

    from PIL import Image

    out = tmp_path / "shots" / "ur5.png"
    scratch = set(Path(tempfile.gettempdir()).glob("rerun-data-*"))
    code = main(["replay", str(recording), "--screenshot", str(out), "--time", "2"])
    printed, err = capsys.readouterr()
    if code == 2 and ("no graphics adapter" in err or "no `rerun` program" in err):
        pytest.skip(f"no headless rendering here: {err.strip()}")
    assert code == 0, err
    assert printed == f"written (--screenshot): {out} (the recording at 2 s)\n"
    assert leftovers(out.parent) == ["ur5.png"]  # written under a temporary name, then renamed
    assert set(Path(tempfile.gettempdir()).glob("rerun-data-*")) <= scratch  # the viewer's scratch folder is gone
    image = np.asarray(Image.open(out).convert("RGB")).astype(int)
    height, width, _ = image.shape
    assert (width, height) == (1920, 1080)
    background = np.median(image.reshape(-1, 3), axis=0)
    drawn = np.abs(image - background).max(axis=2) > 40
    assert drawn.mean() > 0.05, "the screenshot is blank"
    colourful = (image.max(axis=2) - image.min(axis=2)) > 80  # the joints' curves, not grey grid lines or text
    plots, scene = colourful[60:1040, width // 2 + 40:], drawn[60:780, :width // 2]
    for k in range(4):  # each of the four profile plots (a quarter of the right half each) holds curves
        band = plots[k * plots.shape[0] // 4:(k + 1) * plots.shape[0] // 4]
        assert band.sum() > 2000, f"plot {k} holds no drawn curves"
        assert band.any(axis=1).mean() > 0.2, f"plot {k} holds only straight lines"  # curves rise and fall
    assert scene.mean() > 0.05, "the 3D view is empty"


def test_without_a_graphics_adapter_one_line_says_what_to_install(recording, tmp_path, monkeypatch, capsys):
    from planner.screenshot import rerun_executable
    if rerun_executable() is None:
        pytest.skip("no `rerun` program here")
    monkeypatch.setenv("WGPU_BACKEND", "vulkan")  # Vulkan only, and no Vulkan driver: no adapter at all
    monkeypatch.setenv("VK_ICD_FILENAMES", str(tmp_path / "no-such-driver.json"))
    monkeypatch.setenv("VK_DRIVER_FILES", str(tmp_path / "no-such-driver.json"))
    out = tmp_path / "out" / "shot.png"
    assert main(["replay", str(recording), "--screenshot", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and captured.err.startswith("error: no graphics adapter")
    assert "mesa-vulkan-drivers" in captured.err
    assert not out.exists() and (not out.parent.exists() or leftovers(out.parent) == [])


def test_without_the_rerun_program_one_line_says_what_to_install(recording, tmp_path, monkeypatch, capsys):
    import planner.screenshot as screenshot
    monkeypatch.setattr(screenshot, "rerun_executable", lambda: None)
    out = tmp_path / "shot.png"
    assert main(["replay", str(recording), "--screenshot", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "rerun-sdk" in err
    assert leftovers(tmp_path) == []


def test_a_failed_screenshot_leaves_neither_its_folders_nor_the_csv_asked_with_it(recording, tmp_path, monkeypatch,
                                                                                   capsys):
    """``--export-csv`` and ``--screenshot`` are published together: the CSV is not left behind when the
    screenshot fails, and the folders made for either are removed."""
    import planner.screenshot as screenshot
    from planner.errors import ViewerError

    def fail(*args, **kwargs):
        raise ViewerError("no graphics adapter (a test)")
    monkeypatch.setattr(screenshot, "render_screenshot", fail)
    shot, table = tmp_path / "a" / "b" / "shot.png", tmp_path / "c" / "trajectory.csv"
    assert main(["replay", str(recording), "--export-csv", str(table), "--screenshot", str(shot)]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("arguments, said", [
    (["--screenshot", "{tmp}/shot.png", "--time", "99"], "outside the recording's 0 to"),
    (["--screenshot", "{tmp}/shot.png", "--time", "-0.5"], "outside the recording's 0 to"),
    (["--screenshot", "{tmp}/shot.png", "--time", "nan"], "finite number of seconds"),
    (["--time", "1"], "--time says when to take a --screenshot"),
    (["--screenshot", "{tmp}/shot.jpg"], "writes a PNG image: give a file name ending in .png"),
    (["--screenshot", "{recording}"], "is the recording itself"),
    (["--screenshot", "{tmp}/same", "--export-csv", "{tmp}/./same"], "--screenshot and --export-csv name the same "
                                                                    "file"),
])
def test_bad_screenshot_arguments_fail_before_rendering(arguments, said, recording, tmp_path, monkeypatch, capsys):
    import planner.screenshot as screenshot

    def refuse(*args, **kwargs):
        raise AssertionError("a viewer was started")
    monkeypatch.setattr(screenshot, "render_screenshot", refuse)
    before = recording.read_bytes()
    arguments = [a.format(tmp=tmp_path, recording=recording) for a in arguments]
    try:
        code = main(["replay", str(recording), *arguments])
    except SystemExit as usage_error:  # argparse: a malformed option value
        code = usage_error.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and said in err
    assert leftovers(tmp_path) == [] and recording.read_bytes() == before


def test_a_time_just_past_the_end_reads_past_it(recording, tmp_path, capsys):
    """--time a hair past the end is refused with the digits that show it ("27 s is outside ... 0 to
    27.0000 s" read as a contradiction)."""
    from planner.recording import read_recording

    total = read_recording(recording).trajectory.total_time
    past = total * (1 + 1e-8)  # beyond the rounding of the printed end (``TIME_END_TOLERANCE``)
    assert main(["replay", str(recording), "--screenshot", str(tmp_path / "s.png"), "--time", repr(past)]) == 2
    said = re.search(r"--time (\S+) s is outside the recording's 0 to (\S+) s", capsys.readouterr().err)
    assert said and said[1] != said[2] and float(said[1]) > float(said[2]) == pytest.approx(total, rel=1e-9)


def test_the_end_as_the_outputs_print_it_is_the_end(recording, tmp_path, monkeypatch):
    """summary.json and the CSV print the total time to 12 or 13 digits, rounded up half the time: that
    time was refused as outside the recording (sweep 16). Within ``TIME_END_TOLERANCE`` it is the end."""
    import planner.screenshot as screenshot
    from planner.recording import read_recording

    asked = []
    monkeypatch.setattr(screenshot, "render_screenshot", lambda source, target, at: asked.append(at))
    total = read_recording(recording).trajectory.total_time
    for at in (total * (1 + 1e-12), total * (1 + 1e-10)):  # as 12 or 13 digits round it up, and more
        assert main(["replay", str(recording), "--screenshot", str(tmp_path / "s.png"), "--time", repr(at),
                     "--force"]) == 0
    assert asked == [total, total]


def _viewers_of(port_marker: str) -> list[int]:
    """Pids of the processes whose command line holds ``port_marker`` (the headless viewer's --port)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                command = (entry / "cmdline").read_bytes().split(b"\0")
                state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
            except OSError:
                continue
            if b"--headless" in command and port_marker.encode() in command and state != "Z":
                found.append(int(entry.name))
    return found


@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="reads /proc")
def test_a_replay_killed_outright_takes_its_headless_viewer_with_it(recording, tmp_path):
    """``kill -9`` on replay --screenshot (the OOM killer, a CI timeout's second stage) left the viewer running
    for good, re-parented to init: the launcher it started ran the viewer as a child of its own (sweep 22)."""
    from planner.screenshot import rerun_executable
    if rerun_executable() is None:
        pytest.skip("no `rerun` program here")
    probe = ("import planner.screenshot as s, sys; s._free_port = lambda: int(sys.argv[1]); "
             "from planner.cli import main; main(['replay', sys.argv[2], '--screenshot', sys.argv[3]])")
    with socket.socket() as free:
        free.bind(("127.0.0.1", 0))
        port = str(free.getsockname()[1])
    replay = subprocess.Popen([sys.executable, "-c", probe, port, str(recording), str(tmp_path / "s.png")],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 20
    while not _viewers_of(port) and time.monotonic() < deadline and replay.poll() is None:
        time.sleep(0.05)
    if not _viewers_of(port):
        replay.kill()
        pytest.skip("the viewer did not start here")
    environment = (Path("/proc") / str(_viewers_of(port)[0]) / "environ").read_bytes().split(b"\0")
    scratch = Path(next(item for item in environment if item.startswith(b"TMPDIR="))[7:].decode())
    replay.send_signal(signal.SIGKILL)
    replay.wait()
    deadline = time.monotonic() + 5
    while _viewers_of(port) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = _viewers_of(port)
    for pid in left:  # (not to leave them to the next test)
        os.kill(pid, signal.SIGKILL)
    assert left == []
    # Its temporary screenshot and the viewer's scratch folder stay; runs after it remove them once they are
    # abandoned: no process holds them, and a minute has passed.
    from planner.outputs import ABANDONED_AFTER_S
    from planner.screenshot import SCRATCH_LOCK, SCRATCH_PREFIX, remove_abandoned_scratch
    temporaries = list(tmp_path.glob(".s.png.*.tmp"))
    assert len(temporaries) == 1 and scratch.name.startswith(SCRATCH_PREFIX) and (scratch / SCRATCH_LOCK).is_file()
    assert scratch.parent == Path(tempfile.gettempdir())
    remove_abandoned_scratch()
    assert scratch.exists()  # too recent to tell from one being made
    long_ago = time.time() - ABANDONED_AFTER_S - 1
    for path in temporaries + [scratch / SCRATCH_LOCK]:
        os.utime(path, (long_ago, long_ago))
    remove_abandoned_scratch()
    assert not scratch.exists()
    with atomic_file(tmp_path / "s.png") as temporary:
        temporary.write_bytes(b"png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.png"]


@pytest.mark.parametrize("output, said", [
    ("thread 'main' panicked at 'No glyph for \"ם\" (U+05DD) in Proportional. Installed fonts: [\"Inter\"].'\n"
     "  17: <egui::ui::Ui>::scope::<TimeSeriesView error>\n",
     r"^Rerun's viewer cannot draw the character ם \(U\+05DD\) of a name in the recording .*Latin, Greek or Cyrillic"),
    ("INFO start\nthread 'main' panicked at crates/viewer/src/app.rs:12:5:\nindex out of bounds\n  3: error frame\n",
     r"^Rerun's headless viewer stopped with an error \(thread 'main' panicked at crates/viewer/src/app.rs:12:5: "
     r"index out of bounds\)$"),
    ("[ERROR wgpu] no suitable adapter found\n", r"^no graphics adapter for Rerun's headless viewer: install"),
])
def test_the_viewers_own_reason_is_the_one_line(output, said):
    """A name the viewer's font cannot draw (CJK, Hebrew) made it panic, and the line named a backtrace frame
    and a graphics adapter as the cause (sweep 26): a panic is reported as such, a missing glyph by its
    character and what to do."""
    from planner.screenshot import _failure
    with tempfile.TemporaryFile() as log:
        log.write(output.encode())
        error = _failure(102, log)
    assert re.search(said, str(error)) and "\n" not in str(error)
    assert ("graphics adapter" in str(error)) == ("adapter" in output)
