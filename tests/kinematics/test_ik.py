import dataclasses

import numpy as np
import pytest

from robocell.errors import IKError, ModelError
from robocell.geometry import Pose
from robocell.kinematics import (
    AnalyticIK,
    NumericIK,
    OPWParameters,
    URParameters,
    fk,
    ik_solver,
    pose_error,
    solve_ik,
)
from robocell.scene import PlanningScene


def _round_trips(group, n, seed, tip=None):
    rng = np.random.default_rng(seed)
    counts = []
    for _ in range(n):
        q = group.random(rng)
        T = fk(group, q, tip, relative_to=group.base_link)
        res = solve_ik(group, T, seed=q, tip_link=tip)
        assert res.success, res.reason
        for sol in res.solutions:
            assert group.within_limits(sol)
            ep, er = pose_error(fk(group, sol, tip, relative_to=group.base_link), T)
            assert ep < 1e-6 and er < 1e-6
        # the original configuration is among the solutions (up to conditioning near singularities)
        assert np.min(np.abs(res.solutions - q).max(axis=1)) < 1e-4
        counts.append(len(res.solutions))
    return counts


def test_opw_round_trips_irb120(irb120):
    arm = irb120.group("arm")
    assert ik_solver(arm).name == "opw"
    counts = _round_trips(arm, 200, 0)
    assert max(counts) <= 8 and min(counts) >= 1


def test_opw_gives_eight_solutions_at_a_generic_pose(irb120):
    """With the joint limits opened to ±2π every branch is within reach: 8 solutions (each
    with its 2π wraps) that all reach the pose."""
    arm = dataclasses.replace(
        irb120.group("arm"), lower=np.full(6, -2 * np.pi), upper=np.full(6, 2 * np.pi)
    )
    solver = AnalyticIK(
        arm,
        OPWParameters(
            0, -0.070, 0, 0.290, 0.270, 0.302, 0.072, offsets=(0, 0, -np.pi / 2, 0, 0, 0)
        ),
    )
    T = fk(arm, [0.3, 0.2, -0.4, 0.5, 0.6, 0.7], relative_to="base_link")
    sols = solver.solve(T).solutions
    assert all(max(pose_error(fk(arm, s, relative_to="base_link"), T)) < 1e-6 for s in sols)
    distinct = {tuple(np.round(np.mod(s + np.pi, 2 * np.pi) - np.pi, 6)) for s in sols}
    assert len(distinct) == 8
    assert len(sols) == 8 * 2**6  # each branch with both 2π wraps of every joint


def test_a_solution_on_a_joint_limit_written_to_eight_decimals_is_found(irb120):
    """The IRB 120's joint 6 limit is written ±3.14159265, 3.6e-9 inside ±π: a pose whose
    solution turns joint 6 by exactly π (a side grasp straight out from the base does) keeps
    that solution, on the limit."""
    arm = irb120.group("arm")
    assert arm.upper[5] < np.pi
    for q6 in (np.pi, -np.pi):
        q = np.array([0.436, 1.134, -0.189, 0.0, -0.595, q6])
        T = fk(arm, q, relative_to=arm.base_link)
        res = solve_ik(arm, T, collision_free=False)
        assert res.success, res.reason
        near = res.solutions[np.argmin(np.abs(res.solutions - q).max(axis=1))]
        assert np.abs(near - np.clip(q, arm.lower, arm.upper)).max() < 1e-6
        assert arm.within_limits(near)


def test_ur_round_trips_ur5e(ur5e):
    arm = ur5e.group("manipulator")
    assert ik_solver(arm).name == "ur"
    counts = _round_trips(arm, 100, 1)
    # ±2π on five joints: every branch comes with its 2π wraps
    assert max(counts) >= 64


def test_ur_closed_form_on_the_mbm_ur5(mbm_ur5):
    """The MBM UR5's URDF frames differ from DH (base rotated by π, tool frame ee_link): the fit
    finds the transforms, and the solver agrees with FK."""
    arm = mbm_ur5.group("manipulator")
    solver = AnalyticIK(arm, URParameters(0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823))
    rng = np.random.default_rng(2)
    for _ in range(50):
        q = arm.random(rng)
        T = fk(arm, q, relative_to=arm.base_link)
        sols = solver.solve(T, seed=q).solutions
        assert np.min(np.abs(sols - q).max(axis=1)) < 1e-4


def test_wrong_parameters_are_refused(irb120):
    with pytest.raises(ModelError, match="do not describe group 'arm'"):
        AnalyticIK(
            irb120.group("arm"),
            OPWParameters(
                0, -0.07, 0, 0.3, 0.27, 0.302, 0.072, offsets=(0, 0, -np.pi / 2, 0, 0, 0)
            ),
        )


@pytest.mark.parametrize(
    "robot_name, group", [("mbm_ur5", "manipulator"), ("mbm_panda", "panda_arm")]
)
def test_numeric_ik_round_trips(request, robot_name, group):
    robot = request.getfixturevalue(robot_name)
    g = robot.group(group)
    solver = ik_solver(g)
    assert isinstance(solver, NumericIK)
    rng = np.random.default_rng(4)
    ok = 0
    for _ in range(100):
        q = g.random(rng)
        T = fk(g, q, relative_to=g.base_link)
        res = solve_ik(g, T, rng=rng, timeout=0.2)
        if res.success:
            ok += 1
            assert g.within_limits(res.best)
            assert max(pose_error(fk(g, res.best, relative_to=g.base_link), T)) < 1e-6
    assert ok >= 98


def test_out_of_reach_says_so(irb120):
    arm = irb120.group("arm")
    res = solve_ik(arm, Pose((2.0, 0, 0.5)))
    assert not res.success and "out of reach" in res.reason
    with pytest.raises(IKError, match="no IK solution"):
        _ = res.best


def test_collision_free_filter_and_reason(irb120):
    arm = irb120.group("arm")
    scene = PlanningScene(irb120)
    q = np.array([0.0, 0.3, 0.2, 0.0, 1.0, 0.0])
    T = fk(arm, q, relative_to="base_link")
    free = solve_ik(arm, T, seed=q, checker=scene.checker(arm))
    assert free.success
    # a box around the tool: every solution reaches into it
    scene.add_box("block", Pose.from_matrix(fk(arm, q, "tcp")), (0.1, 0.1, 0.1))
    blocked = solve_ik(arm, T, seed=q, checker=scene.checker(arm))
    assert not blocked.success and "in collision" in blocked.reason
    # without the filter the same pose still has solutions
    assert solve_ik(arm, T, checker=scene.checker(arm), collision_free=False).success


def test_bad_targets(irb120):
    arm = irb120.group("arm")
    with pytest.raises(IKError, match="NaN"):
        solve_ik(arm, np.full((4, 4), np.nan))
    with pytest.raises(IKError, match="4x4"):
        solve_ik(arm, np.eye(3))
    with pytest.raises(ModelError, match="IK seed"):
        solve_ik(arm, Pose((0.4, 0, 0.4)), seed=[0, 0])
    # values of the wrong kind: the same errors, not a TypeError or ValueError from inside
    with pytest.raises(IKError, match="4x4"):
        solve_ik(arm, "abc")
    with pytest.raises(ModelError, match="unknown link"):
        solve_ik(arm, Pose((0.4, 0, 0.4)), tip_link=["tool0"])
    with pytest.raises(ModelError, match="unknown link"):
        fk(arm, np.zeros(6), np.zeros(3))


def test_solvers_do_not_keep_their_robots_alive():
    """IK solvers are cached on their robot: a process that loads robot after robot (a cell
    per layout) does not keep them all, with their collision models."""
    import gc
    import weakref

    from robocell import RobotModel
    from robocell.kinematics import fk, solve_ik

    loaded = []
    for _ in range(10):
        robot = RobotModel.load("irb120_robotiq85")
        arm = robot.group("arm")
        assert solve_ik(arm, fk(arm, arm.named("home"))).success
        loaded.append(weakref.ref(robot))
    del robot, arm
    gc.collect()
    assert sum(r() is not None for r in loaded) <= 4  # what the per-robot caches may keep


@pytest.mark.parametrize("robot_name", ["irb120", "ur5e"])
def test_a_line_followed_in_one_call_is_the_line_solved_step_by_step(request, robot_name):
    """AnalyticIK.follow_line: each step the solution nearest the one before, the same
    configurations as solve_ik step by step; it stops where a step has no solution or jumps."""
    robot = request.getfixturevalue(robot_name)
    arm = robot.group(robot.group_names[0])
    solver = ik_solver(arm)
    assert isinstance(solver, AnalyticIK)
    rng = np.random.default_rng(3)
    stopped = 0
    for _ in range(40):
        q = rng.uniform(arm.lower * 0.8, arm.upper * 0.8)
        T = fk(arm, q, relative_to=arm.base_link)
        offset = rng.normal(size=3) * 0.08
        n = 16
        along, ok = solver.follow_line(T, offset, q, n, 0.3)
        expected, q_k = [], q
        for k in range(1, n + 1):
            T_k = T.copy()
            T_k[:3, 3] += offset * (k / n)
            sols = solve_ik(arm, T_k, seed=q_k).solutions
            if len(sols) == 0 or np.abs(sols[0] - q_k).max() > 0.3:
                break
            q_k = sols[0]
            expected.append(q_k)
        assert ok == (len(expected) == n) and len(along) == len(expected)
        assert np.array_equal(along, np.array(expected).reshape(-1, arm.dof))
        if ok:
            end = fk(arm, along[-1], relative_to=arm.base_link)
            assert np.allclose(end[:3, 3], T[:3, 3] + offset, atol=1e-6)
        stopped += not ok
    assert 0 < stopped < 40  # both outcomes were exercised


@pytest.mark.parametrize("robot_name", ["irb120", "ur5e"])
def test_many_targets_in_one_call_are_each_target_solved_alone(request, robot_name):
    """AnalyticIK.solve_many: each target's solutions, nearest the seed first, exactly as
    solve_ik gives them one target at a time; a target out of reach has none; NaN is refused."""
    robot = request.getfixturevalue(robot_name)
    arm = robot.group(robot.group_names[0])
    solver = ik_solver(arm)
    assert isinstance(solver, AnalyticIK)
    rng = np.random.default_rng(5)
    seed = arm.random(rng) * 0.5
    targets = [fk(arm, arm.random(rng), relative_to=arm.base_link) for _ in range(60)]
    targets[7] = Pose((3.0, 0.0, 0.5)).matrix()  # out of reach
    sols, counts = solver.solve_many(np.array(targets), seed)
    assert counts[7] == 0 and counts.sum() == len(sols) and (counts > 0).sum() >= 55
    alone = [solve_ik(arm, T, seed=seed).solutions for T in targets]
    assert [len(a) for a in alone] == counts.tolist()
    assert np.array_equal(sols, np.vstack(alone))
    with pytest.raises(IKError, match="NaN"):
        solver.solve_many(np.full((2, 4, 4), np.nan), seed)
