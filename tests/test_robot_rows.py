"""The NLP's torque and tool-speed model (planner.timing.robot_rows) against Pinocchio's own RNEA and
frame velocity, finite differences, and its CasADi rows against its numeric form."""

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from planner.robot import Robot
from planner.timing.robot_rows import (
    RobotConstraints,
    freeze,
    modelled,
    parameters,
    point_derivatives,
    point_rows,
    row_bounds,
    sample_points,
    spline_states,
)

LIMITS = np.array([150.0, 150.0, 150.0, 28.0, 28.0, 28.0])


@pytest.fixture(scope="module")
def ur5():
    return Robot.from_example_robot_data("ur5", "tool0")


def rnea(robot, q, qd, qdd):
    model, data = robot.model, robot.model.createData()
    return np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])


def tool_velocity(robot, q, qd, rows=slice(0, 3)):
    """The tool origin's linear velocity (``rows`` 3:6: its angular velocity) in world axes: a different
    frame from the model's, same norm."""
    model, data = robot.model, robot.model.createData()
    return np.array([pin.computeFrameJacobian(model, data, a, robot.tool_frame_id,
                                              pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[rows] @ b for a, b in zip(q, qd)])


states = arrays(float, (3, 4, 6), elements=st.floats(-2.0, 2.0))


@given(states, st.floats(0.2, 5.0), st.floats(-3.0, 3.0))
@settings(max_examples=15, deadline=None)
def test_the_frozen_model_is_rnea_at_its_positions_whatever_the_velocities(ur5, drawn, k, c):
    """At the positions it was frozen at, the model is exact for any velocity and acceleration (a time
    scaling changes those, not the positions): torque and tool speed equal Pinocchio's."""
    q, qd, qdd = drawn
    constraints = RobotConstraints(ur5, LIMITS, 1.0, 2.0)
    frozen = freeze(constraints, q, qd, qdd)
    torque, velocity = modelled(frozen, q, k * qd, c * qdd)
    np.testing.assert_allclose(torque, rnea(ur5, q, k * qd, c * qdd), atol=1e-9)
    for part, rows in ((slice(0, 3), slice(0, 3)), (slice(3, 6), slice(3, 6))):  # linear, then angular
        np.testing.assert_allclose(np.linalg.norm(velocity[:, part], axis=1),
                                   np.linalg.norm(tool_velocity(ur5, q, k * qd, rows), axis=1), atol=1e-12)


@given(states, arrays(float, (4, 6), elements=st.floats(-1.0, 1.0)))
@settings(max_examples=15, deadline=None)
def test_the_frozen_model_has_the_true_derivative_in_position(ur5, drawn, direction):
    """The model's change along a change of position equals RNEA's and the tool velocity's, by central
    differences (the q-terms come from computeRNEADerivatives and getFrameVelocityDerivatives)."""
    q, qd, qdd = drawn
    frozen = freeze(RobotConstraints(ur5, LIMITS, None, 1.0), q, qd, qdd)  # the angular speed alone
    step = 1e-6
    ahead, behind = q + step * direction, q - step * direction
    model_torque = (modelled(frozen, ahead, qd, qdd)[0] - modelled(frozen, behind, qd, qdd)[0]) / (2 * step)
    true_torque = (rnea(ur5, ahead, qd, qdd) - rnea(ur5, behind, qd, qdd)) / (2 * step)
    np.testing.assert_allclose(model_torque, true_torque, atol=1e-5 * np.abs(true_torque).max() + 1e-6)
    # The model's velocity is in the tool's own axes, which turn with q: compare the speed's change.
    model_speed = [np.linalg.norm(modelled(frozen, x, qd, qdd)[1], axis=1) for x in (ahead, behind)]
    true_speed = [np.linalg.norm(tool_velocity(ur5, x, qd, slice(3, 6)), axis=1) for x in (ahead, behind)]
    np.testing.assert_allclose((model_speed[0] - model_speed[1]) / (2 * step),
                               (true_speed[0] - true_speed[1]) / (2 * step), atol=1e-6)


@pytest.mark.parametrize("torque, speed, angular", [(True, True, False), (True, False, False), (False, True, False),
                                                    (False, False, True), (True, True, True)])
def test_the_nlp_rows_are_the_model_scaled_by_the_limits(ur5, torque, speed, angular):
    """The CasADi rows, mapped over points with the model's numbers as parameters (the layout the NLP
    uses), give tau / L, |v|^2 / V^2 and |w|^2 / W^2 of the numeric model at every point, in
    ``row_bounds``' order."""
    rng = np.random.default_rng(3)
    q, qd, qdd = rng.normal(size=(3, 5, 6))
    constraints = RobotConstraints(ur5, LIMITS if torque else None, 0.3 if speed else None, 1.5 if angular else None)
    frozen = freeze(constraints, q, qd, qdd)
    shifted = q + 0.05 * rng.normal(size=q.shape), 1.7 * qd, -0.4 * qdd  # not where it was frozen
    function = point_rows(ca, constraints, 6)
    rows = np.array(function.map(5)(*(x.T for x in shifted), parameters(frozen)))
    model_torque, model_velocity = modelled(frozen, *shifted)
    expected = []
    if torque:
        expected.append((model_torque / LIMITS).T)
    if speed:
        expected.append((np.sum(model_velocity[:, :3] ** 2, axis=1) / 0.3 ** 2)[None])
    if angular:
        expected.append((np.sum(model_velocity[:, -3:] ** 2, axis=1) / 1.5 ** 2)[None])
    np.testing.assert_allclose(rows, np.vstack(expected), rtol=1e-12, atol=1e-12)
    low, high = row_bounds(constraints, 6)
    assert len(low) == len(high) == rows.shape[0]


def test_the_samples_are_the_spline_at_each_segments_points():
    """``spline_states`` at ``sample_points`` against numpy's own polynomial evaluation."""
    rng = np.random.default_rng(5)
    coefficients, durations = rng.normal(size=(3, 2, 6)), rng.uniform(0.5, 2.0, 3)
    segments, s = sample_points(np.array([0, 2]))
    q, qd, qdd = spline_states(coefficients, durations, segments, s)
    for p, (k, fraction) in enumerate(zip(segments, s)):
        for j in range(2):
            polynomial = np.polynomial.Polynomial(coefficients[k, j])
            tau = fraction * durations[k]
            assert (q[p, j], qd[p, j], qdd[p, j]) == pytest.approx(
                (polynomial(tau), polynomial.deriv()(tau), polynomial.deriv(2)(tau)), rel=1e-12, abs=1e-12)
    assert sorted(set(s)) == list(np.arange(8) / 8)


def test_the_nlp_rows_derivatives_are_the_models_by_finite_differences(ur5):
    """The Jacobian CasADi derives of the mapped rows in q, q' and q'' (the model's numbers are
    parameters it does not differentiate in) against central differences of the numeric model."""
    rng = np.random.default_rng(11)
    points = 3
    q, qd, qdd = rng.normal(size=(3, points, 6))
    constraints = RobotConstraints(ur5, LIMITS, 0.3, 1.5)
    frozen = freeze(constraints, q, qd, qdd)
    numbers = parameters(frozen)
    symbols = [ca.MX.sym(name, 6, points) for name in ("q", "qd", "qdd")]
    rows = ca.vec(point_rows(ca, constraints, 6).map(points)(*symbols, numbers))
    inputs = ca.vertcat(*[ca.vec(x) for x in symbols])
    jacobian = ca.Function("jacobian", [inputs], [ca.jacobian(rows, inputs)])
    at = np.concatenate([x.T.ravel() for x in (q + 0.1, 1.3 * qd, -0.7 * qdd)])  # not where it was frozen

    def numeric(x):
        states = [x[k * 6 * points:(k + 1) * 6 * points].reshape(points, 6) for k in range(3)]
        torque, velocity = modelled(frozen, *states)
        speeds = [np.sum(velocity[:, :3] ** 2, axis=1) / 0.3 ** 2, np.sum(velocity[:, 3:] ** 2, axis=1) / 1.5 ** 2]
        return np.vstack([(torque / LIMITS).T, *[s[None] for s in speeds]]).T.ravel()  # point by point

    step = 1e-6
    differences = np.column_stack([(numeric(at + step * e) - numeric(at - step * e)) / (2 * step)
                                   for e in np.eye(len(at))])
    np.testing.assert_allclose(np.array(jacobian(at)), differences, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("family", ["cubic", "hybrid", "quintic", "hermite7", "trigonometric"])
def test_the_nlp_samples_are_the_splines_at_the_model_points(family):
    """The NLP's symbolic q, q', q'' at the samples (``_sampled_states``), column by column, equal
    ``spline_states`` at ``sample_points`` (the order the frozen model's numbers come in), evaluated
    at a spline's durations and knot states."""
    from planner.limits import JointLimits
    from planner.timing.nlp import TimingNLP, _sampled_states
    from planner.timing.problem import TimingProblem

    rng = np.random.default_rng(2)
    via = np.cumsum(rng.normal(size=(5, 2)), axis=0)
    limits = JointLimits.create(2, velocity=np.ones(2), acceleration=np.ones(2), jerk=np.ones(2))
    problem = TimingProblem(via, family, limits)
    h = rng.uniform(0.5, 2.0, problem.segment_count)
    coefficients = problem.coefficients(h[None])[0]
    formulation = TimingNLP(problem, h).formulation
    symbolic = ca.MX.sym("h", problem.segment_count)
    spline = formulation.build(symbolic)
    for block in spline.blocks:
        evaluate = ca.Function("samples", [symbolic, spline.states], list(_sampled_states(ca, block, symbolic)))
        found = [np.array(x) for x in evaluate(h, formulation.state_values(coefficients, h))]
        expected = spline_states(coefficients, h, *sample_points(block.segments), problem.family.basis)
        for got, want in zip(found, expected):
            np.testing.assert_allclose(got, want.T, rtol=1e-9, atol=1e-9)


def test_the_rows_own_derivatives_are_the_models_by_finite_differences(ur5):
    """``point_derivatives``' Jacobian, and Hessian of a weighted sum of the rows, at one point (away
    from where the model was frozen), against central differences of the numeric model and of its
    Jacobian; the Hessian is the upper triangle."""
    rng = np.random.default_rng(13)
    q, qd, qdd = rng.normal(size=(3, 1, 6))
    constraints = RobotConstraints(ur5, LIMITS, 0.3, 1.5)
    frozen = freeze(constraints, q, qd, qdd)
    numbers = parameters(frozen)[:, 0]
    jacobian, hessian = point_derivatives(ca, point_rows(ca, constraints, 6))
    weights = rng.normal(size=8)
    at = np.concatenate([(q + 0.1)[0], 1.3 * qd[0], -0.7 * qdd[0]])

    def numeric(x):
        torque, velocity = modelled(frozen, x[None, :6], x[None, 6:12], x[None, 12:])
        return np.concatenate([torque[0] / LIMITS, [np.sum(velocity[0, :3] ** 2) / 0.3 ** 2,
                                                    np.sum(velocity[0, 3:] ** 2) / 1.5 ** 2]])

    def numeric_jacobian(x):
        return np.array(ca.densify(jacobian(x[:6], x[6:12], x[12:], numbers)))

    step = 1e-6
    unit = np.eye(18)
    differences = np.column_stack([(numeric(at + step * e) - numeric(at - step * e)) / (2 * step) for e in unit])
    np.testing.assert_allclose(numeric_jacobian(at), differences, rtol=1e-6, atol=1e-6)
    second = np.column_stack([weights @ (numeric_jacobian(at + step * e) - numeric_jacobian(at - step * e))
                              / (2 * step) for e in unit])
    found = np.array(ca.densify(hessian(at[:6], at[6:12], at[12:], numbers, weights)))
    np.testing.assert_allclose(found, np.triu(second), rtol=1e-6, atol=1e-6)
    assert np.abs(second[6:12, 6:12]).max() > 1e-3  # the velocities' block is not trivially zero


@pytest.mark.parametrize("family", ["hybrid", "hermite7"])
def test_the_programs_derivative_functions_are_casadis_own(ur5, family, monkeypatch):
    """The constraint Jacobian and Lagrangian Hessian IPOPT gets (the robot rows' placed from their own
    derivatives, ``nlp._robot_derivative_functions``) equal those CasADi derives itself of the same
    program, entry by entry and in sparsity, at random variables, model numbers and multipliers:
    torque and both speeds, several blocks (hybrid: cubic interior and quintic ends), and the trust
    region's rows (hermite7)."""
    from planner.limits import JointLimits
    from planner.timing import nlp as nlp_module
    from planner.timing.problem import TimingProblem

    rng = np.random.default_rng(4)
    via = np.cumsum(0.3 * rng.normal(size=(5, 6)), axis=0)
    limits = JointLimits.create(6, velocity=np.ones(6), acceleration=np.ones(6), jerk=np.ones(6))
    problem = TimingProblem(via, family, limits)
    nlp = nlp_module.TimingNLP(problem, np.ones(problem.segment_count), RobotConstraints(ur5, LIMITS, 0.3, 1.5))
    assert len(nlp.blocks) >= (2 if family == "hybrid" else 1) and nlp.trusted == (family == "hermite7")
    placed = nlp_module._Program(nlp, [])
    monkeypatch.setattr(nlp_module, "_robot_derivative_functions", lambda *args, **kwargs: {})
    derived = nlp_module._Program(nlp, [])
    for name in ("nlp_jac_g", "nlp_hess_l"):
        ours, casadis = placed.solver.get_function(name), derived.solver.get_function(name)
        arguments = [ca.DM(rng.normal(size=ours.size_in(i))) for i in range(ours.n_in())]
        for got, want in zip(ours.call(arguments), casadis.call(arguments)):
            np.testing.assert_allclose(np.array(ca.densify(got)), np.array(ca.densify(want)), rtol=1e-12,
                                       atol=1e-12)
            assert got.sparsity() == want.sparsity()
    assert len(placed.robot_rows) > 0
