"""What numba compiles on first use, and how long each function takes.

Builds an env (by default the flagship's training env: DiscFlow-v0's vector env of 16
reactors on the event-driven integrator, as ``agents/train_ppo.py`` builds it) in a process
whose numba cache is a fresh temporary folder, steps it once, and prints every compiled
function's own time (its compile minus that of the functions it compiled on the way) and
its inclusive time, from numba's ``numba:compile`` events. The own time of a function that
calls others is mostly LLVM optimising and generating code for everything it links in, so
deep call chains pay for their leaves again at every level.

The env's compile helper (a second process compiling part of a first compile, see
``discgym/kernels/helper.py``) is off, so that one process compiles everything; ``--helper``
lets it run, and the times are then those of the env's process, the table without what the
helper compiled.

    python benchmarks/compile_profile.py                       # the flagship's env
    python benchmarks/compile_profile.py --env DiscReactor-v0 --integrator step --num-envs 1
    python benchmarks/compile_profile.py --simulation reactor --integrator step
    python benchmarks/compile_profile.py --env DiscReactor-v0 --num-envs 1 --helper
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from collections import defaultdict


def profile(env_id: str, integrator: str | None, num_envs: int,
            scene: str | None = None) -> dict:
    """In this process (its numba cache must be empty): compile times by function, to the
    first step of the env (or, with ``scene``, of a ``Simulation`` of that scene)."""
    import numpy as np
    from numba.core import event

    t0 = time.perf_counter()
    c0 = time.process_time()
    with event.install_recorder("numba:compile") as rec:
        if scene:
            import discgym as dg

            dg.Simulation(scene, seed=0, integrator=integrator or "step").step(1)
        else:
            from discgym.tasks import TASKS
            from discgym.vector import DiscReactorVectorEnv

            kw = dict(TASKS[env_id][0].defaults)
            if integrator:
                kw["integrator"] = integrator
            venv = DiscReactorVectorEnv(num_envs=num_envs, **kw)
            venv.reset(seed=0)
            venv.step(np.zeros((num_envs,) + venv.single_action_space.shape, np.float32))
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    return {"wall": wall, "cpu": cpu, **compile_times(rec.buffer)}


def compile_times(buffer) -> dict:
    """From a ``numba:compile`` recorder's buffer: ``own`` and ``incl`` (seconds by function
    name: without and with the functions compiled inside its compile) and ``literal`` (how
    many versions of each were compiled for literal arguments; ``literal_args``: their
    argument types)."""
    own, incl, literal = defaultdict(float), defaultdict(float), defaultdict(int)
    literal_args = defaultdict(list)
    stack = []
    for ts, ev in buffer:
        f = getattr(ev.data.get("dispatcher"), "py_func", None)
        name = f"{f.__module__}.{f.__qualname__}" if f else "?"
        if ev.is_start:
            stack.append([name, ts, 0.0])
            if re.search(r"Literal\[", str(ev.data.get("args"))):
                literal[name] += 1
                literal_args[name].append(str(ev.data.get("args")))
            continue
        name, start, children = stack.pop()
        own[name] += ts - start - children
        incl[name] += ts - start
        if stack:
            stack[-1][2] += ts - start
    return {"own": dict(own), "incl": dict(incl), "literal": dict(literal),
            "literal_args": dict(literal_args)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--env", default="DiscFlow-v0")
    p.add_argument("--integrator", default="event", help="'step', 'event' or '' (the task's)")
    p.add_argument("--num-envs", type=int, default=16)
    p.add_argument("--simulation", metavar="SCENE", default=None,
                   help="profile a Simulation of this built-in scene (or TOML) instead of an "
                   "env: its first step(1), on --integrator")
    p.add_argument("--top", type=int, default=15)
    p.add_argument("--literal-args", action="store_true",
                   help="print the argument types of the literal versions")
    p.add_argument("--helper", action="store_true",
                   help="let the env start its compile helper (kernels.helper): the times are "
                        "then this process's, the table without what the helper compiled")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if not a.child:  # run in a child whose numba cache is empty, whatever this one's holds
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache,
                       DISCGYM_COMPILE_HELPER="1" if a.helper else "0")
            args = sys.argv[1:] if argv is None else list(argv)
            return subprocess.call([sys.executable, __file__, "--child", *args], env=env)
    r = profile(a.env, a.integrator or None, a.num_envs, a.simulation)
    total = sum(r["own"].values())
    what = f"Simulation({a.simulation!r}), integrator {a.integrator or 'step'}" if a.simulation \
        else f"{a.env}, {a.num_envs} reactors, integrator {a.integrator or 'of the task'}"
    print(f"{what}: first step after {r['wall']:.1f} s ({r['cpu']:.1f} s of CPU), of which "
          f"{total:.1f} s compiling ({len(r['own'])} functions)\n")
    print("| function | own s | inclusive s |\n|---|---|---|")
    for name, t in sorted(r["own"].items(), key=lambda kv: -kv[1])[:a.top]:
        print(f"| {name.replace('discgym.kernels.', '')} | {t:.1f} | {r['incl'][name]:.1f} |")
    lit = {k: v for k, v in r["literal"].items() if k.startswith("discgym")}
    print("\ncompiled for literal arguments (a version of its own each): " +
          (", ".join(f"{k.replace('discgym.kernels.', '')} x{v}" for k, v in sorted(lit.items()))
           or "none"))
    if a.literal_args:
        for k in sorted(lit):
            for args in r["literal_args"][k]:
                print(f"  {k}{args}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
