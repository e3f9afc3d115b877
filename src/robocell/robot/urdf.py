"""URDF reading: the kinematic tree (links, joints, limits, mimic) as plain dataclasses.

Geometry (meshes, primitives) is loaded by pinocchio/coal in :mod:`robocell.robot.model`; this
module reads what planning needs from the XML and validates it with messages that name the
bad element.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocell.errors import ModelError, unknown
from robocell.geometry.pose import make_transform, rpy_to_matrix

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
_INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


@dataclass
class JointInfo:
    """One URDF joint. ``origin`` is T_parent_joint (4×4); ``axis`` is a unit vector in the
    joint frame."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float = -math.inf
    upper: float = math.inf
    velocity: float = math.inf
    effort: float = math.inf
    mimic: tuple[str, float, float] | None = None  # (master joint, multiplier, offset)


@dataclass
class UrdfMesh:
    """A mesh reference of a link (kept to check that the file exists before loading)."""

    link: str
    filename: str
    kind: str  # "collision" or "visual"


@dataclass
class Inertial:
    """A link's mass [kg], centre of mass frame ``origin`` (4×4, in the link frame) and inertia
    tensor (3×3) [kg m²] about the centre of mass, in that frame."""

    mass: float
    origin: np.ndarray
    inertia: np.ndarray


@dataclass
class UrdfRobot:
    name: str
    links: list[str]
    joints: list[JointInfo]
    root: str
    meshes: list[UrdfMesh] = field(default_factory=list)
    source: str = ""
    inertials: dict[str, Inertial] = field(default_factory=dict)
    colors: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)

    def joint(self, name: str) -> JointInfo:
        for j in self.joints:
            if j.name == name:
                return j
        raise ModelError(unknown("joint", name, [j.name for j in self.joints]))


def _floats(text: str | None, n: int, what: str, default: tuple[float, ...]) -> np.ndarray:
    if text is None:
        return np.array(default, dtype=float)
    try:
        vals = np.array([float(v) for v in text.split()], dtype=float)
    except ValueError as exc:
        raise ModelError(f"{what}: cannot read numbers from {text!r}") from exc
    if vals.shape != (n,) or not np.all(np.isfinite(vals)):
        raise ModelError(f"{what}: expected {n} finite numbers, got {text!r}")
    return vals


def _origin(elem: ET.Element | None, what: str) -> np.ndarray:
    if elem is None:
        return np.eye(4)
    xyz = _floats(elem.get("xyz"), 3, f"{what} origin xyz", (0.0, 0.0, 0.0))
    rpy = _floats(elem.get("rpy"), 3, f"{what} origin rpy", (0.0, 0.0, 0.0))
    return make_transform(rpy_to_matrix(*rpy), xyz)


def parse_urdf(text: str, source: str = "<string>") -> UrdfRobot:
    """Parse URDF XML text. Raises :class:`ModelError` naming the file and the bad element."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ModelError(f"{source}: not valid XML: {exc}") from exc
    if root.tag != "robot":
        raise ModelError(f"{source}: the root element is <{root.tag}>, expected <robot>")
    name = root.get("name", "robot")
    links: list[str] = []
    meshes: list[UrdfMesh] = []
    inertials: dict[str, Inertial] = {}
    colors: dict[str, tuple[float, float, float, float]] = {}
    # materials defined at the top level, referred to by name in links
    named_colors = {
        m.get("name", ""): m.find("color").get("rgba", "")  # type: ignore[union-attr]
        for m in root.findall("material")
        if m.find("color") is not None
    }
    for link in root.findall("link"):
        lname = link.get("name")
        if not lname:
            raise ModelError(f"{source}: a <link> has no name")
        if lname in links:
            raise ModelError(f"{source}: duplicate link {lname!r}")
        links.append(lname)
        inertial = link.find("inertial")
        if inertial is not None:
            mass_el = inertial.find("mass")
            mass = float(mass_el.get("value", 0.0)) if mass_el is not None else 0.0
            if not mass >= 0:
                raise ModelError(f"{source}: link {lname!r} has a negative mass {mass}")
            ie = inertial.find("inertia")
            vals = {k: float(ie.get(k, 0.0)) if ie is not None else 0.0 for k in _INERTIA_KEYS}
            tensor = np.array(
                [
                    [vals["ixx"], vals["ixy"], vals["ixz"]],
                    [vals["ixy"], vals["iyy"], vals["iyz"]],
                    [vals["ixz"], vals["iyz"], vals["izz"]],
                ]
            )
            inertials[lname] = Inertial(
                mass, _origin(inertial.find("origin"), f"link {lname!r} inertial"), tensor
            )
        mat = link.find("visual/material")
        if mat is not None:
            col = mat.find("color")
            rgba: str | None = (
                col.get("rgba") if col is not None else named_colors.get(mat.get("name", ""))
            )
            if rgba:
                c = _floats(rgba, 4, f"link {lname!r} colour", (0.7, 0.7, 0.7, 1.0))
                colors[lname] = (float(c[0]), float(c[1]), float(c[2]), float(c[3]))
        for kind in ("collision", "visual"):
            for el in link.findall(kind):
                mesh = el.find("geometry/mesh")
                if mesh is not None:
                    meshes.append(UrdfMesh(lname, mesh.get("filename", ""), kind))
    if not links:
        raise ModelError(f"{source}: the robot has no <link>")

    joints: list[JointInfo] = []
    seen: set[str] = set()
    for el in root.findall("joint"):
        jname = el.get("name")
        if not jname:
            raise ModelError(f"{source}: a <joint> has no name")
        if jname in seen:
            raise ModelError(f"{source}: duplicate joint {jname!r}")
        seen.add(jname)
        jtype = el.get("type", "")
        if jtype not in JOINT_TYPES:
            raise ModelError(
                f"{source}: joint {jname!r} has type {jtype!r}; supported: {', '.join(JOINT_TYPES)}"
            )
        parent_el, child_el = el.find("parent"), el.find("child")
        if parent_el is None or child_el is None:
            raise ModelError(f"{source}: joint {jname!r} needs <parent> and <child>")
        parent, child = parent_el.get("link", ""), child_el.get("link", "")
        for role, lk in (("parent", parent), ("child", child)):
            if lk not in links:
                raise ModelError(f"{source}: joint {jname!r} {role} " + unknown("link", lk, links))
        axis_el = el.find("axis")
        axis = _floats(
            None if axis_el is None else axis_el.get("xyz"), 3, f"joint {jname!r} axis", (1, 0, 0)
        )
        norm = float(np.linalg.norm(axis))
        if jtype != "fixed" and norm < 1e-12:
            raise ModelError(f"{source}: joint {jname!r} has a zero axis")
        info = JointInfo(
            jname,
            jtype,
            parent,
            child,
            _origin(el.find("origin"), f"joint {jname!r}"),
            axis / norm if norm > 0 else axis,
        )
        limit = el.find("limit")
        if jtype in ("revolute", "prismatic"):
            if limit is None:
                raise ModelError(f"{source}: {jtype} joint {jname!r} needs a <limit>")
            info.lower = float(limit.get("lower", 0.0))
            info.upper = float(limit.get("upper", 0.0))
            if not info.lower <= info.upper:
                raise ModelError(
                    f"{source}: joint {jname!r} has lower limit {info.lower} > upper {info.upper}"
                )
        if limit is not None:
            info.velocity = float(limit.get("velocity", math.inf)) or math.inf
            info.effort = float(limit.get("effort", math.inf)) or math.inf
        mimic = el.find("mimic")
        if mimic is not None and jtype != "fixed":
            info.mimic = (
                mimic.get("joint", ""),
                float(mimic.get("multiplier", 1.0)),
                float(mimic.get("offset", 0.0)),
            )
        joints.append(info)

    names = [j.name for j in joints]
    for j in joints:
        if j.mimic is not None and j.mimic[0] not in names:
            raise ModelError(
                f"{source}: joint {j.name!r} mimics " + unknown("joint", j.mimic[0], names)
            )
    children = [j.child for j in joints]
    for lk in set(children):
        if children.count(lk) > 1:
            raise ModelError(f"{source}: link {lk!r} has more than one parent joint")
    roots = [lk for lk in links if lk not in children]
    if len(roots) != 1:
        raise ModelError(f"{source}: the robot must have exactly one root link, found {roots}")
    robot = UrdfRobot(
        name,
        links,
        _topological(joints, roots[0], source),
        roots[0],
        meshes,
        source,
        inertials,
        colors,
    )
    return robot


def _topological(joints: list[JointInfo], root: str, source: str) -> list[JointInfo]:
    """Joints in depth-first order from the root, children in file order (as pinocchio does).

    Each link has one parent and there is one root, so a loop can only sit in a part that is not
    connected to the root: the count check below catches it.
    """
    by_parent: dict[str, list[JointInfo]] = {}
    for j in joints:
        by_parent.setdefault(j.parent, []).append(j)
    order: list[JointInfo] = []
    stack = list(reversed(by_parent.get(root, [])))
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(by_parent.get(j.child, [])))
    if len(order) != len(joints):
        raise ModelError(f"{source}: some joints are not connected to the root link {root!r}")
    return order


def load_urdf(path: str | Path) -> UrdfRobot:
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"URDF file not found: {str(p)!r}")
    return parse_urdf(p.read_text(), str(p))


def resolve_mesh_path(filename: str, urdf_dir: Path, package_dirs: list[Path]) -> Path | None:
    """The file a URDF mesh reference names: ``package://pkg/rel`` is looked up as ``pkg/rel`` and
    as ``rel`` under each package dir (and the URDF's folder); ``file://`` and relative paths
    resolve against the URDF's folder. None if no file exists."""
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        tail = rest.split("/", 1)[1] if "/" in rest else rest
        for d in [*package_dirs, urdf_dir]:
            for cand in (d / rest, d / tail, d.parent / rest):
                if cand.is_file():
                    return cand
        return None
    if filename.startswith("file://"):
        filename = filename[len("file://") :]
    p = Path(filename)
    p = p if p.is_absolute() else urdf_dir / p
    return p if p.is_file() else None
