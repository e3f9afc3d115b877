"""The continuous check: its bound on how far points move, and its answers against dense exact
sampling (a path it calls free never collides; one it does not has a colliding configuration
where it says)."""

import numpy as np
import pytest

from robocell import PlanningScene, Pose
from robocell.errors import SceneError
from robocell.kinematics import fk
from robocell.scene import _kernels as K
from robocell.scene.swept import SweptCheck, motion_radii
from robocell.trajectory import BlendedPath, SplinePath


@pytest.fixture
def cluttered(irb120):
    """The IRB 120 among a thin plate, a post and a ball, holding a box."""
    scene = PlanningScene(irb120)
    scene.add_box("floor", Pose([0, 0, -0.02]), [2.0, 2.0, 0.02])
    scene.add_box("plate", Pose([0.45, 0.0, 0.35]), [0.3, 0.002, 0.3])
    scene.add_cylinder("post", Pose([0.0, 0.45, 0.3]), 0.02, 0.6)
    scene.add_sphere("ball", Pose([-0.3, -0.35, 0.45]), 0.06)
    return scene


def _leaf_points(checker, q):
    """The centres of every kernel body's leaves at group configuration q, per body."""
    model = checker.kernel_inputs()[0]
    f = K.MODEL_FIELDS.index
    link, T_body, root = model[f("body_link")], model[f("body_T")], model[f("body_root")]
    nodes, left = model[f("nodes")], model[f("left")]
    T = checker._link_poses(checker._full(np.asarray(q, float)[None])[0])
    ends = np.append(root[1:], len(nodes))
    out = []
    for b in range(len(link)):
        leaves = nodes[root[b] : ends[b]][left[root[b] : ends[b]] < 0, :3]
        M = T[link[b]] @ T_body[b]
        out.append(leaves @ M[:3, :3].T + M[:3, 3])
    return out


@pytest.mark.parametrize("robot", ["irb120", "ur5e"])
def test_points_move_no_farther_than_the_motion_radii_say(robot, request):
    model = request.getfixturevalue(robot)
    scene = PlanningScene(model)
    group = model.groups[0] if isinstance(model.groups, list) else next(iter(model.groups.values()))
    checker = scene.checker(group)
    swept = SweptCheck(checker)
    radii = motion_radii(checker)
    model_arrays = checker.kernel_inputs()[0]
    assert radii.joint.shape[0] == len(model_arrays[K.MODEL_FIELDS.index("body_link")])
    rng = np.random.default_rng(7)
    pairs = model_arrays[K.MODEL_FIELDS.index("self_pairs")]
    for _ in range(40):
        q = rng.uniform(group.lower, group.upper)
        dq = rng.normal(size=group.dof) * rng.uniform(0.001, 0.05)
        p0, p1 = _leaf_points(checker, q), _leaf_points(checker, q + dq)
        bound = swept.body_radii @ np.abs(dq)
        for b in range(len(p0)):
            moved = np.linalg.norm(p1[b] - p0[b], axis=1).max(initial=0.0)
            assert moved <= bound[b] + 1e-12
        rel = swept.pair_radii @ np.abs(dq)
        for k, (a, b) in enumerate(pairs):
            i = rng.integers(0, len(p0[a]), 300)
            j = rng.integers(0, len(p0[b]), 300)
            d0 = np.linalg.norm(p0[a][i] - p0[b][j], axis=1)
            d1 = np.linalg.norm(p1[a][i] - p1[b][j], axis=1)
            assert np.abs(d1 - d0).max() <= rel[k] + 1e-12


def _answers_hold(cluttered, paths):
    """How many of the paths ``paths(arm, checker)`` yields the continuous check calls free
    and how many not, each answer checked: a path called free has no colliding sample
    0.2 mrad apart (coal's exact check); one not called free collides where the check says
    (the checker's check, which counts bodies closer than a micrometre as touching). The
    check's tolerances at 10 µm (not the default 0.1 mm for the world and half a millimetre
    between links), so that pairs are proven exactly."""
    arm = cluttered.robot.group("arm")
    checker = cluttered.checker(arm)
    swept = SweptCheck(checker, tolerance=1e-5, self_tolerance=1e-5)
    free_paths = colliding = 0
    for path in paths(arm, checker):
        result = swept.check_path(path)
        if result.free:
            free_paths += 1
            s = np.linspace(0.0, path.length, int(path.length / 2e-4) + 2)
            assert not checker.check_exact(path(s)).any()
        else:
            colliding += 1
            assert checker.check(path(np.array([result.at])))[0]
    return free_paths, colliding


def test_a_motion_called_free_never_collides_and_one_not_called_free_does(cluttered):
    """Random bent paths among the obstacles (and the robot itself), corners rounded."""

    def bent(arm, checker):
        rng = np.random.default_rng(11)
        for _ in range(300):
            a = rng.uniform(arm.lower, arm.upper)
            b = a + rng.normal(size=arm.dof) * 0.6
            c = b + rng.normal(size=arm.dof) * 0.6
            if not checker.check(np.array([a, b, c])).any():
                yield BlendedPath(np.array([a, b, c]), 0.05)

    free_paths, colliding = _answers_hold(cluttered, bent)
    assert free_paths >= 5 and colliding >= 5


def _swing_past_post(irb120, offset):
    """The IRB 120's base joint swinging its arm 0.6 rad in one straight motion past a post
    (a 2 cm rod) placed ``offset`` [m] beyond where the tool's origin passes, outward; the
    scene's checker and the swing."""
    scene = PlanningScene(irb120)
    arm = irb120.group("arm")
    a = np.array([-0.3, 0.3, 0.2, 0.0, 0.8, 0.0])
    b = a * [-1, 1, 1, 1, 1, 1]
    p = fk(arm, a * [0, 1, 1, 1, 1, 1], "tcp")[:3, 3]
    out = np.array([p[0], p[1], 0.0]) / np.hypot(p[0], p[1])
    scene.add_cylinder("post", Pose(p + offset * out), 0.01, 0.3)
    return scene.checker(arm), BlendedPath(np.array([a, b]), 0.0)


def test_a_post_the_swing_passes_through_between_its_ends_is_found(irb120):
    checker, swing = _swing_past_post(irb120, 0.0)
    assert not checker.check(swing(np.array([0.0, swing.length]))).any()  # both ends free
    result = checker.swept().check_path(swing)
    assert not result.free
    assert checker.check(swing(np.array([result.at])))[0]


def test_a_swing_that_misses_the_post_by_half_a_millimetre_is_proven_free(irb120):
    """The post's offset where the swing just touches it, by bisection on dense exact samples
    (0.1 mm of tool motion apart); half a millimetre beyond it the swing is proven free, half
    a millimetre short of it it is not."""
    s = None
    lo, hi = 0.0, 0.3
    for _ in range(16):
        mid = 0.5 * (lo + hi)
        checker, swing = _swing_past_post(irb120, mid)
        s = np.linspace(0.0, swing.length, 6000)
        if checker.check_exact(swing(s)).any():
            lo = mid
        else:
            hi = mid
    assert 0.0 < lo < 0.29  # the swing does pass the post
    checker, swing = _swing_past_post(irb120, hi + 0.0005)
    assert checker.swept().check_path(swing).free
    checker, swing = _swing_past_post(irb120, lo - 0.0005)
    result = checker.swept().check_path(swing)
    assert not result.free
    assert checker.check(swing(np.array([result.at])))[0]


def test_bad_tolerances_are_refused(cluttered):
    checker = cluttered.checker("arm")
    with pytest.raises(SceneError, match="tolerance"):
        SweptCheck(checker, tolerance=0.0)
    with pytest.raises(SceneError, match="first_pad"):
        SweptCheck(checker, first_pad=1e-6, tolerance=1e-5)


def test_a_scene_that_collides_whatever_the_arm_does_is_never_proven_free(irb120):
    """A box through the robot's base: a pair no joint of the arm separates."""
    scene = PlanningScene(irb120)
    scene.add_box("through_base", Pose([0.0, 0.0, 0.05]), [0.3, 0.3, 0.1])
    checker = scene.checker("arm")
    assert checker.static_collisions
    a = np.zeros(6)
    path = BlendedPath(np.array([a, a + 0.3]), 0.0)
    assert not checker.swept().check_path(path).free


def test_a_path_the_budget_cannot_prove_is_not_called_free(irb120, monkeypatch):
    """With a budget of 2 tests per first part, the swing that misses the post by 0.3 mm is
    not proven (and not said to collide); with the default budget it is proven free."""
    from robocell.scene import swept as swept_module

    lo, hi = 0.0, 0.3
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        checker, swing = _swing_past_post(irb120, mid)
        if checker.check_exact(swing(np.linspace(0.0, swing.length, 6000))).any():
            lo = mid
        else:
            hi = mid
    checker, swing = _swing_past_post(irb120, hi + 0.0003)
    assert checker.swept().check_path(swing).free
    monkeypatch.setattr(swept_module, "BUDGET", 2)
    result = swept_module.SweptCheck(checker).check_path(swing)
    assert not result.free and not result.collides
    assert 0.0 <= result.at <= swing.length


def test_a_spline_called_free_never_collides_and_one_not_called_free_does(cluttered):
    """The same for cubic splines through random waypoints (the path a Cartesian motion's
    steps are executed along): its cubic pieces are proven as segments and arcs are."""

    def splines(arm, checker):
        rng = np.random.default_rng(5)
        for _ in range(300):
            wp = rng.uniform(arm.lower, arm.upper) + np.cumsum(
                rng.normal(size=(4, arm.dof)) * 0.6, axis=0
            )
            if not checker.check(wp).any():
                yield SplinePath(wp)

    free_paths, colliding = _answers_hold(cluttered, splines)
    assert free_paths >= 5 and colliding >= 5
