"""The exact, event-driven integrator: the accuracy ceiling of the time-stepped one.

Discs fly in straight lines between exactly predicted events, processed in time order:

- disc-disc contacts (the earlier root of |r + t v| = R_i + R_j, cancellation-free);
- disc-wall contacts (box: per axis; circle: the root of |d + t v| = R_m - R_c ahead);
- cell crossings: discs are kept in a grid of cells at least one largest diameter wide, so a
  disc only ever predicts contacts with the discs of its own and the 8 adjacent cells, and a
  crossing into a new cell is itself an event, after which only the 3 cells that have just
  become adjacent are scanned (prediction stays local: O(1) work per event);
- first-order reactions at exactly sampled exponential times: each disc carries the total
  rate K of its first-order channels whose energy condition holds now
  (:func:`~discgym.kernels.reactions.first_order_rate`, the same rule as the time-stepped
  integrator) and its next reaction time t + Exp(1)/K. K only changes when the disc's species
  or internal energy does (at collisions and reactions); it is recomputed then and the time
  resampled if K changed (exact, the exponential being memoryless).

The queue is an indexed binary min-heap holding ONE event per disc, its earliest (Isobe's
scheme): O(log N) per event, no heap growth. Each disc also has an event counter ``stamp``,
bumped whenever its trajectory changes; an event naming a partner whose counter has moved on
is stale and only makes its disc predict again. Positions are stored at each disc's own last
event time (``W[:, 4]``) and only brought to the common time at the end of a step.

Calls: a call of n steps is one exact run of n dt. It starts from the state alone (times
from 0, every disc's first event predicted afresh, O(N log N); reaction times drawn afresh,
exact since the exponential is memoryless; discs numbered in cell order for memory
locality) and ends with every disc brought to its end. So a copy or a restored state
continues bit for bit as the original does under the same calls, and the arrays' capacity
plays no part (a fission that finds them full grows them in place). A call boundary is a
synchronisation point: ``step(30); step(40)`` is two runs, the same physics as ``step(70)``
but not the same round-off and random stream. Predicting every disc afresh at every step
boundary would make them equal at ~150 ns per disc-step, several times the cost of the run
itself at dt = 0.05 (docs/hard_cases.md, finding 19).

Bounds on the work of a call (no input may make a call run without end), per step of dt in
the call: a refused first-order reaction retries no sooner than one substep of the
time-stepped integrator later (``dt / k``, k its substep count for a step from the speeds at
the call's start: the pace at which it retries), a disc's first-order events past FO_EXACT
per step are delayed to the same pace (a cycle of certain reactions, A -> B -> A, has no end
at one instant), and a call stops at the time-stepped integrator's event bound for its
steps, ``n k (64 N + 1024)`` events, after which the time-stepped integrator finishes it
(``events_capped``). Bounds that leave a species less than
FIT_MARGIN radii of room are refused by :class:`~discgym.Simulation`.

Round-off: a pair counts as approaching only if its normal approach speed exceeds 1e-10 of
its relative speed (``APPROACH2``); closer to tangential, the impulse would vanish in
round-off and the same contact would be predicted again at once. Nothing physical is lost.

The physics is shared with the time-stepped integrator, not copied: impulses come from
:func:`~discgym.kernels.collisions.bounce`, wall reflections from
:func:`~discgym.kernels.walls.reflected`, reaction outcomes from the pure functions of
:mod:`~discgym.kernels.reactions` (``combine_outcome``, ``exchange_outcome``,
``fission_outcome``, ...). Reactive collisions fire at the contact when the energy along the
line of centres, 1/2 mu v_r^2, is at least E_a (the same trigger). Products are placed only
where they fit inside the bounds without overlapping any disc (no room: the collision
bounces, a first-order reaction waits an exponential time, but at least a substep, and tries
again); both count as ``reactions_without_room``.

Inelastic collapse (restitution e < 1) would make infinitely many collisions in finite time:
a collision of a disc that collided less than t_c ago is elastic (the TC model of Luding and
McNamara; the time-stepped integrator uses t_c = its substep), with t_c = ``TC_FRACTION``
times the time the smallest disc takes to move its radius at the root-mean-square speed
(taken at the start of each step). The energy booked as dissipated is exactly what was lost;
such collisions are counted as ``elastic_repeats``.

Counters (``icnt``, ``fsum``, ``ch_count``) are those of :mod:`discgym.kernels.step`;
``events_capped`` counts the steps stopped at the event bound and the delayed first-order
events; ``substeps`` and the other counters of the time-stepped integrator count only what it
did finishing such steps (0 otherwise).
"""

import math

import numpy as np
from numba import njit

from .._dtypes import COUNT, FLOAT, INDEX
from .celllist import cell_coord
from .collisions import bounce, normal_at
from .reactions import (
    _SEP,
    COMBINATION,
    TRANSFORMATION,
    combine_outcome,
    exchange_outcome,
    exchange_species,
    first_order_pick,
    first_order_rate,
    fission_direction,
    fission_outcome,
    grow1,
    grow2,
    released_energy,
    transform_energy,
)
from .step import (
    EVENTS_PER_DISC,
    FS_DISSIPATED,
    FS_WALL_MOMENTUM,
    IC_COLLISIONS,
    IC_EVENTS_CAPPED,
    IC_NO_ROOM,
    IC_REACTIVE,
    IC_TC_ELASTIC,
    IC_WALL_HITS,
    MAX_SUBSTEPS,
    _compact,
    empty_work,
)
from .step import run_tracked as step_run
from .walls import box_next, circle_next, graze_floor, inside, reflected

INF = math.inf

# Event codes (the partner field of a disc's event): >= 0 is a disc.
EV_WALL = -1
EV_CELL = -2
EV_REACT = -3
EV_NONE = -4

# Columns of the per-disc working array W (C, 8).
W_X, W_Y, W_VX, W_VY, W_T, W_R, W_M = range(7)

# Statistics (``stats``, int64, filled by :func:`run_stats`).
ST_EVENTS = 0  # events popped (valid or stale)
ST_STALE = 1  # events found stale (partner changed since the prediction)
ST_CROSSINGS = 2  # cell crossings
ST_PREDICTIONS = 3  # disc predictions
ST_RESTARTS = 4  # growths of the state arrays in a step (a fission found them full)
ST_GRAZES = 5  # predicted contacts found tangential at the contact (round-off); no impulse
ST_CELLS = 6  # cells in the grid (last restart)
N_STATS = 7

# A pair is approaching when r.w < 0 with (r.w)^2 > APPROACH2 |r|^2 |w|^2 (r = r_j - r_i,
# w = v_j - v_i): a contact closer to tangential than 1e-10 rad, or a touching pair whose
# normal speeds agree to 1e-10 of their relative speed (after an e = 0 collision), is not a
# collision (its impulse would be lost in round-off and the pair predicted again at once).
APPROACH2 = 1e-20
FIT_MARGIN = 1e-3  # the free gap a species needs in its bounds, in radii (Simulation refuses
# less): a disc with gap g meets the walls |v| / g times per unit time
FO_EXACT = 16  # first-order events of one disc per step at exact times (see below)
TC_FRACTION = 1e-3  # t_c of the TC model, in units of r_min / v_rms (e < 1 only)
CELLS_PER_DISC = 4.0  # grid cells per disc, when that makes cells larger than a diameter
MAX_CELLS = 1 << 26
_CELL_MARGIN = 1e-9  # cells are this fraction wider than the largest contact distance


# ------------------------------------------------------------------------------ the heap
@njit(cache=True, inline="always")
def _hset(d, key, hk, hd, hpos):
    """Set disc d's key in the indexed min-heap (``hk`` keys, ``hd`` discs, ``hpos`` the
    slot of each disc; all (C,)) and restore the heap order."""
    p = hpos[d]
    size = hk.shape[0]
    if key < hk[p]:
        while p > 0:
            q = (p - 1) >> 1
            kq = hk[q]
            if kq <= key:
                break
            hk[p] = kq
            e = hd[q]
            hd[p] = e
            hpos[e] = p
            p = q
    else:
        while True:
            a = 2 * p + 1
            if a >= size:
                break
            ka = hk[a]
            b = a + 1
            if b < size:
                kb = hk[b]
                if kb < ka:
                    a = b
                    ka = kb
            if key <= ka:
                break
            hk[p] = ka
            e = hd[a]
            hd[p] = e
            hpos[e] = p
            p = a
    hk[p] = key
    hd[p] = d
    hpos[d] = p


# ------------------------------------------------------------------------------ the cells
@njit(cache=True)
def _cell_of(x, y, gx0, gy0, icw, ich, ncx, ncy):
    return cell_coord(x, icw, gx0, ncx) + ncx * cell_coord(y, ich, gy0, ncy)


@njit(cache=True, inline="always")
def _cell_insert(d, c, cell, head, nxt, prv):
    cell[d] = c
    h = head[c]
    nxt[d] = h
    prv[d] = -1
    if h >= 0:
        prv[h] = d
    head[c] = d


@njit(cache=True, inline="always")
def _cell_remove(d, cell, head, nxt, prv):
    c = cell[d]
    a = prv[d]
    b = nxt[d]
    if a >= 0:
        nxt[a] = b
    else:
        head[c] = b
    if b >= 0:
        prv[b] = a
    cell[d] = -1


# ------------------------------------------------------------------------ the prediction
@njit(cache=True, inline="always")
def _predict(d, T, W, stamp, trx, cell, head, nxt, Ev, hk, hd, hpos, collide, bkind, b0, b1,
             b2, b3, gx0, gy0, cw, ch, ncx, ncy, entered):
    """Find disc d's earliest event after T (d must be at time T: ``W[d, W_T] == T``), store
    it in ``Ev[d, :4]`` = (time, partner code, partner stamp, aux) and in the heap.

    aux: the wall axis (box) or the cell being entered. ``Ev[d, 4:]`` keeps the earliest
    event other than a cell crossing, so that after a crossing (``entered`` = the direction
    came from: 1 +x, 2 -x, 3 +y, 4 -y; 0 for a full prediction) only the 3 cells that have
    just become adjacent need a scan, unless that event's partner has changed since.
    """
    x = W[d, 0]
    y = W[d, 1]
    vx = W[d, 2]
    vy = W[d, 3]
    r = W[d, 5]
    c = cell[d]
    cx = c % ncx
    cy = c // ncx
    if entered != 0:
        q = int(Ev[d, 5])
        if q >= 0 and stamp[q] != int(Ev[d, 6]):
            entered = 0  # the kept event is stale: predict afresh
    if entered == 0:
        best = trx[d] - T  # times relative to T from here on
        code = EV_REACT if best < INF else EV_NONE
        aux = 0
        if bkind == 0:
            tw, axis = box_next(x, y, vx, vy, r, b0, b1, b2, b3)
        else:
            tw, axis = circle_next(x, y, vx, vy, r, b0, b1, b2)
        if tw < best:
            best = tw
            code = EV_WALL
            aux = axis
        qx0 = max(cx - 1, 0)
        qx1 = min(cx + 2, ncx)
        qy0 = max(cy - 1, 0)
        qy1 = min(cy + 2, ncy)
    else:
        best = Ev[d, 4] - T
        code = int(Ev[d, 5])
        aux = int(Ev[d, 7])
        if entered == 1:
            qx0 = cx + 1
            qx1 = min(cx + 2, ncx)
            qy0 = max(cy - 1, 0)
            qy1 = min(cy + 2, ncy)
        elif entered == 2:
            qx0 = max(cx - 1, 0)
            qx1 = cx
            qy0 = max(cy - 1, 0)
            qy1 = min(cy + 2, ncy)
        elif entered == 3:
            qx0 = max(cx - 1, 0)
            qx1 = min(cx + 2, ncx)
            qy0 = cy + 1
            qy1 = min(cy + 2, ncy)
        else:
            qx0 = max(cx - 1, 0)
            qx1 = min(cx + 2, ncx)
            qy0 = max(cy - 1, 0)
            qy1 = cy
    if collide:
        # contacts with the discs of the cells around (all 3 x 3, or the new strip)
        for qy in range(qy0, qy1):
            for qx in range(qx0, qx1):
                k = head[qx + ncx * qy]
                while k >= 0:
                    if k != d:
                        dtk = T - W[k, 4]
                        wx = W[k, 2] - vx
                        wy = W[k, 3] - vy
                        rx = W[k, 0] + dtk * W[k, 2] - x
                        ry = W[k, 1] + dtk * W[k, 3] - y
                        b = rx * wx + ry * wy
                        vv = wx * wx + wy * wy
                        rr = rx * rx + ry * ry
                        if b < 0.0 and b * b > APPROACH2 * rr * vv:
                            R = r + W[k, 5]
                            cc = rr - R * R
                            D = b * b - vv * cc
                            if D > 0.0:
                                tk = cc / (math.sqrt(D) - b)
                                if tk < best:
                                    best = max(tk, 0.0)
                                    code = k
                                    aux = 0
                    k = nxt[k]
    t = T + best
    Ev[d, 4] = t
    Ev[d, 5] = code
    Ev[d, 6] = stamp[code] if code >= 0 else 0
    Ev[d, 7] = aux
    if collide:
        # the next cell crossing (none out of the grid: a wall comes first)
        tx = INF
        if vx > 0.0:
            if cx < ncx - 1:
                tx = (gx0 + (cx + 1) * cw - x) / vx
        elif vx < 0.0:
            if cx > 0:
                tx = (gx0 + cx * cw - x) / vx
        ty = INF
        if vy > 0.0:
            if cy < ncy - 1:
                ty = (gy0 + (cy + 1) * ch - y) / vy
        elif vy < 0.0:
            if cy > 0:
                ty = (gy0 + cy * ch - y) / vy
        if tx <= ty:
            if tx < best:
                best = max(tx, 0.0)
                code = EV_CELL
                aux = c + 1 if vx > 0.0 else c - 1
        elif ty < best:
            best = max(ty, 0.0)
            code = EV_CELL
            aux = c + ncx if vy > 0.0 else c - ncx
        t = T + best
    Ev[d, 0] = t
    Ev[d, 1] = code
    Ev[d, 2] = stamp[code] if code >= 0 else 0
    Ev[d, 3] = aux
    _hset(d, t, hk, hd, hpos)


@njit(cache=True)
def _room(x, y, r, ex1, ex2, T, W, spc, cell, head, nxt, collide, bkind, bp, gx0, gy0, icw,
          ich, ncx, ncy, rmax):
    """Does a disc of radius r fit at (x, y) at time T: inside the bounds and overlapping no
    live disc but ex1 and ex2 (touching is not overlapping)?"""
    if not inside(x, y, r, bkind, bp):
        return False
    if not collide:
        return True
    reach = r + rmax + _CELL_MARGIN * (r + rmax) + 1e-12
    c0 = _cell_of(x - reach, y - reach, gx0, gy0, icw, ich, ncx, ncy)
    c1 = _cell_of(x + reach, y + reach, gx0, gy0, icw, ich, ncx, ncy)
    for qy in range(c0 // ncx, c1 // ncx + 1):
        for qx in range(c0 % ncx, c1 % ncx + 1):
            k = head[qx + ncx * qy]
            while k >= 0:
                if k != ex1 and k != ex2:
                    dtk = T - W[k, 4]
                    dx = W[k, 0] + dtk * W[k, 2] - x
                    dy = W[k, 1] + dtk * W[k, 3] - y
                    R = r + W[k, 5]
                    if dx * dx + dy * dy < R * R:
                        return False
                k = nxt[k]
    return True


@njit(cache=True)
def _next_reaction(d, T, krate, trx, tables, spc, uint, rng, always, floor):
    """Recompute disc d's first-order rate K; draw a new reaction time if K changed (or if
    ``always``), no sooner than ``floor`` after T (0: the exact exponential time)."""
    K = first_order_rate(d, tables, spc, uint)
    if K != krate[d] or always:
        krate[d] = K
        if K > 0.0:
            trx[d] = T + max(-math.log1p(-rng.random()) / K, floor)
        else:
            trx[d] = INF


# ------------------------------------------------------------------------ event handlers
@njit(cache=True)
def _first_order_event(d, n, t, W, spc, uint, ids, idctr, stamp, trx, krate, tcol, cell, head,
                       nxt, prv, tables, collide, rmax, bkind, bp, gx0, gy0, icw, ich, ncx,
                       ncy, rng, icnt, ch_count, nfo, hsub, fo_exact):
    """Disc d (at time t) undergoes one of its first-order channels, if its products fit
    (else it waits an exponential time, but at least ``hsub``: a certain reaction, rate
    ~1e300, would otherwise retry at the same instant forever). After ``fo_exact`` first-order
    events of one disc in a call (``nfo``; FO_EXACT per step), its next ones are also at least
    ``hsub`` apart
    (a cycle of certain reactions, A -> B -> A, would not advance the clock either), each
    such delay counted in ``events_capped``. A fission's second fragment becomes disc n (the
    caller made sure there is room for it). Returns n if it was created, else -1."""
    sp_radius, sp_mass, sp_form = tables[0], tables[1], tables[2]
    ch_kind, ch_prod = tables[3], tables[5]
    s = spc[d]
    K = krate[d]
    c = first_order_pick(d, K, tables, spc, uint, rng)
    fired = False
    newd = -1
    if ch_kind[c] == TRANSFORMATION:
        p = ch_prod[c, 0]
        if sp_radius[p] <= sp_radius[s] or _room(
                W[d, 0], W[d, 1], sp_radius[p], d, d, t, W, spc, cell, head, nxt,
                collide, bkind, bp, gx0, gy0, icw, ich, ncx, ncy, rmax):
            fired = True
            uint[d] = transform_energy(uint[d], sp_form[s], sp_form[p])
            spc[d] = p
            W[d, 5] = sp_radius[p]
            W[d, 6] = sp_mass[p]
    else:
        pb = ch_prod[c, 0]
        pc = ch_prod[c, 1]
        E = released_energy(d, c, tables, spc, uint)
        m1 = sp_mass[pb]
        m2 = sp_mass[pc]
        r1 = sp_radius[pb]
        r2 = sp_radius[pc]
        X = W[d, 0]
        Y = W[d, 1]
        Vx = W[d, 2]
        Vy = W[d, 3]
        nx, ny = fission_direction(Vx, Vy, rng)
        sep = (r1 + r2) * _SEP
        for _attempt in range(2):
            x1, y1, v1x, v1y, x2, y2, v2x, v2y = fission_outcome(X, Y, Vx, Vy, E, m1,
                                                                 m2, sep, nx, ny)
            if _room(x1, y1, r1, d, d, t, W, spc, cell, head, nxt, collide, bkind,
                     bp, gx0, gy0, icw, ich, ncx, ncy, rmax) and \
                    _room(x2, y2, r2, d, d, t, W, spc, cell, head, nxt, collide,
                          bkind, bp, gx0, gy0, icw, ich, ncx, ncy, rmax):
                fired = True
                newd = n
                n += 1
                ids[newd] = idctr[0]
                idctr[0] += 1
                spc[d] = pb
                uint[d] = 0.0
                W[d, 0] = x1
                W[d, 1] = y1
                W[d, 2] = v1x
                W[d, 3] = v1y
                W[d, 5] = r1
                W[d, 6] = m1
                _cell_remove(d, cell, head, nxt, prv)
                _cell_insert(d, _cell_of(x1, y1, gx0, gy0, icw, ich, ncx, ncy), cell,
                             head, nxt, prv)
                spc[newd] = pc
                uint[newd] = 0.0
                W[newd, 0] = x2
                W[newd, 1] = y2
                W[newd, 2] = v2x
                W[newd, 3] = v2y
                W[newd, 4] = t
                W[newd, 5] = r2
                W[newd, 6] = m2
                stamp[newd] += 1
                tcol[newd] = -INF
                krate[newd] = 0.0
                trx[newd] = INF
                _cell_insert(newd, _cell_of(x2, y2, gx0, gy0, icw, ich, ncx, ncy),
                             cell, head, nxt, prv)
                break
            nx = -nx
            ny = -ny
    nfo[d] += 1
    if fired:
        ch_count[c] += 1
        stamp[d] += 1
        floor = 0.0
        if nfo[d] >= fo_exact:
            floor = hsub
            icnt[IC_EVENTS_CAPPED] += 1
        _next_reaction(d, t, krate, trx, tables, spc, uint, rng, True, floor)
        if newd >= 0:  # (lighter than d: chains of fissions end)
            _next_reaction(newd, t, krate, trx, tables, spc, uint, rng, True, 0.0)
    else:
        icnt[IC_NO_ROOM] += 1
        trx[d] = t + max(-math.log1p(-rng.random()) / K, hsub)  # wait and try again
    return newd


# ------------------------------------------------------------------------------ the run
@njit(cache=True)
def _grow_fill(a, cap, fill):
    out = np.full(cap, fill, dtype=a.dtype)
    out[: a.shape[0]] = a
    return out


@njit(cache=True)
def _grow_range(a, cap):
    out = np.arange(cap).astype(a.dtype)
    out[: a.shape[0]] = a
    return out


@njit(cache=True)
def _simulate(pos, vel, spc_ext, uint_ext, ids, idctr, n, n_steps, step_dt, bkind, bp,
              tables, params, flags, rng, icnt, fsum, ch_count, stats, cells_per_disc):
    """Advance discs [0, n) by ``n_steps`` steps of ``step_dt`` in one run, from time 0 to
    t1 = n_steps step_dt.

    Everything is derived from the state at the start of the run (positions, velocities,
    species, internal energies, the generator): the grid, the TC model's t_c, the retry
    floor, the event bound, and the reaction times, drawn afresh (exact: the exponential is
    memoryless). So the outcome does not depend on the arrays' capacity: a fission that
    finds them full grows them (and the working arrays) in place and carries on.

    Returns ``(pos, vel, spc, uint, ids, n, t)``: the state arrays (new ones if they grew),
    holding the discs at t; t = t1 unless the run reached its event bound (``n_steps k (64 n
    + 1024)`` events, the time-stepped integrator's bound for n_steps steps of k substeps):
    then t is the time of the first event not processed, and the caller finishes the run
    otherwise.
    Discs consumed by combinations are left with ``spc = -1`` (the caller compacts).

    Inside, discs are renumbered in cell order, so that neighbours are near in memory (at
    N = 10^5 a random order made each collision 2.6x as expensive); fragments are appended
    with the same index inside and out.
    """
    if n == 0:
        return pos, vel, spc_ext, uint_ext, ids, 0, n_steps * step_dt
    t1 = n_steps * step_dt
    sp_radius, sp_mass, sp_form = tables[0], tables[1], tables[2]
    ch_kind, ch_reac, ch_prod = tables[3], tables[4], tables[5]
    ch_energy = tables[7]
    bi_table = tables[10]
    e_rest = params[0]
    kappa = params[1]
    rmax = params[4]
    collide = flags[0] != 0
    has_uni = flags[1] != 0
    has_bi = flags[2] != 0
    cap = pos.shape[0]
    b0, b1, b2, b3 = bp[0], bp[1], bp[2], bp[3]
    tc = 0.0  # the TC model's t_c (inelastic scenes only)
    # the substep the time-stepped integrator would take (no disc moves more than
    # max_displacement smallest radii): the shortest wait of a refused reaction, and the
    # unit of the event bound
    v2max = 0.0
    for d in range(n):
        if spc_ext[d] >= 0:
            v2max = max(v2max, vel[d, 0] * vel[d, 0] + vel[d, 1] * vel[d, 1])
    ksub = 1
    q = math.sqrt(v2max) * step_dt / (params[2] * params[3])
    if not q <= MAX_SUBSTEPS:
        ksub = MAX_SUBSTEPS
    elif q > 1.0:
        ksub = int(math.ceil(q))
    hsub = step_dt / ksub
    budget = n_steps * ksub * (EVENTS_PER_DISC * n + 1024)
    fo_exact = n_steps * FO_EXACT
    if e_rest < 1.0:
        mv2 = 0.0
        msum = 0.0
        for d in range(n):
            if spc_ext[d] >= 0:
                m = sp_mass[spc_ext[d]]
                mv2 += m * (vel[d, 0] * vel[d, 0] + vel[d, 1] * vel[d, 1])
                msum += m
        if mv2 > 0.0:
            tc = TC_FRACTION * params[3] / math.sqrt(mv2 / msum)

    # ---- the grid (one cell when discs do not collide)
    if bkind == 0:
        gx0, gy0, gx1, gy1 = b0, b1, b2, b3
    else:
        gx0, gy0, gx1, gy1 = b0 - b2, b1 - b2, b0 + b2, b1 + b2
    gw = gx1 - gx0
    gh = gy1 - gy0
    ncx = 1
    ncy = 1
    if collide:
        cs = max(2.0 * rmax * (1.0 + _CELL_MARGIN),
                 math.sqrt(gw * gh / max(cells_per_disc * n, 1.0)),
                 math.sqrt(gw * gh / MAX_CELLS))
        ncx = max(1, int(gw / cs))
        ncy = max(1, int(gh / cs))
    cw = gw / ncx
    ch = gh / ncy
    icw = ncx / gw
    ich = ncy / gh
    stats[ST_CELLS] = ncx * ncy

    # ---- per-disc working state
    W = np.zeros((cap, 8), dtype=FLOAT)
    Ev = np.zeros((cap, 8), dtype=FLOAT)
    nfo = np.zeros(cap, dtype=COUNT)  # first-order events of each disc in this run
    stamp = np.zeros(cap, dtype=COUNT)
    trx = np.full(cap, INF, dtype=FLOAT)
    krate = np.zeros(cap, dtype=FLOAT)
    tcol = np.full(cap, -INF, dtype=FLOAT)
    cell = np.full(cap, -1, dtype=INDEX)
    nxt = np.full(cap, -1, dtype=INDEX)
    prv = np.full(cap, -1, dtype=INDEX)
    head = np.full(ncx * ncy, -1, dtype=INDEX)
    hk = np.full(cap, INF, dtype=FLOAT)
    hd = np.arange(cap).astype(INDEX)
    hpos = np.arange(cap).astype(INDEX)
    # internal numbering: live discs in cell order (dead ones last); perm[a] = outside index
    perm = np.arange(cap).astype(INDEX)
    cstart = np.zeros(ncx * ncy + 2, dtype=INDEX)
    for e in range(n):
        c = _cell_of(pos[e, 0], pos[e, 1], gx0, gy0, icw, ich, ncx, ncy) if spc_ext[e] >= 0 \
            else ncx * ncy
        cell[e] = c  # scratch: reset below
        cstart[c + 1] += 1
    for c in range(ncx * ncy + 1):
        cstart[c + 1] += cstart[c]
    for e in range(n):
        c = cell[e]
        perm[cstart[c]] = e
        cstart[c] += 1
    spc = np.full(cap, -1, dtype=INDEX)
    uint = np.zeros(cap, dtype=FLOAT)
    for d in range(n):
        e = perm[d]
        cell[d] = -1
        s = spc_ext[e]
        spc[d] = s
        uint[d] = uint_ext[e]
        if s < 0:
            continue
        W[d, 0] = pos[e, 0]
        W[d, 1] = pos[e, 1]
        W[d, 2] = vel[e, 0]
        W[d, 3] = vel[e, 1]
        W[d, 4] = 0.0
        W[d, 5] = sp_radius[s]
        W[d, 6] = sp_mass[s]
        _cell_insert(d, _cell_of(pos[e, 0], pos[e, 1], gx0, gy0, icw, ich, ncx, ncy), cell,
                     head, nxt, prv)
    if has_uni:  # reaction times drawn in the outside order (independent of the grid)
        inv = np.empty(n, dtype=INDEX)
        for d in range(n):
            inv[perm[d]] = d
        for e in range(n):
            d = inv[e]
            if spc[d] >= 0:
                _next_reaction(d, 0.0, krate, trx, tables, spc, uint, rng, True, 0.0)
    for d in range(n):
        if spc[d] >= 0:
            _predict(d, 0.0, W, stamp, trx, cell, head, nxt, Ev, hk, hd, hpos, collide, bkind,
                     b0, b1, b2, b3, gx0, gy0, cw, ch, ncx, ncy, 0)
    stats[ST_PREDICTIONS] += n

    t = 0.0
    events = 0
    while True:
        d = hd[0]
        t = hk[0]
        if not t <= t1:
            t = t1
            break
        if events >= budget:  # (t: the event not processed)
            break
        events += 1
        stats[ST_EVENTS] += 1
        code = int(Ev[d, 1])
        # bring d to t
        dt = t - W[d, 4]
        W[d, 0] += dt * W[d, 2]
        W[d, 1] += dt * W[d, 3]
        W[d, 4] = t
        p0 = d  # the discs to predict afresh after this event (-1: none)
        p1 = -1
        entered = 0
        if code >= 0 and stamp[code] != int(Ev[d, 2]):  # ------------- stale: predict again
            stats[ST_STALE] += 1
        elif code >= 0:  # ------------------------------------------------ disc-disc contact
            j = code
            p1 = j
            i = d
            dt = t - W[j, 4]
            W[j, 0] += dt * W[j, 2]
            W[j, 1] += dt * W[j, 3]
            W[j, 4] = t
            # approaching, by the very arithmetic of the prediction? (else a graze that
            # round-off made tangential: no impulse, and no new prediction of this pair)
            rx = W[j, 0] - W[i, 0]
            ry = W[j, 1] - W[i, 1]
            wx = W[j, 2] - W[i, 2]
            wy = W[j, 3] - W[i, 3]
            b = rx * wx + ry * wy
            if not (b < 0.0 and b * b > APPROACH2 * (rx * rx + ry * ry) * (wx * wx + wy * wy)):
                stats[ST_GRAZES] += 1
            else:
                # a reactive collision if a channel's trigger holds and its products
                # fit, else a bounce
                xi = W[i, 0]
                yi = W[i, 1]
                xj = W[j, 0]
                yj = W[j, 1]
                vxi = W[i, 2]
                vyi = W[i, 3]
                vxj = W[j, 2]
                vyj = W[j, 3]
                xi, yi, xj, yj, nx, ny = normal_at(xi, yi, vxi, vyi, xj, yj, vxj, vyj, 0.0)
                vr = (vxi - vxj) * nx + (vyi - vyj) * ny
                si = spc[i]
                sj = spc[j]
                mi = W[i, 6]
                mj = W[j, 6]
                fired = False
                killed = False
                if has_bi and vr > 0.0:
                    c = bi_table[si, sj]
                    if c >= 0 and 0.5 * mi * mj / (mi + mj) * vr * vr >= ch_energy[c]:
                        if ch_kind[c] == COMBINATION:
                            p = ch_prod[c, 0]
                            ok, X, Y, Vx, Vy, U = combine_outcome(
                                mi, mj, vxi, vyi, vxj, vyj, xi, yi, xj, yj, uint[i], uint[j],
                                sp_form[si], sp_form[sj], sp_form[p], 0.0)
                            fits = ok and _room(X, Y, sp_radius[p], i, j, t, W, spc, cell,
                                                head, nxt, collide, bkind, bp, gx0, gy0, icw,
                                                ich, ncx, ncy, rmax)
                            refused = ok and not fits
                            if fits:
                                fired = True
                                killed = True
                                spc[i] = p
                                W[i, 0] = X
                                W[i, 1] = Y
                                W[i, 2] = Vx
                                W[i, 3] = Vy
                                W[i, 5] = sp_radius[p]
                                W[i, 6] = sp_mass[p]
                                uint[i] = U
                                spc[j] = -1
                                uint[j] = 0.0
                                W[j, 2] = 0.0
                                W[j, 3] = 0.0
                                _cell_remove(j, cell, head, nxt, prv)
                                _hset(j, INF, hk, hd, hpos)
                                Ev[j, 0] = INF
                                Ev[j, 1] = EV_NONE
                                trx[j] = INF
                                krate[j] = 0.0
                                _cell_remove(i, cell, head, nxt, prv)
                                _cell_insert(i, _cell_of(X, Y, gx0, gy0, icw, ich, ncx, ncy),
                                             cell, head, nxt, prv)
                        else:
                            pi, pj = exchange_species(c, si, ch_reac, ch_prod)
                            ok, XC, YC, vCx, vCy, XD, YD, vDx, vDy = exchange_outcome(
                                mi, mj, sp_mass[pi], sp_mass[pj], sp_radius[pi], sp_radius[pj],
                                vxi, vyi, vxj, vyj, xi, yi, xj, yj, nx, ny, uint[i], uint[j],
                                sp_form[si], sp_form[sj], sp_form[pi], sp_form[pj], 0.0)
                            fits = ok and _room(XC, YC, sp_radius[pi], i, j, t, W, spc, cell,
                                                head, nxt, collide, bkind, bp, gx0, gy0, icw,
                                                ich, ncx, ncy, rmax) and \
                                _room(XD, YD, sp_radius[pj], i, j, t, W, spc, cell, head, nxt,
                                      collide, bkind, bp, gx0, gy0, icw, ich, ncx, ncy, rmax)
                            refused = ok and not fits
                            if fits:
                                fired = True
                                spc[i] = pi
                                spc[j] = pj
                                W[i, 0] = XC
                                W[i, 1] = YC
                                W[i, 2] = vCx
                                W[i, 3] = vCy
                                W[i, 5] = sp_radius[pi]
                                W[i, 6] = sp_mass[pi]
                                W[j, 0] = XD
                                W[j, 1] = YD
                                W[j, 2] = vDx
                                W[j, 3] = vDy
                                W[j, 5] = sp_radius[pj]
                                W[j, 6] = sp_mass[pj]
                                uint[i] = 0.0
                                uint[j] = 0.0
                                _cell_remove(i, cell, head, nxt, prv)
                                _cell_insert(i, _cell_of(XC, YC, gx0, gy0, icw, ich, ncx, ncy),
                                             cell, head, nxt, prv)
                                _cell_remove(j, cell, head, nxt, prv)
                                _cell_insert(j, _cell_of(XD, YD, gx0, gy0, icw, ich, ncx, ncy),
                                             cell, head, nxt, prv)
                        if fired:
                            ch_count[c] += 1
                            icnt[IC_REACTIVE] += 1
                        elif refused:  # (not when the energy could not pay for it)
                            icnt[IC_NO_ROOM] += 1
                if not fired:
                    e = e_rest
                    if e < 1.0 and (t - tcol[i] < tc or t - tcol[j] < tc):
                        e = 1.0
                        icnt[IC_TC_ELASTIC] += 1
                    ui0 = uint[i]
                    uj0 = uint[j]
                    vxi, vyi, vxj, vyj, ui, uj, lost = bounce(vxi, vyi, vxj, vyj, mi, mj, nx, ny,
                                                              e, kappa, ui0, uj0)
                    fsum[FS_DISSIPATED] += lost
                    W[i, 2] = vxi
                    W[i, 3] = vyi
                    W[j, 2] = vxj
                    W[j, 3] = vyj
                    icnt[IC_COLLISIONS] += 1
                    if ui != ui0 or uj != uj0:
                        uint[i] = ui
                        uint[j] = uj
                        if has_uni:
                            _next_reaction(i, t, krate, trx, tables, spc, uint, rng, False, 0.0)
                            _next_reaction(j, t, krate, trx, tables, spc, uint, rng, False, 0.0)
                elif has_uni:
                    _next_reaction(i, t, krate, trx, tables, spc, uint, rng, False, 0.0)
                    if not killed:
                        _next_reaction(j, t, krate, trx, tables, spc, uint, rng, False, 0.0)
                tcol[i] = t
                tcol[j] = t
                stamp[i] += 1
                stamp[j] += 1
                if killed:
                    p1 = -1
        elif code == EV_CELL:  # -------------------------------------------- cell crossing
            stats[ST_CROSSINGS] += 1
            c_old = cell[d]
            c_new = int(Ev[d, 3])
            _cell_remove(d, cell, head, nxt, prv)
            _cell_insert(d, c_new, cell, head, nxt, prv)
            if c_new // ncx == c_old // ncx:  # same row: crossed in x
                entered = 1 if c_new > c_old else 2
            else:
                entered = 3 if c_new > c_old else 4
        elif code == EV_WALL:  # -------------------------------------------------- a wall
            vx0 = W[d, 2]
            vy0 = W[d, 3]
            vx, vy, vn = reflected(W[d, 0], W[d, 1], vx0, vy0, int(Ev[d, 3]), bkind, b0, b1)
            if bkind == 1:  # never tangent to the curved wall (see walls.graze_floor)
                vx, vy = graze_floor(W[d, 0], W[d, 1], vx, vy, b0, b1)
                nx = W[d, 0] - b0
                ny = W[d, 1] - b1
                nr = math.sqrt(nx * nx + ny * ny)
                if nr > 0.0:  # the normal momentum the wall takes
                    vn = 0.5 * ((vx0 - vx) * nx + (vy0 - vy) * ny) / nr
            W[d, 2] = vx
            W[d, 3] = vy
            fsum[FS_WALL_MOMENTUM] += 2.0 * W[d, 6] * vn
            icnt[IC_WALL_HITS] += 1
            stamp[d] += 1
        elif code == EV_REACT:  # ------------------------------------ first-order reaction
            s = spc[d]
            # a fission needs a free slot: stop before drawing anything if there is none
            fission_possible = False
            for q in range(tables[8][s], tables[8][s + 1]):
                if ch_kind[tables[9][q]] != TRANSFORMATION:
                    fission_possible = True
            if fission_possible and n >= cap:  # grow everything, keep going
                stats[ST_RESTARTS] += 1
                cap = 2 * cap + 16
                pos = grow2(pos, cap)
                vel = grow2(vel, cap)
                spc_ext = _grow_fill(spc_ext, cap, -1)
                uint_ext = grow1(uint_ext, cap)
                ids = grow1(ids, cap)
                W = grow2(W, cap)
                Ev = grow2(Ev, cap)
                nfo = grow1(nfo, cap)
                stamp = grow1(stamp, cap)
                trx = _grow_fill(trx, cap, INF)
                krate = grow1(krate, cap)
                tcol = _grow_fill(tcol, cap, -INF)
                cell = _grow_fill(cell, cap, -1)
                nxt = _grow_fill(nxt, cap, -1)
                prv = _grow_fill(prv, cap, -1)
                hk = _grow_fill(hk, cap, INF)  # (slots past n hold inf: the order of the
                hd = _grow_range(hd, cap)  # heap, and so of the events, does not change)
                hpos = _grow_range(hpos, cap)
                perm = _grow_range(perm, cap)
                spc = _grow_fill(spc, cap, -1)
                uint = grow1(uint, cap)
            newd = _first_order_event(d, n, t, W, spc, uint, ids, idctr, stamp, trx, krate,
                                      tcol, cell, head, nxt, prv, tables, collide, rmax,
                                      bkind, bp, gx0, gy0, icw, ich, ncx, ncy, rng, icnt,
                                      ch_count, nfo, hsub, fo_exact)
            if newd >= 0:
                n += 1
                p1 = newd
        else:  # a disc with no event at all cannot be at the top below inf
            p0 = -1
            _hset(d, INF, hk, hd, hpos)
        for q in range(2):  # the one place predictions are made in the loop (inlined)
            pd = p0 if q == 0 else p1
            if pd >= 0:
                _predict(pd, t, W, stamp, trx, cell, head, nxt, Ev, hk, hd, hpos, collide,
                         bkind, b0, b1, b2, b3, gx0, gy0, cw, ch, ncx, ncy,
                         entered if q == 0 else 0)
                stats[ST_PREDICTIONS] += 1
    # ---- bring everyone to the common time t and write back (in the outside numbering)
    for d in range(n):
        e = perm[d]
        spc_ext[e] = spc[d]
        uint_ext[e] = uint[d]
        if spc[d] >= 0:
            dt = t - W[d, 4]
            pos[e, 0] = W[d, 0] + dt * W[d, 2]
            pos[e, 1] = W[d, 1] + dt * W[d, 3]
            vel[e, 0] = W[d, 2]
            vel[e, 1] = W[d, 3]
        else:
            vel[e, 0] = 0.0
            vel[e, 1] = 0.0
    return pos, vel, spc_ext, uint_ext, ids, n, t


@njit(cache=True)
def run_steps(pos, vel, spc, uint, ids, idctr, n, n_steps, dt, bkind, bp, tables, params,
              flags, rng, icnt, fsum, ch_count, stats, cells_per_disc):
    """Advance ``n_steps`` steps of ``dt`` in one exact run (every disc brought to the end).
    A run that reaches its event bound (see :func:`_simulate`) is finished from the time of
    the bound by the time-stepped integrator (steps of ``dt``, single-threaded; counted in
    ``events_capped``), whose own bounds hold. ``stats``: see :func:`run_stats`. Returns
    ``(pos, vel, spc, uint, ids, n)``."""
    pos, vel, spc, uint, ids, n, t = _simulate(pos, vel, spc, uint, ids, idctr, n, n_steps, dt,
                                               bkind, bp, tables, params, flags, rng, icnt,
                                               fsum, ch_count, stats, cells_per_disc)
    n = _compact(n, pos, vel, spc, uint, ids)
    rest = n_steps * dt - t
    if rest > 0.0:
        icnt[IC_EVENTS_CAPPED] += 1
        whole = min(int(rest / dt), n_steps)
        if whole > 0:
            pos, vel, spc, uint, ids, n, _w = step_run(
                pos, vel, spc, uint, n, whole, dt, bkind, bp, tables, params, flags, rng,
                icnt, fsum, ch_count, 1, ids, idctr, 0, 0, empty_work())
        if rest - whole * dt > 0.0:
            pos, vel, spc, uint, ids, n, _w = step_run(
                pos, vel, spc, uint, n, 1, rest - whole * dt, bkind, bp, tables, params, flags,
                rng, icnt, fsum, ch_count, 1, ids, idctr, 0, 0, empty_work())
    return pos, vel, spc, uint, ids, n


@njit(cache=True)
def run_stats(pos, vel, spc, uint, ids, idctr, n, duration, bkind, bp, tables, params, flags,
              rng, icnt, fsum, ch_count, stats, cells_per_disc):
    """:func:`run_tracked`, also accumulating the integrator's statistics in ``stats``
    (N_STATS,) int64 (see ST_*). ``cells_per_disc``: how many grid cells per disc at most
    (cells are never narrower than the largest diameter); :data:`CELLS_PER_DISC` by default.
    """
    return run_steps(pos, vel, spc, uint, ids, idctr, n, 1, duration, bkind, bp, tables,
                     params, flags, rng, icnt, fsum, ch_count, stats, cells_per_disc)


@njit(cache=True)
def run_steps_rngs(pos, vel, spc, uint, ids, idctr, n, n_steps, dt, bkind, bp, tables, params,
                   flags, rngs, icnt, fsum, ch_count):
    """:func:`run_steps` with its generator passed as ``rngs[0]`` (a ``numba.typed.List``;
    see :func:`discgym.kernels.step.run_tracked_rngs`): the entry point of
    :class:`~discgym.Simulation`."""
    stats = np.zeros(N_STATS, dtype=COUNT)
    return run_steps(pos, vel, spc, uint, ids, idctr, n, n_steps, dt, bkind, bp, tables,
                     params, flags, rngs[0], icnt, fsum, ch_count, stats, CELLS_PER_DISC)


@njit(cache=True)
def run_tracked(pos, vel, spc, uint, ids, idctr, n, duration, bkind, bp, tables, params, flags,
                rng, icnt, fsum, ch_count):
    """Advance discs [0, n) exactly by ``duration`` of simulated time, as one step.

    State and counters as for :func:`discgym.kernels.step.run_tracked`: ``pos`` (C, 2),
    ``vel`` (C, 2), ``spc`` (C,) species index (-1: no disc), ``uint`` (C,) internal energy,
    ``ids`` (C,) int64 disc identities (a fragment takes ``idctr[0]``, which is incremented),
    capacity C >= n; ``tables``, ``params``, ``flags`` from
    :class:`discgym.compiled.CompiledScene`; ``icnt``, ``fsum``, ``ch_count`` accumulated in
    place. Single-threaded.

    Returns ``(pos, vel, spc, uint, ids, n)``: new (larger) arrays when decompositions needed
    more capacity, else the ones passed in. Discs consumed by combinations are removed (the
    order of the others is kept); fragments are appended.
    """
    stats = np.zeros(N_STATS, dtype=COUNT)
    return run_stats(pos, vel, spc, uint, ids, idctr, n, duration, bkind, bp, tables, params,
                     flags, rng, icnt, fsum, ch_count, stats, CELLS_PER_DISC)


@njit(cache=True)
def run_tracked_rngs(pos, vel, spc, uint, ids, idctr, n, duration, bkind, bp, tables, params,
                     flags, rngs, icnt, fsum, ch_count):
    """:func:`run_tracked` with its generator passed as ``rngs[0]`` (a ``numba.typed.List``;
    see :func:`discgym.kernels.step.run_tracked_rngs`)."""
    return run_tracked(pos, vel, spc, uint, ids, idctr, n, duration, bkind, bp, tables, params,
                       flags, rngs[0], icnt, fsum, ch_count)


@njit(cache=True)
def run(pos, vel, spc, uint, n, duration, bkind, bp, tables, params, flags, rng, icnt, fsum,
        ch_count):
    """:func:`run_tracked` without disc identities. Returns ``(pos, vel, spc, uint, n)``."""
    ids = np.zeros(pos.shape[0], dtype=COUNT)
    idctr = np.zeros(1, dtype=COUNT)
    pos, vel, spc, uint, ids, n = run_tracked(pos, vel, spc, uint, ids, idctr, n, duration,
                                              bkind, bp, tables, params, flags, rng, icnt, fsum,
                                              ch_count)
    return pos, vel, spc, uint, n
