"""The planning scene: world and attached objects, allowed collisions, collision and distance
queries (batched, two-level), MoveIt scene and request YAML."""

from robocell.scene.acm import AllowedCollisionMatrix
from robocell.scene.checker import CollisionChecker, robot_spheres
from robocell.scene.moveit_yaml import (
    PlanRequest,
    load_request,
    load_scene,
    save_scene,
    scene_to_dict,
)
from robocell.scene.objects import AttachedObject, CollisionObject
from robocell.scene.planning_scene import DistanceResult, PlanningScene
from robocell.scene.spheres import SphereTree, body_tree

__all__ = [
    "AllowedCollisionMatrix",
    "AttachedObject",
    "CollisionChecker",
    "CollisionObject",
    "DistanceResult",
    "PlanRequest",
    "PlanningScene",
    "SphereTree",
    "load_request",
    "load_scene",
    "robot_spheres",
    "save_scene",
    "scene_to_dict",
    "body_tree",
]
