"""Gaps in the tests of planner/cartesian_path.py found by mutation testing (mutmut 3.8.1, a partial run)."""

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from planner.cartesian_path import segment_deviation


def _point_to_segment(p, a, b):
    """Independent oracle: distance from p to the segment a-b (brute force over a fine grid of u)."""
    u = np.linspace(0.0, 1.0, 200_001)
    return np.min(np.linalg.norm(a + u[:, None] * (b - a) - p, axis=1))


def test_a_segment_of_constant_orientation_measures_the_angle_to_that_orientation():
    # Pure translation: both ends have the same rotation, so the slerp "arc" is one rotation (phi = 0).
    rng = np.random.default_rng(7)
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # exact: R^T R == I
    a = pin.SE3(rotation, np.array([0.3, -0.1, 0.5]))
    b = pin.SE3(rotation, np.array([0.5, 0.2, 0.4]))
    positions = rng.uniform(-0.2, 0.8, (6, 3))
    offsets = Rotation.from_rotvec(rng.normal(size=(6, 3)) * 0.3)
    rotations = (Rotation.from_matrix(rotation) * offsets).as_matrix()
    distance, angle = segment_deviation(a, b, positions, rotations)
    assert np.all(np.isfinite(angle)) and np.all(np.isfinite(distance))
    np.testing.assert_allclose(angle, offsets.magnitude(), atol=1e-12)
    expected = [_point_to_segment(p, a.translation, b.translation) for p in positions]
    np.testing.assert_allclose(distance, expected, atol=1e-9)


class _PlanarRobot:
    """Stand-in robot: the tool sits at (q0, q1, 0), turned by q2 about z."""

    def tool_placements(self, q):
        q = np.asarray(q)
        return (np.column_stack([q[:, 0], q[:, 1], np.zeros(len(q))]),
                np.array([pin.exp3(np.array([0.0, 0.0, angle])) for angle in q[:, 2]]))


class _RecordingTrajectory:
    """Stand-in trajectory: q(t) = (t, 0.01 sin(3 t) t, 0.02 t cos t), recording every time it is sampled at."""

    def __init__(self, via_times):
        self.via_times = np.asarray(via_times, dtype=float)
        self.total_time = float(self.via_times[-1])
        self.sampled = []

    def evaluate(self, times):
        times = np.asarray(times, dtype=float)
        self.sampled.append(times)
        return np.stack([times, 0.01 * np.sin(3 * times) * times, 0.02 * times * np.cos(times)], axis=1)


def test_tool_deviation_samples_every_interval_densely_and_takes_the_maxima_per_segment():
    from planner.cartesian_path import CHECK_RATE_HZ, CHECK_SAMPLES, tool_deviation
    via_times = [0.0, 0.01, 0.5, 2.0, 2.3]          # 4 via-point intervals
    waypoint_via = np.array([0, 2, 4])               # 2 user segments: intervals (0, 1) and (2, 3)
    poses = [pin.SE3(np.eye(3), np.array([t, 0.0, 0.0])) for t in (0.0, 0.5, 2.3)]
    trajectory = _RecordingTrajectory(via_times)
    distance, angle, per_distance, per_angle = tool_deviation(_PlanarRobot(), trajectory, poses, waypoint_via)
    # Sampling: each interval, both ends included, at least CHECK_SAMPLES steps and at least CHECK_RATE_HZ.
    assert len(trajectory.sampled) == 4
    for k, times in enumerate(trajectory.sampled):
        span = via_times[k + 1] - via_times[k]
        expected = max(CHECK_SAMPLES, int(np.ceil(span * CHECK_RATE_HZ))) + 1
        np.testing.assert_allclose(times, np.linspace(via_times[k], via_times[k + 1], expected), rtol=0, atol=1e-15)
    # Independent oracle: the tool is at (t, y(t), 0) on a segment of the x axis (x within it), turned by q2 about z.
    segment_of = [0, 0, 1, 1]
    for k, times in enumerate(list(trajectory.sampled)):
        q = trajectory.evaluate(times)
        a, b = poses[segment_of[k]].translation[0], poses[segment_of[k] + 1].translation[0]
        dx = np.maximum(np.maximum(a - q[:, 0], q[:, 0] - b), 0.0)
        np.testing.assert_allclose(distance[k], np.max(np.hypot(dx, q[:, 1])), rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(angle[k], np.max(np.abs(q[:, 2])), rtol=1e-9, atol=1e-15)
    assert per_distance.shape == per_angle.shape == (2,)
    np.testing.assert_array_equal(per_distance, [distance[:2].max(), distance[2:].max()])
    np.testing.assert_array_equal(per_angle, [angle[:2].max(), angle[2:].max()])


def test_a_long_trajectory_is_sampled_more_sparsely_down_to_the_sample_cap(monkeypatch):
    from planner import cartesian_path
    monkeypatch.setattr(cartesian_path, "MAX_CHECK_SAMPLES", 1_000)  # the cap, made small to keep the test fast
    trajectory = _RecordingTrajectory([0.0, 60.0, 100.0])           # 100 s: 250 Hz would be 25 000 samples
    poses = [pin.SE3(np.eye(3), np.array([x, 0.0, 0.0])) for x in (0.0, 100.0)]
    cartesian_path.tool_deviation(_PlanarRobot(), trajectory, poses, np.array([0, 2]))
    counts = [len(times) for times in trajectory.sampled]
    assert counts == [601, 401]                                       # 10 Hz = 1 000 / 100 s, ends included
    assert sum(counts) - len(counts) == 1_000


def test_even_counts_space_every_segment_as_closely_as_half_the_held_segments_spacing():
    from planner.cartesian_path import _even_counts
    # Two joints; a segment's length is the sum over its intervals of the largest joint change.
    configurations = [
        [np.array([1.0, -2.0]), np.array([1.1, -2.05]), np.array([1.2, -2.3])],   # 0.1 + 0.25 = 0.35, 2 intervals
        [np.array([1.2, -2.3]), np.array([2.0, -2.0])],                           # 0.8, 1 interval
        [np.array([2.0, -2.0]), np.array([2.01, -2.0])],                          # 0.01, 1 interval
        [np.array([2.01, -2.0]), np.array([2.02, -2.0]), np.array([2.03, -2.0]), np.array([2.04, -2.0])],  # 0.03, 3
    ]
    # Held: segment 0, spacing 0.35 / 2 = 0.175; step = half of it = 0.0875. A segment keeps at least the
    # intervals it has (segment 3).
    counts = _even_counts(configurations, {0: (0.01, "trajectory.min_segment_s")})
    assert counts == {0: 4, 1: 10, 2: 1, 3: 3}   # ceil(0.35 / 0.0875), ceil(0.8 / 0.0875), ceil(0.01 / 0.0875), 3
    assert _even_counts(configurations, {}) == {}
    # The closest held spacing sets the step: with segment 2 held too, step = 0.01 / 2.
    assert _even_counts(configurations, {0: (0.01, ""), 2: (0.01, "")}) == {0: 70, 1: 160, 2: 2, 3: 6}
    # A held segment that does not move (length 0): no step to space by; every segment keeps its intervals.
    still = [[np.array([0.5, 0.5]), np.array([0.5, 0.5])], configurations[1]]
    assert _even_counts(still, {0: (0.01, "")}) == {0: 1, 1: 1}


def test_at_least_duration_looks_only_at_the_segments_of_its_interval():
    from types import SimpleNamespace

    from planner.cartesian_path import _at_least_duration
    # Via-points at 0, 1.2, 3 s; knots at 0, 0.6, 1.2, 1.7, 3: interval 0 holds segments of 0.6 and 0.6 s,
    # interval 1 segments of 0.5 and 1.3 s.
    knots = np.array([0.0, 0.6, 1.2, 1.7, 3.0])
    trajectory = SimpleNamespace(via_times=np.array([0.0, 1.2, 3.0]), knot_times=knots, durations=np.diff(knots))
    least = (0.5, "trajectory.min_segment_s")
    assert _at_least_duration(trajectory, 1, least) == least        # its first segment (starting at 1.2 s) is held
    assert _at_least_duration(trajectory, 0, least) is None         # 0.6 s > 0.5 s; the 0.5 s segment is interval 1's
    assert _at_least_duration(trajectory, 0, (0.6, "k")) == (0.6, "k")
    assert _at_least_duration(trajectory, 0, (0.59, "k")) is None   # within 1e-6 of it only
    assert _at_least_duration(trajectory, 0, (0.0, "")) is None
