"""Baselines for ``DiscReactor-v0``: a scheduled heuristic, constant actions, random actions.

Policies here map an observation (D,) or a batch (R, D) to an action (A,) or (R, A);
:func:`evaluate` runs one on a :class:`~discgym.vector.DiscReactorVectorEnv`, one episode per
reactor. They see only what the env shows (observations, its names and defaults), never the
physics; their returns on the default env are in ``docs/env.md``.

>>> from discgym.baselines import evaluate, heuristic_policy
>>> returns = evaluate(heuristic_policy, episodes=2, episode_steps=5)  # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from .env import DEFAULTS, ReactorConfig
from .kernels.structs import FLOAT
from .vector import DiscReactorVectorEnv

__all__ = [
    "HeuristicPolicy",
    "heuristic_policy",
    "constant_policy",
    "random_policy",
    "evaluate",
    "best_constant_action",
]


class HeuristicPolicy:
    """The scheduled heuristic: a thermostat on the observed temperature that heats the cold
    reactor over the activation barrier to ``t_hot`` and holds it there until the product
    yield reaches ``switch_yield`` (or the fraction ``switch_time`` of the episode is over),
    then holds ``t_cold``, cooling against the reaction heat. It also sets the wall action to
    ``wall`` (-1: the smallest reactor) and the injection actions to ``inject`` (one value
    per feed species, or one for all).

    Works on one observation (D,) or a batch (R, D); reads the slots by name, so give it the
    ``observation_names`` of the env (default: those of the default env) and the env's
    ``heat_rate`` if it is not the default.
    """

    def __init__(self, observation_names: Sequence[str] | None = None, *, t_hot=1.8,
                 t_cold=1.6, switch_yield=0.2, switch_time=1.0, wall=-1.0, inject=1.0,
                 heat_rate=None):
        if observation_names is None:
            observation_names = _default_config().obs_names
        names = list(observation_names)
        self.frac = [k for k, nm in enumerate(names) if nm.startswith("fraction_")]
        self.kT = [k for k, nm in enumerate(names) if nm.startswith("kT_")]
        self.i_yield = names.index("yield")
        self.i_time = names.index("time_left")
        self.n_feed = sum(nm.startswith("feed_left_") for nm in names)
        self.t_hot, self.t_cold = float(t_hot), float(t_cold)
        self.switch_yield, self.switch_time = float(switch_yield), float(switch_time)
        self.wall = float(wall)
        self.inject = np.broadcast_to(np.asarray(inject, dtype=FLOAT), (self.n_feed,))
        self.log_rate = math.log(heat_rate if heat_rate else DEFAULTS["heat_rate"])

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.asarray(obs, dtype=FLOAT)
        one = o.ndim == 1
        o = np.atleast_2d(o)
        T = (o[:, self.frac] * o[:, self.kT]).sum(axis=1)
        late = (o[:, self.i_yield] >= self.switch_yield) | \
            (o[:, self.i_time] <= 1.0 - self.switch_time)
        target = np.where(late, self.t_cold, self.t_hot)
        a = np.empty((len(o), 2 + self.n_feed), dtype=np.float32)
        a[:, 0] = np.clip(np.log(target / np.maximum(T, 1e-6)) / self.log_rate, -1.0, 1.0)
        a[:, 1] = self.wall
        a[:, 2:] = self.inject
        return a[0] if one else a


def heuristic_policy(obs: np.ndarray) -> np.ndarray:
    """The default :class:`HeuristicPolicy` on observations of the default env."""
    global _HEURISTIC
    if _HEURISTIC is None:
        _HEURISTIC = HeuristicPolicy()
    return _HEURISTIC(obs)


_HEURISTIC = None
_CONFIG = None


def _default_config() -> ReactorConfig:
    global _CONFIG
    if _CONFIG is None:
        _CONFIG = ReactorConfig.from_kwargs()
    return _CONFIG


def constant_policy(action) -> Callable[[np.ndarray], np.ndarray]:
    """A policy that always takes ``action`` (A,) (for a batch: the same row for each)."""
    act = np.asarray(action, dtype=np.float32)

    def policy(obs):
        o = np.asarray(obs)
        return act.copy() if o.ndim == 1 else np.tile(act, (len(o), 1))

    return policy


def random_policy(n_actions: int = 4, seed=None) -> Callable[[np.ndarray], np.ndarray]:
    """Uniform random actions in [-1, 1]^n_actions from its own generator."""
    rng = np.random.default_rng(seed)

    def policy(obs):
        o = np.asarray(obs)
        shape = (n_actions,) if o.ndim == 1 else (len(o), n_actions)
        return rng.uniform(-1.0, 1.0, size=shape).astype(np.float32)

    return policy


def evaluate(policy: Callable[[np.ndarray], np.ndarray], episodes: int = 10, seed: int = 0,
             threads: int | None = None, **env_kwargs) -> np.ndarray:
    """Returns (episodes,) undiscounted returns of ``policy`` (a batch of observations ->
    a batch of actions), one episode per reactor of a vector env, seeds ``seed + k``."""
    venv = DiscReactorVectorEnv(num_envs=episodes, autoreset_mode="Disabled", threads=threads,
                                **env_kwargs)
    obs, _ = venv.reset(seed=seed)
    total = np.zeros(episodes)
    for _ in range(venv.config.episode_steps):
        obs, r, term, trunc, _ = venv.step(policy(obs))
        total += r
        if (term | trunc).all():
            break
    venv.close()
    return total


def best_constant_action(candidates: Sequence[Sequence[float]], episodes: int = 10,
                         seed: int = 0, threads: int | None = None,
                         **env_kwargs) -> tuple[np.ndarray, np.ndarray]:
    """Evaluate each constant action of ``candidates`` (K, A) on the same seeds; returns
    ``(best action (A,), mean returns (K,))``."""
    cand = np.asarray(candidates, dtype=np.float32)
    means = np.array([evaluate(constant_policy(c), episodes, seed, threads, **env_kwargs)
                      .mean() for c in cand])
    return cand[int(np.argmax(means))], means

