"""The Python handle on a running reactor: validates and casts, then calls the kernels.

>>> import discgym as dg
>>> sim = dg.Simulation(dg.scenes.load("ideal_gas"), seed=0)
>>> sim.advance(1.0)
>>> round(sim.temperature(), 6) == round(sim.kinetic_energy() / len(sim), 6)
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numba
import numpy as np

from .checks import (  # noqa: F401  (importable from here too, as before)
    as_scene,
    check_discs,
    check_sides,
    discs_inside,
    event_fit,
    integrator_name,
    real_arg,
)
from .compiled import compile_scene, kernel_bounds, kernel_walls
from .kernels import controls as _controls
from .kernels import event_driven as _event
from .kernels import step as _step
from .kernels.placement import overlapping_pairs, place_rngs
from .kernels.structs import (
    FLOAT,
    INDEX,
    P_MAXDISP,
    P_RMIN,
    Bounds,
    Discs,
    Injection,
    speed_limit,
)
from .observables import Observables
from .scene import (
    HEX_PACKING,
    MAX_MAGNITUDE,
    Box,
    Circle,
    Scene,
    SceneError,
    check_bounds_scale,
    finite_value,
    sides_of,
    too_hot_for_walls,
    validated_counts,
)
from .state import ReactorState
from .state_io import StateIO
from .threads import ThreadChooser, numba_threads
from .values import integer, plain, real

__all__ = ["Simulation", "PlacementError"]

PLACEMENT_ATTEMPTS = 2000  #: random placement tries per disc before a spot counts as not found



class PlacementError(ValueError):
    """Discs could not be placed (or kept) without overlap in the bounds."""


def _rng(seed) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.Generator(np.random.PCG64(plain(seed)))


class Simulation(Observables, StateIO):
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
        row: ``(state, r)``, a :class:`~discgym.state.ReactorState` of the scene's species
            and reactions and a row of it, to live in (emptied first): how the environments
            keep every reactor in one state. Default: a state of one row of its own.

    Arrays returned by the properties are copies; shapes use N = ``len(sim)``.
    """

    def __init__(self, scene: Scene | str, counts: Mapping[str, int] | None = None,
                 temperature: float | None = None, seed=None, integrator: str = "step", *,
                 row: tuple[ReactorState, int] | None = None):
        integrator = integrator_name(integrator)
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
        self._integrator = integrator_name(integrator)
        return self

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
        integrator = integrator_name(integrator)
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
        check_discs(pos, vel, spc, u, self._cs.sp_radius, self._bounds_kind, self._bounds_params,
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
            if isinstance(s, str):
                if s not in names:
                    raise ValueError(f"species of disc {k}: unknown species {s!r} "
                                     f"(scene has {names})")
                out[k] = names.index(s)
                continue
            if real(s) is None:
                raise ValueError(f"species of disc {k}: expected a species name or index, got "
                                 f"{s!r}")
            i = integer(s, integral_float=True)
            if i is None or not 0 <= i < len(names):
                raise ValueError(f"species of disc {k}: no species index {s!r}")
            out[k] = i
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
        k = integer(value, integral_float=True)
        if k is None:
            raise ValueError(f"threads: expected a whole number, got {plain(value)!r}")
        self._threads = max(k, 1)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps of ``scene.dt``."""
        k = integer(n, integral_float=True)
        if k is None or k < 0:
            raise ValueError(f"step(n): need a whole number >= 0, got {n!r}")
        n = k
        if n:
            self._run(n, self.scene.dt)

    def advance(self, duration: float) -> None:
        """Advance the simulated time by ``duration``: whole steps of ``scene.dt``, then one
        shorter step for the remainder (if more than 1e-9 of a step)."""
        duration = real_arg("advance(duration)", duration)
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
            kT = real_arg(f"{what}({sd!r})", kT)
            if not math.isfinite(kT) or kT <= 0.0:
                raise ValueError(f"{what}({sd!r}): need a finite temperature > 0, got {kT}")
            if not kT <= t_max:
                raise ValueError(f"{what}({sd!r}): {too_hot_for_walls(kT, t_max)}")
            walls[sides.index(sd)] = kT
        if not partial and set(todo) != set(thermal):
            miss = sorted(set(thermal) - set(todo))
            raise ValueError(f"{what}: no temperature for the thermal walls {miss}")
        return walls

    # ------------------------------------------------------------------ controls
    def scale_temperature(self, factor: float) -> None:
        """Multiply every kinetic energy by ``factor`` >= 0 (velocities by sqrt(factor)).

        The energy added (or removed) is booked in :attr:`energy_input`. Heating that would
        push a disc past :attr:`speed_limit` is refused with ``ValueError`` (nothing changes);
        cooling always applies."""
        factor = real_arg("scale_temperature(factor)", factor)
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
        k = integer(n, integral_float=True)
        if k is None or k < 0:
            raise ValueError(f"inject(n): need a whole number >= 0, got {n!r}")
        n = k
        if n == 0:
            return 0
        given = temperature is not None
        if not given:
            temperature = self.temperature() if self._n else self.scene.temperature
        temperature = real_arg("inject(temperature)", temperature)
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

    def __repr__(self) -> str:
        return (f"Simulation({self.scene.name or 'scene'!s}, N={self._n}, t={self._time:.4g}, "
                f"kT={self.temperature():.4g})")


