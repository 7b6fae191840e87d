"""Gaps in the tests of planner/timing/__init__.py found by mutation testing (mutmut)."""

import numpy as np
import pytest

from planner import InputError, JointLimits, SettingError, paper
from planner.timing import TimingProblem, optimize


def test_cuckoo_paper_takes_its_settings():
    """``cuckoo-paper`` passes its settings on to Cuckoo Search (the plain variant)."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits(), bounds=(0.5, 8.0))
    result = optimize(problem, "cuckoo-paper", nests=4, iterations=3, seed=5)
    assert result.algorithm == "cuckoo-paper" and result.seed == 5
    assert result.settings["nests"] == 4 and result.settings["iterations"] == 3 and len(result.history) == 3
    assert result.settings["variant"] == "paper" and result.evaluations == 4 * (1 + 2 * 3)


# ---------------------------------------------------------------- added by the second mutation run (/tmp/mut38)


def _walk(via_count):
    """A cubic problem of via_count + 1 segments: a 2-joint random walk (fixed seed) under all three limits."""
    via = np.cumsum(np.random.default_rng(5).uniform(-1, 1, (via_count, 2)), axis=0)
    limits = JointLimits.create(2, velocity=[1.0, 1.5], acceleration=[2.0, 3.0], jerk=[10.0, 20.0])
    return TimingProblem(via, "cubic", limits)


def test_the_default_planner_explores_up_to_16_segments_with_its_documented_cuckoo_search():
    """Up to EXPLORED_SEGMENTS = 16 segments: Cuckoo Search of 10 nests and 5 iterations, seeded by the run's
    seed, then the NLP from its two best nests; progress once per iteration."""
    problem = _walk(15)
    assert problem.segment_count == 16
    calls = []
    result = optimize(problem, seed=3, progress=lambda *args: calls.append(args))
    assert result.algorithm == "cuckoo" and result.seed == 3
    assert (result.settings["nests"], result.settings["iterations"], result.settings["refine_starts"]) == (10, 5, 2)
    assert [start.label for start in result.starts][:2] == ["nest 1", "nest 2"]
    assert [(done, total) for done, total, _ in calls] == [(k, 5) for k in range(1, 6)]


def test_the_default_planner_solves_larger_problems_from_the_shapes_unless_given_settings():
    """Beyond 16 segments and without settings: the NLP from the cheap shapes (one iteration of progress);
    Cuckoo Search settings, when given, apply at any size."""
    problem = _walk(16)
    assert problem.segment_count == 17
    calls = []
    shaped = optimize(problem, progress=lambda *args: calls.append(args))
    assert shaped.algorithm == "nlp" and shaped.settings["starts"] == ["cruise", "stop-at-turns"]
    assert [(done, total) for done, total, _ in calls] == [(1, 1)]
    explored = optimize(problem, "default", nests=4, iterations=2, polish=False)
    assert explored.algorithm == "cuckoo" and explored.settings["nests"] == 4 and len(explored.history) == 2


def _outcome(algorithm, objective, feasible, statuses=()):
    """A hand-made optimizer result: only what the default planner's choice reads is meaningful."""
    from planner.timing import OptimizationResult, StartReport

    starts = [StartReport(f"nest {k + 1}", objective, feasible, 5, 1, status, 0) for k, status in enumerate(statuses)]
    return OptimizationResult(algorithm, np.ones(2), objective, objective, np.zeros((3, 1)), feasible, 1, 0.0, [],
                              f"{algorithm} done", 0, starts=starts)


OK, SLOW = "Solve_Succeeded", "Maximum_Iterations_Exceeded"


@pytest.mark.parametrize("explored, shaped, chosen, reason", [
    (_outcome("cuckoo", 10.0, True, [OK, OK]), None, "cuckoo", "cuckoo done"),  # converged: no second NLP
    (_outcome("cuckoo", 10.0, True, [OK, SLOW]), _outcome("nlp", 11.0, True), "cuckoo", "cuckoo done"),
    (_outcome("cuckoo", 10.0, True, [OK, SLOW]), _outcome("nlp", 9.0, True), "nlp",
     f"the NLP from Cuckoo Search's nests did not converge (start nest 2: IPOPT {SLOW}); nlp done"),
    (_outcome("cuckoo", 10.0, True, [SLOW]), _outcome("nlp", 9.0, False), "cuckoo", "cuckoo done"),
    (_outcome("cuckoo", 10.0, True, [SLOW]), _outcome("nlp", 10.0, True), "cuckoo", "cuckoo done"),  # a tie keeps it
    (_outcome("cuckoo", 10.0, False, [OK]), _outcome("nlp", 12.0, True), "nlp",
     "the NLP from Cuckoo Search's nests ended infeasible; nlp done"),
    (_outcome("cuckoo", 10.0, False, [OK]), _outcome("nlp", 9.0, False), "nlp",
     "the NLP from Cuckoo Search's nests ended infeasible; nlp done"),
    (_outcome("cuckoo", 10.0, False, [OK]), _outcome("nlp", 11.0, False), "cuckoo", "cuckoo done"),
])
def test_the_default_planner_keeps_the_better_of_its_nests_and_the_shapes(monkeypatch, explored, shaped, chosen,
                                                                          reason):
    """Feasible first, then the smaller objective (explored kept on a tie); the shapes' NLP runs only where
    the nests' NLP ended infeasible or a start fell short of Solve_Succeeded. Both get the run's seed,
    progress and settings."""
    import planner.timing as timing

    calls = []

    def cuckoo(problem, **keywords):
        calls.append(("cuckoo", keywords))
        return explored

    def shapes(problem, **keywords):
        calls.append(("shapes", keywords))
        return shaped

    monkeypatch.setattr(timing, "cuckoo_search", cuckoo)
    monkeypatch.setattr(timing, "shape_starts", shapes)
    progress = print
    result = timing._default_planner(_walk(4), seed=7, progress=progress, pa=0.5)
    assert (result.algorithm, result.stop_reason) == (chosen, reason)
    assert calls[0] == ("cuckoo", {"seed": 7, "progress": progress, "nests": 10, "iterations": 5, "refine_starts": 2,
                                   "pa": 0.5})
    assert calls[1:] == ([] if shaped is None else [("shapes", {"progress": progress})])


def test_the_shapes_nlp_reports_its_name_reason_and_settings():
    """``nlp``: the NLP from the two cheap shapes, named and explained as such, with the NLP's settings for two
    starts (a quintic problem of two segments solves them side by side: two processes)."""
    from planner.timing.nlp import nlp_settings

    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:3], "quintic", paper.paper_limits())
    result = optimize(problem, "nlp")
    assert result.algorithm == "nlp" and result.stop_reason == "NLP from 2 shapes" and result.seed is None
    assert result.settings == {"starts": ["cruise", "stop-at-turns"], "nlp": nlp_settings(problem, 2)}
    assert result.settings["nlp"]["processes"] == 2


def test_every_setting_after_a_progress_callback_is_still_checked_and_used():
    problem = _walk(4)
    calls = []
    result = optimize(problem, "cuckoo", progress=lambda *args: calls.append(args), nests=4, iterations=2,
                      polish=False)
    assert result.settings["nests"] == 4 and len(result.history) == 2 and len(calls) == 2
    with pytest.raises(SettingError, match="nests"):
        optimize(problem, "cuckoo", progress=None, nests=1)


def test_none_is_taken_where_it_means_something_and_refused_elsewhere():
    """seed, alpha and polish may be None (unseeded, the variant's defaults); the settings after them are still
    used. Any other setting None is refused by name."""
    problem = _walk(4)
    result = optimize(problem, "cuckoo", seed=None, alpha=None, polish=None, nests=4, iterations=2, refine_starts=1)
    assert result.seed is None and result.settings["alpha"] == 0.3 and result.settings["polish"] is True
    assert result.settings["nests"] == 4 and len(result.history) == 2
    with pytest.raises(SettingError, match="nests"):
        optimize(problem, "cuckoo", nests=None)


def test_refine_starts_may_equal_nests():
    result = optimize(_walk(4), "cuckoo", nests=2, refine_starts=2, iterations=1)
    assert result.settings["refine_starts"] == result.settings["nests"] == 2 and len(result.starts) >= 2


def test_a_wrong_problem_or_optimizer_is_refused_by_name():
    with pytest.raises(InputError, match="^optimize takes a TimingProblem first, got dict$"):
        optimize({"via_points": []})
    with pytest.raises(InputError, match="^unknown optimizer 'ga'; known: default, nlp, cuckoo, cuckoo-paper, pso, de, "
                                         "slsqp$"):
        optimize(_walk(4), "ga")


def test_a_run_stopped_by_its_time_limit_reports_what_was_asked():
    """At the time limit: the best candidate so far, under the optimizer's name, with the run's seed and every
    setting it ran with, the caller's and the defaults, as a whole run records them (not seed or progress),
    and the reason."""
    calls = []
    result = optimize(_walk(4), "cuckoo", time_limit_s=0.05, nests=50, iterations=100_000, seed=4,
                      progress=lambda *args: calls.append(args))
    assert result.algorithm == "cuckoo" and result.seed == 4 and result.feasible
    defaults = optimize(_walk(4), "cuckoo", nests=2, iterations=1).settings
    assert result.settings == defaults | {"nests": 50, "iterations": 100_000} and "seed" not in result.settings
    assert result.stop_reason == "time limit of 0.05 s reached" and 0 < len(result.history) < 100_000
