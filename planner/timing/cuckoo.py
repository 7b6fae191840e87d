"""Cuckoo Search (Yang & Deb 2009) over segment durations, vectorised over nests.

Each iteration:

1. Levy flights: every nest x_i proposes x_i + alpha * L * (x_i - x_best) * N(0, 1),
   with L drawn by Mantegna's method, L = u / |v|^(1/beta), u ~ N(0, sigma_u^2),
   v ~ N(0, 1), sigma_u = [Gamma(1+beta) sin(pi beta / 2) /
   (Gamma((1+beta)/2) beta 2^((beta-1)/2))]^(1/beta), beta = 1.5.
2. Discovery: each component is abandoned with probability pa and moved by
   r * (x_perm1 - x_perm2), r ~ U(0, 1), two random permutations of the nests.

A proposal replaces its nest only if it is better (greedy). Proposals are
clipped to the search box.

Variants:

* ``paper``: the plain algorithm, candidates evaluated as durations with a
  penalty where infeasible (needs duration bounds), as the source paper did.
* ``improved`` (default): every candidate is repaired by the time-scaling
  lemma (feasible and tight in closed form) and the repaired durations
  replace the nest (Lamarckian); the best nests are then refined by the
  sparse NLP (``nlp.py``).
"""

from __future__ import annotations

from math import gamma, pi, sin

import numpy as np

from ..errors import InputError
from .nlp import nlp_refine, nlp_settings
from .problem import TimingProblem
from .result import OptimizationResult, Progress, SearchTracker, check_population

VARIANTS = ("improved", "paper")


def mantegna_sigma(beta: float) -> float:
    """sigma_u of Mantegna's algorithm for Levy-stable steps of index ``beta``."""
    return (gamma(1 + beta) * sin(pi * beta / 2) / (gamma((1 + beta) / 2) * beta * 2 ** ((beta - 1) / 2))) ** (1 / beta)


def cuckoo_search(problem: TimingProblem, *, nests: int = 20, iterations: int = 150, pa: float = 0.25,
                  alpha: float | None = None, beta: float = 1.5, seed: int | None = 0,
                  variant: str = "improved", polish: bool | None = None, refine_starts: int = 1,
                  progress: Progress | None = None) -> OptimizationResult:
    """Minimise the problem's objective with Cuckoo Search.

    Args:
        problem: the timing problem.
        nests: population size.
        iterations: generations (2 * nests evaluations each).
        pa: discovery probability.
        beta: Levy index.
        alpha: Levy step scale (default 0.3 for ``improved``, which measured best of 0.01 to 1
            on the paper case, and Yang and Deb's 0.01 for ``paper``).
        seed: seed of the ``numpy.random.Generator``; equal seeds give equal results.
        variant: ``improved`` or ``paper`` (see module docstring).
        polish: refine by the sparse NLP at the end (default: True for ``improved``, False for ``paper``).
        refine_starts: how many of the best final nests the NLP starts from.
        progress: called after every iteration.
    """
    if variant not in VARIANTS:
        raise InputError(f"unknown Cuckoo Search variant {variant!r}; known: {', '.join(VARIANTS)}")
    if alpha is None:
        alpha = 0.3 if variant == "improved" else 0.01
    if (nests < 2 or iterations < 1 or not 0 <= pa <= 1 or alpha <= 0 or not 1 < beta <= 2
            or not 1 <= refine_starts <= nests):
        raise InputError(f"Cuckoo Search needs nests >= 2, iterations >= 1, 0 <= pa <= 1, alpha > 0, "
                         f"1 < beta <= 2 and 1 <= refine_starts <= nests; got nests={nests}, "
                         f"iterations={iterations}, pa={pa}, alpha={alpha}, beta={beta}, "
                         f"refine_starts={refine_starts}")
    check_population(problem, "nests", nests, nests)
    repair = variant == "improved"
    if not repair and problem.bounds is None:
        raise InputError("the plain paper variant of Cuckoo Search (cuckoo-paper) needs duration bounds: "
                         "give optimizer.bounds_s")
    polish = repair if polish is None else polish
    rng = np.random.default_rng(seed)
    settings = {"nests": nests, "iterations": iterations, "pa": pa, "alpha": alpha, "beta": beta,
                "variant": variant, "polish": polish, "refine_starts": refine_starts}
    if polish:
        settings["nlp"] = nlp_settings(problem, refine_starts)
    tracker = SearchTracker(problem, progress, iterations, settings)
    lower, upper = problem.search_box()
    dimension = len(lower)
    sigma = mantegna_sigma(beta)

    def assess(candidates):
        evaluation = tracker.evaluate(candidates, repair=repair)
        kept = problem.to_search_space(evaluation.durations) if repair else candidates
        return kept, evaluation.objective

    x, fitness = assess(lower + (upper - lower) * rng.random((nests, dimension)))
    for _ in range(iterations):
        best = x[np.argmin(fitness)]
        levy = (rng.standard_normal((nests, dimension)) * sigma
                / np.abs(rng.standard_normal((nests, dimension))) ** (1 / beta))
        proposal = np.clip(x + alpha * levy * (x - best) * rng.standard_normal((nests, dimension)), lower, upper)
        x, fitness = _greedy(x, fitness, *assess(proposal))
        abandon = rng.random((nests, dimension)) < pa
        step = rng.random() * (x[rng.permutation(nests)] - x[rng.permutation(nests)])
        proposal = np.clip(x + step * abandon, lower, upper)
        x, fitness = _greedy(x, fitness, *assess(proposal))
        tracker.end_iteration()
    if polish:
        best = np.argsort(fitness)[:refine_starts]
        nlp_refine(problem, {f"nest {rank + 1}": x[i] for rank, i in enumerate(best)}, tracker)
    name = "cuckoo" if repair else "cuckoo-paper"
    return tracker.result(name, f"completed {iterations} iterations" + (" and NLP refinement" if polish else ""),
                          seed)


def _greedy(x, fitness, proposal, proposal_fitness):
    better = proposal_fitness < fitness
    return np.where(better[:, None], proposal, x), np.where(better, proposal_fitness, fitness)
