"""The fallback past the event bound: resolve what is left of a substep without time order.

The time-stepped integrator processes a substep's contacts one by one in time order (see
:mod:`.step`). Two configurations have no finite event sequence in exact hard-disc dynamics,
or one too long to follow: a disc wedged between the curved circle wall and another disc
while sliding along the wall (its reflections come at the same instant, forever), and
clusters whose collisions pile up faster than the per-disc event bound allows. When a disc
exhausts its events of a substep, its remaining contacts in that substep are dropped and the
state at the end of the substep is repaired here instead. The same repair ends a substep in
which a pair was found overlapping while separating (``collisions.SEPARATING_OVERLAP``): left
so by a graze inside an earlier substep, not seen because both of its ends were outside
contact, during which an event turned one of the discs. The repair keeps the invariants:

- every disc outside the bounds is moved back inside (along the wall normal) and the
  outward component of its velocity is reflected (the wall receives 2 m |v_n|); a disc held
  at the wall during a pair push (below) is only moved (its next drift reflects it);
- every overlapping pair is pushed apart along its line of centres by 1.5 times its overlap
  (over-relaxation), each disc moved in inverse proportion to its mass (the centre of mass
  stays put) unless that would move it out of the bounds: then it is held inside and the
  other disc moves the rest; if the pair is approaching it exchanges the impulse of a
  collision with restitution e (the kinetic energy lost is booked as dissipated).

Positions move but no velocity is scaled, so the energy ledger stays exact; momentum is
conserved by the pair velocity corrections. The passes repeat until nothing is left to repair
or the pass bound is reached: ``RESOLVE_WORK / n`` passes, at least 64 and at most
``RESOLVE_PASSES`` (a packing too dense to untangle keeps its remaining overlaps, which
``Simulation.overlaps`` reports). Each repair is counted.
"""

import math

import numpy as np

from .celllist import build, cell_range
from .jit import kernel
from .walls import inside, push_inside

RESOLVE_PASSES = 4096  # at most this many passes, and at most RESOLVE_WORK / n (but >= 64)
RESOLVE_WORK = 1 << 20  # disc-passes: the work bound of one repair below 16384 discs (~0.05 s);
# above, 64 passes
_SEP = 1.0 + 1e-12  # pairs are pushed this fraction beyond touching, ...
_OVER = 1.5  # ... by this multiple of their overlap (over-relaxation: 3x fewer passes where a
# ring of discs pressed against the circle wall took ~800 passes to untangle)


@kernel
def _move_inside(i, pos, r, bounds_kind, bounds_params):
    """Move disc i (radius r) to the nearest point inside the bounds, so that ``inside``
    holds afterwards (in the circle a margin of 1e-12 of R_m - r, as the rescaled position
    can land a rounding error outside); returns False if it was inside already."""
    if inside(pos[i, 0], pos[i, 1], r, bounds_kind, bounds_params):
        return False
    push_inside(i, pos, r, bounds_kind, bounds_params)
    if bounds_kind != 0 and not inside(pos[i, 0], pos[i, 1], r, bounds_kind, bounds_params):
        L = bounds_params[2] - r
        dx = pos[i, 0] - bounds_params[0]
        dy = pos[i, 1] - bounds_params[1]
        k = L * (1.0 - 1e-12) / math.sqrt(dx * dx + dy * dy)
        pos[i, 0] = bounds_params[0] + dx * k
        pos[i, 1] = bounds_params[1] + dy * k
    return True


@kernel
def _wall_fix(i, pos, vel, r, m, bounds_kind, bounds_params):
    """Move disc i inside and reflect its outward velocity; returns the wall momentum."""
    x0 = pos[i, 0]
    y0 = pos[i, 1]
    _move_inside(i, pos, r, bounds_kind, bounds_params)
    dp = 0.0
    if bounds_kind == 0:
        if pos[i, 0] > x0 and vel[i, 0] < 0.0 or pos[i, 0] < x0 and vel[i, 0] > 0.0:
            dp += 2.0 * m * abs(vel[i, 0])
            vel[i, 0] = -vel[i, 0]
        if pos[i, 1] > y0 and vel[i, 1] < 0.0 or pos[i, 1] < y0 and vel[i, 1] > 0.0:
            dp += 2.0 * m * abs(vel[i, 1])
            vel[i, 1] = -vel[i, 1]
    else:
        nx = pos[i, 0] - bounds_params[0]
        ny = pos[i, 1] - bounds_params[1]
        d = math.sqrt(nx * nx + ny * ny)
        if d > 0.0:
            nx /= d
            ny /= d
            vn = vel[i, 0] * nx + vel[i, 1] * ny
            if vn > 0.0:
                vel[i, 0] -= 2.0 * vn * nx
                vel[i, 1] -= 2.0 * vn * ny
                dp = 2.0 * m * vn
    return dp


@kernel
def _repair_pair(i, j, pos, vel, species, sp_radius, sp_mass, e, bounds_kind, bounds_params):
    """Push discs i and j apart if they overlap (see the module docstring); returns
    ``(repaired, kinetic energy lost)``.

    The wall is rigid here: a disc the push would move out of the bounds is held inside and
    its partner takes the rest of the separation. (Splitting it by mass and leaving the wall
    to the next pass let a ring of discs pressed against the circle wall by an inner cluster
    converge by a few percent per pass: 64 passes left overlaps of 5e-6.)"""
    si = species[i]
    sj = species[j]
    R = sp_radius[si] + sp_radius[sj]
    dx = pos[j, 0] - pos[i, 0]
    dy = pos[j, 1] - pos[i, 1]
    d2 = dx * dx + dy * dy
    if d2 >= R * R:
        return False, 0.0
    d = math.sqrt(d2)
    if d > 0.0:
        nx = dx / d
        ny = dy / d
    else:
        nx = 1.0
        ny = 0.0
    mi = sp_mass[si]
    mj = sp_mass[sj]
    M = mi + mj
    gap = (R * _SEP - d) * _OVER
    pos[i, 0] -= gap * mj / M * nx
    pos[i, 1] -= gap * mj / M * ny
    pos[j, 0] += gap * mi / M * nx
    pos[j, 1] += gap * mi / M * ny
    # (int64 indices: the signature of the other callers, so that numba compiles one version)
    held_i = _move_inside(np.int64(i), pos, sp_radius[si], bounds_kind, bounds_params)
    held_j = _move_inside(np.int64(j), pos, sp_radius[sj], bounds_kind, bounds_params)
    if held_i != held_j:  # the one held by the wall stays, the other moves the rest
        k = j if held_i else i
        ex = pos[j, 0] - pos[i, 0]
        ey = pos[j, 1] - pos[i, 1]
        de = math.sqrt(ex * ex + ey * ey)
        rest = R * _SEP - de
        if rest > 0.0:
            if de > 0.0:
                ex /= de
                ey /= de
            else:
                ex = nx
                ey = ny
            sgn = 1.0 if k == j else -1.0
            pos[k, 0] += sgn * rest * ex
            pos[k, 1] += sgn * rest * ey
            _move_inside(k, pos, sp_radius[species[k]], bounds_kind, bounds_params)
    lost = 0.0
    vr = (vel[i, 0] - vel[j, 0]) * nx + (vel[i, 1] - vel[j, 1]) * ny
    if vr > 0.0:
        mu = mi * mj / M
        dp = (1.0 + e) * mu * vr
        vel[i, 0] -= dp / mi * nx
        vel[i, 1] -= dp / mi * ny
        vel[j, 0] += dp / mj * nx
        vel[j, 1] += dp / mj * ny
        lost = 0.5 * (1.0 - e * e) * mu * vr * vr
    return True, lost


@kernel
def resolve(n, ph):
    """Repair discs [0, n) of the :class:`~.structs.Phase` ``ph`` (see the module
    docstring). Leaves the cell list built at the final positions. Returns ``(repairs,
    wall_momentum, dissipated)``."""
    pos, vel, species = ph.discs.pos, ph.discs.vel, ph.discs.species
    sp_radius, sp_mass = ph.tables.sp_radius, ph.tables.sp_mass
    e, collide = ph.rc.restitution, ph.rc.collide
    bounds_kind, bounds_params, grid = ph.bounds.kind, ph.bounds.params, ph.grid
    cell_start, cell_items, cell_of = ph.sc.cell_start, ph.sc.cell_items, ph.sc.cell_of
    ncx = int(grid[4])
    ncy = int(grid[5])
    rcell = grid[6]
    nbc = ncx * ncy
    repairs = 0
    wall_dp = 0.0
    lost = 0.0
    passes = max(64, min(RESOLVE_PASSES, RESOLVE_WORK // max(n, 1)))
    for _pass in range(passes):
        fixed = 0
        for i in range(n):
            s = species[i]
            if s >= 0 and not inside(pos[i, 0], pos[i, 1], sp_radius[s], bounds_kind,
                                     bounds_params):
                wall_dp += _wall_fix(i, pos, vel, sp_radius[s], sp_mass[s], bounds_kind,
                                     bounds_params)
                fixed += 1
        if collide:
            build(n, pos, species, sp_radius, grid, cell_start, cell_items, cell_of)
            for i in range(n):
                if species[i] < 0:
                    continue
                # cells that can hold an overlapping partner: a small disc's 3 x 3 around
                # its cell, a big disc's within its radius + rcell; and every big disc
                c = cell_of[i]
                if c == nbc:
                    x0, x1, y0, y1 = cell_range(pos[i, 0], pos[i, 1],
                                                sp_radius[species[i]] + rcell, grid)
                    x1 += 1
                    y1 += 1
                else:
                    x0 = max(c % ncx - 1, 0)
                    x1 = min(c % ncx + 2, ncx)
                    y0 = max(c // ncx - 1, 0)
                    y1 = min(c // ncx + 2, ncy)
                for yy in range(y0, y1):
                    for xx in range(x0, x1):
                        cc = xx + ncx * yy
                        for a in range(cell_start[cc], cell_start[cc + 1]):
                            j = cell_items[a]
                            if j > i:
                                ok, dl = _repair_pair(i, j, pos, vel, species, sp_radius, sp_mass,
                                                      e, bounds_kind, bounds_params)
                                fixed += ok
                                lost += dl
                for a in range(cell_start[nbc], cell_start[nbc + 1]):
                    j = cell_items[a]
                    if j > i:
                        ok, dl = _repair_pair(i, j, pos, vel, species, sp_radius, sp_mass, e,
                                              bounds_kind, bounds_params)
                        fixed += ok
                        lost += dl
        repairs += fixed
        if fixed == 0:
            break
    if collide:
        build(n, pos, species, sp_radius, grid, cell_start, cell_items, cell_of)
    return repairs, wall_dp, lost
