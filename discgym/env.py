"""``DiscReactor-v0``: the Gymnasium environment on top of the simulator.

An adapter at the edge (the physics never imports gymnasium): it translates an action into
the controls of a :class:`~discgym.Simulation` (heating, moving a wall, injecting), advances
the reactor, and translates its state into an observation and a reward. The controls, the
physics and the observation of a step run in one compiled call
(:func:`discgym.kernels.batch.env_step`, which does bit for bit what
``Simulation.scale_temperature``, ``resize``, ``inject`` and ``step`` do, except that heating
stops at the speed limit and that a refused wall move or injection has drawn from the
generator); the Python here checks the action's shape and builds ``info``. The
specification (action space, observation space, rewards, episode end, arguments) is the
README's section on the environment; the vector env, the baselines and the measured speed
are in ``docs/env.md``.

>>> import gymnasium as gym
>>> import discgym  # registers DiscReactor-v0
>>> env = gym.make("DiscReactor-v0")
>>> obs, info = env.reset(seed=0)
>>> obs.shape, obs.dtype.name
((19,), 'float32')
>>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
>>> type(reward).__name__, terminated
('float', False)

The per-reactor logic (:class:`~discgym.config.ReactorConfig` and the compiled
:func:`~discgym.kernels.batch.reactor_step`) is shared with the batched
:class:`discgym.vector.DiscReactorVectorEnv`, so that a reactor of the batch follows exactly
the trajectory of a lone environment with the same seed and actions.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping

import gymnasium as gym
import numpy as np

from .arguments import (  # noqa: F401  (lattice_sites: importable from here too)
    check_keywords,
    check_render_mode,
    lattice_sites,
    whole,
    with_config,
)
from .config import (  # noqa: F401  (importable from here too)
    DEFAULTS,
    ENV_ID,
    FLOAT_EXACT,
    FLOAT_NORMAL_MIN,
    HEAT_RATE_MAX,
    HEATINGS,
    INT_MAX,
    INT_MAX_TEXT,
    INTEGRATORS,
    MAX_ENERGY_BINS,
    MAX_GRID,
    MAX_RENDER_SIZE,
    OBS_DISCS_MAX,
    OBS_ENERGY_MAX,
    OBS_RATE_MAX,
    OBS_YIELD_MAX,
    RANDOM_PLACEMENT_SHARE,
    REWARDS,
    SLOT_BYTES_BATCH,
    ReactorConfig,
    energy_edges,
)
from .core import REAL_KINDS, EpisodeCore, as_actions
from .kernels import helper as compile_helper
from .simulation import Simulation

__all__ = [
    "DiscReactorEnv",
    "ReactorConfig",
    "register_envs",
    "ENV_ID",
    "DEFAULTS",
]

_ONE = np.ones(1, dtype=bool)  # the "active" mask of a batch of one reactor
_ROW = [0]  # its rows
_NON_INTERACTIVE = {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"}



# --------------------------------------------------------------------------------------------
# the environment


class DiscReactorEnv(gym.Env):
    """A reactor of reacting hard discs to be run for the most product.

    The full specification, with every slot and default, is ``docs/env.md``; this is its
    summary.

    ## Description
    The built-in ``reactor`` scene: ~120 A and ~120 B discs, cold (kT ~0.6), in a 30 x 30
    box. A + B -> C (activation energy 4) makes the product; C + A -> W + B (activation 8)
    destroys it, and grows faster with temperature. The agent heats or cools, moves a wall
    and feeds A and B; the goal is the most C by the end of the episode.

    ## Action Space
    ``Box(-1, 1, (2 + F,), float32)``: heat (kinetic energy x ``heat_rate ** a``, kT kept in
    ``temperature_range``), wall (target width ``size_min + (a + 1)/2 (size_max - size_min)``
    of the scene's, approached by at most ``wall_speed`` per step), then one injection
    component per feed species (``round(a * inject_max)`` discs for a > 0, within the
    episode's ``feed_budget``). NaN or infinite components do nothing (counted in
    ``info["invalid_action"]``); finite values outside [-1, 1] are clipped. ``step`` takes an
    array (or list) of exactly that shape, of real numbers (bool, integer or float dtypes,
    converted to float64); any other shape (a scalar, (1, 2 + F), ...) raises ``ValueError``
    naming the expected and the received shape, any other dtype (complex, str, object)
    ``TypeError``, before anything is stepped.

    ## Observation Space
    ``Box(low, high, (3 S + 5 + F,), float32)``, every slot clipped to finite bounds: the
    share of each species, each species' kT and mean internal energy, the total energy per
    disc, discs / discs at reset, product / limiting reactant at reset (the yield), the
    reactor's size, the fraction of the episode left, and the feed budget left per feed
    species. Names in ``env.unwrapped.observation_names``.

    ## Rewards
    ``(C_now - C_before) / n_ref - heat_cost |heat energy| / n_ref - feed_cost injected /
    n_ref``, n_ref the initial count of the limiting feed species, so an episode's return is
    the product yield. ``info`` carries the breakdown and the raw counts, flat, with the
    same keys at reset and at each step (:attr:`~discgym.config.ReactorConfig.info_types`).

    ## Starting State
    Counts x U[1 - count_jitter, 1 + count_jitter], kT x U[1 - temperature_jitter,
    1 + temperature_jitter], positions uniform without overlap, all drawn from the seed.

    ## Episode End
    Never terminated (no absorbing state); truncated after ``episode_steps`` (100) steps of
    ``step_time`` (0.5) each.

    ## Arguments
    All optional, shown in ``env.spec.kwargs`` when given to ``gymnasium.make`` (defaults:
    :data:`~discgym.config.DEFAULTS`). Each is checked at construction: a wrong type raises
    ``TypeError``, a value out of its range ``ValueError``, both naming the argument; an
    unknown keyword raises Python's own ``TypeError: DiscReactorEnv.__init__() got an
    unexpected keyword argument 'x'``. They may also come as one mapping, the only positional
    argument (``DiscReactorEnv({"episode_steps": 50})``: RLlib passes its ``EnvContext``), alone or
    with keywords (a key in both raises ``TypeError``). Numbers may be Python or numpy
    scalars (``np.int64``, ``np.float32``: taken as the numbers they are); bools are refused
    where a number is expected; whole numbers may be given as integral floats (``40.0``);
    pairs and lists may be lists, tuples or 1-d arrays. The ranges:

    - ``scene``: a built-in name, a TOML path (``str`` or ``os.PathLike``) or a
      :class:`~discgym.Scene` with initial ``counts``.
    - ``n_discs``: None or a whole number >= 1; the largest contents a reset can draw
      (each species' share of ``n_discs`` x (1 + ``count_jitter``), rounded) must fit the
      scene's bounds: no more area than the densest packing (0.9069) and, if they cover more
      than half the area (random placement is unreliable there), no more discs than the
      hexagonal lattice ``Simulation`` falls back to has sites (986 for the default scene:
      ``n_discs`` <= 897 at ``count_jitter`` 0.1). The same holds for the scene's own counts
      when ``n_discs`` is None.
    - ``episode_steps``: whole, >= 1, and ``episode_steps x step_time / dt`` <= 2**63 - 1
      (the simulation's int64 step counter).
    - ``step_time``: finite, > 0, a whole number (>= 1) of the scene's ``dt`` within 1e-9
      relative (a float32 or float16 at its own precision: ``np.float32(0.1)`` is 2 x 0.05),
      at most 2**63 - 1 steps of ``dt``.
    - ``heat_rate``: finite, 1 <= ``heat_rate`` <= 1 / 2.2250738585072014e-308
      (4.49e307: the factor at action -1, ``1 / heat_rate``, stays a normal float64). At 1
      the heat action does nothing.
    - ``temperature_range``: (low, high), finite, 0 < low <= high, low a normal float64
      (>= 2.2250738585072014e-308, as every range's low end: the heat control clamps by
      ``low / kT`` and ``high / kT``, the jacket maps by ``high / low``, and a subnormal's
      reciprocal overflows). With ``heating="jacket"`` also ``high / low`` finite
      (<= 1.797e308, the jacket's log-uniform map ``low (high / low) ** ((a + 1) / 2)``) and
      high within float32 (the bound of the ``jacket_kT`` observation). low == high is
      accepted: the jacket is then fixed (the heat action does nothing).
    - ``size_range``: (low, high), finite, 0 < low <= 1 <= high (every episode starts at the
      scene's size, 1), high within float32 (the observation's dtype), and the bounds at both
      ends valid bounds of finite area (e.g. a circle's centre within 1e6 diameters).
    - ``wall_speed``: finite, >= 0 (0: the wall never moves).
    - ``feed``: None, a species name, or a non-empty list of distinct species names.
    - ``inject_max``: whole, 0 <= ``inject_max`` <= 2**53.
    - ``feed_budget``: None, a whole number >= 0 for every feed species, or one per feed
      species; each at most the discs of that species whose mass the reactor could ever hold
      (its area at ``size_range``'s high end filled at the scene's densest mass per area:
      1898 for A and B in the default scene).
    - ``product``: None or a species name.
    - ``count_jitter``, ``temperature_jitter``: finite, 0 <= x < 1.
    - ``heat_cost``, ``feed_cost``: finite, >= 0, and small enough that no step's cost can
      overflow (about 7e285 and 1.25e299 for the default scene).
    - ``energy_bins``: whole, 0 (none) or 2..32; ``spatial_grid``: whole, 0..16;
      ``observe_reactions``: a bool (the observation blocks of ``docs/tasks.md``).
    - ``activation_jitter``: finite, 0 <= x < 1; ``reverse_jitter``: finite, 0 <= y <= 3;
      ``formation_jitter``: finite, 0 <= z <= 1000 (kinetics drawn per episode, see
      :meth:`~discgym.config.ReactorConfig.draw_kinetics`).
    - ``heating``: "scale" (the heat action rescales velocities) or "jacket" (it sets the
      thermal walls' kT; the scene must have some, and ``temperature_range``'s high end must
      not pass ``Scene.max_wall_temperature()``); ``reward``: "product" or "outflow" (the
      product leaving through the scene's outlets, which it must have); ``observe_outflow``:
      a bool; ``feed_temperature``: None or a (low, high) pair, 0 < low <= high <= the
      scene's hottest wall temperature, low a normal float64 (see
      :meth:`~discgym.config.ReactorConfig.draw_feed`).
    - ``integrator``: "step" (the time-stepped integrator, ``step_time / dt`` steps of the
      scene's ``dt``) or "event" (one exact event-driven run of ``step_time``, as
      ``Simulation(..., integrator="event").step(step_time / dt)``; the env's simulation
      has that integrator). With "event" the scene's bounds and the reactor at
      ``size_range``'s low end must leave every species at least 1e-3 of its radius of free
      room along each axis (the event integrator's own rule), so that no wall move can
      reach bounds it refuses.
    - ``render_mode``: None, "rgb_array" or "human"; ``render_size``: whole pixels,
      1 <= ``render_size`` <= 4096.

    The state a reactor's capacity plan needs must fit in the machine's memory.

    ``env.unwrapped.simulation`` is the underlying :class:`~discgym.Simulation`. Its controls
    and ``set_state`` may be used between steps: bounds that ``resize`` or ``set_state``
    replaced give the wall its size, which the ``size`` observation and the next wall move
    start from (:meth:`~discgym.config.ReactorConfig.read_size`); bounds the wall cannot make
    (another kind, height, origin or centre, or a size outside ``size_range``) raise
    ``RuntimeError`` at the next step, before anything is stepped.

    ## Version History
    - v0: first version.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}
    #: the keyword arguments and their defaults (a task of :mod:`discgym.tasks` sets its own)
    defaults = DEFAULTS

    def __init__(self, config: Mapping | None = None, /, **kwargs):
        kwargs = with_config(f"{type(self).__name__}.__init__", config, kwargs)
        self._construct(**kwargs)

    def _construct(self, render_mode: str | None = None, render_size: int = 400, **kwargs):
        check_keywords(f"{type(self).__name__}.__init__", kwargs, self.defaults)
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.render_size = whole(render_size, "render_size", 1, MAX_RENDER_SIZE)
        self.config = cfg = ReactorConfig.from_kwargs(self.defaults, **kwargs)
        compile_helper.expect(f"env-{cfg.integrator}")
        self.render_mode = render_mode
        if render_mode == "human":
            _need_matplotlib()
        self.observation_space = cfg.observation_space()
        self.action_space = cfg.action_space()
        self.observation_names = cfg.obs_names
        self.action_names = cfg.action_names
        # the episode core of one reactor: its state, episode row and Simulation handle
        self.core = EpisodeCore(cfg, 1, numbers=True)
        self._ashape = (2 + len(cfg.feed),)
        self._fig = None

    @property
    def simulation(self) -> Simulation | None:
        """The reactor's :class:`~discgym.Simulation` (None before the first reset): a
        handle on the env's own state, so that its controls act on the next step."""
        return self.core.simulations[0]

    # ------------------------------------------------------------------ API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        cfg, core = self.config, self.core
        core.np_randoms[0] = self.np_random
        core.reset(_ROW)
        ep = core.episodes
        counts = list(map(int, ep.stats[0, :cfg.n_species].tolist()))
        product = counts[cfg.product]
        n_ref = ep.n_ref.item()
        # the keys of a step's info; what only a step does (reward, costs, heat, injections,
        # a blocked wall, invalid components) is 0 / False
        none = [0] * len(cfg.feed)
        info = cfg.info_values(counts, product, product / n_ref, 0.0, 0.0, 0.0, 0.0,
                               ep.temperature.item(), ep.size.item(), none, none, False, 0,
                               core.state.time(0), n_ref)
        if self.render_mode == "human":
            self.render()
        return ep.obs[0].copy(), info

    def step(self, action):
        if self.core.simulations[0] is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        cfg, core = self.config, self.core
        if type(action) is np.ndarray and action.shape == self._ashape and \
                action.dtype.kind in REAL_KINDS:
            core.act[0] = action
        else:
            core.act[0] = as_actions(cfg, action)
        out = core.step(_ONE)
        ep = core.episodes
        counts = list(map(int, ep.stats[0, :cfg.n_species].tolist()))
        product = counts[cfg.product]
        n_ref = ep.n_ref.item()
        info = cfg.info_values(counts, product, product / n_ref, out.gain, out.cost_heat,
                               out.cost_feed, out.heat, ep.temperature.item(), ep.size.item(),
                               out.injected, out.refused, out.blocked, out.invalid,
                               core.state.time(0), n_ref)
        truncated = ep.steps.item() >= cfg.episode_steps
        if self.render_mode == "human":
            self.render()
        return ep.obs[0].copy(), out.reward, False, truncated, info

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass "
                            "render_mode='rgb_array' or 'human' to gymnasium.make")
            return None
        if self.simulation is None:
            raise gym.error.ResetNeeded("call reset() before render()")
        frame = self._frame()
        if self.render_mode == "rgb_array":
            return frame
        plt = _need_matplotlib()
        import matplotlib

        backend = matplotlib.get_backend().lower()
        shown = backend not in _NON_INTERACTIVE and "inline" not in backend
        if self._fig is None:
            self._fig, ax = plt.subplots(figsize=(5, 5))
            ax.set_axis_off()
            self._im = ax.imshow(frame)
            if shown:
                plt.show(block=False)
        else:
            self._im.set_data(frame)
        self._fig.canvas.draw_idle()
        if shown:  # a headless (Agg) backend just draws, without a window
            plt.pause(1.0 / self.metadata["render_fps"])
        return None

    def close(self):
        if self._fig is not None:
            import matplotlib.pyplot as plt

            plt.close(self._fig)
            self._fig = None

    # ------------------------------------------------------------------ helpers
    def _frame(self) -> np.ndarray:
        from .render import render_frame

        ep = self.core.episodes
        y = self.core.product.item() / ep.n_ref.item()
        title = f"T {ep.temperature.item():.2f} Y {y:.2f}"
        return render_frame(self.simulation, size=self.render_size, title=title)

    def clone(self, reseed=None) -> DiscReactorEnv:
        """An independent copy that continues bit for bit as this env would under the same
        actions (observations, rewards, infos, the next ``reset()`` without a seed): what
        ``copy.deepcopy(env)`` gives, for planners that copy at every decision (see
        :class:`discgym.oracle.RolloutOracle`). The frozen
        :class:`~discgym.config.ReactorConfig` is shared and so is the simulation's frozen
        :class:`~discgym.Scene` (deepcopy copies and compiles them again), everything else is
        copied: the
        :class:`~discgym.Simulation` (state, counters, random generator), the env's
        ``np_random``, the episode bookkeeping and the spaces (with their own generators). No
        figure: a clone renders into a new one. It costs about as much as ``deepcopy`` (~0.7 ms
        for the default env, about three env steps, measured 2026-12-02 on a 2-core AMD EPYC
        VM): most of it is copying the simulation's state.

        ``reseed`` (an int or ``numpy.random.SeedSequence``): the copy's random generators
        (the simulation's and the env's ``np_random``) are replaced by fresh ones seeded from
        it, so that the copy continues from the same state into *another* random future: what
        a planner that knows the model but not the noise can simulate
        (``RolloutOracle(noise=...)``)."""
        memo = {id(self.config): self.config}
        if self.simulation is not None:  # (its Scene is frozen too)
            memo[id(self.simulation.scene)] = self.simulation.scene
        c = copy.deepcopy(self, memo)
        if reseed is not None:
            ss = reseed if isinstance(reseed, np.random.SeedSequence) \
                else np.random.SeedSequence(reseed)
            env_seq, sim_seq = ss.spawn(2)
            c.np_random = np.random.Generator(np.random.PCG64(env_seq))
            c.core.state.set_generator(0, np.random.Generator(np.random.PCG64(sim_seq)))
        return c

    def __getstate__(self):
        d = self.__dict__.copy()
        d["_fig"] = None
        d.pop("_im", None)
        return d


def _need_matplotlib():
    try:
        import matplotlib.pyplot as plt
    except ImportError:
        raise gym.error.DependencyNotInstalled(
            "render_mode='human' needs matplotlib: pip install 'discgym[render]' "
            "(or use render_mode='rgb_array', which needs numpy only)") from None
    return plt


# --------------------------------------------------------------------------------------------
# registration


def register_envs() -> None:
    """Register ``DiscReactor-v0`` (idempotent). Called by ``import discgym``."""
    if ENV_ID in gym.registry:
        return
    gym.register(
        id=ENV_ID,
        entry_point="discgym.env:DiscReactorEnv",
        vector_entry_point="discgym.vector:DiscReactorVectorEnv",
        max_episode_steps=DEFAULTS["episode_steps"],
    )
