"""Each of the sorting cell's eight objects, gripped from above by friction alone (no grasp
assist), stays in the gripper through a full-speed swing of joint 1 with < 5 mm of slip."""

import math

import pytest

from robocell import Pose
from robocell.cell import Cell
from robocell.trajectory import ptp

OBJECTS = [
    "yellow_box", "red_box", "blue_box", "blue_ball", "yellow_ball", "green_ball",
    "green_cylinder", "red_cylinder",
]  # fmt: skip


@pytest.fixture(scope="module")
def cell():
    return Cell.load("sorting")


@pytest.mark.parametrize("name", OBJECTS)
def test_object_held_through_a_full_speed_transfer(cell, name):
    cell.reset()
    w = cell.world
    o = cell.spec.object(name)
    z = 1.0 + 0.5 * o.size[2]
    for k, other in enumerate(n for n in cell.object_names if n != name):
        oz = 1.0 + 0.5 * cell.spec.object(other).size[2]
        w.set_object_pose(other, Pose([0.45 + 0.15 * (k % 3), 0.7 + 0.15 * (k // 3), oz]))
    w.set_object_pose(name, Pose([0.45, 0.0, z]))
    w.step(50)
    cell.sync_scene()
    arm = cell.move_group("arm")
    arm.set_end_effector_link("tcp")
    gripper = cell.move_group("gripper")
    top = 1.0 + o.size[2]
    z_tcp = max(z, top - 0.035, 1.0 + 0.023)
    yaw = math.pi / 2 if o.size[1] > o.size[0] + 1e-9 else 0.0  # fingers across the narrow side
    arm.set_pose_target(Pose.from_rpy(0.45, 0.0, z_tcp + 0.12, 0, math.pi / 2, yaw))
    assert arm.go()
    cell.scene.allow_collision(name, ["gripper_left_finger", "gripper_right_finger", "conveyor"])
    assert arm.move_relative((0, 0, -0.12), frame="world").fraction == 1.0
    assert not cell.is_grasped(name)
    cell.controller("gripper").execute(
        ptp(gripper.group, gripper.get_current_joint_values(), [0.8])
    ).wait()
    w.step(100)
    assert cell.is_grasped(name)
    cell.sync_scene()
    arm.attach_object(name)
    assert arm.move_relative((0, 0, 0.15), frame="world").fraction == 1.0
    cell.scene.allow_collision(name, "conveyor", False)
    before = cell.held_offset(name)
    arm.set_joint_value_target({"joint_1": 2.5})
    assert arm.go()
    w.step(100)
    assert cell.is_grasped(name)
    assert not cell.has_slipped(name, before, tolerance=0.005)
    assert w.object_pose(name).position[2] > 1.1
    arm.detach_object(name)


def test_respawn(cell):
    cell.reset()
    cell.world.set_object_pose("green_ball", Pose([0.3, 0.3, 2.0]))
    cell.world.step(200)
    cell.respawn("green_ball")
    assert cell.world.object_pose("green_ball").isclose(cell.spec.object("green_ball").pose)
    assert cell.scene.get_object("green_ball").pose.isclose(cell.spec.object("green_ball").pose)
