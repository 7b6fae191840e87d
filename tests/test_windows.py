"""The windowed start of long problems (planner/timing/windows.py): windows that cover every chord, a stitched
start that keeps each window's core as the window's own optimum has it, and the whole NLP from there."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import planner.timing.windows as windows_module
from conftest import clipped_walk
from planner import paper
from planner.timing import TimingProblem, optimize
from planner.timing.starts import chord_segments
from planner.timing.windows import WINDOW_CHORDS, WINDOW_MARGIN, window_spans, windowed_start


@given(st.integers(1, 5000))
def test_the_cores_partition_the_chords_and_each_window_is_its_core_and_margins(chords):
    parts = window_spans(chords)
    cores = [(low, high) for _, _, low, high in parts]
    assert cores[0][0] == 0 and cores[-1][1] == chords
    assert all(high == low for (_, high), (low, _) in zip(cores, cores[1:]))
    for first, end, low, high in parts:
        assert low < high <= low + WINDOW_CHORDS - 2 * WINDOW_MARGIN
        assert (first, end) == (max(0, low - WINDOW_MARGIN), min(chords, high + WINDOW_MARGIN))
        assert end - first <= WINDOW_CHORDS


@pytest.fixture
def small_windows(monkeypatch):
    """Windows of 24 chords with margins of 4, from 40 segments: a 72-via-point walk has 5 of them."""
    monkeypatch.setattr(windows_module, "WINDOW_CHORDS", 24)
    monkeypatch.setattr(windows_module, "WINDOW_MARGIN", 4)
    monkeypatch.setattr(windows_module, "WINDOWED_SEGMENTS", 40)


def _window_problem(problem, first, end):
    return TimingProblem(problem.via_points[first:end + 1], problem.family, problem.limits,
                         min_duration=problem.duration_floor)


@pytest.mark.parametrize("family", ["cubic", "hybrid"])
def test_the_stitched_start_is_each_windows_own_optimum_in_its_core(small_windows, family):
    """Each core's durations are those of its window's optimum, computed here by the classic NLP from the
    shapes on the window alone (an independent solve, to its full tolerance), and the end segments (two
    on the first and last chord) come from the windows that hold the trajectory's ends."""
    via, _ = clipped_walk(72, 7)  # (the ranges not enforced: scripts/bench_scale.py's clipped class)
    limits = paper.paper_limits()
    problem = TimingProblem(via, family, limits, min_duration=1e-3)
    found = windowed_start(problem)
    assert found is not None and found[0].shape == (problem.segment_count,) and found[1] > 0
    stitched = found[0]
    whole = chord_segments(problem)
    parts = window_spans(len(problem.via_points) - 1)
    assert len(parts) == 5
    for first, end, low, high in parts:
        part = _window_problem(problem, first, end)
        own = optimize(part, "nlp")
        local = chord_segments(part) + first
        kept, theirs = stitched[(whole >= low) & (whole < high)], own.durations[(local >= low) & (local < high)]
        # The window's looser tolerance (1e-6) leaves durations 1e-3 apart where the optimum is flat; their
        # sum is tight. A chord off by one would be tens of percent off.
        np.testing.assert_allclose(kept, theirs, rtol=1e-2)
        assert kept.sum() == pytest.approx(theirs.sum(), rel=1e-5)


def test_the_whole_nlp_from_the_stitched_windows_reaches_the_shapes_optimum(small_windows, monkeypatch):
    via, _ = clipped_walk(72, 7)  # (the ranges not enforced: scripts/bench_scale.py's clipped class)
    limits = paper.paper_limits()
    problem = TimingProblem(via, "hybrid", limits, min_duration=1e-3)
    result = optimize(problem, "nlp")
    assert [start.label for start in result.starts] == ["windows"]
    assert result.starts[0].status == "Solve_Succeeded" and result.feasible
    assert result.settings["windows"]["count"] == 5 and result.settings["starts"] == ["windows"]
    assert result.settings["windows"]["iterations"] > result.starts[0].iterations
    assert "stitched solutions of its windows" in result.stop_reason
    monkeypatch.setattr(windows_module, "WINDOWED_SEGMENTS", 10**6)
    shapes = optimize(problem, "nlp")
    assert [start.label for start in shapes.starts][:2] == ["cruise", "stop-at-turns"]
    assert result.objective == pytest.approx(shapes.objective, rel=1e-6)


def test_a_window_that_does_not_solve_leaves_the_shapes_to_start_from(small_windows, monkeypatch):
    via, _ = clipped_walk(72, 7)  # (the ranges not enforced: scripts/bench_scale.py's clipped class)
    limits = paper.paper_limits()
    problem = TimingProblem(via, "hybrid", limits, min_duration=1e-3)
    monkeypatch.setattr(windows_module, "_solve_window", lambda problem, window, report=None: None)
    assert windowed_start(problem) is None
    result = optimize(problem, "nlp")
    assert [start.label for start in result.starts][:2] == ["cruise", "stop-at-turns"] and result.feasible
    assert "windows" not in result.settings


def test_a_time_limit_that_ends_the_windows_returns_a_feasible_timing(small_windows):
    """The windows run in processes ended at the time limit: the run then stops with the repaired shapes,
    feasible, and says the limit stopped it."""
    via, _ = clipped_walk(72, 7)
    problem = TimingProblem(via, "hybrid", paper.paper_limits(), min_duration=1e-3)
    result = optimize(problem, "nlp", time_limit_s=0.05)
    assert result.feasible and result.out_of_time and "time limit" in result.stop_reason
    assert "windows" not in result.settings
