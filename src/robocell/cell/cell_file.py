"""Cell files: robots, fixtures, objects, targets, cameras and layouts of a work cell, once, in
YAML. :func:`load_cell_file` reads and validates one; every error names the file, the item and
what was expected.

Poses are ``{xyz: [x, y, z], rpy: [r, p, y]}`` or ``{xyz: …, quat: [x, y, z, w]}`` in the world
frame (floor, z up). Shapes: ``box`` (size: full extents), ``cylinder`` (radius, height; axis z),
``sphere`` (radius), ``mesh`` (file, scale), and for fixtures ``tray`` (size: outer x, y and
wall height; wall: thickness; pose: the centre of its bottom face).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from robocell.errors import CellError, choices
from robocell.geometry.pose import Pose
from robocell.geometry.shapes import Box, Cylinder, Mesh, Shape, Sphere

COLORS = {
    "red": (0.85, 0.1, 0.1, 1.0),
    "green": (0.1, 0.7, 0.2, 1.0),
    "blue": (0.1, 0.25, 0.85, 1.0),
    "yellow": (0.95, 0.85, 0.1, 1.0),
    "white": (0.95, 0.95, 0.95, 1.0),
    "black": (0.05, 0.05, 0.05, 1.0),
    "grey": (0.5, 0.5, 0.5, 1.0),
    "orange": (0.95, 0.5, 0.1, 1.0),
}


@dataclass(frozen=True)
class RobotSpec:
    name: str
    model: str | None
    urdf: Path | None
    srdf: Path | None
    pose: Pose
    arm: str
    gripper: str | None
    gripper_command: tuple[float, float]
    home: str | None


@dataclass(frozen=True)
class Part:
    """One shape of a fixture or object at ``pose`` in its frame."""

    shape: Shape
    pose: Pose


@dataclass(frozen=True)
class FixtureSpec:
    name: str
    parts: tuple[Part, ...]
    pose: Pose
    color: tuple[float, float, float, float]
    friction: float


@dataclass(frozen=True)
class ObjectSpec:
    name: str
    shape: Shape
    pose: Pose
    mass: float
    friction: float
    color: tuple[float, float, float, float]
    color_name: str

    @property
    def kind(self) -> str:
        return self.shape.kind

    @property
    def size(self) -> tuple[float, float, float]:
        """(length x, width y, height z) of its bounding box in its own frame [m]."""
        s = self.shape
        if isinstance(s, Box):
            return (s.size[0], s.size[1], s.size[2])
        if isinstance(s, Cylinder):
            return (2 * s.radius, 2 * s.radius, s.length)
        if isinstance(s, Sphere):
            return (2 * s.radius,) * 3
        lo, hi = s.vertices.min(axis=0), s.vertices.max(axis=0)
        return tuple(float(v) for v in hi - lo)  # type: ignore[return-value]


@dataclass(frozen=True)
class TargetSpec:
    name: str
    position: tuple[float, float, float]
    frame: str  # "world" or "robot"
    tray: str | None


@dataclass(frozen=True)
class CameraSpec:
    name: str
    position: tuple[float, float, float]
    look_at: tuple[float, float, float]
    fovy: float
    width: int
    height: int


@dataclass(frozen=True)
class LayoutSpec:
    jitter: float = 0.0
    random_yaw: tuple[str, ...] = ()


@dataclass(frozen=True)
class CellSpec:
    name: str
    description: str
    robots: tuple[RobotSpec, ...]
    fixtures: tuple[FixtureSpec, ...]
    objects: tuple[ObjectSpec, ...]
    targets: tuple[TargetSpec, ...]
    cameras: tuple[CameraSpec, ...]
    layouts: LayoutSpec
    source: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    def object(self, name: str) -> ObjectSpec:
        for o in self.objects:
            if isinstance(name, str) and o.name == name:
                return o
        raise CellError(f"unknown object {name!r}; known: {choices(o.name for o in self.objects)}")

    def layout(self, k: int) -> dict[str, Pose]:
        """Initial object poses of layout ``k``: 0 as written; k > 0 the objects shuffled among
        the layout-0 slots (keeping each object's height above the surface), jittered, and
        yawed, from a generator seeded with k."""
        if not isinstance(k, int | np.integer) or k < 0:
            raise CellError(f"layout must be an integer >= 0, got {k!r}")
        poses = {o.name: o.pose for o in self.objects}
        if k == 0:
            return poses
        rng = np.random.default_rng(int(k))
        objs = list(self.objects)
        slots = [o.pose.position for o in objs]
        # the surface under each slot: the slot's z minus its object's half height
        ground = [float(p[2]) - 0.5 * o.size[2] for p, o in zip(slots, objs, strict=True)]
        order = rng.permutation(len(objs))
        out: dict[str, Pose] = {}
        j = self.layouts.jitter
        for o, s in zip(objs, order, strict=True):
            x, y = float(slots[s][0]), float(slots[s][1])
            x += rng.uniform(-j, j)
            y += rng.uniform(-j, j)
            z = ground[s] + 0.5 * o.size[2]
            yaw = rng.uniform(-math.pi, math.pi) if o.kind in self.layouts.random_yaw else 0.0
            out[o.name] = Pose.from_rpy(x, y, z, 0.0, 0.0, yaw)
        return out


# ---------------------------------------------------------------------- reading
class _Reader:
    def __init__(self, source: str, base: Path) -> None:
        self.source = source
        self.base = base

    def fail(self, where: str, msg: str) -> CellError:
        return CellError(f"{self.source}: {where}: {msg}")

    def keys(self, d: Any, where: str, required: set[str], optional: set[str]) -> dict[str, Any]:
        if not isinstance(d, dict):
            raise self.fail(where, f"expected a mapping, got {type(d).__name__}")
        known = required | optional
        for k in d:
            if k not in known:
                raise self.fail(where, f"unknown key {k!r}; expected: {choices(known)}")
        for k in sorted(required):
            if k not in d:
                raise self.fail(where, f"missing {k!r} (required: {choices(required)})")
        return d

    def number(self, v: Any, where: str, positive: bool = False, nonneg: bool = False) -> float:
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise self.fail(where, f"expected a number, got {v!r}") from None
        if not math.isfinite(x):
            raise self.fail(where, f"expected a finite number, got {v!r}")
        if positive and x <= 0:
            raise self.fail(where, f"must be > 0, got {x}")
        if nonneg and x < 0:
            raise self.fail(where, f"must be >= 0, got {x}")
        return x

    def vector(self, v: Any, n: int, where: str, positive: bool = False) -> tuple[float, ...]:
        if not isinstance(v, list | tuple) or len(v) != n:
            raise self.fail(where, f"expected {n} numbers, got {v!r}")
        return tuple(self.number(x, f"{where}[{i}]", positive) for i, x in enumerate(v))

    def pose(self, v: Any, where: str) -> Pose:
        if v is None:
            return Pose()
        d = self.keys(v, where, set(), {"xyz", "rpy", "quat"})
        xyz = self.vector(d.get("xyz", [0, 0, 0]), 3, f"{where}.xyz")
        if "rpy" in d and "quat" in d:
            raise self.fail(where, "give either rpy or quat, not both")
        if "quat" in d:
            q = self.vector(d["quat"], 4, f"{where}.quat")
            if np.linalg.norm(q) < 1e-9:
                raise self.fail(f"{where}.quat", "a zero quaternion is not a rotation")
            return Pose(xyz, q)
        rpy = self.vector(d.get("rpy", [0, 0, 0]), 3, f"{where}.rpy")
        return Pose.from_rpy(*xyz, *rpy)

    def color(self, v: Any, where: str) -> tuple[float, float, float, float]:
        if v is None:
            return (0.6, 0.6, 0.6, 1.0)
        if isinstance(v, str):
            if v not in COLORS:
                raise self.fail(where, f"unknown colour {v!r}; known: {choices(COLORS)}")
            return COLORS[v]
        c = self.vector(v, 4, where) if len(v) == 4 else self.vector(v, 3, where) + (1.0,)
        if not all(0 <= x <= 1 for x in c):
            raise self.fail(where, f"colour components must be in [0, 1], got {list(c)}")
        return c  # type: ignore[return-value]

    def shape(self, d: dict[str, Any], where: str) -> Shape:
        kind = d.get("shape")
        if kind == "box":
            return Box(self.vector(d.get("size"), 3, f"{where}.size", positive=True))  # type: ignore[arg-type]
        if kind == "cylinder":
            return Cylinder(
                self.number(d.get("radius"), f"{where}.radius", positive=True),
                self.number(d.get("height"), f"{where}.height", positive=True),
            )
        if kind == "sphere":
            return Sphere(self.number(d.get("radius"), f"{where}.radius", positive=True))
        if kind == "mesh":
            f = d.get("file")
            if not isinstance(f, str):
                raise self.fail(where, "a mesh needs 'file'")
            path = (self.base / f).resolve()
            if not path.is_file():
                raise self.fail(f"{where}.file", f"mesh file not found: {path}")
            scale = self.vector(d.get("scale", [1, 1, 1]), 3, f"{where}.scale", positive=True)
            return Mesh.from_file(path, scale)
        raise self.fail(where, f"unknown shape {kind!r}; known: box, cylinder, mesh, sphere")


def _item(kind: str, i: int, d: Any) -> str:
    """``objects[3] (red_box)``: an item's place in the file and, when it has one, its name."""
    name = d.get("name") if isinstance(d, dict) else None
    return f"{kind}[{i}] ({name})" if isinstance(name, str) and name else f"{kind}[{i}]"


SHAPE_KEYS = {"box": {"size"}, "cylinder": {"radius", "height"}, "sphere": {"radius"},
              "mesh": {"file"}, "tray": {"size"}}  # fmt: skip


def _tray_parts(r: _Reader, d: dict[str, Any], where: str) -> tuple[Part, ...]:
    """A tray: a bottom plate and four walls; its frame is the centre of its bottom face."""
    sx, sy, h = r.vector(d.get("size"), 3, f"{where}.size", positive=True)
    t = r.number(d.get("wall", 0.01), f"{where}.wall", positive=True)
    if 2 * t >= min(sx, sy) or t >= h:
        raise r.fail(where, f"wall {t} too thick for a tray of size {[sx, sy, h]}")
    return (
        Part(Box((sx, sy, t)), Pose([0, 0, t / 2])),
        Part(Box((t, sy, h)), Pose([(sx - t) / 2, 0, h / 2])),
        Part(Box((t, sy, h)), Pose([-(sx - t) / 2, 0, h / 2])),
        Part(Box((sx - 2 * t, t, h)), Pose([0, (sy - t) / 2, h / 2])),
        Part(Box((sx - 2 * t, t, h)), Pose([0, -(sy - t) / 2, h / 2])),
    )


def load_cell_file(path: str | Path) -> CellSpec:
    """Read and validate a cell file."""
    p = Path(path)
    if not p.is_file():
        raise CellError(f"cell file not found: {p}")
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise CellError(f"{p}: not valid YAML: {exc}") from exc
    return parse_cell(data, str(p), p.parent)


def parse_cell(data: Any, source: str = "<cell>", base: Path | None = None) -> CellSpec:
    """Validate a cell description (the YAML's data)."""
    r = _Reader(source, base or Path.cwd())
    top = r.keys(
        data, "cell", {"name", "robots"},
        {"description", "fixtures", "objects", "targets", "cameras", "layouts"},
    )  # fmt: skip
    names: dict[str, str] = {}

    def claim(name: Any, where: str) -> str:
        if not isinstance(name, str) or not name:
            raise r.fail(where, f"'name' must be a non-empty string, got {name!r}")
        if name in names:
            raise r.fail(where, f"duplicate name {name!r} (also {names[name]})")
        names[name] = where
        return name

    robots = []
    for i, d in enumerate(top.get("robots") or []):
        where = _item("robots", i, d)
        r.keys(d, where, {"name"}, {"model", "urdf", "srdf", "pose", "arm", "gripper",
                                     "gripper_command", "home"})  # fmt: skip
        name = claim(d["name"], where)
        where = f"robots[{i}] ({name})"
        model = d.get("model")
        urdf = d.get("urdf")
        if (model is None) == (urdf is None):
            raise r.fail(where, "give either 'model' (a bundled robot) or 'urdf' (a path)")
        if model is not None:
            from robocell.robot.model import bundled_robots

            if model not in bundled_robots():
                raise r.fail(
                    f"{where}.model",
                    f"unknown robot {model!r}; bundled: {choices(bundled_robots())}",
                )
        urdf_path = srdf_path = None
        if urdf is not None:
            urdf_path = (r.base / str(urdf)).resolve()
            if not urdf_path.is_file():
                raise r.fail(f"{where}.urdf", f"file not found: {urdf_path}")
            if d.get("srdf") is not None:
                srdf_path = (r.base / str(d["srdf"])).resolve()
                if not srdf_path.is_file():
                    raise r.fail(f"{where}.srdf", f"file not found: {srdf_path}")
        gc = r.vector(d.get("gripper_command", [0.0, 1.0]), 2, f"{where}.gripper_command")
        robots.append(
            RobotSpec(
                name, model, urdf_path, srdf_path, r.pose(d.get("pose"), f"{where}.pose"),
                str(d.get("arm", "arm")), d.get("gripper"), (gc[0], gc[1]), d.get("home"),
            )
        )  # fmt: skip
    if len(robots) != 1:
        raise r.fail("robots", f"a cell has exactly one robot for now, got {len(robots)}")

    fixtures = []
    for i, d in enumerate(top.get("fixtures") or []):
        where = _item("fixtures", i, d)
        if not isinstance(d, dict):
            raise r.fail(where, "expected a mapping")
        kind = d.get("shape")
        if kind not in SHAPE_KEYS:
            raise r.fail(where, f"unknown shape {kind!r}; known: {choices(SHAPE_KEYS)}")
        r.keys(d, where, {"name", "shape"} | SHAPE_KEYS[kind],
               {"pose", "color", "friction", "wall", "scale"})  # fmt: skip
        name = claim(d["name"], where)
        where = f"fixtures[{i}] ({name})"
        parts = _tray_parts(r, d, where) if kind == "tray" else (Part(r.shape(d, where), Pose()),)
        fixtures.append(
            FixtureSpec(
                name, parts, r.pose(d.get("pose"), f"{where}.pose"),
                r.color(d.get("color"), f"{where}.color"),
                r.number(d.get("friction", 1.0), f"{where}.friction", positive=True),
            )
        )  # fmt: skip

    objects = []
    for i, d in enumerate(top.get("objects") or []):
        where = _item("objects", i, d)
        if not isinstance(d, dict):
            raise r.fail(where, "expected a mapping")
        kind = d.get("shape")
        if kind not in ("box", "cylinder", "sphere", "mesh"):
            raise r.fail(where, f"unknown shape {kind!r}; known: box, cylinder, mesh, sphere")
        r.keys(d, where, {"name", "shape", "mass", "pose"} | SHAPE_KEYS[kind],
               {"color", "friction", "scale"})  # fmt: skip
        name = claim(d["name"], where)
        where = f"objects[{i}] ({name})"
        color = d.get("color")
        objects.append(
            ObjectSpec(
                name, r.shape(d, where), r.pose(d.get("pose"), f"{where}.pose"),
                r.number(d["mass"], f"{where}.mass", positive=True),
                r.number(d.get("friction", 1.0), f"{where}.friction", positive=True),
                r.color(color, f"{where}.color"), color if isinstance(color, str) else "",
            )
        )  # fmt: skip

    targets = []
    for i, d in enumerate(top.get("targets") or []):
        where = _item("targets", i, d)
        r.keys(d, where, {"name", "position"}, {"frame", "tray"})
        name = claim(d["name"], where)
        where = f"targets[{i}] ({name})"
        frame = d.get("frame", "world")
        if frame not in ("world", "robot"):
            raise r.fail(f"{where}.frame", f"unknown frame {frame!r}; known: robot, world")
        tray = d.get("tray")
        if tray is not None and tray not in [f.name for f in fixtures]:
            raise r.fail(
                f"{where}.tray",
                f"unknown fixture {tray!r}; known: {choices(f.name for f in fixtures)}",
            )
        pos = r.vector(d["position"], 3, f"{where}.position")
        targets.append(TargetSpec(name, (pos[0], pos[1], pos[2]), frame, tray))

    cameras = []
    for i, d in enumerate(top.get("cameras") or []):
        where = _item("cameras", i, d)
        r.keys(d, where, {"name", "position", "look_at"}, {"fovy", "width", "height"})
        name = claim(d["name"], where)
        where = f"cameras[{i}] ({name})"
        pos = r.vector(d["position"], 3, f"{where}.position")
        at = r.vector(d["look_at"], 3, f"{where}.look_at")
        if np.linalg.norm(np.subtract(at, pos)) < 1e-6:
            raise r.fail(where, "look_at must differ from position")
        cameras.append(
            CameraSpec(
                name, (pos[0], pos[1], pos[2]), (at[0], at[1], at[2]),
                r.number(d.get("fovy", 45), f"{where}.fovy", positive=True),
                int(r.number(d.get("width", 640), f"{where}.width", positive=True)),
                int(r.number(d.get("height", 480), f"{where}.height", positive=True)),
            )
        )  # fmt: skip

    lay = top.get("layouts") or {}
    r.keys(lay, "layouts", set(), {"jitter", "random_yaw"})
    ry = lay.get("random_yaw", [])
    if not isinstance(ry, list) or not all(k in ("box", "cylinder", "sphere", "mesh") for k in ry):
        raise r.fail("layouts.random_yaw", f"expected a list of shapes, got {ry!r}")
    layouts = LayoutSpec(r.number(lay.get("jitter", 0.0), "layouts.jitter", nonneg=True), tuple(ry))
    return CellSpec(
        str(top["name"]), str(top.get("description", "")), tuple(robots), tuple(fixtures),
        tuple(objects), tuple(targets), tuple(cameras), layouts, source,
    )  # fmt: skip


def bundled_cells() -> list[str]:
    """Names of the cells shipped with robocell."""
    d = Path(__file__).resolve().parent.parent / "assets" / "cells"
    return sorted(p.stem for p in d.glob("*.yaml"))


def cell_path(name_or_path: str | Path) -> Path:
    """A bundled cell's file by name, or the path given."""
    if not isinstance(name_or_path, str | Path):
        raise CellError(
            f"a cell is a bundled cell's name or a cell file's path, got {name_or_path!r}; "
            f"bundled: {choices(bundled_cells())}"
        )
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists():
        return p
    d = Path(__file__).resolve().parent.parent / "assets" / "cells"
    if (d / f"{name_or_path}.yaml").is_file():
        return d / f"{name_or_path}.yaml"
    raise CellError(f"unknown cell {str(name_or_path)!r}; bundled: {choices(bundled_cells())}")
