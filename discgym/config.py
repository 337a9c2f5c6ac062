"""The settings of a reactor environment: :data:`DEFAULTS`, the observation's bounds and the
limits of the arguments, and :class:`ReactorConfig`, the validated settings that the single
env, the vector env and the baselines share (its draws at reset, its reward, its info)."""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from gymnasium import spaces

from .arguments import (  # noqa: F401  (the limits, here with the others)
    FLOAT_NORMAL_MIN,
    INT_MAX,
    INT_MAX_TEXT,
    RANDOM_PLACEMENT_SHARE,
    bounds_of,
    check_event_fit,
    check_keywords,
    check_memory,
    check_placeable,
    choice,
    env_scene,
    flag,
    most_discs,
    pair,
    real,
    steps_per_action,
    whole,
)
from .compiled import P_MAXDISP, P_RMIN, CompiledScene, compile_scene
from .kernels.step import MAX_SUBSTEPS, REORDER_EVERY
from .kernels.structs import (
    FLOAT,
    INDEX,
    Episodes,
    ReactorConsts,
    capacity_for_discs,
    speed_limit,
)
from .scene import (
    HEX_PACKING,
    Box,
    Combination,
    Exchange,
    Scene,
    SceneError,
    check_bounds_scale,
)
from .simulation import PLACEMENT_ATTEMPTS, Simulation
from .slots import (  # noqa: F401  (the bounds: importable from here too)
    OBS_DISCS_MAX,
    OBS_ENERGY_MAX,
    OBS_RATE_MAX,
    OBS_YIELD_MAX,
    energy_edges,
    extra_slots,
    observation_slots,
)

ENV_ID = "DiscReactor-v0"

#: The arguments each reactor of a vector env may set for itself
#: (``DiscReactorVectorEnv(configs=...)``): its contents, controls' ranges, budgets, costs,
#: kinetics and episode length. The others make the batch (the scene, what is fed and made,
#: the observation's layout, the integrator, ``step_time``) and are the same for every reactor.
ROW_ARGUMENTS = ("n_discs", "count_jitter", "temperature_jitter", "episode_steps",
                 "heat_rate", "temperature_range", "size_range", "wall_speed", "inject_max",
                 "feed_budget", "heat_cost", "feed_cost", "activation_jitter",
                 "reverse_jitter", "formation_jitter", "feed_temperature")
# the fields of a ReactorConfig that every reactor of a batch must share (the rest follow
# from ROW_ARGUMENTS; obs_low and obs_high are checked against the batch's observation space)
_SHARED = ("steps_per_action", "feed", "product", "energy_bins", "grid", "observe_reactions",
           "heating", "reward", "observe_outflow", "integrator", "obs_names")

#: Default keyword arguments of :class:`~discgym.env.DiscReactorEnv` (and of ``gymnasium.make``).
DEFAULTS = dict(
    scene="reactor",
    n_discs=None,
    episode_steps=100,
    step_time=0.5,
    heat_rate=2.0,
    temperature_range=(0.2, 8.0),
    size_range=(0.6, 1.4),
    wall_speed=0.05,
    feed=None,
    inject_max=4,
    feed_budget=None,
    product=None,
    count_jitter=0.1,
    temperature_jitter=0.4,
    heat_cost=0.0,
    feed_cost=0.0,
    energy_bins=0,
    spatial_grid=0,
    observe_reactions=False,
    activation_jitter=0.0,
    reverse_jitter=0.0,
    formation_jitter=0.0,
    heating="scale",
    reward="product",
    observe_outflow=False,
    feed_temperature=None,
    integrator="step",
)

#: The ways the heat action heats (see ``heating``) and the rewards (see ``reward``).
HEATINGS = ("scale", "jacket")
REWARDS = ("product", "outflow")
#: The integrators an env step may run (see ``integrator``; ReactorConsts.integrator's order).
INTEGRATORS = ("step", "event")

#: Observations are clipped to the bounds of discgym.slots (OBS_ENERGY_MAX, ...).
#: The most bins of the kinetic-energy histogram and cells per side of the spatial one.
MAX_ENERGY_BINS = 32
MAX_GRID = 16

#: Whole numbers a float64 holds exactly (the kernel computes round(a * inject_max) in float64).
FLOAT_EXACT = 2**53
#: The largest ``heat_rate``: ``heat_rate ** a`` for every action a in [-1, 1] is a normal
#: float (at -1 its reciprocal, at least FLOAT_NORMAL_MIN).
HEAT_RATE_MAX = 1.0 / FLOAT_NORMAL_MIN
#: Largest ``render_size`` (the renderer's scratch is ~40 bytes a pixel: ~0.7 GB at 4096).
MAX_RENDER_SIZE = 4096
_FLOAT32_MAX = float(np.finfo(np.float32).max)
_COST_SCALE = 1e300  # a step's cost terms stay below this (a margin under the float range)
# bytes per disc of capacity: the state arrays (52) and the stepper's scratch of a lone
# Simulation (the single env), or the state arrays only (the vector env, per reactor)
_SLOT_BYTES_SINGLE = 192
SLOT_BYTES_BATCH = 64


# --------------------------------------------------------------------------------------------
# configuration shared by the single and the vector environment


@dataclass(frozen=True, eq=False)
class ReactorConfig:
    """The validated settings of a reactor environment (see :data:`DEFAULTS`).

    Built by :meth:`from_kwargs`; read by :class:`~discgym.env.DiscReactorEnv` and
    :class:`discgym.vector.DiscReactorVectorEnv`. ``S`` species, ``F`` feed species.
    """

    scene: Scene
    template: np.ndarray  # (S,) int, initial counts before the jitter
    episode_steps: int
    steps_per_action: int  # kernel steps of scene.dt per env step
    heat_rate: float
    t_min: float
    t_max: float
    size_min: float
    size_max: float
    wall_speed: float
    feed: tuple  # (F,) species indices
    inject_max: int
    feed_budget: np.ndarray  # (F,) int
    product: int  # species index
    count_jitter: float
    temperature_jitter: float
    heat_cost: float
    feed_cost: float
    max_discs: int  # the most discs a reactor can ever hold
    energy_bins: int  # B, bins of the kinetic-energy histogram (0: none)
    energy_edges: np.ndarray  # (B - 1,) inner edges
    grid: int  # G, cells per side of the spatial histogram (0: none)
    observe_reactions: bool
    activation_jitter: float  # activation energies x U[1 - x, 1 + x] per episode
    reverse_jitter: float  # reverse probabilities x 10 ** U[-x, x] per episode (at most 1)
    formation_jitter: float  # formation energies + U[-x, x] per episode
    heating: str  # "scale" (every velocity rescaled) or "jacket" (thermal walls set)
    reward: str  # "product" (product made) or "outflow" (product leaving through outlets)
    observe_outflow: bool
    feed_temperature: tuple | None  # (low, high) of the inlet kT drawn per episode, or None
    integrator: str  # "step" (time-stepped) or "event" (one exact event-driven run per step)
    obs_names: tuple
    obs_low: np.ndarray
    obs_high: np.ndarray
    compiled: CompiledScene

    @property
    def n_species(self) -> int:
        return len(self.scene.species)

    @cached_property
    def species_names(self) -> list:
        return self.scene.species_names

    @property
    def action_names(self) -> tuple:
        return ("heat", "wall") + tuple(f"inject_{self.scene.species[f].name}"
                                        for f in self.feed)

    @property
    def capacity(self) -> int:
        """Disc capacity that keeps a reactor's arrays from ever growing (see kernels.batch)."""
        return capacity_for_discs(self.max_discs)

    def capacity_for(self, spc: np.ndarray, feed_left: np.ndarray) -> tuple[int, float]:
        """``(capacity, mass)``: the capacity a reactor holding the discs of species ``spc``
        (n,) with ``feed_left`` (F,) still to inject needs so that its arrays never grow (all
        the discs its mass could ever split into, twice over: mass is conserved), and that
        mass."""
        m = self.compiled.sp_mass
        mass = float(m[spc].sum()) + float((feed_left * m[list(self.feed)]).sum())
        return capacity_for_discs(most_discs(mass, float(m.min()))), mass

    @cached_property
    def consts(self) -> ReactorConsts:
        """The constants :func:`discgym.kernels.batch.env_step` reads."""
        ref = self.scene.bounds
        if isinstance(ref, Box):
            r4 = (ref.origin[0], ref.origin[1], ref.width, ref.height)
        else:
            r4 = (ref.center[0], ref.center[1], ref.radius, 0.0)
        cs = self.compiled
        return ReactorConsts(
            speed_limit=float(speed_limit(MAX_SUBSTEPS, cs.params[P_MAXDISP],
                                          cs.params[P_RMIN], self.scene.dt)),
            ref_bounds=np.array(r4, dtype=FLOAT), temperature=float(self.scene.temperature),
            dt=float(self.scene.dt), packing=float(HEX_PACKING),
            steps_per_action=int(self.steps_per_action),
            attempts=int(PLACEMENT_ATTEMPTS), reorder_every=int(REORDER_EVERY),
            product=int(self.product), feed=np.array(self.feed, dtype=INDEX),
            obs_low=self.obs_low, obs_high=self.obs_high, energy_edges=self.energy_edges,
            energy_bins=int(self.energy_bins), grid=int(self.grid),
            obs_reactions=int(self.observe_reactions),
            heating=HEATINGS.index(self.heating),
            obs_feed_kT=int(self.feed_temperature is not None),
            obs_outflow=int(self.observe_outflow),
            integrator=INTEGRATORS.index(self.integrator))

    @property
    def uncertain(self) -> bool:
        """Whether each episode draws its own kinetics."""
        return bool(self.activation_jitter or self.reverse_jitter or self.formation_jitter)

    @cached_property
    def tables(self) -> tuple:
        """The compiled scene's tables (one tuple, built once)."""
        return self.compiled.tables

    @classmethod
    def from_kwargs(cls, defaults: dict | None = None, **kw) -> ReactorConfig:
        """Validate the keyword arguments of :data:`DEFAULTS` (the ranges are in the
        docstring of :class:`~discgym.env.DiscReactorEnv`, section Arguments): a bad one raises
        ``TypeError`` (wrong type) or ``ValueError`` (out of range) naming it. ``defaults``:
        a task's defaults (every key of :data:`DEFAULTS`), :data:`DEFAULTS` if None."""
        defaults = DEFAULTS if defaults is None else defaults
        check_keywords("ReactorConfig.from_kwargs", kw, defaults)
        o = dict(defaults)
        o.update(kw)
        scene = env_scene(o["scene"])
        names = scene.species_names
        product, feed = _product_and_feed(scene, o)
        cj, tj, template, n_discs, most = _contents(scene, o)
        episode_steps = whole(o["episode_steps"], "episode_steps", 1)
        spa = steps_per_action(o["step_time"], scene.dt)
        if spa > INT_MAX // episode_steps:
            raise ValueError(
                f"episode_steps, step_time: an episode of {episode_steps} steps of {spa} x dt "
                f"is more steps than the simulation's step counter holds ({INT_MAX_TEXT}); at "
                f"this step_time, episode_steps <= {INT_MAX // spa}")
        heat_rate = real(o["heat_rate"], "heat_rate", 1.0, HEAT_RATE_MAX,
                          why="the factor at action -1, 1 / heat_rate, must be a normal "
                              "float64")
        t_min, t_max = pair(o["temperature_range"], "temperature_range")
        size_min, size_max = _size_range(scene, o)
        wall_speed = real(o["wall_speed"], "wall_speed", 0.0)
        inject_max = whole(o["inject_max"], "inject_max", 0, FLOAT_EXACT,
                            "2**53: round(a * inject_max) is computed in float64")
        mass = [sp.mass for sp in scene.species]
        feed_budget = _feed_budget(scene, o, feed, template, size_max)
        # the most discs a reactor can ever hold: reactions conserve mass, so at most the
        # largest initial contents plus every feed budget, all split into the lightest species
        total_mass = sum(c * m for c, m in zip(most, mass)) + \
            sum(int(b) * mass[f] for b, f in zip(feed_budget, feed))
        max_discs = most_discs(total_mass, min(mass))
        capacity = capacity_for_discs(max_discs)
        check_memory(capacity * _SLOT_BYTES_SINGLE, "n_discs, feed_budget",
                      f"a reactor's capacity plan of {capacity} discs")
        # costs: a step's cost must stay finite (energies bounded by the speed limit, a
        # disc's chemistry, the capacity; injections by inject_max)
        cs = compile_scene(scene)
        v_lim = speed_limit(MAX_SUBSTEPS, cs.params[P_MAXDISP], cs.params[P_RMIN], scene.dt)
        e_disc = max(mass) * v_lim * v_lim + 2.0 * max(
            abs(sp.formation_energy) for sp in scene.species) + 1.0
        why = "a larger cost could make a step's reward overflow"
        heat_cost = real(o["heat_cost"], "heat_cost", 0.0, _COST_SCALE / (capacity * e_disc),
                          why=why)
        feed_cost = real(o["feed_cost"], "feed_cost", 0.0,
                          _COST_SCALE / (len(feed) * max(inject_max, 1)), why=why)

        energy_bins = whole(o["energy_bins"], "energy_bins", 0, MAX_ENERGY_BINS)
        if energy_bins == 1:
            raise ValueError("energy_bins: need 0 (no histogram) or at least 2 bins, got 1")
        grid = whole(o["spatial_grid"], "spatial_grid", 0, MAX_GRID)
        observe_reactions = flag(o["observe_reactions"], "observe_reactions")
        aj = real(o["activation_jitter"], "activation_jitter", 0.0, 1.0, hi_open=True)
        rj = real(o["reverse_jitter"], "reverse_jitter", 0.0, 3.0,
                   why="a factor of 10 ** 3 either way")
        fj = real(o["formation_jitter"], "formation_jitter", 0.0, 1e3)
        heating = _heating(scene, o, t_min, t_max)
        reward = choice(o["reward"], "reward", REWARDS)
        if reward == "outflow" and not scene.outlets:
            raise ValueError("reward: 'outflow' rewards the product leaving through the scene's "
                             "outlets, and the scene has none (Scene(outlets=...))")
        observe_outflow = flag(o["observe_outflow"], "observe_outflow")
        feed_temperature = o["feed_temperature"]
        if feed_temperature is not None:
            feed_temperature = pair(feed_temperature, "feed_temperature")
            hottest = scene.max_wall_temperature()
            if feed_temperature[1] > hottest:
                raise ValueError(f"feed_temperature: {feed_temperature[1]} would inject discs "
                                 f"beyond the speed limit (at most {hottest:.4g})")
        integrator = choice(o["integrator"], "integrator", INTEGRATORS)
        if integrator == "event":
            check_event_fit(scene, size_min)
        edges = energy_edges(scene, energy_bins)
        obs_names, lo, hi = observation_slots(names, feed, size_min, size_max)
        extra_slots(obs_names, lo, hi, names, energy_bins, edges, grid,
                     cs.labels if observe_reactions else (), jacket=heating == "jacket",
                     t_max=t_max, feed_kT=feed_temperature is not None,
                     outflow=observe_outflow)
        return cls(
            scene=scene, template=template, episode_steps=episode_steps,
            steps_per_action=spa, heat_rate=heat_rate, t_min=t_min, t_max=t_max,
            size_min=size_min, size_max=size_max, wall_speed=wall_speed, feed=feed,
            inject_max=inject_max, feed_budget=feed_budget, product=product,
            count_jitter=cj, temperature_jitter=tj, heat_cost=heat_cost, feed_cost=feed_cost,
            max_discs=max_discs, energy_bins=energy_bins, energy_edges=edges, grid=grid,
            observe_reactions=observe_reactions, activation_jitter=aj, reverse_jitter=rj,
            formation_jitter=fj, heating=heating, reward=reward,
            observe_outflow=observe_outflow, feed_temperature=feed_temperature,
            integrator=integrator, obs_names=tuple(obs_names),
            obs_low=np.array(lo, dtype=np.float32), obs_high=np.array(hi, dtype=np.float32),
            compiled=cs)

    # ---------------------------------------------------------------- spaces
    def observation_space(self) -> spaces.Box:
        return spaces.Box(self.obs_low.copy(), self.obs_high.copy(), dtype=np.float32)

    def action_space(self) -> spaces.Box:
        return spaces.Box(-1.0, 1.0, shape=(2 + len(self.feed),), dtype=np.float32)

    # ---------------------------------------------------------------- reset
    def draw_contents(self, np_random: np.random.Generator):
        """Initial ``{species: count}``, temperature and simulation seed, drawn from
        ``np_random`` in this fixed order (the single and the vector env share it)."""
        names = self.scene.species_names
        cj, tj = self.count_jitter, self.temperature_jitter
        counts = {}
        for k, t in enumerate(self.template):
            if t > 0:
                counts[names[k]] = int(round(t * np_random.uniform(1.0 - cj, 1.0 + cj)))
        temperature = self.scene.temperature * float(np_random.uniform(1.0 - tj, 1.0 + tj))
        seed = int(np_random.integers(0, 2**63 - 1))
        return counts, temperature, seed

    def new_simulation(self, np_random: np.random.Generator,
                       generator: np.random.Generator | None = None,
                       row: tuple | None = None) -> Simulation:
        """A fresh reactor with contents drawn from ``np_random``. Its own generator is
        seeded from ``np_random`` too; pass ``generator`` to have that one reseeded and used
        (the environments keep one generator object per reactor; one of another kind than
        PCG64 is replaced by a new PCG64), ``row`` = (state, r) to
        build it in row r of a :class:`~discgym.state.ReactorState`."""
        counts, temperature, seed = self.draw_contents(np_random)
        scene = self.draw_kinetics(np_random) if self.uncertain else self.scene
        if generator is None or type(generator.bit_generator) is not np.random.PCG64:
            # (a row's set_state may have given it another kind of bit generator)
            generator = np.random.Generator(np.random.PCG64(seed))
        else:
            generator.bit_generator.state = np.random.PCG64(seed).state
        sim = Simulation(scene, counts=counts, temperature=temperature, seed=generator,
                         integrator=self.integrator, row=row)
        sim.threads = 1
        return sim

    def draw_kinetics(self, np_random: np.random.Generator) -> Scene:
        """The scene with this episode's kinetics, drawn from ``np_random`` after the contents
        (:meth:`draw_contents`), in this order: one factor U[1 - activation_jitter,
        1 + activation_jitter] multiplying every combination's and exchange's activation
        energy (the temperature window of the chemistry moves with it), then every
        combination's reverse probability x 10 ** U[-reverse_jitter, reverse_jitter] (at most
        1), then every species' formation energy + U[-formation_jitter, formation_jitter]
        (a jitter of 0 draws nothing)."""
        scene = self.scene
        aj, rj, fj = self.activation_jitter, self.reverse_jitter, self.formation_jitter
        scale = float(np_random.uniform(1.0 - aj, 1.0 + aj)) if aj else 1.0
        reactions = []
        for r in scene.reactions:
            if isinstance(r, (Combination, Exchange)):
                ch = {}
                if aj:
                    ch["activation_energy"] = r.activation_energy * scale
                if rj and isinstance(r, Combination) and r.reverse_probability > 0.0:
                    ch["reverse_probability"] = min(1.0, r.reverse_probability * 10.0 ** float(
                        np_random.uniform(-rj, rj)))
                r = replace(r, **ch) if ch else r
            reactions.append(r)
        species = list(scene.species)
        if fj:
            species = [replace(sp, formation_energy=sp.formation_energy + float(
                np_random.uniform(-fj, fj))) for sp in species]
        return scene.replace(species=species, reactions=reactions)

    def draw_feed(self, np_random: np.random.Generator) -> tuple:
        """``(kT, kT_next, switch)``: the inlet temperature of the episode, the one it changes
        to and the step at which it does, drawn from ``np_random`` after the kinetics
        (:meth:`draw_kinetics`) when ``feed_temperature`` = (low, high) is set: both kT from
        U[low, high], the step uniform in [episode_steps / 3, 2 episode_steps / 3]. Without
        it, ``(nan, nan, -1)``: injected discs take the reactor's own kT, as in
        ``DiscReactor-v0``, and nothing is drawn."""
        if self.feed_temperature is None:
            return math.nan, math.nan, -1
        lo, hi = self.feed_temperature
        kT = float(np_random.uniform(lo, hi))
        kT_next = float(np_random.uniform(lo, hi))
        E = self.episode_steps
        switch = int(np_random.integers(E // 3, 2 * E // 3 + 1))
        return kT, kT_next, switch

    def kinetics(self, scene: Scene) -> tuple:
        """``(sp_form (S,), ch_rate (K,), ch_energy (K,))`` of a reactor of ``scene`` (this
        config's scene or one :meth:`draw_kinetics` gave), the rows of
        :class:`~discgym.kernels.structs.Episodes` the compiled step reads."""
        cs = compile_scene(scene)
        return cs.sp_form, cs.ch_rate, cs.ch_energy

    def n_ref(self, counts: np.ndarray) -> float:
        """The normaliser of the reward: the initial count of the limiting feed species."""
        return float(max(min(int(counts[f]) for f in self.feed), 1))

    def reset_row(self, ep: Episodes, r: int, sim: Simulation,
                  np_random: np.random.Generator) -> None:
        """The episode state of reactor ``r`` (row ``r`` of ``ep``) at the start of an
        episode, ``sim`` the reactor :meth:`new_simulation` just drew from ``np_random``:
        the one reset of the single and the vector env. Draws the inlet temperatures from
        ``np_random`` (:meth:`draw_feed`); the observation and the product count come from
        the observation that follows (:meth:`~discgym.core.EpisodeCore.observe`)."""
        ep.steps[r] = 0
        self.settings_row(ep, r)
        ep.size[r] = self.size_of(sim.bounds)
        ep.feed_left[r] = self.feed_budget
        ep.sp_form[r], ep.ch_rate[r], ep.ch_energy[r] = self.kinetics(sim.scene)
        ep.ch_last[r] = 0
        ep.out_last[r] = 0
        ep.feed_kT[r], ep.feed_kT_next[r], ep.feed_switch[r] = self.draw_feed(np_random)
        ep.n_init[r] = len(sim)
        ep.n_ref[r] = self.n_ref(np.bincount(sim.species, minlength=self.n_species))

    def row(self, defaults: dict, kwargs: Mapping, row: Mapping, who: str) -> ReactorConfig:
        """The configuration of one reactor of a batch made with this one from ``kwargs``:
        ``row`` sets some of :data:`ROW_ARGUMENTS` (anything else raises ``ValueError``);
        each value is checked as the env's own argument (the error naming ``who`` and it);
        the scene is this config's own object."""
        if not isinstance(row, Mapping):
            raise TypeError(f"{who}: expected a mapping of arguments, got "
                            f"{type(row).__name__}")
        bad = [k for k in row if k not in ROW_ARGUMENTS]
        if bad:
            raise ValueError(f"{who}: {bad[0]!r} cannot differ between the reactors of one "
                             f"batch (a reactor sets only {list(ROW_ARGUMENTS)})")
        try:
            cfg = ReactorConfig.from_kwargs(defaults, **{**kwargs, "scene": self.scene, **row})
        except (TypeError, ValueError) as e:
            raise type(e)(f"{who}: {e}") from None
        self.check_batch(cfg, None, None, who)
        return cfg

    def check_batch(self, other: ReactorConfig, low, high, who: str) -> None:
        """Refuse ``other`` as a reactor of this config's batch of observation bounds
        ``low``, ``high`` (None: not checked): another layout, or bounds outside them
        (``ValueError`` naming ``who`` and what differs)."""
        for f in _SHARED:
            a, b = getattr(other, f), getattr(self, f)
            if not (np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b):
                raise ValueError(f"{who}: its {f} ({a!r}) is not the batch's ({b!r})")
        if low is None:
            return
        out = np.flatnonzero((other.obs_low < low) | (other.obs_high > high))
        if len(out):
            k = out[0]
            raise ValueError(
                f"{who}: its observation slot {self.obs_names[k]!r} spans "
                f"[{other.obs_low[k]:g}, {other.obs_high[k]:g}], outside the batch's "
                f"[{low[k]:g}, {high[k]:g}]; give the vector env's own arguments the widest "
                "ranges its reactors draw (size_range, temperature_range)")

    def settings_row(self, ep: Episodes, r: int) -> None:
        """This configuration's settings that each reactor of a batch may have on its own,
        as row ``r`` of ``ep`` (what the compiled step reads)."""
        ep.heat_rate[r], ep.t_min[r], ep.t_max[r] = self.heat_rate, self.t_min, self.t_max
        ep.size_min[r], ep.size_max[r] = self.size_min, self.size_max
        ep.wall_speed[r], ep.inject_max[r] = self.wall_speed, self.inject_max
        ep.episode_steps[r], ep.feed_budget[r] = self.episode_steps, self.feed_budget
        ep.heat_cost[r], ep.feed_cost[r] = self.heat_cost, self.feed_cost

    # ---------------------------------------------------------------- reward
    def reward_terms(self, product, product_before, outflow, heat, injected, n_ref,
                     costs: tuple | None = None) -> tuple:
        """``(gain, cost_heat, cost_feed, reward)`` of a step: the one reward of the single
        env (floats) and the vector env (arrays (R,), the same expressions element-wise, so
        the same bits). ``product`` and ``product_before`` the product count after and
        before the step, ``outflow`` the product discs that left through the outlets
        during it, ``heat`` the heat put in, ``injected`` the discs injected (all feed
        species), ``n_ref`` :meth:`n_ref`; ``costs`` ``(heat_cost, feed_cost)``, by default
        this config's (arrays (R,) for a batch whose reactors have their own)."""
        if self.reward == "outflow":
            gain = outflow / n_ref
        else:
            gain = (product - product_before) / n_ref
        heat_cost, feed_cost = (self.heat_cost, self.feed_cost) if costs is None else costs
        cost_heat = heat_cost * abs(heat) / n_ref
        cost_feed = feed_cost * injected / n_ref
        return gain, cost_heat, cost_feed, gain - cost_heat - cost_feed

    # ---------------------------------------------------------------- info
    @cached_property
    def info_types(self) -> dict:
        """``{key: dtype}`` of ``info``, in order: the same flat keys at reset and at every
        step, each one number with a numpy dtype (TorchRL's info reader needs a ``dtype``):
        an ``np.int64`` or ``np.float64`` scalar, or for ``np.bool_`` a 0-d bool array
        (Gymnasium's ``SyncVectorEnv`` batches a numpy bool scalar as an object array, a 0-d
        array as a bool array), so that every RL library's info reader takes them (TorchRL's,
        RLlib's ``DictInfoToList``, SB3's; Gymnasium's vector envs batch them as arrays of
        that dtype). Per-species keys are named after the species:
        ``count_<species>`` (discs after the step), ``injected_<feed species>`` and
        ``inject_refused_<feed species>`` (discs placed / not placed this step). A new task
        adds its keys here and in :meth:`info_values`."""
        names = self.species_names
        fed = [names[f] for f in self.feed]
        i, f, b = np.int64, np.float64, np.bool_
        return dict(
            [(f"count_{nm}", i) for nm in names]
            + [("product", i), ("yield", f), ("reward_product", f), ("cost_heat", f),
               ("cost_feed", f), ("heat_energy", f), ("temperature", f), ("size", f)]
            + [(f"injected_{nm}", i) for nm in fed]
            + [(f"inject_refused_{nm}", i) for nm in fed]
            + [("wall_blocked", b), ("invalid_action", i), ("time", f), ("n_ref", f)])

    @property
    def info_keys(self) -> tuple:
        """The keys of ``info`` (see :attr:`info_types`)."""
        return tuple(self.info_types)

    def info_values(self, counts, product, yield_, reward_product, cost_heat, cost_feed,
                    heat_energy, temperature, size, injected, refused, wall_blocked,
                    invalid_action, time, n_ref, *, batch: bool = False) -> dict:
        """``info`` from its values, in the order of :attr:`info_types`, each converted to
        its dtype: numbers for the single env, or (``batch``) fresh arrays of one entry per
        reactor for the vector env; ``counts`` one value per species, ``injected`` and
        ``refused`` one per feed species."""
        values = [*counts, product, yield_, reward_product, cost_heat, cost_feed,
                  heat_energy, temperature, size, *injected, *refused, wall_blocked,
                  invalid_action, time, n_ref]
        if len(values) != len(self.info_types):
            raise ValueError(f"info_values: {len(values)} values for "
                             f"{len(self.info_types)} keys")
        if batch:
            return {k: np.array(v, dtype=t) for (k, t), v in
                    zip(self.info_types.items(), values)}
        return {k: cast(v) for (k, cast), v in zip(self._info_casts, values)}

    @cached_property
    def _info_casts(self) -> tuple:
        """``(key, conversion)`` of each entry of a single env's info, in order (built once:
        the conversions are a share of a step's Python)."""
        return tuple((k, _bool_0d if t is np.bool_ else t) for k, t in self.info_types.items())

    def size_of(self, bounds) -> float:
        ref = self.scene.bounds
        if isinstance(ref, Box):
            return bounds.width / ref.width
        return bounds.radius / ref.radius

    def bounds_of(self, size: float):
        return bounds_of(self.scene, size)

    def read_size(self, bounds, size: float, who: str) -> float:
        """The wall's size for ``bounds``, which ``resize`` or ``set_state`` gave a reactor's
        Simulation from outside (the state's ``touched`` rows tell the envs when), the env
        having held ``size``: ``size`` if they are still its bounds (``bounds_of(size)``: a
        copy, a state of the same size), else theirs, so that the ``size`` observation and the
        next wall move start from the bounds the reactor has. The wall sets a box's width (the
        scene's height and origin kept) or a circle's radius (its centre kept) to the size x
        the scene's, within ``size_range``; other bounds (another kind, height, origin or
        centre, or a size outside ``size_range``) are refused with ``RuntimeError`` naming
        them, before anything is stepped, rather than reshaped or clipped by the next wall
        move (the size observation would no longer describe the reactor): resize back, set
        another state or reset."""
        if bounds == self.bounds_of(size):
            return size
        ref = self.scene.bounds
        box = isinstance(ref, Box)
        length = "width" if box else "radius"
        if type(bounds) is not type(ref):
            why = f"a {bounds.kind}, not a {ref.kind}"
        elif box and (bounds.height, bounds.origin) != (ref.height, ref.origin):
            why = (f"height {bounds.height} and origin {bounds.origin}, not the scene's "
                   f"{ref.height} and {ref.origin}")
        elif not box and bounds.center != ref.center:
            why = f"centre {bounds.center}, not the scene's {ref.center}"
        else:
            # (in lengths: the bounds of the range's ends, as the wall makes them, are in it)
            x = getattr(bounds, length)
            lo = getattr(self.bounds_of(self.size_min), length)
            hi = getattr(self.bounds_of(self.size_max), length)
            if lo <= x <= hi:
                return min(max(self.size_of(bounds), self.size_min), self.size_max)
            why = (f"size {self.size_of(bounds):.6g} (its {length} / the scene's), outside "
                   f"size_range ({self.size_min:g}, {self.size_max:g})")
        raise RuntimeError(
            f"bounds: {who} was given {bounds} from outside (resize or set_state): {why}. The "
            f"env's wall sets the {length} of the scene's {ref} to size x the scene's, the "
            f"size within size_range ({self.size_min:g}, {self.size_max:g}), and cannot take "
            "these bounds over; resize to such bounds, set a state with them, or reset")


def _bool_0d(v) -> np.ndarray:
    return np.array(v, dtype=np.bool_)


def _contents(scene: Scene, o: dict) -> tuple:
    """``(count_jitter, temperature_jitter, template, n_discs, most)``: the initial contents
    (the scene's counts, rescaled to ``n_discs``) and the largest a reset can draw, checked
    to be placeable."""
    names = scene.species_names
    S = len(names)
    cj = real(o["count_jitter"], "count_jitter", 0.0, 1.0, hi_open=True)
    tj = real(o["temperature_jitter"], "temperature_jitter", 0.0, 1.0, hi_open=True)
    template = np.array([scene.counts.get(nm, 0) for nm in names], dtype=np.int64)
    if template.sum() == 0:
        raise ValueError("scene: the scene has no initial contents (counts; n_discs "
                         "only rescales them)")
    n_discs = o["n_discs"]
    if n_discs is not None:
        n_discs = whole(n_discs, "n_discs", 1)
        # (before the float arithmetic of the rescaling: no more than the densest packing
        # of the smallest discs present could hold)
        r_small = min(scene.species[k].radius for k in range(S) if template[k])
        if n_discs > HEX_PACKING * scene.bounds.area / (math.pi * r_small * r_small):
            raise ValueError(
                f"n_discs: {n_discs} discs cannot fit in the scene's bounds "
                f"{scene.bounds} (more than the densest packing of its smallest discs)")
        template = np.round(template * (n_discs / template.sum())).astype(np.int64)
        if template.sum() == 0:
            raise ValueError(f"n_discs: {n_discs} disc(s) spread over the scene's counts "
                             f"{dict(scene.counts)} round to none")
    # the largest contents a reset can draw must fit (the placement of Simulation)
    most = [int(math.floor(t * (1.0 + cj) + 0.5)) for t in template]
    check_placeable(scene, most, "n_discs" if n_discs is not None else "count_jitter")

    return cj, tj, template, n_discs, most


def _size_range(scene: Scene, o: dict) -> tuple[float, float]:
    """``size_range``, checked: it contains 1, and the reactor at each end is valid bounds."""
    size_min, size_max = pair(o["size_range"], "size_range")
    if not size_min <= 1.0 <= size_max:
        raise ValueError(f"size_range: must contain 1 (the scene's size, at which every "
                         f"episode starts), got {o['size_range']!r}")
    if size_max > _FLOAT32_MAX:
        raise ValueError(f"size_range: the high end {size_max} is beyond float32 (the "
                         "observation's dtype)")
    for s in (size_min, size_max):
        try:
            b = bounds_of(scene, s)
            # the sizes the compiled wall reaches must be bounds a simulation can hold
            check_bounds_scale(b, scene.species, "bounds", "species")
        except SceneError as e:
            raise ValueError(f"size_range: the reactor at size {s} is not valid bounds: "
                             f"{e}") from None
        if not math.isfinite(b.area):
            raise ValueError(f"size_range: the reactor at size {s} has an infinite area")
    return size_min, size_max


def _heating(scene: Scene, o: dict, t_min: float, t_max: float) -> str:
    """``heating``, checked against the scene (a jacket needs thermal walls) and
    ``temperature_range`` (a jacket's range must be wall temperatures it can map)."""
    heating = choice(o["heating"], "heating", HEATINGS)
    if heating == "jacket":
        if not scene.thermal_walls:
            raise ValueError("heating: 'jacket' sets the temperature of the scene's thermal "
                             "walls, and the scene has none (Scene(thermal_walls=...))")
        if t_max > scene.max_wall_temperature():
            raise ValueError(
                f"temperature_range: with heating='jacket' the high end {t_max} is a wall "
                f"temperature, above the hottest a thermal wall of this scene may be "
                f"({scene.max_wall_temperature():.4g})")
        if not math.isfinite(t_max / t_min):
            raise ValueError(
                f"temperature_range: with heating='jacket' the jacket is set to low x "
                f"(high / low) ** ((a + 1) / 2), and high / low = {t_max} / {t_min} "
                f"overflows float64 (need high / low <= {sys.float_info.max!r})")
        if t_max > _FLOAT32_MAX:
            raise ValueError(
                f"temperature_range: with heating='jacket' the high end {t_max} is the "
                f"bound of the jacket_kT observation, beyond float32 (the observation's "
                f"dtype)")
    return heating


def _product_and_feed(scene: Scene, o: dict) -> tuple[int, tuple]:
    """The species indices of ``o["product"]`` and ``o["feed"]`` (checked; by default the
    product and the reactants of the scene's first combination or exchange)."""
    names = scene.species_names

    def index(what, nm):
        if not isinstance(nm, str):
            raise TypeError(f"{what}: expected a species name, got {nm!r}")
        if nm not in names:
            raise ValueError(f"{what}: unknown species {nm!r} (scene has {names})")
        return names.index(nm)

    first = next((r for r in scene.reactions if isinstance(r, (Combination, Exchange))),
                 None)
    product = o["product"]
    if product is None:
        if first is None:
            raise ValueError("product: the scene has no combination or exchange reaction; "
                             "name the product species")
        product = first.products[0]
    product = index("product", product)
    feed = o["feed"]
    if feed is None:
        if first is None:
            raise ValueError("feed: the scene has no combination or exchange reaction; "
                             "name the feed species")
        feed = first.reactants
    elif isinstance(feed, str):
        feed = (feed,)
    elif isinstance(feed, (list, tuple)) or (isinstance(feed, np.ndarray) and
                                             feed.ndim == 1):
        feed = tuple(feed)
    else:
        raise TypeError(f"feed: expected a species name or a list of them, got {feed!r}")
    if not feed:
        raise ValueError("feed: need at least one feed species (the reward is divided by "
                         "the initial count of the limiting one)")
    feed = tuple(index("feed", f) for f in feed)
    if len(set(feed)) != len(feed):
        raise ValueError(f"feed: species repeated in {o['feed']!r}")
    return product, feed


def _feed_budget(scene: Scene, o: dict, feed: tuple, template: np.ndarray,
                 size_max: float) -> np.ndarray:
    """``o["feed_budget"]`` as (F,) int64, checked (default: a quarter of each feed species'
    template count, or of the mean count for a species absent from it)."""
    budget = o["feed_budget"]
    names = scene.species_names
    S = len(names)
    mass = [sp.mass for sp in scene.species]
    if budget is None:
        mean = template.sum() / max(S, 1)
        feed_budget = np.array([int(math.ceil(0.25 * (template[f] if template[f]
                                                      else mean))) for f in feed],
                               dtype=np.int64)
    else:
        if isinstance(budget, (list, tuple)) or (isinstance(budget, np.ndarray) and
                                                 budget.ndim == 1):
            budget = list(budget)
            if len(budget) != len(feed):
                raise ValueError(f"feed_budget: need one budget per feed species "
                                 f"({len(feed)}), got {o['feed_budget']!r}")
        elif isinstance(budget, np.ndarray) and budget.ndim > 1:
            raise ValueError(f"feed_budget: need a number or one per feed species "
                             f"({len(feed)}), got an array of shape {budget.shape}")
        else:
            budget = [budget] * len(feed)
        # a reactor can never hold more mass than discs of the densest mass per area
        # covering its largest area: a budget beyond that could never be injected
        m_cap = bounds_of(scene, size_max).area * max(
            sp.mass / (math.pi * sp.radius * sp.radius) for sp in scene.species)
        feed_budget = np.array(
            [whole(b, "feed_budget", 0, int(m_cap / mass[f]),
                    f"more discs of {names[f]} than the reactor can ever hold (its "
                    f"largest area, size {size_max}, filled at the densest mass per area)")
             for b, f in zip(budget, feed)], dtype=np.int64)
    return feed_budget
