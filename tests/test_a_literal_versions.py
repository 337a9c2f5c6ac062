"""No kernel the envs run gets versions of its own for literal arguments.

numba compiles another version of a function, with everything below it, for each literal
constant passed at a call site (benchmarks/compile_profile.py lists them), so the envs'
kernels take int64 and bool values, not constants (the event integrator's fallback calls the
stepped ``advance`` with the batch's argument types; pushes and scans convert at the call
site). The check runs in a child process that steps both integrators' envs and vector envs
and then reads every kernel's compiled signatures. This module's name sorts first, so from
a fresh clone (as in CI) the child compiles the envs' whole trees and sees every kernel in
them, before any other test compiles the Simulation's cluster phase (``kernels.clusters``,
which still passes literals to the kernels it shares, and is left out); with a warm cache it
sees the entry points (the callees load inside their callers). The child then runs a
Simulation on both integrators and checks that no kernel was called from Python.
"""

import json
import subprocess
import sys

CHILD = r"""
import importlib, json, pkgutil
import numpy as np
from numba import types
from numba.core.registry import CPUDispatcher
import discgym.kernels as kernels
from discgym.env import DiscReactorEnv
from discgym.vector import DiscReactorVectorEnv

for integrator in ("event", "step"):
    kw = dict(n_discs=80, episode_steps=5, integrator=integrator)
    venv = DiscReactorVectorEnv(num_envs=2, **kw)
    venv.reset(seed=0)
    venv.step(np.zeros((2, 4), np.float32))
    env = DiscReactorEnv(**kw)
    env.reset(seed=0)
    env.step(np.zeros(4, np.float32))
seen, literal = 0, []
for info in pkgutil.iter_modules(kernels.__path__):
    if info.name == "clusters":
        continue
    mod = importlib.import_module(f"discgym.kernels.{info.name}")
    for name, fn in vars(mod).items():
        if isinstance(fn, CPUDispatcher) and fn.py_func.__module__ == mod.__name__:
            for sig in fn.signatures:
                seen += 1
                if any(isinstance(t, types.Literal) for t in sig):
                    literal.append(f"{info.name}.{name}{sig}")
# and whether any kernel was called from Python (it would compile twice: its twin)
import discgym as dg
from discgym.kernels.jit import is_kernel
for integrator in ("step", "event"):
    for scene in ("reactor", "flow"):
        sim = dg.Simulation(scene, seed=0, integrator=integrator)
        sim.step(3)
        sim.total_energy(), sim.overlaps(), sim.outside()
        sim.inject(0, 1)
        sim.scale_temperature(1.1)
        sim.resize(sim.bounds)
twins = sorted(f"{info.name}.{name}"
               for info in pkgutil.iter_modules(kernels.__path__)
               for name, fn in vars(importlib.import_module(f"discgym.kernels.{info.name}")).items()
               if is_kernel(fn) and fn.__dict__.get("_discgym_twin"))
print(json.dumps({"seen": seen, "literal": literal, "twins": twins}))
"""


def test_no_kernel_is_compiled_for_literal_arguments():
    out = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True,
                         timeout=1800)
    assert out.returncode == 0, out.stderr[-3000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["literal"] == [], got["literal"]
    assert got["seen"] >= 4  # (at least the envs' entry points)
    # the envs and the Simulation call only entry points (njit) from Python: no kernel
    # (discgym.kernels.jit) is compiled a second time as its twin (the linked-only layer's;
    # the plain layer has none)
    assert got["twins"] == [], got["twins"]
