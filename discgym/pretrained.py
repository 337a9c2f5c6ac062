"""Trained policies shipped with discgym, run with numpy alone.

The flagship's agents (PPO correcting ``DiscFlow-v0``'s flow thermostat, the README's main
command, one per training seed) are stored as their network's weights and their observation
normalisation (``.npz``, read with ``allow_pickle=False``) and a JSON file of how they act
(the controller they correct, by its name in discgym): loading one unpickles nothing, and
needs neither torch nor Stable-Baselines3::

    import gymnasium as gym
    import discgym
    from discgym import pretrained

    agent = pretrained.load("DiscFlow-v0", seed=0)
    env = gym.make("DiscFlow-v0")
    obs, info = env.reset(seed=1000)
    policy = agent.policy(env)  # one per episode: it counts the episode's steps
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        done = terminated or truncated

An agent acts as it was trained and evaluated (``agents/evaluate.py``): its deterministic
action (the mean of its Gaussian, clipped to [-1, 1]) on the observation as its
``VecNormalize`` statistics normalise it, through the action interface it was trained
with (:class:`discgym.controllers.SetpointActions`: every ``hold`` env steps a factor on the
thermostat's setpoint and a correction of its wall). ``python agents/export_policy.py``
writes the files from a training run and records each agent's returns on a few evaluation
seeds, which ``tests/test_pretrained.py`` reproduces.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .controllers import SetpointActions
from .values import integer

#: Where the agents are: ``<folder>/<env_id>/agents.json`` and ``seed<k>.npz``.
FOLDER = Path(__file__).with_name("agents")
#: The arrays of an agent's file: the network's layers (``w0``, ``b0``, ``w1``, ...: weight
#: (out, in) and bias, tanh between them, none after the last) and the observation's
#: normalisation.
NORMALISATION = ("obs_mean", "obs_var")


def available() -> dict:
    """``{env_id: [training seeds]}`` of the shipped agents."""
    out = {}
    for f in sorted(FOLDER.glob("*/agents.json")):
        if f.parent.name.startswith("."):  # (an export's staging folder)
            continue
        out[f.parent.name] = sorted(int(k) for k in json.loads(f.read_text())["agents"])
    return out


def load(env_id: str = "DiscFlow-v0", seed: int = 0) -> Agent:
    """The shipped agent of task ``env_id`` trained with ``seed`` (:func:`available`)."""
    have = available()
    if not isinstance(env_id, str) or env_id not in have:
        raise ValueError(f"env_id: no trained agent of {env_id!r}; shipped: {sorted(have)}")
    k = integer(seed)
    if k is None or k not in have[env_id]:
        raise ValueError(f"seed: {env_id} has agents of training seeds {have[env_id]}, "
                         f"got {seed!r}")
    meta = json.loads((FOLDER / env_id / "agents.json").read_text())
    with np.load(FOLDER / env_id / f"seed{k}.npz", allow_pickle=False) as z:
        arrays = {name: z[name] for name in z.files}
    return Agent(env_id, k, arrays, meta)


class Agent:
    """A trained agent: :meth:`decide` maps what it observes to its action, :meth:`policy`
    makes the env policy of one episode. ``info``: how it was trained and what it scored."""

    def __init__(self, env_id: str, seed: int, arrays: dict, meta: dict):
        n = sum(k.startswith("w") for k in arrays)
        self.layers = [(arrays[f"w{i}"], arrays[f"b{i}"]) for i in range(n)]
        self.obs_mean, self.obs_var = (arrays[k] for k in NORMALISATION)
        self.env_id, self.seed = env_id, seed
        self.interface = dict(meta["interface"])
        base = self.interface.get("base")
        if base is not None and not str(base).startswith("discgym."):
            raise ValueError(f"{env_id} seed {seed}: its interface names a controller "
                             f"outside discgym ({base!r}); refusing to import it")
        self.clip_obs, self.epsilon = float(meta["clip_obs"]), float(meta["epsilon"])
        self.info = {k: v for k, v in meta.items() if k != "agents"}
        self.info.update(meta["agents"][str(seed)])

    def decide(self, agent_obs) -> np.ndarray:
        """The action (float32, in [-1, 1]) for what the agent observes (the observation and
        its running mean: :meth:`discgym.controllers.SetpointActions.agent_obs`)."""
        o = np.asarray(agent_obs, dtype=np.float32)
        if o.shape != (self.layers[0][0].shape[1],):
            raise ValueError(f"agent_obs: expected shape ({self.layers[0][0].shape[1]},) (what "
                             f"the agent observes), got {o.shape}")
        x = np.clip((o - self.obs_mean) / np.sqrt(self.obs_var + self.epsilon),
                    -self.clip_obs, self.clip_obs).astype(np.float32)
        for i, (w, b) in enumerate(self.layers):
            x = w @ x + b
            if i < len(self.layers) - 1:
                x = np.tanh(x)
        return np.clip(x, -1.0, 1.0).astype(np.float32)

    def policy(self, env):
        """The env policy (observation -> env action) of one episode of ``env`` (a
        ``gymnasium.make`` of the agent's task): make one per episode. An agent trained on
        the env's own observations and actions (no interface) is :meth:`decide` itself."""
        spec = getattr(env, "spec", None)
        if spec is not None and spec.id != self.env_id:
            raise ValueError(f"env: the agent was trained on {self.env_id}, got {spec.id}")
        if not self.interface:
            return self.decide
        return SetpointActions(env, **self.interface).policy(self.decide)

    def __repr__(self) -> str:
        return f"<discgym.pretrained.Agent {self.env_id} seed {self.seed}>"
