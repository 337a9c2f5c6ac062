"""The exact integrator's event handlers: what each kind of event does to the discs it
involves, at the time of the event (the event loop of :mod:`.event_driven` calls them and
predicts the discs they name afresh).

- :func:`collision`: two discs in contact: a reactive collision (:mod:`.reactions`' outcomes,
  if the products fit) or a bounce (restitution, the TC model of :mod:`.rules`, relaxation).
- :func:`crossing`: a disc enters the next cell of the grid.
- :func:`wall_event`: a disc meets the bounds: it leaves through an outlet, or reflects
  (specular, or redrawn by a thermal side).
- :func:`first_order_event`: a disc's first-order reaction (transformation or fission, if
  the products fit).
"""

import math

from numba import njit

from .collisions import bounce, normal_at
from .event_predict import (
    APPROACH2,
    cell_insert,
    cell_move,
    cell_of,
    cell_remove,
    fly_to,
    has_room,
    next_reaction,
    set_kind,
)
from .event_structs import (
    EV_NONE,
    NEXT_AUX,
    NEXT_CODE,
    NEXT_T,
    PM,
    PT,
    PVX,
    PVY,
    PX,
    PY,
    ST_CROSSINGS,
    ST_GRAZES,
)
from .heap import heap_set
from .jit import kernel
from .reactions import (
    COMBINATION,
    SEP,
    TRANSFORMATION,
    Contact,
    apply_combination,
    apply_exchange,
    apply_fission,
    apply_transformation,
    combine_outcome,
    exchange_outcome,
    exchange_species,
    first_order_pick,
    fission_direction,
    fission_outcome,
    kind,
    released_energy,
)
from .rules import book_outflow, book_thermal, tc_restitution
from .structs import (
    FS_DISSIPATED,
    FS_WALL_MOMENTUM,
    IC_COLLISIONS,
    IC_EVENTS_CAPPED,
    IC_NO_ROOM,
    IC_REACTIVE,
    IC_WALL_HITS,
)
from .walls import graze_floor, on_outlet, reflected, side_of, thermal_velocity

INF = math.inf


@njit(cache=True, inline="always")
def remove_disc(j, fl, cells, queue):
    """Disc j is gone (combined away, or out through an outlet): out of its cell, the heap
    and the reactions."""
    cell_remove(j, cells)
    heap_set(queue.heap, j, INF)
    queue.event[j, NEXT_T] = INF
    queue.event[j, NEXT_CODE] = EV_NONE
    fl.t_reaction[j] = INF
    fl.rate[j] = 0.0


# ------------------------------------------------------------------------------ collisions
@njit(cache=True, inline="always")
def _combine(i, j, c, t, k, fl, cells, queue, run, tables):
    """A + B -> C at the contact k of i and j at time t, if C fits: i becomes C, j goes.
    Returns (fired, refused: the energy could pay but there was no room)."""
    W = fl.path
    p = tables.ch_prod[c, 0]
    ok, q = combine_outcome(k, kind(fl.species[i], tables), kind(fl.species[j], tables),
                            kind(p, tables), fl.internal_energy[i], fl.internal_energy[j],
                            0.0)
    fits = ok and has_room(q.x, q.y, tables.sp_radius[p], i, j, t, fl, cells, run)
    if fits:
        apply_combination(i, j, p, q, W[:, PX:PY + 1], W[:, PVX:PVY + 1], fl.species,
                          fl.internal_energy)
        set_kind(i, p, W, tables)
        remove_disc(j, fl, cells, queue)
        cell_move(i, q.x, q.y, cells)
    return fits, ok and not fits


@njit(cache=True, inline="always")
def _exchange(i, j, c, t, k, fl, cells, run, tables):
    """A + B -> C + D at the contact k of i and j at time t, if C and D fit. Returns (fired,
    refused) as :func:`_combine`."""
    W = fl.path
    sp_radius = tables.sp_radius
    pi, pj = exchange_species(c, fl.species[i], tables.ch_reac, tables.ch_prod)
    ok, qi, qj = exchange_outcome(k, kind(fl.species[i], tables), kind(fl.species[j], tables),
                                  kind(pi, tables), kind(pj, tables), fl.internal_energy[i],
                                  fl.internal_energy[j], 0.0)
    fits = ok and has_room(qi.x, qi.y, sp_radius[pi], i, j, t, fl, cells, run) and \
        has_room(qj.x, qj.y, sp_radius[pj], i, j, t, fl, cells, run)
    if fits:
        apply_exchange(i, j, pi, pj, qi, qj, W[:, PX:PY + 1], W[:, PVX:PVY + 1], fl.species,
                       fl.internal_energy)
        set_kind(i, pi, W, tables)
        set_kind(j, pj, W, tables)
        cell_move(i, qi.x, qi.y, cells)
        cell_move(j, qj.x, qj.y, cells)
    return fits, ok and not fits


@njit(cache=True, inline="always")
def _react(i, j, t, k, vr, fl, cells, queue, run, tables, counters):
    """A reactive collision of i and j (contact k, normal approach speed vr > 0) if their
    channel's trigger holds and its products fit. Returns (fired, j combined away)."""
    W = fl.path
    c = tables.bi_table[fl.species[i], fl.species[j]]
    mi = W[i, PM]
    mj = W[j, PM]
    if c < 0 or not 0.5 * mi * mj / (mi + mj) * vr * vr >= tables.ch_energy[c]:
        return False, False
    combination = tables.ch_kind[c] == COMBINATION
    if combination:
        fired, refused = _combine(i, j, c, t, k, fl, cells, queue, run, tables)
    else:
        fired, refused = _exchange(i, j, c, t, k, fl, cells, run, tables)
    if fired:
        counters.ch_count[c] += 1
        counters.icnt[IC_REACTIVE] += 1
    elif refused:  # (not when the energy could not pay for it)
        counters.icnt[IC_NO_ROOM] += 1
    return fired, fired and combination


@njit(cache=True, inline="always")
def _bounce(i, j, t, k, fl, run, tables, rng, counters):
    """An ordinary collision of i and j at the contact k (restitution, the TC model,
    relaxation of internal energy)."""
    W = fl.path
    u = fl.internal_energy
    e = tc_restitution(run.e_rest, t - fl.t_collision[i] < run.tc or
                       t - fl.t_collision[j] < run.tc, counters.icnt)
    ui0 = u[i]
    uj0 = u[j]
    vxi, vyi, vxj, vyj, ui, uj, lost = bounce(k.vxi, k.vyi, k.vxj, k.vyj, W[i, PM], W[j, PM],
                                              k.nx, k.ny, e, run.kappa, ui0, uj0)
    counters.fsum[FS_DISSIPATED] += lost
    W[i, PVX] = vxi
    W[i, PVY] = vyi
    W[j, PVX] = vxj
    W[j, PVY] = vyj
    counters.icnt[IC_COLLISIONS] += 1
    if ui != ui0 or uj != uj0:
        u[i] = ui
        u[j] = uj
        if run.has_uni:
            next_reaction(i, t, fl, tables, rng, False, 0.0)
            next_reaction(j, t, fl, tables, rng, False, 0.0)


@kernel(_nrt=False, inline_code=True)  # (see _event_loop)
def collision(i, j, t, fl, cells, queue, run, tables, rng, counters):
    """Disc i (at t) meets disc j: a reaction or a bounce, unless round-off made the contact
    tangential. Returns the partner to predict afresh (-1: it combined away)."""
    W = fl.path
    fly_to(j, t, W)
    # approaching, by the very arithmetic of the prediction? (else a graze that round-off
    # made tangential: no impulse, and no new prediction of this pair)
    rx = W[j, PX] - W[i, PX]
    ry = W[j, PY] - W[i, PY]
    wx = W[j, PVX] - W[i, PVX]
    wy = W[j, PVY] - W[i, PVY]
    b = rx * wx + ry * wy
    if not (b < 0.0 and b * b > APPROACH2 * (rx * rx + ry * ry) * (wx * wx + wy * wy)):
        counters.stats[ST_GRAZES] += 1
        return j
    vxi = W[i, PVX]
    vyi = W[i, PVY]
    vxj = W[j, PVX]
    vyj = W[j, PVY]
    xi, yi, xj, yj, nx, ny = normal_at(W[i, PX], W[i, PY], vxi, vyi, W[j, PX], W[j, PY], vxj,
                                       vyj, 0.0)
    k = Contact(xi, yi, xj, yj, nx, ny, vxi, vyi, vxj, vyj)
    vr = (vxi - vxj) * nx + (vyi - vyj) * ny
    fired = False
    killed = False
    if run.has_bi and vr > 0.0:
        fired, killed = _react(i, j, t, k, vr, fl, cells, queue, run, tables, counters)
    if not fired:
        _bounce(i, j, t, k, fl, run, tables, rng, counters)
    elif run.has_uni:
        next_reaction(i, t, fl, tables, rng, False, 0.0)
        if not killed:
            next_reaction(j, t, fl, tables, rng, False, 0.0)
    fl.t_collision[i] = t
    fl.t_collision[j] = t
    fl.stamp[i] += 1
    fl.stamp[j] += 1
    return -1 if killed else j


# ---------------------------------------------------------------------- crossings and walls
@njit(cache=True, inline="always")
def crossing(d, cells, queue, stats):
    """Disc d enters the cell of its event. Returns the direction it came (``entered``)."""
    stats[ST_CROSSINGS] += 1
    c_old = cells.cell[d]
    c_new = int(queue.event[d, NEXT_AUX])
    cell_remove(d, cells)
    cell_insert(d, c_new, cells)
    if c_new // cells.ncx == c_old // cells.ncx:  # same row: crossed in x
        return 1 if c_new > c_old else 2
    return 3 if c_new > c_old else 4


@njit(cache=True, inline="always")
def _leaves(d, fl, queue, run, tables, counters):
    """Does disc d, at the wall contact of its event, meet an outlet? If so it leaves: its
    energy (kinetic + internal + formation) booked in FS_OUTFLOW, counted in
    ``counters.outflow``, species -1 (the run's end compacts it away, as a disc consumed by a
    combination)."""
    W = fl.path
    side, frac = side_of(W[d, PX], W[d, PY], int(queue.event[d, NEXT_AUX]), W[d, PVX],
                         W[d, PVY], run.bounds_kind, run.bounds_params)
    if not on_outlet(side, frac, int(fl.species[d]), tables.outlets):
        return False
    book_outflow(fl.species[d], W[d, PM], W[d, PVX], W[d, PVY], fl.internal_energy[d],
                 tables.sp_form, counters.fsum, counters.outflow)
    fl.species[d] = -1
    return True


@njit(cache=True, inline="always")
def _thermal_hit(d, side, kT, fl, run, fsum, rng):
    """Disc d leaves thermal side ``side`` (temperature kT) with a velocity drawn from the
    wall (:func:`~discgym.kernels.walls.thermal_velocity`, the energy exchanged booked in
    FS_WALL_HEAT + side)."""
    W = fl.path
    b0, b1 = run.b0, run.b1
    vx0 = W[d, PVX]
    vy0 = W[d, PVY]
    m = W[d, PM]
    vx, vy, vn_in, vn_out = thermal_velocity(W[d, PX], W[d, PY], vx0, vy0, side, kT, m,
                                             run.bounds_kind, run.bounds_params, rng)
    if run.bounds_kind == 1:  # (as after a reflection: see walls.graze_floor)
        vx, vy = graze_floor(W[d, PX], W[d, PY], vx, vy, b0, b1)
        nx = b0 - W[d, PX]
        ny = b1 - W[d, PY]
        nr = math.sqrt(nx * nx + ny * ny)
        if nr > 0.0:
            vn_out = (vx * nx + vy * ny) / nr
    W[d, PVX] = vx
    W[d, PVY] = vy
    book_thermal(side, m, vx0, vy0, vx, vy, vn_in, vn_out, fsum)


@njit(cache=True, inline="always")
def _specular_hit(d, axis, fl, run, fsum):
    """Disc d reflects off the wall along ``axis``, the momentum the wall takes booked in
    FS_WALL_MOMENTUM."""
    W = fl.path
    b0, b1 = run.b0, run.b1
    vx0 = W[d, PVX]
    vy0 = W[d, PVY]
    vx, vy, vn = reflected(W[d, PX], W[d, PY], vx0, vy0, axis, run.bounds_kind, b0, b1)
    if run.bounds_kind == 1:  # never tangent to the curved wall (see walls.graze_floor)
        vx, vy = graze_floor(W[d, PX], W[d, PY], vx, vy, b0, b1)
        nx = W[d, PX] - b0
        ny = W[d, PY] - b1
        nr = math.sqrt(nx * nx + ny * ny)
        if nr > 0.0:  # the normal momentum the wall takes
            vn = 0.5 * ((vx0 - vx) * nx + (vy0 - vy) * ny) / nr
    W[d, PVX] = vx
    W[d, PVY] = vy
    fsum[FS_WALL_MOMENTUM] += 2.0 * W[d, PM] * vn


@kernel(_nrt=False, inline_code=True)  # (see _event_loop)
def wall_event(d, fl, cells, queue, run, tables, counters, rng):
    """Disc d at the wall contact of its event: out through an outlet (``run.outlets``,
    ``tables.outlets``) or reflected, off a thermal side (``run.thermal``, ``run.walls``: kT
    per side, NaN specular) with a velocity drawn from the wall. Returns whether d is still
    there (else it is out of the cells and the queue)."""
    W = fl.path
    if run.outlets and _leaves(d, fl, queue, run, tables, counters):
        remove_disc(d, fl, cells, queue)
        fl.stamp[d] += 1
        return False
    axis = int(queue.event[d, NEXT_AUX])
    side = 0
    kT = math.nan
    if run.thermal:
        side, _f = side_of(W[d, PX], W[d, PY], axis, W[d, PVX], W[d, PVY], run.bounds_kind,
                           run.bounds_params)
        kT = run.walls[side]
    if kT == kT:  # (NaN: a specular side)
        _thermal_hit(d, side, kT, fl, run, counters.fsum, rng)
    else:
        _specular_hit(d, axis, fl, run, counters.fsum)
    counters.icnt[IC_WALL_HITS] += 1
    fl.stamp[d] += 1
    return True


# ---------------------------------------------------------------- first-order reactions
@kernel
def _fission(d, c, n, t, fl, cells, state, run, tables, rng):
    """A -> B + C of disc d by channel c if the fragments fit (two tries, the second with
    the separation direction reversed): d becomes B, disc n (there is room for it) C.
    Returns True if it fired."""
    W = fl.path
    sp_radius, sp_mass = tables.sp_radius, tables.sp_mass
    pb = tables.ch_prod[c, 0]
    pc = tables.ch_prod[c, 1]
    E = released_energy(d, c, tables, fl.species, fl.internal_energy)
    m1 = sp_mass[pb]
    m2 = sp_mass[pc]
    r1 = sp_radius[pb]
    r2 = sp_radius[pc]
    X = W[d, PX]
    Y = W[d, PY]
    Vx = W[d, PVX]
    Vy = W[d, PVY]
    nx, ny = fission_direction(Vx, Vy, rng)
    sep = (r1 + r2) * SEP
    for _attempt in range(2):
        qb, qc = fission_outcome(X, Y, Vx, Vy, E, m1, m2, sep, nx, ny)
        if has_room(qb.x, qb.y, r1, d, d, t, fl, cells, run) and \
                has_room(qc.x, qc.y, r2, d, d, t, fl, cells, run):
            state.ids[n] = state.next_id[0]
            state.next_id[0] += 1
            apply_fission(d, n, pb, pc, qb, qc, W[:, PX:PY + 1], W[:, PVX:PVY + 1], fl.species,
                          fl.internal_energy)
            set_kind(d, pb, W, tables)
            cell_move(d, qb.x, qb.y, cells)
            W[n, PT] = t
            set_kind(n, pc, W, tables)
            fl.stamp[n] += 1
            fl.t_collision[n] = -INF
            fl.rate[n] = 0.0
            fl.t_reaction[n] = INF
            cell_insert(n, cell_of(qc.x, qc.y, cells), cells)
            return True
        nx = -nx
        ny = -ny
    return False


@kernel
def first_order_event(d, n, t, fl, cells, state, run, tables, rng, counters):
    """Disc d (at time t) undergoes one of its first-order channels, if its products fit
    (else it waits an exponential time, but at least ``run.hsub``: a certain reaction, rate
    ~1e300, would otherwise retry at the same instant forever). After ``run.fo_exact``
    first-order events of one disc in a call (FO_EXACT per step), its next ones are also at
    least ``hsub`` apart (a cycle of certain reactions, A -> B -> A, would not advance the
    clock either), each such delay counted in ``events_capped``. A fission's second fragment
    becomes disc n (the caller made sure there is room for it). Returns n if it was created,
    else -1."""
    W = fl.path
    sp_radius = tables.sp_radius
    s = fl.species[d]
    K = fl.rate[d]
    c = first_order_pick(d, K, tables, fl.species, fl.internal_energy, rng)
    newd = -1
    if tables.ch_kind[c] == TRANSFORMATION:
        p = tables.ch_prod[c, 0]
        fired = sp_radius[p] <= sp_radius[s] or has_room(W[d, PX], W[d, PY], sp_radius[p], d,
                                                         d, t, fl, cells, run)
        if fired:
            apply_transformation(d, p, tables.sp_form, fl.species, fl.internal_energy)
            set_kind(d, p, W, tables)
    else:
        fired = _fission(d, c, n, t, fl, cells, state, run, tables, rng)
        if fired:
            newd = n
    fl.n_first_order[d] += 1
    if fired:
        counters.ch_count[c] += 1
        fl.stamp[d] += 1
        floor = 0.0
        if fl.n_first_order[d] >= run.fo_exact:
            floor = run.hsub
            counters.icnt[IC_EVENTS_CAPPED] += 1
        next_reaction(d, t, fl, tables, rng, True, floor)
        if newd >= 0:  # (lighter than d: chains of fissions end)
            next_reaction(newd, t, fl, tables, rng, True, 0.0)
    else:
        counters.icnt[IC_NO_ROOM] += 1
        fl.t_reaction[d] = t + max(-math.log1p(-rng.random()) / K, run.hsub)  # try again
    return newd


@kernel
def may_split(s, tables):
    """Has species s a first-order channel that makes two discs?"""
    for q in range(tables.uni_start[s], tables.uni_start[s + 1]):
        if tables.ch_kind[tables.uni_chan[q]] != TRANSFORMATION:
            return True
    return False
