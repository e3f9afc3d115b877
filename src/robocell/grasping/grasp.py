"""Grasp and place records, as MoveIt's moveit_msgs/Grasp and PlaceLocation, and the geometry of
a two-finger gripper read from the robot description."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import GraspError
from robocell.geometry.pose import Pose
from robocell.geometry.shapes import triangulate
from robocell.kinematics.fk import link_poses
from robocell.robot.model import RobotModel


@dataclass(frozen=True)
class GripperTranslation:
    """A straight move of the gripper: ``direction`` (unit, world frame), at least
    ``min_distance`` and ideally ``desired_distance`` [m] long."""

    direction: tuple[float, float, float]
    min_distance: float
    desired_distance: float

    def __post_init__(self) -> None:
        # in Python floats: candidates make thousands (1.6 µs each; 4.6 with numpy)
        try:
            d = tuple(float(x) for x in self.direction)
        except (TypeError, ValueError):
            d = ()
        n = math.sqrt(sum(x * x for x in d)) if len(d) == 3 else math.nan
        if not math.isfinite(n) or n < 1e-9:
            raise GraspError(
                f"a gripper translation needs a non-zero direction, got {self.direction}"
            )
        if not 0 <= self.min_distance <= self.desired_distance:
            raise GraspError(
                f"need 0 <= min_distance <= desired_distance, got {self.min_distance}, "
                f"{self.desired_distance}"
            )
        object.__setattr__(self, "direction", (d[0] / n, d[1] / n, d[2] / n))

    def vector(self, distance: float | None = None) -> NDArray[np.float64]:
        return np.asarray(self.direction) * (
            self.desired_distance if distance is None else distance
        )


@dataclass(frozen=True)
class Grasp:
    """One way to grasp an object (MoveIt's Grasp). ``pose``: the end-effector link's pose in
    the world at the grasp; ``tcp``: the tool centre point there; ``width`` [m] of the object
    between the fingers; gripper commands before (open) and at the grasp (closed)."""

    id: str
    pose: Pose
    tcp: Pose
    pre_grasp_approach: GripperTranslation
    post_grasp_retreat: GripperTranslation
    pre_grasp_posture: float
    grasp_posture: float
    width: float
    quality: float
    kind: str = ""
    allowed_touch_objects: tuple[str, ...] = ()
    joint_positions: NDArray[np.float64] | None = field(default=None, compare=False)


@dataclass(frozen=True)
class PlaceLocation:
    """Where to put a held object (MoveIt's PlaceLocation): ``pose`` of the end-effector link in
    the world when the object is at its place, approach and retreat, and the gripper command to
    release it."""

    id: str
    pose: Pose
    object_pose: Pose
    pre_place_approach: GripperTranslation
    post_place_retreat: GripperTranslation
    post_place_posture: float
    quality: float = 1.0
    allowed_touch_objects: tuple[str, ...] = ()


@dataclass(frozen=True)
class Push:
    """A straight push of an object with the closed gripper (non-prehensile manipulation, to
    turn or move an object no grasp reaches): ``pose`` of the end-effector link where the push
    starts (the fingers beside the object's face, not touching it), reached by coming straight
    down ``descent`` [m]; then the straight ``push``. ``contact``: the point of the face the
    fingers meet (world); ``joint_positions``: an IK solution at ``pose``. After the push the
    gripper lifts by ``descent`` along :meth:`lift`."""

    id: str
    pose: Pose
    push: GripperTranslation
    descent: float
    contact: tuple[float, float, float]
    quality: float
    joint_positions: NDArray[np.float64] | None = field(default=None, compare=False)

    def lift(self) -> NDArray[np.float64]:
        """The move after the push (world): ``descent`` long, up and back from the pushed
        face (a push ends at the edge of the arm's reach, where straight up can leave it)."""
        return self.descent * up_and_back(self.push.direction)


def up_and_back(direction: ArrayLike) -> NDArray[np.float64]:
    """Unit vector up and back against ``direction``'s horizontal part (2 up for 1.2 back;
    straight up if it has none): how a gripper leaves what it reached at the edge of the
    arm's reach, where straight up can leave that reach."""
    up = np.array([0.0, 0.0, 1.0])
    d = np.asarray(direction, dtype=float)
    back = -np.array([d[0], d[1], 0.0])
    norm = float(np.linalg.norm(back))
    if norm < 1e-6:
        return up
    v = up + 0.6 * back / norm
    return v / float(np.linalg.norm(v))


@dataclass(frozen=True)
class GripperGeometry:
    """A parallel gripper as its description has it, in the end-effector link's frame:
    ``approach`` and ``closing`` axes (unit), the ``T_eef_tcp`` transform, the opening [m] at
    the open and closed commands, the fingers' length along the approach, how far behind the
    tcp the gripper's body starts (what must clear an object's top), how far the fingers reach
    beyond the tcp (what must clear the surface under it), and the half height of the whole
    gripper across both axes (what must clear that surface in a side grasp). ``points`` and
    ``closed_points``: vertices of its collision shapes, open and closed, relative to the tcp
    (eef axes)."""

    eef_link: str
    tcp_link: str
    group: str
    T_eef_tcp: NDArray[np.float64]
    approach: NDArray[np.float64]
    closing: NDArray[np.float64]
    open_command: float
    closed_command: float
    open_width: float
    closed_width: float
    pad_length: float
    body_clearance: float
    finger_reach: float = 0.0
    body_half_height: float = 0.0
    points: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)), compare=False)
    pad_width: float = 0.0
    closed_points: NDArray[np.float64] = field(
        default_factory=lambda: np.zeros((0, 3)), compare=False
    )

    def lowest(self, R_world_eef: NDArray[np.float64]) -> float:
        """How far [m] the open gripper reaches below its tcp when turned by ``R_world_eef``
        (from the vertices of its collision shapes; ``body_half_height`` if it has none)."""
        if len(self.points) == 0:
            return self.body_half_height
        return float(-(self.points @ R_world_eef[2]).min())

    def command_for(self, width: float) -> float:
        """The gripper command at which the fingers are ``width`` [m] apart (linear)."""
        f = (self.open_width - width) / (self.open_width - self.closed_width)
        return self.open_command + f * (self.closed_command - self.open_command)

    def width_at(self, command: float) -> float:
        """The fingers' opening [m] at gripper ``command`` (linear; the inverse of
        :meth:`command_for`)."""
        f = (command - self.open_command) / (self.closed_command - self.open_command)
        return self.open_width + f * (self.closed_width - self.open_width)

    @classmethod
    def from_robot(
        cls,
        robot: RobotModel,
        gripper_group: str,
        tcp_link: str | None = None,
        open_command: float | None = None,
        closed_command: float | None = None,
    ) -> GripperGeometry:
        """Read the geometry from the model: the end effector whose group is ``gripper_group``,
        its TCP link (default ``tcp`` if the robot has one), the fingers' collision shapes at
        the open and closed commands."""
        ees = [e for e in robot.end_effectors.values() if e.group == gripper_group]
        if not ees:
            raise GraspError(
                f"no end effector uses group {gripper_group!r}; "
                f"end effectors: {sorted(robot.end_effectors)}"
            )
        eef = ees[0].parent_link
        group = robot.group(gripper_group)
        if group.dof != 1:
            raise GraspError(f"gripper group {gripper_group!r} must have one joint (the command)")
        tcp = tcp_link or ("tcp" if "tcp" in robot.link_names else eef)
        lo = float(group.lower[0]) if open_command is None else open_command
        hi = float(group.upper[0]) if closed_command is None else closed_command
        i_eef, i_tcp = robot.link_index(eef), robot.link_index(tcp)

        def frames(command: float) -> NDArray[np.float64]:
            full = robot.default_positions.copy()
            full[group.indices[0]] = command
            T = link_poses(robot, full)
            return np.linalg.inv(T[i_eef]) @ T  # every link in the eef frame

        T_open, T_closed = frames(lo), frames(hi)
        T_eef_tcp = T_open[i_tcp]
        offset = T_eef_tcp[:3, 3]
        approach = (
            offset / np.linalg.norm(offset)
            if np.linalg.norm(offset) > 1e-6
            else np.array([0.0, 0.0, 1.0])
        )
        # the fingers: gripper links with shapes that translate when the command changes
        with_shapes = {g.link for g in robot.collision_geometry}
        moving = [
            lk for lk in group.link_names
            if lk in with_shapes
            and np.linalg.norm(
                T_open[robot.link_index(lk)][:3, 3] - T_closed[robot.link_index(lk)][:3, 3]
            ) > 1e-6
        ]  # fmt: skip
        shapes = [g for g in robot.collision_geometry if g.link in moving]
        if len(moving) < 2 or not shapes:
            raise GraspError(f"gripper {gripper_group!r}: found no two moving fingers with shapes")
        d = (
            T_closed[robot.link_index(moving[0])][:3, 3]
            - T_open[robot.link_index(moving[0])][:3, 3]
        )
        closing = d / np.linalg.norm(d)
        closing = closing - (closing @ approach) * approach
        closing /= np.linalg.norm(closing)

        def vertices(T_frames: NDArray[np.float64], links: list[str]) -> list[NDArray[np.float64]]:
            out = []
            for lk in links:
                pts = []
                for g in robot.collision_geometry:
                    if g.link == lk:
                        v, _ = triangulate(g.shape, 8)
                        T = T_frames[robot.link_index(lk)] @ g.T_link_shape
                        pts.append(v @ T[:3, :3].T + T[:3, 3])
                if pts:
                    out.append(np.vstack(pts) - offset)
            return out

        def width(T_frames: NDArray[np.float64]) -> float:
            sides = [v @ closing for v in vertices(T_frames, moving)]
            pos = [s for s in sides if np.median(s) > 0]
            neg = [s for s in sides if np.median(s) <= 0]
            if not pos or not neg:
                raise GraspError(f"gripper {gripper_group!r}: fingers are not on both sides")
            return float(min(s.min() for s in pos) - max(s.max() for s in neg))

        pads = np.vstack(vertices(T_open, moving)) @ approach
        # the body: what is welded to the end-effector link (a gripper's base), and the
        # gripper's links that do not move
        tree = robot.tree
        root = tree.rigid_root(i_eef)
        body_links = [
            lk for lk in robot.link_names
            if lk in with_shapes and lk not in moving
            and (tree.rigid_root(robot.link_index(lk)) == root or lk in group.link_names)
        ]  # fmt: skip
        body = vertices(T_open, body_links)
        # along the approach the body lies behind the tcp (negative): the nearest of it
        clearance = float(-max(float((v @ approach).max()) for v in body)) if body else 0.1
        w_lo, w_hi = max(width(T_open), 0.0), max(width(T_closed), 0.0)
        if w_lo < w_hi and open_command is None and closed_command is None:
            lo, hi, w_lo, w_hi = hi, lo, w_hi, w_lo  # the upper limit opens this gripper
        third = np.cross(approach, closing)
        fingers = np.vstack(vertices(T_open, moving))
        everything = np.vstack(body + vertices(T_open, moving)) if body else np.zeros((1, 3))
        closed = np.vstack(vertices(T_closed, body_links) + vertices(T_closed, moving))
        return cls(
            eef, tcp, gripper_group, T_eef_tcp, approach, closing, lo, hi, w_lo, w_hi,
            float(pads.max() - pads.min()), clearance, float(pads.max()),
            float(np.abs(everything @ third).max()), everything,
            float(np.ptp(fingers @ third)), closed,
        )  # fmt: skip
