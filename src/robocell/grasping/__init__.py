"""Grasps and place locations (MoveIt's records), gripper geometry from the robot description,
and candidate generators for boxes, cylinders and spheres."""

from robocell.grasping.generators import (
    generate_grasps,
    generate_places,
    generate_pushes,
    reachable_places,
)
from robocell.grasping.grasp import Grasp, GripperGeometry, GripperTranslation, PlaceLocation, Push

__all__ = [
    "Grasp",
    "GripperGeometry",
    "GripperTranslation",
    "PlaceLocation",
    "Push",
    "generate_grasps",
    "generate_places",
    "generate_pushes",
    "reachable_places",
]
