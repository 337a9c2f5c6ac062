"""Queueing the contacts of a substep (``kernels.events`` and ``kernels.clusters``): an event
appended or pushed, a pair's contact tested and queued, the half stencil of the scan, the
drift's and the scan's lists of the discs with contacts.

The drift lists the discs with a wall contact (or pushed inside) and the scan the sorted
discs with overlapping partners (``Scratch.wl``, ``Scratch.ol``, how many of each in
``Scratch.nlist``; in increasing order), so that queueing the substep's contacts costs
what it queues, not a pass over every disc: fewer than 4% of the discs have either. Each
chunk of a parallel drift (scan) writes its list into its own range of the array, from the
range's start; :func:`close_lists` then moves them together."""

import math

import numpy as np
from numba import njit

from .collisions import pair_time
from .heap import push
from .jit import kernel
from .structs import IC_LEFT_OVERLAPPING, OV_SLOTS


@njit(cache=True, inline="always")
def add_event(H, size, sift, t, i, j, si, sj):
    """Push an event (``sift``) or append it to the unordered rows ``H[0:size]``."""
    if sift:
        return push(H, size, t, i, j, si, sj)
    if size >= H.shape[0]:
        raise IndexError("event list full: room was not reserved (a bug in the caller)")
    H[size, 0] = t
    H[size, 1] = i
    H[size, 2] = j
    H[size, 3] = si
    H[size, 4] = sj
    return size + 1


@njit(cache=True, inline="always")
def try_pair(i, j, discs, sp_radius, tlast, stamp, H, size, icnt, sift=True):
    """Queue the contact of i and j (of ``discs``; ``tlast``, ``stamp``: the
    :class:`~.structs.Scratch` arrays) if they overlap and touched in this step (room for one
    event must be reserved; ``sift`` False: appended, see ``events.queue_initial``); returns
    the new size. A pair left overlapping while separating (``pair_time`` +inf) is counted
    in ``icnt[IC_LEFT_OVERLAPPING]``."""
    # (the indices, size and sift cast here, at each call site: one compiled _try_pair
    # whatever the callers' integer types, and none for literal arguments)
    # (discs whole: a field read here, in the caller's loop, would count a reference; the
    # two arrays of the Scratch, not the Scratch: a call passes every array of its structs)
    return _try_pair(np.int64(i), np.int64(j), discs, sp_radius, tlast, stamp, H,
                     np.int64(size), icnt, np.bool_(sift))


@kernel(_nrt=False)  # (no reference counts of the structs' arrays: it allocates nothing)
def _try_pair(i, j, discs, sp_radius, tlast, stamp, H, size, icnt, sift):
    pos, vel, species = discs.pos, discs.vel, discs.species
    t = pair_time(pos[i, 0], pos[i, 1], vel[i, 0], vel[i, 1], sp_radius[species[i]], tlast[i],
                  pos[j, 0], pos[j, 1], vel[j, 0], vel[j, 1], sp_radius[species[j]], tlast[j])
    if math.isnan(t):
        return size
    if t == math.inf:
        icnt[IC_LEFT_OVERLAPPING] += 1
        return size
    if i < j:
        return add_event(H, size, sift, t, i, j, stamp[i], stamp[j])
    return add_event(H, size, sift, t, j, i, stamp[j], stamp[i])


@kernel
def close_lists(lst, starts, counts):
    """Move the lists of the chunks, ``lst[starts[c]:starts[c] + counts[c]]`` (chunks in
    increasing order of ``starts``, each list within its chunk's range), together to the
    front of ``lst``, in order; returns how many entries there are."""
    m = 0
    for c in range(starts.shape[0]):
        lo = starts[c]
        for p in range(lo, lo + counts[c]):
            lst[m] = lst[p]  # (m <= p: the earlier chunks' lists fit in their ranges)
            m += 1
    return m


@kernel
def half_stencil(c, ncx, ncy, cell_start):
    """The two runs of sorted discs a disc in cell c is compared with (half stencil):
    the rest of its own cell and the next cell in its row, then the three cells below
    (row + 1, columns -1..+1), each contiguous in the sorted order."""
    cx = c % ncx
    cy = c // ncx
    e1 = cell_start[c + 2] if cx + 1 < ncx else cell_start[c + 1]
    if cy + 1 < ncy:
        lo2 = cell_start[c + ncx - 1] if cx > 0 else cell_start[c + ncx]
        hi2 = cell_start[c + ncx + 2] if cx + 1 < ncx else cell_start[c + ncx + 1]
    else:
        lo2 = 0
        hi2 = 0
    return e1, lo2, hi2


@kernel
def queue_scan(a0, a1, discs, sp_radius, sc, grid, H, size, icnt, sift):
    """Queue the contacts of the overlapping pairs the scan found for the sorted discs
    [a0, a1) (listed in ``sc.ol``; ``sc.ov_n``, ``sc.ov_b``: a disc with more partners than
    OV_SLOTS has its half stencil scanned again); room must be reserved (``sc.ov_n`` of
    each). Returns the new size."""
    ncx = int(grid[4])
    ncy = int(grid[5])
    cell_start, cell_items, cell_of = sc.cell_start, sc.cell_items, sc.cell_of
    ov_n, ov_b, ol = sc.ov_n, sc.ov_b, sc.ol
    tlast, stamp = sc.tlast, sc.stamp
    m = sc.nlist[1]
    for p in range(np.searchsorted(ol[:m], a0), m):
        a = ol[p]
        if a >= a1:
            break
        i = cell_items[a]
        k = ov_n[a]
        if k <= OV_SLOTS:
            for q in range(k):
                size = try_pair(i, cell_items[ov_b[a, q]], discs, sp_radius, tlast, stamp, H, size,
                                icnt, sift)
            continue
        e1, lo2, hi2 = half_stencil(cell_of[i], ncx, ncy, cell_start)
        for b in range(a + 1, e1):
            size = try_pair(i, cell_items[b], discs, sp_radius, tlast, stamp, H, size, icnt, sift)
        for b in range(lo2, hi2):
            size = try_pair(i, cell_items[b], discs, sp_radius, tlast, stamp, H, size, icnt, sift)
    return size
