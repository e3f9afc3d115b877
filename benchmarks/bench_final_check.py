"""How sound the planner's final check is: the paths it returns for MotionBenchMaker problems,
as they will be executed (corners rounded), sampled far finer than the check's 0.01 rad and
checked exactly by coal. A path whose samples collide passes into an obstacle between two
states the final check found free (it is discrete, as MoveIt's is); the table gives how many
paths do, and how deep (coal's signed distance).

    python benchmarks/bench_final_check.py [--robots ur5,panda] [--sets table_pick,...]
        [--limit 20] [--step 0.001]

Session 22, with ``PlannerConfig(shortcut_tries=40, shortcut_min_gain=0.02)``: 16 of 280 paths
(20 per set), 0.02–1.97 mm deep: the gripper's fingers (13 of the 17 pairs), the Panda's hand and
its links 6 and 7; 17 of 280 with the defaults then, up to 1.97 mm. Session 24, with the
defaults (``shortcut_min_gain=0.02`` since): 16 of 280, 0.08–2.00 mm, fingers in 13 of the 17
pairs. With ``--continuous``: 0 of 280 (session 23).
"""

from __future__ import annotations

import argparse

from robocell.apps.bench_planning import default_mbm_dir, load_robot, set_problems
from robocell.planning import JointGoal, MotionPlanRequest, Planner, PlannerConfig
from robocell.trajectory import BlendedPath

SETS = "table_pick,table_under_pick,box,bookshelf_small,bookshelf_tall,bookshelf_thin,cage"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robots", default="ur5,panda")
    ap.add_argument("--sets", default=SETS)
    ap.add_argument("--limit", type=int, default=20, help="problems per set (first N)")
    ap.add_argument("--step", type=float, default=0.001, help="sampling of the paths [rad]")
    ap.add_argument(
        "--continuous", action="store_true", help="plan with PlannerConfig(continuous=True)"
    )
    args = ap.parse_args()
    config = PlannerConfig(continuous=args.continuous)
    mbm = default_mbm_dir()
    print(
        f"paths sampled every {args.step} rad, first {args.limit} problems per set, "
        f"continuous check {'on' if args.continuous else 'off'}"
    )
    header = f"{'robot':6} {'set':17} {'paths':>5} {'collide':>7} {'deepest mm':>10}  pairs"
    print(header)
    print("-" * len(header))
    total = into = 0
    for robot in args.robots.split(","):
        model = load_robot(mbm, robot)
        for name in args.sets.split(","):
            depths: list[float] = []
            pairs: set[str] = set()
            n = 0
            for k, scene, req in set_problems(mbm, model, robot, name, args.limit):
                checker = scene.checker(req.group)
                goal = JointGoal(req.goal)
                request = MotionPlanRequest(req.group, goal, start=req.start, seed=k)
                plan = Planner(scene, config).plan(request)
                if not plan.success:
                    continue
                n += 1
                path = BlendedPath(plan.path, plan.stats["corner_deviation"])
                states = path.sample_states(args.step)
                hit = states[checker.check_exact(states)]
                if len(hit):
                    found = [checker.min_distance(q) for q in hit]
                    depths.append(-min(d for d, _ in found))
                    pairs |= {" – ".join(p) for _, p in found}
            total += n
            into += len(depths)
            deepest = f"{max(depths) * 1e3:10.2f}" if depths else f"{'-':>10}"
            named = ", ".join(sorted(pairs))
            print(f"{robot:6} {name:17} {n:5d} {len(depths):7d} {deepest}  {named}", flush=True)
    print(f"{into} of {total} paths pass into an obstacle between the final check's states")


if __name__ == "__main__":
    main()
