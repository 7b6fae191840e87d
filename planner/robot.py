"""Robot: a Pinocchio model reduced to the joints that move a tool frame, with its limits.

A robot comes from a URDF file (with an optional ``<name>.limits.yaml`` beside
it giving acceleration and jerk limits in degrees) or from example-robot-data
by name. Joints that do not move the tool frame (a gripper's fingers, say)
are locked at their neutral position with ``pinocchio.buildReducedModel``, so
the planned joints are exactly those of the tool frame's kinematic chain.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml

from .errors import RobotError
from .limits import JointLimits

_LIMIT_FILE_KEYS = {"acceleration_deg_s2": "acceleration", "jerk_deg_s3": "jerk"}


@dataclass
class Robot:
    """A serial chain to plan for.

    Attributes:
        name: robot name.
        model, data: the reduced Pinocchio model (revolute or prismatic joints, nq == nv).
        tool_frame: name of the frame whose pose waypoints give; ``tool_frame_id`` its index.
        limits: ``JointLimits`` in SI units (position and velocity from the URDF,
            acceleration and jerk from the limits file where there is one).
        urdf_path: the URDF file, for visualisation.
        package_dirs: folders that resolve the URDF's ``package://`` meshes.
    """

    name: str
    model: pin.Model
    data: pin.Data
    tool_frame: str
    tool_frame_id: int
    limits: JointLimits
    urdf_path: Path
    package_dirs: tuple[Path, ...] = ()

    @property
    def joint_names(self) -> list[str]:
        return [self.model.names[i] for i in range(1, self.model.njoints)]

    @property
    def dof(self) -> int:
        return self.model.nq

    @cached_property
    def revolute(self) -> np.ndarray:
        """(nq,) whether each joint is revolute (angles that may be shifted by 2 pi)."""
        return np.array([self.model.joints[j].shortname().startswith(("JointModelR", "JointModelRevolute"))
                         for j in range(1, self.model.njoints)])

    def forward_kinematics(self, q) -> pin.SE3:
        """Pose of the tool frame in the world for joint positions ``q`` [rad]."""
        q = np.asarray(q, dtype=float)
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.tool_frame_id].copy()

    def frame_jacobian(self, q) -> np.ndarray:
        """(6, nv) Jacobian of the tool frame in its LOCAL frame (linear first)."""
        return pin.computeFrameJacobian(self.model, self.data, np.asarray(q, dtype=float), self.tool_frame_id,
                                        pin.ReferenceFrame.LOCAL)

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_urdf(cls, path, tool_frame: str | None = None, package_dirs=()) -> "Robot":
        """Load a URDF; ``tool_frame`` defaults to the last frame of the model."""
        path = Path(path)
        try:
            model = pin.buildModelFromUrdf(str(path))
        except (RuntimeError, ValueError, OSError) as exc:
            raise RobotError(f"cannot load URDF {path}: {str(exc).strip().splitlines()[0]}") from None
        extra = _read_limit_file(path.with_suffix(".limits.yaml"), model)
        return cls._build(model.name or path.stem, model, tool_frame, path, tuple(package_dirs), extra)

    @classmethod
    def from_example_robot_data(cls, name: str, tool_frame: str | None = None) -> "Robot":
        """An example-robot-data robot by name (``ur5``, ``panda``, ...)."""
        from example_robot_data.robots_loader import ROBOTS
        if name not in ROBOTS:
            raise RobotError(f"unknown robot {name!r}; example-robot-data has: {', '.join(sorted(ROBOTS))}")
        loader = ROBOTS[name]()
        model = loader.robot.model
        if model.joints[1].shortname() == "JointModelFreeFlyer":
            raise RobotError(f"robot {name!r} has a floating base; only fixed-base arms can be planned")
        package_dirs = tuple(Path(d) for d in (loader.model_path, Path(loader.model_path).parent))
        return cls._build(name, model, tool_frame, Path(loader.df_path), package_dirs, {})

    @classmethod
    def _build(cls, name, model, tool_frame, urdf_path, package_dirs, extra_limits) -> "Robot":
        frame_names = [f.name for f in model.frames]
        if tool_frame is None:
            tool_frame = frame_names[-1]
        if not model.existFrame(tool_frame):
            raise RobotError(f"robot {name!r} has no frame {tool_frame!r}; frames: {', '.join(frame_names)}")
        parent = model.frames[model.getFrameId(tool_frame)].parentJoint
        chain = set(model.supports[parent])
        locked = [j for j in range(1, model.njoints) if j not in chain]
        reduced = pin.buildReducedModel(model, locked, pin.neutral(model)) if locked else model
        for j in range(1, reduced.njoints):
            joint = reduced.joints[j]
            if joint.nq != 1 or joint.nv != 1:
                raise RobotError(f"joint {reduced.names[j]!r} ({joint.shortname()}) is not a single revolute "
                                 f"or prismatic joint; it cannot be planned")
        if reduced.nq == 0:
            raise RobotError(f"frame {tool_frame!r} of robot {name!r} is not moved by any joint")
        velocity = np.where(reduced.velocityLimit > 0, reduced.velocityLimit, np.inf)
        lower = np.where(np.isfinite(reduced.lowerPositionLimit), reduced.lowerPositionLimit, -np.inf)
        upper = np.where(np.isfinite(reduced.upperPositionLimit), reduced.upperPositionLimit, np.inf)
        limits = JointLimits.create(reduced.nq, lower=lower, upper=upper, velocity=velocity, **extra_limits)
        return cls(name, reduced, reduced.createData(), tool_frame, reduced.getFrameId(tool_frame), limits,
                   Path(urdf_path), package_dirs)


def _read_limit_file(path: Path, model: pin.Model) -> dict[str, np.ndarray]:
    """Acceleration and jerk limits [deg-based] from ``<robot>.limits.yaml``, in SI; {} if absent."""
    if not path.is_file():
        return {}
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise RobotError(f"cannot read limits file {path}: {exc}") from None
    if not isinstance(data, dict) or set(data) - set(_LIMIT_FILE_KEYS):
        raise RobotError(f"limits file {path} must map {' and '.join(_LIMIT_FILE_KEYS)} to lists")
    limits = {}
    for key, name in _LIMIT_FILE_KEYS.items():
        if key in data:
            values = np.asarray(data[key], dtype=float)
            if values.shape != (model.nq,) or not np.all(np.isfinite(values) & (values > 0)):
                raise RobotError(f"limits file {path}: {key} needs {model.nq} positive numbers, got {data[key]}")
            limits[name] = np.deg2rad(values)
    return limits


def load_robot(urdf: Path | None = None, name: str | None = None, tool_frame: str | None = None) -> Robot:
    """A robot from a URDF path or an example-robot-data name."""
    if (urdf is None) == (name is None):
        raise RobotError("give exactly one of a URDF path or a robot name")
    return Robot.from_urdf(urdf, tool_frame) if urdf is not None else Robot.from_example_robot_data(name, tool_frame)
