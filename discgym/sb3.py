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
``seed(s)`` seeds reactor i with ``s + i`` at the next ``reset()``, like SB3's own VecEnvs;
``reset_infos`` holds each reactor's last reset info (autoresets too). ``get_attr``,
``set_attr`` and ``env_method`` work per reactor, on a :class:`Reactor` view of each, as
``DummyVecEnv`` does per env (``env_method("get_wrapper_attr", name, indices=[i])`` and the
other gymnasium ``*_wrapper_attr`` methods included). Wrap it in ``VecMonitor`` for episode
statistics.

stable-baselines3 (and torch) are needed only by this module, which the rest of discgym never
imports: ``pip install torch==2.13.0 'discgym[agents]'``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

try:
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvWrapper
except ImportError as exc:  # pragma: no cover - exercised only without SB3
    raise ImportError(
        "discgym.sb3 needs stable-baselines3: pip install torch==2.13.0 'discgym[agents]'"
    ) from exc

from .vector import DiscReactorVectorEnv

__all__ = ["DiscReactorSB3VecEnv", "SetpointHold"]


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
        self._reactors = [Reactor(self.venv, i) for i in range(n)]  # (SB3's __init__ reads)
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
        self.reset_infos = [_row(info, i) for i in range(self.num_envs)]
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
                # (the top level of a finished reactor's info is its reset's, SameStep)
                self.reset_infos[i] = _row(info, i)
            infos.append(d)
        return obs, rew.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    # ------------------------------------------------------------------ attributes
    # SB3's DummyVecEnv looks attributes and methods up on each env; here each reactor is a
    # Reactor view (below) of the batch.
    def _targets(self, indices):
        return list(self._get_indices(indices))

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        """``attr_name`` of each reactor in ``indices`` (see :class:`Reactor`), looked up as
        DummyVecEnv looks it up on each env (``get_wrapper_attr``)."""
        return [self._reactors[i].get_wrapper_attr(attr_name) for i in self._targets(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        """Set ``attr_name`` on each reactor in ``indices``. A setting of the whole batch
        (an attribute of the vector env, e.g. ``render_mode``, ``threads``) must be set for
        every reactor at once (``ValueError`` otherwise); any other name is kept per reactor,
        as DummyVecEnv keeps it on each env."""
        self._set(self._targets(indices), attr_name, value)

    def _set(self, targets: list, attr_name: str, value: Any) -> None:
        if _is_batch_setting(self.venv, attr_name):
            if sorted(set(targets)) != list(range(self.num_envs)):
                raise ValueError(
                    f"attr_name: {attr_name!r} is one setting of the whole batch of reactors; "
                    f"set it for all of them (indices=None), got indices {targets}")
            setattr(self.venv, attr_name, value)
            if attr_name == "render_mode":
                self.render_mode = value
            return
        for i in targets:
            setattr(self._reactors[i], attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs):
        """Call ``method_name`` of each reactor in ``indices`` (see :class:`Reactor`), looked
        up as DummyVecEnv looks it up on each env (``get_wrapper_attr``).
        ``"set_wrapper_attr"`` follows :meth:`set_attr`'s rule (a setting of the whole batch
        for every reactor at once) and returns one ``True`` per reactor set, as gymnasium's
        does."""
        targets = self._targets(indices)
        if method_name == "set_wrapper_attr":
            return self._set_wrapper_attr(targets, *method_args, **method_kwargs)
        return [self._reactors[i].get_wrapper_attr(method_name)(*method_args, **method_kwargs)
                for i in targets]

    def _set_wrapper_attr(self, targets: list, name: str, value: Any, *,
                          force: bool = True) -> list[bool]:
        # gymnasium's Env.set_wrapper_attr: without force, only where the name exists
        done = [force or self._reactors[i].has_wrapper_attr(name) for i in targets]
        self._set([i for i, d in zip(targets, done) if d], name, value)
        return done

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._targets(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.venv.render_mode != "rgb_array":
            return [None] * self.num_envs
        return list(self.venv.render())


class Reactor:
    """Reactor ``index`` of a :class:`~discgym.vector.DiscReactorVectorEnv`, with the
    attributes and methods of a lone :class:`~discgym.env.DiscReactorEnv` that
    ``get_attr``, ``set_attr`` and ``env_method`` of the SB3 adapter reach:
    ``simulation`` (its :class:`~discgym.Simulation`), ``np_random`` (the generator its
    resets draw from), ``observation_space`` and ``action_space`` (one reactor's),
    ``render()`` (its frame, in render mode "rgb_array"), ``unwrapped`` (itself), and
    gymnasium's ``get_wrapper_attr``, ``has_wrapper_attr`` and ``set_wrapper_attr`` (what
    ``DummyVecEnv`` calls on each env); any other name is the batch's (``config``,
    ``render_mode``, ``metadata``, ``observation_names``, ...), the same for every reactor,
    unless set on this reactor. A setting of the batch (a name the vector env has) is not
    set on one reactor (``ValueError``: ``set_attr`` of the adapter sets it for all), nor
    are the names above; ``step``, ``reset`` and ``close`` are the batch's only (the
    reactors step, reset and close together)."""

    def __init__(self, venv: DiscReactorVectorEnv, index: int):
        self.__dict__["_venv"] = venv
        self.__dict__["index"] = index

    @property
    def simulation(self):
        return self._venv.simulations[self.index]

    @property
    def np_random(self):
        return self._venv.core.np_randoms[self.index]

    @property
    def observation_space(self):
        return self._venv.single_observation_space

    @property
    def action_space(self):
        return self._venv.single_action_space

    @property
    def unwrapped(self):
        return self

    def render(self):
        venv = self._venv
        if venv.render_mode is None:
            return venv.render()  # (warns, returns None)
        from .render import render_frame

        return render_frame(self.simulation, size=venv.render_size)

    # gymnasium's Env methods, which DummyVecEnv's get_attr and env_method go through
    def get_wrapper_attr(self, name: str) -> Any:
        """``getattr(self, name)``, as ``gymnasium.Env.get_wrapper_attr``."""
        return getattr(self, name)

    def has_wrapper_attr(self, name: str) -> bool:
        """``hasattr(self, name)``, as ``gymnasium.Env.has_wrapper_attr``."""
        return hasattr(self, name)

    def set_wrapper_attr(self, name: str, value: Any, *, force: bool = True) -> bool:
        """As ``gymnasium.Env.set_wrapper_attr``: set ``name`` on this reactor (if it exists,
        or with ``force``) and return whether it was set."""
        if force or hasattr(self, name):
            setattr(self, name, value)
            return True
        return False

    def __getattr__(self, name: str):
        # (reached only for names that are neither set on this reactor nor defined above)
        if name.startswith("_"):
            raise AttributeError(f"reactor {self.index} of the batch has no attribute "
                                 f"{name!r}")
        if name in _PER_BATCH_ONLY:
            raise AttributeError(f"reactor {self.index} of the batch has no attribute "
                                 f"{name!r}: the batch's reactors step, reset and close "
                                 f"together, and num_envs, the single spaces and "
                                 f"simulations are the batch's")
        return getattr(self._venv, name)

    def __setattr__(self, name: str, value) -> None:
        if name in _READ_ONLY:
            raise AttributeError(f"attr_name: {name!r} of a reactor cannot be set")
        if _is_batch_setting(self._venv, name):
            raise ValueError(f"attr_name: {name!r} is one setting of the whole batch of "
                             f"reactors; set it for all of them (the adapter's set_attr, "
                             f"indices=None), not on reactor {self.index}")
        self.__dict__[name] = value

    def __repr__(self) -> str:
        return f"Reactor({self.index} of {self._venv.num_envs})"


# batch-shaped attributes of the vector env, which a single reactor does not have
_PER_BATCH_ONLY = frozenset({"num_envs", "single_observation_space", "single_action_space",
                             "simulations", "step", "reset", "close"})
_READ_ONLY = frozenset({"simulation", "np_random", "observation_space", "action_space",
                        "unwrapped", "index", "render", "get_wrapper_attr",
                        "has_wrapper_attr", "set_wrapper_attr"})


def _is_batch_setting(venv: DiscReactorVectorEnv, name: str) -> bool:
    # (the batch-shaped names are no reactor's: set, they are kept per reactor, as any name
    # a reactor lacks, never on the batch, whose num_envs or step they would replace)
    return not name.startswith("_") and name not in _READ_ONLY \
        and name not in _PER_BATCH_ONLY and hasattr(venv, name)


def _row(info: dict, i: int) -> dict:
    """Reactor ``i``'s entries of the vector env's info (flat arrays), as Python numbers."""
    out = {}
    for k, v in info.items():
        if k.startswith("_") or k in ("final_obs", "final_info"):
            continue
        out[k] = v[i].item() if isinstance(v, np.ndarray) and v.dtype != object else v[i]
    return out


class SetpointHold(VecEnvWrapper):
    """The agent sets a kT setpoint, the wall and the feeds once every ``hold`` env steps
    (:class:`discgym.controllers.SetpointActions`: the heat action that reaches the setpoint
    is recomputed at every env step from the raw observation).

    One agent step is ``hold`` env steps: its reward is their sum, its observation the last
    one's (followed by the running mean of every env step's observation with ``average``;
    ``terminal_observation`` likewise), and ``infos`` are the last env step's. Put it under
    ``VecNormalize`` (it needs the raw observations) and over ``VecMonitor`` (whose episodes
    are then counted in env steps).
    With ``base`` (a controller class's dotted name) the agent corrects that controller:
    one instance per reactor, reset with the reactor's episode
    (:class:`~discgym.controllers.SetpointActions`).
    Every reactor's episode must end at the same env step, a multiple of ``hold`` (the
    suite's tasks never terminate and truncate after ``episode_steps``); an episode that
    ends inside a held block raises ``RuntimeError``, as the reactors already reset would
    otherwise run the rest of the block on the old decision. In the hyperparameter files
    (RL Zoo's ``vec_env_wrapper`` key)::

        vec_env_wrapper:
          - discgym.sb3.SetpointHold: {hold: 4}
    """

    def __init__(self, venv, hold: int = 4, kT_low: float = 0.8, kT_high: float = 3.2,
                 average: float | None = None, base: str | None = None, span: float = 1.5,
                 correct: str = "all"):
        from gymnasium import spaces

        from .controllers import SetpointActions

        law = SetpointActions(venv.get_attr("unwrapped", [0])[0], hold=hold, kT_low=kT_low,
                              kT_high=kT_high, average=average, base=base, span=span,
                              correct=correct)
        space = venv.observation_space
        low, high = law.observation_bounds(space.low, space.high)
        actions = venv.action_space if correct == "all" else spaces.Box(
            -1.0, 1.0, (law.action_dim,), dtype=venv.action_space.dtype)
        super().__init__(venv, observation_space=spaces.Box(low, high, dtype=space.dtype),
                         action_space=actions)
        self.actions_law = law
        self.hold = law.hold
        steps = venv.get_attr("config", [0])[0].episode_steps
        if steps % self.hold:
            raise ValueError(f"hold: {self.hold} does not divide the episode's "
                             f"{steps} env steps")
        self._obs = None
        self._mean = None
        self._actions = None
        self._bases = None

    @staticmethod
    def episode_policy(env, decide, hold: int = 4, kT_low: float = 0.8,
                       kT_high: float = 3.2, average: float | None = None,
                       base: str | None = None, span: float = 1.5, correct: str = "all"):
        """The same interface for one episode of one env (``agents/evaluate.py``): obs ->
        env action, asking ``decide`` (what the agent observes -> agent action) every
        ``hold`` steps."""
        from .controllers import SetpointActions

        return SetpointActions(env, hold=hold, kT_low=kT_low, kT_high=kT_high,
                               average=average, base=base, span=span,
                               correct=correct).policy(decide)

    def reset(self) -> np.ndarray:
        self._obs = self.venv.reset()
        law = self.actions_law
        self._bases = law.new_bases(self.num_envs)
        self._mean = law.update_mean(None, self._obs) if law.average is not None else None
        return law.agent_obs(self._obs, self._mean)

    def step_async(self, actions: np.ndarray) -> None:
        a = np.asarray(actions)
        if a.shape != (self.num_envs,) + self.action_space.shape:
            raise ValueError(f"actions: expected shape "
                             f"{(self.num_envs,) + self.action_space.shape}, got {a.shape}")
        self._actions = a

    def step_wait(self):
        law = self.actions_law
        total = np.zeros(self.num_envs, dtype=np.float32)
        for k in range(self.hold):
            self.venv.step_async(law.env_actions(self._actions, self._obs, self._bases))
            obs, rewards, dones, infos = self.venv.step_wait()
            total += rewards
            self._obs = obs
            if dones.any():
                if not dones.all() or k != self.hold - 1:
                    raise RuntimeError(
                        f"SetpointHold: reactors {np.flatnonzero(dones).tolist()} ended their "
                        f"episode at env step {k + 1} of a held block of {self.hold}: the "
                        f"episodes must end together, at a multiple of hold")
                if self._bases is not None:
                    for c in self._bases:
                        c.reset()
                if law.average is not None:
                    # the last observation of each episode, as the agent would have seen it
                    for i, info in enumerate(infos):
                        last = info["terminal_observation"]
                        info["terminal_observation"] = law.agent_obs(
                            last, law.update_mean(self._mean[i], last))
                    self._mean = law.update_mean(None, obs)
                break
            if law.average is not None:
                self._mean = law.update_mean(self._mean, obs)
        return law.agent_obs(obs, self._mean), total, dones, infos
