"""Compiled kernel of the continuous check (:mod:`robocell.scene.swept`): whether the bodies,
each grown by a pad of its own, are clear at a configuration.

The same levels as the collision kernel (``_kernels``), each with the pads: the world's distance
grid against a body's (or a rigid cluster's union's) grown bounding sphere, then each
obstacle's exact distance against its grown sphere tree; where a grown leaf touches an
obstacle, the body's own pieces (mesh triangles, primitives) against the obstacle grown by the
pad (a box or cylinder grown by the pad along each of its axes contains the obstacle's points
within the pad); for a self pair, its table over every cell the part's joints can reach, else
one body's distance field against the other's grown tree, else both trees with the pad between
them. Inner spheres are not used (a hit is not the question here): a pair these cannot prove
clear is simply not proven, and the part is halved.

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
    EXACT_TOL,
    FIELD_PRIMITIVES,
    GJK_COST,
    GJK_FREE,
    INV_TWO_PI,
    NRT_OFF,
    OBS_BOX,
    OBS_CYLINDER,
    OBS_TRIANGLE,
    PAIR_TAGS,
    TABLE_FREE,
    _centre,
    _field_bound,
    _obstacle_distance,
    _placed,
    _range_buffers,
    _relative_pose,
    _slot,
    _tree_touches_sphere,
    _triangle_copy,
    _triangle_into,
    _world_clear,
    gjk_intersect,
    gjk_within,
    place_bodies,
    triangle_box_overlap,
)

# the kinds of a path's pieces (SweptPath.piece_arrays)
SEGMENT, ARC, CUBIC = 0, 1, 2
TABLE_CELLS = 64  # at most, of a table looked up for one piece (else the trees decide)
# triangle tests (GJK_COST each) a self pair's exact stage may make per state: two links that
# skim each other (the UR5's wrist 2 and forearm) meet thousands of triangle pairs within the
# pads, so the part is halved instead, down to the self tolerance
SELF_BUDGET = 1024
# what clear_with_pads says of a part: not proven free; proven; proven but for self pairs
# whose pads are within the self tolerance (free if its middle is)
UNPROVEN, PROVEN, NEAR = 0, 1, 2


@njit(cache=True, inline="always")
def _push_children(stack, sp, n, left, right):  # type: ignore[no-untyped-def]
    """The stack's new top after pushing node n's two children, or -1 if it is full (the
    callers then answer "not proven")."""
    if sp + 2 > stack.shape[0]:
        return -1
    stack[sp] = left[n]
    stack[sp + 1] = right[n]
    return sp + 2


@njit(cache=True, inline="always")
def _moved(R, t, p, i):  # type: ignore[no-untyped-def]
    """Point p[i, :3] moved by rotation R and translation t, as (x, y, z)."""
    x, y, z = p[i, 0], p[i, 1], p[i, 2]
    return (
        R[0, 0] * x + R[0, 1] * y + R[0, 2] * z + t[0],
        R[1, 0] * x + R[1, 1] * y + R[1, 2] * z + t[1],
        R[2, 0] * x + R[2, 1] * y + R[2, 2] * z + t[2],
    )


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
    seen, tag, pieces, big, tri, Tp,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Whether body b, grown by ``pad`` [m], may touch the obstacle (False: proven clear).
    ``exact``: (field_kind, prim_start, prim_kind, prim_T, prim_dims, body_mesh,
    node_tri_start, node_tri_ids, tri_V, tri_sphere) of the checker's model: where grown
    leaves touch, the body's pieces are tested against the obstacle grown by the pad, if
    ``pieces`` (else a touching leaf is the answer). ``big`` (3,), ``tri`` and ``Tp`` (3×4):
    work arrays."""
    (
        field_kind, prim_start, prim_kind, prim_T, prim_dims, body_mesh, node_tri_start,
        node_tri_ids, tri_V, tri_sphere,
    ) = exact  # fmt: skip
    _grown(kind, dims, pad, big)
    R = TB[b, :, :3]
    t = TB[b, :, 3]
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
            sp = _push_children(stack, sp, n, left, right)
            if sp < 0:
                return True
            continue
        if not pieces:
            return True
        if field_kind[b] == FIELD_PRIMITIVES:
            # the body's solids, each against the grown obstacle, once
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
            x, y, z = _moved(R, t, tri_sphere, f)
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
def _body_near_body(
    f, d, use_field, gap, TB, body_root, nodes, left, right, fields, exact, R, t, stack,
    stack_f, seen, tag, tri_d, tri_f,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Whether bodies f and d may come within ``gap`` [m] of each other (False: proven
    apart). d's tree is descended in f's frame against f's distance field (``use_field``) or
    f's tree; where a leaf of d comes near, its triangles are tested exactly against f's
    primitives, or against the triangles of f's leaves near them (GJK with the gap as margin),
    within SELF_BUDGET. ``fields``/``exact``: the model's arrays (see clear_with_pads);
    R (3, 3), t (3,), tri_d, tri_f (3, 4): work arrays; ``seen[tri] == tag`` marks d's
    triangles tested in this call."""
    (
        field_kind, prim_start, prim_kind, prim_T, prim_dims, body_mesh, node_tri_start,
        node_tri_ids, tri_V, tri_sphere,
    ) = exact  # fmt: skip
    _relative_pose(TB, f, d, R, t)
    margin = gap + EXACT_TOL
    settle = body_mesh[d] and (field_kind[f] == FIELD_PRIMITIVES or body_mesh[f])
    tests = 0
    sp = 1
    stack[0] = body_root[d]
    while sp > 0:
        sp -= 1
        n = stack[sp]
        x, y, z = _moved(R, t, nodes, n)
        if use_field:
            (
                fk, grid_origin, grid_box, grid_h, grid_dims, grid_off, grid_values, ps, pk,
                pT, pd,
            ) = fields  # fmt: skip
            bound = _field_bound(
                x, y, z, f, fk, grid_origin, grid_box, grid_h, grid_dims, grid_off,
                grid_values, ps, pk, pT, pd,
            )  # fmt: skip
            if bound > nodes[n, 3] + gap:
                continue
        elif not _tree_touches_sphere(
            body_root[f], nodes, left, right, x, y, z, nodes[n, 3] + gap, stack_f
        ):
            continue
        if left[n] >= 0:
            sp = _push_children(stack, sp, n, left, right)
            if sp < 0:
                return True
            continue
        if not settle:
            return True
        for i in range(node_tri_start[n], node_tri_start[n + 1]):
            u = node_tri_ids[i]
            if seen[u] == tag:
                continue
            seen[u] = tag
            _triangle_into(R, t, tri_V[u], tri_d)
            if field_kind[f] == FIELD_PRIMITIVES:
                for p in range(prim_start[f], prim_start[f + 1]):
                    tests += GJK_COST
                    if (
                        gjk_within(OBS_TRIANGLE, tri_d, prim_dims[p], prim_kind[p], prim_T[p],
                                   prim_dims[p], margin) != GJK_FREE
                    ):  # fmt: skip
                        return True
            else:
                # f's leaves near the triangle's bounding sphere, their triangles one by one
                wx, wy, wz = _moved(R, t, tri_sphere, u)
                reach = tri_sphere[u, 3] + gap
                fp = 1
                stack_f[0] = body_root[f]
                while fp > 0:
                    fp -= 1
                    m = stack_f[fp]
                    dx, dy, dz = wx - nodes[m, 0], wy - nodes[m, 1], wz - nodes[m, 2]
                    rr = reach + nodes[m, 3]
                    if dx * dx + dy * dy + dz * dz > rr * rr:
                        continue
                    if left[m] >= 0:
                        fp = _push_children(stack_f, fp, m, left, right)
                        if fp < 0:
                            return True
                        continue
                    for j in range(node_tri_start[m], node_tri_start[m + 1]):
                        tests += GJK_COST
                        if tests > SELF_BUDGET:
                            return True
                        _triangle_copy(tri_V[node_tri_ids[j]], tri_f)
                        if (
                            gjk_within(OBS_TRIANGLE, tri_d, tri_d[:, 3], OBS_TRIANGLE, tri_f,
                                       tri_f[:, 3], margin) != GJK_FREE
                        ):  # fmt: skip
                            return True
            if tests > SELF_BUDGET:
                return True
    return False


@njit(cache=True, inline="always")
def _cells(q, moving, half, v, n):  # type: ignore[no-untyped-def]
    """(first cell, count) of variable v's cells (n over 2π) within ``half`` [rad] of q[v]
    if it moves, else its one cell (as K._table_value indexes them)."""
    h = half if moving[v] else 0.0
    x = (q[v] - h) * INV_TWO_PI
    x = (x - math.floor(x)) * n
    i0 = min(int(x), n - 1)
    i1 = int(math.floor(x + 2.0 * h * INV_TWO_PI * n * (1.0 + 1e-9) + 1e-9))
    return i0, min(i1 - i0 + 1, n)


@njit(cache=True)
def _table_free_around(q, moving, half, ti, table_vars, table_n, table_off, table_values):  # type: ignore[no-untyped-def]
    """Whether table ti says FREE in every cell within ``half`` [rad] of q in each of its
    moving variables (one to three), at most TABLE_CELLS cells."""
    n = table_n[ti]
    f0, c0 = _cells(q, moving, half, table_vars[ti, 0], n)
    f1, c1, f2, c2 = 0, 1, 0, 1
    nv = 1
    if table_vars[ti, 1] >= 0:
        f1, c1 = _cells(q, moving, half, table_vars[ti, 1], n)
        nv = 2
        if table_vars[ti, 2] >= 0:
            f2, c2 = _cells(q, moving, half, table_vars[ti, 2], n)
            nv = 3
    if c0 * c1 * c2 > TABLE_CELLS:
        return False
    off = table_off[ti]
    for i in range(c0):
        for j in range(c1):
            for k in range(c2):
                idx = (f0 + i) % n
                if nv > 1:
                    idx = idx * n + (f1 + j) % n
                if nv > 2:
                    idx = idx * n + (f2 + k) % n
                cell = off + idx
                if (table_values[cell >> 2] >> ((cell & 3) << 1)) & 3 != TABLE_FREE:
                    return False
    return True


@njit(cache=True)
def _pads(
    b, T, TB, nodes, body_root, W, stamp, cur, chain, revolute, child, axis, w, tail, hh,
    contrib,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Body b's pad [m] over a part of half length ``hh`` [rad] around the configuration whose
    link poses are T: Σ over the joints k on its chain (``chain[b]``, from the body towards
    the root) of w_k (d_k + hh·tail_k), where w_k bounds the joint's speed, d_k is how far the
    body's bounding sphere reaches from the joint's axis here, and hh·tail_k bounds how much
    farther the joints below k can take it within the part (a joint's own turn keeps the
    distance to its axis). A prismatic joint moves the body w_k. Each term goes to
    ``contrib[b]`` (for the self pairs), the sum times hh is returned."""
    r0 = body_root[b]
    _centre(r0, b, TB, nodes, W, stamp, cur)
    cx, cy, cz, rb = W[r0, 0], W[r0, 1], W[r0, 2], nodes[r0, 3]
    total = 0.0
    for i in range(chain.shape[1]):
        k = chain[b, i]
        if k < 0:
            break
        wk = w[k]
        if wk == 0.0:
            contrib[b, i] = 0.0
            continue
        if revolute[k]:
            L = child[k]
            ax = T[L, 0, 0] * axis[k, 0] + T[L, 0, 1] * axis[k, 1] + T[L, 0, 2] * axis[k, 2]
            ay = T[L, 1, 0] * axis[k, 0] + T[L, 1, 1] * axis[k, 1] + T[L, 1, 2] * axis[k, 2]
            az = T[L, 2, 0] * axis[k, 0] + T[L, 2, 1] * axis[k, 1] + T[L, 2, 2] * axis[k, 2]
            dx, dy, dz = cx - T[L, 0, 3], cy - T[L, 1, 3], cz - T[L, 2, 3]
            ex = dy * az - dz * ay
            ey = dz * ax - dx * az
            ez = dx * ay - dy * ax
            c = wk * (math.sqrt(ex * ex + ey * ey + ez * ez) + rb + hh * tail[b, i])
        else:
            c = wk
        contrib[b, i] = c
        total += c
    return hh * total


@njit(cache=True, inline="always")
def _pad_of(
    b, static, pad, T, TB, nodes, body_root, W, stamp, cur, chain, revolute, child, axis,
    speed, tail, hh, contrib,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Body b's pad at this state (computed once: ``pad[b]`` < 0 until then): the smaller of
    its bound everywhere, ``static``, and :func:`_pads` (which fills ``contrib[b]``)."""
    if pad[b] < 0.0:
        pad[b] = min(
            static,
            _pads(
                b, T, TB, nodes, body_root, W, stamp, cur, chain, revolute, child, axis,
                speed, tail, hh, contrib,
            ),
        )  # fmt: skip
    return pad[b]


@njit(cache=True, inline="always")
def _clear_of_world(
    b, static, clear, pad, T, TB, nodes, body_root, W, stamp, cur, chain, revolute, child,
    axis, speed, tail, hh, contrib, world_frame, world_dims, world_values,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Whether body b's bounding sphere grown by its pad is clear of the whole world
    (K._world_clear), asked once per state (``clear[b]``: 1, 0, or −1 not yet): with the
    bound everywhere (``static``) first, its own pad only if that is not enough (so a body
    not clear has its pad known: ``pad[b]``)."""
    if clear[b] < 0:
        r0 = body_root[b]
        _centre(r0, b, TB, nodes, W, stamp, cur)
        x, y, z, r = W[r0, 0], W[r0, 1], W[r0, 2], nodes[r0, 3]
        if _world_clear(x, y, z, r + static, world_frame, world_dims, world_values):
            clear[b] = 1
        else:
            grown = r + _pad_of(
                b, static, pad, T, TB, nodes, body_root, W, stamp, cur, chain, revolute,
                child, axis, speed, tail, hh, contrib,
            )  # fmt: skip
            clear[b] = (
                1 if _world_clear(x, y, z, grown, world_frame, world_dims, world_values) else 0
            )
    return clear[b] == 1


@njit(cache=True)
def clear_with_pads(
    qs, half, part, model, scratch, epoch, speed, tail, chain, revolute, own_a, own_b,
    body_rate, pair_rate, pieces_below, self_tolerance,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """(N,) bool: True where, at configuration qs[s] (group variables), the middle of a part
    of the path of half length ``half[s]`` [rad] on path piece ``part[s]``, every world pair's
    body grown by its pad is proven clear of its obstacle, and every self pair's bodies
    farther apart than their pads, or its table FREE over every cell within ``half[s]`` of
    qs[s] (:func:`_pads`: ``speed[piece]`` (J,) bounds each tree joint's speed on the piece,
    ``tail[piece]`` (B, C) the speeds of the joints below each chain joint times how far they
    move the body; ``chain`` (B, C) the group's joints from each body to the root, −1 after;
    ``own_a``/``own_b`` (P, C): which of the chain joints of a self pair's first and second
    body the other's chain lacks), and at most ``half[s]`` times ``body_rate[piece]`` (B,) and
    ``pair_rate[piece]`` (P,), bounds that hold everywhere. (N,) int8: UNPROVEN, PROVEN, or
    NEAR: proven but for self pairs whose pads are at most ``self_tolerance`` [m] (the part is
    free to that depth if its middle is free). A body's pieces are tested only
    when its pad is below ``pieces_below`` [m] (larger pads leave pieces farther than a
    leaf's size apart, which are the cheaper to halve). ``model``: the checker's
    (K.MODEL_FIELDS); stamps from ``epoch``; scratch slot 0."""
    group_idx = model[0]
    moving = np.zeros(model[1].shape[0], np.bool_)
    for i in range(group_idx.shape[0]):
        moving[group_idx[i]] = True
    B = model[12].shape[0]
    work = (
        np.empty(B, np.int8),  # per body: grown sphere clear of the world (1), not (0), unasked
        np.empty(B),  # per body: its pad
        np.zeros(chain.shape),  # per body and chain joint: its share of the pad (_pads)
        np.empty(3),
        np.empty((3, 4)),
        np.empty((3, 4)),
        moving,
        np.empty((3, 3)),
        np.empty(3),
        np.empty((3, 4)),
    )
    out = np.zeros(qs.shape[0], np.int8)
    _clear_states(
        qs, half, part, model, scratch, epoch, speed, tail, chain, revolute, own_a, own_b,
        body_rate, pair_rate, pieces_below, self_tolerance, _range_buffers(model), work, out,
    )  # fmt: skip
    return out


# Compiled without numba's reference counting, as K._classify_range is (and for the same
# reason: counting the references to the arrays passed to the helpers, for each pair of each
# state, cost more than the tests; measured 3.8 against 1.5 µs a state): it allocates nothing.
@njit(cache=True, **NRT_OFF)
def _clear_states(
    qs, half, part, model, scratch, epoch, speed, tail, chain, revolute, own_a, own_b,
    body_rate, pair_rate, pieces_below, self_tolerance, buffers, work, out,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """:func:`clear_with_pads`' loop over the states, into ``out``."""
    group_idx, q_base, joints, root, parent, child, origin, jtype, axis, var, mult, offset = model[
        :12
    ]
    body_link, body_T, body_root, nodes, left, right = model[12:18]
    obs_kind, obs_T, obs_dims, obs_sphere = model[20:24]
    world_pairs, self_pairs = model[25], model[26]
    pair_field, field_kind = model[27], model[28]
    exact = (field_kind,) + model[35:39] + model[39:44]
    fields = (field_kind,) + model[29:35] + model[35:39]
    pair_table, table_vars, table_n, table_off, table_values, group_table = model[44:50]
    group_start, _, group_count = model[50:53]
    world_frame, world_dims, world_values = model[-3], model[-2], model[-1]
    world_group_start, world_group_union, world_group_count, world_run_end = model[-7:-3]
    W, stamp, _, _, seen, _, T = _slot(scratch, 0)
    blocks, q, stack, stack2, stack3, _, _, plain, _, _, _ = buffers
    TB = blocks[0]  # one state at a time here
    clear, pad, contrib, big, tri, Tp, moving, R3, t3, tri_f = work
    B = body_link.shape[0]
    N = qs.shape[0]
    for s in range(N):
        cur = epoch + s
        hh = half[s]
        p = part[s]
        for i in range(group_idx.shape[0]):
            q[group_idx[i]] = qs[s, i]
        fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
        place_bodies(T, body_link, body_T, plain, TB)
        for b in range(B):
            clear[b] = -1
            pad[b] = -1.0  # not yet known (_pad_of)
        free = True
        near = False  # a self pair closer than self_tolerance, not proven apart
        skip_to = 0
        for k in range(world_pairs.shape[0]):
            if k < skip_to:
                continue
            b, o = world_pairs[k, 0], world_pairs[k, 1]
            g = world_group_start[k]
            if g >= 0:
                # pairs k … k + count − 1: a rigid cluster's members against obstacle o; its
                # union's grown sphere clear of the world, or of o, clears them all
                u = world_group_union[g]
                if _clear_of_world(
                    u, hh * body_rate[p, u], clear, pad, T, TB, nodes, body_root, W, stamp,
                    cur, chain, revolute, child, axis, speed[p], tail[p], hh, contrib,
                    world_frame, world_dims, world_values,
                ):  # fmt: skip
                    skip_to = world_run_end[k]
                    continue
                ru = body_root[u]
                pu = pad[u]  # known: the union was not clear with its static pad
                dx = W[ru, 0] - obs_sphere[o, 0]
                dy = W[ru, 1] - obs_sphere[o, 1]
                dz = W[ru, 2] - obs_sphere[o, 2]
                rr = nodes[ru, 3] + pu + obs_sphere[o, 3]
                if (
                    dx * dx + dy * dy + dz * dz > rr * rr
                    or _obstacle_distance(
                        W[ru, 0], W[ru, 1], W[ru, 2], obs_kind[o], obs_T[o], obs_dims[o]
                    )
                    > nodes[ru, 3] + pu
                ):
                    skip_to = k + world_group_count[g]
                    continue
            if _clear_of_world(
                b, hh * body_rate[p, b], clear, pad, T, TB, nodes, body_root, W, stamp, cur,
                chain, revolute, child, axis, speed[p], tail[p], hh, contrib, world_frame,
                world_dims, world_values,
            ):  # fmt: skip
                if g < 0:
                    skip_to = world_run_end[k]
                continue
            r0 = body_root[b]
            dx = W[r0, 0] - obs_sphere[o, 0]
            dy = W[r0, 1] - obs_sphere[o, 1]
            dz = W[r0, 2] - obs_sphere[o, 2]
            rr = nodes[r0, 3] + pad[b] + obs_sphere[o, 3]
            if dx * dx + dy * dy + dz * dz > rr * rr:
                continue
            if _body_near_obstacle(
                b, nodes, left, right, body_root, TB, W, stamp, cur, obs_kind[o], obs_T[o],
                obs_dims[o], pad[b], stack, exact, seen, cur * PAIR_TAGS + k,
                pad[b] < pieces_below, big, tri, Tp,
            ):  # fmt: skip
                free = False
                break
        k = 0
        while free and k < self_pairs.shape[0]:
            g = group_start[k]
            if g >= 0 and group_table[g] >= 0:
                # a body against a rigid cluster's members, tabulated together
                if _table_free_around(
                    q, moving, hh, group_table[g], table_vars, table_n, table_off,
                    table_values,
                ):  # fmt: skip
                    k += group_count[g]
                    continue
            if pair_table[k] >= 0 and _table_free_around(
                q, moving, hh, pair_table[k], table_vars, table_n, table_off, table_values
            ):
                k += 1
                continue
            a, b = self_pairs[k, 0], self_pairs[k, 1]
            for x in (a, b):
                _pad_of(
                    x, hh * body_rate[p, x], pad, T, TB, nodes, body_root, W, stamp, cur,
                    chain, revolute, child, axis, speed[p], tail[p], hh, contrib,
                )  # fmt: skip
            gap = 0.0
            for i in range(chain.shape[1]):
                if own_a[k, i]:
                    gap += contrib[a, i]
                if own_b[k, i]:
                    gap += contrib[b, i]
            gap = min(gap * hh, hh * pair_rate[p, k])
            ra, rb = body_root[a], body_root[b]
            _centre(ra, a, TB, nodes, W, stamp, cur)
            _centre(rb, b, TB, nodes, W, stamp, cur)
            dx = W[ra, 0] - W[rb, 0]
            dy = W[ra, 1] - W[rb, 1]
            dz = W[ra, 2] - W[rb, 2]
            rr = nodes[ra, 3] + nodes[rb, 3] + gap
            if dx * dx + dy * dy + dz * dz > rr * rr:
                k += 1
                continue
            m = pair_field[k]
            f, d = (b, a) if m == 1 else (a, b)  # f: the body whose field is used, if any
            if _body_near_body(
                f, d, m >= 0, gap, TB, body_root, nodes, left, right, fields, exact, R3, t3,
                stack, stack3, seen, cur * PAIR_TAGS + world_pairs.shape[0] + k, tri, tri_f,
            ):  # fmt: skip
                if gap <= self_tolerance:
                    near = True
                else:
                    free = False
            k += 1
        out[s] = (NEAR if near else PROVEN) if free else UNPROVEN


@njit(cache=True, inline="always")
def _point(s, k, starts, origin, d1, d2, d3, radius, kind, out):  # type: ignore[no-untyped-def]
    """out (dof,): the path's position at arc length s on its piece k (piece_arrays)."""
    x = s - starts[k]
    if kind[k] == ARC:
        r = radius[k]
        a, b = r * math.cos(x / r), r * math.sin(x / r)
        for j in range(out.shape[0]):
            out[j] = origin[k, j] + a * d1[k, j] + b * d2[k, j]
    elif kind[k] == CUBIC:
        for j in range(out.shape[0]):
            out[j] = origin[k, j] + x * (d1[k, j] + x * (d2[k, j] + x * d3[k, j]))
    else:
        for j in range(out.shape[0]):
            out[j] = origin[k, j] + x * d1[k, j]


@njit(cache=True)
def prove_parts(
    s0, h, seg, level, last, limit, budget, pieces, inputs, epoch, speed, tail, chain, revolute,
    own_a, own_b, body_rate, pair_rate, pieces_below, self_tolerance,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Parts of a path (from arc length s0 over h, on piece seg) tested with pads at their
    middles (:func:`clear_with_pads`), those not proven halved, level after level: from
    ``level`` until none is left, or ``last`` is reached, or more than ``limit`` are left, or
    the next level would take the states tested past ``budget``.
    Returns (s0, h, seg) of the parts left, halved (their middles are s0 + h: the caller
    checks those), the level they were left at, the states tested, and the middles (s, seg)
    of the parts proven NEAR (the caller checks those too). ``pieces``: the path's
    piece_arrays(); stamps from ``epoch`` on (one per state tested)."""
    starts, origin, d1, d2, d3, radius, kind = pieces
    dof = origin.shape[1]
    tests = 0
    near_s = np.empty(0)
    near_seg = np.empty(0, np.int64)
    while True:
        n = s0.shape[0]
        qs = np.empty((n, dof))
        half = 0.5 * h
        for i in range(n):
            _point(s0[i] + half[i], seg[i], starts, origin, d1, d2, d3, radius, kind, qs[i])
        said = clear_with_pads(
            qs, half, seg, inputs.model, inputs.scratch, epoch + tests, speed, tail, chain,
            revolute, own_a, own_b, body_rate, pair_rate, pieces_below, self_tolerance,
        )  # fmt: skip
        tests += n
        near = said == NEAR
        if near.any():
            near_s = np.concatenate((near_s, s0[near] + half[near]))
            near_seg = np.concatenate((near_seg, seg[near]))
        keep = said == UNPROVEN
        s0, h, seg = s0[keep], half[keep], seg[keep]
        if (
            s0.shape[0] == 0
            or level >= last
            or s0.shape[0] > limit
            or tests + 2 * s0.shape[0] > budget
        ):
            return s0, h, seg, level, tests, near_s, near_seg
        s0 = np.concatenate((s0, s0 + h))
        h = np.concatenate((h, h))
        seg = np.concatenate((seg, seg))
        level += 1


@njit(cache=True)
def path_parts(starts, bounds, body_radii, pair_radii, joint_column, gain, R, chain, first_pad):  # type: ignore[no-untyped-def]
    """What :func:`prove_parts` takes for a path of S pieces (``starts`` (S + 1,), joint
    speed ``bounds`` (S, dof)): per piece, each body's and self pair's speed bound everywhere
    (S, B), (S, P) [m per rad of s]; each tree joint's speed bound (S, J); per body and chain
    joint, how fast the joints below it move the body (S, B, C) (:func:`_pads`); and the
    first parts (s0, h, seg): each piece cut into equal parts whose pads are at most
    ``first_pad`` [m] by the bounds everywhere."""
    S, dof = bounds.shape
    B, C = chain.shape
    body = bounds @ body_radii.T
    pair = bounds @ pair_radii.T
    J = joint_column.shape[0]
    speed = np.zeros((S, J))
    for k in range(S):
        for j in range(J):
            if joint_column[j] >= 0:
                speed[k, j] = bounds[k, joint_column[j]] * gain[j]
    tail = np.zeros((S, B, C))
    for k in range(S):
        for b in range(B):
            below = 0.0
            for i in range(C):
                j = chain[b, i]
                if j < 0:
                    break
                tail[k, b, i] = below
                below += speed[k, j] * R[b, j]
    counts = np.zeros(S, np.int64)
    for k in range(S):
        length = starts[k + 1] - starts[k]
        if length <= 0.0:
            continue
        fastest = 0.0
        for b in range(body.shape[1]):
            fastest = max(fastest, body[k, b])
        for p in range(pair.shape[1]):
            fastest = max(fastest, pair[k, p])
        if fastest <= 0.0:
            counts[k] = 1
        else:
            counts[k] = max(1, int(math.ceil(length * fastest / (2.0 * first_pad))))
    n = counts.sum()
    s0 = np.empty(n)
    h = np.empty(n)
    seg = np.empty(n, np.int64)
    i = 0
    for k in range(S):
        if counts[k] == 0:
            continue
        step = (starts[k + 1] - starts[k]) / counts[k]
        for m in range(counts[k]):
            s0[i] = starts[k] + m * step
            h[i] = step
            seg[i] = k
            i += 1
    return body, pair, speed, tail, s0, h, seg
