"""Placing discs without overlap: random sequential addition on an incremental grid.

Used for the initial population, for injection and for discs a shrinking wall pushes in.
The grid is a linked list per cell (``head``/``nxt``) so discs can be added one by one.
The bounds are a :class:`~discgym.kernels.structs.Bounds` (only its ``kind`` and ``params``
are read); the entry points called from Python take it as a plain tuple of its fields.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .celllist import cell_coord, make_grid
from .jit import kernel
from .structs import BOX, INDEX, Bounds
from .walls import inside


class Occupied(NamedTuple):
    """The discs placed so far, binned for the free-spot test (:func:`_free`)."""

    pos: np.ndarray  #: (C, 2) FLOAT positions (only the binned discs are read)
    species: np.ndarray  #: (C,) INDEX species index
    sp_radius: np.ndarray  #: (S,) FLOAT
    grid: np.ndarray  #: the grid's geometry (kernels.celllist.make_grid)
    head: np.ndarray  #: (cells,) INDEX the last disc binned in each cell, -1: none
    nxt: np.ndarray  #: (C,) INDEX the disc binned before it in its cell, -1: none
    rmax: float  #: the largest radius


@kernel
def _occupied(pos, species, sp_radius, bounds, slots):
    """An empty grid over ``bounds`` for up to ``slots`` discs of ``pos``."""
    rmax = sp_radius.max()
    grid = make_grid(bounds.kind, bounds.params, rmax, slots)
    head = np.full(int(grid[4]) * int(grid[5]), -1, dtype=INDEX)
    nxt = np.full(max(slots, 1), -1, dtype=INDEX)
    return Occupied(pos, species, sp_radius, grid, head, nxt, rmax)


@kernel
def _cell(x, y, grid):
    return cell_coord(x, grid[2], grid[0], int(grid[4])) + int(grid[4]) * cell_coord(
        y, grid[3], grid[1], int(grid[5]))


@kernel
def _bin(occ, k, x, y):
    """Bin disc k, at (x, y)."""
    c = _cell(x, y, occ.grid)
    occ.nxt[k] = occ.head[c]
    occ.head[c] = k


@kernel
def _free(x, y, r, occ):
    """Whether a disc of radius r at (x, y) overlaps none of the binned discs."""
    grid = occ.grid
    reach = r + occ.rmax
    cx0 = cell_coord(x - reach, grid[2], grid[0], int(grid[4]))
    cx1 = cell_coord(x + reach, grid[2], grid[0], int(grid[4]))
    cy0 = cell_coord(y - reach, grid[3], grid[1], int(grid[5]))
    cy1 = cell_coord(y + reach, grid[3], grid[1], int(grid[5]))
    ncx = int(grid[4])
    for cy in range(cy0, cy1 + 1):
        for cx in range(cx0, cx1 + 1):
            k = occ.head[cx + ncx * cy]
            while k >= 0:
                R = r + occ.sp_radius[occ.species[k]]
                dx = occ.pos[k, 0] - x
                dy = occ.pos[k, 1] - y
                if dx * dx + dy * dy < R * R:
                    return False
                k = occ.nxt[k]
    return True


@kernel
def _sample(r, bounds, rng):
    b = bounds.params
    if bounds.kind == BOX:
        x = b[0] + r + (b[2] - b[0] - 2.0 * r) * rng.random()
        y = b[1] + r + (b[3] - b[1] - 2.0 * r) * rng.random()
        return x, y
    L = b[2] - r
    rho = L * math.sqrt(rng.random())
    a = 2.0 * math.pi * rng.random()
    return b[0] + rho * math.cos(a), b[1] + rho * math.sin(a)


@kernel
def _clamp_inside(x, y, r, bounds):
    b = bounds.params
    if bounds.kind == BOX:
        return min(max(x, b[0] + r), b[2] - r), min(max(y, b[1] + r), b[3] - r)
    dx = x - b[0]
    dy = y - b[1]
    L = b[2] - r
    d = math.sqrt(dx * dx + dy * dy)
    if d > L:
        if d > 0.0:
            return b[0] + dx * (L / d), b[1] + dy * (L / d)
        return b[0], b[1]
    return x, y


@kernel
def _place_one(tx, ty, r, occ, bounds, rng, attempts):
    """A free spot for a disc of radius r: at the target (tx, ty) clamped inside if free,
    then at random points ever farther around it, then anywhere in the bounds (NaN target:
    anywhere), ``attempts`` tries in all. Returns ``(found, x, y)``."""
    x = tx
    y = ty
    for a in range(attempts):
        if not math.isnan(tx) and a < attempts // 2:
            if a == 0:
                x, y = _clamp_inside(tx, ty, r, bounds)
            else:
                spread = r * (1.0 + 0.25 * a)
                ang = 2.0 * math.pi * rng.random()
                x, y = _clamp_inside(tx + spread * math.cos(ang), ty + spread * math.sin(ang),
                                     r, bounds)
        else:
            x, y = _sample(r, bounds, rng)
        if _free(x, y, r, occ):
            return True, x, y
    return False, x, y


@kernel
def place(pos, species, n, todo, targets, sp_radius, bounds, rng, attempts):
    """Place discs of species ``todo`` (M,) after the n placed ones; returns how many fit.

    ``targets`` (M, 2): where each disc should go if that spot is free (NaN: anywhere); see
    :func:`_place_one`. Placing stops at the first disc that finds no room (the rest are left
    for the caller to report). The discs [0, n) must not overlap each other; they are not
    moved.
    """
    m = todo.shape[0]
    occ = _occupied(pos, species, sp_radius, bounds, n + m)
    for k in range(n):
        _bin(occ, k, pos[k, 0], pos[k, 1])
    for q in range(m):
        s = todo[q]
        k = n + q
        species[k] = s
        ok, x, y = _place_one(targets[q, 0], targets[q, 1], sp_radius[s], occ, bounds, rng,
                              attempts)
        if not ok:
            species[k] = -1
            return q
        pos[k, 0] = x
        pos[k, 1] = y
        _bin(occ, k, x, y)
    return m


@kernel
def relocate(pos, species, n, sp_radius, bounds, rng, attempts):
    """Move each disc of [0, n) that lies outside the bounds (after they shrank) to the
    nearest free spot found inside (:func:`_place_one`, its position as the target), in disc
    order; the discs inside stay put. Returns the number of discs that found no room: if
    any, ``pos`` is left unchanged (the caller refuses the resize)."""
    work = pos[:n].copy()
    occ = _occupied(work, species, sp_radius, bounds, n)
    out = np.empty(n, dtype=INDEX)
    m = 0
    for k in range(n):
        if inside(work[k, 0], work[k, 1], sp_radius[species[k]], bounds.kind, bounds.params):
            _bin(occ, k, work[k, 0], work[k, 1])
        else:
            out[m] = k
            m += 1
    for q in range(m):
        k = out[q]
        ok, x, y = _place_one(work[k, 0], work[k, 1], sp_radius[species[k]], occ, bounds, rng,
                              attempts)
        if not ok:
            return m - q
        work[k, 0] = x
        work[k, 1] = y
        _bin(occ, k, x, y)
    for k in range(n):  # (a loop: numba's slice assignment compiles a formatted error)
        pos[k, 0] = work[k, 0]
        pos[k, 1] = work[k, 1]
    return 0


@njit(cache=True)
def overlapping_pairs(pos, species, n, sp_radius, bounds, tol):
    """Count pairs among [0, n) overlapping by more than ``tol`` (relative to R_i + R_j);
    ``bounds`` a plain tuple of the fields of a :class:`~discgym.kernels.structs.Bounds`."""
    occ = _occupied(pos, species, sp_radius, Bounds(*bounds), n)
    grid = occ.grid
    head = occ.head
    nxt = occ.nxt
    rmax = occ.rmax
    count = 0
    for i in range(n):
        x = pos[i, 0]
        y = pos[i, 1]
        r = sp_radius[species[i]]
        reach = r + rmax
        ncx = int(grid[4])
        cx0 = cell_coord(x - reach, grid[2], grid[0], ncx)
        cx1 = cell_coord(x + reach, grid[2], grid[0], ncx)
        cy0 = cell_coord(y - reach, grid[3], grid[1], int(grid[5]))
        cy1 = cell_coord(y + reach, grid[3], grid[1], int(grid[5]))
        for cy in range(cy0, cy1 + 1):
            for cx in range(cx0, cx1 + 1):
                k = head[cx + ncx * cy]
                while k >= 0:
                    R = (r + sp_radius[species[k]]) * (1.0 - tol)
                    dx = pos[k, 0] - x
                    dy = pos[k, 1] - y
                    if dx * dx + dy * dy < R * R:
                        count += 1
                    k = nxt[k]
        _bin(occ, i, x, y)
    return count


@njit(cache=True)
def place_rngs(pos, species, n, todo, targets, sp_radius, bounds, rngs, attempts):
    """:func:`place` called from Python: ``bounds`` a plain tuple of the fields of a
    :class:`~discgym.kernels.structs.Bounds`, the generator as ``rngs[0]`` (a
    ``numba.typed.List``; see :func:`discgym.kernels.step.advance_rngs`)."""
    return place(pos, species, n, todo, targets, sp_radius, Bounds(*bounds), rngs[0], attempts)
