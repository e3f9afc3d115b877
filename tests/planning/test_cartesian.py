"""Cartesian paths: straight lines, fractions and their reasons, relative moves."""

import math

import numpy as np
import pytest

from robocell import PlanningScene, Pose
from robocell.errors import PlanningError
from robocell.kinematics import fk
from robocell.planning.cartesian import compute_cartesian_path, relative_pose

Q0 = np.array([0.0, 0.3, 0.2, 0.0, 0.9, 0.0])


@pytest.fixture
def scene(irb120):
    s = PlanningScene(irb120)
    s.set_joint_positions("arm", Q0)
    return s


def test_straight_line_is_straight(scene):
    arm = scene.robot.group("arm")
    T0 = scene.link_pose("tcp")
    target = relative_pose(T0, (0.0, 0.12, 0.08))
    cp = compute_cartesian_path(scene, "arm", [target], eef_step=0.005, link="tcp")
    assert cp.fraction == 1.0 and cp.reason == ""
    pts = np.array([fk(arm, q, "tcp")[:3, 3] for q in cp.path])
    a, b = T0.position, target.position
    d = (b - a) / np.linalg.norm(b - a)
    off_line = np.linalg.norm((pts - a) - ((pts - a) @ d)[:, None] * d, axis=1)
    assert off_line.max() < 1e-5
    # orientation held, steps no longer than eef_step
    for q in cp.path:
        assert np.allclose(fk(arm, q, "tcp")[:3, :3], T0.rotation(), atol=1e-5)
    assert np.linalg.norm(np.diff(pts, axis=0), axis=1).max() <= 0.005 + 1e-6


def test_collision_stops_the_path_and_says_with_what(scene):
    T0 = scene.link_pose("tcp")
    scene.add_box("post", Pose(T0.position + [0.0, 0.1, 0.0]), [0.05, 0.02, 0.4])
    cp = compute_cartesian_path(scene, "arm", [relative_pose(T0, (0, 0.2, 0))], link="tcp")
    assert 0.0 < cp.fraction < 0.5
    assert "collision" in cp.reason and "post" in cp.reason
    # without collision avoidance the line goes through
    free = compute_cartesian_path(
        scene, "arm", [relative_pose(T0, (0, 0.2, 0))], link="tcp", avoid_collisions=False
    )
    assert free.fraction == 1.0


def test_out_of_reach_says_no_ik(scene):
    T0 = scene.link_pose("tcp")
    cp = compute_cartesian_path(scene, "arm", [relative_pose(T0, (0.8, 0, 0))], link="tcp")
    assert cp.fraction < 1.0 and "no IK" in cp.reason


def test_joint_limit_reason(scene):
    # turning the tool about its axis by more than joint 6 allows (±400°) is refused at the limit
    arm = scene.robot.group("arm")
    q = Q0.copy()
    q[5] = arm.upper[5] - 0.05
    scene.set_joint_positions("arm", q)
    T0 = scene.link_pose("tool0")
    target = relative_pose(T0, rpy=(0.3, 0, 0), frame="tool")
    cp = compute_cartesian_path(scene, "arm", [target], link="tool0")
    assert cp.fraction < 1.0 and "joint limit" in cp.reason and "joint_6" in cp.reason


def test_jump_threshold(scene):
    T0 = scene.link_pose("tcp")
    cp = compute_cartesian_path(
        scene, "arm", [relative_pose(T0, (0, 0.1, 0))], link="tcp", jump_threshold=1.5
    )
    assert cp.fraction == 1.0  # a smooth line has no jump


def test_relative_pose_frames():
    T = Pose.from_rpy(0.3, 0.0, 0.2, 0, math.pi / 2, 0)  # tool z points along world x
    assert np.allclose(relative_pose(T, (0, 0, 0.1)).position, [0.3, 0.0, 0.3])
    assert np.allclose(relative_pose(T, (0, 0, 0.1), frame="tool").position, [0.4, 0.0, 0.2])
    base = Pose.from_rpy(0, 0, 0, 0, 0, math.pi / 2)
    assert np.allclose(
        relative_pose(T, (0.1, 0, 0), frame="base", T_world_base=base).position, [0.3, 0.1, 0.2]
    )
    with pytest.raises(PlanningError, match="known: base, tool, world"):
        relative_pose(T, (0, 0, 0.1), frame="flange")


def test_bad_arguments(scene):
    T0 = scene.link_pose("tcp")
    with pytest.raises(PlanningError, match="eef_step"):
        compute_cartesian_path(scene, "arm", [T0], eef_step=0)
    with pytest.raises(PlanningError, match="at least one waypoint"):
        compute_cartesian_path(scene, "arm", [])
    with pytest.raises(PlanningError, match="waypoint 0"):
        compute_cartesian_path(scene, "arm", ["up"])


def test_a_step_whose_joints_move_fast_is_split_not_called_a_jump(scene):
    """With long steps and a small joint step allowed, each step is followed in finer steps:
    the path is complete, continuous within the allowed joint step, and still straight."""
    arm = scene.robot.group("arm")
    T0 = scene.link_pose("tcp")
    target = relative_pose(T0, (0.0, 0.12, 0.0))
    coarse = compute_cartesian_path(scene, "arm", [target], eef_step=0.04, link="tcp")
    assert coarse.fraction == 1.0
    step = float(np.abs(np.diff(coarse.path, axis=0)).max())
    cp = compute_cartesian_path(
        scene, "arm", [target], eef_step=0.04, link="tcp", max_joint_step=0.6 * step
    )
    assert cp.fraction == 1.0 and cp.reason == ""
    assert len(cp.path) > len(coarse.path)
    assert float(np.abs(np.diff(cp.path, axis=0)).max()) <= 0.6 * step + 1e-12
    pts = np.array([fk(arm, q, "tcp")[:3, 3] for q in cp.path])
    d = (target.position - T0.position) / np.linalg.norm(target.position - T0.position)
    rel = pts - T0.position
    assert np.linalg.norm(rel - (rel @ d)[:, None] * d, axis=1).max() < 1e-5
    # a limit no split can meet is still a jump
    cp = compute_cartesian_path(
        scene, "arm", [target], eef_step=0.04, link="tcp", max_joint_step=step / 100
    )
    assert cp.fraction < 1.0 and "joint jump" in cp.reason


def _swing(irb120):
    """The IRB 120's base joint swinging 0.6 rad past a post its tool passes through midway,
    both ends free: a scene, its checker, and the swing's two ends."""
    scene = PlanningScene(irb120)
    arm = irb120.group("arm")
    a = np.array([-0.3, 0.3, 0.2, 0.0, 0.8, 0.0])
    b = a * [-1, 1, 1, 1, 1, 1]
    scene.add_cylinder("post", Pose(fk(arm, a * [0, 1, 1, 1, 1, 1], "tcp")[:3, 3]), 0.01, 0.3)
    checker = scene.checker(arm)
    assert not checker.check(np.array([a, b])).any()
    return scene, checker, a, b


def test_the_continuous_check_stops_a_path_before_a_collision_between_its_steps(irb120):
    """Two free steps with the post between them: proven only up to the first; a free step
    before them is kept, its spline proven free."""
    from robocell.planning.cartesian import _prove_spline

    _, checker, a, b = _swing(irb120)
    last, reason = _prove_spline(checker, np.array([a, b]), 1e-4)
    assert last == 0 and "collision before step 1" in reason and "post" in reason
    before = a + [-0.2, 0.0, 0.0, 0.0, 0.0, 0.0]
    last, reason = _prove_spline(checker, np.array([before, a, b]), 1e-4)
    assert last == 1 and "post" in reason
    free, why = _prove_spline(checker, np.array([before, a]), 1e-4)
    assert free == 1 and why == ""


def test_a_continuous_cartesian_path_is_proven_free_as_it_will_run(scene):
    """With ``continuous`` the path's spline (what time_optimal(smooth=True) runs along) has
    no colliding configuration, densely sampled and checked by coal; into a post, the path
    stops before it and says so."""
    from robocell.scene.swept import TOLERANCE
    from robocell.trajectory import SplinePath

    arm = scene.robot.group("arm")
    checker = scene.checker(arm)
    T0 = scene.link_pose("tcp")
    line = [relative_pose(T0, (0.0, 0.12, 0.08))]
    cp = compute_cartesian_path(scene, "arm", line, link="tcp", continuous=TOLERANCE)
    assert cp.fraction == 1.0 and cp.reason == ""
    path = SplinePath(cp.path)
    assert checker.swept().check_path(path).free
    scene.add_box("post", Pose(T0.position + [0.0, 0.1, 0.0]), [0.05, 0.02, 0.4])
    checker = scene.checker(arm)
    target = [relative_pose(T0, (0, 0.2, 0))]
    cp = compute_cartesian_path(scene, "arm", target, link="tcp", continuous=TOLERANCE)
    assert 0.0 < cp.fraction < 0.5 and "collision" in cp.reason and "post" in cp.reason
    path = SplinePath(cp.path)
    s = np.linspace(0.0, path.length, int(path.length / 2e-4) + 2)
    assert not checker.check_exact(path(s)).any()
