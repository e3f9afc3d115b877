"""Cell files: the bundled sorting cell per the spec, layouts, and every bad-input error."""

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from robocell.cell import bundled_cells, load_cell_file
from robocell.cell.cell_file import cell_path
from robocell.errors import CellError


@pytest.fixture(scope="module")
def sorting():
    return load_cell_file(cell_path("sorting"))


def test_sorting_cell_per_spec(sorting):
    assert "sorting" in bundled_cells()
    assert sorting.robots[0].model == "irb120_robotiq85"
    assert np.allclose(sorting.robots[0].pose.position, [0, 0, 0.9])
    assert {o.name for o in sorting.objects} == {
        "yellow_box", "red_box", "blue_box", "blue_ball", "yellow_ball", "green_ball",
        "green_cylinder", "red_cylinder",
    }  # fmt: skip
    blue_box = sorting.object("blue_box")
    assert blue_box.size == (0.10, 0.05, 0.07) and blue_box.mass == 0.20
    # every object rests on the conveyor top (z = 1.0)
    for o in sorting.objects:
        assert o.pose.position[2] - 0.5 * o.size[2] == pytest.approx(1.0)
    targets = {t.name: t for t in sorting.targets}
    assert targets["blue_target"].position == (-0.4, 0.39, 0.2)
    assert targets["blue_target"].frame == "robot"
    trays = [f for f in sorting.fixtures if f.name.endswith("_tray")]
    assert len(trays) == 4 and all(len(t.parts) == 5 for t in trays)


def test_layouts(sorting):
    l0 = sorting.layout(0)
    assert all(l0[o.name].isclose(o.pose) for o in sorting.objects)
    a, b, c = sorting.layout(5), sorting.layout(5), sorting.layout(6)
    assert all(a[n].isclose(b[n]) for n in a)  # seeded
    assert any(not a[n].isclose(c[n]) for n in a)
    slots = np.array([o.pose.position[:2] for o in sorting.objects])
    for o in sorting.objects:
        p = a[o.name].position
        assert np.min(np.max(np.abs(slots - p[:2]), axis=1)) <= 0.02 + 1e-12  # near a slot
        assert p[2] - 0.5 * o.size[2] == pytest.approx(1.0)  # still resting on the conveyor
        roll, pitch, _ = a[o.name].rpy()
        assert abs(roll) < 1e-9 and abs(pitch) < 1e-9
    yaws = [abs(a[o.name].rpy()[2]) for o in sorting.objects if o.kind in ("box", "cylinder")]
    assert max(yaws) > 0.1
    with pytest.raises(CellError, match="layout"):
        sorting.layout(-1)


def _write(tmp_path: Path, data: dict) -> Path:
    p = tmp_path / "cell.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


def _base() -> dict:
    return {
        "name": "t",
        "robots": [{"name": "r", "model": "irb120_robotiq85"}],
        "fixtures": [{"name": "table", "shape": "box", "size": [1, 1, 0.1]}],
        "objects": [
            {"name": "cube", "shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1,
             "pose": {"xyz": [0.4, 0, 0.1]}}
        ],
    }  # fmt: skip


BAD = [
    (
        lambda d: d["objects"][0].update(colour="red"),
        r"objects\[0\] \(cube\): unknown key 'colour'; expected: .*color",
    ),
    (lambda d: d["objects"][0].pop("mass"), r"objects\[0\] \(cube\): missing 'mass'"),
    (
        lambda d: d["objects"][0].update(size=[0.05, -0.05, 0.05]),
        r"objects\[0\] \(cube\).size\[1\]: must be > 0",
    ),
    (
        lambda d: d["fixtures"].append({"name": "cube", "shape": "sphere", "radius": 0.1}),
        r"duplicate name 'cube'",
    ),
    (
        lambda d: d["robots"][0].update(model="irb12"),
        r"unknown robot 'irb12'; bundled: .*irb120_robotiq85",
    ),
    (
        lambda d: d["fixtures"].append({"name": "m", "shape": "mesh", "file": "nowhere.stl"}),
        r"fixtures\[1\] \(m\).file: mesh file not found",
    ),
    (lambda d: d["objects"][0].update(shape="cone"), r"unknown shape 'cone'"),
    (
        lambda d: d["objects"][0]["pose"].update(xyz=[0, math.nan, 0]),
        r"expected a finite number",
    ),
    (
        lambda d: d.update(targets=[{"name": "t1", "position": [0, 0, 0], "tray": "bin"}]),
        r"unknown fixture 'bin'",
    ),
    (lambda d: d.update(robots=[]), r"exactly one robot"),
]


@pytest.mark.parametrize("change, message", BAD)
def test_bad_cell_files(tmp_path, change, message):
    data = _base()
    change(data)
    path = _write(tmp_path, data)
    with pytest.raises(CellError, match=message) as err:
        load_cell_file(path)
    assert str(path) in str(err.value)


def test_unknown_cell_and_file():
    with pytest.raises(CellError, match="unknown cell 'sortin'; bundled: sorting"):
        cell_path("sortin")
    with pytest.raises(CellError, match="not found"):
        load_cell_file("/nonexistent/cell.yaml")
