"""The seed exercise's API (``HAL`` in the web template, ``self.pick_place`` in the script
template), on a robocell cell: the world plays the robot, the planning scene plans.

Every pose it takes or returns is in the robot base frame; angles are degrees where the seed
has them (``generate_grasp``, ``place``, the ``_deg`` helpers) and radians elsewhere.

    pp = PickPlace()                                    # the sorting cell, physics
    pose = pp.get_object_pose("blue_ball")
    grasp = pp.generate_grasp("blue_ball", "vertical", pose.position, 0.3, length=0.15)
    pp.pickup("blue_ball", [grasp])
    pp.place("vertical", pp.get_target_position("blue_target"))

Motion commands return whether they worked (a pick or place returns its result, true when it
worked) and print why not, as the seed's console does; a name, value or mode that is not valid
raises a :class:`~robocell.errors.RobocellError` that lists the valid ones, before anything moves.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robocell.cell.cell import Cell
from robocell.errors import GraspError, PlanningError, RobocellError, choices, number
from robocell.exercise.msgs import Point, PoseMsg
from robocell.geometry.pose import Pose, rpy_to_matrix
from robocell.grasping.grasp import Grasp, GripperTranslation, PlaceLocation
from robocell.manipulation.pick_place import ManipulationResult, Manipulator

ORIENTATIONS = ("horizontal", "vertical", "user_defined")
WORKSPACE_WARNING = "***** GOAL POSE IS OUT OF ROBOT WORKSPACE *****"
# the seed's quick reachability check for the IRB 120 (../shared/specs/sorting_cell.md)
WORKSPACE_CENTRE = (0.0, 0.0, 0.27)
WORKSPACE_RADII = (0.169, 0.580)
WORKSPACE_MIN_Z = -0.112
SQUEEZE = 0.01  # width=0: close this much [m] below the object's size, to press it


def in_workspace(position: Sequence[float] | NDArray[np.float64]) -> bool:
    """The seed's workspace check of a tool0 position (robot frame): inside the shell around
    the shoulder and above the lowest point. True does not promise a reachable pose."""
    p = np.asarray(position, dtype=float)
    r = float(np.linalg.norm(p - np.asarray(WORKSPACE_CENTRE)))
    return bool(WORKSPACE_RADII[0] < r < WORKSPACE_RADII[1] and p[2] > WORKSPACE_MIN_Z)


class PickPlace:
    """The exercise API on a cell (default: the bundled sorting cell in physics).

    ``printer`` receives the console lines (warnings, why a command failed)."""

    def __init__(
        self,
        cell: Cell | str = "sorting",
        layout: int = 0,
        mode: str = "physics",
        printer: Callable[[str], None] = print,
    ) -> None:
        self.cell = cell if isinstance(cell, Cell) else Cell.load(cell, layout, mode, time_scale=0)
        self.hand = Manipulator(self.cell)
        self.arm = self.hand.arm
        self.arm.set_end_effector_link(self.hand.geometry.eef_link)
        self.printer = printer
        self._T_world_robot = self.cell.robot_spec.pose
        self._T_robot_world = self._T_world_robot.inverse()
        self._direction: tuple[float, float, float] = (0.0, 0.0, -0.5)
        self._min_distance, self._desired_distance = 0.1, 0.2
        self._held: str | None = None
        self._held_command = 0.0
        self._grasps = 0

    # ------------------------------------------------------------------ frames
    def _to_world(self, pose: Pose) -> Pose:
        return self._T_world_robot * pose

    def _to_robot(self, pose: Pose) -> Pose:
        return self._T_robot_world * pose

    def _direction_world(self, d: Sequence[float]) -> NDArray[np.float64]:
        return self._T_world_robot.rotation() @ np.asarray(d, dtype=float)

    def _warn_workspace(self, position: NDArray[np.float64]) -> bool:
        if in_workspace(position):
            return True
        self.printer(WORKSPACE_WARNING)
        return False

    # ------------------------------------------------------------------ environment
    def get_object_list(self) -> list[str]:
        """The names of all objects."""
        return list(self.cell.object_names)

    def get_object_pose(self, object_name: str) -> PoseMsg:
        """The object's pose now (the world's ground truth), robot frame."""
        return PoseMsg.from_pose(self._to_robot(self.cell.object_pose(object_name)))

    def get_object_info(self, object_name: str) -> tuple[PoseMsg, float, float, float, str, str]:
        """(pose, height, width, length, shape, color): height is the z size, width the y
        size, length the x size; a cylinder's or a sphere's width and length are 2 r."""
        pose = self.get_object_pose(object_name)
        o = self.cell.spec.object(object_name)
        length, width, height = o.size
        return pose, height, width, length, o.kind, o.color_name

    def get_target_list(self) -> list[str]:
        """The names of the place targets."""
        return list(self.cell.target_names)

    def get_target_position(self, target_name: str) -> Point:
        """A copy of the target's position, robot frame (changing it changes nothing else)."""
        return Point(*map(float, self.cell.target_position(target_name, frame="robot")))

    # ------------------------------------------------------------------ pose messages
    @staticmethod
    def pose2msg(roll: float, pitch: float, yaw: float, x: float, y: float, z: float) -> PoseMsg:
        """A Pose message from a position [m] and roll, pitch, yaw [rad] (static x-y-z)."""
        return PoseMsg.from_pose(Pose.from_rpy(x, y, z, roll, pitch, yaw))

    @staticmethod
    def pose2msg_deg(
        roll: float, pitch: float, yaw: float, x: float, y: float, z: float
    ) -> PoseMsg:
        """As :meth:`pose2msg` with the angles in degrees."""
        return PoseMsg.from_pose(Pose.from_rpy_deg(x, y, z, roll, pitch, yaw))

    @staticmethod
    def msg2pose(pose: PoseMsg) -> tuple[float, float, float, float, float, float]:
        """(roll, pitch, yaw, x, y, z) of a Pose message, angles in [rad]."""
        p = PoseMsg.of(pose).to_pose()
        r, pi, y = (float(v) for v in p.rpy())
        return r, pi, y, float(p.position[0]), float(p.position[1]), float(p.position[2])

    @staticmethod
    def msg2pose_deg(pose: PoseMsg) -> tuple[float, float, float, float, float, float]:
        """As :meth:`msg2pose` with the angles in degrees."""
        r, p, y, *xyz = PickPlace.msg2pose(pose)
        return (math.degrees(r), math.degrees(p), math.degrees(y), *xyz)  # type: ignore[return-value]

    # ------------------------------------------------------------------ motion
    def _report(self, what: str, ok: bool, reason: str = "") -> bool:
        if not ok:
            self.printer(f"{what} failed: {reason or 'no reason given'}")
        return ok

    def move_pose_arm(self, pose_goal: PoseMsg | Pose) -> bool:
        """Plan and move tool0 to ``pose_goal`` (robot frame)."""
        target = PoseMsg.of(pose_goal).to_pose()
        if not self._warn_workspace(target.position):
            return self._report("move_pose_arm", False, "the goal is out of the workspace")
        self.arm.set_pose_target(self._to_world(target))
        return self._go("move_pose_arm")

    def move_joint_arm(
        self,
        joint_0: float,
        joint_1: float,
        joint_2: float,
        joint_3: float,
        joint_4: float,
        joint_5: float,
    ) -> bool:
        """Plan and move the arm to joint values [rad] (joint_1 … joint_6 of the robot)."""
        q = np.array(
            [
                number(v, f"move_joint_arm: joint_{i}", PlanningError)
                for i, v in enumerate((joint_0, joint_1, joint_2, joint_3, joint_4, joint_5))
            ]
        )
        g = self.arm.group
        for i, v in enumerate(q):
            if not np.isfinite(v) or not g.lower[i] - 1e-9 <= v <= g.upper[i] + 1e-9:
                raise PlanningError(
                    f"move_joint_arm: joint_{i} ({g.joint_names[i]}) = {v!r} is outside its "
                    f"limits [{g.lower[i]:.4f}, {g.upper[i]:.4f}] rad"
                )
        self.arm.set_joint_value_target(q)
        return self._go("move_joint_arm")

    def _go(self, what: str) -> bool:
        try:
            plan = self.arm.plan()
        except RobocellError as exc:
            return self._report(what, False, str(exc))
        if not plan.success:
            return self._report(what, False, plan.reason or "no plan found")
        ok = self.arm.execute(plan)
        self.cell.sync_scene()
        return self._report(what, ok, "the motion did not complete")

    def move_joint_hand(self, joint_value: float) -> bool:
        """Move the gripper to ``joint_value`` in [0, 0.8] (0 open, 0.8 closed). Opening it
        on a held object lets the object go."""
        v = _gripper_value(joint_value, "move_joint_hand: joint_value")
        try:
            self.hand.set_gripper(v)
        except RobocellError as exc:
            return self._report("move_joint_hand", False, str(exc))
        if self._held is not None and self._lets_go(v):
            self._let_go(self._held)
        if self._held is None:
            self.cell.sync_scene()
        return True

    def _lets_go(self, command: float) -> bool:
        """Whether the gripper at ``command`` no longer holds the held object: the fingers
        lost it (physics), or opened past the grasp's command (kinematic mode)."""
        assert self._held is not None
        if self.cell.world is not None:
            return not self.cell.is_grasped(self._held)
        geo = self.hand.geometry
        return (command - self._held_command) * (geo.closed_command - geo.open_command) < 0

    def _let_go(self, name: str) -> None:
        scene = self.cell.scene
        if name in scene.attached_objects:
            scene.detach_object(name)
        if self.cell.world is None:
            self.cell.drop(name)
        self.cell.sync_scene()
        self._held = None

    def back_to_home(self) -> bool:
        """Open the gripper and move the arm to its home pose. Opening lets go of anything
        held."""
        ok = self.move_joint_hand(self.hand.geometry.open_command)
        home = self.cell.robot_spec.home or "home"
        self.arm.set_named_target(home)
        return self._go("back_to_home") and ok

    def stop(self) -> None:
        """Stop the arm and gripper now (from another thread: the stop button)."""
        self.hand.stop()

    # ------------------------------------------------------------------ grasps
    def set_grasp_distance(self, min_distance: float, desired_distance: float) -> None:
        """How far [m] the gripper moves straight before a grasp (approach) and after it
        (retreat): at least ``min_distance``, ideally ``desired_distance``."""
        lo = number(min_distance, "set_grasp_distance: min_distance", GraspError)
        hi = number(desired_distance, "set_grasp_distance: desired_distance", GraspError)
        if not 0 <= lo <= hi:
            raise GraspError(
                f"set_grasp_distance needs 0 <= min_distance <= desired_distance, got "
                f"{min_distance!r}, {desired_distance!r}"
            )
        self._min_distance, self._desired_distance = lo, hi

    def set_grasp_direction(self, x: float, y: float, z: float) -> None:
        """The direction of the approach before a grasp (robot frame; any length); the
        retreat goes the opposite way."""
        d = np.array(
            [
                number(v, f"set_grasp_direction: {a}", GraspError)
                for a, v in zip("xyz", (x, y, z), strict=True)
            ]
        )
        if np.linalg.norm(d) < 1e-9:
            raise GraspError(f"set_grasp_direction needs a non-zero direction, got {(x, y, z)}")
        self._direction = (float(d[0]), float(d[1]), float(d[2]))

    def generate_grasp(
        self,
        object_name: str,
        eef_orientation: str,
        position: Point | Sequence[float],
        width: float = 0,
        roll: float = 0,
        pitch: float = 0,
        yaw: float = 0,
        length: float = 0,
    ) -> Grasp:
        """A grasp of ``object_name`` with tool0 turned by ``eef_orientation`` (degrees):
        horizontal (0, pitch, 0), vertical (0, 90, yaw) pointing down, user_defined (roll,
        pitch, yaw). tool0 goes to ``position − length · x_tool`` (robot frame): with a length
        of 0.15 (the tool centre point's offset), ``position`` is where the fingertips close.
        ``width`` is the gripper value to close to, in [0, 0.8]; 0 chooses it from the
        object's size across the fingers."""
        self._known_object(object_name)
        R = _orientation(eef_orientation, roll, pitch, yaw, "generate_grasp", (0.0, 0.0, 0.0))
        w = _gripper_value(width, "generate_grasp: width")
        p = np.asarray(Point.of(position, "generate_grasp: position"), dtype=float)
        tool0 = p - number(length, "generate_grasp: length", GraspError) * R[:, 0]
        self._warn_workspace(tool0)
        T_r = np.eye(4)
        T_r[:3, :3], T_r[:3, 3] = R, tool0
        pose = self._to_world(Pose.from_matrix(T_r))
        geo = self.hand.geometry
        tcp = Pose.from_matrix(pose.matrix() @ geo.T_eef_tcp)
        if w == 0:
            w = self._command_from_size(object_name, pose)
        d = self._direction_world(self._direction)
        self._grasps += 1
        return Grasp(
            f"{object_name}/{eef_orientation}/{self._grasps}",
            pose,
            tcp,
            GripperTranslation(tuple(d), self._min_distance, self._desired_distance),  # type: ignore[arg-type]
            GripperTranslation(tuple(-d), self._min_distance, self._desired_distance),  # type: ignore[arg-type]
            geo.open_command,
            w,
            geo.width_at(w),
            1.0,
            eef_orientation,
            (object_name,),
        )  # fmt: skip

    def _known_object(self, name: str) -> None:
        if not isinstance(name, str) or name not in self.cell.object_names:
            raise GraspError(f"unknown object {name!r}; known: {choices(self.cell.object_names)}")

    def _command_from_size(self, name: str, pose: Pose) -> float:
        """The gripper value that closes SQUEEZE below the object's size across the fingers."""
        from robocell.grasping.generators import _extent

        geo = self.hand.geometry
        closing_w = pose.rotation() @ geo.closing
        R_o = self.cell.object_pose(name).rotation()
        size = _extent(self.cell.spec.object(name).shape, R_o.T @ closing_w)
        cmd = geo.command_for(max(size - SQUEEZE, geo.closed_width))
        lo, hi = sorted((geo.open_command, geo.closed_command))
        return float(np.clip(cmd, lo, hi))

    # ------------------------------------------------------------------ pick and place
    def pickup(self, object_name: str, grasps: Sequence[Grasp]) -> ManipulationResult:
        """Pick ``object_name`` with the first of ``grasps`` (in the given order) that works:
        open, approach, close, attach, retreat. The object stays attached until placed."""
        self._known_object(object_name)
        if isinstance(grasps, Grasp):
            grasps = [grasps]
        if (
            not isinstance(grasps, list | tuple)
            or not grasps
            or not all(isinstance(g, Grasp) for g in grasps)
        ):
            raise GraspError(f"pickup needs a list of grasps from generate_grasp, got {grasps!r}")
        if self._held is not None:
            raise GraspError(f"already holding {self._held!r}: place it before picking another")
        ordered = [
            dataclasses.replace(g, quality=1.0 - i / len(grasps)) for i, g in enumerate(grasps)
        ]
        for g in ordered:
            self._warn_workspace(self._to_robot(g.pose).position)
        result = self.hand.pick(object_name, ordered)
        if result.success:
            self._held = object_name
            self._held_command = next(g.grasp_posture for g in ordered if g.id == result.candidate)
        self._report(f"pickup of {object_name}", result.success, result.reason)
        return result

    def place(
        self,
        eef_orientation: str,
        position: Point | Sequence[float],
        distance: float = 0.1,
        roll: float = 0,
        pitch: float = 0,
        yaw: float = 180,
    ) -> ManipulationResult:
        """Place the held object with tool0 at ``position`` (robot frame), turned by
        ``eef_orientation`` (degrees): horizontal (0, pitch, 180), vertical (0, 90, yaw),
        user_defined (roll, pitch, yaw). Moves to ``distance`` [m] above, goes straight down,
        opens, lets go, goes straight up."""
        R = _orientation(eef_orientation, roll, pitch, yaw, "place", (0.0, 0.0, 180.0))
        p = np.asarray(Point.of(position, "place: position"), dtype=float)
        dist = number(distance, "place: distance [m]", GraspError)
        if not dist > 0:
            raise GraspError(f"place: distance must be > 0 [m], got {distance!r}")
        if self._held is None:
            raise GraspError("place: nothing is held; pickup an object first")
        name = self._held
        if not self._warn_workspace(p):
            result = ManipulationResult(False, reason="the goal is out of the workspace")
            self._report(f"place of {name}", False, result.reason)
            return result
        T_r = np.eye(4)
        T_r[:3, :3], T_r[:3, 3] = R, p
        pose = self._to_world(Pose.from_matrix(T_r))
        held = self.cell.held_offset(name, self.hand.geometry.eef_link)
        location = PlaceLocation(
            f"{name}/place/{eef_orientation}",
            pose,
            pose * held,
            GripperTranslation((0.0, 0.0, -1.0), 0.5 * dist, dist),
            GripperTranslation((0.0, 0.0, 1.0), 0.5 * dist, dist),
            self.hand.geometry.open_command,
            1.0,
            (name,),
        )
        result = self.hand.place(name, [location], settle_tolerance=0.1)
        if name not in self.cell.scene.attached_objects:
            self._held = None
        self._report(f"place of {name}", result.success, result.reason)
        return result


def _gripper_value(v: Any, what: str) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        f = math.nan
    if not (math.isfinite(f) and 0.0 <= f <= 0.8):
        raise GraspError(f"{what} must be a gripper value in [0, 0.8] (0 open), got {v!r}")
    return f


def _orientation(
    mode: str,
    roll: float,
    pitch: float,
    yaw: float,
    what: str,
    default: tuple[float, float, float],
) -> NDArray[np.float64]:
    """R of tool0 (robot frame) for a mode and angles in degrees, as the seed defines them."""
    if not isinstance(mode, str) or mode not in ORIENTATIONS:
        raise GraspError(
            f"{what}: unknown eef_orientation {mode!r}; known: {', '.join(ORIENTATIONS)}"
        )
    if mode == "horizontal":
        rpy = (default[0], pitch, default[2])
    elif mode == "vertical":
        rpy = (0.0, 90.0, yaw)
    else:  # user_defined
        rpy = (roll, pitch, yaw)
    a = np.radians(
        [
            number(v, f"{what}: {n}", GraspError)
            for n, v in zip(("roll", "pitch", "yaw"), rpy, strict=True)
        ]
    )
    return rpy_to_matrix(*a)
