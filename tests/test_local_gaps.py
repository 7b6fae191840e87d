"""Gaps in the tests of planner/timing/local.py (the SLSQP refinement) found by mutation testing (mutmut)."""

import numpy as np
import pytest

from planner import paper
from planner.timing import TimingProblem, optimize
from planner.timing.local import refine
from planner.timing.result import SearchTracker

VIA = np.deg2rad(paper.VIA_POINTS_DEG)[:5]
MARGIN = np.deg2rad(5.0)


def _refined(problem, start, max_iterations=100):
    """SLSQP from ``start`` (S,) [s]: the tracker holds its (repaired) result and nothing else."""
    tracker = SearchTracker(problem)
    refine(problem, np.asarray(start, dtype=float), tracker, max_iterations=max_iterations)
    return tracker


def _equal_durations(problem):
    return problem.evaluate(np.ones((1, problem.segment_count))).durations[0]


@pytest.mark.parametrize("sign, sides", [(1.0, "upper"), (-1.0, "lower"), (1.0, "both")])
def test_slsqp_keeps_every_position_inside_a_range_the_start_leaves(sign, sides):
    """Five paper via-points, cubic, a range 5 deg beyond the via-points on one side (mirrored for the
    lower side) or both. Equal durations leave the range, and no time scaling mends a position: only the
    SLSQP's range constraints bring the result inside, to the NLP's optimum (an independent solver)."""
    via = sign * VIA
    lower, upper = via.min(axis=0) - MARGIN, via.max(axis=0) + MARGIN
    ranges = {"upper": {"upper": upper}, "lower": {"lower": lower}, "both": {"lower": lower, "upper": upper}}[sides]
    problem = TimingProblem(via, "cubic", paper.paper_limits().with_overrides(**ranges))
    start = _equal_durations(problem)
    assert not problem.evaluate_durations(start).feasible[0], "the start should leave the range"
    tracker = _refined(problem, start)
    best = optimize(problem, "nlp")
    assert tracker.best_feasible and best.feasible
    assert tracker.best_objective == pytest.approx(best.total_time, rel=1e-6)


@pytest.mark.parametrize("weights", [(1.0, 0.1), (2.0, 0.5)])
def test_slsqp_minimises_the_time_jerk_objective_to_the_nlps_optimum(weights):
    """``time-jerk``: SLSQP minimises K_t T + K_j E (not T alone), to the optimum the NLP finds."""
    problem = TimingProblem(VIA, "cubic", paper.paper_limits(), objective="time-jerk", weights=weights)
    tracker = _refined(problem, _equal_durations(problem))
    best = optimize(problem, "nlp")
    assert tracker.best_feasible and tracker.best_objective == pytest.approx(best.objective, rel=1e-7)
    assert best.total_time > optimize(TimingProblem(VIA, "cubic", paper.paper_limits()), "nlp").total_time * 1.01


@pytest.mark.parametrize("keywords", [
    {"bounds": (0.1, 5.0)},  # the optimum's first segment is 0.88 s: the floor of the variables must be h_min
    {"bounds": (0.1, 2.0), "objective": "time-jerk", "weights": (1.0, 0.1)},  # h_max binds on three segments
])
def test_slsqp_searches_exactly_the_duration_bounds(keywords):
    """With duration bounds, SLSQP's variables range over [h_min, h_max]: it reaches the NLP's optimum, which
    has segments below 1 s and, for ``time-jerk``, segments on h_max."""
    problem = TimingProblem(VIA, "cubic", paper.paper_limits(), **keywords)
    tracker = _refined(problem, _equal_durations(problem))
    best = optimize(problem, "nlp")
    assert tracker.best_feasible and tracker.best_objective == pytest.approx(best.objective, rel=1e-7)
    assert best.durations.min() < 1.0
    if "weights" in keywords:
        assert np.sum(np.isclose(best.durations, 2.0, rtol=1e-9)) >= 2


def test_slsqp_stops_after_its_iterations():
    """``max_iterations`` bounds SLSQP's iterations (the ``slsqp`` optimizer's ``iterations`` setting): one
    iteration costs a few batches of S + 1 points; converging takes many more."""
    problem = TimingProblem(VIA, "cubic", paper.paper_limits())
    start = _equal_durations(problem)
    one, many = _refined(problem, start, max_iterations=1), _refined(problem, start, max_iterations=100)
    assert one.evaluations <= 4 * (problem.segment_count + 1) + 1 < many.evaluations
    assert one.best_objective > many.best_objective * (1 + 1e-3)


def test_the_finite_difference_points_are_evaluated_in_bounded_chunks(monkeypatch):
    """The S + 1 points of a forward-difference Jacobian were one batch: 3000 segments made a 1.2 GB array
    (a MemoryError out of planner.plan) and overran the time limit 3-fold (sweep 22). In chunks of at most
    CHUNK_COEFFICIENTS coefficients, each counted (the time limit checked) as it is evaluated, with the same
    values as one batch."""
    import planner.timing.local as local
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    x = _equal_durations(problem) * np.linspace(0.8, 1.2, problem.segment_count)
    whole = local._Model(problem, SearchTracker(problem)).at(x)
    segments, joints = problem.segment_count, problem.joint_count
    monkeypatch.setattr(local, "CHUNK_COEFFICIENTS", 3 * segments * joints * 8)  # three points a chunk
    tracker = SearchTracker(problem)
    counted: list[int] = []
    monkeypatch.setattr(tracker, "count", counted.append)
    chunked = local._Model(problem, tracker).at(x)
    assert counted[:-1] == [3] * (len(counted) - 1) and 1 <= counted[-1] <= 3 and sum(counted) == segments + 1
    np.testing.assert_allclose(chunked.df, whole.df, rtol=0, atol=0)
    np.testing.assert_allclose(chunked.dg, whole.dg, rtol=0, atol=0)
    assert (chunked.f, chunked.g.tolist()) == (whole.f, whole.g.tolist())
