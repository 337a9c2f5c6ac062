"""How fast is DiscReactor-v0? Prints four tables for the default env.

1. the single env made with ``gymnasium.make`` (wrappers included): env steps/s, and the share
   of a step spent outside the compiled kernel (the Python layer: actions, observation,
   reward, info, gymnasium's wrappers);
2. the vector env: reactor-steps/s for 1, 16, 64, 256 reactors on one thread and on all cores
   (``numba.set_num_threads``), and the speed-up, for random actions and for one whole
   episode of the heuristic (the batched kernel alone in brackets);
3. where the time of a vector step goes (kernel vs Python) at 64 reactors over one episode
   of the heuristic;
4. a short Stable-Baselines3 PPO run on the batched env: the share of its wall time spent in
   the environment (SB3's default PPO hyperparameters, 16 reactors, n_steps=128).

With ``--baselines`` it instead prints the three baselines of docs/env.md: the scheduled
heuristic, the best constant action (searched on other seeds) and uniform random actions,
as mean +- std of the episode return over 16 seeded episodes.

Run:  python benchmarks/bench_env.py              (~3-5 min on 2 cores)
      python benchmarks/bench_env.py --quick      (smaller, for a smoke test)
      python benchmarks/bench_env.py --baselines  (~5 min on 2 cores)
Actions are seeded, so every configuration steps the same trajectories. Each figure is the
best of ``--repeat`` (3) runs, the runs of the compared configurations interleaved: on a shared
or virtual machine the speed drifts by tens of percent from minute to minute. Numbers depend
on the machine and on its load: quote them with the command and the machine.
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import numba
import numpy as np

import discgym  # noqa: F401  (registers DiscReactor-v0)
import discgym.kernels.step as kstep
from discgym.vector import DiscReactorVectorEnv


@numba.njit(parallel=True, cache=True)
def _spin(R, m):
    out = np.zeros(R)
    for r in numba.prange(R):
        x = 1.0 + r
        acc = 0.0
        for _ in range(m):
            x = x * 1.0000001 + 0.1
            acc += np.sqrt(x)
        out[r] = acc
    return out


def machine_scaling(threads: int, repeat: int) -> float:
    """Speed-up of a trivially parallel, compute-bound numba loop on ``threads`` threads: what
    this machine offers right now (on a shared or virtual machine, often less than the core
    count)."""
    _spin(4, 10)
    best = {1: np.inf, threads: np.inf}
    for _ in range(repeat):
        for t in best:
            numba.set_num_threads(t)
            t0 = time.perf_counter()
            _spin(64, 400_000)
            best[t] = min(best[t], time.perf_counter() - t0)
    numba.set_num_threads(threads)
    return best[1] / best[threads]


class KernelTimer:
    """Times every call of the compiled environment step (``discgym.kernels.batch.env_step``:
    the controls, the physics and the observation of one step, in one call) and, separately,
    every other compiled function called from Python (at a reset: placement and the first
    observation): what is left is the Python layer. Times include numba's dispatch of the
    arguments (a few microseconds for ``env_step``'s nine, most of them structs)."""

    def __init__(self):
        import discgym.core as envmod
        import discgym.kernels.controls as kcontrols
        import discgym.simulation as simmod

        self.total = 0.0  # the compiled step
        self.other = 0.0  # every other compiled call
        self.calls = 0
        self._targets = [(envmod, "env_step", "total")]
        for mod in (simmod, envmod, kcontrols, kstep):
            for name, obj in vars(mod).items():
                if isinstance(obj, numba.core.registry.CPUDispatcher) and name != "env_step":
                    self._targets.append((mod, name, "other"))
        self._saved = []

    def __enter__(self):
        for mod, name, slot in self._targets:
            orig = getattr(mod, name)
            self._saved.append((mod, name, orig))
            setattr(mod, name, self._timed(orig, slot))
        return self

    def _timed(self, orig, slot):
        def timed(*args):
            t = time.perf_counter()
            out = orig(*args)
            setattr(self, slot, getattr(self, slot) + time.perf_counter() - t)
            if slot == "total":
                self.calls += 1
            return out

        return timed

    def __exit__(self, *exc):
        for mod, name, orig in reversed(self._saved):
            setattr(mod, name, orig)
        self._saved.clear()


def bench_single(steps: int, policy: str = "random") -> dict:
    """``policy``: "random" (uniform actions: the wall moves and the temperature swings every
    step) or "heuristic" (discgym.baselines.heuristic_policy: typical control)."""
    from discgym.baselines import heuristic_policy

    env = gym.make("DiscReactor-v0")
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (steps, env.action_space.shape[0])).astype(np.float32)
    obs, _ = env.reset(seed=0)
    for a in acts[:5]:  # warm up (compile / load the cache)
        env.step(a)
    obs, _ = env.reset(seed=1)
    wall = 0.0
    with KernelTimer() as kt:
        for a in acts:
            if policy == "heuristic":
                a = heuristic_policy(obs)
            t0 = time.perf_counter()
            obs, _, term, trunc, _ = env.step(a)
            wall += time.perf_counter() - t0
            if term or trunc:
                obs, _ = env.reset()
    env.close()
    return {"steps_per_s": steps / wall, "us_per_step": 1e6 * wall / steps,
            "kernel_us": 1e6 * kt.total / steps, "outside": 1.0 - kt.total / wall,
            "python": 1.0 - (kt.total + kt.other) / wall}


def _time_vector_kernels(vmod, spent: list) -> dict:
    """Wrap the vector env's compiled step (serial and parallel) so that its time adds up
    in ``spent[0]``; returns the originals (to put back)."""
    saved = {name: getattr(vmod, name) for name in ("env_step", "env_step_parallel")}

    def wrap(orig):
        def timed(*args):
            t = time.perf_counter()
            orig(*args)
            spent[0] += time.perf_counter() - t

        return timed

    for name, orig in saved.items():
        setattr(vmod, name, wrap(orig))
    return saved


def bench_vector(R: int, threads: int, steps: int, policy: str) -> tuple[float, float]:
    """(reactor-steps/s of whole vector steps, reactor-steps/s of the batched kernel alone).

    ``policy``: "random" (every control acts on every step: the worst case for the Python
    part; ``steps`` steps after 2 warm-up steps) or "heuristic"
    (discgym.baselines.heuristic_policy, one whole episode; its own time is not counted)."""
    import discgym.core as vmod
    from discgym.baselines import heuristic_policy

    venv = DiscReactorVectorEnv(num_envs=R, threads=threads)
    if policy == "heuristic":
        steps = venv.config.episode_steps
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (steps + 2, R, venv.single_action_space.shape[0]))
    acts = acts.astype(np.float32)
    obs, _ = venv.reset(seed=0)
    if policy == "random":
        obs, *_ = venv.step(acts[0])
        obs, *_ = venv.step(acts[1])
    spent = [0.0]
    saved = _time_vector_kernels(vmod, spent)
    wall = 0.0
    try:
        for a in acts[2:]:
            if policy == "heuristic":
                a = heuristic_policy(obs)
            t0 = time.perf_counter()
            obs, *_ = venv.step(a)
            wall += time.perf_counter() - t0
    finally:
        vars(vmod).update(saved)
    venv.close()
    return R * steps / wall, R * steps / spent[0]


def bench_vector_split(R: int) -> dict:
    """One full episode of the heuristic on R reactors: the share of the wall time spent in
    the batched kernel vs the Python around it (controls, observation, info)."""
    import discgym.core as vmod
    from discgym.baselines import heuristic_policy

    venv = DiscReactorVectorEnv(num_envs=R, autoreset_mode="Disabled")
    obs, _ = venv.reset(seed=0)
    spent = [0.0]
    saved = _time_vector_kernels(vmod, spent)
    wall = 0.0
    steps = venv.config.episode_steps
    try:
        for _ in range(steps):
            a = heuristic_policy(obs)
            t0 = time.perf_counter()
            obs, *_ = venv.step(a)
            wall += time.perf_counter() - t0
    finally:
        vars(vmod).update(saved)
    return {"wall_ms": 1e3 * wall / steps, "kernel_ms": 1e3 * spent[0] / steps,
            "outside": 1.0 - spent[0] / wall}


def bench_ppo(num_envs: int, n_steps: int, rollouts: int) -> dict | None:
    try:
        from stable_baselines3 import PPO
        from stable_baselines3.common.vec_env import VecMonitor

        from discgym.sb3 import DiscReactorSB3VecEnv
    except ImportError:
        return None
    venv = DiscReactorSB3VecEnv(num_envs=num_envs)
    spent = [0.0]
    orig = venv.step_wait

    def timed():
        t = time.perf_counter()
        out = orig()
        spent[0] += time.perf_counter() - t
        return out

    venv.step_wait = timed
    env = VecMonitor(venv)
    model = PPO("MlpPolicy", env, n_steps=n_steps, seed=0, device="cpu")
    model.learn(total_timesteps=num_envs * n_steps)  # warm-up rollout (and compile)
    spent[0] = 0.0
    t0 = time.perf_counter()
    model.learn(total_timesteps=rollouts * num_envs * n_steps, reset_num_timesteps=False)
    wall = time.perf_counter() - t0
    return {"wall_s": wall, "env_s": spent[0], "share": spent[0] / wall,
            "samples_per_s": rollouts * num_envs * n_steps / wall}


def baselines(episodes: int = 16, seed: int = 0, search_episodes: int = 8,
              search_seed: int = 1000) -> None:
    """Print the three baselines of docs/env.md (returns over ``episodes`` seeded episodes)."""
    from discgym.baselines import (
        best_constant_action,
        constant_policy,
        evaluate,
        heuristic_policy,
        random_policy,
    )

    t0 = time.perf_counter()
    grid = [[h, w, ia, ib] for h in (0.0, 0.005, 0.01, 0.015, 0.02, 0.03, 0.05)
            for w in (-1.0, 0.0, 1.0) for ia, ib in ((0, 0), (1, 1), (0, 1), (1, 0))]
    best, means = best_constant_action(grid, episodes=search_episodes, seed=search_seed)
    order = np.argsort(means)[::-1]
    print(f"best constant actions on seeds {search_seed}..{search_seed + search_episodes - 1} "
          f"({len(grid)} candidates; heat, wall, inject A, inject B):")
    for k in order[:5]:
        print(f"   {grid[k]}  {means[k]:.3f}")
    rows = [("scheduled heuristic (discgym.baselines.heuristic_policy)", heuristic_policy),
            (f"best constant action {[round(float(x), 3) for x in best]}",
             constant_policy(best)),
            ("uniform random actions (random_policy(seed=0))", random_policy(4, seed=0))]
    print(f"\nreturns over seeds {seed}..{seed + episodes - 1} (mean +- std):")
    for name, pol in rows:
        r = evaluate(pol, episodes=episodes, seed=seed)
        print(f"   {name:56s} {r.mean():.3f} +- {r.std():.3f}  (min {r.min():.3f}, "
              f"max {r.max():.3f})")
    print(f"({time.perf_counter() - t0:.0f} s)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (smoke test)")
    ap.add_argument("--no-ppo", action="store_true", help="skip the SB3 PPO run")
    ap.add_argument("--repeat", type=int, default=3, help="runs per figure (best is kept)")
    ap.add_argument("--baselines", action="store_true",
                    help="print the heuristic / best constant / random baselines instead")
    args = ap.parse_args()
    if args.baselines:
        baselines()
        return
    all_cores = numba.config.NUMBA_NUM_THREADS
    print(f"discgym {discgym.__version__}, numba {numba.__version__}, {os.cpu_count()} CPUs, "
          f"numba threads {all_cores}; load average {os.getloadavg()[0]:.2f}")
    env = gym.make("DiscReactor-v0")
    cfg = env.unwrapped.config
    print(f"default env: scene {cfg.scene.name!r}, ~{int(cfg.template.sum())} discs, "
          f"{cfg.episode_steps} steps of {cfg.steps_per_action} x dt={cfg.scene.dt}")
    env.close()
    print(f"machine check: a compute-bound numba prange runs {machine_scaling(all_cores, 3):.2f}x "
          f"faster on {all_cores} threads than on 1")

    print("\n1. single env (gymnasium.make, wrappers and resets included, policy excluded;"
          "\n   outside the kernel: all but the compiled env step; Python layer: all but compiled "
          "code)")
    steps = 100 if args.quick else 300
    runs = {p: [bench_single(steps, p) for _ in range(args.repeat)]
            for p in ("random", "heuristic")}
    for policy, rs in runs.items():
        s = max(rs, key=lambda d: d["steps_per_s"])
        shares = ", ".join(f"{100 * d['python']:.1f}%" for d in rs)
        print(f"   {policy:9s} actions: {s['steps_per_s']:6.0f} env steps/s  "
              f"{s['us_per_step']:6.0f} us/step, kernel {s['kernel_us']:6.0f} us, outside the "
              f"kernel {100 * s['outside']:.1f}%, Python layer {100 * s['python']:.1f}% "
              f"(all runs: {shares})")

    print("\n2. vector env, reactor-steps/s; in brackets: the batched kernel alone")
    sizes = (1, 16, 64) if args.quick else (1, 16, 64, 256)
    for policy in ("random", "heuristic"):
        print(f"   {policy} actions")
        print(f"   {'reactors':>8} {'1 thread':>16} {f'{all_cores} threads':>16} "
              f"{'speed-up':>16}")
        for R in sizes:
            steps = max(10, (1000 if not args.quick else 40) // R)
            res = {1: [], all_cores: []}
            for _ in range(args.repeat):
                for t in res:
                    res[t].append(bench_vector(R, t, steps, policy))
            one = max(r[0] for r in res[1])
            one_k = max(r[1] for r in res[1])
            many = max(r[0] for r in res[all_cores])
            many_k = max(r[1] for r in res[all_cores])
            print(f"   {R:8d} {one:7.0f} ({one_k:6.0f}) {many:7.0f} ({many_k:6.0f}) "
                  f"{many / one:7.2f}x ({many_k / one_k:4.2f}x)")

    R = 16 if args.quick else 64
    print(f"\n3. vector env, {R} reactors, all threads, one episode of the heuristic")
    v = bench_vector_split(R)
    print(f"   {v['wall_ms']:.1f} ms/step, batched kernel {v['kernel_ms']:.1f} ms, "
          f"Python around it {100 * v['outside']:.1f}%")

    if not args.no_ppo:
        print("\n4. SB3 PPO (MlpPolicy, defaults; 16 reactors x n_steps=128)")
        p = bench_ppo(16, 128, 1 if args.quick else 4)
        if p is None:
            print("   skipped: stable-baselines3 not installed")
        else:
            print(f"   {p['wall_s']:.1f} s wall, {p['env_s']:.1f} s in the env: "
                  f"{100 * p['share']:.0f}% of the run ({p['samples_per_s']:.0f} samples/s)")


if __name__ == "__main__":
    main()
