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


# TOPP-RA (Pham & Pham 2018) under joint velocity and acceleration limits, as toppra computes
# it with its interpolation discretization and its seidel solver; toppra's constants
TOPP_MAX_SPEED = 100.0  # the largest path speed ṡ [rad/s of path] (toppra's MAXSD)
TOPP_U_BOUND = 1e8  # |s̈| at most (toppra's seidel VAR_MAX)
TOPP_TRIES = 10  # reductions of a stage's x that the forward pass may make (MAX_TRIES)
TOPP_OK, TOPP_UNCONTROLLABLE, TOPP_FORWARD_FAILED = 0, 1, 2


@njit(cache=True, inline="always")
def _topp_rows(i, dq, ddq, deltas, a_max, alpha, beta, gamma):  # type: ignore[no-untyped-def]
    """Stage i's constraints on (u, x) = (s̈, ṡ²) as rows α u + β x ≤ γ, into the arrays;
    returns how many. Each joint's acceleration q̈ = q' u + q'' x within ±a_max at both ends of
    the stage (toppra's interpolation scheme: at s_{i+1}, x = x_i + 2 Δ_i u), and |u| ≤
    TOPP_U_BOUND."""
    dof = dq.shape[1]
    d2 = 2.0 * deltas[i]
    r = 0
    for j in range(dof):
        a0, b0 = dq[i, j], ddq[i, j]
        a1, b1 = dq[i + 1, j] + d2 * ddq[i + 1, j], ddq[i + 1, j]
        am = a_max[j]
        alpha[r], beta[r], gamma[r] = a0, b0, am
        alpha[r + 1], beta[r + 1], gamma[r + 1] = -a0, -b0, am
        alpha[r + 2], beta[r + 2], gamma[r + 2] = a1, b1, am
        alpha[r + 3], beta[r + 3], gamma[r + 3] = -a1, -b1, am
        r += 4
    alpha[r], beta[r], gamma[r] = 1.0, 0.0, TOPP_U_BOUND
    alpha[r + 1], beta[r + 1], gamma[r + 1] = -1.0, 0.0, TOPP_U_BOUND
    return r + 2


@njit(cache=True)
def topp_ra(dq, ddq, deltas, v_max, a_max):  # type: ignore[no-untyped-def]
    """The time-optimal rest-to-rest squared path speeds x_i = ṡ(s_i)² (N + 1,) at a path's
    gridpoints, under joint velocity limits ``v_max`` and acceleration limits ``a_max`` (dof,)
    (symmetric), from the path's derivatives ``dq`` = q'(s_i) and ``ddq`` = q''(s_i) (N + 1,
    dof) and the grid's steps ``deltas`` (N,); and a status: (TOPP_OK, 0), or
    (TOPP_UNCONTROLLABLE, the stage) where no speed at that gridpoint can reach the end at
    rest, or (TOPP_FORWARD_FAILED, the stage).

    The algorithm is toppra's: s̈ = u is constant over each stage, so x_{i+1} = x_i + 2 Δ_i u.
    A backward pass finds each gridpoint's controllable set K_i = [lo, hi] of the x from which
    the path can still end at rest: the projection on x of the stage's polygon in (u, x) (its
    rows, ``_topp_rows``, x within the velocity bound and x + 2 Δ_i u in K_{i+1}). Where
    toppra solves two 2-variable LPs per stage with its seidel solver, in a Python loop over
    the stages, here u is eliminated (Fourier–Motzkin): each pair of a lower and an upper bound
    on u, α_l < 0 < α_m, holds for x with (β_l α_m − β_m α_l) x ≤ γ_l α_m − γ_m α_l, and K_i is
    the intersection of those half-lines, exact. A forward pass then takes from x_0 = 0 the
    largest u that each stage allows at its x and that keeps x_{i+1} in K_{i+1}, shrinking
    x_{i+1} by toppra's margin (−1e-8, or × 0.9999) and reducing an x it cannot leave (by 0.1
    %, up to TOPP_TRIES times) as toppra does. The same profiles as toppra's to about 1e-7
    (toppra bounds the speed in float32), 10–20× as fast (``benchmarks/bench_trajectory.py``)."""
    n1, dof = dq.shape
    N = n1 - 1
    xs = np.full(n1, np.nan)
    x_hi = np.empty(n1)
    for i in range(n1):
        sd = TOPP_MAX_SPEED
        for j in range(dof):
            if dq[i, j] != 0.0:
                sd = min(sd, v_max[j] / abs(dq[i, j]))
        x_hi[i] = sd * sd
    m = 4 * dof + 4
    alpha, beta, gamma = np.empty(m), np.empty(m), np.empty(m)
    K = np.zeros((n1, 2))
    for i in range(N - 1, -1, -1):
        n = _topp_rows(i, dq, ddq, deltas, a_max, alpha, beta, gamma)
        d2 = 2.0 * deltas[i]
        alpha[n], beta[n], gamma[n] = d2, 1.0, K[i + 1, 1]
        alpha[n + 1], beta[n + 1], gamma[n + 1] = -d2, -1.0, -K[i + 1, 0]
        n += 2
        lo, hi, ok = 0.0, x_hi[i], True
        for low in range(n):
            al = alpha[low]
            if al > 0.0:
                continue
            bl, gl = beta[low], gamma[low]
            if al == 0.0:  # a bound on x alone
                if bl > 0.0:
                    hi = min(hi, gl / bl)
                elif bl < 0.0:
                    lo = max(lo, gl / bl)
                elif gl < 0.0:
                    ok = False
                continue
            for up in range(n):
                am = alpha[up]
                if am <= 0.0:
                    continue
                c1, c2 = bl * am, beta[up] * al
                g1, g2 = gl * am, gamma[up] * al
                c, d = c1 - c2, g1 - g2
                if abs(c) <= 1e-12 * (abs(c1) + abs(c2)):  # parallel bounds on u
                    if d < -1e-9 * (abs(g1) + abs(g2)):
                        ok = False
                elif c > 0.0:
                    hi = min(hi, d / c)
                else:
                    lo = max(lo, d / c)
        if not ok or lo > hi + 1e-12 * max(1.0, abs(hi)):
            return xs, TOPP_UNCONTROLLABLE, i
        K[i, 0], K[i, 1] = lo, max(hi, lo)
    if K[0, 0] > 1e-5:  # toppra's SMALL: the start at rest is not controllable
        return xs, TOPP_UNCONTROLLABLE, 0
    xs[0] = 0.0
    tries = 0
    i = 0
    while i < N:
        x = xs[i]
        n = _topp_rows(i, dq, ddq, deltas, a_max, alpha, beta, gamma)
        d2 = 2.0 * deltas[i]
        u_lo = max(-TOPP_U_BOUND, (K[i + 1, 0] - x) / d2)
        u_hi = min(TOPP_U_BOUND, (K[i + 1, 1] - x) / d2)
        ok = x <= x_hi[i]
        for k in range(n):
            a, v = alpha[k], gamma[k] - beta[k] * x
            if a > 0.0:
                u_hi = min(u_hi, v / a)
            elif a < 0.0:
                u_lo = max(u_lo, v / a)
            elif v < 0.0:
                ok = False
        if not ok or u_lo > u_hi + 1e-10 * max(1.0, abs(u_hi)):
            if tries == TOPP_TRIES:
                return xs, TOPP_FORWARD_FAILED, i
            xs[i] = max(x - 1e-8, 0.999 * x)
            tries += 1
            continue
        tries = 0
        x_next = x + d2 * u_hi
        x_next = max(x_next - 1e-8, 0.9999 * x_next)
        xs[i + 1] = min(K[i + 1, 1], max(K[i + 1, 0], x_next))
        i += 1
    return xs, TOPP_OK, 0
