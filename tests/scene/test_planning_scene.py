import time

import numpy as np
import pytest

from robocell.errors import GeometryError, ModelError, SceneError
from robocell.geometry import Box, Cylinder, Pose, Sphere
from robocell.kinematics import fk
from robocell.scene import CollisionObject, PlanningScene, scene_to_dict


@pytest.fixture
def scene(irb120):
    s = PlanningScene(irb120)
    s.add_box("table", Pose((0.5, 0.0, 0.05)), (0.4, 0.6, 0.1))
    s.add_cylinder("can", Pose((0.45, 0.2, 0.16)), 0.03, 0.12)
    return s


def _snapshot(scene):
    return scene_to_dict(scene), scene.state.positions.copy()


def _same(a, b):
    return a[0] == b[0] and np.array_equal(a[1], b[1])


def test_add_move_remove(scene):
    assert scene.object_ids == ["table", "can"]
    scene.move_object("can", Pose((0.4, -0.2, 0.16)))
    assert np.allclose(scene.get_object("can").pose.position, [0.4, -0.2, 0.16])
    scene.remove_object("can")
    assert scene.object_ids == ["table"]


@pytest.mark.parametrize(
    "action, error, words",
    [
        (lambda s: s.add_box("table", Pose(), (1, 1, 1)), SceneError, "already exists"),
        (lambda s: s.add_box("x", Pose(), (1, -1, 1)), GeometryError, "positive"),
        (lambda s: s.add_box("x", Pose((0, 0, np.nan)), (1, 1, 1)), GeometryError, "NaN"),
        (lambda s: s.add_sphere("link_1", Pose(), 0.1), SceneError, "robot link"),
        (
            lambda s: s.move_object("tabel", Pose()),
            SceneError,
            "unknown object 'tabel'; known: can, table",
        ),
        (lambda s: s.remove_object("cann"), SceneError, "known: can, table"),
        (lambda s: s.remove_world_object(["can"]), SceneError, "unknown object"),
        (lambda s: s.remove_attached_object(name="can"), SceneError, "not attached"),
        (lambda s: s.remove_attached_object("palm"), ModelError, "unknown link 'palm'"),
        (lambda s: s.detach_object("can"), SceneError, "not attached; attached: \\(none\\)"),
        (
            lambda s: s.attach_object("can", "gripper_palm"),
            ModelError,
            "unknown link 'gripper_palm'",
        ),
        (lambda s: s.attach_object("can", "tool0", ["fingr"]), ModelError, "unknown link 'fingr'"),
        (
            lambda s: s.set_joint_positions("arm", [0, 0, 3.0, 0, 0, 0]),
            SceneError,
            "joint_3=3.0000 not in",
        ),
        (lambda s: s.set_joint_positions("arm", [0, 0]), ModelError, "must have 6 entries"),
        (lambda s: s.allow_collision("can", "tabel"), SceneError, "unknown link or object 'tabel'"),
        # values of the wrong kind: the same errors, not a TypeError from inside
        (lambda s: s.add_box("x", Pose(), 0.1), SceneError, "box's size"),
        (lambda s: s.add_box("x", Pose(), "abc"), SceneError, "box's size"),
        (lambda s: s.set_joint_positions(["arm"], [0] * 6), ModelError, "unknown group"),
        (lambda s: s.set_joint_positions("arm", "abc"), ModelError, "must be numbers"),
        (lambda s: s.set_object_padding("can", "0.01"), SceneError, "padding"),
        (lambda s: s.remove_object(["can"]), SceneError, "unknown object"),
        (lambda s: s.allow_collision(["can"], "table"), SceneError, "unknown link or object"),
        (lambda s: s.checker("arm").check("abc"), ModelError, "must be numbers"),
        (lambda s: s.allow_collision("can", 0.5), SceneError, "unknown link or object 0.5"),
        (lambda s: s.without_padding(None), SceneError, "unknown object None"),
        (lambda s: s.add_mesh("m", Pose(), None), GeometryError, "path must be a str or a Path"),
        (
            lambda s: s.add_object(CollisionObject("bad id!", (Box((1, 1, 1)),), (Pose(),))),
            SceneError,
            "not valid",
        ),
    ],
)
def test_bad_operations_raise_and_change_nothing(scene, action, error, words):
    before = _snapshot(scene)
    with pytest.raises(error, match=words):
        action(scene)
    assert _same(before, _snapshot(scene))


def test_attach_keeps_the_world_pose_and_detach_puts_it_back(irb120):
    scene = PlanningScene(irb120)
    arm = irb120.group("arm")
    q = np.array([0.2, 0.3, 0.1, 0.0, 0.8, 0.0])
    scene.set_joint_positions("arm", q)
    T_tcp = fk(arm, q, "tcp")
    scene.add_box("part", Pose.from_matrix(T_tcp), (0.03, 0.03, 0.03))
    held = scene.attach_object("part", "tool0")
    assert held.touch_links >= {"tool0", "gripper_left_finger", "gripper_right_finger"}
    assert "part" not in scene.object_ids and "part" in scene.attached_objects
    assert not scene.in_collision()  # touching the fingers is allowed
    q2 = np.array([-0.5, 0.1, 0.2, 0.3, 0.6, 0.1])
    scene.set_joint_positions("arm", q2)
    obj = scene.detach_object("part")
    assert np.allclose(obj.pose.matrix(), fk(arm, q2, "tcp"), atol=1e-12)
    with pytest.raises(SceneError, match="is not attached"):
        scene.detach_object("part")


def test_planning_scene_interface_calls_as_moveit_scripts_use_them(scene, irb120):
    """remove_world_object: idempotent by name (a script's clean-up before adding), all for
    None, a held object refused; remove_attached_object: held objects back into the world,
    by name, by link or all; get_known_object_names: world and held ids."""
    assert not scene.remove_world_object("coke_can")  # not there: nothing to do
    scene.add_box("coke_can", Pose((0.3, -0.2, 0.2)), (0.05, 0.05, 0.1))
    assert scene.remove_world_object("coke_can") and "coke_can" not in scene.object_ids
    scene.add_box("part", Pose((0.3, 0.0, 0.4)), (0.02, 0.02, 0.02))
    scene.add_box("other", Pose((0.3, 0.1, 0.4)), (0.02, 0.02, 0.02))
    scene.attach_object("part", "tool0")
    scene.attach_object("other", "link_6")
    assert scene.get_known_object_names() == ["can", "other", "part", "table"]
    with pytest.raises(SceneError, match="held by link 'tool0'; detach it first"):
        scene.remove_world_object("part")
    assert not scene.remove_attached_object("link_5")
    assert scene.remove_attached_object("tool0")  # "part", not "other"
    assert sorted(scene.attached_objects) == ["other"] and "part" in scene.object_ids
    assert np.allclose(scene.get_object("part").pose.position, [0.3, 0.0, 0.4])
    assert scene.remove_attached_object(name="other") and scene.attached_objects == {}
    assert not scene.remove_attached_object()
    assert scene.remove_world_object() and scene.object_ids == []
    assert not scene.remove_world_object()


def test_held_object_collides_with_world_and_robot(irb120):
    scene = PlanningScene(irb120)
    arm = irb120.group("arm")
    q = np.array([0.0, 0.4, 0.3, 0.0, 0.87, 0.0])  # tool pointing down
    scene.set_joint_positions("arm", q)
    T_tcp = fk(arm, q, "tcp")
    assert np.allclose(T_tcp[:3, 0], [0, 0, -1], atol=1e-3)  # approach axis (tool x) points down
    # a 0.2 m bar hanging from the TCP along the approach axis
    T_bar = T_tcp @ Pose.from_rpy(0.1, 0, 0, 0, np.pi / 2, 0).matrix()
    scene.add_cylinder("bar", Pose.from_matrix(T_bar), 0.01, 0.2)
    scene.attach_object("bar", "tool0")
    assert not scene.in_collision()
    # a floor whose top is 1 cm above the bar's lower end
    scene.add_box("floor", Pose(T_tcp[:3, 3] - [0, 0, 0.2 + 0.05 - 0.01]), (0.3, 0.3, 0.1))
    assert ("bar", "floor") in scene.colliding_pairs() or (
        "floor",
        "bar",
    ) in scene.colliding_pairs()
    scene.allow_collision("bar", "floor")
    assert not scene.in_collision()


def test_colliding_pairs_and_distance(scene, irb120):
    arm = irb120.group("arm")
    home = arm.named("home")
    assert not scene.in_collision(home, arm)
    d = scene.distance(home, arm)
    assert d.distance > 0
    down = np.array([0.0, 1.2, 0.3, 0.0, 0.0, 0.0])  # arm swung down into the table
    assert scene.in_collision(down, arm)
    pairs = scene.colliding_pairs(down, arm)
    assert any("table" in p for p in pairs)
    assert scene.distance(down, arm).distance <= 0.0


def test_acm_allows_and_forbids(scene, irb120):
    down = np.array([0.0, 1.2, 0.3, 0.0, 0.0, 0.0])
    links = [
        p[0] if p[1] == "table" else p[1]
        for p in scene.colliding_pairs(down, "arm")
        if "table" in p
    ]
    for link in links:
        scene.allow_collision(link, "table")
    assert not any("table" in p for p in scene.colliding_pairs(down, "arm"))
    scene.allow_collision(links[0], "table", False)
    assert any("table" in p for p in scene.colliding_pairs(down, "arm"))


def _exact_agrees(checker, qs):
    fast = checker.check(qs)
    exact = checker.check_exact(qs)
    free_but_hit = np.flatnonzero(~fast & exact)
    return fast, exact, free_but_hit


def test_exact_check_of_one_state_agrees_with_the_batch(scene, irb120):
    """check_exact_one (coal through a broad phase, one state per call) answers as the
    batched exact check does, on random states and on states within 0.1 mrad of contact."""
    scene.add_sphere("ball", Pose((0.3, -0.3, 0.4)), 0.08)
    scene.add_shape("post", Cylinder(0.05, 0.8), Pose((-0.3, 0.3, 0.4)))
    arm = irb120.group("arm")
    checker = scene.checker(arm)
    qs = arm.random(np.random.default_rng(3), 400)
    exact = checker.check_exact(qs)
    free, hit = qs[~exact][:20], qs[exact][:20]
    near = []
    for a, b in zip(free, hit, strict=True):  # bisect each free-hit pair to the contact
        for _ in range(14):
            m = (a + b) / 2
            a, b = (a, m) if checker.check_exact(m[None])[0] else (m, b)
        near += [a, b]
    qs = np.vstack([qs, near])
    one = np.array([checker.check_exact_one(q) for q in qs])
    assert np.array_equal(one, checker.check_exact(qs))
    assert one[-40:].sum() == 20  # both sides of every contact


def test_collides_answers_as_check_does_for_one_state(scene, irb120):
    """collides(q) is check() of one state: on random states (free, colliding, and the
    kernel's unsure ones settled exactly), and it refuses a batch or a bad vector."""
    from tests.conftest import mbm_dir

    stl = mbm_dir() / "ur5" / "meshes" / "robotiq_fts300.stl"  # a mesh: unsure states
    scene.add_mesh("sensor", Pose((0.35, 0.0, 0.45)), stl, scale=(3, 3, 3))
    arm = irb120.group("arm")
    checker = scene.checker(arm)
    qs = arm.random(np.random.default_rng(5), 600)
    cls, _ = checker.classify(qs)
    assert {0, 1, 2} <= set(cls.tolist())  # every class of the kernel is met
    one = np.array([checker.collides(q) for q in qs])
    assert np.array_equal(one, checker.check(qs))
    assert checker.collides(list(qs[0])) == bool(checker.check(qs[:1])[0])
    with pytest.raises(SceneError, match="one configuration"):
        checker.collides(qs[:2])
    with pytest.raises(ModelError, match="NaN"):
        checker.collides(np.full(arm.dof, np.nan))


def test_a_batch_after_a_rest_is_checked_in_the_calling_thread(scene, irb120, monkeypatch):
    """After the process rested (the kernel's sleeping threads slow to wake), or while the
    host keeps the threads waiting (checker.THREADS), a batch of up to REST_CHUNK states is
    classified in the calling thread; while the process is busy and its threads run
    together, on the kernel's threads. The answers are the same."""
    from robocell.scene import checker as checker_module
    from tests.conftest import busy

    arm = irb120.group("arm")
    checker = scene.checker(arm)
    qs = arm.random(np.random.default_rng(2), 300)
    checker.check(qs)  # compiled or loaded
    threaded = []
    parallel = checker_module.K.classify_in
    monkeypatch.setattr(
        checker_module.K,
        "classify_in",
        lambda *args: threaded.append(len(args[0])) or parallel(*args),
    )

    def contended(seconds: float) -> None:  # busy, beside a host that kept the threads waiting
        busy(seconds)
        checker_module.THREADS.note(wall=2e-3, cpu=1e-3)

    answers = []
    for rest in (time.sleep, contended, busy):
        checker_module.THREADS.note(wall=1e-3, cpu=1e-3)  # they ran together
        checker_module.threads_rested()
        rest(0.06)
        answers.append(checker.check(qs))
    assert threaded == [300]  # the last batch only
    assert all(np.array_equal(answers[0], a) for a in answers[1:])
    assert answers[0].any() and not answers[0].all()


def test_the_threads_chunks_answer_as_the_calling_thread_does(irb120):
    """The kernel's threads take chunks of a batch in turn: every state is classified once,
    with the same class and unsure pairs as in the calling thread, whatever the chunk's size
    (one state, fewer chunks than threads, a chunk that does not divide the batch), past a
    mesh that leaves states unsure. A chunk of one state is placed alone (fk_into), larger ones
    a block of states at a time (fk_block), as are the calling thread's; a scan that stops at
    the first state not FREE places its first state alone, then blocks of 8 and 16."""
    from robocell.scene import _kernels as K
    from robocell.scene.checker import next_epoch
    from tests.conftest import past_a_mesh

    arm = irb120.group("arm")
    checker = past_a_mesh(irb120).checker(arm)
    inputs = checker.compiled_inputs
    many = arm.random(np.random.default_rng(5), 4000)
    first, _ = K.classify_serial_in(many, inputs, next_epoch(4000), True, False, 0)
    # a batch of 301 with unsure states (near contact) among the others
    pick = np.concatenate([np.flatnonzero(first == K.UNSURE)[:60], np.arange(241)])
    qs = np.ascontiguousarray(many[np.random.default_rng(6).permutation(pick)])
    cls, flags = K.classify_serial_in(qs, inputs, next_epoch(301), True, False, 0)
    assert {K.FREE, K.HIT, K.UNSURE} <= set(cls.tolist())  # the batch has all three
    for chunk in (1, 7, 64, 200, 301, 1000):
        got, got_flags = K.classify_in(qs, inputs, next_epoch(301), True, chunk)
        assert np.array_equal(got, cls), chunk
        unsure = cls == K.UNSURE
        assert np.array_equal(got_flags[unsure], flags[unsure]), chunk
    # a scan through k free states to a hit or an unsure one: its blocks end anywhere
    free = qs[cls == K.FREE][:40]
    for stopper in (K.HIT, K.UNSURE):
        q_stop = qs[cls == stopper][:1]
        for k in (0, 1, 5, 9, 24, 33):
            sub = np.ascontiguousarray(np.vstack([free[:k], q_stop, free[k:]]))
            got, _ = K.classify_serial_in(sub, inputs, next_epoch(len(sub)), True, True, 0)
            expected = [K.FREE] * k + [stopper] + [K.UNCHECKED] * (len(sub) - k - 1)
            assert got.tolist() == expected, (stopper, k)


def test_an_edge_scan_counts_the_free_states_before_the_first_that_is_not(irb120):
    """scan (a search's edge check: the model and the slot's work arrays as one Scanner,
    read without reference counting) returns how many leading states are FREE, as the
    classifier says, for edges longer than its buffer (chunks of 8) and its first ``n`` states
    alone; the scratch slot's stamps carry over from call to call without mixing states. The
    scanners a checker keeps for its kernel calls scan the same."""
    from numba import njit
    from numba.typed import List

    from robocell.scene import _kernels as K
    from robocell.scene.checker import next_epoch
    from tests.conftest import past_a_mesh

    @njit
    def scan_each(batches, n, model, scratch, epoch):  # type: ignore[no-untyped-def]
        sc = K.scanner(model, scratch, 0, 8)
        out = np.empty(len(batches), np.int64)
        for i in range(len(batches)):
            out[i] = K.scan(batches[i], n[i], sc, epoch + 100 * i)
        return out

    arm = irb120.group("arm")
    checker = past_a_mesh(irb120).checker(arm)
    model, scratch = checker.kernel_inputs()
    qs = arm.random(np.random.default_rng(7), 3000)
    cls, _ = K.classify_serial_in(qs, checker.compiled_inputs, next_epoch(3000), True, False, 0)
    free = qs[cls == K.FREE][:40]
    batches, n, expected = [], [], []
    for stopper in (K.HIT, K.UNSURE):
        q_stop = qs[cls == stopper][:1]
        for k in (0, 1, 7, 8, 9, 20, 33):
            batch = np.ascontiguousarray(np.vstack([free[:k], q_stop, free[k:]]))
            batches.append(batch)
            n.append(len(batch))
            expected.append(k)
            batches.append(batch)  # its first k states only: all free
            n.append(k)
            expected.append(k)
    got = scan_each(List(batches), np.array(n), model, scratch, next_epoch(100 * len(n)))
    assert got.tolist() == expected
    # the checker's own scanners (one per scratch slot, kept for its kernel calls) stop where
    # a new one does, in every slot, and again on a later call
    kept = K.scanners_in(checker.compiled_inputs)
    assert len(kept) == scratch[0].shape[0]
    for _ in range(2):
        for slot in range(len(kept)):
            epoch = next_epoch(100 * len(n))
            got = [
                K.scan(b, m, kept[slot], epoch + 100 * i)
                for i, (b, m) in enumerate(zip(batches, n, strict=True))
            ]
            assert got == expected


def test_the_scanners_meminfo_layout_is_numbas():
    """_scanner_fields reads a Scanner's data pointer from numba's MemInfo as robocell spells
    it out (_MEMINFO): the same struct as numba's runtime's own description, whose fourth
    field (the data pointer) NRT_MemInfo_data_fast reads."""
    from numba.core.runtime import nrtdynmod

    from robocell.scene import _kernels as K

    assert str(K._MEMINFO) == str(nrtdynmod._meminfo_struct_type)


@pytest.mark.parametrize("seed", [0, 1])
def test_fast_check_never_calls_a_colliding_state_free(scene, irb120, seed):
    scene.add_sphere("ball", Pose((0.3, -0.3, 0.4)), 0.08)
    scene.add_shape("post", Cylinder(0.05, 0.8), Pose((-0.3, 0.3, 0.4)))
    arm = irb120.group("arm")
    checker = scene.checker(arm)
    qs = arm.random(np.random.default_rng(seed), 4000)
    fast, exact, free_but_hit = _exact_agrees(checker, qs)
    assert len(free_but_hit) == 0
    assert 0.05 < exact.mean() < 0.95  # the sample exercises both answers
    # the sphere level decides most states by itself
    cls, _ = checker.classify(qs)
    assert (cls != 2).mean() > 0.7


def test_primitive_robot_is_settled_in_the_kernel(scene, irb120):
    """A robot and a held object made of primitives against primitive obstacles: the kernel's
    exact test (GJK) settles every state, and its answer is coal's."""
    arm = irb120.group("arm")
    q = np.array([0.0, 0.4, 0.3, 0.0, 0.87, 0.0])
    scene.set_joint_positions("arm", q)
    T_tcp = fk(arm, q, "tcp")
    scene.add_box("part", Pose.from_matrix(T_tcp), (0.03, 0.04, 0.12))
    scene.attach_object("part", "tool0")
    scene.add_sphere("ball", Pose((0.3, -0.3, 0.4)), 0.08)
    checker = scene.checker(arm)
    qs = arm.random(np.random.default_rng(5), 3000)
    cls, _ = checker.classify(qs)
    assert (cls != 2).mean() > 0.99
    fast, exact, _ = _exact_agrees(checker, qs)
    assert np.array_equal(fast, exact)
    assert 0.05 < exact.mean() < 0.95


@pytest.mark.parametrize(
    ("robot", "group_name", "named"),
    [("mbm_ur5", "manipulator", "home"), ("mbm_panda", "panda_arm", "ready")],
)
def test_mesh_robot_with_a_held_box_is_never_called_free_in_collision(
    robot, group_name, named, request
):
    """Mesh links: pairs of links go through one tree against the other's distance grid; a
    held box through the exact primitive distance. No state the fast path calls free collides."""
    model = request.getfixturevalue(robot)
    group = model.group(group_name)
    scene = PlanningScene(model)
    scene.set_joint_positions(group.name, group.named(named))
    T_tip = scene.link_pose(group.tip_link).matrix()
    scene.add_box("part", Pose.from_matrix(T_tip), (0.05, 0.05, 0.15))
    # held in the hand: it may touch the links it touches where it is picked up
    touching = {a if b == "part" else b for a, b in scene.colliding_pairs() if "part" in (a, b)}
    scene.attach_object("part", group.tip_link, sorted(touching))
    assert not scene.in_collision()
    scene.add_box("table", Pose((0.5, 0.0, 0.1)), (0.5, 0.8, 0.2))
    scene.add_cylinder("post", Pose((-0.3, 0.3, 0.4)), 0.05, 0.8)
    checker = scene.checker(group)
    qs = group.random(np.random.default_rng(11), 2500)
    fast, exact, free_but_hit = _exact_agrees(checker, qs)
    assert len(free_but_hit) == 0
    assert 0.05 < exact.mean() < 0.95


def test_check_motion(scene, irb120):
    arm = irb120.group("arm")
    checker = scene.checker(arm)
    a = np.array([-1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert not checker.check_motion(a, a + [2.0, 0, 0, 0, 0, 0])
    down = np.array([0.0, 1.2, 0.3, 0.0, 0.0, 0.0])
    assert checker.check_motion(arm.named("home"), down)
    states = checker.motion_states(a, a + [0.1, 0, 0, 0, 0, 0], resolution=0.01)
    assert len(states) == 11 and np.allclose(states[-1, 0], -0.9)
    with pytest.raises(SceneError, match="resolution"):
        checker.check_motion(a, a, resolution=0)


def test_checker_sees_scene_changes(scene, irb120):
    arm = irb120.group("arm")
    q = np.array([0.0, 0.5, 0.0, 0.0, 0.5, 0.0])
    assert not scene.in_collision(q, arm)
    scene.add_shape("blocker", Sphere(0.05), Pose.from_matrix(fk(arm, q, "tcp")))
    assert scene.in_collision(q, arm)
    scene.remove_object("blocker")
    assert not scene.in_collision(q, arm)


def test_checkers_alive_at_once_never_share_merge_buffers(irb120):
    """A checker's packed bodies (links, the gripper's cluster union, the held object) are
    written into buffers recycled from checkers no longer alive, where the links' arrays are
    already: checkers alive at the same time keep theirs, and a recycled merge checks states
    exactly as the first one did."""
    import gc

    from robocell.scene import checker as checker_module

    arm = irb120.group("arm")
    q = np.array([0.0, 0.4, 0.3, 0.0, 0.87, 0.0])  # tool pointing down
    T_tcp = fk(arm, q, "tcp")
    qs = q + np.random.default_rng(7).uniform(-0.6, 0.6, (300, arm.dof))

    def holding(length):
        """A checker of the arm holding a bar of ``length`` [m] down from the TCP, above a
        table that a long bar hits."""
        s = PlanningScene(irb120)
        s.set_joint_positions("arm", q)
        T_bar = T_tcp @ Pose.from_rpy(length / 2, 0, 0, 0, np.pi / 2, 0).matrix()
        s.add_cylinder("bar", Pose.from_matrix(T_bar), 0.01, length)
        s.attach_object("bar", "tool0")
        s.add_box("table", Pose((0.45, 0.0, T_tcp[2, 3] - 0.35)), (0.5, 0.6, 0.1))
        return s.checker(arm)

    def arrays(checker):
        return [a.copy() for a in checker.kernel_inputs()[0] if isinstance(a, np.ndarray)]

    checker_module._MERGED.clear()  # else a merge with the same key is shared, not made
    short = holding(0.05)
    short_hits, short_arrays = short.check(qs), arrays(short)
    buffer = short._packed.nodes.base  # the pool's array the nodes are a view of
    assert buffer is not None
    long = holding(0.3)  # while the short bar's checker is alive
    long_hits = long.check(qs)
    assert long_hits.sum() > short_hits.sum()  # the long bar hits the table where the short
    assert not np.shares_memory(long._packed.nodes, short._packed.nodes)
    assert all(np.array_equal(a, b) for a, b in zip(arrays(short), short_arrays, strict=True))
    assert np.array_equal(short.check(qs), short_hits)
    # once the short bar's checker is gone, a checker holding it again takes its buffers
    del short
    checker_module._MERGED.clear()
    gc.collect()
    again = holding(0.05)
    assert again._packed.nodes.base is buffer
    assert all(np.array_equal(a, b) for a, b in zip(arrays(again), short_arrays, strict=True))
    assert np.array_equal(again.check(qs), short_hits)
    assert np.array_equal(long.check(qs), long_hits)


def test_gripper_union_serves_openings_micrometres_apart(irb120):
    """The gripper's cluster union is made once for openings that move its links by less than
    its margin (physics syncs them micrometres apart), anew for another opening; answers near
    the gripper's contact with a box are coal's either way."""
    from robocell.scene import checker as checker_module

    arm = irb120.group("arm")
    q = np.array([0.0, 0.4, 0.3, 0.0, 0.87, 0.0])
    T_tcp = fk(arm, q, "tcp")
    qs = q + np.random.default_rng(11).uniform(-0.25, 0.25, (400, arm.dof))

    def checker(opening):
        s = PlanningScene(irb120)
        s.set_joint_positions("arm", q)
        s.set_joint_positions("gripper", [opening])
        T_block = T_tcp @ Pose((0.0, 0.0, 0.06)).matrix()
        s.add_box("block", Pose.from_matrix(T_block), (0.1, 0.1, 0.04))
        return s.checker(arm)

    a, b, c = checker(0.3), checker(0.3 + 1e-6), checker(0.5)
    assert a._union_keys and a._union_keys == b._union_keys  # the same union serves both
    assert c._union_keys != a._union_keys
    for ch in (a, b, c):
        hits = ch.check(qs)
        assert 0.05 < hits.mean() < 0.95  # the states reach into the box and out of it
        assert np.array_equal(hits, ch.check_exact(qs))
    assert not np.array_equal(a.check(qs), c.check(qs))  # another opening, other answers
    assert checker_module.UNION_MARGIN > 0


def test_models_of_the_same_robot_share_its_collision_model():
    """Two models loaded from the same files (a cell per layout) share the links' sphere
    trees, distance fields and packed arrays, and check states alike; a model whose collision
    geometry differs does not share them; models dropped are not kept by what they share."""
    import gc
    import weakref

    from robocell import RobotModel
    from robocell.scene import checker as checker_module

    a, b = RobotModel.load("irb120_robotiq85"), RobotModel.load("irb120_robotiq85")
    assert a is not b
    assert checker_module.robot_spheres(a) is checker_module.robot_spheres(b)
    assert checker_module.robot_grids(a) is checker_module.robot_grids(b)
    arm_a, arm_b = a.group("arm"), b.group("arm")
    qs = arm_a.random(np.random.default_rng(9), 500)
    scenes = [PlanningScene(r) for r in (a, b)]
    for scene in scenes:
        scene.add_box("table", Pose((0.45, 0.0, 0.1)), (0.4, 0.6, 0.2))
    ca, cb = scenes[0].checker(arm_a), scenes[1].checker(arm_b)
    names = tuple(checker_module.robot_spheres(a))
    assert checker_module._robot_pack(a, names) is checker_module._robot_pack(b, names)
    assert np.array_equal(ca.check(qs), cb.check(qs))
    assert np.array_equal(cb.check(qs), cb.check_exact(qs))
    other = RobotModel.load("ur5e_gripper")
    assert checker_module.geometry_key(other) != checker_module.geometry_key(a)
    del b, arm_b, cb, scenes, scene
    loaded = []
    for _ in range(8):  # models dropped after use are not kept by what they share
        r = RobotModel.load("irb120_robotiq85")
        PlanningScene(r).checker(r.group("arm")).check(qs[:5])
        loaded.append(weakref.ref(r))
    del r
    gc.collect()
    assert sum(x() is not None for x in loaded) <= 4  # what the per-robot caches may keep


def test_without_padding_is_one_copy_while_the_scene_stays_as_it_is(scene, irb120):
    arm = irb120.group("arm")
    q = np.array([0.0, 0.5, 0.0, 0.0, 0.5, 0.0])
    T_tcp = fk(arm, q, "tcp")
    # a ball 10 cm ahead of the tool centre point: free, but not with 20 cm of padding
    scene.add_shape("ball", Sphere(0.02), Pose.from_matrix(T_tcp) * Pose((0, 0, 0.1)))
    free = scene.in_collision(q, arm)
    scene.set_object_padding("ball", 0.2)
    assert scene.in_collision(q, arm) and not free
    bare = scene.without_padding(["ball", "can"])
    assert bare.object_padding("ball") == 0.0 and not bare.in_collision(q, arm)
    assert scene.object_padding("ball") == 0.2 and scene.in_collision(q, arm)
    assert scene.without_padding(["ball"]) is bare  # nothing changed: its checkers kept
    assert bare.checker(arm) is bare.checker(arm)
    scene.set_joint_positions("gripper", [0.3])
    again = scene.without_padding(["ball"])
    assert again is not bare and np.array_equal(again.state.positions, scene.state.positions)
    assert scene.without_padding(["can"]) is scene  # nothing padded: the scene itself
    before = _snapshot(scene)
    with pytest.raises(SceneError, match="unknown object 'bal'; known: .*ball"):
        scene.without_padding(["bal"])
    assert _same(before, _snapshot(scene))


def test_gripper_joint_state_moves_fingers_in_arm_checks(irb120):
    scene = PlanningScene(irb120)
    arm = irb120.group("arm")
    q = np.array([0.0, 0.5, 0.0, 0.0, 0.5, 0.0])
    T_tcp = fk(arm, q, "tcp")
    scene.add_shape("block", Box((0.02, 0.06, 0.02)), Pose.from_matrix(T_tcp))  # 6 cm across y_tool
    assert not scene.in_collision(q, arm)  # open: 85 mm between the pads
    scene.set_joint_positions("gripper", [0.8])
    assert scene.in_collision(q, arm)  # closed: the pads meet inside the block


def test_mesh_obstacles_are_checked_exactly(irb120):
    """A world mesh (STL) is tested at the sphere level through its bounding box and settled by
    the exact check; the fast answer must agree with the exact one."""
    from tests.conftest import mbm_dir

    stl = mbm_dir() / "ur5" / "meshes" / "robotiq_fts300.stl"
    scene = PlanningScene(irb120)
    obj = scene.add_mesh("sensor", Pose((0.35, 0.0, 0.45)), stl, scale=(3, 3, 3))
    assert obj.shapes[0].kind == "mesh" and len(obj.shapes[0].triangles) > 100
    arm = irb120.group("arm")
    checker = scene.checker(arm)
    qs = arm.random(np.random.default_rng(7), 3000)
    fast = checker.check(qs)
    exact = checker.check_exact(qs)
    assert np.array_equal(fast, exact)
    hits = np.flatnonzero(exact)
    assert any("sensor" in p for q in qs[hits[:20]] for p in checker.colliding_pairs(q))
    with pytest.raises(GeometryError, match="not found"):
        scene.add_mesh("ghost", Pose(), stl.with_name("nope.stl"))
    assert scene.object_ids == ["sensor"]


def test_checkers_after_a_scene_change_share_coal_geometry_and_agree_with_coal(irb120):
    """A pick-and-place builds a checker per scene change; a mesh's coal geometry (its BVH:
    129 ms for 20 k triangles, measured) is made once and shared by the later checkers, whose
    exact answers stay coal's on the moved world. Equal boxes share one geometry, others not."""
    from robocell.scene.checker import coal_geometry
    from tests.conftest import mbm_dir

    stl = mbm_dir() / "ur5" / "meshes" / "robotiq_fts300.stl"
    scene = PlanningScene(irb120)
    scene.add_mesh("sensor", Pose((0.35, 0.0, 0.45)), stl, scale=(3, 3, 3))
    scene.add_box("block", Pose((0.3, 0.3, 0.3)), (0.1, 0.1, 0.1))
    arm = irb120.group("arm")
    qs = arm.random(np.random.default_rng(3), 1500)
    first = scene.checker(arm)
    assert np.array_equal(first.check(qs), first.check_exact(qs))
    scene.move_object("block", Pose((0.3, -0.3, 0.3)))
    second = scene.checker(arm)
    assert second is not first
    import coal

    meshes = [
        [g for g, _ in c._coal_geometry()[1] if isinstance(g, coal.BVHModelOBBRSS)]
        for c in (first, second)
    ]
    assert len(meshes[0]) == 1 and meshes[1][0] is meshes[0][0]
    exact = second.check_exact(qs)
    assert np.array_equal(second.check(qs), exact)
    assert not np.array_equal(exact, first.check_exact(qs))  # the block moved
    assert coal_geometry(Box((0.1, 0.2, 0.3))) is coal_geometry(Box((0.1, 0.2, 0.3)))
    assert coal_geometry(Box((0.1, 0.2, 0.3))) is not coal_geometry(Box((0.1, 0.2, 0.31)))
    with pytest.raises(SceneError, match="cannot build collision geometry"):
        coal_geometry("a box")


def test_robot_mounted_off_the_world_origin(irb120):
    """World objects are in the world frame; the robot's root sits at robot_pose."""
    arm = irb120.group("arm")
    q = np.array([0.0, 0.5, 0.0, 0.0, 0.5, 0.0])
    T_root_tcp = fk(arm, q, "tcp")
    mount = Pose.from_rpy(1.0, -2.0, 0.9, 0, 0, np.pi / 2)
    scene = PlanningScene(irb120, robot_pose=mount)
    T_world_tcp = mount.matrix() @ T_root_tcp
    scene.add_shape("blocker", Sphere(0.05), Pose(T_world_tcp[:3, 3]))  # wider than the pads
    assert scene.in_collision(q, arm)
    T_world_tcp_home = mount.matrix() @ fk(arm, np.zeros(6), "tcp")
    assert np.allclose(scene.link_pose("tcp").position, T_world_tcp_home[:3, 3])
    scene.move_object("blocker", Pose(T_root_tcp[:3, 3]))  # the same point in the root frame
    assert not scene.in_collision(q, arm)


def test_rigid_clusters_are_decided_once_and_broad_phased(mbm_ur5):
    """While the UR5 arm plans, its gripper's links keep their relative poses: their pairs are
    decided once (static), and the arm links' pairs against the hand go through one union tree
    first. Answers are those of the checker without that broad phase, and coal's."""
    from robocell.scene import _kernels as K

    group = mbm_ur5.group("manipulator")
    scene = PlanningScene(mbm_ur5)
    scene.add_box("table", Pose((0.5, 0.0, 0.1)), (0.5, 0.8, 0.2))
    checker = scene.checker(group)
    names = [b.name for b in checker.bodies]
    static = {frozenset((names[i], names[j])) for i, j in checker.static_self_pairs}
    assert frozenset(("fts_robotside", "robotiq_85_left_finger_link")) in static
    hand = {"fts_robotside", "robotiq_85_base_link", "robotiq_85_left_finger_tip_link"}
    assert not any({names[i], names[j]} <= hand for i, j in checker.self_pairs)
    grouped = {names[g.body] for g in checker._groups}
    assert {"forearm_link", "upper_arm_link"} <= grouped
    qs = group.random(np.random.default_rng(3), 3000)
    with_groups = checker.check(qs)
    assert np.array_equal(with_groups, checker.check_exact(qs))
    model = list(checker._model)
    model[K.MODEL_FIELDS.index("group_start")] = np.full(len(checker.self_pairs), -1, np.int64)
    checker._model = tuple(model)
    assert np.array_equal(checker.check(qs), with_groups)
    assert 0.1 < with_groups.mean() < 0.9


def test_world_grid_bounds_the_distance_to_every_obstacle(scene, irb120):
    """The world's distance grid (a body's first test against the world) never claims more
    clearance than there is: at its points, at points between them and outside it, for boxes,
    cylinders and spheres at any angle. A sphere it calls clear is clear of every obstacle."""
    from robocell.scene import _kernels as K
    from robocell.scene.checker import world_grid

    scene.add_box("tilted", Pose.from_rpy(0.2, -0.4, 0.3, 0.3, 0.5, 0.7), (0.3, 0.05, 0.2))
    scene.add_shape("pole", Cylinder(0.04, 0.5), Pose.from_rpy(-0.3, 0.2, 0.3, 1.0, 0.2, 0.0))
    scene.add_sphere("ball", Pose((0.3, 0.3, 0.5)), 0.07)
    checker = scene.checker(irb120.group("arm"))
    kind, T, dims = checker._obs_kind, checker._obs_T, checker._obs_dims
    frame, n, values = world_grid(kind, T, dims, 0.3)

    def distance(p):
        return min(K._obstacle_distance(*p, kind[o], T[o], dims[o]) for o in range(len(kind)))

    rng = np.random.default_rng(0)
    idx = np.column_stack([rng.integers(0, n[i], 3000) for i in range(3)])
    points = frame[:3] + frame[3] * idx
    flat = (idx[:, 0] * n[1] + idx[:, 1]) * n[2] + idx[:, 2]
    true = np.array([distance(p) for p in points])
    assert np.all(values[flat] <= np.minimum(true, 0.3))
    assert np.mean(values[flat] > np.minimum(true, 0.3) - 0.01) > 0.99  # and close to it
    lo, hi = frame[:3] - 0.5, frame[:3] + frame[3] * (n - 1) + 0.5  # beyond the grid too
    points = rng.uniform(lo, hi, (6000, 3))
    radii = rng.uniform(0.0, 0.3, len(points))
    true = np.array([distance(p) for p in points])
    clear = np.array(
        [K._world_clear(*p, r, frame, n, values) for p, r in zip(points, radii, strict=True)]
    )
    assert not np.any(clear & (true <= radii))
    assert clear.sum() > 0.8 * (true > radii + 2 * frame[3]).sum()  # it clears most of those


def test_world_grid_patched_from_another_world_is_the_same_to_the_bit(scene, irb120, monkeypatch):
    """A world that differs from a cached one by a few objects (one picked, placed or
    moved, or two moved) gets its grid patched from the cached one's: the same values, to
    the bit, as computed anew."""
    from robocell.scene import _kernels as K
    from robocell.scene import checker as C

    patches = []
    patched_grid = C._patched_grid
    monkeypatch.setattr(
        C, "_patched_grid", lambda *a: patches.append(patched_grid(*a)) or patches[-1]
    )
    scene.add_box("wall", Pose((0.0, 0.7, 0.4)), (1.6, 0.05, 0.8))  # keeps the grid's frame
    scene.add_box("floor", Pose((0.0, 0.0, -0.05)), (1.6, 1.6, 0.1))
    rng = np.random.default_rng(3)

    def somewhere(tilt: float) -> Pose:
        xy, z = rng.uniform(-0.4, 0.4, 2), rng.uniform(0.05, 0.5)
        return Pose.from_rpy(*xy, z, *rng.uniform(-tilt, tilt, 3))

    for k in range(6):
        scene.add_box(f"box{k}", somewhere(1.0), rng.uniform(0.02, 0.1, 3))
    arm = irb120.group("arm")
    for step in range(12):
        C._WORLD_GRIDS.clear()
        before = scene.checker(arm)
        C.world_grid(before._obs_kind, before._obs_T, before._obs_dims, 0.3)
        moved = [f"box{k}" for k in rng.choice(6, size=1 + step % 2, replace=False)]
        if step % 3 == 2:
            scene.remove_object(moved[0])  # picked
        else:
            for name in moved:
                scene.move_object(name, somewhere(0.5))
        after = scene.checker(arm)
        kind, T, dims = after._obs_kind, after._obs_T, after._obs_dims
        frame, n, values = C.world_grid(kind, T, dims, 0.3)
        anew = K.world_distance_grid(kind, T, dims, frame, n, 0.3)
        assert patches[-1] is not None and patches[-1] is values
        assert np.array_equal(values.view(np.uint32), anew.view(np.uint32))
        if step % 3 == 2:
            scene.add_box(moved[0], somewhere(0.5), (0.05, 0.05, 0.05))  # placed


def _with_states_near_contact(checker, qs):
    """``qs`` and, for 30 of its free states and 30 of its colliding ones (coal's verdict),
    a pair within 0.1 mrad of contact: each bisected 14 times towards the other."""
    exact = checker.check_exact(qs)
    near = []
    for a, b in zip(qs[~exact][:30], qs[exact][:30], strict=True):
        for _ in range(14):
            m = (a + b) / 2
            a, b = (a, m) if checker.check_exact(m[None])[0] else (m, b)
        near += [a, b]
    return np.vstack([qs, near])


def test_checks_are_the_same_without_the_world_grid(mbm_panda):
    """The world grid only saves work: with it made useless (every value 0), the checker
    answers the same on random states and on states within 0.1 mrad of contact."""
    from robocell.scene import _kernels as K

    group = mbm_panda.group("panda_arm")
    scene = PlanningScene(mbm_panda)
    scene.add_box("table", Pose((0.5, 0.0, 0.1)), (0.5, 0.8, 0.2))
    scene.add_cylinder("can", Pose((0.45, 0.2, 0.3)), 0.04, 0.2)
    checker = scene.checker(group)
    qs = _with_states_near_contact(checker, group.random(np.random.default_rng(4), 2000))
    with_grid = checker.check(qs)
    assert np.array_equal(with_grid, checker.check_exact(qs))
    model = list(checker._model)
    values = K.MODEL_FIELDS.index("world_values")
    model[values] = np.zeros_like(model[values])
    checker._model = tuple(model)
    assert np.array_equal(checker.check(qs), with_grid)
    assert 0.1 < with_grid.mean() < 0.9


@pytest.mark.parametrize(
    ("robot", "group"), [("mbm_panda", "panda_arm"), ("mbm_ur5", "manipulator"), ("irb120", "arm")]
)
def test_every_moving_body_stays_in_its_reach_ball(robot, group, request):
    """The ball a body is said to stay in (``_reach``: centred on the first group joint's
    origin on its chain) holds the body's bounding sphere at any configuration, limits or not;
    bodies the group does not move have none."""
    from robocell.kinematics.fk import link_poses
    from robocell.scene.checker import _reach

    model = request.getfixturevalue(robot)
    g = model.group(group)
    checker = PlanningScene(model).checker(g)
    q0 = checker.base_positions
    balls = [_reach(model, g, b, link_poses(model, q0)) for b in checker.bodies]
    assert [ball is not None for ball in balls] == [b.moving for b in checker.bodies]
    rng = np.random.default_rng(1)
    qs = np.vstack([g.random(rng, 500), rng.uniform(-2 * np.pi, 2 * np.pi, (500, g.dof))])
    worst = 0.0
    for q in qs:
        full = q0.copy()
        full[g.indices] = q
        T = link_poses(model, full)
        for b, ball in zip(checker.bodies, balls, strict=True):
            if ball is None:
                continue
            T_body = T[model.link_index(b.link)] @ b.T_link_body
            c = T_body[:3, :3] @ b.spheres.nodes[0, :3] + T_body[:3, 3]
            worst = max(worst, np.linalg.norm(c - ball[0]) + b.spheres.nodes[0, 3] - ball[1])
    assert worst <= 1e-9


def test_obstacles_out_of_a_bodys_reach_are_not_paired_with_it(mbm_panda, monkeypatch):
    """A world pair whose obstacle no configuration brings the body to is left out (the
    Panda's first links against a table and a shelf beside it), and the checker answers as
    the one that keeps every pair, on random states and within 0.1 mrad of contact (where
    the kernel may call a state coal finds 0.1 mrad clear in collision, never the reverse)."""
    import robocell.scene.checker as C

    group = mbm_panda.group("panda_arm")
    scene = PlanningScene(mbm_panda)
    scene.add_box("table", Pose((0.6, 0.0, 0.1)), (0.5, 0.8, 0.2))
    scene.add_box("shelf", Pose((0.0, 0.75, 0.5)), (0.6, 0.2, 1.0))
    scene.add_cylinder("can", Pose((0.55, 0.2, 0.3)), 0.04, 0.2)
    checker = scene.checker(group)
    names = [b.name for b in checker.bodies]
    paired = {(names[b], checker.obstacles[o].object_id) for b, o in checker.world_pairs}
    assert ("panda_link1", "table") not in paired and ("panda_link2", "table") not in paired
    assert ("panda_link4", "shelf") not in paired  # 0.65 m from the shoulder, 0.60 of reach
    assert ("panda_hand", "table") in paired and ("panda_link5", "shelf") in paired
    monkeypatch.setattr(C, "_reach", lambda *args: None)
    every = C.CollisionChecker(scene, group)
    assert len(every.world_pairs) > len(checker.world_pairs)
    qs = _with_states_near_contact(every, group.random(np.random.default_rng(5), 3000))
    answers = checker.check(qs)
    assert np.array_equal(answers, every.check(qs))
    assert not np.any(~answers & every.check_exact(qs))  # never free where coal sees contact
    assert 0.1 < answers.mean() < 0.9


def test_obstacle_clear_answers_as_the_distance_does():
    """The descent's test of a sphere against a primitive (squares compared) says clear exactly
    where the distance exceeds the radius: boxes, cylinders and spheres at any pose, points
    inside, outside and on their surfaces, radii from 0."""
    from robocell.scene import _kernels as K

    rng = np.random.default_rng(2)
    dims = {K.OBS_BOX: (0.2, 0.1, 0.3), K.OBS_CYLINDER: (0.15, 0.25, 0), K.OBS_SPHERE: (0.2, 0, 0)}
    agree = 0
    for kind, d in dims.items():
        T = Pose.from_rpy(*rng.uniform(-1, 1, 6)).matrix()
        d = np.array(d, float)
        points = T[:3, 3] + rng.uniform(-0.6, 0.6, (2000, 3))
        radii = np.concatenate([np.zeros(200), rng.uniform(0, 0.4, 1800)])
        for p, r in zip(points, radii, strict=True):
            far = K._obstacle_distance(*p, kind, T, d)
            if abs(far - r) < 1e-9:
                continue  # on the boundary either answer is within rounding
            assert K._obstacle_clear(*p, r, kind, T, d) == (far > r)
            agree += 1
    assert agree > 5900
