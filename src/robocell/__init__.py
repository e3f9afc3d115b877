"""robocell: plan, simulate and run pick-and-place with industrial robot arms from Python.

The public API, by layer (ARCHITECTURE.md): geometry → robot → kinematics → scene.
"""

import os as _os

# MuJoCo picks its OpenGL backend when first imported: offscreen EGL unless the user chose
_os.environ.setdefault("MUJOCO_GL", "egl")
# The kernels' OpenMP threads spin briefly when a parallel check ends, then sleep (GNU
# OpenMP's default spins for milliseconds): the planner's searches run in threads of their own
# right after such checks, and spinning threads took their cores (a search ran up to 2.5x
# slower), while threads that sleep at once take 0.2 ms to wake for the next check (measured).
# Read when OpenMP starts, so unless the user chose.
_os.environ.setdefault("GOMP_SPINCOUNT", "10000")

# robocell's own locators of numba's cache, installed on import: before any kernel is compiled
import robocell._numba_cache  # noqa: F401
from robocell.errors import (
    ExecutionError,
    GeometryError,
    GraspError,
    IKError,
    ModelError,
    PlanningError,
    RobocellError,
    RobocellWarning,
    SceneError,
)
from robocell.geometry import Box, Cylinder, Mesh, Pose, Sphere
from robocell.kinematics import IKResult, fk, fk_batch, jacobian, solve_ik
from robocell.robot import JointGroup, RobotModel, RobotState, bundled_robots
from robocell.scene import (
    CollisionChecker,
    CollisionObject,
    PlanningScene,
    load_request,
    load_scene,
    save_scene,
)

__version__ = "0.1.0"

__all__ = [
    "Box",
    "CollisionChecker",
    "CollisionObject",
    "Cylinder",
    "ExecutionError",
    "GeometryError",
    "GraspError",
    "IKError",
    "IKResult",
    "JointGroup",
    "Mesh",
    "ModelError",
    "PlanningError",
    "PlanningScene",
    "Pose",
    "RobocellError",
    "RobocellWarning",
    "RobotModel",
    "RobotState",
    "SceneError",
    "Sphere",
    "bundled_robots",
    "fk",
    "fk_batch",
    "jacobian",
    "load_request",
    "load_scene",
    "save_scene",
    "solve_ik",
]
