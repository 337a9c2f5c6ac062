"""Train a Stable-Baselines3 agent on a task of discgym's suite, through the batched vector env.

One readable script in the spirit of CleanRL's: the arguments are a documented dataclass
(parsed by tyro, so every field is a flag), the hyperparameters of each task live in RL Zoo
style files (``hyperparams/<algo>.yml``, one entry per env id), and the rest is SB3's own
machinery: ``VecMonitor`` (episode statistics, ``monitor.csv``), the entry's
``vec_env_wrapper`` if it names one (RL Zoo's key, e.g. ``discgym.sb3.SetpointHold``),
``VecNormalize`` (saved and loaded with its statistics), ``EvalCallback`` on validation
seeds (``evaluations.npz``, the best checkpoint) and SB3's logger (``progress.csv``).

    # the README's main command: PPO correcting DiscFlow-v0's controller, then its table
    python agents/train_ppo.py --env-id DiscFlow-v0 --hyperparams hyperparams/residual \\
        --train-integrator event --eval-episodes 30
    python agents/evaluate.py --run runs/DiscFlow-v0_ppo --seeds 300
    python agents/train_ppo.py                               # PPO on DiscReactor-v0
    python agents/train_ppo.py --env-id DiscKinetics-v0 --algo recurrent_ppo
    python agents/train_ppo.py --env-id DiscJacket-v0 --algo sac --total-timesteps 200000

It writes into ``--out`` (default ``runs/<env-id>_<algo>``): ``model.zip`` and
``vecnormalize.pkl`` (the final policy and its observation statistics), ``best_model.zip`` and
``best_vecnormalize.pkl`` (the checkpoint that did best on the validation seeds), ``args.json``,
``hyperparams.json``, ``monitor.csv``, ``progress.csv``, ``evaluations.npz`` and
``train_summary.json``. Evaluate with ``python agents/evaluate.py --run <out>``.

Every argument and the hyperparameters' entry are checked before anything is written (a bad
one is refused in one line, exit status 2). The run is written into a hidden sibling of
``--out`` (``.<name>.partial-*``) and renamed into place once ``train_summary.json``, the last
file, is written: an interrupted or crashed training leaves no run folder (a previous run
folder at ``--out`` is replaced only then).

Seeds: training reactors start from ``seed``, ``seed + 1``, ...; the validation episodes of
``EvalCallback`` use :data:`VALIDATION_SEEDS` (``--eval-episodes`` of them from seed 500),
disjoint from the seeds ``evaluate.py`` reports
(1000-1019) and from the constant-action search (0-9 are the *search* seeds of the baselines;
training reactors reuse them, which is harmless: they are not the reported seeds).
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from argcheck import (  # noqa: E402
    MAX_SEED,
    SUMMARY,
    Range,
    check_env_kwargs,
    check_fields,
    check_out_folder,
    check_task,
    flag,
    staged_folder,
    usage,
)

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
    total_timesteps: Annotated[int | None, Range(1)] = None
    """agent steps summed over all reactors (default: the file's ``n_timesteps``): env steps,
    or decisions of ``hold`` env steps each with a ``SetpointHold`` ``vec_env_wrapper``"""
    seed: Annotated[int, Range(0, MAX_SEED)] = 0
    """seed of the policy initialisation, of the algorithm's sampling and of the reactors"""
    out: str | None = None
    """output folder (default ``runs/<env-id>_<algo>``)"""
    hyperparams: str = str(ROOT / "hyperparams")
    """folder of the RL Zoo style files ``<algo>.yml``"""
    n_envs: Annotated[int | None, Range(1)] = None
    """reactors stepped together in one compiled call (default: the file's ``n_envs``)"""
    scene: str | None = None
    """built-in scene name or TOML path, replacing the task's scene"""
    episode_steps: Annotated[int | None, Range(1)] = None
    """env steps per episode, replacing the task's (tests use short episodes)"""
    train_integrator: Literal["step", "event"] | None = None
    """integrator of the training reactors only (default: the task's); validation and
    ``evaluate.py`` keep the task's own, so the policy is chosen and scored on the task as
    registered. ``"event"``, the exact one, costs about 0.6x the stepped one per env step
    (docs/performance.md)"""
    threads: Annotated[int | None, Range(1)] = None
    """numba threads of the vector env (None: all cores; at most numba's own count)"""
    torch_threads: Annotated[int, Range(1)] = 1
    """torch intra-op threads (the small networks here gain nothing from more)"""
    eval_freq: Annotated[int, Range(0)] = 50_000
    """validate every this many env steps, summed over the reactors (0: no EvalCallback, no
    best checkpoint)"""
    eval_episodes: Annotated[int, Range(1, MAX_EVAL_EPISODES)] = len(VALIDATION_SEEDS)
    """validation episodes per evaluation, on seeds 500, 501, ... (at most 500): returns that
    spread by more than the checkpoints differ need more of them to pick the best checkpoint"""
    progress_bar: bool = True
    device: str = "cpu"
    """torch device: cpu, cuda, cuda:N, mps or auto"""

    def env_kwargs(self) -> dict:
        """Keyword arguments for the env beyond the task's own defaults."""
        return {k: v for k, v in (("scene", self.scene), ("episode_steps", self.episode_steps))
                if v is not None}

    def folder(self) -> Path:
        return Path(self.out or f"runs/{self.env_id}_{self.algo}")


#: The keys of an entry that are not the algorithm's keyword arguments (RL Zoo's).
ZOO_KEYS = ("n_envs", "n_timesteps", "policy", "normalize", "vec_env_wrapper")


def load_hyperparams(args: Args) -> dict:
    """The task's entry of ``<hyperparams>/<algo>.yml`` (RL Zoo's format: ``n_envs``,
    ``n_timesteps``, ``policy``, ``normalize``, ``policy_kwargs`` as a Python expression, the
    rest the algorithm's keyword arguments), with ``--n-envs`` and ``--total-timesteps``
    applied. A missing folder or file, a file that does not parse, a missing entry or a
    count that is not a whole number >= 1 is refused, naming the flag."""
    folder = Path(args.hyperparams)
    if not folder.is_dir():
        raise usage("hyperparams", f"{folder} is not a folder" if folder.exists() else
                    f"no folder {folder}")
    path = folder / f"{args.algo}.yml"
    if not path.is_file():
        raise usage("hyperparams", f"{folder} has no {args.algo}.yml (the file of --algo "
                                   f"{args.algo})")
    try:
        table = yaml.safe_load(path.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as e:
        raise usage("hyperparams", f"{path} is not valid YAML: {e}") from None
    if not isinstance(table, dict):
        raise usage("hyperparams", f"{path}: expected a mapping of env ids to entries")
    if args.env_id not in table:
        raise usage("env_id", f"{args.env_id!r} has no entry in {path} (entries: "
                              f"{', '.join(sorted(map(str, table)))})")
    if not isinstance(table[args.env_id], dict):
        raise usage("hyperparams", f"{path}: the entry of {args.env_id} is not a mapping")
    hp = dict(table[args.env_id])
    # RL Zoo writes these two as Python expressions; evaluate them with only what they need
    for key in ("policy_kwargs", "normalize"):
        if isinstance(hp.get(key), str):
            import torch

            names = {"dict": dict, "nn": torch.nn}
            try:
                hp[key] = eval(hp[key], {"__builtins__": {}}, names)  # noqa: S307 (our file)
            except Exception as e:  # (the file's text, not our code: any error is the file's)
                raise usage("hyperparams", f"{path}: {args.env_id}'s {key} {hp[key]!r} does "
                                           f"not evaluate ({type(e).__name__}: {e})") from None
    for key, given in (("n_envs", args.n_envs), ("n_timesteps", args.total_timesteps)):
        if given is not None:
            hp[key] = given
        v = hp.get(key)
        if v is None:
            raise usage("hyperparams", f"{path}: {args.env_id}'s entry has no {key} (or pass "
                        f"{flag('total_timesteps' if key == 'n_timesteps' else key)})")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v) or v < 1:
            raise usage("hyperparams", f"{path}: {args.env_id}'s {key}: expected a whole "
                                       f"number >= 1, got {v!r}")
        hp[key] = int(v)
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
    import gymnasium as gym
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from discgym.sb3 import DiscReactorSB3VecEnv
    from discgym.tasks import TASKS

    if args.env_id not in TASKS:
        raise ValueError(f"env_id: {args.env_id!r} is not a task of discgym.tasks.TASKS "
                         f"({', '.join(sorted(TASKS))})")
    kw = {**TASKS[args.env_id][0].defaults, **args.env_kwargs()}
    if training and args.train_integrator is not None:
        kw["integrator"] = args.train_integrator
    inner = DiscReactorSB3VecEnv(num_envs=n_envs, threads=args.threads, **kw)
    # (the task's spec, with the arguments it was built with: a controller found by task id,
    # as discgym.searched.searched, finds it from any reactor of the batch)
    inner.venv.spec = dataclasses.replace(gym.spec(args.env_id), kwargs=kw)
    venv = VecMonitor(inner, filename=None if monitor is None else str(monitor))
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


def check_args(args: Args) -> dict:
    """The validation pass, before anything is written: every flag against its type and
    range, the task (through Gymnasium's registry), the env's arguments (as the env would
    check them), ``--out``, the hyperparameters' entry (its algorithm's keyword arguments,
    its policy and wrappers importable), ``--device``, and the flags taken together. Returns
    the entry (:func:`load_hyperparams`). (``eval_episodes`` is checked even when
    ``eval_freq`` turns validation off: a typo should not wait for the next run.)"""
    import inspect

    check_fields(args)
    env_cls = check_task(args.env_id)
    kw = args.env_kwargs()
    for key, value in kw.items():
        check_env_kwargs(env_cls, {key: value}, key)
    if args.train_integrator is not None:
        kw = {**kw, "integrator": args.train_integrator}
    if len(kw) > 1:  # (each may fit alone and not together: a longer episode, another scene)
        check_env_kwargs(env_cls, kw, "/".join(flag(k) for k in kw if k != "integrator")
                         or "train_integrator")
    check_out_folder(args.folder(), "out")
    hp = load_hyperparams(args)
    if args.seed + hp["n_envs"] - 1 > MAX_SEED:
        raise usage("seed", f"the reactors' seeds {args.seed}..{args.seed + hp['n_envs'] - 1} "
                            f"pass {MAX_SEED} (--n-envs {hp['n_envs']})")
    try:
        cls = algo_class(args.algo)
    except ImportError as e:
        raise usage("algo", f"{args.algo} needs {e.name}: pip install -e '.[agents]'") from None
    params = inspect.signature(cls.__init__).parameters
    unknown = sorted(set(hp) - set(ZOO_KEYS) - set(params) - {"self", "env"})
    if unknown:
        raise usage("hyperparams", f"{Path(args.hyperparams) / (args.algo + '.yml')}: "
                    f"{args.env_id}'s entry has keys {cls.__name__} does not take: "
                    f"{', '.join(unknown)}")
    try:
        policy_of(hp.get("policy"), args.algo)
        vec_env_wrappers(hp.get("vec_env_wrapper"))
    except (ImportError, AttributeError, ValueError) as e:
        raise usage("hyperparams", f"{args.env_id}'s policy or vec_env_wrapper: {e}") from None
    check_device(args.device)
    return hp


def check_device(device: str) -> None:
    import torch

    if device == "auto":  # (SB3's: CUDA if there is one)
        return
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError, ValueError):
        raise usage("device", f"{device!r}: expected cpu, cuda, cuda:N, mps or auto") from None
    if dev.type == "cuda" and (not torch.cuda.is_available()
                               or (dev.index or 0) >= torch.cuda.device_count()):
        raise usage("device", f"{device!r}: no such CUDA device on this machine")
    if dev.type == "mps" and not torch.backends.mps.is_available():
        raise usage("device", f"{device!r}: MPS is not available on this machine")
    if dev.type not in ("cpu", "cuda", "mps"):
        raise usage("device", f"{device!r}: expected cpu, cuda, cuda:N, mps or auto")


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


def set_torch_threads(n: int) -> None:
    """torch's intra-op threads, set so that the vector env cannot undo it. numba's OpenMP
    threading layer shares torch's libgomp and, when it starts its pool (the first
    ``numba.get_num_threads()`` or parallel call: a vector env's first reset), sets OpenMP's
    thread count back to every core; torch's updates then run on every core, and between
    its parallel regions a worker spins beside a run that was meant to take one. Starting
    numba's pool first keeps ``n``."""
    import numba
    import torch

    numba.get_num_threads()  # (starts numba's thread pool)
    torch.set_num_threads(n)


def train(args: Args) -> Path:
    """Train; returns the output folder (see the module docstring for its files). Refuses a
    bad argument (:class:`argcheck.UsageError`, a ``ValueError``) before writing anything;
    the folder appears, complete, when training ends (:func:`argcheck.staged_folder`)."""
    hp = check_args(args)
    from stable_baselines3.common.logger import configure

    final = args.folder()
    with staged_folder(final) as out:
        (out / "args.json").write_text(json.dumps(dataclasses.asdict(args), indent=2))
        (out / "hyperparams.json").write_text(json.dumps(hp, indent=2, default=repr))
        set_torch_threads(args.torch_threads)
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
        # the last file: evaluate.py takes a folder without it for an unfinished run
        (out / SUMMARY).write_text(json.dumps(
            {"env_id": args.env_id, "algo": args.algo, "wall_seconds": wall,
             "cpu_seconds": cpu, "timesteps": int(model.num_timesteps),
             "env_steps": int(model.num_timesteps) * hold, "n_envs": n_envs,
             "best_checkpoint": (out / "best_model.zip").exists()}, indent=2))
    return final


def _has_progress_bar() -> bool:
    try:
        import rich  # noqa: F401
        import tqdm  # noqa: F401
    except ImportError:
        return False
    return True


def parse_args(argv=None) -> Args:
    import argcheck

    return argcheck.parse(Args, argv, description=__doc__.split("\n\n")[0])


def main(argv=None) -> int:
    folder = train(parse_args(argv))
    summary = json.loads((folder / SUMMARY).read_text())
    print(f"trained {summary['timesteps']} steps in {summary['wall_seconds']:.0f} s; wrote "
          f"{folder}; evaluate with python agents/evaluate.py --run {folder}")
    return 0


if __name__ == "__main__":
    import argcheck

    argcheck.run(main)
