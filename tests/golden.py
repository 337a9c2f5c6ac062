"""Fingerprints of trajectories: hashes of what the public API shows after a run of every
built-in scene (both integrators, several seeds, growth and reordering) and of env episodes
(single and vector env, random and heuristic actions).

A change that must keep results bit for bit (a refactoring) records them before and checks
them after:

    python tests/golden.py --write tests/golden.json   # before
    python tests/golden.py --check tests/golden.json   # after: exit 1 and a list on any change

Only public observables are hashed (positions, velocities, species, internal energies, ids,
counters, reactions, time and the energy ledger; observations, rewards, flags and infos), so
the fingerprints survive a change of internal names. They are exact float bits: they hold on
the machine, CPU model and library versions they were written with (recorded in the file); on
another CPU or another numpy/numba they may differ without anything being wrong.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import sys
from pathlib import Path

import numpy as np

# from a checkout, import the checkout's discgym
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import discgym as dg  # noqa: E402

SEEDS = (0, 1, 2)
# steps per run: enough for reactions, decompositions doubling the capacity and one memory
# reordering where the scene has the discs for it; fewer with the exact integrator (slower)
STEPS = {"step": 300, "event": 60}
ENV_STEPS = 120


class _Hasher:
    def __init__(self):
        self._h = hashlib.sha256()

    def add(self, value) -> None:
        if isinstance(value, np.ndarray):
            a = np.ascontiguousarray(value)
            self._h.update(f"{a.dtype.str}{a.shape}".encode())
            self._h.update(a.tobytes())
        elif isinstance(value, dict):
            for k in sorted(value):
                self._h.update(str(k).encode())
                self.add(value[k])
        elif isinstance(value, (list, tuple)):
            for v in value:
                self.add(v)
        elif isinstance(value, (float, np.floating)):
            self._h.update(float(value).hex().encode())
        else:
            self._h.update(repr(value).encode())

    def hexdigest(self) -> str:
        return self._h.hexdigest()[:20]


def simulation_fingerprint(sim: dg.Simulation) -> str:
    h = _Hasher()
    for value in (sim.positions, sim.velocities, sim.species, sim.internal_energy, sim.ids,
                  sim.counters(), sim.reactions(), sim.time, sim.kinetic_energy(),
                  sim.internal_energy_total(), sim.dissipated_energy, sim.energy_input,
                  sim.energy_balance()):
        h.add(value)
    return h.hexdigest()


def scene_runs(integrators=("step", "event"), seeds=SEEDS):
    """{name: fingerprint} of every built-in scene, run in two calls (split runs and a
    continued copy must agree with one run, so splitting here also pins that)."""
    out = {}
    for name in dg.scenes.names():
        for integ in integrators:
            for seed in seeds:
                sim = dg.Simulation(name, seed=seed, integrator=integ)
                n = STEPS[integ]
                sim.step(n // 3)
                sim = sim.copy()
                sim.step(n - n // 3)
                out[f"scene/{name}/{integ}/seed{seed}"] = simulation_fingerprint(sim)
    return out


def control_runs(integrators=("step", "event"), seeds=SEEDS):
    """{name: fingerprint} of every built-in scene driven through the Simulation's controls
    (heating, cooling, injection, a wall moved in and out) between runs, and restored from a
    state in the middle."""
    out = {}
    for name in dg.scenes.names():
        for integ in integrators:
            for seed in seeds:
                sim = dg.Simulation(name, seed=seed, integrator=integ)
                n = STEPS[integ] // 6
                b = sim.bounds
                sim.step(n)
                sim.scale_temperature(1.3)
                placed = sim.inject(0, 5)
                placed += sim.inject(len(sim.scene.species) - 1, 3, temperature=2.0,
                                     near=(b.center if isinstance(b, dg.Circle) else
                                           (b.origin[0] + 0.5 * b.width,
                                            b.origin[1] + 0.5 * b.height)))
                sim.step(n)
                if isinstance(b, dg.Box):
                    sim.resize(dg.Box(0.9 * b.width, b.height, b.origin))
                else:
                    sim.resize(dg.Circle(0.95 * b.radius, b.center))
                sim.step(n)
                state = sim.get_state()
                sim.scale_temperature(0.7)
                sim.step(n)
                sim.set_state(state)
                sim.resize(b)
                sim.scale_temperature(0.8)
                sim.step(n)
                out[f"controls/{name}/{integ}/seed{seed}"] = (
                    simulation_fingerprint(sim) + f"/{placed}")
    return out


def large_runs(seed=7):
    """{name: fingerprint} of runs above 10^5 discs, where the stepped integrator takes its
    other paths: the event phase by clusters on the calling thread (above the pair list's
    range), and on two threads with the parallel drift and scan (clusters in chunks,
    escapes, repairs and merges at packing 0.5; the TC model at e < 1; first-order reactions
    and fissions between event phases); and the pair list of a long call on one thread."""
    from discgym.bench import bench_scene
    from discgym.kernels import step as S
    from discgym.threads import ENV_VAR as threads_env

    B = dg.Species("B", 1.0, 1.0)
    C = dg.Species("C", 1.0, 2.0)
    n = S.PAIR_MAX_DISCS + 3000
    cases = {
        "clusters1/e1": (bench_scene(n, eta=0.5), 1, 3),
        "threads2/e1": (bench_scene(n, eta=0.5), 2, 3),
        "threads2/e0.7": (bench_scene(n, eta=0.5, restitution=0.7), 2, 3),
        "threads2/e0": (bench_scene(n, eta=0.3, restitution=0.0), 2, 3),
        "threads2/reactions": (bench_scene(n - 4000, extra_species=[B, C],
                                           extra_counts={"C": 4000}, reactions=[
            dg.Transformation("A", "B", 0.05), dg.Transformation("B", "A", 0.05),
            dg.Decomposition("C", "A", "A", 0.5)]), 2, 3),
        "pairlist1/e0.9": (bench_scene(100_000, eta=0.4, restitution=0.9), 1,
                           S.PAIR_MIN_STEPS),
    }
    os.environ[threads_env] = "0"  # (the threads asked for, not the ones measured fastest)
    out = {}
    for name, (scene, threads, steps) in cases.items():
        sim = dg.Simulation(scene, seed=seed)
        sim.threads = threads
        sim.step(steps)
        out[f"large/{name}"] = simulation_fingerprint(sim)
    return out


def _episode(env, policy, seed: int) -> tuple[str, str]:
    """The fingerprints of an episode's trajectory (observations, rewards, flags) and of its
    infos, apart: a change of the info format leaves the trajectory's untouched."""
    h = _Hasher()
    hi = _Hasher()
    obs, info = env.reset(seed=seed)
    h.add(obs)
    hi.add(info)
    for _ in range(ENV_STEPS):
        obs, reward, term, trunc, info = env.step(policy(obs))
        h.add((obs, reward, term, trunc))
        hi.add(info)
    return h.hexdigest(), hi.hexdigest()


def _controller_policy(env):
    """The task's hand-written controller, reset at each reset (a stateful one is built per
    env; for the vector env, one per reactor)."""
    from discgym.controllers import controller_for

    n = getattr(env, "num_envs", None)
    if n is None:
        ctl = controller_for(env)
        return ctl
    ctls = [controller_for(env) for _ in range(n)]
    return lambda obs: np.stack([c(o) for c, o in zip(ctls, obs)])


def env_runs(seeds=SEEDS):
    """{name: fingerprint} of env episodes: the single env and the vector env, with random
    actions from a seeded generator and with the heuristic baseline (DiscReactor-v0), and
    every other task of the suite with random actions and its hand-written controller."""
    import gymnasium as gym

    from discgym import baselines as denv
    from discgym.tasks import TASKS

    out = {}

    def put(key, fp):
        out[f"env/{key}"], out[f"envinfo/{key}"] = fp

    for seed in seeds:
        env = gym.make("DiscReactor-v0")
        put(f"single/random/seed{seed}", _episode(env, denv.random_policy(4, seed=100 + seed),
                                                  seed))
        put(f"single/heuristic/seed{seed}", _episode(env, denv.heuristic_policy, seed))
        env.close()
    venv = gym.make_vec("DiscReactor-v0", num_envs=4, vectorization_mode="vector_entry_point")
    for seed in seeds:
        put(f"vector4/random/seed{seed}", _episode(
            venv, denv.random_policy(4, seed=200 + seed), seed))
        put(f"vector4/heuristic/seed{seed}", _episode(venv, denv.heuristic_policy, seed))
    venv.close()
    for env_id in sorted(TASKS):
        if env_id == "DiscReactor-v0":
            continue
        for seed in seeds[:2]:
            env = gym.make(env_id)
            A = env.action_space.shape[0]
            put(f"{env_id}/single/random/seed{seed}", _episode(
                env, denv.random_policy(A, seed=300 + seed), seed))
            put(f"{env_id}/single/controller/seed{seed}", _episode(
                env, _controller_policy(env), seed))
            env.close()
        venv = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point")
        A = venv.single_action_space.shape[0]
        put(f"{env_id}/vector3/random/seed{seeds[0]}", _episode(
            venv, denv.random_policy(A, seed=400), seeds[0]))
        venv.close()
    return out


def platform_key() -> dict:
    import numba

    return {"machine": platform.machine(), "processor": _cpu_model(),
            "python": platform.python_version(), "numpy": np.__version__,
            "numba": numba.__version__}


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def all_fingerprints() -> dict:
    return {**scene_runs(), **control_runs(), **env_runs(), **large_runs()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    group = ap.add_mutually_exclusive_group(required=True)
    group.add_argument("--write", type=Path, help="record the fingerprints in this file")
    group.add_argument("--check", type=Path, help="compare with the fingerprints in this file")
    ap.add_argument("--confirm", action="store_true",
                    help="with --check: when every fingerprint is identical on a platform other "
                         "than the recording one, add it to the file's 'also_on' (the test then "
                         "runs there too)")
    args = ap.parse_args(argv)
    if args.confirm and not args.check:
        ap.error("--confirm goes with --check")
    prints = all_fingerprints()
    if args.write:
        args.write.write_text(json.dumps({"platform": platform_key(), "fingerprints": prints},
                                         indent=1, sort_keys=True) + "\n")
        print(f"{len(prints)} fingerprints written to {args.write}")
        return 0
    recorded = json.loads(args.check.read_text())
    if recorded["platform"] != platform_key():
        print(f"note: recorded on {recorded['platform']}, checking on {platform_key()}")
    old = recorded["fingerprints"]
    changed = sorted(k for k in old.keys() | prints.keys() if old.get(k) != prints.get(k))
    for k in changed:
        print(f"changed: {k}: {old.get(k)} -> {prints.get(k)}")
    print(f"{len(prints) - len(changed)} of {len(prints)} fingerprints identical")
    here = platform_key()
    if args.confirm and not changed and here not in verified_platforms(recorded):
        recorded.setdefault("also_on", []).append(here)
        args.check.write_text(json.dumps(recorded, indent=1, sort_keys=True) + "\n")
        print(f"added {here} to also_on in {args.check}")
    return 1 if changed else 0


def verified_platforms(recorded: dict) -> list:
    """The platforms a golden file holds for: the one it was recorded on, and those on which
    ``--check --confirm`` found every fingerprint identical."""
    return [recorded["platform"], *recorded.get("also_on", [])]


if __name__ == "__main__":
    sys.exit(main())
