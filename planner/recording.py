"""Rerun recordings of a plan (``trajectory.rrd``), reading them back, and opening them in the viewer.

What a recording holds (timeline ``time``, in seconds):

* ``robot/...``: the robot from its URDF through Rerun's own URDF support
  (``rerun.urdf.UrdfTree``), its joints animated by per-joint transforms;
  joints the planner locked are logged once at their neutral value.
* ``scene/tool_path`` (the tool frame's path, a 3D line), ``scene/tool`` (the tool's position
  at every sample, on the ``time`` timeline: it moves with the time cursor), ``scene/waypoints``
  (the task's waypoints as RGB axes) and ``scene/waypoint_labels`` (one labelled point per place:
  coincident waypoints share one label, "waypoints 0, 2", with the IK solution chosen of those found
  for Cartesian tasks), and for Cartesian tasks ``scene/straight_segments`` (the straight lines
  between waypoints) and ``scene/inserted_poses`` (poses ``linear`` mode inserted: small blue points,
  unlabelled), in the robot's root frame.
* ``profiles/{position,velocity,acceleration,jerk}/<joint>``: time series in degrees (at the sample
  rate, or at ``PROFILE_SAMPLES`` + 1 evenly spaced times in all when that is fewer), each joint
  in one colour (``JOINT_COLOURS``, matplotlib's default cycle as in ``profiles.png``) and named as
  the joint in every plot; ``.../limits/<joint>/{upper,lower}``: its limits as thin dashed lines
  (NaN gaps) of the same colour and name, so that the legend lists each joint once and no limit;
  for positions, via-point markers ``profiles/position/via_points/<joint>`` (same colour and name).
  With torque limits, ``profiles/torque/<joint>``: each joint's torque over its limit (dimensionless,
  the limits at +-1), so that the joint that binds shows whatever its limit in N m.
* ``summary``: a markdown text (task, robot, family, optimizer, total time, largest ratio per
  quantity and its joint, the torque's and the tool speeds' where the task limits them, feasibility).
* ``trajectory/samples``: joint positions [rad] at every sample (float64),
  and static ``trajectory/definition``: the piecewise polynomial (durations,
  coefficients, via knots) and the limits in SI units, so ``planner replay
  --check`` can re-run the exact checks without the task.
* static ``trajectory/end``, written last of all (after a flush): the sample
  count, sample rate and time span. A recording cut short lacks it, so
  ``read_recording`` can tell a complete recording from a truncated one.
* recording properties ``plan``: task, family, optimizer, total time.

Names (task, joints) are labels: each is one escaped entity-path part, whatever
characters it holds, and is read back from the definition, never from a path.

The default blueprint shows the 3D view above the summary, beside the four profile plots (units in
their names, the legend on the position plot only); the 3D view's eye frames the whole robot over
the motion, the tool path and the waypoints (``framing_eye``).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TypeGuard

import numpy as np

from .concurrency import WorkerLost, call_in_child
from .errors import InputError, RecordingError, ViewerError, shown
from .kinematics import Break, Violation, continuity_breaks, kinematic_figures, via_point_misses
from .limits import DEGREE_UNITS, PROFILE_QUANTITIES, QUANTITIES, JointLimits, seconds_text
from .outputs import not_utf8, utf8_path
from .read_only import ReadOnlyArrays, freeze_arrays
from .splines import BASES, MAX_SAMPLES, PiecewisePolynomial
from .validate import CONTROL_CHARACTERS

APPLICATION_ID = "planner"
FORMAT = "planner-recording/v2"
_PROFILES = tuple(q.name for q in PROFILE_QUANTITIES)
_LIMIT_FIELDS = ("lower", "upper", *QUANTITIES)
_SAMPLES = "/trajectory/samples"
#: Intervals between the times at which the profile plots are logged (per series: at most this many + 1
#: times, both ends included): zoomed to a tenth of a 20-minute plan, still about one value per pixel;
#: ``trajectory/samples`` keeps every sample.
PROFILE_SAMPLES = 50_000
_DEFINITION = "/trajectory/definition"
_END = "/trajectory/end"
_SUMMARY = "/summary"
_SCALARS = "Scalars:scalars"
#: Rerun keeps times in whole nanoseconds (``_time_index`` rounds them to the nearest): a recorded time
#: is within half of this of the planner's [ns].
_TIME_QUANTUM_NS = 1.0


def _time_index(times) -> list:
    """Rerun's time index of times [s], each rounded to the nearest whole nanosecond (Rerun's own
    conversion of seconds truncates: 2155.47 s became 2155.469999999 s)."""
    import rerun as rr
    nanoseconds = np.round(np.asarray(times, dtype=float) * 1e9).astype(np.int64)
    return [rr.TimeColumn("time", duration=nanoseconds.astype("timedelta64[ns]"))]


def _entity(*parts: str) -> str:
    """An entity path from unescaped parts: a name with spaces, slashes, ``$`` or emoji stays one part."""
    import rerun as rr
    return rr.new_entity_path(list(parts))


def trajectory_definition(trajectory: PiecewisePolynomial, limits: JointLimits, joint_names: list[str],
                          via_points: np.ndarray | None = None) -> dict:
    """The ``trajectory/definition`` document: the exact piecewise polynomial, the limits [SI] and, where
    given, the via-points (n, J) [rad] it was planned through (``via_points_rad``, passed at the knots
    ``via_knots``), so that ``replay --check`` can confirm it passes them."""
    document = {
        "format": FORMAT, "joint_names": list(joint_names), "durations_s": trajectory.durations.tolist(),
        "coefficients_shape": list(trajectory.coefficients.shape),
        "coefficients": trajectory.coefficients.ravel().tolist(), "via_knots": trajectory.via_knots.tolist(),
        "basis": trajectory.basis,
        "limits": {name: [float(v) for v in getattr(limits, name)] for name in _LIMIT_FIELDS},
    }
    if via_points is not None:
        document["via_points_rad"] = np.asarray(via_points, dtype=float).tolist()
    return document


def end_marker(times: np.ndarray, rate_hz: float) -> dict:
    """The ``trajectory/end`` document for samples at ``times`` [s] taken at ``rate_hz`` [Hz]."""
    return {"sample_count": int(len(times)), "sample_rate_hz": float(rate_hz),
            "time_span_s": [float(times[0]), float(times[-1])]}


#: One colour per joint (matplotlib's default cycle, as in ``profiles.png``), the same in every plot.
JOINT_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                 "#bcbd22", "#17becf")
#: Dashes per limit line: the limits are drawn dashed (a line broken by gaps), thin, in the joint's colour.
LIMIT_DASHES = 60
#: Waypoints closer than this [m] share one label ("waypoints 0, 2").
COINCIDENT_M = 1e-3
_TOOL_PATH_COLOUR = (255, 170, 0)
_TOOL_COLOUR = (255, 235, 90)
_WAYPOINT_COLOUR = (235, 235, 235)
_INSERTED_COLOUR = (90, 160, 255)


def joint_colour(j: int) -> tuple[int, int, int]:
    """Joint ``j``'s colour as RGB."""
    code = JOINT_COLOURS[j % len(JOINT_COLOURS)]
    return int(code[1:3], 16), int(code[3:5], 16), int(code[5:7], 16)


def _dashed(value: float, total_time: float) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of a horizontal dashed line at ``value`` over [0, total_time]: NaN breaks the line."""
    period = total_time / LIMIT_DASHES
    starts = np.arange(LIMIT_DASHES) * period
    times = np.stack([starts, starts + 0.6 * period, starts + 0.8 * period], axis=1).ravel()
    values = np.tile([value, value, np.nan], LIMIT_DASHES)
    return np.append(times, total_time), np.append(values, value)


def _position_range(positions: np.ndarray, limits: JointLimits) -> tuple[float, float]:
    """The position plot's range [deg]: the motion with a margin, and the limits near it (far ones would
    squash the curves: a UR5's +-360 deg around a motion of +-90 deg)."""
    low, high = float(np.rad2deg(positions.min())), float(np.rad2deg(positions.max()))
    span = max(high - low, 10.0)
    low, high = low - 0.12 * span, high + 0.12 * span
    bounds = np.rad2deg(np.concatenate([limits.lower, limits.upper]))
    near = bounds[np.isfinite(bounds) & (bounds > low - 0.4 * span) & (bounds < high + 0.4 * span)]
    if near.size:
        low, high = min(low, near.min() - 0.05 * span), max(high, near.max() + 0.05 * span)
    return low, high


#: The width [px] the plots' time axes are laid out for (half of a 1920 px screen), and the position plot's
#: legend's width: a margin and colour dot, and each character of the longest joint name (Rerun's font).
PLOT_WIDTH_PX, LEGEND_BASE_PX, LEGEND_CHARACTER_PX = 700.0, 40.0, 7.0


def _time_axis(total_time: float, names: list[str]):
    """Every plot's time axis: from before 0 s, so that the position plot's legend (the joints' names and
    colours, at its top left) sits over no motion, to ``total_time`` [s]. The lead is the legend's width on a
    plot ``PLOT_WIDTH_PX`` wide, of the whole axis (at most half of it)."""
    import rerun.blueprint as rrb
    legend = (LEGEND_BASE_PX + LEGEND_CHARACTER_PX * max(map(len, names), default=0)) / PLOT_WIDTH_PX
    lead = total_time * min(legend, 0.5) / (1.0 - min(legend, 0.5))
    return rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.absolute(seconds=-lead),
                                                 end=rrb.TimeRangeBoundary.absolute(seconds=total_time)))


def _symmetric_range(values: np.ndarray, magnitudes: np.ndarray) -> tuple[float, float]:
    """A derivative's or a torque's plot range, in the units of ``values`` and ``magnitudes`` (its limits):
    +-(the largest value or limit, with a margin), widened to the next power of ten when just short
    of it, so that the plot's power-of-ten ticks label more than its zero line."""
    finite = magnitudes[np.isfinite(magnitudes)]
    top = 1.08 * max(float(np.abs(values).max()), float(finite.max()) if finite.size else 0.0)
    if top <= 0:
        return -1.0, 1.0
    decade = 10.0 ** math.floor(math.log10(top))
    if top > 5 * decade:
        top = max(top, 10.4 * decade)
    return -top, top


def _log_profile(rec, profile: str, name: str, colour, index: list, values: np.ndarray, bounds, total_time: float):
    """One joint's series in the plot ``profile`` (values in the plot's units), named and coloured as the
    joint, and each finite bound (lower, upper) as a thinner dashed line of the same name and colour: the
    legend holds one entry per joint (entries of one name are merged) and never lists the limits."""
    import rerun as rr

    entity = _entity("profiles", profile, name)
    rec.log(entity, rr.SeriesLines(names=name, colors=[colour], widths=1.5), static=True)
    rec.send_columns(entity, indexes=index, columns=rr.Scalars.columns(scalars=values))
    for side, bound in zip(("lower", "upper"), bounds):
        if np.isfinite(bound):
            entity = _entity("profiles", profile, "limits", name, side)
            rec.log(entity, rr.SeriesLines(names=name, colors=[colour], widths=0.75), static=True)
            dash_times, dash_values = _dashed(float(bound), total_time)
            rec.send_columns(entity, indexes=_time_index(dash_times),
                             columns=rr.Scalars.columns(scalars=dash_values))


def plan_summary(result) -> str:
    """The markdown text of the summary panel: task, robot, family, optimizer, total time, the largest
    constraint ratio of each quantity and its joint (the torque's, the tool's linear and angular speed's
    after the kinematic ones, where the task limits them: ``RobotLimitOutcome.summary``), feasibility."""
    figures = kinematic_figures(result.trajectory)
    ratios = np.nan_to_num(figures.ratios(result.limits))
    names = result.joint_names
    robot = getattr(result, "robot", None)
    feasible = bool(result.feasible)
    columns = [(quantity, ratios[d, j], _markdown_text(names[j]))
               for d, quantity in enumerate(QUANTITIES) for j in [int(np.argmax(ratios[d]))]]
    columns += _robot_limit_columns(getattr(result, "robot_limits", None), names)
    torque_note = " Torque: each joint's over its limit (+-1)." if any(c[0] == "torque" for c in columns) else ""
    optimizer = optimizer_name(result.task.optimizer["algorithm"], result.optimization.algorithm)
    return "\n".join([
        f"### {_markdown_text(result.task.name)}: {'feasible' if feasible else 'NOT feasible (a limit is exceeded)'}",
        "",
        f"**robot** {_markdown_text(robot.name) if robot is not None else 'none (joint space)'} · "
        f"**family** {_markdown_text(result.task.family)} · "
        f"**optimizer** {_markdown_text(optimizer)}"
        f" · **total time** {seconds_text(result.trajectory.total_time)} s",
        "",
        "| largest ratio | " + " | ".join(quantity for quantity, _, _ in columns) + " |",
        "|---|" + "---|" * len(columns),
        "| max / limit | " + " | ".join(f"{ratio:.3f}" for _, ratio, _ in columns) + " |",
        "| joint | " + " | ".join(joint for _, _, joint in columns) + " |",
        "",
        f"Plots in degrees; dashed lines: each joint's limits, in its colour.{torque_note}",
    ])


def _robot_limit_columns(outcome, names: list[str]) -> list[tuple[str, float, str]]:
    """The summary table's columns (quantity, largest ratio, joint) for the robot-aware limits a plan met
    (``outcome``: its ``RobotLimitOutcome``, or None): torque (the joint of the largest ratio), the tool's
    linear and angular speed (the tool, not a joint)."""
    if outcome is None:
        return []
    figures = outcome.summary()
    columns = []
    if "torque_ratio" in figures:
        joint = int(np.argmax(figures["torque_ratio"]))
        columns.append(("torque", float(figures["torque_ratio"][joint]), _markdown_text(names[joint])))
    for key, quantity in (("tool_speed_ratio", "tool speed"), ("tool_angular_speed_ratio", "tool angular speed")):
        if key in figures:
            columns.append((quantity, float(figures[key]), "(tool)"))
    return columns


def optimizer_name(requested: str, kept: str) -> str:
    """The algorithm the task asked for, and the one whose result was kept where they differ
    (``default`` runs several): ``default (cuckoo)``."""
    return kept if requested == kept else f"{requested} ({kept})"


def _markdown_text(text: str) -> str:
    """``text`` shown as itself in markdown (no emphasis, links or table breaks)."""
    return "".join("\\" + c if c in "\\`*_{}[]()#+-.!|<>~$" else c for c in str(text)).replace("\n", " ")


def _quiet_rerun_logs() -> None:
    """Keep Rerun's own log lines (its URDF importer's warnings, its decoder's errors) off stderr, where
    a planner run prints one line of its own, unless the user set ``RUST_LOG``. Rerun reads it when
    first imported, so this goes before the first import in the process (the writers' own, a replay's)."""
    os.environ.setdefault("RUST_LOG", "off")


#: The longest wait [s] for Rerun to encode a recording in memory (about 0.1 s for the bundled tasks).
FLUSH_TIMEOUT_S = 600.0


def prepare_recording() -> None:
    """Import Rerun as ``write_recording`` uses it, ahead of the recording (``pipeline.output_writers``)."""
    _quiet_rerun_logs()
    import rerun.blueprint  # noqa: F401 - imported for its cost, now
    import rerun.urdf  # noqa: F401


def write_recording(result, path: Path, *, rate_hz: float | None = None) -> None:
    """Write ``result`` (a ``PlanResult``) as a Rerun recording at ``path`` (flushed and closed)."""
    _quiet_rerun_logs()  # the planner names missing meshes itself (summary.json, progress)
    import rerun as rr

    rec = rr.RecordingStream(APPLICATION_ID, recording_id=f"{result.task.name}-{id(result)}")
    # Into memory, then one ordinary write: Rerun's own file sink left the plan hanging for good (deaf
    # to Ctrl-C and SIGTERM) in a flush after its writer thread died of a full disk.
    stream = rr.binary_stream(recording=rec)
    try:
        _log_plan(rec, result, rate_hz or result.task.sample_rate_hz)
        encoded = stream.read(flush=True, flush_timeout_sec=FLUSH_TIMEOUT_S)
    except BaseException:  # what was logged is read and dropped: left in the stream, Rerun warned on stderr
        stream.read(flush=True, flush_timeout_sec=FLUSH_TIMEOUT_S)  # when it dropped it, in a later output
        rec.disconnect()
        raise
    rec.disconnect()
    Path(path).write_bytes(encoded or b"")


def _log_plan(rec, result, rate_hz: float) -> None:
    """Log everything a recording of ``result`` holds (module docstring) into ``rec``, sampled at ``rate_hz``
    [Hz], the end marker last."""
    import rerun as rr
    import rerun.blueprint as rrb

    trajectory: PiecewisePolynomial = result.trajectory
    names = result.joint_names
    times = trajectory.sample_times(rate_hz)
    time_index = _time_index(times)
    if len(times) > PROFILE_SAMPLES:  # what a person looks at: the trajectory's own values, at fewer times
        plot_times, plot_values = trajectory.sample(PROFILE_SAMPLES / trajectory.total_time)
        positions = trajectory.evaluate(times)  # every sample: the robot's motion, and what replay --check reads
    else:
        plot_times, plot_values = times, trajectory.states(times)
        positions = plot_values[0]
    plot_index = _time_index(plot_times)
    rec.send_recording_name(result.task.name)
    rec.send_property("plan", rr.AnyValues(
        task=result.task.name, family=result.task.family, optimizer=optimizer_name(
            result.task.optimizer["algorithm"], result.optimization.algorithm),
        total_time_s=trajectory.total_time, feasible=bool(result.feasible),
        joints=", ".join(names)))
    definition = trajectory_definition(trajectory, result.limits, names, getattr(result, "via_points", None))
    rec.log(_DEFINITION, rr.AnyValues(planner_definition=json.dumps(definition)), static=True)
    rec.send_columns(_SAMPLES, indexes=time_index, columns=rr.Scalars.columns(scalars=positions))
    rec.log(_SUMMARY, rr.TextDocument(plan_summary(result), media_type=rr.MediaType.MARKDOWN), static=True)

    # Each joint's series carries its name and colour in every plot; its limits and via-points share both,
    # so the legend holds one entry per joint (entries of one name are merged) and never lists the limits.
    bounds = [(result.limits.lower, result.limits.upper)] + [(-m, m) for m in result.limits.magnitudes]
    for k, profile in enumerate(_PROFILES):
        for j, name in enumerate(names):
            _log_profile(rec, profile, name, joint_colour(j), plot_index, np.rad2deg(plot_values[k, :, j]),
                         np.rad2deg((bounds[k][0][j], bounds[k][1][j])), trajectory.total_time)
    torque_limit = getattr(result, "torque_limit", None)
    if torque_limit is not None:  # a fifth plot: each joint's torque over its limit, the limits at +-1
        torque_ratios = result.torques_at(plot_times) / torque_limit
        for j, name in enumerate(names):
            _log_profile(rec, "torque", name, joint_colour(j), plot_index, torque_ratios[:, j],
                         (-1.0, 1.0), trajectory.total_time)
    via_index = _time_index(trajectory.via_times)
    via_positions = trajectory.evaluate(trajectory.via_times)
    for j, name in enumerate(names):
        entity = _entity("profiles", "position", "via_points", name)
        rec.log(entity, rr.SeriesPoints(names=name, colors=[joint_colour(j)], marker_sizes=3.0), static=True)
        rec.send_columns(entity, indexes=via_index,
                         columns=rr.Scalars.columns(scalars=np.rad2deg(via_positions[:, j])))

    plots = [rrb.TimeSeriesView(origin=f"/profiles/{p}", name=f"{p} [{unit}]",
                                plot_legend=rrb.PlotLegend(corner="LeftTop", visible=k == 0),
                                axis_x=_time_axis(trajectory.total_time, names),
                                axis_y=rrb.ScalarAxis(
                                    range=_position_range(plot_values[0], result.limits) if k == 0
                                    else _symmetric_range(np.rad2deg(plot_values[k]),
                                                          np.rad2deg(result.limits.magnitudes[k - 1]))))
             for k, (p, unit) in enumerate(zip(_PROFILES, DEGREE_UNITS))]
    if torque_limit is not None:
        plots.append(rrb.TimeSeriesView(origin="/profiles/torque", name="torque / limit",
                                        plot_legend=rrb.PlotLegend(corner="LeftTop", visible=False),
                                        axis_x=_time_axis(trajectory.total_time, names),
                                        axis_y=rrb.ScalarAxis(range=_symmetric_range(torque_ratios, np.ones(1)))))
    summary = rrb.TextDocumentView(origin=_SUMMARY, name="summary")
    if result.robot is not None:
        eye = _log_robot(rec, result, times, positions)
        robot_view = rrb.Spatial3DView(origin="/", name="robot", contents=[  # visual geometry only
            "/robot/**", "/scene/**", "- /robot/**/collision_geometries/**"], eye_controls=eye)
        layout = rrb.Horizontal(rrb.Vertical(robot_view, summary, row_shares=[3, 1]), rrb.Vertical(*plots),
                                column_shares=[1, 1])
    else:
        layout = rrb.Horizontal(summary, rrb.Vertical(*plots), column_shares=[1, 2])
    rec.send_blueprint(rrb.Blueprint(layout, collapse_panels=True))
    rec.flush()  # everything above is in the stream before the end marker
    rec.log(_END, rr.AnyValues(planner_end=json.dumps(end_marker(times, rate_hz))), static=True)


@contextmanager
def _ros_package_path(package_dirs):
    """``ROS_PACKAGE_PATH`` set, for the block, to ``robot.package_roots(package_dirs)``, so that
    Rerun's URDF importer resolves what the drawn copy (``robot.drawable_urdf``, its meshes by absolute
    path) still names as ``package://NAME/...`` (a material's texture) under the robot's package roots."""
    from .robot import package_roots  # here: replaying a recording needs no Pinocchio

    previous = os.environ.get("ROS_PACKAGE_PATH")
    os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(str(root) for root in package_roots(package_dirs))
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop("ROS_PACKAGE_PATH", None)
        else:
            os.environ["ROS_PACKAGE_PATH"] = previous


def _check_urdf_unchanged(robot) -> None:
    """Refuse to draw a robot whose URDF file is gone or no longer the one it was loaded from (a result
    saved after the file was edited would show another robot than it planned for), or one of whose
    meshes is gone since, or is no longer a regular file of a mesh's size (``robot.check_meshes``: Rerun
    would wait forever on a pipe put in a mesh's place).

    Raises:
        RecordingError: naming the file.
    """
    from .errors import RobotFileError
    from .robot import check_meshes, file_digest  # the robot is loaded: so is its module

    try:
        now = file_digest(robot.urdf_path)
    except OSError as exc:
        raise RecordingError(f"cannot read the URDF {robot.urdf_path} again to draw the robot: "
                             f"{exc.strerror or exc}") from None
    if robot.urdf_digest and now != robot.urdf_digest:
        raise RecordingError(f"the URDF {robot.urdf_path} has changed since the robot was loaded: the recording "
                             f"would draw another robot than the plan's; plan again with it as it is now")
    try:
        missing = check_meshes(robot.urdf_path, robot.package_dirs)
    except RobotFileError as exc:
        raise RecordingError(f"cannot draw the robot: {exc}, which it was not when the robot was loaded; "
                             f"restore the mesh, or plan again") from None
    gone = [mesh for mesh in missing if mesh not in robot.missing_meshes]
    if gone:
        raise RecordingError(f"cannot draw the robot: the mesh {shown(gone[0], 120)} the URDF {robot.urdf_path} "
                             f"names is gone since the robot was loaded; restore it, or plan again")


def _log_robot(rec, result, times: np.ndarray, positions: np.ndarray):
    """Log the robot, animated, and the scene around it; returns the 3D view's eye, framing them all."""
    import rerun as rr
    import rerun.urdf as rru

    robot = result.robot
    _check_urdf_unchanged(robot)
    from .robot import drawable_urdf
    with _ros_package_path(robot.package_dirs), tempfile.TemporaryDirectory(prefix="planner-urdf-") as folder:
        drawn = Path(folder) / robot.urdf_path.name  # its meshes by their checked absolute paths only
        drawn.write_bytes(drawable_urdf(robot.urdf_path, robot.package_dirs))
        try:
            tree = rru.UrdfTree.from_file_path(drawn, entity_path_prefix="robot")
        except Exception as exc:  # rerun raises plain exceptions for unreadable URDFs
            raise RecordingError(f"Rerun cannot read the URDF {robot.urdf_path}: {exc}") from None
        tree.log_urdf_to_recording(rec)
    planned = {name: j for j, name in enumerate(robot.joint_names)}
    time_index = _time_index(times)
    for joint in tree.joints():
        if joint.joint_type == "fixed":
            continue
        entity = _entity("robot", "joint_transforms", joint.name)
        if joint.name in planned:
            angles = positions[:, planned[joint.name]].tolist()
            rec.send_columns(entity, indexes=time_index, columns=joint.compute_transform_columns(angles, clamp=False))
        elif joint.joint_type in ("revolute", "continuous", "prismatic"):  # held where the planner's model holds it
            rec.log(entity, joint.compute_transform(robot.locked_positions.get(joint.name, 0.0), clamp=False),
                    static=True)
        else:  # floating or planar, off the chain (Rerun computes no transform of these): at its origin, as locked
            from scipy.spatial.transform import Rotation
            rec.log(entity, rr.Transform3D(translation=joint.origin_xyz,
                                           quaternion=rr.Quaternion(xyzw=Rotation.from_euler(
                                               "xyz", joint.origin_rpy).as_quat()),
                                           parent_frame=joint.parent_link, child_frame=joint.child_link), static=True)
    root = rr.CoordinateFrame(tree.root_link().name)
    tool = robot.tool_placements(positions)[0]
    rec.log("scene/tool_path", rr.LineStrips3D([tool], colors=[_TOOL_PATH_COLOUR], radii=0.003), root, static=True)
    rec.log("scene/tool", rr.Points3D.from_fields(colors=[_TOOL_COLOUR], radii=0.018), root, static=True)
    rec.send_columns("scene/tool", indexes=time_index, columns=rr.Points3D.columns(positions=tool))

    waypoints = result.waypoint_via
    poses = [robot.forward_kinematics(q) for q in result.via_points[waypoints]]
    origins = np.array([p.translation for p in poses])
    vectors = np.concatenate([0.06 * p.rotation.T for p in poses])
    rec.log("scene/waypoints", rr.Arrows3D(origins=np.repeat(origins, 3, axis=0), vectors=vectors,
                                           colors=[[230, 40, 40], [40, 200, 40], [40, 90, 230]] * len(poses),
                                           radii=0.004), root, static=True)
    groups = coincident_groups(origins, COINCIDENT_M)
    labels = [_waypoint_label(group, result.ik) for group in groups]
    rec.log("scene/waypoint_labels", rr.Points3D([origins[g[0]] for g in groups], colors=[_WAYPOINT_COLOUR],
                                                 radii=0.008, labels=labels, show_labels=True), root, static=True)
    inserted_points = np.empty((0, 3))
    if result.path is not None:
        rec.log("scene/straight_segments", rr.LineStrips3D([origins], colors=[[150, 150, 150]], radii=0.0015),
                root, static=True)
        inserted = np.setdiff1d(np.arange(len(result.via_points)), waypoints)
        if inserted.size:
            inserted_points = robot.tool_placements(result.via_points[inserted])[0]
            rec.log("scene/inserted_poses", rr.Points3D(inserted_points, colors=[_INSERTED_COLOUR], radii=0.005,
                                                        show_labels=False), root, static=True)
    body = _robot_points(robot, positions)
    return framing_eye(np.concatenate([tool, origins, inserted_points, body, np.zeros((1, 3))]), tool, origins)


def coincident_groups(points: np.ndarray, tolerance: float) -> list[list[int]]:
    """Indices of ``points`` grouped where they lie within ``tolerance`` of a group's first point, in order."""
    groups: list[list[int]] = []
    for i, point in enumerate(points):
        for group in groups:
            if np.linalg.norm(points[group[0]] - point) <= tolerance:
                group.append(i)
                break
        else:
            groups.append([i])
    return groups


def _waypoint_label(group: list[int], ik) -> str:
    """The label of coincident waypoints ``group``: "waypoint 1 (IK 3/8)", "waypoints 0, 2 (...)"."""
    text = ("waypoint " if len(group) == 1 else "waypoints ") + ", ".join(str(i) for i in group)
    if ik:
        chosen = {(ik[i].chosen + 1, ik[i].solutions) for i in group}
        if len(chosen) == 1:
            (k, n), = chosen
            text += f" (IK {k}/{n})"
        else:
            text += " (IK " + ", ".join(f"{ik[i].chosen + 1}/{ik[i].solutions}" for i in group) + ")"
    return text


#: Shapes whose size or offset reach this [m] are left out of the view's framing.
_FRAMED_SIZE_M = 1e3


def _robot_points(robot, positions: np.ndarray, count: int = 24) -> np.ndarray:
    """Where the arm's bodies go: around the centre of each link's visual geometry, as far as it reaches,
    at ``count`` configurations along ``positions``."""
    import pinocchio as pin

    visuals = _link_visuals(robot.urdf_path)
    bodies = [(f, visuals.get(frame.name, [(np.zeros(3), _LINK_REACH)])) for f, frame in enumerate(robot.model.frames)
              if frame.type == pin.FrameType.BODY]
    directions = np.concatenate([np.zeros((1, 3)), np.eye(3), -np.eye(3)])
    points = []
    for q in positions[np.linspace(0, len(positions) - 1, min(count, len(positions))).astype(int)]:
        pin.framesForwardKinematics(robot.model, robot.data, np.asarray(q, dtype=float))
        for f, shapes in bodies:
            placement = robot.data.oMf[f]
            points += [placement.rotation @ centre + placement.translation + size * directions
                       for centre, size in shapes]
    return np.concatenate(points) if points else np.zeros((0, 3))


def _link_visuals(urdf_path) -> dict[str, list[tuple[np.ndarray, float]]]:
    """Each link's visual shapes as (centre in the link's frame [m], half their size [m]), from the URDF;
    meshes count as ``_LINK_REACH`` around their origin. A shape at or beyond ``_FRAMED_SIZE_M`` (or not
    a number) is left out: the view frames the arm, not a 1e300 m box."""
    from .robot import urdf_elements  # the robot is loaded: so is its module

    visuals: dict[str, list[tuple[np.ndarray, float]]] = {}
    try:
        for link in urdf_elements(urdf_path, "link"):
            for visual in link.iter("visual"):
                origin = visual.find("origin")
                centre = np.fromstring(origin.get("xyz", "0 0 0"), sep=" ") if origin is not None else np.zeros(3)
                size = _LINK_REACH
                geometry = visual.find("geometry")
                for shape in geometry if geometry is not None else ():
                    if shape.tag == "box":
                        size = math.hypot(*np.fromstring(shape.get("size", ""), sep=" ")) / 2
                    elif shape.tag == "cylinder":
                        size = math.hypot(float(shape.get("radius", 0)), float(shape.get("length", 0)) / 2)
                    elif shape.tag == "sphere":
                        size = float(shape.get("radius", 0))
                if centre.shape == (3,) and np.abs(centre).max() < _FRAMED_SIZE_M and 0 <= size < _FRAMED_SIZE_M:
                    visuals.setdefault(link.get("name") or "", []).append((centre, size))
    except ValueError:  # a number that is none: framing is a nicety, link frames alone then
        return {}
    return visuals


#: The 3D view's vertical field of view [rad] (Rerun's default eye), and the least width / height of the view.
_FOV_Y = math.radians(55.0)
_ASPECT = 1.2
#: Angle kept free at the view's edges [rad].
_EDGE = math.radians(3.0)
#: How far a link's body reaches from its frame where the URDF does not say (meshes) [m], about.
_LINK_REACH = 0.06


def framing_eye(points: np.ndarray, tool: np.ndarray, waypoints: np.ndarray):
    """An orbital eye (``rrb.EyeControls3D``, +Z up) that sees all of ``points``.

    It looks at the centre of their bounding box from the side of the tool path (so the arm does not
    hide it), across the path's widest horizontal spread turned by 35 degrees (for depth), from 30 degrees
    above, and just far enough for every point to lie inside the view (less a small edge)."""
    import rerun.blueprint as rrb

    low, high = points.min(axis=0), points.max(axis=0)
    centre = (low + high) / 2
    path = np.concatenate([tool, waypoints])
    spread = path[:, :2] - path[:, :2].mean(axis=0)
    if len(spread) > 1 and np.abs(spread).max() > 1e-6:
        major = np.linalg.svd(spread, full_matrices=False)[2][0]
        side = np.array([-major[1], major[0]])
    else:
        side = np.array([1.0, -1.0]) / math.sqrt(2)
    towards_path = path.mean(axis=0)[:2] - centre[:2]
    if side @ towards_path < 0 or (abs(side @ towards_path) < 1e-6 and side @ [1.0, -1.0] < 0):
        side = -side
    turn, elevation = math.radians(35.0), math.radians(30.0)
    side = np.array([side[0] * math.cos(turn) - side[1] * math.sin(turn),
                     side[0] * math.sin(turn) + side[1] * math.cos(turn)])
    backwards = np.array([side[0] * math.cos(elevation), side[1] * math.cos(elevation), math.sin(elevation)])
    up = np.array([0.0, 0.0, 1.0]) - math.sin(elevation) * backwards
    up /= np.linalg.norm(up)
    right = np.cross(backwards, up)
    offsets = points - centre
    towards_eye = offsets @ backwards
    half_height = math.tan(_FOV_Y / 2 - _EDGE)
    half_width = math.tan(math.atan(_ASPECT * math.tan(_FOV_Y / 2)) - _EDGE)
    distance = float(np.max(towards_eye + np.maximum(np.abs(offsets @ up) / half_height,
                                                     np.abs(offsets @ right) / half_width)))
    distance = max(distance, float(np.max(towards_eye)) + 0.05, 0.1)
    return rrb.EyeControls3D(kind="Orbital", position=centre + distance * backwards, look_target=centre,
                             eye_up=[0.0, 0.0, 1.0])


# ---------------------------------------------------------------------------- reading back


@dataclass(frozen=True)
class RecordingCheck:
    """What ``RecordedPlan.check`` finds.

    Attributes:
        violations: each limit the exact trajectory exceeds (joint, quantity, value, limit), the exact
            check's own (``KinematicFigures.violations``); empty when all hold.
        breaks: each break of its continuity or of its rest at the ends (``continuity_breaks``), and each
            via-point it misses (``via_point_misses``): lines with the joint, quantity, value and tolerance
            as fields.
        largest_ratio: largest constraint ratio max|q^(d)| / limit over joints and orders.
        deviation: largest |sample - trajectory at the sample's time| [rad].
        tolerance: the deviation allowed by Rerun's whole-nanosecond times [rad].
    """

    violations: tuple[Violation, ...]
    breaks: tuple[Break, ...]
    largest_ratio: float
    deviation: float
    tolerance: float

    @property
    def findings(self) -> list[str]:
        """One line per violation, then per break (empty when the trajectory holds)."""
        return [str(v) for v in self.violations] + list(self.breaks)

    @property
    def passed(self) -> bool:
        """Every limit holds, the trajectory is whole, and every sample lies on it."""
        return not self.violations and not self.breaks and self.deviation <= self.tolerance


@dataclass(frozen=True)
class RecordedPlan(ReadOnlyArrays):
    """What ``read_recording`` recovers: the sampled joint positions and the exact trajectory (its arrays
    read-only).

    Attributes:
        times: (N,) sample times [s], increasing, from 0 to the total time.
        positions: (N, J) joint positions [rad] at ``times``.
        trajectory: the exact piecewise polynomial.
        limits: the limits it was planned under [SI].
        joint_names: (J,) names, as the planner knew them.
        rate_hz: the sample rate [Hz].
        via_points: (n, J) the via-points it was planned through [rad] (None in a recording without them).
    """

    times: np.ndarray
    positions: np.ndarray
    trajectory: PiecewisePolynomial
    limits: JointLimits
    joint_names: list[str]
    rate_hz: float
    via_points: np.ndarray | None = None

    def __post_init__(self):
        freeze_arrays(self)

    def check(self) -> RecordingCheck:
        """Re-run the exact limit checks, check that the trajectory is continuous and rests at both ends
        (``continuity_breaks``) and passes its via-points where the recording holds them
        (``via_point_misses``), and compare the samples with the trajectory."""
        figures = kinematic_figures(self.trajectory)
        deviation = float(np.abs(self.trajectory.evaluate(self.times) - self.positions).max())
        # A sample may sit up to half a time quantum off its time: allow the position change over a whole
        # one, and a few units in the last place of the largest position (the positions' own rounding).
        largest = float(np.abs(self.positions).max(initial=0.0))
        tolerance = _TIME_QUANTUM_NS * 1e-9 * float(figures.max_abs[0].max()) + 1e-12 + 8 * float(np.spacing(largest))
        ratio = float(np.nan_to_num(figures.ratios(self.limits)).max())
        breaks = continuity_breaks(self.trajectory, self.joint_names)
        if self.via_points is not None:
            breaks += via_point_misses(self.trajectory, self.via_points, self.joint_names)
        return RecordingCheck(tuple(figures.violations(self.limits)), tuple(breaks), ratio, deviation, tolerance)


def read_recording(path) -> RecordedPlan:
    """Read a planner recording back, without a viewer, and check that it is whole.

    Decoded in a forked child (``concurrency.call_in_child``) where this process has not loaded Rerun yet:
    bytes that make Rerun's decoder abort (a Rust panic, which no ``except`` catches) end the child, and are
    said as an unreadable recording. Where Rerun is loaded, decoded here (a child forked beside its native
    threads could hang).

    Raises:
        RecordingError: a missing file, one Rerun cannot read, one not written by the
            planner, a definition or samples that are malformed (the field is named), or
            an incomplete recording (no end marker, samples missing, duplicated or off
            the trajectory's time span).
    """
    if not isinstance(path, (str, os.PathLike)) or not isinstance(os.fspath(path), str):
        raise RecordingError(f"a recording is given by its path (text or path-like), not {type(path).__name__}")
    if isinstance(path, str) and not path.strip():
        raise RecordingError("the recording's path is empty (an unset shell variable?); give a path")
    path = Path(path)
    if not utf8_path(path.absolute()):
        raise RecordingError(f"{shown(str(path.absolute()))}: "
                             + not_utf8(path.absolute(), "Rerun reads recordings at UTF-8 paths only: rename or "
                                                         "link it"))
    try:
        if not path.is_file():
            what = ("a folder: give the .rrd file in it" if path.is_dir() else
                    "not a regular file (a device or pipe)" if path.exists() else
                    "a symbolic link to nothing (its target is missing, or the links form a loop)"
                    if path.is_symlink() else "no such recording")
            raise RecordingError(f"{path}: {what}")
    except OSError as exc:  # a name too long, a folder on the way that cannot be read
        raise RecordingError(f"{shown(str(path))}: {exc.strerror or exc}") from None
    if "rerun_bindings" in sys.modules:  # Rerun's native threads run here: a child forked now could hang
        return _read(path)
    try:  # bytes that crash Rerun's decoder (a Rust panic aborts the process) end a child, not this process
        return call_in_child(_read, path)
    except WorkerLost as lost:
        panic = [line.strip() for line in lost.said.splitlines() if line.strip()]
        cause = next((panic[i + 1] for i, line in enumerate(panic[:-1]) if "panicked at" in line), "")
        raise RecordingError(f"{path}: not a readable Rerun recording (its decoder crashed on it"
                             f"{': ' + cause if cause else ''})") from None


def _read(path: Path) -> RecordedPlan:
    """``read_recording`` of a path known to be a file."""
    application, chunks = _trajectory_chunks(path)
    definition_text = _single_text(path, chunks.get(_DEFINITION, []), "planner_definition")
    if definition_text is None and application != APPLICATION_ID:
        raise RecordingError(f"{path}: not a planner recording (application {shown(application)}, no trajectory "
                             f"definition of format {FORMAT})")
    if definition_text is None:
        raise RecordingError(f"{path}: recording is incomplete: no trajectory/definition")
    names, trajectory, limits, via_points = _definition(path, definition_text)
    end_text = _single_text(path, chunks.get(_END, []), "planner_end")
    if end_text is None:
        raise RecordingError(f"{path}: recording is incomplete: no end marker (trajectory/end, written last: the "
                             "file was cut short, or is not as the planner wrote it)")
    count, rate_hz, span = _end(path, end_text, trajectory.total_time)
    times_ns, positions = _samples(path, chunks.get(_SAMPLES, []), list(names))
    _require_complete(path, times_ns, count, rate_hz, span)
    _require_schedule(path, times_ns, trajectory, rate_hz)
    return RecordedPlan(times_ns / 1e9, positions, trajectory, limits, names, rate_hz, via_points)


def _trajectory_chunks(path: Path) -> tuple[str, dict[str, list]]:
    """The recording's application id and its ``trajectory/...`` chunks by entity path."""
    _quiet_rerun_logs()  # what the decoder cannot decode, the RecordingError below says once
    import rerun.chunk as rc

    try:
        with warnings.catch_warnings(record=True) as warned:  # rerun warns about a file without its footer
            warnings.simplefilter("always")
            reader = rc.RrdReader(str(path))
            stores = reader.recordings()
            chunks = reader.stream().filter(content="/trajectory/**").to_chunks()
    except Exception as exc:  # rerun raises plain exceptions for corrupt files
        said = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise RecordingError(f"{path}: not a readable Rerun recording ({said})") from None
    if any("no footer" in str(warning.message) for warning in warned):
        raise RecordingError(f"{path}: recording is incomplete: its footer, written when the file is closed, is "
                             f"missing (the file was cut short, is still being written, or has bytes after its "
                             f"end)")
    if len(stores) != 1:
        raise RecordingError(f"{path}: holds {len(stores)} recordings; a planner recording holds one")
    by_entity: dict[str, list] = {}
    for chunk in chunks:
        by_entity.setdefault(chunk.entity_path, []).append(chunk)
    return stores[0].application_id, by_entity


def _single_text(path: Path, chunks: list, component: str) -> str | None:
    """The one static text ``component`` of an entity's ``chunks``; None when there are no chunks."""
    if not chunks:
        return None
    entity = chunks[0].entity_path.lstrip("/")
    values = []
    for chunk in chunks:
        batch = chunk.to_record_batch()
        columns = [n for n in batch.schema.names if n == component or n.endswith(f":{component}")]
        if not chunk.is_static or len(columns) != 1:
            raise RecordingError(f"{path}: {entity} holds no static {component} text")
        values += batch.column(columns[0]).to_pylist()
    if len(values) > 1:  # the same recording's file written twice over, or two joined (``cat a.rrd b.rrd``)
        raise RecordingError(f"{path}: {entity} holds {len(values)} {component} texts where a recording holds one "
                             f"(two recordings joined into one file?)")
    if len(values) != 1 or not isinstance(values[0], list) or len(values[0]) != 1 or not isinstance(values[0][0], str):
        raise RecordingError(f"{path}: {entity} must hold one {component} text, got {shown(values)}")
    return values[0][0]


def _json_object(where: str, text: str) -> dict:
    try:
        value = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise RecordingError(f"{where}: not JSON ({exc}): {shown(text)}") from None
    if not isinstance(value, dict):
        raise RecordingError(f"{where}: must be a JSON object, got {shown(value)}")
    return value


def _seconds(ns) -> str:
    """A recorded time [ns] as text in seconds."""
    return f"{float(ns) / 1e9!r} s"


def _is_number(value) -> TypeGuard[int | float]:
    """A JSON number a float holds: JSON's integers have no bound (10**400 parses), floats do."""
    return isinstance(value, float) or (isinstance(value, int) and not isinstance(value, bool)
                                        and abs(value) <= sys.float_info.max)


def _is_count(value) -> TypeGuard[int]:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _numbers(where: str, data: dict, key: str, count: int | None = None, *, infinite: bool = False) -> np.ndarray:
    """``data[key]`` as a float vector: a JSON list of numbers, ``count`` long if given, never NaN.

    Args:
        where: what the error names first (the recording and its part).
        data: the JSON object read.
        key: the entry's key.
        count: the numbers it must hold, if given.
        infinite: whether +-inf is allowed (absent limits); otherwise every entry is finite.
    """
    value = data.get(key)
    if not isinstance(value, list) or not all(_is_number(v) for v in value):
        raise RecordingError(f"{where}: {key} must be a list of numbers, got {shown(value)}")
    if count is not None and len(value) != count:
        raise RecordingError(f"{where}: {key} must hold {count} numbers, got {len(value)}")
    array = np.array(value, dtype=float)
    bad = np.flatnonzero(np.isnan(array) if infinite else ~np.isfinite(array))
    if bad.size:
        wanted = "number" if infinite else "finite number"
        raise RecordingError(f"{where}: {key}[{bad[0]}] is {array[bad[0]]}, not a {wanted}")
    return array


def _writable_name(name: str) -> bool:
    r"""A joint name the exports can write: not empty, no control character, and text UTF-8 encodes (JSON's
    escapes can spell a lone surrogate such as \udcff, which is no character)."""
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return bool(name) and not CONTROL_CHARACTERS.search(name)


#: The most coefficients per polynomial a recording may hold: the planner's families have 4 to 8.
_MAX_COEFFICIENTS = 16


def _definition(path: Path, text: str) -> tuple[list[str], PiecewisePolynomial, JointLimits, np.ndarray | None]:
    """Joint names, trajectory, limits and via-points (None where absent) from the ``trajectory/definition``
    text, every field checked."""
    where = f"{path}: trajectory/definition"
    data = _json_object(where, text)
    if data.get("format") != FORMAT:
        raise RecordingError(f"{where}: format {shown(data.get('format'))}, expected {FORMAT!r} "
                             "(not a planner recording, or one from another planner version)")
    names = data.get("joint_names")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) and _writable_name(n) for n in names) \
            or len(set(names)) < len(names):
        raise RecordingError(f"{where}: joint_names must be a non-empty list of distinct texts, each non-empty, of "
                             f"Unicode characters and without control characters, got {shown(names)}")
    durations = _numbers(where, data, "durations_s")
    shape = data.get("coefficients_shape")
    if not (isinstance(shape, list) and len(shape) == 3 and all(_is_count(n) for n in shape)
            and shape[:2] == [len(durations), len(names)] and 1 <= shape[2] <= _MAX_COEFFICIENTS):
        raise RecordingError(f"{where}: coefficients_shape must be [{len(durations)} segments, {len(names)} joints, "
                             f"1 to {_MAX_COEFFICIENTS} coefficients per polynomial], got {shown(shape)}")
    coefficients = _numbers(where, data, "coefficients", math.prod(shape))
    knots = data.get("via_knots")
    if not (isinstance(knots, list) and all(_is_count(k) and k <= len(durations) for k in knots)
            and all(a <= b for a, b in zip(knots, knots[1:]))):  # repeated via-points share a knot
        raise RecordingError(f"{where}: via_knots must be non-decreasing knot indices 0..{len(durations)}, "
                             f"got {shown(knots)}")
    basis = data.get("basis", "power")  # recordings from before the trigonometric family hold power series
    if basis not in BASES:
        raise RecordingError(f"{where}: basis must be one of {', '.join(BASES)}, got {shown(basis)}")
    limits = data.get("limits")
    if not isinstance(limits, dict):
        raise RecordingError(f"{where}: limits must be an object of {', '.join(_LIMIT_FIELDS)}, got {shown(limits)}")
    bounds = [_numbers(f"{where}: limits", limits, key, len(names), infinite=True) for key in _LIMIT_FIELDS]
    via_points = None
    if "via_points_rad" in data:
        given = data["via_points_rad"]
        if not (isinstance(given, list) and len(given) == len(knots)
                and all(isinstance(row, list) and len(row) == len(names) for row in given)):
            raise RecordingError(f"{where}: via_points_rad must be {len(knots)} lists (one per via knot) of "
                                 f"{len(names)} positions, got {shown(given)}")
        via_points = _numbers(where, {"via_points_rad": [v for row in given for v in row]}, "via_points_rad",
                              len(knots) * len(names)).reshape(len(knots), len(names))
    try:
        return (names, PiecewisePolynomial(durations, coefficients.reshape(shape), np.array(knots, dtype=int), basis),
                JointLimits(bounds[0], bounds[1], bounds[2], bounds[3], bounds[4], names=tuple(names)), via_points)
    except InputError as exc:
        raise RecordingError(f"{where}: {exc}") from None


def _end(path: Path, text: str, total_time: float) -> tuple[int, float, tuple[float, float]]:
    """Sample count, rate [Hz] and time span [s] from the ``trajectory/end`` text, checked against the definition."""
    where = f"{path}: trajectory/end"
    data = _json_object(where, text)
    count = data.get("sample_count")
    if not _is_count(count) or not 1 <= count <= MAX_SAMPLES:
        raise RecordingError(f"{where}: sample_count must be a whole number from 1 to {MAX_SAMPLES:,}, got "
                             f"{shown(count)}")
    rate = data.get("sample_rate_hz")
    if not _is_number(rate) or not math.isfinite(rate) or rate <= 0:
        raise RecordingError(f"{where}: sample_rate_hz must be a finite number > 0, got {shown(rate)}")
    span = _numbers(where, data, "time_span_s", 2)
    if abs(span[0]) > 1e-9 or abs(span[1] - total_time) > 1e-9 * max(1.0, total_time):
        raise RecordingError(f"{where}: time_span_s {shown(span.tolist())} is not the trajectory's "
                             f"[0, {total_time!r}] s")
    return count, float(rate), (float(span[0]), float(span[1]))


def _samples(path: Path, chunks: list, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Sample times [ns] (N,) and positions [rad] (N, joints) of ``trajectory/samples`` of the joints ``names``,
    sorted by time."""
    import pyarrow as pa

    joints = len(names)
    where = f"{path}: trajectory/samples"
    times, rows = [], []
    for chunk in chunks:
        batch = chunk.to_record_batch()
        if "time" not in batch.schema.names or batch.schema.field("time").type != pa.duration("ns"):
            raise RecordingError(f"{where}: not logged on the duration timeline 'time'")
        if _SCALARS not in batch.schema.names:
            raise RecordingError(f"{where}: holds no {_SCALARS} column")
        column = batch.column("time")
        if column.null_count:
            raise RecordingError(f"{where}: {column.null_count} samples without a time")
        times.append(column.cast(pa.int64()).to_numpy(zero_copy_only=False))
        rows += batch.column(_SCALARS).to_pylist()
    if not rows:
        raise RecordingError(f"{path}: recording is incomplete: no trajectory/samples")
    times_ns = np.concatenate(times)
    for i, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != joints or not all(_is_number(v) for v in row):
            raise RecordingError(f"{where}: the sample at {_seconds(times_ns[i])} holds {shown(row)}, "
                                 f"expected {joints} joint positions")
    positions = np.array(rows, dtype=float).reshape(len(rows), joints)
    bad = np.argwhere(~np.isfinite(positions))
    if bad.size:
        i, j = (int(k) for k in bad[0])
        raise RecordingError(f"{where}: joint {names[j]} at {_seconds(times_ns[i])} is {positions[i, j]}")
    order = np.argsort(times_ns, kind="stable")
    return times_ns[order], positions[order]


def _require_complete(path: Path, times_ns: np.ndarray, count: int, rate_hz: float,
                      span: tuple[float, float]) -> None:
    """Samples as the end marker says: ``count`` of them from span[0] to span[1], none twice, no gap > 1/rate."""
    incomplete = f"{path}: recording is incomplete:"
    if len(times_ns) < count:
        raise RecordingError(f"{incomplete} {len(times_ns)} of the {count} samples the end marker announces")
    steps = np.diff(times_ns)
    if np.any(steps == 0):
        raise RecordingError(f"{incomplete} two samples at {_seconds(times_ns[np.argmax(steps == 0)])}")
    if len(times_ns) > count:
        raise RecordingError(f"{path}: recording is not as the planner wrote it: {len(times_ns)} samples where the "
                             f"end marker announces {count}")
    start, end = span[0] * 1e9, span[1] * 1e9
    if abs(times_ns[0] - start) > _TIME_QUANTUM_NS:
        raise RecordingError(f"{incomplete} samples start at {_seconds(times_ns[0])}, not at {span[0]!r} s")
    if abs(times_ns[-1] - end) > _TIME_QUANTUM_NS + 1e-12 * end:
        raise RecordingError(f"{incomplete} samples end at {_seconds(times_ns[-1])}, not at the total time "
                             f"{span[1]!r} s")
    period = 1e9 / rate_hz
    if steps.size and steps.max() > period + _TIME_QUANTUM_NS:
        k = int(np.argmax(steps))
        raise RecordingError(f"{incomplete} no samples between {_seconds(times_ns[k])} and "
                             f"{_seconds(times_ns[k + 1])} (sample period {1 / rate_hz!r} s)")


def _require_schedule(path: Path, times_ns: np.ndarray, trajectory: PiecewisePolynomial, rate_hz: float) -> None:
    """Samples at the times the planner samples ``trajectory`` at ``rate_hz`` (``sample_times``): an end marker
    whose rate disagrees with its samples (a CSV export would follow the rate, not the samples) is refused."""
    forged = f"{path}: recording is not as the planner wrote it:"
    try:
        schedule_ns = trajectory.sample_times(rate_hz) * 1e9
    except InputError as exc:
        raise RecordingError(f"{forged} {exc}") from None
    if len(schedule_ns) != len(times_ns):
        raise RecordingError(f"{forged} {len(times_ns)} samples where {rate_hz!r} Hz (the end marker's rate) over "
                             f"{trajectory.total_time!r} s makes {len(schedule_ns)}")
    off = np.abs(times_ns - schedule_ns)
    if off.max() > _TIME_QUANTUM_NS + 1e-12 * schedule_ns[-1]:
        k = int(np.argmax(off))
        raise RecordingError(f"{forged} sample {k} at {_seconds(times_ns[k])}, where {rate_hz!r} Hz (the end "
                             f"marker's rate) samples at {_seconds(schedule_ns[k])}")


# ---------------------------------------------------------------------------- the viewer

#: How long ``open_in_viewer`` watches the viewer for a failure at start-up [s].
VIEWER_STARTUP_S = 1.5
#: The command that opens a recording in the Rerun viewer (the file is appended).
VIEWER_COMMAND = (sys.executable, "-m", "rerun")


def has_display() -> bool:
    """Whether a window can be opened: always on macOS and Windows, elsewhere with DISPLAY or WAYLAND_DISPLAY set."""
    if os.name != "posix" or sys.platform == "darwin":
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def open_in_viewer(path: Path, *, startup_s: float = VIEWER_STARTUP_S, command: str = "planner") -> None:
    """Open the recording ``path`` in the Rerun viewer, a process of its own that outlives this one.

    ``command`` is how the planner was invoked, for the commands a failure suggests.

    Raises:
        PlannerError: no display to show the viewer on (checked before starting it), the viewer
            cannot be started, or it exits with an error within ``startup_s`` [s].
    """
    alternatives = (f"check it without a viewer with `{command} replay {path} --check`, render a view with "
                    f"--screenshot OUT.png, export its samples with --export-csv PATH, or open it on a machine "
                    f"with a display (or under xvfb-run)")
    if not has_display():
        raise ViewerError(f"no display for the Rerun viewer (neither DISPLAY nor WAYLAND_DISPLAY is set): "
                           f"{alternatives}")
    with tempfile.TemporaryFile() as log:  # the viewer's output, shown only if it fails at start-up
        try:
            viewer = subprocess.Popen([*VIEWER_COMMAND, str(path)], stdout=log, stderr=subprocess.STDOUT)
        except OSError as exc:
            raise ViewerError(f"cannot start the Rerun viewer: {exc}") from None
        try:
            code = viewer.wait(timeout=startup_s)
        except subprocess.TimeoutExpired:
            return  # still running: it is showing the recording
        if code == 0:
            return
        log.seek(0)
        lines = log.read().decode(errors="replace").strip().splitlines()
        said = f" ({shown(lines[-1].strip(), 300)})" if lines else ""  # its last line says why
        raise ViewerError(f"the Rerun viewer exited with code {code}{said}; {alternatives}")
