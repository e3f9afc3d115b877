"""Compiled collision kernels over sphere trees (see :mod:`robocell.scene.spheres`).

Per state the answer is FREE (certain: no leaf touches), HIT (certain: an inner sphere touches)
or UNSURE (leaves touch, inner spheres do not): the caller settles UNSURE pairs exactly.
Node centres are moved to the world lazily, once per state (a stamp marks those done).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from robocell.kinematics._kernels import fk_into

FREE, HIT, UNSURE = 0, 1, 2
OBS_BOX, OBS_CYLINDER, OBS_SPHERE = 0, 1, 2


@njit(cache=True, inline="always")
def _obstacle_distance(x, y, z, kind, T, dims):  # type: ignore[no-untyped-def]
    """Distance from point (x, y, z) to a solid primitive at T (0 inside)."""
    dx, dy, dz = x - T[0, 3], y - T[1, 3], z - T[2, 3]
    lx = T[0, 0] * dx + T[1, 0] * dy + T[2, 0] * dz
    ly = T[0, 1] * dx + T[1, 1] * dy + T[2, 1] * dz
    lz = T[0, 2] * dx + T[1, 2] * dy + T[2, 2] * dz
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
def _centre(n, b, TB, S, W, stamp, cur):  # type: ignore[no-untyped-def]
    """World centre of sphere n of body b (cached for the current state)."""
    if stamp[n] != cur:
        x, y, z = S[n, 0], S[n, 1], S[n, 2]
        for i in range(3):
            W[n, i] = TB[b, i, 0] * x + TB[b, i, 1] * y + TB[b, i, 2] * z + TB[b, i, 3]
        stamp[n] = cur


@njit(cache=True)
def _tree_touches_obstacle(b, root, nodes, left, right, TB, W, stamp, cur, kind, To, dims, stack):  # type: ignore[no-untyped-def]
    sp = 1
    stack[0] = root
    while sp > 0:
        sp -= 1
        n = stack[sp]
        _centre(n, b, TB, nodes, W, stamp, cur)
        if _obstacle_distance(W[n, 0], W[n, 1], W[n, 2], kind, To, dims) > nodes[n, 3]:
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


@njit(cache=True)
def _classify_state(  # type: ignore[no-untyped-def]
    TB,
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
    W,
    stamp,
    Wi,
    stamp_i,
    cur,
    stack,
    stack2,
    flags,
):
    """FREE / HIT / UNSURE for one state (body poses in TB). Unsure pairs are flagged
    (world pairs first, then self pairs) for the exact stage."""
    n_world = world_pairs.shape[0]
    unsure = False
    for k in range(n_world):
        b = world_pairs[k, 0]
        o = world_pairs[k, 1]
        # broadphase: the body's bounding sphere against the obstacle's
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
        unsure = True
        flags[k] = True
    for k in range(self_pairs.shape[0]):
        a = self_pairs[k, 0]
        b = self_pairs[k, 1]
        ra, rb = body_root[a], body_root[b]
        _centre(ra, a, TB, nodes, W, stamp, cur)
        _centre(rb, b, TB, nodes, W, stamp, cur)
        dx = W[ra, 0] - W[rb, 0]
        dy = W[ra, 1] - W[rb, 1]
        dz = W[ra, 2] - W[rb, 2]
        rr = nodes[ra, 3] + nodes[rb, 3]
        if dx * dx + dy * dy + dz * dz > rr * rr:
            continue
        # inner spheres first: overlapping solids are a hit, however deep (a link inside
        # another's shell has no crossing surfaces, and would make the descent exhaustive)
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
                    return HIT
        if not _trees_touch(a, b, ra, rb, nodes, left, right, TB, W, stamp, cur, stack2):
            continue
        unsure = True
        flags[n_world + k] = True
    return UNSURE if unsure else FREE


@njit(cache=True)
def _classify_range(  # type: ignore[no-untyped-def]
    s0,
    s1,
    qs,
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
    W,
    stamp,
    Wi,
    stamp_i,
    T,
    epoch,
    flags,
    record_flags,
    scratch_row,
    out,
):
    """Classify states s0..s1-1 with one thread's scratch (W, stamp, Wi, stamp_i, T).
    Stamps hold ``epoch + s`` for the state that last placed a sphere, so the scratch is
    reused across calls without being reset."""
    B = body_link.shape[0]
    TB = np.empty((B, 3, 4))
    q = q_base.copy()
    stack = np.empty(256, np.int64)
    stack2 = np.empty((512, 2), np.int64)
    for s in range(s0, s1):
        for i in range(group_idx.shape[0]):
            q[group_idx[i]] = qs[s, i]
        fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
        for b in range(B):
            L = T[body_link[b]]
            for i in range(3):
                for j in range(4):
                    TB[b, i, j] = (
                        L[i, 0] * body_T[b, 0, j]
                        + L[i, 1] * body_T[b, 1, j]
                        + L[i, 2] * body_T[b, 2, j]
                        + (L[i, 3] if j == 3 else 0.0)
                    )
        out[s] = _classify_state(
            TB,
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
            W,
            stamp,
            Wi,
            stamp_i,
            epoch + s,
            stack,
            stack2,
            flags[s] if record_flags else scratch_row,
        )


@njit(cache=True, parallel=True)
def classify(  # type: ignore[no-untyped-def]
    qs,
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
    W,
    stamp,
    Wi,
    stamp_i,
    T,
    epoch,
    record_flags,
    chunk,
):
    """(N,) int8 FREE/HIT/UNSURE for (N, dof) group configurations, and (N, P) flags of the
    unsure pairs of each unsure state ((0, P) unless ``record_flags``).

    W, stamp, Wi, stamp_i, T are per-thread scratch (leading axis: thread slot), kept by the
    caller between calls: allocating them per call cost more than classifying a few states.
    One chunk runs serially in the calling thread; more are spread over the threads."""
    N = qs.shape[0]
    out = np.empty(N, np.int8)
    P = world_pairs.shape[0] + self_pairs.shape[0]
    n_chunks = (N + chunk - 1) // chunk
    flags = np.zeros((N if record_flags else 0, P), np.bool_)
    scratch = np.zeros((W.shape[0], 0 if record_flags else P), np.bool_)
    if n_chunks <= 1:
        _classify_range(
            0,
            N,
            qs,
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
            W[0],
            stamp[0],
            Wi[0],
            stamp_i[0],
            T[0],
            epoch,
            flags,
            record_flags,
            scratch[0],
            out,
        )
        return out, flags
    for c in prange(n_chunks):
        t = numba.get_thread_id()
        _classify_range(
            c * chunk,
            min(N, (c + 1) * chunk),
            qs,
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
            W[t],
            stamp[t],
            Wi[t],
            stamp_i[t],
            T[t],
            epoch,
            flags,
            record_flags,
            scratch[t],
            out,
        )
    return out, flags
