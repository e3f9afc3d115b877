"""Planning after a rest: how long a plan takes when the process has slept before it (a user's
script between moves, an interactive session), against one made while the process is busy.

    python benchmarks/bench_rest.py [--limit 20] [--rest 0.3]

The kernel's threads sleep between parallel calls; after the process rested they were slow to
wake on this 2-core VM (5.7–7.8 ms, session 18). The planner then keeps to the calling thread
(``PlannerConfig.threads=None``, the default); the baseline, ``threads=True``, uses the threads
whatever came before, as the planner did up to session 17. Each problem is planned with both,
alternating, after the same rest, in one process; the paths are the same.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from robocell.apps.bench_planning import default_mbm_dir, load_robot, set_problems
from robocell.planning import JointGoal, MotionPlanRequest, Planner, PlannerConfig

CONFIGS = {"robocell": PlannerConfig(), "threads always": PlannerConfig(threads=True)}


def busy(seconds: float) -> None:
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--limit", type=int, default=20, help="problems per set")
    ap.add_argument("--rest", type=float, default=0.3, help="seconds before each plan")
    args = ap.parse_args()
    mbm = default_mbm_dir()
    print(f"before each plan: {args.rest} s asleep or busy; medians over {args.limit} problems")
    print(f"{'robot':6} {'set':11} {'before':7} {'planner':15} {'median ms':>10} {'ratio':>7}")
    for robot in ("panda", "ur5"):
        model = load_robot(mbm, robot)
        problems = []
        for k, scene, req in set_problems(mbm, model, robot, "table_pick", args.limit):
            request = MotionPlanRequest(
                req.group, JointGoal(req.goal), start=req.start, seed=k, time_parameterize=False
            )
            Planner(scene).plan(request)  # the scene's checker built, the kernels loaded
            problems.append((scene, request))
        # all plans after a sleep first, then all after busy spells: how fast the threads
        # wake depends on how busy the machine was in the last second or so (measured)
        for before, wait in (("asleep", time.sleep), ("busy", busy)):
            times: dict[str, list[float]] = {name: [] for name in CONFIGS}
            for k, (scene, request) in enumerate(problems):
                paths = []
                for name in list(CONFIGS) if k % 2 else list(CONFIGS)[::-1]:
                    wait(args.rest)
                    t0 = time.perf_counter()
                    plan = Planner(scene, CONFIGS[name]).plan(request)
                    times[name].append(time.perf_counter() - t0)
                    paths.append(plan.path)
                if not np.array_equal(paths[0], paths[1]):
                    raise SystemExit(f"{robot} problem {k + 1}: the paths differ")
            base = statistics.median(times["threads always"])
            for name in CONFIGS:
                med = statistics.median(times[name])
                print(
                    f"{robot:6} {'table_pick':11} {before:7} {name:15} {med * 1e3:10.2f} "
                    f"{base / med:6.2f}x"
                )


if __name__ == "__main__":
    main()
