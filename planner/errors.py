"""One exception hierarchy for every user-facing failure.

Every error carries a one-line message that names what was wrong (the
waypoint, joint, key path, value and bound where they apply) and an
``exit_code`` the CLI returns: 2 for every planner error (bad input, an infeasible
task, an unusable output path, a recording or viewer that fails); 1 is left
for internal errors.
"""

from __future__ import annotations

import codecs
import sys

#: Longest text of one value shown in a message [characters].
SHOWN_VALUE_CHARS = 80
#: Longest message of any planner error [characters]; longer ones are cut in the middle.
MESSAGE_CHARS = 600


def shown(value, limit: int = SHOWN_VALUE_CHARS) -> str:
    """``repr(value)`` cut to at most ``limit`` characters (with its full length said), for messages.

    A value from a task file can be arbitrarily large (a YAML alias bomb expands
    a few hundred bytes into megabytes): no message prints one in full.
    """
    try:
        text = repr(value)
    except Exception:  # a value whose repr fails still gets a message
        text = f"<{type(value).__name__}>"
    if len(text) <= limit:
        return text
    return f"{text[:limit - 1]}… ({len(text)} characters)"


def path_encoding_advice(text: str) -> str:
    """A sentence for a path ``text`` that holds characters beyond ASCII where Python's filesystem
    encoding is not UTF-8 (a C or POSIX locale with PYTHONUTF8=0: such paths are then neither opened
    by the names a task file gives nor handed to Rerun as they are), else ""."""
    encoding = sys.getfilesystemencoding()
    if codecs.lookup(encoding).name == "utf-8" or text.isascii():
        return ""
    return (f"; Python's filesystem encoding here is {encoding!r} (a C or POSIX locale with PYTHONUTF8=0), so "
            f"paths beyond ASCII cannot be used: set a UTF-8 locale (LC_ALL=C.UTF-8) or PYTHONUTF8=1")


def one_line(message: str, limit: int = MESSAGE_CHARS) -> str:
    """``message`` on one line (newlines become spaces), cut in the middle beyond ``limit`` characters."""
    text = " ".join(str(message).split("\n"))
    if len(text) <= limit:
        return text
    half = (limit - 5) // 2
    return f"{text[:half]} [...] {text[-half:]}"


class PlannerError(Exception):
    """Base class of every error the planner raises on purpose.

    Its message is one line of at most ``MESSAGE_CHARS`` characters, whatever it is built from.
    """

    exit_code: int = 1

    def __init__(self, message: str = ""):
        super().__init__(one_line(message))

    def __reduce__(self):
        """Pickle as message and fields, whatever the constructor takes (an error raised in a worker
        process reaches the parent whole: ``concurrency.map_forked``)."""
        return _restore, (type(self), self.args, self.__dict__)


def _restore(kind: type, args: tuple, fields: dict) -> PlannerError:
    """A ``kind`` error with these ``args`` and attributes, without calling its constructor."""
    error: PlannerError = Exception.__new__(kind)
    error.args = args
    error.__dict__.update(fields)
    return error


class InputError(PlannerError, ValueError):
    """Malformed numeric input: NaN or inf, wrong shape, non-positive durations."""

    exit_code = 2


class SettingError(InputError):
    """An optimizer setting that the optimizer does not take, or outside its range."""

    def __init__(self, setting: str, problem: str):
        self.setting = setting
        self.problem = problem
        super().__init__(f"optimizer setting {setting}: {problem}")


class TaskError(InputError):
    """A task file that does not follow the schema; the message names the key path."""

    def __init__(self, path: str, problem: str):
        self.path = path
        self.problem = problem
        super().__init__(f"{path}: {problem}" if path else problem)


class InfeasibleError(PlannerError):
    """No trajectory can satisfy a limit (the joint, quantity, value and limit are named).

    Attributes:
        joint: the joint's name, as the message says it (``joint2``, a URDF's ``shoulder_lift_joint``), as
            on every error that names a joint; ``joint_index``: its column (0-based) in the plan's arrays.
        quantity, value, limit: what exceeds which limit (SI units: rad, s, N m).
    """

    exit_code = 2

    def __init__(self, message: str, *, joint: str | None = None, joint_index: int | None = None,
                 quantity: str | None = None, value: float | None = None, limit: float | None = None,
                 violation=None):
        """The fields come from ``violation`` (a ``kinematics.Violation``: its joint's name and index,
        quantity, value and limit) when one is given, else from the keywords."""
        if violation is not None:
            joint, joint_index = violation.joint, violation.index
            quantity, value, limit = violation.quantity, violation.value, violation.limit
        self.joint = joint
        self.joint_index = joint_index
        self.quantity = quantity
        self.value = value
        self.limit = limit
        super().__init__(message)


class RobotError(PlannerError):
    """A robot that cannot be planned for; the subclasses tell the cases apart."""

    exit_code = 2


class UnknownRobotError(RobotError):
    """No example-robot-data robot of that name; ``known`` lists the names there are."""

    def __init__(self, message: str, *, name: object, known: tuple[str, ...]):
        self.name = name
        self.known = known
        super().__init__(message)


class UnknownFrameError(RobotError):
    """The robot has no frame of that name; ``frames`` lists the frames it has."""

    def __init__(self, message: str, *, frame: object, frames: tuple[str, ...]):
        self.frame = frame
        self.frames = frames
        super().__init__(message)


class RobotFileError(RobotError):
    """A URDF, a mesh it names, or a ``.limits.yaml`` file that cannot be read or is malformed
    (``path``: the file), or an example-robot-data model that cannot be loaded."""

    def __init__(self, message: str, *, path: object = None):
        self.path = path
        super().__init__(message)


class UnsupportedRobotError(RobotError):
    """A robot the planner does not plan for: a floating base, a joint of another kind than
    single-axis revolute (``joint``: its name), a tool frame no joint moves."""

    def __init__(self, message: str, *, joint: str | None = None):
        self.joint = joint
        super().__init__(message)


class MissingLimitError(RobotError):
    """A joint without a limit the planner needs (``quantity``); ``key`` is the task key to give it."""

    def __init__(self, message: str, *, joint: str, quantity: str, key: str):
        self.joint = joint
        self.quantity = quantity
        self.key = key
        super().__init__(message)


class IKError(PlannerError):
    """A waypoint whose pose could not be reached within the joint ranges."""

    exit_code = 2

    def __init__(self, message: str, *, waypoint: int | None = None, residual: float | None = None):
        self.waypoint = waypoint
        self.residual = residual
        super().__init__(message)


class OutputError(PlannerError):
    """An output path that cannot be used: empty, a file where a folder is needed (or the
    reverse), not writable, a folder of someone else's files, or one another run is writing."""

    exit_code = 2


class ViewerError(PlannerError):
    """The Rerun viewer cannot be used here: no display for the window, no graphics adapter or
    ``rerun`` program for a headless screenshot, or a viewer that failed to start."""

    exit_code = 2


class RecordingError(PlannerError):
    """A missing, corrupt or foreign Rerun recording."""

    exit_code = 2
