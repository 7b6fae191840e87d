import itertools
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from planner import IKError, InputError, paper
from planner.ik import (
    choose_branches,
    pose_error,
    pose_from_position_quaternion,
    pose_solutions,
    range_margin_deg,
    resting_solutions,
    solve_pose,
    solve_waypoints,
    turn_variants,
)
from planner.limits import rest_to_rest_time
from planner.robot import Robot

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def puma():
    return Robot.from_urdf(ROOT / "robots" / "puma560.urdf", "tool")


def within_ranges(robot, q):
    return np.all(q >= robot.limits.lower - 1e-12) and np.all(q <= robot.limits.upper + 1e-12)


def test_table_ii_with_hints_recovers_via_points(puma):
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    poses = [puma.forward_kinematics(q) for q in via]
    solutions = solve_waypoints(puma, poses, hints=list(via))
    np.testing.assert_allclose(np.rad2deg([s.q for s in solutions]), paper.VIA_POINTS_DEG, atol=1e-6)


def test_table_ii_without_hints_reaches_every_pose_in_range(puma):
    poses = [puma.forward_kinematics(q) for q in np.deg2rad(paper.VIA_POINTS_DEG)]
    solutions = solve_waypoints(puma, poses)
    for solution, pose in zip(solutions, poses):
        error = pose_error(puma, solution.q, pose)
        assert np.linalg.norm(error[:3]) <= 1e-9 and np.linalg.norm(error[3:]) <= 1e-9
        assert within_ranges(puma, solution.q)
    assert solutions[0].jump == 0 and all(s.jump > 0 for s in solutions[1:])


@pytest.mark.parametrize("name, tool", [("puma", "tool"), ("ur5", "tool0"), ("panda", "panda_hand_tcp")])
def test_random_reachable_poses_solve_to_1e_9(puma, name, tool):
    robot = puma if name == "puma" else Robot.from_example_robot_data(name, tool)
    rng = np.random.default_rng(7)
    lower, upper = robot.limits.lower, robot.limits.upper
    configurations = lower + (upper - lower) * rng.random((8, robot.dof))
    poses = [robot.forward_kinematics(q) for q in configurations]
    for solution, pose in zip(solve_waypoints(robot, poses, seed=3), poses):
        error = pose_error(robot, solution.q, pose)
        assert max(np.linalg.norm(error[:3]), np.linalg.norm(error[3:])) <= 1e-9
        assert within_ranges(robot, solution.q)


@pytest.mark.parametrize("singular", [[4], [2, 4]])
def test_poses_at_a_singularity_are_reached(singular):
    """The UR5 with its wrist straight (q5 = 0), and elbow too (q3 = 0): the closed form's solutions
    degenerate there, and the default rule refused 9 of 300 such poses, and 67 of 300 with both, as "not
    reached within the joint ranges after 1 attempt" (sweep 24); the arm straight up among them. Each is
    reached now, within the ranges, by the numeric search where the closed form has nothing."""
    robot = Robot.from_example_robot_data("ur5", "tool0")
    rng = np.random.default_rng(11)
    configurations = rng.uniform(-np.pi * 17 / 18, np.pi * 17 / 18, (12, 6))
    configurations[:, singular] = 0.0
    configurations[0] = np.deg2rad([0, -90, 0, -90, 0, 90])  # straight up
    for q in configurations:
        pose = robot.forward_kinematics(q)
        found, best, _ = pose_solutions(robot, pose, robot.limits, np.random.default_rng(0))
        assert found, (np.rad2deg(q), best.residual)
        for solution in found:
            assert np.linalg.norm(pose_error(robot, solution.q, pose)) <= 1e-9
            assert len(turn_variants(robot, solution.q, robot.limits))  # a turn of it lies within the ranges


def test_single_solve_converges_quadratically(puma):
    """Newton's rate: once the residual is small, each step squares it (r_k+1 <= 10 r_k^2), until rounding."""
    q = np.deg2rad(paper.VIA_POINTS_DEG[2])
    residuals = [solve_pose(puma, puma.forward_kinematics(q), q + 0.05, max_iterations=k).residual for k in range(1, 7)]
    assert residuals[-1] <= 1e-12
    steps = [(r, following) for r, following in zip(residuals, residuals[1:]) if following > 1e-14]
    assert len(steps) >= 2 and all(following <= 10 * r ** 2 for r, following in steps), residuals


def test_unreachable_pose_names_waypoint_and_residual(puma):
    poses = [puma.forward_kinematics(np.zeros(6)), pin.SE3(np.eye(3), np.array([3.0, 0.0, 1.0]))]
    with pytest.raises(IKError, match=r"waypoint 1: pose not reached .* best residual [\d.e+-]+ m") as info:
        solve_waypoints(puma, poses, restarts=3)
    assert info.value.waypoint == 1 and info.value.residual > 1.0


def test_a_reachable_pose_outside_narrow_ranges_names_a_joint_and_its_bound():
    """Reachable, but not within ranges of +-1 deg: the message says so and names a joint beyond its bound
    (it used to report a residual of 3e-16 m as if the pose were out of reach)."""
    robot = Robot.from_example_robot_data("ur5", "tool0")
    narrow = robot.limits.with_overrides(lower=np.full(6, np.deg2rad(-1.0)), upper=np.full(6, np.deg2rad(1.0)))
    pose = robot.forward_kinematics(np.deg2rad([10.0, -60.0, 80.0, -100.0, -90.0, 30.0]))
    said = (r"^waypoint 0: .*the pose is reachable, but outside the ranges: "
            r"the solution found nearest them puts joint \w+ at -?[\d.]+ deg, beyond its (upper|lower) limit -?1 deg$")
    with pytest.raises(IKError, match=said) as raised:
        solve_waypoints(robot, [pose, pose], limits=narrow)
    assert raised.value.waypoint == 0 and raised.value.residual <= 1e-9


@pytest.mark.parametrize("joint", range(6))
def test_a_pose_reachable_outside_the_ranges_names_its_solution_nearest_them(joint):
    """Ranges of +-5 deg around one of the UR5's 8 solutions of a pose, but one joint's moved 2 deg past it: the
    message names that joint 2 deg beyond its bound (it named another solution, 170 deg outside a range)."""
    robot = Robot.from_example_robot_data("ur5", "tool0")
    q = np.deg2rad([10.0, -60.0, 80.0, -100.0, -90.0, 30.0])
    lower, upper = q - np.deg2rad(5.0), q + np.deg2rad(5.0)
    lower[joint], upper[joint] = q[joint] + np.deg2rad(2.0), q[joint] + np.deg2rad(12.0)
    with pytest.raises(IKError) as raised:
        solve_waypoints(robot, [robot.forward_kinematics(q)], limits=robot.limits.with_overrides(lower=lower,
                                                                                                  upper=upper))
    value, bound = np.rad2deg(q[joint]), np.rad2deg(lower[joint])
    assert str(raised.value).endswith(f"joint {robot.joint_names[joint]} at {value:.6g} deg, beyond its lower limit "
                                      f"{bound:.6g} deg"), str(raised.value)


@pytest.mark.parametrize("low, high", [(100.0, 120.0), (-100.0, -80.0), (500.0, 520.0)])
def test_a_pose_reachable_only_outside_one_narrow_range_names_that_joint_its_nearest_turn_and_bound(low, high):
    """Only the shoulder-lift joint's range is narrowed (and away from the solution, on either side and
    beyond a turn): the message names it, its value in the turn nearest the range, and the bound it passes."""
    import re
    robot = Robot.from_example_robot_data("ur5", "tool0")
    lower, upper = robot.limits.lower.copy(), robot.limits.upper.copy()
    lower[1], upper[1] = np.deg2rad(low), np.deg2rad(high)
    pose = robot.forward_kinematics(np.deg2rad([10.0, -60.0, 80.0, -100.0, -90.0, 30.0]))
    with pytest.raises(IKError) as raised:
        solve_waypoints(robot, [pose], limits=robot.limits.with_overrides(lower=lower, upper=upper))
    found = re.search(r"joint (\w+) at (-?[\d.]+) deg, beyond its (upper|lower) limit (-?[\d.]+) deg",
                      str(raised.value))
    assert found, str(raised.value)
    name, value, side, bound = found[1], float(found[2]), found[3], float(found[4])
    assert name == "shoulder_lift_joint" and abs(value - (low + high) / 2) <= 180
    assert (side, bound) == (("lower", low) if value < low else ("upper", high))


def test_without_a_start_the_branch_nearest_the_middle_of_the_ranges_is_chosen(puma):
    middle = (puma.limits.lower + puma.limits.upper) / 2
    for seed in range(20):
        candidates = np.random.default_rng(seed).uniform(puma.limits.lower, puma.limits.upper, (5, 6))
        assert choose_branches(puma, puma.limits, [candidates]) == \
            [int(np.argmin(np.linalg.norm(candidates - middle, axis=1)))]


def test_a_hint_whose_solve_stalls_gives_the_solution_nearest_it():
    """UR5: the solve seeded by this hint stalls at a range bound (residual 0.32), yet the pose has
    solutions in range: the one nearest the hint (up to 2 pi turns) is taken, not an 'unreached' error."""
    ur5 = Robot.from_example_robot_data("ur5", "tool0")
    pose = pin.SE3(pin.rpy.rpyToMatrix(*np.deg2rad([180, 0, 90])), np.array([0.4, -0.25, 0.35]))
    hint = np.deg2rad([1.5, -90, 90, -90, -90, 0])
    assert solve_pose(ur5, pose, hint).residual > 0.1  # the case this guards
    [solution] = solve_waypoints(ur5, [pose], hints=[hint])
    assert np.linalg.norm(pose_error(ur5, solution.q, pose)) <= 1e-9
    every, _, _ = pose_solutions(ur5, pose, ur5.limits, np.random.default_rng(1))
    nearest = min(np.linalg.norm(q - hint) for s in every for q in turn_variants(ur5, s.q, ur5.limits))
    assert np.linalg.norm(solution.q - hint) == pytest.approx(nearest, abs=1e-6)


def test_hint_of_wrong_length(puma):
    pose = puma.forward_kinematics(np.zeros(6))
    with pytest.raises(InputError, match="waypoint 0: hint has 3 values, robot has 6 joints"):
        solve_waypoints(puma, [pose], hints=[np.zeros(3)])


def test_pose_from_quaternion_matches_pinocchio():
    quaternion = np.array([0.1, -0.3, 0.2, 0.9])
    quaternion /= np.linalg.norm(quaternion)
    pose = pose_from_position_quaternion([1, 2, 3], quaternion)
    np.testing.assert_allclose(pin.Quaternion(pose.rotation).coeffs(), quaternion, atol=1e-12)
    np.testing.assert_allclose(pose.translation, [1, 2, 3])
    assert pose_from_position_quaternion([1, 2, 3], [0, 0, 1, 1]).isApprox(
        pose_from_position_quaternion([1.0, 2.0, 3.0], [0.0, 0.0, 2 ** -0.5, 2 ** -0.5]), 1e-12)  # integers too


# ---------------------------------------------------------------------------- branch choice


def smooth_branch_path(robot, rng, count=6, step_deg=10.0, margin_deg=20.0):
    """Random joint path with small steps, inside the ranges and away from singularities."""
    lower = np.maximum(robot.limits.lower, -np.pi) + np.deg2rad(margin_deg)
    upper = np.minimum(robot.limits.upper, np.pi) - np.deg2rad(margin_deg)
    while True:
        q = [lower + (upper - lower) * rng.random(robot.dof)]
        for _ in range(count - 1):
            q.append(np.clip(q[-1] + np.deg2rad(rng.uniform(-step_deg, step_deg, robot.dof)), lower, upper))
        if all(np.linalg.svd(robot.frame_jacobian(qi), compute_uv=False)[-1] > 0.05 for qi in q):
            return np.array(q)


@pytest.mark.parametrize("name", ["puma", "ur5"])
def test_optimal_branch_recovers_a_smooth_path_without_hints(puma, name):
    robot = puma if name == "puma" else Robot.from_example_robot_data("ur5", "tool0")
    rng = np.random.default_rng(11)
    for _ in range(3):
        path = smooth_branch_path(robot, rng)
        poses = [robot.forward_kinematics(q) for q in path]
        solutions = solve_waypoints(robot, poses, start=path[0], seed=1)
        chosen = np.array([s.q for s in solutions])
        turns = (chosen - path) / (2 * np.pi)
        np.testing.assert_allclose(turns, np.round(turns), atol=1e-6)
        assert all(s.solutions >= 2 for s in solutions)  # there was a choice to make


def test_pose_solutions_are_distinct_in_range_and_include_the_generating_one(puma):
    q = np.deg2rad(paper.VIA_POINTS_DEG[1])
    target = puma.forward_kinematics(q)
    found, _, attempts = pose_solutions(puma, target, puma.limits, np.random.default_rng(0))
    assert attempts == 1  # the PUMA has closed-form IK: one solve gives every solution
    assert len(found) >= 3
    for s in found:
        error = pose_error(puma, s.q, target)
        assert max(np.linalg.norm(error[:3]), np.linalg.norm(error[3:])) <= 1e-9
        assert len(turn_variants(puma, s.q, puma.limits)) >= 1
    wrapped = [np.angle(np.exp(1j * s.q)) for s in found]
    for i, a in enumerate(wrapped):
        assert all(np.abs(np.angle(np.exp(1j * (a - b)))).max() > 1e-5 for b in wrapped[:i])
    assert min(np.abs(np.angle(np.exp(1j * (w - q)))).max() for w in wrapped) <= 1e-6


@st.composite
def candidate_sets(draw, dof: int = 6):
    """2 to 5 waypoints' candidate configurations (1 to 4 each) in [-3, 3] rad and a start, drawn as arrays."""
    radians = st.floats(-3.0, 3.0)
    sizes = draw(st.lists(st.integers(1, 4), min_size=2, max_size=5))
    return ([draw(arrays(float, (k, dof), elements=radians)) for k in sizes],
            draw(arrays(float, dof, elements=radians)))


@given(candidate_sets())
def test_branch_choice_is_the_brute_force_optimum(puma, drawn):
    candidates, start = drawn
    paper_limits = paper.paper_limits()  # with the PUMA's finite ranges: no joint turns freely
    limits = puma.limits.with_overrides(**{q: getattr(paper_limits, q) for q in ("velocity", "acceleration", "jerk")})
    chosen = choose_branches(puma, limits, candidates, start)

    def cost(sequence):
        configurations = [start] + [c[i] for c, i in zip(candidates, sequence)]
        return sum(rest_to_rest_time(np.abs(b - a), limits).max() for a, b in zip(configurations, configurations[1:]))
    best = min(cost(s) for s in itertools.product(*(range(len(c)) for c in candidates)))
    assert cost(chosen) <= best + 1e-12


def test_resting_solutions_are_each_turned_to_their_widest_margin(puma):
    """The solutions offered as a resting hint sit each joint at its turn farthest from its bounds: with
    joint 6's range moved to [0, 532] deg, a wrist at 10 deg is offered at 370 deg (margin 162 deg,
    not 10)."""
    q = np.deg2rad([10, -20, 30, 40, 50, 10])
    limits = puma.limits.with_overrides(lower=np.r_[puma.limits.lower[:5], 0.0],
                                        upper=np.r_[puma.limits.upper[:5], np.deg2rad(532)])
    resting, count = resting_solutions(puma, puma.forward_kinematics(q), limits, lambda _: True)
    assert count >= 3 and len(resting) == count
    for solution in resting:
        margin = range_margin_deg(solution, limits)
        for variant in turn_variants(puma, solution, limits):
            assert range_margin_deg(variant, limits) <= margin + 1e-9
    assert np.any(np.isclose(np.rad2deg(resting[:, 5]), 370.0))
    assert len(resting_solutions(puma, puma.forward_kinematics(q), limits, lambda _: False)[0]) == 0


def test_turn_variants_cover_every_turn_in_range(puma):
    q = np.deg2rad([10, -20, 30, 40, 50, -100])
    variants = np.rad2deg(turn_variants(puma, q, puma.limits))
    # Only joint 6 (range +-266 deg) has a second turn in range: -100 + 360 = 260.
    assert sorted(np.round(variants[:, 5])) == [-100.0, 260.0]
    np.testing.assert_allclose(variants[:, :5], np.rad2deg(np.tile(q[:5], (2, 1))))
    narrow = puma.limits.with_overrides(lower=np.deg2rad([20, -225, -45, -110, -100, -266]))
    assert len(turn_variants(puma, q, narrow)) == 0  # joint 1 at 10 deg is below 20 deg, in every turn


def test_turn_variants_of_a_34_joint_chain(tmp_path):
    """Every product of the joints' turns in range, last joint fastest (as itertools.product), beyond
    the 32 dimensions numpy's meshgrid takes (a 33-joint arm was an internal error)."""
    joints = 34
    links = "".join(f'<link name="l{i}"/>' for i in range(joints + 1))
    chain = "".join(f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
                    f'<origin xyz="0 0 0.05"/><axis xyz="0 {i % 2} {(i + 1) % 2}"/>'
                    f'<limit lower="{-6.0 if i in (3, 30) else -1.0}" upper="{4.0 if i in (3, 30) else 1.0}" '
                    f'velocity="1" effort="1"/></joint>' for i in range(joints))
    urdf = tmp_path / "chain.urdf"
    urdf.write_text(f'<robot name="chain">{links}{chain}</robot>')
    robot = Robot.from_urdf(urdf, f"l{joints}")
    q = np.full(joints, 0.5)
    variants = turn_variants(robot, q, robot.limits)
    expected = list(itertools.product(*[[0.5 - 2 * np.pi, 0.5] if j in (3, 30) else [0.5] for j in range(joints)]))
    np.testing.assert_allclose(variants, np.array(expected))


def test_ranges_so_wide_that_the_turns_outnumber_the_branch_budget_are_refused_naming_the_joints():
    """UR5 ranges of +-600 deg give each of a pose's 8 solutions about 4^6 turn variants: more than the
    optimal rule's dynamic programme can hold (it needed 48 GB at +-720 deg). Refused at once, naming
    the waypoint, the count and the wide joints; the continuous rule still plans it."""
    import time

    from planner.ik import MAX_CANDIDATES, turn_variant_count
    robot = Robot.from_example_robot_data("ur5", "tool0")
    wide = robot.limits.with_overrides(lower=np.full(6, np.deg2rad(-600.0)), upper=np.full(6, np.deg2rad(600.0)))
    q = np.deg2rad([10.0, -60.0, 80.0, -100.0, -90.0, 30.0])
    assert turn_variant_count(robot, q, wide) == len(turn_variants(robot, q, wide)) > MAX_CANDIDATES // 8
    pose = robot.forward_kinematics(q)
    started = time.perf_counter()
    with pytest.raises(IKError, match=r"^waypoint 0: its \d+ IK solutions have \d+ variants by 2 pi turns .*"
                                      r"shoulder_pan_joint \(1200 deg\).*ik\.branch: continuous") as raised:
        solve_waypoints(robot, [pose, pose], limits=wide)
    assert raised.value.waypoint == 0 and time.perf_counter() - started < 30
    solutions = solve_waypoints(robot, [pose, pose], limits=wide, branch="continuous")
    assert all(s.residual <= 1e-9 for s in solutions)


def test_the_too_many_turns_refusal_lists_exactly_the_joints_spanning_more_than_a_turn():
    import re
    robot = Robot.from_example_robot_data("ur5", "tool0")
    half = np.deg2rad([700, 700, 700, 700, 200, 170])
    pose = robot.forward_kinematics(np.deg2rad([10.0, -60.0, 80.0, -100.0, -90.0, 30.0]))
    with pytest.raises(IKError) as raised:
        solve_waypoints(robot, [pose], limits=robot.limits.with_overrides(lower=-half, upper=half))
    listed = re.search(r"spans more than 360 deg: (.*)\. Narrow", str(raised.value))
    assert listed, str(raised.value)
    assert [item.split(" (")[0] for item in listed[1].split(", ")] == robot.joint_names[:5]


@given(st.lists(st.floats(-700.0, 700.0), min_size=6, max_size=6), st.lists(st.floats(100.0, 700.0), min_size=6,
                                                                               max_size=6))
def test_the_widest_turn_variant_is_the_brute_force_one(puma, angles, spans):
    """A redundant arm's solution is centred from its turn with the widest margin to the ranges: chosen
    joint by joint, it must equal the best of every variant."""
    from planner.ik import IKSolution, _widest_variant
    from planner.limits import JointLimits
    half = np.deg2rad(spans) / 2
    limits = JointLimits.create(6, lower=-half, upper=half)
    q = np.deg2rad(angles)
    variants = turn_variants(puma, q, limits)
    if len(variants) == 0:
        return
    best = max(range_margin_deg(v, limits) for v in variants)
    widest = _widest_variant(puma, IKSolution(q, 0.0, 0.0, 1), limits)
    assert widest.margin_deg == pytest.approx(best, abs=1e-9)
    assert range_margin_deg(widest.q, limits) == widest.margin_deg
    assert any(np.allclose(widest.q, v) for v in variants)


def largest_margin_on_self_motion(robot, target, q0):
    """An independent local maximum of the smallest distance to a range bound [deg] over the
    configurations reaching ``target``, from ``q0`` (scipy's SLSQP on max t subject to the pose and
    lower + t <= q <= upper - t)."""
    from scipy.optimize import minimize
    lower, upper, n = robot.limits.lower, robot.limits.upper, robot.dof
    constraints = [{"type": "eq", "fun": lambda x: pose_error(robot, x[:n], target)},
                   {"type": "ineq", "fun": lambda x: np.concatenate((x[:n] - lower - x[n], upper - x[:n] - x[n]))}]
    start = np.append(q0, np.min(np.minimum(q0 - lower, upper - q0)))
    found = minimize(lambda x: -x[n], start, jac=lambda x: np.r_[np.zeros(n), -1.0], constraints=constraints,
                     method="SLSQP", options={"maxiter": 500, "ftol": 1e-12})
    assert np.abs(pose_error(robot, found.x[:n], target)).max() < 1e-8
    return float(np.rad2deg(found.x[n]))


def test_centring_reaches_the_largest_margin_of_the_self_motion():
    """A redundant arm's solution centred from anywhere in its ranges (here the configuration the pose
    came from, often a degree or less from a bound) keeps the pose and reaches at least 90 % of the
    largest margin an independent optimizer finds on the same self-motion (the barrier only
    approximates the max-min margin). The centring once lost the pose near a bound and gave up
    (0.9 deg kept where 5 deg was there)."""
    from planner.ik import IKSolution, centred
    robot = Robot.from_example_robot_data("panda", "panda_hand_tcp")
    lower, upper = robot.limits.lower, robot.limits.upper
    rng = np.random.default_rng(0)
    for q in lower + (upper - lower) * rng.random((16, robot.dof)):
        target = robot.forward_kinematics(q)
        moved = centred(robot, target, IKSolution(q, 0.0, 0.0, 1, margin_deg=range_margin_deg(q, robot.limits)),
                        robot.limits)
        assert np.abs(pose_error(robot, moved.q, target)).max() <= 1e-9 and within_ranges(robot, moved.q)
        assert moved.margin_deg == pytest.approx(range_margin_deg(moved.q, robot.limits))
        best = largest_margin_on_self_motion(robot, target, moved.q)
        assert moved.margin_deg >= 0.9 * best, (q, moved.margin_deg, best)


def test_continuous_rule_takes_the_turn_nearest_the_previous_configuration(monkeypatch):
    """Whatever 2 pi representative the solver returns, the continuous rule keeps each joint within
    pi of the previous configuration where the ranges allow (UR5: +-360 deg)."""
    import dataclasses

    import planner.ik as ik
    robot = Robot.from_example_robot_data("ur5", "tool0")
    solve = ik.solve_pose

    def wrapped_solve(robot, target, seed, *args, **kwargs):  # a solver that returns angles in [-pi, pi)
        solution = solve(robot, target, seed, *args, **kwargs)
        return dataclasses.replace(solution, q=(solution.q + np.pi) % (2 * np.pi) - np.pi)

    monkeypatch.setattr(ik, "solve_pose", wrapped_solve)
    path = np.deg2rad([[200, -80, 100, -110, 250, 300], [210, -75, 95, -100, 260, 330],
                       [220, -70, 90, -90, 270, 350]])
    poses = [robot.forward_kinematics(q) for q in path]
    solutions = solve_waypoints(robot, poses, start=path[0], branch="continuous", seed=0)
    np.testing.assert_allclose([s.q for s in solutions], path, atol=1e-6)
    assert all(s.jump < np.deg2rad(60) for s in solutions)


@pytest.mark.parametrize("branch", ["optimal", "continuous"])
def test_a_joint_without_a_range_turns_the_short_way(branch):
    """UR5 base at 170 deg, then -170 deg, with the base's range taken away: it turns 20 deg on (to 190),
    not 340 deg back; the other joints stay as they were."""
    robot = Robot.from_example_robot_data("ur5", "tool0")
    free = robot.limits.with_overrides(lower=np.r_[-np.inf, robot.limits.lower[1:]],
                                       upper=np.r_[np.inf, robot.limits.upper[1:]])
    first = np.deg2rad([170, -60, 80, -110, -90, 0])
    second = first.copy()
    second[0] = np.deg2rad(-170)
    poses = [robot.forward_kinematics(first), robot.forward_kinematics(second)]
    solutions = solve_waypoints(robot, poses, start=first, branch=branch, limits=free)
    np.testing.assert_allclose(np.rad2deg(solutions[1].q - solutions[0].q), [20, 0, 0, 0, 0, 0], atol=1e-6)


@pytest.mark.parametrize("branch", ["optimal", "continuous"])
def test_progress_counts_every_waypoint(puma, branch):
    via = np.deg2rad([[10, -20, 30, 40, 50, -100], [20, -30, 40, 30, 40, -90], [30, -40, 50, 20, 30, -80]])
    calls = []
    solve_waypoints(puma, [puma.forward_kinematics(q) for q in via], branch=branch,
                    progress=lambda done, total: calls.append((done, total)))
    assert calls == [(1, 3), (2, 3), (3, 3)]


def test_a_solution_on_a_documented_bound_is_in_range(puma):
    """45 deg is 4e-10 rad above the URDF's upper="0.785398163" of joint 2: within ``FEASIBILITY_TOLERANCE``
    of a bound a solution is on it (clipped there), as a via-point is, so the pose is reached; the pose was
    "not reached within the joint ranges" (sweep 16)."""
    q = np.deg2rad([60, 45, -45, 20, 100, 40])
    assert q[1] > puma.limits.upper[1] and q[2] < puma.limits.lower[2]  # just past both, by < 1e-9 rad
    variants = turn_variants(puma, q, puma.limits)
    assert len(variants) and all(within_ranges(puma, v) for v in variants)
    start = puma.forward_kinematics(np.deg2rad([10, -30, 45, 5, 10, 6]))
    solutions = solve_waypoints(puma, [start, puma.forward_kinematics(q)])
    assert np.abs(solutions[1].q - q).max() <= 1e-9 and within_ranges(puma, solutions[1].q)
    assert solutions[1].q[1] == puma.limits.upper[1]


def test_the_numeric_search_reports_a_solve_that_reaches_the_pose_outside_the_ranges():
    """Ranges of +-1 deg around a UR5 configuration, the shoulder's moved 2 deg past it, numeric search: no
    solution lies inside them, and the best solve reported (for the message) must be one that reaches the
    pose, outside the ranges, not an unreached solve that ends nearer them (the message would then say the
    pose is out of reach)."""
    robot = Robot.from_example_robot_data("ur5", "tool0")
    q = np.deg2rad([10.0, -60.0, 80.0, -100.0, -90.0, 30.0])
    lower, upper = q - np.deg2rad(1.0), q + np.deg2rad(1.0)
    lower[1], upper[1] = q[1] + np.deg2rad(2.0), q[1] + np.deg2rad(4.0)
    narrow = robot.limits.with_overrides(lower=lower, upper=upper)
    found, best, _ = pose_solutions(robot, robot.forward_kinematics(q), narrow, np.random.default_rng(0),
                                    closed_form=False)
    assert found == [] and best.residual <= 1e-9, best.residual
