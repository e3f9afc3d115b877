"""OMPL's planners behind the planner interface (optional: ``pip install ompl``).

Planners are chosen by the names MoveIt's ompl_planning.yaml uses (``RRTConnectkConfigDefault``,
``RRTstarkConfigDefault``, …) or by their OMPL class name. States are checked one at a time
through the same :class:`~robocell.scene.CollisionChecker`: by default with its fast two-level
check, or (``state_check="exact"``) by coal alone through a broad phase, as MoveIt's FCL
environment checks them. RRTConnect's edges are checked at the native planner's per-joint
resolution; other planners use OMPL's own motion validator at a resolution at least as fine.
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np
from numpy.typing import NDArray

from robocell.errors import PlanningError
from robocell.planning.rrt import Edges

# MoveIt's names (without "kConfigDefault") → OMPL geometric planner classes
PLANNERS = {
    "RRTConnect": "RRTConnect",
    "RRT": "RRT",
    "RRTstar": "RRTstar",
    "InformedRRTstar": "InformedRRTstar",
    "SORRTstar": "SORRTstar",
    "AORRTC": "AORRTC",
    "PRM": "PRM",
    "PRMstar": "PRMstar",
    "KPIECE": "KPIECE1",
    "BKPIECE": "BKPIECE1",
    "LBKPIECE": "LBKPIECE1",
    "BITstar": "BITstar",
    "FMT": "FMT",
    "BFMT": "BFMT",
}


STATE_CHECKS = ("kernel", "exact")


def _class_name(name: str) -> str | None:
    base = name.removesuffix("kConfigDefault")
    if base in PLANNERS:
        return PLANNERS[base]
    if base in PLANNERS.values():
        return base
    return None


def is_ompl_name(name: str) -> bool:
    return _class_name(name) is not None


def plan(
    name: str,
    edges: Edges,
    start: NDArray[np.float64],
    goals: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    deadline: float,
    seed: int,
    state_check: str = "kernel",
    simplify: bool = False,
) -> NDArray[np.float64] | None:
    """A path (K, dof) from ``start`` to one of ``goals`` found by OMPL planner ``name``, or None
    when none is found before ``deadline``. ``state_check``: how OMPL's callback checks a
    state, ``"kernel"`` (the checker's two-level check: spheres, then coal where they are
    unsure) or ``"exact"`` (coal alone, :meth:`CollisionChecker.check_exact_one`).
    ``simplify``: the solution simplified by OMPL's own simplifier in the time left (vertex
    reduction, shortcuts, B-spline smoothing, with the same state and edge checks), as
    MoveIt's OMPL pipeline does with ``simplify_solutions: true``."""
    if state_check not in STATE_CHECKS:
        raise PlanningError(
            f"unknown OMPL state check {state_check!r}; known: {', '.join(STATE_CHECKS)}"
        )
    try:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise PlanningError(f"planner {name!r} needs OMPL: pip install ompl ({exc})") from exc
    cls_name = _class_name(name)
    if cls_name is None or not hasattr(og, cls_name):
        raise PlanningError(f"unknown OMPL planner {name!r}; known: {', '.join(PLANNERS)}")
    # OMPL seeds each generator it makes (the planner's, the samplers') from one sequence per
    # process. Restarting that sequence before each plan makes the plan depend on its own seed
    # alone, as a native plan does, and not on the plans made before it in the process (seeded
    # once per process, the benchmark's baseline median of the Panda's table_pick moved
    # between 7.4 and 11.5 ms with the sets run before it: sessions 23–24). OMPL logs an error
    # on a restart, for the generators made before it: each plan makes its own, so none of
    # those is used again.
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(seed % (2**31 - 1) + 1)  # OMPL ignores a seed of 0
    ou.setLogLevel(ou.LogLevel.LOG_WARN)
    dof = start.shape[0]
    space = ob.RealVectorStateSpace(dof)
    bounds = ob.RealVectorBounds(dof)
    for i in range(dof):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    checker = edges.checker
    buf = np.empty((1, dof))

    collides = (
        (lambda q: bool(checker.check(q[None])[0]))
        if state_check == "kernel"
        else checker.check_exact_one  # type: ignore[attr-defined]
    )

    def free(q: NDArray[np.float64]) -> bool:
        edges.stats.states += 1
        return not collides(q)

    def valid(state: object) -> bool:
        for i in range(dof):
            buf[0, i] = state[i]  # type: ignore[index]
        return free(buf[0])

    ss.setStateValidityChecker(valid)
    si = ss.getSpaceInformation()
    if cls_name == "RRTConnect":
        # its edges checked at the native planner's resolution, per joint (L∞), in OMPL's
        # order (the end, then midpoints): the same states per edge as the native search
        si.setMotionValidator(_motion_validator(si, free, dof, edges.resolution))
    else:
        # other planners also ask OMPL's validator for the last valid state of an edge,
        # which a validator written in Python cannot give; OMPL's resolution is a fraction
        # of the space's extent in its (L2) distance, at least as fine per joint
        si.setStateValidityCheckingResolution(edges.resolution / space.getMaximumExtent())
    st = space.allocState()
    for i in range(dof):
        st[i] = float(start[i])
    goal_states = ob.GoalStates(si)
    for g in goals:
        s = space.allocState()
        for i in range(dof):
            s[i] = float(g[i])
        goal_states.addState(s)
    ss.setStartState(st)
    ss.setGoal(goal_states)
    ss.setPlanner(getattr(og, cls_name)(si))
    remaining = deadline - time.perf_counter()
    if remaining <= 0:
        return None
    solved = ss.solve(remaining)
    if not solved or not ss.haveExactSolutionPath():
        return None
    if simplify:
        ss.simplifySolution(max(0.0, deadline - time.perf_counter()))
    path = ss.getSolutionPath()
    out = np.array([[path.getState(k)[i] for i in range(dof)] for k in range(path.getStateCount())])
    return out


@functools.lru_cache(maxsize=256)
def _bisection_order(n: int) -> tuple[int, ...]:
    """1 … n in the order OMPL's discrete motion validator checks an edge's states: the end
    (n) first, then the midpoints of ever smaller intervals."""
    order = [n]
    queue = [(1, n - 1)]
    while queue:
        lo, hi = queue.pop(0)
        if lo > hi:
            continue
        mid = (lo + hi) // 2
        order.append(mid)
        queue += [(lo, mid - 1), (mid + 1, hi)]
    return tuple(order)


def _motion_validator(si: object, free: object, dof: int, resolution: float) -> object:
    """An OMPL motion validator checking an edge's states at most ``resolution`` apart per
    joint (L∞, as the native planner does) with ``free(q)``, in :func:`_bisection_order`."""
    from ompl import base as ob

    class MotionValidator(ob.MotionValidator):  # type: ignore[misc]
        def checkMotion(self, s1: object, s2: object) -> bool:  # noqa: N802 (OMPL's name)
            a = np.array([s1[i] for i in range(dof)])  # type: ignore[index]
            b = np.array([s2[i] for i in range(dof)])  # type: ignore[index]
            n = max(1, math.ceil(float(np.abs(b - a).max()) / resolution))
            for k in _bisection_order(n):
                if not free(a + (k / n) * (b - a)):  # type: ignore[operator]
                    return False
            return True

    return MotionValidator(si)
