"""Frozen dataclasses whose arrays are frozen too: ``frozen=True`` stops reassigning a field, not
writing into the array it holds (``limits.velocity[0] = 0`` would silently change a value that
others share)."""

from __future__ import annotations

import dataclasses

import numpy as np


def freeze_arrays(instance) -> None:
    """Replace every NumPy array field of the dataclass ``instance`` by a read-only copy (call it
    from ``__post_init__``, after any conversion); a mapping's or a tuple's arrays are copied likewise."""
    for field in dataclasses.fields(instance):
        value = getattr(instance, field.name)
        if isinstance(value, np.ndarray):
            object.__setattr__(instance, field.name, read_only(value))
        elif isinstance(value, dict) and any(isinstance(item, np.ndarray) for item in value.values()):
            object.__setattr__(instance, field.name, type(value)({key: read_only(item) if isinstance(item, np.ndarray)
                                                                  else item for key, item in value.items()}))
        elif isinstance(value, tuple) and any(isinstance(item, np.ndarray) for item in value):
            object.__setattr__(instance, field.name, tuple(read_only(item) if isinstance(item, np.ndarray) else item
                                                           for item in value))


def read_only(array: np.ndarray) -> np.ndarray:
    """A read-only copy of ``array`` (the caller's array stays writable), as a view of a read-only array: NumPy
    lets an array that owns its data be made writable again (``setflags(write=True)``), not such a view."""
    copy = np.array(array)
    copy.setflags(write=False)
    view = copy.view()
    view.setflags(write=False)
    return view


class ReadOnlyDict(dict):
    """A dict that refuses changes: a frozen value's mapping (``Task.limits``, ``Task.optimizer``), which a
    result holds as planned. Pickled, copied and read as a dict; ``copy()`` gives a plain, changeable one."""

    def _refuse(self, *args, **kwargs):
        raise TypeError("this mapping belongs to a frozen value and cannot be changed: make a new one (for a "
                        "task, dataclasses.replace(task, optimizer={**task.optimizer, ...}))")

    __setitem__ = __delitem__ = clear = pop = popitem = setdefault = update = __ior__ = _refuse  # type: ignore[assignment]

    def copy(self) -> dict:  # type: ignore[override]
        """A plain dict of the same items."""
        return dict(self)

    def __reduce__(self):
        return type(self), (dict(self),)


class ReadOnlyArrays:
    """Base of the frozen dataclasses that call ``freeze_arrays`` in ``__post_init__``: an unpickled or
    copied instance (``pickle``, ``copy.deepcopy``) gets read-only arrays too, for NumPy does not keep
    the flag in a copy and neither runs ``__post_init__``."""

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)  # a frozen dataclass refuses setattr, not its __dict__
        freeze_arrays(self)
