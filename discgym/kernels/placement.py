"""Placing discs without overlap: random sequential addition on an incremental grid.

Used for the initial population, for injection and for discs a shrinking wall pushes in.
The grid is a linked list per cell (``head``/``nxt``) so discs can be added one by one.
"""

import math

import numpy as np
from numba import njit

from .celllist import cell_coord, make_grid
from .jit import kernel
from .structs import INDEX
from .walls import inside


@kernel
def _cell(x, y, grid):
    return cell_coord(x, grid[2], grid[0], int(grid[4])) + int(grid[4]) * cell_coord(
        y, grid[3], grid[1], int(grid[5]))


@kernel
def _free(x, y, r, pos, species, sp_radius, grid, head, nxt, rmax):
    reach = r + rmax
    cx0 = cell_coord(x - reach, grid[2], grid[0], int(grid[4]))
    cx1 = cell_coord(x + reach, grid[2], grid[0], int(grid[4]))
    cy0 = cell_coord(y - reach, grid[3], grid[1], int(grid[5]))
    cy1 = cell_coord(y + reach, grid[3], grid[1], int(grid[5]))
    ncx = int(grid[4])
    for cy in range(cy0, cy1 + 1):
        for cx in range(cx0, cx1 + 1):
            k = head[cx + ncx * cy]
            while k >= 0:
                R = r + sp_radius[species[k]]
                dx = pos[k, 0] - x
                dy = pos[k, 1] - y
                if dx * dx + dy * dy < R * R:
                    return False
                k = nxt[k]
    return True


@kernel
def _sample(r, bounds_kind, bounds_params, rng):
    if bounds_kind == 0:
        x = bounds_params[0] + r + (bounds_params[2] - bounds_params[0] - 2.0 * r) * rng.random()
        y = bounds_params[1] + r + (bounds_params[3] - bounds_params[1] - 2.0 * r) * rng.random()
        return x, y
    L = bounds_params[2] - r
    rho = L * math.sqrt(rng.random())
    a = 2.0 * math.pi * rng.random()
    return bounds_params[0] + rho * math.cos(a), bounds_params[1] + rho * math.sin(a)


@kernel
def _clamp_inside(x, y, r, bounds_kind, bounds_params):
    if bounds_kind == 0:
        b = bounds_params
        return min(max(x, b[0] + r), b[2] - r), min(max(y, b[1] + r), b[3] - r)
    dx = x - bounds_params[0]
    dy = y - bounds_params[1]
    L = bounds_params[2] - r
    d = math.sqrt(dx * dx + dy * dy)
    if d > L:
        if d > 0.0:
            return bounds_params[0] + dx * (L / d), bounds_params[1] + dy * (L / d)
        return bounds_params[0], bounds_params[1]
    return x, y


@kernel
def _place_one(tx, ty, r, pos, species, sp_radius, bounds_kind, bounds_params, grid, head, nxt,
               rmax, rng, attempts):
    """A free spot for a disc of radius r: at the target (tx, ty) clamped inside if free,
    then at random points ever farther around it, then anywhere in the bounds (NaN target:
    anywhere), ``attempts`` tries in all. Returns ``(found, x, y)``."""
    x = tx
    y = ty
    for a in range(attempts):
        if not math.isnan(tx) and a < attempts // 2:
            if a == 0:
                x, y = _clamp_inside(tx, ty, r, bounds_kind, bounds_params)
            else:
                spread = r * (1.0 + 0.25 * a)
                ang = 2.0 * math.pi * rng.random()
                x, y = _clamp_inside(tx + spread * math.cos(ang), ty + spread * math.sin(ang),
                                     r, bounds_kind, bounds_params)
        else:
            x, y = _sample(r, bounds_kind, bounds_params, rng)
        if _free(x, y, r, pos, species, sp_radius, grid, head, nxt, rmax):
            return True, x, y
    return False, x, y


@kernel
def place(pos, species, n, todo, targets, sp_radius, bounds_kind, bounds_params, rng, attempts):
    """Place discs of species ``todo`` (M,) after the n placed ones; returns how many fit.

    ``targets`` (M, 2): where each disc should go if that spot is free (NaN: anywhere); see
    :func:`_place_one`. Placing stops at the first disc that finds no room (the rest are left
    for the caller to report). The discs [0, n) must not overlap each other; they are not
    moved.
    """
    m = todo.shape[0]
    rmax = sp_radius.max()
    grid = make_grid(bounds_kind, bounds_params, rmax, n + m)
    ncells = int(grid[4]) * int(grid[5])
    head = np.full(ncells, -1, dtype=INDEX)
    nxt = np.full(n + m, -1, dtype=INDEX)
    for k in range(n):
        c = _cell(pos[k, 0], pos[k, 1], grid)
        nxt[k] = head[c]
        head[c] = k
    for q in range(m):
        s = todo[q]
        k = n + q
        species[k] = s
        ok, x, y = _place_one(targets[q, 0], targets[q, 1], sp_radius[s], pos, species, sp_radius,
                              bounds_kind, bounds_params, grid, head, nxt, rmax, rng, attempts)
        if not ok:
            species[k] = -1
            return q
        pos[k, 0] = x
        pos[k, 1] = y
        c = _cell(x, y, grid)
        nxt[k] = head[c]
        head[c] = k
    return m


@kernel
def relocate(pos, species, n, sp_radius, bounds_kind, bounds_params, rng, attempts):
    """Move each disc of [0, n) that lies outside the bounds (after they shrank) to the
    nearest free spot found inside (:func:`_place_one`, its position as the target), in disc
    order; the discs inside stay put. Returns the number of discs that found no room: if
    any, ``pos`` is left unchanged (the caller refuses the resize)."""
    rmax = sp_radius.max()
    grid = make_grid(bounds_kind, bounds_params, rmax, n)
    ncells = int(grid[4]) * int(grid[5])
    head = np.full(ncells, -1, dtype=INDEX)
    nxt = np.full(max(n, 1), -1, dtype=INDEX)
    work = pos[:n].copy()
    out = np.empty(n, dtype=INDEX)
    m = 0
    for k in range(n):
        r = sp_radius[species[k]]
        if inside(work[k, 0], work[k, 1], r, bounds_kind, bounds_params):
            c = _cell(work[k, 0], work[k, 1], grid)
            nxt[k] = head[c]
            head[c] = k
        else:
            out[m] = k
            m += 1
    for q in range(m):
        k = out[q]
        ok, x, y = _place_one(work[k, 0], work[k, 1], sp_radius[species[k]], work, species,
                              sp_radius,
                              bounds_kind, bounds_params, grid, head, nxt, rmax, rng, attempts)
        if not ok:
            return m - q
        work[k, 0] = x
        work[k, 1] = y
        c = _cell(x, y, grid)
        nxt[k] = head[c]
        head[c] = k
    for k in range(n):  # (a loop: numba's slice assignment compiles a formatted error)
        pos[k, 0] = work[k, 0]
        pos[k, 1] = work[k, 1]
    return 0


@njit(cache=True)
def overlapping_pairs(pos, species, n, sp_radius, bounds_kind, bounds_params, tol):
    """Count pairs among [0, n) overlapping by more than ``tol`` (relative to R_i + R_j)."""
    rmax = sp_radius.max()
    grid = make_grid(bounds_kind, bounds_params, rmax, n)
    ncells = int(grid[4]) * int(grid[5])
    head = np.full(ncells, -1, dtype=INDEX)
    nxt = np.full(max(n, 1), -1, dtype=INDEX)
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
        c = _cell(x, y, grid)
        nxt[i] = head[c]
        head[c] = i
    return count


@njit(cache=True)
def place_rngs(pos, species, n, todo, targets, sp_radius, bounds_kind, bounds_params, rngs,
               attempts):
    """:func:`place` with its generator passed as ``rngs[0]`` (a ``numba.typed.List``; see
    :func:`discgym.kernels.step.advance_rngs`)."""
    return place(pos, species, n, todo, targets, sp_radius, bounds_kind, bounds_params, rngs[0],
                 attempts)


@kernel
def relocate_rngs(pos, species, n, sp_radius, bounds_kind, bounds_params, rngs, attempts):
    """:func:`relocate` with its generator passed as ``rngs[0]`` (a ``numba.typed.List``)."""
    return relocate(pos, species, n, sp_radius, bounds_kind, bounds_params, rngs[0], attempts)
