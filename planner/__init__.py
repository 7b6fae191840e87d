"""Time-optimal, limit-respecting joint trajectories through via-points."""

from .errors import (IKError, InfeasibleError, InputError, PlannerError, RecordingError, RobotError,
                     TaskError)
from .kinematics import KinematicFigures, kinematic_figures
from .limits import JointLimits, time_scale_factor
from .splines import FAMILIES, PiecewisePolynomial, SplineFamily, get_family
from .robot import Robot
from .task import Task, load_task
from .pipeline import PlanResult, plan

__all__ = [
    "FAMILIES", "IKError", "InfeasibleError", "InputError", "JointLimits", "KinematicFigures",
    "PiecewisePolynomial", "PlanResult", "PlannerError", "RecordingError", "Robot", "RobotError", "SplineFamily",
    "Task", "TaskError", "get_family", "kinematic_figures", "load_task", "plan", "time_scale_factor",
]
