"""Gaps in the tests of planner/ik.py found by a second mutation run (mutmut 3.8.1) over the functions the
first (tests/test_ik_mutation_gaps.py) did not cover: centring, the hinted solve, the numeric search's
starts, resting solutions, the described (tracked) sequences and the input and refusal messages."""

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import null_space

import planner.ik as ik
from planner import IKError, InputError
from planner.limits import FEASIBILITY_TOLERANCE, JointLimits
from planner.robot import Robot

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def ur5():
    return Robot.from_example_robot_data("ur5", "tool0")


@pytest.fixture(scope="module")
def panda():
    return Robot.from_example_robot_data("panda", "panda_hand_tcp")


@pytest.fixture(scope="module")
def puma():
    return Robot.from_urdf(ROOT / "robots" / "puma560.urdf", "tool")


def _placement(robot, q):
    """The tool frame's placement at q by Pinocchio's own forward kinematics (not ``Robot``'s)."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, np.asarray(q, dtype=float))
    return data.oMf[robot.model.getFrameId(robot.tool_frame)]


def _errors(robot, q, target):
    """|translation error| [m] and |rotation error| [rad] of q for target (Pinocchio's log6, tool frame)."""
    error = pin.log6(_placement(robot, q).actInv(target)).vector
    return np.linalg.norm(error[:3]), np.linalg.norm(error[3:])


def _margin_deg(q, lower, upper):
    return float(np.rad2deg(np.min(np.minimum(q - lower, upper - q))))


def _turns_in_range(q, lower, upper, tolerance=FEASIBILITY_TOLERANCE):
    """Per joint, every q_j + 2 pi k (k in -4..4) within [lower_j, upper_j] (to ``tolerance``), clipped onto it."""
    options = []
    for j in range(len(q)):
        values = q[j] + 2 * np.pi * np.arange(-4, 5)
        values = values[(values >= lower[j] - tolerance) & (values <= upper[j] + tolerance)]
        options.append(np.clip(values, lower[j], upper[j]))
    return options


def _no_closed_form(monkeypatch):
    """The numeric search for every arm (as for an arm of no closed-form class)."""
    monkeypatch.setattr(ik, "closed_form_solver", lambda robot: None)


# --- centring a redundant arm's solution ---------------------------------------------------------------------

def _barrier_gradient(q, lower, upper):
    """The gradient of sum_j (q_j - lower_j)^-8 + (upper_j - q_j)^-8 over the joints bounded on both sides."""
    bounded = np.isfinite(lower) & np.isfinite(upper)
    gradient = np.zeros_like(q)
    gradient[bounded] = 8 * ((upper - q)[bounded] ** -9 - (q - lower)[bounded] ** -9)
    return gradient


@pytest.mark.parametrize("free", [[], [0], [6], [2, 5]])
def test_centring_ends_where_the_barrier_is_stationary_on_the_self_motion(panda, free):
    """``centred`` minimises the barrier sum (q_j - lower_j)^-8 + (upper_j - q_j)^-8 over the joints bounded
    on both sides, on the configurations reaching the pose: where it ends, the barrier's gradient (by hand)
    has no component along the self-motion (the null space of Pinocchio's tool Jacobian), relative to the
    gradient, and the result keeps the pose and stays in the ranges. Some Panda joints are given no range
    (one of them bounded on one side only) so the barrier leaves them out: such a joint neither pushes the
    self-motion (a gradient of 0) nor blocks the centring of the others. (From near the lower bounds; where
    the barrier's minimum has a narrower margin than the start, the start is kept, as documented.)"""
    lower, upper = panda.limits.lower.copy(), panda.limits.upper.copy()
    for k, j in enumerate(free):
        lower[j] = -np.inf
        upper[j] = np.inf if k % 2 == 0 else upper[j]
    limits = panda.limits.with_overrides(lower=lower, upper=upper)
    robot = replace(panda, limits=limits)
    rng = np.random.default_rng(3)
    low, high = np.where(np.isfinite(lower), lower, -np.pi), np.where(np.isfinite(upper), upper, np.pi)
    kept = 0
    for q in low + (high - low) * rng.uniform(0.02, 0.3, (6, 7)):  # near the lower bounds
        target = _placement(robot, q)
        given = ik.IKSolution(q, 0.0, 0.0, 1, margin_deg=_margin_deg(q, lower, upper))
        moved = ik.centred(robot, target, given, limits)
        assert max(_errors(robot, moved.q, target)) <= 1e-9
        assert np.all((moved.q >= lower) & (moved.q <= upper))
        assert _margin_deg(moved.q, lower, upper) >= given.margin_deg
        if moved is given:  # the barrier's minimum had a narrower margin: the solution is kept as given
            kept += 1
            continue
        data = robot.model.createData()
        jacobian = pin.computeFrameJacobian(robot.model, data, moved.q, robot.model.getFrameId(robot.tool_frame),
                                            pin.LOCAL)
        tangent = null_space(jacobian)
        gradient = _barrier_gradient(moved.q, lower, upper)
        assert np.linalg.norm(tangent.T @ gradient) <= 1e-3 * np.linalg.norm(gradient), (q, moved.q)
    assert kept <= 2


def test_centring_keeps_the_given_solution_where_the_result_is_not_accepted_as_reaching_the_pose(panda):
    """``centred`` keeps its result only if it reaches the pose within ``accept``: with an ``accept`` no
    residual meets (negative), the solution comes back as given, whatever margin the centring found."""
    lower, upper = panda.limits.lower, panda.limits.upper
    q = lower + (upper - lower) * np.random.default_rng(5).uniform(0.05, 0.3, 7)  # near the lower bounds
    given = ik.IKSolution(q, 0.0, 0.0, 1, margin_deg=_margin_deg(q, lower, upper))
    target = _placement(panda, q)
    assert _margin_deg(ik.centred(panda, target, given, panda.limits).q, lower, upper) > given.margin_deg + 1
    assert ik.centred(panda, target, given, panda.limits, accept=-1.0) is given


@pytest.mark.parametrize("branch", ["continuous", "optimal"])
def test_a_redundant_arm_without_any_finite_range_is_solved_uncentred(panda, branch):
    """A Panda whose joints all turn freely (no finite range): there is nothing to centre on, and the
    waypoints are reached (Pinocchio's FK), each solution as found (its joints wrapped into [-pi, pi) by the
    optimal rule)."""
    limits = panda.limits.with_overrides(lower=np.full(7, -np.inf), upper=np.full(7, np.inf))
    robot = replace(panda, limits=limits)
    path = np.deg2rad([[10, -30, 20, -120, 10, 100, 40], [20, -20, 10, -110, 20, 110, 30]])
    poses = [_placement(robot, q) for q in path]
    solutions = ik.solve_waypoints(robot, poses, start=path[0], branch=branch, limits=limits, seed=0)
    for solution, pose in zip(solutions, poses):
        assert max(_errors(robot, solution.q, pose)) <= 1e-9
    q = path[0]
    given = ik.IKSolution(q, 0.0, 0.0, 1)
    assert ik.centred(robot, poses[0], given, limits) is given


# --- a hinted waypoint ------------------------------------------------------------------------------------------

STALL_POSE = pin.SE3(pin.rpy.rpyToMatrix(*np.deg2rad([180, 0, 90])), np.array([0.4, -0.25, 0.35]))
STALL_HINT_DEG = np.array([1.5, -90, 90, -90, -90, 0])


@pytest.mark.parametrize("turns", [[0, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, 0], [0, 0, 0, 1, 1, 0]])
def test_a_stalled_hint_takes_the_turn_of_the_solution_nearest_it_and_reports_the_solves(ur5, turns):
    """UR5, a hint whose own solve stalls at a range bound (tests/test_ik.py), given in several 2 pi turns of
    the wrist joints (each periodic-equivalent, so the solve stalls the same way): the waypoint takes the
    pose's solution in its 2 pi turn nearest the hint (a brute force over each joint's in-range turns of
    the pose's solutions), and reports the solves made: the hint's, then the search's."""
    hint = np.deg2rad(STALL_HINT_DEG + 360.0 * np.array(turns))
    assert ik.solve_pose(ur5, STALL_POSE, hint).residual > 0.1  # the case this guards
    [solution] = ik.solve_waypoints(ur5, [STALL_POSE], hints=[hint], seed=0)
    assert max(_errors(ur5, solution.q, STALL_POSE)) <= 1e-9
    lower, upper = ur5.limits.lower, ur5.limits.upper
    found, _, used = ik.pose_solutions(ur5, STALL_POSE, ur5.limits, np.random.default_rng(0))
    nearest = np.inf
    for s in found:  # joint by joint, the turn nearest the hint: the nearest variant
        best = np.array([values[np.argmin(np.abs(values - h))] for values, h in
                         zip(_turns_in_range(s.q, lower, upper), hint)])
        nearest = min(nearest, np.linalg.norm(best - hint))
    assert np.linalg.norm(solution.q - hint) == pytest.approx(nearest, abs=1e-9)
    assert solution.attempts == 1 + used


def test_a_hinted_waypoint_whose_solve_succeeds_reports_one_solve(ur5):
    """A hint whose own solve reaches the pose: one solve, one solution, the hint's (Pinocchio's FK)."""
    path = np.deg2rad([[10, -60, 80, -100, -90, 30], [20, -70, 90, -110, -80, 40]])
    poses = [_placement(ur5, q) for q in path]
    solutions = ik.solve_waypoints(ur5, poses, hints=list(path + np.deg2rad(2.0)))
    for solution, pose, q in zip(solutions, poses, path):
        assert (solution.attempts, solution.solutions, solution.chosen) == (1, 1, 0)
        assert max(_errors(ur5, solution.q, pose)) <= 1e-9
        assert np.abs(solution.q - q).max() < 1e-6


def test_a_hinted_pose_out_of_reach_names_its_waypoint_every_solve_and_the_best_residual(ur5, monkeypatch):
    """A hinted waypoint whose pose is out of reach (2 m away; the numeric search): the error names the
    waypoint, the solves made (the hint's and every random start's, counted by a wrapper) and the lowest
    residual of all of them, the hint's included."""
    _no_closed_form(monkeypatch)
    solve, residuals = ik.solve_pose, {}

    def counting(robot, target, *args, **kwargs):
        solution = solve(robot, target, *args, **kwargs)
        residuals.setdefault(id(target), []).append(
            (solution.residual, solution.position_error, solution.orientation_error))
        return solution

    monkeypatch.setattr(ik, "solve_pose", counting)
    hint = np.deg2rad([10, -60, 80, -100, -90, 30])
    near = _placement(ur5, hint)
    far = pin.SE3(near.rotation, near.translation + np.array([2.0, 0.0, 0.0]))
    with pytest.raises(IKError) as raised:
        ik.solve_waypoints(ur5, [near, far], hints=[None, hint])
    solves = residuals[id(far)]
    best = min(solves)
    assert raised.value.waypoint == 1 and len(solves) > 1
    assert f"waypoint 1: pose not reached within the joint ranges after {len(solves)} attempts; " in str(raised.value)
    assert raised.value.residual == best[0]
    assert f"best residual {best[1]:.3g} m, {np.rad2deg(best[2]):.3g} deg" in str(raised.value)


# --- the numeric search's starts, resting solutions ---------------------------------------------------------

def test_the_numeric_search_makes_its_starts_spread_over_the_ranges_and_counts_them(ur5, monkeypatch):
    """``pose_solutions`` without the closed form: exactly ``starts`` free (unclipped) solves, from
    configurations drawn independently per joint within the ranges (-pi..pi where a side is unbounded), and
    ``used`` counts them; each solution found reaches the pose (Pinocchio's FK)."""
    seeds = []
    solve = ik.solve_pose

    def recording(robot, target, seed, **kwargs):
        if not kwargs.get("clip", True):  # a free solve
            seeds.append(np.array(seed, dtype=float))
        return solve(robot, target, seed, **kwargs)

    monkeypatch.setattr(ik, "solve_pose", recording)
    lower = np.deg2rad([-100.0, -200.0, -np.inf, -300.0, -50.0, -360.0])
    upper = np.deg2rad([100.0, 0.0, 150.0, np.inf, 250.0, 360.0])
    limits = ur5.limits.with_overrides(lower=lower, upper=upper)
    robot = replace(ur5, limits=limits)
    q = np.deg2rad([10, -60, 80, -100, -90, 30])
    pose = _placement(ur5, q)
    for starts in (1, 5, 9):
        seeds.clear()
        found, _, used = ik.pose_solutions(robot, pose, limits, np.random.default_rng(starts), starts=starts,
                                           closed_form=False)
        assert used == starts == len(seeds)
        assert all(max(_errors(ur5, s.q, pose)) <= 1e-9 for s in found)
    low, high = np.where(np.isfinite(lower), lower, -np.pi), np.where(np.isfinite(upper), upper, np.pi)
    fractions = (np.array(seeds) - low) / (high - low)
    assert np.all((fractions >= 0) & (fractions <= 1))
    assert np.all(np.ptp(fractions, axis=1) > 0.05)  # the joints' fractions differ within each start


def _stationary(robot, q, lower, upper):
    """Whether the barrier's gradient (by hand) has no component along the self-motion at q (the null space of
    Pinocchio's tool Jacobian), relative to the gradient."""
    data = robot.model.createData()
    jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.model.getFrameId(robot.tool_frame), pin.LOCAL)
    gradient = _barrier_gradient(q, lower, upper)
    return np.linalg.norm(null_space(jacobian).T @ gradient) <= 1e-3 * np.linalg.norm(gradient)


def test_the_numeric_search_finds_a_redundant_arms_solutions_in_narrow_ranges_and_centres_them(panda):
    """A Panda pose searched within ranges 8 deg wide about a configuration reaching it, the random starts
    drawn over the robot's own (wide) ranges: the free solves land on the self-motion outside the narrow
    ranges, and solved again with clipping they reach the pose inside them. Each solution found reaches
    the pose (Pinocchio's FK), lies in the ranges and (a redundant arm) is centred: the barrier is
    stationary on its self-motion (by hand)."""
    q = np.deg2rad([10, -30, 20, -120, 10, 100, 40])
    below = np.deg2rad([3.0, 5.0, 3.0, 5.0, 3.0, 5.0, 3.0])  # asymmetric: q is not the centre
    lower, upper = q - below, q + np.deg2rad(8.0) - below
    narrow = panda.limits.with_overrides(lower=lower, upper=upper)
    pose = _placement(panda, q)
    found, _, _ = ik.pose_solutions(panda, pose, narrow, np.random.default_rng(0))
    assert found
    for solution in found:
        assert max(_errors(panda, solution.q, pose)) <= 1e-9
        assert np.all((solution.q >= lower) & (solution.q <= upper))
        assert _stationary(panda, solution.q, lower, upper)


def test_resting_solutions_are_the_searched_solutions_at_their_widest_turn_that_rest(ur5, monkeypatch):
    """``resting_solutions`` (the numeric search, seed 0 by default): the solutions ``pose_solutions`` finds
    with the same seed, each turned joint by joint to its widest margin (a brute force over the in-range
    turns), kept where ``rests`` holds at that configuration, in order; and the count of all of them."""
    _no_closed_form(monkeypatch)
    lower = np.deg2rad([-360.0, -200.0, -180.0, -360.0, -300.0, 0.0])
    upper = np.deg2rad([360.0, 20.0, 180.0, 360.0, 300.0, 530.0])
    limits = ur5.limits.with_overrides(lower=lower, upper=upper)
    pose = _placement(ur5, np.deg2rad([10, -60, 80, -100, -90, 30]))

    def rests(q):
        return q[2] > 0  # the elbow up

    for seed in (None, 4):
        kwargs = {} if seed is None else {"seed": seed}
        resting, count = ik.resting_solutions(ur5, pose, limits, rests, **kwargs)
        found, _, _ = ik.pose_solutions(ur5, pose, limits, np.random.default_rng(seed or 0))
        widest = [np.array([values[np.argmax(np.minimum(values - lo, hi - values))]
                            for values, lo, hi in zip(_turns_in_range(s.q, lower, upper), lower, upper)])
                  for s in found]
        expected = [q for q in widest if q[2] > 0]
        assert count == len(found) and 0 < len(expected) < len(found)
        np.testing.assert_allclose(resting, np.array(expected).reshape(-1, 6), rtol=0, atol=1e-12)


# --- described (tracked) sequences --------------------------------------------------------------------------

@pytest.mark.parametrize("numeric", [False, True])
def test_a_described_sequence_reports_residuals_jumps_margins_and_which_solution_it_is(puma, numeric, monkeypatch):
    """``described`` (the IK report of a sequence tracked along straight lines): per configuration its
    residuals (Pinocchio's FK), no DLS iterations, the search's solves, the jump from the previous one, its
    margin to the ranges (by hand) and which of the pose's distinct solutions (``pose_solutions`` with the
    same seed; equal up to 2 pi turns, by hand) it is, one more than them where it is none (a configuration
    off the pose)."""
    if numeric:
        _no_closed_form(monkeypatch)
    lower, upper = puma.limits.lower, puma.limits.upper
    path = np.deg2rad([[10, -30, 40, 20, 30, -100], [20, -40, 50, 10, 40, -95], [30, -50, 60, 0, 50, -80]])
    poses = [_placement(puma, q) for q in path]
    configurations = path.copy()
    configurations[1, 5] += 2 * np.pi  # the same solution in another turn (the wrist spans 532 deg)
    configurations[2] += np.deg2rad(1.0)  # off the pose
    solutions = ik.described(puma, poses, configurations, puma.limits, seed=3)
    rng = np.random.default_rng(3)
    previous = None
    for index, (solution, pose, q) in enumerate(zip(solutions, poses, configurations)):
        found, _, used = ik.pose_solutions(puma, pose, puma.limits, rng)
        same = [i for i, s in enumerate(found)
                if np.abs((q - s.q + np.pi) % (2 * np.pi) - np.pi).max() <= ik.DISTINCT]
        which = same[0] if same else len(found)
        assert (which < len(found)) == (index < 2)  # the last is off the pose
        assert (solution.chosen, solution.solutions) == (which, max(len(found), which + 1))
        assert (solution.attempts, solution.iterations) == (used, 0)
        assert np.array_equal(solution.q, q)
        assert (solution.position_error, solution.orientation_error) == pytest.approx(_errors(puma, q, pose),
                                                                                      abs=1e-12)
        assert solution.margin_deg == pytest.approx(_margin_deg(q, lower, upper), abs=1e-12)
        assert solution.jump == (0.0 if previous is None else pytest.approx(np.linalg.norm(q - previous)))
        previous = q
    assert solutions[2].position_error > 1e-3


# --- input and refusal messages ----------------------------------------------------------------------------

def test_waypoint_input_errors_say_what_is_wrong(puma):
    """``solve_waypoints`` refuses, saying how: hints not one per waypoint, an unknown branch rule (naming
    the known ones) and a start of the wrong length."""
    poses = [puma.forward_kinematics(np.zeros(6))] * 2
    with pytest.raises(InputError, match=r"^1 hints for 2 waypoints$"):
        ik.solve_waypoints(puma, poses, hints=[None])
    with pytest.raises(InputError, match=r"^unknown IK branch rule 'shortest'; known: optimal, continuous$"):
        ik.solve_waypoints(puma, poses, branch="shortest")
    with pytest.raises(InputError, match=r"^IK start has 4 values, robot has 6 joints$"):
        ik.solve_waypoints(puma, poses, start=np.zeros(4))


def _variants(q, lower, upper):
    return int(np.prod([len(values) for values in _turns_in_range(q, lower, upper)]))


def test_exactly_the_most_candidates_are_compared_and_a_joint_spanning_one_turn_is_not_blamed(puma):
    """The optimal rule compares up to ``MAX_CANDIDATES`` turn variants per waypoint: five joints of
    +-720 deg (4 turns each of 0.5 rad) and one of exactly +-180 deg give 4^5 = 1024 variants (counted by
    hand), which are compared; twice as many are refused, and the refusal names the five joints spanning
    more than 360 deg, not the one spanning exactly 360 deg."""
    lower = np.deg2rad([-720.0] * 5 + [-180.0])
    upper = np.deg2rad([720.0] * 5 + [180.0])
    limits = JointLimits.create(6, lower=lower, upper=upper)
    q = np.full(6, 0.5)
    assert _variants(q, lower, upper) == ik.MAX_CANDIDATES
    one = ik.IKSolution(q, 0.0, 0.0, 1)
    ik._check_candidate_count(puma, limits, 3, [one])
    with pytest.raises(IKError, match=r"^waypoint 3: its 2 IK solutions have 2048 variants") as raised:
        ik._check_candidate_count(puma, limits, 3, [one, one])
    listed = re.search(r"spans more than 360 deg: (.*)\. Narrow", str(raised.value))
    assert listed and [item.split(" (")[0] for item in listed[1].split(", ")] == puma.joint_names[:5]


@pytest.mark.parametrize("low, high", [(500.0, 520.0), (-480.0, -460.0), (100.0, 120.0)])
def test_a_pose_reachable_outside_a_range_names_a_true_turn_of_a_solution_nearest_the_range(ur5, low, high):
    """UR5, only the shoulder-lift joint's range narrowed away from every solution of the pose (beyond a turn,
    either side): the message names that joint at a value that is a 2 pi turn of one of the pose's
    solutions (the wide-range search; the value's FK reaches the pose with the other joints of that
    solution), the turn within 180 deg of the range's middle, and the bound it passes."""
    lower, upper = ur5.limits.lower.copy(), ur5.limits.upper.copy()
    lower[1], upper[1] = np.deg2rad(low), np.deg2rad(high)
    pose = _placement(ur5, np.deg2rad([10.0, -60.0, 80.0, -100.0, -90.0, 30.0]))
    with pytest.raises(IKError) as raised:
        ik.solve_waypoints(ur5, [pose], limits=ur5.limits.with_overrides(lower=lower, upper=upper))
    found = re.search(r"joint shoulder_lift_joint at (-?[\d.]+) deg, beyond its (upper|lower) limit (-?[\d.]+) deg",
                      str(raised.value))
    assert found, str(raised.value)
    value, side, bound = float(found[1]), found[2], float(found[3])
    assert abs(value - (low + high) / 2) <= 180
    assert (side, bound) == (("lower", low) if value < low else ("upper", high))
    solutions, _, _ = ik.pose_solutions(ur5, pose, ur5.limits, np.random.default_rng(0))
    reaching = []
    for s in solutions:
        q = s.q.copy()
        q[1] = np.deg2rad(value)
        reaching.append(max(_errors(ur5, q, pose)))
    assert min(reaching) <= 1e-4  # the value is printed to 6 significant digits


def test_a_free_solve_landing_outside_the_ranges_is_solved_again_with_clipping_and_kept(panda, monkeypatch):
    """A redundant arm's free solve can land on the pose's self-motion outside the ranges (no 2 pi turn
    inside); solved again with clipping from there it slides inside. With one start each, drawn as the
    search draws them, the seeds whose free solve lands outside (found here with a free solve of our own)
    still give a solution that reaches the pose (Pinocchio's FK) inside the ranges for some of them: only
    the second solve can have found it. (Without it, every such search came back empty.)"""
    _no_closed_form(monkeypatch)
    q = np.array([0.3, -0.4, 0.2, -2.0, 0.1, 1.8, 0.5])
    pose = _placement(panda, q)
    lower, upper = panda.limits.lower, panda.limits.upper
    kept = 0
    for seed in range(30):
        low, high = ik._finite_ranges(panda)
        start = low + (high - low) * np.random.default_rng(seed).random(panda.dof)
        free = ik.solve_pose(panda, pose, start, clip=False)
        turn_inside = all(len(turns) for turns in _turns_in_range(free.q, lower, upper))
        if max(_errors(panda, free.q, pose)) > 1e-9 or turn_inside:
            continue  # not reached, or reached with a turn inside the ranges: the first solve suffices
        found, _, used = ik.pose_solutions(panda, pose, panda.limits, np.random.default_rng(seed), starts=1)
        assert used == 1
        for solution in found:
            assert max(_errors(panda, solution.q, pose)) <= 1e-9
            assert np.all((solution.q >= lower) & (solution.q <= upper))
        kept += bool(found)
    assert kept >= 2


def test_a_hint_that_misses_on_an_arm_without_a_closed_form_falls_back_to_its_random_search(panda):
    """A Panda (no closed form) waypoint whose hint's solve stalls (clipped at a range bound): the waypoint
    takes the pose's solution nearest the hint from the numeric search, whose random starts come from the
    plan's seeded generator. The solution reaches the pose (Pinocchio's FK) within the ranges, the same
    for the same seed."""
    q = np.array([0.3, -0.4, 0.2, -2.0, 0.1, 1.8, 0.5])
    pose = _placement(panda, q)
    hint = np.deg2rad([45.5, -46.5, -152.4, -173.2, 104.0, 196.2, 35.4])
    assert ik.solve_pose(panda, pose, hint).residual > 1e-3  # the case: the hint's own solve misses
    solved = [ik.solve_waypoints(panda, [pose], hints=[hint], seed=4)[0] for _ in range(2)]
    assert max(_errors(panda, solved[0].q, pose)) <= 1e-9
    assert np.all((solved[0].q >= panda.limits.lower) & (solved[0].q <= panda.limits.upper))
    assert solved[0].attempts > 1
    np.testing.assert_array_equal(solved[0].q, solved[1].q)
