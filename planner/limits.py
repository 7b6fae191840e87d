"""Per-joint kinematic limits in SI units, any of which may be absent (= unlimited), and how
values are said to a user: in degrees (the task files' units) with the joint's name."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from .errors import InputError, shown
from .read_only import ReadOnlyArrays, freeze_arrays
from .validate import finite_array, float_array


@dataclass(frozen=True)
class Quantity:
    """One derivative of a joint's motion, and every name it goes by.

    Attributes:
        name: ``position``, ``velocity``, ``acceleration``, ``jerk``.
        order: the derivative order d (0 = position): scaling every duration by s divides it by s^d.
        unit: its SI unit (``rad/s``); degree_unit: its unit in task files, messages and
            outputs (``deg/s``).
        key: its key in task files, robot limits files and ``summary.json`` (``velocity_deg_s``).
        column: the prefix of its ``trajectory.csv`` columns (``v``: ``v_<joint>_deg_s``).
    """

    name: str
    order: int
    unit: str
    degree_unit: str
    key: str
    column: str

    @property
    def key_unit(self) -> str:
        """The degree unit as written in keys and column names (``deg_s2``)."""
        return self.key.removeprefix(f"{self.name}_")


#: The one table of the quantities: position and the limited derivatives 1..3, in order.
PROFILE_QUANTITIES = (
    Quantity("position", 0, "rad", "deg", "position_deg", "q"),
    Quantity("velocity", 1, "rad/s", "deg/s", "velocity_deg_s", "v"),
    Quantity("acceleration", 2, "rad/s^2", "deg/s^2", "acceleration_deg_s2", "a"),
    Quantity("jerk", 3, "rad/s^3", "deg/s^3", "jerk_deg_s3", "j"),
)
#: The derivatives with magnitude limits (orders 1..3).
LIMITED = PROFILE_QUANTITIES[1:]
#: Names of the derivative orders 1..3, as used in ratios, reports and task files.
QUANTITIES = tuple(q.name for q in LIMITED)
#: SI units of position and of the derivative orders 1..3.
UNITS = tuple(q.unit for q in PROFILE_QUANTITIES)
#: Units of position and of the derivative orders 1..3 in messages and reports (task files use degrees).
DEGREE_UNITS = tuple(q.degree_unit for q in PROFILE_QUANTITIES)

#: The largest joint position [deg] (277 turns) a task file's angle or a timing problem's via-point may
#: be: caps like this catch unit mistakes and keep the arithmetic finite (via-points of 1e308 rad overflowed
#: the spline's arithmetic).
LARGEST_POSITION_DEG = 1e5
#: The range [deg/s^d] any velocity, acceleration or jerk limit may take, in a task file or a robot's
#: limits file (1e-320 underflowed to 0 and 1e308 overflowed in the arithmetic).
LIMIT_DEG_RANGE = (1e-12, 1e15)
#: Every joint torque limit [N m], a task's or a URDF's effort: a micro-actuator's to a large press's.
TORQUE_RANGE_NM = (1e-6, 1e7)
#: The one feasibility tolerance: constraint ratios up to 1 + this, positions up to this [rad]
#: outside their range, count as holding (rounding in the exact checks and in unit conversions,
#: such as a via-point written as -160 deg against a URDF bound of -2.792526803 rad).
FEASIBILITY_TOLERANCE = 1e-9
#: How near its range bound [rad] a via-point rests on it (``JointLimits.bound_sides``): the planner then
#: stops the joint there. A velocity left free must turn the joint within so small a gap (|v| <= sqrt(2 A
#: gap) under an acceleration limit A), which the cut rounds did not settle: hermite7's via-points 1.7e-9
#: .. 3.5e-8 rad inside their bounds were refused, those on them planned.
RESTING_DISTANCE = 1e-7
#: Most joints a set of limits is made for (``JointLimits.create``): a humanoid has tens; the cap keeps a
#: mistaken count from allocating without end.
MAX_JOINTS = 10_000


def ratio_exceeded(ratios) -> np.ndarray:
    """Where a constraint ratio (|value| / limit, any shape) breaks its limit: above 1 +
    ``FEASIBILITY_TOLERANCE``, or not a number. The one test of a magnitude limit: the exact check
    (``KinematicFigures.violations``), the optimizers' feasibility and their repair all use it (the
    repair's time-scale factor within the tolerance left a jerk ratio up to 1 + 3e-9)."""
    return ~(np.asarray(ratios, dtype=float) <= 1.0 + FEASIBILITY_TOLERANCE)


def range_exceeded(excess) -> np.ndarray:
    """Where a distance [rad] outside a position range (any shape; 0 or less inside, ``JointLimits.range_excess``)
    breaks it: above ``FEASIBILITY_TOLERANCE``, or not a number. The one test of a position range, beside
    ``ratio_exceeded`` for the magnitudes: the exact check, the optimizers' feasibility and the NLP's."""
    return ~(np.asarray(excess, dtype=float) <= FEASIBILITY_TOLERANCE)


def bounds_exceeded(durations, bounds: tuple[float, float]) -> np.ndarray:
    """(...) whether durations (..., S) [s] leave the duration bounds (h_min, h_max) [s] in some segment: a
    ratio h / h_max or h_min / h above 1 + ``FEASIBILITY_TOLERANCE`` (``ratio_exceeded``, the tolerance of
    every limit; h_max may be inf and h_min 0)."""
    h = np.asarray(durations, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = np.maximum(h / bounds[1], bounds[0] / h)
    return np.asarray(ratio_exceeded(ratios).any(axis=-1))


def in_degrees(value: float, order: int) -> str:
    """A value [rad-based SI] of derivative ``order`` (0 = position) as the user reads it: "12.5 deg/s"; in
    its SI unit where degrees would overflow ("-1e+308 rad/s", not "-inf deg/s")."""
    with np.errstate(over="ignore", under="ignore"):
        degrees = float(np.rad2deg(value))
    if math.isfinite(value) and not math.isfinite(degrees):
        return f"{float(value):.6g} {UNITS[order]}"
    return f"{degrees:.6g} {DEGREE_UNITS[order]}"


def numbers_apart(value: float, bound: float) -> tuple[str, str]:
    """``value`` and the ``bound`` it passes with as many significant digits (6 to 17) as it takes for
    the two to read differently (27.0000000001 against 27)."""
    for digits in range(6, 18):
        said = (f"{value:.{digits}g}", f"{bound:.{digits}g}")
        if said[0] != said[1]:
            break
    return said


def seconds_text(value: float, decimals: int = 4) -> str:
    """A duration [s] to ``decimals`` decimals, or to as many significant digits where that would show fewer
    than two of them (a 9.9e-6 s trajectory read "0.0000 s")."""
    return f"{value:.{decimals}f}" if value >= 10.0 ** (1 - decimals) else f"{value:.{decimals}g}"


def in_degrees_apart(value: float, bound: float, order: int) -> tuple[str, str]:
    """``value`` and the ``bound`` it passes, as ``in_degrees`` but with as many significant digits
    as it takes for the two to read differently (-160.000001 deg against -160 deg, ``numbers_apart``)."""
    said = numbers_apart(float(np.rad2deg(value)), float(np.rad2deg(bound)))
    return f"{said[0]} {DEGREE_UNITS[order]}", f"{said[1]} {DEGREE_UNITS[order]}"


def default_joint_names(joints: int) -> tuple[str, ...]:
    """Names of joints that have none of their own (a joint-space task without a robot): joint1, joint2, ..."""
    return tuple(f"joint{j + 1}" for j in range(joints))


def _limit_vector(name: str, value, joints: int, fill: float) -> np.ndarray:
    if value is None:
        return np.full(joints, fill)
    array = float_array(f"{name} limits", value).reshape(-1)
    if array.shape != (joints,):
        raise InputError(f"{name} limits need {joints} values, got {array.size}")
    if np.isnan(array).any():
        joint = int(np.argmax(np.isnan(array)))
        raise InputError(f"{name} limits[{joint}] is NaN")
    return array


@dataclass(frozen=True)
class JointLimits(ReadOnlyArrays):
    """Position range and symmetric magnitude limits per joint.

    Attributes:
        lower, upper: (J,) position range [rad]; -inf / +inf where absent.
        velocity: (J,) [rad/s], acceleration: (J,) [rad/s^2], jerk: (J,) [rad/s^3];
            +inf where absent. Every given magnitude limit is > 0.
        names: (J,) the joints' names, used in every message about them
            (default ``default_joint_names``).
    """

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    names: tuple[str, ...] = ()

    @classmethod
    def create(cls, joints: int, *, lower=None, upper=None, velocity=None, acceleration=None,
               jerk=None, names=None) -> "JointLimits":
        """Limits for ``joints`` joints; ``None`` means absent for every joint."""
        if isinstance(joints, bool) or not isinstance(joints, (int, np.integer)) or not 1 <= joints <= MAX_JOINTS:
            raise InputError(f"the joint count must be a whole number from 1 to {MAX_JOINTS}, got {joints!r}")
        return cls(_limit_vector("lower position", lower, joints, -np.inf),
                   _limit_vector("upper position", upper, joints, np.inf),
                   _limit_vector("velocity", velocity, joints, np.inf),
                   _limit_vector("acceleration", acceleration, joints, np.inf),
                   _limit_vector("jerk", jerk, joints, np.inf), () if names is None else names)

    def __post_init__(self):
        joints = len(np.atleast_1d(self.lower))
        given = tuple(self.names) if isinstance(self.names, Iterable) and not isinstance(self.names, (str, bytes)) \
            else None
        if given is None or not all(isinstance(name, str) and name for name in given):
            raise InputError(f"joint names must be a list of non-empty texts, got "
                             f"{shown(self.names if given is None else list(given))}")
        names = tuple(str(name) for name in given) or default_joint_names(joints)
        if len(names) != joints:
            raise InputError(f"{len(names)} joint names for {joints} joints")
        if len(set(names)) != joints:
            raise InputError(f"joint names must be distinct (errors name joints by them), got {shown(list(names))}")
        object.__setattr__(self, "names", names)
        for name in ("lower", "upper", *QUANTITIES):
            object.__setattr__(self, name, _limit_vector(name, getattr(self, name), joints, np.inf))
        freeze_arrays(self)
        low, high = np.deg2rad(LIMIT_DEG_RANGE)
        for order, name in enumerate(QUANTITIES, start=1):
            values = getattr(self, name)
            bad = np.flatnonzero((values < low) | ((values > high) & np.isfinite(values)))
            if bad.size:
                j = int(bad[0])
                raise InputError(f"{name} limit of joint {names[j]} is {in_degrees(values[j], order)}; limits must "
                                 f"be from {LIMIT_DEG_RANGE[0]:g} to {LIMIT_DEG_RANGE[1]:g} {DEGREE_UNITS[order]}, "
                                 f"or absent (inf)")
        bad = np.flatnonzero(self.lower >= self.upper)
        if bad.size:
            j = int(bad[0])
            raise InputError(f"joint {names[j]} position range [{in_degrees(self.lower[j], 0)}, "
                             f"{in_degrees(self.upper[j], 0)}] is empty")

    @property
    def joint_count(self) -> int:
        """J, the number of joints."""
        return len(self.lower)

    @property
    def magnitudes(self) -> np.ndarray:
        """(3, J) velocity, acceleration and jerk limits [SI], +inf where absent."""
        return np.stack((self.velocity, self.acceleration, self.jerk))

    @property
    def has_position_range(self) -> bool:
        """Some joint has a lower or an upper position bound."""
        return bool(np.isfinite(self.lower).any() or np.isfinite(self.upper).any())

    def range_excess(self, low: np.ndarray, high: np.ndarray) -> np.ndarray:
        """(..., J) how far [rad] positions spanning [low, high] (each (..., J)) leave each joint's range; 0
        inside it (``range_exceeded`` tells whether that breaks the range)."""
        return np.maximum(np.maximum(self.lower - low, high - self.upper), 0.0)

    def range_violation(self, positions: np.ndarray) -> tuple[tuple[int, ...], str, float] | None:
        """The first position outside its joint's range by more than ``FEASIBILITY_TOLERANCE``, or None.

        Args:
            positions: (..., J) joint positions [rad].

        Returns:
            (index of the position in ``positions``, "lower" or "upper", the bound [rad] it passes).

        Raises:
            InputError: positions that are not finite numbers, or not J to a row.
        """
        positions = self._positions(positions)
        for side, outside in (("lower", range_exceeded(self.lower - positions)),
                              ("upper", range_exceeded(positions - self.upper))):
            hits = np.argwhere(outside)
            if hits.size:
                index = tuple(int(i) for i in hits[0])
                return index, side, float(getattr(self, side)[index[-1]])
        return None

    def ratios(self, max_abs: np.ndarray) -> np.ndarray:
        """Constraint ratios r_{j,d} = max|q^(d)| / limit_{j,d}; 0 where the limit is absent.

        Args:
            max_abs: (..., 3, J) maxima of |velocity|, |acceleration|, |jerk| [SI].
        """
        max_abs = float_array("maxima", max_abs)
        if max_abs.shape[-2:] != (3, self.joint_count):
            raise InputError(f"maxima must have shape (..., 3, {self.joint_count}), got {max_abs.shape}")
        return max_abs / self.magnitudes

    def bound_sides(self, positions: np.ndarray) -> np.ndarray:
        """(..., J) +1 / -1 where a position [rad] is on its joint's upper / lower bound (within
        ``RESTING_DISTANCE``), else 0.

        Raises:
            InputError: positions that are not numbers, or not J to a row.
        """
        positions = self._positions(positions)
        sides = np.where(np.abs(positions - self.upper) <= RESTING_DISTANCE, 1, 0)
        return np.where(np.abs(positions - self.lower) <= RESTING_DISTANCE, -1, sides)

    def _positions(self, positions) -> np.ndarray:
        """``positions`` (..., J) [rad] as finite floats with one column per joint."""
        array = float_array("positions", positions)
        if array.ndim == 0 or array.shape[-1] != self.joint_count:
            held = f"{array.shape[-1]} values" if array.ndim else "a single value"
            raise InputError(f"positions hold {held} per configuration; give {self.joint_count} values to a row "
                             f"(one per joint)")
        return finite_array("positions", array, array.ndim)

    def with_overrides(self, **values) -> "JointLimits":
        """A copy with the named fields (lower, upper, velocity, acceleration, jerk, names) replaced.

        Raises:
            InputError: a name that is none of these.
        """
        fields = {name: getattr(self, name) for name in ("lower", "upper", *QUANTITIES, "names")}
        unknown = sorted(set(values) - set(fields))
        if unknown:
            raise InputError(f"JointLimits has no field {unknown[0]!r}; it has: {', '.join(fields)}")
        fields.update({k: v for k, v in values.items() if v is not None})
        return JointLimits(**fields)


def time_scale_factor(ratios: np.ndarray) -> np.ndarray:
    """Smallest s with s * h feasible: max_j max(r_j1, r_j2^(1/2), r_j3^(1/3)).

    Scaling every duration by s divides velocity by s, acceleration by s^2 and
    jerk by s^3, so the scaled trajectory meets every magnitude limit and
    touches at least one.

    Args:
        ratios: (..., 3, J) constraint ratios.

    Returns:
        (...,) scale factors (0 when nothing is limited).

    Raises:
        InputError: ratios that are not numbers >= 0 (NaN included) of shape (..., 3, J), J >= 1.
    """
    ratios = float_array("ratios", ratios)
    if ratios.ndim < 2 or ratios.shape[-2] != 3 or ratios.shape[-1] == 0:
        raise InputError(f"ratios must have shape (..., 3, J) with J >= 1, got {ratios.shape}")
    if not np.all(ratios >= 0):  # NaN fails too
        raise InputError(f"ratios must be numbers >= 0, got {ratios[~(ratios >= 0)][0]}")
    # the order-th root of each quantity's ratio (its time-scaling exponent), by the correctly rounded roots
    root: dict[int, Callable[[np.ndarray], np.ndarray]] = {1: np.asarray, 2: np.sqrt, 3: np.cbrt}
    roots = np.stack([root[quantity.order](ratios[..., d, :]) for d, quantity in enumerate(LIMITED)])
    return roots.max(axis=(0, -1))


def rest_to_rest_time(distance: np.ndarray, limits: JointLimits) -> np.ndarray:
    """(..., J) a lower bound on the time [s] to move each joint by ``distance`` [rad] from rest to rest.

    Under one limit alone the shortest motion takes D / V (velocity), 2 sqrt(D / A)
    (bang-bang acceleration) or (32 D / Jk)^(1/3) (bang-bang jerk); the largest of the
    three is a lower bound under all of them. Absent limits contribute nothing.

    Args:
        distance: (..., J) non-negative joint displacements [rad].
        limits: the joints' limits.
    """
    distance = np.asarray(distance, dtype=float)
    velocity = distance / limits.velocity
    acceleration = 2.0 * np.sqrt(distance / limits.acceleration)
    jerk = np.cbrt(32.0 * distance / limits.jerk)
    return np.maximum.reduce([velocity, acceleration, jerk])
