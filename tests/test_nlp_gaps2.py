"""Gaps in the tests of planner/timing/nlp.py (TimingNLP.solve, the certificates, the program, robot_refine, ...)
found by mutation testing (mutmut 3.8.1, second pass over the whole module)."""

from pathlib import Path

import numpy as np
import pytest

import planner.timing.nlp as nlp
from conftest import pendulum, record_solves
from planner import JointLimits, paper
from planner.timing import TimingProblem, optimize
from planner.timing.result import SOLVED

VIA = np.deg2rad(paper.VIA_POINTS_DEG)
PUMA = Path(__file__).resolve().parents[1] / "robots" / "puma560.urdf"
GRAVITY = 9.81  # Pinocchio's default [m/s^2]


def _uniform_start(problem: TimingProblem) -> np.ndarray:
    """Equal durations, repaired (feasible and tight)."""
    return problem.evaluate(np.ones((1, problem.segment_count))).durations[0]


# ------------------------------------------------------------------ TimingNLP.solve: rounds and counts

@pytest.mark.parametrize("family, rounds", [("hybrid", 1), ("quintic", 2)])
def test_rounds_and_iterations_are_those_of_the_solves_made(monkeypatch, family, rounds):
    """The rounds stop as soon as the exact check passes: the hybrid spline through the paper's via-points
    (exact rows, no certificate needed) after its first solve; the quintic after its second (the first
    leaves extremes inside segments beyond their bounds, which cuts then hold). The outcome reports one
    round per IPOPT solve made and the sum of their iterations."""
    certificates: list[int] = []
    counts = record_solves(monkeypatch, certificates)
    problem = TimingProblem(VIA, family, paper.paper_limits())
    start = _uniform_start(problem)
    outcome = nlp.TimingNLP(problem, start).solve(start)
    assert len(counts) == rounds and min(counts) > 0
    assert outcome.rounds == rounds
    assert outcome.iterations == sum(counts)
    assert outcome.certificates == certificates[-1] and (outcome.certificates > 0) == (family == "quintic")
    assert outcome.status == "Solve_Succeeded"
    assert problem.evaluate_durations(outcome.durations[None]).feasible[0]


def test_the_rounds_stop_at_max_rounds(monkeypatch):
    """With MAX_ROUNDS 1, the case above (two rounds) stops after one solve, whatever it left."""
    counts = record_solves(monkeypatch)
    monkeypatch.setattr(nlp, "MAX_ROUNDS", 1)
    problem = TimingProblem(VIA, "quintic", paper.paper_limits())
    start = _uniform_start(problem)
    outcome = nlp.TimingNLP(problem, start).solve(start)
    assert len(counts) == 1 and outcome.rounds == 1 and outcome.iterations == counts[0]


def test_a_first_round_ipopt_does_not_solve_returns_the_start(monkeypatch):
    """IPOPT stopped before any iteration (max_iter 0): its solution is discarded, so the outcome is the
    start itself, one round, no iterations, IPOPT's status, and no via-point states."""
    monkeypatch.setattr(nlp, "IPOPT_OPTIONS", {**nlp.IPOPT_OPTIONS, "ipopt.max_iter": 0})
    problem = TimingProblem(VIA, "hybrid", paper.paper_limits())
    start = _uniform_start(problem) * 1.5
    outcome = nlp.TimingNLP(problem, start).solve(start)
    assert outcome.status not in SOLVED and outcome.status == "Maximum_Iterations_Exceeded"
    np.testing.assert_array_equal(outcome.durations, start)
    assert (outcome.rounds, outcome.iterations, outcome.certificates) == (1, 0, 0)
    assert outcome.states is None


def _accept_any_point(monkeypatch):
    """IPOPT's convergence tolerances so loose that it stops at its starting point (iteration 0, solved)."""
    loose = {f"ipopt.{name}": 1e20 for name in ("tol", "constr_viol_tol", "dual_inf_tol", "compl_inf_tol")}
    monkeypatch.setattr(nlp, "IPOPT_OPTIONS", {**nlp.IPOPT_OPTIONS, **loose})


@pytest.mark.parametrize("family", ["hybrid", "quintic"])
def test_ipopt_starts_from_the_given_durations(monkeypatch, family):
    """Where IPOPT accepts its starting point as it is (no iteration), the solve returns the start's own
    durations: the start (a feasible one, 30 % slower than needed) is where the NLP begins."""
    _accept_any_point(monkeypatch)
    problem = TimingProblem(VIA, family, paper.paper_limits())
    start = _uniform_start(problem) * 1.3
    outcome = nlp.TimingNLP(problem, start).solve(start)
    assert (outcome.status, outcome.iterations, outcome.rounds) == ("Solve_Succeeded", 0, 1)
    np.testing.assert_allclose(outcome.durations, start, rtol=1e-12, atol=0)


def _tamper_solves(monkeypatch, status: str, change):
    """Have every IPOPT solve report ``status`` and return its solution passed through ``change`` (a function of
    the solution vector and the segment count): a stand-in for a solver that fails or returns garbage."""
    build = nlp._Program.__init__

    def init(self, program_nlp, certificates, warm=False):
        build(self, program_nlp, certificates, warm)
        solver, segments = self.solver, program_nlp.problem.segment_count

        class Tampered:
            def __call__(self, **arguments):
                x = np.asarray(solver(**arguments)["x"], dtype=float).ravel()
                return {"x": change(x.copy(), segments)}

            def stats(self):
                return {**solver.stats(), "return_status": status}

        self.solver = Tampered()

    monkeypatch.setattr(nlp._Program, "__init__", init)


def _longer(x, segments):
    x[:segments] += np.log(2.0)  # every duration twice as long: still finite and positive
    return x


def _nan_state(x, segments):
    x[segments] = np.nan  # a knot state NaN, the durations fine
    return x


def _overflow(x, segments):
    x[0] = 1000.0  # exp overflows: an infinite duration
    return x


def _underflow(x, segments):
    x[0] = -1000.0  # exp underflows: a zero duration
    return x


@pytest.mark.parametrize("status, change", [("Infeasible_Problem_Detected", _longer), ("Solve_Succeeded", _nan_state),
                                            ("Solve_Succeeded", _overflow), ("Solve_Succeeded", _underflow)])
def test_a_round_not_solved_or_not_finite_is_discarded(monkeypatch, status, change):
    """A round IPOPT did not solve, or whose solution has a NaN, an infinite or a zero duration, is discarded:
    the outcome is the start, after that one round."""
    _tamper_solves(monkeypatch, status, change)
    problem = TimingProblem(VIA[:5], "hybrid", paper.paper_limits())
    start = _uniform_start(problem) * 1.2
    outcome = nlp.TimingNLP(problem, start).solve(start)
    assert outcome.rounds == 1 and outcome.status == status
    np.testing.assert_array_equal(outcome.durations, start)
    assert outcome.states is None


# ------------------------------------------------------------------ TimingNLP with a robot

def test_a_robot_without_limits_is_ignored():
    """RobotConstraints with neither a torque nor a tool-speed limit are not supported: the NLP leaves the robot
    out and solves exactly as without it."""
    from planner.robot import Robot
    from planner.timing.robot_rows import RobotConstraints

    unlimited = RobotConstraints(Robot.from_urdf(PUMA, "tool"), None, None)
    assert not unlimited.supported
    problem = TimingProblem(VIA, "hybrid", paper.paper_limits())
    start = _uniform_start(problem)
    with_robot = nlp.TimingNLP(problem, start, unlimited)
    assert with_robot.robot is None
    plain = nlp.TimingNLP(problem, start).solve(start)
    np.testing.assert_array_equal(with_robot.solve(start).durations, plain.durations)


def _pendulum_problem(tmp_path, torque=None, tool_speed=None):
    """The pendulum swinging through -90, 60, -30, 90 deg (hybrid), its kinematic limits far from binding,
    with a torque or tip-speed limit; and a slow start (3 times the repaired equal durations)."""
    from planner.timing.robot_rows import RobotConstraints

    via = np.deg2rad([[-90.0], [60.0], [-30.0], [90.0]])
    limits = JointLimits.create(1, velocity=np.deg2rad([400.0]), acceleration=np.deg2rad([4000.0]),
                                jerk=np.deg2rad([40000.0]))
    problem = TimingProblem(via, "hybrid", limits)
    constraints = RobotConstraints(pendulum(tmp_path), None if torque is None else np.array([torque]),
                                   tool_speed)
    return problem, constraints, _uniform_start(problem) * 3


def test_torque_rounds_go_on_until_the_frozen_model_settles(tmp_path, monkeypatch):
    """The torque rows hold the robot model frozen at the previous round's trajectory: the first round's
    model (the slow start's) is off, so a second round solves with the model frozen at the first one's
    result, and then stops (model settled, exact check passed). The result reaches the 12 N m limit by the
    closed form, densely sampled, within the model tolerance (1e-3 of the limit)."""
    counts = record_solves(monkeypatch)
    problem, constraints, start = _pendulum_problem(tmp_path, torque=12.0)
    outcome = nlp.TimingNLP(problem, start, constraints).solve(start)
    assert outcome.rounds == len(counts) == 2 and outcome.status == "Solve_Succeeded"
    trajectory = problem.trajectory(outcome.durations)
    times = np.linspace(0.0, trajectory.total_time, 20001)
    q, qdd = trajectory.evaluate(times, 0)[:, 0], trajectory.evaluate(times, 2)[:, 0]
    torque = (0.03 + 2.0 * 0.5**2) * qdd - 2.0 * GRAVITY * 0.5 * np.cos(q)
    assert np.abs(torque).max() / 12.0 == pytest.approx(1.0, abs=1e-3)


def test_every_program_with_robot_rows_is_built_with_the_warm_settings(tmp_path, monkeypatch):
    """A robot round's start is the last round's solution or a slow, feasible start, near the optimum's
    active set either way: every program with robot rows, the first round's too, gets
    ``WARM_IPOPT_OPTIONS``; a program without them starts cold in its first round."""
    built: list[tuple[bool, bool]] = []
    build = nlp._Program.__init__

    def init(self, program_nlp, program_certificates, warm=False):
        build(self, program_nlp, program_certificates, warm)
        built.append((program_nlp.robot is not None, warm))

    monkeypatch.setattr(nlp._Program, "__init__", init)
    problem, constraints, start = _pendulum_problem(tmp_path, torque=12.0)
    nlp.TimingNLP(problem, start, constraints).solve(start)
    nlp.TimingNLP(problem, start).solve(start)
    assert built[0] == (True, True) and all(warm for robot, warm in built if robot)
    assert (False, False) in built


# ------------------------------------------------------------------ certificates

def _cubic_certified_on_grid(coefficients: np.ndarray, step: float = 0.04, top: float = 6.0) -> np.ndarray:
    """(P,) whether some (a0, a2) on a grid over [0, top]^2 makes every row of ``cubic_certificate`` >= 0 for
    each cubic (P, 4)."""
    grid = np.arange(0.0, top + step / 2, step)
    a0, a2 = (g.ravel()[None] for g in np.meshgrid(grid, grid))
    p = [coefficients[:, k, None] for k in range(4)]
    rows = nlp.cubic_certificate(p, a0, a2)
    return np.all([np.broadcast_to(row, np.broadcast(*rows).shape) >= 0 for row in rows], axis=0).any(axis=1)


def test_the_cubic_certificate_is_exact():
    """Lukacs: p >= 0 on [0, 1] if and only if some a0, a2 >= 0 satisfy the four rows. For 150 random cubics
    (coefficients in [-2, 2], then shifted so their minimum over [0, 1] lies in [-1, 1], away from 0 by at
    least 0.05), the rows hold for a point of a fine grid of (a0, a2) exactly where the dense minimum is >= 0."""
    rng = np.random.default_rng(7)
    coefficients = rng.uniform(-2.0, 2.0, (150, 4))
    s = np.linspace(0.0, 1.0, 4001)
    values = coefficients @ s[None] ** np.arange(4)[:, None]
    lowest = values.min(axis=1)
    target = np.where(rng.uniform(size=150) < 0.5, rng.uniform(0.05, 1.0, 150), -np.geomspace(0.002, 1.0, 150))
    coefficients[:, 0] += target - lowest
    nonnegative = target > 0
    np.testing.assert_array_equal(_cubic_certified_on_grid(coefficients), nonnegative)
    assert 40 < nonnegative.sum() < 110  # both kinds well represented


def test_the_cubic_certificate_of_a_cubic_vanishing_at_0_is_exact():
    """p0 = 0 (the quantity on its bound at the segment's start, as at an active knot): the last row forces
    a0 = p1, and then p >= 0 on [0, 1] if and only if some a2 >= 0 satisfies the rows. 200 random such
    cubics with p1 >= 0, their minimum over [0, 1] at least 1e-3 from 0 where negative."""
    rng = np.random.default_rng(11)
    coefficients = rng.uniform(-2.0, 2.0, (200, 4))
    coefficients[:, 0], coefficients[:, 1] = 0.0, np.abs(coefficients[:, 1])
    s = np.linspace(0.0, 1.0, 4001)
    lowest = (coefficients @ s[None] ** np.arange(4)[:, None]).min(axis=1)
    keep = (lowest >= 0) | (lowest < -1e-3)
    coefficients, lowest = coefficients[keep], lowest[keep]
    a2 = np.arange(0.0, 8.0, 1e-3)[None]
    p = [coefficients[:, k, None] for k in range(4)]
    rows = nlp.cubic_certificate(p, p[1], a2)
    certified = np.all([np.broadcast_to(row, (len(coefficients), a2.shape[1])) >= 0 for row in rows], axis=0)
    np.testing.assert_array_equal(certified.any(axis=1), lowest >= 0)
    assert 20 < (lowest >= 0).sum() < len(coefficients) - 20


def test_a_cut_evaluates_its_polynomial_at_its_centre_and_exact_kinds_keep_every_coefficient():
    """``Certificate.model`` maps f's coefficients (power by power) to the certified polynomial's: for a cut,
    f's value at the centre (one row); for the exact kinds, the coefficients themselves."""
    f = np.array([0.7, -1.3, 2.1, 0.4, -0.9])
    cut = nlp.Certificate(0, 0, 0, 1, 1, 4, centre=0.37)
    assert cut.kind == "cut" and cut.model().shape == (1, 5)
    assert (cut.model() @ f)[0] == pytest.approx(np.polynomial.polynomial.polyval(0.37, f), rel=1e-14)
    for degree, kind in ((2, "quadratic"), (3, "cubic")):
        exact = nlp.Certificate(0, 0, 0, 1, -1, degree)
        assert exact.kind == kind
        np.testing.assert_array_equal(exact.model() @ f[:degree + 1], f[:degree + 1])


def _dense_ratio(problem: TimingProblem, durations: np.ndarray, states=None) -> float:
    """The largest |q^(d)| / limit over velocity, acceleration and jerk, sampled at 20001 points."""
    trajectory = problem.trajectory(durations, states)
    times = np.linspace(0.0, trajectory.total_time, 20001)
    return max(float((np.abs(trajectory.evaluate(times, order)) / problem.limits.magnitudes[order - 1]).max())
               for order in (1, 2, 3))


@pytest.mark.parametrize("seed, rounds", [(4, 3), (5, 8)])
def test_later_rounds_add_cuts_to_those_of_earlier_ones(seed, rounds):
    """Two random 2-joint quintics through 4 via-points whose cuts take several rounds (each adding cuts to
    the earlier rounds' certificates): one solve from equal durations reaches the optimum of a 3-start
    SLSQP (an independent solver) within 1e-6, and its repaired result, densely sampled, reaches a limit
    and breaks none."""
    from planner.timing import optimize

    rng = np.random.default_rng(seed)
    via = rng.uniform(-2.0, 2.0, (4, 2))
    limits = JointLimits.create(2, velocity=rng.uniform(0.5, 2, 2), acceleration=rng.uniform(0.5, 3, 2),
                                jerk=rng.uniform(1, 10, 2))
    problem = TimingProblem(via, "quintic", limits)
    start = _uniform_start(problem)
    outcome = nlp.TimingNLP(problem, start).solve(start)
    assert outcome.rounds == rounds and outcome.status == "Solve_Succeeded"
    repaired = problem.evaluate(outcome.durations[None])
    independent = optimize(problem, "slsqp", starts=3, iterations=100, seed=seed)
    assert repaired.objective[0] == pytest.approx(independent.total_time, rel=1e-6)
    assert 1 - 1e-6 <= _dense_ratio(problem, repaired.durations[0]) <= 1 + 1e-9


def _faster(x, segments):
    x[:segments] -= np.log(2.0)  # every duration halved: the limits broken at the knots
    return x


def test_a_round_that_fails_the_check_with_nothing_to_certify_ends_the_rounds(monkeypatch):
    """A cubic with jerk limits only has nothing to certify inside a segment (its jerk is constant there).
    A solved round whose result breaks the limits (the solver's durations halved) then ends the rounds at
    once: one round, no certificate, that result returned as it is (the caller repairs it)."""
    problem = TimingProblem(VIA, "cubic", JointLimits.create(6, jerk=np.deg2rad([60, 66, 85, 70, 75, 70])))
    start = _uniform_start(problem)
    solved = nlp.TimingNLP(problem, start).solve(start)
    assert solved.rounds == 1 and problem.evaluate_durations(solved.durations[None]).feasible[0]
    _tamper_solves(monkeypatch, "Solve_Succeeded", _faster)
    outcome = nlp.TimingNLP(problem, start).solve(start)
    assert (outcome.rounds, outcome.certificates, outcome.status) == (1, 0, "Solve_Succeeded")
    np.testing.assert_allclose(outcome.durations, solved.durations / 2, rtol=1e-9)
    assert not problem.evaluate_durations(outcome.durations[None]).feasible[0]


@pytest.mark.parametrize("family", ["cubic", "hybrid"])
@pytest.mark.parametrize("offset", [-10.0, 10.0])
def test_position_ranges_far_from_zero_bind_inside_segments_exactly(family, offset):
    """The paper's via-points moved 10 rad down or up, every range 5 deg beyond them (as in
    test_position_range_is_respected, where the bounds straddle 0): positions peak inside segments
    beyond the range unless certified, and the flag band must not depend on where the range sits.
    From equal durations one solve reaches the optimum of the same problem at 0 offset, and densely sampled
    positions stay within the range, touching it."""
    margin = np.deg2rad(5.0)
    optima = []
    for shift in (0.0, offset):
        via = VIA + shift
        limits = paper.paper_limits().with_overrides(lower=via.min(axis=0) - margin, upper=via.max(axis=0) + margin)
        problem = TimingProblem(via, family, limits)
        start = _uniform_start(problem)
        outcome = nlp.TimingNLP(problem, start).solve(start)
        repaired = problem.evaluate(outcome.durations[None])
        assert repaired.feasible[0] and outcome.certificates > 0
        trajectory = problem.trajectory(repaired.durations[0])
        positions = trajectory.evaluate(np.linspace(0.0, trajectory.total_time, 20001))
        assert np.all(positions <= limits.upper + 1e-9) and np.all(positions >= limits.lower - 1e-9)
        optima.append(repaired.objective[0])
    assert optima[1] == pytest.approx(optima[0], rel=1e-7)


# ------------------------------------------------------------------ the position-range fallback

def test_the_range_fallback_start_is_feasible_and_the_same_every_time():
    """Ranges 10 deg beyond the paper's via-points: equal durations leave them (cubic), some random shapes do not.
    ``_range_feasible_start`` returns a start that is feasible as it is, its positions, densely sampled, within the
    ranges, the tracker's best; and, its shapes drawn with a fixed seed, the same start on every call."""
    from planner.timing.result import SearchTracker

    margin = np.deg2rad(10.0)
    limits = paper.paper_limits().with_overrides(lower=VIA.min(axis=0) - margin, upper=VIA.max(axis=0) + margin)
    problem = TimingProblem(VIA, "cubic", limits)
    assert not problem.evaluate(np.ones((1, problem.segment_count))).feasible[0]
    tracker = SearchTracker(problem)
    start = nlp._range_feasible_start(problem, tracker)
    evaluation = problem.evaluate_durations(start[None])
    assert evaluation.feasible[0] and tracker.best_objective == pytest.approx(evaluation.objective[0], rel=1e-12)
    trajectory = problem.trajectory(start)
    positions = trajectory.evaluate(np.linspace(0.0, trajectory.total_time, 20001))
    assert np.all(positions <= limits.upper + 1e-9) and np.all(positions >= limits.lower - 1e-9)
    np.testing.assert_array_equal(nlp._range_feasible_start(problem, SearchTracker(problem)), start)


def test_the_walk_back_from_outside_a_range_offers_the_first_feasible_point_of_the_path():
    """``_towards`` offers the tracker the durations h(l) = outside^(1 - l) inside^l nearest ``outside`` that are
    feasible. With ``outside`` equal durations (beyond the 10 deg ranges) and ``inside`` the fallback's feasible
    start, a dense scan of the same path (4097 points) finds the first feasible l; the tracker's best lies
    between the best feasible point of the scan and the scan's first feasible one (to 1e-3)."""
    from planner.timing.result import SearchTracker

    margin = np.deg2rad(10.0)
    limits = paper.paper_limits().with_overrides(lower=VIA.min(axis=0) - margin, upper=VIA.max(axis=0) + margin)
    problem = TimingProblem(VIA, "cubic", limits)
    outside = np.ones(problem.segment_count)
    inside = nlp._range_feasible_start(problem, SearchTracker(problem))
    tracker = SearchTracker(problem)
    nlp._towards(problem, tracker, outside, inside)
    share = np.linspace(0.0, 1.0, 4097)[:, None]
    scan = problem.evaluate(outside[None] ** (1 - share) * inside[None] ** share)
    first = int(np.argmax(scan.feasible))
    assert 0 < first and scan.feasible[first]
    lowest = scan.objective[scan.feasible].min()
    assert lowest * (1 - 1e-3) <= tracker.best_objective <= scan.objective[first] * (1 + 1e-3)


# ------------------------------------------------------------------ starts side by side under a time limit

def test_starts_side_by_side_under_a_time_limit_keep_what_was_solved_and_mark_what_ran_over(monkeypatch):
    """From CONCURRENT_SEGMENTS segments, under a time limit, each start is solved in its own process, ended at
    the limit. A start solved in time keeps its outcome; one that runs over comes back as the start itself,
    marked OUT_OF_TIME, with no iteration, round or certificate. The solve is stubbed (the fast start halves its
    durations; the slow one sleeps)."""
    import time

    from planner.timing.result import time_limit

    via = np.cumsum(np.random.default_rng(3).uniform(-0.5, 0.5, (nlp.CONCURRENT_SEGMENTS + 2, 1)), axis=0)
    problem = TimingProblem(via, "cubic", JointLimits.create(1, velocity=[1.0], acceleration=[2.0], jerk=[10.0]))
    assert nlp._concurrent(problem)
    start = _uniform_start(problem)

    def solve(self, durations, report=None):
        if durations[0] > start[0]:
            time.sleep(600)
        return nlp.NLPOutcome(np.asarray(durations) / 2, 7, 2, "Solve_Succeeded", 3)

    monkeypatch.setattr(nlp.TimingNLP, "solve", solve)
    timing = nlp.TimingNLP(problem, start)
    with time_limit(1.5):
        fast, slow = nlp._solve_all(timing, [start, start * 2])
    assert (fast.iterations, fast.rounds, fast.status, fast.certificates) == (7, 2, "Solve_Succeeded", 3)
    np.testing.assert_array_equal(fast.durations, start / 2)
    assert (slow.iterations, slow.rounds, slow.status, slow.certificates) == (0, 0, nlp.OUT_OF_TIME, 0)
    np.testing.assert_array_equal(slow.durations, start * 2)
    assert slow.states is None and not timing.deadline_enforced


@pytest.mark.parametrize("family", ["hermite7", "hybrid"])
def test_robot_refine_slows_a_result_beyond_a_kinematic_limit_down_with_its_own_states(tmp_path, monkeypatch, family):
    """Where the robot rounds leave a kinematic limit exceeded, ``robot_refine`` slows the result down by the
    time-scaling lemma, with the NLP's own via-point states where the family's are free (``hermite7``:
    ``evaluate_states``; the family's rule would give another trajectory), and returns those states
    scaled; a result within every limit is returned as it is. The solve is replaced by a known outcome:
    an optimum run 10 % fast, or 5 % slow."""
    from planner.timing import optimize
    from planner.timing.robot_rows import RobotConstraints
    robot = pendulum(tmp_path)
    via = np.deg2rad([[-90.0], [60.0], [-30.0], [90.0]])
    problem = TimingProblem(via, family, JointLimits.create(1, velocity=[7.0], acceleration=[70.0], jerk=[700.0]))
    optimum = optimize(problem, "nlp")
    states = optimum.knot_states
    assert (states is not None) == (family == "hermite7")
    for factor in (0.9, 1.05):
        fast = optimum.durations * factor
        outcome = nlp.NLPOutcome(fast, 1, 1, "Solve_Succeeded", 0, states)
        monkeypatch.setattr(nlp.TimingNLP, "solve", lambda self, start, outcome=outcome: outcome)
        durations, returned = nlp.robot_refine(problem, RobotConstraints(robot, np.array([20.0]), None), fast)
        if factor > 1:  # within every limit: kept as solved (not sped up: the robot's limits may bind)
            assert np.array_equal(durations, fast) and (returned is states or np.array_equal(returned, states))
            continue
        expected = (problem.evaluate(fast[None]) if states is None
                    else problem.evaluate_states(fast[None], states[None]))
        assert durations.sum() > fast.sum() * 1.01
        np.testing.assert_allclose(durations, expected.durations[0], rtol=1e-12)
        if states is None:
            assert returned is None
        else:
            np.testing.assert_allclose(returned, expected.states[0], rtol=1e-12)
            assert problem.evaluate_states(durations[None], returned[None]).feasible[0]
            assert not np.allclose(durations, problem.evaluate(fast[None]).durations[0], rtol=1e-6)


def test_a_later_rounds_program_starts_from_the_earlier_solution_row_by_row():
    """A round with certificates added starts from the last round's solution and multipliers
    (``_Program.carried``): each kept row, told apart by its value, and each kept certificate variable
    carry over; the new ones start at the given start with zero multipliers."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    limits = paper.paper_limits()
    problem = TimingProblem(via, "hybrid", limits.with_overrides(lower=via.min(axis=0) - 0.02,
                                                                 upper=via.max(axis=0) + 0.02))
    optimum = nlp.TimingNLP(problem, np.full(problem.segment_count, 3.0)).solve(np.full(problem.segment_count, 3.0))
    solver = nlp.TimingNLP(problem, optimum.durations)
    h = optimum.durations
    coefficients = problem.coefficients(h[None])[0]
    every, _ = solver._certify([], coefficients, h)
    earlier, later = every[::2], every
    assert [c.kind for c in every[::2]].count("cubic") >= 2 and [c.kind for c in every[1::2]].count("cubic") >= 2
    # (exact certificates with two variables each, kept and new: the ranges bind inside segments)
    core = np.concatenate((np.log(h / solver.scales.time), solver.formulation.state_values(coefficients, h)))
    first = solver._program(earlier)
    solution = first.solver(x0=np.concatenate((core, solver._certificate_start(earlier, coefficients, h))),
                            lbx=first.lbx, ubx=first.ubx, lbg=first.lbg, ubg=first.ubg, p=np.zeros(0))
    assert first.solver.stats()["return_status"] in SOLVED
    second = solver._program(later, warm=True)
    given = np.concatenate((core, solver._certificate_start(later, coefficients, h)))
    start = first.carried(solution, second, given)
    x, lam_g = solution["x"].full().ravel(), solution["lam_g"].full().ravel()
    lam_x = solution["lam_x"].full().ravel()
    assert np.any(lam_x[first.core_size:])  # (some certificate variable sits on its bound: the check below bites)
    g_first = first.solver.get_function("nlp_g")(x, np.zeros(0)).full().ravel()
    g_second = second.solver.get_function("nlp_g")(start["x0"], np.zeros(0)).full().ravel()
    np.testing.assert_allclose(g_second[second.spline_rows], g_first[first.spline_rows], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(start["lam_g0"][second.spline_rows], lam_g[first.spline_rows])
    np.testing.assert_array_equal(start["x0"][:first.core_size], x[:first.core_size])
    for certificate in later:
        rows, variables = second.certificate_rows[certificate], second.certificate_variables[certificate]
        if certificate in first.certificate_rows:
            old_rows = first.certificate_rows[certificate]
            np.testing.assert_allclose(g_second[rows], g_first[old_rows], rtol=1e-12, atol=1e-12)
            np.testing.assert_array_equal(start["lam_g0"][rows], lam_g[old_rows])
            np.testing.assert_array_equal(start["x0"][variables], x[first.certificate_variables[certificate]])
            np.testing.assert_array_equal(start["lam_x0"][variables],
                                          lam_x[first.certificate_variables[certificate]])
        else:
            assert not np.any(start["lam_g0"][rows]) and not np.any(start["lam_x0"][variables])
            np.testing.assert_array_equal(start["x0"][variables], given[variables])
    assert sum(map(len, second.certificate_rows.values())) + len(second.spline_rows) == len(second.lbg)


def _assert_partitioned(program) -> None:
    """The program's variables past the core are exactly its certificates' (one owner each) and the robot
    rows' samples', and its constraint rows exactly its spline's, robot's, samples' and certificates' rows."""
    from itertools import chain
    variables = sorted(chain(chain.from_iterable(map(list, program.certificate_variables.values())),
                             program.sampled_variables))
    assert variables == list(range(program.core_size, len(program.lbx)))
    rows = sorted(chain(program.spline_rows, program.robot_rows, program.sampled_rows,
                        chain.from_iterable(map(list, program.certificate_rows.values()))))
    assert rows == list(range(len(program.lbg)))


def test_certificates_of_both_kinds_own_disjoint_variables_and_rows():
    """Quadratic and cubic certificates in one program (ranges of +-0.02 rad around the paper's via-points,
    durations 0.7 of the optimum, every extreme cut): each variable and row has one owner."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    problem = TimingProblem(via, "hybrid", paper.paper_limits().with_overrides(lower=via.min(axis=0) - 0.02,
                                                                              upper=via.max(axis=0) + 0.02))
    optimum = nlp.TimingNLP(problem, np.full(problem.segment_count, 3.0)).solve(np.full(problem.segment_count, 3.0))
    solver = nlp.TimingNLP(problem, optimum.durations)
    h = 0.7 * optimum.durations
    every, _ = solver._certify([], problem.coefficients(h[None])[0], h, everywhere=True)
    kinds = {c.kind for c in every}
    assert {"quadratic", "cubic"} <= kinds, kinds
    _assert_partitioned(solver._program(every))


def test_a_later_rounds_program_carries_the_robot_rows_multipliers(tmp_path):
    """With a torque limit (the pendulum swinging between +-88 deg, its range +-90.5 deg), a round with
    certificates added starts its robot rows from the last round's multipliers, row by row (the rows'
    values agree there too)."""
    from planner.timing.robot_rows import parameters
    problem, constraints, start = _pendulum_problem(tmp_path, torque=12.0)
    problem = TimingProblem(np.deg2rad([[-90.0], [88.0], [-88.0], [90.0]]), "hybrid",
                            problem.limits.with_overrides(lower=np.deg2rad([-90.5]), upper=np.deg2rad([90.5])))
    solver = nlp.TimingNLP(problem, start, constraints)
    h = start / 2
    coefficients = problem.coefficients(h[None])[0]
    model = parameters(solver._freeze(coefficients, h)).ravel(order="F")
    core = np.concatenate((np.log(h / solver.scales.time), solver.formulation.state_values(coefficients, h)))
    first = solver._program([])
    solution = first.solver(x0=first.start(core, np.zeros(0)), lbx=first.lbx, ubx=first.ubx, lbg=first.lbg,
                            ubg=first.ubg, p=model)
    assert first.solver.stats()["return_status"] in SOLVED
    x = solution["x"].full().ravel()
    every, _ = solver._certify([], coefficients, h, everywhere=True)
    assert every  # (the range binds inside segments)
    second = solver._program(every, warm=True)
    _assert_partitioned(first)
    _assert_partitioned(second)
    given = second.start(core, solver._certificate_start(every, coefficients, h))
    carried = first.carried(solution, second, given)
    lam_g = solution["lam_g"].full().ravel()
    assert len(second.robot_rows) == len(first.robot_rows) > 0 and np.any(lam_g[first.robot_rows])
    np.testing.assert_array_equal(carried["lam_g0"][second.robot_rows], lam_g[first.robot_rows])
    g_first = first.solver.get_function("nlp_g")(x, model).full().ravel()
    g_second = second.solver.get_function("nlp_g")(carried["x0"], model).full().ravel()
    np.testing.assert_allclose(g_second[second.robot_rows], g_first[first.robot_rows], rtol=1e-12, atol=1e-12)
    # the samples' variables carried with the spline's, their rows' multipliers not (the model is refitted)
    assert len(second.sampled_rows) == len(first.sampled_rows) == len(first.sampled_variables) > 0
    np.testing.assert_array_equal(carried["x0"][second.sampled_variables], x[first.sampled_variables])
    np.testing.assert_allclose(g_second[second.sampled_rows], 0.0, atol=1e-9)
    assert not np.any(carried["lam_g0"][second.sampled_rows])


def test_starts_solved_one_after_another_are_not_begun_after_the_time_limit(monkeypatch):
    """Below ``CONCURRENT_SEGMENTS`` the starts run in this process: 1000 of them (Cuckoo Search's
    refine_starts) took a 5 s limit to 16 s, the limit looked at only once all were solved (sweep 22)."""
    import time

    from planner.timing.result import time_limit
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    start = problem.evaluate(np.ones((1, problem.segment_count))).durations[0]
    solver = nlp.TimingNLP(problem, start)
    solve = solver.solve
    begun: list[float] = []

    def slow(durations, report=None):
        begun.append(time.monotonic())
        time.sleep(0.05)
        return solve(durations, report)
    monkeypatch.setattr(solver, "solve", slow)
    with time_limit(0.3):
        limit = time.monotonic() + 0.3
        outcomes = nlp._solve_all(solver, [start] * 40)
    assert len(outcomes) == 40 and 1 <= len(begun) < 40
    assert all(moment <= limit for moment in begun)
    assert [o.status == nlp.OUT_OF_TIME for o in outcomes] == [False] * len(begun) + [True] * (40 - len(begun))
    assert outcomes[0].status in SOLVED  # (the last one begun may end at IPOPT's own wall-time limit)
    np.testing.assert_array_equal(outcomes[-1].durations, start)


@pytest.mark.parametrize("family", ["hermite7", "trigonometric"])
def test_a_feasible_task_every_start_fails_is_timed_at_rest_at_its_via_points(family):
    """A hunt's case (one joint, its range from the last via-point to the middle one, a slow velocity limit):
    every NLP start ended infeasible or outside the range, and the rule's shapes overshot the range by 1e-7
    deg, so the task was refused. At rest at every via-point each segment stays between its via-points: the
    timing is feasible (a plan, not a refusal), and dense sampling keeps it within the range and limits."""
    from conftest import dense_extremes

    via = np.deg2rad([[-19.625055497912495], [7.152343453939288], [-19.630469633254656]])
    limits = JointLimits.create(1, velocity=np.deg2rad([4.634844087688916]),
                                acceleration=np.deg2rad([4.969213348621558]), jerk=np.deg2rad([100.61247567248961]),
                                lower=np.deg2rad([-19.630469633254656]), upper=np.deg2rad([7.152343453939288]))
    problem = TimingProblem(via, family, limits)
    result = optimize(problem, "nlp")
    assert result.feasible
    trajectory = problem.trajectory(result.durations, result.knot_states)
    times = np.linspace(0.0, trajectory.knot_times[-1], 20001)
    positions = trajectory.evaluate(times, 0)
    assert positions.min() >= limits.lower[0] - 1e-9 and positions.max() <= limits.upper[0] + 1e-9
    largest, _, _ = dense_extremes(trajectory)
    assert np.all(largest <= limits.magnitudes * (1 + 1e-6))
