"""What a reactor's state says: the views and observables of a :class:`~discgym.Simulation`
(positions, energies, temperature, pressure, counters, the energy ledger, overlaps), each a
function of its row of the :class:`~discgym.state.ReactorState`; :class:`Observables` gives
them to the handle as its methods.
"""

from __future__ import annotations

import math

import numpy as np

from .checks import discs_inside, real_arg
from .kernels import controls as _controls
from .kernels import step as _step
from .kernels.placement import overlapping_pairs
from .scene import sides_of
from .state import Row

SPEC_COUNTERS = {
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


def wall_heat_of(fsum) -> float:
    """The heat of the four sides' sums, added in side order."""
    k = _step.FS_WALL_HEAT
    return float(fsum[k]) + float(fsum[k + 1]) + float(fsum[k + 2]) + float(fsum[k + 3])


class Observables(Row):
    """The views and observables of a reactor's row (``scene``, ``_cs`` its compiled scene:
    set by the handle)."""

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
        return wall_heat_of(self._fsum)

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

    def counters(self) -> dict:
        """Event counters since the start: collisions, wall hits, substeps, ..."""
        return {k: int(self._icnt[v]) for k, v in SPEC_COUNTERS.items()}

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
        tol = real_arg("overlaps(tol)", tol)
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
        tol = real_arg("outside(tol)", tol)
        if not math.isfinite(tol):
            raise ValueError(f"outside(tol): need a finite tolerance, got {tol}")
        r = self.radii * (1.0 - tol)
        inside = discs_inside(self._pos[: self._n], r, self._bounds_kind, self._bounds_params)
        return int((~inside).sum())
