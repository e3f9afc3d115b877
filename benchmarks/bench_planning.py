"""MotionBenchMaker planning benchmark (same as ``robocell bench planning``).

python benchmarks/bench_planning.py --robots ur5 --sets table_pick --limit 10 --baseline ompl
"""

import sys

from robocell.apps.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "planning", *sys.argv[1:]]))
