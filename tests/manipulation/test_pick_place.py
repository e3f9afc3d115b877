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
    # values of the wrong kind: a GraspError, not a TypeError or AttributeError from inside
    with pytest.raises(GraspError, match="unknown object"):
        man.pick(["red_box"], [good])
    with pytest.raises(GraspError, match="list of Grasp"):
        man.pick("red_box", good)
    with pytest.raises(GraspError, match="list of Grasp"):
        man.pick("red_box", ["good"])
    with pytest.raises(GraspError, match="not held"):
        man.release(["red_box"])
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


def _yaw(T: Pose) -> float:
    R = T.rotation()
    return float(np.arctan2(R[1, 0], R[0, 0]))


def test_a_push_turns_a_box_whose_pinch_is_out_of_reach():
    """The blue box at the far edge, its long side facing the robot: no pinch reaches it. A push
    near one end of its near face turns it toward the line to the robot (the shorter way round,
    as generate_pushes predicts), keeps it upright on the conveyor, and a few pushes make it
    graspable."""
    from robocell.grasping import generate_pushes

    cell = Cell.load("sorting", mode="physics", time_scale=0)
    man = Manipulator(cell)
    name = "blue_box"
    o = cell.spec.object(name)
    start = cell.object_pose(name)
    # at (0.67, -0.15) (the robot's base is above the origin), its long axis 75° from the line
    # to the robot; the red box, in front of it, out of the way
    yaw = np.arctan2(-0.15, 0.67) + np.radians(75)
    c, s = np.cos(yaw / 2), np.sin(yaw / 2)
    cell.world.set_object_pose(name, Pose((0.67, -0.15, start.position[2]), (0.0, 0.0, s, c)))
    red = cell.object_pose("red_box")
    cell.world.set_object_pose("red_box", Pose((0.45, -0.6, red.position[2])))
    cell.world.step(200)
    cell.sync_scene()
    T = cell.object_pose(name)
    assert not generate_grasps(name, o.shape, T, man.geometry, cell.scene, "arm")
    turns = 0
    before = T
    while turns < 4:
        pushes = generate_pushes(name, o.shape, before, man.geometry, cell.scene, "arm")
        assert pushes, "no push reaches the box"
        pushed = man.push(name, pushes)
        assert pushed.success, pushed.reason
        turns += 1
        after = cell.object_pose(name)
        # turned clockwise (toward the line to the robot, 75° away the short way)
        turn = np.degrees(np.angle(np.exp(1j * (_yaw(after) - _yaw(before)))))
        assert -60 < turn < -3, turn
        assert after.rotation()[2, 2] > 0.99  # upright
        assert abs(after.position[2] - start.position[2]) < 0.005  # on the conveyor
        if generate_grasps(name, o.shape, after, man.geometry, cell.scene, "arm"):
            break
        before = after
    assert generate_grasps(name, o.shape, cell.object_pose(name), man.geometry, cell.scene, "arm")


def test_a_push_that_moves_nothing_is_not_reported_done():
    """A push that passes the object by (here 8 cm above it) fails, says so, and the next
    candidate is tried."""
    from dataclasses import replace

    from robocell.grasping import generate_pushes

    cell = Cell.load("sorting", mode="physics", time_scale=0)
    man = Manipulator(cell)
    name = "red_box"
    o = cell.spec.object(name)
    before = cell.object_pose(name)
    pushes = generate_pushes(name, o.shape, before, man.geometry, cell.scene, "arm")
    assert pushes
    up = pushes[0].pose.position + np.array([0.0, 0.0, 0.08])
    air = replace(pushes[0], id="air", pose=Pose(up, pushes[0].pose.orientation),
                  joint_positions=None)  # fmt: skip
    result = man.push(name, [air])
    assert not result.success
    assert "did not move" in result.reason
    assert [s.stage for s in result.stages if not s.success] == ["push"]
    assert np.linalg.norm(cell.object_pose(name).position - before.position) < 0.002


def test_push_refuses_bad_input():
    from robocell.grasping import generate_pushes

    cell = Cell.load("sorting", mode="physics", time_scale=0)
    man = Manipulator(cell)
    ball = cell.spec.object("blue_ball")
    with pytest.raises(GraspError, match="boxes"):
        generate_pushes("blue_ball", ball.shape, cell.object_pose("blue_ball"), man.geometry,
                        cell.scene, "arm")  # fmt: skip
    with pytest.raises(GraspError, match="unknown object"):
        man.push("purple_box", [])
    kinematic = Cell.load("sorting", mode="kinematic", time_scale=0)
    with pytest.raises(GraspError, match="physics"):
        Manipulator(kinematic).push("red_box", [])


def test_a_held_object_keeps_its_padding_clear_of_the_world():
    """A held object's padding counts in collision checks (it swings a little in the fingers),
    and it may touch every link of the hand, the gripper's body included."""
    cell = Cell.load("sorting", mode="kinematic", time_scale=0)
    man = Manipulator(cell)
    name = "red_box"
    o = cell.spec.object(name)
    grasps = generate_grasps(name, o.shape, cell.object_pose(name), man.geometry, cell.scene, "arm")
    assert man.pick(name, grasps).success
    scene = cell.scene
    att = scene.attached_objects[name]
    assert {"gripper_base_link", *man.finger_links} <= att.touch_links
    arm = scene.robot.group("arm")
    q = scene.state.group_positions(arm)
    box = scene.link_pose(att.link) * att.object.pose
    bottom = box.position[2] - 0.5 * o.size[2]
    # a plate 5 mm under the held box: clear without padding, hit with 1 cm of it
    scene.add_box("plate", Pose((box.position[0], box.position[1], bottom - 0.005 - 0.005)),
                  (0.2, 0.2, 0.01))  # fmt: skip
    scene.set_object_padding(name, 0.0)
    assert not scene.checker(arm).check(q[None])[0]
    scene.set_object_padding(name, 0.01)
    assert scene.checker(arm).check(q[None])[0]
    assert ("plate", name) in {tuple(sorted(p)) for p in scene.colliding_pairs(q, "arm")} or (
        name,
        "plate",
    ) in {tuple(p) for p in scene.colliding_pairs(q, "arm")}
