"""What a plan costs before it meets its problem: the same plans first in a freshly loaded
scene, or right after an ``ompl`` plan, as `robocell bench planning` makes them (each planner
goes first on every other problem), and a plan that has nothing to search.

    python benchmarks/bench_plan_order.py [--robot panda] [--sets table_pick,table_under_pick]
        [--limit 50]

Per problem, in one process, each timed as the benchmark times a plan (``Planner.plan``):

- ``first in scene``: robocell's plan of a freshly loaded scene, after what the benchmark does
  before its first plan there (the checker built, the start and goal checked);
- ``first, threads woken``: the same, after an untimed parallel call that does nothing, just
  before the plan: the kernel's threads awake, the scene's data as it was;
- ``after ompl``: the same plan (the same seed: the same path), right after an ``ompl`` plan of
  the problem;
- ``nothing to search``: a plan from the start to the start moved 0.02 rad on joint 1, right
  after an ``ompl`` plan: what every plan costs whatever its problem (the request's checks,
  the kernel call, the searches' threads, the final check of a short path).

The paired differences (each problem's plan against its own ``after ompl`` plan) take out
the problems' spread, which the medians keep. Each variant of a problem loads its scene anew.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from robocell.apps.bench_planning import _plan_once, default_mbm_dir, load_robot, set_problems
from robocell.planning import JointGoal, MotionPlanRequest, Planner, PlannerConfig
from robocell.planning.rrt import warm_up
from robocell.scene.moveit_yaml import load_scene

VARIANTS = ("first in scene", "first, threads woken", "after ompl", "nothing to search")


@njit(parallel=True)
def _parallel_nothing(n: int) -> NDArray[np.float64]:
    """A parallel loop of n iterations that does nothing: it wakes the kernel's threads."""
    out = np.zeros(n)
    for i in prange(n):
        out[i] = i
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robot", default="panda")
    ap.add_argument("--sets", default="table_pick,table_under_pick")
    ap.add_argument("--limit", type=int, default=50, help="problems per set")
    ap.add_argument("--seed", type=int, default=0, help="problem k plans with seed + k")
    args = ap.parse_args()
    mbm = default_mbm_dir()
    model = load_robot(mbm, args.robot)
    _parallel_nothing(2)
    print(f"{args.robot}, first {args.limit} problems per set; ms, medians; paired: each")
    print("problem's plan minus its own plan after an ompl plan")
    print(f"{'set':17} {'plan':22} {'median ms':>10} {'paired ms':>10}")
    for set_name in args.sets.split(","):
        folder = mbm / args.robot / "problems" / f"{set_name}_{args.robot}"
        times: dict[str, list[float]] = {v: [] for v in VARIANTS}
        for k, loaded, req in set_problems(mbm, model, args.robot, set_name, args.limit):
            seed = args.seed + k
            request = MotionPlanRequest(
                req.group, JointGoal(req.goal), start=req.start, planning_time=1.0, seed=seed,
                time_parameterize=False,
            )  # fmt: skip
            nearby = req.start.copy()
            nearby[0] += 0.02
            short = MotionPlanRequest(
                req.group, JointGoal(nearby), start=req.start, planning_time=1.0, seed=seed,
                time_parameterize=False,
            )  # fmt: skip
            for i, variant in enumerate(VARIANTS):
                # each variant plans in a scene of its own, loaded anew (the first: set_problems')
                scene = load_scene(model, folder / f"scene{k:04d}.yaml") if i else loaded
                checker = scene.checker(model.group(req.group))
                warm_up(checker)
                checker.check_exact_one(req.start)
                if checker.check(np.array([req.start, req.goal])).any():
                    break  # not a valid problem
                planner = Planner(scene, PlannerConfig())
                if variant == "first, threads woken":
                    _parallel_nothing(2)
                elif variant in ("after ompl", "nothing to search"):
                    _plan_once(scene, args.robot, set_name, k, req, "ompl", True, 1.0, seed, False)
                t = time.perf_counter()
                plan = planner.plan(short if variant == "nothing to search" else request)
                times[variant].append((time.perf_counter() - t) * 1e3)
                if not plan.success:
                    raise RuntimeError(f"{set_name} problem {k}: {variant}: {plan.reason}")
        base = times["after ompl"]
        for variant in VARIANTS:
            v = times[variant]
            paired = statistics.median([a - b for a, b in zip(v, base, strict=True)])
            print(f"{set_name:17} {variant:22} {statistics.median(v):10.3f} {paired:10.3f}")


if __name__ == "__main__":
    main()
