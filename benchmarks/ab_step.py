#!/usr/bin/env python
"""The stepped integrator of two checkouts, interleaved: ns per disc-step, new / old.

    python benchmarks/ab_step.py OLD_TREE NEW_TREE                  # every case, 5 rounds
    python benchmarks/ab_step.py OLD NEW --cases clusters --rounds 6

Each round runs, for each checkout in turn, a new process (``PYTHONPATH`` the checkout, its
own numba cache: its ``__pycache__``) that builds the benchmark gas of each case, steps it
once to compile, then times ``reps`` calls of ``Simulation.step(steps)`` each from a copy of
that state and keeps the best. The table gives each case's ns per disc-step in both, and
the ratio new / old per round: its median, min and max. Rounds alternate the two, so the
drift of a shared machine falls on both; trust a median of several rounds only.

Cases (``--cases``, comma-separated; the benchmark gas of ``discgym.bench``, elastic unless
said, ``threads`` = ``Simulation.threads``): ``serial`` 2,000 discs, 10 steps, one thread;
``inelastic`` 10,000 discs, restitution 0.8, 4 steps; ``pairlist`` 20,000 discs, 40 steps
(the pair list); ``threads`` 40,000 discs, 4 steps, two threads; ``clusters`` 140,000 discs,
2 steps, one thread (the event phase by clusters).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

#: name: (discs, threads, steps, packing, restitution)
CASES = {
    "serial": (2000, 1, 10, 0.3, 1.0),
    "inelastic": (10000, 1, 4, 0.4, 0.8),
    "pairlist": (20000, 1, 40, 0.3, 1.0),
    "threads": (40000, 2, 4, 0.3, 1.0),
    "clusters": (140000, 1, 2, 0.3, 1.0),
}

_CHILD = """
import json, os, sys, time
tree, names, reps = sys.argv[1], sys.argv[2].split(","), int(sys.argv[3])
cases = json.loads(sys.argv[4])
import discgym as dg
from discgym.bench import bench_scene
assert dg.__file__.startswith(tree), dg.__file__
out = {}
for name in names:
    n, threads, steps, eta, e = cases[name]
    sim = dg.Simulation(bench_scene(n, eta=eta, restitution=e), seed=3)
    sim.threads = threads
    sim.step(steps)  # (compiles, or loads the cache)
    best = float("inf")
    for _ in range(reps):
        c = sim.copy()
        t0 = time.perf_counter()
        c.step(steps)
        best = min(best, time.perf_counter() - t0)
    out[name] = best / (n * steps) * 1e9
print(json.dumps(out))
"""


def run_tree(tree: Path, names: list[str], reps: int) -> dict:
    """ns per disc-step of each case in a new process on checkout ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree), DISCGYM_ADAPTIVE_THREADS="0")
    out = subprocess.run([sys.executable, "-c", _CHILD, str(tree), ",".join(names), str(reps),
                          json.dumps({k: CASES[k] for k in names})],
                         env=env, cwd=tree, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("old", type=Path)
    p.add_argument("new", type=Path)
    p.add_argument("--cases", default=",".join(CASES))
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--reps", type=int, default=12, help="timed calls per case (the best kept)")
    a = p.parse_args(argv)
    names = [c for c in a.cases.split(",") if c]
    bad = [c for c in names if c not in CASES]
    if bad or not names:
        p.error(f"--cases: unknown {bad or 'none given'} (cases: {', '.join(CASES)})")
    for tree in (a.old, a.new):
        if not (tree / "discgym" / "__init__.py").is_file():
            p.error(f"{tree}: not a discgym checkout (no discgym/__init__.py)")
    if a.rounds < 1 or a.reps < 1:
        p.error("--rounds and --reps must be at least 1")
    rows = {k: ([], []) for k in names}
    for r in range(a.rounds):
        for side, tree in enumerate((a.old, a.new)):
            for k, v in run_tree(tree.resolve(), names, a.reps).items():
                rows[k][side].append(v)
        print(f"round {r + 1}: " + ", ".join(
            f"{k} {rows[k][0][-1]:.1f} / {rows[k][1][-1]:.1f}" for k in names), flush=True)
    print("\n| case | old ns/disc-step (best) | new (best) | new / old median [min, max] |")
    print("|---|---|---|---|")
    for k in names:
        old, new = rows[k]
        ratios = [b / o for o, b in zip(old, new)]
        print(f"| {k} | {min(old):.1f} | {min(new):.1f} | {statistics.median(ratios):.2f} "
              f"[{min(ratios):.2f}, {max(ratios):.2f}] |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
