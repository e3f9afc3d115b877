"""RRT-Connect compiled whole (numba), on the collision kernel directly: no Python call per edge.

The search is the one :func:`robocell.planning.rrt.rrt_connect` runs (the same extension,
connection and straight-to-goal steps); the differences are speed and one rule: a state the
kernel cannot settle by itself (UNSURE, left to coal by the checker) blocks the edge here. The
compiled search is therefore a little conservative near contact; the planner falls back to the
Python search, which settles such states exactly, when the compiled one finds nothing.
"""

from __future__ import annotations

import math
import os
import platform
import sys
import time

import numba
import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.core import cgutils
from numba.extending import intrinsic

from robocell.scene import _kernels as SK
from robocell.trajectory import _kernels as TK

FOUND, NOT_FOUND, FULL, STOPPED = 0, 1, 2, 3
BLOCKED = 4  # plan_in: the start or a goal is not FREE (the caller settles why)
STATE_WORK = 100  # a state's kinematics and pair loop, in sphere centres placed (fitted)


# time.perf_counter, read in compiled code. On Linux it is clock_gettime(CLOCK_MONOTONIC),
# called here directly (30 ns, measured); elsewhere it goes through numba's object mode, which
# takes the GIL (1.2 µs, and it makes the GIL-free searches wait for each other and for the
# main thread: 9 % of a UR5 table_pick plan was spent there, measured with pyinstrument).
DIRECT_CLOCK = sys.platform.startswith("linux") and (
    time.get_clock_info("perf_counter").implementation == "clock_gettime(CLOCK_MONOTONIC)"
)
_CLOCK_MONOTONIC = 1  # Linux's id


@intrinsic
def _monotonic(typingctx):  # type: ignore[no-untyped-def]
    """clock_gettime(CLOCK_MONOTONIC) in seconds (the C library's, bound by name when the
    code is linked, so the compiled code can be cached)."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        i64, i32, f64 = ir.IntType(64), ir.IntType(32), ir.DoubleType()
        timespec = ir.LiteralStructType([i64, i64])
        fnty = ir.FunctionType(i32, [i32, timespec.as_pointer()])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "clock_gettime")
        ts = cgutils.alloca_once(builder, timespec)
        builder.call(fn, [ir.Constant(i32, _CLOCK_MONOTONIC), ts])
        sec = builder.sitofp(builder.load(cgutils.gep_inbounds(builder, ts, 0, 0)), f64)
        nsec = builder.sitofp(builder.load(cgutils.gep_inbounds(builder, ts, 0, 1)), f64)
        return builder.fadd(sec, builder.fmul(nsec, ir.Constant(f64, 1e-9)))

    return types.float64(), codegen


if DIRECT_CLOCK:

    @njit(cache=True)
    def _clock():  # type: ignore[no-untyped-def]
        return _monotonic()

else:

    @njit(cache=True)
    def _clock():  # type: ignore[no-untyped-def]
        with numba.objmode(t="float64"):
            t = time.perf_counter()
        return t


@intrinsic
def _atomic_add(typingctx, arr, i, v):  # type: ignore[no-untyped-def]
    """arr[i] += v as one atomic step (sequentially consistent) on an int64 array; returns
    the value before. The searches' threads share a few counters through it (_search_one)."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1]])
        return builder.atomic_rmw("add", ptr, args[2], "seq_cst")

    return types.int64(arr, i, v), codegen


@intrinsic
def _atomic_cas(typingctx, arr, i, expected, new):  # type: ignore[no-untyped-def]
    """arr[i] = new if it holds ``expected``, as one atomic step (sequentially consistent)
    on an int64 array; returns the value before (``expected`` when it was swapped)."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1]])
        pair = builder.cmpxchg(ptr, args[2], args[3], "seq_cst", "seq_cst")
        return builder.extract_value(pair, 0)

    return types.int64(arr, i, expected, new), codegen


@intrinsic
def _atomic_load(typingctx, arr, i):  # type: ignore[no-untyped-def]
    """arr[i] read as one atomic step (acquire) on an int64 array: what the writer stored
    before its :func:`_atomic_store` of that value is there to read after it. A plain load on
    x86: a thread that polls it leaves the cache line shared with its writer (an atomic add of
    0, as :func:`_decided` polls, takes the line from it every time)."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1]])
        return builder.load_atomic(ptr, "acquire", 8)

    return types.int64(arr, i), codegen


@intrinsic
def _atomic_store(typingctx, arr, i, v):  # type: ignore[no-untyped-def]
    """arr[i] = v as one atomic step (sequentially consistent) on an int64 array: what was
    written before it is there to read for a thread that reads v (:func:`_atomic_add` with 0)."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1]])
        builder.atomic_rmw("xchg", ptr, args[2], "seq_cst")
        return context.get_dummy_value()

    return types.none(arr, i, v), codegen


@intrinsic
def _pause(typingctx):  # type: ignore[no-untyped-def]
    """The CPU's spin-wait hint (x86's ``pause``; nothing elsewhere), in a thread that polls
    a counter another thread will change."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        _emit_pause(builder)
        return context.get_dummy_value()

    return types.none(), codegen


def _emit_pause(builder):  # type: ignore[no-untyped-def]
    """x86's ``pause`` at the builder's position (nothing elsewhere)."""
    if _X86:
        fnty = ir.FunctionType(ir.VoidType(), [])
        builder.call(cgutils.get_or_insert_function(builder.module, fnty, _PAUSE), [])


@intrinsic
def _nap(typingctx, us):  # type: ignore[no-untyped-def]
    """The C library's usleep(us): the thread sleeps, its core goes idle, and the operating
    system may run another thread there (bound by name, as :func:`_monotonic`; POSIX only,
    elsewhere the spin-wait hint of :func:`_pause`)."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        if _POSIX:
            i32 = ir.IntType(32)
            fnty = ir.FunctionType(i32, [i32])
            fn = cgutils.get_or_insert_function(builder.module, fnty, "usleep")
            builder.call(fn, [builder.trunc(args[0], i32)])
        else:
            _emit_pause(builder)
        return context.get_dummy_value()

    return types.none(us), codegen


@intrinsic
def _num_threads(typingctx):  # type: ignore[no-untyped-def]
    """numba.get_num_threads() in compiled code, from the threading layer's C function bound
    by name, as numba's parallel loops bind it (its own get_num_threads in compiled code goes
    through ctypes, which keeps a function out of numba's cache). The symbol is there once
    numba launched its threads, as for any parallel loop."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        fnty = ir.FunctionType(cgutils.intp_t, [])  # as numba declares it
        fn = cgutils.get_or_insert_function(builder.module, fnty, "get_num_threads")
        n = builder.trunc(builder.call(fn, []), ir.IntType(32))  # a C int
        return builder.sext(n, ir.IntType(64))

    return types.int64(), codegen


_X86 = platform.machine().lower() in ("x86_64", "amd64", "i686", "x86")
_POSIX = os.name == "posix"  # the C library has usleep (_nap)
_PAUSE = "llvm.x86.sse2.pause"  # LLVM's intrinsic (numba's JIT takes no inline assembly)


@njit(cache=True, inline="always")
def _edge_states(a, b, resolution, buf, coarse):  # type: ignore[no-untyped-def]
    """The states of the segment a → b (b included, a not), at most ``resolution`` apart per
    joint, written into ``buf`` (or a buffer of their own if it is too short): in order, or
    with ``coarse`` every 8th first, then the 4th, 2nd and 1st between them, so that an
    obstacle across the edge is met early wherever it lies. Returns (the buffer, how many).
    The shortcut checked 9–16 % fewer states coarse to fine on 30 problems each of UR5
    table_pick, table_under_pick and box than with every 8th first and the rest in order;
    109 of 120 paths over six sets came out the same, the others 0–0.5 % shorter on average,
    more random tries fitting in the budget."""
    dof = a.shape[0]
    dist = 0.0
    for j in range(dof):
        dist = max(dist, abs(b[j] - a[j]))
    n = max(1, int(math.ceil(dist / resolution)))
    if n > buf.shape[0]:  # a long straight edge
        buf = np.empty((n, dof))
    r = 0
    stride = 8 if coarse else 1
    while stride >= 1:
        for k in range(stride, n + 1, stride):
            if coarse and stride < 8 and k % (2 * stride) == 0:
                continue  # on a coarser pass's grid
            t = k / n
            for j in range(dof):
                buf[r, j] = a[j] + t * (b[j] - a[j])
            r += 1
        stride //= 2
    return buf, n


@njit(cache=True)
def _beaten(found, me, work):  # type: ignore[no-untyped-def]
    """Whether another search found a path with less than ``work`` done."""
    for j in range(found.shape[0]):
        if j != me and found[j] < work:
            return True
    return False


@njit(cache=True, inline="always")
def _lost(found, me):  # type: ignore[no-untyped-def]
    """Whether search ``me``, which found a path, lost the race: another found one with less
    work (see :func:`_best`)."""
    return _beaten(found, me, found[me])


@njit(cache=True)
def _placed(scratch, slot):  # type: ignore[no-untyped-def]
    """The sphere centres the kernel has placed on scratch slot ``slot`` (K._centre)."""
    return scratch[1][slot, -1] + scratch[3][slot, -1]


@njit(cache=True)
def _work(stats, scratch, slot, placed_before):  # type: ignore[no-untyped-def]
    """A search's work so far, in sphere centres placed, each state counted as STATE_WORK
    more (its kinematics): a measure of its time that does not depend on the machine or its
    load. Kept in stats[4]."""
    stats[4] = stats[3] * STATE_WORK + _placed(scratch, slot) - placed_before
    return stats[4]


# SplitMix64's constants (rrt.Seeds)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True, inline="always")
def _next_seed(state):  # type: ignore[no-untyped-def]
    """:meth:`robocell.planning.rrt.Seeds.next` in compiled code: the stream's next state
    (uint64) and its seed, in [0, 2**31)."""
    state = state + _GOLDEN
    z = (state ^ (state >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return state, np.int64((z ^ (z >> np.uint64(31))) >> np.uint64(33))


@njit(cache=True)
def _nearest(Q, n, q):  # type: ignore[no-untyped-def]
    best, arg = np.inf, 0
    for i in range(n):
        d = 0.0
        for j in range(q.shape[0]):
            e = Q[i, j] - q[j]
            d += e * e
        if d < best:
            best, arg = d, i
    return arg


@njit(cache=True, inline="always")
def _extend(Q, P, n, i, q_to, step, resolution, sc, epoch, buf, stats, whole):  # type: ignore[no-untyped-def]
    """Grow the tree (Q, P, n nodes) from node i towards q_to by at most ``step`` (L∞): the
    new node's index, or −1 if not even the first state is free. ``whole``: only if the whole
    edge is free (its states checked coarse to fine, so that a blocked edge is rejected after
    a few), else as far as it is free (checked in order)."""
    dof = q_to.shape[0]
    dist = 0.0
    for j in range(dof):
        dist = max(dist, abs(q_to[j] - Q[i, j]))
    if dist < 1e-12:
        return -1
    f = 1.0 if dist <= step else step / dist
    target = np.empty(dof)
    for j in range(dof):
        target[j] = Q[i, j] + f * (q_to[j] - Q[i, j])
    # one scan call either way (the search's code compiles in a first run's critical path)
    qs, m = _edge_states(Q[i], target, resolution, buf, whole)
    k = SK.scan(qs, m, sc, epoch + stats[2])
    stats[2] += m
    stats[3] += min(k + 1, m)
    if whole:
        if k < m:
            return -1
        Q[n] = target
    elif k == 0:
        return -1
    elif k == m:
        Q[n] = target
    else:
        Q[n] = qs[k - 1]
    P[n] = i
    return n


@njit(cache=True, nogil=True)
def rrt_connect(
    start, goals, lower, upper, seed, deadline, resolution, step, scratch, scanners, epoch, cap,
    slot, found, me, box_lo, box_hi, p_box, whole_for,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """A collision-free path (K, dof) from ``start`` to one of ``goals`` (G, dof) and a status
    (FOUND, NOT_FOUND when ``deadline`` (time.perf_counter) passed, FULL when a tree reached
    ``cap`` nodes, STOPPED), with stats (iterations, nodes, epochs used, states checked).

    Runs without the GIL, on scratch slot ``slot``, so that searches with other seeds can run
    beside it: ``found[me]`` is set to its work (see :func:`_work`) when it finds a path,
    and it stops (STOPPED) once its work exceeds that of another search that found one
    (``found[j]``, j ≠ me). Which search wins is then the one that needs the least work, however the
    threads are scheduled."""
    np.random.seed(seed)  # noqa: NPY002 (numba's generator: the legacy API is what it compiles)
    dof = start.shape[0]
    stats = np.zeros(5, np.int64)  # iterations, nodes, epochs used, states checked, work
    placed = _placed(scratch, slot)
    buf = np.empty((SK.SCAN_STATES, dof))
    sc = scanners[slot]
    empty = np.empty((0, dof))
    # straight to the nearest goals first: many requests need nothing more (the first search
    # tries it; the others would repeat it)
    d = np.empty(goals.shape[0])
    for g in range(goals.shape[0]):
        d[g] = np.sqrt(np.sum((goals[g] - start) ** 2))
    for g in np.argsort(d)[: 4 if me == 0 else 0]:
        if _edge_free(start, goals[g], resolution, sc, epoch, buf, stats):
            path = np.empty((2, dof))
            path[0] = start
            path[1] = goals[g]
            found[me] = _work(stats, scratch, slot, placed)
            return path, FOUND, stats
    Qa = np.empty((cap, dof))
    Pa = np.empty(cap, np.int64)
    Qb = np.empty((cap, dof))
    Pb = np.empty(cap, np.int64)
    Qa[0] = start
    Pa[0] = -1
    na = 1
    for g in range(goals.shape[0]):
        Qb[g] = goals[g]
        Pb[g] = -1
    nb = goals.shape[0]
    a_is_start = True
    q_rand = np.empty(dof)
    while True:
        if stats[0] % 16 == 0 and _clock() > deadline:
            stats[1] = na + nb
            return empty, NOT_FOUND, stats
        if na >= cap - 1 or nb >= cap - 1:
            stats[1] = na + nb
            return empty, FULL, stats
        if _beaten(found, me, _work(stats, scratch, slot, placed)):
            stats[1] = na + nb
            return empty, STOPPED, stats
        stats[0] += 1
        lo, hi = (box_lo, box_hi) if np.random.random() < p_box else (lower, upper)  # noqa: NPY002
        for j in range(dof):
            q_rand[j] = lo[j] + np.random.random() * (hi[j] - lo[j])  # noqa: NPY002
        i = _nearest(Qa, na, q_rand)
        whole = stats[0] <= whole_for
        i_new = _extend(
            Qa, Pa, na, i, q_rand, step, resolution, sc, epoch, buf, stats, whole
        )  # fmt: skip
        if i_new >= 0:
            na += 1
            q_new = Qa[i_new].copy()
            # connect: grow the other tree towards q_new, as far as it is free
            j = _nearest(Qb, nb, q_new)
            while nb < cap - 1:
                j2 = _extend(
                    Qb, Pb, nb, j, q_new, step, resolution, sc, epoch, buf, stats, whole
                )  # fmt: skip
                if j2 < 0:
                    break
                nb += 1
                j = j2
                reached = True
                for c in range(dof):
                    if Qb[j, c] != q_new[c]:
                        reached = False
                        break
                if reached:
                    # the path: a's branch reversed, then b's branch
                    la = 0
                    x = i_new
                    while x >= 0:
                        la += 1
                        x = Pa[x]
                    lb = 0
                    x = j
                    while x >= 0:
                        lb += 1
                        x = Pb[x]
                    path = np.empty((la + lb - 1, dof))
                    x = i_new
                    for s in range(la - 1, -1, -1):
                        path[s] = Qa[x]
                        x = Pa[x]
                    x = Pb[j]
                    for s in range(la, la + lb - 1):
                        path[s] = Qb[x]
                        x = Pb[x]
                    stats[1] = na + nb
                    if not a_is_start:
                        path = path[::-1].copy()
                    found[me] = _work(stats, scratch, slot, placed)
                    return path, FOUND, stats
        Qa, Qb = Qb, Qa
        Pa, Pb = Pb, Pa
        na, nb = nb, na
        a_is_start = not a_is_start


@njit(cache=True, parallel=True, nogil=True)
def rrt_connect_many(
    start, goals, lower, upper, seeds, deadline, resolution, step, scratch, scanners, epochs,
    cap, first_slot, box_lo, box_hi, p_box, whole_for, finish, final, ends_epoch,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """:func:`rrt_connect` once per seed of ``seeds``, side by side on the kernel's threads
    (search i on scratch slot ``first_slot + i``, from stamp ``epochs[i]``): each stops once
    another has found a path with less work. A search that finds a path shortcuts it at once
    on its own thread (``finish``: see :func:`_search_one`), before it knows whether it won;
    then (``final``) the threads check the winner's path together, as the final check would.
    With ``ends_epoch`` ≥ 0 the first search checks the start and the goals first (status
    BLOCKED if one is not FREE: see :func:`_search_one`). Returns :func:`_search_outputs`.
    Launching them here cost 10–20 µs instead of the 150–200 µs of a Python thread's handoff
    (measured)."""
    out = _search_outputs(seeds.shape[0], cap, start.shape[0])
    for i in prange(seeds.shape[0]):
        # prange's index is unsigned: _search_one would be compiled anew for it
        _search_one(
            np.int64(i), start, goals, lower, upper, seeds, deadline, resolution, step, scratch,
            scanners, epochs, cap, first_slot, box_lo, box_hi, p_box, whole_for, finish, final,
            ends_epoch, out,
        )  # fmt: skip
    return out


@njit(cache=True)
def _search_outputs(n, cap, dof):  # type: ignore[no-untyped-def]
    """What n searches return (:func:`rrt_connect_many`): paths (n, 2·cap, dof) of which path
    i is the first ``lengths[i]`` rows, statuses, stats (n, 5), the work each had done when
    it found its path, whether its path is shortcut already, the states its shortcut
    checked, the counters the threads share (SYNC_*), and which of the final check's states
    of each search's path the threads found not FREE (:func:`_final_share`), and each
    search's board for its shortcut and the points it posts (:func:`_edge_free_ahead`)."""
    return (
        np.empty((n, 2 * cap, dof)),
        np.zeros(n, np.int64),
        np.full(n, NOT_FOUND, np.int64),
        np.zeros((n, 5), np.int64),
        np.full(n, np.iinfo(np.int64).max, np.int64),
        np.zeros(n, np.bool_),
        np.zeros(n, np.int64),
        np.zeros(_counters(n, n), np.int64),
        np.zeros((n, FINAL_STATES), np.int8),
        np.zeros((n, BOARD), np.int64),
        np.empty((n, 2, 2, dof)),
    )


@njit(cache=True, nogil=True)
def _search_one(
    i, start, goals, lower, upper, seeds, deadline, resolution, step, scratch, scanners, epochs,
    cap, first_slot, box_lo, box_hi, p_box, whole_for, finish, final, ends_epoch, out,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Search i of :func:`rrt_connect_many` (seed ``seeds[i]``, scratch slot
    ``first_slot + i``, stamps from ``epochs[i]``), its results written into ``out``
    (:func:`_search_outputs`).

    ``finish`` = (seed, deadline, tries, share, min_states, epoch, min_gain): with tries > 0, a path
    found is shortcut at once on this thread (:func:`shortcut` with these settings, stamps
    from ``epoch + i·2**40 / n`` of n searches). A search that finds its path first used to
    wait at the end of the race for the other to do as much work, 0.1–0.2 ms when the other's
    thread was slow to wake; its shortcut now runs meanwhile. Whichever search wins, the path
    is the same: the winner's shortcut, with the same seed.

    ``final`` = (resolution, max_deviation, chunk, epoch, concurrent, helpers): with resolution
    > 0 and a shortcut, the search then checks the winner's path with the others
    (:func:`_final_share`); with ``helpers`` too, its shortcut offers segments to a search's
    thread that waits there with nothing to check (:func:`_edge_free_ahead`).

    ``ends_epoch`` ≥ 0: search 0 first classifies the start and the goals (:func:`SK.scan`,
    stamps from ``ends_epoch``) while the others start searching; if one is not FREE, its
    status is BLOCKED and the others stop at once (it sets its work found to −1: see
    :func:`_beaten`). Before the threads were launched, on the calling thread alone, that
    check took 16 µs of a plan (Panda table_pick after an ``ompl`` plan, median, session 39),
    and every search waited for it."""
    paths, lengths, statuses, stats, found, shortened, shortcut_states, sync, _, boards, points = (
        out
    )
    n = seeds.shape[0]
    _atomic_add(sync, i, 1)
    if (
        i == 0
        and ends_epoch >= 0
        and not _ends_free(start, goals, scanners, first_slot, ends_epoch)
    ):
        statuses[0] = BLOCKED
        found[0] = -1
        _atomic_add(sync, n + i, 1)  # done
        return
    path, status, st = rrt_connect(
        start, goals, lower, upper, seeds[i], deadline, resolution, step, scratch, scanners,
        epochs[i], cap, first_slot + i, found, i, box_lo, box_hi, p_box, whole_for,
    )  # fmt: skip
    seed, sc_deadline, tries, share, min_states, sc_epoch, min_gain = finish
    resolution_f, max_deviation, chunk, epoch_f, concurrent, helpers = final
    if status == FOUND and tries > 0:
        budget = max(min_states, int(share * st[3]))
        # open to help from another search's thread once that one waits (_final_share)
        helped = helpers and concurrent and n > 1 and resolution_f > 0
        if helped:
            _atomic_store(boards[i], B_OPEN, 1)
        short, sc = shortcut(
            path, seed, sc_deadline, resolution, scanners, _stamps(sc_epoch, n, i), tries,
            budget, first_slot + i, min_gain, found, i, boards[i], points[i],
        )  # fmt: skip
        if helped:
            _atomic_store(boards[i], B_OPEN, 0)
        if short.shape[0] <= paths.shape[1]:
            path = short
            shortened[i] = True
            shortcut_states[i] = sc[3]
    lengths[i] = path.shape[0]
    paths[i, : path.shape[0]] = path
    statuses[i] = status
    stats[i] = st
    _atomic_add(sync, n + i, 1)  # done: what it wrote above is there to read
    if resolution_f > 0 and tries > 0:
        _final_share(
            out, n, resolution_f, max_deviation, chunk, epoch_f, concurrent, deadline, scanners,
            first_slot + i, i, resolution,
        )  # fmt: skip


@njit(cache=True)
def _ends_free(start, goals, scanners, slot, epoch):  # type: ignore[no-untyped-def]
    """Whether the start and every goal (G, dof) are FREE, scanned on scratch slot ``slot``
    (its scanner of ``scanners``, stamps from ``epoch``)."""
    ends = np.empty((1 + goals.shape[0], start.shape[0]))
    ends[0] = start
    ends[1:] = goals
    return SK.scan(ends, ends.shape[0], scanners[slot], epoch) == ends.shape[0]


# the counters the searches' threads share (_search_outputs' sync array): per search j
# whether it started (at j), then per search whether it is done (at n + j); then, from
# _counters(n, i), those of the final check of search i's path: the next chunk of its first
# states to take, how many were not FREE, how many were checked, of how many; the same for
# the states of the corners' stretches (checked after them when one was not FREE); the
# chunks of the first states its own search's thread took before the winner was known
SYNC_NEXT, SYNC_BAD, SYNC_CHECKED, SYNC_STATES = 0, 1, 2, 3
SYNC_LATER_NEXT, SYNC_LATER_CHECKED, SYNC_LATER_STATES, SYNC_AHEAD = 4, 5, 6, 7
SYNC_COUNTERS = 8  # per search
# the most final-check states whose classes the searches' threads keep for the final check
# proper (_final_share; a longer path's are checked again there)
FINAL_STATES = 1 << 14
# how long a search's thread waits for another search to start on a thread of its own (a
# sleeping thread wakes in 0.2–0.4 ms here; OpenMP may give fewer threads than asked)
NOT_STARTED_WAIT = 0.005
# how long a thread waiting for another search's thread spins before it naps between looks
# (NAP_US µs at a time): when another process keeps a core busy, the thread it waits for may
# sit behind it, and a spinning thread keeps its own core from taking it; a napping one leaves
# its core idle, and the operating system moves the waiting work there. Spinning throughout,
# the Panda table sets' medians rose from 0.9–1.2 ms to 4.6–4.8 ms beside a busy loop
# (session 39); most waits without one end within it (the loser of the race waited for the
# winner's shortcut 34 µs, median; 106 µs at the 3rd quartile)
SPIN_WAIT = 0.0002
NAP_US = 20


@njit(cache=True, inline="always")
def _stamps(epoch, n, i):  # type: ignore[no-untyped-def]
    """The first of search i's share of the 2**40 stamps from ``epoch`` of n searches (its
    shortcut's, and its path's final check: each search's of its own)."""
    return epoch + i * ((1 << 40) // n)


@njit(cache=True, inline="always")
def _counters(n, i):  # type: ignore[no-untyped-def]
    """Where the counters of the final check of search i's path start in the sync array of n
    searches."""
    return 2 * n + SYNC_COUNTERS * i


@njit(cache=True)
def _best(statuses, found, n):  # type: ignore[no-untyped-def]
    """The search whose path the plan takes: the one that found one with the least work
    (search 0 if none did)."""
    best = 0
    for i in range(n):
        if statuses[i] == FOUND and (statuses[best] != FOUND or found[i] < found[best]):
            best = i
    return best


@njit(cache=True)
def _decided(sync, statuses, found, n):  # type: ignore[no-untyped-def]
    """:func:`_best` once it is known (every search done, its outputs written), else −1."""
    for j in range(n):
        if _atomic_add(sync, n + j, 0) == 0:
            return -1
    return _best(statuses, found, n)


@njit(cache=True)
def _final_share(
    out, n, resolution, max_deviation, chunk, epoch, concurrent, deadline, scanners, slot, me,
    edge_resolution,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """Search ``me``'s thread, once its search is done, checks the winner's shortcut path with
    the others, as :func:`_final_check` would classify it first (:func:`_final_batch`):
    chunks of ``chunk`` states taken in turn from the path's shared counters
    (:func:`_counters`) and scanned on the search's own code and scratch slot
    (:func:`SK.scan`, stamps ``epoch`` + the search's share of the 2**40 stamps + the state's
    row). ``out``'s counters then say whether every state was FREE (the final check's usual
    answer: the caller then needs no final check of its own); else ``out``'s last array
    marks those that were not, by their row in the final check's first batch, and the final
    check classifies only them again (``known``). Until session 33 the threads stopped at
    the first state that was not FREE, and the final check classified every state again.

    A thread waits for the winner to be known (every search done; pausing) while the
    searches it waits for run on other threads: started, or ``concurrent`` (each search has
    a thread of its own, as numba's OpenMP layer gives them) and started within
    NOT_STARTED_WAIT; else the last search to finish checks alone. Taken from a counter, the
    chunks go to whichever threads are there, in the same parallel region as the race,
    instead of a call of its own after it (another region, and Python between the two).
    Session 31, both ways alternating in one process, each plan in the benchmark's pattern
    (first in its scene, then after an ``ompl`` plan), 50 problems × 2–4: Panda table_pick
    0.685–0.702 against 0.732–0.757 ms (three runs), table_under_pick 1.246 against 1.259,
    box 1.047 against 1.072; UR5 table_pick 1.089 against 1.097, box 1.320 against 1.322,
    table_under_pick 1.810 against 1.761: there 24 of 50 searches' paths pass through an
    obstacle between the search's states, and the final check proper ran after the threads'
    check stopped at the first state that was not FREE (scanned in the order of
    :func:`_final_batch`; in order, 1.944 against 1.764).

    While it waits, a thread whose search found a path checks that path, a chunk at a time,
    looking at the decision between chunks: it wins if the search it waits for does more
    work than it did before finding one (timed in session 36, Panda table_pick after an
    ``ompl`` plan: in 70 of 150 plans the winner's thread waited 120 µs for the other search,
    while its path's check took 180 µs on two threads after it). Each search's path has
    counters, marks and stamps of its own, so a check of a path that lost is left as it is.
    The thread's scanner is its slot's, kept by the checker (:func:`SK.kernel_inputs`).

    A thread with nothing to check while it waits could scan chunks of the edges the other
    search's shortcut checks (the edge's states posted on a board, chunks of 4 taken by
    compare-and-swap, the answer and count as one scan's). Tried in session 37: the same
    paths, the waiting thread scanned 40 % of the posted chunks, but the kernel call was
    slower, hot and after an ``ompl`` plan (Panda table_pick 380 → 462 µs, table_under_pick
    721 → 774 hot; the board alone, with no thread to help, 511 → 602): not kept."""
    paths, _, statuses, _, found, shortened, _, sync, not_free, boards, points = out
    dof = paths.shape[2]
    sc = scanners[slot]
    # the path this thread checks (-1: none yet): its first batch, their rows in the final
    # check's order, the states of the corners' stretches, whether their marks fit (_prepared)
    prepared = -1
    both, order, later = np.empty((0, dof)), np.empty(0, np.int64), np.empty((0, dof))
    keep = False
    mine = _counters(n, me)
    # its own path, checked while it waits, until it loses
    ahead = statuses[me] == FOUND and shortened[me]
    t0 = _clock()
    idle = -1.0  # when it started to wait with nothing to check
    # a thread with nothing to check helps another search's shortcut (_help): its checks at
    # the searches' ``edge_resolution`` on its own slot, stamps above its final check's
    help_epoch = _stamps(epoch, n, me) + (1 << 38)
    help_stats = np.zeros(4, np.int64)
    help_buf = np.empty((0, dof))
    seg = np.empty((2, dof))
    while True:
        w = _decided(sync, statuses, found, n)
        if w >= 0:
            break
        if ahead and _lost(found, me):
            ahead = False
        if ahead:
            if prepared != me:
                both, order, later, keep = _prepared(out, n, me, resolution, max_deviation)
                prepared = me
            taken = _scan_shared(
                both, order, 0, sync, mine, SYNC_NEXT, SYNC_CHECKED, chunk, sc,
                _stamps(epoch, n, me), not_free[me], keep, 1,
            )  # fmt: skip
            _atomic_add(sync, mine + SYNC_AHEAD, taken)
            ahead = taken > 0  # else its first batch is all taken
            continue
        if _others_open(boards, me):
            if help_buf.shape[0] == 0:
                help_buf = np.empty((SK.SCAN_STATES, dof))
            if _help(
                boards, points, me, edge_resolution, sc, help_epoch, help_buf, help_stats, seg
            ):
                idle = -1.0
                continue
        now = _clock()
        if now > deadline:
            return
        for j in range(n):
            if _atomic_add(sync, n + j, 0) == 0:
                if _atomic_add(sync, j, 0) == 0:
                    # not running yet: it checks when it is done (a search said to have a
                    # thread of its own that has not started in NOT_STARTED_WAIT s has not)
                    if not concurrent or now - t0 > NOT_STARTED_WAIT:
                        return
        if idle < 0.0:
            idle = now
        if now - idle > SPIN_WAIT:  # no job for that long either: the owner may lack a core
            _nap(NAP_US)
        else:
            _pause()
    if statuses[w] != FOUND or not shortened[w] or statuses[0] == BLOCKED:
        return
    if prepared != w:
        both, order, later, keep = _prepared(out, n, w, resolution, max_deviation)
    N, L = both.shape[0], later.shape[0]
    c = _counters(n, w)
    e = _stamps(epoch, n, w)
    _scan_shared(
        both, order, 0, sync, c, SYNC_NEXT, SYNC_CHECKED, chunk, sc, e, not_free[w], keep, N,
    )  # fmt: skip
    if _atomic_add(sync, c + SYNC_BAD, 0) > 0:
        # the final check classifies the corners' stretches of the segments too (where each
        # segment collides, whether the corners may stay sharp): the thread that found a
        # state not FREE gets here, and any other still checking
        _scan_shared(
            later, np.arange(L), N, sync, c, SYNC_LATER_NEXT, SYNC_LATER_CHECKED, chunk, sc,
            e + N, not_free[w], keep, L,
        )  # fmt: skip


@njit(cache=True, inline="always")
def _prepared(out, n, i, resolution, max_deviation):  # type: ignore[no-untyped-def]
    """Search i's path as the final check classifies it (:func:`_final_batch`: its first
    batch, their rows, the corners' stretches) and whether its states' marks fit ``out``'s;
    the sizes set in its counters (the same in every thread)."""
    paths, lengths, _, _, _, _, _, sync, not_free, _, _ = out
    both, order, later = _final_batch(paths[i, : lengths[i]], resolution, max_deviation)
    c = _counters(n, i)
    sync[c + SYNC_STATES] = both.shape[0]
    sync[c + SYNC_LATER_STATES] = later.shape[0]
    return both, order, later, both.shape[0] + later.shape[0] <= not_free.shape[1]


@njit(cache=True, **SK.NRT_OFF)
def _scanned_class(sc, k):  # type: ignore[no-untyped-def]
    """The class :func:`SK.scan` gave state k of its last call on scanner ``sc``, where it
    stopped (the first state not FREE: HIT or UNSURE)."""
    _, work = SK._scanner_fields(sc)
    out = work[9]
    return out[k % out.shape[0]]


@njit(cache=True, inline="always")
def _scan_shared(
    qs, order, base, sync, c, counter, checked, chunk, sc, epoch, not_free, keep, most
):  # type: ignore[no-untyped-def]  # fmt: skip
    """:func:`_final_share`'s scan of ``qs``: at most ``most`` chunks of ``chunk`` states
    taken in turn from the shared counter ``sync[c + counter]``, each scanned whole (stamps
    ``epoch`` + the row): the states not FREE counted in ``sync[c + SYNC_BAD]`` and, if
    ``keep``, marked with their class (HIT or UNSURE) in ``not_free`` at ``base +
    order[row]``; the states checked counted in ``sync[c + checked]``. Returns how many
    chunks it took."""
    N = qs.shape[0]
    taken = 0
    while taken < most:
        c0 = _atomic_add(sync, c + counter, 1) * chunk
        if c0 >= N:
            break
        taken += 1
        c1 = min(N, c0 + chunk)
        s = c0
        while s < c1:
            k = SK.scan(qs[s:c1], c1 - s, sc, epoch + s)
            if s + k >= c1:
                break
            # state s + k is not FREE: noted with its class, and the scan goes on after it
            _atomic_add(sync, c + SYNC_BAD, 1)
            if keep:
                not_free[base + order[s + k]] = _scanned_class(sc, k)
            s += k + 1
        _atomic_add(sync, c + checked, c1 - c0)
    return taken


@njit(cache=True, inline="always")
def _edge_free(a, b, resolution, sc, epoch, buf, stats):  # type: ignore[no-untyped-def]
    """Whether the segment a → b (b included, a assumed free) is free, its states at most
    ``resolution`` apart per joint checked coarse to fine (:func:`_edge_states`), stopping
    at the first that is not FREE. Counts epochs and states in ``stats`` (2: epochs used,
    3: states checked). ``sc``: a :class:`SK.Scanner`."""
    qs, n = _edge_states(a, b, resolution, buf, True)
    k = SK.scan(qs, n, sc, epoch + stats[2])
    stats[2] += n
    stats[3] += min(k + 1, n)
    return k == n


# A search's board (_search_outputs' boards and board points): while its shortcut checks one
# segment, it offers the next one it would check if that one is not free to a thread that waits
# with nothing to check (_help), and takes that answer instead of checking the segment itself
# (:func:`_edge_free_ahead`). The path comes out as without the board: the same segments are
# checked, in the same order, only some on another thread. The job word is a job's number × 4
# and its state; the answer word the job's number << 32, its states checked << 1, and 1 if free.
B_JOB, B_ANSWER, B_LAST, B_OPEN = 0, 1, 2, 3
B_HELPED = 4  # the answers its shortcut took (a count, for tests and benchmarks)
BOARD = 16  # a board's row: 128 bytes, so that two searches' boards share no cache line
JOB_OPEN, JOB_HELPED, JOB_BACK = 0, 1, 2
# how long a shortcut waits for a helper's answer before it checks the segment itself (the
# helper's thread may have lost its core)
HELP_WAIT = 0.0002


@njit(cache=True)
def _edge_free_ahead(a, b, c, d, offer, resolution, sc, epoch, buf, stats, board, points):  # type: ignore[no-untyped-def]
    """:func:`_edge_free` of a → b; with ``offer``, the segment c → d (the caller's next if a → b
    is not free) first posted on ``board`` (``points``: its two buffers) for a helper. Returns
    (whether a → b is free, c → d's answer when a → b is not and a helper gave it: 1 free, 0
    not, −1 none; the states that check counted, as :func:`_edge_free` counts them)."""
    if not offer:
        return _edge_free(a, b, resolution, sc, epoch, buf, stats), -1, 0
    job = board[B_LAST] + 1
    board[B_LAST] = job
    k = job % 2
    for j in range(c.shape[0]):
        points[k, 0, j] = c[j]
        points[k, 1, j] = d[j]
    _atomic_store(board, B_JOB, job * 4 + JOB_OPEN)
    free = _edge_free(a, b, resolution, sc, epoch, buf, stats)
    w = job * 4
    if _atomic_cas(board, B_JOB, w + JOB_OPEN, w + JOB_BACK) == w + JOB_OPEN or free:
        return free, -1, 0  # not taken, or its answer not needed (it comes, and is ignored)
    t0 = _clock()
    while True:
        v = _atomic_load(board, B_ANSWER)
        if (v >> 32) == job:
            return free, v & 1, (v >> 1) & 0x7FFFFFFF
        if _clock() - t0 > HELP_WAIT:
            return free, -1, 0
        _pause()


@njit(cache=True)
def _help(boards, points, me, resolution, sc, epoch, buf, stats, seg):  # type: ignore[no-untyped-def]
    """For search ``me``'s thread while it waits with nothing to check: takes a segment another
    search's shortcut posted (:func:`_edge_free_ahead`), checks it on this thread's scanner
    ``sc`` (stamps from ``epoch`` + ``stats[2]``) and answers. ``seg`` (2, dof): room for the
    segment. Returns whether it took one."""
    for j in range(boards.shape[0]):
        if j == me:
            continue
        w = _atomic_load(boards[j], B_JOB)
        if w == 0 or w % 4 != JOB_OPEN:
            continue
        job = w // 4
        k = job % 2
        for i in range(seg.shape[1]):
            seg[0, i] = points[j, k, 0, i]
            seg[1, i] = points[j, k, 1, i]
        # taken while still posted: then the owner wrote no later job over the copy
        if _atomic_cas(boards[j], B_JOB, w, w + JOB_HELPED) != w:
            continue
        before = stats[3]
        free = _edge_free(seg[0], seg[1], resolution, sc, epoch, buf, stats)
        _atomic_store(boards[j], B_ANSWER, (job << 32) | ((stats[3] - before) << 1) | int(free))
        return True
    return False


@njit(cache=True)
def _others_open(boards, me):  # type: ignore[no-untyped-def]
    """Whether another search's shortcut takes help now (its board open)."""
    for j in range(boards.shape[0]):
        if j != me and _atomic_load(boards[j], B_OPEN) == 1:
            return True
    return False


@njit(cache=True)
def _skip_waypoints(path, resolution, sc, epoch, buf, stats, deadline, found, me, board, points):  # type: ignore[no-untyped-def]
    """From each kept waypoint, jump to the farthest one reachable in a straight line (until
    ``deadline``, or until search ``me`` lost: :func:`_lost`); the next nearer waypoint offered
    on ``board`` while one is checked (:func:`_edge_free_ahead`)."""
    n = path.shape[0]
    keep = np.empty(n, np.int64)
    keep[0] = 0
    m = 1
    i = 0
    offer = board[B_OPEN] == 1
    known_states = 0
    while i < n - 1:
        j = n - 1
        known = -1
        while j > i + 1:
            if _clock() > deadline or _lost(found, me):
                j = i + 1
                break
            if known >= 0:  # checked by a helper
                free = known == 1
                stats[3] += known_states
                board[B_HELPED] += 1
                known = -1
            else:
                free, known, known_states = _edge_free_ahead(
                    path[i], path[j], path[i], path[j - 1], offer and j - 1 > i + 1,
                    resolution, sc, epoch, buf, stats, board, points,
                )  # fmt: skip
            if free:
                break
            j -= 1
        keep[m] = j
        m += 1
        i = j
    return path[keep[:m]].copy()


TRY_CHECK, TRY_FAILS, TRY_END = 0, 1, 2  # _shortcut_try


@njit(cache=True)
def _shortcut_try(path, u1, u2, min_gain):  # type: ignore[no-untyped-def]
    """A random shortcut's segment on ``path``, between the points at the shares ``u1`` and
    ``u2`` of its length: (TRY_CHECK, its ends, the segments they lie on), or TRY_FAILS when
    they lie on one segment or it would shorten the stretch by less than the share
    ``min_gain`` (it fails unchecked), or TRY_END when the path has no length."""
    K = path.shape[0]
    cum = np.zeros(K)
    for s in range(1, K):
        cum[s] = cum[s - 1] + np.sqrt(np.sum((path[s] - path[s - 1]) ** 2))
    total = cum[K - 1]
    if total < 1e-9:
        return TRY_END, path[0], path[0], 0, 0
    s1 = u1 * total
    s2 = u2 * total
    if s1 > s2:
        s1, s2 = s2, s1
    i1 = min(np.searchsorted(cum, s1, side="right") - 1, K - 2)
    i2 = min(np.searchsorted(cum, s2, side="right") - 1, K - 2)
    if i1 == i2:
        return TRY_FAILS, path[0], path[0], i1, i2
    l1 = max(cum[i1 + 1] - cum[i1], 1e-12)
    l2 = max(cum[i2 + 1] - cum[i2], 1e-12)
    p1 = path[i1] + (path[i1 + 1] - path[i1]) * ((s1 - cum[i1]) / l1)
    p2 = path[i2] + (path[i2 + 1] - path[i2]) * ((s2 - cum[i2]) / l2)
    if np.sqrt(np.sum((p2 - p1) ** 2)) > (s2 - s1) - max(1e-6, min_gain * (s2 - s1)):
        return TRY_FAILS, p1, p2, i1, i2
    return TRY_CHECK, p1, p2, i1, i2


@njit(cache=True)
def shortcut(
    path,
    seed,
    deadline,
    resolution,
    scanners,
    epoch,
    max_tries,
    budget,
    slot,
    min_gain,
    found,
    me,
    board,
    points,
):  # type: ignore[no-untyped-def]
    """:func:`robocell.planning.rrt.shortcut` compiled: greedy waypoint skipping, random
    shortcuts between points on the path (at most ``max_tries``, until 12 fail in a row or
    ``budget`` states are checked; one that would shorten the stretch it replaces by less than
    the share ``min_gain`` is not checked, and fails), greedy again if they changed the path;
    repeated waypoints dropped. Checks on scratch slot ``slot`` (its scanner of ``scanners``).
    Returns the path and stats
    (2: epochs used, 3: states checked).

    It stops early, its path left as far as it got, once search ``me`` of a race lost
    (:func:`_lost`: ``found`` as :func:`rrt_connect` takes it; one entry and ``me`` 0 when
    there is no race): the winner's thread waited for it otherwise (session 36: 30 µs of a
    Panda table_pick plan's kernel call, median; the plans 3 % faster).

    ``board`` and ``points``: a board of :func:`_edge_free_ahead` (the search's, open while it
    shortcuts with another search's thread there to help; else closed: ``B_OPEN`` 0). Open, each
    check offers the next try's segment, drawn early on the path as it stands (a try's two
    draws do not depend on the try before). The answers are the same, so is the path."""
    np.random.seed(seed)  # noqa: NPY002 (numba's generator)
    dof = path.shape[1]
    stats = np.zeros(4, np.int64)
    buf = np.empty((SK.SCAN_STATES, dof))
    sc = scanners[slot]
    path = _skip_waypoints(
        path, resolution, sc, epoch, buf, stats, deadline, found, me, board, points
    )
    stop_at = stats[3] + budget
    fails = 0
    tries = 0
    changed = False
    offer = board[B_OPEN] == 1
    ahead = False  # the next try's draws taken
    u1_next, u2_next = 0.0, 0.0
    known = -1  # the next try's answer from a helper (see _edge_free_ahead)
    known_states = 0
    while path.shape[0] > 2 and tries < max_tries and fails < 12 and _clock() < deadline:
        if stats[3] >= stop_at or _lost(found, me):
            break
        tries += 1
        if ahead:
            u1, u2 = u1_next, u2_next
            ahead = False
        else:
            u1 = np.random.random()  # noqa: NPY002
            u2 = np.random.random()  # noqa: NPY002
        go, p1, p2, i1, i2 = _shortcut_try(path, u1, u2, min_gain)
        if go == TRY_END:
            break
        if go == TRY_FAILS:
            fails += 1
            continue
        if known >= 0:  # this segment, checked by a helper while the last try was
            free = known == 1
            stats[3] += known_states
            board[B_HELPED] += 1
            known = -1
        else:
            go_next, q1, q2 = TRY_FAILS, p1, p2
            if offer and tries < max_tries and fails + 1 < 12:
                u1_next = np.random.random()  # noqa: NPY002
                u2_next = np.random.random()  # noqa: NPY002
                ahead = True
                go_next, q1, q2, _, _ = _shortcut_try(path, u1_next, u2_next, min_gain)
            free, known, known_states = _edge_free_ahead(
                p1, p2, q1, q2, go_next == TRY_CHECK, resolution, sc, epoch, buf, stats, board,
                points,
            )  # fmt: skip
        if free:
            known = -1  # the next try is on the new path
            K = path.shape[0]
            new = np.empty((i1 + 1 + 2 + K - i2 - 1, dof))
            new[: i1 + 1] = path[: i1 + 1]
            new[i1 + 1] = p1
            new[i1 + 2] = p2
            new[i1 + 3 :] = path[i2 + 1 :]
            path = new
            fails = 0
            changed = True
        else:
            fails += 1
    if changed:  # else the first pass's result stands (a second would redo its checks)
        path = _skip_waypoints(
            path, resolution, sc, epoch, buf, stats, deadline, found, me, board, points
        )
    # repeated waypoints dropped (at least the two ends)
    keep = np.ones(path.shape[0], np.bool_)
    for s in range(1, path.shape[0]):
        keep[s] = np.sqrt(np.sum((path[s] - path[s - 1]) ** 2)) > 1e-9
    out = path[keep]
    if out.shape[0] < 2:
        out = np.empty((2, dof))
        out[0] = path[0]
        out[1] = path[path.shape[0] - 1]
    return out, stats


@njit(cache=True)
def detour(a, b, near, lower, upper, radii, seed, resolution, scanners, epoch):  # type: ignore[no-untyped-def]
    """A waypoint w near ``near``, one per radius of ``radii`` tried (uniform in the box of that
    half-width, within the limits), such that a → w → b is free at ``resolution`` (w checked
    alone first: most tries fail there; on scratch slot 0's scanner of ``scanners``). Returns
    (found, w, stats (2: epochs used, 3: states checked))."""
    np.random.seed(seed)  # noqa: NPY002 (numba's generator)
    dof = a.shape[0]
    stats = np.zeros(4, np.int64)
    buf = np.empty((SK.SCAN_STATES, dof))
    sc = scanners[0]
    w = np.empty(dof)
    for radius in radii:
        for j in range(dof):
            x = near[j] + (2.0 * np.random.random() - 1.0) * radius  # noqa: NPY002
            w[j] = min(max(x, lower[j]), upper[j])
        if (
            _edge_free(w, w, resolution, sc, epoch, buf, stats)
            and _edge_free(a, w, resolution, sc, epoch, buf, stats)
            and _edge_free(w, b, resolution, sc, epoch, buf, stats)
        ):
            return True, w, stats
    return False, w, stats


# The entry points called from Python, on a checker's SK.KernelInputs (one object to pass
# instead of the model's and the scratch's 69 arrays: see SK.KernelInputs).
@njit(cache=True, nogil=True)
def plan_in(
    start, goals, lower, upper, stream_bits, searches, deadline, resolution, step, inputs, epoch,
    cap, first_slot, box_margin, p_box, whole_for, side_by_side, shortcut_deadline,
    shortcut_tries, shortcut_share, shortcut_min, shortcut_min_gain, check_ends,
    final_resolution, max_deviation, final_chunk, omp, mend_radii,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """A plan's search in one call: the searches of
    :func:`robocell.planning.rrt.rrt_connect_compiled`, then (``shortcut_tries`` > 0) the
    winner's path shortened by :func:`shortcut` (until ``shortcut_deadline``, checking at
    most ``shortcut_share`` of the states the search checked and at least ``shortcut_min``;
    shortcuts that gain less than the share ``shortcut_min_gain`` not checked).

    The seeds come from the plan's stream (:class:`robocell.planning.rrt.Seeds`, its state
    ``stream_bits``: the uint64's bits as an int64, in and out; a numpy uint64 made in Python
    cost 20 µs of a plan on cold caches, measured), in the order the planner drew them in Python
    until session 39: one per search, then the shortcut's (if ``shortcut_tries`` > 0), then the
    detours' (if ``mend_radii``). Those draws, the list of seeds and its array took 18 µs of
    Python on a plan's cold caches (Panda table_pick after an ``ompl`` plan, measured); here
    they take nanoseconds.

    The searches (``searches`` of them): side by side on the kernel's threads
    (:func:`rrt_connect_many`) or one after the other (each later one stops once it has done
    more work than an earlier one that found a path, so that the same one wins), search i on
    scratch slot ``first_slot + i`` from stamp ``epoch + i·2**40``. Samples come from the box
    around the start and the goals grown by ``box_margin`` with probability ``p_box``; edges
    are added whole for the first ``whole_for`` iterations, then as far as free. Side by
    side, each search that finds a path shortcuts it at once on its own thread and slot
    (:func:`_search_one`); one after the other, the winner's path is shortcut once known, on
    the first search's slot. The shortcuts' stamps start at ``epoch + n·2**40`` (n searches),
    and the call needs no GIL.

    With ``check_ends``, the start and the goals are classified first, on the search's own
    code (:func:`SK.scan`, stamps from ``epoch + (n + 1)·2**40``), by the first search's
    thread while the others start (:func:`_search_one`): if one is not FREE, the call returns
    with status BLOCKED once the searches stopped, and the caller checks them itself (coal
    settles the unsure ones; the error names the colliding pair). Their checks in Python,
    before the call, took 36–54 µs of a plan (two kernel calls; 4–6 µs in this call, before
    the threads were launched, session 30; 16 µs there on a plan's cold caches, session
    39). Through the checker's batch classifier instead of ``scan`` (session 16), the first
    run's second process (planning.precompile) took 190 s instead of 144 to compile this
    kernel.

    With ``final_resolution`` > 0, side by side, the searches' threads then check the
    winner's shortcut path together as the final check classifies it first, in chunks of
    ``final_chunk`` states (:func:`_final_share`, stamps from ``epoch + (n + 2)·2**40``,
    search i's path from i/n of the way on; ``concurrent``: each search has a thread of its
    own); one after the other, the calling thread checks it so once it is shortcut. Where
    they found states not FREE, and none UNSURE, the calling thread then judges
    the path as the planner would, mending its colliding segments by detours (radii
    ``mend_radii``, none: not judged; seeded from the stream; stamps from ``epoch + (n +
    3)·2**40``): :func:`_judged`.

    Returns the stream's state after its draws and the detours' seed (the planner's own
    repair takes it when the path is not judged here), then the path (the winner's, or
    search 0's if none found one; mended if judged so), the search's status and stats
    (:func:`rrt_connect`), the states the shortcut checked, whether that check found every
    state FREE (then the final check's answer is FREE too), which states it found not FREE
    (their classes: ``validate_path``'s ``known``; empty if it did not check the path whole,
    or judged it), and :func:`_judged`'s verdict and corner deviation (JUDGED_NOT: the
    caller runs the final check proper, :func:`validate_path`, for where and why). With the
    final check proper in this call (session 16), on the checker's parallel classifier, this
    kernel took 220 s to compile instead of about 130, and the first run, which compiles it
    in a second process (planning.precompile), 250 s instead of 135 (measured); ``SK.scan``
    is the searches' own code. In session 30 the same scan after the race, in the calling thread
    alone, made plans slower: on two threads the final check took less."""
    scratch, scanners = inputs.scratch, inputs.scanners
    stream = np.uint64(stream_bits)
    dof = start.shape[0]
    n = searches
    seeds = np.empty(n, np.int64)
    for i in range(n):
        stream, seeds[i] = _next_seed(stream)
    shortcut_seed = np.int64(0)
    if shortcut_tries > 0:
        stream, shortcut_seed = _next_seed(stream)
    mend_seed = np.int64(0)
    if mend_radii.shape[0] > 0:
        stream, mend_seed = _next_seed(stream)
    # each search has a thread of its own (numba's OpenMP layer gives each iteration of a
    # loop of at most its thread count one; TBB's may run them one after the other): asked
    # here, as numba.get_num_threads took 25 µs in Python on a plan's cold caches (measured)
    concurrent = omp and _num_threads() >= n
    ends_epoch = epoch + ((n + 1) << 40) if check_ends else np.int64(-1)
    box_lo = np.empty(dof)
    box_hi = np.empty(dof)
    for j in range(dof):
        lo = start[j]
        hi = start[j]
        for g in range(goals.shape[0]):
            lo = min(lo, goals[g, j])
            hi = max(hi, goals[g, j])
        box_lo[j] = max(lower[j], lo - box_margin)
        box_hi[j] = min(upper[j], hi + box_margin)
    epochs = np.empty(n, np.int64)
    for i in range(n):
        epochs[i] = epoch + (i << 40)
    finish = (
        shortcut_seed, shortcut_deadline, shortcut_tries, shortcut_share, shortcut_min,
        epoch + (n << 40), shortcut_min_gain,
    )  # fmt: skip
    final_epoch = epoch + ((n + 2) << 40)
    final = (final_resolution, max_deviation, final_chunk, final_epoch, concurrent, True)
    if side_by_side:
        out = rrt_connect_many(
            start, goals, lower, upper, seeds, deadline, resolution, step, scratch, scanners,
            epochs, cap, first_slot, box_lo, box_hi, p_box, whole_for, finish, final, ends_epoch,
        )  # fmt: skip
    else:
        # one after the other, the shortcut once the winner is known (a search that found a
        # path may yet lose to a later one)
        finish = (
            shortcut_seed, shortcut_deadline, 0, shortcut_share, shortcut_min, 0, shortcut_min_gain
        )  # fmt: skip
        out = _search_outputs(n, cap, dof)
        for i in range(n):
            _search_one(
                np.int64(i), start, goals, lower, upper, seeds, deadline, resolution, step,
                scratch, scanners, epochs, cap, first_slot, box_lo, box_hi, p_box, whole_for,
                finish, (0.0, max_deviation, final_chunk, final_epoch, concurrent, False),
                ends_epoch, out,
            )  # fmt: skip
            if out[2][0] == BLOCKED:
                break
    paths, lengths, statuses, stats, found, shortened, shortcut_done, sync, not_free, _, _ = out
    if statuses[0] == BLOCKED:
        return (
            np.int64(stream), mend_seed, np.empty((0, dof)), BLOCKED, np.zeros(5, np.int64), 0,
            False,
            np.zeros(0, np.int8), JUDGED_NOT, max_deviation,
        )  # fmt: skip
    best = _best(statuses, found, n)
    path = paths[best, : lengths[best]].copy()
    shortcut_states = shortcut_done[best]
    if statuses[best] == FOUND and shortcut_tries > 0 and not shortened[best]:
        budget = max(shortcut_min, int(shortcut_share * stats[best, 3]))
        path, st = shortcut(
            path, shortcut_seed, shortcut_deadline, resolution, scanners, epoch + (n << 40),
            shortcut_tries, budget, first_slot, shortcut_min_gain, np.zeros(1, np.int64),
            np.int64(0), np.zeros(BOARD, np.int64), np.empty((2, 2, dof)),
        )  # fmt: skip
        shortcut_states = st[3]
        if final_resolution > 0 and path.shape[0] <= paths.shape[1]:
            # checked here as the searches' threads check it side by side (_final_share, by
            # the calling thread alone), on the searches' scan and in this call, and judged
            # and mended below; before, the planner's final check proper (validate_path)
            # classified it with its pairs' flags in a call of its own. Session 50, Panda
            # table sets beside a busy process (the planner then keeps to the calling
            # thread), medians 0.99–1.10 and 1.69–1.73 ms against 1.29–1.40 and 2.27–2.50
            paths[best, : path.shape[0]] = path
            lengths[best] = path.shape[0]
            shortened[best] = True
            _final_share(
                out, n, final_resolution, max_deviation, final_chunk, final_epoch, False,
                deadline, scanners, first_slot, best, resolution,
            )  # fmt: skip
    # the threads' check covered this path whole (_final_share): every state FREE, or which
    # were not, for the final check proper
    c = _counters(n, best)
    N, L = sync[c + SYNC_STATES], sync[c + SYNC_LATER_STATES]
    whole = shortened[best] and N > 0 and sync[c + SYNC_CHECKED] == N
    free = whole and sync[c + SYNC_BAD] == 0
    kept = whole and not free and N + L <= not_free.shape[1]
    whole_later = sync[c + SYNC_LATER_CHECKED] == L
    if kept and whole_later:
        N += L  # the corners' stretches too
    known = not_free[best, : N if kept else 0].copy()
    judged, dev = JUDGED_NOT, max_deviation
    if kept and whole_later and mend_radii.shape[0] > 0:
        judged, path, dev = _judged(
            path, known, final_resolution, max_deviation, lower, upper, mend_radii, mend_seed,
            scanners, epoch + ((n + 3) << 40),
        )  # fmt: skip
        if judged != JUDGED_NOT:
            known = known[:0]
    return (
        np.int64(stream), mend_seed, path, statuses[best], stats[best].copy(), shortcut_states,
        free, known,
        judged, dev,
    )  # fmt: skip


@njit(cache=True)
def shortcut_in(path, seed, deadline, resolution, inputs, epoch, max_tries, budget, min_gain):  # type: ignore[no-untyped-def]
    """:func:`shortcut` on a KernelInputs."""
    return shortcut(
        path, seed, deadline, resolution, inputs.scanners, epoch, max_tries, budget, np.int64(0),
        min_gain, np.zeros(1, np.int64), np.int64(0), np.zeros(BOARD, np.int64),
        np.empty((2, 2, path.shape[1])),
    )  # fmt: skip


@njit(cache=True)
def detour_in(a, b, near, lower, upper, radii, seed, resolution, inputs, epoch):  # type: ignore[no-untyped-def]
    """:func:`detour` on a KernelInputs."""
    return detour(a, b, near, lower, upper, radii, seed, resolution, inputs.scanners, epoch)


@njit(cache=True)
def segment_states(path, resolution):  # type: ignore[no-untyped-def]
    """The states of a path's straight segments, consecutive ones at most ``resolution``
    apart in every joint (the path's start first, on segment 0), and the index of the
    segment each lies on."""
    n_wp, dof = path.shape
    steps = np.empty(max(n_wp - 1, 0), np.int64)
    total = 1
    for k in range(n_wp - 1):
        d = 0.0
        for j in range(dof):
            d = max(d, abs(path[k + 1, j] - path[k, j]))
        steps[k] = max(1, int(math.ceil(d / resolution)))
        total += steps[k]
    states = np.empty((total, dof))
    segment = np.zeros(total, np.int64)
    states[0] = path[0]
    row = 1
    for k in range(n_wp - 1):
        n = steps[k]
        for i in range(1, n + 1):
            t = i / n
            for j in range(dof):
                states[row, j] = path[k, j] + t * (path[k + 1, j] - path[k, j])
            segment[row] = k
            row += 1
    return states, segment


@njit(cache=True, inline="always")
def _run_states(runs):  # type: ignore[no-untyped-def]
    """How many states the runs [s0, s1) of ``runs`` (R, 2) hold."""
    total = 0
    for r in range(runs.shape[0]):
        total += runs[r, 1] - runs[r, 0]
    return total


@njit(cache=True)
def _gathered(qs, runs, extra):  # type: ignore[no-untyped-def]
    """The states of ``qs`` in the runs [s0, s1) of ``runs`` (R, 2), in one array, with
    ``extra`` rows left after them."""
    batch = np.empty((_run_states(runs) + extra, qs.shape[1]))
    row = 0
    for r in range(runs.shape[0]):
        for s in range(runs[r, 0], runs[r, 1]):
            batch[row] = qs[s]
            row += 1
    return batch


@njit(cache=True)
def _classify_runs(qs, runs, cls, flags, model, scratch, epoch, chunk):  # type: ignore[no-untyped-def]
    """Classify the states of ``qs`` in the runs [s0, s1) of ``runs`` (R, 2), with the unsure
    pairs' flags, into ``cls`` and ``flags`` at their rows: gathered into one batch for the
    checker's own kernels (:func:`SK.classify_serial` for at most one chunk of states, else
    :func:`SK.classify` on the kernel's threads), stamped ``epoch`` + the batch's row.
    Returns how many states it classified (the caller's next epoch is ``epoch`` + that).

    The checker's kernels, not a copy of their loop over runs in place: a first run compiles
    them before any plan, and the copy (two more functions around the classifier, one of them
    parallel) took 61 s to compile in the main process, on the path of a first run's first
    plan (session 17, measured); gathering costs a microsecond."""
    batch = _gathered(qs, runs, 0)
    total = batch.shape[0]
    if total == 0:
        return total
    if total <= chunk:
        out, out_flags = SK.classify_serial(
            batch, model, scratch, epoch, np.bool_(True), np.bool_(False), np.int64(0)
        )
    else:
        out, out_flags = SK.classify(batch, model, scratch, epoch, np.bool_(True), chunk)
    row = 0
    for r in range(runs.shape[0]):
        for s in range(runs[r, 0], runs[r, 1]):
            cls[s] = out[row]
            if out[row] == SK.UNSURE:  # the flags of the others are all False
                flags[s] = out_flags[row]
            row += 1
    return total


@njit(cache=True)
def validate_path(path, resolution, max_deviation, check_segments, inputs, epoch, chunk, known):  # type: ignore[no-untyped-def]
    """The planner's final check of ``path`` (K, dof) as it will be executed, in one call
    (:func:`_final_check` on the kernel's threads). Before, the same steps in Python between
    two kernel calls cost 250–300 µs of a 600 µs check in a plan (cold caches after the
    search; UR5 table_pick, measured)."""
    return _final_check(
        path, resolution, max_deviation, check_segments, inputs.model, inputs.scratch, epoch,
        chunk, known,
    )  # fmt: skip


@njit(cache=True)
def _final_check(
    path, resolution, max_deviation, check_segments, model, scratch, epoch, chunk, known
):  # type: ignore[no-untyped-def]  # fmt: skip
    """The final check of ``path`` (K, dof) as it will be executed: its straight segments'
    states at ``resolution`` (if ``check_segments``) and the states of its corners rounded
    within ``max_deviation`` (if > 0), classified by the kernel with the unsure pairs flagged
    (:func:`_classify_runs`). Returns (segment states, their
    segment, classes, flags, arc states, classes, flags).

    The stretches of the segments that the rounded corners replace are classified only when
    needed: when a state elsewhere on the segments is not FREE (where each segment collides
    is then known whole, for a repair) or an arc's is not (the corners may have to stay
    sharp); otherwise they keep the class UNCHECKED, as the motion does not pass there.
    They were 16–20 % of a Panda's segment states and 9–11 % of a UR5's (MotionBenchMaker
    sets, session 15). The arcs' states are classified in one batch with the segments': two
    batches, one after the other, took 179 against 168 µs on the Panda's table_pick paths
    checked over and over, as long on table_under_pick's, and 0.39–0.41 against 0.34–0.36 ms
    in table_under_pick plans that follow an ``ompl`` plan (session 25). They are dropped when
    a segment state is a HIT, as the corners are then not rounded.

    ``known``: the states the searches' threads checked already, and which they found not
    FREE (:func:`_classify_first`): only those are classified again. In the Panda's table
    sets' plans that need a final check proper (a quarter to a third of them), that took its
    median from 270–369 to 148–150 µs with the first batch known, and to 64–94 µs with the
    corners' stretches known too; those plans' median from 987–1087 to 886–987 µs on
    table_pick, 1701–1732 to 1513–1645 on table_under_pick (session 33, each plan after an
    ``ompl`` plan, three runs of each version alternating)."""
    states, segment, arcs, off, on = _final_states(path, resolution, max_deviation, check_segments)
    dof = path.shape[1]
    P = model[25].shape[0] + model[26].shape[0]
    # the segments' states off the corners' stretches and the arcs' states, in one batch (one
    # round of the kernel's threads instead of two, which ended unevenly: 64 + 14 arc states)
    S = states.shape[0]
    A = arcs.shape[0]
    both = np.empty((S + A, dof))
    both[:S] = states
    both[S:] = arcs
    first = np.empty((off.shape[0] + 1, 2), np.int64)
    first[: off.shape[0]] = off
    first[off.shape[0], 0] = S
    first[off.shape[0], 1] = S + A
    cls_all = np.full(S + A, SK.UNCHECKED, np.int8)
    flags_all = np.zeros((S + A, P), np.bool_)
    n_first, on_done = _classify_first(
        both, first, on, cls_all, flags_all, model, scratch, epoch, chunk, known
    )  # fmt: skip
    cls, flags = cls_all[:S], flags_all[:S]
    arc_cls, arc_flags = cls_all[S:], flags_all[S:]
    free = True
    for i in range(S):
        if cls[i] != SK.FREE and cls[i] != SK.UNCHECKED:
            free = False
            break
    arcs_free = True
    for i in range(A):
        if arc_cls[i] != SK.FREE:
            arcs_free = False
            break
    if not (free and arcs_free) and not on_done:
        # where each segment collides, known whole (for a repair), or whether the corners
        # may stay sharp
        _classify_runs(both, on, cls_all, flags_all, model, scratch, epoch + n_first, chunk)
        for i in range(S):
            if cls[i] != SK.FREE and cls[i] != SK.UNCHECKED:
                free = False
                break
    for i in range(S):
        if cls[i] == SK.HIT:  # the corners are not rounded: their arcs do not matter
            arcs, arc_cls, arc_flags = arcs[:0], arc_cls[:0], arc_flags[:0]
            arcs_free = True
            break
    # what the caller need not look at: 0 when every state classified is FREE
    summary = (0 if free else 1) + (0 if arcs_free else 2)
    return states, segment, cls, flags, arcs, arc_cls, arc_flags, summary


@njit(cache=True)
def _classify_first(both, first, on, cls, flags, model, scratch, epoch, chunk, known):  # type: ignore[no-untyped-def]
    """:func:`_final_check`'s first batch (the states of ``both`` in the runs ``first``) into
    ``cls`` and ``flags``, and the states of the runs ``on`` where known. ``known``: which
    states the searches' threads found not FREE (their class; 0: FREE), one entry per state of the
    first batch in its order, then, if they checked them, per state of ``on``'s runs
    (empty: none checked). Those are classified again, for their class and unsure pairs;
    without ``known``, the whole first batch is classified. Returns how many states it
    classified, and whether ``on``'s states are classified too."""
    n_first = _run_states(first)
    n_on = _run_states(on)
    if known.shape[0] != n_first and known.shape[0] != n_first + n_on:
        return _classify_runs(both, first, cls, flags, model, scratch, epoch, chunk), False
    parts = 2 if known.shape[0] == n_first + n_on else 1
    again = np.empty((known.shape[0], 2), np.int64)
    m = 0
    i = 0
    for p in range(parts):
        part = first if p == 0 else on
        for r in range(part.shape[0]):
            for s in range(part[r, 0], part[r, 1]):
                if known[i] == 0:
                    cls[s] = SK.FREE
                else:
                    again[m, 0], again[m, 1] = s, s + 1
                    m += 1
                i += 1
    n = _classify_runs(both, again[:m].copy(), cls, flags, model, scratch, epoch, chunk)
    return n, parts == 2


@njit(cache=True)
def _final_states(path, resolution, max_deviation, check_segments):  # type: ignore[no-untyped-def]
    """What :func:`_final_check` classifies: the segment states at ``resolution`` (none if
    not ``check_segments``) and their segments, the states of the corners' arcs rounded
    within ``max_deviation``, and the runs [s0, s1) of segment states off the corners'
    stretches and on them."""
    dof = path.shape[1]
    # the waypoints without repeats (a repeated point has no direction), their corners'
    # arcs, and how far along each segment from each rounded waypoint its arc reaches
    keep = np.ones(path.shape[0], np.bool_)
    for k in range(1, path.shape[0]):
        d = 0.0
        for j in range(dof):
            d += (path[k, j] - path[k - 1, j]) ** 2
        keep[k] = math.sqrt(d) > 1e-9
    wp = path[keep]
    arcs = np.empty((0, dof))
    reach = np.zeros(path.shape[0])
    if max_deviation > 0 and wp.shape[0] > 2:
        u, _, waypoint, ell, centre, e1, radius, angle = TK.corner_arcs(wp, max_deviation, -1.0)
        arcs = TK.arc_points(u, waypoint, centre, e1, radius, angle, resolution)
        if wp.shape[0] == path.shape[0]:  # else every segment state is checked
            for c in range(waypoint.shape[0]):
                reach[waypoint[c]] = ell[c] * (1.0 - 1e-9)
    if check_segments:
        states, segment = segment_states(path, resolution)
    else:
        states, segment = np.empty((0, dof)), np.zeros(0, np.int64)
    # the segment states within a rounded corner's stretch (the start never is)
    corner = np.zeros(states.shape[0], np.bool_)
    row = 1
    for k in range(path.shape[0] - 1 if states.shape[0] > 0 else 0):
        n = 0
        while row + n < segment.shape[0] and segment[row + n] == k:
            n += 1
        if reach[k] > 0 or reach[k + 1] > 0:
            length = 0.0
            for j in range(dof):
                length += (path[k + 1, j] - path[k, j]) ** 2
            length = math.sqrt(length)
            for i in range(n):
                along = (i + 1) / n * length
                corner[row + i] = along < reach[k] or length - along < reach[k + 1]
        row += n
    # the runs of states off the corners' stretches, and on them
    runs = np.empty((2 * path.shape[0], 2), np.int64)
    n_runs = 0
    for s in range(states.shape[0]):
        if s > 0 and corner[s] == corner[s - 1]:
            runs[n_runs - 1, 1] = s + 1
        else:
            runs[n_runs, 0], runs[n_runs, 1] = s, s + 1
            n_runs += 1
    first_off = 0 if states.shape[0] == 0 or not corner[0] else 1
    off = runs[first_off:n_runs:2].copy()
    on = runs[1 - first_off : n_runs : 2].copy()
    return states, segment, arcs, off, on


@njit(cache=True)
def _final_batch(path, resolution, max_deviation):  # type: ignore[no-untyped-def]
    """The states :func:`_final_check` classifies first, in one array (all of them FREE:
    its answer is FREE): the segment states off the corners' stretches and the arcs',
    every 8th first, then the 4th, 2nd and 1st between them; the row of each in
    :func:`_final_check`'s order; and the states it classifies when one of those is not
    FREE (the segments' stretches at the corners), in its order. Until session 33 a scan
    stopped at the first state that was not FREE, and in this order it met an obstacle
    early (most stretches of a path through one span several states); scanned whole, in
    chunks of 32 on one thread, the states of 30 Panda plans' paths took 0.77 µs each
    against 0.79 in their order (table_pick; table_under_pick 0.75 against 0.78; session
    33, both alternating)."""
    states, _, arcs, off, on = _final_states(path, resolution, max_deviation, True)
    ordered = _gathered(states, off, arcs.shape[0])
    n = ordered.shape[0]
    ordered[n - arcs.shape[0] :] = arcs
    both = np.empty_like(ordered)
    order = np.empty(n, np.int64)
    row = 0
    for first in (0, 4, 2, 6, 1, 5, 3, 7):
        for i in range(first, n, 8):
            both[row] = ordered[i]
            order[row] = i
            row += 1
    return both, order, _gathered(states, on, 0)


@njit(cache=True)
def segment_hits(segment, hit):  # type: ignore[no-untyped-def]
    """Where each straight segment of a path collides, from its segment states (``segment``:
    the segment of each, in order, as :func:`segment_states` gives them; ``hit``: whether
    each collides): one row per segment with a colliding state, (segment, its first
    colliding state, the state before it, the state after its last colliding one or the
    segment's last state). The state before a segment's first is the previous segment's
    last: its start."""
    n = segment.shape[0]
    rows = np.empty((n, 4), np.int64)
    m = 0
    s = 0
    while s < n:
        k = segment[s]
        end = s
        while end + 1 < n and segment[end + 1] == k:
            end += 1
        first = -1
        last = -1
        for i in range(s, end + 1):
            if hit[i]:
                if first < 0:
                    first = i
                last = i
        if first >= 0:
            rows[m, 0] = k
            rows[m, 1] = first
            rows[m, 2] = first - 1
            rows[m, 3] = min(last + 1, end)
            m += 1
        s = end + 1
    return rows[:m].copy()


@njit(cache=True)
def _detoured(path, segments, near, lower, upper, radii, seed, resolution, scanners, epoch):  # type: ignore[no-untyped-def]
    """The path with its colliding segments mended by detours: segment ``segments[h]``
    (increasing) collides first at ``near[h, 0]``, between the free states ``near[h, 1]`` and
    ``near[h, 2]``; the stretch between those is replaced by a detour (:func:`detour`, seed
    ``seed`` + 2h), else the whole segment by one (seed + 2h + 1). Returns (whether every
    segment was mended, the mended path (the path if not), the first segment that was not or
    −1, the epochs used)."""
    n, dof = path.shape
    out = np.empty((n + 3 * segments.shape[0], dof))
    out[0] = path[0]
    m = 1
    h = 0
    used = 0
    for k in range(n - 1):
        b = path[k + 1]
        if h >= segments.shape[0] or segments[h] != k:
            out[m] = b
            m += 1
            continue
        mended = False
        for attempt in range(2):
            p0 = near[h, 1] if attempt == 0 else path[k]
            p1 = near[h, 2] if attempt == 0 else b
            found, via, st = detour(
                p0, p1, near[h, 0], lower, upper, radii, seed + 2 * h + attempt, resolution,
                scanners, epoch + used,
            )  # fmt: skip
            used += st[2]
            if found:
                # an end of the stretch may be a or b
                for p in (p0, via, p1, b):
                    same = True
                    for j in range(dof):
                        if p[j] != out[m - 1, j]:
                            same = False
                            break
                    if not same:
                        out[m] = p
                        m += 1
                mended = True
                break
        if not mended:
            return False, path, k, used
        h += 1
    return True, out[:m].copy(), -1, used


@njit(cache=True)
def repair_in(
    path, segments, near, lower, upper, radii, seed, resolution, max_deviation, inputs, epoch,
    chunk,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """The mending of a path's colliding segments and the check of the mended path's corners,
    in one call (the planner's first repair: ``Planner._repair`` does the same detours, then
    searches where they fail): :func:`_detoured`.

    Returns (whether every segment was mended, the mended path (the path if not), the first
    segment that was not or −1, the epochs used, and :func:`_final_check`'s outputs for the
    mended path's corners: its segments are free at ``resolution`` already, the states kept
    from the path checked before and the detours' by them)."""
    model, scratch = inputs.model, inputs.scratch
    ok, new, k, used = _detoured(
        path, segments, near, lower, upper, radii, seed, resolution, inputs.scanners, epoch
    )  # fmt: skip
    if not ok:
        checked = _final_check(
            path[:2], resolution, 0.0, False, model, scratch, epoch, chunk, np.zeros(0, np.int8)
        )  # fmt: skip
        return False, path, k, used, checked
    checked = _final_check(
        new, resolution, max_deviation, False, model, scratch, epoch + used, chunk,
        np.zeros(0, np.int8),
    )  # fmt: skip
    return True, new, -1, used, checked


@njit(cache=True, inline="always")
def _read_marks(runs, marks, i, hit):  # type: ignore[no-untyped-def]
    """The marks of the states in the runs [s0, s1) of ``runs``, read in order from
    ``marks[i]`` on: ``hit[s]`` set where a state is a HIT. Returns the next mark's index, or
    −1 at an UNSURE state (:func:`_judged` then leaves the path to the planner)."""
    for r in range(runs.shape[0]):
        for s in range(runs[r, 0], runs[r, 1]):
            if marks[i] == SK.UNSURE:
                return -1
            hit[s] = marks[i] == SK.HIT
            i += 1
    return i


# what _judged settled in the searches' kernel call (plan_in): nothing (the planner's final
# check proper decides), the path as it is, the path mended by detours, or the path mended
# with its corners left to the planner's check (a state of their arcs UNSURE)
JUDGED_NOT, JUDGED, JUDGED_MENDED, MENDED_CORNERS_OPEN = 0, 1, 2, 3


@njit(cache=True)
def _judged(path, marks, resolution, max_deviation, lower, upper, radii, seed, scanners, epoch):  # type: ignore[no-untyped-def]
    """The planner's judgement of a path the searches' threads checked whole and found not
    FREE throughout (``marks``: the class of each state the final check classifies, in its
    order: :func:`_final_share`), made in their kernel call when no state is UNSURE (coal
    would settle those, in Python): where segments collide, they are mended by detours
    (:func:`_detoured`, as ``Planner._mend`` does first) and the mended path's corners are
    checked; where only the corners' arcs collide, the corners stay sharp. Returns (one of
    JUDGED_*, the path (mended or not), the corners' deviation to execute it with).

    Until session 37 such a plan went back to Python for the final check proper and the
    repair, two kernel calls more on cold code: 15 of 50 Panda table_under_pick plans, whose
    median was 1.65 ms against 0.97 for the plans found free (their final check proper took
    110–240 µs, the repair 140–440). Session 38, both ways alternating in one process, each
    plan after an ``ompl`` plan (50 problems × 2–3), medians in ms: Panda table_under_pick
    2.09 → 1.76 and 1.78 → 1.56, table_pick 1.03 → 0.90 and 0.95 → 0.89, box 1.65 → 1.45;
    UR5 table_under_pick 2.28 → 2.10, table_pick 1.08 → 0.96; the same paths (mean lengths
    equal, as many repaired)."""
    states, segment, arcs, off, on = _final_states(path, resolution, max_deviation, True)
    A = arcs.shape[0]
    if marks.shape[0] != _run_states(off) + A + _run_states(on):
        return JUDGED_NOT, path, max_deviation
    # the marks: the segments' states off the corners' stretches, the arcs', then those on
    hit = np.zeros(states.shape[0], np.bool_)
    i = _read_marks(off, marks, 0, hit)
    if i < 0:
        return JUDGED_NOT, path, max_deviation
    arc_hit = False
    for a in range(i, i + A):
        if marks[a] == SK.UNSURE:
            return JUDGED_NOT, path, max_deviation
        arc_hit = arc_hit or marks[a] == SK.HIT
    if _read_marks(on, marks, i + A, hit) < 0:
        return JUDGED_NOT, path, max_deviation
    rows = segment_hits(segment, hit)
    if rows.shape[0] == 0:
        # the segments are free whole: the corners stay sharp where an arc collides
        return JUDGED, path, 0.0 if arc_hit else max_deviation
    near = np.empty((rows.shape[0], 3, path.shape[1]))
    for h in range(rows.shape[0]):
        for c in range(3):
            near[h, c] = states[rows[h, c + 1]]
    ok, new, _, used = _detoured(
        path, rows[:, 0].copy(), near, lower, upper, radii, seed, resolution, scanners, epoch,
    )  # fmt: skip
    if not ok:
        return JUDGED_NOT, path, max_deviation
    # the mended path's segments are free at the resolution: its corners decide
    _, _, arcs, _, _ = _final_states(new, resolution, max_deviation, False)
    A = arcs.shape[0]
    if A == 0:
        return JUDGED_MENDED, new, max_deviation
    sc = scanners[0]
    k = SK.scan(arcs, A, sc, epoch + used)
    if k == A:
        return JUDGED_MENDED, new, max_deviation
    if _scanned_class(sc, k) == SK.HIT:
        return JUDGED_MENDED, new, 0.0
    return MENDED_CORNERS_OPEN, new, max_deviation
