from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import planner.timing.nlp as nlp
from planner import paper
from planner.timing import TimingProblem

ROOT = Path(__file__).resolve().parents[1]

settings.register_profile("project", deadline=None, max_examples=40, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("project")


# Corke's PUMA 560 (mdl_puma560, standard DH): (d, a, alpha) per joint; the shoulder 0.6718 m above the floor.
PUMA_DH = [(0.0, 0.0, np.pi / 2), (0.0, 0.4318, 0.0), (0.15005, 0.0203, -np.pi / 2),
           (0.4318, 0.0, np.pi / 2), (0.0, 0.0, -np.pi / 2), (0.0, 0.0, 0.0)]


def puma_dh_frames(q: np.ndarray) -> list[np.ndarray]:
    """Independent of the URDF: the 4x4 DH frames 1..6 of configuration ``q`` [rad], from the
    pedestal on, each frame i = frame i-1 Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)."""
    def rz(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])

    def rx(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])

    frame = np.eye(4)
    frame[2, 3] = 0.6718
    frames = []
    for qi, (d, a, alpha) in zip(q, PUMA_DH):
        shift = np.eye(4)
        shift[0, 3], shift[2, 3] = a, d
        frame = frame @ rz(qi) @ shift @ rx(alpha)
        frames.append(frame)
    return frames


def puma_segment(puma):
    """A short PUMA straight-line segment: its end configurations [rad], their poses (Pinocchio FK) and a
    function of the fraction u giving the segment's pose there, computed independently of the planner
    (linear position, scipy's slerp of the rotations)."""
    from scipy.spatial.transform import Rotation, Slerp

    q0 = np.deg2rad([10.0, -60.0, 150.0, 0.0, -30.0, 10.0])
    q1 = q0 + np.deg2rad([20.0, 10.0, -15.0, 10.0, 15.0, -20.0])
    poses = [puma.forward_kinematics(q) for q in (q0, q1)]
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([p.rotation for p in poses])))

    def pose_at(u):
        return (1 - u) * poses[0].translation + u * poses[1].translation, slerp([u])[0]

    return q0, q1, poses, pose_at


def assert_on_segment(puma, pose_at, fractions, configurations) -> None:
    """Each configuration puts the tool (Pinocchio FK) at its fraction's pose of ``puma_segment``'s
    ``pose_at``, to 1e-8 m and 1e-8 rad."""
    from scipy.spatial.transform import Rotation

    for u, q in zip(fractions, configurations):
        frame = puma.forward_kinematics(q)
        position, rotation = pose_at(u)
        np.testing.assert_allclose(frame.translation, position, atol=1e-8)
        assert (rotation.inv() * Rotation.from_matrix(frame.rotation)).magnitude() <= 1e-8


@pytest.fixture
def paper_via() -> np.ndarray:
    return np.deg2rad(paper.VIA_POINTS_DEG)


@pytest.fixture
def paper_limits():
    return paper.paper_limits()


def nanoradians(bound: float) -> st.SearchStrategy[float]:
    """Joint positions in [-bound, bound] rad in whole nanoradians (shrinking towards 0)."""
    return st.integers(-round(bound * 1e9), round(bound * 1e9)).map(lambda k: k * 1e-9)


@st.composite
def via_and_durations(draw, family_name: str, max_points: int = 7, max_joints: int = 3):
    """Via-points (n, J) in [-3, 3] rad, in whole nanoradians (the resolution at which via-points are told
    apart, ``timing.problem``; a via-point of 1e-239 rad underflows the extrema's products), and durations
    in [0.2, 5] s for a family, drawn as arrays (so that hypothesis shrinks a failing case to its simplest
    numbers: repeated via-points, equal durations)."""
    from planner import get_family
    n = draw(st.integers(2, max_points))
    joints = draw(st.integers(1, max_joints))
    via = draw(hnp.arrays(float, (n, joints), elements=nanoradians(3.0)))
    durations = draw(hnp.arrays(float, get_family(family_name).segment_count(n), elements=st.floats(0.2, 5.0)))
    return via, durations


def clipped_walk(count: int, seed: int):
    """Via-points (count, 6) [rad] of a random walk (steps within +-40 deg) clipped to the PUMA 560's
    ranges, and the paper's limits with those ranges: many via-points sit on a range bound."""
    low, high = np.deg2rad([[-160, -225, -45, -110, -100, -266], [160, 45, 225, 170, 100, 266]])
    steps = np.random.default_rng(seed).uniform(-40, 40, (count - 1, 6))
    via = np.clip(np.deg2rad(np.vstack((np.zeros(6), np.cumsum(steps, axis=0)))), low, high)
    return via, paper.paper_limits().with_overrides(lower=low, upper=high)


def dense_extremes(trajectory, per_segment: int = 400):
    """Max |q^(d)| (3, J) and position min, max (J,) from samples in every segment: independent of the
    exact root-finding the planner uses."""
    knots = trajectory.knot_times
    times = np.concatenate([np.linspace(a, b, per_segment) for a, b in zip(knots[:-1], knots[1:]) if b > a])
    positions = trajectory.evaluate(times)
    largest = np.stack([np.abs(trajectory.evaluate(times, order)).max(axis=0) for order in (1, 2, 3)])
    return largest, positions.min(axis=0), positions.max(axis=0)


def assert_plan_holds(result) -> None:
    """Independent checks of a feasible plan: every limit by dense sampling, the exact and reported
    figures against the samples, the duration floor and bounds, finite coefficients, lower bounds
    on the total time that any trajectory through the via-points obeys."""
    from planner.export import coefficients_document
    from planner.limits import rest_to_rest_time

    trajectory, limits, summary = result.trajectory, result.limits, result.summary()
    assert summary["feasible"] is True
    largest, low, high = dense_extremes(trajectory)
    assert np.all(largest <= limits.magnitudes * (1 + 1e-6))
    assert np.all(low >= limits.lower - 1e-9) and np.all(high <= limits.upper + 1e-9)
    assert np.all(largest <= result.figures.max_abs * (1 + 1e-9) + 1e-12)
    assert np.all(largest >= result.figures.max_abs * (1 - 1e-3) - 1e-12)
    reported = np.array([summary["max_abs"][key] for key in ("velocity_deg_s", "acceleration_deg_s2", "jerk_deg_s3")])
    np.testing.assert_allclose(reported, np.rad2deg(result.figures.max_abs), rtol=1e-9, atol=1e-9)
    # No segment shorter than the floor (merged repeated via-points apart), none beyond the bounds.
    moving = trajectory.durations[trajectory.durations > 0]
    assert moving.min() >= result.task.min_segment_s * (1 - 1e-9)
    bounds = result.task.optimizer["bounds"]
    if bounds is not None:
        assert moving.min() >= bounds[0] * (1 - 1e-9) and moving.max() <= bounds[1] * (1 + 1e-9)
    document = coefficients_document(trajectory)
    trigonometric = trajectory.basis == "trigonometric"
    normalized = np.asarray(document["coefficients" if trigonometric else "normalized_coefficients"])
    assert np.all(np.isfinite(trajectory.coefficients)) and np.all(np.isfinite(normalized))
    motion = float(np.ptp(result.via_points, axis=0).max())
    # A polynomial within +-1 on [0, 1] can have coefficients up to those of the shifted Chebyshev
    # polynomial of its degree (48 for a cubic, 39424 for degree 7): a margin of 20 over that. A trigonometric
    # segment within +-1 on [0, 3 pi / 4]: its coefficients are at most 270 (a linear program on 4001 angles).
    degree = normalized.shape[-1] - 1
    chebyshev = np.polynomial.Polynomial(np.polynomial.chebyshev.cheb2poly([0] * degree + [1]))
    largest = 270.0 if trigonometric else np.abs(chebyshev(np.polynomial.Polynomial([-1.0, 2.0])).coef).max()
    assert np.abs(normalized[..., 1:]).max() <= 20 * largest * motion
    assert_summary_figures(result, summary)
    # The trajectory passes through every via-point, in order, at its knot.
    via = result.via_points
    np.testing.assert_allclose(trajectory.evaluate(np.asarray(summary["via_times_s"])), via, atol=1e-9)
    steps = np.abs(np.diff(via, axis=0))
    assert trajectory.total_time >= (steps / limits.velocity).max(axis=1).sum() * (1 - 1e-9)
    assert trajectory.total_time >= rest_to_rest_time(np.abs(via[-1] - via[0]), limits).max() * (1 - 1e-9)


def assert_summary_figures(result, summary: dict, nodes: int = 400) -> None:
    """summary.json's figures against dense samples of the trajectory: the total time; the position range and
    every ratio to a limit (exact: no sample beyond them, and some sample within the sampling's reach of them,
    from the next derivative's largest sample and the widest gap between samples) from samples at
    Gauss-Legendre nodes (``nodes`` per segment, strictly inside it, where the segment's own polynomial holds:
    a knot's jerk is the next segment's) and at the knots; the mean |q^(d)| and the jerk energy by
    Gauss-Legendre quadrature on those nodes (exact for the energy)."""
    trajectory, limits = result.trajectory, result.limits
    assert summary["total_time_s"] == pytest.approx(trajectory.total_time, rel=1e-11)
    s, w = np.polynomial.legendre.leggauss(nodes)
    knots = np.asarray(trajectory.knot_times)
    moving = [(a, b) for a, b in zip(knots[:-1], knots[1:]) if b > a]
    inside = np.concatenate([a + (b - a) * (s + 1) / 2 for a, b in moving])
    weights = np.concatenate([(b - a) / 2 * w for a, b in moving])
    times = np.concatenate((inside, knots))
    half_gap = np.diff(np.sort(times)).max() / 2
    values = [trajectory.evaluate(times, order) for order in range(5)]
    largest = [np.abs(v).max(axis=0) for v in values]
    reported = [np.asarray(summary["position_range_deg"][side]) for side in ("min", "max")]
    reach = np.rad2deg(largest[1] * half_gap) * 1.01 + 1e-9  # |q(t*) - q(t)| <= max|q'| |t* - t|
    assert np.all(np.rad2deg(values[0].min(axis=0)) >= reported[0] - 1e-9)
    assert np.all(np.rad2deg(values[0].max(axis=0)) <= reported[1] + 1e-9)
    assert np.all(np.rad2deg(values[0].min(axis=0)) <= reported[0] + reach)
    assert np.all(np.rad2deg(values[0].max(axis=0)) >= reported[1] - reach)
    keys = ("velocity_deg_s", "acceleration_deg_s2", "jerk_deg_s3")
    for d, (quantity, key) in enumerate(zip(("velocity", "acceleration", "jerk"), keys), start=1):
        ratio = np.array([np.nan if r is None else r for r in summary["max_ratio"][quantity]], dtype=float)
        bound = limits.magnitudes[d - 1]
        assert np.all(largest[d] / bound <= ratio * (1 + 1e-9) + 1e-12)
        assert np.all(largest[d] / bound >= ratio - (largest[d + 1] * half_gap * 1.01 + 1e-9) / bound)
        inner = np.abs(values[d][:len(inside)])
        mean = np.rad2deg(weights @ inner / trajectory.total_time)
        np.testing.assert_allclose(summary["mean_abs"][key], mean, rtol=1e-4, atol=1e-9 * (1 + mean.max()))
    energy = weights @ values[3][:len(inside)] ** 2
    np.testing.assert_allclose(summary["jerk_energy_rad2_s5"], energy, rtol=1e-9, atol=1e-12 * (1 + energy.max()))


#: Four tool poses of the UR5 pick-and-place (down, up, across), for robot-limit and straight-line tasks.
UR5_PICK_POSES = [{"xyz_m": [0.40, -0.25, 0.35], "rpy_deg": [180, 0, 90]},
                  {"xyz_m": [0.40, -0.25, 0.12], "rpy_deg": [180, 0, 90]},
                  {"xyz_m": [0.40, -0.25, 0.35], "rpy_deg": [180, 0, 90]},
                  {"xyz_m": [0.25, 0.35, 0.40], "rpy_deg": [180, 0, 45]}]
#: UR5 acceleration and jerk limits 10 times the pick-and-place task's: fast joints, so robot limits bind.
UR5_FAST = {"acceleration_deg_s2": [1500, 1500, 1500, 3000, 3000, 3000],
            "jerk_deg_s3": [6000, 6000, 6000, 12000, 12000, 12000]}


PENDULUM = """<robot name="pendulum">
  <link name="base"/>
  <link name="arm"><inertial><origin xyz="{length} 0 0"/><mass value="{mass}"/>
    <inertia ixx="0.001" iyy="{inertia}" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="swing" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" velocity="2" effort="{effort}"/></joint>
  <link name="tip"/>
  <joint name="tip_fixed" type="fixed"><parent link="arm"/><child link="tip"/><origin xyz="{length} 0 0"/></joint>
</robot>"""


def pendulum(tmp_path, length=0.5, mass=2.0, inertia=0.03, effort=20.0):
    """A one-joint pendulum robot about a horizontal axis, its mass at ``length`` [m] from it, its tip
    frame ``tip`` at ``length`` too: tau = (I + m l^2) q'' - m g l cos q."""
    from planner.robot import Robot

    urdf = tmp_path / "pendulum.urdf"
    urdf.write_text(PENDULUM.format(length=length, mass=mass, inertia=inertia, effort=effort))
    return Robot.from_urdf(urdf, "tip")


def record_evaluations(monkeypatch) -> list[np.ndarray]:
    """Wrap ``TimingProblem.evaluate``: the returned list gets a copy of every batch of candidates (S,)
    or (B, S) evaluated, in order, so a search's candidates can be checked against its update rules."""
    batches: list[np.ndarray] = []
    evaluate = TimingProblem.evaluate

    def recording(self, candidates):
        batches.append(np.array(candidates, copy=True))
        return evaluate(self, candidates)

    monkeypatch.setattr(TimingProblem, "evaluate", recording)
    return batches


def record_solves(monkeypatch, certificates: list[int] | None = None) -> list[int]:
    """Wrap every program's IPOPT solver: the returned list gets each solve's own iteration count (and
    ``certificates`` the number of certificates of the program solved), so the rounds, iterations and
    certificates an outcome reports can be checked against the solves actually made."""
    counts: list[int] = []
    build = nlp._Program.__init__

    def init(self, program_nlp, program_certificates, warm=False):
        build(self, program_nlp, program_certificates, warm)
        solver, size = self.solver, len(program_certificates)

        class Recorder:
            def __call__(self, **arguments):
                solution = solver(**arguments)
                counts.append(int(solver.stats()["iter_count"]))
                if certificates is not None:
                    certificates.append(size)
                return solution

            def stats(self):
                return solver.stats()

        self.solver = Recorder()

    monkeypatch.setattr(nlp._Program, "__init__", init)
    return counts
