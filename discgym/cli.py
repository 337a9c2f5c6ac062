"""The ``discgym`` command line: list, inspect, run and picture scenes without writing Python.

::

    discgym scenes                          # the built-in scenes, one line each
    discgym show reactor                    # species, reactions, bounds
    discgym show reactor --toml my.toml     # an editable scene file to start from
    discgym run reactor --time 20 --plot r.png --gif r.gif --csv r.csv --save r.pkl
    discgym run --resume r.pkl --time 20    # continue, bit for bit
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
import csv
import difflib
import importlib
import inspect
import math
import os
import pickle
import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

__all__ = ["main", "CLIError", "parse_counts", "CSV_HELP"]

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


def _err(msg: str) -> None:
    print(f"discgym: error: {msg}", file=sys.stderr)


def _note(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _say(msg: str) -> None:
    """Print to stdout; a closed pipe (``discgym run ... | head``) silences the rest of the
    output instead of stopping the command before it writes its files."""
    try:
        print(msg, flush=True)
    except BrokenPipeError:
        sys.stdout = open(os.devnull, "w")


def _fmt(v: float, digits: int = 6) -> str:
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


def _table(rows, header=None) -> str:
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


def _need(module: str, what: str, install: str):
    """Import an optional dependency, or fail with the command that installs it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise CLIError(f"{what} needs {module.split('.')[0]}, which is not installed: "
                       f"{install}") from None


def _writable(path: str, option: str) -> Path:
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise CLIError(f"{option} {path}: the directory {parent} does not exist")
    if p.is_dir():
        raise CLIError(f"{option} {path}: is a directory")
    return p


def _atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write via a temporary file in the same directory, then rename: a crash or a second
    Ctrl-C never leaves a half-written checkpoint over a good one."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


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


def _load_scene(arg: str):
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


# --------------------------------------------------------------------------------------------
# discgym scenes / show


def cmd_scenes(args) -> int:
    import discgym as dg

    desc = dg.scenes.describe()
    print(_table([(n, d) for n, d in desc.items()]))
    print("\nInspect one with `discgym show NAME`; run one with "
          "`discgym run NAME --time 20 --plot out.png`.")
    return EXIT_OK


def _describe_bounds(b) -> str:
    if b.kind == "box":
        return (f"box {_fmt(b.width)} x {_fmt(b.height)} from ({_fmt(b.origin[0])}, "
                f"{_fmt(b.origin[1])}), area {_fmt(b.area)}")
    return (f"circle of radius {_fmt(b.radius)} around ({_fmt(b.center[0])}, "
            f"{_fmt(b.center[1])}), area {_fmt(b.area)}")


def _reaction_params(r) -> str:
    if r.kind in ("transformation", "decomposition"):
        return f"probability {_fmt(r.probability)} per unit time"
    s = f"activation energy {_fmt(r.activation_energy)}"
    if r.kind == "combination":
        s += f", reverse probability {_fmt(r.reverse_probability)} per unit time"
    return s


def scene_summary(scene) -> str:
    """A human-readable description of a scene (what ``discgym show`` prints)."""
    lines = []
    title = scene.name or "(unnamed scene)"
    lines.append(f"{title}: {scene.description}" if scene.description else title)
    lines.append("")
    lines.append(f"bounds       {_describe_bounds(scene.bounds)}")
    lines.append(f"dt {_fmt(scene.dt)}, temperature {_fmt(scene.temperature)}, restitution "
                 f"{_fmt(scene.restitution)}, internal relaxation "
                 f"{_fmt(scene.internal_relaxation)}, max displacement "
                 f"{_fmt(scene.max_displacement)}, collisions "
                 f"{'on' if scene.collisions else 'off'}")
    lines.append("")
    rows = [(s.name, _fmt(s.radius), _fmt(s.mass), _fmt(s.formation_energy),
             scene.counts.get(s.name, 0)) for s in scene.species]
    lines.append(_table(rows, header=("species", "radius", "mass", "formation energy",
                                      "default count")))
    area = sum(math.pi * s.radius ** 2 * scene.counts.get(s.name, 0) for s in scene.species)
    lines.append(f"packing fraction of the default counts: {area / scene.bounds.area:.3f}")
    lines.append("")
    if scene.reactions:
        lines.append("reactions")
        lines.append(_table([("  " + r.kind, r.label(), _reaction_params(r))
                             for r in scene.reactions]))
    else:
        lines.append("reactions    none")
    return "\n".join(lines)


def cmd_show(args) -> int:
    scene = _load_scene(args.scene)
    if args.toml == "-":
        sys.stdout.write(scene.to_toml())
        return EXIT_OK
    print(scene_summary(scene))
    if args.toml:
        p = _writable(args.toml, "--toml")
        if p.exists() and not args.force:
            raise CLIError(f"--toml {args.toml}: the file exists (it may hold your edits); "
                           "add --force to overwrite it")
        p.write_text(scene.to_toml())
        print(f"\nwrote {p}: edit it, then `discgym run {p} --time 20`")
    return EXIT_OK


# --------------------------------------------------------------------------------------------
# discgym bench


def cmd_bench(args) -> int:
    try:
        bench = importlib.import_module("discgym.bench")
    except ImportError as exc:
        missing = getattr(exc, "name", None) or ""
        if missing in ("discgym.bench", "discgym"):
            raise CLIError("the benchmark suite (discgym.bench) is not available in this "
                           "version of discgym") from None
        raise CLIError(f"the benchmark suite needs {missing or exc}, which is not installed: "
                       f"{BENCH_EXTRA}") from None
    argv = ([] if args.full else ["--quick"]) + list(args.bench_args)
    try:
        code = bench.main(argv)
    except ImportError as exc:
        raise CLIError(f"the benchmark suite needs {getattr(exc, 'name', None) or exc}, "
                       f"which is not installed: {BENCH_EXTRA}") from None
    return int(code or 0)


# --------------------------------------------------------------------------------------------
# discgym compile


def _env_ids() -> list:
    from .tasks import TASKS

    return list(TASKS)


#: the job warming a Simulation's kernels (the ``discgym run`` path), as an "env id"
SIMULATION = "Simulation"


def _warm(env_id: str, integrator: str) -> float:
    """Build ``env_id``'s env and its vector env of 2 reactors on ``integrator``, reset and
    step each once (numba compiles what they run, or loads it from its cache); or, for
    :data:`SIMULATION`, a Simulation of the reactor scene. The seconds taken. Run in a worker
    process of :func:`cmd_compile`."""
    import numpy as np

    t0 = time.perf_counter()
    if env_id == SIMULATION:
        from .simulation import Simulation

        Simulation("reactor", seed=0, integrator=integrator).step(2)
        return time.perf_counter() - t0
    from .tasks import TASKS

    env_cls, vec_cls = TASKS[env_id]
    env = env_cls(integrator=integrator)
    env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, env.action_space.dtype))
    env.close()
    venv = vec_cls(num_envs=2, integrator=integrator)  # (the parallel step over reactors)
    venv.reset(seed=0)
    venv.step(np.zeros((2,) + venv.single_action_space.shape, venv.single_action_space.dtype))
    venv.close()
    return time.perf_counter() - t0


def _warm_quietly(env_id: str, integrator: str) -> float:
    from .kernels import notice

    level = notice.LOGGER.level
    notice.LOGGER.setLevel("ERROR")  # (the command reports its own progress)
    try:
        return _warm(env_id, integrator)
    finally:
        notice.LOGGER.setLevel(level)


def cmd_compile(args) -> int:
    known = _env_ids()
    unknown = [e for e in args.env or () if e not in known]
    if unknown:
        raise CLIError(f"unknown env id{'s' if len(unknown) > 1 else ''} "
                       f"{', '.join(map(repr, unknown))} (known: {', '.join(known)})")
    if args.jobs is not None and args.jobs < 1:
        raise CLIError(f"--jobs: need at least 1, got {args.jobs}")
    ids = known + [SIMULATION] if args.all else list(dict.fromkeys(args.env or [known[0]]))
    integrators = [args.integrator] if args.integrator else ["step", "event"]
    todo = [(e, i) for e in ids for i in integrators]
    # The envs share their kernels: the first env of each integrator (and the Simulation)
    # compiles them, the others then mostly load them. So two waves: those first, at once,
    # then the rest (two processes compiling the same kernels would only race).
    heads = [(e, i) for e, i in todo if e in (ids[0], SIMULATION)]
    waves = [w for w in (heads, [j for j in todo if j not in heads]) if w]
    jobs = min(args.jobs or os.cpu_count() or 1, max(len(w) for w in waves))
    _note(f"compiling discgym's kernels for {len(todo)} configuration(s) in {jobs} "
          f"process(es); cached afterwards")
    bar = _JobBar(len(todo), quiet=args.quiet)
    t0 = time.perf_counter()
    if jobs == 1:
        for env_id, integrator in todo:
            bar.done(f"{env_id} {integrator}", _warm_quietly(env_id, integrator))
    else:
        import concurrent.futures as cf
        import multiprocessing

        from .kernels import helper

        # (the workers fill the CPUs and share their kernels through the cache's locks: no
        # compile helper of their own)
        os.environ[helper.ENV_VAR] = "0"

        # (spawned, not forked: a fresh interpreter each, whatever numba's threads have done)
        with cf.ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) \
                as pool:
            for wave in waves:
                futures = {pool.submit(_warm_quietly, e, i): f"{e} {i}" for e, i in wave}
                for f in cf.as_completed(futures):
                    bar.done(futures[f], f.result())
    bar.close()
    _say(f"compiled or loaded the kernels of {len(todo)} configuration(s) in "
         f"{time.perf_counter() - t0:.1f} s")
    return EXIT_OK


class _JobBar:
    """Jobs done out of the total on stderr: a tqdm bar when tqdm is installed, else one
    line per job."""

    def __init__(self, total: int, quiet: bool = False):
        self.total = total
        self.n = 0
        self.quiet = quiet
        self._bar = None
        if quiet:
            return
        try:
            from tqdm import tqdm
        except ImportError:
            return
        self._bar = tqdm(total=total, file=sys.stderr, unit="env", leave=True)

    def done(self, label: str, seconds: float) -> None:
        self.n += 1
        if self.quiet:
            return
        if self._bar is not None:
            self._bar.set_postfix_str(f"{label} {seconds:.0f} s", refresh=False)
            self._bar.update(1)
        else:
            _note(f"[{self.n}/{self.total}] {label}: {seconds:.1f} s")

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


# --------------------------------------------------------------------------------------------
# discgym run: progress bar


class _Progress:
    """Simulated time done out of the total, wall time and events per second, on stderr.

    Uses tqdm when it is installed, else a minimal bar of its own (redrawn in place on a
    terminal, one line per 10 % otherwise). ``enabled=False`` draws nothing."""

    def __init__(self, total: float, t0: float, enabled: bool = True, stream=None):
        self.total = max(float(total), 0.0)
        self.t0 = t0
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.wall0 = time.perf_counter()
        self._bar = None
        self._last_draw = 0.0
        self._last_decile = -1
        self._done = 0.0
        self._eps = math.nan
        if not enabled:
            return
        try:
            from tqdm import tqdm
        except ImportError:
            tqdm = None
        if tqdm is not None:
            self._bar = tqdm(total=self.total, file=self.stream, mininterval=0.2,
                             dynamic_ncols=True, leave=True,
                             bar_format="{l_bar}{bar}| t {n:.4g}/{total:.4g} "
                                        "[{elapsed}<{remaining}{postfix}]")

    def _line(self) -> str:
        frac = self._done / self.total if self.total > 0 else 1.0
        frac = min(max(frac, 0.0), 1.0)
        width = 24
        fill = int(round(frac * width))
        wall = time.perf_counter() - self.wall0
        return (f"[{'#' * fill}{'.' * (width - fill)}] {100 * frac:3.0f}%  "
                f"t {self.t0 + self._done:.4g}/{self.t0 + self.total:.4g}  "
                f"wall {wall:.1f}s  {self._rate()}")

    def _rate(self) -> str:
        return f"{self._eps:.3g} events/s" if math.isfinite(self._eps) else ""

    def update(self, done: float, events_per_s: float) -> None:
        if not self.enabled:
            return
        self._eps = events_per_s
        if abs(done - self.total) <= 1e-9 * max(self.total, 1.0):
            done = self.total  # the clock's round-off would show 99.9 %
        delta = done - self._done
        self._done = done
        if self._bar is not None:
            self._bar.set_postfix_str(self._rate(), refresh=False)
            self._bar.update(delta)
            return
        now = time.perf_counter()
        if self.stream.isatty():
            if now - self._last_draw >= 0.1:
                self._last_draw = now
                self.stream.write("\r" + self._line())
                self.stream.flush()
        else:
            dec = int(10 * done / self.total) if self.total > 0 else 10
            if dec > self._last_decile:
                self._last_decile = dec
                self.stream.write(self._line() + "\n")
                self.stream.flush()

    def close(self) -> None:
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.close()
            return
        if self.stream.isatty():
            self.stream.write("\r" + self._line() + "\n")
        elif self._last_decile < 10:
            self.stream.write(self._line() + "\n")
        self.stream.flush()


# --------------------------------------------------------------------------------------------
# discgym run: time series


#: rows kept by the adaptive sampling (no --every): between ADAPTIVE_ROWS / 2 and
#: ADAPTIVE_ROWS intervals, evenly spaced, whenever the run stops.
ADAPTIVE_ROWS = 200


class _Series:
    """The sampled time series of a run (column order as documented in :data:`CSV_HELP`),
    and the animation frames taken at some of its samples.

    ``adaptive``: the sampling interval starts at one step and doubles whenever the series
    reaches ``ADAPTIVE_ROWS`` intervals (every other row is dropped, and the pressure of the
    dropped interval merged into the next), so a run stopped at any time has an evenly
    spaced series of 100-200 intervals; frames are kept at the even rows. Otherwise a fixed
    interval, and a frame every ``frame_stride`` rows.
    """

    def __init__(self, sim, adaptive: bool, frame_stride: int = 1, render=None):
        self.species = list(sim.scene.species_names)
        self.labels = list(sim.reactions())
        self.columns = (["time"] + [f"n_{s}" for s in self.species] +
                        ["n_total", "temperature", "pressure", "kinetic", "internal",
                         "formation", "total_energy", "energy_input", "dissipated",
                         "energy_balance", "collisions", "wall_hits", "reactive_collisions"] +
                        [f"fired[{lab}]" for lab in self.labels])
        self._ip = self.columns.index("pressure")
        self.rows: list[list] = []
        self.spans: list[float] = []  # length of the interval each row's pressure covers
        self.images: list = []  # a frame or None, per row
        self.adaptive = adaptive
        self.frame_stride = max(int(frame_stride), 1)
        self.render = render  # sim -> image, or None for no frames

    def sample(self, sim, pressure: float, span: float) -> bool:
        """Add a row (and maybe a frame); True when the adaptive sampling just thinned the
        rows (the caller doubles its interval)."""
        c = sim.counts()
        cnt = sim.counters()
        fired = sim.reactions()
        ke, ui, fe = sim.kinetic_energy(), sim.internal_energy_total(), sim.formation_energy()
        self.rows.append(
            [float(sim.time)] + [c[s] for s in self.species] +
            [len(sim), sim.temperature(), pressure, ke, ui, fe, ke + ui + fe,
             float(sim.energy_input), float(sim.dissipated_energy), sim.energy_balance(),
             cnt["collisions"], cnt["wall_hits"], cnt["reactive_collisions"]] +
            [fired[lab] for lab in self.labels])
        self.spans.append(span)
        k = len(self.rows) - 1
        stride = 2 if self.adaptive else self.frame_stride
        self.images.append(self.render(sim) if self.render and k % stride == 0 else None)
        if self.adaptive and k >= ADAPTIVE_ROWS:
            self._thin()
            return True
        return False

    def _thin(self) -> None:
        """Keep rows 0, 2, 4, ...; a kept row's pressure becomes the mean over both halves."""
        rows, spans, ip = self.rows, self.spans, self._ip
        for k in range(2, len(rows), 2):
            s1, s2 = spans[k - 1], spans[k]
            if s1 + s2 > 0:
                p1 = rows[k - 1][ip] if s1 > 0 else 0.0
                p2 = rows[k][ip] if s2 > 0 else 0.0
                rows[k][ip] = (p1 * s1 + p2 * s2) / (s1 + s2)
            spans[k] = s1 + s2
        self.rows, self.spans = rows[::2], spans[::2]
        images = self.images[::2]
        self.images = [im if k % 2 == 0 else None for k, im in enumerate(images)]

    def frames(self, limit: int) -> list:
        """At most ``limit`` frames, evenly picked, the last one always included."""
        ims = [im for im in self.images if im is not None]
        if len(ims) <= limit:
            return ims
        pick = sorted({int(round(x)) for x in
                       [k * (len(ims) - 1) / (limit - 1) for k in range(limit)]}) \
            if limit > 1 else [len(ims) - 1]
        return [ims[k] for k in pick]

    def column(self, name: str) -> list:
        k = self.columns.index(name)
        return [r[k] for r in self.rows]

    def write_csv(self, path: Path) -> None:
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(self.columns)
            for r in self.rows:
                w.writerow([repr(v) if isinstance(v, float) else v for v in r])


def _write_plot(series: _Series, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = series.column("time")
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.5), sharex=True,
                             gridspec_kw={"height_ratios": [3, 2, 2]})
    _plot_counts(axes[0], series, t, title)
    _plot_temperature(axes[1], series, t)
    _plot_energies(axes[2], series, t)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plain_y(ax, *columns: list) -> None:
    """Label ``ax``'s y axis by plain values: no offset (a kT that round-off moves by 1e-12
    would otherwise be labelled ``1e-12+6e-1``), and a constant curve (to round-off) drawn in
    a band of +-5 % around its value rather than blown up to fill the axis."""
    ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    values = [v for c in columns for v in c if math.isfinite(v)]
    if not values:
        return
    lo, hi = min(values), max(values)
    mid = 0.5 * (lo + hi)
    if hi - lo <= 1e-9 * max(abs(mid), 1e-300):
        half = 0.05 * abs(mid) if mid != 0.0 else 1.0
        ax.set_ylim(mid - half, mid + half)


def _plot_counts(ax, series: _Series, t: list, title: str) -> None:
    from .render import species_colors

    colors = species_colors(len(series.species)) / 255.0
    for k, (s, col) in enumerate(zip(series.species, colors)):
        # widths alternate so that equal curves (A and B of A + B -> C) both stay visible
        ax.plot(t, series.column(f"n_{s}"), color=col, lw=2.6 if k % 2 == 0 else 1.2,
                label=s)
    ax.set_ylabel("discs")
    ax.set_title(title)
    ax.legend(loc="best", fontsize=9, ncol=min(len(series.species), 4))
    ax.grid(alpha=0.3)


def _plot_temperature(ax, series: _Series, t: list) -> None:
    """Temperature, and the interval-mean pressure on a second axis."""
    ax.plot(t, series.column("temperature"), color="tab:red", lw=1.4, label="temperature kT")
    p = series.column("pressure")
    if len(t) > 1:
        ax2 = ax.twinx()
        ax2.step(t[1:], p[1:], where="pre", color="tab:gray", lw=1.0, alpha=0.8,
                 label="pressure (interval mean)")
        ax2.set_ylabel("pressure", color="tab:gray")
        _plain_y(ax2, p[1:])
        ax2.tick_params(axis="y", colors="tab:gray")
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, loc="best", fontsize=9)
    else:
        ax.legend(loc="best", fontsize=9)
    ax.set_ylabel("kT")
    _plain_y(ax, series.column("temperature"))
    ax.grid(alpha=0.3)


def _plot_energies(ax, series: _Series, t: list) -> None:
    for name, lab, col in (("kinetic", "kinetic", "tab:red"),
                           ("internal", "internal", "tab:orange"),
                           ("formation", "formation", "tab:purple"),
                           ("total_energy", "total", "black")):
        ax.plot(t, series.column(name), color=col, lw=1.4, label=lab)
    bal = series.column("energy_balance")
    worst = max(abs(b) for b in bal) if bal else 0.0
    ax.plot([], [], " ", label=f"max |energy balance| {worst:.2g}")
    ax.set_ylabel("energy")
    _plain_y(ax, *(series.column(n) for n in ("kinetic", "internal", "formation",
                                               "total_energy")))
    ax.set_xlabel("simulated time")
    ax.legend(loc="best", fontsize=9, ncol=2)
    ax.grid(alpha=0.3)


def _write_movie(frames, path: Path, fps: float, kind: str) -> None:
    if kind == "gif":
        from PIL import Image

        images = [Image.fromarray(f) for f in frames]
        images[0].save(path, save_all=True, append_images=images[1:],
                       duration=max(int(round(1000.0 / fps)), 20), loop=0)
    else:
        import imageio.v2 as imageio
        import numpy as np

        with imageio.get_writer(path, fps=fps, codec="libx264", quality=7,
                                macro_block_size=2) as w:
            for f in frames:  # H.264 (yuv420p) needs even sizes: repeat the last row/column
                w.append_data(np.pad(f, ((0, f.shape[0] % 2), (0, f.shape[1] % 2), (0, 0)),
                                     mode="edge"))


# --------------------------------------------------------------------------------------------
# discgym run


def _integrator_supported() -> bool:
    import discgym as dg

    try:
        return "integrator" in inspect.signature(dg.Simulation).parameters
    except (TypeError, ValueError):
        return False


def _build_simulation(args):
    """-> (sim, label). A new simulation from the scene, or one resumed from a checkpoint."""
    return _resume(args) if args.resume else _new_simulation(args)


def _resume(args):
    """-> (sim, label): the checkpoint of ``--resume``, checked against the other options."""
    import discgym as dg

    for opt, val in (("--n", args.n), ("--seed", args.seed),
                     ("--temperature", args.temperature)):
        if val is not None:
            raise CLIError(f"{opt} cannot be used with --resume: the checkpoint carries "
                           "the discs, their velocities and the random state")
    p = Path(args.resume)
    if not p.is_file():
        raise CLIError(f"--resume {args.resume}: no such file")
    try:
        with open(p, "rb") as f:
            sim = pickle.load(f)
    except Exception as exc:  # any unpickling failure is a bad checkpoint
        raise CLIError(f"--resume {args.resume}: not a discgym checkpoint "
                       f"({type(exc).__name__}: {exc})") from None
    if not isinstance(sim, dg.Simulation):
        raise CLIError(f"--resume {args.resume}: not a discgym checkpoint (it holds a "
                       f"{type(sim).__name__})")
    used = getattr(sim, "integrator", "step")
    if args.integrator is not None and args.integrator != used:
        raise CLIError(f"--integrator {args.integrator}: the checkpoint {args.resume} runs "
                       f"the {used!r} integrator; leave out --integrator to continue it")
    if args.scene is not None:
        scene = _load_scene(args.scene)
        if scene != sim.scene:
            raise CLIError(f"--resume {args.resume}: the checkpoint holds the scene "
                           f"{sim.scene.name or '(unnamed)'!r}, which differs from "
                           f"{args.scene}; leave out the scene to continue the checkpoint")
    return sim, f"{sim.scene.name or 'scene'} (resumed from {p.name})"


def _new_simulation(args):
    """-> (sim, label): a new simulation of the scene with ``--n``, ``--temperature``,
    ``--seed`` and ``--integrator``."""
    import discgym as dg

    if args.scene is None:
        raise CLIError("run: give a scene (a built-in name or a TOML file) or --resume STATE")
    scene = _load_scene(args.scene)
    counts = None
    if args.n is not None:
        counts = dict(scene.counts)
        counts.update(parse_counts(args.n, scene.species_names))
    kw = {}
    if args.integrator is not None:
        if _integrator_supported():
            kw["integrator"] = args.integrator
        elif args.integrator != "step":
            raise CLIError(f"--integrator {args.integrator} is not available in this version "
                           "of discgym (its Simulation has only the time-stepped integrator); "
                           "use --integrator step")
    try:
        sim = dg.Simulation(scene, counts=counts, temperature=args.temperature, seed=args.seed,
                            **kw)
    except dg.SceneError:
        raise
    except ValueError as exc:  # PlacementError, bad temperature, bad integrator name
        raise CLIError(str(exc)) from None
    return sim, scene.name or Path(args.scene).stem


class _Stop:
    """Ctrl-C during the run: the first sets a flag (the loop stops at its next check, then
    writes the outputs); a second one interrupts at once."""

    def __init__(self):
        self.requested = False
        self._old = None

    def _handler(self, signum, frame):
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        _note("\nCtrl-C: stopping after the current chunk of steps (Ctrl-C again to abort "
              "without writing anything)")

    def __enter__(self):
        try:
            self._old = signal.signal(signal.SIGINT, self._handler)
        except ValueError:  # not the main thread: KeyboardInterrupt is caught instead
            self._old = None
        return self

    def __exit__(self, *exc):
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
        return False


def _events(sim) -> int:
    """Collisions + wall hits + reactions fired since the simulation started."""
    c = sim.counters()
    return c["collisions"] + c["wall_hits"] + sum(sim.reactions().values())


class _Clock:
    """Wall time of a run, and the simulator's speed: events and simulated time per second
    spent in ``sim.advance`` (sampling, pictures and the progress bar left out), after the
    first chunk (one step), whose wall time is mostly numba loading (or compiling) the
    kernels."""

    def __init__(self):
        self.wall0 = time.perf_counter()
        self.first_wall = None  # wall time of the first chunk
        self.first = None  # (events, simulated time) at the end of the first chunk
        self.busy = 0.0  # seconds in advance() after the first chunk

    def advanced(self, sim, seconds: float) -> None:
        """Book a call of ``sim.advance`` that took ``seconds``."""
        if self.first is None:
            self.first_wall = seconds
            self.first = (_events(sim), sim.time)
        else:
            self.busy += seconds

    def wall(self) -> float:
        return time.perf_counter() - self.wall0

    def rates(self, sim) -> tuple[float, float]:
        """(events per second, simulated time per second) in advance() after the first
        chunk; nan until there is something to measure."""
        if self.first is None or self.busy <= 0:
            return math.nan, math.nan
        return ((_events(sim) - self.first[0]) / self.busy,
                (sim.time - self.first[1]) / self.busy)


def _check_run_options(args) -> tuple[dict, str | None]:
    """Check everything that can fail before spending time on the run: the numbers, the
    output paths and the optional packages they need. -> (output paths by kind, the movie
    kind "gif" / "mp4" or None)."""
    if not (math.isfinite(args.time) and args.time >= 0):
        raise CLIError(f"--time must be a finite number >= 0, got {args.time}")
    if args.every is not None and not (math.isfinite(args.every) and args.every > 0):
        raise CLIError(f"--every must be a number > 0, got {args.every}")
    if args.fps <= 0 or args.size < 32 or args.frames < 1:
        raise CLIError("--fps must be > 0, --size >= 32 and --frames >= 1")
    outputs = {}
    if args.csv:
        outputs["csv"] = _writable(args.csv, "--csv")
    if args.plot:
        outputs["plot"] = _writable(args.plot, "--plot")
        _need("matplotlib", "--plot", RENDER_EXTRA)
    movie_kind = None
    if args.gif:
        movie_kind = "gif"
        outputs["movie"] = _writable(args.gif, "--gif")
        _need("PIL", "--gif", RENDER_EXTRA)
    if args.mp4:
        movie_kind = "mp4"
        outputs["movie"] = _writable(args.mp4, "--mp4")
        _need("imageio", "--mp4", "pip install imageio imageio-ffmpeg")
        _need("imageio_ffmpeg", "--mp4", "pip install imageio imageio-ffmpeg")
    if args.save:
        outputs["save"] = _writable(args.save, "--save")
    return outputs, movie_kind


class _Plan(NamedTuple):
    """How a run of ``--time`` is cut: ``steps`` whole steps of ``dt``, then ``rest`` (0 or
    a fraction of a step); a sample every ``every`` steps (``adaptive``: starting at one step
    and doubling); ``samples``: the rows a fixed interval gives (1 when adaptive)."""

    dt: float
    steps: int
    rest: float
    adaptive: bool
    every: int
    samples: int


def _plan_run(duration: float, every: float | None, dt: float) -> _Plan:
    steps = int(math.floor(duration / dt + 1e-9))
    rest = duration - steps * dt
    if rest <= 1e-9 * dt:
        rest = 0.0
    adaptive = every is None
    k_every = 1 if adaptive else max(int(round(every / dt)), 1)
    samples = 1 if adaptive else -(-steps // k_every) + 1 + (1 if rest else 0)
    return _Plan(dt, steps, rest, adaptive, k_every, samples)


def _frame_renderer(size: int):
    """sim -> an animation frame of ``size`` pixels, titled with the clock."""
    from .render import render_frame

    def render(s) -> object:
        return render_frame(s, size=size, title=f"t = {s.time:.1f}")

    return render


class _Start(NamedTuple):
    """The state at the start of a run, which the summary compares the end with."""

    time: float
    counts: dict
    temperature: float
    total_energy: float
    kinetic: float
    balance: float
    counters: dict
    fired: dict

    @classmethod
    def of(cls, sim) -> _Start:
        return cls(sim.time, sim.counts(), sim.temperature(), sim.total_energy(),
                   sim.kinetic_energy(), sim.energy_balance(), sim.counters(), sim.reactions())


class _RunLoop:
    """The run itself: advances ``sim`` in chunks, samples ``series`` at the planned steps
    with the mean pressure of each interval, drives the progress bar and stops early on
    Ctrl-C. Creating it takes the first sample and starts the pressure bookkeeping."""

    def __init__(self, sim, series: _Series, plan: _Plan):
        self.sim, self.series, self.plan = sim, series, plan
        self.t_start = sim.time
        self.every = plan.every  # steps per sample (doubles as the adaptive series thins)
        series.sample(sim, math.nan, 0.0)
        sim.reset_counters()  # pressure: averaged over each sampling interval from here
        self.p_weighted = 0.0  # sum of interval pressure x interval length
        self.p_time = 0.0
        self.last_t = sim.time
        self.progress = None
        self.clock = None

    def mean_pressure(self) -> float:
        return self.p_weighted / self.p_time if self.p_time > 0 else math.nan

    def _sample(self) -> None:
        sim = self.sim
        span = sim.time - self.last_t
        p = sim.pressure() if span > 0 else math.nan
        if span > 0:
            self.p_weighted += p * span
            self.p_time += span
        if self.series.sample(sim, p, span):
            self.every *= 2
        sim.reset_counters()
        self.last_t = sim.time

    def _advance(self, duration: float) -> float:
        w = time.perf_counter()
        self.sim.advance(duration)
        w = time.perf_counter() - w
        self.clock.advanced(self.sim, w)
        self.progress.update(self.sim.time - self.t_start, self.clock.rates(self.sim)[0])
        return w

    def run(self, duration: float, quiet: bool) -> bool:
        """Run the plan; True if Ctrl-C stopped it early (the state is then sampled where it
        stopped). A second Ctrl-C propagates as KeyboardInterrupt."""
        sim, plan = self.sim, self.plan
        self.progress = _Progress(duration, self.t_start, enabled=not quiet)
        self.clock = _Clock()
        steps_per_s = None  # measured; chunks of ~0.1 s keep Ctrl-C responsive
        with _Stop() as stop:
            try:
                done = 0
                next_sample = self.every
                while done < plan.steps and not stop.requested:
                    # the first chunk is one step; then chunks of ~0.1 s of wall time, cut at
                    # the next sample
                    chunk = 1 if steps_per_s is None else max(int(0.1 * steps_per_s), 1)
                    chunk = min(chunk, next_sample - done, plan.steps - done)
                    w = self._advance(chunk * plan.dt)
                    if w > 0:
                        rate = chunk / w
                        steps_per_s = rate if steps_per_s is None else \
                            0.5 * steps_per_s + 0.5 * rate
                    done += chunk
                    if done == next_sample or done == plan.steps:
                        self._sample()
                        next_sample = done + self.every
                if plan.rest and not stop.requested:
                    self._advance(plan.rest)
                    self._sample()
            except KeyboardInterrupt:
                # a second Ctrl-C: it may have struck in the middle of a step, so the state
                # is not worth writing; main() reports the interruption
                self.progress.close()
                _note("aborted by a second Ctrl-C: nothing written")
                raise
            interrupted = stop.requested
            if interrupted and sim.time > self.last_t:
                self._sample()
        self.progress.close()
        if interrupted:
            _note(f"interrupted at t {sim.time:.6g} (Ctrl-C): writing what was asked for")
        return interrupted


def _running_note(label: str, sim, duration: float, plan: _Plan) -> str:
    every_txt = ("adaptive sampling, 100-200 samples" if plan.adaptive else
                 f"a sample every {plan.every * plan.dt:.4g}")
    integrator = getattr(sim, "integrator", "step")
    return (f"running {label}: {len(sim)} discs, t {sim.time:.4g} -> "
            f"{sim.time + duration:.4g} ({integrator} integrator, dt {plan.dt:g}, "
            f"{every_txt}); Ctrl-C stops and writes the outputs")


def _write_outputs(args, outputs: dict, movie_kind: str | None, series: _Series, sim,
                   plot_title: str) -> bool:
    """Write each output asked for, each on its own, so one failure does not lose the
    others; True if one could not be written."""
    writers = []
    if "csv" in outputs:
        writers.append(("time series", outputs["csv"], lambda p: series.write_csv(p)))
    if "plot" in outputs:
        writers.append(("plot", outputs["plot"], lambda p: _write_plot(series, p, plot_title)))
    if movie_kind:
        if series.images[-1] is None:  # always end on the final state
            series.images[-1] = series.render(sim)
        frames = series.frames(args.frames)
        writers.append((f"{movie_kind} ({len(frames)} frames)", outputs["movie"],
                        lambda p: _write_movie(frames, p, args.fps, movie_kind)))
    if "save" in outputs:
        writers.append(("checkpoint", outputs["save"],
                        lambda p: _atomic_write_bytes(p, pickle.dumps(sim, protocol=4))))
    failed = False
    for what, path, write in writers:
        try:
            write(path)
            _say(f"wrote {what}: {path}")
        except KeyboardInterrupt:
            raise
        except Exception as exc:
            failed = True
            _err(f"could not write the {what} to {path}: {type(exc).__name__}: {exc}")
    return failed


def cmd_run(args) -> int:
    outputs, movie_kind = _check_run_options(args)
    sim, label = _build_simulation(args)
    plan = _plan_run(args.time, args.every, float(sim.scene.dt))
    render = _frame_renderer(args.size)
    series = _Series(sim, plan.adaptive, frame_stride=max(-(-plan.samples // args.frames), 1),
                     render=render if movie_kind else None)
    start = _Start.of(sim)
    loop = _RunLoop(sim, series, plan)
    _note(_running_note(label, sim, args.time, plan))
    interrupted = loop.run(args.time, args.quiet)
    _say(_run_summary(sim, label, start, loop.mean_pressure(), loop.clock, interrupted))
    title = (f"{label}: t {start.time:.4g} to {sim.time:.4g}, {len(series.rows)} samples"
             + (" (interrupted)" if interrupted else ""))
    failed = _write_outputs(args, outputs, movie_kind, series, sim, title)
    if interrupted:
        return EXIT_INTERRUPTED
    return EXIT_FAILED if failed else EXIT_OK


def _counts_table(start: _Start, counts1: dict) -> str:
    rows = [(s, start.counts[s], counts1[s], f"{counts1[s] - start.counts[s]:+d}")
            for s in counts1]
    n0, n1 = sum(start.counts.values()), sum(counts1.values())
    rows.append(("total", n0, n1, f"{n1 - n0:+d}"))
    return _table(rows, header=("species", "start", "end", "change"))


def _state_table(sim, start: _Start, pressure: float) -> str:
    balance1 = sim.energy_balance()
    rows = [
        ("temperature kT", _fmt(start.temperature), _fmt(sim.temperature())),
        ("total energy", _fmt(start.total_energy), _fmt(sim.total_energy())),
        ("pressure (mean over the run)", "", _fmt(pressure)),
        ("packing fraction", "", _fmt(sim.packing_fraction())),
        ("energy balance", _fmt(start.balance), _fmt(balance1)),
    ]
    drift = balance1 - start.balance
    rel = f" ({abs(drift) / start.kinetic:.2g} of the initial kinetic energy)" \
        if start.kinetic > 0 else ""
    return (_table(rows, header=("", "start", "end"))
            + f"\nenergy drift over the run: {drift:.3g}{rel}")


def _events_table(sim, start: _Start) -> str:
    c1 = sim.counters()
    fired1 = sim.reactions()
    c0, fired0 = start.counters, start.fired
    rows = [("collisions", c1["collisions"] - c0["collisions"]),
            ("wall hits", c1["wall_hits"] - c0["wall_hits"])]
    rows += [(f"  {lab}", fired1[lab] - fired0.get(lab, 0)) for lab in fired1]
    if fired1:
        rows.insert(2, ("reactions fired", sum(fired1.values()) - sum(fired0.values())))
    for key, what in (("events_capped", "substeps out of event budget"),
                      ("substeps_capped", "steps at the substep cap"),
                      ("reactions_without_room", "reactions waiting for room")):
        d = c1[key] - c0[key]
        if d:
            rows.append((what, d))
    return _table(rows, header=("during the run", "count"))


def _run_summary(sim, label: str, start: _Start, pressure: float, clock: _Clock,
                 interrupted: bool) -> str:
    state = "interrupted" if interrupted else "done"
    out = [f"\n{label}: t {start.time:.6g} -> {sim.time:.6g} ({state})\n",
           _counts_table(start, sim.counts()), "",
           _state_table(sim, start, pressure), "",
           _events_table(sim, start)]
    rate, speed = clock.rates(sim)
    first = clock.first_wall or 0.0
    out.append(f"\nwall time {clock.wall():.2f} s, of which {first:.2f} s in the first step "
               f"(numba loading or compiling the kernels) and {clock.busy:.2f} s simulating "
               f"the rest: {rate:.3g} events/s (collisions + wall hits + reactions), "
               f"{speed:.3g} time units per second")
    return "\n".join(out)


# --------------------------------------------------------------------------------------------
# the parser


def _int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    return v


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

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
               "--save run.pkl\n"
               "  discgym run --resume run.pkl --time 50 --csv more.csv")
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
                   help="write a checkpoint (a pickled Simulation) at the end, or when stopped")
    p.add_argument("--resume", metavar="STATE",
                   help="continue a checkpoint written by --save (only load files you trust: "
                        "it is a pickle)")
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
    from .scene import SceneError

    try:
        return args.func(args)
    except CLIError as exc:
        _err(str(exc))
        return exc.code
    except SceneError as exc:
        _err(f"bad scene: {exc}")
        return EXIT_USAGE
    except KeyboardInterrupt:
        _note("\ninterrupted")
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `discgym scenes | head`
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
