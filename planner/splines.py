"""Piecewise polynomials and the via-point spline families (README, "The maths").

Conventions: coefficients in local time ``tau`` in ``[0, h_k]`` of each
segment, lowest order first, shaped (segments, joints, degree + 1), or
(batch, segments, joints, degree + 1) for a batch of candidate durations
(batch, segments). Units SI: [rad], [s].

Families:

* ``cubic``: cubic spline with two virtual knots (Lin, Chang & Luh), S = n + 1.
* ``hybrid``: ``cubic`` with its first and last segment replaced by the
  7th-order Hermite polynomials of the paper's method, S = n + 1.
* ``quintic``: interpolating quintic B-spline (Gasparetto & Zanotto), S = n - 1.
* ``hermite7``: one 7th-order Hermite segment per chord, C3, with free via-point
  velocity, acceleration and jerk (optimized by the NLP), S = n - 1.
* ``trigonometric``: ``hermite7``'s structure with Simon & Isik's order-4 trigonometric
  segments (``trigonometric.py``), coefficients (segments, joints, 8) in theta = 3 pi tau / (4 h).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial
from typing import Callable

import numpy as np
from scipy.linalg import solve_banded

from . import trigonometric
from .errors import InputError, shown
from .read_only import ReadOnlyArrays, freeze_arrays
from .validate import finite_array, float_array, positive_durations, positive_finite

#: Most samples ``PiecewisePolynomial.sample`` makes (each sample holds 4 x J floats): a cap on
#: memory whatever the trajectory's length and the sample rate.
MAX_SAMPLES = 1_000_000
#: Largest gap a built spline may leave, by rounding, at a via-point or between two segments: this
#: fraction of the largest |via-point| [rad], and at least this many radians.
BUILD_TOLERANCE = 1e-6
#: Coefficients smaller than this [rad/s^i] carry no motion: a cubic spline's joint at rest over hundreds
#: of segments decays geometrically towards them (and into subnormal numbers, which c_i h^i may lose).
NEGLIGIBLE = 1e-150
#: Kinds of segment a ``PiecewisePolynomial`` holds: ``power``, polynomials sum_i c_i tau^i in local time;
#: ``trigonometric``, the trigonometric polynomials of ``trigonometric.BASIS`` in theta = SPAN tau / h_k.
BASES = ("power", "trigonometric")


@dataclass(frozen=True)
class PiecewisePolynomial(ReadOnlyArrays):
    """A joint trajectory: one polynomial per segment and joint, in local time.

    Attributes:
        durations: (S,) segment durations h_k [s], all > 0.
        coefficients: (S, J, D+1) coefficients of q(tau) = sum_i c_i tau^i [rad, s]; with the
            ``trigonometric`` basis (S, J, 8), those a_i of ``trigonometric.BASIS`` in theta = SPAN tau / h_k
            [rad] (trigonometric polynomials).
        via_knots: indices of the knots (0..S) at which the given via-points are passed.
        basis: ``power`` or ``trigonometric`` (``BASES``).
    """

    durations: np.ndarray
    coefficients: np.ndarray
    via_knots: np.ndarray
    basis: str = "power"

    def __post_init__(self):
        if not isinstance(self.basis, str) or self.basis not in BASES:
            raise InputError(f"basis must be one of {', '.join(BASES)}, got {shown(self.basis)}")
        durations = positive_durations("durations", self.durations)
        coefficients = finite_array("coefficients", self.coefficients, 3)
        if durations.ndim != 1 or coefficients.shape[0] != durations.shape[0]:
            raise InputError(
                f"coefficients shape {coefficients.shape} does not match {durations.shape[-1]} durations")
        if 0 in coefficients.shape:
            raise InputError(f"coefficients must be (segments, joints, degree + 1), each at least 1, got shape "
                             f"{coefficients.shape}")
        knots = float_array("via_knots", self.via_knots)
        if (knots.ndim != 1 or not np.all(knots == np.round(knots)) or knots.min(initial=0) < 0
                or knots.max(initial=0) > durations.shape[0] or np.any(np.diff(knots) < 0)):
            raise InputError(f"via_knots must be non-decreasing knot indices from 0 to {durations.shape[0]} (the "
                             f"segment count; repeated via-points share a knot), got {shown(self.via_knots)}")
        with np.errstate(over="ignore"):
            total = durations.sum()
        if not np.isfinite(total):
            raise InputError(f"the durations sum to more than any number of seconds ({durations.max():g} s at most "
                             f"each): the total time must be finite")
        if self.basis == "trigonometric" and coefficients.shape[2] != len(trigonometric.BASIS):
            raise InputError(f"trigonometric coefficients must be (segments, joints, {len(trigonometric.BASIS)}), "
                             f"got shape {coefficients.shape}")
        lost = _lost_segments(coefficients, durations, self.basis)
        if lost.any():
            k = int(np.argwhere(lost)[0][0])
            terms = "a_i (SPAN / h)^d" if self.basis == "trigonometric" else "c_i h^i"
            raise InputError(f"segment {k}'s duration {durations[k]:.3g} s with its coefficients is beyond what "
                             f"floating point holds ({terms} overflows or vanishes); give durations of a physical size")
        object.__setattr__(self, "durations", durations)
        object.__setattr__(self, "coefficients", coefficients)
        object.__setattr__(self, "via_knots", knots.astype(int))
        freeze_arrays(self)

    @property
    def width(self) -> int:
        """The coefficients per segment and joint: D + 1, or 8 for the ``trigonometric`` basis."""
        return self.coefficients.shape[2]

    @property
    def segment_count(self) -> int:
        """S, the number of segments."""
        return self.durations.shape[0]

    @property
    def segment_degrees(self) -> list[int]:
        """(S,) the polynomial degree of each segment: its highest power with a non-zero coefficient
        in any joint (the array is padded with zeros to the family's highest degree)."""
        return self._degrees().tolist()

    def _degrees(self) -> np.ndarray:
        """``segment_degrees`` as an array (S,), found without a loop over segments (``evaluate`` needs
        them at every call); for the ``trigonometric`` basis, the highest basis function used."""
        nonzero = np.any(self.coefficients != 0.0, axis=1)  # (S, k+1)
        highest = nonzero.shape[1] - 1 - np.argmax(nonzero[:, ::-1], axis=1)
        return np.where(nonzero.any(axis=1), highest, 0)

    @property
    def joint_count(self) -> int:
        """J, the number of joints."""
        return self.coefficients.shape[1]

    @property
    def total_time(self) -> float:
        """T = sum of h_k [s], summed in order: the last of ``knot_times`` (numpy's pairwise ``sum`` can
        differ from it in the last digit, and the trajectory's end would not be its last knot)."""
        return float(self.knot_times[-1])

    @property
    def knot_times(self) -> np.ndarray:
        """(S+1,) times t_k of the segment boundaries [s], t_0 = 0."""
        return np.concatenate(([0.0], np.cumsum(self.durations)))

    @property
    def via_times(self) -> np.ndarray:
        """Times [s] at which each given via-point is passed."""
        return self.knot_times[self.via_knots]

    def evaluate(self, times, order: int = 0) -> np.ndarray:
        """The ``order``-th time derivative at ``times`` [s], shaped (len(times), J).

        Times outside [0, T] are clamped to the ends.

        Raises:
            InputError: times that are not finite numbers, or an order that is not a whole number >= 0.
        """
        return self._derivatives(times, (checked_order(order),))[0]

    def _derivatives(self, times, orders: tuple[int, ...]) -> np.ndarray:
        """(len(orders), N, J) the derivatives of each order at ``times`` [s] (clamped to [0, T]).

        Each sample's segment and local time are found once, and segments of each degree
        (``segment_degrees``: a hybrid's cubic interior, its 7th-order ends) are evaluated by
        Horner's rule on their own coefficients only, not on the zeros padding them to the
        family's highest degree (the same values: c + 0 x is exactly c).
        """
        times = np.clip(np.atleast_1d(checked_times(times)), 0.0, self.total_time)
        knots = self.knot_times
        segment = np.clip(np.searchsorted(knots, times, side="right") - 1, 0, self.segment_count - 1)
        tau = times - knots[segment]
        values = np.empty((len(orders), len(times), self.joint_count))
        if self.basis == "trigonometric":
            for k, order in enumerate(orders):
                values[k] = segment_values(self.coefficients[segment], self.durations[segment], tau, order,
                                           self.basis)
            return values
        degree_of = self._degrees()[segment]
        for degree in np.unique(degree_of).tolist():
            chosen = degree_of == degree
            coefficients = self.coefficients[segment[chosen], :, :degree + 1]  # (M, J, degree + 1)
            for k, order in enumerate(orders):
                values[k, chosen] = segment_values(coefficients, self.durations[segment[chosen]], tau[chosen], order)
        return values

    def sample_times(self, rate_hz: float) -> np.ndarray:
        """(N,) times [s] at ``rate_hz`` [Hz] from 0 to T inclusive (T appended when the rate misses it).

        Raises:
            InputError: a rate that is not > 0, or more than ``MAX_SAMPLES`` samples.
        """
        if not positive_finite(rate_hz):
            raise InputError(f"sample rate must be a number > 0 Hz, got {shown(rate_hz)}")
        span = self.total_time * rate_hz
        if span >= MAX_SAMPLES:  # counted below: the sample at t = 0 and the end time one more
            raise InputError(f"sampling the {self.total_time:.6g} s trajectory at {rate_hz:g} Hz makes "
                             f"{span + 1:.3g} samples, above the cap of {MAX_SAMPLES:,}")
        count = int(np.floor(span + 1e-9)) + 1
        times = np.arange(count) / rate_hz
        if count == MAX_SAMPLES and times[-1] < self.total_time - 1e-12:
            raise InputError(f"sampling the {self.total_time:.6g} s trajectory at {rate_hz:g} Hz makes "
                             f"{MAX_SAMPLES + 1:,} samples (with its end time), above the cap of {MAX_SAMPLES:,}")
        if times[-1] < self.total_time - 1e-12:
            times = np.append(times, self.total_time)
        return times

    def sample(self, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """Sample at ``rate_hz`` [Hz] from 0 to T inclusive (``sample_times``).

        Returns:
            times (N,) [s] and values (4, N, J): position [rad], velocity [rad/s],
            acceleration [rad/s^2] and jerk [rad/s^3].
        """
        times = self.sample_times(rate_hz)
        return times, self.states(times)

    def states(self, times) -> np.ndarray:
        """(4, N, J) position [rad], velocity [rad/s], acceleration [rad/s^2] and jerk [rad/s^3] at ``times``."""
        return self._derivatives(times, (0, 1, 2, 3))

    def segment_ends(self, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q^(order) at the start and the end of every segment, and a bound on |q^(order)| over it, each (S, J).

        ``segment_ends`` of the coefficients.

        Raises:
            InputError: an order that is not a whole number >= 0."""
        return segment_ends(self.coefficients, self.durations, checked_order(order), self.basis)

    def slowed(self, factor: float) -> "PiecewisePolynomial":
        """The same path run ``factor`` times slower (q_k(tau) = q(tau / k) on each segment): durations times k;
        power coefficient i divided by k^i; trigonometric coefficients unchanged (theta = SPAN tau / h keeps
        its range).

        Raises:
            InputError: a factor that is not a finite number > 0."""
        if not positive_finite(factor):
            raise InputError(f"the slow-down factor must be a finite number > 0, got {shown(factor)}")
        factor = float(factor)
        coefficients = self.coefficients
        if self.basis == "power":
            coefficients = coefficients * factor ** -np.arange(self.width)
        return PiecewisePolynomial(self.durations * factor, coefficients, self.via_knots, self.basis)


def segment_values(coefficients: np.ndarray, durations: np.ndarray, tau: np.ndarray, order: int,
                   basis: str = "power") -> np.ndarray:
    """(M, J) q^(order) [rad/s^order] of M segments' coefficients (M, J, C) in ``basis``, durations (M,) [s],
    each at its own local time ``tau`` (M,) [s]: Horner's rule on the derivative's power coefficients, or
    ``trigonometric.values``."""
    if basis == "trigonometric":
        h = np.broadcast_to(durations[:, None], coefficients.shape[:2])
        at = np.broadcast_to(tau[:, None, None], coefficients.shape[:2] + (1,))
        return trigonometric.values(coefficients, h, at, order)[..., 0]
    return polyval(derivative_coefficients(coefficients, order), tau[:, None, None])[..., 0]


def segment_ends(coefficients: np.ndarray, durations: np.ndarray, order: int,
                 basis: str = "power") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q^(order) at the start and the end of every segment of ``coefficients`` (S, J, C), durations (S,) [s],
    and a bound on |q^(order)| over the segment, each (S, J) (not finite where they overflow).

    Power basis: the derivative polynomial's constant term, its value at tau = h_k, and sum_i |c_i^(d)|
    h_k^i. Trigonometric: the values at theta = 0 and SPAN, and (SPAN / h_k)^d sum_i k_i^d |a_i| (the d-th
    derivative of cos k theta or sin k theta is at most k^d in size)."""
    c, h = coefficients, durations
    with np.errstate(over="ignore", invalid="ignore"):
        end = segment_values(c, h, h, order, basis)
        if basis == "trigonometric":
            frequencies = np.array([k for k, _ in trigonometric.BASIS], dtype=float)
            bound = (trigonometric.SPAN / h[:, None]) ** order * (np.abs(c) @ frequencies ** order)
            return segment_values(c, h, np.zeros_like(h), order, basis), end, bound
        derivative = derivative_coefficients(c, order)  # (S, J, D + 1 - order)
        return derivative[..., 0], end, polyval(np.abs(derivative), h[:, None, None])[..., 0]


def _lost_segments(coefficients: np.ndarray, durations: np.ndarray, basis: str) -> np.ndarray:
    """(S,) segments whose coefficients with their durations are beyond floating point: the exact figures work
    on c_i h^i (power) or a_i (SPAN / h)^d for d <= 3 (trigonometric), which must not overflow, nor a moving
    joint's all vanish (a jerk of 6 over 1e-110 s would then be taken for none); a term that carries motion
    (|c_i| > ``NEGLIGIBLE``) may not vanish alone either (c_3 h^3 of a jerk of 6 over 1e-160 s is 0, beside
    c_2 h^2 = 3e-320: the jerk would be taken for none, the acceleration off by 1e-5)."""
    with np.errstate(all="ignore"):
        if basis == "trigonometric":
            rates = (trigonometric.SPAN / durations[:, None]) ** np.arange(4)  # (S, 4): d theta / d tau ^ d
            scaled = coefficients[..., None] * rates[:, None, None, :]
            carried = np.abs(coefficients[..., 1:, None]) > NEGLIGIBLE
            terms = scaled[..., 1:, 1:]
        else:
            scaled = coefficients * durations[:, None, None] ** np.arange(coefficients.shape[2])
            carried = np.abs(coefficients[..., 1:]) > NEGLIGIBLE
            terms = scaled[..., 1:]
    underflown = carried & (np.abs(terms) < np.finfo(float).tiny)
    flat = scaled.reshape(scaled.shape[0], -1)
    return ~np.isfinite(flat).all(axis=1) | underflown.reshape(underflown.shape[0], -1).any(axis=1)


def checked_order(order) -> int:
    """``order`` as the order of a derivative (a whole number >= 0).

    Raises:
        InputError: naming the order given.
    """
    if isinstance(order, (bool, np.bool_)) or not isinstance(order, (int, np.integer)) or order < 0:
        raise InputError(f"the derivative order must be a whole number >= 0, got {shown(order)}")
    return int(order)


def checked_times(times) -> np.ndarray:
    """``times`` [s] as a float array of one time or a list of them (0 or 1 dimensions), all finite.

    Raises:
        InputError: naming ``times``: not numbers, more dimensions, or a non-finite entry.
    """
    array = float_array("times", times)
    if array.ndim > 1:
        raise InputError(f"times must be one time or a list of times, got shape {array.shape}")
    return finite_array("times", array, array.ndim)


def derivative_coefficients(coefficients: np.ndarray, order: int) -> np.ndarray:
    """Coefficients of the ``order``-th derivative along the last axis (lowest first)."""
    degree = coefficients.shape[-1] - 1
    if order == 0:
        return coefficients
    if order > degree:
        return np.zeros(coefficients.shape[:-1] + (1,))
    factors = np.array([factorial(i) / factorial(i - order) for i in range(order, degree + 1)])
    return coefficients[..., order:] * factors


def powers(x, count: int) -> np.ndarray:
    """x^0 .. x^(count-1) on a new last axis, by repeated products (numpy's pow is slow)."""
    x = np.asarray(x, dtype=float)
    result = np.empty(x.shape + (count,))
    result[..., 0] = 1.0
    for i in range(1, count):
        result[..., i] = result[..., i - 1] * x
    return result


def polyval(coefficients: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Horner evaluation of polynomials ``coefficients`` (..., k+1), lowest first.

    A scalar ``x`` gives (...); an array ``x`` holds points on its last axis,
    (..., m) broadcast against the leading shape, and gives (..., m).
    """
    coefficients = coefficients[..., None, :] if np.ndim(x) else coefficients
    result = np.zeros(np.broadcast_shapes(coefficients.shape[:-1], np.shape(x)))
    for i in range(coefficients.shape[-1] - 1, -1, -1):
        result = result * x + coefficients[..., i]
    return result


# --------------------------------------------------------------------------- families


class SplineFamily:
    """A way to build a piecewise polynomial through n via-points from S durations."""

    name: str = ""
    #: The via-point states (velocity, acceleration, jerk) are free: a timing may choose them
    #: (``coefficients_from_states``); from durations alone they follow the family's fixed rule.
    free_states: bool = False
    #: The kind of segments it builds (``BASES``).
    basis: str = "power"
    #: Coefficients per segment and joint that it builds (``PiecewisePolynomial.width``).
    width: int = 0

    def segment_count(self, via_count: int) -> int:
        """How many durations the family needs for ``via_count`` via-points."""
        raise NotImplementedError(self._abstract("segment_count"))

    def via_knots(self, via_count: int) -> np.ndarray:
        """Indices of the knots at which the via-points are passed."""
        raise NotImplementedError(self._abstract("via_knots"))

    def batch_coefficients(self, via_points: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """(B, S, J, D+1) coefficients for durations (B, S); inputs already validated."""
        raise NotImplementedError(self._abstract("batch_coefficients"))

    def _abstract(self, method: str) -> str:
        """Why a family that defines no ``method`` cannot be used."""
        return (f"{type(self).__name__} does not define {method}: SplineFamily is the base a family derives from; "
                f"get_family(name) gives one of {', '.join(FAMILIES)}")

    def coefficients_from_states(self, via_points: np.ndarray, durations: np.ndarray,
                                 states: np.ndarray) -> np.ndarray:
        """(B, S, J, D+1) coefficients with the via-point states (B, n, J, 3) given (velocity,
        acceleration, jerk), for a family whose states are free (``free_states``)."""
        raise InputError(f"the {self.name} family fixes its via-point states from the durations")

    def rule_states(self, via_points: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """(B, n, J, 3) the via-point states (velocity, acceleration, jerk) a family whose states are free
        (``free_states``) takes from durations (B, S) alone."""
        raise InputError(f"the {self.name} family fixes its via-point states from the durations")

    def check(self, via_points, durations) -> tuple[np.ndarray, np.ndarray]:
        """Validate via-points (n, J), n >= 2, and durations (S,) or (B, S) of the right count."""
        via = finite_array("via_points", via_points, 2)
        if via.shape[0] < 2 or via.shape[1] < 1:
            raise InputError(f"need at least 2 via-points of at least 1 joint, got shape {via.shape}")
        count = self.segment_count(via.shape[0])
        h = positive_durations("durations", durations, count)
        return via, h

    def build(self, via_points, durations, states: np.ndarray | None = None) -> PiecewisePolynomial:
        """The family's trajectory through ``via_points`` (n, J) [rad] with ``durations`` (S,) [s], and
        via-point states (n, J, 3) for a family whose states are free (None: its fixed rule)."""
        via, h = self.check(via_points, durations)
        if h.ndim != 1:
            raise InputError(f"build takes one duration vector, got shape {h.shape}; use build_batch")
        if states is not None and not self.free_states:
            raise InputError(f"the {self.name} family fixes its via-point states from the durations: give no states")
        if states is not None:
            states = finite_array("states", states, 3)
            if states.shape != (*via.shape, 3):
                raise InputError(f"states must have shape (n, J, 3) = {(*via.shape, 3)} (velocity, acceleration "
                                 f"and jerk of every via-point), got {states.shape}")
        coefficients = self._computed(h, lambda: (self.batch_coefficients(via, h[None]) if states is None else
                                                       self.coefficients_from_states(via, h[None], states[None]))[0])
        if not np.all(np.isfinite(coefficients)):
            raise InputError(f"durations from {h.min():.3g} to {h.max():.3g} s overflow the {self.name} spline's "
                             f"coefficients (not finite numbers); give durations of a physical size")
        knots = self.via_knots(via.shape[0])
        self._check_passes(via, h, coefficients, knots)
        return PiecewisePolynomial(h, coefficients, knots, self.basis)

    def _check_passes(self, via: np.ndarray, h: np.ndarray, coefficients: np.ndarray, knots: np.ndarray) -> None:
        """Refuse coefficients (S, J, C) that rounding has parted from the via-points (``rounding_break``).

        Raises:
            InputError: naming the knot, the joint, the gap and the durations' spread.
        """
        broken = self.rounding_break(via, h, coefficients, knots)
        if broken is not None:
            raise InputError(broken)

    def rounding_break(self, via: np.ndarray, h: np.ndarray, coefficients: np.ndarray, knots: np.ndarray) -> str | None:
        """Where rounding has parted coefficients (S, J, C) from the via-points (n, J) [rad] or broken them
        apart at a knot by more than ``BUILD_TOLERANCE`` (relative), what is wrong (knot, joint, gap and the
        durations' spread); else None. Each segment's start and end (``segment_ends``) are compared with the
        via-point at its knot and with the next segment's start. An end is only known to within C eps times
        the bound on |q| there (sum_i |c_i| h^i: the sum's own rounding, large where its terms cancel): that
        is added to its gap, so a spline whose ends no evaluation pins down is refused too."""
        starts, ends, bound = segment_ends(coefficients, h, 0, self.basis)
        with np.errstate(all="ignore"):
            doubt = coefficients.shape[2] * np.finfo(float).eps * bound
        positions = np.concatenate((starts, ends[-1:]))  # (S+1, J) the start of each knot
        uncertain = np.concatenate((np.zeros_like(coefficients[:, :, 0]), doubt[-1:]))  # the last knot's is an end
        gaps = np.concatenate(((np.abs(positions[knots] - via) + uncertain[knots]).ravel(),
                               (np.abs(ends[:-1] - positions[1:-1]) + doubt[:-1]).ravel()))
        worst = int(np.argmax(gaps))
        if gaps[worst] <= BUILD_TOLERANCE * max(1.0, float(np.abs(via).max())):
            return None
        on_via = worst < via.size
        knot = int(knots[worst // via.shape[1]]) if on_via else worst // via.shape[1] - len(knots) + 1
        what = "misses its via-point" if on_via else "breaks apart"
        return (f"the {self.name} spline built from durations {h.min():.3g} to {h.max():.3g} s {what} at knot "
                f"{knot}, joint {worst % via.shape[1]}, by {gaps[worst]:.3g} rad (rounding: the durations are too "
                f"far apart for floating point); give durations of a physical size")

    def build_batch(self, via_points, durations) -> np.ndarray:
        """Coefficients (B, S, J, D+1) for a batch of duration vectors (B, S) [s] (not finite where
        durations of no physical size overflow them)."""
        via, h = self.check(via_points, durations)
        return self._computed(h, lambda: self.batch_coefficients(via, np.atleast_2d(h)))

    def _computed(self, h: np.ndarray, compute: Callable[[], np.ndarray]) -> np.ndarray:
        """``compute()``'s coefficients, its overflows silent (the callers check them), and the failure of a
        library it calls on extreme durations (SciPy's B-spline for ``quintic``) an ``InputError``."""
        try:
            with np.errstate(all="ignore"):
                return compute()
        except InputError:
            raise
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            raise InputError(f"the {self.name} spline cannot be built from durations {h.min():.3g} to {h.max():.3g} s "
                             f"({type(exc).__name__}: {exc}); give durations of a physical size") from None


class CubicFamily(SplineFamily):
    """Cubic spline with virtual knots after the first and before the last via-point.

    Knots y_0..y_{m-1}, m = n + 2, with y_1 and y_{m-2} free. With knot
    accelerations M_k (M_0 = M_{m-1} = 0), segment k on [0, h_k] is

        q(tau) = y_k + c_k tau + M_k tau^2 / 2 + (M_{k+1} - M_k) tau^3 / (6 h_k),
        c_k = (y_{k+1} - y_k) / h_k - h_k (2 M_k + M_{k+1}) / 6,

    and velocity continuity at each interior knot k = 1..m-2 reads

        h_{k-1} M_{k-1} + 2 (h_{k-1} + h_k) M_k + h_k M_{k+1}
            = 6 [(y_{k+1} - y_k) / h_k - (y_k - y_{k-1}) / h_{k-1}].

    Zero end velocities fix the virtual knots: y_1 = p_0 + h_0^2 M_1 / 6 and
    y_{m-2} = p_{n-1} + h_{S-1}^2 M_{m-2} / 6. Writing y_k = ybar_k + g_k M_k and
    substituting keeps the system tridiagonal in M_1..M_{m-2}: O(S) per joint.
    A batch is solved as one block-diagonal tridiagonal system (LAPACK gtsv).
    """

    name = "cubic"
    width = 4

    def segment_count(self, via_count: int) -> int:
        """n + 1: the first and last chords have two segments each (a virtual knot between)."""
        return via_count + 1

    def via_knots(self, via_count: int) -> np.ndarray:
        """Knots 0, 2, .., n - 1, n + 1: the virtual knots 1 and n are no via-points."""
        return np.concatenate(([0], np.arange(2, via_count), [via_count + 1]))

    def batch_coefficients(self, via_points: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """The cubic spline's coefficients from its linear system (the class docstring), per batch row."""
        h = durations
        batch, segments = h.shape
        knots = segments + 1
        joints = via_points.shape[1]
        # Knot positions ybar (m, J): the virtual knots start at their neighbours' positions.
        ybar = np.concatenate((via_points[:1], via_points, via_points[-1:]))
        gain = np.zeros((batch, knots))
        gain[:, 1] = h[:, 0] * h[:, 0] / 6.0
        gain[:, -2] = h[:, -1] * h[:, -1] / 6.0
        h_prev, h_next = h[:, :-1], h[:, 1:]
        lower = h_prev - 6.0 * gain[:, :-2] / h_prev
        diag = 2.0 * (h_prev + h_next) + 6.0 * gain[:, 1:-1] * (1.0 / h_prev + 1.0 / h_next)
        upper = h_next - 6.0 * gain[:, 2:] / h_next
        slope = np.diff(ybar, axis=0)[None] / h[:, :, None]  # (B, S, J)
        rhs = 6.0 * np.diff(slope, axis=1)  # (B, m-2, J)
        unknowns = knots - 2
        banded = np.zeros((3, batch, unknowns))
        banded[0, :, 1:] = upper[:, :-1]
        banded[1] = diag
        banded[2, :, :-1] = lower[:, 1:]
        banded = banded.reshape(3, batch * unknowns)
        moments = solve_banded((1, 1), banded, rhs.reshape(batch * unknowns, joints),
                               overwrite_ab=True, overwrite_b=True, check_finite=False)
        m_full = np.zeros((batch, knots, joints))
        m_full[:, 1:-1] = moments.reshape(batch, unknowns, joints)
        y = ybar[None] + gain[:, :, None] * m_full
        hh = h[:, :, None]
        m0, m1 = m_full[:, :-1], m_full[:, 1:]
        coefficients = np.empty((batch, segments, joints, 4))
        coefficients[..., 0] = y[:, :-1]
        coefficients[..., 1] = np.diff(y, axis=1) / hh - hh * (2.0 * m0 + m1) / 6.0
        coefficients[..., 2] = m0 / 2.0
        coefficients[..., 3] = (m1 - m0) / (6.0 * hh)
        return coefficients


# Q^(d)(1) of Q(s) = sum_i b_i s^i is sum_i b_i i! / (i - d)!: the map from the
# low coefficients b0..b3 and, inverted, the one onto the high ones b4..b7.
_FALLING = np.array([[factorial(i) / factorial(i - d) if i >= d else 0.0 for i in range(8)]
                     for d in range(4)])
_HERMITE7_INVERSE = np.linalg.inv(_FALLING[:, 4:])
_TAYLOR_LOW = np.array([1.0, 1.0, 2.0, 6.0])


def hermite7(start: np.ndarray, end: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The 7th-order polynomial on [0, h] with given (q, q', q'', q''') at both ends.

    Args:
        start: (..., 4) position [rad], velocity, acceleration, jerk at tau = 0.
        end: (..., 4) the same at tau = h.
        h: durations [s], broadcastable to start[..., 0].

    Returns:
        (..., 8) coefficients in tau, lowest first. Solved in normalised time
        s = tau / h: b_i = c_i h^i, the first four fixed by the start state and
        b4..b7 from a constant 4x4 inverse applied to the end residuals.
    """
    power = powers(h, 8)
    scaled_start = start * power[..., :4] / _TAYLOR_LOW
    scaled_end = end * power[..., :4]
    residual = scaled_end - scaled_start @ _FALLING[:, :4].T
    high = residual @ _HERMITE7_INVERSE.T
    return np.concatenate((scaled_start, high), axis=-1) / power


#: The hybrid family's first segment in normalised time: the cubic end segment
#: y_0 + M_1 h^2 s^3 / 6 becomes y_0 + M_1 h^2 P(s), P the 7th-order polynomial from rest
#: to the state (1/6, 1/2, 1, 1) of s^3 / 6 at s = 1. P, P' and P'' rise monotonically to
#: 1/6, 1/2 and 1 at s = 1 (so the segment's speed and acceleration peak at its knot), and
#: its jerk peaks inside: max P''' = 1.3869...
HYBRID_END = hermite7(np.zeros(4), np.array([1 / 6, 1 / 2, 1.0, 1.0]), np.array(1.0))
#: The last segment's shape P(1 - s): it is y_{n-1} + M h^2 P(1 - s), M the last virtual knot's acceleration.
HYBRID_END_REFLECTED = np.polynomial.Polynomial(HYBRID_END)(np.polynomial.Polynomial([1.0, -1.0])).coef


class HybridFamily(CubicFamily):
    """The paper's method: the ``cubic`` spline with 7th-order end segments.

    Segment 0 becomes the 7th-order polynomial from (p_0, 0, 0, 0) to the cubic's
    state (q, q', q'', q''') at tau = h_0, and segment S-1 the one from the
    cubic's state at tau = 0 of that segment to (p_{n-1}, 0, 0, 0). The result is
    C2 everywhere with zero velocity, acceleration and jerk at both ends.

    Note: the state matched includes the jerk of the cubic's own end segment,
    so at the virtual knots jerk jumps exactly as the cubic spline's does (C3
    there would need the neighbouring segment's jerk instead).

    That state is (p_0 + h_0^2 M_1 / 6, h_0 M_1 / 2, M_1, M_1 / h_0), so the segment is
    p_0 + M_1 h_0^2 P(s) (``HYBRID_END``), built from M_1 alone. Matching absolute
    positions instead left only rounding noise of p_0 in the offset h_0^2 M_1 / 6 when
    h_0 is tiny (an optimum can shrink an end segment to microseconds), and that noise,
    divided by h_0^3, became jerk (3.8 times its limit on a 2 us segment).
    """

    name = "hybrid"
    width = 8

    def batch_coefficients(self, via_points: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """The cubic spline's coefficients with the first and last segments replaced by 7th-order ones."""
        cubic = super().batch_coefficients(via_points, durations)
        batch, segments, joints, _ = cubic.shape
        coefficients = np.zeros((batch, segments, joints, 8))
        coefficients[..., :4] = cubic
        # (end segment, its via-point, its shape, the segment that starts at its virtual knot: c_2 = M / 2)
        for segment, via, shape, knot in ((0, 0, HYBRID_END, 1), (-1, -1, HYBRID_END_REFLECTED, -1)):
            h = durations[:, segment]
            acceleration = 2.0 * cubic[:, knot, :, 2:3]  # (B, J, 1)
            coefficients[:, segment] = acceleration * (shape * h[:, None] ** 2 / powers(h, 8))[:, None, :]
            coefficients[:, segment, :, 0] += via_points[via]
        return coefficients


class QuinticFamily(SplineFamily):
    """Interpolating quintic B-spline with zero end velocity and acceleration.

    Knots at the via-points (S = n - 1); built by scipy's ``make_interp_spline``
    and converted to per-segment power-basis coefficients (the Taylor
    coefficients q^(i)(t_k) / i! at each segment's left knot). Needs n >= 2; with
    n = 2 it is the rest-to-rest quintic.
    """

    name = "quintic"
    width = 6

    def segment_count(self, via_count: int) -> int:
        """n - 1: one segment per chord."""
        return via_count - 1

    def via_knots(self, via_count: int) -> np.ndarray:
        """Every knot is a via-point."""
        return np.arange(via_count)

    def batch_coefficients(self, via_points: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """The quintic spline's coefficients: zero end velocity and acceleration, C4 inside (class docstring).

        Interpolated relative to the first via-point, which is added back to c_0: the B-spline's linear
        solve rounds relative to the positions' magnitude, so a joint at 720 deg moving 1e-4 deg had
        its jerk 1e-9 off, beyond the exact check's tolerance, where at 0 deg it was not."""
        from scipy.interpolate import make_interp_spline  # imported where used: 0.1 s of every run's start

        batch, segments = durations.shape
        joints = via_points.shape[1]
        zero_ends = ([(1, np.zeros(joints)), (2, np.zeros(joints))],) * 2
        result = np.empty((batch, segments, joints, 6))
        origin = via_points[0]
        for b in range(batch):
            times = np.concatenate(([0.0], np.cumsum(durations[b])))
            spline = make_interp_spline(times, via_points - origin, k=5, bc_type=zero_ends)
            # Taylor coefficients at each segment's left knot: c_i = q^(i)(t_k) / i!.
            result[b] = np.stack([spline(times[:-1], nu=i) / factorial(i) for i in range(6)], axis=-1)
        result[..., 0] = via_points[:-1]  # the interpolation's own values, exactly
        return result


def parabola_states(via_points: np.ndarray, durations: np.ndarray) -> np.ndarray:
    """(B, n, J, 3) velocity, acceleration and jerk at each via-point: those of the parabola through
    it and its two neighbours at their times, and zero jerk (all zero at the first and last).

    With chord slopes s_k = (p_{k+1} - p_k) / h_k, at interior via-point i:
    v_i = (h_i s_{i-1} + h_{i-1} s_i) / (h_{i-1} + h_i), a_i = 2 (s_i - s_{i-1}) / (h_{i-1} + h_i).
    Scaling every duration by k divides v by k and a by k^2, as the time-scaling lemma needs.
    """
    h = durations[:, :, None]
    slopes = np.diff(via_points, axis=0)[None] / h
    before, after = h[:, :-1], h[:, 1:]
    states = np.zeros((durations.shape[0], via_points.shape[0], via_points.shape[1], 3))
    states[:, 1:-1, :, 0] = (after * slopes[:, :-1] + before * slopes[:, 1:]) / (before + after)
    states[:, 1:-1, :, 1] = 2 * (slopes[:, 1:] - slopes[:, :-1]) / (before + after)
    return states


class Hermite7Family(SplineFamily):
    """One 7th-order Hermite segment per chord (S = n - 1): position, velocity, acceleration and
    jerk match at both ends of every segment, so the trajectory is C3 (jerk-continuous); velocity,
    acceleration and jerk are zero at both ends under the fixed rule and from the NLP (states given
    to ``build`` are used as they are).

    The interior via-point states are free (``free_states``): the sparse NLP optimizes them with the
    durations. Built from durations alone (the population optimizers, the starts) they follow a
    fixed rule, ``parabola_states``.
    """

    name = "hermite7"
    width = 8
    free_states = True
    #: The segment between two states (..., 4) (position, velocity, acceleration, jerk) over durations h [s]:
    #: its coefficients (..., 8).
    segment = staticmethod(hermite7)

    def segment_count(self, via_count: int) -> int:
        """n - 1: one segment per chord."""
        return via_count - 1

    def via_knots(self, via_count: int) -> np.ndarray:
        """Every knot is a via-point."""
        return np.arange(via_count)

    def batch_coefficients(self, via_points: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """The segments between the fixed-rule states (``parabola_states``)."""
        return self.coefficients_from_states(via_points, durations, self.rule_states(via_points, durations))

    def rule_states(self, via_points: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """(B, n, J, 3) the via-point states of the fixed rule (``parabola_states``) for durations (B, S)."""
        return parabola_states(via_points, durations)

    def coefficients_from_states(self, via_points: np.ndarray, durations: np.ndarray,
                                 states: np.ndarray) -> np.ndarray:
        """(B, S, J, 8) each segment (``segment``) between the states (B, n, J, 3) (velocity,
        acceleration, jerk) of its two via-points; the first and last via-point's are used as given."""
        position = np.broadcast_to(via_points[None, :, :, None], states.shape[:3] + (1,))
        full = np.concatenate((position, states), axis=-1)  # (B, n, J, 4)
        return self.segment(full[:, :-1], full[:, 1:], durations[:, :, None])


class TrigonometricFamily(Hermite7Family):
    """``hermite7``'s structure (S = n - 1, C3, zero velocity, acceleration and jerk at both ends, free
    interior via-point states, the same fixed rule ``parabola_states``) with Simon & Isik's order-4
    trigonometric segments (``trigonometric.hermite_coefficients``): coefficients (B, S, J, 8) of
    ``trigonometric.BASIS`` in theta = SPAN tau / h_k, theta in [0, SPAN = 3 pi / 4] with cos 4 theta (the
    Hermite system's condition number 38.5, ``trigonometric``'s docstring)."""

    name = "trigonometric"
    basis = "trigonometric"
    segment = staticmethod(trigonometric.hermite_coefficients)


FAMILIES: dict[str, SplineFamily] = {f.name: f for f in (CubicFamily(), HybridFamily(), QuinticFamily(),
                                                          Hermite7Family(), TrigonometricFamily())}


def get_family(name: str) -> SplineFamily:
    """The family called ``name``; an unknown name is an ``InputError`` listing the known ones."""
    try:
        return FAMILIES[name]
    except (KeyError, TypeError):
        raise InputError(f"unknown spline family {name!r}; known: {', '.join(FAMILIES)}") from None

