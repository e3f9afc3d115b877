"""Where a plan's time goes, part by part, as `robocell bench planning` makes its plans.

    python benchmarks/bench_plan_parts.py [--robot panda] [--sets table_pick,table_under_pick]
        [--limit 50] [--rounds 6]

Each problem is planned once with the default settings, and the arguments of its kernel call
(``_kernels.plan_in``: the searches, the shortcut and the threads' final check in one call)
are kept. The call is then made again with parts of it switched off, each time right after a
plan of the `ompl` baseline (its caches, as in the benchmark). The parts' costs are the
differences of the medians:

- ``whole``: the call as the planner makes it;
- ``no final``: without the threads' final check of the shortcut path (the planner would
  then check it in a kernel call of its own);
- ``no shortcut``: without the shortcut (and so without the threads' final check, which
  checks the shortcut path);
- ``one search``: one search, in the calling thread, no final check;
- ``ends known``: the start and goal not classified first in the call.

Beside them: the whole plan (``Planner.plan``, as the benchmark times it) and the part of it
outside the kernel call (Python, and the numba dispatch of the call's 27 arguments). The
variants take turns from problem to problem. Medians over the problems and rounds, in one
process.

Session 35, Panda, 50 problems × 6 rounds: table_pick whole 515–548 µs, no final 374–409,
no shortcut 252–268, one search 370–399 (three runs): the search about 260 µs, the shortcut
about 120, the threads' final check about 140–200; outside the call 124–136 µs of a
0.66–0.70 ms plan. table_under_pick: whole 855–1043, no final 698–771, no shortcut 456–532.
A plan after an `ompl` plan met up to 18 page faults (2.5 µs each here), all in the kernel
call's allocations (trees of 16384 nodes, buffers of 4096 states: 4 MB a call), in
processes that had planned few problems; allocating them small and growing them left 11,
and no change in planning time that 7 alternating runs of each could show: not kept.
"""

from __future__ import annotations

import argparse
import statistics
import time

import robocell.planning._kernels as PK
from robocell.apps.bench_planning import BASELINES, default_mbm_dir, load_robot, set_problems
from robocell.planning import JointGoal, MotionPlanRequest, Planner, PlannerConfig
from robocell.planning.rrt import warm_up
from robocell.scene.checker import next_epoch

# plan_in's arguments by position (see its signature)
SEARCHES, DEADLINE, EPOCH, SIDE_BY_SIDE = 5, 6, 10, 16
SHORTCUT_DEADLINE, SHORTCUT_TRIES, CHECK_ENDS, FINAL_RESOLUTION = 17, 18, 22, 23
VARIANTS = {
    "whole": {},
    "no final": {FINAL_RESOLUTION: 0.0},
    "no shortcut": {SHORTCUT_TRIES: 0, FINAL_RESOLUTION: 0.0},
    "one search": {SEARCHES: 1, SIDE_BY_SIDE: False, FINAL_RESOLUTION: 0.0},
    "ends known": {CHECK_ENDS: False},
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robot", default="panda")
    ap.add_argument("--sets", default="table_pick,table_under_pick")
    ap.add_argument("--limit", type=int, default=50)
    ap.add_argument("--rounds", type=int, default=6, help="rounds over the problems")
    args = ap.parse_args()
    planner_id, state_check, simplify = BASELINES["ompl"]
    baseline = PlannerConfig(ompl_state_check=state_check, ompl_simplify=simplify)
    mbm = default_mbm_dir()
    model = load_robot(mbm, args.robot)
    plan_in = PK.plan_in
    call: dict[str, object] = {}

    def kept(*a: object) -> object:
        t = time.perf_counter()
        out = plan_in(*a)
        call["time"] = time.perf_counter() - t
        call["args"] = list(a)
        return out

    names = list(VARIANTS)
    print(f"{'set':17} {'part':14} {'median µs':>10}")
    for set_name in args.sets.split(","):
        cases = []
        outside, plans = [], []
        for k, scene, req in set_problems(mbm, model, args.robot, set_name, args.limit):
            checker = scene.checker(model.group(req.group))
            warm_up(checker)
            checker.check_exact_one(req.start)  # the baseline's coal model, built

            def request(pid: str, k: int = k, req=req) -> MotionPlanRequest:  # type: ignore[no-untyped-def]
                return MotionPlanRequest(
                    req.group, JointGoal(req.goal), start=req.start, seed=k, planner_id=pid,
                    time_parameterize=False,
                )  # fmt: skip

            cases.append((scene, request))
            PK.plan_in = kept
            try:
                for _ in range(2):  # a first plan, then one as the benchmark makes it
                    Planner(scene, baseline).plan(request(planner_id))
                    plan = Planner(scene, PlannerConfig()).plan(request(""))
                plans.append(plan.planning_time)
                outside.append(plan.planning_time - float(call["time"]))  # type: ignore[arg-type]
            finally:
                PK.plan_in = plan_in
            cases[-1] += (list(call["args"]),)  # type: ignore[arg-type]
        times: dict[str, list[float]] = {n: [] for n in names}
        for r in range(args.rounds):
            for c, (scene, request, a) in enumerate(cases):
                name = names[(c + r) % len(names)]
                Planner(scene, baseline).plan(request(planner_id))
                b = list(a)
                for i, v in VARIANTS[name].items():
                    b[i] = v
                now = time.perf_counter()
                b[DEADLINE] = b[SHORTCUT_DEADLINE] = now + 1.0
                b[EPOCH] = next_epoch(1 << 44)
                t = time.perf_counter()
                plan_in(*b)
                times[name].append(time.perf_counter() - t)
        rows = [("plan", statistics.median(plans)), ("outside call", statistics.median(outside))]
        rows += [(n, statistics.median(times[n])) for n in names]
        for part, t in rows:
            print(f"{set_name:17} {part:14} {t * 1e6:10.0f}")


if __name__ == "__main__":
    main()
