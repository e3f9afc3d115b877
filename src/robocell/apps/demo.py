"""``robocell demo``: the main job. Loads the sorting cell and sorts its eight objects into
their trays by running ``examples/sort_cell.py`` (the solution a user can copy), then prints a
table and a summary; the exit status is 0 only if every object ended in its tray."""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path
from types import ModuleType

from robocell.errors import RobocellError

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "sort_cell.py"
# shown until a demo has run to its end once with this cache (see scene.spheres.cache_root);
# from a fresh clone on 2 cores: 168 s (session 17), 221 s with the planning kernels compiled
# in this process too (planning.precompile; measured)
FIRST_RUN = (
    "first run: robocell compiles its kernels (numba) and builds the robots' collision models "
    "once, about 3 minutes on 2 cores; later runs start in a few seconds"
)


def load_example(path: Path = EXAMPLE) -> ModuleType:
    if not path.is_file():
        raise RobocellError(
            f"the example solution {path} is not there: robocell demo runs from a clone of the "
            "repository (pip install -e .)"
        )
    spec = importlib.util.spec_from_file_location("robocell_sort_cell_example", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while being defined
    spec.loader.exec_module(module)
    return module


def first_run_marker() -> Path:
    """A file in robocell's cache that says a demo has run to its end there."""
    from robocell.scene.spheres import cache_root

    return cache_root() / "demo-ran"


def run_demo(by: str = "color", layout: int = 0, mode: str = "physics") -> int:
    from robocell.cell import Cell
    from robocell.planning.rrt import warm_up

    example = load_example()
    t0 = time.perf_counter()
    print(f"robocell demo: sorting cell, layout {layout}, by {by}, {mode} mode", flush=True)
    ran = first_run_marker()
    if not ran.exists():
        print(FIRST_RUN, flush=True)
    cell = Cell.load("sorting", layout=layout, mode=mode, time_scale=0)
    # the compiled planner loaded (or compiled, on a first run) before the first pick, so
    # that the table's planning times are the plans' own: it took 1.3 s of the first
    # object's planning
    warm_up(cell.scene.checker("arm"))
    load_s = time.perf_counter() - t0
    rows = example.sort(cell, by)
    wall = time.perf_counter() - t0
    head = f"{'object':15} {'tray':12} {'grasp':12} {'planning ms':>11} {'robot s':>8}  result"
    print("\n" + head + "\n" + "-" * len(head))
    for r in rows:
        result = "in its tray" if r.in_tray else f"FAILED: {r.note}"
        print(
            f"{r.name:15} {r.tray:12} {r.grasp:12} {r.planning_ms:11.0f} {r.robot_s:8.2f}  {result}"
        )
    done = sum(r.in_tray for r in rows)
    robot = sum(r.robot_s for r in rows)
    print(
        f"\n{done}/{len(rows)} objects in their trays; {wall:.1f} s wall clock "
        f"(cell and planner loaded in {load_s:.1f} s), {robot:.1f} s of robot motion "
        f"({robot / max(len(rows), 1):.2f} s per object)"
    )
    try:
        ran.parent.mkdir(parents=True, exist_ok=True)
        ran.touch()
    except OSError:  # a read-only cache: the notice shows again next time, nothing worse
        pass
    return 0 if done == len(rows) else 1
