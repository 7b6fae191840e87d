"""The windowed start of long problems (planner/timing/windows.py): windows that cover every chord, a stitched
start that keeps each window's core as the window's own optimum has it, and the whole NLP from there."""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import planner.timing as timing_module
import planner.timing.starts as starts_module
import planner.timing.windows as windows_module
from conftest import clipped_walk
from planner import paper
from planner.timing import TimingProblem, optimize
from planner.timing.starts import chord_segments, start_shapes
from planner.timing.windows import (
    STITCHED_IPOPT,
    WINDOW_CHORDS,
    WINDOW_IPOPT,
    WINDOW_MARGIN,
    window_spans,
    windowed,
    windowed_start,
)


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


# ---------------------------------------------------------------- from a mutation run (each test kills some)

def test_windowed_from_384_segments_and_only_for_the_families_without_cut_rounds():
    limits = paper.paper_limits()
    walk = np.cumsum(np.random.default_rng(3).uniform(-0.3, 0.3, (400, 6)), axis=0)  # no repeats to merge
    at, below = TimingProblem(walk[:383], "cubic", limits), TimingProblem(walk[:382], "hybrid", limits)
    assert (at.segment_count, below.segment_count) == (384, 383)
    assert windowed(at) and not windowed(below) and windowed(TimingProblem(walk[:383], "hybrid", limits))
    assert not any(windowed(TimingProblem(walk, family, limits)) for family in ("quintic", "hermite7"))


def test_a_window_where_no_limited_joint_moves_leaves_the_shapes(small_windows):
    """Such a window is no timing problem of its own (nothing bounds its time from below)."""
    via, _ = clipped_walk(72, 7)
    via[20:50, :5] = via[20, :5]  # only joint 6 moves on chords 20 .. 49, and it has no limit
    limits = paper.paper_limits()
    limits = limits.with_overrides(**{name: np.r_[getattr(limits, name)[:5], np.inf]
                                      for name in ("velocity", "acceleration", "jerk")})
    problem = TimingProblem(via, "hybrid", limits, min_duration=1e-3)
    assert windowed_start(problem) is None
    result = optimize(problem, "nlp")
    assert "windows" not in result.settings and result.feasible


class _ScriptedNLP:
    """A ``TimingNLP`` stand-in: each solve returns the next scripted (durations of its start, status), in 7
    iterations; what it was made with and started from is kept."""

    script: list = []
    made: list = []
    starts: list = []

    def __init__(self, part, reference, ipopt=None):
        _ScriptedNLP.made.append(ipopt)

    def solve(self, start):
        _ScriptedNLP.starts.append(np.array(start))
        durations, status = _ScriptedNLP.script.pop(0)
        return SimpleNamespace(durations=np.array(durations(start), dtype=float), iterations=7, status=status)


@pytest.fixture
def window(monkeypatch):
    """A 20-via-point window, its NLP scripted and ``recombined`` spied (it returns 3 times the first)."""
    via, _ = clipped_walk(20, 5)
    problem = TimingProblem(via, "hybrid", paper.paper_limits(), min_duration=1e-3)
    calls: list = []

    def spy(solutions):
        calls.append(solutions)
        return 3 * solutions[0]
    monkeypatch.setattr(windows_module, "TimingNLP", _ScriptedNLP)
    monkeypatch.setattr(starts_module, "recombined", spy)
    _ScriptedNLP.made, _ScriptedNLP.starts, _ScriptedNLP.script = [], [], []
    shapes = problem.evaluate(np.array(list(start_shapes(problem).values())))
    return problem, (0, len(via) - 1, 0, len(via) - 1), calls, shapes


def test_a_window_no_solve_solved_is_none(window):
    problem, span, _, _ = window
    _ScriptedNLP.script = [(lambda s: s, "Maximum_Iterations_Exceeded")] * 2
    assert windows_module._solve_window(problem, span) is None


def test_a_window_keeps_its_best_solve_repaired_and_recombines_where_they_differ(window):
    problem, span, calls, shapes = window
    assert shapes.objective.max() > shapes.objective.min() * 1.01  # the shapes differ: a recombination
    slow = np.ones(problem.segment_count)
    slow[0] = 100.0
    # the first two solves return half their start (too fast: the window repairs them), the third (from the
    # recombination) a slow timing
    _ScriptedNLP.script = [(lambda s: s / 2, "Solve_Succeeded")] * 2 + [(lambda s: slow, "Solve_Succeeded")]
    durations, _, iterations = windows_module._solve_window(problem, span)
    assert _ScriptedNLP.made == [WINDOW_IPOPT] and len(calls) == 1 and len(calls[0]) == 2
    repaired = problem.evaluate(shapes.durations / 2)
    recombination = problem.evaluate(3 * repaired.durations[0][None]).durations[0]  # repaired before it is solved
    np.testing.assert_array_equal(_ScriptedNLP.starts[2], recombination)
    np.testing.assert_array_equal(durations, repaired.durations[int(np.argmin(repaired.objective))])
    assert iterations == 3 * 7


def test_a_window_whose_solves_agree_is_not_recombined_and_one_whose_differ_by_a_thousandth_is(window):
    problem, span, calls, shapes = window
    same = shapes.durations[0]
    _ScriptedNLP.script = [(lambda s: same, "Solve_Succeeded")] * 2
    windows_module._solve_window(problem, span)
    assert calls == []
    longer = same.copy()
    longer[np.argmax(longer)] += 2e-3 * same.sum()
    assert 1e-4 < problem.evaluate(longer[None]).objective[0] / problem.evaluate(same[None]).objective[0] - 1 < 1e-2
    _ScriptedNLP.script = [(lambda s: same, "Solve_Succeeded"), (lambda s: longer, "Solve_Succeeded"),
                           (lambda s: s, "Solve_Succeeded")]
    windows_module._solve_window(problem, span)
    assert len(calls) == 1


def test_the_iterations_recorded_are_every_windows(small_windows, monkeypatch):
    via, _ = clipped_walk(72, 7)
    problem = TimingProblem(via, "hybrid", paper.paper_limits(), min_duration=1e-3)
    seen = []
    real = windows_module._solve_window

    def spy(problem, window, report=None):
        solved = real(problem, window)
        seen.append(solved[2])
        return solved
    monkeypatch.setattr(windows_module, "_solve_window", spy)
    monkeypatch.setattr(windows_module, "core_count", lambda: 1)  # in this process: the spy sees each window
    found = windowed_start(problem)
    assert found is not None and len(seen) == 5 and found[1] == sum(seen)
    monkeypatch.setattr(timing_module, "windowed_start", lambda problem: found)
    assert optimize(problem, "nlp").settings["windows"]["iterations"] == found[1]


def test_the_whole_nlp_from_the_windows_starts_as_set_and_falls_back_where_it_does_not_solve(small_windows,
                                                                                            monkeypatch):
    via, _ = clipped_walk(72, 7)
    problem = TimingProblem(via, "hybrid", paper.paper_limits(), min_duration=1e-3)
    given = []
    real = timing_module.nlp_refine

    def spy(problem, starts, tracker, *rest, **keywords):
        given.append((list(starts), rest))
        return real(problem, starts, tracker, *rest, **keywords)
    monkeypatch.setattr(timing_module, "nlp_refine", spy)
    optimize(problem, "nlp")
    assert given[0] == (["windows"], (STITCHED_IPOPT,))
    monkeypatch.setattr(timing_module, "STITCHED_IPOPT", {"ipopt.max_iter": 1})  # the windows' start stops short
    result = optimize(problem, "nlp")
    assert [start.label for start in result.starts][:3] == ["windows", "cruise", "stop-at-turns"]
    assert result.feasible and result.settings["starts"] == ["cruise", "stop-at-turns"]
    assert "2 shapes" in result.stop_reason and "windows" in result.settings


def test_the_windows_settings_record_what_ran(small_windows):
    via, _ = clipped_walk(65, 7)  # 64 chords: 4 cores of 16 (65 chords would make 5)
    problem = TimingProblem(via, "hybrid", paper.paper_limits(), min_duration=1e-3)
    windows = optimize(problem, "nlp").settings["windows"]
    assert {key: windows[key] for key in ("count", "chords", "margin", "ipopt", "stitched_ipopt")} == {
        "count": 4, "chords": 24, "margin": 4,
        "ipopt": {"tol": 1e-6, "constr_viol_tol": 1e-6, "mu_init": 1e-2, "mumps_scaling": 0,
                  "mumps_permuting_scaling": 0},
        "stitched_ipopt": {"mu_init": 1e-7, "bound_push": 1e-8, "bound_frac": 1e-8, "tol": 1e-8,
                           "constr_viol_tol": 1e-8}}
    assert (WINDOW_CHORDS, WINDOW_MARGIN) == (128, 16)  # what the README says
