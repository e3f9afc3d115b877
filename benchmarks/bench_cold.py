"""Where a plan's time goes when its caches are cold.

    python benchmarks/bench_cold.py [--limit 30] [--rounds 3]

The same Panda table_pick problems, each planned once first, then again:

- at once (hot);
- after the calling thread kept busy for 10 ms: the kernel's second thread went to sleep;
- after 64 MB were read: the caches flushed, as loading a scene or a neighbour on the host
  does, with the planner's threads and in the calling thread alone (one search, the final
  check in the calling thread: no thread to wake).

Then, after the same flush and in the calling thread alone, which of the kernel's data read
back first gives back most of the plan's time: its sphere trees, its self-collision distance
fields, the world's distance grid, its self-collision tables, its other arrays, the scratch.
Reading them takes longer than it saves: the table says where the cold plan's misses are,
not what to do before a plan (prefetching the model's arrays of up to 64 kB, 512 kB or 2 MB
at the search's start, with LLVM's prefetch, made cold plans 2–10 % slower, session 30).
Medians over the problems and rounds, in one process.

These conditions are colder than a plan that follows an ``ompl`` plan, as `robocell bench
planning` makes them: after 10 ms of a Python loop or asleep, the kernel's second thread is
asleep (a parallel call of nothing took 149 µs after the loop, 11 µs after an ``ompl`` plan),
and after an ``ompl`` plan reading the world grid or the tables back saved 0–14 µs, not
~100 (session 41; see PLANNING.md).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from bench_rest import busy  # this folder's (python benchmarks/bench_cold.py)
from robocell.apps.bench_planning import default_mbm_dir, load_robot, set_problems
from robocell.planning import JointGoal, MotionPlanRequest, Planner, PlannerConfig
from robocell.scene import _kernels as K

ALONE = PlannerConfig(threads=False, searches=1)  # the calling thread alone
FLUSH = np.ones(64 << 17)  # 64 MB, twice this host's last-level cache
GROUPS = {
    "sphere trees": (
        "nodes", "left", "right", "node_tri_start", "node_tri_ids", "node_members", "inner",
    ),
    "distance fields": ("grid_values",),
    "world grid": ("world_values",),
    "tables": ("table_values",),
}  # fmt: skip


def flush() -> None:
    for _ in range(2):
        FLUSH[::8].sum()  # one read per 64-byte line


def read(arrays: list[np.ndarray]) -> None:
    for a in arrays:
        a.reshape(-1).view(np.uint8)[::64].sum()


def data_groups(checker: Any) -> dict[str, list[np.ndarray]]:
    """The checker's kernel data by GROUPS, the model's other arrays, and the scratch."""
    model, scratch = checker.kernel_inputs()
    named = dict(zip(K.MODEL_FIELDS, model, strict=True))
    out = {g: [named[n] for n in names] for g, names in GROUPS.items()}
    grouped = {n for names in GROUPS.values() for n in names}
    out["other model arrays"] = [
        a for n, a in named.items() if n not in grouped and isinstance(a, np.ndarray)
    ]
    out["scratch"] = list(scratch)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--limit", type=int, default=30, help="problems")
    ap.add_argument("--rounds", type=int, default=3, help="plans of each problem per condition")
    args = ap.parse_args()
    mbm = default_mbm_dir()
    model = load_robot(mbm, "panda")
    problems = []
    for k, scene, req in set_problems(mbm, model, "panda", "table_pick", args.limit):
        request = MotionPlanRequest(
            req.group, JointGoal(req.goal), start=req.start, seed=k, time_parameterize=False
        )
        Planner(scene).plan(request)  # the scene's checker built, the kernels loaded
        problems.append((scene, request))

    def plan(scene: Any, request: MotionPlanRequest, config: PlannerConfig) -> float:
        t0 = time.perf_counter()
        Planner(scene, config).plan(request)
        return time.perf_counter() - t0

    conditions: dict[str, tuple[Callable[[], None], PlannerConfig]] = {
        "hot": (lambda: None, PlannerConfig(threads=True)),
        "after 10 ms busy": (lambda: busy(0.01), PlannerConfig(threads=True)),
        "after a flush": (flush, PlannerConfig(threads=True)),
        "hot, alone": (lambda: None, ALONE),
        "after a flush, alone": (flush, ALONE),
    }
    times: dict[str, list[float]] = {name: [] for name in conditions}
    for _ in range(args.rounds):
        for scene, request in problems:
            for name, (before, config) in conditions.items():
                plan(scene, request, config)
                before()
                times[name].append(plan(scene, request, config))
    hot = statistics.median(times["hot"])
    print(f"Panda table_pick, {len(problems)} problems x {args.rounds} rounds, medians")
    print(f"{'the plan runs':24} {'ms':>7} {'vs hot':>7}")
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"{name:24} {med * 1e3:7.3f} {med / hot:6.2f}x")

    names = ["nothing", *data_groups(problems[0][0].checker(problems[0][1].group))]
    plans: dict[str, list[float]] = {name: [] for name in names}
    reads: dict[str, list[float]] = {name: [] for name in names}
    sizes: dict[str, float] = {}
    for _ in range(args.rounds):
        for scene, request in problems:
            groups = data_groups(scene.checker(request.group))
            for name in names:
                arrays = groups.get(name, [])
                sizes[name] = sum(a.nbytes for a in arrays) / 1e6
                plan(scene, request, ALONE)
                flush()
                t0 = time.perf_counter()
                read(arrays)
                reads[name].append(time.perf_counter() - t0)
                plans[name].append(plan(scene, request, ALONE))
    cold = statistics.median(plans["nothing"])
    print()
    print("after a flush, in the calling thread alone: the data read back before the plan")
    print(f"{'read back':20} {'MB':>6} {'read ms':>8} {'plan ms':>8} {'saved ms':>9}")
    for name in names:
        med = statistics.median(plans[name])
        print(
            f"{name:20} {sizes[name]:6.1f} {statistics.median(reads[name]) * 1e3:8.3f} "
            f"{med * 1e3:8.3f} {(cold - med) * 1e3:9.3f}"
        )


if __name__ == "__main__":
    main()
