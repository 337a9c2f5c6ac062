"""The compiled step: composes the effects a scene calls for.

One (sub)step of length h:

1. drift: every disc moves in a straight line, r += v h;
2. contacts (only if the scene has collisions; walls always): every disc that crossed a wall
   and every overlapping, approaching pair is rewound to its exact contact time t in [-h, 0]
   and queued; events are processed earliest first (ties by disc index), each one rewinding
   its discs to t, responding (reflection, bounce, or a reactive collision), and winding them
   forward by -t. A disc's later contacts in the same step are predicted from its new
   trajectory and may not precede its previous contact, so a disc may collide many times per
   step, in order;
3. first-order reactions (only if the scene has any), each disc with its own random draws;
4. removal of the discs consumed by combinations (stable: the order of the others is kept).

A step is split into k equal substeps when its fastest disc would move more than
``max_displacement`` times the smallest radius, so no disc can pass through another. Energy
released inside the step (a fission, a reactive collision, internal energy released at a
collision) can make discs faster than that split allows: the rest of the step is then split
anew, and a reactive collision whose products would outrun the contact checks of their
substep ends that substep at the collision (:func:`~.events.collide_pair`, :func:`_resplit`).

Which effects run is decided once per call from ``flags``; an absent effect is a skipped
branch per substep, not a per-disc cost (``benchmarks/bench_core.py`` measures it; the
figures are in docs/performance.md).

The driver is :func:`advance`; its state, call, bounds, physics and counters are the structs
of :mod:`discgym.kernels.structs`.

**Who compiles what.** :func:`advance`'s two optional arguments decide at compile time what
is compiled (numba prunes the branches of an omitted one); each path gives the same
trajectory bit for bit. ``clusters`` given: a box scene whose events are local runs the event
phase of its substeps by clusters (:mod:`~discgym.kernels.clusters`), on the threads from
PARALLEL_MIN discs with ``threads`` > 1 and on the calling thread above PAIR_MAX_DISCS
discs (below that, on one thread, the serial phase and the pair list are as fast or
faster); the drift and the scan run in parallel. Omitted, as by the single-threaded callers
(the vector env's reactors, the exact integrator's fallback, :func:`advance_serial_rngs`):
everything on the calling thread, and only the owner array's one-line constructor compiled.
``lists`` given: a call of PAIR_MIN_STEPS steps or more keeps a pair list
(:mod:`~discgym.kernels.pairlist`) across its substeps, the broad phase of long calls.
Omitted (None), as by a caller whose calls are all shorter (an env of fewer steps per
action, a ``Simulation``'s short calls, the exact integrator's fallback): the scan only.
"""

import math

import numpy as np
from numba import njit
from numba.extending import register_jitable

from .celllist import build, cell_coord, cell_radius, make_grid
from .claims import new_owner
from .clusters import eligible
from .clusters import events as cluster_events
from .drift import PARALLEL_MIN, drift_and_bin
from .events import queue_initial, rewind, run_events
from .heap import new_heap
from .jit import kernel
from .pairlist import PAIR_CAP, new_pairlist, pl_compact, pl_permute, pl_resize
from .reactions import (
    TRANSFORMATION,
    first_order_draws,
    fission,
    grow1,
    grow2,
    transform,
)
from .resolve import resolve

# The counters' names, read as step.X by the Simulation, the envs and the tests
from .structs import (  # noqa: E402,F401,I001
    COUNT,
    EVENTS_PER_DISC,
    F_BI,
    F_COLLISIONS,
    F_FISSION,
    F_OUTLETS,
    F_THERMAL,
    F_UNI,
    FLOAT,
    FS_DISSIPATED,
    FS_OUTFLOW,
    FS_WALL_HEAT,
    FS_WALL_MOMENTUM,
    IC_COLLISIONS,
    IC_CUTS,
    IC_EVENTS_CAPPED,
    IC_GLIDES,
    IC_GRAZE_REPAIRS,
    IC_LEFT_OVERLAPPING,
    IC_NO_ROOM,
    IC_PUSHED_INSIDE,
    IC_REACTIVE,
    IC_RESOLVED,
    IC_RESPLITS,
    IC_SUBSTEPS,
    IC_SUBSTEPS_CAPPED,
    IC_TC_ELASTIC,
    IC_WALL_HITS,
    INDEX,
    N_FSUMS,  # noqa: F401 (step.N_FSUMS: the counters' sizes, read by Simulation)
    N_ICOUNTERS,  # noqa: F401
    OV_SLOTS,
    P_MAXDISP,
    P_RELAX,
    P_RESTITUTION,
    P_RMIN,
    Bounds,
    Call,
    Counters,
    Discs,
    PairList,
    Phase,
    Physics,
    RunConsts,
    Scratch,
    Search,
    Substep,
    Tables,
    capacity_for_discs,
    fields,
)

MAX_SUBSTEPS = 1 << 16
REBUILD_UNBINNED = 256  # rebuild the grid when this many discs were created since it was built
CHUNK_MIN = 1024  # discs per work chunk at least (more chunks than this allows: fewer)
REORDER_MIN = 16384  # from this many discs, discs are periodically put in cell order in memory
REORDER_EVERY = 8  # steps between reorderings (Simulation's default)
REORDER_CELLS = 1 << 19  # the reordering grid: cells of 2 r_max, at most about this many
PAIR_MIN_STEPS = 32  # calls of fewer steps use the per-substep scan: the list is built at the
# start of each call (about 120 ns per disc), which a call of fewer steps does not earn back
# (new / old 1.07 at 4 steps per call, 1.01 at 16, 0.99 at 32, 0.89 at 200: docs/performance.md)
PAIR_MAX_DISCS = 1 << 17  # calls on more discs use the scan: the list's scattered reads cost
# more than the scan once the state and the list outgrow the caches (list / scan 0.85 at
# 10^5, 1.10 at 3 10^5, 1.30 at 10^6: docs/performance.md)



# ------------------------------------------------------------- phase 4: first-order reactions
@kernel
def _first_order(n, h, ph, fission_possible, delta, rng, cnt):
    """Each disc present at the start of the pass draws its first-order reactions (``ph``:
    the :class:`~.structs.Phase`).

    Capacity for one fission per disc is made before the loop (so no array is reallocated
    inside it). A new disc gets the identity ``discs.next_id[0]`` (then incremented). Returns
    the state arrays (new ones if they grew) as :class:`~.structs.Discs`, the new n and the
    largest speed of a fragment made (0 if none).
    """
    discs, tables, bounds, grid, sc, rc = ph
    pos, vel, species, internal_energy = discs.pos, discs.vel, discs.species, discs.internal_energy
    ids, idctr = discs.ids, discs.next_id
    cell_start, cell_items, cell_of = sc.cell_start, sc.cell_items, sc.cell_of
    collide, rcell = rc.collide, rc.rcell
    icnt, ch_count = cnt.icnt, cnt.ch_count
    ch_kind = tables.ch_kind
    nbin = n if collide else 0
    n0 = n
    if fission_possible and pos.shape[0] < 2 * n0:
        cap = capacity_for_discs(n0)
        pos = grow2(pos, cap)
        vel = grow2(vel, cap)
        species = grow1(species, cap)
        species[n0:] = -1
        internal_energy = grow1(internal_energy, cap)
        ids = grow1(ids, cap)
    if collide and fission_possible and cell_items.shape[0] < pos.shape[0]:
        cell_items = np.empty(pos.shape[0], dtype=INDEX)
        cell_of = np.empty(pos.shape[0], dtype=INDEX)
        build(n, pos, species, tables.sp_radius, grid, cell_start, cell_items, cell_of)
    react = np.empty(n0, dtype=INDEX)
    chan = np.empty(n0, dtype=INDEX)
    m = first_order_draws(n0, h, tables, species, internal_energy, rng, react, chan)
    vfrag = 0.0
    for q in range(m):
        i = react[q]
        c = chan[q]
        if ch_kind[c] == TRANSFORMATION:
            fired = transform(i, c, tables, Discs(pos, vel, species, internal_energy, ids, idctr),
                              bounds, Search(grid, cell_start, cell_items, nbin, n,
                                             rcell + delta, collide))
        else:
            if collide and n - nbin > REBUILD_UNBINNED:
                build(n, pos, species, tables.sp_radius, grid, cell_start, cell_items, cell_of)
                nbin = n
                delta = 0.0
            x_old = pos[i, 0]
            y_old = pos[i, 1]
            fired = fission(i, c, n, tables, Discs(pos, vel, species, internal_energy, ids, idctr),
                            bounds, Search(grid, cell_start, cell_items, nbin, n, rcell + delta,
                                           collide), rng)
            if fired:
                ids[n] = idctr[0]
                idctr[0] += 1
                n += 1
                # disc i moved from where it is binned: widen the search (triangle inequality)
                delta += math.hypot(pos[i, 0] - x_old, pos[i, 1] - y_old)
                vfrag = max(vfrag, math.hypot(vel[i, 0], vel[i, 1]),
                            math.hypot(vel[n - 1, 0], vel[n - 1, 1]))
        if fired:
            ch_count[c] += 1
        else:
            icnt[IC_NO_ROOM] += 1
    return Discs(pos, vel, species, internal_energy, ids, idctr), n, vfrag


# -------------------------------------------------------------------------- phase 5: removal
@kernel
def compact(n, pos, vel, species, internal_energy, ids):
    """Remove discs with species < 0, keeping the order of the others; returns the new n."""
    m = 0
    for i in range(n):
        if species[i] >= 0:
            if m != i:
                pos[m, 0] = pos[i, 0]
                pos[m, 1] = pos[i, 1]
                vel[m, 0] = vel[i, 0]
                vel[m, 1] = vel[i, 1]
                species[m] = species[i]
                internal_energy[m] = internal_energy[i]
                ids[m] = ids[i]
            m += 1
    for i in range(m, n):
        species[i] = -1
    return m


@kernel
def _reorder(n, pos, vel, species, internal_energy, ids, grid, work):
    """Permute discs [0, n) into cell order (stable), so that neighbours are neighbours in
    memory. Disc identity is kept in ``ids``. Without it, from about 1e5 discs the gather
    and event phases are bound by cache misses. The copies are made in the
    scratch buffers ``work`` (between steps nothing in them is live; see :func:`_carve`)."""
    ncx = int(grid[4])
    ncy = int(grid[5])
    nc = ncx * ncy
    fw, iw, cw = work
    start = np.zeros(nc + 1, dtype=np.int64)
    cell = iw[0:n]
    for i in range(n):
        c = cell_coord(pos[i, 0], grid[2], grid[0], ncx) + \
            ncx * cell_coord(pos[i, 1], grid[3], grid[1], ncy)
        cell[i] = c
        start[c + 1] += 1
    for c in range(nc):
        start[c + 1] += start[c]
    perm = iw[n:2 * n]
    for i in range(n):
        perm[start[cell[i]]] = i
        start[cell[i]] += 1
    p2 = fw[0:2 * n].reshape((n, 2))
    v2 = fw[2 * n:4 * n].reshape((n, 2))
    u2 = fw[4 * n:5 * n]
    s2 = iw[2 * n:3 * n]
    d2 = cw[0:n]
    for i in range(n):  # (a loop, not slice assignments: see pl_resize)
        p2[i, 0] = pos[i, 0]
        p2[i, 1] = pos[i, 1]
        v2[i, 0] = vel[i, 0]
        v2[i, 1] = vel[i, 1]
        u2[i] = internal_energy[i]
        s2[i] = species[i]
        d2[i] = ids[i]
    for a in range(n):
        i = perm[a]
        pos[a, 0] = p2[i, 0]
        pos[a, 1] = p2[i, 1]
        vel[a, 0] = v2[i, 0]
        vel[a, 1] = v2[i, 1]
        species[a] = s2[i]
        internal_energy[a] = u2[i]
        ids[a] = d2[i]


@kernel
def _resplit(n, vel, species, rem, cut, dt, maxdisp, split, icnt):
    """Split the time ``rem`` left in a step anew after energy was released in its last
    substep (of length ``h``; ``cut``: ended early, see :func:`~.events.collide_pair`), into
    substeps of at most ``maxdisp`` for the fastest disc now. As for the first split of a step, the
    substeps are no shorter than the capped ones (the remainder's share of MAX_SUBSTEPS);
    a step that needed shorter ones counts once in IC_SUBSTEPS_CAPPED. Nothing changes when
    the fastest disc is within the current substeps after all (and the substep was not cut).
    ``split``: the substep loop's ``(k, h, vfast, capped, sub)``, returned new (unchanged when
    the substeps are capped already and the last one was not cut)."""
    k, h, vfast, capped, sub = split
    if not rem > 0.0:
        return k, h, vfast, capped, sub
    v2max = 0.0
    for i in range(n):
        if species[i] >= 0:
            v2 = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1]
            if v2 > v2max:
                v2max = v2
    vmax = math.sqrt(v2max)
    if not cut and not vmax * h > maxdisp:
        return k, h, vfast, capped, sub
    q = vmax * rem / maxdisp
    qcap = MAX_SUBSTEPS * rem / dt  # (rem <= dt: at most MAX_SUBSTEPS)
    if not q <= qcap:
        if capped and not cut:  # the substeps are as short as they may be already
            return k, h, vfast, capped, sub
        k = max(int(math.ceil(qcap)), 1)
        if not capped:
            icnt[IC_SUBSTEPS_CAPPED] += 1
            capped = True
    else:
        k = max(int(math.ceil(q)), 1)
    icnt[IC_RESPLITS] += 1
    return k, rem / k, max(vfast, vmax), capped, 0


# --------------------------------------------------------------------------------- the driver
N_FWORK = 7  # float scratch arrays per disc (see _carve)
N_IWORK = 8 + OV_SLOTS  # INDEX scratch per disc (cell_start and nlist come after them)
N_CWORK = 2  # COUNT scratch arrays per disc


@njit(cache=True)
def empty_work():
    """Scratch buffers of size 0 for :func:`advance`, which makes them as large as needed
    and returns them: a caller that keeps them for its next call saves allocating and
    first-touching them on every call (about 130 bytes per disc, which for short calls on
    many discs costs as much as the step)."""
    return (np.empty(0, dtype=FLOAT), np.empty(0, dtype=INDEX), np.empty(0, dtype=COUNT))


@kernel
def _fit_work(work, ws, nstart):
    """``work`` if its buffers hold ``ws`` discs and a cell index of ``nstart``, else new
    buffers of exactly that size."""
    fw, iw, cw = work
    if fw.shape[0] >= N_FWORK * ws and iw.shape[0] >= N_IWORK * ws + nstart + 2 and \
            cw.shape[0] >= N_CWORK * ws:
        return work
    return (np.empty(N_FWORK * ws, dtype=FLOAT), np.empty(N_IWORK * ws + nstart + 2, dtype=INDEX),
            np.empty(N_CWORK * ws, dtype=COUNT))


@kernel
def _carve(work, ws, nstart):
    """The per-disc scratch arrays of a run for ``ws`` discs, and ``cell_start``
    (``nstart``), as a :class:`~.structs.Scratch` of views of the buffers ``work`` (see
    :func:`_fit_work`). ``stamp``, ``lastcol`` and ``nev`` start at zero; the others are
    written before they are read. Between steps nothing in them is live except ``lastcol``,
    so :func:`_reorder` may use all of ``fw`` and ``iw`` and the first ws entries of ``cw``
    (``stamp``, only ever compared within a substep), never ``lastcol`` (kept at
    ``cw[ws:2 ws]``: a disc's last collision substep, which must not match a later substep
    by accident)."""
    fw, iw, cw = work
    stamp = cw[0:ws]
    lastcol = cw[ws:2 * ws]
    stamp[:] = 0
    lastcol[:] = 0
    tlast = fw[0:ws]
    wall_t = fw[ws:2 * ws]
    sx = fw[2 * ws:3 * ws]
    sy = fw[3 * ws:4 * ws]
    sr = fw[4 * ws:5 * ws]
    binx = fw[5 * ws:6 * ws]
    biny = fw[6 * ws:7 * ws]
    wflag = iw[0:ws]
    cell_of = iw[ws:2 * ws]
    cell_items = iw[2 * ws:3 * ws]
    ov_n = iw[3 * ws:4 * ws]
    partner = iw[4 * ws:5 * ws]
    nev = iw[5 * ws:6 * ws]
    nev[:] = 0
    wl = iw[6 * ws:7 * ws]
    ol = iw[7 * ws:8 * ws]
    ov_b = iw[8 * ws:N_IWORK * ws].reshape((ws, OV_SLOTS))
    cell_start = iw[N_IWORK * ws:N_IWORK * ws + nstart]
    nlist = iw[N_IWORK * ws + nstart:N_IWORK * ws + nstart + 2]
    return Scratch(stamp, lastcol, tlast, wall_t, wflag, cell_of, cell_items, sx, sy, sr, ov_n,
                   ov_b, binx, biny, partner, nev, cell_start, wl, ol, nlist)


@njit(cache=True)
def advance_rngs(discs, n, call, bounds, physics, rngs, cnt, work, lists):
    """:func:`advance` called from Python: the structs ``discs``, ``call``, ``bounds``,
    ``physics`` (its tables too) and ``cnt`` passed as plain tuples of their fields, the
    generator as ``rngs[0]``, a ``numba.typed.List``. Both are for the cost of the call: numba
    types a plain tuple of arrays in C but a NamedTuple field by field in Python (about 0.5 us
    per field), and it rebuilds the ctypes interface of an ``np.random.Generator`` argument
    every time (a typed list holding the same generator, same state, is an order of magnitude
    cheaper); a Simulation makes many short calls. ``lists``: :func:`lists_for` the call.
    Returns :func:`advance`'s ``(discs, n, work)`` with ``discs`` a plain tuple too (boxing a
    NamedTuple unpickles its class at every return)."""
    d, n, work = advance(Discs(*discs), n, Call(*call), Bounds(*bounds), _physics(physics),
                         rngs[0], Counters(*cnt), work, np.bool_(True), lists)  # (not a literal)
    return fields(d), n, work


@njit(cache=True)
def advance_serial_rngs(discs, n, call, bounds, physics, rngs, cnt, work, lists):
    """:func:`advance_rngs` on the calling thread, without the event phase by clusters:
    ``clusters`` omitted, so numba compiles neither (nor the parallel drift and scan), as
    for the vector env's reactors, whose :func:`advance` this is (the same argument types:
    one compiled version, shared through the cache, for ``lists`` None: :func:`lists_for`
    a call of fewer than PAIR_MIN_STEPS steps; ``call.threads`` must be 1). A
    ``Simulation`` calls it when :func:`advance_rngs` would not take those paths
    (:func:`serial_suffices`), which is the same trajectory bit for bit; its first step
    compiles half as much."""
    d, n, work = advance(Discs(*discs), n, Call(*call), Bounds(*bounds), _physics(physics),
                         rngs[0], Counters(*cnt), work, lists=lists)
    return fields(d), n, work


@register_jitable
def _physics(physics):
    """A :class:`~.structs.Physics` from a plain ``(tables, params, flags)`` tuple."""
    return Physics(Tables(*physics[0]), physics[1], physics[2])


def lists_for(n_steps: int):
    """:func:`advance`'s ``lists`` for a call of ``n_steps`` steps: True where the call may
    keep a pair list (PAIR_MIN_STEPS steps or more), else None (no pair-list code compiled:
    the same trajectory)."""
    return np.bool_(True) if n_steps >= PAIR_MIN_STEPS else None


def serial_suffices(n: int, threads: int) -> bool:
    """Whether :func:`advance` given ``clusters`` and ``threads`` work chunks would run a call
    starting with ``n`` discs on the calling thread without clusters: below PARALLEL_MIN
    discs on several threads, up to PAIR_MAX_DISCS on one. (Discs made during a call may
    cross PARALLEL_MIN: :func:`advance_serial_rngs` then runs the rest of that call serially,
    the same bits, the results not depending on the thread count.)"""
    return n < PARALLEL_MIN if threads > 1 else n <= PAIR_MAX_DISCS


@kernel
def advance(discs, n, call, bounds, physics, rng, cnt, work, clusters=None, lists=None):
    """Advance ``call.n_steps`` steps of length ``call.dt`` (a :class:`~.structs.Call`).

    ``discs`` (capacity C >= n; discs are [0, n); new ones take the identity
    ``discs.next_id[0]``, incremented), ``bounds``, ``physics`` and the counters ``cnt``
    (accumulated in place): the structs of :mod:`~discgym.kernels.structs`. ``call.threads``
    work chunks for numba's threads (4 per thread is a good choice; at most one per CHUNK_MIN
    discs is used; 0 or 1: all on the calling thread). With ``call.reorder_every`` > 0 and
    n >= REORDER_MIN, the discs are put in cell order before every step whose global index
    ``call.step0 + s`` is a multiple of it (the result does not depend on how a run is split
    into calls). ``work``: scratch buffers (:func:`empty_work`), replaced when too small.
    ``clusters``, ``lists``: see "Who compiles what" above.

    Returns ``(discs, n, work)``: new (larger) state arrays when a decomposition needed more
    capacity, else the ones passed in; the scratch buffers used.
    """
    tables, flags = physics.tables, physics.flags
    d = discs
    icnt = cnt.icnt
    sp_radius = tables.sp_radius
    dt, reorder_every = call.dt, call.reorder_every
    has_uni = flags[F_UNI] != 0
    H = new_heap(256)
    rc, grid, rgrid = _run_setup(d.species, n, bounds, physics)
    collide, maxdisp = rc.collide, rc.maxdisp
    ncx = int(grid[4])
    ncy = int(grid[5])
    nstart = ncx * ncy + 2 if collide else 3
    ws = d.pos.shape[0]  # per-disc workspace, reallocated when the state grows
    work = _fit_work(work, ws, nstart)
    sc = _carve(work, ws, nstart)
    # a pair list for a call long enough to pay, not on threads (the parallel scan beats it)
    threads = min(call.threads, max(n // CHUNK_MIN, 1))
    on_threads = threads > 1 and n >= PARALLEL_MIN
    if lists is not None:  # (pruned by numba when None: no pair-list code compiled)
        listed = (collide and call.n_steps >= PAIR_MIN_STEPS and n <= PAIR_MAX_DISCS
                  and not on_threads)
        pl = new_pairlist(ws if listed else 0, PAIR_CAP * ws if listed else 0)
    else:
        listed = False
        pl = None
    big = sp_radius.max() > rc.rcell  # (discs not in the list: see PairList)
    full = True  # (the list is built at the first substep, and after a reordering)
    # the event phase by clusters (kernels.clusters) where the scene's events are local
    clustered = False
    if clusters is not None:  # (pruned by numba when the argument is omitted)
        clustered = eligible(rc, bounds.kind) and (on_threads or n > PAIR_MAX_DISCS)
    own = new_owner(grid) if clustered else np.empty(0, dtype=np.int32)
    for s in range(call.n_steps):
        if reorder_every > 0 and n >= REORDER_MIN and (call.step0 + s) % reorder_every == 0:
            _reorder(n, d.pos, d.vel, d.species, d.internal_energy, d.ids, rgrid, work)
            if lists is not None:
                if listed:  # (perm and free scratch: see _reorder)
                    pl_permute(n, work[1][n:2 * n], pl, work[1][0:n], work[0])
        # first-order reactions run only if some disc has a first-order channel: a scene
        # whose first-order species are absent pays this lookup, not a pass per substep
        uni_live = has_uni and _any_first_order(d.species, n, tables.uni_start)
        reactive0 = icnt[IC_REACTIVE]
        # substeps so that no disc moves more than maxdisp
        k, capped, vfast = _first_split(d.vel, n, dt, maxdisp, icnt)
        h = dt / k
        taken = 0  # substeps of this step so far
        sub = 0
        while sub < k:
            icnt[IC_SUBSTEPS] += 1
            ph = Phase(d, tables, bounds, grid, sc, rc)
            if clusters is None:  # (a single-threaded caller: no parallel code compiled)
                pl = drift_and_bin(None, n, h, ph, pl, listed, full, big)
            else:
                pl = drift_and_bin(threads, n, h, ph, pl, listed, full, big)
            full = False
            left0 = icnt[IC_LEFT_OVERLAPPING]
            # a substep is cut short (at a reaction: events.collide_pair) only while the step has
            # taken fewer than MAX_SUBSTEPS substeps and not shorter than the capped substep
            # dt / MAX_SUBSTEPS: a step of a finite number of substeps, each of them useful
            cut_after = dt / MAX_SUBSTEPS if taken < MAX_SUBSTEPS else math.inf
            taken += 1
            sub_c = Substep(icnt[IC_SUBSTEPS], h, cut_after, EVENTS_PER_DISC * n + 1024)
            if clusters is None:
                H, n_dead, delta, dropped, vfast, vrel, t_cut = _event_phase(
                    n, ph, cnt, sub_c, vfast, rng, H, pl, listed, None)
            else:  # (by clusters where the scene allows and there are no big discs now)
                go = clustered and sc.cell_start[ncx * ncy + 1] == sc.cell_start[ncx * ncy]
                H, n_dead, delta, dropped, vfast, vrel, t_cut = _event_phase(
                    n, ph, cnt, sub_c, vfast, rng, H, pl, listed, (own, threads, go))
            hu, delta = _settle(n, h, t_cut, delta, dropped, left0, ph, cnt)
            # (a reactive collision may have made a species with first-order channels)
            if has_uni and (uni_live or icnt[IC_REACTIVE] != reactive0):
                uni_live = True
                n_before = n
                d, n, vfrag = _first_order(n, hu, ph, flags[F_FISSION] != 0, delta, rng, cnt)
                # fragments are binned where they end the next substep: the reach of its
                # room checks must cover their speed
                vfast = max(vfast, vfrag)
                vrel = max(vrel, vfrag)
                if ws < d.pos.shape[0]:  # the state grew: scratch for the next substep and
                    ws = d.pos.shape[0]  # for the next step's reordering
                    work = _fit_work(work, ws, nstart)
                    sc = _carve(work, ws, nstart)
                    if lists is not None:
                        if listed:
                            pl = pl_resize(pl, ws, pl.pi.shape[0])
                if lists is not None:
                    if listed:
                        pl.listed[n_before:n] = 0  # fragments: listed at the next substep
            if n_dead:
                if lists is not None:
                    if listed:
                        pl_compact(n, d.species, pl, pl.todo)
                n = compact(n, d.pos, d.vel, d.species, d.internal_energy, d.ids)
            sub += 1
            # Energy released in this substep (vrel: the speeds of its products alone) may
            # have made a disc faster than the substeps sized at the step's start allow: the
            # rest of the step is split anew (a substep without releases: one comparison)
            if t_cut < 0.0 or vrel * h > maxdisp:
                k, h, vfast, capped, sub = _resplit(n, d.vel, d.species, (k - sub) * h + (h - hu),
                                                    t_cut < 0.0, dt, maxdisp,
                                                    (k, h, vfast, capped, sub), icnt)
    return d, n, work


@kernel
def _run_setup(species, n, bounds, physics):
    """What a call reads from its scene once: the :class:`~.structs.RunConsts`, the grid of
    the contacts (cells sized by the small discs; the few much larger ones in the big cell,
    see celllist) and the grid of the memory reordering (independent of n)."""
    params, flags, sp_radius = physics.params, physics.flags, physics.tables.sp_radius
    rcell = cell_radius(species, n, sp_radius)
    rc = RunConsts(params[P_RESTITUTION], params[P_RELAX], params[P_MAXDISP] * params[P_RMIN],
                   rcell, flags[F_COLLISIONS] != 0, flags[F_BI] != 0, flags[F_THERMAL] != 0,
                   flags[F_OUTLETS] != 0)
    grid = make_grid(bounds.kind, bounds.params, rcell, max(n, 1))
    rgrid = make_grid(bounds.kind, bounds.params, sp_radius.max(), np.int64(REORDER_CELLS))
    return rc, grid, rgrid


@kernel
def _settle(n, h, t_cut, delta, dropped, left0, ph, cnt):
    """After a substep's events: a substep cut at ``t_cut`` < 0 rewound to its end, and the
    repair of a substep that ran out of events (``dropped``) or left a pair overlapping
    (its count past ``left0``). Returns the substep's length and the drift of the grid's
    positions (0 after a repair, which leaves the grid built at the final positions)."""
    hu = h
    if t_cut < 0.0:
        cnt.icnt[IC_CUTS] += 1
        delta = rewind(n, t_cut, ph.discs, ph.sc, ph.rc.collide)
        hu = h + t_cut
    if dropped or cnt.icnt[IC_LEFT_OVERLAPPING] != left0:
        _repair(dropped, n, ph, cnt)
        delta = 0.0
    return hu, delta


@kernel
def _any_first_order(species, n, uni_start):
    """Does some disc of [0, n) have a species with first-order channels?"""
    for i in range(n):
        s_i = species[i]
        if s_i >= 0 and uni_start[s_i + 1] > uni_start[s_i]:
            return True
    return False


@kernel
def _first_split(vel, n, dt, maxdisp, icnt):
    """The substeps of a step of ``dt``: k of them, so that the fastest disc moves at most
    ``maxdisp`` in each, but at most MAX_SUBSTEPS (then ``capped``, counted in
    IC_SUBSTEPS_CAPPED). Returns ``(k, capped, vmax)``, vmax the fastest disc's speed."""
    v2max = 0.0
    for i in range(n):
        v2 = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1]
        if v2 > v2max:
            v2max = v2
    k = 1
    capped = False
    if v2max > 0.0:
        q = math.sqrt(v2max) * dt / maxdisp  # compared as a float: ceil() of 1e19 or of
        if not q <= MAX_SUBSTEPS:  # inf would overflow int64 (and NaN compares false)
            k = MAX_SUBSTEPS
            icnt[IC_SUBSTEPS_CAPPED] += 1
            capped = True
        else:
            k = max(int(math.ceil(q)), 1)
    return k, capped, math.sqrt(v2max)


@kernel
def _repair(dropped, n, ph, cnt):
    """The fallback after a substep that ran out of events (``dropped``) or left a pair
    overlapping: :func:`~discgym.kernels.resolve.resolve`, and its counts."""
    icnt, fsum = cnt.icnt, cnt.fsum
    if dropped:
        icnt[IC_EVENTS_CAPPED] += 1
    else:
        icnt[IC_GRAZE_REPAIRS] += 1
    fixes, wdp, lost = resolve(n, ph)
    icnt[IC_RESOLVED] += fixes
    fsum[FS_WALL_MOMENTUM] += wdp
    fsum[FS_DISSIPATED] += lost


@kernel
def _event_phase(n, ph, cnt, sub, vfast, rng, H, pl, listed, by_clusters):
    """Phase 3 of a substep: its contacts queued and processed (:mod:`.events`), by clusters
    where ``by_clusters`` (``(own, threads, go)``; None: a caller without the clusters, whose
    code numba then never compiles) says ``go`` and they do not decline (:mod:`.clusters`),
    else serially. Returns ``(H, n_dead, delta, dropped, vfast, vrel, t_cut)``."""
    queued = False
    if by_clusters is not None:
        own, threads, go = by_clusters
        if go:
            done, H, size, delta, dropped, vfast = cluster_events(n, H, ph, cnt, sub, vfast, own,
                                                                  threads)
            if done:
                return H, 0, delta, dropped, vfast, 0.0, 0.0
            queued = True  # (declined: the serial phase, on the queue it made)
    if not queued:
        H, size = queue_initial(n, ph, H, cnt.icnt, pl, listed)
    _code, _other, H, _ev, n_dead, delta, dropped, vfast, vrel, t_cut = run_events(
        H, size, n, ph, cnt, sub, vfast, rng, None)
    return H, n_dead, delta, dropped, vfast, vrel, t_cut
