"""Forward kinematics and Jacobians, single and batched.

Poses are 4×4 transforms in the robot's root frame (the URDF's root link), unless a
``relative_to`` link is given. Batched forms take (N, dof) and run compiled over all N.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import ModelError, name_or
from robocell.geometry.pose import invert_transform
from robocell.kinematics import _kernels as K
from robocell.robot.model import JointGroup, RobotModel


class _TreeArgs:
    """The tree's arrays in the order the kernels take them, and per-link joint subsets."""

    def __init__(self, robot: RobotModel) -> None:
        t = robot.tree
        self.root = robot.link_index(robot.root_link)
        self.arrays = (
            t.parent_link,
            t.child_link,
            t.origin,
            t.type,
            t.axis,
            t.var,
            t.mult,
            t.offset,
        )
        self.n_links = t.n_links
        self.all_joints = np.arange(len(t.parent_link), dtype=np.int64)
        self._subsets: dict[tuple[int, ...], NDArray[np.int64]] = {}
        self.tree = t

    def joints_to(self, *links: int) -> NDArray[np.int64]:
        if links in self._subsets:
            return self._subsets[links]
        key = tuple(sorted(set(links)))
        if key not in self._subsets:
            self._subsets[key] = self.tree.joints_to(list(key))
        self._subsets[links] = self._subsets[key]
        return self._subsets[key]


@lru_cache(maxsize=4)
def tree_args(robot: RobotModel) -> _TreeArgs:
    return _TreeArgs(robot)


def _link(group: JointGroup, link: str | None) -> tuple[RobotModel, int]:
    robot = group.robot
    if robot is None:
        raise ModelError(f"group {group.name!r} is not attached to a robot model")
    name = name_or(link, group.tip_link)
    if isinstance(name, str) and not name:
        raise ModelError(f"group {group.name!r} has no tip link; name the link to use")
    return robot, robot.link_index(name)


def _robot(group: JointGroup) -> RobotModel:
    if group.robot is None:
        raise ModelError(f"group {group.name!r} is not attached to a robot model")
    return group.robot


def link_poses(robot: RobotModel, positions: ArrayLike) -> NDArray[np.float64]:
    """(L, 4, 4) poses of every link for a full variable vector (robot.variable_names order)."""
    q = np.asarray(positions, dtype=float)
    if q.shape != (robot.n_variables,):
        raise ModelError(f"{robot.name}: expected {robot.n_variables} positions, got {q.shape}")
    args = tree_args(robot)
    T = np.empty((args.n_links, 4, 4))
    K.fk_into(q, args.all_joints, args.root, *args.arrays, T)
    return T


def link_poses_batch(robot: RobotModel, positions: ArrayLike) -> NDArray[np.float64]:
    """(N, L, 4, 4) poses of every link for (N, V) full variable vectors."""
    qs = np.ascontiguousarray(np.atleast_2d(np.asarray(positions, dtype=float)))
    args = tree_args(robot)
    return K.fk_batch(qs, args.all_joints, args.root, *args.arrays, args.n_links)


def fk(
    group: JointGroup,
    q: ArrayLike,
    link: str | None = None,
    base_positions: ArrayLike | None = None,
    relative_to: str | None = None,
) -> NDArray[np.float64]:
    """Pose (4×4) of ``link`` (default: the group's tip) for group joint values ``q``.

    Joints outside the group take ``base_positions`` (a full variable vector; default: the
    robot's default positions). In the root frame, or in ``relative_to``'s frame if given.
    """
    robot, li = _link(group, link)
    args = tree_args(robot)
    if relative_to is None:
        base = (
            robot.default_positions if base_positions is None else np.asarray(base_positions, float)
        )
        return K.fk_link(
            group.as_joint_vector(q),
            group.indices,
            base,
            args.joints_to(li),  # type: ignore[no-any-return]
            args.root,
            *args.arrays,
            args.n_links,
            li,
        )
    full = robot.full_positions(group, q, base_positions)
    ri = robot.link_index(relative_to)
    T = np.empty((args.n_links, 4, 4))
    K.fk_into(full, args.joints_to(li, ri), args.root, *args.arrays, T)
    return invert_transform(T[ri]) @ T[li]


def fk_batch(
    group: JointGroup,
    qs: ArrayLike,
    link: str | None = None,
    base_positions: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """(N, 4, 4) poses of ``link`` (default: tip) in the root frame for (N, dof) joint values."""
    robot, li = _link(group, link)
    q = group.as_joint_batch(qs)
    full = np.tile(
        robot.default_positions if base_positions is None else np.asarray(base_positions, float),
        (q.shape[0], 1),
    )
    full[:, group.indices] = q
    args = tree_args(robot)
    return K.fk_batch_link(full, args.joints_to(li), args.root, *args.arrays, args.n_links, li)


def jacobian(
    group: JointGroup,
    q: ArrayLike,
    link: str | None = None,
    base_positions: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Geometric Jacobian (6, dof) of ``link``'s origin: rows (vx, vy, vz, wx, wy, wz) in the
    root frame (pinocchio's LOCAL_WORLD_ALIGNED), columns in the group's joint order."""
    robot, li = _link(group, link)
    full = robot.full_positions(group, q, base_positions)
    args = tree_args(robot)
    joints = args.joints_to(li)
    T = np.empty((args.n_links, 4, 4))
    K.fk_into(full, joints, args.root, *args.arrays, T)
    column = np.full(robot.n_variables, -1, dtype=np.int64)
    column[group.indices] = np.arange(group.dof)
    J = np.empty((6, group.dof))
    t = robot.tree
    K.jacobian_into(
        T, joints, t.parent_link, t.origin, t.type, t.axis, t.var, t.mult, column, li, J
    )
    return J
