"""RRT-Connect and shortcutting on the batched checker: the Python and compiled versions."""

import numpy as np
import pytest

from robocell import PlanningScene, Pose
from robocell.planning.rrt import (
    Edges,
    rrt_connect,
    rrt_connect_compiled,
    shortcut,
    shortcut_compiled,
    warm_up,
)

START = np.array([-1.2, 0.3, 0.2, 0.0, 0.8, 0.0])
GOAL = np.array([1.2, 0.3, 0.2, 0.0, 0.8, 0.0])


@pytest.fixture
def walled(irb120):
    scene = PlanningScene(irb120)
    scene.add_box("wall", Pose([0.4, 0.0, 0.35]), [0.5, 0.04, 0.5])
    scene.add_box("floor", Pose([0, 0, -0.02]), [2.0, 2.0, 0.02])
    return scene


def _length(path):
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())


@pytest.mark.parametrize("compiled", [False, True])
def test_shortcut_keeps_the_ends_shortens_and_stays_free(walled, compiled):
    arm = walled.robot.group("arm")
    checker = walled.checker(arm)
    warm_up(checker)
    edges = Edges(checker, 0.05)
    rng = np.random.default_rng(4)
    search = rrt_connect_compiled if compiled else rrt_connect
    path = search(edges, START, GOAL[None], arm.lower, arm.upper, rng, 1e18, 0.5)
    assert path is not None and len(path) > 3
    cut = (shortcut_compiled if compiled else shortcut)(edges, path, rng, 1e18, budget=2000)
    assert np.array_equal(cut[0], START) and np.array_equal(cut[-1], GOAL)
    assert 3 <= len(cut) < len(path)  # the wall is in the way: not a straight line
    assert _length(cut) < _length(path)
    for a, b in zip(cut[:-1], cut[1:], strict=True):
        assert not checker.check(edges.states(a, b, include_start=True)).any()
    assert np.all(np.linalg.norm(np.diff(cut, axis=0), axis=1) > 1e-9)


def test_compiled_shortcut_stops_at_its_budget(walled):
    """The random shortcuts check at most ``budget`` states (the greedy passes aside): a
    deterministic cap, whatever the machine's load."""
    arm = walled.robot.group("arm")
    checker = walled.checker(arm)
    warm_up(checker)
    edges = Edges(checker, 0.05)
    path = rrt_connect_compiled(
        edges, START, GOAL[None], arm.lower, arm.upper, np.random.default_rng(2), 1e18, 0.5
    )
    rng = np.random.default_rng(0)
    few, many = Edges(checker, 0.05), Edges(checker, 0.05)
    shortcut_compiled(few, path, np.random.default_rng(0), 1e18, budget=0)
    shortcut_compiled(many, path, rng, 1e18, budget=5000)
    assert few.stats.states < many.stats.states
