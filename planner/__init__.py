"""Time-optimal, limit-respecting joint trajectories through via-points.

The public names below are imported on first use (PEP 562), so that
``import planner`` (and the command line's start-up) stays light until
Pinocchio, SciPy or CasADi are actually needed.
"""

from __future__ import annotations

import importlib
import logging

from .errors import (
    IKError,
    InfeasibleError,
    InputError,
    MissingLimitError,
    OutputError,
    PlannerError,
    RecordingError,
    RobotError,
    RobotFileError,
    SettingError,
    TaskError,
    UnknownFrameError,
    UnknownRobotError,
    UnsupportedRobotError,
    ViewerError,
)

logging.getLogger(__name__).addHandler(logging.NullHandler())  # silent unless the application logs

#: public name -> the module that defines it
_LAZY = {
    "KinematicFigures": ".kinematics", "kinematic_figures": ".kinematics",
    "JointLimits": ".limits", "time_scale_factor": ".limits",
    "FAMILIES": ".splines", "PiecewisePolynomial": ".splines", "SplineFamily": ".splines", "get_family": ".splines",
    "Robot": ".robot", "Task": ".task", "load_task": ".task", "make_task": ".task", "pose_entry": ".task",
    "PlanResult": ".pipeline", "plan": ".pipeline",
}

__all__ = [
    "FAMILIES", "IKError", "InfeasibleError", "InputError", "JointLimits", "KinematicFigures", "MissingLimitError",
    "OutputError", "PiecewisePolynomial", "PlanResult", "PlannerError", "RecordingError", "Robot", "RobotError",
    "RobotFileError", "SettingError", "SplineFamily", "Task", "TaskError", "UnknownFrameError", "UnknownRobotError",
    "UnsupportedRobotError", "ViewerError", "get_family", "kinematic_figures", "load_task", "make_task", "plan",
    "pose_entry", "time_scale_factor",
]


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'planner' has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name], __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
