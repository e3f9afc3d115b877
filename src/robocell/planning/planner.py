"""The planner: validates a request, turns its goal into a set of goal configurations, plans
with RRT-Connect on the batched checker (or an OMPL planner), shortens the path, re-validates
the path that will be executed at fine resolution and times it.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from robocell.errors import PlanningError, choices, number, vector, whole
from robocell.geometry.pose import Pose
from robocell.kinematics.ik import IKResult, NumericIK, NumericIKConfig, solve_ik
from robocell.planning import _kernels as PK
from robocell.planning import ompl_backend
from robocell.planning.request import (
    Goal,
    JointGoal,
    MotionPlan,
    MotionPlanRequest,
    PoseGoal,
    PositionGoal,
)
from robocell.planning.rrt import (
    NOTHING_CHECKED,
    Edges,
    Finish,
    Rng,
    Seeds,
    dedupe,
    rrt_connect,
    rrt_connect_compiled,
    seed_of,
    shortcut,
    shortcut_compiled,
    warm_up,
)
from robocell.robot.model import JointGroup
from robocell.scene.checker import (
    REST_CHUNK,
    THREADS,
    CollisionChecker,
    next_epoch,
    threads_rested,
)
from robocell.scene.planning_scene import PlanningScene
from robocell.scene.swept import SweptResult
from robocell.trajectory.path import BlendedPath
from robocell.trajectory.timing import time_optimal

NATIVE_PLANNERS = ("", "rrtconnect", "robocell")
# states per task of the final check on the kernel's threads: a finer split than the checker's
# (CHUNK, 64) lets the two threads end together on a check of a few hundred states (session 25,
# the same paths checked over and over: Panda table_under_pick 261 µs against 274 with 64,
# 268 with 16; table_pick 164 against 168 and 165)
FINAL_CHUNK = 32
# waypoints a detour tries, at radii from 0.02 to 0.4 rad (_radii)
DETOUR_TRIES = 24
# a joint goal in collision: the free states within its tolerance nearest it that are kept
GOAL_NEAR = 4
CheckOutputs = tuple[NDArray, ...]  # _kernels.validate_path's


@dataclass
class PlannerConfig:
    """Planner settings. Resolutions are the largest joint step [rad or m] between two checked
    states: ``resolution`` while planning, ``validation_resolution`` for the final check of
    the path as it will be executed (rounded corners included). Both checks are discrete, as
    MoveIt's and OMPL's are: between two checked states a thin part can skim an obstacle's
    edge (IRB 120 past a 4 cm wall, 3 goal kinds × 40 seeds, 2000 trajectory samples checked
    exactly: 10 of 120 plans grazed it with a finger or link 3, by 0.01–0.46 mm, session 11;
    in session 10, 8 by 0.02–0.4 mm, and halving ``validation_resolution`` left 5 of them,
    the slivers being narrower than 1 mrad of the path). On the MotionBenchMaker sets (20
    problems each, the executed paths sampled at 1 mrad, session 24): 16 of 280 paths pass
    into an obstacle between two checked states, by 0.08–2.00 mm, mostly with a finger (a
    step of 0.01 rad moves some point of a Panda by 6–16 mm; 17 of 280, up to 1.97 mm, in
    session 22 before ``shortcut_min_gain`` was 0.02) (``benchmarks/bench_final_check.py``).
    ``continuous=True`` proves the executed path free instead (0 of 280 pass into an
    obstacle, session 23)."""

    # 0.07 rather than 0.05: the search and shortcuts check 30 % fewer states, and what
    # that steps over the final check finds and a detour mends (cheap since session 11).
    # Medians over 14 MotionBenchMaker sets (50 problems each, same process): 11–16 %
    # lower; 0.06 gained 9 %, 0.085 and 0.1 13 % (0.1 failed one problem in 1 s)
    resolution: float = 0.07
    validation_resolution: float = 0.01
    step: float = 0.7
    max_deviation: float = 0.05
    shortcut: bool = True
    compiled: bool = True  # the search compiled whole (numba); False: the Python search alone
    compiled_share: float = 0.8  # of the time budget; the Python search gets the rest
    # compiled searches side by side, on seeds of their own (threads): the one that needs
    # the least work wins (rrt.rrt_connect_compiled)
    searches: int = 2
    # the kernel's threads for the searches and the final check: None: unless the process
    # rested since the last plan (they are slow to wake then: see checker.REST_CHUNK) or
    # the host kept them waiting lately (another process on a core: checker.THREADS)
    threads: bool | None = None
    # a share of the search's samples from around the start and goals (rrt_connect_compiled)
    box_share: float = 0.8
    box_margin: float = 2.0
    # the compiled search's first iterations add whole edges only, the later ones as far as
    # free (rrt_connect_compiled); 0: as far as free throughout
    whole_edges_for: int = 40
    # the random shortcuts may check this share of the states the search checked, and at
    # least shortcut_min_states
    shortcut_share: float = 0.5
    shortcut_min_states: int = 100
    # random shortcuts at most (fewer if 12 fail in a row), and the least share of the
    # stretch of path a shortcut replaces that it must save to be checked at all (near a
    # gentle bend every shortcut is free, so checked whole, for almost nothing). Session 22,
    # on the searches' own paths (30–50 problems of each MotionBenchMaker set but the UR5's
    # cage, states the shortcut checked): 40 tries and 2 % checked 3–37 % fewer states than
    # 20 tries and no least gain (the setting of sessions 10–21), and the paths came out as
    # long (mean −1.1 to +0.5 % per set); 20 tries and 2 % checked 10–38 % fewer, paths up to
    # 0.9 % longer; 1 % saved less. The default since session 24: 50 problems per set, both
    # settings alternating in one process, medians with 2 % against none: Panda table_pick
    # 0.63 against 0.79 ms, bookshelves 7–9 % lower, table_under_pick, box and cage within
    # ±3 %; UR5 table_pick 1.36 against 1.65 ms, table_under_pick 2.07 against 2.31, box 1.40
    # against 1.62, cage 13.4 against 13.7; mean path lengths within ±0.5 %. (Session 22 had
    # held it back because the Python search's plan past the IRB 120's 4 cm wall, seed 0,
    # skims the wall by 0.12 mm with it between two states the final check found free: the
    # discrete check's known gap, as often without it, 3 of 31 seeds against 4; the test of
    # that plan turns ``continuous`` on, which closes the gap.)
    shortcut_tries: int = 20
    shortcut_min_gain: float = 0.02
    ik_timeout: float = 0.05
    numeric_goal_solutions: int = 4
    fix_start_radius: float = 0.2
    # how an OMPL planner's state validity callback checks a state: "kernel" (the checker's
    # two-level check) or "exact" (coal alone through a broad phase, as MoveIt's FCL does)
    ompl_state_check: str = "kernel"
    # an OMPL planner's path simplified by OMPL's simplifier (with its state checks), as
    # MoveIt's simplify_solutions does, instead of the native shortcut (it is slower: 20 ms
    # for a Panda, 55–93 ms for a UR5 with exact checks, measured)
    ompl_simplify: bool = False
    # prove every configuration of the path as it will be executed free (robocell.scene.
    # swept), instead of checking it at validation_resolution: where a part of it comes
    # closer to an obstacle than continuous_tolerance [m], it is checked exactly at that
    # spacing, so nothing passes deeper than that. A path it cannot prove goes through the
    # discrete final check and its repairs, then is proven again. Off by default, as MoveIt's
    # checks are discrete: it costs more than the final check (session 23, Panda table sets,
    # in the planner: 0.6–1.6 ms against 0.3–0.4 ms; see the README's figures)
    continuous: bool = False
    continuous_tolerance: float = 1e-4


class Planner:
    """Plans motions for the groups of a scene's robot (MoveIt's planning pipeline).

    The scene is read when :meth:`plan` is called (its objects, attached objects, allowed
    collisions, and the positions of joints outside the planned group)."""

    def __init__(self, scene: PlanningScene, config: PlannerConfig | None = None) -> None:
        self.scene = scene
        self.config = config or PlannerConfig()
        self._position_ik: dict[tuple[str, str], NumericIK] = {}
        self._approximate: dict[tuple[str, str], NumericIK] = {}

    # ------------------------------------------------------------------ public
    def plan(self, request: MotionPlanRequest) -> MotionPlan:
        """Plan ``request``. Malformed requests (unknown group or link, NaN, a goal outside
        the limits or in collision, an unreachable pose, a start in collision without
        ``fix_start``) raise a :class:`PlanningError`; a request that is valid but not solved in
        time returns a :class:`MotionPlan` with ``success=False`` and the reason."""
        t0 = time.perf_counter()
        cfg = self.config
        group = self.scene.robot.group(request.group)
        _check_request(request)
        checker = self.scene.checker(group)
        planner_name = request.planner_id.strip()
        native = is_native(planner_name)
        if cfg.compiled and native:
            warm_up(checker)
        # the kernel's threads, unless they would be slow to wake (a rest) or the host keeps
        # one of them off its core (THREADS): the searches then run in the calling thread
        threads = cfg.threads
        if threads is None:
            threads = not (threads_rested() or THREADS.contended())
        chunk = FINAL_CHUNK if threads else REST_CHUNK
        # the start's and a joint goal's collision checks left to the compiled search's call
        # (check_ends), on its own code: checked here only if it finds one of them not FREE
        defer = cfg.compiled and native and not checker.static_collisions
        start, prefix = self._start(group, request, checker, collisions=not defer)
        goals = self.goal_configurations(group, request.goal, start, checker, collisions=not defer)
        # the search's budget starts once the checker exists and the goals are known: building
        # a scene's sphere model and compiling kernels happen once, not per plan, and IK has
        # its own time budget
        deadline = time.perf_counter() + request.planning_time
        rng = Seeds(request.seed)
        resolution = cfg.resolution
        best: NDArray[np.float64] | None = None
        best_dev = cfg.max_deviation
        stats: dict[str, float] = {"goals": float(len(goals))}
        reason = ""
        found = 0
        tries = 0
        # ``attempts`` plans are made (the shortest is kept); a path that fails validation
        # does not count, and the next try plans at a finer resolution
        while found < request.attempts and time.perf_counter() < deadline:
            tries += 1
            edges = Edges(checker, resolution)
            path, shortened = self._solve(
                planner_name, edges, start, goals, group, rng, deadline, threads=threads,
                check_ends=defer,
            )  # fmt: skip
            if edges.stats.blocked_ends:
                # the start or a goal is not FREE in the kernel: checked exactly, as without
                # deferring (the error names the colliding pair; fix_start nudges the start),
                # then the plan as if they had been checked first
                start, prefix = self._start(group, request, checker)
                goals = self.goal_configurations(group, request.goal, start, checker)
                stats["goals"] = float(len(goals))
                defer = False
                rng = Seeds(request.seed)
                tries -= 1
                continue
            defer = False  # the search's call found them FREE: later tries need not ask again
            stats["checked_states"] = stats.get("checked_states", 0) + edges.stats.states
            if path is None:
                reason = (
                    f"no path found in {request.planning_time:.3f} s "
                    f"({edges.stats.iterations} iterations, {edges.stats.nodes} nodes)"
                )
                continue
            if not shortened:  # else in the search's kernel call
                if cfg.shortcut and (native or not cfg.ompl_simplify):
                    budget = max(
                        cfg.shortcut_min_states, int(cfg.shortcut_share * edges.stats.states)
                    )
                    path = self._shortcut(edges, path, rng, deadline, budget)
                else:
                    path = dedupe(path)  # a tree's connect step can repeat a node
            first = None
            if cfg.continuous:
                # proven free as it will be executed, corners rounded: the discrete final
                # check would add nothing (most paths); else it finds where, for a repair
                first = self._swept(checker, path, cfg.max_deviation, stats)
            judged = edges.stats.final_judged if shortened else PK.JUDGED_NOT
            if (first is not None and first.free) or (shortened and edges.stats.final_free):
                # proven free, or every state the final check classifies first is FREE,
                # found by the searches' threads in their kernel call (_kernels._final_share)
                ok, dev, bad = True, cfg.max_deviation, _NONE
                hits: dict[int, Hit] = {}
            elif judged in (PK.JUDGED, PK.JUDGED_MENDED):
                # not every state FREE, none UNSURE: judged in the same call, the colliding
                # segments mended by detours (_kernels._judged)
                ok, dev, bad, hits = True, edges.stats.final_deviation, _NONE, {}
            elif judged == PK.MENDED_CORNERS_OPEN:
                # mended there, a state of the corners' arcs unsure: coal settles them
                ok, dev, bad, hits = self._validate(checker, path, True, chunk)
            else:
                # the states the searches' threads checked are not checked again (None when
                # they did not check this path: then it was not shortened in their call)
                known = edges.stats.final_not_free
                ok, dev, bad, hits = self._validate(checker, path, chunk=chunk, known=known)
            if judged in (PK.JUDGED_MENDED, PK.MENDED_CORNERS_OPEN):
                stats["repairs"] = stats.get("repairs", 0) + 1
            if not ok and native:
                # repair the segments that collide between checked states, each by a detour
                # or a search between its ends at the validation resolution, before
                # replanning it all
                # the detours' seed the searches' call drew for them (a plan after a rest
                # mends here what a busy one mends in that call: the same path)
                mended = self._mend(
                    checker, path, group, rng, deadline, hits, chunk, edges.stats.detour_seed
                )
                if mended is not None:
                    path, (ok, dev, bad, _) = mended
                    stats["repairs"] = stats.get("repairs", 0) + 1
            if ok and cfg.continuous and not (first is not None and first.free):
                ok, path, dev, bad = self._prove_free(
                    checker, path, dev, group, rng, deadline, chunk, native, stats
                )
            if not ok:
                reason = (
                    f"the path found at resolution {edges.resolution} rad collides between "
                    f"checked states ({_pairs(checker, bad)}); replanning finer"
                )
                resolution = max(resolution / 2, cfg.validation_resolution)
                continue
            found += 1
            if best is None or _length(path) < _length(best):
                best, best_dev = path, dev
        stats["tries"] = tries
        if best is None and defer:
            # the start and the goals, if no search ran to check them (no time left for one)
            self._start(group, request, checker)
            self.goal_configurations(group, request.goal, start, checker)
        if best is None:
            return MotionPlan(
                False,
                group.name,
                np.empty((0, group.dof)),
                None,
                time.perf_counter() - t0,
                reason or "no path found",
                planner_name or "rrtconnect",
                stats,
            )
        stats["corner_deviation"] = best_dev  # the rounding the path was checked with
        if prefix is not None:
            best = np.vstack([prefix, best])
        plan_time = time.perf_counter() - t0
        traj = None
        if request.time_parameterize:
            traj = time_optimal(
                group,
                BlendedPath(best, best_dev),
                request.velocity_scaling,
                request.acceleration_scaling,
            )
        stats["timing_time"] = time.perf_counter() - t0 - plan_time
        return MotionPlan(
            True, group.name, best, traj, plan_time, "", planner_name or "rrtconnect", stats
        )

    def goal_configurations(
        self,
        group: JointGroup,
        goal: Goal,
        seed: NDArray[np.float64],
        checker: CollisionChecker,
        collisions: bool = True,
    ) -> NDArray[np.float64]:
        """(G, dof) collision-free configurations that satisfy ``goal``, nearest ``seed`` first.
        Raises :class:`PlanningError` when there are none, saying why. ``collisions=False``:
        a joint goal is not checked for collisions (the caller does it)."""
        if isinstance(goal, JointGoal):
            tolerance = _tolerance(goal.tolerance, "joint goal tolerance [rad]")
            q = group.as_joint_vector(goal.positions, "joint goal")
            bad = group.limit_violations(q)
            if bad:
                raise PlanningError(f"joint goal outside the limits: {'; '.join(bad)}")
            if collisions and checker.collides(q):
                # MoveIt's joint constraints: any state within the tolerance meets the goal
                rng = np.random.default_rng(0)
                near = _free_around(group, q, checker, rng, tolerance, GOAL_NEAR)
                if len(near):
                    return near
                raise PlanningError(
                    f"joint goal is in collision: {_pairs(checker, q)}; no state within its "
                    f"tolerance (±{tolerance:g} rad) is free"
                )
            return q[None, :]
        robot = self.scene.robot
        if isinstance(goal, PoseGoal | PositionGoal):
            robot.link_index(goal.link, "goal link")
        T_world_base = self.scene.link_pose(group.base_link).matrix()
        T_base_world = np.linalg.inv(T_world_base)
        if isinstance(goal, PoseGoal):
            if not isinstance(goal.pose, Pose):
                raise PlanningError(f"a pose goal needs a Pose, got {type(goal.pose).__name__}")
            position_tolerance = _tolerance(goal.position_tolerance, "position tolerance [m]")
            orientation_tolerance = _tolerance(
                goal.orientation_tolerance, "orientation tolerance [rad]"
            )
            T = T_base_world @ goal.pose.matrix()
            res = solve_ik(
                group,
                T,
                seed=seed,
                checker=checker,
                tip_link=goal.link,
                timeout=self.config.ik_timeout,
                max_solutions=0,
                rng=np.random.default_rng(0),
            )
            if res.solver == "numeric" and res.success:
                more = solve_ik(
                    group,
                    T,
                    seed=seed,
                    checker=checker,
                    tip_link=goal.link,
                    timeout=self.config.ik_timeout,
                    max_solutions=self.config.numeric_goal_solutions,
                    rng=np.random.default_rng(1),
                )
                sols = np.vstack([res.solutions, more.solutions])
                return _unique(sols)
            if not res.success:
                near = self._approximate_ik(
                    group, goal.link, T, seed, checker, position_tolerance, orientation_tolerance
                )
                if len(near):
                    return near
                raise PlanningError(
                    f"pose goal for {goal.link!r} has no solution: {res.reason}; none within "
                    f"its tolerance (±{position_tolerance:g} m, ±{orientation_tolerance:g} rad) "
                    "either"
                )
            return res.solutions
        if isinstance(goal, PositionGoal):
            p = vector(goal.position, 3, "a position goal", PlanningError)
            tolerance = _tolerance(goal.tolerance, "position tolerance [m]")
            T = np.eye(4)
            T[:3, 3] = (T_base_world @ np.append(p, 1.0))[:3]
            key = (group.name, goal.link)
            if key not in self._position_ik:
                self._position_ik[key] = NumericIK(
                    group, goal.link, NumericIKConfig(position_only=True)
                )
            ik = self._position_ik[key]
            # each goal's own tolerance (the solver is kept per link)
            ik.config = replace(ik.config, tol_pos=max(min(tolerance, 1e-4), 1e-9))
            ik.set_base_positions(self.scene.state.positions)
            gen = np.random.default_rng(0)
            res = ik.solve(T, seed, gen, self.config.ik_timeout, self.config.numeric_goal_solutions)
            if not res.success and tolerance > ik.config.tol_pos:
                near = self._approximate_ik(group, goal.link, T, seed, None, tolerance, None)
                res = IKResult(near, res.solver, res.reason) if len(near) else res
            if not res.success:
                raise PlanningError(
                    f"position goal for {goal.link!r} at {p.round(4).tolist()} is out of reach: "
                    f"{res.reason}"
                )
            free = res.solutions[~checker.check(res.solutions)]
            if len(free) == 0:
                raise PlanningError(
                    f"position goal for {goal.link!r} at {p.round(4).tolist()} is reachable but "
                    f"every solution found is in collision"
                )
            return free
        raise PlanningError(
            f"unknown goal type {type(goal).__name__}; use JointGoal, PoseGoal or PositionGoal"
        )

    def _approximate_ik(
        self,
        group: JointGroup,
        link: str,
        T: NDArray[np.float64],
        seed: NDArray[np.float64],
        checker: CollisionChecker | None,
        position_tolerance: float,
        orientation_tolerance: float | None,
    ) -> NDArray[np.float64]:
        """Configurations that bring ``link`` within the goal's tolerances of ``T`` (the
        group's base frame; ``orientation_tolerance`` None: the position only), free of
        collision (with a ``checker``), nearest ``seed`` first: where no configuration reaches
        the goal exactly, MoveIt's goal constraints still take one within their tolerances.
        One batch of the numeric solver's restarts (1–2 ms), as this runs only when the
        exact goal failed."""
        key = (group.name, link)
        ik = self._approximate.get(key)
        if ik is None:
            ik = self._approximate[key] = NumericIK(group, link)
        ik.config = NumericIKConfig(
            tol_pos=position_tolerance,
            tol_rot=math.inf if orientation_tolerance is None else orientation_tolerance,
            position_only=orientation_tolerance is None,
        )
        ik.set_base_positions(self.scene.state.positions)
        res = ik.solve(T, seed, np.random.default_rng(2), 0.0, self.config.numeric_goal_solutions)
        sols = res.solutions
        if checker is not None and len(sols):
            sols = sols[~checker.check(sols)]
        return sols

    # ------------------------------------------------------------------ steps
    def _start(
        self,
        group: JointGroup,
        request: MotionPlanRequest,
        checker: CollisionChecker,
        collisions: bool = True,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """The start configuration, and the original start when it had to be nudged;
        ``collisions=False``: not checked for collisions (the caller does it)."""
        if request.start is None:
            q = self.scene.state.group_positions(group)
        else:
            q = group.as_joint_vector(request.start, "start state")
        original = q
        bad = group.limit_violations(q)
        if bad:
            if not request.fix_start:
                raise PlanningError(
                    f"start state outside the joint limits: {'; '.join(bad)} "
                    "(fix_start=True moves it inside)"
                )
            q = np.clip(q, group.lower, group.upper)
        if collisions and checker.collides(q):
            if not request.fix_start:
                raise PlanningError(
                    f"start state in collision: {_pairs(checker, q)} "
                    "(fix_start=True nudges it to the nearest valid state)"
                )
            q = self._nudge(group, q, checker, np.random.default_rng(request.seed))
        return q, (original[None, :] if q is not original else None)

    def _nudge(
        self,
        group: JointGroup,
        q: NDArray[np.float64],
        checker: CollisionChecker,
        rng: np.random.Generator,
    ) -> NDArray[np.float64]:
        """The nearest collision-free state found around q (radii growing to
        ``fix_start_radius``), as MoveIt's FixStartStateCollision adapter does."""
        free = _free_around(group, q, checker, rng, self.config.fix_start_radius, 1)
        if len(free):
            return free[0]
        raise PlanningError(
            f"start state in collision ({_pairs(checker, q)}) and no valid state within "
            f"{self.config.fix_start_radius} rad"
        )

    def _solve(
        self,
        planner_name: str,
        edges: Edges,
        start: NDArray[np.float64],
        goals: NDArray[np.float64],
        group: JointGroup,
        rng: Rng,
        deadline: float,
        shorten: bool = True,
        threads: bool = True,
        check_ends: bool = False,
    ) -> tuple[NDArray[np.float64] | None, bool]:
        """A path from ``start`` to one of ``goals`` (None if none was found in time), and
        whether it is shortcut already: by the compiled search, in the same kernel call, if
        ``shorten`` and the config's ``shortcut`` (else the caller shortcuts it). ``threads``:
        the compiled searches may run side by side (else one after the other: the same
        path). ``check_ends``: the compiled search checks the start and the goals first
        (:func:`rrt_connect_compiled`); if one is not FREE, nothing is searched (None)."""
        cfg = self.config
        if is_native(planner_name):
            lo, hi, step = group.lower, group.upper, cfg.step
            if cfg.compiled:
                # most of the budget to the compiled search; what is left to the Python one,
                # which settles the states the kernel leaves unsure (near contact)
                now = time.perf_counter()
                soon = now + cfg.compiled_share * (deadline - now)
                todo = None
                if shorten and cfg.shortcut:
                    todo = Finish(
                        deadline, cfg.shortcut_tries, cfg.shortcut_share, cfg.shortcut_min_states,
                        cfg.shortcut_min_gain,
                        0.0 if cfg.continuous else cfg.validation_resolution,
                        cfg.max_deviation, FINAL_CHUNK, _radii(DETOUR_TRIES),
                    )  # fmt: skip
                path = rrt_connect_compiled(
                    edges, start, goals, lo, hi, rng, soon, step, searches=cfg.searches,
                    box_margin=cfg.box_margin, box_share=cfg.box_share,
                    whole_for=cfg.whole_edges_for, finish=todo,
                    side_by_side=None if threads else False, check_ends=check_ends,
                )  # fmt: skip
                if path is not None or edges.stats.blocked_ends or time.perf_counter() >= deadline:
                    return path, path is not None and todo is not None
            return rrt_connect(edges, start, goals, lo, hi, rng, deadline, step), False
        if not ompl_backend.is_ompl_name(planner_name):
            raise PlanningError(
                f"unknown planner {planner_name!r}; known: rrtconnect (native, default) or an "
                f"OMPL planner: {choices(ompl_backend.PLANNERS)}"
            )
        path = ompl_backend.plan(
            planner_name,
            edges,
            start,
            goals,
            group.lower,
            group.upper,
            deadline,
            seed_of(rng),
            cfg.ompl_state_check,
            cfg.ompl_simplify,
        )
        return path, False

    def _shortcut(
        self,
        edges: Edges,
        path: NDArray[np.float64],
        rng: Rng,
        deadline: float,
        budget: int,
    ) -> NDArray[np.float64]:
        tries, gain = self.config.shortcut_tries, self.config.shortcut_min_gain
        if self.config.compiled:
            return shortcut_compiled(edges, path, rng, deadline, tries, budget, gain)
        return shortcut(edges, path, rng, deadline, tries, budget, gain)

    def _mend(
        self,
        checker: CollisionChecker,
        path: NDArray[np.float64],
        group: JointGroup,
        rng: Rng,
        deadline: float,
        hits: dict[int, Hit],
        chunk: int,
        seed: int | None = None,
    ) -> tuple[NDArray[np.float64], tuple[bool, float, NDArray[np.float64], dict[int, Hit]]] | None:
        """:meth:`_repair` of the segments ``hits`` names, and :meth:`_validate`'s answer for
        the mended path (its segments checked by the repair: the corners decide): (path,
        answer), or None if a segment could not be mended. Detours first, in one compiled
        call with the corners' check (``_kernels.repair_in``); where one fails, the repair
        in Python, which searches. Against the detours, the corners' check and the steps
        between them called one by one from Python (session 26, each plan after an ``ompl``
        plan, 3 × 50 problems, both alternating): repaired plans' median 1.80 against 1.90
        ms on the Panda's table_under_pick (39 of 150 plans repaired), 1.52 against 1.62 ms
        on table_pick (22 of 150). ``seed``: the detours' (else drawn from ``rng``)."""
        ks = np.array(sorted(hits), np.int64)
        near = np.array([hits[k] for k in ks.tolist()])
        ok, mended, _, _, checked = PK.repair_in(
            np.ascontiguousarray(path, dtype=float), ks, near,
            np.ascontiguousarray(group.lower, dtype=float),
            np.ascontiguousarray(group.upper, dtype=float),
            _radii(DETOUR_TRIES), seed_of(rng) if seed is None else seed,
            self.config.validation_resolution,
            self.config.max_deviation, checker.compiled_inputs, next_epoch(1 << 40), chunk,
        )  # fmt: skip
        if ok:
            return mended, self._judge(checker, checked, True)
        repaired = self._repair(checker, path, group, rng, deadline, hits)
        if repaired is None:
            return None
        return repaired, self._validate(checker, repaired, True, chunk)

    def _repair(
        self,
        checker: CollisionChecker,
        path: NDArray[np.float64],
        group: JointGroup,
        rng: Rng,
        deadline: float,
        hits: dict[int, Hit] | None = None,
    ) -> NDArray[np.float64] | None:
        """``path`` with each segment that collides at the validation resolution mended at
        that resolution: the stretch between the free states either side of where it
        collides replaced by a detour through one waypoint, else the whole segment by such a
        detour, else by a search between its ends; None if none succeeds. ``hits``: where
        each segment that collides does, as :meth:`_validate` found them (checked here if not
        given). Over 40 UR5 bookshelf_thin plans, 18 needed a repair: detours around the
        stretch alone took them from 60 to 17 ms in all (the ends of the stretch lie close
        together, so a detour's checks are few)."""
        res = self.config.validation_resolution
        if hits is None:
            hits = _first_hits(checker, path, res)
        fine = Edges(checker, res)
        out = [path[0]]
        for k, (a, b) in enumerate(zip(path[:-1], path[1:], strict=True)):
            if k not in hits:
                out.append(b)
                continue
            hit = hits[k]
            # around the stretch that collides (a → before and after → b are pieces of the
            # segment, free already), else from end to end, else a search
            for p0, p1 in ((hit.before, hit.after), (a, b)):
                via = self._detour(checker, p0, p1, group, rng, hit.first)
                if via is not None:
                    for p in (p0, via, p1, b):
                        if np.any(p != out[-1]):  # an end of the stretch may be a or b
                            out.append(p)
                    break
            else:
                sub, _ = self._solve("", fine, a, b[None, :], group, rng, deadline, False)
                if sub is None:
                    return None
                out.extend(self._shortcut(fine, sub, rng, deadline, fine.stats.states)[1:])
        return np.array(out)

    def _detour(
        self,
        checker: CollisionChecker,
        a: NDArray[np.float64],
        b: NDArray[np.float64],
        group: JointGroup,
        rng: Rng,
        near: NDArray[np.float64],
        tries: int = DETOUR_TRIES,
    ) -> NDArray[np.float64] | None:
        """A waypoint near ``near`` through which a → waypoint → b is free at the validation
        resolution, or None. A segment the search found free at its coarser resolution
        usually clips an obstacle between two checked states only: a small step aside there
        clears it, for a few checks instead of a search (radii from 0.02 to 0.4 rad; compiled,
        as a state the kernel leaves unsure blocks a try)."""

        found, via, _ = PK.detour_in(
            np.ascontiguousarray(a, dtype=float),
            np.ascontiguousarray(b, dtype=float),
            np.ascontiguousarray(near, dtype=float),
            np.ascontiguousarray(group.lower, dtype=float),
            np.ascontiguousarray(group.upper, dtype=float),
            _radii(tries),
            seed_of(rng),
            self.config.validation_resolution,
            checker.compiled_inputs,
            next_epoch(1 << 40),
        )
        return via if found else None

    def _swept(
        self,
        checker: CollisionChecker,
        path: NDArray[np.float64],
        dev: float,
        stats: dict[str, float],
    ) -> SweptResult:
        """The continuous check of ``path`` with its corners rounded within ``dev``."""
        swept = checker.swept(self.config.continuous_tolerance)
        result = swept.check_path(BlendedPath(path, dev))
        stats["swept_tests"] = stats.get("swept_tests", 0) + result.tests
        return result

    def _prove_free(
        self,
        checker: CollisionChecker,
        path: NDArray[np.float64],
        dev: float,
        group: JointGroup,
        rng: Rng,
        deadline: float,
        chunk: int,
        native: bool,
        stats: dict[str, float],
    ) -> tuple[bool, NDArray[np.float64], float, NDArray[np.float64]]:
        """The continuous check of a path the final check found free (``continuous``): (free,
        the path, its corner deviation, a colliding configuration or an empty array). Where a
        configuration between two checked states collides, the corners are first left sharp
        (if that is where), else its segment is repaired as the final check's are, and the
        new path checked again, a few times at most."""
        bad = _NONE
        for _ in range(3):
            result = self._swept(checker, path, dev, stats)
            if result.free:
                return True, path, dev, _NONE
            if dev > 0:
                sharp = self._swept(checker, path, 0.0, stats)
                if sharp.free:
                    return True, path, 0.0, _NONE
                result, dev = sharp, 0.0
            bad = BlendedPath(path, 0.0)(result.at)
            if not native:
                break
            hit = _hit_near(path, bad, 5 * self.config.validation_resolution)
            mended = self._mend(checker, path, group, rng, deadline, hit, chunk)
            if mended is None:
                break
            stats["repairs"] = stats.get("repairs", 0) + 1
            # the repair checked its new segments: the arcs decide the corners' rounding
            path, (_, dev, _, _) = mended
        return False, path, dev, bad

    def _validate(
        self,
        checker: CollisionChecker,
        path: NDArray[np.float64],
        segments_checked: bool = False,
        chunk: int = FINAL_CHUNK,
        known: NDArray[np.int8] | None = None,
    ) -> tuple[bool, float, NDArray[np.float64], dict[int, Hit]]:
        """Check the path as it will be executed at the validation resolution: (valid, corner
        deviation to execute it with, the first colliding state or an empty array, where each
        straight segment that collides does (:class:`Hit`)).

        A path is valid when it is free as it will be executed: with its corners rounded if
        their arcs and the rest of the segments are free (the stretches of the segments the
        arcs replace are then not checked: the motion does not pass there), else with sharp
        corners (the motion stops at each) if the whole segments are free.
        ``segments_checked``: the segments already were, at this resolution, as a repair
        does; only the arcs are checked. Where a segment collides is known whole, for a
        repair (``_kernels._final_check``). ``chunk``: states per task on the kernel's
        threads (at most one chunk of states is checked in the calling thread). ``known``:
        which of the states it classifies first the searches' threads found not FREE, for
        this path (``EdgeStats.final_not_free``): only those are classified again."""

        checked = PK.validate_path(
            np.ascontiguousarray(path, dtype=float),
            self.config.validation_resolution,
            self.config.max_deviation,
            not segments_checked,
            checker.compiled_inputs,
            next_epoch(1 << 40),
            chunk,
            NOTHING_CHECKED if known is None else known,
        )
        return self._judge(checker, checked, segments_checked)

    def _judge(
        self, checker: CollisionChecker, checked: CheckOutputs, segments_checked: bool = False
    ) -> tuple[bool, float, NDArray[np.float64], dict[int, Hit]]:
        """:meth:`_validate`'s answer from the final check's outputs (``validate_path``'s):
        its unsure states settled by coal."""
        states, segment, cls, flags, arcs, arc_cls, arc_flags, summary = checked
        dev = self.config.max_deviation
        if summary == 0:
            # every state classified is FREE, as in most final checks (looking at the classes
            # in numpy cost 20–35 µs of a 1 ms plan on a plan's cold caches, measured)
            return True, dev, _NONE, {}
        # a segment state HIT or UNSURE (UNCHECKED: a corner's stretch of a segment, which
        # the motion does not pass: see validate_path)
        if not segments_checked and summary & 1:
            hits = _hits(states, segment, checker.settle(states, cls, flags))
            if hits:
                # naming the colliding pair costs as much as the check: the caller does it
                return False, 0.0, hits[min(hits)].first, hits
        if summary & 2 and checker.settle(arcs, arc_cls, arc_flags).any():
            dev = 0.0
        return True, dev, _NONE, {}


_NONE = np.empty((0,))  # no colliding state
_NONE.flags.writeable = False


class Hit(NamedTuple):
    """Where a straight segment of a path collides at some resolution: its first colliding
    state, and the free states just before the first and just after the last colliding one
    (the segment's ends at most)."""

    first: NDArray[np.float64]
    before: NDArray[np.float64]
    after: NDArray[np.float64]


def _hit_near(path: NDArray[np.float64], q: NDArray[np.float64], margin: float) -> dict[int, Hit]:
    """The :class:`Hit` of configuration q on the path's segment nearest to it: the stretch
    from ``margin`` [rad] before it to ``margin`` after it, within the segment."""
    a, d = path[:-1], np.diff(path, axis=0)
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", q - a, d) / dd, 0.0, 1.0)
    k = int(np.argmin(np.linalg.norm(a + t[:, None] * d - q, axis=1)))
    w = margin / math.sqrt(dd[k])
    return {k: Hit(q, a[k] + max(0.0, t[k] - w) * d[k], a[k] + min(1.0, t[k] + w) * d[k])}


def _first_hits(
    checker: CollisionChecker, path: NDArray[np.float64], resolution: float
) -> dict[int, Hit]:
    """Where each of the path's straight segments that collides at ``resolution`` does, by
    segment index (all states checked in one batch)."""

    states, segment = PK.segment_states(np.ascontiguousarray(path, dtype=float), resolution)
    return _hits(states, segment, checker.check(states))


def _hits(
    states: NDArray[np.float64], segment: NDArray[np.int64], hit: NDArray[np.bool_]
) -> dict[int, Hit]:
    """:func:`_first_hits` from a path's segment states, the segment of each, and whether
    each collides (``_kernels.segment_hits``: numpy's unique and searches took 75 µs of a
    repaired plan, on cold caches)."""
    return {
        int(k): Hit(states[first], states[before], states[after])
        for k, first, before, after in PK.segment_hits(segment, hit)
    }


@functools.lru_cache(maxsize=8)
def _radii(tries: int) -> NDArray[np.float64]:
    """The detour's radii [rad], from 0.02 to 0.4 (np.geomspace took 20 µs per detour)."""
    return np.geomspace(0.02, 0.4, tries)


def _check_request(request: MotionPlanRequest) -> None:
    t, a, seed = request.planning_time, request.attempts, request.seed
    v, w = request.velocity_scaling, request.acceleration_scaling
    if (
        type(t) is float and 0 < t < math.inf and type(a) is int and a >= 1
        and type(v) is float and 0 < v <= 1 and type(w) is float and 0 < w <= 1
        and (seed is None or type(seed) is int) and type(request.planner_id) is str
    ):  # fmt: skip
        # plain values, all valid (the checks below took 15 µs of a plan on the caches an
        # ``ompl`` plan leaves, measured: six calls)
        return
    if not number(request.planning_time, "planning time [s]", PlanningError) > 0:
        raise PlanningError(f"planning time must be > 0 s, got {request.planning_time!r}")
    planning_attempts(request.attempts)
    for name in ("velocity_scaling", "acceleration_scaling"):
        v = getattr(request, name)
        what = f"{name.replace('_', ' ')} factor"
        if not 0 < number(v, what, PlanningError) <= 1:
            raise PlanningError(f"{what} must be in (0, 1], got {v!r}")
    if request.seed is not None:
        whole(request.seed, "seed (or None)", PlanningError)
    planner_name(request.planner_id)


def planning_attempts(n: object) -> int:
    """A number of planning attempts, or the PlanningError naming it."""
    attempts = whole(n, "number of planning attempts", PlanningError)
    if attempts < 1:
        raise PlanningError(f"number of planning attempts must be >= 1, got {n!r}")
    return attempts


def _tolerance(value: object, what: str) -> float:
    """A goal's tolerance: a number ≥ 0, or the PlanningError naming it."""
    x = number(value, what, PlanningError)
    if x < 0:
        raise PlanningError(f"{what} must be >= 0, got {value!r}")
    return x


def is_native(planner_id: str) -> bool:
    """Whether ``planner_id`` names the native planner: "", "rrtconnect" or "robocell" in
    any case, but not an OMPL planner's own name ("RRTConnect" is OMPL's class, as in the
    list of OMPL planners the errors give)."""
    return planner_id.lower() in NATIVE_PLANNERS and not ompl_backend.is_ompl_name(planner_id)


def planner_name(planner_id: object) -> str:
    """A planner id as a request takes it (checked against the planners when planning), or
    the PlanningError naming it."""
    if not isinstance(planner_id, str):
        raise PlanningError(
            f'planner id must be a name (a string, "" for the native planner), got {planner_id!r}'
        )
    return planner_id


def _free_around(
    group: JointGroup,
    q: NDArray[np.float64],
    checker: CollisionChecker,
    rng: np.random.Generator,
    radius: float,
    keep: int,
) -> NDArray[np.float64]:
    """Up to ``keep`` collision-free states around ``q``, nearest first: 128 drawn within the
    limits in each of 8 boxes whose half-width grows to ``radius`` [rad or m] on every joint,
    from the first box that has one; (0, dof) when none has (or ``radius`` is 0)."""
    if radius <= 0.0:
        return np.empty((0, group.dof))
    for r in np.geomspace(min(0.005, radius), radius, 8):
        cand = np.clip(q + rng.uniform(-r, r, (128, group.dof)), group.lower, group.upper)
        free = cand[~checker.check(cand)]
        if len(free):
            order = np.argsort(np.linalg.norm(free - q, axis=1), kind="stable")
            return free[order[:keep]]
    return np.empty((0, group.dof))


def _pairs(checker: CollisionChecker, q: NDArray[np.float64]) -> str:
    pairs = checker.colliding_pairs(q)
    return ", ".join(f"{a} – {b}" for a, b in pairs) if pairs else "(unknown pair)"


def _length(path: NDArray[np.float64]) -> float:
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())


def _unique(sols: NDArray[np.float64], tol: float = 1e-4) -> NDArray[np.float64]:
    out: list[NDArray[np.float64]] = []
    for s in sols:
        if not any(np.max(np.abs(s - o)) < tol for o in out):
            out.append(s)
    return np.array(out)
