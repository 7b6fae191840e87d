"""Gaps in the tests of planner/timing/nlp.py (nlp_settings, _processes, _concurrent, nlp_refine) found by
mutation testing (mutmut)."""

import numpy as np
import pytest

from planner import JointLimits, paper
from planner.timing import TimingProblem, optimize
from planner.timing.nlp import CONCURRENT_SEGMENTS, CUT_CONCURRENT_SEGMENTS, IPOPT_OPTIONS, nlp_settings


def _problem(family, segments):
    """A 1-joint zigzag of ``segments`` segments for ``family`` (cubic families: via-points + 1 segments)."""
    via_count = segments - 1 if family in ("cubic", "hybrid") else segments + 1
    via = np.array([[float(k % 2)] for k in range(via_count)])
    return TimingProblem(via, family, JointLimits.create(1, velocity=[1.0], acceleration=[2.0], jerk=[10.0]))


def test_the_nlp_settings_record_ipopts_options_without_its_output_switches():
    settings = nlp_settings(_problem("hybrid", 4), 2)
    assert set(settings) == {"ipopt", "warm_rounds", "variables", "max_rounds", "flag_margin", "processes"}
    assert settings["warm_rounds"] == {"warm_start_init_point": "yes", "mu_init": 1e-4}
    expected = {key[len("ipopt."):]: value for key, value in IPOPT_OPTIONS.items()
                if key.startswith("ipopt.") and key not in ("ipopt.print_level", "ipopt.sb")}
    assert settings["ipopt"] == expected and settings["ipopt"]["tol"] == 1e-10
    assert not {"print_level", "sb", "print_time"} & set(settings["ipopt"])
    assert settings["variables"] == "log-durations and knot states"
    assert (settings["max_rounds"], settings["flag_margin"]) == (12, 0.05)


@pytest.mark.parametrize("family, segments, processes", [
    ("hybrid", CONCURRENT_SEGMENTS - 1, 1), ("hybrid", CONCURRENT_SEGMENTS, 3), ("cubic", CONCURRENT_SEGMENTS, 3),
    ("cubic", 4, 1), ("quintic", CUT_CONCURRENT_SEGMENTS - 1, 1), ("quintic", CUT_CONCURRENT_SEGMENTS, 3),
    ("hermite7", CUT_CONCURRENT_SEGMENTS, 3), ("hermite7", CUT_CONCURRENT_SEGMENTS - 1, 1)])
def test_starts_are_solved_side_by_side_from_the_documented_sizes(family, segments, processes):
    """One process per start from CONCURRENT_SEGMENTS segments on, or CUT_CONCURRENT_SEGMENTS for quintic and
    hermite7 (cuts bound their limits); one process below."""
    problem = _problem(family, segments)
    assert problem.segment_count == segments
    assert nlp_settings(problem, 3)["processes"] == processes


def test_every_start_is_reported_under_its_label():
    result = optimize(TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits()), "nlp")
    assert [start.label for start in result.starts][:2] == ["cruise", "stop-at-turns"]


def test_starts_that_end_apart_are_recombined_and_solved_once_more(monkeypatch):
    """Where the solved starts differ (beyond AGREEMENT), ``nlp_refine`` solves once more from their
    recombination and reports it as the start ``recombined``; a start IPOPT did not solve takes no part.
    The solves and the recombination are stubbed (``starts.recombined`` has its own tests): two solved
    outcomes, the optimum with segment 1 or segment 6 30 % longer (5.8 % and 9.9 % slower once repaired),
    and an unsolved one; the recombination, given the two solved ones repaired, returns the optimum, which
    the stub solve returns as solved."""
    import planner.timing.nlp as nlp
    import planner.timing.starts as starts_module
    from planner.timing.result import SearchTracker

    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    optimum = optimize(problem, "nlp").durations
    slower = [optimum * np.where(np.arange(len(optimum)) == k, 1.3, 1.0) for k in (1, 6)]
    outcomes = [nlp.NLPOutcome(slower[0], 5, 1, "Solve_Succeeded", 0),
                nlp.NLPOutcome(slower[1], 6, 1, "Solve_Succeeded", 0),
                nlp.NLPOutcome(0.5 * optimum, 500, 1, "Maximum_Iterations_Exceeded", 0)]
    solves, recombinations = [], []

    def solve_all(_, starts):
        solves.append([np.array(start) for start in starts])
        return outcomes if len(solves) == 1 else [nlp.NLPOutcome(starts[0], 7, 1, "Solve_Succeeded", 0)]

    def recombine(solutions):
        recombinations.append([np.array(solution) for solution in solutions])
        return optimum

    monkeypatch.setattr(nlp, "_solve_all", solve_all)
    monkeypatch.setattr(starts_module, "recombined", recombine)
    tracker = SearchTracker(problem)
    nlp.nlp_refine(problem, {label: optimum for label in ("a", "b", "c")}, tracker)
    assert [start.label for start in tracker.starts] == ["a", "b", "c", "recombined"]
    repaired = problem.evaluate(np.array([outcome.durations for outcome in outcomes[:2]])).durations
    assert len(recombinations) == 1 and np.allclose(recombinations[0], repaired, rtol=1e-12, atol=0)
    assert len(solves) == 2 and np.allclose(solves[1], [optimum], rtol=1e-9, atol=0)
    recombined = tracker.starts[-1]
    assert recombined.status == "Solve_Succeeded" and recombined.iterations == 7
    assert recombined.objective == pytest.approx(optimum.sum(), rel=1e-9)
    assert tracker.best_objective == pytest.approx(recombined.objective, rel=1e-12)


def test_starts_that_agree_are_not_recombined(monkeypatch):
    """Solved starts within AGREEMENT of each other: no recombination, no fourth solve."""
    import planner.timing.nlp as nlp
    import planner.timing.starts as starts_module
    from planner.timing.result import SearchTracker

    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    optimum = optimize(problem, "nlp").durations
    monkeypatch.setattr(nlp, "_solve_all", lambda _, starts: [nlp.NLPOutcome(optimum, 5, 1, "Solve_Succeeded", 0)
                                                                for _ in starts])
    monkeypatch.setattr(starts_module, "recombined",
                        lambda solutions: pytest.fail("recombined where the starts agree"))
    tracker = SearchTracker(problem)
    nlp.nlp_refine(problem, {"a": optimum, "b": optimum}, tracker)
    assert [start.label for start in tracker.starts] == ["a", "b"]
