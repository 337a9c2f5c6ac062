#!/usr/bin/env python
"""Collisions per second of the event-driven integrator in two checkouts, as ratios of
interleaved runs (for a change that must keep the trajectories: the collision counts are
asserted equal), on the benchmark gas (r = 1, m = 1, kT = 1, packing 0.3, square box).

    python benchmarks/bench_event_ab.py OLD NEW                  # N = 1e3, 1e4; 7 pairs
    python benchmarks/bench_event_ab.py OLD NEW --sizes 1e5 --pairs 5 --per-step

OLD and NEW are checkouts (e.g. ``git worktree add --detach /tmp/old main``); each run is a
separate process with ``PYTHONPATH`` set to its checkout (clear both numba caches after
editing a kernel). A run equilibrates 200 steps of the time-stepped integrator, then times
(``time.process_time``) ``--rounds`` event-driven runs of ``2e5 / N`` time units from that
state (one call of ``step(k)``; with ``--per-step`` a quarter of that time in calls of
``step(1)``) and keeps the fastest. Pairs alternate which checkout goes first; prints each
pair and, per N, the medians and the ratio new / old (median, min, max). (This script and
bench_event.py, whose timing it uses, run from the checkout it is started in.)
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys


def child(n: int, duration: float, rounds: int, per_step: bool) -> None:
    from bench_event import _run  # (this script's folder is on the path)

    import discgym as dg
    from discgym.bench import bench_scene

    base = dg.Simulation(bench_scene(n), seed=1)
    base.step(200)
    dg.Simulation(bench_scene(50), seed=0, integrator="event").step(2)  # compile or load
    best, coll = 0.0, 0
    for _ in range(rounds):
        sim = dg.Simulation.from_arrays(bench_scene(n), base.positions, base.velocities,
                                        base.species, seed=2, integrator="event")
        cpu = _run(sim, duration, sim.scene.dt, per_step)
        best, coll = max(best, sim.collisions / cpu), sim.collisions
    print("RATE", best, coll)


def _one(tree: str, n: int, a) -> tuple[float, int]:
    cmd = [sys.executable, os.path.abspath(__file__), "--child", str(n),
           "--rounds", str(a.rounds)] + (["--per-step"] if a.per_step else [])
    out = subprocess.run(cmd, env=dict(os.environ, PYTHONPATH=os.path.abspath(tree)),
                         capture_output=True, text=True, cwd=tree, check=True)
    _, rate, coll = next(x for x in out.stdout.splitlines() if x.startswith("RATE")).split()
    return float(rate), int(coll)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("old", nargs="?")
    ap.add_argument("new", nargs="?")
    ap.add_argument("--sizes", default="1e3,1e4")
    ap.add_argument("--pairs", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--per-step", action="store_true", help="calls of step(1)")
    ap.add_argument("--child", type=int, default=0, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        child(a.child, 2e5 / a.child * (0.25 if a.per_step else 1.0), a.rounds, a.per_step)
        return 0
    for n in (int(float(x)) for x in a.sizes.split(",")):
        old, new = [], []
        for k in range(a.pairs):
            order = ((a.old, old), (a.new, new)) if k % 2 == 0 else ((a.new, new), (a.old, old))
            colls = []
            for tree, rates in order:
                r, c = _one(tree, n, a)
                rates.append(r)
                colls.append(c)
            assert colls[0] == colls[1], f"the trajectories differ: {colls}"
            print(f"N = {n:.0e} pair {k}: old {old[-1]:.4g} new {new[-1]:.4g} collisions/s, "
                  f"new / old {new[-1] / old[-1]:.3f}", flush=True)
        ratios = [b / c for b, c in zip(new, old)]
        print(f"N = {n:.0e}: old {statistics.median(old):.4g}, new {statistics.median(new):.4g}"
              f" collisions/s (medians); new / old median {statistics.median(ratios):.3f}, "
              f"min {min(ratios):.3f}, max {max(ratios):.3f} ({a.pairs} pairs)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
