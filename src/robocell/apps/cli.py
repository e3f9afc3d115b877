"""The ``robocell`` command."""

from __future__ import annotations

import argparse
import sys

from robocell.errors import RobocellError

SETS = (
    "table_pick",
    "table_under_pick",
    "box",
    "bookshelf_small",
    "bookshelf_tall",
    "bookshelf_thin",
    "cage",
)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="robocell", description="robocell command line")
    sub = parser.add_subparsers(dest="command", metavar="command")
    sub.add_parser("info", help="list bundled robots and cells, and run a short self-check")
    demo = sub.add_parser("demo", help="sort the sorting cell's eight objects into their trays")
    demo.add_argument("--by", choices=["color", "shape"], default="color")
    demo.add_argument("--layout", type=int, default=0, help="0: the seed's; k > 0: randomized")
    demo.add_argument("--mode", choices=["physics", "kinematic"], default="physics")
    runp = sub.add_parser("run", help="run an exercise file (HAL or myalgorithm style) on a cell")
    runp.add_argument("file", help="the user's Python file")
    runp.add_argument("--cell", default="sorting", help="bundled cell name or cell file path")
    runp.add_argument("--layout", type=int, default=0, help="0: the seed's; k > 0: randomized")
    runp.add_argument("--mode", choices=["physics", "kinematic"], default="physics")
    runp.add_argument("--frequency", type=float, default=10.0, help="the loop's target [Hz]")
    runp.add_argument("--max-time", type=float, help="end the while-True loop after [s]")
    runp.add_argument("--iterations", type=int, help="end the while-True loop after N")
    runp.add_argument("--gui-dir", help="where GUI.showImage saves images")
    bench = sub.add_parser("bench", help="run a benchmark and print its table")
    bench_sub = bench.add_subparsers(dest="bench", metavar="benchmark")
    bp = bench_sub.add_parser("planning", help="MotionBenchMaker problems (../shared/bench/mbm)")
    bp.add_argument("--robots", default="ur5,panda", help="comma-separated: ur5, panda")
    bp.add_argument("--sets", default=",".join(SETS), help="comma-separated problem sets")
    bp.add_argument("--limit", type=int, default=50, help="problems per set (first N)")
    bp.add_argument("--timeout", type=float, default=1.0, help="planning time per problem [s]")
    bp.add_argument(
        "--baseline",
        default="",
        help="comma-separated, also plan with: ompl (OMPL's RRTConnect, states checked "
        "exactly by coal, as MoveIt with FCL), ompl-kernel (OMPL's RRTConnect on robocell's "
        "checker), ompl-moveit (as ompl, its path simplified by OMPL's simplifier, as MoveIt "
        "does)",
    )
    bp.add_argument("--json", help="write every problem's figures to this file")
    bp.add_argument("--mbm", help="folder holding ur5/ and panda/ (default: ../shared/bench/mbm)")
    bp.add_argument("--seed", type=int, default=0, help="problem k plans with seed + k")
    bp.add_argument(
        "--runs",
        type=int,
        default=1,
        help="plans per problem, each with a seed of its own (MoveIt benchmark's runs): "
        "medians over all of them",
    )
    bp.add_argument(
        "--continuous",
        action="store_true",
        help="every planner's path proven free by the continuous check (PlannerConfig)",
    )
    bp.add_argument(
        "--busy",
        type=int,
        default=0,
        help="other processes that each keep a core busy during the run (a shared machine)",
    )
    args = parser.parse_args(argv)
    try:
        if args.command in ("info", "demo", "run"):
            from robocell.planning import precompile

            # they plan: on a first run the planning kernels compile on the other core
            # meanwhile (nothing starts once they are in numba's cache)
            precompile.start()
        if args.command == "info":
            from robocell.apps.selfcheck import run_info

            return run_info()
        if args.command == "demo":
            from robocell.apps.demo import run_demo

            return run_demo(args.by, args.layout, args.mode)
        if args.command == "run":
            from pathlib import Path

            from robocell.exercise.runner import run_file

            return run_file(
                args.file, args.cell, args.layout, args.mode, args.frequency, args.max_time,
                args.iterations, Path(args.gui_dir) if args.gui_dir else None,
            ).exit_code  # fmt: skip
        if args.command == "bench" and args.bench == "planning":
            from robocell.apps.bench_planning import run

            return run(
                [r.strip() for r in args.robots.split(",") if r.strip()],
                [x.strip() for x in args.sets.split(",") if x.strip()],
                args.limit,
                args.timeout,
                [b.strip() for b in args.baseline.split(",") if b.strip()],
                args.json,
                args.mbm,
                args.seed,
                args.continuous,
                args.runs,
                args.busy,
            )
        parser.print_help()
        return 2
    except RobocellError as exc:
        print(f"robocell: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
