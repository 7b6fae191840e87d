"""Time-optimal, limit-respecting joint trajectories through via-points."""

from .errors import (IKError, InfeasibleError, InputError, PlannerError, RecordingError, RobotError,
                     TaskError)
from .kinematics import KinematicFigures, kinematic_figures
from .limits import JointLimits, time_scale_factor
from .splines import FAMILIES, PiecewisePolynomial, SplineFamily, get_family

__all__ = [
    "FAMILIES", "IKError", "InfeasibleError", "InputError", "JointLimits", "KinematicFigures",
    "PiecewisePolynomial", "PlannerError", "RecordingError", "RobotError", "SplineFamily", "TaskError",
    "get_family", "kinematic_figures", "time_scale_factor",
]
