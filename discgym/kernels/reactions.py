"""Reactions (physics.md 2, with the energy bookkeeping of notes.md).

Every reaction conserves mass, momentum and total energy = kinetic + internal + formation:

- Transformation A -> B (first order): velocity unchanged; the formation-energy difference goes
  into the disc's internal energy, so an endothermic one waits until that can pay for it.
- Decomposition A -> B + C and the reverse of a combination C -> A + B (first order): the
  fragments leave the parent's velocity V in opposite directions perpendicular to V (a random
  direction if V = 0) with equal and opposite momenta |P| = sqrt(2 mu E), E the energy
  released (internal + formation difference); they are placed touching, about the parent's
  centre of mass. The reverse fires only while the internal energy is above its barrier.
- Combination A + B -> C (on a collision with 1/2 mu v_r^2 >= E_a): C sits at the centre of
  mass with the centre-of-mass velocity and stores the relative kinetic energy, the reactants'
  internal energy and the formation-energy difference as internal energy.
- Exchange A + B -> C + D (same trigger): the products leave the centre of mass along the
  direction an elastic bounce would have given, with the relative speed that the available
  energy (relative kinetic + internal + formation difference) sets; their internal energy is 0.

Products are only placed where they fit inside the bounds without overlapping any disc;
where there is no room, the reaction does not happen (a collision then bounces elastically,
a first-order reaction waits for a later step).
"""

import math

import numpy as np
from numba import njit

from .celllist import overlaps_any
from .walls import inside

TRANSFORMATION, DECOMPOSITION, COMBINATION, EXCHANGE, REVERSE = 0, 1, 2, 3, 4
_SEP = 1.0 + 1e-9  # products are placed this fraction farther apart than touching


@njit(cache=True)
def room(x, y, r, ex1, ex2, collide, bkind, bp, pos, spc, sp_radius, grid, cell_start,
         cell_items, nbin, n, reach):
    if not inside(x, y, r, bkind, bp):
        return False
    if not collide:
        return True
    return not overlaps_any(x, y, r, ex1, ex2, pos, spc, sp_radius, grid, cell_start,
                            cell_items, nbin, n, reach)


@njit(cache=True)
def combine(i, j, c, t, xi, yi, xj, yj, tables, pos, vel, spc, uint, bkind, bp, grid,
            cell_start, cell_items, nbin, n, reach):
    """A + B -> C at contact time t; i becomes C, j dies (spc = -1). Returns True if fired."""
    sp_radius, sp_mass, sp_form = tables[0], tables[1], tables[2]
    ch_prod = tables[5]
    a = spc[i]
    b = spc[j]
    p = ch_prod[c, 0]
    mi = sp_mass[a]
    mj = sp_mass[b]
    M = mi + mj
    mu = mi * mj / M
    dvx = vel[i, 0] - vel[j, 0]
    dvy = vel[i, 1] - vel[j, 1]
    U = uint[i] + uint[j] + 0.5 * mu * (dvx * dvx + dvy * dvy) + sp_form[a] + sp_form[b] \
        - sp_form[p]
    if U < 0.0:
        return False
    Vx = (mi * vel[i, 0] + mj * vel[j, 0]) / M
    Vy = (mi * vel[i, 1] + mj * vel[j, 1]) / M
    X = (mi * xi + mj * xj) / M - t * Vx
    Y = (mi * yi + mj * yj) / M - t * Vy
    if not room(X, Y, sp_radius[p], i, j, True, bkind, bp, pos, spc, sp_radius, grid,
                cell_start, cell_items, nbin, n, reach):
        return False
    spc[i] = p
    pos[i, 0] = X
    pos[i, 1] = Y
    vel[i, 0] = Vx
    vel[i, 1] = Vy
    uint[i] = U
    spc[j] = -1
    vel[j, 0] = 0.0
    vel[j, 1] = 0.0
    uint[j] = 0.0
    return True


@njit(cache=True)
def exchange(i, j, c, t, xi, yi, xj, yj, nx, ny, tables, pos, vel, spc, uint, bkind, bp,
             grid, cell_start, cell_items, nbin, n, reach):
    """A + B -> C + D at contact time t (n from i to j); i and j become the products."""
    sp_radius, sp_mass, sp_form = tables[0], tables[1], tables[2]
    ch_reac, ch_prod = tables[4], tables[5]
    a = spc[i]
    b = spc[j]
    if a == ch_reac[c, 0]:
        pi, pj = ch_prod[c, 0], ch_prod[c, 1]
    else:
        pi, pj = ch_prod[c, 1], ch_prod[c, 0]
    mi = sp_mass[a]
    mj = sp_mass[b]
    M = mi + mj
    mu = mi * mj / M
    wx = vel[i, 0] - vel[j, 0]
    wy = vel[i, 1] - vel[j, 1]
    w2 = wx * wx + wy * wy
    E = 0.5 * mu * w2 + uint[i] + uint[j] + sp_form[a] + sp_form[b] - sp_form[pi] - sp_form[pj]
    if E < 0.0:
        return False
    mC = sp_mass[pi]
    mD = sp_mass[pj]
    Mp = mC + mD
    muCD = mC * mD / Mp
    # direction of the elastic outcome of the relative velocity
    wn = wx * nx + wy * ny
    ux = wx - 2.0 * wn * nx
    uy = wy - 2.0 * wn * ny
    w = math.sqrt(w2)
    if w > 0.0:
        ux /= w
        uy /= w
    else:
        ux = -nx
        uy = -ny
    s = math.sqrt(2.0 * E / muCD)
    Vx = (mi * vel[i, 0] + mj * vel[j, 0]) / M
    Vy = (mi * vel[i, 1] + mj * vel[j, 1]) / M
    vCx = Vx + mD / Mp * s * ux
    vCy = Vy + mD / Mp * s * uy
    vDx = Vx - mC / Mp * s * ux
    vDy = Vy - mC / Mp * s * uy
    d = (sp_radius[pi] + sp_radius[pj]) * _SEP
    cx = (mi * xi + mj * xj) / M
    cy = (mi * yi + mj * yj) / M
    XC = cx - mD / Mp * d * nx - t * vCx
    YC = cy - mD / Mp * d * ny - t * vCy
    XD = cx + mC / Mp * d * nx - t * vDx
    YD = cy + mC / Mp * d * ny - t * vDy
    if not room(XC, YC, sp_radius[pi], i, j, True, bkind, bp, pos, spc, sp_radius, grid,
                cell_start, cell_items, nbin, n, reach):
        return False
    if not room(XD, YD, sp_radius[pj], i, j, True, bkind, bp, pos, spc, sp_radius, grid,
                cell_start, cell_items, nbin, n, reach):
        return False
    spc[i] = pi
    spc[j] = pj
    pos[i, 0], pos[i, 1], vel[i, 0], vel[i, 1] = XC, YC, vCx, vCy
    pos[j, 0], pos[j, 1], vel[j, 0], vel[j, 1] = XD, YD, vDx, vDy
    uint[i] = 0.0
    uint[j] = 0.0
    return True


@njit(cache=True)
def released_energy(i, c, tables, spc, uint):
    """Energy a first-order channel c would release from disc i, or -1 if it cannot fire."""
    sp_form = tables[2]
    ch_kind, ch_prod, ch_energy = tables[3], tables[5], tables[7]
    kind = ch_kind[c]
    a = spc[i]
    if kind == TRANSFORMATION:
        return uint[i] + sp_form[a] - sp_form[ch_prod[c, 0]]
    if kind == REVERSE and uint[i] < ch_energy[c]:
        return -1.0
    return uint[i] + sp_form[a] - sp_form[ch_prod[c, 0]] - sp_form[ch_prod[c, 1]]


@njit(cache=True)
def first_order_choice(i, h, tables, spc, uint, rng):
    """Draw whether disc i undergoes one of its first-order channels during a step of length h.

    Competing channels with rates k_c (only those whose energy condition holds): one fires
    with probability 1 - exp(-K h), K = sum k_c, channel c with probability k_c / K.
    Returns the channel or -1.
    """
    ch_rate = tables[6]
    uni_start, uni_chan = tables[8], tables[9]
    s = spc[i]
    K = 0.0
    for q in range(uni_start[s], uni_start[s + 1]):
        c = uni_chan[q]
        if released_energy(i, c, tables, spc, uint) >= 0.0:
            K += ch_rate[c]
    if K == 0.0:
        return -1
    if rng.random() >= -math.expm1(-K * h):
        return -1
    x = rng.random() * K
    last = -1
    for q in range(uni_start[s], uni_start[s + 1]):
        c = uni_chan[q]
        if released_energy(i, c, tables, spc, uint) >= 0.0:
            last = c
            x -= ch_rate[c]
            if x < 0.0:
                return c
    return last


@njit(cache=True)
def transform(i, c, collide, tables, pos, spc, uint, bkind, bp, grid, cell_start, cell_items,
              nbin, n, reach):
    sp_radius, sp_form = tables[0], tables[2]
    p = tables[5][c, 0]
    a = spc[i]
    if sp_radius[p] > sp_radius[a] and not room(
            pos[i, 0], pos[i, 1], sp_radius[p], i, i, collide, bkind, bp, pos, spc, sp_radius,
            grid, cell_start, cell_items, nbin, n, reach):
        return False
    uint[i] += sp_form[a] - sp_form[p]
    if uint[i] < 0.0:  # round-off only: released_energy was checked >= 0
        uint[i] = 0.0
    spc[i] = p
    return True


@njit(cache=True)
def fission(i, c, n, collide, tables, pos, vel, spc, uint, bkind, bp, grid, cell_start,
            cell_items, nbin, reach, rng):
    """A -> B + C (decomposition or reverse combination): i becomes B, disc n becomes C.

    The caller guarantees capacity for disc n. Returns True if fired.
    """
    sp_radius, sp_mass = tables[0], tables[1]
    b = tables[5][c, 0]
    cc = tables[5][c, 1]
    E = released_energy(i, c, tables, spc, uint)
    m1 = sp_mass[b]
    m2 = sp_mass[cc]
    M = m1 + m2
    Vx = vel[i, 0]
    Vy = vel[i, 1]
    speed = math.sqrt(Vx * Vx + Vy * Vy)
    if speed > 0.0:
        nx = -Vy / speed
        ny = Vx / speed
    else:
        ang = 2.0 * math.pi * rng.random()
        nx = math.cos(ang)
        ny = math.sin(ang)
    if rng.random() < 0.5:
        nx = -nx
        ny = -ny
    d = (sp_radius[b] + sp_radius[cc]) * _SEP
    P = math.sqrt(2.0 * (m1 * m2 / M) * max(E, 0.0))
    X = pos[i, 0]
    Y = pos[i, 1]
    for attempt in range(2):
        x1 = X - m2 / M * d * nx
        y1 = Y - m2 / M * d * ny
        x2 = X + m1 / M * d * nx
        y2 = Y + m1 / M * d * ny
        if room(x1, y1, sp_radius[b], i, i, collide, bkind, bp, pos, spc, sp_radius, grid,
                cell_start, cell_items, nbin, n, reach) and \
                room(x2, y2, sp_radius[cc], i, i, collide, bkind, bp, pos, spc, sp_radius,
                     grid, cell_start, cell_items, nbin, n, reach):
            spc[i] = b
            pos[i, 0], pos[i, 1] = x1, y1
            vel[i, 0] = Vx - P / m1 * nx
            vel[i, 1] = Vy - P / m1 * ny
            uint[i] = 0.0
            spc[n] = cc
            pos[n, 0], pos[n, 1] = x2, y2
            vel[n, 0] = Vx + P / m2 * nx
            vel[n, 1] = Vy + P / m2 * ny
            uint[n] = 0.0
            return True
        nx = -nx
        ny = -ny
    return False


@njit(cache=True)
def grow1(a, n_new):
    out = np.zeros(n_new, dtype=a.dtype)
    out[: a.shape[0]] = a
    return out


@njit(cache=True)
def grow2(a, n_new):
    out = np.zeros((n_new, a.shape[1]), dtype=a.dtype)
    out[: a.shape[0]] = a
    return out
