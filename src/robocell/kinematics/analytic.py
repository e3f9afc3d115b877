"""Closed-form inverse kinematics: OPW arms (ortho-parallel base, spherical wrist: ABB, KUKA,
Fanuc, …) and Universal Robots arms (UR3/5/10/16, e-series).

Each solver works in its *canonical* frames: OPW's (Brandstötter, Angerer, Hofbaur 2014) and the
UR's DH frames (Hawkins 2013). :class:`robocell.kinematics.AnalyticIK` ties them to a URDF by
fitting the constant base and tool transforms and checking the fit on random configurations, so
a parameter set that does not match the robot is refused instead of giving wrong answers.

Every candidate is checked by the canonical forward kinematics before it is returned: a branch
that is numerically off (near singularities) is dropped, never returned.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from robocell.errors import ModelError


@dataclass(frozen=True)
class OPWParameters:
    """The seven OPW lengths in [m] (names as in the paper and opw_kinematics), plus the map from
    URDF joint values to canonical ones: ``q_canonical = sign * q − offset``."""

    a1: float
    a2: float
    b: float
    c1: float
    c2: float
    c3: float
    c4: float
    offsets: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    signs: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)

    def array(self) -> np.ndarray:
        return np.array([self.a1, self.a2, self.b, self.c1, self.c2, self.c3, self.c4])


@dataclass(frozen=True)
class URParameters:
    """UR Denavit–Hartenberg lengths in [m]: d1, a2, a3, d4, d5, d6 (a2, a3 negative, as UR
    publishes them); alpha = (π/2, 0, 0, π/2, −π/2, 0). Same joint map as OPW."""

    d1: float
    a2: float
    a3: float
    d4: float
    d5: float
    d6: float
    offsets: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    signs: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)

    def array(self) -> np.ndarray:
        return np.array([self.d1, self.a2, self.a3, self.d4, self.d5, self.d6])


def parameters_from_config(config: dict) -> OPWParameters | URParameters:
    """Parameters from a kinematics.yaml group entry: ``{solver: opw|ur, parameters: {...}}``."""
    solver = config.get("solver")
    params = dict(config.get("parameters", {}))
    for key in ("offsets", "signs"):
        if key in params:
            params[key] = tuple(float(v) for v in params[key])
    try:
        if solver == "opw":
            return OPWParameters(**params)
        if solver == "ur":
            return URParameters(**params)
    except TypeError as exc:
        raise ModelError(f"kinematics: bad {solver} parameters {sorted(params)}: {exc}") from exc
    raise ModelError(f"kinematics: unknown analytic solver {solver!r}; known: opw, ur")


@njit(cache=True, inline="always")
def _mm(A, B):  # type: ignore[no-untyped-def]
    """Small matrix product by loops (numba sends 2-D @ to BLAS: ~1 µs for a 3×3)."""
    n, m, k = A.shape[0], B.shape[1], A.shape[1]
    C = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            acc = 0.0
            for l in range(k):
                acc += A[i, l] * B[l, j]
            C[i, j] = acc
    return C


@njit(cache=True, inline="always")
def _mv(A, v):  # type: ignore[no-untyped-def]
    n, k = A.shape[0], A.shape[1]
    out = np.zeros(n)
    for i in range(n):
        acc = 0.0
        for l in range(k):
            acc += A[i, l] * v[l]
        out[i] = acc
    return out


# ---------------------------------------------------------------------------------------- OPW
@njit(cache=True)
def _rz(t):  # type: ignore[no-untyped-def]
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@njit(cache=True)
def _ry(t):  # type: ignore[no-untyped-def]
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@njit(cache=True)
def opw_fk(p, q):  # type: ignore[no-untyped-def]
    """Canonical OPW forward kinematics: 4×4 flange pose for canonical joint values q (6,)."""
    a1, a2, b, c1, c2, c3, c4 = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    R1 = _rz(q[0])
    local = np.array([a1, b, c1])
    local += _mv(_ry(q[1]), np.array([0.0, 0.0, c2]))
    local += _mv(_ry(q[1] + q[2]), np.array([a2, 0.0, c3]))
    R0c = _mm(R1, _ry(q[1] + q[2]))  # canonical: forearm along z at q2 = q3 = 0
    R0e = _mm(_mm(_mm(R0c, _rz(q[3])), _ry(q[4])), _rz(q[5]))
    T = np.eye(4)
    T[:3, :3] = R0e
    T[:3, 3] = _mv(R1, local) + c4 * R0e[:, 2]
    return T


@njit(cache=True)
def _wrap(a):  # type: ignore[no-untyped-def]
    return math.atan2(math.sin(a), math.cos(a))


@njit(cache=True)
def opw_ik(p, T, wrist_seed):  # type: ignore[no-untyped-def]
    """Canonical OPW IK: up to 8 solutions (K, 6) for the flange pose T (4×4).

    At a wrist singularity (q5 = 0) only q4 + q6 is determined: q4 is set to ``wrist_seed``.
    """
    a1, a2, b, c1, c2, c3, c4 = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    R = np.ascontiguousarray(T[:3, :3])
    wc = T[:3, 3] - c4 * R[:, 2]
    out = np.empty((8, 6))
    n = 0
    rxy2 = wc[0] * wc[0] + wc[1] * wc[1] - b * b
    if rxy2 < 0.0:
        return out[:0]
    base_angle = math.atan2(wc[1], wc[0])
    off = math.atan2(b, math.sqrt(rxy2))
    k2 = a2 * a2 + c3 * c3
    k = math.sqrt(k2)
    psi3 = math.atan2(a2, c3)
    for i1 in range(2):
        q1 = base_angle - off if i1 == 0 else base_angle + off - math.pi
        c1_, s1_ = math.cos(q1), math.sin(q1)
        u = wc[0] * c1_ + wc[1] * s1_ - a1
        v = wc[2] - c1
        s2 = u * u + v * v
        cg = (s2 - c2 * c2 - k2) / (2.0 * c2 * k)
        if cg > 1.0 + 1e-12 or cg < -1.0 - 1e-12:
            continue
        cg = min(1.0, max(-1.0, cg))
        for i3 in range(2):
            g = math.acos(cg) if i3 == 0 else -math.acos(cg)
            q3 = g - psi3
            q2 = math.atan2(u, v) - math.atan2(k * math.sin(g), c2 + k * math.cos(g))
            Rw = _mm(_mm(_rz(q1), _ry(q2 + q3)).T, R)
            s5 = math.sqrt(Rw[0, 2] * Rw[0, 2] + Rw[1, 2] * Rw[1, 2])
            if s5 < 1e-10:
                q5 = 0.0 if Rw[2, 2] > 0 else math.pi
                q4 = wrist_seed
                if Rw[2, 2] > 0:
                    q6 = math.atan2(Rw[1, 0], Rw[0, 0]) - q4
                else:
                    q6 = q4 - math.atan2(-Rw[1, 0], -Rw[0, 0])
                out[n] = (q1, q2, q3, q4, q5, _wrap(q6))
                n += 1
                continue
            q5 = math.atan2(s5, Rw[2, 2])
            q4 = math.atan2(Rw[1, 2], Rw[0, 2])
            q6 = math.atan2(Rw[2, 1], -Rw[2, 0])
            out[n] = (q1, q2, q3, q4, q5, q6)
            out[n + 1] = (q1, q2, q3, _wrap(q4 + math.pi), -q5, _wrap(q6 + math.pi))
            n += 2
    return out[:n]


# ---------------------------------------------------------------------------------------- UR
@njit(cache=True)
def _dh(theta, d, a, alpha):  # type: ignore[no-untyped-def]
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


_UR_ALPHA = np.array([math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0])


@njit(cache=True)
def ur_fk(p, q):  # type: ignore[no-untyped-def]
    """UR forward kinematics in DH frames: T_0_6 for joint values q (6,).

    T ← T · DH_i in place, column by column (DH_i = Rz(θ) Tz(d) Tx(a) Rx(α)), no allocation
    per joint.
    """
    d = (p[0], 0.0, 0.0, p[3], p[4], p[5])
    a = (0.0, p[1], p[2], 0.0, 0.0, 0.0)
    T = np.eye(4)
    for i in range(6):
        ct, st = math.cos(q[i]), math.sin(q[i])
        ca, sa = math.cos(_UR_ALPHA[i]), math.sin(_UR_ALPHA[i])
        for r in range(3):
            c0, c1, c2, c3 = T[r, 0], T[r, 1], T[r, 2], T[r, 3]
            T[r, 0] = ct * c0 + st * c1
            T[r, 1] = -st * ca * c0 + ct * ca * c1 + sa * c2
            T[r, 2] = st * sa * c0 - ct * sa * c1 + ca * c2
            T[r, 3] = a[i] * ct * c0 + a[i] * st * c1 + d[i] * c2 + c3
    return T


@njit(cache=True)
def _inv(T):  # type: ignore[no-untyped-def]
    out = np.eye(4)
    Rt = np.ascontiguousarray(T[:3, :3].T)
    out[:3, :3] = Rt
    out[:3, 3] = -_mv(Rt, T[:3, 3])
    return out


@njit(cache=True)
def ur_ik(p, T, wrist_seed):  # type: ignore[no-untyped-def]
    """UR IK (Hawkins): up to 8 solutions (K, 6) for T_0_6. At a wrist singularity (sin q5 = 0)
    q6 is set to ``wrist_seed``."""
    d1, a2, a3, d4, d5, d6 = p[0], p[1], p[2], p[3], p[4], p[5]
    out = np.empty((8, 6))
    n = 0
    P05 = T[:3, 3] - d6 * T[:3, 2]
    r = math.hypot(P05[0], P05[1])
    if r < abs(d4) - 1e-12:
        return out[:0]
    phi1 = math.atan2(P05[1], P05[0])
    phi2 = math.acos(min(1.0, d4 / r)) if r > 0 else 0.0
    Ti = _inv(T)
    for i1 in range(2):
        q1 = phi1 + (phi2 if i1 == 0 else -phi2) + math.pi / 2
        s1, c1 = math.sin(q1), math.cos(q1)
        c5 = (T[0, 3] * s1 - T[1, 3] * c1 - d4) / d6
        if c5 > 1.0 + 1e-12 or c5 < -1.0 - 1e-12:
            continue
        c5 = min(1.0, max(-1.0, c5))
        for i5 in range(2):
            q5 = math.acos(c5) if i5 == 0 else -math.acos(c5)
            s5 = math.sin(q5)
            if abs(s5) < 1e-10:
                q6 = wrist_seed
            else:
                q6 = math.atan2(
                    (-Ti[1, 0] * s1 + Ti[1, 1] * c1) / s5, (Ti[0, 0] * s1 - Ti[0, 1] * c1) / s5
                )
            T01 = _dh(q1, d1, 0.0, math.pi / 2)
            T45 = _dh(q5, d5, 0.0, -math.pi / 2)
            T56 = _dh(q6, d6, 0.0, 0.0)
            T14 = _mm(_mm(_inv(T01), T), _inv(_mm(T45, T56)))
            px = T14[0, 3] - d4 * T14[0, 1]
            py = T14[1, 3] - d4 * T14[1, 1]
            norm = math.hypot(px, py)
            c3 = (norm * norm - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
            if c3 > 1.0 + 1e-12 or c3 < -1.0 - 1e-12:
                continue
            c3 = min(1.0, max(-1.0, c3))
            for i3 in range(2):
                q3 = math.acos(c3) if i3 == 0 else -math.acos(c3)
                q2 = -math.atan2(py, -px) + math.asin(max(-1.0, min(1.0, a3 * math.sin(q3) / norm)))
                T13 = _mm(_dh(q2, 0.0, a2, 0.0), _dh(q3, 0.0, a3, 0.0))
                T34 = _mm(_inv(T13), T14)
                q4 = math.atan2(T34[1, 0], T34[0, 0])
                out[n] = (q1, q2, q3, q4, q5, q6)
                n += 1
    return out[:n]


# ---------------------------------------------------------------------------------- shared
# how far outside its limits [rad] a solution is still taken, clamped onto them: limits written
# to 8 decimals, like ±3.14159265 for ±π, lie 3.6e-9 inside, and a solution exactly at π (a
# side grasp straight out from the base turns the IRB 120's joint 6 by π) was lost
LIMIT_SLACK = 1e-6


@njit(cache=True)
def _expand_wraps(sol, lower, upper, out, n):  # type: ignore[no-untyped-def]
    """Append to ``out`` every 2π variant of ``sol`` that lies within the limits (up to
    LIMIT_SLACK outside, clamped onto them); returns new n."""
    counts = np.zeros(6, np.int64)
    options = np.empty((6, 8))
    for j in range(6):
        base = sol[j] - 2.0 * math.pi * math.floor(
            (sol[j] - lower[j] + LIMIT_SLACK) / (2.0 * math.pi)
        )
        m = 0
        v = base
        while v <= upper[j] + LIMIT_SLACK and m < 8:
            if v >= lower[j] - LIMIT_SLACK:
                options[j, m] = min(upper[j], max(lower[j], v))
                m += 1
            v += 2.0 * math.pi
        counts[j] = m
        if m == 0:
            return n
    idx = np.zeros(6, np.int64)
    while True:
        if n >= out.shape[0]:
            return n
        for j in range(6):
            out[n, j] = options[j, idx[j]]
        n += 1
        j = 0
        while j < 6:
            idx[j] += 1
            if idx[j] < counts[j]:
                break
            idx[j] = 0
            j += 1
        if j == 6:
            return n


@njit(cache=True)
def _canon_error(kind, p, qc, T, e):  # type: ignore[no-untyped-def]
    Tc = opw_fk(p, qc) if kind == 0 else ur_fk(p, qc)
    for i in range(3):
        e[i] = T[i, 3] - Tc[i, 3]
    # small-angle rotation error: vee(R_target R_cᵀ − I) / 2 · … is enough near a solution
    R = _mm(T[:3, :3], Tc[:3, :3].T)
    e[3] = 0.5 * (R[2, 1] - R[1, 2])
    e[4] = 0.5 * (R[0, 2] - R[2, 0])
    e[5] = 0.5 * (R[1, 0] - R[0, 1])
    if R[0, 0] + R[1, 1] + R[2, 2] < 1.0:  # more than 90° off: vee(R − Rᵀ) would shrink again
        return np.inf
    return math.sqrt((e * e).sum())


@njit(cache=True)
def _polish(kind, p, qc, T):  # type: ignore[no-untyped-def]
    """Newton steps (finite-difference Jacobian) on a closed-form candidate whose branch lost
    precision near acos/asin(±1); exact candidates (error < 1e-11) return untouched."""
    e = np.empty(6)
    e2 = np.empty(6)
    J = np.empty((6, 6))
    for _ in range(3):
        err = _canon_error(kind, p, qc, T, e)
        if err < 1e-11:
            return err
        h = 1e-7
        for j in range(6):
            qc[j] += h
            _canon_error(kind, p, qc, T, e2)
            qc[j] -= h
            for i in range(6):
                J[i, j] = (e[i] - e2[i]) / h
        dq = np.linalg.lstsq(J, e)[0]
        for j in range(6):
            qc[j] += dq[j]
    return _canon_error(kind, p, qc, T, e)


@njit(cache=True)
def solve_analytic(kind, p, T_canon, signs, offsets, lower, upper, wrist_seed, tol_pos, tol_rot):  # type: ignore[no-untyped-def]
    """All URDF-joint solutions (K, 6) within limits for a canonical target pose.

    kind 0 = OPW, 1 = UR. Canonical candidates are checked by canonical FK, mapped to URDF
    joints (q = (q_canonical + offset) · sign), and expanded over 2π wraps within the limits.
    """
    cands = opw_ik(p, T_canon, wrist_seed) if kind == 0 else ur_ik(p, T_canon, wrist_seed)
    out = np.empty((512, 6))
    n = 0
    for i in range(cands.shape[0]):
        qc = cands[i].copy()
        # the residual (position and small-angle rotation, combined) must be within tolerance
        if _polish(kind, p, qc, T_canon) > min(tol_pos, tol_rot):
            continue
        q = np.empty(6)
        for j in range(6):
            q[j] = (qc[j] + offsets[j]) * signs[j]
        n = _expand_wraps(q, lower, upper, out, n)
    return out[:n]


@njit(cache=True)
def solve_ordered(
    kind,
    p,
    T_base_tip,
    T_canon_base,
    T_tip_flange,
    seed,
    signs,
    offsets,
    lower,
    upper,
    wrist_index,
    tol,
):  # type: ignore[no-untyped-def]
    """:func:`solve_analytic` for a target in the URDF base frame, solutions ordered by their
    distance to ``seed``."""
    T_canon = _mm(_mm(T_canon_base, T_base_tip), T_tip_flange)
    wrist_seed = signs[wrist_index] * seed[wrist_index] - offsets[wrist_index]
    sols = solve_analytic(kind, p, T_canon, signs, offsets, lower, upper, wrist_seed, tol, tol)
    n = sols.shape[0]
    d = np.empty(n)
    for i in range(n):
        acc = 0.0
        for j in range(6):
            acc += (sols[i, j] - seed[j]) ** 2
        d[i] = acc
    return sols[np.argsort(d, kind="mergesort")]


@njit(cache=True)
def solve_ordered_many(
    kind, p, Ts, T_canon_base, T_tip_flange, seed, signs, offsets, lower, upper, wrist_index,
    tol,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """:func:`solve_ordered` for each target of ``Ts`` (N, 4, 4): the solutions of them all
    (S, 6), target after target, and how many each has (N,)."""
    n = Ts.shape[0]
    counts = np.zeros(n, np.int64)
    out = np.empty((max(8 * n, 1), 6))
    m = 0
    for k in range(n):
        sols = solve_ordered(
            kind, p, Ts[k], T_canon_base, T_tip_flange, seed, signs, offsets, lower, upper,
            wrist_index, tol,
        )  # fmt: skip
        if m + sols.shape[0] > out.shape[0]:
            grown = np.empty((2 * out.shape[0] + sols.shape[0], 6))
            grown[:m] = out[:m]
            out = grown
        out[m : m + sols.shape[0]] = sols
        m += sols.shape[0]
        counts[k] = sols.shape[0]
    return out[:m].copy(), counts


@njit(cache=True)
def follow_line(
    kind, p, T_start, offset, n, q, T_canon_base, T_tip_flange, signs, offsets, lower, upper,
    wrist_index, tol, max_jump,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """The configurations along the straight line from ``T_start`` (URDF base frame) by
    ``offset`` in ``n`` steps, each the solution nearest the one before (from ``q``), and
    whether the line was followed to its end: it stops at a step with no solution within the
    limits, or whose nearest solution jumps by more than ``max_jump`` in some joint (the
    configurations before that step are returned)."""
    out = np.empty((n, q.shape[0]))
    T = T_start.copy()
    for k in range(1, n + 1):
        f = k / n
        for i in range(3):
            T[i, 3] = T_start[i, 3] + offset[i] * f
        sols = solve_ordered(
            kind, p, T, T_canon_base, T_tip_flange, q, signs, offsets, lower, upper,
            wrist_index, tol,
        )  # fmt: skip
        if sols.shape[0] == 0:
            return out[: k - 1], False
        jump = 0.0
        for j in range(q.shape[0]):
            jump = max(jump, abs(sols[0, j] - q[j]))
        if jump > max_jump:
            return out[: k - 1], False
        q = sols[0].copy()
        out[k - 1] = q
    return out, True
