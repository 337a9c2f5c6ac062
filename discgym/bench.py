"""The quick benchmark of ``discgym bench``: how fast this discgym runs on this machine.

Everything runs on the *benchmark scene*: elastic discs of radius 1 and mass 1 at kT = 1 in a
square box at packing fraction 0.3, time step 0.05 (:func:`bench_scene`). Two sections:

``scaling``
    disc-steps per second of :class:`discgym.Simulation` at N = 10^2 ... 10^6, on one thread
    (``sim.threads = 1``) and on all of numba's threads (the default), and the cost per
    disc-step in ns (flat in N is the goal).
``effects``
    the same population with one effect switched on at a time (walls only, collisions,
    restitution, circle bounds, first-order and bimolecular reactions, reactions whose species
    are rare or absent), each as ns per disc-step on one thread.

Timing: each measurement is one untimed warm-up step, one untimed probe step (to size the
first chunk), then timed chunks of ``sim.step(k)``, each sized from the one before. Things
compared with each other (one thread / all threads, the rows of the effect table) are timed
in alternating chunks (:func:`interleave`), so load from other processes hits them alike.
Rates are given for the whole timed run and for its fastest chunk (``best``). Nothing here
asserts a time: the numbers are printed (and written as Markdown or JSON on request).

The tables and figures of ``docs/performance.md`` come from the scripts in the repository's
``benchmarks/``, built on this module: ``bench_core.py`` adds a minimal reference kernel to
the effect table and draws the figures, ``bench_peers.py`` compares with LAMMPS, pymunk and
Box2D, ``profile_step.py`` times the phases of a step.

Command line: ``discgym bench`` (quick mode; ``--full`` for the full sizes) or
``python -m discgym.bench [--quick] [--sections scaling,effects] [--markdown FILE]
[--json FILE]`` (``--help`` for the rest).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field

import numba
import numpy as np

from .scene import Box, Circle, Exchange, Outlet, Scene, Species, ThermalWall, Transformation
from .simulation import Simulation

__all__ = [
    "RADIUS", "MASS", "KT", "ETA", "DT",
    "bench_scene", "box_side", "timed_simulation", "Timing", "time_steps", "Runner",
    "interleave", "machine_info", "machine_line", "format_table", "n_label", "mega",
    "scaling", "scaling_table", "effect_scenes", "effects", "effects_table", "Report",
    "build_parser", "chosen_sections", "run_scaling", "run_effects", "main",
]

RADIUS = 1.0  #: disc radius of the benchmark scene
MASS = 1.0  #: disc mass
KT = 1.0  #: temperature (k_B = 1)
ETA = 0.3  #: packing fraction
DT = 0.05  #: time step

FULL_SIZES = (100, 1_000, 10_000, 100_000, 1_000_000)
QUICK_SIZES = (100, 1_000, 10_000)
SECTIONS = ("scaling", "effects")

#: sections that live in the repository's benchmarks/, not in the package
ELSEWHERE = {"peers": "the comparison with LAMMPS, pymunk and Box2D is "
                      "benchmarks/bench_peers.py in the source repository"}


def _log(msg: str) -> None:
    print(msg, flush=True)


# =============================================================================== the scene
def box_side(n: int, eta: float = ETA, radius: float = RADIUS) -> float:
    """Side of the square box in which ``n`` discs of ``radius`` have packing fraction eta."""
    return math.sqrt(n * math.pi * radius * radius / eta)


def bench_scene(n: int, *, eta: float = ETA, dt: float = DT, shape: str = "box",
                collisions: bool = True, restitution: float = 1.0,
                extra_species: Sequence[Species] = (), reactions: Sequence = (),
                extra_counts: dict | None = None) -> Scene:
    """The benchmark scene: ``n`` discs "A" (r = 1, m = 1, kT = 1) at packing fraction
    ``eta`` in a square box (``shape="circle"``: a circle of the same area)."""
    side = box_side(n, eta)
    if shape == "box":
        bounds = Box(side, side)
    elif shape == "circle":
        R = side / math.sqrt(math.pi)
        bounds = Circle(R, (R, R))
    else:
        raise ValueError(f"shape must be 'box' or 'circle', got {shape!r}")
    counts = {"A": int(n)}
    counts.update(extra_counts or {})
    return Scene(bounds=bounds, species=[Species("A", RADIUS, MASS), *extra_species],
                 reactions=tuple(reactions), restitution=restitution, dt=dt,
                 collisions=collisions, counts=counts, temperature=KT,
                 name=f"bench_{shape}_{n}")


def timed_simulation(scene: Scene, seed: int) -> tuple[Simulation, float]:
    """A new simulation of ``scene`` and the seconds its placement took."""
    t0 = time.perf_counter()
    sim = Simulation(scene, seed=seed)
    return sim, time.perf_counter() - t0


# ================================================================================= timing
@dataclass
class Timing:
    """Timed chunks of one run: ``steps[k]`` steps took ``seconds[k]`` s, with ``n`` discs."""

    n: int
    steps: list = field(default_factory=list)
    seconds: list = field(default_factory=list)

    @property
    def total_steps(self) -> int:
        return int(sum(self.steps))

    @property
    def wall(self) -> float:
        return float(sum(self.seconds))

    @property
    def rate(self) -> float:
        """Disc-steps per second over the whole timed run."""
        return self.n * self.total_steps / self.wall if self.wall > 0 else math.nan

    @property
    def rate_best(self) -> float:
        """Disc-steps per second of the fastest chunk."""
        return max(self.n * s / w for s, w in zip(self.steps, self.seconds) if w > 0)

    @property
    def ns(self) -> float:
        """ns per disc-step over the whole timed run."""
        return 1e9 / self.rate

    @property
    def ns_best(self) -> float:
        return 1e9 / self.rate_best

    def summary(self) -> dict:
        return {"n": self.n, "steps": self.total_steps, "wall_s": self.wall,
                "rate": self.rate, "rate_best": self.rate_best, "ns": self.ns,
                "ns_best": self.ns_best, "chunks": list(zip(self.steps, self.seconds))}


def time_steps(step: Callable[[int], None], n: int, seconds: float, chunks: int = 3,
               max_steps: int | None = None, between: Callable[[], None] | None = None,
               timing: Timing | None = None, min_steps: int = 1) -> Timing:
    """Time ``step(k)`` (advancing ``n`` discs ``k`` steps) for about ``seconds`` in ``chunks``.

    One untimed probe step sizes the first chunk (warm up before calling), and each chunk
    sizes the next (a probe step also pays a call's set-up cost). ``between()`` runs,
    untimed, before each chunk (to restore a temperature, take a snapshot, ...). ``max_steps``
    caps the timed steps, ``min_steps`` sets a floor. Chunks are appended to ``timing`` if
    given.
    """
    t0 = time.perf_counter()
    step(1)
    est = max(time.perf_counter() - t0, 1e-7)  # seconds per step (an overestimate: set-up)
    total = max(chunks, min_steps, int(seconds / est))
    if max_steps is not None:
        total = max(1, min(total, int(max_steps)))
    chunks = min(chunks, total)
    lo = -(-max(min_steps, chunks) // chunks)  # steps per chunk: at least this many ...
    hi = None if max_steps is None else max(1, int(max_steps) // chunks)  # ... at most this
    chunk_s = seconds / chunks
    out = timing if timing is not None else Timing(n)
    for _ in range(chunks):
        per = max(lo, int(chunk_s / est))
        if hi is not None:
            per = min(per, hi)
        if between is not None:
            between()
        t0 = time.perf_counter()
        step(per)
        w = time.perf_counter() - t0
        out.seconds.append(w)
        out.steps.append(per)
        est = max(w / per, est / 10.0, 1e-9)  # re-estimate from the chunk just timed
    return out


class Runner:
    """One contender in an interleaved timing: ``step(k)`` advances ``n`` discs k steps.

    ``chunk(seconds)`` times one chunk of about that long (sized from the chunk before; the
    first from an untimed probe step), after calling ``before()`` and ``between()`` untimed;
    the steps per chunk stay within [lo, hi]. Chunks accumulate in ``timing``; ``seconds`` is
    the runner's whole budget in :func:`interleave`.
    """

    def __init__(self, name: str, step: Callable[[int], None], n: int, seconds: float,
                 between: Callable[[], None] | None = None, lo: int = 1,
                 hi: int | None = None, before: Callable[[], None] | None = None):
        self.name, self.step, self.between, self.before = name, step, between, before
        self.seconds, self.lo, self.hi = seconds, lo, hi
        self.timing = Timing(n)
        self.est = None

    def chunk(self, seconds: float) -> None:
        if self.before is not None:
            self.before()
        if self.est is None:
            t0 = time.perf_counter()
            self.step(1)
            self.est = max(time.perf_counter() - t0, 1e-7)
        per = max(self.lo, int(seconds / self.est))
        if self.hi is not None:
            per = min(per, self.hi)
        if self.between is not None:
            self.between()
        t0 = time.perf_counter()
        self.step(per)
        w = time.perf_counter() - t0
        self.timing.seconds.append(w)
        self.timing.steps.append(per)
        self.est = max(w / per, self.est / 10.0, 1e-9)


def interleave(runners: Sequence[Runner], rounds: int) -> None:
    """Time the runners in turn, ``rounds`` chunks each, of ``runner.seconds / rounds`` each:
    load from other processes then hits every contender alike (the machine is shared)."""
    for _ in range(rounds):
        for r in runners:
            r.chunk(r.seconds / rounds)


# ================================================================================== machine
_MACHINE_KEYS = ("date", "cpu", "nproc", "numba_threads", "load_avg", "load_avg_end", "python",
                 "numpy", "numba")


def machine_info(**versions) -> dict:
    """Date, CPU, cores, load and versions: the header every table is printed with.
    ``versions``: more packages to name (e.g. ``pymunk="7.1"``; None: not installed)."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        load = os.getloadavg()
    except OSError:
        load = (math.nan,) * 3
    return {
        "date": datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z"),
        "cpu": cpu,
        "nproc": os.cpu_count(),
        "numba_threads": numba.get_num_threads(),
        "load_avg": [round(x, 2) for x in load],
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        **versions,
    }


def machine_line(info: dict) -> str:
    """:func:`machine_info` on one line."""
    more = "".join(f", {k} {v}" for k, v in info.items() if k not in _MACHINE_KEYS and v)
    return (f"{info['date']}; {info['cpu']}, nproc = {info['nproc']}, numba threads = "
            f"{info['numba_threads']}; load average {info['load_avg'][0]:.2f} at the start; "
            f"python {info['python']}, numpy {info['numpy']}, numba {info['numba']}" + more)


# ================================================================================== tables
def format_table(headers: Sequence[str], rows: Sequence[Sequence], markdown: bool = False
                 ) -> str:
    """Plain-text (aligned) or Markdown table of already-formatted cells."""
    cells = [[str(c) for c in r] for r in rows]
    if markdown:
        out = ["| " + " | ".join(headers) + " |",
               "|" + "|".join("---:" if k else ":---" for k in range(len(headers))) + "|"]
        out += ["| " + " | ".join(r) + " |" for r in cells]
        return "\n".join(out)
    widths = [max(len(h), *(len(r[k]) for r in cells)) if cells else len(h)
              for k, h in enumerate(headers)]
    line = "  ".join(h.rjust(w) if k else h.ljust(w) for k, (h, w) in
                     enumerate(zip(headers, widths)))
    out = [line, "-" * len(line)]
    out += ["  ".join(c.rjust(w) if k else c.ljust(w) for k, (c, w) in
                      enumerate(zip(r, widths))) for r in cells]
    return "\n".join(out)


def n_label(n: int) -> str:
    """N for a table: a power of ten as 1eK, others in digits."""
    e = int(round(math.log10(n))) if n > 0 else 0
    return f"1e{e}" if n == 10 ** e else str(n)


def mega(rate: float) -> str:
    """A rate in millions per second, two decimals."""
    return f"{rate / 1e6:.2f}"


# ================================================================================== scaling
def scaling(sizes: Sequence[int] = FULL_SIZES, seconds: float = 1.5, seed: int = 0,
            chunks: int = 3) -> list[dict]:
    """Disc-steps per second at each N, on one thread and on all threads (the default),
    timed in alternating chunks (``seconds`` each in all) on the same simulation."""
    rows = []
    for n in sizes:
        sim, placed = timed_simulation(bench_scene(n), seed)
        _log(f"  N = {n}: placed in {placed:.2f} s")
        all_threads = sim.threads
        sim.step(1)  # warm-up (loads the compiled kernels)
        row = {"n": n, "place_s": placed, "threads_all": all_threads}
        c0 = sim.counters()
        t0 = sim.time
        runners = [Runner(label, sim.step, n, seconds, lo=2,
                          before=lambda th=th, sim=sim: setattr(sim, "threads", th))
                   for label, th in (("one", 1), ("all", all_threads))]
        interleave(runners, chunks)
        c1 = sim.counters()
        steps = round((sim.time - t0) / sim.scene.dt)
        for r in runners:
            tm = r.timing
            row[r.name] = tm.summary()
            row[r.name]["collisions_per_disc_step"] = \
                (c1["collisions"] - c0["collisions"]) / (n * steps)
            row[r.name]["substeps_per_step"] = (c1["substeps"] - c0["substeps"]) / steps
            _log(f"    {r.name} thread(s): {tm.total_steps} steps, {tm.rate / 1e6:.2f} M "
                 f"disc-steps/s ({tm.ns:.0f} ns per disc-step)")
        row["speedup"] = row["all"]["rate"] / row["one"]["rate"]
        rows.append(row)
    return rows


def scaling_table(rows, markdown=False) -> str:
    headers = ["N", "place s", "steps 1t", "M/s 1t", "best", "ns 1t", "steps all", "M/s all",
               "best", "ns all", "speed-up", "coll/disc-step"]
    body = [[n_label(r["n"]), f"{r['place_s']:.2f}", r["one"]["steps"], mega(r["one"]["rate"]),
             mega(r["one"]["rate_best"]), f"{r['one']['ns']:.0f}", r["all"]["steps"],
             mega(r["all"]["rate"]), mega(r["all"]["rate_best"]), f"{r['all']['ns']:.0f}",
             f"{r['speedup']:.2f}", f"{r['one']['collisions_per_disc_step']:.4f}"]
            for r in rows]
    return format_table(headers, body, markdown)


# ================================================================================== effects
#: another contender for the effect table: called with the reference simulation (elastic
#: discs) and the time budget, it returns ``(runner, stats)``; ``stats()``, called after the
#: rounds, gives its row's ``collisions_per_disc_step`` and ``reactions``
Contender = Callable[[Simulation, float], tuple[Runner, Callable[[], dict]]]


def effect_scenes(n: int) -> list[tuple[str, Scene, bool]]:
    """The per-effect rows: (label, scene, restore_temperature)."""
    B = Species("B", RADIUS, MASS)
    Rr = Species("R", RADIUS, MASS)
    S = Species("S", RADIUS, MASS)
    Z = Species("Z", RADIUS, MASS)
    Y = Species("Y", RADIUS, MASS)
    return [
        ("walls only (collisions=False)", bench_scene(n, collisions=False), False),
        ("elastic discs (reference)", bench_scene(n), False),
        ("+ restitution e = 0.95", bench_scene(n, restitution=0.95), True),
        ("circle bounds (same area)", bench_scene(n, shape="circle"), False),
        ("+ first-order A -> B, B -> A (p = 0.05)",
         bench_scene(n, extra_species=[B], reactions=[Transformation("A", "B", 0.05),
                                                      Transformation("B", "A", 0.05)]), False),
        ("+ bimolecular R + R -> S + S, 10 R discs",
         bench_scene(n, extra_species=[Rr, S], reactions=[Exchange("R", "R", "S", "S")],
                     extra_counts={"R": 10}), False),
        ("+ absent first-order Z -> Y (no Z)",
         bench_scene(n, extra_species=[Z, Y], reactions=[Transformation("Z", "Y", 0.5)]),
         False),
        ("+ absent bimolecular Z + Z -> Y + Y (no Z)",
         bench_scene(n, extra_species=[Z, Y], reactions=[Exchange("Z", "Z", "Y", "Y")]),
         False),
        ("+ thermal walls (all four sides at kT = 1)",
         bench_scene(n).replace(thermal_walls=tuple(ThermalWall(sd, KT) for sd in
                                                    ("left", "right", "bottom", "top"))),
         False),
        ("+ outlet (0.1 % of one side: ~1 disc leaves per 800 steps)",
         bench_scene(n).replace(outlets=(Outlet("right", 0.4995, 0.5005),)), False),
        ("elastic discs (reference, again)", bench_scene(n), False),
    ]


def effects(n: int = 10_000, seconds: float = 0.25, reps: int = 5, seed: int = 0,
            extra: Sequence[Contender] = ()) -> list[dict]:
    """ns per disc-step on one thread for each effect, timed in ``reps`` interleaved rounds
    of about ``seconds`` per row (so a burst of load from elsewhere hits every row alike);
    the temperature is restored to kT = 1 (untimed) before each chunk of the inelastic row.
    Each of the ``extra`` contenders gets a row after the effects."""
    cases, runners = [], []
    for label, scene, restore in effect_scenes(n):
        sim, _ = timed_simulation(scene, seed)
        sim.threads = 1
        sim.step(1)
        between = (lambda sim=sim: sim.scale_temperature(KT / sim.temperature())) \
            if restore else None
        cases.append({"label": label, "sim": sim, "c0": sim.counters(), "t0": sim.time})
        runners.append(Runner(label, sim.step, len(sim), seconds * reps, between=between))
    others = [make(cases[1]["sim"], seconds * reps) for make in extra]
    runners += [r for r, _ in others]
    for rep in range(reps):
        for r in runners:
            r.chunk(seconds)
        _log(f"  round {rep + 1}/{reps} done")
    rows = []
    for case, r in zip(cases, runners):
        sim, tm = case["sim"], r.timing
        c1 = sim.counters()
        steps = round((sim.time - case["t0"]) / sim.scene.dt)
        rows.append({"label": case["label"], "n": len(sim), "steps": tm.total_steps,
                     "ns_best": tm.ns_best, "ns_median": _median_ns(tm), "ns": tm.ns,
                     "collisions_per_disc_step": (c1["collisions"] - case["c0"]["collisions"]
                                                  + c1["reactive_collisions"]
                                                  - case["c0"]["reactive_collisions"])
                     / (len(sim) * steps),
                     "reactions": sum(sim.reactions().values())})
    for r, stats in others:
        tm = r.timing
        rows.append({"label": r.name, "n": tm.n, "steps": tm.total_steps,
                     "ns_best": tm.ns_best, "ns_median": _median_ns(tm), "ns": tm.ns,
                     **stats()})
    ref = [r["ns_best"] for r in rows if r["label"].startswith("elastic discs (reference")]
    ref_ns = float(np.mean(ref))
    for row in rows:
        row["vs_reference"] = row["ns_best"] / ref_ns - 1.0
        row["extra_ns"] = row["ns_best"] - ref_ns
    return rows


def _median_ns(tm: Timing) -> float:
    return float(np.median([w / (tm.n * s) * 1e9 for s, w in zip(tm.steps, tm.seconds)]))


def effects_table(rows, markdown=False) -> str:
    headers = [f"effect (N = {n_label(rows[0]['n'])}, one thread)", "ns/disc-step (best)",
               "median", "extra ns", "vs reference", "coll/disc-step", "reactions"]
    body = [[r["label"], f"{r['ns_best']:.1f}", f"{r['ns_median']:.1f}",
             f"{r['extra_ns']:+.1f}", f"{100 * r['vs_reference']:+.1f}%",
             f"{r['collisions_per_disc_step']:.4f}", r["reactions"]] for r in rows]
    return format_table(headers, body, markdown)


# ============================================================================ command line
class Report:
    """What one benchmark run prints and keeps: the machine line first, then each section's
    table as it is done; at the end the Markdown tables and the JSON of every result."""

    def __init__(self, argv: Sequence[str] | None, quick: bool, **versions):
        self.info = machine_info(**versions)
        self.results: dict = {"machine": self.info,
                              "argv": list(sys.argv[1:] if argv is None else argv)}
        self.md = [f"Machine: {machine_line(self.info)}", ""]
        _log(f"discgym benchmarks{' (quick)' if quick else ''}: {machine_line(self.info)}")
        _log("(the first run in a fresh checkout compiles the kernels: about a minute)")

    def section(self, key: str, title: str, rows: list, table: Callable[..., str]) -> None:
        """Keep ``rows`` under ``key``, print ``table(rows)``, add it to the Markdown."""
        self.results[key] = rows
        _log("\n" + table(rows))
        self.md += [f"### {title}", "", table(rows, True), ""]

    def finish(self, markdown: str | None = None, json_path: str | None = None) -> None:
        self.info["load_avg_end"] = [round(x, 2) for x in os.getloadavg()]
        _log(f"\nload average at the end: {self.info['load_avg_end'][0]:.2f}")
        if markdown:
            with open(markdown, "w") as f:
                f.write("\n".join(self.md) + "\n")
        if json_path:
            with open(json_path, "w") as f:
                json.dump(self.results, f, indent=1, default=_jsonable)


def _jsonable(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, Timing):
        return asdict(o)
    return str(o)


def _ints(text: str) -> list[int]:
    return [int(float(x)) for x in text.split(",") if x.strip()]


def build_parser(prog: str = "discgym bench", description: str | None = None,
                 sections: Sequence[str] = SECTIONS) -> argparse.ArgumentParser:
    """The options of the scaling and effects sections (callers may add their own)."""
    p = argparse.ArgumentParser(
        prog=prog,
        description=description or
        "Benchmarks of discgym on the benchmark scene (discs r = 1, m = 1, kT = 1, "
        "packing 0.3, dt = 0.05): scaling with N and threads, and the cost of each effect.")
    p.add_argument("--quick", action="store_true",
                   help="small sizes and short timings (under a minute once compiled)")
    p.add_argument("--sections", default=",".join(sections),
                   help=f"comma-separated: {', '.join(sections)} (default: all)")
    p.add_argument("--sizes", type=_ints, default=None,
                   help="scaling: N values, e.g. 100,1000,1e4 (default 1e2..1e6; quick 1e2..1e4)")
    p.add_argument("--seconds", type=float, default=None,
                   help="timed seconds per measurement (default 1.5; quick 0.3)")
    p.add_argument("--effects-n", type=int, default=None,
                   help="effects: N (default 1e4; quick 2000)")
    p.add_argument("--reps", type=int, default=None,
                   help="effects: round-robin rounds (default 6; quick 3)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--markdown", default=None, metavar="FILE",
                   help="also write the tables as Markdown to FILE")
    p.add_argument("--json", default=None, metavar="FILE", help="write all results as JSON")
    return p


def chosen_sections(args, sections: Sequence[str] = SECTIONS) -> list[str] | None:
    """The sections of ``args.sections``; None (after a message on stderr) if one is unknown."""
    chosen = [s.strip() for s in args.sections.split(",") if s.strip()]
    bad = [s for s in chosen if s not in sections]
    if bad:
        where = "".join(f"; {ELSEWHERE[s]}" for s in bad if s in ELSEWHERE)
        print(f"unknown section(s) {bad}; choose from {', '.join(sections)}{where}",
              file=sys.stderr)
        return None
    return chosen


def _seconds(args) -> float:
    return args.seconds if args.seconds is not None else (0.3 if args.quick else 1.5)


def run_scaling(args) -> list[dict]:
    """The scaling section with the sizes and durations of ``args``."""
    sizes = args.sizes or list(QUICK_SIZES if args.quick else FULL_SIZES)
    seconds = _seconds(args)
    _log(f"\n== scaling: disc-steps per second against N ({seconds:g} s per point)")
    return scaling(sizes, seconds, args.seed)


def run_effects(args, extra: Sequence[Contender] = ()) -> list[dict]:
    """The effects section with the size, rounds and durations of ``args``."""
    q = args.quick
    n = args.effects_n or (2000 if q else 10_000)
    reps = args.reps or (3 if q else 6)
    per = _seconds(args) / (4 if q else 5)
    _log(f"\n== effects: ns per disc-step on one thread, N = {n} ({reps} rounds)")
    return effects(n, per, reps, args.seed, extra)


def main(argv: list[str] | None = None) -> int:
    """Run the chosen sections, print their tables; returns 0 (2 on bad arguments)."""
    args = build_parser().parse_args(argv)
    sections = chosen_sections(args)
    if sections is None:
        return 2
    report = Report(argv, args.quick)
    if "scaling" in sections:
        report.section("scaling", "Scaling", run_scaling(args), scaling_table)
    if "effects" in sections:
        report.section("effects", "Cost of each effect", run_effects(args), effects_table)
    report.finish(args.markdown, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
