"""Cells in both modes: scene and world agree, trajectories execute, stop and preempt in
physics, bad trajectories are refused, an object is held by friction through a transfer."""

import math
import time

import numpy as np
import pytest

from robocell import Pose
from robocell.cell import Cell
from robocell.errors import CellError, ExecutionError, ModelError, SimulationError
from robocell.execution import ExecutionStatus
from robocell.kinematics import fk
from robocell.planning import PlannerConfig
from robocell.trajectory import BlendedPath, ptp, time_optimal


@pytest.fixture
def cell():
    return Cell.load("sorting")


def test_scene_and_world_agree_and_objects_rest(cell):
    for name in cell.object_names:
        assert cell.world.object_pose(name).isclose(cell.scene.get_object(name).pose, atol=1e-9)
    cell.world.step(5)  # awake: each object stands on the conveyor
    for name in cell.object_names:
        assert "conveyor" in cell.world.touching(name)
    cell.world.step(500)  # 1 s: at rest where they were put (then asleep)
    for name in cell.object_names:
        moved = cell.world.object_pose(name).position - cell.scene.get_object(name).pose.position
        assert np.linalg.norm(moved) < 1e-3
        assert cell.world.object_speed(name) < 1e-3
    cell.sync_scene()
    for name in cell.object_names:
        assert cell.world.object_pose(name).isclose(cell.scene.get_object(name).pose, atol=1e-9)
    # the robot stands on its pedestal: allowed in the scene, excluded in the world
    assert cell.scene.is_state_valid()


def test_layout_and_reset(cell):
    before = cell.world.object_pose("blue_ball")
    cell.world.set_object_pose("blue_ball", Pose([0.5, 0.5, 1.5]))
    cell.reset()
    assert cell.world.object_pose("blue_ball").isclose(before, atol=1e-9)
    cell.reset(layout=3)
    expected = cell.spec.layout(3)
    for n in cell.object_names:
        assert cell.world.object_pose(n).isclose(expected[n], atol=1e-9)
        assert cell.scene.get_object(n).pose.isclose(expected[n], atol=1e-9)


def test_physics_tracks_a_full_speed_move(cell):
    arm = cell.robot.group("arm")
    c = cell.controller("arm")
    q0 = c.current_positions()
    q1 = np.array([1.2, -0.3, 0.2, 1.0, -0.8, 1.5])
    traj = time_optimal(arm, np.array([q0, q1]))
    h = c.execute(traj)
    assert h.wait(30) and h.result.success
    assert h.result.max_tracking_error < 2e-3  # [rad], at any joint, any step
    assert np.allclose(c.current_positions(), q1, atol=2e-3)


def test_stop_and_preempt_in_physics(cell):
    arm = cell.robot.group("arm")
    c = cell.controller("arm")
    q0 = c.current_positions()
    traj = ptp(arm, q0, q0 + [2.0, 0, 0, 0, 0, 0], velocity_scaling=0.2)
    h = c.execute(traj)
    t0 = cell.world.time
    while cell.world.time < t0 + 0.3:
        time.sleep(0.001)
    c.stop()
    assert h.result.status is ExecutionStatus.PREEMPTED
    q_stop = c.current_positions()
    assert 0 < q_stop[0] - q0[0] < 2.0
    cell.world.step(200)
    q_hold = c.current_positions()
    assert np.allclose(q_hold, q_stop, atol=0.01)
    cell.world.step(200)
    assert np.allclose(c.current_positions(), q_hold, atol=1e-4)  # holds
    first = c.execute(ptp(arm, q_hold, q_hold + [0.5, 0, 0, 0, 0, 0], velocity_scaling=0.2))
    # the world steps in a thread of its own, as fast as it can: held still while the next
    # trajectory is built from where the arm is, or it may have moved on past the start
    # tolerance by the time that trajectory is submitted
    with cell.world.lock:
        q = c.current_positions()
        second = c.execute(ptp(arm, q, q + [0, 0.1, 0, 0, 0, 0]))
    assert first.result.status is ExecutionStatus.PREEMPTED
    assert second.wait(30) and second.result.success


def test_bad_trajectories_are_refused(cell):
    arm = cell.robot.group("arm")
    c = cell.controller("arm")
    with pytest.raises(ExecutionError, match="starts .* from the current state"):
        c.execute(ptp(arm, np.full(6, 0.2), np.full(6, 0.3)))
    with pytest.raises(ExecutionError, match="velocity"):
        c.execute(ptp(arm, np.zeros(6), np.full(6, 0.5)).scaled(0.5))
    assert np.allclose(c.current_positions(), 0, atol=1e-6)


def test_divergence_is_reported_and_the_world_reset(cell):
    w = cell.world
    start = w.object_pose("red_box")
    w.data.qvel[w._obj_qvel["red_box"]] = 1e6
    with pytest.raises(SimulationError, match="diverged"):
        w.step(5)
    assert w.object_pose("red_box").isclose(start, atol=1e-9)


def test_friction_grasp_holds_through_a_full_speed_transfer(cell):
    """Pick the red box from above, lift it and swing joint 1 at full speed: it stays in the
    fingers (friction only) and slips less than 5 mm."""
    arm = cell.move_group("arm")
    arm.set_end_effector_link("tcp")
    gripper = cell.move_group("gripper")
    w = cell.world
    box = "red_box"
    p = w.object_pose(box).position
    arm.set_pose_target(Pose.from_rpy(p[0], p[1], p[2] + 0.12, 0, math.pi / 2, 0))
    assert arm.go()
    cell.scene.allow_collision(box, ["gripper_left_finger", "gripper_right_finger", "conveyor"])
    assert arm.move_relative((0, 0, -0.12), frame="world").fraction == 1.0
    h = cell.controller("gripper").execute(
        ptp(gripper.group, gripper.get_current_joint_values(), [0.8])
    )
    assert h.wait(10)
    w.step(100)
    assert {"robot/gripper_left_finger", "robot/gripper_right_finger"} <= w.touching(box)
    cell.sync_scene()
    arm.attach_object(box)
    assert arm.move_relative((0, 0, 0.15), frame="world").fraction == 1.0
    cell.scene.allow_collision(box, "conveyor", False)

    def offset():
        q = w.robot_positions()[arm.group.indices]
        T = cell.scene.T_world_root @ fk(arm.group, q, "tcp")
        return T[:3, :3].T @ (w.object_pose(box).position - T[:3, 3])

    before = offset()
    arm.set_joint_value_target({"joint_1": 2.5})
    assert arm.go()
    w.step(100)
    assert w.object_pose(box).position[2] > 1.1  # still up in the air
    assert np.linalg.norm(offset() - before) < 5e-3


def test_kinematic_mode(tmp_path):
    cell = Cell.load("sorting", mode="kinematic", time_scale=0)
    assert cell.world is None
    arm = cell.move_group("arm")
    arm.set_joint_value_target([0.5, 0, 0, 0, 0, 0])
    assert arm.go()
    assert np.allclose(cell.scene.state.group_positions("arm"), [0.5, 0, 0, 0, 0, 0])
    assert cell.object_pose("red_box").isclose(cell.spec.object("red_box").pose)
    with pytest.raises(CellError, match="unknown mode"):
        Cell.load("sorting", mode="dream")
    with pytest.raises(CellError, match="unknown mode"):
        Cell.load("sorting", mode=["kinematic"])
    with pytest.raises(CellError, match="bundled: .*sorting"):
        Cell.load(None)
    with pytest.raises(CellError, match="unknown frame 'tool'"):
        cell.target_position("red_target", frame="tool")
    with pytest.raises(CellError, match="unknown target 'pink_target'"):
        cell.target_position("pink_target")
    assert np.allclose(cell.target_position("red_target"), [-0.4, 0.15, 0.2])
    assert np.allclose(cell.target_position("red_target", frame="world"), [-0.4, 0.15, 1.1])
    # names of the wrong kind: the same errors, not a TypeError or a ValueError from inside
    with pytest.raises(CellError, match="unknown fixture \\['tray'\\]"):
        cell.fixture_bounds(["tray"])
    with pytest.raises(CellError, match="unknown fixture array"):
        cell.inside("red_box", np.zeros(2))
    with pytest.raises(CellError, match="unknown object array"):
        cell.is_grasped(np.zeros(2))
    with pytest.raises(CellError, match="unknown object array"):
        cell.respawn(np.zeros(2))
    with pytest.raises(ModelError, match="unknown group \\['arm'\\]"):
        cell.controller(["arm"])


def test_a_cells_move_groups_plan_with_its_planner_settings(monkeypatch):
    """Cell.load(planner_config=...): every move group's plans are proven free by the
    continuous check when it asks for it."""
    cell = Cell.load(
        "sorting", mode="kinematic", time_scale=0, planner_config=PlannerConfig(continuous=True)
    )
    arm = cell.move_group("arm")
    assert arm.planner.config.continuous
    arm.set_joint_value_target([0.5, 0.2, 0.1, 0, 0.3, 0])
    plan = arm.plan()
    assert plan.success and plan.stats["swept_tests"] > 0
    path = BlendedPath(plan.path, plan.stats["corner_deviation"])
    assert cell.scene.checker("arm").swept().check_path(path).free
    # and its Cartesian motions as they will run (the spline through their steps)
    from robocell.cell import move_group as move_group_module

    asked = []
    real = move_group_module.compute_cartesian_path

    def spy(*args, **kwargs):  # type: ignore[no-untyped-def]
        asked.append(kwargs.get("continuous"))
        return real(*args, **kwargs)

    monkeypatch.setattr(move_group_module, "compute_cartesian_path", spy)
    arm.execute(plan)
    up = arm.compute_cartesian_path([arm.get_current_pose() * Pose([0.0, 0.0, -0.05])])
    assert asked == [PlannerConfig().continuous_tolerance] and up.fraction == 1.0
    plain = Cell.load("sorting", mode="kinematic", time_scale=0).move_group("arm")
    assert not plain.planner.config.continuous
    assert plain._continuous() is None


def test_cameras(cell):
    rgb = cell.world.render("overhead")
    depth = cell.world.render("overhead", depth=True)
    assert rgb.shape == (480, 640, 3) and rgb.dtype == np.uint8 and rgb.std() > 5
    assert depth.shape == (480, 640)
    # the conveyor top (z = 1.0) is 1.2 m under the overhead camera at z = 2.2
    assert float(np.median(depth[200:280, 280:360])) == pytest.approx(1.2, abs=0.05)
    with pytest.raises(SimulationError, match="unknown camera 'top'; known: front, overhead"):
        cell.world.render("top")
