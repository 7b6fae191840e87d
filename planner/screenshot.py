"""Screenshots of a recording (``planner replay FILE --screenshot OUT.png``), rendered by Rerun's headless viewer.

The viewer (the ``rerun`` program of the ``rerun-sdk`` package) runs without a window but still needs a
graphics adapter: a GPU with a Vulkan driver, or Mesa's software one (Debian/Ubuntu:
``apt-get install mesa-vulkan-drivers``). Without one it cannot start, and ``render_screenshot``
says so in one line and writes nothing.
"""

from __future__ import annotations

import fcntl
import functools
import importlib.util
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .concurrency import end_with
from .errors import ViewerError, one_line
from .outputs import abandoned

#: What to install where the viewer finds no graphics adapter.
ADAPTER_HINT = ("install a Vulkan driver (Debian/Ubuntu: apt-get install mesa-vulkan-drivers, a software "
                "renderer) or run on a machine with a GPU")
#: The viewer's screen [logical points]: the whole viewer is captured at this size.
WINDOW_SIZE = "1920x1080"
#: Most time the viewer may take to start and answer [s].
STARTUP_S = 30.0
#: Least time between the viewer's start and the screenshot [s]: its start-up notice has faded by then,
#: and the meshes are drawn.
SETTLE_S = 4.0
#: Most time the recording may take to load [s].
LOAD_S = 30.0
#: Most time the viewer may take to exit after a request failed [s] (its reason is then in its output).
STOPPING_S = 3.0


def time_argument(text: str) -> float:
    """A ``--time`` argument: a finite number of seconds."""
    import argparse
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds, got {text!r}") from None
    if value != value or abs(value) == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds, got {text!r}")
    return value


def rerun_executable() -> str | None:
    """The ``rerun`` program: the one beside this Python (its virtual environment's), else the first on PATH."""
    beside = Path(sys.executable).parent / ("rerun.exe" if os.name == "nt" else "rerun")
    if beside.is_file() and os.access(beside, os.X_OK):
        return str(beside)
    return shutil.which("rerun")


#: The viewer's scratch folder (its TMPDIR) in the system's temporary folder, and the file a replay holds
#: locked in it while it runs.
SCRATCH_PREFIX = "planner-viewer-"
SCRATCH_LOCK = ".planner.lock"


def remove_abandoned_scratch() -> None:
    """Remove the viewer scratch folders that replays killed outright left (``outputs.abandoned``)."""
    for stale in Path(tempfile.gettempdir()).glob(f"{SCRATCH_PREFIX}*"):
        if abandoned(stale / SCRATCH_LOCK):
            shutil.rmtree(stale, ignore_errors=True)


def _viewer_program(executable: str) -> str:
    """The viewer binary itself where ``executable`` is the rerun-sdk package's launcher (a Python script that
    runs it as a child, which would outlive the launcher ended with this process), else ``executable``."""
    if Path(executable).parent != Path(sys.executable).parent:  # not this environment's launcher
        return executable
    spec = importlib.util.find_spec("rerun_cli")
    folders = list(spec.submodule_search_locations or []) if spec is not None else []
    binary = next((Path(folder) / Path(executable).name for folder in folders
                   if (Path(folder) / Path(executable).name).is_file()), None)
    return str(binary) if binary is not None and os.access(binary, os.X_OK) else executable


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _failure(code: int | None, log) -> ViewerError:
    """Why the viewer stopped (or never answered), from its exit ``code`` and its output ``log``."""
    log.seek(0)
    text = log.read().decode(errors="replace")
    lowered = text.lower()
    if any(sign in lowered for sign in ("graphics adapter", "render context", "render state", "adapter was found",
                                        "no suitable adapter", "failed to create wgpu")):
        return ViewerError(f"no graphics adapter for Rerun's headless viewer: {ADAPTER_HINT}")
    glyph = re.search(r'No glyph for "(.+?)" \((U\+[0-9A-F]+)\)', text)
    if glyph:  # egui's font (Latin, Greek and Cyrillic) lacks a character of a name: the viewer panics
        return ViewerError(f"Rerun's viewer cannot draw the character {glyph[1]} ({glyph[2]}) of a name in the "
                           f"recording (the task's, the robot's or a joint's): its font has no glyph for it, and "
                           f"it stopped; name them in Latin, Greek or Cyrillic letters")
    lines = text.splitlines()
    panic = next((k for k, line in enumerate(lines) if "panicked at" in line), None)
    if panic is not None:  # (since Rust 1.73 the message follows on the next line)
        end = panic + 2 if lines[panic].endswith(":") else panic + 1
        panicked = " ".join(line.strip() for line in lines[panic:end])
        return ViewerError(f"Rerun's headless viewer stopped with an error ({one_line(panicked, 300)})")
    said = [line.strip() for line in lines if "error" in line.lower() and "XDG_RUNTIME_DIR" not in line]
    reason = f" ({one_line(said[-1], 300)})" if said else ""
    what = f"exited with code {code}" if code is not None else f"did not answer within {STARTUP_S:g} s"
    return ViewerError(f"Rerun's headless viewer {what}{reason}; it needs a graphics adapter: {ADAPTER_HINT}")


def _stop(viewer: subprocess.Popen) -> None:
    """End the viewer we started: its process group (the ``rerun`` launcher and the viewer it runs)."""
    if viewer.poll() is None:
        try:
            os.killpg(viewer.pid, signal.SIGTERM) if os.name == "posix" else viewer.terminate()
            viewer.wait(timeout=5)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            try:
                os.killpg(viewer.pid, signal.SIGKILL) if os.name == "posix" else viewer.kill()
            except ProcessLookupError:
                pass
    viewer.wait()


def render_screenshot(recording, out: Path, time_s: float) -> None:
    """Render the recording ``recording`` at ``time_s`` [s] in a headless viewer and write the PNG to ``out``
    (a path the caller stages: written only once the viewer has painted).

    Raises:
        ViewerError: no ``rerun`` program, no graphics adapter, or the viewer failed or timed out.
    """
    from rerun.experimental import ViewerClient

    executable = rerun_executable()
    if executable is None:
        raise ViewerError("no `rerun` program to render with: install the rerun-sdk package "
                              "(pip install rerun-sdk) in this environment, or put its `rerun` on PATH")
    port = _free_port()
    command = [_viewer_program(executable), "--headless", "--port", str(port), "--hide-welcome-screen",
               "--window-size", WINDOW_SIZE]
    # The viewer's own scratch files (a rerun-data-* folder it leaves when it is ended) go into a folder
    # removed afterwards.
    remove_abandoned_scratch()
    with tempfile.TemporaryFile() as log, tempfile.TemporaryDirectory(prefix=SCRATCH_PREFIX) as scratch, \
            open(Path(scratch) / SCRATCH_LOCK, "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX)  # while the folder is in use (``outputs.abandoned``)
        started = time.monotonic()
        try:
            viewer = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                                      env={**os.environ, "RERUN_APP_ONLY": "true", "TMPDIR": scratch},
                                      start_new_session=os.name == "posix",  # ended with this process, even
                                      preexec_fn=functools.partial(end_with, os.getpid())  # by SIGKILL
                                      if os.name == "posix" else None)
        except OSError as exc:
            raise ViewerError(f"cannot start Rerun's headless viewer {executable}: {exc}") from None
        try:
            client = _connect(ViewerClient, viewer, port, log, started)
            try:
                client.open(str(Path(recording).resolve()))
                _wait_loaded(client, viewer, log)
                client.set_time("time", duration=time_s, play_state="paused")
                time.sleep(max(0.0, started + SETTLE_S - time.monotonic()))
                png = client.take_screenshot()
            except Exception as exc:  # the viewer may be stopping (a panic): its own reason, where it gives one
                try:
                    viewer.wait(timeout=STOPPING_S)
                except subprocess.TimeoutExpired:
                    raise ViewerError(f"Rerun's headless viewer failed ({type(exc).__name__}: "
                                      f"{one_line(str(exc), 200)})") from None
                raise _failure(viewer.returncode, log) from None
            if not png.startswith(b"\x89PNG"):
                raise ViewerError("Rerun's headless viewer returned no PNG image")
            Path(out).write_bytes(png)
        finally:
            _stop(viewer)


def _connect(client_class, viewer: subprocess.Popen, port: int, log, started: float):
    """A client of the viewer once it answers; the viewer's failure if it stops first."""
    while True:
        if viewer.poll() is not None:
            raise _failure(viewer.returncode, log)
        try:
            client = client_class(f"rerun+http://127.0.0.1:{port}/proxy")
            client.get_state()
            time.sleep(0.3)  # it answers before drawing its first frame, where a missing adapter shows
            if viewer.poll() is None:
                client.get_state()
                return client
        except Exception:  # not listening yet
            pass
        if time.monotonic() - started > STARTUP_S:
            raise _failure(None, log)
        time.sleep(0.2)


def _wait_loaded(client, viewer: subprocess.Popen, log) -> None:
    deadline = time.monotonic() + LOAD_S
    while True:
        state = client.get_state()
        if not state.loading and state.recordings and state.recordings[0].timelines:
            return
        if viewer.poll() is not None:
            raise _failure(viewer.returncode, log)
        if time.monotonic() > deadline:
            raise ViewerError(f"Rerun's headless viewer did not load the recording within {LOAD_S:g} s")
        time.sleep(0.2)
