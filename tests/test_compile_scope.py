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

from discgym.kernels import helper, jit

CHILD = r"""
import importlib, json, pkgutil, sys
import numpy as np
from numba.core import event
from numba.core.registry import CPUDispatcher
import discgym.kernels as kernels
from discgym.kernels import helper
from discgym.kernels.jit import is_kernel, is_linked_only
from discgym.vector import DiscReactorVectorEnv


def encoded(args):
    try:
        return json.dumps([helper.encode_type(t) for t in args])
    except TypeError:  # (a type no plan holds)
        return None

integrator = sys.argv[1]
obs = None
with event.install_recorder("numba:compile") as rec:
    if integrator == "simulation":  # a stepped Simulation, as `discgym run` makes it
        import discgym as dg

        dg.Simulation("reactor", seed=0).step(2)
    else:
        venv = DiscReactorVectorEnv(num_envs=2, n_discs=80, episode_steps=5,
                                    integrator=integrator, threads=1)
        venv.reset(seed=0)
        obs = venv.step(np.full((2, 4), 0.3, np.float32))[0].tolist()
signatures = sorted({(f"{ev.data['dispatcher'].py_func.__module__}."
                   f"{ev.data['dispatcher'].py_func.__qualname__}",
                   encoded(ev.data["args"]))
                  for _, ev in rec.buffer if ev.is_start
                  and is_kernel(ev.data['dispatcher'])})
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
                (linked if is_linked_only(cres) else machine).append(
                    (f"{info.name}.{name}", is_kernel(fn)))
everything = sorted({getattr(ev.data['dispatcher'], 'py_func', ev.data['dispatcher']).__qualname__
                     for _, ev in rec.buffer if ev.is_start})
print(json.dumps({"compiled": compiled, "linked": linked, "machine": machine,
                  "signatures": signatures, "obs": obs, "everything": everything}))
"""


def _children(tmp_path, *integrators, helper=(), cache=None):
    """Run CHILD for each integrator, each in a fresh cache under ``tmp_path`` (or in
    ``cache``), without a compile helper (for those in ``helper``, under
    ``<integrator>+helper``: a second child with one)."""
    procs = {}
    for integrator, with_helper in [(i, False) for i in integrators] + [(i, True)
                                                                         for i in helper]:
        name = integrator + "+helper" * with_helper
        folder = cache or tmp_path / f"cache-{name}"
        env = dict(os.environ, NUMBA_CACHE_DIR=str(folder), DISCGYM_COMPILE_NOTICE="0",
                   DISCGYM_COMPILE_HELPER="1" if with_helper else "0")
        procs[name] = subprocess.Popen(
            [sys.executable, "-c", CHILD, integrator], env=env, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True)
    out = {}
    for integrator, p in procs.items():
        stdout, stderr = p.communicate(timeout=1800)
        assert p.returncode == 0, stderr[-3000:]
        out[integrator] = json.loads(stdout.strip().splitlines()[-1])
    return out


@pytest.mark.slow
def test_each_env_compiles_its_own_integrator_and_links_its_kernels(tmp_path):
    got = _children(tmp_path, "step", "event", "simulation", helper=["step"])
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
        # calls (njit) have theirs. (Under the plain layer every function has its own.)
        if jit.LAYER == jit.PLAIN:
            assert not g["linked"] and g["machine"]
            continue
        assert g["linked"] and all(is_kernel for _, is_kernel in g["linked"]), g["linked"]
        assert g["machine"] and not any(is_kernel for _, is_kernel in g["machine"]), \
            g["machine"]

    # the compile helper's plans (kernels.helper) are kernels the envs compile, with those
    # argument types: else re-record them (python benchmarks/record_plans.py --write)
    plans = helper.load_plans()
    if plans:  # (recorded with this numba)
        for plan, g in (("env-step", stepped), ("env-event", exact)):
            compiled = {(q, a) for q, a in g["signatures"]}
            stale = [q for q, a, _ in plans[plan] if (q, json.dumps(a)) not in compiled]
            assert not stale, f"plan {plan}: not compiled so by the env: {stale}"
    # with a helper: the same step, and the helper's first kernel (the plan's longest,
    # which the env's process reaches after its reset, controls and first phases) compiled
    # by the helper
    helped = got["step+helper"]
    assert helped["obs"] == stepped["obs"]
    # a process whose cache holds the kernels compiles nothing, not even numba's typed list
    # of the generators (kernels.structs.generator_list), and steps the same
    warm = _children(tmp_path, "step", cache=tmp_path / "cache-step")["step"]
    assert warm["everything"] == [] and warm["obs"] == stepped["obs"]
    if plans and helper.enabled():
        first = max(plans["env-step"], key=lambda k: k[2])[0]
        assert first in stepped["compiled"] and first not in helped["compiled"]
        assert len(helped["compiled"]) < len(stepped["compiled"])
