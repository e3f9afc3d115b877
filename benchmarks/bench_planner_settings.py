"""Planner settings side by side on the MotionBenchMaker problems, in one process, each plan
made as `robocell bench planning` makes it: right after a plan of the `ompl` baseline (which
leaves the caches and the kernel's threads as they are in that benchmark). Prints, per set and
setting, the median and p95 planning time, the mean path length, and two counts of work that
do not depend on the machine or its load (a plan's seed fixes them): the states the searches
and the shortcut checked (``checked``), and the states of the path at the validation
resolution (``path states``: about what the final check classifies; corners' arcs aside).

    python benchmarks/bench_planner_settings.py --robots panda --sets table_pick \\
        --settings '{"now": {}, "no gain": {"shortcut_min_gain": 0.0}}' [--reps 2] [--limit 50]

The counts compare settings where the times cannot: on a busy day of this shared machine the
times of one setting scatter by ±15 % from run to run, the counts not at all. Session 44, 30
problems each: ``shortcut_min_gain`` 0.05 instead of 0.02 checked 7 % fewer states on Panda
table_pick (274 against 295 a plan; the searches are the same, the shortcut checks less) and 5 %
fewer on table_under_pick (331 against 348), with paths 1.0 % and 0.6 % longer; the times did
not show it (0.856 against 0.866 ms, 1.457 against 1.428).

Each setting is a dict of PlannerConfig fields. The order in which the settings run turns from
problem to problem. Why each plan follows a baseline plan: when settings A and B simply took
turns with the baseline (A, B, ompl, then B, ompl, A, then ompl, A, B), A came after the
baseline twice as often as B did, and a plan that follows the baseline's 10 ms of Python starts
on cold caches and sleeping threads. Session 24, the final check in the calling thread (B)
against on the kernel's threads (A), Panda table and bookshelf_thin sets: taking turns, B looked
3–12 % faster; each after a baseline plan, it was 2–9 % slower.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from robocell.apps.bench_planning import BASELINES, default_mbm_dir, load_robot, set_problems
from robocell.planning import JointGoal, MotionPlanRequest, Planner, PlannerConfig
from robocell.planning import _kernels as PK
from robocell.planning.rrt import warm_up


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", default="panda")
    ap.add_argument("--sets", default="table_pick,table_under_pick")
    ap.add_argument("--settings", default='{"default": {}}', help="JSON: name -> PlannerConfig")
    ap.add_argument("--reps", type=int, default=1, help="rounds over the problems")
    ap.add_argument("--limit", type=int, default=50)
    args = ap.parse_args()
    settings = {name: PlannerConfig(**kw) for name, kw in json.loads(args.settings).items()}
    names = list(settings)
    planner_id, state_check, simplify = BASELINES["ompl"]
    baseline = PlannerConfig(ompl_state_check=state_check, ompl_simplify=simplify)
    mbm = default_mbm_dir()
    print(
        f"{'robot':6} {'set':17} {'setting':16} {'median ms':>10} {'p95 ms':>8} {'length':>7} "
        f"{'checked':>8} {'path states':>11}"
    )
    for robot in args.robots.split(","):
        model = load_robot(mbm, robot)
        for set_name in args.sets.split(","):
            times: dict[str, list[float]] = {n: [] for n in names}
            lengths: dict[str, list[float]] = {n: [] for n in names}
            checked: dict[str, list[float]] = {n: [] for n in names}
            path_states: dict[str, list[float]] = {n: [] for n in names}
            for rep in range(args.reps):
                for k, scene, req in set_problems(mbm, model, robot, set_name, args.limit):
                    checker = scene.checker(model.group(req.group))
                    warm_up(checker)
                    checker.check_exact_one(req.start)  # the baseline's coal model, built
                    turn = (k + rep) % len(names)
                    for name in names[turn:] + names[:turn]:
                        for config, pid in ((baseline, planner_id), (settings[name], "")):
                            request = MotionPlanRequest(
                                req.group, JointGoal(req.goal), start=req.start, seed=k + rep,
                                planner_id=pid, time_parameterize=False,
                            )  # fmt: skip
                            t0 = time.perf_counter()
                            plan = Planner(scene, config).plan(request)
                            took = time.perf_counter() - t0
                        times[name].append(took * 1e3 if plan.success else float("nan"))
                        lengths[name].append(plan.path_length if plan.success else float("nan"))
                        checked[name].append(plan.stats.get("checked_states", float("nan")))
                        # a failed plan's path is empty: segment_states needs its start
                        resolution = settings[name].validation_resolution
                        n = float("nan")
                        if plan.success:
                            n = len(PK.segment_states(plan.path, resolution)[0])
                        path_states[name].append(n)
            for name in names:
                t = np.array(times[name])
                print(
                    f"{robot:6} {set_name:17} {name:16} {np.nanmedian(t):10.3f} "
                    f"{np.nanpercentile(t, 95):8.2f} {np.nanmean(lengths[name]):7.3f} "
                    f"{np.nanmean(checked[name]):8.1f} {np.nanmean(path_states[name]):11.1f}"
                    + (f"  ({int(np.isnan(t).sum())} failed)" if np.isnan(t).any() else "")
                )


if __name__ == "__main__":
    main()
