"""MoveIt PlanningScene and MotionPlanRequest messages in YAML (as MotionBenchMaker writes them).

Conventions of the format: a collision object has a ``pose`` (its frame, optional: identity) and
``primitives`` + ``primitive_poses`` (relative to that frame; world pose = pose · primitive_pose),
likewise ``meshes`` + ``mesh_poses``; quaternions are x, y, z, w; box dimensions are full
extents; cylinder dimensions are [height, radius]; sphere [radius].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from robocell.errors import GeometryError, ModelError, SceneError, choices
from robocell.geometry.pose import Pose
from robocell.geometry.shapes import Box, Cylinder, Mesh, Shape, Sphere
from robocell.robot.model import RobotModel
from robocell.scene.objects import CollisionObject
from robocell.scene.planning_scene import PlanningScene

PRIMITIVES = ("box", "cylinder", "sphere")


def _read_yaml(path: str | Path) -> dict[str, Any]:
    p = Path(path)
    if not p.is_file():
        raise SceneError(f"file not found: {str(p)!r}")
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise SceneError(f"{p}: not valid YAML: {exc}") from exc
    if not isinstance(data, dict):
        raise SceneError(f"{p}: expected a mapping at the top level")
    return data


def _pose(d: Any, where: str) -> Pose:
    if d is None:
        return Pose()
    try:
        return Pose(d.get("position", (0, 0, 0)), d.get("orientation", (0, 0, 0, 1)))
    except (GeometryError, AttributeError) as exc:
        raise SceneError(f"{where}: bad pose {d!r}: {exc}") from exc


def _primitive(p: dict[str, Any], where: str) -> Shape:
    kind = str(p.get("type", "")).lower()
    dims = p.get("dimensions", [])
    try:
        if kind == "box":
            return Box(tuple(float(v) for v in dims))  # type: ignore[arg-type]
        if kind == "cylinder":
            height, radius = dims
            return Cylinder(float(radius), float(height))
        if kind == "sphere":
            return Sphere(float(dims[0]))
    except (ValueError, TypeError, GeometryError) as exc:
        raise SceneError(f"{where}: bad {kind} dimensions {dims!r}: {exc}") from exc
    raise SceneError(f"{where}: unknown primitive type {kind!r}; known: {', '.join(PRIMITIVES)}")


def _mesh(m: dict[str, Any], where: str) -> Mesh:
    try:
        verts = np.array([[v["x"], v["y"], v["z"]] for v in m["vertices"]], dtype=float)
        tris = np.array([t["vertex_indices"] for t in m["triangles"]], dtype=np.int64)
        return Mesh(verts, tris)
    except (KeyError, TypeError, GeometryError) as exc:
        raise SceneError(f"{where}: bad mesh: {exc}") from exc


def collision_object_from_msg(o: dict[str, Any], where: str) -> CollisionObject:
    oid = o.get("id")
    if not oid:
        raise SceneError(f"{where}: a collision object has no id")
    where = f"{where}: object {oid!r}"
    shapes: list[Shape] = []
    poses: list[Pose] = []
    prims = o.get("primitives") or []
    ppos = o.get("primitive_poses") or []
    if len(prims) != len(ppos):
        raise SceneError(f"{where}: {len(prims)} primitives but {len(ppos)} primitive_poses")
    for k, (p, pp) in enumerate(zip(prims, ppos, strict=True)):
        shapes.append(_primitive(p, f"{where} primitive {k}"))
        poses.append(_pose(pp, f"{where} primitive_pose {k}"))
    meshes = o.get("meshes") or []
    mposes = o.get("mesh_poses") or []
    if len(meshes) != len(mposes):
        raise SceneError(f"{where}: {len(meshes)} meshes but {len(mposes)} mesh_poses")
    for k, (m, mp) in enumerate(zip(meshes, mposes, strict=True)):
        shapes.append(_mesh(m, f"{where} mesh {k}"))
        poses.append(_pose(mp, f"{where} mesh_pose {k}"))
    if not shapes:
        raise SceneError(f"{where}: no primitives or meshes")
    return CollisionObject(str(oid), tuple(shapes), tuple(poses), _pose(o.get("pose"), where))


def _joint_values(robot: RobotModel, js: dict[str, Any], where: str) -> dict[str, float]:
    """name → value for the robot's variables; names of fixed or mimic URDF joints are ignored
    (MotionBenchMaker lists gripper joints the URDF has fixed); unknown names are errors."""
    names = js.get("name", []) or []
    values = js.get("position", []) or []
    if len(names) != len(values):
        raise SceneError(f"{where}: {len(names)} joint names but {len(values)} positions")
    urdf_joints = {j.name for j in robot.urdf.joints}
    out: dict[str, float] = {}
    for n, v in zip(names, values, strict=True):
        if n in robot.variable_names:
            out[n] = float(v)
        elif n not in urdf_joints:
            raise SceneError(
                f"{where}: unknown joint {n!r}; known: {choices(robot.variable_names)}"
            )
    return out


def load_scene(
    robot: RobotModel, path: str | Path, scene: PlanningScene | None = None
) -> PlanningScene:
    """A :class:`PlanningScene` from a MoveIt PlanningScene YAML file (world objects, robot
    state, allowed-collision matrix). Into ``scene`` if given: all or nothing."""
    data = _read_yaml(path)
    where = str(path)
    target = (scene or PlanningScene(robot, name=str(data.get("name", "")))).copy()
    objs = (data.get("world") or {}).get("collision_objects") or []
    for k, o in enumerate(objs):
        if not isinstance(o, dict):
            raise SceneError(f"{where}: collision object {k} is not a mapping")
        target.add_object(collision_object_from_msg(o, where))
    rs = data.get("robot_state") or {}
    js = rs.get("joint_state") or {}
    for name, value in _joint_values(robot, js, f"{where}: robot_state").items():
        target.state.positions[robot.variable_index(name)] = value
    acm = data.get("allowed_collision_matrix") or {}
    names = acm.get("entry_names") or []
    values = acm.get("entry_values") or []
    if len(values) != len(names):
        raise SceneError(
            f"{where}: allowed_collision_matrix has {len(names)} names but {len(values)} rows"
        )
    for i, row in enumerate(values):
        if len(row) != len(names):
            raise SceneError(
                f"{where}: allowed_collision_matrix row {i} has {len(row)} entries, "
                f"expected {len(names)}"
            )
        for j in range(i + 1, len(names)):
            target.acm.set_entry(names[i], names[j], bool(row[j]))
    target._changed()
    if scene is None:
        return target
    scene.__dict__.update(target.__dict__)
    return scene


def scene_to_dict(scene: PlanningScene) -> dict[str, Any]:
    """The scene as a MoveIt PlanningScene message (world objects, robot state, ACM)."""
    objs = []
    for obj in scene.world_objects.values():
        msg: dict[str, Any] = {
            "id": obj.id,
            "pose": obj.pose.to_dict(),
            "primitives": [],
            "primitive_poses": [],
            "meshes": [],
            "mesh_poses": [],
        }
        for shape, p in zip(obj.shapes, obj.shape_poses, strict=True):
            if isinstance(shape, Box):
                msg["primitives"].append({"type": "box", "dimensions": list(shape.size)})
            elif isinstance(shape, Cylinder):
                msg["primitives"].append(
                    {"type": "cylinder", "dimensions": [shape.length, shape.radius]}
                )
            elif isinstance(shape, Sphere):
                msg["primitives"].append({"type": "sphere", "dimensions": [shape.radius]})
            else:
                msg["meshes"].append(
                    {
                        "vertices": [
                            {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}
                            for v in shape.vertices
                        ],
                        "triangles": [
                            {"vertex_indices": [int(i) for i in t]} for t in shape.triangles
                        ],
                    }
                )
                msg["mesh_poses"].append(p.to_dict())
                continue
            msg["primitive_poses"].append(p.to_dict())
        for key in ("meshes", "mesh_poses"):
            if not msg[key]:
                del msg[key]
        objs.append(msg)
    entry = scene.acm.entries()
    names = sorted(scene.acm.names())
    values = [
        [bool(entry.get(frozenset((a, b)), False)) if a != b else False for b in names]
        for a in names
    ]
    return {
        "name": scene.name,
        "robot_model_name": scene.robot.name,
        "fixed_frame_transforms": [
            {
                "child_frame_id": "world",
                "transform": {
                    "translation": scene.robot_pose.position.tolist(),
                    "rotation": scene.robot_pose.orientation.tolist(),
                },
            }
        ],
        "robot_state": {
            "joint_state": {
                "name": list(scene.robot.variable_names),
                "position": scene.state.positions.tolist(),
            }
        },
        "allowed_collision_matrix": {"entry_names": names, "entry_values": values},
        "world": {"collision_objects": objs},
    }


def save_scene(scene: PlanningScene, path: str | Path) -> None:
    """Write the scene as MoveIt PlanningScene YAML (readable back by :func:`load_scene`)."""
    Path(path).write_text(yaml.safe_dump(scene_to_dict(scene), sort_keys=False))


@dataclass
class PlanRequest:
    """A MoveIt MotionPlanRequest as read from YAML: group, start and joint goal (full vectors
    of the group's joints, in its order), and the request's settings."""

    group: str
    start: np.ndarray
    goal: np.ndarray
    planner_id: str = ""
    allowed_planning_time: float = 5.0
    num_planning_attempts: int = 1
    goal_tolerances: np.ndarray = field(default_factory=lambda: np.zeros(0))
    source: str = ""


def load_request(
    robot: RobotModel, path: str | Path, scene: PlanningScene | None = None
) -> PlanRequest:
    """A MotionPlanRequest YAML with a joint-space goal (goal_constraints[0].joint_constraints).
    Joints the request's start state omits take ``scene``'s current values (or defaults)."""
    data = _read_yaml(path)
    where = str(path)
    group_name = data.get("group_name", "")
    try:
        group = robot.group(group_name)
    except ModelError as exc:
        raise SceneError(f"{where}: {exc}") from exc
    base = scene.state.positions.copy() if scene is not None else robot.default_positions.copy()
    start_js = ((data.get("start_state") or {}).get("joint_state")) or {}
    for name, v in _joint_values(robot, start_js, f"{where}: start_state").items():
        base[robot.variable_index(name)] = v
    goals = data.get("goal_constraints") or []
    if not goals or not goals[0].get("joint_constraints"):
        raise SceneError(
            f"{where}: only joint-space goals are read (goal_constraints[0].joint_constraints)"
        )
    goal = base[group.indices].copy()
    tols = np.zeros(group.dof)
    for jc in goals[0]["joint_constraints"]:
        name = jc.get("joint_name")
        if name not in group.joint_names:
            raise SceneError(
                f"{where}: goal joint {name!r} is not in group {group.name!r}; "
                f"its joints: {', '.join(group.joint_names)}"
            )
        k = group.joint_names.index(name)
        goal[k] = float(jc["position"])
        tols[k] = max(
            float(jc.get("tolerance_above", 0) or 0), float(jc.get("tolerance_below", 0) or 0)
        )
    return PlanRequest(
        group=group.name,
        start=base[group.indices].copy(),
        goal=goal,
        planner_id=str(data.get("planner_id", "")),
        allowed_planning_time=float(data.get("allowed_planning_time", 5.0) or 5.0),
        num_planning_attempts=int(data.get("num_planning_attempts", 1) or 1),
        goal_tolerances=tols,
        source=where,
    )
