"""The Python handle on a running reactor: validates and casts, then calls the kernels.

>>> import discgym as dg
>>> sim = dg.Simulation(dg.scenes.load("ideal_gas"), seed=0)
>>> sim.advance(1.0)
>>> round(sim.temperature(), 6) == round(sim.kinetic_energy() / len(sim), 6)
True
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping

import numba
import numpy as np

from .compiled import CIRCLE, compile_scene, kernel_bounds, kernel_walls
from .kernels import controls as _controls
from .kernels import event_driven as _event
from .kernels import step as _step
from .kernels import walls as _walls
from .kernels.placement import overlapping_pairs, place_rngs
from .kernels.structs import (
    COUNT,
    FLOAT,
    INDEX,
    P_MAXDISP,
    P_RMIN,
    Bounds,
    Discs,
    Injection,
    speed_limit,
)
from .scene import (
    HEX_PACKING,
    MAX_MAGNITUDE,
    Box,
    Circle,
    Scene,
    SceneError,
    check_bounds_scale,
    check_side,
    finite_value,
    plain,
    sides_of,
    too_hot_for_walls,
    validated_counts,
)
from .state import ReactorState
from .threads import ThreadChooser, numba_threads

__all__ = ["Simulation", "PlacementError"]

PLACEMENT_ATTEMPTS = 2000  #: random placement tries per disc before a spot counts as not found
_SPEC_COUNTERS = {
    "collisions": _step.IC_COLLISIONS,
    "wall_hits": _step.IC_WALL_HITS,
    "substeps": _step.IC_SUBSTEPS,
    "reactive_collisions": _step.IC_REACTIVE,
    "events_capped": _step.IC_EVENTS_CAPPED,
    "pushed_inside": _step.IC_PUSHED_INSIDE,
    "reactions_without_room": _step.IC_NO_ROOM,
    "substeps_capped": _step.IC_SUBSTEPS_CAPPED,
    "elastic_repeats": _step.IC_TC_ELASTIC,
    "wall_glides": _step.IC_GLIDES,
    "fallback_repairs": _step.IC_RESOLVED,
    "graze_repairs": _step.IC_GRAZE_REPAIRS,
    "resplits": _step.IC_RESPLITS,
    "substeps_cut": _step.IC_CUTS,
}


_OLDEST_ICOUNTERS = 11  # counters in states of discgym before graze_repairs


class PlacementError(ValueError):
    """Discs could not be placed (or kept) without overlap in the bounds."""


def _rng(seed) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.Generator(np.random.PCG64(plain(seed)))


class Simulation:
    """A reactor of hard discs, advanced by the compiled time-stepped integrator.

    Arguments:
        scene: the :class:`~discgym.Scene` (or a built-in scene name, or a TOML path).
        counts: initial population ``{species: count}``; default ``scene.counts``.
        temperature: initial temperature kT (k_B = 1); default ``scene.temperature``.
            Velocities are drawn from the Maxwell-Boltzmann distribution, then shifted to zero
            total momentum and scaled so that the kinetic energy is exactly N kT.
        seed: an int, None, or a ``numpy.random.Generator``. All randomness (placement,
            velocities, reactions) comes from this one generator, so the same seed gives the
            same trajectory, bit for bit.
        integrator: ``"step"`` (default), the time-stepped integrator (``scene.dt``,
            ``scene.max_displacement``), or ``"event"``, the exact event-driven one
            (:mod:`discgym.kernels.event_driven`): discs fly freely between exactly predicted
            contacts and react at exactly sampled times; ``step(n)`` then advances exactly
            ``n * scene.dt`` of simulated time. Same scene, same physics rules.

    Arrays returned by the properties are copies; shapes use N = ``len(sim)``.
    """

    def __init__(self, scene: Scene | str, counts: Mapping[str, int] | None = None,
                 temperature: float | None = None, seed=None, integrator: str = "step", *,
                 row: tuple[ReactorState, int] | None = None):
        integrator = _integrator_name(integrator)
        scene = as_scene(scene)
        # validated by the scene model's own rules (errors name the offending field)
        counts = validated_counts(scene.bounds, {s.name: s for s in scene.species},
                                  scene.counts if counts is None else counts)
        temperature = finite_value("temperature", scene.temperature if temperature is None
                              else temperature, nonneg=True, energy=True)
        self._setup(scene, seed, row)
        self._integrator = event_fit(integrator, scene, scene.bounds)
        todo = np.concatenate([np.full(c, scene.species_index(nm), dtype=INDEX)
                               for nm, c in counts.items()] + [np.zeros(0, INDEX)])
        # random order, then largest discs first (random sequential addition packs far
        # denser that way); the stable sort keeps the random order within a species
        todo = self._rng.permutation(todo).astype(INDEX)
        todo = todo[np.argsort(-self._cs.sp_radius[todo], kind="stable")]
        self._reserve(len(todo))
        placed = self._place(todo, None)
        if placed < len(todo):
            placed = self._place_lattice(todo)
        self._n = placed
        self._new_ids(0, placed)
        self._vel[: self._n] = self._maxwell(self._species[: self._n], temperature)
        if self._n > 1:
            m = self.masses
            p = (m[:, None] * self._vel[: self._n]).sum(axis=0)
            self._vel[: self._n] -= p / m.sum()
            ke = self.kinetic_energy()
            if ke > 0:
                self._vel[: self._n] *= math.sqrt(self._n * temperature / ke)
        self._check_speeds(self._vel[: self._n], "temperature")
        self._check_energy("Simulation")
        self._energy_start = self.total_energy()

    # ------------------------------------------------------------------ construction
    def _setup(self, scene: Scene, seed, row: tuple | None = None) -> None:
        """The handle's own attributes, and row ``row`` = (state, r) emptied for this
        reactor (default: a state of one row of its own)."""
        self._attach(scene, row)
        st, r = self._st, self._r
        st.clear(r)
        st.dt[r] = scene.dt
        st.set_bounds(r, scene.bounds)
        st.rx.bounds_walls[r] = kernel_walls(scene)  # kT per side, NaN: specular
        self._set_rng(_rng(seed))

    def _attach(self, scene: Scene, row: tuple | None) -> None:
        self.scene = scene
        self._cs = compile_scene(scene)
        self._species_of = {sp.name: k for k, sp in enumerate(scene.species)}
        S, K = len(scene.species), len(self._cs.labels)
        if row is None:
            row = (ReactorState(1, 16, S, K), 0)
        st, r = row
        if not isinstance(st, ReactorState) or not 0 <= r < st.rows or \
                st.rx.outflow.shape[1] != S or st.rx.ch_count.shape[1] != K:
            raise ValueError(f"row: expected (ReactorState, row index) of a state of {S} "
                             f"species and {K} reaction channels, got {row!r}")
        self._st, self._r = st, int(r)
        self._work = _step.empty_work()  # the stepper's scratch, kept between calls
        self._integrator = "step"
        self._threads = 4 * numba.get_num_threads()
        # the thread count of each call (speed only: not part of the state); one thread
        # takes the serial entry, which a parallel Simulation may not have compiled yet
        self._chooser = ThreadChooser(
            compiles=lambda t: t == 1 and not _step.advance_serial_rngs.signatures)

    @classmethod
    def attach(cls, scene: Scene, row: tuple[ReactorState, int],
               integrator: str = "step") -> Simulation:
        """A handle on row ``row`` = (state, r) of a :class:`~discgym.state.ReactorState`
        as it is (nothing is copied or cleared): how an environment that holds the state
        (after unpickling it, say) gives each reactor its :class:`Simulation` again."""
        self = cls.__new__(cls)
        self._attach(scene, row)
        self._integrator = _integrator_name(integrator)
        return self

    # the row's arrays in the shared state (views, written in place) and its numbers
    _pos = property(lambda self: self._st.rx.pos[self._r])
    _vel = property(lambda self: self._st.rx.vel[self._r])
    _species = property(lambda self: self._st.rx.species[self._r])
    _internal_energy = property(lambda self: self._st.rx.internal_energy[self._r])
    _ids = property(lambda self: self._st.rx.ids[self._r])
    _idctr = property(lambda self: self._st.rx.next_id[self._r])  # the next disc identity
    _icnt = property(lambda self: self._st.rx.icnt[self._r])
    _fsum = property(lambda self: self._st.rx.fsum[self._r])
    _ch_count = property(lambda self: self._st.rx.ch_count[self._r])
    _outflow = property(lambda self: self._st.rx.outflow[self._r])
    _walls = property(lambda self: self._st.rx.bounds_walls[self._r])  # (Bounds.walls)
    _bounds_kind = property(lambda self: int(self._st.rx.bounds_kind[self._r]))
    _bounds_params = property(lambda self: self._st.rx.bounds_params[self._r])
    _time = property(lambda self: float(self._st.time(self._r)))
    _rng = property(lambda self: self._st.generator(self._r))
    _rngs = property(lambda self: self._st.row_rngs(self._r))  # (the kernels' form)
    _since_reset = property(lambda self: float(self._st.since_reset(self._r)))

    @property
    def _n(self) -> int:
        return int(self._st.rx.n[self._r])

    @_n.setter
    def _n(self, n: int) -> None:
        self._st.rx.n[self._r] = n

    @property
    def _steps(self) -> int:  # kernel steps taken (times the memory reordering)
        return int(self._st.rx.ksteps[self._r])

    @_steps.setter
    def _steps(self, k: int) -> None:
        self._st.rx.ksteps[self._r] = k

    @property
    def _energy_input(self) -> float:
        return float(self._st.energy_input[self._r])

    @_energy_input.setter
    def _energy_input(self, e: float) -> None:
        self._st.energy_input[self._r] = e

    @property
    def _energy_start(self) -> float:
        return float(self._st.energy_start[self._r])

    @_energy_start.setter
    def _energy_start(self, e: float) -> None:
        self._st.energy_start[self._r] = e

    @classmethod
    def from_arrays(cls, scene: Scene | str, positions, velocities, species,
                    internal_energy=None, seed=None,
                    integrator: str = "step") -> Simulation:
        """Build from explicit initial conditions.

        ``positions``, ``velocities``: (N, 2); ``species``: (N,) names or indices;
        ``internal_energy``: (N,) >= 0, default 0. Overlapping or out-of-bounds discs, NaN and
        unknown species raise ``ValueError`` naming the disc. ``integrator``: as for
        :class:`Simulation`.
        """
        integrator = _integrator_name(integrator)
        scene = as_scene(scene)
        self = cls.__new__(cls)
        self._setup(scene, seed)
        self._integrator = event_fit(integrator, scene, scene.bounds)
        pos = np.asarray(positions, dtype=FLOAT)
        vel = np.asarray(velocities, dtype=FLOAT)
        n = len(pos)
        if pos.shape != (n, 2) or vel.shape != (n, 2):
            raise ValueError(f"positions and velocities must both be (N, 2); got {pos.shape} "
                             f"and {vel.shape}")
        spc = self._species_indices(species, n)
        u = np.zeros(n) if internal_energy is None else np.asarray(internal_energy, FLOAT)
        if u.shape != (n,):
            raise ValueError(f"internal_energy must be ({n},), got {u.shape}")
        _check_discs(pos, vel, spc, u, self._cs.sp_radius, self._bounds_kind, self._bounds_params,
                     scene.bounds)
        if n and not u.max() <= MAX_MAGNITUDE:  # (the energy range of scene.MAX_MAGNITUDE)
            raise ValueError(f"internal_energy of disc {int(np.argmax(u))} is {u.max():g}, "
                             f"above {MAX_MAGNITUDE:g}: the speeds it would release over- or "
                             "underflow float64; choose other units")
        self._check_speeds(vel, "velocities")
        self._reserve(n)
        self._pos[:n] = pos
        self._vel[:n] = vel
        self._species[:n] = spc
        self._internal_energy[:n] = u
        self._n = n
        self._new_ids(0, n)
        if scene.collisions and n > 1:
            bad = overlapping_pairs(self._pos, self._species, n, self._cs.sp_radius,
                                    (self._bounds_kind, self._bounds_params, self._walls),
                                    1e-12)
            if bad:
                raise ValueError(f"{bad} pair(s) of discs overlap; discs must not overlap "
                                 "initially")
        self._check_energy("from_arrays")
        self._energy_start = self.total_energy()
        return self

    def _species_indices(self, species, n) -> np.ndarray:
        names = self.scene.species_names
        out = np.empty(n, dtype=INDEX)
        sp = list(species) if not isinstance(species, np.ndarray) else species
        if len(sp) != n:
            raise ValueError(f"species must have {n} entries, got {len(sp)}")
        for k, s in enumerate(sp):
            if not isinstance(s, (str, int, np.integer, float, np.floating)) or \
                    isinstance(s, bool):
                raise ValueError(f"species of disc {k}: expected a species name or index, got "
                                 f"{s!r}")
            if isinstance(s, str):
                if s not in names:
                    raise ValueError(f"species of disc {k}: unknown species {s!r} "
                                     f"(scene has {names})")
                out[k] = names.index(s)
            else:
                if not (math.isfinite(s) and 0 <= s < len(names) and int(s) == s):
                    raise ValueError(f"species of disc {k}: no species index {s!r}")
                out[k] = int(s)
        return out

    @property
    def speed_limit(self) -> float:
        """The fastest a disc may move: a step of ``scene.dt`` is split into at most
        ``MAX_SUBSTEPS`` (65536) substeps of at most ``max_displacement`` smallest radii, so
        faster discs could pass through each other. Controls and initial conditions that
        would exceed it are refused with ``ValueError``."""
        cs = self._cs
        return speed_limit(_step.MAX_SUBSTEPS, cs.params[P_MAXDISP], cs.params[P_RMIN],
                           self.scene.dt)

    def _too_fast(self, v: float, what: str) -> str:
        return (f"{what}: a disc would move at speed {v:.3g}, above the speed limit "
                f"{self.speed_limit:.3g} (65536 substeps of max_displacement x the smallest "
                "radius per step of dt); lower the temperature or dt")

    def _check_speeds(self, vel: np.ndarray, what: str) -> None:
        if len(vel):
            with np.errstate(over="ignore"):  # (a speed beyond float64 is inf: refused)
                v = float(np.sqrt((vel * vel).sum(axis=1)).max())
            if not v <= self.speed_limit:
                raise ValueError(self._too_fast(v, what))

    def _check_energy(self, what: str) -> None:
        if not math.isfinite(self.total_energy()):
            raise ValueError(f"{what}: the total energy {self.total_energy()} is not a finite "
                             "number (energies beyond the float range)")

    def _set_rng(self, generator: np.random.Generator) -> None:
        """Use ``generator`` for all randomness. Kernels receive it inside a one-item
        ``numba.typed.List`` (same object, same state): far cheaper to pass than the
        generator itself (see ``kernels.step.advance_rngs``)."""
        self._st.set_generator(self._r, generator)

    def _reserve(self, extra: int) -> None:
        self._st.grow(self._n + extra)

    def _new_ids(self, lo: int, hi: int) -> None:
        """Give discs [lo, hi) fresh identities."""
        k = self._idctr[0]
        self._ids[lo:hi] = np.arange(k, k + hi - lo)
        self._idctr[0] = k + hi - lo

    def _discs(self) -> Discs:
        return Discs(self._pos, self._vel, self._species, self._internal_energy, self._ids,
                     self._idctr)

    def _place(self, todo: np.ndarray, targets: np.ndarray | None) -> int:
        if targets is None:
            targets = np.full((len(todo), 2), np.nan)
        self._reserve(len(todo))
        return place_rngs(self._pos, self._species, self._n, todo,
                          np.ascontiguousarray(targets, dtype=FLOAT), self._cs.sp_radius,
                          (self._bounds_kind, self._bounds_params, self._walls), self._rngs,
                          PLACEMENT_ATTEMPTS)

    def _place_lattice(self, todo: np.ndarray) -> int:
        """Dense initial populations: a hexagonal lattice of the largest diameter."""
        rmax = float(self._cs.sp_radius[todo].max())
        a = 2.0 * rmax * (1.0 + 1e-9)
        x0, y0, x1, y1 = self.bounds.extent
        xs = np.arange(x0 + rmax, x1 - rmax + 1e-12, a)
        ys = np.arange(y0 + rmax, y1 - rmax + 1e-12, a * math.sqrt(3) / 2)
        sites = np.array([(x + (0.5 * a if k % 2 else 0.0), y) for k, y in enumerate(ys)
                          for x in xs]).reshape(-1, 2)
        sites = sites[discs_inside(sites, np.full(len(sites), rmax), self._bounds_kind,
                              self._bounds_params)]
        if len(sites) < len(todo):
            raise PlacementError(
                f"counts: {len(todo)} discs do not fit in {self.bounds} (random placement "
                f"failed and a hexagonal lattice has only {len(sites)} sites)")
        chosen = sites[self._rng.choice(len(sites), size=len(todo), replace=False)]
        self._pos[: len(todo)] = chosen
        self._species[: len(todo)] = todo
        return len(todo)

    def _maxwell(self, spc: np.ndarray, temperature: float) -> np.ndarray:
        m = self._cs.sp_mass[spc]
        return self._rng.standard_normal((len(spc), 2)) * np.sqrt(temperature / m)[:, None]

    # ------------------------------------------------------------------ running
    @property
    def threads(self) -> int:
        """Work chunks for numba's threads in a step (4 per thread; 1: single-threaded; with
        one numba thread a step runs single-threaded whatever this says). A call that would
        run on several threads runs on the count measured fastest for this simulation (every
        thread, or fewer when other processes hold cores: :mod:`discgym.threads`; the same
        trajectory whatever the count)."""
        return self._threads

    @threads.setter
    def threads(self, value: int) -> None:
        value = plain(value)
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if not isinstance(value, numbers.Integral):
            raise ValueError(f"threads: expected a whole number, got {value!r}")
        self._threads = max(int(value), 1)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps of ``scene.dt``."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer, float, np.floating)) \
                or not math.isfinite(n) or n != int(n) or n < 0:
            raise ValueError(f"step(n): need a whole number >= 0, got {n!r}")
        n = int(n)
        if n:
            self._run(n, self.scene.dt)

    def advance(self, duration: float) -> None:
        """Advance the simulated time by ``duration``: whole steps of ``scene.dt``, then one
        shorter step for the remainder (if more than 1e-9 of a step)."""
        duration = _real("advance(duration)", duration)
        if not math.isfinite(duration) or duration < 0:
            raise ValueError(f"advance(duration): need a finite duration >= 0, got {duration}")
        dt = self.scene.dt
        full = int(math.floor(duration / dt + 1e-9))
        rest = duration - full * dt
        if full:
            self._run(full, dt)
        if rest > 1e-9 * dt:
            self._run(1, rest)

    @property
    def integrator(self) -> str:
        """``"step"`` (time-stepped) or ``"event"`` (exact, event-driven)."""
        return self._integrator

    def _run(self, n_steps: int, dt: float) -> None:
        cs = self._cs
        # (the structs as plain tuples: see kernels.step.advance_rngs)
        discs = (self._pos, self._vel, self._species, self._internal_energy, self._ids,
                 self._idctr)
        bounds = (self._bounds_kind, self._bounds_params, self._walls)
        counters = (self._icnt, self._fsum, self._ch_count, self._outflow)
        tables = tuple(cs.tables)
        if self._integrator == "event":  # one exact run of n_steps * dt
            discs, n, rest = _event.run_steps_rngs(discs, self._n, n_steps, dt, bounds,
                                                   tables, cs.params, cs.flags, self._rngs,
                                                   counters)
            if rest > 0.0:  # its event bound: the rest stepped (compiled when first needed)
                discs, n = _event.finish_capped_rngs(discs, n, n_steps, dt, rest, bounds,
                                                     tables, cs.params, cs.flags, self._rngs,
                                                     counters)
        else:
            most = numba.get_num_threads()
            chunks = self._threads if most > 1 else 1
            lists = _step.lists_for(n_steps)

            def run(threads: int):
                # (on fewer threads than numba's, proportionally fewer work chunks; on one,
                # one: the serial entry)
                k = chunks if threads == most else 1 if threads == 1 else \
                    max(chunks * threads // most, 2)
                physics = (tables, cs.params, cs.flags)
                if _step.serial_suffices(self._n, k):  # (compiles no parallel code)
                    call = (n_steps, dt, 1, self._steps, _step.REORDER_EVERY)
                    return _step.advance_serial_rngs(discs, self._n, call, bounds, physics,
                                                     self._rngs, counters, self._work, lists)
                call = (n_steps, dt, k, self._steps, _step.REORDER_EVERY)
                with numba_threads(threads):
                    return _step.advance_rngs(discs, self._n, call, bounds, physics,
                                              self._rngs, counters, self._work, lists)

            if _step.serial_suffices(self._n, chunks):
                discs, n, self._work = run(most)
            else:  # (the thread count measured call by call: discgym.threads)
                sub0 = self._icnt[_step.IC_SUBSTEPS]
                discs, n, self._work = self._chooser.timed(
                    most, run, lambda: self._n * float(self._icnt[_step.IC_SUBSTEPS] - sub0))
        st = self._st
        st.adopt(self._r, discs, n)  # (a kernel that grew the row's arrays returned new ones)
        st.rx.ksteps[self._r] += n_steps
        st.tick(self._r, n_steps, dt)
        st.touch(self._r)

    # ------------------------------------------------------------------ state views
    def __len__(self) -> int:
        return self._n

    @property
    def time(self) -> float:
        """Simulated time since the start."""
        return self._time

    @property
    def bounds(self):
        """The current bounds (changed by :meth:`resize`)."""
        return self._st.bounds(self._r)

    @property
    def positions(self) -> np.ndarray:
        """(N, 2) copy of the disc centres."""
        return self._pos[: self._n].copy()

    @property
    def velocities(self) -> np.ndarray:
        """(N, 2) copy of the velocities."""
        return self._vel[: self._n].copy()

    @property
    def species(self) -> np.ndarray:
        """(N,) species index of each disc (into ``scene.species``)."""
        return self._species[: self._n].copy()

    @property
    def radii(self) -> np.ndarray:
        """(N,) radius of each disc."""
        return self._cs.sp_radius[self._species[: self._n]]

    @property
    def masses(self) -> np.ndarray:
        """(N,) mass of each disc."""
        return self._cs.sp_mass[self._species[: self._n]]

    @property
    def ids(self) -> np.ndarray:
        """(N,) int64 identity of each disc: stable while the disc exists, never reused.

        The order of the discs in the arrays may change (reaction products, and for N >= 16384
        a periodic reordering in memory by position, for speed); ``ids`` follows each disc."""
        return self._ids[: self._n].copy()

    @property
    def internal_energy(self) -> np.ndarray:
        """(N,) internal energy of each disc (stored by combination products)."""
        return self._internal_energy[: self._n].copy()

    # ------------------------------------------------------------------ observables
    def counts(self) -> dict:
        """``{species name: number of discs}`` (every species of the scene, zeros included)."""
        c = np.bincount(self._species[: self._n], minlength=len(self.scene.species))
        return {s.name: int(k) for s, k in zip(self.scene.species, c)}

    def _energies(self) -> tuple[float, float, float]:
        cs = self._cs
        return _controls.energies(self._vel, self._species, self._internal_energy, cs.sp_mass,
                                  cs.sp_form, self._n)

    def kinetic_energy(self) -> float:
        return self._energies()[0]

    def internal_energy_total(self) -> float:
        return self._energies()[1]

    def formation_energy(self) -> float:
        return self._energies()[2]

    def total_energy(self) -> float:
        """Kinetic + internal + formation energy."""
        k, u, f = self._energies()
        return k + u + f

    def temperature(self) -> float:
        """kT = kinetic energy per disc (2D, k_B = 1); 0 for an empty reactor."""
        return self.kinetic_energy() / self._n if self._n else 0.0

    def momentum(self) -> np.ndarray:
        """(2,) total momentum."""
        return (self.masses[:, None] * self._vel[: self._n]).sum(axis=0)

    def pressure(self) -> float:
        """Force per unit length of wall, from the momentum delivered to the walls since the
        last :meth:`reset_counters` (or the start), averaged over that time."""
        if self._since_reset <= 0:
            return 0.0
        return float(self._fsum[_step.FS_WALL_MOMENTUM] / (self._since_reset *
                                                           self.bounds.perimeter))

    def packing_fraction(self) -> float:
        return float(np.pi * (self.radii ** 2).sum() / self.bounds.area)

    @property
    def dissipated_energy(self) -> float:
        """Kinetic energy lost to restitution e < 1 since the start."""
        return float(self._fsum[_step.FS_DISSIPATED])

    @property
    def energy_input(self) -> float:
        """Energy added by the controls since the start (heating, injection)."""
        return self._energy_input

    @property
    def wall_heat(self) -> float:
        """Energy the thermal walls put into the discs since the start (negative: they took
        more out than they put in): the sum of :meth:`wall_heat_by_side`."""
        return _wall_heat(self._fsum)

    def wall_heat_by_side(self) -> dict:
        """``{side: energy put in by that side}`` since the start, for every side of the
        bounds (0 for a specular one): of the current bounds, which keep the scene's kind
        whenever it has thermal walls (:func:`check_sides`)."""
        sides = sides_of(self.bounds)
        return {sd: float(self._fsum[_step.FS_WALL_HEAT + k]) for k, sd in enumerate(sides)}

    @property
    def outflow_energy(self) -> float:
        """Energy (kinetic + internal + formation) the discs that left through outlets
        carried out since the start."""
        return float(self._fsum[_step.FS_OUTFLOW])

    def outflow(self) -> dict:
        """``{species name: discs that left through an outlet}`` since the start (every
        species, zeros included; cumulative: :meth:`reset_counters` does not reset it)."""
        return {sp.name: int(k) for sp, k in zip(self.scene.species, self._outflow)}

    def energy_balance(self) -> float:
        """total energy now - (at the start + added by controls - dissipated + put in by the
        thermal walls - carried out through outlets): 0 up to round-off when every change is
        accounted for."""
        return self.total_energy() - (self._energy_start + self._energy_input
                                      - self.dissipated_energy + self.wall_heat
                                      - self.outflow_energy)

    # ------------------------------------------------------------------ thermal walls
    @property
    def wall_temperature(self) -> dict:
        """``{side: kT}`` of the scene's thermal walls (empty without any)."""
        sides = sides_of(self.scene.bounds)
        return {w.side: float(self._walls[sides.index(w.side)])
                for w in self.scene.thermal_walls}

    def max_wall_temperature(self) -> float:
        """The hottest a thermal wall may be set to: 40 thermal speeds sqrt(kT / m) of the
        lightest species within :attr:`speed_limit` (``Scene.max_wall_temperature``)."""
        return self.scene.max_wall_temperature()

    def set_wall_temperature(self, side, temperature: float | None = None) -> None:
        """Set the temperature kT of a thermal wall: ``set_wall_temperature("left", 2.0)``,
        or of several: ``set_wall_temperature({"left": 2.0, "right": 0.5})``. Only sides the
        scene declares thermal; kT finite, > 0 and at most :meth:`max_wall_temperature`
        (else ``ValueError`` naming the side, and nothing changes)."""
        if isinstance(side, Mapping):
            if temperature is not None:
                raise ValueError("set_wall_temperature(temperature): give either a mapping "
                                 "{side: kT} or a side and a temperature, not both")
            todo = dict(side)
        else:
            if temperature is None:
                raise ValueError("set_wall_temperature(temperature): missing (a side needs "
                                 "a temperature)")
            todo = {side: temperature}
        new = self._checked_walls(todo, "set_wall_temperature", partial=True)
        _controls.set_wall_temperatures(self._walls, new, self.max_wall_temperature())

    def _checked_walls(self, todo, what: str, partial: bool) -> np.ndarray:
        """The wall array with the temperatures ``todo`` {side: kT} (all of the thermal
        sides unless ``partial``), checked; ``ValueError`` starting with ``what``."""
        sides = sides_of(self.scene.bounds)
        thermal = [w.side for w in self.scene.thermal_walls]
        walls = self._walls.copy()
        t_max = self.max_wall_temperature()
        for sd, kT in todo.items():
            if not isinstance(sd, str) or sd not in thermal:
                raise ValueError(f"{what}({sd!r}): not a thermal wall of this scene (its "
                                 f"thermal walls: {thermal})")
            kT = _real(f"{what}({sd!r})", kT)
            if not math.isfinite(kT) or kT <= 0.0:
                raise ValueError(f"{what}({sd!r}): need a finite temperature > 0, got {kT}")
            if not kT <= t_max:
                raise ValueError(f"{what}({sd!r}): {too_hot_for_walls(kT, t_max)}")
            walls[sides.index(sd)] = kT
        if not partial and set(todo) != set(thermal):
            miss = sorted(set(thermal) - set(todo))
            raise ValueError(f"{what}: no temperature for the thermal walls {miss}")
        return walls

    def counters(self) -> dict:
        """Event counters since the start: collisions, wall hits, substeps, ..."""
        return {k: int(self._icnt[v]) for k, v in _SPEC_COUNTERS.items()}

    @property
    def collisions(self) -> int:
        """Non-reactive disc-disc collisions since the start."""
        return int(self._icnt[_step.IC_COLLISIONS])

    @property
    def wall_hits(self) -> int:
        return int(self._icnt[_step.IC_WALL_HITS])

    def reactions(self) -> dict:
        """``{reaction label: times fired}`` (a combination's reverse has its own entry)."""
        return {lab: int(c) for lab, c in zip(self._cs.labels, self._ch_count)}

    def reset_counters(self) -> None:
        """Restart the pressure average (the momentum delivered to the walls)."""
        self._fsum[_step.FS_WALL_MOMENTUM] = 0.0
        st, r = self._st, self._r
        st.reset_origin[r] = st.reset_steps[r] = 0

    def overlaps(self, tol: float = 1e-9) -> int:
        """Number of pairs overlapping by more than ``tol`` (in [0, 1)) of their contact
        distance."""
        tol = _real("overlaps(tol)", tol)
        if not 0.0 <= tol < 1.0:
            raise ValueError(f"overlaps(tol): need 0 <= tol < 1 (a fraction of the contact "
                             f"distance), got {tol}")
        if self._n < 2:
            return 0
        return int(overlapping_pairs(self._pos, self._species, self._n, self._cs.sp_radius,
                                     (self._bounds_kind, self._bounds_params, self._walls),
                                     tol))

    def outside(self, tol: float = 1e-9) -> int:
        """Number of discs reaching out of the bounds by more than ``tol`` of their radius."""
        tol = _real("outside(tol)", tol)
        if not math.isfinite(tol):
            raise ValueError(f"outside(tol): need a finite tolerance, got {tol}")
        r = self.radii * (1.0 - tol)
        inside = discs_inside(self._pos[: self._n], r, self._bounds_kind, self._bounds_params)
        return int((~inside).sum())

    # ------------------------------------------------------------------ controls
    def scale_temperature(self, factor: float) -> None:
        """Multiply every kinetic energy by ``factor`` >= 0 (velocities by sqrt(factor)).

        The energy added (or removed) is booked in :attr:`energy_input`. Heating that would
        push a disc past :attr:`speed_limit` is refused with ``ValueError`` (nothing changes);
        cooling always applies."""
        factor = _real("scale_temperature(factor)", factor)
        if not math.isfinite(factor) or factor < 0:
            raise ValueError(f"scale_temperature(factor): need a finite factor >= 0, got "
                             f"{factor}")
        f, energy, fastest = _controls.heat_entry(self._vel, self._species,
                                                  self._cs.sp_mass, self._n, factor,
                                                  self.speed_limit, False)
        if math.isnan(f):
            raise ValueError(self._too_fast(fastest, f"scale_temperature({factor})"))
        self._energy_input += energy

    def inject(self, species: str | int, n: int, temperature: float | None = None,
               near=None) -> int:
        """Add up to ``n`` discs of ``species`` at free random spots (near ``near`` (x, y) if
        given), with Maxwell-Boltzmann velocities at ``temperature`` (default: the current
        temperature, or the scene's when the reactor is empty).

        Returns how many were placed: fewer than ``n`` when the reactor has no room (never an
        overlap). The energy added is booked in :attr:`energy_input`.
        """
        s = self._species_of.get(species) if isinstance(species, str) else None
        if s is None:
            s = int(self._species_indices([species], 1)[0])
        if isinstance(n, bool) or not isinstance(n, (int, np.integer, float, np.floating)) \
                or not math.isfinite(n) or int(n) != n or n < 0:
            raise ValueError(f"inject(n): need a whole number >= 0, got {n!r}")
        n = int(n)
        if n == 0:
            return 0
        given = temperature is not None
        if not given:
            temperature = self.temperature() if self._n else self.scene.temperature
        temperature = _real("inject(temperature)", temperature)
        if not math.isfinite(temperature) or temperature < 0:
            raise ValueError(f"inject(temperature): need a finite value >= 0, got "
                             f"{temperature}")
        if given and temperature > MAX_MAGNITUDE:  # (a default's speeds: see _check_speeds)
            raise ValueError(f"inject(temperature): must be at most {MAX_MAGNITUDE:g}, got "
                             f"{temperature}: beyond, the speeds it makes over- or underflow "
                             "float64; choose other units")
        targets = np.full((n, 2), np.nan)
        if near is not None:
            try:
                if any(isinstance(plain(c), bool) for c in near):
                    raise TypeError  # (a bool is not a coordinate)
                xy = np.asarray(near, dtype=FLOAT).reshape(2)
            except (TypeError, ValueError):
                raise ValueError(f"inject(near): expected a point (x, y), got {near!r}") \
                    from None
            if not np.isfinite(xy).all():
                raise ValueError(f"inject(near): need a finite point, got {near!r}")
            targets[:] = xy
        self._reserve(n)
        rng_state = self._rng.bit_generator.state
        placed, energy, fastest = _controls.inject_entry(
            self._discs(), self._n, Injection(s, targets, temperature if given else math.nan),
            self.scene.temperature, self.speed_limit, self._cs.tables,
            Bounds(self._bounds_kind, self._bounds_params, self._walls), self._rngs, 0,
            PLACEMENT_ATTEMPTS)
        if not fastest <= self.speed_limit:
            self._rng.bit_generator.state = rng_state  # refused: as if never tried
            raise ValueError(self._too_fast(fastest, f"inject(temperature={temperature})"))
        self._n += placed
        self._energy_input += energy
        self._st.touch(self._r)
        return placed

    def resize(self, bounds: Box | Circle) -> None:
        """Change the bounds. Discs that would end up outside are moved inside, to the nearest
        free spot found (velocities kept, so no energy changes); if any finds no room, the
        resize is refused with :class:`PlacementError` and nothing changes."""
        if not isinstance(bounds, (Box, Circle)):
            raise TypeError(f"resize(bounds): expected Box or Circle, got {bounds!r}")
        try:
            check_bounds_scale(bounds, self.scene.species, "bounds", "species")
            check_sides(self.scene, bounds)
        except SceneError as exc:
            raise ValueError(f"resize(bounds): {exc}") from None
        event_fit(self._integrator, self.scene, bounds)
        kind, params = kernel_bounds(bounds)
        rng_state = self._rng.bit_generator.state
        done, failed = _controls.resize_entry(self._discs(), self._n, self._cs.sp_radius,
                                              Bounds(kind, params, self._walls),
                                              bounds.max_radius(), bounds.area, HEX_PACKING,
                                              self._rngs, 0, PLACEMENT_ATTEMPTS)
        if done == _controls.RESIZED:
            self._st.set_bounds(self._r, bounds)
            self._st.touch(self._r)
            return
        self._rng.bit_generator.state = rng_state  # refused: as if never tried
        if done == _controls.TOO_BIG:
            too_big = [s.name for s in self.scene.species if s.radius > bounds.max_radius()]
            raise PlacementError(f"resize: species {too_big} do not fit in {bounds}")
        if done == _controls.TOO_DENSE:
            area = float(np.pi * (self.radii ** 2).sum())
            raise PlacementError(
                f"resize: the discs cannot fit: they cover {area:.4g}, more than the densest "
                f"packing ({HEX_PACKING:.4f}) of the bounds' area {bounds.area:.4g}")
        raise PlacementError(
            f"resize to {bounds}: {failed} of the discs outside the new bounds find no free "
            "spot inside; resize refused")

    # ------------------------------------------------------------------ state
    # the keys of a state; "integrator" (default: the simulation's own) and "scene_fingerprint"
    # (not in states of versions before it) may be left out
    _STATE_KEYS = ("positions", "velocities", "species", "internal_energy", "ids", "next_id",
                   "steps", "time", "bounds", "rng", "icnt", "fsum", "ch_count", "since_reset",
                   "energy_input", "energy_start")
    _STATE_OPTIONAL = ("integrator", "scene_fingerprint", "clock", "wall_temperature",
                       "outflow")

    def get_state(self) -> dict:
        """Everything needed to continue bit-identically (copies), and the fingerprint of the
        scene that gives the numbers their meaning (see :meth:`set_state`)."""
        n = self._n
        return {
            "positions": self._pos[:n].copy(),
            "velocities": self._vel[:n].copy(),
            "species": self._species[:n].copy(),
            "internal_energy": self._internal_energy[:n].copy(),
            "ids": self._ids[:n].copy(),
            "next_id": int(self._idctr[0]),
            "steps": self._steps,
            "time": self._time,
            "bounds": self.bounds,
            "rng": self._rng.bit_generator.state,
            "icnt": self._icnt.copy(),
            "fsum": self._fsum.copy(),
            "ch_count": self._ch_count.copy(),
            "since_reset": self._since_reset,
            "clock": self._clock(),
            "energy_input": self._energy_input,
            "energy_start": self._energy_start,
            "integrator": self._integrator,
            "scene_fingerprint": self._scene_fingerprint(),
            "wall_temperature": self.wall_temperature,
            "outflow": self._outflow.copy(),
        }

    def _scene_fingerprint(self) -> dict:
        """The species (name, radius, mass, formation energy, in index order) and the reaction
        channels (labels, in ``ch_count`` order): what species indices, energies, positions
        and reaction counts of a state mean. Rates, barriers, dt, restitution are not in it:
        they govern what happens next, not what the state says."""
        return {"species": tuple((s.name, float(s.radius), float(s.mass),
                                  float(s.formation_energy)) for s in self.scene.species),
                "channels": tuple(self._cs.labels)}

    def set_state(self, state: Mapping) -> None:
        """Restore a state from :meth:`get_state` of a simulation with the same species and
        reactions (the state carries its own bounds and integrator; dt, restitution, rates and
        barriers are the scene's).

        Everything is checked before anything changes: a state this simulation could not hold
        raises ``ValueError`` naming the key (``state['time']``) and leaves the simulation
        exactly as it was (arrays, counters, random generator). Refused: a missing or unknown
        key; a wrong type, dtype or shape; a non-finite number; a negative count, time,
        internal energy or sum; a species index out of range; a disc outside the bounds or
        faster than :attr:`speed_limit`; duplicate ids, or a ``next_id`` not above every id
        (``inject`` would reuse an identity); ``since_reset`` beyond ``time``; energies beyond
        the float range; a generator state numpy would not restore as given; a
        ``scene_fingerprint`` of other species or reactions. Overlapping discs are allowed.
        A state of an earlier version (no ``scene_fingerprint``, 11 counters) is restored
        after all the other checks; without ``integrator``, the simulation keeps its own.
        """
        self._apply_state(self._checked_state(state))

    def _checked_state(self, state) -> dict:
        """The validated contents of ``state``, converted to the simulation's dtypes; nothing
        is assigned. Per-key checks first, then those that relate keys."""
        if not isinstance(state, Mapping):
            raise ValueError(f"set_state: expected a state dict (from get_state), got "
                             f"{type(state).__name__}")
        missing = [k for k in self._STATE_KEYS if k not in state]
        if missing:
            also = f" (missing too: {missing[1:]})" if len(missing) > 1 else ""
            raise _state_error(missing[0], f"is missing{also}")
        unknown = [k for k in state if k not in self._STATE_KEYS + self._STATE_OPTIONAL]
        if unknown:
            raise _state_error(unknown[0], f"is not a key of a state (unknown keys: {unknown}; "
                               f"a state has {list(self._STATE_KEYS + self._STATE_OPTIONAL)})")
        if "scene_fingerprint" in state:  # first: another scene explains every later mismatch
            self._check_fingerprint(state["scene_fingerprint"])
        cs = self._cs
        S = len(self.scene.species)
        s = {
            "positions": _state_array(state, "positions", (None, 2)),
            "velocities": _state_array(state, "velocities", (None, 2)),
            "species": _state_array(state, "species", (None,), integer=True),
            "internal_energy": _state_array(state, "internal_energy", (None,), nonneg=True),
            "ids": _state_array(state, "ids", (None,), integer=True),
        }
        lengths = {k: len(a) for k, a in s.items()}
        n = max(lengths.values(), key=list(lengths.values()).count)  # the most common
        odd = [k for k, m in lengths.items() if m != n]
        if odd:
            raise _state_error(odd[0], f"has {lengths[odd[0]]} discs, the other per-disc "
                               f"arrays {n} (lengths: {lengths})")
        spc = s["species"]
        if n and spc.max() >= S:
            k = int(np.argmax(spc))
            raise _state_error("species", f"of disc {k} is {spc[k]}, not an index of the "
                               f"scene's {S} species")
        s["species"] = np.ascontiguousarray(spc, dtype=INDEX)
        u = s["internal_energy"]
        if n and not u.max() <= MAX_MAGNITUDE:
            k = int(np.argmax(u))
            raise _state_error("internal_energy", f"of disc {k} is {u[k]:g}, above "
                               f"{MAX_MAGNITUDE:g}: the speeds it would release over- or "
                               "underflow float64")
        ids = s["ids"]
        if n > 1:
            srt = np.sort(ids)
            dup = srt[1:][srt[1:] == srt[:-1]]
            if len(dup):
                i, j = np.flatnonzero(ids == dup[0])[:2]
                raise _state_error("ids", f"has id {dup[0]} twice (discs {i} and {j}): ids "
                                   "identify discs")
        for key in ("next_id", "steps"):
            s[key] = _state_whole(state, key)
        for key, nonneg in (("time", True), ("since_reset", True), ("energy_input", False),
                            ("energy_start", False)):
            s[key] = _state_real(state, key, nonneg)
        s["clock"] = self._checked_clock(state, s["time"], s["since_reset"])
        bounds = state["bounds"]
        if not isinstance(bounds, (Box, Circle)):
            raise _state_error("bounds", f"must be a Box or Circle, got {_short(bounds)}")
        try:
            check_bounds_scale(bounds, self.scene.species, "bounds", "species")
            check_sides(self.scene, bounds)
        except SceneError as e:
            raise _state_error("bounds", str(e)) from None
        s["bounds"] = bounds
        s["bounds_kind"], s["bounds_params"] = kernel_bounds(bounds)
        integrator = state.get("integrator", self._integrator)
        if not isinstance(integrator, str) or integrator not in ("step", "event"):
            raise _state_error("integrator", f"must be 'step' or 'event', got "
                               f"{_short(integrator)}")
        s["integrator"] = integrator
        s["bit_generator"] = _checked_rng(state["rng"])
        s["rng"] = state["rng"]
        _state_counters(self, state, s)
        # relations between keys
        pos, vel = s["positions"], s["velocities"]
        r = cs.sp_radius[s["species"]]
        out = np.flatnonzero(~discs_inside(pos, r, s["bounds_kind"], s["bounds_params"]))
        if len(out):
            k = out[0]
            raise _state_error("positions", f"has disc {k} (radius {r[k]}) at {pos[k]}, not "
                               f"inside state['bounds'] = {bounds}")
        try:
            event_fit(integrator, self.scene, bounds)
        except ValueError as exc:
            raise _state_error("bounds", f"with state['integrator'] = {integrator!r}: "
                               f"{exc}") from None
        self._check_speeds(vel, "set_state: state['velocities']")
        if n and ids.max() >= s["next_id"]:
            raise _state_error("next_id", f"is {s['next_id']}, but disc "
                               f"{int(np.argmax(ids))} has id {ids.max()}: next_id must exceed "
                               "every id (injected discs take the next ones)")
        if s["since_reset"] > s["time"]:
            raise _state_error("since_reset", f"is {s['since_reset']}, beyond state['time'] = "
                               f"{s['time']} (the time since the last reset_counters)")
        kin, uin, form = _controls.energies(vel, s["species"], s["internal_energy"], cs.sp_mass,
                                            cs.sp_form, n)
        for key, e in (("velocities", kin), ("internal_energy", uin), ("species", form)):
            if not math.isfinite(e):
                raise _state_error(key, f"gives an energy of {e}, beyond the float range")
        if not math.isfinite(kin + uin + form):
            raise _state_error("velocities", "and state['internal_energy'] give a total "
                               f"energy of {kin + uin + form}, beyond the float range")
        if not math.isfinite(s["energy_start"] + s["energy_input"]
                             - float(s["fsum"][_step.FS_DISSIPATED])
                             + _wall_heat(s["fsum"])
                             - float(s["fsum"][_step.FS_OUTFLOW])):
            raise _state_error("energy_start", "+ state['energy_input'] - state['fsum'] "
                               "(dissipated) is beyond the float range: no energy balance")
        s["n"] = n
        return s

    def _check_fingerprint(self, fp) -> None:
        """Refuse a fingerprint that is malformed or differs from this simulation's, saying
        what differs."""
        own = self._scene_fingerprint()
        try:
            species = tuple((nm, float(r), float(m), float(f)) for nm, r, m, f in fp["species"])
            channels = tuple(fp["channels"])
            ok = isinstance(fp, Mapping) and set(fp) == set(own) and \
                all(isinstance(x[0], str) for x in species) and \
                all(isinstance(c, str) for c in channels)
        except (TypeError, ValueError, KeyError, IndexError):
            ok = False
        if not ok:
            raise _state_error("scene_fingerprint", f"is not a scene fingerprint "
                               f"({_short(fp)}); get_state gives e.g. {own}")
        diff = []
        if [x[0] for x in species] != [x[0] for x in own["species"]]:
            diff.append(("species names", [x[0] for x in species],
                         [x[0] for x in own["species"]]))
        else:
            for k, what in ((1, "radii"), (2, "masses"), (3, "formation energies")):
                a, b = [x[k] for x in species], [x[k] for x in own["species"]]
                if a != b:
                    diff.append((what, a, b))
        if channels != own["channels"]:
            diff.append(("reactions", list(channels), list(own["channels"])))
        if diff:
            detail = "; ".join(f"{w}: {a} in the state, {b} here" for w, a, b in diff)
            raise _state_error(
                "scene_fingerprint", f"belongs to a scene with other "
                f"{', '.join(w for w, _, _ in diff)} ({detail}): a state restores only into a "
                "simulation of the same species and reactions (Simulation.from_arrays starts "
                "another scene from its discs)")

    def _checked_clock(self, state, time: float, since_reset: float) -> tuple:
        """The clocks ``(origin, steps since it, origin of since_reset, steps since it)``.
        ``time`` and ``since_reset`` are what a state says; a clock that does not give them
        with this scene's dt (a state continued under another dt) and a state of an earlier
        version (no clock) restart the clocks at those times."""
        restart = (time, 0, since_reset, 0)
        if "clock" not in state:
            return restart
        c = state["clock"]
        if not isinstance(c, (tuple, list)) or len(c) != 4:
            raise _state_error("clock", f"must be (origin, steps, reset origin, steps since "
                               f"reset), got {_short(c)}")
        t0, k0 = _state_real(c, 0, True, "clock"), _state_whole(c, 1, "clock")
        r0, k1 = _state_real(c, 2, True, "clock"), _state_whole(c, 3, "clock")
        h = self.scene.dt
        if t0 + k0 * h != time or r0 + k1 * h != since_reset:
            return restart
        return (t0, k0, r0, k1)

    def _apply_state(self, s: dict) -> None:
        """Assign a state checked by :meth:`_checked_state` (in place where arrays are big
        enough: the vector env holds views of them)."""
        n = s["n"]
        st, r = self._st, self._r
        st.set_bounds(r, s["bounds"])
        st.touch(r)
        self._n = 0
        self._reserve(n)
        self._pos[:n] = s["positions"]
        self._vel[:n] = s["velocities"]
        self._species[:n] = s["species"]
        self._species[n:] = -1
        self._internal_energy[:n] = s["internal_energy"]
        self._ids[:n] = s["ids"]
        self._idctr[0] = s["next_id"]
        self._steps = s["steps"]
        self._n = n
        if type(self._rng.bit_generator) is type(s["bit_generator"]):
            self._rng.bit_generator.state = s["rng"]
        else:
            self._set_rng(np.random.Generator(s["bit_generator"]))
        self._icnt[:] = 0
        self._icnt[:len(s["icnt"])] = s["icnt"]
        self._fsum[:] = s["fsum"]
        self._ch_count[:] = s["ch_count"]
        self._outflow[:] = s["outflow"]
        self._walls[:] = s["walls"]
        st.origin[r], st.steps[r], st.reset_origin[r], st.reset_steps[r] = s["clock"]
        self._energy_input = s["energy_input"]
        self._energy_start = s["energy_start"]
        self._integrator = s["integrator"]

    def __getstate__(self):
        return {"scene": self.scene, "state": self.get_state()}

    def __setstate__(self, d):
        if not isinstance(d, Mapping) or set(d) != {"scene", "state"} or \
                not isinstance(d["scene"], Scene):
            raise ValueError(f"Simulation.__setstate__: expected {{'scene': Scene, 'state': "
                             f"dict}} (from __getstate__), got {_short(d)}")
        self._setup(d["scene"], None)
        self.set_state(d["state"])

    def _clock(self) -> tuple:
        """(time origin, whole steps since it, the same for since_reset)."""
        st, r = self._st, self._r
        return (float(st.origin[r]), int(st.steps[r]), float(st.reset_origin[r]),
                int(st.reset_steps[r]))

    def copy(self) -> Simulation:
        other = Simulation.__new__(Simulation)
        other.__setstate__(self.__getstate__())
        return other

    def __repr__(self) -> str:
        return (f"Simulation({self.scene.name or 'scene'!s}, N={self._n}, t={self._time:.4g}, "
                f"kT={self.temperature():.4g})")


# ------------------------------------------------------------------ set_state's checks
_INT64_MAX = int(np.iinfo(np.int64).max)
# numpy bit generators a state may name (a Generator made from a seed uses PCG64)
_BIT_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")


def _state_counters(sim: Simulation, state, s: dict) -> None:
    """Check and convert the counters of ``state`` (``icnt``, ``fsum``, ``wall_temperature``,
    ``outflow``, ``ch_count``) into ``s``, for :meth:`Simulation._checked_state`."""
    icnt = _state_array(state, "icnt", (None,), integer=True)
    # counters are only ever appended: a state of an older version has a prefix of them
    if not _OLDEST_ICOUNTERS <= len(icnt) <= len(sim._icnt):
        raise _state_error("icnt", f"has {len(icnt)} counters, this version "
                           f"{_OLDEST_ICOUNTERS} to {len(sim._icnt)}: the state comes "
                           "from another version of discgym")
    s["icnt"] = icnt
    # (a state of a version before the thermal walls and outlets has 2 sums; those two
    # are >= 0, the wall heat and the outflow energy may have either sign)
    fsum = _state_array(state, "fsum", (None,))
    if len(fsum) not in (2, len(sim._fsum)):
        raise _state_error("fsum", f"must have shape ({len(sim._fsum)},), got "
                           f"{fsum.shape}")
    if fsum[:2].min() < 0:
        k = int(np.argmin(fsum[:2]))
        raise _state_error("fsum", f"of entry {k} is negative: {fsum[k]}")
    s["fsum"] = np.zeros(len(sim._fsum), dtype=FLOAT)
    s["fsum"][:len(fsum)] = fsum
    walls = state.get("wall_temperature", None)
    if "wall_temperature" not in state:  # (a state of an earlier version)
        s["walls"] = kernel_walls(sim.scene)
    elif not isinstance(walls, Mapping):
        raise _state_error("wall_temperature", f"must be a dict {{side: kT}} of the "
                           f"scene's thermal walls, got {_short(walls)}")
    else:
        try:
            s["walls"] = sim._checked_walls(walls, "wall_temperature", partial=False)
        except ValueError as exc:
            raise _state_error("wall_temperature", str(exc).split(": ", 1)[-1]) from None
    S = len(sim.scene.species)
    if "outflow" in state:
        s["outflow"] = _state_array(state, "outflow", (S,), integer=True)
    else:
        s["outflow"] = np.zeros(S, dtype=COUNT)
    s["ch_count"] = _state_array(state, "ch_count", (None,), integer=True)
    if len(s["ch_count"]) != len(sim._cs.labels):
        raise _state_error("ch_count", f"has {len(s['ch_count'])} reaction channels, this "
                           f"scene {len(sim._cs.labels)}: the state belongs to a scene with "
                           "other reactions")


def _state_error(key, what: str, within: str | None = None) -> ValueError:
    """The error naming ``state[key]`` (or ``state[within][key]``, an entry of a key)."""
    name = f"[{within!r}][{key!r}]" if within else f"[{key!r}]"
    return ValueError(f"set_state: state{name} {what}")


def _short(v) -> str:
    r = repr(v)
    return r if len(r) <= 80 else r[:77] + "..."


def _state_array(state, key: str, shape: tuple, integer: bool = False,
                 nonneg: bool = False) -> np.ndarray:
    """``state[key]`` as an array of the given shape (None: any length) of finite real numbers
    (FLOAT) or of integers in [0, 2**63) (COUNT; an empty array of any number dtype too)."""
    v = state[key]
    try:
        a = np.asarray(v)
    except (TypeError, ValueError):  # ragged nesting
        a = None
    kinds = "iu" if integer else "fiu"
    if a is None or not (a.dtype.kind in kinds or a.size == 0 and a.dtype.kind == "f"):
        raise _state_error(key, f"must be an array of {'integers' if integer else 'numbers'}"
                           f", got {_short(v)}" + ("" if a is None else f" (dtype {a.dtype})"))
    if a.shape == (0,) and shape == (None, 2):
        a = a.reshape(0, 2)  # no discs: [] (from tolist()) is as good as an empty (0, 2)
    if a.ndim != len(shape) or any(w is not None and w != m for w, m in zip(shape, a.shape)):
        want = ", ".join("N" if w is None else str(w) for w in shape)
        raise _state_error(key, f"must have shape ({want}{',' if len(shape) == 1 else ''}), "
                           f"got {a.shape}")
    item = "disc" if shape[0] is None and key not in ("icnt", "ch_count", "fsum") else "entry"
    if integer:
        # (as Python ints: numpy 1.x compares uint64 with int64 as float64, 2**63 <= 2**63 - 1)
        if a.size and (int(a.min()) < 0 or int(a.max()) > _INT64_MAX):
            k = int(np.argmin(a)) if a.min() < 0 else int(np.argmax(a))
            raise _state_error(key, f"of {item} {k} is {a[k]}: must be in [0, 2**63)")
        return np.ascontiguousarray(a, dtype=COUNT)
    a = np.ascontiguousarray(a, dtype=FLOAT)
    if not np.isfinite(a).all():
        k = np.flatnonzero(~np.isfinite(a.reshape(len(a), -1)).all(axis=1))[0]
        raise _state_error(key, f"of {item} {k} is not finite: {a[k]}")
    if nonneg and a.size and a.min() < 0:
        k = int(np.argmin(a))
        raise _state_error(key, f"of {item} {k} is negative: {a[k]}")
    return a


def _state_whole(state, key, within: str | None = None) -> int:
    v = state[key]
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise _state_error(key, f"must be an integer, got {_short(v)}", within)
    if not 0 <= int(v) <= _INT64_MAX:
        raise _state_error(key, f"must be in [0, 2**63), got {v}", within)
    return int(v)


def _state_real(state, key, nonneg: bool, within: str | None = None) -> float:
    v = state[key]
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise _state_error(key, f"must be a real number, got {_short(v)}", within)
    try:
        x = float(v)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise _state_error(key, f"must be finite, got {_short(v)}", within)
    if nonneg and x < 0:
        raise _state_error(key, f"must be >= 0, got {x}", within)
    return x


def _is_whole(v, lo: int, hi: int) -> bool:
    return not isinstance(v, bool) and isinstance(v, (int, np.integer)) and lo <= v < hi


def _same_value(a, b) -> bool:
    """Equal nested dicts / arrays / numbers (a generator state read back vs the given)."""
    if isinstance(a, Mapping) or isinstance(b, Mapping):
        return isinstance(a, Mapping) and isinstance(b, Mapping) and set(a) == set(b) and \
            all(_same_value(a[k], b[k]) for k in a)
    if isinstance(a, (np.ndarray, list, tuple)) or isinstance(b, (np.ndarray, list, tuple)):
        x, y = np.asarray(a), np.asarray(b)
        kinds = {x.dtype.kind, y.dtype.kind}
        return x.shape == y.shape and (len(kinds) == 1 or kinds <= set("iu")) and \
            bool((x == y).all())
    return type(a) is type(b) and a == b or (isinstance(a, (int, np.integer)) and
                                             isinstance(b, (int, np.integer)) and a == b)


def _checked_rng(value) -> np.random.BitGenerator:
    """A bit generator holding the generator state ``value``, after checking that numpy
    restores it exactly as given (its setters accept, and silently truncate, floats and
    out-of-range fields)."""
    name = value.get("bit_generator") if isinstance(value, Mapping) else None
    if not isinstance(name, str) or name not in _BIT_GENERATORS:
        raise _state_error("rng", f"must be a numpy bit-generator state (a dict from "
                           f"bit_generator.state, of {', '.join(_BIT_GENERATORS)}), got "
                           f"{_short(value)}")
    if name == "PCG64":
        st = value.get("state")
        ok = set(value) == {"bit_generator", "state", "has_uint32", "uinteger"} and \
            isinstance(st, Mapping) and set(st) == {"state", "inc"} and \
            _is_whole(st["state"], 0, 2 ** 128) and _is_whole(st["inc"], 0, 2 ** 128) and \
            st["inc"] % 2 == 1 and _is_whole(value["has_uint32"], 0, 2) and \
            _is_whole(value["uinteger"], 0, 2 ** 32)
        if not ok:  # (PCG64 streams have an odd increment)
            raise _state_error("rng", "is not a PCG64 state: need {'bit_generator': 'PCG64', "
                               "'state': {'state': int in [0, 2**128), 'inc': odd int in [0, "
                               "2**128)}, 'has_uint32': 0 or 1, 'uinteger': int in [0, 2**32)}"
                               f", got {_short(value)}")
    bg = getattr(np.random, name)(0)
    try:
        bg.state = value
        ok = _same_value(bg.state, value)
    except (TypeError, ValueError, KeyError, IndexError, OverflowError):
        ok = False
    if not ok:
        raise _state_error("rng", f"is not a state numpy restores as given: {_short(value)}")
    return bg


def _wall_heat(fsum) -> float:
    """The heat of the four sides' sums, added in side order."""
    k = _step.FS_WALL_HEAT
    return float(fsum[k]) + float(fsum[k + 1]) + float(fsum[k + 2]) + float(fsum[k + 3])


def _real(what: str, value) -> float:
    """A real-number argument as a float: numpy scalars (and 0-d arrays) as the Python
    numbers they are; bools and non-numbers raise ValueError naming ``what``."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value.item()
    value = plain(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{what}: expected a number, got {value!r}")
    try:
        return float(value)
    except OverflowError:  # an int beyond the float range
        return math.inf if value > 0 else -math.inf


def discs_inside(pos: np.ndarray, r: np.ndarray, kind: int, params: np.ndarray) -> np.ndarray:
    if kind == CIRCLE:
        d2 = (pos[:, 0] - params[0]) ** 2 + (pos[:, 1] - params[1]) ** 2
        L = params[2] - r
        return (L >= 0) & (d2 <= L * L)
    return ((pos[:, 0] >= params[0] + r) & (pos[:, 0] <= params[2] - r) &
            (pos[:, 1] >= params[1] + r) & (pos[:, 1] <= params[3] - r))


def _check_discs(pos, vel, species, u, sp_radius, bounds_kind, bounds_params, bounds,
                 what: str = "") -> None:
    """Finite positions, velocities and internal energies, no negative internal energy, every
    disc inside ``bounds``; else ``ValueError`` naming the first offending disc."""
    n = len(pos)
    if n == 0:
        return
    for name, arr in (("positions", pos), ("velocities", vel), ("internal_energy", u)):
        bad = np.flatnonzero(~np.isfinite(arr.reshape(n, -1)).all(axis=1))
        if len(bad):
            raise ValueError(f"{what}{name} of disc {bad[0]} is not finite: {arr[bad[0]]}")
    if (u < 0).any():
        raise ValueError(f"{what}internal_energy of disc {np.flatnonzero(u < 0)[0]} is "
                         "negative")
    r = sp_radius[species]
    outside = np.flatnonzero(~discs_inside(pos, r, bounds_kind, bounds_params))
    if len(outside):
        k = outside[0]
        raise ValueError(f"{what}positions: disc {k} (radius {r[k]}) at {pos[k]} is not "
                         f"inside the bounds {bounds}")


def check_sides(scene: Scene, bounds) -> None:
    """Refuse ``bounds`` replacing the scene's (:meth:`Simulation.resize`,
    :meth:`Simulation.set_state`) that lack a side a feature of the scene is on, by the rule
    ``Scene`` applies to its own bounds (``scene.check_side``): a box's "left" outlet must not
    become an arc of a circle, nor a circle's thermal wall a box's left side (the kernels index
    walls and outlets by side). Every entry with a ``side`` in a field of the scene (thermal
    walls, outlets) is checked; SceneError naming it, e.g. ``outlets[0].side``."""
    sides = sides_of(bounds)
    for f in dataclasses.fields(scene):
        items = getattr(scene, f.name)
        if not isinstance(items, tuple):
            continue
        for k, x in enumerate(items):
            if not hasattr(x, "side"):
                continue
            try:
                check_side(f"{f.name}[{k}]", x.side, sides, bounds.kind)
            except SceneError as e:
                why = str(e).removeprefix(f"{e.field}: ")
                raise SceneError(e.field, f"the scene's {x!r} cannot move to {bounds}: {why}; "
                                 "thermal walls and outlets keep their sides, so the bounds "
                                 f"keep their kind ({scene.bounds.kind})") from None


def event_fit(integrator: str, scene: Scene, bounds) -> str:
    """The event-driven integrator refuses bounds that leave a species less room than
    ``event_driven.FIT_MARGIN`` (1e-3) of its radius along an axis (box: width or height
    minus the diameter; circle: radius minus the disc's). A disc that fits exactly would meet
    both walls at once, forever, an event sequence with no end; one with a free gap g meets
    them every g / |v| (5e7 wall hits per unit time at g = 1e-8 radii), work without a
    practical bound. (The time-stepped integrator holds an exactly fitting disc in place.)"""
    if integrator == "event":
        for s in scene.species:
            if isinstance(bounds, Circle):
                gaps = [bounds.radius - s.radius]
            else:
                gaps = [bounds.width - 2 * s.radius, bounds.height - 2 * s.radius]
            if not min(gaps) >= _event.FIT_MARGIN * s.radius:
                what = "exactly" if min(gaps) <= _walls.FIT_TOL * s.radius else \
                    f"to within {min(gaps) / s.radius:.3g} of its radius"
                raise ValueError(
                    f"integrator='event': species {s.name!r} (radius {s.radius}) fits "
                    f"{bounds} {what}, with (almost) no room to move: its wall contacts "
                    "would (almost) never end. The event-driven integrator needs a free gap "
                    f"of at least {_event.FIT_MARGIN} of the radius along each axis. Use "
                    "the time-stepped integrator (the default), which holds such a disc in "
                    "place.")
    return integrator


def _integrator_name(name) -> str:
    if name not in ("step", "event"):
        raise ValueError(f"integrator: expected 'step' or 'event', got {name!r}")
    return name


def as_scene(scene) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, str):
        from . import scenes

        if scene in scenes.names():
            return scenes.load(scene)
        return Scene.from_toml(scene)
    raise TypeError(f"expected a Scene, a built-in scene name or a TOML path, got {scene!r}")
