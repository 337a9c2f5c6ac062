#!/usr/bin/env python
"""The vector env's compiled step on one thread, for a fixed action sequence: microseconds
per reactor-step (best of 4 repetitions) and a hash of the final observation.

    python benchmarks/bench_env_kernel.py zero     # 100 steps of zero action: a cold reactor
    python benchmarks/bench_env_kernel.py random   # 100 steps of seeded random actions

Run it alternately on two versions of the code (``PYTHONPATH=<tree>``) to compare them: with
``zero`` the trajectories of versions that keep the physics are bit-identical (same hash), so
a difference in time is the code's; with ``random`` the reactor is heated and a change of the
physics shows in the hash.
"""

import argparse
import hashlib
import time

import numba
import numpy as np

from discgym.vector import DiscReactorVectorEnv

REACTORS, STEPS, REPEATS = 64, 100, 4


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench_env_kernel.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("mode", nargs="?", choices=("zero", "random"), default="zero",
                    help="zero: a cold reactor (bit-identical across versions that keep the "
                    "physics); random: seeded random actions (default %(default)s)")
    mode = ap.parse_args(argv).mode
    numba.set_num_threads(1)
    venv = DiscReactorVectorEnv(num_envs=REACTORS, autoreset_mode="Disabled", threads=1)
    rng = np.random.default_rng(5)
    if mode == "zero":
        actions = [np.zeros((REACTORS, 4), np.float32)] * STEPS
    else:
        actions = [rng.uniform(-1, 1, (REACTORS, 4)).astype(np.float32) for _ in range(STEPS)]
    best = float("inf")
    for _ in range(REPEATS):
        obs, _ = venv.reset(seed=3)
        t0 = time.perf_counter()
        for a in actions:
            obs, *_ = venv.step(a)
        best = min(best, time.perf_counter() - t0)
    digest = hashlib.sha1(obs.tobytes()).hexdigest()[:10]
    print(f"{mode}: {best / (REACTORS * STEPS) * 1e6:.1f} us per reactor-step, final "
          f"observation {digest}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
