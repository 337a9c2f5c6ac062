"""Stable-Baselines3 adapter: the batched reactor as an SB3 ``VecEnv``.

>>> from discgym.sb3 import DiscReactorSB3VecEnv          # doctest: +SKIP
>>> from stable_baselines3 import PPO                       # doctest: +SKIP
>>> venv = DiscReactorSB3VecEnv(num_envs=16)               # doctest: +SKIP
>>> PPO("MlpPolicy", venv).learn(100_000)                   # doctest: +SKIP

Wraps :class:`discgym.vector.DiscReactorVectorEnv` (all reactors in one compiled call) in
"SameStep" autoreset mode and converts to SB3's conventions: ``step_wait`` returns
``(obs, rewards float32, dones, infos)`` with one ``info`` dict per reactor; a finished
reactor's info carries ``terminal_observation`` (its last observation; the returned
observation is already the first of its next episode) and ``TimeLimit.truncated``.
``seed(s)`` seeds reactor i with ``s + i`` at the next ``reset()``, like SB3's own VecEnvs.
Wrap it in ``VecMonitor`` for episode statistics.

stable-baselines3 (and torch) are needed only by this module, which the rest of discgym never
imports: ``pip install torch==2.13.0 'discgym[agents]'``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

try:
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv
except ImportError as exc:  # pragma: no cover - exercised only without SB3
    raise ImportError(
        "discgym.sb3 needs stable-baselines3: pip install torch==2.13.0 'discgym[agents]'"
    ) from exc

from .vector import DiscReactorVectorEnv

__all__ = ["DiscReactorSB3VecEnv"]


class DiscReactorSB3VecEnv(VecEnv):
    """``num_envs`` reactors of ``DiscReactor-v0`` as one SB3 ``VecEnv``.

    Keyword arguments go to :class:`~discgym.vector.DiscReactorVectorEnv` (and from there to
    :class:`~discgym.env.DiscReactorEnv`), e.g. ``episode_steps``, ``threads``,
    ``render_mode="rgb_array"``, with their ranges; ``autoreset_mode`` may only be
    "SameStep" (SB3's convention). Actions: (``num_envs``, 2 + F), as SB3 passes them.
    """

    def __init__(self, num_envs: int = 8, **kwargs):
        mode = kwargs.pop("autoreset_mode", AutoresetMode.SAME_STEP)
        if mode not in (AutoresetMode.SAME_STEP, AutoresetMode.SAME_STEP.value):
            raise ValueError(f"autoreset_mode: SB3's VecEnv resets a finished reactor in the "
                             f"same step (\"SameStep\", the only mode here), got {mode!r}")
        self.venv = DiscReactorVectorEnv(num_envs=num_envs, autoreset_mode="SameStep",
                                         **kwargs)
        self.render_mode = self.venv.render_mode
        n = self.venv.num_envs  # (validated: a Python int)
        super().__init__(n, self.venv.single_observation_space, self.venv.single_action_space)
        # the batch's metadata (render_fps: VecVideoRecorder reads it from here)
        self.metadata = dict(self.venv.metadata)
        self._actions = None
        self.reset_infos = [{} for _ in range(n)]

    # ------------------------------------------------------------------ core API
    def reset(self) -> np.ndarray:
        seeds = list(self._seeds)
        seed = None if all(s is None for s in seeds) else seeds
        obs, info = self.venv.reset(seed=seed)
        self.reset_infos = [{"n_ref": float(info["n_ref"][i])} for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        actions, self._actions = self._actions, None  # (consumed even if refused)
        obs, rew, terminated, truncated, info = self.venv.step(actions)
        dones = terminated | truncated
        src = info.get("final_info", info)
        infos = []
        for i in range(self.num_envs):
            d = _row(info if not dones[i] else src, i)
            d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            if dones[i]:
                d["terminal_observation"] = info["final_obs"][i]
            infos.append(d)
        return obs, rew.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    # ------------------------------------------------------------------ attributes
    def _targets(self, indices):
        return list(self._get_indices(indices))

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        if attr_name == "render_mode":
            return [self.venv.render_mode for _ in self._targets(indices)]
        value = getattr(self.venv, attr_name)
        return [value for _ in self._targets(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs):
        if method_name == "render":
            frames = self.venv.render() or (None,) * self.num_envs
            return [frames[i] for i in self._targets(indices)]
        raise AttributeError(f"DiscReactorSB3VecEnv has no per-reactor method {method_name!r}")

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._targets(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.venv.render_mode != "rgb_array":
            return [None] * self.num_envs
        return list(self.venv.render())


def _row(info: dict, i: int) -> dict:
    out = {}
    for k, v in info.items():
        if k.startswith("_") or k in ("final_obs", "final_info"):
            continue
        if isinstance(v, dict):
            out[k] = _row(v, i)
        else:
            out[k] = v[i].item() if isinstance(v, np.ndarray) and v.dtype != object else v[i]
    return out
