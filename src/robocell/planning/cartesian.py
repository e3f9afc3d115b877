"""Cartesian paths (MoveIt's ``computeCartesianPath``): the link moves along straight lines in
task space through the waypoints, with orientation interpolated by slerp.

Each step's IK is tracked from the previous step's solution (Levenberg–Marquardt seeded there,
without joint limits), so the joint path follows one continuous IK branch. The path stops at
the first step that fails, and the reason says why: no IK, a joint limit, a joint jump, or a
collision (with which pair).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from robocell.errors import PlanningError, number, vector
from robocell.geometry.pose import Pose
from robocell.kinematics import _kernels as KK
from robocell.kinematics.fk import fk, tree_args
from robocell.robot.model import JointGroup

if TYPE_CHECKING:
    from robocell.scene.checker import CollisionChecker
    from robocell.scene.planning_scene import PlanningScene


@dataclass
class CartesianPath:
    """``path`` (K, dof): the joint states of the steps reached (the start first);
    ``fraction`` of the requested Cartesian length that they cover; ``reason`` why the path
    stops early (empty when fraction is 1)."""

    path: NDArray[np.float64]
    fraction: float
    reason: str = ""
    poses: NDArray[np.float64] | None = None


def _poses_between(
    T_a: NDArray[np.float64], T_b: NDArray[np.float64], eef_step: float, rotation_step: float
) -> NDArray[np.float64]:
    """Poses (n, 4, 4) along the straight moves from each pose T_a[k] (excluded) to T_b[k]
    (included) (M, 4, 4, or one 4×4 each), one move after the other, in steps no longer than
    eef_step [m] and rotation_step [rad]: the position linear, the orientation slerped
    (T_a's rotation turned by a share of the one turn to T_b's, as scipy's Slerp). All moves
    at once, in two scipy calls: a Slerp per move cost 0.3 ms, and a LIN sequence's dense
    waypoints made hundreds of them (190–230 ms for the IRB 120's standard cycle)."""
    T_a, T_b = np.reshape(T_a, (-1, 4, 4)), np.reshape(T_b, (-1, 4, 4))
    d = T_b[:, :3, 3] - T_a[:, :3, 3]
    turn = Rotation.from_matrix(T_a[:, :3, :3].transpose(0, 2, 1) @ T_b[:, :3, :3]).as_rotvec()
    n = np.maximum(
        1,
        np.maximum(
            np.ceil(np.linalg.norm(d, axis=1) / eef_step),
            np.ceil(np.linalg.norm(turn, axis=1) / rotation_step),
        ),
    ).astype(np.int64)
    k = np.repeat(np.arange(len(n)), n)  # each step's move
    s = (np.arange(len(k)) - np.repeat(np.cumsum(n) - n, n) + 1) / n[k]
    out = np.tile(np.eye(4), (len(k), 1, 1))
    out[:, :3, 3] = T_a[k, :3, 3] + s[:, None] * d[k]
    out[:, :3, :3] = T_a[k, :3, :3] @ Rotation.from_rotvec(s[:, None] * turn[k]).as_matrix()
    return out


def waypoint_poses(waypoints: list[Pose]) -> list[Pose]:
    """Each waypoint read as a pose (:meth:`Pose.from_any`: a user's list may hold any of
    its forms), else a PlanningError naming the first that is not one."""
    poses = []
    for k, w in enumerate(waypoints):
        if not isinstance(w, Pose):
            try:
                w = Pose.from_any(w)
            except Exception as exc:
                raise PlanningError(f"waypoint {k} is not a pose: {w!r}") from exc
        poses.append(w)
    return poses


def compute_cartesian_path(
    scene: PlanningScene,
    group: str | JointGroup,
    waypoints: list[Pose],
    eef_step: float = 0.01,
    jump_threshold: float = 0.0,
    avoid_collisions: bool = True,
    link: str | None = None,
    rotation_step: float = 0.05,
    start: ArrayLike | None = None,
    max_joint_step: float = 0.2,
    continuous: float | None = None,
) -> CartesianPath:
    """Straight lines of ``link`` (default: the group's tip) through ``waypoints`` (world
    frame), from ``start`` (default: the scene's current state).

    ``eef_step`` [m] and ``rotation_step`` [rad] bound each step. ``jump_threshold`` > 0 is
    MoveIt's relative test (a step longer in joint space than that many times the mean step is
    a jump); whatever it is, no joint may move more than ``max_joint_step`` [rad] in one step.

    With ``avoid_collisions`` the steps, and the straight joint motions between them at
    0.01 rad, are checked (discrete, as MoveIt's check is). ``continuous`` [m] (a tolerance,
    as PlannerConfig's ``continuous_tolerance``) proves instead every configuration of the
    motion as it will run free (:mod:`robocell.scene.swept`): the cubic spline through the
    steps that :func:`robocell.trajectory.time_optimal` times (``smooth=True``); the path
    stops before the first step where it is not proven.
    """
    g = group if isinstance(group, JointGroup) else scene.robot.group(group)
    robot = scene.robot
    tip = link or g.tip_link
    robot.link_index(tip, "Cartesian path link")
    if not waypoints:
        raise PlanningError("compute_cartesian_path needs at least one waypoint")
    for name, v in (("eef_step", eef_step), ("rotation_step", rotation_step)):
        if not number(v, name, PlanningError) > 0:
            raise PlanningError(f"{name} must be > 0, got {v!r}")
    if number(jump_threshold, "jump_threshold", PlanningError) < 0:
        raise PlanningError(f"jump_threshold must be >= 0, got {jump_threshold!r}")
    targets = [w.matrix() for w in waypoint_poses(waypoints)]
    q0 = (
        scene.state.group_positions(g).copy()
        if start is None
        else g.as_joint_vector(start, "Cartesian path start")
    )
    full = scene.state.positions.copy()
    full[g.indices] = q0
    T_world_base = scene.T_world_root @ _link_in_root(scene, g.base_link, full)
    T_base_world = np.linalg.inv(T_world_base)
    T_start = fk(g, q0, tip, relative_to=g.base_link)

    # every step pose, in the base frame
    T_to = np.asarray(T_base_world @ np.array(targets), dtype=np.float64)
    T_from = np.concatenate([T_start[None], T_to[:-1]])
    P = np.concatenate([T_start[None], _poses_between(T_from, T_to, eef_step, rotation_step)])
    n = len(P) - 1
    # Cartesian arc length at each step, for the fraction
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P[:, :3, 3], axis=0), axis=1))])
    ang = np.concatenate(
        [
            [0.0],
            np.cumsum(
                Rotation.from_matrix(P[1:, :3, :3] @ P[:-1, :3, :3].transpose(0, 2, 1)).magnitude()
            ),
        ]
    )
    progress = arc / arc[-1] if arc[-1] > 1e-9 else ang / max(ang[-1], 1e-12)

    tracker = _Tracker(g, tip, full)
    reason = ""
    # a step whose joints move more than max_joint_step is split in SPLIT finer steps first:
    # near a wrist singularity the wrist turns fast but continuously, which finer steps follow;
    # a real jump (another IK branch) stays one
    out_q, out_P, out_prog = [q0], [P[0]], [0.0]
    reached = 0  # the last whole step reached
    for k in range(1, n + 1):
        q_prev = out_q[-1]
        q, ok = tracker.solve(P[k], q_prev)
        sub = [(P[k], float(progress[k]), q)]
        if ok and float(np.max(np.abs(q - q_prev))) > max_joint_step:
            fine = _poses_between(P[k - 1], P[k], eef_step / SPLIT, rotation_step / SPLIT)
            s = np.arange(1, len(fine) + 1) / len(fine)
            sub, q_at = [], q_prev
            for T_s, s_i in zip(fine, s, strict=True):
                q_at, ok = tracker.solve(T_s, q_at)
                if not ok:
                    break
                p_s = float(progress[k - 1] + s_i * (progress[k] - progress[k - 1]))
                sub.append((T_s, p_s, q_at))
        if not ok:
            reason = f"no IK solution for the step at {P[k][:3, 3].round(4).tolist()} (base frame)"
            break
        failed = False
        parts = len(out_q)
        for T_s, p_s, q_s in sub:
            bad = g.limit_violations(q_s)
            if bad:
                reason = f"joint limit reached: {bad[0]}"
                failed = True
                break
            step = np.abs(q_s - out_q[-1])
            if float(step.max()) > max_joint_step:
                j = int(step.argmax())
                reason = f"joint jump: {g.joint_names[j]} moves {step[j]:.3f} rad in one step"
                failed = True
                break
            out_q.append(q_s)
            out_P.append(T_s)
            out_prog.append(p_s)
        if failed:
            # a split step counts once all of its parts are in
            del out_q[parts:], out_P[parts:], out_prog[parts:]
            break
        reached = k
    qs = np.array(out_q)
    P_out = np.array(out_P)
    prog_out = np.array(out_prog)
    last = len(qs) - 1  # the last state kept
    if jump_threshold > 0 and len(qs) > 2:
        d = np.linalg.norm(np.diff(qs, axis=0), axis=1)
        limit = jump_threshold * d.mean()
        over = np.flatnonzero(d > limit)
        if len(over):
            last = int(over[0])
            reason = f"joint jump: step {last + 1} is longer than {jump_threshold} × the mean step"
    if avoid_collisions and last > 0:
        checker = scene.checker(g)
        # every step, and between steps at 0.01 rad, so that no collision hides between them
        dense, owner = _densify(qs[: last + 1], 0.01)
        hit = checker.check(dense)
        if hit.any():
            first = int(np.argmax(hit))
            last = max(0, int(owner[first]) - 1)
            pairs = checker.colliding_pairs(dense[first])
            what = ", ".join(f"{a} – {b}" for a, b in pairs) or "(unknown pair)"
            reason = f"collision at step {last + 1}: {what}"
    if avoid_collisions and continuous is not None and last > 0:
        last, why = _prove_spline(scene.checker(g), qs[: last + 1], continuous)
        reason = why or reason
    whole = reached == n and last == len(qs) - 1
    fraction = 1.0 if whole else float(prog_out[last])
    return CartesianPath(qs[: last + 1], fraction, "" if whole else reason, P_out[: last + 1])


SPLIT = 8  # how finely a step whose joints jump is split before it is called a jump


def _prove_spline(
    checker: CollisionChecker, qs: NDArray[np.float64], tolerance: float
) -> tuple[int, str]:
    """The last step of ``qs`` up to which the spline through the steps (the path as it will
    run) is proven free by the continuous check, and why it stops earlier ("" if it does
    not). A spline through fewer steps bends differently near its end, so each shorter one
    is proven anew."""
    from robocell.trajectory.path import SplinePath, distinct_waypoints

    swept = checker.swept(tolerance)
    last = len(qs) - 1
    reason = ""
    while last > 0:
        prefix = qs[: last + 1]
        kept = distinct_waypoints(prefix)  # the spline's breakpoint i is step kept[i]
        if len(kept) < 2:  # the arm does not move: its one state was checked
            return last, reason
        path = SplinePath(prefix)
        result = swept.check_path(path)
        if result.free:
            return last, reason
        i = int(np.searchsorted(path.breakpoints, result.at, side="right"))
        k = int(kept[min(max(i, 1), len(kept) - 1)])  # the first step past the unproven point
        q = path(np.array([result.at]))[0]
        if result.collides:
            pairs = checker.colliding_pairs(q)
            what = ", ".join(f"{a} – {b}" for a, b in pairs) or "(unknown pair)"
            reason = f"collision before step {k} (continuous check): {what}"
        else:
            reason = (
                f"the motion before step {k} could not be proven free within the continuous "
                "check's budget"
            )
        last = k - 1
    return 0, reason


def _densify(
    qs: NDArray[np.float64], resolution: float
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """States along the polyline qs at most ``resolution`` apart per joint, and for each the
    index of the step it ends at (all steps at once)."""
    d = np.diff(qs, axis=0)
    m = np.maximum(1, np.ceil(np.abs(d).max(axis=1, initial=0.0) / resolution)).astype(np.int64)
    k = np.repeat(np.arange(len(d)), m)  # each state's step − 1
    t = (np.arange(len(k)) - np.repeat(np.cumsum(m) - m, m) + 1) / m[k]
    dense = np.concatenate([qs[:1], qs[k] + t[:, None] * d[k]])
    return dense, np.concatenate([[0], k + 1])


def _link_in_root(
    scene: PlanningScene, link: str, full: NDArray[np.float64]
) -> NDArray[np.float64]:
    from robocell.kinematics.fk import link_poses

    return link_poses(scene.robot, full)[scene.robot.link_index(link)]


class _Tracker:
    """IK that follows one branch: LM from the previous step's solution, joint limits off
    (a limit is reported, not silently avoided by switching branch)."""

    def __init__(self, group: JointGroup, tip: str, full: NDArray[np.float64]) -> None:
        robot = group.robot
        assert robot is not None
        self.g = group
        self.args = tree_args(robot)
        self.tip = robot.link_index(tip)
        self.base = robot.link_index(group.base_link)
        self.joints = self.args.joints_to(self.tip, self.base)
        self.full = full.copy()
        T = np.empty((self.args.n_links, 4, 4))
        KK.fk_into(self.full, self.joints, self.args.root, *self.args.arrays, T)
        self.T_root_base = T[self.base].copy()
        self.lo = np.full(group.dof, -1e9)
        self.hi = np.full(group.dof, 1e9)

    def solve(
        self, T_base_tip: NDArray[np.float64], seed: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], bool]:
        q, ok, _, _ = KK.numeric_ik(
            self.T_root_base @ T_base_tip,
            self.full,
            self.g.indices,
            seed[None, :],
            self.lo,
            self.hi,
            self.tip,
            self.joints,
            self.args.root,
            *self.args.arrays,
            self.args.n_links,
            1e-6,
            1e-6,
            100,
            False,
        )
        return q, bool(ok)


def relative_pose(
    T_world_link: Pose,
    translation: ArrayLike = (0.0, 0.0, 0.0),
    rpy: ArrayLike = (0.0, 0.0, 0.0),
    frame: str = "world",
    T_world_base: Pose | None = None,
) -> Pose:
    """``T_world_link`` moved by ``translation`` [m] and rotated by ``rpy`` [rad], expressed in
    ``frame``: "world", "base" (the robot base; needs ``T_world_base``) or "tool" (the link's
    own frame: "forward 0.05 m" along its z axis is ``translation=(0, 0, 0.05)``)."""
    if not isinstance(frame, str) or frame not in ("world", "base", "tool"):
        raise PlanningError(f"unknown frame {frame!r}; known: base, tool, world")
    t = vector(translation, 3, "translation", PlanningError)
    delta = Pose.from_rpy(*t, *vector(rpy, 3, "rpy", PlanningError))
    if frame == "tool":
        return T_world_link * delta
    if frame in ("world", "base"):
        R_frame = np.eye(3)
        if frame == "base":
            if T_world_base is None:
                raise PlanningError("a move in the base frame needs the base pose")
            R_frame = T_world_base.rotation()
        T = T_world_link.matrix()
        D = delta.matrix()
        out = np.eye(4)
        # rotate about the link's own origin, with axes of the frame
        R_d = R_frame @ D[:3, :3] @ R_frame.T
        out[:3, :3] = R_d @ T[:3, :3]
        out[:3, 3] = T[:3, 3] + R_frame @ D[:3, 3]
        return Pose.from_matrix(out)
    raise PlanningError(f"unknown frame {frame!r}; known: base, tool, world")


@dataclass
class LinearSequence:
    """Joint paths of a sequence of straight moves, one per stretch between the points where
    the motion must stop (sharp corners, reversals); ``fraction`` of the whole Cartesian
    length reached and ``reason`` as for :class:`CartesianPath`."""

    pieces: list[NDArray[np.float64]]
    fraction: float
    reason: str = ""


def compute_linear_sequence(
    scene: PlanningScene,
    group: str | JointGroup,
    waypoints: list[Pose],
    blend_radius: float = 0.0,
    eef_step: float = 0.005,
    avoid_collisions: bool = True,
    link: str | None = None,
    start: ArrayLike | None = None,
    continuous: float | None = None,
) -> LinearSequence:
    """Straight moves of ``link`` through ``waypoints`` (world frame), as a Pilz LIN sequence:
    each corner is rounded by an arc that starts ``blend_radius`` [m] before it (at most half
    of each neighbouring move), so the motion flows through; ``blend_radius=0`` stops at every
    corner. A reversal always stops. Orientation is interpolated along each move.
    ``continuous``: as :func:`compute_cartesian_path`'s, for each stretch between stops."""
    g = group if isinstance(group, JointGroup) else scene.robot.group(group)
    tip = link or g.tip_link
    if number(blend_radius, "blend_radius [m]", PlanningError) < 0:
        raise PlanningError(f"blend_radius must be >= 0 [m], got {blend_radius!r}")
    if not number(eef_step, "eef_step [m]", PlanningError) > 0:
        raise PlanningError(f"eef_step must be > 0 [m], got {eef_step!r}")
    if not waypoints:
        raise PlanningError("a linear sequence needs at least one waypoint")
    q = (
        scene.state.group_positions(g).copy()
        if start is None
        else g.as_joint_vector(start, "sequence start")
    )
    full = scene.state.positions.copy()
    full[g.indices] = q
    T0 = scene.T_world_root @ _link_in_root(scene, tip, full)
    poses = [T0] + [w.matrix() for w in waypoint_poses(waypoints)]
    P = np.array([T[:3, 3] for T in poses])
    # where the motion must stop: every corner without blending, and reversals
    stops = [0]
    for i in range(1, len(P) - 1):
        u1, u2 = P[i] - P[i - 1], P[i + 1] - P[i]
        n1, n2 = np.linalg.norm(u1), np.linalg.norm(u2)
        reversal = n1 > 1e-9 and n2 > 1e-9 and float(u1 @ u2) / (n1 * n2) < -1.0 + 1e-6
        if blend_radius == 0 or reversal:
            stops.append(i)
    stops.append(len(P) - 1)
    total = float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum())
    pieces: list[NDArray[np.float64]] = []
    done = 0.0
    for a, b in zip(stops[:-1], stops[1:], strict=True):
        dense = _rounded_poses(poses[a : b + 1], blend_radius, eef_step)
        cp = compute_cartesian_path(
            scene, g, dense, eef_step, 0.0, avoid_collisions, tip, 0.05, q, continuous=continuous
        )
        piece_len = float(np.linalg.norm(np.diff(P[a : b + 1], axis=0), axis=1).sum())
        if cp.fraction < 1.0:
            if len(cp.path) > 1:
                pieces.append(cp.path)
            reached = done + cp.fraction * piece_len
            return LinearSequence(pieces, reached / total if total > 0 else 0.0, cp.reason)
        pieces.append(cp.path)
        q = cp.path[-1]
        done += piece_len
    return LinearSequence(pieces, 1.0, "")


def _rounded_poses(
    poses: list[NDArray[np.float64]], blend_radius: float, step: float
) -> list[Pose]:
    """Dense poses (the first excluded) along the corners' polyline with each interior corner
    rounded; orientation slerped along each move by the distance covered."""
    from robocell.trajectory.path import BlendedPath

    P = np.array([T[:3, 3] for T in poses])
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    if seg.sum() < 1e-12:  # a pure rotation
        return [Pose.from_matrix(poses[-1])]
    bp = BlendedPath(P, blend_length=blend_radius if blend_radius > 0 else 0.0)
    n = max(1, int(math.ceil(bp.length / step)))
    s = np.linspace(0.0, bp.length, n + 1)[1:]
    pts = bp(s)
    # orientation by the fraction of the straight polyline covered (arc ≈ polyline)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    frac = s / bp.length * cum[-1]
    R = np.array([T[:3, :3] for T in poses])
    turn = Rotation.from_matrix(R[:-1].transpose(0, 2, 1) @ R[1:]).as_rotvec()  # (moves, 3)
    k = np.minimum(np.searchsorted(cum, frac, side="right") - 1, len(seg) - 1)
    long = seg[k] > 1e-12
    t = np.where(long, (frac - cum[k]) / np.where(long, seg[k], 1.0), 1.0).clip(0.0, 1.0)
    T = np.tile(np.eye(4), (len(s), 1, 1))
    T[:, :3, :3] = R[k] @ Rotation.from_rotvec(t[:, None] * turn[k]).as_matrix()
    T[:, :3, 3] = pts
    return [Pose.from_matrix(x) for x in T]
