"""The kernel's exact test of solid primitives (GJK) against coal's verdict, on random pairs and
on pairs placed a hair's breadth apart or into each other."""

import coal
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from robocell.scene import _kernels as K


def _random_primitive(rng: np.random.Generator):  # type: ignore[no-untyped-def]
    kind = int(rng.integers(3))
    if kind == K.OBS_BOX:
        dims = rng.uniform(0.01, 0.3, 3)
        geom = coal.Box(*(2 * dims))
    elif kind == K.OBS_CYLINDER:
        dims = np.array([rng.uniform(0.01, 0.2), rng.uniform(0.01, 0.3), 0.0])
        geom = coal.Cylinder(dims[0], 2 * dims[1])
    else:
        dims = np.array([rng.uniform(0.01, 0.2), 0.0, 0.0])
        geom = coal.Sphere(dims[0])
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.uniform(-0.3, 0.3, 3)
    return kind, T, dims, geom


def _tf(T):  # type: ignore[no-untyped-def]
    return coal.Transform3s(T[:3, :3], T[:3, 3])


def _coal_collides(ga, Ta, gb, Tb) -> bool:  # type: ignore[no-untyped-def]
    req = coal.CollisionRequest()
    req.enable_contact = True
    return coal.collide(ga, _tf(Ta), gb, _tf(Tb), req, coal.CollisionResult()) > 0


def _coal_distance(ga, Ta, gb, Tb):  # type: ignore[no-untyped-def]
    res = coal.DistanceResult()
    d = coal.distance(ga, _tf(Ta), gb, _tf(Tb), coal.DistanceRequest(), res)
    return d, np.array(res.getNearestPoint1()), np.array(res.getNearestPoint2())


def _verdicts_agree(a, b) -> None:  # type: ignore[no-untyped-def]
    ka, Ta, da, ga = a
    kb, Tb, db, gb = b
    r = K.gjk_intersect(ka, Ta, da, kb, Tb, db)
    assert r != K.GJK_UNSURE
    if r == K.GJK_FREE:
        # a pair called free is free for coal
        assert not _coal_collides(ga, Ta, gb, Tb)
    else:
        # a pair called colliding is, or is closer than the tolerance
        assert _coal_collides(ga, Ta, gb, Tb) or _coal_distance(ga, Ta, gb, Tb)[0] <= 2e-6


@pytest.mark.parametrize("seed", range(4))
def test_random_pairs_match_coal(seed: int) -> None:
    rng = np.random.default_rng(seed)
    hits = 0
    for _ in range(500):
        a, b = _random_primitive(rng), _random_primitive(rng)
        _verdicts_agree(a, b)
        hits += K.gjk_intersect(a[0], a[1], a[2], b[0], b[1], b[2]) == K.GJK_HIT
    assert 50 < hits < 450  # both verdicts are exercised


@pytest.mark.parametrize("seed", range(4))
def test_pairs_a_hair_apart_or_into_each_other(seed: int) -> None:
    """B is moved along the closest points' line to a gap of −0.1 mm … +0.1 mm."""
    rng = np.random.default_rng(100 + seed)
    free = hit = 0
    for _ in range(300):
        a, b = _random_primitive(rng), _random_primitive(rng)
        d, pa, pb = _coal_distance(a[3], a[1], b[3], b[1])
        if d <= 1e-4:
            continue  # already overlapping: the normal is not reliable
        n = (pb - pa) / d
        gap = rng.uniform(-1e-4, 1e-4)
        Tb = b[1].copy()
        Tb[:3, 3] += (gap - d) * n
        moved = (b[0], Tb, b[2], b[3])
        _verdicts_agree(a, moved)
        r = K.gjk_intersect(a[0], a[1], a[2], moved[0], Tb, moved[2])
        free += r == K.GJK_FREE
        hit += r == K.GJK_HIT
    assert free > 20 and hit > 20


def _random_triangle(rng: np.random.Generator, near: np.ndarray, scale: float):  # type: ignore[no-untyped-def]
    V = near + rng.normal(0.0, scale, (3, 3))
    tri = np.zeros((3, 4))
    tri[:, :3] = V.T
    tri[:, 3] = V.mean(axis=0)
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(1, 3)
    mesh.addVertices(np.ascontiguousarray(V))
    mesh.addTriangles(np.array([[0, 1, 2]], dtype=np.int64))
    mesh.endModel()
    return tri, mesh


@pytest.mark.parametrize("seed", range(3))
def test_triangle_box_test_matches_coal_and_gjk(seed: int) -> None:
    """The separating-axis triangle–box test: coal's verdict (a mesh triangle against a solid
    box), and the same as GJK's, on triangles around and across the box's faces."""
    rng = np.random.default_rng(200 + seed)
    hits = 0
    for _ in range(600):
        dims = rng.uniform(0.02, 0.2, 3)
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        T[:3, 3] = rng.uniform(-0.1, 0.1, 3)
        # near a random point of the box's surface, so that both verdicts occur
        local = rng.uniform(-1, 1, 3) * dims
        local[rng.integers(3)] = dims[rng.integers(3)] * rng.choice([-1, 1])
        tri, mesh = _random_triangle(rng, T[:3, :3] @ local + T[:3, 3], 0.03)
        sat = K.triangle_box_overlap(tri, T, dims)
        assert sat == (K.gjk_intersect(K.OBS_TRIANGLE, tri, dims, K.OBS_BOX, T, dims) == K.GJK_HIT)
        box = coal.Box(*(2 * dims))
        if not sat:
            assert not _coal_collides(mesh, np.eye(4), box, T)
        hits += sat
    assert 100 < hits < 500


@pytest.mark.parametrize("seed", range(3))
def test_triangle_triangle_test_matches_coal_and_gjk(seed: int) -> None:
    """The separating-axis triangle–triangle test: coal's verdict on two one-triangle meshes and
    GJK's verdict, on triangles of mixed sizes around a common point, some of them in one plane
    and some a hair apart."""
    rng = np.random.default_rng(300 + seed)
    hits = 0
    for i in range(600):
        centre = rng.uniform(-0.1, 0.1, 3)
        a, ma = _random_triangle(rng, centre, rng.uniform(0.005, 0.05))
        b, mb = _random_triangle(rng, centre, rng.uniform(0.005, 0.05))
        if i % 5 == 0:
            # into A's plane (coplanar pairs), or just off it
            n = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
            n /= np.linalg.norm(n)
            off = (b[:, :3].T - a[:, 0]) @ n
            V = b[:, :3].T - np.outer(off, n) + n * rng.choice([0.0, 1e-5, -1e-5])
            b, mb = _random_triangle(rng, V, 0.0)
        sat = K.triangle_triangle_overlap(a, b)
        r = K.gjk_intersect(K.OBS_TRIANGLE, a, a[:, 3], K.OBS_TRIANGLE, b, b[:, 3])
        assert r != K.GJK_UNSURE
        assert sat == (r == K.GJK_HIT)
        assert sat == _coal_collides(ma, np.eye(4), mb, np.eye(4))
        hits += sat
    assert 100 < hits < 500


@pytest.mark.parametrize("seed", range(2))
def test_within_a_margin_agrees_with_coals_distance(seed: int) -> None:
    """gjk_within(margin): a pair it calls farther apart than the margin is, by coal's
    distance; a pair it calls within the margin is closer than it (to a micrometre)."""
    rng = np.random.default_rng(seed)
    near = far = 0
    for _ in range(400):
        (ka, Ta, da, ga), (kb, Tb, db, gb) = _random_primitive(rng), _random_primitive(rng)
        if _coal_collides(ga, Ta, gb, Tb):
            continue
        d = _coal_distance(ga, Ta, gb, Tb)[0]
        margin = float(rng.uniform(0.001, 0.1))
        r = K.gjk_within(ka, Ta, da, kb, Tb, db, margin)
        assert r != K.GJK_UNSURE
        if r == K.GJK_FREE:
            assert d >= margin - 1e-6
            far += 1
        else:
            assert d <= margin + 1e-6
            near += 1
    assert near > 10 and far > 10
