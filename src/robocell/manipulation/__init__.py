"""Pick and place as stages with fallbacks."""

from robocell.manipulation.pick_place import ManipulationResult, Manipulator, StageResult

__all__ = ["ManipulationResult", "Manipulator", "StageResult"]
