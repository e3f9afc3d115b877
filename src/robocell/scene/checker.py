"""The batched collision checker of one planning group in one planning-scene snapshot.

Two levels (ARCHITECTURE.md): a compiled kernel classifies each state as certainly free,
certainly colliding or unsure (sphere trees, distance fields, and exact tests of the pieces under
touching leaves: see :mod:`robocell.scene._kernels`); the pairs it leaves unsure go to coal, one
pair at a time, with the bodies placed by our FK. ``check_exact`` is the exact check alone
(pinocchio over every pair, batched in C++), for comparison. Pairs whose relative pose the
group's joints cannot change are checked once, when the checker is built.

Semantics: robot links and held objects are solids; ``check`` returns True for a state in
collision (robot against world, held objects against world and robot, robot against itself),
skipping pairs the allowed-collision matrix allows.
"""

from __future__ import annotations

import hashlib
import math
import threading
import time
import weakref
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import SceneError
from robocell.geometry.pose import invert_transform
from robocell.geometry.shapes import Box, Cylinder, Mesh, Shape, Sphere, padded
from robocell.kinematics._kernels import fk_into
from robocell.kinematics.fk import link_poses, tree_args
from robocell.robot.model import PRISMATIC, JointGroup, RobotModel
from robocell.scene import _kernels as K
from robocell.scene.objects import AttachedObject
from robocell.scene.pair_tables import Chain, Members, PairTable, pair_table, table_chain
from robocell.scene.spheres import (
    DistanceGrid,
    SphereTree,
    _shape_key,
    body_grid,
    body_tree,
    build_tree,
)

if TYPE_CHECKING:
    from robocell.scene.planning_scene import PlanningScene
    from robocell.scene.swept import SweptCheck


CHUNK = 64  # states per kernel task; a batch of at most one chunk runs in the calling thread
# The kernel's threads sleep between parallel calls. Waking one took 210–230 µs when this
# process had kept a core busy meanwhile, whatever the gap, but 5.7–7.8 ms once it had slept
# for 50 ms or more (this 2-core VM's idle cores, it seems; medians, measured): more than a
# whole plan. So after a rest (see threads_rested) a batch of up to REST_CHUNK states runs in
# the calling thread, and the planner runs its searches one after the other (the same path)
# and its final check in the calling thread too. Two threads classify 480–7680 states only
# 1.3–1.6× as fast as one here.
REST_CHUNK = 4096
SEARCH_SLOTS = K.SEARCH_SLOTS  # scratch slots for the planner's searches (see there)
UNION_INNER = 32  # inner spheres of a rigid cluster's union body (the first pass's hit test)
UNION_MARGIN = 1e-4  # [m] a cluster union's spheres are grown by (_RobotTables.union)


def geometry_key(robot: RobotModel) -> str:
    """A digest of the robot's collision geometry (links, shapes, their poses, in order): what
    its links' sphere trees, distance fields and packed arrays are made from, so that every
    model of the same robot shares them. A process that loads a cell per layout made them
    again for each (a third of a 0.4 s ``Cell.load``), and kept each model's until the
    garbage collector freed the model. Computed once per model."""
    key = _GEOMETRY_KEYS.get(robot)
    if key is None:
        h = hashlib.sha1(b"robot geometry")
        for g in robot.collision_geometry:
            h.update(g.link.encode() + b"\0")
            h.update(_shape_key(g.shape))
            h.update(np.round(np.asarray(g.T_link_shape, float), 12).tobytes())
        key = _GEOMETRY_KEYS[robot] = h.hexdigest()
    return key


_GEOMETRY_KEYS: weakref.WeakKeyDictionary[RobotModel, str] = weakref.WeakKeyDictionary()


def robot_spheres(robot: RobotModel) -> dict[str, SphereTree]:
    """The sphere tree of every link with collision geometry, in the link's frame (shared by
    the models of the same robot: :func:`geometry_key`)."""

    def make() -> dict[str, SphereTree]:
        by_link: dict[str, list[tuple[Shape, NDArray[np.float64]]]] = {}
        for g in robot.collision_geometry:
            by_link.setdefault(g.link, []).append((g.shape, g.T_link_shape))
        return {link: body_tree(shapes) for link, shapes in by_link.items()}

    return _kept(_ROBOT_GEOMETRY, ("spheres", geometry_key(robot)), make, 12)  # type: ignore[no-any-return]


def robot_grids(robot: RobotModel) -> dict[str, DistanceGrid]:
    """The distance grid of every link whose collision geometry has a mesh (links made of
    primitives only have exact distances instead)."""

    def make() -> dict[str, DistanceGrid]:
        meshy = {g.link for g in robot.collision_geometry if isinstance(g.shape, Mesh)}
        return {link: body_grid(t) for link, t in robot_spheres(robot).items() if link in meshy}

    return _kept(_ROBOT_GEOMETRY, ("grids", geometry_key(robot)), make, 12)  # type: ignore[no-any-return]


def _kept(cache: dict[Any, Any], key: Any, make: Callable[[], Any], size: int) -> Any:
    """``cache[key]``, made by ``make()`` if missing; ``cache`` keeps the ``size`` most
    recently used (a dict in the order of use)."""
    hit = cache.pop(key, None)
    if hit is None:
        hit = make()
    cache[key] = hit  # the most recently used last
    while len(cache) > size:
        cache.pop(next(iter(cache)))
    return hit


# the robots' link sphere trees, distance grids and packed links, by geometry_key: those of
# four robots (12 entries)
_ROBOT_GEOMETRY: dict[tuple[Any, ...], Any] = {}


@dataclass
class Body:
    """A rigid body that collides: a robot link or a held object, on link ``link``.
    ``shapes`` are its shapes in the body's frame; ``grid`` its distance grid, if it has one."""

    name: str
    link: str
    T_link_body: NDArray[np.float64]
    spheres: SphereTree
    moving: bool
    shapes: list[tuple[Shape, NDArray[np.float64]]]
    grid: DistanceGrid | None = None

    @property
    def field_kind(self) -> int:
        """How the kernel bounds the distance to this body (see K.FIELD_*)."""
        if self.shapes and all(isinstance(s, Box | Cylinder | Sphere) for s, _ in self.shapes):
            return K.FIELD_PRIMITIVES
        return K.FIELD_GRID if self.grid is not None else K.FIELD_NONE


def field_side(a: Body, b: Body) -> int:
    """Which body of a self pair the kernel takes the distance field of, descending the
    other's tree: 0 (a), 1 (b) or −1 (neither has one: both trees are descended). Exact
    primitive distances first; between two of a kind, the field of the body with the larger
    tree (the smaller tree is descended)."""
    ka, kb = a.field_kind, b.field_kind
    rank = {K.FIELD_PRIMITIVES: 2, K.FIELD_GRID: 1, K.FIELD_NONE: 0}
    if rank[ka] == 0 and rank[kb] == 0:
        return -1
    if rank[ka] != rank[kb]:
        return 0 if rank[ka] > rank[kb] else 1
    return 0 if len(a.spheres.nodes) >= len(b.spheres.nodes) else 1


@dataclass
class Obstacle:
    """One primitive of a world object, as the kernel sees it (mesh shapes as their box)."""

    object_id: str
    kind: int
    T_scene_shape: NDArray[np.float64]  # in the robot's root frame
    dims: NDArray[np.float64]
    exact_inner: bool  # inner-sphere hits are certain (solid primitive)


def obstacle_of(object_id: str, shape: Shape, T: NDArray[np.float64]) -> Obstacle:
    if isinstance(shape, Box):
        return Obstacle(object_id, K.OBS_BOX, T, 0.5 * np.array(shape.size), True)
    if isinstance(shape, Cylinder):
        return Obstacle(
            object_id, K.OBS_CYLINDER, T, np.array([shape.radius, 0.5 * shape.length, 0]), True
        )
    if isinstance(shape, Sphere):
        return Obstacle(object_id, K.OBS_SPHERE, T, np.array([shape.radius, 0, 0]), True)
    # a mesh: its bounding box in its own frame, for the sphere level only
    V = np.asarray(shape.vertices)
    lo, hi = V.min(axis=0), V.max(axis=0)
    Tb = T.copy()
    Tb[:3, 3] = T[:3, :3] @ (0.5 * (lo + hi)) + T[:3, 3]
    return Obstacle(object_id, K.OBS_BOX, Tb, np.maximum(0.5 * (hi - lo), 1e-9), False)


def _bounding_sphere(o: Obstacle) -> NDArray[np.float64]:
    """Centre (scene frame) and radius of a sphere around an obstacle primitive."""
    d = o.dims
    if o.kind == K.OBS_BOX:
        r = float(np.linalg.norm(d))
    elif o.kind == K.OBS_CYLINDER:
        r = float(np.hypot(d[0], d[1]))
    else:
        r = float(d[0])
    return np.array([*o.T_scene_shape[:3, 3], r * (1 + 1e-9) + 1e-12])


def _reach(
    robot: RobotModel, group: JointGroup, body: Body, T_links: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float] | None:
    """A ball that holds ``body`` at every configuration of ``group`` (the other joints as in
    ``T_links``, the links' poses in the root frame): centred on the origin of the first of
    the group's joints on the body's chain, which lies on that joint's axis and so stays put;
    its radius the distances between the successive link origins from there on (which turning
    a joint keeps), plus how far the body's bounding sphere reaches from its link's origin.
    None when no joint of the group moves the body, or a prismatic one does (its reach is
    bounded only by limits that a checked state need not keep)."""
    tree = robot.tree
    moving = set(group.indices.tolist())
    by_child = {int(c): j for j, c in enumerate(tree.child_link)}
    chain: list[int] = []
    link = robot.link_index(body.link)
    while link in by_child:
        chain.append(by_child[link])
        link = int(tree.parent_link[by_child[link]])
    chain.reverse()
    driven = [int(tree.var[j]) in moving for j in chain]
    if not any(driven) or not len(body.spheres.nodes):
        return None
    if any(d and tree.type[j] == PRISMATIC for d, j in zip(driven, chain, strict=True)):
        return None
    first = driven.index(True)
    origins = T_links[:, :3, 3]
    radius = sum(
        float(np.linalg.norm(origins[tree.child_link[j]] - origins[tree.parent_link[j]]))
        for j in chain[first + 1 :]
    )
    c, r = body.spheres.nodes[0, :3], float(body.spheres.nodes[0, 3])
    radius += float(np.linalg.norm(body.T_link_body[:3, :3] @ c + body.T_link_body[:3, 3])) + r
    return T_links[tree.child_link[chain[first]], :3, 3].copy(), radius


REACH_MARGIN = 1e-3  # [m] a pair is left out only if its obstacle is this much beyond reach


def _world_runs(
    pairs: NDArray[np.int64],
    group_start: NDArray[np.int64],
    group_union: NDArray[np.int64],
    group_count: NDArray[np.int64],
) -> NDArray[np.int64]:
    """For each world pair k, the end of the run of pairs from k on that one body's test
    against the whole world clears (``K._world_clear``): the body's next pairs, or for a
    group's first pair (a cluster's members against one obstacle), the groups of the same
    cluster that follow it (that is the union's run; the member of that first pair clears
    only its own). A pair inside a group's block ends its own run."""
    n = len(pairs)
    run_end = np.arange(1, n + 1, dtype=np.int64)
    in_group = np.zeros(n, np.bool_)
    for first in np.flatnonzero(group_start >= 0):
        in_group[first : first + group_count[group_start[first]]] = True
    for k in range(n - 1, -1, -1):
        g = int(group_start[k])
        if g >= 0:
            end = k + int(group_count[g])
            nxt = group_start[end] if end < n else -1
            same = nxt >= 0 and group_union[nxt] == group_union[g]
            run_end[k] = run_end[end] if same else end
        elif not in_group[k] and k + 1 < n and not in_group[k + 1]:
            if pairs[k + 1, 0] == pairs[k, 0]:
                run_end[k] = run_end[k + 1]
    return run_end


WORLD_GRID_POINTS = 1 << 18  # at most, in the world's distance grid (1 MB of float32)
# the last few worlds' grids (frame, points per axis, values) and their obstacles (kind, T,
# dims), to patch another world's from
_WORLD_GRIDS: dict[tuple[Any, ...], tuple[tuple[NDArray[Any], ...], tuple[NDArray[Any], ...]]] = {}
# a cached grid is patched (K.world_distance_patch) when the worlds differ by this many
# obstacles at most, else computed anew
PATCH_OBSTACLES = 4


def world_grid(
    kind: NDArray[np.int64], T: NDArray[np.float64], dims: NDArray[np.float64], cap: float
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float32]]:
    """The world's distance grid for the kernel's first test of a body against the world
    (``K._world_clear``): (frame: origin, spacing, the obstacles' bounding box, 1 / spacing;
    grid points per axis; values, see ``K.world_distance_grid``). It spans the obstacles' box
    grown by ``cap`` [m], at most WORLD_GRID_POINTS points 1 cm apart or more. Kept for the
    last few worlds: a checker is built for each candidate grasp and place in the same world."""
    key = (kind.tobytes(), T.tobytes(), dims.tobytes(), cap)
    hit = _WORLD_GRIDS.get(key)
    if hit is not None:
        return hit[0]  # type: ignore[return-value]
    if len(kind) == 0:
        out = (
            np.array([0.0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1]),
            np.ones(3, np.int64),
            np.zeros(1, np.float32),
        )
    else:
        R = np.abs(T[:, :3, :3])
        ext = np.where(
            (kind == K.OBS_BOX)[:, None],
            np.einsum("nij,nj->ni", R, dims),
            np.where(
                (kind == K.OBS_CYLINDER)[:, None],
                R[:, :, 2] * dims[:, 1:2]
                + dims[:, :1] * np.sqrt(np.clip(1 - T[:, :3, 2] ** 2, 0, None)),
                dims[:, :1] * np.ones(3),
            ),
        )
        lo = (T[:, :3, 3] - ext).min(axis=0)
        hi = (T[:, :3, 3] + ext).max(axis=0)
        size = hi - lo + 2 * cap
        h = max(0.01, float(np.prod(size) / WORLD_GRID_POINTS) ** (1 / 3))
        n = np.ceil(size / h).astype(np.int64) + 1
        while np.prod(n) > WORLD_GRID_POINTS:
            h *= 1.05
            n = np.ceil(size / h).astype(np.int64) + 1
        frame = np.concatenate([lo - cap, [h], lo, hi, [1.0 / h]])
        values = _patched_grid(kind, T, dims, frame, n, cap)
        if values is None:
            values = K.world_distance_grid(kind, T, dims, frame, n, cap)
        out = (frame, n, values)
    _WORLD_GRIDS[key] = (out, (kind.copy(), T.copy(), dims.copy()))
    while len(_WORLD_GRIDS) > 8:
        _WORLD_GRIDS.pop(next(iter(_WORLD_GRIDS)))
    return out


def _patched_grid(
    kind: NDArray[np.int64],
    T: NDArray[np.float64],
    dims: NDArray[np.float64],
    frame: NDArray[np.float64],
    n: NDArray[np.int64],
    cap: float,
) -> NDArray[np.float32] | None:
    """This world's grid values patched from a cached world's with the same frame that
    differs from it by PATCH_OBSTACLES obstacles at most (an object picked, placed or moved:
    the rest of the cell stays), or None. A pick-and-place rebuilds its checker on every such
    change, and the grid took 3.5 ms of a 10 ms build in the sorting cell (session 47)."""

    def rows(k: NDArray[np.int64], t: NDArray[np.float64], d: NDArray[np.float64]) -> list[bytes]:
        return [k[i].tobytes() + t[i].tobytes() + d[i].tobytes() for i in range(len(k))]

    mine = rows(kind, T, dims)
    counted = Counter(mine)
    best = None
    for key, ((f, m, values), (k2, T2, d2)) in _WORLD_GRIDS.items():
        if not (np.array_equal(m, n) and np.array_equal(f, frame)) or key[3] != cap:
            continue
        theirs = rows(k2, T2, d2)
        their_count = Counter(theirs)
        gone = list((their_count - counted).elements())
        added = counted - their_count
        changes = len(gone) + sum(added.values())
        if changes <= PATCH_OBSTACLES and (best is None or changes < best[0]):
            g = [theirs.index(r) for r in gone]
            a = [i for i, r in enumerate(mine) if r in added]
            best = (changes, values, (k2[g], T2[g], d2[g]), np.array(a, np.int64))
    if best is None:
        return None
    values = best[1].copy()
    K.world_distance_patch(values, kind, T, dims, frame, n, cap, best[2], best[3])
    return values


# coal geometry made for a shape, kept for the next checkers: a pick-and-place builds one per
# scene change, and each made the coal geometry of every obstacle again for its exact checks
# (boxes by value: a padded box is a new one each time; meshes by identity, their arrays being
# read-only). coal's geometry is not changed by a collision test, so checkers share it.
_COAL_GEOMETRY: dict[Shape, object] = {}
_COAL_GEOMETRY_LOCK = threading.Lock()
COAL_GEOMETRY_KEPT = 256


def coal_geometry(shape: Shape) -> object:
    """The coal collision geometry of a shape (made once, then shared)."""
    if not isinstance(shape, Box | Cylinder | Sphere | Mesh):
        raise SceneError(f"cannot build collision geometry for {shape!r}")
    geom = _COAL_GEOMETRY.get(shape)
    if geom is None:
        geom = _new_coal_geometry(shape)
        with _COAL_GEOMETRY_LOCK:
            _COAL_GEOMETRY[shape] = geom
            while len(_COAL_GEOMETRY) > COAL_GEOMETRY_KEPT:
                _COAL_GEOMETRY.pop(next(iter(_COAL_GEOMETRY)))
    return geom


def _new_coal_geometry(shape: Shape) -> object:
    import coal

    if isinstance(shape, Box):
        return coal.Box(*shape.size)
    if isinstance(shape, Cylinder):
        return coal.Cylinder(shape.radius, shape.length)
    if isinstance(shape, Sphere):
        return coal.Sphere(shape.radius)
    bvh = coal.BVHModelOBBRSS()  # a Mesh: coal_geometry let no other kind through
    bvh.beginModel(len(shape.triangles), len(shape.vertices))
    bvh.addVertices(np.ascontiguousarray(shape.vertices, dtype=np.float64))
    bvh.addTriangles(np.ascontiguousarray(shape.triangles, dtype=np.int64))
    bvh.endModel()
    return bvh


def exact_data(gm: Any) -> Any:
    """Geometry data for exact checks. Contacts are enabled: coal 3.0.3's collision test
    without contact computation (pinocchio's default request) misses shallow penetrations
    between primitives (seen: two cylinders 0.7 mm deep reported free)."""
    gd = gm.createData()
    for req in gd.collisionRequests:
        req.enable_contact = True
    return gd


def exact_pool(model: Any, gm: Any, threads: int) -> Any:
    """A pinocchio GeometryPool whose geometry data are configured as :func:`exact_data`'s."""
    import pinocchio as pin

    pool = pin.GeometryPool(model, gm, max(1, threads))
    for gd in pool.getGeometryDatas():
        for req in gd.collisionRequests:
            req.enable_contact = True
    return pool


def _pack_fields(bodies: list[Body]) -> tuple[NDArray[Any], ...]:
    """The kernel's arrays of the bodies' distance fields: field_kind, grid_origin,
    grid_box, grid_h, grid_dims, grid_off, grid_values (concatenated), prim_start, prim_kind,
    prim_T, prim_dims."""
    B = len(bodies)
    kind = np.array([b.field_kind for b in bodies], dtype=np.int64)
    origin = np.zeros((B, 3))
    box = np.zeros((B, 2, 3))
    h = np.ones(B)
    dims = np.ones((B, 3), dtype=np.int64)
    off = np.zeros(B, dtype=np.int64)
    values: list[NDArray[np.float32]] = [np.zeros(1, np.float32)]
    n = 1
    prims: list[Obstacle] = []
    prim_start = [0]
    for bi, b in enumerate(bodies):
        if kind[bi] == K.FIELD_GRID and b.grid is not None:
            origin[bi], box[bi], h[bi], dims[bi] = b.grid.origin, b.grid.box, b.grid.h, b.grid.dims
            off[bi] = n
            values.append(b.grid.values)
            n += len(b.grid.values)
        elif kind[bi] == K.FIELD_PRIMITIVES:
            prims += [obstacle_of(b.name, sh, T) for sh, T in b.shapes]
        prim_start.append(len(prims))
    return (
        kind,
        origin,
        box,
        h,
        dims,
        off,
        np.concatenate(values).astype(np.float32),
        np.array(prim_start, dtype=np.int64),
        np.array([o.kind for o in prims], dtype=np.int64),
        np.array([o.T_scene_shape for o in prims]).reshape(-1, 4, 4),
        np.array([o.dims for o in prims]).reshape(-1, 3),
    )


def _pack_triangles(bodies: list[Body]) -> tuple[NDArray[Any], ...]:
    """The kernel's arrays of the bodies' triangles: body_mesh (B,) (the body is all meshes, so
    its triangles settle its contacts), node_tri_start (M + 1,) and node_tri_ids (triangles of
    each leaf, node and triangle indices global), tri_V (T, 3, 3) in the bodies' frames, and
    tri_sphere (T, 4), a ball around each triangle."""
    body_mesh = np.array([b.spheres.meshes_only for b in bodies], dtype=np.bool_)
    starts: list[NDArray[np.int64]] = []
    ids: list[NDArray[np.int64]] = []
    tris: list[NDArray[np.float64]] = []
    n_ids = n_tris = 0
    for b in bodies:
        t = b.spheres
        starts.append(t.tri_start[:-1] + n_ids)
        ids.append(t.tri_ids + n_tris)
        tris.append(t.tris.reshape(-1, 3, 3))
        n_ids += int(t.tri_start[-1])
        n_tris += len(t.tris)
    node_tri_start = np.concatenate([*starts, [n_ids]]).astype(np.int64)
    tri_V = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
    centre = tri_V.mean(axis=1)
    radius = np.linalg.norm(tri_V - centre[:, None, :], axis=2).max(axis=1, initial=0.0)
    tri_sphere = np.c_[centre, radius * (1 + 1e-9) + 1e-9].reshape(-1, 4)
    return (
        body_mesh,
        node_tri_start,
        np.concatenate(ids).astype(np.int64) if ids else np.zeros(0, np.int64),
        np.ascontiguousarray(tri_V),
        np.ascontiguousarray(tri_sphere),
    )


@dataclass
class Packed:
    """The kernel's arrays of a list of bodies (node and triangle indices global to it)."""

    body_root: NDArray[np.int64]
    nodes: NDArray[np.float64]
    left: NDArray[np.int64]
    right: NDArray[np.int64]
    inner_start: NDArray[np.int64]
    inner: NDArray[np.float64]
    fields: tuple[NDArray[Any], ...]
    triangles: tuple[NDArray[Any], ...]


def pack_bodies(bodies: list[Body]) -> Packed:
    node_start = np.concatenate([[0], np.cumsum([len(b.spheres.nodes) for b in bodies])]).astype(
        np.int64
    )
    nodes = np.vstack([b.spheres.nodes for b in bodies]) if bodies else np.zeros((0, 4))

    def child(side: str) -> NDArray[np.int64]:
        parts = [
            np.where(getattr(b.spheres, side) >= 0, getattr(b.spheres, side) + o, -1)
            for b, o in zip(bodies, node_start, strict=False)
        ]
        return np.concatenate(parts).astype(np.int64) if parts else np.zeros(0, np.int64)

    inner = [b.spheres.inner for b in bodies]
    return Packed(
        node_start[:-1].copy(),
        nodes,
        child("left"),
        child("right"),
        np.concatenate([[0], np.cumsum([len(i) for i in inner])]).astype(np.int64),
        np.vstack(inner) if any(len(i) for i in inner) else np.zeros((0, 4)),
        _pack_fields(bodies),
        _pack_triangles(bodies),
    )


def _merge(a: Packed, b: Packed) -> Packed:
    """a's bodies then b's, b's indices shifted past a's.

    The arrays indexed by node, triangle or grid value are views of buffers that hold a's
    arrays already when they were a merge's of the same ``a`` that is no longer in use
    (:class:`_MergeBuffers`): only b's part is written. A checker is built per scene change
    (8 per object in the sorting demo, each merging the arm's links with the gripper's
    cluster unions and the held object): copying the links' 25 MB into fresh pages took
    2.4–5 ms of a 12 ms build; b's part is a tenth of that."""
    m = len(a.nodes)
    fa, fb = a.fields, b.fields  # kind, origin, box, h, dims, off, values, pstart, pkind, pT, pdims
    ta, tb = a.triangles, b.triangles  # mesh, node_tri_start, node_tri_ids, tri_V, tri_sphere
    n_values, n_prims = len(fa[6]), int(fa[7][-1])
    n_ids, n_tris = int(ta[1][-1]), len(ta[3])
    # the tails behind a's arrays, in _heads' order
    tails = (
        b.nodes,
        np.where(b.left >= 0, b.left + m, -1),
        np.where(b.right >= 0, b.right + m, -1),
        fb[6],
        tb[1] + n_ids,  # behind a's node_tri_start without its last entry (n_ids: tb[1][0])
        tb[2] + n_tris,
        tb[3],
        tb[4],
    )
    nodes, left, right, values, tri_start, tri_ids, tri_V, tri_sphere, lease = _MERGE_POOL.take(
        a, tails
    )
    fields = (
        np.concatenate([fa[0], fb[0]]),
        np.concatenate([fa[1], fb[1]]),
        np.concatenate([fa[2], fb[2]]),
        np.concatenate([fa[3], fb[3]]),
        np.concatenate([fa[4], fb[4]]),
        np.concatenate([fa[5], np.where(fb[0] == K.FIELD_GRID, fb[5] + n_values, 0)]),
        values,
        np.concatenate([fa[7][:-1], fb[7] + n_prims]),
        np.concatenate([fa[8], fb[8]]),
        np.concatenate([fa[9], fb[9]]),
        np.concatenate([fa[10], fb[10]]),
    )
    triangles = (np.concatenate([ta[0], tb[0]]), tri_start, tri_ids, tri_V, tri_sphere)
    out = Packed(
        np.concatenate([a.body_root, b.body_root + m]),
        nodes,
        left,
        right,
        np.concatenate([a.inner_start[:-1], b.inner_start + len(a.inner)]),
        np.vstack([a.inner, b.inner]),
        fields,
        triangles,
    )
    # the buffers go back to the pool once this merge is no longer in use: a checker keeps
    # its Packed (CollisionChecker._packed) for as long as it lives
    weakref.finalize(out, _MERGE_POOL.give_back, lease)
    return out


class _MergeBuffers:
    """Buffers for merges of one robot's packed links (``a`` of :func:`_merge`) with extra
    bodies: each part's array holds a's part first, then room for an extra bodies' part.
    Recycled through :data:`_MERGE_POOL`; the parts are :func:`_heads`'."""

    def __init__(self, a: Packed, tails: tuple[NDArray[Any], ...]) -> None:
        self.a = a  # the buffers serve merges of this very ``a`` only (fits)
        self.arrays: list[NDArray[Any]] = []
        for head, tail in zip(_heads(a), tails, strict=True):
            # room for bigger extra bodies than these: twice as many, and at least a quarter
            # of a's (the sorting demo's extras, cluster unions and held objects, ran from
            # 21 to 119 thousand nodes: with 50 % more room than the first, 3 of 7 merges
            # per layout made new buffers, copying the links' 25 MB)
            room = len(head) + max(2 * len(tail), len(head) // 4)
            buf = np.empty((room, *head.shape[1:]), head.dtype)
            buf[: len(head)] = head
            self.arrays.append(buf)

    def fits(self, a: Packed, tails: tuple[NDArray[Any], ...]) -> bool:
        return self.a is a and all(
            len(buf) >= len(head) + len(tail)
            for buf, head, tail in zip(self.arrays, _heads(a), tails, strict=True)
        )

    def views(self, a: Packed, tails: tuple[NDArray[Any], ...]) -> list[NDArray[Any]]:
        """a's parts followed by ``tails``, as views of the buffers (written here)."""
        out = []
        for buf, head, tail in zip(self.arrays, _heads(a), tails, strict=True):
            n = len(head) + len(tail)
            buf[len(head) : n] = tail
            out.append(buf[:n])
        return out


def _heads(a: Packed) -> tuple[NDArray[Any], ...]:
    """a's parts of a merge's arrays indexed by node, grid value or triangle: nodes, left,
    right, values, node_tri_start (without its last entry), node_tri_ids, tri_V, tri_sphere."""
    f, t = a.fields, a.triangles
    return (a.nodes, a.left, a.right, f[6], t[1][:-1], t[2], t[3], t[4])


class _MergePool:
    """Merge buffers no longer in use, the last few given back (whatever their robot): a merge
    takes one that holds its robot's links already and fits its extra bodies, else new ones."""

    KEEP = 2  # each holds a robot's links (tens of MB: 25 for the IRB 120, 62 for a Panda)

    def __init__(self) -> None:
        self._free: list[_MergeBuffers] = []
        # reentrant: a merge given back by the garbage collector may come in the middle of a
        # take, in the same thread
        self._lock = threading.RLock()

    def take(self, a: Packed, tails: tuple[NDArray[Any], ...]) -> list[Any]:
        """The views of :meth:`_MergeBuffers.views`, then the buffers (the lease to give
        back)."""
        with self._lock:
            found = next((x for x in reversed(list(self._free)) if x.fits(a, tails)), None)
            if found is not None and found in self._free:
                self._free.remove(found)  # (else dropped meanwhile: free all the same)
        buffers = found if found is not None else _MergeBuffers(a, tails)
        return [*buffers.views(a, tails), buffers]

    def give_back(self, buffers: _MergeBuffers) -> None:
        with self._lock:
            self._free.append(buffers)
            del self._free[: -self.KEEP]


_MERGE_POOL = _MergePool()


def _robot_pack(robot: RobotModel, names: tuple[str, ...]) -> Packed:
    """The packed links of a robot (the same for every checker of every model of it: its
    merges' buffers then serve them all)."""

    def make() -> Packed:
        spheres, grids = robot_spheres(robot), robot_grids(robot)
        link_shapes: dict[str, list[tuple[Shape, NDArray[np.float64]]]] = {}
        for g in robot.collision_geometry:
            link_shapes.setdefault(g.link, []).append((g.shape, g.T_link_shape))
        return pack_bodies(
            [Body(n, n, np.eye(4), spheres[n], True, link_shapes[n], grids.get(n)) for n in names]
        )

    key = ("packed", geometry_key(robot), names)
    return _kept(_ROBOT_GEOMETRY, key, make, 12)  # type: ignore[no-any-return]


@dataclass
class _PairGroup:
    """Self pairs (indices into the checker's ``self_pairs``, consecutive once packed) of one
    body against members of a rigid cluster, whose union body is ``union``."""

    body: int
    union: int
    pairs: list[int]


def _shapes_key(shapes: list[tuple[Shape, NDArray[np.float64]]]) -> str:
    h = hashlib.sha1()
    for shape, T in shapes:
        h.update(_shape_key(shape))
        h.update(np.round(np.asarray(T, float), 12).tobytes())
    return h.hexdigest()


def _moved_by(tree: SphereTree, A: NDArray[np.float64], B: NDArray[np.float64]) -> float:
    """A bound on how far a point of ``tree`` (within its root sphere) moves from pose A to
    pose B: |(R_B − R_A) p + t_B − t_A| ≤ ‖R_B − R_A‖_F |p| + |t_B − t_A|."""
    c, r = tree.nodes[0, :3], tree.nodes[0, 3]
    dR = float(np.linalg.norm(B[:3, :3] - A[:3, :3]))
    return dR * (float(np.linalg.norm(c)) + r) + float(np.linalg.norm(B[:3, 3] - A[:3, 3]))


def _union_tree(
    trees: list[SphereTree], T_union_member: list[NDArray[np.float64]], margin: float = 0.0
) -> tuple[SphereTree, NDArray[np.int64]]:
    """The union of members' sphere trees placed at ``T_union_member``: a small tree over the
    members' root spheres whose leaves are the members' own trees (no rebuild: a checker is
    built per gripper opening, and rebuilding a UR5 hand's tree took 20 ms), the biggest of
    their inner spheres, and each node's members as bits. ``margin`` [m]: the spheres grown
    and the inner spheres shrunk by it, so that the union stays sound for members moved by
    up to that much (:meth:`_RobotTables.union`)."""
    parts = [
        np.c_[t.nodes[:, :3] @ T[:3, :3].T + T[:3, 3], t.nodes[:, 3] + margin]
        for t, T in zip(trees, T_union_member, strict=True)
    ]
    top, top_left, top_right, top_leaf_of = build_tree(np.array([P[0] for P in parts]))
    offset = np.cumsum([len(top)] + [len(P) for P in parts])[:-1]
    # a top leaf stands for member j: links to it go to the member's root instead
    redirect = np.arange(len(top))
    redirect[top_leaf_of >= 0] = offset[top_leaf_of[top_leaf_of >= 0]]
    left = [np.where(top_left >= 0, redirect[np.maximum(top_left, 0)], -1)]
    right = [np.where(top_right >= 0, redirect[np.maximum(top_right, 0)], -1)]
    bits = [np.zeros(len(top), np.int64)]
    for j, (t, o) in enumerate(zip(trees, offset, strict=True)):
        left.append(np.where(t.left >= 0, t.left + o, -1))
        right.append(np.where(t.right >= 0, t.right + o, -1))
        bits.append(np.full(len(t.nodes), 1 << j, np.int64))
    all_bits = np.concatenate(bits)
    # the top tree's nodes: their members' bits (children come after their parent)
    for n in range(len(top) - 1, -1, -1):
        if top_leaf_of[n] >= 0:
            all_bits[n] = 1 << int(top_leaf_of[n])
        elif top_left[n] >= 0:
            all_bits[n] = all_bits[top_left[n]] | all_bits[top_right[n]]
    inner = np.vstack(
        [
            np.c_[t.inner[:, :3] @ T[:3, :3].T + T[:3, 3], t.inner[:, 3]]
            for t, T in zip(trees, T_union_member, strict=True)
        ]
    )
    inner[:, 3] -= margin
    inner = inner[inner[:, 3] > 0]
    inner = inner[np.argsort(-inner[:, 3], kind="stable")[:UNION_INNER]]
    nodes = np.vstack([top, *parts])
    tree = SphereTree(
        nodes,
        np.concatenate(left).astype(np.int64),
        np.concatenate(right).astype(np.int64),
        inner,
        tri_start=np.zeros(len(nodes) + 1, np.int64),
    )
    return tree, all_bits


def _regroup(
    pairs: list[tuple[int, int]], groups: list[_PairGroup]
) -> tuple[list[tuple[int, int]], list[_PairGroup]]:
    """``pairs`` reordered so that each group's pairs are consecutive, where its first pair
    was, and the groups with their new pair indices."""
    if not groups:
        return pairs, groups
    taken = {k for g in groups for k in g.pairs}
    by_first = {g.pairs[0]: g for g in groups}
    order: list[int] = []
    out = []
    for k in range(len(pairs)):
        if k in by_first:
            g = by_first[k]
            out.append(
                _PairGroup(g.body, g.union, list(range(len(order), len(order) + len(g.pairs))))
            )
            order += g.pairs
        elif k not in taken:
            order.append(k)
    return [pairs[k] for k in order], out


def _anchors(
    robot: RobotModel, group: JointGroup, base: NDArray[np.float64]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Per link: its anchor (the child link of the last joint on its path from the root that
    the group moves, or the root) and its pose in the anchor's frame, which the joints outside
    the group fix at ``base``."""
    t = robot.tree
    moving = {int(i) for i in group.indices}
    T = link_poses(robot, base)
    parent_joint = {int(c): j for j, c in enumerate(t.child_link)}
    root = robot.link_index(robot.root_link)
    anchor = np.empty(t.n_links, np.int64)
    for link in range(t.n_links):
        k = link
        while k in parent_joint:
            j = parent_joint[k]
            if t.var[j] >= 0 and int(t.var[j]) in moving:
                break
            k = int(t.parent_link[j])
        anchor[link] = k if k in parent_joint else root
    T_anchor_link = np.einsum("lij,ljk->lik", np.linalg.inv(T[anchor]), T)
    return anchor, T_anchor_link


def _motion_signatures(
    robot: RobotModel, links: list[str], group: JointGroup
) -> list[frozenset[int]]:
    """For each link, the joints on its path from the root whose variable the group moves:
    two links with the same set keep their relative pose whatever the group does."""
    t = robot.tree
    moving = {int(i) for i in group.indices}
    parent_joint = {int(c): j for j, c in enumerate(t.child_link)}
    memo: dict[str, frozenset[int]] = {}
    for name in links:
        if name in memo:
            continue
        k = robot.link_index(name)
        js = []
        while k in parent_joint:
            j = parent_joint[k]
            if t.var[j] >= 0 and int(t.var[j]) in moving:
                js.append(j)
            k = int(t.parent_link[j])
        memo[name] = frozenset(js)
    return [memo[n] for n in links]


def _rigid(robot: RobotModel, links: list[str], moving: frozenset[int]) -> bool:
    """Whether no variable outside ``moving`` sits between any of ``links`` and the last
    joint above it that ``moving`` has (a gripper's finger joint): links the same group joints
    move then keep their relative poses whatever the other variables are."""
    t = robot.tree
    parent_joint = {int(c): j for j, c in enumerate(t.child_link)}
    for name in links:
        k = robot.link_index(name)
        while k in parent_joint:
            j = parent_joint[k]
            if t.var[j] >= 0:
                if int(t.var[j]) not in moving:
                    return False
                break
            k = int(t.parent_link[j])
    return True


@dataclass
class _RobotTables:
    """A robot's pair tables, kept per robot (the disk cache is keyed by a hash of the links'
    meshes, which costs more than building a checker): the chains of its link pairs, the
    tables by key, and the kernel's packed arrays per list of tables, the last few kept
    (joints outside the group, a gripper's, can take many values over a run)."""

    chains: dict[tuple[Any, ...], Chain | None] = field(default_factory=dict)
    tables: dict[tuple[Any, ...], PairTable] = field(default_factory=dict)
    packed: dict[tuple[Any, ...], tuple[NDArray[Any], ...]] = field(default_factory=dict)
    # cluster unions: (key, the members' poses (M, 4, 4), union tree, members' bits)
    unions: list[tuple[tuple[Any, ...], NDArray[np.float64], SphereTree, NDArray[np.int64]]] = (
        field(default_factory=list)
    )

    KEEP = 16

    def union(
        self, names: tuple[str, ...], trees: list[SphereTree], Ts: NDArray[np.float64]
    ) -> tuple[tuple[Any, ...], SphereTree, NDArray[np.int64]]:
        """The union body of cluster members ``names`` (their trees, at poses ``Ts`` (M, 4, 4) in
        the union's frame): its key, tree and members' bits (:func:`_union_tree`). A union made
        for poses that move no point of a member's tree by more than UNION_MARGIN serves (it
        is grown by that margin): a gripper's opening synced from physics differs between
        checkers by micrometres (1e-6 to 5e-6 of its transforms in the sorting demo), and
        a new union, its merge with the links and its pair tables cost 3–4 ms of a 6 ms
        build."""
        for i, (key, cached, tree, bits) in enumerate(self.unions):
            if key[1] == names and all(
                _moved_by(t, A, B) <= UNION_MARGIN
                for t, A, B in zip(trees, cached, Ts, strict=True)
            ):
                self.unions.append(self.unions.pop(i))  # the most recently used last
                return key, tree, bits
        Ts = np.round(Ts, 12)
        key = ("union", names, tuple(T.tobytes() for T in Ts))
        tree, bits = _union_tree(trees, list(Ts), UNION_MARGIN)
        self.unions.append((key, Ts, tree, bits))
        del self.unions[:-8]
        return key, tree, bits

    def keep(self, key: tuple[Any, ...], arrays: tuple[NDArray[Any], ...]) -> None:
        self.packed[key] = arrays
        while len(self.packed) > self.KEEP:
            self.packed.pop(next(iter(self.packed)))
        while len(self.tables) > 4 * self.KEEP:
            self.tables.pop(next(iter(self.tables)))


_TABLES: weakref.WeakKeyDictionary[RobotModel, _RobotTables] = weakref.WeakKeyDictionary()
# the kernel's packed bodies (links, cluster unions, held objects) of the last few checkers,
# across robots: a checker is built per candidate grasp or place, mostly for the same opening
# and held object (the same merge then serves them all: see _merge for what one costs)
_MERGED: dict[tuple[Any, ...], Packed] = {}


_EPOCH = [0]
_WARM = [False]  # the kernels have run once in this process


def skip_warm_up() -> None:
    """Build checkers without compiling the batch kernels first (a process that compiles
    other kernels only: robocell.planning.precompile)."""
    _WARM[0] = True


def threads_rested() -> bool:
    """Whether this process mostly rested since the last call: its threads used less than
    half of the time since as CPU time, so the kernel's sleeping threads are slow to wake
    (see REST_CHUNK). A plan asks once at its start, a check of a batch of more than CHUNK
    states once per batch."""
    now, cpu = time.perf_counter(), time.process_time()
    wall, used = now - _LAST_ASKED[0], cpu - _LAST_ASKED[1]
    _LAST_ASKED[0], _LAST_ASKED[1] = now, cpu
    return used < 0.5 * wall


_LAST_ASKED = [0.0, 0.0]  # time.perf_counter and time.process_time at threads_rested's last call


# The kernel's two threads need both of this machine's cores. Beside another process that keeps
# a core busy, the operating system shares them among three threads, and a call on the kernel's
# threads waits for whichever is off its core: its searches for each other, the parallel
# region's end for the last thread. Session 50, Panda table sets after `ompl` plans, medians:
# beside a busy loop, searches side by side 1.95 and 3.31 ms, one after the other in the calling
# thread 1.11 and 2.28 (the same paths); without it 0.66 and 1.22 against 0.96 and 2.06. The
# calling thread spins while it waits for the other thread, so a call's wall time less its CPU
# time says whether the host kept it waiting: 0 µs in 40 of 40 plans without the busy loop,
# 660 µs at the 10th percentile beside it (half the call).
CONTENDED_WAIT = 150e-6  # [s] a threaded call whose calling thread waited longer than this,
CONTENDED_SHARE = 0.25  # and than this share of the call, was kept waiting by the host
CONTENDED_FOR = 0.02  # [s] then calls run in the calling thread this long, then try the
CONTENDED_MAX = 1.0  # threads again; doubling each time they still wait, up to this [s]


@dataclass
class ThreadGauge:
    """Whether the host lets the kernel's threads run together: from the calls made on them
    (:meth:`note`), :meth:`contended` says whether to keep the next call in the calling thread
    (see CONTENDED_WAIT). Which it does changes how fast a plan is found, never which path:
    the searches run one after the other to the same result."""

    until: float = 0.0  # time.perf_counter until which calls keep to the calling thread
    backoff: float = 0.0  # [s] how long that was, 0 once the threads ran together again

    def note(self, wall: float, cpu: float) -> None:
        """A call on the kernel's threads took ``wall`` [s], the calling thread's CPU time
        in it ``cpu`` [s] (time.thread_time)."""
        if wall - cpu > max(CONTENDED_WAIT, CONTENDED_SHARE * wall):
            self.backoff = min(2 * self.backoff, CONTENDED_MAX) if self.backoff else CONTENDED_FOR
            self.until = time.perf_counter() + self.backoff
        else:
            self.until, self.backoff = 0.0, 0.0

    def contended(self) -> bool:
        """Whether the host kept the threads waiting lately: the next call keeps to the
        calling thread."""
        return time.perf_counter() < self.until


THREADS = ThreadGauge()  # the process's: its kernel threads are shared by every checker


def next_epoch(n: int) -> int:
    """The first of n stamps no kernel call has used: the scratch below is shared by every
    checker of the process, so stamps must be unique across them (kernels hold the GIL, so two
    calls never overlap)."""
    e = _EPOCH[0]
    _EPOCH[0] = e + n
    return e


_SCRATCH: list[tuple[NDArray[Any], ...]] = []  # the kernel's scratch (_scratch), once made


def _scratch(m: int, k: int, n_tris: int, n_links: int) -> tuple[NDArray[Any], ...]:
    """Per-thread scratch of the kernel (see K.classify), shared by every checker of the
    process, whatever its robot, and grown when a checker needs more room. Filling tens of MB
    per checker cost more than the rest of building it (measured); per robot model, each cell
    loaded made it anew, twice (the sorting benchmark: 0.27 s of a 2.5 s layout). Sharing is
    safe as kernel calls never overlap (see :func:`next_epoch`) and take their stamps from
    one counter."""
    slots = int(numba.config.NUMBA_NUM_THREADS) + SEARCH_SLOTS  # type: ignore[attr-defined]
    m, k, n_tris = max(m, 1), max(k, 1), max(n_tris, 1)
    have = _SCRATCH[0] if _SCRATCH else None
    if (
        have is None
        or have[0].shape[1] < m
        or have[2].shape[1] < k
        or have[4].shape[1] < n_tris
        or have[6].shape[1] < n_links
    ):
        if have is not None:
            # grown by half at least: a robot holding objects of a few sizes in turn (the
            # sorting demo) grew it 24 times by a few nodes, filling it anew each time
            m = max(m, have[0].shape[1] * 3 // 2)
            k = max(k, have[2].shape[1] * 3 // 2)
            n_tris = max(n_tris, have[4].shape[1] * 3 // 2)
            n_links = max(n_links, have[6].shape[1])
        # the stamps' last entry is not a sphere's: it counts the centres placed (K._centre).
        # Filled, not empty: a slot's pages are then mapped here, not in a plan's first search
        _SCRATCH[:] = []  # the old scratch freed before the new one is filled
        have = (
            np.zeros((slots, m, 3)),
            np.full((slots, m + 1), -1, np.int64),
            np.zeros((slots, k, 3)),
            np.full((slots, k + 1), -1, np.int64),
            np.full((slots, n_tris), -1, np.int64),
            np.full((slots, 2, K.PAIR_SET), -1, np.int64),
            np.zeros((slots, n_links, 4, 4)),
        )
        for i in (0, 2, 6):  # np.zeros maps pages lazily
            have[i].fill(0.0)
        _SCRATCH.append(have)
    return have


class CollisionChecker:
    """Batched collision checks for ``group`` in a snapshot of ``scene`` (joints outside the
    group at the scene's current state). Build it with :meth:`PlanningScene.checker`.

    - ``check(qs)``: (N, dof) → (N,) bool, True = in collision;
    - ``check_motion(q_a, q_b, resolution)``: True if any state on the straight joint-space
      segment (sampled so that no joint moves more than ``resolution`` [rad or m]) collides.
    """

    def __init__(self, scene: PlanningScene, group: JointGroup, exact_threads: int = 2) -> None:
        robot = scene.robot
        self.robot = robot
        self.group = group
        self.exact_threads = exact_threads
        self.base_positions = scene.state.positions.copy()
        acm = scene.acm
        moved = set(group.link_names)

        spheres = robot_spheres(robot)
        grids = robot_grids(robot)
        link_shapes: dict[str, list[tuple[Shape, NDArray[np.float64]]]] = {}
        for g in robot.collision_geometry:
            link_shapes.setdefault(g.link, []).append((g.shape, g.T_link_shape))
        bodies = [
            Body(link, link, np.eye(4), s, link in moved, link_shapes[link], grids.get(link))
            for link, s in spheres.items()
        ]
        for att in scene.attached_objects.values():
            # a held object's padding keeps it clear of the world on the way (it swings)
            pad = scene.object_padding(att.id)
            shapes = [
                (padded(sh, pad), p.matrix())
                for sh, p in zip(att.object.shapes, att.object.shape_poses, strict=True)
            ]
            tree = body_tree(shapes)
            bodies.append(
                Body(att.id, att.link, att.object.pose.matrix(), tree, att.link in moved, shapes)
            )
        self.bodies = bodies
        T_root_world = scene.T_root_world
        obstacles: list[Obstacle] = []
        self._padding = {o: scene.object_padding(o) for o in scene.world_objects}
        self._obstacle_shapes: list[tuple[Shape, NDArray[np.float64]]] = []
        for obj in scene.world_objects.values():
            for shape, T in zip(obj.shapes, obj.shape_matrices(), strict=True):
                shape = padded(shape, self._padding[obj.id])
                obstacles.append(obstacle_of(obj.id, shape, T_root_world @ T))
                self._obstacle_shapes.append((shape, T_root_world @ T))
        self.obstacles = obstacles
        self._coal: tuple[list[Any], list[Any]] | None = None
        self._world_objects = list(scene.world_objects.values())
        self._attached = list(scene.attached_objects.values())
        self._T_root_world = T_root_world

        self.world_pairs: list[tuple[int, int]] = []
        self.static_world_pairs: list[tuple[int, int]] = []
        T_links = link_poses(robot, self.base_positions)
        for bi, b in enumerate(bodies):
            reach = _reach(robot, group, b, T_links) if b.moving else None
            for oi, o in enumerate(obstacles):
                if acm.allowed(b.name, o.object_id):
                    continue
                if reach is not None and (
                    K._obstacle_distance(
                        reach[0][0], reach[0][1], reach[0][2], o.kind, o.T_scene_shape, o.dims
                    )
                    > reach[1] + REACH_MARGIN
                ):
                    continue  # the body cannot reach the obstacle, whatever the joints do
                (self.world_pairs if b.moving else self.static_world_pairs).append((bi, oi))
        self.self_pairs: list[tuple[int, int]] = []
        self.static_self_pairs: list[tuple[int, int]] = []
        att_by_id = {a.id: a for a in self._attached}
        motion = _motion_signatures(robot, [b.link for b in bodies], group)
        for i in range(len(bodies)):
            for j in range(i + 1, len(bodies)):
                a, b = bodies[i], bodies[j]
                if acm.allowed(a.name, b.name):
                    continue
                if self._touching_allowed(a, b, att_by_id):
                    continue
                # two bodies the same group joints move are rigid to each other (a gripper's
                # links while the arm plans): their pair is decided once, like a fixed one's
                if motion[i] != motion[j]:
                    self.self_pairs.append((i, j))
                else:
                    self.static_self_pairs.append((i, j))
        self._groups = self._pair_groups(motion, len(robot_spheres(robot)))
        self._pack()
        self._warm_up()
        self._exact = None
        self._pool = None
        self._broadphase: tuple[Any, Any] | None = None
        self._full_exact = None
        self._swept: dict[float, SweptCheck] = {}
        self.static_collisions = self._static_collisions()

    @staticmethod
    def _touching_allowed(a: Body, b: Body, att_by_id: dict[str, AttachedObject]) -> bool:
        """A held object may touch its link and its touch links."""
        for x, y in ((a, b), (b, a)):
            att = att_by_id.get(x.name)
            if (
                att is not None
                and x.name != y.name
                and (y.name in att.touch_links or y.name == att.link)
            ):
                return True
        return False

    def _pair_groups(self, motion: list[frozenset[int]], n_robot: int) -> list[_PairGroup]:
        """The broad phase over rigid clusters: the robot's moving links that the same group
        joints move (a UR5's wrist 3 and its gripper's ten links) form a cluster; a body with
        self pairs against two or more of its members gets one test of the cluster's union
        tree against its distance field before those pairs, and each obstacle one test of
        the union's bounding sphere before the members' world pairs. ``self_pairs`` and
        ``world_pairs`` are reordered so that each group's pairs are consecutive (where its
        first pair was)."""
        self._unions: list[tuple[int, ...]] = []
        clusters: dict[frozenset[int], list[int]] = {}
        for i in range(n_robot):
            if motion[i]:
                clusters.setdefault(motion[i], []).append(i)
        groups: list[_PairGroup] = []
        member_of = {i: c for c, ms in enumerate(clusters.values()) for i in ms if len(ms) > 1}
        by_key: dict[tuple[int, int], list[tuple[int, int]]] = {}
        for k, (i, j) in enumerate(self.self_pairs):
            for x, m in ((i, j), (j, i)):
                if m in member_of and member_of.get(x) != member_of[m]:
                    by_key.setdefault((x, member_of[m]), []).append((k, m))
                    break
        taken: set[int] = set()
        unions: dict[tuple[int, ...], int] = {}
        for (x, _), km in by_key.items():
            km = [(k, m) for k, m in km if k not in taken]
            if len(km) < 2 or self.bodies[x].field_kind == K.FIELD_NONE:
                continue
            # the union of just the members x has pairs with (the ACM may allow some), at most
            # 62 of them (the kernel marks members as bits of an int64)
            members = tuple(sorted({m for _, m in km}))[:62]
            km = [(k, m) for k, m in km if m in members]
            if len(km) < 2:
                continue
            taken.update(k for k, _ in km)
            u = unions.setdefault(members, len(unions))
            groups.append(_PairGroup(x, u, [k for k, _ in km]))
        # world pairs: a cluster's members against one obstacle, behind the union's sphere
        w_by_key: dict[tuple[int, int], list[tuple[int, int]]] = {}
        for k, (b, o) in enumerate(self.world_pairs):
            if b in member_of:
                w_by_key.setdefault((o, member_of[b]), []).append((k, b))
        self._world_groups: list[_PairGroup] = []
        # one union per cluster, of its members with any world pair, however few of them
        # have a pair with each obstacle (the ACM, or reach, leaves some out): the union's
        # sphere clear of the whole world then clears all its groups at once
        in_world: dict[int, set[int]] = {}
        for (_, c), km in w_by_key.items():
            in_world.setdefault(c, set()).update(m for _, m in km)
        for (o, c), km in w_by_key.items():
            members = tuple(sorted(in_world[c]))[:62]
            km = [(k, m) for k, m in km if m in members]
            if len(km) >= 2:
                u = unions.setdefault(members, len(unions))
                self._world_groups.append(_PairGroup(o, u, [k for k, _ in km]))
        self.world_pairs, self._world_groups = _regroup(self.world_pairs, self._world_groups)
        self._unions = list(unions)
        if not groups:
            return []
        self.self_pairs, groups = _regroup(self.self_pairs, groups)
        return groups

    def _union_bodies(self) -> list[Body]:
        """One body per member set of :meth:`_pair_groups`, in the frame of the first member's
        link (see :func:`_union_tree`; cached per robot by the members' relative poses, which
        the joints outside the group set: a gripper's opening)."""
        if not self._unions:
            return []
        robot = self.robot
        cache = _TABLES.setdefault(robot, _RobotTables())
        T_link = link_poses(robot, self.base_positions)
        out = []
        self._union_bits: list[NDArray[np.int64]] = []
        self._union_keys: list[tuple[Any, ...]] = []
        for members in self._unions:
            rep = self.bodies[members[0]].link
            T_rep_world = invert_transform(T_link[robot.link_index(rep)])
            Ts = np.array(
                [
                    T_rep_world @ T_link[robot.link_index(self.bodies[m].link)]
                    @ self.bodies[m].T_link_body
                    for m in members
                ]
            )  # fmt: skip
            key, tree, bits = cache.union(
                tuple(self.bodies[m].name for m in members),
                [self.bodies[m].spheres for m in members],
                Ts,
            )
            self._union_keys.append(key)
            out.append(Body(f"<cluster of {rep}>", rep, np.eye(4), tree, True, []))
            self._union_bits.append(bits)
        return out

    # ------------------------------------------------------------------ packing for the kernel
    def _pack(self) -> None:
        robot, group = self.robot, self.group
        bodies = self.bodies
        # each body rides on its anchor, the link below the last group joint on its path, at
        # a pose the other joints fix: FK then runs over the group's chain alone (the UR5's
        # gripper and flange frames are 14 of its 20 links)
        anchor, T_anchor_link = _anchors(robot, group, self.base_positions)
        link_idx = np.array([anchor[robot.link_index(b.link)] for b in bodies], dtype=np.int64)
        self._body_link = link_idx
        self._body_T = np.array(
            [T_anchor_link[robot.link_index(b.link)] @ b.T_link_body for b in bodies]
        ).reshape(-1, 4, 4)
        n_robot = len(robot_spheres(robot))
        names = tuple(b.name for b in bodies[:n_robot])
        robot_packed = _robot_pack(robot, names)  # packed once per robot
        obs = self.obstacles
        self._obs_kind = np.array([o.kind for o in obs], dtype=np.int64)
        self._obs_T = np.array([o.T_scene_shape for o in obs]).reshape(-1, 4, 4)
        self._obs_dims = np.array([o.dims for o in obs]).reshape(-1, 3)
        self._obs_sphere = np.array([_bounding_sphere(o) for o in obs]).reshape(-1, 4)
        self._obs_inner_ok = np.array([o.exact_inner for o in obs], dtype=np.bool_)

        self._pair_field = np.array(
            [field_side(bodies[i], bodies[j]) for i, j in self.self_pairs], dtype=np.int64
        )
        # the kernel's bodies: the robot's links, the rigid clusters' union bodies (no pair
        # names them), then held objects. Links and unions are packed together once per
        # gripper opening (a checker is built for each candidate grasp and place: merging the
        # link arrays each time cost 10 ms of a 13 ms build)
        unions = self._union_bodies()
        n_u = len(unions)
        kmap = np.arange(len(bodies))
        kmap[n_robot:] += n_u
        ui = [robot.link_index(u.link) for u in unions]
        packed = robot_packed
        extra = unions + bodies[n_robot:]
        if extra:
            # held objects by their shapes (place candidates are checked one checker each,
            # all holding the same object); not by where they are held, which is the
            # checker's (body_T), not the merge's: synced from physics, it differs each time
            held = tuple((b.name, b.link, _shapes_key(b.shapes)) for b in bodies[n_robot:])
            key = (geometry_key(robot), names, tuple(self._union_keys), held)
            # each holds a copy of a robot's arrays (tens of MB). The sorting demo's 100
            # lookups per layout, 34 of them new: 50 merges kept 3 first in, first out, 37
            # kept 5 least recently used out
            packed = _kept(_MERGED, key, lambda: _merge(robot_packed, pack_bodies(extra)), 5)
        # kept for as long as this checker lives: its arrays may be views of buffers that go
        # back to the pool when the merge is no longer in use (_merge)
        self._packed = packed
        self._tables = self._pair_tables(packed, n_robot)
        body_link = np.concatenate([link_idx[:n_robot], anchor[ui], link_idx[n_robot:]])
        body_T = np.concatenate(
            [self._body_T[:n_robot], T_anchor_link[ui].reshape(-1, 4, 4), self._body_T[n_robot:]]
        )
        world = np.array(self.world_pairs, dtype=np.int64).reshape(-1, 2)
        self._world_pairs = np.c_[kmap[world[:, 0]], world[:, 1]].reshape(-1, 2)
        self._self_pairs = kmap[np.array(self.self_pairs, dtype=np.int64).reshape(-1, 2)]
        node_members = np.zeros(len(packed.nodes), np.int64)
        for i, bits in enumerate(self._union_bits if unions else []):
            r = int(packed.body_root[n_robot + i])
            node_members[r : r + len(bits)] = bits
        pair_bit = np.full(len(self.self_pairs), -1, np.int64)
        for g in self._groups:
            members = self._unions[g.union]
            for k in g.pairs:
                i, j = self.self_pairs[k]
                pair_bit[k] = members.index(j if i == g.body else i)
        world_group_start = np.full(len(self.world_pairs), -1, np.int64)
        world_group_union = np.zeros(len(self._world_groups), np.int64)
        world_group_count = np.zeros(len(self._world_groups), np.int64)
        for gi, g in enumerate(self._world_groups):
            world_group_start[g.pairs[0]] = gi
            world_group_union[gi] = n_robot + g.union
            world_group_count[gi] = len(g.pairs)
        world_run_end = _world_runs(
            self._world_pairs, world_group_start, world_group_union, world_group_count
        )
        n_groups = len(self._groups)
        group_start = np.full(len(self.self_pairs), -1, np.int64)
        group_bodies = np.zeros((n_groups, 2), np.int64)
        group_count = np.zeros(n_groups, np.int64)
        for gi, g in enumerate(self._groups):
            group_start[g.pairs[0]] = gi
            group_bodies[gi] = (kmap[g.body], n_robot + g.union)
            group_count[gi] = len(g.pairs)
        # the world's distance grid reaches as far out as the widest body's bounding sphere
        # and a margin for the grid's spacing (a body nearer than its radius is tested
        # against each obstacle)
        bodies_w = np.union1d(self._world_pairs[:, 0], world_group_union)
        radii = packed.nodes[packed.body_root[bodies_w], 3]
        cap = min(1.0, float(radii.max(initial=0.0)) + 0.1)
        self._world_grid = world_grid(self._obs_kind, self._obs_T, self._obs_dims, cap)
        args = tree_args(robot)
        self._args = args
        moving_links = sorted({int(x) for x in body_link})
        self._joints = args.joints_to(*moving_links)
        self._group_idx = group.indices.astype(np.int64)
        self._scratch = _scratch(
            len(packed.nodes), len(packed.inner), len(packed.triangles[3]), args.n_links
        )
        # everything the kernel takes besides the states, in its order, built once: a call
        # then costs one tuple unpacking instead of forty attribute lookups
        # the kernel's model (K.MODEL_FIELDS), built once: a call then passes one tuple
        self._model = (
            self._group_idx,
            self.base_positions,
            self._joints,
            args.root,
            *args.arrays,
            body_link,
            body_T,
            packed.body_root,
            packed.nodes,
            packed.left,
            packed.right,
            packed.inner_start,
            packed.inner,
            self._obs_kind,
            self._obs_T,
            self._obs_dims,
            self._obs_sphere,
            self._obs_inner_ok,
            self._world_pairs,
            self._self_pairs,
            self._pair_field,
            *packed.fields,
            *packed.triangles,
            *self._tables,
            group_start,
            group_bodies,
            group_count,
            node_members,
            pair_bit,
            world_group_start,
            world_group_union,
            world_group_count,
            world_run_end,
            *self._world_grid,
        )
        assert len(self._model) == len(K.MODEL_FIELDS)

    def _pair_tables(self, packed: Packed, n_robot: int) -> tuple[NDArray[Any], ...]:
        """The kernel's pair tables (see :mod:`robocell.scene.pair_tables`): pair_table (a
        table per self pair, or −1), table_vars, table_n, table_off, table_values, and
        group_table (a table per pair group, or −1). ``packed``: the links, then the union
        bodies."""
        robot = self.robot
        cache = _TABLES.setdefault(robot, _RobotTables())
        moving = frozenset(int(i) for i in self.group.indices)
        base = self.base_positions

        def chain_of(a: str, b: str, max_joints: int) -> Chain | None:
            ck = (a, b, moving, max_joints)
            if ck not in cache.chains:
                cache.chains[ck] = table_chain(robot, a, b, set(moving), max_joints)
            return cache.chains[ck]

        # which pairs and groups have a table, and each table's key: the packed arrays are
        # kept per such list (a checker is built per scene change; concatenating MBs of tables
        # each time cost 40 % of building one, measured)
        wanted: list[tuple[int, Chain, int, int, tuple[Any, ...], Members]] = []
        for k, (i, j) in enumerate(self.self_pairs):
            if i >= n_robot or j >= n_robot:
                continue
            a, b = self.bodies[i].name, self.bodies[j].name
            chain = chain_of(a, b, 2)
            if chain is None:
                continue
            f, d = (i, j) if robot.link_index(a) == chain.upper else (j, i)
            if self.bodies[f].field_kind == K.FIELD_NONE:
                continue
            key = (chain.upper, chain.lower, chain.variables, tuple(base[list(chain.fixed)]))
            wanted.append((k, chain, f, d, key, None))
        n_pairs = len(self.self_pairs)
        for gi, g in enumerate(self._groups):
            # a body against a rigid cluster below it: a table over up to three angles, if the
            # members keep their poses whatever the robot's other joints do (a hand that opens
            # would need a table per opening)
            x, members = self.bodies[g.body], self._unions[g.union]
            rep = self.bodies[members[0]].link
            if not _rigid(robot, [self.bodies[m].link for m in members], moving):
                continue
            chain = chain_of(x.name, rep, 3)
            if chain is None or chain.upper != robot.link_index(x.name):
                continue
            # the members with their poses, for the table's key; the margin too (the table
            # is built on the union's spheres)
            _, names, poses = self._union_keys[g.union]
            margin = np.float64(UNION_MARGIN).tobytes()
            placed = tuple((n, T + margin) for n, T in zip(names, poses, strict=True))
            key = (chain.upper, chain.lower, chain.variables, tuple(base[list(chain.fixed)]))
            wanted.append((n_pairs + gi, chain, g.body, n_robot + g.union, key + placed, placed))
        out_key = (n_pairs, tuple((k, key) for k, _, _, _, key, _ in wanted))
        if out_key in cache.packed:
            return cache.packed[out_key]
        index = np.full(n_pairs + len(self._groups), -1, np.int64)
        tables: list[PairTable] = []
        for k, chain, f, d, key, parts in wanted:
            if key not in cache.tables:
                cache.tables[key] = pair_table(robot, chain, base, f, d, packed, parts)
            index[k] = len(tables)
            tables.append(cache.tables[key])
        # four cells to a byte (K.pack_tables), each table from a byte of its own
        packed_values = [t.packed for t in tables]
        sizes = [4 * len(v) for v in packed_values]
        out = (
            index[:n_pairs],
            np.array(
                [list(t.variables) + [-1] * (3 - len(t.variables)) for t in tables], np.int64
            ).reshape(-1, 3),
            np.array([t.n for t in tables], np.int64),
            np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
            if tables
            else np.zeros(0, np.int64),
            np.concatenate(packed_values) if tables else np.zeros(1, np.uint8),
            index[n_pairs:],
        )
        cache.keep(out_key, out)
        return out

    def _warm_up(self) -> None:
        """Compile (or load from numba's cache) the batch kernels once per process, here
        rather than inside the first plan's time budget (one signature each: whatever the
        flags, a call from Python passes the same types)."""
        if _WARM[0]:
            return
        q = np.tile(self.base_positions[self.group.indices], (CHUNK + 1, 1))
        K.classify_in(q, self._inputs, next_epoch(len(q)), False, CHUNK)
        K.classify_serial_in(q[:1], self._inputs, next_epoch(1), True, True, 0)
        _WARM[0] = True

    # ------------------------------------------------------------------ exact level
    def _exact_model(self):  # type: ignore[no-untyped-def]
        """Pinocchio geometry model with the robot, held and world geometry, and exactly the
        pairs the sphere level checks (static pairs excluded)."""
        if self._exact is not None:
            return self._exact
        import pinocchio as pin

        robot = self.robot
        gm = robot.pin_collision_model.copy()
        gm.removeAllCollisionPairs()
        geoms_of: dict[str, list[int]] = {}
        for gi, g in enumerate(robot.collision_geometry):
            geoms_of.setdefault(g.link, []).append(gi)
        pm = robot.pin_model
        for att in self._attached:
            fid = pm.getFrameId(att.link, pin.BODY)
            frame = pm.frames[fid]
            T_joint_obj = frame.placement.homogeneous @ att.object.pose.matrix()
            ids = []
            for k, (shape, p) in enumerate(
                zip(att.object.shapes, att.object.shape_poses, strict=True)
            ):
                go = pin.GeometryObject(
                    f"{att.id}#{k}",
                    frame.parentJoint,
                    fid,
                    pin.SE3(T_joint_obj @ p.matrix()),
                    coal_geometry(shape),
                )
                ids.append(gm.addGeometryObject(go))
            geoms_of[att.id] = ids
        obs_geoms: list[int] = []
        for obj in self._world_objects:
            for k, (shape, T) in enumerate(zip(obj.shapes, obj.shape_matrices(), strict=True)):
                go = pin.GeometryObject(
                    f"{obj.id}#{k}", 0, 0, pin.SE3(self._T_root_world @ T),
                    coal_geometry(padded(shape, self._padding[obj.id])),
                )  # fmt: skip
                obs_geoms.append(gm.addGeometryObject(go))
        self._geoms_of, self._obs_geoms = geoms_of, obs_geoms
        self._add_pairs(gm, self.world_pairs, self.self_pairs)
        self._exact = (gm, exact_data(gm), pm.createData())
        return self._exact

    def _exact_pool(self):  # type: ignore[no-untyped-def]
        """The exact model's pool of geometry data for :meth:`check_exact`'s threads, made on
        first use: a pool of two took 11 ms to make beside a 20 k-triangle mesh, and a checker
        that checks one state at a time (:meth:`check_exact_one`) never needs it."""
        if self._pool is None:
            gm = self._exact_model()[0]
            self._pool = exact_pool(self.robot.pin_model, gm, self.exact_threads)
        return self._pool

    def _full(self, qs: NDArray[np.float64]) -> NDArray[np.float64]:
        full = np.tile(self.base_positions, (qs.shape[0], 1))
        full[:, self.group.indices] = qs
        return full

    def check_exact(self, qs: ArrayLike) -> NDArray[np.bool_]:
        """(N,) bool: the exact (coal) answer alone, batched in C++ over the states."""
        import pinocchio as pin

        q = self.group.as_joint_batch(qs)
        if self.static_collisions:
            return np.ones(q.shape[0], dtype=bool)
        gm = self._exact_model()[0]
        if len(gm.collisionPairs) == 0:
            return np.zeros(q.shape[0], dtype=bool)
        pool = self._exact_pool()
        Q = np.asfortranarray(self.robot.pin_configurations(self._full(q)).T)
        return np.asarray(
            pin.computeCollisionsInParallel(self.exact_threads, pool, Q, True), dtype=bool
        )

    def check_exact_one(self, q: ArrayLike) -> bool:
        """Whether one configuration collides, exactly (coal), the pairs found through coal's
        dynamic AABB tree broad phase, as MoveIt's FCL environment finds them: for callers
        that check one state at a time (the OMPL baseline's state validity callback). For a
        UR5 among shelves, 60 µs per state instead of 175 µs testing every pair (measured)."""
        import pinocchio as pin

        qv = self.group.as_joint_vector(q)
        if self.static_collisions:
            return True
        gm, _, data = self._exact_model()
        if len(gm.collisionPairs) == 0:
            return False
        if self._broadphase is None:
            gd = exact_data(gm)  # the manager keeps a pointer to it: kept alive beside it
            manager = pin.BroadPhaseManager_DynamicAABBTreeCollisionManager(
                self.robot.pin_model, gm, gd
            )
            self._broadphase = (manager, gd)
        q_pin = self.robot.pin_configurations(self._full(qv[None]))[0]
        return bool(
            pin.computeCollisions(self.robot.pin_model, data, self._broadphase[0], q_pin, True)
        )

    def classify(
        self, qs: ArrayLike, pair_flags: bool = True
    ) -> tuple[NDArray[np.int8], NDArray[np.bool_]]:
        """The sphere level alone: (N,) int8 (0 free, 1 colliding, 2 unsure) and (N, P) flags
        of the unsure pairs (world pairs, then self pairs). ``pair_flags=False`` skips the
        flags (an empty array): ``check`` does not need them."""
        return self._classify(self.group.as_joint_batch(qs), pair_flags)

    def _classify(
        self, q: NDArray[np.float64], pair_flags: bool
    ) -> tuple[NDArray[np.int8], NDArray[np.bool_]]:
        """classify on an already validated (N, dof) C-contiguous array."""
        epoch = next_epoch(q.shape[0])
        n = q.shape[0]
        if n <= CHUNK or (n <= REST_CHUNK and (threads_rested() or THREADS.contended())):
            return K.classify_serial_in(q, self._inputs, epoch, pair_flags, False, 0)  # type: ignore[no-any-return]
        return K.classify_in(q, self._inputs, epoch, pair_flags, CHUNK)  # type: ignore[no-any-return]

    def check(self, qs: ArrayLike) -> NDArray[np.bool_]:
        """(N,) bool, True where the configuration (N, dof) is in collision."""
        q = self.group.as_joint_batch(qs)
        if self.static_collisions:
            return np.ones(q.shape[0], dtype=bool)
        cls, flags = self._classify(q, True)
        return self.settle(q, cls, flags)

    def collides(self, q: ArrayLike) -> bool:
        """:meth:`check` of one configuration (dof,), as a bool: a plan's start and goal
        (the batch's numpy steps cost 20–40 µs of Python when a plan starts on cold caches,
        measured)."""
        qs = self.group.as_joint_batch(q)
        if qs.shape[0] != 1:
            raise SceneError(
                f"collides() takes one configuration of {self.group.dof} values, "
                f"got shape {np.shape(q)}; use check() for a batch"
            )
        if self.static_collisions:
            return True
        cls, flags = self._classify(qs, True)
        c = int(cls[0])
        if c == K.FREE:
            return False
        return c == K.HIT or bool(self._settle(qs, flags)[0])

    def settle(
        self, q: NDArray[np.float64], cls: NDArray[np.int8], flags: NDArray[np.bool_]
    ) -> NDArray[np.bool_]:
        """:meth:`check`'s answer for states (N, dof) the kernel classified (``cls``, with
        the unsure pairs' ``flags``): its HITs, and its UNSURE states settled by coal."""
        if self.static_collisions:
            return np.ones(q.shape[0], dtype=bool)
        out = cls == K.HIT
        unsure = np.flatnonzero(cls == K.UNSURE)
        if len(unsure):
            out[unsure] = self._settle(q[unsure], flags[unsure])
        return out

    def _settle(self, q: NDArray[np.float64], flags: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """The exact answer (coal) for states whose unsure pairs are flagged: only those pairs
        are tested, with the bodies placed by our own FK (about 5× faster than pinocchio's
        check of every pair, which places every geometry first)."""
        n_world = len(self.world_pairs)
        full = self._full(q)
        out = np.zeros(len(q), dtype=bool)
        for s in range(len(q)):
            T = self._link_poses(full[s])
            for k in np.flatnonzero(flags[s]):
                if k < n_world:
                    hit = self._collide(T, self.world_pairs[k], True)
                else:
                    hit = self._collide(T, self.self_pairs[k - n_world], False)
                if hit:
                    out[s] = True
                    break
        return out

    def _link_poses(self, full: NDArray[np.float64]) -> NDArray[np.float64]:
        args = self._args
        T = np.empty((args.n_links, 4, 4))
        fk_into(full, self._joints, args.root, *args.arrays, T)
        return T

    def _collide(self, T: NDArray[np.float64], pair: tuple[int, int], world: bool) -> bool:
        """coal's verdict on a (body, obstacle) pair (world) or a (body, body) pair, the links
        at poses T."""
        import coal

        body_geoms, obstacle_geoms = self._coal_geometry()
        req = coal.CollisionRequest()
        req.enable_contact = True  # see exact_data

        def placed(bi: int, T_body_geom: NDArray[np.float64]) -> Any:
            M = T[self._body_link[bi]] @ self._body_T[bi] @ T_body_geom
            return coal.Transform3s(M[:3, :3], M[:3, 3])

        a, b = pair
        if world:
            g2, T2 = obstacle_geoms[b]
            others = [(g2, coal.Transform3s(T2[:3, :3], T2[:3, 3]))]
        else:
            others = [(g, placed(b, Tg)) for g, Tg in body_geoms[b]]
        for g1, T1 in body_geoms[a]:
            tf1 = placed(a, T1)
            for g2, tf2 in others:
                if coal.collide(g1, tf1, g2, tf2, req, coal.CollisionResult()) > 0:
                    return True
        return False

    def _coal_geometry(self) -> tuple[list[Any], list[Any]]:
        """coal geometry of every body [(geometry, T_body_geometry)] and every obstacle
        primitive (geometry, T_root_shape); the robot's come from its pinocchio model."""
        if self._coal is None:
            robot_geoms: dict[str, list[tuple[Any, NDArray[np.float64]]]] = {}
            for go, g in zip(
                self.robot.pin_collision_model.geometryObjects,
                self.robot.collision_geometry,
                strict=True,
            ):
                robot_geoms.setdefault(g.link, []).append((go.geometry, g.T_link_shape))
            bodies = [
                robot_geoms.get(b.name)
                or [(coal_geometry(sh), np.asarray(T, float)) for sh, T in b.shapes]
                for b in self.bodies
            ]
            obstacles = [(coal_geometry(sh), T) for sh, T in self._obstacle_shapes]
            self._coal = (bodies, obstacles)
        return self._coal

    def swept(self, tolerance: float | None = None) -> SweptCheck:
        """The continuous check of paths in this checker's scene (:mod:`robocell.scene.swept`),
        to ``tolerance`` [m] (default: swept.TOLERANCE); made once per tolerance."""
        from robocell.scene.swept import TOLERANCE, SweptCheck

        tol = TOLERANCE if tolerance is None else tolerance
        check = self._swept.get(tol)
        if check is None:
            check = self._swept[tol] = SweptCheck(self, tolerance=tol)
        return check

    def kernel_inputs(self) -> tuple[tuple[Any, ...], tuple[NDArray[Any], ...]]:
        """(model, scratch) for compiled code that calls the kernel itself (the compiled
        planner): see K.MODEL_FIELDS. Stamps must come from :func:`next_epoch`."""
        return self._model, self._scratch

    @property
    def compiled_inputs(self) -> K.KernelInputs:
        """:meth:`kernel_inputs` as one object, for compiled entry points called from
        Python (K.KernelInputs: cheaper to pass than the tuples)."""
        return self._inputs

    @property
    def _model(self) -> tuple[Any, ...]:
        """The kernel's model (K.MODEL_FIELDS); setting it rebuilds :attr:`compiled_inputs`."""
        return self._model_tuple

    @_model.setter
    def _model(self, model: tuple[Any, ...]) -> None:
        self._model_tuple = model
        self._inputs = K.kernel_inputs(model, self._scratch)

    def first_collision(self, qs: ArrayLike) -> int:
        """Index of the first state of ``qs`` (N, dof) in collision, N if none: states are
        checked in order and the scan stops at the first collision (an edge check)."""
        q = self.group.as_joint_batch(qs)
        n = q.shape[0]
        if self.static_collisions:
            return 0
        start = 0
        while start < n:
            sub = q[start:]
            cls, flags = K.classify_serial_in(
                sub, self._inputs, next_epoch(len(sub)), True, True, 0
            )
            i = int(np.argmax(cls != K.FREE))
            if cls[i] == K.FREE:
                return n
            if cls[i] == K.HIT or self._settle(sub[i : i + 1], flags[i : i + 1])[0]:
                return start + i
            start += i + 1
        return n

    def is_valid(self, qs: ArrayLike) -> NDArray[np.bool_]:
        """(N,) bool, True where the configuration is collision-free."""
        return ~self.check(qs)

    def motion_states(
        self, q_a: ArrayLike, q_b: ArrayLike, resolution: float = 0.01
    ) -> NDArray[np.float64]:
        """States on the segment q_a → q_b (both ends included), at most ``resolution`` apart
        per joint."""
        a = self.group.as_joint_vector(q_a, "motion start")
        b = self.group.as_joint_vector(q_b, "motion end")
        if not resolution > 0:
            raise SceneError(f"resolution must be > 0, got {resolution}")
        n = max(1, int(math.ceil(float(np.max(np.abs(b - a))) / resolution)))
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        return a + t * (b - a)

    def check_motion(self, q_a: ArrayLike, q_b: ArrayLike, resolution: float = 0.01) -> bool:
        """True if any state on the straight segment from q_a to q_b collides."""
        return bool(self.check(self.motion_states(q_a, q_b, resolution)).any())

    # ------------------------------------------------------------------ diagnostics
    def _static_collisions(self) -> list[tuple[str, str]]:
        """Pairs that collide whatever the group's joints do (checked once, exactly)."""
        if not self.static_world_pairs and not self.static_self_pairs:
            return []
        return self._hits(self.base_positions, self.static_world_pairs, self.static_self_pairs)

    def colliding_pairs(
        self, q: ArrayLike, include_static: bool = True, only_static: bool = False
    ) -> list[tuple[str, str]]:
        """Names of the colliding pairs (link, object id or held object id) at configuration q,
        by coal on every pair whose bounding spheres meet."""
        qv = self.group.as_joint_vector(q)
        world = [] if only_static else list(self.world_pairs)
        own = [] if only_static else list(self.self_pairs)
        if include_static:
            world += self.static_world_pairs
            own += self.static_self_pairs
        return self._hits(self._full(qv[None])[0], world, own)

    def _hits(
        self,
        full: NDArray[np.float64],
        world_pairs: list[tuple[int, int]],
        self_pairs: list[tuple[int, int]],
    ) -> list[tuple[str, str]]:
        """The colliding pairs among these, the robot at the full variable vector ``full``."""
        T = self._link_poses(full)
        spheres = []
        for bi, b in enumerate(self.bodies):
            root = b.spheres.nodes[0] if len(b.spheres.nodes) else np.zeros(4)
            M = T[self._body_link[bi]] @ self._body_T[bi]
            spheres.append((M[:3, :3] @ root[:3] + M[:3, 3], root[3]))
        obs = self._obs_sphere

        def near(c: NDArray[np.float64], r: float, c2: NDArray[np.float64], r2: float) -> bool:
            return float(np.linalg.norm(c - c2)) <= r + r2

        hits = [
            (self.bodies[i].name, self.obstacles[o].object_id)
            for i, o in world_pairs
            if near(*spheres[i], obs[o, :3], obs[o, 3]) and self._collide(T, (i, o), True)
        ]
        hits += [
            (self.bodies[i].name, self.bodies[j].name)
            for i, j in self_pairs
            if near(*spheres[i], *spheres[j]) and self._collide(T, (i, j), False)
        ]
        return sorted(set(hits))

    def min_distance(self, q: ArrayLike) -> tuple[float, tuple[str, str]]:
        """(distance [m], pair) of the closest checked pair at q (negative: penetration)."""
        import pinocchio as pin

        qv = self.group.as_joint_vector(q)
        gm, gd, data, _ = self._full_exact_model()
        if len(gm.collisionPairs) == 0:
            return math.inf, ("", "")
        pin.computeDistances(
            self.robot.pin_model,
            data,
            gm,
            gd,
            self.robot.pin_configurations(self._full(qv[None]))[0],
        )
        d = [r.min_distance for r in gd.distanceResults]
        k = int(np.argmin(d))
        cp = gm.collisionPairs[k]
        return float(d[k]), (self._geom_owner[cp.first], self._geom_owner[cp.second])

    def _add_pairs(
        self, gm: Any, world_pairs: list[tuple[int, int]], self_pairs: list[tuple[int, int]]
    ) -> None:
        """Add to ``gm`` the geometry pairs of these (body, obstacle) and (body, body) pairs."""
        import pinocchio as pin

        for bi, oi in world_pairs:
            for g in self._geoms_of.get(self.bodies[bi].name, []):
                gm.addCollisionPair(pin.CollisionPair(g, self._obs_geoms[oi]))
        for i, j in self_pairs:
            for ga in self._geoms_of.get(self.bodies[i].name, []):
                for gb in self._geoms_of.get(self.bodies[j].name, []):
                    gm.addCollisionPair(pin.CollisionPair(ga, gb))

    def _full_exact_model(self):  # type: ignore[no-untyped-def]
        """Like the exact model, with the static pairs too (for queries, not hot paths)."""
        if self._full_exact is not None:
            return self._full_exact

        gm0 = self._exact_model()[0]
        gm = gm0.copy()
        gm.removeAllCollisionPairs()
        owner = {}
        for name, ids in self._geoms_of.items():
            for g in ids:
                owner[g] = name
        for oi, g in enumerate(self._obs_geoms):
            owner[g] = self.obstacles[oi].object_id
        self._geom_owner = owner
        self._add_pairs(
            gm, self.world_pairs + self.static_world_pairs, self.self_pairs + self.static_self_pairs
        )
        self._full_exact = (gm, exact_data(gm), self.robot.pin_model.createData(), None)
        return self._full_exact
