"""The kinematic controller: follows the trajectory in time, preempts, stops within limits,
rejects bad trajectories."""

import time

import numpy as np
import pytest

from robocell.errors import ExecutionError
from robocell.execution import ExecutionStatus, KinematicController, stopping_trajectory
from robocell.trajectory import ptp


@pytest.fixture
def arm(irb120):
    return irb120.group("arm")


def test_instant_execution_reaches_the_end(irb120, arm):
    state = irb120.default_positions.copy()
    c = KinematicController(arm, state, time_scale=0)
    goal = np.array([0.5, 0.2, -0.1, 0.3, 0.4, 0.5])
    h = c.execute(ptp(arm, np.zeros(6), goal))
    assert h.done() and h.result.status is ExecutionStatus.SUCCEEDED
    assert np.allclose(c.current_positions(), goal)
    assert np.allclose(state[arm.indices], goal)  # the state vector it was given


def test_real_time_execution_follows_the_trajectory(irb120, arm):
    state = irb120.default_positions.copy()
    c = KinematicController(arm, state, time_scale=1.0)
    traj = ptp(arm, np.zeros(6), np.array([1.0, 0, 0, 0, 0, 0]))
    h = c.execute(traj)
    assert not h.done()
    time.sleep(traj.duration / 2)
    mid = c.current_positions()[0]
    assert 0.05 < mid < 0.95
    assert h.wait(5.0) and h.result.success
    assert c.current_positions()[0] == pytest.approx(1.0)


def test_stop_decelerates_within_limits(irb120, arm):
    state = irb120.default_positions.copy()
    c = KinematicController(arm, state, time_scale=1.0)
    traj = ptp(arm, np.zeros(6), np.array([2.5, 0, 0, 0, 0, 0]), velocity_scaling=0.3)
    h = c.execute(traj)
    time.sleep(0.3)
    h.stop()
    assert h.done() and h.result.status is ExecutionStatus.PREEMPTED
    q_stop = c.current_positions()
    time.sleep(0.1)
    assert np.array_equal(c.current_positions(), q_stop)  # holds
    assert 0 < q_stop[0] < 2.5


def test_stopping_trajectory_limits(arm):
    v = arm.velocity * np.array([1, -0.5, 0.2, 0, 1, -1])
    stop = stopping_trajectory(arm, np.zeros(6), v)
    assert np.allclose(stop.velocities[-1], 0)
    assert np.all(np.abs(stop.accelerations) <= arm.acceleration + 1e-9)
    # along the direction of motion
    d = stop.positions[-1] - stop.positions[0]
    assert np.allclose(d / np.linalg.norm(d), v / np.linalg.norm(v))


def test_new_goal_preempts(irb120, arm):
    state = irb120.default_positions.copy()
    c = KinematicController(arm, state, time_scale=1.0, start_tolerance=10.0)
    first = c.execute(ptp(arm, np.zeros(6), np.array([2.0, 0, 0, 0, 0, 0]), velocity_scaling=0.2))
    time.sleep(0.1)
    q = c.current_positions()
    second = c.execute(ptp(arm, q, q + [0, 0.1, 0, 0, 0, 0]))
    assert first.result.status is ExecutionStatus.PREEMPTED
    assert second.wait(5.0) and second.result.success


def test_bad_trajectories_are_rejected(irb120, arm):
    state = irb120.default_positions.copy()
    c = KinematicController(arm, state, time_scale=0)
    far = ptp(arm, np.full(6, 0.1), np.full(6, 0.2))
    with pytest.raises(ExecutionError, match="starts 0.1000 rad from the current state"):
        c.execute(far)
    gripper = irb120.group("gripper")
    with pytest.raises(ExecutionError, match="not those of group"):
        c.execute(ptp(gripper, [0.0], [0.5]))
    fast = ptp(arm, np.zeros(6), np.full(6, 0.5)).scaled(0.5)  # twice too fast
    with pytest.raises(ExecutionError, match="velocity"):
        c.execute(fast)
    assert np.allclose(c.current_positions(), 0)  # nothing was sent
