"""Compiled (numba) kernels of the joint paths: the rounded corners of a polyline and the
points of their arcs. The planner's final check samples the corners of every path it returns,
and in numpy, over the few corners of a path, this took 0.1 ms of a 1.3 ms plan (measured on
Panda table_pick); compiled, it takes a few µs."""

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
