"""The timing problem and its optimizers, behind one entry point: ``optimize``."""

from __future__ import annotations

import inspect
import time
from dataclasses import replace
from typing import Callable

import numpy as np

from ..errors import InputError, SettingError, shown
from ..validate import MAX_SEED, Range, positive_finite, ranged
from .baselines import multistart_slsqp, particle_swarm, scipy_differential_evolution
from .cuckoo import cuckoo_search
from .nlp import OUT_OF_TIME, nlp_refine, nlp_settings
from .problem import Evaluation, TimingProblem
from .result import (
    SOLVED,
    TIME_LIMIT_REASON,
    OptimizationResult,
    OutOfTime,
    Progress,
    SearchTracker,
    StartReport,
    time_limit,
)
from .starts import start_shapes
from .windows import STITCHED_IPOPT, WINDOWS, window_settings, windowed, windowed_start

#: The start ``shape_starts`` adds where no shape's NLP solved (``result.SOLVED``): equal durations.
UNIFORM = "uniform"
#: Problems with at most this many segments get Cuckoo Search before the NLP in the default planner.
EXPLORED_SEGMENTS = 16


def shape_starts(problem: TimingProblem, *, seed: int | None = None,
                 progress: Progress | None = None) -> OptimizationResult:
    """The sparse NLP from the cheap shapes of ``starts.py`` (deterministic; ``seed`` is ignored)."""
    shapes = start_shapes(problem)
    tracker = SearchTracker(problem, progress, 1, {"starts": list(shapes), "nlp": nlp_settings(problem, len(shapes))})
    found = windowed_start(problem) if windowed(problem) else None
    if found is not None:
        tracker.settings["windows"] = window_settings(problem, found[1])
        nlp_refine(problem, {WINDOWS: found[0]}, tracker, STITCHED_IPOPT)
    if found is not None and any(start.status in SOLVED and start.feasible for start in tracker.starts):
        shapes = {WINDOWS: found[0]}
    else:  # no windows, or their start did not solve: the shapes themselves
        nlp_refine(problem, shapes, tracker)
    if not any(start.status in SOLVED for start in tracker.starts):
        # IPOPT is that sensitive on some problems (quintic, 6 via-points within 0.3 deg: both starts at the
        # iteration cap, and at the via-points shifted by 360 deg, which round the relative ones
        # differently, both converged 2 % lower): once more from equal durations, its own scaling too.
        # Not where a start solved to IPOPT's acceptable level (quintic, clipped 256-point walk: the third
        # start stopped at the cap too, and took the wall time from 12 to 54 s)
        shapes = {**shapes, UNIFORM: np.ones(problem.segment_count)}
        nlp_refine(problem, {UNIFORM: shapes[UNIFORM]}, tracker)
    tracker.end_iteration()
    origin = "the stitched solutions of its windows" if WINDOWS in shapes else f"{len(shapes)} shapes"
    tracker.settings.update(starts=list(shapes), nlp=nlp_settings(problem, len(shapes)))
    return tracker.result("nlp", f"NLP from {origin}{_unconverged(tracker.starts)}", None)



def _unconverged(starts: list[StartReport]) -> str:
    """What a stop reason adds where NLP starts fell short of IPOPT's full convergence (``Solve_Succeeded``):
    how many, and the first's status; nothing where every start converged."""
    short = [start for start in starts if start.status != "Solve_Succeeded"]
    if not short:
        return ""
    return (f"; {len(short)} of {len(starts)} starts fell short of IPOPT's full convergence (start "
            f"{short[0].label}: IPOPT {short[0].status})")


#: Relative difference within which the default planner's two NLPs (from the nests and from the shapes) found
#: one optimum (IPOPT's tolerances leave it 1e-12 apart): the nests' result is kept then.
SAME_OPTIMUM = 1e-9
#: The Cuckoo Search the default planner explores with (``_default_planner``).
DEFAULT_SEARCH = {"nests": 10, "iterations": 5, "refine_starts": 2}


def _default_planner(problem: TimingProblem, *, seed: int | None = 0, progress: Progress | None = None,
                     **settings) -> OptimizationResult:
    """The project's default. Up to ``EXPLORED_SEGMENTS`` segments: a short improved Cuckoo
    Search (10 nests, 5 iterations) explores, then the NLP refines its two best nests; the NLP from
    the cheap shapes (``shape_starts``) runs too and the better is kept: the NLP is not convex, and
    either set of starts can end in a local optimum the other avoids (8 via-points, three on range
    bounds: the nests' NLP, scaled by a nest, ended at an infeasible 30.12 s, and with other IPOPT
    settings at a feasible 15.32 s "solved to an acceptable level", where the shapes' reaches
    11.633 s; a cubic through 5 via-points of one joint: both nests converged to 1.0285 s, the shapes
    to 0.83893 s, which SLSQP from 24 random starts and differential evolution confirm). With
    ``polish: false`` (no NLP after the search) the shapes run only where the search ended infeasible.
    Larger problems, and the families whose via-point states the NLP chooses (hermite7,
    trigonometric): the NLP from the cheap shapes (``shape_starts``), where exploring costs more
    than it finds (each of those two families on the paper case and 16 random walks of 5 to 17
    via-points, smooth and clipped: the nests' NLP ended within 4e-8 of the shapes' every time, at
    up to 2.6 times their wall; trigonometric's paper case 3.0 s against 1.5 s). Cuckoo Search
    ``settings``, when given, apply at any size. The result's
    ``wall_time_s`` is the whole run's, both NLPs' included, whichever result it keeps."""
    if (problem.segment_count > EXPLORED_SEGMENTS or problem.family.free_states) and not settings:
        return shape_starts(problem, progress=progress)
    began = time.perf_counter()
    settings = DEFAULT_SEARCH | settings
    explored = cuckoo_search(problem, seed=seed, progress=progress, **settings)
    unconverged = [start for start in explored.starts if start.status != "Solve_Succeeded"]
    if settings.get("polish") is False and explored.feasible:  # the search alone, as asked: no NLP after it
        return explored
    try:
        shaped = shape_starts(problem, progress=progress)  # the NLP scaled by and started from the shapes too
    except OutOfTime as stop:  # the time limit ended the shapes' NLP: what the nests' found stays in the running
        states = None if explored.knot_states is None else explored.knot_states[None]
        stop.tracker.offer(problem.evaluate_durations(explored.durations[None], states))
        raise
    if shaped.feasible > explored.feasible or (shaped.feasible == explored.feasible
                                               and shaped.objective < explored.objective * (1 - SAME_OPTIMUM)):
        why = ("ended infeasible" if not explored.feasible else
               f"fell short of full convergence (start {unconverged[0].label}: IPOPT {unconverged[0].status})"
               if unconverged else
               f"ended higher ({explored.objective:.9g})")
        return replace(shaped, stop_reason=f"the NLP from Cuckoo Search's nests {why}; {shaped.stop_reason}",
                       wall_time_s=time.perf_counter() - began)
    return replace(explored, wall_time_s=time.perf_counter() - began)


def _paper_cuckoo(problem: TimingProblem, **settings) -> OptimizationResult:
    return cuckoo_search(problem, variant="paper", **settings)


#: Keyword parameters of the optimizers that are not settings of a task: the run's seed and progress
#: display, and the Cuckoo Search variant that the algorithm's name chooses.
NOT_SETTINGS = ("seed", "progress", "variant")
_COUNT = 10_000
#: Allowed values of every optimizer setting (``bool``: true or false), whichever optimizer takes it;
#: ``seed`` may also be None (an unseeded run), ``alpha`` and ``polish`` None (the variant's default).
#: Upper caps keep run time bounded; memory is bounded by the task's size too (``result.check_population``).
SETTING_RANGES: dict[str, Range | type] = {
    "nests": Range(2, _COUNT, integer=True),                 # Cuckoo Search
    "iterations": Range(1, 100_000, integer=True),           # Cuckoo Search, PSO, SLSQP
    "pa": Range(0, 1),
    "alpha": Range(0, 10, low_open=True),
    "beta": Range(1, 2, low_open=True),
    "polish": bool,
    "refine_starts": Range(1, _COUNT, integer=True),         # also at most nests
    "particles": Range(2, _COUNT, integer=True),             # PSO
    "inertia": Range(0, 1),
    "cognitive": Range(0, 4),
    "social": Range(0, 4),
    "population": Range(1, 1_000, integer=True),             # differential evolution
    "evaluations": Range(1, 10_000_000, integer=True),
    "starts": Range(1, _COUNT, integer=True),                # SLSQP
}
_SEED = Range(0, MAX_SEED, integer=True)
_MAY_BE_NONE = ("seed", "alpha", "polish")
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


def setting_names(algorithm: str) -> tuple[str, ...]:
    """Names of ``algorithm``'s settings: its keyword parameters but ``NOT_SETTINGS`` (ranges in
    ``SETTING_RANGES``; every algorithm also takes ``seed``)."""
    return tuple(p.name for p in inspect.signature(settings_signature(algorithm)).parameters.values()
                 if p.kind == p.KEYWORD_ONLY and p.name not in NOT_SETTINGS)


def checked_settings(algorithm: str, settings: dict) -> dict:
    """``settings`` of ``algorithm`` (a name in ``OPTIMIZERS``), each checked against ``SETTING_RANGES``
    and numpy scalars made Python numbers.

    ``progress`` (a callable, not a setting) passes through.

    Raises:
        SettingError: naming the first setting ``algorithm`` does not take, or that is outside its range,
            and for Cuckoo Search ``refine_starts`` above ``nests``.
    """
    names = setting_names(algorithm)
    checked = {}
    for name, value in settings.items():
        if name == "progress":
            if value is not None and not callable(value):
                raise SettingError(name, f"must be a callable progress(done, total) or None, got {shown(value)}")
            checked[name] = value
            continue
        if name != "seed" and name not in names:
            raise SettingError(name, f"{algorithm} takes no such setting; it takes: seed, {', '.join(names)}")
        if value is None and name in _MAY_BE_NONE:
            checked[name] = None
            continue
        try:
            checked[name] = ranged(value, _SEED if name == "seed" else SETTING_RANGES[name])
        except InputError as exc:
            raise SettingError(name, str(exc)) from None
    if checked.get("refine_starts") is not None:
        _check_refine_starts(algorithm, checked)
    return checked


def _check_refine_starts(algorithm: str, checked: dict) -> None:
    """``refine_starts`` needs the NLP polish and at most ``nests`` nests, given or the algorithm's default.

    Raises:
        SettingError: naming ``refine_starts``.
    """
    polish = checked.get("polish")
    if polish is False or (polish is None and algorithm == "cuckoo-paper"):
        raise SettingError("refine_starts", f"is how many nests the NLP polish starts from, and {algorithm} runs "
                                            f"no polish{' by default' if polish is None else ''}: drop it or set "
                                            f"polish: true")
    nests = checked.get("nests")
    default = nests is None
    if default:
        nests = DEFAULT_SEARCH["nests"] if algorithm == "default" else \
            inspect.signature(cuckoo_search).parameters["nests"].default
    if checked["refine_starts"] > nests:
        given = f" for {algorithm} by default" if default else ""
        raise SettingError("refine_starts", f"must be at most nests ({nests}{given}), got {checked['refine_starts']}")


def optimize(problem: TimingProblem, algorithm: str = "default", *, time_limit_s: float | None = None,
             **settings) -> OptimizationResult:
    """Run the named optimizer (see ``OPTIMIZERS``) with its settings.

    Args:
        problem: the timing problem.
        algorithm: a name in ``OPTIMIZERS`` (``default``: the sparse NLP from chosen starts).
        time_limit_s: wall time [s] after which the search stops and returns the best candidate
            found so far (``stop_reason`` says so; every optimizer but ``cuckoo-paper``, which scores
            raw penalised durations, holds a feasible candidate from its first evaluation on). None: no limit.
        **settings: the optimizer's own keywords (its function's), checked by ``checked_settings``.
    """
    if not isinstance(problem, TimingProblem):
        raise InputError(f"optimize takes a TimingProblem first, got {type(problem).__name__}")
    if time_limit_s is not None and not positive_finite(time_limit_s):
        raise InputError(f"time_limit_s must be a finite number of seconds > 0, or None for no limit; "
                         f"got {time_limit_s!r}")
    try:
        optimizer = OPTIMIZERS[algorithm]
    except (KeyError, TypeError):
        raise InputError(f"unknown optimizer {algorithm!r}; known: {', '.join(OPTIMIZERS)}") from None
    settings = checked_settings(algorithm, settings)
    began = time.perf_counter()
    with time_limit(time_limit_s):
        try:
            return optimizer(problem, **settings)
        except OutOfTime as stop:  # the search's settings (``SearchTracker.settings``) go with what it found
            found = stop.tracker.result(algorithm, _stopped(time_limit_s, stop.tracker.starts), settings.get("seed"))
            # the whole run's wall, not the stopped tracker's (the default planner's second NLP started late)
            return replace(found, wall_time_s=time.perf_counter() - began)


def _stopped(time_limit_s: float | None, starts: list[StartReport]) -> str:
    """The stop reason of a run the time limit ended, naming the NLP starts it cut off and the rounds
    each had solved (its last one is what the run kept of it)."""
    reason = f"{TIME_LIMIT_REASON} {time_limit_s:g} s reached"
    cut = [start for start in starts if start.status == OUT_OF_TIME]
    if not cut:
        return reason
    return reason + "; it stopped the NLP " + ", ".join(
        f"from {start.label} " + (f"after {start.rounds} solved round{'' if start.rounds == 1 else 's'}"
                                  if start.rounds else "before it solved a round") for start in cut)


__all__ = ["NOT_SETTINGS", "OPTIMIZERS", "SETTING_RANGES", "Evaluation", "OptimizationResult", "StartReport",
           "TimingProblem", "checked_settings", "cuckoo_search", "multistart_slsqp", "optimize", "particle_swarm",
           "scipy_differential_evolution", "setting_names", "settings_signature", "shape_starts"]
