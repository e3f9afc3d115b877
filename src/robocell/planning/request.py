"""Motion plan requests, goals and results (MoveIt's MotionPlanRequest / MotionPlanResponse).

Poses and positions of goals are in the planning scene's world frame.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from robocell.geometry.pose import Pose
from robocell.trajectory.trajectory import JointTrajectory


@dataclass(frozen=True)
class JointGoal:
    """Reach ``positions`` (dof,) in the group's joint order, each joint within ``tolerance``
    [rad or m]."""

    positions: NDArray[np.float64]
    tolerance: float = 1e-4


@dataclass(frozen=True)
class PoseGoal:
    """Bring ``link`` to ``pose`` (world frame) within ``position_tolerance`` [m] and
    ``orientation_tolerance`` [rad]. Any collision-free IK solution is a valid goal."""

    link: str
    pose: Pose
    position_tolerance: float = 1e-4
    orientation_tolerance: float = 1e-3


@dataclass(frozen=True)
class PositionGoal:
    """Bring the origin of ``link`` to ``position`` (3,) [m] (world frame), any orientation,
    within ``tolerance`` [m]."""

    link: str
    position: NDArray[np.float64]
    tolerance: float = 1e-4


Goal = JointGoal | PoseGoal | PositionGoal


@dataclass
class MotionPlanRequest:
    """What to plan: ``group`` from ``start`` (default: the scene's current state) to ``goal``.

    ``planning_time`` [s] is the budget of the whole request; ``attempts`` independent plans
    are made within it and the shortest is returned (MoveIt's num_planning_attempts).
    ``seed`` makes the result reproducible. ``fix_start`` nudges a start state that is in
    collision or slightly outside its limits to the nearest valid state (MoveIt's start
    state adapters) instead of refusing it.
    """

    group: str
    goal: Goal
    start: NDArray[np.float64] | None = None
    planning_time: float = 1.0
    attempts: int = 1
    seed: int | None = 0
    velocity_scaling: float = 1.0
    acceleration_scaling: float = 1.0
    planner_id: str = ""
    fix_start: bool = False
    time_parameterize: bool = True


@dataclass
class MotionPlan:
    """The result of planning. ``path`` (K, dof) are the waypoints (straight in joint space
    between them, corners rounded in ``trajectory``); ``trajectory`` is timed and validated.
    When ``success`` is False, ``reason`` says why."""

    success: bool
    group: str
    path: NDArray[np.float64]
    trajectory: JointTrajectory | None
    planning_time: float
    reason: str = ""
    planner: str = ""
    stats: dict[str, float] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return self.success

    def __iter__(self) -> Iterator[object]:
        """Unpacks as moveit_commander's ``plan()`` result since Noetic: ``success,
        trajectory, planning_time, error`` (here the error is ``reason``, "" on success)."""
        return iter((self.success, self.trajectory, self.planning_time, self.reason))

    @property
    def path_length(self) -> float:
        """Joint-space length of the path [rad] (Euclidean)."""
        if len(self.path) < 2:
            return 0.0
        return float(np.linalg.norm(np.diff(self.path, axis=0), axis=1).sum())
