#!/usr/bin/env python
"""Where the event-driven integrator's time goes, on the benchmark gas (elastic discs r = 1,
m = 1, kT = 1, packing 0.3, square box; docs/performance.md).

    python benchmarks/profile_event.py                 # N = 1e3, 1e4
    python benchmarks/profile_event.py --sizes 1e5 --time 2

Two parts, each from the same equilibrated state (200 steps of the time-stepped integrator):

- **counts**: one run of ``--time`` time units through ``event_driven.run_steps`` (the
  integrator itself), its statistics per disc and unit time (collisions, cell crossings,
  wall hits, stale events, predictions) and its CPU time per event and per collision;
- **phases**: the same run through a copy of the event loop (``_event_loop``, for the
  gas's events only: collisions, crossings, walls, stale events; the same inlined handlers
  and predictions, so the same trajectory) with the processor's cycle counter
  (``llvm.readcyclecounter``, about 11 ns a read on this VM) read around the handler of
  each kind and around each prediction (full, or after a crossing) and each heap update.
  Prints ns per event in each phase: the CPU time of the run (``time.process_time``)
  shared out in proportion to the cycles counted in each (the counter runs on while another
  process holds the core); their sum exceeds the uninstrumented time by the counter's reads.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

import discgym as dg
from discgym.bench import bench_scene, format_table, n_label
from discgym.compiled import kernel_bounds
from discgym.kernels import event_driven as ev
from discgym.kernels import event_handlers as eh
from discgym.kernels import event_predict as ep
from discgym.kernels import step as S
from discgym.kernels.event_structs import EVENT_COLUMNS, NEXT_CODE, NEXT_STAMP, Queue
from discgym.kernels.heap import IndexedHeap
from discgym.kernels.structs import FLOAT, INDEX, Bounds, Discs

DT = 0.05
PHASES = ("collision handler", "crossing handler", "wall handler", "stale event",
          "prediction, full (3 x 3 cells)", "prediction after a crossing (3 cells)",
          "top of the heap, advance, loop")


@intrinsic
def _cycles(typingctx):
    sig = types.int64()

    def codegen(context, builder, signature, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.IntType(64), []),
                                            "llvm.readcyclecounter")
        return builder.call(fn, [])
    return sig, codegen


@njit
def _now():
    return _cycles()


@njit(_nrt=False)
def _phased_loop(fl, cells, queue, run, tables, rng, counters, P):
    """ev._event_loop for an elastic gas (no reactions, outlets or growth), the cycles of
    each phase added to P (indices of PHASES)."""
    t = 0.0
    events = 0
    c0 = _cycles()
    while True:
        d = queue.heap.disc[0]
        t = queue.heap.key[0]
        if not t <= run.t1:
            break
        events += 1
        code = int(queue.event[d, NEXT_CODE])
        ep.fly_to(d, t, fl.path)
        p1 = -1
        entered = 0
        c1 = _cycles()
        P[6] += c1 - c0
        if code >= 0 and fl.stamp[code] != int(queue.event[d, NEXT_STAMP]):
            k = 3
        elif code >= 0:
            p1 = eh.collision(d, code, t, fl, cells, queue, run, tables, rng, counters)
            k = 0
        elif code == ev.EV_CELL:
            entered = eh.crossing(d, cells, queue, counters.stats)
            k = 1
        elif code == ev.EV_WALL:
            eh.wall_event(d, fl, cells, queue, run, tables, counters, rng)
            k = 2
        else:
            raise ValueError("profile_event: only an elastic gas")
        c0 = _cycles()
        P[k] += c0 - c1
        ep.predict(d, t, fl, cells, queue, run, entered)
        c1 = _cycles()
        P[4 if entered == 0 else 5] += c1 - c0
        c0 = c1
        if p1 >= 0:
            ep.predict(p1, t, fl, cells, queue, run, 0)
            c0 = _cycles()
            P[4] += c0 - c1
    return events


@njit
def _setup(state, n, n_steps, bounds, tables, params, flags, rng, counters):
    run = ev._run_constants(n, n_steps, DT, state.vel, state.species, tables, params, flags,
                            bounds)
    cap = state.pos.shape[0]
    cells = ep.make_cells(n, cap, run, ev.CELLS_PER_DISC)
    fl = ev._load(n, cap, state, cells, tables)
    queue = Queue(np.zeros((cap, EVENT_COLUMNS), dtype=FLOAT),
                  IndexedHeap(np.full(cap, np.inf, dtype=FLOAT), np.arange(cap).astype(INDEX),
                              np.arange(cap).astype(INDEX)))
    ev._first_predictions(n, fl, cells, queue, run, tables, rng, counters.stats)
    return run, cells, fl, queue


def _args(sim, n):
    cs = sim._cs
    discs = Discs(sim.positions.copy(), sim.velocities.copy(), sim.species.copy(),
                  np.zeros(n), np.arange(n), np.array([n]))
    counters = ev.EventCounters(np.zeros_like(sim._icnt), np.zeros_like(sim._fsum),
                                np.zeros_like(sim._ch_count),
                                np.zeros(ev.N_STATS, dtype=np.int64),
                                np.zeros_like(sim._outflow))
    return discs, Bounds(*kernel_bounds(sim.bounds), sim._walls), cs, counters


def counts(sim, n, duration):
    discs, bounds, cs, cnt = _args(sim, n)
    t0 = time.process_time()
    ev.run_steps(discs, n, round(duration / DT), DT, bounds, cs.tables, cs.params, cs.flags,
                 np.random.default_rng(0), cnt, ev.CELLS_PER_DISC)
    cpu = time.process_time() - t0
    st, ic = cnt.stats, cnt.icnt
    return cpu, {"events": st[ev.ST_EVENTS], "collisions": ic[S.IC_COLLISIONS],
                 "crossings": st[ev.ST_CROSSINGS], "wall hits": ic[S.IC_WALL_HITS],
                 "stale": st[ev.ST_STALE], "predictions": st[ev.ST_PREDICTIONS]}


def phases(sim, n, duration):
    discs, bounds, cs, cnt = _args(sim, n)
    rng = np.random.default_rng(0)
    run, cells, fl, queue = _setup(discs, n, round(duration / DT), bounds, cs.tables,
                                   cs.params, cs.flags, rng, cnt)
    P = np.zeros(len(PHASES), dtype=np.int64)
    p0, c0 = time.process_time(), _now()
    events = _phased_loop(fl, cells, queue, run, cs.tables, rng, cnt, P)
    cpu, cyc = time.process_time() - p0, _now() - c0
    # the counter runs on while another process has the core: share out the CPU time
    return events, cpu, P / cyc * cpu * 1e9


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="1e3,1e4")
    ap.add_argument("--time", type=float, default=None,
                    help="simulated time per run (default: 2e5 / N)")
    ap.add_argument("--markdown", action="store_true")
    a = ap.parse_args(argv)
    crow, prow = [], []
    for n in (int(float(x)) for x in a.sizes.split(",")):
        duration = a.time if a.time else 2e5 / n
        base = dg.Simulation(bench_scene(n), seed=1)
        base.step(200)
        sim = dg.Simulation.from_arrays(bench_scene(n), base.positions, base.velocities,
                                        base.species, seed=2, integrator="event")
        counts(sim, n, 1.0)  # compile or load
        phases(sim, n, 1.0)
        cpu, c = counts(sim, n, duration)
        per = n * duration
        crow.append([n_label(n)] + [f"{c[k] / per:.3f}" for k in c]
                    + [f"{1e9 * cpu / c['events']:.0f}", f"{1e9 * cpu / c['collisions']:.0f}",
                       f"{c['collisions'] / cpu / 1e6:.3f}"])
        events, cpu, ns = phases(sim, n, duration)
        prow.append([n_label(n)] + [f"{x / events:.1f}" for x in ns]
                    + [f"{1e9 * cpu / events:.0f}"])
    print(format_table(["N", "events", "collisions", "crossings", "wall hits", "stale",
                        "predictions", "ns/event", "ns/collision", "M collisions/s"],
                       crow, a.markdown))
    print("(counts per disc and unit time)\n")
    print(format_table(["N", *PHASES, "all (instrumented)"], prow, a.markdown))
    print("(ns per event)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
