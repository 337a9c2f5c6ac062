"""Who owns which cells in a substep's event phase by clusters (:mod:`.clusters`).

Cells are claimed in blocks of 2^OWN_SHIFT x 2^OWN_SHIFT (one owner entry each): a claim
touches 2-3 cache lines instead of 5-6 rows of the finer array, which at 10^5 discs and more
is out of the L2 cache (docs/performance.md, "The event phase by clusters"). A block holds
the substep's base + an event of the cluster that claimed it; anything below the base is
free, so no block need be freed after a substep. Events that claim the same block are joined
(union-find). During a cluster's run, a disc's search for contacts must stay within its
cluster's blocks (:func:`check_cells`); the repair claims free blocks as it goes.
"""

import numpy as np
from numba import njit

from .jit import kernel

CLAIM = 2  # cells a cluster claims around each disc of its initial events (each side)
OWN_SHIFT = 1
OWN_LIMIT = 2**31 - 1  # (owner entries are int32)

# How a run of the event loop ended: R_OK; for a cluster, why it stopped (kernels.events;
# R_FULL: no room left in its log or records, R_HEAP: in its heap)
R_OK, R_ESCAPE, R_CONFLICT, R_FULL, R_SERIAL, R_HEAP = range(6)


@njit(cache=True, inline="always")
def blocks(grid):
    """The owner blocks' grid: (columns, rows)."""
    m = (1 << OWN_SHIFT) - 1
    return (int(grid[4]) + m) >> OWN_SHIFT, (int(grid[5]) + m) >> OWN_SHIFT


@kernel
def new_owner(grid):
    """The owner of each block of cells for a call's substeps (``clusters.events``): -1,
    none yet; the last entry is the base of the next substep's entries (0)."""
    nbx, nby = blocks(grid)
    own = np.full(nbx * nby + 1, -1, dtype=np.int32)
    own[-1] = 0
    return own


@njit(cache=True, inline="always")
def find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(cache=True, inline="always")
def union(parent, a, b):
    a = find(parent, a)
    b = find(parent, b)
    if a < b:
        parent[b] = a
    elif b < a:
        parent[a] = b


@njit(cache=True, inline="always")
def claim(own, cc, q, base, parent):
    """Event q claims owner block cc (``own``: ``base`` + the event of a block claimed in
    this substep; anything below ``base``: free): a free block becomes its, a block of
    another event joins the two in ``parent``."""
    o = own[cc] - base
    if o < 0:
        own[cc] = base + q
    elif o != q:
        union(parent, q, o)


@njit(cache=True, inline="always")
def check_cells(cx0, cx1, cy0, cy1, grid, cl):
    """Whether the cells [cx0, cx1] x [cy0, cy1] a disc of cluster ``cl`` (a
    ``clusters.ClusterRun``) searches are its own: an event of the cluster owns each one's
    block. Not ``cl.dynamic``: R_ESCAPE at the first that is not. Dynamic (the repair): a
    free block is claimed for the cluster's event ``cl.rep``, a block of another cluster
    (found by ``cl.cparent``) gives R_CONFLICT. Returns ``(code, other cluster)``."""
    nbx = blocks(grid)[0]
    own, base, ecl, cid = cl.own, cl.base, cl.ecl, cl.cid
    for by in range(cy0 >> OWN_SHIFT, (cy1 >> OWN_SHIFT) + 1):
        for bx in range(cx0 >> OWN_SHIFT, (cx1 >> OWN_SHIFT) + 1):
            c = bx + nbx * by
            o = own[c] - base
            if o >= 0 and ecl[o] == cid:
                continue
            if not cl.dynamic:
                return R_ESCAPE, -1
            if o < 0:
                own[c] = base + cl.rep
            else:
                g = find(cl.cparent, ecl[o])
                if g != cid:
                    return R_CONFLICT, g
    return R_OK, -1
