"""Train a Stable-Baselines3 agent on a task of discgym's suite, through the batched vector env.

One readable script in the spirit of CleanRL's: the arguments are a documented dataclass
(parsed by tyro, so every field is a flag), the hyperparameters of each task live in RL Zoo
style files (``hyperparams/<algo>.yml``, one entry per env id), and the rest is SB3's own
machinery: ``VecMonitor`` (episode statistics, ``monitor.csv``), the entry's
``vec_env_wrapper`` if it names one (RL Zoo's key, e.g. ``discgym.sb3.SetpointHold``),
``VecNormalize`` (saved and loaded with its statistics), ``EvalCallback`` on validation
seeds (``evaluations.npz``, the best checkpoint) and SB3's logger (``progress.csv``).

    python agents/train_ppo.py                               # the README's main demo
    python agents/train_ppo.py --env-id DiscKinetics-v0 --algo recurrent_ppo
    python agents/train_ppo.py --env-id DiscJacket-v0 --algo sac --total-timesteps 200000

It writes into ``--out`` (default ``runs/<env-id>_<algo>``): ``model.zip`` and
``vecnormalize.pkl`` (the final policy and its observation statistics), ``best_model.zip`` and
``best_vecnormalize.pkl`` (the checkpoint that did best on the validation seeds), ``args.json``,
``hyperparams.json``, ``monitor.csv``, ``progress.csv``, ``evaluations.npz`` and
``train_summary.json``. Evaluate with ``python agents/evaluate.py --run <out>``.

Seeds: training reactors start from ``seed``, ``seed + 1``, ...; the validation episodes of
``EvalCallback`` use :data:`VALIDATION_SEEDS` (``--eval-episodes`` of them from seed 500),
disjoint from the seeds ``evaluate.py`` reports
(1000-1019) and from the constant-action search (0-9 are the *search* seeds of the baselines;
training reactors reuse them, which is harmless: they are not the reported seeds).
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import yaml

ROOT = Path(__file__).resolve().parent.parent
#: Seeds of the validation episodes EvalCallback runs during training (not the reported ones).
VALIDATION_SEEDS = range(500, 510)
#: The most validation episodes: their seeds stay below evaluate.py's first (1000).
MAX_EVAL_EPISODES = 500
#: The algorithm classes by name, and the policy each one uses when the hyperparameters do not
#: name one.
ALGOS = ("ppo", "sac", "recurrent_ppo")


@dataclass
class Args:
    """Training arguments; each is also a flag (``--env-id``, ``--total-timesteps``, ...)."""

    env_id: str = "DiscReactor-v0"
    """the task (``discgym.tasks.TASKS``); hyperparameters from ``hyperparams/<algo>.yml``"""
    algo: Literal["ppo", "sac", "recurrent_ppo"] = "ppo"
    """SB3's PPO, SB3's SAC, or sb3-contrib's RecurrentPPO (an LSTM policy)"""
    total_timesteps: int | None = None
    """agent steps summed over all reactors (default: the file's ``n_timesteps``): env steps,
    or decisions of ``hold`` env steps each with a ``SetpointHold`` ``vec_env_wrapper``"""
    seed: int = 0
    """seed of the policy initialisation, of the algorithm's sampling and of the reactors"""
    out: str | None = None
    """output folder (default ``runs/<env-id>_<algo>``)"""
    hyperparams: str = str(ROOT / "hyperparams")
    """folder of the RL Zoo style files ``<algo>.yml``"""
    n_envs: int | None = None
    """reactors stepped together in one compiled call (default: the file's ``n_envs``)"""
    scene: str | None = None
    """built-in scene name or TOML path, replacing the task's scene"""
    episode_steps: int | None = None
    """env steps per episode, replacing the task's (tests use short episodes)"""
    train_integrator: Literal["step", "event"] | None = None
    """integrator of the training reactors only (default: the task's); validation and
    ``evaluate.py`` keep the task's own, so the policy is chosen and scored on the task as
    registered. ``"event"``, the exact one, costs about 0.6x the stepped one per env step
    (docs/performance.md)"""
    threads: int | None = None
    """numba threads of the vector env (None: all cores)"""
    torch_threads: int = 1
    """torch intra-op threads (the small networks here gain nothing from more)"""
    eval_freq: int = 50_000
    """validate every this many env steps, summed over the reactors (0: no EvalCallback, no
    best checkpoint)"""
    eval_episodes: int = len(VALIDATION_SEEDS)
    """validation episodes per evaluation, on seeds 500, 501, ... (at most 500): returns that
    spread by more than the checkpoints differ need more of them to pick the best checkpoint"""
    progress_bar: bool = True
    device: str = "cpu"

    def env_kwargs(self) -> dict:
        """Keyword arguments for the env beyond the task's own defaults."""
        return {k: v for k, v in (("scene", self.scene), ("episode_steps", self.episode_steps))
                if v is not None}

    def folder(self) -> Path:
        return Path(self.out or f"runs/{self.env_id}_{self.algo}")


def load_hyperparams(args: Args) -> dict:
    """The task's entry of ``<hyperparams>/<algo>.yml`` (RL Zoo's format: ``n_envs``,
    ``n_timesteps``, ``policy``, ``normalize``, ``policy_kwargs`` as a Python expression, the
    rest the algorithm's keyword arguments), with ``--n-envs`` and ``--total-timesteps``
    applied."""
    import torch

    path = Path(args.hyperparams) / f"{args.algo}.yml"
    table = yaml.safe_load(path.read_text())
    if args.env_id not in table:
        raise ValueError(f"env_id: {args.env_id!r} has no entry in {path} (entries: "
                         f"{', '.join(sorted(table))})")
    hp = dict(table[args.env_id])
    # RL Zoo writes these two as Python expressions; evaluate them with only what they need
    names = {"dict": dict, "nn": torch.nn}
    for key in ("policy_kwargs", "normalize"):
        if isinstance(hp.get(key), str):
            hp[key] = eval(hp[key], {"__builtins__": {}}, names)  # noqa: S307 (our own file)
    if args.n_envs is not None:
        hp["n_envs"] = args.n_envs
    if args.total_timesteps is not None:
        hp["n_timesteps"] = args.total_timesteps
    hp["n_timesteps"] = int(hp["n_timesteps"])
    return hp


def import_name(path: str):
    """The object a dotted name (``"module.Class"``) names."""
    import importlib

    module, _, name = str(path).rpartition(".")
    return getattr(importlib.import_module(module), name)


def vec_env_wrappers(spec) -> list:
    """RL Zoo's ``vec_env_wrapper`` entry (``"module.Class"``, or a list of those and of
    ``{"module.Class": {kwargs}}``) as a list of ``(class, kwargs)``."""
    out = []
    for item in ([] if spec is None else [spec] if isinstance(spec, (str, dict)) else spec):
        for path, kwargs in (item.items() if isinstance(item, dict) else [(item, None)]):
            out.append((import_name(path), dict(kwargs or {})))
    return out


def make_vec_env(args: Args, n_envs: int, normalize: dict | bool, gamma: float,
                 monitor: Path | None = None, wrappers=None, training: bool = False):
    """The SB3 VecEnv: ``n_envs`` reactors of the task (on ``args.train_integrator`` if
    ``training``), VecMonitor, the hyperparameters' ``vec_env_wrapper``
    (:func:`vec_env_wrappers`), then VecNormalize."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from discgym.sb3 import DiscReactorSB3VecEnv
    from discgym.tasks import TASKS

    if args.env_id not in TASKS:
        raise ValueError(f"env_id: {args.env_id!r} is not a task of discgym.tasks.TASKS "
                         f"({', '.join(sorted(TASKS))})")
    kw = {**TASKS[args.env_id][0].defaults, **args.env_kwargs()}
    if training and args.train_integrator is not None:
        kw["integrator"] = args.train_integrator
    venv = VecMonitor(DiscReactorSB3VecEnv(num_envs=n_envs, threads=args.threads, **kw),
                      filename=None if monitor is None else str(monitor))
    for cls, kwargs in vec_env_wrappers(wrappers):
        venv = cls(venv, **kwargs)
    if normalize:
        opts = {"norm_obs": True, "norm_reward": False}
        opts.update(normalize if isinstance(normalize, dict) else {})
        venv = VecNormalize(venv, gamma=gamma, clip_obs=10.0, **opts)
    return venv


def env_steps_per_step(venv) -> int:
    """Env steps per agent step of ``venv`` (a ``SetpointHold`` in it holds each decision)."""
    hold = 1
    while venv is not None:
        hold *= vars(venv).get("hold", 1)  # (not getattr: VecEnvWrappers forward it)
        venv = vars(venv).get("venv")
    return hold


def check_args(args: Args) -> None:
    """Refuse what no run could use, before anything is built (``eval_episodes`` is checked
    even when ``eval_freq`` turns validation off: a typo should not wait for the next run)."""
    n = args.eval_episodes
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_EVAL_EPISODES:
        raise ValueError(f"eval_episodes: expected an int in [1, {MAX_EVAL_EPISODES}], got "
                         f"{n!r}")


def _callbacks(args: Args, out: Path, n_envs: int, normalize, gamma: float, wrappers=None,
               hold: int = 1):
    """EvalCallback on the validation seeds (re-seeded before every evaluation, so that every
    checkpoint meets the same episodes), saving VecNormalize's statistics with the best model."""
    from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

    if args.eval_freq <= 0:
        return None

    class SaveVecNormalize(BaseCallback):
        def _on_step(self) -> bool:
            vn = self.model.get_vec_normalize_env()
            if vn is not None:
                vn.save(str(out / "best_vecnormalize.pkl"))
            return True

    class SeededEval(EvalCallback):
        def _on_step(self) -> bool:
            if self.eval_freq > 0 and self.n_calls % self.eval_freq == 0:
                self.eval_env.seed(VALIDATION_SEEDS[0])
            return super()._on_step()

    n = args.eval_episodes
    # one reactor per episode: every checkpoint meets the same n episodes, seeds 500 .. 500 + n - 1
    eval_env = make_vec_env(args, n, normalize, gamma, wrappers=wrappers)
    if hasattr(eval_env, "training"):
        eval_env.training, eval_env.norm_reward = False, False
    return SeededEval(eval_env, n_eval_episodes=n,
                      eval_freq=max(1, args.eval_freq // (n_envs * hold)),
                      best_model_save_path=str(out), log_path=str(out),
                      deterministic=True, callback_on_new_best=SaveVecNormalize(), verbose=0)


def policy_of(name: str | None, algo: str):
    """The hyperparameters' ``policy``: an SB3 alias (``"MlpPolicy"``), a class by its dotted
    name (``"discgym.sb3_recurrent.SequenceLstmPolicy"``), or the algorithm's MLP policy if
    None."""
    name = name or ("MlpLstmPolicy" if algo == "recurrent_ppo" else "MlpPolicy")
    return import_name(name) if "." in name else name


def algo_class(name: str):
    if name == "recurrent_ppo":
        from sb3_contrib import RecurrentPPO

        return RecurrentPPO
    import stable_baselines3

    return getattr(stable_baselines3, name.upper())


def train(args: Args) -> Path:
    """Train; returns the output folder (see the module docstring for its files)."""
    import torch
    from stable_baselines3.common.logger import configure

    check_args(args)
    out = args.folder()
    out.mkdir(parents=True, exist_ok=True)
    hp = load_hyperparams(args)
    (out / "args.json").write_text(json.dumps(dataclasses.asdict(args), indent=2))
    (out / "hyperparams.json").write_text(json.dumps(hp, indent=2, default=repr))
    torch.set_num_threads(args.torch_threads)
    n_envs, steps = int(hp.pop("n_envs")), hp.pop("n_timesteps")
    normalize, policy = hp.pop("normalize", False), hp.pop("policy", None)
    wrappers = hp.pop("vec_env_wrapper", None)
    gamma = hp.get("gamma", 0.99)
    venv = make_vec_env(args, n_envs, normalize, gamma, monitor=out / "monitor.csv",
                        wrappers=wrappers, training=True)
    venv.seed(args.seed)
    hold = env_steps_per_step(venv)
    callback = _callbacks(args, out, n_envs, normalize, gamma, wrappers, hold)
    cls = algo_class(args.algo)
    model = cls(policy_of(policy, args.algo), venv, seed=args.seed, device=args.device,
                verbose=0, **hp)
    model.set_logger(configure(str(out), ["csv"]))
    t0, c0 = time.perf_counter(), time.process_time()
    model.learn(total_timesteps=steps, callback=callback,
                progress_bar=args.progress_bar and _has_progress_bar())
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    model.save(out / "model.zip")
    if normalize:
        venv.save(str(out / "vecnormalize.pkl"))
    venv.close()
    (out / "train_summary.json").write_text(json.dumps(
        {"env_id": args.env_id, "algo": args.algo, "wall_seconds": wall, "cpu_seconds": cpu,
         "timesteps": int(model.num_timesteps), "env_steps": int(model.num_timesteps) * hold,
         "n_envs": n_envs,
         "best_checkpoint": (out / "best_model.zip").exists()}, indent=2))
    return out


def _has_progress_bar() -> bool:
    try:
        import rich  # noqa: F401
        import tqdm  # noqa: F401
    except ImportError:
        return False
    return True


def parse_args(argv=None) -> Args:
    import tyro

    return tyro.cli(Args, args=argv, description=__doc__.split("\n\n")[0])


if __name__ == "__main__":
    a = parse_args()
    folder = train(a)
    summary = json.loads((folder / "train_summary.json").read_text())
    print(f"trained {summary['timesteps']} steps in {summary['wall_seconds']:.0f} s; wrote "
          f"{folder}; evaluate with python agents/evaluate.py --run {folder}")
