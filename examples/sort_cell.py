"""Sort the sorting cell's eight objects into their trays, by colour or by shape.

For each object: grasp candidates from its shape and pose (from above when the wrist reaches
over it, else from the side); a box whose only pinch is out of reach is first turned by pushes
near one end (in physics); pick with the first grasp that works, then put it in its tray on a free
spot the arm reaches: set down on the floor, else released just above the walls, else released
from the cell's place point for that tray, as the seed exercise does.

    python examples/sort_cell.py [--by color|shape] [--layout K] [--mode physics|kinematic]
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from robocell.cell import Cell
from robocell.geometry import Box, Pose
from robocell.grasping import (
    Grasp,
    PlaceLocation,
    generate_grasps,
    generate_places,
    generate_pushes,
    reachable_places,
)
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
    note: str = ""  # why it is not in its tray: what went wrong at each attempt
    history: list[str] = field(default_factory=list)


def tray_of(cell: Cell, name: str, by: str) -> str:
    o = cell.spec.object(name)
    return f"{SHAPE_TRAY[o.kind] if by == 'shape' else o.color_name}_tray"


def place_candidates(
    hand: Manipulator, name: str, tray: str, grasp: Grasp, T_at_grasp: Pose, spots: int = 5
) -> list[PlaceLocation]:
    """Places in the tray on free spots (away from its walls and from what is already in it)
    that the arm reaches, farthest from the robot first and at least 5 cm apart, each at several
    yaws: first set down on the floor, then released just above the walls (a gripper holding
    an object from the side cannot go down between them). Farthest first: a tray at the edge
    of the arm's reach fills from its far reachable side, and the nearer spots stay free for
    the next objects (nearest first left a ball on top of the box before it, measured)."""
    cell = hand.cell
    o = cell.spec.object(name)
    top = cell.fixture_bounds(tray)[1][2]
    radius = 0.5 * math.hypot(o.size[0], o.size[1])
    free = cell.free_spots(tray, radius, near=cell.robot_spec.pose.position, clearance=0.02)
    out: list[PlaceLocation] = []
    for bottom in ("floor", "walls"):
        chosen: list[np.ndarray] = []
        for p in free[::-1]:
            if len(chosen) == spots:
                break
            if any(np.linalg.norm(p[:2] - c[:2]) < 0.05 for c in chosen):
                continue
            z = (p[2] if bottom == "floor" else top + 0.01) + 0.5 * o.size[2] + 0.005
            places = generate_places(
                name, (p[0], p[1], z), grasp, T_at_grasp, yaws_deg=tuple(range(0, 360, 45))
            )
            ok = reachable_places(places, cell.scene, hand.arm.get_name(), hand.geometry.eef_link)
            if ok:
                chosen.append(p)
                out += ok
    return [replace(loc, quality=1.0 - i / len(out)) for i, loc in enumerate(out)]


def sort(cell: Cell, by: str = "color", attempts: int = 3) -> list[Row]:
    """Sort every object into its tray; an object that is not in its tray after a pick and
    place (it slipped, dropped, rolled off) is picked again from where it lies, up to
    ``attempts`` times. An object no grasp reaches yet waits until the others are sorted
    (a neighbour nearer the robot can be what the arm would hit)."""
    hand = Manipulator(cell)
    rows = {
        o.name: Row(o.name, tray_of(cell, o.name, by), "-", 0.0, 0.0, False)
        for o in cell.spec.objects
    }
    queue = [o.name for o in cell.spec.objects]
    waited: set[str] = set()
    while queue:
        name = queue.pop(0)
        row = rows[name]
        for _ in range(attempts):
            note = sort_one(cell, hand, name, row.tray, row)
            row.in_tray = cell.inside(name, row.tray)  # at rest: the place step settled it
            if not row.in_tray:
                row.history.append(note or "place: not in its tray")
            row.note = "" if row.in_tray else " / ".join(row.history)
            if row.in_tray or note.startswith("pick: no grasp"):
                break
        if not row.in_tray and note.startswith("pick: no grasp") and queue and name not in waited:
            waited.add(name)
            queue.append(name)
    return list(rows.values())


def sort_one(cell: Cell, hand: Manipulator, name: str, tray: str, row: Row) -> str:
    """One pick and place of ``name`` into ``tray``; adds its times to ``row``; returns why it
    failed ("" if it did not)."""
    o = cell.spec.object(name)
    T = cell.object_pose(name)
    t0 = time.perf_counter()
    grasps = generate_grasps(name, o.shape, T, hand.geometry, cell.scene, "arm")
    row.planning_ms += (time.perf_counter() - t0) * 1e3
    turns, why = 0, ""
    while not grasps and isinstance(o.shape, Box) and cell.world is not None and turns < 4:
        # no pinch reaches it: its pinch faces the robot from too far. Turn it with pushes
        # near one end until one does
        t0 = time.perf_counter()
        pushes = generate_pushes(name, o.shape, T, hand.geometry, cell.scene, "arm")
        row.planning_ms += (time.perf_counter() - t0) * 1e3
        pushed = hand.push(name, pushes)
        row.planning_ms += pushed.planning_time * 1e3
        row.robot_s += pushed.robot_time
        if not pushed.success:
            why = f"; push: {pushed.reason}"
            break
        turns += 1
        T = cell.object_pose(name)
        t0 = time.perf_counter()
        grasps = generate_grasps(name, o.shape, T, hand.geometry, cell.scene, "arm")
        row.planning_ms += (time.perf_counter() - t0) * 1e3
    if not grasps:
        turned = f" ({turns} pushes turned it)" if turns else ""
        return f"pick: no grasp candidates for {name!r}{turned}{why}"
    picked = hand.pick(name, grasps)
    row.planning_ms += picked.planning_time * 1e3
    row.robot_s += picked.robot_time
    if not picked.success:
        return f"pick: {picked.reason}"
    grasp = next(g for g in grasps if g.id == picked.candidate)
    row.grasp = grasp.id.split("/", 1)[1]
    t0 = time.perf_counter()
    places = place_candidates(hand, name, tray, grasp, T)
    row.planning_ms += (time.perf_counter() - t0) * 1e3
    placed = hand.place(name, places, settle_tolerance=0.1)
    if not placed.success and name in cell.scene.attached_objects:
        # no spot in the tray worked: release where the seed does, the tool at the place
        # point, the object hanging below it
        target = cell.target_position(tray.replace("tray", "target"), frame="world")
        target[2] -= float(np.linalg.norm(hand.geometry.T_eef_tcp[:3, 3]))
        drop = generate_places(name, target, grasp, T, yaws_deg=tuple(range(0, 360, 45)))
        row.planning_ms += placed.planning_time * 1e3
        row.robot_s += placed.robot_time
        placed = hand.place(name, drop, settle_tolerance=0.12)
    row.planning_ms += placed.planning_time * 1e3
    row.robot_s += placed.robot_time
    if name in cell.scene.attached_objects:  # no place worked: let go, carry on
        hand.release(name)
    return "" if placed.success else f"place: {placed.reason}"


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
