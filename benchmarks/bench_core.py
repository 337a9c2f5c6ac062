#!/usr/bin/env python
"""discgym's own speed: disc-steps per second from N = 10^2 to 10^6 on one and on all
threads, and the cost of each effect (absent effects cost nothing), next to a minimal
reference kernel.

    python benchmarks/bench_core.py                  # the full run, figures into out/
    python benchmarks/bench_core.py --plot docs/img  # the figures of docs/performance.md
    python benchmarks/bench_core.py --quick          # a smoke run (no figures written)

Prints plain-text tables and writes perf_scaling.png and perf_effects.png into ``--plot DIR``,
by default ``out/`` (gitignored: the tracked figures change only when asked to, with ``--plot
docs/img``); ``--quick`` writes none unless given ``--plot``. The sections and their options
are those of ``discgym bench`` (:mod:`discgym.bench`; ``--help``), e.g. ``--markdown FILE`` or
``--sizes 1e3,1e4``; this script adds the reference kernel :func:`lean_run` to the effect
table and draws the figures.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import figures
import numpy as np
from numba import njit

from discgym import Simulation, bench
from discgym.bench import RADIUS, Runner, Timing, time_steps

OUT = Path(__file__).resolve().parents[1] / "out"  # (gitignored)
LEAN_LABEL = "lean reference kernel (drift, box walls, 1 collision pass)"


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
    pos = np.ascontiguousarray(sim.positions - np.array([x0, y0]), dtype=np.float64)
    vel = np.ascontiguousarray(sim.velocities, dtype=np.float64)
    n = len(pos)
    counter = [0, 0]

    def step(k):
        counter[0] += lean_run(pos, vel, k, sim.scene.dt, RADIUS, x1 - x0, y1 - y0)
        counter[1] += k

    step(1)  # warm-up (compile or load from cache)
    counter[:] = [0, 0]
    tm = time_steps(step, n, seconds, chunks)
    return tm, counter[0] / max(n * counter[1], 1)


def lean_contender(ref: Simulation, seconds: float):
    """:func:`lean_run` as a contender of :func:`discgym.bench.effects`, on a copy of the
    reference simulation's discs."""
    n = len(ref)
    x0, y0, x1, y1 = ref.bounds.extent
    pos = np.ascontiguousarray(ref.positions - np.array([x0, y0]))
    vel = np.ascontiguousarray(ref.velocities)
    dt = ref.scene.dt
    lean_run(pos, vel, 1, dt, RADIUS, x1 - x0, y1 - y0)  # warm-up / compile
    done = {"coll": 0, "steps": 0}

    def step(k):
        done["coll"] += lean_run(pos, vel, k, dt, RADIUS, x1 - x0, y1 - y0)
        done["steps"] += k

    def stats() -> dict:
        return {"collisions_per_disc_step": done["coll"] / max(n * done["steps"], 1),
                "reactions": 0}

    return Runner(LEAN_LABEL, step, n, seconds), stats


def effects(n: int = 10_000, seconds: float = 0.25, reps: int = 5, seed: int = 0
            ) -> list[dict]:
    """:func:`discgym.bench.effects` with the reference kernel as the last row."""
    return bench.effects(n, seconds, reps, seed, extra=[lean_contender])


# ===================================================================================== main
def main(argv: list[str] | None = None) -> int:
    """Run the chosen sections, print their tables; returns 0 (2 on bad arguments)."""
    p = bench.build_parser(
        prog="bench_core.py",
        description="discgym's own speed on the benchmark scene (discs r = 1, m = 1, kT = 1, "
                    "packing 0.3, dt = 0.05): scaling with N and threads, and the cost of "
                    "each effect next to a minimal reference kernel.")
    p.add_argument("--plot", default=None, metavar="DIR",
                   help=f"write perf_scaling.png and perf_effects.png into DIR (default {OUT}, "
                        "none with --quick; docs/img for the figures of docs/performance.md)")
    args = p.parse_args(argv)
    if args.plot is None and not args.quick:
        args.plot = str(OUT)
    sections = bench.chosen_sections(args)
    if sections is None:
        return 2
    report = bench.Report(argv, args.quick)
    if args.plot:
        os.makedirs(args.plot, exist_ok=True)
    if "scaling" in sections:
        rows = bench.run_scaling(args)
        report.section("scaling", "Scaling", rows, bench.scaling_table)
        if args.plot:
            figures.save(figures.plot_scaling, rows, os.path.join(args.plot, "perf_scaling.png"))
    if "effects" in sections:
        rows = bench.run_effects(args, extra=[lean_contender])
        report.section("effects", "Cost of each effect", rows, bench.effects_table)
        if args.plot:
            figures.save(figures.plot_effects, rows, os.path.join(args.plot, "perf_effects.png"))
    report.finish(args.markdown, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
