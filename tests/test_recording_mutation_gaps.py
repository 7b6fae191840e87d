"""Gaps a hand mutation run over ``planner/recording.py`` found: each test kills a mutant the recording tests let
live, comparing with an independent computation (the .rrd read back with Rerun's own chunk API, the trajectory
sampled here)."""

import json
import re
from types import SimpleNamespace

import numpy as np
import pyarrow as pa
import pytest

from planner import JointLimits, RecordingError, get_family
from planner.cli import main
from planner.recording import end_marker, read_recording, trajectory_definition, write_recording

RATE_HZ = 50.0
VIA = [[0.0, 0.0], [0.5, -1.0], [1.0, 0.5]]


def small_result(via=VIA, durations=(1.0, 1.0, 1.0, 1.0), limits=None, rate_hz=RATE_HZ, name="t"):
    """A plan result without a robot, as ``write_recording`` takes it: a 2-joint cubic through ``via``."""
    trajectory = get_family("cubic").build(via, list(durations))
    limits = limits or JointLimits.create(2, lower=[-3.0, -3.0], velocity=[5.0, 5.0], acceleration=[4.0, 4.0],
                                          jerk=[100.0, 100.0])
    return SimpleNamespace(trajectory=trajectory, joint_names=["a", "b"], limits=limits, robot=None, feasible=True,
                           task=SimpleNamespace(name=name, family="cubic", sample_rate_hz=rate_hz,
                                                optimizer={"algorithm": "test"}),
                           optimization=SimpleNamespace(algorithm="test", feasible=True))


def dense_ratios(trajectory, limits) -> np.ndarray:
    """(3, J) max |q^(d)| / limit of velocity, acceleration and jerk, sampled densely here (10 kHz, and at the
    knots, where a cubic's acceleration peaks)."""
    times = np.union1d(np.linspace(0.0, trajectory.total_time, 40_001), np.cumsum([0.0, *trajectory.durations]))
    inner = np.clip(times, 0.0, trajectory.total_time)
    peaks = np.array([np.abs(trajectory.evaluate(inner, d)).max(axis=0) for d in (1, 2, 3)])
    # the jerk of a piecewise cubic is constant per segment: each segment's value, taken inside it
    middles = np.cumsum([0.0, *trajectory.durations])[:-1] + np.asarray(trajectory.durations) / 2
    peaks[2] = np.maximum(peaks[2], np.abs(trajectory.evaluate(middles, 3)).max(axis=0))
    return peaks / np.array([limits.velocity, limits.acceleration, limits.jerk])


def rrd_series(path, entity) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and scalar values logged on the ``time`` timeline at ``entity``, read with Rerun's chunk API."""
    import rerun.chunk as rc
    times, values = [], []
    for chunk in rc.RrdReader(str(path)).stream().filter(content=entity).to_chunks():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        times += batch.column("time").cast(pa.int64()).to_pylist()
        values += [v[0] for v in batch.column("Scalars:scalars").to_pylist()]
    order = np.argsort(times, kind="stable")
    return np.asarray(times, dtype=float)[order] / 1e9, np.asarray(values, dtype=float)[order]


# ---------------------------------------------------------------------------- replay --check


def test_a_slow_plan_allows_only_the_deviation_its_time_rounding_explains(tmp_path):
    """Mutant ``8 * np.spacing(largest)`` -> ``8e6 * ...`` lived: a sample 1e-10 rad off a plan that moves
    1e-4 rad/s (a whole nanosecond of time explains 1e-13 rad) is off the trajectory."""
    result = small_result(via=[[1.0, -1.0], [1.0 + 5e-5, -1.0 - 5e-5], [1.0 + 1e-4, -1.0]])
    write_recording(result, tmp_path / "slow.rrd")
    assert read_recording(tmp_path / "slow.rrd").check().passed  # the planner's own samples lie on it
    times, values = result.trajectory.sample(RATE_HZ)
    positions = values[0].copy()
    positions[77, 1] += 1e-10
    path = tmp_path / "off.rrd"
    write_like_planner(path, result, times, positions)
    check = read_recording(path).check()
    assert check.deviation == pytest.approx(1e-10, rel=1e-3)
    assert check.tolerance < 1e-11 and not check.passed


def test_the_largest_ratio_is_the_largest_of_every_joint_and_order(tmp_path, capsys):
    """Mutant ratio ``.max()`` -> ``.mean()`` lived: ``largest_ratio`` (printed by replay --check) is
    the largest max|q^(d)| / limit, found here by dense sampling."""
    result = small_result()
    write_recording(result, tmp_path / "r.rrd")
    expected = float(dense_ratios(result.trajectory, result.limits).max())
    check = read_recording(tmp_path / "r.rrd").check()
    assert check.largest_ratio == pytest.approx(expected, rel=1e-6)
    assert main(["replay", str(tmp_path / "r.rrd"), "--check"]) == 0
    assert f"largest ratio {expected:.4f}," in capsys.readouterr().out


def write_like_planner(path, result, times, positions, *, definition=None, rate_hz=RATE_HZ, end=None):
    """A recording laid out as the planner's (definition, samples at ``times``, end marker at ``rate_hz``)
    written with Rerun directly; ``definition`` replaces the definition document, ``end`` the end marker."""
    import rerun as rr
    document = definition or trajectory_definition(result.trajectory, result.limits, result.joint_names)
    rec = rr.RecordingStream("planner")
    rec.save(str(path))
    rec.log("trajectory/definition", rr.AnyValues(planner_definition=json.dumps(document)), static=True)
    nanoseconds = np.round(np.asarray(times) * 1e9).astype(np.int64).astype("timedelta64[ns]")
    rec.send_columns("trajectory/samples", indexes=[rr.TimeColumn("time", duration=nanoseconds)],
                     columns=rr.Scalars.columns(scalars=positions))
    rec.flush()
    rec.log("trajectory/end", rr.AnyValues(planner_end=json.dumps(end or end_marker(times, rate_hz))), static=True)
    rec.flush()
    rec.disconnect()
    return path


def test_an_end_marker_rate_a_little_off_the_samples_rate_is_refused(tmp_path):
    """Mutant schedule tolerance ``_TIME_QUANTUM_NS`` -> ``1e3 * ...`` lived. The planner's 201 samples at
    50 Hz under an end marker saying 49.99999 Hz: the count, the ends and every gap (< the marker's period) agree,
    but that rate samples 3.98 s at 3.9800008 s (0.8 us off; a CSV export would follow the marker's rate): the
    recording is not as the planner wrote it."""
    result = small_result()
    times, values = result.trajectory.sample(RATE_HZ)
    rate = 49.99999
    schedule = result.trajectory.sample_times(rate)
    assert len(schedule) == len(times) and 500e-9 < np.abs(schedule - times).max() < 1e-6  # what makes the case
    path = write_like_planner(tmp_path / "r.rrd", result, times, values[0], rate_hz=rate)
    with pytest.raises(RecordingError, match=r"recording is not as the planner wrote it: sample 199 at 3\.98 s, where "
                                             r"49\.99999 Hz \(the end marker's rate\) samples at 3\.98000"):
        read_recording(path)


def test_a_definition_without_a_basis_is_read_as_power_series(tmp_path):
    """Mutant default basis ``"power"`` -> ``"trigonometric"`` lived: recordings from before the
    trigonometric family hold no ``basis``; their coefficients are power series, and their samples lie on them."""
    result = small_result()
    document = trajectory_definition(result.trajectory, result.limits, result.joint_names)
    assert document.pop("basis") == "power"
    times, values = result.trajectory.sample(RATE_HZ)
    recorded = read_recording(write_like_planner(tmp_path / "old.rrd", result, times, values[0], definition=document))
    assert recorded.trajectory.basis == "power"
    np.testing.assert_allclose(recorded.trajectory.evaluate(times), values[0], atol=1e-12)
    assert recorded.check().passed


# ---------------------------------------------------------------------------- what the writer logs


def test_a_recording_at_a_rate_of_its_own_says_that_rate(tmp_path):
    """Mutant end marker ``end_marker(times, rate_hz)`` -> ``(times, result.task.sample_rate_hz)``
    lived: ``write_recording(..., rate_hz=10)`` of a 50 Hz task samples at 10 Hz, and its end marker says so (the
    recording reads back, at 10 Hz)."""
    result = small_result(rate_hz=50.0)
    write_recording(result, tmp_path / "r.rrd", rate_hz=10.0)
    recorded = read_recording(tmp_path / "r.rrd")
    expected = np.arange(41) / 10.0
    assert recorded.rate_hz == 10.0
    np.testing.assert_allclose(recorded.times, expected, atol=1e-9)
    np.testing.assert_allclose(recorded.positions, result.trajectory.evaluate(expected), atol=1e-12)


def test_profiles_are_decimated_as_soon_as_the_samples_outnumber_profile_samples(tmp_path, monkeypatch):
    """Mutant ``len(times) > PROFILE_SAMPLES`` -> ``> 2 * PROFILE_SAMPLES`` lived: with 201 samples
    and PROFILE_SAMPLES = 101, each plotted series holds about 101 evenly spaced times (not all 201), at the
    trajectory's values there; trajectory/samples keeps all 201."""
    import rerun as rr

    import planner.recording as recording
    monkeypatch.setattr(recording, "PROFILE_SAMPLES", 101)
    result = small_result()
    write_recording(result, tmp_path / "r.rrd")
    times, values = rrd_series(tmp_path / "r.rrd", rr.new_entity_path(["profiles", "acceleration", "b"]))
    assert len(times) <= 102 and times[0] == 0.0 and times[-1] == pytest.approx(4.0, abs=1e-9)
    np.testing.assert_allclose(np.diff(times), 4.0 / 101, atol=1e-8)
    np.testing.assert_allclose(values, np.rad2deg(result.trajectory.evaluate(times, 2)[:, 1]), atol=1e-9)
    assert len(read_recording(tmp_path / "r.rrd").times) == 201


def summary_table(path) -> dict[str, list[str]]:
    """The summary panel's table rows (first cell -> the other cells), read with Rerun's chunk API."""
    import rerun.chunk as rc
    chunk = next(c for c in rc.RrdReader(str(path)).stream().filter(content="/summary").to_chunks() if c.is_static)
    text = chunk.to_record_batch().column("TextDocument:text").to_pylist()[0]
    text = text[0] if isinstance(text, list) else text
    rows = [line.strip("|").split("|") for line in text.splitlines() if line.startswith("| ")]
    return {cells[0].strip(): [c.strip() for c in cells[1:]] for cells in rows}


def test_the_summary_names_the_largest_ratio_of_each_quantity_and_its_joint(tmp_path):
    """Mutant ``np.argmax(ratios[d])`` -> ``np.argmin`` lived: the panel's table holds, per quantity,
    the largest max|q^(d)| / limit over the joints and the joint that reaches it (found by dense sampling)."""
    result = small_result(limits=JointLimits.create(2, velocity=[5.0, 1.0], acceleration=[4.0, 40.0],
                                                    jerk=[100.0, 5.0]))
    write_recording(result, tmp_path / "r.rrd")
    table = summary_table(tmp_path / "r.rrd")
    ratios = dense_ratios(result.trajectory, result.limits)
    assert table["largest ratio"] == ["velocity", "acceleration", "jerk"]
    assert [float(v) for v in table["max / limit"]] == pytest.approx(ratios.max(axis=1), abs=1.5e-3)
    assert table["joint"] == [result.joint_names[j] for j in ratios.argmax(axis=1)]
    assert len(set(ratios.argmax(axis=1))) == 2  # both joints named: a joint picked some other way would show


def blueprint_views(path) -> dict[str, dict]:
    """The views of the recording's blueprint by origin: their components (range, legend visibility, name)."""
    import rerun.chunk as rc
    reader = rc.RrdReader(str(path))
    (blueprint,) = reader.blueprints()
    parts: dict[str, dict] = {}
    for chunk in reader.stream(store=blueprint).to_chunks():
        match = re.match(r"/view/([0-9a-f-]+)", chunk.entity_path)
        if match:
            batch = chunk.to_record_batch()
            parts.setdefault(match.group(1), {}).update(
                {n.split(":")[-1]: batch.column(n).to_pylist()[-1][0] for n in batch.schema.names if ":" in n})
    return {view["space_origin"]: view for view in parts.values() if "space_origin" in view}


def test_each_plot_range_holds_its_curves_and_limits_and_the_legend_is_on_the_position_plot(tmp_path):
    """Mutants ``range=_position_range(...) if k == 0`` -> ``k == 1`` and the position margin
    ``0.12 * span`` -> ``0.5 * span`` lived. Read from the blueprint itself: each derivative plot's y range
    holds every value logged in it and its limit lines; the position plot's holds the motion with a margin, the
    motion filling most of it (the far limits, -172 deg, left out); the legend is on the position plot only."""
    result = small_result()
    path = tmp_path / "r.rrd"
    write_recording(result, path)
    views = blueprint_views(path)
    import rerun as rr
    for k, profile in enumerate(("position", "velocity", "acceleration", "jerk")):
        low, high = views[f"/profiles/{profile}"]["range"]
        values = np.concatenate([rrd_series(path, rr.new_entity_path(["profiles", profile, name]))[1]
                                 for name in result.joint_names])
        assert low < values.min() and values.max() < high, profile
        assert views[f"/profiles/{profile}"]["visible"] == (k == 0), profile
        if k:
            limit = np.rad2deg(result.limits.magnitudes[k - 1]).max()
            assert low <= -limit and limit <= high and high < 2.1 * max(limit, np.abs(values).max()), profile
        else:
            assert (values.max() - values.min()) / (high - low) > 0.7  # the motion fills the plot


def test_every_plot_starts_before_zero_by_the_width_of_the_position_plots_legend(tmp_path):
    """The position plot's legend (top left) covered its first seconds of motion. Every plot's time axis now
    runs from before 0 s to the trajectory's end, the lead being the legend's share of a 700 px plot: 40 px
    and 7 px per character of the longest joint name (so longer names lead by more), the same on every plot."""
    leads = []
    for names in (["a", "b"], ["shoulder_lift_joint", "b"]):
        result = small_result()
        result.joint_names = names
        path = tmp_path / f"{len(names[0])}.rrd"
        write_recording(result, path)
        views = blueprint_views(path)
        ranges = [view["view_range"] for origin, view in views.items() if origin.startswith("/profiles")]
        assert len(ranges) == 4 and all(r == ranges[0] for r in ranges)
        total_ns = result.trajectory.total_time * 1e9
        assert ranges[0]["end"] == pytest.approx(total_ns, abs=1)
        share = (40 + 7 * max(map(len, names))) / 700
        assert -ranges[0]["start"] / (total_ns - ranges[0]["start"]) == pytest.approx(share, rel=1e-6)
        leads.append(-ranges[0]["start"])
    assert leads[1] > 2 * leads[0] > 0


def test_the_robot_joints_turn_as_the_trajectory_at_every_sample(tmp_path):
    """Mutant ``positions[:, planned[joint.name]]`` -> ``positions[::-1, ...]`` lived: the robot was
    counted (one transform per sample) but never compared. Each revolute joint's logged rotation (a quaternion
    about its axis, z for the shoulder, y for the elbow) is the trajectory's angle at the sample's time."""
    import rerun as rr
    import rerun.chunk as rc

    from planner import make_task
    from planner.pipeline import plan
    urdf = tmp_path / "two.urdf"
    urdf.write_text("""<robot name="two"><link name="base"/>
  <link name="arm"><visual><geometry><box size="0.1 0.1 0.5"/></geometry></visual></link>
  <link name="fore"><visual><geometry><box size="0.1 0.1 0.3"/></geometry></visual></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="arm"/><child link="fore"/><origin xyz="0 0 0.5"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" velocity="1" effort="1"/></joint></robot>""")
    result = plan(make_task(robot={"urdf": urdf, "tool_frame": "fore"}, joints_deg=[[0, 0], [10, 40], [-20, 10]],
                            limits={"acceleration_deg_s2": [30, 30], "jerk_deg_s3": [100, 100]}))
    write_recording(result, tmp_path / "r.rrd")
    for name, axis in (("shoulder", 2), ("elbow", 1)):
        times, quaternions = [], []
        entity = rr.new_entity_path(["robot", "joint_transforms", name])
        for chunk in rc.RrdReader(str(tmp_path / "r.rrd")).stream().filter(content=entity).to_chunks():
            if not chunk.is_static:
                batch = chunk.to_record_batch()
                times += batch.column("time").cast(pa.int64()).to_pylist()
                quaternions += [q[0] for q in batch.column("Transform3D:quaternion").to_pylist()]
        order = np.argsort(times, kind="stable")
        times, quaternions = np.asarray(times)[order] / 1e9, np.asarray(quaternions)[order]
        np.testing.assert_allclose(times, result.trajectory.sample_times(result.task.sample_rate_hz), atol=1e-9)
        angles = 2 * np.arctan2(quaternions[:, axis], quaternions[:, 3])
        expected = result.trajectory.evaluate(times)[:, result.joint_names.index(name)]
        assert np.ptp(expected) > 0.1  # the joint moves: a reversed or shifted motion would show
        np.testing.assert_allclose(angles, expected, atol=1e-6)


@pytest.mark.parametrize("span", [[1e-6, 4.0], [0.0, 4.0 - 1e-6]])
def test_an_end_marker_whose_span_is_a_microsecond_off_the_trajectory_is_named_as_such(tmp_path, span):
    """Mutants of the span check's tolerances, ``abs(span[0]) > 1e-9`` -> ``> 1e-3`` and ``1e-9 * max(1.0, T)`` ->
    ``1e-3 * ...``, lived: the recording was still refused, but as one whose (complete, planner-made)
    samples start or end at the wrong time. The end marker is what is wrong, and the message says so."""
    result = small_result()
    times, values = result.trajectory.sample(RATE_HZ)
    path = write_like_planner(tmp_path / "r.rrd", result, times, values[0],  # its end marker's span a microsecond
                              end={**end_marker(times, RATE_HZ), "time_span_s": span})  # off the trajectory's
    with pytest.raises(RecordingError) as raised:
        read_recording(path)
    assert str(raised.value) == f"{path}: trajectory/end: time_span_s {span!r} is not the trajectory's [0, 4.0] s"
