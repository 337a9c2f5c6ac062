#!/usr/bin/env python
"""The exact, event-driven integrator: CPU time per unit of simulated time and collisions
per second, for one long call and for calls of one step, against the time-stepped
integrator on the same gas (the benchmark scene of docs/performance.md: r = 1, m = 1,
kT = 1, packing 0.3, square box); with ``--ab OLD NEW``, the same integrator in two
checkouts.

    python benchmarks/bench_event.py                    # N = 1e3, 1e4; dt = 0.05, 0.01
    python benchmarks/bench_event.py --sizes 1e3 --time 20
    python benchmarks/bench_event.py --ab OLD NEW       # N = 1e3, 1e4; 7 pairs
    python benchmarks/bench_event.py --ab OLD NEW --sizes 1e5 --pairs 5 --per-step

Every configuration is timed in ``--rounds`` interleaved rounds (best kept), from the same
equilibrated state, so a burst of load on this shared machine hits them alike. Prints a
plain-text (or ``--markdown``) table.

``--ab OLD NEW``: collisions per second as ratios of interleaved runs, for a change that must
keep the trajectories (the collision counts are asserted equal). OLD and NEW are checkouts
(e.g. ``git worktree add --detach /tmp/old main``); each run is a separate process with
``PYTHONPATH`` set to its checkout (clear both numba caches after editing a kernel), running
this script of the checkout it is started in. A run equilibrates 200 steps of the
time-stepped integrator, then times (``time.process_time``) ``--rounds`` event-driven runs of
``2e5 / N`` time units (``--time`` otherwise) from that state (one call of ``step(k)``; with
``--per-step`` a quarter of that time in calls of ``step(1)``) and keeps the fastest. Pairs
alternate which checkout goes first; prints each pair and, per N, the medians and the ratio
new / old (median, min, max).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

import discgym as dg
from discgym.bench import bench_scene, format_table


def _run(sim: dg.Simulation, duration: float, dt: float, per_step: bool) -> float:
    steps = round(duration / dt)
    t0 = time.process_time()
    if per_step:
        for _ in range(steps):
            sim.step(1)
    else:
        sim.step(steps)
    return time.process_time() - t0


def table(a) -> str:
    """The event-driven integrator against the time-stepped one, in this process."""
    rows = []
    for integ in ("event", "step"):  # compile (or load) the kernels before timing
        dg.Simulation(bench_scene(50), seed=0, integrator=integ).step(2)
    for n in (int(float(x)) for x in a.sizes.split(",")):
        duration = a.time if a.time else 2e4 / n
        base = dg.Simulation(bench_scene(n), seed=1)
        base.step(200)  # equilibrate from the placement
        for dt in (float(x) for x in a.dts.split(",")):
            configs = [("event", False), ("event", True), ("step", False)]
            best = {c: (float("inf"), 0) for c in configs}
            for _ in range(a.rounds):
                for integ, per_step in configs:
                    sc = bench_scene(n, dt=dt)
                    sim = dg.Simulation.from_arrays(sc, base.positions, base.velocities,
                                                    base.species, seed=2, integrator=integ)
                    cpu = _run(sim, duration, dt, per_step)
                    best[(integ, per_step)] = min(best[(integ, per_step)],
                                                  (cpu, sim.collisions))
            for integ, per_step in configs:
                cpu, coll = best[(integ, per_step)]
                rows.append([f"{n:.0e}", dt, integ, "step(1) calls" if per_step else "one call",
                             f"{1e3 * cpu / duration:.2f}", f"{coll / cpu / 1e6:.3f}",
                             f"{coll / (n * duration):.3f}"])
    return format_table(["N", "dt", "integrator", "calls", "ms CPU per time unit",
                         "M collisions/s", "coll/disc/time"], rows, a.markdown)


def ab_child(n: int, duration: float, rounds: int, per_step: bool) -> tuple[float, int]:
    """The fastest of ``rounds`` event-driven runs (collisions per CPU second) and their
    collision count, in the discgym this process imports."""
    base = dg.Simulation(bench_scene(n), seed=1)
    base.step(200)
    dg.Simulation(bench_scene(50), seed=0, integrator="event").step(2)  # compile or load
    best, coll = 0.0, 0
    for _ in range(rounds):
        sim = dg.Simulation.from_arrays(bench_scene(n), base.positions, base.velocities,
                                        base.species, seed=2, integrator="event")
        cpu = _run(sim, duration, sim.scene.dt, per_step)
        best, coll = max(best, sim.collisions / cpu), sim.collisions
    return best, coll


def _ab_one(tree: str, n: int, a) -> tuple[float, int]:
    cmd = [sys.executable, os.path.abspath(__file__), "--ab-child", str(n),
           "--rounds", str(a.rounds)] + (["--per-step"] if a.per_step else []) \
        + (["--time", str(a.time)] if a.time else [])
    out = subprocess.run(cmd, env=dict(os.environ, PYTHONPATH=os.path.abspath(tree)),
                         capture_output=True, text=True, cwd=tree, check=True)
    _, rate, coll = next(x for x in out.stdout.splitlines() if x.startswith("RATE")).split()
    return float(rate), int(coll)


def ab(a) -> None:
    """``--ab OLD NEW``: interleaved pairs of child processes, one per checkout."""
    for tree in a.ab:
        if not os.path.isdir(os.path.join(tree, "discgym")):
            raise SystemExit(f"bench_event.py: error: --ab: {tree!r} is not a checkout of "
                             "discgym (no discgym/ in it)")
    for n in (int(float(x)) for x in a.sizes.split(",")):
        old, new = [], []
        for k in range(a.pairs):
            order = ((a.ab[0], old), (a.ab[1], new))
            colls = []
            for tree, rates in order if k % 2 == 0 else order[::-1]:
                r, c = _ab_one(tree, n, a)
                rates.append(r)
                colls.append(c)
            assert colls[0] == colls[1], f"the trajectories differ: {colls}"
            print(f"N = {n:.0e} pair {k}: old {old[-1]:.4g} new {new[-1]:.4g} collisions/s, "
                  f"new / old {new[-1] / old[-1]:.3f}", flush=True)
        ratios = [b / c for b, c in zip(new, old)]
        print(f"N = {n:.0e}: old {statistics.median(old):.4g}, new {statistics.median(new):.4g}"
              f" collisions/s (medians); new / old median {statistics.median(ratios):.3f}, "
              f"min {min(ratios):.3f}, max {max(ratios):.3f} ({a.pairs} pairs)", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench_event.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="1e3,1e4", help="numbers of discs, comma-separated")
    ap.add_argument("--dts", default="0.05,0.01", help="time steps, comma-separated")
    ap.add_argument("--time", type=float, default=None,
                    help="simulated time per timed run (default: 2e4 / N; --ab: 2e5 / N)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--ab", nargs=2, metavar=("OLD", "NEW"),
                    help="compare the event-driven integrator of two checkouts instead")
    ap.add_argument("--pairs", type=int, default=7, help="--ab: interleaved pairs per N")
    ap.add_argument("--per-step", action="store_true", help="--ab: calls of step(1)")
    ap.add_argument("--ab-child", type=int, default=0, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.ab_child:
        n = a.ab_child
        duration = (a.time or 2e5 / n) * (0.25 if a.per_step else 1.0)
        print("RATE", *ab_child(n, duration, a.rounds, a.per_step))
    elif a.ab:
        ab(a)
    else:
        print(table(a))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
