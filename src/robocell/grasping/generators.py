"""Grasp and place candidates for boxes, cylinders and spheres, for a parallel gripper.

Candidates are built in the object's frame and ranked by a quality score in [0, 1]:
- from above (approach along −z of the world), at yaw angles around the object's axis;
- from the side (approach horizontal, or tilted down by a few angles), at angles around it.

A candidate is kept only when the object fits between the open fingers with a margin, the
fingers clear the surface the object stands on, the gripper's body clears the object's top, and
(when a scene is given) the arm reaches it with a collision-free IK solution (the object may
touch the fingers).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from robocell.errors import GraspError, vector
from robocell.geometry.pose import Pose
from robocell.geometry.shapes import Box, Cylinder, Shape, Sphere
from robocell.grasping.grasp import (
    Grasp,
    GripperGeometry,
    GripperTranslation,
    PlaceLocation,
    Push,
    up_and_back,
)
from robocell.kinematics.ik import AnalyticIK, ik_solver, solve_ik
from robocell.robot.model import JointGroup
from robocell.scene.checker import CollisionChecker
from robocell.scene.planning_scene import PlanningScene

_R = TypeVar("_R")

BOX_FACE_MIN = math.cos(math.radians(2 * 10))  # side pinches of a box: within 10° of its faces


def _check_object(object_id: object, shape: object, T_world_object: object) -> None:
    """A GraspError unless the object is named by a string, with a Shape and a Pose."""
    if not isinstance(object_id, str):
        raise GraspError(f"an object id must be a string, got {object_id!r}")
    if not isinstance(shape, Shape):
        raise GraspError(f"object {object_id!r}: its shape must be a Shape, got {shape!r}")
    if not isinstance(T_world_object, Pose):
        raise GraspError(f"object {object_id!r}: its pose must be a Pose, got {T_world_object!r}")


def _frame(
    approach: NDArray[np.float64], closing: NDArray[np.float64], g: GripperGeometry
) -> NDArray[np.float64]:
    """R_world_eef that points the gripper's approach axis along ``approach`` and its closing
    axis along ``closing`` (both world, orthonormal)."""
    A = np.array([approach, closing, _cross(approach, closing)])  # rows: the world's axes
    B = np.array([g.approach, g.closing, _cross(g.approach, g.closing)])  # rows: the eef's
    return A.T @ B


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """a × b of two 3-vectors, as np.cross computes it (1 µs; np.cross took 16, a third of
    generating grasps)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def _extent(shape: Shape, axis_obj: NDArray[np.float64]) -> float:
    """Width of a solid along a unit axis given in its frame [m]."""
    if isinstance(shape, Box):
        return float(np.abs(axis_obj) @ np.asarray(shape.size))
    if isinstance(shape, Cylinder):
        radial = math.hypot(axis_obj[0], axis_obj[1])
        return 2 * shape.radius * radial + shape.length * abs(axis_obj[2])
    if isinstance(shape, Sphere):
        return 2 * shape.radius
    raise GraspError(f"grasps are generated for boxes, cylinders and spheres, not {shape.kind}")


def _upright(shape: Shape, T: NDArray[np.float64]) -> tuple[Shape, NDArray[np.float64]]:
    """A box lying on any of its faces as an upright box: its axes relabelled (cyclically,
    keeping the frame right-handed, two flipped if need be) so that its z is the axis nearest
    the world's up, and its size to match (a box that a push tipped over is a box resting on
    another face). Other shapes, and upright boxes, unchanged."""
    if not isinstance(shape, Box):
        return shape, T
    return _upright_box(shape, T)


def _upright_box(shape: Box, T: NDArray[np.float64]) -> tuple[Box, NDArray[np.float64]]:
    """:func:`_upright` for a box."""
    R = T[:3, :3]
    k = int(np.argmax(np.abs(R[2])))
    if k == 2 and R[2, 2] > 0:
        return shape, T
    i, j = (k + 1) % 3, (k + 2) % 3
    flip = 1.0 if R[2, k] > 0 else -1.0
    out = T.copy()
    out[:3, :3] = np.column_stack([R[:, i], flip * R[:, j], flip * R[:, k]])
    return Box((shape.size[i], shape.size[j], shape.size[k])), out


def _retreat_direction(kind: str, approach: NDArray[np.float64]) -> NDArray[np.float64]:
    """Straight up from a grasp from above; up and back along the approach from a side grasp,
    which is made at the edge of the arm's reach, where straight up can leave it (measured:
    2 of 200 sorting layouts)."""
    return np.array([0.0, 0.0, 1.0]) if kind == "top" else up_and_back(approach)


def _half_height(shape: Shape) -> float:
    if isinstance(shape, Box):
        return 0.5 * shape.size[2]
    if isinstance(shape, Cylinder):
        return 0.5 * shape.length
    if isinstance(shape, Sphere):
        return shape.radius
    raise GraspError(f"grasps are generated for boxes, cylinders and spheres, not {shape.kind}")


def generate_grasps(
    object_id: str,
    shape: Shape,
    T_world_object: Pose,
    gripper: GripperGeometry,
    scene: PlanningScene | None = None,
    arm: str | None = None,
    yaw_step_deg: float = 15.0,
    tilts_deg: tuple[float, ...] = (0.0, 20.0, 40.0, 50.0, 60.0, 70.0),
    clearance: float = 0.004,
    approach_distance: tuple[float, float] = (0.05, 0.1),
    retreat_distance: tuple[float, float] = (0.05, 0.1),
    max_grasps: int = 0,
) -> list[Grasp]:
    """Ranked grasp candidates for an upright object (its z along the world's) resting on a
    surface. With ``scene`` and ``arm``, only those the arm reaches collision-free, at the
    grasp and at the start of the approach's minimum distance, are kept, each with its IK
    solution."""
    _check_object(object_id, shape, T_world_object)
    if yaw_step_deg <= 0:
        raise GraspError(f"yaw_step_deg must be > 0, got {yaw_step_deg}")
    shape, T = _upright(shape, T_world_object.matrix())
    R_o, c_o = T[:3, :3], T[:3, 3]
    hz = _half_height(shape)
    bottom = c_o[2] - hz
    top = c_o[2] + hz
    max_w = gripper.open_width - 2 * clearance
    out: list[Grasp] = []
    z_w = np.array([0.0, 0.0, 1.0])

    def add(kind: str, approach: NDArray[np.float64], closing: NDArray[np.float64],
            tcp: NDArray[np.float64], quality: float) -> None:  # fmt: skip
        width = _extent(shape, R_o.T @ closing)
        if width > max_w:
            return
        R = _frame(approach, closing, gripper)
        if kind == "top" and tcp[2] + gripper.body_clearance < top + 0.005:
            return
        T_w_tcp = np.eye(4)
        T_w_tcp[:3, :3], T_w_tcp[:3, 3] = R, tcp
        T_w_eef = T_w_tcp @ np.linalg.inv(gripper.T_eef_tcp)
        # where along the pads the object's centre sits: mid-pad holds best, the fingertips
        # worst (a ball pinched at the tips flew out on a full-speed transfer, measured)
        depth = float((c_o - tcp) @ approach)  # ahead of the tcp, along the approach
        mid = 0.5 * (gripper.finger_reach - pad_back)
        along = max(0.0, 1.0 - abs(depth - mid) / max(0.5 * gripper.pad_length, 1e-6))
        q = quality * (1.0 - 0.3 * width / gripper.open_width) * (0.6 + 0.4 * along)
        out.append(
            Grasp(
                f"{object_id}/{kind}/{len(out)}",
                Pose.from_matrix(T_w_eef),
                Pose.from_matrix(T_w_tcp),
                GripperTranslation(tuple(approach), *approach_distance),  # type: ignore[arg-type]
                GripperTranslation(tuple(_retreat_direction(kind, approach)), *retreat_distance),  # type: ignore[arg-type]
                gripper.open_command,
                gripper.closed_command,
                width,
                float(q),
                kind,
                (object_id,),
            )
        )

    yaws = np.radians(np.arange(0.0, 180.0, yaw_step_deg))
    x_o, y_o = R_o[:, 0], R_o[:, 1]
    # from above: tcp at the centre, raised so that the body clears the top and the fingers
    # the support, as long as the pads still reach the centre's height
    z_tcp = max(c_o[2], top + 0.005 - gripper.body_clearance, bottom + gripper.finger_reach + 0.002)
    pad_back = gripper.pad_length - gripper.finger_reach  # pads behind the tcp
    top_ok = z_tcp - gripper.finger_reach <= c_o[2] <= z_tcp + pad_back
    for yaw in yaws:
        closing = math.cos(yaw) * x_o + math.sin(yaw) * y_o
        closing = closing - (closing @ z_w) * z_w
        closing /= np.linalg.norm(closing)
        face = abs(math.cos(2 * yaw)) if isinstance(shape, Box) else 1.0  # across faces
        if top_ok and face >= (BOX_FACE_MIN if isinstance(shape, Box) else 0.0):
            add("top", -z_w, closing, np.array([c_o[0], c_o[1], z_tcp]), 0.7 + 0.3 * face)
    # from the side: horizontal closing, approach tilted down by each tilt; around a box from
    # its faces' directions (its yaw), so that the pads can lie flat on two faces
    yaw_o = math.atan2(x_o[1], x_o[0]) if isinstance(shape, Box) else 0.0
    for phi in yaw_o + np.radians(np.arange(0.0, 360.0, yaw_step_deg)):
        horiz = np.array([math.cos(phi), math.sin(phi), 0.0])
        closing = _cross(z_w, horiz)
        face = 1.0
        if isinstance(shape, Box):
            face = abs(math.cos(2 * math.atan2(closing @ y_o, closing @ x_o)))
            if face < BOX_FACE_MIN:
                continue  # pads on two edges: the squeeze spins the box out (measured)
        for tilt in np.radians(tilts_deg):
            approach = math.cos(tilt) * horiz - math.sin(tilt) * z_w
            # tcp at the centre, raised until the gripper clears the support (as long as it
            # stays below the top, where the fingers would grip nothing)
            below = gripper.lowest(_frame(approach, closing, gripper))
            lift = max(0.0, bottom + below + 0.003 - c_o[2])
            tcp = c_o + np.array([0.0, 0.0, lift])
            if tcp[2] > top - 0.005:
                continue
            if (
                isinstance(shape, Sphere)
                and lift * math.cos(tilt) > 0.5 * gripper.pad_width - 0.003
            ):
                continue  # a sphere is pinched at its equator: it must lie across the pads
            # back off along the approach until the gripper's body clears the object's near part
            half = 0.5 * _extent(shape, R_o.T @ approach)
            tcp = tcp - approach * max(0.0, half - (gripper.body_clearance - 0.005))
            add("side", approach, closing, tcp, (0.55 + 0.15 * face) * (1 - 0.2 * tilt))
    out.sort(key=lambda g: -g.quality)
    if scene is not None:
        if arm is None:
            raise GraspError("checking grasps for reachability needs the arm group's name")
        out = _reachable(out, scene, arm, gripper, object_id)
    return out[:max_grasps] if max_grasps > 0 else out


def _reachable(
    grasps: list[Grasp], scene: PlanningScene, arm: str, gripper: GripperGeometry, object_id: str
) -> list[Grasp]:
    """The grasps whose pose, and pre-grasp pose at the approach's minimum distance, the arm
    reaches without collision (the object may touch the gripper's links), each with its IK
    solution nearest the current state. Every IK solution of every grasp is collision-checked
    in one batch; the pre-grasps of those that pass in another."""
    group = scene.robot.group(arm)
    links = scene.robot.group(gripper.group).link_names
    work = scene.copy()
    if object_id in work.world_objects:
        work.allow_collision(object_id, links)
        work.set_object_padding(object_id, 0.0)  # the gripper goes right up to it
    T_base_world = np.linalg.inv(work.link_pose(group.base_link).matrix())
    seed = work.state.group_positions(group)
    targets = [T_base_world @ g.pose.matrix() for g in grasps]
    found = _free_ik(work, group, gripper.eef_link, targets, seed)
    ok = [(g, q) for g, q in zip(grasps, found, strict=True) if q is not None]
    pre = []
    for g, _ in ok:
        T = g.pose.matrix().copy()
        T[:3, 3] -= g.pre_grasp_approach.vector(g.pre_grasp_approach.min_distance)
        pre.append(T_base_world @ T)
    found_pre = _free_ik(work, group, gripper.eef_link, pre, seed)
    R_bw = np.asarray(T_base_world[:3, :3], dtype=np.float64)
    checker = work.checker(group)
    out = []
    for (g, q), p in zip(ok, found_pre, strict=True):
        if p is None:
            continue
        # the approach and the retreat must stay within the joint limits from the grasp's
        # solution: the nearest one if they do, else the nearest one from which they do
        # (measured: candidates whose approach ran joint 3 or 4 into its limit cost the
        # sorting demo a wasted move each, 3 for one ball)
        T = T_base_world @ g.pose.matrix()
        lines = partial(_grasp_lines, group, gripper.eef_link, g, T, R_bw=R_bw, checker=checker)
        chosen = _first_solution(group, gripper.eef_link, T, q, lambda: checker, lines)
        if chosen is not None:
            q, kept = chosen
            out.append(Grasp(**{**kept.__dict__, "joint_positions": q}))  # type: ignore[arg-type]
    return out


def _first_solution(
    group: JointGroup,
    tip_link: str,
    T: NDArray[np.float64],
    q: NDArray[np.float64],
    checker: Callable[[], CollisionChecker],
    accept: Callable[[NDArray[np.float64]], _R | None],
) -> tuple[NDArray[np.float64], _R] | None:
    """(q, accept(q)) if that is truthy, else the same for the first other collision-free IK
    solution at T (base frame; nearest q first) that ``accept`` takes, or None. ``checker``
    is called only if the other solutions are needed."""
    r = accept(q)
    if r:
        return q, r
    sols = solve_ik(group, T, seed=q, tip_link=tip_link).solutions[1:]
    if len(sols) == 0:
        return None
    for s, hit in zip(sols, checker().check(sols), strict=True):
        r = None if hit else accept(s)
        if r:
            return s, r
    return None


def _grasp_lines(
    group: JointGroup,
    tip_link: str,
    g: Grasp,
    T: NDArray[np.float64],
    q: NDArray[np.float64],
    R_bw: NDArray[np.float64],
    checker: CollisionChecker,
) -> Grasp | None:
    """``g`` if its approach (at its desired distance, else at its minimum one: the grasp is
    then returned with that as its desired distance) and its retreat (the minimum distance)
    stay within the joint limits and clear of collisions (``checker``: the object may touch
    the gripper), the arm at q at the grasp pose T (base frame); else None. (Measured: an
    approach that met a neighbouring box at its first step was one layout's only grasp.)"""
    r = g.post_grasp_retreat
    retreat: list[NDArray[np.float64]] = []
    if (
        _line_ok(group, tip_link, T, q, R_bw @ r.vector(r.min_distance), 0.01, states=retreat)
        is None
    ):
        return None
    a = g.pre_grasp_approach
    for dist in dict.fromkeys((a.desired_distance, a.min_distance)):
        approach: list[NDArray[np.float64]] = []
        if _line_ok(group, tip_link, T, q, -(R_bw @ a.vector(dist)), 0.01, states=approach) is None:
            continue
        if checker.check(np.array(retreat + approach)).any():
            continue
        if dist == a.desired_distance:
            return g
        return replace(g, pre_grasp_approach=replace(a, desired_distance=dist))
    return None


def _free_ik(
    scene: PlanningScene,
    group: JointGroup,
    tip_link: str,
    targets: list[NDArray[np.float64]],
    seed: NDArray[np.float64] | None = None,
) -> list[NDArray[np.float64] | None]:
    """For each target (base frame), its collision-free IK solution nearest ``seed``, or None.
    An analytic solver gives every solution: all of them, for all targets, are checked in one
    batch; a numeric one checks inside, retrying until a collision-free one."""
    checker = scene.checker(group)
    solver = ik_solver(group, tip_link)
    if not isinstance(solver, AnalyticIK):
        found = [
            solve_ik(group, T, seed=seed, checker=checker, tip_link=tip_link, timeout=0.02)
            for T in targets
        ]  # collision-free already, nearest the seed first
        return [r.solutions[0] if len(r.solutions) else None for r in found]
    # every solution of every target (nearest the seed first) in one compiled call
    Q, counts = solver.solve_many(np.array(targets).reshape(-1, 4, 4), seed)
    owner = np.repeat(np.arange(len(targets)), counts)
    out: list[NDArray[np.float64] | None] = [None] * len(targets)
    if not len(Q):
        return out
    for row in np.flatnonzero(~checker.check(Q)):
        if out[owner[row]] is None:
            out[owner[row]] = Q[row]
    return out


def generate_places(
    object_id: str,
    target: NDArray[np.float64] | tuple[float, float, float],
    grasp: Grasp,
    T_world_object_at_grasp: Pose,
    yaws_deg: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0),
    approach_distance: tuple[float, float] = (0.05, 0.1),
    retreat_distance: tuple[float, float] = (0.05, 0.1),
    open_command: float | None = None,
) -> list[PlaceLocation]:
    """Place candidates: the held object's centre at ``target`` (world), turned about the
    vertical by each yaw, the gripper keeping the grasp it holds the object with; approach
    down and retreat up."""
    p = vector(target, 3, "a place target", GraspError)
    if not isinstance(grasp, Grasp) or not isinstance(T_world_object_at_grasp, Pose):
        raise GraspError("generate_places needs the Grasp that holds the object and its Pose then")
    T_obj_eef = T_world_object_at_grasp.inverse() * grasp.pose
    # the same moves for every yaw (immutable: shared)
    approach = GripperTranslation((0.0, 0.0, -1.0), *approach_distance)
    retreat = GripperTranslation((0.0, 0.0, 1.0), *retreat_distance)
    out = []
    for k, yaw in enumerate(yaws_deg):
        # the object turned about the vertical by yaw from how it was held, centred at p
        R = _rz(math.radians(yaw)) @ T_world_object_at_grasp.rotation()
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, p
        obj = Pose.from_matrix(T)
        out.append(
            PlaceLocation(
                f"{object_id}/place/{k}",
                obj * T_obj_eef,
                obj,
                approach,
                retreat,
                grasp.pre_grasp_posture if open_command is None else open_command,
                1.0 - 0.1 * k,
                (object_id,),
            )
        )
    return out


def reachable_places(
    places: list[PlaceLocation], scene: PlanningScene, arm: str, eef_link: str
) -> list[PlaceLocation]:
    """The places whose pose and pre-place pose (at the approach's min distance) the arm
    reaches without collision, with the held object attached as the scene has it; order
    kept. Every IK solution of every place is collision-checked in one batch."""
    group = scene.robot.group(arm)
    T_base_world = np.linalg.inv(scene.link_pose(group.base_link).matrix())
    at, pre = [], []
    for loc in places:
        T = loc.pose.matrix().copy()
        at.append(T_base_world @ T)
        T[:3, 3] -= loc.pre_place_approach.vector(loc.pre_place_approach.min_distance)
        pre.append(T_base_world @ T)
    found_pre = _free_ik(scene, group, eef_link, pre)
    # at the place the held object comes right down onto the surface: no padding there (the
    # approach is made without it), only on the way to the pre-place
    found = _free_ik(scene.without_padding(scene.attached_objects), group, eef_link, at)
    return [
        loc
        for loc, a, b in zip(places, found, found_pre, strict=True)
        if a is not None and b is not None
    ]


def generate_pushes(
    object_id: str,
    shape: Shape,
    T_world_object: Pose,
    gripper: GripperGeometry,
    scene: PlanningScene,
    arm: str,
    distances: tuple[float, ...] = (0.04, 0.03, 0.02),
    tilts_deg: tuple[float, ...] = (30.0, 45.0, 60.0, 75.0, 15.0, 0.0),
    clearance: float = 0.01,
    inset: float = 0.006,
    above: float = 0.01,
    descent: float = 0.05,
    sideways_deg: tuple[float, ...] = (35.0, 0.0),
) -> list[Push]:
    """Pushes that turn an upright box about the vertical: the closed fingers come down beside
    the face that looks most toward the arm's base, ``inset`` [m] in from one end of it, and push
    that end straight away from the base, by the longest of ``distances`` [m] the arm reaches.
    A box pushed near one end turns about a point beyond its centre, on the side away from the
    pushed end (for a slender box about a sixth of its length, in quasi-static pushing with
    uniform support), so each push turns it by about distance / (2/3 of its length) and moves
    its centre little: for a box whose only pinch faces the base, out of reach, a few pushes
    bring a pinch within reach. The nearer the end, the longer the lever and the less the box
    drifts away from the base per degree (measured at the far corner slots of the sorting cell,
    r = 0.72 m: a 12 mm inset drifted the slender boxes out of reach, 1.4 cm per 15° push;
    6 mm sorted all 14 boxes that 12 mm left there over 200 layouts; the 7 cm tall box then
    tipped over in 4 other layouts, and 9 mm traded those for 3 that drifted out of reach).

    The gripper leans toward the base by each tilt (what lets the arm reach a far face), its
    fingers closed along the face, their lowest point ``above`` [m] the support (measured over
    200 layouts: at 4 mm, 6 mm from the end, the fingers tipped the 7 cm tall box over in 4; at
    1 cm none of those, and the 4 cm tall box in 1; at a quarter of the box's depth, 7.5 mm for
    that one, in 3). Only pushes the arm reaches collision-free at the start
    and at its end are kept, each with its IK solution, in order of distance, then tilt, then
    end."""
    if not isinstance(shape, Box):
        raise GraspError(f"turning pushes are made for boxes, not {shape.kind}")
    if not distances or min(distances) <= 0 or clearance < 0:
        raise GraspError(f"need distances > 0 and clearance >= 0, got {distances}, {clearance}")
    group = scene.robot.group(arm)
    box, T = _upright_box(shape, T_world_object.matrix())
    R_o, c_o = T[:3, :3], T[:3, 3]
    half = 0.5 * np.asarray(box.size, dtype=float)
    bottom = c_o[2] - half[2]
    base = scene.link_pose(group.base_link).position
    to_base = base[:2] - c_o[:2]
    to_base = np.array([*to_base, 0.0]) / max(float(np.linalg.norm(to_base)), 1e-9)
    # the face whose outward normal looks most toward the base (a box's side faces: ±x, ±y)
    k = max(range(4), key=lambda i: (R_o[:, i // 2] * (1 if i % 2 else -1)) @ to_base)
    axis, sign = k // 2, (1 if k % 2 else -1)
    n = R_o[:, axis] * sign
    n = n - n[2] * np.array([0.0, 0.0, 1.0])
    n /= np.linalg.norm(n)
    push_dir = -n
    u = _cross(np.array([0.0, 0.0, 1.0]), n)  # along the face
    half_n, half_u = half[axis], half[1 - axis]
    if half_u - inset <= 0:
        return []
    # which end: pushing the +u end turns the box counter-clockwise (u toward -n). The turn
    # that brings the box the shorter way to where a pinch faces the base's side: an axis on
    # the line to the base whose crossing axis the open gripper spans (a slender box: its long
    # axis; a square one: either, so never more than 45°; measured: a cube chosen by one axis
    # was turned 25° one way, then back the other)
    radial = math.atan2(-to_base[1], -to_base[0])
    spanned = [i for i in range(2) if 2 * half[1 - i] <= gripper.open_width - 0.008]
    turns = [
        (radial - math.atan2(R_o[1, i], R_o[0, i])) % math.pi
        for i in spanned or [int(np.argmax(half[:2]))]
    ]
    ccw, cw = min(turns), min(math.pi - t for t in turns)
    ends = (
        (1.0,)
        if ccw < cw - math.radians(10)
        else (-1.0,)
        if cw < ccw - math.radians(10)
        else (1.0, -1.0)
    )
    P = gripper.closed_points if len(gripper.closed_points) else gripper.points
    z_w = np.array([0.0, 0.0, 1.0])
    starts: list[tuple[Pose, NDArray[np.float64], float]] = []
    # the gripper leans toward the base: across the face, or along the line from the base
    # (which brings the wrist nearer the base when the face is oblique to that line)
    away = -to_base
    leans = [(push_dir, u)]
    if abs(away @ push_dir) < math.cos(math.radians(5)):
        leans.append((away, _cross(z_w, away)))
    # each also turned half a turn about its approach (the closed fingers push alike): the
    # wrist then starts half a turn away, clear of the joint limits a straight push can run
    # into (measured: 6 of 200 layouts stopped at joint 4's or joint 6's limit)
    leans += [(lean, -closing) for lean, closing in leans]
    for (lean, closing), tilt in itertools.product(leans, np.radians(tilts_deg)):
        approach = -math.cos(tilt) * z_w + math.sin(tilt) * lean
        R = _frame(approach, closing, gripper)
        W = P @ R.T  # the gripper's points relative to its tcp, world axes
        lead = W @ push_dir
        front = W[lead >= lead.max() - 0.005]  # what meets the face first
        for end in ends:
            # the tcp from its parts along push_dir, u and z (orthonormal): the leading points
            # `clearance` before the face, the front's middle `inset` in from the end, the
            # lowest point `above` the support
            tcp = (
                (float(c_o @ push_dir) - half_n - clearance - float(lead.max())) * push_dir
                + (float(c_o @ u) + end * (half_u - inset) - float((front @ u).mean())) * u
                + (bottom + above - float((W @ z_w).min())) * z_w
            )
            T_w_tcp = np.eye(4)
            T_w_tcp[:3, :3], T_w_tcp[:3, 3] = R, tcp
            T_w_eef = T_w_tcp @ np.linalg.inv(gripper.T_eef_tcp)
            contact = c_o + half_n * n + end * (half_u - inset) * u
            contact[2] = bottom + 0.5 * min(2 * half[2], 0.03)
            starts.append((Pose.from_matrix(T_w_eef), contact, end))
    # first pushed obliquely, toward the pushed end's side (inside the contact's friction
    # cone): the push turns the box more and drives it less away from the base (measured:
    # 14–18° for 11–13 mm, against 14–29° for 23–32 mm straight); then straight
    out: list[Push] = []
    for d in sorted(distances, reverse=True):
        for side in sideways_deg:
            a = math.radians(side)
            for pose, contact, end in starts:
                along = -n * math.cos(a) + end * u * math.sin(a)
                out.append(
                    Push(
                        f"{object_id}/push/{len(out)}",
                        pose,
                        GripperTranslation(tuple(along), d, d + clearance),  # type: ignore[arg-type]
                        descent,
                        (float(contact[0]), float(contact[1]), float(contact[2])),
                        0.0,
                    )
                )
    out = [replace(p, quality=1.0 - i / len(out)) for i, p in enumerate(out)]
    return _reachable_pushes(out, scene, group, gripper, object_id)


def _reachable_pushes(
    pushes: list[Push],
    scene: PlanningScene,
    group: JointGroup,
    gripper: GripperGeometry,
    object_id: str,
) -> list[Push]:
    """The pushes whose start, start before the descent and end the arm reaches without
    collision, with the gripper closed (the pushed object is checked too: the fingers start
    clear of it), each with an IK solution at the start from which its three straight lines
    (the descent, the push and the lift after it) stay within the joint limits: the solution
    nearest the current state if it does, else the nearest one that does (near the wrist's
    singularity a 4 cm line can turn joints 4 and 6 by a radian; measured: 6 of 200 sorting
    layouts stopped at their limits)."""
    work = scene.copy()
    work.set_joint_positions(gripper.group, [gripper.closed_command])
    if object_id in work.world_objects:
        work.set_object_padding(object_id, 0.0)
    T_base_world = np.linalg.inv(work.link_pose(group.base_link).matrix())
    seed = work.state.group_positions(group)
    targets = []
    for p in pushes:
        start = p.pose.matrix()
        above, end = start.copy(), start.copy()
        above[2, 3] += p.descent
        end[:3, 3] += p.push.vector()
        targets += [T_base_world @ start, T_base_world @ above, T_base_world @ end]
    found = _free_ik(work, group, gripper.eef_link, targets[0::3], seed)
    other = _free_ik(work, group, gripper.eef_link, targets[1::3], seed)
    at_start = work.copy()
    # at the end the gripper is where the object was (it has moved on): not a collision
    work.allow_collision(object_id, work.robot.link_names)
    ends = _free_ik(work, group, gripper.eef_link, targets[2::3], seed)
    start_checker: list[CollisionChecker] = []  # built if a push needs another solution

    def checker() -> CollisionChecker:
        if not start_checker:
            start_checker.append(at_start.checker(group))
        return start_checker[0]

    out = []
    R_bw = T_base_world[:3, :3]
    for p, q, a, e in zip(pushes, found, other, ends, strict=True):
        if q is None or a is None or e is None:
            continue
        start = T_base_world @ p.pose.matrix()
        lines = partial(
            _lines_ok,
            group,
            gripper.eef_link,
            start,
            up=R_bw @ np.array([0.0, 0.0, p.descent]),
            along=R_bw @ p.push.vector(p.push.min_distance),
            lift=R_bw @ p.lift(),
        )
        chosen = _first_solution(group, gripper.eef_link, start, q, checker, lines)
        if chosen is not None:
            out.append(Push(**{**p.__dict__, "joint_positions": chosen[0]}))  # type: ignore[arg-type]
    return out


def _line_ok(
    group: JointGroup,
    tip_link: str,
    T_start: NDArray[np.float64],
    q: NDArray[np.float64],
    offset: NDArray[np.float64],
    step: float = 0.005,
    max_jump: float = 0.3,
    states: list[NDArray[np.float64]] | None = None,
) -> NDArray[np.float64] | None:
    """The configuration at the end of the straight line from ``T_start`` (base frame, the
    arm at q) by ``offset`` (base frame), following IK from step to step, or None when a
    step leaves the joint limits or jumps (by more than ``max_jump`` rad). Each step's
    configuration is appended to ``states`` if given."""
    n = max(1, int(math.ceil(float(np.linalg.norm(offset)) / step)))
    solver = ik_solver(group, tip_link)
    if isinstance(solver, AnalyticIK):  # the same steps, compiled
        along, ok = solver.follow_line(T_start, offset, q, n, max_jump)
        if states is not None:
            states.extend(along)
        return along[-1] if ok else None
    for k in range(1, n + 1):
        T = T_start.copy()
        T[:3, 3] += offset * (k / n)
        sols = solve_ik(group, T, seed=q, tip_link=tip_link).solutions
        if len(sols) == 0 or float(np.max(np.abs(sols[0] - q))) > max_jump:
            return None
        q = sols[0]
        if states is not None:
            states.append(q)
    return q


def _lines_ok(
    group: JointGroup,
    tip_link: str,
    T_start: NDArray[np.float64],
    q: NDArray[np.float64],
    up: NDArray[np.float64],
    along: NDArray[np.float64],
    lift: NDArray[np.float64],
) -> bool:
    """Whether a push's descent (checked upward from its start), push and lift stay within
    the joint limits, the arm at q at the start."""
    if _line_ok(group, tip_link, T_start, q, up) is None:
        return False
    end = _line_ok(group, tip_link, T_start, q, along)
    if end is None:
        return False
    T_end = T_start.copy()
    T_end[:3, 3] += along
    return _line_ok(group, tip_link, T_end, end, lift) is not None


def _rz(a: float) -> NDArray[np.float64]:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
