"""World collision objects and attached objects (MoveIt's CollisionObject and
AttachedCollisionObject)."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from robocell.errors import SceneError
from robocell.geometry.pose import Pose
from robocell.geometry.shapes import Box, Cylinder, Mesh, Shape, Sphere

_ID = re.compile(r"^[A-Za-z0-9_.\-/]+$")


@dataclass(frozen=True)
class CollisionObject:
    """An object of the world: ``shapes`` at ``shape_poses`` in the object's frame, which is at
    ``pose`` in the world (scene) frame. World pose of shape i = pose * shape_poses[i]."""

    id: str
    shapes: tuple[Shape, ...]
    shape_poses: tuple[Pose, ...]
    pose: Pose = field(default_factory=Pose)

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not _ID.match(self.id):
            raise SceneError(
                f"object id {self.id!r} is not valid: use letters, digits, '_', '-', '.', '/'"
            )
        shapes = tuple(self.shapes)
        poses = tuple(Pose.from_any(p) for p in self.shape_poses)
        if not shapes:
            raise SceneError(f"object {self.id!r} has no shapes")
        if len(poses) != len(shapes):
            raise SceneError(
                f"object {self.id!r}: {len(shapes)} shapes but {len(poses)} shape poses"
            )
        for s in shapes:
            if not isinstance(s, Box | Cylinder | Sphere | Mesh):
                raise SceneError(
                    f"object {self.id!r}: {s!r} is not a Box, Cylinder, Sphere or Mesh"
                )
        object.__setattr__(self, "shapes", shapes)
        object.__setattr__(self, "shape_poses", poses)
        object.__setattr__(self, "pose", Pose.from_any(self.pose))

    @classmethod
    def single(cls, id: str, shape: Shape, pose: Pose | None = None) -> CollisionObject:
        """One shape at the object's origin."""
        return cls(id, (shape,), (Pose(),), pose or Pose())

    def shape_matrices(self) -> list[NDArray[np.float64]]:
        """World 4×4 pose of each shape."""
        T = self.pose.matrix()
        return [T @ p.matrix() for p in self.shape_poses]

    def moved(self, pose: Pose) -> CollisionObject:
        return CollisionObject(self.id, self.shapes, self.shape_poses, pose)


@dataclass(frozen=True)
class AttachedObject:
    """An object held by the robot: ``object.pose`` is its pose in ``link``'s frame. Links in
    ``touch_links`` may touch it (the gripper's fingers), as MoveIt's touch_links."""

    object: CollisionObject
    link: str
    touch_links: frozenset[str]

    @property
    def id(self) -> str:
        return self.object.id
