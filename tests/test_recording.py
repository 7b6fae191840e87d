import json
import os
import re
import struct
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pyarrow as pa
import pytest

from planner import JointLimits, RecordingError, get_family
from planner.cli import main
from planner.export import read_trajectory_csv
from planner.pipeline import plan
from planner.recording import end_marker, read_recording, trajectory_definition, write_recording
from planner.splines import PiecewisePolynomial

ROOT = Path(__file__).resolve().parents[1]
TASKS = ROOT / "scripts" / "tasks"


@pytest.fixture(scope="module", params=["puma560_paper_cartesian", "ur5_pick_and_place"])
def planned(request, tmp_path_factory):
    result = plan(TASKS / f"{request.param}.yaml")
    out = result.save(tmp_path_factory.mktemp(request.param) / "out")
    return result, out


def test_every_output_exists_and_agrees(planned):
    result, out = planned
    assert sorted(p.name for p in out.iterdir()) == [".planner-output", "coefficients.json", "profiles.png",
                                                     "summary.json", "trajectory.csv", "trajectory.rrd"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["robot"]["name"] == result.robot.name and len(summary["ik"]["waypoints"]) == len(result.ik)
    assert all(w["position_error_m"] <= 1e-9 for w in summary["ik"]["waypoints"])
    # The trajectory passes through the IK via-points at the via times, and its samples respect the limits.
    trajectory = result.trajectory
    np.testing.assert_allclose(trajectory.evaluate(summary["via_times_s"]), result.via_points, atol=1e-9)
    times, values = read_trajectory_csv(out / "trajectory.csv")
    # The total time is where the motion ends: the CSV's last row (its end time) holds the last via-point at rest.
    assert times[-1] == pytest.approx(result.trajectory.total_time, rel=1e-14)
    assert summary["total_time_s"] == pytest.approx(times[-1], rel=1e-11) == summary["via_times_s"][-1]
    np.testing.assert_allclose(values[0][-1], result.via_points[-1], atol=1e-9)
    np.testing.assert_allclose(values[1:, -1], 0.0, atol=1e-6)
    for d in (1, 2, 3):
        assert np.all(np.abs(values[d]).max(axis=0) <= result.limits.magnitudes[d - 1] * (1 + 1e-6))
    coefficients = json.loads((out / "coefficients.json").read_text())
    assert coefficients["joint_names"] == result.robot.joint_names
    np.testing.assert_allclose(np.array(coefficients["coefficients"]), trajectory.coefficients)


def test_recording_round_trip_matches_planner_samples(planned):
    result, out = planned
    recorded = read_recording(out / "trajectory.rrd")
    times, values = result.trajectory.sample(result.task.sample_rate_hz)
    # Rerun keeps time in whole nanoseconds: each the nearest to the planner's time (not truncated)
    np.testing.assert_array_equal(np.round(recorded.times * 1e9), np.round(times * 1e9))
    np.testing.assert_array_equal(recorded.positions, values[0])  # float64 kept exactly
    np.testing.assert_array_equal(recorded.trajectory.coefficients, result.trajectory.coefficients)
    assert recorded.joint_names == result.joint_names
    np.testing.assert_array_equal(recorded.limits.jerk, result.limits.jerk)
    np.testing.assert_array_equal(recorded.via_points, result.via_points)


def test_replay_check_and_export(planned, tmp_path, capsys):
    result, out = planned
    assert main(["replay", str(out / "trajectory.rrd"), "--check", "--export-csv", str(tmp_path / "x.csv")]) == 0
    printed = capsys.readouterr().out
    assert "limits hold" in printed and printed.endswith(f"\nwritten (--export-csv): {tmp_path / 'x.csv'}\n")
    times, values = read_trajectory_csv(tmp_path / "x.csv")
    assert times[-1] == pytest.approx(result.trajectory.total_time)


def test_missing_corrupt_and_foreign_recordings(tmp_path, capsys):
    import rerun as rr
    with pytest.raises(RecordingError, match="missing.rrd: no such recording"):
        read_recording(tmp_path / "missing.rrd")
    with pytest.raises(RecordingError, match=": a folder: give the .rrd file in it"):
        read_recording(tmp_path)
    with pytest.raises(RecordingError, match="zero: not a regular file"):
        read_recording("/dev/zero")
    corrupt = tmp_path / "corrupt.rrd"
    corrupt.write_bytes(b"this is not a recording" * 10)
    with pytest.raises(RecordingError, match="not a readable Rerun recording"):
        read_recording(corrupt)
    foreign = tmp_path / "foreign.rrd"
    rec = rr.RecordingStream("someone_else")
    rec.save(str(foreign))
    rec.log("points", rr.Points3D([[0, 0, 0]]))
    rec.flush()
    rec.disconnect()
    with pytest.raises(RecordingError, match="not a planner recording"):
        read_recording(foreign)
    assert main(["replay", str(corrupt), "--check"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1


def test_failure_midway_leaves_nothing(tmp_path, monkeypatch):
    import planner.pipeline as pipeline

    def broken(*args, **kwargs):
        raise RecordingError("simulated failure while recording")
    monkeypatch.setattr(pipeline, "write_recording", broken)
    out = tmp_path / "out"
    assert main(["plan", str(TASKS / "ur5_pick_and_place.yaml"), "--out", str(out), "--quiet"]) == 2
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------- completeness (cut or gappy recordings)


def rrd_message_offsets(data: bytes) -> tuple[list[int], int]:
    """Offsets of the messages of an .rrd (12-byte file header, then (kind u64, length u64) + payload each),
    and the offset of the End message (kind 0) after which only the footer follows."""
    assert data[:4] == b"RRF2"
    offsets, position = [], 12
    while position + 16 <= len(data):
        kind, length = struct.unpack_from("<QQ", data, position)
        offsets.append(position)
        if kind == 0:
            return offsets, position
        position += 16 + length
    raise AssertionError("no End message: the .rrd layout changed")


def test_every_cut_of_a_recording_is_an_error(planned, tmp_path):
    _, out = planned
    data = (out / "trajectory.rrd").read_bytes()
    offsets, end = rrd_message_offsets(data)
    cuts = sorted(set(offsets) | set(range(0, len(data), len(data) // 25)) | {end, end + 1, len(data) - 1})
    cut = tmp_path / "cut.rrd"
    for size in cuts:
        cut.write_bytes(data[:size])
        with pytest.raises(RecordingError, match="recording is incomplete: its footer|no end marker|not a"):
            read_recording(cut)
    for size in (len(data) - 1, len(data) - 8):  # every message there, the footer cut
        cut.write_bytes(data[:size])
        with pytest.raises(RecordingError, match="recording is incomplete: its footer, written when the file is "
                                                 "closed, is missing"):
            read_recording(cut)
    cut.write_bytes(data[:offsets[-2]])  # cleanly between two messages: the last one (the marker) is lost
    with pytest.raises(RecordingError, match="recording is incomplete: its footer"):
        read_recording(cut)


@pytest.mark.parametrize("appended", [b"garbage", bytes(20_000)])
def test_bytes_after_a_recording_are_one_line_without_rerun_logging(planned, tmp_path, appended):
    """A fresh process, as a user runs it (Rerun reads its log settings when first imported)."""
    import os
    import subprocess
    import sys
    _, out = planned
    damaged = tmp_path / "damaged.rrd"
    damaged.write_bytes((out / "trajectory.rrd").read_bytes() + appended)
    environment = {key: value for key, value in os.environ.items() if key != "RUST_LOG"}
    run = subprocess.run([sys.executable, "-m", "planner.cli", "replay", str(damaged), "--check"],
                         capture_output=True, text=True, env=environment, timeout=120)
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "bytes after its end" in run.stderr, run.stderr


def test_two_recordings_joined_are_named_as_such(planned, tmp_path):
    """``cat a.rrd a.rrd``: the message quoted 3,000 characters of the definitions (sweep 26)."""
    _, out = planned
    joined = tmp_path / "joined.rrd"
    joined.write_bytes((out / "trajectory.rrd").read_bytes() * 2)
    with pytest.raises(RecordingError, match=r"holds 2 planner_definition texts where a recording holds one \(two "
                                             r"recordings joined into one file\?\)$"):
        read_recording(joined)


def test_a_decoder_that_crashes_is_one_line_and_exit_2(planned, tmp_path):
    """One changed byte of a plan's recording made Rerun's Arrow decoder panic (rerun-sdk 0.2x): the process
    aborted with a 60-line Rust backtrace (exit 134), and from Python no ``except`` could catch it. Which byte
    does so moves from file to file (the recording's ids and compression differ each run), so the decoder is
    made to panic and abort here, in a fresh process as a user runs it: one line naming the panic, exit 2;
    the same process with the decoder as it is passes the file."""
    import subprocess
    import sys

    _, out = planned
    crash = ("import os, sys\n"
             "import planner.recording as recording\n"
             "def panic(path):\n"
             "    sys.stderr.write(\"thread 'main' panicked at arrow/src/ipc.rs:1:1:\\nbuffer out of bounds\\n\")\n"
             "    sys.stderr.flush()\n"
             "    os.abort()\n"
             "if sys.argv[1] == 'crash':\n"
             "    recording._read = panic\n"
             "from planner.cli import main\n"
             "sys.exit(main(['replay', sys.argv[2], '--check']))\n")
    for mode, code in (("crash", 2), ("as is", 0)):
        run = subprocess.run([sys.executable, "-c", crash, mode, str(out / "trajectory.rrd")],
                             capture_output=True, text=True, timeout=120)
        assert run.returncode == code and run.stderr.count("\n") == (code != 0), run.stderr[:2000]
    assert run.stdout and "not a readable Rerun recording" not in run.stdout
    crashed = subprocess.run([sys.executable, "-c", crash, "crash", str(out / "trajectory.rrd")],
                             capture_output=True, text=True, timeout=120)
    assert crashed.stderr.startswith(f"error: {out / 'trajectory.rrd'}: not a readable Rerun recording (its "
                                     f"decoder crashed on it: buffer out of bounds)")


RATE_HZ = 50.0


def small_plan():
    """A 2-joint cubic trajectory (T = 4 s) with limits, sampled at RATE_HZ: what a recording holds."""
    trajectory = get_family("cubic").build([[0.0, 0.0], [0.5, -1.0], [1.0, 0.5]], [1.0, 1.0, 1.0, 1.0])
    limits = JointLimits.create(2, lower=[-3.0, -3.0], velocity=[5.0, 5.0], jerk=[100.0, 100.0])
    times, values = trajectory.sample(RATE_HZ)
    return trajectory, limits, times, values[0]


def write_like_planner(path, *, definition="valid", times="valid", positions="valid", end="valid",
                       rows=None, static_samples=False, application="planner"):
    """A recording written with rerun directly at the planner's entity paths; "valid" parts are the planner's own,
    None leaves a part out, and ``rows`` logs samples one by one as (time, values)."""
    import rerun as rr

    trajectory, limits, valid_times, valid_positions = small_plan()
    times = valid_times if isinstance(times, str) else times
    positions = valid_positions if isinstance(positions, str) else positions
    if isinstance(definition, str) and definition == "valid":
        definition = json.dumps(trajectory_definition(trajectory, limits, ["shoulder", "elbow"]))
    if isinstance(end, str) and end == "valid":
        end = json.dumps(end_marker(valid_times, RATE_HZ))
    rec = rr.RecordingStream(application)
    rec.save(str(path))
    if definition is not None:
        rec.log("trajectory/definition", rr.AnyValues(planner_definition=definition), static=True)
    if rows is not None:
        for t, row in rows:
            rec.set_time("time", duration=t)
            rec.log("trajectory/samples", rr.Scalars(row))
    elif static_samples:
        rec.log("trajectory/samples", rr.Scalars(positions[0]), static=True)
    elif times is not None:
        rec.send_columns("trajectory/samples", indexes=[rr.TimeColumn("time", duration=times)],
                         columns=rr.Scalars.columns(scalars=positions))
    rec.flush()
    if end is not None:
        rec.log("trajectory/end", rr.AnyValues(planner_end=end), static=True)
    rec.flush()
    rec.disconnect()
    return path


def test_a_recording_written_like_the_planner_reads_back(tmp_path):
    trajectory, limits, times, positions = small_plan()
    recorded = read_recording(write_like_planner(tmp_path / "ok.rrd"))
    assert recorded.joint_names == ["shoulder", "elbow"] and recorded.rate_hz == RATE_HZ
    np.testing.assert_allclose(recorded.times, times, atol=1e-9)
    np.testing.assert_array_equal(recorded.positions, positions)
    assert recorded.check().passed


_TIMES = small_plan()[2]
_POSITIONS = small_plan()[3]
_PERIOD = 1.0 / RATE_HZ
INCOMPLETE = {
    "no end marker": dict(end=None),
    "no samples": dict(times=None),
    "no definition": dict(definition=None),
    "last samples missing": dict(times=_TIMES[:-5], positions=_POSITIONS[:-5]),
    "first samples missing": dict(times=_TIMES[3:], positions=_POSITIONS[3:]),
    "a sample missing inside": dict(times=np.delete(_TIMES, 100), positions=np.delete(_POSITIONS, 100, axis=0)),
    "a gap, the count as announced": dict(
        times=np.delete(_TIMES, 100), positions=np.delete(_POSITIONS, 100, axis=0),
        end=json.dumps({**end_marker(_TIMES, RATE_HZ), "sample_count": len(_TIMES) - 1})),
    "samples shifted by half a period": dict(times=_TIMES + _PERIOD / 2),
    "samples shifted by 2 ns": dict(times=_TIMES + 2e-9),
    "samples stretched beyond the end": dict(times=_TIMES * 1.01),
    "a duplicated time": dict(times=np.concatenate([_TIMES[:50], [_TIMES[50], _TIMES[50]], _TIMES[52:]])),
    "a duplicated sample": dict(times=np.insert(_TIMES, 10, _TIMES[10]), positions=np.insert(_POSITIONS, 10,
                                                                                              _POSITIONS[10], axis=0)),
    "end marker's span shorter than the trajectory": dict(
        end=json.dumps({**end_marker(_TIMES, RATE_HZ), "time_span_s": [0.0, 3.0]})),
}


#: What the message says of an incomplete recording, beyond "recording is incomplete" (computed from the
#: 201 samples of 4 s at 50 Hz that ``write_like_planner`` writes).
DIAGNOSES = {
    "a duplicated time": r"two samples at 1\.0 s",
    "samples shifted by 2 ns": r"samples start at 2e-09 s, not at 0\.0 s",
    "samples stretched beyond the end": r"samples end at 4\.04 s, not at the total time 4\.0 s",
    "a sample missing inside": r"200 of the 201 samples",
    "a gap, the count as announced": r"no samples between 1\.98 s and 2\.02 s \(sample period 0\.02 s\)",
}


@pytest.mark.parametrize("case", INCOMPLETE)
def test_incomplete_recordings_are_errors(case, tmp_path, capsys):
    path = write_like_planner(tmp_path / "r.rrd", **INCOMPLETE[case])
    with pytest.raises(RecordingError, match="recording is incomplete|trajectory/end") as raised:
        read_recording(path)
    assert re.search(DIAGNOSES.get(case, ""), str(raised.value)), str(raised.value)
    assert main(["replay", str(path), "--check"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.startswith("error: ") and captured.err.count("\n") == 1


# ---------------------------------------------------------------------------- malformed content at the planner's paths


def _definition(**changes):
    trajectory, limits, _, _ = small_plan()
    document = trajectory_definition(trajectory, limits, ["shoulder", "elbow"])
    for key, value in changes.items():
        if "." in key:
            outer, inner = key.split(".")
            document[outer] = {**document[outer], inner: value}
        else:
            document[key] = value
    return json.dumps(document)


MALFORMED = {  # case: (write_like_planner arguments, a text the message must hold)
    "definition not JSON": (dict(definition="{not json"), "not JSON"),
    "definition a JSON list": (dict(definition="[1, 2, 3]"), "must be a JSON object"),
    "definition a JSON text": (dict(definition='"durations"'), "must be a JSON object"),
    "definition deeply nested": (dict(definition="[" * 100000 + "]" * 100000), "not JSON"),
    "definition a number, not a text": (dict(definition=pa.array([5])), "planner_definition"),
    "definition two texts": (dict(definition=["{}", "{}"]), "planner_definition"),
    "format missing": (dict(definition=_definition(format=None)), "format"),
    "format of another version": (dict(definition=_definition(format="planner-recording/v1")), "format"),
    "joint_names not a list": (dict(definition=_definition(joint_names="shoulder")), "joint_names"),
    "joint_names of numbers": (dict(definition=_definition(joint_names=[1, 2])), "joint_names"),
    "joint_names empty": (dict(definition=_definition(joint_names=[])), "joint_names"),
    "joint_names repeated": (dict(definition=_definition(joint_names=["a", "a"])), "distinct texts"),
    "joint_names with a newline": (dict(definition=_definition(joint_names=["sho\nulder", "elbow"])),
                                   "without control characters"),
    "joint_names with an escape": (dict(definition=_definition(joint_names=["\x1b[2J", "elbow"])),
                                   "without control characters"),
    "joint_names with a lone surrogate": (dict(definition=_definition(joint_names=["\udcff", "elbow"])),
                                          "of Unicode characters"),
    "joint_names with an empty name": (dict(definition=_definition(joint_names=["", "elbow"])), "each non-empty"),
    "durations_s an integer beyond any float": (dict(definition=_definition(durations_s=[10**400, 1, 1, 1])),
                                                "durations_s must be a list of numbers"),
    "limits an integer beyond any float": (dict(definition=_definition(**{"limits.velocity": [10**400, 1]})),
                                           "velocity must be a list of numbers"),
    "end marker rate beyond any float": (dict(end=json.dumps({**end_marker(_TIMES, RATE_HZ),
                                                              "sample_rate_hz": 10**400})), "sample_rate_hz"),
    "end marker count beyond any sampling": (dict(end=json.dumps({**end_marker(_TIMES, RATE_HZ),
                                                                  "sample_count": 10**400})),
                                             "sample_count must be a whole number from 1 to 1,000,000"),
    "a sample more than announced": (dict(times=np.append(_TIMES, _TIMES[-1] + _PERIOD),
                                          positions=np.vstack((_POSITIONS, _POSITIONS[-1:]))),
                                     "recording is not as the planner wrote it: 202 samples where the end marker "
                                     "announces 201"),
    "another application's samples": (dict(application="my_app", definition=None),
                                      "not a planner recording (application 'my_app', no trajectory definition"),
    "via_points_rad of one via knot too few": (dict(definition=_definition(via_points_rad=[[0, 0], [1, 0.5]])),
                                               "via_points_rad must be 3 lists (one per via knot) of 2 positions"),
    "via_points_rad with a text": (dict(definition=_definition(via_points_rad=[[0, 0], [0.5, "x"], [1, 0.5]])),
                                   "via_points_rad must be a list of numbers"),
    "via_points_rad with NaN": (dict(definition=_definition(via_points_rad=[[0, 0], [0.5, float("nan")], [1, 0.5]])),
                                "via_points_rad[3] is nan, not a finite number"),
    "joint_names one too many": (dict(definition=_definition(joint_names=["a", "b", "c"])), "coefficients_shape"),
    "durations_s a text": (dict(definition=_definition(durations_s="1, 1, 1, 1")), "durations_s"),
    "durations_s NaN": (dict(definition=_definition(durations_s=[1.0, float("nan"), 1.0, 1.0])), "durations_s[1]"),
    "durations_s infinite": (dict(definition=_definition(durations_s=[1.0, float("inf"), 1.0, 1.0])), "durations_s"),
    "durations_s negative": (dict(definition=_definition(durations_s=[1.0, -1.0, 1.0, 3.0])), "durations"),
    "durations_s booleans": (dict(definition=_definition(durations_s=[True, 1.0, 1.0, 1.0])), "durations_s"),
    "durations_s one too few": (dict(definition=_definition(durations_s=[2.0, 1.0, 1.0])), "coefficients_shape"),
    "coefficients_shape not 3 numbers": (dict(definition=_definition(coefficients_shape=[4, 8])), "coefficients_shape"),
    "coefficients_shape of floats": (dict(definition=_definition(coefficients_shape=[4.0, 2.0, 4.0])),
                                     "coefficients_shape"),
    "coefficients_shape not the count": (dict(definition=_definition(coefficients_shape=[4, 2, 3])), "coefficients"),
    "coefficients_shape huge": (dict(definition=_definition(coefficients_shape=[4, 2, 10**30])), "coefficients"),
    "coefficients of degree 1999": (dict(definition=_definition(coefficients_shape=[4, 2, 2000],
                                                                coefficients=[0.0] * 16000)), "1 to 16 coefficients"),
    "durations_s summing beyond any number": (dict(definition=_definition(durations_s=[1e308] * 4)),
                                              "total time must be finite"),
    "coefficients missing": (dict(definition=_definition(coefficients=None)), "coefficients"),
    "coefficients with a text": (dict(definition=_definition(coefficients=["0"] * 32)), "coefficients"),
    "coefficients with NaN": (dict(definition=_definition(coefficients=[float("nan")] * 32)), "coefficients[0]"),
    "via_knots beyond the segments": (dict(definition=_definition(via_knots=[0, 2, 9])), "via_knots"),
    "via_knots not integers": (dict(definition=_definition(via_knots=[0, 2.5, 4])), "via_knots"),
    "via_knots decreasing": (dict(definition=_definition(via_knots=[4, 2, 0])), "via_knots"),
    "limits not an object": (dict(definition=_definition(limits=[1, 2])), "limits"),
    "limits without jerk": (dict(definition=_definition(**{"limits.jerk": None})), "jerk"),
    "limits too short": (dict(definition=_definition(**{"limits.velocity": [5.0]})), "velocity"),
    "limits too long": (dict(definition=_definition(**{"limits.upper": [1.0, 2.0, 3.0]})), "upper"),
    "limits NaN": (dict(definition=_definition(**{"limits.acceleration": [float("nan"), 1.0]})), "acceleration[0]"),
    "limits not positive": (dict(definition=_definition(**{"limits.velocity": [0.0, 1.0]})), "velocity"),
    "limits an empty range": (dict(definition=_definition(**{"limits.upper": [-4.0, 1.0]})), "position range"),
    "end marker not JSON": (dict(end="done"), "trajectory/end"),
    "end marker count a text": (dict(end=json.dumps({**end_marker(_TIMES, RATE_HZ), "sample_count": "201"})),
                                "sample_count"),
    "end marker rate NaN": (dict(end=json.dumps({**end_marker(_TIMES, RATE_HZ), "sample_rate_hz": float("nan")})),
                            "sample_rate_hz"),
    "end marker rate half the samples'": (dict(end=json.dumps({**end_marker(_TIMES, RATE_HZ),
                                                                "sample_rate_hz": RATE_HZ / 2})),
                                          "not as the planner wrote it"),  # (sweep 22: the CSV followed the rate)
    "end marker rate 1e-300 Hz": (dict(end=json.dumps({**end_marker(_TIMES, RATE_HZ), "sample_rate_hz": 1e-300})),
                                  "not as the planner wrote it"),
    "end marker span one number": (dict(end=json.dumps({**end_marker(_TIMES, RATE_HZ), "time_span_s": [4.0]})),
                                   "time_span_s"),
    "samples of one joint too few": (dict(positions=_POSITIONS[:, :1]), "expected 2 joint positions"),
    "samples of one joint too many": (dict(positions=np.hstack([_POSITIONS, _POSITIONS[:, :1]])),
                                      "expected 2 joint positions"),
    "samples ragged": (dict(rows=[(t, q if k != 7 else q[:1]) for k, (t, q) in enumerate(zip(_TIMES, _POSITIONS))]),
                       "expected 2 joint positions"),
    "samples with NaN": (dict(positions=np.where(np.arange(len(_TIMES))[:, None] == 9, np.nan, _POSITIONS)),
                         "joint shoulder at 0.18 s is nan"),
    "samples static": (dict(static_samples=True), "timeline"),
}


@pytest.mark.parametrize("case", MALFORMED)
def test_malformed_recordings_are_errors_naming_the_field(case, tmp_path, capsys):
    arguments, named = MALFORMED[case]
    path = write_like_planner(tmp_path / "r.rrd", **arguments)
    with pytest.raises(RecordingError) as error:
        read_recording(path)
    assert named in str(error.value)
    assert main(["replay", str(path), "--check"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.startswith("error: ") and captured.err.count("\n") == 1
    assert len(captured.err) < 800


# ---------------------------------------------------------------------------- replay --check exit codes


def test_check_fails_on_violated_limits(tmp_path, capsys):
    tight = _definition(**{"limits.velocity": [0.1, 5.0]})
    assert main(["replay", str(write_like_planner(tmp_path / "r.rrd", definition=tight)), "--check"]) == 1
    out = capsys.readouterr().out
    assert "VIOLATIONS: joint shoulder velocity 28.6479 deg/s exceeds its limit 5.72958 deg/s" in out


@pytest.mark.parametrize("offset", [1e-6, 1e-8])
def test_check_fails_on_samples_off_the_trajectory(offset, tmp_path, capsys):
    positions = _POSITIONS.copy()
    positions[77, 1] += offset
    assert main(["replay", str(write_like_planner(tmp_path / "r.rrd", positions=positions)), "--check"]) == 1
    out = capsys.readouterr().out
    assert "SAMPLES OFF THE TRAJECTORY" in out and f"samples vs trajectory {offset:.3e} rad" in out
    assert "limits hold" not in out  # it said so, exiting 1


def test_exports_of_a_recording_that_fails_its_check_are_not_written(tmp_path, capsys):
    tight = _definition(**{"limits.velocity": [0.1, 5.0]})
    path = write_like_planner(tmp_path / "r.rrd", definition=tight)
    csv = tmp_path / "r.csv"
    assert main(["replay", str(path), "--check", "--export-csv", str(csv)]) == 1
    assert "VIOLATIONS" in (out := capsys.readouterr().out) and "; --export-csv not written: the check failed" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.rrd"]
    assert main(["replay", str(write_like_planner(tmp_path / "ok.rrd")), "--check", "--export-csv", str(csv)]) == 0
    assert csv.is_file() and "not written" not in capsys.readouterr().out


def test_a_recording_name_too_long_for_the_file_system_is_a_named_error(tmp_path, capsys):
    path = tmp_path / ("y" * 300 + ".rrd")
    with pytest.raises(RecordingError, match=r"characters\): File name too long$"):
        read_recording(path)
    assert main(["replay", str(path), "--check"]) == 2 and capsys.readouterr().err.count("\n") == 1


@pytest.mark.parametrize("link", ["loop", "dangling"])
def test_a_symbolic_link_to_nothing_is_named_as_one(link, tmp_path):
    path = tmp_path / "r.rrd"
    path.symlink_to(path if link == "loop" else tmp_path / "gone.rrd")
    with pytest.raises(RecordingError, match=r"r\.rrd: a symbolic link to nothing \(its target is missing, or"):
        read_recording(path)


def test_check_passes_only_when_everything_holds(tmp_path, capsys):
    assert main(["replay", str(write_like_planner(tmp_path / "r.rrd")), "--check"]) == 0
    assert "2 joints, 201 samples, T = 4.0000 s" in capsys.readouterr().out


# ---------------------------------------------------------------------------- names


NAMES = ["shoulder pan", "wrist/3", "$x^2$", "\\frac{", "a\\b", "关节", "😀", "x.y", "*", "[0]", "a:b", "limits"]


def test_any_joint_and_task_name_is_logged_as_one_entity_and_read_back(tmp_path, capfd):
    import rerun as rr
    import rerun.chunk as rc

    trajectory, limits, _, _ = small_plan()
    via = np.repeat(np.linspace(0.0, 1.0, 3)[:, None], len(NAMES), axis=1)
    trajectory = get_family("cubic").build(via, trajectory.durations)
    limits = JointLimits.create(len(NAMES), upper=[2.0] * len(NAMES), velocity=[5.0] * len(NAMES))
    result = SimpleNamespace(
        trajectory=trajectory, joint_names=NAMES, limits=limits, robot=None, feasible=True,
        task=SimpleNamespace(name="task $\\frac{$ / 关节 😀", family="cubic", sample_rate_hz=RATE_HZ,
                             optimizer={"algorithm": "test"}),
        optimization=SimpleNamespace(algorithm="test", feasible=True))
    path = tmp_path / "names.rrd"
    write_recording(result, path)
    recorded = read_recording(path)
    assert recorded.joint_names == NAMES and recorded.check().passed
    entities = {chunk.entity_path for chunk in rc.RrdReader(str(path)).stream().to_chunks()}
    for name in NAMES:
        for profile in ("position", "velocity", "acceleration", "jerk"):
            assert rr.new_entity_path(["profiles", profile, name]) in entities
        assert rr.new_entity_path(["profiles", "position", "limits", name, "upper"]) in entities
        assert rr.new_entity_path(["profiles", "position", "via_points", name]) in entities
    assert len([e for e in entities if e.startswith("/profiles/jerk/") and "/limits/" not in e]) == len(NAMES)
    assert capfd.readouterr().err == ""  # Rerun warns on stderr about paths it has to reinterpret


# ---------------------------------------------------------------------------- the viewer


@pytest.fixture
def recording(tmp_path):
    return write_like_planner(tmp_path / "r.rrd")


@pytest.fixture
def no_viewer(monkeypatch):
    """Fail the test if a viewer process is started."""
    def refuse(*args, **kwargs):
        raise AssertionError("a viewer was started")
    monkeypatch.setattr(subprocess, "Popen", refuse)


@pytest.mark.parametrize("platform", ["linux", "freebsd13"])
def test_replay_without_a_display_fails_before_starting_the_viewer(platform, recording, monkeypatch, no_viewer,
                                                                   capsys):
    monkeypatch.setattr(sys, "platform", platform)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setenv("WAYLAND_DISPLAY", "")
    assert main(["replay", str(recording)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: no display") and err.count("\n") == 1
    assert "--check" in err and "--export-csv" in err and "--screenshot" in err and "machine with a display" in err
    monkeypatch.setattr(sys, "argv", [".venv/bin/planner", "replay", str(recording)])  # as the user typed it
    assert main(["replay", str(recording)]) == 2
    assert f"`.venv/bin/planner replay {recording} --check`" in capsys.readouterr().err


def test_replay_reports_a_viewer_that_fails_at_start_up(recording, monkeypatch, capsys):
    import planner.recording as module

    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(module, "VIEWER_COMMAND",
                        (sys.executable, "-c",
                         "import sys; print('starting', flush=True); sys.exit('cannot open display :99')"))
    assert main(["replay", str(recording)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exited with code 1" in err and "cannot open display :99" in err


def test_replay_returns_once_the_viewer_is_up(recording, monkeypatch, capsys):
    started = []

    class RunningViewer:
        def __init__(self, command, **kwargs):
            started.append(command)

        def wait(self, timeout=None):
            raise subprocess.TimeoutExpired("rerun", timeout)
    monkeypatch.setenv("WAYLAND_DISPLAY", "wayland-0")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setattr(subprocess, "Popen", RunningViewer)
    assert main(["replay", str(recording)]) == 0
    assert started[0][-1] == str(recording) and capsys.readouterr().err == ""


def test_a_bad_recording_fails_before_the_viewer(tmp_path, monkeypatch, no_viewer):
    monkeypatch.setenv("DISPLAY", ":0")
    assert main(["replay", str(write_like_planner(tmp_path / "r.rrd", end=None))]) == 2


# ---------------------------------------------------------------------------- --export-csv


def test_export_to_a_folder_fails_before_reading(tmp_path, capsys):
    target = tmp_path / "x.csv"
    target.mkdir()
    assert main(["replay", str(tmp_path / "missing.rrd"), "--export-csv", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"output file {target} is an existing folder" in err
    assert [p.name for p in tmp_path.iterdir()] == ["x.csv"] and list(target.iterdir()) == []


@pytest.mark.parametrize("below", ["x.csv", "sub/x.csv"])
def test_export_below_a_file_fails(below, recording, tmp_path, capsys):
    blocker = tmp_path / "notes.txt"
    blocker.write_text("a file")
    target = blocker / below
    assert main(["replay", str(recording), "--export-csv", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(target) in err and f"lies under {blocker}, which is a file" in err
    assert blocker.read_text() == "a file"


def test_export_over_the_recording_itself_fails(recording, capsys):
    before = recording.read_bytes()
    assert main(["replay", str(recording), "--export-csv", str(recording)]) == 2
    assert "is the recording itself" in capsys.readouterr().err and recording.read_bytes() == before


@pytest.mark.parametrize("umask", [0o022, 0o027, 0o002])
def test_export_gets_the_usual_permissions(umask, recording, tmp_path):
    previous = os.umask(umask)
    try:
        assert main(["replay", str(recording), "--export-csv", str(tmp_path / "out" / "x.csv")]) == 0
    finally:
        os.umask(previous)
    assert (tmp_path / "out" / "x.csv").stat().st_mode & 0o777 == 0o666 & ~umask
    times, values = read_trajectory_csv(tmp_path / "out" / "x.csv")
    assert len(times) == 201 and times[-1] == pytest.approx(4.0)


def test_a_plan_with_repeated_via_points_replays_and_checks(tmp_path, capsys):
    """Repeated via-points share a knot: the recording keeps them and --check passes."""
    import yaml
    task = {"version": 1, "waypoints": {"joints_deg": [[0, 0], [30, 10], [30, 10], [60, -20]]},
            "limits": {"velocity_deg_s": [40, 40], "acceleration_deg_s2": [80, 80], "jerk_deg_s3": [300, 300]}}
    (tmp_path / "task.yaml").write_text(yaml.safe_dump(task))
    out = tmp_path / "out"
    assert main(["plan", str(tmp_path / "task.yaml"), "--out", str(out), "--quiet"]) == 0
    recorded = read_recording(out / "trajectory.rrd")
    assert list(recorded.trajectory.via_knots) == [0, 2, 2, 4]
    assert main(["replay", str(out / "trajectory.rrd"), "--check"]) == 0
    assert "limits hold" in capsys.readouterr().out


def test_example_robot_data_meshes_resolve_without_warnings(tmp_path, capfd):
    """The UR5's package:// meshes are found (no importer warning on stderr), and the 3D view
    draws visual geometry only."""
    result = plan(TASKS / "ur5_pick_and_place.yaml")
    capfd.readouterr()
    write_recording(result, tmp_path / "ur5.rrd")
    err = capfd.readouterr().err
    assert "WARN" not in err and "package://" not in err
    import rerun.chunk as rc
    chunks = rc.RrdReader(str(tmp_path / "ur5.rrd")).stream().to_chunks()
    meshes = {c.entity_path for c in chunks if "/visual_geometries/" in c.entity_path
              and any("Asset3D" in name for name in c.to_record_batch().schema.names)}
    assert len(meshes) >= 7  # base, shoulder, upper arm, forearm, three wrists


# ---------------------------------------------------------------------------- what the viewer shows


def static_components(path, content: str) -> dict[str, dict[str, list]]:
    """The static components of the entities under ``content``: {entity: {component: values}}."""
    import rerun.chunk as rc
    found: dict[str, dict[str, list]] = {}
    for chunk in rc.RrdReader(str(path)).stream().filter(content=content).to_chunks():
        if chunk.is_static:
            batch = chunk.to_record_batch()
            found.setdefault(chunk.entity_path, {}).update(
                {n.split(":")[-1]: batch.column(n).to_pylist()[0] for n in batch.schema.names if ":" in n})
    return found


def test_each_joint_has_one_colour_and_its_name_in_every_plot(planned):
    import rerun as rr

    from planner.recording import JOINT_COLOURS
    result, out = planned
    styles = static_components(out / "trajectory.rrd", "/profiles/**")
    for j, name in enumerate(result.joint_names):
        rgba = int(JOINT_COLOURS[j % 10][1:] + "ff", 16)
        entities = [rr.new_entity_path(["profiles", p, name]) for p in ("position", "velocity", "acceleration", "jerk")]
        entities += [rr.new_entity_path(["profiles", p, "limits", name, side])
                     for p in ("velocity", "acceleration", "jerk") for side in ("lower", "upper")]
        entities.append(rr.new_entity_path(["profiles", "position", "via_points", name]))
        for entity in entities:  # a limit is named as its joint: the legend lists the joint once, never the limit
            assert styles[entity]["names"] == [name] and styles[entity]["colors"] == [rgba], entity
    widths = {e: s["widths"][0] for e, s in styles.items() if "widths" in s}
    limit_widths = [w for e, w in widths.items() if "/limits/" in e]
    assert max(limit_widths) < min(w for e, w in widths.items() if "/limits/" not in e)


def test_limits_are_dashed_lines(planned):
    """A limit line is broken by gaps (NaN), so it reads as dashed, unlike the joint's own curve."""
    import rerun as rr
    import rerun.chunk as rc
    result, out = planned
    entity = rr.new_entity_path(["profiles", "jerk", "limits", result.joint_names[0], "upper"])
    values = [v[0] for c in rc.RrdReader(str(out / "trajectory.rrd")).stream().filter(content=entity).to_chunks()
              if not c.is_static for v in c.to_record_batch().column("Scalars:scalars").to_pylist()]
    finite = [v for v in values if v == v]
    assert len(finite) > 50 and len(values) - len(finite) > 25
    assert np.allclose(finite, np.rad2deg(result.limits.jerk[0]))


def test_summary_panel_says_what_was_planned(planned):
    result, out = planned
    summary = static_components(out / "trajectory.rrd", "/summary")["/summary"]
    text = summary["text"][0] if isinstance(summary["text"], list) else summary["text"]
    assert summary["media_type"] in ("text/markdown", ["text/markdown"])
    for part in (result.task.name.replace("_", "\\_"), result.robot.name.replace("_", "\\_"), "hybrid",
                 f"{result.trajectory.total_time:.4f} s", "feasible", "velocity", "acceleration", "jerk"):
        assert part in text, part
    # The algorithm asked for, and the one whose result was kept where they differ (the panel said
    # "cuckoo" where the task and the command line said "default").
    requested, kept = result.task.optimizer["algorithm"], result.optimization.algorithm
    assert (f"**optimizer** {requested} \\({kept}\\)" if requested != kept else f"**optimizer** {kept} ·") in text


def test_coincident_waypoints_share_one_label_and_the_tool_moves(planned):
    result, out = planned
    scene = static_components(out / "trajectory.rrd", "/scene/**")
    labels = scene["/scene/waypoint_labels"]["labels"]
    if result.task.name == "ur5_pick_and_place":  # pick and lift, place and lift: the same places
        assert [label.split(" (")[0] for label in labels] == ["waypoints 0, 2", "waypoint 1", "waypoints 3, 5",
                                                              "waypoint 4"]
    else:
        assert len(labels) == len(result.ik) and labels[0].startswith("waypoint 0 (IK ")
    import rerun.chunk as rc
    moving = [c for c in rc.RrdReader(str(out / "trajectory.rrd")).stream().filter(content="/scene/tool").to_chunks()
              if not c.is_static]
    assert sum(c.num_rows for c in moving) == len(result.trajectory.sample(result.task.sample_rate_hz)[0])


def test_inserted_poses_look_unlike_waypoints(tmp_path):
    import yaml
    task = yaml.safe_load((TASKS / "ur5_pick_and_place.yaml").read_text())
    task["path"] = {"mode": "linear"}
    result = plan(task)
    write_recording(result, tmp_path / "linear.rrd")
    scene = static_components(tmp_path / "linear.rrd", "/scene/**")
    inserted, waypoints = scene["/scene/inserted_poses"], scene["/scene/waypoint_labels"]
    assert "labels" not in inserted and inserted["colors"] != waypoints["colors"]
    assert inserted["radii"][0] < waypoints["radii"][0]


def test_the_eye_sees_every_point():
    from planner.recording import framing_eye
    rng = np.random.default_rng(1)
    for _ in range(20):
        points = rng.uniform(-1, 1, (50, 3)) * rng.uniform(0.05, 2, 3)
        eye = framing_eye(points, points[:30], points[30:35])
        position, target = (np.array(eye.position.as_arrow_array().to_pylist()[0]),
                            np.array(eye.look_target.as_arrow_array().to_pylist()[0]))
        forward = (target - position) / np.linalg.norm(target - position)
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        rays = points - position
        depth = rays @ forward
        assert np.all(depth > 0)
        vertical = np.arctan(np.abs(rays @ up) / depth).max() / np.radians(27.5)  # of half the 55 deg field of view
        horizontal = np.arctan(np.abs(rays @ right) / depth).max() / np.arctan(1.2 * np.tan(np.radians(27.5)))
        assert max(vertical, horizontal) < 1 and max(vertical, horizontal) > 0.8  # inside, and filling it


@pytest.mark.parametrize("limit_deg, top_deg", [(90.0, 104.0), (60.0, 104.0), (180.0, 194.4), (1200.0, 1296.0)])
def test_derivative_plots_show_their_limits_and_labelled_ticks(limit_deg, top_deg):
    """The range holds the limits with a margin, and reaches the next power of ten when just short of it
    (the plots label power-of-ten ticks only: +-95 would show a lone 0)."""
    from planner.recording import _symmetric_range
    values = np.array([[0.5 * limit_deg, -0.2 * limit_deg]])
    low, high = _symmetric_range(values, np.array([limit_deg, limit_deg / 2]))
    assert low == -high and high == pytest.approx(top_deg)


def test_long_plans_log_fewer_profile_values_but_every_sample(planned, tmp_path, monkeypatch):
    """Above ``PROFILE_SAMPLES`` times the plots are logged at fewer, evenly spaced times, with the
    trajectory's exact values there; ``trajectory/samples`` and the check keep every sample."""
    import rerun as rr
    import rerun.chunk as rc

    import planner.recording as recording
    result, _ = planned
    monkeypatch.setattr(recording, "PROFILE_SAMPLES", 40)
    path = tmp_path / "short.rrd"
    write_recording(result, path)
    trajectory = result.trajectory
    entity = rr.new_entity_path(["profiles", "velocity", result.joint_names[1]])
    batches = [c.to_record_batch() for c in rc.RrdReader(str(path)).stream().filter(content=entity).to_chunks()
               if not c.is_static]
    times = np.concatenate([np.asarray(b.column("time").cast(pa.int64()).to_pylist()) for b in batches]) / 1e9
    values = np.concatenate([[v[0] for v in b.column("Scalars:scalars").to_pylist()] for b in batches])
    assert 30 <= len(times) <= 41 and times[0] == 0 and abs(times[-1] - trajectory.total_time) < 0.2
    np.testing.assert_allclose(values, np.rad2deg(trajectory.evaluate(times, 1)[:, 1]), atol=1e-6)
    recorded = read_recording(path)
    assert len(recorded.times) == len(trajectory.sample(result.task.sample_rate_hz)[0])
    assert recorded.check().passed


def test_the_recorded_robot_is_animated_joint_by_joint(planned):
    """Every planned joint's transform is logged once per sample on the time timeline, and the robot's
    geometry is there (the recording once lost its robot without a test noticing)."""
    import rerun.chunk as rc
    result, out = planned
    rows: dict[str, int] = {}
    geometry = 0
    for chunk in rc.RrdReader(str(out / "trajectory.rrd")).stream().filter(content="/robot/**").to_chunks():
        if "joint_transforms" not in chunk.entity_path:
            geometry += 1
        elif not chunk.is_static and "time" in chunk.to_record_batch().schema.names:
            rows[chunk.entity_path] = rows.get(chunk.entity_path, 0) + chunk.num_rows
    samples = len(result.trajectory.sample_times(result.task.sample_rate_hz))
    assert {name: rows.get(f"/robot/joint_transforms/{name}") for name in result.joint_names} == \
        {name: samples for name in result.joint_names}
    assert geometry > 0


def test_absurd_visual_shapes_are_left_out_of_the_framing(tmp_path):
    """A 1e300 m box overflowed (numpy warnings on a successful run's stderr) and would frame nothing."""
    from planner.recording import _link_visuals

    urdf = tmp_path / "boxes.urdf"
    urdf.write_text('<robot name="r">'
                    '<link name="a"><visual><geometry><box size="0.3 0.4 1.2"/></geometry></visual></link>'
                    '<link name="b"><visual><geometry><box size="1e300 1e300 1e300"/></geometry></visual></link>'
                    '<link name="c"><visual><origin xyz="nan 0 0"/><geometry><sphere radius="0.1"/></geometry>'
                    '</visual></link></robot>')
    with np.errstate(all="raise"):
        visuals = _link_visuals(urdf)
    assert list(visuals) == ["a"] and visuals["a"][0][1] == pytest.approx(0.65)


def test_a_long_slow_recording_reads_back_whole(tmp_path):
    """200,001 samples (a 4000 s trajectory at 50 Hz): every one is read back, in order, exactly."""
    trajectory, limits, _, _ = small_plan()
    slow = get_family("cubic").build([[0.0, 0.0], [0.5, -1.0], [1.0, 0.5]], [1000.0] * 4)
    result = SimpleNamespace(trajectory=slow, joint_names=["a", "b"], limits=limits, robot=None, feasible=True,
                             task=SimpleNamespace(name="slow", family="cubic", sample_rate_hz=RATE_HZ,
                                                  optimizer={"algorithm": "test"}),
                             optimization=SimpleNamespace(algorithm="test", feasible=True))
    path = tmp_path / "slow.rrd"
    write_recording(result, path)
    recorded = read_recording(path)
    times, values = slow.sample(RATE_HZ)
    assert len(recorded.times) == len(times) == 200001
    np.testing.assert_allclose(recorded.times, times, atol=1e-9)
    np.testing.assert_array_equal(recorded.positions, values[0])
    assert recorded.check().passed


def test_a_definition_whose_trajectory_breaks_its_limits_fails_its_check(tmp_path, capsys):
    """A forged definition: the trajectory of the samples, with limits it breaks. Read back whole, but
    ``check`` (and ``replay --check``) says no and names the violation."""
    trajectory, _, _, _ = small_plan()
    tight = JointLimits.create(2, lower=[-3.0, -3.0], velocity=[0.1, 0.1], jerk=[100.0, 100.0])
    definition = json.dumps(trajectory_definition(trajectory, tight, ["shoulder", "elbow"]))
    path = write_like_planner(tmp_path / "forged.rrd", definition=definition)
    check = read_recording(path).check()
    assert not check.passed and check.deviation <= check.tolerance and not check.breaks
    assert [(v.index, v.quantity, v.limit) for v in check.violations] == [(0, "velocity", 0.1), (1, "velocity", 0.1)]
    assert all(abs(v.value) > v.limit for v in check.violations)
    assert main(["replay", str(path), "--check"]) == 1
    said = capsys.readouterr().out
    assert "VIOLATIONS: " in said and "velocity" in said and "limits hold" not in said


def test_a_recording_whose_trajectory_jumps_fails_its_check(tmp_path, capsys):
    """A consistent rewrite (samples from the changed trajectory) with a 30 deg jump at a knot, each segment
    within every limit: ``replay --check`` said "limits hold" (it bounded each segment alone)."""
    trajectory, limits, _, _ = small_plan()
    coefficients = np.array(trajectory.coefficients)
    coefficients[2, 0, 0] += np.deg2rad(30)
    jumping = PiecewisePolynomial(trajectory.durations, coefficients, trajectory.via_knots)
    result = SimpleNamespace(trajectory=jumping, joint_names=["a", "b"], limits=limits, robot=None, feasible=True,
                             task=SimpleNamespace(name="jump", family="cubic", sample_rate_hz=RATE_HZ,
                                                  optimizer={"algorithm": "test"}),
                             optimization=SimpleNamespace(algorithm="test", feasible=True))
    write_recording(result, tmp_path / "jump.rrd")
    check = read_recording(tmp_path / "jump.rrd").check()
    assert check.deviation <= check.tolerance and check.largest_ratio <= 1 and not check.passed
    assert not check.violations and (check.breaks[0].joint, check.breaks[0].joint_index,
                                                       check.breaks[0].quantity) == ("a", 0, "position")
    assert check.breaks[0].value == pytest.approx(np.deg2rad(30)) and check.findings[0] == check.breaks[0]
    assert main(["replay", str(tmp_path / "jump.rrd"), "--check"]) == 1
    said = capsys.readouterr().out
    assert "VIOLATIONS: joint a position jumps by 30 deg at knot 2 (t = 2 s)" in said and "limits hold" not in said


def test_a_recording_whose_trajectory_misses_a_via_point_fails_its_check(tmp_path, capsys):
    """The recording carries the via-points it was planned through; a trajectory that does not pass one (a
    consistent rewrite, continuous and within every limit) fails ``replay --check`` naming it. Where they
    are passed, the check holds; a recording without them is read as before."""
    trajectory, limits, _, _ = small_plan()
    via = np.array([[0.0, 0.0], [0.5, -1.0], [1.0, 0.5]])
    for name, given in (("passes", via), ("misses", via + [[0.0, 0.0], [0.0, 0.1], [0.0, 0.0]])):
        result = SimpleNamespace(trajectory=trajectory, joint_names=["a", "b"], limits=limits, robot=None,
                                 feasible=True, via_points=given,
                                 task=SimpleNamespace(name=name, family="cubic", sample_rate_hz=RATE_HZ,
                                                      optimizer={"algorithm": "test"}),
                                 optimization=SimpleNamespace(algorithm="test", feasible=True))
        write_recording(result, tmp_path / f"{name}.rrd")
        recorded = read_recording(tmp_path / f"{name}.rrd")
        np.testing.assert_array_equal(recorded.via_points, given)
        assert recorded.check().passed == (name == "passes")
    assert main(["replay", str(tmp_path / "misses.rrd"), "--check"]) == 1
    assert "VIOLATIONS: joint b misses via-point 1 by 5.72958 deg (t = 2 s)" in capsys.readouterr().out


def test_replay_replaces_an_existing_file_only_with_force(recording, tmp_path, capsys):
    """--export-csv onto a user's file replaced it silently."""
    target = tmp_path / "mine.csv"
    target.write_text("precious")
    assert main(["replay", str(recording), "--export-csv", str(target)]) == 2
    assert "exists; add --force to replace it" in capsys.readouterr().err and target.read_text() == "precious"
    assert main(["replay", str(recording), "--export-csv", str(target), "--force"]) == 0
    assert read_trajectory_csv(target)[0][0] == 0.0


@pytest.mark.parametrize("path", [None, b"x.rrd", 3])
def test_a_recording_path_that_is_no_path_is_a_recording_error(path):
    with pytest.raises(RecordingError, match="a recording is given by its path"):
        read_recording(path)


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (a device that is always full)")
def test_a_full_disk_is_an_error_not_a_hang(planned):
    """Writing to a full device raises at once (Rerun's own file sink hung for good in a flush after its
    writer thread died of ENOSPC, deaf to Ctrl-C; the outputs' publisher names the OSError)."""
    import errno
    result, _ = planned
    with pytest.raises(OSError) as caught:
        write_recording(result, Path("/dev/full"))
    assert caught.value.errno == errno.ENOSPC


def test_a_robot_with_locked_joints_outside_neutral_records_without_a_warning(tmp_path):
    """A successful --quiet plan printed Rerun's clamping warning (with a source line) to stderr."""
    import warnings
    result = plan({"version": 1, "robot": {"name": "allegro_right_hand", "tool_frame": "link_3.0_tip"},
                   "waypoints": {"joints_deg": [[0, 0, 0, 0], [20, 60, 60, 60]]},
                   "limits": {"acceleration_deg_s2": [300] * 4, "jerk_deg_s3": [3000] * 4}})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        write_recording(result, tmp_path / "r.rrd")
    read_recording(tmp_path / "r.rrd")


def test_the_summary_panel_says_what_the_exact_check_says():
    """The panel's verdict is the plan's (``PlanResult.feasible``: the exact check of the trajectory
    written), not the optimizer's own flag."""
    from planner.recording import plan_summary

    trajectory, limits, _, _ = small_plan()
    verdicts = []
    for feasible in (True, False):
        result = SimpleNamespace(trajectory=trajectory, joint_names=["a", "b"], limits=limits, robot=None,
                                 feasible=feasible, task=SimpleNamespace(name="t", family="cubic",
                                                                         sample_rate_hz=RATE_HZ,
                                                                         optimizer={"algorithm": "test"}),
                                 optimization=SimpleNamespace(algorithm="test", feasible=True))
        verdicts.append(plan_summary(result).splitlines()[0])
    assert verdicts == ["### t: feasible", "### t: NOT feasible (a limit is exceeded)"]


@pytest.mark.parametrize("change", ["edited", "removed"])
def test_a_urdf_changed_after_planning_is_not_drawn(tmp_path, change):
    """The recording reads the URDF again: one edited since the plan would draw another robot than the
    plan's (silently), one removed could not be drawn. Both are refused, and nothing is published."""
    import shutil

    from planner import make_task

    root = Path(__file__).resolve().parents[1]
    urdf = tmp_path / "puma.urdf"
    shutil.copy(root / "robots" / "puma560.urdf", urdf)
    shutil.copy(root / "robots" / "puma560.limits.yaml", tmp_path / "puma.limits.yaml")
    result = plan(make_task(robot={"urdf": urdf, "tool_frame": "tool"},
                            joints_deg=[[0, 0, 0, 0, 0, 0], [10, -10, 20, 0, 10, 0]]))
    if change == "edited":
        urdf.write_text("<robot name='x'><link name='a'/></robot>")
    else:
        urdf.unlink()
    expected = "has changed since the robot was loaded" if change == "edited" else "cannot read the URDF"
    with pytest.raises(RecordingError, match=expected):
        result.save(tmp_path / "out")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("change", ["fifo", "folder", "removed"])
def test_a_mesh_changed_after_planning_is_not_drawn(tmp_path, change):
    """Rerun reads the meshes when it draws the robot: a mesh made a pipe since the robot was loaded hung the
    save forever (sweep 17), a folder or a removed one left the link undrawn without a word. All three are
    refused, naming the mesh, and nothing is published."""
    import os

    from planner import make_task

    (tmp_path / "link.stl").write_bytes(b"solid x\nendsolid x\n")
    urdf = tmp_path / "meshy.urdf"
    urdf.write_text("""<robot name="meshy"><link name="base"/>
  <link name="arm"><visual><geometry><mesh filename="link.stl"/></geometry></visual></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="1" effort="1"/></joint></robot>""")
    result = plan(make_task(robot={"urdf": urdf, "tool_frame": "arm"}, joints_deg=[[0], [10]],
                            limits={"acceleration_deg_s2": [10], "jerk_deg_s3": [10]}))
    (tmp_path / "link.stl").unlink()
    if change == "fifo":
        os.mkfifo(tmp_path / "link.stl")
    elif change == "folder":
        (tmp_path / "link.stl").mkdir()
    expected = (r"the mesh 'link.stl' the URDF .*meshy.urdf names is gone since the robot was loaded"
                if change == "removed" else r"mesh 'link.stl' is not a regular file .*, which it was not when")
    with pytest.raises(RecordingError, match=expected):
        result.save(tmp_path / "out")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_a_floating_or_planar_joint_off_the_chain_is_drawn_at_its_origin(tmp_path, kind):
    """A body hung on a floating (or planar) joint beside the arm: the plan locks it, and the recording
    failed with an internal NotImplementedError (Rerun computes no transform of such joints; sweep 19).
    It is drawn at the joint's origin, and the recording reads back and checks."""
    from planner import make_task

    urdf = tmp_path / "two.urdf"
    urdf.write_text(f"""<robot name="two"><link name="base"/>
  <link name="arm"><visual><geometry><box size="0.1 0.1 0.5"/></geometry></visual></link>
  <link name="obj"><visual><geometry><box size="0.05 0.05 0.05"/></geometry></visual></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
  <joint name="free" type="{kind}"><parent link="base"/><child link="obj"/><origin xyz="0.5 0 0.3"/>
    <axis xyz="0 0 1"/></joint></robot>""")
    result = plan(make_task(robot={"urdf": urdf, "tool_frame": "arm"}, joints_deg=[[0], [10]],
                            limits={"acceleration_deg_s2": [10], "jerk_deg_s3": [10]}))
    result.save(tmp_path / "out")
    assert read_recording(tmp_path / "out" / "trajectory.rrd").check().passed


def test_a_robot_limited_plan_records_its_torque_over_the_limit_and_its_ratios_in_the_summary(tmp_path):
    """With torque and tool-speed limits, the torque plot holds each joint's torque over its limit (the
    pendulum's closed form, tau = (I + m l^2) q'' - m g l cos q, by hand, at the recorded times) with the
    limits at +-1, and the summary panel's table lists the torque's and the tool speed's largest ratios
    beside the kinematic ones (as summary.json gives them)."""
    import rerun as rr
    import rerun.chunk as rc

    from conftest import pendulum

    robot = pendulum(tmp_path)
    result = plan({"version": 1, "name": "swing", "robot": {"urdf": str(robot.urdf_path), "tool_frame": "tip"},
                   "waypoints": {"joints_deg": [[-90], [60], [-30], [90]]},
                   "limits": {"velocity_deg_s": [400], "acceleration_deg_s2": [4000], "jerk_deg_s3": [40000],
                              "torque_nm": [12.0], "tool_speed_m_s": 1.5}})
    path = tmp_path / "r.rrd"
    write_recording(result, path)
    entity = rr.new_entity_path(["profiles", "torque", "swing"])
    times, values = [], []
    for chunk in rc.RrdReader(str(path)).stream().filter(content=entity).to_chunks():
        if not chunk.is_static:
            batch = chunk.to_record_batch()
            times += (batch.column("time").cast(pa.int64()).to_numpy() / 1e9).tolist()
            values += [v[0] for v in batch.column("Scalars:scalars").to_pylist()]
    q, qdd = (result.trajectory.evaluate(np.array(times), order)[:, 0] for order in (0, 2))
    expected = ((0.03 + 2.0 * 0.25) * qdd - 2.0 * 9.81 * 0.5 * np.cos(q)) / 12.0
    assert len(values) > 100
    np.testing.assert_allclose(values, expected, atol=1e-6)
    upper = rr.new_entity_path(["profiles", "torque", "limits", "swing", "upper"])
    dashes = [v[0] for c in rc.RrdReader(str(path)).stream().filter(content=upper).to_chunks() if not c.is_static
              for v in c.to_record_batch().column("Scalars:scalars").to_pylist()]
    assert {v for v in dashes if v == v} == {1.0}
    summary = static_components(path, "/summary")["/summary"]
    text = summary["text"][0] if isinstance(summary["text"], list) else summary["text"]
    figures = result.summary()["robot_limits"]
    header, _, ratios, joints = [line for line in text.splitlines() if line.startswith("|")]
    assert header.split(" | ")[-2:] == ["torque", "tool speed |"]
    assert ratios.split(" | ")[-2:] == [f"{figures['torque_ratio'][0]:.3f}", f"{figures['tool_speed_ratio']:.3f} |"]
    assert joints.split(" | ")[-2:] == ["swing", "(tool) |"]
    assert max(figures["torque_ratio"][0], figures["tool_speed_ratio"]) > 0.999
