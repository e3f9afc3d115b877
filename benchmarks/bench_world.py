"""Physics world benchmark (sorting cell, headless, no grasp assist):

- real-time factor with the arm moving (full-speed moves back and forth);
- tool tracking error during a full-speed move (tool position of the simulated robot against
  the planned one, every physics step);
- slip of each object held by friction through a full-speed transfer (joint 1 swinging
  2.5 rad at its limits): the object's offset in the tool frame before and after;
- memory over simulated time.

    python benchmarks/bench_world.py [--hours 1.0]
"""

from __future__ import annotations

import argparse
import math
import resource
import time

import numpy as np

from robocell import Pose
from robocell.cell import Cell
from robocell.execution.physics import PhysicsController
from robocell.kinematics import fk
from robocell.trajectory import ptp, time_optimal


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() / 2**20


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--hours", type=float, default=1.0, help="simulated time for the memory run")
    args = ap.parse_args()
    cell = Cell.load("sorting")
    w = cell.world
    arm = cell.robot.group("arm")
    c = PhysicsController(cell.stepper, arm, record=True)  # type: ignore[arg-type]

    # 1 + 2: full-speed moves, real-time factor and tool tracking
    a = np.array([1.2, -0.3, 0.2, 1.0, -0.8, 1.5])
    b = np.array([-1.2, 0.2, -0.2, -1.0, 0.8, -1.5])
    rtf, tool_err = [], []
    q = c.current_positions()
    for target in (a, b, a, b, np.zeros(6)):
        traj = time_optimal(arm, np.array([q, target]))
        t0 = time.perf_counter()
        h = c.execute(traj)
        h.wait()
        wall = time.perf_counter() - t0
        rtf.append(h.result.duration / wall)
        ref, act = h.reference, h.trace  # type: ignore[attr-defined]
        T_ref = np.array([fk(arm, x, "tcp")[:3, 3] for x in ref[::2]])
        T_act = np.array([fk(arm, x, "tcp")[:3, 3] for x in act[::2]])
        tool_err.append(float(np.max(np.linalg.norm(T_ref - T_act, axis=1))))
        q = c.current_positions()
    print("## Sorting cell, headless physics (timestep 2 ms), no grasp assist\n")
    print("| measure | value | target |\n|---|---|---|")
    print(f"| real-time factor, arm moving at full speed (median of 5 moves) | "
          f"{np.median(rtf):.1f} | >= 20 |")  # fmt: skip
    print(f"| tool tracking error, full-speed moves (max over 5) | "
          f"{max(tool_err) * 1e3:.2f} mm | <= 1 mm |")  # fmt: skip

    # 3: slip of each object
    print("\n| object | grasp | slip through a full-speed transfer [mm] | held |")
    print("|---|---|---|---|")
    for name in cell.object_names:
        slip, held = transfer_slip(cell, name)
        print(f"| {name} | from above, at (0.45, 0.0) | {slip:.2f} | {'yes' if held else 'NO'} |")

    # 4: memory over simulated time
    cell.reset()
    steps = int(args.hours * 3600 / w.timestep)
    m0 = None
    t0 = time.perf_counter()
    marks = []
    chunk = max(1, steps // 10)
    for k in range(0, steps, chunk):
        w.step(min(chunk, steps - k))
        m = rss_mb()
        m0 = m0 if m0 is not None else m
        marks.append(m)
    wall = time.perf_counter() - t0
    growth = (marks[-1] / marks[0] - 1) * 100
    print(
        f"\nmemory over {args.hours:.2f} h simulated (idle world, {wall:.0f} s wall): "
        f"{marks[0]:.1f} -> {marks[-1]:.1f} MB ({growth:+.1f} %)"
    )


def transfer_slip(cell: Cell, name: str) -> tuple[float, bool]:
    """Top grasp of ``name`` placed at (0.45, 0) on the conveyor, lift 15 cm, swing joint 1 by
    2.5 rad at full speed; the object's offset in the tool frame before and after [mm]."""
    cell.reset()
    w = cell.world
    assert w is not None
    o = cell.spec.object(name)
    z = 1.0 + 0.5 * o.size[2]
    # the others out of the way, along the far end of the conveyor
    others = [n for n in cell.object_names if n != name]
    for k, other in enumerate(others):
        oz = 1.0 + 0.5 * cell.spec.object(other).size[2]
        w.set_object_pose(other, Pose([0.45 + 0.15 * (k % 3), 0.7 + 0.15 * (k // 3), oz]))
    w.set_object_pose(name, Pose([0.45, 0.0, z]))
    w.step(50)
    cell.sync_scene()
    arm = cell.move_group("arm")
    arm.set_end_effector_link("tcp")
    grip = cell.move_group("gripper")
    # tcp at the object's centre, but high enough that the gripper's body (45 mm above the
    # tcp) clears a tall object's top, and the 38 mm pads clear the conveyor
    top = 1.0 + o.size[2]
    z_tcp = max(z, top - 0.035, 1.0 + 0.019 + 0.004)
    # the fingers close along the world y axis at yaw 0: across the narrower side
    yaw = math.pi / 2 if o.size[1] > o.size[0] + 1e-9 else 0.0
    arm.set_pose_target(Pose.from_rpy(0.45, 0.0, z_tcp + 0.12, 0, math.pi / 2, yaw))
    if not arm.go():
        return float("nan"), False
    cell.scene.allow_collision(name, ["gripper_left_finger", "gripper_right_finger", "conveyor"])
    if arm.move_relative((0, 0, -0.12), frame="world").fraction < 1.0:
        return float("nan"), False
    gc = cell.controller("gripper")
    gc.execute(ptp(grip.group, grip.get_current_joint_values(), [0.8])).wait()
    w.step(100)
    cell.sync_scene()
    arm.attach_object(name)
    if arm.move_relative((0, 0, 0.15), frame="world").fraction < 1.0:
        return float("nan"), False
    cell.scene.allow_collision(name, "conveyor", False)

    def offset() -> np.ndarray:
        q = w.robot_positions()[arm.group.indices]
        T = cell.scene.T_world_root @ fk(arm.group, q, "tcp")
        return T[:3, :3].T @ (w.object_pose(name).position - T[:3, 3])

    before = offset()
    arm.set_joint_value_target({"joint_1": 2.5})
    arm.go()
    w.step(100)
    after = offset()
    held = {"robot/gripper_left_finger", "robot/gripper_right_finger"} <= w.touching(name)
    arm.detach_object(name)
    return float(np.linalg.norm(after - before) * 1e3), held


if __name__ == "__main__":
    main()
