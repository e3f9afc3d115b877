"""Blended joint paths: exact derivatives, bounded corner deviation, continuity."""

import numpy as np
import pytest

from robocell.errors import PlanningError
from robocell.scene.swept import CUBIC
from robocell.trajectory import BlendedPath, SplinePath


def _polyline_distance(points: np.ndarray, wp: np.ndarray) -> np.ndarray:
    """Distance of each point to the nearest point of the polyline wp."""
    best = np.full(len(points), np.inf)
    for a, b in zip(wp[:-1], wp[1:], strict=True):
        d = b - a
        t = np.clip(((points - a) @ d) / (d @ d), 0, 1)
        best = np.minimum(best, np.linalg.norm(points - (a + t[:, None] * d), axis=1))
    return best


@pytest.fixture
def waypoints() -> np.ndarray:
    rng = np.random.default_rng(3)
    return np.cumsum(rng.normal(0, 0.5, (6, 4)), axis=0)


def test_derivatives_match_finite_differences(waypoints):
    bp = BlendedPath(waypoints, 0.1)
    s = np.linspace(1e-4, bp.length - 1e-4, 3001)
    h = 1e-6
    d1 = (bp(s + h) - bp(s - h)) / (2 * h)
    d2 = (bp(s + h, 1) - bp(s - h, 1)) / (2 * h)
    interior = np.min(np.abs(s[:, None] - bp.breakpoints[None, :]), axis=1) > 2 * h
    assert np.allclose(d1[interior], bp(s[interior], 1), atol=1e-6)
    assert np.allclose(d2[interior], bp(s[interior], 2), atol=1e-4)
    # unit speed: s is arc length
    assert np.allclose(np.linalg.norm(bp(s, 1), axis=1), 1.0)


def test_path_ends_at_waypoints_and_stays_within_deviation(waypoints):
    for dev in (0.0, 0.02, 0.1):
        bp = BlendedPath(waypoints, dev)
        assert np.allclose(bp(0.0), waypoints[0])
        assert np.allclose(bp(bp.length), waypoints[-1])
        pts = bp.sample_states(0.005)
        assert _polyline_distance(pts, waypoints).max() <= dev + 1e-9


def test_sample_states_respects_resolution(waypoints):
    bp = BlendedPath(waypoints, 0.05)
    pts = bp.sample_states(0.01)
    assert np.abs(np.diff(pts, axis=0)).max() <= 0.01 + 1e-12


def test_arc_states_are_the_rounded_corners_points(waypoints):
    """arc_states (the planner's final check of the corners) samples the arcs BlendedPath
    executes: the same points, and only those off the straight segments."""
    from robocell.trajectory.path import arc_states

    wp = waypoints.copy()
    wp[3] = wp[2] - (wp[1] - wp[2])  # a reversal: left sharp, no arc
    for dev in (0.0, 0.02, 0.1):
        bp = BlendedPath(wp, dev)
        got = arc_states(wp, dev, 0.01)
        want = bp.sample_states(0.01, arcs_only=True)
        assert np.allclose(np.unique(got.round(9), axis=0), np.unique(want.round(9), axis=0))
        if dev == 0:
            assert len(got) == 0
        else:  # the arcs stay within the deviation of the polyline
            assert _polyline_distance(got, wp).max() <= dev + 1e-9


def test_sharp_corners_are_stops(waypoints):
    assert len(BlendedPath(waypoints, 0.0).stops) == len(waypoints) - 2
    assert BlendedPath(waypoints, 0.05).stops == []
    # collinear waypoints are not a corner
    line = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    assert BlendedPath(line, 0.0).stops == []


def test_bad_waypoints_are_refused():
    with pytest.raises(PlanningError, match="waypoints"):
        BlendedPath(np.zeros(3))


def test_collinear_waypoints_need_no_rounding():
    """A waypoint on the straight line between its neighbours is no corner: the path is that
    line (an RRT's extension steps leave such waypoints). Equal directions read a turn of
    1.5e-8 rad through acos, whose rounding had no direction (NaN)."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        a, d = rng.uniform(-1, 1, 6), rng.uniform(-1, 1, 6)
        states = BlendedPath(np.array([a, a + d, a + 2 * d]), 0.05).sample_states(0.01)
        assert np.all(np.isfinite(states))
        t = (states - a) @ d / (d @ d)
        assert np.allclose(states, a + t[:, None] * d, atol=1e-9)
        assert np.allclose(states[-1], a + 2 * d)


def test_points_on_known_pieces_and_speed_bounds(waypoints):
    """``at(s, piece)`` is ``path(s)``; along each piece no joint moves faster than its
    bound per unit of arc length (finite differences); on the straight pieces the bound is
    the speed."""
    path = BlendedPath(waypoints, 0.1)
    starts, bounds = path.speed_bounds()
    assert starts[0] == 0.0 and np.isclose(starts[-1], path.length)
    s = np.linspace(0.0, path.length, 2001)
    piece = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(bounds) - 1)
    assert np.allclose(path.at(s, piece), path(s), atol=1e-12)
    for k in range(len(bounds)):
        ss = np.linspace(starts[k], starts[k + 1], 400)
        rate = np.abs(np.diff(path(ss), axis=0)) / np.diff(ss)[:, None]
        assert np.all(rate <= bounds[k] + 1e-9)
        if k % 2 == 0:  # a straight piece (they alternate with the arcs here)
            assert np.allclose(rate, bounds[k], atol=1e-9)


def test_a_splines_points_on_known_pieces_and_speed_bounds():
    """SplinePath's ``at(s, piece)`` is ``path(s)``; along each piece (between two waypoints)
    no joint moves faster than its bound per unit of s, and the bound is reached (it is the
    largest speed there, not a looser one)."""
    rng = np.random.default_rng(3)
    wp = np.cumsum(rng.normal(size=(12, 6)) * 0.2, axis=0)
    path = SplinePath(wp)
    starts, bounds = path.speed_bounds()
    assert np.allclose(starts, path.breakpoints) and bounds.shape == (11, 6)
    s = np.linspace(0.0, path.length, 3001)
    piece = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(bounds) - 1)
    assert np.allclose(path.at(s, piece), path(s), atol=1e-12)
    for k in range(len(bounds)):
        ss = np.linspace(starts[k], starts[k + 1], 2000)
        speed = np.abs(path(ss, 1))
        assert np.all(speed <= bounds[k])
        assert np.allclose(speed.max(axis=0), bounds[k], rtol=1e-4)
    starts_, origin, d1, d2, d3, _, kind = path.piece_arrays()
    assert np.all(kind == CUBIC)
    x = (s - starts_[piece])[:, None]
    assert np.allclose(origin[piece] + x * d1[piece] + x**2 * d2[piece] + x**3 * d3[piece], path(s))
