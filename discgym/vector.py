"""The batched ``DiscReactor-v0``: many reactors stepped in one compiled, parallel call.

``gymnasium.make_vec("DiscReactor-v0", num_envs=64)`` builds a :class:`DiscReactorVectorEnv`
(it is the registered ``vector_entry_point``). Each reactor follows, bit for bit, the
trajectory of a lone :class:`~discgym.env.DiscReactorEnv` reset with the same seed and given
the same actions (``tests/test_vector.py`` checks it; ``tests/test_env_event.py`` with
``integrator="event"``): both share the action, observation and reward code of
:mod:`discgym.env`, and the kernel of each reactor is the same
(:func:`discgym.kernels.step.advance`, or :func:`discgym.kernels.event_driven.run_steps`).

How it works: the state of all reactors lives in padded arrays ``(R, C, 2)`` / ``(R, C)``
with a capacity ``C = capacity_for_discs(max_discs)`` that can never run out (``max_discs``:
the initial contents at their largest plus every feed budget), so one compiled call,
:func:`discgym.kernels.batch.env_step_parallel` (a ``prange`` over reactors), applies every
reactor's action (heat, wall, injection), advances it and observes it, in place. It runs
for each reactor the same :func:`~discgym.kernels.batch.reactor_step` as the single env,
whose controls are the kernels of :mod:`discgym.kernels.controls` that
``Simulation.scale_temperature``, ``resize`` and ``inject`` call (``tests/test_env.py`` checks
the two paths agree to the bit; the differences: heating stops at the speed limit where
``scale_temperature`` refuses, and a refused wall move or injection has drawn from the
generator). Each reactor keeps a real ``Simulation``, which moves its state arrays and
counters into row r of those arrays (``Simulation.move_into``) and, after each step, books
its disc count, step count, clocks, energy input and bounds (``Simulation.book_env_step``).
``env.simulations[r]`` is reactor r's ``Simulation``: its controls and ``set_state`` may be
used between steps (the next step reads the disc count, clocks and bounds back: bounds that
``resize`` or ``set_state`` replaced give the wall its size, which the ``size`` observation and
the next wall move start from, ``ReactorConfig.read_size``, as in the single env); more discs
than the capacity plan holds, state arrays replaced, or bounds the wall cannot make (another
kind, height, origin or centre, or a size outside ``size_range``) raise ``RuntimeError`` at the
next step, before any reactor is stepped. Do not keep it across a reset, which builds a new
one.

Autoreset: ``autoreset_mode`` ("NextStep", the Gymnasium default; "SameStep", with
``info["final_obs"]`` and ``info["final_info"]``; or "Disabled", then reset finished reactors
with ``reset(options={"reset_mask": mask})``); declared in ``metadata["autoreset_mode"]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial

import numba
import numpy as np
from gymnasium import error, logger
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .arguments import check_keywords, check_memory, check_render_mode, whole, with_config
from .config import DEFAULTS, MAX_RENDER_SIZE, SLOT_BYTES_BATCH, ReactorConfig
from .core import as_actions, check_status, integrator_changed, observe
from .kernels import helper as compile_helper
from .kernels import step as _step
from .kernels.batch import (
    O_BLOCKED,
    O_ENERGY_HEAT,
    O_HEAT,
    O_INVALID,
    O_STATUS,
    balance,
    env_step,
    env_step_parallel,
)
from .kernels.structs import COUNT, FLOAT, INDEX, Episodes, Reactors, generator_list
from .threads import ThreadChooser, numba_threads

__all__ = ["DiscReactorVectorEnv"]

# the counters of events (collisions, wall hits, reactive collisions): each costs about as
# much as 4 disc-substeps
_EVENTS = [_step.IC_COLLISIONS, _step.IC_WALL_HITS, _step.IC_REACTIVE]


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
      :mod:`discgym.threads`; the same bits whatever the count).

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
                 render_mode: str | None = None, render_size: int = 200, **kwargs):
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
        check_memory(R * (cfg.capacity * SLOT_BYTES_BATCH + 4096), "num_envs",
                      f"{R} reactors of capacity {cfg.capacity} discs")
        self.limit = cfg.episode_steps if max_episode_steps is None else \
            min(max_episode_steps, cfg.episode_steps)
        self.metadata = dict(self.metadata, autoreset_mode=self.autoreset_mode)
        self.render_mode = render_mode
        self.num_envs = R
        self.single_observation_space = cfg.observation_space()
        self.single_action_space = cfg.action_space()
        self.observation_space = batch_space(self.single_observation_space, R)
        self.action_space = batch_space(self.single_action_space, R)
        self.observation_names = cfg.obs_names
        self.action_names = cfg.action_names

        C = cfg.capacity
        S = cfg.n_species
        F = len(cfg.feed)
        self._pos = np.zeros((R, C, 2), dtype=FLOAT)
        self._vel = np.zeros((R, C, 2), dtype=FLOAT)
        self._species = np.full((R, C), -1, dtype=INDEX)
        self._internal_energy = np.zeros((R, C), dtype=FLOAT)
        self._ids = np.zeros((R, C), dtype=COUNT)
        self._idctr = np.zeros((R, 1), dtype=COUNT)
        self._n = np.zeros(R, dtype=np.int64)
        self._ksteps = np.zeros(R, dtype=np.int64)  # kernel steps taken (Simulation._steps)
        self._bounds_kind = np.zeros(R, dtype=np.int64)
        self._bounds_params = np.zeros((R, 4), dtype=FLOAT)
        self._icnt = np.zeros((R, _step.N_ICOUNTERS), dtype=COUNT)
        self._fsum = np.zeros((R, _step.N_FSUMS), dtype=FLOAT)
        self._ch_count = np.zeros((R, len(cfg.compiled.labels)), dtype=COUNT)
        self._outflow = np.zeros((R, S), dtype=COUNT)
        self._walls = np.zeros((R, 4), dtype=FLOAT)
        self._cost = np.ones(R, dtype=FLOAT)  # the cost of each reactor's next step (estimate)
        self._chooser = ThreadChooser()  # (speed only: the bits do not depend on it)
        self._order = np.zeros(R, dtype=np.int64)
        self._starts = np.zeros(numba.config.NUMBA_NUM_THREADS + 1, dtype=np.int64)
        self._fout = np.zeros((R, 2 + F), dtype=FLOAT)
        self._iout = np.zeros((R, 3 + 2 * F), dtype=np.int64)
        self._stats = np.zeros((R, 3 * S + 1), dtype=FLOAT)
        # one persistent generator per reactor, reseeded at each reset (see env.new_simulation)
        self._gens = [np.random.Generator(np.random.PCG64(0)) for _ in range(R)]
        self._np_randoms: list = [None] * R
        self.simulations: list = [None] * R
        # per-reactor episode state
        self._steps = np.zeros(R, dtype=np.int64)
        self._size = np.ones(R, dtype=FLOAT)
        self._bounds_seen = [-1] * R  # each Simulation's bounds serial read back (_sync)
        self._feed_left = np.zeros((R, F), dtype=np.int64)
        self._n_init = np.ones(R, dtype=FLOAT)
        self._n_ref = np.ones(R, dtype=FLOAT)
        self._product = np.zeros(R, dtype=FLOAT)
        self._autoreset = np.zeros(R, dtype=bool)
        self._obs = np.zeros((R, len(cfg.obs_names)), dtype=np.float32)
        self._temps = np.zeros(R, dtype=FLOAT)
        self._kin = np.zeros(R, dtype=FLOAT)
        # each reactor's kinetics, last step's reactions and outflow, inlet temperatures
        K = len(cfg.compiled.labels)
        self._sp_form = np.zeros((R, S), dtype=FLOAT)
        self._ch_rate = np.zeros((R, K), dtype=FLOAT)
        self._ch_energy = np.zeros((R, K), dtype=FLOAT)
        self._ch_last = np.zeros((R, K), dtype=np.int64)
        self._out_last = np.zeros((R, S), dtype=np.int64)
        self._feed_kT = np.full(R, np.nan, dtype=FLOAT)
        self._feed_kT_next = np.full(R, np.nan, dtype=FLOAT)
        self._feed_switch = np.full(R, -1, dtype=np.int64)
        self._pending = np.zeros((R, 2), dtype=FLOAT)
        self._started = False
        self._link()

    def _link(self) -> None:
        """The objects that only refer to the batch's arrays: the per-reactor row views, the
        kernels' structs and the typed list of generators (a numba object that does not
        pickle); rebuilt after unpickling."""
        R = self.num_envs
        self._rngs = generator_list(self._gens)
        self._views = [(self._pos[r], self._vel[r], self._species[r], self._internal_energy[r],
                        self._ids[r], self._idctr[r]) for r in range(R)]
        self._rx = Reactors(self._pos, self._vel, self._species, self._internal_energy,
                            self._ids, self._idctr, self._n, self._ksteps, self._bounds_kind,
                            self._bounds_params, self._icnt, self._fsum, self._ch_count,
                            self._outflow, self._walls)
        self._ep = Episodes(self._size, self._feed_left, self._steps, self._n_init,
                            self._n_ref, self._temps, self._kin, self._stats, self._obs,
                            self._fout, self._iout, self._sp_form, self._ch_rate,
                            self._ch_energy, self._ch_last, self._out_last, self._feed_kT,
                            self._feed_kT_next, self._feed_switch, self._pending)
        # (the structs as plain tuples of their fields: see kernels.batch.env_step)
        cfg = self.config
        cs = cfg.compiled
        self._fields = (tuple(self._rx), tuple(self._ep),
                        (tuple(cfg.tables), cs.params, cs.flags), tuple(cfg.consts))

    # ------------------------------------------------------------------ pickle, deepcopy
    def __getstate__(self):
        d = self.__dict__.copy()
        for k in ("_rngs", "_views", "_rx", "_ep", "_fields"):
            del d[k]
        # each Simulation's state lives in row r of the batch's arrays (views, which pickle
        # as copies) and its generator is self._gens[r]: rebuilt from these in __setstate__
        d["simulations"] = [None if s is None else s.__getstate__() for s in self.simulations]
        return d

    def __setstate__(self, d):
        from .simulation import Simulation

        self.__dict__.update(d)
        self._link()
        sims = []
        for r, st in enumerate(d["simulations"]):
            if st is None:
                sims.append(None)
                continue
            sim = Simulation.__new__(Simulation)
            sim.__setstate__(st)
            sim._set_rng(self._gens[r])  # (the same state: pickled together)
            sim.move_into(*self._views[r], self._icnt[r], self._fsum[r], self._ch_count[r],
                          self._outflow[r], self._walls[r])
            sims.append(sim)
        self.simulations = sims

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
        idx = np.flatnonzero(mask)
        for r in idx:
            if seeds[r] is not None or self._np_randoms[r] is None:
                self._np_randoms[r], _ = seeding.np_random(seeds[r])
            self._reset_one(r)
        self._started = True
        self._autoreset[idx] = False
        self._observe_all()
        self._product[idx] = self._stats[idx, self.config.product]
        return self._obs.copy(), self._reset_infos(mask)

    def _reset_infos(self, mask: np.ndarray) -> dict:
        """The info of a reset: the keys of a step's info, for the reactors in ``mask``
        (Gymnasium's ``_key`` masks); what only a step does is 0 / False."""
        R = self.num_envs
        zero = np.zeros(R, dtype=FLOAT)
        none = np.zeros((R, len(self.config.feed)), dtype=np.int64)
        return self._infos(zero, zero, zero, zero, none, none, np.zeros(R, dtype=bool),
                           np.zeros(R, dtype=np.int64), mask)

    def _reset_one(self, r: int) -> None:
        cfg = self.config
        sim = cfg.new_simulation(self._np_randoms[r], generator=self._gens[r])
        n = len(sim)
        if n > cfg.max_discs:  # cannot happen: max_discs bounds the drawn contents
            raise RuntimeError(f"reactor {r}: {n} discs exceed the capacity plan")
        sim.move_into(*self._views[r], self._icnt[r], self._fsum[r], self._ch_count[r],
                      self._outflow[r], self._walls[r])
        self._bounds_seen[r] = sim.export_scalars(self._rx, r)
        self._cost[r] = n * cfg.steps_per_action  # (no history yet: one substep a step)
        self.simulations[r] = sim
        cfg.reset_row(self._ep, r, sim, self._np_randoms[r])

    def _observe_all(self) -> None:
        observe(self.config, self._rx, self._ep)

    # ------------------------------------------------------------------ step
    def step(self, actions):
        if not self._started:
            raise error.ResetNeeded("call reset() before step()")
        cfg = self.config
        R = self.num_envs
        act = as_actions(cfg, actions, R)
        F = len(cfg.feed)
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
        self._advance(active, act)
        fout, iout = self._fout, self._iout
        heat = fout[:, O_HEAT].copy()
        injected = iout[:, 3:3 + F].copy()
        refused = iout[:, 3 + F:].copy()
        blocked = iout[:, O_BLOCKED].astype(bool)
        invalid = iout[:, O_INVALID].copy()
        any_reset = bool(resetting.any())
        if any_reset:  # (their rows of the outputs are from an earlier step)
            heat[resetting] = 0.0
            injected[resetting] = 0
            refused[resetting] = 0
            blocked[resetting] = False
            invalid[resetting] = 0
            for r in np.flatnonzero(resetting).tolist():
                self._reset_one(r)
            self._observe_all()
        product = self._stats[:, cfg.product].copy()
        gain, cost_heat, cost_feed, rew = cfg.reward_terms(
            product, self._product, self._out_last[:, cfg.product].astype(FLOAT), heat,
            injected.sum(axis=1).astype(FLOAT), self._n_ref)
        if any_reset:
            rew[resetting] = 0.0
            gain[resetting] = 0.0
        self._product = product
        terminated = np.zeros(R, dtype=bool)
        truncated = active & (self._steps >= self.limit)
        # every reactor reports, as in Gymnasium's SyncVectorEnv: a reactor reset by this
        # step (NextStep) its reset's info (the step-only entries 0 / False)
        everyone = np.ones(R, dtype=bool)
        infos = self._infos(gain, cost_heat, cost_feed, heat, injected, refused, blocked,
                            invalid, everyone)
        obs = self._obs.copy()
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
            for r in np.flatnonzero(done).tolist():
                self._reset_one(r)
            self._observe_all()
            obs = self._obs.copy()
            self._product = self._stats[:, cfg.product].copy()
            # the finished reactors report their reset's info (as SyncVectorEnv does)
            fresh = self._reset_infos(everyone)
            for k, v in fresh.items():
                if not k.startswith("_"):
                    infos[k][done] = v[done]
            done = np.zeros(R, dtype=bool)
        self._autoreset = done
        return obs, rew, terminated, truncated, infos

    def _infos(self, gain, cost_heat, cost_feed, heat, injected, refused, blocked, invalid,
               active) -> dict:
        """The info as arrays (R,) with Gymnasium's ``_key`` masks (``active``: False for the
        reactors reset by this step, or not reset by ``reset``): the keys of the single env's
        info (:attr:`~discgym.config.ReactorConfig.info_types`), each an array of its type."""
        cfg = self.config
        counts = self._stats[:, :cfg.n_species].astype(np.int64)
        product = counts[:, cfg.product]
        infos = cfg.info_values(
            list(counts.T), product, product / self._n_ref, gain, cost_heat, cost_feed, heat,
            self._temps.copy(), self._size.copy(), list(injected.T), list(refused.T),
            blocked, invalid.astype(np.int64),
            np.array([s.time for s in self.simulations], dtype=FLOAT), self._n_ref.copy(),
            batch=True)
        return _masked(infos, active)

    def _advance(self, active: np.ndarray, act: np.ndarray) -> None:
        """One compiled call: the actions ``act`` (R, A), the physics and the observation of
        every active reactor (:func:`discgym.kernels.batch.env_step`), in parallel over the
        reactors when more than one thread is asked for; then what ``Simulation.step`` and
        its controls book, for each reactor's ``Simulation``."""
        cfg = self.config
        idx = np.flatnonzero(active).tolist()
        self._sync(idx)
        size0 = self._size.copy()
        rx, ep, physics, consts = self._fields
        args = (rx, ep, physics, consts, self._rngs, active, act)
        sub0 = self._icnt[:, _step.IC_SUBSTEPS].copy()
        ev0 = self._icnt[:, _EVENTS].sum(axis=1)
        if len(idx) <= 1 or self.threads == 1:  # (a lone reactor runs on the calling thread)
            env_step(*args)
        else:
            most = numba.get_num_threads() if self.threads is None else \
                min(self.threads, numba.config.NUMBA_NUM_THREADS)

            def run(want: int) -> None:
                # one list of consecutive reactors per thread, of about equal cost (the last
                # step's work of each reactor: disc-substeps + 4 x events)
                balance(self._cost, active, want, self._order, self._starts[:want + 1])
                with numba_threads(want):
                    env_step_parallel(*args, self._order, self._starts[:want + 1])

            # (the thread count measured call by call, the work by the same estimate:
            # discgym.threads)
            work = float(self._cost[active].sum())
            self._chooser.timed(most, run, lambda: work)
        # the work of each reactor in this step, the estimate of its cost in the next
        cost = self._n * (self._icnt[:, _step.IC_SUBSTEPS] - sub0) + \
            4 * (self._icnt[:, _EVENTS].sum(axis=1) - ev0)
        self._cost[active] = cost[active]
        if self._iout[:, O_STATUS].any():
            check_status(cfg, self._iout, active)
        k = cfg.steps_per_action
        dt = cfg.scene.dt
        moved = self._size != size0
        n, ks, fo = self._n.tolist(), self._ksteps.tolist(), self._fout.tolist()
        for r in idx:
            bounds = (partial(cfg.bounds_of, float(self._size[r])), self._bounds_params[r]) \
                if moved[r] else None
            self.simulations[r].book_env_step(n[r], ks[r], k, dt, fo[r][O_ENERGY_HEAT:],
                                              bounds)

    def _sync(self, idx: list) -> None:
        """Read what a user may have changed through ``env.simulations[r]`` since the last
        step (its disc count, clocks, bounds: the wall's size, ``ReactorConfig.read_size``)
        into the batch; refuse what the batch cannot follow (state arrays replaced, more discs
        than the capacity plan holds, bounds that are none of the wall's) with
        ``RuntimeError`` rather than lose it."""
        cfg = self.config
        for r in idx:
            sim = self.simulations[r]
            v = self._views[r]
            a = sim.kernel_arrays()
            if any(a[k] is not v[k] for k in range(6)):
                raise RuntimeError(
                    f"reactor {r}: its Simulation's state arrays were replaced from outside "
                    "(e.g. an injection beyond the batch's capacity); the vector env "
                    "keeps every reactor in its own arrays and cannot follow. Change a reactor "
                    "through its controls (inject, resize, scale_temperature) only, or reset it")
            if sim.integrator != cfg.integrator:
                raise integrator_changed(cfg, sim.integrator, f"reactor {r}'s Simulation")
            m = len(sim)
            if m != self._n[r]:  # discs added or removed from outside: still within the plan?
                need, mass = cfg.capacity_for(sim.species, self._feed_left[r])
                if need > cfg.capacity:
                    raise RuntimeError(
                        f"reactor {r}: {m} discs (mass {mass:g}) could split into more discs "
                        f"than the batch's capacity {cfg.capacity} holds; do not add discs to "
                        "env.simulations[r] beyond the initial contents and the feed budget")
            serial = sim.export_scalars(self._rx, r)
            if serial != self._bounds_seen[r]:  # bounds replaced (resize, set_state)
                self._size[r] = cfg.read_size(sim.bounds, float(self._size[r]),
                                              f"reactor {r}'s Simulation")
                self._bounds_seen[r] = serial

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
