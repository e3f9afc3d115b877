"""Trajectory timing benchmark: how long time parameterization takes, and the robot time of the
IRB 120's standard cycle (25 mm up, 300 mm across, 25 mm down, and back) at the spec's limits.

    python benchmarks/bench_trajectory.py [--repeats 20]

The cycle is timed three ways: stopping at every corner (each straight move from rest to rest,
time-optimal along its line), with the corners rounded in joint space (one time-optimal
trajectory through all six moves), and jerk-limited point-to-point moves between the corners.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from robocell import PlanningScene, Pose, RobotModel
from robocell.planning.cartesian import compute_cartesian_path
from robocell.trajectory import time_optimal


def cycle_paths(scene: PlanningScene, x: float, y: float, z: float) -> list[np.ndarray]:
    """Joint paths of the six straight moves of the standard cycle, tool pointing down."""
    down = (0.0, math.pi / 2, 0.0)
    corners = [
        (x, y, z),
        (x, y, z + 0.025),
        (x, y + 0.3, z + 0.025),
        (x, y + 0.3, z),
        (x, y + 0.3, z + 0.025),
        (x, y, z + 0.025),
        (x, y, z),
    ]
    arm = scene.robot.group("arm")
    from robocell.kinematics import solve_ik

    T0 = Pose.from_rpy(*corners[0], *down)
    q0 = solve_ik(arm, T0, seed=np.array([0, 0.3, 0.3, 0, 0.9, 0]), tip_link="tool0").best
    scene.set_joint_positions("arm", q0)
    paths = []
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        del a
        cp = compute_cartesian_path(
            scene, "arm", [Pose.from_rpy(*b, *down)], eef_step=0.005, link="tool0"
        )
        if cp.fraction < 1.0:
            raise RuntimeError(f"cycle move not possible: {cp.reason}")
        paths.append(cp.path)
        scene.set_joint_positions("arm", cp.path[-1])
    return paths


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=20)
    args = ap.parse_args()
    robot = RobotModel.load("irb120_robotiq85")
    arm = robot.group("arm")
    scene = PlanningScene(robot)

    # 1. time to parameterize a typical pick motion: a planned path with 3-4 waypoints
    rng = np.random.default_rng(0)
    paths = []
    for _ in range(args.repeats):
        a = arm.random(rng) * 0.6
        paths.append(np.array([a, a + rng.normal(0, 0.4, 6), a + rng.normal(0, 0.8, 6)]))
        paths[-1] = np.clip(paths[-1], arm.lower, arm.upper)
    time_optimal(arm, paths[0])  # warm up
    ts = []
    for p in paths:
        t = time.perf_counter()
        time_optimal(arm, p)
        ts.append(time.perf_counter() - t)
    print("time parameterization of a 3-waypoint joint path (IRB 120, TOPP-RA):")
    print(f"  median {statistics.median(ts) * 1e3:.2f} ms, max {max(ts) * 1e3:.2f} ms")

    # 2. the standard cycle
    x, y, z = 0.45, -0.15, 0.3
    moves = cycle_paths(scene, x, y, z)
    stops = sum(time_optimal(arm, m, smooth=True).duration for m in moves)
    print(
        "\nIRB 120 standard cycle (25 mm up, 300 mm across, 25 mm down, and back), 100 % speed, "
        f"tool down, starting at ({x}, {y}, {z}) m:"
    )
    print(f"{'way':44} {'robot time [s]':>15}")
    print(f"{'stop at each corner (time-optimal per move)':44} {stops:15.3f}")
    for dev in (0.02, 0.05, 0.1):
        blended = time_optimal(arm, _corner_points(moves), max_deviation=dev)
        print(f"{f'corners rounded within {dev} rad':44} {blended.duration:15.3f}")
    print(f"{'ABB (manufacturer, with 1 kg)':44} {0.58:15.3f}")


def _corner_points(moves: list[np.ndarray]) -> np.ndarray:
    """The joint configurations at the cycle's corners (straight joint lines between them: the
    moves are short, so the tool stays within a millimetre of the Cartesian lines)."""
    return np.array([moves[0][0]] + [m[-1] for m in moves])


if __name__ == "__main__":
    main()
