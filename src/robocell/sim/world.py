"""The physics world: a MuJoCo model generated from the robot description (URDF, SRDF) and a
cell's fixtures, objects and cameras — no second hand-written copy of any geometry.

Robot joints are driven by position servos (stiffness and damping per joint) whose reference
and feed-forward torque the controllers set every physics step; gravity is compensated as a
real controller does. Objects are free bodies held by friction alone (elliptic friction cones,
torsional friction, no welding). The world frame is the cell's (floor, z up).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from robocell.errors import SimulationError, choices
from robocell.geometry.pose import Pose
from robocell.geometry.shapes import Box, Cylinder, Mesh, Shape, Sphere
from robocell.robot.model import JointGroup, RobotModel

ROBOT_CONTYPE, ROBOT_CONAFFINITY = 1, 2  # robot touches world and objects, not itself
WORLD_CONTYPE, WORLD_CONAFFINITY = 2, 3


@dataclass(frozen=True)
class FixtureGeom:
    """A static shape of the world at ``pose`` (world frame)."""

    name: str
    shape: Shape
    pose: Pose
    color: tuple[float, float, float, float]
    friction: float = 1.0


@dataclass(frozen=True)
class FreeObject:
    """A free body: one shape, mass [kg], friction coefficient, colour."""

    name: str
    shape: Shape
    pose: Pose
    mass: float
    friction: float
    color: tuple[float, float, float, float]


@dataclass(frozen=True)
class Camera:
    name: str
    position: tuple[float, float, float]
    look_at: tuple[float, float, float]
    fovy: float = 45.0
    width: int = 640
    height: int = 480


@dataclass
class ServoGains:
    """Joint servo: stiffness [N m/rad], damping [N m s/rad], rotor inertia [kg m²]."""

    kp: float
    kv: float
    armature: float


def _quat_wxyz(p: Pose) -> list[float]:
    x, y, z, w = p.orientation
    return [float(w), float(x), float(y), float(z)]


def _look_at_quat(position: NDArray[np.float64], target: NDArray[np.float64]) -> list[float]:
    """MuJoCo camera orientation (w, x, y, z): it looks along its −z, y up."""
    fwd = target - position
    fwd = fwd / np.linalg.norm(fwd)
    z = -fwd
    up = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.99 else np.array([0.0, 1.0, 0.0])
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.column_stack([x, y, z]).ravel())
    return q.tolist()


def _add_shape(
    body: mujoco.MjsBody,
    spec: mujoco.MjSpec,
    name: str,
    shape: Shape,
    pose: Pose,
    rgba: tuple[float, float, float, float],
    contype: int,
    conaffinity: int,
    friction: float,
    timestep: float,
) -> mujoco.MjsGeom:
    g = body.add_geom()
    g.name = name
    g.pos = pose.position.tolist()
    g.quat = _quat_wxyz(pose)
    g.rgba = list(rgba)
    g.contype, g.conaffinity = contype, conaffinity
    g.friction = [friction, 0.005, 0.0001]
    g.condim = 4
    # stiff contacts (time constant of two physics steps): MuJoCo's default (0.02 s) lets a
    # squeezed object creep out of the fingers under a fraction of its friction limit
    g.solref = [2 * timestep, 1.0]
    if isinstance(shape, Box):
        g.type = mujoco.mjtGeom.mjGEOM_BOX
        g.size = [0.5 * s for s in shape.size]
    elif isinstance(shape, Cylinder):
        g.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        g.size = [shape.radius, 0.5 * shape.length, 0.0]
    elif isinstance(shape, Sphere):
        g.type = mujoco.mjtGeom.mjGEOM_SPHERE
        g.size = [shape.radius, 0.0, 0.0]
    elif isinstance(shape, Mesh):
        m = spec.add_mesh()
        m.name = f"{name}_mesh"
        m.uservert = shape.vertices.ravel().tolist()
        m.userface = shape.triangles.ravel().tolist()
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = m.name
    else:  # pragma: no cover - shapes are validated upstream
        raise SimulationError(f"cannot simulate shape {shape!r}")
    return g


class World:
    """A MuJoCo world with one robot, static fixtures, free objects and cameras.

    ``timestep`` [s] of the physics; the controllers update the servo references every step.
    Access is guarded by ``lock`` (the execution thread steps while user code reads poses).
    """

    def __init__(
        self,
        robot: RobotModel,
        robot_pose: Pose,
        fixtures: list[FixtureGeom],
        objects: list[FreeObject],
        cameras: list[Camera] | None = None,
        timestep: float = 0.002,
        gains: dict[str, ServoGains] | None = None,
        gripper_force: float = 40.0,
    ) -> None:
        self.robot = robot
        self.robot_pose = robot_pose
        self.timestep = timestep
        self.lock = threading.RLock()
        self._objects = {o.name: o for o in objects}
        self._initial = {o.name: o.pose for o in objects}
        self.cameras = {c.name: c for c in cameras or []}
        spec = mujoco.MjSpec()
        spec.modelname = "robocell"
        spec.option.timestep = timestep
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = 10.0
        spec.option.noslip_iterations = 0  # stiff contacts hold without it (measured), faster
        # objects at rest sleep (and wake when touched): resting objects cost nothing, which
        # doubles the real-time factor of the sorting cell (measured)
        spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        spec.compiler.autolimits = True
        spec.compiler.degree = False  # joint ranges in radians
        wb = spec.worldbody
        floor = wb.add_geom()
        floor.name = "floor"
        floor.type = mujoco.mjtGeom.mjGEOM_PLANE
        floor.size = [5.0, 5.0, 0.1]
        floor.rgba = [0.8, 0.8, 0.8, 1.0]
        floor.contype, floor.conaffinity = WORLD_CONTYPE, WORLD_CONAFFINITY
        light = wb.add_light()
        light.pos = [0.0, 0.0, 3.0]
        light.dir = [0.0, 0.0, -1.0]
        self.fixture_names = sorted({f.name for f in fixtures})
        fixture_bodies: dict[str, mujoco.MjsBody] = {}
        for k, f in enumerate(fixtures):
            if f.name not in fixture_bodies:  # a static body per fixture (no joint)
                fb = wb.add_body()
                fb.name = f.name
                fixture_bodies[f.name] = fb
            _add_shape(fixture_bodies[f.name], spec, f"{f.name}#{k}", f.shape, f.pose, f.color,
                       WORLD_CONTYPE, WORLD_CONAFFINITY, f.friction, timestep)  # fmt: skip
        for o in objects:
            b = wb.add_body()
            b.name = o.name
            b.pos = o.pose.position.tolist()
            b.quat = _quat_wxyz(o.pose)
            b.add_freejoint()
            g = _add_shape(b, spec, o.name, o.shape, Pose(), o.color,
                           WORLD_CONTYPE, WORLD_CONAFFINITY, o.friction, timestep)  # fmt: skip
            g.mass = o.mass
        for c in self.cameras.values():
            cam = wb.add_camera()
            cam.name = c.name
            cam.pos = list(c.position)
            cam.quat = _look_at_quat(np.array(c.position), np.array(c.look_at))
            cam.fovy = c.fovy
        self._build_robot(spec, gains or {}, gripper_force)
        try:
            self.model = spec.compile()
            # the robot stands on what it touches at its default state (its pedestal): those
            # contacts are excluded, as the SRDF's "adjacent" pairs are for the planner
            self.mounted = self._touching_at_default()
            for link_body, fixture in self.mounted:
                ex = spec.add_exclude()
                ex.bodyname1, ex.bodyname2 = link_body, fixture
            if self.mounted:
                self.model = spec.compile()
        except ValueError as exc:
            raise SimulationError(f"MuJoCo could not compile the world: {exc}") from exc
        self.data = mujoco.MjData(self.model)
        self.spec = spec
        m = self.model
        self._obj_qpos = {n: int(m.jnt_qposadr[m.body_jntadr[m.body(n).id]]) for n in self._objects}
        self._obj_qvel = {n: int(m.jnt_dofadr[m.body_jntadr[m.body(n).id]]) for n in self._objects}
        self._jnt_qpos = {n: int(m.jnt_qposadr[m.joint(n).id]) for n in self._sim_joints}
        self._jnt_dof = {n: int(m.jnt_dofadr[m.joint(n).id]) for n in self._sim_joints}
        self._jnt_qpos_by_dof = {self._jnt_dof[n]: self._jnt_qpos[n] for n in self._sim_joints}
        self._act = {n: int(m.actuator(f"servo_{n}").id) for n in self._actuated}
        self._body_owner = {}
        for b in range(m.nbody):
            name = m.body(b).name
            self._body_owner[b] = name
        self.reset()

    # ------------------------------------------------------------------ building
    def _touching_at_default(self) -> list[tuple[str, str]]:
        m = self.model
        d = mujoco.MjData(m)
        full = self.robot.default_positions
        for name in self._sim_joints:
            d.qpos[m.jnt_qposadr[m.joint(name).id]] = self._joint_value_from_variables(name, full)
        mujoco.mj_forward(m, d)
        pairs = set()
        for k in range(d.ncon):
            c = d.contact[k]
            b1 = m.body(int(m.geom_bodyid[c.geom1])).name
            b2 = m.body(int(m.geom_bodyid[c.geom2])).name
            for a, b in ((b1, b2), (b2, b1)):
                if a.startswith("robot/") and b in self.fixture_names:
                    pairs.add((a, b))
        return sorted(pairs)

    def _build_robot(
        self, spec: mujoco.MjSpec, gains: dict[str, ServoGains], grip_f: float
    ) -> None:
        robot = self.robot
        urdf = robot.urdf
        geoms: dict[str, list[tuple[Shape, NDArray[np.float64]]]] = {}
        for lg in robot.collision_geometry:
            geoms.setdefault(lg.link, []).append((lg.shape, lg.T_link_shape))
        by_child = {j.child: j for j in urdf.joints}
        children: dict[str, list[str]] = {}
        for j in urdf.joints:
            children.setdefault(j.parent, []).append(j.child)

        def massless(link: str) -> bool:
            inert = urdf.inertials.get(link)
            return (inert is None or inert.mass <= 0) and link not in geoms

        # a joint whose moving link has no mass and no shape, and that others mimic, is a
        # virtual driver (a gripper's one command): it is not simulated; the first of its
        # followers is driven instead, and the others follow that one
        followers: dict[str, list[str]] = {}
        for j in urdf.joints:
            if j.mimic is not None:
                followers.setdefault(j.mimic[0], []).append(j.name)
        # driver -> [(follower, mult, offset)]
        self._virtual: dict[str, list[tuple[str, float, float]]] = {}
        for j in urdf.joints:
            if (
                j.type != "fixed"
                and j.mimic is None
                and massless(j.child)
                and followers.get(j.name)
            ):
                self._virtual[j.name] = [
                    (f, urdf.joint(f).mimic[1], urdf.joint(f).mimic[2])  # type: ignore[index]
                    for f in followers[j.name]
                ]
        self._sim_joints: list[str] = []
        self._actuated: list[str] = []
        color = urdf.colors
        T_root = self.robot_pose

        def build(
            link: str, parent_body: mujoco.MjsBody, T_parent_link: NDArray[np.float64]
        ) -> None:
            b = parent_body.add_body()
            b.name = f"robot/{link}"
            pose = Pose.from_matrix(T_parent_link)
            b.pos = pose.position.tolist()
            b.quat = _quat_wxyz(pose)
            inert = urdf.inertials.get(link)
            if inert is not None and inert.mass > 0:
                b.explicitinertial = True
                b.mass = inert.mass
                ip = Pose.from_matrix(inert.origin)
                b.ipos = ip.position.tolist()
                I = inert.inertia
                b.fullinertia = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
                b.iquat = _quat_wxyz(ip)
            j = by_child.get(link)
            if j is not None and j.type != "fixed" and j.name not in self._virtual:
                if inert is None or inert.mass <= 0:
                    b.explicitinertial = True
                    b.mass = 1e-3
                    b.inertia = [1e-6, 1e-6, 1e-6]
                jt = b.add_joint()
                jt.name = j.name
                jt.type = (
                    mujoco.mjtJoint.mjJNT_SLIDE
                    if j.type == "prismatic"
                    else mujoco.mjtJoint.mjJNT_HINGE
                )
                jt.axis = j.axis.tolist()
                if j.type != "continuous" and math.isfinite(j.lower):
                    jt.range = [j.lower, j.upper]
                    jt.limited = mujoco.mjtLimited.mjLIMITED_TRUE
                g = gains.get(j.name) or _default_gains(j.type)
                jt.armature = g.armature
                self._sim_joints.append(j.name)
                if j.mimic is None or j.mimic[0] in self._virtual:
                    # each follower of a virtual driver (each finger) gets its own
                    # force-limited servo; a stiff equality (below) keeps the fingers symmetric
                    follower = j.mimic is not None
                    a = spec.add_actuator()
                    a.name = f"servo_{j.name}"
                    a.target = j.name
                    a.trntype = mujoco.mjtTrn.mjTRN_JOINT
                    kp, kv = g.kp, g.kv
                    a.gaintype = mujoco.mjtGain.mjGAIN_FIXED
                    a.gainprm = [kp] + [0.0] * 9
                    a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
                    a.biasprm = [0.0, -kp, -kv] + [0.0] * 7
                    if follower:  # a gripper finger: force-limited
                        a.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
                        a.forcerange = [-grip_f, grip_f]
                    self._actuated.append(j.name)
            b.gravcomp = 1.0  # the robot's controller compensates gravity
            for k, (shape, T) in enumerate(geoms.get(link, [])):
                _add_shape(b, spec, f"robot/{link}#{k}", shape, Pose.from_matrix(T),
                           color.get(link, (0.7, 0.7, 0.7, 1.0)),
                           ROBOT_CONTYPE, ROBOT_CONAFFINITY, 1.0, self.timestep)  # fmt: skip
            for c in children.get(link, []):
                build(c, b, by_child[c].origin)

        build(urdf.root, spec.worldbody, T_root.matrix())
        # mimic couplings: follower = offset + mult × master (or × the lead of a virtual master)
        for j in urdf.joints:
            if j.mimic is None or j.name not in self._sim_joints:
                continue
            master, mult, off = j.mimic
            stiff = False
            if master in self._virtual:
                # fingers have their own servos, and a stiff coupling as a gripper's linkage:
                # without it the two saturated servos let a held object push both sideways
                lead, lmult, loff = self._virtual[master][0]
                if lead == j.name:
                    continue
                bcoef = mult / lmult  # q_j = off + mult·v, q_lead = loff + lmult·v
                acoef = off - bcoef * loff
                master, stiff = lead, True
            else:
                bcoef, acoef = mult, off
            e = spec.add_equality()
            e.type = mujoco.mjtEq.mjEQ_JOINT
            e.name1, e.name2 = j.name, master
            e.data = [acoef, bcoef, 0.0, 0.0, 0.0] + [0.0] * (len(e.data) - 5)
            if stiff:
                e.solref = [2 * self.timestep, 1.0]
                e.solimp = [0.99, 0.999, 0.001, 0.5, 2.0]

    # ------------------------------------------------------------------ state
    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return float(self.data.time)

    def reset(self, poses: dict[str, Pose] | None = None) -> None:
        """Back to the start: robot at its default (home) positions, at rest; objects at
        ``poses`` (default: where they were first placed)."""
        with self.lock:
            mujoco.mj_resetData(self.model, self.data)
            self.set_robot_positions(self.robot.default_positions)
            for name, pose in {**self._initial, **(poses or {})}.items():
                self.set_object_pose(name, pose)
            mujoco.mj_forward(self.model, self.data)

    def set_robot_positions(self, full: NDArray[np.float64]) -> None:
        """Teleport the robot to the full variable vector ``full`` (at rest, servos there)."""
        with self.lock:
            for name in self._sim_joints:
                q = self._joint_value_from_variables(name, full)
                self.data.qpos[self._jnt_qpos[name]] = q
                self.data.qvel[self._jnt_dof[name]] = 0.0
                if name in self._act:
                    self.data.ctrl[self._act[name]] = q
            mujoco.mj_forward(self.model, self.data)

    def _joint_value_from_variables(self, name: str, full: NDArray[np.float64]) -> float:
        r = self.robot
        j = r.urdf.joint(name)
        if j.mimic is not None:
            master, mult, off = j.mimic
            return off + mult * float(full[r.variable_index(master)])
        return float(full[r.variable_index(name)])

    def robot_positions(self) -> NDArray[np.float64]:
        """The robot's full variable vector as the world has it now (virtual drivers from
        their lead joint)."""
        r = self.robot
        full = r.default_positions.copy()
        with self.lock:
            for name in r.variable_names:
                if name in self._virtual:
                    vals = [
                        (self.data.qpos[self._jnt_qpos[f]] - off) / mult
                        for f, mult, off in self._virtual[name]
                    ]
                    full[r.variable_index(name)] = float(np.mean(vals))
                elif name in self._jnt_qpos:
                    full[r.variable_index(name)] = self.data.qpos[self._jnt_qpos[name]]
        return full

    def group_positions(self, group: JointGroup) -> NDArray[np.float64]:
        return self.robot_positions()[group.indices]

    def group_velocities(self, group: JointGroup) -> NDArray[np.float64]:
        out = np.zeros(group.dof)
        with self.lock:
            for i, name in enumerate(group.joint_names):
                if name in self._virtual:
                    v = [self.data.qvel[self._jnt_dof[f]] / m for f, m, _ in self._virtual[name]]
                    out[i] = float(np.mean(v))
                else:
                    out[i] = self.data.qvel[self._jnt_dof[name]]
        return out

    def servo_targets(self, group: JointGroup) -> list[tuple[int, int, int, float, float]]:
        """The servos of a group: (actuator id, dof address, group joint index, scale, offset);
        the reference of a servo is offset + scale × q[index]. A virtual driver (a gripper's
        command) has one servo per finger."""
        out = []
        for i, name in enumerate(group.joint_names):
            if name in self._virtual:
                for f, mult, off in self._virtual[name]:
                    out.append((self._act[f], self._jnt_dof[f], i, mult, off))
            elif name in self._act:
                out.append((self._act[name], self._jnt_dof[name], i, 1.0, 0.0))
            else:
                raise SimulationError(f"joint {name!r} has no servo in the world")
        return out

    # ------------------------------------------------------------------ objects
    @property
    def object_names(self) -> list[str]:
        return sorted(self._objects)

    def _check_object(self, name: str) -> None:
        if name not in self._objects:
            raise SimulationError(f"unknown object {name!r}; known: {choices(self._objects)}")

    def object_pose(self, name: str) -> Pose:
        """Ground-truth pose of an object (world frame)."""
        self._check_object(name)
        with self.lock:
            a = self._obj_qpos[name]
            x, y, z, qw, qx, qy, qz = self.data.qpos[a : a + 7]
        return Pose([x, y, z], [qx, qy, qz, qw])

    def object_poses(self) -> dict[str, Pose]:
        return {n: self.object_pose(n) for n in self._objects}

    def set_object_pose(self, name: str, pose: Pose) -> None:
        """Teleport an object (at rest)."""
        self._check_object(name)
        with self.lock:
            a = self._obj_qpos[name]
            self.data.qpos[a : a + 3] = pose.position
            self.data.qpos[a + 3 : a + 7] = _quat_wxyz(pose)
            d = self._obj_qvel[name]
            self.data.qvel[d : d + 6] = 0.0

    def object_speed(self, name: str) -> float:
        """Linear speed of an object [m/s]."""
        self._check_object(name)
        with self.lock:
            d = self._obj_qvel[name]
            return float(np.linalg.norm(self.data.qvel[d : d + 3]))

    def contacts(self) -> list[tuple[str, str]]:
        """Pairs of things touching now: object names, ``robot/<link>``, fixture names, floor.
        An object asleep at rest (MuJoCo's sleeping islands) reports no contacts; anything
        that touches it wakes it."""
        d = self.data
        out = []
        with self.lock:
            for k in range(d.ncon):
                c = d.contact[k]
                out.append((self._owner(c.geom1), self._owner(c.geom2)))
        return out

    def _owner(self, geom: int) -> str:
        name = self.model.geom(geom).name
        if name.startswith("robot/") or "#" in name:
            return name.split("#")[0]
        b = int(self.model.geom_bodyid[geom])
        return self._body_owner.get(b, name) or name

    def touching(self, name: str) -> set[str]:
        """Names of what touches ``name`` (an object, ``robot/<link>`` or a fixture)."""
        out = set()
        for a, b in self.contacts():
            if a == name:
                out.add(b)
            elif b == name:
                out.add(a)
        return out

    # ------------------------------------------------------------------ stepping
    def step(self, n: int = 1) -> None:
        """Advance the physics by ``n`` steps; divergence resets the world and raises."""
        with self.lock:
            for _ in range(n):
                mujoco.mj_step(self.model, self.data)
            if not self.healthy():
                raise SimulationError(self.diverged())

    def healthy(self) -> bool:
        """No NaN, no exploding velocity (> 1000 rad/s or m/s)."""
        v = self.data.qvel
        return bool(np.all(np.isfinite(self.data.qpos)) and np.all(np.abs(v) < 1e3))

    def diverged(self) -> str:
        """Reset the world after a divergence; the message saying so."""
        t = self.time
        self.reset()
        return (
            f"the simulation diverged at t = {t:.3f} s (NaN or exploding velocities); "
            "the world was reset"
        )

    # ------------------------------------------------------------------ cameras
    def render(
        self, camera: str, depth: bool = False, width: int | None = None, height: int | None = None
    ) -> NDArray[np.uint8] | NDArray[np.float32]:
        """An RGB image (H, W, 3) uint8, or with ``depth`` a depth image (H, W) float32 [m],
        from a camera of the cell."""
        if camera not in self.cameras:
            raise SimulationError(f"unknown camera {camera!r}; known: {choices(self.cameras)}")
        c = self.cameras[camera]
        w, h = width or c.width, height or c.height
        with self.lock:
            renderer = mujoco.Renderer(self.model, height=h, width=w)
            try:
                if depth:
                    renderer.enable_depth_rendering()
                renderer.update_scene(self.data, camera=camera)
                img = renderer.render()
            finally:
                renderer.close()
        return img.copy()


def _default_gains(jtype: str) -> ServoGains:
    """Stiff industrial servos: rotor inertia (armature) as geared motors have, and a critically
    damped PD on top of it."""
    if jtype == "prismatic":
        return ServoGains(kp=2000.0, kv=40.0, armature=0.01)
    return ServoGains(kp=3000.0, kv=120.0, armature=0.2)
