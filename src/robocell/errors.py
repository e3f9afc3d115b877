"""The one error hierarchy of robocell.

Every error a user can reach is a :class:`RobocellError`. Messages name what was wrong and list
the valid choices, so that a typo is fixed from the message alone.
"""

from __future__ import annotations

from collections.abc import Iterable


class RobocellError(Exception):
    """Root of every error robocell raises on purpose."""


class GeometryError(RobocellError, ValueError):
    """A pose, rotation or shape is malformed (NaN, zero quaternion, non-positive size)."""


class ModelError(RobocellError):
    """A robot description (URDF, SRDF, joint limits) is malformed or names something unknown."""


class IKError(RobocellError):
    """Inverse kinematics was asked something it cannot answer (not 'no solution': that is a
    result, see :class:`robocell.kinematics.IKResult`)."""


class SceneError(RobocellError):
    """A planning-scene operation names an unknown or duplicate object, or bad geometry."""


class PlanningError(RobocellError):
    """A motion-planning request is malformed."""


class ExecutionError(RobocellError):
    """A trajectory cannot be executed."""


class CellError(RobocellError):
    """A cell file is malformed (unknown key, missing field, bad value, unknown robot or mesh)."""


class SimulationError(RobocellError):
    """The physics world diverged or was asked something it cannot do."""


class GraspError(RobocellError):
    """A grasp or place request is malformed."""


class ExerciseError(RobocellError):
    """A user's exercise file cannot be run (missing, not Python, nothing to run)."""


def choices(names: Iterable[str], limit: int = 30) -> str:
    """Format valid choices for an error message: ``'a, b, c'`` (sorted, at most ``limit``)."""
    items = sorted(names)
    if not items:
        return "(none)"
    shown = ", ".join(items[:limit])
    return shown if len(items) <= limit else f"{shown}, … ({len(items)} in all)"


def unknown(kind: str, name: object, known: Iterable[str]) -> str:
    """The standard message for an unknown name: ``unknown link 'x'; known: a, b``."""
    return f"unknown {kind} {name!r}; known: {choices(known)}"
