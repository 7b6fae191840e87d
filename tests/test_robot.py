import os
import re
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

from conftest import puma_dh_frames
from planner import (
    InputError,
    MissingLimitError,
    RobotError,
    RobotFileError,
    UnknownFrameError,
    UnknownRobotError,
    UnsupportedRobotError,
    paper,
    plan,
)
from planner.robot import Robot, load_robot

ROOT = Path(__file__).resolve().parents[1]
PUMA = ROOT / "robots" / "puma560.urdf"

def dh_forward_kinematics(q: np.ndarray) -> np.ndarray:
    """Independent FK: the DH frames (``conftest.puma_dh_frames``), then the 0.1 m tool."""
    tool = np.eye(4)
    tool[2, 3] = 0.1
    return puma_dh_frames(q)[-1] @ tool


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
    with pytest.raises(UnknownRobotError, match="unknown robot 'r2d2'; example-robot-data has: .*ur5") as caught:
        Robot.from_example_robot_data("r2d2")
    assert caught.value.name == "r2d2" and "ur5" in caught.value.known and "panda" in caught.value.known
    with pytest.raises(UnknownFrameError, match="robot 'puma560' has no frame 'gripper'; frames: .*tool") as caught:
        Robot.from_urdf(PUMA, "gripper")
    assert caught.value.frame == "gripper" and "tool" in caught.value.frames
    with pytest.raises(RobotFileError, match="cannot load URDF") as caught:
        Robot.from_urdf(ROOT / "robots" / "missing.urdf")
    assert caught.value.path == ROOT / "robots" / "missing.urdf"
    assert all(issubclass(kind, RobotError) for kind in (UnknownRobotError, UnknownFrameError, RobotFileError,
                                                         UnsupportedRobotError, MissingLimitError))
    with pytest.raises(InputError, match="load_robot takes exactly one of a URDF path or a robot name, got neither"):
        load_robot()  # the call's mistake, not a robot's: no RobotError
    with pytest.raises(InputError, match="got both"):
        load_robot(ROOT / "robots" / "puma560.urdf", "ur5")


def arm_with_limits(tmp_path, limits_text: str | bytes) -> Path:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(PUMA.read_text())
    limits = tmp_path / "arm.limits.yaml"
    (limits.write_bytes if isinstance(limits_text, bytes) else limits.write_text)(limits_text)
    return urdf


def test_a_urdf_named_through_a_link_takes_the_limits_file_beside_the_link(tmp_path):
    """A task naming a URDF through a symbolic link (a ROS workspace is made of them) takes the
    ``NAME.limits.yaml`` beside the path it names, as ``Robot.from_urdf`` does: the target's folder's
    file was taken instead, without a word (ten times the user's accelerations, exit 0)."""
    (tmp_path / "arm.urdf").symlink_to(PUMA)
    (tmp_path / "arm.limits.yaml").write_text("acceleration_deg_s2: [6, 6, 7.5, 7, 9, 8]\n"
                                              "jerk_deg_s3: [6, 6.6, 8.5, 7, 7.5, 7]\n")
    task = {"version": 1, "robot": {"urdf": "arm.urdf", "tool_frame": "tool"},
            "waypoints": {"joints_deg": [[10, 15, 45, 5, 10, 6], [60, 25, 150, 20, 30, 40]]}}
    (tmp_path / "task.yaml").write_text(yaml.safe_dump(task))
    result = plan(tmp_path / "task.yaml")
    assert np.allclose(np.rad2deg(result.limits.acceleration), [6, 6, 7.5, 7, 9, 8])
    assert np.allclose(np.rad2deg(Robot.from_urdf(tmp_path / "arm.urdf", "tool").limits.acceleration),
                       [6, 6, 7.5, 7, 9, 8])


@pytest.mark.parametrize("text, message", [
    ("acceleration_deg_s2: [1, 2]\n", r"acceleration_deg_s2 must be a list of 6 positive numbers, one per joint "
                                      r"\(joint1, .*\), got \[1, 2\]$"),
    ("acceleration_deg_s2: [a, b]\n", r"acceleration_deg_s2 must be a list of 6 .*got \['a', 'b'\]$"),
    ("acceleration_deg_s2: {a: 1}\n", r"acceleration_deg_s2 must be a list of 6 .*got \{'a': 1\}$"),
    ("jerk_deg_s3: 5\n", r"jerk_deg_s3 must be a list of 6"),
    ("jerk_deg_s3: [1, 2, x, 4, 5, 6]\n", r"jerk_deg_s3 of joint 'joint3' must be a number >= 1e-12 .*, got 'x'$"),
    ("jerk_deg_s3: [1, 2, 3, 4, 5, true]\n", r"jerk_deg_s3 of joint 'joint6' must be a number >= 1e-12 .*, got True$"),
    ("jerk_deg_s3: [1, 2, 3, 4, [5], 6]\n", r"of joint 'joint5' must be a number >= 1e-12 .*, got \[5\]$"),
    ("jerk_deg_s3: [1, 2, 3, 4, .nan, 6]\n", r"of joint 'joint5' must be a number >= 1e-12 .*, got nan$"),
    (f"jerk_deg_s3: [1, 2, 3, 4, {'9' * 400}, 6]\n", r"of joint 'joint5' must be a number >= 1e-12 .*, got 9+… \(400"),
    ("jerk_deg_s3: [1, 2, 3, 4, 0, 6]\n", r"of joint 'joint5' must be a number >= 1e-12 .*, got 0$"),
    ("acceleration_deg_s2: [1, 1, 1e-300, 1, 1, 1]\n", r"of joint 'joint3' must be a number >= 1e-12 .*, got 1e-300$"),
    ("acceleration_deg_s2: [1, 1, 1, 1, 1, 1.0e+300]\n", r"of joint 'joint6' must be .*<= 1e\+15, got 1e\+300$"),
    ("speed: [1]\n", r"unknown key 'speed'; expected acceleration_deg_s2 and jerk_deg_s3"),
    ("- 1\n", r"must map acceleration_deg_s2 and jerk_deg_s3 to lists, got list"),
    ("jerk_deg_s3: [1, 2\n", r"not valid YAML at line 2, column 1"),
    ("jerk_deg_s3: !!timestamp 2001-13-45\n", r"not valid YAML at line 1, column 14: .*month must be in 1..12"),
    ("jerk_deg_s3: [1:40, 1, 1, 1, 1, 1]\n", r"jerk_deg_s3.*got .1:40."),
    ("a: " + "[" * 5000 + "]" * 5000, r"nested deeper than 64 levels"),
    (b"jerk_deg_s3: [\xff]\n", r"not valid UTF-8 at byte 14"),
    ("jerk_deg_s3: [1, 2, 3, 4, 5, 6]\njerk_deg_s3: [1, 2, 3, 4, 5, 6]\n", r"duplicate key at line 2"),
])
def test_bad_limits_file_names_file_key_joint_and_value(tmp_path, text, message):
    urdf = arm_with_limits(tmp_path, text)
    with pytest.raises(RobotError, match=message) as caught:
        Robot.from_urdf(urdf, "tool")
    assert str(caught.value).startswith(f"limits file {tmp_path / 'arm.limits.yaml'}") and len(str(caught.value)) < 400


@pytest.mark.parametrize("kind", ["folder", "pipe", "broken link"])
def test_a_limits_file_that_is_no_file_is_refused(tmp_path, kind):
    """It was ignored without a word, and the task then lacked the limits it holds."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(PUMA.read_text())
    limits = tmp_path / "arm.limits.yaml"
    if kind == "folder":
        limits.mkdir()
    elif kind == "pipe":
        os.mkfifo(limits)
    else:
        limits.symlink_to(tmp_path / "missing.yaml")
    with pytest.raises(RobotFileError, match=r"limits file .*arm\.limits\.yaml is not a regular file"):
        Robot.from_urdf(urdf, "tool")


def test_limits_file_gives_one_value_per_urdf_joint_and_keeps_those_of_the_chain(tmp_path):
    urdf = arm_with_limits(tmp_path, "jerk_deg_s3: [1, 2, 3, 4, 5, 6]\n")
    robot = Robot.from_urdf(urdf, "link3")  # joints 1 to 3 move it
    assert robot.joint_names == ["joint1", "joint2", "joint3"]
    np.testing.assert_allclose(robot.limits.jerk, np.deg2rad([1, 2, 3]))


MALFORMED_URDFS = {
    "not xml": "not xml at all <<",
    "joint without limits": '<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
                            '<parent link="a"/><child link="b"/></joint></robot>',
    "no links": '<robot name="x"></robot>',
    "two roots": '<robot name="x"><link name="a"/><link name="b"/></robot>',
    "empty": "",
}


@pytest.mark.parametrize("name", MALFORMED_URDFS)
def test_malformed_urdf_is_one_line_and_stderr_stays_clean(tmp_path, capfd, name):
    urdf = tmp_path / "bad.urdf"
    urdf.write_text(MALFORMED_URDFS[name])
    with pytest.raises(RobotError, match=rf"^cannot load URDF {urdf}: ") as caught:
        Robot.from_urdf(urdf)
    captured = capfd.readouterr()
    assert captured.err == "" and captured.out == ""
    assert "\n" not in str(caught.value) and len(str(caught.value)) < 400
    print("still writes", file=sys.stderr)
    os.write(2, b"fd 2 restored\n")
    assert capfd.readouterr().err == "still writes\nfd 2 restored\n"


def test_urdf_parser_line_is_in_the_message(tmp_path):
    urdf = tmp_path / "bad.urdf"
    urdf.write_text(MALFORMED_URDFS["joint without limits"])
    with pytest.raises(RobotError, match=r"\(Joint \[j\] is of type REVOLUTE but it does not specify limits\)$"):
        Robot.from_urdf(urdf)


def chain_urdf(joints: list[tuple[str, str, str]], links=("base", "l1", "l2", "l3", "tool")) -> str:
    """A URDF of massless ``links`` joined by revolute joints (name, parent link, child link)."""
    body = "".join(f'<link name="{link}"/>' for link in links)
    body += "".join(f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                    f'<axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
                    for name, parent, child in joints)
    return f'<robot name="x">{body}</robot>'


CHAIN = [("j1", "base", "l1"), ("j2", "l1", "l2"), ("j3", "l2", "l3"), ("j4", "l3", "tool")]


@pytest.mark.parametrize(("joints", "message"), [
    # l1 .. tool in a loop through j1 (Pinocchio dropped them all: "no frame 'tool'")
    ([("j1", "tool", "l1"), *CHAIN[1:]], r"joints 'j2', 'j3', 'j4', 'j1' make links 'l2', 'l3', 'tool', 'l1' a "
                                         r"loop \(each the parent of the next\)"),
    ([*CHAIN[:2], ("j3", "l3", "l3"), CHAIN[3]], r"joint 'j3' makes link 'l3' its own parent"),
    # a second parent joint of l3 (Pinocchio: "Model does not have any body named l2")
    ([*CHAIN, ("extra", "l1", "l3")], r"link 'l3' is the child of two joints, 'j3' and 'extra'"),
])
def test_urdf_links_that_are_no_tree_are_named(tmp_path, joints, message):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(chain_urdf(joints))
    with pytest.raises(RobotFileError, match=rf"^cannot load URDF {urdf}: {message}; "):
        Robot.from_urdf(urdf, "tool")


def test_a_long_urdf_loop_is_named_by_its_first_links(tmp_path):
    links = [f"l{i}" for i in range(40)]
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(chain_urdf([(f"j{i}", links[i - 1], links[i]) for i in range(40)], links))  # j0: l39 -> l0
    with pytest.raises(RobotFileError, match=r"joints 'j1', 'j2', 'j3', 'j4', 'j5', 'j6', \.\.\. \(40 in all\) "
                                             r"make links 'l1', .*, 'l6', \.\.\. \(40 in all\) a loop"):
        Robot.from_urdf(urdf, "l5")
    urdf.write_text(chain_urdf([(f"j{i}", links[i - 1], links[i]) for i in range(1, 40)], links))  # the tree
    assert Robot.from_urdf(urdf, "l3").dof == 3


@pytest.mark.parametrize("path", ["/dev/zero", "/tmp", "missing.urdf"])
def test_urdf_must_be_a_regular_file(path):
    with pytest.raises(RobotError, match="not an existing regular file"):
        Robot.from_urdf(path)


PRISMATIC_ARM = """<robot name="slider">
  <link name="base"/><link name="carriage"/><link name="arm"/><link name="finger"/>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="carriage"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="1" velocity="1" effort="1"/></joint>
  <joint name="shoulder" type="revolute"><parent link="carriage"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
  <joint name="grip" type="prismatic"><parent link="carriage"/><child link="finger"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.1" velocity="1" effort="1"/></joint>
</robot>"""


def test_prismatic_joints_in_the_planned_chain_are_refused(tmp_path):
    urdf = tmp_path / "slider.urdf"
    urdf.write_text(PRISMATIC_ARM)
    with pytest.raises(UnsupportedRobotError, match=r"joint 'lift' of robot 'slider' is prismatic \(JointModelPZ\); "
                                                    r"only revolute joints are supported") as caught:
        Robot.from_urdf(urdf, "arm")
    assert caught.value.joint == "lift"
    with pytest.raises(RobotError, match=r"joint 'torso_lift_joint' of robot 'tiago_no_hand' is prismatic"):
        Robot.from_example_robot_data("tiago_no_hand", "arm_tool_link")


def test_continuous_joints_are_refused_in_urdf_terms_with_the_remedy():
    """Named by Pinocchio's class alone ("is a JointModelRUBZ"), with no remedy (sweep 16)."""
    with pytest.raises(RobotError, match=r"joint '.*' of robot 'double_pendulum_continuous' is continuous \(a revolute "
                                         r"joint without position limits, JointModelRUBX\); only revolute joints with "
                                         r"limits are supported: in the URDF, give it type=\"revolute\" and "
                                         r"<limit lower=... upper=...>$"):
        Robot.from_example_robot_data("double_pendulum_continuous")


def test_locked_prismatic_fingers_do_not_matter():
    robot = Robot.from_example_robot_data("panda", "panda_hand_tcp")
    assert robot.dof == 7 and robot.revolute.all()


@pytest.mark.parametrize("frame", [["tool"], {}, 3, None])
def test_tool_frame_must_be_a_string(frame):
    if frame is None:
        assert Robot.from_urdf(PUMA).tool_frame == "tool"
        return
    with pytest.raises(RobotError, match=r"robot 'puma560' has no frame"):
        Robot.from_urdf(PUMA, frame)


@pytest.mark.parametrize("name", [["ur5"], {}, 5, None])
def test_robot_name_must_be_a_string(name):
    with pytest.raises(RobotError, match=r"unknown robot"):
        Robot.from_example_robot_data(name)


def test_example_robot_this_pinocchio_cannot_load_is_a_robot_error(monkeypatch, capfd):
    from example_robot_data import robots_loader

    class Broken:
        def __init__(self):
            os.write(2, b"loader noise\n")
            raise ImportError("Building SDF models require pinocchio >= 3.0.0")

    monkeypatch.setitem(robots_loader.ROBOTS, "broken", Broken)
    with pytest.raises(RobotError, match=r"^robot 'broken' of example-robot-data cannot be loaded with Pinocchio "
                                         r"[\d.]+: ImportError: Building SDF models require pinocchio >= 3.0.0 "
                                         r"\(loader noise\); this Pinocchio build has no SDF support, which "
                                         r"its model needs$"):  # (cassie: the version it names is older)
        Robot.from_example_robot_data("broken")
    assert capfd.readouterr().err == ""

    class Missing:
        def __init__(self):
            raise ImportError("no module named meshcat")

    monkeypatch.setitem(robots_loader.ROBOTS, "missing", Missing)
    with pytest.raises(RobotError, match=r": ImportError: no module named meshcat$"):  # no SDF cause made up
        Robot.from_example_robot_data("missing")


MESH_ARM = """<robot name="meshy">
  <link name="base"/>
  <link name="arm"><visual><geometry><mesh filename="{mesh}"/></geometry></visual></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
</robot>"""


@pytest.mark.parametrize("mesh, what", [("/dev/zero", "not a regular file"), ("file:///dev/zero", "not a regular file"),
                                        ("meshes", "not a regular file"), ("link.stl", None),
                                        ("missing.stl", None), ("package://nowhere/arm.stl", None),
                                        ("dangling.stl", None)])
def test_urdf_meshes_must_be_regular_files(tmp_path, mesh, what):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "link.stl").write_bytes(b"solid x\nendsolid x\n")
    (tmp_path / "dangling.stl").symlink_to(tmp_path / "gone.stl")  # a link to nothing: not found
    urdf = tmp_path / "meshy.urdf"
    urdf.write_text(MESH_ARM.format(mesh=mesh))
    if what is None:  # a regular file, or one the viewer will not find either: named as missing
        robot = Robot.from_urdf(urdf, "arm")
        assert robot.dof == 1 and robot.missing_meshes == (() if mesh == "link.stl" else (mesh,))
    else:
        with pytest.raises(RobotError, match=rf"URDF .*meshy.urdf: link 'arm' mesh '{mesh}' is {what}"):
            Robot.from_urdf(urdf, "arm")


def test_a_missing_mesh_is_named_once_by_the_planner_and_rerun_stays_quiet(tmp_path):
    """Planned and recorded without it: the progress says which, summary.json lists it, and Rerun's
    importer prints nothing on stderr (it warned in a coloured log line of its own). The command runs in
    a process of its own, as a user runs it: Rerun reads its log setting once, when first imported, which in
    this test process an earlier test may have done without it."""
    import json
    import os
    import subprocess
    import sys

    import yaml

    urdf = tmp_path / "meshy.urdf"
    urdf.write_text(MESH_ARM.format(mesh="nothere.stl"))
    task = tmp_path / "task.yaml"
    task.write_text(yaml.safe_dump({"version": 1, "robot": {"urdf": str(urdf), "tool_frame": "arm"},
                                    "waypoints": {"joints_deg": [[0], [10]]},
                                    "limits": {"acceleration_deg_s2": [10], "jerk_deg_s3": [10]}}))
    environment = {key: value for key, value in os.environ.items() if key != "RUST_LOG"}
    done = subprocess.run([sys.executable, "-m", "planner.cli", "plan", str(task), "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, env=environment, timeout=600)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert "1 mesh the URDF names is not found (nothing is drawn for it): nothere.stl" in done.stdout
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["robot"]["missing_meshes"] == ["nothere.stl"]


ONE_JOINT = """<robot name="r"><link name="base"/><link name="l1"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="{lower}" upper="{upper}" effort="1" velocity="2"/></joint>
  <joint name="{fixed}" type="fixed"><parent link="l1"/><child link="tool"/><origin xyz="0.3 0 0"/></joint></robot>"""


@pytest.mark.parametrize("declaration", ["", '<?xml version="1.0" encoding="ISO-8859-1"?>\n'])
def test_a_urdf_that_is_not_utf8_is_named_with_its_byte_and_line(tmp_path, declaration):
    """A Latin-1 joint name (valid XML under its declaration): Pinocchio's names would not decode."""
    urdf = tmp_path / "r.urdf"
    urdf.write_bytes((declaration + ONE_JOINT.format(lower=-3, upper=3, fixed="tool")).encode("utf-8")
                     .replace(b'name="j1"', b'name="j\xe9"'))
    with pytest.raises(RobotFileError, match=rf"URDF .*r.urdf: byte 0xe9 on line {3 if declaration else 2} is not "
                                             r"UTF-8.*save it as UTF-8"):
        Robot.from_urdf(urdf, "tool")
    urdf.write_bytes(urdf.read_bytes().replace(b"\xe9", "\u00e9".encode("utf-8")))  # the same name in UTF-8
    assert "j\u00e9" in Robot.from_urdf(urdf, "tool").joint_names


@pytest.mark.parametrize("origin, what", [('<origin xyz="0.3 0 0"/>', None),
                                           ('<origin xyz="0 -2e6 0"/>', r"frame 'tool' .* placed 2e\+06 m"),
                                           ('<origin xyz="1e300 0 0"/>', r"frame 'tool' .* placed 1e\+300 m")])
def test_a_frame_placed_beyond_a_thousand_kilometres_is_refused(tmp_path, origin, what):
    """Far beyond, the forward kinematics and the recording's float32 geometry would overflow."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text(ONE_JOINT.format(lower=-3, upper=3, fixed="tool").replace('<origin xyz="0.3 0 0"/>', origin))
    if what is None:
        assert Robot.from_urdf(urdf, "tool").joint_names == ["j1"]
        return
    with pytest.raises(RobotFileError, match=what + r" along an axis from its parent \(<origin>\); at most 1e\+06"):
        Robot.from_urdf(urdf, "tool")


def test_a_tool_frame_named_in_another_unicode_form_is_found(tmp_path):
    """'café' with a composed é in the URDF, asked for as e + U+0301 (as macOS writes names): the same name."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text(ONE_JOINT.format(lower=-3, upper=3, fixed="tool").replace('"tool"', '"caf\u00e9"'),
                    encoding="utf-8")
    assert Robot.from_urdf(urdf, "cafe\u0301").tool_frame == "caf\u00e9"
    with pytest.raises(UnknownFrameError, match="has no frame 'cafe'"):
        Robot.from_urdf(urdf, "cafe")


def test_a_fixed_joint_named_as_its_link_and_a_one_joint_arm_plan(tmp_path):
    """A fixed joint named like its child link (common in URDFs): the tool frame is the link's. A one-joint
    arm reaches Cartesian waypoints (the binding gives its Jacobian as a vector)."""
    import pinocchio as pin

    from planner.ik import solve_pose
    urdf = tmp_path / "r.urdf"
    urdf.write_text(ONE_JOINT.format(lower=-3, upper=3, fixed="tool"))
    robot = Robot.from_urdf(urdf, "tool")
    assert robot.model.frames[robot.tool_frame_id].type == pin.FrameType.BODY
    assert robot.frame_jacobian(np.array([0.2])).shape == (6, 1)
    target = robot.forward_kinematics(np.array([0.5]))
    np.testing.assert_allclose(target.translation, [0.3 * np.cos(0.5), 0.3 * np.sin(0.5), 0.0], atol=1e-12)
    assert solve_pose(robot, target, np.array([0.0])).residual <= 1e-9


def test_urdf_limits_are_named_by_the_urdf_joint(tmp_path):
    urdf = tmp_path / "r.urdf"
    urdf.write_text(ONE_JOINT.format(lower=1, upper=-1, fixed="tf"))
    with pytest.raises(RobotError, match="joint j1 position range"):
        Robot.from_urdf(urdf, "tool")


@pytest.mark.parametrize("path", [None, 5])
def test_a_urdf_path_that_is_no_path_is_a_robot_error(path):
    with pytest.raises(RobotError, match="given by its path"):
        Robot.from_urdf(path)


def puma_edited(tmp_path, old: str, new: str) -> Path:
    """The bundled PUMA URDF (and its limits file) with the first ``old`` replaced by ``new``."""
    text = PUMA.read_text()
    assert old in text
    urdf = tmp_path / "edited.urdf"
    urdf.write_text(text.replace(old, new, 1))
    (tmp_path / "edited.limits.yaml").write_text(PUMA.with_suffix(".limits.yaml").read_text())
    return urdf


@pytest.mark.parametrize("attribute", ["velocity", "effort"])
def test_a_negative_urdf_limit_names_its_joint(tmp_path, attribute):
    first = 'velocity="1.745329252" effort="97.6"'
    edited = first.replace('"1.745329252"', '"-2"') if attribute == "velocity" else first.replace('"97.6"', '"-1"')
    with pytest.raises(RobotFileError, match=rf"joint 'joint1': <limit {attribute}> must be >= 0, got '-"):
        Robot.from_urdf(puma_edited(tmp_path, first, edited))


@pytest.mark.parametrize("mass", ["nan", "-5", "heavy", "inf"])
def test_a_link_mass_that_is_no_finite_non_negative_number_names_the_link(tmp_path, mass):
    """Pinocchio's parser logs an unreadable mass and leaves the link massless, and takes a negative one:
    the torques would be computed for another robot."""
    with pytest.raises(RobotFileError, match=rf"link 'link2': <mass value> must be a finite number >= 0, got '{mass}'"):
        Robot.from_urdf(puma_edited(tmp_path, '<mass value="17.4"/>', f'<mass value="{mass}"/>'))


def test_an_inertial_element_the_parser_skips_is_refused(tmp_path):
    with pytest.raises(RobotFileError, match=r"an element the URDF parser skipped \(.*"):
        Robot.from_urdf(puma_edited(tmp_path, 'ixx="0.13"', 'ixx="wide"'))


def test_a_joint_without_an_axis_is_refused_and_a_long_axis_is_a_direction(tmp_path):
    """Pinocchio takes <axis xyz="0 0 0"/> and turns a rotation into a scaling; a non-unit axis is normalized."""
    for axis in ("0 0 0", "0 0 1e300"):  # the second overflows when normalised (it was called the zero vector)
        with pytest.raises(RobotFileError, match=r"joint 'joint1' of robot 'puma560' .* has no axis to turn about: "
                                                 r"its <axis xyz> is the zero vector, or too long or too short"):
            Robot.from_urdf(puma_edited(tmp_path, '<axis xyz="0 0 1"/>', f'<axis xyz="{axis}"/>'))
    long_axis = Robot.from_urdf(puma_edited(tmp_path, '<axis xyz="0 0 1"/>', '<axis xyz="0 0 2"/>'))
    q = np.linspace(0.1, 0.6, 6)
    assert long_axis.forward_kinematics(q).isApprox(Robot.from_urdf(PUMA).forward_kinematics(q), 1e-12)


def test_a_joint_without_a_name_is_refused_by_its_links(tmp_path):
    """``<joint name="">`` showed a Pinocchio vector object in the message (sweep 26)."""
    with pytest.raises(RobotFileError, match=r"^robot 'puma560' \(.*\): the <joint> from link 'link2' to link "
                                             r"'link3' has an empty name; give every joint a name of its own$"):
        Robot.from_urdf(puma_edited(tmp_path, '<joint name="joint3"', '<joint name=" "'))


def test_a_urdf_declaring_xml_entities_is_refused(tmp_path):
    """``<!ENTITY j "jointA">`` and ``name="&j;"``: the planner's XML checks read jointA, Pinocchio the literal
    "&j;", which then named the joint in the outputs (sweep 26)."""
    urdf = puma_edited(tmp_path, '<joint name="joint3"', '<joint name="&j;"')
    urdf.write_text(urdf.read_text().replace("<robot ", '<!DOCTYPE robot [<!ENTITY j "joint3">]>\n<robot ', 1))
    with pytest.raises(RobotFileError, match=r"declares XML entities \(<!ENTITY \.\.\.>\), which Pinocchio's URDF "
                                             r"parser does not expand"):
        Robot.from_urdf(urdf)


def test_a_mimic_joint_in_the_chain_is_refused(tmp_path):
    """Pinocchio ignores <mimic> by default: the joint would be planned as if it moved freely."""
    last = 'velocity="1.919862177" effort="21.3"/>'
    urdf = puma_edited(tmp_path, last, last + '\n    <mimic joint="joint5" multiplier="1" offset="0"/>')
    with pytest.raises(UnsupportedRobotError, match=r"joint 'joint6' of robot 'puma560' copies another") as caught:
        Robot.from_urdf(urdf)
    assert caught.value.joint == "joint6"
    assert Robot.from_urdf(urdf, "link5").dof == 5  # a chain without it plans


@pytest.mark.parametrize("q, message", [([np.nan] * 6, r"joint positions\[0\] is nan"),
                                        ([True] * 6, "joint positions must be numeric")])
def test_kinematics_refuse_positions_that_are_not_finite_numbers(q, message):
    robot = Robot.from_example_robot_data("ur5", "tool0")
    for call in (robot.forward_kinematics, robot.frame_jacobian):
        with pytest.raises(InputError, match=message):
            call(q)


@pytest.mark.parametrize("name, tool", [("ur5", "tool0"), ("ur5", "wrist_3_joint"), ("panda", "panda_hand_tcp")])
def test_batched_tool_placements_and_jacobians_are_the_pointwise_ones(name, tool):
    """``tool_placements`` and ``frame_jacobians`` over rows of positions equal ``forward_kinematics`` and
    ``frame_jacobian`` row by row, and Pinocchio's own of the named frame (a joint's frame too, whose
    placement differs from the frame before it); an empty batch is empty; a row of NaN, rows of the wrong
    length or a single row not given as one are refused naming what is wrong."""
    robot = Robot.from_example_robot_data(name, tool)
    q = np.random.default_rng(8).uniform(-2.0, 2.0, (5, robot.dof))
    positions, rotations = robot.tool_placements(q)
    jacobians = robot.frame_jacobians(q)
    model, data = robot.model, robot.model.createData()
    frame = model.getFrameId(tool)
    for k, row in enumerate(q):
        pose = robot.forward_kinematics(row)
        np.testing.assert_array_equal(positions[k], pose.translation)
        np.testing.assert_array_equal(rotations[k], pose.rotation)
        np.testing.assert_array_equal(jacobians[k], robot.frame_jacobian(row))
        pin.framesForwardKinematics(model, data, row)
        np.testing.assert_allclose(positions[k], data.oMf[frame].translation, rtol=0, atol=1e-12)
        np.testing.assert_allclose(jacobians[k], pin.computeFrameJacobian(model, data, row, frame,
                                                                           pin.ReferenceFrame.LOCAL), atol=1e-12)
    for call in (robot.tool_placements, robot.frame_jacobians):
        with pytest.raises(InputError, match="must have 2 dimension"):
            call(q[0])
    assert robot.tool_placements(q[:0])[0].shape == (0, 3) and robot.frame_jacobians(q[:0]).shape == (0, 6, robot.dof)
    bad = q.copy()
    bad[3, 1] = np.nan
    for call in (robot.tool_placements, robot.frame_jacobians):
        with pytest.raises(InputError, match=r"joint positions\[3, 1\] is nan"):
            call(bad)
        with pytest.raises(InputError, match=f"rows of {robot.dof} values.*got shape \\(5, {robot.dof - 1}\\)"):
            call(q[:, 1:])


def test_joints_off_the_chain_are_held_inside_their_ranges():
    """The Allegro thumb's range [0.263, 1.396] rad excludes the neutral 0: planning the index finger holds
    it at its lower bound (Rerun clamped it there with a warning on stderr, the model held it at 0)."""
    robot = Robot.from_example_robot_data("allegro_right_hand", "link_3.0_tip")
    full = pin.buildModelFromUrdf(str(robot.urdf_path))
    assert set(robot.locked_positions) == {name for name in full.names[1:] if name not in robot.joint_names}
    for name, value in robot.locked_positions.items():
        i = full.joints[full.getJointId(name)].idx_q
        assert full.lowerPositionLimit[i] <= value <= full.upperPositionLimit[i]
        assert value == np.clip(0.0, full.lowerPositionLimit[i], full.upperPositionLimit[i])
    assert robot.locked_positions["joint_12.0"] == pytest.approx(0.263)


@pytest.mark.parametrize("package_dirs", [None, 3, [3], [None]])
def test_package_dirs_that_are_no_folders_are_named(package_dirs):
    with pytest.raises(InputError, match="package_dirs must be a folder or a list of folders"):
        Robot.from_urdf(ROOT / "robots" / "puma560.urdf", None, package_dirs=package_dirs)


def test_one_package_folder_may_be_given_alone():
    robot = Robot.from_urdf(ROOT / "robots" / "puma560.urdf", None, package_dirs=str(ROOT / "robots"))
    assert robot.package_dirs == (str(ROOT / "robots"),)


def test_a_limits_file_gives_the_planned_joints_or_every_joint_of_the_urdf(tmp_path):
    """A gripper's fingers are locked, so a limits file may leave them out; one with a value per joint of
    the URDF (fingers too) still reads. It had to list the fingers, in deg/s^2 (sweep 16)."""
    fingers = "".join(f'<link name="finger{k}"/><joint name="finger{k}" type="prismatic"><parent link="tool"/>'
                      f'<child link="finger{k}"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" velocity="0.1" '
                      f'effort="20"/></joint>' for k in (1, 2))
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(PUMA.read_text().replace("</robot>", fingers + "</robot>"))
    limits = tmp_path / "arm.limits.yaml"
    planned = [10, 20, 30, 40, 50, 60]
    for values in (planned, planned + [1, 2]):
        limits.write_text(f"acceleration_deg_s2: {values}\njerk_deg_s3: {[3 * v for v in values]}\n")
        robot = Robot.from_urdf(urdf, "tool")
        np.testing.assert_allclose(np.rad2deg(robot.limits.acceleration), planned)
        np.testing.assert_allclose(np.rad2deg(robot.limits.jerk), [3 * v for v in planned])
    limits.write_text("acceleration_deg_s2: [10, 20, 30]\n")
    with pytest.raises(RobotFileError, match=r"acceleration_deg_s2 must be a list of 6 positive numbers, one per joint "
                                             r"\(joint1, .*, joint6\), or 8, one per joint of the URDF \(joint1, .*, "
                                             r"finger2\), got \[10, 20, 30\]$"):
        Robot.from_urdf(urdf, "tool")


@pytest.mark.parametrize("text, remedy", [
    (MESH_ARM.format(mesh="link.stl") + "<extra/>\n", "fix the file"),
    (MESH_ARM.format(mesh="link.stl").replace('<robot name="meshy">', '<robot name="meshy">\n  <xacro:property '
                                                                      'name="l" value="1"/>'),
     r"expand the xacro macros first \(xacro FILE > ROBOT\.urdf\)")])
def test_a_urdf_that_is_not_well_formed_xml_is_refused(tmp_path, text, remedy):
    """Pinocchio's parser takes text after </robot>, but the planner's checks (mimic joints, limits, masses,
    meshes) read the file as XML and were silently skipped: a mimic joint was planned as a free one
    (sweep 19). Such a file is refused, naming the XML error and where."""
    urdf = tmp_path / "meshy.urdf"
    urdf.write_text(text)
    with pytest.raises(RobotFileError, match=rf"meshy\.urdf: not well-formed XML \(.*: line \d+, column \d+\); the "
                                             rf"planner's checks .* read it as XML: {remedy}$"):
        Robot.from_urdf(urdf, "arm")


def test_the_urdf_drawn_names_only_the_meshes_checked(tmp_path, monkeypatch):
    """Rerun's importer resolved a package:// mesh that no package root holds against the current folder
    (and opened a pipe there, hanging the save; sweep 19). The URDF it is handed names each mesh found by
    its absolute path and leaves out a visual whose mesh is not found."""
    import xml.etree.ElementTree as ElementTree

    from planner.robot import drawable_urdf
    (tmp_path / "link.stl").write_bytes(b"solid x\nendsolid x\n")
    urdf = tmp_path / "meshy.urdf"
    urdf.write_text(MESH_ARM.format(mesh="link.stl").replace(
        '<link name="base"/>', '<link name="base"><visual><geometry><mesh filename="package://pkg/m.stl"/>'
                               '</geometry></visual></link>'))
    (tmp_path / "cwd" / "pkg").mkdir(parents=True)
    monkeypatch.chdir(tmp_path / "cwd")
    robot = Robot.from_urdf(urdf, "arm")
    assert robot.missing_meshes == ("package://pkg/m.stl",)
    root = ElementTree.fromstring(drawable_urdf(urdf, robot.package_dirs))
    assert [m.get("filename") for m in root.iter("mesh")] == [str((tmp_path / "link.stl").resolve())]
    assert root.find("link[@name='base']").find("visual") is None


def test_a_joint_name_with_a_control_character_is_refused(tmp_path):
    """A character reference such as "&#10;" keeps a line break in a URDF name: the planner wrote it into
    CSV headers and recordings (which replay refuses); it is refused at load."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(chain_urdf([("j1", "base", "l1"), ("j&#10;2", "l1", "l2"), ("j3", "l2", "l3"),
                                ("j4", "l3", "tool")]))
    with pytest.raises(RobotFileError, match=r"joint 'j\\n2' of robot 'x' \(.*arm\.urdf\) has a control character in "
                                             r"its name \(a line break, say\): rename it$"):
        Robot.from_urdf(urdf, "tool")
    assert Robot.from_urdf(urdf, "l1").joint_names == ["j1"]  # off the planned chain: no matter


@pytest.mark.parametrize("velocity, shown", [("1e-300", "5.72958e-299"), ("1e300", "5.72958e+301")])
def test_a_urdf_velocity_beyond_the_planners_range_is_named_with_the_joint(velocity, shown, tmp_path):
    """A URDF velocity of 1e-300 rad/s was refused only through the trajectory's length it implied (8.7e299 s,
    'raise the limits'), naming neither the URDF, the joint nor the velocity (sweep 22)."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text(ONE_JOINT.format(lower=-3, upper=3, fixed="tool").replace('velocity="2"', f'velocity="{velocity}"'))
    said = re.escape(f"): joint 'j1' has a velocity limit of {shown} deg/s; the planner takes 1e-12 to 1e+15 deg/s: "
                     f"correct its <limit velocity=...> in the URDF")
    with pytest.raises(RobotFileError, match=rf"robot 'r' \(.*r\.urdf{said}"):
        Robot.from_urdf(urdf, "tool")


def test_a_default_tool_frame_no_joint_moves_says_it_was_a_default(tmp_path):
    """Without robot.tool_frame the model's last frame is taken; where no joint moves it the error named a
    frame the user never gave (tiago's 'rgbd_laser_link', sweep 22)."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text(ONE_JOINT.format(lower=-3, upper=3, fixed="tool").replace(
        "</robot>", '<link name="stand"/><joint name="s" type="fixed"><parent link="base"/><child link="stand"/>'
                    '</joint></robot>'))
    with pytest.raises(UnsupportedRobotError, match=r"frame 'stand' of robot 'r' is not moved by any joint \(no "
                                                    r"robot\.tool_frame was given: the model's last frame was taken\); "
                                                    r"give robot\.tool_frame"):
        Robot.from_urdf(urdf, None)
    with pytest.raises(UnsupportedRobotError, match=r"frame 'stand' of robot 'r' is not moved by any joint$"):
        Robot.from_urdf(urdf, "stand")
