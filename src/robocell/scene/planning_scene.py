"""The planning scene: what the planner believes about the world (MoveIt's PlanningScene).

World objects in the scene's frame ("world"), where the robot's root link sits at
``robot_pose``; objects held by the robot; the allowed-collision matrix; the robot's current
state. Every operation validates everything first and changes nothing when it fails.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import SceneError, choices, number, unknown, vector
from robocell.geometry.pose import Pose, invert_transform
from robocell.geometry.shapes import Box, Cylinder, Mesh, Shape, Sphere
from robocell.kinematics.fk import link_poses
from robocell.robot.model import JointGroup, RobotModel, RobotState
from robocell.scene.acm import AllowedCollisionMatrix
from robocell.scene.checker import CollisionChecker
from robocell.scene.objects import AttachedObject, CollisionObject


@dataclass(frozen=True)
class DistanceResult:
    """The closest pair at a state: ``distance`` in [m] (negative or 0 when in contact)."""

    distance: float
    pair: tuple[str, str]


class PlanningScene:
    """World objects, held objects, allowed collisions and the robot's state, for one robot."""

    def __init__(self, robot: RobotModel, robot_pose: Pose | None = None, name: str = "") -> None:
        self.robot = robot
        self.name = name
        self.robot_pose = robot_pose or Pose()
        self.state: RobotState = robot.default_state()
        self._world: dict[str, CollisionObject] = {}
        self._attached: dict[str, AttachedObject] = {}
        self.acm = AllowedCollisionMatrix(robot.disabled_collisions)
        self._version = 0
        self._checkers: dict[tuple[object, ...], CollisionChecker] = {}
        self._padding: dict[str, float] = {}
        self._unpadded: dict[tuple[object, ...], PlanningScene] = {}

    # ------------------------------------------------------------------ frames and state
    @property
    def T_world_root(self) -> NDArray[np.float64]:
        return self.robot_pose.matrix()

    @property
    def T_root_world(self) -> NDArray[np.float64]:
        return invert_transform(self.robot_pose.matrix())

    def set_joint_positions(self, group: str | JointGroup, q: ArrayLike) -> None:
        """Set the current joint values of a group (validated: length, finite, within limits)."""
        g = group if isinstance(group, JointGroup) else self.robot.group(group)
        arr = g.as_joint_vector(q)
        bad = g.limit_violations(arr)
        if bad:
            raise SceneError(f"joint values outside limits for group {g.name!r}: {'; '.join(bad)}")
        self.state.set_group_positions(g, arr)

    def link_pose(self, link: str) -> Pose:
        """The current pose of a robot link in the world frame."""
        i = self.robot.link_index(link)
        return Pose.from_matrix(self.T_world_root @ link_poses(self.robot, self.state.positions)[i])

    # ------------------------------------------------------------------ world objects
    @property
    def world_objects(self) -> dict[str, CollisionObject]:
        return dict(self._world)

    @property
    def attached_objects(self) -> dict[str, AttachedObject]:
        return dict(self._attached)

    @property
    def object_ids(self) -> list[str]:
        """Ids of the world objects (held objects are listed by ``attached_objects``)."""
        return list(self._world)

    def _changed(self) -> None:
        self._version += 1
        self._checkers.clear()
        self._unpadded = {}

    def add_object(self, obj: CollisionObject) -> None:
        """Add a world object; its id must be new (neither in the world nor held)."""
        if not isinstance(obj, CollisionObject):
            raise SceneError(f"add_object takes a CollisionObject, got {type(obj).__name__}")
        if obj.id in self._world or obj.id in self._attached:
            raise SceneError(
                f"an object with id {obj.id!r} already exists; ids in the scene: "
                f"{choices([*self._world, *self._attached])}"
            )
        if obj.id in self.robot.link_names:
            raise SceneError(f"object id {obj.id!r} is the name of a robot link; choose another")
        self._world[obj.id] = obj
        self._changed()

    def set_object_padding(self, id: str, padding: float) -> None:
        """Plan ``padding`` [m] clear of an object: its shapes count grown by that much
        (boxes, cylinders and spheres) in every collision check, so that a path that grazes
        a world object in the plan does not knock it over in the world, and a held object,
        which swings a little in the fingers, does not hit the world. 0 removes the padding."""
        if not isinstance(id, str) or (id not in self._world and id not in self._attached):
            raise SceneError(unknown("object", id, [*self._world, *self._attached]))
        p = number(padding, "padding [m]", SceneError)
        if p < 0:
            raise SceneError(f"padding must be >= 0 [m], got {padding!r}")
        obj = self._world.get(id) or self._attached[id].object
        for shape in obj.shapes:
            if p and not isinstance(shape, Box | Cylinder | Sphere):
                raise SceneError(
                    f"object {id!r}: only primitives can be padded, not a {shape.kind}"
                )
        if p:
            self._padding[id] = p
        else:
            self._padding.pop(id, None)
        self._changed()

    def object_padding(self, id: str) -> float:
        """The padding [m] of an object, in the world or held (0 if none)."""
        if not isinstance(id, str):
            raise SceneError(unknown("object", id, [*self._world, *self._attached]))
        return self._padding.get(id, 0.0)

    def without_padding(self, ids: Iterable[str]) -> PlanningScene:
        """This scene with the padding of objects ``ids`` removed, to be read, not changed
        (``copy()`` it first): the same copy, and so the same checkers, for as long as this
        scene, its allowed collisions and its state stay as they are; this scene itself if
        none of them is padded. (The sorting demo's place candidates asked for such a copy
        41 times per object, each building a checker of its own: 1.3 s per layout.)"""
        ids = [ids] if isinstance(ids, str) or not isinstance(ids, Iterable) else [*ids]
        for id in ids:
            if not isinstance(id, str) or (id not in self._world and id not in self._attached):
                raise SceneError(unknown("object", id, [*self._world, *self._attached]))
        padded = tuple(sorted(id for id in ids if id in self._padding))
        if not padded:
            return self
        key = (padded, self._version, self.acm.version, self.state.positions.tobytes())
        if key not in self._unpadded:
            other = self.copy()
            for id in padded:
                other.set_object_padding(id, 0.0)
            self._unpadded = {key: other}  # one at a time: each holds checkers
        return self._unpadded[key]

    def add_shape(
        self, id: str, shape: Shape, pose: Pose | ArrayLike | None = None
    ) -> CollisionObject:
        """Add a one-shape object at ``pose`` (world frame) and return it."""
        obj = CollisionObject.single(id, shape, Pose.from_any(pose if pose is not None else Pose()))
        self.add_object(obj)
        return obj

    def add_box(self, id: str, pose: Pose | ArrayLike, size: ArrayLike) -> CollisionObject:
        """A box of full extents ``size`` (x, y, z) [m] centred at ``pose``."""
        sx, sy, sz = vector(size, 3, "a box's size (x, y, z) [m]", SceneError).tolist()
        return self.add_shape(id, Box((sx, sy, sz)), pose)

    def add_cylinder(
        self, id: str, pose: Pose | ArrayLike, radius: float, length: float
    ) -> CollisionObject:
        """A cylinder (axis z, centred) of ``radius`` and ``length`` [m] at ``pose``."""
        return self.add_shape(id, Cylinder(radius, length), pose)

    def add_sphere(self, id: str, pose: Pose | ArrayLike, radius: float) -> CollisionObject:
        return self.add_shape(id, Sphere(radius), pose)

    def add_mesh(
        self, id: str, pose: Pose | ArrayLike, path: str | Path, scale: ArrayLike = (1.0, 1.0, 1.0)
    ) -> CollisionObject:
        """A mesh read from an STL, OBJ or DAE file, at ``pose``."""
        return self.add_shape(id, Mesh.from_file(path, scale), pose)

    def get_object(self, id: str) -> CollisionObject:
        """A world object by id (a held object: see ``attached_objects``)."""
        if not isinstance(id, str) or id not in self._world:
            raise SceneError(unknown("object", id, self._world))
        return self._world[id]

    def move_object(self, id: str, pose: Pose | ArrayLike) -> None:
        """Move a world object to ``pose`` (world frame)."""
        obj = self.get_object(id)
        self._world[id] = obj.moved(Pose.from_any(pose))
        self._changed()

    def remove_object(self, id: str) -> None:
        """Remove a world object (detach a held one first)."""
        if not isinstance(id, str):
            raise SceneError(unknown("object", id, self._world))
        if id in self._attached:
            raise SceneError(
                f"object {id!r} is held by link {self._attached[id].link!r}; detach it first"
            )
        self.get_object(id)
        del self._world[id]
        self.acm.remove(id)
        self._changed()

    def remove_world_object(self, name: str | None = None) -> bool:
        """MoveIt's PlanningSceneInterface call: remove world object ``name`` if the world
        has it (the idempotent clean-up MoveIt scripts start with), or every world object
        for None; whether anything was removed. A held object is refused as by
        :meth:`remove_object`."""
        if name is None:
            removed = bool(self._world)
            for id in list(self._world):
                self.remove_object(id)
            return removed
        if not isinstance(name, str):
            raise SceneError(unknown("object", name, self._world))
        if name not in self._world and name not in self._attached:
            return False
        self.remove_object(name)
        return True

    def remove_attached_object(self, link: str | None = None, name: str | None = None) -> bool:
        """MoveIt's PlanningSceneInterface call: detach the held object ``name`` (None: every
        object held by ``link``, or every held object), each back into the world where it is
        now, as MoveIt does; whether anything was detached."""
        if link is not None:
            self.robot.link_index(link, "remove_attached_object link")
        if name is not None and (not isinstance(name, str) or name not in self._attached):
            raise SceneError(
                f"object {name!r} is not attached; attached: {choices(self._attached)}"
            )
        ids = [
            id
            for id, held in self._attached.items()
            if (name is None or id == name) and (link is None or held.link == link)
        ]
        for id in ids:
            self.detach_object(id)
        return bool(ids)

    def get_known_object_names(self) -> list[str]:
        """Ids of the world objects and the held ones (MoveIt's PlanningSceneInterface)."""
        return sorted([*self._world, *self._attached])

    def clear(self) -> None:
        """Remove every world object and held object."""
        for id in [*self._world, *self._attached]:
            self.acm.remove(id)
        self._world.clear()
        self._attached.clear()
        self._changed()

    # ------------------------------------------------------------------ attached objects
    def attach_object(
        self, id: str, link: str, touch_links: Iterable[str] | None = None
    ) -> AttachedObject:
        """Attach world object ``id`` to ``link``, keeping its current world pose. Touch links
        (allowed to touch it) default to ``link`` and the links of any end effector on ``link``."""
        obj = self.get_object(id)
        self.robot.link_index(link, "attach_object")
        if touch_links is None:
            # the link, and the links of an end effector on the same rigid body (a TCP frame
            # welded to the flange carries the gripper mounted there)
            touch = {link}
            tree, robot = self.robot.tree, self.robot
            body = tree.rigid_root(robot.link_index(link))
            for ee in robot.end_effectors.values():
                ee_links = robot.group(ee.group).link_names
                if (
                    ee.parent_link == link
                    or link in ee_links
                    or tree.rigid_root(robot.link_index(ee.parent_link)) == body
                ):
                    touch |= set(ee_links)
        else:
            touch = set(touch_links)
            for t in touch:
                self.robot.link_index(t, "touch_links")
        T_world_link = self.link_pose(link).matrix()
        T_link_obj = invert_transform(T_world_link) @ obj.pose.matrix()
        held = AttachedObject(obj.moved(Pose.from_matrix(T_link_obj)), link, frozenset(touch))
        del self._world[id]
        self._attached[id] = held
        self._changed()
        return held

    def detach_object(self, id: str) -> CollisionObject:
        """Put a held object back into the world at its current pose."""
        if not isinstance(id, str) or id not in self._attached:
            raise SceneError(f"object {id!r} is not attached; attached: {choices(self._attached)}")
        held = self._attached[id]
        T_world_obj = self.link_pose(held.link).matrix() @ held.object.pose.matrix()
        obj = held.object.moved(Pose.from_matrix(T_world_obj))
        del self._attached[id]
        self._world[id] = obj
        self._changed()
        return obj

    # ------------------------------------------------------------------ allowed collisions
    def allow_collision(self, a: str, b: str | Iterable[str], allowed: bool = True) -> None:
        """Allow (or forbid) contact between two names: links, object ids."""
        known = set(self.robot.link_names) | set(self._world) | set(self._attached)
        for name in [a, *([b] if isinstance(b, str) or not isinstance(b, Iterable) else b)]:
            if not isinstance(name, str) or name not in known:
                raise SceneError(unknown("link or object", name, known))
        self.acm.set_entry(a, b, allowed)
        self._changed()

    # ------------------------------------------------------------------ queries
    def checker(self, group: str | JointGroup) -> CollisionChecker:
        """The batched checker for ``group`` at this scene's contents, other joints as now."""
        g = group if isinstance(group, JointGroup) else self.robot.group(group)
        others = self.state.positions.copy()
        others[g.positions] = 0.0  # the other joints' values (np.delete cost 6 µs a plan)
        key = (g.name, self._version, self.acm.version, others.tobytes())
        if key not in self._checkers:
            # a few checkers are kept (a gripper opening and closing switches between two);
            # each holds its sphere model's scratch, so the oldest goes beyond eight
            while len(self._checkers) >= 8:
                self._checkers.pop(next(iter(self._checkers)))
            self._checkers[key] = CollisionChecker(self, g)
        return self._checkers[key]

    def _group_and_q(
        self, q: ArrayLike | None, group: str | JointGroup | None
    ) -> tuple[JointGroup, NDArray[np.float64]]:
        if group is None:
            all_group = self._all_group()
            return (
                all_group,
                self.state.positions.copy() if q is None else all_group.as_joint_vector(q),
            )
        g = group if isinstance(group, JointGroup) else self.robot.group(group)
        return g, self.state.group_positions(g) if q is None else g.as_joint_vector(q)

    def _all_group(self) -> JointGroup:
        """A group of every variable, for whole-robot queries."""
        if not hasattr(self, "_whole"):
            r = self.robot
            idx = np.arange(r.n_variables)
            self._whole = JointGroup(
                "(all joints)",
                list(r.variable_names),
                idx,
                r.lower.copy(),
                r.upper.copy(),
                r.velocity_limits.copy(),
                r.acceleration_limits.copy(),
                r.jerk_limits.copy(),
                r.continuous.copy(),
                r.root_link,
                "",
                list(r.link_names),
                r.default_positions.copy(),
                {},
                r,
            )
        return self._whole

    def in_collision(
        self, q: ArrayLike | None = None, group: str | JointGroup | None = None
    ) -> bool:
        """Whether the robot (state now, or group values ``q``) collides."""
        g, qv = self._group_and_q(q, group)
        return bool(self.checker(g).check(qv[None])[0])

    def is_state_valid(
        self, q: ArrayLike | None = None, group: str | JointGroup | None = None
    ) -> bool:
        """Collision-free and within joint limits."""
        g, qv = self._group_and_q(q, group)
        return bool(g.within_limits(qv)) and not self.in_collision(qv, g)

    def colliding_pairs(
        self, q: ArrayLike | None = None, group: str | JointGroup | None = None
    ) -> list[tuple[str, str]]:
        """Names of the pairs in collision (links, object ids)."""
        g, qv = self._group_and_q(q, group)
        return self.checker(g).colliding_pairs(qv)

    def distance(
        self, q: ArrayLike | None = None, group: str | JointGroup | None = None
    ) -> DistanceResult:
        """The smallest distance between any checked pair, and that pair."""
        g, qv = self._group_and_q(q, group)
        d, pair = self.checker(g).min_distance(qv)
        return DistanceResult(d, pair)

    def copy(self) -> PlanningScene:
        """An independent copy (objects are immutable and shared)."""
        other = copy.copy(self)
        other.state = self.state.copy()
        other._world = dict(self._world)
        other._attached = dict(self._attached)
        other.acm = self.acm.copy()
        other._checkers = {}
        other._padding = dict(self._padding)
        other._unpadded = {}
        if hasattr(other, "_whole"):
            del other._whole
        return other
