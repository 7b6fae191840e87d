"""The source paper's numbers, in its units: degrees, seconds.

Paper: ``TITLE``. Each constant names the table it comes from. Table V is
reported beside ours but is not reproducible: for most joints it is below the
mean speed between two of its own via-points (``planner reproduce`` shows it).
"""

from __future__ import annotations

import numpy as np

from .limits import JointLimits

#: The source paper's title.
TITLE = ("Time-optimal trajectory generation in joint space for 6R industrial serial robots "
         "using Cuckoo search algorithm")

#: Table II: joint via-points [deg], 8 x 6.
VIA_POINTS_DEG = np.array([
    [10, 15, 45, 5, 10, 6],
    [60, 25, 180, 20, 30, 40],
    [75, 30, 200, 60, -40, 80],
    [130, -45, 120, 110, -60, 70],
    [110, -55, 15, 20, 10, -10],
    [100, -70, -10, 60, 50, 10],
    [-10, -10, 100, -100, -40, 30],
    [-50, 10, 50, -30, 10, 20],
], dtype=float)

#: Table III: velocity [deg/s], acceleration [deg/s^2], jerk [deg/s^3] limits per joint.
VELOCITY_LIMITS_DEG = np.array([100, 95, 100, 150, 130, 110], dtype=float)
ACCELERATION_LIMITS_DEG = np.array([60, 60, 75, 70, 90, 80], dtype=float)
JERK_LIMITS_DEG = np.array([60, 66, 85, 70, 75, 70], dtype=float)

#: Table IV: the paper's optimized durations [s] of the hybrid spline (9 segments).
DURATIONS_S = np.array([4.9452, 3.0933, 3.4937, 3.9156, 4.6478, 4.9945, 3.8972, 4.3261, 4.9980])

#: The paper's optimizer settings and duration bounds [s].
CUCKOO_SETTINGS = {"nests": 20, "iterations": 150, "pa": 0.25}
BOUNDS_S = (3.0, 5.0)

#: Table V (as reported; not reproducible): max |v|, |a|, |j| per joint for the paper's CS result.
TABLE_V_DEG = {
    "velocity": [16.92, 18.99, 41.43, 26.72, 18.30, 12.93],
    "acceleration": [11.20, 9.91, 26.29, 21.78, 12.49, 5.60],
    "jerk": [11.72, 8.38, 29.04, 34.20, 12.65, 3.01],
}

#: Table VI: time-averaged |v|, |a|, |j| per joint for the paper's CS result.
TABLE_VI_DEG = {
    "velocity": [8.32, 5.70, 15.65, 13.28, 11.16, 6.20],
    "acceleration": [4.22, 2.99, 6.89, 8.83, 5.88, 2.42],
    "jerk": [3.95, 2.51, 5.75, 8.76, 4.53, 1.40],
}


def paper_limits() -> JointLimits:
    """Table III as ``JointLimits`` in SI units (no position range)."""
    return JointLimits.create(6, velocity=np.deg2rad(VELOCITY_LIMITS_DEG),
                              acceleration=np.deg2rad(ACCELERATION_LIMITS_DEG),
                              jerk=np.deg2rad(JERK_LIMITS_DEG))
