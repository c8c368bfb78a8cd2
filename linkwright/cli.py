"""The ``linkwright`` command: design studies from TOML files, reports, demo and benchmarks.

Study files are checked against the command's schema (:mod:`linkwright.schema`) before
anything runs; ``linkwright run FILE`` takes the command from ``[study].command``,
``linkwright schema CMD`` prints the reference and ``linkwright init CMD`` writes a starter.

Exit status: 0 success; 2 bad input (a study file: the message names the file and the key;
degenerate input such as a singular pose; or an output folder that cannot be made or
replaced, found before any computation); 1 a failure while running (numerical trouble such
as a singular matrix, or the disk: the message says what failed); 130 and 143 interrupted
by SIGINT and SIGTERM.  A run's outputs are committed as one set: written
into a temporary folder beside the output folder and swapped in at once, so the folder
holds either the previous set or the new one, never a mix.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
import time
import warnings
from pathlib import Path

from . import __version__
from .interrupt import catch_signals, reraise_caught

STUDY_COMMANDS = ("synth", "stiffness", "approx", "analyze")

QUIET_HELP = ("no progress messages or bars on stderr and no summary line on stdout "
              "(warnings and errors are still printed; --json still prints the summary). "
              "Progress is shown only when stderr is a terminal.")


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
    helps["run"] = "a study file of any kind: the command is read from its [study].command"
    helps["draw"] = ("an analyze, synth or stiffness study → 3D drawings (PNG) and an "
                     "offline animation (HTML) of its mechanism, variants or hexapod")
    for name, text in helps.items():
        s = sub.add_parser(name, help=text, description=text + ". The study file is checked "
                           "against the schema first (`linkwright schema " +
                           (name if name not in ("run", "draw") else "CMD") + "`): an unknown key, a wrong "
                           "type or a value out of range exits 2 naming the file and the key.")
        s.add_argument("study", help="the study file (TOML)")
        s.add_argument("-o", "--out", help="output folder (default: linkwright-out/<study>" +
                       ("-drawings)" if name == "draw" else ")"))
        s.add_argument("--quiet", action="store_true", help=QUIET_HELP)
        s.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    sc = sub.add_parser("schema", help="print the reference of a study kind: every key "
                                       "with its type, unit, default, meaning and example",
                        description="Print the study-file reference (Markdown) of one study "
                                    "kind, or of all with no argument; docs/study-files.md is "
                                    "the same text.")
    sc.add_argument("kind", nargs="?", choices=STUDY_COMMANDS, help="the study kind")
    it = sub.add_parser("init", help="write a commented starter study that runs as it is",
                        description="Write a commented starter study of one kind (every key "
                                    "explained, optional keys commented out). It refuses to "
                                    "overwrite a file.")
    it.add_argument("kind", choices=STUDY_COMMANDS, help="the study kind")
    it.add_argument("-o", "--out", help="the new file (default: KIND.toml; - for stdout)")
    g = sub.add_parser("grid", help="every case of a study's [grid] table, on Dask or "
                       "--serial → partitioned Parquet table",
                       description="Run every case of the [grid] table of a study file "
                       "(see docs/studies-on-dask.md) on a Dask cluster and write one table "
                       "as partitioned Parquet under OUT as cases finish.")
    g.add_argument("study", help="the study file (TOML) with a [grid] table")
    g.add_argument("-o", "--out", help="output folder (default: linkwright-out/<study>-grid)")
    g.add_argument("--scheduler", help="address of a running Dask scheduler "
                   "(tcp://HOST:PORT; default: $DASK_SCHEDULER_ADDRESS, else a local cluster)")
    g.add_argument("--workers", type=int, help="worker processes of the local cluster "
                   "(default: sized to the machine)")
    g.add_argument("--serial", action="store_true", help="run the partitions in this "
                   "process, without Dask")
    g.add_argument("--resume", action="store_true", help="keep the partitions already in "
                   "OUT and run only the missing ones")
    g.add_argument("--partition-size", type=int, help="cases per task (default: up to 16)")
    g.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    g.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    d = sub.add_parser("demo", help="run every shipped example study into an output folder")
    d.add_argument("-o", "--out", default="linkwright-demo", help="output folder")
    d.add_argument("--examples", help="folder of study files (default: the studies shipped "
                                      "with linkwright; see `linkwright examples`)")
    d.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    d.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    e = sub.add_parser("examples", help="list the shipped example studies, or copy them "
                                        "into a new folder with -o")
    e.add_argument("-o", "--out", help="copy the studies and example scripts into this new "
                                       "(or empty) folder")
    e.add_argument("--json", action="store_true")
    c = sub.add_parser("compile", help="compile the numba kernels now, one process per group, "
                       "so that later runs only load them",
                       description="Compile linkwright's numba kernels (solver, synthesis, "
                       "dynamics, stiffness, approx) and store them in numba's cache, each "
                       "group in its own process. The first use in a new installation "
                       "compiles anyway; this does it ahead of time and in parallel.")
    c.add_argument("--processes", type=int, help="worker processes (default: one per CPU)")
    c.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    c.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    b = sub.add_parser("bench", help="speed-against-error tables of all modules")
    b.add_argument("modules", nargs="*", help="closure, synthesis, stiffness, mechanism, approx, dynamics, engine, links, "
                   "families, complete, kernels, surrogate-dynamics (default: all)")
    b.add_argument("--quick", action="store_true", help="smaller problem sizes")
    b.add_argument("-o", "--out", help="also write the tables to OUT/bench.md")
    b.add_argument("--quiet", action="store_true", help="no progress bar on stderr (the "
                                                        "tables are still printed)")
    return p


def jsonable(value):
    """``value`` with every float that JSON cannot carry replaced: NaN → None (null),
    ±inf → ``"inf"`` / ``"-inf"``; numpy scalars and arrays → Python numbers and lists."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return jsonable(value.tolist())
    if isinstance(value, float):
        if math.isnan(value):
            return None
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return value
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, Path):
        return str(value)
    try:
        return jsonable(float(value))
    except (TypeError, ValueError):
        return str(value)


def main(argv: list[str] | None = None, *, _process: bool = False) -> int:
    """Run the ``linkwright`` command line; returns the exit status."""
    with catch_signals(restore=not _process):
        state: dict = {}
        try:
            args = _parser().parse_args(argv)
            if args.command is None:
                _parser().print_help()
                return 0
            return _dispatch(args, state)
        except KeyboardInterrupt as e:  # Interrupted (SIGINT, SIGTERM) or a bare Ctrl-C
            import signal
            for s in (signal.SIGINT, signal.SIGTERM):
                signal.signal(s, signal.SIG_IGN)
            name = getattr(e, "name", "SIGINT")
            out = state.get("out")
            if out is not None and out.committed:
                where = f"the outputs were written to {out.folder} before it"
            elif out is not None and out.folder.exists():
                where = f"nothing was written ({out.folder} is as it was)"
            else:
                where = "nothing was written"
            print(f"linkwright: interrupted by {name}; {where}", file=sys.stderr, flush=True)
            return getattr(e, "exit_code", 130)


def console() -> None:
    """The ``linkwright`` console script: :func:`main`, then exit with its status (signals
    that arrive once the outcome is decided are ignored)."""
    sys.exit(main(_process=True))


def _dispatch(args, state: dict) -> int:
    from .output import OutputFolderError, Outputs, OutputWriteError, Progress
    from .study import StudyError

    what = args.command + (f" {args.study}" if getattr(args, "study", None) else "")
    try:
        if args.command in STUDY_COMMANDS or args.command == "run":
            from .study import load_study
            study = load_study(args.study, None if args.command == "run" else args.command)
            out = state["out"] = Outputs(args.out or Path("linkwright-out") / Path(args.study).stem,
                                         study.command)
            out.check()
            with one_line_warnings(args.study):
                summary = _commands()[study.command](study, out, Progress(args.quiet))
            written = out.commit()
            summary["files"] = [str(p) for p in written]
            args.command = study.command
        elif args.command == "draw":
            from .cmd_draw import run as run_draw
            from .study import load_study
            study = load_study(args.study, None)
            out = state["out"] = Outputs(args.out or Path("linkwright-out") /
                                         (Path(args.study).stem + "-drawings"), "draw")
            out.check()
            with one_line_warnings(args.study):
                summary = run_draw(study, out, Progress(args.quiet))
            summary["files"] = [str(p) for p in out.commit()]
        elif args.command == "demo":
            from .cmd_demo import run_demo
            out = state["out"] = Outputs(args.out, "demo")
            out.check()
            with one_line_warnings("demo"):
                summary = run_demo(args.examples, out, _commands(), Progress(args.quiet))
            out.commit()
        elif args.command == "grid":
            from .cmd_grid import run_grid
            from .distributed import MissingExtraError
            try:
                with one_line_warnings(args.study):
                    summary = run_grid(args, Progress(args.quiet), state)
            except MissingExtraError as e:
                print(f"linkwright: error: {e}", file=sys.stderr)
                return 2
        elif args.command == "examples":
            return _examples(args, state)
        elif args.command == "schema":
            from .schema import reference, reference_markdown
            print(reference(args.kind, level=1) if args.kind else reference_markdown(), end="")
            return 0
        elif args.command == "init":
            return _init(args)
        elif args.command == "compile":
            from .warmup import compile_kernels
            t0 = time.perf_counter()
            try:
                table = compile_kernels(processes=args.processes)
            except ValueError as e:
                print(f"linkwright: error: --{e}", file=sys.stderr)
                return 2
            summary = {"seconds": time.perf_counter() - t0,
                       "groups": {r.group: {"seconds": r.seconds,
                                            "compile_seconds": r.compile_seconds}
                                  for r in table.itertuples()}}
            if not args.json and not args.quiet:
                print("\n".join(f"{r.group:<10} {r.seconds:6.1f} s ({r.compile_seconds:.1f} s "
                                "compiling)" for r in table.itertuples()))
                print(f"linkwright compile: {summary['seconds']:.1f} s in all")
                return 0
        else:
            return _bench(args, state)
    except (StudyError, OutputFolderError) as e:
        reraise_caught(e)
        print(f"linkwright: error: {e}", file=sys.stderr)
        return 2
    except OutputWriteError as e:
        reraise_caught(e)
        print(f"linkwright: failed: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # numerical failures (LinAlgError, ClosureError, solver trouble)
        reraise_caught(e)   # a failure that follows a signal is the interrupt's
        print(f"linkwright: failed: {what}: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps(jsonable(summary), indent=2, allow_nan=False))
    elif not args.quiet:
        print(f"linkwright {args.command}: " + summary_line(summary))
    return 0


def summary_line(summary: dict) -> str:
    """The summary as one line: quantities with their units (``kt_min = 2.027e+07 N/m``)."""
    from .render import fmt_num, fmt_q

    def show(v):
        if isinstance(v, dict) and set(v) == {"value", "unit"}:
            return "n/a" if v["value"] is None else fmt_q(v["value"], v["unit"])
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k}: {show(x)}" for k, x in v.items()) + "}"
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(show(x) for x in v) + "]"
        return "none" if v is None else fmt_num(v) if isinstance(v, float) else str(v)
    return ", ".join(f"{k} = {show(v)}" for k, v in summary.items()
                     if k not in ("command", "files", "results"))


@contextlib.contextmanager
def one_line_warnings(where):
    """Python warnings raised while a study runs, printed as one line each on stderr
    (``linkwright: warning: WHERE: message``), never with their source lines."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        try:
            yield
        finally:
            seen = set()
            for w in caught:
                text = " ".join(str(w.message).split())
                if text not in seen:
                    seen.add(text)
                    print(f"linkwright: warning: {where}: {text}", file=sys.stderr, flush=True)


def _init(args) -> int:
    from .atomic import write_new_file
    from .schema import starter
    text = starter(args.kind)
    if args.out == "-":
        print(text, end="")
        return 0
    path = Path(args.out or f"{args.kind}.toml")
    try:
        write_new_file(path, text.encode("utf-8"))
    except FileExistsError:
        print(f"linkwright: error: {path}: exists; linkwright init never overwrites a file: "
              "give another name with -o", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"linkwright: error: {path}: cannot write it: {e.strerror or e}",
              file=sys.stderr)
        return 2
    print(f"linkwright init: wrote {path}; edit it, then run: linkwright run {path}")
    return 0


def _examples(args, state: dict) -> int:
    from .cmd_examples import copy_examples, list_examples
    from .output import Outputs
    if args.out:
        out = state["out"] = Outputs(args.out, "examples", owned=False)
        out.check()
        summary = copy_examples(out)
        summary["files"] = [str(p) for p in out.commit()]
        if args.json:
            print(json.dumps(jsonable(summary), indent=2, allow_nan=False))
        else:
            print(f"linkwright examples: copied {len(summary['studies'])} studies to {out.folder}: "
                  f"{', '.join(summary['studies'])}")
        return 0
    rows = list_examples()
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    width = max(len(r["name"]) for r in rows)
    for r in rows:
        print(f"{r['name']:<{width}}  {r['command']:<9}  {r['title']}")
    print("\ncopy them out with: linkwright examples -o DIR  (then e.g. "
          "linkwright synth DIR/seed001_rrr.toml -o out/rrr)")
    return 0


def _bench(args, state: dict) -> int:
    from .bench import BENCHES, stream
    from .output import Outputs
    from .study import StudyError
    unknown = [m for m in args.modules if m not in BENCHES]
    if unknown:
        raise StudyError("bench", None, f"unknown module {unknown[0]!r}; expected one of "
                         f"{', '.join(BENCHES)}")
    out = None
    if args.out:
        out = state["out"] = Outputs(args.out, "bench")
        out.check()
    modules = list(args.modules or BENCHES)
    texts, failed = [], []
    from .output import Progress
    bar = Progress(getattr(args, "quiet", False)).bar(total=len(modules), desc="bench",
                                                      unit="module")
    bar.set_postfix_str(modules[0] if modules else "")
    for i, (name, text, error) in enumerate(stream(modules, args.quick)):
        bar.write(text)                      # above the bar (stdout), flushed
        bar.update(1)
        bar.set_postfix_str(modules[i + 1] if i + 1 < len(modules) else "")
        texts.append(text)
        if error is not None:
            reraise_caught(error)           # a module's failure that follows a signal
            failed.append(name)
            print(f"linkwright: bench {name} failed: {type(error).__name__}: {error}",
                  file=sys.stderr, flush=True)
    bar.close()
    if out is not None:
        out.add("bench.md", "\n".join(texts))
        out.commit()
    if failed:
        print(f"linkwright: bench: {len(failed)} of {len(modules)} modules failed: "
              f"{', '.join(failed)}", file=sys.stderr, flush=True)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
