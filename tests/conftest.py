"""Shared fixtures: bundled robots and the MotionBenchMaker robots from ../shared/bench/mbm."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from robocell.robot import RobotModel

if TYPE_CHECKING:
    from robocell.geometry import Pose
    from robocell.robot import JointGroup
    from robocell.scene import PlanningScene

REPO = Path(__file__).resolve().parent.parent


def shared_dir() -> Path:
    """``$ROBOCELL_SHARED`` or ../shared beside the repository (CI puts it there)."""
    env = os.environ.get("ROBOCELL_SHARED")
    path = Path(env) if env else REPO.parent / "shared"
    if not (path / "bench" / "mbm").is_dir():
        raise FileNotFoundError(
            f"the shared benchmark problems are missing: {path / 'bench' / 'mbm'} "
            "(set ROBOCELL_SHARED to the folder that holds bench/mbm)"
        )
    return path


def mbm_dir() -> Path:
    return shared_dir() / "bench" / "mbm"


def busy(seconds: float) -> None:
    """Keep this thread's core busy for ``seconds`` (the opposite of time.sleep)."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


def past_a_mesh(robot: RobotModel) -> PlanningScene:
    """A scene with a mesh obstacle in reach of the IRB 120's arm (a force sensor's mesh,
    three times its size): its triangles leave states near it unsure at the sphere level."""
    from robocell.geometry import Pose
    from robocell.scene import PlanningScene

    scene = PlanningScene(robot)
    stl = mbm_dir() / "ur5" / "meshes" / "robotiq_fts300.stl"
    scene.add_mesh("sensor", Pose((0.35, 0.0, 0.45)), stl, scale=(3, 3, 3))
    return scene


def beyond_reach(
    scene: PlanningScene,
    group: JointGroup,
    direction: tuple[float, float],
    z: float,
    pitch: float,
    by: float,
) -> Pose:
    """A pose of "tcp" (roll 0, ``pitch``, yaw 0) ``by`` [m] beyond the reach of ``group``
    along ``direction`` (world xy) at height ``z``: the edge found by bisection on its IK."""
    from robocell.geometry import Pose
    from robocell.kinematics import solve_ik

    def pose(r: float) -> Pose:
        return Pose.from_rpy(r * direction[0], r * direction[1], z, 0, pitch, 0)

    base = scene.link_pose(group.base_link).inverse()
    lo, hi = 0.2, 1.2
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        ok = solve_ik(group, base * pose(mid), tip_link="tcp", collision_free=False).success
        lo, hi = (mid, hi) if ok else (lo, mid)
    return pose(lo + by)


def load_mbm(robot: str) -> RobotModel:
    d = mbm_dir() / robot
    return RobotModel.from_urdf(d / f"{robot}.urdf", d / f"{robot}.srdf", package_dirs=[d])


@pytest.fixture(scope="session")
def irb120() -> RobotModel:
    return RobotModel.load("irb120_robotiq85")


@pytest.fixture(scope="session")
def ur5e() -> RobotModel:
    return RobotModel.load("ur5e_gripper")


@pytest.fixture(scope="session")
def mbm_ur5() -> RobotModel:
    return load_mbm("ur5")


@pytest.fixture(scope="session")
def mbm_panda() -> RobotModel:
    return load_mbm("panda")
