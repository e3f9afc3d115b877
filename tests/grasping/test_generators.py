"""Gripper geometry read from the description; grasp and place candidates."""

import numpy as np
import pytest

from robocell import Pose
from robocell.cell import Cell
from robocell.errors import GraspError
from robocell.geometry.shapes import Box, Mesh
from robocell.grasping import GripperGeometry, generate_grasps, generate_places
from robocell.kinematics import fk


@pytest.fixture(scope="module")
def cell():
    return Cell.load("sorting", mode="kinematic", time_scale=0)


@pytest.fixture(scope="module")
def gripper(cell):
    return GripperGeometry.from_robot(cell.robot, "gripper")


def test_gripper_geometry_from_the_description(gripper, ur5e):
    # the spec: 85 mm open at 0, closed at 0.8, linear; TCP 0.15 m along tool0's x
    assert gripper.eef_link == "tool0" and gripper.tcp_link == "tcp"
    assert np.allclose(gripper.approach, [1, 0, 0])
    assert abs(gripper.closing @ gripper.approach) < 1e-9
    assert gripper.open_width == pytest.approx(0.085, abs=1e-6)
    assert gripper.closed_width == pytest.approx(0.0, abs=1e-6)
    assert gripper.command_for(0.05) == pytest.approx(0.8 * (1 - 0.05 / 0.085))
    assert np.allclose(gripper.T_eef_tcp[:3, 3], [0.15, 0, 0])
    g2 = GripperGeometry.from_robot(ur5e, "gripper")
    assert g2.open_command == pytest.approx(0.04) and g2.closed_command == pytest.approx(0.0)
    assert g2.open_width > g2.closed_width
    with pytest.raises(GraspError, match="no end effector uses group 'arm'"):
        GripperGeometry.from_robot(ur5e, "arm")


def test_every_object_of_the_cell_has_a_reachable_grasp(cell, gripper):
    arm = cell.robot.group("arm")
    for o in cell.spec.objects:
        grasps = generate_grasps(
            o.name, o.shape, cell.object_pose(o.name), gripper, cell.scene, "arm"
        )
        assert grasps, o.name
        assert [g.quality for g in grasps] == sorted((g.quality for g in grasps), reverse=True)
        for g in grasps[:3]:
            assert g.width <= gripper.open_width
            # the IK solution puts tool0 exactly at the grasp pose
            T = cell.scene.T_world_root @ fk(arm, g.joint_positions, "tool0")
            assert np.allclose(T, g.pose.matrix(), atol=1e-5)
            # collision-free, the object touching only the gripper's links
            work = cell.scene.copy()
            work.allow_collision(o.name, cell.robot.group("gripper").link_names)
            work.set_object_padding(o.name, 0.0)  # the gripper goes right up to it
            assert not work.checker(arm).check(g.joint_positions)[0]
        # beyond the wrist's reach from above, only side grasps
        if o.pose.position[0] > 0.6:
            assert all(g.kind == "side" for g in grasps), o.name


def test_candidates_respect_the_stroke(gripper):
    wide = Box((0.2, 0.2, 0.05))
    assert generate_grasps("slab", wide, Pose([0.4, 0, 0.025]), gripper) == []
    narrow = Box((0.03, 0.2, 0.05))
    grasps = generate_grasps("bar", narrow, Pose([0.4, 0, 0.025]), gripper)
    assert grasps and all(g.width <= 0.085 for g in grasps)
    # across the 3 cm side: the closing axis is the box's x
    best = grasps[0]
    closing_world = best.tcp.rotation() @ np.array([0.0, -1.0, 0.0])  # tcp frame = tool0's
    assert abs(closing_world @ [1, 0, 0]) > 0.99


def test_bad_input(gripper):
    mesh = Mesh(np.eye(3), np.array([[0, 1, 2]]))
    with pytest.raises(GraspError, match="boxes, cylinders and spheres"):
        generate_grasps("m", mesh, Pose(), gripper)
    with pytest.raises(GraspError, match="yaw_step_deg"):
        generate_grasps("b", Box((0.05, 0.05, 0.05)), Pose(), gripper, yaw_step_deg=0)
    # values of the wrong kind: a GraspError naming them, not a TypeError from inside
    with pytest.raises(GraspError, match="object id"):
        generate_grasps(["b"], Box((0.05, 0.05, 0.05)), Pose(), gripper)
    with pytest.raises(GraspError, match="Shape"):
        generate_grasps("b", (0.05, 0.05, 0.05), Pose(), gripper)
    with pytest.raises(GraspError, match="Pose"):
        generate_grasps("b", Box((0.05, 0.05, 0.05)), [0, 0, 0], gripper)


def test_places_put_the_object_at_the_target(cell, gripper):
    o = cell.spec.object("red_box")
    T_obj = cell.object_pose("red_box")
    g = generate_grasps(o.name, o.shape, T_obj, gripper, cell.scene, "arm")[0]
    target = np.array([-0.4, 0.15, 0.8])
    places = generate_places("red_box", target, g, T_obj)
    assert len(places) == 4
    for p in places:
        assert np.allclose(p.object_pose.position, target)
        # the object keeps its offset in the gripper
        rel_grasp = T_obj.inverse() * g.pose
        rel_place = p.object_pose.inverse() * p.pose
        assert rel_grasp.isclose(rel_place, atol=1e-9, rot_atol=1e-9)
        assert p.pre_place_approach.direction == (0.0, 0.0, -1.0)
    with pytest.raises(GraspError, match="3 finite numbers"):
        generate_places("red_box", [0, np.nan, 0], g, T_obj)


def test_straight_lines_near_the_wrist_singularity_stay_within_the_limits(irb120):
    """A push's lines are followed by IK before the push is offered: near the wrist's
    singularity a 3 cm sideways line turns joint 4 by about a radian, so from joint 4 at 2.6
    rad (limit 2.79) one way leaves the limits and the other does not; the line's end
    configuration puts the tool at the line's end."""
    from robocell.grasping.generators import _line_ok

    arm = irb120.group("arm")
    q = np.array([0.0, 0.3, 0.2, 2.6, 0.05, 0.0])
    T = fk(arm, q, "tool0")
    assert _line_ok(arm, "tool0", T, q, np.array([0.0, 0.03, 0.0])) is None
    end = _line_ok(arm, "tool0", T, q, np.array([0.0, -0.03, 0.0]))
    assert end is not None and abs(end[3] - q[3]) > 0.5
    assert np.all(end >= arm.lower) and np.all(end <= arm.upper)
    T_end = fk(arm, end, "tool0")
    assert np.allclose(T_end[:3, 3], T[:3, 3] + [0.0, -0.03, 0.0], atol=1e-6)
    assert np.allclose(T_end[:3, :3], T[:3, :3], atol=1e-6)
    # away from the singularity the same line barely turns the wrist
    q0 = np.array([0.0, 0.3, 0.2, 0.0, 0.8, 0.0])
    end0 = _line_ok(arm, "tool0", fk(arm, q0, "tool0"), q0, np.array([0.0, 0.03, 0.0]))
    assert end0 is not None and abs(end0[3] - q0[3]) < 0.3


@pytest.mark.parametrize("axis", [0, 1])
def test_a_box_lying_on_its_side_gets_the_grasps_of_an_upright_one(gripper, axis):
    """A box a push tipped over rests on another face: its grasps are those of an upright box
    with its axes relabelled (same poses, widths and kinds)."""
    import math

    size = (0.03, 0.10, 0.04)
    c = np.array([0.45, 0.1, 1.0])
    # lying: rotated a quarter turn about its x (or y) axis
    R = np.eye(3)
    a, b = (1, 2) if axis == 0 else (2, 0)
    R[a, a] = R[b, b] = 0.0
    R[a, b], R[b, a] = -1.0, 1.0
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c
    lying = generate_grasps("b", Box(size), Pose.from_matrix(T), gripper)
    assert lying
    # the same box described upright: the size along the world's axes
    world = np.abs(R) @ np.array(size)
    upright = generate_grasps("b", Box(tuple(world)), Pose(c, (0, 0, 0, 1)), gripper)
    key = lambda g: (g.kind, round(g.width, 5), tuple(np.round(g.pose.position, 5) + 0.0))  # noqa: E731
    assert sorted(map(key, lying)) == sorted(map(key, upright))
    assert math.isclose(max(g.quality for g in lying), max(g.quality for g in upright))


@pytest.mark.parametrize(
    ("name", "off_deg", "ccw"),
    [
        ("red_box", 60.0, True),  # a cube: either axis on the radial line will do, 30° ccw
        ("red_box", 20.0, False),  # 20° cw
        ("blue_box", 60.0, False),  # only its long axis (x): 60° cw, not 120° ccw
    ],
)
def test_pushes_turn_a_box_the_shorter_way_to_a_pinch(cell, gripper, name, off_deg, ccw):
    """Pushes turn a box toward the nearest orientation with a pinch across the line to the
    base: a square box's faces are all pinchable (never more than 45° away), a slender box's
    only across its short side. The turn's sense is that of the push's moment about the box's
    centre."""
    from robocell.grasping import generate_pushes

    scene = cell.scene.copy()
    for other in cell.object_names:
        if other != name:
            scene.remove_object(other)
    base = scene.link_pose("base_link").position
    c = np.array([0.62, -0.22, cell.object_pose(name).position[2]])
    radial = np.arctan2(c[1] - base[1], c[0] - base[0])
    yaw = radial + np.radians(off_deg)  # the box's x axis off the radial line
    T = Pose(c, (0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)))
    scene.move_object(name, T)
    o = cell.spec.object(name)
    pushes = generate_pushes(name, o.shape, T, gripper, scene, "arm")
    assert pushes
    for p in pushes:
        lever = np.asarray(p.contact) - c
        moment = lever[0] * p.push.direction[1] - lever[1] * p.push.direction[0]
        assert (moment > 0) == ccw, p.id
