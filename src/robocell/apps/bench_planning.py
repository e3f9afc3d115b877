"""``robocell bench planning``: the MotionBenchMaker problems (../shared/bench/mbm), planned
with the native planner and, with ``--baseline``, with OMPL's RRTConnect in the same run. Prints
one row per set and planner; ``--json`` writes every problem's figures.

Baselines (``--baseline ompl,ompl-kernel,ompl-moveit``); the first two go through the native
planner's shortcut and final check after OMPL's search, so that only the search differs:

- ``ompl``: OMPL's RRTConnect checking each state exactly, coal alone through a broad phase
  (``CollisionChecker.check_exact_one``), as MoveIt's OMPL pipeline does with FCL.
- ``ompl-kernel``: OMPL's RRTConnect checking each state with robocell's two-level checker
  (spheres, then coal where they are unsure), one state per call: the search alone compared.
- ``ompl-moveit``: as ``ompl``, its path then simplified by OMPL's own simplifier with the
  same exact checks, as MoveIt's OMPL pipeline does (``simplify_solutions``), instead of the
  native shortcut; the same final check.

Planning time is from the request to the validated path (goal resolution, planning,
shortcutting, the final check at fine resolution); scene loading and the checker's
construction (its sphere model, and coal's model of the scene for ``ompl``) are not in it, as
in MoveIt's benchmarks. The planners take turns going first in each new scene.

Each baseline's row gives its speed-up (its median over the native planner's) and that ratio's
95 % interval over the set's problems (:func:`ratio_interval`); with ``--runs N``, also the
lowest and highest ratio of a single run (:func:`run_ratios`): the spread a one-run benchmark
shows from seed to seed (session 32, Panda table_pick over ten seeds, one run each: 9.4–17.4×;
OMPL's median ranged from 6.5 to 10.7 ms).

Problem k plans with seed ``--seed`` + k, OMPL's plans too (OMPL's seed sequence restarts
before each plan), so that a run repeats whatever ran before it in the process. ``--runs N``
plans each problem N times, run r with seed ``--seed`` + k + 1000·r, as MoveIt's benchmarks run
each query several times: a set's median is then over N·50 plans, and the ratio between two
planners less at the mercy of one seed (over seeds 0–5, one run each, OMPL's median on the
Panda's table_under_pick ranged from 11.8 to 16.3 ms, session 25).

``--busy N`` runs N other processes that each keep a core busy meanwhile: what a shared
machine's load does to the planners. Beside one on this 2-core machine (session 50, Panda table
sets), robocell's medians were 1.97 and 2.94 ms and the ratios 10.0× and 9.7× while its two
searches still ran side by side; with the planner keeping to the calling thread while the host
keeps its threads waiting (:class:`robocell.scene.checker.ThreadGauge`), 1.12 and 1.80 ms and
14.8× and 15.4×, every set of both robots 14.8× or more.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from robocell.errors import PlanningError, RobocellError, unknown
from robocell.planning import JointGoal, MotionPlanRequest, Planner, PlannerConfig
from robocell.planning.rrt import warm_up
from robocell.robot.model import RobotModel
from robocell.scene.moveit_yaml import PlanRequest, load_request, load_scene
from robocell.scene.planning_scene import PlanningScene

# baseline name -> OMPL planner, how its callback checks a state, whether OMPL simplifies
BASELINES = {
    "ompl": ("RRTConnectkConfigDefault", "exact", False),
    "ompl-kernel": ("RRTConnectkConfigDefault", "kernel", False),
    "ompl-moveit": ("RRTConnectkConfigDefault", "exact", True),
}


@dataclass
class ProblemResult:
    robot: str
    set: str
    problem: int
    planner: str
    valid: bool
    seed: int = 0
    solved: bool = False
    time: float = float("nan")
    path_length: float = float("nan")
    reason: str = ""


@dataclass
class SetRow:
    robot: str
    set: str
    planner: str
    problems: int
    valid: int
    solved: int
    median_ms: float
    p95_ms: float
    median_length: float
    results: list[ProblemResult] = field(default_factory=list)
    runs: int = 1  # plans per problem, each with a seed of its own: solved counts plans
    # a baseline's row: its median over the native planner's, and that ratio's 95 % interval
    # over the set's problems (ratio_interval)
    speedup: float = float("nan")
    speedup_low: float = float("nan")
    speedup_high: float = float("nan")
    # with --runs N: the ratio in each run alone (run_ratios)
    speedup_runs: list[float] = field(default_factory=list)


RESAMPLES = 2000  # of the problems, for a speed-up's interval


def ratio_interval(
    native: list[ProblemResult],
    baseline: list[ProblemResult],
    level: float = 0.95,
    resamples: int = RESAMPLES,
    seed: int = 0,
) -> tuple[float, float]:
    """The ``level`` interval of the ratio of the baseline's median planning time to the
    native planner's over a set, by the bootstrap over its valid problems: the problems drawn
    again with replacement, each with all its plans by both planners, so that a problem that
    is hard for both weighs on both medians together. It says how far another draw of 50
    problems like these could move the ratio, not how far the machine's load can (the
    planners take turns, problem by problem, to share that). NaN when no problem is valid."""
    tables = _time_tables(native, baseline)
    if tables is None:
        return float("nan"), float("nan")
    a, b = tables
    n = a.shape[0]
    draws = np.random.default_rng(seed).integers(0, n, (resamples, n))
    ratios = np.median(b[draws].reshape(resamples, -1), axis=1) / np.median(
        a[draws].reshape(resamples, -1), axis=1
    )
    tail = 50.0 * (1.0 - level)
    low, high = np.percentile(ratios, [tail, 100.0 - tail])
    return float(low), float(high)


def run_ratios(native: list[ProblemResult], baseline: list[ProblemResult]) -> list[float]:
    """The ratio of the baseline's median planning time to the native planner's in each run
    of ``--runs`` (each problem's r-th plans by both planners; run r plans with seeds of its
    own): what one run of the benchmark, with another seed, could have printed. The pooled
    ratio (over all runs) is steadier; the spread of these says how often a single run falls
    below a target. Empty when no problem is valid."""
    tables = _time_tables(native, baseline)
    if tables is None:
        return []
    a, b = tables
    return [float(np.median(b[:, r]) / np.median(a[:, r])) for r in range(a.shape[1])]


def _time_tables(
    native: list[ProblemResult], baseline: list[ProblemResult]
) -> tuple[np.ndarray, np.ndarray] | None:
    """(problems, runs) planning times of the native planner and of a baseline over the
    set's valid problems, a problem's plans in the order they ran; None if none is valid."""
    problems = sorted({r.problem for r in native if r.valid})
    if not problems:
        return None
    index = {k: i for i, k in enumerate(problems)}
    runs = max(1, len([r for r in native if r.valid]) // len(problems))

    def table(results: list[ProblemResult]) -> np.ndarray:
        out = np.full((len(problems), runs), np.nan)
        seen = np.zeros(len(problems), np.int64)
        for r in results:
            if r.valid and r.problem in index:
                i = index[r.problem]
                out[i, seen[i]] = r.time
                seen[i] += 1
        return out

    return table(native), table(baseline)


def default_mbm_dir() -> Path:
    env = os.environ.get("ROBOCELL_SHARED")
    candidates = [Path(env)] if env else []
    candidates += [Path.cwd().parent / "shared", Path.cwd() / "shared", Path.cwd() / "../shared"]
    for c in candidates:
        if (c / "bench" / "mbm").is_dir():
            return c / "bench" / "mbm"
    raise RobocellError(
        "the MotionBenchMaker problems were not found: pass --mbm PATH (the folder holding "
        "ur5/ and panda/) or set ROBOCELL_SHARED"
    )


def _check_choices(mbm: Path, robots: list[str], sets: list[str]) -> None:
    """A RobocellError naming an unknown robot or set, with the ones ``mbm`` holds (before,
    an unknown set printed a row of zeros, and an unknown robot a missing URDF file)."""
    known_robots = sorted(d.name for d in mbm.iterdir() if (d / "problems").is_dir())
    for robot in robots:
        if robot not in known_robots:
            raise RobocellError(unknown("robot", robot, known_robots))
        folder = mbm / robot / "problems"
        known_sets = sorted(
            d.name.removesuffix(f"_{robot}") for d in folder.iterdir() if d.is_dir()
        )
        for s in sets:
            if s not in known_sets:
                raise RobocellError(unknown(f"problem set of {robot}", s, known_sets))


def load_robot(mbm: Path, robot: str) -> RobotModel:
    d = mbm / robot
    return RobotModel.from_urdf(d / f"{robot}.urdf", d / f"{robot}.srdf", package_dirs=[d])


def set_problems(
    mbm: Path, model: RobotModel, robot: str, set_name: str, limit: int
) -> Iterator[tuple[int, PlanningScene, PlanRequest]]:
    """The first ``limit`` problems of a MotionBenchMaker set, loaded one at a time: (their
    number, the scene, the request)."""
    folder = mbm / robot / "problems" / f"{set_name}_{robot}"
    for scene_path in sorted(folder.glob("scene*.yaml"))[:limit]:
        k = int(scene_path.stem.removeprefix("scene"))
        scene = load_scene(model, scene_path)
        yield k, scene, load_request(model, folder / f"request{k:04d}.yaml", scene)


RUN_SEEDS = 1000  # run r of problem k plans with seed (--seed) + k + RUN_SEEDS · r


def _plan_once(
    scene: PlanningScene,
    robot: str,
    set_name: str,
    k: int,
    req: PlanRequest,
    planner: str,
    valid: bool,
    timeout: float,
    seed: int,
    continuous: bool,
) -> ProblemResult:
    """Problem k planned once by ``planner`` ("" for robocell, else a baseline) with ``seed``,
    timed from the request to the validated path."""
    r = ProblemResult(robot, set_name, k, planner or "robocell", valid, seed)
    if not valid:
        return r
    planner_id, state_check, simplify = BASELINES[planner] if planner else ("", "kernel", False)
    config = PlannerConfig(
        ompl_state_check=state_check, ompl_simplify=simplify, continuous=continuous
    )
    request = MotionPlanRequest(
        req.group,
        JointGoal(req.goal),
        start=req.start,
        planning_time=timeout,
        seed=seed,
        planner_id=planner_id,
        time_parameterize=False,
    )
    planning = Planner(scene, config)
    t0 = time.perf_counter()
    plan = planning.plan(request)
    r.time = time.perf_counter() - t0
    r.solved = plan.success
    r.path_length = plan.path_length if plan.success else float("nan")
    r.reason = plan.reason
    return r


def run_set(
    mbm: Path,
    model: RobotModel,
    robot: str,
    set_name: str,
    planners: list[str],
    limit: int,
    timeout: float,
    seed: int,
    continuous: bool = False,
    runs: int = 1,
) -> dict[str, SetRow]:
    results: dict[str, list[ProblemResult]] = {p: [] for p in planners}
    for k, scene, req in set_problems(mbm, model, robot, set_name, limit):
        group = model.group(req.group)
        checker = scene.checker(group)
        warm_up(checker)  # compiling the search once per process is not planning
        if continuous:
            # the bounds of how far its bodies move: the checker's construction, not planning
            checker.swept(PlannerConfig.continuous_tolerance)
        if any(p and BASELINES[p][1] == "exact" for p in planners):
            # coal's model of the scene and its broad phase, built on the first exact check
            # (12–14 ms for a UR5 scene, 2 ms for a Panda's): the checker's construction,
            # not planning, as the kernel's model is (before session 11 it was timed in
            # the baseline's plans)
            checker.check_exact_one(req.start)
        valid = (
            bool(group.within_limits(req.start))
            and bool(group.within_limits(req.goal))
            and not bool(checker.check(np.array([req.start, req.goal])).any())
        )
        # the first plan in a new scene runs on cold caches (10 % slower, measured): each
        # planner goes first on every other problem, and in every other run
        for run in range(runs):
            order = planners if (k + run) % 2 == 0 else planners[::-1]
            for p in order:
                results[p].append(
                    _plan_once(
                        scene,
                        robot,
                        set_name,
                        k,
                        req,
                        p,
                        valid,
                        timeout,
                        seed + k + RUN_SEEDS * run,
                        continuous,
                    )
                )
    rows = {}
    for p, rs in results.items():
        solved = [r for r in rs if r.solved]
        times = np.array([r.time for r in rs if r.valid]) * 1e3
        rows[p] = SetRow(
            robot,
            set_name,
            p or "robocell",
            len(rs) // runs,
            sum(r.valid for r in rs) // runs,
            len(solved),
            float(np.median(times)) if len(times) else float("nan"),
            float(np.percentile(times, 95)) if len(times) else float("nan"),
            float(np.median([r.path_length for r in solved])) if solved else float("nan"),
            rs,
            runs,
        )
    return rows


def run(
    robots: list[str],
    sets: list[str],
    limit: int = 50,
    timeout: float = 1.0,
    baselines: list[str] | None = None,
    json_path: str | None = None,
    mbm: str | None = None,
    seed: int = 0,
    continuous: bool = False,
    runs: int = 1,
    busy: int = 0,
) -> int:
    base = Path(mbm) if mbm else default_mbm_dir()
    baselines = baselines or []
    for b in baselines:
        if b not in BASELINES:
            raise PlanningError(f"unknown baseline {b!r}; known: {', '.join(BASELINES)}")
    _check_choices(base, robots, sets)
    if limit < 1:
        raise PlanningError(f"--limit must be at least 1 problem per set, got {limit}")
    if not timeout > 0:
        raise PlanningError(f"--timeout must be > 0 s, got {timeout}")
    if runs < 1:
        raise PlanningError(f"--runs must be at least 1 plan per problem, got {runs}")
    if busy < 0:
        raise PlanningError(f"--busy must be 0 or more processes, got {busy}")
    loops = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(busy)]
    try:
        return _run(
            base, robots, sets, limit, timeout, baselines, json_path, seed, continuous, runs, busy
        )
    finally:
        for loop in loops:
            loop.kill()
            loop.wait()


def _run(
    base: Path,
    robots: list[str],
    sets: list[str],
    limit: int,
    timeout: float,
    baselines: list[str],
    json_path: str | None,
    seed: int,
    continuous: bool,
    runs: int,
    busy: int,
) -> int:
    planners = ["", *baselines]
    header = (
        f"{'robot':6} {'set':17} {'planner':11} {'probs':>5} {'valid':>5} {'solved':>6} "
        f"{'median ms':>10} {'p95 ms':>9} {'length':>7}"
    )
    if baselines:
        header += f" {'speed-up':>9} {'95 % interval':>13}"
        if runs > 1:
            header += f" {'each run':>11}"
    print(
        f"planning time budget {timeout} s per problem, first {limit} problems per set"
        + (
            f", {runs} runs per problem (seeds {seed} + problem + {RUN_SEEDS} × run; "
            "solved counts plans)"
            if runs > 1
            else ""
        )
        + (", paths proven free by the continuous check" if continuous else "")
        + (f", {busy} other process(es) keeping a core busy" if busy else "")
    )
    print(header)
    print("-" * len(header))
    all_rows: list[SetRow] = []
    for robot in robots:
        model = load_robot(base, robot)
        for s in sets:
            rows = run_set(base, model, robot, s, planners, limit, timeout, seed, continuous, runs)
            native = rows[""]
            for p in planners:
                row = rows[p]
                line = (
                    f"{robot:6} {s:17} {row.planner:11} {row.problems:5d} {row.valid:5d} "
                    f"{row.solved:6d} {row.median_ms:10.2f} {row.p95_ms:9.2f} "
                    f"{row.median_length:7.2f}"
                )
                if p:
                    row.speedup = row.median_ms / native.median_ms
                    row.speedup_low, row.speedup_high = ratio_interval(native.results, row.results)
                    line += f" {row.speedup:8.1f}x {row.speedup_low:6.1f}–{row.speedup_high:<5.1f}"
                    if runs > 1:
                        row.speedup_runs = run_ratios(native.results, row.results)
                        runs_r = row.speedup_runs or [float("nan")]  # no valid problem
                        each = f"{min(runs_r):.1f}–{max(runs_r):.1f}"
                        line += f" {each:>11}"
                print(line, flush=True)
                all_rows.append(row)
    if json_path:
        Path(json_path).write_text(
            json.dumps([asdict(r) for r in all_rows], indent=1, default=float)
        )
        print(f"wrote {json_path}")
    failed = [
        r
        for row in all_rows
        if row.planner == "robocell"
        for r in row.results
        if r.valid and not r.solved
    ]
    for r in failed:
        print(f"unsolved: {r.robot} {r.set} {r.problem} (seed {r.seed}): {r.reason}")
    return 0
