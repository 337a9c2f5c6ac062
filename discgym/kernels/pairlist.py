"""The stepped integrator's broad phase of long calls: a pair (Verlet) list.

The broad phase of a call of PAIR_MIN_STEPS or more steps (``step.advance``'s ``lists``): a
flat list of the pairs of small discs whose reference positions are closer than 2 rcell +
skin (:class:`~.structs.PairList`), kept across substeps. Each substep, a disc that has
moved more than skin / 2 from its reference position (or is not listed yet) is "refreshed":
its pairs are dropped, its reference position set to where it is, and its pairs searched
anew in this substep's grid; the other pairs are tested for an overlap in one pass over the
list. The overlapping pairs found are exactly the scan's (the invariant of PairList), so the
same contacts are queued and, as the heap pops them by (t, i, j), the trajectory is the same
bit for bit.
"""

import numpy as np

from .celllist import cell_range
from .jit import kernel
from .structs import FLOAT, INDEX, PairList

PAIR_SKIN = 1.0  # the pair list's skin, in cell radii (docs/performance.md)
PAIR_CAP = 2  # listed pairs the pair list has room for per disc at first (doubled when full)


@kernel
def new_pairlist(ws, cap):
    """An empty pair list for ``ws`` discs and ``cap`` pairs (no disc listed)."""
    return PairList(np.empty((ws, 2), dtype=FLOAT), np.zeros(ws, dtype=INDEX),
                    np.zeros(ws, dtype=INDEX), np.empty(ws, dtype=INDEX),
                    np.empty(cap, dtype=INDEX), np.empty(cap, dtype=INDEX),
                    np.empty(cap, dtype=INDEX), np.empty(cap, dtype=INDEX),
                    np.zeros(2, dtype=np.int64))


@kernel
def pl_resize(pl, ws, cap):
    """``pl`` with room for ``ws`` discs and ``cap`` pairs, its entries kept, the refresh's
    marks and to-do list too (discs past the old size not listed)."""
    q = new_pairlist(ws, cap)
    # (loops, not slice assignments: numba compiles a formatted error message for the shape
    # check of each of those, seconds of a first compile)
    for i in range(min(pl.ref.shape[0], ws)):
        q.ref[i, 0] = pl.ref[i, 0]
        q.ref[i, 1] = pl.ref[i, 1]
        q.listed[i] = pl.listed[i]
        q.mark[i] = pl.mark[i]
        q.todo[i] = pl.todo[i]
    for i in range(pl.count[0]):
        q.pi[i] = pl.pi[i]
        q.pj[i] = pl.pj[i]
    for i in range(pl.count[1]):
        q.ovi[i] = pl.ovi[i]
        q.ovj[i] = pl.ovj[i]
    for i in range(pl.count.shape[0]):
        q.count[i] = pl.count[i]
    return q


@kernel
def pl_stale(n, pos, species, sp_radius, rcell, half, big, pl):
    """Mark the discs to refresh in this substep (``pl.mark``), small ones in ``pl.todo``:
    every listed disc farther than ``half`` (skin / 2) from its reference position, every
    small disc not listed. If ``big`` (the scene has discs larger than rcell), a listed disc
    that has become big (a reaction) is marked, to drop its pairs, and unlisted: big discs
    are queued by :func:`.events.queue_initial`. Returns how many discs are in ``pl.todo``."""
    ref, listed, mark, todo = pl.ref, pl.listed, pl.mark, pl.todo
    h2 = half * half
    m = 0
    if not big:
        for i in range(n):  # (without branches: the test goes either way)
            dx = pos[i, 0] - ref[i, 0]
            dy = pos[i, 1] - ref[i, 1]
            st = (dx * dx + dy * dy > h2) | (listed[i] == 0)
            mark[i] = st
            todo[m] = i
            m += st
        return m
    for i in range(n):
        small = sp_radius[species[i]] <= rcell
        dx = pos[i, 0] - ref[i, 0]
        dy = pos[i, 1] - ref[i, 1]
        st = (dx * dx + dy * dy > h2) | (listed[i] == 0)
        if not small:
            st = listed[i] != 0
            listed[i] = 0
        mark[i] = st
        if st and small:
            todo[m] = i
            m += 1
    return m


@kernel
def pl_test(pos, species, sp_radius, rmono, pl):
    """Drop the pairs of the marked discs from the list and test the others for an overlap,
    in one pass: the overlapping pairs go to ``pl.ovi``, ``pl.ovj`` (their number to
    ``pl.count[1]``). ``rmono`` > 0: every small disc has this radius (no lookup)."""
    pi, pj, ovi, ovj, mark = pl.pi, pl.pj, pl.ovi, pl.ovj, pl.mark
    w = 0
    v = 0
    R = rmono + rmono
    for p in range(pl.count[0]):
        i = pi[p]
        j = pj[p]
        keep = (mark[i] | mark[j]) == 0
        pi[w] = i
        pj[w] = j
        w += keep
        dx = pos[j, 0] - pos[i, 0]
        dy = pos[j, 1] - pos[i, 1]
        if rmono == 0.0:
            R = sp_radius[species[i]] + sp_radius[species[j]]
        if keep and dx * dx + dy * dy < R * R:
            ovi[v] = i
            ovj[v] = j
            v += 1
    pl.count[0] = w
    pl.count[1] = v


@kernel
def pl_refresh(m, pos, species, sp_radius, pl, grid, cell_start, cell_items, cut, reach):
    """Re-list the ``m`` discs of ``pl.todo`` (their pairs dropped already): each one's
    reference position is set to where it is, and its pairs (reference positions closer than
    ``cut``) searched for in this substep's grid (the discs binned where they are now, within
    ``reach - cut`` of their reference positions), appended to the list and tested for an
    overlap. Returns False, the list left to be refreshed again, when it is full: the
    caller grows it and calls again."""
    ref, listed, mark, todo = pl.ref, pl.listed, pl.mark, pl.todo
    pi, pj, ovi, ovj = pl.pi, pl.pj, pl.ovi, pl.ovj
    cap = pi.shape[0]
    ncx = int(grid[4])
    for q in range(m):
        v = todo[q]
        ref[v, 0] = pos[v, 0]
        ref[v, 1] = pos[v, 1]
        listed[v] = 1
    cut2 = cut * cut
    p = pl.count[0]
    o = pl.count[1]
    for q in range(m):
        v = todo[q]
        x = ref[v, 0]
        y = ref[v, 1]
        rv = sp_radius[species[v]]
        p1 = p
        cx0, cx1, cy0, cy1 = cell_range(x, y, reach, grid)
        for cy in range(cy0, cy1 + 1):
            a0 = cell_start[cx0 + ncx * cy]
            a1 = cell_start[cx1 + 1 + ncx * cy]
            if p + (a1 - a0) > cap:
                return False
            for a in range(a0, a1):
                # written whatever the test says, kept if it passes: no branch to mispredict
                # (a pair of two refreshed discs is listed from the lower one)
                k = cell_items[a]
                dx = ref[k, 0] - x
                dy = ref[k, 1] - y
                keep = (dx * dx + dy * dy < cut2) & (k != v) & ((mark[k] == 0) | (k > v))
                pi[p] = v
                pj[p] = k
                p += keep
        for b in range(p1, p):  # the pairs just listed that overlap now
            k = pj[b]
            dx = pos[k, 0] - x
            dy = pos[k, 1] - y
            R = rv + sp_radius[species[k]]
            if dx * dx + dy * dy < R * R:
                ovi[o] = v
                ovj[o] = k
                o += 1
    pl.count[0] = p
    pl.count[1] = o
    return True


@kernel
def mono_radius(sp_radius, rcell):
    """rcell if every species no larger than rcell has radius rcell (so every small disc
    has), else 0."""
    for s in range(sp_radius.shape[0]):
        if sp_radius[s] < rcell:
            return 0.0
    return rcell


@kernel
def pl_broad(n, pos, species, sp_radius, grid, sc, pl, full, big):
    """The broad phase through the pair list (after :func:`sort_cells`): refresh the discs that
    need it (every small disc if ``full``: the list is built anew), test the listed pairs.
    Returns the pair list (a new one when it had to grow)."""
    rcell = grid[6]
    skin = PAIR_SKIN * rcell
    cut = 2.0 * rcell + skin
    if full:
        pl.listed[:n] = 0
    m = pl_stale(n, pos, species, sp_radius, rcell, 0.5 * skin, big, pl)
    pl_test(pos, species, sp_radius, mono_radius(sp_radius, rcell), pl)
    p0 = pl.count[0]
    o0 = pl.count[1]
    # (a disc not refreshed is within skin / 2 of its reference position)
    while not pl_refresh(m, pos, species, sp_radius, pl, grid, sc.cell_start, sc.cell_items,
                          cut, cut + 0.5 * skin):
        pl.count[0] = p0
        pl.count[1] = o0
        pl = pl_resize(pl, pl.ref.shape[0], 2 * pl.pi.shape[0])
    return pl


@kernel
def pl_compact(n, species, pl, newidx):
    """Follow :func:`compact` (to be called before it, on the same discs): drop the pairs
    of the removed discs (species < 0) and renumber the others. ``newidx``: (n,) scratch."""
    ref, listed, pi, pj = pl.ref, pl.listed, pl.pi, pl.pj
    m = 0
    for i in range(n):
        if species[i] >= 0:
            newidx[i] = m
            ref[m, 0] = ref[i, 0]
            ref[m, 1] = ref[i, 1]
            listed[m] = listed[i]
            m += 1
        else:
            newidx[i] = -1
    listed[m:n] = 0
    w = 0
    for p in range(pl.count[0]):
        a = newidx[pi[p]]
        b = newidx[pj[p]]
        if a >= 0 and b >= 0:
            pi[w] = a
            pj[w] = b
            w += 1
    pl.count[0] = w


@kernel
def pl_permute(n, perm, pl, inv, fs):
    """Follow :func:`_reorder` (called after it): disc ``perm[a]`` is now disc a. ``inv``
    (n,) INDEX and ``fs`` (2 n,) FLOAT: scratch."""
    ref, listed, pi, pj = pl.ref, pl.listed, pl.pi, pl.pj
    lt = pl.mark  # (free between substeps)
    for a in range(n):
        inv[perm[a]] = a
        lt[a] = listed[a]
        fs[a] = ref[a, 0]
        fs[n + a] = ref[a, 1]
    for a in range(n):
        b = perm[a]
        listed[a] = lt[b]
        ref[a, 0] = fs[b]
        ref[a, 1] = fs[n + b]
    for p in range(pl.count[0]):
        pi[p] = inv[pi[p]]
        pj[p] = inv[pj[p]]


