"""Cheap starting durations for the sparse NLP, from the limits alone.

A chord is the motion between two consecutive (distinct) via-points, D_j =
|p_{i+1,j} - p_{i,j}| per joint [rad]. Two estimates of its duration [s]:

* ``rest-to-rest``: the slowest joint's time to cover D_j from rest to rest,
  max_j max(D_j / V_j, 2 sqrt(D_j / A_j), (32 D_j / Jk_j)^(1/3)) (the
  velocity-, acceleration- and jerk-limited minima, ``limits.rest_to_rest_time``);
* ``cruise``: max_j D_j / V_j, the time at the velocity limit (rest-to-rest
  where no joint has one).

A chord's time is split evenly among its segments (the cubic families have two
segments on the first and last chord), and chords are kept above 1e-3 of the
longest. The starts are shapes: ``TimingProblem.evaluate`` scales them to be
feasible and tight.

Two starts, one per core of a two-core machine. A third, ``uniform`` (all
segments equal), was dropped: over 74 problems (hybrid, cubic, quintic and
hermite7; smooth and clipped walks of 24 to 1024 via-points; with and without
bounds) it never ended strictly best, and where the starts found different
optima (clipped walks from 256 via-points) it ended with ``rest-to-rest``,
at that one's objective, while ``cruise`` found the best; it cost a third of
the NLP's wall time at n >= 512.
"""

from __future__ import annotations

import numpy as np

from ..limits import rest_to_rest_time
from .problem import TimingProblem

_CHORD_FLOOR = 1e-3


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
    """Named starting shapes (S,) [s, up to scale]: ``rest-to-rest`` and ``cruise``."""
    limits = problem.limits
    distance = np.abs(np.diff(problem.via_points, axis=0))  # (chords, J)
    velocity = distance / limits.velocity  # absent limits are inf: their terms vanish
    rest = rest_to_rest_time(distance, limits).max(axis=1)
    cruise = velocity.max(axis=1) if np.isfinite(limits.velocity).any() else rest
    return {"rest-to-rest": _spread(problem, rest), "cruise": _spread(problem, cruise)}
