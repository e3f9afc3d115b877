"""The planner: goals of each kind, validation of the executed path, errors."""

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from robocell import Pose
from robocell.errors import ModelError, PlanningError
from robocell.kinematics import fk
from robocell.planning import (
    JointGoal,
    MotionPlanRequest,
    Planner,
    PlannerConfig,
    PoseGoal,
    PositionGoal,
)
from robocell.planning.rrt import Edges, Seeds, rrt_connect_compiled
from robocell.scene.moveit_yaml import load_request, load_scene
from robocell.trajectory import BlendedPath
from tests.conftest import beyond_reach, mbm_dir
from tests.planning.conftest import GOAL, START


def _assert_valid(scene, group, plan):
    """The plan's executed path (2000 samples of its trajectory) is collision-free, exactly;
    so is the path as executed at the planner's validation resolution; and the trajectory
    follows that path within the limits. (The planner's final check is discrete, as MoveIt's:
    see PlannerConfig. These plans are free at the trajectory's samples too.)"""
    from scipy.spatial import cKDTree

    assert plan.success, plan.reason
    checker = scene.checker(group)
    path = BlendedPath(plan.path, plan.stats["corner_deviation"])
    assert not checker.check_exact(path.sample_states(PlannerConfig().validation_resolution)).any()
    traj = plan.trajectory
    states = traj.sample(np.linspace(0, traj.duration, 2000)).positions
    assert np.abs(np.diff(states, axis=0)).max() < 0.02
    assert not checker.check_exact(states).any()
    dense = path(np.linspace(0, path.length, max(2, int(path.length / 1e-4))))
    assert cKDTree(dense).query(states)[0].max() < 1e-3
    assert traj.limit_violations(group) == []


def test_joint_goal_around_a_wall(walled):
    arm = walled.robot.group("arm")
    checker = walled.checker(arm)
    assert checker.check_motion(START, GOAL)  # the straight path is blocked
    plan = Planner(walled).plan(MotionPlanRequest("arm", JointGoal(GOAL), start=START))
    _assert_valid(walled, arm, plan)
    assert np.allclose(plan.path[0], START) and np.allclose(plan.path[-1], GOAL)
    assert np.allclose(plan.trajectory.positions[-1], GOAL)
    assert len(plan.path) >= 3


def test_unshortened_paths_are_valid_too(mbm_ur5):
    """Without shortcutting, the search's own path is validated and timed. A connect step can
    repeat a node: the zero-length segment crashed the corner rounding (MBM table_pick 9)."""
    from robocell.planning.planner import PlannerConfig

    folder = mbm_dir() / "ur5" / "problems" / "table_pick_ur5"
    scene = load_scene(mbm_ur5, folder / "scene0009.yaml")
    req = load_request(mbm_ur5, folder / "request0009.yaml", scene)
    group = mbm_ur5.group(req.group)
    request = MotionPlanRequest(req.group, JointGoal(req.goal), start=req.start, seed=9)
    plan = Planner(scene, PlannerConfig(shortcut=False)).plan(request)
    _assert_valid(scene, group, plan)
    assert np.all(np.linalg.norm(np.diff(plan.path, axis=0), axis=1) > 0)


def test_compiled_and_python_searches_both_go_around_the_wall(walled):
    """The compiled search (default) and the Python one (PlannerConfig(compiled=False), the
    fallback that settles unsure states exactly) each find a valid path."""
    from robocell.planning import PlannerConfig
    from robocell.planning.rrt import Edges, rrt_connect_compiled

    arm = walled.robot.group("arm")
    for cfg in (PlannerConfig(), PlannerConfig(compiled=False)):
        plan = Planner(walled, cfg).plan(MotionPlanRequest("arm", JointGoal(GOAL), start=START))
        _assert_valid(walled, arm, plan)
    # the compiled search alone: a path whose every edge is free, from START to GOAL
    edges = Edges(walled.checker(arm), 0.01)
    path = rrt_connect_compiled(
        edges, START, GOAL[None], arm.lower, arm.upper, np.random.default_rng(3), 1e18, 1.0
    )
    assert path is not None and np.allclose(path[0], START) and np.allclose(path[-1], GOAL)
    states = BlendedPath(path, 0.0).sample_states(0.01)
    assert not walled.checker(arm).check_exact(states).any()
    assert edges.stats.iterations > 0 and edges.stats.states > 0


def test_seeded_planning_is_reproducible(walled):
    # the same seed gives the same path as long as the time budget does not cut the search or
    # the shortcutting short: a generous one, so that a loaded machine does not either
    p = Planner(walled)
    a = p.plan(MotionPlanRequest("arm", JointGoal(GOAL), start=START, seed=5, planning_time=60))
    b = p.plan(MotionPlanRequest("arm", JointGoal(GOAL), start=START, seed=5, planning_time=60))
    assert np.array_equal(a.path, b.path)


def test_a_plan_after_a_rest_keeps_to_the_calling_thread_and_finds_the_same_path(walled):
    """After the process rested, the kernel's sleeping threads are slow to wake, and while
    the host keeps one of them off its core they wait for each other (checker.THREADS): a
    plan then runs its searches one after the other and its final check in the calling
    thread, and finds the same path as a plan made while the process is busy and its threads
    run together (searches side by side), mended by the same detours."""
    import time

    import robocell.planning.planner as planner_module
    from robocell.scene.checker import THREADS, threads_rested
    from tests.conftest import busy

    def contended(seconds: float) -> None:  # busy, beside a host that kept the threads waiting
        busy(seconds)
        THREADS.note(wall=2e-3, cpu=1e-3)

    threads_rested()
    time.sleep(0.06)
    assert threads_rested()
    busy(0.03)
    assert not threads_rested()

    calls: list[tuple[str, object]] = []
    search, validate = planner_module.rrt_connect_compiled, planner_module.PK.validate_path

    def spy_search(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(("side_by_side", kwargs["side_by_side"]))
        return search(*args, **kwargs)

    def spy_validate(*args):  # type: ignore[no-untyped-def]
        calls.append(("chunk", args[6]))
        return validate(*args)

    p = Planner(walled)
    request = MotionPlanRequest("arm", JointGoal(GOAL), start=START, seed=9, planning_time=60)
    p.plan(request)  # kernels compiled or loaded (warm_up's own calls are not the plan's)
    paths, repairs = [], []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(planner_module, "rrt_connect_compiled", spy_search)
        mp.setattr(planner_module.PK, "validate_path", spy_validate)
        seen = []
        for rest in (time.sleep, contended, busy):
            THREADS.note(wall=1e-3, cpu=1e-3)  # they ran together (whatever the host did before)
            threads_rested()
            rest(0.06)
            plan = p.plan(request)
            paths.append(plan.path)
            repairs.append(plan.stats.get("repairs", 0))
            seen.append(set(calls))  # (a repair validates once more)
            calls.clear()
    # the searches' call checks the path (side by side, on their threads), and judges and
    # mends it where it finds states not FREE (none UNSURE); the planner checks it only if
    # the threads could not (one after the other, the calling thread checks it whole)
    assert seen[0] == seen[1] == {("side_by_side", False)}
    assert seen[2] - {("chunk", planner_module.FINAL_CHUNK)} == {("side_by_side", None)}
    assert np.array_equal(paths[0], paths[1]) and np.array_equal(paths[0], paths[2])
    assert repairs == [1, 1, 1]  # mended by the same detours, in Python and in the kernel call


def test_the_thread_gauge_keeps_calls_off_threads_the_host_kept_waiting():
    """A call on the kernel's threads whose calling thread waited (its wall time less its CPU
    time) longer than CONTENDED_WAIT and than CONTENDED_SHARE of the call keeps the next
    calls in the calling thread for CONTENDED_FOR, doubling while the threads still wait, up
    to CONTENDED_MAX; a call in which they ran together returns to them at once."""
    import time

    from robocell.scene.checker import (
        CONTENDED_FOR,
        CONTENDED_MAX,
        CONTENDED_SHARE,
        CONTENDED_WAIT,
        ThreadGauge,
    )

    gauge = ThreadGauge()
    assert not gauge.contended()
    gauge.note(wall=1e-3, cpu=1e-3 - 0.9 * CONTENDED_WAIT)  # a short wait: a thread's wake
    assert not gauge.contended()
    long_call = 10 * CONTENDED_WAIT / CONTENDED_SHARE  # waiting CONTENDED_WAIT is no share
    gauge.note(wall=long_call, cpu=long_call - 2 * CONTENDED_WAIT)
    assert not gauge.contended()
    before = time.perf_counter()
    gauge.note(wall=2e-3, cpu=1e-3)
    assert gauge.contended() and gauge.backoff == CONTENDED_FOR
    assert before + CONTENDED_FOR <= gauge.until <= time.perf_counter() + CONTENDED_FOR
    backoffs = []
    for _ in range(12):
        gauge.note(wall=2e-3, cpu=0.0)
        backoffs.append(gauge.backoff)
    assert backoffs[:3] == [2 * CONTENDED_FOR, 4 * CONTENDED_FOR, 8 * CONTENDED_FOR]
    assert max(backoffs) == backoffs[-1] == CONTENDED_MAX
    gauge.note(wall=2e-3, cpu=2e-3)
    assert not gauge.contended() and gauge.backoff == 0.0
    gauge.note(wall=2e-3, cpu=0.0)
    assert gauge.backoff == CONTENDED_FOR  # from the start again
    gauge.until = time.perf_counter() - 1e-3  # its time passed
    assert not gauge.contended()


def test_pose_goal_reaches_the_pose(walled):
    arm = walled.robot.group("arm")
    target = Pose.from_rpy(0.3, 0.25, 0.3, 0, math.pi / 2, 0)
    plan = Planner(walled).plan(MotionPlanRequest("arm", PoseGoal("tcp", target), start=START))
    _assert_valid(walled, arm, plan)
    T = fk(arm, plan.path[-1], "tcp")
    assert np.allclose(T[:3, 3], target.position, atol=1e-5)
    assert np.allclose(T[:3, :3], target.rotation(), atol=1e-5)


def test_position_goal(walled):
    arm = walled.robot.group("arm")
    p = np.array([0.25, -0.3, 0.25])
    plan = Planner(walled).plan(MotionPlanRequest("arm", PositionGoal("tcp", p), start=START))
    _assert_valid(walled, arm, plan)
    assert np.allclose(fk(arm, plan.path[-1], "tcp")[:3, 3], p, atol=1e-4)


def test_goal_tolerances_take_a_goal_met_within_them(walled):
    """MoveIt's goal constraints: a goal no configuration meets exactly is met by one within
    its tolerances. A joint goal touching the floor, a pose and a position 3 mm beyond
    reach: refused with the default tolerances (saying so), planned with wider ones, the
    plan ending free and within them."""
    arm = walled.robot.group("arm")
    checker = walled.checker(arm)
    planner = Planner(walled)
    touching = START.copy()
    while not checker.check(touching)[0]:
        touching[1] += 0.005
    with pytest.raises(PlanningError, match="in collision: .*floor.*tolerance"):
        planner.plan(MotionPlanRequest("arm", JointGoal(touching), start=START))
    plan = planner.plan(MotionPlanRequest("arm", JointGoal(touching, 0.02), start=START))
    _assert_valid(walled, arm, plan)
    end = plan.path[-1]
    assert np.abs(end - touching).max() <= 0.02 and not np.array_equal(end, touching)

    target = beyond_reach(walled, arm, (0.0, -1.0), 0.3, math.pi / 2, 0.003)
    with pytest.raises(PlanningError, match="no solution.*out of reach.*tolerance"):
        planner.plan(MotionPlanRequest("arm", PoseGoal("tcp", target), start=START))
    plan = planner.plan(MotionPlanRequest("arm", PoseGoal("tcp", target, 0.01, 0.01), start=START))
    _assert_valid(walled, arm, plan)
    T = fk(arm, plan.path[-1], "tcp")
    assert 0.003 - 1e-6 <= np.linalg.norm(T[:3, 3] - target.position) <= 0.01
    cos = (np.trace(T[:3, :3].T @ target.rotation()) - 1) / 2
    assert math.acos(min(1.0, cos)) <= 0.01

    # any orientation reaches farther: the edge of what the planner reaches, by bisection
    def reached(r):
        try:
            planner.goal_configurations(arm, PositionGoal("tcp", [0, -r, 0.3]), START, checker)
        except PlanningError as e:
            assert "out of reach" in str(e)
            return False
        return True

    lo, hi = 0.2, 1.2
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if reached(mid) else (lo, mid)
    p = np.array([0, -(hi + 0.003), 0.3])
    with pytest.raises(PlanningError, match="out of reach"):
        planner.plan(MotionPlanRequest("arm", PositionGoal("tcp", p), start=START))
    plan = planner.plan(MotionPlanRequest("arm", PositionGoal("tcp", p, 0.01), start=START))
    _assert_valid(walled, arm, plan)
    assert np.linalg.norm(fk(arm, plan.path[-1], "tcp")[:3, 3] - p) <= 0.01


def test_named_goal_and_mbm_problem(mbm_ur5):
    folder = mbm_dir() / "ur5" / "problems" / "bookshelf_small_ur5"
    scene = load_scene(mbm_ur5, folder / "scene0001.yaml")
    req = load_request(mbm_ur5, folder / "request0001.yaml", scene)
    group = mbm_ur5.group(req.group)
    plan = Planner(scene).plan(
        MotionPlanRequest(req.group, JointGoal(req.goal), start=req.start, planning_time=5.0)
    )
    _assert_valid(scene, group, plan)


def test_unsolved_in_time_is_a_result_not_an_error(walled):
    # the straight path is blocked, and a microsecond is not enough for anything else (a
    # millisecond is, since the search is compiled)
    plan = Planner(walled).plan(
        MotionPlanRequest("arm", JointGoal(GOAL), start=START, planning_time=1e-6)
    )
    assert not plan.success
    assert "no path found" in plan.reason and plan.trajectory is None


def test_errors(walled):
    planner = Planner(walled)
    # values of the wrong kind: a PlanningError naming the field, not a TypeError from inside
    for kwargs, words in (
        ({"seed": "abc"}, "seed"),
        ({"seed": 1.5}, "seed"),
        ({"planning_time": None}, "planning time"),
        ({"attempts": 2.5}, "attempts"),
        ({"velocity_scaling": "1"}, "velocity scaling"),
        ({"planner_id": None}, "planner id"),
    ):
        with pytest.raises(PlanningError, match=words):
            planner.plan(MotionPlanRequest("arm", JointGoal(GOAL), start=START, **kwargs))
    with pytest.raises(PlanningError, match="position goal"):
        planner.plan(MotionPlanRequest("arm", PositionGoal("tcp", "abc"), start=START))
    # goal tolerances of the wrong kind (they decide which states meet a goal)
    inside = np.array([0, 0.6, 0.3, 0, 0, 0])  # in the wall
    for goal, words in (
        (JointGoal(GOAL, -0.1), "joint goal tolerance .* >= 0"),
        (JointGoal(GOAL, "abc"), "joint goal tolerance .* number"),
        (JointGoal(inside, 0.0), "in collision: .*wall.*tolerance"),
        (PoseGoal("tcp", Pose([0.3, 0, 0.3]), np.nan), "position tolerance .* finite"),
        (PoseGoal("tcp", Pose([0.3, 0, 0.3]), 1e-4, -1.0), "orientation tolerance .* >= 0"),
        (PositionGoal("tcp", [0.3, 0, 0.3], None), "position tolerance .* number"),
    ):
        with pytest.raises(PlanningError, match=words):
            planner.plan(MotionPlanRequest("arm", goal, start=START))
    p = fk(walled.robot.group("arm"), START, "tcp")[:3, 3]  # a zero tolerance: met to 1e-9
    plan = planner.plan(MotionPlanRequest("arm", PositionGoal("tcp", p, 0.0), start=GOAL))
    assert np.linalg.norm(fk(walled.robot.group("arm"), plan.path[-1], "tcp")[:3, 3] - p) < 1e-8
    with pytest.raises(ModelError, match="known: arm"):
        planner.plan(MotionPlanRequest("arms", JointGoal(GOAL)))
    with pytest.raises(PlanningError, match="joint_1"):
        planner.plan(
            MotionPlanRequest("arm", JointGoal(np.array([4.0, 0, 0, 0, 0, 0])), start=START)
        )
    with pytest.raises(ModelError, match="NaN"):
        planner.plan(
            MotionPlanRequest("arm", JointGoal(np.array([np.nan, 0, 0, 0, 0, 0])), start=START)
        )
    with pytest.raises(PlanningError, match="in collision: .*wall"):
        planner.plan(
            MotionPlanRequest("arm", JointGoal(GOAL), start=np.array([0, 0.6, 0.3, 0, 0, 0]))
        )
    with pytest.raises(ModelError, match="unknown link .tcpp.; known: .*tcp"):
        planner.plan(MotionPlanRequest("arm", PoseGoal("tcpp", Pose([0.3, 0, 0.3])), start=START))
    with pytest.raises(PlanningError, match="no solution.*(out of reach|reach)"):
        planner.plan(MotionPlanRequest("arm", PoseGoal("tcp", Pose([2.0, 0, 0.3])), start=START))
    with pytest.raises(PlanningError, match="collision"):
        # inside the wall: reachable, but every solution collides
        planner.plan(
            MotionPlanRequest(
                "arm",
                PoseGoal("tcp", Pose.from_rpy(0.4, 0.0, 0.35, 0, math.pi / 2, 0)),
                start=START,
            )
        )
    with pytest.raises(PlanningError, match="planning time"):
        planner.plan(MotionPlanRequest("arm", JointGoal(GOAL), start=START, planning_time=0))
    with pytest.raises(PlanningError, match="unknown planner"):
        planner.plan(MotionPlanRequest("arm", JointGoal(GOAL), start=START, planner_id="RRTfast"))


def test_fix_start_nudges_out_of_collision(walled):
    arm = walled.robot.group("arm")
    checker = walled.checker(arm)
    # a start just touching the floor
    q = START.copy()
    while not checker.check(q)[0]:
        q[1] += 0.005
    with pytest.raises(PlanningError, match="start state in collision: .*floor"):
        Planner(walled).plan(MotionPlanRequest("arm", JointGoal(START), start=q))
    plan = Planner(walled).plan(MotionPlanRequest("arm", JointGoal(START), start=q, fix_start=True))
    assert plan.success
    assert np.allclose(plan.path[0], q)  # the original start, then the nudged one
    assert not checker.check(plan.path[1])[0]
    assert np.abs(plan.path[1] - q).max() < 0.2


def test_the_search_checks_the_start_and_goal_and_the_planner_settles_them(walled, irb120):
    """The compiled search's call classifies the start and the goal before it searches; where
    one is not FREE there, the planner checks it exactly as it would have first: a goal in
    collision raises naming the pair; a start or goal the kernel leaves unsure (near a mesh)
    but free is planned from or to as it is, the same plan each time; and with no time for a
    search at all, a start in collision still raises."""
    from robocell.scene import _kernels as K
    from tests.conftest import past_a_mesh

    arm = walled.robot.group("arm")
    inside = np.array([0, 0.6, 0.3, 0, 0, 0])
    assert walled.checker(arm).check(inside)[0]
    for threads in (True, False):  # the searches side by side, or one after the other
        with pytest.raises(PlanningError, match="joint goal is in collision: .*wall"):
            Planner(walled, PlannerConfig(threads=threads)).plan(
                MotionPlanRequest("arm", JointGoal(inside), start=START)
            )
        # in the search's call, the first search's thread finds the goal not FREE and the
        # call stops: nothing searched, the caller told
        edges = Edges(walled.checker(arm), 0.07)
        path = rrt_connect_compiled(
            edges, START, inside[None], arm.lower, arm.upper, Seeds(0), 1e18, 0.7,
            side_by_side=threads, check_ends=True,
        )  # fmt: skip
        assert path is None and edges.stats.blocked_ends and edges.stats.iterations == 0
    with pytest.raises(PlanningError, match="start state in collision: .*wall"):
        Planner(walled).plan(
            MotionPlanRequest("arm", JointGoal(GOAL), start=inside, planning_time=1e-12)
        )
    scene = past_a_mesh(irb120)
    checker = scene.checker(arm)
    qs = arm.random(np.random.default_rng(5), 4000)
    cls, _ = checker.classify(qs)
    unsure = qs[cls == K.UNSURE]
    free = unsure[~checker.check_exact(unsure)][:2]
    assert len(free) == 2
    planner = Planner(scene)
    plans = [
        planner.plan(MotionPlanRequest("arm", JointGoal(free[1]), start=free[0], seed=3))
        for _ in range(2)
    ]
    assert plans[0].success and np.array_equal(plans[0].path[[0, -1]], free)
    assert np.array_equal(plans[0].path, plans[1].path)


def test_attempts_keep_the_shortest(walled):
    one = Planner(walled).plan(MotionPlanRequest("arm", JointGoal(GOAL), start=START, seed=1))
    many = Planner(walled).plan(
        MotionPlanRequest("arm", JointGoal(GOAL), start=START, seed=1, attempts=4, planning_time=5)
    )
    assert many.success and many.path_length <= one.path_length + 1e-9


@pytest.mark.parametrize("state_check", ["kernel", "exact"])
def test_ompl_backend(walled, state_check):
    pytest.importorskip("ompl")
    arm = walled.robot.group("arm")
    plan = Planner(walled, PlannerConfig(ompl_state_check=state_check)).plan(
        MotionPlanRequest(
            "arm",
            JointGoal(GOAL),
            start=START,
            planner_id="RRTConnectkConfigDefault",
            planning_time=5.0,
        )
    )
    _assert_valid(walled, arm, plan)


def test_ompl_plans_depend_on_their_own_seed_alone(walled):
    """An OMPL plan repeats with its seed, whatever was planned before it in the process (OMPL
    seeds its generators from one sequence per process, restarted before each plan)."""
    pytest.importorskip("ompl")
    config = PlannerConfig(shortcut=False)

    def plan(seed: int) -> NDArray[np.float64]:
        request = MotionPlanRequest(
            "arm", JointGoal(GOAL), start=START, planner_id="RRTConnectkConfigDefault",
            planning_time=5.0, seed=seed,
        )  # fmt: skip
        result = Planner(walled, config).plan(request)
        assert result.success
        return result.path

    first = plan(3)
    other = plan(4)
    again = plan(3)
    assert np.array_equal(first, again)
    assert not (first.shape == other.shape and np.array_equal(first, other))


def test_ompl_simplifies_as_moveit_does(walled):
    """With ompl_simplify, OMPL's own simplifier shortens OMPL's path (the native shortcut is
    skipped), and the path is validated as any other."""
    pytest.importorskip("ompl")
    arm = walled.robot.group("arm")
    request = MotionPlanRequest(
        "arm",
        JointGoal(GOAL),
        start=START,
        planner_id="RRTConnectkConfigDefault",
        planning_time=5.0,
        seed=3,
    )
    raw = Planner(walled, PlannerConfig(shortcut=False)).plan(request)
    simplified = Planner(walled, PlannerConfig(ompl_simplify=True)).plan(request)
    _assert_valid(walled, arm, simplified)
    assert simplified.path_length < raw.path_length


def test_planner_ids_name_ompls_planners_by_their_own_names(walled, monkeypatch):
    """ "RRTConnect" is OMPL's class (as the errors list it), not the native planner, whose
    ids are "", "rrtconnect" and "robocell" (any case); MoveIt's names go to OMPL too."""
    pytest.importorskip("ompl")
    from robocell.planning import ompl_backend

    asked = []
    plan = ompl_backend.plan
    monkeypatch.setattr(
        ompl_backend, "plan", lambda name, *a, **k: asked.append(name) or plan(name, *a, **k)
    )
    planner = Planner(walled)
    for pid in ("RRTConnect", "RRTConnectkConfigDefault", "", "rrtconnect", "ROBOCELL"):
        result = planner.plan(
            MotionPlanRequest("arm", JointGoal(GOAL), start=START, planner_id=pid)
        )
        assert result.success
    assert asked == ["RRTConnect", "RRTConnectkConfigDefault"]


def test_ompl_state_check_must_be_known(walled):
    pytest.importorskip("ompl")
    request = MotionPlanRequest(
        "arm", JointGoal(GOAL), start=START, planner_id="RRTConnectkConfigDefault"
    )
    with pytest.raises(PlanningError, match=r"'fcl'.*known: kernel, exact"):
        Planner(walled, PlannerConfig(ompl_state_check="fcl")).plan(request)


def test_ompl_edges_are_checked_as_the_native_planner_checks_them():
    """OMPL's RRTConnect checks an edge's states at the native resolution per joint, every
    one of them once, the end first and then midpoints (OMPL's order)."""
    from robocell.planning.ompl_backend import _bisection_order

    assert _bisection_order(1) == (1,)
    assert _bisection_order(7) == (7, 3, 1, 5, 2, 4, 6)
    for n in (2, 13, 64):
        order = _bisection_order(n)
        assert order[0] == n and sorted(order) == list(range(1, n + 1))


def test_ompl_motion_validator_checks_per_joint_steps_and_stops_at_a_collision():
    pytest.importorskip("ompl")
    from ompl import base as ob

    from robocell.planning.ompl_backend import _motion_validator

    space = ob.RealVectorStateSpace(2)
    bounds = ob.RealVectorBounds(2)
    bounds.setLow(-2.0)
    bounds.setHigh(2.0)
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    seen = []
    wall = 0.25  # states with x in [0.25, 0.3] collide

    def free(q):
        seen.append(q.copy())
        return not (wall <= q[0] <= 0.3)

    validator = _motion_validator(si, free, 2, 0.05)
    a, b = space.allocState(), space.allocState()
    a[0], a[1], b[0], b[1] = 0.0, 0.0, 0.2, -0.1  # 4 steps of 0.05 in x
    assert validator.checkMotion(a, b)
    xs = [round(float(q[0]), 6) for q in seen]
    assert xs == [0.2, 0.1, 0.05, 0.15]  # the end, then midpoints; the start not checked
    seen.clear()
    b[0] = 0.6  # 12 steps; the end is free, the wall is crossed
    assert not validator.checkMotion(a, b)
    assert wall <= seen[-1][0] <= 0.3 and len(seen) < 12  # stopped at the first collision


def test_the_continuous_check_keeps_a_plan_off_the_wall_between_checked_states(walled):
    """With the shortcut's least gain on, the Python search's plan past the wall (seed 0)
    skims the wall by 0.12 mm between two states the discrete final check found free; with
    PlannerConfig(continuous=True) the executed path is proven free, and a dense exact
    sampling agrees."""
    arm = walled.robot.group("arm")
    checker = walled.checker(arm)
    request = MotionPlanRequest("arm", JointGoal(GOAL), start=START, seed=0)

    def dense(plan):
        path = BlendedPath(plan.path, plan.stats["corner_deviation"])
        return path, path(np.linspace(0.0, path.length, int(path.length / 2e-4) + 2))

    base = dict(compiled=False, shortcut_tries=40, shortcut_min_gain=0.02)
    discrete = Planner(walled, PlannerConfig(**base)).plan(request)
    assert discrete.success and checker.check_exact(dense(discrete)[1]).any()
    plan = Planner(walled, PlannerConfig(**base, continuous=True)).plan(request)
    _assert_valid(walled, arm, plan)
    path, states = dense(plan)
    assert not checker.check_exact(states).any()
    assert checker.swept(PlannerConfig().continuous_tolerance).check_path(path).free
    assert plan.stats["swept_tests"] > 0


def test_the_continuous_check_proves_a_path_where_the_ur5s_wrist_skims_its_forearm(mbm_ur5):
    """MotionBenchMaker UR5 bookshelf_small 33: its path moves the wrist with wrist 2 within
    0.1–0.9 mm of the forearm over a long stretch. Links may pass each other that close: the
    check proves the world clear and checks those stretches exactly at the self tolerance's
    spacing, within its budget (it had taken 300,000 tests and 6 s, session 23)."""
    from robocell.scene.swept import BUDGET

    folder = mbm_dir() / "ur5" / "problems" / "bookshelf_small_ur5"
    scene = load_scene(mbm_ur5, folder / "scene0033.yaml")
    req = load_request(mbm_ur5, folder / "request0033.yaml", scene)
    request = MotionPlanRequest(req.group, JointGoal(req.goal), start=req.start, seed=33)
    plan = Planner(scene, PlannerConfig(continuous=True)).plan(request)
    assert plan.success, plan.reason
    checker = scene.checker(req.group)
    path = BlendedPath(plan.path, plan.stats["corner_deviation"])
    result = checker.swept().check_path(path)
    assert result.free and result.exact > 0
    assert result.tests < BUDGET * 200
    dense = path(np.linspace(0.0, path.length, int(path.length / 1e-3)))
    assert not checker.check(dense).any()
