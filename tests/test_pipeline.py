import dataclasses
import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

import planner
from conftest import UR5_FAST, UR5_PICK_POSES, assert_plan_holds, clipped_walk
from planner import (
    InfeasibleError,
    InputError,
    JointLimits,
    MissingLimitError,
    PlannerError,
    TaskError,
    UnknownFrameError,
    UnknownRobotError,
    get_family,
    paper,
)
from planner.cli import main
from planner.ik import pose_from_position_quaternion
from planner.pipeline import plan
from planner.task import load_task, parse_task

ROOT = Path(__file__).resolve().parents[1]
TASKS = ROOT / "scripts" / "tasks"
PAPER_JOINT = TASKS / "puma560_paper_joint.yaml"
PAPER_CARTESIAN = TASKS / "puma560_paper_cartesian.yaml"


def test_paper_cartesian_task_recovers_table_ii():
    result = plan(TASKS / "puma560_paper_cartesian.yaml")
    np.testing.assert_allclose(np.rad2deg(result.via_points), paper.VIA_POINTS_DEG, atol=1e-6)
    assert all(s.residual <= 1e-9 for s in result.ik)
    assert result.optimization.feasible and result.trajectory.total_time < 17.5
    # The trajectory passes through the IK via-points at the via times.
    np.testing.assert_allclose(result.trajectory.evaluate(result.trajectory.via_times), result.via_points, atol=1e-9)
    summary = result.summary()
    assert summary["robot"]["tool_frame"] == "tool" and len(summary["ik"]["waypoints"]) == 8
    assert (summary["ik"]["solver"], summary["ik"]["seed"]) == ("closed form", 0)


def test_the_summary_records_the_ik_seed_and_solver(monkeypatch):
    """ik.seed was accepted and not recorded (sweep 17): the summary now gives it, and says whether the
    poses were solved in closed form (the seed then only seeds the continuous rule's restarts)."""
    import planner.pipeline as pipeline

    data = yaml.safe_load(PAPER_CARTESIAN.read_text())
    data["ik"] = {"seed": 12345}
    monkeypatch.setattr(pipeline, "closed_form_solver", lambda robot: None)  # as for an arm of another type
    summary = plan(parse_task(data, source=PAPER_CARTESIAN)).summary()
    assert (summary["ik"]["solver"], summary["ik"]["seed"]) == ("numeric", 12345)


def test_ur5_task_plans_within_its_limits():
    result = plan(TASKS / "ur5_pick_and_place.yaml")
    assert result.robot.name == "ur5" and result.optimization.feasible
    assert result.figures.violations(result.limits) == []
    for solution, waypoint in zip(result.ik, result.task.cartesian_waypoints):
        pose = result.robot.forward_kinematics(solution.q)
        np.testing.assert_allclose(pose.translation, waypoint.position, atol=1e-9)


def paper_cartesian(**changes) -> dict:
    data = yaml.safe_load((TASKS / "puma560_paper_cartesian.yaml").read_text())
    data["robot"]["urdf"] = str(ROOT / "robots" / "puma560.urdf")
    data.update(changes)
    return data


@pytest.mark.parametrize("changes, error, message", [
    ({"robot": {"name": "r2d2"}}, UnknownRobotError, "unknown robot 'r2d2'"),
    ({"robot": {"urdf": str(ROOT / "robots" / "puma560.urdf"), "tool_frame": "hand"}}, UnknownFrameError,
     "no frame 'hand'"),
    ({"robot": {"name": "ur5", "tool_frame": "tool0"}}, MissingLimitError,
     "robot 'ur5' has no acceleration limit for joint shoulder_pan_joint; give limits.acceleration_deg_s2"),
    ({"limits": {"jerk_deg_s3": [1, 2]}}, TaskError,
     r"^limits.jerk_deg_s3: must have 6 values for robot 'puma560', got 2"),
    # a tool frame that only the first joints move: the count is theirs, and the message says so (sweep 24)
    ({"robot": {"name": "ur5", "tool_frame": "forearm_link"}, "limits": {"jerk_deg_s3": [1] * 6}}, TaskError,
     r"^limits.jerk_deg_s3: must have 3 values for robot 'ur5' \(one per joint that moves tool frame "
     r"'forearm_link': shoulder_pan_joint, shoulder_lift_joint, elbow_joint\), got 6"),
    ({"robot": {"name": "ur5", "tool_frame": "shoulder_link"}, "limits": {"jerk_deg_s3": [1] * 6}}, TaskError,
     r"^limits.jerk_deg_s3: must have 1 value for robot 'ur5' \(one per joint that moves tool frame "
     r"'shoulder_link': shoulder_pan_joint\), got 6"),
])
def test_robot_task_errors(changes, error, message):
    with pytest.raises(error, match=message):
        plan(parse_task(paper_cartesian(**changes)))


@pytest.mark.parametrize("waypoint, message", [
    ({"xyz_m": [0, 0]}, r"waypoints.cartesian\[0\].xyz_m: must have 3 values"),
    ({"xyz_m": [0, 0, 1]}, r"waypoints.cartesian\[0\]: needs exactly one of rpy_deg or quat_xyzw"),
    ({"xyz_m": [0, 0, 1], "quat_xyzw": [0, 0, 0, 2]}, r"quat_xyzw: must be a unit quaternion"),
    ({"xyz_m": [0, 0, 1], "rpy_deg": [0, 0, 0], "grip": 1}, r"cartesian\[0\].grip: unknown key"),
])
def test_bad_cartesian_waypoints(waypoint, message):
    data = paper_cartesian()
    data["waypoints"]["cartesian"][0] = waypoint
    with pytest.raises(TaskError, match=message):
        parse_task(data)


def test_cartesian_without_robot_and_missing_urdf(tmp_path):
    data = paper_cartesian()
    del data["robot"]
    with pytest.raises(TaskError, match="^robot: is required for cartesian waypoints"):
        parse_task(data)
    with pytest.raises(TaskError, match=r"^robot.urdf: file not found: nowhere.urdf"):
        parse_task(paper_cartesian(robot={"urdf": "nowhere.urdf"}))


def test_rpy_and_quaternion_waypoints_agree():
    task = parse_task(paper_cartesian(waypoints={"cartesian": [
        {"xyz_m": [0.4, 0, 0.5], "rpy_deg": [30, -20, 75]},
        {"xyz_m": [0.4, 0, 0.5], "rpy_deg": [180, 0, 90]}]}))
    for waypoint, rpy in zip(task.cartesian_waypoints, ([30, -20, 75], [180, 0, 90])):
        expected = pin.rpy.rpyToMatrix(*np.deg2rad(rpy))
        np.testing.assert_allclose(pose_from_position_quaternion(waypoint.position, waypoint.quaternion_xyzw).rotation,
                                   expected, atol=1e-12)


def test_joint_task_with_robot_checks_ranges_and_joint_count():
    data = yaml.safe_load((TASKS / "puma560_paper_joint.yaml").read_text())
    data["robot"] = {"urdf": str(ROOT / "robots" / "puma560.urdf"), "tool_frame": "tool"}
    data["waypoints"]["joints_deg"][3][1] = -230
    with pytest.raises(InfeasibleError, match="via-point 3 puts joint joint2 at -230 deg, outside its lower limit "
                                              "-225 deg"):
        plan(parse_task(data))
    data["waypoints"]["joints_deg"] = [row[:5] for row in data["waypoints"]["joints_deg"]]
    del data["limits"]
    with pytest.raises(TaskError, match="has 5 joints, robot 'puma560' has 6"):
        plan(parse_task(data))


def test_unreachable_pose_exits_2_with_one_line(tmp_path, capsys):
    data = paper_cartesian()
    data["waypoints"]["cartesian"][2] = {"xyz_m": [3.0, 0.0, 1.0], "rpy_deg": [0, 0, 0]}
    task = tmp_path / "far.yaml"
    task.write_text(yaml.safe_dump(data))
    assert main(["plan", str(task), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: waypoint 2: pose not reached") and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("path", sorted(TASKS.glob("*.yaml")), ids=lambda path: path.stem)
def test_every_bundled_task_plans_within_its_limits(path):
    """Each task file the project ships (a new one too) plans, and its result holds every limit by an
    independent dense check (``assert_plan_holds``), not only loads under its name."""
    task = load_task(path)
    assert task.name == path.stem
    assert_plan_holds(plan(task))


@pytest.mark.parametrize("change, message", [
    ({"trajectory": {"sample_rate_hz": 1e5}}, r"100000 Hz over the 17.3128 s of trajectory makes 1.73e\+06 samples"),
    ({"limits": {"velocity_deg_s": [1e-4] * 6}}, r"100 Hz over at least [\d.e+]+ s of trajectory makes"),
    ({"limits": {"acceleration_deg_s2": [1e-5] * 6}}, r"100 Hz over the [\d.e+]+ s of trajectory makes"),
])
def test_too_many_samples_are_refused_naming_the_key(change, message):
    data = yaml.safe_load(PAPER_JOINT.read_text())
    data.pop("optimizer", None)  # no duration bounds: the limits alone set the length
    for section, values in change.items():
        data.setdefault(section, {}).update(values)
    task = parse_task(data, name="long")
    with pytest.raises(TaskError, match=r"^trajectory\.sample_rate_hz: " + message + r" .* above the cap"):
        plan(task)


@pytest.mark.parametrize("branch", ["optimal", "continuous"])
def test_ik_searches_the_task_position_ranges(branch):
    """A task range that excludes the UR5's usual wrist solution at the place pose: IK must find
    the flipped wrist inside it instead of a solution the timing then rejects."""
    data = yaml.safe_load((TASKS / "ur5_pick_and_place.yaml").read_text())
    data["ik"] = {"branch": branch}
    ranges = [[-360, 360], [-360, 360], [-180, 180], [-360, 360], [-360, 360], [-250, -100]]
    data["limits"]["position_deg"] = ranges
    result = plan(parse_task(data))
    low, high = np.deg2rad(np.array(ranges)).T
    assert np.all((result.via_points >= low) & (result.via_points <= high))
    assert np.all(result.figures.position_min >= low - 1e-9) and np.all(result.figures.position_max <= high + 1e-9)
    for solution, waypoint in zip(result.ik, result.task.cartesian_waypoints):
        reached = result.robot.forward_kinematics(solution.q)
        np.testing.assert_allclose(reached.translation, waypoint.position, atol=1e-9)


def test_summary_says_which_rule_sequence_was_planned(monkeypatch):
    """The `optimal` rule's sequence made slow on purpose (a full turn of the base joint on the way
    to the place poses): the faster `continuous` sequence must be planned and the summary must say so."""
    import dataclasses

    import planner.pipeline as pipeline
    real = pipeline.solve_waypoints

    def slowed(robot, poses, **options):
        solutions = real(robot, poses, **options)
        if options["branch"] != "optimal":
            return solutions
        turned = []
        for s in solutions:
            q = s.q.copy()
            if q[0] > 0:
                q[0] -= 2 * np.pi  # the same pose, the long way round
            turned.append(dataclasses.replace(s, q=q))
        return turned
    monkeypatch.setattr(pipeline, "solve_waypoints", slowed)
    result = plan(TASKS / "ur5_pick_and_place.yaml")
    summary = result.summary()["ik"]
    times = summary["timed_sequences_s"]
    assert times["continuous"] < times["optimal"] and summary["sequence_kept"] == "continuous"
    assert result.trajectory.total_time == pytest.approx(times["continuous"])
    assert result.via_points[:, 0].min() > -np.pi  # not the slowed sequence (its base joint passes -320 deg)


def test_summary_says_optimal_when_it_is_faster():
    summary = plan(TASKS / "ur5_pick_and_place.yaml").summary()["ik"]
    times = summary["timed_sequences_s"]
    assert summary["sequence_kept"] == min(times, key=times.get) == "optimal"


def test_summary_reports_each_waypoints_margin_to_the_ranges():
    result = plan(TASKS / "ur5_pick_and_place.yaml")
    waypoints = result.summary()["ik"]["waypoints"]
    for entry, q in zip(waypoints, result.via_points[result.waypoint_via]):
        independent = np.rad2deg(np.minimum(q - result.limits.lower, result.limits.upper - q)).min()
        assert entry["margin_deg"] == pytest.approx(independent, abs=1e-9)


@pytest.mark.parametrize("change", [
    {"joint_waypoints": np.array([1.0, 2.0])}, {"joint_waypoints": np.array([["a", "b"], ["c", "d"]])},
    {"joint_waypoints": [[0.0, 1.0], [1.0, 2.0]]}, {"joint_waypoints": None}, {"joint_waypoints": np.zeros((3, 0))},
    {"joint_waypoints": np.array([[0.0, np.nan], [1.0, 2.0]])}, {"limits": {"snap": np.ones(6)}},
    {"limits": {"velocity": np.ones(3)}}, {"sample_rate_hz": "100"}, {"sample_rate_hz": -5.0}, {"optimizer": {}},
    {"family": "septic"}, {"name": 7}, {"min_segment_s": 0.0},
])
def test_a_hand_made_task_gets_the_task_file_errors(change):
    """From Python, plan() raises only PlannerError subclasses, also for a Task built by hand."""
    import dataclasses
    task = dataclasses.replace(load_task(PAPER_JOINT), **change)
    with pytest.raises(PlannerError):
        plan(task)


def test_the_time_limit_keeps_the_best_timing_says_so_and_saves_it(tmp_path):
    data = yaml.safe_load(PAPER_JOINT.read_text())
    data["optimizer"] = {"algorithm": "cuckoo", "nests": 50, "iterations": 100_000, "time_limit_s": 0.5}
    result = plan(parse_task(data, name="limited"))
    result.save(tmp_path / "out")  # the run's settings, not its progress display, are recorded
    optimizer = json.loads((tmp_path / "out" / "summary.json").read_text())["optimizer"]
    assert optimizer["stop_reason"] == "time limit of 0.5 s reached"
    assert optimizer["settings"]["nests"] == 50 and optimizer["settings"]["iterations"] == 100_000
    assert {"nests", "iterations"} < set(optimizer["settings"]) and "progress" not in optimizer["settings"]
    assert result.summary()["feasible"] and len(optimizer["best_per_iteration"]) < 100_000


@pytest.mark.parametrize("where, value, message", [
    ("start", [0, 0, 0, 0, 0, 900], r"^ik\.start_deg\[5\]: 900 deg is outside the range of joint \w+ \(upper limit "),
    ("start", [0, -400, 0, 0, 0, 0], r"^ik\.start_deg\[1\]: -400 deg is outside the range of joint \w+ \(lower limit "),
    ("start", [0, 0, 0], r"^ik\.start_deg: must have 6 values for robot 'puma560', got 3"),
    ("hint", [10, 15, 45, 5, 10, 300], r"^waypoints\.cartesian\[2\]\.hint_deg\[5\]: 300 deg is outside the range "),
    ("hint", [10, 15, 45, 5], r"^waypoints\.cartesian\[2\]\.hint_deg: must have 6 values"),
])
def test_start_and_hints_outside_the_ranges_name_key_joint_and_bound(where, value, message):
    data = yaml.safe_load(PAPER_CARTESIAN.read_text())
    if where == "start":
        data["ik"] = {"start_deg": value}
    else:
        data["waypoints"]["cartesian"][2]["hint_deg"] = value
    with pytest.raises(TaskError, match=message):
        plan(parse_task(data, source=PAPER_CARTESIAN))


def test_a_urdf_velocity_limit_of_zero_is_a_placeholder_the_task_must_replace(tmp_path):
    robots = ROOT / "robots"
    urdf = (robots / "puma560.urdf").read_text()
    assert urdf.count('velocity="1.658062789"') == 1
    (tmp_path / "puma560.urdf").write_text(urdf.replace('velocity="1.658062789"', 'velocity="0"'))
    (tmp_path / "puma560.limits.yaml").write_text((robots / "puma560.limits.yaml").read_text())
    data = yaml.safe_load(PAPER_JOINT.read_text())
    data["robot"] = {"urdf": str(tmp_path / "puma560.urdf"), "tool_frame": "tool"}
    data.pop("limits", None)
    with pytest.raises(MissingLimitError, match=r"gives joint joint2 a velocity limit of 0 in its URDF .* give "
                                                r"limits\.velocity_deg_s in the task") as caught:
        plan(parse_task(data))
    assert (caught.value.joint, caught.value.quantity, caught.value.key) == ("joint2", "velocity",
                                                                             "limits.velocity_deg_s")
    data["limits"] = {"velocity_deg_s": [100] * 6}
    assert plan(parse_task(data)).summary()["feasible"]


def test_a_urdf_range_of_zero_is_a_placeholder_the_task_must_replace():
    """example-robot-data's double pendulums write <limit lower="0" upper="0" velocity="0"/>: the range
    was refused as empty at load, before the task's position_deg could override it (sweep 20)."""
    task = {"version": 1, "robot": {"name": "double_pendulum_simple", "tool_frame": "link3"},
            "waypoints": {"joints_deg": [[0, 0], [40, -20], [90, 10]]},
            "limits": {"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120], "jerk_deg_s3": [600, 600]}}
    with pytest.raises(MissingLimitError, match=r"gives joint joint1 the range \[0, 0\] in its URDF \(a placeholder: "
                                                r"the joint could not move\); give limits\.position_deg in the task"):
        plan(task)
    result = plan({**task, "limits": {**task["limits"], "position_deg": [[-90, 120], [-45, 45]]}})
    assert_plan_holds(result)
    np.testing.assert_allclose(np.rad2deg([result.limits.lower, result.limits.upper]), [[-90, -45], [120, 45]])


def test_summary_feasible_is_the_exact_check_of_the_planned_limits():
    from dataclasses import replace
    result = plan(PAPER_JOINT)
    assert result.summary()["feasible"] is True
    figures = result.figures
    for order, quantity in enumerate(("velocity", "acceleration", "jerk")):
        # a limit 0.1 % below the trajectory's exact maximum of one joint: the summary must say so
        j = int(np.argmax(figures.max_abs[order] / getattr(result.limits, quantity)))
        values = getattr(result.limits, quantity).copy()
        values[j] = figures.max_abs[order, j] * 0.999
        tighter = replace(result, limits=result.limits.with_overrides(**{quantity: values}))
        assert tighter.summary()["feasible"] is False


def test_a_range_left_next_to_via_points_on_its_bounds_says_why():
    via, limits = clipped_walk(16, 17)
    on_bound = np.argwhere(limits.bound_sides(via)[1:-1])
    task = {"version": 1, "name": "clipped", "waypoints": {"joints_deg": np.rad2deg(via).tolist()},
            "limits": {"velocity_deg_s": np.rad2deg(limits.velocity).tolist(),
                       "acceleration_deg_s2": np.rad2deg(limits.acceleration).tolist(),
                       "jerk_deg_s3": np.rad2deg(limits.jerk).tolist(),
                       "position_deg": np.rad2deg(np.vstack((limits.lower, limits.upper))).T.tolist()}}
    # the algorithm the task asked for (here the default), and the one whose best timing it reports
    with pytest.raises(InfeasibleError, match=rf"^no feasible timing found by default \((cuckoo|nlp)\); in its best "
                                              rf"timing, .*position .* is (below|above) its (lower|upper) limit .*; "
                                              rf"{len(on_bound)} via-point values sit on a range bound \(first: "
                                              rf"via-point {on_bound[0][0] + 1}, joint joint{on_bound[0][1] + 1}, "
                                              rf"on it\)"
                                              rf".* or set trajectory.family: hermite7"):
        plan(parse_task(task))


def test_the_family_the_on_bound_hint_offers_plans_what_hybrid_cannot():
    """Two joints rest on a range bound at the one interior via-point, coming from and going to
    different distances: hybrid cannot stop both there (its knot velocity there is c0(h) D0 + c1(h) D1,
    linear in the joint's steps D0, D1 with the same c0, c1 > 0 for every joint, and two joints with
    different D1 / D0 would need c0 = c1 = 0), so it leaves the range; the message offers hermite7,
    and hermite7 (free via-point velocities) plans it within every limit, by dense sampling."""
    limits = paper.paper_limits()
    upper = np.array([90.0, 45.0, 180.0, 180.0, 180.0, 180.0])
    via = [[0.0] * 6, [90.0, 45.0, 10.0, 10.0, 10.0, 10.0], [30.0, -40.0, 20.0, 20.0, 20.0, 20.0]]
    task = {"version": 1, "name": "on bounds", "waypoints": {"joints_deg": via},
            "limits": {"velocity_deg_s": np.rad2deg(limits.velocity).tolist(),
                       "acceleration_deg_s2": np.rad2deg(limits.acceleration).tolist(),
                       "jerk_deg_s3": np.rad2deg(limits.jerk).tolist(),
                       "position_deg": np.column_stack((np.full(6, -180.0), upper)).tolist()}}
    with pytest.raises(InfeasibleError, match="or set trajectory.family: hermite7"):
        plan(parse_task(task))
    result = plan(parse_task({**task, "trajectory": {"family": "hermite7"}}))
    assert result.summary()["feasible"] is True
    assert_plan_holds(result)


def near_bound_task(margin_deg: float, family: str) -> dict:
    """Three joints whose interior via-points sit ``margin_deg`` inside a range bound each."""
    return {"version": 1, "name": "near bounds",
            "waypoints": {"joints_deg": [[0, 0, 0], [30, -20, 10], [10, 25, -5], [40, 0, 20]]},
            "limits": {"velocity_deg_s": [60] * 3, "acceleration_deg_s2": [120] * 3, "jerk_deg_s3": [600] * 3,
                       "position_deg": [[-margin_deg, 40 + margin_deg], [-20 - margin_deg, 25 + margin_deg],
                                        [-5 - margin_deg, 20 + margin_deg]]},
            "trajectory": {"family": family}}


@pytest.mark.parametrize("margin_deg", [1e-7, 2e-6, 5e-6])
def test_hermite7_stops_a_joint_just_inside_its_bound_as_on_it(margin_deg):
    """Via-points 1.7e-9 .. 8.7e-8 rad inside their bounds rest there like those on them (their
    velocity left free, the rounds did not settle and the task was refused): the plan is the one
    with the via-points on the bounds, which lies within these wider ranges."""
    on = plan(parse_task(near_bound_task(0.0, "hermite7")))
    inside = plan(parse_task(near_bound_task(margin_deg, "hermite7")))
    assert inside.summary()["feasible"] is True
    assert_plan_holds(inside)
    assert inside.trajectory.total_time == pytest.approx(on.trajectory.total_time, rel=1e-6)


def test_the_on_bound_hint_names_via_points_near_a_bound_and_how_far_inside():
    with pytest.raises(InfeasibleError, match=r"; 3 via-point values sit on or within 0.05 deg of a range bound "
                                              r"\(first: via-point 1, joint joint2, 1e-05 deg inside it\), where the "
                                              r"joint must stop or nearly, .* or set trajectory.family: hermite7"):
        plan(parse_task(near_bound_task(1e-5, "hybrid")))


def test_an_infeasible_optimum_names_its_worst_violation_in_text_and_attributes(monkeypatch):
    import dataclasses

    import planner.pipeline as pipeline
    real = pipeline.optimize

    def too_fast(problem, *args, **kwargs):  # an optimizer that returned a timing 20 times too fast
        result = real(problem, *args, **kwargs)
        return dataclasses.replace(result, durations=result.durations / 20, feasible=False,
                                   ratios=result.ratios * 20 ** np.arange(1, 4)[:, None])

    monkeypatch.setattr(pipeline, "optimize", too_fast)
    data = yaml.safe_load(PAPER_JOINT.read_text())
    data.pop("optimizer")
    with pytest.raises(InfeasibleError, match=r"no feasible timing found by .*; joint joint\d (jerk|acceleration) "
                                              r".* exceeds its limit") as caught:
        plan(parse_task(data, name="fast"))
    error = caught.value
    assert error.quantity in ("acceleration", "jerk") and 0 <= error.joint_index < 6 and abs(error.value) > error.limit
    assert error.joint == f"joint{error.joint_index + 1}" and f"joint {error.joint} {error.quantity}" in str(error)


def _two_joint_problem():
    from planner.timing import TimingProblem
    return TimingProblem([[0.0, 0.0], [1.0, 0.5]], "hybrid", JointLimits.create(2, velocity=[1, 1], jerk=[5, 5]))


@pytest.mark.parametrize("call, said", [
    (lambda: planner.make_task(poses=pin.SE3.Identity(), robot={"name": "ur5"}), "poses must be a list of tool poses"),
    (lambda: planner.make_task(poses=5, robot={"name": "ur5"}), "poses must be a list of tool poses"),
    (lambda: planner.pose_entry(type("Pose", (), {"translation": [0, 0, 0], "rotation": [[1, 0], [0, 1]]})()),
     "a pose must be a pinocchio.SE3, got Pose"),
    (lambda: planner.pose_entry(pin.SE3.Identity(), xyz_m=[1, 2, 3]),
     "waypoints.cartesian: give either a pose or xyz_m with an orientation, not both (a pose and xyz_m)"),
    (lambda: planner.pose_entry(pin.SE3.Identity(), rpy_deg=[0, 0, 90], quat_xyzw=[0, 0, 0, 1], where="w[2]"),
     "w[2]: give either a pose or xyz_m with an orientation, not both (a pose and rpy_deg, quat_xyzw)"),
    (lambda: __import__("planner.timing").timing.TimingProblem([[0.0], [1.0]], 5, JointLimits.create(1)),
     "family must be a family's name"),
    (lambda: __import__("planner.timing").timing.TimingProblem([[0.0], [1.0]], "cubic", {"velocity": [1]}),
     "limits must be a JointLimits"),
    (lambda: __import__("planner.timing").timing.optimize("problem"), "optimize takes a TimingProblem first, got str"),
    (lambda: JointLimits.create(10**12), "the joint count must be a whole number from 1 to 10000"),
    (lambda: JointLimits.create(2).range_violation("ab"), "positions must be numeric"),
    (lambda: JointLimits.create(2).range_violation([0.0, 1.0, 2.0]), "positions hold 3 values per configuration"),
    (lambda: planner.Robot.from_example_robot_data("ur5").forward_kinematics([0, 0]),
     "joint positions must be 6 values for robot"),
    (lambda: planner.kinematic_figures(_two_joint_problem().trajectory([1.0, 1.0, 1.0])).violations(None),
     "limits must be a JointLimits for 2 joints, got NoneType"),
    (lambda: planner.plan(planner.make_task(joints_deg=[[0], [10]], limits={"velocity_deg_s": [10]})).torques_at([0.0]),
     "has no robot: torques need one"),
    (lambda: planner.plan(planner.make_task(joints_deg=[[0], [10]], limits={"velocity_deg_s": [10]}), progress=5),
     "progress must be a planner.progress.TerminalProgress or None, got int"),
])
def test_public_calls_with_values_of_the_wrong_kind_raise_named_planner_errors(call, said):
    with pytest.raises(planner.PlannerError) as caught:
        call()
    assert said in str(caught.value) and "\n" not in str(caught.value)


def test_write_into_a_folder_that_does_not_exist_is_an_output_error(tmp_path):
    result = plan(planner.make_task(joints_deg=[[0, 0], [40, -20]], limits={"velocity_deg_s": [60, 60]}))
    with pytest.raises(planner.OutputError, match="does not exist"):
        result.write(tmp_path / "not" / "there")
    assert not (tmp_path / "not").exists()


def test_a_family_with_free_states_outside_the_duration_bounds_names_the_bound_and_the_binding_limit():
    """hermite7 has no up-front h_max check (its free states may meet limits the fixed rule cannot): when
    no timing within the bounds meets the limits, the error said only "largest constraint ratio 1 (limit 1)"."""
    task = planner.make_task(joints_deg=[[0, 0], [40, -20], [90, 10]],
                             limits={"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120],
                                     "jerk_deg_s3": [600, 600]},
                             trajectory={"family": "hermite7"}, optimizer={"bounds_s": [1.1, 1.1]})
    # (no joint provably needs longer than 1.1 s between two via-points: pair_lower_bounds)
    with pytest.raises(InfeasibleError, match=r"within optimizer.bounds_s = \[1.1, 1.1\] s: meeting the limits takes "
                                              r"segment \d [0-9.]+ s, above h_max = 1.1 s, with joint joint\d's "
                                              r"(velocity|acceleration|jerk) at its limit") as caught:
        plan(task)
    error = caught.value
    assert error.quantity in ("velocity", "acceleration", "jerk") and error.joint_index in (0, 1)
    assert error.joint == f"joint{error.joint_index + 1}"
    assert f"with joint {error.joint}'s {error.quantity}" in str(error)
    assert error.value == pytest.approx(error.limit, rel=1e-6)


def test_a_writer_killed_from_outside_is_an_output_error_and_nothing_is_published(tmp_path):
    import os
    import signal

    from planner.concurrency import WarmWorkers
    from planner.outputs import output_folder
    from planner.pipeline import OUTPUT_FILES, OUTPUT_WRITERS

    result = plan(PAPER_JOINT)
    with WarmWorkers([None] * OUTPUT_WRITERS) as writers:
        os.kill(writers._children[2][0].pid, signal.SIGKILL)
        with pytest.raises(planner.OutputError,
                           match=r"^cannot write the outputs: a process writing them died \(.*exit code -9\)\)$"):
            with output_folder(tmp_path / "out", files=OUTPUT_FILES) as staging:
                result.write(staging, writers=writers)
    assert list(tmp_path.iterdir()) == []  # no staging folder, no half-written output


def test_the_summary_is_the_summary_json_document(tmp_path):
    """summary() gives plain JSON values, as written: json.dumps took numpy arrays for an error."""
    result = plan(parse_task({"version": 1, "name": "two", "waypoints": {"joints_deg": [[0, 0], [40, -20]]},
                              "limits": {"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120],
                                         "jerk_deg_s3": [600, 600]}}))
    result.save(tmp_path / "out")
    written = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert json.loads(json.dumps(result.summary())) == written
    assert written["limits"]["position_deg"] == {"lower": [None, None], "upper": [None, None]}  # no ranges: null


TWO_JOINTS = {"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120], "jerk_deg_s3": [600, 600]}


def test_a_task_cannot_be_changed_after_planning():
    """The Task's dicts were the result's: setting bounds and the objective on it afterwards made the
    summary report them, not what was planned (sweep 11), and the result's own task could still be changed
    (``result.task.optimizer["algorithm"] = "bogus"``, sweep 26). A Task's limits and optimizer (and its
    settings) are read-only mappings; a changed copy is a new Task, and the result stays as planned."""
    import dataclasses

    task = planner.make_task(joints_deg=[[0, 0], [40, -20], [90, 10]], limits=TWO_JOINTS,
                             optimizer={"bounds_s": [0.2, 3.0]})
    result = plan(task)
    before = result.summary()["optimizer"]
    for mapping in (task.optimizer, task.limits, task.optimizer["settings"], result.task.optimizer,
                    result.task.limits):
        with pytest.raises(TypeError, match="cannot be changed: make a new one"):
            mapping["bounds"] = (9.0, 10.0)
        with pytest.raises(TypeError, match="cannot be changed"):
            mapping.update(objective="time-jerk")
    changed = dataclasses.replace(task, optimizer={**task.optimizer, "bounds": (9.0, 10.0)})
    assert changed.optimizer["bounds"] == (9.0, 10.0) and task.optimizer["bounds"] == (0.2, 3.0)
    assert result.summary()["optimizer"] == before and before["bounds_s"] == [0.2, 3.0]
    assert result.trajectory.durations.max() <= 3.0 + 1e-12


def test_a_mapping_takes_what_make_task_takes():
    """numpy arrays and scalars, and a generator of rows, in a mapping given to ``plan`` (each was
    refused as 'at least 2 joint vectors' or 'unsupported version np.int64(1)'); same plan as make_task's."""
    rows = np.array([[0, 0], [40, -20], [90, 10]])
    expected = plan(planner.make_task(joints_deg=rows, limits=TWO_JOINTS)).trajectory.total_time
    for document in ({"version": 1, "waypoints": {"joints_deg": rows}, "limits": TWO_JOINTS},
                     {"version": np.int64(1), "waypoints": {"joints_deg": rows.tolist()}, "limits": TWO_JOINTS},
                     {"version": 1, "waypoints": {"joints_deg": (row for row in rows.tolist())}, "limits": TWO_JOINTS}):
        assert plan(document).trajectory.total_time == pytest.approx(expected, rel=1e-12)


def test_write_puts_the_csv_pieces_together_in_order_and_leaves_only_the_outputs(tmp_path, monkeypatch):
    """The CSV's pieces are written by several processes side by side (in any order) and joined under
    the header: the file is the trajectory's samples, row for row, and nothing but the five outputs is
    left beside the user's own file."""
    import planner.export as export
    from planner.export import read_trajectory_csv
    from planner.pipeline import OUTPUT_FILES

    monkeypatch.setattr(export, "CSV_PIECE_ROWS", 13)  # many pieces, a ragged last one
    result = plan(planner.make_task(joints_deg=[[0, 0], [40, -20], [90, 10]], limits=TWO_JOINTS))
    (tmp_path / "mine.txt").write_text("mine")
    result.write(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(OUTPUT_FILES + ("mine.txt",))
    times, values = read_trajectory_csv(tmp_path / "trajectory.csv")
    expected_times, expected = result.trajectory.sample(result.task.sample_rate_hz)
    assert len(times) > 10 * 13
    np.testing.assert_allclose(times, expected_times, rtol=1e-12)
    np.testing.assert_allclose(values, expected, rtol=1e-8, atol=1e-9)


def test_write_replaces_nothing_and_the_results_arrays_are_read_only(tmp_path):
    """``write`` (public) replaced a user's summary.json in an existing folder, where ``save`` refuses
    it; the via-points and a Cartesian plan's path arrays were writable, and the summary read them."""
    result = plan(planner.make_task(joints_deg=[[0, 0], [40, -20], [90, 10]], limits=TWO_JOINTS))
    (tmp_path / "summary.json").write_text("mine")
    with pytest.raises(planner.OutputError, match=r"already holds summary.json: write replaces nothing"):
        result.write(tmp_path)
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]
    assert (tmp_path / "summary.json").read_text() == "mine"
    with pytest.raises(ValueError, match="read-only"):
        result.via_points[0, 0] = 1.0
    with pytest.raises(planner.OutputError, match="force must be True or False, not 'no'"):
        result.save(tmp_path, force="no")
    assert (tmp_path / "summary.json").read_text() == "mine"
    cartesian = plan(load_task(TASKS / "ur5_pick_and_place.yaml"))
    for array in (cartesian.via_points, cartesian.path.via_points, cartesian.path.max_distance_m,
                  cartesian.path.waypoint_via):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 123


def test_a_trajectory_the_exact_check_fails_is_never_returned_or_written(tmp_path, monkeypatch):
    """Whatever the optimizer reported, the trajectory built is checked exactly once more: one that
    exceeds a limit is refused with the violation named, and nothing is written."""
    from planner.timing import TimingProblem

    built = TimingProblem.trajectory
    monkeypatch.setattr(TimingProblem, "trajectory", lambda self, *args: built(self, *args).slowed(0.999))
    document = {"version": 1, "name": "faster", "waypoints": {"joints_deg": [[0, 0], [40, -20], [90, 10]]},
                "limits": {"velocity_deg_s": [50, 50], "acceleration_deg_s2": [100, 100], "jerk_deg_s3": [500, 500]}}
    with pytest.raises(InfeasibleError, match=r"joint joint\d \w+ [\d.]+ deg/s\S* exceeds its limit") as caught:
        plan(document)
    assert caught.value.value is not None and abs(caught.value.value) > caught.value.limit
    (tmp_path / "task.yaml").write_text(yaml.safe_dump(document))
    assert main(["plan", str(tmp_path / "task.yaml"), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    assert not (tmp_path / "out").exists()


def test_ranges_the_nlp_would_end_a_hair_outside_plan():
    """Ranges half a degree around the via-points: IPOPT's relaxed bounds left both starts 1.3e-9 rad
    beyond a range (past the exact check's 1e-9) and the task was refused; its bounds now hold exactly."""
    task = planner.make_task(
        name="tight_ranges", trajectory={"family": "cubic"}, optimizer={"algorithm": "nlp"},
        joints_deg=[[25.030066391571133, 7.753575269460626, 0.8470587959708311],
                    [24.842472515181388, -7.395529408899524, -28.445299671478818],
                    [6.386601154300028, 4.126397844010828, -46.40889623225911],
                    [-1.4412202095675717, -25.649547632864614, -26.606032444154373]],
        limits={"velocity_deg_s": [14.27121934089908, 18.51822278310826, 75.91579667892603],
                "acceleration_deg_s2": [58.16827901330455, 186.51998400896062, 91.11203576359559],
                "jerk_deg_s3": [409.8797107382672, 43.37539148989955, 204.98200276454855],
                "position_deg": [[-1.9412202095675717, 25.530066391571133], [-26.149547632864614, 8.253575269460626],
                                 [-46.90889623225911, 1.3470587959708311]]})
    result = plan(task)
    assert result.feasible and result.trajectory.total_time == pytest.approx(7.99017, abs=1e-4)
    assert_plan_holds(result)


def test_over_the_sample_cap_after_the_time_limit_stopped_the_timing_the_error_says_so(monkeypatch):
    """A hermite7 run the time limit stops early keeps a timing far longer than its optimum; refused by
    the sample cap, the error blamed only the rate, limits and bounds (sweep 15)."""
    import planner.pipeline as pipeline

    def task(time_limit_s):
        return planner.make_task(joints_deg=[[0, 0], [40, -20], [90, 10], [30, 30], [-20, 5]],
                                 limits={"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120],
                                         "jerk_deg_s3": [600, 600]},
                                 trajectory={"family": "hermite7", "sample_rate_hz": 10},
                                 optimizer={"time_limit_s": time_limit_s})
    cut = plan(task(1e-9))
    assert cut.optimization.out_of_time
    converged = plan(task(120))
    assert not converged.optimization.out_of_time and converged.trajectory.total_time < cut.trajectory.total_time
    monkeypatch.setattr(pipeline, "MAX_SAMPLES", int(10 * (cut.trajectory.total_time + converged.trajectory.total_time)
                                                     / 2))  # between the two
    with pytest.raises(TaskError, match=r"^trajectory.sample_rate_hz: 10 Hz over the [\d.]+ s of trajectory makes "
                                        r"[\d.]+ samples per output, above the cap of [\d,]+; the time limit of "
                                        r"1e-09 s \(optimizer.time_limit_s\) stopped the timing before it converged"):
        plan(task(1e-9))
    plan(task(120))  # within the cap


def test_a_best_timing_outside_the_bounds_is_refused_for_the_bounds_first_and_hermite7_gets_no_on_bound_hint():
    """Durations outside ``bounds_s`` make a timing invalid whatever else it breaks: the error named a
    3e-7 deg position overshoot and advised moving the via-point off its range bound, which hermite7,
    whose via-point states are free, can stop at (sweep 15). (Its best timing may now be one at rest at every
    via-point, within the ranges: then the error names the bounds alone.)"""
    task = planner.make_task(joints_deg=[[0, 0], [40, -20], [90, 10]],
                             limits={"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120],
                                     "jerk_deg_s3": [600, 600], "position_deg": [[-10, 95], [-20, 20]]},
                             trajectory={"family": "hermite7"}, optimizer={"bounds_s": [1.1, 1.1]})
    with pytest.raises(InfeasibleError, match=r"^no feasible timing found by default \(nlp\) within "
                                              r"optimizer.bounds_s = \[1.1, 1.1\] s: meeting the limits takes "
                                              r"segment \d [\d.]+ s, above h_max = 1.1 s, with joint joint\d's \w+ at "
                                              r"its limit [^;,]*(, and in that timing joint joint2 position -20.\d+ "
                                              r"deg is below its lower limit -20 deg)?; widen the bounds or raise that "
                                              r"limit$"):
        plan(task)


SWEEP21_VIA_DEG = [[0, 0, 0], [40, -20, 10], [45, 30, -30], [90, 10, 0], [20, 20, 20]]
SWEEP21_LIMITS = {"velocity_deg_s": [60, 80, 100], "acceleration_deg_s2": [120, 100, 200],
                  "jerk_deg_s3": [600, 500, 900]}


@pytest.mark.parametrize("h_max", [2.001, 2.0])
def test_hermite7_on_h_max_is_kept_within_it(h_max):
    """hermite7's NLP put the last segment on h_max, and the repair, scaling every duration by the 2e-7
    its cut rounds left the limits exceeded, took it past: the task was refused ("takes segment 3
    2.001 s, above h_max = 2.001 s"), though timings within the bounds meet the limits (sweep 21)."""
    result = plan(planner.make_task(joints_deg=SWEEP21_VIA_DEG, limits=SWEEP21_LIMITS,
                                    trajectory={"family": "hermite7"},
                                    optimizer={"algorithm": "nlp", "bounds_s": [0.5, h_max]}))
    assert result.trajectory.durations.max() == pytest.approx(h_max, rel=1e-5)  # on it, not past it
    assert_plan_holds(result)


def test_hermite7_time_jerk_whose_ray_optimum_is_past_h_max_stops_on_it():
    """With time-jerk, the repair of the NLP's solution scaled it to the jerk-weighted optimum along its ray,
    4.6 s for the last segment where h_max is 2 s, and the task was refused as if the limits took that long
    (sweep 21). The objective along the ray is convex: within the bounds its best is on h_max."""
    result = plan(planner.make_task(joints_deg=SWEEP21_VIA_DEG, limits=SWEEP21_LIMITS,
                                    trajectory={"family": "hermite7"},
                                    optimizer={"algorithm": "nlp", "bounds_s": [0.5, 2.0], "objective": "time-jerk",
                                               "weights": [1, 10]}))
    assert result.trajectory.durations.max() == pytest.approx(2.0, rel=1e-9)
    assert_plan_holds(result)


def test_hermite7_without_the_nlp_names_its_fixed_via_point_states_where_the_bounds_refuse_it():
    """de keeps hermite7's via-point states on the family's fixed rule and finds no timing within [0.5, 2] s;
    the nlp algorithm, choosing them, plans the same task (sweep 21): the refusal says so."""
    task = planner.make_task(joints_deg=SWEEP21_VIA_DEG, limits=SWEEP21_LIMITS, trajectory={"family": "hermite7"},
                             optimizer={"algorithm": "de", "bounds_s": [0.5, 2.0]})
    with pytest.raises(InfeasibleError, match=r"widen the bounds or raise that limit \(with de, hermite7's via-point "
                                              r"velocities, accelerations and jerks follow its fixed rule; the "
                                              r"default, nlp and cuckoo algorithms choose them too\)$"):
        plan(task)
    assert_plan_holds(plan(dataclasses.replace(task, optimizer={**task.optimizer, "algorithm": "nlp"})))


def test_a_robot_retiming_that_leaves_a_range_is_timed_within_it_narrowed():
    """The side of each range a re-timing leaves is narrowed by RANGE_NARROWING times the excess, the
    other limits kept; a broken magnitude limit, or a via-point inside the band given up, leaves nothing to
    narrow (hermite7 on the PUMA paper task with a 0.25 m/s tool cap: a re-timing 1.7e-6 rad out of joint 5's
    range was dropped for a slow-down to 57.13 s; timed again narrowed, 25.82 s)."""
    from planner.kinematics import Violation
    from planner.pipeline import RANGE_NARROWING, _narrower_ranges
    from planner.timing import TimingProblem

    limits = JointLimits.create(2, lower=np.deg2rad([-100, -50]), upper=np.deg2rad([100, 50]),
                                velocity=np.deg2rad([60, 60]))
    problem = TimingProblem(np.deg2rad([[0, 0], [90, -40], [20, 10]]), "hermite7", limits, bounds=(0.5, 4.0))
    above = Violation("joint1", 0, "position", 0, np.deg2rad(100.001), np.deg2rad(100), "upper")
    below = Violation("joint2", 1, "position", 0, np.deg2rad(-50.01), np.deg2rad(-50), "lower")
    narrower = _narrower_ranges(problem, [above, below])
    assert narrower is not None and narrower.bounds == problem.bounds and narrower.family is problem.family
    np.testing.assert_allclose(narrower.limits.upper, np.deg2rad([100 - RANGE_NARROWING * 0.001, 50]))
    np.testing.assert_allclose(narrower.limits.lower, np.deg2rad([-100, -50 + RANGE_NARROWING * 0.01]))
    np.testing.assert_array_equal(narrower.limits.velocity, limits.velocity)
    speeding = Violation("joint1", 0, "velocity", 1, 1.2, 1.0)
    assert _narrower_ranges(problem, [above, speeding]) is None
    on_bound = TimingProblem(np.deg2rad([[0, 0], [100, -40], [20, 10]]), "hermite7", limits)
    assert _narrower_ranges(on_bound, [above]) is None  # the via-point at 100 deg must stay inside


def test_a_search_the_time_limit_stops_before_a_feasible_timing_says_so():
    """quintic within position ranges: a start scaled to meet the limits can leave a range, and a search the
    time limit stops there was refused as if the task were infeasible, the time limit unnamed (sweep 21)."""
    task = planner.make_task(joints_deg=[*SWEEP21_VIA_DEG, [-50, -50, 80], [99, 59, -89]],
                             limits={**SWEEP21_LIMITS, "position_deg": [[-100, 100], [-60, 60], [-90, 90]]},
                             trajectory={"family": "quintic"}, optimizer={"time_limit_s": 1e-9})
    with pytest.raises(InfeasibleError, match=r"^no feasible timing found by default before the time limit of 1e-09 s "
                                              r"\(optimizer.time_limit_s\) stopped it \(raise or remove that limit\); "
                                              r"in its best timing, joint joint\d position"):
        plan(task)
    assert_plan_holds(plan(dataclasses.replace(task, optimizer={**task.optimizer, "time_limit": 120.0})))


def test_a_population_too_large_for_the_task_is_a_task_error_naming_the_key():
    walk = np.cumsum(np.random.default_rng(2).uniform(-20, 20, (200, 2)), axis=0)
    task = planner.make_task(joints_deg=walk.tolist(), limits={"velocity_deg_s": [60, 60]},
                             optimizer={"algorithm": "de", "population": 1000})
    with pytest.raises(TaskError, match=r"^optimizer.population: 1000 makes a population of 201,000 candidates of "
                                        r"201 durations \(40,401,000 numbers\), above the 20,000,000 a search holds: "
                                        r"at most 495 for 201 segments$"):
        plan(task)


def test_a_planned_trajectory_that_misses_a_via_point_is_refused_with_the_fields(monkeypatch):
    """The final guard (a spline passes its via-points by construction) raised an InfeasibleError without
    the joint, quantity, value and limit the other refusals carry (sweep 16); a via-point moved after the
    timing stands in for a construction that misses it."""
    import planner.pipeline as pipeline
    from planner import InfeasibleError
    from planner.kinematics import via_point_misses

    def moved(trajectory, via, names):
        shifted = np.array(via, dtype=float)
        shifted[2, 1] += 1e-3
        return via_point_misses(trajectory, shifted, names)

    monkeypatch.setattr(pipeline, "via_point_misses", moved)
    with pytest.raises(InfeasibleError, match=r"fails the exact check: joint joint2 misses via-point 2 by "
                                              r"0\.0572958 deg") as raised:
        plan(PAPER_JOINT)
    error = raised.value
    assert (error.joint, error.joint_index, error.quantity) == ("joint2", 1, "position")
    assert error.value == pytest.approx(1e-3, rel=1e-6)
    assert error.limit == pytest.approx(2e-9 * max(1.0, abs(np.deg2rad(paper.VIA_POINTS_DEG[2][1]))), rel=1e-9)


def test_a_trajectory_longer_than_a_recording_holds_is_refused(tmp_path):
    """Limits of 1e-9 deg/s (within their documented range) made a 1.5e10 s trajectory; its recording's
    nanosecond times overflowed 64 bits and replay found no samples (sweep 19). It is refused before the
    timing; 5e9 s still fits, and its recording reads back and checks."""
    from planner.recording import read_recording
    task = {"version": 1, "waypoints": {"joints_deg": [[0], [10]]}, "limits": {"velocity_deg_s": [1e-9]},
            "trajectory": {"family": "cubic", "sample_rate_hz": 1e-7}}
    with pytest.raises(TaskError, match=r"^limits: the trajectory would last at least 1e\+10 s \(joint joint1 alone "
                                        r"covers 10 deg at its velocity limit of 1e-09 deg/s in 1e\+10 s\), beyond the "
                                        r"9\.2e\+09 s \(292 years\) that a recording's timeline"):
        plan(task)
    # The joint named is the one whose own velocity limit takes longest (the hostile-input sweep of 2026-12-07:
    # the message named no joint), not the first, nor the one that moves furthest.
    slow = {**task, "waypoints": {"joints_deg": [[0, 0, 0], [90, 10, 5], [0, 20, 0]]},
            "limits": {"velocity_deg_s": [1.0, 1e-9, 2e-9]}}
    with pytest.raises(TaskError, match=r"\(joint joint2 alone covers 20 deg at its velocity limit of 1e-09 deg/s in "
                                        r"2e\+10 s\)"):
        plan(slow)
    result = plan({**task, "limits": {"velocity_deg_s": [3e-9]}})
    assert 4e9 < result.trajectory.total_time < 9.2e9
    result.save(tmp_path / "out")
    assert read_recording(tmp_path / "out" / "trajectory.rrd").check().passed


def test_a_straight_line_round_that_inserts_nothing_keeps_the_comparisons_timing():
    """A 12-pose UR5 circle in straight-line mode within a 10 mm tolerance (no pose inserted) and a 0.5 s
    time limit: the IK sequences' comparison timed the kept sequence (2.74 s), then the straight-line
    round timed the same via-points again after the limit had passed and kept a start's shape (9.72 s,
    sweep 20: 36.2 s against 2.92 s on a 100-pose circle). It now keeps the comparison's timing."""
    angles = np.linspace(0, 2 * np.pi, 12)
    poses = [{"xyz_m": [0.4 + 0.1 * np.cos(a), 0.1 * np.sin(a), 0.3], "rpy_deg": [180, 0, 90]} for a in angles]
    result = plan({"version": 1, "robot": {"name": "ur5", "tool_frame": "tool0"}, "waypoints": {"cartesian": poses},
                   "limits": {"acceleration_deg_s2": [150] * 6, "jerk_deg_s3": [600] * 6},
                   "path": {"mode": "linear", "tolerance_m": 0.01}, "trajectory": {"family": "quintic"},
                   "optimizer": {"time_limit_s": 0.5}})
    assert result.path.inserted.sum() == 0 and set(result.branch_times) == {"optimal", "continuous"}
    assert result.trajectory.total_time == result.branch_times[result.branch_kept]


def test_a_plan_result_describes_the_trajectory_it_holds():
    """A result given another trajectory (``dataclasses.replace``) was saved with the old figures:
    summary.json said feasible with the old maxima beside a trajectory 8 times over its jerk limit (sweep
    20). The figures are now computed from the trajectory held; parts that do not belong together are
    refused, and the fields cannot be assigned."""
    import dataclasses

    result = plan(planner.make_task(name="two", joints_deg=[[0, 0], [40, -20], [90, 10]],
                                    limits={"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120],
                                            "jerk_deg_s3": [600, 600]}, trajectory={"family": "hybrid"}))
    assert result.feasible and result.max_ratio == pytest.approx(1.0)
    faster = dataclasses.replace(result, trajectory=get_family("hybrid").build(result.via_points,
                                                                                result.trajectory.durations / 2))
    assert not faster.feasible and faster.max_ratio == pytest.approx(8.0, rel=1e-6)
    assert faster.summary()["feasible"] is False
    with pytest.raises(InputError, match=r"does not pass its via-points: joint joint1 misses via-point 1 by 5\.7"):
        dataclasses.replace(result, via_points=result.via_points + np.deg2rad([[0, 0], [5.7, 0], [0, 0]]))
    with pytest.raises(InputError, match=r"via-points \(2, 2\) and limits \(2 joints\) must match its trajectory "
                                         r"\(3 via-points, 2 joints\)"):
        dataclasses.replace(result, via_points=result.via_points[:2])
    with pytest.raises(InputError, match="trajectory must be a PiecewisePolynomial, not NoneType"):
        dataclasses.replace(result, trajectory=None)
    for wrong in ("x", None, [[True, 0], [1, 1], [2, 2]]):  # numpy's own ValueError or a boolean read as 1
        with pytest.raises(InputError, match="a plan result's via-points must be numeric"):
            dataclasses.replace(result, via_points=wrong)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.trajectory = faster.trajectory
    for name, wrong, said in (("timings_s", None, "not NoneType"), ("timings_s", {"ik": -1.0}, "'ik': -1.0"),
                              ("timings_s", {"ik": None}, "'ik': None"), ("branch_times", {1: 2.0}, "1: 2.0")):
        with pytest.raises(InputError, match=f"a plan result's {name} must map names to seconds.*{said}"):
            dataclasses.replace(result, **{name: wrong})  # save() then failed with a TypeError (sweep 26)
    copy = dataclasses.replace(result, branch_times={"optimal": 2, "continuous": None})
    assert copy.timings_s == result.timings_s and copy.timings_s is not result.timings_s  # write() adds to its own


def test_the_summary_holds_what_repeats_the_run():
    """summary.json's optimizer section gives the algorithm asked for (beside the one that ran), the
    objective with its weights, the bounds, the time limit and the seed: a task made from them plans the
    same trajectory. The weights and time limit were missing, so a time-jerk run could not be repeated."""
    limits = {"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120], "jerk_deg_s3": [600, 600]}
    joints = [[0, 0], [40, -20], [90, 10], [30, 30]]
    asked = {"algorithm": "default", "objective": "time-jerk", "weights": [1.0, 0.02], "bounds_s": [0.2, 3.0],
             "time_limit_s": 60, "seed": 3}
    result = plan(planner.make_task(name="jerk", joints_deg=joints, limits=limits, optimizer=asked))
    summary = result.summary()["optimizer"]
    assert summary["requested_algorithm"] == "default" and summary["algorithm"] == "cuckoo"
    again = {"algorithm": summary["requested_algorithm"], "objective": summary["objective"],
             "weights": summary["weights"], "bounds_s": summary["bounds_s"], "time_limit_s": summary["time_limit_s"],
             "seed": summary["seed"]}
    assert again == asked
    repeated = plan(planner.make_task(name="jerk", joints_deg=joints, limits=limits, optimizer=again))
    np.testing.assert_array_equal(repeated.trajectory.durations, result.trajectory.durations)


def test_a_plan_result_refuses_a_task_or_parts_that_are_not_the_ones_planned():
    """A result given another task (``dataclasses.replace``) was saved as that task's: summary.json named
    a 3-joint quintic task for a 2-joint hybrid trajectory, with another algorithm requested; a part of
    the wrong type (task None, a path as the task, a robot name) ended in an AttributeError traceback
    (sweep 24). Both are refused when the result is made, naming the part."""
    import dataclasses

    limits = {"velocity_deg_s": [60, 60], "acceleration_deg_s2": [120, 120], "jerk_deg_s3": [600, 600]}
    joints = [[0, 0], [40, -20], [90, 10]]
    result = plan(planner.make_task(name="two", joints_deg=joints, limits=limits, trajectory={"family": "hybrid"}))

    def task(**changes):
        return planner.make_task(**{"name": "other", "joints_deg": joints, "limits": limits,
                                    "trajectory": {"family": "hybrid"}, **changes})
    assert dataclasses.replace(result, task=task(optimizer={"algorithm": "pso"})).summary()["task"] == "other"
    with pytest.raises(InputError, match=r"\(4 segments through 3 distinct via-points\) is not of its task's "
                                         r"family 'quintic'"):
        dataclasses.replace(result, task=task(trajectory={"family": "quintic"}))
    with pytest.raises(InputError, match="via-points are not its task 'other''s joint waypoints"):
        dataclasses.replace(result, task=task(joints_deg=[[0, 0], [40, -20], [90, 11]]))
    # Another family of the same segment count (sweep 27): cubic for hybrid, trigonometric for hermite7.
    cubic = planner.get_family("cubic").build(result.via_points, result.trajectory.durations)
    with pytest.raises(InputError, match=r"\(power segments of 4 coefficients\) is not of its task's family "
                                         r"'hybrid' \(power segments of 8\)"):
        dataclasses.replace(result, trajectory=cubic)
    smooth = plan(planner.make_task(name="c3", joints_deg=joints, limits=limits, trajectory={"family": "hermite7"}))
    trigonometric = planner.get_family("trigonometric").build(smooth.via_points, smooth.trajectory.durations)
    with pytest.raises(InputError, match=r"\(trigonometric segments of 8 coefficients\) is not of its task's "
                                         r"family 'hermite7' \(power segments of 8\)"):
        dataclasses.replace(smooth, trajectory=trigonometric)
    three = {key: values + [values[0]] for key, values in limits.items()}
    with pytest.raises(InputError, match="via-points are not its task 'other''s joint waypoints"):
        dataclasses.replace(result, task=task(joints_deg=[row + [0] for row in joints], limits=three))
    with pytest.raises(InputError, match="task 'other' has a robot, the result none"):
        dataclasses.replace(result, task=planner.make_task(name="other", joints_deg=[[0] * 6, [10] * 6],
                                                           robot={"name": "ur5", "tool_frame": "tool0"}))
    for part, value, said in (("task", None, "task must be a Task, not NoneType"),
                              ("task", "x.yaml", "task must be a Task, not str"),
                              ("optimization", None, "optimization must be an OptimizationResult, not NoneType"),
                              ("limits", {}, "limits must be a JointLimits, not dict"),
                              ("robot", "ur5", "robot must be a Robot or None, not str"),
                              ("ik", (), "ik must be a list or None, not tuple")):
        with pytest.raises(InputError, match=said):
            dataclasses.replace(result, **{part: value})


def test_a_plan_result_with_a_tool_path_refuses_another_trajectory():
    """The tool path's deviations and the tool-speed figures describe the trajectory planned: a result
    given another one kept them (saved as "within 0.875 mm of the line" where the tool strayed 50.8 mm,
    sweep 20). It is refused; the same trajectory again is taken."""
    import dataclasses

    result = plan({"version": 1, "robot": {"name": "ur5", "tool_frame": "tool0"},
                   "waypoints": {"cartesian": UR5_PICK_POSES[:2]}, "limits": {**UR5_FAST, "tool_speed_m_s": 0.5}})
    assert result.path is not None and result.robot_limits is not None
    slower = get_family(result.task.family).build(result.via_points, result.trajectory.durations * 2)
    with pytest.raises(InputError, match="tool path and robot-limit figures were measured on the trajectory planned"):
        dataclasses.replace(result, trajectory=slower)
    assert dataclasses.replace(result, timings_s={}).figures.max_abs.tolist() == result.figures.max_abs.tolist()
    # The IK report in another order, or with something else in it, is not the plan's (sweep 27).
    with pytest.raises(InputError, match="IK solution for waypoint 0 is not its via-point 0: the IK report belongs"):
        dataclasses.replace(result, ik=list(reversed(result.ik)))
    with pytest.raises(InputError, match="IK solution 1 must be an IKSolution, not dict"):
        dataclasses.replace(result, ik=[result.ik[0], {}])
    assert dataclasses.replace(result, ik=list(result.ik)).ik == result.ik


def test_task_limits_beyond_the_robots_own_are_said():
    """The task's limits override the robot's, and may widen them: the UR5's shoulder was planned to 500 deg
    (its URDF's range +-360 deg) at 1000 deg/s without a word (sweep 21). The plan now says so, naming the
    joint, the task's limit and the URDF's; narrower overrides, and the bundled tasks, say nothing."""
    from planner.progress import TerminalProgress

    def notes_of(limits: dict) -> tuple[list[str], list]:
        notes: list[str] = []
        progress = TerminalProgress("t", quiet=True)
        progress.note = notes.append
        result = plan({"version": 1, "robot": {"name": "ur5", "tool_frame": "tool0"},
                       "waypoints": {"joints_deg": [[0, -90, 90, 0, 90, 0], [40, -60, 60, 10, 80, 20]]},
                       "limits": {**UR5_FAST, **limits}}, progress=progress)
        return ([note for note in notes if note.startswith("the task's limits go beyond")],
                result.summary()["robot"]["limits_beyond_urdf"])

    ranges = [[-500, 500]] + [[-180, 180]] * 5
    said, summary = notes_of({"position_deg": ranges, "velocity_deg_s": [1000, 90, 90, 90, 90, 90]})
    assert len(said) == 1 and said[0] == ("the task's limits go beyond those of robot 'ur5' (its URDF's): joint "
                                          "shoulder_pan_joint range [-500 deg, 500 deg] (URDF [-360 deg, 360 deg]); "
                                          "joint shoulder_pan_joint velocity 1000 deg/s (URDF 180.482 deg/s); the "
                                          "plan keeps to the task's (summary.json: robot.limits_beyond_urdf)")
    urdf_velocity = pytest.approx(np.rad2deg(3.15), rel=1e-9)  # the UR5 URDF's shoulder_pan_joint, rad/s
    assert summary == [{"joint": "shoulder_pan_joint", "limit": "position_deg", "task": [-500.0, 500.0],
                        "robot": [-360.0, 360.0]},
                       {"joint": "shoulder_pan_joint", "limit": "velocity_deg_s", "task": 1000.0,
                        "robot": urdf_velocity}]
    assert notes_of({"position_deg": [[-100, 100]] * 6, "velocity_deg_s": [90] * 6}) == ([], [])


def test_an_infeasible_best_whose_states_no_spline_holds_is_refused_as_infeasible(monkeypatch):
    """A time limit stopped the NLP on via-point states so large against the durations that rounding broke
    the hermite7 spline apart, and that infeasible best was built as it was: the plan failed with the build's
    rounding message ("give durations of a physical size"), naming nothing the user gave (a fuzzed task,
    2026-12-07). The best timing is now refused as no feasible timing found, naming the time limit."""
    import planner.pipeline as pipeline
    from planner.timing.result import TIME_LIMIT_REASON

    optimize = pipeline.optimize

    def stopped(problem, *args, **kwargs):
        result = optimize(problem, *args, **kwargs)
        states = np.array(result.knot_states)
        states[1:-1, :, 0] = 1e12  # rad/s: every segment's coefficients parted by rounding
        return dataclasses.replace(result, knot_states=states, feasible=False,
                                   stop_reason=f"{TIME_LIMIT_REASON} of 30 s reached")
    monkeypatch.setattr(pipeline, "optimize", stopped)
    task = {"version": 1, "waypoints": {"joints_deg": [[0, 0], [40, -20], [10, 30]]},
            "limits": {"velocity_deg_s": [50, 50], "acceleration_deg_s2": [100, 100], "jerk_deg_s3": [500, 500]},
            "trajectory": {"family": "hermite7"}, "optimizer": {"algorithm": "nlp", "time_limit_s": 30}}
    with pytest.raises(InfeasibleError, match=r"no feasible timing found by nlp before the time limit of 30 s"):
        plan(task)
