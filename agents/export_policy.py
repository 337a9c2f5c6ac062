"""Ship trained PPO agents with the package (``discgym.pretrained``): their network's weights
and observation normalisation as ``.npz`` and how they act as JSON, checked against the
trained model and scored on a few evaluation seeds.

    python agents/export_policy.py --runs runs/flagship_seed0 runs/flagship_seed1 \\
        runs/flagship_seed2

Each run is a folder written by ``train_ppo.py`` (PPO with an ``MlpPolicy``, observation
normalisation and at most one ``SetpointHold`` interface), all of one task; its best
validation checkpoint is exported. The numpy agent's actions must equal the trained
model's (torch, as ``evaluate.py`` runs it) within ``--atol`` on every observation of an
episode, or nothing is written. (Not along two episodes of their own: the float32 sums of
the two differ in their last bits, and the reactor's trajectory amplifies any difference.)
Each agent's return on ``--seeds`` (evaluation seeds) is recorded with it;
``tests/test_pretrained.py`` reproduces them. The files of the task are replaced as a whole.
"""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from argcheck import Range, parse, run, staged_folder, usage  # noqa: E402
from evaluate import checkpoint_file, env_kwargs_of, load_run, run_info, variant  # noqa: E402

import discgym  # noqa: E402, F401  (registers the tasks)


@dataclass
class Args:
    """Export arguments; each is also a flag."""

    runs: list[str] = field(default_factory=list)
    """the run folders (one per training seed) of one task"""
    seeds: list[int] = field(default_factory=lambda: [1000, 1001, 1002])
    """evaluation seeds on which each agent's return is recorded"""
    atol: Annotated[float, Range(0.0)] = 1e-4
    """largest difference allowed between the numpy and the torch agent's env actions"""
    out: str | None = None
    """the agents' folder (default: the package's, discgym/agents)"""


def export(run_dir: Path) -> tuple:
    """``(arrays, interface, normalisation, model, vecnormalize)`` of a run's best
    checkpoint."""
    import torch

    model, vn, wrappers = load_run(run_dir, "best")
    pol = model.policy
    if type(model).__name__ != "PPO" or pol.squash_output or \
            pol.activation_fn is not torch.nn.Tanh:
        raise usage("runs", f"{run_dir}: not a PPO MlpPolicy with tanh units")
    if vn is None or not vn.norm_obs:
        raise usage("runs", f"{run_dir}: no observation normalisation to export")
    if len(wrappers) > 1 or (wrappers and wrappers[0][0].__name__ != "SetpointHold"):
        raise usage("runs", f"{run_dir}: an interface other than one SetpointHold")
    sd = {k: v.detach().cpu().numpy() for k, v in pol.state_dict().items()}
    names = sorted({k.rsplit(".", 1)[0] for k in sd if k.startswith("mlp_extractor.policy_net")},
                   key=lambda n: int(n.rsplit(".", 1)[1]))
    layers = [*names, "action_net"]
    arrays = {}
    for i, n in enumerate(layers):
        arrays[f"w{i}"] = sd[f"{n}.weight"].astype(np.float32)
        arrays[f"b{i}"] = sd[f"{n}.bias"].astype(np.float32)
    arrays["obs_mean"] = np.asarray(vn.obs_rms.mean, dtype=np.float64)
    arrays["obs_var"] = np.asarray(vn.obs_rms.var, dtype=np.float64)
    interface = dict(wrappers[0][1]) if wrappers else {}
    return arrays, interface, {"clip_obs": float(vn.clip_obs), "epsilon": float(vn.epsilon)}, \
        model, vn


def episode(env_id: str, agent, seed: int, seen: list | None = None) -> float:
    """The return of one episode of ``env_id`` from ``seed`` under the numpy ``agent``
    (appending what it observed at each decision to ``seen``)."""
    import gymnasium as gym

    decide = type(agent).decide.__get__(agent)

    def recording(o):
        if seen is not None:
            seen.append(np.asarray(o, dtype=np.float32))
        return decide(o)

    agent.decide = recording  # (what agent.policy asks, this episode)
    env = gym.make(env_id)
    try:
        obs, _ = env.reset(seed=seed)
        policy = agent.policy(env)
        total, done = 0.0, False
        while not done:
            obs, r, terminated, truncated, _ = env.step(policy(obs))
            total += float(r)
            done = terminated or truncated
    finally:
        env.close()
        del agent.decide
    return total


def main(argv=None) -> int:
    from discgym import pretrained

    args = parse(Args, argv, description=__doc__.split("\n\n")[0])
    if not args.runs:
        raise usage("runs", "give the run folders to export")
    if not args.seeds or min(args.seeds) < 1000:
        raise usage("seeds", f"evaluation seeds (1000 and up), got {args.seeds}")
    infos = [run_info(Path(r)) for r in args.runs]
    env_ids = {i["env_id"] for i in infos}
    if len(env_ids) != 1:
        raise usage("runs", f"runs of one task, got {sorted(env_ids)}")
    env_id = env_ids.pop()
    seeds = [int(i["seed"]) for i in infos]
    if len(set(seeds)) != len(seeds):
        raise usage("runs", f"one run per training seed, got seeds {seeds}")
    kinds = sorted({variant(i) for i in infos})
    if len(kinds) != 1:
        raise usage("runs", f"runs of one setting (seeds of one variant), got {kinds}")
    for r in args.runs:
        if env_kwargs_of(Path(r)):
            raise usage("runs", f"{r} trained on {env_kwargs_of(Path(r))}, not the task as "
                                f"registered: its agent would be scored on another env")
    final = Path(args.out or pretrained.FOLDER) / env_id
    meta = {"env_id": env_id, "agents": {}}
    files = {}
    for r, info in zip(args.runs, infos):
        arrays, interface, norm, model, vn = export(Path(r))
        agent = pretrained.Agent(env_id, info["seed"], arrays,
                                 {"interface": interface, **norm,
                                  "agents": {str(info["seed"]): {}}})
        seen: list = []
        returns = {str(s): episode(env_id, agent, s, seen if s == args.seeds[0] else None)
                   for s in args.seeds}
        theirs = model.predict(vn.normalize_obs(np.stack(seen)), deterministic=True)[0]
        gap = float(np.max(np.abs(np.stack([agent.decide(o) for o in seen]) - theirs)))
        if gap > args.atol:
            raise usage("atol", f"{r}: the numpy agent's actions differ from the trained "
                                f"model's by {gap:.3g} (over {args.atol:g})")
        summary = info.get("summary") or {}
        ev = Path(r) / "evaluations.npz"
        if ev.exists():  # (EvalCallback keeps the first checkpoint of the best mean)
            with np.load(ev) as z:
                summary = {**summary, "best_at": int(z["timesteps"][np.argmax(
                    z["results"].mean(axis=1))])}
        if "interface" in meta and (meta["interface"], meta["clip_obs"], meta["epsilon"]) != \
                (interface, norm["clip_obs"], norm["epsilon"]):
            raise usage("runs", f"{r}: another action interface or normalisation than "
                                f"{args.runs[0]}'s")
        meta.update({"interface": interface, **norm})
        meta["agents"][str(info["seed"])] = {
            "returns": returns, "checkpoint": checkpoint_file(Path(r), "best"),
            "training": {k: summary.get(k) for k in ("timesteps", "wall_seconds", "best_at")
                         if k in summary},
            "largest_action_difference": gap, "decisions_compared": len(seen)}
        files[f"seed{info['seed']}.npz"] = arrays
        print(f"seed {info['seed']}: returns {returns}; largest action difference from the "
              f"trained model {gap:.2g} over {len(seen)} decisions")
    meta["trained"] = kinds[0]  # (evaluate.variant: the algorithm, hyperparameters, settings)
    with staged_folder(final, "out") as tmp:
        for name, arrays in files.items():
            np.savez(Path(tmp) / name, **arrays)
        (Path(tmp) / "agents.json").write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
    print(f"wrote {final}")
    return 0


if __name__ == "__main__":
    run(main)
