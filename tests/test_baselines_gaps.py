"""Gaps in the tests of planner/timing/baselines.py found by mutation testing (mutmut)."""

import numpy as np
import pytest

from conftest import record_evaluations
from planner import InputError, paper
from planner.timing import TimingProblem, particle_swarm, scipy_differential_evolution


def _problem():
    """The paper's first four via-points and limits, cubic family (6 segments): fast to search."""
    return TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits())


def test_pso_defaults_are_clerc_and_kennedys_constriction_and_the_documented_budget():
    """20 particles, 300 iterations (one evaluation of each particle at the start and per iteration:
    20 * 301), w = 0.7298, c1 = c2 = 1.49618, seed 0."""
    result = particle_swarm(_problem())
    assert result.settings == {"particles": 20, "iterations": 300, "inertia": 0.7298,
                               "cognitive": 1.49618, "social": 1.49618}
    assert result.evaluations == 20 * 301 and len(result.history) == 300 and result.seed == 0
    assert result.stop_reason == "completed 300 iterations" and result.feasible and result.algorithm == "pso"


@pytest.mark.parametrize("particles, iterations", [(1, 5), (0, 5), (5, 0), (1, 0)])
def test_pso_rejects_fewer_than_two_particles_or_no_iteration(particles, iterations):
    with pytest.raises(InputError, match=f"^PSO needs particles >= 2 and iterations >= 1, got {particles}, "
                                         f"{iterations}$"):
        particle_swarm(_problem(), particles=particles, iterations=iterations)


def test_pso_runs_with_the_smallest_settings():
    result = particle_swarm(_problem(), particles=2, iterations=1)
    assert result.evaluations == 2 * 2 and len(result.history) == 1 and result.feasible


def test_pso_is_reproducible_from_its_seed():
    problem = _problem()
    first, again = (particle_swarm(problem, iterations=5, seed=11) for _ in range(2))
    np.testing.assert_array_equal(first.durations, again.durations)
    assert first.history == again.history


def test_pso_reports_progress_once_per_iteration_with_the_best_so_far():
    calls = []
    result = particle_swarm(_problem(), particles=4, iterations=6, progress=lambda *args: calls.append(args))
    assert [(done, total) for done, total, _ in calls] == [(k, 6) for k in range(1, 7)]
    assert [best for _, _, best in calls] == result.history


def pso_candidates(monkeypatch, problem, **settings):
    """PSO's result on ``problem`` and every candidate (rows) it evaluated."""
    seen = record_evaluations(monkeypatch)
    result = particle_swarm(problem, **settings)
    return result, np.concatenate(seen)


def test_pso_evaluates_only_candidates_inside_the_search_box(monkeypatch):
    """Particles start uniformly in the box and every move is clipped to it (x <- clip(x + v))."""
    problem = _problem()
    lower, upper = problem.search_box()
    _, candidates = pso_candidates(monkeypatch, problem, particles=10, iterations=60, seed=2)
    assert len(candidates) == 10 * 61
    assert np.all(candidates >= lower) and np.all(candidates <= upper)


def test_pso_moves_stay_in_the_box_where_its_lower_side_binds(monkeypatch):
    """With duration bounds [2, 8] s every segment's optimum is the lower bound 2 s: particles drawn
    towards it overshoot, and each move must still be clipped to the box (mutmut: clipping only at the
    upper side evaluated about 2000 candidates below 2 s)."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits(), bounds=(2.0, 8.0))
    lower, upper = problem.search_box()
    result, candidates = pso_candidates(monkeypatch, problem, particles=10, iterations=60, seed=0)
    assert np.all(candidates >= lower) and np.all(candidates <= upper)
    assert np.allclose(result.durations, 2.0, rtol=0, atol=1e-9)  # the lower side is where the optimum is


def test_de_defaults_spend_about_the_documented_budget():
    """population 15 (15 * S members), generations chosen so that members * (generations + 1), the
    evaluations scipy spends without polishing, stays within the 6000 evaluations; seed 0."""
    problem = _problem()
    members = 15 * problem.segment_count
    result = scipy_differential_evolution(problem)
    generations = 6000 // members - 1
    assert result.settings == {"population": 15, "evaluations": 6000, "generations": generations}
    assert result.seed == 0
    assert result.evaluations == members * (generations + 1) <= 6000 < members * (generations + 2)
    assert result.algorithm == "de" and result.feasible


def test_de_refuses_a_budget_below_its_first_population_and_one_generation():
    """scipy evaluates the first population and at least one generation whatever the budget: 1
    evaluation asked spent 10 (sweep 15). A given budget below that is refused; without one, the
    budget is 6000 or those two populations where they are more, and the settings say which."""
    from planner import SettingError
    problem = _problem()
    members = 2 * problem.segment_count
    with pytest.raises(SettingError, match=rf"^optimizer setting evaluations: {2 * members - 1} is less than "
                                           rf"differential evolution's first population and one generation, "
                                           rf"{2 * members} evaluations here \(population 2 x {problem.segment_count} "
                                           rf"segments each\): raise it or lower the population$"):
        scipy_differential_evolution(problem, population=2, evaluations=2 * members - 1)
    calls = []
    result = scipy_differential_evolution(problem, population=2, evaluations=2 * members,
                                          progress=lambda *args: calls.append(args))
    assert result.settings["generations"] == 1 and result.evaluations == 2 * members
    assert [(done, total) for done, total, _ in calls] == [(1, 1)]
    large = scipy_differential_evolution(problem, population=1000, seed=1)
    members = 1000 * problem.segment_count
    assert large.settings["evaluations"] == 2 * members == large.evaluations
