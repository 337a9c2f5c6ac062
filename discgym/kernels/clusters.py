"""The event phase of a substep by clusters of events (phase 3 of :mod:`.step`).

The serial event phase (:func:`.events.run_events` on the whole reactor) pops one heap of the
whole reactor in time order. Most of its events have nothing to do with each other: a
collision at one end of the box cannot change what happens at the other end within a substep
unless a chain of contacts links them. Here the substep's initial events (its wall contacts
and overlapping pairs) are grouped by the cells they claim, each disc's cell and the cells
within ``CLAIM`` cells of it (in blocks of 2 x 2 cells), merged by union-find; each group (a
*cluster*) is processed alone, in its own time order, from its own small heap, clusters in
memory order, and on several threads the clusters of one chunk on one thread
(:func:`events`).

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
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from .claims import (
    CLAIM,
    OWN_LIMIT,
    OWN_SHIFT,
    R_FULL,
    R_HEAP,
    R_OK,
    R_SERIAL,
    blocks,
    claim,
    find,
    new_owner,
)
from .contacts import add_event, queue_scan
from .events import run_cluster
from .heap import new_heap, push, reserve
from .jit import kernel
from .structs import FLOAT, IC_PUSHED_INSIDE, N_ICOUNTERS, ClusterRun, Phase

__all__ = ["ClusterRun", "eligible", "events", "new_owner"]

REC_SLACK = 1024  # records and log rows a chunk has room for beyond its events (more: repair)

# a cluster's status
C_PENDING, C_DONE, C_ESCAPED, C_MERGED = range(4)


class Groups(NamedTuple):
    """A substep's clusters (:func:`events`): their initial events and what their runs
    left."""

    E: np.ndarray  #: (m, 5) FLOAT the initial events (t, i, j, stamp i, stamp j)
    ev_start: np.ndarray  #: cluster c's events are evs[ev_start[c]:ev_start[c + 1]] (rows of E)
    evs: np.ndarray
    ecl: np.ndarray  #: event q's cluster
    own: np.ndarray  #: the owner blocks (kernels.claims)
    base: int  #: this substep's base in ``own``
    status: np.ndarray  #: (ncl,) C_PENDING, C_DONE, C_ESCAPED or C_MERGED
    res: np.ndarray  #: (ncl, 7) int64 what a cluster's run did (X_* columns)
    resf: np.ndarray  #: (ncl, 2) FLOAT its largest displacement and speed
    cicnt: np.ndarray  #: (ncl, N_ICOUNTERS) its integer counts


@kernel
def eligible(rc, bounds_kind):
    """Can a scene's substeps (``rc``: its :class:`~.structs.RunConsts`) take this path?
    (The big discs are checked per substep.)"""
    return (rc.collide and not rc.has_bi and not rc.thermal and not rc.outlets
            and bounds_kind == 0)


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
def _fill(k, nst, E, off, discs, sp_radius, sc, grid, qcnt):
    """Append strip k's initial events (those :func:`_count` counted that occur) to E from
    row ``off``, as ``events.queue_initial`` queues them; returns how many."""
    ncx = int(grid[4])
    r0, r1 = _rows(k, nst, int(grid[5]))
    cell_of, wall_t, stamp, wl = sc.cell_of, sc.wall_t, sc.stamp, sc.wl
    size = off
    for p in range(sc.nlist[0]):
        i = wl[p]
        if wall_t[i] < math.inf and r0 <= cell_of[i] // ncx < r1:
            size = add_event(E, size, False, wall_t[i], i, -1, stamp[i], 0)
    size = queue_scan(sc.cell_start[r0 * ncx], sc.cell_start[r1 * ncx], discs, sp_radius, sc,
                      grid, E, size, qcnt[k], np.bool_(False))
    return size - off


@kernel
def _claims(k, nst, q0, q1, E, cell_of, grid, own, base, parent, bnd, b0):
    """Strip k's claims for the events E[q0:q1]: the owner blocks of the cells within CLAIM
    of its discs' cells (one rectangle for both), those in the strip's rows in ``own``
    (:func:`_claim`), the others noted in ``bnd`` from row b0 (event, block) for the serial
    pass after. Returns how many were noted."""
    ncx = int(grid[4])
    ncy = int(grid[5])
    nbx = blocks(grid)[0]
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
                    claim(own, cc, q, base, parent)
                else:
                    bnd[nb, 0] = q
                    bnd[nb, 1] = cc
                    nb += 1
    return nb - b0


@kernel(parallel=True)
def _queue_parallel(nst, E, off, discs, sp_radius, sc, grid, qcnt, got):
    # (a parallel kernel takes structs of arrays, not a Phase: numba's parfors do not unpack
    # structs of structs)
    for k in prange(nst):
        got[k] = _fill(k, nst, E, off[k], discs, sp_radius, sc, grid, qcnt)


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
def _queue(ph, icnt, nst):
    """The substep's initial events (``events.queue_initial``'s, in another order), found
    by nst strips of cell rows on numba's threads (one: on the calling thread) from the
    drift's and the scan's lists. Returns ``(E,
    qs)``: the events of strip k are E[qs[k]:qs[k + 1]] (those of its sorted discs: one disc
    of each in its rows, the other in them or in the row below)."""
    sc, grid = ph.sc, ph.grid
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
        _queue_parallel(nst, E0, off, ph.discs, ph.tables.sp_radius, sc, grid, qcnt, got)
    else:
        got[0] = _fill(0, 1, E0, 0, ph.discs, ph.tables.sp_radius, sc, grid, qcnt)
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
            claim(own, bnd[a, 1], bnd[a, 0], base, parent)
    # number the clusters by the cell of their root event's first disc (memory order)
    ncl = 0
    for q in range(size):
        parent[q] = find(parent, q)
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


@njit(cache=True, inline="always")
def _done(status, res, resf, c, events, dropped, delta, vfast, fill0, fill, repaired):
    """Note what cluster c's run did (``status``, ``res``, ``resf``: the
    :class:`Clusters`'; ``fill0``, ``fill``: its first and its end rows of the log and of
    the records, ``(log, records)``; ``repaired``: in the repair's buffers)."""
    status[c] = C_DONE
    res[c, X_EVENTS] = events
    res[c, X_DROPPED] = 1 if dropped else 0
    res[c, X_REC_LO] = fill0[1]
    res[c, X_REC_HI] = fill[1]
    res[c, X_LOG_LO] = fill0[0]
    res[c, X_LOG_HI] = fill[0]
    res[c, X_REPAIRED] = repaired
    resf[c, 0] = delta
    resf[c, 1] = vfast


@kernel
def _chunk(c0, c1, n, ph, cnt, sub, g, rec, lg, row0):
    """Clusters [c0, c1) in turn, on one thread (``events.run_cluster``); their records in
    ``rec`` and their logs in ``lg`` (this chunk's rows, the first of which are rows ``row0``
    = (log, records) of all the chunks'). A cluster that escapes its cells, or finds no
    room for its records or its log, is undone (C_ESCAPED); one past the budget or at a
    release of internal energy is undone and stops the chunk (``res[c, X_EVENTS]`` = -1);
    one that fills the chunk's heap is undone and run again on a heap twice as large."""
    H = new_heap(256)
    fill = np.zeros(2, dtype=np.int64)
    # (the arrays read out of the structs once: a read per cluster would count references)
    E, evs, ev_start, cicnt = g.E, g.evs, g.ev_start, g.cicnt
    status, res, resf = g.status, g.res, g.resf
    pos, vel, sc = ph.discs.pos, ph.discs.vel, ph.sc
    cl = ClusterRun(-1, False, g.own, g.base, g.ecl, -1, np.empty(0, dtype=np.int64), lg, rec,
                    fill)
    for c in range(c0, c1):
        l0 = fill[0]
        r0 = fill[1]
        while True:
            H, size = _load(H, E, evs, ev_start[c], ev_start[c + 1])
            code, other, events, delta, dropped, vfast = run_cluster(
                H, size, n, ph, cnt, sub, cl, c, evs[ev_start[c]], cicnt)
            if code == R_OK:
                break
            _undo(lg, l0, fill[0], sub.h, pos, vel, sc)
            fill[0] = l0
            fill[1] = r0
            cicnt[c, :] = 0
            if code != R_HEAP:
                break
            H = reserve(H, 0, 2 * H.shape[0])
        if code == R_OK:
            _done(status, res, resf, c, events, dropped, delta, vfast,
                  (l0 + row0[0], r0 + row0[1]), (fill[0] + row0[0], fill[1] + row0[1]), 0)
        elif code == R_SERIAL:
            res[c, X_EVENTS] = -1
            return
        else:
            status[c] = C_ESCAPED


@kernel(parallel=True)
def _chunks_parallel(nch, n, discs, tables, bounds, grid, sc, rc, cnt, sub, g, bufs):
    """The chunks of clusters on numba's threads (``bufs``: the chunks' bounds, the
    capacities of a chunk's log and records, the logs and the records; the phase's structs
    apart, as in :func:`_queue_parallel`)."""
    for k in prange(nch):
        _chunk_k(k, n, discs, tables, bounds, grid, sc, rc, cnt, sub, g, bufs)


@kernel
def _chunk_k(k, n, discs, tables, bounds, grid, sc, rc, cnt, sub, g, bufs):
    """Chunk k of :func:`_chunks_parallel` (``bufs``: its chunks, capacities, records and
    logs), its phase put together again."""
    bounds_c, caps, rec, lg = bufs
    _chunk(bounds_c[k], bounds_c[k + 1], n, Phase(discs, tables, bounds, grid, sc, rc), cnt,
           sub, g, rec[k * caps[1]:(k + 1) * caps[1]], lg[k * caps[0]:(k + 1) * caps[0]],
           (k * caps[0], k * caps[1]))


@kernel
def _undo_done(c, g, lg, lg2, h, pos, vel, sc):
    """Undo what cluster (or merged group) c did, from its log."""
    if g.res[c, X_REPAIRED]:
        _undo(lg2, g.res[c, X_LOG_LO], g.res[c, X_LOG_HI], h, pos, vel, sc)
    else:
        _undo(lg, g.res[c, X_LOG_LO], g.res[c, X_LOG_HI], h, pos, vel, sc)


@kernel
def _grown(a, used):
    b = np.empty((2 * a.shape[0], a.shape[1]), dtype=a.dtype)
    for i in range(used):  # (loops: numba's slice assignment compiles an error)
        for k in range(a.shape[1]):
            b[i, k] = a[i, k]
    return b


@kernel
def _merged_heap(H, g, gid, cnext):
    """A heap of the initial events of every cluster merged into ``gid``; returns (H,
    size)."""
    need = 0
    c = gid
    while c >= 0:
        need += g.ev_start[c + 1] - g.ev_start[c]
        c = cnext[c]
    H = reserve(H, 0, need)
    size = 0
    c = gid
    while c >= 0:
        for a in range(g.ev_start[c], g.ev_start[c + 1]):
            q = g.evs[a]
            E = g.E
            size = push(H, size, E[q, 0], int(E[q, 1]), int(E[q, 2]), int(E[q, 3]),
                        int(E[q, 4]))
        c = cnext[c]
    return H, size


@kernel
def _repair(ncl, n, ph, cnt, sub, g, lg):
    """Run the escaped clusters one at a time, growing them into free cells and merging
    them with the clusters they reach (undone and run again as one). Returns ``(ok, rec2,
    lg2)``: ``ok`` False when a run went past the budget or reached a release of internal
    energy (it is undone); the records and logs of the repaired clusters (``res[c,
    X_REPAIRED]`` = 1)."""
    pos, vel = ph.discs.pos, ph.discs.vel
    cparent = np.arange(ncl)
    cnext = np.full(ncl, -1, dtype=np.int64)
    ctail = np.arange(ncl)
    rec2 = np.empty((256, 5), dtype=FLOAT)
    lg2 = np.empty((1024, 5), dtype=FLOAT)
    fill = np.zeros(2, dtype=np.int64)
    H = new_heap(256)
    for c0 in range(ncl):
        if g.status[c0] != C_ESCAPED:
            continue
        gid = c0
        while True:
            H, size = _merged_heap(H, g, gid, cnext)
            g.cicnt[gid, :] = 0
            l0 = fill[0]
            r0 = fill[1]
            cl = ClusterRun(gid, True, g.own, g.base, g.ecl, -1, cparent, lg2, rec2, fill)
            code, other, events, delta, dropped, vfast = run_cluster(
                H, size, n, ph, cnt, sub, cl, gid, g.evs[g.ev_start[gid]], g.cicnt)
            if code == R_OK:
                _done(g.status, g.res, g.resf, gid, events, dropped, delta, vfast, (l0, r0),
                      (fill[0], fill[1]), 1)
                break
            l1 = fill[0]
            r1 = fill[1]
            _undo(lg2, l0, l1, sub.h, pos, vel, ph.sc)
            fill[0] = l0
            fill[1] = r0
            g.cicnt[gid, :] = 0
            if code == R_SERIAL:
                return False, rec2, lg2
            if code == R_HEAP:  # a larger heap, and again
                H = reserve(H, 0, 2 * H.shape[0])
                continue
            if code == R_FULL:  # room for more records and log, and again
                if r1 + 64 >= rec2.shape[0]:
                    rec2 = _grown(rec2, r0)
                if l1 + 64 >= lg2.shape[0]:
                    lg2 = _grown(lg2, l0)
                continue
            # R_CONFLICT: merge the cluster it reached into gid (undone if it ran)
            if g.status[other] == C_DONE:
                _undo_done(other, g, lg, lg2, sub.h, pos, vel, ph.sc)
            g.cicnt[other, :] = 0
            lo = min(gid, other)
            hi = max(gid, other)
            cparent[hi] = lo
            cnext[ctail[lo]] = hi
            ctail[lo] = ctail[hi]
            g.status[hi] = C_MERGED
            gid = lo
            g.status[gid] = C_PENDING
    return True, rec2, lg2


@kernel
def _chunked(g, ncl, nst, size):
    """Chunks of about equal numbers of events: chunk k runs clusters [b[k], b[k + 1]).
    Returns ``(b, most)``, most the largest number of initial events of a chunk."""
    nch = max(min(nst, ncl), 1)
    b = np.empty(nch + 1, dtype=np.int64)
    b[0] = 0
    c = 0
    for k in range(1, nch):
        while c < ncl and g.ev_start[c] < k * size // nch:
            c += 1
        b[k] = c
    b[nch] = ncl
    most = 0
    for k in range(nch):
        most = max(most, g.ev_start[b[k + 1]] - g.ev_start[b[k]])
    return b, most


@kernel
def events(n, H, ph, cnt, sub, vfast, own, threads):
    """The initial queue and the event phase of a substep (as ``events.queue_initial`` and
    ``events.run_events`` for the scenes of :func:`eligible`, after the scan: not the pair
    list), by clusters, in ``threads`` strips and chunks on numba's threads (one: all on
    the calling thread).
    ``own``: :func:`~.claims.new_owner`; the blocks a substep claims hold its base
    (``own[-1]``, then raised past its events) + an event, so no block need be freed after.
    Returns ``(done, H, size, delta, dropped, vfast)``; ``done`` False (nothing changed but
    the queue's counts) when the clusters would spend more than the substep's event budget
    or reach a release of internal energy: the caller then runs the serial phase on the
    initial events, the heap ``H[0:size]``."""
    pos, vel = ph.discs.pos, ph.discs.vel
    nst = max(threads, 1)
    E, qs = _queue(ph, cnt.icnt, nst)
    size = E.shape[0]
    base = np.int64(own[-1])
    if base + size >= OWN_LIMIT:  # (rare: after about 2^31 events in one call)
        own[:] = -1
        base = 0
    own[-1] = base + size + 1
    ncl, ev_start, evs, ecl = _cluster(E, qs, nst, ph.sc.cell_of, ph.grid, own, base)
    g = Groups(E, ev_start, evs, ecl, own, base, np.full(ncl, C_PENDING, dtype=np.int64),
               np.zeros((ncl, 7), dtype=np.int64), np.zeros((ncl, 2), dtype=FLOAT),
               np.zeros((ncl, N_ICOUNTERS), dtype=np.int64))
    bounds_c, most = _chunked(g, ncl, nst, size)
    nch = bounds_c.shape[0] - 1
    caps = np.array([3 * most + REC_SLACK, most + REC_SLACK], dtype=np.int64)
    rec = np.empty((nch * caps[1], 5), dtype=FLOAT)
    lg = np.empty((nch * caps[0], 5), dtype=FLOAT)
    if nch > 1:
        _chunks_parallel(nch, n, ph.discs, ph.tables, ph.bounds, ph.grid, ph.sc, ph.rc, cnt, sub,
                         g, (bounds_c, caps, rec, lg))
    else:
        _chunk(0, ncl, n, ph, cnt, sub, g, rec, lg, (np.int64(0), np.int64(0)))
    ok = True
    for c in range(ncl):
        if g.res[c, X_EVENTS] < 0:
            ok = False
    if ok:
        ok, rec2, lg2 = _repair(ncl, n, ph, cnt, sub, g, lg)
    else:
        rec2 = np.empty((0, 5), dtype=FLOAT)
        lg2 = np.empty((0, 5), dtype=FLOAT)
    total = 0
    nrec = 0
    for c in range(ncl):
        if g.status[c] == C_DONE:
            total += g.res[c, X_EVENTS]
            nrec += g.res[c, X_REC_HI] - g.res[c, X_REC_LO]
    if not ok or total > sub.budget:  # the serial phase stops where the budget runs out
        for c in range(ncl):
            if g.status[c] == C_DONE:
                _undo_done(c, g, lg, lg2, sub.h, pos, vel, ph.sc)
        H = reserve(H, 0, size)  # the serial phase pops a heap
        m = 0
        for q in range(size):
            m = push(H, m, E[q, 0], int(E[q, 1]), int(E[q, 2]), int(E[q, 3]), int(E[q, 4]))
        return False, H, size, 0.0, False, vfast
    delta, dropped, vfast = _gather(g, ncl, nrec, rec, rec2, cnt, vfast)
    return True, H, size, delta, dropped, vfast


@kernel
def _gather(g, ncl, nrec, rec, rec2, cnt, vfast):
    """The clusters' counts into ``cnt``, their float terms added in the serial order;
    returns ``(delta, dropped, vfast)`` of them all."""
    icnt = cnt.icnt
    delta = 0.0
    dropped = False
    R = np.empty((nrec, 5), dtype=FLOAT)
    k = 0
    for c in range(ncl):
        if g.status[c] != C_DONE:
            continue
        for q in range(N_ICOUNTERS):
            icnt[q] += g.cicnt[c, q]
        dropped = dropped or g.res[c, X_DROPPED] != 0
        delta = max(delta, g.resf[c, 0])
        vfast = max(vfast, g.resf[c, 1])
        src = rec2 if g.res[c, X_REPAIRED] else rec
        for a in range(g.res[c, X_REC_LO], g.res[c, X_REC_HI]):
            R[k] = src[a]
            k += 1
    _add_in_order(R, cnt.fsum)
    return delta, dropped, vfast


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
