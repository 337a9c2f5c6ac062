"""The controls of a reactor (heating, moving a wall, injecting), written once: the
:class:`~discgym.Simulation` methods validate their arguments and call these kernels, and the
environment's one-call step (:mod:`~discgym.kernels.batch`) calls the same kernels after it
has turned an action into their arguments, so both change a reactor's state the same way, to
the last bit. A refusal is a return value (nothing changed); the caller words the error.

Energy sums run in disc order with Neumaier's compensated summation (accurate to about one
rounding of the result, whatever N), and are what ``Simulation``'s energy observables report.
"""

import math

import numpy as np
from numba import njit

from .jit import kernel
from .placement import place, relocate
from .structs import INDEX
from .walls import inside

#: outcomes of :func:`resize`
RESIZED, TOO_BIG, TOO_DENSE, NO_ROOM = range(4)


@njit(cache=True)
def energies(vel, species, internal_energy, sp_mass, sp_form, n):
    """``(kinetic, internal, formation)`` energy of discs [0, n), each a compensated sum."""
    k = 0.0
    kc = 0.0
    u = 0.0
    uc = 0.0
    f = 0.0
    fc = 0.0
    for i in range(n):
        s = species[i]
        x = 0.5 * sp_mass[s] * (vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1])
        t = k + x
        kc += (k - t) + x if abs(k) >= abs(x) else (x - t) + k
        k = t
        x = internal_energy[i]
        t = u + x
        uc += (u - t) + x if abs(u) >= abs(x) else (x - t) + u
        u = t
        x = sp_form[s]
        t = f + x
        fc += (f - t) + x if abs(f) >= abs(x) else (x - t) + f
        f = t
    return k + kc, u + uc, f + fc


@kernel
def kinetic_and_fastest(vel, species, sp_mass, n):
    """``(kinetic energy, largest squared speed)`` of discs [0, n); ``vel`` (C, 2)."""
    ke = 0.0
    v2max = 0.0
    for i in range(n):
        v2 = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1]
        ke += 0.5 * sp_mass[species[i]] * v2
        if v2 > v2max:
            v2max = v2
    return ke, v2max


@kernel
def scale(vel, n, s):
    """``vel[:n] *= s`` in place."""
    for i in range(n):
        vel[i, 0] *= s
        vel[i, 1] *= s


@kernel
def heat(vel, species, sp_mass, n, factor, speed_limit, clip):
    """Multiply the kinetic energy of discs [0, n) by ``factor`` >= 0 (their velocities by
    its square root).

    If that would push the fastest disc past ``speed_limit``: with ``clip``, heat only up to
    the limit (not at all if a disc is already past it); without, change nothing. Returns
    ``(factor applied, energy added, fastest speed asked for)``; the factor is NaN when
    refused, 1 (and nothing computed) when there is nothing to do.
    """
    if factor == 1.0:
        return 1.0, 0.0, 0.0
    sc = math.sqrt(factor)
    ke0, v2max = kinetic_and_fastest(vel, species, sp_mass, n)
    vmax = math.sqrt(v2max)
    fastest = vmax * sc
    if sc > 1.0 and not fastest <= speed_limit:
        if not clip:
            return np.nan, 0.0, fastest
        sc = max(speed_limit / vmax, 1.0)
        factor = sc * sc
        if factor == 1.0:
            return 1.0, 0.0, fastest
    scale(vel, n, sc)
    ke1, _ = kinetic_and_fastest(vel, species, sp_mass, n)
    return factor, ke1 - ke0, fastest


@kernel
def resize(discs, n, sp_radius, bounds, fit_radius, area, packing, rngs, r, attempts):
    """Put discs [0, n) of ``discs`` (a :class:`~discgym.kernels.structs.Discs`) into new
    ``bounds`` (a :class:`~discgym.kernels.structs.Bounds`) whose largest disc radius is
    ``fit_radius`` and whose area is ``area``: a disc left outside moves to the nearest free
    spot found inside (:func:`~discgym.kernels.placement.relocate`; velocities kept, so no
    energy changes).

    Returns ``(outcome, discs without room)``: :data:`RESIZED`, or, with nothing moved,
    :data:`TOO_BIG` (the largest species does not fit), :data:`TOO_DENSE` (the discs would
    cover more than ``packing`` of the area), :data:`NO_ROOM` (discs outside found no free
    spot; the generator ``rngs[r]`` has been drawn from).
    """
    if sp_radius.max() > fit_radius:
        return TOO_BIG, 0
    pos = discs.pos
    species = discs.species
    all_in = True
    for i in range(n):
        if not inside(pos[i, 0], pos[i, 1], sp_radius[species[i]], bounds.kind,
                      bounds.params):
            all_in = False
            break
    if all_in:  # (e.g. the wall moved out)
        return RESIZED, 0
    disc_area = 0.0
    for i in range(n):
        q = sp_radius[species[i]]
        disc_area += math.pi * q * q
    if disc_area > packing * area:
        return TOO_DENSE, 0
    failed = relocate(pos, species, n, sp_radius, bounds, rngs[r], attempts)
    return (NO_ROOM, failed) if failed else (RESIZED, 0)


@kernel
def inject(discs, n, what, temperature_if_empty, speed_limit, tables, bounds, rngs, r,
           attempts):
    """Add up to ``len(what.targets)`` discs of species ``what.species`` (an
    :class:`~discgym.kernels.structs.Injection`) after discs [0, n) of ``discs`` (a
    :class:`~discgym.kernels.structs.Discs` with room for them), each at a free random spot in
    ``bounds`` (a :class:`~discgym.kernels.structs.Bounds`; near its row of the targets if
    that is not NaN), with Maxwell-Boltzmann velocities at ``what.temperature`` (NaN: the
    current kT, ``temperature_if_empty`` for an empty reactor), internal energy 0 and fresh
    identities.

    Returns ``(placed, energy added, fastest speed drawn)``. Placing stops at the first disc
    that finds no room. If a drawn speed passes ``speed_limit`` the whole injection is
    refused: ``(0, 0, fastest)``, nothing added, but the generator ``rngs[r]`` has been drawn
    from (:meth:`Simulation.inject <discgym.Simulation.inject>` puts its state back).
    """
    rng = rngs[r]
    vel = discs.vel
    species = discs.species
    internal_energy = discs.internal_energy
    sp_mass = tables.sp_mass
    sp_form = tables.sp_form
    ke, ui, fo = energies(vel, species, internal_energy, sp_mass, sp_form, n)
    e0 = ke + ui + fo
    temperature = what.temperature
    if not temperature >= 0.0:
        temperature = ke / n if n > 0 else temperature_if_empty
    kinds = np.full(what.targets.shape[0], what.species, dtype=INDEX)
    placed = place(discs.pos, species, n, kinds, what.targets, tables.sp_radius, bounds, rng,
                   attempts)
    sd = math.sqrt(temperature / sp_mass[what.species])
    fastest = 0.0
    for i in range(n, n + placed):
        vx = rng.standard_normal() * sd
        vy = rng.standard_normal() * sd
        vel[i, 0] = vx
        vel[i, 1] = vy
        v = math.sqrt(vx * vx + vy * vy)
        if not v <= fastest:
            fastest = v
    if not fastest <= speed_limit:
        for i in range(n, n + placed):
            species[i] = -1
            vel[i, 0] = 0.0
            vel[i, 1] = 0.0
        return 0, 0.0, fastest
    ids = discs.ids
    k0 = discs.next_id[0]
    for i in range(n, n + placed):
        internal_energy[i] = 0.0
        ids[i] = k0 + (i - n)
    discs.next_id[0] = k0 + placed
    ke, ui, fo = energies(vel, species, internal_energy, sp_mass, sp_form, n + placed)
    return placed, ke + ui + fo - e0, fastest


# -- the entry points Simulation's controls call from Python (an env's step links the kernels
#    above into its own, so its first compile emits no machine code of theirs)

@njit(cache=True)
def heat_entry(vel, species, sp_mass, n, factor, speed_limit, clip):
    """:func:`heat`, called from Python."""
    return heat(vel, species, sp_mass, n, factor, speed_limit, clip)


@njit(cache=True)
def resize_entry(discs, n, sp_radius, bounds, fit_radius, area, packing, rngs, r, attempts):
    """:func:`resize`, called from Python."""
    return resize(discs, n, sp_radius, bounds, fit_radius, area, packing, rngs, r, attempts)


@njit(cache=True)
def inject_entry(discs, n, what, temperature_if_empty, speed_limit, tables, bounds, rngs, r,
                 attempts):
    """:func:`inject`, called from Python."""
    return inject(discs, n, what, temperature_if_empty, speed_limit, tables, bounds, rngs, r,
                  attempts)


@njit(cache=True)
def set_wall_temperatures(walls, temps, t_max):
    """Set the thermal walls' temperatures: each side k of ``walls`` (N_SIDES,) that is
    thermal (not NaN) takes ``temps[k]`` where that is not NaN, clipped to
    [5e-324, t_max] (> 0; ``t_max``: the hottest a wall may be, see
    ``Scene.max_wall_temperature``). Specular sides (NaN) stay specular. Returns the number of
    sides changed. ``Simulation.set_wall_temperature`` validates its arguments (and refuses
    what this clips) and calls it; an environment's action can call it directly."""
    changed = 0
    for k in range(walls.shape[0]):
        t = temps[k]
        if walls[k] == walls[k] and t == t:
            t = min(max(t, 5e-324), t_max)
            if t != walls[k]:
                walls[k] = t
                changed += 1
    return changed
