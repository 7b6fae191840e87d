"""Baseline optimizers on the same ``TimingProblem``: PSO, differential evolution, multi-start SLSQP.

All of them see the repaired objective (the time-scaling repair of ``problem``) over
the same search box as Cuckoo Search, so a comparison measures the search strategy
alone. The default budgets of PSO and differential evolution match Cuckoo Search
with the paper's settings (about 6000 evaluations); SLSQP's (starts x iterations)
is not an evaluation budget: its finite differences spend far more.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, SettingError
from .local import refine
from .problem import TimingProblem
from .result import OptimizationResult, Progress, SearchTracker, check_population


def particle_swarm(problem: TimingProblem, *, particles: int = 20, iterations: int = 300,
                   inertia: float = 0.7298, cognitive: float = 1.49618, social: float = 1.49618,
                   seed: int | None = 0, progress: Progress | None = None) -> OptimizationResult:
    """Global-best PSO with constriction coefficients (Clerc & Kennedy), as in Kucuk's method.

    v <- w v + c1 r1 (p_i - x) + c2 r2 (g - x); x <- clip(x + v); velocities
    limited to 20 % of the box; repaired positions replace the particles.
    """
    if particles < 2 or iterations < 1:
        raise InputError(f"PSO needs particles >= 2 and iterations >= 1, got {particles}, {iterations}")
    check_population(problem, "particles", particles, particles)
    rng = np.random.default_rng(seed)
    tracker = SearchTracker(problem, progress, iterations, {
        "particles": particles, "iterations": iterations, "inertia": inertia, "cognitive": cognitive, "social": social})
    lower, upper = problem.search_box()
    span = upper - lower
    x = lower + span * rng.random((particles, len(lower)))
    velocity = 0.1 * span * rng.standard_normal(x.shape)
    evaluation = tracker.evaluate(x)
    x = problem.to_search_space(evaluation.durations)
    personal, personal_value = x.copy(), evaluation.objective.copy()
    for _ in range(iterations):
        best = personal[np.argmin(personal_value)]
        r1, r2 = rng.random(x.shape), rng.random(x.shape)
        velocity = inertia * velocity + cognitive * r1 * (personal - x) + social * r2 * (best - x)
        velocity = np.clip(velocity, -0.2 * span, 0.2 * span)
        x = np.clip(x + velocity, lower, upper)
        evaluation = tracker.evaluate(x)
        x = problem.to_search_space(evaluation.durations)
        better = evaluation.objective < personal_value
        personal[better], personal_value[better] = x[better], evaluation.objective[better]
        tracker.end_iteration()
    return tracker.result("pso", f"completed {iterations} iterations", seed)


def scipy_differential_evolution(problem: TimingProblem, *, population: int = 15, evaluations: int | None = None,
                                 seed: int | None = 0, progress: Progress | None = None) -> OptimizationResult:
    """scipy's ``differential_evolution`` (best1bin), vectorised, on the repaired objective.

    ``population`` is scipy's popsize multiplier (population * S members); generations are chosen
    so the budget is about ``evaluations``, which must cover the first population and one
    generation (2 * population * S). None: 6000, or those two where they are more.

    Raises:
        SettingError: ``evaluations`` below two populations, or a population too large for the
            problem (``check_population``).
    """
    lower, upper = problem.search_box()
    members = population * len(lower)
    check_population(problem, "population", population, members)
    if evaluations is not None and evaluations < 2 * members:
        raise SettingError("evaluations", f"{evaluations} is less than differential evolution's first population and "
                                          f"one generation, {2 * members:,} evaluations here (population {population} "
                                          f"x {len(lower)} segments each): raise it or lower the population")
    budget = max(6000, 2 * members) if evaluations is None else evaluations
    generations = max(1, budget // members - 1)
    tracker = SearchTracker(problem, progress, generations,
                            {"population": population, "evaluations": budget, "generations": generations})
    from scipy.optimize import differential_evolution  # imported where used: 0.1 s of every run's start

    solution = differential_evolution(
        lambda x: tracker.evaluate(x.T).objective, list(zip(lower, upper)), popsize=population,
        maxiter=generations, tol=0, seed=np.random.default_rng(seed), polish=False, vectorized=True,
        updating="deferred", callback=lambda *args, **kwargs: tracker.end_iteration())
    return tracker.result("de", solution.message, seed)


def multistart_slsqp(problem: TimingProblem, *, starts: int = 8, iterations: int = 100, seed: int | None = 0,
                     progress: Progress | None = None) -> OptimizationResult:
    """scipy SLSQP (see ``local.refine``) from ``starts`` random repaired points of the box."""
    if starts < 1:
        raise InputError(f"SLSQP needs starts >= 1, got {starts}")
    rng = np.random.default_rng(seed)
    tracker = SearchTracker(problem, progress, starts, {"starts": starts, "iterations": iterations})
    lower, upper = problem.search_box()
    points = tracker.evaluate(lower + (upper - lower) * rng.random((starts, len(lower)))).durations
    for start in points:
        refine(problem, start, tracker, max_iterations=iterations)
        tracker.end_iteration()
    return tracker.result("slsqp", f"{starts} SLSQP starts", seed)
