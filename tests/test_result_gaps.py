"""Gaps in the tests of planner/timing/result.py found by mutation testing (mutmut)."""

import time

import numpy as np
import pytest

from planner import paper
from planner.timing import TimingProblem
from planner.timing.result import OptimizationResult, OutOfTime, SearchTracker, StartReport, remaining_time, time_limit


def _problem():
    """The paper's first four via-points and limits, cubic family: fast to evaluate."""
    return TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits())


def _start(label, iterations, objective=10.0, feasible=True):
    return StartReport(label, objective, feasible, iterations, 1, "Solve_Succeeded", 0)


def _result(starts):
    return OptimizationResult("nlp", np.ones(2), 2.0, 2.0, np.zeros((3, 1)), True, 1, 0.0, [], "", None, starts=starts)


def test_solver_iterations_add_up_over_the_starts():
    assert _result([_start("a", 3), _start("b", 4), _start("c", 0)]).solver_iterations == 7
    assert _result([]).solver_iterations == 0


def test_without_a_time_limit_there_is_no_remaining_time():
    assert remaining_time() is None
    with time_limit(None):
        assert remaining_time() is None
    with time_limit(5.0):
        pass
    assert remaining_time() is None  # the limit ends with its block


def test_a_limit_of_none_inside_another_keeps_the_outer_one():
    with time_limit(2.0):
        with time_limit(None):
            assert 1.0 < remaining_time() <= 2.0
        with time_limit(50.0):
            assert 1.0 < remaining_time() <= 2.0
        assert 1.0 < remaining_time() <= 2.0  # the inner blocks do not change the outer deadline


def test_the_remaining_time_is_zero_once_the_limit_has_passed_not_negative():
    with time_limit(1e-6):
        time.sleep(0.01)
        assert remaining_time() == 0.0


def test_the_tracker_stops_at_the_time_limit_only_once_it_holds_a_candidate():
    problem = _problem()
    tracker = SearchTracker(problem)
    with time_limit(1e-6):
        time.sleep(0.01)
        tracker.count(3)  # no candidate yet: the search goes on
        with pytest.raises(OutOfTime) as stop:
            tracker.evaluate(np.ones((2, problem.segment_count)))
    assert stop.value.tracker is tracker and tracker.evaluations == 3 + 2
    assert tracker.best_durations is not None and tracker.best_feasible


def test_the_tracker_counts_every_evaluation_and_reports_each_iteration():
    problem = _problem()
    calls = []
    tracker = SearchTracker(problem, lambda *args: calls.append(args), 4)
    assert tracker.evaluations == 0 and tracker.history == [] and tracker.best_objective == np.inf
    first = tracker.evaluate(np.ones((3, problem.segment_count)))
    tracker.end_iteration()
    tracker.count(5)
    shapes = np.array([[1.0] * (problem.segment_count - 1) + [0.2]])
    second = tracker.evaluate(shapes)
    tracker.end_iteration()
    best = min(first.objective.min(), second.objective.min())
    assert tracker.evaluations == 3 + 5 + 1
    assert tracker.history == [first.objective.min(), best]
    assert calls == [(1, 4, first.objective.min()), (2, 4, best)]


def test_the_result_reports_the_best_candidate_checked_again_as_durations():
    problem = _problem()
    tracker = SearchTracker(problem)
    evaluation = tracker.evaluate(np.array([[1.0] * problem.segment_count, [0.5] * problem.segment_count]))
    tracker.end_iteration()
    tracker.starts.append(_start("s", 9))
    tracker.settings = {"k": 1}
    result = tracker.result("test", "why", 7)
    best = int(np.argmin(evaluation.objective))
    np.testing.assert_allclose(result.durations, evaluation.durations[best], rtol=0)
    check = problem.evaluate_durations(evaluation.durations[best][None])
    assert result.total_time == pytest.approx(evaluation.durations[best].sum(), rel=1e-15)
    assert result.objective == pytest.approx(check.objective[0], rel=1e-15) and result.feasible
    np.testing.assert_allclose(result.ratios, check.ratios[0], rtol=0)
    assert result.max_ratio == pytest.approx(1.0, abs=1e-9)
    assert (result.algorithm, result.stop_reason, result.seed, result.settings) == ("test", "why", 7, {"k": 1})
    assert result.evaluations == 2 and result.history == [evaluation.objective.min()]
    assert [s.label for s in result.starts] == ["s"] and result.solver_iterations == 9 and result.knot_states is None
    assert 0.0 <= result.wall_time_s < 60.0


def test_the_result_checks_free_states_with_the_states_the_search_chose():
    """hermite7 (free via-point states): the result re-checks the best durations with the via-point states
    that came with them (here all zero: rest at every via-point), not with the family's own rule, and
    reports those states."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "hermite7", paper.paper_limits())
    count, joints = 4, 6
    states = np.zeros((1, count, joints, 3))
    tracker = SearchTracker(problem)
    evaluation = problem.evaluate_states(np.ones((1, problem.segment_count)), states)
    tracker.offer(evaluation)  # as the NLP offers each start's solution
    result = tracker.result("nlp", "", None)
    at_rest = problem.evaluate_durations(evaluation.durations, states)
    own_rule = problem.evaluate_durations(evaluation.durations)
    np.testing.assert_allclose(result.ratios, at_rest.ratios[0], rtol=1e-12)
    assert not np.allclose(result.ratios, own_rule.ratios[0], rtol=1e-3)
    assert result.objective == pytest.approx(at_rest.objective[0], rel=1e-12) and result.feasible
    np.testing.assert_array_equal(result.knot_states, states[0])


def test_a_search_that_meets_only_infeasible_candidates_keeps_the_least_penalised_as_they_are():
    """Raw durations (repair=False) far too short are infeasible and scored with a penalty, unrepaired; the
    tracker keeps the least penalised one (it has no feasible one to prefer) and reports it infeasible."""
    problem = _problem()
    tracker = SearchTracker(problem)
    short = np.array([[0.01] * problem.segment_count, [0.02] * problem.segment_count])
    evaluation = tracker.evaluate(short, repair=False)
    np.testing.assert_array_equal(evaluation.durations, short)
    assert not evaluation.feasible.any()
    assert tracker.best_durations is not None and not tracker.best_feasible
    assert tracker.best_objective == evaluation.objective.min() > short.sum(axis=1).max()
    result = tracker.result("cuckoo-paper", "", 0)
    assert not result.feasible and result.total_time == pytest.approx(short[np.argmin(evaluation.objective)].sum())


def test_within_one_batch_a_feasible_candidate_is_kept_before_a_less_penalised_infeasible_one():
    """The tracker picks a batch's best among its feasible candidates when it has any: an infeasible one of
    smaller (penalised) objective in the same batch is not taken, not even as the first best."""
    from planner.timing.problem import Evaluation

    problem = _problem()
    segments = problem.segment_count

    class Given:  # a problem whose evaluations are given: the tracker's rule alone is under test
        segment_count, joint_count = segments, 6

        def evaluate(self, candidates):
            return Evaluation(np.array([[3.0] * segments, [2.0] * segments]), np.array([30.0, 20.0]),
                              np.zeros((2, 3, 6)), np.zeros(2), np.array([True, False]))

    tracker = SearchTracker(Given())
    tracker.evaluate(np.zeros((2, segments)))
    assert tracker.best_feasible and tracker.best_objective == 30.0
    np.testing.assert_array_equal(tracker.best_durations, [3.0] * segments)


@pytest.mark.parametrize("family", ["hybrid", "hermite7"])
def test_a_large_batch_is_evaluated_in_chunks_with_the_same_result(monkeypatch, family):
    """Above ``CHUNK_COEFFICIENTS`` a batch is evaluated a chunk at a time (10,000 nests of 999 segments were
    one 915 MB array, then a MemoryError): the same evaluation, the same best, every candidate counted."""
    from planner.timing import result as result_module

    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), family, paper.paper_limits())
    rng = np.random.default_rng(8)
    candidates = rng.uniform(0.05, 1.0, (23, problem.segment_count))
    whole = SearchTracker(problem)
    expected = whole.evaluate(candidates)
    monkeypatch.setattr(result_module, "CHUNK_COEFFICIENTS", 5 * problem.segment_count * problem.joint_count * 8)
    chunked = SearchTracker(problem)
    evaluation = chunked.evaluate(candidates)
    for name in ("durations", "objective", "ratios", "position_excess", "feasible"):
        np.testing.assert_array_equal(getattr(evaluation, name), getattr(expected, name))
    assert evaluation.states is None and chunked.evaluations == 23
    np.testing.assert_array_equal(chunked.best_durations, whole.best_durations)


def test_a_batch_in_chunks_stops_at_the_time_limit_after_the_first_chunk(monkeypatch):
    """The time limit is checked between chunks: a 10,000-nest batch overran a 2 s limit 3.8 times."""
    from planner.timing import result as result_module

    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    monkeypatch.setattr(result_module, "CHUNK_COEFFICIENTS", 4 * problem.segment_count * problem.joint_count * 8)
    tracker = SearchTracker(problem)
    with time_limit(1e-9):
        time.sleep(0.01)
        with pytest.raises(OutOfTime):
            tracker.evaluate(np.full((40, problem.segment_count), 0.5))
    assert tracker.evaluations == 4 and tracker.best_feasible


@pytest.mark.parametrize("algorithm, setting, value, points", [
    ("de", "population", 1000, 200), ("cuckoo", "nests", 10_000, 2500), ("pso", "particles", 10_000, 2500)])
def test_a_population_beyond_what_a_search_holds_is_refused_naming_its_setting(algorithm, setting, value, points):
    """nests, particles and DE's population (x segments members) within their ranges made arrays of several
    GB; the most a task allows is the largest whose population holds at most ``MAX_POPULATION_NUMBERS``."""
    from planner import JointLimits, SettingError
    from planner.timing import optimize
    from planner.timing.result import MAX_POPULATION_NUMBERS

    via = np.cumsum(np.random.default_rng(2).uniform(-0.3, 0.3, (points, 2)), axis=0)
    problem = TimingProblem(via, "cubic", JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0]))
    segments = problem.segment_count
    numbers = (lambda count: count * segments * segments) if algorithm == "de" else (lambda count: count * segments)
    most = max(count for count in range(1, value) if numbers(count) <= MAX_POPULATION_NUMBERS)
    with pytest.raises(SettingError, match=rf"^optimizer setting {setting}: {value} makes a population of "
                                           rf"{numbers(value) // segments:,} candidates of {segments} durations "
                                           rf"\({numbers(value):,} numbers\), above the 20,000,000 a search holds: "
                                           rf"at most {most} for {segments} segments$"):
        optimize(problem, algorithm, **{setting: value})
    optimize(problem, algorithm, **{setting: most}, time_limit_s=1e-9)  # the most allowed runs


def test_a_large_batch_under_a_time_limit_is_evaluated_in_chunks_the_limit_can_stop():
    """A population that is slow to evaluate (PSO with 10,000 particles of 99 hermite7 segments: 882 in one
    chunk took 7.8 s) ran past a 2 s limit by its first chunk (sweep 24). Under a limit the first chunk
    measures the cost per candidate, and later chunks take a tenth of the time left: the search stops near
    the limit, with what it evaluated. Without a limit the batch is one chunk, as before."""
    problem = _problem()
    seen = []

    def slow(candidates):
        seen.append(len(candidates))
        time.sleep(2e-3 * len(candidates))  # 2 ms a candidate
        return problem.evaluate(candidates)

    lower, upper = problem.search_box()
    batch = lower + (upper - lower) * np.random.default_rng(0).random((400, len(lower)))
    tracker = SearchTracker(problem)
    tracker._track(slow, batch)
    assert seen == [400]
    seen.clear()
    tracker = SearchTracker(problem)
    with time_limit(0.2), pytest.raises(OutOfTime):
        tracker._track(slow, batch)  # 0.8 s in one chunk
    assert seen[0] == 8 and max(seen) <= 0.1 * 0.2 / 2e-3 + 1 and tracker.evaluations == sum(seen) < 400
    assert tracker.best_objective == pytest.approx(problem.evaluate(batch[:sum(seen)]).objective.min())
