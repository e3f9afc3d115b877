"""Time parameterization: limits hold at every sample, rest to rest, the path is kept."""

import numpy as np
import pytest

from robocell.errors import PlanningError, RobocellWarning
from robocell.execution.controller import stopping_trajectory
from robocell.trajectory import (
    BlendedPath,
    JointTrajectory,
    jerk_limited,
    ptp,
    retimed,
    stationary,
    time_optimal,
)
from robocell.trajectory import _kernels as TK
from robocell.trajectory.path import SplinePath, SubPath
from robocell.trajectory.timing import DEFAULT_LIMITS, _limits, joint_limits


@pytest.fixture
def arm(irb120):
    return irb120.group("arm")


@pytest.fixture
def path(arm) -> np.ndarray:
    rng = np.random.default_rng(1)
    return arm.random(rng, 4) * 0.5


@pytest.mark.parametrize("deviation", [0.0, 0.05, 0.2])
def test_time_optimal_within_limits_and_at_rest(arm, path, deviation):
    traj = time_optimal(arm, path, max_deviation=deviation)
    assert traj.limit_violations(arm) == []
    assert np.allclose(traj.positions[0], path[0]) and np.allclose(traj.positions[-1], path[-1])
    assert np.allclose(traj.velocities[[0, -1]], 0.0)
    # the trajectory follows the blended path (within the corner deviation)
    bp = BlendedPath(path, deviation)
    dense = bp.sample_states(0.002)
    pts = traj.sample(np.linspace(0, traj.duration, 500)).positions
    gap = np.min(np.linalg.norm(pts[:, None, :] - dense[None, :, :], axis=2), axis=1)
    assert gap.max() < 2e-3


def test_time_optimal_is_tight(arm, path):
    """Time-optimal: some joint runs at its velocity or acceleration limit most of the time."""
    traj = time_optimal(arm, path, max_deviation=0.05)
    s = traj.sample(np.linspace(0, traj.duration, 2000))
    at_limit = np.maximum(
        np.max(np.abs(s.velocities) / arm.velocity, axis=1),
        np.max(np.abs(s.accelerations) / arm.acceleration, axis=1),
    )
    assert np.mean(at_limit > 0.95) > 0.8


def test_default_grid_is_as_fast_as_a_converged_one(arm):
    """The default grid times a rounded path as a grid 16 times finer does: the gridpoint just
    before each arc lets the line brake into it (without it the motion all but stopped at
    the start of some arcs: 40 pick motions up to 6.6 % slower, 1.7 % in the mean)."""
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(12):
        a = arm.random(rng) * 0.6
        p = np.clip([a, a + rng.normal(0, 0.4, 6), a + rng.normal(0, 0.8, 6)], arm.lower, arm.upper)
        coarse = time_optimal(arm, p).duration
        fine = time_optimal(arm, p, grid_step=0.0025).duration
        worst = max(worst, coarse / fine - 1.0)
    assert worst < 2e-3


def test_joints_without_limits_are_timed_with_moveits_defaults(mbm_panda):
    """The MotionBenchMaker Panda's URDF gives no acceleration or jerk limits (and it has no
    joint_limits.yaml): every profile keeps to MoveIt's defaults, reaches them, and says so."""
    arm = mbm_panda.group("panda_arm")
    assert not np.isfinite(arm.acceleration).any() and not np.isfinite(arm.jerk).any()
    path = arm.random(np.random.default_rng(2), 3) * 0.5
    a = DEFAULT_LIMITS["acceleration"]
    with pytest.warns(RobocellWarning, match="no acceleration limits for panda_joint1, "):
        timed = time_optimal(arm, path)
    with pytest.warns(RobocellWarning, match="acceleration limits .* MoveIt's default, 1 rad/s²"):
        move = ptp(arm, path[0], path[1])
    with pytest.warns(RobocellWarning) as said:
        smooth = jerk_limited(arm, path)
    assert {str(w.message).split(" for ")[0] for w in said} == {
        "no acceleration limits",
        "no jerk limits",
    }
    assert "100 rad/s³" in str(said[-1].message)
    with pytest.warns(RobocellWarning, match="no acceleration limits"):
        stop = stopping_trajectory(arm, path[0], np.full(arm.dof, 0.5))
    for traj in (timed, move, smooth, stop):
        s = traj.sample(np.linspace(0.0, traj.duration, 3000))
        assert 0.95 * a < np.max(np.abs(s.accelerations)) <= a * (1 + 1e-3)
        assert traj.limit_violations(arm) == []  # the velocity limits the URDF gives
    assert stop.duration == pytest.approx(0.5 / a)
    with pytest.raises(PlanningError, match="unknown kind of joint limit 'accel'; known: "):
        joint_limits(arm, "accel")


@pytest.mark.parametrize("robot", ["irb120", "ur5e"])
def test_compiled_topp_ra_gives_toppras_profiles(robot, request):
    """The compiled TOPP-RA (trajectory._kernels.topp_ra) against toppra itself, with the
    same constraints (joint velocity, joint acceleration in its interpolation scheme), on the
    same grids: 3–6 waypoint paths with corners rounded or stopped at, splines, full and
    scaled limits. toppra bounds the path speed in float32: profiles agree to about 1e-7."""
    import toppra
    import toppra.constraint as tc

    model = request.getfixturevalue(robot)
    group = model.group("arm" if "arm" in model.groups else "manipulator")
    rng = np.random.default_rng(7)
    pieces = 0
    for trial in range(24):
        scale = (1.0, 0.3)[trial % 2]
        v_max, a_max = _limits(group, scale, scale)
        a = group.random(rng) * 0.6
        if trial % 4 == 3:
            t = np.linspace(0.0, 1.0, 25)[:, None]
            bp = SplinePath(a + np.sin(3.0 * t) * rng.normal(0.0, 0.3, group.dof))
        else:
            steps = rng.normal(0.0, 0.5, (rng.integers(2, 6), group.dof))
            wp = np.clip(a + np.cumsum(steps, axis=0), group.lower, group.upper)
            bp = BlendedPath(np.vstack([a, wp]), (0.0, 0.05, 0.2)[trial % 3])
        for s0, s1 in bp.split_at_stops():
            grid = bp.grid(0.04)
            grid = np.union1d(grid[(grid > s0) & (grid < s1)], [s0, s1])
            g = grid - grid[0]
            s = np.clip(g, 0.0, g[-1]) + grid[0]
            xs, status, _ = TK.topp_ra(bp(s, 1), bp(s, 2), np.diff(g), v_max, a_max)
            reference = toppra.algorithm.TOPPRA(
                [
                    tc.JointVelocityConstraint(v_max),
                    tc.JointAccelerationConstraint(
                        a_max, discretization_scheme=tc.DiscretizationType.Interpolation
                    ),
                ],
                SubPath(bp, grid[0], grid[-1]),
                gridpoints=g,
                solver_wrapper="seidel",
                parametrizer="ParametrizeConstAccel",
            ).compute_trajectory(0.0, 0.0)
            assert status == TK.TOPP_OK and reference is not None
            sd, sd_ref = np.sqrt(xs), np.asarray(reference._velocities)
            assert np.max(np.abs(sd - sd_ref)) < 1e-6 * sd_ref.max()
            pieces += 1
    assert pieces > 24


@pytest.mark.parametrize("move", [2e-5, 1e-6, 1e-8])
def test_a_tiny_move_arrives_where_it_was_asked(arm, move):
    """A path that moves a joint by a few µrad is timed and ends at its last waypoint: it is
    not taken as standing still (a relative tolerance had called joints near 3 rad equal
    within 3e-5 rad)."""
    q0 = np.array([0.5, 0.2, 0.1, 2.7, 0.3, 3.0])
    q1 = q0 + np.eye(6)[5] * move
    traj = time_optimal(arm, np.array([q0, q1]))
    assert traj.duration > 0.0
    assert np.allclose(traj.positions[-1], q1, rtol=0.0, atol=1e-12)
    assert traj.limit_violations(arm) == []


def test_then_joins_only_trajectories_that_meet(arm):
    """then() joins a trajectory that starts where the first ends (within 1 µrad) and refuses
    one that starts 20 µrad away, whatever the joints' values (a relative tolerance had let
    joints near 3 rad jump by 3e-5 rad at the join)."""
    q0 = np.array([0.5, 0.2, 0.1, 2.7, 0.3, 2.5])
    q1 = q0 + np.eye(6)[5] * 0.3
    first = time_optimal(arm, np.array([q0, q1]))
    back = time_optimal(arm, np.array([q1, q0]))
    joined = first.then(back)
    assert joined.duration == pytest.approx(first.duration + back.duration)
    assert np.allclose(joined.positions[-1], q0, rtol=0.0, atol=1e-12)
    off = time_optimal(arm, np.array([q1 + np.eye(6)[5] * 2e-5, q0]))
    with pytest.raises(PlanningError, match="does not start where"):
        first.then(off)


def test_limit_violations_name_the_sample_farthest_outside(arm):
    """A joint above its upper limit whose largest |value| is inside (below zero): the message
    gives the value above the limit and its time (it gave the largest |value|, inside)."""
    hi = arm.upper[2]  # joint_3: [-1.9199, 1.2217]
    q = np.zeros((3, 6))
    q[:, 2] = [-1.8, hi + 0.1, 0.0]
    traj = JointTrajectory(list(arm.joint_names), np.array([0.0, 1.0, 2.0]), q, q * 0, q * 0)
    (msg,) = [m for m in traj.limit_violations(arm, dt=0.001) if " position " in m]
    t = float(msg.split("at t=")[1].split(" s")[0])
    value = float(msg.split()[2])
    assert msg.startswith("joint_3 position") and value > hi and 0.9 < t < 1.1
    highest = traj.sample(np.arange(0, 2, 0.001)).positions[:, 2].max()
    assert value == pytest.approx(highest, abs=1e-4)


def test_waypoints_outside_the_limits_or_a_negative_deviation_are_refused(arm):
    """Before timing, naming the waypoint and the joint (the trajectory would have gone
    outside the limits, for the execution to refuse)."""
    q0, q1 = np.zeros(6), np.array([0.5, 0.2, 0.1, 0.0, 0.3, 0.0])
    far = q1.copy()
    far[4] = arm.upper[4] + 0.01
    with pytest.raises(PlanningError, match=r"waypoint 2 of 3 .*joint_5=2\.1044 not in"):
        time_optimal(arm, np.array([q0, q1, far]))
    with pytest.raises(PlanningError, match="waypoint 0 of 2"):
        time_optimal(arm, np.array([far, q0]), smooth=True)
    edge = q1.copy()
    edge[4] = arm.upper[4] + 5e-7  # within the rounding the execution's check allows
    assert time_optimal(arm, np.array([q0, edge])).limit_violations(arm) == []
    with pytest.raises(PlanningError, match="max_deviation"):
        time_optimal(arm, np.array([q0, q1, q0]), max_deviation=-0.1)


def test_retimed_runs_a_trajectory_uniformly_to_the_scaled_limits(arm, path, ur5e):
    traj = time_optimal(arm, path, 0.5, 0.5)  # a time-optimal trajectory at half the limits
    full = retimed(arm, traj, 1.0, 1.0)  # faster, to the full limits
    assert full.duration < traj.duration and full.limit_violations(arm) == []
    k = traj.duration / full.duration
    t = np.linspace(0, full.duration, 200)
    assert np.allclose(full.sample(t).positions, traj.sample(t * k).positions, atol=1e-9)
    assert retimed(arm, stationary(arm, path[0])).duration == 0.0
    with pytest.raises(PlanningError, match="not those of group 'manipulator'"):
        retimed(ur5e.group("manipulator"), traj)


def test_rounded_corners_are_faster_than_stops(arm, path):
    stop = time_optimal(arm, path, max_deviation=0.0)
    round_ = time_optimal(arm, path, max_deviation=0.1)
    assert round_.duration < stop.duration


def test_scaling_factors_slow_down(arm, path):
    full = time_optimal(arm, path)
    half = time_optimal(arm, path, velocity_scaling=0.5, acceleration_scaling=0.5)
    assert half.duration > 1.4 * full.duration
    assert half.limit_violations(arm, 0.5, 0.5) == []
    with pytest.raises(PlanningError, match="scaling"):
        time_optimal(arm, path, velocity_scaling=0.0)
    with pytest.raises(PlanningError, match="scaling"):
        time_optimal(arm, path, acceleration_scaling=1.5)


def test_ptp_synchronized_trapezoid(arm):
    a = np.zeros(6)
    b = np.array([1.0, -0.5, 0.3, 2.0, 0.1, -1.0])
    traj = ptp(arm, a, b)
    assert traj.limit_violations(arm) == []
    # a straight line in joint space: every sample is a + s (b - a)
    pts = traj.sample(np.linspace(0, traj.duration, 300)).positions
    s = (pts - a) @ (b - a) / ((b - a) @ (b - a))
    assert np.allclose(pts, a + s[:, None] * (b - a), atol=1e-9)
    # the limiting joint reaches its velocity or acceleration limit
    sm = traj.sample(np.linspace(0, traj.duration, 2000))
    ratio = max(
        np.max(np.abs(sm.velocities) / arm.velocity),
        np.max(np.abs(sm.accelerations) / arm.acceleration),
    )
    assert ratio > 0.99
    # the duration is the slowest joint's fastest trapezoid (closed form)
    times = []
    for dj, vj, aj in zip(np.abs(b - a), arm.velocity, arm.acceleration, strict=True):
        t_acc = vj / aj
        full = aj * t_acc**2 < dj
        times.append(2 * t_acc + (dj - aj * t_acc**2) / vj if full else 2 * np.sqrt(dj / aj))
    assert traj.duration == pytest.approx(max(times), rel=1e-9)


def test_ptp_rejects_out_of_limits(arm):
    with pytest.raises(PlanningError, match="joint_1"):
        ptp(arm, np.zeros(6), np.array([4.0, 0, 0, 0, 0, 0]))


def test_jerk_limited(arm, path):
    traj = jerk_limited(arm, path)
    assert traj.limit_violations(arm) == []
    # the knots are exact samples of ruckig's profile: the mean jerk between two is bounded
    jerk = np.diff(traj.accelerations, axis=0) / np.diff(traj.times)[:, None]
    assert np.max(np.abs(jerk) / arm.jerk) < 1.0 + 1e-6
    for w in path:  # passes through every waypoint (stops there)
        assert np.min(np.linalg.norm(traj.positions - w, axis=1)) < 1e-6


def test_resample_and_sample(arm, path):
    traj = time_optimal(arm, path)
    r = traj.resample(0.01)
    assert np.allclose(np.diff(r.times)[:-1], 0.01)
    # the new knots are the old trajectory's states; between them it stays within 0.1 mrad
    assert np.allclose(r.positions, traj.sample(r.times).positions, atol=1e-12)
    t = np.linspace(0, traj.duration, 777)
    assert np.allclose(r.sample(t).positions, traj.sample(t).positions, atol=1e-4)
    with pytest.raises(PlanningError):
        traj.resample(0.0)


def test_samples_between_knots_are_the_quintic_through_them(arm, path):
    """At the knots a sample is the knot; between them its velocity and acceleration are the
    derivatives of its positions (central differences), and at each interval's ends its
    acceleration is that interval's (the joint accelerations jump at a knot)."""
    traj = time_optimal(arm, path)
    at_knots = traj.sample(traj.times)
    assert np.allclose(at_knots.positions, traj.positions, atol=1e-12)
    assert np.allclose(at_knots.velocities, traj.velocities, atol=1e-9)
    i = np.arange(0, len(traj) - 1, 7)
    t = traj.times[i] + 0.37 * np.diff(traj.times)[i]
    h = 1e-5
    p = [traj.sample(t + k * h).positions for k in (-1, 0, 1)]
    s = traj.sample(t)
    assert np.allclose(s.velocities, (p[2] - p[0]) / (2 * h), atol=1e-5)
    assert np.allclose(s.accelerations, (p[2] - 2 * p[1] + p[0]) / h**2, atol=1e-2)
    ends = traj.sample(traj.times[i] + 1e-12 * np.diff(traj.times)[i])
    assert np.allclose(ends.accelerations, traj.segment_accelerations[i, 0], atol=1e-6)


@pytest.mark.parametrize(
    "call",
    [
        lambda arm, traj: time_optimal(arm, "abc"),
        lambda arm, traj: time_optimal(arm, [[0.0] * 6, [0.1, "x", 0, 0, 0, 0]]),
        lambda arm, traj: jerk_limited(arm, {"x": 1}),
        lambda arm, traj: jerk_limited(arm, [[0.0] * 6, [np.nan] * 6]),
        lambda arm, traj: traj.sample("abc"),
        lambda arm, traj: traj.sample(np.nan),
        lambda arm, traj: traj.positions_at(None),
        lambda arm, traj: traj.resample(None),
        lambda arm, traj: traj.resample("0.01"),
        lambda arm, traj: traj.scaled(None),
        lambda arm, traj: traj.scaled(0.0),
        lambda arm, traj: traj.then(None),
        lambda arm, traj: traj.then(traj.positions),
    ],
)
def test_values_of_the_wrong_kind_get_a_planning_error(arm, path, call):
    """Not a TypeError, ValueError or AttributeError from inside (a NaN time used to give NaN
    positions without a word)."""
    traj = time_optimal(arm, path)
    with pytest.raises(PlanningError):
        call(arm, traj)


def test_plot_writes_a_png(arm, path, tmp_path):
    from robocell.trajectory import plot_trajectory

    out = plot_trajectory(time_optimal(arm, path), tmp_path / "traj.png", arm)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.stat().st_size > 10_000
    with pytest.raises(PlanningError, match="JointTrajectory"):
        plot_trajectory(path, tmp_path / "x.png")
    with pytest.raises(PlanningError, match="file path"):
        plot_trajectory(time_optimal(arm, path), None)


def test_smooth_path_through_dense_samples_is_exactly_time_optimal(arm):
    """Dense samples of a smooth curve: the spline goes through each sample, and the profile
    needs no slowing down after the fact."""
    s = np.linspace(0, 1, 80)[:, None]
    curve = np.hstack([0.8 * np.sin(2 * s), 0.3 * s, 0.5 * s**2, 0.2 * s, np.cos(s), 0.1 * s])
    traj = time_optimal(arm, curve, smooth=True)
    assert traj.limit_violations(arm) == []
    assert traj.info.get("slowed_by", 1.0) < 1.01
    for q in curve[::10]:
        assert (
            np.min(
                np.linalg.norm(
                    traj.sample(np.linspace(0, traj.duration, 4000)).positions - q, axis=1
                )
            )
            < 2e-3
        )
