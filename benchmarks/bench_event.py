#!/usr/bin/env python
"""The exact, event-driven integrator: CPU time per unit of simulated time and collisions
per second, for one long call and for calls of one step, against the time-stepped
integrator on the same gas (the benchmark scene of docs/performance.md: r = 1, m = 1,
kT = 1, packing 0.3, square box).

    python benchmarks/bench_event.py                    # N = 1e3, 1e4; dt = 0.05, 0.01
    python benchmarks/bench_event.py --sizes 1e3 --time 20

Every configuration is timed in ``--rounds`` interleaved rounds (best kept), from the same
equilibrated state, so a burst of load on this shared machine hits them alike. Prints a
plain-text (or ``--markdown``) table.
"""

from __future__ import annotations

import argparse
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="1e3,1e4", help="numbers of discs, comma-separated")
    ap.add_argument("--dts", default="0.05,0.01", help="time steps, comma-separated")
    ap.add_argument("--time", type=float, default=None,
                    help="simulated time per timed run (default: 2e4 / N)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--markdown", action="store_true")
    a = ap.parse_args(argv)
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
    print(format_table(["N", "dt", "integrator", "calls", "ms CPU per time unit",
                        "M collisions/s", "coll/disc/time"], rows, a.markdown))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
