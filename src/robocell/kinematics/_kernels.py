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


# sin and cos as fdlibm computes them on [-π/4, π/4] (its __kernel_sin and __kernel_cos
# polynomials), after reducing the angle by a multiple of π/2 in two parts (Cody and Waite):
# within 2.3e-16 of libm's for |x| ≤ SINCOS_RANGE (the tests' bound), and free of calls, so
# that a loop over a block of states runs on SIMD lanes. Calling libm's sincos took 110 of a
# Panda state's 300 ns of forward kinematics, and as a call it keeps the loop scalar.
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_TWO_OVER_PI = 6.36619772367581382433e-01
# π/2 as a 33-bit head (n·head is exact for |n| < 2**20) and the rest
_PIO2_HEAD, _PIO2_TAIL = 1.57079632673412561417e00, 6.07710050650619224932e-11
# beyond this [rad] (or NaN) a block's angles go to libm: the two-part reduction loses digits
SINCOS_RANGE = 1.0e5


@njit(cache=True, inline="always")
def _sincos(x):  # type: ignore[no-untyped-def]
    """(sin x, cos x) for |x| ≤ SINCOS_RANGE, without a call (see above)."""
    n = math.floor(x * _TWO_OVER_PI + 0.5)
    r = (x - n * _PIO2_HEAD) - n * _PIO2_TAIL
    z = r * r
    s = r + r * z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    c = 1.0 - 0.5 * z + z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    quadrant = np.int64(n) & 3
    odd = (quadrant & 1) == 1
    sin_x = c if odd else s
    cos_x = s if odd else c
    if quadrant >= 2:
        sin_x = -sin_x
    if quadrant == 1 or quadrant == 2:
        cos_x = -cos_x
    return sin_x, cos_x


@njit(cache=True, inline="always")
def sincos_block(x, sin_x, cos_x):  # type: ignore[no-untyped-def]
    """sin and cos of every angle of ``x`` (n,) into ``sin_x`` and ``cos_x``: the polynomials
    on SIMD lanes when every angle is within SINCOS_RANGE, else libm's."""
    n = x.shape[0]
    far = 0
    for s in range(n):
        far += not abs(x[s]) <= SINCOS_RANGE
    if far == 0:
        for s in range(n):
            sin_x[s], cos_x[s] = _sincos(x[s])
    else:
        for s in range(n):
            sin_x[s] = math.sin(x[s])
            cos_x[s] = math.cos(x[s])


@njit(cache=True, inline="always")
def fk_block(
    qs, s0, n, column, q_base, joints, root, parent, child, origin, jtype, axis, var, mult,
    offset, Ts, values, sin_v, cos_v,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """:func:`fk_into` for the n group configurations ``qs[s0 : s0 + n]`` at once, joint by
    joint over the block's states so that each step runs on SIMD lanes (a Panda's 7 joints:
    39 ns a state in blocks of 16, 52 in blocks of 8, against 265 ns one state at a time,
    measured). The lanes are a multiple of 8 (:func:`block_lanes`; the last state repeated):
    LLVM's vector loop takes 8 at a time and leaves fewer to a scalar loop, in which a block
    of 4 took 714 ns. ``column``: each variable's column in ``qs``, or -1 for a variable
    outside the group (it keeps its value in ``q_base``). Writes the top three rows of the
    link poses, row-major, state last: ``Ts[link, 4·i + j, s]`` (L, 12, ≥ lanes).
    ``values``, ``sin_v``, ``cos_v``: work arrays (≥ lanes,)."""
    lanes = block_lanes(n)
    for i in range(12):
        one = 1.0 if i == 0 or i == 5 or i == 10 else 0.0
        for s in range(lanes):
            Ts[root, i, s] = one
    vals, sv, cv = values[:lanes], sin_v[:lanes], cos_v[:lanes]
    last = n - 1
    for jn in range(joints.shape[0]):
        k = joints[jn]
        p, c, O, t = parent[k], child[k], origin[k], jtype[k]
        v = var[k]
        m, b = mult[k], offset[k]
        if v < 0:
            vals[:] = b
        elif column[v] < 0:
            vals[:] = m * q_base[v] + b
        else:
            col = column[v]
            for s in range(lanes):
                vals[s] = m * qs[s0 + min(s, last), col] + b
        # the parent's pose times the joint's origin
        o00, o01, o02, o03 = O[0, 0], O[0, 1], O[0, 2], O[0, 3]
        o10, o11, o12, o13 = O[1, 0], O[1, 1], O[1, 2], O[1, 3]
        o20, o21, o22, o23 = O[2, 0], O[2, 1], O[2, 2], O[2, 3]
        for i in range(3):
            r = 4 * i
            for s in range(lanes):
                t0, t1, t2 = Ts[p, r, s], Ts[p, r + 1, s], Ts[p, r + 2, s]
                Ts[c, r, s] = t0 * o00 + t1 * o10 + t2 * o20
                Ts[c, r + 1, s] = t0 * o01 + t1 * o11 + t2 * o21
                Ts[c, r + 2, s] = t0 * o02 + t1 * o12 + t2 * o22
                Ts[c, r + 3, s] = t0 * o03 + t1 * o13 + t2 * o23 + Ts[p, r + 3, s]
        # times the joint's motion
        x, y, z = axis[k, 0], axis[k, 1], axis[k, 2]
        if t == REVOLUTE:
            sincos_block(vals, sv, cv)
            if x == 0.0 and y == 0.0:
                # about z (most URDFs' axes): columns 0 and 1 turn
                for i in range(3):
                    r = 4 * i
                    for s in range(lanes):
                        a0, a1, zs = Ts[c, r, s], Ts[c, r + 1, s], z * sv[s]
                        Ts[c, r, s] = a0 * cv[s] + a1 * zs
                        Ts[c, r + 1, s] = a1 * cv[s] - a0 * zs
            else:
                for i in range(3):
                    r = 4 * i
                    for s in range(lanes):
                        co, si = cv[s], sv[s]
                        w = 1.0 - co
                        a0, a1, a2 = Ts[c, r, s], Ts[c, r + 1, s], Ts[c, r + 2, s]
                        Ts[c, r, s] = (
                            a0 * (co + x * x * w) + a1 * (y * x * w + z * si)
                            + a2 * (z * x * w - y * si)
                        )  # fmt: skip
                        Ts[c, r + 1, s] = (
                            a0 * (x * y * w - z * si) + a1 * (co + y * y * w)
                            + a2 * (z * y * w + x * si)
                        )  # fmt: skip
                        Ts[c, r + 2, s] = (
                            a0 * (x * z * w + y * si) + a1 * (y * z * w - x * si)
                            + a2 * (co + z * z * w)
                        )  # fmt: skip
        elif t == PRISMATIC:
            for i in range(3):
                r = 4 * i
                for s in range(lanes):
                    Ts[c, r + 3, s] += vals[s] * (
                        Ts[c, r, s] * x + Ts[c, r + 1, s] * y + Ts[c, r + 2, s] * z
                    )


@njit(cache=True, inline="always")
def block_lanes(n):  # type: ignore[no-untyped-def]
    """The lanes :func:`fk_block` fills for n states: n rounded up to a multiple of 8."""
    return max(8, (n + 7) // 8 * 8)


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
