"""Controllers that run trajectories on the physics world.

One :class:`Stepper` per world steps the physics while any goal is active (as fast as it can,
or paced to real time) and, every step, sets each active goal's servo references (position and
velocity) and feed-forward torque M(q)·q̈_ref from the trajectory sampled at the physics rate.
Goals for different groups run at the same time; a new goal for a group preempts its old one.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from robocell.execution.controller import (
    ExecutionHandle,
    ExecutionResult,
    ExecutionStatus,
    stopping_trajectory,
    validate_trajectory,
)
from robocell.robot.model import JointGroup
from robocell.sim.world import World
from robocell.trajectory.trajectory import JointTrajectory


@dataclass
class _Goal:
    group: JointGroup
    handle: ExecutionHandle
    q: NDArray[np.float64]  # (K, dof) references per physics step
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]
    act: NDArray[np.int64]
    dof: NDArray[np.int64]
    col: NDArray[np.int64]  # the group joint each servo follows
    scale: NDArray[np.float64]
    offset: NDArray[np.float64]
    qpos_adr: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    k: int = 0
    max_error: float = 0.0
    stopping: bool = False
    trace: NDArray[np.float64] | None = None  # actual positions per step, when recorded
    ctrl_ref: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    qdd_ref: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    q_servo: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    prepared: object = None
    final: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    # the indices above as slices where they are contiguous (cheaper to index every step)
    act_ix: slice | NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    dof_ix: slice | NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    qpos_ix: slice | NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))


def _index(a: NDArray[np.int64]) -> slice | NDArray[np.int64]:
    """``a`` as a slice when it is a contiguous ascending run, else as it is."""
    if len(a) and np.array_equal(a, np.arange(a[0], a[0] + len(a))):
        return slice(int(a[0]), int(a[0]) + len(a))
    return a


CHUNK = 20  # physics steps per lock of the world


class Stepper:
    """Steps one world for its controllers (a background thread while goals are active)."""

    def __init__(self, world: World, realtime: bool = False) -> None:
        self.world = world
        self.realtime = realtime
        self._goals: dict[str, _Goal] = {}
        self._cv = threading.Condition()
        self._thread: threading.Thread | None = None
        m = world.model
        self._kp = m.actuator_gainprm[:, 0].copy()
        self._kv = -m.actuator_biasprm[:, 2].copy()
        self._qdd_full = np.zeros(m.nv)
        self._tau = np.zeros(m.nv)
        self.error: str = ""
        self._version = 0  # bumped whenever the set of goals or a goal's references change
        #: simulated over wall-clock time of the stepping so far (0 before any)
        self.real_time_factor = 0.0
        self._sim_total = 0.0
        self._wall_total = 0.0

    def submit(self, goal: _Goal) -> None:
        with self._cv:
            old = self._goals.get(goal.group.name)
            if old is not None:
                old.handle._finish(
                    ExecutionResult(
                        ExecutionStatus.PREEMPTED, "preempted by a new goal", old.max_error
                    )
                )
            self._goals[goal.group.name] = goal
            self._version += 1
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._run, daemon=True)
                self._thread.start()
            self._cv.notify_all()

    def stop(self, group: str) -> None:
        """Replace the group's remaining references by a stop within its limits."""
        with self._cv:
            g = self._goals.get(group)
            if g is None or g.stopping:
                return
            k = min(g.k, len(g.q) - 1)
            stop = stopping_trajectory(g.group, g.q[k], g.qd[k], self.world.timestep)
            g.q, g.qd, g.qdd = _sampled(stop, self.world.timestep)
            g.k = 0
            g.stopping = True
            self._version += 1
        g.handle.wait()

    def _prepare(self, g: _Goal) -> None:
        """Per-step servo commands and feed-forward accelerations, computed once per goal:
        the stepping loop then only copies rows."""
        ratio = self._kv[g.act] / self._kp[g.act]
        dt = self.world.timestep
        q = g.q[:, g.col]
        # references consistent with the integrator (q_{k+1} = q_k + dt·v_{k+1}): the velocity
        # over each step is the finite difference of the positions, and the acceleration the
        # change of that velocity. Feeding the analytic q̇, q̈ leaves a steady error of
        # M·q̈·dt²/2 per step, a millimetre at full acceleration (measured).
        v = np.vstack([np.diff(q, axis=0) / dt, np.zeros((1, q.shape[1]))])
        a = np.vstack([v[:1] / dt, np.diff(v, axis=0) / dt])
        g.ctrl_ref = g.offset + g.scale * (q + v * ratio)
        g.qdd_ref = g.scale * a
        g.q_servo = g.q[:, g.col]
        g.act_ix, g.dof_ix, g.qpos_ix = _index(g.act), _index(g.dof), _index(g.qpos_adr)
        g.prepared = g.q

    def _run(self) -> None:
        world = self.world
        m, d = world.model, world.data
        dt = world.timestep
        t_wall0 = time.perf_counter()
        t_sim0 = world.time
        qdd_full, tau = self._qdd_full, self._tau
        step = 0
        while True:
            with self._cv:
                if not self._goals:
                    return
                goals = list(self._goals.values())
                version = self._version
            for g in goals:
                if g.prepared is not g.q:  # new goal, or a stop replaced its references
                    self._prepare(g)
            dofs = _index(np.concatenate([g.dof for g in goals]))
            ended = False
            t_chunk, steps_before = time.perf_counter(), step
            # each goal's actual positions over the chunk, and the reference rows they track
            actual = [np.empty((CHUNK, len(g.act))) for g in goals]
            rows = [np.empty(CHUNK, np.int64) for _ in goals]
            n = 0
            with world.lock:
                # up to CHUNK steps per lock (40 ms simulated): readers wait at most that long
                for _ in range(CHUNK):
                    for g in goals:
                        # the reference at the start of the step (the implicit integrator
                        # moves the joint with the velocity at its end: aiming there runs
                        # ahead)
                        k0 = g.k if g.k < len(g.q) else len(g.q) - 1
                        d.ctrl[g.act_ix] = g.ctrl_ref[k0]
                        qdd_full[g.dof_ix] = g.qdd_ref[k0]
                    mujoco.mj_mulM(m, d, tau, qdd_full)
                    # inertial and Coriolis feed-forward (gravity is compensated by the bodies'
                    # gravcomp; qfrc_bias holds Coriolis plus gravity)
                    d.qfrc_applied[dofs] = tau[dofs] + d.qfrc_bias[dofs] - d.qfrc_gravcomp[dofs]
                    mujoco.mj_step(m, d)
                    step += 1
                    if step % 25 == 0 and not world.healthy():
                        self._abort(goals, world.diverged())
                        return
                    for i, g in enumerate(goals):
                        g.k += 1
                        rows[i][n] = g.k if g.k < len(g.q) else len(g.q) - 1
                        actual[i][n] = d.qpos[g.qpos_ix]
                        if g.k >= len(g.q):
                            ended = True
                    n += 1
                    if ended or self._version != version:
                        break
                d.qfrc_applied[dofs] = 0.0
                qdd_full[:] = 0.0
            # tracking over the chunk, in one go per goal
            for i, g in enumerate(goals):
                got = (actual[i][:n] - g.offset) / g.scale
                ks = rows[i][:n]
                if g.trace is not None:
                    g.trace[ks[:, None], g.col[None, :]] = got
                if not g.stopping and n:
                    g.max_error = max(g.max_error, float(np.max(np.abs(got - g.q_servo[ks]))))
            self._sim_total += (step - steps_before) * dt
            self._wall_total += time.perf_counter() - t_chunk
            self.real_time_factor = self._sim_total / max(self._wall_total, 1e-9)
            if not world.healthy():
                self._abort(goals, world.diverged())
                return
            with self._cv:
                for g in goals:
                    if g.k >= len(g.q) and self._goals.get(g.group.name) is g:
                        del self._goals[g.group.name]
                        self._version += 1
                        status = (
                            ExecutionStatus.PREEMPTED if g.stopping else ExecutionStatus.SUCCEEDED
                        )
                        g.handle._finish(
                            ExecutionResult(
                                status, "stopped" if g.stopping else "", g.max_error,
                                len(g.q) * dt,
                            )
                        )  # fmt: skip
            if self.realtime:
                ahead = (world.time - t_sim0) - (time.perf_counter() - t_wall0)
                if ahead > 0.002:
                    time.sleep(ahead)

    def _abort(self, goals: list[_Goal], message: str) -> None:
        self.error = message
        with self._cv:
            for g in goals:
                g.handle._finish(ExecutionResult(ExecutionStatus.ABORTED, message, g.max_error))
            self._goals.clear()
            self._version += 1


def _sampled(
    traj: JointTrajectory, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    n = int(np.ceil(traj.duration / dt)) + 1
    s = traj.sample(np.minimum(np.arange(n) * dt, traj.duration))
    return s.positions, s.velocities, s.accelerations


class PhysicsController:
    """Runs trajectories of ``group`` on the world through its stepper. ``start_tolerance``
    [rad or m]: how far the trajectory's start may be from the current state (MoveIt's 0.01;
    a gripper, whose fingers stall on what they hold, takes any start)."""

    def __init__(
        self,
        stepper: Stepper,
        group: JointGroup,
        start_tolerance: float = 0.01,
        record: bool = False,
    ) -> None:
        self.stepper = stepper
        self.world = stepper.world
        self.group = group
        self.start_tolerance = start_tolerance
        #: keep the actual joint positions of every physics step in ``handle.trace``
        self.record = record
        self._targets = self.world.servo_targets(group)
        self._handle: ExecutionHandle | None = None

    def current_positions(self) -> NDArray[np.float64]:
        return self.world.group_positions(self.group)

    def execute(self, trajectory: JointTrajectory) -> ExecutionHandle:
        """Start ``trajectory`` (checked first: joints, limits, start at the current state)."""
        validate_trajectory(self.group, trajectory, self.current_positions(), self.start_tolerance)
        q, qd, qdd = _sampled(trajectory, self.world.timestep)
        act = np.array([t[0] for t in self._targets], np.int64)
        dof = np.array([t[1] for t in self._targets], np.int64)
        col = np.array([t[2] for t in self._targets], np.int64)
        scale = np.array([t[3] for t in self._targets])
        offset = np.array([t[4] for t in self._targets])
        handle = ExecutionHandle(self, trajectory)
        self._handle = handle
        trace = None
        if self.record:
            trace = np.tile(q[0], (len(q), 1))
            handle.trace = trace  # type: ignore[attr-defined]
            handle.reference = q  # type: ignore[attr-defined]
        adr = np.array([self.world._jnt_qpos_by_dof[int(x)] for x in dof], np.int64)
        self.stepper.submit(
            _Goal(
                self.group,
                handle,
                q,
                qd,
                qdd,
                act,
                dof,
                col,
                scale,
                offset,
                qpos_adr=adr,
                trace=trace,
            )
        )
        return handle

    def stop(self) -> None:
        self.stepper.stop(self.group.name)
