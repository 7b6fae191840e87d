"""Gaps in the tests of planner/timing/starts.py and result.py found by mutation testing (mutmut 3.8.1 over
both modules; the survivors that change a result, one test each)."""

from typing import cast

import numpy as np
import pytest

from planner import paper
from planner.timing import TimingProblem
from planner.timing.result import SearchTracker, time_limit

# ---------------------------------------------------------------- result.py


def _paper_problem(family="cubic"):
    """The paper's eight via-points and limits (9 cubic segments, 7 hermite7 ones): fast to evaluate."""
    return TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), family, paper.paper_limits())


class _Clock:
    """A stand-in for the ``time`` module of planner.timing.result: the test moves it, ``_Timed`` by the cost of
    each candidate it evaluates."""

    def __init__(self):
        self.now = 1000.0  # like ``time.perf_counter``, an arbitrary origin: only differences mean anything

    def perf_counter(self):
        return self.now

    def monotonic(self):
        return self.now


class _Timed:
    """A problem whose evaluations take ``cost`` [s] of the fake clock per candidate; it records each chunk's
    size and evaluates it with the real problem."""

    def __init__(self, problem, clock, cost):
        self.problem, self.clock, self.cost, self.chunks = problem, clock, cost, []
        self.segment_count, self.joint_count = problem.segment_count, problem.joint_count

    def evaluate(self, candidates):
        self.chunks.append(len(candidates))
        self.clock.now += self.cost * len(candidates)
        return self.problem.evaluate(candidates)


@pytest.mark.parametrize("cost, most, batches, chunks", [
    # 8 to measure (0.08 s), then 10 % of the 9.92 s left at 0.01 s a candidate: 99, then the 13 left
    (0.01, None, [120], [8, 99, 13]),
    # the same, each chunk at most 50 candidates (the coefficient budget)
    (0.01, 50, [120], [8, 50, 50, 12]),
    # a batch of one measures 0.01 s a candidate: 10 % of the 9.99 s left is 99; then 10 % of 9.0 s, 90 > 51
    (0.01, None, [1, 150], [1, 99, 51]),
    # 0.5 s a candidate: after the 8 of the probe 10 % of the 6 s left is 1.2 candidates, then 1.1: one each
    (0.5, None, [10], [8, 1, 1]),
])
def test_under_a_time_limit_a_chunk_holds_what_takes_a_tenth_of_the_time_left(monkeypatch, cost, most, batches,
                                                                             chunks):
    """Under a 10 s time limit the first chunk of a tracker holds 8 candidates (a probe); each later one the
    candidates that take a tenth of the time left at the cost per candidate last measured (rounded down), at
    least one and at most what ``CHUNK_COEFFICIENTS`` allows. The time is a fake clock that each evaluated
    candidate moves by ``cost``; the chunks' evaluation is the whole batch's, every candidate counted."""
    from planner.timing import result as result_module

    problem = _paper_problem()
    clock = _Clock()
    monkeypatch.setattr(result_module, "time", clock)
    if most is not None:
        monkeypatch.setattr(result_module, "CHUNK_COEFFICIENTS", most * problem.segment_count * problem.joint_count * 8)
    timed = _Timed(problem, clock, cost)
    tracker = SearchTracker(cast(TimingProblem, timed))
    rng = np.random.default_rng(5)
    with time_limit(10.0):
        for size in batches:
            candidates = rng.uniform(0.1, 1.0, (size, problem.segment_count))
            evaluation = tracker.evaluate(candidates)
            whole = problem.evaluate(candidates)
            for name in ("durations", "objective", "ratios", "position_excess", "feasible"):
                np.testing.assert_array_equal(getattr(evaluation, name), getattr(whole, name))
    assert timed.chunks == chunks
    assert tracker.evaluations == sum(batches)


def test_a_budget_of_one_candidate_a_chunk_evaluates_a_batch_one_candidate_at_a_time(monkeypatch):
    """A coefficient budget below one candidate's still evaluates one at a time (never zero, never two); a
    batch of two so split (exactly two chunks) gives the same evaluation as the batch evaluated whole, both
    candidates in it."""
    from planner.timing import result as result_module

    problem = _paper_problem()
    rng = np.random.default_rng(3)
    candidates = rng.uniform(0.1, 1.0, (2, problem.segment_count))
    whole = problem.evaluate(candidates)
    monkeypatch.setattr(result_module, "CHUNK_COEFFICIENTS", 1)
    clock = _Clock()
    timed = _Timed(problem, clock, 0.0)
    evaluation = SearchTracker(cast(TimingProblem, timed)).evaluate(candidates)
    assert timed.chunks == [1, 1]
    for name in ("durations", "objective", "ratios", "position_excess", "feasible"):
        np.testing.assert_array_equal(getattr(evaluation, name), getattr(whole, name))



def test_one_candidate_of_many_segments_is_evaluated_whole_under_a_time_limit():
    """One candidate (S,) with S = 9 segments, above the probe's 8 candidates: under a time limit the
    tracker evaluates it as a batch of one, as it does without a limit (it is not cut into chunks of
    durations)."""
    problem = _paper_problem()
    candidate = np.linspace(0.2, 1.0, problem.segment_count)
    expected = SearchTracker(problem).evaluate(candidate)
    tracker = SearchTracker(problem)
    with time_limit(100.0):
        evaluation = tracker.evaluate(candidate)
    assert evaluation.objective.shape == (1,) and tracker.evaluations == 1
    np.testing.assert_array_equal(evaluation.durations, expected.durations)
    np.testing.assert_array_equal(evaluation.objective, expected.objective)
