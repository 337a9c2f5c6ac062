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
from typing import NamedTuple

import numpy as np

from .celllist import overlaps_any
from .jit import kernel
from .walls import inside

TRANSFORMATION, DECOMPOSITION, COMBINATION, EXCHANGE, REVERSE = 0, 1, 2, 3, 4
FIRED, NO_ENERGY, NO_ROOM = 1, 0, -1  # outcomes of a reactive collision
SEP = 1.0 + 1e-9  # products are placed this fraction farther apart than touching


class Contact(NamedTuple):
    """Discs i and j at the instant they touch (floats): centres (xi, yi), (xj, yj), unit
    normal (nx, ny) from i to j, velocities (vxi, vyi), (vxj, vyj)."""

    xi: float
    yi: float
    xj: float
    yj: float
    nx: float
    ny: float
    vxi: float
    vyi: float
    vxj: float
    vyj: float


class Kind(NamedTuple):
    """A species' constants as a reaction uses them (floats)."""

    mass: float
    radius: float
    formation: float


class Product(NamedTuple):
    """A disc a reaction makes (floats): position, velocity and internal energy u."""

    x: float
    y: float
    vx: float
    vy: float
    u: float



@kernel
def kind(s, tables):
    """Species s's :class:`Kind` from the compiled tables."""
    return Kind(tables.sp_mass[s], tables.sp_radius[s], tables.sp_form[s])


# ---------------------------------------------------------------------- the state writes
# What a reaction does to the state, for both integrators (the event-driven one passes views
# of its per-disc rows as pos and vel).
@kernel
def write_product(i, s, q, pos, vel, species, internal_energy):
    """Disc i becomes the product q of species s."""
    species[i] = s
    pos[i, 0] = q.x
    pos[i, 1] = q.y
    vel[i, 0] = q.vx
    vel[i, 1] = q.vy
    internal_energy[i] = q.u


@kernel
def apply_combination(i, j, s, q, pos, vel, species, internal_energy):
    """A + B -> C: i becomes the product q of species s; j is removed (species -1, at rest,
    no internal energy)."""
    write_product(i, s, q, pos, vel, species, internal_energy)
    species[j] = -1
    vel[j, 0] = 0.0
    vel[j, 1] = 0.0
    internal_energy[j] = 0.0


@kernel
def apply_exchange(i, j, si, sj, qi, qj, pos, vel, species, internal_energy):
    """A + B -> C + D: i becomes qi (species si), j becomes qj (species sj)."""
    write_product(i, si, qi, pos, vel, species, internal_energy)
    write_product(j, sj, qj, pos, vel, species, internal_energy)


@kernel
def apply_fission(i, k, sb, sc, qb, qc, pos, vel, species, internal_energy):
    """A -> B + C: i becomes the fragment qb (species sb), disc k the fragment qc (sc)."""
    # (int64 indices: the signature of the other callers, so that numba compiles one version)
    write_product(np.int64(i), sb, qb, pos, vel, species, internal_energy)
    write_product(k, sc, qc, pos, vel, species, internal_energy)


@kernel
def apply_transformation(i, s, sp_form, species, internal_energy):
    """A -> B: disc i becomes species s (velocity unchanged, see :func:`transform_energy`)."""
    internal_energy[i] = transform_energy(internal_energy[i], sp_form[species[i]], sp_form[s])
    species[i] = s


@kernel
def room(x, y, r, t, ex1, ex2, discs, sp_radius, bounds, search):
    """Is there room for a disc of radius r at (x, y) at time t (<= 0: the contact time of a
    reactive collision, 0 for a first-order reaction at the end of the substep), inside the
    bounds and clear of every other disc of ``discs`` (except ex1, ex2) where it is at that
    time? (``search``: a :class:`~.structs.Search`; without collisions only the bounds
    count.)"""
    if not inside(x, y, r, bounds.kind, bounds.params):
        return False
    if not search.collide:
        return True
    return not overlaps_any(x, y, r, t, ex1, ex2, discs, sp_radius, search)


@kernel
def combine_outcome(k, A, B, P, ui, uj, t):
    """The product of A + B -> P (pure).

    Reactants of kinds A (disc i) and B (disc j) touching as :class:`Contact` k, internal
    energies ui, uj. P sits at the centre of mass, wound forward by -t (t <= 0: the contact
    was -t ago; 0 for the event-driven integrator), with the centre-of-mass velocity, and
    stores U = ui + uj + 1/2 mu |v_i - v_j|^2 + f_A + f_B - f_P. Returns ``(ok, product)``,
    ok False when U < 0 (an endothermic combination the energy cannot pay for).
    """
    mi = A.mass
    mj = B.mass
    vxi, vyi, vxj, vyj = k.vxi, k.vyi, k.vxj, k.vyj
    M = mi + mj
    mu = mi * mj / M
    dvx = vxi - vxj
    dvy = vyi - vyj
    U = ui + uj + 0.5 * mu * (dvx * dvx + dvy * dvy) + A.formation + B.formation - P.formation
    if U < 0.0:
        return False, Product(0.0, 0.0, 0.0, 0.0, 0.0)
    Vx = (mi * vxi + mj * vxj) / M
    Vy = (mi * vyi + mj * vyj) / M
    X = (mi * k.xi + mj * k.xj) / M - t * Vx
    Y = (mi * k.yi + mj * k.yj) / M - t * Vy
    return True, Product(X, Y, Vx, Vy, U)


@kernel
def combine(i, j, c, t, k, tables, discs, bounds, search):
    """A + B -> C at contact time t (``k``: the :class:`Contact`); i becomes C, j dies
    (species = -1). Returns FIRED, or NO_ENERGY (an endothermic product the energy cannot pay
    for) or NO_ROOM."""
    species, internal_energy = discs.species, discs.internal_energy
    sp_radius = tables.sp_radius
    p = tables.ch_prod[c, 0]
    ok, q = combine_outcome(k, kind(species[i], tables), kind(species[j], tables), kind(p, tables),
                            internal_energy[i], internal_energy[j], t)
    if not ok:
        return NO_ENERGY
    # room where C appears: at the contact, not where it would be at the end of the substep
    if not room(q.x + t * q.vx, q.y + t * q.vy, sp_radius[p], t, i, j, discs, sp_radius, bounds,
                search):
        return NO_ROOM
    apply_combination(i, j, p, q, discs.pos, discs.vel, species, internal_energy)
    return FIRED


@kernel
def exchange_species(c, a, ch_reac, ch_prod):
    """The products (for i, for j) of exchange channel c when disc i is of species a."""
    if a == ch_reac[c, 0]:
        return ch_prod[c, 0], ch_prod[c, 1]
    return ch_prod[c, 1], ch_prod[c, 0]


@kernel
def exchange_outcome(k, A, B, C, D, ui, uj, t):
    """The products of A + B -> C + D (pure).

    Reactants of kinds A (disc i, -> C) and B (disc j, -> D) touching as :class:`Contact` k
    (normal n from i to j), internal energies ui, uj. The products leave the centre of mass
    along the direction an elastic bounce gives the relative velocity, with the relative
    speed the available energy E = 1/2 mu |w|^2 + ui + uj + f_A + f_B - f_C - f_D sets;
    they are placed (r_C + r_D)(1 + 1e-9) apart along n about the centre of mass, wound
    forward by -t (t <= 0), with no internal energy. Returns ``(ok, product C, product D)``,
    ok False when E < 0.
    """
    mi, mj, mC, mD, rC, rD = A.mass, B.mass, C.mass, D.mass, C.radius, D.radius
    vxi, vyi, vxj, vyj, nx, ny = k.vxi, k.vyi, k.vxj, k.vyj, k.nx, k.ny
    M = mi + mj
    mu = mi * mj / M
    wx = vxi - vxj
    wy = vyi - vyj
    w2 = wx * wx + wy * wy
    E = 0.5 * mu * w2 + ui + uj + A.formation + B.formation - C.formation - D.formation
    if E < 0.0:
        return False, Product(0.0, 0.0, 0.0, 0.0, 0.0), Product(0.0, 0.0, 0.0, 0.0, 0.0)
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
    d = (rC + rD) * SEP
    cx = (mi * k.xi + mj * k.xj) / M
    cy = (mi * k.yi + mj * k.yj) / M
    XC = cx - mD / Mp * d * nx - t * vCx
    YC = cy - mD / Mp * d * ny - t * vCy
    XD = cx + mC / Mp * d * nx - t * vDx
    YD = cy + mC / Mp * d * ny - t * vDy
    return True, Product(XC, YC, vCx, vCy, 0.0), Product(XD, YD, vDx, vDy, 0.0)


@kernel
def exchange(i, j, c, t, k, tables, discs, bounds, search):
    """A + B -> C + D at contact time t (``k``: the :class:`Contact`, n from i to j); i and j
    become the products. Returns FIRED, NO_ENERGY or NO_ROOM (as :func:`combine`)."""
    species, internal_energy = discs.species, discs.internal_energy
    sp_radius = tables.sp_radius
    pi, pj = exchange_species(c, species[i], tables.ch_reac, tables.ch_prod)
    ok, qi, qj = exchange_outcome(k, kind(species[i], tables), kind(species[j], tables),
                                  kind(pi, tables), kind(pj, tables), internal_energy[i],
                                  internal_energy[j], t)
    if not ok:
        return NO_ENERGY
    # room where the products appear, at the contact
    if not room(qi.x + t * qi.vx, qi.y + t * qi.vy, sp_radius[pi], t, i, j, discs, sp_radius,
                bounds, search):
        return NO_ROOM
    if not room(qj.x + t * qj.vx, qj.y + t * qj.vy, sp_radius[pj], t, i, j, discs, sp_radius,
                bounds, search):
        return NO_ROOM
    apply_exchange(i, j, pi, pj, qi, qj, discs.pos, discs.vel, species, internal_energy)
    return FIRED


@kernel
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


@kernel
def released_energy(i, c, tables, species, internal_energy):
    """Energy a first-order channel c would release from disc i, or -1 if it cannot fire."""
    sp_form = tables.sp_form
    ch_prod = tables.ch_prod
    return channel_energy(tables.ch_kind[c], internal_energy[i], sp_form[species[i]],
                          sp_form[ch_prod[c, 0]], sp_form[ch_prod[c, 1]], tables.ch_energy[c])


@kernel
def first_order_draws(n, h, tables, species, internal_energy, rng, out_disc, out_chan):
    """Draw which discs [0, n) undergo a first-order reaction in a step of length h.

    Each disc's competing channels with rates k_c (only those whose energy condition holds
    now): one fires with probability 1 - exp(-K h), K = sum k_c, channel c with probability
    k_c / K. The reacting discs and their channels are written to ``out_disc``,
    ``out_chan`` (n,); returns how many. One pass taking the arrays once: per-disc helpers
    taking arrays cost a reference count per array per call, many times the cost of the
    rate computation written out, as here.
    """
    sp_form, ch_kind, ch_prod, ch_rate = tables.sp_form, tables.ch_kind, tables.ch_prod, \
        tables.ch_rate
    ch_energy, uni_start, uni_chan = tables.ch_energy, tables.uni_start, tables.uni_chan
    m = 0
    for i in range(n):
        s = species[i]
        if s < 0:
            continue
        q0 = uni_start[s]
        q1 = uni_start[s + 1]
        if q0 == q1:  # no channel for this species
            continue
        u = internal_energy[i]
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


@kernel
def first_order_rate(i, tables, species, internal_energy):
    """Total rate K of the first-order channels of disc i whose energy condition holds now
    (per event, for the event-driven integrator; :func:`first_order_draws` is the per-step
    pass). K changes only when the disc's species or internal energy does."""
    ch_rate = tables.ch_rate
    uni_start, uni_chan = tables.uni_start, tables.uni_chan
    s = species[i]
    K = 0.0
    for q in range(uni_start[s], uni_start[s + 1]):
        c = uni_chan[q]
        if released_energy(i, c, tables, species, internal_energy) >= 0.0:
            K += ch_rate[c]
    return K


@kernel
def first_order_pick(i, K, tables, species, internal_energy, rng):
    """Which eligible first-order channel of disc i fires (channel c with chance k_c / K; K
    from :func:`first_order_rate`, > 0). Draws one random number."""
    ch_rate = tables.ch_rate
    uni_start, uni_chan = tables.uni_start, tables.uni_chan
    s = species[i]
    x = rng.random() * K
    last = -1
    for q in range(uni_start[s], uni_start[s + 1]):
        c = uni_chan[q]
        if released_energy(i, c, tables, species, internal_energy) >= 0.0:
            last = c
            x -= ch_rate[c]
            if x < 0.0:
                return c
    return last


@kernel
def transform_energy(u, fa, fp):
    """Internal energy after A -> B of a disc with internal energy u (formation energies fa,
    fp): the formation-energy difference goes into it (never below 0: round-off only, since
    the channel fires only when this is >= 0)."""
    u += fa - fp
    if u < 0.0:
        u = 0.0
    return u


@kernel
def transform(i, c, tables, discs, bounds, search):
    """A -> B on disc i by channel c if B fits where A is (B no larger than A always does).
    Returns True if fired."""
    pos, species = discs.pos, discs.species
    sp_radius = tables.sp_radius
    p = tables.ch_prod[c, 0]
    if sp_radius[p] > sp_radius[species[i]] and not room(
            pos[i, 0], pos[i, 1], sp_radius[p], 0.0, np.int64(i), np.int64(i), discs, sp_radius,
            bounds, search):
        return False
    apply_transformation(i, p, tables.sp_form, species, discs.internal_energy)
    return True


@kernel
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


@kernel
def fission_outcome(X, Y, Vx, Vy, E, m1, m2, d, nx, ny):
    """The fragments of A -> B + C (pure): parent at (X, Y) with velocity V, energy released
    E, fragment masses m1 (B), m2 (C), centre distance d, separation direction n (from B to
    C). They sit about the parent's centre of mass and carry equal and opposite momenta
    |P| = sqrt(2 mu E) in its frame, with no internal energy. Returns the products
    ``(B, C)``."""
    M = m1 + m2
    P = math.sqrt(2.0 * (m1 * m2 / M) * max(E, 0.0))
    x1 = X - m2 / M * d * nx
    y1 = Y - m2 / M * d * ny
    x2 = X + m1 / M * d * nx
    y2 = Y + m1 / M * d * ny
    return Product(x1, y1, Vx - P / m1 * nx, Vy - P / m1 * ny, 0.0), \
        Product(x2, y2, Vx + P / m2 * nx, Vy + P / m2 * ny, 0.0)


@kernel
def fission(i, c, n, tables, discs, bounds, search, rng):
    """A -> B + C (decomposition or reverse combination): i becomes B, disc n becomes C.

    The caller guarantees capacity for disc n. Returns True if fired.
    """
    pos, vel, species, internal_energy = discs.pos, discs.vel, discs.species, discs.internal_energy
    sp_radius, sp_mass = tables.sp_radius, tables.sp_mass
    b = tables.ch_prod[c, 0]
    cc = tables.ch_prod[c, 1]
    E = released_energy(i, c, tables, species, internal_energy)
    m1 = sp_mass[b]
    m2 = sp_mass[cc]
    Vx = vel[i, 0]
    Vy = vel[i, 1]
    nx, ny = fission_direction(Vx, Vy, rng)
    d = (sp_radius[b] + sp_radius[cc]) * SEP
    X = pos[i, 0]
    Y = pos[i, 1]
    ii = np.int64(i)  # (the signature of room's other callers: one version compiled)
    for _attempt in range(2):
        qb, qc = fission_outcome(X, Y, Vx, Vy, E, m1, m2, d, nx, ny)
        if room(qb.x, qb.y, sp_radius[b], 0.0, ii, ii, discs, sp_radius, bounds, search) and \
                room(qc.x, qc.y, sp_radius[cc], 0.0, ii, ii, discs, sp_radius, bounds, search):
            apply_fission(i, n, b, cc, qb, qc, pos, vel, species, internal_energy)
            return True
        nx = -nx
        ny = -ny
    return False


@kernel
def grow1(a, n_new):
    out = np.zeros(n_new, dtype=a.dtype)
    for i in range(a.shape[0]):  # (a loop: numba's slice assignment compiles an error)
        out[i] = a[i]
    return out


@kernel
def grow2(a, n_new):
    out = np.zeros((n_new, a.shape[1]), dtype=a.dtype)
    for i in range(a.shape[0]):  # (loops: numba's slice assignment compiles an error)
        for k in range(a.shape[1]):
            out[i, k] = a[i, k]
    return out
