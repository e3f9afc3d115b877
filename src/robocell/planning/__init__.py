"""Motion planning: requests and goals, RRT-Connect on the batched checker (OMPL optional),
path shortcutting, validation, Cartesian paths."""

from robocell.planning.planner import Planner, PlannerConfig
from robocell.planning.request import (
    Goal,
    JointGoal,
    MotionPlan,
    MotionPlanRequest,
    PoseGoal,
    PositionGoal,
)

__all__ = [
    "Goal",
    "JointGoal",
    "MotionPlan",
    "MotionPlanRequest",
    "Planner",
    "PlannerConfig",
    "PoseGoal",
    "PositionGoal",
]
