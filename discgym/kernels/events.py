"""The event phase of a stepped substep (phase 3 of :mod:`.step`): its contacts queued, then
processed earliest first by one loop, :func:`run_events`, which serves both the serial phase
(the whole reactor's heap) and the phase by clusters (a cluster's heap, :mod:`.clusters`).

Each event rewinds its discs to the event's time t in [-h, 0], responds (a reflection, a
bounce, a reactive collision), and winds them forward by -t; a disc's later contacts are
predicted from its new trajectory (:func:`schedule`) and may not precede its previous
contact, so a disc may collide many times per substep, in order. The tests of a popped event
and the TC model are the rules of :mod:`.rules`.

Energy released inside the substep: ``vrel`` is the largest speed a reactive collision, a
collision releasing internal energy (``kappa``) or a thermal wall left a disc with (0 if
none). When such a disc would move more than ``maxdisp`` in what is left of the substep
(-t), and -t > ``cut_after`` (inf: no cut), processing stops at that contact: ``t_cut`` = t
(else 0), every disc has its latest event at or before t and the caller ends the substep
there (:func:`rewind`). Queued later events are dropped; they lie after the new end and are
found again by the next substep. A disc glided past t (:func:`glide` jumps ahead in time)
could not be rewound: no cut is made while one has (``t_glide``).

A disc is within ``delta + h * vfast`` of where it was binned at any time of the substep
(``vfast`` is raised whenever a collision makes a disc faster), which is the reach of the
room checks made at a contact time.

Inelastic collapse (e < 1): a disc's second and later collisions within one substep are
elastic (the TC model, with t_c = the substep; ``lastcol`` holds the substep of each disc's
last collision). Without it a cluster at e = 0 takes unbounded numbers of ever smaller
collisions. A wall reflection that would leave a disc outside along the reflected axis (a
disc as wide as the bounds) is followed by moving it inside along that axis.

Work bound: events past a disc's DISC_EVENTS or the substep's budget are dropped and the
caller repairs the state (:func:`~discgym.kernels.resolve.resolve`).

**A cluster's run** (``cl``: :class:`~discgym.kernels.clusters.ClusterRun`; None for the
serial phase, whose code numba compiles without any of this): before its first event a disc
is logged (to undo the cluster), the float terms are recorded with their event's (t, i, j)
instead of added (they are added later in the serial order), a disc's search for contacts
first checks that its cells are the cluster's (:func:`~discgym.kernels.claims.check_cells`),
and the run stops (``code``) where the cluster must be undone or left to the serial phase.
"""

import math

import numpy as np
from numba import njit, types
from numba.extending import overload

from .celllist import cell_range, overlaps_any
from .claims import R_FULL, R_HEAP, R_OK, R_SERIAL, check_cells
from .collisions import bounce, normal_at, pair_time
from .contacts import queue_scan, try_pair
from .heap import pop, push, reserve
from .jit import kernel
from .reactions import COMBINATION, FIRED, NO_ROOM, Contact, combine, exchange
from .rules import (
    book_outflow,
    book_thermal,
    grazing,
    out_of_events,
    rebound,
    stale,
    tc_restitution,
)
from .structs import (
    DISC_EVENTS,
    FS_DISSIPATED,
    FS_WALL_MOMENTUM,
    IC_COLLISIONS,
    IC_GLIDES,
    IC_LEFT_OVERLAPPING,
    IC_NO_ROOM,
    IC_PUSHED_INSIDE,
    IC_REACTIVE,
    IC_WALL_HITS,
    ClusterRun,
    Counters,
    Marks,
    Search,
)
from .walls import (
    GLIDE_CHORDS,
    circle_chord,
    circle_glide,
    contact,
    on_outlet,
    push_inside,
    reflect,
    settle_after_reflection,
    side_of,
    thermal_velocity,
)

# What a wall event did (wall_event)
W_NONE, W_REFLECTED, W_THERMAL, W_LEFT = range(4)
# What a pair event did (collide_pair)
P_SKIPPED, P_BOUNCED, P_RELEASED, P_SERIAL = range(4)


# ------------------------------------------------------------------------- the initial queue
@kernel
def queue_initial(n, ph, H, icnt, pl, listed):
    """Queue every wall contact and every overlapping pair of the substep (``ph``: the
    :class:`~.structs.Phase`): the pairs the broad phase found (``ph.sc.ov_n``, ``ov_b``:
    small discs; by sorted position from the scan, half stencil, or by disc from the pair
    list ``pl`` if ``listed``; ``pl`` None: no pair lists, pruned by numba) and those of the
    big discs (found here: each big disc against the cells within its radius + rcell and
    the big discs after it). Returns ``(H, size)``."""
    discs, sp_radius, sc, grid = ph.discs, ph.tables.sp_radius, ph.sc, ph.grid
    collide = ph.rc.collide
    wall_t, wflag, stamp, tlast = sc.wall_t, sc.wflag, sc.stamp, sc.tlast
    cell_start, cell_items = sc.cell_start, sc.cell_items
    sx, sy, sr, ov_n, wl, ol = sc.sx, sc.sy, sc.sr, sc.ov_n, sc.wl, sc.ol
    ncx = int(grid[4])
    rcell = grid[6]
    nbc = ncx * int(grid[5])
    # the drift's and the scan's lists (contacts), in the order of the discs (of the sorted
    # discs) as a pass over all of them would take them
    nw = sc.nlist[0]
    need = 0
    for p in range(nw):
        i = wl[p]
        if wall_t[i] < math.inf:
            need += 1
        icnt[IC_PUSHED_INSIDE] += wflag[i]
    if collide:
        scanned = True
        if pl is not None:  # (pruned by numba when None: advance's lists)
            if listed:
                need += pl.count[1]
                scanned = False
        if scanned:
            for p in range(sc.nlist[1]):
                need += ov_n[ol[p]]
        for a in range(cell_start[nbc], cell_start[nbc + 1]):
            need += _big_candidates(a, sx, sy, sr, grid, cell_start)
    H = reserve(H, 0, need)
    size = np.int64(0)  # (not a literal: see queue_scan's call)
    for p in range(nw):
        i = wl[p]
        if wall_t[i] < math.inf:
            size = push(H, size, wall_t[i], i, -1, stamp[i], 0)
    if not collide:
        return H, size
    scanned = True
    if pl is not None:
        if listed:
            ovi, ovj = pl.ovi, pl.ovj
            for q in range(pl.count[1]):
                size = try_pair(ovi[q], ovj[q], discs, sp_radius, tlast, stamp, H, size, icnt)
            scanned = False
    if scanned:
        # (an int32 and a bool, not literals: the types of kernels.clusters' call, so that
        # numba compiles queue_scan once)
        size = queue_scan(np.int32(0), cell_start[nbc], discs, sp_radius, sc, grid, H, size,
                          icnt, np.bool_(True))
    for a in range(cell_start[nbc], cell_start[nbc + 1]):  # the big discs
        i = cell_items[a]
        cx0, cx1, cy0, cy1 = cell_range(sx[a], sy[a], sr[a] + rcell, grid)
        for cy in range(cy0, cy1 + 1):
            for b in range(cell_start[cx0 + ncx * cy], cell_start[cx1 + 1 + ncx * cy]):
                size = try_pair(i, cell_items[b], discs, sp_radius, tlast, stamp, H, size, icnt)
        for b in range(a + 1, cell_start[nbc + 1]):
            size = try_pair(i, cell_items[b], discs, sp_radius, tlast, stamp, H, size, icnt)
    return H, size


@kernel
def _big_candidates(a, sx, sy, sr, grid, cell_start):
    """How many discs big disc a (sorted index) is compared with in :func:`queue_initial`."""
    ncx = int(grid[4])
    nbc = ncx * int(grid[5])
    cx0, cx1, cy0, cy1 = cell_range(sx[a], sy[a], sr[a] + grid[6], grid)
    k = cell_start[nbc + 1] - a - 1
    for cy in range(cy0, cy1 + 1):
        k += cell_start[cx1 + 1 + ncx * cy] - cell_start[cx0 + ncx * cy]
    return k


# ------------------------------------------------------------------------ a disc's contacts
@njit(cache=True, inline="always")
def schedule(d, discs, sp_radius, bounds, tlast, stamp, search, H, size, icnt, cl):
    """Queue the next contacts of disc d (of ``discs``): a wall, and every disc in the cells
    within ``search.reach`` + its radius (discs [0, nbin) binned, [nbin, n) made since and
    tried one by one, as are the big discs). A disc overlapping a wall while moving inward is
    moved inside first. Room is reserved first (one wall event plus every disc searched), so
    the loops never reallocate the heap.

    For a cluster (``cl``) the cells searched must be the cluster's (or claimed for it), and
    its heap is never grown (:func:`run_cluster` allocates nothing): returns ``(code, other,
    H, size)``, code R_ESCAPE or R_CONFLICT (``other``: the cluster reached) or R_HEAP (no
    room in the heap) before anything is queued, else R_OK. (Two kernels that allocate
    nothing, so count no references, around the one step that may, the heap's growth; they
    take the arrays they read, not the Phase: a call passes every array of its structs.)"""
    code, other, need, t = _search_room(d, discs, sp_radius, bounds, search, icnt, cl)
    if code != R_OK:
        return code, other, H, size
    room, H = room_for(H, size, need, cl)
    if not room:
        return R_HEAP, -1, H, size
    return R_OK, -1, H, _queue_next(d, t, discs, sp_radius, tlast, stamp, search, H, size, icnt)


def room_for(H, size, need, cl):
    """``(room, H)``: whether the heap ``H[0:size]`` has room for ``need`` more events, and
    the heap. The serial phase's (``cl`` None) grows it; a cluster's is never grown (its
    run allocates nothing), so the branch is chosen by type, where numba compiles it."""
    if cl is None:
        return True, reserve(H, size, need)
    return size + need <= H.shape[0], H


@overload(room_for, inline="always")
def _room_for_typed(H, size, need, cl):
    # (numba does not prune an inlined function's `cl is None` by the type of cl: a cluster's
    # run would still type reserve's allocation, which a kernel without NRT cannot)
    if isinstance(cl, types.NoneType):
        return lambda H, size, need, cl: (True, reserve(H, size, need))
    return lambda H, size, need, cl: (size + need <= H.shape[0], H)


@kernel(_nrt=False, inline_code=True)
def _search_room(d, discs, sp_radius, bounds, search, icnt, cl):
    """:func:`schedule`'s first half: disc d's wall contact time t (d moved inside first if
    it overlaps a wall moving inward), the cluster's check of the cells searched, and the
    room its contacts need. Returns ``(code, other, need, t)``."""
    pos, vel, species = discs.pos, discs.vel, discs.species
    grid, cell_start = search.grid, search.cell_start
    r = sp_radius[species[d]]
    t, axis, inward = contact(pos[d, 0], pos[d, 1], vel[d, 0], vel[d, 1], r, bounds.kind,
                              bounds.params)
    if inward and t == math.inf:
        push_inside(d, pos, r, bounds.kind, bounds.params)
        icnt[IC_PUSHED_INSIDE] += 1
    ncx = int(grid[4])
    nbc = ncx * int(grid[5])
    cx0, cx1, cy0, cy1 = cell_range(pos[d, 0], pos[d, 1], r + search.reach, grid)
    if cl is not None:
        code, other = check_cells(cx0, cx1, cy0, cy1, grid, cl)
        if code != R_OK:
            return code, other, np.int64(0), t
    need = 1 + search.n - search.nbin
    if search.collide:
        need += cell_start[nbc + 1] - cell_start[nbc]
        for cy in range(cy0, cy1 + 1):
            need += cell_start[cx1 + 1 + ncx * cy] - cell_start[cx0 + ncx * cy]
    return R_OK, -1, np.int64(need), t


@kernel(_nrt=False, inline_code=True)
def _queue_next(d, t, discs, sp_radius, tlast, stamp, search, H, size, icnt):
    """:func:`schedule`'s second half, the room reserved: queue disc d's wall contact (at
    ``t``) and its contacts with the discs searched. Returns the heap's new size."""
    pos, vel, species = discs.pos, discs.vel, discs.species
    grid, cell_start, cell_items = search.grid, search.cell_start, search.cell_items
    r = sp_radius[species[d]]
    vx = vel[d, 0]
    vy = vel[d, 1]
    x = pos[d, 0]
    y = pos[d, 1]
    td = tlast[d]
    ncx = int(grid[4])
    nbc = ncx * int(grid[5])
    cx0, cx1, cy0, cy1 = cell_range(x, y, r + search.reach, grid)
    if t < math.inf:
        size = push(H, size, max(t, td), d, -1, stamp[d], 0)
    if not search.collide:
        return size
    sd = stamp[d]
    left = 0
    for cy in range(cy0, cy1 + 1):
        for a in range(cell_start[cx0 + ncx * cy], cell_start[cx1 + 1 + ncx * cy]):
            k = cell_items[a]
            if k == d or species[k] < 0:
                continue
            tc = pair_time(x, y, vx, vy, r, td, pos[k, 0], pos[k, 1], vel[k, 0], vel[k, 1],
                           sp_radius[species[k]], tlast[k])
            if tc == math.inf:
                left += 1
            elif not math.isnan(tc):
                if d < k:
                    size = push(H, size, tc, d, k, sd, stamp[k])
                else:
                    size = push(H, size, tc, k, d, stamp[k], sd)
    icnt[IC_LEFT_OVERLAPPING] += left
    for a in range(cell_start[nbc], cell_start[nbc + 1]):  # the big discs (celllist)
        k = cell_items[a]
        if k != d and species[k] >= 0:
            size = try_pair(d, k, discs, sp_radius, tlast, stamp, H, size, icnt)
    for k in range(search.nbin, search.n):
        if k != d and species[k] >= 0:
            size = try_pair(d, k, discs, sp_radius, tlast, stamp, H, size, icnt)
    return size


# --------------------------------------------------------------------------- the event loop
@njit(cache=True, inline="always")
def book(fsum, cl, which, value, t, i, j):
    """Add ``value`` to the float sum ``which``, or for a cluster record it with its event
    (t, i, j), to be added in the serial phase's order (``clusters.add_in_order``)."""
    if cl is None:
        fsum[which] += value
    else:
        r = cl.fill[1]
        cl.rec[r, 0] = t
        cl.rec[r, 1] = i
        cl.rec[r, 2] = j
        cl.rec[r, 3] = which
        cl.rec[r, 4] = value
        cl.fill[1] = r + 1


@njit(cache=True, inline="always")
def _log_first(i, j, sc, vel, cl):
    """A cluster's log of discs i (and j >= 0) before their first event of the substep: what
    undoing the cluster needs (disc, velocity, stamp, lastcol). False, nothing done, when the
    log or the records have no room left for an event."""
    lg, nlog = cl.lg, cl.fill[0]
    if nlog + 2 > lg.shape[0] or cl.fill[1] + 1 > cl.rec.shape[0]:
        return False
    for w in range(1 if j < 0 else 2):
        d = i if w == 0 else j
        if sc.nev[d] == 0:
            lg[nlog, 0] = d
            lg[nlog, 1] = vel[d, 0]
            lg[nlog, 2] = vel[d, 1]
            lg[nlog, 3] = sc.stamp[d]
            lg[nlog, 4] = sc.lastcol[d]
            nlog += 1
    cl.fill[0] = nlog
    return True


def run_events_py(H, size, n, ph, cnt, sub, vfast, rng, cl):
    """Process the heap ``H[0:size]`` earliest first (module docstring; ``ph``: the
    :class:`~.structs.Phase`, ``cnt``: the :class:`~.structs.Counters`, ``sub``: the
    :class:`~.structs.Substep`, ``vfast``: the largest speed so far). Returns ``(code, other,
    H, events, n_dead, delta, dropped, vfast, vrel, t_cut)``: ``dropped`` if events were left
    unprocessed because a disc or the substep ran out of events (the caller repairs);
    ``code`` R_OK, or why a cluster's run stopped (``other``: the cluster it reached)."""
    # (the arrays read once: a struct's field read in the loop would count references)
    discs, tables, bounds, grid = ph.discs, ph.tables, ph.bounds, ph.grid
    sp_radius = tables.sp_radius
    pos, vel, species = discs.pos, discs.vel, discs.species
    sc, rc, icnt = ph.sc, ph.rc, cnt.icnt
    stamp, nev, tlast, binx, biny = sc.stamp, sc.nev, sc.tlast, sc.binx, sc.biny
    cell_start, cell_items = sc.cell_start, sc.cell_items
    marks = Marks(tlast, stamp, sc.partner, sc.lastcol)
    nbin = n if rc.collide else 0
    h, maxdisp = sub.h, rc.maxdisp
    delta = 0.0  # largest distance of a disc from where it was binned
    n_dead = 0
    events = 0
    dropped = False
    vrel = 0.0
    t_cut = 0.0
    t_glide = -math.inf  # the latest time a glide took a disc to in this substep
    while size > 0:
        t, i, j, si, sj, size = pop(H, size)
        if stale(stamp, i, j, si, sj):
            continue
        if out_of_events(nev, i, j):
            dropped = True  # a disc out of events: left to resolve() at the end
            continue
        events += 1
        if events > sub.budget:
            if cl is None:
                dropped = True
                break
            return R_SERIAL, -1, H, events, n_dead, delta, dropped, vfast, vrel, t_cut
        if cl is not None:
            if not _log_first(i, j, sc, vel, cl):
                return R_FULL, -1, H, events, n_dead, delta, dropped, vfast, vrel, t_cut
        nev[i] += 1
        if j >= 0:
            nev[j] += 1
        if j < 0:
            what, t_end = wall_event(i, t, ph, cnt, n, rc.rcell + delta + h * vfast, H, size,
                                     vfast, rng, cl)
            if what == W_NONE:
                continue
            t_glide = max(t_glide, t_end)
            stamp[i] += 1
            if what == W_LEFT:  # gone through an outlet: removed at the end of the substep
                n_dead += 1
                continue
            if rc.collide:
                delta = max(delta, _moved(i, pos, binx, biny))
            if what == W_THERMAL:  # a drawn speed: checked as a release of energy is
                vi = math.hypot(vel[i, 0], vel[i, 1])
                vfast = max(vfast, vi)
                vrel = max(vrel, vi)
                if vi * -t > maxdisp and -t > sub.cut_after and t >= t_glide:
                    t_cut = max(t, tlast[i])
                    break
        else:
            search = Search(grid, cell_start, cell_items, nbin, n, rc.rcell + delta + h * vfast,
                            True)
            what, dead = collide_pair(i, j, t, discs, tables, bounds, marks, rc, cnt, sub,
                                      search, cl)
            if what == P_SKIPPED:
                continue
            if what == P_SERIAL:
                return R_SERIAL, -1, H, events, n_dead, delta, dropped, vfast, vrel, t_cut
            n_dead += dead
            delta = max(delta, _moved(i, pos, binx, biny))
            vi = math.hypot(vel[i, 0], vel[i, 1])
            vfast = max(vfast, vi)
            if species[j] >= 0:
                delta = max(delta, _moved(j, pos, binx, biny))
                vj = math.hypot(vel[j, 0], vel[j, 1])
                vfast = max(vfast, vj)
                vi = max(vi, vj)
            if what == P_RELEASED:
                vrel = max(vrel, vi)
                if vi * -t > maxdisp and -t > sub.cut_after and t >= t_glide:
                    # the substep's contact checks come too late for it: end the substep here
                    t_cut = t
                    break
        for w in range(1 if j < 0 else 2):  # the new contacts of i (and j)
            d = i if w == 0 else j
            if species[d] >= 0:
                search = Search(grid, cell_start, cell_items, nbin, n, rc.rcell + delta,
                                rc.collide)
                code, other, H, size = schedule(d, discs, sp_radius, bounds, tlast, stamp,
                                                search, H, size, icnt, cl)
                if code != R_OK:
                    return code, other, H, events, n_dead, delta, dropped, vfast, vrel, t_cut
    return R_OK, -1, H, events, n_dead, delta, dropped, vfast, vrel, t_cut


#: The event loop of the serial phase (``cl`` None), as a kernel
run_events = kernel(run_events_py)


@kernel(_nrt=False)  # (allocates nothing: no reference counts, per cluster, of its arrays)
def run_cluster(H, size, n, ph, cnt, sub, cl, cid, rep, cicnt):
    """Cluster ``cid``'s run of the event loop (:func:`run_events_py` inlined, on the heap
    ``H[0:size]``, which it never grows: R_HEAP when it has no room left; the caller undoes
    the run, grows the heap and runs the cluster again). ``cl``: the chunk's
    :class:`~.structs.ClusterRun`, whose ``cid`` and ``rep`` (the event free blocks are
    claimed for) are this cluster's here; its counts go to ``cicnt[cid]``, ``cnt``'s
    others. Returns ``(code, other, events, delta, dropped, vfast)``."""
    # (the cluster's structs made here, where counting no references makes them free)
    mine = ClusterRun(cid, cl.dynamic, cl.own, cl.base, cl.ecl, rep, cl.cparent, cl.lg,
                      cl.rec, cl.fill)
    code, other, _H, events, _n_dead, delta, dropped, vfast, _vrel, _t_cut = _run_inline(
        H, size, n, ph, Counters(cicnt[cid], cnt.fsum, cnt.ch_count, cnt.outflow), sub, 0.0,
        None, mine)
    return code, other, events, delta, dropped, vfast


_run_inline = njit(cache=True, inline="always")(run_events_py)


@njit(cache=True, inline="always")
def _moved(i, pos, binx, biny):
    """How far disc i is from where it was binned."""
    return math.hypot(pos[i, 0] - binx[i], pos[i, 1] - biny[i])


@kernel(_nrt=False, inline_code=True)  # (allocates nothing: no reference counts)
def collide_pair(i, j, t, discs, tables, bounds, marks, rc, cnt, sub, search, cl):
    """Discs i and j meet at t: a reactive collision if the scene has their channel, the
    energy along the line of centres pays for it and the products fit (``reach``: of the
    room checks), else a bounce (restitution, the TC model, a share of the pair's internal
    energy released). Returns ``(what, dead)``: P_SKIPPED (not approaching to round-off, or
    the pair's last events were with each other: :mod:`.rules`), P_SERIAL (a cluster met a
    release of internal energy: nothing done), P_BOUNCED or P_RELEASED (energy went into
    motion: a reaction or a release); ``dead`` 1 if j was combined away. (It takes the
    arrays it reads, not the Phase: a call passes every array of its structs.)"""
    pos, vel, species, u = discs.pos, discs.vel, discs.species, discs.internal_energy
    icnt = cnt.icnt
    vxi = vel[i, 0]
    vyi = vel[i, 1]
    vxj = vel[j, 0]
    vyj = vel[j, 1]
    xi, yi, xj, yj, nx, ny = normal_at(pos[i, 0], pos[i, 1], vxi, vyi, pos[j, 0], pos[j, 1],
                                       vxj, vyj, t)
    vr = (vxi - vxj) * nx + (vyi - vyj) * ny
    if grazing(vr, vxi, vyi, vxj, vyj) or rebound(marks.partner, i, j):
        return P_SKIPPED, 0
    kappa = rc.relax
    if cl is not None:  # (the serial phase handles a release: it may cut the substep)
        if kappa > 0.0 and u[i] + u[j] > 0.0:
            return P_SERIAL, 0
    what = P_BOUNCED
    dead = 0
    fired = False
    if rc.has_bi:
        c = tables.bi_table[species[i], species[j]]
        if c >= 0:
            mi = tables.sp_mass[species[i]]
            mj = tables.sp_mass[species[j]]
            if 0.5 * mi * mj / (mi + mj) * vr * vr >= tables.ch_energy[c]:
                k = Contact(xi, yi, xj, yj, nx, ny, vxi, vyi, vxj, vyj)
                if tables.ch_kind[c] == COMBINATION:
                    outcome = combine(i, j, c, t, k, tables, discs, bounds, search)
                else:
                    outcome = exchange(i, j, c, t, k, tables, discs, bounds, search)
                fired = outcome == FIRED
                if fired:
                    what = P_RELEASED
                    cnt.ch_count[c] += 1
                    icnt[IC_REACTIVE] += 1
                    if tables.ch_kind[c] == COMBINATION:
                        dead = 1
                elif outcome == NO_ROOM:
                    icnt[IC_NO_ROOM] += 1
    if not fired:
        e = rc.restitution
        lastcol, sub_id = marks.lastcol, sub.sub_id
        e_eff = tc_restitution(e, lastcol[i] == sub_id or lastcol[j] == sub_id, icnt)
        if e < 1.0:
            lastcol[i] = sub_id
            lastcol[j] = sub_id
        if kappa > 0.0 and u[i] + u[j] > 0.0:  # the bounce releases a share of it
            what = P_RELEASED
        vxi, vyi, vxj, vyj, ui, uj, lost = bounce(vxi, vyi, vxj, vyj, tables.sp_mass[species[i]],
                                                  tables.sp_mass[species[j]], nx, ny, e_eff,
                                                  kappa, u[i], u[j])
        if e < 1.0:  # (at e = 1 nothing is lost: lost is 0 exactly)
            book(cnt.fsum, cl, FS_DISSIPATED, lost, t, i, j)
        vel[i, 0] = vxi
        vel[i, 1] = vyi
        vel[j, 0] = vxj
        vel[j, 1] = vyj
        u[i] = ui
        u[j] = uj
        pos[i, 0] = xi - t * vxi
        pos[i, 1] = yi - t * vyi
        pos[j, 0] = xj - t * vxj
        pos[j, 1] = yj - t * vyj
        icnt[IC_COLLISIONS] += 1
    marks.tlast[i] = t
    marks.tlast[j] = t
    marks.stamp[i] += 1
    marks.stamp[j] += 1
    marks.partner[i] = j
    marks.partner[j] = i
    return what, dead


@kernel(_nrt=False, inline_code=True)  # (allocates nothing: no reference counts)
def wall_event(i, t, ph, cnt, n, reach, H, size, vfast, rng, cl):
    """Disc i meets the wall (if it still does at its queued time t): reflect it, settle it
    inside, and on a circle let a grazing disc glide through its chords in closed form
    (:func:`glide`), to the end of the substep or to the next queued event when discs near
    it could interfere (``reach``: the search radius for them; ``vfast``: the fastest speed
    in the substep). Where the scene has them, an outlet or a thermal side
    (:func:`_wall_exchange`; never for a cluster: ``clusters.eligible``). Returns ``(what,
    t_end)``: W_NONE (it does not meet the wall), W_REFLECTED, W_THERMAL or W_LEFT, and the
    time a glide took the disc to (-inf if none)."""
    pos, vel, species = ph.discs.pos, ph.discs.vel, ph.discs.species
    sp_radius = ph.tables.sp_radius
    bounds_kind, bounds_params = ph.bounds.kind, ph.bounds.params
    sc, rc = ph.sc, ph.rc
    icnt = cnt.icnt
    r = sp_radius[species[i]]
    tw, axis, inward = contact(pos[i, 0], pos[i, 1], vel[i, 0], vel[i, 1], r, bounds_kind,
                               bounds_params)
    if tw == math.inf:
        return W_NONE, -math.inf
    tw = max(tw, sc.tlast[i])
    mi = ph.tables.sp_mass[species[i]]
    what = W_REFLECTED
    if cl is None:
        if rc.thermal or rc.outlets:
            what = _wall_exchange(i, tw, axis, ph, cnt, rng)
            if what == W_LEFT:
                return what, -math.inf
    if what == W_REFLECTED:
        book(cnt.fsum, cl, FS_WALL_MOMENTUM,
             reflect(i, tw, axis, pos, vel, mi, bounds_kind, bounds_params), t, i, -1)
    icnt[IC_WALL_HITS] += 1
    sc.partner[i] = -1
    sc.tlast[i] = tw
    t_end = -math.inf
    if settle_after_reflection(i, axis, pos, r, bounds_kind, bounds_params):
        icnt[IC_PUSHED_INSIDE] += 1
    elif bounds_kind == 1 and not (rc.thermal or rc.outlets):
        xc = pos[i, 0] + tw * vel[i, 0]
        yc = pos[i, 1] + tw * vel[i, 1]
        tau, psi, vn = circle_chord(xc, yc, vel[i, 0], vel[i, 1], r, bounds_params[0],
                                    bounds_params[1], bounds_params[2])
        T = -tw  # glide to the end of the substep, ...
        nbin = n if rc.collide else 0
        if rc.collide and size > 0 and tau * GLIDE_CHORDS < T:
            # ... but the glide is closed form only while the discs near it keep
            # their trajectories: with one near, stop at the next queued event
            sweep = (math.hypot(vel[i, 0], vel[i, 1]) + vfast) * T
            if overlaps_any(xc, yc, r + sweep, tw, i, i, ph.discs, sp_radius,
                            Search(ph.grid, sc.cell_start, sc.cell_items, nbin, n,
                                   reach + sweep, rc.collide)):
                T = min(T, H[0, 0] - tw)
        if tau * GLIDE_CHORDS < T:
            search = Search(ph.grid, sc.cell_start, sc.cell_items, nbin, n, reach, rc.collide)
            if not glide(i, tw, T, (xc, yc, tau, psi, vn), ph, search, cnt):
                sc.nev[i] = DISC_EVENTS  # wedged: no finite sequence of events frees it
            else:
                t_end = sc.tlast[i]
    return what, t_end


@kernel(_nrt=False, inline_code=True)  # (allocates nothing: no reference counts)
def _wall_exchange(i, tw, axis, ph, cnt, rng):
    """Disc i at the wall at tw, where the scene has outlets or thermal sides: through an
    outlet it leaves (species -1, placed where it left; removed at the end of the substep;
    W_LEFT), off a thermal side it takes a velocity drawn from ``rng`` (W_THERMAL), else it
    is reflected (W_REFLECTED, by the caller). ``rng`` None: a cluster's run, whose scenes
    have neither (numba compiles nothing of this for it)."""
    if rng is None:
        return W_REFLECTED
    pos, vel, species = ph.discs.pos, ph.discs.vel, ph.discs.species
    bounds_kind, bounds_params = ph.bounds.kind, ph.bounds.params
    mi = ph.tables.sp_mass[species[i]]
    xc = pos[i, 0] + tw * vel[i, 0]
    yc = pos[i, 1] + tw * vel[i, 1]
    side, frac = side_of(xc, yc, axis, vel[i, 0], vel[i, 1], bounds_kind, bounds_params)
    if ph.rc.outlets and on_outlet(side, frac, int(species[i]), ph.tables.outlets):
        book_outflow(species[i], mi, vel[i, 0], vel[i, 1], ph.discs.internal_energy[i],
                     ph.tables.sp_form, cnt.fsum, cnt.outflow)
        species[i] = -1
        pos[i, 0] = xc  # (where it left; removed at the end of the substep)
        pos[i, 1] = yc
        ph.sc.tlast[i] = tw
        return W_LEFT
    kT = ph.bounds.walls[side]
    if ph.rc.thermal and kT == kT:  # (NaN: a specular side)
        vx0 = vel[i, 0]
        vy0 = vel[i, 1]
        vx, vy, vn_in, vn_out = thermal_velocity(xc, yc, vx0, vy0, side, kT, mi, bounds_kind,
                                                 bounds_params, rng)
        book_thermal(side, mi, vx0, vy0, vx, vy, vn_in, vn_out, cnt.fsum)
        vel[i, 0] = vx
        vel[i, 1] = vy
        pos[i, 0] = xc - tw * vx
        pos[i, 1] = yc - tw * vy
        return W_THERMAL
    return W_REFLECTED


@kernel(_nrt=False, inline_code=True)  # (allocates nothing)
def glide(i, tw, T, chord, ph, search, cnt):
    """Disc i, just reflected at (xc, yc) at time tw, grazes the circle wall so closely that
    more than GLIDE_CHORDS chords ``(tau, psi, vn)`` fit in the time T it glides (``chord``:
    ``(xc, yc, tau, psi, vn)``): move it through them in closed form
    (:func:`~discgym.kernels.walls.circle_glide`) to time tw + T. If the glide would run
    into another disc (``search``), it stops where the two touch (bisection on the glide
    time, to 2^-40 of T), and that collision is the disc's next event. Books the wall
    momentum, leaves the disc on its straight chord (``pos`` its extrapolation to the end of
    the substep, ``tlast[i]`` its last reflection). Returns False (nothing done) for a disc
    wedged between the wall and a disc it already touches.
    """
    pos, vel, species = ph.discs.pos, ph.discs.vel, ph.discs.species
    sp_radius, bp = ph.tables.sp_radius, ph.bounds.params
    xc, yc, tau, psi, vn = chord
    r = sp_radius[species[i]]
    mi = ph.tables.sp_mass[species[i]]
    vx = vel[i, 0]
    vy = vel[i, 1]
    gx, gy, ux, uy, rest, imp = circle_glide(xc, yc, vx, vy, r, bp[0], bp[1], bp[2], tau, psi,
                                             vn, T)
    s = T
    if search.collide and overlaps_any(gx, gy, r, tw + T, i, i, ph.discs, sp_radius, search):
        lo = 0.0
        hi = T
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            x, y, _ux, _uy, _rest, _imp = circle_glide(xc, yc, vx, vy, r, bp[0], bp[1], bp[2],
                                                       tau, psi, vn, mid)
            if overlaps_any(x, y, r, tw + mid, i, i, ph.discs, sp_radius, search):
                hi = mid
            else:
                lo = mid
        s = lo
        if s <= 0.0:
            return False  # wedged between the wall and a disc it touches
        gx, gy, ux, uy, rest, imp = circle_glide(xc, yc, vx, vy, r, bp[0], bp[1], bp[2], tau,
                                                 psi, vn, s)
    # the position at tw + s -> its straight-line extrapolation to the end of the substep
    pos[i, 0] = gx - (tw + s) * ux
    pos[i, 1] = gy - (tw + s) * uy
    vel[i, 0] = ux
    vel[i, 1] = uy
    ph.sc.tlast[i] = tw + s - rest
    cnt.fsum[FS_WALL_MOMENTUM] += mi * imp
    cnt.icnt[IC_GLIDES] += 1
    return True


@kernel
def rewind(n, t, discs, sc, collide):
    """End the substep at time t < 0 (see the module docstring): every disc, on its straight
    trajectory since its latest event (none after t), goes back to where it is at t. Returns
    the largest distance of a disc from where it was binned (if ``collide``)."""
    pos, vel, species = discs.pos, discs.vel, discs.species
    delta = 0.0
    for q in range(n):
        if species[q] < 0:
            continue
        pos[q, 0] += t * vel[q, 0]
        pos[q, 1] += t * vel[q, 1]
        if collide:
            delta = max(delta, math.hypot(pos[q, 0] - sc.binx[q], pos[q, 1] - sc.biny[q]))
    return delta
