"""The exercise API's contracts (../shared/specs/sorting_cell.md, "The exercise API"): frames,
conventions, grasp construction, motion commands, and bad input that changes nothing."""

import math

import numpy as np
import pytest

from robocell.errors import GraspError, PlanningError, RobocellError
from robocell.exercise import WORKSPACE_WARNING, PickPlace, Point, PoseMsg, in_workspace
from robocell.geometry.pose import rpy_to_matrix


@pytest.fixture(scope="module")
def pp():
    lines: list[str] = []
    api = PickPlace("sorting", mode="kinematic", printer=lines.append)
    api.lines = lines  # type: ignore[attr-defined]
    return api


def _snapshot(api):
    cell = api.cell
    return (
        cell.scene.state.positions.copy(),
        {n: cell.object_pose(n).position.copy() for n in cell.object_names},
        dict(cell.scene.attached_objects),
    )


def _same(a, b):
    assert np.array_equal(a[0], b[0])
    assert all(np.array_equal(a[1][k], b[1][k]) for k in a[1])
    assert a[2].keys() == b[2].keys()


def test_lists_and_info(pp):
    assert pp.get_object_list() == [
        "yellow_box", "red_box", "blue_box", "blue_ball",
        "yellow_ball", "green_ball", "green_cylinder", "red_cylinder",
    ]  # fmt: skip
    assert set(pp.get_target_list()) == {
        "red_target",
        "green_target",
        "blue_target",
        "yellow_target",
    }
    pose, h, w, length, shape, color = pp.get_object_info("blue_box")
    assert (h, w, length, shape, color) == (0.07, 0.05, 0.10, "box", "blue")
    # robot frame: the base is 0.9 m above the world's floor, the conveyor top at 0.1
    assert pose.position.x == pytest.approx(0.65) and pose.position.y == pytest.approx(-0.10)
    assert pose.position.z == pytest.approx(0.1 + 0.035)
    _, h, w, length, shape, _ = pp.get_object_info("green_cylinder")
    assert (h, w, length, shape) == (0.10, 0.06, 0.06, "cylinder")
    _, h, w, length, shape, _ = pp.get_object_info("yellow_ball")
    assert (h, w, length, shape) == (0.03, 0.03, 0.03, "sphere")


def test_object_pose_is_live(pp):
    cell = pp.cell
    before = pp.get_object_pose("red_box")
    T = cell.object_pose("red_box")
    cell.scene.move_object("red_box", type(T)(T.position + [0.0, 0.01, 0.0], T.orientation))
    try:
        assert pp.get_object_pose("red_box").position.y == pytest.approx(before.position.y + 0.01)
    finally:
        cell.scene.move_object("red_box", T)


def test_target_position_is_a_copy(pp):
    p = pp.get_target_position("blue_target")
    assert (p.x, p.y, p.z) == pytest.approx((-0.4, 0.39, 0.2))
    p.z += 0.1
    assert pp.get_target_position("blue_target").z == pytest.approx(0.2)


def test_pose_messages_round_trip_and_follow_tf():
    m = PickPlace.pose2msg(0.1, -0.4, 2.0, 0.3, -0.2, 0.5)
    assert PickPlace.msg2pose(m) == pytest.approx((0.1, -0.4, 2.0, 0.3, -0.2, 0.5))
    d = PickPlace.pose2msg_deg(10, 20, 30, 1, 2, 3)
    assert PickPlace.msg2pose_deg(d) == pytest.approx((10, 20, 30, 1, 2, 3))
    # static x-y-z: R = Rz(yaw) Ry(pitch) Rx(roll); quaternion (x, y, z, w)
    q = PickPlace.pose2msg(0, math.pi / 2, 0, 0, 0, 0).orientation
    assert (q.x, q.y, q.z, q.w) == pytest.approx((0, math.sqrt(0.5), 0, math.sqrt(0.5)))
    R = m.to_pose().rotation()
    assert np.allclose(R, rpy_to_matrix(0.1, -0.4, 2.0))


def test_generate_grasp_geometry(pp):
    ball = pp.get_object_pose("blue_ball").position
    g = pp.generate_grasp("blue_ball", "vertical", ball, 0.3, length=0.15)
    base = pp.cell.robot_spec.pose
    tool0 = (base.inverse() * g.pose).position
    # vertical: tool0's x points down; tool0 is `length` above the given point
    assert tool0 == pytest.approx([ball.x, ball.y, ball.z + 0.15])
    assert (base.inverse() * g.pose).rotation()[:, 0] == pytest.approx([0, 0, -1], abs=1e-9)
    # the tcp (fingertips) is at the ball's centre
    assert (base.inverse() * g.tcp).position == pytest.approx(list(ball), abs=1e-9)
    assert g.grasp_posture == 0.3 and g.pre_grasp_posture == 0.0
    assert g.width == pytest.approx(0.085 * (1 - 0.3 / 0.8))
    # default approach: down, min 0.1, desired 0.2; retreat opposite
    assert g.pre_grasp_approach.direction == pytest.approx((0, 0, -1))
    assert (g.pre_grasp_approach.min_distance, g.pre_grasp_approach.desired_distance) == (0.1, 0.2)
    assert g.post_grasp_retreat.direction == pytest.approx((0, 0, 1))
    # horizontal: tool0 along x, pitched; user_defined: every angle
    h = pp.generate_grasp("blue_ball", "horizontal", ball, pitch=30)
    R = (base.inverse() * h.pose).rotation()
    assert np.allclose(R, rpy_to_matrix(0, math.radians(30), 0))
    u = pp.generate_grasp("blue_ball", "user_defined", ball, roll=10, pitch=20, yaw=30)
    assert np.allclose(
        (base.inverse() * u.pose).rotation(), rpy_to_matrix(*np.radians([10, 20, 30]))
    )


def test_width_zero_is_chosen_from_the_object(pp):
    ball = pp.get_object_pose("blue_ball").position
    g = pp.generate_grasp("blue_ball", "vertical", ball, length=0.15)
    # closes 1 cm below the ball's 60 mm diameter: it presses the ball
    assert g.width == pytest.approx(0.05, abs=1e-9)
    box = pp.get_object_pose("blue_box").position
    # vertical, yaw 0: the fingers close along the robot's y, across the box's 5 cm side
    g = pp.generate_grasp("blue_box", "vertical", box, length=0.15)
    assert g.width == pytest.approx(0.04, abs=1e-6)
    # across its 10 cm side it is wider than the gripper opens: the value stays at open
    g = pp.generate_grasp("blue_box", "vertical", box, yaw=90, length=0.15)
    assert g.grasp_posture == 0.0 and g.width == pytest.approx(0.085)


def test_grasp_settings(pp):
    try:
        pp.set_grasp_direction(1, 0, 0)
        pp.set_grasp_distance(0.05, 0.08)
        g = pp.generate_grasp("red_box", "horizontal", [0.3, 0.0, 0.2])
        assert g.pre_grasp_approach.direction == pytest.approx((1, 0, 0))
        assert g.post_grasp_retreat.direction == pytest.approx((-1, 0, 0))
        assert g.pre_grasp_approach.min_distance == 0.05
        assert g.pre_grasp_approach.desired_distance == 0.08
    finally:
        pp.set_grasp_direction(0, 0, -0.5)
        pp.set_grasp_distance(0.1, 0.2)


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda p: p.get_object_pose("purple_box"), ["purple_box", "blue_ball"]),
        (lambda p: p.get_target_position("black_target"), ["black_target", "red_target"]),
        (
            lambda p: p.generate_grasp("red_box", "diagonal", [0.4, 0, 0.2]),
            ["diagonal", "vertical"],
        ),
        (lambda p: p.generate_grasp("red_box", "vertical", [0.4, 0, 0.2], 0.9), ["0.8", "0.9"]),
        (lambda p: p.generate_grasp("red_box", "vertical", [0.4, 0, 0.2], -0.1), ["[0, 0.8]"]),
        (lambda p: p.generate_grasp("nope", "vertical", [0.4, 0, 0.2]), ["nope", "red_box"]),
        (lambda p: p.generate_grasp("red_box", "vertical", [0.4, 0]), ["three"]),
        (lambda p: p.set_grasp_distance(0.3, 0.1), ["min_distance"]),
        (lambda p: p.set_grasp_direction(0, 0, 0), ["non-zero"]),
        (lambda p: p.move_joint_hand(1.2), ["[0, 0.8]", "1.2"]),
        (lambda p: p.move_joint_arm(0, 0, 0, 0, 3.0, 0), ["joint_4", "joint_5", "limits"]),
        (lambda p: p.place("vertical", [-0.4, 0.39, 0.2]), ["nothing is held"]),
        (lambda p: p.place("sideways", [-0.4, 0.39, 0.2]), ["sideways", "user_defined"]),
        (lambda p: p.place("vertical", [-0.4, 0.39, 0.2], distance=-1), ["distance"]),
        (lambda p: p.pickup("red_box", []), ["generate_grasp"]),
        (lambda p: p.pickup("purple_box", []), ["purple_box"]),
    ],
)
def test_bad_input_names_the_item_and_changes_nothing(pp, call, words):
    before = _snapshot(pp)
    with pytest.raises(RobocellError) as e:
        call(pp)
    for w in words:
        assert w in str(e.value)
    _same(before, _snapshot(pp))


# values of the wrong kind, as a student's slip makes them (a list for a name, a string
# for a number, None): a RobocellError, as for a bad value, and nothing changes
NUMBERS = [None, "abc", [1, 2], np.zeros(3), {"x": 1}, float("inf")]
NAMES = [None, [1, 2], np.zeros(3), {"x": 1}, 3.5]
P = [0.4, 0.0, 0.2]
API_CALLS = {
    "get_object_pose": (lambda p, v: p.get_object_pose(v), NAMES),
    "get_object_info": (lambda p, v: p.get_object_info(v), NAMES),
    "get_target_position": (lambda p, v: p.get_target_position(v), NAMES),
    "move_joint_arm": (lambda p, v: p.move_joint_arm(v, 0, 0, 0, 0, 0), NUMBERS),
    "move_joint_hand": (lambda p, v: p.move_joint_hand(v), NUMBERS),
    "set_grasp_distance": (lambda p, v: p.set_grasp_distance(v, 0.2), NUMBERS),
    "set_grasp_direction": (lambda p, v: p.set_grasp_direction(0, v, -1), NUMBERS),
    "generate_grasp (object)": (lambda p, v: p.generate_grasp(v, "vertical", P), NAMES),
    "generate_grasp (orientation)": (lambda p, v: p.generate_grasp("red_box", v, P), NAMES),
    "generate_grasp (length)": (
        lambda p, v: p.generate_grasp("red_box", "vertical", P, length=v),
        NUMBERS,
    ),
    "generate_grasp (yaw)": (
        lambda p, v: p.generate_grasp("red_box", "vertical", P, yaw=v),
        NUMBERS,
    ),
    "pickup (object)": (
        lambda p, v: p.pickup(v, [p.generate_grasp("red_box", "vertical", P)]),
        NAMES,
    ),
    "pickup (grasps)": (lambda p, v: p.pickup("red_box", v), [*NUMBERS, 3.5]),
    "place (orientation)": (lambda p, v: p.place(v, P), NAMES),
    "place (distance)": (lambda p, v: p.place("vertical", P, v), NUMBERS),
}


@pytest.mark.parametrize("name", API_CALLS)
def test_values_of_the_wrong_kind_get_a_robocell_error(pp, name):
    call, values = API_CALLS[name]
    for v in values:
        before = _snapshot(pp)
        with pytest.raises(RobocellError):
            call(pp, v)
        _same(before, _snapshot(pp))


def test_errors_are_the_right_kind(pp):
    with pytest.raises(GraspError):
        pp.generate_grasp("red_box", "vertical", [0.4, 0, 0.2], 0.9)
    with pytest.raises(PlanningError):
        pp.move_joint_arm(0, 0, 0, 0, 3.0, 0)


def test_workspace_warning_then_a_clean_failure_and_the_next_call_works(pp):
    assert in_workspace([0.374, 0.0, 0.63]) and not in_workspace([0.9, 0.0, 0.3])
    assert not in_workspace([0.0, 0.0, 0.3])  # inside the inner sphere
    assert not in_workspace([0.3, 0.0, -0.2])  # below the lowest point
    pp.lines.clear()
    before = _snapshot(pp)
    assert pp.move_pose_arm(PickPlace.pose2msg_deg(0, 90, 0, 0.9, 0.0, 0.3)) is False
    assert WORKSPACE_WARNING in pp.lines
    _same(before, _snapshot(pp))
    pp.lines.clear()
    pp.generate_grasp("red_box", "vertical", [0.9, 0.0, 0.3])
    assert pp.lines == [WORKSPACE_WARNING]
    assert pp.move_joint_arm(0.2, 0.1, 0.1, 0.0, 0.3, 0.0)
    assert pp.back_to_home()


def test_moves_reach_their_goals(pp):
    arm = pp.arm
    q = [0.3, 0.2, -0.1, 0.4, 0.5, -0.6]
    assert pp.move_joint_arm(*q)
    assert arm.get_current_joint_values() == pytest.approx(q, abs=1e-9)
    goal = PickPlace.pose2msg_deg(0, 90, 30, 0.35, 0.1, 0.3)
    assert pp.move_pose_arm(goal)
    tool0 = pp.cell.robot_spec.pose.inverse() * pp.cell.scene.link_pose("tool0")
    assert tool0.isclose(goal.to_pose(), atol=1e-4, rot_atol=1e-3)
    assert pp.move_joint_hand(0.5)
    assert pp.hand.gripper.get_current_joint_values() == pytest.approx([0.5])
    assert pp.back_to_home()
    assert arm.get_current_joint_values() == pytest.approx(np.zeros(6), abs=1e-9)
    assert pp.hand.gripper.get_current_joint_values() == pytest.approx([0.0])


def test_messages_accept_points_lists_and_arrays():
    assert Point.of([1, 2, 3]) == Point(1.0, 2.0, 3.0)
    assert list(np.asarray(Point(1, 2, 3))) == [1, 2, 3]
    m = PoseMsg.of(PickPlace.pose2msg(0, 0, 0, 1, 2, 3))
    assert Point.of(m) == Point(1, 2, 3)
