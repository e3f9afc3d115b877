"""The ``robocell`` command."""

from __future__ import annotations

import argparse
import sys

from robocell.errors import RobocellError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="robocell", description="robocell command line")
    sub = parser.add_subparsers(dest="command", metavar="command")
    sub.add_parser("info", help="list bundled robots and cells, and run a short self-check")
    args = parser.parse_args(argv)
    try:
        if args.command == "info":
            from robocell.apps.selfcheck import run_info

            return run_info()
        parser.print_help()
        return 2
    except RobocellError as exc:
        print(f"robocell: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
