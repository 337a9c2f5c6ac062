"""The event phase of a substep by clusters of events (``kernels.step``, phase 2).

The serial event phase (``step._events``) pops one heap of the whole reactor in time order.
Most of its events have nothing to do with each other: a collision at one end of the box
cannot change what happens at the other end within a substep unless a chain of contacts
links them. Here the substep's initial events (its wall contacts and overlapping pairs) are
grouped by the cells they claim, each disc's cell and the cells within ``CLAIM`` cells of
it (in blocks of 2 x 2 cells), merged by union-find; each group (a *cluster*) is processed
alone, in its own time order, from its own small heap, clusters in memory order, and on
several threads the clusters of one chunk on one thread (:func:`events`).

Why the result is the serial phase's, bit for bit: a cluster reads the discs of the cells
it searches and changes only discs it found there, so when no two clusters search the same
cell, every disc sees the same events in the same (t, i, j) order as in the serial phase
(the events of the other clusters touch none of the discs it reads). A cluster whose search
would leave its cells stops, is undone (each disc back to its state at the start of the
phase) and is left to the repair: run alone after the others, it claims the free cells it
searches, and when it reaches a cell of another cluster both are undone and run again as
one. The search radius of a cluster is its own largest displacement (``rcell + delta``, as
the serial phase's is the largest so far of all discs); it finds every disc that can
overlap one of its discs, or else the other disc's search reaches into its cells. The
float sums of the substep (the wall momentum, the energy lost to restitution) are
recorded with their event's (t, i, j) and added in that order; the integer counts, the
largest displacement and speed do not depend on the order.

Only scenes whose events touch nothing but the two discs of an event take this path
(:func:`eligible`): box bounds (a disc gliding along a circle's wall reads the global
heap), no thermal walls, outlets or bimolecular reactions (they draw random numbers, add or
remove discs, and may cut a substep short at a global time), no big discs in the substep
(every search reads them all; checked by ``step.advance``). A substep whose clusters would
spend more than the event budget, or in which a collision would release internal energy
(which may end the substep at its time), runs the serial phase instead, from the same
start. ``step.advance`` takes this path on several threads from PARALLEL_MIN discs, and on
one thread above PAIR_MAX_DISCS discs, where its local order of events beats the global
one (below, on one thread, the serial phase is as fast or faster; docs/performance.md, "The
event phase by clusters").
"""

import math

import numpy as np
from numba import njit, prange

from .celllist import cell_range
from .collisions import bounce, normal_at
from .contacts import add_event, push_contacts, queue_scan, schedule_start
from .heap import new_heap, pop, push, reserve
from .jit import kernel
from .structs import (
    DISC_EVENTS,
    EVENTS_PER_DISC,
    FLOAT,
    FS_DISSIPATED,
    FS_WALL_MOMENTUM,
    IC_COLLISIONS,
    IC_LEFT_OVERLAPPING,
    IC_PUSHED_INSIDE,
    IC_TC_ELASTIC,
    IC_WALL_HITS,
    N_ICOUNTERS,
    VR_ROUNDOFF,
)
from .walls import contact, reflect, settle_after_reflection

CLAIM = 2  # cells a cluster claims around each disc of its initial events (each side)
# Cells are claimed in blocks of 2^OWN_SHIFT x 2^OWN_SHIFT (one owner entry each): a claim
# touches 2-3 cache lines instead of 5-6 rows of the finer array, which at 10^5 discs and
# more is out of the L2 cache (docs/performance.md, "The event phase by clusters")
OWN_SHIFT = 1
OWN_LIMIT = 2**31 - 1  # (owner entries are int32)
REC_SLACK = 1024  # records and log rows a chunk has room for beyond its events (more: repair)

# a run's outcome
R_OK, R_ESCAPE, R_CONFLICT, R_FULL, R_SERIAL = range(5)
# a cluster's status
C_PENDING, C_DONE, C_ESCAPED, C_MERGED = range(4)


@kernel
def eligible(rc, bounds_kind):
    """Can a scene's substeps (``rc``: its :class:`~.structs.RunConsts`) take this path?
    (The big discs are checked per substep.)"""
    return (rc.collide and not rc.has_bi and not rc.thermal and not rc.outlets
            and bounds_kind == 0)


@njit(cache=True, inline="always")
def _blocks(grid):
    """The owner blocks' grid: (columns, rows)."""
    m = (1 << OWN_SHIFT) - 1
    return (int(grid[4]) + m) >> OWN_SHIFT, (int(grid[5]) + m) >> OWN_SHIFT


@kernel
def new_owner(grid):
    """The owner of each block of cells for a call's substeps (:func:`events`): -1, none
    yet; the last entry is the base of the next substep's entries (0)."""
    nbx, nby = _blocks(grid)
    own = np.full(nbx * nby + 1, -1, dtype=np.int32)
    own[-1] = 0
    return own


@njit(cache=True, inline="always")
def _find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(cache=True, inline="always")
def _rows(k, nst, ncy):
    """The cell rows [r0, r1) of strip k of nst (whole rows of owner blocks)."""
    nby = (ncy + (1 << OWN_SHIFT) - 1) >> OWN_SHIFT
    return (min((k * nby // nst) << OWN_SHIFT, ncy),
            min(((k + 1) * nby // nst) << OWN_SHIFT, ncy))


@kernel
def _count(k, nst, sc, grid, qcnt):
    """How many events strip k may queue: the wall contacts of its discs and the overlaps
    of its sorted discs found by the scan (from the drift's and the scan's lists). Counts
    its discs the drift pushed inside (in ``qcnt[k]``)."""
    ncx = int(grid[4])
    ncy = int(grid[5])
    r0, r1 = _rows(k, nst, ncy)
    a0 = sc.cell_start[r0 * ncx]
    a1 = sc.cell_start[r1 * ncx]
    cell_of, wall_t, wflag, ov_n, wl, ol = sc.cell_of, sc.wall_t, sc.wflag, sc.ov_n, sc.wl, sc.ol
    need = 0
    pushed = 0
    for p in range(sc.nlist[0]):
        i = wl[p]
        if r0 <= cell_of[i] // ncx < r1:
            if wall_t[i] < math.inf:
                need += 1
            pushed += wflag[i]
    m = sc.nlist[1]
    for p in range(np.searchsorted(ol[:m], a0), m):
        a = ol[p]
        if a >= a1:
            break
        need += ov_n[a]
    qcnt[k, IC_PUSHED_INSIDE] += pushed
    return need


@kernel
def _fill(k, nst, E, off, sp_radius, pos, vel, species, sc, grid, qcnt):
    """Append strip k's initial events (those :func:`_count` counted that occur) to E from
    row ``off``, as ``step._queue_initial`` queues them; returns how many."""
    ncx = int(grid[4])
    r0, r1 = _rows(k, nst, int(grid[5]))
    cell_of, wall_t, stamp, wl = sc.cell_of, sc.wall_t, sc.stamp, sc.wl
    size = off
    for p in range(sc.nlist[0]):
        i = wl[p]
        if wall_t[i] < math.inf and r0 <= cell_of[i] // ncx < r1:
            size = add_event(E, size, False, wall_t[i], i, -1, stamp[i], 0)
    size = queue_scan(sc.cell_start[r0 * ncx], sc.cell_start[r1 * ncx], sp_radius, pos, vel,
                      species, sc, grid, E, size, qcnt[k], np.bool_(False))
    return size - off


@njit(cache=True, inline="always")
def _claim(own, cc, q, base, parent):
    """Event q claims owner block cc (``own``: ``base`` + the event of a block claimed in
    this substep; anything below ``base``: free): a free block becomes its, a block of
    another event joins the two in ``parent``."""
    o = own[cc] - base
    if o < 0:
        own[cc] = base + q
    elif o != q:
        _union(parent, q, o)


@kernel
def _claims(k, nst, q0, q1, E, cell_of, grid, own, base, parent, bnd, b0):
    """Strip k's claims for the events E[q0:q1]: the owner blocks of the cells within CLAIM
    of its discs' cells (one rectangle for both), those in the strip's rows in ``own``
    (:func:`_claim`), the others noted in ``bnd`` from row b0 (event, block) for the serial
    pass after. Returns how many were noted."""
    ncx = int(grid[4])
    ncy = int(grid[5])
    nbx = _blocks(grid)[0]
    r0, r1 = _rows(k, nst, ncy)
    nb = b0
    for q in range(q0, q1):
        c = cell_of[int(E[q, 1])]
        cx0 = cx1 = c % ncx
        cy0 = cy1 = c // ncx
        j = int(E[q, 2])
        if j >= 0:
            c = cell_of[j]
            cx0 = min(cx0, c % ncx)
            cx1 = max(cx1, c % ncx)
            cy0 = min(cy0, c // ncx)
            cy1 = max(cy1, c // ncx)
        bx0 = max(cx0 - CLAIM, 0) >> OWN_SHIFT
        bx1 = min(cx1 + CLAIM, ncx - 1) >> OWN_SHIFT
        for by in range(max(cy0 - CLAIM, 0) >> OWN_SHIFT,
                        (min(cy1 + CLAIM, ncy - 1) >> OWN_SHIFT) + 1):
            inside = r0 <= (by << OWN_SHIFT) < r1
            for bx in range(bx0, bx1 + 1):
                cc = bx + nbx * by
                if inside:
                    _claim(own, cc, q, base, parent)
                else:
                    bnd[nb, 0] = q
                    bnd[nb, 1] = cc
                    nb += 1
    return nb - b0


@njit(cache=True, inline="always")
def _union(parent, a, b):
    a = _find(parent, a)
    b = _find(parent, b)
    if a < b:
        parent[b] = a
    elif b < a:
        parent[a] = b


@kernel(parallel=True)
def _queue_parallel(nst, E, off, sp_radius, pos, vel, species, sc, grid, qcnt, got):
    for k in prange(nst):
        got[k] = _fill(k, nst, E, off[k], sp_radius, pos, vel, species, sc, grid, qcnt)


@kernel(parallel=True)
def _count_parallel(nst, sc, grid, qcnt, need):
    for k in prange(nst):
        need[k] = _count(k, nst, sc, grid, qcnt)


@kernel(parallel=True)
def _claims_parallel(nst, qs, E, cell_of, grid, own, base, parent, bnd, boff, nbs):
    for k in prange(nst):
        nbs[k] = _claims(k, nst, qs[k], qs[k + 1], E, cell_of, grid, own, base, parent, bnd,
                         boff[k])


@kernel
def _queue(sp_radius, pos, vel, species, sc, grid, icnt, nst):
    """The substep's initial events (``step._queue_initial``'s, in another order), found
    by nst strips of cell rows on numba's threads (one: on the calling thread) from the
    drift's and the scan's lists. Returns ``(E,
    qs)``: the events of strip k are E[qs[k]:qs[k + 1]] (those of its sorted discs: one disc
    of each in its rows, the other in them or in the row below)."""
    qcnt = np.zeros((nst, N_ICOUNTERS), dtype=np.int64)
    need = np.empty(nst, dtype=np.int64)
    if nst > 1:
        _count_parallel(nst, sc, grid, qcnt, need)
    else:
        need[0] = _count(0, 1, sc, grid, qcnt)
    off = np.zeros(nst + 1, dtype=np.int64)
    for k in range(nst):
        off[k + 1] = off[k] + need[k]
    E0 = np.empty((off[nst], 5), dtype=FLOAT)
    got = np.empty(nst, dtype=np.int64)
    if nst > 1:
        _queue_parallel(nst, E0, off, sp_radius, pos, vel, species, sc, grid, qcnt, got)
    else:
        got[0] = _fill(0, 1, E0, 0, sp_radius, pos, vel, species, sc, grid, qcnt)
    for k in range(nst):
        for q in range(N_ICOUNTERS):
            icnt[q] += qcnt[k, q]
    qs = np.zeros(nst + 1, dtype=np.int64)
    for k in range(nst):
        qs[k + 1] = qs[k] + got[k]
    E = np.empty((qs[nst], 5), dtype=FLOAT)
    for k in range(nst):
        E[qs[k]:qs[k + 1]] = E0[off[k]:off[k] + got[k]]
    return E, qs


@kernel
def _cluster(E, qs, nst, cell_of, grid, own, base):
    """Group the events E (strip k's: E[qs[k]:qs[k + 1]]) by the cells they claim, the
    strips in parallel, then across the strips' borders. Returns ``(ncl, ev_start, evs,
    ecl)``: cluster c's events are ``evs[ev_start[c]:ev_start[c + 1]]`` (rows of E), event
    q's cluster ``ecl[q]``; ``own`` holds ``base`` + an event of the cluster that claimed
    each claimed block of cells. Clusters are numbered in the order of the cell of the first disc of
    their lowest event (roughly memory order)."""
    size = E.shape[0]
    parent = np.arange(size)
    # room for the claims outside each strip: only its events near its edges (first disc
    # within CLAIM + 1 rows of the top, CLAIM + 2 of the bottom: the partner may be a row
    # below) have any, at most a whole claim each (4 x 4 blocks for two adjacent cells)
    ncx = int(grid[4])
    ncy = int(grid[5])
    boff = np.zeros(nst + 1, dtype=np.int64)
    for k in range(nst):
        r0, r1 = _rows(k, nst, ncy)
        near = 0
        for q in range(qs[k], qs[k + 1]):
            cy = cell_of[int(E[q, 1])] // ncx
            if cy < r0 + CLAIM + 1 or cy >= r1 - CLAIM - 2:
                near += 1
        boff[k + 1] = boff[k] + (((2 * CLAIM + 2) >> OWN_SHIFT) + 1) ** 2 * near
    bnd = np.empty((boff[nst], 2), dtype=np.int64)
    nbs = np.zeros(nst, dtype=np.int64)
    if nst > 1:
        _claims_parallel(nst, qs, E, cell_of, grid, own, base, parent, bnd, boff, nbs)
    else:
        nbs[0] = _claims(0, 1, qs[0], qs[1], E, cell_of, grid, own, base, parent, bnd, 0)
    for k in range(nst):  # the claims across the strips' borders
        for a in range(boff[k], boff[k] + nbs[k]):
            _claim(own, bnd[a, 1], bnd[a, 0], base, parent)
    # number the clusters by the cell of their root event's first disc (memory order)
    ncl = 0
    for q in range(size):
        parent[q] = _find(parent, q)
        if parent[q] == q:
            ncl += 1
    roots = np.empty(ncl, dtype=np.int64)
    key = np.empty(ncl, dtype=np.int64)
    k = 0
    for q in range(size):
        if parent[q] == q:
            roots[k] = q
            key[k] = cell_of[int(E[q, 1])]
            k += 1
    order = np.argsort(key)
    cid = np.empty(size, dtype=np.int64)
    for c in range(ncl):
        cid[roots[order[c]]] = c
    for q in range(size):
        cid[q] = cid[parent[q]]  # (parent[q] is q's root after the finds above)
    ev_start = np.zeros(ncl + 1, dtype=np.int64)
    for q in range(size):
        ev_start[cid[q] + 1] += 1
    for c in range(ncl):
        ev_start[c + 1] += ev_start[c]
    evs = np.empty(size, dtype=np.int64)
    fill = ev_start[:ncl].copy()
    for q in range(size):
        evs[fill[cid[q]]] = q
        fill[cid[q]] += 1
    return ncl, ev_start, evs, cid


@kernel
def _undo(lg, lo, hi, h, pos, vel, sc):
    """Put the discs logged in ``lg[lo:hi]`` back as they were at the start of the phase."""
    for r in range(lo, hi):
        k = int(lg[r, 0])
        pos[k, 0] = sc.binx[k]
        pos[k, 1] = sc.biny[k]
        vel[k, 0] = lg[r, 1]
        vel[k, 1] = lg[r, 2]
        sc.stamp[k] = int(lg[r, 3])
        sc.lastcol[k] = int(lg[r, 4])
        sc.tlast[k] = -h
        sc.partner[k] = -1
        sc.nev[k] = 0


@njit(cache=True, inline="always")
def _schedule(d, cid, dynamic, pos, vel, species, sp_radius, tlast, stamp, cell_start,
              cell_items, bounds_kind, bounds_params, grid, reach, own, base, ecl, rep, cparent,
              H, size, cicnt, crow):
    """``step._schedule`` for a cluster: first checks that every cell it searches is the
    cluster's (``own``: an event of the cluster of the cell's owner block, ``ecl``: the
    cluster of an event; ``dynamic``: a free block is claimed for the cluster's event
    ``rep``, a block of another cluster found by ``cparent``). Returns ``(code, other, H,
    size)``: code R_ESCAPE (a cell not its own, not ``dynamic``), R_CONFLICT (``other``:
    the cluster owning it) or R_OK."""
    r, x, y, vx, vy, td, t, pushed = schedule_start(d, pos, vel, species, sp_radius, tlast,
                                                    bounds_kind, bounds_params)
    if pushed:
        cicnt[crow, IC_PUSHED_INSIDE] += 1
    ncx = int(grid[4])
    nbx = _blocks(grid)[0]
    cx0, cx1, cy0, cy1 = cell_range(x, y, r + reach, grid)
    for by in range(cy0 >> OWN_SHIFT, (cy1 >> OWN_SHIFT) + 1):
        for bx in range(cx0 >> OWN_SHIFT, (cx1 >> OWN_SHIFT) + 1):
            c = bx + nbx * by
            o = own[c] - base
            if o >= 0 and ecl[o] == cid:
                continue
            if not dynamic:
                return R_ESCAPE, -1, H, size
            if o < 0:
                own[c] = base + rep
            else:
                g = _find(cparent, ecl[o])
                if g != cid:
                    return R_CONFLICT, g, H, size
    need = 1
    for cy in range(cy0, cy1 + 1):
        need += cell_start[cx1 + 1 + ncx * cy] - cell_start[cx0 + ncx * cy]
    H = reserve(H, size, need)
    if t < math.inf:
        size = push(H, size, max(t, td), d, -1, stamp[d], 0)
    size, left = push_contacts(d, x, y, vx, vy, r, td, cx0, cx1, cy0, cy1, ncx, pos, vel,
                               species, sp_radius, tlast, stamp, cell_start, cell_items, H, size)
    cicnt[crow, IC_LEFT_OVERLAPPING] += left
    return R_OK, -1, H, size


def _run_py(cid, dynamic, H, size, discs, tables, sc, bounds_kind, bounds_params, grid, rc,
            sub_id, own, base, ecl, rep, cparent, lg, nlog, cicnt, crow, rec, nrec, budget):
    """Process one cluster's heap ``H[0:size]`` in time order, as ``step._events`` does for
    the scenes of :func:`eligible`. Before its first event each disc is logged in ``lg``
    (rows from ``nlog``: disc, velocity, stamp, lastcol; what :func:`_undo` needs). Float
    terms go to ``rec`` rows (t, i, j, which sum, value) from ``nrec``; counts to
    ``cicnt[crow]``. Returns ``(code, other, H, nrec, nlog, events, delta, vfast,
    dropped)`` (``code``: R_OK, or why it stopped: see :func:`_schedule`; R_FULL: no room
    left in ``rec`` or ``lg``;
    R_SERIAL past ``budget`` events or at a release of internal energy, which the serial
    phase must handle). Compiled twice: inlined into the loop over a chunk's clusters
    (:func:`_chunk`: a call per cluster would reference-count its dozens of arrays) and as a
    function for the repair."""
    pos, vel, species, internal_energy = discs.pos, discs.vel, discs.species, discs.internal_energy
    sp_radius, sp_mass = tables.sp_radius, tables.sp_mass
    tlast, stamp, lastcol, partner, nev = sc.tlast, sc.stamp, sc.lastcol, sc.partner, sc.nev
    binx, biny, cell_start, cell_items = sc.binx, sc.biny, sc.cell_start, sc.cell_items
    e = rc.restitution
    kappa = rc.relax
    rcell = rc.rcell
    delta = 0.0
    vfast = 0.0
    events = 0
    dropped = False
    while size > 0:
        t, i, j, si, sj, size = pop(H, size)
        if stamp[i] != si or (j >= 0 and stamp[j] != sj):
            continue
        if nev[i] >= DISC_EVENTS or (j >= 0 and nev[j] >= DISC_EVENTS):
            dropped = True
            continue
        events += 1
        if events > budget:
            return R_SERIAL, -1, H, nrec, nlog, events, delta, vfast, dropped
        for w in range(1 if j < 0 else 2):  # log the discs of their first event
            d = i if w == 0 else j
            if nev[d] == 0:
                if nlog >= lg.shape[0]:
                    return R_FULL, -1, H, nrec, nlog, events, delta, vfast, dropped
                lg[nlog, 0] = d
                lg[nlog, 1] = vel[d, 0]
                lg[nlog, 2] = vel[d, 1]
                lg[nlog, 3] = stamp[d]
                lg[nlog, 4] = lastcol[d]
                nlog += 1
            nev[d] += 1
        if j < 0:
            r = sp_radius[species[i]]
            tw, axis, inward = contact(pos[i, 0], pos[i, 1], vel[i, 0], vel[i, 1], r,
                                       bounds_kind, bounds_params)
            if tw == math.inf:
                continue
            if nrec >= rec.shape[0]:
                return R_FULL, -1, H, nrec, nlog, events, delta, vfast, dropped
            tw = max(tw, tlast[i])
            dp = reflect(i, tw, axis, pos, vel, sp_mass[species[i]], bounds_kind, bounds_params)
            rec[nrec, 0] = t
            rec[nrec, 1] = i
            rec[nrec, 2] = -1
            rec[nrec, 3] = FS_WALL_MOMENTUM
            rec[nrec, 4] = dp
            nrec += 1
            cicnt[crow, IC_WALL_HITS] += 1
            partner[i] = -1
            tlast[i] = tw
            if settle_after_reflection(i, axis, pos, r, bounds_kind, bounds_params):
                cicnt[crow, IC_PUSHED_INSIDE] += 1
            stamp[i] += 1
            delta = max(delta, math.hypot(pos[i, 0] - binx[i], pos[i, 1] - biny[i]))
        else:
            vxi = vel[i, 0]
            vyi = vel[i, 1]
            vxj = vel[j, 0]
            vyj = vel[j, 1]
            xi, yi, xj, yj, nx, ny = normal_at(pos[i, 0], pos[i, 1], vxi, vyi, pos[j, 0],
                                               pos[j, 1], vxj, vyj, t)
            vr = (vxi - vxj) * nx + (vyi - vyj) * ny
            if vr <= VR_ROUNDOFF * (abs(vxi) + abs(vyi) + abs(vxj) + abs(vyj)):
                continue
            if partner[i] == j and partner[j] == i:
                continue
            if kappa > 0.0 and internal_energy[i] + internal_energy[j] > 0.0:
                # a release of internal energy may cut the substep short at its time: serial
                return R_SERIAL, -1, H, nrec, nlog, events, delta, vfast, dropped
            e_eff = e
            if e < 1.0:
                if lastcol[i] == sub_id or lastcol[j] == sub_id:
                    e_eff = 1.0
                    cicnt[crow, IC_TC_ELASTIC] += 1
                lastcol[i] = sub_id
                lastcol[j] = sub_id
            vxi, vyi, vxj, vyj, ui, uj, lost = bounce(vxi, vyi, vxj, vyj, sp_mass[species[i]],
                                                      sp_mass[species[j]], nx, ny, e_eff, kappa,
                                                      internal_energy[i], internal_energy[j])
            if e < 1.0:
                if nrec >= rec.shape[0]:
                    return R_FULL, -1, H, nrec, nlog, events, delta, vfast, dropped
                rec[nrec, 0] = t
                rec[nrec, 1] = i
                rec[nrec, 2] = j
                rec[nrec, 3] = FS_DISSIPATED
                rec[nrec, 4] = lost
                nrec += 1
            vel[i, 0] = vxi
            vel[i, 1] = vyi
            vel[j, 0] = vxj
            vel[j, 1] = vyj
            pos[i, 0] = xi - t * vxi
            pos[i, 1] = yi - t * vyi
            pos[j, 0] = xj - t * vxj
            pos[j, 1] = yj - t * vyj
            cicnt[crow, IC_COLLISIONS] += 1
            tlast[i] = t
            tlast[j] = t
            stamp[i] += 1
            stamp[j] += 1
            partner[i] = j
            partner[j] = i
            delta = max(delta, math.hypot(pos[i, 0] - binx[i], pos[i, 1] - biny[i]))
            delta = max(delta, math.hypot(pos[j, 0] - binx[j], pos[j, 1] - biny[j]))
            vfast = max(vfast, math.hypot(vxi, vyi), math.hypot(vxj, vyj))
        for w in range(1 if j < 0 else 2):  # the new contacts of i (and j)
            code, other, H, size = _schedule(
                i if w == 0 else j, cid, dynamic, pos, vel, species, sp_radius, tlast, stamp,
                cell_start, cell_items, bounds_kind, bounds_params, grid, rcell + delta, own,
                base, ecl, rep, cparent, H, size, cicnt, crow)
            if code != R_OK:
                return code, other, H, nrec, nlog, events, delta, vfast, dropped
    return R_OK, -1, H, nrec, nlog, events, delta, vfast, dropped


_run = kernel(_run_py)
_run_inline = njit(cache=True, inline="always")(_run_py)


@njit(cache=True, inline="always")
def _load(H, E, evs, lo, hi):
    """A heap of the events ``E[evs[lo:hi]]``; returns (H, size)."""
    H = reserve(H, 0, hi - lo)
    size = 0
    for a in range(lo, hi):
        q = evs[a]
        size = push(H, size, E[q, 0], int(E[q, 1]), int(E[q, 2]), int(E[q, 3]), int(E[q, 4]))
    return H, size


# the columns of a cluster's integer results (res): what it did and where its records and
# its log are (rows of the chunks' buffers, or of the repair's if X_REPAIRED is 1)
X_EVENTS, X_DROPPED, X_REC_LO, X_REC_HI, X_LOG_LO, X_LOG_HI, X_REPAIRED = range(7)


@kernel
def _chunk(c0, c1, E, ev_start, evs, ecl, discs, tables, sc, bounds_kind, bounds_params, grid,
           rc, sub_id, h, own, base, rec, rec0, lg, lg0, budget, status, res, resf, cicnt):
    """Clusters [c0, c1) in turn, on one thread; their records in ``rec`` and their logs in
    ``lg`` (this chunk's rows, the first of which are rows ``rec0`` and ``lg0`` of all the
    chunks'). A cluster that escapes its cells, or finds no room for its records or its log,
    is undone (C_ESCAPED); one past the budget or at a release of internal energy is undone
    and stops the chunk (``res[c, X_EVENTS]`` = -1)."""
    H = new_heap(256)
    cparent = np.empty(0, dtype=np.int64)
    nrec = 0
    nlog = 0
    pos, vel = discs.pos, discs.vel
    for c in range(c0, c1):
        H, size = _load(H, E, evs, ev_start[c], ev_start[c + 1])
        code, other, H, nrec1, nlog1, events, delta, vfast, dropped = _run_inline(
            c, False, H, size, discs, tables, sc, bounds_kind, bounds_params, grid, rc,
            sub_id, own, base, ecl, evs[ev_start[c]], cparent, lg, nlog, cicnt, c, rec, nrec,
            budget)
        if code != R_OK:
            _undo(lg, nlog, nlog1, h, pos, vel, sc)
            cicnt[c, :] = 0
            if code == R_SERIAL:
                res[c, X_EVENTS] = -1
                return
            status[c] = C_ESCAPED
            continue
        status[c] = C_DONE
        res[c, X_EVENTS] = events
        res[c, X_DROPPED] = 1 if dropped else 0
        res[c, X_REC_LO] = rec0 + nrec
        res[c, X_REC_HI] = rec0 + nrec1
        res[c, X_LOG_LO] = lg0 + nlog
        res[c, X_LOG_HI] = lg0 + nlog1
        resf[c, 0] = delta
        resf[c, 1] = vfast
        nrec = nrec1
        nlog = nlog1


@kernel(parallel=True)
def _chunks_parallel(nch, bounds_c, E, ev_start, evs, ecl, discs, tables, sc, bounds_kind,
                     bounds_params, grid, rc, sub_id, h, own, base, rec, rcap, lg, lcap, budget,
                     status, res, resf, cicnt):
    for k in prange(nch):
        _chunk(bounds_c[k], bounds_c[k + 1], E, ev_start, evs, ecl, discs, tables, sc,
               bounds_kind, bounds_params, grid, rc, sub_id, h, own, base,
               rec[k * rcap:(k + 1) * rcap], k * rcap,
               lg[k * lcap:(k + 1) * lcap], k * lcap, budget, status, res, resf, cicnt)


@kernel
def _undo_done(c, res, lg, lg2, h, pos, vel, sc):
    """Undo what cluster (or merged group) c did, from its log."""
    if res[c, X_REPAIRED]:
        _undo(lg2, res[c, X_LOG_LO], res[c, X_LOG_HI], h, pos, vel, sc)
    else:
        _undo(lg, res[c, X_LOG_LO], res[c, X_LOG_HI], h, pos, vel, sc)


@kernel
def _grown(a, used):
    b = np.empty((2 * a.shape[0], a.shape[1]), dtype=a.dtype)
    for i in range(used):  # (loops: numba's slice assignment compiles an error)
        for k in range(a.shape[1]):
            b[i, k] = a[i, k]
    return b


@kernel
def _repair(ncl, E, ev_start, evs, ecl, discs, tables, sc, bounds_kind, bounds_params, grid,
            rc, sub_id, h, own, base, lg, budget, status, res, resf, cicnt):
    """Run the escaped clusters one at a time, growing them into free cells and merging
    them with the clusters they reach (undone and run again as one). Returns ``(ok, rec2,
    lg2)``: ``ok`` False when a run went past the budget or reached a release of internal
    energy (it is undone); the records and logs of the repaired clusters (``res[c,
    X_REPAIRED]`` = 1)."""
    pos, vel = discs.pos, discs.vel
    cparent = np.arange(ncl)
    cnext = np.full(ncl, -1, dtype=np.int64)
    ctail = np.arange(ncl)
    rec2 = np.empty((256, 5), dtype=FLOAT)
    lg2 = np.empty((1024, 5), dtype=FLOAT)
    nrec = 0
    nlog = 0
    H = new_heap(256)
    for c0 in range(ncl):
        if status[c0] != C_ESCAPED:
            continue
        g = c0
        while True:
            # a heap of the initial events of every cluster merged into g
            need = 0
            c = g
            while c >= 0:
                need += ev_start[c + 1] - ev_start[c]
                c = cnext[c]
            H = reserve(H, 0, need)
            size = 0
            c = g
            while c >= 0:
                for a in range(ev_start[c], ev_start[c + 1]):
                    q = evs[a]
                    size = push(H, size, E[q, 0], int(E[q, 1]), int(E[q, 2]), int(E[q, 3]),
                                int(E[q, 4]))
                c = cnext[c]
            cicnt[g, :] = 0
            code, other, H, nrec1, nlog1, events, delta, vfast, dropped = _run(
                g, True, H, size, discs, tables, sc, bounds_kind, bounds_params, grid, rc,
                sub_id, own, base, ecl, evs[ev_start[g]], cparent, lg2, nlog, cicnt, g, rec2,
                nrec, budget)
            if code == R_OK:
                status[g] = C_DONE
                res[g, X_EVENTS] = events
                res[g, X_DROPPED] = 1 if dropped else 0
                res[g, X_REC_LO] = nrec
                res[g, X_REC_HI] = nrec1
                res[g, X_LOG_LO] = nlog
                res[g, X_LOG_HI] = nlog1
                res[g, X_REPAIRED] = 1
                resf[g, 0] = delta
                resf[g, 1] = vfast
                nrec = nrec1
                nlog = nlog1
                break
            _undo(lg2, nlog, nlog1, h, pos, vel, sc)
            cicnt[g, :] = 0
            if code == R_SERIAL:
                return False, rec2, lg2
            if code == R_FULL:  # room for more records and log, and again
                if nrec1 + 64 >= rec2.shape[0]:
                    rec2 = _grown(rec2, nrec)
                if nlog1 + 64 >= lg2.shape[0]:
                    lg2 = _grown(lg2, nlog)
                continue
            # R_CONFLICT: merge the cluster it reached into g (undone if it ran)
            if status[other] == C_DONE:
                _undo_done(other, res, lg, lg2, h, pos, vel, sc)
            cicnt[other, :] = 0
            lo = min(g, other)
            hi = max(g, other)
            cparent[hi] = lo
            cnext[ctail[lo]] = hi
            ctail[lo] = ctail[hi]
            status[hi] = C_MERGED
            g = lo
            status[g] = C_PENDING
    return True, rec2, lg2


@kernel
def events(n, H, tables, discs, sc, bounds, grid, cnt, rc, sub_id, h, vfast, own, threads):
    """The initial queue and the event phase of a substep (as ``step._queue_initial`` and
    ``step._events`` for the scenes of :func:`eligible`, after the scan: not the pair
    list), by clusters, in ``threads`` strips and chunks on numba's threads (one: all on
    the calling thread).
    ``own``: :func:`new_owner`; the blocks a substep claims hold its base (``own[-1]``, then
    raised past its events) + an event, so no block need be freed after.
    Returns ``(done, H, size, delta, dropped, vfast)``; ``done`` False (nothing changed but
    the queue's counts) when the clusters would spend more than the substep's event budget
    or reach a release of internal energy: the caller then runs the serial phase on the
    initial events, the heap ``H[0:size]``."""
    bounds_kind, bounds_params = bounds.kind, bounds.params
    pos, vel = discs.pos, discs.vel
    budget = EVENTS_PER_DISC * n + 1024  # (step._events')
    nst = max(threads, 1)
    E, qs = _queue(tables.sp_radius, pos, vel, discs.species, sc, grid, cnt.icnt, nst)
    size = E.shape[0]
    base = np.int64(own[-1])
    if base + size >= OWN_LIMIT:  # (rare: after about 2^31 events in one call)
        own[:] = -1
        base = 0
    own[-1] = base + size + 1
    ncl, ev_start, evs, ecl = _cluster(E, qs, nst, sc.cell_of, grid, own, base)
    status = np.full(ncl, C_PENDING, dtype=np.int64)
    res = np.zeros((ncl, 7), dtype=np.int64)
    resf = np.zeros((ncl, 2), dtype=FLOAT)
    cicnt = np.zeros((ncl, N_ICOUNTERS), dtype=np.int64)
    nch = max(min(nst, ncl), 1)
    # chunks of about equal numbers of events
    bounds_c = np.empty(nch + 1, dtype=np.int64)
    bounds_c[0] = 0
    c = 0
    for k in range(1, nch):
        while c < ncl and ev_start[c] < k * size // nch:
            c += 1
        bounds_c[k] = c
    bounds_c[nch] = ncl
    most = 0
    for k in range(nch):
        most = max(most, ev_start[bounds_c[k + 1]] - ev_start[bounds_c[k]])
    rcap = most + REC_SLACK
    lcap = 3 * most + REC_SLACK
    rec = np.empty((nch * rcap, 5), dtype=FLOAT)
    lg = np.empty((nch * lcap, 5), dtype=FLOAT)
    if nch > 1:
        _chunks_parallel(nch, bounds_c, E, ev_start, evs, ecl, discs, tables, sc, bounds_kind,
                         bounds_params, grid, rc, sub_id, h, own, base, rec, rcap, lg, lcap,
                         budget, status, res, resf, cicnt)
    else:
        _chunk(0, ncl, E, ev_start, evs, ecl, discs, tables, sc, bounds_kind, bounds_params,
               grid, rc, sub_id, h, own, base, rec, 0, lg, 0, budget, status, res, resf, cicnt)
    ok = True
    for c in range(ncl):
        if res[c, X_EVENTS] < 0:
            ok = False
    if ok:
        ok, rec2, lg2 = _repair(ncl, E, ev_start, evs, ecl, discs, tables, sc, bounds_kind,
                                bounds_params, grid, rc, sub_id, h, own, base, lg, budget,
                                status, res, resf, cicnt)
    else:
        rec2 = np.empty((0, 5), dtype=FLOAT)
        lg2 = np.empty((0, 5), dtype=FLOAT)
    total = 0
    nrec = 0
    for c in range(ncl):
        if status[c] == C_DONE:
            total += res[c, X_EVENTS]
            nrec += res[c, X_REC_HI] - res[c, X_REC_LO]
    if not ok or total > budget:  # the serial phase stops where the budget runs out
        for c in range(ncl):
            if status[c] == C_DONE:
                _undo_done(c, res, lg, lg2, h, pos, vel, sc)
        H = reserve(H, 0, size)  # the serial phase pops a heap
        m = 0
        for q in range(size):
            m = push(H, m, E[q, 0], int(E[q, 1]), int(E[q, 2]), int(E[q, 3]), int(E[q, 4]))
        return False, H, size, 0.0, False, vfast
    icnt, fsum = cnt.icnt, cnt.fsum
    delta = 0.0
    dropped = False
    R = np.empty((nrec, 5), dtype=FLOAT)
    k = 0
    for c in range(ncl):
        if status[c] != C_DONE:
            continue
        for q in range(N_ICOUNTERS):
            icnt[q] += cicnt[c, q]
        dropped = dropped or res[c, X_DROPPED] != 0
        delta = max(delta, resf[c, 0])
        vfast = max(vfast, resf[c, 1])
        src = rec2 if res[c, X_REPAIRED] else rec
        for a in range(res[c, X_REC_LO], res[c, X_REC_HI]):
            R[k] = src[a]
            k += 1
    _add_in_order(R, fsum)
    return True, H, size, delta, dropped, vfast


@kernel
def _add_in_order(R, fsum):
    """Add the recorded terms R (rows t, i, j, which sum, value) to ``fsum`` in the serial
    phase's order: by (t, i, j), terms of one event in the order recorded (a disc at a
    corner meets both walls at one t). Three stable sorts, the last key first."""
    m = R.shape[0]
    order = np.argsort(R[:, 2], kind="mergesort")
    order = order[np.argsort(R[order, 1], kind="mergesort")]
    order = order[np.argsort(R[order, 0], kind="mergesort")]
    for p in range(m):
        q = order[p]
        fsum[int(R[q, 3])] += R[q, 4]
