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
      torque_nm: [...]                                     # robot only: per joint, or urdf (its efforts)
      tool_speed_m_s: 0.25                                 # robot only: the tool frame's linear speed
      tool_speed_deg_s: 90                                 # robot only: its angular speed
    ik: {branch: optimal, start_deg: [...], seed: 0}       # cartesian only; branch: optimal | continuous
    path: {mode: joint, tolerance_m: 0.001, tolerance_deg: 0.5}   # cartesian only; mode: joint | linear
    trajectory: {family: hybrid, sample_rate_hz: 100, min_segment_s: 0.001}
    optimizer: {algorithm: default, seed: 0, bounds_s: [h_min, h_max], objective: time, time_limit_s: 120,
                weights: [K_t, K_j], ...algorithm settings (nests, iterations, pa, ...)}

Every single number has the range given in ``RANGES`` (seeds are integers in [0, 2^63),
``sample_rate_hz`` at most 100 kHz, every optimizer setting has its own range), and every
number in a list the range of its kind (``ANGLE_DEG``, ``LIMIT_DEG``, ``POSITION_M``); a task
file is UTF-8 (byte-order mark optional) or UTF-16/UTF-32 with a byte-order mark, at
most ``yaml_input.MAX_FILE_BYTES`` long, nested at most ``MAX_NESTING`` deep, expanding to at most
``MAX_VALUES`` values, with no key twice in a mapping.

Every error is a ``TaskError`` naming the key path, e.g.
``limits.velocity_deg_s[2]: must be >= 1e-12 and <= 1e+15, got -1``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import SHOWN_VALUE_CHARS, InputError, SettingError, TaskError, path_encoding_advice, shown
from .ik import BRANCH_RULES
from .limits import LARGEST_POSITION_DEG, LIMIT_DEG_RANGE, LIMITED, PROFILE_QUANTITIES, TORQUE_RANGE_NM
from .read_only import ReadOnlyArrays, ReadOnlyDict, freeze_arrays
from .splines import FAMILIES
from .timing import OPTIMIZERS, SETTING_RANGES, checked_settings, setting_names
from .timing.problem import OBJECTIVES
from .validate import CONTROL_CHARACTERS, DURATION_BOUND_RANGE, MAX_SEED, Range, number, ranged
from .yaml_input import MAX_NESTING, key_path, read_yaml

SCHEMA_VERSION = 1
#: Longest task name [characters]: it titles the figure, the recording and the summary.
MAX_NAME_CHARS = 200
#: Default shortest segment duration [s]: one period of a 1 kHz controller. Merged repeated
#: via-points keep their zero-length segment.
MIN_SEGMENT_S = 1e-3
#: Most via-points a task may plan (its waypoints, and with ``path.mode: linear`` the poses
#: inserted between them): the timing scales to thousands, and 5000 via-points are already
#: a trajectory to be split.
MAX_VIA_POINTS = 5000
_TOP_KEYS = ("version", "name", "robot", "waypoints", "limits", "ik", "path", "trajectory", "optimizer")
PATH_MODES = ("joint", "linear")
_LIMIT_KEYS = {q.key: q.name for q in LIMITED}
_LIMIT_KEY_OF = {**{name: key for key, name in _LIMIT_KEYS.items()}, "lower": PROFILE_QUANTITIES[0].key,
                 "upper": PROFILE_QUANTITIES[0].key}
_COMMON_OPTIMIZER_KEYS = ("algorithm", "seed", "bounds_s", "objective", "weights", "time_limit_s")
#: Default wall-time limit of the timing optimization [s]: past it, the best timing found so far is kept.
TIME_LIMIT_S = 120.0


#: Every number in a list of angles (joint waypoints, ranges, hints, start, roll-pitch-yaw) [deg]:
#: 277 turns either way (``LARGEST_POSITION_DEG``).
ANGLE_DEG = Range(-LARGEST_POSITION_DEG, LARGEST_POSITION_DEG)
#: Every velocity, acceleration and jerk limit [deg/s^d].
LIMIT_DEG = Range(*LIMIT_DEG_RANGE)
#: Every tool position coordinate [m].
POSITION_M = Range(-1e4, 1e4)
#: How far a quaternion's norm may be from 1, and a pose's R^T R from the identity (entrywise), before the
#: orientation is refused rather than normalised.
UNIT_TOLERANCE = 1e-3
#: Every joint torque limit [N m] (``limits.TORQUE_RANGE_NM``).
TORQUE_NM = Range(*TORQUE_RANGE_NM)
#: Allowed values of every single number of a task, by key path; ``bool`` marks a true/false
#: setting. The ``optimizer.*`` settings are the keyword arguments of the algorithms
#: (``timing.setting_names``), each with its range here. Upper caps keep memory and run time
#: bounded and catch unit mistakes.
RANGES: dict[str, Range | type] = {
    "ik.seed": Range(0, MAX_SEED, integer=True),
    "path.tolerance_m": Range(1e-5, 1),                               # [m]: 10 um (a robot's repeatability) to 1 m
    "path.tolerance_deg": Range(1e-3, 180),                           # [deg]
    "trajectory.sample_rate_hz": Range(0, 100_000, low_open=True),     # [Hz]: at most 100 kHz
    "trajectory.min_segment_s": Range(0, 10, low_open=True),           # [s]
    "limits.tool_speed_m_s": Range(1e-6, 1e3),                        # [m/s]
    "limits.tool_speed_deg_s": Range(1e-6, 1e6),                      # [deg/s]
    "optimizer.seed": Range(0, MAX_SEED, integer=True),
    "optimizer.time_limit_s": Range(0, 86_400, low_open=True),         # [s]: at most a day
    "optimizer.bounds_s[0]": Range(DURATION_BOUND_RANGE.low, 86_400),  # h_min [s]: 1 us to a day
    "optimizer.bounds_s[1]": Range(DURATION_BOUND_RANGE.low, 86_400),  # h_max [s]
    "optimizer.weights[0]": Range(1e-6, 1e6),                          # K_t [1/s]
    "optimizer.weights[1]": Range(0, 1e6),                             # K_j [s^5/rad^2]
    **{f"optimizer.{name}": rule for name, rule in SETTING_RANGES.items()},
}


@dataclass(frozen=True)
class RobotAwareLimits(ReadOnlyArrays):
    """Limits that need the robot's model, in SI units.

    Attributes:
        torque: (J,) joint torque limits [N m] (|tau| <= torque), ``"urdf"`` for the URDF's
            efforts, or None.
        tool_speed: the tool frame's largest linear speed [m/s], or None.
        tool_angular_speed: its largest angular speed [rad/s], or None.
    """

    torque: np.ndarray | str | None = None
    tool_speed: float | None = None
    tool_angular_speed: float | None = None

    def __post_init__(self):
        freeze_arrays(self)

    @property
    def given(self) -> bool:
        """Whether any of them is set."""
        return any(value is not None for value in (self.torque, self.tool_speed, self.tool_angular_speed))


@dataclass(frozen=True)
class CartesianWaypoint(ReadOnlyArrays):
    """A tool pose: position [m], orientation as a unit quaternion (x, y, z, w), optional joint hint [rad]."""

    position: np.ndarray
    quaternion_xyzw: np.ndarray
    hint: np.ndarray | None = None

    def __post_init__(self):
        freeze_arrays(self)


@dataclass(frozen=True)
class IKOptions(ReadOnlyArrays):
    """How IK picks a solution per waypoint (``ik.solve_waypoints``).

    Attributes:
        branch: ``optimal`` (dynamic programming over the sequence) or ``continuous``.
        start: the robot's configuration before the task [rad], or None.
        seed: seed of the random IK starts.
    """

    branch: str = "optimal"
    start: np.ndarray | None = None
    seed: int = 0

    def __post_init__(self):
        freeze_arrays(self)


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
class Task(ReadOnlyArrays):
    """A validated task, in SI units.

    Attributes:
        joint_waypoints: (n, J) joint via-points [rad], or None for a Cartesian task.
        cartesian_waypoints: tool poses, or None for a joint-space task.
        limits: per-quantity overrides: ``velocity``, ``acceleration``, ``jerk`` (J,) [SI]
            and ``lower``, ``upper`` (J,) [rad]; absent keys are absent limits.
        optimizer: ``algorithm``, ``seed``, ``bounds`` [s] or None, ``objective``, ``weights``,
            ``time_limit`` [s] or None, and ``settings`` passed to the algorithm.
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
                                                     "time_limit": TIME_LIMIT_S,
                                                     "objective": "time", "weights": (1.0, 1.0),
                                                     "settings": {}})
    source: Path | None = None
    ik: IKOptions = field(default_factory=IKOptions)
    path: PathOptions = field(default_factory=PathOptions)
    robot_limits: RobotAwareLimits = field(default_factory=RobotAwareLimits)

    def __post_init__(self):
        """Arrays read-only, and ``limits`` and ``optimizer`` (with its ``settings``) read-only mappings: a plan
        result holds its task as planned (a script that changed them after planning made the summary report
        values never planned)."""
        if isinstance(self.optimizer, dict):
            settings = self.optimizer.get("settings")
            object.__setattr__(self, "optimizer", ReadOnlyDict(
                {**self.optimizer, **({"settings": ReadOnlyDict(settings)} if isinstance(settings, dict) else {})}))
        if isinstance(self.limits, dict):
            object.__setattr__(self, "limits", ReadOnlyDict(self.limits))
        freeze_arrays(self)


# ---------------------------------------------------------------------------- primitives


def _mapping(value, path: str, allowed) -> dict:
    if not isinstance(value, dict):
        raise TaskError(path, f"must be a mapping, got {type(value).__name__}")
    for key in value:
        if key not in allowed:
            raise TaskError(key_path(path, key), f"unknown key; expected one of: {', '.join(allowed)}")
    return value


@contextmanager
def _at(path: str) -> Iterator[None]:
    """A ``validate`` check's ``InputError`` (the problem alone) as a ``TaskError`` at key ``path``."""
    try:
        yield
    except InputError as exc:
        raise TaskError(path, str(exc)) from None


def _number(value, path: str, *, integer: bool = False) -> float:
    """``value`` as a finite float (or int if ``integer``): ``validate.number``, its error at key ``path``."""
    with _at(path):
        return number(value, integer=integer)


def _ranged(value, path: str, rule: Range | type | None = None):
    """``value`` checked against ``rule`` (default ``RANGES[path]``): a number in its range, or true/false."""
    with _at(path):
        return ranged(value, RANGES[path] if rule is None else rule)


def _vector(value, path: str, rule: Range, length: int | None = None) -> np.ndarray:
    """A non-empty list of finite numbers in ``rule`` (of ``length`` values if given)."""
    if not isinstance(value, (list, tuple)):
        raise TaskError(path, f"must be a list of numbers, got {shown(value)}")
    if length is not None and len(value) != length:
        raise TaskError(path, f"must have {length} values, got {len(value)}")
    if not value:
        raise TaskError(path, "must have at least 1 value, got an empty list")
    for i, v in enumerate(value):  # every value a number before any range (an integer beyond a double's: its range)
        if isinstance(v, bool) or not isinstance(v, int):
            _number(v, f"{path}[{i}]")
    return np.array([_ranged(v, f"{path}[{i}]", rule) for i, v in enumerate(value)])


def _text(value, path: str) -> str:
    """A non-empty string without control characters."""
    if not isinstance(value, str) or not value:
        raise TaskError(path, f"must be a non-empty string, got {shown(value)}")
    if CONTROL_CHARACTERS.search(value):
        raise TaskError(path, f"must not contain control characters (nor line separators or bidirectional "
                              f"overrides), got {shown(value)}")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:  # a lone surrogate (a YAML escape such as "\ud800"): no file or figure can hold it
        raise TaskError(path, f"must be valid Unicode text, got {shown(value.encode('utf-8', 'replace').decode())}") \
            from None
    return value


def _said(text: str) -> str:
    """``text`` as it is when short, else cut by ``shown``."""
    return text if len(text) <= SHOWN_VALUE_CHARS else shown(text)


def _choice(value, path: str, known, what: str) -> str:
    """One of the names ``known``."""
    if not isinstance(value, str) or value not in known:
        raise TaskError(path, f"unknown {what} {shown(value)}; known: {', '.join(known)}")
    return value


# ---------------------------------------------------------------------------- sections


def _joint_waypoints(value, path: str) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or len(value) < 2:
        raise TaskError(path, "must be a list of at least 2 joint vectors")
    first = _vector(value[0], f"{path}[0]", ANGLE_DEG)
    rows = [first] + [_vector(v, f"{path}[{i}]", ANGLE_DEG, len(first)) for i, v in enumerate(value[1:], start=1)]
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
    position = _vector(entry["xyz_m"], f"{path}.xyz_m", POSITION_M, 3)
    if ("rpy_deg" in entry) == ("quat_xyzw" in entry):
        raise TaskError(path, "needs exactly one of rpy_deg or quat_xyzw")
    if "rpy_deg" in entry:
        quaternion = _quaternion_from_rpy(np.deg2rad(_vector(entry["rpy_deg"], f"{path}.rpy_deg", ANGLE_DEG, 3)))
    else:
        quaternion = _vector(entry["quat_xyzw"], f"{path}.quat_xyzw", Range(-math.inf), 4)
        norm = math.hypot(*quaternion)  # no overflow warning for huge entries: inf, refused below
        if not abs(norm - 1.0) <= UNIT_TOLERANCE:
            raise TaskError(f"{path}.quat_xyzw", f"must be a unit quaternion, norm is {norm:.6g}")
        quaternion = quaternion / norm
    hint = np.deg2rad(_vector(entry["hint_deg"], f"{path}.hint_deg", ANGLE_DEG)) if "hint_deg" in entry else None
    return CartesianWaypoint(position, quaternion, hint)


def _waypoints(value, path: str):
    section = _mapping(value, path, ("joints_deg", "cartesian"))
    if len(section) != 1:
        raise TaskError(path, "needs exactly one of joints_deg or cartesian")
    key, entries = next(iter(section.items()))
    if isinstance(entries, (list, tuple)) and len(entries) > MAX_VIA_POINTS:
        raise TaskError(f"{path}.{key}", f"has {len(entries)} waypoints; at most {MAX_VIA_POINTS} are planned at once "
                                         f"(split the task)")
    if "joints_deg" in section:
        return _joint_waypoints(section["joints_deg"], f"{path}.joints_deg"), None
    poses = section["cartesian"]
    if not isinstance(poses, (list, tuple)) or len(poses) < 2:
        raise TaskError(f"{path}.cartesian", "must be a list of at least 2 poses")
    return None, [_cartesian_waypoint(p, f"{path}.cartesian[{i}]") for i, p in enumerate(poses)]


_ROBOT_LIMIT_KEYS = ("torque_nm", "tool_speed_m_s", "tool_speed_deg_s")


def _robot_limits(section: dict, path: str) -> RobotAwareLimits:
    """``torque_nm`` (a list, or ``urdf``), ``tool_speed_m_s`` and ``tool_speed_deg_s`` of a limits section."""
    torque: np.ndarray | str | None = None
    given = section.get("torque_nm")
    if given == "urdf":
        torque = "urdf"
    elif isinstance(given, (list, tuple)):
        torque = _vector(given, f"{path}.torque_nm", TORQUE_NM)
    elif "torque_nm" in section:
        raise TaskError(f"{path}.torque_nm", f"must be a list of torques [N m], one per joint, or urdf (the "
                                             f"URDF's efforts), got {shown(given)}")
    speed = _ranged(section["tool_speed_m_s"], f"{path}.tool_speed_m_s") if "tool_speed_m_s" in section else None
    angular = _ranged(section["tool_speed_deg_s"], f"{path}.tool_speed_deg_s") \
        if "tool_speed_deg_s" in section else None
    return RobotAwareLimits(torque, speed, None if angular is None else math.radians(angular))


def _limits(value, path: str) -> dict[str, np.ndarray]:
    section = _mapping(value, path, (*_LIMIT_KEYS, "position_deg", *_ROBOT_LIMIT_KEYS))
    limits = {name: np.deg2rad(_vector(section[key], f"{path}.{key}", LIMIT_DEG))
              for key, name in _LIMIT_KEYS.items() if key in section}
    if "position_deg" in section:
        ranges = section["position_deg"]
        if not isinstance(ranges, (list, tuple)) or not ranges:
            raise TaskError(f"{path}.position_deg", f"must be a non-empty list of [lower, upper] pairs, "
                                                    f"got {shown(ranges)}")
        pairs = np.array([_vector(r, f"{path}.position_deg[{i}]", ANGLE_DEG, 2) for i, r in enumerate(ranges)])
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
    given = section["urdf"]  # a path object too, from Python (make_task)
    text = _text(os.fspath(given) if isinstance(given, os.PathLike) else given, f"{path}.urdf")
    if re.match(r"^[A-Za-z][A-Za-z0-9+.-]*://", text):  # (Path would read package://x as package:/x)
        raise TaskError(f"{path}.urdf", f"{_said(text)} is a URI; give the URDF as a file path (relative to the task "
                                        f"file, or absolute): the planner does not resolve package:// or fetch URLs")
    urdf = Path(text)
    candidates = [urdf] if urdf.is_absolute() else [p for p in ((base / urdf) if base else None, urdf) if p]
    try:
        for candidate in candidates:
            if candidate.is_file():  # absolute, links kept: its limits file is the one beside the path named
                return RobotSpec(Path(os.path.abspath(candidate)), None, tool)
        other = next((candidate for candidate in candidates if candidate.exists()), None)
    except OSError as exc:  # a name too long, say
        raise TaskError(f"{path}.urdf", f"cannot read {_said(str(urdf))} ({exc.strerror or exc})") from None
    if other is not None:
        what = "a folder" if other.is_dir() else "a device, pipe or socket"
        raise TaskError(f"{path}.urdf", f"{_said(str(urdf))} is {what}, not a URDF file")
    raise TaskError(f"{path}.urdf", f"file not found: {_said(str(urdf))}{path_encoding_advice(str(urdf))}")


def _ik(value, path: str) -> IKOptions:
    section = _mapping(value, path, ("branch", "start_deg", "seed"))
    branch = _choice(section.get("branch", "optimal"), f"{path}.branch", BRANCH_RULES, "branch rule")
    start = np.deg2rad(_vector(section["start_deg"], f"{path}.start_deg", ANGLE_DEG)) if "start_deg" in section \
        else None
    seed = _ranged(section["seed"], f"{path}.seed") if "seed" in section else 0
    return IKOptions(branch, start, seed)


def _path(value, path: str) -> PathOptions:
    section = _mapping(value, path, ("mode", "tolerance_m", "tolerance_deg"))
    mode = _choice(section.get("mode", "joint"), f"{path}.mode", PATH_MODES, "path mode")
    default = PathOptions()
    for key in ("tolerance_m", "tolerance_deg"):
        if key in section and mode != "linear":
            raise TaskError(f"{path}.{key}", f"bounds the tool's deviation from straight lines, which only "
                                             f"{path}.mode: linear follows (here {mode}): remove it, or set "
                                             f"mode: linear")
    tolerance_m = _ranged(section["tolerance_m"], f"{path}.tolerance_m") \
        if "tolerance_m" in section else default.tolerance_m
    tolerance_rad = np.deg2rad(_ranged(section["tolerance_deg"], f"{path}.tolerance_deg")) \
        if "tolerance_deg" in section else default.tolerance_rad
    return PathOptions(mode, tolerance_m, float(tolerance_rad))


def _optimizer(value, path: str) -> dict:
    value = {} if value is None else value
    if not isinstance(value, dict):
        raise TaskError(path, f"must be a mapping, got {type(value).__name__}")
    algorithm = _choice(value.get("algorithm", "default"), f"{path}.algorithm", OPTIMIZERS, "algorithm")
    parameters = setting_names(algorithm)
    section = _mapping(value, path, _COMMON_OPTIMIZER_KEYS + parameters)
    settings: dict[str, Any] = {}
    result = {"algorithm": algorithm, "seed": 0, "bounds": None, "objective": "time", "weights": (1.0, 1.0),
              "time_limit": TIME_LIMIT_S, "settings": settings}
    for key, item in section.items():
        where = f"{path}.{key}"
        if key == "algorithm":
            continue
        if key == "seed":
            if algorithm == "nlp":
                seeded = ", ".join(name for name in OPTIMIZERS if name != "nlp")
                raise TaskError(where, f"the nlp algorithm is deterministic and uses no seed: remove it, or choose "
                                       f"a search that does ({seeded})")
            result["seed"] = _ranged(item, where)
        elif key == "time_limit_s":
            result["time_limit"] = float(_ranged(item, where))
        elif key in ("bounds_s", "weights"):
            if not isinstance(item, (list, tuple)) or len(item) != 2:
                raise TaskError(where, f"must be a list of 2 numbers, got {shown(item)}")
            pair = tuple(float(_ranged(entry, f"{where}[{i}]")) for i, entry in enumerate(item))
            if key == "bounds_s" and pair[0] > pair[1]:
                raise TaskError(where, f"lower bound {pair[0]} exceeds upper bound {pair[1]}")
            result["bounds" if key == "bounds_s" else "weights"] = pair
        elif key == "objective":
            result["objective"] = _choice(item, where, OBJECTIVES, "objective")
        else:
            settings[key] = _ranged(item, where)
    if "weights" in section and result["objective"] != "time-jerk":
        raise TaskError(f"{path}.weights", f"only the time-jerk objective has weights (here {path}.objective is "
                                           f"{result['objective']}): remove them, or set objective: time-jerk")
    try:
        checked_settings(algorithm, settings)
    except SettingError as exc:
        raise TaskError(f"{path}.{exc.setting}", exc.problem) from None
    return result


def _trajectory(value, path: str) -> tuple[str, float, float]:
    section = _mapping({} if value is None else value, path, ("family", "sample_rate_hz", "min_segment_s"))
    family = _choice(section.get("family", "hybrid"), f"{path}.family", FAMILIES, "family")
    rate = _ranged(section["sample_rate_hz"], f"{path}.sample_rate_hz") if "sample_rate_hz" in section else 100.0
    minimum = _ranged(section["min_segment_s"], f"{path}.min_segment_s") \
        if "min_segment_s" in section else MIN_SEGMENT_S
    return family, rate, minimum


# ---------------------------------------------------------------------------- entry points


def check_limit_counts(limits: dict[str, np.ndarray], joints: int, context: str) -> None:
    """Every limit override has one value per joint; the error names the task key."""
    for key, values in limits.items():
        if len(values) != joints:
            raise TaskError(f"limits.{_LIMIT_KEY_OF[key]}", f"must have {joints} value{'s' * (joints != 1)} {context}, "
                                                            f"got {len(values)}")


def _check_joint_counts(joints: int, limits: dict[str, np.ndarray]) -> None:
    """Via-points of ``joints`` values and the limit lists agree (a task without a robot).

    When every limit list gives the same other count, the via-points are the odd one out
    and are named; otherwise the limit list that differs from the via-points is.
    """
    counts = {len(values) for values in limits.values()}
    if len(counts) == 1 and joints not in counts:
        raise TaskError("waypoints.joints_deg", f"via-points have {joints} values each, but every limit list "
                                                f"has {counts.pop()} (one per joint)")
    check_limit_counts(limits, joints, "(one per joint, as the via-points have)")


def parse_task(data, *, name: str = "task", source: str | os.PathLike | None = None) -> Task:
    """Validate a task given as plain data (the parsed YAML)."""
    document = _mapping(data, "", _TOP_KEYS)
    if "version" not in document:
        raise TaskError("version", f"is required (use version: {SCHEMA_VERSION})")
    version = document["version"]
    if type(version) is not int or version != SCHEMA_VERSION:  # true is no version, nor is 1.0
        raise TaskError("version", f"unsupported version {shown(version)}; this planner reads {SCHEMA_VERSION}")
    if "waypoints" not in document:
        raise TaskError("waypoints", "is required")
    if source is not None and not isinstance(source, (str, os.PathLike)):
        raise TaskError("", f"a task's source is the path of its file (text or path-like) or None, got "
                            f"{shown(source)}")
    base = Path(source).parent if source is not None else None
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
    robot_limits = _robot_limits(document["limits"], "limits") if "limits" in document else RobotAwareLimits()
    if robot_limits.given and robot is None:
        given = [key for key in _ROBOT_LIMIT_KEYS if key in document["limits"]]
        raise TaskError(f"limits.{given[0]}", "needs a robot (its dynamics and tool frame): give robot")
    if robot is None and not any(quantity.name in limits for quantity in LIMITED):
        raise TaskError("limits", f"a joint-space task without a robot needs {', '.join(q.key for q in LIMITED[:-1])} "
                                  f"or {LIMITED[-1].key}")
    if joints is not None and robot is None:  # a robot's joint count decides (``pipeline.robot_limits``)
        _check_joint_counts(joints.shape[1], limits)
    family, rate, min_segment = _trajectory(document.get("trajectory"), "trajectory")
    optimizer = _optimizer(document.get("optimizer"), "optimizer")
    if optimizer["bounds"] is not None and min_segment > optimizer["bounds"][1]:
        raise TaskError("trajectory.min_segment_s", f"{min_segment:g} s exceeds the upper duration bound "
                                                    f"optimizer.bounds_s[1] = {optimizer['bounds'][1]:g} s")
    if "name" in document:
        label = _text(document["name"], "name")
    else:
        try:
            label = _text(name, "name")
        except TaskError as exc:  # the file's name: a byte that is no UTF-8, an escape sequence, ...
            raise TaskError("name", f"is not given, so it would be the task file's name, which {exc.problem}; "
                                    f"add a name: key to the task") from None
    if len(label) > MAX_NAME_CHARS:
        raise TaskError("name", f"must be at most {MAX_NAME_CHARS} characters (it titles figures and files), "
                                f"got {len(label)}")
    return Task(label, joints, cartesian, robot, limits, family, rate, min_segment, optimizer,
                None if source is None else Path(source), ik, path, robot_limits)


def _degrees(values) -> list:
    """Radians (any nesting) as plain lists of degrees."""
    return np.rad2deg(np.asarray(values, dtype=float)).tolist()


def task_document(task: Task) -> dict:
    """The task-file document of a ``Task`` (the inverse of ``parse_task``, in degrees).

    Raises:
        TaskError: ``task`` is not a ``Task`` or holds values no task file could (a hand-made one).
    """
    if not isinstance(task, Task):
        raise TaskError("", f"not a Task: {type(task).__name__}")
    field = "name"  # the Task's field being written, for a refusal
    try:
        document = {"version": SCHEMA_VERSION, "name": task.name}
        field = "robot"
        if task.robot is not None:
            robot = {"urdf": str(task.robot.urdf)} if task.robot.urdf is not None else {"name": task.robot.name}
            document["robot"] = robot | ({"tool_frame": task.robot.tool_frame} if task.robot.tool_frame else {})
        field = "cartesian_waypoints"
        if task.cartesian_waypoints is not None:
            document["waypoints"] = {"cartesian": [
                {"xyz_m": np.asarray(w.position, dtype=float).tolist(),
                 "quat_xyzw": np.asarray(w.quaternion_xyzw, dtype=float).tolist()}
                | ({"hint_deg": _degrees(w.hint)} if w.hint is not None else {}) for w in task.cartesian_waypoints]}
            document["ik"] = {"branch": task.ik.branch, "seed": task.ik.seed} | (
                {"start_deg": _degrees(task.ik.start)} if task.ik.start is not None else {})
            document["path"] = {"mode": task.path.mode} | ({"tolerance_m": task.path.tolerance_m,
                                                            "tolerance_deg": float(np.rad2deg(task.path.tolerance_rad))}
                                                           if task.path.mode == "linear" else {})
        elif task.joint_waypoints is not None:
            field = "joint_waypoints"
            document["waypoints"] = {"joints_deg": _degrees(task.joint_waypoints)}
            ik, default = task.ik, IKOptions()
            if (ik.branch, ik.seed, ik.start is None) != (default.branch, default.seed, True):
                document["ik"] = {"branch": ik.branch, "seed": ik.seed}  # as a file would give it: refused
            if task.path != PathOptions():
                document["path"] = {"mode": task.path.mode}
        else:
            document["waypoints"] = None
        field = "limits"
        limits: dict[str, Any] = {_LIMIT_KEY_OF[name]: _degrees(values) for name, values in task.limits.items()
                                  if name not in ("lower", "upper")}
        if "lower" in task.limits or "upper" in task.limits:
            limits["position_deg"] = np.stack((_degrees(task.limits["lower"]), _degrees(task.limits["upper"])),
                                              axis=-1).tolist()
        field, given = "robot_limits", task.robot_limits
        if given.torque is not None:
            limits["torque_nm"] = given.torque if isinstance(given.torque, str) else np.asarray(given.torque).tolist()
        if given.tool_speed is not None:
            limits["tool_speed_m_s"] = given.tool_speed
        if given.tool_angular_speed is not None:
            limits["tool_speed_deg_s"] = math.degrees(given.tool_angular_speed)
        if limits:
            document["limits"] = limits
        field = "family, sample_rate_hz or min_segment_s"
        document["trajectory"] = {"family": task.family, "sample_rate_hz": task.sample_rate_hz,
                                  "min_segment_s": task.min_segment_s}
        field, settings = "optimizer", task.optimizer
        unknown = sorted(set(settings) - set(_OPTIMIZER_FIELDS), key=str)
        if unknown:  # a Task changed by hand: its optimizer holds parsed fields, not the task file's keys
            raise TaskError(f"optimizer.{unknown[0]}", f"is no field of a Task's optimizer (it holds "
                                                       f"{', '.join(_OPTIMIZER_FIELDS)}; the task file's keys, such "
                                                       f"as bounds_s, are parsed into these)")
        # nlp refuses a seed: its parsed default 0 is left out, any other is kept, and refused as in a file
        seeded = {"seed": settings["seed"]} if settings["algorithm"] != "nlp" or settings["seed"] != 0 else {}
        document["optimizer"] = {"algorithm": settings["algorithm"], **seeded, "time_limit_s": settings["time_limit"],
                                 "objective": settings["objective"], **settings["settings"]} | (
            {"weights": list(settings["weights"])} if settings["objective"] == "time-jerk" else {}) | (
            {"bounds_s": list(settings["bounds"])} if settings["bounds"] is not None else {})
    except TaskError:  # one named here (an optimizer field no Task holds)
        raise
    except (TypeError, ValueError, AttributeError, LookupError, ArithmeticError) as exc:
        raise TaskError("", f"the Task's {field} holds values no task file could ({type(exc).__name__}: {exc}); "
                            f"build tasks with load_task, parse_task or make_task") from None
    return plain_values(document)


#: The fields of a parsed ``Task.optimizer`` (``_optimizer``).
_OPTIMIZER_FIELDS = ("algorithm", "seed", "bounds", "objective", "weights", "time_limit", "settings")


def check_task(task: Task) -> Task:
    """``task`` as a task file would give it (``task_document``, then ``parse_task``): a ``Task`` made
    by hand gets the same errors as a task file, and its values the same types (a list of via-points
    where an array belongs crashed the planner further on). Its own numbers are kept where the round
    trip through degrees only rounded them (``_unrounded``)."""
    parsed = parse_task(task_document(task), name=task.name, source=task.source)
    return dataclasses.replace(
        parsed, joint_waypoints=_unrounded(task.joint_waypoints, parsed.joint_waypoints),
        limits={name: _unrounded(task.limits.get(name), values) for name, values in parsed.limits.items()},
        ik=dataclasses.replace(parsed.ik, start=_unrounded(task.ik.start, parsed.ik.start)))


def _unrounded(given, parsed):
    """``given``'s numbers (a copy, as floats) where ``parsed`` holds the same to within the rounding of
    radians to degrees and back (1e-14 relative), else ``parsed``: planning a ``Task`` must not move
    its values by an ulp (quintic's NLP converged on one via-point sequence and stopped at its
    iteration cap on the same one re-parsed, 12 % slower)."""
    if parsed is None or given is None:
        return parsed
    try:
        kept = np.array(given, dtype=float)
    except (TypeError, ValueError):
        return parsed
    if kept.shape != np.shape(parsed) or not np.allclose(kept, parsed, rtol=1e-14, atol=0.0):
        return parsed
    return kept


def plain_values(value, path: str = "", depth: int = 0):
    """Python and numpy values as the plain lists, dicts and numbers a parsed task file holds (any
    ``Mapping`` becomes a dict), nested at most ``MAX_NESTING`` deep as in a file (a list that
    contains itself is refused, not recursed into without end)."""
    if depth > MAX_NESTING:
        raise TaskError(path if len(path) <= 60 else f"{path[:60]}...",
                        f"nested deeper than {MAX_NESTING} levels (a list or mapping containing itself?)")
    if isinstance(value, np.ma.MaskedArray) and np.ma.is_masked(value):
        index = [int(i) for i in np.argwhere(np.ma.getmaskarray(value))[0]]
        raise TaskError(path + "".join(f"[{i}]" for i in index),
                        "is a masked entry of a numpy masked array, not a number "
                        "(give the values, or fill the masked ones: numpy.ma.filled)")
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {key: plain_values(item, key_path(path, key), depth + 1) for key, item in value.items()}
    if isinstance(value, (list, tuple, Iterator)):  # a generator of rows too
        return [plain_values(item, f"{path}[{index}]", depth + 1) for index, item in enumerate(value)]
    return value


def pose_entry(pose=None, *, xyz_m=None, rpy_deg=None, quat_xyzw=None, hint_deg=None,
               where: str = "waypoints.cartesian") -> dict:
    """One Cartesian waypoint of the task schema, from a ``pinocchio.SE3`` (``pose``) or from a
    position [m] and an orientation (``rpy_deg`` [deg], roll-pitch-yaw, or ``quat_xyzw``).

    Raises:
        TaskError: at key path ``where``: ``pose`` is no SE3, or its rotation is no rotation matrix
            (R^T R off the identity by more than ``UNIT_TOLERANCE``, or det R < 0), or a pose and a
            position or orientation both given (the pose's would replace them).
    """
    if pose is not None:
        import pinocchio as pin
        given = [key for key, value in (("xyz_m", xyz_m), ("rpy_deg", rpy_deg), ("quat_xyzw", quat_xyzw))
                 if value is not None]
        if given:
            raise TaskError(where, f"give either a pose or xyz_m with an orientation, not both (a pose and "
                                   f"{', '.join(given)})")
        if not isinstance(pose, pin.SE3):
            raise TaskError(where, f"a pose must be a pinocchio.SE3, got {type(pose).__name__}")
        rotation = np.asarray(pose.rotation, dtype=float)
        if rotation.shape == (3, 3) and np.isfinite(rotation).all():
            off = float(np.abs(rotation.T @ rotation - np.eye(3)).max())
            if off > UNIT_TOLERANCE or np.linalg.det(rotation) < 0:
                what = f"R^T R is off the identity by {off:.3g}" if off > UNIT_TOLERANCE else "a reflection (det R < 0)"
                raise TaskError(where, f"the pose's rotation is not a rotation matrix: {what}")
        xyz_m, quat_xyzw = pose.translation, pin.Quaternion(pose.rotation).coeffs()  # coeffs: x, y, z, w
    entry = {"xyz_m": xyz_m, "rpy_deg": rpy_deg, "quat_xyzw": quat_xyzw, "hint_deg": hint_deg}
    return plain_values({key: value for key, value in entry.items() if value is not None})


def make_task(*positional, name: str = "task", robot: dict | None = None, joints_deg=None, poses=None,
              limits: dict | None = None, ik: dict | None = None, path: dict | None = None,
              trajectory: dict | None = None, optimizer: dict | None = None, **unknown) -> Task:
    """A task built in Python, validated exactly as a task file (``parse_task``; errors name the same keys).

    Args:
        *positional: none is taken (a ``TaskError`` says so).
        name: the task's name (output folders, the recording).
        robot: ``{"urdf": path, "tool_frame": ...}`` or ``{"name": "ur5", "tool_frame": "tool0"}``.
        joints_deg: (n, J) joint via-points [deg] (a joint-space task), or
        poses: n tool poses: ``pinocchio.SE3`` objects or ``pose_entry`` mappings (a Cartesian task).
        limits: the task file's ``limits`` section, keys as documented there (numpy arrays are accepted
            wherever the file has lists); so are the four below.
        ik: the ``ik`` section.
        path: the ``path`` section.
        trajectory: the ``trajectory`` section.
        optimizer: the ``optimizer`` section.
        **unknown: none is taken (a ``TaskError`` names the first).

    Relative URDF paths are taken from the working directory.

    Raises:
        TaskError: as ``parse_task``, and for a positional argument or a keyword that is no section.
    """
    keywords = "name, robot, joints_deg or poses, limits, ik, path, trajectory, optimizer"
    if positional:
        raise TaskError("", f"make_task takes keywords only ({keywords}); got {len(positional)} positional "
                            f"argument{'s' * (len(positional) > 1)}")
    if unknown:
        raise TaskError(shown(next(iter(unknown)))[1:-1], f"is no keyword of make_task; it takes {keywords}")
    if (joints_deg is None) == (poses is None):
        raise TaskError("waypoints", "give exactly one of joints_deg or poses")
    if poses is not None and (isinstance(poses, (str, bytes, Mapping)) or not isinstance(poses, Iterable)):
        raise TaskError("waypoints.cartesian", f"poses must be a list of tool poses (pinocchio.SE3 objects or "
                                               f"pose_entry mappings), got {type(poses).__name__}")
    waypoints = {"joints_deg": joints_deg} if poses is None else {"cartesian": [
        entry if isinstance(entry, Mapping) else pose_entry(entry, where=f"waypoints.cartesian[{i}]")
        for i, entry in enumerate(poses)]}
    document = {"version": SCHEMA_VERSION, "name": name, "waypoints": waypoints}
    for key, section in (("robot", robot), ("limits", limits), ("ik", ik), ("path", path),
                         ("trajectory", trajectory), ("optimizer", optimizer)):
        if section is not None:
            document[key] = section
    return parse_task(plain_values(document), name=name)


def load_task(path) -> Task:
    """Read and validate a YAML task file (see the module docstring for what a file may be)."""
    if not isinstance(path, (str, os.PathLike)) or not isinstance(os.fspath(path), str):
        raise TaskError("", f"a task file is given by its path (text or path-like), not {type(path).__name__}")
    if not os.fspath(path).strip():
        raise TaskError("", "the task file's path is empty (an unset shell variable?); give a path")
    path = Path(path)
    data = read_yaml(path, "task file")
    if data is None:
        raise TaskError(str(path), "the task file is empty (nothing but blanks and comments); a task starts "
                                   "with version: 1 and gives waypoints:")
    if not isinstance(data, dict):
        raise TaskError(str(path), f"the task file holds a {_yaml_kind(data)} where a task is a mapping of keys "
                                   f"(version: 1, waypoints: ..., limits: ...)")
    return parse_task(data, name=path.stem[:MAX_NAME_CHARS], source=path)


def _yaml_kind(value) -> str:
    """What a parsed YAML value is, in YAML's words: list, text, number, true/false."""
    if isinstance(value, list):
        return "list"
    if isinstance(value, bool):
        return "true/false value"
    return "number" if isinstance(value, (int, float)) else "text" if isinstance(value, str) else type(value).__name__
