"""Compiled kernel of the continuous check (:mod:`robocell.scene.swept`): whether the bodies,
each grown by a pad of its own, are clear at a configuration.

The same levels as the collision kernel (``_kernels``), each with the pads: the world's distance
grid and each obstacle's exact distance against a body's grown spheres; where a grown leaf
touches an obstacle, the body's own pieces (mesh triangles, primitives) against the obstacle
grown by the pad (a box or cylinder grown by the pad along each of its axes contains the
obstacle's points within the pad); a self pair's table, over every cell the piece's joints can
reach, or the two trees with the pad between them. Everything else the collision kernel
decides by (distance fields, inner spheres, rigid clusters) is of the bodies as they are, and
is not used: a pair it cannot prove clear here is simply not proven.

In a module of its own: numba's cache of a module's functions is dropped whenever the module's
file changes, and the collision kernels take minutes to compile.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from robocell.kinematics._kernels import fk_into
from robocell.scene._kernels import (
    EXACT_BUDGET,
    FIELD_PRIMITIVES,
    GJK_COST,
    GJK_FREE,
    INV_TWO_PI,
    MAX_VISITS,
    OBS_BOX,
    OBS_CYLINDER,
    OBS_TRIANGLE,
    PAIR_TAGS,
    TABLE_FREE,
    _centre,
    _obstacle_distance,
    _placed,
    _range_buffers,
    _slot,
    _triangle_into,
    _world_clear,
    gjk_intersect,
    triangle_box_overlap,
)

TABLE_CELLS = 64  # at most, of a table looked up for one piece (else the trees decide)


@njit(cache=True)
def _grown(kind, dims, pad, out):  # type: ignore[no-untyped-def]
    """out: the dims of an obstacle primitive grown by ``pad`` [m] along each axis (a box's
    half extents, a cylinder's radius and half length, a sphere's radius): it contains every
    point within ``pad`` of the obstacle."""
    out[0] = dims[0] + pad
    out[1] = dims[1] + pad if kind in (OBS_BOX, OBS_CYLINDER) else dims[1]
    out[2] = dims[2] + pad if kind == OBS_BOX else dims[2]


@njit(cache=True)
def _body_near_obstacle(
    b, nodes, left, right, body_root, TB, W, stamp, cur, kind, To, dims, pad, stack, exact,
    seen, tag, pieces,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Whether body b, grown by ``pad`` [m], may touch the obstacle (False: proven clear).
    ``exact``: (field_kind, prim_start, prim_kind, prim_T, prim_dims, body_mesh,
    node_tri_start, node_tri_ids, tri_V, tri_sphere) of the checker's model: where grown
    leaves touch, the body's pieces are tested against the obstacle grown by the pad, if
    ``pieces`` (else a touching leaf is the answer)."""
    (
        field_kind, prim_start, prim_kind, prim_T, prim_dims, body_mesh, node_tri_start,
        node_tri_ids, tri_V, tri_sphere,
    ) = exact  # fmt: skip
    big = np.empty(3)
    _grown(kind, dims, pad, big)
    R = TB[b, :, :3]
    t = TB[b, :, 3]
    tri = np.empty((3, 4))
    tests = 0
    sp = 1
    stack[0] = body_root[b]
    while sp > 0:
        sp -= 1
        n = stack[sp]
        _centre(n, b, TB, nodes, W, stamp, cur)
        if _obstacle_distance(W[n, 0], W[n, 1], W[n, 2], kind, To, dims) > nodes[n, 3] + pad:
            continue
        if left[n] >= 0:
            if sp + 2 > stack.shape[0]:
                return True
            stack[sp] = left[n]
            stack[sp + 1] = right[n]
            sp += 2
            continue
        if not pieces:
            return True
        if field_kind[b] == FIELD_PRIMITIVES:
            # the body's solids, each against the grown obstacle, once
            Tp = np.empty((3, 4))
            for p in range(prim_start[b], prim_start[b + 1]):
                _placed(TB, b, prim_T[p], Tp)
                if gjk_intersect(prim_kind[p], Tp, prim_dims[p], kind, To, big) != GJK_FREE:
                    return True
            return False
        if not body_mesh[b]:
            return True
        for k in range(node_tri_start[n], node_tri_start[n + 1]):
            f = node_tri_ids[k]
            if seen[f] == tag:
                continue
            seen[f] = tag
            sx, sy, sz = tri_sphere[f, 0], tri_sphere[f, 1], tri_sphere[f, 2]
            x = R[0, 0] * sx + R[0, 1] * sy + R[0, 2] * sz + t[0]
            y = R[1, 0] * sx + R[1, 1] * sy + R[1, 2] * sz + t[1]
            z = R[2, 0] * sx + R[2, 1] * sy + R[2, 2] * sz + t[2]
            if _obstacle_distance(x, y, z, kind, To, dims) > tri_sphere[f, 3] + pad:
                continue
            tests += 1 if kind == OBS_BOX else GJK_COST
            if tests > EXACT_BUDGET:
                return True
            _triangle_into(R, t, tri_V[f], tri)
            if kind == OBS_BOX:
                if triangle_box_overlap(tri, To, big):
                    return True
            elif gjk_intersect(OBS_TRIANGLE, tri, dims, kind, To, big) != GJK_FREE:
                return True
    return False


@njit(cache=True)
def _trees_near(a, b, ra, rb, nodes, left, right, TB, W, stamp, cur, pad, stack):  # type: ignore[no-untyped-def]
    """Whether a leaf of a's tree and one of b's come within ``pad`` [m] of each other (True
    also when the descent runs past MAX_VISITS: unproven)."""
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
        rr = nodes[i, 3] + nodes[j, 3] + pad
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


@njit(cache=True)
def _table_free_around(q, moving, half, ti, table_vars, table_n, table_off, table_values):  # type: ignore[no-untyped-def]
    """Whether table ti says FREE in every cell within ``half`` [rad] of q in each of its
    moving variables (the cells as K._table_value indexes them), at most TABLE_CELLS cells."""
    n = table_n[ti]
    first = np.zeros(3, np.int64)
    count = np.ones(3, np.int64)
    nv = 0
    total = 1
    for c in range(3):
        v = table_vars[ti, c]
        if v < 0:
            break
        nv += 1
        h = half if moving[v] else 0.0
        x = (q[v] - h) * INV_TWO_PI
        x = (x - math.floor(x)) * n
        i0 = min(int(x), n - 1)
        i1 = int(math.floor(x + 2.0 * h * INV_TWO_PI * n * (1.0 + 1e-9) + 1e-9))
        first[c] = i0
        count[c] = min(i1 - i0 + 1, n)
        total *= count[c]
    if total > TABLE_CELLS:
        return False
    off = table_off[ti]
    for m in range(total):
        idx = 0
        r = m
        for c in range(nv):
            step = r % count[c]
            r //= count[c]
            idx = idx * n + (first[c] + step) % n
        cell = off + idx
        if (table_values[cell >> 2] >> ((cell & 3) << 1)) & 3 != TABLE_FREE:
            return False
    return True


@njit(cache=True)
def clear_with_pads(qs, half, model, scratch, epoch, body_rate, pair_rate, pieces_below):  # type: ignore[no-untyped-def]
    """(N,) bool: True where, at configuration qs[s] (group variables), every world pair's
    body grown by ``half[s] * body_rate[s, body]`` [m] is proven clear of its obstacle, and
    every self pair's bodies farther apart than ``half[s] * pair_rate[s, pair]``, or its table FREE
    over every cell within ``half[s]`` [rad] of qs[s]. A body's pieces are tested only
    when its pad is below ``pieces_below`` [m] (larger pads leave pieces farther than a
    leaf's size apart, which are the cheaper to halve). ``model``: the checker's
    (K.MODEL_FIELDS); stamps from ``epoch``; scratch slot 0."""
    group_idx, q_base, joints, root, parent, child, origin, jtype, axis, var, mult, offset = model[
        :12
    ]
    body_link, body_T, body_root, nodes, left, right = model[12:18]
    obs_kind, obs_T, obs_dims, obs_sphere = model[20:24]
    world_pairs, self_pairs = model[25], model[26]
    field_kind = model[28]
    exact = (field_kind,) + model[35:39] + model[39:44]
    pair_table, table_vars, table_n, table_off, table_values, group_table = model[44:50]
    group_start, _, group_count = model[50:53]
    world_frame, world_dims, world_values = model[-3], model[-2], model[-1]
    W, stamp, _, _, seen, _, T = _slot(scratch, 0)
    TB, q, stack, stack2, _, _, _, plain = _range_buffers(model)
    moving = np.zeros(q.shape[0], np.bool_)
    for i in range(group_idx.shape[0]):
        moving[group_idx[i]] = True
    B = body_link.shape[0]
    # per body: its grown bounding sphere clear of the whole world (1), not (0), not asked (−1)
    clear = np.empty(B, np.int8)
    N = qs.shape[0]
    out = np.zeros(N, np.bool_)
    for s in range(N):
        cur = epoch + s
        for i in range(group_idx.shape[0]):
            q[group_idx[i]] = qs[s, i]
        fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
        for b in range(B):
            L = T[body_link[b]]
            clear[b] = -1
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
        free = True
        for k in range(world_pairs.shape[0]):
            b, o = world_pairs[k, 0], world_pairs[k, 1]
            pad = half[s] * body_rate[s, b]
            r0 = body_root[b]
            if clear[b] < 0:
                _centre(r0, b, TB, nodes, W, stamp, cur)
                clear[b] = _world_clear(
                    W[r0, 0], W[r0, 1], W[r0, 2], nodes[r0, 3] + pad, world_frame, world_dims,
                    world_values,
                )  # fmt: skip
            if clear[b] == 1:
                continue
            dx = W[r0, 0] - obs_sphere[o, 0]
            dy = W[r0, 1] - obs_sphere[o, 1]
            dz = W[r0, 2] - obs_sphere[o, 2]
            rr = nodes[r0, 3] + pad + obs_sphere[o, 3]
            if dx * dx + dy * dy + dz * dz > rr * rr:
                continue
            if _body_near_obstacle(
                b, nodes, left, right, body_root, TB, W, stamp, cur, obs_kind[o], obs_T[o],
                obs_dims[o], pad, stack, exact, seen, cur * PAIR_TAGS + k, pad < pieces_below,
            ):  # fmt: skip
                free = False
                break
        k = 0
        while free and k < self_pairs.shape[0]:
            g = group_start[k]
            if g >= 0 and group_table[g] >= 0:
                # a body against a rigid cluster's members, tabulated together
                if _table_free_around(
                    q, moving, half[s], group_table[g], table_vars, table_n, table_off,
                    table_values,
                ):  # fmt: skip
                    k += group_count[g]
                    continue
            if pair_table[k] >= 0 and _table_free_around(
                q, moving, half[s], pair_table[k], table_vars, table_n, table_off, table_values
            ):
                k += 1
                continue
            a, b = self_pairs[k, 0], self_pairs[k, 1]
            pad = half[s] * pair_rate[s, k]
            ra, rb = body_root[a], body_root[b]
            _centre(ra, a, TB, nodes, W, stamp, cur)
            _centre(rb, b, TB, nodes, W, stamp, cur)
            dx = W[ra, 0] - W[rb, 0]
            dy = W[ra, 1] - W[rb, 1]
            dz = W[ra, 2] - W[rb, 2]
            rr = nodes[ra, 3] + nodes[rb, 3] + pad
            if dx * dx + dy * dy + dz * dz > rr * rr:
                k += 1
                continue
            if _trees_near(a, b, ra, rb, nodes, left, right, TB, W, stamp, cur, pad, stack2):
                free = False
            k += 1
        out[s] = free
    return out


@njit(cache=True)
def clear_with_pads_in(qs, half, inputs, epoch, body_rate, pair_rate, pieces_below):  # type: ignore[no-untyped-def]
    """:func:`clear_with_pads` on a K.KernelInputs."""
    return clear_with_pads(
        qs, half, inputs.model, inputs.scratch, epoch, body_rate, pair_rate, pieces_below
    )
