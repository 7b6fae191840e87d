"""Gaps in the tests of planner/timing/starts.py, result.py and lower_bound.py found by a hand
mutation-testing run: each test kills a mutant that survived the existing tests."""

import numpy as np
import pytest

from planner import JointLimits
from planner.timing import TimingProblem
from planner.timing.result import AGREEMENT
from planner.timing.starts import recombination, recombined, start_shapes

# ---------------------------------------------------------------- starts.py

def test_durations_that_differ_by_five_ten_thousandths_are_a_region_of_their_own():
    """DIFFERENCE is 1e-4 (relative): a segment 5e-4 shorter in the other solution is taken from it.
    (A DIFFERENCE of 1e-3 survived: the existing tests scale their inputs with the imported constant.)"""
    first = np.full(12, 10.0)
    other = first.copy()
    other[3] = 10.0 * (1 - 5e-4)   # shorter on 3: a region, taken
    other[10] = 11.0               # longer on 10: a region, kept from the shortest
    expected = first.copy()
    expected[3] = other[3]
    np.testing.assert_array_equal(recombined([first, other]), expected)


def test_a_joint_without_a_velocity_limit_adds_nothing_to_the_cruise_shape():
    """Velocity limit on joint 0 only: ``cruise`` is D_0 / V_0 per chord (joint 1's D / inf vanishes); the
    rest-to-rest fallback is only for problems where no joint has a velocity limit."""
    via = np.array([[0.0, 0.0], [1.0, 0.5], [1.5, -0.5], [3.0, -0.2]])
    limits = JointLimits.create(2, velocity=[1.0, np.inf], acceleration=[2.0, 0.5])
    problem = TimingProblem(via, "hermite7", limits)  # one segment per chord
    expected = [abs(via[c + 1, 0] - via[c, 0]) / 1.0 for c in range(3)]
    np.testing.assert_allclose(start_shapes(problem)["cruise"], expected, rtol=1e-12)


def test_durations_exactly_one_ten_thousandth_apart_do_not_differ():
    """``differ by more than DIFFERENCE``: 9999 s against 10,000 s is exactly 1e-4 of the larger (1.0 s, exact
    in floating point), so not a region; 9998 s is."""
    first = np.full(12, 10_000.0)
    at = first.copy()
    at[4], at[10] = 9_999.0, 10_001.5  # exactly at the threshold on 4; longer on 10 (kept)
    assert recombined([first, at]) is None
    beyond = first.copy()
    beyond[4], beyond[10] = 9_998.0, 10_001.5
    expected = first.copy()
    expected[4] = 9_998.0
    np.testing.assert_array_equal(recombined([first, beyond]), expected)


def test_the_difference_is_relative_to_the_larger_duration():
    """1 s against 1 - 0.99995e-4 s: the gap is below 1e-4 of the larger (1 s), though above 1e-4 of the
    smaller: no region."""
    first = np.ones(12)
    close = first.copy()
    close[4], close[10] = 1.0 - 0.99995e-4, 1.5
    assert np.abs(first[4] - close[4]) <= 1e-4 * first[4] and np.abs(first[4] - close[4]) > 1e-4 * close[4]
    assert recombined([first, close]) is None


def test_a_region_of_equal_total_is_not_taken():
    """Segments 3 and 4 differ (0.5 + 1.5 against 1 + 1) but sum the same there: nothing is gained, so the
    region is not taken, and with no other region taken there is nothing to solve again (None)."""
    first = np.ones(12)
    other = first.copy()
    other[3], other[4] = 0.5, 1.5  # region 1 .. 6: the same total, 6 s
    other[10] = 2.0                # region 8 .. 11: longer
    assert other[1:7].sum() == first[1:7].sum()
    assert recombined([first, other]) is None


def _two_solved(objective_gap):
    """Two solved starts (durations, objective): the second shorter on segment 3, longer on 10."""
    first = np.ones(12)
    other = first.copy()
    other[3], other[10] = 0.5, 2.0
    expected = first.copy()
    expected[3] = 0.5
    return [(first, 10.0), (other, 10.0 * (1 + objective_gap))], expected


def test_starts_whose_objectives_agree_are_not_recombined_up_to_the_gap_itself():
    """Objectives within ``AGREEMENT`` (1e-4), the bound included, agree: no recombination."""
    solved, _ = _two_solved(AGREEMENT)
    assert solved[1][1] == solved[0][1] * (1 + AGREEMENT)
    assert recombination(solved) is None
    assert recombination([]) is None


def test_starts_whose_objectives_differ_by_more_than_the_gap_are_recombined():
    """5e-4 apart (more than ``AGREEMENT``, less than ten times it): their recombination is solved."""
    solved, expected = _two_solved(5e-4)
    np.testing.assert_array_equal(recombination(solved), expected)


# ---------------------------------------------------------------- result.py

def _nlp_result(*objectives, status="Solve_Succeeded"):
    from planner.timing.result import OptimizationResult, StartReport

    starts = [StartReport(f"start {i}", value, True, 10, 1, status, 0) for i, value in enumerate(objectives)]
    return OptimizationResult("nlp", np.ones(1), 1.0, 1.0, np.zeros((3, 1)), True, 1, 0.0, [], "", None,
                              starts=starts)


def test_starts_agree_within_one_ten_thousandth_the_bound_included():
    """``AGREEMENT`` is 1e-4 of the best: 5e-4 apart do not agree; exactly 1e-4 apart (as computed) do."""
    assert not _nlp_result(10.0, 10.0 * (1 + 5e-4)).starts_agree
    assert _nlp_result(10.0, 10.0 * (1 + AGREEMENT)).starts_agree
    assert _nlp_result(10.0 * (1 + AGREEMENT), 10.0, 10.0).starts_agree


def test_a_population_of_exactly_the_most_numbers_a_search_holds_is_allowed():
    """``check_population`` refuses more than ``MAX_POPULATION_NUMBERS`` (2e7) numbers, not that many:
    5 segments x 4,000,000 members is allowed, one member more is refused."""
    from planner import SettingError
    from planner.timing.result import MAX_POPULATION_NUMBERS, check_population

    via = np.array([[0.0], [1.0], [0.5], [1.5], [1.0], [2.0]])
    problem = TimingProblem(via, "hermite7", JointLimits.create(1, velocity=[1.0]))
    assert problem.segment_count == 5 and MAX_POPULATION_NUMBERS == 5 * 4_000_000
    check_population(problem, "nests", 4_000_000, 4_000_000)
    with pytest.raises(SettingError, match="nests"):
        check_population(problem, "nests", 4_000_001, 4_000_001)


def _paper_problem():
    from planner import paper

    return TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits())


def test_counted_evaluations_stop_the_search_at_the_time_limit_once_it_holds_a_candidate():
    """``count`` (a finite-difference Jacobian's points) checks the time limit too: a local solver between
    two offered candidates can run far past it."""
    import time

    from planner.timing.result import OutOfTime, SearchTracker, time_limit

    problem = _paper_problem()
    tracker = SearchTracker(problem)
    tracker.evaluate(np.ones((1, problem.segment_count)))  # a best candidate, before any limit
    with time_limit(1e-6):
        time.sleep(0.01)
        with pytest.raises(OutOfTime) as stop:
            tracker.count(3)
    assert stop.value.tracker is tracker and tracker.evaluations == 1 + 3


def test_chunks_keep_the_same_best_as_one_batch_among_equal_objectives(monkeypatch):
    """Candidates of equal objective: the whole batch keeps its first; evaluated one candidate a chunk, the
    tracker keeps the first too (a later equal one does not displace it), so chunking changes nothing."""
    from planner.timing import result as result_module
    from planner.timing.problem import Evaluation
    from planner.timing.result import SearchTracker

    class Given:  # every candidate feasible, of objective 5: only the tie-break is under test
        segment_count, joint_count = 2, 1

        def evaluate(self, candidates):
            count = len(candidates)
            return Evaluation(np.asarray(candidates, float), np.full(count, 5.0), np.zeros((count, 3, 1)),
                              np.zeros(count), np.ones(count, dtype=bool))

    candidates = np.array([[1.0, 4.0], [2.0, 3.0], [3.0, 2.0]])
    whole = SearchTracker(Given())
    whole.evaluate(candidates)
    monkeypatch.setattr(result_module, "CHUNK_COEFFICIENTS", 2 * 1 * 8)  # one candidate a chunk
    chunked = SearchTracker(Given())
    chunked.evaluate(candidates)
    assert chunked.evaluations == whole.evaluations == 3
    np.testing.assert_array_equal(whole.best_durations, candidates[0])
    np.testing.assert_array_equal(chunked.best_durations, candidates[0])


def test_a_batch_that_is_not_two_dimensional_goes_to_the_problem_whole():
    """One candidate (S,) is evaluated as a batch of one; a (2, 1, S) batch is refused by the problem's own
    check, naming it (not an error of the tracker's chunking)."""
    from planner.errors import InputError
    from planner.timing.result import SearchTracker

    problem = _paper_problem()
    tracker = SearchTracker(problem)
    evaluation = tracker.evaluate(np.ones(problem.segment_count))
    assert evaluation.objective.shape == (1,) and tracker.evaluations == 1
    np.testing.assert_array_equal(tracker.best_durations, evaluation.durations[0])
    with pytest.raises(InputError, match="candidates must have 1 dimension"):
        tracker.evaluate(np.ones((2, 1, problem.segment_count)))


def test_the_history_keeps_every_iteration():
    """The convergence history has one entry per iteration, however many (Cuckoo Search allows 10,000)."""
    from planner.timing.result import SearchTracker

    problem = _paper_problem()
    tracker = SearchTracker(problem)
    evaluation = tracker.evaluate(np.ones((1, problem.segment_count)))
    for _ in range(1500):
        tracker.end_iteration()
    assert tracker.history == [evaluation.objective[0]] * 1500
    assert len(tracker.result("test", "", None).history) == 1500


# ---------------------------------------------------------------- lower_bound.py

def test_links_reach_thirty_two_via_points_without_a_patched_window():
    """The existing chain tests cut ``WINDOW`` to 3; here it is the module's own 32, on a 40-point walk whose
    longest chain needs a link 17 to 32 via-points long (with pairs at most 16 apart the bound is 0.5 % lower):
    the bound is the longest chain over every pair at most 32 apart (and every pair from the first and to the
    last), by ``test_lower_bound``'s independent reading of the module docstring."""
    from test_lower_bound import _longest_chain

    from planner.timing.lower_bound import time_lower_bound

    rng = np.random.default_rng(258)
    n, joints = int(rng.integers(20, 60)), int(rng.integers(1, 4))
    steps = rng.choice([-2, -1, 0, 1, 2], (n, joints)) * 0.25 * rng.uniform(0.05, 1, (1, joints))
    via = np.cumsum(steps, axis=0)
    limits = JointLimits.create(joints, velocity=rng.uniform(0.3, 3, joints), acceleration=rng.uniform(0.3, 3, joints),
                                jerk=rng.uniform(0.1, 10, joints))
    assert (n, joints) == (40, 2)
    bound = time_lower_bound(via, limits)
    assert bound == pytest.approx(_longest_chain(via, limits, 32), rel=1e-12)
    assert bound > _longest_chain(via, limits, 16) * (1 + 1e-3)
