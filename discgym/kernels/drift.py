"""Phases 1 and 2 of a stepped substep: the drift (every disc moves in a straight line, its
wall contact noted, and it is binned in its cell) and the broad phase (the discs sorted by
cell, the overlapping pairs found by a scan of the half stencil, or by the pair list of
:mod:`.pairlist`), in parallel chunks from PARALLEL_MIN discs."""

import math

import numpy as np
from numba import njit, prange

from .celllist import cell_coord
from .contacts import close_lists
from .jit import kernel
from .pairlist import pl_broad
from .structs import OV_SLOTS
from .walls import box_contact, circle_contact, push_inside

PARALLEL_MIN = 8192  # below this many discs a step runs on one thread: waking numba's
# threads for the parallel regions of a substep costs more than they save (2 threads against
# 1: 1.3-1.4x at 8,200 discs, docs/performance.md)


@kernel(_nrt=False)  # (allocates nothing: no reference counts of the structs' arrays)
def drift_range(lo, hi, h, discs, sp_radius, bounds, grid, sc, collide):
    """Move discs [lo, hi) of ``discs`` by h; note their wall contacts (and list the discs
    that have one or were pushed inside in ``sc.wl`` from ``lo`` on; returns how many);
    reset their event counts; bin them (if collide: their cell, where they were binned, no
    partner yet). One pass does it all (these were separate passes over the discs).

    Bounds are unpacked to scalars once: helpers taking arrays cost a reference count per
    call, which in this loop would dominate its time.
    """
    pos, vel, species = discs.pos, discs.vel, discs.species
    bounds_kind, bounds_params = bounds.kind, bounds.params
    tlast, wall_t, wflag, wl, nev = sc.tlast, sc.wall_t, sc.wflag, sc.wl, sc.nev
    cell_of, binx, biny, partner = sc.cell_of, sc.binx, sc.biny, sc.partner
    x0, y0, icx, icy = grid[0], grid[1], grid[2], grid[3]
    ncx = int(grid[4])
    ncy = int(grid[5])
    rcell = grid[6]
    nbc = ncx * ncy  # the big cell (celllist)
    b0, b1, b2, b3 = bounds_params[0], bounds_params[1], bounds_params[2], bounds_params[3]
    m = lo
    for i in range(lo, hi):
        vx = vel[i, 0]
        vy = vel[i, 1]
        x = pos[i, 0] + h * vx
        y = pos[i, 1] + h * vy
        pos[i, 0] = x
        pos[i, 1] = y
        tlast[i] = -h
        r = sp_radius[species[i]]
        if bounds_kind == 0:
            t, axis, inward = box_contact(x, y, vx, vy, r, b0, b1, b2, b3)
        else:
            t, axis, inward = circle_contact(x, y, vx, vy, r, b0, b1, b2)
        wall_t[i] = max(t, -h)
        wflag[i] = 0
        nev[i] = 0
        if inward:
            push_inside(i, pos, r, bounds_kind, bounds_params)
            wflag[i] = 1
            x = pos[i, 0]
            y = pos[i, 1]
        if inward or t < math.inf:
            wl[m] = i
            m += 1
        if collide:
            if r > rcell:
                cell_of[i] = nbc
            else:
                cell_of[i] = cell_coord(x, icx, x0, ncx) + ncx * cell_coord(y, icy, y0, ncy)
            binx[i] = x
            biny[i] = y
            partner[i] = -1
    return m - lo


@kernel(parallel=True)
def _drift_parallel(nch, n, h, discs, sp_radius, bounds, grid, sc, collide):
    """drift_range in nch chunks of discs; returns how many discs are listed in ``wl``."""
    starts = np.empty(nch, dtype=np.int64)
    counts = np.empty(nch, dtype=np.int64)
    for c in prange(nch):
        lo = c * n // nch
        starts[c] = lo
        counts[c] = drift_range(lo, (c + 1) * n // nch, h, discs, sp_radius, bounds, grid, sc,
                                collide)
    return close_lists(sc.wl, starts, counts)


# ----------------------------------------------------------------------- phase 2: broad phase
@kernel
def sort_cells(n, cell_of, cell_start, cell_items):
    """Counting sort of discs [0, n) by ``cell_of`` (all live)."""
    nc = cell_start.shape[0] - 1
    cell_start[:] = 0
    for i in range(n):
        cell_start[cell_of[i] + 1] += 1
    for c in range(nc):
        cell_start[c + 1] += cell_start[c]
    for i in range(n):
        c = cell_of[i]
        cell_items[cell_start[c]] = i
        cell_start[c] += 1
    for c in range(nc, 0, -1):
        cell_start[c] = cell_start[c - 1]
    cell_start[0] = 0


@kernel
def scan_rows(r0, r1, grid, cell_start, sx, sy, sr, ov_n, ov_b, ol):
    """Overlapping pairs among discs binned in rows [r0, r1), in sorted order.

    Reads the gathered (sorted, contiguous) ``sx, sy, sr``. ``ov_n[a]`` gets the number of
    partners b > a (in the half stencil, ``contacts.half_stencil``) of sorted disc a, the first
    OV_SLOTS of them, in increasing b, in ``ov_b[a]``; the discs with any are listed in
    ``ol`` from the rows' first sorted disc on (returns how many). Each call writes only its
    own rows' discs, so row chunks run in parallel.

    The loop runs over the discs of a row (a disc's column from its x, as it was binned),
    not over the cells: most cells are empty (about 60% at packing 0.3), and a branch on
    that mispredicts. (Testing a fixed window of candidates without branches was slower:
    docs/performance.md.)
    """
    x0, icx = grid[0], grid[2]
    ncx = int(grid[4])
    ncy = int(grid[5])
    m = cell_start[r0 * ncx]
    for cy in range(r0, r1):
        rowc = ncx * cy
        below = cy + 1 < ncy
        for a in range(cell_start[rowc], cell_start[rowc + ncx]):
            xi = sx[a]
            yi = sy[a]
            ri = sr[a]
            cx = cell_coord(xi, icx, x0, ncx)
            c = rowc + cx
            e1 = cell_start[c + 2] if cx + 1 < ncx else cell_start[c + 1]
            if below:
                lo2 = cell_start[c + ncx - 1] if cx > 0 else cell_start[c + ncx]
                hi2 = cell_start[c + ncx + 2] if cx + 1 < ncx else cell_start[c + ncx + 1]
            else:
                lo2 = 0
                hi2 = 0
            k = _overlaps_in(a, a + 1, e1, 0, xi, yi, ri, sx, sy, sr, ov_b)
            k = _overlaps_in(a, lo2, hi2, k, xi, yi, ri, sx, sy, sr, ov_b)
            ov_n[a] = k
            if k > 0:
                ol[m] = a
                m += 1
    return m - cell_start[r0 * ncx]


@njit(cache=True, inline="always")
def _overlaps_in(a, lo, hi, k, xi, yi, ri, sx, sy, sr, ov_b):
    """Note the sorted discs [lo, hi) overlapping disc ``a`` (at xi, yi, radius ri) in its
    overlap slots from count ``k`` on; returns the new count (slots beyond OV_SLOTS are
    counted, not stored)."""
    for b in range(lo, hi):
        dx = sx[b] - xi
        dy = sy[b] - yi
        R = ri + sr[b]
        if dx * dx + dy * dy < R * R:
            if k < OV_SLOTS:
                ov_b[a, k] = b
            k += 1
    return k


@kernel
def gather(lo, hi, cell_items, pos, species, sp_radius, sx, sy, sr):
    for a in range(lo, hi):
        i = cell_items[a]
        sx[a] = pos[i, 0]
        sy[a] = pos[i, 1]
        sr[a] = sp_radius[species[i]]


@kernel(parallel=True)
def _broad_parallel(nch, n, grid, discs, sp_radius, sc):
    """gather and scan_rows in nch chunks; returns how many discs are listed in ``sc.ol``."""
    pos, species = discs.pos, discs.species
    cell_start, cell_items, sx, sy, sr = sc.cell_start, sc.cell_items, sc.sx, sc.sy, sc.sr
    ov_n, ov_b, ol = sc.ov_n, sc.ov_b, sc.ol
    ncx = int(grid[4])
    ncy = int(grid[5])
    for c in prange(nch):
        gather(c * n // nch, (c + 1) * n // nch, cell_items, pos, species, sp_radius, sx, sy, sr)
    starts = np.empty(nch, dtype=np.int64)
    counts = np.empty(nch, dtype=np.int64)
    for c in prange(nch):
        r0 = c * ncy // nch
        starts[c] = cell_start[r0 * ncx]
        counts[c] = scan_rows(r0, (c + 1) * ncy // nch, grid, cell_start, sx, sy, sr, ov_n,
                               ov_b, ol)
    return close_lists(ol, starts, counts)


@kernel
def drift_and_bin(threads, n, h, ph, pl, listed, full, big):
    """Phases 1 and 2 of a substep (``ph``: the :class:`~.structs.Phase`): the drift (and
    wall contacts), then, if the discs collide, the discs sorted into their cells and the
    overlapping pairs found, by the pair list ``pl`` if ``listed`` (built anew if ``full``;
    ``big``: the scene has big discs), else by the scan (in parallel over ``threads`` chunks
    from PARALLEL_MIN discs, as the drift); resets the per-disc event counts.
    Returns the pair list (a new one if it had to grow). ``threads`` None: a single-threaded
    caller; numba prunes the parallel drift and scan and never compiles them. ``pl`` None:
    a caller without pair lists (``step.advance``'s ``lists``); numba prunes them."""
    discs, sp_radius, bounds, grid, sc = ph.discs, ph.tables.sp_radius, ph.bounds, ph.grid, ph.sc
    collide = ph.rc.collide
    pos, species = discs.pos, discs.species
    sc.nlist[1] = 0  # (no scan: no overlapping discs listed)
    par = False
    if threads is not None:
        par = threads > 1 and n >= PARALLEL_MIN
        if par:
            sc.nlist[0] = _drift_parallel(threads, n, h, discs, sp_radius, bounds, grid, sc,
                                          collide)
    if not par:
        sc.nlist[0] = drift_range(np.int64(0), n, h, discs, sp_radius, bounds, grid, sc, collide)
    if collide:
        ncy = int(grid[5])
        cell_start, cell_items = sc.cell_start, sc.cell_items
        sort_cells(n, sc.cell_of, cell_start, cell_items)
        if pl is not None:  # (pruned by numba when None: advance's lists)
            if listed:
                # (a new name: numba 0.59 prunes `pl is None` only where pl is never rebound)
                grown = pl_broad(n, pos, species, sp_radius, grid, sc, pl, full, big)
                # the big discs' positions, for events.queue_initial
                nbc = int(grid[4]) * ncy
                gather(np.int64(cell_start[nbc]), np.int64(cell_start[nbc + 1]), cell_items, pos,
                       species, sp_radius, sc.sx, sc.sy, sc.sr)
                return grown
        if threads is not None:
            if par:
                sc.nlist[1] = _broad_parallel(threads, n, grid, discs, sp_radius, sc)
        if not par:
            gather(np.int64(0), n, cell_items, pos, species, sp_radius, sc.sx, sc.sy, sc.sr)
            sc.nlist[1] = scan_rows(np.int64(0), ncy, grid, cell_start, sc.sx, sc.sy, sc.sr,
                                    sc.ov_n, sc.ov_b, sc.ol)
    return pl
