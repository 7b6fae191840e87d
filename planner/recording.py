"""Rerun recordings of a plan (``trajectory.rrd``), and reading them back.

What a recording holds (timeline ``time``, in seconds):

* ``robot/...``: the robot from its URDF through Rerun's own URDF support
  (``rerun.urdf.UrdfTree``), its joints animated by per-joint transforms;
  joints the planner locked are logged once at their neutral value.
* ``scene/tool_path`` (the tool frame's path, a 3D line),
  ``scene/waypoints`` (the task's waypoints as RGB axes, labelled with their index
  and, for Cartesian tasks, the IK solution chosen of those found), and for Cartesian
  tasks ``scene/straight_segments`` (the straight lines between waypoints) and
  ``scene/inserted_poses`` (poses ``linear`` mode inserted), in the robot's root frame.
* ``profiles/{position,velocity,acceleration,jerk}/<joint>``: time series in
  degrees, with ``.../limits/<joint>/{upper,lower}`` and, for positions,
  via-point markers ``profiles/position/via_points/<joint>``.
* ``trajectory/samples``: joint positions [rad] at every sample (float64),
  and static ``trajectory/definition``: the piecewise polynomial (durations,
  coefficients, via knots) and the limits in SI units, so ``planner replay
  --check`` can re-run the exact checks without the task.
* recording properties ``plan``: task, family, optimizer, total time.

The default blueprint shows the 3D view beside the four profile plots.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import RecordingError
from .limits import QUANTITIES, JointLimits
from .splines import PiecewisePolynomial

APPLICATION_ID = "planner"
FORMAT = "planner-recording/v1"
_PROFILES = ("position", *QUANTITIES)


def write_recording(result, path: Path, *, rate_hz: float | None = None) -> None:
    """Write ``result`` (a ``PlanResult``) as a Rerun recording at ``path`` (flushed and closed)."""
    import rerun as rr
    import rerun.blueprint as rrb

    trajectory: PiecewisePolynomial = result.trajectory
    names = result.joint_names
    times, values = trajectory.sample(rate_hz or result.task.sample_rate_hz)
    time_index = [rr.TimeColumn("time", duration=times)]
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=f"{result.task.name}-{id(result)}")
    rec.save(str(path))
    rec.send_recording_name(result.task.name)
    rec.send_property("plan", rr.AnyValues(
        task=result.task.name, family=result.task.family, optimizer=result.optimization.algorithm,
        total_time_s=trajectory.total_time, feasible=bool(result.optimization.feasible),
        joints=", ".join(names)))
    definition = {
        "format": FORMAT, "joint_names": names, "durations_s": trajectory.durations.tolist(),
        "coefficients_shape": list(trajectory.coefficients.shape),
        "coefficients": trajectory.coefficients.ravel().tolist(), "via_knots": trajectory.via_knots.tolist(),
        "limits": {name: [float(v) for v in getattr(result.limits, name)]
                   for name in ("lower", "upper", *QUANTITIES)},
    }
    rec.log("trajectory/definition", rr.AnyValues(planner_definition=json.dumps(definition)), static=True)
    rec.send_columns("trajectory/samples", indexes=time_index, columns=rr.Scalars.columns(scalars=values[0]))

    bounds = [(result.limits.lower, result.limits.upper)] + [(-m, m) for m in result.limits.magnitudes]
    ends = [rr.TimeColumn("time", duration=[0.0, trajectory.total_time])]
    for k, profile in enumerate(_PROFILES):
        for j, name in enumerate(names):
            rec.send_columns(f"profiles/{profile}/{name}", indexes=time_index,
                             columns=rr.Scalars.columns(scalars=np.rad2deg(values[k, :, j])))
            for side, bound in zip(("lower", "upper"), (bounds[k][0][j], bounds[k][1][j])):
                if np.isfinite(bound):
                    entity = f"profiles/{profile}/limits/{name}/{side}"
                    rec.log(entity, rr.SeriesLines(names=f"{name} {side} limit", widths=1.0), static=True)
                    rec.send_columns(entity, indexes=ends, columns=rr.Scalars.columns(scalars=[np.rad2deg(bound)] * 2))
    via_index = [rr.TimeColumn("time", duration=trajectory.via_times)]
    via_positions = trajectory.evaluate(trajectory.via_times)
    for j, name in enumerate(names):
        entity = f"profiles/position/via_points/{name}"
        rec.log(entity, rr.SeriesPoints(names=f"{name} via-points", marker_sizes=4.0), static=True)
        rec.send_columns(entity, indexes=via_index, columns=rr.Scalars.columns(scalars=np.rad2deg(via_positions[:, j])))

    views = []
    if result.robot is not None:
        _log_robot(rec, result, times, values[0])
        views.append(rrb.Spatial3DView(origin="/", contents=["/robot/**", "/scene/**"], name="robot"))
    plots = [rrb.TimeSeriesView(origin=f"/profiles/{p}", name=p) for p in _PROFILES]
    rec.send_blueprint(rrb.Blueprint(rrb.Horizontal(*views, rrb.Vertical(*plots)) if views else rrb.Vertical(*plots),
                                     collapse_panels=True))
    rec.flush()
    rec.disconnect()


def _log_robot(rec, result, times: np.ndarray, positions: np.ndarray) -> None:
    import rerun as rr
    import rerun.urdf as rru

    robot = result.robot
    try:
        tree = rru.UrdfTree.from_file_path(robot.urdf_path, entity_path_prefix="robot")
    except Exception as exc:  # rerun raises plain exceptions for unreadable URDFs
        raise RecordingError(f"Rerun cannot read the URDF {robot.urdf_path}: {exc}") from None
    tree.log_urdf_to_recording(rec)
    planned = {name: j for j, name in enumerate(robot.joint_names)}
    time_index = [rr.TimeColumn("time", duration=times)]
    for joint in tree.joints():
        if joint.joint_type == "fixed":
            continue
        entity = f"robot/joint_transforms/{joint.name}"
        if joint.name in planned:
            rec.send_columns(entity, indexes=time_index,
                             columns=joint.compute_transform_columns(positions[:, planned[joint.name]], clamp=False))
        else:
            rec.log(entity, joint.compute_transform(0.0, clamp=True), static=True)
    root = tree.root_link().name
    tool = np.array([robot.forward_kinematics(q).translation for q in positions])
    rec.log("scene/tool_path", rr.LineStrips3D([tool], colors=[[255, 170, 0]], radii=0.003),
            rr.CoordinateFrame(root), static=True)
    waypoints = result.waypoint_via
    poses = [robot.forward_kinematics(q) for q in result.via_points[waypoints]]
    origins = np.repeat([p.translation for p in poses], 3, axis=0)
    vectors = np.concatenate([0.06 * p.rotation.T for p in poses])
    labels = [f"waypoint {i}" + (f" (IK solution {s.chosen + 1} of {s.solutions})" if result.ik else "")
              for i, s in enumerate(result.ik or [None] * len(poses))]
    rec.log("scene/waypoints", rr.Arrows3D(origins=origins, vectors=vectors,
                                           colors=[[230, 40, 40], [40, 200, 40], [40, 90, 230]] * len(poses),
                                           labels=[text for label in labels for text in (label, "", "")]),
            rr.CoordinateFrame(root), static=True)
    if result.path is not None:
        rec.log("scene/straight_segments", rr.LineStrips3D([[p.translation for p in poses]], colors=[[150, 150, 150]],
                                                           radii=0.0015), rr.CoordinateFrame(root), static=True)
        inserted = np.setdiff1d(np.arange(len(result.via_points)), waypoints)
        if inserted.size:
            points = [robot.forward_kinematics(q).translation for q in result.via_points[inserted]]
            rec.log("scene/inserted_poses", rr.Points3D(points, colors=[[120, 120, 255]], radii=0.004),
                    rr.CoordinateFrame(root), static=True)


# ---------------------------------------------------------------------------- reading back


@dataclass(frozen=True)
class RecordedPlan:
    """What ``read_recording`` recovers: the sampled joint positions and the exact trajectory."""

    times: np.ndarray
    positions: np.ndarray
    trajectory: PiecewisePolynomial
    limits: JointLimits
    joint_names: list[str]


def read_recording(path) -> RecordedPlan:
    """Read a planner recording back, without a viewer.

    Raises:
        RecordingError: a missing file, one Rerun cannot read, or a recording not written by the planner.
    """
    import rerun.chunk as rc

    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"{path}: no such recording")
    try:
        with warnings.catch_warnings():  # rerun warns about files without a footer; the errors below say it
            warnings.simplefilter("ignore")
            chunks = rc.RrdReader(str(path)).stream().to_chunks()
    except Exception as exc:  # rerun raises plain exceptions for corrupt files
        raise RecordingError(f"{path}: not a readable Rerun recording ({str(exc).splitlines()[0]})") from None
    samples, definition = [], None
    for chunk in chunks:
        if chunk.entity_path == "/trajectory/samples":
            batch = chunk.to_record_batch()
            times = np.asarray(batch.column("time").cast("int64").to_numpy(zero_copy_only=False)) / 1e9
            values = np.array(batch.column("Scalars:scalars").to_pylist(), dtype=float)
            samples.append((times, values))
        elif chunk.entity_path == "/trajectory/definition":
            batch = chunk.to_record_batch()
            column = [n for n in batch.schema.names if n.endswith("planner_definition")]
            if column:
                definition = json.loads(batch.column(column[0])[0].as_py()[0])
    if definition is None or not samples or definition.get("format") != FORMAT:
        raise RecordingError(f"{path}: not a planner recording (no trajectory definition of format {FORMAT})")
    times = np.concatenate([t for t, _ in samples])
    positions = np.concatenate([v for _, v in samples])
    order = np.argsort(times, kind="stable")
    coefficients = np.array(definition["coefficients"]).reshape(definition["coefficients_shape"])
    trajectory = PiecewisePolynomial(np.array(definition["durations_s"]), coefficients, definition["via_knots"])
    limits = JointLimits(*(np.array(definition["limits"][k], dtype=float) for k in ("lower", "upper", *QUANTITIES)))
    return RecordedPlan(times[order], positions[order], trajectory, limits, list(definition["joint_names"]))
