"""The planner end to end: task -> (robot, IK) -> timing optimization -> trajectory -> outputs.

Each stage takes and returns plain objects; this module only wires them.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from .cartesian_path import JUMP_RAD, StraightPath, follow_straight_lines, tool_deviation, track_from_turns
from .concurrency import WarmWorkers, WorkerLost, map_forked
from .dynamics import (
    RobotLimitOutcome,
    bodies_without_inertia,
    check_resting_ends,
    holds_still,
    joint_torques,
    meet_robot_limits,
    torque_limits,
)
from .errors import (
    IKError,
    InfeasibleError,
    InputError,
    MissingLimitError,
    OutputError,
    PlannerError,
    SettingError,
    TaskError,
    shown,
)
from .export import TrajectoryCsv, coefficients_document, json_ready, write_json
from .ik import (
    IKSolution,
    closed_form_solver,
    described,
    pose_from_position_quaternion,
    resting_solutions,
    solve_waypoints,
)
from .kinematics import KinematicFigures, Violation, continuity_breaks, kinematic_figures, via_point_misses
from .limits import (
    FEASIBILITY_TOLERANCE,
    LIMITED,
    PROFILE_QUANTITIES,
    QUANTITIES,
    JointLimits,
    bounds_exceeded,
    in_degrees,
    in_degrees_apart,
    numbers_apart,
    ratio_exceeded,
    seconds_text,
)
from .outputs import absolute_path, output_folder
from .progress import TerminalProgress
from .read_only import read_only
from .recording import optimizer_name, prepare_recording, write_recording
from .report import plot_profiles, prepare_figure
from .robot import Robot, load_robot
from .splines import MAX_SAMPLES, PiecewisePolynomial, get_family
from .task import Task, check_limit_counts, check_task, load_task, parse_task, plain_values
from .timing import OptimizationResult, TimingProblem, optimize
from .timing.nlp import robot_refine
from .timing.result import time_limit
from .timing.robot_rows import RobotConstraints
from .validate import finite_array

#: Significant digits of the numbers in summary.json (coefficients.json keeps every digit).
SUMMARY_DIGITS = 12


@dataclass(frozen=True)
class PlanResult:
    """Everything a plan produced, in SI units. Frozen: a result with another trajectory, via-points or
    limits (``dataclasses.replace``) has its figures computed again, so ``feasible``, the summary and
    ``save`` describe the trajectory it holds.

    Attributes:
        task: the validated task.
        via_points: (n, J) joint via-points [rad].
        limits: the limits planned against (robot's, with the task's overrides).
        optimization: the optimizer's result.
        trajectory: the final piecewise polynomial.
        figures: its exact kinematic figures (computed from it, not given).
        timings_s: wall time of each stage [s].
        robot: the robot, for robot tasks.
        ik: one IK solution per Cartesian waypoint (residuals, branches, joint-space jumps).
        branch_times: total time [s] of each branch rule's sequence, when both were timed (None: that
            rule's sequence could not be timed); with torque or tool-speed limits, each kinematic
            optimum slowed down uniformly to meet them (``meet_robot_limits``), the times compared.
        branch_kept: the rule (``optimal`` or ``continuous``) whose IK sequence was planned, or ``tracked``:
            in linear mode, the solutions the straight lines reach from a rule's first (``_follow_lines``).
        robot_limits: how the torque and tool-speed limits were met, where the task gives them.
        measured_on: ``trajectory_digest`` of the trajectory ``path`` and ``robot_limits`` were measured on
            (a result with another trajectory and either of them is refused); "" where not recorded.
        limits_beyond_robot: where the task's limits allow more than the robot's own (URDF) range or velocity,
            one record per joint and limit (``summary.json``'s ``robot.limits_beyond_urdf``).
        path: for Cartesian tasks, how the tool follows the straight segments between
            waypoints (``linear`` mode) or strays from them (``joint`` mode).
    """

    task: Task
    via_points: np.ndarray
    limits: JointLimits
    optimization: OptimizationResult
    trajectory: PiecewisePolynomial
    timings_s: dict[str, float] = field(default_factory=dict)
    robot: Robot | None = None
    ik: list[IKSolution] | None = None
    path: StraightPath | None = None
    branch_times: dict[str, float | None] = field(default_factory=dict)
    branch_kept: str | None = None
    robot_limits: RobotLimitOutcome | None = None
    measured_on: str = ""
    limits_beyond_robot: tuple[dict, ...] = ()
    figures: KinematicFigures = field(init=False)

    def __post_init__(self):
        """Check that the parts belong together, and compute the trajectory's figures.

        Raises:
            InputError: a part of another type (a trajectory that is not a ``PiecewisePolynomial``, ...),
                via-points or limits for another number of joints, via-points the trajectory does not pass,
                IK solutions for another number of waypoints, a task that is not the one planned (another
                family's segments, a robot where the result has none or the reverse, other joint
                waypoints, limits for another number of joints), or a tool path or robot-limit figures
                measured on another trajectory (``measured_on``).
        """
        self._check_types()
        via = finite_array("a plan result's via-points", self.via_points, 2)
        joints = self.trajectory.joint_count
        if via.shape != (len(self.trajectory.via_knots), joints) or self.limits.joint_count != joints:
            raise InputError(f"a plan result's via-points {via.shape} and limits ({self.limits.joint_count} joints) "
                             f"must match its trajectory ({len(self.trajectory.via_knots)} via-points, {joints} "
                             f"joints)")
        missed = via_point_misses(self.trajectory, via, self.limits.names)
        if missed:
            raise InputError(f"a plan result's trajectory does not pass its via-points: {missed[0]}")
        waypoints = self.task.cartesian_waypoints
        if self.ik is not None and waypoints is not None and len(self.ik) != len(waypoints):
            raise InputError(f"a plan result holds {len(self.ik)} IK solutions for {len(waypoints)} waypoints")
        self._check_task(via)
        self._check_ik(via)
        object.__setattr__(self, "via_points", read_only(via))  # the summary reads it
        if self.measured_on and (self.path is not None or self.robot_limits is not None) \
                and self.measured_on != trajectory_digest(self.trajectory):
            raise InputError("a plan result's tool path and robot-limit figures were measured on the trajectory "
                             "planned, not on this one: plan again for another trajectory")
        object.__setattr__(self, "figures", kinematic_figures(self.trajectory))

    def _check_types(self) -> None:
        """Each part of its type (``dataclasses.replace`` takes anything)."""
        required = {"task": (self.task, Task), "limits": (self.limits, JointLimits),
                    "optimization": (self.optimization, OptimizationResult),
                    "trajectory": (self.trajectory, PiecewisePolynomial)}
        optional = {"robot": (self.robot, Robot), "ik": (self.ik, list), "path": (self.path, StraightPath),
                    "robot_limits": (self.robot_limits, RobotLimitOutcome)}
        for name, (value, kind) in {**required, **optional}.items():
            if not isinstance(value, kind) and not (name in optional and value is None):
                article = "an" if kind.__name__[0] in "AEIOU" else "a"
                raise InputError(f"a plan result's {name} must be {article} {kind.__name__}"
                                 f"{' or None' if name in optional else ''}, not {type(value).__name__}")
        for name, may_be_none in (("timings_s", False), ("branch_times", True)):
            # each result its own copy: ``write`` adds the outputs' time to it, and copies by
            # ``dataclasses.replace`` shared the one dict
            object.__setattr__(self, name, _seconds_by_name(name, getattr(self, name), may_be_none))

    def _check_ik(self, via: np.ndarray) -> None:
        """Each IK solution is its waypoint's via-point (the straight path's ``waypoint_via`` places them among
        inserted poses), in order."""
        if self.ik is None:
            return
        places = self.path.waypoint_via if self.path is not None else np.arange(len(self.ik))
        for waypoint, (solution, place) in enumerate(zip(self.ik, places)):
            if not isinstance(solution, IKSolution):
                raise InputError(f"a plan result's IK solution {waypoint} must be an IKSolution, not "
                                 f"{type(solution).__name__}")
            if not (0 <= place < len(via) and solution.q.shape == via[place].shape
                    and np.allclose(solution.q, via[place], rtol=2 * FEASIBILITY_TOLERANCE,
                                    atol=2 * FEASIBILITY_TOLERANCE)):  # as ``via_point_misses`` allows
                raise InputError(f"a plan result's IK solution for waypoint {waypoint} is not its via-point "
                                 f"{place}: the IK report belongs to another plan, or to another order")

    def _check_task(self, via: np.ndarray) -> None:
        """The task is the one planned: its family's segments, its robot, its joint waypoints and its limits'
        joint count."""
        task, trajectory = self.task, self.trajectory
        family = get_family(task.family)
        distinct = np.unique(trajectory.via_knots)  # repeated via-points share a knot
        if trajectory.segment_count != family.segment_count(len(distinct)) \
                or not np.array_equal(distinct, family.via_knots(len(distinct))):
            raise InputError(f"a plan result's trajectory ({trajectory.segment_count} segments through "
                             f"{len(distinct)} distinct via-points) is not of its task's family {task.family!r}")
        if (trajectory.width, trajectory.basis) != (family.width, family.basis):
            raise InputError(f"a plan result's trajectory ({trajectory.basis} segments of {trajectory.width} "
                             f"coefficients) is not of its task's family {task.family!r} ({family.basis} segments of "
                             f"{family.width})")
        if task.cartesian_waypoints is not None and task.path.mode == "linear" and self.path is None:
            raise InputError(f"a plan result's task {task.name!r} follows straight lines, and the result has no "
                             f"straight-path report")
        if (task.robot is None) != (self.robot is None):
            raise InputError(f"a plan result's task {task.name!r} has {'no' if task.robot is None else 'a'} robot, "
                             f"the result {'none' if self.robot is None else 'one'}")
        if task.joint_waypoints is not None and not np.array_equal(task.joint_waypoints, via):
            raise InputError(f"a plan result's via-points are not its task {task.name!r}'s joint waypoints")
        counts = {len(values) for values in task.limits.values()} - {via.shape[1]}
        if counts:
            raise InputError(f"a plan result's task {task.name!r} gives limits for {counts.pop()} joints, its "
                             f"trajectory has {via.shape[1]}")

    @property
    def feasible(self) -> bool:
        """Whether the final trajectory meets every kinematic limit (the exact check) after a
        feasible optimization (``summary.json``'s ``feasible``)."""
        return bool(self.optimization.feasible) and not self.figures.violations(self.limits)

    @property
    def max_ratio(self) -> float:
        """The final trajectory's largest kinematic constraint ratio (after any slow-down)."""
        return float(np.max(self.figures.ratios(self.limits)))

    @property
    def torque_limit(self) -> np.ndarray | None:
        """(J,) the joint torque limits [N m] the plan met, or None without any."""
        return None if self.robot_limits is None else self.robot_limits.torque_limit

    def torques_at(self, times: np.ndarray) -> np.ndarray:
        """(K, J) the joint torques [N m] of the trajectory at ``times`` [s] (Pinocchio's RNEA).

        Raises:
            InputError: a plan without a robot (a joint-space task has no dynamics).
        """
        if self.robot is None:
            raise InputError(f"task {self.task.name!r} has no robot: torques need one (give robot in the task)")
        trajectory = self.trajectory
        return joint_torques(self.robot, *(trajectory.evaluate(times, order) for order in range(3)))

    @property
    def waypoint_via(self) -> np.ndarray:
        """(n,) index of each user waypoint among the via-points (inserted poses are not waypoints)."""
        return self.path.waypoint_via if self.path is not None else np.arange(len(self.via_points))

    @property
    def joint_names(self) -> list[str]:
        """The joints' names: the robot's, else joint1, joint2, ... (``limits.names``)."""
        return list(self.limits.names)

    def summary(self) -> dict:
        """The ``summary.json`` document (degrees for angles, seconds for time), as plain JSON values:
        lists, floats of ``SUMMARY_DIGITS`` significant digits, null for an absent (infinite) limit."""
        ratios = self.figures.ratios(self.limits)
        result = self.optimization
        to_deg = np.rad2deg

        def per_quantity_deg(table):
            return {q.key: to_deg(table[d]) for d, q in enumerate(LIMITED)}
        return json_ready({
            "task": self.task.name,
            "family": self.task.family,
            "joint_names": self.joint_names,
            "via_points_deg": to_deg(self.via_points),
            "via_times_s": self.trajectory.via_times,
            "durations_s": self.trajectory.durations,
            "total_time_s": self.trajectory.total_time,
            "feasible": self.feasible,
            "max_ratio": {q: ratios[d] for d, q in enumerate(QUANTITIES)},
            "limits": {**per_quantity_deg(self.limits.magnitudes),
                       "position_deg": {"lower": to_deg(self.limits.lower), "upper": to_deg(self.limits.upper)}},
            "max_abs": per_quantity_deg(self.figures.max_abs),
            "mean_abs": per_quantity_deg(self.figures.mean_abs),
            "position_range_deg": {"min": to_deg(self.figures.position_min), "max": to_deg(self.figures.position_max)},
            "jerk_energy_rad2_s5": self.figures.jerk_energy,
            "optimizer": {
                "requested_algorithm": self.task.optimizer["algorithm"],
                "algorithm": result.algorithm, "seed": result.seed, "evaluations": result.evaluations,
                "wall_time_s": result.wall_time_s, "objective": self.task.optimizer["objective"],
                "weights": self.task.optimizer["weights"], "time_limit_s": self.task.optimizer["time_limit"],
                "objective_value": result.objective, "bounds_s": self.task.optimizer["bounds"],
                "stop_reason": result.stop_reason, "settings": result.settings,
                "best_per_iteration": result.history,
                "refinement_starts": [asdict(start) for start in result.starts],
                "starts_agree": result.starts_agree, "solver_iterations": result.solver_iterations,
            },
            "sample_rate_hz": self.task.sample_rate_hz,
            "timings_s": self.timings_s,
            **self._robot_summary(),
        }, SUMMARY_DIGITS)

    def _robot_summary(self) -> dict:
        if self.robot is None:
            return {}
        summary: dict[str, Any] = {"robot": {"name": self.robot.name, "urdf": str(self.robot.urdf_path),
                             "tool_frame": self.robot.tool_frame, "missing_meshes": list(self.robot.missing_meshes),
                                       "limits_beyond_urdf": list(self.limits_beyond_robot)}}
        if self.robot_limits is not None:
            summary["robot_limits"] = self.robot_limits.summary()
            if self.robot_limits.torque_limit is not None:
                assert self.robot is not None
                summary["robot_limits"]["rotor_inertia_kg_m2"] = self.robot.model.armature.tolist()
                summary["robot_limits"]["bodies_without_inertia"] = bodies_without_inertia(self.robot)
        if self.ik is not None:
            assert self.robot is not None  # Cartesian waypoints need a robot
            solver = "closed form" if closed_form_solver(self.robot) is not None else "numeric"
            summary["ik"] = {"branch": self.task.ik.branch, "solver": solver, "seed": self.task.ik.seed,
                             "sequence_kept": self.branch_kept,
                             "timed_sequences_s": self.branch_times, "waypoints": [
                {"waypoint": i, "position_error_m": s.position_error, "orientation_error_rad": s.orientation_error,
                 "attempts": s.attempts, "solutions": s.solutions, "chosen_solution": s.chosen,
                 "margin_deg": s.margin_deg,
                 "joint_jump_deg": np.rad2deg(s.jump)} for i, s in enumerate(self.ik)]}
        if self.path is not None:
            options = self.task.path
            tolerances = {"tolerance_m": options.tolerance_m, "tolerance_deg": np.rad2deg(options.tolerance_rad)} \
                if options.mode == "linear" else {}  # joint mode does not follow lines: no tolerance applies
            summary["path"] = {
                "mode": options.mode, **tolerances, "rounds": self.path.rounds,
                "waypoint_via_index": self.path.waypoint_via,
                "segments": [{"from_waypoint": i, "to_waypoint": i + 1, "inserted_poses": int(inserted),
                              "max_position_deviation_m": distance, "max_orientation_deviation_deg": np.rad2deg(angle)}
                             for i, (inserted, distance, angle) in enumerate(zip(
                                 self.path.inserted, self.path.max_distance_m, self.path.max_angle_rad))]}
        return summary

    def save(self, out_dir, *, force: bool = False) -> Path:
        """Publish the outputs (``write``) in ``out_dir`` under the rules of ``planner.outputs``:
        checked and locked first, staged beside it, swapped in as one step; nothing partial on failure.

        Raises:
            OutputError: an unusable ``out_dir`` (empty, a file, someone else's files without ``force``).
        """
        with output_folder(out_dir, force=force, files=OUTPUT_FILES) as staging:
            self.write(staging)
        return Path(out_dir)

    def write(self, folder: Path, *, writers: WarmWorkers | None = None) -> None:
        """Write summary.json, trajectory.csv, coefficients.json, profiles.png and trajectory.rrd into
        the existing ``folder`` (no atomicity of its own: ``save`` provides it), with ``writers``
        (``output_writers()``, started before planning) or processes forked now. The files are the
        caller's: no marker records them as the planner's, so a later ``save`` into the folder treats
        them as any user's files (replaced only with ``force``).

        Raises:
            OutputError: ``folder`` is no existing folder, or holds one of the files already (``write``
                replaces nothing: ``save`` replaces the planner's own outputs, by its rules).
        """
        folder = absolute_path(folder, "the output folder")
        if not folder.is_dir():
            raise OutputError(f"output folder {str(folder)!r} does not exist (write needs an existing folder; save "
                              f"creates one)")
        present = [name for name in OUTPUT_FILES if os.path.lexists(folder / name)]
        if present:
            raise OutputError(f"output folder {str(folder)!r} already holds {', '.join(present)}: write replaces "
                              f"nothing; save replaces the planner's own outputs (force=True: anyone's)")
        start = time.perf_counter()
        table = TrajectoryCsv(folder / "trajectory.csv", self.trajectory, self.task.sample_rate_hz, self.joint_names,
                              self.torques_at if self.torque_limit is not None else None)
        with tempfile.TemporaryDirectory(dir=folder, prefix=".trajectory.csv.") as pieces:
            # Independent writers, each holding the GIL most of its time: side by side in processes, the
            # recording's and the figure's first (their processes prepared for them), then the CSV's pieces
            # (its own process's first), each to the first process free.
            work: list[Callable[[], None]] = [partial(self._write_recording, folder),
                                              partial(self._write_figure, folder), *table.pieces(Path(pieces))]
            try:
                if writers is None:
                    map_forked(_call, work, workers=OUTPUT_WRITERS)
                else:
                    writers.map(_call, work)
            except WorkerLost as exc:
                raise OutputError(f"cannot write the outputs: a process writing them died ({exc})") from None
            table.join(Path(pieces))
        self.timings_s["outputs"] = time.perf_counter() - start
        write_json(folder / "summary.json", self.summary(), digits=SUMMARY_DIGITS)

    def _write_recording(self, folder: Path) -> None:
        """coefficients.json and trajectory.rrd."""
        write_json(folder / "coefficients.json", coefficients_document(self.trajectory, self.joint_names),
                   value_per_line=True)
        write_recording(self, folder / "trajectory.rrd")

    def _write_figure(self, folder: Path) -> None:
        """profiles.png."""
        total = seconds_text(self.trajectory.total_time, 3)
        plot_profiles(self.trajectory, self.limits, folder / "profiles.png",
                      title=f"{self.task.name}: {self.task.family}, T = {total} s",
                      joint_names=self.joint_names, waypoint_via=self.waypoint_via,
                      torques=None if self.torque_limit is None else (self.torques_at, self.torque_limit))


#: The algorithms whose plans are timed again with the torque and tool-speed limits in the NLP when
#: those slow the kinematic optimum down, unless their setting ``polish`` turns their NLP off
#: (``retimes_in_nlp``); the others end there: they have no NLP of their own.
ROBOT_AWARE_ALGORITHMS = ("default", "nlp", "cuckoo")
#: The dense check's slow-down of the NLP's robot-aware timing above which it is timed once more with the
#: robot-aware limits tightened by it (the NLP's samples missed peaks between them by that much).
RETIMED_SLOW_DOWN = 1.01
#: The files ``PlanResult.write`` writes.
OUTPUT_FILES = ("summary.json", "trajectory.csv", "coefficients.json", "profiles.png", "trajectory.rrd")
#: Processes that write the outputs (``PlanResult.write``): one prepared for the recording and coefficients,
#: one for the figure, and one more; the CSV's pieces go to whichever is free.
OUTPUT_WRITERS = 3


def _follow_lines(robot: Robot, poses: list, sequences: list, hints: list, limits: JointLimits, seed: int,
                  follow: Callable, progress) -> tuple:
    """``follow`` the straight lines from one of the branch rules' IK sequences (``sequences``: (IK,
    via-points, rule), the kept rule's first), or from what the lines reach from one's first waypoint.

    Each rule picks a waypoint's solution by the joints' motion between waypoints, and may pick one
    that the line from the previous waypoint does not reach (the joints would have to jump on it).
    On an arm without redundancy the motion along a line is one continuous curve from its start
    configuration (away from singularities), which IK continuation finds
    (``track_from_turns``, from the first waypoint's configuration or another 2 pi turn of it): a sequence
    that it does not reach is tried only last, to name the
    failure, after each rule's sequence that it does reach and each tracked sequence (kept as
    ``tracked``, with its IK report from ``ik.described``). Hinted waypoints keep their solutions.

    Returns the path, the timing, the IK report and the kept sequence's name.

    Raises:
        IKError: where none follows the lines, the failure of the first sequence tried (in the order
            above: one the lines reach is named before a rule's that they do not).
    """
    attempts: list[tuple[np.ndarray, Any, str]] = []
    jumping: list[tuple[np.ndarray, Any, str]] = []
    tracked: list[np.ndarray] = []
    for sequence, points, rule in sequences:
        reached = None if robot.model.nv > 6 else track_from_turns(
            robot, poses, points[0], [q if hint is not None else None for q, hint in zip(points, hints)])
        if reached is None or np.abs(reached - points).max() <= JUMP_RAD:
            attempts.append((points, sequence, rule))
            continue
        progress.note(f"the {rule} rule's IK sequence picks a waypoint solution that the straight line from the one "
                      f"before does not reach")
        jumping.append((points, sequence, rule))
        tracked.append(reached)
    for reached in tracked:
        if not any(np.abs(reached - other[0]).max() <= JUMP_RAD for other in attempts):  # tried once
            attempts.append((reached, None, "tracked"))
    attempts += jumping
    failure: IKError | None = None
    for points, sequence, rule in attempts:
        try:
            path, timing = follow(points)
        except IKError as exc:
            failure = failure or exc
            name = "tracked" if rule == "tracked" else f"{rule} rule's"
            progress.note(f"the {name} IK sequence cannot follow the straight lines ({exc})")
            continue
        return path, timing, sequence if sequence is not None else described(robot, poses, points, limits, seed), rule
    assert failure is not None  # every rule's own sequence is among the attempts
    raise failure


def output_writers() -> WarmWorkers:
    """The ``OUTPUT_WRITERS`` processes of ``PlanResult.write``, forked now so that they import Rerun
    and matplotlib (about 0.3 s each) while the plan runs, rather than after it."""
    return WarmWorkers([prepare_recording, prepare_figure, None])


def _call(work: Callable[[], None]) -> None:
    work()


def retimes_in_nlp(optimizer: dict) -> bool:
    """Whether a plan by ``optimizer`` (a task's ``optimizer`` section: ``algorithm`` and its ``settings``)
    is timed again with the torque and tool-speed limits in the NLP (``ROBOT_AWARE_ALGORITHMS``)."""
    return optimizer["algorithm"] in ROBOT_AWARE_ALGORITHMS and optimizer["settings"].get("polish") is not False


#: The longest trajectory a recording holds [s]: Rerun's timeline counts whole nanoseconds in 64 bits.
MAX_RECORDED_S = 9.2e9


def check_recordable(total_time: float, *, lower_bound: bool = False,
                     slowed: RobotLimitOutcome | None = None, slowest: str = "") -> None:
    """Refuse a trajectory longer than ``MAX_RECORDED_S`` (292 years): its recording's times would
    overflow, and replay would find no samples in it. ``slowest``: what makes it this long, in words
    (``slowest_joint``), added to the message.

    Raises:
        TaskError: naming the limits (or the robot-aware limit that made it this long) and the duration.
    """
    if total_time < MAX_RECORDED_S:
        return
    key = "limits" if slowed is None or total_time <= slowed.kinematic_total_s else _binding_limit(slowed)
    raise TaskError(key, f"the trajectory would last {'at least ' if lower_bound else ''}{total_time:.4g} s"
                         f"{f' ({slowest})' if slowest else ''}, beyond the {MAX_RECORDED_S:.3g} s (292 years) that a "
                         f"recording's timeline of whole nanoseconds holds: raise the limits (or lower the duration "
                         f"bounds)")


def check_sample_count(task: Task, total_time: float, *, lower_bound: bool = False,
                       slowed: RobotLimitOutcome | None = None, out_of_time: bool = False) -> None:
    """Refuse a trajectory whose outputs at ``trajectory.sample_rate_hz`` would exceed ``MAX_SAMPLES`` samples.

    Args:
        task: the task, for its sample rate.
        total_time: the trajectory's duration [s], or (``lower_bound``) a lower bound on it.
        lower_bound: ``total_time`` is a lower bound, so that a hopeless task is refused before it is timed.
        slowed: how the robot-aware limits slowed the trajectory down, if they did: then the error
            names the limit that set the slow-down.
        out_of_time: the time limit ended the timing: then the error says it may have left the
            trajectory longer than the limits need.

    Raises:
        TaskError: naming ``trajectory.sample_rate_hz``, the duration and the sample count (or the
            robot-aware limit that made the trajectory this long).
    """
    count = total_time * task.sample_rate_hz
    if count < MAX_SAMPLES:
        return
    what = "at least" if lower_bound else "the"
    samples = (f"{task.sample_rate_hz:g} Hz over {what} {total_time:.6g} s of trajectory makes {count:.3g} samples "
               f"per output, above the cap of {MAX_SAMPLES:,}")
    if out_of_time and (slowed is None or total_time <= slowed.kinematic_total_s):
        raise TaskError("trajectory.sample_rate_hz", f"{samples}; the time limit of {task.optimizer['time_limit']:g} "
                                                     f"s (optimizer.time_limit_s) stopped the timing before it "
                                                     f"converged, which may have left the trajectory longer than the "
                                                     f"limits need: raise the time limit, lower the rate, or check "
                                                     f"the limits and duration bounds")
    if slowed is None or total_time <= slowed.kinematic_total_s:
        raise TaskError("trajectory.sample_rate_hz", f"{samples}; lower the rate or check the limits and duration "
                                                     f"bounds (they make the trajectory this long)")
    raise TaskError(_binding_limit(slowed), f"{_lengthening(slowed, total_time)}: {samples} "
                                            f"(trajectory.sample_rate_hz); raise the limit or lower the rate")


def _lengthening(slowed: RobotLimitOutcome, total_time: float) -> str:
    """How much the robot-aware limits lengthened the trajectory to ``total_time`` [s], in words."""
    kinematic = slowed.kinematic_total_s
    return (f"makes the trajectory {total_time:.4g} s long to meet it, {total_time / kinematic:.4g} times the "
            f"{kinematic:.4g} s the kinematic limits allow")


def _binding_limit(slowed: RobotLimitOutcome) -> str:
    """The task key of the robot-aware limit that set ``slowed``'s slow-down (its largest ratio after it)."""
    ratios = slowed.largest_ratios()
    keys = {"torque": "limits.torque_nm", "tool_speed": "limits.tool_speed_m_s",
            "tool_angular_speed": "limits.tool_speed_deg_s"}
    return keys[max(ratios, key=ratios.__getitem__)]


def _beyond_h_max(durations: np.ndarray, bounds: tuple[float, float] | None) -> bool:
    """Whether a duration (S,) [s] exceeds the bound h_max (beyond the exact check's tolerance)."""
    return bounds is not None and bool(bounds_exceeded(durations, (0.0, bounds[1])))


def _narrower_h_max(problem: TimingProblem, factor: float) -> TimingProblem | None:
    """``problem`` (which has duration bounds) with h_max divided by ``factor``, or None where that
    leaves it below the shortest segment allowed or no timing within the narrower bounds meets the limits."""
    assert problem.bounds is not None
    h_max = problem.bounds[1] / factor
    if h_max < problem.duration_floor:
        return None
    return _narrower(problem, problem.limits, (problem.bounds[0], h_max))


def _narrower(problem: TimingProblem, limits: JointLimits, bounds: tuple[float, float] | None) -> TimingProblem | None:
    """``problem`` with ``limits`` and duration ``bounds`` (its via-points, family, objective and least duration
    kept), or None where no timing within them meets the limits (``TimingProblem`` refuses it)."""
    try:
        return TimingProblem(problem.given_via_points, problem.family, limits, bounds=bounds,
                             objective=problem.objective_name, weights=problem.weights,
                             min_duration=problem.duration_floor)
    except PlannerError:
        return None


#: A robot re-timing that leaves a joint range by e is timed again within that side of the range narrowed by
#: this many times e (hermite7 on the PUMA paper task with a tool cap: its robot model's rounds, which move
#: the positions, ended 1.7e-6 and 1.7e-5 rad past a range, and re-timings 2.2 and 1.9 times faster than the
#: slow-down were not kept).
RANGE_NARROWING = 4.0


def _narrower_ranges(problem: TimingProblem, broken: list[Violation]) -> TimingProblem | None:
    """``problem`` with each position range a trajectory leaves (``broken``: its violations) narrowed on that
    side by ``RANGE_NARROWING`` times the excess; None where a limit other than a position is broken, or a
    via-point lies within the band given up (it must stay inside)."""
    if any(violation.order for violation in broken):
        return None
    lower, upper = problem.limits.lower.copy(), problem.limits.upper.copy()
    for violation in broken:
        band = RANGE_NARROWING * abs(violation.value - violation.limit)
        if violation.side == "lower":
            lower[violation.index] = violation.limit + band
        else:
            upper[violation.index] = violation.limit - band
    via = problem.given_via_points
    if np.any(via < lower) or np.any(via > upper):
        return None
    return _narrower(problem, problem.limits.with_overrides(lower=lower, upper=upper), problem.bounds)


def _tightened(constraints: RobotConstraints, factor: float) -> RobotConstraints:
    """``constraints`` with every robot-aware limit divided by ``factor``."""
    def divided(limit):
        return None if limit is None else limit / factor
    return replace(constraints, torque=divided(constraints.torque), tool_speed=divided(constraints.tool_speed),
                   tool_angular_speed=divided(constraints.tool_angular_speed))


def check_slowed_bounds(durations: np.ndarray, bounds: tuple[float, float] | None, slowed: RobotLimitOutcome) -> None:
    """Refuse a slow-down (torque, tool speed) that puts a segment above the duration bound h_max.

    Raises:
        TaskError: naming the robot-aware limit that set the slow-down, the segment and ``optimizer.bounds_s``.
    """
    total = float(durations.sum())
    if not _beyond_h_max(durations, bounds) or total <= slowed.kinematic_total_s:
        return
    k = int(np.argmax(durations))
    assert bounds is not None
    value, bound = numbers_apart(float(durations[k]), bounds[1])
    raise TaskError(_binding_limit(slowed), f"{_lengthening(slowed, total)}, and segment {k} {value} s long, above "
                                            f"the duration bound h_max = {bound} s (optimizer.bounds_s): raise "
                                            f"h_max or the limit")


def _seconds_by_name(name: str, value, may_be_none: bool) -> dict[str, float | None]:
    """A copy of ``value``, a mapping of names to durations [s] (finite numbers >= 0, or None where
    ``may_be_none``).

    Raises:
        InputError: naming the part ``name`` and the first entry that is none of these.
    """
    if not isinstance(value, Mapping):
        raise InputError(f"a plan result's {name} must map names to seconds, not {type(value).__name__}")
    copied: dict[str, float | None] = {}
    for key, seconds in value.items():
        if seconds is None and may_be_none:
            copied[key] = None
            continue
        if (not isinstance(key, str) or isinstance(seconds, bool) or not isinstance(seconds, (int, float, np.number))
                or not np.isfinite(seconds) or seconds < 0):
            raise InputError(f"a plan result's {name} must map names to seconds (finite numbers >= 0"
                             f"{', or None' if may_be_none else ''}), got {shown(key)}: {shown(seconds)}")
        copied[key] = float(seconds)
    return copied


def trajectory_digest(trajectory: PiecewisePolynomial) -> str:
    """The SHA-256 of a trajectory's durations, coefficients and via knots, in hex: what a plan result's
    tool path and robot-limit figures were measured on (``PlanResult.measured_on``)."""
    digest = hashlib.sha256()
    for part in (trajectory.durations, trajectory.coefficients, trajectory.via_knots):
        digest.update(np.ascontiguousarray(part).tobytes())
    digest.update(trajectory.basis.encode())
    return digest.hexdigest()


def shortest_total_time(via: np.ndarray, limits: JointLimits, task: Task) -> float:
    """A lower bound on any trajectory's duration [s] through ``via`` (n, J) [rad] in order:
    each step takes at least max_j |dq_j| / V_j, and every segment between distinct
    via-points at least the minimum segment duration (and h_min)."""
    steps = np.abs(np.diff(via, axis=0))
    distinct = int(np.count_nonzero(steps.max(axis=1) > 0))
    floor = max(task.min_segment_s, (task.optimizer["bounds"] or (0.0,))[0])
    return max(float((steps / limits.velocity).max(axis=1).sum()), distinct * floor)


def slowest_joint(via: np.ndarray, limits: JointLimits) -> str:
    """The joint whose velocity limit alone makes a trajectory through ``via`` (n, J) [rad] longest, in words:
    its name, the distance it covers (the sum of its steps), its limit and the time that takes."""
    distance = np.abs(np.diff(via, axis=0)).sum(axis=0)
    alone = distance / limits.velocity  # limits are > 0; a joint without one (inf) takes 0 s
    j = int(np.argmax(alone))
    return (f"joint {limits.names[j]} alone covers {in_degrees(distance[j], 0)} at its velocity limit of "
            f"{in_degrees(limits.velocity[j], 1)} in {alone[j]:.4g} s")


def robot_limits(robot: Robot, task: Task) -> JointLimits:
    """The robot's limits with the task's overrides; acceleration and jerk limits must exist."""
    chain = f"one per joint that moves tool frame {robot.tool_frame!r}: {', '.join(robot.joint_names)}"
    check_limit_counts(task.limits, robot.dof, f"for robot {robot.name!r} ({chain})" if robot.locked_positions
                       else f"for robot {robot.name!r}")
    if robot.placeholder_velocity and task.limits.get("velocity") is None:
        joint, key = robot.placeholder_velocity[0], f"limits.{LIMITED[0].key}"
        raise MissingLimitError(f"robot {robot.name!r} gives joint {joint} a velocity limit of 0 in its URDF (a "
                                f"placeholder: the joint could not move); give {key} in the task", joint=joint,
                                quantity=LIMITED[0].name, key=key)
    if robot.placeholder_range and task.limits.get("lower") is None:
        joint = robot.placeholder_range[0]
        raise MissingLimitError(f"robot {robot.name!r} gives joint {joint} the range [0, 0] in its URDF (a "
                                f"placeholder: the joint could not move); give limits.position_deg in the task",
                                joint=joint, quantity="position", key="limits.position_deg")
    limits = robot.limits.with_overrides(names=tuple(robot.joint_names), **task.limits)
    for quantity in LIMITED[1:]:  # acceleration and jerk; a velocity limit is optional
        missing = np.flatnonzero(~np.isfinite(getattr(limits, quantity.name)))
        if missing.size:
            joint = limits.names[missing[0]]
            raise MissingLimitError(f"robot {robot.name!r} has no {quantity.name} limit for joint {joint}; give "
                                    f"limits.{quantity.key} in the task", joint=joint, quantity=quantity.name,
                                    key=f"limits.{quantity.key}")
    return limits


def _beyond_the_robot(robot: Robot, limits: JointLimits) -> tuple[dict, ...]:
    """Where ``limits`` (the robot's with the task's overrides) allow more than the robot's own (its URDF's
    range and velocity, and its limits file's): a joint planned there may be beyond what the arm does, so the
    plan says so (the UR5's shoulder was planned to 500 deg, its URDF's range +-360 deg, without a word).
    Not the URDF's placeholders (a velocity of 0, a range of [0, 0]), which the task must replace.

    Returns:
        One record per joint and limit, for ``summary.json``: ``joint``, ``limit`` (``position_deg`` or
        ``velocity_deg_s``), and the ``task``'s and the ``robot``'s value ([lower, upper] for a range) [deg].
    """
    own, said = robot.limits, []
    for j, name in enumerate(limits.names):
        if name not in robot.placeholder_range and (limits.lower[j] < own.lower[j] or limits.upper[j] > own.upper[j]):
            said.append({"joint": name, "limit": PROFILE_QUANTITIES[0].key,
                         "task": np.rad2deg([limits.lower[j], limits.upper[j]]).tolist(),
                         "robot": np.rad2deg([own.lower[j], own.upper[j]]).tolist()})
        if name not in robot.placeholder_velocity and limits.velocity[j] > own.velocity[j]:
            said.append({"joint": name, "limit": LIMITED[0].key, "task": float(np.rad2deg(limits.velocity[j])),
                         "robot": float(np.rad2deg(own.velocity[j]))})
    return tuple(said)


def _beyond_the_robot_text(widened: dict) -> str:
    """One record of ``_beyond_the_robot`` as the progress says it."""
    if widened["limit"] == "position_deg":
        return (f"joint {widened['joint']} range [{widened['task'][0]:.6g} deg, {widened['task'][1]:.6g} deg] "
                f"(URDF [{widened['robot'][0]:.6g} deg, {widened['robot'][1]:.6g} deg])")
    return f"joint {widened['joint']} velocity {widened['task']:.6g} deg/s (URDF {widened['robot']:.6g} deg/s)"


def as_task(task) -> Task:
    """A ``Task`` from a ``Task``, a task file's path (str or path-like), or a mapping of the task
    file's schema (``parse_task``: relative URDF paths are then taken from the working directory).

    Raises:
        TaskError: anything else, or a task that does not validate.
    """
    if isinstance(task, Task):  # parsed anew: the caller's later changes to its dicts stay out of the result
        return check_task(task)
    if isinstance(task, Mapping):  # numpy values and iterators as make_task takes them
        return parse_task(plain_values(task))
    if isinstance(task, (str, os.PathLike)):
        return load_task(task)
    raise TaskError("", f"a task is a Task, a task file's path or a mapping of the task schema, "
                        f"not {type(task).__name__}")


def _check_configuration(q: np.ndarray | None, key: str, robot: Robot) -> None:
    """A task's configuration (``ik.start_deg``, a waypoint's ``hint_deg``) has one value per joint,
    each inside its joint's range (``robot.limits``, the task's overrides included)."""
    if q is None:
        return
    if len(q) != robot.dof:
        raise TaskError(key, f"must have {robot.dof} values for robot {robot.name!r}, got {len(q)}")
    violation = robot.limits.range_violation(q)
    if violation is not None:
        (j,), side, bound = violation
        value, limit = in_degrees_apart(q[j], bound, 0)
        raise TaskError(f"{key}[{j}]", f"{value} is outside the range of joint {robot.limits.names[j]} "
                                        f"({side} limit {limit})")


def _outside_bounds(problem: TimingProblem, result: OptimizationResult, worst: Violation | None,
                    stopped: str, by: str) -> InfeasibleError:
    """The error for a best timing outside ``optimizer.bounds_s`` (some duration is outside them): it
    names the segment furthest outside, the bound, and the limit that binds there (its largest ratio),
    and ``worst``, a limit the timing still breaks (a position range), if any; ``stopped`` says that the
    time limit ended the search, where it did (else ''); ``by`` names the algorithm (``optimizer_name``)."""
    assert problem.bounds is not None
    low, high = problem.bounds
    h = result.durations
    k = int(np.argmax(h / high)) if h.max() > high else int(np.argmin(h / low))
    side, bound = ("above h_max", high) if h[k] > high else ("below h_min", low)
    d, j = (int(i) for i in np.unravel_index(int(np.argmax(result.ratios)), result.ratios.shape))
    limited, limit = LIMITED[d], float(problem.limits.magnitudes[d, j])
    also = "" if worst is None else f", and in that timing {worst}"
    duration, shown_bound = numbers_apart(float(h[k]), bound)
    return InfeasibleError(f"no feasible timing found by {by}{stopped} within optimizer.bounds_s = "
                           f"[{low:g}, {high:g}] s: meeting the limits takes segment {k} {duration} s, {side} = "
                           f"{shown_bound} s, "
                           f"with joint {problem.limits.names[j]}'s {limited.name} at its limit "
                           f"{in_degrees(limit, limited.order)}{also}; widen the bounds or raise that limit"
                           + _fixed_states_hint(problem, result), joint=problem.limits.names[j], joint_index=j,
                           quantity=limited.name, value=float(result.ratios[d, j]) * limit, limit=limit)


def _fixed_states_hint(problem: TimingProblem, result: OptimizationResult) -> str:
    """For a family whose via-point states are free but were not optimized (a search without the NLP keeps
    its fixed rule: ``de``, ``pso``, ``slsqp``, ``cuckoo-paper``), that the NLP's algorithms would choose them
    (hermite7 within bounds of [0.5, 2] s: ``de`` found nothing, ``nlp`` a timing of 5.59 s); else ''."""
    if not problem.family.free_states or result.starts:  # the NLP ran (its starts), and chose them
        return ""
    return (f" (with {result.algorithm}, {problem.family.name}'s via-point velocities, accelerations and jerks "
            f"follow its fixed rule; the default, nlp and cuckoo algorithms choose them too)")


#: How near its range bound [rad] an interior via-point makes the hint of a range left name it (0.05 deg):
#: the joint must nearly stop there, which families that fix via-point velocities from the durations
#: seldom allow at many via-points at once.
NEAR_BOUND_HINT = float(np.deg2rad(0.05))


def _on_bound_hint(problem: TimingProblem, violations: list[Violation]) -> str:
    """Why a range may be left: via-points on or near a range bound (within ``NEAR_BOUND_HINT``),
    where the joint must stop or nearly so, which the family's continuity conditions fix from the
    durations (and cannot make 0 at many via-points at once), and the family whose via-point states
    are free. Empty unless a position violation and such a via-point exist, or for a family with
    free states."""
    limits, via = problem.limits, problem.given_via_points[1:-1]
    gaps = np.minimum(np.abs(via - limits.lower), np.abs(via - limits.upper))
    near = (gaps <= NEAR_BOUND_HINT) & np.isfinite(gaps)
    if problem.family.free_states or not any(v.quantity == "position" for v in violations) or not near.any():
        return ""  # free via-point states can stop there
    k, j = np.argwhere(near)[0]
    on = limits.bound_sides(via)
    where, stop = ("on a range bound", "stop") if on[near].all() else (
        f"on or within {in_degrees(NEAR_BOUND_HINT, 0)} of a range bound", "stop or nearly")
    gap = "on it" if on[k, j] else f"{in_degrees(float(gaps[k, j]), 0)} inside it"
    return (f"; {np.count_nonzero(near)} via-point values sit {where} (first: via-point {k + 1}, joint "
            f"{limits.names[j]}, {gap}), where the joint must {stop}, which the {problem.family.name} spline's "
            f"continuity conditions seldom allow at more than a few: move them inside their ranges or set "
            f"trajectory.family: hermite7, whose via-point velocities the optimizer chooses (it can stop there)")


def _resting_remedy(robot: Robot, task: Task, poses: list, limits: JointLimits, torque: np.ndarray,
                    via_index: int) -> str:
    """What to change where gravity alone breaks a torque limit at the configuration chosen for the first
    or last waypoint of a Cartesian task (``via_index`` 0 or not): another IK solution of its pose that
    the limits hold still, where one is, else the limit or the pose."""
    waypoint = 0 if via_index == 0 else len(poses) - 1
    resting, count = resting_solutions(robot, poses[waypoint], limits, partial(holds_still, robot, torque),
                                       task.ik.seed)
    if not len(resting):
        return (f"none of the {count} IK solutions of waypoint {waypoint}'s pose within the joint ranges holds still "
                f"within the limits either: raise limits.torque_nm or move the waypoint")
    hinted = task.cartesian_waypoints is not None and task.cartesian_waypoints[waypoint].hint is not None
    optimal = ", or choose ik.branch: optimal" if task.ik.branch == "continuous" and not hinted else ""
    one = len(resting) == 1
    return (f"{len(resting)} of the {count} IK solutions of waypoint {waypoint}'s pose within the joint ranges "
            f"{'holds' if one else 'hold'} still within the limits: give {'it' if one else 'one'} as "
            f"waypoints.cartesian[{waypoint}].hint_deg{':' if one else ', such as'} "
            f"{np.round(np.rad2deg(resting[0]), 4).tolist()}{optimal}")


def plan(task, *, progress: TerminalProgress | None = None) -> PlanResult:
    """Plan a task and return the result (nothing written; ``PlanResult.save`` writes it).

    Args:
        task: a ``Task``, a task file's path, or a mapping of the task file's schema (``as_task``).
        progress: stage notes and optimizer progress (default: silent).

    Raises:
        PlannerError: a bad task, an unknown robot or frame, an unreachable pose,
            an infeasible problem.
    """
    timings: dict[str, float] = {}
    start = time.perf_counter()
    task = as_task(task)
    if progress is not None and not isinstance(progress, TerminalProgress):
        raise InputError(f"progress must be a planner.progress.TerminalProgress or None, got {type(progress).__name__}")
    progress = progress or TerminalProgress("", quiet=True)
    robot, ik, alternative, torque = None, None, None, None
    widened: tuple[dict, ...] = ()
    if task.robot is not None:
        progress.note(f"loading robot {task.robot.name or task.robot.urdf}")
        robot = load_robot(task.robot.urdf, task.robot.name, task.robot.tool_frame)
        if robot.missing_meshes:
            count = len(robot.missing_meshes)
            progress.note(f"{count} mesh{'es' * (count > 1)} the URDF names {'are' if count > 1 else 'is'} not found "
                          f"(nothing is drawn for {'them' if count > 1 else 'it'}): "
                          f"{', '.join(robot.missing_meshes[:3])}{', ...' * (count > 3)}")
        limits = robot_limits(robot, task)
        widened = _beyond_the_robot(robot, limits)
        if widened:
            progress.note(f"the task's limits go beyond those of robot {robot.name!r} (its URDF's): "
                          f"{'; '.join(map(_beyond_the_robot_text, widened[:3]))}{'; ...' * (len(widened) > 3)}; "
                          f"the plan keeps to the task's (summary.json: robot.limits_beyond_urdf)")
        robot = replace(robot, limits=limits)  # IK searches the very ranges the timing enforces
        if task.robot_limits.torque is not None:  # checked now, not after IK and the timing runs
            torque = torque_limits(robot, task.robot_limits.torque)
            empty = bodies_without_inertia(robot)
            if empty:
                progress.note(f"the torques leave out the bod{'ies' if len(empty) > 1 else 'y'} moved by joint"
                              f"{'s' * (len(empty) > 1)} {', '.join(map(repr, empty))}: the URDF gives "
                              f"{'them' if len(empty) > 1 else 'it'} no mass and no inertia")
    timings["setup"] = time.perf_counter() - start

    start = time.perf_counter()
    poses = None
    if task.cartesian_waypoints is not None:
        assert robot is not None  # the task schema requires a robot for Cartesian waypoints
        _check_configuration(task.ik.start, "ik.start_deg", robot)
        for index, waypoint in enumerate(task.cartesian_waypoints):
            _check_configuration(waypoint.hint, f"waypoints.cartesian[{index}].hint_deg", robot)
        poses = [pose_from_position_quaternion(w.position, w.quaternion_xyzw) for w in task.cartesian_waypoints]
        hints = [w.hint for w in task.cartesian_waypoints]
        progress.note(f"inverse kinematics: {len(poses)} waypoints ({task.ik.branch} branch rule)")
        progress.label = f"inverse kinematics, {task.ik.branch} rule"
        waypoints_done = partial(progress.count, what="waypoints")
        rests = None if torque is None else partial(holds_still, robot, torque)
        ik = solve_waypoints(robot, poses, hints=hints, start=task.ik.start, branch=task.ik.branch, limits=limits,
                             seed=task.ik.seed, progress=waypoints_done, rests=rests)
        if task.ik.branch == "optimal":  # the timing below keeps the faster of the two rules' sequences
            progress.label = "inverse kinematics, continuous rule (the alternative sequence)"
            try:
                alternative = solve_waypoints(robot, poses, hints=hints, start=task.ik.start, branch="continuous",
                                              limits=limits, seed=task.ik.seed, progress=waypoints_done)
            except IKError:
                alternative = None
        via = np.array([solution.q for solution in ik])
        timings["ik"] = time.perf_counter() - start
    else:
        via = task.joint_waypoints
        if robot is not None and via.shape[1] != robot.dof:
            raise TaskError("waypoints.joints_deg", f"has {via.shape[1]} joints, robot {robot.name!r} has {robot.dof}")
    if robot is None:
        limits = JointLimits.create(via.shape[1], **task.limits)

    shortest = shortest_total_time(via, limits, task)
    check_recordable(shortest, lower_bound=True, slowest=slowest_joint(via, limits))
    check_sample_count(task, shortest, lower_bound=True)
    start = time.perf_counter()
    settings = task.optimizer
    # One time limit for all of the plan's timing runs (both IK sequences', every straight-line round's):
    # each runs within what is left of it, and one started after it keeps its first feasible candidate.
    deadline = time.monotonic() + settings["time_limit"]

    def time_via_points(points: np.ndarray, what: str = "") -> tuple[PiecewisePolynomial,
                                                                      tuple[TimingProblem, OptimizationResult]]:
        progress.label = f"timing {len(points)} via-points{what} ({task.family}, {settings['algorithm']})"
        if torque is not None:
            assert robot is not None
            remedy = None if poses is None else partial(_resting_remedy, robot, task, poses, limits, torque)
            check_resting_ends(robot, torque, points, remedy)
        problem = TimingProblem(points, task.family, limits, bounds=settings["bounds"],
                                objective=settings["objective"], weights=settings["weights"],
                                min_duration=task.min_segment_s)
        with time_limit(max(deadline - time.monotonic(), 0.0)):  # nested: the run's own limit cannot outlast it
            try:
                result = optimize(problem, settings["algorithm"], seed=settings["seed"], progress=progress,
                                  time_limit_s=settings["time_limit"], **settings["settings"])
            except SettingError as exc:  # one the task's size decides (``check_population``)
                raise TaskError(f"optimizer.{exc.setting}", exc.problem) from None
        try:
            trajectory = problem.trajectory(result.durations, result.knot_states)
        except InputError:  # an infeasible best whose states no spline holds (a stopped NLP's): refused below
            if result.knot_states is None or result.feasible:
                raise
            trajectory = problem.trajectory(result.durations)  # as the family's rule would time it
        found = kinematic_figures(trajectory).violations(limits)  # the trajectory built, checked once more
        cut = f", stopped by the time limit of {settings['time_limit']:g} s" if result.out_of_time else ""
        progress.note(f"{progress.label}: total time {result.total_time:.6g} s, "
                      f"{'feasible' if result.feasible and not found else 'INFEASIBLE'}{cut} "
                      f"({result.wall_time_s:.2f} s)")
        if not result.feasible or found:
            worst = max(found, key=lambda violation: violation.ratio, default=None)
            by = optimizer_name(settings["algorithm"], result.algorithm)  # "default (cuckoo)": what ran, what was kept
            stopped = (f" before the time limit of {settings['time_limit']:g} s (optimizer.time_limit_s) stopped "
                       f"it (raise or remove that limit)" if result.out_of_time else "")
            if problem.bounds is not None and bounds_exceeded(result.durations, problem.bounds):
                raise _outside_bounds(problem, result, worst, stopped, by)  # whatever else it breaks: the bounds
            reasons = ([f"largest constraint ratio {result.max_ratio:.12g} (limit 1)"]
                       if ratio_exceeded(result.max_ratio) or worst is None else []) + \
                ([str(worst)] if worst else [])  # a position alone leaves the ratio at 1: no word of it then
            raise InfeasibleError(f"no feasible timing found by {by}{stopped}; in its best timing, "
                                  f"{'; '.join(reasons)}"
                                  + _on_bound_hint(problem, found), violation=worst)
        return trajectory, (problem, result)

    def timed_or_none(points: np.ndarray, rule: str):
        """``time_via_points`` of one branch rule's IK sequence, or None where it cannot be timed."""
        try:
            return time_via_points(points, f" of the {rule} rule's IK sequence")
        except PlannerError:
            return None

    # Each kinematic optimum compared slowed down, and how (``compared_total``): the robot-limit stage below
    # starts from the kept one's rather than checking the same trajectory densely again.
    compared_met: list[tuple[PiecewisePolynomial, tuple[PiecewisePolynomial, RobotLimitOutcome]]] = []

    def compared_total(timed_rule) -> float | None:
        """The total time [s] a rule's timed sequence is compared by: the kinematic optimum's, slowed down
        uniformly to meet the torque and tool-speed limits where the task gives them (the sequence that
        is faster kinematically may swing the tool wider or the arm heavier); None where it cannot be
        timed or no slow-down meets them."""
        if timed_rule is None:
            return None
        if not task.robot_limits.given:
            return timed_rule[0].total_time
        assert robot is not None
        try:  # (the waypoint times only word a refusal, which is not kept here)
            slowed = meet_robot_limits(robot, timed_rule[0], torque, task.robot_limits.tool_speed,
                                       task.robot_limits.tool_angular_speed, timed_rule[0].via_times)
        except InfeasibleError:
            return None
        compared_met.append((timed_rule[0], slowed))
        return slowed[0].total_time

    branch_times: dict[str, float | None] = {}
    timed, kept = None, task.ik.branch if ik is not None else None
    # The via-points the comparison timed, and their timings: a straight-line round from the same
    # via-points (one that inserts no pose) reuses them, rather than timing them again after the time limit.
    compared_timings: list[tuple[np.ndarray, tuple]] = []
    # The other rule's sequence, where there is one that differs: (its IK, via-points, rule's name).
    second: tuple[list[IKSolution] | None, np.ndarray, str] | None = None
    if alternative is not None:
        other = np.array([solution.q for solution in alternative])
        if not np.allclose(other, via, rtol=0, atol=1e-9):
            mine, theirs = timed_or_none(via, "optimal"), timed_or_none(other, "continuous")
            compared_timings += [(points, done) for points, done in ((via, mine), (other, theirs)) if done is not None]
            branch_times = {"optimal": compared_total(mine), "continuous": compared_total(theirs)}
            timed, second = mine, (alternative, other, "continuous")
            ours, others = branch_times["optimal"], branch_times["continuous"]
            if others is not None and (ours is None or others < ours):
                second = (ik, via, "optimal")
                ik, via, timed, kept = alternative, other, theirs, "continuous"
    path = None
    if poses is not None and task.path.mode == "linear":
        assert robot is not None

        def follow(points: np.ndarray):
            """``follow_straight_lines`` from ``points``; where the time limit stopped some of its rounds'
            timings and the lines are not followed, the refusal names the limit: a timing stopped early keeps
            a start's shape, whose spline overshoots between the poses however many are inserted."""
            least = (task.min_segment_s, "trajectory.min_segment_s")
            if settings["bounds"] is not None and settings["bounds"][0] > task.min_segment_s:
                least = (settings["bounds"][0], "optimizer.bounds_s")
            stopped = []

            def timed(points: np.ndarray):
                trajectory, timing = next((done for compared, done in compared_timings
                                           if np.array_equal(compared, points)), None) or time_via_points(points)
                stopped.append(timing[1].out_of_time)
                return trajectory, timing
            try:
                return follow_straight_lines(robot, poses, points, timed, task.path.tolerance_m,
                                             task.path.tolerance_rad, progress.note, least)
            except IKError as exc:
                if not any(stopped):
                    raise
                raise IKError(f"the time limit of {settings['time_limit']:g} s (optimizer.time_limit_s) stopped "
                              f"{sum(stopped)} of {len(stopped)} straight-line rounds' timings before they converged, "
                              f"and a timing stopped early overshoots between the poses: raise or remove the time "
                              f"limit (the last round: {exc})", waypoint=exc.waypoint, residual=exc.residual) from None
        sequences = [(ik, via, kept)] + ([second] if second is not None else [])
        path, (problem, result), ik, kept = _follow_lines(robot, poses, sequences, hints, limits, task.ik.seed,
                                                          follow, progress)
        via = path.via_points
        trajectory = problem.trajectory(result.durations, result.knot_states)
    else:
        trajectory, (problem, result) = timed or time_via_points(via)  # the comparison's timing is reused
        if poses is not None:
            assert robot is not None
            waypoints = np.arange(len(poses))
            *_, distance, angle = tool_deviation(robot, trajectory, poses, waypoints)
            path = StraightPath(via, waypoints, np.zeros(len(poses) - 1, dtype=int), distance, angle, 1)
    timings["optimization"] = time.perf_counter() - start
    met = None
    if task.robot_limits.given:
        assert robot is not None  # the task schema requires a robot for them
        start = time.perf_counter()
        given = task.robot_limits
        progress.note("checking torques and tool speed")
        at_waypoints: np.ndarray | slice = path.waypoint_via if path is not None else slice(None)

        def meet(timed: PiecewisePolynomial) -> tuple[PiecewisePolynomial, RobotLimitOutcome]:
            return meet_robot_limits(robot, timed, torque, given.tool_speed, given.tool_angular_speed,
                                     timed.via_times[at_waypoints])
        compared = next((done for timed_before, done in compared_met if timed_before is trajectory), None)
        trajectory, met = compared if compared is not None else meet(trajectory)
        constraints = RobotConstraints(robot, torque, given.tool_speed, given.tool_angular_speed)

        def retime(nlp_limits: RobotConstraints, start_durations: np.ndarray, timing: TimingProblem = problem,
                   narrowed: bool = False):
            """The NLP's timing of ``timing`` (the kinematic problem, or one with a tighter h_max) with
            ``nlp_limits`` from ``start_durations`` (S,) [s], slowed down to meet the
            robot limits densely (``meet``), with its path; None where it cannot be kept:
            the new durations reshape the spline between via-points, so its positions may leave a range (and in
            linear mode the tool the straight lines) where the kinematic optimum's did not, or its path may need
            more than a torque limit to hold still. A timing that leaves a range is timed once more within that
            range narrowed (``_narrower_ranges``; ``narrowed``: this is that timing)."""
            with time_limit(max(deadline - time.monotonic(), 0.0)):
                retimed = problem.trajectory(*robot_refine(timing, nlp_limits, start_durations))
            try:
                candidate, candidate_met = meet(retimed)
            except InfeasibleError:
                return None
            broken = kinematic_figures(candidate).violations(limits)
            if broken:
                narrower = None if narrowed else _narrower_ranges(timing, broken)
                if narrower is None:
                    return None
                progress.note(f"the re-timing leaves a range ({broken[0]}); timing again within ranges that much "
                              f"narrower")
                return retime(nlp_limits, start_durations, narrower, narrowed=True)
            candidate_path = path
            if path is not None:  # the tool's path changed with the spline: its deviations are measured again
                assert poses is not None and robot is not None
                *_, distance, angle = tool_deviation(robot, candidate, poses, path.waypoint_via)
                if task.path.mode == "linear" and not (np.all(distance <= task.path.tolerance_m)
                                                       and np.all(angle <= task.path.tolerance_rad)):
                    return None
                candidate_path = replace(path, max_distance_m=distance, max_angle_rad=angle)
            return candidate, candidate_met, candidate_path

        if met.slow_down > 1 and retimes_in_nlp(settings) and constraints.supported:
            progress.note(f"slowed down {met.slow_down:.6g} times; timing again with the torque and tool-speed "
                          f"limits in the NLP")
            found = retime(constraints, result.durations * met.slow_down)
            if found is not None and found[1].slow_down > RETIMED_SLOW_DOWN and \
                    not _beyond_h_max(found[0].durations, settings["bounds"]):
                factor = found[1].slow_down
                progress.note(f"slowed down {factor:.6g} times, the NLP's timing missed peaks between its samples; "
                              f"timing again with the torque and tool-speed limits {factor:.6g} times tighter")
                tighter = retime(_tightened(constraints, factor), found[0].durations)
                if tighter is not None and tighter[0].total_time < found[0].total_time:
                    found = tighter
            if found is not None and _beyond_h_max(found[0].durations, settings["bounds"]):
                # The dense check slowed the NLP's timing (its samples are sparser) past h_max: once more, with
                # the robot limits tightened by that slow-down, so that the dense check needs little or none;
                # where a segment still ends on h_max, that little breaks it: then h_max tightened too.
                factor = found[1].slow_down
                progress.note(f"slowed down {factor:.6g} times, the NLP's timing breaks h_max; timing again with the "
                              f"torque and tool-speed limits {factor:.6g} times tighter")
                tighter = retime(_tightened(constraints, factor), found[0].durations)
                narrower = _narrower_h_max(problem, factor)
                if (tighter is None or _beyond_h_max(tighter[0].durations, settings["bounds"])) and narrower:
                    progress.note(f"still beyond h_max; timing again with h_max {factor:.6g} times tighter too")
                    assert narrower.bounds is not None
                    tighter = retime(_tightened(constraints, factor),
                                     np.clip(found[0].durations / factor, *narrower.bounds), narrower)
                if tighter is not None and not _beyond_h_max(tighter[0].durations, settings["bounds"]):
                    found = tighter
            if found is not None and found[0].total_time < trajectory.total_time:
                uniform_total = trajectory.total_time
                trajectory, retimed_met, path = found
                met = replace(retimed_met, uniform_total_s=uniform_total, kinematic_total_s=met.kinematic_total_s)
        check_slowed_bounds(trajectory.durations, settings["bounds"], met)
        if met.uniform_total_s is not None:
            progress.note(f"timed with the torque and tool-speed limits: {trajectory.total_time:.6g} s, where slowing "
                          f"the kinematic optimum down takes {met.uniform_total_s:.6g} s")
        elif met.slow_down > 1:
            progress.note(f"slowed down {met.slow_down:.6g} times to meet the torque and tool-speed limits")
        timings["robot_limits"] = time.perf_counter() - start
    check_recordable(trajectory.total_time, slowed=met)
    check_sample_count(task, trajectory.total_time, slowed=met, out_of_time=result.out_of_time)
    broken = continuity_breaks(trajectory, limits.names) + via_point_misses(trajectory, via, limits.names)
    if broken:  # a spline is continuous and passes its via-points by construction: this guards the construction
        first = broken[0]
        raise InfeasibleError(f"the planned trajectory fails the exact check: {first}", joint=first.joint,
                              joint_index=first.joint_index, quantity=first.quantity, value=first.value,
                              limit=first.limit)
    planned = PlanResult(task, via, limits, result, trajectory, timings, robot, ik, path, branch_times, kept, met,
                         trajectory_digest(trajectory), widened)
    exceeded = max(planned.figures.violations(limits), key=lambda violation: violation.ratio, default=None)
    if exceeded is not None:  # never returned, whatever stage let it through (each checks its own result)
        raise InfeasibleError(f"the planned trajectory fails the exact check: {exceeded}", violation=exceeded)
    return planned
