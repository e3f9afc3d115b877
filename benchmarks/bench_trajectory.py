"""Trajectory timing benchmark: how long time parameterization takes, and the robot time of the
IRB 120's standard cycle (25 mm up, 300 mm across, 25 mm down, and back) at the spec's limits.

    python benchmarks/bench_trajectory.py [--repeats 20]

Time parameterization is timed whole (``time_optimal``), then its TOPP-RA step alone: the
compiled one robocell runs (``trajectory._kernels.topp_ra``) and toppra's own, with the same
constraints on the same grids (toppra's Python loop over the gridpoints took three quarters of
a 4 ms ``time_optimal``, session 47).

The cycle runs as a sequence of straight (LIN) moves through its corners: stopping at every
corner, then with the corners rounded by blend radii (Pilz's blend, ABB's zones).
"""

from __future__ import annotations

import argparse
import functools
import math
import statistics
import time

import numpy as np
import toppra
import toppra.constraint as tc

from robocell import PlanningScene, Pose, RobotModel
from robocell.cell import MoveGroup
from robocell.kinematics import solve_ik
from robocell.trajectory import BlendedPath, time_optimal
from robocell.trajectory import _kernels as TK
from robocell.trajectory.path import SubPath
from robocell.trajectory.timing import _limits


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=20)
    args = ap.parse_args()
    robot = RobotModel.load("irb120_robotiq85")
    arm = robot.group("arm")
    scene = PlanningScene(robot)

    # 1. time to parameterize a typical pick motion: a planned path with 3 waypoints
    rng = np.random.default_rng(0)
    paths = []
    for _ in range(args.repeats):
        a = arm.random(rng) * 0.6
        p = np.array([a, a + rng.normal(0, 0.4, 6), a + rng.normal(0, 0.8, 6)])
        paths.append(np.clip(p, arm.lower, arm.upper))
    time_optimal(arm, paths[0])  # warm up
    ts = []
    for p in paths:
        t = time.perf_counter()
        time_optimal(arm, p)
        ts.append(time.perf_counter() - t)
    print("time parameterization of a 3-waypoint joint path (IRB 120, TOPP-RA):")
    print(f"  median {statistics.median(ts) * 1e3:.2f} ms, max {max(ts) * 1e3:.2f} ms")

    # 1b. the TOPP-RA step alone, compiled against toppra's own, on the same grids, alternating
    v_max, a_max = _limits(arm, 1.0, 1.0)
    # toppra at its best, as robocell ran it until session 47: its constraints made once, its
    # look for optional solvers (importlib, per instance) made once per process
    constraints = [
        tc.JointVelocityConstraint(v_max),
        tc.JointAccelerationConstraint(
            a_max, discretization_scheme=tc.DiscretizationType.Interpolation
        ),
    ]
    toppra.solverwrapper.available_solvers = functools.cache(toppra.solverwrapper.available_solvers)
    ours, theirs = [], []
    for p in paths * 3:
        bp = BlendedPath(p, 0.05)
        grid = bp.grid(0.04)
        g = grid - grid[0]
        t = time.perf_counter()
        s = np.clip(g, 0.0, g[-1]) + grid[0]
        TK.topp_ra(bp(s, 1), bp(s, 2), np.diff(g), v_max, a_max)
        ours.append(time.perf_counter() - t)
        t = time.perf_counter()
        toppra.algorithm.TOPPRA(
            constraints,
            SubPath(bp, grid[0], grid[-1]),
            gridpoints=g,
            solver_wrapper="seidel",
            parametrizer="ParametrizeConstAccel",
        ).compute_trajectory(0.0, 0.0)
        theirs.append(time.perf_counter() - t)
    print("its TOPP-RA step (the same grids, alternating):")
    print(f"{'':4}{'':24} {'median ms':>10} {'max ms':>8}")
    for name, x in (("compiled (topp_ra)", ours), ("toppra 0.6 (seidel)", theirs)):
        print(f"{'':4}{name:24} {statistics.median(x) * 1e3:10.3f} {max(x) * 1e3:8.3f}")
    print(f"{'':4}ratio of medians: {statistics.median(theirs) / statistics.median(ours):.1f}x")

    # 2. the standard cycle, as a LIN sequence through its corners
    x, y, z = 0.45, -0.15, 0.3
    down = (0.0, math.pi / 2, 0.0)
    corners = [
        (x, y, z + 0.025),
        (x, y + 0.3, z + 0.025),
        (x, y + 0.3, z),
        (x, y + 0.3, z + 0.025),
        (x, y, z + 0.025),
        (x, y, z),
    ]
    start = solve_ik(
        arm,
        Pose.from_rpy(x, y, z, *down),
        seed=np.array([0, 0.3, 0.3, 0, 0.9, 0]),
        tip_link="tool0",
    ).best
    print(
        "\nIRB 120 standard cycle (25 mm up, 300 mm across, 25 mm down, and back), 100 % speed, "
        f"tool down, from ({x}, {y}, {z}) m:"
    )
    print(f"{'way':36} {'robot time [s]':>15} {'plan+timing [ms]':>17}")
    # the first sequence builds the scene's collision checker (sphere model, pair tables) and
    # loads the compiled kernels: once per scene, not per motion (it was in the first row)
    scene.set_joint_positions("arm", start)
    MoveGroup(scene, "arm", time_scale=0).compute_sequence([Pose.from_rpy(*corners[0], *down)])
    for blend in (0.0, 0.01, 0.02, 0.025):
        scene.set_joint_positions("arm", start)
        group = MoveGroup(scene, "arm", time_scale=0)
        group.set_end_effector_link("tool0")
        t = time.perf_counter()
        plan = group.compute_sequence([Pose.from_rpy(*c, *down) for c in corners], blend)
        ms = (time.perf_counter() - t) * 1e3
        assert plan.fraction == 1.0, plan.reason
        way = "stop at each corner" if blend == 0 else f"blend radius {blend * 1e3:.1f} mm"
        print(f"{way:36} {plan.trajectory.duration:15.3f} {ms:17.1f}")
    print(f"{'ABB (manufacturer, with 1 kg)':36} {0.58:15.3f}")
    print(
        "Each is TOPP-RA's time-optimal bound along its own path (the check after it slows it "
        "by < 0.01 %)."
    )


if __name__ == "__main__":
    main()
