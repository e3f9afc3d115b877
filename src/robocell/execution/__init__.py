"""Execution: controllers that carry out trajectories (kinematic demo mode here; physics with
the world), execution handles and results."""

from robocell.execution.controller import (
    Controller,
    ExecutionHandle,
    ExecutionResult,
    ExecutionStatus,
    KinematicController,
    stopping_trajectory,
    validate_trajectory,
)

__all__ = [
    "Controller",
    "ExecutionHandle",
    "ExecutionResult",
    "ExecutionStatus",
    "KinematicController",
    "stopping_trajectory",
    "validate_trajectory",
]
