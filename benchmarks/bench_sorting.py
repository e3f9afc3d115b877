"""Sorting benchmark: the example solution (examples/sort_cell.py) over randomized layouts of the
sorting cell, headless physics, no grasp assist. Prints per layout the objects in their trays,
wall-clock and robot time, and lists every failure with its stage and reason.

    python benchmarks/bench_sorting.py [--layouts 200] [--by color] [--mode physics]
        [--continuous]
"""

from __future__ import annotations

import argparse
import statistics
import time

from robocell.apps.demo import load_example
from robocell.cell import Cell
from robocell.planning import PlannerConfig


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--layouts", type=int, default=200)
    ap.add_argument("--first", type=int, default=0, help="first layout (0 is the seed's)")
    ap.add_argument("--by", choices=["color", "shape"], default="color")
    ap.add_argument("--mode", choices=["physics", "kinematic"], default="physics")
    ap.add_argument(
        "--continuous", action="store_true", help="plan with PlannerConfig(continuous=True)"
    )
    args = ap.parse_args()
    config = PlannerConfig(continuous=args.continuous)
    example = load_example()
    total = ok = 0
    walls, per_object, planning = [], [], []
    failures = []
    print(f"{'layout':>6} {'in trays':>9} {'wall s':>7} {'robot s/object':>15}", flush=True)
    for k in range(args.first, args.first + args.layouts):
        t0 = time.perf_counter()
        cell = Cell.load("sorting", layout=k, mode=args.mode, time_scale=0, planner_config=config)
        rows = example.sort(cell, args.by)
        wall = time.perf_counter() - t0
        done = sum(r.in_tray for r in rows)
        total += len(rows)
        ok += done
        walls.append(wall)
        per_object += [r.robot_s for r in rows]
        planning += [r.planning_ms for r in rows]
        failures += [(k, r.name, r.note) for r in rows if not r.in_tray]
        robot = sum(r.robot_s for r in rows) / len(rows)
        print(f"{k:6d} {done:6d}/{len(rows)} {wall:7.1f} {robot:15.2f}", flush=True)
        for r in rows:
            if not r.in_tray:  # as they happen, so that a cut-short run still says why
                print(f"{'':6}   {r.name}: {r.note[:400]}", flush=True)
    print(
        f"\n{ok}/{total} objects in their trays ({100 * ok / max(total, 1):.1f} %) over "
        f"{args.layouts} layouts; wall per layout median {statistics.median(walls):.1f} s, "
        f"max {max(walls):.1f} s; robot time per object median "
        f"{statistics.median(per_object):.2f} s, max {max(per_object):.2f} s; planning per "
        f"object median {statistics.median(planning):.0f} ms"
    )
    if failures:
        print("\nfailures (layout, object, stage: reason):")
        for k, name, note in failures:
            print(f"  {k:4d} {name:15} {note[:400]}")


if __name__ == "__main__":
    main()
