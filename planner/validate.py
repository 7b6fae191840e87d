"""Input checks shared by every stage: finite arrays of a stated shape, positive finite numbers."""

from __future__ import annotations

import math
import numbers

import numpy as np

from .errors import InputError


def float_array(name: str, value) -> np.ndarray:
    """``value`` as a float array.

    Raises:
        InputError: naming ``name``, for text, ragged lists or anything else that is not numbers.
    """
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an integer beyond any float
        raise InputError(f"{name} must be numeric ({exc})") from None


def finite_array(name: str, value, ndim: int) -> np.ndarray:
    """Return ``value`` as a float array of ``ndim`` dimensions, all entries finite.

    Raises:
        InputError: naming ``name``, the shape found, or the first non-finite entry.
    """
    array = float_array(name, value)
    if array.ndim != ndim:
        raise InputError(f"{name} must have {ndim} dimension(s), got shape {array.shape}")
    bad = np.argwhere(~np.isfinite(array))
    if bad.size:
        index = tuple(int(i) for i in bad[0])
        raise InputError(f"{name}{list(index)} is {array[index]}, not a finite number")
    return array


def positive_durations(name: str, value, count: int | None = None) -> np.ndarray:
    """Durations [s] as a (S,) or (B, S) array, finite and > 0, with S == ``count`` if given."""
    array = float_array(name, value)
    array = finite_array(name, array, array.ndim if array.ndim in (1, 2) else 1)
    if count is not None and array.shape[-1] != count:
        raise InputError(f"{name} must hold {count} segment durations, got {array.shape[-1]}")
    bad = np.argwhere(array <= 0)
    if bad.size:
        index = tuple(int(i) for i in bad[0])
        raise InputError(f"{name}{list(index)} is {array[index]} s; durations must be > 0")
    return array


def positive_finite(value) -> bool:
    """Whether ``value`` is a real number (not a boolean), finite and > 0 (an integer too large for a
    float is not)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return False
    try:
        number = float(value)
    except OverflowError:
        return False
    return math.isfinite(number) and number > 0
