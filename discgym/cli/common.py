"""What the commands share: exit codes, messages, number formatting, checked output paths,
the scene argument."""

from __future__ import annotations

import difflib
import importlib
import math
import os
import sys
from pathlib import Path

EXIT_OK = 0
EXIT_FAILED = 1  # something asked for could not be written
EXIT_USAGE = 2  # bad input: scene, arguments, missing optional dependency
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), outputs written

RENDER_EXTRA = 'pip install "discgym[render]"'
BENCH_EXTRA = 'pip install "discgym[bench]"'

CSV_HELP = """\
CSV columns (one row per sample, the first at the start of the run, the last where it stopped):
  time             simulated time (continues the checkpoint's clock after --resume)
  n_<species>      number of discs of each species, in scene order
  n_total          number of discs
  temperature      kT = kinetic energy per disc (k_B = 1)
  pressure         force per unit wall length, averaged over the interval ending at this
                   sample (nan in the first row)
  kinetic, internal, formation, total_energy
                   energies; total_energy = kinetic + internal + formation
  energy_input     energy added by controls since the simulation started
  dissipated       kinetic energy lost to restitution e < 1 since the start
  energy_balance   total_energy - (initial + energy_input - dissipated): 0 up to round-off
  collisions, wall_hits, reactive_collisions
                   event counters since the simulation started
  fired[<label>]   times each reaction fired since the start, e.g. fired[A + B -> C]
"""


class CLIError(Exception):
    """An error meant for the person at the terminal: printed without a traceback."""

    def __init__(self, message: str, code: int = EXIT_USAGE):
        super().__init__(message)
        self.code = code


# --------------------------------------------------------------------------------------------
# small helpers


def err(msg: str) -> None:
    print(f"discgym: error: {msg}", file=sys.stderr)


def note(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def say(msg: str) -> None:
    """Print to stdout; a closed pipe (``discgym run ... | head``) silences the rest of the
    output instead of stopping the command before it writes its files."""
    try:
        print(msg, flush=True)
    except BrokenPipeError:
        sys.stdout = open(os.devnull, "w")


def fmt(v: float, digits: int = 6) -> str:
    """A number for a table: integers as integers, others with ``digits`` significant digits."""
    if isinstance(v, int):
        return str(v)
    if not math.isfinite(v):
        return str(v)
    if v == 0:
        return "0"
    if 1e-3 <= abs(v) < 1e6:
        return f"{v:.{digits}g}"
    return f"{v:.3e}"


def _is_number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def table(rows, header=None) -> str:
    """Plain text columns: numbers right-aligned, text left-aligned."""
    body = [[str(c) for c in r] for r in rows]
    rows = ([[str(c) for c in header]] if header else []) + body
    if not rows:
        return ""
    ncol = max(len(r) for r in rows)
    rows = [r + [""] * (ncol - len(r)) for r in rows]
    body = rows[1:] if header else rows
    widths = [max(len(r[k]) for r in rows) for k in range(ncol)]
    right = [k > 0 and all(_is_number(r[k]) for r in body if r[k]) for k in range(ncol)]
    out = []
    for r in rows:
        cells = [r[k].rjust(widths[k]) if right[k] else r[k].ljust(widths[k])
                 for k in range(ncol)]
        out.append("  ".join(cells).rstrip())
    return "\n".join(out)


def need(module: str, what: str, install: str):
    """Import an optional dependency, or fail with the command that installs it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise CLIError(f"{what} needs {module.split('.')[0]}, which is not installed: "
                       f"{install}") from None


def writable(path: str, option: str) -> Path:
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise CLIError(f"{option} {path}: the directory {parent} does not exist")
    if p.is_dir():
        raise CLIError(f"{option} {path}: is a directory")
    return p


def parse_counts(text: str, species_names) -> dict:
    """``"A=200,B=100"`` -> ``{"A": 200, "B": 100}``, checked against the scene's species."""
    out = {}
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        name, eq, value = item.partition("=")
        name = name.strip()
        if not eq:
            raise CLIError(f"--n {text!r}: expected SPECIES=COUNT items separated by commas "
                           f"(e.g. {species_names[0]}=100), got {item!r}")
        if name not in species_names:
            raise CLIError(f"--n: unknown species {name!r}; this scene has "
                           f"{', '.join(species_names)}")
        try:
            c = int(value.strip())
        except ValueError:
            raise CLIError(f"--n: {name}={value.strip()!r} is not a whole number") from None
        if c < 0:
            raise CLIError(f"--n: {name}={c}: a count must be >= 0")
        out[name] = c
    if not out:
        raise CLIError(f"--n {text!r}: no counts given (e.g. {species_names[0]}=100)")
    return out


def load_scene(arg: str):
    """A built-in scene name or a TOML file path -> Scene (SceneError propagates)."""
    import discgym as dg

    names = dg.scenes.names()
    p = Path(arg)
    looks_like_file = arg.endswith(".toml") or os.sep in arg or "/" in arg
    if p.is_file() and (looks_like_file or arg not in names):
        return dg.Scene.from_toml(p)
    if arg in names:
        return dg.scenes.load(arg)
    if looks_like_file:
        raise CLIError(f"scene file {arg} not found")
    close = difflib.get_close_matches(arg, names, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    raise CLIError(f"unknown scene {arg!r}{hint}: not a built-in scene ({', '.join(names)}) "
                   "nor a TOML file; `discgym scenes` lists them")
