"""Evaluate a trained PPO policy against the baselines, and animate one episode.

    python agents/evaluate.py --run runs/ppo            # after agents/train_ppo.py

Baselines, all on the same seeds as the policy (seed, seed + 1, ...):
- random: uniform actions in [-1, 1];
- best constant: the best of a grid of constant actions, chosen on *other* seeds (so the
  selection does not flatter it);
- heuristic: the scheduled thermostat of ``discgym.baselines.HeuristicPolicy`` (hot until the
  product builds up, then cool).

Writes into the run folder: ``evaluation.json`` (every return), ``evaluation.md`` (the table),
and ``episode.gif`` (the trained policy's episode on the first seed, discs beside the species
counts).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from discgym.baselines import (
    HeuristicPolicy,
    best_constant_action,
    constant_policy,
    evaluate,
    random_policy,
    reactor_constant_grid,
)
from discgym.bench import machine_info
from discgym.env import ReactorConfig


def load_policy(run: Path):
    """The trained policy as a function (R, D) observations -> (R, A) actions."""
    from stable_baselines3 import PPO

    model = PPO.load(run / "model.zip", device="cpu")
    stats = None
    if (run / "vecnormalize.pkl").exists():
        import pickle

        with open(run / "vecnormalize.pkl", "rb") as fh:
            vn = pickle.load(fh)
        stats = (vn.obs_rms.mean, np.sqrt(vn.obs_rms.var + vn.epsilon), vn.clip_obs)

    def policy(obs):
        o = np.asarray(obs, dtype=np.float64)
        if stats is not None:
            mean, std, clip = stats
            o = np.clip((o - mean) / std, -clip, clip)
        act, _ = model.predict(o.astype(np.float32), deterministic=True)
        return act

    return policy


def constant_grid(n_actions: int) -> np.ndarray:
    """Candidate constant actions: :func:`discgym.baselines.reactor_constant_grid` (heat x
    wall x each feed on or off, 120 for the default env, heat levels dense near 0)."""
    return reactor_constant_grid(n_actions)


def compare(run: Path | None, episodes: int = 10, seed: int = 0, env_kwargs=None,
            threads=None, search_episodes: int = 6, grid=None) -> dict:
    """Mean, std and all returns of every policy on seeds ``seed .. seed + episodes - 1``.

    The best constant action is searched over ``grid`` (default :func:`constant_grid`) on
    ``search_episodes`` other seeds."""
    env_kwargs = dict(env_kwargs or {})
    cfg = ReactorConfig.from_kwargs(**env_kwargs)
    n_act = len(cfg.action_names)
    grid = constant_grid(n_act) if grid is None else np.asarray(grid, dtype=np.float32)
    best, means = best_constant_action(grid, episodes=search_episodes, seed=seed + 10_000,
                                       threads=threads, **env_kwargs)
    policies = {
        "random": random_policy(n_act, seed=seed),
        "best constant": constant_policy(best),
        "heuristic": HeuristicPolicy(cfg.obs_names),
    }
    if run is not None:
        policies["PPO"] = load_policy(run)
    results = {}
    for name, pol in policies.items():
        r = evaluate(pol, episodes=episodes, seed=seed, threads=threads, **env_kwargs)
        results[name] = {"mean": float(r.mean()), "std": float(r.std(ddof=1)),
                         "returns": [float(x) for x in r]}
    results["best constant"]["action"] = [float(x) for x in best]
    results["_meta"] = {"episodes": episodes, "seeds": [seed, seed + episodes - 1],
                        "constant_grid_size": len(grid), "action_names": list(cfg.action_names),
                        "env_kwargs": env_kwargs}
    return results


def table(results: dict) -> str:
    lines = ["| policy | yield (mean +- std) |", "|---|---|"]
    for name, r in results.items():
        if name.startswith("_"):
            continue
        lines.append(f"| {name} | {r['mean']:.3f} +- {r['std']:.3f} |")
    return "\n".join(lines)


def animate(run: Path, path: Path, seed: int = 0, env_kwargs=None, every: int = 2,
            size: int = 320) -> Path:
    """A GIF of one episode of the trained policy: the reactor beside its species counts."""
    import gymnasium as gym
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    import discgym  # noqa: F401  (registers the env)

    policy = load_policy(run)
    env = gym.make("DiscReactor-v0", render_mode="rgb_array", render_size=size,
                   **(env_kwargs or {}))
    obs, _ = env.reset(seed=seed)
    sim = env.unwrapped.simulation
    names = sim.scene.species_names
    history = [list(sim.counts().values())]
    frames = []
    done = False
    t = 0
    while not done:
        obs, _, term, trunc, _ = env.step(policy(obs[None])[0])
        done = term or trunc
        history.append(list(env.unwrapped.simulation.counts().values()))
        if t % every == 0 or done:
            frames.append((env.render(), np.array(history)))
        t += 1
    env.close()
    total = len(history)
    ymax = 1.05 * max(1, int(np.max(history)))
    images = []
    fig, ax = plt.subplots(figsize=(size / 100, size / 100), dpi=100)
    for img, hist in frames:
        ax.clear()
        for k, nm in enumerate(names):
            ax.plot(np.arange(len(hist)), hist[:, k], label=nm)
        ax.set_xlim(0, total)
        ax.set_ylim(0, ymax)
        ax.set_xlabel("env step")
        ax.set_ylabel("discs")
        ax.legend(loc="upper right", fontsize=7)
        fig.tight_layout()
        fig.canvas.draw()
        chart = np.asarray(fig.canvas.buffer_rgba())[..., :3]
        h = min(img.shape[0], chart.shape[0])
        images.append(Image.fromarray(np.concatenate([img[:h], chart[:h]], axis=1)))
    plt.close(fig)
    images[0].save(path, save_all=True, append_images=images[1:], duration=80, loop=0)
    return path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", type=Path, required=True, help="folder written by train_ppo.py")
    p.add_argument("--episodes", type=int, default=10, help="evaluation seeds (>= 10)")
    p.add_argument("--seed", type=int, default=0, help="first evaluation seed")
    p.add_argument("--no-gif", action="store_true", help="skip the animation")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--search-episodes", type=int, default=6,
                   help="seeds (other than the evaluation's) for the constant-action search")
    a = p.parse_args(argv)
    args_file = a.run / "args.json"
    env_kwargs = {}
    if args_file.exists():
        saved = json.loads(args_file.read_text())
        env_kwargs = {"scene": saved.get("scene", "reactor")}
        for k in ("product", "episode_steps"):
            if saved.get(k) is not None:
                env_kwargs[k] = saved[k]
        if env_kwargs == {"scene": "reactor"}:
            env_kwargs = {}
    res = compare(a.run, episodes=a.episodes, seed=a.seed, env_kwargs=env_kwargs,
                  threads=a.threads, search_episodes=a.search_episodes)
    res["_meta"]["date"] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    res["_meta"]["machine"] = (f"{platform.machine()}, {os.cpu_count()} CPUs, "
                               f"{machine_info()['cpu']}")
    summary = a.run / "train_summary.json"
    if summary.exists():
        res["_meta"]["train"] = json.loads(summary.read_text())
    (a.run / "evaluation.json").write_text(json.dumps(res, indent=2))
    md = table(res) + f"\n\n{res['_meta']['episodes']} episodes (seeds {a.seed}.." \
        f"{a.seed + a.episodes - 1}), {res['_meta']['date']}, {res['_meta']['machine']}"
    (a.run / "evaluation.md").write_text(md + "\n")
    print(md)
    if not a.no_gif:
        gif = animate(a.run, a.run / "episode.gif", seed=a.seed, env_kwargs=env_kwargs)
        print(f"wrote {gif}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
