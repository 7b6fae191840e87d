"""Task files: YAML schema, loading and validation. Degrees become SI units here, and only here.

Schema (version 1)::

    version: 1
    name: optional label                                   # default: the file's stem
    robot: {urdf: robots/puma560.urdf, tool_frame: tool}   # or {name: ur5, tool_frame: tool0}; optional
    waypoints:
      joints_deg: [[...], ...]                             # joint via-points, or:
      cartesian:
        - {xyz_m: [x, y, z], rpy_deg: [r, p, y], hint_deg: [...]}   # or quat_xyzw: [x, y, z, w]
    limits:                                                # optional with a robot (overrides)
      velocity_deg_s: [...]
      acceleration_deg_s2: [...]
      jerk_deg_s3: [...]
      position_deg: [[lower, upper], ...]
    ik: {branch: optimal, start_deg: [...], seed: 0}       # cartesian only; branch: optimal | continuous
    path: {mode: joint, tolerance_m: 0.001, tolerance_deg: 0.5}   # cartesian only; mode: joint | linear
    trajectory: {family: hybrid, sample_rate_hz: 100, min_segment_s: 0.001}
    optimizer: {algorithm: default, seed: 0, bounds_s: [h_min, h_max], objective: time,
                weights: [K_t, K_j], ...algorithm settings (nests, iterations, pa, ...)}

Every error is a ``TaskError`` naming the key path, e.g.
``limits.velocity_deg_s[2]: must be > 0, got -1``.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from .errors import TaskError
from .ik import BRANCH_RULES
from .splines import FAMILIES
from .timing import OPTIMIZERS, cuckoo_search
from .timing.problem import OBJECTIVES

SCHEMA_VERSION = 1
#: Default shortest segment duration [s]: one period of a 1 kHz controller. Merged repeated
#: via-points keep their zero-length segment.
MIN_SEGMENT_S = 1e-3
_TOP_KEYS = ("version", "name", "robot", "waypoints", "limits", "ik", "path", "trajectory", "optimizer")
PATH_MODES = ("joint", "linear")
_LIMIT_KEYS = {"velocity_deg_s": "velocity", "acceleration_deg_s2": "acceleration", "jerk_deg_s3": "jerk"}
_LIMIT_KEY_OF = {**{name: key for key, name in _LIMIT_KEYS.items()}, "lower": "position_deg", "upper": "position_deg"}
_COMMON_OPTIMIZER_KEYS = ("algorithm", "seed", "bounds_s", "objective", "weights")


@dataclass(frozen=True)
class CartesianWaypoint:
    """A tool pose: position [m], orientation as a unit quaternion (x, y, z, w), optional joint hint [rad]."""

    position: np.ndarray
    quaternion_xyzw: np.ndarray
    hint: np.ndarray | None = None


@dataclass(frozen=True)
class IKOptions:
    """How IK picks a solution per waypoint (``ik.solve_waypoints``).

    Attributes:
        branch: ``optimal`` (dynamic programming over the sequence) or ``continuous``.
        start: the robot's configuration before the task [rad], or None.
        seed: seed of the random IK starts.
    """

    branch: str = "optimal"
    start: np.ndarray | None = None
    seed: int = 0


@dataclass(frozen=True)
class PathOptions:
    """How the tool moves between Cartesian waypoints (``cartesian_path.py``).

    Attributes:
        mode: ``joint`` (the joint-space spline, the tool path follows) or ``linear``
            (straight lines, orientation by slerp, within the tolerances).
        tolerance_m: largest distance of the tool from the straight segment [m].
        tolerance_rad: largest angle of the tool from the slerp arc [rad].
    """

    mode: str = "joint"
    tolerance_m: float = 1e-3
    tolerance_rad: float = float(np.deg2rad(0.5))


@dataclass(frozen=True)
class RobotSpec:
    """Which robot: a URDF path (resolved against the task file's folder, then the working
    directory) or an example-robot-data name, and the tool frame's name."""

    urdf: Path | None
    name: str | None
    tool_frame: str | None


@dataclass(frozen=True)
class Task:
    """A validated task, in SI units.

    Attributes:
        joint_waypoints: (n, J) joint via-points [rad], or None for a Cartesian task.
        cartesian_waypoints: tool poses, or None for a joint-space task.
        limits: per-quantity overrides: ``velocity``, ``acceleration``, ``jerk`` (J,) [SI]
            and ``lower``, ``upper`` (J,) [rad]; absent keys are absent limits.
        optimizer: ``algorithm``, ``seed``, ``bounds`` [s] or None, ``objective``, ``weights``,
            and ``settings`` passed to the algorithm.
    """

    name: str
    joint_waypoints: np.ndarray | None
    cartesian_waypoints: list[CartesianWaypoint] | None
    robot: RobotSpec | None
    limits: dict[str, np.ndarray]
    family: str = "hybrid"
    sample_rate_hz: float = 100.0
    min_segment_s: float = 1e-3
    optimizer: dict = field(default_factory=lambda: {"algorithm": "default", "seed": 0, "bounds": None,
                                                     "objective": "time", "weights": (1.0, 1.0),
                                                     "settings": {}})
    source: Path | None = None
    ik: IKOptions = field(default_factory=IKOptions)
    path: PathOptions = field(default_factory=PathOptions)


# ---------------------------------------------------------------------------- primitives


def _mapping(value, path: str, allowed) -> dict:
    if not isinstance(value, dict):
        raise TaskError(path, f"must be a mapping, got {type(value).__name__}")
    for key in value:
        if key not in allowed:
            raise TaskError(f"{path}.{key}" if path else str(key),
                            f"unknown key; expected one of: {', '.join(allowed)}")
    return value


def _number(value, path: str, *, positive: bool = False, integer: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TaskError(path, f"must be a number, got {value!r}")
    if not math.isfinite(value):
        raise TaskError(path, f"must be a finite number, got {value}")
    if integer and int(value) != value:
        raise TaskError(path, f"must be a whole number, got {value}")
    if positive and value <= 0:
        raise TaskError(path, f"must be > 0, got {value}")
    return int(value) if integer else float(value)


def _vector(value, path: str, length: int | None = None, *, positive: bool = False) -> np.ndarray:
    if not isinstance(value, (list, tuple)):
        raise TaskError(path, f"must be a list of numbers, got {value!r}")
    if length is not None and len(value) != length:
        raise TaskError(path, f"must have {length} values, got {len(value)}")
    return np.array([_number(v, f"{path}[{i}]", positive=positive) for i, v in enumerate(value)])


def _text(value, path: str) -> str:
    if not isinstance(value, str) or not value:
        raise TaskError(path, f"must be a non-empty string, got {value!r}")
    return value


# ---------------------------------------------------------------------------- sections


def _joint_waypoints(value, path: str) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or len(value) < 2:
        raise TaskError(path, "must be a list of at least 2 joint vectors")
    first = _vector(value[0], f"{path}[0]")
    if len(first) < 1:
        raise TaskError(f"{path}[0]", "must have at least 1 joint value")
    rows = [first] + [_vector(v, f"{path}[{i}]", len(first)) for i, v in enumerate(value[1:], start=1)]
    return np.deg2rad(np.array(rows))


def _quaternion_from_rpy(rpy: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll), angles [rad] (URDF convention)."""
    half = rpy / 2.0
    cr, cp, cy = np.cos(half)
    sr, sp, sy = np.sin(half)
    return np.array([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy])


def _cartesian_waypoint(value, path: str) -> CartesianWaypoint:
    entry = _mapping(value, path, ("xyz_m", "rpy_deg", "quat_xyzw", "hint_deg"))
    if "xyz_m" not in entry:
        raise TaskError(f"{path}.xyz_m", "is required")
    position = _vector(entry["xyz_m"], f"{path}.xyz_m", 3)
    if ("rpy_deg" in entry) == ("quat_xyzw" in entry):
        raise TaskError(path, "needs exactly one of rpy_deg or quat_xyzw")
    if "rpy_deg" in entry:
        quaternion = _quaternion_from_rpy(np.deg2rad(_vector(entry["rpy_deg"], f"{path}.rpy_deg", 3)))
    else:
        quaternion = _vector(entry["quat_xyzw"], f"{path}.quat_xyzw", 4)
        norm = np.linalg.norm(quaternion)
        if abs(norm - 1.0) > 1e-3:
            raise TaskError(f"{path}.quat_xyzw", f"must be a unit quaternion, norm is {norm:.6g}")
        quaternion = quaternion / norm
    hint = np.deg2rad(_vector(entry["hint_deg"], f"{path}.hint_deg")) if "hint_deg" in entry else None
    return CartesianWaypoint(position, quaternion, hint)


def _waypoints(value, path: str):
    section = _mapping(value, path, ("joints_deg", "cartesian"))
    if len(section) != 1:
        raise TaskError(path, "needs exactly one of joints_deg or cartesian")
    if "joints_deg" in section:
        return _joint_waypoints(section["joints_deg"], f"{path}.joints_deg"), None
    poses = section["cartesian"]
    if not isinstance(poses, (list, tuple)) or len(poses) < 2:
        raise TaskError(f"{path}.cartesian", "must be a list of at least 2 poses")
    return None, [_cartesian_waypoint(p, f"{path}.cartesian[{i}]") for i, p in enumerate(poses)]


def _limits(value, path: str) -> dict[str, np.ndarray]:
    section = _mapping(value, path, (*_LIMIT_KEYS, "position_deg"))
    limits = {name: np.deg2rad(_vector(section[key], f"{path}.{key}", positive=True))
              for key, name in _LIMIT_KEYS.items() if key in section}
    if "position_deg" in section:
        ranges = section["position_deg"]
        if not isinstance(ranges, (list, tuple)):
            raise TaskError(f"{path}.position_deg", "must be a list of [lower, upper] pairs")
        pairs = np.array([_vector(r, f"{path}.position_deg[{i}]", 2) for i, r in enumerate(ranges)])
        for i, (low, high) in enumerate(pairs):
            if low >= high:
                raise TaskError(f"{path}.position_deg[{i}]", f"lower {low} must be below upper {high}")
        limits["lower"], limits["upper"] = np.deg2rad(pairs[:, 0]), np.deg2rad(pairs[:, 1])
    return limits


def _robot(value, path: str, base: Path | None) -> RobotSpec:
    section = _mapping(value, path, ("urdf", "name", "tool_frame"))
    if ("urdf" in section) == ("name" in section):
        raise TaskError(path, "needs exactly one of urdf or name")
    tool = _text(section["tool_frame"], f"{path}.tool_frame") if "tool_frame" in section else None
    if "name" in section:
        return RobotSpec(None, _text(section["name"], f"{path}.name"), tool)
    urdf = Path(_text(section["urdf"], f"{path}.urdf"))
    candidates = [urdf] if urdf.is_absolute() else [p for p in ((base / urdf) if base else None, urdf) if p]
    for candidate in candidates:
        if candidate.is_file():
            return RobotSpec(candidate.resolve(), None, tool)
    raise TaskError(f"{path}.urdf", f"file not found: {urdf}")


def _ik(value, path: str) -> IKOptions:
    section = _mapping(value, path, ("branch", "start_deg", "seed"))
    branch = section.get("branch", "optimal")
    if branch not in BRANCH_RULES:
        raise TaskError(f"{path}.branch", f"unknown branch rule {branch!r}; known: {', '.join(BRANCH_RULES)}")
    start = np.deg2rad(_vector(section["start_deg"], f"{path}.start_deg")) if "start_deg" in section else None
    seed = _number(section["seed"], f"{path}.seed", integer=True) if "seed" in section else 0
    return IKOptions(branch, start, seed)


def _path(value, path: str) -> PathOptions:
    section = _mapping(value, path, ("mode", "tolerance_m", "tolerance_deg"))
    mode = section.get("mode", "joint")
    if mode not in PATH_MODES:
        raise TaskError(f"{path}.mode", f"unknown path mode {mode!r}; known: {', '.join(PATH_MODES)}")
    default = PathOptions()
    tolerance_m = _number(section["tolerance_m"], f"{path}.tolerance_m", positive=True) \
        if "tolerance_m" in section else default.tolerance_m
    tolerance_rad = np.deg2rad(_number(section["tolerance_deg"], f"{path}.tolerance_deg", positive=True)) \
        if "tolerance_deg" in section else default.tolerance_rad
    return PathOptions(mode, tolerance_m, float(tolerance_rad))


def _optimizer_parameters(algorithm: str) -> dict[str, str]:
    """Keyword settings of ``algorithm`` and their kinds (bool, int, float), read from its signature."""
    function = cuckoo_search if algorithm in ("default", "cuckoo-paper") else OPTIMIZERS[algorithm]
    kinds = {}
    for p in inspect.signature(function).parameters.values():
        if p.kind == p.KEYWORD_ONLY and p.name not in ("seed", "progress", "variant"):
            kinds[p.name] = str(p.annotation).split("|")[0].strip()
    return kinds


def _optimizer(value, path: str) -> dict:
    value = {} if value is None else value
    if not isinstance(value, dict):
        raise TaskError(path, f"must be a mapping, got {type(value).__name__}")
    algorithm = value.get("algorithm", "default")
    if algorithm not in OPTIMIZERS:
        raise TaskError(f"{path}.algorithm", f"unknown algorithm {algorithm!r}; known: {', '.join(OPTIMIZERS)}")
    parameters = _optimizer_parameters(algorithm)
    section = _mapping(value, path, _COMMON_OPTIMIZER_KEYS + tuple(parameters))
    result = {"algorithm": algorithm, "seed": 0, "bounds": None, "objective": "time", "weights": (1.0, 1.0),
              "settings": {}}
    for key, item in section.items():
        where = f"{path}.{key}"
        if key == "algorithm":
            continue
        if key == "seed":
            result["seed"] = _number(item, where, integer=True)
        elif key == "bounds_s":
            bounds = _vector(item, where, 2, positive=True)
            if bounds[0] > bounds[1]:
                raise TaskError(where, f"lower bound {bounds[0]} exceeds upper bound {bounds[1]}")
            result["bounds"] = (float(bounds[0]), float(bounds[1]))
        elif key == "objective":
            if item not in OBJECTIVES:
                raise TaskError(where, f"unknown objective {item!r}; known: {', '.join(OBJECTIVES)}")
            result["objective"] = item
        elif key == "weights":
            result["weights"] = tuple(_vector(item, where, 2))
        elif parameters[key] == "bool":
            if not isinstance(item, bool):
                raise TaskError(where, f"must be true or false, got {item!r}")
            result["settings"][key] = item
        else:
            result["settings"][key] = _number(item, where, integer=parameters[key] == "int")
    return result


def _trajectory(value, path: str) -> tuple[str, float, float]:
    section = _mapping({} if value is None else value, path, ("family", "sample_rate_hz", "min_segment_s"))
    family = section.get("family", "hybrid")
    if family not in FAMILIES:
        raise TaskError(f"{path}.family", f"unknown family {family!r}; known: {', '.join(FAMILIES)}")
    rate = _number(section["sample_rate_hz"], f"{path}.sample_rate_hz", positive=True) \
        if "sample_rate_hz" in section else 100.0
    minimum = _number(section["min_segment_s"], f"{path}.min_segment_s", positive=True) \
        if "min_segment_s" in section else MIN_SEGMENT_S
    return family, rate, minimum


# ---------------------------------------------------------------------------- entry points


def check_limit_counts(limits: dict[str, np.ndarray], joints: int, context: str) -> None:
    """Every limit override has one value per joint; the error names the task key."""
    for key, values in limits.items():
        if len(values) != joints:
            raise TaskError(f"limits.{_LIMIT_KEY_OF[key]}", f"must have {joints} values {context}, got {len(values)}")


def parse_task(data, *, name: str = "task", source: Path | None = None) -> Task:
    """Validate a task given as plain data (the parsed YAML)."""
    document = _mapping(data, "", _TOP_KEYS)
    if "version" not in document:
        raise TaskError("version", f"is required (use version: {SCHEMA_VERSION})")
    if document["version"] != SCHEMA_VERSION:
        raise TaskError("version", f"unsupported version {document['version']!r}; this planner reads {SCHEMA_VERSION}")
    if "waypoints" not in document:
        raise TaskError("waypoints", "is required")
    base = source.parent if source else None
    robot = _robot(document["robot"], "robot", base) if "robot" in document else None
    joints, cartesian = _waypoints(document["waypoints"], "waypoints")
    if cartesian is not None and robot is None:
        raise TaskError("robot", "is required for cartesian waypoints")
    for key in ("ik", "path"):
        if key in document and cartesian is None:
            raise TaskError(key, "applies to cartesian waypoints only")
    ik = _ik(document["ik"], "ik") if "ik" in document else IKOptions()
    path = _path(document["path"], "path") if "path" in document else PathOptions()
    limits = _limits(document["limits"], "limits") if "limits" in document else {}
    if robot is None and not any(k in limits for k in ("velocity", "acceleration", "jerk")):
        raise TaskError("limits", "a joint-space task without a robot needs velocity_deg_s, "
                                  "acceleration_deg_s2 or jerk_deg_s3")
    if joints is not None:
        check_limit_counts(limits, joints.shape[1], "(one per joint)")
    family, rate, min_segment = _trajectory(document.get("trajectory"), "trajectory")
    optimizer = _optimizer(document.get("optimizer"), "optimizer")
    label = _text(document["name"], "name") if "name" in document else name
    return Task(label, joints, cartesian, robot, limits, family, rate, min_segment, optimizer, source, ik, path)


def load_task(path) -> Task:
    """Read and validate a YAML task file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise TaskError(str(path), f"cannot read task file ({exc.strerror or exc})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise TaskError(str(path), f"not valid YAML{where}: {getattr(exc, 'problem', exc)}") from None
    return parse_task(data, name=path.stem, source=path)
