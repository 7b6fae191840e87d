"""Gaps in the tests of planner/timing/problem.py found by mutation testing (mutmut 3.8.1, run of 2026-12-07 over
the functions an earlier run left unchecked: evaluate, the batch checks, coefficients and their neighbours)."""

import numpy as np
import pytest

from planner import JointLimits
from planner.errors import InputError
from planner.timing import TimingProblem

VIA = np.radians([[0.0, 0.0], [40.0, -20.0], [90.0, 10.0]])
LIMITS = JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0], jerk=[10.0, 10.0])


def test_coefficients_name_the_durations_they_refuse():
    """``coefficients`` checks its durations as ``evaluate_durations`` does, and its refusal names them
    ``durations`` (the NLP passes its iterates there: a message naming anything else points nowhere)."""
    problem = TimingProblem(VIA, "quintic", LIMITS)
    with pytest.raises(InputError, match=r"^durations\[0, 1\] is -1\.0 s; durations must be > 0$"):
        problem.coefficients(np.array([[1.0, -1.0]]))
    with pytest.raises(InputError, match=r"^durations must hold 2 segment durations, got 3$"):
        problem.coefficients(np.ones((1, 3)))


def test_unbounded_evaluate_builds_each_candidates_splines_once(monkeypatch):
    """Without bounds (and with every candidate above the minimum duration), ``evaluate`` builds the splines of a
    batch once: the repaired durations' ratios and jerk energy follow from the candidates' by the time-scaling
    lemma (its docstring). The figures it returns are those of the repaired durations, built afresh."""
    problem = TimingProblem(VIA, "quintic", LIMITS, objective="time-jerk", weights=(1.0, 0.5))
    candidates = np.random.default_rng(3).uniform(0.2, 1.0, (4, problem.segment_count))
    builds = []
    build = problem.family.batch_coefficients

    def counted(*args):
        builds.append(args)
        return build(*args)
    monkeypatch.setattr(problem.family, "batch_coefficients", counted)
    evaluation = problem.evaluate(candidates)
    assert len(builds) == 1
    monkeypatch.undo()
    exact = problem.evaluate_durations(evaluation.durations)
    np.testing.assert_allclose(evaluation.ratios, exact.ratios, rtol=1e-9)
    np.testing.assert_allclose(evaluation.objective, exact.objective, rtol=1e-9)


def test_via_point_states_that_are_not_finite_are_named_states():
    """Free via-point states (hermite7) with a NaN are refused naming ``states`` and the entry, by every method
    that takes them."""
    problem = TimingProblem(VIA, "hermite7", LIMITS)
    states = np.zeros((1, *problem.via_points.shape, 3))
    states[0, 1, 0, 2] = np.nan
    durations = np.array([[1.0, 1.0]])
    for method in (problem.evaluate_durations, problem.evaluate_states, problem.coefficients):
        with pytest.raises(InputError, match=r"^states\[0, 1, 0, 2\] is nan, not a finite number$"):
            method(durations, states)


def _quadrature_jerk_energy(problem: TimingProblem, durations: np.ndarray) -> float:
    """Integral of the squared jerk over the trajectory [rad^2/s^5], summed over joints: the trajectory built
    from ``durations`` and its jerk evaluated at 8 Gauss-Legendre nodes inside every segment (exact for the
    squared jerk of these families, of degree <= 4), not the closed form the problem uses."""
    trajectory = problem.trajectory(durations)
    nodes, weights = np.polynomial.legendre.leggauss(8)
    total = 0.0
    for start, end in zip(trajectory.knot_times[:-1], trajectory.knot_times[1:]):
        t = (start + end) / 2 + (end - start) / 2 * nodes
        total += (end - start) / 2 * weights @ (trajectory.evaluate(t, order=3) ** 2).sum(axis=1)
    return total


@pytest.mark.parametrize("family", ["cubic", "quintic"])
def test_time_jerk_repair_stops_where_the_objective_is_stationary_along_the_ray(family):
    """With ``time-jerk``, a jerk weight large enough that the limits do not bind, the repair scales each
    candidate of a batch to the optimum of K_t T s + K_j E / s^5 along its ray: there K_t T = 5 K_j E, with the
    jerk energy E integrated by quadrature of the built trajectory's jerk (an independent computation). A factor off by
    any constant, or T taken over the whole batch, misses it."""
    weights = (1.0, 40.0)
    problem = TimingProblem(VIA, family, LIMITS, objective="time-jerk", weights=weights)
    candidates = np.random.default_rng(5).uniform(0.5, 1.2, (3, problem.segment_count))  # cubic: 4 segments
    repaired = problem.evaluate(candidates)
    assert repaired.feasible.all()
    for durations, objective in zip(repaired.durations, repaired.objective):
        energy = _quadrature_jerk_energy(problem, durations)
        assert weights[0] * durations.sum() == pytest.approx(5 * weights[1] * energy, rel=1e-6)
        assert objective == pytest.approx(weights[0] * durations.sum() + weights[1] * energy, rel=1e-6)
        limited = problem.evaluate_durations(durations[None] / 1.5)
        assert limited.feasible[0]  # the limits do not bind: the ray's optimum set the scale


def test_a_via_point_exactly_the_repeat_tolerance_away_is_merged_and_one_a_float_further_is_not():
    """"Within 1e-9 rad" (REPEAT_TOLERANCE, README) includes the tolerance itself: a via-point exactly that far
    from the last one kept, in its farthest joint, is the same via-point; the next float beyond is a via-point of
    its own (a mutant of the comparison, >= for >, lived)."""
    from planner.timing.problem import REPEAT_TOLERANCE

    for step, merged in ((REPEAT_TOLERANCE, True), (np.nextafter(REPEAT_TOLERANCE, 1.0), False)):
        via = np.array([[0.0, 0.0], [step, -step / 2], [0.5, 0.3]])
        assert np.abs(via[1] - via[0]).max() == step  # the difference itself, exactly
        problem = TimingProblem(via, "cubic", LIMITS)
        assert len(problem.via_points) == (2 if merged else 3)
        assert problem.via_index.tolist() == ([0, 0, 1] if merged else [0, 1, 2])


def test_the_set_up_refusals_name_the_argument_and_what_was_given():
    """``TimingProblem`` names what it refuses: limits of another type by that type, a via-point that is not a
    finite number by its place in ``via_points`` (mutants that emptied or misnamed these messages lived)."""
    with pytest.raises(InputError, match=r"^limits must be a JointLimits \(JointLimits.create\), got dict$"):
        TimingProblem(VIA, "cubic", {"velocity": [1.0, 1.0]})
    bad = VIA.copy()
    bad[1, 1] = np.nan
    with pytest.raises(InputError, match=r"^via_points\[1, 1\] is nan, not a finite number$"):
        TimingProblem(bad, "cubic", LIMITS)


def test_a_via_point_on_the_largest_position_is_taken_and_one_a_float_beyond_is_refused():
    """The largest position the planner takes (LARGEST_POSITION_DEG, in rad) is itself taken; the next float
    beyond it is refused by name (a mutant that refused the bound itself lived)."""
    from planner.limits import LARGEST_POSITION_DEG

    largest = np.deg2rad(LARGEST_POSITION_DEG)
    on_it = np.array([[largest, 0.0], [largest - 1.0, 0.5]])
    assert TimingProblem(on_it, "cubic", LIMITS).via_points[0, 0] == largest
    beyond = on_it.copy()
    beyond[0, 0] = np.nextafter(largest, np.inf)
    with pytest.raises(InputError, match=r"^via-point 0, joint 0: .* rad is beyond the largest position"):
        TimingProblem(beyond, "cubic", LIMITS)
