"""The batched ``DiscReactor-v0``: many reactors stepped in one compiled, parallel call.

``gymnasium.make_vec("DiscReactor-v0", num_envs=64)`` builds a :class:`DiscReactorVectorEnv`
(it is the registered ``vector_entry_point``). Each reactor follows, bit for bit, the
trajectory of a lone :class:`~discgym.env.DiscReactorEnv` reset with the same seed and given
the same actions (``tests/test_vector.py`` checks it): both share the action, observation and
reward code of :mod:`discgym.env`, and the kernel of each reactor is the same
:func:`discgym.kernels.step.run_tracked`.

How it works (and why it touches the private state of :class:`~discgym.Simulation`): the state
of all reactors lives in padded arrays ``(R, C, 2)`` / ``(R, C)`` with a capacity ``C = 2 *
max_discs + 16`` that can never run out (``max_discs``: the initial contents at their largest
plus every feed budget), so :func:`discgym.kernels.batch.run_batch` steps them all in place in
a ``prange`` over reactors. Each reactor keeps a real ``Simulation`` whose state arrays
(``_pos``, ``_vel``, ``_spc``, ``_uint``, ``_ids``, ``_idctr``) and counters (``_icnt``,
``_fsum``, ``_ch_count``) are *views* of row r of those arrays, so the wall and injection
controls reuse the ``Simulation`` methods (``resize``, ``inject``) unchanged. Heating, the
control used at nearly every step, scales the velocities of all reactors in one compiled loop
(:func:`~discgym.kernels.batch.scale_velocities`: the very multiplication
``Simulation.scale_temperature`` does, so the trajectories stay bit-identical) and books the
energy added in the ``Simulation`` (``energy_input``; equal to what ``scale_temperature`` books
up to rounding). After each control the views are checked to still be the batch's (a control
that reallocated would raise ``RuntimeError``), and after each batched step the
``Simulation``'s disc count, step count and clocks are advanced exactly as ``Simulation.step``
does. ``env.simulations[r]`` is reactor r's ``Simulation`` (read it; do not keep it across a
reset, which builds a new one).

Autoreset: ``autoreset_mode`` ("NextStep", the Gymnasium default; "SameStep", with
``info["final_obs"]`` and ``info["final_info"]``; or "Disabled", then reset finished reactors
with ``reset(options={"reset_mask": mask})``); declared in ``metadata["autoreset_mode"]``.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from gymnasium import error, logger
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import typed

from ._dtypes import COUNT, FLOAT, INDEX
from .env import ReactorConfig, heat_factor, observe, sanitize_actions, wall_and_feed
from .kernels import step as _step
from .kernels.batch import GREW, run_batch, scale_velocities

__all__ = ["DiscReactorVectorEnv"]


class DiscReactorVectorEnv(VectorEnv):
    """``num_envs`` reactors of ``DiscReactor-v0``, advanced together in one compiled call
    parallel over reactors (on numba's threads; ``threads`` sets how many, default: numba's
    current setting).

    Takes the keyword arguments of :class:`~discgym.env.DiscReactorEnv` (except
    ``render_mode="human"``) plus ``num_envs``, ``autoreset_mode`` and ``threads``;
    ``max_episode_steps`` (passed by ``gymnasium.make_vec`` from the registration) caps the
    episode length like the ``TimeLimit`` wrapper of ``gymnasium.make`` does.

    ``reset(seed=s)`` seeds reactor i with ``s + i`` (a list gives one seed per reactor).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10,
                "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, *, max_episode_steps: int | None = None,
                 autoreset_mode=AutoresetMode.NEXT_STEP, threads: int | None = None,
                 render_mode: str | None = None, render_size: int = 200, **kwargs):
        if isinstance(num_envs, bool) or int(num_envs) != num_envs or num_envs < 1:
            raise ValueError(f"num_envs: need a whole number >= 1, got {num_envs!r}")
        if max_episode_steps is not None and "episode_steps" not in kwargs:
            kwargs["episode_steps"] = max_episode_steps
        self.config = cfg = ReactorConfig.from_kwargs(**kwargs)
        self.limit = cfg.episode_steps if max_episode_steps is None else \
            min(int(max_episode_steps), cfg.episode_steps)
        self.autoreset_mode = autoreset_mode if isinstance(autoreset_mode, AutoresetMode) \
            else AutoresetMode(autoreset_mode)
        self.metadata = dict(self.metadata, autoreset_mode=self.autoreset_mode)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: the vector env renders 'rgb_array' only, got "
                             f"{render_mode!r}")
        self.render_mode = render_mode
        self.render_size = int(render_size)
        self.threads = None if threads is None else max(int(threads), 1)
        self.num_envs = R = int(num_envs)
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
        self._spc = np.full((R, C), -1, dtype=INDEX)
        self._uint = np.zeros((R, C), dtype=FLOAT)
        self._ids = np.zeros((R, C), dtype=COUNT)
        self._idctr = np.zeros((R, 1), dtype=COUNT)
        self._n = np.zeros(R, dtype=np.int64)
        self._ksteps = np.zeros(R, dtype=np.int64)  # kernel steps taken (Simulation._steps)
        self._bkind = np.zeros(R, dtype=np.int64)
        self._bp = np.zeros((R, 4), dtype=FLOAT)
        self._icnt = np.zeros((R, _step.N_ICOUNTERS), dtype=COUNT)
        self._fsum = np.zeros((R, _step.N_FSUMS), dtype=FLOAT)
        self._chc = np.zeros((R, len(cfg.compiled.labels)), dtype=COUNT)
        self._status = np.zeros(R, dtype=np.int64)
        self._stats = np.zeros((R, 3 * S + 1), dtype=FLOAT)
        # one persistent generator per reactor, reseeded at each reset (see env.new_simulation)
        self._gens = [np.random.Generator(np.random.PCG64(0)) for _ in range(R)]
        self._rngs = typed.List(self._gens)
        self._np_randoms: list = [None] * R
        self.simulations: list = [None] * R
        self._views = [(self._pos[r], self._vel[r], self._spc[r], self._uint[r], self._ids[r],
                        self._idctr[r]) for r in range(R)]
        # per-reactor episode state
        self._steps = np.zeros(R, dtype=np.int64)
        self._size = np.ones(R, dtype=FLOAT)
        self._feed_left = np.zeros((R, F), dtype=np.int64)
        self._n_init = np.ones(R, dtype=FLOAT)
        self._n_ref = np.ones(R, dtype=FLOAT)
        self._product = np.zeros(R, dtype=FLOAT)
        self._autoreset = np.zeros(R, dtype=bool)
        self._obs = np.zeros((R, len(cfg.obs_names)), dtype=np.float32)
        self._temps = np.zeros(R, dtype=FLOAT)
        self._kin = np.zeros(R, dtype=FLOAT)
        self._started = False

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
        info = {"n_ref": self._n_ref.copy(), "_n_ref": mask.copy()}
        return self._obs.copy(), info

    def _reset_one(self, r: int) -> None:
        cfg = self.config
        sim = cfg.new_simulation(self._np_randoms[r], generator=self._gens[r])
        n = len(sim)
        if n > cfg.max_discs:  # cannot happen: max_discs bounds the drawn contents
            raise RuntimeError(f"reactor {r}: {n} discs exceed the capacity plan")
        pos, vel, spc, uint, ids, idctr = self._views[r]
        pos[:] = 0.0
        vel[:] = 0.0
        spc[:] = -1
        uint[:] = 0.0
        ids[:] = 0
        pos[:n] = sim._pos[:n]
        vel[:n] = sim._vel[:n]
        spc[:n] = sim._spc[:n]
        uint[:n] = sim._uint[:n]
        ids[:n] = sim._ids[:n]
        idctr[:] = sim._idctr
        sim._pos, sim._vel, sim._spc, sim._uint = pos, vel, spc, uint
        sim._ids, sim._idctr = ids, idctr
        self._ksteps[r] = sim._steps
        self._icnt[r] = sim._icnt
        self._fsum[r] = sim._fsum
        self._chc[r] = sim._ch_count
        sim._icnt, sim._fsum, sim._ch_count = self._icnt[r], self._fsum[r], self._chc[r]
        self._n[r] = n
        self._bkind[r] = sim._bkind
        self._bp[r] = sim._bp
        self.simulations[r] = sim
        self._steps[r] = 0
        self._size[r] = cfg.size_of(sim.bounds)
        self._feed_left[r] = cfg.feed_budget
        self._n_init[r] = n
        self._n_ref[r] = cfg.n_ref(np.bincount(sim.species, minlength=cfg.n_species))
        self._product[r] = np.count_nonzero(sim.species == cfg.product)

    def _observe_all(self) -> None:
        observe(self.config, self._vel, self._spc, self._uint, self._n, self._size,
                self._steps, self._feed_left, self._n_init, self._n_ref, self._stats,
                self._temps, self._kin, self._obs)

    # ------------------------------------------------------------------ step
    def step(self, actions):
        if not self._started:
            raise error.ResetNeeded("call reset() before step()")
        cfg = self.config
        R = self.num_envs
        a, bad = sanitize_actions(cfg, np.asarray(actions).reshape(R, -1))
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
        heat = np.zeros(R, dtype=FLOAT)
        injected = np.zeros((R, F), dtype=np.int64)
        refused = np.zeros((R, F), dtype=np.int64)
        blocked = np.zeros(R, dtype=bool)
        rows, flags = a.tolist(), bad.tolist()
        idx = np.flatnonzero(active).tolist()
        # heat: the same factor as DiscReactorEnv, applied to all reactors in one compiled
        # loop (bit for bit what Simulation.scale_temperature does to the velocities)
        scale = np.ones(R, dtype=FLOAT)
        for r in idx:
            f = heat_factor(cfg, rows[r][0], float(self._temps[r]))
            if f != 1.0:
                scale[r] = math.sqrt(f)
                heat[r] = (f - 1.0) * float(self._kin[r])
        scale_velocities(self._vel, self._n, scale)
        for r in idx:
            sim = self.simulations[r]
            if scale[r] != 1.0:  # the energy added, as scale_temperature books it (to rounding)
                sim._energy_input += float(heat[r])
            size, injected[r], refused[r], blocked[r] = wall_and_feed(
                cfg, sim, rows[r], flags[r], float(self._size[r]), self._feed_left[r])
            self._size[r] = size
            v = self._views[r]
            if sim._pos is not v[0] or sim._vel is not v[1] or sim._spc is not v[2] \
                    or sim._uint is not v[3] or sim._ids is not v[4] or sim._idctr is not v[5]:
                raise RuntimeError(f"reactor {r}: a control reallocated the state arrays "
                                   f"(capacity {cfg.capacity} too small); this is a bug")
            self._n[r] = sim._n
            self._bkind[r] = sim._bkind
            self._bp[r] = sim._bp
        self._advance(active)
        for r in np.flatnonzero(resetting).tolist():
            self._reset_one(r)
        self._steps[active] += 1
        self._observe_all()
        product = self._stats[:, cfg.product].copy()
        # rewards: the same arithmetic, in the same order, as DiscReactorEnv.step
        gain = (product - self._product) / self._n_ref
        cost_heat = cfg.heat_cost * np.abs(heat) / self._n_ref
        cost_feed = cfg.feed_cost * injected.sum(axis=1).astype(FLOAT) / self._n_ref
        rew = gain - cost_heat - cost_feed
        rew[resetting] = 0.0
        self._product = product
        terminated = np.zeros(R, dtype=bool)
        truncated = active & (self._steps >= self.limit)
        infos = self._infos(gain, cost_heat, cost_feed, heat, injected, refused, blocked,
                            bad.sum(axis=1), active)
        obs = self._obs.copy()
        done = terminated | truncated
        if self.autoreset_mode == AutoresetMode.SAME_STEP and done.any():
            final_obs = np.full(R, None, dtype=object)
            for r in np.flatnonzero(done).tolist():
                final_obs[r] = obs[r].copy()
            infos["final_obs"] = final_obs
            infos["_final_obs"] = done.copy()
            infos["final_info"] = _masked(
                {k: v for k, v in infos.items() if not k.startswith("_")}, done)
            infos["_final_info"] = done.copy()
            for r in np.flatnonzero(done).tolist():
                self._reset_one(r)
            self._observe_all()
            obs = self._obs.copy()
            self._product = self._stats[:, cfg.product].copy()
            done = np.zeros(R, dtype=bool)
        self._autoreset = done
        return obs, rew, terminated, truncated, infos

    def _infos(self, gain, cost_heat, cost_feed, heat, injected, refused, blocked, invalid,
               active) -> dict:
        """The step's info as arrays (R,) with Gymnasium's ``_key`` masks (False for the
        reactors reset by this step); per-species entries are nested dicts."""
        cfg = self.config
        names = cfg.scene.species_names
        counts = self._stats[:, :cfg.n_species].astype(np.int64)
        product = counts[:, cfg.product]
        infos = {
            "counts": {nm: counts[:, k] for k, nm in enumerate(names)},
            "product": product,
            "yield": product / self._n_ref,
            "reward_product": gain,
            "cost_heat": cost_heat,
            "cost_feed": cost_feed,
            "heat_energy": heat,
            "temperature": self._temps.copy(),
            "size": self._size.copy(),
            "injected": {names[f]: injected[:, k] for k, f in enumerate(cfg.feed)},
            "inject_refused": {names[f]: refused[:, k] for k, f in enumerate(cfg.feed)},
            "wall_blocked": blocked,
            "invalid_action": invalid.astype(np.int64),
            "time": np.array([s.time for s in self.simulations], dtype=FLOAT),
        }
        return _masked(infos, active)

    def _advance(self, active: np.ndarray) -> None:
        cfg = self.config
        cs = cfg.compiled
        k = cfg.steps_per_action
        dt = cfg.scene.dt
        # never more threads than reactors to step (a lone reactor runs on the calling thread)
        old = numba.get_num_threads()
        want = old if self.threads is None else min(self.threads, numba.config.NUMBA_NUM_THREADS)
        want = max(1, min(want, int(active.sum())))
        if want != old:
            numba.set_num_threads(want)
        try:
            run_batch(self._pos, self._vel, self._spc, self._uint, self._ids, self._idctr,
                      self._n, self._ksteps, k, dt, self._bkind, self._bp, cs.tables,
                      cs.params, cs.flags, self._rngs, self._icnt, self._fsum, self._chc,
                      _step.REORDER_EVERY, active, self._status)
        finally:
            if want != old:
                numba.set_num_threads(old)
        if self._status.any():
            bad = np.flatnonzero(self._status == GREW).tolist()
            raise RuntimeError(f"reactors {bad}: the state outgrew the capacity "
                               f"{cfg.capacity}; this is a bug in the capacity plan")
        for r in np.flatnonzero(active):
            sim = self.simulations[r]
            # exactly what Simulation._run does after the kernel
            sim._n = int(self._n[r])
            sim._steps += k
            sim._time += k * dt
            sim._since_reset += k * dt

    # ------------------------------------------------------------------ misc
    def render(self):
        if self.render_mode is None:
            logger.warn("render() called without a render_mode; pass render_mode='rgb_array'")
            return None
        from .render import render_frame

        return tuple(render_frame(s, size=self.render_size) for s in self.simulations)

    def close_extras(self, **kwargs):
        pass


def _masked(infos: dict, mask: np.ndarray) -> dict:
    """Add Gymnasium's ``_key`` masks (``mask``) to every entry, recursively."""
    out = {}
    for k, v in infos.items():
        out[k] = _masked(v, mask) if isinstance(v, dict) else v
        out[f"_{k}"] = mask.copy()
    return out
