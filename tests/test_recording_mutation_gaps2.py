"""Gaps a mutmut run over ``planner/recording.py`` found after ``test_recording_mutation_gaps.py``: each test
kills mutants the recording tests let live, comparing with an independent computation (the .rrd read back with
Rerun's own chunk API, the trajectory evaluated here)."""

from types import SimpleNamespace

import numpy as np
import pytest

from planner import JointLimits, get_family
from planner.recording import read_recording, write_recording
from planner.splines import PiecewisePolynomial

RATE_HZ = 50.0
VIA = [[0.0, 0.0], [0.5, -1.0], [1.0, 0.5]]


def small_result(trajectory=None, limits=None, rate_hz=RATE_HZ, name="t", **extra):
    """A plan result without a robot, as ``write_recording`` takes it: a 2-joint cubic through ``VIA`` (T = 4 s)
    unless ``trajectory`` is given; ``extra`` sets more attributes (``via_points``)."""
    trajectory = trajectory or get_family("cubic").build(VIA, [1.0, 1.0, 1.0, 1.0])
    limits = limits or JointLimits.create(2, lower=[-3.0, -3.0], velocity=[5.0, 5.0], acceleration=[4.0, 4.0],
                                          jerk=[100.0, 100.0])
    return SimpleNamespace(trajectory=trajectory, joint_names=["a", "b"], limits=limits, robot=None, feasible=True,
                           task=SimpleNamespace(name=name, family="cubic", sample_rate_hz=rate_hz,
                                                optimizer={"algorithm": "test"}),
                           optimization=SimpleNamespace(algorithm="test", feasible=True), **extra)


def test_the_recording_properties_say_what_was_planned(tmp_path):
    """Mutants of the ``plan`` recording properties lived (their name ``"plan"`` -> ``"PLAN"``, any field left
    out or None): the viewer's recording panel shows the task, family, optimizer, total time, feasibility and
    joints, read back here from ``/__properties/plan``."""
    import rerun.chunk as rc
    for feasible in (True, False):  # the plan's own verdict, not a constant
        result = small_result(name="pick")
        result.feasible = feasible
        path = tmp_path / f"{feasible}.rrd"
        write_recording(result, path)
        chunks = [c for c in rc.RrdReader(str(path)).stream().filter(content="/__properties/**").to_chunks()
                  if c.entity_path == "/__properties/plan"]
        assert len(chunks) == 1 and chunks[0].is_static
        batch = chunks[0].to_record_batch()
        fields = {n: batch.column(n).to_pylist()[0] for n in batch.schema.names if not n.startswith("rerun.")}
        assert fields == {"task": ["pick"], "family": ["cubic"], "optimizer": ["test"],
                          "total_time_s": [result.trajectory.total_time], "feasible": [feasible], "joints": ["a, b"]}


def test_a_jump_is_found_in_a_recording_that_holds_its_via_points(tmp_path):
    """Mutant ``breaks += via_point_misses(...)`` -> ``breaks = ...`` lived: the planner's recordings hold their
    via-points, and the via-point check replaced the continuity check. A 30 deg jump at knot 1 of a trajectory
    that passes every via-point it holds (taken from the jumping trajectory itself) fails ``check``."""
    smooth = get_family("cubic").build(VIA, [1.0, 1.0, 1.0, 1.0])
    coefficients = np.array(smooth.coefficients)
    coefficients[1, 0, 0] += np.deg2rad(30)
    jumping = PiecewisePolynomial(smooth.durations, coefficients, smooth.via_knots)
    result = small_result(jumping, via_points=jumping.evaluate(jumping.via_times))
    write_recording(result, tmp_path / "r.rrd")
    check = read_recording(tmp_path / "r.rrd").check()
    assert check.deviation <= check.tolerance and not check.violations
    assert not check.passed and [(b.joint, b.quantity) for b in check.breaks][:1] == [("a", "position")]
    assert check.breaks[0].value == pytest.approx(np.deg2rad(30))


def test_a_slow_plan_sampled_off_whole_nanoseconds_passes_its_check(tmp_path):
    """Mutant check tolerance ``figures.max_abs[0]`` (velocity) -> ``max_abs[1]`` (acceleration) lived. At 3 Hz
    the sample times are not whole nanoseconds: Rerun keeps each up to 0.5 ns off, so a sample may sit
    velocity x 0.5 ns off the trajectory. A long plan moving ~1 rad/s with little acceleration: its own recording
    passes ``check``, its deviation above what the acceleration would allow and within the velocity's."""
    trajectory = get_family("cubic").build([[0.0, 0.0], [100.0, -100.0], [200.0, 0.0]], [100.0] * 4)
    limits = JointLimits.create(2, lower=[-300.0, -300.0], upper=[300.0, 300.0], velocity=[5.0, 5.0],
                                acceleration=[4.0, 4.0], jerk=[100.0, 100.0])
    write_recording(small_result(trajectory, limits, rate_hz=3.0), tmp_path / "r.rrd")
    recorded = read_recording(tmp_path / "r.rrd")
    velocity, acceleration = (np.abs(trajectory.evaluate(recorded.times, d)).max() for d in (1, 2))
    check = recorded.check()
    assert velocity > 20 * acceleration and check.deviation > 2e-9 * acceleration
    assert check.deviation <= 0.5e-9 * velocity + 1e-12 and check.passed


def static_style(path, entity) -> dict[str, list]:
    """The static components (names, colors, ...) logged at ``entity``, read with Rerun's chunk API."""
    import rerun.chunk as rc
    style: dict[str, list] = {}
    for chunk in rc.RrdReader(str(path)).stream().filter(content=entity).to_chunks():
        if chunk.is_static:
            batch = chunk.to_record_batch()
            style.update({n.split(":")[-1]: batch.column(n).to_pylist()[0] for n in batch.schema.names if ":" in n})
    return style


def test_each_limit_line_sits_at_its_own_limit_in_every_plot_and_the_torques_are_in_joint_colours(tmp_path):
    """Mutants lived that drew the derivative plots' lower limit lines at +limit (``(-m, m)`` -> ``(+m, m)``,
    or the upper bound passed as both), the torque plot's lower limit line at +1 (``(-1.0, 1.0)`` ->
    ``(+1.0, 1.0)``) and the torque curves without their joint's colour (``joint_colour(j)`` -> None). Every limit
    line (position: the joint's own bounds; derivatives: -+ its limit [deg]; torque over its limit: -+1) is read
    back at its value, and every torque series and its limit lines carry the joint's name and colour."""
    import rerun as rr

    from planner.recording import JOINT_COLOURS
    result = small_result(limits=JointLimits.create(2, lower=[-3.0, -2.0], upper=[2.5, 3.0], velocity=[5.0, 6.0],
                                                    acceleration=[4.0, 7.0], jerk=[100.0, 90.0]))
    result.torque_limit = np.array([2.0, 4.0])
    result.torques_at = lambda times: np.stack([np.sin(times), 3.0 * np.cos(times)], axis=1)  # [N m]
    path = tmp_path / "r.rrd"
    write_recording(result, path)
    limits = result.limits
    expected = {"position": (limits.lower, limits.upper), "torque": (-np.ones(2), np.ones(2))}
    for profile, magnitude in zip(("velocity", "acceleration", "jerk"), limits.magnitudes):
        expected[profile] = (-magnitude, magnitude)
    for profile, (lower, upper) in expected.items():
        scale = 1.0 if profile == "torque" else np.rad2deg(1.0)
        for j, name in enumerate(result.joint_names):
            for side, bound in (("lower", lower[j]), ("upper", upper[j])):
                entity = rr.new_entity_path(["profiles", profile, "limits", name, side])
                values = rrd_values(path, entity)
                finite = values[np.isfinite(values)]
                assert finite.size > 50 and np.allclose(finite, scale * bound, rtol=1e-12), (entity, finite[:3])
    for j, name in enumerate(result.joint_names):
        rgba = int(JOINT_COLOURS[j][1:] + "ff", 16)
        for entity in (rr.new_entity_path(["profiles", "torque", name]),
                       *(rr.new_entity_path(["profiles", "torque", "limits", name, s]) for s in ("lower", "upper"))):
            style = static_style(path, entity)
            assert style["names"] == [name] and style["colors"] == [rgba], entity
    torque = rrd_values(path, rr.new_entity_path(["profiles", "torque", "b"]))
    times = result.trajectory.sample_times(RATE_HZ)
    np.testing.assert_allclose(torque, 3.0 * np.cos(times) / 4.0, atol=1e-12)  # each joint over its own limit


def rrd_values(path, entity) -> np.ndarray:
    """The scalar values logged at ``entity`` on the ``time`` timeline, in time order."""
    import pyarrow as pa
    import rerun.chunk as rc
    times, values = [], []
    for chunk in rc.RrdReader(str(path)).stream().filter(content=entity).to_chunks():
        if not chunk.is_static:
            batch = chunk.to_record_batch()
            times += batch.column("time").cast(pa.int64()).to_pylist()
            values += [v[0] for v in batch.column("Scalars:scalars").to_pylist()]
    return np.asarray(values, dtype=float)[np.argsort(times, kind="stable")]
