"""Training throughput: RLlib PPO with 1 and 2 env runners against SB3 PPO, in env steps per
second of wall time, on this machine.

    python benchmarks/bench_rllib.py                # the table of docs/ecosystem.md
    python benchmarks/bench_rllib.py --iterations 3 # shorter
    python benchmarks/bench_rllib.py --nodes        # 2 env runners on 1 node vs on 2 nodes

Every path trains PPO with the same batch: 16 reactors of DiscReactor-v0 per sampler
(the native vector env: RLlib's ``gym_env_vectorize_mode="vector_entry_point"`` in each env
runner; SB3 through ``discgym.sb3.DiscReactorSB3VecEnv``), 128 steps per reactor per
iteration, 10 epochs of minibatches of 64, a 64x64 MLP, one numba thread per sampler. The
clock runs over whole training iterations (sampling + learning) after a first, untimed one
(compilation, Ray's start-up). RLlib's 2 runners sample twice the steps per iteration. RLlib
runs in a local Ray on 127.0.0.1 with one logical CPU per env runner and one for the
driver (which learns).

``--nodes``: RLlib with the same 2 env runners three ways, interleaved ``--repeats`` times (A B C
A B C ...): the local Ray above, a one-node Ray cluster of 2 CPUs and a two-node Ray cluster of
1 CPU per node (one runner on each), the clusters made by agents/ray_cluster.py on 127.0.0.1
(Ray's multi-node test cluster: a raylet per node), the script connected with ``--address``.
Reports env steps sampled per second of training wall time and seconds per iteration.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "agents"))

ENVS, ROLLOUT, MINIBATCH, EPOCHS = 16, 128, 64, 10


def bench_sb3(iterations: int) -> tuple[float, int]:
    from stable_baselines3 import PPO
    from train_ppo import set_torch_threads

    from discgym.sb3 import DiscReactorSB3VecEnv

    set_torch_threads(1)
    venv = DiscReactorSB3VecEnv(num_envs=ENVS, threads=1)
    model = PPO("MlpPolicy", venv, n_steps=ROLLOUT, batch_size=MINIBATCH, n_epochs=EPOCHS,
                learning_rate=3e-4, gamma=0.99, gae_lambda=0.95, seed=0, device="cpu",
                policy_kwargs={"net_arch": [64, 64]})
    model.learn(ENVS * ROLLOUT)  # (untimed: compilation)
    t = time.perf_counter()
    model.learn(iterations * ENVS * ROLLOUT, reset_num_timesteps=False)
    dt = time.perf_counter() - t
    steps = iterations * ENVS * ROLLOUT
    venv.close()
    return steps / dt, steps


def bench_rllib(runners: int, iterations: int) -> tuple[float, int]:
    import train_rllib

    args = train_rllib.parse([
        "--iterations", str(iterations + 1), "--env-runners", str(runners),
        "--envs-per-runner", str(ENVS), "--rollout", str(ROLLOUT),
        "--minibatch", str(MINIBATCH), "--epochs", str(EPOCHS),
        "--num-cpus", str(runners + 1), "--out", "runs/bench_rllib"])
    rows = train_rllib.train(args)
    first, last = rows[0], rows[-1]
    steps = last["env_steps"] - first["env_steps"]
    return steps / (last["wall_s"] - first["wall_s"]), steps


def bench_rllib_nodes(nodes: int | None, iterations: int) -> tuple[float, float, int]:
    """2 env runners on a local Ray (``nodes`` None) or on a loopback cluster of ``nodes``
    nodes sharing 2 CPUs; returns (env steps/s, s/iteration, env steps timed)."""
    import ray_cluster
    import train_rllib

    argv = ["--iterations", str(iterations + 1), "--env-runners", "2",
            "--envs-per-runner", str(ENVS), "--rollout", str(ROLLOUT),
            "--minibatch", str(MINIBATCH), "--epochs", str(EPOCHS), "--out",
            "runs/bench_rllib"]
    if nodes is None:
        rows = train_rllib.train(train_rllib.parse([*argv, "--num-cpus", "3"]))
    else:
        with ray_cluster.loopback_cluster(nodes, 2 // nodes) as cluster:
            rows = train_rllib.train(train_rllib.parse([*argv, "--address",
                                                        cluster.address]))
            where = ray_cluster.env_runner_nodes(cluster)
            assert len(set(where)) == nodes, where  # (one runner per node on 2 nodes)
    first, last = rows[0], rows[-1]
    steps, dt = last["env_steps"] - first["env_steps"], last["wall_s"] - first["wall_s"]
    return steps / dt, dt / (len(rows) - 1), steps


def main_nodes(iterations: int, repeats: int) -> None:
    paths = [("local Ray (train_rllib.py's own), 3 CPUs", None),
             ("Ray cluster, 1 node x 2 CPUs", 1), ("Ray cluster, 2 nodes x 1 CPU", 2)]
    results = {name: [] for name, _ in paths}
    for r in range(repeats):
        for name, nodes in paths:
            rate, per_it, steps = bench_rllib_nodes(nodes, iterations)
            results[name].append((rate, per_it, steps))
            print(f"repeat {r + 1}: {name}: {rate:.0f} env steps/s, {per_it:.2f} s/iteration",
                  flush=True)
    print("\n| 2 env runners x 16 reactors on | env steps timed | env steps/s (each run) | "
          "s/iteration (each run) |\n|---|---|---|---|")
    for name, runs in results.items():
        print(f"| {name} | {sum(s for *_, s in runs)} | "
              f"{', '.join(f'{r:.0f}' for r, _, _ in runs)} | "
              f"{', '.join(f'{t:.1f}' for _, t, _ in runs)} |")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--iterations", type=int, default=6, help="timed iterations per path")
    p.add_argument("--nodes", action="store_true",
                   help="2 env runners on a local Ray, a 1-node and a 2-node Ray cluster")
    p.add_argument("--repeats", type=int, default=2, help="interleaved rounds of --nodes")
    args = p.parse_args(argv)
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    if args.nodes:
        return main_nodes(args.iterations, args.repeats)
    rows = [("SB3 PPO, DiscReactorSB3VecEnv (16 reactors)", *bench_sb3(args.iterations))]
    for runners in (1, 2):
        rows.append((f"RLlib PPO, {runners} env runner(s) x 16 reactors",
                     *bench_rllib(runners, args.iterations)))
    print("\n| path | env steps timed | env steps/s |\n|---|---|---|")
    for name, rate, steps in rows:
        print(f"| {name} | {steps} | {rate:.0f} |")


if __name__ == "__main__":
    main()
