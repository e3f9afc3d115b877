"""Trajectories: joint trajectories, blended joint-space paths and time parameterization
(time-optimal TOPP-RA, synchronized PTP, jerk-limited ruckig), plotting."""

from robocell.trajectory.path import BlendedPath, SplinePath
from robocell.trajectory.plot import plot_trajectory
from robocell.trajectory.timing import (
    Profile,
    along_line,
    jerk_limited,
    ptp,
    retimed,
    time_optimal,
    trapezoid_profile,
)
from robocell.trajectory.trajectory import JointTrajectory, TrajectorySample, stationary

__all__ = [
    "BlendedPath",
    "SplinePath",
    "Profile",
    "along_line",
    "plot_trajectory",
    "JointTrajectory",
    "TrajectorySample",
    "jerk_limited",
    "ptp",
    "retimed",
    "stationary",
    "time_optimal",
    "trapezoid_profile",
]
