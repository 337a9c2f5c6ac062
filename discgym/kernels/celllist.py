"""The O(N) neighbour grid (a cell list built by counting sort), with a separate class for
the few large discs of a polydisperse scene.

Cells are at least one diameter of the *cell radius* ``rcell`` wide, so two overlapping discs
no larger than ``rcell`` lie in the same or in adjacent cells; cells are also made wide enough
that there are at most about two per disc, so a huge box with few tiny discs does not
allocate a huge grid. Discs outside the grid (a disc that has just crossed a wall) are binned
into the nearest edge cell, which keeps adjacency.

Discs larger than ``rcell`` ("big") are not binned in the cells at all but in one extra cell,
index ``ncx * ncy`` (so ``cell_start`` has ``ncx * ncy + 2`` entries), which every search
scans in full. :func:`cell_radius` makes a species big only when it is much larger than the
others and its discs are few, so a 1:50 polydisperse scene keeps cells sized by its small
discs (no cost cliff: without the class, 20 discs of radius 5 among 20000 of radius 0.1 made
the cells 10 wide and the cost per disc 80x); a scene without such species has rcell = the
largest radius and an empty big cell.

``grid`` is a float vector (x0, y0, 1/cell_w, 1/cell_h, ncx, ncy, rcell).
"""

import math

import numpy as np
from numba import njit

from .jit import kernel
from .structs import FLOAT

MAX_CELLS = 1 << 26
BIG_RATIO = 2.0  # a big species is more than this many times larger than rcell
BIG_SHARE = 1.0 / 32.0  # ... and holds at most this share of the discs (or BIG_MIN of them)
BIG_MIN = 32


@kernel
def cell_radius(species, n, sp_radius):
    """The cell radius for discs [0, n): the smallest species radius r such that the discs
    larger than BIG_RATIO * r are at most max(BIG_MIN, BIG_SHARE * n) (the largest radius,
    which always qualifies, when no smaller one does)."""
    S = sp_radius.shape[0]
    count = np.zeros(S, dtype=np.int64)
    for i in range(n):
        if species[i] >= 0:
            count[species[i]] += 1
    limit = max(BIG_MIN, int(BIG_SHARE * n))
    best = sp_radius.max()
    for s in range(S):
        rc = sp_radius[s]
        if rc >= best:
            continue
        big = 0
        for q in range(S):
            if sp_radius[q] > rc and sp_radius[q] <= BIG_RATIO * rc:
                big = limit + 1  # a species between rc and BIG_RATIO rc: rc too small
                break
            if sp_radius[q] > BIG_RATIO * rc:
                big += count[q]
        if big <= limit:
            best = rc
    return best


@kernel
def make_grid(bounds_kind, bounds_params, rcell, n):
    b = bounds_params
    if bounds_kind == 0:
        x0, y0, x1, y1 = b[0], b[1], b[2], b[3]
    else:
        x0, y0, x1, y1 = b[0] - b[2], b[1] - b[2], b[0] + b[2], b[1] + b[2]
    w = x1 - x0
    h = y1 - y0
    cs = max(2.0 * rcell, math.sqrt(w * h / max(2 * n, 1)), math.sqrt(w * h / MAX_CELLS))
    ncx = max(1, int(w / cs))
    ncy = max(1, int(h / cs))
    grid = np.empty(7, dtype=FLOAT)
    grid[0] = x0
    grid[1] = y0
    grid[2] = ncx / w
    grid[3] = ncy / h
    grid[4] = ncx
    grid[5] = ncy
    grid[6] = rcell
    return grid


@kernel
def big_cell(grid):
    """Index of the extra cell holding the big discs (see the module docstring)."""
    return int(grid[4]) * int(grid[5])


@kernel
def cell_coord(x, icw, x0, nc):
    """Column (or row) of coordinate x in a grid of nc cells of inverse width icw from x0,
    clamped to [0, nc - 1] before the conversion to an integer (a disc far outside, or a
    search reach far larger than the grid, must not overflow int64: NaN goes to 0 too)."""
    f = (x - x0) * icw
    if not f > 0.0:
        return 0
    if f >= nc:
        return nc - 1
    return int(f)


@kernel
def build(n, pos, species, sp_radius, grid, cell_start, cell_items, cell_of):
    """Counting sort of the live discs (species >= 0) into cells (big discs into the big cell).

    Fills ``cell_start`` (ncells + 2,) and ``cell_items`` (n,); ``cell_of`` (n,) gets each
    disc's cell (-1 for dead discs). Returns the number of discs binned.
    """
    x0, y0, icx, icy = grid[0], grid[1], grid[2], grid[3]
    ncx = int(grid[4])
    ncy = int(grid[5])
    rcell = grid[6]
    nc = ncx * ncy + 1
    for c in range(nc + 1):
        cell_start[c] = 0
    for i in range(n):
        if species[i] < 0:
            cell_of[i] = -1
            continue
        if sp_radius[species[i]] > rcell:
            c = nc - 1
        else:
            c = cell_coord(pos[i, 0], icx, x0, ncx) + ncx * cell_coord(pos[i, 1], icy, y0, ncy)
        cell_of[i] = c
        cell_start[c + 1] += 1
    for c in range(nc):
        cell_start[c + 1] += cell_start[c]
    # fill using cell_start as cursors, then shift back
    for i in range(n):
        c = cell_of[i]
        if c >= 0:
            cell_items[cell_start[c]] = i
            cell_start[c] += 1
    for c in range(nc, 0, -1):
        cell_start[c] = cell_start[c - 1]
    cell_start[0] = 0
    return cell_start[nc]


@kernel
def cell_range(x, y, reach, grid):
    """Cells (cx0, cx1, cy0, cy1), inclusive, covering the square of half-side ``reach``."""
    x0, y0, icx, icy = grid[0], grid[1], grid[2], grid[3]
    ncx = int(grid[4])
    ncy = int(grid[5])
    return (cell_coord(x - reach, icx, x0, ncx), cell_coord(x + reach, icx, x0, ncx),
            cell_coord(y - reach, icy, y0, ncy), cell_coord(y + reach, icy, y0, ncy))


@kernel
def overlaps_any(x, y, r, t, ex1, ex2, discs, sp_radius, search):
    """Does a disc of radius r at (x, y) at time t (<= 0, relative to the end of the substep)
    overlap any live disc of ``discs`` other than ex1 and ex2, each taken at ``pos + t * vel``
    on its current straight trajectory (exact for a time no earlier than every disc's latest
    event, as holds for an event being processed in time order)?

    ``search`` (a :class:`~.structs.Search`): discs [0, nbin) are in its grid, binned at
    positions at most ``reach - rcell`` away from where they are at time t (the big discs, in
    the big cell, are all checked); discs [nbin, n) were created since and are checked one
    by one. Touching is not overlapping.
    """
    pos, vel, species = discs.pos, discs.vel, discs.species
    grid, cell_start, cell_items = search.grid, search.cell_start, search.cell_items
    cx0, cx1, cy0, cy1 = cell_range(x, y, r + search.reach, grid)
    ncx = int(grid[4])
    for cy in range(cy0, cy1 + 1):
        for a in range(cell_start[cx0 + ncx * cy], cell_start[cx1 + 1 + ncx * cy]):
            k = cell_items[a]
            if _hits(x, y, r, t, k, ex1, ex2, pos, vel, species, sp_radius):
                return True
    nb = big_cell(grid)
    for a in range(cell_start[nb], cell_start[nb + 1]):
        if _hits(x, y, r, t, cell_items[a], ex1, ex2, pos, vel, species, sp_radius):
            return True
    for k in range(search.nbin, search.n):
        if _hits(x, y, r, t, k, ex1, ex2, pos, vel, species, sp_radius):
            return True
    return False


@njit(cache=True, inline="always")
def _hits(x, y, r, t, k, ex1, ex2, pos, vel, species, sp_radius):
    if k == ex1 or k == ex2 or species[k] < 0:
        return False
    R = r + sp_radius[species[k]]
    dx = pos[k, 0] + t * vel[k, 0] - x
    dy = pos[k, 1] + t * vel[k, 1] - y
    return dx * dx + dy * dy < R * R
