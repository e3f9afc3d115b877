"""Compiled (numba) kernels of the joint paths and trajectories: the rounded corners of a
polyline and the points of their arcs (the planner's final check samples the corners of every
path it returns, and in numpy, over the few corners of a path, this took 0.1 ms of a 1.3 ms plan,
measured on Panda table_pick; compiled, it takes a few µs), a rounded path's points and
derivatives, and a trajectory's states between its knots."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def corner_arcs(wp, max_deviation, blend_length):  # type: ignore[no-untyped-def]
    """The unit directions (K−1, dof) and lengths (K−1,) of the segments between waypoints
    ``wp`` (K, dof, no repeats), and the arcs that round their interior corners: each
    rounded corner's waypoint index, how far from the waypoint its arc starts (``ell``), its
    centre, its unit vector from the centre to the arc's start (``e1``), radius and turning
    angle. Corners are rounded within ``max_deviation`` of the waypoint, or (``blend_length``
    ≥ 0) from ``blend_length`` before it (a first or last segment may be used whole, any
    other up to its half). A reversal or a turn under 1e-9 rad is not rounded."""
    n, dof = wp.shape
    u = np.empty((max(n - 1, 0), dof))
    seg_len = np.empty(max(n - 1, 0))
    for k in range(n - 1):
        s = 0.0
        for j in range(dof):
            s += (wp[k + 1, j] - wp[k, j]) ** 2
        seg_len[k] = math.sqrt(s)
        inv = 1.0 / max(seg_len[k], 1e-300)
        for j in range(dof):
            u[k, j] = (wp[k + 1, j] - wp[k, j]) * inv
    m = max(n - 2, 0)
    waypoint = np.empty(m, np.int64)
    ell_out = np.empty(m)
    centre = np.empty((m, dof))
    e1 = np.empty((m, dof))
    radius = np.empty(m)
    angle = np.empty(m)
    rounding = max_deviation > 0 if blend_length < 0 else blend_length > 0
    c = 0
    for k in range(m if rounding else 0):
        # turning angle; acos(u1·u2) reads 1.5e-8 rad for two equal directions, whose corner
        # then had no direction to round towards (NaN)
        dm = 0.0
        dp = 0.0
        for j in range(dof):
            dm += (u[k + 1, j] - u[k, j]) ** 2
            dp += (u[k + 1, j] + u[k, j]) ** 2
        dm = math.sqrt(dm)
        alpha = 2.0 * math.atan2(dm, math.sqrt(dp))
        len1, len2 = seg_len[k], seg_len[k + 1]
        if not (1e-9 <= alpha <= math.pi - 1e-6 and len1 >= 1e-12 and len2 >= 1e-12):
            continue  # a reversal cannot be rounded: the motion stops there
        half = 0.5 * alpha
        if blend_length < 0:
            # deviation of the arc's midpoint from the corner: r (1/cos(half) − 1), with
            # 1 − cos(half) written as 2 sin²(half/2): exact for tiny turns too
            r = max_deviation * math.cos(half) / (2.0 * math.sin(0.5 * half) ** 2)
            ell = min(r * math.tan(half), 0.5 * len1, 0.5 * len2)
        else:
            # Pilz: blend spheres must not overlap
            avail1 = len1 * (1.0 - 1e-6) if k == 0 else 0.5 * len1
            avail2 = len2 * (1.0 - 1e-6) if k + 1 == n - 2 else 0.5 * len2
            ell = min(blend_length, avail1, avail2)
        if ell < 1e-9:
            continue
        r = ell / math.tan(half)
        to_centre = r / math.cos(half)
        for j in range(dof):
            x = (u[k + 1, j] - u[k, j]) / dm
            centre[c, j] = wp[k + 1, j] + x * to_centre
            e1[c, j] = (wp[k + 1, j] - ell * u[k, j] - centre[c, j]) / r
        waypoint[c] = k + 1
        ell_out[c] = ell
        radius[c] = r
        angle[c] = alpha
        c += 1
    return u, seg_len, waypoint[:c], ell_out[:c], centre[:c], e1[:c], radius[:c], angle[:c]


@njit(cache=True)
def arc_points(u, waypoint, centre, e1, radius, angle, resolution):  # type: ignore[no-untyped-def]
    """The points of the arcs :func:`corner_arcs` returns, consecutive ones at most
    ``resolution`` apart in every joint, each arc's ends included."""
    dof = u.shape[1]
    counts = np.empty(waypoint.shape[0], np.int64)
    for c in range(waypoint.shape[0]):
        rate = 0.0
        for j in range(dof):
            rate = max(rate, math.hypot(e1[c, j], u[waypoint[c] - 1, j]))
        counts[c] = max(1, int(math.ceil(radius[c] * angle[c] * rate / resolution)))
    out = np.empty((int(np.sum(counts + 1)), dof))
    row = 0
    for c in range(waypoint.shape[0]):
        e2 = u[waypoint[c] - 1]
        for t in range(counts[c] + 1):
            th = t / counts[c] * angle[c]
            co, si = math.cos(th), math.sin(th)
            for j in range(dof):
                out[row, j] = centre[c, j] + radius[c] * (co * e1[c, j] + si * e2[j])
            row += 1
    return out


@njit(cache=True)
def blended_points(starts, origin, d1, d2, radius, on_arc, s, order):  # type: ignore[no-untyped-def]
    """A :class:`robocell.trajectory.path.BlendedPath` at arc lengths ``s`` (N,), clamped to
    the path: its points (``order`` 0), unit tangents (1) or curvature vectors (2), (N, dof).
    The pieces as ``BlendedPath.piece_arrays`` gives them (``starts`` (S + 1,); a segment is
    origin + x·d1, an arc is centre (origin) + r (cos θ d1 + sin θ d2), θ = x / r), ``on_arc``
    (S,) whether each is an arc. In numpy, piece by piece with masks, a time parameterization's
    eight evaluations took 1.2 ms of 8.6 (IRB 120 pick motions, session 45, measured)."""
    S = radius.shape[0]
    n, dof = s.shape[0], origin.shape[1]
    out = np.empty((n, dof))
    for i in range(n):
        if math.isnan(s[i]):
            out[i] = math.nan  # as numpy's clip would carry it
            continue
        x = min(max(s[i], 0.0), starts[S])
        k = min(max(np.searchsorted(starts, x, side="right") - 1, 0), S - 1)
        local = x - starts[k]
        if on_arc[k]:
            r = radius[k]
            th = local / r
            co, si = math.cos(th), math.sin(th)
            for j in range(dof):
                if order == 0:
                    out[i, j] = origin[k, j] + r * (co * d1[k, j] + si * d2[k, j])
                elif order == 1:
                    out[i, j] = -si * d1[k, j] + co * d2[k, j]
                else:
                    out[i, j] = (-co * d1[k, j] - si * d2[k, j]) / r
        else:
            for j in range(dof):
                if order == 0:
                    out[i, j] = origin[k, j] + local * d1[k, j]
                elif order == 1:
                    out[i, j] = d1[k, j]
                else:
                    out[i, j] = 0.0
    return out


@njit(cache=True)
def quintic_states(times, positions, velocities, acc_start, acc_end, ts):  # type: ignore[no-untyped-def]
    """Positions, velocities and accelerations (M, dof) at times ``ts`` (M,), within the
    knots' ``times`` (K,), of the quintic Hermite through the knots: on each knot interval the
    polynomial that matches the positions and velocities at both knots and the accelerations
    ``acc_start`` and ``acc_end`` (K − 1, dof) at its start and end. In numpy, a time
    parameterization's check of its 2000 samples took 0.7 ms of 8.6 (session 45, measured)."""
    K, dof = positions.shape
    m = ts.shape[0]
    pos, vel, acc = np.empty((m, dof)), np.empty((m, dof)), np.empty((m, dof))
    for r in range(m):
        i = min(max(np.searchsorted(times, ts[r], side="right") - 1, 0), K - 2)
        h = times[i + 1] - times[i]
        s = (ts[r] - times[i]) / h
        for j in range(dof):
            p0 = positions[i, j]
            v0, v1 = velocities[i, j] * h, velocities[i + 1, j] * h
            a0, a1 = acc_start[i, j] * h * h, acc_end[i, j] * h * h
            c0, c1, c2 = p0, v0, 0.5 * a0
            d = positions[i + 1, j] - p0 - v0 - 0.5 * a0
            e = v1 - v0 - a0
            f = a1 - a0
            c3 = 10 * d - 4 * e + 0.5 * f
            c4 = -15 * d + 7 * e - f
            c5 = 6 * d - 3 * e + 0.5 * f
            pos[r, j] = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
            vel[r, j] = (c1 + s * (2 * c2 + s * (3 * c3 + s * (4 * c4 + s * 5 * c5)))) / h
            acc[r, j] = (2 * c2 + s * (6 * c3 + s * (12 * c4 + s * 20 * c5))) / (h * h)
    return pos, vel, acc
