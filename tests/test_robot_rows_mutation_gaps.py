"""Gaps in the tests of planner/timing/robot_rows.py (and of the searches: cuckoo.py, baselines.py, local.py) found
by a hand mutation-testing run: each test kills a mutant that survived the existing tests. The references
are computed independently: Pinocchio's rnea, computeRNEADerivatives and frame-velocity derivatives called
directly, the one-joint pendulum's closed form (tip speed l |q'|), and, for the searches, the candidates
they evaluate (recorded) against the update laws their docstrings give, with the repair recomputed."""

import numpy as np
import pinocchio as pin
import pytest

from conftest import pendulum
from planner import JointLimits, paper
from planner.robot import Robot
from planner.timing import TimingProblem, cuckoo_search, optimize
from planner.timing.baselines import multistart_slsqp, particle_swarm
from planner.timing.cuckoo import mantegna_sigma
from planner.timing.local import refine
from planner.timing.nlp import TimingNLP
from planner.timing.result import SearchTracker
from planner.timing.robot_rows import (
    RobotConstraints,
    freeze,
    model_error,
    modelled,
    sample_points,
    spline_states,
)

GRAVITY = 9.81  # Pinocchio's default [m/s^2]
LIMITS = np.array([150.0, 150.0, 150.0, 28.0, 28.0, 28.0])


@pytest.fixture(scope="module")
def ur5():
    return Robot.from_example_robot_data("ur5", "tool0")


def _states(seed, points=4):
    """(q0, q'0, q''0) a model is frozen at and (q, q', q'') away from it, each (points, 6)."""
    rng = np.random.default_rng(seed)
    frozen = rng.uniform(-2.0, 2.0, (3, points, 6))
    moved = frozen[0] + 0.2 * rng.normal(size=(points, 6)), 1.4 * rng.normal(size=(points, 6)), rng.normal(
        size=(points, 6))
    return frozen, moved


def _local_twist(robot, q, qd):
    """(P, 6) the tool's twist (linear, angular) in its own LOCAL frame, from Pinocchio directly."""
    model, data = robot.model, robot.model.createData()
    twists = []
    for a, b in zip(q, qd):
        pin.forwardKinematics(model, data, a, b)
        pin.updateFramePlacements(model, data)
        twists.append(pin.getFrameVelocity(model, data, robot.tool_frame_id, pin.ReferenceFrame.LOCAL).vector)
    return np.array(twists)


def test_the_frozen_tool_twist_is_the_local_twist_component_by_component(ur5):
    """The model's tool velocity is the twist in the tool's LOCAL frame, every component (not only its norm,
    which every frame shares): at the positions it was frozen at, for other velocities, it equals
    Pinocchio's LOCAL frame velocity, so ``model_error`` there is 0 (the rounds can settle)."""
    (q, qd, qdd), _ = _states(1)
    constraints = RobotConstraints(ur5, None, 0.3, 1.5)
    frozen = freeze(constraints, q, qd, qdd)
    _, velocity = modelled(frozen, q, 1.7 * qd, -0.5 * qdd)
    np.testing.assert_allclose(velocity, _local_twist(ur5, q, 1.7 * qd), atol=1e-12)
    assert model_error(constraints, frozen, q, 1.7 * qd, -0.5 * qdd) < 1e-12


def test_the_torque_gap_is_each_joints_share_of_its_own_limit(ur5):
    """``model_error`` for torque: the largest |RNEA(q, q', q'') - model| / L_j, each joint against its own
    limit, where the model is RNEA(q0, q', q'') + dtau/dq(q0, q'0, q''0) (q - q0) (exact in q', q'', first
    order in q)."""
    (q0, qd0, qdd0), (q, qd, qdd) = _states(2)
    limits = LIMITS.copy()
    limits[5] = 0.5  # a wrist joint with a small limit sets the gap
    constraints = RobotConstraints(ur5, limits, None)
    model, data = ur5.model, ur5.model.createData()
    ratios = []
    for p in range(len(q)):
        dtau_dq = np.array(pin.computeRNEADerivatives(model, data, q0[p], qd0[p], qdd0[p])[0])
        approximation = pin.rnea(model, data, q0[p], qd[p], qdd[p]) + dtau_dq @ (q[p] - q0[p])
        ratios.append(np.abs(pin.rnea(model, data, q[p], qd[p], qdd[p]) - approximation) / limits)
    gap = model_error(constraints, freeze(constraints, q0, qd0, qdd0), q, qd, qdd)
    assert gap == pytest.approx(np.max(ratios), rel=1e-9)


@pytest.mark.parametrize("linear, angular", [(0.3, 0.05), (0.02, 1.5)])
def test_the_speed_gap_is_the_worst_points_distance_for_each_speed_limited(ur5, linear, angular):
    """``model_error`` for tool speeds: for the linear and the angular part each, the largest (over points)
    Euclidean distance between the true LOCAL twist part and the model's, over that part's limit; the larger
    part sets it. The model is J(q0) q' + dv/dq(q0, q'0) (q - q0), from Pinocchio's own derivatives."""
    (q0, qd0, qdd0), (q, qd, qdd) = _states(3)
    constraints = RobotConstraints(ur5, None, linear, angular)
    model, data = ur5.model, ur5.model.createData()
    approximation = []
    for p in range(len(q)):
        pin.computeForwardKinematicsDerivatives(model, data, q0[p], qd0[p], qdd0[p])
        dv_dq, _ = pin.getFrameVelocityDerivatives(model, data, ur5.tool_frame_id, pin.ReferenceFrame.LOCAL)
        jacobian = pin.computeFrameJacobian(model, data, q0[p], ur5.tool_frame_id, pin.ReferenceFrame.LOCAL)
        approximation.append(jacobian @ qd[p] + np.asarray(dv_dq) @ (q[p] - q0[p]))
    difference = _local_twist(ur5, q, qd) - np.array(approximation)
    expected = max(np.linalg.norm(difference[:, :3], axis=1).max() / linear,
                   np.linalg.norm(difference[:, 3:], axis=1).max() / angular)
    gap = model_error(constraints, freeze(constraints, q0, qd0, qdd0), q, qd, qdd)
    assert gap == pytest.approx(expected, rel=1e-9)


def test_the_tip_speed_rows_bound_the_speed_by_its_limit(tmp_path):
    """The pendulum swing -90, 60, -30, 90 deg (hybrid, kinematic limits far from binding) timed by the
    NLP with a 1.5 m/s tip-speed limit, from 1.5 times the repaired equal durations: the NLP's own result
    (before any dense check or slow-down) has the tip's closed-form speed l |q'| at its samples at most the
    limit, and reaching it."""
    via = np.deg2rad([[-90.0], [60.0], [-30.0], [90.0]])
    limits = JointLimits.create(1, velocity=np.deg2rad([400.0]), acceleration=np.deg2rad([4000.0]),
                                jerk=np.deg2rad([40000.0]))
    problem = TimingProblem(via, "hybrid", limits)
    start = problem.evaluate(np.ones((1, problem.segment_count))).durations[0] * 1.5
    constraints = RobotConstraints(pendulum(tmp_path), None, 1.5)
    outcome = TimingNLP(problem, start, constraints).solve(start)
    coefficients = problem.coefficients(outcome.durations[None])[0]
    _, qd, _ = spline_states(coefficients, outcome.durations, *sample_points(np.arange(problem.segment_count)),
                             problem.family.basis)
    assert 0.5 * np.abs(qd[:, 0]).max() / 1.5 == pytest.approx(1.0, abs=1e-6)


# ---------------------------------------------------------------- the searches (cuckoo.py, baselines.py)

def _search_problem(**keywords):
    """The paper's first four via-points and limits, cubic family (five segments): fast to search."""
    return TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits(), **keywords)


def _recorded(monkeypatch, name):
    """The batches of candidates ``TimingProblem.<name>`` (``evaluate``: repaired; ``evaluate_durations``:
    raw) receives, in order."""
    seen = []
    original = getattr(TimingProblem, name)

    def recording(self, candidates, *args, **keywords):
        seen.append(np.array(candidates, dtype=float, copy=True))
        return original(self, candidates, *args, **keywords)

    monkeypatch.setattr(TimingProblem, name, recording)
    return seen


def _first_cuckoo_moves(monkeypatch, **settings):
    """A one-iteration ``paper`` Cuckoo Search of 400 nests: (nests, Levy proposals, discovery proposals)."""
    seen = _recorded(monkeypatch, "evaluate_durations")
    cuckoo_search(_search_problem(bounds=(0.5, 8.0)), variant="paper", nests=400, iterations=1, seed=5, **settings)
    return seen[0], seen[1], seen[2]


def test_cuckoo_levy_flights_are_mantegna_steps_of_index_beta(monkeypatch):
    """A Levy flight moves x by alpha * L * (x - x_best) * N with Mantegna's L = u / |v|^(1/beta): the
    multipliers Z = L N recovered from the first proposals have E log|Z| = log sigma_u + (2 - 1/beta) E log|n|
    (n standard normal: E log|n| = -(gamma + log 2) / 2), -1.21 for beta = 1.5 (|v|^beta would give -0.68)."""
    alpha = 1e-3  # small: almost no proposal reaches the bounds
    first, levy, _ = _first_cuckoo_moves(monkeypatch, alpha=alpha)
    best = np.all(levy == first, axis=1)  # the best nest's step is zero
    assert best.sum() == 1
    inside = (levy > 0.5) & (levy < 8.0) & ~best[:, None]
    multipliers = (levy - first)[inside] / (alpha * (first - first[best])[inside])
    assert len(multipliers) > 1500
    log_normal = -(np.euler_gamma + np.log(2)) / 2
    expected = np.log(mantegna_sigma(1.5)) + (2 - 1 / 1.5) * log_normal
    assert np.mean(np.log(np.abs(multipliers))) == pytest.approx(expected, abs=0.2)  # 5 standard errors


def test_cuckoo_discovery_abandons_each_component_with_probability_pa(monkeypatch):
    """Discovery moves each component with probability pa (0.25 by default) and leaves the others where the
    nest is (its first position or its accepted Levy proposal): about a quarter of 2000 components move."""
    first, levy, discovery = _first_cuckoo_moves(monkeypatch)
    moved = (discovery != first) & (discovery != levy)
    assert moved.mean() == pytest.approx(0.25, abs=0.05)


def _swarm_moves(monkeypatch, **settings):
    """A PSO run's evaluated candidates and the particles they make (repaired, in the search space):
    [(candidates, particles)] per evaluation, the repair recomputed here."""
    problem = _search_problem()
    seen = _recorded(monkeypatch, "evaluate")
    particle_swarm(problem, seed=1, **settings)
    monkeypatch.undo()
    return problem, [(batch, problem.to_search_space(problem.evaluate(batch).durations)) for batch in seen]


def test_pso_particles_move_towards_the_best_position_found_so_far(monkeypatch):
    """Social term alone (w = c1 = 0, c2 = 1): every particle's next candidate is x + r (g - x), r in [0, 1]
    per component, with x its repaired position and g the best repaired position any particle has reached so
    far (the particles hold their repaired positions)."""
    problem, moves = _swarm_moves(monkeypatch, particles=30, iterations=4, inertia=0.0, cognitive=0.0, social=1.0)
    best_value, best = np.inf, None
    for (candidates, particles), (following, _) in zip(moves, moves[1:5]):
        objective = problem.evaluate(candidates).objective
        if objective.min() < best_value:
            best_value, best = objective.min(), particles[np.argmin(objective)]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = (following - particles) / (best - particles)
        assert np.all(np.isnan(ratio) | ((ratio >= -1e-9) & (ratio <= 1 + 1e-9)))


def test_pso_velocities_decay_by_the_inertia_without_attraction(monkeypatch):
    """Without attraction (c1 = c2 = 0) a particle's velocity is w times the last: the second move of every
    component the box does not stop is w = 0.5 times the first."""
    problem, moves = _swarm_moves(monkeypatch, particles=20, iterations=3, inertia=0.5, cognitive=0.0, social=0.0)
    lower, upper = problem.search_box()
    (_, first), (second_candidates, second), (third_candidates, _) = moves[:3]
    free = ((second_candidates > lower) & (second_candidates < upper) & (third_candidates > lower)
            & (third_candidates < upper))
    assert free.mean() > 0.5
    np.testing.assert_allclose((third_candidates - second)[free], 0.5 * (second_candidates - first)[free],
                               rtol=1e-9, atol=1e-12)


def test_pso_velocities_are_limited_to_a_fifth_of_the_box(monkeypatch):
    """Strong attraction (c1 = c2 = 4): every move from a particle's repaired position to its next candidate
    is at most 20 % of the box in each component, and some reach that limit."""
    problem, moves = _swarm_moves(monkeypatch, particles=20, iterations=10, cognitive=4.0, social=4.0)
    lower, upper = problem.search_box()
    steps = np.abs(np.concatenate([following - particles for (_, particles), (following, _) in
                                   zip(moves, moves[1:11])])) / (upper - lower)
    assert steps.max() == pytest.approx(0.2, rel=1e-9)


def test_multistart_slsqp_runs_every_start_within_its_iterations():
    """``starts`` SLSQP runs, one progress entry each; ``iterations`` bounds each run: one iteration per start
    costs a few batches of S + 1 points, fifty many more."""
    problem = _search_problem()
    short, long = (multistart_slsqp(problem, starts=3, iterations=iterations) for iterations in (1, 50))
    assert len(short.history) == len(long.history) == 3
    assert short.evaluations <= 3 * (1 + 4 * (problem.segment_count + 1)) < long.evaluations


def test_slsqp_keeps_the_minimum_segment_duration_and_converges_to_the_nlps_optimum():
    """With a 1 s minimum segment duration that binds (the free optimum has a 0.79 s segment), SLSQP's
    variables start at the floor: it reaches the NLP's floored optimum to 1e-9 (its ftol is 1e-12)."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:5], "cubic", paper.paper_limits(), min_duration=1.0)
    tracker = SearchTracker(problem)
    refine(problem, problem.evaluate(np.ones((1, problem.segment_count))).durations[0], tracker, max_iterations=100)
    best = optimize(problem, "nlp")
    assert best.durations.min() == pytest.approx(1.0, rel=1e-9)
    assert tracker.best_feasible and tracker.best_objective == pytest.approx(best.objective, rel=1e-9)


def test_slsqp_weighs_the_time_by_k_t_where_the_limits_bind():
    """``time-jerk`` with K_t = 5, K_j = 0.01: the limits bind, so the best shape depends on K_t / K_j (not only
    the repair's scale) and SLSQP, minimising K_t T + K_j E, reaches the NLP's optimum to 1e-9."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:5], "cubic", paper.paper_limits(),
                            objective="time-jerk", weights=(5.0, 0.01))
    tracker = SearchTracker(problem)
    refine(problem, problem.evaluate(np.ones((1, problem.segment_count))).durations[0], tracker, max_iterations=100)
    assert tracker.best_feasible
    assert tracker.best_objective == pytest.approx(optimize(problem, "nlp").objective, rel=1e-9)
