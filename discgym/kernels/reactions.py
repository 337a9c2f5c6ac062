"""Reactions (docs/physics.md, section 5).

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
without room the reaction does not happen (an ordinary collision: restitution, TC model,
relaxation; a first-order reaction is tried again in the next substep, in the event-driven
integrator at least one substep of the time-stepped one later).
"""

import math

import numpy as np
from numba import njit

from .celllist import overlaps_any
from .walls import inside

TRANSFORMATION, DECOMPOSITION, COMBINATION, EXCHANGE, REVERSE = 0, 1, 2, 3, 4
FIRED, NO_ENERGY, NO_ROOM = 1, 0, -1  # outcomes of a reactive collision
_SEP = 1.0 + 1e-9  # products are placed this fraction farther apart than touching


@njit(cache=True)
def room(x, y, r, t, ex1, ex2, collide, bkind, bp, pos, vel, spc, sp_radius, grid, cell_start,
         cell_items, nbin, n, reach):
    """Is there room for a disc of radius r at (x, y) at time t (<= 0: the contact time of a
    reactive collision, 0 for a first-order reaction at the end of the substep), inside the
    bounds and clear of every other disc (except ex1, ex2) where it is at that time?"""
    if not inside(x, y, r, bkind, bp):
        return False
    if not collide:
        return True
    return not overlaps_any(x, y, r, t, ex1, ex2, pos, vel, spc, sp_radius, grid, cell_start,
                            cell_items, nbin, n, reach)


@njit(cache=True)
def combine_outcome(mi, mj, vxi, vyi, vxj, vyj, xi, yi, xj, yj, ui, uj, fa, fb, fp, t):
    """The product of A + B -> C (pure: scalars in, scalars out).

    Reactants of masses mi, mj with velocities v_i, v_j at contact positions (xi, yi),
    (xj, yj); internal energies ui, uj; formation energies fa, fb of the reactants and fp of
    the product. C sits at the centre of mass, wound forward by -t (t <= 0: the contact was
    -t ago; 0 for the event-driven integrator), with the centre-of-mass velocity, and stores
    U = ui + uj + 1/2 mu |v_i - v_j|^2 + fa + fb - fp. Returns ``(ok, X, Y, Vx, Vy, U)``,
    ok False (and zeros) when U < 0 (an endothermic combination the energy cannot pay for).
    """
    M = mi + mj
    mu = mi * mj / M
    dvx = vxi - vxj
    dvy = vyi - vyj
    U = ui + uj + 0.5 * mu * (dvx * dvx + dvy * dvy) + fa + fb - fp
    if U < 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    Vx = (mi * vxi + mj * vxj) / M
    Vy = (mi * vyi + mj * vyj) / M
    X = (mi * xi + mj * xj) / M - t * Vx
    Y = (mi * yi + mj * yj) / M - t * Vy
    return True, X, Y, Vx, Vy, U


@njit(cache=True)
def combine(i, j, c, t, xi, yi, xj, yj, tables, pos, vel, spc, uint, bkind, bp, grid,
            cell_start, cell_items, nbin, n, reach):
    """A + B -> C at contact time t; i becomes C, j dies (spc = -1). Returns FIRED, or
    NO_ENERGY (an endothermic product the energy cannot pay for) or NO_ROOM."""
    sp_radius, sp_mass, sp_form = tables[0], tables[1], tables[2]
    ch_prod = tables[5]
    a = spc[i]
    b = spc[j]
    p = ch_prod[c, 0]
    ok, X, Y, Vx, Vy, U = combine_outcome(
        sp_mass[a], sp_mass[b], vel[i, 0], vel[i, 1], vel[j, 0], vel[j, 1], xi, yi, xj, yj,
        uint[i], uint[j], sp_form[a], sp_form[b], sp_form[p], t)
    if not ok:
        return NO_ENERGY
    # room where C appears: at the contact, not where it would be at the end of the substep
    if not room(X + t * Vx, Y + t * Vy, sp_radius[p], t, i, j, True, bkind, bp, pos, vel, spc,
                sp_radius, grid, cell_start, cell_items, nbin, n, reach):
        return NO_ROOM
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
    return FIRED


@njit(cache=True)
def exchange_species(c, a, ch_reac, ch_prod):
    """The products (for i, for j) of exchange channel c when disc i is of species a."""
    if a == ch_reac[c, 0]:
        return ch_prod[c, 0], ch_prod[c, 1]
    return ch_prod[c, 1], ch_prod[c, 0]


@njit(cache=True)
def exchange_outcome(mi, mj, mC, mD, rC, rD, vxi, vyi, vxj, vyj, xi, yi, xj, yj, nx, ny, ui,
                     uj, fa, fb, fC, fD, t):
    """The products of A + B -> C + D (pure: scalars in, scalars out).

    Reactants i (-> C) and j (-> D) of masses mi, mj at contact positions (xi, yi), (xj, yj)
    with unit normal n from i to j; products of masses mC, mD and radii rC, rD; internal
    energies ui, uj; formation energies fa, fb (reactants), fC, fD (products). The products
    leave the centre of mass along the direction an elastic bounce gives the relative
    velocity, with the relative speed the available energy E = 1/2 mu |w|^2 + ui + uj + fa +
    fb - fC - fD sets; they are placed (rC + rD)(1 + 1e-9) apart along n about the centre of
    mass, wound forward by -t (t <= 0). Returns ``(ok, XC, YC, vCx, vCy, XD, YD, vDx, vDy)``,
    ok False (and zeros) when E < 0.
    """
    M = mi + mj
    mu = mi * mj / M
    wx = vxi - vxj
    wy = vyi - vyj
    w2 = wx * wx + wy * wy
    E = 0.5 * mu * w2 + ui + uj + fa + fb - fC - fD
    if E < 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
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
    Vx = (mi * vxi + mj * vxj) / M
    Vy = (mi * vyi + mj * vyj) / M
    vCx = Vx + mD / Mp * s * ux
    vCy = Vy + mD / Mp * s * uy
    vDx = Vx - mC / Mp * s * ux
    vDy = Vy - mC / Mp * s * uy
    d = (rC + rD) * _SEP
    cx = (mi * xi + mj * xj) / M
    cy = (mi * yi + mj * yj) / M
    XC = cx - mD / Mp * d * nx - t * vCx
    YC = cy - mD / Mp * d * ny - t * vCy
    XD = cx + mC / Mp * d * nx - t * vDx
    YD = cy + mC / Mp * d * ny - t * vDy
    return True, XC, YC, vCx, vCy, XD, YD, vDx, vDy


@njit(cache=True)
def exchange(i, j, c, t, xi, yi, xj, yj, nx, ny, tables, pos, vel, spc, uint, bkind, bp,
             grid, cell_start, cell_items, nbin, n, reach):
    """A + B -> C + D at contact time t (n from i to j); i and j become the products.
    Returns FIRED, NO_ENERGY or NO_ROOM (as :func:`combine`)."""
    sp_radius, sp_mass, sp_form = tables[0], tables[1], tables[2]
    ch_reac, ch_prod = tables[4], tables[5]
    a = spc[i]
    b = spc[j]
    pi, pj = exchange_species(c, a, ch_reac, ch_prod)
    ok, XC, YC, vCx, vCy, XD, YD, vDx, vDy = exchange_outcome(
        sp_mass[a], sp_mass[b], sp_mass[pi], sp_mass[pj], sp_radius[pi], sp_radius[pj],
        vel[i, 0], vel[i, 1], vel[j, 0], vel[j, 1], xi, yi, xj, yj, nx, ny, uint[i], uint[j],
        sp_form[a], sp_form[b], sp_form[pi], sp_form[pj], t)
    if not ok:
        return NO_ENERGY
    # room where the products appear, at the contact
    if not room(XC + t * vCx, YC + t * vCy, sp_radius[pi], t, i, j, True, bkind, bp, pos, vel,
                spc, sp_radius, grid, cell_start, cell_items, nbin, n, reach):
        return NO_ROOM
    if not room(XD + t * vDx, YD + t * vDy, sp_radius[pj], t, i, j, True, bkind, bp, pos, vel,
                spc, sp_radius, grid, cell_start, cell_items, nbin, n, reach):
        return NO_ROOM
    spc[i] = pi
    spc[j] = pj
    pos[i, 0], pos[i, 1], vel[i, 0], vel[i, 1] = XC, YC, vCx, vCy
    pos[j, 0], pos[j, 1], vel[j, 0], vel[j, 1] = XD, YD, vDx, vDy
    uint[i] = 0.0
    uint[j] = 0.0
    return FIRED


@njit(cache=True)
def channel_energy(kind, u, f_parent, f_prod1, f_prod2, barrier):
    """Energy a first-order channel of ``kind`` would release from a disc with internal
    energy u (formation energies: the parent's and its products'; ``f_prod2`` is ignored by a
    transformation), or -1 if it cannot fire (the reverse of a combination below its
    ``barrier``). Scalars only, so it costs nothing to call per disc."""
    if kind == TRANSFORMATION:
        return u + f_parent - f_prod1
    if kind == REVERSE and u < barrier:
        return -1.0
    return u + f_parent - f_prod1 - f_prod2


@njit(cache=True)
def released_energy(i, c, tables, spc, uint):
    """Energy a first-order channel c would release from disc i, or -1 if it cannot fire."""
    sp_form = tables[2]
    ch_prod = tables[5]
    return channel_energy(tables[3][c], uint[i], sp_form[spc[i]], sp_form[ch_prod[c, 0]],
                          sp_form[ch_prod[c, 1]], tables[7][c])


@njit(cache=True)
def first_order_draws(n, h, sp_form, ch_kind, ch_prod, ch_rate, ch_energy, uni_start,
                      uni_chan, spc, uint, rng, out_disc, out_chan):
    """Draw which discs [0, n) undergo a first-order reaction in a step of length h.

    Each disc's competing channels with rates k_c (only those whose energy condition holds
    now): one fires with probability 1 - exp(-K h), K = sum k_c, channel c with probability
    k_c / K. The reacting discs and their channels are written to ``out_disc``,
    ``out_chan`` (n,); returns how many. One pass taking the arrays once: per-disc helpers
    taking arrays cost a reference count per array per call (measured: 70-110 ns per disc
    for a rate computation that takes 7 ns written out, as here).
    """
    m = 0
    for i in range(n):
        s = spc[i]
        if s < 0:
            continue
        q0 = uni_start[s]
        q1 = uni_start[s + 1]
        if q0 == q1:  # no channel for this species
            continue
        u = uint[i]
        fs = sp_form[s]
        K = 0.0
        for q in range(q0, q1):
            c = uni_chan[q]
            if channel_energy(ch_kind[c], u, fs, sp_form[ch_prod[c, 0]],
                              sp_form[ch_prod[c, 1]], ch_energy[c]) >= 0.0:
                K += ch_rate[c]
        if K == 0.0 or rng.random() >= -math.expm1(-K * h):
            continue
        x = rng.random() * K
        pick = -1
        for q in range(q0, q1):
            c = uni_chan[q]
            if channel_energy(ch_kind[c], u, fs, sp_form[ch_prod[c, 0]],
                              sp_form[ch_prod[c, 1]], ch_energy[c]) >= 0.0:
                pick = c
                x -= ch_rate[c]
                if x < 0.0:
                    break
        out_disc[m] = i
        out_chan[m] = pick
        m += 1
    return m


@njit(cache=True)
def first_order_rate(i, tables, spc, uint):
    """Total rate K of the first-order channels of disc i whose energy condition holds now
    (per event, for the event-driven integrator; :func:`first_order_draws` is the per-step
    pass). K changes only when the disc's species or internal energy does."""
    ch_rate = tables[6]
    uni_start, uni_chan = tables[8], tables[9]
    s = spc[i]
    K = 0.0
    for q in range(uni_start[s], uni_start[s + 1]):
        c = uni_chan[q]
        if released_energy(i, c, tables, spc, uint) >= 0.0:
            K += ch_rate[c]
    return K


@njit(cache=True)
def first_order_pick(i, K, tables, spc, uint, rng):
    """Which eligible first-order channel of disc i fires (channel c with chance k_c / K; K
    from :func:`first_order_rate`, > 0). Draws one random number."""
    ch_rate = tables[6]
    uni_start, uni_chan = tables[8], tables[9]
    s = spc[i]
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
def transform_energy(u, fa, fp):
    """Internal energy after A -> B of a disc with internal energy u (formation energies fa,
    fp): the formation-energy difference goes into it (never below 0: round-off only, since
    the channel fires only when this is >= 0)."""
    u += fa - fp
    if u < 0.0:
        u = 0.0
    return u


@njit(cache=True)
def transform(i, c, collide, tables, pos, vel, spc, uint, bkind, bp, grid, cell_start,
              cell_items, nbin, n, reach):
    sp_radius, sp_form = tables[0], tables[2]
    p = tables[5][c, 0]
    a = spc[i]
    if sp_radius[p] > sp_radius[a] and not room(
            pos[i, 0], pos[i, 1], sp_radius[p], 0.0, i, i, collide, bkind, bp, pos, vel, spc,
            sp_radius, grid, cell_start, cell_items, nbin, n, reach):
        return False
    uint[i] = transform_energy(uint[i], sp_form[a], sp_form[p])
    spc[i] = p
    return True


@njit(cache=True)
def fission_direction(Vx, Vy, rng):
    """Unit direction along which the fragments of a parent with velocity V separate:
    perpendicular to V with a random sign (a random direction if V = 0). Draws 1 or 2
    random numbers."""
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
    return nx, ny


@njit(cache=True)
def fission_outcome(X, Y, Vx, Vy, E, m1, m2, d, nx, ny):
    """The fragments of A -> B + C (pure): parent at (X, Y) with velocity V, energy released
    E, fragment masses m1 (B), m2 (C), centre distance d, separation direction n (from B to
    C). They sit about the parent's centre of mass and carry equal and opposite momenta
    |P| = sqrt(2 mu E) in its frame. Returns ``(x1, y1, v1x, v1y, x2, y2, v2x, v2y)``."""
    M = m1 + m2
    P = math.sqrt(2.0 * (m1 * m2 / M) * max(E, 0.0))
    x1 = X - m2 / M * d * nx
    y1 = Y - m2 / M * d * ny
    x2 = X + m1 / M * d * nx
    y2 = Y + m1 / M * d * ny
    return x1, y1, Vx - P / m1 * nx, Vy - P / m1 * ny, x2, y2, Vx + P / m2 * nx, \
        Vy + P / m2 * ny


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
    Vx = vel[i, 0]
    Vy = vel[i, 1]
    nx, ny = fission_direction(Vx, Vy, rng)
    d = (sp_radius[b] + sp_radius[cc]) * _SEP
    X = pos[i, 0]
    Y = pos[i, 1]
    for _attempt in range(2):
        x1, y1, v1x, v1y, x2, y2, v2x, v2y = fission_outcome(X, Y, Vx, Vy, E, m1, m2, d, nx,
                                                             ny)
        if room(x1, y1, sp_radius[b], 0.0, i, i, collide, bkind, bp, pos, vel, spc, sp_radius,
                grid, cell_start, cell_items, nbin, n, reach) and \
                room(x2, y2, sp_radius[cc], 0.0, i, i, collide, bkind, bp, pos, vel, spc,
                     sp_radius, grid, cell_start, cell_items, nbin, n, reach):
            spc[i] = b
            pos[i, 0], pos[i, 1] = x1, y1
            vel[i, 0] = v1x
            vel[i, 1] = v1y
            uint[i] = 0.0
            spc[n] = cc
            pos[n, 0], pos[n, 1] = x2, y2
            vel[n, 0] = v2x
            vel[n, 1] = v2y
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
