"""Train Stable-Baselines3 PPO on DiscReactor-v0 through the batched vector env.

One readable script in the spirit of CleanRL: the arguments are a documented dataclass, the
logic lives in functions a test can call, and ``__main__`` only parses arguments.

    python agents/train_ppo.py                         # the README's main demo (~4 min)
    python agents/train_ppo.py --total-timesteps 1000000 --out runs/ppo_long
    python agents/train_ppo.py --scene path/to/my_scene.toml --product C

It writes into ``--out``: ``model.zip`` (the policy), ``vecnormalize.pkl`` (observation
normalisation statistics), ``learning_curve.png``, ``progress.csv`` (episode returns over
training), ``args.json``, and TensorBoard logs under ``tb/`` when tensorboard is installed.
Evaluate with ``python agents/evaluate.py --run <out>``.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class Args:
    """Training arguments (each is also a command-line flag: ``--total-timesteps`` ...)."""

    total_timesteps: int = 400_000
    """environment steps (summed over all reactors) to train for"""
    num_envs: int = 16
    """reactors stepped together in one compiled call"""
    seed: int = 0
    """seed of the policy initialisation, of PPO's sampling and of the reactors' contents"""
    scene: str = "reactor"
    """built-in scene name or TOML path for the reactor"""
    product: str | None = None
    """product species rewarded (default: the env's choice for the scene)"""
    episode_steps: int | None = None
    """env steps per episode (default: the env's)"""
    out: str = "runs/ppo"
    """output folder"""
    learning_rate: float = 3e-4
    n_steps: int = 256
    """rollout length per reactor between updates"""
    batch_size: int = 512
    n_epochs: int = 10
    gamma: float = 0.995
    gae_lambda: float = 0.95
    ent_coef: float = 0.0
    clip_range: float = 0.2
    net_arch: list = field(default_factory=lambda: [64, 64])
    normalize: bool = True
    """normalise observations (VecNormalize)"""
    normalize_reward: bool = False
    """also scale rewards by a running estimate of the return's spread (VecNormalize)"""
    threads: int | None = None
    """numba threads for the vector env (None: all cores)"""
    torch_threads: int = 1
    """torch intra-op threads (the tiny MLP gains nothing from more)"""
    progress_bar: bool = True
    device: str = "cpu"

    def env_kwargs(self) -> dict:
        kw = {"scene": self.scene}
        if self.product is not None:
            kw["product"] = self.product
        if self.episode_steps is not None:
            kw["episode_steps"] = self.episode_steps
        return kw


def make_vec_env(args: Args, num_envs: int | None = None, seed: int | None = None):
    """The SB3 VecEnv: batched reactors, episode statistics, optional normalisation."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from discgym.sb3 import DiscReactorSB3VecEnv

    venv = DiscReactorSB3VecEnv(num_envs=num_envs or args.num_envs, threads=args.threads,
                                **args.env_kwargs())
    venv.seed(args.seed if seed is None else seed)
    venv = VecMonitor(venv)
    if args.normalize:
        venv = VecNormalize(venv, norm_obs=True, norm_reward=args.normalize_reward,
                            gamma=args.gamma, clip_obs=10.0)
    return venv


class _CurveCallback:
    """Collects (timestep, episode return) pairs from VecMonitor infos."""

    def __init__(self):
        from stable_baselines3.common.callbacks import BaseCallback

        outer = self

        class CB(BaseCallback):
            def _on_step(self) -> bool:
                for info in self.locals.get("infos", []):
                    ep = info.get("episode")
                    if ep is not None:
                        outer.rows.append((self.num_timesteps, float(ep["r"])))
                return True

        self.rows: list[tuple[int, float]] = []
        self.callback = CB()


def train(args: Args) -> Path:
    """Train PPO; returns the output folder (see the module docstring for its files)."""
    import torch
    from stable_baselines3 import PPO

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "args.json").write_text(json.dumps(dataclasses.asdict(args), indent=2))
    torch.set_num_threads(args.torch_threads)
    venv = make_vec_env(args)
    try:
        import tensorboard  # noqa: F401

        tb = str(out / "tb")
    except ImportError:
        tb = None
    model = PPO(
        "MlpPolicy", venv, learning_rate=args.learning_rate, n_steps=args.n_steps,
        batch_size=args.batch_size, n_epochs=args.n_epochs, gamma=args.gamma,
        gae_lambda=args.gae_lambda, ent_coef=args.ent_coef, clip_range=args.clip_range,
        policy_kwargs={"net_arch": list(args.net_arch)}, seed=args.seed, device=args.device,
        tensorboard_log=tb, verbose=0,
    )
    curve = _CurveCallback()
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.total_timesteps, callback=curve.callback,
                progress_bar=args.progress_bar and _has_progress_bar())
    wall = time.perf_counter() - t0
    model.save(out / "model.zip")
    if args.normalize:
        venv.save(str(out / "vecnormalize.pkl"))
    venv.close()
    with open(out / "progress.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["timestep", "episode_return"])
        w.writerows(curve.rows)
    (out / "train_summary.json").write_text(json.dumps(
        {"wall_seconds": wall, "timesteps": args.total_timesteps,
         "episodes": len(curve.rows)}, indent=2))
    plot_learning_curve(curve.rows, out / "learning_curve.png")
    return out


def plot_learning_curve(rows, path: Path, window: int = 32) -> None:
    """Episode return against timestep, with a moving average."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=120)
    if rows:
        t = np.array([r[0] for r in rows])
        r = np.array([r[1] for r in rows])
        ax.plot(t, r, ".", ms=2, alpha=0.35, color="tab:blue", label="episode")
        if len(r) >= window:
            k = np.ones(window) / window
            ax.plot(t[window - 1:], np.convolve(r, k, mode="valid"), color="tab:blue",
                    label=f"mean of {window}")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return (product yield)")
    ax.set_title("PPO on DiscReactor-v0")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _has_progress_bar() -> bool:
    try:
        import rich  # noqa: F401
        import tqdm  # noqa: F401
    except ImportError:
        return False
    return True


def parse_args(argv=None) -> Args:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    for f in dataclasses.fields(Args):
        flag = "--" + f.name.replace("_", "-")
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        if f.type in ("bool", bool):
            p.add_argument(flag, action=argparse.BooleanOptionalAction, default=default)
        elif f.name == "net_arch":
            p.add_argument(flag, type=int, nargs="+", default=default)
        elif f.name in ("product", "threads", "episode_steps"):
            typ = str if f.name == "product" else int
            p.add_argument(flag, type=typ, default=default)
        else:
            p.add_argument(flag, type=type(default), default=default)
    return Args(**vars(p.parse_args(argv)))


if __name__ == "__main__":
    a = parse_args()
    folder = train(a)
    summary = json.loads((folder / "train_summary.json").read_text())
    print(f"trained in {summary['wall_seconds']:.0f} s; wrote {folder}/model.zip, "
          "learning_curve.png; evaluate with "
          f"python agents/evaluate.py --run {folder}")
