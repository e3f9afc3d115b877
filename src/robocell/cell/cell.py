"""A cell: one robot, fixtures, objects, targets and cameras from one cell file, building both
the planning scene (what the planner believes) and the physics world (what is).

They are separate on purpose, as MoveIt's scene is from Gazebo's world: :meth:`Cell.sync_scene`
copies the world's ground truth into the scene; the world never reads the scene.

    cell = Cell.load("sorting")                 # physics (MuJoCo); mode="kinematic": demo mode
    arm = cell.move_group("arm")
    arm.set_named_target("home"); arm.go()
    cell.world.object_pose("blue_ball")
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.cell.cell_file import CellSpec, cell_path, load_cell_file
from robocell.cell.move_group import MoveGroup
from robocell.errors import CellError, choices
from robocell.execution.controller import Controller, KinematicController
from robocell.geometry.pose import Pose
from robocell.planning.planner import PlannerConfig
from robocell.robot.model import RobotModel
from robocell.scene.objects import CollisionObject
from robocell.scene.planning_scene import PlanningScene

if TYPE_CHECKING:
    from robocell.execution.physics import Stepper

MODES = ("physics", "kinematic")


class Cell:
    """A work cell. ``mode``: "physics" (a MuJoCo world plays the robot) or "kinematic" (demo
    mode: the scene's robot follows trajectories exactly; objects do not move by themselves).
    ``realtime`` paces the physics to the wall clock (for viewing); ``time_scale`` sets the
    kinematic controller's pace (0: at once); ``object_padding`` [m]: how far plans keep clear
    of the free objects (see :meth:`PlanningScene.set_object_padding`); ``planner_config``:
    the move groups' planner settings (e.g. ``PlannerConfig(continuous=True)``: every
    motion proven free, not only checked at fine steps)."""

    def __init__(
        self,
        spec: CellSpec,
        layout: int = 0,
        mode: str = "physics",
        realtime: bool = False,
        time_scale: float = 1.0,
        object_padding: float = 0.01,
        planner_config: PlannerConfig | None = None,
    ) -> None:
        if not isinstance(mode, str) or mode not in MODES:
            raise CellError(f"unknown mode {mode!r}; known: {', '.join(MODES)}")
        self.spec = spec
        self.mode = mode
        rs = spec.robots[0]
        self.robot_spec = rs
        try:
            if rs.model is not None:
                self.robot = RobotModel.load(rs.model)
            else:
                assert rs.urdf is not None
                self.robot = RobotModel.from_urdf(rs.urdf, rs.srdf)
        except Exception as exc:
            raise CellError(f"{spec.source}: robot {rs.name!r}: {exc}") from exc
        for g in [rs.arm] + ([rs.gripper] if rs.gripper else []):
            if g not in self.robot.group_names:
                raise CellError(
                    f"{spec.source}: robot {rs.name!r}: unknown group {g!r}; "
                    f"known: {choices(self.robot.group_names)}"
                )
        self.layout = layout
        self._initial = spec.layout(layout)
        self.scene = PlanningScene(self.robot, rs.pose, spec.name)
        for f in spec.fixtures:
            self.scene.add_object(
                CollisionObject(
                    f.name, tuple(p.shape for p in f.parts), tuple(p.pose for p in f.parts), f.pose
                )
            )
        for o in spec.objects:
            self.scene.add_object(
                CollisionObject(o.name, (o.shape,), (Pose(),), self._initial[o.name])
            )
        # plans keep clear of the free objects, so that a path that grazes one in the plan
        # does not knock it over in physics (MuJoCo collides the convex hulls of meshes)
        for o in spec.objects:
            self.scene.set_object_padding(o.name, object_padding)
        # what the robot stands on at its default state (its pedestal) may touch it
        for link, other in self.scene.colliding_pairs(self.robot.default_positions):
            fixture = other if other in [f.name for f in spec.fixtures] else link
            robot_link = link if fixture == other else other
            self.scene.allow_collision(robot_link, fixture)
        self.world = None
        self._stepper = None
        if mode == "physics":
            from robocell.execution.physics import Stepper
            from robocell.sim.world import Camera, FixtureGeom, FreeObject, World

            fixtures = [
                FixtureGeom(f.name, p.shape, f.pose * p.pose, f.color, f.friction)
                for f in spec.fixtures
                for p in f.parts
            ]
            objects = [
                FreeObject(o.name, o.shape, self._initial[o.name], o.mass, o.friction, o.color)
                for o in spec.objects
            ]
            cams = [Camera(c.name, c.position, c.look_at, c.fovy, c.width, c.height)
                    for c in spec.cameras]  # fmt: skip
            self.world = World(self.robot, rs.pose, fixtures, objects, cams)
            self._stepper = Stepper(self.world, realtime)
        self.time_scale = time_scale
        self.planner_config = planner_config
        self._controllers: dict[str, Controller] = {}
        self._groups: dict[str, MoveGroup] = {}
        self._boxes: dict[str, list[NDArray[np.float64]]] = {}

    @classmethod
    def load(
        cls,
        name_or_path: str | Path,
        layout: int = 0,
        mode: str = "physics",
        realtime: bool = False,
        time_scale: float = 1.0,
        planner_config: PlannerConfig | None = None,
    ) -> Cell:
        """A bundled cell by name (``"sorting"``) or a cell file by path."""
        return cls(
            load_cell_file(cell_path(name_or_path)),
            layout,
            mode,
            realtime,
            time_scale,
            planner_config=planner_config,
        )

    @property
    def stepper(self) -> Stepper | None:
        """The thread that steps the world for the controllers (None in kinematic mode); its
        ``real_time_factor`` is what the stepping achieved so far."""
        return self._stepper

    # ------------------------------------------------------------------ names
    @property
    def object_names(self) -> list[str]:
        return [o.name for o in self.spec.objects]

    @property
    def target_names(self) -> list[str]:
        return [t.name for t in self.spec.targets]

    def target_position(self, name: str, frame: str = "robot") -> NDArray[np.float64]:
        """A target's position [m] in the robot base frame (``frame="robot"``) or the world."""
        if not isinstance(frame, str) or frame not in ("robot", "world"):
            raise CellError(f"unknown frame {frame!r}; known: robot, world")
        for t in self.spec.targets:
            if isinstance(name, str) and t.name == name:
                p = np.array(t.position, dtype=float)
                T_w_r = self.robot_spec.pose.matrix()
                if t.frame == frame:
                    return p
                if t.frame == "robot":  # to world
                    return (T_w_r @ np.append(p, 1.0))[:3]
                return (np.linalg.inv(T_w_r) @ np.append(p, 1.0))[:3]
        raise CellError(f"unknown target {name!r}; known: {choices(self.target_names)}")

    # ------------------------------------------------------------------ state
    def _part_boxes(self, name: str) -> list[NDArray[np.float64]]:
        """World-aligned boxes (2×3: min, max corners) around each part of a fixture [m]."""
        from robocell.geometry.shapes import triangulate

        if not isinstance(name, str) or name not in self._boxes:
            fixtures = self.spec.fixtures if isinstance(name, str) else []
            f = next((f for f in fixtures if f.name == name), None)
            if f is None:
                known = choices(x.name for x in self.spec.fixtures)
                raise CellError(f"unknown fixture {name!r}; known: {known}")
            boxes = []
            for part in f.parts:
                v, _ = triangulate(part.shape, 16)
                T = (f.pose * part.pose).matrix()
                w = v @ T[:3, :3].T + T[:3, 3]
                boxes.append(np.array([w.min(axis=0), w.max(axis=0)]))
            self._boxes[name] = boxes
        return self._boxes[name]

    def fixture_bounds(self, name: str) -> NDArray[np.float64]:
        """The world-aligned box (2×3: min, max corners) around a fixture's parts [m]."""
        boxes = np.array(self._part_boxes(name))
        return np.array([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])

    def inside(self, name: str, fixture: str) -> bool:
        """Whether the object's centre lies within the fixture's bounds: inside a tray's
        footprint and below its wall tops (the sorting spec's success, without "at rest")."""
        lo, hi = self.fixture_bounds(fixture)
        p = self.object_pose(name).position
        return bool(np.all(p >= lo) and np.all(p <= hi))

    def container_of(self, name: str) -> str | None:
        """The fixture the object is inside (a tray), if any."""
        for f in self.spec.fixtures:
            if self.inside(name, f.name):
                return f.name
        return None

    def free_spots(
        self,
        fixture: str,
        radius: float,
        near: ArrayLike | None = None,
        clearance: float = 0.01,
        step: float = 0.02,
    ) -> NDArray[np.float64]:
        """Where an object of footprint ``radius`` [m] fits on a fixture's floor (a tray's):
        points (N×3, world; z on the floor's top) on a grid of ``step``, at least ``clearance``
        from the fixture's walls (its parts that rise above the floor) and from every object
        there now, nearest to ``near`` (xy) first (default: the fixture's centre)."""
        lo, hi = self.fixture_bounds(fixture)
        boxes = self._part_boxes(fixture)
        floor = min(b[1][2] for b in boxes)
        walls = [b for b in boxes if b[1][2] > floor + 1e-3]
        xs = np.arange(lo[0], hi[0] + 1e-9, step)
        ys = np.arange(lo[1], hi[1] + 1e-9, step)
        P = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
        keep = np.ones(len(P), dtype=bool)
        for b_lo, b_hi in walls:
            d = np.linalg.norm(np.maximum(0.0, np.maximum(b_lo[:2] - P, P - b_hi[:2])), axis=1)
            keep &= d >= radius + clearance
        for o in self.spec.objects:
            if o.name in self.scene.attached_objects:
                continue
            c = self.object_pose(o.name).position
            if not (lo[2] - 0.05 <= c[2] <= hi[2] + 0.2):
                continue
            r_o = 0.5 * math.hypot(o.size[0], o.size[1])
            keep &= np.linalg.norm(P - c[:2], axis=1) >= radius + r_o + clearance
        P = P[keep]
        ref = 0.5 * (lo + hi) if near is None else np.asarray(near, dtype=float)
        P = P[np.argsort(np.linalg.norm(P - ref[:2], axis=1), kind="stable")]
        return np.column_stack([P, np.full(len(P), floor)])

    def object_pose(self, name: str) -> Pose:
        """An object's pose in the world frame: the world's ground truth in physics mode, the
        scene's in kinematic mode (held objects follow the gripper)."""
        if not isinstance(name, str) or name not in self.object_names:
            raise CellError(f"unknown object {name!r}; known: {choices(self.object_names)}")
        if self.world is not None:
            return self.world.object_pose(name)
        if name in self.scene.attached_objects:
            held = self.scene.attached_objects[name]
            return self.scene.link_pose(held.link) * held.object.pose
        return self.scene.get_object(name).pose

    def sync_robot_state(self) -> None:
        """The scene's robot state from the world (physics mode)."""
        if self.world is not None:
            self.scene.state.positions[:] = self.world.robot_positions()

    def sync_scene(self) -> None:
        """The scene's robot state and free objects' poses from the world's ground truth
        (held objects stay attached)."""
        if self.world is None:
            return
        self.sync_robot_state()
        for name in self.object_names:
            if name in self.scene.world_objects:
                self.scene.move_object(name, self.world.object_pose(name))

    def reset(self, layout: int | None = None) -> None:
        """Back to the initial layout (or layout ``layout``): robot home, objects placed,
        nothing held; the scene follows."""
        for c in self._controllers.values():
            c.stop()
        if layout is not None:
            self._initial = self.spec.layout(layout)
            self.layout = layout
        for name in list(self.scene.attached_objects):
            self.scene.detach_object(name)
        self.scene.state.positions[:] = self.robot.default_positions
        for name, pose in self._initial.items():
            self.scene.move_object(name, pose)
        if self.world is not None:
            self.world.reset(self._initial)

    def respawn(self, name: str) -> None:
        """Put one object back where the layout has it, at rest (world and scene)."""
        if not isinstance(name, str) or name not in self.object_names:
            raise CellError(f"unknown object {name!r}; known: {choices(self.object_names)}")
        if name in self.scene.attached_objects:
            self.scene.detach_object(name)
        self.scene.move_object(name, self._initial[name])
        if self.world is not None:
            self.world.set_object_pose(name, self._initial[name])

    def drop(self, name: str) -> Pose:
        """Kinematic mode: let a released object fall straight down onto the highest fixture
        part under its centre (or the floor), keeping its orientation; returns its new pose.
        (In physics the world does this by itself.)"""
        pose = self.object_pose(name)
        if self.world is not None:
            return pose
        x, y, z = pose.position
        o = self.spec.object(name)
        support = 0.0
        for f in self.spec.fixtures:
            for part in f.parts:
                T = (f.pose * part.pose).matrix()
                local = np.linalg.inv(T) @ np.array([x, y, z, 1.0])
                shape = part.shape
                half = np.asarray(getattr(shape, "size", (0.0, 0.0, 0.0))) / 2
                if half.any() and abs(local[0]) <= half[0] and abs(local[1]) <= half[1]:
                    top = float((T @ np.array([0, 0, half[2], 1.0]))[2])
                    if top <= z + 1e-9:
                        support = max(support, top)
        lowest = z - self._half_extent_z(o, pose)
        new = Pose(pose.position - np.array([0.0, 0.0, lowest - support]), pose.orientation)
        self.scene.move_object(name, new)
        return new

    @staticmethod
    def _half_extent_z(o: object, pose: Pose) -> float:
        from robocell.geometry.shapes import triangulate

        v, _ = triangulate(o.shape, 16)  # type: ignore[attr-defined]
        return float(-(v @ pose.rotation().T)[:, 2].min())

    # ------------------------------------------------------------------ grasps
    def _gripper_links(self) -> list[str]:
        g = self.robot_spec.gripper
        return [] if g is None else [f"robot/{n}" for n in self.robot.group(g).link_names]

    def is_grasped(self, name: str) -> bool:
        """Whether the object is squeezed by the gripper: two or more of the gripper's links
        touch it (physics), or it is attached to the robot (kinematic mode)."""
        if not isinstance(name, str) or name not in self.object_names:
            raise CellError(f"unknown object {name!r}; known: {choices(self.object_names)}")
        if self.world is None:
            return name in self.scene.attached_objects
        return len(self.world.touching(name) & set(self._gripper_links())) >= 2

    def held_offset(self, name: str, link: str | None = None) -> Pose:
        """The object's pose in the frame of ``link`` (default: the gripper's parent link, or
        the arm's tip) now: compare two of them to see a held object slip."""
        if link is None:
            ees = [
                e for e in self.robot.end_effectors.values() if e.group == self.robot_spec.gripper
            ]
            link = ees[0].parent_link if ees else self.robot.group(self.robot_spec.arm).tip_link
        self.sync_robot_state()
        return self.scene.link_pose(link).inverse() * self.object_pose(name)

    def has_slipped(self, name: str, since: Pose, tolerance: float = 0.005) -> bool:
        """Whether a held object moved more than ``tolerance`` [m] in the gripper since the
        offset ``since`` (from :meth:`held_offset`)."""
        now = self.held_offset(name)
        return bool(np.linalg.norm(now.position - since.position) > tolerance)

    # ------------------------------------------------------------------ motion
    def controller(self, group: str) -> Controller:
        """The controller of a group: physics or kinematic, by the cell's mode."""
        if not isinstance(group, str) or group not in self._controllers:
            g = self.robot.group(group)
            if self._stepper is not None:
                from robocell.execution.physics import PhysicsController

                gripper = group == self.robot_spec.gripper
                self._controllers[group] = PhysicsController(
                    self._stepper, g, math.inf if gripper else 0.01
                )
            else:
                self._controllers[group] = KinematicController(
                    g, self.scene.state.positions, time_scale=self.time_scale
                )
        return self._controllers[group]

    def move_group(self, group: str) -> MoveGroup:
        """MoveIt's commander for ``group`` of the cell's robot (one per group)."""
        self.scene.robot.group(group)  # an unknown one refused, naming the groups
        if group not in self._groups:
            mg = MoveGroup(
                self.scene,
                group,
                controller=self.controller(group),
                planner_config=self.planner_config,
            )
            mg.sync_state = self.sync_robot_state
            self._groups[group] = mg
        return self._groups[group]
