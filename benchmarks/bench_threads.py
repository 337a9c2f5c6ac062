"""One simulation on one thread against the same on all of numba's threads.

Two simulations of the benchmark gas from the same state, one with ``threads = 1`` and one
with ``threads`` work chunks (default: discgym's, 4 per numba thread), step in alternation
(``steps`` per call, ``pairs`` times each); their trajectories are asserted equal at the
end (bit for bit: the result does not depend on the number of threads). Prints ns per
disc-step of each and the speed-up of each pair (median, min, max).

    python benchmarks/bench_threads.py                      # 1e4 (20 steps) to 1e6
    python benchmarks/bench_threads.py --cases 1e5:40 --pairs 9

From PARALLEL_MIN = 8,192 discs the drift, the scan and (by clusters, kernels.clusters)
the event phase run on the threads (at most one work chunk per CHUNK_MIN = 1,024 discs);
below it a step runs on one thread either way.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

# (the threads' own speed-up: every call on all of numba's threads, not the count that
# discgym.threads would measure best; benchmarks/bench_busy.py measures that one)
os.environ.setdefault("DISCGYM_ADAPTIVE_THREADS", "0")

from discgym import Simulation
from discgym.bench import bench_scene, format_table, machine_info, machine_line, n_label


def pair_run(n: int, steps: int, pairs: int, threads: int | None = None, seed: int = 3,
             eta: float = 0.3) -> dict:
    one = Simulation(bench_scene(n, eta=eta), seed=seed)
    many = one.copy()
    one.threads = 1
    if threads is not None:
        many.threads = threads
    one.step(steps)  # (warm: loads the compiled kernels)
    many.step(steps)
    t1, tm = [], []
    for _ in range(pairs):
        a = time.perf_counter()
        one.step(steps)
        b = time.perf_counter()
        many.step(steps)
        c = time.perf_counter()
        t1.append((b - a) / (n * steps) * 1e9)
        tm.append((c - b) / (n * steps) * 1e9)
    for x, y in ((one.positions, many.positions), (one.velocities, many.velocities),
                 (one._fsum, many._fsum)):
        if not np.array_equal(x, y):
            raise AssertionError("one thread and several gave different trajectories")
    if one.counters() != many.counters():
        raise AssertionError("one thread and several gave different counters")
    ratio = [a / b for a, b in zip(t1, tm)]
    return {"n": n, "steps": steps, "threads": many.threads, "ns_one": statistics.median(t1),
            "ns_many": statistics.median(tm), "speedup": statistics.median(ratio),
            "speedup_min": min(ratio), "speedup_max": max(ratio)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default="1e4:20,3e4:10,1e5:5,3e5:10,1e6:4",
                    help="comma-separated N:steps per call")
    ap.add_argument("--pairs", type=int, default=9)
    ap.add_argument("--threads", type=int, default=None,
                    help="work chunks of the threaded simulation (default: discgym's)")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    rows = []
    for case in args.cases.split(","):
        n, steps = case.split(":")
        r = pair_run(int(float(n)), int(steps), args.pairs, args.threads)
        rows.append([n_label(r["n"]), r["steps"], r["threads"], f"{r['ns_one']:.1f}",
                     f"{r['ns_many']:.1f}", f"{r['speedup']:.2f}",
                     f"{r['speedup_min']:.2f}", f"{r['speedup_max']:.2f}"])
        print(f"  N = {r['n']}: {r['speedup']:.2f}x", flush=True)
    print(machine_line(machine_info()))
    print(format_table(["N", "steps/call", "chunks", "ns 1 thread", "ns threads",
                        "speed-up (median)", "min", "max"], rows, args.markdown))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
