"""Compiled (numba) kernels over a :class:`robocell.robot.KinematicTree`'s arrays.

Every kernel takes the tree as plain arrays so that numba compiles it once for all robots:
``parent, child, origin, jtype, axis, var, mult, offset`` (see KinematicTree). ``joints`` is the
subset of joint indices to evaluate (in tree order): only the links on those joints' paths get
valid poses, which is what makes single-frame FK cheap.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

FIXED, REVOLUTE, PRISMATIC = 0, 1, 2


@njit(cache=True, inline="always")
def _place_joint(T, k, parent, child, origin, jtype, axis, value):  # type: ignore[no-untyped-def]
    """T[child[k]] = T[parent[k]] @ origin[k] @ motion(k, value), written in place (in scalars:
    a temporary array per joint cost a third of a state's collision check, measured)."""
    p = parent[k]
    c = child[k]
    O = origin[k]
    t = jtype[k]
    r00 = r01 = r02 = r10 = r11 = r12 = r20 = r21 = r22 = 0.0
    if t == REVOLUTE:
        x, y, z = axis[k, 0], axis[k, 1], axis[k, 2]
        s, co = math.sin(value), math.cos(value)
        v = 1.0 - co
        r00, r01, r02 = co + x * x * v, x * y * v - z * s, x * z * v + y * s
        r10, r11, r12 = y * x * v + z * s, co + y * y * v, y * z * v - x * s
        r20, r21, r22 = z * x * v - y * s, z * y * v + x * s, co + z * z * v
    for i in range(3):
        t0, t1, t2 = T[p, i, 0], T[p, i, 1], T[p, i, 2]
        a0 = t0 * O[0, 0] + t1 * O[1, 0] + t2 * O[2, 0]
        a1 = t0 * O[0, 1] + t1 * O[1, 1] + t2 * O[2, 1]
        a2 = t0 * O[0, 2] + t1 * O[1, 2] + t2 * O[2, 2]
        a3 = t0 * O[0, 3] + t1 * O[1, 3] + t2 * O[2, 3] + T[p, i, 3]
        if t == REVOLUTE:
            T[c, i, 0] = a0 * r00 + a1 * r10 + a2 * r20
            T[c, i, 1] = a0 * r01 + a1 * r11 + a2 * r21
            T[c, i, 2] = a0 * r02 + a1 * r12 + a2 * r22
            T[c, i, 3] = a3
        else:
            T[c, i, 0] = a0
            T[c, i, 1] = a1
            T[c, i, 2] = a2
            T[c, i, 3] = a3
            if t == PRISMATIC:
                T[c, i, 3] += value * (a0 * axis[k, 0] + a1 * axis[k, 1] + a2 * axis[k, 2])
    T[c, 3, 0] = 0.0
    T[c, 3, 1] = 0.0
    T[c, 3, 2] = 0.0
    T[c, 3, 3] = 1.0


@njit(cache=True)
def fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T):  # type: ignore[no-untyped-def]
    """Poses of the links on ``joints``' paths for one full variable vector ``q``; T: (L, 4, 4)."""
    for i in range(4):
        for j in range(4):
            T[root, i, j] = 1.0 if i == j else 0.0
    for n in range(joints.shape[0]):
        k = joints[n]
        value = 0.0
        if var[k] >= 0:
            value = mult[k] * q[var[k]] + offset[k]
        _place_joint(T, k, parent, child, origin, jtype, axis, value)


@njit(cache=True, parallel=True)
def fk_batch(qs, joints, root, parent, child, origin, jtype, axis, var, mult, offset, n_links):  # type: ignore[no-untyped-def]
    """(N, L, 4, 4) link poses for (N, V) full variable vectors."""
    N = qs.shape[0]
    out = np.zeros((N, n_links, 4, 4))
    for s in prange(N):
        fk_into(qs[s], joints, root, parent, child, origin, jtype, axis, var, mult, offset, out[s])
    return out


@njit(cache=True, parallel=True)
def fk_batch_link(
    qs, joints, root, parent, child, origin, jtype, axis, var, mult, offset, n_links, link
):  # type: ignore[no-untyped-def]
    """(N, 4, 4) poses of one link for (N, V) full variable vectors."""
    N = qs.shape[0]
    out = np.empty((N, 4, 4))
    for s in prange(N):
        T = np.empty((n_links, 4, 4))
        fk_into(qs[s], joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
        out[s] = T[link]
    return out


@njit(cache=True)
def jacobian_into(T, joints, parent, origin, jtype, axis, var, mult, column, link, J):  # type: ignore[no-untyped-def]
    """Geometric Jacobian (6, n) of ``link``'s origin, in the root frame (linear; angular), with
    respect to the variables whose column (``column[var]``) is ≥ 0. T holds the link poses."""
    J[:, :] = 0.0
    px, py, pz = T[link, 0, 3], T[link, 1, 3], T[link, 2, 3]
    for n in range(joints.shape[0]):
        k = joints[n]
        if var[k] < 0 or column[var[k]] < 0 or jtype[k] == FIXED:
            continue
        col = column[var[k]]
        p = parent[k]
        # joint frame = T[parent] @ origin[k]; its axis and origin in the root frame
        zx = zy = zz = 0.0
        ox = oy = oz = 0.0
        for i in range(3):
            ri = 0.0
            oi = T[p, i, 3]
            for m in range(3):
                rim = (
                    T[p, i, 0] * origin[k, 0, m]
                    + T[p, i, 1] * origin[k, 1, m]
                    + T[p, i, 2] * origin[k, 2, m]
                )
                ri += rim * axis[k, m]
                oi += T[p, i, m] * origin[k, m, 3]
            if i == 0:
                zx, ox = ri, oi
            elif i == 1:
                zy, oy = ri, oi
            else:
                zz, oz = ri, oi
        m_ = mult[k]
        if jtype[k] == REVOLUTE:
            dx, dy, dz = px - ox, py - oy, pz - oz
            J[0, col] += m_ * (zy * dz - zz * dy)
            J[1, col] += m_ * (zz * dx - zx * dz)
            J[2, col] += m_ * (zx * dy - zy * dx)
            J[3, col] += m_ * zx
            J[4, col] += m_ * zy
            J[5, col] += m_ * zz
        else:
            J[0, col] += m_ * zx
            J[1, col] += m_ * zy
            J[2, col] += m_ * zz


@njit(cache=True, inline="always")
def _rotation_log(R):  # type: ignore[no-untyped-def]
    """Rotation vector (axis · angle) of a 3×3 rotation matrix, robust near 0 and π."""
    c = (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) * 0.5
    c = min(1.0, max(-1.0, c))
    angle = math.acos(c)
    wx = R[2, 1] - R[1, 2]
    wy = R[0, 2] - R[2, 0]
    wz = R[1, 0] - R[0, 1]
    out = np.empty(3)
    if angle < 1e-6:
        out[0], out[1], out[2] = 0.5 * wx, 0.5 * wy, 0.5 * wz
        return out
    if angle > math.pi - 1e-4:
        # near π: axis from the diagonal of (R + I) / 2 = a aᵀ
        xx = max(0.0, (R[0, 0] + 1.0) * 0.5)
        yy = max(0.0, (R[1, 1] + 1.0) * 0.5)
        zz = max(0.0, (R[2, 2] + 1.0) * 0.5)
        ax, ay, az = math.sqrt(xx), math.sqrt(yy), math.sqrt(zz)
        if ax >= ay and ax >= az:
            ay = math.copysign(ay, R[0, 1] + R[1, 0])
            az = math.copysign(az, R[0, 2] + R[2, 0])
        elif ay >= az:
            ax = math.copysign(ax, R[0, 1] + R[1, 0])
            az = math.copysign(az, R[1, 2] + R[2, 1])
        else:
            ax = math.copysign(ax, R[0, 2] + R[2, 0])
            ay = math.copysign(ay, R[1, 2] + R[2, 1])
        n = math.sqrt(ax * ax + ay * ay + az * az)
        out[0], out[1], out[2] = angle * ax / n, angle * ay / n, angle * az / n
        return out
    f = angle / (2.0 * math.sin(angle))
    out[0], out[1], out[2] = f * wx, f * wy, f * wz
    return out


@njit(cache=True, inline="always")
def _pose_error(T_target, T_tip, e):  # type: ignore[no-untyped-def]
    """e = (p_target − p_tip, log(R_target R_tipᵀ)) in the root frame; returns (|e_p|, |e_r|)."""
    for i in range(3):
        e[i] = T_target[i, 3] - T_tip[i, 3]
    R = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            R[i, j] = (
                T_target[i, 0] * T_tip[j, 0]
                + T_target[i, 1] * T_tip[j, 1]
                + T_target[i, 2] * T_tip[j, 2]
            )
    w = _rotation_log(R)
    e[3], e[4], e[5] = w[0], w[1], w[2]
    ep = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    er = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    return ep, er


@njit(cache=True)
def numeric_ik(  # type: ignore[no-untyped-def]
    T_target,
    q_full,
    group_idx,
    seeds,
    lower,
    upper,
    tip,
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
    n_links,
    tol_pos,
    tol_rot,
    max_iter,
    position_only,
):
    """Levenberg–Marquardt IK (Sugihara's damping λ = ½|e|² + ε) with restarts.

    ``seeds`` (R, n): the first row is the user's seed, the rest random restarts (drawn by the
    caller from its Generator). Each attempt iterates until the error is within (tol_pos [m],
    tol_rot [rad]) or it stalls; steps are clamped to the joint limits. Returns
    (q (n,), success, attempts used, iterations in all).
    """
    n = group_idx.shape[0]
    column = np.full(q_full.shape[0], -1, np.int64)
    for i in range(n):
        column[group_idx[i]] = i
    T = np.empty((n_links, 4, 4))
    J = np.empty((6, n))
    e = np.empty(6)
    q = q_full.copy()
    best = np.empty(n)
    total_iters = 0
    rows = 3 if position_only else 6
    for attempt in range(seeds.shape[0]):
        for i in range(n):
            q[group_idx[i]] = min(upper[i], max(lower[i], seeds[attempt, i]))
        fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
        ep, er = _pose_error(T_target, T[tip], e)
        err = ep * ep + (0.0 if position_only else er * er)
        stall = 0
        for _ in range(max_iter):
            total_iters += 1
            if ep < tol_pos and (position_only or er < tol_rot):
                for i in range(n):
                    best[i] = q[group_idx[i]]
                return best, True, attempt + 1, total_iters
            jacobian_into(T, joints, parent, origin, jtype, axis, var, mult, column, tip, J)
            lam = 0.5 * err + 1e-9
            H = np.empty((n, n))
            g = np.empty(n)
            for a in range(n):
                acc = 0.0
                for r in range(rows):
                    acc += J[r, a] * e[r]
                g[a] = acc
                for b in range(a, n):
                    acc = 0.0
                    for r in range(rows):
                        acc += J[r, a] * J[r, b]
                    H[a, b] = acc
                    H[b, a] = acc
                H[a, a] += lam
            dq = np.linalg.solve(H, g)
            for i in range(n):
                k = group_idx[i]
                q[k] = min(upper[i], max(lower[i], q[k] + dq[i]))
            fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
            ep, er = _pose_error(T_target, T[tip], e)
            new_err = ep * ep + (0.0 if position_only else er * er)
            if new_err > 0.999 * err:
                stall += 1
                if stall >= 4:
                    break
            else:
                stall = 0
            err = new_err
    for i in range(n):
        best[i] = q[group_idx[i]]
    return best, False, seeds.shape[0], total_iters


@njit(cache=True)
def fk_link(
    qg,
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
    n_links,
    link,
):  # type: ignore[no-untyped-def]
    """Pose (4, 4) of one link for group joint values qg (other joints at q_base)."""
    q = q_base.copy()
    for i in range(group_idx.shape[0]):
        q[group_idx[i]] = qg[i]
    T = np.empty((n_links, 4, 4))
    fk_into(q, joints, root, parent, child, origin, jtype, axis, var, mult, offset, T)
    return T[link].copy()
