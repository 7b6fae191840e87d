"""Tests for behaviour of planner.recording that no existing test checks (found by mutation testing)."""
import subprocess
import sys
import time

import pytest

import planner.recording as recording
from planner.errors import ViewerError


def test_macos_always_has_a_display(monkeypatch):
    """has_display: 'always on macOS and Windows, elsewhere with DISPLAY or WAYLAND_DISPLAY set'."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "darwin")
    assert recording.has_display() is True
    monkeypatch.setattr(sys, "platform", "linux")
    assert recording.has_display() is False


def viewer(monkeypatch, script):
    """The viewer replaced by a Python process running ``script``; a display is set."""
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(recording, "VIEWER_COMMAND", (sys.executable, "-c", script))


@pytest.mark.parametrize("script, reason", [
    ("import sys; sys.exit('cannot open display :99')", " ('cannot open display :99')"),
    ("import sys; print('one'); print('two'); print('three', flush=True); sys.exit(1)", " ('three')"),
    ("import sys; sys.stdout.buffer.write(b'bad \\xff byte\\n'); sys.stdout.flush(); sys.exit(1)",
     " ('bad \ufffd byte')"),
    ("import sys; sys.exit(1)", ""),
])
def test_a_viewer_failing_at_start_up_is_reported_with_its_last_line(monkeypatch, tmp_path, script, reason):
    """The error quotes the whole last line of the viewer's output (one line only, several, bytes that are
    not UTF-8), or nothing when it said nothing; then the alternatives."""
    viewer(monkeypatch, script)
    with pytest.raises(ViewerError) as raised:
        recording.open_in_viewer(tmp_path / "r.rrd", command="planner")
    said = str(raised.value)
    assert said.startswith(f"the Rerun viewer exited with code 1{reason}; check it"), said


def test_a_viewer_that_cannot_be_started_is_reported(monkeypatch, tmp_path):
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(recording, "VIEWER_COMMAND", (str(tmp_path / "no-such-viewer"),))
    with pytest.raises(ViewerError, match=r"^cannot start the Rerun viewer: .*no-such-viewer"):
        recording.open_in_viewer(tmp_path / "r.rrd")


def test_open_in_viewer_returns_after_the_start_up_time_while_the_viewer_runs(monkeypatch, tmp_path):
    """A viewer still running after ``startup_s`` is showing the recording: the call returns then, it does
    not wait for the viewer to close."""
    started = []
    real = subprocess.Popen

    def popen(*args, **kwargs):
        started.append(real(*args, **kwargs))
        return started[-1]
    viewer(monkeypatch, "import time; time.sleep(6)")
    monkeypatch.setattr(subprocess, "Popen", popen)
    begun = time.monotonic()
    try:
        recording.open_in_viewer(tmp_path / "r.rrd", startup_s=0.5)
        elapsed = time.monotonic() - begun
    finally:
        for process in started:
            process.kill()
            process.wait()
    assert 0.4 <= elapsed < 3.0


# ---------------------------------------------------------------------------- reading recordings back

def write_recording_like_planner(path, *, rate_hz=50.0, chunks=1, end=None, definition=None, acceleration=None,
                                 end_static=True, end_twice=False):
    """As test_recording.write_like_planner (a 2-joint cubic, T = 4 s), at ``rate_hz``, its samples sent in
    ``chunks`` separate columns (Rerun keeps each send as a chunk of its own); ``end`` overrides end-marker keys,
    ``definition`` definition keys; ``acceleration``: the joints' acceleration limits (default none)."""
    import json

    import numpy as np
    import rerun as rr

    from planner import JointLimits, get_family
    from planner.recording import end_marker, trajectory_definition
    trajectory = get_family("cubic").build([[0.0, 0.0], [0.5, -1.0], [1.0, 0.5]], [1.0, 1.0, 1.0, 1.0])
    limits = JointLimits.create(2, lower=[-3.0, -3.0], velocity=[5.0, 5.0], acceleration=acceleration,
                                jerk=[100.0, 100.0])
    times, values = trajectory.sample(rate_hz)
    rec = rr.RecordingStream("planner")
    rec.save(str(path))
    rec.log("trajectory/definition", rr.AnyValues(planner_definition=json.dumps(
        {**trajectory_definition(trajectory, limits, ["shoulder", "elbow"]), **(definition or {})})), static=True)
    for part in np.array_split(np.arange(len(times)), chunks):
        rec.send_columns("trajectory/samples", indexes=[rr.TimeColumn("time", duration=times[part])],
                         columns=rr.Scalars.columns(scalars=values[0][part]))
    rec.flush()
    if not end_static:
        rec.set_time("time", duration=times[-1])
    if end_twice:  # an earlier, different end marker as well
        rec.log("trajectory/end", rr.AnyValues(planner_end=json.dumps(end_marker(times[:-1], rate_hz))), static=True)
        rec.flush()
    rec.log("trajectory/end", rr.AnyValues(planner_end=json.dumps({**end_marker(times, rate_hz), **(end or {})})),
            static=end_static)
    rec.flush()
    rec.disconnect()
    return path, times, values[0]


def test_samples_sent_in_several_chunks_read_back_whole(tmp_path):
    """A recording's samples may lie in several chunks (Rerun splits large sends): all of them are read."""
    import numpy as np

    from planner.recording import read_recording
    path, times, positions = write_recording_like_planner(tmp_path / "r.rrd", chunks=3)
    recorded = read_recording(path)
    np.testing.assert_allclose(recorded.times, times, atol=1e-9)
    np.testing.assert_array_equal(recorded.positions, positions)
    assert recorded.check().passed


@pytest.mark.parametrize("rate_hz", [1.0, 0.5])
def test_a_recording_sampled_at_one_hertz_or_less_reads_back(tmp_path, rate_hz):
    """A sample rate is any number > 0 Hz (a task's sample_rate_hz may be 1 Hz or less)."""
    from planner.recording import read_recording
    path, times, _ = write_recording_like_planner(tmp_path / "r.rrd", rate_hz=rate_hz)
    recorded = read_recording(path)
    assert recorded.rate_hz == rate_hz and len(recorded.times) == len(times)


@pytest.mark.parametrize("end, message", [
    ({"sample_rate_hz": 0.0}, r"trajectory/end: sample_rate_hz must be a finite number > 0, got 0\.0$"),
    ({"sample_count": "201"}, r"trajectory/end: sample_count must be a whole number from 1 to 1,000,000, got '201'$"),
    ({"sample_count": 0}, r"trajectory/end: sample_count must be a whole number from 1 to 1,000,000, got 0$"),
    ({"time_span_s": [0.0, 4.0, 7.0]}, r"trajectory/end: time_span_s must hold 2 numbers, got 3$"),
    ({"time_span_s": "0 to 4"}, r"trajectory/end: time_span_s must be a list of numbers, got '0 to 4'$"),
])
def test_a_malformed_end_marker_is_an_error_naming_the_file_the_field_and_the_value(tmp_path, end, message):
    import re

    from planner.errors import RecordingError
    from planner.recording import read_recording
    path, _, _ = write_recording_like_planner(tmp_path / "r.rrd", end=end)
    with pytest.raises(RecordingError) as raised:
        read_recording(path)
    assert str(raised.value).startswith(f"{path}: trajectory/end: ") and re.search(message, str(raised.value)), \
        str(raised.value)


def test_a_malformed_sample_is_an_error_naming_the_file_the_time_and_the_value(tmp_path):
    """A sample holding one joint position where two are expected: the message names the file, the part,
    the sample's time and what it holds."""
    import numpy as np
    import rerun as rr

    from planner.errors import RecordingError
    from planner.recording import read_recording
    path, times, positions = write_recording_like_planner(tmp_path / "r.rrd")
    rows = tmp_path / "rows.rrd"
    import json

    from planner.recording import end_marker
    rec = rr.RecordingStream("planner")
    rec.save(str(rows))
    recorded_definition = read_recording(path)  # the same definition, logged again below
    from planner.recording import trajectory_definition
    rec.log("trajectory/definition", rr.AnyValues(planner_definition=json.dumps(trajectory_definition(
        recorded_definition.trajectory, recorded_definition.limits, ["shoulder", "elbow"]))), static=True)
    for k, (t, q) in enumerate(zip(times, positions)):
        rec.set_time("time", duration=t)
        rec.log("trajectory/samples", rr.Scalars(q if k != 7 else q[:1]))
    rec.flush()
    rec.log("trajectory/end", rr.AnyValues(planner_end=json.dumps(end_marker(times, 50.0))), static=True)
    rec.flush()
    rec.disconnect()
    with pytest.raises(RecordingError) as raised:
        read_recording(rows)
    said = str(raised.value)
    assert said.startswith(f"{rows}: trajectory/samples: the sample at 0.14 s holds [{float(positions[7][0])!r}], "
                           f"expected 2 joint positions"), said
    assert np.isfinite(positions[7][0])


def handmade_recording(path, trajectory, limits, times, columns) -> None:
    """A recording laid out as the planner's (definition, samples, end marker), its samples ``columns``
    at ``times`` [s] written by Rerun directly."""
    import json

    import rerun as rr

    from planner.recording import end_marker, trajectory_definition
    rec = rr.RecordingStream("planner")
    rec.save(str(path))
    rec.log("trajectory/definition", rr.AnyValues(planner_definition=json.dumps(
        trajectory_definition(trajectory, limits, ["shoulder", "elbow"]))), static=True)
    rec.send_columns("trajectory/samples", indexes=[rr.TimeColumn("time", duration=times)], columns=columns)
    rec.flush()
    rec.log("trajectory/end", rr.AnyValues(planner_end=json.dumps(end_marker(times, 50.0))), static=True)
    rec.flush()
    rec.disconnect()


def test_samples_without_scalars_are_an_error_naming_the_file_and_the_part(tmp_path):

    import rerun as rr

    from planner.errors import RecordingError
    from planner.recording import read_recording
    path, times, _ = write_recording_like_planner(tmp_path / "r.rrd")
    recorded = read_recording(path)
    bad = tmp_path / "bad.rrd"
    handmade_recording(bad, recorded.trajectory, recorded.limits, times, rr.AnyValues.columns(something=times))
    with pytest.raises(RecordingError, match=r"trajectory/samples: holds no Scalars:scalars column$") as raised:
        read_recording(bad)
    assert str(raised.value).startswith(f"{bad}: trajectory/samples: ")


def test_a_urdf_rerun_cannot_read_is_a_recording_error_naming_it(tmp_path, monkeypatch):
    """Rerun raises plain exceptions for URDFs it cannot read: write_recording turns them into a
    RecordingError naming the URDF and Rerun's reason."""
    from pathlib import Path

    import rerun.urdf as rru

    from planner.errors import RecordingError
    from planner.pipeline import plan
    from planner.recording import write_recording
    result = plan(Path(__file__).resolve().parents[1] / "scripts" / "tasks" / "ur5_pick_and_place.yaml")

    def unreadable(*args, **kwargs):
        raise ValueError("no <robot> element")
    monkeypatch.setattr(rru.UrdfTree, "from_file_path", unreadable)
    with pytest.raises(RecordingError) as raised:
        write_recording(result, tmp_path / "r.rrd")
    assert str(raised.value) == f"Rerun cannot read the URDF {result.robot.urdf_path}: no <robot> element"


@pytest.mark.parametrize("keep", [slice(25, None), slice(None, 151)])
def test_samples_cut_short_with_a_matching_end_marker_are_refused(tmp_path, keep):
    """Samples of only part of the trajectory (from 0.5 s, or up to 3 s) whose end marker describes exactly
    those samples: the span is checked against the trajectory's own [0, T], so the recording is refused."""

    import rerun as rr

    from planner import JointLimits, get_family
    from planner.errors import RecordingError
    from planner.recording import read_recording
    trajectory = get_family("cubic").build([[0.0, 0.0], [0.5, -1.0], [1.0, 0.5]], [1.0, 1.0, 1.0, 1.0])
    limits = JointLimits.create(2, lower=[-3.0, -3.0], velocity=[5.0, 5.0], jerk=[100.0, 100.0])
    times, values = trajectory.sample(50.0)
    times, positions = times[keep], values[0][keep]
    path = tmp_path / "r.rrd"
    handmade_recording(path, trajectory, limits, times, rr.Scalars.columns(scalars=positions))
    with pytest.raises(RecordingError,
                       match=r"trajectory/end: time_span_s \[.*\] is not the trajectory's \[0, 4\.0\] s"):
        read_recording(path)


def test_decreasing_via_knots_are_refused(tmp_path):
    from planner.errors import RecordingError
    from planner.recording import read_recording
    path, _, _ = write_recording_like_planner(tmp_path / "r.rrd", definition={"via_knots": [0, 3, 2]})
    with pytest.raises(RecordingError, match=r"trajectory/definition: via_knots must be non-decreasing"):
        read_recording(path)


def test_the_acceleration_limits_are_read_back_and_checked(tmp_path):
    """Every limit of the definition is read back (here the acceleration limits, 0.5 rad/s^2, which the
    trajectory breaks: its peak is above 1 rad/s^2), so the check fails on them."""
    import numpy as np

    from planner.kinematics import kinematic_figures
    from planner.recording import read_recording
    path, _, _ = write_recording_like_planner(tmp_path / "r.rrd", acceleration=[0.5, 0.5])
    recorded = read_recording(path)
    np.testing.assert_array_equal(recorded.limits.acceleration, [0.5, 0.5])
    assert kinematic_figures(recorded.trajectory).max_abs[1].max() > 1.0
    assert not recorded.check().passed


def test_an_end_marker_logged_on_the_timeline_is_refused(tmp_path):
    """The definition and the end marker are static texts; one logged on the timeline is not the planner's."""
    from planner.errors import RecordingError
    from planner.recording import read_recording
    path, _, _ = write_recording_like_planner(tmp_path / "r.rrd", end_static=False)
    with pytest.raises(RecordingError, match=r"trajectory/end holds no static planner_end text$"):
        read_recording(path)


def test_two_end_markers_are_refused(tmp_path):
    from planner.errors import RecordingError
    from planner.recording import read_recording
    path, _, _ = write_recording_like_planner(tmp_path / "r.rrd", end_twice=True)
    with pytest.raises(RecordingError, match=r"trajectory/end holds 2 planner_end texts where a recording holds one"):
        read_recording(path)


def test_a_path_that_is_not_utf8_is_refused_before_rerun_reads_it(tmp_path):
    """Rerun reads recordings at UTF-8 paths only: a name holding other bytes is refused up front, naming why."""
    import os

    from planner.errors import RecordingError
    from planner.recording import read_recording
    path, _, _ = write_recording_like_planner(tmp_path / "r.rrd")
    odd = os.path.join(os.fsencode(tmp_path), b"r\xff.rrd")
    os.rename(os.fsencode(path), odd)
    with pytest.raises(RecordingError, match=r"the path holds bytes that are not UTF-8"):
        read_recording(os.fsdecode(odd))


def test_a_recording_that_fails_halfway_leaves_nothing_to_print(tmp_path):
    """What was logged before a failure is dropped with the failure: left in Rerun's in-memory stream, it was
    dropped later with a warning on stderr (where Rerun's log is not turned off), inside whatever output
    came next (a test of the figure's quiet stderr failed on it)."""
    import os
    import subprocess
    import sys
    script = """
import gc, sys
import rerun  # before the planner turns Rerun's log off: its warnings reach stderr
from planner import pipeline, recording
result = pipeline.plan({"version": 1, "name": "drop", "waypoints": {"joints_deg": [[0, 0], [30, 10], [60, 0]]},
                        "limits": {"velocity_deg_s": [50, 50], "acceleration_deg_s2": [100, 100],
                                   "jerk_deg_s3": [500, 500]}})
def broken(_):
    raise RuntimeError("the summary fails")
recording.plan_summary = broken
try:
    recording.write_recording(result, sys.argv[1])
except RuntimeError:
    pass
gc.collect()
"""
    environment = {key: value for key, value in os.environ.items() if key != "RUST_LOG"}
    done = subprocess.run([sys.executable, "-c", script, str(tmp_path / "r.rrd")], capture_output=True, text=True,
                          env=environment, timeout=300)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert not (tmp_path / "r.rrd").exists()
