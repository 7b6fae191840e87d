"""Starting durations for the sparse NLP: cheap shapes from the limits, and a recombination of
solved starts.

A chord is the motion between two consecutive (distinct) via-points, D_j =
|p_{i+1,j} - p_{i,j}| per joint [rad]. Two estimates of its duration [s]:

* ``cruise``: max_j D_j / V_j, the time at the velocity limit (rest-to-rest
  where no joint has one);
* ``stop-at-turns``: per joint, D_j / V_j where the joint moves the same way
  before, along and after the chord (it passes both via-points at speed), and
  its rest-to-rest time otherwise, max(D_j / V_j, 2 sqrt(D_j / A_j),
  (32 D_j / Jk_j)^(1/3)) (``limits.rest_to_rest_time``): it stops where it turns,
  rests or the path ends. The slowest joint sets the chord's time.

A chord's time is split evenly among its segments (the cubic families have two
segments on the first and last chord), and chords are kept above 1e-3 of the
longest. The shapes are shapes: ``TimingProblem.evaluate`` scales them to be
feasible and tight.

Two starts, one per core of a two-core machine. ``stop-at-turns`` replaced
``rest-to-rest`` (every chord from rest to rest), which gives a short chord of a
joint passing its via-points a time that grows like sqrt(D) rather than D; from
there the NLP often kept the joint nearly stopped on it, a local optimum up to
6.5 % above the best that any start found (clipped random walks, cubic and
hybrid, 64 to 1024 via-points). ``uniform`` (all segments equal) was dropped
before: over 74 problems it never ended strictly best.

Recombination. The problem is not convex: on clipped walks the starts can end
in optima that differ region by region (a short chord passed at speed in one,
nearly stopped at in the other). ``recombined`` takes, in each region where two
solutions differ, the durations of the one that spends less time there, and the
NLP solves from that, unless no region was taken (the best start is then its
own recombination). Over 28 walks (hybrid, 128 to 1024 via-points: the
benchmark's smooth and clipped walks, and walks clipped to half the PUMA's
ranges) the starts differed in 15; solved from their recombination, the NLP
ended at the better start's optimum in 11 and below both in the other 4.
"""

from __future__ import annotations

import numpy as np

from ..limits import rest_to_rest_time
from .problem import TimingProblem
from .result import AGREEMENT

_CHORD_FLOOR = 1e-3
#: Solutions differ on a segment where their durations differ by more than this fraction.
DIFFERENCE = 1e-4
#: Segments on each side of a difference that belong to its region: the knot states couple neighbours.
REGION_MARGIN = 2


def chord_segments(problem: TimingProblem) -> np.ndarray:
    """(S,) the chord (0 .. n'-2) each segment belongs to."""
    knots = problem.family.via_knots(len(problem.via_points))
    return np.searchsorted(knots, np.arange(problem.segment_count), side="right") - 1


def _spread(problem: TimingProblem, chord_times: np.ndarray) -> np.ndarray:
    """Durations (S,) that split each chord's time evenly among its segments."""
    floor = _CHORD_FLOOR * chord_times.max() if chord_times.max() > 0 else 1.0
    chord_times = np.maximum(chord_times, floor)
    chords = chord_segments(problem)
    return chord_times[chords] / np.bincount(chords)[chords]


def start_shapes(problem: TimingProblem) -> dict[str, np.ndarray]:
    """Named starting shapes (S,) [s, up to scale]: ``cruise`` and ``stop-at-turns``."""
    limits = problem.limits
    step = np.diff(problem.via_points, axis=0)  # (chords, J)
    distance = np.abs(step)
    cruise = distance / limits.velocity  # absent limits are inf: their terms vanish
    rest = rest_to_rest_time(distance, limits)
    if not np.isfinite(limits.velocity).any():
        cruise = rest
    direction = np.sign(step)
    still = np.zeros((1, direction.shape[1]))
    passing = (np.vstack((still, direction[:-1])) == direction) & (np.vstack((direction[1:], still)) == direction)
    return {"cruise": _spread(problem, cruise.max(axis=1)),
            "stop-at-turns": _spread(problem, np.where(passing, cruise, rest).max(axis=1))}


def _regions(first: np.ndarray, second: np.ndarray) -> list[slice]:
    """Maximal runs of segments where durations (S,) ``first`` and ``second`` differ by more than
    ``DIFFERENCE`` (relative), each widened by ``REGION_MARGIN`` segments on both sides."""
    differ = np.abs(first - second) > DIFFERENCE * np.maximum(first, second)
    widened = np.convolve(differ, np.ones(2 * REGION_MARGIN + 1), mode="same") > 0
    edges = np.flatnonzero(np.diff(np.concatenate(([0], widened.astype(int), [0]))))
    return [slice(start, end) for start, end in zip(edges[::2], edges[1::2])]


def recombined(solutions: list[np.ndarray]) -> np.ndarray | None:
    """Durations (S,) [s] that follow the shortest of ``solutions`` (each (S,), feasible) and, in every
    region where another one differs from it, take that one's durations if they sum to less there;
    None where no region is taken (the shortest is already the recombination: nothing to solve)."""
    if not solutions:
        return None
    order = np.argsort([solution.sum() for solution in solutions])
    result = solutions[order[0]].copy()
    taken = 0
    for other in (solutions[i] for i in order[1:]):
        for region in _regions(result, other):
            if other[region].sum() < result[region].sum():
                result[region] = other[region]
                taken += 1
    return result if taken else None


def recombination(solved: list[tuple[np.ndarray, float]]) -> np.ndarray | None:
    """``recombined`` durations (S,) [s] of solved starts, each (durations (S,) [s], objective), where their
    objectives differ by more than ``AGREEMENT``; None where none is given, they agree (nothing to gain), or no
    region is taken."""
    objectives = [objective for _, objective in solved]
    if not solved or max(objectives) <= min(objectives) * (1 + AGREEMENT):
        return None
    return recombined([durations for durations, _ in solved])
