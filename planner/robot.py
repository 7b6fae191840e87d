"""Robot: a Pinocchio model reduced to the joints that move a tool frame, with its limits.

A robot comes from a URDF file (with an optional ``<name>.limits.yaml`` beside
it giving acceleration and jerk limits in degrees) or from example-robot-data
by name. Joints that do not move the tool frame (a gripper's fingers, say)
are locked at their neutral position (moved into their range where it lies
outside) with ``pinocchio.buildReducedModel``, so the planned joints are
exactly those of the tool frame's kinematic chain, which must all be
single-axis revolute joints (task values are in degrees).
"""

from __future__ import annotations

import hashlib
import math
import os
import stat
import unicodedata
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pinocchio as pin

from .errors import (
    InputError,
    RobotFileError,
    TaskError,
    UnknownFrameError,
    UnknownRobotError,
    UnsupportedRobotError,
    shown,
)
from .limits import LIMIT_DEG_RANGE, LIMITED, JointLimits
from .native_output import stderr_captured
from .validate import CONTROL_CHARACTERS, finite_array, float_array, positive_finite
from .yaml_input import read_yaml

#: Largest URDF file loaded [bytes]: the parser reads about 1 MB/s of XML.
MAX_URDF_BYTES = 16 * 2**20
#: Largest mesh file a URDF may name [bytes]: a detailed industrial-arm link is a few MB.
MAX_MESH_BYTES = 256 * 2**20
#: A joint or frame is placed at most this far from its parent [m] (a robot a thousand kilometres long is a
#: typing error; far beyond it, 1e300, the forward kinematics and the recording's float32 geometry overflow).
MAX_PLACEMENT_M = 1e6
_LIMIT_FILE_KEYS = {q.key: q.name for q in LIMITED[1:]}  # acceleration and jerk (URDFs give velocity)
#: Pinocchio's single-axis revolute joints, the only ones planned (task keys are in degrees).
_REVOLUTE = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")
#: Pinocchio's prismatic joints, named as such when refused.
_PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")
#: Pinocchio's revolute joints without bounds (a URDF ``continuous`` joint), named as such when refused.
_CONTINUOUS = ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ", "JointModelRevoluteUnboundedUnaligned")


@dataclass
class Robot:
    """A serial chain to plan for.

    Attributes:
        name: robot name.
        model, data: the reduced Pinocchio model (single-axis revolute joints only).
        tool_frame: name of the frame whose pose waypoints give; ``tool_frame_id`` its index.
        limits: ``JointLimits`` in SI units (position and velocity from the URDF,
            acceleration and jerk from the limits file where there is one).
        urdf_path: the URDF file, for visualisation.
        package_dirs: folders that resolve the URDF's ``package://`` meshes.
        placeholder_velocity: joints whose URDF velocity limit is 0, which exporters write as a
            placeholder: their ``limits.velocity`` is absent (+inf) and a task must give one.
        placeholder_range: joints whose URDF range is [0, 0], the same placeholder: their position
            range is absent and a task must give one (``limits.position_deg``).
        missing_meshes: meshes the URDF names that are not found (as named): nothing is drawn for them.
        locked_positions: where the joints that do not move the tool are held [rad or m], by name
            (one-coordinate joints; ``_locked_configuration``).
        urdf_digest: ``file_digest`` of the URDF as it was loaded: the recording reads the file again
            and refuses one that has changed since.
    """

    name: str
    model: pin.Model
    data: pin.Data
    tool_frame: str
    tool_frame_id: int
    limits: JointLimits
    urdf_path: Path
    package_dirs: tuple[Path, ...] = ()
    placeholder_velocity: tuple[str, ...] = ()
    placeholder_range: tuple[str, ...] = ()
    missing_meshes: tuple[str, ...] = ()
    locked_positions: dict[str, float] = field(default_factory=dict)
    urdf_digest: str = ""

    @property
    def joint_names(self) -> list[str]:
        """The planned joints' names, in configuration order."""
        return [self.model.names[i] for i in range(1, self.model.njoints)]

    @property
    def dof(self) -> int:
        """Degrees of freedom: the number of planned joints."""
        return self.model.nq

    @cached_property
    def revolute(self) -> np.ndarray:
        """(nq,) whether each joint is revolute (angles that may be shifted by 2 pi)."""
        return np.array([self.model.joints[j].shortname() in _REVOLUTE for j in range(1, self.model.njoints)])

    def forward_kinematics(self, q) -> pin.SE3:
        """Pose of the tool frame in the world for joint positions ``q`` [rad]."""
        pin.forwardKinematics(self.model, self.data, self._configuration(q))
        return pin.updateFramePlacement(self.model, self.data, self.tool_frame_id).copy()

    def frame_jacobian(self, q) -> np.ndarray:
        """(6, nv) Jacobian of the tool frame in its LOCAL frame (linear first)."""
        jacobian = pin.computeFrameJacobian(self.model, self.data, self._configuration(q), self.tool_frame_id,
                                            pin.ReferenceFrame.LOCAL)
        return np.reshape(jacobian, (6, self.model.nv))  # one joint: the binding returns a (6,) vector

    def tool_placements(self, q) -> tuple[np.ndarray, np.ndarray]:
        """(K, 3) positions [m] and (K, 3, 3) rotations of the tool frame in the world for (K, nq) joint
        positions [rad]: ``forward_kinematics`` point by point, the array checked once."""
        q = self._configurations(q)
        positions, rotations = np.zeros((len(q), 3)), np.zeros((len(q), 3, 3))
        for k, configuration in enumerate(q):
            pin.forwardKinematics(self.model, self.data, configuration)
            placement = pin.updateFramePlacement(self.model, self.data, self.tool_frame_id)
            positions[k], rotations[k] = placement.translation, placement.rotation
        return positions, rotations

    def frame_jacobians(self, q) -> np.ndarray:
        """(K, 6, nv) ``frame_jacobian`` at each of (K, nq) joint positions [rad], the array checked once."""
        q = self._configurations(q)
        return np.array([pin.computeFrameJacobian(self.model, self.data, configuration, self.tool_frame_id,
                                                  pin.ReferenceFrame.LOCAL) for configuration in q]).reshape(
            len(q), 6, self.model.nv)

    def _configurations(self, q) -> np.ndarray:
        """(K, nq) ``q`` as float rows of the model's nq values.

        Raises:
            InputError: as ``_configuration``, for the array as a whole.
        """
        q = finite_array("joint positions", q, 2)
        if q.shape[1] != self.model.nq:
            raise InputError(f"joint positions must be rows of {self.model.nq} values for robot {self.name!r}, "
                             f"got shape {q.shape}")
        return q

    def _configuration(self, q) -> np.ndarray:
        """``q`` as a float array of the model's nq values (Pinocchio's own error is a multi-line C++ one).

        Raises:
            InputError: not numbers, another count of values, or one that is not finite.
        """
        q = float_array("joint positions", q)
        if q.shape != (self.model.nq,):
            raise InputError(f"joint positions must be {self.model.nq} values for robot {self.name!r}, got shape "
                             f"{q.shape}")
        return finite_array("joint positions", q, 1)

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_urdf(cls, path, tool_frame: str | None = None, package_dirs=()) -> "Robot":
        """Load a URDF; ``tool_frame`` defaults to the last frame of the model.

        The URDF parser's own log lines are kept off stderr; the first of them goes into the error.
        """
        if not isinstance(path, (str, os.PathLike)):
            raise RobotFileError(f"a URDF is given by its path (text or path-like), not {type(path).__name__}",
                                 path=None)
        try:
            folders = [package_dirs] if isinstance(package_dirs, (str, os.PathLike)) else list(package_dirs)
        except TypeError:  # no list at all: refused below with it
            folders = [package_dirs]
        if not all(isinstance(d, (str, os.PathLike)) for d in folders):
            raise InputError(f"package_dirs must be a folder or a list of folders (text or path-like), got "
                             f"{shown(package_dirs)}")
        path = Path(path)
        if not path.is_file():  # a device such as /dev/zero would be read without end
            raise RobotFileError(f"cannot load URDF {path}: not an existing regular file", path=path)
        if path.stat().st_size > MAX_URDF_BYTES:
            raise RobotFileError(f"cannot load URDF {path}: larger than {MAX_URDF_BYTES >> 20} MiB "
                                 f"(a robot description, its meshes apart, is well under 1 MiB)", path=path)
        _check_utf8(path)
        root = _well_formed_root(path)
        _check_tree(root, path)
        with stderr_captured() as parser_log:
            failure: Exception | None
            try:
                model = pin.buildModelFromUrdf(str(path))
            except Exception as exc:  # the parser raises RuntimeError, ValueError, OSError, ...
                failure = exc
            else:
                failure = None
        if failure is not None:
            problem = _negative_limit(root) or f"{_first_line(str(failure))}{_detail(parser_log)}"
            raise RobotFileError(f"cannot load URDF {path}: {problem}", path=path) from None
        swallowed = "Could not parse" in "".join(parser_log)  # the parser logs a bad <inertial> and goes on
        problem = _bad_mass(root) or (f"an element the URDF parser skipped{_detail(parser_log)}" if swallowed else "")
        if problem:
            raise RobotFileError(f"cannot load URDF {path}: {problem}", path=path)
        name = model.name or path.stem
        _check_joint_names(root, path, name)
        extra = _read_limit_file(path.with_suffix(".limits.yaml"))
        return cls._build(name, model, tool_frame, path, tuple(folders), extra)

    @classmethod
    def from_example_robot_data(cls, name: str, tool_frame: str | None = None) -> "Robot":
        """An example-robot-data robot by name (``ur5``, ``panda``, ...)."""
        from example_robot_data.robots_loader import ROBOTS
        if not isinstance(name, str) or name not in ROBOTS:
            raise UnknownRobotError(f"unknown robot {shown(name)}; example-robot-data has: {', '.join(sorted(ROBOTS))}",
                                    name=name, known=tuple(sorted(ROBOTS)))
        with stderr_captured() as loader_log:
            failure: Exception | None
            try:
                loader = ROBOTS[name]()
                model = loader.robot.model
            except Exception as exc:  # a model this Pinocchio cannot build, missing files, ...
                failure = exc
            else:
                failure = None
        if failure is not None:
            text = _first_line(str(failure))
            # example-robot-data words a Pinocchio built without SDF as "require pinocchio >= 3.0.0"
            cause = "; this Pinocchio build has no SDF support, which its model needs" if "SDF" in text else ""
            raise RobotFileError(f"robot {name!r} of example-robot-data cannot be loaded with Pinocchio "
                                 f"{pin.__version__}: {type(failure).__name__}: {text}{_detail(loader_log)}"
                                 f"{cause}") from None
        if model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer":
            raise UnsupportedRobotError(f"robot {name!r} has a floating base; only fixed-base arms can be planned")
        package_dirs = tuple(Path(d) for d in (loader.model_path, Path(loader.model_path).parent))
        return cls._build(name, model, tool_frame, Path(loader.df_path), package_dirs, {})

    @classmethod
    def _build(cls, name, model, tool_frame, urdf_path, package_dirs, extra_limits) -> "Robot":
        frame_names = [f.name for f in model.frames]
        defaulted = tool_frame is None
        if tool_frame is None:
            tool_frame = frame_names[-1]
        if isinstance(tool_frame, str) and not model.existFrame(tool_frame):  # the same name in another Unicode
            same = [f for f in frame_names if _nfc(f) == _nfc(tool_frame)]  # form (macOS writes e + U+0301 for é)
            tool_frame = same[0] if len(set(same)) == 1 else tool_frame
        if not isinstance(tool_frame, str) or not model.existFrame(tool_frame):
            raise UnknownFrameError(f"robot {shown(name)} has no frame {shown(tool_frame)}; frames: "
                                    f"{', '.join(frame_names)}", frame=tool_frame, frames=tuple(frame_names))
        parent = model.frames[_frame_id(model, tool_frame)].parentJoint
        chain = set(model.supports[parent])
        locked = [j for j in range(1, model.njoints) if j not in chain]
        reference = _locked_configuration(model)
        try:
            reduced = pin.buildReducedModel(model, locked, reference) if locked else model
        except ValueError as exc:  # names Pinocchio cannot tell apart, a link with two parent joints
            raise RobotFileError(f"cannot build the chain of robot {shown(name)} to frame {shown(tool_frame)}: "
                                 f"{_first_line(str(exc))}", path=Path(urdf_path)) from None
        for j in range(1, reduced.njoints):
            if CONTROL_CHARACTERS.search(reduced.names[j]):  # a "&#10;" in the URDF: it would break CSV headers
                raise RobotFileError(f"joint {reduced.names[j]!r} of robot {shown(name)} ({urdf_path}) has a control "
                                     f"character in its name (a line break, say): rename it", path=Path(urdf_path))
            kind = reduced.joints[j].shortname()
            if kind in _PRISMATIC:
                raise UnsupportedRobotError(f"joint {reduced.names[j]!r} of robot {shown(name)} is prismatic ({kind}); "
                                            f"only revolute joints are supported (task values are in degrees)",
                                            joint=reduced.names[j])
            if kind in _CONTINUOUS:
                raise UnsupportedRobotError(f"joint {reduced.names[j]!r} of robot {shown(name)} is continuous (a "
                                            f"revolute joint without position limits, {kind}); only revolute joints "
                                            f"with limits are supported: in the URDF, give it type=\"revolute\" and "
                                            f"<limit lower=... upper=...>", joint=reduced.names[j])
            if kind not in _REVOLUTE:
                raise UnsupportedRobotError(f"joint {reduced.names[j]!r} of robot {shown(name)} is a {kind}; only "
                                            f"revolute joints with one axis and position limits are supported",
                                            joint=reduced.names[j])
            if kind == "JointModelRevoluteUnaligned" and not np.linalg.norm(reduced.joints[j].extract().axis) > 0:
                raise RobotFileError(f"joint {reduced.names[j]!r} of robot {shown(name)} ({urdf_path}) has no axis "
                                     f"to turn about: its <axis xyz> is the zero vector, or too long or too short to "
                                     f"make a unit vector of in floating point (give one such as 0 0 1)",
                                     path=Path(urdf_path))
        mimics = [joint for joint in _mimic_joints(Path(urdf_path)) if joint in reduced.names[1:]]
        if mimics:
            raise UnsupportedRobotError(f"joint {mimics[0]!r} of robot {shown(name)} copies another joint (URDF "
                                        f"<mimic>); coupled joints are not supported: choose a tool frame whose "
                                        f"chain has none", joint=mimics[0])
        if reduced.nq == 0:
            raise UnsupportedRobotError(f"frame {tool_frame!r} of robot {shown(name)} is not moved by any joint"
                                        + (" (no robot.tool_frame was given: the model's last frame was taken); "
                                           "give robot.tool_frame, a frame at the end of the arm" if defaulted else ""))
        _check_placements(reduced, name, Path(urdf_path))
        extra_limits = _file_limits(Path(urdf_path).with_suffix(".limits.yaml"), extra_limits,
                                    list(reduced.names[1:]), list(model.names[1:]))
        velocity = np.where(reduced.velocityLimit > 0, reduced.velocityLimit, np.inf)
        _check_urdf_velocities(np.rad2deg(velocity), reduced, name, Path(urdf_path))
        # <limit lower="0" upper="0" velocity="0"/>: an exporter's placeholder, not a joint that cannot move
        unset = (reduced.lowerPositionLimit == 0) & (reduced.upperPositionLimit == 0)
        lower = np.where(np.isfinite(reduced.lowerPositionLimit) & ~unset, reduced.lowerPositionLimit, -np.inf)
        upper = np.where(np.isfinite(reduced.upperPositionLimit) & ~unset, reduced.upperPositionLimit, np.inf)
        try:
            limits = JointLimits.create(reduced.nq, lower=lower, upper=upper, velocity=velocity,
                                        names=reduced.names[1:], **extra_limits)
        except InputError as exc:  # an empty range, a negative limit: the robot's files are at fault
            raise RobotFileError(f"robot {shown(name)} ({urdf_path}): {exc}", path=Path(urdf_path)) from None
        placeholder = tuple(reduced.names[int(j) + 1] for j in np.flatnonzero(reduced.velocityLimit == 0))
        unset_range = tuple(reduced.names[int(j) + 1] for j in np.flatnonzero(unset))
        missing = check_meshes(Path(urdf_path), package_dirs)
        held = {model.names[j]: float(reference[model.joints[j].idx_q]) for j in locked if model.joints[j].nq == 1}
        return cls(name, reduced, reduced.createData(), tool_frame, _frame_id(reduced, tool_frame), limits,
                   Path(urdf_path), package_dirs, placeholder, unset_range, missing, held, file_digest(Path(urdf_path)))


def _check_urdf_velocities(velocity: np.ndarray, model: pin.Model, name: str, path: Path) -> None:
    """Refuse a URDF velocity limit (per joint of ``model`` [deg/s]; inf where the URDF gives none) outside the
    range a task file's own velocity limit must be in (``LIMIT_DEG_RANGE``): a velocity of 1e-300 rad/s was
    named by none of the URDF, the joint or the velocity, only by the trajectory's length it implied.

    Raises:
        RobotFileError: naming the robot, the URDF, the joint, the value and the range.
    """
    low, high = LIMIT_DEG_RANGE
    bad = np.flatnonzero(np.isfinite(velocity) & ((velocity < low) | (velocity > high)))
    if bad.size:
        j = int(bad[0])
        raise RobotFileError(f"robot {shown(name)} ({path}): joint {model.names[j + 1]!r} has a velocity limit of "
                             f"{velocity[j]:.6g} deg/s; the planner takes {low:g} to {high:g} deg/s: correct "
                             f"its <limit velocity=...> in the URDF", path=path)


def file_digest(path: Path) -> str:
    """The SHA-256 of a file's bytes, in hex (OSError where it cannot be read)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _nfc(name: str) -> str:
    """``name`` in Unicode normal form C (composed characters)."""
    return unicodedata.normalize("NFC", name)


def _check_placements(model: pin.Model, name: str, urdf_path: Path) -> None:
    """Refuse a joint or frame of ``model`` placed at a non-finite pose or with a coordinate beyond
    ``MAX_PLACEMENT_M`` from its parent.

    Raises:
        RobotFileError: naming the joint or frame and the coordinate.
    """
    placed = [(f"joint {model.names[j]!r}", model.jointPlacements[j]) for j in range(1, model.njoints)]
    placed += [(f"frame {frame.name!r}", frame.placement) for frame in model.frames]
    for what, placement in placed:
        farthest = float(np.max(np.abs(placement.translation)))
        if not (farthest <= MAX_PLACEMENT_M and np.all(np.isfinite(placement.rotation))):
            raise RobotFileError(f"{what} of robot {shown(name)} ({urdf_path}) is placed {farthest:.3g} m along an "
                                 f"axis from its parent (<origin>); at most {MAX_PLACEMENT_M:.0e} m is taken",
                                 path=urdf_path)


def _locked_configuration(model: pin.Model) -> np.ndarray:
    """Where the joints that do not move the tool are held: Pinocchio's neutral configuration (0 for a
    one-coordinate joint), moved into each such joint's range where 0 is outside it (a thumb's
    [0.263, 1.396] rad), so the locked bodies sit where the robot can be."""
    reference = pin.neutral(model)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nq == 1:
            i = joint.idx_q
            reference[i] = np.clip(reference[i], model.lowerPositionLimit[i], model.upperPositionLimit[i])
    return reference


def _frame_id(model: pin.Model, name: str) -> int:
    """The index of frame ``name``; where a joint and a link share it (a fixed joint named as its
    child link, common in URDFs), the link's (body) frame."""
    found = [i for i, frame in enumerate(model.frames) if frame.name == name]
    bodies = [i for i in found if model.frames[i].type == pin.FrameType.BODY]
    return (bodies or found)[0]


def package_roots(package_dirs) -> list[Path]:
    """The one rule for ``package://NAME/...``: the folders whose subfolder NAME is package NAME, in
    order: each of ``package_dirs`` (a folder of packages) and its parent (the folder is itself a
    package, named as it is), then the ``ROS_PACKAGE_PATH`` entries. The mesh check (``_mesh_file``)
    searches them, and the recording hands them to Rerun's URDF importer as ``ROS_PACKAGE_PATH``."""
    given = [Path(d) for d in package_dirs]
    roots = [folder for d in given for folder in (d, d.resolve().parent)]
    roots += [Path(d) for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if d]
    return list(dict.fromkeys(roots))


def _mesh_file(filename: str, urdf_path: Path, package_dirs) -> Path | None:
    """The file a URDF ``<mesh filename>`` names, resolved as the recording's importer does
    (``package://NAME/...`` under ``package_roots``, ``file://``, or relative to the URDF's folder),
    or None where it is not found."""
    if filename.startswith("package://"):
        package, _, rest = filename.removeprefix("package://").partition("/")
        candidates = [root / package / rest for root in package_roots(package_dirs)]
        return next((c for c in candidates if os.path.lexists(c)), None)
    path = Path(filename.removeprefix("file://"))
    return path if path.is_absolute() else urdf_path.parent / path


def urdf_elements(urdf_path: Path, tag: str) -> list:
    """The ``<tag>`` elements directly under the URDF's ``<robot>`` (ElementTree elements); [] where
    the file cannot be read (``_urdf_root``)."""
    return _urdf_root(urdf_path).findall(tag)


def _urdf_root(urdf_path: Path):
    """The URDF's root element (ElementTree); an empty ``<robot>`` where the file cannot be read (a URDF
    given by path is refused before unless well-formed: ``_well_formed_root``)."""
    import xml.etree.ElementTree as ElementTree

    try:
        return ElementTree.parse(urdf_path).getroot()
    except (OSError, ElementTree.ParseError):
        return ElementTree.Element("robot")


def _well_formed_root(path: Path):
    """The URDF's root element (ElementTree), which the checks at load read; a URDF that is not
    well-formed XML (text after ``</robot>``, say) is refused: Pinocchio's and Rerun's parsers accept
    some such files, but the planner's own checks (mimic joints, limits, masses, meshes:
    ``urdf_elements``) read the file as XML, and would pass it unchecked. So is one declaring XML
    entities, which those checks would read expanded and Pinocchio not.

    Raises:
        RobotFileError: naming the XML error and where it is.
    """
    import xml.etree.ElementTree as ElementTree

    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise RobotFileError(f"cannot load URDF {path}: cannot read it ({exc.strerror or exc})", path=path) from None
    try:
        root = ElementTree.fromstring(raw)
    except ElementTree.ParseError as exc:
        remedy = "expand the xacro macros first (xacro FILE > ROBOT.urdf)" if b"xacro:" in raw else "fix the file"
        raise RobotFileError(f"cannot load URDF {path}: not well-formed XML ({exc}); the planner's checks of its "
                             f"joints, masses and meshes read it as XML: {remedy}", path=path) from None
    if b"<!ENTITY" in raw:  # the XML parser above expands them, Pinocchio's takes "&name;" as it is
        raise RobotFileError(f"cannot load URDF {path}: it declares XML entities (<!ENTITY ...>), which Pinocchio's "
                             f"URDF parser does not expand (a joint would be named '&name;'): write their values "
                             f"out", path=path)
    return root


def _check_tree(root, path: Path) -> None:
    """Refuse a URDF whose joints do not make its links a tree: a link that is the child of two joints,
    or links that are each other's ancestors (a loop). Pinocchio's parser drops the links of a loop
    without a word (the tool frame then seems unknown) and reports a second parent joint as some
    other link missing. Joints that lack a parent or child link are left to its own message.

    Raises:
        RobotFileError: naming the link and its two parent joints, or the loop's joints in order.
    """
    parent_joint: dict[str, tuple[str, str]] = {}  # child link -> (joint, parent link)
    for joint in root.findall("joint"):
        parent, child = (joint.find(end) for end in ("parent", "child"))
        if parent is None or child is None or parent.get("link") is None or child.get("link") is None:
            continue
        name, child_link = joint.get("name", ""), child.get("link", "")
        if child_link in parent_joint:
            raise RobotFileError(f"cannot load URDF {path}: link {shown(child_link, 60)} is the child of two joints, "
                                 f"{shown(parent_joint[child_link][0], 60)} and {shown(name, 60)}; in a URDF every "
                                 f"link but the root has exactly one parent joint (a closed chain cannot be "
                                 f"described)", path=path)
        parent_joint[child_link] = (name, parent.get("link", ""))
    rooted: set[str] = set()  # links whose ancestors end at a root
    for start in parent_joint:
        seen: list[str] = []
        link = start
        while link in parent_joint and link not in rooted and link not in seen:
            seen.append(link)
            link = parent_joint[link][1]
        if link in seen:  # the walk towards the root came back: seen[index:] is the loop
            loop = seen[seen.index(link):][::-1]
            if len(loop) == 1:
                raise RobotFileError(f"cannot load URDF {path}: joint {shown(parent_joint[link][0], 60)} makes link "
                                     f"{shown(link, 60)} its own parent; a URDF's links form a tree from one root "
                                     f"link", path=path)
            shown_loop = loop[:6]
            more = f", ... ({len(loop)} in all)" if len(loop) > len(shown_loop) else ""
            joints = ", ".join(shown(parent_joint[child][0], 60) for child in shown_loop)
            raise RobotFileError(f"cannot load URDF {path}: joints {joints}{more} make links "
                                 f"{', '.join(shown(child, 60) for child in shown_loop)}{more} a loop (each the "
                                 f"parent of the next); a URDF's links form a tree from one root link", path=path)
        rooted.update(seen)


def _check_utf8(path: Path) -> None:
    """Refuse a URDF that is not UTF-8 text: Pinocchio hands its names to Python as UTF-8 and Rerun reads
    its mesh paths so (an XML declaration of another encoding, such as ISO-8859-1, is not followed).

    Raises:
        RobotFileError: naming the first offending byte and its line.
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise RobotFileError(f"cannot load URDF {path}: cannot read it ({exc.strerror or exc})", path=path) from None
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise RobotFileError(f"cannot load URDF {path}: byte 0x{data[exc.start]:02x} on line {line} is not UTF-8; "
                             f"the planner reads a URDF's names and mesh paths as UTF-8: save it as UTF-8",
                             path=path) from None


def _negative_limit(root) -> str:
    """The first ``<limit velocity|effort>`` of the URDF below zero, as ``joint 'j1': <limit velocity>
    must be >= 0, got -2``; '' if none, in the URDF's ``root`` element. Pinocchio refuses such a file
    without naming the joint."""
    for joint in root.findall("joint"):
        for limit in joint.findall("limit"):
            for attribute in ("velocity", "effort"):
                try:
                    negative = float(limit.get(attribute, "0")) < 0
                except ValueError:  # not a number: Pinocchio's own message names the joint
                    negative = False
                if negative:
                    return (f"joint {shown(joint.get('name'), 60)}: <limit {attribute}> must be >= 0, got "
                            f"{shown(limit.get(attribute), 40)}")
    return ""


def _bad_mass(root) -> str:
    """The first link whose ``<inertial><mass value>`` is not a finite number >= 0, as ``link 'l2':
    <mass value> must be a finite number >= 0, got 'nan'``; '' if none. Pinocchio's parser leaves a link
    of unreadable mass massless and takes a negative one as it is, so the torques would be wrong.
    ``root``: the URDF's root element."""
    for link in root.findall("link"):
        for mass in link.findall("inertial/mass"):
            try:
                value = float(mass.get("value", ""))
            except ValueError:
                value = math.nan
            if not (math.isfinite(value) and value >= 0):
                return (f"link {shown(link.get('name'), 60)}: <mass value> must be a finite number >= 0, got "
                        f"{shown(mass.get('value'), 40)}")
    return ""


def _check_joint_names(root, urdf_path: Path, name: str) -> None:
    """Refuse a ``<joint>`` without a name under the URDF's ``root`` element (Pinocchio reads it as the empty
    name; errors and outputs name joints by their names), naming its links.

    Raises:
        RobotFileError: naming the joint's parent and child links.
    """
    for joint in root.findall("joint"):
        if not (joint.get("name") or "").strip():
            links = [(joint.find(end).get("link") if joint.find(end) is not None else None) for end in ("parent",
                                                                                                    "child")]
            raise RobotFileError(f"robot {shown(name)} ({urdf_path}): the <joint> from link {shown(links[0])} to "
                                 f"link {shown(links[1])} has an empty name; give every joint a name of its own",
                                 path=urdf_path)


def _mimic_joints(urdf_path: Path) -> list[str]:
    """Names of the URDF's joints that copy another (``<mimic joint=...>``); Pinocchio ignores the tag."""
    return [joint.get("name", "") for joint in urdf_elements(urdf_path, "joint") if joint.find("mimic") is not None]


def _link_meshes(root, urdf_path: Path, package_dirs):
    """Each ``<mesh>`` of a link's ``<visual>`` or ``<collision>`` under the URDF's ``root`` element, as
    (link, its visual or collision element, the mesh element, the file's status (``os.stat``) and path),
    status and path None where the file is not found (``_mesh_file``), is a dangling link, or its name
    cannot be a path (a NUL in it)."""
    for link in root.findall("link"):
        for element in [e for kind in ("visual", "collision") for e in link.findall(kind)]:
            for mesh in element.iter("mesh"):
                try:
                    path = _mesh_file(mesh.get("filename") or "", urdf_path, package_dirs)
                    status = None if path is None else os.stat(path)
                except (OSError, ValueError):
                    path, status = None, None
                yield link, element, mesh, status, path


def check_meshes(urdf_path: Path, package_dirs) -> tuple[str, ...]:
    """Every mesh the URDF names that exists is a regular file of at most ``MAX_MESH_BYTES``, so that
    drawing the robot cannot read a device (``/dev/zero``) or a pipe without end. Returns the
    meshes not found, as named (a robot is planned without them; the recording draws nothing there).

    Raises:
        RobotError: naming the link, the mesh and what it is.
    """
    missing: list[str] = []
    for link, _, mesh, status, path in _link_meshes(_urdf_root(urdf_path), urdf_path, package_dirs):
        named = mesh.get("filename") or ""
        if status is None:
            missing.append(named)
            continue
        where = f"URDF {urdf_path}: link {shown(link.get('name'), 60)} mesh {shown(named, 120)}"
        if not stat.S_ISREG(status.st_mode):
            raise RobotFileError(f"{where} is not a regular file (a folder, device or pipe)", path=path)
        if status.st_size > MAX_MESH_BYTES:
            raise RobotFileError(f"{where} is larger than {MAX_MESH_BYTES >> 20} MiB", path=path)
    return tuple(dict.fromkeys(missing))


def drawable_urdf(urdf_path: Path, package_dirs) -> bytes:
    """The URDF as the recording hands it to Rerun's importer: every mesh named by the absolute path of
    the regular file ``check_meshes`` resolved, and each ``<visual>`` or ``<collision>`` whose mesh is
    not found, or is no regular file, left out. So the importer opens only files the planner checked:
    left to itself it resolves a ``package://NAME/...`` that no package root holds against the current
    folder (a pipe or ``/dev/zero`` reached so hung the recording or filled the memory)."""
    import xml.etree.ElementTree as ElementTree

    root = _urdf_root(urdf_path)
    for link, element, mesh, status, path in list(_link_meshes(root, urdf_path, package_dirs)):
        if status is not None and stat.S_ISREG(status.st_mode):
            mesh.set("filename", str(Path(path).resolve()))
        elif element in link:  # not yet left out for another of its meshes
            link.remove(element)
    return ElementTree.tostring(root, encoding="utf-8")


def _first_line(text: str) -> str:
    """The first non-empty line of ``text`` without a log-level prefix, cut to 160 characters."""
    for line in text.splitlines():
        line = line.strip().removeprefix("Error:").removeprefix("Warning:").strip()
        if line and not line.startswith("at line "):
            return line if len(line) <= 160 else shown(line, 160)
    return ""


def _detail(log: list[str]) -> str:
    """`` (first logged line)`` of a captured log, or ''."""
    line = _first_line("".join(log))
    return f" ({line})" if line else ""


def _read_limit_file(path: Path) -> dict[str, object]:
    """The lists of ``<robot>.limits.yaml`` by key, as written ({} if there is no file); checked against the
    joints by ``_file_limits`` once the planned chain is known."""
    if not os.path.lexists(path):
        return {}
    if not path.is_file():
        raise RobotFileError(f"limits file {path} is not a regular file (a folder, pipe or broken link); move it "
                             f"away or make it a file", path=path)
    try:
        data = read_yaml(path, "limits file")
    except TaskError as exc:
        raise RobotFileError(f"limits file {path}: {exc.problem}" if exc.path == str(path) else
                             f"limits file {path}: {exc}", path=path) from None
    data = {} if data is None else data
    keys = " and ".join(_LIMIT_FILE_KEYS)
    if not isinstance(data, dict):
        raise RobotFileError(f"limits file {path} must map {keys} to lists, got {type(data).__name__}", path=path)
    for key in data:
        if key not in _LIMIT_FILE_KEYS:
            raise RobotFileError(f"limits file {path}: unknown key {shown(key)}; expected {keys}", path=path)
    return data


def _file_limits(path: Path, data: dict[str, object], chain: list[str], every: list[str]) -> dict[str, np.ndarray]:
    """Acceleration and jerk limits [rad/s^2, rad/s^3] of the planned ``chain``'s joints from a limits
    file's lists ``data`` [deg/s^2, deg/s^3]: one value per joint of the chain, or per joint of the
    whole URDF (``every``, locked ones too: a gripper's fingers), in order."""
    limits = {}
    for key, quantity in _LIMIT_FILE_KEYS.items():
        if key not in data:
            continue
        values = data[key]
        layouts = [chain] + ([every] if len(every) != len(chain) else [])
        joints = next((names for names in layouts if isinstance(values, list) and len(values) == len(names)), None)
        if joints is None:
            whole = f", or {len(every)}, one per joint of the URDF ({', '.join(every)})" if len(layouts) > 1 else ""
            raise RobotFileError(f"limits file {path}: {key} must be a list of {len(chain)} positive numbers, one "
                                 f"per joint ({', '.join(chain)}){whole}, got {shown(values)}", path=path)
        assert isinstance(values, list)
        low, high = LIMIT_DEG_RANGE
        for joint, value in zip(joints, values):
            if not positive_finite(value) or not low <= value <= high:
                raise RobotFileError(f"limits file {path}: {key} of joint {joint!r} must be a number >= {low:g} and "
                                     f"<= {high:g}, got {shown(value)}", path=path)
        by_name = dict(zip(joints, values))
        limits[quantity] = np.radians([by_name[joint] for joint in chain])
    return limits


def load_robot(urdf: Path | None = None, name: str | None = None, tool_frame: str | None = None) -> Robot:
    """A robot from a URDF path or an example-robot-data name.

    Raises:
        InputError: both or neither given (a call's mistake, not the robot's).
    """
    if (urdf is None) == (name is None):
        raise InputError(f"load_robot takes exactly one of a URDF path or a robot name, got "
                         f"{'both' if urdf is not None else 'neither'}")
    if urdf is not None:
        return Robot.from_urdf(urdf, tool_frame)
    assert name is not None
    return Robot.from_example_robot_data(name, tool_frame)
