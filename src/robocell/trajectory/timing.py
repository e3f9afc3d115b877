"""Time parameterization: time-optimal along a path (TOPP-RA, compiled), synchronized point-to-point
(trapezoidal, as Pilz's PTP; or jerk-limited through ruckig).

Every function returns a :class:`JointTrajectory` that starts and ends at rest and whose
samples have been checked against the limits (scaled by MoveIt's velocity and acceleration
scaling factors). A profile that the check finds over a limit by rounding is slowed down
uniformly until it is within; it is never returned over a limit.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import PlanningError, RobocellWarning, floats, number, unknown
from robocell.robot.model import JointGroup
from robocell.trajectory import _kernels as TK
from robocell.trajectory.path import BlendedPath, SplinePath
from robocell.trajectory.trajectory import POSITION_SLACK, JointTrajectory, stationary

KNOT_DT = 0.004  # [s] knot spacing of generated trajectories (250 Hz, a servo rate)
# MoveIt's limits for a joint whose URDF and joint_limits.yaml give none: its time-optimal
# parameterization's for velocity and acceleration, its ruckig smoothing's for jerk (rad or m)
DEFAULT_LIMITS = {"velocity": 1.0, "acceleration": 1.0, "jerk": 100.0}


def _scaling(value: float, name: str) -> float:
    if not (isinstance(value, int | float) and 0.0 < value <= 1.0):
        raise PlanningError(f"{name} must be in (0, 1], got {value!r}")
    return float(value)


def _limits(
    group: JointGroup, velocity_scaling: float, acceleration_scaling: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    vs = _scaling(velocity_scaling, "velocity scaling factor")
    as_ = _scaling(acceleration_scaling, "acceleration scaling factor")
    return joint_limits(group, "velocity") * vs, joint_limits(group, "acceleration") * as_


def joint_limits(group: JointGroup, kind: str) -> NDArray[np.float64]:
    """The limits every profile of the group keeps to, for ``kind`` "velocity",
    "acceleration" or "jerk": the group's, and MoveIt's default (DEFAULT_LIMITS) for the
    joints that have none, with a :class:`RobocellWarning` naming them. Without a default a
    profile had no bound but its grid's: a Panda without acceleration limits reached 364
    rad/s² on TOPP-RA's default grid, 685 on a finer one, and a PTP move failed."""
    if kind not in DEFAULT_LIMITS:
        raise PlanningError(unknown("kind of joint limit", kind, DEFAULT_LIMITS))
    limit: NDArray[np.float64] = getattr(group, kind)
    missing = ~np.isfinite(limit)
    if not missing.any():
        return limit
    names = [n for n, m in zip(group.joint_names, missing, strict=True) if m]
    unit = {"velocity": "/s", "acceleration": "/s²", "jerk": "/s³"}[kind]
    warnings.warn(
        f"no {kind} limits for {', '.join(names)} of group {group.name!r}: timed with MoveIt's "
        f"default, {DEFAULT_LIMITS[kind]:g} rad{unit} (m{unit} for a prismatic joint); give "
        f"them in a joint_limits.yaml (RobotModel.from_urdf(..., joint_limits=...))",
        RobocellWarning,
        stacklevel=3,
    )
    return np.where(missing, DEFAULT_LIMITS[kind], limit)


def fit_to_limits(
    traj: JointTrajectory, v_max: NDArray[np.float64], a_max: NDArray[np.float64]
) -> JointTrajectory:
    """``traj`` slowed down uniformly (if needed) so that it is within the limits at its knots
    and between them (sampled four times per knot interval)."""
    if len(traj) < 2:
        return traj
    k = max(_peak_ratio(traj, v_max, a_max), 1.0)
    if k > 1.0:
        traj = traj.scaled(k * (1.0 + 1e-9))
        traj.info["slowed_by"] = k
    return traj


def _peak_ratio(
    traj: JointTrajectory, v_max: NDArray[np.float64], a_max: NDArray[np.float64]
) -> float:
    """How many times slower ``traj`` must run to keep within ``v_max`` and ``a_max`` (< 1:
    it may run faster), from its knots and four samples per knot interval."""
    t = traj.times
    dense = np.concatenate([t, (t[:-1, None] + np.diff(t)[:, None] * [0.25, 0.5, 0.75]).ravel()])
    smp = traj.sample(dense)
    rv = float(np.max(np.abs(smp.velocities) / v_max))
    ra = float(np.max(np.abs(smp.accelerations) / a_max))
    return max(rv, math.sqrt(ra))


def retimed(
    group: JointGroup,
    traj: JointTrajectory,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
) -> JointTrajectory:
    """``traj`` run uniformly slower or faster until a joint reaches the group's velocity or
    acceleration limit scaled by the factors (MoveIt's ``retime_trajectory`` on a trajectory
    whose path is not known otherwise): the same positions in the same order, at times
    scaled by one factor (velocities by its inverse, accelerations by its inverse square).
    Time-optimal again where ``traj`` was time-optimal and the two factors keep the ratio
    they had (velocity², acceleration)."""
    if list(traj.joint_names) != list(group.joint_names):
        raise PlanningError(
            f"trajectory joints {traj.joint_names} are not those of group {group.name!r}: "
            f"{group.joint_names}"
        )
    v_max, a_max = _limits(group, velocity_scaling, acceleration_scaling)
    if len(traj) < 2:
        return traj
    k = _peak_ratio(traj, v_max, a_max)
    if k < 1e-12:  # it does not move
        return traj
    out = traj.scaled(k * (1.0 + 1e-9))
    out.info["scaled_by"] = k
    return out


def time_optimal(
    group: JointGroup,
    path: ArrayLike | BlendedPath | SplinePath,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
    max_deviation: float = 0.05,
    grid_step: float = 0.04,
    dt: float = KNOT_DT,
    smooth: bool = False,
) -> JointTrajectory:
    """Time-optimal trajectory along ``path`` (waypoints (K, dof) or a :class:`BlendedPath`)
    under the group's joint velocity and acceleration limits, from rest to rest (TOPP-RA).

    Waypoint corners are rounded within ``max_deviation`` [rad] (0: stop at each corner);
    ``smooth`` instead passes a cubic spline through the waypoints (for dense samples of a
    smooth curve, such as a Cartesian path's). ``grid_step`` [rad of path] sets TOPP-RA's grid
    (plus every segment boundary).
    """
    v_max, a_max = _limits(group, velocity_scaling, acceleration_scaling)
    bp: BlendedPath | SplinePath
    if isinstance(path, BlendedPath | SplinePath):
        bp = path
    else:
        wp = floats(path, "a path's waypoints", PlanningError)
        if wp.ndim != 2 or wp.shape[1] != group.dof or not np.all(np.isfinite(wp)):
            raise PlanningError(
                f"a path for group {group.name!r} must be finite (K, {group.dof}) waypoints, "
                f"got shape {wp.shape}"
            )
        # refused here rather than by the execution's check of the trajectory (the same
        # tolerance: JointTrajectory.limit_violations)
        outside = ~group.within_limits(wp, POSITION_SLACK)
        if outside.any():
            k = int(np.argmax(outside))
            raise PlanningError(
                f"waypoint {k} of {wp.shape[0]} is outside the joint limits: "
                f"{'; '.join(group.limit_violations(wp[k], POSITION_SLACK))}"
            )
        if wp.shape[0] == 1 or np.allclose(wp, wp[0], rtol=0.0, atol=1e-12):
            return stationary(group, wp[0])
        if not number(max_deviation, "max_deviation [rad]", PlanningError) >= 0:
            raise PlanningError(f"max_deviation must be >= 0 [rad], got {max_deviation!r}")
        bp = SplinePath(wp) if smooth else BlendedPath(wp, max_deviation)
    if bp.length < 1e-9:
        return stationary(group, bp(0.0))
    pieces = []
    for s0, s1 in bp.split_at_stops():
        grid = bp.grid(grid_step)
        grid = np.union1d(grid[(grid > s0) & (grid < s1)], [s0, s1])
        pieces.append(_topp_piece(group, bp, grid, v_max, a_max, dt))
    traj = pieces[0]
    for p in pieces[1:]:
        traj = traj.then(p)
    traj = fit_to_limits(traj, v_max, a_max)
    traj.info["path_length"] = bp.length
    return traj


def _topp_piece(
    group: JointGroup,
    bp: BlendedPath | SplinePath,
    grid: NDArray[np.float64],
    v_max: NDArray[np.float64],
    a_max: NDArray[np.float64],
    dt: float,
) -> JointTrajectory:
    """TOPP-RA from rest to rest over the smooth stretch ``grid`` of ``bp``
    (:func:`robocell.trajectory._kernels.topp_ra`)."""
    # the path's derivatives at the grid's points, measured from the stretch's start as
    # toppra took them through SubPath (the same side of a corner's breakpoint, to the bit)
    g = grid - grid[0]
    s = np.clip(g, 0.0, g[-1]) + grid[0]
    steps = np.diff(g)
    xs, status, stage = TK.topp_ra(bp(s, 1), bp(s, 2), steps, v_max, a_max)
    if status != TK.TOPP_OK:
        raise PlanningError(
            f"time parameterization failed for group {group.name!r} on the path stretch "
            f"[{grid[0]:.3f}, {grid[-1]:.3f}] rad (at {grid[stage]:.3f} rad)"
        )
    g_sd = np.sqrt(xs)
    with np.errstate(divide="ignore"):  # two gridpoints at rest: a stall, said below
        g_t = np.concatenate([[0.0], np.cumsum(2.0 * steps / (g_sd[:-1] + g_sd[1:]))])
    if not np.isfinite(g_t[-1]):
        raise PlanningError(
            f"time parameterization of group {group.name!r} stalls on the path stretch "
            f"[{grid[0]:.3f}, {grid[-1]:.3f}] rad (a corner too sharp to pass)"
        )
    g_s = grid
    g_u = 0.5 * np.diff(xs) / steps  # s̈, constant on each grid interval
    # Knots from the exact profile: s̈ is constant on each grid interval, so each interval
    # is cut into knot intervals ≤ dt and the accelerations at both ends of each are taken
    # from inside it (the joint accelerations jump where s̈ or the path's curvature does).
    h = np.diff(g_t)
    # a grid interval this short (the point set just before a breakpoint) gets no knot of
    # its own: a quintic over microseconds only amplifies rounding errors
    i = np.arange(len(h))
    keep = np.flatnonzero((h >= 1e-5) | (i == 0) | (i == len(h) - 1))
    m = np.maximum(1, np.ceil(h[keep] / dt).astype(np.int64))  # knot intervals per grid interval
    iv = np.repeat(keep, m)  # the grid interval of each knot interval
    first = np.repeat(np.cumsum(m) - m, m)
    tau = (np.arange(len(iv)) - first) * np.repeat(h[keep] / m, m)
    ts = np.append(g_t[iv] + tau, g_t[-1]) - g_t[0]
    s_k = g_s[iv] + g_sd[iv] * tau + 0.5 * g_u[iv] * tau**2
    ss = np.clip(np.append(s_k, g_s[-1]), grid[0], grid[-1])
    sd = np.append(g_sd[iv] + g_u[iv] * tau, 0.0)
    u = g_u[iv]  # per knot interval
    eps = 1e-12
    q = bp(ss)
    dq_r, ddq_r = (
        bp(np.minimum(ss[:-1] + eps, grid[-1]), 1),
        bp(np.minimum(ss[:-1] + eps, grid[-1]), 2),
    )
    dq_l, ddq_l = bp(np.maximum(ss[1:] - eps, grid[0]), 1), bp(np.maximum(ss[1:] - eps, grid[0]), 2)
    acc_start = ddq_r * sd[:-1, None] ** 2 + dq_r * u[:, None]
    acc_end = ddq_l * sd[1:, None] ** 2 + dq_l * u[:, None]
    vel = np.vstack([dq_r * sd[:-1, None], np.zeros((1, bp.dof))])
    acc = np.vstack([acc_start, acc_end[-1:]])
    traj = JointTrajectory(
        list(group.joint_names),
        ts,
        q,
        vel,
        acc,
        group.name,
        segment_accelerations=np.stack([acc_start, acc_end], axis=1),
    )
    return traj


def _trapezoid(distance: float, v: float, a: float) -> tuple[float, float, float]:
    """(duration, cruise speed, acceleration time) of the fastest rest-to-rest trapezoid."""
    if distance <= 0:
        return 0.0, 0.0, 0.0
    t_acc = v / a
    if a * t_acc * t_acc >= distance:  # no cruise: a triangle
        t_acc = math.sqrt(distance / a)
        return 2.0 * t_acc, a * t_acc, t_acc
    return 2.0 * t_acc + (distance - a * t_acc * t_acc) / v, v, t_acc


@dataclass(frozen=True)
class Profile:
    """A scalar motion profile s(t) at knot times: s, ṡ at the knots and s̈ inside each
    knot interval (constant there: the knots include every switching time)."""

    t: NDArray[np.float64]
    s: NDArray[np.float64]
    sd: NDArray[np.float64]
    sdd: NDArray[np.float64]  # (K-1,) per interval


def trapezoid_profile(distance: float, v: float, a: float, dt: float = KNOT_DT) -> Profile:
    """The fastest rest-to-rest trapezoid (or triangle) over ``distance`` with speed ≤ v and
    acceleration ≤ a, knots every ≤ dt and at both switching times."""
    T, vc, ta = _trapezoid(distance, v, a)
    acc = vc / ta if ta > 0 else 0.0
    n = max(2, int(math.ceil(T / dt)) + 1)
    t = np.unique(np.concatenate([np.linspace(0.0, T, n), [ta, T - ta]]))
    t = t[(t >= 0) & (t <= T)]
    mid = 0.5 * (t[:-1] + t[1:])
    sdd = np.where(mid < ta, acc, np.where(mid > T - ta, -acc, 0.0))
    r = T - t
    s = np.where(
        t <= ta,
        0.5 * acc * t**2,
        np.where(t >= T - ta, distance - 0.5 * acc * r**2, 0.5 * acc * ta * ta + vc * (t - ta)),
    )
    sd = np.where(t <= ta, acc * t, np.where(t >= T - ta, acc * r, vc))
    s[-1], sd[-1] = distance, 0.0
    return Profile(t, s, sd, sdd)


def along_line(
    group: JointGroup, a: NDArray[np.float64], d: NDArray[np.float64], p: Profile
) -> JointTrajectory:
    """The joint trajectory a + s(t) d of a profile along the straight line from a by d."""
    seg = np.repeat(p.sdd[:, None, None] * d[None, None, :], 2, axis=1)
    acc = np.vstack([seg[:, 0, :], seg[-1:, 1, :]])
    return JointTrajectory(
        list(group.joint_names),
        p.t,
        a + p.s[:, None] * d,
        p.sd[:, None] * d,
        acc,
        group.name,
        segment_accelerations=seg,
    )


def ptp(
    group: JointGroup,
    q_start: ArrayLike,
    q_goal: ArrayLike,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
    jerk_limited: bool = False,
    dt: float = KNOT_DT,
) -> JointTrajectory:
    """Point-to-point move (Pilz PTP): a straight line in joint space, all joints starting and
    arriving together, as fast as the slowest joint allows. Trapezoidal velocity by default;
    ``jerk_limited`` uses ruckig with the group's jerk limits (phase-synchronized, so the path
    stays the straight line)."""
    a = group.as_joint_vector(q_start, "PTP start")
    b = group.as_joint_vector(q_goal, "PTP goal")
    for q, what in ((a, "start"), (b, "goal")):
        bad = group.limit_violations(q)
        if bad:
            raise PlanningError(f"PTP {what} is outside the joint limits: {'; '.join(bad)}")
    v_max, a_max = _limits(group, velocity_scaling, acceleration_scaling)
    d = b - a
    if np.max(np.abs(d)) < 1e-12:
        return stationary(group, a)
    if jerk_limited:
        return fit_to_limits(_ruckig_ptp(group, a, b, v_max, a_max, dt), v_max, a_max)
    # along s ∈ [0, 1]: q = a + s d; joint j limits ṡ ≤ v_j/|d_j| and s̈ ≤ a_j/|d_j|
    moving = np.abs(d) > 1e-12
    v_s = float(np.min(v_max[moving] / np.abs(d[moving])))
    a_s = float(np.min(a_max[moving] / np.abs(d[moving])))
    traj = along_line(group, a, d, trapezoid_profile(1.0, v_s, a_s, dt))
    traj.positions[-1] = b
    return traj


def _ruckig_ptp(
    group: JointGroup,
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    v_max: NDArray[np.float64],
    a_max: NDArray[np.float64],
    dt: float,
) -> JointTrajectory:
    from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory

    n = group.dof
    otg = Ruckig(n)
    inp = InputParameter(n)
    inp.current_position = a.tolist()
    inp.current_velocity = [0.0] * n
    inp.current_acceleration = [0.0] * n
    inp.target_position = b.tolist()
    inp.target_velocity = [0.0] * n
    inp.target_acceleration = [0.0] * n
    inp.max_velocity = v_max.tolist()
    inp.max_acceleration = a_max.tolist()
    inp.max_jerk = joint_limits(group, "jerk").tolist()
    inp.synchronization = Synchronization.Phase
    out = Trajectory(n)
    result = otg.calculate(inp, out)
    if result not in (Result.Working, Result.Finished):
        raise PlanningError(f"ruckig could not time the PTP move of {group.name!r}: {result}")
    T = float(out.duration)
    k = max(2, int(math.ceil(T / dt)) + 1)
    ts = np.linspace(0.0, T, k)
    states = [out.at_time(float(t)) for t in ts]
    pos = np.array([s[0] for s in states])
    vel = np.array([s[1] for s in states])
    acc = np.array([s[2] for s in states])
    pos[-1], vel[-1], acc[-1] = b, 0.0, 0.0
    return JointTrajectory(list(group.joint_names), ts, pos, vel, acc, group.name)


def jerk_limited(
    group: JointGroup,
    waypoints: ArrayLike,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
    dt: float = KNOT_DT,
) -> JointTrajectory:
    """Jerk-limited trajectory through ``waypoints`` (K, dof): a ruckig PTP per segment, each
    a straight line from rest to rest (the path is exactly the polyline)."""
    wp = floats(waypoints, "waypoints", PlanningError)
    if wp.ndim != 2 or wp.shape[1] != group.dof or not np.all(np.isfinite(wp)):
        raise PlanningError(f"waypoints must be (K, {group.dof}), got shape {wp.shape}")
    traj = stationary(group, wp[0])
    for a, b in zip(wp[:-1], wp[1:], strict=True):
        if np.max(np.abs(b - a)) < 1e-12:
            continue
        traj = traj.then(
            ptp(group, a, b, velocity_scaling, acceleration_scaling, jerk_limited=True, dt=dt)
        )
    return traj
