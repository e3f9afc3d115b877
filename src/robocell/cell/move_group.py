"""MoveGroup: MoveIt's MoveGroupCommander on one group of a planning scene: targets, planning,
execution through a controller, Cartesian paths, attached objects.

    arm = MoveGroup(scene, "arm")
    arm.set_named_target("home")
    arm.go()
    arm.set_pose_target(Pose.from_rpy(0.4, 0.0, 0.3, 0, math.pi, 0))
    plan = arm.plan()
    arm.execute(plan)
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import (
    ExecutionError,
    ModelError,
    PlanningError,
    choices,
    name_or,
    number,
    unknown,
    vector,
    whole,
)
from robocell.execution.controller import Controller, ExecutionHandle, KinematicController
from robocell.geometry.pose import Pose
from robocell.kinematics.fk import fk, jacobian
from robocell.planning.cartesian import (
    compute_cartesian_path,
    compute_linear_sequence,
    relative_pose,
    waypoint_poses,
)
from robocell.planning.planner import Planner, PlannerConfig, planner_name, planning_attempts
from robocell.planning.request import (
    Goal,
    JointGoal,
    MotionPlan,
    MotionPlanRequest,
    PoseGoal,
    PositionGoal,
)
from robocell.scene.objects import AttachedObject, CollisionObject
from robocell.scene.planning_scene import PlanningScene
from robocell.trajectory.path import BlendedPath
from robocell.trajectory.timing import retimed, time_optimal
from robocell.trajectory.trajectory import JointTrajectory, stationary


@dataclass
class CartesianPlan:
    """Result of :meth:`MoveGroup.compute_cartesian_path`. Unpacks as MoveIt's
    ``(trajectory, fraction)``; ``reason`` says why ``fraction`` < 1."""

    trajectory: JointTrajectory
    fraction: float
    reason: str = ""

    def __iter__(self) -> Iterator[JointTrajectory | float]:
        return iter((self.trajectory, self.fraction))


class MoveGroup:
    """One planning group of a scene's robot, with MoveIt's commander interface.

    ``controller``: what executes (default: a :class:`KinematicController` on the scene's own
    state, MoveIt's demo mode; ``time_scale`` 0 makes it jump to each trajectory's end).
    """

    def __init__(
        self,
        scene: PlanningScene,
        group: str,
        controller: Controller | None = None,
        planner_config: PlannerConfig | None = None,
        time_scale: float = 1.0,
    ) -> None:
        self.scene = scene
        self.group = scene.robot.group(group)
        self.planner = Planner(scene, planner_config)
        self._lock = threading.Lock()
        self.controller: Controller = controller or KinematicController(
            self.group, scene.state.positions, time_scale=time_scale, lock=self._lock
        )
        self._goal: Goal | None = None
        self._start: NDArray[np.float64] | None = None
        self.planning_time = 1.0
        self.attempts = 1
        self.velocity_scaling = 1.0
        self.acceleration_scaling = 1.0
        self.joint_tolerance = 1e-4
        self.position_tolerance = 1e-4
        self.orientation_tolerance = 1e-3
        self.planner_id = ""
        self.end_effector_link = self.group.tip_link
        self._pose_frame = WORLD_FRAME
        self._handle: ExecutionHandle | None = None
        self.seed: int | None = 0
        self._remembered: dict[str, NDArray[np.float64]] = {}
        self._rng: np.random.Generator | None = None
        #: copies the executing robot's state into the scene (physics mode) before it is read
        self.sync_state: Callable[[], None] | None = None

    # ------------------------------------------------------------------ state
    def get_name(self) -> str:
        return self.group.name

    def get_active_joints(self) -> list[str]:
        return list(self.group.joint_names)

    def get_current_joint_values(self) -> NDArray[np.float64]:
        """The group's joint values now [rad or m], in its joint order."""
        return self.controller.current_positions()

    def get_current_pose(self, link: str | None = None) -> Pose:
        """Pose of ``link`` (default: the end-effector link) in the world frame, now."""
        if self.sync_state is not None:
            self.sync_state()
        with self._lock:
            return self.scene.link_pose(self._link(link))

    def _link(self, link: str | None) -> str:
        """``link``, or the end-effector link for None or "" (MoveIt's default argument)."""
        return name_or(link, self.end_effector_link)

    def get_current_rpy(self, link: str | None = None) -> list[float]:
        """Roll, pitch and yaw [rad] of ``link`` (default: the end-effector link) in the world
        frame, now (tf's static x-y-z angles, as MoveIt)."""
        return [float(a) for a in self.get_current_pose(link).rpy()]

    def get_planning_frame(self) -> str:
        """The frame poses are given and returned in: the scene's world frame."""
        return WORLD_FRAME

    def get_pose_reference_frame(self) -> str:
        """The frame pose and position targets and Cartesian waypoints are given in: the
        scene's world frame unless :meth:`set_pose_reference_frame` named another."""
        return self._pose_frame

    def set_pose_reference_frame(self, frame: str) -> None:
        """Give pose and position targets and Cartesian waypoints in ``frame``: the world
        frame or a link of the robot (its base link, say, for a robot mounted off the
        world's origin, as in a cell of two robots), as MoveIt's call. A link that moves is
        taken where it is when the target or the waypoints are given. Poses the group
        returns (:meth:`get_current_pose`) stay in the world frame, MoveIt's planning frame."""
        links = self.scene.robot.link_names
        if not isinstance(frame, str) or (frame != WORLD_FRAME and frame not in links):
            raise PlanningError(unknown("pose reference frame", frame, [WORLD_FRAME, *links]))
        self._pose_frame = frame

    def _in_world(self, pose: Pose) -> Pose:
        """``pose``, given in the pose reference frame, in the world frame (the frame where
        it is now)."""
        if self._pose_frame == WORLD_FRAME:
            return pose
        if self.sync_state is not None:
            self.sync_state()
        with self._lock:
            T_world_frame = self.scene.link_pose(self._pose_frame)
        return T_world_frame * pose

    def get_named_targets(self) -> list[str]:
        """The SRDF's group states and the joint values remembered by name
        (:meth:`remember_joint_values`), as MoveIt lists both."""
        return sorted(set(self.group.named_states) | set(self._remembered))

    def get_named_target_values(self, name: str) -> dict[str, float]:
        q = self._named(name)
        return dict(zip(self.group.joint_names, q.tolist(), strict=True))

    def _named(self, name: str) -> NDArray[np.float64]:
        """The joint values named ``name``: remembered ones first, then the SRDF's (as
        MoveIt's setNamedTarget looks them up)."""
        if isinstance(name, str) and name in self._remembered:
            return self._remembered[name].copy()
        if isinstance(name, str) and name in self.group.named_states:
            return self.group.named(name)
        raise ModelError(
            f"unknown named state {name!r} of group {self.group.name!r}; "
            f"known: {choices(self.get_named_targets())}"
        )

    def remember_joint_values(self, name: str, values: ArrayLike | None = None) -> None:
        """Remember ``values`` (default: the current joint values) as the named target
        ``name``, for :meth:`set_named_target`, ``plan(name)`` and ``go(name)``; a
        remembered name hides an SRDF state of the same name."""
        if not isinstance(name, str) or not name:
            raise PlanningError(f"a remembered target needs a name (a non-empty str), got {name!r}")
        q = (
            self.get_current_joint_values()
            if values is None
            else self.group.as_joint_vector(values, f"joint values for {name!r}")
        )
        bad = self.group.limit_violations(q)
        if bad:
            raise PlanningError(f"joint values for {name!r} outside the limits: {'; '.join(bad)}")
        self._remembered[name] = q

    def get_remembered_joint_values(self) -> dict[str, list[float]]:
        """The joint values remembered by name, each in the group's joint order."""
        return {name: q.tolist() for name, q in self._remembered.items()}

    def forget_joint_values(self, name: str) -> None:
        """Forget the joint values remembered as ``name``."""
        if not isinstance(name, str) or name not in self._remembered:
            raise PlanningError(
                f"no joint values remembered as {name!r}; remembered: {choices(self._remembered)}"
            )
        del self._remembered[name]

    def get_jacobian_matrix(
        self, joint_values: ArrayLike, reference_point: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """The geometric Jacobian (6, dof) of the end-effector link at ``joint_values``: rows
        (vx, vy, vz, wx, wy, wz) along the axes of the planning frame (the world's, where the
        poses are), of the link's origin or of ``reference_point`` [m], a point in the link's
        frame."""
        q = self.group.as_joint_vector(joint_values, "joint values")
        link = self.end_effector_link
        with self._lock:
            base = self.scene.state.positions.copy()
        J = jacobian(self.group, q, link, base)  # the robot's root frame
        if reference_point is not None:
            p = vector(reference_point, 3, "reference point", PlanningError)
            r = fk(self.group, q, link, base)[:3, :3] @ p  # the point from the origin, root frame
            # v_point = v_origin + w x r = v_origin - [r]x w
            rx = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
            J[:3] -= rx @ J[3:]
        R = self.scene.T_world_root[:3, :3]
        return np.vstack([R @ J[:3], R @ J[3:]])

    def set_end_effector_link(self, link: str) -> None:
        self.scene.robot.link_index(link, "end-effector link")
        self.end_effector_link = link

    def get_end_effector_link(self) -> str:
        return self.end_effector_link

    # ------------------------------------------------------------------ settings
    def set_planning_time(self, seconds: float) -> None:
        self.planning_time = _positive(seconds, "planning time [s]")

    def set_num_planning_attempts(self, n: int) -> None:
        self.attempts = planning_attempts(n)

    def set_max_velocity_scaling_factor(self, f: float) -> None:
        self.velocity_scaling = _factor(f, "velocity scaling factor")

    def set_max_acceleration_scaling_factor(self, f: float) -> None:
        self.acceleration_scaling = _factor(f, "acceleration scaling factor")

    def set_goal_tolerance(self, tolerance: float) -> None:
        """Joint [rad], position [m] and orientation [rad] tolerance at once (as MoveIt)."""
        self.set_goal_joint_tolerance(tolerance)
        self.set_goal_position_tolerance(tolerance)
        self.set_goal_orientation_tolerance(tolerance)

    def set_goal_joint_tolerance(self, tolerance: float) -> None:
        self.joint_tolerance = _positive(tolerance, "joint tolerance")

    def set_goal_position_tolerance(self, tolerance: float) -> None:
        self.position_tolerance = _positive(tolerance, "position tolerance")

    def set_goal_orientation_tolerance(self, tolerance: float) -> None:
        self.orientation_tolerance = _positive(tolerance, "orientation tolerance")

    def get_planning_time(self) -> float:
        return self.planning_time

    def get_goal_tolerance(self) -> tuple[float, float, float]:
        """(joint [rad], position [m], orientation [rad]) tolerances, as MoveIt."""
        return self.joint_tolerance, self.position_tolerance, self.orientation_tolerance

    def get_goal_joint_tolerance(self) -> float:
        return self.joint_tolerance

    def get_goal_position_tolerance(self) -> float:
        return self.position_tolerance

    def get_goal_orientation_tolerance(self) -> float:
        return self.orientation_tolerance

    def set_planner_id(self, planner_id: str) -> None:
        """An OMPL planner by MoveIt's name (``RRTConnectkConfigDefault``, …) or OMPL's
        (``RRTConnect``, …; needs ``pip install ompl``), or "" for the native planner
        (checked when planning)."""
        self.planner_id = planner_name(planner_id)

    # ------------------------------------------------------------------ targets
    def set_start_state(self, q: ArrayLike | None) -> None:
        """Plan from ``q`` instead of the current state (None: the current state)."""
        self._start = None if q is None else self.group.as_joint_vector(q, "start state")

    def set_start_state_to_current_state(self) -> None:
        self._start = None

    def set_named_target(self, name: str) -> None:
        """A joint goal by name: joint values remembered by that name, or the SRDF's state."""
        self._goal = JointGoal(self._named(name))

    def set_joint_value_target(
        self, q: ArrayLike | dict[str, float] | str | Pose, value: object = None
    ) -> None:
        """A joint goal: a vector in the group's order, {joint name: value} or a joint's name
        and its value (the other joints keep their current values), or a Pose of the
        end-effector link (or of the link named by ``value``) in the pose reference frame, whose
        collision-free IK solution nearest the current joint values becomes the goal (one
        within the goal tolerances where none meets the pose exactly), as moveit_commander's
        forms of this call."""
        if isinstance(q, Pose):
            link = self._link(value)  # type: ignore[arg-type]
            self.scene.robot.link_index(link, "pose target link")
            goal = PoseGoal(
                link, self._in_world(q), self.position_tolerance, self.orientation_tolerance
            )
            current = self.get_current_joint_values()
            with self._lock:
                checker = self.scene.checker(self.group)
                solutions = self.planner.goal_configurations(self.group, goal, current, checker)
            self._goal = JointGoal(solutions[0])
            return
        if isinstance(q, str):
            q = {q: value}  # type: ignore[dict-item]
        elif value is not None:
            raise PlanningError(
                f"a second argument goes with a joint's name or a Pose, not with {q!r}"
            )
        if isinstance(q, dict):
            target = self.get_current_joint_values()
            for name, v in q.items():
                if name not in self.group.joint_names:
                    raise PlanningError(
                        f"unknown joint {name!r} of group {self.group.name!r}; "
                        f"known: {choices(self.group.joint_names)}"
                    )
                target[self.group.joint_names.index(name)] = number(
                    v, f"joint target {name!r}", PlanningError
                )
        else:
            target = self.group.as_joint_vector(q, "joint target")
        bad = self.group.limit_violations(target)
        if bad:
            raise PlanningError(f"joint target outside the limits: {'; '.join(bad)}")
        self._goal = JointGoal(target)

    def get_joint_value_target(self) -> NDArray[np.float64]:
        """The joint values of the joint goal set last (a named target, joint values, a
        Pose through :meth:`set_joint_value_target`)."""
        if not isinstance(self._goal, JointGoal):
            raise PlanningError(
                "the target is not a joint goal: "
                + ("none is set" if self._goal is None else f"a {type(self._goal).__name__}")
            )
        return self._goal.positions.copy()

    def set_pose_target(self, pose: Pose | ArrayLike, link: str | None = None) -> None:
        """A pose goal for ``link`` (default: the end-effector link), in the pose reference
        frame (the world's unless :meth:`set_pose_reference_frame` named another)."""
        p = pose if isinstance(pose, Pose) else Pose.from_any(pose)
        link = self._link(link)
        self.scene.robot.link_index(link, "pose target link")
        self._goal = PoseGoal(link, self._in_world(p))

    def set_position_target(self, xyz: ArrayLike, link: str | None = None) -> None:
        """A position-only goal for ``link`` (any orientation) [m], in the pose reference
        frame."""
        p = vector(xyz, 3, "a position target", PlanningError)
        link = self._link(link)
        self.scene.robot.link_index(link, "position target link")
        self._goal = PositionGoal(link, self._in_world(Pose(p)).position)

    def shift_pose_target(self, axis: int, value: float, link: str | None = None) -> None:
        """A pose target: the current pose of ``link`` (default: the end-effector link) with
        ``value`` added along ``axis`` 0–5: x, y, z [m] or roll, pitch, yaw [rad] of the
        world frame (as MoveIt: the angles are the pose's tf roll, pitch and yaw)."""
        i = whole(axis, "axis (0-5: x, y, z, roll, pitch, yaw)", PlanningError)
        if not 0 <= i <= 5:
            raise PlanningError(f"axis must be 0-5 (x, y, z, roll, pitch, yaw), got {axis!r}")
        d = number(value, f"shift along axis {i}", PlanningError)
        link = self._link(link)
        pose = self.get_current_pose(link)
        xyz_rpy = np.concatenate([pose.position, pose.rpy()])
        xyz_rpy[i] += d
        target = Pose(xyz_rpy[:3], pose.orientation) if i < 3 else Pose.from_rpy(*xyz_rpy)
        self._goal = PoseGoal(link, target)

    def set_random_target(self) -> None:
        """A joint goal drawn uniformly within the limits among the states free of collision
        in the scene as it is (MoveIt draws within the limits only, and its plan then fails
        on a colliding one); the draws follow the group's ``seed``."""
        self._goal = JointGoal(self.get_random_joint_values())

    def get_random_joint_values(self) -> NDArray[np.float64]:
        """Joint values drawn uniformly within the limits, free of collision in the scene as
        it is (the group's ``seed`` seeds the draws)."""
        if self._rng is None:
            self._rng = np.random.default_rng(self.seed)
        with self._lock:
            checker = self.scene.checker(self.group)
        for _ in range(RANDOM_BATCHES):
            qs = self.group.random(self._rng, RANDOM_BATCH)
            free = np.flatnonzero(~checker.check(qs))
            if len(free):
                return qs[free[0]]
        raise PlanningError(
            f"no collision-free state of group {self.group.name!r} in "
            f"{RANDOM_BATCHES * RANDOM_BATCH} draws within its limits"
        )

    def clear_pose_targets(self) -> None:
        self._goal = None

    def _set_target(self, target: object) -> None:
        """moveit_commander's target argument of ``plan`` and ``go``: a name (remembered or
        the SRDF's), a Pose (pose target), joint values (a vector or {joint: value})."""
        if isinstance(target, str):
            self.set_named_target(target)
        elif isinstance(target, Pose):
            self.set_pose_target(target)
        else:
            self.set_joint_value_target(target)  # type: ignore[arg-type]

    def _goal_now(self) -> Goal:
        """The target set last, with the tolerances set now (the stored target carries none
        of its own): MoveIt builds a request's goal constraints when it plans, so a tolerance
        set after the target applies to it."""
        goal = self._goal
        if goal is None:
            raise PlanningError(
                "no target: call set_named_target, set_joint_value_target, set_pose_target "
                "or set_position_target first"
            )
        if isinstance(goal, JointGoal):
            return replace(goal, tolerance=self.joint_tolerance)
        if isinstance(goal, PoseGoal):
            return replace(
                goal,
                position_tolerance=self.position_tolerance,
                orientation_tolerance=self.orientation_tolerance,
            )
        return replace(goal, tolerance=self.position_tolerance)

    # ------------------------------------------------------------------ plan and move
    def plan(self, joints: object = None, *, fix_start: bool = False) -> MotionPlan:
        """Plan from the start state (default: current) to the target set last, or to
        ``joints`` (set as the target first, as moveit_commander's ``plan(joints)``: a named
        target, a Pose, or joint values). The plan unpacks as MoveIt's ``success,
        trajectory, planning_time, error`` (here the error is the reason, "" on success)."""
        if joints is not None:
            self._set_target(joints)
        goal = self._goal_now()
        if self.sync_state is not None:
            self.sync_state()
        request = MotionPlanRequest(
            group=self.group.name,
            goal=goal,
            start=self._start if self._start is not None else self.get_current_joint_values(),
            planning_time=self.planning_time,
            attempts=self.attempts,
            seed=self.seed,
            velocity_scaling=self.velocity_scaling,
            acceleration_scaling=self.acceleration_scaling,
            planner_id=self.planner_id,
            fix_start=fix_start,
        )
        with self._lock:
            return self.planner.plan(request)

    def execute(
        self, plan: MotionPlan | JointTrajectory | CartesianPlan, wait: bool = True
    ) -> bool:
        """Execute a plan (or a trajectory). With ``wait`` block until it ends and return
        whether it succeeded; otherwise return True once it has started."""
        traj = _trajectory_of(plan)
        self._handle = self.controller.execute(traj)
        if not wait:
            return True
        self._handle.wait()
        return self._handle.result.success

    def go(self, joints: object = None, wait: bool = True) -> bool:
        """Plan to the target (or to ``joints``, as :meth:`plan`) and execute; False if
        planning or execution failed. ``go(False)`` is ``go(wait=False)``, as MoveIt's."""
        if isinstance(joints, bool):
            wait = joints
            joints = None
        plan = self.plan(joints)
        if not plan.success:
            return False
        return self.execute(plan, wait)

    def stop(self) -> None:
        """Stop the running motion (decelerate, hold)."""
        self.controller.stop()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the motion started with ``wait=False``; True if it ended in time."""
        return True if self._handle is None else self._handle.wait(timeout)

    @property
    def last_execution(self) -> ExecutionHandle | None:
        return self._handle

    def retime_trajectory(
        self,
        plan: MotionPlan | CartesianPlan | JointTrajectory,
        velocity_scaling_factor: float = 1.0,
        acceleration_scaling_factor: float = 1.0,
    ) -> JointTrajectory:
        """``plan``'s motion timed again for other scaling factors (MoveIt's call, without
        its reference state: the motion says where it starts). A plan's path is timed
        time-optimally again, its corners rounded as before; a trajectory whose path is not
        known otherwise (a Cartesian plan's, or any) runs uniformly slower or faster until a
        joint reaches a scaled limit (:func:`robocell.trajectory.retimed`)."""
        vs = _factor(velocity_scaling_factor, "velocity scaling factor")
        as_ = _factor(acceleration_scaling_factor, "acceleration scaling factor")
        traj = _trajectory_of(plan)  # refuses a failed plan or something else
        if isinstance(plan, MotionPlan):
            path = BlendedPath(plan.path, plan.stats.get("corner_deviation", 0.0))
            return time_optimal(self.group, path, vs, as_)
        return retimed(self.group, traj, vs, as_)

    # ------------------------------------------------------------------ Cartesian
    def compute_cartesian_path(
        self,
        waypoints: list[Pose],
        eef_step: float = 0.01,
        jump_threshold: float = 0.0,
        avoid_collisions: bool = True,
        rotation_step: float = 0.05,
    ) -> CartesianPlan:
        """Straight lines of the end-effector link through ``waypoints`` (in the pose reference
        frame), from the start state; unpacks as ``trajectory, fraction``. With the planner's
        ``continuous`` setting, the motion as it will run is proven free (it stops before
        the first step where it is not: see :func:`compute_cartesian_path`)."""
        waypoints = self._waypoints_in_world(waypoints)
        if self.sync_state is not None:
            self.sync_state()
        start = self._start if self._start is not None else self.get_current_joint_values()
        with self._lock:
            cp = compute_cartesian_path(
                self.scene,
                self.group,
                waypoints,
                eef_step,
                jump_threshold,
                avoid_collisions,
                self.end_effector_link,
                rotation_step,
                start,
                continuous=self._continuous(),
            )
        # the steps are dense samples of a smooth joint curve: a spline through them follows
        # it (a polyline would have a corner at every step)
        traj = time_optimal(
            self.group,
            cp.path if len(cp.path) > 1 else cp.path[[0, 0]],
            self.velocity_scaling,
            self.acceleration_scaling,
            smooth=True,
        )
        return CartesianPlan(traj, cp.fraction, cp.reason)

    def _waypoints_in_world(self, waypoints: Iterable[Pose]) -> list[Pose]:
        """``waypoints`` (a list of poses in the pose reference frame) in the world frame."""
        return [self._in_world(w) for w in waypoint_poses(_waypoints(waypoints))]

    def _continuous(self) -> float | None:
        """The continuous check's tolerance for Cartesian motions, when the planner's
        settings ask for it (``PlannerConfig.continuous``), else None."""
        config = self.planner.config
        return config.continuous_tolerance if config.continuous else None

    def compute_sequence(
        self, waypoints: list[Pose], blend_radius: float = 0.0, eef_step: float = 0.005
    ) -> CartesianPlan:
        """Straight moves of the end-effector link through ``waypoints`` (in the pose reference
        frame), each corner rounded from ``blend_radius`` [m] before it (Pilz's LIN sequence
        with blend radii, ABB's zones); 0 stops at every corner. Timed time-optimally."""
        waypoints = self._waypoints_in_world(waypoints)
        if self.sync_state is not None:
            self.sync_state()
        start = self._start if self._start is not None else self.get_current_joint_values()
        with self._lock:
            seq = compute_linear_sequence(
                self.scene,
                self.group,
                waypoints,
                blend_radius,
                eef_step,
                True,
                self.end_effector_link,
                start,
                continuous=self._continuous(),
            )
        traj = stationary(self.group, start)
        for piece in seq.pieces:
            traj = traj.then(
                time_optimal(
                    self.group,
                    piece,
                    self.velocity_scaling,
                    self.acceleration_scaling,
                    smooth=True,
                )
            )
        return CartesianPlan(traj, seq.fraction, seq.reason)

    def move_relative(
        self,
        translation: ArrayLike = (0.0, 0.0, 0.0),
        rpy: ArrayLike = (0.0, 0.0, 0.0),
        frame: str = "base",
        wait: bool = True,
    ) -> CartesianPlan:
        """Move the end-effector link in a straight line by ``translation`` [m] (and ``rpy``
        [rad]) in the robot's base frame, the tool's own frame or the world frame. Executes
        only when the whole move is possible; the returned plan says why not otherwise."""
        T = self.get_current_pose()
        with self._lock:
            T_base = self.scene.link_pose(self.group.base_link)
        target = relative_pose(T, translation, rpy, frame, T_base)
        cp = self.compute_cartesian_path([target])
        if cp.fraction >= 1.0:
            self.execute(cp.trajectory, wait)
        return cp

    # ------------------------------------------------------------------ objects
    def attach_object(
        self, id: str, link: str | None = None, touch_links: Iterable[str] | None = None
    ) -> AttachedObject:
        """Attach world object ``id`` to ``link`` (default: the end-effector link)."""
        with self._lock:
            return self.scene.attach_object(id, self._link(link), touch_links)

    def detach_object(self, id: str) -> CollisionObject:
        with self._lock:
            return self.scene.detach_object(id)


#: the frame of every pose a MoveGroup takes and returns
WORLD_FRAME = "world"
#: random targets: draws per batch, batches before giving up
RANDOM_BATCH, RANDOM_BATCHES = 64, 16


def _positive(v: float, what: str) -> float:
    x = number(v, what, PlanningError)
    if not x > 0:
        raise PlanningError(f"{what} must be > 0, got {v!r}")
    return x


def _factor(v: float, what: str) -> float:
    x = number(v, what, PlanningError)
    if not 0 < x <= 1:
        raise PlanningError(f"{what} must be in (0, 1], got {v!r}")
    return x


def _waypoints(waypoints: Iterable[Pose]) -> list[Pose]:
    """``waypoints`` as a list (each is read as a pose by the Cartesian planner)."""
    if isinstance(waypoints, str | bytes | dict | Pose) or not isinstance(waypoints, Iterable):
        raise PlanningError(
            f"waypoints must be a list of poses, got {type(waypoints).__name__} {waypoints!r}"
        )
    return list(waypoints)


def _trajectory_of(plan: MotionPlan | JointTrajectory | CartesianPlan) -> JointTrajectory:
    if isinstance(plan, JointTrajectory):
        return plan
    if isinstance(plan, CartesianPlan):
        return plan.trajectory
    if isinstance(plan, MotionPlan):
        if not plan.success or plan.trajectory is None:
            raise ExecutionError(f"cannot execute a failed plan: {plan.reason}")
        return plan.trajectory
    raise ExecutionError(
        f"execute needs a MotionPlan, CartesianPlan or JointTrajectory, got {type(plan).__name__}"
    )
