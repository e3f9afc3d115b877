"""The seed exercise's API and its two user-code templates (web: ``from HAL import HAL``; script:
``myalgorithm(self)`` with ``self.pick_place``), run by ``robocell run FILE``."""

from robocell.exercise.msgs import Point, PoseMsg, Quaternion
from robocell.exercise.pick_place import (
    ORIENTATIONS,
    WORKSPACE_WARNING,
    PickPlace,
    in_workspace,
)

__all__ = [
    "ORIENTATIONS",
    "PickPlace",
    "Point",
    "PoseMsg",
    "Quaternion",
    "WORKSPACE_WARNING",
    "in_workspace",
]
