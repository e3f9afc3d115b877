"""MoveGroup: MoveIt's commander calls on a scene, in demo mode."""

import math
import time

import numpy as np
import pytest

from robocell import PlanningScene, Pose
from robocell.cell import MoveGroup
from robocell.errors import ExecutionError, ModelError, PlanningError, RobocellError
from robocell.kinematics import fk
from robocell.trajectory import stationary
from tests.conftest import beyond_reach


@pytest.fixture
def arm(irb120):
    scene = PlanningScene(irb120)
    scene.add_box("table", Pose([0.45, 0, -0.05]), [0.4, 0.8, 0.1])
    g = MoveGroup(scene, "arm", time_scale=0)
    g.set_end_effector_link("tcp")
    return g


def test_targets_of_each_kind(arm):
    assert arm.get_named_targets() == ["home"]
    target = Pose.from_rpy(0.35, 0.1, 0.2, 0, math.pi / 2, 0)
    arm.set_pose_target(target)
    assert arm.go()
    assert arm.get_current_pose().isclose(target, atol=1e-5, rot_atol=1e-4)
    arm.set_position_target([0.3, -0.2, 0.3])
    assert arm.go()
    assert np.allclose(arm.get_current_pose().position, [0.3, -0.2, 0.3], atol=1e-4)
    arm.set_joint_value_target({"joint_1": 0.4})
    assert arm.go()
    assert arm.get_current_joint_values()[0] == pytest.approx(0.4)
    arm.set_named_target("home")
    plan = arm.plan()
    assert plan.success and arm.execute(plan)
    assert np.allclose(arm.get_current_joint_values(), 0, atol=1e-9)


def test_plan_respects_scaling(arm):
    arm.set_joint_value_target([1.0, 0.2, 0.1, 0.5, 0.5, 0.5])
    fast = arm.plan()
    arm.set_max_velocity_scaling_factor(0.25)
    arm.set_max_acceleration_scaling_factor(0.25)
    slow = arm.plan()
    assert slow.trajectory.duration > 2 * fast.trajectory.duration
    assert slow.trajectory.limit_violations(arm.group, 0.25, 0.25) == []


def test_cartesian_and_relative_moves(arm):
    arm.set_joint_value_target([0, 0.3, 0.2, 0, 0.9, 0])
    assert arm.go()
    p0 = arm.get_current_pose().position
    traj, fraction = arm.compute_cartesian_path(
        [Pose(p0 + [0, 0.05, 0.05], arm.get_current_pose().orientation)]
    )
    assert fraction == 1.0 and traj.duration > 0
    cp = arm.move_relative((0, 0, 0.1))
    assert cp.fraction == 1.0
    assert np.allclose(arm.get_current_pose().position, p0 + [0, 0, 0.1], atol=1e-4)
    cp = arm.move_relative((0, 0, 0.05), frame="tool")  # tool z is forward
    assert cp.fraction == 1.0
    # a move into the table is refused as a whole, with the reason; nothing moves
    before = arm.get_current_joint_values()
    cp = arm.move_relative((0, 0, -0.6))
    assert cp.fraction < 1.0 and "table" in cp.reason
    assert np.array_equal(arm.get_current_joint_values(), before)


def test_non_blocking_execution_and_stop(irb120):
    scene = PlanningScene(irb120)
    arm = MoveGroup(scene, "arm", time_scale=1.0)
    arm.set_max_velocity_scaling_factor(0.2)
    arm.set_joint_value_target([1.5, 0, 0, 0, 0, 0])
    assert arm.go(wait=False)
    assert not arm.last_execution.done()  # go returned while the motion runs
    time.sleep(0.2)
    arm.stop()
    q = arm.get_current_joint_values()[0]
    assert 0 < q < 1.5
    assert arm.last_execution.result.status.value == "preempted"


def test_moveit_commander_targets_in_plan_and_go(arm):
    """moveit_commander's forms: ``plan(target)`` and ``go(target, wait)`` with a name, joint
    values or a Pose; ``go(False)``; a plan unpacked as ``success, trajectory, time, error``;
    joint values remembered by name; ``shift_pose_target``."""
    q = np.array([0.3, 0.2, 0.1, 0.0, 0.6, 0.0])
    success, traj, planning_time, error = arm.plan(q)
    assert success and error == "" and planning_time > 0
    assert np.allclose(traj.positions[-1], q) and arm.execute(traj)
    arm.remember_joint_values("here")
    assert "here" in arm.get_named_targets() and "home" in arm.get_named_targets()
    assert np.allclose(arm.get_remembered_joint_values()["here"], q)
    assert arm.go("home")
    assert np.allclose(arm.get_current_joint_values(), 0, atol=1e-9)
    assert arm.go("here", wait=True)
    assert np.allclose(arm.get_current_joint_values(), q)
    assert arm.get_named_target_values("here") == dict(
        zip(arm.get_active_joints(), q.tolist(), strict=True)
    )
    arm.forget_joint_values("here")
    with pytest.raises(ModelError, match="unknown named state 'here'.*known: home"):
        arm.go("here")
    with pytest.raises(PlanningError, match="no joint values remembered as 'here'"):
        arm.forget_joint_values("here")
    with pytest.raises(PlanningError, match="outside the limits"):
        arm.remember_joint_values("far", [4, 0, 0, 0, 0, 0])
    assert arm.get_remembered_joint_values() == {}

    target = Pose.from_rpy(0.35, 0.1, 0.25, 0, math.pi / 2, 0)
    assert arm.go(target)
    assert arm.get_current_pose().isclose(target, atol=1e-5, rot_atol=1e-4)
    assert np.allclose(arm.get_current_rpy(), target.rpy(), atol=1e-4)
    assert arm.get_planning_frame() == arm.get_pose_reference_frame() == "world"
    # [x, y, z, roll, pitch, yaw], as moveit_commander reads six numbers
    arm.set_pose_target([0.35, -0.1, 0.25, 0, math.pi / 2, 0])
    assert arm.go(False)  # wait=False (demo mode here jumps: done already)
    assert np.allclose(arm.get_current_pose().position, [0.35, -0.1, 0.25], atol=1e-5)
    before = arm.get_current_pose()
    arm.shift_pose_target(2, 0.05)  # 5 cm up
    assert arm.go()
    after = arm.get_current_pose()
    assert np.allclose(after.position, before.position + [0, 0, 0.05], atol=1e-5)
    assert np.allclose(after.rotation(), before.rotation(), atol=1e-4)
    arm.shift_pose_target(5, 0.3)  # yaw
    assert arm.go()
    assert np.allclose(arm.get_current_rpy(), before.rpy() + [0, 0, 0.3], atol=1e-4)
    assert np.allclose(arm.get_current_pose().position, after.position, atol=1e-5)
    for axis, words in ((6, "axis must be 0-5"), (1.5, "whole number"), ("z", "number")):
        with pytest.raises(PlanningError, match=words):
            arm.shift_pose_target(axis, 0.1)


def test_joint_value_targets_in_moveit_commanders_forms(arm):
    """A joint's name and value; a Pose (its collision-free IK solution nearest the current
    joint values); get_joint_value_target gives the goal's values."""
    arm.set_joint_value_target("joint_2", 0.3)
    assert np.array_equal(arm.get_joint_value_target(), [0, 0.3, 0, 0, 0, 0])
    assert arm.go()
    pose = Pose.from_rpy(0.25, 0.1, 0.45, 0, math.pi / 4, 0)  # two free IK solutions
    arm.set_joint_value_target(pose)
    q = arm.get_joint_value_target()
    checker = arm.scene.checker(arm.group)
    assert not checker.check_exact(q[None])[0]
    T = Pose.from_matrix(arm.scene.T_world_root @ fk(arm.group, q, "tcp"))
    assert T.isclose(pose, atol=1e-6, rot_atol=1e-6)
    from robocell.kinematics import solve_ik

    base = arm.scene.link_pose(arm.group.base_link).inverse()
    others = solve_ik(arm.group, base * pose, tip_link="tcp", checker=checker).solutions
    current = arm.get_current_joint_values()
    assert len(others) > 1
    assert np.linalg.norm(q - current) == pytest.approx(
        min(np.linalg.norm(others - current, axis=1)), abs=1e-6
    )
    assert arm.go() and np.allclose(arm.get_current_joint_values(), q)
    arm.set_joint_value_target(pose, "tool0")  # the same pose for another link
    assert not np.allclose(arm.get_joint_value_target(), q)
    arm.set_pose_target(pose)
    with pytest.raises(PlanningError, match="not a joint goal: a PoseGoal"):
        arm.get_joint_value_target()
    with pytest.raises(PlanningError, match="second argument"):
        arm.set_joint_value_target([0] * 6, 0.3)
    with pytest.raises(PlanningError, match="no solution"):
        arm.set_joint_value_target(Pose([1.5, 0, 0.3]))


def test_goal_tolerances_apply_when_planning_as_in_moveit(arm):
    """A tolerance set after the target applies to it (MoveIt builds the goal's constraints
    when it plans): a pose 3 mm beyond reach is refused, then reached within 1 cm."""
    target = beyond_reach(arm.scene, arm.group, (0.0, 1.0), 0.3, math.pi / 2, 0.003)
    arm.set_pose_target(target)
    with pytest.raises(PlanningError, match="out of reach.*±0.0001 m"):
        arm.plan()
    arm.set_goal_tolerance(0.01)
    assert arm.get_goal_tolerance() == (0.01, 0.01, 0.01)
    assert arm.go()
    assert np.linalg.norm(arm.get_current_pose().position - target.position) <= 0.01


def test_random_targets_are_free_and_follow_the_seed(arm):
    checker = arm.scene.checker(arm.group)
    drawn = [arm.get_random_joint_values() for _ in range(5)]
    for q in drawn:
        assert arm.group.limit_violations(q) == [] and not checker.check_exact(q[None])[0]
    assert len({tuple(q) for q in drawn}) == 5
    again = MoveGroup(arm.scene, "arm", time_scale=0)
    assert np.array_equal(again.get_random_joint_values(), drawn[0])
    arm.set_random_target()
    plan = arm.plan()
    assert plan.success and not checker.check_exact(plan.path[-1:])[0]


@pytest.mark.parametrize("mount", [Pose(), Pose.from_rpy(0.3, -0.2, 0.1, 0.2, -0.1, 1.0)])
def test_jacobian_matches_finite_differences(irb120, mount):
    """Columns: the end-effector link's origin (or a point on it) moving, and its frame
    turning, along the world's axes (the poses' frame), per joint; the robot mounted at the
    world's origin or turned and moved off it."""
    arm = MoveGroup(PlanningScene(irb120, robot_pose=mount), "arm", time_scale=0)
    arm.set_end_effector_link("tcp")
    W = mount.matrix()

    def world_fk(q, link):
        return W @ fk(arm.group, q, link)

    q = np.array([0.3, 0.2, -0.4, 0.5, 0.6, -0.2])
    point = np.array([0.0, 0.02, 0.1])
    J = arm.get_jacobian_matrix(q)
    Jp = arm.get_jacobian_matrix(q, point)
    h = 1e-6
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        Ta, Tb = world_fk(q - dq, "tcp"), world_fk(q + dq, "tcp")
        assert np.allclose((Tb[:3, 3] - Ta[:3, 3]) / (2 * h), J[:3, j], atol=1e-6)
        pa, pb = Ta[:3, :3] @ point + Ta[:3, 3], Tb[:3, :3] @ point + Tb[:3, 3]
        assert np.allclose((pb - pa) / (2 * h), Jp[:3, j], atol=1e-6)
        dR = (Tb[:3, :3] - Ta[:3, :3]) / (2 * h) @ world_fk(q, "tcp")[:3, :3].T
        assert np.allclose([dR[2, 1], dR[0, 2], dR[1, 0]], J[3:, j], atol=1e-6)
    assert np.array_equal(J[3:], Jp[3:])
    with pytest.raises(RobocellError, match="reference point"):
        arm.get_jacobian_matrix(q, [0, 1])


def test_pose_reference_frame_gives_targets_and_waypoints_in_a_link(irb120):
    """MoveIt's set_pose_reference_frame: with the robot turned and moved off the world's
    origin, a pose target, a position target and Cartesian waypoints given in its base link
    are reached where that frame puts them in the world; in the world frame (the default)
    the same numbers mean another place. Returned poses stay in the world frame."""
    mount = Pose.from_rpy(0.4, -0.3, 0.1, 0.0, 0.0, 2.0)
    arm = MoveGroup(PlanningScene(irb120, robot_pose=mount), "arm", time_scale=0)
    arm.set_end_effector_link("tcp")
    assert arm.get_pose_reference_frame() == "world"
    base = arm.group.base_link
    arm.set_pose_reference_frame(base)
    assert arm.get_pose_reference_frame() == base
    T_world_base = arm.scene.link_pose(base)
    assert T_world_base.isclose(mount, atol=1e-9, rot_atol=1e-9)

    in_base = Pose.from_rpy(0.35, 0.1, 0.3, 0, math.pi / 2, 0)
    assert arm.go(in_base)
    reached = arm.get_current_pose()
    want = T_world_base * in_base
    assert np.allclose(reached.position, want.position, atol=1e-5)
    assert np.allclose(reached.rotation(), want.rotation(), atol=1e-5)
    assert not np.allclose(reached.position, in_base.position, atol=0.05)

    arm.set_position_target([0.3, -0.15, 0.35])
    assert arm.go()
    want = (T_world_base * Pose([0.3, -0.15, 0.35])).position
    assert np.allclose(arm.get_current_pose().position, want, atol=1e-4)

    start = arm.get_current_pose()
    up = Pose(start.position, start.orientation)
    up_in_base = T_world_base.inverse() * up
    waypoints = [Pose(up_in_base.position + [0, 0, 0.05], up_in_base.orientation)]
    plan = arm.compute_cartesian_path(waypoints, 0.005)
    assert plan.fraction == 1.0
    end = fk(arm.group, plan.trajectory.positions[-1], "tcp")
    assert np.allclose(mount.matrix() @ end, (T_world_base * waypoints[0]).matrix(), atol=1e-4)

    with pytest.raises(PlanningError, match=r"unknown pose reference frame 'bse'.*world"):
        arm.set_pose_reference_frame("bse")
    assert arm.get_pose_reference_frame() == base
    arm.set_pose_reference_frame("world")
    arm.set_pose_target(in_base)
    assert arm.go()
    assert np.allclose(arm.get_current_pose().position, in_base.position, atol=1e-5)


def test_retime_trajectory_keeps_the_motion_and_meets_the_new_limits(arm):
    """A plan's path timed again time-optimally (as the planner times it at those factors);
    a Cartesian trajectory run uniformly slower: the same states at scaled times, a limit
    reached, none passed."""
    from scipy.spatial import cKDTree

    from robocell.trajectory import BlendedPath, time_optimal

    arm.set_joint_value_target([1.0, 0.2, 0.1, 0.5, 0.5, 0.5])
    plan = arm.plan()
    slow = arm.retime_trajectory(plan, 0.3, 0.2)
    again = time_optimal(
        arm.group, BlendedPath(plan.path, plan.stats["corner_deviation"]), 0.3, 0.2
    )
    assert slow.duration == pytest.approx(again.duration, rel=1e-9)
    assert slow.duration > 2 * plan.trajectory.duration
    assert slow.limit_violations(arm.group, 0.3, 0.2) == []
    assert np.allclose(slow.positions[[0, -1]], plan.trajectory.positions[[0, -1]], atol=1e-12)
    dense = plan.trajectory.sample(np.linspace(0, plan.trajectory.duration, 4000)).positions
    states = slow.sample(np.linspace(0, slow.duration, 500)).positions
    assert cKDTree(dense).query(states)[0].max() < 1e-3  # on the same path

    assert arm.execute(plan)
    p0 = arm.get_current_pose()
    cart, fraction = arm.compute_cartesian_path([Pose(p0.position + [0, 0.1, 0], p0.orientation)])
    assert fraction == 1.0
    for vs, as_ in ((0.2, 0.2), (0.2, 1.0), (1.0, 0.1)):
        traj = arm.retime_trajectory(cart, vs, as_)
        k = traj.duration / cart.duration
        t = np.linspace(0, cart.duration, 300)
        assert np.allclose(traj.sample(t * k).positions, cart.sample(t).positions, atol=1e-9)
        assert traj.limit_violations(arm.group, vs, as_) == []
        s = traj.sample(np.linspace(0, traj.duration, 2000))
        v = np.abs(s.velocities).max(axis=0) / (arm.group.velocity * vs)
        a = np.abs(s.accelerations).max(axis=0) / (arm.group.acceleration * as_)
        assert max(v.max(), a.max()) > 0.98  # a limit is reached: no slower than needed
    with pytest.raises(PlanningError, match="scaling factor"):
        arm.retime_trajectory(plan, 0.0)
    with pytest.raises(ExecutionError, match="MotionPlan, CartesianPlan or JointTrajectory"):
        arm.retime_trajectory("plan")


def test_attach_detach(arm):
    arm.scene.add_box("part", Pose(arm.get_current_pose().position), [0.02, 0.02, 0.02])
    held = arm.attach_object("part")
    assert held.link == "tcp" and "gripper_left_finger" in held.touch_links
    assert "part" in arm.scene.attached_objects
    arm.detach_object("part")
    assert "part" in arm.scene.world_objects


def test_errors(arm):
    with pytest.raises(PlanningError, match="no target"):
        arm.plan()
    with pytest.raises(ModelError, match="unknown named state 'hom'.*known: home"):
        arm.set_named_target("hom")
    with pytest.raises(PlanningError, match="unknown joint 'joint_7'.*joint_1"):
        arm.set_joint_value_target({"joint_7": 0.1})
    with pytest.raises(PlanningError, match="outside the limits"):
        arm.set_joint_value_target([4, 0, 0, 0, 0, 0])
    with pytest.raises(ModelError, match="unknown link"):
        arm.set_pose_target(Pose([0.3, 0, 0.3]), link="hand")
    with pytest.raises(PlanningError, match="position target"):
        arm.set_position_target([0.3, np.nan, 0.3])
    with pytest.raises(PlanningError, match="scaling"):
        arm.set_max_velocity_scaling_factor(1.5)
    with pytest.raises(ModelError, match="unknown group|known"):
        MoveGroup(arm.scene, "arms")
    arm.set_pose_target(Pose([1.5, 0, 0.3]))
    with pytest.raises(PlanningError, match="no solution"):
        arm.plan()
    with pytest.raises(ExecutionError, match="JointTrajectory"):
        arm.execute("plan")


# values of the wrong kind, as a user's slip makes them: each call must answer with a
# RobocellError naming the argument (before, most raised TypeError or ValueError from a
# comparison or a conversion deep inside), and change neither the group nor the scene
NUMBERS = [None, "abc", [1, 2], np.zeros(3), {"x": 1.0}, float("nan")]
NAMES = ["abc", [1, 2], np.zeros(3), {"x": 1.0}, 3.5]
VECTORS = [None, "abc", [1, 2], {"x": 1.0}, [0.3, float("nan"), 0.3], 3.5]
GROUP_CALLS = {
    "set_planning_time": (lambda g, v: g.set_planning_time(v), NUMBERS),
    "set_num_planning_attempts": (lambda g, v: g.set_num_planning_attempts(v), [*NUMBERS, 2.5]),
    "set_max_velocity_scaling_factor": (
        lambda g, v: g.set_max_velocity_scaling_factor(v),
        NUMBERS,
    ),
    "set_max_acceleration_scaling_factor": (
        lambda g, v: g.set_max_acceleration_scaling_factor(v),
        NUMBERS,
    ),
    "set_goal_tolerance": (lambda g, v: g.set_goal_tolerance(v), NUMBERS),
    "set_planner_id": (lambda g, v: g.set_planner_id(v), [None, *NAMES[1:]]),
    "set_named_target": (lambda g, v: g.set_named_target(v), [None, *NAMES]),
    "set_end_effector_link": (lambda g, v: g.set_end_effector_link(v), [None, *NAMES]),
    "get_current_pose": (lambda g, v: g.get_current_pose(v), NAMES),
    "get_named_target_values": (lambda g, v: g.get_named_target_values(v), [None, *NAMES]),
    "set_joint_value_target": (lambda g, v: g.set_joint_value_target({"joint_1": v}), NUMBERS),
    "set_joint_value_target (name, value)": (
        lambda g, v: g.set_joint_value_target("joint_1", v),
        NUMBERS,
    ),
    "set_joint_value_target (name)": (lambda g, v: g.set_joint_value_target(v, 0.1), NAMES),
    "set_joint_value_target (pose link)": (
        lambda g, v: g.set_joint_value_target(Pose([0.3, 0, 0.3]), v),
        NAMES,
    ),
    "set_position_target": (lambda g, v: g.set_position_target(v), VECTORS),
    "compute_cartesian_path (waypoints)": (lambda g, v: g.compute_cartesian_path(v), NUMBERS),
    "compute_cartesian_path (eef_step)": (
        lambda g, v: g.compute_cartesian_path([g.get_current_pose()], v),
        NUMBERS,
    ),
    "compute_cartesian_path (jump_threshold)": (
        lambda g, v: g.compute_cartesian_path([g.get_current_pose()], 0.01, v),
        NUMBERS,
    ),
    "compute_sequence (blend_radius)": (
        lambda g, v: g.compute_sequence([g.get_current_pose()], v),
        NUMBERS,
    ),
    "set_pose_reference_frame": (
        lambda g, v: g.set_pose_reference_frame(v),
        [None, *NAMES, "World"],
    ),
    "move_relative (rpy)": (lambda g, v: g.move_relative((0, 0, 0.01), v), VECTORS),
    "move_relative (frame)": (lambda g, v: g.move_relative((0, 0, 0.01), (0, 0, 0), v), NAMES),
    "plan (target)": (lambda g, v: g.plan(v), [*NAMES, [1, 2], [0, 0, float("nan"), 0, 0, 0]]),
    "go (target)": (lambda g, v: g.go(v), [*NAMES, [0, 0, 0, 0, 0, 9]]),
    "shift_pose_target (axis)": (lambda g, v: g.shift_pose_target(v, 0.01), NUMBERS),
    "shift_pose_target (value)": (lambda g, v: g.shift_pose_target(2, v), NUMBERS),
    "remember_joint_values (name)": (
        lambda g, v: g.remember_joint_values(v),
        [None, "", *NAMES[1:]],
    ),
    "remember_joint_values (values)": (lambda g, v: g.remember_joint_values("a", v), VECTORS[1:]),
    "forget_joint_values": (lambda g, v: g.forget_joint_values(v), [None, *NAMES]),
    "get_jacobian_matrix": (lambda g, v: g.get_jacobian_matrix(v), VECTORS),
    "get_jacobian_matrix (point)": (
        lambda g, v: g.get_jacobian_matrix(np.zeros(6), v),
        ["abc", [1, 2], {"x": 1.0}, [0.3, float("nan"), 0.3], 3.5],
    ),
    "retime_trajectory": (lambda g, v: g.retime_trajectory(v), [None, *NAMES]),
    "retime_trajectory (factor)": (
        lambda g, v: g.retime_trajectory(stationary(g.group, np.zeros(6)), 1.0, v),
        NUMBERS,
    ),
    "detach_object": (lambda g, v: g.detach_object(v), [None, *NAMES]),
    "attach_object": (lambda g, v: g.attach_object(v), [None, *NAMES]),
    "scene.set_object_padding": (lambda g, v: g.scene.set_object_padding("table", v), NUMBERS),
    "scene.remove_object": (lambda g, v: g.scene.remove_object(v), [None, *NAMES]),
    "scene.allow_collision": (lambda g, v: g.scene.allow_collision(v, "table"), [None, *NAMES]),
}


@pytest.mark.parametrize("name", GROUP_CALLS)
def test_values_of_the_wrong_kind_get_a_robocell_error(arm, name):
    call, values = GROUP_CALLS[name]
    settings = dict(vars(arm))
    q = arm.scene.state.positions.copy()
    objects = (sorted(arm.scene.world_objects), sorted(arm.scene.attached_objects))
    for v in values:
        with pytest.raises(RobocellError):
            call(arm, v)
        assert dict(vars(arm)) == settings
        assert np.array_equal(arm.scene.state.positions, q)
        assert (sorted(arm.scene.world_objects), sorted(arm.scene.attached_objects)) == objects


def test_linear_sequence_with_blend_radius(arm):
    """A LIN sequence: stopping at the corners, or rounding them within the blend radius,
    which is faster; away from the corners the tool is on the straight lines."""
    from robocell.kinematics import fk

    arm.set_end_effector_link("tool0")
    arm.set_joint_value_target([0, 0.3, 0.2, 0, 0.9, 0])
    assert arm.go()
    start = arm.get_current_joint_values()
    T0 = arm.get_current_pose()
    p0 = T0.position
    corners = [p0 + [0, 0, 0.03], p0 + [0, 0.2, 0.03], p0 + [0, 0.2, 0.0]]
    poses = [Pose(c, T0.orientation) for c in corners]
    stop = arm.compute_sequence(poses, 0.0)
    blend = arm.compute_sequence(poses, 0.02)
    assert stop.fraction == 1.0 and blend.fraction == 1.0
    assert blend.trajectory.duration < stop.trajectory.duration
    for plan, radius in ((stop, 0.0), (blend, 0.02)):
        traj = plan.trajectory
        assert traj.limit_violations(arm.group) == []
        assert np.allclose(traj.positions[0], start)
        qs = traj.sample(np.linspace(0, traj.duration, 400)).positions
        pts = np.array([fk(arm.group, q, "tool0")[:3, 3] for q in qs])
        poly = np.array([p0, *corners])
        d_line = np.min(
            [
                np.linalg.norm(
                    pts
                    - (
                        a
                        + np.clip(((pts - a) @ (b - a)) / ((b - a) @ (b - a)), 0, 1)[:, None]
                        * (b - a)
                    ),
                    axis=1,
                )
                for a, b in zip(poly[:-1], poly[1:], strict=True)
            ],
            axis=0,
        )
        near_corner = np.min(np.linalg.norm(pts[:, None, :] - poly[None, 1:-1, :], axis=2), axis=1)
        away = near_corner > radius + 1e-3
        assert d_line[away].max() < 5e-4
        assert d_line.max() < max(radius, 1e-3)
        assert np.allclose(pts[-1], corners[-1], atol=1e-4)
