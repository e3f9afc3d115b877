"""Shared planning fixtures: the IRB 120 with a wall between two arm configurations."""

import numpy as np
import pytest

from robocell import PlanningScene, Pose

START = np.array([-1.2, 0.3, 0.2, 0.0, 0.8, 0.0])
GOAL = np.array([1.2, 0.3, 0.2, 0.0, 0.8, 0.0])


@pytest.fixture
def walled(irb120):
    """The IRB 120 with a wall between START and GOAL (the straight joint path crosses it)."""
    scene = PlanningScene(irb120)
    scene.add_box("wall", Pose([0.4, 0.0, 0.35]), [0.5, 0.04, 0.5])
    scene.add_box("floor", Pose([0, 0, -0.02]), [2.0, 2.0, 0.02])
    return scene
