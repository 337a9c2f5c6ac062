"""The ``discgym`` command line: list, inspect, run and picture scenes without writing Python.

::

    discgym scenes                          # the built-in scenes, one line each
    discgym show reactor                    # species, reactions, bounds
    discgym show reactor --toml my.toml     # an editable scene file to start from
    discgym run reactor --time 20 --plot r.png --gif r.gif --csv r.csv --save r.npz
    discgym run --resume r.npz --time 20    # continue, bit for bit
    discgym bench                           # the benchmark suite, quick mode
    discgym compile --all                   # compile every env's kernels ahead of first use

An adapter at the edge: it drives :class:`~discgym.Simulation` through its public API and
imports matplotlib / Pillow only when a picture is asked for. Errors meant for people (a bad
scene file, an unknown scene, a missing optional dependency) print one message and exit with
status 2; Ctrl-C during ``run`` stops at the next chunk of steps, writes everything asked for
and exits with status 130.
"""

from __future__ import annotations

import argparse
import os
import sys

from .common import (  # noqa: F401  (BENCH_EXTRA, EXIT_FAILED, RENDER_EXTRA: importable here)
    BENCH_EXTRA,
    CSV_HELP,
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
    RENDER_EXTRA,
    CLIError,
    err,
    note,
    parse_counts,
)
from .compile import SIMULATION, cmd_bench, cmd_compile  # noqa: F401
from .run import ADAPTIVE_ROWS, cmd_run, integrator_supported  # noqa: F401
from .scenes import cmd_scenes, cmd_show, scene_summary  # noqa: F401

__all__ = ["main", "CLIError", "parse_counts", "CSV_HELP"]


# --------------------------------------------------------------------------------------------
# the parser


def _int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    return v


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="discgym",
        description="Run, inspect and picture reactors of hard discs that react.",
        epilog="`discgym COMMAND --help` describes each command.",
    )
    parser.add_argument("--version", action="version", version=f"discgym {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("scenes", help="list the built-in scenes",
                       description="List the built-in scenes with a one-line description each.")
    p.set_defaults(func=cmd_scenes)

    _add_show(sub)
    _add_run(sub)
    _add_bench(sub)
    _add_compile(sub)
    return parser


def _add_show(sub) -> None:
    p = sub.add_parser(
        "show", help="print a scene's species, reactions and bounds",
        description="Print a scene's species, reactions, bounds and parameters; with --toml, "
                    "write it out as an editable TOML scene file to start from.")
    p.add_argument("scene", metavar="SCENE", help="a built-in scene name or a TOML file")
    p.add_argument("--toml", metavar="FILE",
                   help="write the scene as TOML to FILE ('-': to standard output only)")
    p.add_argument("--force", action="store_true", help="let --toml overwrite an existing file")
    p.set_defaults(func=cmd_show)


def _add_run(sub) -> None:
    p = sub.add_parser(
        "run", help="run a scene and report, plot, animate or save it",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Run a scene for --time units of simulated time with a progress bar, "
                    "then print a summary:\ncounts per species at the start and end, "
                    "temperature, pressure, collisions and reactions\nfired, and the energy "
                    "drift. Ctrl-C stops the run early and still writes every output\nasked "
                    "for (exit status 130).",
        epilog=CSV_HELP + "\nExamples:\n"
               "  discgym run reactor --time 20 --plot reactor.png --gif reactor.gif\n"
               "  discgym run my_scene.toml --time 50 --n A=200,B=100 --csv run.csv "
               "--save run.npz\n"
               "  discgym run --resume run.npz --time 50 --csv more.csv")
    p.add_argument("scene", metavar="SCENE_OR_TOML", nargs="?",
                   help="a built-in scene name or a TOML scene file (optional with --resume)")
    p.add_argument("--time", "-t", type=float, required=True, metavar="T",
                   help="simulated time to run (added to the clock of a resumed checkpoint)")
    p.add_argument("--seed", type=int, help="random seed (same seed, same run, bit for bit)")
    p.add_argument("--n", metavar="COUNTS",
                   help="initial counts, e.g. A=200,B=100; species not named keep the scene's "
                        "default count (give B=0 to leave one out)")
    p.add_argument("--temperature", type=float, metavar="kT",
                   help="initial temperature (default: the scene's)")
    p.add_argument("--integrator", choices=("step", "event"),
                   help="time-stepped (step) or event-driven (event, where this version "
                        "supports it); default: the Simulation's")
    p.add_argument("--every", type=float, metavar="DT",
                   help="sampling interval of the time series, rounded to whole steps of the "
                        "scene's dt (default: adaptive, 100-200 evenly spaced samples "
                        "wherever the run stops)")
    p.add_argument("--plot", metavar="FILE.png",
                   help="plot species counts, temperature, pressure and energies over time "
                        "(needs matplotlib)")
    movie = p.add_mutually_exclusive_group()
    movie.add_argument("--gif", metavar="FILE.gif",
                       help="animation of the discs (needs Pillow)")
    movie.add_argument("--mp4", metavar="FILE.mp4",
                       help="animation as MP4 video (needs imageio and imageio-ffmpeg)")
    p.add_argument("--frames", type=_int, default=100, metavar="N",
                   help="at most N animation frames, picked evenly from the samples "
                        "(default 100)")
    p.add_argument("--fps", type=float, default=15.0, help="animation frame rate (default 15)")
    p.add_argument("--size", type=_int, default=400, metavar="PX",
                   help="animation frame size in pixels (default 400)")
    p.add_argument("--csv", metavar="FILE", help="write the time series (columns below)")
    p.add_argument("--save", metavar="STATE",
                   help="write a checkpoint (.npz: arrays and JSON, no code; "
                        "discgym.checkpoint) at the end, or when stopped")
    p.add_argument("--resume", metavar="STATE",
                   help="continue a checkpoint written by --save (checked like "
                        "Simulation.set_state)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_run)


def _add_bench(sub) -> None:
    p = sub.add_parser(
        "bench", help="run the benchmark suite (quick mode) and print its tables",
        description="Run the benchmark suite (discgym.bench: scaling with N and threads, the "
                    "cost of each effect) in its quick mode and print its tables. Other "
                    "options are passed on to the suite, e.g. "
                    "`discgym bench --sections scaling --sizes 100,1000`; "
                    "`python -m discgym.bench --help` lists them. The comparison with pymunk "
                    "and the figures of docs/performance.md are the scripts in benchmarks/ "
                    "of the source repository.")
    p.add_argument("--full", action="store_true", help="the full suite instead of --quick "
                   "(many minutes)")
    p.set_defaults(func=cmd_bench, bench_args=[])


def _add_compile(sub) -> None:
    p = sub.add_parser(
        "compile", help="compile the envs' kernels ahead of their first use",
        description="Compile (or load from numba's cache) the kernels an env runs, so that "
                    "its first step does not wait minutes for them: for each env, its "
                    "single env and its vector env are built, reset and stepped once, on "
                    "each integrator. The environments share most kernels. Several "
                    "processes at once where there are several cores.")
    p.add_argument("--env", action="append", metavar="ID",
                   help="an env id of the suite (repeatable; default: DiscReactor-v0)")
    p.add_argument("--all", action="store_true",
                   help="every env of the suite, and the Simulation (`discgym run`)")
    p.add_argument("--integrator", choices=("step", "event"),
                   help="only this integrator (default: both)")
    p.add_argument("--jobs", "-j", type=_int, metavar="N",
                   help="processes at once (default: the number of cores)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compile)


def main(argv=None) -> int:
    """Entry point of the ``discgym`` console script and ``python -m discgym``: the exit
    status (0 ok, 1 an output could not be written, 2 bad input, 130 stopped by Ctrl-C)."""
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if extra and getattr(args, "command", None) != "bench":
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    if extra:
        args.bench_args = extra
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_OK
    from ..scene import SceneError

    try:
        return args.func(args)
    except CLIError as exc:
        err(str(exc))
        return exc.code
    except SceneError as exc:
        err(f"bad scene: {exc}")
        return EXIT_USAGE
    except KeyboardInterrupt:
        note("\ninterrupted")
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `discgym scenes | head`
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return EXIT_OK

