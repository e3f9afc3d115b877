import numpy as np
import pytest

from robocell.errors import SceneError
from robocell.scene import PlanningScene, load_request, load_scene, save_scene
from tests.conftest import mbm_dir

SETS = [
    "table_pick",
    "table_under_pick",
    "box",
    "bookshelf_small",
    "bookshelf_tall",
    "bookshelf_thin",
    "cage",
]


@pytest.mark.parametrize("robot_name, short", [("mbm_ur5", "ur5"), ("mbm_panda", "panda")])
@pytest.mark.parametrize("problem_set", SETS)
def test_shared_problems_load_with_free_start_and_goal(request, robot_name, short, problem_set):
    robot = request.getfixturevalue(robot_name)
    folder = mbm_dir() / short / "problems" / f"{problem_set}_{short}"
    for k in (1, 2, 3):
        scene = load_scene(robot, folder / f"scene{k:04d}.yaml")
        assert len(scene.object_ids) >= 1
        req = load_request(robot, folder / f"request{k:04d}.yaml", scene)
        group = robot.group(req.group)
        assert group.within_limits(req.start) and group.within_limits(req.goal)
        checker = scene.checker(group)
        states = np.array([req.start, req.goal])
        assert not checker.check_exact(states).any(), f"{problem_set} {k}: start or goal collides"
        assert not checker.check(states).any()


def test_box_scene_contents(mbm_ur5):
    scene = load_scene(mbm_ur5, mbm_dir() / "ur5" / "problems" / "box_ur5" / "scene0001.yaml")
    can = scene.get_object("Can1")
    assert can.shapes[0].kind == "cylinder"
    assert np.isclose(can.shapes[0].length, 0.14) and np.isclose(can.shapes[0].radius, 0.03)
    assert scene.acm.allowed("base_link", "shoulder_link")


def test_export_round_trip(tmp_path, mbm_ur5):
    src = mbm_dir() / "ur5" / "problems" / "bookshelf_tall_ur5" / "scene0002.yaml"
    scene = load_scene(mbm_ur5, src)
    save_scene(scene, tmp_path / "out.yaml")
    again = load_scene(mbm_ur5, tmp_path / "out.yaml")
    assert again.object_ids == scene.object_ids
    for oid in scene.object_ids:
        a, b = scene.get_object(oid), again.get_object(oid)
        assert a.shapes == b.shapes
        for pa, pb in zip(a.shape_poses, b.shape_poses, strict=True):
            assert np.allclose((a.pose * pa).matrix(), (b.pose * pb).matrix(), atol=1e-12)
    assert np.allclose(again.state.positions, scene.state.positions)
    assert again.acm == scene.acm


def test_bad_files(tmp_path, mbm_ur5):
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "world: {collision_objects: [{id: a, primitives: [{type: cone, dimensions: [1]}], "
        "primitive_poses: [{position: [0, 0, 0], orientation: [0, 0, 0, 1]}]}]}"
    )
    with pytest.raises(
        SceneError, match="unknown primitive type 'cone'; known: box, cylinder, sphere"
    ):
        load_scene(mbm_ur5, bad)
    bad.write_text("robot_state: {joint_state: {name: [elbo_joint], position: [0]}}")
    with pytest.raises(SceneError, match="unknown joint 'elbo_joint'"):
        load_scene(mbm_ur5, bad)
    with pytest.raises(SceneError, match="not found"):
        load_scene(mbm_ur5, tmp_path / "missing.yaml")
    bad.write_text("group_name: arm\ngoal_constraints: []\n")
    with pytest.raises(SceneError, match="unknown group 'arm'"):
        load_request(mbm_ur5, bad)


def test_failed_load_leaves_the_scene_alone(tmp_path, mbm_ur5):
    scene = PlanningScene(mbm_ur5)
    scene.add_box("keep", [0, 0, -1], (1, 1, 0.1))
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "world: {collision_objects: [{id: ok, primitives: [{type: box, dimensions: [1, 1, 1]}], "
        "primitive_poses: [{position: [0, 0, 2]}]}, {id: keep, primitives: [{type: sphere, "
        "dimensions: [1]}], primitive_poses: [{position: [0, 0, 0]}]}]}"
    )
    with pytest.raises(SceneError, match="already exists"):
        load_scene(mbm_ur5, bad, scene)
    assert scene.object_ids == ["keep"]


def test_mesh_objects_round_trip(tmp_path, irb120):
    from robocell.geometry import Mesh, Pose

    stl = mbm_dir() / "ur5" / "meshes" / "robotiq_fts300.stl"
    scene = PlanningScene(irb120)
    scene.add_mesh("sensor", Pose.from_rpy(0.3, 0.1, 0.2, 0.1, 0.2, 0.3), stl)
    save_scene(scene, tmp_path / "mesh.yaml")
    again = load_scene(irb120, tmp_path / "mesh.yaml")
    a, b = scene.get_object("sensor"), again.get_object("sensor")
    assert isinstance(b.shapes[0], Mesh)
    assert np.allclose(a.shapes[0].vertices, b.shapes[0].vertices)
    assert np.array_equal(a.shapes[0].triangles, b.shapes[0].triangles)
    assert (a.pose * a.shape_poses[0]).isclose(b.pose * b.shape_poses[0], 1e-12, 1e-9)
