"""The robot model: a URDF (+ SRDF, + joint_limits.yaml) loaded once into the forms planning needs.

- the kinematic tree as flat arrays (:class:`KinematicTree`) that the compiled kernels of
  :mod:`robocell.kinematics` and :mod:`robocell.scene` read;
- planning groups (:class:`JointGroup`) with joint order, limits, base and tip links, named states;
- the collision geometry of every link, and pinocchio's model and geometry model for the exact
  collision checks (coal).

Variables: every non-fixed, non-mimic URDF joint is one variable of the robot's state vector, in
the URDF's depth-first joint order. Mimic joints follow their master (value = m·q + offset).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from robocell.errors import ModelError, choices, floats, unknown
from robocell.geometry.pose import invert_transform
from robocell.geometry.shapes import Box, Cylinder, Mesh, Shape, Sphere, bvh_arrays
from robocell.robot.srdf import EndEffectorSpec, Srdf, load_srdf, parse_srdf
from robocell.robot.urdf import UrdfRobot, load_urdf, parse_urdf, resolve_mesh_path

ASSETS = Path(__file__).resolve().parent.parent / "assets" / "robots"

FIXED, REVOLUTE, PRISMATIC = 0, 1, 2


@dataclass
class KinematicTree:
    """The URDF tree as arrays, joints in depth-first order (parents before children).

    For joint j: ``T_world_child = T_world_parent @ origin[j] @ motion(type[j], axis[j], value)``
    with ``value = mult[j] * q[var[j]] + offset[j]`` (var = −1 for fixed joints). The root link's
    pose is the identity: poses are in the robot's root frame.
    """

    link_names: list[str]
    parent_link: NDArray[np.int64]  # (J,)
    child_link: NDArray[np.int64]  # (J,)
    origin: NDArray[np.float64]  # (J, 4, 4)
    type: NDArray[np.int64]  # (J,)
    axis: NDArray[np.float64]  # (J, 3)
    var: NDArray[np.int64]  # (J,)
    mult: NDArray[np.float64]  # (J,)
    offset: NDArray[np.float64]  # (J,)

    @property
    def n_links(self) -> int:
        return len(self.link_names)

    def joints_to(self, links: list[int]) -> NDArray[np.int64]:
        """Indices of the joints on the paths from the root to ``links``, in tree order."""
        by_child = {int(c): j for j, c in enumerate(self.child_link)}
        needed: set[int] = set()
        for lk in links:
            while lk in by_child:
                j = by_child[lk]
                if j in needed:
                    break
                needed.add(j)
                lk = int(self.parent_link[j])
        return np.array(sorted(needed), dtype=np.int64)

    def rigid_root(self, link: int) -> int:
        """The link that ``link`` is welded to: up through fixed joints (var = −1) to the
        child of the first moving joint (or the root)."""
        by_child = {int(c): j for j, c in enumerate(self.child_link)}
        while link in by_child and self.var[by_child[link]] < 0:
            link = int(self.parent_link[by_child[link]])
        return link


@dataclass
class LinkGeometry:
    """One collision shape of a link, at ``T_link_shape`` in the link's frame."""

    link: str
    shape: Shape
    T_link_shape: NDArray[np.float64]


@dataclass
class EndEffector:
    name: str
    parent_link: str
    group: str
    parent_group: str | None


@dataclass
class JointGroup:
    """A planning group: an ordered set of robot variables (MoveIt's JointModelGroup).

    ``indices`` map the group's joint vector into the robot's full state vector. ``base_link`` and
    ``tip_link`` are set for chains (and for groups whose joints form one serial chain).
    Limits are per joint, in [rad] or [m] and per second (…², …³).
    """

    name: str
    joint_names: list[str]
    indices: NDArray[np.int64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    jerk: NDArray[np.float64]
    continuous: NDArray[np.bool_]
    base_link: str
    tip_link: str
    link_names: list[str]
    default_positions: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    named_states: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    robot: RobotModel | None = field(default=None, repr=False)

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def __post_init__(self) -> None:
        # Where the group's joints sit in a full variable vector: a slice when they are
        # contiguous (cheaper to write through than an index array), else the indices.
        idx = self.indices
        self._dof = len(self.joint_names)
        self.positions: slice | NDArray[np.int64] = idx
        if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
            self.positions = slice(int(idx[0]), int(idx[0]) + len(idx))

    def __repr__(self) -> str:
        return (
            f"JointGroup({self.name!r}, joints={self.joint_names}, "
            f"base={self.base_link!r}, tip={self.tip_link!r})"
        )

    def named(self, name: str) -> NDArray[np.float64]:
        """The joint values of a named state of this group (from the SRDF's group_state)."""
        if not isinstance(name, str) or name not in self.named_states:
            raise ModelError(
                f"unknown named state {name!r} of group {self.name!r}; "
                f"known: {choices(self.named_states)}"
            )
        return self.named_states[name].copy()

    def as_joint_vector(self, q: ArrayLike, name: str = "joint values") -> NDArray[np.float64]:
        """``q`` as a (dof,) float array, or a :class:`ModelError` naming the problem."""
        if type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (self._dof,):
            if math.isfinite(sum(q.tolist())):  # fast path: a NaN or an infinity poisons the sum
                return q
        arr = floats(q, f"{name} for group {self.name!r}", ModelError)
        if arr.shape != (self.dof,):
            raise ModelError(
                f"{name} for group {self.name!r} must have {self.dof} entries "
                f"({', '.join(self.joint_names)}), got shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise ModelError(f"{name} for group {self.name!r} contain NaN or infinity: {arr}")
        return arr

    def as_joint_batch(self, qs: ArrayLike, name: str = "configurations") -> NDArray[np.float64]:
        """``qs`` as an (N, dof) C-contiguous float array (a single (dof,) vector gives N = 1)."""
        if type(qs) is np.ndarray and qs.dtype == np.float64 and qs.flags.c_contiguous:
            # fast paths: a NaN or an infinity poisons the sum (a finite sum proves all finite)
            if qs.ndim == 2 and qs.shape[1] == self._dof:
                if math.isfinite(float(qs.sum())):
                    return qs
            elif qs.shape == (self._dof,) and math.isfinite(sum(qs.tolist())):
                # one configuration (a plan's start and goal checks: the general path below
                # cost 10 µs of Python, measured)
                return qs.reshape(1, self._dof)
        arr = floats(qs, f"{name} for group {self.name!r}", ModelError)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.dof:
            raise ModelError(
                f"{name} for group {self.name!r} must be (N, {self.dof}), got shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise ModelError(f"{name} for group {self.name!r} contain NaN or infinity")
        return np.ascontiguousarray(arr)

    def within_limits(self, q: ArrayLike, tol: float = 1e-9) -> NDArray[np.bool_]:
        """(N,) or scalar: whether each configuration lies within the joint limits."""
        arr = np.asarray(q, dtype=float)
        ok = (arr >= self.lower - tol) & (arr <= self.upper + tol)
        return np.all(ok, axis=-1)

    def limit_violations(self, q: ArrayLike, tol: float = 1e-9) -> list[str]:
        """Human-readable list of the joints of ``q`` outside their limits."""
        values = self.as_joint_vector(q).tolist()
        # Python floats: each index into the arrays makes a numpy scalar
        lower, upper = self.lower.tolist(), self.upper.tolist()
        out = []
        for i, name in enumerate(self.joint_names):
            if not lower[i] - tol <= values[i] <= upper[i] + tol:
                out.append(f"{name}={values[i]:.4f} not in [{lower[i]:.4f}, {upper[i]:.4f}]")
        return out

    def random(self, rng: np.random.Generator, n: int | None = None) -> NDArray[np.float64]:
        """Uniform configurations within limits: (dof,) or (n, dof)."""
        size = (self.dof,) if n is None else (n, self.dof)
        return rng.uniform(self.lower, self.upper, size=size)


class RobotModel:
    """A robot: kinematic tree, planning groups, limits, collision geometry.

    Build with :meth:`from_urdf` or :meth:`load` (a bundled robot by name).
    """

    def __init__(
        self,
        urdf: UrdfRobot,
        srdf: Srdf | None,
        joint_limits: dict[str, Any] | None,
        urdf_text: str,
        kinematics_config: dict[str, Any] | None = None,
    ) -> None:
        self.urdf = urdf
        self.srdf = srdf if srdf is not None else Srdf()
        self.name = self.srdf.name or urdf.name
        self.source = urdf.source
        self.kinematics_config: dict[str, Any] = kinematics_config or {}
        self.link_names: list[str] = list(urdf.links)
        self.root_link = urdf.root
        self._link_index = {n: i for i, n in enumerate(self.link_names)}
        passive = set(self.srdf.passive_joints)
        for pj in passive:
            urdf.joint(pj)  # raises for an unknown passive joint

        # variables: active (non-fixed, non-mimic) joints in tree order
        self.variable_names: list[str] = [
            j.name for j in urdf.joints if j.type != "fixed" and j.mimic is None
        ]
        self._var_index = {n: i for i, n in enumerate(self.variable_names)}
        nv = len(self.variable_names)
        self.lower = np.full(nv, -math.inf)
        self.upper = np.full(nv, math.inf)
        self.velocity_limits = np.full(nv, math.inf)
        self.acceleration_limits = np.full(nv, math.inf)
        self.jerk_limits = np.full(nv, math.inf)
        self.continuous = np.zeros(nv, dtype=bool)
        self.passive = np.array([n in passive for n in self.variable_names], dtype=bool)
        for j in urdf.joints:
            if j.name in self._var_index:
                i = self._var_index[j.name]
                if j.type == "continuous":
                    self.lower[i], self.upper[i] = -math.pi, math.pi
                    self.continuous[i] = True
                else:
                    self.lower[i], self.upper[i] = j.lower, j.upper
                self.velocity_limits[i] = j.velocity
        if joint_limits:
            self._apply_joint_limits(joint_limits)

        self.tree = self._build_tree()
        self.default_positions = np.clip(np.zeros(nv), self.lower, self.upper)
        self._pin_setup(urdf_text)
        self.disabled_collisions = self._disabled_pairs()
        self.groups: dict[str, JointGroup] = {}
        for spec in self.srdf.groups:
            self.groups[spec.name] = self._resolve_group(spec.name, set())
        self.end_effectors: dict[str, EndEffector] = {}
        for ee in self.srdf.end_effectors:
            self._add_end_effector(ee)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_urdf(
        cls,
        urdf: str | Path,
        srdf: str | Path | None = None,
        joint_limits: str | Path | dict[str, Any] | None = None,
        package_dirs: list[str | Path] | tuple[str | Path, ...] = (),
        kinematics: str | Path | dict[str, Any] | None = None,
    ) -> RobotModel:
        """Load a robot from a URDF file (and optionally an SRDF file and a MoveIt
        joint_limits.yaml). Meshes named ``package://pkg/path`` or by relative path resolve
        against ``package_dirs`` and the URDF's folder. XML text may be passed instead of a path.
        """
        if not isinstance(urdf, str | Path):
            raise ModelError(f"a URDF is a file's path or its XML text, got {urdf!r}")
        if isinstance(urdf, str) and urdf.lstrip().startswith("<"):
            text, robot, urdf_dir = urdf, parse_urdf(urdf), Path.cwd()
        else:
            robot = load_urdf(urdf)
            text, urdf_dir = Path(urdf).read_text(), Path(urdf).resolve().parent
        srdf_obj = None
        if srdf is not None:
            if isinstance(srdf, str) and srdf.lstrip().startswith("<"):
                srdf_obj = parse_srdf(srdf)
            else:
                srdf_obj = load_srdf(srdf)
        limits = _load_yaml_arg(joint_limits, "joint limits")
        kin = _load_yaml_arg(kinematics, "kinematics")
        dirs = [Path(d).resolve() for d in package_dirs]
        text = _absolute_mesh_paths(robot, text, urdf_dir, dirs)
        return cls(robot, srdf_obj, limits, text, kin)

    @classmethod
    def load(cls, name: str) -> RobotModel:
        """A bundled robot by name (see :func:`bundled_robots`)."""
        folder = ASSETS / name
        if not (folder / f"{name}.urdf").is_file():
            raise ModelError(unknown("bundled robot", name, bundled_robots()))
        srdf = folder / f"{name}.srdf"
        limits = folder / "joint_limits.yaml"
        kin = folder / "kinematics.yaml"
        return cls.from_urdf(
            folder / f"{name}.urdf",
            srdf if srdf.is_file() else None,
            limits if limits.is_file() else None,
            package_dirs=[folder],
            kinematics=kin if kin.is_file() else None,
        )

    def _apply_joint_limits(self, data: dict[str, Any]) -> None:
        entries = data.get("joint_limits", data)
        if not isinstance(entries, dict):
            raise ModelError("joint limits: expected a mapping 'joint_limits: {joint: {...}}'")
        for jname, spec in entries.items():
            if jname not in self._var_index:
                raise ModelError("joint limits: " + unknown("joint", jname, self.variable_names))
            i = self._var_index[jname]
            spec = spec or {}
            for key, arr in (
                ("velocity", self.velocity_limits),
                ("acceleration", self.acceleration_limits),
                ("jerk", self.jerk_limits),
            ):
                if spec.get(f"has_{key}_limits", f"max_{key}" in spec) and f"max_{key}" in spec:
                    value = float(spec[f"max_{key}"])
                    if not value > 0:
                        raise ModelError(
                            f"joint limits: {jname} max_{key} must be > 0, got {value}"
                        )
                    arr[i] = value
            if spec.get("has_position_limits"):
                self.lower[i] = float(spec.get("min_position", self.lower[i]))
                self.upper[i] = float(spec.get("max_position", self.upper[i]))

    def _build_tree(self) -> KinematicTree:
        joints = self.urdf.joints
        J = len(joints)
        tree = KinematicTree(
            link_names=self.link_names,
            parent_link=np.array([self._link_index[j.parent] for j in joints], dtype=np.int64),
            child_link=np.array([self._link_index[j.child] for j in joints], dtype=np.int64),
            origin=np.array([j.origin for j in joints]).reshape(J, 4, 4),
            type=np.zeros(J, dtype=np.int64),
            axis=np.array([j.axis for j in joints]).reshape(J, 3),
            var=np.full(J, -1, dtype=np.int64),
            mult=np.ones(J),
            offset=np.zeros(J),
        )
        for k, j in enumerate(joints):
            if j.type == "fixed":
                continue
            tree.type[k] = PRISMATIC if j.type == "prismatic" else REVOLUTE
            if j.mimic is None:
                tree.var[k] = self._var_index[j.name]
            else:
                master, mult, off = j.mimic
                chain = [j.name]
                while self.urdf.joint(master).mimic is not None:  # mimic of a mimic
                    if master in chain:
                        raise ModelError(f"{self.source}: mimic loop through joint {master!r}")
                    chain.append(master)
                    m2, mult2, off2 = self.urdf.joint(master).mimic  # type: ignore[misc]
                    master, mult, off = m2, mult * mult2, mult * off2 + off
                if master not in self._var_index:
                    raise ModelError(f"{self.source}: joint {j.name!r} mimics a fixed joint")
                tree.var[k], tree.mult[k], tree.offset[k] = self._var_index[master], mult, off
        return tree

    def _pin_setup(self, text: str) -> None:
        import pinocchio as pin

        try:
            self.pin_model = pin.buildModelFromXML(text)
            # mesh paths are absolute by now (see _absolute_mesh_paths)
            self.pin_collision_model = pin.buildGeomFromUrdfString(
                self.pin_model, text, pin.GeometryType.COLLISION
            )
        except (RuntimeError, ValueError) as exc:
            raise ModelError(f"{self.source}: pinocchio could not load the robot: {exc}") from exc
        # Our variables → pinocchio's q vector (pinocchio keeps mimic joints as joints of their
        # own; continuous joints take (cos, sin)).
        rows = []
        by_name = {j.name: k for k, j in enumerate(self.urdf.joints)}
        for jid in range(1, self.pin_model.njoints):
            jm = self.pin_model.joints[jid]
            k = by_name[self.pin_model.names[jid]]
            rows.append(
                (jm.idx_q, jm.nq, int(self.tree.var[k]), self.tree.mult[k], self.tree.offset[k])
            )
        self._pin_rows = rows
        self.pin_nq = self.pin_model.nq

        # collision geometry per link, in the link's frame
        self.collision_geometry: list[LinkGeometry] = []
        for g in self.pin_collision_model.geometryObjects:
            frame = self.pin_model.frames[g.parentFrame]
            link = frame.name
            if link not in self._link_index:
                raise ModelError(
                    f"{self.source}: geometry {g.name!r} hangs on unknown frame {link!r}"
                )
            T_joint_link = frame.placement.homogeneous
            T_link_shape = invert_transform(T_joint_link) @ g.placement.homogeneous
            shape = _shape_of(g.geometry, g.meshPath, np.asarray(g.meshScale))
            self.collision_geometry.append(LinkGeometry(link, shape, T_link_shape))

    def _disabled_pairs(self) -> set[frozenset[str]]:
        pairs: set[frozenset[str]] = set()
        for a, b, _ in self.srdf.disabled_collisions:
            for lk in (a, b):
                self.link_index(lk, "disable_collisions")
            pairs.add(frozenset((a, b)))
        for lk in self.srdf.disabled_default:
            self.link_index(lk, "disable_default_collisions")
            for other in self.link_names:
                if other != lk:
                    pairs.add(frozenset((lk, other)))
        for a, b in self.srdf.enabled_collisions:
            pairs.discard(frozenset((a, b)))
        return pairs

    def _resolve_group(self, name: str, visiting: set[str]) -> JointGroup:
        specs = {g.name: g for g in self.srdf.groups}
        spec = specs[name]
        if name in visiting:
            raise ModelError(f"{self.srdf.source}: group {name!r} contains itself")
        visiting = visiting | {name}
        joint_names: set[str] = set()
        by_child = {j.child: j for j in self.urdf.joints}
        base, tip = "", ""
        for b, t in spec.chains:
            self.link_index(b, f"group {name!r} chain base_link")
            self.link_index(t, f"group {name!r} chain tip_link")
            path = []
            lk = t
            while lk != b:
                if lk not in by_child:
                    raise ModelError(
                        f"{self.srdf.source}: group {name!r}: link {t!r} is not below {b!r}"
                    )
                path.append(by_child[lk].name)
                lk = by_child[lk].parent
            joint_names.update(path)
            base, tip = b, t
        for jn in spec.joints:
            self.urdf.joint(jn)
            joint_names.add(jn)
        for ln in spec.links:
            self.link_index(ln, f"group {name!r} link")
            if ln in by_child:
                joint_names.add(by_child[ln].name)
        for sub in spec.subgroups:
            if sub not in specs:
                raise ModelError(f"group {name!r}: " + unknown("subgroup", sub, specs))
            joint_names.update(self._resolve_group(sub, visiting).joint_names)
        passive = set(self.srdf.passive_joints)
        active = [v for v in self.variable_names if v in joint_names and v not in passive]
        idx = np.array([self._var_index[v] for v in active], dtype=np.int64)
        if not base:
            base, tip = self._chain_ends(active)
        # links moved by the group: children of its joints (mimics included) and below
        moved: list[str] = []
        group_vars = set(idx.tolist())
        moving = set()
        for k, j in enumerate(self.urdf.joints):
            if int(self.tree.var[k]) in group_vars or j.parent in moving:
                moving.add(j.child)
                moved.append(j.child)
        group = JointGroup(
            name=name,
            joint_names=active,
            indices=idx,
            lower=self.lower[idx].copy(),
            upper=self.upper[idx].copy(),
            velocity=self.velocity_limits[idx].copy(),
            acceleration=self.acceleration_limits[idx].copy(),
            jerk=self.jerk_limits[idx].copy(),
            continuous=self.continuous[idx].copy(),
            base_link=base,
            tip_link=tip,
            link_names=moved,
            default_positions=self.default_positions[idx].copy(),
            robot=self,
        )
        for sname, values in self.srdf.group_states.get(name, {}).items():
            q = self.default_positions[idx].copy()
            for jn, v in values.items():
                if jn in active:
                    q[active.index(jn)] = v
                elif jn not in [j.name for j in self.urdf.joints]:
                    raise ModelError(
                        f"group_state {sname!r} of group {name!r}: " + unknown("joint", jn, active)
                    )
            group.named_states[sname] = q
        return group

    def _chain_ends(self, active: list[str]) -> tuple[str, str]:
        """Base and tip links of a joint list that forms one serial chain ('' if it does not)."""
        if not active:
            return "", ""
        first, last = self.urdf.joint(active[0]), self.urdf.joint(active[-1])
        tip = last.child
        by_parent: dict[str, list[str]] = {}
        for j in self.urdf.joints:
            by_parent.setdefault(j.parent, []).append(j.child)
        while len(by_parent.get(tip, [])) == 1:  # follow fixed single children (tool flanges)
            nxt = by_parent[tip][0]
            j = next(j for j in self.urdf.joints if j.child == nxt)
            if j.type != "fixed":
                break
            tip = nxt
        return first.parent, tip

    def _add_end_effector(self, ee: EndEffectorSpec) -> None:
        self.link_index(ee.parent_link, f"end_effector {ee.name!r} parent_link")
        if ee.group not in self.groups:
            raise ModelError(
                f"end_effector {ee.name!r}: " + unknown("group", ee.group, self.groups)
            )
        self.end_effectors[ee.name] = EndEffector(
            ee.name, ee.parent_link, ee.group, ee.parent_group
        )

    # ------------------------------------------------------------------ queries
    @property
    def n_variables(self) -> int:
        return len(self.variable_names)

    @property
    def group_names(self) -> list[str]:
        return list(self.groups)

    def group(self, name: str) -> JointGroup:
        """The planning group ``name`` (MoveIt's getJointModelGroup)."""
        if not isinstance(name, str) or name not in self.groups:
            raise ModelError(unknown("group", name, self.groups))
        return self.groups[name]

    def link_index(self, name: str, context: str = "") -> int:
        if not isinstance(name, str) or name not in self._link_index:
            prefix = f"{context}: " if context else ""
            raise ModelError(prefix + unknown("link", name, self.link_names))
        return self._link_index[name]

    def variable_index(self, name: str) -> int:
        if not isinstance(name, str) or name not in self._var_index:
            raise ModelError(unknown("joint", name, self.variable_names))
        return self._var_index[name]

    def full_positions(
        self, group: JointGroup, q: ArrayLike, base: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """The robot's full variable vector with the group's joints set to ``q``."""
        full = (self.default_positions if base is None else np.asarray(base, dtype=float)).copy()
        full[group.positions] = group.as_joint_vector(q)
        return full

    def pin_configurations(self, full: ArrayLike) -> NDArray[np.float64]:
        """Pinocchio q vectors (N, pin_nq) of full variable vectors (N, n_variables)."""
        arr = np.atleast_2d(np.asarray(full, dtype=float))
        out = np.zeros((arr.shape[0], self.pin_nq))
        for idx_q, nq, var, mult, off in self._pin_rows:
            value = mult * arr[:, var] + off if var >= 0 else np.zeros(arr.shape[0])
            if nq == 1:
                out[:, idx_q] = value
            else:  # continuous joint: (cos, sin)
                out[:, idx_q], out[:, idx_q + 1] = np.cos(value), np.sin(value)
        return out

    def default_state(self) -> RobotState:
        return RobotState(self, self.default_positions.copy())

    def __repr__(self) -> str:
        return (
            f"RobotModel({self.name!r}, {self.n_variables} variables, "
            f"groups: {', '.join(self.groups) or '(none)'})"
        )


class RobotState:
    """The positions of all of a robot's variables (MoveIt's RobotState, positions only)."""

    def __init__(self, robot: RobotModel, positions: ArrayLike | None = None) -> None:
        self.robot = robot
        pos = robot.default_positions.copy() if positions is None else np.array(positions, float)
        if pos.shape != (robot.n_variables,):
            raise ModelError(
                f"a state of {robot.name!r} has {robot.n_variables} positions "
                f"({', '.join(robot.variable_names)}), got shape {pos.shape}"
            )
        self.positions = pos

    def group_positions(self, group: str | JointGroup) -> NDArray[np.float64]:
        g = group if isinstance(group, JointGroup) else self.robot.group(group)
        return self.positions[g.indices].copy()

    def set_group_positions(self, group: str | JointGroup, q: ArrayLike) -> None:
        g = group if isinstance(group, JointGroup) else self.robot.group(group)
        self.positions[g.indices] = g.as_joint_vector(q)

    def set_named(self, group: str, name: str) -> None:
        g = self.robot.group(group)
        self.positions[g.indices] = g.named(name)

    def copy(self) -> RobotState:
        return RobotState(self.robot, self.positions.copy())

    def as_dict(self) -> dict[str, float]:
        return dict(zip(self.robot.variable_names, self.positions.tolist(), strict=True))

    def __repr__(self) -> str:
        vals = ", ".join(f"{n}={v:.4g}" for n, v in self.as_dict().items())
        return f"RobotState({vals})"


def bundled_robots() -> list[str]:
    """Names of the robots shipped as package data."""
    return sorted(p.name for p in ASSETS.iterdir() if (p / f"{p.name}.urdf").is_file())


def _load_yaml_arg(value: str | Path | dict[str, Any] | None, what: str) -> dict[str, Any] | None:
    if value is None or isinstance(value, dict):
        return value
    p = Path(value)
    if not p.is_file():
        raise ModelError(f"{what} file not found: {str(p)!r}")
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise ModelError(f"{p}: not valid YAML: {exc}") from exc
    if not isinstance(data, dict):
        raise ModelError(f"{p}: expected a mapping at the top level")
    return data


def _absolute_mesh_paths(robot: UrdfRobot, text: str, urdf_dir: Path, dirs: list[Path]) -> str:
    """Check that every mesh exists and rewrite its filename to an absolute path."""
    for mesh in robot.meshes:
        path = resolve_mesh_path(mesh.filename, urdf_dir, dirs)
        if path is None:
            searched = ", ".join(str(d) for d in [*dirs, urdf_dir])
            raise ModelError(
                f"{robot.source}: link {mesh.link!r} {mesh.kind} mesh {mesh.filename!r} not found "
                f"(searched: {searched})"
            )
        text = re.sub(
            r'filename\s*=\s*"' + re.escape(mesh.filename) + '"', f'filename="{path}"', text
        )
    return text


def _shape_of(geom: Any, mesh_path: str, scale: np.ndarray) -> Shape:
    import coal

    if isinstance(geom, coal.Box):
        return Box(tuple(2.0 * np.asarray(geom.halfSide)))  # type: ignore[arg-type]
    if isinstance(geom, coal.Cylinder):
        return Cylinder(geom.radius, 2.0 * geom.halfLength)
    if isinstance(geom, coal.Sphere):
        return Sphere(geom.radius)
    if isinstance(geom, coal.BVHModelBase):
        verts, tris = bvh_arrays(geom)
        return Mesh(verts, tris, mesh_path, tuple(float(s) for s in scale))  # type: ignore[arg-type]
    raise ModelError(f"unsupported collision geometry {type(geom).__name__} ({mesh_path})")
