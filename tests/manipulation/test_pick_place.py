"""Pick and place on the sorting cell, in physics and in kinematic mode: the object really ends
in its tray; failures say which stage of which candidate failed and why."""

import numpy as np
import pytest

from robocell import Pose
from robocell.cell import Cell
from robocell.errors import GraspError
from robocell.grasping import generate_grasps, generate_places
from robocell.grasping.grasp import Grasp
from robocell.manipulation import Manipulator


@pytest.mark.parametrize("mode", ["physics", "kinematic"])
@pytest.mark.parametrize("name, tray", [("red_box", "red_tray"), ("blue_ball", "blue_tray")])
def test_pick_and_place_into_the_tray(mode, name, tray):
    cell = Cell.load("sorting", mode=mode, time_scale=0)
    man = Manipulator(cell)
    o = cell.spec.object(name)
    T = cell.object_pose(name)
    grasps = generate_grasps(name, o.shape, T, man.geometry, cell.scene, "arm")
    picked = man.pick(name, grasps)
    assert picked.success, picked.reason
    assert name in cell.scene.attached_objects
    if mode == "physics":
        assert cell.is_grasped(name)
        assert cell.world.object_pose(name).position[2] > T.position[2] + 0.03  # lifted
    g = next(x for x in grasps if x.id == picked.candidate)
    # at the cell's place point for that tray (the seed's: inside the trays at the edge of reach)
    target = cell.target_position(tray.replace("tray", "target"), frame="world")
    floor = next(x for x in cell.spec.fixtures if x.name == tray).pose.position[2] + 0.01
    z = floor + 0.5 * o.size[2] + 0.005
    placed = man.place(name, generate_places(name, [target[0], target[1], z], g, T))
    assert placed.success, placed.reason
    assert name not in cell.scene.attached_objects
    assert cell.inside(name, tray)
    assert picked.robot_time > 0 and placed.robot_time > 0


def test_failures_name_the_stage_and_the_candidate():
    cell = Cell.load("sorting", mode="kinematic", time_scale=0)
    man = Manipulator(cell)
    o = cell.spec.object("red_box")
    T = cell.object_pose("red_box")
    good = generate_grasps("red_box", o.shape, T, man.geometry)[0]
    # the same grasp 1.5 m away: no arm reaches its pre-grasp
    far = Grasp(
        **{
            **good.__dict__,
            "id": "far",
            "pose": Pose(good.pose.position + [1.5, 0, 0], good.pose.orientation),
        }
    )
    result = man.pick("red_box", [far])
    assert not result.success
    assert result.failures()[0].candidate == "far"
    assert result.failures()[0].stage in ("move", "plan")
    assert "far" in result.reason
    assert "red_box" not in cell.scene.attached_objects  # nothing half-done
    with pytest.raises(GraspError, match="unknown object 'red_bx'"):
        man.pick("red_bx", [good])
    with pytest.raises(GraspError, match="not held"):
        man.place("red_box", [])
    # the next call works
    assert man.pick(
        "red_box", generate_grasps("red_box", o.shape, T, man.geometry, cell.scene, "arm")
    ).success
    assert np.isfinite(cell.object_pose("red_box").position).all()


def test_a_pick_stops_when_the_object_moved_during_it():
    """Grasps are made for where the object was: once a failed candidate has knocked it
    elsewhere, trying the rest of them is wasted motion. The pick says so, and fresh grasps
    work."""
    cell = Cell.load("sorting", mode="physics", time_scale=0)
    man = Manipulator(cell)
    o = cell.spec.object("red_box")
    T = cell.object_pose("red_box")
    grasps = generate_grasps("red_box", o.shape, T, man.geometry, cell.scene, "arm")
    assert len(grasps) > 1
    gripper, calls = man._gripper, []

    def knocked(command: float) -> None:
        gripper(command)
        calls.append(command)
        if len(calls) == 2:  # the first close: the box is knocked 10 cm away
            cell.world.set_object_pose(
                "red_box", Pose(T.position + [0.1, 0.0, 0.005], T.orientation)
            )
            cell.world.step(300)

    man._gripper = knocked  # type: ignore[method-assign]
    result = man.pick("red_box", grasps)
    assert not result.success
    assert "moved" in result.reason, result.reason
    assert len({st.candidate for st in result.stages}) == 1  # no other candidate was tried
    man._gripper = gripper  # type: ignore[method-assign]
    fresh = generate_grasps(
        "red_box", o.shape, cell.object_pose("red_box"), man.geometry, cell.scene, "arm"
    )
    assert man.pick("red_box", fresh).success
