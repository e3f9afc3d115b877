"""Sampling-based planning on the batched checker: RRT-Connect (Kuffner & LaValle 2000) to a
goal *set*, and path shortcutting.

Edges are straight lines in joint space checked at ``resolution`` (no joint moves more than
that between two checked states). Every edge is checked as one batch: the states of an edge
go to the checker in one call, and the tree is extended to the last free state before the
first collision.
"""

from __future__ import annotations

import math
import random
import threading
import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

# the compiled steps (numba loads a kernel from its cache on its first call, not here): a
# plan imported them on its way, 10 µs of a plan on the caches a scene's loading leaves
from robocell.planning import _kernels as PK
from robocell.scene.checker import SEARCH_SLOTS, THREADS, next_epoch

_MASK64 = (1 << 64) - 1
# SplitMix64's constants, the compiled draws' (PK._next_seed), as Python ints
_GOLDEN, _MIX1, _MIX2 = int(PK._GOLDEN), int(PK._MIX1), int(PK._MIX2)


class Seeds:
    """A plan's stream of seeds for its compiled steps (each seeds numba's generator), drawn
    from the request's seed by SplitMix64 (Steele et al. 2014) in plain Python. numpy's
    Generator costs little once its code is in the CPU's caches, but a plan starts after
    other work (a scene loaded, physics stepped) has pushed it out: then creating one cost
    180 µs and a draw 75 µs (measured), a fifth of a Panda plan of 1.3 ms.
    :meth:`generator` gives a numpy Generator, seeded from the stream, for the steps in
    Python. ``seed=None``: a seed of the operating system's. ``state`` is the stream's state,
    in [0, 2**64): a compiled step may draw from the stream itself and give back the state
    it left (:func:`rrt_connect_compiled`; ``_kernels._next_seed`` is :meth:`next`)."""

    def __init__(self, seed: int | None) -> None:
        self.state = int(seed) if seed is not None else random.SystemRandom().getrandbits(64)
        self.state &= _MASK64
        self._numpy: np.random.Generator | None = None

    def next(self) -> int:
        """The next seed, in [0, 2**31)."""
        self.state = (self.state + _GOLDEN) & _MASK64
        z = self.state
        z = ((z ^ (z >> 30)) * _MIX1) & _MASK64
        z = ((z ^ (z >> 27)) * _MIX2) & _MASK64
        return (z ^ (z >> 31)) >> 33

    def generator(self) -> np.random.Generator:
        """A numpy Generator seeded from the stream (the same one on each call)."""
        if self._numpy is None:
            self._numpy = np.random.default_rng(self.next())
        return self._numpy


Rng = np.random.Generator | Seeds  # what the planning steps draw their randomness from


def seed_of(rng: Rng) -> int:
    """A seed in [0, 2**31) for a compiled step."""
    return rng.next() if isinstance(rng, Seeds) else int(rng.integers(2**31))


def generator_of(rng: Rng) -> np.random.Generator:
    """A numpy Generator for a step in Python."""
    return rng.generator() if isinstance(rng, Seeds) else rng


class BatchChecker(Protocol):
    def check(self, qs: NDArray[np.float64]) -> NDArray[np.bool_]: ...

    def first_collision(self, qs: NDArray[np.float64]) -> int: ...


@dataclass
class EdgeStats:
    """Counters of one planning run."""

    edges: int = 0
    states: int = 0
    iterations: int = 0
    nodes: int = 0
    # rrt_connect_compiled(check_ends=True) found the start or a goal not FREE: nothing searched
    blocked_ends: bool = False
    # rrt_connect_compiled's path (shortcut), as it will be executed, checked by the
    # searches' threads as the final check classifies it first: every state FREE
    # (Finish.final_resolution)
    final_free: bool = False
    # else, when they checked all of it: which of the states the final check classifies
    # first (then, when they checked them too, of the segments' stretches at the corners)
    # they found not FREE, by class (HIT or UNSURE; 0: FREE), for it (_kernels.validate_path's
    # ``known``)
    final_not_free: NDArray[np.int8] | None = None
    # else, when they found no state UNSURE (Finish.detour_radii): the path judged in their
    # call (_kernels.JUDGED_*: JUDGED_NOT, or the path as it is, mended by detours, or mended
    # with its corners left to the final check) and the corner deviation to execute it with
    final_judged: int = 0
    final_deviation: float = 0.0
    # the seed rrt_connect_compiled drew for those detours (Finish.detour_radii), whether or
    # not its call judged the path: the planner's own repair takes it (the same path)
    detour_seed: int | None = None


class Edges:
    """Straight-line edge checks at a fixed resolution, counted."""

    def __init__(self, checker: BatchChecker, resolution: float) -> None:
        self.checker = checker
        self.resolution = resolution
        self.stats = EdgeStats()

    def states(
        self, a: NDArray[np.float64], b: NDArray[np.float64], include_start: bool = False
    ) -> NDArray[np.float64]:
        n = max(1, int(math.ceil(float(np.max(np.abs(b - a))) / self.resolution)))
        t = np.arange(0 if include_start else 1, n + 1, dtype=float)[:, None] / n
        return a + t * (b - a)

    def first_hit(self, qs: NDArray[np.float64]) -> int:
        """Index of the first colliding state of ``qs`` (len(qs) if none)."""
        self.stats.edges += 1
        k = self.checker.first_collision(qs)
        self.stats.states += min(k + 1, len(qs))
        return k

    def free(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
        """Whether the segment a → b (b included, a assumed free) is collision-free. States are
        checked coarse-to-fine (every 8th first), so a blocked edge is usually found early."""
        qs = self.states(a, b)
        if len(qs) > 16:
            coarse = qs[7::8]
            if self.first_hit(coarse) < len(coarse):
                return False
            mask = np.ones(len(qs), bool)
            mask[7::8] = False
            qs = qs[mask]
        return self.first_hit(qs) == len(qs)


class _Tree:
    def __init__(self, dof: int, capacity: int = 1024) -> None:
        self.q = np.empty((capacity, dof))
        self.parent = np.empty(capacity, np.int64)
        self.n = 0

    def add(self, q: NDArray[np.float64], parent: int) -> int:
        if self.n == len(self.q):
            self.q = np.vstack([self.q, np.empty_like(self.q)])
            self.parent = np.concatenate([self.parent, np.empty_like(self.parent)])
        self.q[self.n] = q
        self.parent[self.n] = parent
        self.n += 1
        return self.n - 1

    def nearest(self, q: NDArray[np.float64]) -> int:
        d = self.q[: self.n] - q
        return int(np.argmin(np.einsum("ij,ij->i", d, d)))

    def branch(self, i: int) -> list[NDArray[np.float64]]:
        """Configurations from node i back to its root."""
        out = []
        while i >= 0:
            out.append(self.q[i])
            i = int(self.parent[i])
        return out


def rrt_connect(
    edges: Edges,
    start: NDArray[np.float64],
    goals: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    rng: Rng,
    deadline: float,
    step: float = 0.8,
) -> NDArray[np.float64] | None:
    """A collision-free path (K, dof) from ``start`` to one of ``goals`` (G, dof), or None when
    ``deadline`` (time.perf_counter) passes. Start and goals must be collision-free.

    ``step`` [rad]: longest extension of a tree towards a sample (L∞ in joint space)."""
    dof = start.shape[0]
    gen = generator_of(rng)
    # straight to a goal first: many requests need nothing more
    for g in goals[np.argsort(np.linalg.norm(goals - start, axis=1))][:4]:
        if edges.free(start, g):
            return np.array([start, g])
        if time.perf_counter() > deadline:
            return None
    ta, tb = _Tree(dof), _Tree(dof)
    ta.add(start, -1)
    for g in goals:
        tb.add(g, -1)
    a_is_start = True
    span = upper - lower
    while time.perf_counter() < deadline:
        edges.stats.iterations += 1
        q_rand = lower + gen.random(dof) * span
        i = ta.nearest(q_rand)
        q_new = _extend(edges, ta.q[i], q_rand, step)
        if q_new is not None:
            i_new = ta.add(q_new, i)
            # connect: grow the other tree towards q_new, as far as it is free
            j = tb.nearest(q_new)
            while True:
                q2 = _extend(edges, tb.q[j], q_new, step)
                if q2 is None:
                    break
                j = tb.add(q2, j)
                if np.array_equal(q2, q_new):
                    pa, pb = ta.branch(i_new), tb.branch(j)
                    path = pa[::-1] + pb[1:]
                    if not a_is_start:
                        path = path[::-1]
                    edges.stats.nodes = ta.n + tb.n
                    return np.array(path)
        ta, tb = tb, ta
        a_is_start = not a_is_start
    edges.stats.nodes = ta.n + tb.n
    return None


@dataclass
class Finish:
    """The shortcut :func:`rrt_connect_compiled` makes of the path it found, in the search's
    kernel call (:func:`shortcut_compiled`'s settings)."""

    deadline: float  # of the shortcut
    tries: int = 0
    share: float = 0.5
    min_states: int = 100
    min_gain: float = 0.0
    # then, side by side, the final check's states of the winner's shortcut path (its
    # corners rounded within max_deviation) at this resolution, checked by the searches'
    # threads in chunks of final_chunk states up to the first that is not FREE (0: not
    # checked): edges.stats.final_free
    final_resolution: float = 0.0
    max_deviation: float = 0.0
    final_chunk: int = 32
    # where they found states not FREE (none UNSURE), the path judged in the same call, its
    # colliding segments mended by detours of these radii (none: not judged):
    # edges.stats.final_judged
    detour_radii: NDArray[np.float64] | None = None


def rrt_connect_compiled(
    edges: Edges,
    start: NDArray[np.float64],
    goals: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    rng: Rng,
    deadline: float,
    step: float = 0.8,
    cap: int = 1 << 14,
    searches: int = 2,
    box_margin: float = 2.0,
    box_share: float = 0.8,
    side_by_side: bool | None = None,
    whole_for: int = 40,
    finish: Finish | None = None,
    check_ends: bool = False,
) -> NDArray[np.float64] | None:
    """:func:`rrt_connect` compiled whole on the collision kernel (see
    :mod:`robocell.planning._kernels`): a path, or None when the deadline passed or a tree
    filled up. States the kernel leaves unsure block its edges; the caller may then search in
    Python, which settles them.

    With ``searches=2`` a second search with a seed of its own runs beside the first, on
    the kernel's threads (``_kernels.rrt_connect_many``; a Python thread's handoff cost
    150–200 µs more per plan: medians 5–13 % higher on UR5 and Panda table_pick,
    table_under_pick and UR5 box, the same paths), and the one that finds a path with the
    least work (see ``_kernels._work``: states and sphere centres placed, a measure of time
    that does not depend on the machine's load) wins: the other stops once it has done
    more. The result depends on the seed only, not on the scheduling of the threads or the
    number of cores.
    A search's work varies widely with its seed, so the better of two cuts the long searches
    most: over the first 40 problems of each UR5 set with obstacles, the mean planning time
    fell by 11–43 %, the p95 by 12–52 %. Short searches are slowed a little (two at once
    share the cache), and joining the second one later did not help.

    A share ``box_share`` of the samples is drawn from the box around the start and the goals
    grown by ``box_margin`` [rad] (within the limits), the rest from the whole joint space
    (so the search stays complete): most motions need a detour near the straight line, not
    one through the far side of the joint space. Over 2 × 40 problems per UR5 set, 0.8 and
    2 rad cut the cage's mean planning time from 95 to 40 ms and the bookshelves' p95 by
    half, and shortened the paths by a sixth; a 1 rad margin doubled the cage's time.

    ``side_by_side``: run the searches on the kernel's threads (True) or one after the other
    (False; the same path); by default side by side where numba's threading layer allows it
    (:func:`_threadsafe_layer`).

    ``whole_for``: for its first ``whole_for`` iterations a search adds an edge only if it
    is free whole (as OMPL's RRTConnect and VAMP do), its states checked coarse to fine so
    that a blocked one is rejected after a few; then, as :func:`rrt_connect` always does, as
    far as it is free (Kuffner and LaValle's EXTEND), which grows the trees into narrow
    passages. Against the latter throughout (session 16: 50 problems per set, alternating in
    one process, each on a freshly loaded scene): with ``whole_for=40`` the medians were
    8–25 % lower on six Panda sets (2 % higher on bookshelf_tall) and 1–20 % lower or within
    7 % on the UR5's, p95 lower on most (Panda table_under_pick 4.7 → 3.0 ms), paths as
    long or shorter. Whole edges throughout made the UR5's cage, whose searches run for
    hundreds of iterations, 35–66 % slower; a switch after 24 iterations cost the Panda's
    table_under_pick 7 % against 64, and 64 the UR5's cage 20 %.

    ``finish``: the path found shortcut in the same kernel call (``_kernels.plan_in``), as
    :func:`shortcut_compiled` does it with these settings; with ``finish.final_resolution``
    and side by side, the searches' threads then check it as the final check classifies it
    first (``_kernels._final_share``): ``edges.stats.final_free`` when every state is FREE,
    else the planner checks it (``_kernels.validate_path``), classifying again only the
    states they found not FREE (``edges.stats.final_not_free``). With ``finish.detour_radii``,
    where no state was UNSURE, the path is judged and mended in the same call
    (``_kernels._judged``): ``edges.stats.final_judged`` and ``final_deviation``; the path
    returned is the mended one.

    ``check_ends``: the start and the goals are classified first, in the same call; if one
    is not FREE (in collision, or unsure near contact), nothing is searched, the result is
    None and ``edges.stats.blocked_ends`` is set: the caller checks them exactly.

    The seeds (one per search, then the shortcut's and the detours') are drawn in the call
    from ``rng``'s stream, which it leaves as :meth:`Seeds.next` would have (a numpy
    Generator seeds a stream with one draw of its own)."""
    _, scratch = edges.checker.kernel_inputs()  # type: ignore[attr-defined]
    inputs = edges.checker.compiled_inputs  # type: ignore[attr-defined]
    searches = max(1, min(searches, SEARCH_SLOTS))
    first_slot = scratch[0].shape[0] - SEARCH_SLOTS
    # the kernel draws the searches', the shortcut's and the detours' seeds from the stream
    stream = rng if isinstance(rng, Seeds) else Seeds(seed_of(rng))
    finish = finish or Finish(deadline)
    radii = finish.detour_radii
    if radii is None or not (finish.tries > 0 and finish.final_resolution > 0):
        radii = _NO_RADII
    start = np.ascontiguousarray(start, dtype=float)
    goals = np.ascontiguousarray(goals, dtype=float)
    lower = np.ascontiguousarray(lower, dtype=float)
    upper = np.ascontiguousarray(upper, dtype=float)
    with _SEARCH_LOCK:
        if side_by_side is None:
            side_by_side = searches > 1 and _threadsafe_layer()
        t0, cpu0 = time.perf_counter(), time.thread_time()
        state, detour_seed, path, status, st, shortcut_states, free, known, judged, dev = (
            PK.plan_in(
                start, goals, lower, upper, _as_int64(stream.state), searches, deadline,
                edges.resolution, step, inputs, next_epoch((searches + 4) << 40), cap,
                first_slot, box_margin, box_share, whole_for, side_by_side, finish.deadline,
                finish.tries, finish.share, finish.min_states, float(finish.min_gain),
                check_ends, float(finish.final_resolution), float(finish.max_deviation),
                int(finish.final_chunk), _omp(), radii,
            )
        )  # fmt: skip
        if side_by_side:
            THREADS.note(time.perf_counter() - t0, time.thread_time() - cpu0)
    stream.state = int(state) & _MASK64
    edges.stats.detour_seed = int(detour_seed) if len(radii) else None
    edges.stats.blocked_ends = status == PK.BLOCKED
    edges.stats.final_free = bool(free)
    edges.stats.final_not_free = known if len(known) else None
    edges.stats.final_judged = int(judged)
    edges.stats.final_deviation = float(dev)
    edges.stats.iterations += int(st[0])
    edges.stats.nodes = int(st[1])
    edges.stats.states += int(st[3]) + int(shortcut_states)
    return path if status == PK.FOUND else None


def _as_int64(state: int) -> int:
    """A stream state in [0, 2**64) as the int64 with its bits (the compiled call's
    ``stream_bits``)."""
    return state - (1 << 64) if state >= 1 << 63 else state


def _threadsafe_layer() -> bool:
    """Whether numba's threading layer lets two threads launch parallel work at once: not
    its ``workqueue`` layer (the fallback where neither OpenMP nor TBB is found), which aborts
    the process then. The searches run side by side only on a threadsafe layer, as a search
    may run while another thread checks a batch of states."""
    if _LAYER:
        return _LAYER[0]
    import numba

    try:
        _LAYER.append(numba.threading_layer() != "workqueue")  # chosen once per process
    except ValueError:  # no parallel work has run yet: the layer is not chosen
        return False
    return _LAYER[0]


_LAYER: list[bool] = []  # whether numba's threading layer is threadsafe, once it is chosen


def _omp() -> bool:
    """Whether numba's threading layer is OpenMP's, which gives each iteration of a loop of
    at most its thread count a thread (TBB's may run them one after the other): then a
    search's thread may wait for another's result (_kernels._final_share), if there are as
    many threads as searches (_kernels.plan_in asks)."""
    if not _OMP:
        import numba

        try:
            _OMP.append(numba.threading_layer() == "omp")  # chosen once per process
        except ValueError:  # no parallel work has run yet: the layer is not chosen
            return False
    return _OMP[0]


_OMP: list[bool] = []  # whether numba's threading layer is OpenMP, once it is chosen


_SEARCH_LOCK = threading.Lock()  # the searches' scratch slots serve one planner at a time


def shortcut_compiled(
    edges: Edges,
    path: NDArray[np.float64],
    rng: Rng,
    deadline: float,
    max_tries: int = 40,
    budget: int | None = None,
    min_gain: float = 0.0,
) -> NDArray[np.float64]:
    """:func:`shortcut` compiled whole on the collision kernel (one call instead of one per
    edge). A state the kernel leaves unsure blocks its edge (the shortcut is not taken)."""

    out, stats = PK.shortcut_in(
        np.ascontiguousarray(path, dtype=float),
        seed_of(rng),
        deadline,
        edges.resolution,
        edges.checker.compiled_inputs,  # type: ignore[attr-defined]
        next_epoch(1 << 40),
        max_tries,
        (1 << 62) if budget is None else int(budget),
        float(min_gain),
    )
    edges.stats.states += int(stats[3])
    return out  # type: ignore[no-any-return]


_WARM = [False]


def warm_up(checker: BatchChecker, searches_only: bool = False) -> None:
    """Compile (or load from numba's cache) the compiled search once per process, outside any
    plan's time budget. A first run may be compiling the searches and the shortcut in a
    second process (planning.precompile): the detour and the final check compile here
    meanwhile, then the rest loads from the cache once it is done. ``searches_only``: that
    second process's part alone."""
    if _WARM[0]:
        return
    from robocell.planning import precompile

    model, scratch = checker.kernel_inputs()  # type: ignore[attr-defined]
    inputs = checker.compiled_inputs  # type: ignore[attr-defined]
    q = np.ascontiguousarray(model[1][model[0]], dtype=float)  # the current state
    if not searches_only:
        PK.detour_in(q, q, q, q - 1, q + 1, np.zeros(1), 0, 0.05, inputs, next_epoch(1 << 20))
        PK._clock()  # through numba's object mode (off Linux), 50 ms on its first call
        corner = np.array([q, q + 0.1, q + 0.2 * (np.arange(q.shape[0]) % 2)])  # final check
        PK.validate_path(corner, 0.01, 0.05, True, inputs, next_epoch(1 << 20), 64, NOTHING_CHECKED)
        # a repair's detours and corners (Planner._mend), and where segments collide
        PK.repair_in(
            corner, np.zeros(1, np.int64), np.array([corner[:3]]), q - 1, q + 1, np.zeros(1),
            0, 0.05, 0.05, inputs, next_epoch(1 << 20), 64,
        )  # fmt: skip
        PK.segment_hits(np.zeros(2, np.int64), np.zeros(2, np.bool_))
        precompile.wait()
    # the searches side by side (the kernel's threads start on the first parallel call) and
    # one after the other (rrt_connect_compiled)
    for side_by_side in (True, False):
        PK.plan_in(
            q, q[None, :], q - 1, q + 1, 0, SEARCH_SLOTS, 0.0, 0.05, 1.0, inputs,
            next_epoch((SEARCH_SLOTS + 4) << 40), 16, scratch[0].shape[0] - SEARCH_SLOTS, 1.0,
            0.5, 40, side_by_side, 0.0, 1, 0.5, 1, 0.0, False, 0.01, 0.05, 32, False,
            np.zeros(1),
        )  # fmt: skip
    PK.shortcut_in(np.array([q, q + 0.01]), 0, 0.0, 0.05, inputs, next_epoch(1 << 20), 1, 1, 0.0)
    _WARM[0] = not searches_only


_NO_RADII = np.zeros(0)  # Finish.detour_radii: the path not judged in the search's call
NOTHING_CHECKED = np.zeros(0, np.int8)  # validate_path's ``known``: no state checked before


def _extend(
    edges: Edges, q_from: NDArray[np.float64], q_to: NDArray[np.float64], step: float
) -> NDArray[np.float64] | None:
    """The farthest free state from q_from towards q_to, at most ``step`` away (L∞); None if
    not even the first state along the way is free."""
    d = q_to - q_from
    dist = float(np.max(np.abs(d)))
    if dist < 1e-12:
        return None
    target = q_to if dist <= step else q_from + d * (step / dist)
    qs = edges.states(q_from, target)
    k = edges.first_hit(qs)  # how many leading states are free
    if k == 0:
        return None
    return target if k == len(qs) else qs[k - 1]


def shortcut(
    edges: Edges,
    path: NDArray[np.float64],
    rng: Rng,
    deadline: float,
    max_tries: int = 40,
    budget: int | None = None,
    min_gain: float = 0.0,
) -> NDArray[np.float64]:
    """A shorter path: greedy removal of waypoints that can be skipped, then random shortcuts
    between points on the path (OMPL's shortcutPath), then greedy again if they changed it.
    Every new edge is checked. ``budget``: the most states the random shortcuts may check (the
    greedy passes are not counted): a deterministic cap, so that a plan's cost does not
    depend on the machine's load. ``min_gain``: a random shortcut that would shorten the
    stretch of path it replaces by less than this share of it is not checked (a failed try):
    near a gentle bend every shortcut is free and checked whole, for almost no gain."""
    gen = generator_of(rng)
    path = _skip_waypoints(edges, path, deadline)
    stop_at = None if budget is None else edges.stats.states + budget
    fails = 0
    tries = 0
    changed = False
    while len(path) > 2 and tries < max_tries and fails < 12 and time.perf_counter() < deadline:
        if stop_at is not None and edges.stats.states >= stop_at:
            break
        tries += 1
        seg_len = np.linalg.norm(np.diff(path, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(seg_len)])
        total = cum[-1]
        if total < 1e-9:
            break
        s1, s2 = np.sort(gen.random(2) * total)
        i1 = int(np.searchsorted(cum, s1, side="right") - 1)
        i2 = int(np.searchsorted(cum, s2, side="right") - 1)
        i2 = min(i2, len(path) - 2)
        if i1 == i2:
            fails += 1
            continue
        p1 = path[i1] + (path[i1 + 1] - path[i1]) * ((s1 - cum[i1]) / max(seg_len[i1], 1e-12))
        p2 = path[i2] + (path[i2 + 1] - path[i2]) * ((s2 - cum[i2]) / max(seg_len[i2], 1e-12))
        old = s2 - s1
        if np.linalg.norm(p2 - p1) > old - max(1e-6, min_gain * old):
            fails += 1
            continue
        if edges.free(p1, p2):
            path = np.vstack([path[: i1 + 1], p1, p2, path[i2 + 1 :]])
            fails = 0
            changed = True
        else:
            fails += 1
    if changed:  # else the first pass's result stands (a second would redo its checks)
        path = _skip_waypoints(edges, path, deadline)
    return dedupe(path)


def _skip_waypoints(
    edges: Edges, path: NDArray[np.float64], deadline: float
) -> NDArray[np.float64]:
    """From each kept waypoint, jump to the farthest one reachable in a straight line."""
    out = [path[0]]
    i = 0
    n = len(path)
    while i < n - 1:
        j = n - 1
        while j > i + 1:
            if time.perf_counter() > deadline:
                j = i + 1
                break
            if edges.free(path[i], path[j]):
                break
            j -= 1
        out.append(path[j])
        i = j
    return np.array(out)


def dedupe(path: NDArray[np.float64]) -> NDArray[np.float64]:
    """``path`` without repeated consecutive waypoints (at least its two ends)."""
    keep = np.concatenate([[True], np.linalg.norm(np.diff(path, axis=0), axis=1) > 1e-9])
    out = path[keep]
    return out if len(out) >= 2 else np.vstack([path[0], path[-1]])
