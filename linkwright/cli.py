"""The ``linkwright`` command: design studies from TOML files, reports, demo and benchmarks.

Exit status: 0 success, 2 bad input (the message names the file and the key), 1 a
numerical failure, 130 interrupted.  Outputs are written only when a study has
run through, file by file with ``os.replace`` (never half-written).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from . import __version__
from .output import Outputs, Progress
from .study import Study, StudyError


def _commands():
    from . import cmd_analyze, cmd_approx, cmd_stiffness, cmd_synth
    return {"synth": cmd_synth.run, "stiffness": cmd_stiffness.run, "approx": cmd_approx.run,
            "analyze": cmd_analyze.run}


def _parser():
    p = argparse.ArgumentParser(
        prog="linkwright",
        description="Design of spatial linkages: dyad synthesis, stiffness reports, "
                    "piecewise-linear analogs and mechanism analysis from TOML study files.")
    p.add_argument("--version", action="version", version=f"linkwright {__version__}")
    sub = p.add_subparsers(dest="command")
    helps = {"synth": "positions (screws) → dyad variant table and ranked report",
             "stiffness": "hexapod geometry, pose, frame, load → stiffness report",
             "approx": "1-DOF mechanism or closed form → piecewise-linear analog tables",
             "analyze": "mechanism and input range → sweep table, point paths, drive forces"}
    for name, text in helps.items():
        s = sub.add_parser(name, help=text)
        s.add_argument("study", help="the study file (TOML)")
        s.add_argument("-o", "--out", help="output folder (default: linkwright-out/<study>)")
        s.add_argument("--quiet", action="store_true", help="no progress on stderr")
        s.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    d = sub.add_parser("demo", help="run every study in examples/ into an output folder")
    d.add_argument("-o", "--out", default="linkwright-demo", help="output folder")
    d.add_argument("--examples", help="folder of study files (default ./examples)")
    d.add_argument("--quiet", action="store_true")
    d.add_argument("--json", action="store_true")
    b = sub.add_parser("bench", help="speed-against-error tables of all modules")
    b.add_argument("modules", nargs="*", help="closure, synthesis, stiffness, approx, dynamics")
    b.add_argument("--quick", action="store_true", help="smaller problem sizes")
    b.add_argument("-o", "--out", help="also write the tables to OUT/bench.md")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command in ("synth", "stiffness", "approx", "analyze"):
            study = Study(args.study)
            out = Outputs(args.out or Path("linkwright-out") / Path(args.study).stem)
            summary = _commands()[args.command](study, out, Progress(args.quiet))
            written = out.commit()
            summary["files"] = [str(p) for p in written]
        elif args.command == "demo":
            from .cmd_demo import run_demo
            summary = run_demo(args.examples, args.out, _commands(), Progress(args.quiet))
        elif args.command == "bench":
            from .bench import BENCHES, tables
            unknown = [m for m in args.modules if m not in BENCHES]
            if unknown:
                raise StudyError("bench", None, f"unknown module {unknown[0]!r}; expected one of "
                                 f"{', '.join(BENCHES)}")
            text = tables(args.modules, args.quick)
            print(text)
            if args.out:
                o = Outputs(args.out)
                o.add("bench.md", text)
                o.commit()
            return 0
        else:
            _parser().print_help()
            return 0
    except (StudyError, ValueError, FileNotFoundError) as e:
        print(f"linkwright: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("linkwright: interrupted; nothing was written", file=sys.stderr)
        return 130
    except Exception as e:  # numerical failures (ClosureError, solver trouble)
        print(f"linkwright: failed: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    if getattr(args, "json", False):
        print(json.dumps(summary, indent=2, default=float))
    elif not getattr(args, "quiet", False):
        print(f"linkwright {args.command}: " + ", ".join(
            f"{k}={v}" for k, v in summary.items() if k not in ("command", "files")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
