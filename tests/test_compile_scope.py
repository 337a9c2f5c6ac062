"""What a first step compiles (docs/performance.md, "First-use compile time"): each env
compiles only its own integrator, a small stepped Simulation no parallel or cluster code,
and the kernels are linked only (optimised and turned into machine code once, inside the
entry point that calls them).

Each check runs in a child process whose numba cache is an empty temporary folder, so that
it sees a first compile whatever the cache of the test run holds; the children run at the
same time.
"""

import json
import os
import subprocess
import sys

import pytest

CHILD = r"""
import importlib, json, pkgutil, sys
import numpy as np
from numba.core import event
from numba.core.registry import CPUDispatcher
import discgym.kernels as kernels
from discgym.kernels.jit import KernelDispatcher, LinkOnlyLibrary
from discgym.vector import DiscReactorVectorEnv

integrator = sys.argv[1]
with event.install_recorder("numba:compile") as rec:
    if integrator == "simulation":  # a stepped Simulation, as `discgym run` makes it
        import discgym as dg

        dg.Simulation("reactor", seed=0).step(2)
    else:
        venv = DiscReactorVectorEnv(num_envs=2, n_discs=80, episode_steps=5,
                                    integrator=integrator, threads=1)
        venv.reset(seed=0)
        venv.step(np.zeros((2, 4), np.float32))
compiled = sorted({f"{ev.data['dispatcher'].py_func.__module__}."
                   f"{ev.data['dispatcher'].py_func.__qualname__}"
                   for _, ev in rec.buffer if ev.is_start
                   and ev.data['dispatcher'].py_func.__module__.startswith("discgym")})
linked, machine = [], []
for info in pkgutil.iter_modules(kernels.__path__):
    mod = importlib.import_module(f"discgym.kernels.{info.name}")
    for name, fn in vars(mod).items():
        if isinstance(fn, CPUDispatcher) and fn.py_func.__module__ == mod.__name__:
            for cres in fn.overloads.values():
                only = isinstance(cres.library, LinkOnlyLibrary) and cres.library.link_only
                (linked if only else machine).append(
                    (f"{info.name}.{name}", isinstance(fn, KernelDispatcher)))
print(json.dumps({"compiled": compiled, "linked": linked, "machine": machine}))
"""


def _children(*integrators):
    procs = {}
    for integrator in integrators:
        import tempfile

        cache = tempfile.mkdtemp(prefix="discgym-cache-")
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, DISCGYM_COMPILE_NOTICE="0")
        procs[integrator] = subprocess.Popen([sys.executable, "-c", CHILD, integrator],
                                             env=env, stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, text=True)
    out = {}
    for integrator, p in procs.items():
        stdout, stderr = p.communicate(timeout=1800)
        assert p.returncode == 0, stderr[-3000:]
        out[integrator] = json.loads(stdout.strip().splitlines()[-1])
    return out


@pytest.mark.slow
def test_each_env_compiles_its_own_integrator_and_links_its_kernels():
    got = _children("step", "event", "simulation")
    stepped, exact, simulation = got["step"], got["event"], got["simulation"]
    # the stepped env: nothing of the exact integrator
    assert not [f for f in stepped["compiled"] if f.startswith("discgym.kernels.event_driven")]
    assert "discgym.kernels.step.advance" in stepped["compiled"]
    # the exact env: not the time-stepped integrator (its fallback waits until a run needs it)
    assert "discgym.kernels.event_driven._simulate" in exact["compiled"]
    assert "discgym.kernels.step.advance" not in exact["compiled"]
    assert "discgym.kernels.event_driven.finish_capped" not in exact["compiled"]
    # a stepped Simulation of a few hundred discs: no cluster phase, no parallel code
    assert not [f for f in simulation["compiled"] if f.startswith("discgym.kernels.clusters")
                or f.endswith("_parallel") or f.startswith("discgym.kernels.event_driven")]
    assert "discgym.kernels.step.advance_serial_rngs" in simulation["compiled"]
    assert "discgym.kernels.step.advance_rngs" not in simulation["compiled"]
    for g in (stepped, exact, simulation):
        # every kernel linked only (no machine code of its own); the entry points Python
        # calls (njit) have theirs
        assert g["linked"] and all(is_kernel for _, is_kernel in g["linked"]), g["linked"]
        assert g["machine"] and not any(is_kernel for _, is_kernel in g["machine"]), \
            g["machine"]
