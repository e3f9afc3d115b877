"""Self-collision tables for link pairs whose relative pose depends on one to three joints.

A link and a link one or two revolute joints below it (the UR5's base and upper arm, forearm and
wrist 2, …) are close in most configurations, so the kernel's descent of their sphere trees is
its most expensive work: on the MotionBenchMaker UR5, base_link–upper_arm_link alone cost more
than all other pairs together. Their relative pose is a function of one or two angles, so the
answer can be tabulated once per robot: a grid over the angles (each 2π-periodic) whose cells
say FREE (no configuration in the cell collides), HIT (every one does) or CHECK (the kernel
decides, as without a table). A link against a rigid cluster three wrist joints below it (the
UR5's forearm against its hand: 12 pairs, a third of a free state's time) gets a table over
three angles, coarser (256 cells per angle).

A cell is decided at its centre with a margin: a point of the lower link moves, within the
cell, at most the angles' half-width times its distance from each joint's axis (bounded per
node of the link's sphere tree, from its centre and radius). The cell is FREE when every node
of the lower link's tree clears the upper link's distance field by its radius plus that margin,
and HIT when an inner sphere of one (inside the solid) overlaps one of the other by more than
the margin. Cells are refined from a coarse grid only where neither holds, and tables are cached
on disk.

Spheres and grids settle nothing where two links pass within a few mm of each other: the UR5's
wrist 2 skims its forearm over a wide band of wrist angles (7.4 % of that table, a third of
the kernel's time on the bookshelf problems). The finest cells left there are settled exactly
(two angles only; three would take too long to build): HIT when a connected piece of the
lower link's surface has a vertex inside the upper (closed) mesh and one outside, each
farther from its surface than it moves in the cell, so that the surfaces cross wherever in
the cell; FREE when coal finds the links farther apart than any point of the lower one moves.
That leaves 1.7 % of the forearm–wrist 2 table to the kernel, and all four UR5 tables' share
of it falls from 4.0 % to 1.6 %.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from robocell.kinematics._kernels import fk_into
from robocell.kinematics.fk import tree_args
from robocell.robot.model import REVOLUTE, RobotModel
from robocell.scene import _kernels as K
from robocell.scene.spheres import SPHERE_MODEL_VERSION, _cache_dir, _shape_key

TABLE_FREE, TABLE_HIT = K.TABLE_FREE, K.TABLE_HIT
TABLE_CHECK = 2
TABLE_VERSION = 5  # 2: distance grids exact to mesh surfaces; 5: cells settled exactly
CELLS = {1: 4096, 2: 1024, 3: 256}  # cells per axis of the finest grid, by number of angles
COARSE = 16  # cells per axis of the first grid
SLACK = 1e-6  # [m] added to every margin


Members = tuple[tuple[str, bytes], ...] | None


@dataclass
class PairTable:
    """FREE/HIT/CHECK over the angles of ``variables`` (indices into the robot's variable
    vector), each wrapped to [0, 2π) and split into ``n`` cells: ``values`` is (n ** dims,)
    row-major (first variable slow)."""

    variables: tuple[int, ...]
    n: int
    values: NDArray[np.uint8]

    @functools.cached_property
    def packed(self) -> NDArray[np.uint8]:
        """``values`` four cells to a byte, as the kernel reads them (K.pack_tables): packed
        once per table, however many checkers use it."""
        return K.pack_tables(self.values)

    def lookup(self, positions: NDArray[np.float64]) -> int:
        """The cell's value for a full variable vector (the kernel does the same)."""
        idx = 0
        for v in self.variables:
            x = positions[v] / (2 * math.pi)
            i = min(int((x - math.floor(x)) * self.n), self.n - 1)
            idx = idx * self.n + i
        return int(self.values[idx])


@dataclass
class Chain:
    """A pair's path: ``upper`` is an ancestor link of ``lower`` (link indices); ``joints``
    the moving joints between them, from upper to lower, and their ``variables``; ``fixed``
    the path's variables that do not move."""

    upper: int
    lower: int
    joints: tuple[int, ...]
    variables: tuple[int, ...]
    fixed: tuple[int, ...]  # the path's other variables (they keep their values)


def table_chain(
    robot: RobotModel, a: str, b: str, moving: set[int], max_joints: int = 2
) -> Chain | None:
    """The pair's chain if one link is an ancestor of the other and the path between them has
    one to ``max_joints`` (at most 3) moving revolute joints, each its own variable with
    |mult| 1 (the relative pose is then 2π-periodic in each); None otherwise. ``moving``: the
    variables the checker changes (the others keep their values)."""
    t = robot.tree
    ia, ib = robot.link_index(a), robot.link_index(b)
    parent_joint = {int(c): j for j, c in enumerate(t.child_link)}
    for upper, lower in ((ia, ib), (ib, ia)):
        path = []
        k = lower
        while k != upper and k in parent_joint:
            path.append(parent_joint[k])
            k = int(t.parent_link[parent_joint[k]])
        if k != upper:
            continue
        mov = [j for j in reversed(path) if t.var[j] >= 0 and int(t.var[j]) in moving]
        vs = tuple(int(t.var[j]) for j in mov)
        if not 1 <= len(mov) <= min(max_joints, 3) or len(set(vs)) != len(vs):
            return None
        if any(t.type[j] != REVOLUTE or abs(t.mult[j]) != 1.0 for j in mov):
            return None
        fixed = tuple(sorted({int(t.var[j]) for j in path if t.var[j] >= 0} - set(vs)))
        return Chain(upper, lower, tuple(mov), vs, fixed)
    return None


def _key(
    robot: RobotModel,
    chain: Chain,
    base: NDArray[np.float64],
    members: Members = None,
) -> str:
    """The table's cache key: the two links' shapes (or the upper link's and the members'
    with their poses), the path's joints and the values of the path's variables that stay
    put."""
    t = robot.tree
    dims = len(chain.variables)
    tag = f"pair table v{TABLE_VERSION} spheres v{SPHERE_MODEL_VERSION} {CELLS[dims]} {COARSE}"
    h = hashlib.sha1(tag.encode())
    names = t.link_names
    lower = {names[chain.lower]: b""} if members is None else dict(members)
    for g in robot.collision_geometry:
        if g.link == names[chain.upper] or g.link in lower:
            h.update(g.link.encode())
            h.update(lower.get(g.link, b""))
            h.update(_shape_key(g.shape))
            h.update(np.round(np.asarray(g.T_link_shape, float), 12).tobytes())
    parent_joint = {int(c): j for j, c in enumerate(t.child_link)}
    k = chain.lower
    while k != chain.upper:
        j = parent_joint[k]
        h.update(np.round(t.origin[j], 12).tobytes())
        h.update(np.round(t.axis[j], 12).tobytes())
        h.update(f"{t.type[j]} {t.var[j]} {t.mult[j]} {t.offset[j]} {j in chain.joints}".encode())
        k = int(t.parent_link[j])
    h.update(np.round(base[list(chain.fixed)], 12).tobytes())
    return h.hexdigest()


def pair_table(
    robot: RobotModel,
    chain: Chain,
    base: NDArray[np.float64],
    f: int,
    d: int,
    packed: Any,
    members: Members = None,
) -> PairTable:
    """The table of ``chain`` from the disk cache, or built on ``packed`` (the robot's packed
    bodies: ``f`` is the upper link's body, whose distance field is used, ``d`` the lower's).
    ``members``: when body d is a rigid cluster's union in the lower link's frame, its member
    links and their poses there (as bytes), for the cache key."""
    folder = _cache_dir()
    path = None if folder is None else folder / f"pair-{_key(robot, chain, base, members)}.npz"
    if path is not None and path.is_file():
        try:
            with np.load(path) as z:
                return PairTable(chain.variables, int(z["n"]), z["values"])
        except (OSError, KeyError, ValueError):
            pass  # a damaged cache entry is rebuilt
    table = _build(robot, chain, base, f, d, packed, exact=members is None)
    if path is not None:
        try:
            tmp = path.with_name(f"{path.stem}.{os.getpid()}.tmp.npz")
            np.savez_compressed(tmp, n=table.n, values=table.values)
            os.replace(tmp, path)
        except OSError:
            pass
    return table


def _reach(
    P: NDArray[np.float64], r: NDArray[np.float64], o: NDArray[np.float64], a: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The largest distance from the axis through o along unit a of the balls (P, r)."""
    v = P - o
    return np.linalg.norm(v - np.outer(v @ a, a), axis=1) + r


def _build(
    robot: RobotModel,
    chain: Chain,
    base: NDArray[np.float64],
    f: int,
    d: int,
    packed: Any,
    exact: bool = True,
) -> PairTable:
    """The table of body f (the upper link) against body d. ``exact``: settle the cells the
    spheres leave exactly (module doc); only for d a link (a cluster's union is several)."""
    args = tree_args(robot)
    t = robot.tree
    joints = args.joints_to(chain.upper, chain.lower)
    dims = len(chain.variables)
    q = base.astype(float).copy()
    for v in chain.variables:
        q[v] = 0.0
    T = np.empty((args.n_links, 4, 4))
    fk_into(q, args.all_joints, args.root, *args.arrays, T)
    # per sphere of the lower link, how far it moves per radian of each angle (module doc)
    lo = T[chain.lower]
    o = [T[int(t.child_link[j]), :3, 3] for j in chain.joints]
    a = [T[int(t.child_link[j]), :3, :3] @ t.axis[j] for j in chain.joints]
    a = [x / np.linalg.norm(x) for x in a]

    def rates(S: NDArray[np.float64]) -> NDArray[np.float64]:
        P = S[:, :3] @ lo[:3, :3].T + lo[:3, 3]
        total = _reach(P, S[:, 3], o[-1], a[-1])
        # about an earlier axis i: the distance of the next axis's origin from it (joint i
        # carries that origin rigidly), plus the path from there through the later axes'
        # origins to the ball, each leg a length the joints in between keep
        tail = np.linalg.norm(P - o[-1], axis=1) + S[:, 3]
        for i in range(dims - 2, -1, -1):
            v = o[i + 1] - o[i]
            total = total + np.linalg.norm(v - (v @ a[i]) * a[i]) + tail
            tail = tail + np.linalg.norm(v)
        return total

    node_rate = np.zeros(len(packed.nodes))
    n0 = int(packed.body_root[d])
    n1 = int(packed.body_root[d + 1]) if d + 1 < len(packed.body_root) else len(packed.nodes)
    node_rate[n0:n1] = rates(packed.nodes[n0:n1])
    i0, i1 = int(packed.inner_start[d]), int(packed.inner_start[d + 1])
    inner_rate = np.zeros(len(packed.inner))
    inner_rate[i0:i1] = rates(packed.inner[i0:i1]) if i1 > i0 else 0.0

    n_final = CELLS[dims]
    values = np.full((n_final,) * dims, TABLE_CHECK, np.uint8)
    variables = np.array(chain.variables, dtype=np.int64)
    n = COARSE
    cells = np.array(list(np.ndindex(*(n,) * dims)), dtype=np.int64)
    while len(cells):
        h = 2 * math.pi / n
        verdict = _cell_verdicts(  # type: ignore[call-arg]
            (cells + 0.5) * h,
            h / 2,
            variables,
            q,
            joints,
            args.root,
            *args.arrays,
            chain.upper,
            chain.lower,
            f,
            d,
            packed.body_root,
            packed.nodes,
            packed.left,
            packed.right,
            packed.inner_start,
            packed.inner,
            node_rate,
            inner_rate,
            packed.fields,
            T,
        )
        scale = n_final // n
        # the finest grid seen as blocks of scale^dims cells, one block per cell of this level
        blocks = values.reshape(sum(((n, scale) for _ in range(dims)), ())).transpose(
            *range(0, 2 * dims, 2), *range(1, 2 * dims, 2)
        )
        for v in (TABLE_FREE, TABLE_HIT):
            blocks[tuple((cells[verdict == v]).T)] = v
        if n == n_final:
            break
        refine = cells[verdict == TABLE_CHECK]
        sub = np.array(list(np.ndindex(*(2,) * dims)), dtype=np.int64)
        cells = (2 * refine[:, None, :] + sub[None, :, :]).reshape(-1, dims)
        n *= 2
    values = values.reshape(-1)
    check = np.flatnonzero(values == TABLE_CHECK)
    if len(check) and dims < 3 and exact:
        cells = np.array(np.unravel_index(check, (n_final,) * dims)).T
        centres = ((cells + 0.5) * (2 * math.pi / n_final)).astype(np.float64)
        half = math.pi / n_final
        mesh = _exact_meshes(packed, f, d)
        if mesh is not None:
            V, comp, n_comp, inside = mesh
            vrate = rates(np.c_[V, np.zeros(len(V))])
            fk_, go, gb, gh, gd, gf, gv = packed.fields[:7]
            size = int(np.prod(gd[f]))
            hit = _certain_hits(  # type: ignore[call-arg]
                centres, half, variables, q, joints, args.root, *args.arrays, chain.upper,
                chain.lower, T.shape[0], V, comp, n_comp, vrate, go[f], gh[f], gd[f],
                gv[gf[f] : gf[f] + size], inside, gb[f],
            )  # fmt: skip
            values[check[hit]] = TABLE_HIT
            check, centres = check[~hit], centres[~hit]
            moves = float(vrate.max())
        else:
            # the lower body's root sphere bounds how far any of its points moves
            moves = float(node_rate[n0])
        margin = moves * half + SLACK + K.EXACT_TOL
        free = _clear_by_coal(robot, chain, base, centres, margin)
        values[check[free]] = TABLE_FREE
    return PairTable(chain.variables, n_final, values)


def _body_triangles(packed: Any, b: int) -> NDArray[np.float64]:
    """(T, 3, 3): body b's triangles in its frame (empty unless it is all meshes)."""
    body_mesh, tri_start, tri_ids, tri_V, _ = packed.triangles
    if not body_mesh[b]:
        return np.zeros((0, 3, 3))
    n0 = int(packed.body_root[b])
    n1 = int(packed.body_root[b + 1]) if b + 1 < len(packed.body_root) else len(packed.nodes)
    ids = np.unique(tri_ids[tri_start[n0] : tri_start[n1]])
    return tri_V[ids]  # type: ignore[no-any-return]


def _merged(tris: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """(vertices, faces) of a triangle soup, vertices at the same point merged."""
    V, inv = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    return V, inv.reshape(-1, 3).astype(np.int64)


def _exact_meshes(
    packed: Any, f: int, d: int
) -> tuple[NDArray[np.float64], NDArray[np.int64], int, NDArray[np.uint8]] | None:
    """What :func:`_certain_hits` needs, or None when the pair does not allow it: body d's
    vertices, the connected piece of its surface each lies on and their number, and for each
    point of body f's grid whether it lies inside f (1), outside (0) or could not be told
    (2). Body f must be a closed mesh (every edge on exactly two triangles) with a grid."""
    if packed.fields[0][f] != K.FIELD_GRID:
        return None
    tf, td = _body_triangles(packed, f), _body_triangles(packed, d)
    if len(tf) == 0 or len(td) == 0:
        return None
    _, Ff = _merged(tf)
    edges = np.sort(np.concatenate([Ff[:, [0, 1]], Ff[:, [1, 2]], Ff[:, [2, 0]]]), axis=1)
    if np.any(np.unique(edges, axis=0, return_counts=True)[1] != 2):
        return None
    V, Fd = _merged(td)
    # connected pieces of d's surface: the components of its faces' edge graph
    rows, cols = Fd[:, [0, 1]].ravel(), Fd[:, [1, 2]].ravel()
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(V), len(V)))
    n, comp = connected_components(graph, directed=False)
    go, gh, gd = packed.fields[1][f], float(packed.fields[3][f]), packed.fields[4][f]
    # two rays per grid column, a hair apart: a point where they disagree is not used
    a = _inside_by_parity(go, gh, gd, tf, 1.2345e-4 * gh, 0.7654e-4 * gh)  # type: ignore[call-arg]
    b = _inside_by_parity(go, gh, gd, tf, -0.9876e-4 * gh, 1.3579e-4 * gh)  # type: ignore[call-arg]
    inside = np.where(a == b, a, 2).astype(np.uint8)
    return V, comp.astype(np.int64), int(n), inside


@njit(cache=True, parallel=True)
def _inside_by_parity(origin, h, dims, tris, ex, ey):  # type: ignore[no-untyped-def]
    """Per grid point (row-major, as the grid's values): 1 if it lies inside the closed mesh
    ``tris`` (an odd number of its triangles below it, along a vertical ray shifted by (ex,
    ey)), else 0."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    out = np.zeros(nx * ny * nz, np.uint8)
    for ij in prange(nx * ny):
        i = ij // ny
        j = ij % ny
        x = origin[0] + i * h + ex
        y = origin[1] + j * h + ey
        zs = np.empty(tris.shape[0])
        m = 0
        for t in range(tris.shape[0]):
            A, B, C = tris[t, 0], tris[t, 1], tris[t, 2]
            d0 = (B[0] - A[0]) * (y - A[1]) - (B[1] - A[1]) * (x - A[0])
            d1 = (C[0] - B[0]) * (y - B[1]) - (C[1] - B[1]) * (x - B[0])
            d2 = (A[0] - C[0]) * (y - C[1]) - (A[1] - C[1]) * (x - C[0])
            if not ((d0 > 0 and d1 > 0 and d2 > 0) or (d0 < 0 and d1 < 0 and d2 < 0)):
                continue
            s = d0 + d1 + d2  # twice the projected area: the weights are d1/s, d2/s, d0/s
            zs[m] = (d1 * A[2] + d2 * B[2] + d0 * C[2]) / s
            m += 1
        zs = np.sort(zs[:m])
        below = 0
        for k in range(nz):
            z = origin[2] + k * h
            while below < m and zs[below] < z:
                below += 1
            out[(i * ny + j) * nz + k] = below % 2
    return out


@njit(cache=True, parallel=True)
def _certain_hits(  # type: ignore[no-untyped-def]
    centres, half, variables, q_base, joints, root, parent, child, origin, jtype, axis, var,
    mult, offset, upper, lower, n_links, V, comp, n_comp, vrate, g_origin, g_h, g_dims,
    g_values, g_inside, g_box,
):  # fmt: skip
    """Per cell: whether the lower link's surface crosses the upper link's everywhere in it.
    So it does if one connected piece of the lower surface has a vertex inside the upper
    (closed) mesh and one outside, each farther from its surface than the vertex moves in the
    cell: a path on the piece between them crosses the surface wherever in the cell. A
    vertex's side is its nearest grid point's when the grid's distance there, less the way
    to the vertex, exceeds that; outside the box around the upper mesh is outside."""
    C = centres.shape[0]
    out = np.zeros(C, np.bool_)
    per = 64
    for chunk in prange((C + per - 1) // per):
        q = q_base.copy()
        T = np.empty((n_links, 4, 4))
        R = np.empty((3, 3))
        tv = np.empty(3)
        seen = np.zeros((n_comp, 2), np.bool_)
        for c in range(chunk * per, min(C, (chunk + 1) * per)):
            _cell_pose(
                centres[c], variables, q, joints, root, parent, child, origin, jtype, axis,
                var, mult, offset, T, upper, lower, R, tv,
            )  # fmt: skip
            seen[:] = False
            for v in range(V.shape[0]):
                x = R[0, 0] * V[v, 0] + R[0, 1] * V[v, 1] + R[0, 2] * V[v, 2] + tv[0]
                y = R[1, 0] * V[v, 0] + R[1, 1] * V[v, 1] + R[1, 2] * V[v, 2] + tv[1]
                z = R[2, 0] * V[v, 0] + R[2, 1] * V[v, 1] + R[2, 2] * V[v, 2] + tv[2]
                m = vrate[v] * half + SLACK
                ex = max(g_box[0, 0] - x, x - g_box[1, 0], 0.0)
                ey = max(g_box[0, 1] - y, y - g_box[1, 1], 0.0)
                ez = max(g_box[0, 2] - z, z - g_box[1, 2], 0.0)
                if ex * ex + ey * ey + ez * ez > m * m:
                    side = 0
                else:
                    i = int(min(max((x - g_origin[0]) / g_h, 0.0), g_dims[0] - 1.0) + 0.5)
                    j = int(min(max((y - g_origin[1]) / g_h, 0.0), g_dims[1] - 1.0) + 0.5)
                    k = int(min(max((z - g_origin[2]) / g_h, 0.0), g_dims[2] - 1.0) + 0.5)
                    gx = x - (g_origin[0] + i * g_h)
                    gy = y - (g_origin[1] + j * g_h)
                    gz = z - (g_origin[2] + k * g_h)
                    idx = (i * g_dims[1] + j) * g_dims[2] + k
                    if g_values[idx] - math.sqrt(gx * gx + gy * gy + gz * gz) <= m:
                        continue
                    side = g_inside[idx]
                    if side > 1:
                        continue
                seen[comp[v], side] = True
                if seen[comp[v], 0] and seen[comp[v], 1]:
                    out[c] = True
                    break
    return out


def _clear_by_coal(
    robot: RobotModel,
    chain: Chain,
    base: NDArray[np.float64],
    centres: NDArray[np.float64],
    margin: float,
) -> NDArray[np.bool_]:
    """Per cell centre: whether coal finds the two links' geometries farther apart than
    ``margin`` (the most a point of the lower link moves in the cell), so that the cell is
    free everywhere. Batched over the centres in pinocchio's thread pool."""
    import pinocchio as pin

    names = robot.tree.link_names
    up, lo = names[chain.upper], names[chain.lower]
    gm = robot.pin_collision_model.copy()
    gm.removeAllCollisionPairs()
    ga = [i for i, g in enumerate(robot.collision_geometry) if g.link == up]
    gb = [i for i, g in enumerate(robot.collision_geometry) if g.link == lo]
    if not ga or not gb or len(centres) == 0:
        return np.zeros(len(centres), dtype=bool)
    for i in ga:
        for j in gb:
            gm.addCollisionPair(pin.CollisionPair(i, j))
    threads = max(1, min(os.cpu_count() or 1, 8))
    pool = pin.GeometryPool(robot.pin_model, gm, threads)
    for gd in pool.getGeometryDatas():
        for req in gd.collisionRequests:
            req.security_margin = margin
            req.enable_contact = True  # see checker.exact_data
    full = np.tile(base.astype(float), (len(centres), 1))
    full[:, list(chain.variables)] = centres
    Q = np.asfortranarray(robot.pin_configurations(full).T)
    hit = np.asarray(pin.computeCollisionsInParallel(threads, pool, Q, True), dtype=bool)
    return ~hit


@njit(cache=True, inline="always")
def _cell_pose(  # type: ignore[no-untyped-def]
    angles, variables, q, joints, root, parent, child, origin, jtype, axis, var, mult, offset,
    T, upper, lower, R, tv,
):  # fmt: skip
    """The lower link's frame in the upper's at ``angles`` of ``variables`` (q holds the rest):
    R = Ru^T Rl, tv = Ru^T (tl - tu), into R and tv (T: scratch for the link poses)."""
    for k in range(variables.shape[0]):
        q[variables[k]] = angles[k]
    fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
    U = T[upper]
    L = T[lower]
    for i in range(3):
        for j in range(3):
            R[i, j] = U[0, i] * L[0, j] + U[1, i] * L[1, j] + U[2, i] * L[2, j]
        tv[i] = (
            U[0, i] * (L[0, 3] - U[0, 3])
            + U[1, i] * (L[1, 3] - U[1, 3])
            + U[2, i] * (L[2, 3] - U[2, 3])
        )


@njit(cache=True, parallel=True)
def _cell_verdicts(  # type: ignore[no-untyped-def]
    centres,
    half,
    variables,
    q_base,
    joints,
    root,
    parent,
    child,
    origin,
    jtype,
    axis,
    var,
    mult,
    offset,
    upper,
    lower,
    f,
    d,
    body_root,
    nodes,
    left,
    right,
    inner_start,
    inner,
    node_rate,
    inner_rate,
    fields,
    T,
):
    """TABLE_FREE/HIT/CHECK for cells of half-width ``half`` [rad] around ``centres``
    (C, dims): body d (lower link) against body f (upper link)'s distance field; ``fields``
    as :func:`robocell.scene.checker._pack_fields` makes them."""
    C = centres.shape[0]
    out = np.empty(C, np.uint8)
    per = 256
    for chunk in prange((C + per - 1) // per):
        _cell_chunk(
            chunk * per, min(C, (chunk + 1) * per), out, centres, half, variables, q_base,
            joints, root, parent, child, origin, jtype, axis, var, mult, offset, upper, lower,
            f, d, body_root, nodes, left, right, inner_start, inner, node_rate, inner_rate,
            fields, T.shape[0],
        )  # fmt: skip
    return out


@njit(cache=True)
def _cell_chunk(
    c0, c1, out, centres, half, variables, q_base, joints, root, parent, child, origin, jtype,
    axis, var, mult, offset, upper, lower, f, d, body_root, nodes, left, right, inner_start,
    inner, node_rate, inner_rate, fields, n_links,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """:func:`_cell_verdicts` of cells c0 … c1 − 1, into ``out``."""
    fk, go, gb, gh, gd, gf, gv, ps, pk, pt, pd = fields  # as K._field_bound takes them
    q = q_base.copy()
    T = np.empty((n_links, 4, 4))
    stack = np.empty(256, np.int64)
    R = np.empty((3, 3))
    tv = np.empty(3)
    for c in range(c0, c1):
        _cell_pose(
            centres[c], variables, q, joints, root, parent, child, origin, jtype, axis, var,
            mult, offset, T, upper, lower, R, tv,
        )  # fmt: skip
        verdict = TABLE_FREE
        # HIT: inner spheres overlapping by more than the margin
        for s in range(inner_start[d], inner_start[d + 1]):
            x = R[0, 0] * inner[s, 0] + R[0, 1] * inner[s, 1] + R[0, 2] * inner[s, 2] + tv[0]
            y = R[1, 0] * inner[s, 0] + R[1, 1] * inner[s, 1] + R[1, 2] * inner[s, 2] + tv[1]
            z = R[2, 0] * inner[s, 0] + R[2, 1] * inner[s, 1] + R[2, 2] * inner[s, 2] + tv[2]
            for u in range(inner_start[f], inner_start[f + 1]):
                dx, dy, dz = x - inner[u, 0], y - inner[u, 1], z - inner[u, 2]
                depth = inner[s, 3] + inner[u, 3] - math.sqrt(dx * dx + dy * dy + dz * dz)
                if depth > inner_rate[s] * half + SLACK:
                    verdict = TABLE_HIT
                    break
            if verdict == TABLE_HIT:
                break
        if verdict == TABLE_HIT:
            out[c] = verdict
            continue
        # FREE: every node of d's tree clears f's field by its radius plus its margin
        sp = 1
        stack[0] = body_root[d]
        while sp > 0:
            sp -= 1
            n = stack[sp]
            x = R[0, 0] * nodes[n, 0] + R[0, 1] * nodes[n, 1] + R[0, 2] * nodes[n, 2] + tv[0]
            y = R[1, 0] * nodes[n, 0] + R[1, 1] * nodes[n, 1] + R[1, 2] * nodes[n, 2] + tv[1]
            z = R[2, 0] * nodes[n, 0] + R[2, 1] * nodes[n, 1] + R[2, 2] * nodes[n, 2] + tv[2]
            b = K._field_bound(x, y, z, f, fk, go, gb, gh, gd, gf, gv, ps, pk, pt, pd)
            if b > nodes[n, 3] + node_rate[n] * half + SLACK:
                continue
            if left[n] < 0:
                verdict = TABLE_CHECK
                break
            stack[sp] = left[n]
            stack[sp + 1] = right[n]
            sp += 2
        out[c] = verdict
