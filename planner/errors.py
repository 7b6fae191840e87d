"""One exception hierarchy for every user-facing failure.

Every error carries a one-line message that names what was wrong (the
waypoint, joint, key path, value and bound where they apply) and an
``exit_code`` the CLI returns: 2 for bad input, 1 for anything else.
"""

from __future__ import annotations


class PlannerError(Exception):
    """Base class of every error the planner raises on purpose."""

    exit_code: int = 1


class InputError(PlannerError, ValueError):
    """Malformed numeric input: NaN or inf, wrong shape, non-positive durations."""

    exit_code = 2


class TaskError(InputError):
    """A task file that does not follow the schema; the message names the key path."""

    def __init__(self, path: str, problem: str):
        self.path = path
        self.problem = problem
        super().__init__(f"{path}: {problem}" if path else problem)


class InfeasibleError(PlannerError):
    """No trajectory can satisfy a limit (the joint, quantity, value and limit are named)."""

    exit_code = 2

    def __init__(self, message: str, *, joint: int | None = None, quantity: str | None = None,
                 value: float | None = None, limit: float | None = None):
        self.joint = joint
        self.quantity = quantity
        self.value = value
        self.limit = limit
        super().__init__(message)


class RobotError(PlannerError):
    """Unknown robot, unreadable URDF, unknown frame, or missing robot limits."""

    exit_code = 2


class IKError(PlannerError):
    """A waypoint whose pose could not be reached within the joint ranges."""

    exit_code = 2

    def __init__(self, message: str, *, waypoint: int | None = None, residual: float | None = None):
        self.waypoint = waypoint
        self.residual = residual
        super().__init__(message)


class RecordingError(PlannerError):
    """A missing, corrupt or foreign Rerun recording."""

    exit_code = 2
