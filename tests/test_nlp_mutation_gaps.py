"""Gaps in the tests of planner/timing/nlp.py and planner/timing/formulations.py found by a hand
mutation-testing run: each test kills a mutant that survived the existing tests, checked against an
independent computation (dense sampling, SLSQP, the problem's own bounds and floor)."""

import numpy as np
import pytest

import planner.timing.nlp as nlp
from conftest import record_solves
from planner import JointLimits, paper
from planner.timing import TimingProblem, optimize
from planner.timing.nlp import TimingNLP, touch_certificate
from planner.timing.result import time_limit
from planner.timing.windows import WINDOW_IPOPT

VIA = np.deg2rad(paper.VIA_POINTS_DEG)


def _uniform_start(problem: TimingProblem) -> np.ndarray:
    """Equal durations, repaired (feasible and tight)."""
    return problem.evaluate(np.ones((1, problem.segment_count))).durations[0]


# ------------------------------------------------------------------ certificates

def test_the_touch_certificates_accept_exactly_the_cubics_that_stay_non_negative():
    """A cubic with a double root at the touched end, (1 - s)^2 (q2 + q3 (1 - s)) at s = 1 or s^2 (q2 + q3 s)
    at s = 0, is >= 0 on [0, 1] iff q2 >= 0 and q2 + q3 >= 0: the rows accept it exactly then, by dense
    sampling over a grid of (q2, q3) that includes q3 between -q2 and -q2 / 2 (a row q2 + 2 q3 would
    refuse those non-negative cubics: a plan resting on a range bound held back for nothing)."""
    s = np.linspace(0.0, 1.0, 2001)
    for q2 in np.linspace(-1.0, 1.0, 21):
        for q3 in np.linspace(-2.0, 2.0, 41):
            at_end = [q2 + q3, -2 * q2 - 3 * q3, q2 + 3 * q3, -q3]
            at_start = [0.0, 0.0, q2, q3]
            for touch, p in ((1, at_end), (0, at_start)):
                lowest = np.polynomial.Polynomial(p)(s).min()  # 0 at the double root where non-negative
                accepted = min(touch_certificate(p, touch)) >= -1e-12
                assert accepted == (lowest >= -1e-12), (touch, q2, q3, lowest)


def test_a_certificate_beside_a_via_point_resting_on_the_other_bound_is_not_a_touch():
    """One joint in [-1, 1] rad (cubic) through 0, 0.901, -1, -0.376, 1, -0.182, 0: it rests at -1 and at 1, and
    segments beside those via-points need position certificates on the far bound too. There the
    polynomial has no double root at the resting end, so the certificate is the exact cubic one; touch rows
    (which assume that double root) refuse the rise away from the bound and leave IPOPT at its iteration
    cap 4.5 % above the optimum. The NLP is no worse than SLSQP on the same problem."""
    via = np.array([0.0, 0.901, -1.0, -0.376, 1.0, -0.182, 0.0])[:, None]
    limits = JointLimits.create(1, velocity=[1.0], acceleration=[2.0], jerk=[5.0], lower=[-1.0], upper=[1.0])
    problem = TimingProblem(via, "cubic", limits)
    result = optimize(problem, "nlp")
    slsqp = optimize(problem, "slsqp", starts=2, iterations=100, seed=1)
    assert result.feasible and slsqp.feasible
    assert result.total_time <= slsqp.total_time * (1 + 1e-4)


@pytest.mark.parametrize("family", ["quintic", "hermite7"])
def test_certifying_the_same_trajectory_again_adds_nothing(family):
    """The certificates found at a trajectory (the paper's via-points at equal durations, every quantity near
    or beyond its bound somewhere: cuts for quintic, exact forms for hermite7's velocity, acceleration and jerk)
    already cover its extremes: certifying it again changes nothing, so a round whose result fails the check
    with nothing new to certify ends the rounds."""
    problem = TimingProblem(VIA, family, paper.paper_limits())
    h = np.full(problem.segment_count, 2.0)
    solver = TimingNLP(problem, h)
    coefficients = problem.coefficients(h[None])[0]
    first, changed = solver._certify([], coefficients, h)
    assert changed and any(c.kind == ("cut" if family == "quintic" else "sos6") for c in first)
    again, changed = solver._certify(first, coefficients, h)
    assert not changed and again == first


def test_a_joint_parked_on_its_bound_gets_no_range_rows_and_every_start_solves():
    """The paper's via-points with joint 3 parked at 0.5 rad, its upper bound (cubic): the spline keeps it there
    whatever the durations, so its range needs no rows (with its virtual knots' range rows one start ended
    Solved_To_Acceptable_Level 6 % above the optimum). Every start solves and reaches SLSQP's optimum."""
    via = VIA.copy()
    via[:, 2] = 0.5
    margin = np.deg2rad(20.0)
    lower, upper = via.min(axis=0) - margin, via.max(axis=0) + margin
    upper[2] = 0.5
    problem = TimingProblem(via, "cubic", paper.paper_limits().with_overrides(lower=lower, upper=upper))
    result = optimize(problem, "nlp")
    assert result.feasible and all(start.status == "Solve_Succeeded" for start in result.starts)
    slsqp = optimize(problem, "slsqp", starts=2, iterations=100, seed=1)
    for start in result.starts:
        assert start.objective == pytest.approx(slsqp.total_time, rel=1e-5)


def test_a_joint_moving_a_fraction_of_a_milliradian_below_its_bound_keeps_to_its_range():
    """Joint 3 through 0.5 rad less 0 to 4e-4 rad, its upper bound 0.5 rad (cubic, the paper's other joints): it
    moves, if little, so its range is constrained and it rests where it touches the bound. The result is
    feasible and, densely sampled, within every range."""
    via = VIA.copy()
    via[:, 2] = 0.5 - np.array([3e-4, 0.0, 2e-4, 0.0, 4e-4, 1e-4, 0.0, 3e-4])
    margin = np.deg2rad(20.0)
    lower, upper = via.min(axis=0) - margin, via.max(axis=0) + margin
    upper[2] = 0.5
    limits = paper.paper_limits().with_overrides(lower=lower, upper=upper)
    problem = TimingProblem(via, "cubic", limits)
    result = optimize(problem, "nlp")
    assert result.feasible
    positions = problem.trajectory(result.durations).evaluate(np.linspace(0.0, result.total_time, 200001))
    assert np.all(positions <= limits.upper + 1e-9) and np.all(positions >= limits.lower - 1e-9)


# ------------------------------------------------------------------ the shortest-segment floor

def test_a_floor_the_optimum_would_cross_gives_the_floored_optimum():
    """The paper's via-points (hybrid) with a 1.5 s floor: the free optimum has segments of 0.92 and 1.22 s,
    so the solve without the floor ends below it and is solved again with it. The result keeps the floor
    and reaches SLSQP's optimum of the floored problem (raising the short segments to the floor and
    scaling the rest, as a repair does, is 2 % longer)."""
    problem = TimingProblem(VIA, "hybrid", paper.paper_limits(), min_duration=1.5)
    result = optimize(problem, "nlp")
    slsqp = optimize(problem, "slsqp", starts=2, iterations=100, seed=1)
    assert result.feasible and slsqp.feasible
    assert result.durations.min() >= 1.5 * (1 - 1e-9)
    assert result.total_time == pytest.approx(slsqp.total_time, rel=1e-5)


def test_the_iterations_reported_include_the_solve_without_the_floor(monkeypatch):
    """Where the solve without the floor ends below it and is solved again with it, the outcome's iterations
    are those of every IPOPT solve made, both passes."""
    problem = TimingProblem(VIA, "hybrid", paper.paper_limits(), min_duration=1.5)
    start = _uniform_start(problem)
    solver = TimingNLP(problem, start)
    counts = record_solves(monkeypatch)
    outcome = solver.solve(start)
    assert len(counts) >= 2  # (the floor was crossed: a second pass)
    assert outcome.iterations == sum(counts)
    assert outcome.durations.min() >= 1.5 * (1 - 1e-6)


def test_a_solve_with_ipopt_options_keeps_the_floor():
    """A solve with IPOPT options of its own (a window's) keeps the shortest-segment floor in its bounds from
    the start: every duration it returns is at least the floor (the free optimum's shortest is 0.92 s)."""
    problem = TimingProblem(VIA, "hybrid", paper.paper_limits(), min_duration=1.5)
    start = _uniform_start(problem)
    outcome = TimingNLP(problem, start, ipopt=WINDOW_IPOPT).solve(start)
    assert outcome.status == "Solve_Succeeded"
    assert outcome.durations.min() >= 1.5 * (1 - 1e-6)


# ------------------------------------------------------------------ the time-jerk objective

@pytest.mark.parametrize("family", ["cubic", "quintic"])
def test_the_time_jerk_optimum_weighs_time_by_its_own_weight(family):
    """Objective K_t T + K_j E with K_t = 5 (not 1) through the paper's first 5 via-points: the NLP reaches
    SLSQP's optimum of the same objective (weighting the jerk energy by K_j instead of K_j / K_t in the
    NLP's time-scaled objective lands 3.6 % above it, cubic)."""
    problem = TimingProblem(VIA[:5], family, paper.paper_limits(), objective="time-jerk", weights=(5.0, 0.1))
    result = optimize(problem, "nlp")
    slsqp = optimize(problem, "slsqp", starts=2, iterations=100, seed=1)
    assert result.feasible and slsqp.feasible
    assert result.objective == pytest.approx(slsqp.objective, rel=1e-6)


# ------------------------------------------------------------------ starts that end outside a range

def test_starts_ipopt_solved_but_outside_a_range_fall_back_inside_it(monkeypatch):
    """Ranges 10 deg beyond the paper's via-points (cubic): equal durations leave them. Where the only start
    is such durations and its solve reports success but ends there (a solve stubbed to return them), it
    does not count as solved-and-feasible, so ``nlp_refine`` falls back on durations that keep the positions
    inside the ranges: the tracker's best is feasible, its positions, densely sampled, within the ranges."""
    from planner.timing.result import SearchTracker

    margin = np.deg2rad(10.0)
    limits = paper.paper_limits().with_overrides(lower=VIA.min(axis=0) - margin, upper=VIA.max(axis=0) + margin)
    problem = TimingProblem(VIA, "cubic", limits)
    outside = problem.evaluate(np.ones((1, problem.segment_count))).durations[0]
    assert not problem.evaluate_durations(outside[None]).feasible[0]
    monkeypatch.setattr(TimingNLP, "solve", lambda self, start, report=None: nlp.NLPOutcome(
        outside, 7, 1, "Solve_Succeeded", 0))
    tracker = SearchTracker(problem)
    nlp.nlp_refine(problem, {"equal": np.ones(problem.segment_count)}, tracker)
    assert tracker.best_feasible
    best = tracker.best_durations
    positions = problem.trajectory(best).evaluate(np.linspace(0.0, best.sum(), 20001))
    assert np.all(positions <= limits.upper + 1e-9) and np.all(positions >= limits.lower - 1e-9)


def test_the_walk_back_into_the_ranges_starts_from_the_best_start_outside(monkeypatch):
    """Where every start ends outside a range, the walk back inside (``_towards``) starts from the solved
    start of the lowest objective: two starts stubbed to end at two shapes outside the ranges (equal
    durations, and the same with the second segment 1.3 times as long); the walk is handed the faster."""
    from planner.timing.result import SearchTracker

    margin = np.deg2rad(10.0)
    limits = paper.paper_limits().with_overrides(lower=VIA.min(axis=0) - margin, upper=VIA.max(axis=0) + margin)
    problem = TimingProblem(VIA, "cubic", limits)
    shapes = np.ones((2, problem.segment_count))
    shapes[1, 1] = 1.3
    ends = problem.evaluate(shapes)
    assert not problem.evaluate_durations(ends.durations).feasible.any()  # both outside a range
    faster = int(np.argmin(ends.objective))
    assert ends.objective[1 - faster] > ends.objective[faster] * (1 + 1e-3)
    calls = []

    def solve(self, start, report=None):
        calls.append(start)
        durations = ends.durations[len(calls) - 1] if len(calls) <= 2 else start
        return nlp.NLPOutcome(durations, 7, 1, "Solve_Succeeded", 0)
    monkeypatch.setattr(TimingNLP, "solve", solve)
    monkeypatch.setattr(nlp, "recombination", lambda kept: None)
    handed = []
    monkeypatch.setattr(nlp, "_towards", lambda problem, tracker, outside, inside: handed.append(outside))
    nlp.nlp_refine(problem, {"first": shapes[0], "second": shapes[1]}, SearchTracker(problem))
    assert len(handed) == 1
    np.testing.assert_allclose(handed[0], ends.durations[faster], rtol=1e-12)


def test_the_walk_back_into_the_ranges_refines_the_first_feasible_step():
    """``_towards`` searches h(l) = outside^(1 - l) inside^l on a grid of RETREAT_STEPS points, then as finely
    between the first feasible point and the one before: with a stub tracker feasible from l = 0.3 on, the
    feasible point nearest it that it offers is within one fine step ((1 / 32)^2 of l), where the first
    grid's is 0.0125 beyond."""
    offered = []

    class Stub:
        def evaluate(self, durations):
            shares = np.log(durations[:, 0])  # outside = 1, inside = e: l itself
            offered.extend(shares.tolist())
            return type("Evaluation", (), {"feasible": shares >= 0.3})()

    nlp._towards(None, Stub(), np.ones(3), np.full(3, np.e))
    feasible = [share for share in offered if share >= 0.3]
    assert 0.3 <= min(feasible) <= 0.3 + (1 / (nlp.RETREAT_STEPS - 1)) ** 2


def test_hermite7s_implied_rows_hold_with_equality_at_markovs_extremes():
    """The rows bounding a via-point's acceleration and jerk where they have no limit of their own are
    Markov's inequality, which Chebyshev polynomials meet with equality: a segment's acceleration A T5(2s - 1)
    (|a| <= A, dense check) has jerk 50 A / h at its start, and a velocity V T6(2s - 1) an acceleration of
    72 V / h there: those rows are exactly 1 (a tighter row cuts such a feasible segment off). The velocity's
    jerk there, V T6''(-1) (2 / h)^2 = 1680 V / h^2, stays within its row (3600 V / h^2) on a segment of
    0.1 s, where a row in h rather than h^2 would exceed 1 four times over."""
    from numpy.polynomial import chebyshev as C

    velocity, acceleration, h = 2.0, 5.0, 0.1
    limits = JointLimits.create(2, velocity=[velocity, velocity], acceleration=[acceleration, np.inf])
    via = np.array([[0.0, 0.0], [0.1, 0.2], [0.3, 0.1]])
    problem = TimingProblem(via, "hermite7", limits)
    formulation = TimingNLP(problem, np.ones(2)).formulation
    s = np.linspace(0.0, 1.0, 20001)
    t5, t6 = C.Chebyshev.basis(5, domain=[0, 1]), C.Chebyshev.basis(6, domain=[0, 1])
    assert np.abs(acceleration * t5(s)).max() == pytest.approx(acceleration)
    jerk_0 = acceleration * t5.deriv()(0.0) / h  # d/dt = (1 / h) d/ds
    acceleration_1 = velocity * t6.deriv()(0.0) / h
    jerk_1 = velocity * t6.deriv(2)(0.0) / h ** 2
    assert abs(jerk_0) == pytest.approx(50 * acceleration / h)
    assert abs(acceleration_1) == pytest.approx(72 * velocity / h)
    knots = [np.zeros((3, 2)), np.array([[0.0, 0.0], [0.0, acceleration_1], [0.0, 0.0]]),
             np.array([[0.0, 0.0], [jerk_0, jerk_1], [0.0, 0.0]])]
    rows = formulation._implied_rows(None, knots, np.array([h, h]))
    values = np.abs(np.concatenate([np.ravel(row) for row, _, _ in rows]))
    assert len(rows) == 6  # joint 0: its jerk, both sides; joint 1: its acceleration and jerk, both sides
    assert values.max() == pytest.approx(1.0, rel=1e-12)
    assert np.sort(values).tolist() == pytest.approx([1680 / 3600] * 2 + [1.0] * 4, rel=1e-12)


# ------------------------------------------------------------------ h_max with free via-point states

def test_a_hermite7_segment_on_h_max_stays_within_it():
    """hermite7 through the paper's first 4 via-points with h_max = 2.8 s (the free optimum's first segment is
    2.9 s): the optimum puts the first segment on h_max. Its cut limits leave about 1e-7 of themselves over,
    which the repair scales away; the result is feasible and no duration exceeds h_max."""
    problem = TimingProblem(VIA[:4], "hermite7", paper.paper_limits(), bounds=(0.1, 2.8))
    result = optimize(problem, "nlp")
    assert result.feasible
    assert result.durations.max() <= 2.8
    assert result.durations[0] == pytest.approx(2.8, rel=1e-5)


def test_hermite7_with_h_min_equal_to_h_max_chooses_its_states():
    """h_min = h_max = 3 s (hermite7, the paper's first 4 via-points, time-jerk): the durations are fixed, and
    the NLP, held just below h_max, still has a non-empty range for them; it solves and chooses via-point
    states whose jerk energy is far below that of the family's rule states at the same durations."""
    problem = TimingProblem(VIA[:4], "hermite7", paper.paper_limits(), bounds=(3.0, 3.0), objective="time-jerk")
    result = optimize(problem, "nlp")
    assert result.feasible and all(start.status == "Solve_Succeeded" for start in result.starts)
    np.testing.assert_array_equal(result.durations, np.full(3, 3.0))
    rule = problem.evaluate(np.full((1, 3), 3.0)).objective[0]
    assert result.objective < 0.1 * rule


# ------------------------------------------------------------------ programs kept under a time limit

def test_a_kept_program_is_built_again_past_a_tenth_of_a_short_time_limit(monkeypatch):
    """Under a 5 s limit a kept program is reused only within 10 % of the time left when it was built
    (0.5 s, below the 1 s cap): after 0.4 s it is reused, after 0.6 s built again (IPOPT's own wall-time
    limit counts from each solve, so a reuse could overrun the limit by the time since the build)."""
    problem = TimingProblem(VIA[:4], "hybrid", paper.paper_limits())
    clock = [1000.0]
    monkeypatch.setattr(nlp.time, "monotonic", lambda: clock[0])
    with time_limit(5.0):
        solver = TimingNLP(problem, _uniform_start(problem))
        built = solver._program([])
        clock[0] += 0.4
        assert solver._program([]) is built
        clock[0] += 0.2
        assert solver._program([]) is not built


def test_a_solve_begun_under_a_time_limit_stops_at_it():
    """A solve run here (not in a process of its own) is stopped by IPOPT's own wall-time limit: hermite7
    through the paper's via-points there and back, whose round takes over a second, under a 0.3 s limit
    returns IPOPT's wall-time status (no timed assertion: the status is IPOPT's own word that its limit
    stopped it)."""
    problem = TimingProblem(np.vstack((VIA, VIA[-2::-1])), "hermite7", paper.paper_limits())
    start = _uniform_start(problem)
    solver = TimingNLP(problem, start)
    solver.blocks  # (the program without certificates, built before the clock starts)
    with time_limit(0.3):
        outcome = solver.solve(start)
    assert outcome.status == "Maximum_WallTime_Exceeded"


# ------------------------------------------------------------------ settings recorded

def test_a_two_segment_quintic_records_one_process_per_start():
    """Families bounded by cuts solve their starts side by side from 2 segments on (the documented
    ``CUT_CONCURRENT_SEGMENTS``): a quintic through 3 via-points records one process per start."""
    problem = TimingProblem(VIA[:3], "quintic", paper.paper_limits())
    assert problem.segment_count == 2
    assert nlp.nlp_settings(problem, 2)["processes"] == 2
    assert nlp.nlp_settings(TimingProblem(VIA[:2], "quintic", paper.paper_limits()), 2)["processes"] == 1
