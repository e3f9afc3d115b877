import math

import numpy as np
import pytest

from robocell.errors import ModelError, RobocellError
from robocell.kinematics import fk
from robocell.robot import RobotModel, RobotState, bundled_robots

DEG = math.pi / 180


def test_bundled_robots_are_listed():
    assert {"irb120_robotiq85", "ur5e_gripper"} <= set(bundled_robots())


def test_irb120_matches_the_spec(irb120):
    arm = irb120.group("arm")
    assert arm.joint_names == [f"joint_{i}" for i in range(1, 7)]
    assert (arm.base_link, arm.tip_link) == ("base_link", "tool0")
    assert np.allclose(arm.lower, np.array([-165, -110, -110, -160, -120, -180]) * DEG)
    assert np.allclose(arm.upper, np.array([165, 110, 70, 160, 120, 180]) * DEG)
    assert np.allclose(arm.velocity, [4.363, 4.363, 4.363, 5.585, 5.585, 7.330])
    assert np.allclose(arm.acceleration, [30, 30, 30, 50, 50, 50])
    assert np.allclose(arm.jerk, 500)
    assert np.allclose(arm.named("home"), 0)
    grip = irb120.group("gripper")
    assert grip.joint_names == ["finger_joint"]
    assert (grip.lower[0], grip.upper[0]) == (0.0, 0.8)
    assert grip.named("open")[0] == 0.0 and grip.named("close")[0] == 0.8
    assert irb120.end_effectors["gripper"].parent_link == "tool0"
    assert irb120.group("arm_with_gripper").dof == 7


def test_gripper_value_drives_both_fingers_linearly(irb120):
    grip = irb120.group("gripper")
    for value, opening in ((0.0, 0.085), (0.4, 0.0425), (0.8, 0.0)):
        left = fk(grip, [value], "gripper_left_finger")
        right = fk(grip, [value], "gripper_right_finger")
        T_base = fk(grip, [value], "tool0")
        # inner pad faces sit at y = ±0.0425 at q = 0 and close symmetrically
        gap = (left[:3, 3] - right[:3, 3]) @ T_base[:3, 1] + 0.085
        assert math.isclose(gap, opening, abs_tol=1e-12)
    tcp = fk(irb120.group("arm"), np.zeros(6), "tcp")
    assert np.allclose(tcp[:3, 3], [0.374 + 0.15, 0, 0.63])


def test_ur5e_matches_the_spec(ur5e):
    arm = ur5e.group("manipulator")
    assert arm.dof == 6 and arm.tip_link == "tool0"
    assert np.allclose(
        arm.upper, [2 * math.pi, 2 * math.pi, math.pi, 2 * math.pi, 2 * math.pi, 2 * math.pi]
    )
    assert np.allclose(arm.velocity, math.pi)
    grip = ur5e.group("gripper")
    assert (grip.lower[0], grip.upper[0]) == (0.0, 0.04)


def test_mbm_robots_load_unchanged(mbm_ur5, mbm_panda):
    arm = mbm_ur5.group("manipulator")
    assert arm.joint_names[0] == "shoulder_pan_joint" and arm.dof == 6
    assert arm.tip_link == "ee_link"
    assert np.allclose(arm.named("home"), [0, -1.57, 0, -1.57, 0, 0])
    assert len(mbm_ur5.collision_geometry) == 18
    panda = mbm_panda.group("panda_arm")
    assert panda.dof == 7 and panda.tip_link == "panda_link8"
    assert "ready" in panda.named_states
    assert frozenset(("base_link", "shoulder_link")) in mbm_ur5.disabled_collisions


def test_state_and_group_positions(irb120):
    state = irb120.default_state()
    state.set_group_positions("arm", [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    state.set_named("gripper", "close")
    assert np.allclose(state.group_positions("arm"), [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert state.as_dict()["finger_joint"] == 0.8
    with pytest.raises(ModelError, match="must have 6 entries"):
        state.set_group_positions("arm", [0.0] * 5)
    with pytest.raises(ModelError, match="NaN"):
        state.set_group_positions("arm", [0, 0, math.nan, 0, 0, 0])
    with pytest.raises(ModelError):
        RobotState(irb120, [0.0])


def test_unknown_names_list_the_valid_ones(irb120):
    with pytest.raises(
        ModelError, match=r"unknown group 'armm'; known: arm, arm_with_gripper, gripper"
    ):
        irb120.group("armm")
    with pytest.raises(ModelError, match="unknown named state 'hom' of group 'arm'; known: home"):
        irb120.group("arm").named("hom")
    with pytest.raises(ModelError, match="unknown link 'tool'"):
        irb120.link_index("tool")
    with pytest.raises(ModelError, match="unknown bundled robot 'irb12'; known: irb120_robotiq85"):
        RobotModel.load("irb12")


URDF = """<robot name="two">
  <link name="base"/>
  <link name="a"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="b"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="a"/><child link="b"/><origin xyz="0.5 0 0"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.2" velocity="1" effort="1"/></joint>
</robot>"""
SRDF = """<robot name="two"><group name="g"><chain base_link="base" tip_link="b"/></group>
  <group_state name="out" group="g">
    <joint name="j1" value="0.5"/><joint name="j2" value="0.1"/></group_state>
</robot>"""


def test_urdf_and_srdf_from_text():
    robot = RobotModel.from_urdf(URDF, SRDF)
    g = robot.group("g")
    assert g.joint_names == ["j1", "j2"] and (g.base_link, g.tip_link) == ("base", "b")
    assert np.allclose(g.named("out"), [0.5, 0.1])
    T = fk(g, [math.pi / 4, 0.1])
    assert np.allclose(T[:3, 3], [0.6 * math.cos(math.pi / 4), 0.6 * math.sin(math.pi / 4), 0])


@pytest.mark.parametrize(
    "urdf, words",
    [
        ("<robot", "not valid XML"),
        ("<robt name='x'/>", "expected <robot>"),
        (
            URDF.replace('<child link="b"/>', '<child link="c"/>'),
            "unknown link 'c'; known: a, b, base",
        ),
        (URDF.replace('type="prismatic"', 'type="planar"'), "supported: revolute, continuous"),
        (
            URDF.replace('<box size="0.1 0.1 0.1"/>', '<mesh filename="package://nowhere/x.stl"/>'),
            "mesh 'package://nowhere/x.stl' not found",
        ),
        (
            URDF.replace('lower="-1" upper="1"', 'lower="1" upper="-1"'),
            "lower limit 1.0 > upper -1.0",
        ),
        (URDF.replace('<origin xyz="0.5 0 0"/>', '<origin xyz="0.5 0 nan"/>'), "finite numbers"),
    ],
)
def test_bad_urdf_raises_model_error(urdf, words):
    with pytest.raises(ModelError, match=words) as info:
        RobotModel.from_urdf(urdf)
    assert isinstance(info.value, RobocellError)


@pytest.mark.parametrize(
    "srdf, words",
    [
        (SRDF.replace('tip_link="b"', 'tip_link="x"'), "unknown link 'x'"),
        (
            SRDF.replace('<joint name="j2" value="0.1"/>', '<joint name="j9" value="0.1"/>'),
            "unknown joint 'j9'",
        ),
        (
            "<robot name='two'><group name='g'><group name='h'/></group></robot>",
            "unknown subgroup 'h'",
        ),
        (
            "<robot name='two'><end_effector name='e' parent_link='b' group='nope'/></robot>",
            "unknown group 'nope'",
        ),
        (
            "<robot name='two'><disable_collisions link1='a' link2='zz'/></robot>",
            "unknown link 'zz'",
        ),
    ],
)
def test_bad_srdf_raises_model_error(srdf, words):
    with pytest.raises(ModelError, match=words):
        RobotModel.from_urdf(URDF, srdf)


def test_joint_limits_yaml(tmp_path):
    path = tmp_path / "joint_limits.yaml"
    path.write_text("joint_limits:\n  j1: {has_acceleration_limits: true, max_acceleration: 3.5}\n")
    robot = RobotModel.from_urdf(URDF, SRDF, joint_limits=path)
    assert robot.group("g").acceleration[0] == 3.5
    path.write_text("joint_limits:\n  j7: {max_velocity: 1}\n")
    with pytest.raises(ModelError, match="unknown joint 'j7'; known: j1, j2"):
        RobotModel.from_urdf(URDF, SRDF, joint_limits=path)
