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

The per-reactor logic (:class:`ReactorConfig` and the compiled
:func:`~discgym.kernels.batch.reactor_step`) is shared with the batched
:class:`discgym.vector.DiscReactorVectorEnv`, so that a reactor of the batch follows exactly
the trajectory of a lone environment with the same seed and actions.
"""

from __future__ import annotations

import copy
import math
import numbers
import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import cached_property, partial

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .compiled import P_MAXDISP, P_RMIN, CompiledScene, compile_scene, kernel_bounds
from .kernels import helper as compile_helper
from .kernels.batch import (
    O_BLOCKED,
    O_ENERGY_HEAT,
    O_HEAT,
    O_INVALID,
    O_STATUS,
    env_step,
    observe_batch,
)
from .kernels.step import MAX_SUBSTEPS, REORDER_EVERY
from .kernels.structs import (
    FLOAT,
    INDEX,
    Episodes,
    ReactorConsts,
    Reactors,
    capacity_for_discs,
    speed_limit,
)
from .scene import (
    HEX_PACKING,
    Box,
    Circle,
    Combination,
    Exchange,
    Scene,
    SceneError,
    check_bounds_scale,
)
from .simulation import PLACEMENT_ATTEMPTS, Simulation, _as_scene, _event_fit, _inside

__all__ = [
    "DiscReactorEnv",
    "ReactorConfig",
    "register_envs",
    "ENV_ID",
    "DEFAULTS",
]

ENV_ID = "DiscReactor-v0"

#: Default keyword arguments of :class:`DiscReactorEnv` (and of ``gymnasium.make``).
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

#: Observations are clipped to these bounds (see the README, "Observation Space").
OBS_ENERGY_MAX = 20.0  # per-species kT, mean internal energy, |total energy per disc|
OBS_DISCS_MAX = 4.0  # discs now / discs at reset
OBS_YIELD_MAX = 4.0  # product / limiting reactant at reset
OBS_RATE_MAX = 4.0  # reactions of one channel in one step / limiting reactant at reset
#: The most bins of the kinetic-energy histogram and cells per side of the spatial one.
MAX_ENERGY_BINS = 32
MAX_GRID = 16

#: The kernels count steps (and discs) in int64.
INT_MAX = 2**63 - 1
INT_MAX_TEXT = "2**63 - 1"
#: Whole numbers a float64 holds exactly (the kernel computes round(a * inject_max) in float64).
FLOAT_EXACT = 2**53
#: The smallest normal float64. A range's ends must be at least this: a subnormal has fewer
#: significant bits and its reciprocal overflows (1 / 1e-310 is inf), so the maps that divide
#: by an end or take a ratio of the ends (the heat control's clamps, the jacket's log-uniform
#: map, a controller inverting them) would give inf or NaN.
FLOAT_NORMAL_MIN = float(np.finfo(np.float64).tiny)
#: The largest ``heat_rate``: ``heat_rate ** a`` for every action a in [-1, 1] is a normal
#: float (at -1 its reciprocal, at least FLOAT_NORMAL_MIN).
HEAT_RATE_MAX = 1.0 / FLOAT_NORMAL_MIN
#: Largest ``render_size`` (the renderer's scratch is ~40 bytes a pixel: ~0.7 GB at 4096).
MAX_RENDER_SIZE = 4096
#: Initial contents covering more of the area than this are not reliably placed by random
#: addition (its jamming limit for equal discs is 0.547); above it they must also fit the
#: hexagonal lattice that ``Simulation`` falls back to.
RANDOM_PLACEMENT_SHARE = 0.5
_FLOAT32_MAX = float(np.finfo(np.float32).max)
_COST_SCALE = 1e300  # a step's cost terms stay below this (a margin under the float range)
# bytes per disc of capacity: the state arrays (52) and the stepper's scratch of a lone
# Simulation (the single env), or the state arrays only (the vector env, per reactor)
_SLOT_BYTES_SINGLE = 192
SLOT_BYTES_BATCH = 64

_ONE = np.ones(1, dtype=bool)  # the "active" mask of a batch of one reactor
_NON_INTERACTIVE = {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"}


# --------------------------------------------------------------------------------------------
# configuration shared by the single and the vector environment


@dataclass(frozen=True, eq=False)
class ReactorConfig:
    """The validated settings of a reactor environment (see :data:`DEFAULTS`).

    Built by :meth:`from_kwargs`; read by :class:`DiscReactorEnv` and
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
        return capacity_for_discs(_most_discs(mass, float(m.min()))), mass

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
            heat_rate=float(self.heat_rate), t_min=float(self.t_min),
            t_max=float(self.t_max), size_min=float(self.size_min),
            size_max=float(self.size_max), wall_speed=float(self.wall_speed),
            speed_limit=float(speed_limit(MAX_SUBSTEPS, cs.params[P_MAXDISP],
                                          cs.params[P_RMIN], self.scene.dt)),
            ref_bounds=np.array(r4, dtype=FLOAT), temperature=float(self.scene.temperature),
            dt=float(self.scene.dt), packing=float(HEX_PACKING),
            inject_max=int(self.inject_max), steps_per_action=int(self.steps_per_action),
            attempts=int(PLACEMENT_ATTEMPTS), reorder_every=int(REORDER_EVERY),
            product=int(self.product), episode_steps=int(self.episode_steps),
            feed=np.array(self.feed, dtype=INDEX), feed_budget=self.feed_budget,
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
        docstring of :class:`DiscReactorEnv`, section Arguments): a bad one raises
        ``TypeError`` (wrong type) or ``ValueError`` (out of range) naming it. ``defaults``:
        a task's defaults (every key of :data:`DEFAULTS`), :data:`DEFAULTS` if None."""
        defaults = DEFAULTS if defaults is None else defaults
        check_keywords("ReactorConfig.from_kwargs", kw, defaults)
        o = dict(defaults)
        o.update(kw)
        scene = _scene(o["scene"])
        names = scene.species_names
        S = len(names)

        product, feed = _product_and_feed(scene, o)

        cj = _real(o["count_jitter"], "count_jitter", 0.0, 1.0, hi_open=True)
        tj = _real(o["temperature_jitter"], "temperature_jitter", 0.0, 1.0, hi_open=True)
        template = np.array([scene.counts.get(nm, 0) for nm in names], dtype=np.int64)
        if template.sum() == 0:
            raise ValueError("scene: the scene has no initial contents (counts; n_discs "
                             "only rescales them)")
        n_discs = o["n_discs"]
        if n_discs is not None:
            n_discs = _whole(n_discs, "n_discs", 1)
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
        _check_placeable(scene, most, "n_discs" if n_discs is not None else "count_jitter")

        episode_steps = _whole(o["episode_steps"], "episode_steps", 1)
        spa = _steps_per_action(o["step_time"], scene.dt)
        if spa > INT_MAX // episode_steps:
            raise ValueError(
                f"episode_steps, step_time: an episode of {episode_steps} steps of {spa} x dt "
                f"is more steps than the simulation's step counter holds ({INT_MAX_TEXT}); at "
                f"this step_time, episode_steps <= {INT_MAX // spa}")
        heat_rate = _real(o["heat_rate"], "heat_rate", 1.0, HEAT_RATE_MAX,
                          why="the factor at action -1, 1 / heat_rate, must be a normal "
                              "float64")
        t_min, t_max = _pair(o["temperature_range"], "temperature_range")
        size_min, size_max = _pair(o["size_range"], "size_range")
        if not size_min <= 1.0 <= size_max:
            raise ValueError(f"size_range: must contain 1 (the scene's size, at which every "
                             f"episode starts), got {o['size_range']!r}")
        if size_max > _FLOAT32_MAX:
            raise ValueError(f"size_range: the high end {size_max} is beyond float32 (the "
                             "observation's dtype)")
        for s in (size_min, size_max):
            try:
                b = _bounds_of(scene, s)
                # the sizes the compiled wall reaches must be bounds a simulation can hold
                check_bounds_scale(b, scene.species, "bounds", "species")
            except SceneError as e:
                raise ValueError(f"size_range: the reactor at size {s} is not valid bounds: "
                                 f"{e}") from None
            if not math.isfinite(b.area):
                raise ValueError(f"size_range: the reactor at size {s} has an infinite area")
        wall_speed = _real(o["wall_speed"], "wall_speed", 0.0)
        inject_max = _whole(o["inject_max"], "inject_max", 0, FLOAT_EXACT,
                            "2**53: round(a * inject_max) is computed in float64")
        mass = [sp.mass for sp in scene.species]
        feed_budget = _feed_budget(scene, o, feed, template, size_max)
        # the most discs a reactor can ever hold: reactions conserve mass, so at most the
        # largest initial contents plus every feed budget, all split into the lightest species
        total_mass = sum(c * m for c, m in zip(most, mass)) + \
            sum(int(b) * mass[f] for b, f in zip(feed_budget, feed))
        max_discs = _most_discs(total_mass, min(mass))
        capacity = capacity_for_discs(max_discs)
        _check_memory(capacity * _SLOT_BYTES_SINGLE, "n_discs, feed_budget",
                      f"a reactor's capacity plan of {capacity} discs")
        # costs: a step's cost must stay finite (energies bounded by the speed limit, a
        # disc's chemistry, the capacity; injections by inject_max)
        cs = compile_scene(scene)
        v_lim = speed_limit(MAX_SUBSTEPS, cs.params[P_MAXDISP], cs.params[P_RMIN], scene.dt)
        e_disc = max(mass) * v_lim * v_lim + 2.0 * max(
            abs(sp.formation_energy) for sp in scene.species) + 1.0
        why = "a larger cost could make a step's reward overflow"
        heat_cost = _real(o["heat_cost"], "heat_cost", 0.0, _COST_SCALE / (capacity * e_disc),
                          why=why)
        feed_cost = _real(o["feed_cost"], "feed_cost", 0.0,
                          _COST_SCALE / (len(feed) * max(inject_max, 1)), why=why)

        energy_bins = _whole(o["energy_bins"], "energy_bins", 0, MAX_ENERGY_BINS)
        if energy_bins == 1:
            raise ValueError("energy_bins: need 0 (no histogram) or at least 2 bins, got 1")
        grid = _whole(o["spatial_grid"], "spatial_grid", 0, MAX_GRID)
        observe_reactions = _flag(o["observe_reactions"], "observe_reactions")
        aj = _real(o["activation_jitter"], "activation_jitter", 0.0, 1.0, hi_open=True)
        rj = _real(o["reverse_jitter"], "reverse_jitter", 0.0, 3.0,
                   why="a factor of 10 ** 3 either way")
        fj = _real(o["formation_jitter"], "formation_jitter", 0.0, 1e3)
        heating = _choice(o["heating"], "heating", HEATINGS)
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
        reward = _choice(o["reward"], "reward", REWARDS)
        if reward == "outflow" and not scene.outlets:
            raise ValueError("reward: 'outflow' rewards the product leaving through the scene's "
                             "outlets, and the scene has none (Scene(outlets=...))")
        observe_outflow = _flag(o["observe_outflow"], "observe_outflow")
        feed_temperature = o["feed_temperature"]
        if feed_temperature is not None:
            feed_temperature = _pair(feed_temperature, "feed_temperature")
            hottest = scene.max_wall_temperature()
            if feed_temperature[1] > hottest:
                raise ValueError(f"feed_temperature: {feed_temperature[1]} would inject discs "
                                 f"beyond the speed limit (at most {hottest:.4g})")
        integrator = _choice(o["integrator"], "integrator", INTEGRATORS)
        if integrator == "event":
            _check_event_fit(scene, size_min)
        edges = energy_edges(scene, energy_bins)
        obs_names, lo, hi = _observation_slots(names, feed, size_min, size_max)
        _extra_slots(obs_names, lo, hi, names, energy_bins, edges, grid,
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
                       generator: np.random.Generator | None = None) -> Simulation:
        """A fresh reactor with contents drawn from ``np_random``. Its own generator is
        seeded from ``np_random`` too; pass ``generator`` to have that one reseeded and used
        (the vector env keeps one generator object per reactor)."""
        counts, temperature, seed = self.draw_contents(np_random)
        scene = self.draw_kinetics(np_random) if self.uncertain else self.scene
        if generator is None:
            generator = np.random.Generator(np.random.PCG64(seed))
        else:
            generator.bit_generator.state = np.random.PCG64(seed).state
        sim = Simulation(scene, counts=counts, temperature=temperature, seed=generator,
                         integrator=self.integrator)
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
        the observation that follows (:func:`observe`)."""
        ep.steps[r] = 0
        ep.size[r] = self.size_of(sim.bounds)
        ep.feed_left[r] = self.feed_budget
        ep.sp_form[r], ep.ch_rate[r], ep.ch_energy[r] = self.kinetics(sim.scene)
        ep.ch_last[r] = 0
        ep.out_last[r] = 0
        ep.feed_kT[r], ep.feed_kT_next[r], ep.feed_switch[r] = self.draw_feed(np_random)
        ep.n_init[r] = len(sim)
        ep.n_ref[r] = self.n_ref(np.bincount(sim.species, minlength=self.n_species))

    # ---------------------------------------------------------------- reward
    def reward_terms(self, product, product_before, outflow, heat, injected, n_ref) -> tuple:
        """``(gain, cost_heat, cost_feed, reward)`` of a step: the one reward of the single
        env (floats) and the vector env (arrays (R,), the same expressions element-wise, so
        the same bits). ``product`` and ``product_before`` the product count after and
        before the step, ``outflow`` the product discs that left through the outlets
        during it, ``heat`` the heat put in, ``injected`` the discs injected (all feed
        species), ``n_ref`` :meth:`n_ref`."""
        if self.reward == "outflow":
            gain = outflow / n_ref
        else:
            gain = (product - product_before) / n_ref
        cost_heat = self.heat_cost * abs(heat) / n_ref
        cost_feed = self.feed_cost * injected / n_ref
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
        types = self.info_types
        if batch:
            return {k: np.array(v, dtype=types[k])
                    for k, v in zip(types, values, strict=True)}
        return {k: np.array(v, dtype=np.bool_) if types[k] is np.bool_ else types[k](v)
                for k, v in zip(types, values, strict=True)}

    def size_of(self, bounds) -> float:
        ref = self.scene.bounds
        if isinstance(ref, Box):
            return bounds.width / ref.width
        return bounds.radius / ref.radius

    def bounds_of(self, size: float):
        return _bounds_of(self.scene, size)

    def read_size(self, bounds, size: float, who: str) -> float:
        """The wall's size for ``bounds``, which ``resize`` or ``set_state`` gave a reactor's
        Simulation from outside (``Simulation.export_scalars`` tells the envs when), the env
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
        m_cap = _bounds_of(scene, size_max).area * max(
            sp.mass / (math.pi * sp.radius * sp.radius) for sp in scene.species)
        feed_budget = np.array(
            [_whole(b, "feed_budget", 0, int(m_cap / mass[f]),
                    f"more discs of {names[f]} than the reactor can ever hold (its "
                    f"largest area, size {size_max}, filled at the densest mass per area)")
             for b, f in zip(budget, feed)], dtype=np.int64)
    return feed_budget


def _observation_slots(names, feed: tuple, size_min: float, size_max: float) -> tuple:
    """``(names, low, high)`` of the observation's slots (see :func:`observe`). Every slot's
    range contains 0: TorchRL fills the final observation of a vector env's reactors that did
    not finish with zeros and checks them against the space."""
    obs_names, lo, hi = [], [], []

    def slot(name, low, high):
        obs_names.append(name)
        lo.append(low)
        hi.append(high)

    for nm in names:
        slot(f"fraction_{nm}", 0.0, 1.0)
    for nm in names:
        slot(f"kT_{nm}", 0.0, OBS_ENERGY_MAX)
    for nm in names:
        slot(f"internal_{nm}", 0.0, OBS_ENERGY_MAX)
    slot("energy_per_disc", -OBS_ENERGY_MAX, OBS_ENERGY_MAX)
    slot("discs", 0.0, OBS_DISCS_MAX)
    slot("yield", 0.0, OBS_YIELD_MAX)
    # (the size never goes below size_min; a low of 0 clips to the same float32 values:
    # rounding to float32 is monotone and float32(size_min) is the rounded size_min)
    slot("size", 0.0, size_max)
    slot("time_left", 0.0, 1.0)
    for f in feed:
        slot(f"feed_left_{names[f]}", 0.0, 1.0)
    return obs_names, lo, hi


def energy_edges(scene: Scene, bins: int) -> np.ndarray:
    """The inner edges (B - 1,) of the kinetic-energy histogram of B bins, relative to the
    scene's activation energies: the distinct positive activation energies E_1 < E_2 < ...
    of its combinations and exchanges are edges (the tail above a barrier is what decides a
    reaction's rate), preceded by E_1 / 2, E_1 / 4, ... for the remaining edges (B - 1 fewer
    than the barriers: the lowest B - 1 of them). A scene without barriers uses its kT x 4
    as E_1."""
    if bins == 0:
        return np.zeros(0, dtype=FLOAT)
    barriers = sorted({float(r.activation_energy) for r in scene.reactions
                       if isinstance(r, (Combination, Exchange)) and r.activation_energy > 0})
    if not barriers:
        barriers = [4.0 * scene.temperature]
    m = bins - 1
    if m <= len(barriers):
        edges = barriers[:m]
    else:
        below = m - len(barriers)
        edges = [barriers[0] / 2.0 ** j for j in range(below, 0, -1)] + barriers
    return np.array(edges, dtype=FLOAT)


def _extra_slots(obs_names, lo, hi, names, bins, edges, grid, labels, *, jacket=False,
                 t_max=0.0, feed_kT=False, outflow=False) -> None:
    """Append the optional blocks' slots (see :func:`discgym.kernels.batch.observe_one`)."""
    def slot(name, low, high):
        obs_names.append(name)
        lo.append(low)
        hi.append(high)

    if jacket:
        slot("jacket_kT", 0.0, t_max)
    if feed_kT:
        slot("feed_kT", 0.0, OBS_ENERGY_MAX)
    if outflow:
        for nm in names:
            slot(f"outflow_{nm}", 0.0, OBS_RATE_MAX)

    for nm in names:
        for b in range(bins):
            a = "0" if b == 0 else f"{edges[b - 1]:g}"
            z = "inf" if b == bins - 1 else f"{edges[b]:g}"
            slot(f"energy_{nm}[{a},{z})", 0.0, 1.0)
    for nm in names:
        for j in range(grid):
            for i in range(grid):
                slot(f"cell_{nm}_{i}_{j}", 0.0, 1.0)
    for j in range(grid):
        for i in range(grid):
            slot(f"cell_kT_{i}_{j}", 0.0, OBS_ENERGY_MAX)
    for lab in labels:
        slot(f"reactions[{lab}]", 0.0, OBS_RATE_MAX)


def _choice(v, name: str, choices: tuple) -> str:
    if not isinstance(v, str):
        raise TypeError(f"{name}: expected one of {list(choices)}, got {v!r}")
    if v not in choices:
        raise ValueError(f"{name}: expected one of {list(choices)}, got {v!r}")
    return v


def _flag(v, name: str) -> bool:
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    raise TypeError(f"{name}: expected True or False, got {v!r} ({type(v).__name__})")


def _most_discs(mass: float, lightest: float) -> int:
    """The most discs a total ``mass`` can be split into (discs of mass ``lightest``)."""
    return int(math.floor(mass / lightest * (1.0 + 1e-12)))


def with_config(owner: str, config, kwargs: dict) -> dict:
    """The keyword arguments of a constructor called as ``Env(config, **kwargs)``: the
    mapping ``config`` (RLlib passes its ``EnvContext``, a dict, as the only positional
    argument) merged with ``kwargs``; a key in both raises Python's own ``TypeError``."""
    if config is None:
        return kwargs
    if not isinstance(config, Mapping):
        raise TypeError(f"config: {owner}() takes keyword arguments, or a mapping of them "
                        f"(e.g. RLlib's EnvContext) as its only positional argument, got "
                        f"{config!r} ({type(config).__name__})")
    merged = {}
    for k, v in config.items():
        if not isinstance(k, str):
            raise TypeError(f"config: keys must be argument names (str), got {k!r}")
        merged[k] = v
    for k, v in kwargs.items():
        if k in merged:
            raise TypeError(f"{owner}() got multiple values for argument {k!r}")
        merged[k] = v
    return merged


def check_keywords(owner: str, kw, allowed) -> None:
    """Refuse an unknown keyword argument with Python's own wording (which TorchRL and
    others recognise): ``DiscReactorEnv.__init__() got an unexpected keyword argument
    'frameskip'``."""
    for k in kw:
        if k not in allowed:
            raise TypeError(f"{owner}() got an unexpected keyword argument {k!r}")


def _number(v, name: str, what: str = "a number"):
    """``v`` if it is a real number (Python or numpy, or a 0-d array of one; not a bool),
    else ``TypeError`` naming ``name``."""
    if isinstance(v, np.ndarray) and v.ndim == 0:
        v = v[()]
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise TypeError(f"{name}: expected {what}, got {v!r} ({type(v).__name__})")
    return v


def _int_text(k: int) -> str:
    return INT_MAX_TEXT if k == INT_MAX else str(k)


def _whole(v, name: str, lo: int, hi: int = INT_MAX, why: str = "") -> int:
    """``v`` as an int in [lo, hi]: an integer or an integral float (numpy too)."""
    v = _number(v, name, "a whole number")
    if isinstance(v, numbers.Integral):
        k = int(v)
    else:
        f = float(v)
        if not math.isfinite(f) or not f.is_integer():
            raise ValueError(f"{name}: need a finite whole number, got {v!r}")
        k = int(f)
    if not lo <= k <= hi:
        more = f" ({why})" if why and k > hi else ""
        raise ValueError(f"{name}: need a whole number in [{lo}, {_int_text(hi)}], got "
                         f"{v!r}{more}")
    return k


def _real(v, name: str, lo: float = -math.inf, hi: float = math.inf, *,
          hi_open: bool = False, why: str = "") -> float:
    """``v`` as a finite float in [lo, hi] (or [lo, hi) with ``hi_open``)."""
    v = _number(v, name)
    try:
        f = float(v)
    except OverflowError:  # (an int beyond the float range)
        f = math.inf
    if not math.isfinite(f):
        raise ValueError(f"{name}: need a finite number, got {v!r}")
    if f < lo or f > hi or (hi_open and f == hi):
        rng = f"[{lo:g}, {hi:g}{')' if hi_open else ']'}" if hi < math.inf else f">= {lo:g}"
        raise ValueError(f"{name}: need a number {'in ' if hi < math.inf else ''}{rng}, got "
                         f"{v!r}{f' ({why})' if why else ''}")
    return f


def _pair(v, name: str) -> tuple[float, float]:
    """``(low, high)``, finite, 0 < low <= high, low a normal float64 (>= FLOAT_NORMAL_MIN),
    from a list, tuple or 1-d array of two."""
    if isinstance(v, np.ndarray) and v.ndim == 1 or isinstance(v, (list, tuple)):
        items = list(v)
    else:
        raise TypeError(f"{name}: expected a (low, high) pair, got {v!r}")
    if len(items) != 2:
        raise ValueError(f"{name}: expected a (low, high) pair, got {len(items)} values {v!r}")
    lo = _real(items[0], f"{name}[0]")
    hi = _real(items[1], f"{name}[1]")
    if not 0 < lo <= hi:
        raise ValueError(f"{name}: need 0 < low <= high, got {v!r}")
    if lo < FLOAT_NORMAL_MIN:
        raise ValueError(f"{name}: the low end {lo!r} is a subnormal float64; need low >= "
                         f"{FLOAT_NORMAL_MIN!r}, the smallest normal one (a subnormal's "
                         f"reciprocal overflows: a map dividing by it gives inf)")
    return lo, hi


def _scene(scene) -> Scene:
    if isinstance(scene, os.PathLike):
        scene = os.fspath(scene)
    if not isinstance(scene, (Scene, str)):
        raise TypeError(f"scene: expected a Scene, a built-in scene name or a TOML path, got "
                        f"{scene!r}")
    try:
        return _as_scene(scene)
    except OSError as e:
        raise type(e)(f"scene: cannot read {scene!r}: {e.strerror or e}") from None


def _steps_per_action(v, dt: float) -> int:
    """``step_time`` as a whole number of steps of the scene's ``dt`` (at most the
    simulation's int64 step counter); a float32 or float16 is taken at its own precision."""
    raw = _number(v, "step_time")
    step_time = _real(raw, "step_time", 0.0)
    if step_time <= 0.0:
        raise ValueError(f"step_time: must be > 0, got {v!r}")
    q = step_time / dt
    if not q < INT_MAX:  # (inf too)
        raise ValueError(f"step_time: {step_time} is {q:.3g} steps of the scene's dt = {dt}, "
                         f"more than the simulation's step counter holds ({INT_MAX_TEXT})")
    spa = int(round(q))
    exact = abs(spa * dt - step_time) <= 1e-9 * step_time
    if not exact and isinstance(raw, np.floating) and np.finfo(raw.dtype).eps > 1e-9:
        exact = raw.dtype.type(spa * dt) == raw
    if spa < 1 or not exact:
        raise ValueError(f"step_time: {step_time} must be a whole number of the scene's "
                         f"time step dt = {dt}")
    return spa


def _check_event_fit(scene: Scene, size_min: float) -> None:
    """The event-driven integrator refuses bounds that leave a species less free room than
    1e-3 of its radius along an axis (``Simulation``'s check: its wall contacts would almost
    never end). The room only shrinks with the size (a box's width, a circle's radius), so
    the scene's bounds and the reactor at ``size_range``'s low end are the ones to check: no
    wall move can then reach bounds the integrator refuses."""
    try:
        _event_fit("event", scene, scene.bounds)
    except ValueError as e:
        raise ValueError(f"integrator: 'event' cannot run the scene's bounds: {e}") from None
    try:
        _event_fit("event", scene, _bounds_of(scene, size_min))
    except ValueError as e:
        raise ValueError(f"size_range: with integrator='event' the reactor at size {size_min} "
                         f"(the low end, the narrowest the wall can make it) is refused: "
                         f"{e}") from None


def _bounds_of(scene: Scene, size: float):
    """The scene's bounds at ``size`` (box: the width scales, origin kept; circle: the
    radius)."""
    ref = scene.bounds
    if isinstance(ref, Box):
        return Box(ref.width * size, ref.height, ref.origin)
    return Circle(ref.radius * size, ref.center)


def lattice_sites(bounds, radius: float) -> int:
    """How many discs of ``radius`` the hexagonal lattice of ``Simulation``'s dense
    placement (``Simulation._place_lattice``: spacing one diameter, rows from the lower left
    corner) puts inside ``bounds``."""
    r = float(radius)
    a = 2.0 * r * (1.0 + 1e-9)
    x0, y0, x1, y1 = bounds.extent
    xs = np.arange(x0 + r, x1 - r + 1e-12, a)
    ys = np.arange(y0 + r, y1 - r + 1e-12, a * math.sqrt(3) / 2)
    shift = np.where(np.arange(len(ys)) % 2 == 1, 0.5 * a, 0.0)
    sites = np.empty((len(ys), len(xs), 2))
    sites[:, :, 0] = xs[None, :] + shift[:, None]
    sites[:, :, 1] = ys[:, None]
    sites = sites.reshape(-1, 2)
    bounds_kind, bounds_params = kernel_bounds(bounds)
    return int(_inside(sites, np.full(len(sites), r), bounds_kind, bounds_params).sum())


def _check_placeable(scene: Scene, most: list, name: str) -> None:
    """Refuse contents (the most of each species a reset can draw) that ``Simulation``
    cannot place in the scene's bounds: more area than the densest packing holds, or, when
    they cover more than RANDOM_PLACEMENT_SHARE of the area (where random addition is no
    longer reliable), more discs than the sites of the hexagonal lattice it falls back to."""
    sp = scene.species
    area = sum(math.pi * sp[k].radius * sp[k].radius * c for k, c in enumerate(most))
    total = sum(most)
    bounds = scene.bounds
    what = (f"up to {total} discs ({'n_discs' if name == 'n_discs' else 'the scene counts'}"
            f" x (1 + count_jitter), rounded)")
    if area > HEX_PACKING * bounds.area:
        raise ValueError(f"{name}: {what} cannot fit in {bounds}: they cover {area:.4g}, more "
                         f"than the densest packing ({HEX_PACKING:.4f}) of its area "
                         f"{bounds.area:.4g}; lower n_discs or count_jitter")
    if area > RANDOM_PLACEMENT_SHARE * bounds.area:
        r = max(sp[k].radius for k, c in enumerate(most) if c)
        sites = lattice_sites(bounds, r)
        if total > sites:
            raise ValueError(
                f"{name}: {what} cannot be placed in {bounds}: they cover "
                f"{area / bounds.area:.3f} of its area (random placement is unreliable above "
                f"{RANDOM_PLACEMENT_SHARE}) and the hexagonal lattice the placement falls "
                f"back to has {sites} sites; lower n_discs or count_jitter")


def _physical_memory() -> int | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def _check_memory(need: int, name: str, what: str) -> None:
    """Refuse state that could not fit in this machine's memory (instead of a MemoryError, or
    the OOM killer on first touch, at reset)."""
    have = _physical_memory()
    if have is not None and need > have:
        raise ValueError(f"{name}: {what} needs about {need / 2**30:.3g} GiB, more than this "
                         f"machine's memory ({have / 2**30:.3g} GiB)")


# --------------------------------------------------------------------------------------------
# the per-step logic, shared with the vector env


def observe(cfg: ReactorConfig, rx: Reactors, ep: Episodes) -> None:
    """Fill ``ep.stats`` (R, 3S+1), ``ep.temperature`` and ``ep.kinetic`` (R,) and
    ``ep.obs`` (R, D) float32 for R reactors (see :func:`discgym.kernels.batch.observe_one`);
    a step observes inside :func:`discgym.kernels.batch.env_step`, this is for resets."""
    observe_batch(tuple(rx), tuple(ep), cfg.compiled.sp_mass, tuple(cfg.consts))


def check_status(cfg: ReactorConfig, iout: np.ndarray, active: np.ndarray) -> None:
    """Raise if an ``active`` reactor of the last :func:`~discgym.kernels.batch.env_step`
    outgrew its arrays (it cannot: the capacity plan bounds every reactor; this would be a
    bug)."""
    status = np.where(active, iout[:, O_STATUS], 0)
    if status.any():
        bad = np.flatnonzero(status).tolist()
        raise RuntimeError(f"reactors {bad}: the state outgrew the capacity {cfg.capacity} "
                           f"(status {status[bad].tolist()}); this is a bug in the capacity "
                           "plan")


def integrator_changed(cfg: ReactorConfig, now: str, who: str) -> RuntimeError:
    """The error of a step whose reactor's ``Simulation`` was switched to another integrator
    (by ``set_state``) than the env runs: the compiled step runs the env's, and the
    Simulation would no longer describe its own trajectory."""
    return RuntimeError(
        f"integrator: {who} now has integrator {now!r} (set_state with a state of another "
        f"integrator), the env was made with integrator={cfg.integrator!r} and steps with "
        f"it; set a state of integrator {cfg.integrator!r} (or without the key) or reset")


_REAL_KINDS = frozenset("biuf")  # numpy dtype kinds of actions: bool, integers, floats


def as_actions(cfg: ReactorConfig, action, batch: int | None = None) -> np.ndarray:
    """``action`` as a float64 array of shape (A,), or (batch, A) for a batch (an array,
    or a list of per-reactor actions): exactly that shape, never reshaped; real numbers only
    (bool, integer or float dtypes). Anything else raises (``ValueError`` naming the expected
    and the received shape, ``TypeError`` naming the dtype) before anything is stepped."""
    what = "action" if batch is None else "actions"
    try:
        a = np.asarray(action)
    except ValueError as e:  # (ragged nested lists)
        raise ValueError(f"{what}: not an array of one shape ({e})") from None
    A = 2 + len(cfg.feed)
    want = (A,) if batch is None else (batch, A)
    if a.shape != want:
        raise ValueError(f"{what}: expected shape {want} ({'' if batch is None else 'num_envs, '}"
                         f"heat, wall, one injection per feed species), got {a.shape}")
    if a.dtype.kind not in _REAL_KINDS:
        raise TypeError(f"{what}: expected real numbers, got an array of dtype {a.dtype}")
    return np.ascontiguousarray(a, dtype=FLOAT)


def check_render_mode(render_mode, modes) -> None:
    if render_mode is None:
        return
    if not isinstance(render_mode, str):
        raise TypeError(f"render_mode: expected one of {modes} or None, got {render_mode!r}")
    if render_mode not in modes:
        raise ValueError(f"render_mode: expected one of {modes} or None, got {render_mode!r}")


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
    same keys at reset and at each step (:attr:`ReactorConfig.info_types`).

    ## Starting State
    Counts x U[1 - count_jitter, 1 + count_jitter], kT x U[1 - temperature_jitter,
    1 + temperature_jitter], positions uniform without overlap, all drawn from the seed.

    ## Episode End
    Never terminated (no absorbing state); truncated after ``episode_steps`` (100) steps of
    ``step_time`` (0.5) each.

    ## Arguments
    All optional, shown in ``env.spec.kwargs`` when given to ``gymnasium.make`` (defaults:
    :data:`DEFAULTS`). Each is checked at construction: a wrong type raises ``TypeError``, a
    value out of its range ``ValueError``, both naming the argument; an unknown keyword
    raises Python's own ``TypeError: DiscReactorEnv.__init__() got an unexpected keyword
    argument 'x'``. They may also come as one mapping, the only positional argument
    (``DiscReactorEnv({"episode_steps": 50})``: RLlib passes its ``EnvContext``), alone or
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
      :meth:`ReactorConfig.draw_kinetics`).
    - ``heating``: "scale" (the heat action rescales velocities) or "jacket" (it sets the
      thermal walls' kT; the scene must have some, and ``temperature_range``'s high end must
      not pass ``Scene.max_wall_temperature()``); ``reward``: "product" or "outflow" (the
      product leaving through the scene's outlets, which it must have); ``observe_outflow``:
      a bool; ``feed_temperature``: None or a (low, high) pair, 0 < low <= high <= the
      scene's hottest wall temperature, low a normal float64 (see
      :meth:`ReactorConfig.draw_feed`).
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
    start from (:meth:`ReactorConfig.read_size`); bounds the wall cannot make (another kind,
    height, origin or centre, or a size outside ``size_range``) raise ``RuntimeError`` at the
    next step, before anything is stepped.

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
        self.render_size = _whole(render_size, "render_size", 1, MAX_RENDER_SIZE)
        self.config = cfg = ReactorConfig.from_kwargs(self.defaults, **kwargs)
        compile_helper.expect(f"env-{cfg.integrator}")
        self.render_mode = render_mode
        if render_mode == "human":
            _need_matplotlib()
        self.observation_space = cfg.observation_space()
        self.action_space = cfg.action_space()
        self.observation_names = cfg.obs_names
        self.action_names = cfg.action_names
        self.simulation: Simulation | None = None
        S, F = cfg.n_species, len(cfg.feed)
        # per-episode state as (1, ...) rows, the layout the compiled observation reads
        self._stats = np.zeros((1, 3 * S + 1), dtype=FLOAT)
        self._size = np.ones(1, dtype=FLOAT)
        self._steps = np.zeros(1, dtype=np.int64)
        self._feed_left = np.zeros((1, F), dtype=np.int64)
        self._n_init = np.ones(1, dtype=FLOAT)
        self._n_ref = np.ones(1, dtype=FLOAT)
        self._n = np.zeros(1, dtype=np.int64)
        self._temp = np.zeros(1, dtype=FLOAT)
        self._kin = np.zeros(1, dtype=FLOAT)
        self._ksteps = np.zeros(1, dtype=np.int64)
        self._bounds_kind = np.zeros(1, dtype=np.int64)
        self._bounds_params = np.zeros((1, 4), dtype=FLOAT)
        self._act = np.zeros((1, 2 + F), dtype=FLOAT)
        self._fout = np.zeros((1, 2 + F), dtype=FLOAT)
        self._iout = np.zeros((1, 3 + 2 * F), dtype=np.int64)
        self._obs = np.zeros((1, len(cfg.obs_names)), dtype=np.float32)
        K = len(cfg.compiled.labels)
        self._sp_form = np.zeros((1, S), dtype=FLOAT)
        self._ch_rate = np.zeros((1, K), dtype=FLOAT)
        self._ch_energy = np.zeros((1, K), dtype=FLOAT)
        self._ch_last = np.zeros((1, K), dtype=np.int64)
        self._out_last = np.zeros((1, S), dtype=np.int64)
        self._feed_kT = np.full(1, np.nan, dtype=FLOAT)
        self._feed_kT_next = np.full(1, np.nan, dtype=FLOAT)
        self._feed_switch = np.full(1, -1, dtype=np.int64)
        self._pending = np.zeros((1, 2), dtype=FLOAT)
        self._ep = Episodes(self._size, self._feed_left, self._steps, self._n_init, self._n_ref,
                            self._temp, self._kin, self._stats, self._obs, self._fout,
                            self._iout, self._sp_form, self._ch_rate, self._ch_energy,
                            self._ch_last, self._out_last, self._feed_kT,
                            self._feed_kT_next, self._feed_switch, self._pending)
        self._ashape = (2 + F,)
        self._n_feed = F
        self._n_species = S
        self._step_k, self._step_dt = cfg.steps_per_action, cfg.scene.dt  # (Simulation.step)
        self._n_seen = -1  # the simulation's disc count after the last step
        self._bounds_seen = -1  # its bounds serial read back (Simulation.export_scalars)
        self._bound: tuple = (None,) * 5
        self._fig = None

    # ------------------------------------------------------------------ API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        cfg = self.config
        self.simulation = sim = cfg.new_simulation(self.np_random)
        cfg.reset_row(self._ep, 0, sim, self.np_random)
        self._bind(sim)
        counts = np.bincount(sim.species, minlength=cfg.n_species)
        self._n_ref_now = float(self._n_ref[0])
        self._size_now = float(self._size[0])
        obs = self._observe()
        self._product = float(self._stats[0, cfg.product])
        # the keys of a step's info; what only a step does (reward, costs, heat, injections,
        # a blocked wall, invalid components) is 0 / False
        counts = counts.tolist()
        product = counts[cfg.product]
        n_ref = self._n_ref_now
        none = [0] * self._n_feed
        info = cfg.info_values(counts, product, product / n_ref, 0.0, 0.0, 0.0, 0.0,
                               self._temperature, self._size_now, none, none, False, 0,
                               sim.time, n_ref)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action):
        sim = self.simulation
        if sim is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        cfg = self.config
        act = self._act
        if type(action) is np.ndarray and action.shape == self._ashape and \
                action.dtype.kind in _REAL_KINDS:
            act[0] = action
        else:
            act[0] = as_actions(cfg, action)
        if sim.integrator != cfg.integrator:
            raise integrator_changed(cfg, sim.integrator, "its Simulation")
        bound = self._bound
        arrays = sim.kernel_arrays()
        if arrays[0] is not bound[0] or arrays[1] is not bound[1] or \
                arrays[2] is not bound[2] or arrays[3] is not bound[3] or \
                arrays[4] is not bound[4] or len(sim) != self._n_seen:
            self._bind(sim)  # (the simulation was changed from outside: arrays, disc count)
        # the simulation's scalar state, as the rows of a batch of one reactor; bounds
        # replaced from outside (resize, set_state) give the wall its size
        serial = sim.export_scalars(self._rx, 0)
        if serial != self._bounds_seen:
            self._size[0] = self._size_now = cfg.read_size(sim.bounds, self._size_now,
                                                           "its Simulation")
            self._bounds_seen = serial
        size0 = self._size_now
        env_step(*self._args)
        fo = self._fout[0].tolist()
        io = self._iout[0].tolist()
        if io[O_STATUS]:
            check_status(cfg, self._iout, _ONE)
        # what Simulation.step and its controls book
        self._n_seen = n = self._n.item()
        self._size_now = size = self._size.item()
        moved = (partial(cfg.bounds_of, size), self._bounds_params[0].copy()) \
            if size != size0 else None
        sim.book_env_step(n, self._ksteps.item(), self._step_k, self._step_dt,
                          fo[O_ENERGY_HEAT:], moved)
        self._temperature = temperature = self._temp.item()
        F = self._n_feed
        injected = io[3:3 + F]
        heat = fo[O_HEAT]
        n_ref = self._n_ref_now
        counts = self._stats[0, :self._n_species].tolist()
        product = counts[cfg.product]
        gain, cost_heat, cost_feed, reward = cfg.reward_terms(
            product, self._product, float(self._out_last[0, cfg.product]), heat,
            float(sum(injected)), n_ref)
        self._product = product
        truncated = self._steps.item() >= cfg.episode_steps
        info = cfg.info_values([int(c) for c in counts], int(product), product / n_ref, gain,
                               cost_heat, cost_feed, heat, temperature, size, injected,
                               io[3 + F:], io[O_BLOCKED] != 0, io[O_INVALID], sim.time, n_ref)
        if self.render_mode == "human":
            self.render()
        return self._obs[0].copy(), reward, False, truncated, info

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
    def _bind(self, sim: Simulation) -> None:
        """Give ``sim`` the capacity the compiled step needs (it never grows arrays) and keep
        the arguments of :func:`~discgym.kernels.batch.env_step`: (1, ...) views of its state
        arrays (the rows of a batch of one reactor) and this env's episode state."""
        cfg = self.config
        # the compiled step never grows arrays: room for all the discs the contents and the
        # feed left could ever split into (mass is conserved), twice over (see kernels.batch)
        sim.reserve_capacity(max(cfg.capacity,
                                 cfg.capacity_for(sim.species, self._feed_left[0])[0]))
        self._n_seen = len(sim)
        cs = cfg.compiled
        pos, vel, species, internal_energy, ids, next_id = arrays = sim.kernel_arrays()
        icnt, fsum, ch_count, outflow = sim.kernel_counters()
        self._bound = arrays[:5]
        self._rx = Reactors(pos[None], vel[None], species[None], internal_energy[None],
                            ids[None], next_id[None], self._n, self._ksteps, self._bounds_kind,
                            self._bounds_params, icnt[None], fsum[None], ch_count[None],
                            outflow[None], sim.kernel_walls()[None])
        # (the structs as plain tuples of their fields: see kernels.batch.env_step)
        self._args = (tuple(self._rx), tuple(self._ep), (tuple(cfg.tables), cs.params, cs.flags),
                      tuple(cfg.consts), sim.kernel_rngs, _ONE, self._act)

    def _observe(self) -> np.ndarray:
        # the simulation's own arrays (padded; the kernel reads discs [0, n)): no copies; at
        # reset, so the new simulation's bounds are those of the size
        self._bounds_seen = self.simulation.export_scalars(self._rx, 0)
        observe(self.config, self._rx, self._ep)
        self._temperature = float(self._temp[0])
        return self._obs[0].copy()

    def _frame(self) -> np.ndarray:
        from .render import render_frame

        y = self._product / float(self._n_ref[0])
        title = f"T {self._temperature:.2f} Y {y:.2f}"
        return render_frame(self.simulation, size=self.render_size, title=title)

    def clone(self, reseed=None) -> DiscReactorEnv:
        """An independent copy that continues bit for bit as this env would under the same
        actions (observations, rewards, infos, the next ``reset()`` without a seed): what
        ``copy.deepcopy(env)`` gives, for planners that copy at every decision (see
        :class:`discgym.oracle.RolloutOracle`). The frozen :class:`ReactorConfig` is shared
        and so is the simulation's frozen :class:`~discgym.Scene` (deepcopy copies and compiles
        them again), everything else is copied: the
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
            if c.simulation is not None:
                c.simulation._set_rng(np.random.Generator(np.random.PCG64(sim_seq)))
        return c

    def __getstate__(self):
        d = self.__dict__.copy()
        d["_fig"] = None
        d.pop("_im", None)
        # views of the simulation's arrays would come back as copies: bind again on the
        # next step
        d.pop("_args", None)
        d.pop("_rx", None)
        d["_bound"] = (None,) * 5
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
