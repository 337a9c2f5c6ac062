"""The batched ``DiscReactor-v0``: many reactors stepped in one compiled, parallel call.

``gymnasium.make_vec("DiscReactor-v0", num_envs=64)`` builds a :class:`DiscReactorVectorEnv`
(it is the registered ``vector_entry_point``). Each reactor follows, bit for bit, the
trajectory of a lone :class:`~discgym.env.DiscReactorEnv` reset with the same seed and given
the same actions (``tests/test_vector.py`` checks it; ``tests/test_env_event.py`` with
``integrator="event"``): both share the action, observation and reward code of
:mod:`discgym.env`, and the kernel of each reactor is the same
(:func:`discgym.kernels.step.advance`, or :func:`discgym.kernels.event_driven.run_steps`).

How it works: the reactors are the rows of one :class:`~discgym.state.ReactorState`
(padded arrays ``(R, C, 2)`` / ``(R, C)`` with a capacity ``C`` that a step can never
outgrow: every reactor's contents at their largest plus its feed budgets, split by every
reaction they could undergo), and one :class:`~discgym.core.EpisodeCore` resets, steps and
rewards them: one compiled call, :func:`discgym.kernels.batch.env_step_parallel` (a
``prange`` over reactors), applies every reactor's action (heat, wall, injection), advances
it and observes it, in place. It runs for each reactor the same
:func:`~discgym.kernels.batch.reactor_step` as the single env, which is the same core with one
reactor; the controls are the kernels of :mod:`discgym.kernels.controls` that
``Simulation.scale_temperature``, ``resize`` and ``inject`` call (``tests/test_env.py`` checks
the two paths agree to the bit; the differences: heating stops at the speed limit where
``scale_temperature`` refuses, and a refused wall move or injection has drawn from the
generator). ``env.simulations[r]`` is a :class:`~discgym.Simulation` handle on row r: its
controls and ``set_state`` act on the batch's own arrays between steps, and the next step
re-checks that reactor (bounds that ``resize`` or ``set_state`` replaced give the wall its
size, ``ReactorConfig.read_size``; discs beyond the capacity plan grow every row; bounds the
wall cannot make, or another integrator, raise ``RuntimeError`` before any reactor is
stepped). A reset builds a new handle: do not keep one across it.

``configs`` gives each reactor a configuration of its own (a sequence of R mappings of
:data:`~discgym.config.ROW_ARGUMENTS`, or a callable drawing one per episode): see
``docs/env.md``, "A configuration per reactor".

Autoreset: ``autoreset_mode`` ("NextStep", the Gymnasium default; "SameStep", with
``info["final_obs"]`` and ``info["final_info"]``; or "Disabled", then reset finished reactors
with ``reset(options={"reset_mask": mask})``); declared in ``metadata["autoreset_mode"]``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from gymnasium import error, logger, spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .arguments import check_keywords, check_memory, check_render_mode, whole, with_config
from .config import DEFAULTS, MAX_RENDER_SIZE, SLOT_BYTES_BATCH, ReactorConfig
from .core import EpisodeCore, as_actions
from .kernels import helper as compile_helper
from .kernels.structs import FLOAT

__all__ = ["DiscReactorVectorEnv"]



class DiscReactorVectorEnv(VectorEnv):
    """``num_envs`` reactors of ``DiscReactor-v0``, advanced together in one compiled call
    parallel over reactors (on numba's threads; ``threads`` sets how many, default: numba's
    current setting).

    Arguments: the keyword arguments of :class:`~discgym.env.DiscReactorEnv`, with the same
    ranges (its docstring, section Arguments; ``render_mode`` "rgb_array" or None only,
    ``render_size`` default 200), plus

    - ``num_envs``: whole, >= 1 (numpy integers accepted, bools refused); the reactors' state
      (``num_envs`` x capacity x 64 bytes) must fit in the machine's memory;
    - ``max_episode_steps``: None or whole, >= 1 (``gymnasium.make_vec`` passes the
      registration's 100): caps the episode length like the ``TimeLimit`` wrapper of
      ``gymnasium.make`` does; it is the episode length if ``episode_steps`` is not given
      (then with the range of ``episode_steps``);
    - ``autoreset_mode``: an ``AutoresetMode`` or its value ("NextStep", "SameStep",
      "Disabled");
    - ``threads``: None (numba's current setting) or whole, >= 1; more than numba's
      ``NUMBA_NUM_THREADS`` uses all of them. It is the most a step runs on: each step runs
      on the count measured fastest (fewer when other processes hold cores:
      :mod:`discgym.threads`; the same bits whatever the count);
    - ``configs``: None, a sequence of ``num_envs`` mappings (reactor r's own settings,
      keys of :data:`~discgym.config.ROW_ARGUMENTS`, updating the arguments above: reactor r
      is then the single env made with both), or a callable ``configs(rng) -> mapping``
      called at each reset of each reactor with a generator of that reactor's own (a
      configuration per episode). Each checked as the env's own argument, naming
      ``configs[r]``; a key that cannot differ between reactors (the scene, ``feed``,
      ``product``, the observation's layout, ...) is refused.

    They may also come as one mapping, the only positional argument (RLlib's
    ``EnvContext``), alone or with keywords. Each is checked at construction (``TypeError``
    for a wrong type, ``ValueError`` out of range, naming it); an unknown keyword raises
    ``TypeError: DiscReactorVectorEnv.__init__() got an unexpected keyword argument 'x'``.

    ``step(actions)`` takes exactly (``num_envs``, 2 + F): an array, or a list of
    ``num_envs`` per-reactor actions, of real numbers (bool, integer or float dtypes). Any
    other shape ((2 + F, ``num_envs``), flat, (1, ``num_envs`` (2 + F)), ...) raises
    ``ValueError`` naming the expected and the received shape, any other dtype ``TypeError``,
    before any reactor is stepped or reset (never reshaped).

    ``reset(seed=s)`` seeds reactor i with ``s + i`` (a list gives one seed per reactor).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10,
                "autoreset_mode": AutoresetMode.NEXT_STEP}
    #: the keyword arguments of a reactor and their defaults (a task sets its own)
    defaults = DEFAULTS

    def __init__(self, config: Mapping | None = None, /, **kwargs):
        kwargs = with_config(f"{type(self).__name__}.__init__", config, kwargs)
        self._construct(**kwargs)

    def _construct(self, num_envs: int = 1, *, max_episode_steps: int | None = None,
                 autoreset_mode=AutoresetMode.NEXT_STEP, threads: int | None = None,
                 render_mode: str | None = None, render_size: int = 200, configs=None,
                 **kwargs):
        check_keywords(f"{type(self).__name__}.__init__", kwargs, self.defaults)
        R = whole(num_envs, "num_envs", 1)
        if max_episode_steps is not None:
            max_episode_steps = whole(max_episode_steps, "max_episode_steps", 1)
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.render_size = whole(render_size, "render_size", 1, MAX_RENDER_SIZE)
        self.threads = None if threads is None else whole(threads, "threads", 1)
        if max_episode_steps is not None and "episode_steps" not in kwargs:
            kwargs["episode_steps"] = max_episode_steps
            try:
                self.config = cfg = ReactorConfig.from_kwargs(self.defaults, **kwargs)
            except ValueError as e:
                if not str(e).startswith("episode_steps"):
                    raise
                raise ValueError(f"{e} (episode_steps is max_episode_steps here, "
                                 f"{max_episode_steps}, as it is not given)") from None
        else:
            self.config = cfg = ReactorConfig.from_kwargs(self.defaults, **kwargs)
        compile_helper.expect(f"env-{cfg.integrator}")
        self._kwargs = dict(kwargs)
        rows, self._draw = self._row_configs(configs, R, kwargs)
        low = np.min([c.obs_low for c in rows], axis=0) if rows else cfg.obs_low
        high = np.max([c.obs_high for c in rows], axis=0) if rows else cfg.obs_high
        cap = max([c.capacity for c in rows] + [cfg.capacity])
        check_memory(R * (cap * SLOT_BYTES_BATCH + 4096), "num_envs",
                      f"{R} reactors of capacity {cap} discs")
        self._max_episode_steps = max_episode_steps
        self.metadata = dict(self.metadata, autoreset_mode=self.autoreset_mode)
        self.render_mode = render_mode
        self.num_envs = R
        self.single_observation_space = spaces.Box(low.copy(), high.copy(), dtype=np.float32)
        self.single_action_space = cfg.action_space()
        self.observation_space = batch_space(self.single_observation_space, R)
        self.action_space = batch_space(self.single_action_space, R)
        self.observation_names = cfg.obs_names
        self.action_names = cfg.action_names

        # the episode core of R reactors: their state, episode rows and Simulation handles
        self.core = EpisodeCore(cfg, R, self.threads, rows or None, low, high)
        self._config_rngs: list = [None] * R  # (a callable's draws: its own generators)
        self._autoreset = np.zeros(R, dtype=bool)
        self._started = False

    def _row_configs(self, configs, R: int, kwargs: dict) -> tuple[list, object]:
        """The reactors' own configurations: ``(list of R, None)`` for a sequence of R
        mappings, ``([], configs)`` for a callable (drawn at each reset), ``([], None)``
        for None."""
        if configs is None:
            return [], None
        if callable(configs):
            return [], configs
        if isinstance(configs, (str, bytes, Mapping)) or not hasattr(configs, "__len__"):
            raise TypeError(f"configs: expected None, a sequence of {R} mappings (one per "
                            f"reactor) or a callable drawing one, got {type(configs).__name__}")
        if len(configs) != R:
            raise ValueError(f"configs: need one mapping per reactor ({R}), got "
                             f"{len(configs)}")
        return [self.config.row(self.defaults, kwargs, c, f"configs[{r}]")
                for r, c in enumerate(configs)], None

    @property
    def limit(self) -> np.ndarray:
        """(R,) each reactor's episode length: its ``episode_steps``, at most
        ``max_episode_steps``."""
        steps = self.core.episodes.episode_steps
        m = self._max_episode_steps
        return steps.copy() if m is None else np.minimum(steps, m)

    @property
    def simulations(self) -> list:
        """Each reactor's :class:`~discgym.Simulation` (None before the first reset): handles
        on rows of the env's own state, so that their controls act on the next step."""
        return self.core.simulations

    # ------------------------------------------------------------------ reset
    def reset(self, *, seed=None, options: dict | None = None):
        R = self.num_envs
        if seed is None:
            seeds = [None] * R
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + r for r in range(R)]
        else:
            seeds = list(seed)
            if len(seeds) != R:
                raise ValueError(f"reset(seed): need {R} seeds, got {len(seeds)}")
        if seed is not None and isinstance(seed, (int, np.integer)):
            self._np_random, self._np_random_seed = seeding.np_random(int(seed))
        mask = np.ones(R, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
            if mask.shape != (R,):
                raise ValueError(f"reset(options['reset_mask']): need shape ({R},), got "
                                 f"{mask.shape}")
            if not self._started and not mask.all():
                raise error.ResetNeeded("the first reset must reset every reactor")
        core = self.core
        idx = np.flatnonzero(mask).tolist()
        for r in idx:
            if seeds[r] is not None or core.np_randoms[r] is None:
                core.np_randoms[r], _ = seeding.np_random(seeds[r])
                # (a callable's own generator: the reactor's draws stay its single env's)
                self._config_rngs[r] = np.random.default_rng(
                    None if seeds[r] is None else [0xC0F16, seeds[r]])
        self._reset_rows(idx)
        self._started = True
        self._autoreset[idx] = False
        return core.episodes.obs.copy(), self._reset_infos(mask)

    def _reset_infos(self, mask: np.ndarray) -> dict:
        """The info of a reset: the keys of a step's info, for the reactors in ``mask``
        (Gymnasium's ``_key`` masks); what only a step does is 0 / False."""
        R = self.num_envs
        zero = np.zeros(R, dtype=FLOAT)
        none = np.zeros((R, len(self.config.feed)), dtype=np.int64)
        return self._infos(zero, zero, zero, zero, none, none, np.zeros(R, dtype=bool),
                           np.zeros(R, dtype=np.int64), mask)

    # ------------------------------------------------------------------ step
    def step(self, actions):
        if not self._started:
            raise error.ResetNeeded("call reset() before step()")
        cfg = self.config
        R = self.num_envs
        act = as_actions(cfg, actions, R)
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            resetting = self._autoreset.copy()
        else:
            if self._autoreset.any():
                if self.autoreset_mode == AutoresetMode.DISABLED:
                    raise error.ResetNeeded(
                        f"reactors {np.flatnonzero(self._autoreset).tolist()} finished; reset "
                        "them with reset(options={'reset_mask': mask}) (autoreset disabled)")
            resetting = np.zeros(R, dtype=bool)
        active = ~resetting
        core = self.core
        # the configurations the resets of this step will draw, drawn (and checked) before
        # anything is stepped: SameStep resets the reactors that reach their limit now
        ending = resetting if self.autoreset_mode != AutoresetMode.SAME_STEP else \
            active & (core.episodes.steps + 1 >= self.limit)
        drawn = self._draw_configs(np.flatnonzero(ending).tolist())
        out = core.step(active, act)
        if resetting.any():  # (their rows of the outputs are zeros)
            self._reset_rows(np.flatnonzero(resetting).tolist(), drawn)
        terminated = np.zeros(R, dtype=bool)
        truncated = active & (core.episodes.steps >= self.limit)
        # every reactor reports, as in Gymnasium's SyncVectorEnv: a reactor reset by this
        # step (NextStep) its reset's info (the step-only entries 0 / False)
        everyone = np.ones(R, dtype=bool)
        infos = self._infos(out.gain, out.cost_heat, out.cost_feed, out.heat, out.injected,
                            out.refused, out.blocked, out.invalid, everyone)
        obs = core.episodes.obs.copy()
        done = terminated | truncated
        if self.autoreset_mode == AutoresetMode.SAME_STEP and done.any():
            final_obs = np.full(R, None, dtype=object)
            for r in np.flatnonzero(done).tolist():
                final_obs[r] = obs[r].copy()
            final_info = _masked({k: v for k, v in infos.items() if not k.startswith("_")},
                                 done)
            infos["final_obs"] = final_obs
            infos["_final_obs"] = done.copy()
            infos["final_info"] = final_info
            infos["_final_info"] = done.copy()
            self._reset_rows(np.flatnonzero(done).tolist(), drawn)
            obs = core.episodes.obs.copy()
            # the finished reactors report their reset's info (as SyncVectorEnv does)
            fresh = self._reset_infos(everyone)
            for k, v in fresh.items():
                if not k.startswith("_"):
                    infos[k][done] = v[done]
            done = np.zeros(R, dtype=bool)
        self._autoreset = done
        return obs, out.reward, terminated, truncated, infos

    def _draw_configs(self, rows: list) -> dict:
        """``{r: configuration}`` for the next episode of each reactor of ``rows`` when
        ``configs`` is a callable (else empty), every one checked before any is used (a
        refused one raises naming its reactor, and nothing has changed)."""
        if self._draw is None:
            return {}
        out = {}
        for r in rows:
            who = f"configs(...) for reactor {r}"
            cfg = self.config.row(self.defaults, self._kwargs, self._draw(self._config_rngs[r]),
                                  who)
            self.config.check_batch(cfg, self.core.low, self.core.high, who)
            out[r] = cfg
        return out

    def _reset_rows(self, rows: list, drawn: dict | None = None) -> None:
        """A new episode in each reactor of ``rows``; with a callable ``configs``, in the
        configuration ``drawn[r]`` (drawn now if not given)."""
        if self._draw is not None:
            missing = [r for r in rows if drawn is None or r not in drawn]
            drawn = {**(drawn or {}), **self._draw_configs(missing)}
            for r in rows:
                self.core.set_config(r, drawn[r], f"configs(...) for reactor {r}")
        self.core.reset(rows)

    def _infos(self, gain, cost_heat, cost_feed, heat, injected, refused, blocked, invalid,
               active) -> dict:
        """The info as arrays (R,) with Gymnasium's ``_key`` masks (``active``: False for the
        reactors reset by this step, or not reset by ``reset``): the keys of the single env's
        info (:attr:`~discgym.config.ReactorConfig.info_types`), each an array of its type."""
        cfg, ep = self.config, self.core.episodes
        counts = ep.stats[:, :cfg.n_species].astype(np.int64)
        product = counts[:, cfg.product]
        infos = cfg.info_values(
            list(counts.T), product, product / ep.n_ref, gain, cost_heat, cost_feed, heat,
            ep.temperature.copy(), ep.size.copy(), list(injected.T), list(refused.T),
            blocked, invalid.astype(np.int64), self.core.state.time(), ep.n_ref.copy(),
            batch=True)
        return _masked(infos, active)

    # ------------------------------------------------------------------ misc
    def render(self):
        if self.render_mode is None:
            logger.warn("render() called without a render_mode; pass render_mode='rgb_array'")
            return None
        from .render import render_frame

        return tuple(render_frame(s, size=self.render_size) for s in self.simulations)

    def close_extras(self, **kwargs):
        pass


def _autoreset_mode(mode) -> AutoresetMode:
    if isinstance(mode, AutoresetMode):
        return mode
    modes = [m.value for m in AutoresetMode]
    if not isinstance(mode, str):
        raise TypeError(f"autoreset_mode: expected an AutoresetMode or one of {modes}, got "
                        f"{mode!r}")
    if mode not in modes:
        raise ValueError(f"autoreset_mode: expected an AutoresetMode or one of {modes}, got "
                         f"{mode!r}")
    return AutoresetMode(mode)


def _masked(infos: dict, mask: np.ndarray) -> dict:
    """Add Gymnasium's ``_key`` masks (``mask``) to every entry (fresh arrays)."""
    out = {}
    for k, v in infos.items():
        out[k] = v.copy()
        out[f"_{k}"] = mask.copy()
    return out
