"""The exact, event-driven integrator: the accuracy ceiling of the time-stepped one.

Between events a disc flies in a straight line: it is stored as its position at the time of
its own last event and its velocity (a row of :class:`~.event_structs.Flights`), and is
brought forward only when an event involves it (x += (t - t_last) v, t_last = t) and, at the
end of a call, to the common end time. Events are exactly predicted and processed in time
order:

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
is stale and only makes its disc predict again.

Calls: a call of n steps is one exact run of n dt. It starts from the state alone (times
from 0, every disc's first event predicted afresh, O(N log N); reaction times drawn afresh,
exact since the exponential is memoryless; discs numbered in cell order for memory
locality) and ends with every disc brought to its end. So a copy or a restored state
continues bit for bit as the original does under the same calls, and the arrays' capacity
plays no part (a fission that finds them full grows them in place). A call boundary is a
synchronisation point: ``step(30); step(40)`` is two runs, the same physics as ``step(70)``
but not the same round-off and random stream. Predicting every disc afresh at every step
boundary would make them equal, at several times the cost of the run itself at ordinary
steps (docs/hard_cases.md, finding 19).

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
``fission_outcome``, ...) and what they write into the state from its ``apply_*`` functions
(given views of the per-disc rows as positions and velocities). Reactive collisions fire at
the contact when the energy along the line of centres, 1/2 mu v_r^2, is at least E_a (the
same trigger). Products are placed only
where they fit inside the bounds without overlapping any disc (no room: the collision
bounces, a first-order reaction waits an exponential time, but at least a substep, and tries
again); both count as ``reactions_without_room``.

Inelastic collapse (restitution e < 1) would make infinitely many collisions in finite time:
a collision of a disc that collided less than t_c ago is elastic (the TC model of Luding and
McNamara; the time-stepped integrator uses t_c = its substep), with t_c = ``TC_FRACTION``
times the time the smallest disc takes to move its radius at the root-mean-square speed
(taken at the start of each call). The energy booked as dissipated is exactly what was lost;
such collisions are counted as ``elastic_repeats``.

Counters (:class:`~.event_structs.Counters`) are those of :mod:`discgym.kernels.step`;
``events_capped`` counts the steps stopped at the event bound and the delayed first-order
events; ``substeps`` and the other counters of the time-stepped integrator count only what it
did finishing such steps (0 otherwise).
"""


import math

import numpy as np
from numba import njit

from .celllist import cell_coord
from .collisions import bounce, normal_at
from .event_structs import (
    EVENT_COLUMNS,
    KEPT_AUX,
    KEPT_CODE,
    KEPT_STAMP,
    KEPT_T,
    NEXT_AUX,
    NEXT_CODE,
    NEXT_STAMP,
    NEXT_T,
    PATH_COLUMNS,
    PM,
    PR,
    PT,
    PVX,
    PVY,
    PX,
    PY,
    Cells,
    Counters,
    Flights,
    Queue,
    Run,
)
from .heap import IndexedHeap, heap_set
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
    first_order_rate,
    fission_direction,
    fission_outcome,
    grow1,
    grow2,
    kind,
    released_energy,
)
from .rules import book_outflow, book_thermal, tc_restitution
from .step import (
    MAX_SUBSTEPS,
    advance,
    compact,
    empty_work,
)
from .structs import (
    COUNT,
    EVENTS_PER_DISC,
    F_BI,
    F_COLLISIONS,
    F_OUTLETS,
    F_THERMAL,
    F_UNI,
    FLOAT,
    FS_DISSIPATED,
    FS_WALL_MOMENTUM,
    IC_COLLISIONS,
    IC_EVENTS_CAPPED,
    IC_NO_ROOM,
    IC_REACTIVE,
    IC_WALL_HITS,
    INDEX,
    P_MAXDISP,
    P_RELAX,
    P_RESTITUTION,
    P_RMAX,
    P_RMIN,
    Bounds,
    Discs,
    Tables,
    fields,
)
from .structs import Counters as StepCounters
from .walls import (
    box_next,
    circle_next,
    graze_floor,
    inside,
    on_outlet,
    reflected,
    side_of,
    thermal_velocity,
)

INF = math.inf

# Event codes (the partner field of a disc's event): >= 0 is a disc.
EV_WALL = -1
EV_CELL = -2
EV_REACT = -3
EV_NONE = -4

# Statistics (``Counters.stats``, int64, filled by :func:`run_steps`).
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


# ------------------------------------------------------------------------------ the cells
@njit(cache=True, inline="always")
def _cell_of(x, y, cells):
    return cell_coord(x, cells.iw, cells.x0, cells.ncx) + cells.ncx * cell_coord(
        y, cells.ih, cells.y0, cells.ncy)


@njit(cache=True, inline="always")
def _cell_insert(d, c, cells):
    cell, head, nxt, prv = cells.cell, cells.head, cells.nxt, cells.prv
    cell[d] = c
    h = head[c]
    nxt[d] = h
    prv[d] = -1
    if h >= 0:
        prv[h] = d
    head[c] = d


@njit(cache=True, inline="always")
def _cell_remove(d, cells):
    cell, head, nxt, prv = cells.cell, cells.head, cells.nxt, cells.prv
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


@njit(cache=True, inline="always")
def _cell_move(d, x, y, cells):
    """Disc d, now at (x, y), into the list of its cell there (last: the list order is the
    order neighbours are scanned in)."""
    _cell_remove(d, cells)
    _cell_insert(d, _cell_of(x, y, cells), cells)


# ------------------------------------------------------------------------ the prediction
@njit(cache=True, inline="always")
def _scan_range(cx, cy, ncx, ncy, entered):
    """Cells (qx0, qx1, qy0, qy1), half open, to scan for contacts from cell (cx, cy): all
    3 x 3 around (``entered`` 0), or the strip that has just become adjacent after a crossing
    (``entered``: 1 +x, 2 -x, 3 +y, 4 -y)."""
    qx0 = max(cx - 1, 0)
    qx1 = min(cx + 2, ncx)
    qy0 = max(cy - 1, 0)
    qy1 = min(cy + 2, ncy)
    if entered == 1:
        qx0 = cx + 1
    elif entered == 2:
        qx1 = cx
    elif entered == 3:
        qy0 = cy + 1
    elif entered == 4:
        qy1 = cy
    return qx0, qx1, qy0, qy1


@njit(cache=True, inline="always")
def _crossing_time(x, y, vx, vy, cx, cy, cells):
    """Time until disc at (x, y) with velocity v leaves cell (cx, cy), and the cell it
    enters (none out of the grid: a wall comes first; (inf, -1) if it never does)."""
    ncx, ncy = cells.ncx, cells.ncy
    tx = INF
    if vx > 0.0:
        if cx < ncx - 1:
            tx = (cells.x0 + (cx + 1) * cells.w - x) / vx
    elif vx < 0.0:
        if cx > 0:
            tx = (cells.x0 + cx * cells.w - x) / vx
    ty = INF
    if vy > 0.0:
        if cy < ncy - 1:
            ty = (cells.y0 + (cy + 1) * cells.h - y) / vy
    elif vy < 0.0:
        if cy > 0:
            ty = (cells.y0 + cy * cells.h - y) / vy
    c = cx + ncx * cy
    if tx <= ty:
        return tx, c + 1 if vx > 0.0 else c - 1
    return ty, c + ncx if vy > 0.0 else c - ncx


@njit(cache=True, inline="always")
def _earliest_contact(d, T, W, cells, span, best, code, aux):
    """The earliest contact of disc d (at time T) with the discs of the cells ``span`` =
    (qx0, qx1, qy0, qy1), half open, if before ``best`` (relative to T): ``(time, partner,
    0)``, else ``(best, code, aux)`` as given."""
    head, nxt, ncx = cells.head, cells.nxt, cells.ncx
    qx0, qx1, qy0, qy1 = span
    x = W[d, PX]
    y = W[d, PY]
    vx = W[d, PVX]
    vy = W[d, PVY]
    r = W[d, PR]
    for qy in range(qy0, qy1):
        for qx in range(qx0, qx1):
            k = head[qx + ncx * qy]
            while k >= 0:
                if k != d:
                    dtk = T - W[k, PT]
                    wx = W[k, PVX] - vx
                    wy = W[k, PVY] - vy
                    rx = W[k, PX] + dtk * W[k, PVX] - x
                    ry = W[k, PY] + dtk * W[k, PVY] - y
                    b = rx * wx + ry * wy
                    vv = wx * wx + wy * wy
                    rr = rx * rx + ry * ry
                    if b < 0.0 and b * b > APPROACH2 * rr * vv:
                        R = r + W[k, PR]
                        cc = rr - R * R
                        D = b * b - vv * cc
                        if D > 0.0:
                            tk = cc / (math.sqrt(D) - b)
                            if tk < best:
                                best = max(tk, 0.0)
                                code = k
                                aux = 0
                k = nxt[k]
    return best, code, aux


@njit(cache=True, inline="always")
def _predict(d, T, fl, cells, queue, run, entered):
    """Find disc d's earliest event after T (d must be at time T: ``path[d, PT] == T``),
    store it in ``event[d, NEXT_*]`` and in the heap.

    ``event[d, KEPT_*]`` keeps the earliest event other than a cell crossing, so that after a
    crossing (``entered`` the direction, see :func:`_scan_range`; 0 for a full prediction)
    only the 3 cells that have just become adjacent need a scan, unless that event's partner
    has changed since.
    """
    W = fl.path
    stamp = fl.stamp
    Ev = queue.event
    ncx = cells.ncx
    x = W[d, PX]
    y = W[d, PY]
    vx = W[d, PVX]
    vy = W[d, PVY]
    r = W[d, PR]
    c = cells.cell[d]
    cx = c % ncx
    cy = c // ncx
    if entered != 0:
        q = int(Ev[d, KEPT_CODE])
        if q >= 0 and stamp[q] != int(Ev[d, KEPT_STAMP]):
            entered = 0  # the kept event is stale: predict afresh
    if entered == 0:
        best = fl.t_reaction[d] - T  # times relative to T from here on
        code = EV_REACT if best < INF else EV_NONE
        aux = 0
        if run.bounds_kind == 0:
            tw, axis = box_next(x, y, vx, vy, r, run.b0, run.b1, run.b2, run.b3)
        else:
            tw, axis = circle_next(x, y, vx, vy, r, run.b0, run.b1, run.b2)
        if tw < best:
            best = tw
            code = EV_WALL
            aux = axis
    else:
        best = Ev[d, KEPT_T] - T
        code = int(Ev[d, KEPT_CODE])
        aux = int(Ev[d, KEPT_AUX])
    collide = run.collide
    if collide:
        # contacts with the discs of the cells around (all 3 x 3, or the new strip)
        span = _scan_range(cx, cy, ncx, cells.ncy, entered)
        best, code, aux = _earliest_contact(d, T, W, cells, span, best, code, aux)
    t = T + best
    Ev[d, KEPT_T] = t
    Ev[d, KEPT_CODE] = code
    Ev[d, KEPT_STAMP] = stamp[code] if code >= 0 else 0
    Ev[d, KEPT_AUX] = aux
    if collide:
        tx, a = _crossing_time(x, y, vx, vy, cx, cy, cells)
        if tx < best:
            best = max(tx, 0.0)
            code = EV_CELL
            aux = a
        t = T + best
    Ev[d, NEXT_T] = t
    Ev[d, NEXT_CODE] = code
    Ev[d, NEXT_STAMP] = stamp[code] if code >= 0 else 0
    Ev[d, NEXT_AUX] = aux
    heap_set(queue.heap, d, t)


@kernel
def _room(x, y, r, ex1, ex2, T, fl, cells, run):
    """Does a disc of radius r fit at (x, y) at time T: inside the bounds and overlapping no
    live disc but ex1 and ex2 (touching is not overlapping)?"""
    if not inside(x, y, r, run.bounds_kind, run.bounds_params):
        return False
    if not run.collide:
        return True
    W = fl.path
    head, nxt, ncx = cells.head, cells.nxt, cells.ncx
    rmax = run.rmax
    reach = r + rmax + _CELL_MARGIN * (r + rmax) + 1e-12
    c0 = _cell_of(x - reach, y - reach, cells)
    c1 = _cell_of(x + reach, y + reach, cells)
    for qy in range(c0 // ncx, c1 // ncx + 1):
        for qx in range(c0 % ncx, c1 % ncx + 1):
            k = head[qx + ncx * qy]
            while k >= 0:
                if k != ex1 and k != ex2:
                    dtk = T - W[k, PT]
                    dx = W[k, PX] + dtk * W[k, PVX] - x
                    dy = W[k, PY] + dtk * W[k, PVY] - y
                    R = r + W[k, PR]
                    if dx * dx + dy * dy < R * R:
                        return False
                k = nxt[k]
    return True


@njit(cache=True, inline="always")
def _next_reaction(d, T, fl, tables, rng, always, floor):
    """Recompute disc d's first-order rate K; draw a new reaction time if K changed (or if
    ``always``), no sooner than ``floor`` after T (0: the exact exponential time)."""
    K = first_order_rate(d, tables, fl.species, fl.internal_energy)
    if K != fl.rate[d] or always:
        fl.rate[d] = K
        if K > 0.0:
            fl.t_reaction[d] = T + max(-math.log1p(-rng.random()) / K, floor)
        else:
            fl.t_reaction[d] = INF


@njit(cache=True, inline="always")
def _advance(d, t, W):
    """Bring disc d along its path to time t."""
    dt = t - W[d, PT]
    W[d, PX] += dt * W[d, PVX]
    W[d, PY] += dt * W[d, PVY]
    W[d, PT] = t


@njit(cache=True, inline="always")
def _set_kind(d, s, W, tables):
    """Disc d's radius and mass columns for its (new) species s."""
    W[d, PR] = tables.sp_radius[s]
    W[d, PM] = tables.sp_mass[s]


# ------------------------------------------------------------------------ event handlers
@njit(cache=True, inline="always")
def _remove(j, fl, cells, queue):
    """Disc j is gone (combined away): out of its cell, the heap and the reactions."""
    _cell_remove(j, cells)
    heap_set(queue.heap, j, INF)
    queue.event[j, NEXT_T] = INF
    queue.event[j, NEXT_CODE] = EV_NONE
    fl.t_reaction[j] = INF
    fl.rate[j] = 0.0


@njit(cache=True, inline="always")
def _combine(i, j, c, t, k, fl, cells, queue, run, tables):
    """A + B -> C at the contact k of i and j at time t, if C fits: i becomes C, j goes.
    Returns (fired, refused: the energy could pay but there was no room)."""
    W = fl.path
    p = tables.ch_prod[c, 0]
    ok, q = combine_outcome(k, kind(fl.species[i], tables), kind(fl.species[j], tables),
                            kind(p, tables), fl.internal_energy[i], fl.internal_energy[j],
                            0.0)
    fits = ok and _room(q.x, q.y, tables.sp_radius[p], i, j, t, fl, cells, run)
    if fits:
        apply_combination(i, j, p, q, W[:, PX:PY + 1], W[:, PVX:PVY + 1], fl.species,
                          fl.internal_energy)
        _set_kind(i, p, W, tables)
        _remove(j, fl, cells, queue)
        _cell_move(i, q.x, q.y, cells)
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
    fits = ok and _room(qi.x, qi.y, sp_radius[pi], i, j, t, fl, cells, run) and \
        _room(qj.x, qj.y, sp_radius[pj], i, j, t, fl, cells, run)
    if fits:
        apply_exchange(i, j, pi, pj, qi, qj, W[:, PX:PY + 1], W[:, PVX:PVY + 1], fl.species,
                       fl.internal_energy)
        _set_kind(i, pi, W, tables)
        _set_kind(j, pj, W, tables)
        _cell_move(i, qi.x, qi.y, cells)
        _cell_move(j, qj.x, qj.y, cells)
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
            _next_reaction(i, t, fl, tables, rng, False, 0.0)
            _next_reaction(j, t, fl, tables, rng, False, 0.0)


@njit(cache=True, inline="always")
def _collision(i, j, t, fl, cells, queue, run, tables, rng, counters):
    """Disc i (at t) meets disc j: a reaction or a bounce, unless round-off made the contact
    tangential. Returns the partner to predict afresh (-1: it combined away)."""
    W = fl.path
    _advance(j, t, W)
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
        _next_reaction(i, t, fl, tables, rng, False, 0.0)
        if not killed:
            _next_reaction(j, t, fl, tables, rng, False, 0.0)
    fl.t_collision[i] = t
    fl.t_collision[j] = t
    fl.stamp[i] += 1
    fl.stamp[j] += 1
    return -1 if killed else j


@njit(cache=True, inline="always")
def _crossing(d, cells, queue, stats):
    """Disc d enters the cell of its event. Returns the direction it came (``entered``)."""
    stats[ST_CROSSINGS] += 1
    c_old = cells.cell[d]
    c_new = int(queue.event[d, NEXT_AUX])
    _cell_remove(d, cells)
    _cell_insert(d, c_new, cells)
    if c_new // cells.ncx == c_old // cells.ncx:  # same row: crossed in x
        return 1 if c_new > c_old else 2
    return 3 if c_new > c_old else 4


@njit(cache=True, inline="always")
def _leaves(d, fl, queue, run, tables, counters):
    """Does disc d, at the wall contact of its event, meet an outlet? If so it leaves: its
    energy (kinetic + internal + formation) booked in FS_OUTFLOW, counted in
    ``counters.outflow``, species -1 (the caller removes it from the cells and the queue;
    the run's end compacts it away, as a disc consumed by a combination)."""
    W = fl.path
    side, frac = side_of(W[d, PX], W[d, PY], int(queue.event[d, NEXT_AUX]), W[d, PVX],
                         W[d, PVY], run.bounds_kind, run.bounds_params)
    if not on_outlet(side, frac, tables.outlets):
        return False
    book_outflow(fl.species[d], W[d, PM], W[d, PVX], W[d, PVY], fl.internal_energy[d],
                 tables.sp_form, counters.fsum, counters.outflow)
    fl.species[d] = -1
    return True


@njit(cache=True, inline="always")
def _wall_hit(d, fl, queue, run, counters, rng):
    """Disc d reflects off the wall of its event; off a thermal side (``run.thermal``,
    ``run.walls``) it leaves with a velocity drawn from the wall
    (:func:`~discgym.kernels.walls.thermal_velocity`, the energy exchanged booked in
    FS_WALL_HEAT + side)."""
    W = fl.path
    b0, b1 = run.b0, run.b1
    vx0 = W[d, PVX]
    vy0 = W[d, PVY]
    axis = int(queue.event[d, NEXT_AUX])
    if run.thermal:
        side, _f = side_of(W[d, PX], W[d, PY], axis, vx0, vy0, run.bounds_kind,
                           run.bounds_params)
        kT = run.walls[side]
        if kT == kT:  # (NaN: a specular side)
            m = W[d, PM]
            vx, vy, vn_in, vn_out = thermal_velocity(W[d, PX], W[d, PY], vx0, vy0, side, kT,
                                                     m, run.bounds_kind, run.bounds_params,
                                                     rng)
            if run.bounds_kind == 1:  # (as after a reflection: see walls.graze_floor)
                vx, vy = graze_floor(W[d, PX], W[d, PY], vx, vy, b0, b1)
                nx = b0 - W[d, PX]
                ny = b1 - W[d, PY]
                nr = math.sqrt(nx * nx + ny * ny)
                if nr > 0.0:
                    vn_out = (vx * nx + vy * ny) / nr
            W[d, PVX] = vx
            W[d, PVY] = vy
            book_thermal(side, m, vx0, vy0, vx, vy, vn_in, vn_out, counters.fsum)
            counters.icnt[IC_WALL_HITS] += 1
            fl.stamp[d] += 1
            return
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
    counters.fsum[FS_WALL_MOMENTUM] += 2.0 * W[d, PM] * vn
    counters.icnt[IC_WALL_HITS] += 1
    fl.stamp[d] += 1


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
        if _room(qb.x, qb.y, r1, d, d, t, fl, cells, run) and \
                _room(qc.x, qc.y, r2, d, d, t, fl, cells, run):
            state.ids[n] = state.next_id[0]
            state.next_id[0] += 1
            apply_fission(d, n, pb, pc, qb, qc, W[:, PX:PY + 1], W[:, PVX:PVY + 1], fl.species,
                          fl.internal_energy)
            W[d, PR] = r1
            W[d, PM] = m1
            _cell_move(d, qb.x, qb.y, cells)
            W[n, PT] = t
            W[n, PR] = r2
            W[n, PM] = m2
            fl.stamp[n] += 1
            fl.t_collision[n] = -INF
            fl.rate[n] = 0.0
            fl.t_reaction[n] = INF
            _cell_insert(n, _cell_of(qc.x, qc.y, cells), cells)
            return True
        nx = -nx
        ny = -ny
    return False


@kernel
def _first_order_event(d, n, t, fl, cells, state, run, tables, rng, counters):
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
        fired = sp_radius[p] <= sp_radius[s] or _room(W[d, PX], W[d, PY], sp_radius[p], d, d,
                                                      t, fl, cells, run)
        if fired:
            apply_transformation(d, p, tables.sp_form, fl.species, fl.internal_energy)
            _set_kind(d, p, W, tables)
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
        _next_reaction(d, t, fl, tables, rng, True, floor)
        if newd >= 0:  # (lighter than d: chains of fissions end)
            _next_reaction(newd, t, fl, tables, rng, True, 0.0)
    else:
        counters.icnt[IC_NO_ROOM] += 1
        fl.t_reaction[d] = t + max(-math.log1p(-rng.random()) / K, run.hsub)  # try again
    return newd


@kernel
def _may_split(s, tables):
    """Has species s a first-order channel that makes two discs?"""
    for q in range(tables.uni_start[s], tables.uni_start[s + 1]):
        if tables.ch_kind[tables.uni_chan[q]] != TRANSFORMATION:
            return True
    return False


# ------------------------------------------------------------------------------ the run
@njit(cache=True, inline="always")
def _grow_fill(a, cap, fill):
    out = np.full(cap, fill, dtype=a.dtype)
    for i in range(a.shape[0]):  # (a loop: numba's slice assignment compiles an error)
        out[i] = a[i]
    return out


@kernel
def _grow_range(a, cap):
    out = np.arange(cap).astype(a.dtype)
    for i in range(a.shape[0]):  # (a loop: numba's slice assignment compiles an error)
        out[i] = a[i]
    return out


@kernel
def _grow(cap, state, fl, cells, queue):
    """Every per-disc array at capacity ``cap`` (the contents kept; new slots hold no disc,
    and heap key inf, so the order of the heap, and of the events, does not change)."""
    state = Discs(grow2(state.pos, cap), grow2(state.vel, cap),
                  _grow_fill(state.species, cap, -1), grow1(state.internal_energy, cap),
                  grow1(state.ids, cap), state.next_id)
    fl = Flights(grow2(fl.path, cap), _grow_fill(fl.species, cap, -1),
                 grow1(fl.internal_energy, cap), grow1(fl.stamp, cap),
                 _grow_fill(fl.t_collision, cap, -INF), _grow_fill(fl.t_reaction, cap, INF),
                 grow1(fl.rate, cap), grow1(fl.n_first_order, cap), _grow_range(fl.perm, cap))
    cells = Cells(cells.x0, cells.y0, cells.w, cells.h, cells.iw, cells.ih, cells.ncx,
                  cells.ncy, cells.head, _grow_fill(cells.nxt, cap, -1),
                  _grow_fill(cells.prv, cap, -1), _grow_fill(cells.cell, cap, -1))
    heap = queue.heap
    queue = Queue(grow2(queue.event, cap),
                  IndexedHeap(_grow_fill(heap.key, cap, INF), _grow_range(heap.disc, cap),
                              _grow_range(heap.slot, cap)))
    return state, fl, cells, queue


@kernel
def _run_constants(n, n_steps, step_dt, vel, species, tables, params, flags, bounds):
    """What a run of ``n_steps`` of ``step_dt`` fixes from the scene and the state at its
    start: the substep the time-stepped integrator would take (no disc moves more than
    max_displacement smallest radii), which is the shortest wait of a refused reaction and
    the unit of the event bound, and the TC model's t_c (inelastic scenes only)."""
    sp_mass = tables.sp_mass
    bounds_params = bounds.params
    e_rest = params[P_RESTITUTION]
    v2max = 0.0
    for d in range(n):
        if species[d] >= 0:
            v2max = max(v2max, vel[d, 0] * vel[d, 0] + vel[d, 1] * vel[d, 1])
    ksub = 1
    q = math.sqrt(v2max) * step_dt / (params[P_MAXDISP] * params[P_RMIN])
    if not q <= MAX_SUBSTEPS:
        ksub = MAX_SUBSTEPS
    elif q > 1.0:
        ksub = int(math.ceil(q))
    tc = 0.0
    if e_rest < 1.0:
        mv2 = 0.0
        msum = 0.0
        for d in range(n):
            if species[d] >= 0:
                m = sp_mass[species[d]]
                mv2 += m * (vel[d, 0] * vel[d, 0] + vel[d, 1] * vel[d, 1])
                msum += m
        if mv2 > 0.0:
            tc = TC_FRACTION * params[P_RMIN] / math.sqrt(mv2 / msum)
    return Run(n_steps * step_dt, n_steps * ksub * (EVENTS_PER_DISC * n + 1024),
               step_dt / ksub, n_steps * FO_EXACT, tc, e_rest, params[P_RELAX], params[P_RMAX],
               flags[F_COLLISIONS] != 0, flags[F_UNI] != 0, flags[F_BI] != 0, bounds.kind,
               bounds.params, bounds_params[0], bounds_params[1], bounds_params[2],
               bounds_params[3], flags[F_THERMAL] != 0, bounds.walls, flags[F_OUTLETS] != 0)


@kernel
def _make_cells(n, cap, run, cells_per_disc):
    """The grid over the bounds (one cell when discs do not collide), no disc in it yet."""
    b0, b1, b2, b3 = run.b0, run.b1, run.b2, run.b3
    if run.bounds_kind == 0:
        gx0, gy0, gx1, gy1 = b0, b1, b2, b3
    else:
        gx0, gy0, gx1, gy1 = b0 - b2, b1 - b2, b0 + b2, b1 + b2
    gw = gx1 - gx0
    gh = gy1 - gy0
    ncx = 1
    ncy = 1
    if run.collide:
        cs = max(2.0 * run.rmax * (1.0 + _CELL_MARGIN),
                 math.sqrt(gw * gh / max(cells_per_disc * n, 1.0)),
                 math.sqrt(gw * gh / MAX_CELLS))
        ncx = max(1, int(gw / cs))
        ncy = max(1, int(gh / cs))
    return Cells(gx0, gy0, gw / ncx, gh / ncy, ncx / gw, ncy / gh, ncx, ncy,
                 np.full(ncx * ncy, -1, dtype=INDEX), np.full(cap, -1, dtype=INDEX),
                 np.full(cap, -1, dtype=INDEX), np.full(cap, -1, dtype=INDEX))


@kernel
def _load(n, cap, state, cells, tables):
    """The discs in the integrator's numbering: live ones in cell order (dead ones last),
    so that neighbours are near in memory; each at time 0 and in its cell."""
    perm = np.arange(cap).astype(INDEX)  # perm[a] = the caller's index of disc a
    fl = Flights(np.zeros((cap, PATH_COLUMNS), dtype=FLOAT), np.full(cap, -1, dtype=INDEX),
                 np.zeros(cap, dtype=FLOAT), np.zeros(cap, dtype=COUNT),
                 np.full(cap, -INF, dtype=FLOAT), np.full(cap, INF, dtype=FLOAT),
                 np.zeros(cap, dtype=FLOAT), np.zeros(cap, dtype=COUNT), perm)
    _fill(n, state, cells, tables, fl, np.zeros(cells.ncx * cells.ncy + 2, dtype=INDEX))
    return fl


@kernel(_nrt=False)
def _fill(n, state, cells, tables, fl, cstart):
    """:func:`_load`'s loops (``cstart`` zeros, one more than the cells and the dead), without
    reference counting (see :func:`_event_loop`)."""
    pos, vel, spc_ext = state.pos, state.vel, state.species
    ncells = cells.ncx * cells.ncy
    cell, perm, W = cells.cell, fl.perm, fl.path
    for e in range(n):
        c = _cell_of(pos[e, 0], pos[e, 1], cells) if spc_ext[e] >= 0 else ncells
        cell[e] = c  # scratch: reset below
        cstart[c + 1] += 1
    for c in range(ncells + 1):
        cstart[c + 1] += cstart[c]
    for e in range(n):
        c = cell[e]
        perm[cstart[c]] = e
        cstart[c] += 1
    for d in range(n):
        e = perm[d]
        cell[d] = -1
        s = spc_ext[e]
        fl.species[d] = s
        fl.internal_energy[d] = state.internal_energy[e]
        if s < 0:
            continue
        W[d, PX] = pos[e, 0]
        W[d, PY] = pos[e, 1]
        W[d, PVX] = vel[e, 0]
        W[d, PVY] = vel[e, 1]
        W[d, PT] = 0.0
        _set_kind(d, s, W, tables)
        _cell_insert(d, _cell_of(pos[e, 0], pos[e, 1], cells), cells)


@kernel
def _first_predictions(n, fl, cells, queue, run, tables, rng, stats):
    """Every disc's reaction time (drawn in the caller's order, independent of the grid) and
    first event."""
    if run.has_uni:
        inv = np.empty(n, dtype=INDEX)
        for d in range(n):
            inv[fl.perm[d]] = d
        for e in range(n):
            d = inv[e]
            if fl.species[d] >= 0:
                _next_reaction(d, 0.0, fl, tables, rng, True, 0.0)
    _predict_all(n, fl, cells, queue, run)
    stats[ST_PREDICTIONS] += n


@kernel(_nrt=False)
def _predict_all(n, fl, cells, queue, run):
    """Every disc's first event (without reference counting: see :func:`_event_loop`)."""
    for d in range(n):
        if fl.species[d] >= 0:
            _predict(d, 0.0, fl, cells, queue, run, 0)


@kernel(_nrt=False)
def _event_loop(n, events, state, fl, cells, queue, run, tables, rng, counters):
    """Process events in time order until the end of the run, its event bound, or a
    first-order reaction that may split a disc while the arrays are full (checked before
    anything of that event is done). Returns ``(t, n, events, grow)``: the time reached (the
    first event not processed, at the bound or the growth), the discs, the events processed
    so far in the run, and whether the arrays must grow before the loop goes on.

    Compiled without numba's reference counting (``_nrt=False``): every array here is
    borrowed from the caller, which keeps it alive, nothing is allocated and none is
    returned. With it, the handlers inlined here took and dropped a reference to each array
    of the structs they are given (some 40 atomic updates per event, most of the time of
    an event at 10^4 discs; numba's pruning of such pairs gives up on a loop this size).
    The arithmetic is the same either way."""
    stats = counters.stats
    cap = fl.path.shape[0]
    t = 0.0
    while True:
        d = queue.heap.disc[0]
        t = queue.heap.key[0]
        if not t <= run.t1:
            t = run.t1
            break
        if events >= run.budget:  # (t: the event not processed)
            break
        code = int(queue.event[d, NEXT_CODE])
        # a fission needs a free slot: the caller makes one before anything is drawn
        if code == EV_REACT and n >= cap and _may_split(fl.species[d], tables):
            return t, n, events, True
        events += 1
        stats[ST_EVENTS] += 1
        _advance(d, t, fl.path)
        p0 = d  # the discs to predict afresh after this event (-1: none)
        p1 = -1
        entered = 0
        if code >= 0 and fl.stamp[code] != int(queue.event[d, NEXT_STAMP]):
            stats[ST_STALE] += 1  # stale: predict again
        elif code >= 0:
            p1 = _collision(d, code, t, fl, cells, queue, run, tables, rng, counters)
        elif code == EV_CELL:
            entered = _crossing(d, cells, queue, stats)
        elif code == EV_WALL:
            if run.outlets and _leaves(d, fl, queue, run, tables, counters):
                _remove(d, fl, cells, queue)
                fl.stamp[d] += 1
                p0 = -1
            else:
                _wall_hit(d, fl, queue, run, counters, rng)
        elif code == EV_REACT:
            newd = _first_order_event(d, n, t, fl, cells, state, run, tables, rng, counters)
            if newd >= 0:
                n += 1
                p1 = newd
        else:  # a disc with no event at all cannot be at the top below inf
            p0 = -1
            heap_set(queue.heap, d, INF)
        for q in range(2):  # the one place predictions are made in the loop (inlined)
            pd = p0 if q == 0 else p1
            if pd >= 0:
                _predict(pd, t, fl, cells, queue, run, entered if q == 0 else 0)
                stats[ST_PREDICTIONS] += 1
    return t, n, events, False


@kernel
def _events(n, state, fl, cells, queue, run, tables, rng, counters):
    """Process events in time order until the end of the run or its event bound
    (:func:`_event_loop`), growing the arrays when a fission finds them full. Returns
    ``(t, n, state, fl)``: the time reached (the first event not processed, at the bound),
    and the arrays (new ones if a fission found them full)."""
    events = np.int64(0)  # (not the literal 0: numba would compile _event_loop for it too)
    while True:
        t, n, events, grow = _event_loop(n, events, state, fl, cells, queue, run, tables, rng,
                                         counters)
        if not grow:
            return t, n, state, fl
        counters.stats[ST_RESTARTS] += 1
        state, fl, cells, queue = _grow(2 * fl.path.shape[0] + 16, state, fl, cells, queue)


@kernel
def _write_back(n, t, fl, state):
    """Every disc brought to time t, into the caller's arrays (in the caller's numbering)."""
    W = fl.path
    pos, vel = state.pos, state.vel
    for d in range(n):
        e = fl.perm[d]
        state.species[e] = fl.species[d]
        state.internal_energy[e] = fl.internal_energy[d]
        if fl.species[d] >= 0:
            dt = t - W[d, PT]
            pos[e, 0] = W[d, PX] + dt * W[d, PVX]
            pos[e, 1] = W[d, PY] + dt * W[d, PVY]
            vel[e, 0] = W[d, PVX]
            vel[e, 1] = W[d, PVY]
        else:
            vel[e, 0] = 0.0
            vel[e, 1] = 0.0


@kernel(optimise=True)  # (see kernels.jit.kernel: an env's step runs it 10 % faster)
def _simulate(state, n, n_steps, step_dt, bounds, tables, params, flags, rng, counters,
              cells_per_disc):
    """Advance discs [0, n) by ``n_steps`` steps of ``step_dt`` in one run, from time 0 to
    t1 = n_steps step_dt.

    Everything is derived from the state at the start of the run (positions, velocities,
    species, internal energies, the generator): the grid, the TC model's t_c, the retry
    floor, the event bound, and the reaction times, drawn afresh (exact: the exponential is
    memoryless). So the outcome does not depend on the arrays' capacity: a fission that
    finds them full grows them (and the working arrays) in place and carries on.

    Returns ``(state, n, t)``: the state (new arrays if they grew), holding the discs at t;
    t = t1 unless the run reached its event bound (``n_steps k (64 n + 1024)`` events, the
    time-stepped integrator's bound for n_steps steps of k substeps): then t is the time of
    the first event not processed, and the caller finishes the run otherwise.
    Discs consumed by combinations are left with species -1 (the caller compacts).
    Fragments are appended with the same index inside and out.
    """
    if n == 0:
        return state, 0, n_steps * step_dt
    run = _run_constants(n, n_steps, step_dt, state.vel, state.species, tables, params, flags,
                         bounds)
    cap = state.pos.shape[0]
    cells = _make_cells(n, cap, run, cells_per_disc)
    counters.stats[ST_CELLS] = cells.ncx * cells.ncy
    fl = _load(n, cap, state, cells, tables)
    queue = Queue(np.zeros((cap, EVENT_COLUMNS), dtype=FLOAT),
                  IndexedHeap(np.full(cap, INF, dtype=FLOAT), np.arange(cap).astype(INDEX),
                              np.arange(cap).astype(INDEX)))
    _first_predictions(n, fl, cells, queue, run, tables, rng, counters.stats)
    t, n, state, fl = _events(n, state, fl, cells, queue, run, tables, rng, counters)
    _write_back(n, t, fl, state)
    return state, n, t


@njit(cache=True, inline="always")
def run_exact(state, n, n_steps, dt, bounds, tables, params, flags, rng, counters,
              cells_per_disc):
    """The exact part of :func:`run_steps`: one event-driven run of ``n_steps`` steps of
    ``dt``, up to its event bound. Returns ``(state, n, rest)``: ``rest`` > 0 the time the
    run did not reach (it reached the bound), which :func:`finish_capped` finishes with the
    time-stepped integrator. Apart, so that an environment or a ``Simulation`` compiles that
    integrator only when a run first needs it (an env of the exact integrator otherwise
    never runs it)."""
    state, n, t = _simulate(state, n, n_steps, dt, bounds, tables, params, flags, rng,
                            counters, cells_per_disc)
    n = compact(n, state.pos, state.vel, state.species, state.internal_energy, state.ids)
    return state, n, n_steps * dt - t


@kernel
def finish_capped(state, n, n_steps, dt, rest, bounds, tables, params, flags, rng, cnt):
    """Finish a run of ``n_steps`` steps of ``dt`` whose exact part stopped ``rest`` before
    its end (:func:`run_exact`) with the time-stepped integrator (steps of ``dt``, the
    remainder in one shorter step), counted in ``events_capped``. ``cnt`` the time-stepped
    integrator's :class:`~discgym.kernels.structs.Counters` (the same arrays as the run's).
    Returns ``(state, n)``."""
    cnt.icnt[IC_EVENTS_CAPPED] += 1
    whole = min(int(rest / dt), n_steps)
    # int64, not literals, for n_steps, threads, step0 and reorder_every: the signature of
    # the batch's call (kernels.batch.reactor_step), so that numba compiles advance once
    zero = np.int64(0)
    one = np.int64(1)
    # (lists None: no pair list, as in a stepped env's step, whose advance this is; a rare
    # rescue, whose broad phase scans each substep)
    if whole > 0:
        state, n, _w = advance(state, n, whole, dt, bounds, tables, params, flags, rng, cnt,
                               one, zero, zero, empty_work(), lists=None)
    if rest - whole * dt > 0.0:
        state, n, _w = advance(state, n, one, rest - whole * dt, bounds, tables, params,
                               flags, rng, cnt, one, zero, zero, empty_work(), lists=None)
    return state, n


@njit(cache=True, inline="always")
def run_steps(state, n, n_steps, dt, bounds, tables, params, flags, rng, counters,
              cells_per_disc):
    """Advance ``n_steps`` steps of ``dt`` in one exact run (every disc brought to the end).

    ``state`` a :class:`~discgym.kernels.structs.Discs` (capacity C >= n; discs [0, n)),
    ``bounds`` a :class:`~discgym.kernels.structs.Bounds`, ``tables``, ``params``, ``flags``
    the compiled scene, ``counters`` a :class:`~discgym.kernels.event_structs.Counters`
    (accumulated in place), ``cells_per_disc`` how many grid cells per disc at most (cells
    are never narrower than the largest diameter; :data:`CELLS_PER_DISC` by default).
    Single-threaded. A run that reaches its event bound (see :func:`_simulate`) is finished
    from the time of the bound by the time-stepped integrator (steps of ``dt``; counted in
    ``events_capped``), whose own bounds hold.

    Returns ``(state, n)``: new (larger) arrays when decompositions needed more capacity,
    else the ones passed in. Discs consumed by combinations are removed (the order of the
    others is kept); fragments are appended, taking the identity ``state.next_id[0]``.

    :func:`run_exact` then :func:`finish_capped` in one compiled call (the ``Simulation``
    and the environments call the two apart).
    """
    state, n, rest = run_exact(state, n, n_steps, dt, bounds, tables, params, flags, rng,
                               counters, cells_per_disc)
    if rest > 0.0:
        state, n = finish_capped(state, n, n_steps, dt, rest, bounds, tables, params, flags,
                                 rng, StepCounters(counters.icnt, counters.fsum,
                                                   counters.ch_count, counters.outflow))
    return state, n


@njit(cache=True)
def run_steps_rngs(discs, n, n_steps, dt, bounds, tables, params, flags, rngs, cnt):
    """:func:`run_exact` called from Python (the structs as plain tuples of their fields, the
    generator as ``rngs[0]``: see :func:`discgym.kernels.step.advance_rngs`), with the
    counters of the time-stepped integrator (``cnt``: the fields of a
    :class:`~discgym.kernels.structs.Counters`; the statistics are dropped): the entry point
    of :class:`~discgym.Simulation`. Returns ``(discs, n, rest)``; ``rest`` > 0: the run
    reached its event bound, and :func:`finish_capped_rngs` finishes it."""
    icnt, fsum, ch_count, outflow = cnt
    stats = np.zeros(N_STATS, dtype=COUNT)
    d, n, rest = run_exact(Discs(*discs), n, n_steps, dt, Bounds(*bounds), Tables(*tables),
                           params, flags, rngs[0],
                           Counters(icnt, fsum, ch_count, stats, outflow), CELLS_PER_DISC)
    return fields(d), n, rest


@njit(cache=True)
def finish_capped_rngs(discs, n, n_steps, dt, rest, bounds, tables, params, flags, rngs, cnt):
    """:func:`finish_capped` called from Python, as :func:`run_steps_rngs`. Returns
    ``(discs, n)``."""
    d, n = finish_capped(Discs(*discs), n, n_steps, dt, rest, Bounds(*bounds),
                         Tables(*tables), params, flags, rngs[0], StepCounters(*cnt))
    return fields(d), n
