"""Compiled collision kernels over sphere trees (see :mod:`robocell.scene.spheres`).

Per state and pair:
- a link against a world primitive: the link's tree against the primitive's exact distance;
- two bodies: one's tree against the other's distance field (a grid of lower bounds for a mesh,
  exact distances for primitives), or both trees when neither has a field;
- no leaf touches: FREE for certain; an inner sphere touches: HIT for certain;
- leaves touch: the pieces under them are tested exactly (primitives by GJK, mesh triangles
  against boxes by the separating-axis test, against the rest by GJK), within a budget per pair.

A state is FREE, HIT, or UNSURE when a pair is left undecided (its flag is set): the caller
settles those pairs with coal. Node centres are moved to the world lazily, once per state (a
stamp marks those done).
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.core import cgutils
from numba.experimental import structref
from numba.extending import intrinsic
from numba.typed import List
from numpy.typing import NDArray

from robocell.kinematics._kernels import block_lanes, fk_block, fk_into

FREE, HIT, UNSURE = 0, 1, 2
UNCHECKED = 3  # a state a scan stopped before
# scratch slots after the kernel's threads', for the planner's searches that run without the
# GIL (robocell.planning.rrt): no other kernel call touches them. The kernel's threads are the
# scratch's other slots (numba's thread count, read in compiled code, would keep it from
# numba's cache)
SEARCH_SLOTS = 2
# states whose bodies are placed at once (fk_block): 16 placed a Panda's state in 39 ns, 8 in
# 52, 32 in 35 (session 28, measured); a block's link and body poses then take 37 kB
BLOCK = 16
OBS_BOX, OBS_CYLINDER, OBS_SPHERE = 0, 1, 2
# a triangle in the exact test: its "pose" (3×4) holds the vertices as columns 0–2 and the
# centroid as column 3
OBS_TRIANGLE = 3
# numba's reference counting (its CPU target's option ``_nrt``, which its type stubs lack), on
# or off: see _classify_range
NRT_ON: dict[str, Any] = {"_nrt": True}
NRT_OFF: dict[str, Any] = {"_nrt": False}


@njit(cache=True, inline="always")
def _in_frame(x, y, z, T):  # type: ignore[no-untyped-def]
    """Point (x, y, z) in the frame of pose T (3×4 or 4×4, rotation and translation)."""
    dx, dy, dz = x - T[0, 3], y - T[1, 3], z - T[2, 3]
    return (
        T[0, 0] * dx + T[1, 0] * dy + T[2, 0] * dz,
        T[0, 1] * dx + T[1, 1] * dy + T[2, 1] * dz,
        T[0, 2] * dx + T[1, 2] * dy + T[2, 2] * dz,
    )


@njit(cache=True, inline="always")
def _obstacle_distance(x, y, z, kind, T, dims):  # type: ignore[no-untyped-def]
    """Distance from point (x, y, z) to a solid primitive at T (0 inside)."""
    lx, ly, lz = _in_frame(x, y, z, T)
    if kind == OBS_BOX:
        ex = max(abs(lx) - dims[0], 0.0)
        ey = max(abs(ly) - dims[1], 0.0)
        ez = max(abs(lz) - dims[2], 0.0)
        return math.sqrt(ex * ex + ey * ey + ez * ez)
    if kind == OBS_CYLINDER:
        er = max(math.sqrt(lx * lx + ly * ly) - dims[0], 0.0)
        ez = max(abs(lz) - dims[1], 0.0)
        return math.sqrt(er * er + ez * ez)
    return max(math.sqrt(lx * lx + ly * ly + lz * lz) - dims[0], 0.0)


@njit(cache=True, inline="always")
def _obstacle_clear(x, y, z, r, kind, T, dims):  # type: ignore[no-untyped-def]
    """Whether the sphere (x, y, z, r) is clear of a solid primitive at T:
    ``_obstacle_distance(...) > r`` with squares compared (one square root fewer for a box or
    a cylinder, none for a sphere: a sphere tree's descent asks this of every node)."""
    lx, ly, lz = _in_frame(x, y, z, T)
    if kind == OBS_BOX:
        ex = max(abs(lx) - dims[0], 0.0)
        ey = max(abs(ly) - dims[1], 0.0)
        ez = max(abs(lz) - dims[2], 0.0)
        return ex * ex + ey * ey + ez * ez > r * r
    if kind == OBS_CYLINDER:
        er = max(math.sqrt(lx * lx + ly * ly) - dims[0], 0.0)
        ez = max(abs(lz) - dims[1], 0.0)
        return er * er + ez * ez > r * r
    s = dims[0] + r
    return lx * lx + ly * ly + lz * lz > s * s


@njit(cache=True, inline="always")
def _centre(n, b, TB, S, W, stamp, cur):  # type: ignore[no-untyped-def]
    """World centre of sphere n of body b (cached for the current state). The stamps' last
    entry counts the centres placed: a measure of the kernel's work (see ``work``)."""
    if stamp[n] != cur:
        x, y, z = S[n, 0], S[n, 1], S[n, 2]
        for i in range(3):
            W[n, i] = TB[b, i, 0] * x + TB[b, i, 1] * y + TB[b, i, 2] * z + TB[b, i, 3]
        stamp[n] = cur
        stamp[-1] += 1


@njit(cache=True, inline="always")
def _obstacle_reach(o, obs_kind, obs_T, obs_dims, frame, dims, cap):  # type: ignore[no-untyped-def]
    """The index ranges (i0, i1, j0, j1, k0, k1, inclusive) of the grid points within ``cap``
    of obstacle o's bounding box: the only points it can bring nearer than cap."""
    T, d = obs_T[o], obs_dims[o]
    ox, oy, oz, h = frame[0], frame[1], frame[2], frame[3]
    e = np.empty(3)
    for i in range(3):  # the half extents of the obstacle's box in the grid's axes
        if obs_kind[o] == OBS_BOX:
            e[i] = abs(T[i, 0]) * d[0] + abs(T[i, 1]) * d[1] + abs(T[i, 2]) * d[2]
        elif obs_kind[o] == OBS_CYLINDER:
            e[i] = abs(T[i, 2]) * d[1] + d[0] * math.sqrt(max(0.0, 1.0 - T[i, 2] ** 2))
        else:
            e[i] = d[0]
    return (
        max(0, int(math.floor((T[0, 3] - e[0] - cap - ox) / h))),
        min(dims[0] - 1, int(math.ceil((T[0, 3] + e[0] + cap - ox) / h))),
        max(0, int(math.floor((T[1, 3] - e[1] - cap - oy) / h))),
        min(dims[1] - 1, int(math.ceil((T[1, 3] + e[1] + cap - oy) / h))),
        max(0, int(math.floor((T[2, 3] - e[2] - cap - oz) / h))),
        min(dims[2] - 1, int(math.ceil((T[2, 3] + e[2] + cap - oz) / h))),
    )


@njit(cache=True, inline="always")
def _lowered(v):  # type: ignore[no-untyped-def]
    """A distance as the grid keeps it: lowered a little, so that float32 keeps it a lower
    bound. Monotone: the grid's value of a minimum is the minimum of the values."""
    return np.float32(max(0.0, v * (1.0 - 1e-6) - 1e-6))


@njit(cache=True)
def world_distance_grid(obs_kind, obs_T, obs_dims, frame, dims, cap):  # type: ignore[no-untyped-def]
    """The values of the world's distance grid (see :func:`_world_clear`): at each grid point
    (flat, x slowest), the distance to the nearest obstacle, or ``cap`` where every obstacle is
    farther (or at least as far) than that (:func:`_lowered`). ``frame``: origin (3),
    spacing, and the obstacles' bounding box (lo 3, hi 3)."""
    values = np.full(dims[0] * dims[1] * dims[2], _lowered(cap))
    for o in range(obs_kind.shape[0]):
        i0, i1, j0, j1, k0, k1 = _obstacle_reach(o, obs_kind, obs_T, obs_dims, frame, dims, cap)
        _lower_into(values, o, obs_kind, obs_T, obs_dims, frame, dims, i0, i1, j0, j1, k0, k1)
    return values


@njit(cache=True, inline="always")
def _lower_into(values, o, obs_kind, obs_T, obs_dims, frame, dims, i0, i1, j0, j1, k0, k1):  # type: ignore[no-untyped-def]
    """values = min(values, obstacle o's distance) over the index ranges given."""
    ny, nz = dims[1], dims[2]
    ox, oy, oz, h = frame[0], frame[1], frame[2], frame[3]
    kind, T, d = obs_kind[o], obs_T[o], obs_dims[o]
    for i in range(i0, i1 + 1):
        x = ox + i * h
        for j in range(j0, j1 + 1):
            y = oy + j * h
            row = (i * ny + j) * nz
            for k in range(k0, k1 + 1):
                v = _lowered(_obstacle_distance(x, y, oz + k * h, kind, T, d))
                if v < values[row + k]:
                    values[row + k] = v


@njit(cache=True)
def world_distance_patch(values, obs_kind, obs_T, obs_dims, frame, dims, cap, gone, added):  # type: ignore[no-untyped-def]
    """The grid ``values`` of another world with this frame, changed in place into this
    world's (obs_*): the same values, to the bit, as :func:`world_distance_grid` would give.
    ``gone`` (kind, T, dims of the obstacles the other world had and this one has not): the
    points within their reach are computed again from this world's obstacles; ``added``
    (indices into obs_*, obstacles the other world had not): taken in where they reach.
    Outside a gone obstacle's reach its distance never counted (the grid keeps the nearest,
    and cap beyond reach)."""
    gone_kind, gone_T, gone_dims = gone
    cap32 = _lowered(cap)
    for g in range(gone_kind.shape[0]):
        i0, i1, j0, j1, k0, k1 = _obstacle_reach(g, gone_kind, gone_T, gone_dims, frame, dims, cap)
        ny, nz = dims[1], dims[2]
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                row = (i * ny + j) * nz
                for k in range(k0, k1 + 1):
                    values[row + k] = cap32
        for o in range(obs_kind.shape[0]):
            a0, a1, b0, b1, c0, c1 = _obstacle_reach(o, obs_kind, obs_T, obs_dims, frame, dims, cap)
            _lower_into(
                values, o, obs_kind, obs_T, obs_dims, frame, dims, max(a0, i0), min(a1, i1),
                max(b0, j0), min(b1, j1), max(c0, k0), min(c1, k1),
            )  # fmt: skip
    for o in added:
        i0, i1, j0, j1, k0, k1 = _obstacle_reach(o, obs_kind, obs_T, obs_dims, frame, dims, cap)
        _lower_into(values, o, obs_kind, obs_T, obs_dims, frame, dims, i0, i1, j0, j1, k0, k1)


@njit(cache=True, inline="always")
def _world_clear(x, y, z, r, frame, dims, values):  # type: ignore[no-untyped-def]
    """Whether the sphere (x, y, z, r) is clear of every obstacle of the world, by a lower
    bound on its centre's distance to them: the distance to the obstacles' bounding box, or
    the value at the nearest grid point less the distance to it (a distance field changes no
    faster than the point moves). One lookup for a body instead of a test per obstacle.
    ``frame``: origin (3), spacing h, the obstacles' box (lo 3, hi 3), 1 / h."""
    ex = max(frame[4] - x, x - frame[7], 0.0)
    ey = max(frame[5] - y, y - frame[8], 0.0)
    ez = max(frame[6] - z, z - frame[9], 0.0)
    if ex * ex + ey * ey + ez * ez > r * r:
        return True
    h, inv_h = frame[3], frame[10]
    i = min(max(int((x - frame[0]) * inv_h + 0.5), 0), dims[0] - 1)
    j = min(max(int((y - frame[1]) * inv_h + 0.5), 0), dims[1] - 1)
    k = min(max(int((z - frame[2]) * inv_h + 0.5), 0), dims[2] - 1)
    dx = x - (frame[0] + i * h)
    dy = y - (frame[1] + j * h)
    dz = z - (frame[2] + k * h)
    # value − |offset| > r, without a division or a square root (any grid point bounds it)
    a = values[(i * dims[1] + j) * dims[2] + k] - r
    return a > 0.0 and a * a > dx * dx + dy * dy + dz * dz


@njit(cache=True, inline="always")
def _body_clear(b, TB, nodes, body_root, W, stamp, cur, mark, frame, dims, values):  # type: ignore[no-untyped-def]
    """:func:`_world_clear` for body b's bounding sphere, once per state: ``mark[b]`` holds
    the state's stamp ``cur`` if it is clear, −cur − 2 if not (−1: not yet asked)."""
    m = mark[b]
    if m == cur:
        return True
    if m == -cur - 2:
        return False
    r0 = body_root[b]
    _centre(r0, b, TB, nodes, W, stamp, cur)
    clear = _world_clear(W[r0, 0], W[r0, 1], W[r0, 2], nodes[r0, 3], frame, dims, values)
    mark[b] = cur if clear else -cur - 2
    return clear


@njit(cache=True)
def _tree_touches_obstacle(b, root, nodes, left, right, TB, W, stamp, cur, kind, To, dims, stack):  # type: ignore[no-untyped-def]
    sp = 1
    stack[0] = root
    while sp > 0:
        sp -= 1
        n = stack[sp]
        _centre(n, b, TB, nodes, W, stamp, cur)
        if _obstacle_clear(W[n, 0], W[n, 1], W[n, 2], nodes[n, 3], kind, To, dims):
            continue
        if left[n] < 0:
            return True
        stack[sp] = left[n]
        stack[sp + 1] = right[n]
        sp += 2
    return False


MAX_VISITS = 4000  # node pairs one descent may test before it hands the pair to the exact check


@njit(cache=True)
def _trees_touch(a, b, ra, rb, nodes, left, right, TB, W, stamp, cur, stack):  # type: ignore[no-untyped-def]
    """Whether any leaf of a's tree touches any leaf of b's (True also when the descent runs
    past MAX_VISITS: the caller then treats the pair as unsure, never as free)."""
    sp = 1
    visits = 0
    stack[0, 0] = ra
    stack[0, 1] = rb
    while sp > 0:
        sp -= 1
        visits += 1
        if visits > MAX_VISITS or sp >= stack.shape[0] - 2:
            return True
        i = stack[sp, 0]
        j = stack[sp, 1]
        _centre(i, a, TB, nodes, W, stamp, cur)
        _centre(j, b, TB, nodes, W, stamp, cur)
        dx = W[i, 0] - W[j, 0]
        dy = W[i, 1] - W[j, 1]
        dz = W[i, 2] - W[j, 2]
        rr = nodes[i, 3] + nodes[j, 3]
        if dx * dx + dy * dy + dz * dz > rr * rr:
            continue
        leaf_i = left[i] < 0
        leaf_j = left[j] < 0
        if leaf_i and leaf_j:
            return True
        if leaf_i or (not leaf_j and nodes[j, 3] > nodes[i, 3]):
            stack[sp, 0] = i
            stack[sp, 1] = left[j]
            stack[sp + 1, 0] = i
            stack[sp + 1, 1] = right[j]
        else:
            stack[sp, 0] = left[i]
            stack[sp, 1] = j
            stack[sp + 1, 0] = right[i]
            stack[sp + 1, 1] = j
        sp += 2
    return False


FIELD_NONE, FIELD_GRID, FIELD_PRIMITIVES = 0, 1, 2


# ---------------------------------------------------------------------------------- exact
# Solid primitives against solid primitives: a boolean GJK on the Minkowski difference
# (Gilbert, Johnson & Keerthi 1988; the simplex cases as in Ericson, ch. 9). One shape is grown
# by EXACT_TOL, so "touching" means closer than that: a pair it calls free is free by at least
# EXACT_TOL (coal's verdict cannot differ there); a pair it cannot settle in GJK_ITERATIONS
# is left to coal.
EXACT_TOL = 1e-6
GJK_ITERATIONS = 64
GJK_FREE, GJK_HIT, GJK_UNSURE = 0, 1, 2


@njit(cache=True, inline="always")
def _support(kind, T, dims, dx, dy, dz, out, sign):  # type: ignore[no-untyped-def]
    """out += sign · the point of primitive (kind, T (≥3×4), dims) farthest along sign·d."""
    dx, dy, dz = sign * dx, sign * dy, sign * dz
    if kind == OBS_TRIANGLE:
        best, k = -np.inf, 0
        for c in range(3):
            v = T[0, c] * dx + T[1, c] * dy + T[2, c] * dz
            if v > best:
                best, k = v, c
        for i in range(3):
            out[i] += sign * T[i, k]
        return
    lx = T[0, 0] * dx + T[1, 0] * dy + T[2, 0] * dz
    ly = T[0, 1] * dx + T[1, 1] * dy + T[2, 1] * dz
    lz = T[0, 2] * dx + T[1, 2] * dy + T[2, 2] * dz
    if kind == OBS_BOX:
        sx = dims[0] if lx >= 0.0 else -dims[0]
        sy = dims[1] if ly >= 0.0 else -dims[1]
        sz = dims[2] if lz >= 0.0 else -dims[2]
    elif kind == OBS_CYLINDER:
        rxy = math.sqrt(lx * lx + ly * ly)
        if rxy > 1e-300:
            sx, sy = dims[0] * lx / rxy, dims[0] * ly / rxy
        else:
            sx, sy = 0.0, 0.0
        sz = dims[1] if lz >= 0.0 else -dims[1]
    else:
        n = math.sqrt(lx * lx + ly * ly + lz * lz)
        if n > 1e-300:
            sx, sy, sz = dims[0] * lx / n, dims[0] * ly / n, dims[0] * lz / n
        else:
            sx, sy, sz = dims[0], 0.0, 0.0
    for i in range(3):
        out[i] += sign * (T[i, 0] * sx + T[i, 1] * sy + T[i, 2] * sz + T[i, 3])


@njit(cache=True, inline="always")
def _minkowski(ka, Ta, da, kb, Tb, db, d, out, margin):  # type: ignore[no-untyped-def]
    """Support of (A grown by ``margin``) − B along d."""
    out[0] = out[1] = out[2] = 0.0
    _support(ka, Ta, da, d[0], d[1], d[2], out, 1.0)
    _support(kb, Tb, db, d[0], d[1], d[2], out, -1.0)
    n = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    for i in range(3):
        out[i] += margin * d[i] / n


@njit(cache=True, inline="always")
def _cross(a, b, out):  # type: ignore[no-untyped-def]
    x = a[1] * b[2] - a[2] * b[1]
    y = a[2] * b[0] - a[0] * b[2]
    z = a[0] * b[1] - a[1] * b[0]
    out[0], out[1], out[2] = x, y, z


@njit(cache=True, inline="always")
def _dot(a, b):  # type: ignore[no-untyped-def]
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, **NRT_ON)  # allocates: counts references even when _classify_range calls it
def gjk_intersect(ka, Ta, da, kb, Tb, db):  # type: ignore[no-untyped-def]
    """GJK_HIT if solid primitives A and B are closer than EXACT_TOL, GJK_FREE if not,
    GJK_UNSURE if the iterations run out."""
    return gjk_within(ka, Ta, da, kb, Tb, db, EXACT_TOL)


@njit(cache=True, **NRT_ON)  # allocates: counts references even when _classify_range calls it
def gjk_within(ka, Ta, da, kb, Tb, db, margin):  # type: ignore[no-untyped-def]
    """GJK_HIT if solid primitives A and B are closer than ``margin`` [m] (> 0), GJK_FREE if
    not, GJK_UNSURE if the iterations run out."""
    S = np.empty((4, 3))  # simplex, newest point last
    d = np.empty(3)
    a = np.empty(3)
    ab = np.empty(3)
    ac = np.empty(3)
    ad = np.empty(3)
    ao = np.empty(3)
    n1 = np.empty(3)
    n2 = np.empty(3)
    for i in range(3):
        d[i] = Tb[i, 3] - Ta[i, 3]
    if _dot(d, d) < 1e-24:
        d[0], d[1], d[2] = 1.0, 0.0, 0.0
    _minkowski(ka, Ta, da, kb, Tb, db, d, a, margin)
    S[0] = a
    n = 1
    d[0], d[1], d[2] = -a[0], -a[1], -a[2]
    for _ in range(GJK_ITERATIONS):
        if _dot(d, d) < 1e-30:
            return GJK_HIT  # the origin is on the simplex
        _minkowski(ka, Ta, da, kb, Tb, db, d, a, margin)
        if _dot(a, d) < 0.0:
            return GJK_FREE  # a separating direction
        S[n] = a
        n += 1
        # the simplex's feature nearest the origin, and the direction from it to the origin
        while True:
            A = S[n - 1]
            ao[0], ao[1], ao[2] = -A[0], -A[1], -A[2]
            if n == 2:
                B = S[0]
                for i in range(3):
                    ab[i] = B[i] - A[i]
                if _dot(ab, ao) > 0.0:
                    _cross(ab, ao, n1)
                    _cross(n1, ab, d)
                else:
                    S[0] = A
                    n = 1
                    d[0], d[1], d[2] = ao[0], ao[1], ao[2]
                break
            if n == 3:
                B, C = S[1], S[0]
                for i in range(3):
                    ab[i] = B[i] - A[i]
                    ac[i] = C[i] - A[i]
                _cross(ab, ac, n1)  # the triangle's normal
                _cross(n1, ac, n2)
                if _dot(n2, ao) > 0.0:
                    if _dot(ac, ao) > 0.0:
                        # edge AC
                        S[1] = A
                        n = 2
                        _cross(ac, ao, n2)
                        _cross(n2, ac, d)
                        break
                    # edge AB (or A)
                    S[0] = S[1]
                    S[1] = A
                    n = 2
                    continue
                _cross(ab, n1, n2)
                if _dot(n2, ao) > 0.0:
                    S[0] = S[1]
                    S[1] = A
                    n = 2
                    continue
                if _dot(n1, ao) > 0.0:
                    d[0], d[1], d[2] = n1[0], n1[1], n1[2]
                else:
                    # the origin is below: wind the triangle the other way
                    tmp0, tmp1, tmp2 = S[0, 0], S[0, 1], S[0, 2]
                    S[0] = S[1]
                    S[1, 0], S[1, 1], S[1, 2] = tmp0, tmp1, tmp2
                    d[0], d[1], d[2] = -n1[0], -n1[1], -n1[2]
                break
            # n == 4: tetrahedron D C B A (S[0], S[1], S[2], A)
            B, C, D = S[2], S[1], S[0]
            for i in range(3):
                ab[i] = B[i] - A[i]
                ac[i] = C[i] - A[i]
                ad[i] = D[i] - A[i]
            _cross(ab, ac, n1)
            if _dot(n1, ao) > 0.0:
                # face ABC: keep C, B, A
                S[0] = S[1]
                S[1] = S[2]
                S[2] = A
                n = 3
                continue
            _cross(ac, ad, n1)
            if _dot(n1, ao) > 0.0:
                # face ACD: keep D, C, A
                S[2] = A
                n = 3
                continue
            _cross(ad, ab, n1)
            if _dot(n1, ao) > 0.0:
                # face ADB: keep B, D, A
                S[1] = S[0]
                S[0] = S[2]
                S[2] = A
                n = 3
                continue
            return GJK_HIT  # the origin is inside the tetrahedron
    return GJK_UNSURE


@njit(cache=True, inline="always")
def _placed(TB, b, P, out):  # type: ignore[no-untyped-def]
    """out (3×4) = TB[b] (3×4) · P (4×4)."""
    for i in range(3):
        for j in range(4):
            out[i, j] = TB[b, i, 0] * P[0, j] + TB[b, i, 1] * P[1, j] + TB[b, i, 2] * P[2, j]
        out[i, 3] += TB[b, i, 3]


@njit(cache=True, **NRT_ON)  # allocates: counts references even when _classify_range calls it
def _exact_world(b, kind, To, dims, TB, prim_start, prim_kind, prim_T, prim_dims):  # type: ignore[no-untyped-def]
    """GJK over body b's primitives against one solid obstacle primitive."""
    Tp = np.empty((3, 4))
    unsure = False
    for p in range(prim_start[b], prim_start[b + 1]):
        _placed(TB, b, prim_T[p], Tp)
        r = gjk_intersect(prim_kind[p], Tp, prim_dims[p], kind, To, dims)
        if r == GJK_HIT:
            return GJK_HIT
        if r == GJK_UNSURE:
            unsure = True
    return GJK_UNSURE if unsure else GJK_FREE


@njit(cache=True, **NRT_ON)  # allocates: counts references even when _classify_range calls it
def _exact_self(a, b, TB, prim_start, prim_kind, prim_T, prim_dims):  # type: ignore[no-untyped-def]
    """GJK over the primitives of bodies a and b."""
    Ta = np.empty((3, 4))
    Tb = np.empty((3, 4))
    unsure = False
    for p in range(prim_start[a], prim_start[a + 1]):
        _placed(TB, a, prim_T[p], Ta)
        for q in range(prim_start[b], prim_start[b + 1]):
            _placed(TB, b, prim_T[q], Tb)
            r = gjk_intersect(prim_kind[p], Ta, prim_dims[p], prim_kind[q], Tb, prim_dims[q])
            if r == GJK_HIT:
                return GJK_HIT
            if r == GJK_UNSURE:
                unsure = True
    return GJK_UNSURE if unsure else GJK_FREE


GJK_COST = 8  # what one GJK costs in triangle–box or triangle–triangle tests (the budget's unit)
EXACT_BUDGET = 8192  # triangle tests one pair may make before it is left to coal
PAIR_TAGS = 1 << 16  # more than any checker's pairs: a (state, pair) tag is cur * PAIR_TAGS + pair
TOUCH = 3  # a pair's leaves touch and the kernel cannot settle it (the caller decides)


@njit(cache=True, **NRT_ON)  # allocates: counts references even when _classify_range calls it
def triangle_box_overlap(tri, T, half):  # type: ignore[no-untyped-def]
    """Whether triangle ``tri`` (3×4: vertices as columns 0–2) meets the solid box at T (≥3×4)
    with half extents ``half`` grown by EXACT_TOL: the separating-axis test of
    Akenine-Möller (2001), 13 axes; several times cheaper than GJK on the same pair."""
    p = np.empty((3, 3))  # vertices in the box frame, one per row
    for v in range(3):
        dx, dy, dz = tri[0, v] - T[0, 3], tri[1, v] - T[1, 3], tri[2, v] - T[2, 3]
        for k in range(3):
            p[v, k] = T[0, k] * dx + T[1, k] * dy + T[2, k] * dz
    e0, e1, e2 = half[0] + EXACT_TOL, half[1] + EXACT_TOL, half[2] + EXACT_TOL
    # the box's face normals
    for k in range(3):
        ek = e0 if k == 0 else (e1 if k == 1 else e2)
        lo = min(p[0, k], p[1, k], p[2, k])
        hi = max(p[0, k], p[1, k], p[2, k])
        if lo > ek or hi < -ek:
            return False
    f = np.empty((3, 3))
    for i in range(3):
        for k in range(3):
            f[i, k] = p[(i + 1) % 3, k] - p[i, k]
    # the triangle's normal
    nx = f[0, 1] * f[1, 2] - f[0, 2] * f[1, 1]
    ny = f[0, 2] * f[1, 0] - f[0, 0] * f[1, 2]
    nz = f[0, 0] * f[1, 1] - f[0, 1] * f[1, 0]
    d = nx * p[0, 0] + ny * p[0, 1] + nz * p[0, 2]
    if abs(d) > e0 * abs(nx) + e1 * abs(ny) + e2 * abs(nz):
        return False
    # box axis × triangle edge
    for i in range(3):
        for k in range(3):
            if k == 0:
                ax, ay, az = 0.0, -f[i, 2], f[i, 1]
            elif k == 1:
                ax, ay, az = f[i, 2], 0.0, -f[i, 0]
            else:
                ax, ay, az = -f[i, 1], f[i, 0], 0.0
            s0 = ax * p[0, 0] + ay * p[0, 1] + az * p[0, 2]
            s1 = ax * p[1, 0] + ay * p[1, 1] + az * p[1, 2]
            s2 = ax * p[2, 0] + ay * p[2, 1] + az * p[2, 2]
            r = e0 * abs(ax) + e1 * abs(ay) + e2 * abs(az)
            if min(s0, s1, s2) > r or max(s0, s1, s2) < -r:
                return False
    return True


PAIR_SET = 16384  # slots of a per-thread hash set of triangle pairs (≥ 2 × EXACT_BUDGET)


@njit(cache=True, inline="always")
def _first_visit(pairs, key, tag):  # type: ignore[no-untyped-def]
    """Add ``key`` to the hash set ``pairs`` (2 × PAIR_SET: keys, tags; a slot is empty unless
    its tag is ``tag``): True if it was not there."""
    h = (key * 2654435761) & (PAIR_SET - 1)
    for _ in range(PAIR_SET):
        if pairs[1, h] != tag:
            pairs[0, h] = key
            pairs[1, h] = tag
            return True
        if pairs[0, h] == key:
            return False
        h = (h + 1) & (PAIR_SET - 1)
    return True


@njit(cache=True, inline="always")
def _separated(ax, ay, az, A, B):  # type: ignore[no-untyped-def]
    """Whether the axis (ax, ay, az) separates triangles A and B (3×4, vertices as columns) by
    more than EXACT_TOL."""
    a0 = ax * A[0, 0] + ay * A[1, 0] + az * A[2, 0]
    a1 = ax * A[0, 1] + ay * A[1, 1] + az * A[2, 1]
    a2 = ax * A[0, 2] + ay * A[1, 2] + az * A[2, 2]
    b0 = ax * B[0, 0] + ay * B[1, 0] + az * B[2, 0]
    b1 = ax * B[0, 1] + ay * B[1, 1] + az * B[2, 1]
    b2 = ax * B[0, 2] + ay * B[1, 2] + az * B[2, 2]
    r = EXACT_TOL * np.sqrt(ax * ax + ay * ay + az * az)
    return min(b0, b1, b2) > max(a0, a1, a2) + r or min(a0, a1, a2) > max(b0, b1, b2) + r


@njit(cache=True)
def triangle_triangle_overlap(A, B):  # type: ignore[no-untyped-def]
    """Whether triangles A and B (3×4, vertices as columns) come closer than EXACT_TOL: the
    separating-axis test over both normals, the nine edge × edge axes and, for triangles in one
    plane, each normal × each edge. An axis found too short to trust is skipped, which can only
    call a pair touching; several times cheaper than GJK on the same pair."""
    # the normals
    ux, uy, uz = A[0, 1] - A[0, 0], A[1, 1] - A[1, 0], A[2, 1] - A[2, 0]
    vx, vy, vz = A[0, 2] - A[0, 0], A[1, 2] - A[1, 0], A[2, 2] - A[2, 0]
    nax, nay, naz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    if _separated(nax, nay, naz, A, B):
        return False
    ux, uy, uz = B[0, 1] - B[0, 0], B[1, 1] - B[1, 0], B[2, 1] - B[2, 0]
    vx, vy, vz = B[0, 2] - B[0, 0], B[1, 2] - B[1, 0], B[2, 2] - B[2, 0]
    nbx, nby, nbz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    if _separated(nbx, nby, nbz, A, B):
        return False
    for i in range(3):
        j = (i + 1) % 3
        ex, ey, ez = A[0, j] - A[0, i], A[1, j] - A[1, i], A[2, j] - A[2, i]
        for k in range(3):
            m = (k + 1) % 3
            fx, fy, fz = B[0, m] - B[0, k], B[1, m] - B[1, k], B[2, m] - B[2, k]
            lx, ly, lz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
            if lx * lx + ly * ly + lz * lz > 1e-24 and _separated(lx, ly, lz, A, B):
                return False
        # in-plane axes (they matter when the triangles share a plane)
        lx, ly, lz = nay * ez - naz * ey, naz * ex - nax * ez, nax * ey - nay * ex
        if lx * lx + ly * ly + lz * lz > 1e-24 and _separated(lx, ly, lz, A, B):
            return False
        fx, fy, fz = B[0, j] - B[0, i], B[1, j] - B[1, i], B[2, j] - B[2, i]
        lx, ly, lz = nby * fz - nbz * fy, nbz * fx - nbx * fz, nbx * fy - nby * fx
        if lx * lx + ly * ly + lz * lz > 1e-24 and _separated(lx, ly, lz, A, B):
            return False
    return True


@njit(cache=True, inline="always")
def _triangle_into(R, t, V, out):  # type: ignore[no-untyped-def]
    """out (3×4): triangle V (3, 3) moved by (R, t), vertices as columns, centroid last."""
    for c in range(3):
        for i in range(3):
            out[i, c] = R[i, 0] * V[c, 0] + R[i, 1] * V[c, 1] + R[i, 2] * V[c, 2] + t[i]
    for i in range(3):
        out[i, 3] = (out[i, 0] + out[i, 1] + out[i, 2]) / 3.0


@njit(cache=True, **NRT_ON)  # allocates: counts references even when _classify_range calls it
def _mesh_vs_obstacle(
    b,
    root,
    nodes,
    left,
    right,
    TB,
    W,
    stamp,
    cur,
    kind,
    To,
    dims,
    node_tri_start,
    node_tri_ids,
    tri_V,
    tri_sphere,
    stack,
    seen,
    tag,
):  # type: ignore[no-untyped-def]
    """Body b's triangles (in the leaves that touch the obstacle) against a solid obstacle
    primitive: GJK_HIT, GJK_FREE, or GJK_UNSURE (a test undecided, or over the budget).
    A triangle spans many leaves: ``seen[tri] == tag`` marks it tested in this call."""
    R = TB[b, :, :3]
    t = TB[b, :, 3]
    tri = np.empty((3, 4))
    tests = 0
    unsure = False
    sp = 1
    stack[0] = root
    while sp > 0:
        sp -= 1
        n = stack[sp]
        _centre(n, b, TB, nodes, W, stamp, cur)
        if _obstacle_clear(W[n, 0], W[n, 1], W[n, 2], nodes[n, 3], kind, To, dims):
            continue
        if left[n] >= 0:
            stack[sp] = left[n]
            stack[sp + 1] = right[n]
            sp += 2
            continue
        for k in range(node_tri_start[n], node_tri_start[n + 1]):
            f = node_tri_ids[k]
            if seen[f] == tag:
                continue
            seen[f] = tag
            sx, sy, sz = tri_sphere[f, 0], tri_sphere[f, 1], tri_sphere[f, 2]
            x = R[0, 0] * sx + R[0, 1] * sy + R[0, 2] * sz + t[0]
            y = R[1, 0] * sx + R[1, 1] * sy + R[1, 2] * sz + t[1]
            z = R[2, 0] * sx + R[2, 1] * sy + R[2, 2] * sz + t[2]
            if _obstacle_clear(x, y, z, tri_sphere[f, 3], kind, To, dims):
                continue
            tests += 1 if kind == OBS_BOX else GJK_COST
            if tests > EXACT_BUDGET:
                return GJK_UNSURE
            _triangle_into(R, t, tri_V[f], tri)
            if kind == OBS_BOX:
                if triangle_box_overlap(tri, To, dims):
                    return GJK_HIT
                continue
            r = gjk_intersect(OBS_TRIANGLE, tri, dims, kind, To, dims)
            if r == GJK_HIT:
                return GJK_HIT
            if r == GJK_UNSURE:
                unsure = True
    return GJK_UNSURE if unsure else GJK_FREE


@njit(cache=True, inline="always")
def _field_bound(
    x,
    y,
    z,
    f,
    field_kind,
    grid_origin,
    grid_box,
    grid_h,
    grid_dims,
    grid_off,
    grid_values,
    prim_start,
    prim_kind,
    prim_T,
    prim_dims,
):  # type: ignore[no-untyped-def]
    """A lower bound of the distance from (x, y, z), in body f's frame, to body f: its grid
    value at the nearest grid point minus the distance to that point, or the exact distance
    to its solid primitives."""
    if field_kind[f] == FIELD_PRIMITIVES:
        best = np.inf
        for p in range(prim_start[f], prim_start[f + 1]):
            d = _obstacle_distance(x, y, z, prim_kind[p], prim_T[p], prim_dims[p])
            if d < best:
                best = d
        return best
    # outside the grid: the distance to the box around the body's leaves
    ex = max(grid_box[f, 0, 0] - x, x - grid_box[f, 1, 0], 0.0)
    ey = max(grid_box[f, 0, 1] - y, y - grid_box[f, 1, 1], 0.0)
    ez = max(grid_box[f, 0, 2] - z, z - grid_box[f, 1, 2], 0.0)
    box = math.sqrt(ex * ex + ey * ey + ez * ez)
    h = grid_h[f]
    i = min(max((x - grid_origin[f, 0]) / h, 0.0), grid_dims[f, 0] - 1.0)
    j = min(max((y - grid_origin[f, 1]) / h, 0.0), grid_dims[f, 1] - 1.0)
    k = min(max((z - grid_origin[f, 2]) / h, 0.0), grid_dims[f, 2] - 1.0)
    ii, jj, kk = int(i + 0.5), int(j + 0.5), int(k + 0.5)
    gx = x - (grid_origin[f, 0] + ii * h)
    gy = y - (grid_origin[f, 1] + jj * h)
    gz = z - (grid_origin[f, 2] + kk * h)
    v = grid_values[grid_off[f] + (ii * grid_dims[f, 1] + jj) * grid_dims[f, 2] + kk]
    return max(v - math.sqrt(gx * gx + gy * gy + gz * gz), box)


@njit(cache=True)
def _tree_touches_sphere(root, nodes, left, right, x, y, z, r, stack):  # type: ignore[no-untyped-def]
    """Whether any leaf of the tree at ``root`` touches the sphere (x, y, z, r), all in the
    tree's body frame."""
    sp = 1
    stack[0] = root
    while sp > 0:
        sp -= 1
        n = stack[sp]
        dx, dy, dz = x - nodes[n, 0], y - nodes[n, 1], z - nodes[n, 2]
        rr = r + nodes[n, 3]
        if dx * dx + dy * dy + dz * dz > rr * rr:
            continue
        if left[n] < 0:
            return True
        stack[sp] = left[n]
        stack[sp + 1] = right[n]
        sp += 2
    return False


@njit(cache=True, inline="always")
def _triangle_copy(V, out):  # type: ignore[no-untyped-def]
    """out (3×4): triangle V (3, 3) as columns, centroid last."""
    for c in range(3):
        for i in range(3):
            out[i, c] = V[c, i]
    for i in range(3):
        out[i, 3] = (V[0, i] + V[1, i] + V[2, i]) / 3.0


@njit(cache=True, inline="always")
def _relative_pose(TB, f, b, R, t):  # type: ignore[no-untyped-def]
    """Body b's frame in body f's: R = Rf^T Rb, t = Rf^T (tb - tf), into R (3, 3), t (3,)."""
    for i in range(3):
        for j in range(3):
            R[i, j] = (
                TB[f, 0, i] * TB[b, 0, j] + TB[f, 1, i] * TB[b, 1, j] + TB[f, 2, i] * TB[b, 2, j]
            )
        t[i] = (
            TB[f, 0, i] * (TB[b, 0, 3] - TB[f, 0, 3])
            + TB[f, 1, i] * (TB[b, 1, 3] - TB[f, 1, 3])
            + TB[f, 2, i] * (TB[b, 2, 3] - TB[f, 2, 3])
        )


@njit(cache=True, **NRT_ON)  # allocates: counts references even when _classify_range calls it
def _near_members(
    f,
    u,
    TB,
    body_root,
    nodes,
    left,
    right,
    node_members,
    field_kind,
    grid_origin,
    grid_box,
    grid_h,
    grid_dims,
    grid_off,
    grid_values,
    prim_start,
    prim_kind,
    prim_T,
    prim_dims,
    stack,
):  # type: ignore[no-untyped-def]
    """The broad phase of a rigid cluster against body f: the union body u's tree descended
    against f's distance field; a bit mask of the members (``node_members``: the members
    under each node of u) that own a leaf the field does not clear. A subtree whose members
    are all marked already is not descended."""
    R = np.empty((3, 3))
    t = np.empty(3)
    _relative_pose(TB, f, u, R, t)
    marked = 0
    sp = 1
    stack[0] = body_root[u]
    while sp > 0:
        sp -= 1
        n = stack[sp]
        if node_members[n] & ~marked == 0:
            continue
        sx, sy, sz = nodes[n, 0], nodes[n, 1], nodes[n, 2]
        x = R[0, 0] * sx + R[0, 1] * sy + R[0, 2] * sz + t[0]
        y = R[1, 0] * sx + R[1, 1] * sy + R[1, 2] * sz + t[1]
        z = R[2, 0] * sx + R[2, 1] * sy + R[2, 2] * sz + t[2]
        d = _field_bound(
            x,
            y,
            z,
            f,
            field_kind,
            grid_origin,
            grid_box,
            grid_h,
            grid_dims,
            grid_off,
            grid_values,
            prim_start,
            prim_kind,
            prim_T,
            prim_dims,
        )
        if d > nodes[n, 3]:
            continue
        if left[n] < 0:
            marked |= node_members[n]
            continue
        stack[sp] = left[n]
        stack[sp + 1] = right[n]
        sp += 2
    return marked


@njit(cache=True, **NRT_ON)  # allocates: counts references even when _classify_range calls it
def _tree_near_field(
    f,
    b,
    TB,
    body_root,
    nodes,
    left,
    right,
    field_kind,
    grid_origin,
    grid_box,
    grid_h,
    grid_dims,
    grid_off,
    grid_values,
    prim_start,
    prim_kind,
    prim_T,
    prim_dims,
    body_mesh,
    node_tri_start,
    node_tri_ids,
    tri_V,
    tri_sphere,
    stack,
    stack2,
    seen,
    pairs,
    tag,
):  # type: ignore[no-untyped-def]
    """Body b against body f by descending b's tree against f's distance field (one tree, not
    two): GJK_FREE, GJK_HIT or TOUCH (leaves may touch; not settled here). A triangle spans
    many leaves: ``seen[tri] == tag`` marks one of b's tested against f's primitives, and the
    hash set ``pairs`` the pairs of triangles tested, in this call.

    At a leaf of b the field cannot clear: if b is all triangles and f is primitives or all
    triangles, the leaf's triangles are tested exactly (GJK) against f's primitives or against
    the triangles of f's leaves near them; otherwise f's own tree is descended with the leaf's
    sphere, and a touch is reported."""
    # b's frame to f's: R = Rf^T Rb, t = Rf^T (tb - tf)
    R = np.empty((3, 3))
    t = np.empty(3)
    _relative_pose(TB, f, b, R, t)
    exact_field = field_kind[f] == FIELD_PRIMITIVES
    settle = body_mesh[b] and (exact_field or body_mesh[f])
    tri_b = np.empty((3, 4))
    tri_f = np.empty((3, 4))
    tests = 0
    touch = False
    sp = 1
    stack[0] = body_root[b]
    while sp > 0:
        sp -= 1
        n = stack[sp]
        sx, sy, sz = nodes[n, 0], nodes[n, 1], nodes[n, 2]
        x = R[0, 0] * sx + R[0, 1] * sy + R[0, 2] * sz + t[0]
        y = R[1, 0] * sx + R[1, 1] * sy + R[1, 2] * sz + t[1]
        z = R[2, 0] * sx + R[2, 1] * sy + R[2, 2] * sz + t[2]
        d = _field_bound(
            x,
            y,
            z,
            f,
            field_kind,
            grid_origin,
            grid_box,
            grid_h,
            grid_dims,
            grid_off,
            grid_values,
            prim_start,
            prim_kind,
            prim_T,
            prim_dims,
        )
        if d > nodes[n, 3]:
            continue
        if left[n] >= 0:
            stack[sp] = left[n]
            stack[sp + 1] = right[n]
            sp += 2
            continue
        if not settle:
            if exact_field or _tree_touches_sphere(
                body_root[f], nodes, left, right, x, y, z, nodes[n, 3], stack2
            ):
                return TOUCH
            continue
        if not exact_field:
            # mesh against mesh: the triangles of this leaf against those of f's leaves that
            # meet it (a point two triangles share lies in a leaf of each that lists it)
            rn = nodes[n, 3] + EXACT_TOL
            sp2 = 1
            stack2[0] = body_root[f]
            while sp2 > 0:
                sp2 -= 1
                m = stack2[sp2]
                dx, dy, dz = x - nodes[m, 0], y - nodes[m, 1], z - nodes[m, 2]
                rr = rn + nodes[m, 3]
                if dx * dx + dy * dy + dz * dz > rr * rr:
                    continue
                if left[m] >= 0:
                    stack2[sp2] = left[m]
                    stack2[sp2 + 1] = right[m]
                    sp2 += 2
                    continue
                for kb in range(node_tri_start[n], node_tri_start[n + 1]):
                    tb = node_tri_ids[kb]
                    sx, sy, sz = tri_sphere[tb, 0], tri_sphere[tb, 1], tri_sphere[tb, 2]
                    cx = R[0, 0] * sx + R[0, 1] * sy + R[0, 2] * sz + t[0]
                    cy = R[1, 0] * sx + R[1, 1] * sy + R[1, 2] * sz + t[1]
                    cz = R[2, 0] * sx + R[2, 1] * sy + R[2, 2] * sz + t[2]
                    for kf in range(node_tri_start[m], node_tri_start[m + 1]):
                        tf = node_tri_ids[kf]
                        dx, dy, dz = (
                            cx - tri_sphere[tf, 0],
                            cy - tri_sphere[tf, 1],
                            cz - tri_sphere[tf, 2],
                        )
                        rr = tri_sphere[tb, 3] + tri_sphere[tf, 3] + EXACT_TOL
                        if dx * dx + dy * dy + dz * dz > rr * rr:
                            continue
                        if not _first_visit(pairs, tb * tri_V.shape[0] + tf, tag):
                            continue
                        tests += 1
                        if tests > EXACT_BUDGET:
                            return TOUCH
                        _triangle_into(R, t, tri_V[tb], tri_b)
                        _triangle_copy(tri_V[tf], tri_f)
                        if triangle_triangle_overlap(tri_b, tri_f):
                            return GJK_HIT
            continue
        for kb in range(node_tri_start[n], node_tri_start[n + 1]):
            tb = node_tri_ids[kb]
            if seen[tb] == tag:
                continue
            seen[tb] = tag
            sx, sy, sz, rb = (
                tri_sphere[tb, 0],
                tri_sphere[tb, 1],
                tri_sphere[tb, 2],
                tri_sphere[tb, 3],
            )
            cx = R[0, 0] * sx + R[0, 1] * sy + R[0, 2] * sz + t[0]
            cy = R[1, 0] * sx + R[1, 1] * sy + R[1, 2] * sz + t[1]
            cz = R[2, 0] * sx + R[2, 1] * sy + R[2, 2] * sz + t[2]
            if (
                _field_bound(
                    cx,
                    cy,
                    cz,
                    f,
                    field_kind,
                    grid_origin,
                    grid_box,
                    grid_h,
                    grid_dims,
                    grid_off,
                    grid_values,
                    prim_start,
                    prim_kind,
                    prim_T,
                    prim_dims,
                )
                > rb
            ):
                continue
            placed = False
            for p in range(prim_start[f], prim_start[f + 1]):
                if _obstacle_distance(cx, cy, cz, prim_kind[p], prim_T[p], prim_dims[p]) > rb:
                    continue
                if not placed:
                    _triangle_into(R, t, tri_V[tb], tri_b)
                    placed = True
                if prim_kind[p] == OBS_BOX:
                    tests += 1
                    if tests > EXACT_BUDGET:
                        return TOUCH
                    if triangle_box_overlap(tri_b, prim_T[p], prim_dims[p]):
                        return GJK_HIT
                    continue
                tests += GJK_COST
                if tests > EXACT_BUDGET:
                    return TOUCH
                r = gjk_intersect(
                    OBS_TRIANGLE, tri_b, prim_dims[p], prim_kind[p], prim_T[p], prim_dims[p]
                )
                if r == GJK_HIT:
                    return GJK_HIT
                if r == GJK_UNSURE:
                    touch = True
    return TOUCH if touch else GJK_FREE


# The model a kernel call works on: everything but the states and the scratch, as one tuple in
# this order (CollisionChecker builds it once). Passing one tuple instead of forty-four arrays
# keeps the signatures short; numba unpacks it at no cost.
MODEL_FIELDS = (
    "group_idx",
    "q_base",
    "joints",
    "root",
    "parent",
    "child",
    "origin",
    "jtype",
    "axis",
    "var",
    "mult",
    "offset",
    "body_link",
    "body_T",
    "body_root",
    "nodes",
    "left",
    "right",
    "inner_start",
    "inner",
    "obs_kind",
    "obs_T",
    "obs_dims",
    "obs_sphere",
    "obs_inner_ok",
    "world_pairs",
    "self_pairs",
    "pair_field",
    "field_kind",
    "grid_origin",
    "grid_box",
    "grid_h",
    "grid_dims",
    "grid_off",
    "grid_values",
    "prim_start",
    "prim_kind",
    "prim_T",
    "prim_dims",
    "body_mesh",
    "node_tri_start",
    "node_tri_ids",
    "tri_V",
    "tri_sphere",
    "pair_table",
    "table_vars",
    "table_n",
    "table_off",
    "table_values",
    "group_table",
    "group_start",
    "group_bodies",
    "group_count",
    "node_members",
    "pair_bit",
    "world_group_start",
    "world_group_union",
    "world_group_count",
    "world_run_end",
    "world_frame",
    "world_dims",
    "world_values",
)


TABLE_FREE, TABLE_HIT = 0, 1  # as pair_tables (imported there from here)


def pack_tables(values: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Pair-table cells (FREE, HIT or CHECK: 0–2) four to a byte, the first in the lowest
    bits, for :func:`_table_value`: the UR5's tables take 5.5 MB instead of 22, and a random
    state's lookups miss the cache less."""
    v = np.concatenate([values, np.zeros(-len(values) % 4, np.uint8)]).reshape(-1, 4)
    return (v[:, 0] | (v[:, 1] << 2) | (v[:, 2] << 4) | (v[:, 3] << 6)).astype(np.uint8)


INV_TWO_PI = 1.0 / (2.0 * math.pi)


@njit(cache=True, inline="always")
def _table_value(q, ti, table_vars, table_n, table_off, table_values):  # type: ignore[no-untyped-def]
    """Table ti's value at q: each of its variables' angles wrapped to [0, 2π), n cells.
    ``table_values`` holds four cells per byte (:func:`pack_tables`)."""
    n = table_n[ti]
    x = q[table_vars[ti, 0]] * INV_TWO_PI
    idx = min(int((x - math.floor(x)) * n), n - 1)
    for c in range(1, 3):
        v = table_vars[ti, c]
        if v < 0:
            break
        x = q[v] * INV_TWO_PI
        idx = idx * n + min(int((x - math.floor(x)) * n), n - 1)
    c = table_off[ti] + idx
    return (table_values[c >> 2] >> ((c & 3) << 1)) & 3


@njit(cache=True, inline="always")
def _inner_overlap(a, b, rb, TB, nodes, inner, inner_start, W, Wi, stamp_i, cur):  # type: ignore[no-untyped-def]
    """Whether an inner sphere of body a overlaps one of body b (both solid there: a certain
    hit). ``rb``: b's root node, whose world centre is in W."""
    for s in range(inner_start[a], inner_start[a + 1]):
        _centre(s, a, TB, inner, Wi, stamp_i, cur)
        dx = Wi[s, 0] - W[rb, 0]
        dy = Wi[s, 1] - W[rb, 1]
        dz = Wi[s, 2] - W[rb, 2]
        rr = inner[s, 3] + nodes[rb, 3]
        if dx * dx + dy * dy + dz * dz > rr * rr:
            continue
        for t in range(inner_start[b], inner_start[b + 1]):
            _centre(t, b, TB, inner, Wi, stamp_i, cur)
            dx = Wi[s, 0] - Wi[t, 0]
            dy = Wi[s, 1] - Wi[t, 1]
            dz = Wi[s, 2] - Wi[t, 2]
            rr = inner[s, 3] + inner[t, 3]
            if dx * dx + dy * dy + dz * dz < rr * rr:
                return True
    return False


# Inlined into _classify_range, which is compiled without numba's reference counting.
@njit(cache=True, inline="always")
def _classify_state(
    q, TB, model, W, stamp, Wi, stamp_i, seen, pairs, cur, stack, stack2, stack3, flags, status,
    mark,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """FREE / HIT / UNSURE for one state (full variables q, body poses in TB). Unsure pairs
    are flagged (world pairs first, then self pairs) for the exact stage. ``seen``: per-triangle
    marks, tagged ``cur * PAIR_TAGS + pair``. A self pair with a table (pair_tables) is looked
    up first."""
    (
        group_idx,
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
        body_link,
        body_T,
        body_root,
        nodes,
        left,
        right,
        inner_start,
        inner,
        obs_kind,
        obs_T,
        obs_dims,
        obs_sphere,
        obs_inner_ok,
        world_pairs,
        self_pairs,
        pair_field,
        field_kind,
        grid_origin,
        grid_box,
        grid_h,
        grid_dims,
        grid_off,
        grid_values,
        prim_start,
        prim_kind,
        prim_T,
        prim_dims,
        body_mesh,
        node_tri_start,
        node_tri_ids,
        tri_V,
        tri_sphere,
        pair_table,
        table_vars,
        table_n,
        table_off,
        table_values,
        group_table,
        group_start,
        group_bodies,
        group_count,
        node_members,
        pair_bit,
        world_group_start,
        world_group_union,
        world_group_count,
        world_run_end,
        world_frame,
        world_dims,
        world_values,
    ) = model
    n_world = world_pairs.shape[0]
    unsure = False
    skip_to = 0
    for k in range(n_world):
        if k < skip_to:
            continue
        b = world_pairs[k, 0]
        o = world_pairs[k, 1]
        g = world_group_start[k]
        if g >= 0:
            # the pairs k … k + count − 1 are members of a rigid cluster against obstacle o:
            # the union's bounding sphere clear of it, or of the whole world, clears them all
            u = world_group_union[g]
            if _body_clear(
                u, TB, nodes, body_root, W, stamp, cur, mark, world_frame, world_dims,
                world_values,
            ):  # fmt: skip
                skip_to = world_run_end[k]
                continue
            ru = body_root[u]
            _centre(ru, u, TB, nodes, W, stamp, cur)
            dx = W[ru, 0] - obs_sphere[o, 0]
            dy = W[ru, 1] - obs_sphere[o, 1]
            dz = W[ru, 2] - obs_sphere[o, 2]
            rr = nodes[ru, 3] + obs_sphere[o, 3]
            if dx * dx + dy * dy + dz * dz > rr * rr or _obstacle_clear(
                W[ru, 0], W[ru, 1], W[ru, 2], nodes[ru, 3], obs_kind[o], obs_T[o], obs_dims[o]
            ):
                skip_to = k + world_group_count[g]
                continue
        # broadphase: the body's bounding sphere against the whole world's distance grid,
        # then against the obstacle's bounding sphere
        if _body_clear(
            b, TB, nodes, body_root, W, stamp, cur, mark, world_frame, world_dims, world_values
        ):
            if g < 0:  # and the body's next pairs, against other obstacles
                skip_to = world_run_end[k]
            continue
        r0 = body_root[b]
        _centre(r0, b, TB, nodes, W, stamp, cur)
        dx = W[r0, 0] - obs_sphere[o, 0]
        dy = W[r0, 1] - obs_sphere[o, 1]
        dz = W[r0, 2] - obs_sphere[o, 2]
        rr = nodes[r0, 3] + obs_sphere[o, 3]
        if dx * dx + dy * dy + dz * dz > rr * rr:
            continue
        if not _tree_touches_obstacle(
            b,
            body_root[b],
            nodes,
            left,
            right,
            TB,
            W,
            stamp,
            cur,
            obs_kind[o],
            obs_T[o],
            obs_dims[o],
            stack,
        ):
            continue
        if obs_inner_ok[o]:
            for s in range(inner_start[b], inner_start[b + 1]):
                _centre(s, b, TB, inner, Wi, stamp_i, cur)
                if (
                    _obstacle_distance(
                        Wi[s, 0], Wi[s, 1], Wi[s, 2], obs_kind[o], obs_T[o], obs_dims[o]
                    )
                    < inner[s, 3]
                ):
                    return HIT
        if obs_inner_ok[o] and (field_kind[b] == FIELD_PRIMITIVES or body_mesh[b]):
            if field_kind[b] == FIELD_PRIMITIVES:
                r = _exact_world(
                    b,
                    obs_kind[o],
                    obs_T[o],
                    obs_dims[o],
                    TB,
                    prim_start,
                    prim_kind,
                    prim_T,
                    prim_dims,
                )
            else:
                r = _mesh_vs_obstacle(
                    b,
                    body_root[b],
                    nodes,
                    left,
                    right,
                    TB,
                    W,
                    stamp,
                    cur,
                    obs_kind[o],
                    obs_T[o],
                    obs_dims[o],
                    node_tri_start,
                    node_tri_ids,
                    tri_V,
                    tri_sphere,
                    stack,
                    seen,
                    cur * PAIR_TAGS + k,
                )
            if r == GJK_HIT:
                return HIT
            if r == GJK_FREE:
                continue
        unsure = True
        flags[k] = True
    # self pairs in two passes. The first makes the cheap decisions (tables, bounding spheres)
    # and finds deep collisions (inner spheres of two solids overlapping) before any descent:
    # a state in collision usually shows one there. ``status``: 0 = the second pass does all
    # of the pair, 1 = decided (free), 2 = only its descent is left.
    n_self = self_pairs.shape[0]
    k = 0
    while k < n_self:
        g = group_start[k]
        if g >= 0:
            ti = group_table[g]
            if ti >= 0:
                v = _table_value(q, ti, table_vars, table_n, table_off, table_values)
                if v == TABLE_FREE:
                    for j in range(k, k + group_count[g]):
                        status[j] = 1
                    k += group_count[g]
                    continue
                if v == TABLE_HIT:
                    return HIT
            x, u = group_bodies[g, 0], group_bodies[g, 1]
            rx, ru = body_root[x], body_root[u]
            _centre(rx, x, TB, nodes, W, stamp, cur)
            _centre(ru, u, TB, nodes, W, stamp, cur)
            dx = W[rx, 0] - W[ru, 0]
            dy = W[rx, 1] - W[ru, 1]
            dz = W[rx, 2] - W[ru, 2]
            rr = nodes[rx, 3] + nodes[ru, 3]
            far = dx * dx + dy * dy + dz * dz > rr * rr
            for j in range(k, k + group_count[g]):
                status[j] = 1 if far else 0
            # the union's inner spheres lie inside members x is paired with
            if not far and _inner_overlap(
                x, u, ru, TB, nodes, inner, inner_start, W, Wi, stamp_i, cur
            ):
                return HIT
            k += group_count[g]
            continue
        status[k] = 1
        ti = pair_table[k]
        if ti >= 0:
            v = _table_value(q, ti, table_vars, table_n, table_off, table_values)
            if v == TABLE_FREE:
                k += 1
                continue
            if v == TABLE_HIT:
                return HIT
        a = self_pairs[k, 0]
        b = self_pairs[k, 1]
        ra, rb = body_root[a], body_root[b]
        _centre(ra, a, TB, nodes, W, stamp, cur)
        _centre(rb, b, TB, nodes, W, stamp, cur)
        dx = W[ra, 0] - W[rb, 0]
        dy = W[ra, 1] - W[rb, 1]
        dz = W[ra, 2] - W[rb, 2]
        rr = nodes[ra, 3] + nodes[rb, 3]
        if dx * dx + dy * dy + dz * dz <= rr * rr:
            # overlapping solids are a hit, however deep (a link inside another's shell has
            # no crossing surfaces, and would make the descent exhaustive)
            if _inner_overlap(a, b, rb, TB, nodes, inner, inner_start, W, Wi, stamp_i, cur):
                return HIT
            status[k] = 2
        k += 1
    for k in range(n_self):
        if status[k] == 1:
            continue
        g = group_start[k]
        if g >= 0:
            # broad phase: the pairs k … k + count − 1 are one body against members of a
            # rigid cluster; one descent of the cluster's union tree against that body's
            # field says which members come near it, and only their pairs go on
            near = _near_members(
                group_bodies[g, 0],
                group_bodies[g, 1],
                TB,
                body_root,
                nodes,
                left,
                right,
                node_members,
                field_kind,
                grid_origin,
                grid_box,
                grid_h,
                grid_dims,
                grid_off,
                grid_values,
                prim_start,
                prim_kind,
                prim_T,
                prim_dims,
                stack,
            )
            for j in range(k, k + group_count[g]):
                if (near >> pair_bit[j]) & 1 == 0:
                    status[j] = 1
            if status[k] == 1:
                continue
        a = self_pairs[k, 0]
        b = self_pairs[k, 1]
        ra, rb = body_root[a], body_root[b]
        if status[k] == 0:
            # a group's member: its own bounding spheres and inner spheres
            _centre(ra, a, TB, nodes, W, stamp, cur)
            _centre(rb, b, TB, nodes, W, stamp, cur)
            dx = W[ra, 0] - W[rb, 0]
            dy = W[ra, 1] - W[rb, 1]
            dz = W[ra, 2] - W[rb, 2]
            rr = nodes[ra, 3] + nodes[rb, 3]
            if dx * dx + dy * dy + dz * dz > rr * rr:
                continue
            if _inner_overlap(a, b, rb, TB, nodes, inner, inner_start, W, Wi, stamp_i, cur):
                return HIT
        m = pair_field[k]
        if m < 0:
            if not _trees_touch(a, b, ra, rb, nodes, left, right, TB, W, stamp, cur, stack2):
                continue
        else:
            f, d = (a, b) if m == 0 else (b, a)
            r = _tree_near_field(
                f,
                d,
                TB,
                body_root,
                nodes,
                left,
                right,
                field_kind,
                grid_origin,
                grid_box,
                grid_h,
                grid_dims,
                grid_off,
                grid_values,
                prim_start,
                prim_kind,
                prim_T,
                prim_dims,
                body_mesh,
                node_tri_start,
                node_tri_ids,
                tri_V,
                tri_sphere,
                stack,
                stack3,
                seen,
                pairs,
                cur * PAIR_TAGS + n_world + k,
            )
            if r == GJK_FREE:
                continue
            if r == GJK_HIT:
                return HIT
        if field_kind[a] == FIELD_PRIMITIVES and field_kind[b] == FIELD_PRIMITIVES:
            r = _exact_self(a, b, TB, prim_start, prim_kind, prim_T, prim_dims)
            if r == GJK_HIT:
                return HIT
            if r == GJK_FREE:
                continue
        unsure = True
        flags[n_world + k] = True
    return UNSURE if unsure else FREE


@njit(cache=True, inline="always")
def _range_buffers(model):  # type: ignore[no-untyped-def]
    """The work arrays of one :func:`_classify_range` call: a block's body poses (BLOCK, B,
    3, 4), the full variable vector (the model's, to be overwritten in the group's
    variables), three descent stacks, the self pairs' status, the bodies' marks of
    :func:`_body_clear`, which bodies sit at their link's frame (``body_T`` the identity:
    their pose is the link's, copied), and for :func:`fk_block` a block's link poses (L, 12,
    BLOCK), each variable's column in the states (-1 outside the group), and work rows (15,
    BLOCK): fk_block's three, then a block's pose of one body (12 rows)."""
    group_idx, q_base, _, root, parent, child = model[:6]
    body_T = model[13]
    plain = np.ones(body_T.shape[0], np.bool_)
    for b in range(body_T.shape[0]):
        for i in range(3):
            for j in range(4):
                if body_T[b, i, j] != (1.0 if i == j else 0.0):
                    plain[b] = False
    n_links = root + 1
    for k in range(child.shape[0]):
        n_links = max(n_links, parent[k] + 1, child[k] + 1)
    column = np.full(q_base.shape[0], -1, np.int64)
    for i in range(group_idx.shape[0]):
        column[group_idx[i]] = i
    return (
        np.empty((BLOCK, model[12].shape[0], 3, 4)),
        q_base.copy(),
        np.empty(256, np.int64),
        np.empty((512, 2), np.int64),
        np.empty(256, np.int64),
        np.empty(model[26].shape[0], np.int8),
        np.full(model[12].shape[0], -1, np.int64),
        plain,
        np.zeros((n_links, 12, BLOCK)),
        column,
        np.zeros((15, BLOCK)),
    )


# Compiled without numba's reference counting (``_nrt=False``, an option of numba's CPU
# target): it creates no array (its caller passes them, :func:`_range_buffers`), and counting
# the references to the model's 58 arrays, which _classify_state (inlined) unpacks for each
# state, and to every array its helpers touch cost 0.5–2 µs of a 1–6 µs state (measured on
# the Panda and the UR5). The functions it calls that allocate set ``_nrt=True``, as they
# would otherwise inherit the option.
@njit(cache=True, **NRT_OFF)
def _classify_range(
    s0, s1, qs, model, W, stamp, Wi, stamp_i, seen, pairs, T, epoch, flags, record_flags,
    scratch_row, out, buffers, stop_early,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Classify states s0..s1-1: :func:`_classify_states`, compiled on its own (for the
    batch checks; :func:`scan` has it inlined).

    Compiled once, for one signature: its callers pass no constants and leave out no
    argument, as numba compiles a function anew for each literal (``0``, ``False``) or left
    out argument it is called with; it had been compiled five times, 48 s each, of a first
    run's 7 minutes of compiling (measured). Hence the ``np.int64(0)`` and ``np.bool_(False)``
    in the callers, and no defaults in them either."""
    _classify_states(
        s0, s1, qs, model, W, stamp, Wi, stamp_i, seen, pairs, T, epoch, flags, record_flags,
        scratch_row, out, buffers, stop_early,
    )  # fmt: skip


@njit(cache=True, inline="always")
def place_bodies(T, body_link, body_T, plain, TB):  # type: ignore[no-untyped-def]
    """The body poses TB (B, 3, 4) of one state from its link poses T (L, 4, 4): each body's
    link pose times the body's (``body_T``), copied where the body sits at its link's frame
    (``plain``: 9 of a Panda's 12 bodies, without the product's multiplications by 1 and 0)."""
    for b in range(body_link.shape[0]):
        L = T[body_link[b]]
        if plain[b]:
            for i in range(3):
                for j in range(4):
                    TB[b, i, j] = L[i, j]
            continue
        for i in range(3):
            for j in range(4):
                TB[b, i, j] = (
                    L[i, 0] * body_T[b, 0, j]
                    + L[i, 1] * body_T[b, 1, j]
                    + L[i, 2] * body_T[b, 2, j]
                    + (L[i, 3] if j == 3 else 0.0)
                )


@njit(cache=True, inline="always")
def _place_block(qs, s0, n, model, plain, TBb, Ts, column, work):  # type: ignore[no-untyped-def]
    """The body poses of states ``qs[s0 : s0 + n]`` into ``TBb[:n]`` (n, B, 3, 4): their links
    placed at once (:func:`fk_block`, on SIMD lanes), then each body's pose."""
    group_idx, q_base, joints, root, parent, child, origin, jtype, axis, var, mult, offset = model[
        :12
    ]
    body_link, body_T = model[12], model[13]
    fk_block(
        qs, s0, n, column, q_base, joints, root, parent, child, origin, jtype, axis, var, mult,
        offset, Ts, work[0], work[1], work[2],
    )  # fmt: skip
    lanes = block_lanes(n)
    Tb = work[3:15]
    for b in range(body_link.shape[0]):
        L = body_link[b]
        if plain[b]:
            # the link's pose (9 of a Panda's 12 bodies, 9 of a UR5's 19)
            for k in range(n):
                for r in range(12):
                    TBb[k, b, r // 4, r % 4] = Ts[L, r, k]
            continue
        # the link's pose times the body's, on SIMD lanes, then state by state (a UR5's
        # bodies placed in 122 instead of 168 ns a state, measured)
        for i in range(3):
            for j in range(4):
                m0, m1, m2 = body_T[b, 0, j], body_T[b, 1, j], body_T[b, 2, j]
                m3 = 1.0 if j == 3 else 0.0
                r = 4 * i
                for k in range(lanes):
                    Tb[r + j, k] = (
                        Ts[L, r, k] * m0 + Ts[L, r + 1, k] * m1 + Ts[L, r + 2, k] * m2
                        + Ts[L, r + 3, k] * m3
                    )  # fmt: skip
        for k in range(n):
            for r in range(12):
                TBb[k, b, r // 4, r % 4] = Tb[r, k]


@njit(cache=True, inline="always")
def _classify_states(
    s0, s1, qs, model, W, stamp, Wi, stamp_i, seen, pairs, T, epoch, flags, record_flags,
    scratch_row, out, buffers, stop_early=False,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Classify states s0..s1-1 with one thread's scratch (W, stamp, Wi, stamp_i, seen, pairs, T;
    T holds the link poses of a state placed alone).
    Stamps hold ``epoch + s`` for the state that last placed a sphere, so the scratch is
    reused across calls without being reset. ``buffers``: :func:`_range_buffers`.
    ``stop_early``: return after the first state that is not FREE (the later ones keep their
    UNCHECKED mark).

    The bodies are placed a block of states at a time (:func:`fk_block`, on SIMD lanes): a
    Panda's final-check states took 640 instead of 935 ns each, a UR5's 770 instead of 1067
    (session 28, measured). A scan that stops early places its first state alone (a block of
    8 took 420 ns for a Panda, one state 265), then blocks of 8, then of BLOCK."""
    group_idx, q_base, joints, root, parent, child, origin, jtype, axis, var, mult, offset = model[
        :12
    ]
    body_link, body_T = model[12], model[13]
    TBb, q, stack, stack2, stack3, status, mark, plain, Ts, column, work = buffers
    # a scan places its first state alone: most edges a search rejects collide there
    size = 1 if stop_early else BLOCK
    b0 = s0
    while b0 < s1:
        n = min(size, s1 - b0)
        if n == 1:
            for i in range(group_idx.shape[0]):
                q[group_idx[i]] = qs[b0, i]
            fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
            place_bodies(T, body_link, body_T, plain, TBb[0])
        else:
            _place_block(qs, b0, n, model, plain, TBb, Ts, column, work)
        for k in range(n):
            s = b0 + k
            for i in range(group_idx.shape[0]):
                q[group_idx[i]] = qs[s, i]
            row = flags[s] if record_flags else scratch_row
            out[s] = _classify_state(
                q, TBb[k], model, W, stamp, Wi, stamp_i, seen, pairs, epoch + s, stack, stack2,
                stack3, row, status, mark,
            )  # fmt: skip
            if stop_early and out[s] != FREE:
                return
        b0 += n
        size = min(8 * size, BLOCK)  # 1, 8, 16


@njit(cache=True, inline="always")
def _slot(scratch, slot):  # type: ignore[no-untyped-def]
    """Scratch slot ``slot``'s arrays: (W, stamp, Wi, stamp_i, seen, pairs, T)."""
    W, stamp, Wi, stamp_i, seen, pairs, T = scratch
    return W[slot], stamp[slot], Wi[slot], stamp_i[slot], seen[slot], pairs[slot], T[slot]


class _TuplesRef(types.StructRef):  # type: ignore[misc]
    """A StructRef of tuples of arrays (:class:`Scanner`, :class:`KernelInputs`), its fields
    typed as their values are."""

    def preprocess_fields(self, fields):  # type: ignore[no-untyped-def]
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


# What a scan works with (the model and a scratch slot's arrays, 88 arrays) as one pointer:
# passed as tuples, every call of :func:`scan` pushed 658 words onto the stack and released
# 100 references after it, 146 ns of a call with warm caches, and its 8 call sites took 57 kB
# of the search's and shortcut's code (rrt_connect, shortcut, _skip_waypoints), fetched anew
# in a plan that follows other work; scanner and scan grew by 15 kB (session 29, measured).
@structref.register
class ScannerType(_TuplesRef):  # type: ignore[misc]
    pass


class Scanner(structref.StructRefProxy):  # type: ignore[misc]
    """(model, work) of :func:`scan`: see :func:`scanner`."""


structref.define_proxy(Scanner, ScannerType, ["model", "work"])


# numba's MemInfo, as its runtime lays it out (nrt.cpp; nrtdynmod's private
# _meminfo_struct_type, which a test compares with this): size_t refct, void *dtor,
# void *dtor_info, void *data, size_t size. _scanner_fields reads its data pointer.
_MEMINFO = ir.LiteralStructType(
    [ir.IntType(64), ir.IntType(8).as_pointer(), ir.IntType(8).as_pointer(),
     ir.IntType(8).as_pointer(), ir.IntType(64)]
)  # fmt: skip


@intrinsic
def _scanner_fields(typingctx, sc):  # type: ignore[no-untyped-def]
    """(model, work) of a :class:`Scanner`, borrowed, in code compiled without numba's
    reference counting (:func:`scan`), where ``sc.model`` cannot compile: it reads the data
    pointer through the runtime. The same read: the data pointer is the fourth field of the
    MemInfo (:data:`_MEMINFO`), as numba's own ``NRT_MemInfo_data_fast`` reads it."""
    names = ("model", "work")
    sig = types.Tuple(tuple(sc.field_dict[n] for n in names))(sc)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        meminfo = cgutils.create_struct_proxy(sc)(context, builder, value=args[0]).meminfo
        info = builder.bitcast(meminfo, _MEMINFO.as_pointer())
        data = builder.load(cgutils.gep(builder, info, 0, 3))
        valtype = sc.get_data_type()
        alloc = context.data_model_manager[valtype].get_value_type()
        fields = cgutils.create_struct_proxy(valtype)(
            context, builder, ref=builder.bitcast(data, alloc.as_pointer())
        )
        values = [getattr(fields, n) for n in names]
        return context.make_tuple(builder, signature.return_type, values)

    return sig, codegen


@njit(cache=True)
def scanner(model, scratch, slot, n):  # type: ignore[no-untyped-def]
    """What :func:`scan` works with on scratch slot ``slot``, up to ``n`` states at a time
    (a :class:`Scanner`): the model, and the slot's arrays, empty flags, and the results' and
    :func:`_range_buffers`' arrays. Allocating them for each edge cost 1.5–2 µs of the 3 µs an
    edge of one state took (measured); a checker keeps one per slot (:func:`kernel_inputs`)."""
    P = model[25].shape[0] + model[26].shape[0]
    work = (np.zeros((0, P), np.bool_), np.zeros(P, np.bool_), np.empty(n, np.int8))
    return Scanner(model, _slot(scratch, slot) + work + (_range_buffers(model),))


@njit(cache=True, **NRT_OFF)
def scan(qs, n, sc, epoch):  # type: ignore[no-untyped-def]
    """How many leading states of ``qs[:n]`` are FREE, classified in order on scanner ``sc``
    (:func:`scanner`) until the first that is not, with stamps from ``epoch``."""
    model, work = _scanner_fields(sc)
    W, stamp, Wi, stamp_i, seen, pairs, T, flags, row, out, buffers = work
    size = out.shape[0]
    for c0 in range(0, n, size):
        c1 = min(n, c0 + size)
        # inlined: a call passing the model's 62 arrays cost 1.4 µs, more than the state
        _classify_states(
            0, c1 - c0, qs[c0:c1], model, W, stamp, Wi, stamp_i, seen, pairs, T, epoch + c0,
            flags, False, row, out, buffers, True,
        )  # fmt: skip
        for k in range(c1 - c0):
            if out[k] != FREE:
                return c0 + k
    return n


@njit(cache=True)
def classify_serial(qs, model, scratch, epoch, record_flags, stop_early, slot):  # type: ignore[no-untyped-def]
    """:func:`classify` in the calling thread, for batches of at most one chunk: a parallel
    function costs several microseconds more per call even when it runs serially (measured).
    ``stop_early``: stop at the first state that is not FREE; later states stay UNCHECKED.
    ``slot``: the scratch's thread slot to use."""
    W, stamp, Wi, stamp_i, seen, pairs, T = _slot(scratch, slot)
    N = qs.shape[0]
    out = np.full(N, UNCHECKED, np.int8)
    P = model[25].shape[0] + model[26].shape[0]
    flags = np.zeros((N if record_flags else 0, P), np.bool_)
    row = np.zeros(0 if record_flags else P, np.bool_)
    _classify_range(
        np.int64(0),
        N,
        qs,
        model,
        W,
        stamp,
        Wi,
        stamp_i,
        seen,
        pairs,
        T,
        epoch,
        flags,
        record_flags,
        row,
        out,
        _range_buffers(model),
        stop_early,
    )
    return out, flags


@njit(cache=True, parallel=True)
def classify(qs, model, scratch, epoch, record_flags, chunk):  # type: ignore[no-untyped-def]
    """(N,) int8 FREE/HIT/UNSURE for (N, dof) group configurations, and (N, P) flags of the
    unsure pairs of each unsure state ((0, P) unless ``record_flags``); ``model`` as
    MODEL_FIELDS says.

    ``scratch`` = (W, stamp, Wi, stamp_i, seen, pairs, T), per-thread (leading axis: thread
    slot), kept by the caller between calls: allocating it per call cost more than classifying
    a few states.
    Chunks of ``chunk`` states are dealt to the threads in turn (chunk c to thread c mod
    threads), each thread with one set of work buffers, so that each gets states from all
    along a path. Split into halves (numba's static schedule of one iteration per chunk), the
    half nearer the obstacles kept one thread busy longer: Panda table_under_pick final
    checks after an ``ompl`` plan, 309 against 260 µs of work. Dealt, against halves
    (session 27, the final checks' states of each problem's plan, both alternating, each
    after an ``ompl`` plan and a native one, medians of 150 checks): Panda table_under_pick
    332 against 352 µs, table_pick 233 against 258; UR5 table_under_pick 403 both."""
    W, stamp, Wi, stamp_i, seen, pairs, T = scratch
    N = qs.shape[0]
    out = np.empty(N, np.int8)
    P = model[25].shape[0] + model[26].shape[0]
    n_chunks = (N + chunk - 1) // chunk
    flags = np.zeros((N if record_flags else 0, P), np.bool_)
    rows = np.zeros((W.shape[0], 0 if record_flags else P), np.bool_)
    n_threads = min(W.shape[0] - SEARCH_SLOTS, n_chunks)
    for first in prange(n_threads):
        t = numba.get_thread_id()
        buffers = _range_buffers(model)
        for c in range(first, n_chunks, n_threads):
            _classify_range(
                c * chunk,
                min(N, (c + 1) * chunk),
                qs,
                model,
                W[t],
                stamp[t],
                Wi[t],
                stamp_i[t],
                seen[t],
                pairs[t],
                T[t],
                epoch,
                flags,
                record_flags,
                rows[t],
                out,
                buffers,
                np.bool_(False),
            )
    return out, flags


# A checker's model and scratch as one object for calls from Python: numba unboxes the 62
# arrays of a model tuple on every call (4 µs with warm caches, 28 µs with cold ones, as in a
# plan's first calls); a StructRef is one pointer (0.6 and 9 µs, measured). Compiled code
# takes the tuples out (``inputs.model``) and calls on as before.
@structref.register
class KernelInputsType(_TuplesRef):  # type: ignore[misc]
    pass


class KernelInputs(structref.StructRefProxy):  # type: ignore[misc]
    """(model, scratch, scanners) of a checker, for compiled entry points (``*_in``):
    ``scanners`` holds a :class:`Scanner` per scratch slot (:func:`kernel_inputs`)."""


structref.define_proxy(KernelInputs, KernelInputsType, ["model", "scratch", "scanners"])


# the states a kept scanner classifies at a time (its results' array; :func:`scan` takes
# any number, in runs of this many): the searches' and shortcuts' longest edge
SCAN_STATES = 4096


@njit(cache=True)
def kernel_inputs(model, scratch):  # type: ignore[no-untyped-def]
    """A :class:`KernelInputs` (built in cached compiled code: the proxy's own constructor
    is compiled anew in each process, 1 s), with a scanner for each scratch slot, made once
    per model rather than by each search, shortcut and check of a plan: a scanner took 11–15
    µs to make in a plan that follows an ``ompl`` plan (4–5 µs hot), and a plan made seven
    (Panda table_pick, session 42, measured)."""
    scanners = List()
    for slot in range(scratch[0].shape[0]):
        scanners.append(scanner(model, scratch, slot, SCAN_STATES))
    return KernelInputs(model, scratch, scanners)


@njit(cache=True)
def scanners_in(inputs):  # type: ignore[no-untyped-def]
    """A :class:`KernelInputs`' scanners, for Python (the proxy's own attribute is compiled
    anew in each process)."""
    return inputs.scanners


@njit(cache=True)
def classify_serial_in(qs, inputs, epoch, record_flags, stop_early, slot):  # type: ignore[no-untyped-def]
    """:func:`classify_serial` on a :class:`KernelInputs`."""
    return classify_serial(qs, inputs.model, inputs.scratch, epoch, record_flags, stop_early, slot)


@njit(cache=True)
def classify_in(qs, inputs, epoch, record_flags, chunk):  # type: ignore[no-untyped-def]
    """:func:`classify` (threads) on a :class:`KernelInputs`."""
    return classify(qs, inputs.model, inputs.scratch, epoch, record_flags, chunk)
