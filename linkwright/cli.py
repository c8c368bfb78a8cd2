"""The ``linkwright`` command.

For now it offers ``--version``, ``--help`` and ``bench``; the study-file
subcommands (synth, stiffness, approx, analyze, demo) come with issue 7.
"""
from __future__ import annotations

import argparse
import sys

from . import __version__


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="linkwright",
        description="Design of spatial linkages: loop closure, dyad synthesis, stiffness of "
                    "parallel mechanisms, piecewise-linear acceleration analogs.")
    parser.add_argument("--version", action="version", version=f"linkwright {__version__}")
    sub = parser.add_subparsers(dest="command")
    b = sub.add_parser("bench", help="speed-against-error tables of the modules")
    b.add_argument("modules", nargs="*", help="modules to benchmark (default: all available)")
    b.add_argument("--quick", action="store_true", help="smaller problem sizes")
    args = parser.parse_args(argv)
    if args.command == "bench":
        from .bench import run
        return run(args.modules, quick=args.quick)
    parser.print_help()
    return 0


if __name__ == "__main__":
    sys.exit(main())
