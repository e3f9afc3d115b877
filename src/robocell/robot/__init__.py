"""Robot descriptions: URDF + SRDF (+ joint_limits.yaml), groups, named states, bundled robots."""

from robocell.robot.model import (
    EndEffector,
    JointGroup,
    KinematicTree,
    LinkGeometry,
    RobotModel,
    RobotState,
    bundled_robots,
)
from robocell.robot.srdf import Srdf, parse_srdf
from robocell.robot.urdf import UrdfRobot, parse_urdf

__all__ = [
    "EndEffector",
    "JointGroup",
    "KinematicTree",
    "LinkGeometry",
    "RobotModel",
    "RobotState",
    "Srdf",
    "UrdfRobot",
    "bundled_robots",
    "parse_srdf",
    "parse_urdf",
]
