"""Controllers carry out joint trajectories: the interface, the execution handle, and the
kinematic controller (MoveIt's "demo mode": no physics, the state follows the trajectory).

A controller owns one group. ``execute(trajectory)`` checks the trajectory (limits; the start
within ``start_tolerance`` of the current state, as MoveIt's 0.01 rad) and returns an
:class:`ExecutionHandle` at once; ``handle.wait()`` blocks until the motion ends. A new goal
preempts the one running; ``stop()`` decelerates within the limits and holds.
"""

from __future__ import annotations

import enum
import threading
import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from robocell.errors import ExecutionError
from robocell.robot.model import JointGroup
from robocell.trajectory.timing import joint_limits
from robocell.trajectory.trajectory import JointTrajectory


class ExecutionStatus(enum.Enum):
    ACTIVE = "active"
    SUCCEEDED = "succeeded"
    PREEMPTED = "preempted"
    ABORTED = "aborted"


@dataclass
class ExecutionResult:
    """How an execution ended; ``max_tracking_error`` [rad] between commanded and actual."""

    status: ExecutionStatus
    message: str = ""
    max_tracking_error: float = 0.0
    duration: float = 0.0

    @property
    def success(self) -> bool:
        return self.status is ExecutionStatus.SUCCEEDED


class ExecutionHandle:
    """A running (or finished) execution."""

    def __init__(self, controller: Controller, trajectory: JointTrajectory) -> None:
        self.controller = controller
        self.trajectory = trajectory
        self._done = threading.Event()
        self._result = ExecutionResult(ExecutionStatus.ACTIVE)

    def _finish(self, result: ExecutionResult) -> None:
        if not self._done.is_set():
            self._result = result
            self._done.set()

    def done(self) -> bool:
        return self._done.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the execution ends (or ``timeout`` [s] passes); True if it ended."""
        return self._done.wait(timeout)

    def stop(self) -> None:
        """Decelerate within the limits and hold; the result becomes PREEMPTED."""
        self.controller.stop()

    @property
    def result(self) -> ExecutionResult:
        return self._result


class Controller(Protocol):
    """What MoveGroup executes through (kinematic here; physics in :mod:`robocell.sim`)."""

    group: JointGroup

    def execute(self, trajectory: JointTrajectory) -> ExecutionHandle: ...

    def stop(self) -> None: ...

    def current_positions(self) -> NDArray[np.float64]: ...


def validate_trajectory(
    group: JointGroup,
    trajectory: JointTrajectory,
    current: NDArray[np.float64],
    start_tolerance: float,
) -> None:
    """Refuse a trajectory for another group, outside the limits, or not starting at the
    current state (an :class:`ExecutionError` saying which)."""
    if list(trajectory.joint_names) != list(group.joint_names):
        raise ExecutionError(
            f"trajectory joints {trajectory.joint_names} are not those of group "
            f"{group.name!r}: {group.joint_names}"
        )
    gap = np.abs(trajectory.positions[0] - current)
    if float(gap.max()) > start_tolerance:
        j = int(gap.argmax())
        raise ExecutionError(
            f"trajectory starts {gap[j]:.4f} rad from the current state at "
            f"{group.joint_names[j]} (tolerance {start_tolerance} rad); plan from the current state"
        )
    bad = trajectory.limit_violations(group)
    if bad:
        raise ExecutionError(f"trajectory violates the limits: {'; '.join(bad[:3])}")


def stopping_trajectory(
    group: JointGroup, q: NDArray[np.float64], v: NDArray[np.float64], dt: float = 0.004
) -> JointTrajectory:
    """From (q, v) to rest along the current direction of motion, all joints stopping together,
    each decelerating at most at its limit (MoveIt's default where the robot gives none, as
    its motions were timed with: :func:`robocell.trajectory.timing.joint_limits`)."""
    speed = np.abs(v)
    T = float(np.max(speed / joint_limits(group, "acceleration")))
    if T < 1e-9:
        z = np.zeros((1, group.dof))
        return JointTrajectory(list(group.joint_names), np.zeros(1), q[None].copy(), z, z.copy())
    n = max(2, int(np.ceil(T / dt)) + 1)
    t = np.linspace(0.0, T, n)[:, None]
    a = -v / T
    pos = np.clip(q + v * t + 0.5 * a * t**2, group.lower, group.upper)
    vel = v + a * t
    acc = np.tile(a, (n, 1))
    vel[-1] = 0.0
    return JointTrajectory(list(group.joint_names), t[:, 0], pos, vel, acc, group.name)


class KinematicController:
    """Demo mode: a background thread moves the group's joints in ``state`` along the
    trajectory in time (``time_scale`` = 1: real time; 0: at once, for scripts and tests;
    2: twice as fast as the trajectory's time)."""

    def __init__(
        self,
        group: JointGroup,
        state_positions: NDArray[np.float64],
        time_scale: float = 1.0,
        rate: float = 250.0,
        start_tolerance: float = 0.01,
        lock: threading.Lock | None = None,
    ) -> None:
        if time_scale < 0:
            raise ExecutionError(f"time_scale must be >= 0, got {time_scale}")
        self.group = group
        self._state = state_positions  # the robot's full state vector, written in place
        self.time_scale = time_scale
        self.rate = rate
        self.start_tolerance = start_tolerance
        self._lock = lock or threading.Lock()
        self._handle: ExecutionHandle | None = None
        self._thread: threading.Thread | None = None
        self._cancel = threading.Event()
        self._stop_requested = threading.Event()
        self._velocity = np.zeros(group.dof)

    def current_positions(self) -> NDArray[np.float64]:
        with self._lock:
            return self._state[self.group.indices].copy()

    def execute(self, trajectory: JointTrajectory) -> ExecutionHandle:
        """Start ``trajectory`` (checked first); the running one, if any, is preempted."""
        self._preempt()
        validate_trajectory(self.group, trajectory, self.current_positions(), self.start_tolerance)
        handle = ExecutionHandle(self, trajectory)
        self._handle = handle
        self._cancel.clear()
        self._stop_requested.clear()
        if self.time_scale == 0:
            self._write(trajectory.positions[-1])
            handle._finish(ExecutionResult(ExecutionStatus.SUCCEEDED, duration=trajectory.duration))
            return handle
        self._thread = threading.Thread(target=self._run, args=(handle,), daemon=True)
        self._thread.start()
        return handle

    def stop(self) -> None:
        """Decelerate the running motion to rest (within the limits) and hold."""
        if self._handle is not None and not self._handle.done():
            self._stop_requested.set()
            self._handle.wait()

    def _preempt(self) -> None:
        if self._handle is not None and not self._handle.done():
            self._cancel.set()
            if self._thread is not None:
                self._thread.join()

    def _write(self, q: NDArray[np.float64]) -> None:
        with self._lock:
            self._state[self.group.indices] = q

    def _run(self, handle: ExecutionHandle) -> None:
        traj = handle.trajectory
        t0 = time.perf_counter()
        period = 1.0 / self.rate
        scale = self.time_scale
        while True:
            t = (time.perf_counter() - t0) * scale
            if self._cancel.is_set():
                handle._finish(
                    ExecutionResult(
                        ExecutionStatus.PREEMPTED, "preempted by a new goal", duration=t
                    )
                )
                return
            s = traj.sample(min(t, traj.duration))
            self._write(s.positions[0])
            self._velocity = s.velocities[0]
            if self._stop_requested.is_set():
                self._decelerate(s.positions[0], s.velocities[0], t0, t)
                handle._finish(ExecutionResult(ExecutionStatus.PREEMPTED, "stopped", duration=t))
                return
            if t >= traj.duration:
                handle._finish(ExecutionResult(ExecutionStatus.SUCCEEDED, duration=traj.duration))
                self._velocity = np.zeros(self.group.dof)
                return
            time.sleep(period)

    def _decelerate(
        self, q: NDArray[np.float64], v: NDArray[np.float64], t0: float, t: float
    ) -> None:
        stop = stopping_trajectory(self.group, q, v)
        ts = time.perf_counter()
        while True:
            tau = (time.perf_counter() - ts) * self.time_scale
            self._write(stop.sample(min(tau, stop.duration)).positions[0])
            if tau >= stop.duration:
                break
            time.sleep(1.0 / self.rate)
        self._velocity = np.zeros(self.group.dof)
