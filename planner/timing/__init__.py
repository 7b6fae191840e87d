"""The timing problem and its optimizers, behind one entry point: ``optimize``."""

from __future__ import annotations

import inspect
from typing import Callable

from ..errors import InputError
from ..validate import positive_finite
from .baselines import multistart_slsqp, particle_swarm, scipy_differential_evolution
from .cuckoo import cuckoo_search
from .nlp import nlp_refine, nlp_settings
from .problem import Evaluation, TimingProblem
from .result import OptimizationResult, OutOfTime, Progress, SearchTracker, StartReport, time_limit
from .starts import start_shapes

#: Problems with at most this many segments get Cuckoo Search before the NLP in the default planner.
EXPLORED_SEGMENTS = 16


def shape_starts(problem: TimingProblem, *, seed: int | None = None,
                 progress: Progress | None = None) -> OptimizationResult:
    """The sparse NLP from the cheap shapes of ``starts.py`` (deterministic; ``seed`` is ignored)."""
    tracker = SearchTracker(problem, progress, 1)
    shapes = start_shapes(problem)
    nlp_refine(problem, shapes, tracker)
    tracker.end_iteration()
    return tracker.result("nlp", f"NLP from {len(shapes)} shapes", None,
                          {"starts": list(shapes), "nlp": nlp_settings(problem, len(shapes))})


def _default_planner(problem: TimingProblem, *, seed: int | None = 0, progress: Progress | None = None,
                     **settings) -> OptimizationResult:
    """The project's default. Up to ``EXPLORED_SEGMENTS`` segments: a short improved Cuckoo
    Search (10 nests, 5 iterations) explores, then the NLP refines its two best nests. Larger
    problems: the NLP from the cheap shapes (``shape_starts``), where exploring costs more than
    it finds. Cuckoo Search ``settings``, when given, apply at any size."""
    if problem.segment_count > EXPLORED_SEGMENTS and not settings:
        return shape_starts(problem, progress=progress)
    settings = {"nests": 10, "iterations": 5, "refine_starts": 2} | settings
    return cuckoo_search(problem, seed=seed, progress=progress, **settings)


def _paper_cuckoo(problem: TimingProblem, **settings) -> OptimizationResult:
    return cuckoo_search(problem, variant="paper", **settings)


#: Keyword parameters of the optimizers that are not settings of a task: the run's seed and progress
#: display, and the Cuckoo Search variant that the algorithm's name chooses.
NOT_SETTINGS = ("seed", "progress", "variant")
#: algorithm name -> optimizer(problem, **settings)
OPTIMIZERS = {
    "default": _default_planner,
    "nlp": shape_starts,
    "cuckoo": cuckoo_search,
    "cuckoo-paper": _paper_cuckoo,
    "pso": particle_swarm,
    "de": scipy_differential_evolution,
    "slsqp": multistart_slsqp,
}


def settings_signature(algorithm: str) -> Callable:
    """The function whose keyword parameters are ``algorithm``'s settings (``default`` and
    ``cuckoo-paper`` pass theirs on to Cuckoo Search)."""
    return cuckoo_search if algorithm in ("default", "cuckoo-paper") else OPTIMIZERS[algorithm]


def optimize(problem: TimingProblem, algorithm: str = "default", *, time_limit_s: float | None = None,
             **settings) -> OptimizationResult:
    """Run the named optimizer (see ``OPTIMIZERS``) with its settings.

    Args:
        time_limit_s: wall time [s] after which the search stops and returns the best candidate
            found so far (``stop_reason`` says so; every optimizer but ``cuckoo-paper``, which scores
            raw penalised durations, holds a feasible candidate from its first evaluation on). None: no limit.
    """
    if time_limit_s is not None and not positive_finite(time_limit_s):
        raise InputError(f"time_limit_s must be a finite number of seconds > 0, or None for no limit; "
                         f"got {time_limit_s!r}")
    try:
        optimizer = OPTIMIZERS[algorithm]
    except (KeyError, TypeError):
        raise InputError(f"unknown optimizer {algorithm!r}; known: {', '.join(OPTIMIZERS)}") from None
    try:  # only a setting the optimizer does not take is the caller's mistake; a TypeError inside is a bug
        inspect.signature(settings_signature(algorithm)).bind(problem, **settings)
    except TypeError as exc:
        raise InputError(f"bad settings for optimizer {algorithm!r}: {exc}") from None
    with time_limit(time_limit_s):
        try:
            return optimizer(problem, **settings)
        except OutOfTime as stop:
            requested = {key: value for key, value in settings.items() if key not in NOT_SETTINGS}
            return stop.tracker.result(algorithm, f"time limit of {time_limit_s:g} s reached", settings.get("seed"),
                                       requested)


__all__ = ["NOT_SETTINGS", "OPTIMIZERS", "Evaluation", "OptimizationResult", "StartReport", "TimingProblem",
           "cuckoo_search", "multistart_slsqp", "optimize", "particle_swarm", "scipy_differential_evolution",
           "settings_signature", "shape_starts"]
