"""How many of the final check's states a state checked nearby could prove free, without a
check of their own: an estimate for a change not made yet (session 41).

    python benchmarks/bench_certify.py [--robot panda] [--sets table_pick,table_under_pick]
        [--limit 30]

A state the kernel finds FREE has margins: each body's bounding sphere is that far from every
obstacle, by the world's distance grid (as ``_kernels._world_clear`` bounds it), and the two
bounding spheres of each self pair without a table that far apart. Along the path, a body
moves at most Σ_j R_bj |Δq_j| and a pair's bodies relative to each other at most
Σ_j P_pj |Δq_j| (R, P: the continuous check's motion radii, ``robocell.scene.swept``). A later
state whose moves stay below every margin, and whose self pairs with a table have a FREE cell
there, is free: it needs no check. Here the final check's states (the segments' states off
the corners' stretches, then the arcs') are walked in order; a state that the last checked one
cannot prove free is checked (its margins computed, in Python, from the kernel's arrays), and
the table counts those checks. Paths: each problem's plan with the default settings.

Session 41, the first 30 problems: Panda table_pick 61 % of 8990 states checked (59 % per
plan, median), table_under_pick 67 % of 13772; the first 20: Panda box 84 %, bookshelf_small
65 %, cage 93 %; UR5 table_pick 30 %, table_under_pick 84 %. The bodies' world margins decide
almost every miss (on the Panda's table_pick: the hand, the fingers and links 5–7 near the
table); the self pairs few. Proving a state costs about 230 multiply-adds and five table
lookups, against 0.6–1.3 µs for a check: the Panda's final check on the table sets would take
about a third less (50–60 µs of a 0.6 ms table_pick plan). Tighter margins (a body's spheres a
level below its bounding sphere) and proofs from the checked state on either side would prove
more. Built in the kernel (branch ``s41-prove``), it proved 41 % but made the final check
slower: its margins cost about 0.25 µs a checked state (PLANNING.md, session 41).
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from numpy.typing import NDArray

from robocell.apps.bench_planning import default_mbm_dir, load_robot, set_problems
from robocell.kinematics._kernels import fk_into
from robocell.planning import JointGoal, MotionPlanRequest, Planner
from robocell.planning import _kernels as PK
from robocell.scene import _kernels as K
from robocell.scene.swept import SweptCheck

F = K.MODEL_FIELDS.index


class Margins:
    """The margins of a state, from a checker's kernel model (see the module's docstring)."""

    def __init__(self, model: tuple, n_links: int) -> None:  # type: ignore[type-arg]
        self.m = model
        self.T = np.zeros((n_links, 4, 4))
        world_pairs = model[F("world_pairs")]
        n_bodies = len(model[F("body_link")])
        bodies = np.unique(world_pairs[:, 0])
        self.world_bodies = bodies[bodies < n_bodies]  # robot bodies (cluster unions after)

    def q_full(self, qg: NDArray[np.float64]) -> NDArray[np.float64]:
        q = self.m[1].copy()
        q[self.m[0]] = qg
        return q

    def of(self, qg: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(per body: its world margin, inf if it has no world pair; per self pair: its
        bounding spheres' margin, NaN if a table decides it)."""
        m = self.m
        fk_into(self.q_full(qg), *m[2:12], self.T)
        body_link, body_T = m[F("body_link")], m[F("body_T")]
        body_root, nodes = m[F("body_root")], m[F("nodes")]
        centres = np.zeros((len(body_link), 3))
        radii = np.zeros(len(body_link))
        for b in range(len(body_link)):
            TB = self.T[body_link[b]] @ body_T[b]
            n = nodes[body_root[b]]
            centres[b] = TB[:3, :3] @ n[:3] + TB[:3, 3]
            radii[b] = n[3]
        frame, dims, values = m[F("world_frame")], m[F("world_dims")], m[F("world_values")]
        h = frame[3]
        body = np.full(len(body_link), np.inf)
        for b in self.world_bodies:
            x, y, z = centres[b]
            box = math.dist(
                (0, 0, 0),
                [max(frame[4 + a] - v, v - frame[7 + a], 0.0) for a, v in enumerate((x, y, z))],
            )
            ijk = [
                min(max(int((v - frame[a]) / h + 0.5), 0), dims[a] - 1)
                for a, v in enumerate((x, y, z))
            ]
            off = math.dist((x, y, z), [frame[a] + ijk[a] * h for a in range(3)])
            grid = float(values[(ijk[0] * dims[1] + ijk[1]) * dims[2] + ijk[2]]) - off
            body[b] = max(box, grid) - radii[b]
        pairs, pair_table = m[F("self_pairs")], m[F("pair_table")]
        pair = np.full(len(pairs), np.nan)
        for p, (a, b) in enumerate(pairs):
            if pair_table[p] >= 0:
                continue
            if a >= len(body_link) or b >= len(body_link):
                pair[p] = -1.0  # a cluster's union: not estimated, never proves
                continue
            pair[p] = np.linalg.norm(centres[a] - centres[b]) - radii[a] - radii[b]
        return body, pair

    def table_free(self, qg: NDArray[np.float64], p: int) -> bool:
        m = self.m
        ti = m[F("pair_table")][p]
        args = (m[F("table_vars")], m[F("table_n")], m[F("table_off")], m[F("table_values")])
        return bool(K._table_value(self.q_full(qg), ti, *args) == K.TABLE_FREE)


def checks_needed(
    states: NDArray[np.float64], margins: Margins, body_rate: NDArray[np.float64],
    pair_rate: NDArray[np.float64],
) -> int:  # fmt: skip
    """The states checked when each state the last checked one proves free is not."""
    checked = 0
    wb = margins.world_bodies
    q0 = body = pair = None
    for q in states:
        if q0 is not None:
            dq = np.abs(q - q0)
            ok = bool(np.all(body_rate[wb] @ dq < body[wb]))
            for p in range(len(pair) if ok else 0):
                free = (
                    margins.table_free(q, p) if np.isnan(pair[p]) else pair_rate[p] @ dq < pair[p]
                )
                if not free:
                    ok = False
                    break
            if ok:
                continue
        checked += 1
        q0 = q
        body, pair = margins.of(q)
    return checked


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robot", default="panda")
    ap.add_argument("--sets", default="table_pick,table_under_pick")
    ap.add_argument("--limit", type=int, default=30)
    args = ap.parse_args()
    mbm = default_mbm_dir()
    model = load_robot(mbm, args.robot)
    print(f"{'set':17} {'states':>7} {'checked':>8} {'share':>6} {'per plan':>9}")
    for set_name in args.sets.split(","):
        total = checked = 0
        shares = []
        for k, scene, req in set_problems(mbm, model, args.robot, set_name, args.limit):
            checker = scene.checker(model.group(req.group))
            request = MotionPlanRequest(
                req.group, JointGoal(req.goal), start=req.start, seed=k, time_parameterize=False
            )
            plan = Planner(scene).plan(request)
            swept = SweptCheck(checker)
            margins = Margins(checker.kernel_inputs()[0], model.tree.n_links)
            dev = plan.stats.get("corner_deviation", 0.05)
            states, _, arcs, off, _ = PK._final_states(plan.path, 0.01, dev, True)
            rows = np.concatenate([np.arange(a, b) for a, b in off]) if len(off) else []
            seq = np.concatenate([states[rows], arcs])
            n = checks_needed(seq, margins, swept.body_radii, swept.pair_radii)
            total += len(seq)
            checked += n
            shares.append(n / max(1, len(seq)))
        print(
            f"{set_name:17} {total:7} {checked:8} {checked / total:6.2f} "
            f"{float(np.median(shares)):9.2f}"
        )


if __name__ == "__main__":
    main()
