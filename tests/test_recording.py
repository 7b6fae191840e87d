import json
from pathlib import Path

import numpy as np
import pytest

from planner import RecordingError
from planner.cli import main
from planner.export import read_trajectory_csv
from planner.pipeline import plan
from planner.recording import read_recording

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
    assert summary["total_time_s"] == pytest.approx(sum(summary["durations_s"]))
    assert summary["robot"]["name"] == result.robot.name and len(summary["ik"]["waypoints"]) == len(result.ik)
    assert all(w["position_error_m"] <= 1e-9 for w in summary["ik"]["waypoints"])
    # The trajectory passes through the IK via-points at the via times, and its samples respect the limits.
    trajectory = result.trajectory
    np.testing.assert_allclose(trajectory.evaluate(summary["via_times_s"]), result.via_points, atol=1e-9)
    times, values = read_trajectory_csv(out / "trajectory.csv")
    for d in (1, 2, 3):
        assert np.all(np.abs(values[d]).max(axis=0) <= result.limits.magnitudes[d - 1] * (1 + 1e-6))
    coefficients = json.loads((out / "coefficients.json").read_text())
    assert coefficients["joint_names"] == result.robot.joint_names
    np.testing.assert_allclose(np.array(coefficients["coefficients"]), trajectory.coefficients)


def test_recording_round_trip_matches_planner_samples(planned):
    result, out = planned
    recorded = read_recording(out / "trajectory.rrd")
    times, values = result.trajectory.sample(result.task.sample_rate_hz)
    np.testing.assert_allclose(recorded.times, times, atol=1e-9)  # Rerun keeps time in whole nanoseconds
    np.testing.assert_array_equal(recorded.positions, values[0])  # float64 kept exactly
    np.testing.assert_array_equal(recorded.trajectory.coefficients, result.trajectory.coefficients)
    assert recorded.joint_names == result.joint_names
    np.testing.assert_array_equal(recorded.limits.jerk, result.limits.jerk)


def test_replay_check_and_export(planned, tmp_path, capsys):
    result, out = planned
    assert main(["replay", str(out / "trajectory.rrd"), "--check", "--export-csv", str(tmp_path / "x.csv")]) == 0
    assert "limits hold" in capsys.readouterr().out
    times, values = read_trajectory_csv(tmp_path / "x.csv")
    assert times[-1] == pytest.approx(result.trajectory.total_time)


def test_missing_corrupt_and_foreign_recordings(tmp_path, capsys):
    import rerun as rr
    with pytest.raises(RecordingError, match="no such recording"):
        read_recording(tmp_path / "missing.rrd")
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


def test_truncated_recording_is_an_error(planned, tmp_path):
    _, out = planned
    truncated = tmp_path / "truncated.rrd"
    data = (out / "trajectory.rrd").read_bytes()
    truncated.write_bytes(data[: len(data) // 3])
    with pytest.raises(RecordingError):
        read_recording(truncated)


def test_failure_midway_leaves_nothing(tmp_path, monkeypatch):
    import planner.pipeline as pipeline

    def broken(*args, **kwargs):
        raise RecordingError("simulated failure while recording")
    monkeypatch.setattr(pipeline, "write_recording", broken)
    out = tmp_path / "out"
    assert main(["plan", str(TASKS / "ur5_pick_and_place.yaml"), "--out", str(out), "--quiet"]) == 2
    assert list(tmp_path.iterdir()) == []


def test_export_to_unwritable_place_leaves_nothing(planned, tmp_path, capsys):
    _, out = planned
    target = tmp_path / "x.csv"
    target.mkdir()  # a folder where the file should go: refused before anything is written
    assert main(["replay", str(out / "trajectory.rrd"), "--export-csv", str(target)]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert [p.name for p in tmp_path.iterdir()] == ["x.csv"] and target.is_dir()
