"""Sort the sorting cell's eight objects into their trays, by colour or by shape.

For each object: grasp candidates from its shape and pose (from above when the wrist reaches
over it, else from the side), pick with the first that works, then place it over its tray at
the cell's place point for that tray, lowered onto the tray's floor (or released from the place
point, as the seed exercise does, if the arm cannot reach that low there).

    python examples/sort_cell.py [--by color|shape] [--layout K] [--mode physics|kinematic]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

from robocell.cell import Cell
from robocell.grasping import generate_grasps, generate_places
from robocell.manipulation import Manipulator

SHAPE_TRAY = {"box": "red", "sphere": "blue", "cylinder": "green"}  # the spec's decision


@dataclass
class Row:
    name: str
    tray: str
    grasp: str
    planning_ms: float
    robot_s: float
    in_tray: bool
    note: str = ""


def tray_of(cell: Cell, name: str, by: str) -> str:
    o = cell.spec.object(name)
    return f"{SHAPE_TRAY[o.kind] if by == 'shape' else o.color_name}_tray"


def in_tray(cell: Cell, name: str, tray: str) -> bool:
    """At rest inside the tray's footprint, below its wall tops (the spec's success)."""
    f = next(x for x in cell.spec.fixtures if x.name == tray)
    p, c = cell.object_pose(name).position, f.pose.position
    return abs(p[0] - c[0]) < 0.14 and abs(p[1] - c[1]) < 0.14 and p[2] < c[2] + 0.1


def sort(cell: Cell, by: str = "color") -> list[Row]:
    hand = Manipulator(cell)
    rows = []
    for o in cell.spec.objects:
        tray = tray_of(cell, o.name, by)
        T = cell.object_pose(o.name)
        grasps = generate_grasps(o.name, o.shape, T, hand.geometry, cell.scene, "arm")
        picked = hand.pick(o.name, grasps)
        if not picked.success:
            rows.append(Row(o.name, tray, "-", picked.planning_time * 1e3, picked.robot_time,
                            False, f"pick: {picked.reason}"))  # fmt: skip
            continue
        grasp = next(g for g in grasps if g.id == picked.candidate)
        target = cell.target_position(tray.replace("tray", "target"), frame="world")
        floor = next(f for f in cell.spec.fixtures if f.name == tray).pose.position[2] + 0.01
        placed = None
        for z in (floor + 0.5 * o.size[2] + 0.005, target[2]):  # on the floor, else from above
            places = generate_places(o.name, [target[0], target[1], z], grasp, T,
                                     yaws_deg=tuple(range(0, 360, 45)))  # fmt: skip
            placed = hand.place(o.name, places, settle_tolerance=0.12)
            if placed.success or o.name not in cell.scene.attached_objects:
                break
        assert placed is not None
        if o.name in cell.scene.attached_objects:  # no place worked: let go, carry on
            hand.release(o.name)
        ok = in_tray(cell, o.name, tray)
        rows.append(
            Row(o.name, tray, grasp.id.split("/", 1)[1],
                (picked.planning_time + placed.planning_time) * 1e3,
                picked.robot_time + placed.robot_time, ok,
                "" if ok else f"place: {placed.reason or 'not in its tray'}")
        )  # fmt: skip
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--by", choices=["color", "shape"], default="color")
    ap.add_argument("--layout", type=int, default=0)
    ap.add_argument("--mode", choices=["physics", "kinematic"], default="physics")
    args = ap.parse_args()
    t0 = time.perf_counter()
    cell = Cell.load("sorting", layout=args.layout, mode=args.mode, time_scale=0)
    rows = sort(cell, args.by)
    for r in rows:
        print(f"{r.name:15} -> {r.tray:12} {'ok' if r.in_tray else 'FAILED'} {r.note}")
    done = sum(r.in_tray for r in rows)
    print(f"{done}/{len(rows)} in their trays in {time.perf_counter() - t0:.1f} s")
    return 0 if done == len(rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
