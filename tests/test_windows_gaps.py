"""Gaps in the tests of planner/timing/windows.py found by mutation testing (mutmut 3.8.1)."""

import time

import numpy as np
import pytest

import planner.timing.windows as windows_module
from conftest import clipped_walk
from planner import paper
from planner.timing import TimingProblem, optimize
from planner.timing.result import time_limit
from planner.timing.windows import windowed_start


@pytest.fixture
def small_windows(monkeypatch):
    """Windows of 24 chords with margins of 4, from 40 segments: a 72-via-point walk has 5 of them."""
    monkeypatch.setattr(windows_module, "WINDOW_CHORDS", 24)
    monkeypatch.setattr(windows_module, "WINDOW_MARGIN", 4)
    monkeypatch.setattr(windows_module, "WINDOWED_SEGMENTS", 40)


def test_a_window_is_timed_with_the_bounds_objective_weights_and_floor_of_the_whole():
    """A window spanning the whole problem is the whole problem: its durations are the whole NLP's optimum
    (solved independently by ``optimize``), with an objective, weights, bounds and a duration floor that
    are not the defaults and that each move the optimum."""
    via, _ = clipped_walk(12, 3)
    # Without them: 1.36 s to 4.43 s; with the bounds alone the end segments take 1.52 s and 1.67 s, which
    # the floor raises to 2 s.
    problem = TimingProblem(via, "hybrid", paper.paper_limits(), bounds=(1e-3, 4.0), objective="time-jerk",
                            weights=(1.0, 30.0), min_duration=2.0)
    whole = optimize(problem, "nlp")
    assert whole.feasible
    assert np.isclose(whole.durations, 4.0, rtol=1e-6).any() and np.isclose(whole.durations, 2.0, rtol=1e-6).any()
    chords = len(problem.via_points) - 1
    durations, local, _ = windows_module._solve_window(problem, (0, chords, 0, chords))
    np.testing.assert_array_equal(local, np.arange(chords).repeat(np.bincount(local)))
    # The window's looser IPOPT tolerance (1e-6) leaves durations a little apart where the optimum is flat.
    np.testing.assert_allclose(durations, whole.durations, rtol=2e-3, atol=1e-4)
    assert problem.evaluate(durations[None]).objective[0] == pytest.approx(whole.objective, rel=1e-5)


def test_a_time_limit_left_open_lets_the_windows_finish(small_windows):
    """Under a time limit that the windows do not reach, they run to the end and stitch the same start as
    without a limit."""
    via, _ = clipped_walk(72, 7)
    problem = TimingProblem(via, "hybrid", paper.paper_limits(), min_duration=1e-3)
    free = windowed_start(problem)
    with time_limit(600.0):
        limited = windowed_start(problem)
    assert free is not None and limited is not None
    np.testing.assert_allclose(limited[0], free[0], rtol=1e-12)


def test_the_windows_are_ended_at_the_time_limit(small_windows, monkeypatch):
    """Windows still running at the time limit are ended there (their processes), not waited for."""
    def slow(problem, window, report=None):
        time.sleep(30.0)
        return None
    monkeypatch.setattr(windows_module, "_solve_window", slow)
    via, _ = clipped_walk(72, 7)
    problem = TimingProblem(via, "hybrid", paper.paper_limits(), min_duration=1e-3)
    started = time.monotonic()
    with time_limit(0.3):
        assert windowed_start(problem) is None
    assert time.monotonic() - started < 15.0  # (not a speed check: waited for, the windows take 30 s)
