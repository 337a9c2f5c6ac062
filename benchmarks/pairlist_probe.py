#!/usr/bin/env python
"""What would a pair (Verlet) list reused across steps cost on the benchmark gas? A probe
for the design in docs/performance.md ("Where the time goes"), not part of the integrator.

    python benchmarks/pairlist_probe.py                     # N = 1e4, skins 0.3, 0.5, 1, 2
    python benchmarks/pairlist_probe.py --n 1e5 --steps 60

Along the real trajectory of ``Simulation.step`` (one thread, one step per call), after each
step it times: the test of every listed pair for an overlap (the work that would replace
the stepped integrator's cell sort, gather and broad-phase scan), the check whether some
disc has moved more than skin / 2 since the list was built (a global rebuild criterion),
and the rebuilds that criterion asks for (a plain cell-grid build with cells of 2r + skin,
full stencil: not tuned). Below 16,384 discs the stepper does not reorder discs in memory,
so the list's indices stay valid between steps; above, the probe still measures the costs
(the reorder every 8 steps would have to rebuild the list).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from numba import njit

from discgym import Simulation
from discgym.bench import bench_scene, format_table
from discgym.kernels.celllist import cell_coord, make_grid


@njit(cache=True)
def build(n, pos, grid, cut, cell_start, cell_items, cell_of, pi, pj, ref):
    """All pairs i < j closer than ``cut`` into (pi, pj); ``ref`` gets the positions."""
    x0, y0, icx, icy = grid[0], grid[1], grid[2], grid[3]
    ncx = int(grid[4])
    ncy = int(grid[5])
    nc = ncx * ncy
    cell_start[:] = 0
    for i in range(n):
        c = cell_coord(pos[i, 0], icx, x0, ncx) + ncx * cell_coord(pos[i, 1], icy, y0, ncy)
        cell_of[i] = c
        cell_start[c + 1] += 1
    for c in range(nc):
        cell_start[c + 1] += cell_start[c]
    for i in range(n):
        c = cell_of[i]
        cell_items[cell_start[c]] = i
        cell_start[c] += 1
    for c in range(nc, 0, -1):
        cell_start[c] = cell_start[c - 1]
    cell_start[0] = 0
    m = 0
    c2 = cut * cut
    for i in range(n):
        ref[i, 0] = pos[i, 0]
        ref[i, 1] = pos[i, 1]
        c = cell_of[i]
        cx = c % ncx
        cy = c // ncx
        for y in range(max(cy - 1, 0), min(cy + 2, ncy)):
            for x in range(max(cx - 1, 0), min(cx + 2, ncx)):
                cc = x + ncx * y
                for a in range(cell_start[cc], cell_start[cc + 1]):
                    j = cell_items[a]
                    if j > i:
                        dx = pos[j, 0] - pos[i, 0]
                        dy = pos[j, 1] - pos[i, 1]
                        if dx * dx + dy * dy < c2:
                            pi[m] = i
                            pj[m] = j
                            m += 1
    return m


@njit(cache=True)
def check(m, pi, pj, pos, d):
    """How many of the m listed pairs are closer than d."""
    k = 0
    d2 = d * d
    for p in range(m):
        i = pi[p]
        j = pj[p]
        dx = pos[j, 0] - pos[i, 0]
        dy = pos[j, 1] - pos[i, 1]
        k += dx * dx + dy * dy < d2
    return k


@njit(cache=True)
def max_displacement2(n, pos, ref):
    m = 0.0
    for i in range(n):
        dx = pos[i, 0] - ref[i, 0]
        dy = pos[i, 1] - ref[i, 1]
        m = max(m, dx * dx + dy * dy)
    return m


def probe(n: int, skin: float, steps: int, seed: int = 0) -> dict:
    sim = Simulation(bench_scene(n), seed=seed)
    sim.threads = 1
    sim.step(1)
    sim.advance(5.0)
    d = 2.0 * sim.scene.species[0].radius
    cut = d + skin
    grid = make_grid(sim._bounds_kind, sim._bounds_params, cut / 2.0, n)
    nc = int(grid[4]) * int(grid[5])
    cs, ci, co = np.zeros(nc + 1, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64)
    pi, pj = np.zeros(32 * n, np.int32), np.zeros(32 * n, np.int32)
    ref = np.zeros((n, 2))
    m = build(n, sim._pos, grid, cut, cs, ci, co, pi, pj, ref)  # (compiles)
    check(m, pi, pj, sim._pos, d)
    max_displacement2(n, sim._pos, ref)
    t = {"step": 0.0, "check": 0.0, "criterion": 0.0, "build": 0.0}
    builds = pairs = 0
    for _ in range(steps):
        t0 = time.perf_counter()
        sim.step(1)
        t1 = time.perf_counter()
        md = max_displacement2(n, sim._pos, ref)
        t2 = time.perf_counter()
        t["step"] += t1 - t0
        t["criterion"] += t2 - t1
        if md > (skin / 2.0) ** 2:
            m = build(n, sim._pos, grid, cut, cs, ci, co, pi, pj, ref)
            t["build"] += time.perf_counter() - t2
            builds += 1
        t0 = time.perf_counter()
        check(m, pi, pj, sim._pos, d)
        t["check"] += time.perf_counter() - t0
        pairs += m
    f = 1e9 / (n * steps)
    return {"n": n, "skin": skin, "steps": steps, "builds": builds,
            "pairs_per_disc": pairs / (steps * n), **{k: v * f for k, v in t.items()},
            "per_build": t["build"] * 1e9 / (max(builds, 1) * n)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="pairlist_probe.py", description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=float, default=1e4)
    ap.add_argument("--skins", default="0.3,0.5,1,2")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    rows = [probe(int(args.n), float(s), args.steps) for s in args.skins.split(",")]
    head = ["skin", "steps rebuilt", "pairs/disc", "step (today)", "pair test", "criterion",
            "builds (amortised)", "one build"]
    body = [[f"{r['skin']:g}", f"{r['builds']}/{r['steps']}", f"{r['pairs_per_disc']:.2f}",
             f"{r['step']:.1f}", f"{r['check']:.2f}", f"{r['criterion']:.2f}",
             f"{r['build']:.1f}", f"{r['per_build']:.1f}"] for r in rows]
    print(f"N = {int(args.n)}, ns per disc-step (one thread)")
    print(format_table(head, body, args.markdown))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
