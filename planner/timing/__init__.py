"""The timing problem and its optimizers, behind one entry point: ``optimize``."""

from __future__ import annotations

from ..errors import InputError
from .baselines import multistart_slsqp, particle_swarm, scipy_differential_evolution
from .cuckoo import cuckoo_search
from .problem import Evaluation, TimingProblem
from .result import OptimizationResult, Progress


def _default_planner(problem: TimingProblem, *, seed: int | None = 0, progress: Progress | None = None,
                     **settings) -> OptimizationResult:
    """The project's default: a short improved Cuckoo Search (20 nests, 10 iterations) for global
    exploration, then SLSQP refinement from its two best nests."""
    settings = {"nests": 20, "iterations": 10, "refine_starts": 2} | settings
    return cuckoo_search(problem, seed=seed, progress=progress, **settings)


def _paper_cuckoo(problem: TimingProblem, **settings) -> OptimizationResult:
    return cuckoo_search(problem, variant="paper", **settings)


#: algorithm name -> optimizer(problem, **settings)
OPTIMIZERS = {
    "default": _default_planner,
    "cuckoo": cuckoo_search,
    "cuckoo-paper": _paper_cuckoo,
    "pso": particle_swarm,
    "de": scipy_differential_evolution,
    "slsqp": multistart_slsqp,
}


def optimize(problem: TimingProblem, algorithm: str = "default", **settings) -> OptimizationResult:
    """Run the named optimizer (see ``OPTIMIZERS``) with its settings."""
    try:
        optimizer = OPTIMIZERS[algorithm]
    except (KeyError, TypeError):
        raise InputError(f"unknown optimizer {algorithm!r}; known: {', '.join(OPTIMIZERS)}") from None
    try:
        return optimizer(problem, **settings)
    except TypeError as exc:
        raise InputError(f"bad settings for optimizer {algorithm!r}: {exc}") from None


__all__ = ["OPTIMIZERS", "Evaluation", "OptimizationResult", "TimingProblem", "cuckoo_search",
           "multistart_slsqp", "optimize", "particle_swarm", "scipy_differential_evolution"]
