"""Gaps in the tests of planner/timing/lower_bound.py, cuckoo.py, baselines.py and local.py found by
mutation testing (mutmut 3.8.1 over each module; the survivors that change a result, one test each)."""

import warnings

import numpy as np
import pytest

from conftest import record_evaluations
from planner import InputError, JointLimits, paper
from planner.errors import SettingError
from planner.timing import (
    TimingProblem,
    baselines,
    multistart_slsqp,
    optimize,
    particle_swarm,
    scipy_differential_evolution,
)
from planner.timing.cuckoo import cuckoo_search
from planner.timing.local import _Model, refine
from planner.timing.lower_bound import pair_lower_bounds, time_lower_bound
from planner.timing.result import MAX_POPULATION_NUMBERS, SearchTracker

# ---------------------------------------------------------------- lower_bound.py


def test_joints_without_velocity_or_acceleration_limits_give_no_numpy_warning():
    """A joint with neither a velocity nor an acceleration limit makes inf / inf in the bang-bang times
    (``_stop_to_stop_va`` and ``_passing_to_stop``): the module turns it into 0 s silently, with no
    RuntimeWarning for a robot that simply lacks those limits. The bound is still the longest chain of the
    documented links (``test_lower_bound``'s independent reading), here through a passing via-point and a
    turn. Pins the ``np.errstate(invalid="ignore")`` of both functions."""
    from test_lower_bound import _longest_chain

    limits = JointLimits.create(2, velocity=[np.inf, 1.0], acceleration=[np.inf, 2.0], jerk=[10.0, np.inf])
    via = np.array([[0.0, 0.0], [0.1, 0.5], [0.3, 0.2], [0.2, 0.2], [0.2, 0.6]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        bound = time_lower_bound(via, limits)
        pair_lower_bounds(via, limits)
    with np.errstate(invalid="ignore"):
        expected = _longest_chain(via, limits, None)
    assert bound == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("count", [1, 3])
def test_a_single_distinct_via_point_has_an_empty_list_of_integer_pairs(count):
    """Via-points that are all one point (once or repeated) have no pair: ``pair_lower_bounds`` returns
    pairs of the documented shape (0, 2), integers that index the via-points like any other pairs, and
    bounds (0, J)."""
    via = np.tile([[0.3, -0.2]], (count, 1))
    pairs, bounds = pair_lower_bounds(via, JointLimits.create(2, velocity=[1.0, 2.0]))
    assert pairs.shape == (0, 2) and pairs.dtype.kind == "i"
    assert bounds.shape == (0, 2)
    assert via[pairs[:, 1]].shape == (0, 2)


# ---------------------------------------------------------------- local.py

PAPER_VIA = np.deg2rad(paper.VIA_POINTS_DEG)[:5]


def _slsqp(problem, start, max_iterations=100):
    """``refine`` from ``start`` (S,) [s]: the tracker holds its repaired result and nothing else."""
    tracker = SearchTracker(problem)
    refine(problem, np.asarray(start, dtype=float), tracker, max_iterations=max_iterations)
    return tracker


@pytest.mark.parametrize("family", ["quintic", "trigonometric"])
def test_the_slsqp_model_is_the_documented_objective_and_constraints_by_dense_sampling(family):
    """SLSQP's model at durations h (paper via-points, a range 5 deg beyond them on both sides, ``time-jerk``):
    the objective K_t sum h + K_j E, E the integral of the squared jerk (Gauss-Legendre on each segment), and
    the constraints 1 - r^(1/d) of each limited (order d, joint) in that order, r the peak of |q^(d)| over its
    limit (4001 samples on each segment, its ends included), then position - lower and upper - position at
    the sampled extremes. Pins the roots 1, 1/2, 1/3 and the family's basis (trigonometric: not the power
    basis) in the ratios, the range and the energy."""
    margin = np.deg2rad(5.0)
    limits = paper.paper_limits().with_overrides(lower=PAPER_VIA.min(axis=0) - margin,
                                                 upper=PAPER_VIA.max(axis=0) + margin)
    problem = TimingProblem(PAPER_VIA, family, limits, objective="time-jerk", weights=(1.5, 0.2))
    h = np.array([0.9, 1.7, 1.2, 2.1, 1.4, 0.8])[:problem.segment_count]
    model = _Model(problem, SearchTracker(problem)).at(h)
    trajectory = problem.trajectory(h)
    knots = trajectory.knot_times
    inside = np.linspace(1e-12, 1 - 1e-12, 4001)  # each segment to within 1e-12 of both its ends
    values = np.concatenate([trajectory.states(begin + (end - begin) * inside)
                             for begin, end in zip(knots[:-1], knots[1:])], axis=1)  # (4, N, J)
    nodes, node_weights = np.polynomial.legendre.leggauss(40)
    energy = 0.0
    for begin, end in zip(knots[:-1], knots[1:]):
        jerk = trajectory.states(begin + (end - begin) * (nodes + 1) / 2)[3]
        energy += (end - begin) / 2 * np.sum(node_weights[:, None] * jerk ** 2)
    assert model.f == pytest.approx(1.5 * h.sum() + 0.2 * energy, rel=1e-9)
    magnitudes = problem.limits.magnitudes
    peaks = np.abs(values[1:]).max(axis=1) / magnitudes  # (3, J)
    limited = np.isfinite(magnitudes)
    expected = np.concatenate([(1 - peaks ** (1 / np.arange(1, 4))[:, None])[limited],
                               values[0].min(axis=0) - problem.limits.lower,
                               problem.limits.upper - values[0].max(axis=0)])
    assert model.g == pytest.approx(expected, abs=1e-6)


@pytest.mark.parametrize("scale, start, bounds", [
    (1.0, 1e-3, None),       # a start 1000 times too fast: the variables' floor is 1e-3 of its shortest duration
    (1.0, 900.0, (1e-3, 1e3)),  # a start 1000 times too slow in wide bounds: the floor is h_min, nothing more
    (1e-6, None, None),      # via-points a millionth apart, centisecond durations: steps relative to each duration
])
def test_slsqp_reaches_the_nlps_optimum_whatever_the_time_scale(scale, start, bounds):
    """SLSQP from a start far from the optimum's scale, or on a problem whose durations are centiseconds,
    reaches the NLP's optimum (an independent solver) to 1e-8: its variables' lower bound is the larger of
    the duration floor and, without bounds, 1e-3 times the start's shortest duration (not 1e-3 over it, not
    with bounds), and its forward-difference steps are 1e-7 of each duration (not of at least 1 s, nor over
    it). Equal durations repaired are the start where none is given."""
    problem = TimingProblem(PAPER_VIA * scale, "cubic", paper.paper_limits(), bounds=bounds)
    durations = (problem.evaluate(np.ones((1, problem.segment_count))).durations[0] if start is None
                 else np.full(problem.segment_count, start))
    tracker = _slsqp(problem, durations)
    best = optimize(problem, "nlp")
    assert best.feasible and tracker.best_feasible
    assert tracker.best_objective == pytest.approx(best.objective, rel=1e-8)


# ---------------------------------------------------------------- cuckoo.py


def test_cuckoo_search_refuses_too_many_nests_by_naming_the_setting():
    """Nests whose durations would exceed ``MAX_POPULATION_NUMBERS`` numbers are refused before any search:
    a SettingError naming ``nests``, its value, and the most nests the problem's S segments allow,
    floor(MAX_POPULATION_NUMBERS / S)."""
    problem = TimingProblem(PAPER_VIA, "cubic", paper.paper_limits())
    segments = problem.segment_count
    most = MAX_POPULATION_NUMBERS // segments
    with pytest.raises(SettingError) as error:
        cuckoo_search(problem, nests=most + 1, iterations=1)
    assert error.value.setting == "nests"
    assert error.value.problem.startswith(f"{most + 1} makes a population of {most + 1:,} candidates of {segments} "
                                          "durations")
    assert error.value.problem.endswith(f"at most {most} for {segments} segments")


# ---------------------------------------------------------------- baselines.py


def _four_via_problem(**keywords):
    """The paper's first four via-points and limits, cubic family (6 segments): fast to search."""
    return TimingProblem(PAPER_VIA[:4], "cubic", paper.paper_limits(), **keywords)


def test_multistart_slsqp_defaults_and_what_its_result_reports(monkeypatch):
    """Eight starts of at most 100 SLSQP iterations each (``refine`` recorded, not run), seed 0, recorded as the
    result's settings and seed; the result is named ``slsqp``, stops with ``8 SLSQP starts`` and holds one
    history entry per start."""
    calls = []
    monkeypatch.setattr(baselines, "refine", lambda problem, start, tracker, max_iterations: calls.append(
        (start.copy(), max_iterations)))
    result = multistart_slsqp(_four_via_problem())
    assert len(calls) == 8 and {iterations for _, iterations in calls} == {100}
    assert result.settings == {"starts": 8, "iterations": 100} and result.seed == 0
    assert result.algorithm == "slsqp" and result.stop_reason == "8 SLSQP starts" and len(result.history) == 8


def test_multistart_slsqp_reports_progress_once_per_start_with_the_best_so_far():
    """``progress`` is called after each start with (starts done, starts, best objective so far)."""
    calls = []
    result = multistart_slsqp(_four_via_problem(), starts=3, iterations=2, progress=lambda *args: calls.append(args))
    assert [(done, total) for done, total, _ in calls] == [(1, 3), (2, 3), (3, 3)]
    assert [best for _, _, best in calls] == result.history


def test_multistart_slsqp_refuses_no_start_with_its_message():
    with pytest.raises(InputError, match="^SLSQP needs starts >= 1, got 0$"):
        multistart_slsqp(_four_via_problem(), starts=0)


def test_multistart_slsqp_draws_its_starts_from_its_seed_inside_the_search_box(monkeypatch):
    """The starts are one batch drawn uniformly in the search box (bounds [2, 8] s: every start inside them)
    from the seed's generator: equal seeds give equal starts and results, other seeds other starts."""
    batches = record_evaluations(monkeypatch)
    problem = _four_via_problem(bounds=(2.0, 8.0))
    lower, upper = problem.search_box()
    runs = []
    for seed in (4, 4, 5):
        batches.clear()
        runs.append((multistart_slsqp(problem, starts=12, iterations=1, seed=seed), batches[0]))
    (first, starts), (again, starts_again), (_, other_starts) = runs
    assert starts.shape == (12, problem.segment_count)
    assert np.all(starts >= lower) and np.all(starts <= upper)
    np.testing.assert_array_equal(starts, starts_again)
    np.testing.assert_array_equal(first.durations, again.durations)
    assert first.history == again.history
    assert not np.array_equal(starts, other_starts)


def test_de_refuses_too_large_a_population_by_naming_the_setting():
    """A population whose population * S members of S durations each exceed ``MAX_POPULATION_NUMBERS``
    numbers is refused before any search: a SettingError naming ``population``, its value, and the most the
    problem allows, floor(MAX_POPULATION_NUMBERS / S^2)."""
    problem = _four_via_problem()
    segments = problem.segment_count
    most = MAX_POPULATION_NUMBERS // segments ** 2
    with pytest.raises(SettingError) as error:
        scipy_differential_evolution(problem, population=most + 1)
    assert error.value.setting == "population"
    assert error.value.problem.startswith(f"{most + 1} makes a population of {(most + 1) * segments:,} candidates")
    assert error.value.problem.endswith(f"at most {most} for {segments} segments")


def test_de_is_reproducible_from_its_seed_and_evaluates_each_generation_in_one_batch(monkeypatch):
    """Equal seeds give equal results (scipy's generator is seeded from ``seed``), another seed another; each
    generation of population * S members is one batch of candidates (vectorised, updating deferred, with no
    warning from scipy about overriding the updating), and the stop reason is scipy's message."""
    batches = []
    evaluate = TimingProblem.evaluate

    def recording(self, candidates):
        batches.append(np.shape(candidates))
        return evaluate(self, candidates)

    monkeypatch.setattr(TimingProblem, "evaluate", recording)
    problem = _four_via_problem()
    members = 4 * problem.segment_count
    runs = []
    for seed in (3, 3, 8):
        batches.clear()
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            runs.append(scipy_differential_evolution(problem, population=4, evaluations=3 * members, seed=seed))
        assert batches == [(members, problem.segment_count)] * 3  # the first population and two generations
    first, again, other = runs
    np.testing.assert_array_equal(first.durations, again.durations)
    assert first.history == again.history and first.seed == 3
    assert not np.array_equal(first.durations, other.durations)
    assert first.stop_reason == "Maximum number of iterations has been exceeded."


def test_pso_refuses_too_many_particles_by_naming_the_setting():
    """Particles whose durations would exceed ``MAX_POPULATION_NUMBERS`` numbers are refused before any
    search: a SettingError naming ``particles``, its value and the most allowed, floor(MAX_POPULATION_NUMBERS
    / S)."""
    problem = _four_via_problem()
    segments = problem.segment_count
    most = MAX_POPULATION_NUMBERS // segments
    with pytest.raises(SettingError) as error:
        particle_swarm(problem, particles=most + 1, iterations=1)
    assert error.value.setting == "particles"
    assert error.value.problem.startswith(f"{most + 1} makes a population of {most + 1:,} candidates")
    assert error.value.problem.endswith(f"at most {most} for {segments} segments")


def _pso_moves(monkeypatch, **settings):
    """A PSO run's evaluations, each (candidates, particles, objective): the candidates evaluated and the
    particles and objectives their repair makes (recomputed here), and the search box."""
    batches = record_evaluations(monkeypatch)
    problem = _four_via_problem()
    particle_swarm(problem, seed=3, **settings)
    monkeypatch.undo()
    moves = []
    for batch in batches:
        evaluation = problem.evaluate(batch)
        moves.append((batch, problem.to_search_space(evaluation.durations), evaluation.objective))
    return moves, *problem.search_box()


def test_pso_first_velocities_are_a_tenth_of_the_box_times_independent_standard_normals(monkeypatch):
    """w = 1 and no attraction: the first move, from a particle to its next candidate, is the initial velocity
    0.1 * span * N(0, 1), drawn for each particle and component, clipped to 20 % of the box (z = move /
    (0.1 span) clipped to +-2). From particles the box cannot stop: about 4.6 % of z at +-2, the others a
    standard normal truncated to (-2, 2) (KS test)."""
    from scipy import stats

    ((_, particles, _), (moved, _, _)), lower, upper = _pso_moves(monkeypatch, particles=500, iterations=1,
                                                                   inertia=1.0, cognitive=0.0, social=0.0)
    span = upper - lower
    free = (particles > lower + 0.2 * span) & (particles < upper - 0.2 * span)
    z = ((moved - particles) / (0.1 * span))[free]
    assert len(z) > 800
    clipped = np.abs(z) > 2 - 1e-9
    assert clipped.mean() == pytest.approx(2 * stats.norm.sf(2.0), abs=0.015)
    assert stats.kstest(z[~clipped], stats.truncnorm(-2.0, 2.0).cdf).pvalue > 1e-3


def test_pso_random_coefficients_are_drawn_for_each_particle_and_component(monkeypatch):
    """r1 and r2 in v <- w v + c1 r1 (p - x) + c2 r2 (g - x) are U(0, 1) for each particle and component,
    recovered from the moves (KS test), not one number per iteration, and p is each particle's own best.
    Social alone (c2 = 0.1: moves of at most a tenth of the box): the first move is r2 (g - x) / 10, g the
    best particle. Inertia and the cognitive term alone (w = 1, c1 = 0.5): a particle whose first move made
    it worse keeps p = its first position x0, so its second move is v1 + r1 (x0 - x1) / 2."""
    from scipy import stats

    ((_, particles, objective), (moved, _, _), _), lower, upper = _pso_moves(
        monkeypatch, particles=60, iterations=2, inertia=0.0, cognitive=0.0, social=0.1)
    best = particles[np.argmin(objective)]
    pulled = np.abs(best - particles) > 1e-6
    r2 = ((moved - particles) / (0.1 * np.where(pulled, best - particles, 1.0)))[pulled]
    assert len(r2) > 200 and stats.kstest(r2, "uniform").pvalue > 1e-3

    ((_, x0, first_value), (first, x1, second_value), (second, _, _)), lower, upper = _pso_moves(
        monkeypatch, particles=300, iterations=2, inertia=1.0, cognitive=0.5, social=0.0)
    span = upper - lower
    v1, v2, pull = first - x0, second - x1, x0 - x1
    usable = ((first > lower) & (first < upper) & (second > lower) & (second < upper)
              & (np.abs(v2) < 0.2 * span * (1 - 1e-9)) & (np.abs(pull) > 1e-6)
              & (second_value >= first_value)[:, None])
    r1 = ((v2 - v1) / (0.5 * np.where(usable, pull, 1.0)))[usable]
    assert len(r1) > 100 and stats.kstest(r1, "uniform").pvalue > 1e-3
