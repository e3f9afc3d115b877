"""Forward kinematics, Jacobians, inverse kinematics (analytic OPW/UR and numeric)."""

from robocell.kinematics.analytic import OPWParameters, URParameters
from robocell.kinematics.fk import fk, fk_batch, jacobian, link_poses, link_poses_batch
from robocell.kinematics.ik import (
    AnalyticIK,
    IKResult,
    IKSolver,
    NumericIK,
    NumericIKConfig,
    ik_solver,
    pose_error,
    solve_ik,
)

__all__ = [
    "AnalyticIK",
    "IKResult",
    "IKSolver",
    "NumericIK",
    "NumericIKConfig",
    "OPWParameters",
    "URParameters",
    "fk",
    "fk_batch",
    "ik_solver",
    "jacobian",
    "link_poses",
    "link_poses_batch",
    "pose_error",
    "solve_ik",
]
