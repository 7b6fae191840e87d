from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from planner import RobotError, paper
from planner.robot import Robot, load_robot

ROOT = Path(__file__).resolve().parents[1]
PUMA = ROOT / "robots" / "puma560.urdf"

# Standard DH of the PUMA 560 (Corke, mdl_puma560): (d, a, alpha) per joint.
PUMA_DH = [(0.0, 0.0, np.pi / 2), (0.0, 0.4318, 0.0), (0.15005, 0.0203, -np.pi / 2),
           (0.4318, 0.0, np.pi / 2), (0.0, 0.0, -np.pi / 2), (0.0, 0.0, 0.0)]


def dh_forward_kinematics(q: np.ndarray) -> np.ndarray:
    """Independent FK: pedestal, prod_i Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i), then the 0.1 m tool."""
    def rz(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])

    def rx(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])

    def translate(x, z):
        m = np.eye(4)
        m[0, 3], m[2, 3] = x, z
        return m

    pose = translate(0, 0.6718)
    for qi, (d, a, alpha) in zip(q, PUMA_DH):
        pose = pose @ rz(qi) @ translate(a, d) @ rx(alpha)
    return pose @ translate(0, 0.1)


@pytest.fixture(scope="module")
def puma():
    return Robot.from_urdf(PUMA, "tool")


def test_puma_fk_matches_dh_table(puma):
    rng = np.random.default_rng(0)
    for q in [np.zeros(6), *np.deg2rad(paper.VIA_POINTS_DEG), *rng.uniform(-np.pi, np.pi, (20, 6))]:
        np.testing.assert_allclose(puma.forward_kinematics(q).homogeneous, dh_forward_kinematics(q), atol=1e-12)


def test_puma_limits_contain_table_ii_and_match_table_iii(puma):
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    assert np.all(via > puma.limits.lower) and np.all(via < puma.limits.upper)
    np.testing.assert_allclose(np.rad2deg(puma.limits.velocity), paper.VELOCITY_LIMITS_DEG)
    np.testing.assert_allclose(np.rad2deg(puma.limits.acceleration), paper.ACCELERATION_LIMITS_DEG)
    np.testing.assert_allclose(np.rad2deg(puma.limits.jerk), paper.JERK_LIMITS_DEG)
    assert puma.joint_names == [f"joint{j}" for j in range(1, 7)]


@pytest.mark.parametrize("name, tool, dof", [("ur5", "tool0", 6), ("panda", "panda_hand_tcp", 7)])
def test_example_robots_keep_only_the_tool_chain(name, tool, dof):
    robot = Robot.from_example_robot_data(name, tool)
    assert robot.dof == dof and robot.urdf_path.is_file()
    assert np.all(np.isfinite(robot.limits.velocity)) and not np.isfinite(robot.limits.jerk).any()


@pytest.mark.parametrize("name, tool", [("puma", "tool"), ("ur5", "tool0"), ("panda", "panda_hand_tcp")])
def test_frame_jacobian_matches_finite_differences(puma, name, tool):
    robot = puma if name == "puma" else Robot.from_example_robot_data(name, tool)
    rng = np.random.default_rng(1)
    lower, upper = np.maximum(robot.limits.lower, -3), np.minimum(robot.limits.upper, 3)
    q = lower + (upper - lower) * rng.random(robot.dof)
    base = robot.forward_kinematics(q)
    numeric = np.empty((6, robot.dof))
    step = 1e-7
    for j in range(robot.dof):
        dq = np.zeros(robot.dof)
        dq[j] = step
        numeric[:, j] = pin.log6(base.actInv(robot.forward_kinematics(q + dq))).vector / step
    np.testing.assert_allclose(robot.frame_jacobian(q), numeric, atol=1e-5)


def test_unknown_robot_frame_and_file():
    with pytest.raises(RobotError, match="unknown robot 'r2d2'; example-robot-data has: .*ur5"):
        Robot.from_example_robot_data("r2d2")
    with pytest.raises(RobotError, match="robot 'puma560' has no frame 'gripper'; frames: .*tool"):
        Robot.from_urdf(PUMA, "gripper")
    with pytest.raises(RobotError, match="cannot load URDF"):
        Robot.from_urdf(ROOT / "robots" / "missing.urdf")
    with pytest.raises(RobotError, match="exactly one"):
        load_robot()


def test_bad_limits_file(tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(PUMA.read_text())
    (tmp_path / "arm.limits.yaml").write_text("acceleration_deg_s2: [1, 2]\n")
    with pytest.raises(RobotError, match="acceleration_deg_s2 needs 6 positive numbers"):
        Robot.from_urdf(urdf, "tool")
