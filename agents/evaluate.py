"""Evaluate trained agents on their task against the task's baselines: the task's whole table.

    python agents/evaluate.py --run runs/DiscReactor-v0_ppo            # after train_ppo.py
    python agents/evaluate.py --run runs/DiscReactor-v0_ppo runs/DiscReactor-v0_sac --planner

Every policy plays one episode on each evaluation seed (1000-1019 by default; training used
other seeds, see train_ppo.py), on a fresh ``gymnasium.make(env_id)``:
- random: ``env.action_space.sample()``;
- best constant: the best of the task's grid of constant actions, searched on seeds 0-9;
- hand-written: the task's simple rule (``discgym.baselines.TASK_BASELINES``);
- searched: the task's searched controller (``discgym.searched``: CMA-ES along every control
  on tuning seeds 3000 and up);
- each trained agent, with deterministic actions (its best validation checkpoint by default);
- with two or more runs of one algorithm (training seeds, say), a row of their mean return on
  each seed;
- with ``--planner``: rollout MPC on the searched controller that does not foresee the random
  draws (``TaskBaselines.planner``);
- oracle: the same rollout MPC on exact clones of the true env, every random draw foreseen
  (``discgym.oracle.RolloutOracle``), the ceiling.
The table gives the mean and the interquartile mean with 95% BCa bootstrap intervals
(``scipy.stats.bootstrap`` through ``discgym.baselines``), each policy's paired differences
to the hand-written and the searched controller over the same seeds (separated: the interval
excludes 0) and its normalised score (its mean return mapped so that random is 0 and the
searched controller 1).

Writes into the first run's folder: ``evaluation.json`` (every return, the table, date,
machine, versions), ``evaluation.md`` (the table), ``learning_curve.png`` (each agent's
validation return over training, with the baselines as horizontal lines) and ``episode.gif``
(the first agent's episode on the first seed). The episodes run in ``--workers`` processes;
the returns do not depend on how many.

Every argument is checked before anything runs or is written, each run folder included: it
must be a finished run of train_ppo.py (``train_summary.json``, written last, present) on a
task with baselines, whose checkpoint loads. A bad one is refused in one line, exit status 2.
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import sys
import time
import zlib
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Annotated, Literal

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from argcheck import (  # noqa: E402
    MAX_SEED,
    PARTIAL,
    SUMMARY,
    Range,
    check_fields,
    one_line,
    usage,
    write_text_atomic,
)
from train_ppo import ALGOS, algo_class, set_torch_threads, vec_env_wrappers  # noqa: E402

LADDER = ("random", "best constant", "hand-written", "searched", "planner", "oracle")


@dataclass
class Args:
    """Evaluation arguments; each is also a flag."""

    run: list[Path] = field(default_factory=list)
    """folders written by train_ppo.py, all on the same task"""
    seeds: Annotated[int, Range(2)] = 20
    """evaluation seeds, from --first-seed (at least 2: a confidence interval)"""
    first_seed: Annotated[int, Range(0, MAX_SEED)] = 1000
    """the first evaluation seed; the seeds must not meet the search seeds"""
    search_seeds: Annotated[int, Range(1)] = 10
    """the best constant action is searched on seeds 0 .. search_seeds - 1"""
    checkpoint: Literal["best", "final"] = "best"
    """the checkpoint that did best on the validation seeds during training, or the last"""
    deterministic: bool = True
    """the agents' mean actions (--no-deterministic: sampled, as in training)"""
    oracle: bool = True
    """run the oracle (about 5-15 s per episode)"""
    planner: bool = False
    """also run the planner that does not foresee the random draws (four times the
    oracle's cost)"""
    oracle_seeds: Annotated[int, Range(2)] = 20
    """the oracles run on the first this many evaluation seeds only (each episode costs them
    seconds), and are compared with the hand-written controller on those"""
    workers: Annotated[int, Range(1)] = os.cpu_count() or 1
    """processes the episodes are spread over"""
    gif: bool = True
    """animate the first agent's episode on the first seed"""
    out: Path | None = None
    """folder for the results (default: the first run's)"""


# ------------------------------------------------------------------------------ the agents


def run_info(run: Path) -> dict:
    """The training arguments and summary (None if absent) of a run folder."""
    run = Path(run)
    if not run.is_dir():
        raise usage("run", f"no folder {run}" if not run.exists() else f"{run} is not a folder")
    if not (run / "args.json").exists():
        raise usage("run", f"{run} has no args.json (not a folder written by train_ppo.py)")
    info = _read_json(run / "args.json")
    if not isinstance(info, dict) or not {"env_id", "algo"} <= set(info):
        raise usage("run", f"{run / 'args.json'} has no env_id and algo (not written by "
                           f"train_ppo.py)")
    summary = run / SUMMARY
    info["summary"] = _read_json(summary) if summary.exists() else None
    return info


#: The training arguments that change what a run learns (its seed aside): runs that differ
#: in one of them are different variants, never pooled as seeds of one.
SETTINGS = ("total_timesteps", "n_envs", "scene", "episode_steps", "train_integrator",
            "eval_freq", "eval_episodes")


def variant(info: dict) -> str:
    """What a run is, for grouping runs of different seeds: its algorithm, the folder of its
    hyperparameters unless it is named ``hyperparams`` (the repository's own, in whichever
    checkout trained it), and each of :data:`SETTINGS` not at train_ppo.py's default (e.g.
    ``"ppo, residual_searched, train_integrator=event"``)."""
    import dataclasses

    from train_ppo import Args

    parts = [info["algo"]]
    folder = Path(str(info.get("hyperparams") or "hyperparams")).name
    if folder != "hyperparams":
        parts.append(folder)
    defaults = {f.name: f.default for f in dataclasses.fields(Args)}
    parts += [f"{k}={info[k]}" for k in SETTINGS if k in info and info[k] != defaults[k]]
    return ", ".join(parts)


def _read_json(path: Path):
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise usage("run", f"{path} is not valid JSON ({e})") from None


def check_run(run: Path, checkpoint: str = "best") -> dict:
    """:func:`run_info` of a run that can be evaluated: finished (``train_summary.json``, the
    last file train_ppo.py writes, is there; a staging folder ``.<name>.partial-*`` never),
    of a known algorithm, on a task with baselines, with the checkpoint's model file."""
    from discgym.baselines import TASK_BASELINES

    run = Path(run)
    info = run_info(run)
    if PARTIAL in run.name or info["summary"] is None:
        raise usage("run", f"{run} is an unfinished run (no {SUMMARY}: its training was "
                           f"interrupted or failed); train it again")
    if not isinstance(info["summary"], dict) or not {"timesteps", "wall_seconds"} <= set(
            info["summary"]):
        raise usage("run", f"{run / SUMMARY} has no timesteps and wall_seconds (not written "
                           f"by train_ppo.py)")
    if info["algo"] not in ALGOS:
        raise usage("run", f"{run} was trained with {info['algo']!r}, not one of "
                           f"{', '.join(ALGOS)}")
    if info["env_id"] not in TASK_BASELINES:
        raise usage("run", f"{run} is on {info['env_id']!r}, which has no baselines (known: "
                           f"{', '.join(TASK_BASELINES)})")
    name = checkpoint_file(run, checkpoint)
    if not (run / name).is_file():
        raise usage("run", f"{run} has no {name}")
    return info


def checkpoint_file(run: Path, checkpoint: str = "best") -> str:
    """The model file of ``checkpoint``: the best validation checkpoint if the run kept one
    (``eval_freq`` > 0), else the final model."""
    return "best_model.zip" if checkpoint == "best" and (Path(run) / "best_model.zip").exists() \
        else "model.zip"


def env_kwargs_of(run: Path) -> dict:
    info = run_info(run)
    return {k: info[k] for k in ("scene", "episode_steps") if info.get(k) is not None}


def agent_factory(run: Path, checkpoint: str = "best", deterministic: bool = True):
    """``env -> policy`` of a trained agent: deterministic actions (or sampled ones, with
    torch's generator seeded from the episode's first observation, so that a seed gives the
    same episode however the seeds are spread over workers), its VecNormalize statistics
    (``VecNormalize.load``) applied to the observations, an LSTM's state reset at each
    episode (a factory is called once per episode), and the action interface the run trained
    through (its ``vec_env_wrapper``, e.g. :class:`discgym.sb3.SetpointHold`, applied to the
    one env by the wrapper's ``episode_policy``)."""
    import torch

    model, vn, wrappers = load_run(run, checkpoint)

    def factory(env):
        state, start = None, np.ones(1, dtype=bool)

        def policy(obs):
            nonlocal state, start
            o = np.asarray(obs, dtype=np.float32)[None]
            if not deterministic and start[0]:
                torch.manual_seed(zlib.crc32(o.tobytes()))
            if vn is not None:
                o = vn.normalize_obs(o)
            act, state = model.predict(o, state=state, episode_start=start,
                                       deterministic=deterministic)
            start = np.zeros(1, dtype=bool)
            return act[0]

        # the training env's action interfaces: the outermost one asks the model
        for cls, kwargs in reversed(wrappers):
            policy = cls.episode_policy(env, policy, **kwargs)
        return policy

    factory.checkpoint = checkpoint_file(run, checkpoint)
    return factory


def load_run(run: Path, checkpoint: str = "best"):
    """``(model, vecnormalize, wrappers)`` of a run: the model of ``checkpoint`` on the CPU,
    its ``VecNormalize`` statistics (``VecNormalize.load``; None if it kept none) set to
    evaluate, and its ``vec_env_wrapper`` as ``(class, kwargs)`` pairs; a file that does not
    load is the run's fault (one line naming it)."""
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    import discgym  # noqa: F401  (registers the tasks)

    set_torch_threads(1)
    run = Path(run)
    info = run_info(run)
    hp_path = run / "hyperparams.json"
    with _loading(hp_path):
        hp = json.loads(hp_path.read_text()) if hp_path.exists() else {}
        wrappers = vec_env_wrappers(hp.get("vec_env_wrapper"))
    for cls, _ in wrappers:
        if not hasattr(cls, "episode_policy"):
            raise usage("run", f"{run} was trained through {cls.__name__}, which has no "
                               f"episode_policy to apply it to one env")

    prefix = checkpoint_file(run, checkpoint).removesuffix("model.zip")
    with _loading(run / f"{prefix}model.zip"):
        model = algo_class(info["algo"]).load(run / f"{prefix}model.zip", device="cpu")
    vn = None
    if (run / f"{prefix}vecnormalize.pkl").exists():
        dummy = DummyVecEnv([lambda: gym.make(info["env_id"], **env_kwargs_of(run))])
        for cls, kwargs in wrappers:  # what the agent observed (and VecNormalize normalised)
            dummy = cls(dummy, **kwargs)
        with _loading(run / f"{prefix}vecnormalize.pkl"):
            vn = VecNormalize.load(str(run / f"{prefix}vecnormalize.pkl"), dummy)
        vn.training, vn.norm_reward = False, False
    return model, vn, wrappers


@contextlib.contextmanager
def _loading(path: Path):
    """A file of the run that does not load (truncated, corrupted, not SB3's) is the run's
    fault, not a bug here: one line naming it."""
    try:
        yield
    except Exception as e:  # (zipfile, pickle, torch and SB3 each raise their own)
        raise usage("run", f"{path} cannot be loaded ({type(e).__name__}: "
                           f"{one_line(e)[:200]})") from None


# --------------------------------------------------------------- episodes in worker processes


def _factory(env_id: str, kind: str, payload):
    from discgym.baselines import TASK_BASELINES, constant_factory, random_factory

    tb = TASK_BASELINES[env_id]
    if kind == "random":
        return random_factory
    if kind == "best constant":
        return constant_factory(payload)
    if kind == "hand-written":
        return tb.controller
    if kind == "searched":
        return tb.searched
    if kind == "planner":
        return tb.planner()
    if kind == "oracle":
        return tb.oracle()
    if kind == "agent":
        return agent_factory(*payload)
    raise ValueError(f"kind: unknown policy {kind!r}")


def _episodes(env_id: str, kind: str, payload, seeds: list, env_kwargs: dict):
    """One worker's share: the returns and wall times of ``kind`` on ``seeds``."""
    from discgym.baselines import run_episodes

    r = run_episodes(env_id, _factory(env_id, kind, payload), seeds, env_kwargs)
    return list(r.returns), list(r.seconds)


def _search(env_id: str, grid, seeds: list, env_kwargs: dict, avoid: list):
    from discgym.baselines import search_constant

    _, means = search_constant(env_id, grid, seeds=seeds, env_kwargs=env_kwargs, avoid=avoid)
    return list(means)


class _InProcess:
    """The executor of ``workers=1``: runs each job at once, in this process."""

    class _Done:
        def __init__(self, value):
            self.value = value

        def result(self):
            return self.value

    def submit(self, fn, *args):
        return self._Done(fn(*args))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _chunks(seeds: list, n: int) -> list:
    n = max(1, min(n, len(seeds)))
    return [list(c) for c in np.array_split(np.array(seeds), n) if len(c)]


def evaluate_task(env_id: str, runs: list, seeds: list, search_seeds: list,
                  env_kwargs: dict | None = None, checkpoint: str = "best",
                  oracle: bool = True, workers: int = 1, planner: bool = False,
                  deterministic: bool = True, oracle_seeds: int | None = None,
                  log=print) -> dict:
    """Every policy's per-seed returns on ``seeds`` (the oracles' on the first
    ``oracle_seeds`` of them, all if None) and the table's statistics."""
    from discgym.baselines import (
        PLANNER_FUTURES,
        TASK_BASELINES,
        check_disjoint,
        iqm_ci,
        mean_ci,
        paired_difference,
    )

    if env_id not in TASK_BASELINES:
        raise ValueError(f"env_id: {env_id!r} has no baselines (known: "
                         f"{', '.join(TASK_BASELINES)})")
    check_disjoint(seeds, search_seeds)
    tb = TASK_BASELINES[env_id]
    kw = {**dict(tb.env_kwargs), **(env_kwargs or {})}
    if workers > 1:
        ctx = get_context("spawn")  # (no fork after torch and numba have started threads)
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
    else:
        pool = _InProcess()
    with pool:
        t0 = time.perf_counter()
        grid = tb.constant_grid
        parts = [pool.submit(_search, env_id, grid, c, kw, seeds)
                 for c in _chunks(search_seeds, workers)]
        sizes = [len(c) for c in _chunks(search_seeds, workers)]
        means = sum(np.array(p.result()) * n for p, n in zip(parts, sizes)) / sum(sizes)
        import gymnasium as gym

        probe = gym.make(env_id, **kw)
        probe.reset(seed=search_seeds[0])
        cand = np.asarray(grid(probe) if callable(grid) else grid, dtype=np.float32)
        probe.close()
        best = cand[int(np.argmax(means))]
        shown = np.round(best.astype(float), 3).tolist()
        log(f"{env_id}: best constant {shown} of {len(cand)} on seeds "
            f"{search_seeds[0]}..{search_seeds[-1]} ({time.perf_counter() - t0:.0f} s)")
        jobs = {"random": None, "best constant": best, "hand-written": None,
                "searched": None}
        names = {"random": "random", "best constant":
                 f"best constant {np.round(best.astype(float), 3).tolist()}",
                 "hand-written": f"simple rule: {tb.controller_name}",
                 "searched": "searched controller"}
        for run in runs:
            info = run_info(run)
            label = f"{info['algo']} ({Path(run).name})"
            jobs[label] = (str(run), checkpoint, deterministic)
            names[label] = label
        if planner:
            jobs["planner"] = None
            names["planner"] = (f"planner (rollout MPC on the searched controller, "
                                f"{PLANNER_FUTURES} fresh futures per candidate)")
        if oracle:
            jobs["oracle"] = None
            names["oracle"] = ("oracle (rollout MPC on the searched controller, every "
                               "random draw foreseen)")
        futures = {}
        for name, payload in jobs.items():
            kind = "agent" if name not in LADDER else name
            # the slow policies get one chunk per worker, the fast ones a single job
            n = workers if kind in ("oracle", "planner", "agent") else 1
            some = seeds[:oracle_seeds] if kind in ("oracle", "planner") else seeds
            futures[name] = [pool.submit(_episodes, env_id, kind, payload, c, kw)
                             for c in _chunks(some, n)]
        runs_out = {}
        for name, fs in futures.items():
            t = time.perf_counter()
            rets, secs = [], []
            for f in fs:
                r, s = f.result()
                rets += r
                secs += s
            runs_out[name] = (np.array(rets), np.array(secs))
            log(f"{env_id}: {name} done (waited {time.perf_counter() - t:.0f} s)")
    ref = runs_out["hand-written"][0]
    top = runs_out["searched"][0]
    rows = {}
    for name, (r, s) in runs_out.items():
        row = {"label": names[name], "mean": mean_ci(r).as_dict(), "iqm": iqm_ci(r).as_dict(),
               "seconds_per_episode": float(s.mean()), "returns": [float(x) for x in r]}
        if name != "hand-written":
            row["minus_hand_written"] = paired_difference(r, ref[:len(r)]).as_dict()
        if name != "searched":
            row["minus_searched"] = paired_difference(r, top[:len(r)]).as_dict()
        if len(r) < len(ref):
            row["seeds"] = list(seeds[:len(r)])
        if name not in LADDER:
            info = run_info(jobs[name][0])
            row["run"] = jobs[name][0]
            row["algo"] = info["algo"]
            row["variant"] = variant(info)
            row["train"] = info["summary"]
        rows[name] = row
    rows.update(pooled_rows(rows, ref, top))
    normalise(rows)
    return {"env_id": env_id, "env_kwargs": kw, "eval_seeds": list(seeds),
            "search_seeds": list(search_seeds), "checkpoint": checkpoint,
            "deterministic": deterministic,
            "best_constant": [float(x) for x in best], "policies": rows}


def pooled_rows(rows: dict, ref: np.ndarray, top: np.ndarray) -> dict:
    """For each :func:`variant` with two or more runs in ``rows`` (training seeds, say): a
    row of their mean return on each evaluation seed, with the same statistics (``ref``,
    ``top``: the hand-written and the searched controller's returns), and the runs' own
    means (``run_means``: the spread across training seeds). Its intervals are over the
    evaluation seeds for these runs; they say nothing of runs not trained."""
    from discgym.baselines import iqm_ci, mean_ci, paired_difference

    by_variant: dict = {}
    for name, row in rows.items():
        if "algo" in row and "pooled" not in row:
            by_variant.setdefault(row.get("variant", row["algo"]), []).append(name)
    out = {}
    for kind, names in by_variant.items():
        if len(names) < 2:
            continue
        r = np.mean([rows[n]["returns"] for n in names], axis=0)
        means = [float(np.mean(rows[n]["returns"])) for n in names]
        key = f"{kind}: mean of {len(names)} runs"
        spread = ", ".join(f"{m:.3f}" for m in means)
        out[key] = {"label": f"{key} (each seed's mean over the runs; the runs' means "
                             f"{spread})", "pooled": names, "run_means": means,
                    "mean": mean_ci(r).as_dict(), "iqm": iqm_ci(r).as_dict(),
                    "minus_hand_written": paired_difference(r, ref[:len(r)]).as_dict(),
                    "minus_searched": paired_difference(r, top[:len(r)]).as_dict(),
                    "seconds_per_episode": float(np.mean(
                        [rows[n]["seconds_per_episode"] for n in names])),
                    "returns": [float(x) for x in r]}
    return out


def normalise(rows: dict) -> None:
    """Each row's ``normalised`` score, in place: its mean return mapped linearly so that
    random's mean is 0 and the searched controller's 1 (the interval's ends mapped alike;
    the two references are treated as exact). Rows on fewer seeds (the oracles) are mapped
    with the references' means on those seeds."""
    from discgym.baselines import normalised_scores

    rand, top = rows["random"]["returns"], rows["searched"]["returns"]
    keys = ("value", "low", "high")
    for row in rows.values():
        n = len(row["returns"])
        try:
            ends = normalised_scores([row["mean"][k] for k in keys], rand[:n], top[:n])
        except ValueError:  # (the searched controller not above random: no scale)
            row["normalised"] = None
            continue
        row["normalised"] = dict(zip(keys, map(float, ends)))


# ------------------------------------------------------------------------ table and figures


def _ci(d: dict) -> str:
    return f"{d['value']:.3f} [{d['low']:.3f}, {d['high']:.3f}]"


def table(res: dict) -> str:
    n = len(res["eval_seeds"])
    lines = [f"| policy ({n} seeds) | mean [95% CI] | IQM [95% CI] | minus the simple rule "
             "[95% CI] | minus searched [95% CI] | normalised (random 0, searched 1) | "
             "training |", "|---|---|---|---|---|---|---|"]
    order = [k for k in LADDER[:4] if k in res["policies"]]
    order += [k for k in res["policies"] if k not in LADDER]
    order += [k for k in LADDER[4:] if k in res["policies"]]
    for k in order:
        r = res["policies"][k]
        d, ds = (("" if diff is None else _ci(diff) + (" **separated**" if diff["low"] > 0
                                                      else ""))
                 for diff in (r.get("minus_hand_written"), r.get("minus_searched")))
        nm = r.get("normalised")
        ns = "" if nm is None else _ci(nm)
        train = ""
        if r.get("train"):
            t = r["train"]
            env_steps = t.get("env_steps", t["timesteps"])
            train = (f"{t['timesteps']:,} steps, {t['wall_seconds']:.0f} s"
                     if env_steps == t["timesteps"] else
                     f"{t['timesteps']:,} decisions = {env_steps:,} env steps, "
                     f"{t['wall_seconds']:.0f} s")
        label = f"**{r['label']}**" if "train" in r else r["label"]
        if "seeds" in r:
            label += f" (seeds {r['seeds'][0]}-{r['seeds'][-1]} only)"
        lines.append(f"| {label} | {_ci(r['mean'])} | {_ci(r['iqm'])} | {d} | {ds} | {ns} | "
                     f"{train} |")
    return "\n".join(lines)


def plot_curves(res: dict, path: Path) -> Path:
    """Each agent's mean validation return (EvalCallback's evaluations.npz) against training
    steps, with the baselines' evaluation means as horizontal lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=120)
    styles = {"random": ("0.6", ":"), "best constant": ("0.4", "--"),
              "hand-written": ("tab:blue", "--"), "searched": ("tab:orange", "--"),
              "planner": ("tab:purple", "-."), "oracle": ("tab:green", "-.")}
    for k, (color, ls) in styles.items():
        if k in res["policies"]:
            ax.axhline(res["policies"][k]["mean"]["value"], color=color, ls=ls, lw=1.2,
                       label={"hand-written": res["policies"][k]["label"],
                              "planner": "planner, random draws not foreseen"}.get(k, k))
    for r in res["policies"].values():
        if "run" not in r:
            continue
        npz = Path(r["run"]) / "evaluations.npz"
        if npz.exists():
            d = np.load(npz)
            t = run_info(r["run"])["summary"] or {}
            per = t.get("env_steps", 1) // max(t.get("timesteps", 1), 1)  # env steps/decision
            ax.plot(d["timesteps"] * max(per, 1), d["results"].mean(axis=1), marker="o", ms=3,
                    label=f"{r['label']} (validation seeds)")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return")
    ax.set_title(res["env_id"])
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def animate(env_id: str, factory, path: Path, seed: int, env_kwargs=None, every: int = 2,
            size: int = 320) -> Path:
    """A GIF of one episode: the reactor beside its species counts."""
    import gymnasium as gym
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    env = gym.make(env_id, render_mode="rgb_array", render_size=size, **(env_kwargs or {}))
    policy = factory(env)
    obs, _ = env.reset(seed=seed)
    names = env.unwrapped.simulation.scene.species_names
    history = [list(env.unwrapped.simulation.counts().values())]
    frames, done, t = [], False, 0
    while not done:
        obs, _, term, trunc, _ = env.step(policy(obs))
        done = term or trunc
        history.append(list(env.unwrapped.simulation.counts().values()))
        if t % every == 0 or done:
            frames.append((env.render(), np.array(history)))
        t += 1
    env.close()
    ymax = 1.05 * max(1, int(np.max(history)))
    images = []
    fig, ax = plt.subplots(figsize=(size / 100, size / 100), dpi=100)
    for img, hist in frames:
        ax.clear()
        for k, nm in enumerate(names):
            ax.plot(np.arange(len(hist)), hist[:, k], label=nm)
        ax.set_xlim(0, len(history))
        ax.set_ylim(0, ymax)
        ax.set_xlabel("env step")
        ax.set_ylabel("discs in the reactor")
        ax.legend(loc="upper right", fontsize=7)
        fig.tight_layout()
        fig.canvas.draw()
        chart = np.asarray(fig.canvas.buffer_rgba())[..., :3]
        h = min(img.shape[0], chart.shape[0])
        images.append(Image.fromarray(np.concatenate([img[:h], chart[:h]], axis=1)))
    plt.close(fig)
    images[0].save(path, save_all=True, append_images=images[1:], duration=80, loop=0)
    return path


def check_args(a: Args) -> tuple[str, dict]:
    """The validation pass, before any episode runs or anything is written: every flag
    against its type and range, the seeds taken together, ``--out``, and each run
    (:func:`check_run`, then its checkpoint loaded once). Returns the runs' task and env
    arguments."""
    check_fields(a)
    if not a.run:
        raise usage("run", "name at least one folder written by train_ppo.py")
    infos = [check_run(r, a.checkpoint) for r in a.run]
    labels = [f"{i['algo']} ({Path(r).name})" for i, r in zip(infos, a.run)]
    for k, lab in enumerate(labels):
        if lab in labels[:k]:
            raise usage("run", f"two runs would share the row {lab!r} ({a.run[labels.index(lab)]}"
                               f" and {a.run[k]}): name each run once, in folders of "
                               f"different names")
    envs = {i["env_id"] for i in infos}
    kws = [env_kwargs_of(r) for r in a.run]
    if len(envs) != 1 or any(k != kws[0] for k in kws):
        raise usage("run", f"the runs must share a task and its arguments, got "
                           f"{sorted(envs)} {kws}")
    if a.first_seed < a.search_seeds:
        raise usage("first_seed", f"the evaluation seeds {a.first_seed}.."
                    f"{a.first_seed + a.seeds - 1} meet the search seeds 0.."
                    f"{a.search_seeds - 1} (--search-seeds {a.search_seeds})")
    if a.first_seed + a.seeds - 1 > MAX_SEED:
        raise usage("seeds", f"the evaluation seeds pass {MAX_SEED}")
    if a.out is not None:
        p = Path(a.out)
        while not p.exists() and p != p.parent:
            p = p.parent
        if not p.is_dir():
            raise usage("out", f"{p} exists and is not a folder")
    for r in a.run:  # (a corrupted checkpoint: refused now, not in a worker after minutes)
        agent_factory(r, a.checkpoint, a.deterministic)
    return envs.pop(), kws[0]


def main(argv=None) -> int:
    import argcheck

    from discgym.bench import machine_info

    a = argcheck.parse(Args, argv, description=__doc__.split("\n\n")[0])
    env_id, kw = check_args(a)
    seeds = list(range(a.first_seed, a.first_seed + a.seeds))
    t0 = time.perf_counter()
    res = evaluate_task(env_id, a.run, seeds, list(range(a.search_seeds)), kw,
                        a.checkpoint, a.oracle, a.workers, a.planner, a.deterministic,
                        a.oracle_seeds, log=lambda s: print(s, file=sys.stderr, flush=True))
    import gymnasium
    import numba
    import stable_baselines3
    import torch

    res.update(date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
               machine=f"{platform.machine()}, {os.cpu_count()} CPUs, {machine_info()['cpu']}",
               versions={"python": platform.python_version(), "numpy": np.__version__,
                         "numba": numba.__version__, "gymnasium": gymnasium.__version__,
                         "torch": torch.__version__,
                         "stable_baselines3": stable_baselines3.__version__},
               evaluation_seconds=time.perf_counter() - t0)
    out = Path(a.out or a.run[0])
    out.mkdir(parents=True, exist_ok=True)
    res["table"] = table(res)
    acts = "deterministic" if a.deterministic else "sampled"
    md = (f"{env_id}, seeds {seeds[0]}-{seeds[-1]} ({acts} actions, the {a.checkpoint} "
          f"checkpoint), {res['date']}, {res['machine']}\n\n{res['table']}")
    write_text_atomic(out / "evaluation.json", json.dumps(res, indent=2) + "\n")
    write_text_atomic(out / "evaluation.md", md + "\n")
    print(md)
    print(f"wrote {out / 'evaluation.md'}, {plot_curves(res, out / 'learning_curve.png')}")
    if a.gif:
        gif = animate(env_id, agent_factory(a.run[0], a.checkpoint, a.deterministic),
                      out / "episode.gif",
                      seed=seeds[0], env_kwargs=kw)
        print(f"wrote {gif}")
    return 0


if __name__ == "__main__":
    import argcheck

    argcheck.run(main)
