"""The physics world (MuJoCo), generated from robot descriptions and cell files."""

import os

# offscreen rendering without a display: EGL (set MUJOCO_GL yourself to choose another)
os.environ.setdefault("MUJOCO_GL", "egl")

from robocell.sim.world import Camera, FixtureGeom, FreeObject, ServoGains, World

__all__ = ["Camera", "FixtureGeom", "FreeObject", "ServoGains", "World"]
