"""``discgym run``: a simulation from a scene or a saved state, with progress, a summary,
and plots, movies, CSV and a saved state if asked."""

from __future__ import annotations

import csv
import inspect
import math
import signal
import sys
import time
from pathlib import Path
from typing import NamedTuple

from .. import checkpoint
from .common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    RENDER_EXTRA,
    CLIError,
    err,
    fmt,
    load_scene,
    need,
    note,
    parse_counts,
    say,
    table,
    writable,
)

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
    from ..render import species_colors

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


def integrator_supported() -> bool:
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
            pickled = f.read(1) == b"\x80"  # (a pickle's first byte, protocol 2 and later)
    except OSError as exc:
        raise CLIError(f"--resume {args.resume}: cannot read it ({exc})") from None
    if pickled:  # (never unpickled here: loading a pickle runs code)
        raise CLIError(f"--resume {args.resume}: a pickled Simulation, which this command does "
                       "not load (unpickling runs code); if you trust it, pickle.load it in "
                       "Python and write it with discgym.checkpoint.save")
    try:
        sim = dg.checkpoint.load(p)
    except ValueError as exc:
        raise CLIError(f"--resume {exc}") from None
    except OSError as exc:
        raise CLIError(f"--resume {args.resume}: cannot read it ({exc})") from None
    if isinstance(sim, list) and len(sim) == 1:  # (a batch of one)
        sim = sim[0]
    if not isinstance(sim, dg.Simulation):
        raise CLIError(f"--resume {args.resume}: a checkpoint of {len(sim)} reactors; "
                       "discgym run continues one")
    used = getattr(sim, "integrator", "step")
    if args.integrator is not None and args.integrator != used:
        raise CLIError(f"--integrator {args.integrator}: the checkpoint {args.resume} runs "
                       f"the {used!r} integrator; leave out --integrator to continue it")
    if args.scene is not None:
        scene = load_scene(args.scene)
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
    scene = load_scene(args.scene)
    counts = None
    if args.n is not None:
        counts = dict(scene.counts)
        counts.update(parse_counts(args.n, scene.species_names))
    kw = {}
    if args.integrator is not None:
        if integrator_supported():
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
        note("\nCtrl-C: stopping after the current chunk of steps (Ctrl-C again to abort "
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
        outputs["csv"] = writable(args.csv, "--csv")
    if args.plot:
        outputs["plot"] = writable(args.plot, "--plot")
        need("matplotlib", "--plot", RENDER_EXTRA)
    movie_kind = None
    if args.gif:
        movie_kind = "gif"
        outputs["movie"] = writable(args.gif, "--gif")
        need("PIL", "--gif", RENDER_EXTRA)
    if args.mp4:
        movie_kind = "mp4"
        outputs["movie"] = writable(args.mp4, "--mp4")
        need("imageio", "--mp4", "pip install imageio imageio-ffmpeg")
        need("imageio_ffmpeg", "--mp4", "pip install imageio imageio-ffmpeg")
    if args.save:
        outputs["save"] = writable(args.save, "--save")
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
    from ..render import render_frame

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
                note("aborted by a second Ctrl-C: nothing written")
                raise
            interrupted = stop.requested
            if interrupted and sim.time > self.last_t:
                self._sample()
        self.progress.close()
        if interrupted:
            note(f"interrupted at t {sim.time:.6g} (Ctrl-C): writing what was asked for")
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
                        lambda p: checkpoint.save(p, sim)))
    failed = False
    for what, path, write in writers:
        try:
            write(path)
            say(f"wrote {what}: {path}")
        except KeyboardInterrupt:
            raise
        except Exception as exc:
            failed = True
            err(f"could not write the {what} to {path}: {type(exc).__name__}: {exc}")
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
    note(_running_note(label, sim, args.time, plan))
    interrupted = loop.run(args.time, args.quiet)
    say(_run_summary(sim, label, start, loop.mean_pressure(), loop.clock, interrupted))
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
    return table(rows, header=("species", "start", "end", "change"))


def _state_table(sim, start: _Start, pressure: float) -> str:
    balance1 = sim.energy_balance()
    rows = [
        ("temperature kT", fmt(start.temperature), fmt(sim.temperature())),
        ("total energy", fmt(start.total_energy), fmt(sim.total_energy())),
        ("pressure (mean over the run)", "", fmt(pressure)),
        ("packing fraction", "", fmt(sim.packing_fraction())),
        ("energy balance", fmt(start.balance), fmt(balance1)),
    ]
    drift = balance1 - start.balance
    rel = f" ({abs(drift) / start.kinetic:.2g} of the initial kinetic energy)" \
        if start.kinetic > 0 else ""
    return (table(rows, header=("", "start", "end"))
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
    return table(rows, header=("during the run", "count"))


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
