"""``robocell info``: the bundled robots and cells, and a short self-check of each robot."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from robocell.cell.cell_file import bundled_cells
from robocell.geometry.pose import Pose
from robocell.kinematics import fk, ik_solver, pose_error, solve_ik
from robocell.robot.model import RobotModel, bundled_robots
from robocell.scene.planning_scene import PlanningScene


@dataclass
class CheckResult:
    robot: str
    groups: str
    load_s: float
    ik_solver: str
    ik_ok: int
    ik_total: int
    collision_ok: bool
    detail: str

    @property
    def passed(self) -> bool:
        return self.ik_ok == self.ik_total and self.collision_ok


def check_robot(name: str, n_poses: int = 20, seed: int = 0) -> CheckResult:
    """Load a bundled robot; IK round trips on random reachable poses; one collision query
    that must be free (home) and one that must collide (a box placed at the tool)."""
    t = time.perf_counter()
    robot = RobotModel.load(name)
    load_s = time.perf_counter() - t
    arm_name = next(g for g in robot.groups if robot.groups[g].dof == 6)
    arm = robot.group(arm_name)
    rng = np.random.default_rng(seed)
    ok = 0
    for _ in range(n_poses):
        q = arm.random(rng)
        T = fk(arm, q, relative_to=arm.base_link)
        res = solve_ik(arm, T, seed=q)
        if res.success and all(
            max(pose_error(fk(arm, s, relative_to=arm.base_link), T)) < 1e-6 for s in res.solutions
        ):
            ok += 1
    scene = PlanningScene(robot)
    home = next(iter(arm.named_states.values()), arm.default_positions)
    free = not scene.in_collision(home, arm)
    T_tool = fk(arm, home)
    scene.add_box("probe", Pose.from_matrix(T_tool), (0.05, 0.05, 0.05))
    hit = scene.in_collision(home, arm)
    pairs = scene.colliding_pairs(home, arm)
    detail = f"home free: {free}; box at {arm.tip_link} collides: {hit} ({len(pairs)} pairs)"
    return CheckResult(
        name,
        ", ".join(f"{g}({robot.groups[g].dof})" for g in robot.groups),
        load_s,
        ik_solver(arm).name,
        ok,
        n_poses,
        free and hit,
        detail,
    )


def run_info() -> int:
    print("robocell: plan, simulate and run pick-and-place with industrial arms\n")
    results = []
    for name in bundled_robots():
        results.append(check_robot(name))
    print(
        f"{'robot':<20} {'groups (dof)':<40} {'load s':>7} {'IK':>6} "
        f"{'IK round trips':>15}  collision"
    )
    for r in results:
        print(
            f"{r.robot:<20} {r.groups:<40} {r.load_s:>7.2f} {r.ik_solver:>6} "
            f"{r.ik_ok:>7}/{r.ik_total:<7}  {'ok' if r.collision_ok else 'FAIL'}: {r.detail}"
        )
    cells = bundled_cells()
    print(f"\ncells: {', '.join(cells) if cells else 'none bundled in this version'}")
    cell_ok = []
    for name in cells:
        ok, line = check_cell(name)
        cell_ok.append(ok)
        print(f"  {name}: {'ok' if ok else 'FAIL'}: {line}")
    passed = all(r.passed for r in results) and all(cell_ok)
    print(
        f"\nself-check: {'PASS' if passed else 'FAIL'} "
        f"({sum(r.passed for r in results)}/{len(results)} robots, "
        f"{sum(cell_ok)}/{len(cell_ok)} cells)"
    )
    return 0 if passed else 1


def check_cell(name: str) -> tuple[bool, str]:
    """Load a cell in physics; plan the arm to a point above its first object and back home,
    run both in the world; report planning time, robot time, tracking and real-time factor."""
    from robocell.cell import Cell

    t = time.perf_counter()
    cell = Cell.load(name)
    load_s = time.perf_counter() - t
    arm = cell.move_group(cell.robot_spec.arm)
    first = cell.object_names[0]
    p = cell.object_pose(first).position
    arm.set_position_target([p[0], p[1], p[2] + 0.2])
    plan = arm.plan()
    if not plan.success:
        return False, f"planning above {first} failed: {plan.reason}"
    ok = arm.execute(plan)
    err = arm.last_execution.result.max_tracking_error if arm.last_execution else float("nan")
    home = cell.robot_spec.home
    if home:
        arm.set_named_target(home)
        ok = ok and arm.go()
    assert cell.stepper is not None
    rtf = cell.stepper.real_time_factor
    return ok, (
        f"loaded in {load_s:.2f} s; planned above {first} in {plan.planning_time * 1e3:.0f} ms, "
        f"{plan.trajectory.duration if plan.trajectory else 0:.2f} s of robot motion, "
        f"tracked within {err * 1e3:.2f} mrad in physics at {rtf:.0f}x real time"
    )
