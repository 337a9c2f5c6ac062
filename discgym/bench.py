"""Benchmarks of the time-stepped simulator: scaling, the cost of each effect, a real peer.

Everything runs on the *benchmark scene*: elastic discs of radius 1 and mass 1 at kT = 1 in a
square box at packing fraction 0.3, time step 0.05 (:func:`bench_scene`). Three sections:

``scaling``
    disc-steps per second of :class:`discgym.Simulation` at N = 10^2 ... 10^6, on one thread
    (``sim.threads = 1``) and on all of numba's threads (the default), and the cost per
    disc-step in ns (flat in N is the goal).
``effects``
    the same population with one effect switched on at a time (walls only, collisions,
    restitution, circle bounds, first-order and bimolecular reactions, reactions whose species
    are rare or absent), each as ns per disc-step on one thread, next to :func:`lean_run`: a
    minimal numba kernel with only drift, box walls and one cell-list collision pass, which
    is the floor the full simulator is compared with.
``peers``
    pymunk (Chipmunk2D) on the same scene and the same time step: particle-steps per second
    of each and their ratio, the wall pressure of each against Henderson's equation of state,
    and the overlaps each leaves. pymunk is optional (the ``bench`` extra); without it the
    section prints a note and is skipped.

Timing: each measurement is one untimed warm-up step, one untimed probe step (to size the
first chunk), then timed chunks of ``sim.step(k)``, each sized from the one before. Things
compared with each other (one thread / all threads, discgym / pymunk, the rows of the effect
table) are timed in alternating chunks (:func:`interleave`), so load from other processes
hits them alike. Rates are given for the whole timed run and for its fastest chunk
(``best``). Nothing here asserts a time: the numbers are printed, plotted and written down
(docs/performance.md).

Command line: ``python -m discgym.bench [--quick] [--sections scaling,effects,peers]
[--plot docs/img] [--markdown FILE] [--json FILE]`` (``--help`` for the rest).
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
from numba import njit

from ._dtypes import FLOAT
from .scene import Box, Circle, Exchange, Scene, Species, Transformation
from .simulation import Simulation

__all__ = [
    "RADIUS", "MASS", "KT", "ETA", "DT", "OVERLAP_TOL",
    "henderson_z", "bench_scene", "box_side", "Timing", "time_steps", "Runner", "interleave",
    "lean_run", "lean_bench",
    "overlap_stats", "bulk_packing", "machine_info", "scaling", "effects", "peers",
    "format_table", "main",
]

RADIUS = 1.0  #: disc radius of the benchmark scene
MASS = 1.0  #: disc mass
KT = 1.0  #: temperature (k_B = 1)
ETA = 0.3  #: packing fraction
DT = 0.05  #: time step
OVERLAP_TOL = 0.01  #: pairs closer than (1 - OVERLAP_TOL) * contact distance count as overlaps
BULK_MARGIN = 10.0  #: discs this far (in radii) from every wall count for the bulk density

FULL_SIZES = (100, 1_000, 10_000, 100_000, 1_000_000)
QUICK_SIZES = (100, 1_000, 10_000)
FULL_PEERS = ((1_000, 0.05), (10_000, 0.05), (100_000, 0.05), (1_000, 0.01), (10_000, 0.01))
QUICK_PEERS = ((1_000, 0.05),)


def _log(msg: str) -> None:
    print(msg, flush=True)


# =============================================================================== the scene
def henderson_z(eta: float) -> float:
    """Henderson's equation of state of hard discs: Z = P / (n kT) = (1 + eta^2/8)/(1-eta)^2."""
    return (1.0 + eta * eta / 8.0) / (1.0 - eta) ** 2


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


def _make_sim(scene: Scene, seed: int) -> tuple[Simulation, float]:
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


# ====================================================================== lean reference kernel
@njit(cache=True)
def lean_run(pos, vel, n_steps, dt, r, width, height):
    """The minimal time-stepped hard-disc kernel: the floor the full simulator is compared with.

    ``pos``, ``vel`` (N, 2) float64, updated in place; equal discs of radius ``r`` in the box
    [0, width] x [0, height]. Each step: drift and specular box walls in one pass, binning into
    a cell list (cells >= one diameter) by counting sort, then one pass over the half stencil
    in which each overlapping, approaching pair is rewound to its contact, bounced elastically
    (equal masses) and moved forward again. No event ordering, no repeated contacts within a
    step, no substeps, reactions, counters or threads. Returns the number of collisions.
    """
    n = pos.shape[0]
    d = 2.0 * r
    ncx = max(1, int(width / d))
    ncy = max(1, int(height / d))
    icx = ncx / width
    icy = ncy / height
    cell_start = np.zeros(ncx * ncy + 1, dtype=np.int32)
    cell_of = np.empty(n, dtype=np.int32)
    items = np.empty(n, dtype=np.int32)
    ncoll = 0
    lo = r
    hx = width - r
    hy = height - r
    R2 = d * d
    for _ in range(n_steps):
        cell_start[:] = 0
        for i in range(n):
            x = pos[i, 0] + dt * vel[i, 0]
            y = pos[i, 1] + dt * vel[i, 1]
            if x < lo:
                x = 2.0 * lo - x
                vel[i, 0] = -vel[i, 0]
            elif x > hx:
                x = 2.0 * hx - x
                vel[i, 0] = -vel[i, 0]
            if y < lo:
                y = 2.0 * lo - y
                vel[i, 1] = -vel[i, 1]
            elif y > hy:
                y = 2.0 * hy - y
                vel[i, 1] = -vel[i, 1]
            pos[i, 0] = x
            pos[i, 1] = y
            cx = min(int(x * icx), ncx - 1) if x > 0.0 else 0
            cy = min(int(y * icy), ncy - 1) if y > 0.0 else 0
            c = cx + ncx * cy
            cell_of[i] = c
            cell_start[c + 1] += 1
        for c in range(ncx * ncy):
            cell_start[c + 1] += cell_start[c]
        for i in range(n):
            c = cell_of[i]
            items[cell_start[c]] = i
            cell_start[c] += 1
        for c in range(ncx * ncy, 0, -1):
            cell_start[c] = cell_start[c - 1]
        cell_start[0] = 0
        for cy in range(ncy):
            for cx in range(ncx):
                c = cx + ncx * cy
                for a in range(cell_start[c], cell_start[c + 1]):
                    i = items[a]
                    for q in range(5):  # own cell (b > a), right, and the row above
                        if q == 0:
                            b0 = a + 1
                            b1 = cell_start[c + 1]
                        else:
                            ox = 1 if q == 1 else q - 3
                            oy = 0 if q == 1 else 1
                            nx_ = cx + ox
                            ny_ = cy + oy
                            if nx_ < 0 or nx_ >= ncx or ny_ >= ncy:
                                continue
                            cc = nx_ + ncx * ny_
                            b0 = cell_start[cc]
                            b1 = cell_start[cc + 1]
                        for bb in range(b0, b1):
                            j = items[bb]
                            dx = pos[j, 0] - pos[i, 0]
                            dy = pos[j, 1] - pos[i, 1]
                            dd = dx * dx + dy * dy
                            if dd >= R2:
                                continue
                            ux = vel[j, 0] - vel[i, 0]
                            uy = vel[j, 1] - vel[i, 1]
                            bdot = dx * ux + dy * uy
                            if bdot >= 0.0:
                                continue
                            uu = ux * ux + uy * uy
                            cc2 = dd - R2
                            t = cc2 / (-bdot + math.sqrt(bdot * bdot - uu * cc2))  # <= 0
                            if t < -dt:
                                t = -dt
                            # rewind to contact, exchange the normal components, wind forward
                            xi = pos[i, 0] + t * vel[i, 0]
                            yi = pos[i, 1] + t * vel[i, 1]
                            xj = pos[j, 0] + t * vel[j, 0]
                            yj = pos[j, 1] + t * vel[j, 1]
                            ex = xj - xi
                            ey = yj - yi
                            inv = 1.0 / math.sqrt(ex * ex + ey * ey)
                            ex *= inv
                            ey *= inv
                            un = ux * ex + uy * ey
                            vel[i, 0] += un * ex
                            vel[i, 1] += un * ey
                            vel[j, 0] -= un * ex
                            vel[j, 1] -= un * ey
                            pos[i, 0] = xi - t * vel[i, 0]
                            pos[i, 1] = yi - t * vel[i, 1]
                            pos[j, 0] = xj - t * vel[j, 0]
                            pos[j, 1] = yj - t * vel[j, 1]
                            ncoll += 1
    return ncoll


def lean_bench(sim: Simulation, seconds: float, chunks: int = 3) -> tuple[Timing, float]:
    """Time :func:`lean_run` on a copy of a box simulation's discs (all of radius RADIUS, box
    at the origin). Returns the timing and the collisions per disc-step."""
    x0, y0, x1, y1 = sim.bounds.extent
    pos = np.ascontiguousarray(sim.positions - np.array([x0, y0]), dtype=FLOAT)
    vel = np.ascontiguousarray(sim.velocities, dtype=FLOAT)
    n = len(pos)
    counter = [0, 0]

    def step(k):
        counter[0] += lean_run(pos, vel, k, sim.scene.dt, RADIUS, x1 - x0, y1 - y0)
        counter[1] += k

    step(1)  # warm-up (compile or load from cache)
    counter[:] = [0, 0]
    tm = time_steps(step, n, seconds, chunks)
    return tm, counter[0] / max(n * counter[1], 1)


# ============================================================================ accuracy probes
@njit(cache=True)
def overlap_stats(pos, r, tol):
    """Overlaps among equal discs of radius ``r`` at ``pos`` (N, 2).

    Returns ``(count, deepest)``: the number of pairs closer than ``(1 - tol) * 2r`` and the
    largest overlap ``(2r - distance) / (2r)`` of any pair (0.0 if none touch).
    """
    n = pos.shape[0]
    if n < 2:
        return 0, 0.0
    d = 2.0 * r
    xmin = pos[:, 0].min()
    ymin = pos[:, 1].min()
    w = max(pos[:, 0].max() - xmin, d)
    h = max(pos[:, 1].max() - ymin, d)
    ncx = max(1, min(int(w / d), 1 << 13))
    ncy = max(1, min(int(h / d), 1 << 13))
    icx = ncx / w
    icy = ncy / h
    start = np.zeros(ncx * ncy + 1, dtype=np.int64)
    cell = np.empty(n, dtype=np.int64)
    items = np.empty(n, dtype=np.int64)
    for i in range(n):
        cx = min(int((pos[i, 0] - xmin) * icx), ncx - 1)
        cy = min(int((pos[i, 1] - ymin) * icy), ncy - 1)
        cell[i] = cx + ncx * cy
        start[cell[i] + 1] += 1
    for c in range(ncx * ncy):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    for i in range(n):
        items[fill[cell[i]]] = i
        fill[cell[i]] += 1
    lim2 = (d * (1.0 - tol)) ** 2
    count = 0
    deepest = 0.0
    for i in range(n):
        cx = cell[i] % ncx
        cy = cell[i] // ncx
        for oy in range(-1, 2):
            for ox in range(-1, 2):
                x = cx + ox
                y = cy + oy
                if x < 0 or y < 0 or x >= ncx or y >= ncy:
                    continue
                c = x + ncx * y
                for a in range(start[c], start[c + 1]):
                    j = items[a]
                    if j <= i:
                        continue
                    dx = pos[j, 0] - pos[i, 0]
                    dy = pos[j, 1] - pos[i, 1]
                    dd = dx * dx + dy * dy
                    if dd < d * d:
                        ov = (d - math.sqrt(dd)) / d
                        if ov > deepest:
                            deepest = ov
                        if dd < lim2:
                            count += 1
    return count, deepest


def bulk_packing(pos: np.ndarray, extent, r: float = RADIUS, margin: float = BULK_MARGIN
                 ) -> float:
    """Packing fraction of the discs whose centres lie at least ``margin * r`` from every
    wall of the box ``extent`` = (x0, y0, x1, y1) (the bulk, away from the wall layers).
    The margin shrinks to a quarter of the box for small boxes."""
    x0, y0, x1, y1 = extent
    m = min(margin * r, 0.25 * (x1 - x0), 0.25 * (y1 - y0))
    inside = ((pos[:, 0] >= x0 + m) & (pos[:, 0] <= x1 - m) &
              (pos[:, 1] >= y0 + m) & (pos[:, 1] <= y1 - m))
    area = (x1 - x0 - 2 * m) * (y1 - y0 - 2 * m)
    return float(inside.sum() * math.pi * r * r / area)


def wall_penetration(pos: np.ndarray, extent, r: float = RADIUS) -> float:
    """Deepest reach of a disc beyond a box wall, as a fraction of r (0 if none)."""
    x0, y0, x1, y1 = extent
    over = np.maximum.reduce([x0 + r - pos[:, 0], pos[:, 0] - (x1 - r),
                              y0 + r - pos[:, 1], pos[:, 1] - (y1 - r)])
    return float(max(over.max(initial=0.0), 0.0) / r)


# ================================================================================== machine
def machine_info() -> dict:
    """Date, CPU, cores, load and versions: the header every table is printed with."""
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
    info = {
        "date": datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z"),
        "cpu": cpu,
        "nproc": os.cpu_count(),
        "numba_threads": numba.get_num_threads(),
        "load_avg": [round(x, 2) for x in load],
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
    }
    try:
        import pymunk

        info["pymunk"] = f"{pymunk.version} (Chipmunk {pymunk.chipmunk_version.split('-')[0]})"
    except ImportError:
        info["pymunk"] = None
    return info


def _machine_line(info: dict) -> str:
    return (f"{info['date']}; {info['cpu']}, nproc = {info['nproc']}, numba threads = "
            f"{info['numba_threads']}; load average {info['load_avg'][0]:.2f} at the start; "
            f"python {info['python']}, numpy {info['numpy']}, numba {info['numba']}"
            + (f", pymunk {info['pymunk']}" if info.get("pymunk") else ""))


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


def _n(n: int) -> str:
    e = int(round(math.log10(n))) if n > 0 else 0
    return f"1e{e}" if n == 10 ** e else str(n)


def _m(rate: float) -> str:
    return f"{rate / 1e6:.2f}"


# ================================================================================== scaling
def scaling(sizes: Sequence[int] = FULL_SIZES, seconds: float = 1.5, seed: int = 0,
            chunks: int = 3) -> list[dict]:
    """Disc-steps per second at each N, on one thread and on all threads (the default),
    timed in alternating chunks (``seconds`` each in all) on the same simulation."""
    rows = []
    for n in sizes:
        sim, placed = _make_sim(bench_scene(n), seed)
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
    body = [[_n(r["n"]), f"{r['place_s']:.2f}", r["one"]["steps"], _m(r["one"]["rate"]),
             _m(r["one"]["rate_best"]), f"{r['one']['ns']:.0f}", r["all"]["steps"],
             _m(r["all"]["rate"]), _m(r["all"]["rate_best"]), f"{r['all']['ns']:.0f}",
             f"{r['speedup']:.2f}", f"{r['one']['collisions_per_disc_step']:.4f}"]
            for r in rows]
    return format_table(headers, body, markdown)


# ================================================================================== effects
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
        ("elastic discs (reference, again)", bench_scene(n), False),
    ]


def effects(n: int = 10_000, seconds: float = 0.25, reps: int = 5, seed: int = 0) -> list[dict]:
    """ns per disc-step on one thread for each effect, timed in ``reps`` interleaved rounds
    of about ``seconds`` per row (so a burst of load from elsewhere hits every row alike);
    the temperature is restored to kT = 1 (untimed) before each chunk of the inelastic row."""
    cases, runners = [], []
    for label, scene, restore in effect_scenes(n):
        sim, _ = _make_sim(scene, seed)
        sim.threads = 1
        sim.step(1)
        between = (lambda sim=sim: sim.scale_temperature(KT / sim.temperature())) \
            if restore else None
        cases.append({"label": label, "sim": sim, "c0": sim.counters(), "t0": sim.time})
        runners.append(Runner(label, sim.step, len(sim), seconds * reps, between=between))
    ref = cases[1]["sim"]
    x0, y0, x1, y1 = ref.bounds.extent
    lean_pos = np.ascontiguousarray(ref.positions - np.array([x0, y0]))
    lean_vel = np.ascontiguousarray(ref.velocities)
    lean_run(lean_pos, lean_vel, 1, DT, RADIUS, x1 - x0, y1 - y0)  # warm-up / compile
    lean = {"coll": 0, "steps": 0}

    def lean_step(k):
        lean["coll"] += lean_run(lean_pos, lean_vel, k, DT, RADIUS, x1 - x0, y1 - y0)
        lean["steps"] += k

    runners.append(Runner("lean reference kernel (drift, box walls, 1 collision pass)",
                          lean_step, n, seconds * reps))
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
    tm = runners[-1].timing
    rows.append({"label": runners[-1].name, "n": n, "steps": tm.total_steps,
                 "ns_best": tm.ns_best, "ns_median": _median_ns(tm), "ns": tm.ns,
                 "collisions_per_disc_step": lean["coll"] / max(n * lean["steps"], 1),
                 "reactions": 0})
    ref = [r["ns_best"] for r in rows if r["label"].startswith("elastic discs (reference")]
    ref_ns = float(np.mean(ref))
    for row in rows:
        row["vs_reference"] = row["ns_best"] / ref_ns - 1.0
        row["extra_ns"] = row["ns_best"] - ref_ns
    return rows


def _median_ns(tm: Timing) -> float:
    return float(np.median([w / (tm.n * s) * 1e9 for s, w in zip(tm.steps, tm.seconds)]))


def effects_table(rows, markdown=False) -> str:
    headers = [f"effect (N = {_n(rows[0]['n'])}, one thread)", "ns/disc-step (best)",
               "median", "extra ns", "vs reference", "coll/disc-step", "reactions"]
    body = [[r["label"], f"{r['ns_best']:.1f}", f"{r['ns_median']:.1f}",
             f"{r['extra_ns']:+.1f}", f"{100 * r['vs_reference']:+.1f}%",
             f"{r['collisions_per_disc_step']:.4f}", r["reactions"]] for r in rows]
    return format_table(headers, body, markdown)


# ==================================================================================== peers
def _have_pymunk() -> bool:
    try:
        import pymunk  # noqa: F401
    except ImportError:
        return False
    return True


class _PymunkBox:
    """The benchmark scene in pymunk: circles (elasticity 1, friction 0) in a box of four
    static segments whose inner faces are the box walls; no gravity, no damping; pymunk's
    other settings at their defaults (10 solver iterations, collision slop 0.1). ``index``:
    pymunk's bounding-box tree (its default) or its spatial hash (cell = one diameter). The
    wall pressure is the sum of the impulses pymunk applies on disc-wall contacts
    (``post_solve`` ``total_impulse``)."""

    DISC, WALL = 1, 2

    def __init__(self, pos: np.ndarray, vel: np.ndarray, extent, threads: int = 1,
                 index: str = "tree"):
        import pymunk

        self.extent = extent
        self.index = index
        x0, y0, x1, y1 = extent
        self.space = space = pymunk.Space(threaded=threads > 1)
        if threads > 1:
            space.threads = threads
        if index == "hash":
            space.use_spatial_hash(2.0 * RADIUS, 10 * len(pos))
        elif index != "tree":
            raise ValueError(f"index must be 'tree' or 'hash', got {index!r}")
        space.gravity = (0.0, 0.0)
        moment = pymunk.moment_for_circle(MASS, 0.0, RADIUS)
        self.bodies = []
        objs = []
        for p, v in zip(pos, vel):
            b = pymunk.Body(MASS, moment)
            b.position = (float(p[0]), float(p[1]))
            b.velocity = (float(v[0]), float(v[1]))
            s = pymunk.Circle(b, RADIUS)
            s.elasticity = 1.0
            s.friction = 0.0
            s.collision_type = self.DISC
            self.bodies.append(b)
            objs += [b, s]
        w = 2.0 * RADIUS  # wall half-thickness; inner face on the box edge
        corners = [(x0 - w, y0 - w), (x1 + w, y0 - w), (x1 + w, y1 + w), (x0 - w, y1 + w)]
        for k in range(4):
            s = pymunk.Segment(space.static_body, corners[k], corners[(k + 1) % 4], w)
            s.elasticity = 1.0
            s.friction = 0.0
            s.collision_type = self.WALL
            objs.append(s)
        space.add(*objs)
        self.impulse = 0.0
        self.time = 0.0

        def post_solve(arbiter, space, data):
            self.impulse += arbiter.total_impulse.length

        space.on_collision(self.DISC, self.WALL, post_solve=post_solve)

    def step(self, k: int, dt: float) -> None:
        st = self.space.step
        for _ in range(k):
            st(dt)
        self.time += k * dt

    def positions(self) -> np.ndarray:
        return np.array([tuple(b.position) for b in self.bodies], dtype=FLOAT)

    def velocities(self) -> np.ndarray:
        return np.array([tuple(b.velocity) for b in self.bodies], dtype=FLOAT)

    def temperature(self) -> float:
        v = self.velocities()
        return float(0.5 * MASS * (v * v).sum() / len(v))


def _accuracy(code, n, dt, extent, blocks, kts, etas, pos_end, t_start, t_end) -> dict:
    """Pressure (from the wall-impulse blocks), its error against Henderson, overlaps."""
    x0, y0, x1, y1 = extent
    perim = 2.0 * ((x1 - x0) + (y1 - y0))
    area = (x1 - x0) * (y1 - y0)
    kt = float(np.mean(kts))
    # merge short blocks (the probe steps) into their neighbours: blocks of about equal length
    durs = [d for _, d in blocks if d > 0]
    merged, acc_i, acc_d = [], 0.0, 0.0
    for imp, d in blocks:
        acc_i += imp
        acc_d += d
        if acc_d >= 0.5 * float(np.median(durs)):
            merged.append((acc_i, acc_d))
            acc_i, acc_d = 0.0, 0.0
    if acc_d > 0 and merged:
        merged[-1] = (merged[-1][0] + acc_i, merged[-1][1] + acc_d)
    zs = np.array([imp / (d * perim) * area / (n * kt) for imp, d in merged])
    dur = sum(d for _, d in blocks)
    z = sum(imp for imp, _ in blocks) / (dur * perim) * area / (n * kt)
    se = float(zs.std(ddof=1) / math.sqrt(len(zs))) if len(zs) > 1 else math.nan
    eta_box = n * math.pi * RADIUS ** 2 / area
    eta_bulk = float(np.mean(etas))
    count, deepest = overlap_stats(np.ascontiguousarray(pos_end), RADIUS, OVERLAP_TOL)
    return {"code": code, "n": n, "dt": dt, "sim_time": dur, "z": z, "z_se": se, "kt": kt,
            "kt_drift": t_end / t_start - 1.0, "eta_box": eta_box, "eta_bulk": eta_bulk,
            "err_box": z / henderson_z(eta_box) - 1.0,
            "err_bulk": z / henderson_z(eta_bulk) - 1.0,
            "overlaps": int(count), "max_overlap": float(deepest),
            "wall_penetration": wall_penetration(pos_end, extent),
            "escaped": int(((pos_end[:, 0] < x0) | (pos_end[:, 0] > x1) | (pos_end[:, 1] < y0)
                            | (pos_end[:, 1] > y1)).sum())}


class _WallPressure:
    """Pressure bookkeeping of one code: ``mark()`` closes a block of (impulse, duration)
    and takes a snapshot (temperature, bulk packing) between timed chunks."""

    def __init__(self, impulse: Callable[[], float], elapsed: Callable[[], float],
                 temperature: Callable[[], float], positions: Callable[[], np.ndarray],
                 extent):
        self.impulse, self.elapsed, self.temperature = impulse, elapsed, temperature
        self.positions, self.extent = positions, extent
        self.blocks, self.kts, self.etas = [], [], []
        self.t0 = temperature()
        self.last = (0.0, 0.0)

    def mark(self) -> None:
        t, p = self.elapsed(), self.impulse()
        if t > self.last[0]:
            self.blocks.append((p - self.last[1], t - self.last[0]))
        self.last = (t, p)
        self.kts.append(self.temperature())
        self.etas.append(bulk_packing(self.positions(), self.extent))

    def result(self, code: str, n: int, dt: float) -> dict:
        self.mark()
        return _accuracy(code, n, dt, self.extent, self.blocks, self.kts, self.etas,
                         self.positions(), self.t0, self.temperature())


def _sim_pressure(sim: Simulation, extent) -> _WallPressure:
    sim.reset_counters()
    t_reset = sim.time
    perim = sim.bounds.perimeter
    return _WallPressure(lambda: sim.pressure() * (sim.time - t_reset) * perim,
                         lambda: sim.time - t_reset, sim.temperature, lambda: sim.positions,
                         extent)


def _exact_run(scene: Scene, pos0, vel0, extent, seconds: float, chunks: int) -> dict | None:
    """The event-driven integrator from (pos0, vel0): pressure, overlaps, throughput in
    disc-steps of ``scene.dt`` per second. None if this discgym has no such integrator."""
    n = len(pos0)
    try:
        ev = Simulation.from_arrays(scene, pos0, vel0, np.zeros(n, dtype=np.int64),
                                    integrator="event")
    except (TypeError, ValueError):
        return None
    ev.step(1)  # warm-up
    wp = _sim_pressure(ev, extent)
    c0 = ev.counters()
    r = Runner("exact", ev.step, n, seconds, between=wp.mark)
    interleave([r], chunks)
    acc = wp.result("discgym event (exact)", n, scene.dt)
    acc.update(rate_one=r.timing.rate, rate_one_best=r.timing.rate_best,
               steps_one=r.timing.total_steps,
               collisions_per_second=(ev.collisions - c0["collisions"]) / r.timing.wall)
    return acc


def peer_run(n: int, dt: float = DT, seconds: float = 1.5, chunks: int = 6,
             pymunk_seconds: float | None = None, pymunk_min_steps: int = 1,
             pymunk_max_steps: int | None = None, equilibrate: float = 10.0,
             seed: int = 0, exact: bool = True, exact_ref: dict | None = None) -> dict:
    """discgym against pymunk at one (N, dt), from the same equilibrated state.

    discgym runs ``equilibrate`` time units from its placement; every code then starts from
    that state. pymunk is built with its bounding-box tree and with its spatial hash (cell =
    one diameter), each timed briefly, and the faster is kept. Then four contenders are timed
    in alternating chunks (:func:`interleave`, ``chunks`` rounds), so that load from other
    processes hits them alike: discgym on one thread and on all threads (``seconds`` each,
    one simulation: its pressure, temperature and overlaps come from both), pymunk on one
    thread (``pymunk_seconds``, default ``seconds``, within [``pymunk_min_steps``,
    ``pymunk_max_steps``] steps; its pressure and overlaps) and pymunk threaded
    (``Space(threaded=True)``, ``threads = nproc``; half as long; throughput only).

    With ``exact``, discgym's event-driven integrator (``integrator="event"``, if this version
    has it) runs from the same state for ``seconds``: the exact reference every pressure is
    also compared with (``exact_ref``: a result of an earlier run at the same N to reuse).
    """
    scene = bench_scene(n, dt=dt)
    sim, placed = _make_sim(scene, seed)
    all_threads = sim.threads
    sim.step(1)
    sim.advance(equilibrate)
    pos0, vel0 = sim.positions, sim.velocities
    extent = sim.bounds.extent
    out = {"n": n, "dt": dt, "place_s": placed}

    if exact_ref is None and exact:
        exact_ref = _exact_run(scene, pos0, vel0, extent, seconds, chunks)
    out["exact"] = exact_ref
    if exact_ref:
        _log(f"    discgym event-driven (exact): Z = {exact_ref['z']:.4f} +- "
             f"{exact_ref['z_se']:.4f}; {exact_ref['sim_time']:.0f} time units")

    def set_threads(th):
        sim.threads = th

    dgp = _sim_pressure(sim, extent)
    c0, t_reset = sim.counters(), sim.time
    runners = [Runner("discgym one", sim.step, n, seconds, between=dgp.mark,
                      before=lambda: set_threads(1)),
               Runner("discgym all", sim.step, n, seconds, between=dgp.mark,
                      before=lambda: set_threads(all_threads))]

    pm = pmt = pmp = None
    if _have_pymunk():
        pm_seconds = seconds if pymunk_seconds is None else pymunk_seconds
        trial = {}
        for index in ("tree", "hash"):
            t0 = time.perf_counter()
            cand = _PymunkBox(pos0, vel0, extent, index=index)
            out[f"pymunk_build_s_{index}"] = time.perf_counter() - t0
            cand.step(1, dt)  # warm-up
            trial[index] = time_steps(lambda k, c=cand: c.step(k, dt), n,
                                      min(0.1 * pm_seconds, 2.0), chunks=1,
                                      max_steps=pymunk_max_steps).rate
            if pm is None or trial[index] > trial[pm.index]:
                pm = cand
            cand = None
        out["pymunk_index"] = pm.index
        out["pymunk_trial_rates"] = trial
        pm.impulse, pm.time = 0.0, 0.0
        pmp = _WallPressure(lambda: pm.impulse, lambda: pm.time, pm.temperature,
                            pm.positions, extent)
        lo = -(-pymunk_min_steps // chunks)
        hi = None if pymunk_max_steps is None else max(1, pymunk_max_steps // chunks)
        runners.append(Runner("pymunk one", lambda k: pm.step(k, dt), n, pm_seconds,
                              between=pmp.mark, lo=lo, hi=hi))
        threads = os.cpu_count() or 1
        if threads > 1:
            pmt = _PymunkBox(pos0, vel0, extent, threads=threads, index=pm.index)
            pmt.step(1, dt)
            runners.append(Runner("pymunk threaded", lambda k: pmt.step(k, dt), n,
                                  pm_seconds / 2, lo=max(1, lo // 2),
                                  hi=None if hi is None else max(1, hi // 2)))
    interleave(runners, chunks)
    tm = {r.name: r.timing for r in runners}

    c1 = sim.counters()
    acc = dgp.result("discgym", n, dt)
    acc.update(rate_one=tm["discgym one"].rate, rate_all=tm["discgym all"].rate,
               rate_one_best=tm["discgym one"].rate_best,
               rate_all_best=tm["discgym all"].rate_best,
               steps_one=tm["discgym one"].total_steps, steps_all=tm["discgym all"].total_steps,
               threads_all=numba.get_num_threads(),
               collisions_per_disc_step=(c1["collisions"] - c0["collisions"])
               / (n * round((sim.time - t_reset) / dt)))
    out["discgym"] = acc
    _log(f"    discgym: {acc['rate_one'] / 1e6:.2f} M/s (1 thread), "
         f"{acc['rate_all'] / 1e6:.2f} M/s (all); Z = {acc['z']:.4f}; "
         f"{acc['sim_time']:.0f} time units")
    if pm is None:
        out["pymunk"] = None
        return out
    acc = pmp.result("pymunk", n, dt)
    one = tm["pymunk one"]
    thr = tm.get("pymunk threaded", one)
    acc.update(rate_one=one.rate, rate_one_best=one.rate_best, steps_one=one.total_steps,
               rate_all=thr.rate, rate_all_best=thr.rate_best, steps_all=thr.total_steps,
               threads_all=os.cpu_count() if pmt is not None else 1, index=pm.index)
    out["pymunk"] = acc
    out["ratio_one"] = out["discgym"]["rate_one"] / acc["rate_one"]
    out["ratio_all"] = out["discgym"]["rate_all"] / acc["rate_all"]
    _log(f"    pymunk ({pm.index}): {acc['rate_one'] / 1e6:.2f} M/s (1 thread), "
         f"{acc['rate_all'] / 1e6:.2f} M/s (threaded); Z = {acc['z']:.4f}; "
         f"{acc['sim_time']:.0f} time units; ratio {out['ratio_one']:.1f}x")
    return out


def peers(cases: Sequence[tuple[int, float]] = FULL_PEERS, seconds: float = 1.5,
          pymunk_seconds: float | None = None, pymunk_min_steps: int = 40,
          pymunk_max_steps: int | None = 200, cap_from: int = 100_000,
          equilibrate: float = 10.0, seed: int = 0, exact: bool = True) -> list[dict]:
    """:func:`peer_run` for each (N, dt). At N >= ``cap_from`` (where pymunk is slow) its
    timed steps are held between ``pymunk_min_steps`` and ``pymunk_max_steps``. The exact
    (event-driven) reference is run once per N."""
    rows, exact_at = [], {}
    for n, dt in cases:
        _log(f"  N = {n}, dt = {dt}")
        big = n >= cap_from
        row = peer_run(n, dt, seconds, pymunk_seconds=pymunk_seconds,
                       pymunk_min_steps=pymunk_min_steps if big else 1,
                       pymunk_max_steps=pymunk_max_steps if big else None,
                       equilibrate=equilibrate, seed=seed, exact=exact,
                       exact_ref=exact_at.get(n))
        exact_at.setdefault(n, row.get("exact"))
        rows.append(row)
    return rows


def peers_tables(rows, markdown=False) -> str:
    h1 = ["N", "dt", "discgym M/s 1t", "pymunk M/s 1t", "ratio", "discgym M/s all",
          "pymunk M/s thr", "ratio", "pymunk index"]
    b1 = []
    for r in rows:
        d, p = r["discgym"], r.get("pymunk")
        b1.append([_n(r["n"]), r["dt"], _m(d["rate_one"]), _m(p["rate_one"]) if p else "-",
                   f"{r['ratio_one']:.1f}x" if p else "-", _m(d["rate_all"]),
                   _m(p["rate_all"]) if p else "-", f"{r['ratio_all']:.1f}x" if p else "-",
                   r.get("pymunk_index", "-")])
    h2 = ["N", "dt", "code", "sim time", "Z meas", "+-", "err vs exact",
          "err vs Z_H(eta_bulk)", "err vs Z_H(eta_box)", "kT drift", "overlaps>1%",
          "max overlap", "wall pen."]
    b2 = []
    for r in rows:
        ex = r.get("exact")
        for code in ("exact", "discgym", "pymunk"):
            a = r.get(code)
            if not a:
                continue
            if code == "exact" and any(q is not r and q.get("exact") is ex and q["n"] == r["n"]
                                       for q in rows[:rows.index(r)]):
                continue  # the same reference, already listed
            if ex and code != "exact":
                e = a["z"] / ex["z"] - 1.0
                se = math.hypot(a["z_se"] / a["z"], ex["z_se"] / ex["z"])
                vs_exact = f"{100 * e:+.2f}% +- {100 * se:.2f}%"
            else:
                vs_exact = "-"
            b2.append([_n(r["n"]), "-" if code == "exact" else r["dt"], a["code"],
                       f"{a['sim_time']:.1f}", f"{a['z']:.4f}", f"{a['z_se']:.4f}", vs_exact,
                       f"{100 * a['err_bulk']:+.2f}%", f"{100 * a['err_box']:+.2f}%",
                       f"{100 * a['kt_drift']:+.3f}%", a["overlaps"], f"{a['max_overlap']:.2e}",
                       f"{a['wall_penetration']:.2e}"])
    sep = "\n\n"
    return (format_table(h1, b1, markdown) + sep + format_table(h2, b2, markdown))


# ==================================================================================== plots
def _log_axis(ax, values) -> None:
    """Whole decades around ``values`` on a log y axis, without minor-tick labels."""
    from matplotlib.ticker import NullFormatter

    lo = 10 ** math.floor(math.log10(min(values)))
    hi = 10 ** math.ceil(math.log10(max(values)))
    ax.set_ylim(lo, hi)
    ax.yaxis.set_minor_formatter(NullFormatter())


def plot_scaling(rows, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ns = [r["n"] for r in rows]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    a1.loglog(ns, [r["one"]["rate"] for r in rows], "o-", label="discgym, 1 thread")
    a1.loglog(ns, [r["all"]["rate"] for r in rows], "s-",
              label=f"discgym, all threads ({numba.get_num_threads()})")
    a1.axhline(12e6, color="gray", ls=":", label="target at N = 1e4: 12 M/s")
    _log_axis(a1, [r[k]["rate"] for r in rows for k in ("one", "all")] + [12e6])
    a1.set_xlabel("N discs")
    a1.set_ylabel("disc-steps per second")
    a1.set_title("Throughput (packing 0.3, dt = 0.05)")
    a1.grid(True, which="both", alpha=0.3)
    a1.legend()
    a2.semilogx(ns, [r["one"]["ns"] for r in rows], "o-", label="1 thread")
    a2.semilogx(ns, [r["all"]["ns"] for r in rows], "s-", label="all threads")
    a2.set_ylim(bottom=0)
    a2.set_xlabel("N discs")
    a2.set_ylabel("ns per disc-step")
    a2.set_title("Cost per disc-step")
    a2.grid(True, which="both", alpha=0.3)
    a2.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_peers(rows, path, dt=DT) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = sorted((r for r in rows if r["dt"] == dt), key=lambda r: r["n"])
    ns = [r["n"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.loglog(ns, [r["discgym"]["rate_one"] for r in rows], "o-", label="discgym, 1 thread")
    ax.loglog(ns, [r["discgym"]["rate_all"] for r in rows], "s-",
              label="discgym, all threads")
    if rows and rows[0].get("pymunk"):
        ax.loglog(ns, [r["pymunk"]["rate_one"] for r in rows], "v--", label="pymunk, 1 thread")
        ax.loglog(ns, [r["pymunk"]["rate_all"] for r in rows], "^--",
                  label="pymunk, threaded")
    _log_axis(ax, [r[c][k] for r in rows for c in ("discgym", "pymunk") if r.get(c)
                   for k in ("rate_one", "rate_all")])
    ax.set_xlabel("N discs")
    ax.set_ylabel("disc-steps per second")
    ax.set_title(f"discgym vs pymunk (packing 0.3, dt = {dt})")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_effects(rows, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 0.45 * len(rows) + 1.2))
    y = np.arange(len(rows))[::-1]
    ax.barh(y, [r["ns_best"] for r in rows], color="#4c72b0")
    ax.set_yticks(y, [r["label"] for r in rows], fontsize=8)
    ax.set_xlabel(f"ns per disc-step (N = {rows[0]['n']}, one thread, best of the rounds)")
    ax.set_title("Cost of each effect")
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ===================================================================================== main
def _ints(text: str) -> list[int]:
    return [int(float(x)) for x in text.split(",") if x.strip()]


def _cases(text: str) -> list[tuple[int, float]]:
    out = []
    for item in text.split(","):
        if item.strip():
            n, _, dt = item.partition("@")
            out.append((int(float(n)), float(dt) if dt else DT))
    return out


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="discgym bench",
        description="Benchmarks of discgym on the benchmark scene (discs r = 1, m = 1, kT = 1, "
                    "packing 0.3, dt = 0.05): scaling with N and threads, the cost of each "
                    "effect, and pymunk on the same scene.")
    p.add_argument("--quick", action="store_true",
                   help="small sizes and short timings (under a minute once compiled)")
    p.add_argument("--sections", default="scaling,effects,peers",
                   help="comma-separated: scaling, effects, peers (default: all)")
    p.add_argument("--sizes", type=_ints, default=None,
                   help="scaling: N values, e.g. 100,1000,1e4 (default 1e2..1e6; quick 1e2..1e4)")
    p.add_argument("--seconds", type=float, default=None,
                   help="timed seconds per measurement (default 1.5; quick 0.3)")
    p.add_argument("--effects-n", type=int, default=None,
                   help="effects: N (default 1e4; quick 2000)")
    p.add_argument("--reps", type=int, default=None,
                   help="effects: round-robin rounds (default 6; quick 3)")
    p.add_argument("--peers", type=_cases, default=None, dest="peer_cases",
                   help="peers: N@dt list, e.g. 1e3@0.05,1e4@0.05 (default 1e3, 1e4, 1e5 at "
                        "0.05 and 1e3, 1e4 at 0.01; quick 1e3@0.05)")
    p.add_argument("--peer-seconds", type=float, default=None,
                   help="peers: discgym's timed seconds per thread setting (default 3; quick 0.5)")
    p.add_argument("--pymunk-seconds", type=float, default=None,
                   help="peers: pymunk's timed seconds on one thread (default 10; quick 1)")
    p.add_argument("--pymunk-steps", default=None, metavar="MIN,MAX",
                   help="peers: at N >= 1e5, pymunk's timed steps are held in [MIN, MAX] "
                        "(default 40,200)")
    p.add_argument("--equilibrate", type=float, default=None,
                   help="peers: simulated time run before measuring (default 10; quick 5)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--plot", default=None, metavar="DIR",
                   help="write perf_scaling.png, perf_effects.png, perf_peers.png into DIR")
    p.add_argument("--markdown", default=None, metavar="FILE",
                   help="also write the tables as Markdown to FILE")
    p.add_argument("--json", default=None, metavar="FILE", help="write all results as JSON")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the chosen sections, print their tables; returns 0 (2 on bad arguments)."""
    args = _parser().parse_args(argv)
    sections = [s.strip() for s in args.sections.split(",") if s.strip()]
    bad = [s for s in sections if s not in ("scaling", "effects", "peers")]
    if bad:
        print(f"unknown section(s) {bad}; choose from scaling, effects, peers", file=sys.stderr)
        return 2
    q = args.quick
    seconds = args.seconds if args.seconds is not None else (0.3 if q else 1.5)
    info = machine_info()
    results: dict = {"machine": info, "argv": list(sys.argv[1:] if argv is None else argv)}
    md = [f"Machine: {_machine_line(info)}", ""]
    _log(f"discgym benchmarks{' (quick)' if q else ''}: {_machine_line(info)}")
    _log("(the first run in a fresh checkout compiles the kernels: about a minute)")
    if args.plot:
        os.makedirs(args.plot, exist_ok=True)

    if "scaling" in sections:
        sizes = args.sizes or list(QUICK_SIZES if q else FULL_SIZES)
        _log(f"\n== scaling: disc-steps per second against N ({seconds:g} s per point)")
        rows = scaling(sizes, seconds, args.seed)
        results["scaling"] = rows
        txt = scaling_table(rows)
        _log("\n" + txt)
        md += ["### Scaling", "", scaling_table(rows, True), ""]
        if args.plot:
            _plot(plot_scaling, rows, os.path.join(args.plot, "perf_scaling.png"))

    if "effects" in sections:
        n = args.effects_n or (2000 if q else 10_000)
        reps = args.reps or (3 if q else 6)
        per = seconds / 4 if q else seconds / 5
        _log(f"\n== effects: ns per disc-step on one thread, N = {n} ({reps} rounds)")
        rows = effects(n, per, reps, args.seed)
        results["effects"] = rows
        _log("\n" + effects_table(rows))
        md += ["### Cost of each effect", "", effects_table(rows, True), ""]
        if args.plot:
            _plot(plot_effects, rows, os.path.join(args.plot, "perf_effects.png"))

    if "peers" in sections:
        cases = args.peer_cases or list(QUICK_PEERS if q else FULL_PEERS)
        _log("\n== peers: discgym against pymunk on the same scene and time step")
        if not _have_pymunk():
            _log("NOTE: pymunk is not installed (pip install 'discgym[bench]'); only discgym's "
                 "side of the comparison is measured.")
        lo, hi = _ints(args.pymunk_steps) if args.pymunk_steps else (40, 200)
        rows = peers(cases, args.peer_seconds or (0.5 if q else 3.0),
                     pymunk_seconds=args.pymunk_seconds or (1.0 if q else 10.0),
                     pymunk_min_steps=lo, pymunk_max_steps=hi,
                     equilibrate=args.equilibrate or (5.0 if q else 10.0), seed=args.seed)
        results["peers"] = rows
        _log("\n" + peers_tables(rows))
        _log("Z from the momentum given to the walls (pymunk: post_solve total_impulse on the "
             "wall segments); Henderson Z_H = (1 + eta^2/8)/(1 - eta)^2 at the bulk packing "
             f"(discs >= {BULK_MARGIN:g} r from the walls) and at N pi r^2 / box area; "
             f"overlaps: pairs closer than {1 - OVERLAP_TOL:g} x 2r at the end; max overlap and "
             "wall penetration as fractions of 2r and r.")
        md += ["### discgym against pymunk", "", peers_tables(rows, True), ""]
        if args.plot:
            _plot(plot_peers, rows, os.path.join(args.plot, "perf_peers.png"))

    info["load_avg_end"] = [round(x, 2) for x in os.getloadavg()]
    _log(f"\nload average at the end: {info['load_avg_end'][0]:.2f}")
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write("\n".join(md) + "\n")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1, default=_jsonable)
    return 0


def _plot(fn, rows, path) -> None:
    try:
        fn(rows, path)
        _log(f"wrote {path}")
    except ImportError:
        _log(f"matplotlib is not installed: {path} not written")


def _jsonable(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, Timing):
        return asdict(o)
    return str(o)


if __name__ == "__main__":
    sys.exit(main())
