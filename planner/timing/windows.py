"""A start for long problems: the NLP solved on overlapping windows of the via-points, stitched.

On a long trajectory the durations of one region hardly depend on those far
away (the spline's knot states couple neighbouring segments, and that coupling
decays within a few segments), but IPOPT's path on the whole problem is long:
clipped random walks of 1024 via-points took 27 to 147 iterations per start at
about 40 ms each, and the two starts could end 0.1 to 1 % apart. Solved on
windows of ``WINDOW_CHORDS`` chords instead (each from both cheap shapes of
``starts.py`` and, where they differ, their recombination, to a looser
tolerance, the best kept), the durations of each window's core, its chords but
``WINDOW_MARGIN`` at either end, are stitched; the whole NLP then solves from
there in 4 to 9 iterations (``STITCHED_IPOPT``). The windows run side by side, one process per core, each
taking the next window not yet taken (their costs differ by up to 3 times).

Windows. The chords 0 .. C-1 are split into k = ceil(C / core) cores of near
equal length, core = ``WINDOW_CHORDS`` - 2 ``WINDOW_MARGIN``; window i spans its
core and ``WINDOW_MARGIN`` chords on each side (fewer at the trajectory's
ends). A window is a timing problem of its own: the family, limits, bounds and
objective of the whole, through its via-points, from rest to rest. The rest at
a window's ends slows the chords next to them: the margins absorb it.
"""

from __future__ import annotations

import functools
import math
import time
from typing import Callable

import numpy as np

from ..concurrency import core_count, map_forked, map_forked_until
from ..errors import PlannerError
from .nlp import TimingNLP
from .problem import TimingProblem
from .result import SOLVED, remaining_time
from .starts import chord_segments, recombination, start_shapes

#: The name of the start stitched from the windows (``StartReport.label``).
WINDOWS = "windows"
#: Problems with at least this many segments start from their windows (``windowed_start``).
WINDOWED_SEGMENTS = 384
#: Chords of a window, and of its margin on each side that is solved but not kept.
WINDOW_CHORDS = 128
WINDOW_MARGIN = 16
#: IPOPT's tolerances in a window (the whole problem is solved to the usual ones after), and its first barrier
#: parameter: from a repaired shape (feasible), 1e-2 rather than the default 0.1 took 12 % fewer iterations over
#: the windows of six clipped walks (512 and 1024 via-points, hybrid; 1870 -> 1639) and 10 % over six more (3959
#: -> 3550), each window's best objective the same (one 3.6e-4 lower); 3e-2 and 5e-3 took more. MUMPS neither
#: scales nor permutes the KKT matrix by its values (``mumps_scaling``, ``mumps_permuting_scaling`` 0; the
#: defaults choose a scaling at every factorization): the windows of two clipped 512-point walks (hybrid) took
#: 1.54 s instead of 1.65 s in one process, with the same iterations and optima. Not in every solve: on the
#: paper's via-points 10 rad from zero, ranges 5 deg beyond them (cubic, from equal durations), a solve without
#: them ended outside a range.
WINDOW_IPOPT = {"ipopt.tol": 1e-6, "ipopt.constr_viol_tol": 1e-6, "ipopt.mu_init": 1e-2, "ipopt.mumps_scaling": 0,
                "ipopt.mumps_permuting_scaling": 0}
#: IPOPT's settings for the whole problem from the stitched windows: a start near the optimum, where the
#: default barrier parameter (0.1) first pushes every iterate away from its bounds, and the default push of
#: the start into the bounds' interior (1e-2 of a bound, or of the gap between two) moves it off the
#: optimum's active bounds. Over 24 clipped walks of 512 and 1024 via-points (hybrid; the benchmark's seeds,
#: 12 each) the whole NLP took 12 to 19 iterations from the stitched start with a barrier parameter of
#: 1e-3 and the default push, 4 to 9 with these, to the same optimum (within 1e-7 of the total); smooth
#: walks (512, hybrid) and cubic (1024, both classes) alike, 12-16 -> 4-7. Its tolerances are 1e-8 (1e-10
#: elsewhere): over six clipped walks (512 and 1024 via-points, hybrid) 28 iterations instead of 37, each
#: total 3.4e-10 to 7.2e-10 of itself higher once repaired (1e-9: 33 iterations, 5e-11 higher).
STITCHED_IPOPT = {"ipopt.mu_init": 1e-7, "ipopt.bound_push": 1e-8, "ipopt.bound_frac": 1e-8, "ipopt.tol": 1e-8,
                  "ipopt.constr_viol_tol": 1e-8}


def window_spans(chords: int) -> list[tuple[int, int, int, int]]:
    """(first, end, core_first, core_end) chord indices of each window of a trajectory of ``chords``
    chords (module docstring): the window spans chords first .. end - 1, its core core_first .. core_end - 1,
    and the cores partition 0 .. chords - 1."""
    core = WINDOW_CHORDS - 2 * WINDOW_MARGIN
    count = max(1, math.ceil(chords / core))
    edges = [round(i * chords / count) for i in range(count + 1)]
    return [(max(0, low - WINDOW_MARGIN), min(chords, high + WINDOW_MARGIN), low, high)
            for low, high in zip(edges[:-1], edges[1:])]


def window_settings(problem: TimingProblem, iterations: int) -> dict:
    """What ``summary.json`` records of ``problem``'s windowed start, whose windows took ``iterations``."""
    def options(ipopt: dict) -> dict:
        return {key.removeprefix("ipopt."): value for key, value in ipopt.items()}
    return {"count": len(window_spans(len(problem.via_points) - 1)), "chords": WINDOW_CHORDS, "margin": WINDOW_MARGIN,
            "ipopt": options(WINDOW_IPOPT), "stitched_ipopt": options(STITCHED_IPOPT), "iterations": iterations}


def windowed(problem: TimingProblem) -> bool:
    """Whether ``problem`` starts from its windows: long enough, and of a family whose limits the NLP bounds
    without cut rounds (``quintic`` and ``hermite7`` take rounds of solves in every window)."""
    return problem.segment_count >= WINDOWED_SEGMENTS and problem.family.name in ("cubic", "hybrid")


def _solve_window(problem: TimingProblem, window: tuple[int, int, int, int],
                  report: Callable | None = None) -> tuple[np.ndarray, np.ndarray, int] | None:
    """One window's NLP (``window_spans``) solved; None where neither of its shapes solved.

    Returns the durations (S_w,) [s], the best of its two shapes' solves and, where they differ, their
    recombination's (``starts.recombination``; repaired: feasible and tight), the chord of ``problem`` each
    of its segments belongs to (S_w,), and IPOPT's iterations over its solves. (``report``:
    ``map_forked_until``'s, unused: a window is whole or nothing.)"""
    first, end, _, _ = window
    try:
        part = TimingProblem(problem.via_points[first:end + 1], problem.family, problem.limits,
                             bounds=problem.bounds, objective=problem.objective_name, weights=problem.weights,
                             min_duration=problem.duration_floor)
    except PlannerError:  # a window with nothing to time on its own (no limited joint moves in it, ...)
        return None
    repaired = part.evaluate(np.array(list(start_shapes(part).values())))
    nlp = TimingNLP(part, repaired.durations[int(np.argmin(repaired.objective))], ipopt=WINDOW_IPOPT)

    iterations = 0

    def solved(starts) -> list[tuple[np.ndarray, float]]:
        """(durations, objective) of each start's solve that ended solved and feasible, repaired."""
        nonlocal iterations
        found = []
        for start in starts:
            outcome = nlp.solve(start)
            iterations += outcome.iterations
            result = part.evaluate(outcome.durations[None])
            if outcome.status in SOLVED and result.feasible[0]:
                found.append((result.durations[0], float(result.objective[0])))
        return found

    found = solved(repaired.durations)
    combined = recombination(found)
    if combined is not None:  # as ``nlp_refine`` does on the whole problem
        found += solved(part.evaluate(combined[None]).durations)
    if not found:
        return None
    return min(found, key=lambda item: item[1])[0], chord_segments(part) + first, iterations


def windowed_start(problem: TimingProblem) -> tuple[np.ndarray, int] | None:
    """Durations (S,) [s] stitched from the cores of ``problem``'s windows (module docstring), not yet
    repaired, and IPOPT's iterations over every window's solves; None where a window did not solve, or the
    time limit ended the windows."""
    chords = len(problem.via_points) - 1
    parts = window_spans(chords)
    solve = functools.partial(_solve_window, problem)
    workers = min(core_count(), len(parts))
    remaining = remaining_time()
    solved = map_forked(solve, parts, workers) if remaining is None else \
        map_forked_until(solve, parts, workers, time.monotonic() + remaining)
    whole = chord_segments(problem)
    stitched = np.full(problem.segment_count, np.nan)
    for (_, _, core_first, core_end), part in zip(parts, solved):
        if part is None:
            return None
        durations, local, _ = part
        kept, into = (local >= core_first) & (local < core_end), (whole >= core_first) & (whole < core_end)
        if kept.sum() != into.sum():  # a window's end chord is a core chord only at the trajectory's ends
            return None
        stitched[into] = durations[kept]
    if not np.all(np.isfinite(stitched)):
        return None
    return stitched, sum(part[2] for part in solved if part is not None)
