"""Input checks shared by every stage: finite arrays of a stated shape, positive finite numbers, single
numbers in a stated range (a task file's and an optimizer's settings alike)."""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass

import numpy as np

from .errors import InputError, shown

#: Characters no name or label may hold: control characters, and those that move or reorder the text around
#: them (line and paragraph separators U+2028, U+2029; bidirectional overrides such as U+202E).
CONTROL_CHARACTERS = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f\u202a-\u202e\u2066-\u2069]")

#: Largest seed of the random generators (numpy takes seeds in [0, 2^63) here).
MAX_SEED = 2**63 - 1


@dataclass(frozen=True)
class Range:
    """Allowed values of one number: ``low`` to ``high`` (both included unless ``low_open``), whole
    numbers only if ``integer``."""

    low: float
    high: float = math.inf
    integer: bool = False
    low_open: bool = False

    def __contains__(self, value: float) -> bool:
        return (value > self.low if self.low_open else value >= self.low) and value <= self.high

    def __str__(self) -> str:
        text = f"{'an integer ' if self.integer else ''}{'>' if self.low_open else '>='} {self.low:g}"
        if self.high == math.inf:
            return text
        return f"{text} and <= {self.high if isinstance(self.high, int) else format(self.high, 'g')}"


#: Duration bounds a timing may impose [s] (a task's ``bounds_s``, ``TimingProblem``'s ``bounds`` and
#: ``min_duration``): 1 us, a hundredth of a 10 kHz controller's period, to 1e6 s (11.6 days). Beyond them
#: the splines' coefficients (c_i ~ dq / h^i, up to i = 7) and jerk energies (~ h^-5) leave floating point
#: (bounds of 1e-300 s ended in NumPy's LinAlgError), and no robot moves on either scale.
DURATION_BOUND_RANGE = Range(1e-6, 1e6)


def number(value, *, integer: bool = False) -> float:
    """``value`` as a finite float (or int if ``integer``); booleans and text are not numbers, numpy
    scalars are.

    Raises:
        InputError: whose message is the problem alone ("must be a number, got 'x'"), for the caller to
            prefix with the name of what was given.
    """
    if isinstance(value, np.floating) and np.isfinite(value) and not math.isfinite(float(value)):
        raise InputError(f"must be a number a double holds (a magnitude up to 1.8e308), got {shown(value)}")
    if isinstance(value, np.generic) and not isinstance(value, np.bool_):
        value = value.item() if not isinstance(value, np.floating) else float(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"must be a number, got {shown(value)}{_text_number_hint(value)}")
    if isinstance(value, int) and not integer:
        try:
            value = float(value)
        except OverflowError:
            raise InputError(f"must be a number a double holds (a magnitude up to 1.8e308), got {shown(value)}") \
                from None
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError(f"must be a finite number, got {value}")
    if integer and int(value) != value:
        raise InputError(f"must be a whole number, got {value}")
    return int(value) if integer else value


def _text_number_hint(value) -> str:
    """A hint for text that reads as a finite number (a quoted number, say), else ''."""
    if not isinstance(value, str) or len(value) > 40:
        return ""
    try:
        finite = math.isfinite(float(value))
    except ValueError:
        return ""
    if not value.isascii() and value.strip().isascii():  # float() strips any Unicode space: a pasted no-break one
        spaces = sorted({f"U+{ord(c):04X}" for c in value if not c.isascii()})
        return f" (a space other than a plain one around the number, {', '.join(spaces)}: write the number alone)" \
            if finite else ""
    if not value.isascii():  # Python reads other scripts' digits (Arabic-Indic, ...); YAML does not
        return " (digits other than 0-9: write the number with 0-9)" if finite else ""
    return " (text: write the number without quotes)" if finite else ""


def within(value, rule: Range, given=None):
    """``value`` if it is in ``rule``; else an ``InputError`` saying so (showing ``given``, the value as
    the user wrote it, when given)."""
    if value not in rule:
        rounded = given is not None and isinstance(given, np.floating) and value != given
        raise InputError(f"must be {rule}, got {shown(value if given is None else given)}"
                         + (f" ({value:g} as a double)" if rounded else ""))
    return value


def ranged(value, rule: Range | type):
    """``value`` checked against ``rule``: a number in its ``Range``, or true/false where ``rule`` is
    ``bool``. Raises ``InputError`` with the problem alone, as ``number`` does."""
    if not isinstance(rule, Range):
        if not isinstance(value, (bool, np.bool_)):
            raise InputError(f"must be true or false, got {shown(value)}")
        return bool(value)
    if isinstance(value, int) and not isinstance(value, bool) and value not in rule:  # exact, however large
        raise InputError(f"must be {rule}, got {shown(value)}")
    return within(number(value, integer=rule.integer), rule, value)


def float_array(name: str, value) -> np.ndarray:
    """``value`` as a float array.

    Raises:
        InputError: naming ``name``, for text, booleans, None, complex numbers, times, ragged lists or
            anything else that is not real numbers (NumPy itself would read "0.5" as 0.5, None as nan, True
            as 1 and 1 + 5j as 1).
    """
    try:
        raw = np.asarray(value)
        if raw.dtype.kind in "USVbMmc" or (raw.dtype.kind == "O" and any(
                item is None or isinstance(item, (str, bytes, bool, np.bool_)) for item in raw.flat)):
            raise TypeError(f"got {shown(value)}")
        if not isinstance(value, np.ndarray) and _holds_boolean(value):  # NumPy made [True, 2.0] floats
            raise TypeError(f"got {shown(value)}, which holds a boolean")
        return raw.astype(float)
    except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an integer beyond any float
        raise InputError(f"{name} must be numeric ({exc})") from None


def _holds_boolean(value) -> bool:
    """Whether ``value``, lists and tuples nested in any depth, holds a boolean (or a boolean array)."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, (bool, np.bool_)) or (isinstance(item, np.ndarray) and item.dtype.kind == "b"):
            return True
        if isinstance(item, (list, tuple)):
            stack.extend(item)
    return False


def finite_array(name: str, value, ndim: int) -> np.ndarray:
    """Return ``value`` as a float array of ``ndim`` dimensions, all entries finite.

    Raises:
        InputError: naming ``name``, the shape found, or the first non-finite entry.
    """
    array = float_array(name, value)
    if array.ndim != ndim:
        raise InputError(f"{name} must have {ndim} dimension(s), got shape {array.shape}")
    bad = np.flatnonzero(~np.isfinite(array))
    if bad.size:
        index = tuple(int(i) for i in np.unravel_index(bad[0], array.shape))
        raise InputError(f"{name}{list(index) if index else ''} is {array[index]}, not a finite number")
    return array


def positive_durations(name: str, value, count: int | None = None) -> np.ndarray:
    """Durations [s] as a (S,) or (B, S) array, finite and > 0, with S == ``count`` if given, each one
    large enough to move its knot time t_k = h_0 + .. + h_(k-1) in floating point."""
    array = float_array(name, value)
    array = finite_array(name, array, array.ndim if array.ndim in (1, 2) else 1)
    if count is not None and array.shape[-1] != count:
        raise InputError(f"{name} must hold {count} segment durations, got {array.shape[-1]}")
    bad = np.argwhere(array <= 0)
    if bad.size:
        index = tuple(int(i) for i in bad[0])
        raise InputError(f"{name}{list(index)} is {array[index]} s; durations must be > 0")
    with np.errstate(over="ignore", invalid="ignore"):  # a sum beyond floating point is refused by its user
        knots = np.cumsum(array, axis=-1)
        lost = np.argwhere(np.diff(knots, axis=-1) <= 0)
    if lost.size:
        index = tuple(int(i) for i in lost[0])
        segment = index[:-1] + (index[-1] + 1,)
        raise InputError(f"{name}{list(segment)} = {array[segment]:.3g} s vanishes against the {knots[index]:.3g} s "
                         f"before it: the knot times before and after it are the same number in floating point; "
                         f"give durations of a physical size")
    return array


def positive_finite(value) -> bool:
    """Whether ``value`` is a real number (not a boolean), finite and > 0 (an integer too large for a
    float is not)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return False
    try:
        magnitude = float(value)
    except OverflowError:
        return False
    return math.isfinite(magnitude) and magnitude > 0
