"""PPO with Ray RLlib: the scale-out path, from one machine to a Ray cluster of several.

Each RLlib env runner builds the native vector env (``gym_env_vectorize_mode=
"vector_entry_point"``: ``num_envs_per_env_runner`` reactors stepped in one compiled call),
so an env runner costs one process whatever its number of reactors; the learner runs in the
driver. On one machine::

    pip install torch==2.13.0 && pip install -e ".[agents,rllib]"
    python agents/train_rllib.py --env-runners 2 --iterations 50
    python agents/train_rllib.py --env-id DiscFlow-v0 --env-runners 2   # any task of the suite

On a cluster (docs/ecosystem.md, "RLlib on several machines"): install the same clone on
every machine, ``ray start --head --node-ip-address=IP`` on one, ``ray start --address=IP:6379``
on the others, then run this script on the head with ``--address auto`` and
``--env-runners`` up to the cluster's CPUs minus one (the learner's). Before training, the
script compiles discgym's numba kernels once on every node (one cache per node, next to the
sources, so the env runners of a node load it rather than all compile at once), and each env
runner steps its reactors on ``--cpus-per-runner`` numba threads (``NUMBA_NUM_THREADS`` and
the env's ``threads``), as many as Ray reserves for it.

Writes ``<out>/progress.csv`` (one row per iteration: env steps, episodes, mean episode return,
wall time) and ``<out>/args.json``, and prints the same; ``--checkpoint`` saves the algorithm.
Every argument is checked before Ray starts (a bad one is refused in one line, exit status 2;
so is a missing Ray, with the command that installs it), and the folder is written as a
hidden sibling renamed into place at the end: an interrupted run leaves none.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import json
import os
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

sys.path.insert(0, str(Path(__file__).resolve().parent))
from argcheck import (  # noqa: E402
    MAX_SEED,
    Range,
    UsageError,
    check_env_kwargs,
    check_fields,
    check_json_object,
    check_out_folder,
    check_task,
    staged_folder,
    usage,
)


@dataclass
class Args:
    """RLlib PPO arguments; each is also a flag (``--env-id``, ``--env-runners``, ...)."""

    env_id: str = "DiscReactor-v0"
    """the task (``discgym.tasks.TASKS``); each env runner builds its native vector env"""
    iterations: Annotated[int, Range(1)] = 50
    """training iterations"""
    env_runners: Annotated[int, Range(0)] = 1
    """RLlib env runners (processes); 0 samples in the driver"""
    envs_per_runner: Annotated[int, Range(1)] = 16
    """reactors in each env runner's native vector env"""
    cpus_per_runner: Annotated[int, Range(1)] = 1
    """CPUs Ray reserves per env runner = numba threads of its vector env"""
    rollout: Annotated[int, Range(1)] = 128
    """steps per reactor per iteration (rollout_fragment_length)"""
    minibatch: Annotated[int, Range(1)] = 64
    """SGD minibatch, at most the train batch (rollout x envs-per-runner x env runners)"""
    epochs: Annotated[int, Range(1)] = 10
    """SGD passes over each train batch"""
    env_config: str = "{}"
    """JSON keyword arguments of the env, e.g. '{"n_discs": 120}' (not threads: that is
    --cpus-per-runner; not num_envs: --envs-per-runner)"""
    address: str | None = None
    """a running Ray cluster ('auto' or HEAD_IP:6379); default: a local Ray on 127.0.0.1"""
    num_cpus: Annotated[int | None, Range(1)] = None
    """CPUs of the local Ray (default: all of this machine's); not with --address"""
    seed: Annotated[int, Range(0, MAX_SEED)] = 0
    out: str = "runs/rllib"
    """output folder (an existing run folder there is replaced when the run ends)"""
    checkpoint: bool = False
    """save the algorithm at the end"""
    plot: bool = False
    """save <out>/learning_curve.png (needs matplotlib)"""

    def train_batch(self) -> int:
        return self.rollout * self.envs_per_runner * max(self.env_runners, 1)


#: Keys of --env-config that flags set.
SET_BY_FLAGS = {"threads": "--cpus-per-runner", "num_envs": "--envs-per-runner"}


def check_args(args: Args) -> dict:
    """The validation pass, before Ray starts or anything is written: every flag against its
    type and range, the task (through Gymnasium's registry), ``--env-config`` (as the env
    would check it), ``--out``, the flags taken together, and Ray RLlib importable. Returns
    the env config."""
    check_fields(args)
    env_cls = check_task(args.env_id)
    cfg = check_json_object(args.env_config, "env_config")
    for key, by in SET_BY_FLAGS.items():
        if key in cfg:
            raise usage("env_config", f"{key!r} is set by {by}, not here")
    check_env_kwargs(env_cls, cfg, "env_config")
    if args.minibatch > args.train_batch():
        raise usage("minibatch", f"{args.minibatch} is more than the train batch "
                                 f"{args.train_batch()} (--rollout x --envs-per-runner x "
                                 f"--env-runners)")
    if args.address is not None:
        if not re.fullmatch(r"auto|(ray://)?[\w.\-\[\]:]+:\d+", args.address):
            raise usage("address", f"expected 'auto' or HOST:PORT, got {args.address!r}")
        if args.num_cpus is not None:
            raise usage("num_cpus", "sets the local Ray's CPUs; a cluster (--address) has "
                                    "its own")
    else:
        cpus = args.num_cpus or os.cpu_count() or 1
        need = args.env_runners * args.cpus_per_runner
        if need > cpus:  # (Ray would wait for CPUs that never come)
            raise usage("env_runners", f"{args.env_runners} runners x --cpus-per-runner "
                        f"{args.cpus_per_runner} need {need} CPUs, more than the local "
                        f"Ray's {cpus}" + ("" if args.num_cpus else " (this machine's)"))
    check_out_folder(args.out, "out", marker="progress.csv")
    try:
        import ray.rllib  # noqa: F401
    except ImportError as e:
        raise UsageError(f"Ray RLlib is not installed ({e}): pip install -e '.[rllib]' "
                         f"(with torch, as docs/ecosystem.md says)") from None
    return cfg


def warm_kernels(threads: int = 1, env_id: str = "DiscReactor-v0") -> str:
    """Compile (or load from the cache) discgym's kernels on this machine: one short
    episode of the task's native vector env. Returns the host name."""
    os.environ.setdefault("NUMBA_NUM_THREADS", str(max(threads, 1)))
    import socket

    import gymnasium as gym
    import numpy as np

    import discgym  # noqa: F401

    env = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point",
                       threads=max(threads, 1), n_discs=40, episode_steps=2)
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros(env.action_space.shape, np.float32))
    env.close()
    return socket.gethostname()


def warm_every_node(threads: int, env_id: str = "DiscReactor-v0") -> list[str]:
    """Run :func:`warm_kernels` once on every node of the Ray cluster (pinned to it), so that
    the env runners of a node find the kernels compiled."""
    import sys

    import ray
    from ray import cloudpickle
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    if __name__ != "__main__":  # (imported: Ray's workers cannot import this script)
        cloudpickle.register_pickle_by_value(sys.modules[__name__])
    task = ray.remote(num_cpus=1)(warm_kernels)
    refs = [task.options(scheduling_strategy=NodeAffinitySchedulingStrategy(
        node["NodeID"], soft=False)).remote(threads, env_id)
        for node in ray.nodes() if node["Alive"] and node["Resources"].get("CPU", 0) >= 1]
    return ray.get(refs)


def build_config(args, env_config: dict):
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.connectors.env_to_module import MeanStdFilter
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    return (
        PPOConfig()
        # ("module:id": each env runner imports discgym itself)
        .environment(f"discgym:{args.env_id}", env_config=env_config)
        .env_runners(
            num_env_runners=args.env_runners,
            num_envs_per_env_runner=args.envs_per_runner,
            num_cpus_per_env_runner=args.cpus_per_runner,
            gym_env_vectorize_mode="vector_entry_point",
            rollout_fragment_length=args.rollout,
            # observation normalisation (SB3's VecNormalize(norm_reward=False) in
            # agents/train_ppo.py)
            env_to_module_connector=lambda env, spaces, device: MeanStdFilter(),
        )
        .learners(num_learners=0)  # (the learner runs in the driver)
        .training(
            lr=3e-4, gamma=0.99, lambda_=0.95, clip_param=0.2, entropy_coeff=0.0,
            vf_loss_coeff=0.5, grad_clip=0.5,
            train_batch_size_per_learner=args.train_batch(),
            minibatch_size=args.minibatch, num_epochs=args.epochs,
        )
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[64, 64],
                                                   fcnet_activation="tanh",
                                                   vf_share_layers=False))
        .debugging(seed=args.seed)
    )


def train(args: Args) -> list[dict]:
    """Train; returns the rows of ``progress.csv``. Refuses a bad argument
    (:func:`check_args`) before Ray starts; the output folder appears when training ends."""
    cfg = check_args(args)
    import ray
    from ray.rllib.utils.metrics import (
        ENV_RUNNER_RESULTS,
        EPISODE_RETURN_MEAN,
        NUM_ENV_STEPS_SAMPLED_LIFETIME,
        NUM_EPISODES_LIFETIME,
    )

    threads = args.cpus_per_runner
    env_vars = {"NUMBA_NUM_THREADS": str(threads)}
    rows: list[dict] = []
    algo = None
    with contextlib.ExitStack() as stack:
        if ray.is_initialized():  # (a caller's Ray: used, left running)
            pass
        elif args.address:
            ray.init(address=args.address, runtime_env={"env_vars": env_vars},
                     include_dashboard=False)
            stack.callback(ray.shutdown)
        else:
            stack.enter_context(local_ray(args.num_cpus, env_vars))
        stack.callback(lambda: algo is not None and algo.stop())
        t0 = time.perf_counter()
        hosts = warm_every_node(threads, args.env_id)
        print(f"numba kernels ready on {len(hosts)} node(s) {sorted(set(hosts))} "
              f"({time.perf_counter() - t0:.1f} s)", flush=True)
        env_config = dict(cfg, threads=threads)
        algo = build_config(args, env_config).build_algo()
        with staged_folder(args.out) as out:
            (out / "args.json").write_text(json.dumps(dataclasses.asdict(args), indent=2))
            start = time.perf_counter()
            with open(out / "progress.csv", "w", newline="") as f:
                w = None
                for it in range(1, args.iterations + 1):
                    r = algo.train()
                    er = r.get(ENV_RUNNER_RESULTS, {})
                    row = {
                        "iteration": it,
                        "env_steps": int(er.get(NUM_ENV_STEPS_SAMPLED_LIFETIME, 0)),
                        "episodes": int(er.get(NUM_EPISODES_LIFETIME, 0)),
                        "episode_return_mean": float(er.get(EPISODE_RETURN_MEAN,
                                                            float("nan"))),
                        "wall_s": round(time.perf_counter() - start, 2),
                    }
                    rows.append(row)
                    if w is None:
                        w = csv.DictWriter(f, fieldnames=list(row))
                        w.writeheader()
                    w.writerow(row)
                    f.flush()
                    print(f"iter {it:4d}  env steps {row['env_steps']:8d}  episodes "
                          f"{row['episodes']:5d}  return {row['episode_return_mean']:.3f}  "
                          f"{row['wall_s']:.0f} s", flush=True)
            if args.checkpoint:
                algo.save(str(out.resolve() / "checkpoint"))
            if args.plot:
                plot(rows, out / "learning_curve.png", args.env_id)
    if args.checkpoint:
        print("checkpoint:", Path(args.out) / "checkpoint")
    return rows


def plot(rows: list[dict], path: Path, env_id: str = "DiscReactor-v0") -> None:
    """The learning curve: mean episode return of each iteration's finished episodes against
    environment steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot([r["env_steps"] for r in rows], [r["episode_return_mean"] for r in rows])
    ax.set_xlabel("environment steps")
    ax.set_ylabel("mean episode return")
    ax.set_title(f"RLlib PPO on {env_id}")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


@contextlib.contextmanager
def local_ray(num_cpus: int | None = None, env_vars: dict | None = None):
    """A local Ray on this machine, listening on 127.0.0.1 only (no dashboard), shut down
    on exit.

    Ray replaces a loopback ``_node_ip_address`` by the machine's reachable address unless
    clusters are off (``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, its switch for machines that
    must not form clusters): set here for Ray's processes (the environment they inherit) and
    for this one (the constant Ray read at import)."""
    import ray
    from ray._private import ray_constants

    var = ray_constants.ENABLE_RAY_CLUSTERS_ENV_VAR
    old_env, old_flag = os.environ.get(var), ray_constants.ENABLE_RAY_CLUSTER
    os.environ[var] = "0"
    ray_constants.ENABLE_RAY_CLUSTER = False
    try:
        ray.init(num_cpus=num_cpus, include_dashboard=False, _node_ip_address="127.0.0.1",
                 runtime_env={"env_vars": env_vars or {}}, configure_logging=False)
        yield ray
    finally:
        ray.shutdown()
        ray_constants.ENABLE_RAY_CLUSTER = old_flag
        if old_env is None:
            os.environ.pop(var, None)
        else:
            os.environ[var] = old_env


def parse(argv=None) -> Args:
    import argcheck

    return argcheck.parse(Args, argv, description=__doc__.split("\n\n")[0])


def main(argv=None) -> list[dict]:
    return train(parse(argv))


if __name__ == "__main__":
    import argcheck

    argcheck.run(lambda: main() and 0)
