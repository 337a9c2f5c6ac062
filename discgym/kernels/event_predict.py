"""The exact integrator's look-ahead: its grid of cells and each disc's next event.

- The grid (:class:`~.event_structs.Cells`): cells at least one largest diameter wide, each
  disc in the doubly linked list of its cell (:func:`make_cells`, :func:`cell_insert`,
  :func:`cell_remove`, :func:`cell_move`), so that a disc meets only the discs of its own and
  the 8 adjacent cells.
- The prediction (:func:`predict`): a disc's earliest event (contact, wall, cell crossing,
  first-order reaction) into its row of :class:`~.event_structs.Queue` and the heap; after a
  crossing only the 3 cells that have just become adjacent are scanned. Reaction times are
  drawn by :func:`next_reaction`.
- :func:`has_room`: whether a new disc fits (products of a reaction), by the same grid.

A disc flies on a straight line between its events, its row of
:class:`~.event_structs.Flights` the start of its path (:func:`fly_to` brings it along,
:func:`set_kind` gives it its species' radius and mass).
"""

import math

import numpy as np
from numba import njit

from .celllist import cell_coord
from .event_structs import (
    EV_CELL,
    EV_NONE,
    EV_REACT,
    EV_WALL,
    KEPT_AUX,
    KEPT_CODE,
    KEPT_STAMP,
    KEPT_T,
    NEXT_AUX,
    NEXT_CODE,
    NEXT_STAMP,
    NEXT_T,
    PM,
    PR,
    PT,
    PVX,
    PVY,
    PX,
    PY,
    Cells,
)
from .heap import heap_set
from .jit import kernel
from .reactions import first_order_rate
from .structs import INDEX
from .walls import box_next, circle_next, inside

INF = math.inf

# A pair is approaching when r.w < 0 with (r.w)^2 > APPROACH2 |r|^2 |w|^2 (r = r_j - r_i,
# w = v_j - v_i): a contact closer to tangential than 1e-10 rad, or a touching pair whose
# normal speeds agree to 1e-10 of their relative speed (after an e = 0 collision), is not a
# collision (its impulse would be lost in round-off and the pair predicted again at once).
APPROACH2 = 1e-20
MAX_CELLS = 1 << 26
CELL_MARGIN = 1e-9  # cells are this fraction wider than the largest contact distance


# ------------------------------------------------------------------------------ the cells
@kernel
def make_cells(n, cap, run, cells_per_disc):
    """The grid over the bounds (one cell when discs do not collide), no disc in it yet."""
    b0, b1, b2, b3 = run.b0, run.b1, run.b2, run.b3
    if run.bounds_kind == 0:
        gx0, gy0, gx1, gy1 = b0, b1, b2, b3
    else:
        gx0, gy0, gx1, gy1 = b0 - b2, b1 - b2, b0 + b2, b1 + b2
    gw = gx1 - gx0
    gh = gy1 - gy0
    ncx = 1
    ncy = 1
    if run.collide:
        cs = max(2.0 * run.rmax * (1.0 + CELL_MARGIN),
                 math.sqrt(gw * gh / max(cells_per_disc * n, 1.0)),
                 math.sqrt(gw * gh / MAX_CELLS))
        ncx = max(1, int(gw / cs))
        ncy = max(1, int(gh / cs))
    return Cells(gx0, gy0, gw / ncx, gh / ncy, ncx / gw, ncy / gh, ncx, ncy,
                 np.full(ncx * ncy, -1, dtype=INDEX), np.full(cap, -1, dtype=INDEX),
                 np.full(cap, -1, dtype=INDEX), np.full(cap, -1, dtype=INDEX))


@njit(cache=True, inline="always")
def cell_of(x, y, cells):
    """The cell of point (x, y) (clamped to the grid)."""
    return cell_coord(x, cells.iw, cells.x0, cells.ncx) + cells.ncx * cell_coord(
        y, cells.ih, cells.y0, cells.ncy)


@njit(cache=True, inline="always")
def cell_insert(d, c, cells):
    """Disc d at the head of the list of cell c."""
    cell, head, nxt, prv = cells.cell, cells.head, cells.nxt, cells.prv
    cell[d] = c
    h = head[c]
    nxt[d] = h
    prv[d] = -1
    if h >= 0:
        prv[h] = d
    head[c] = d


@njit(cache=True, inline="always")
def cell_remove(d, cells):
    """Disc d out of the list of its cell."""
    cell, head, nxt, prv = cells.cell, cells.head, cells.nxt, cells.prv
    c = cell[d]
    a = prv[d]
    b = nxt[d]
    if a >= 0:
        nxt[a] = b
    else:
        head[c] = b
    if b >= 0:
        prv[b] = a
    cell[d] = -1


@njit(cache=True, inline="always")
def cell_move(d, x, y, cells):
    """Disc d, now at (x, y), into the list of its cell there (last: the list order is the
    order neighbours are scanned in)."""
    cell_remove(d, cells)
    cell_insert(d, cell_of(x, y, cells), cells)


# ------------------------------------------------------------------------ the prediction
@njit(cache=True, inline="always")
def set_kind(d, s, W, tables):
    """Disc d's radius and mass columns for its (new) species s."""
    W[d, PR] = tables.sp_radius[s]
    W[d, PM] = tables.sp_mass[s]


@njit(cache=True, inline="always")
def fly_to(d, t, W):
    """Bring disc d along its path to time t."""
    dt = t - W[d, PT]
    W[d, PX] += dt * W[d, PVX]
    W[d, PY] += dt * W[d, PVY]
    W[d, PT] = t


@njit(cache=True, inline="always")
def next_reaction(d, T, fl, tables, rng, always, floor):
    """Recompute disc d's first-order rate K; draw a new reaction time if K changed (or if
    ``always``), no sooner than ``floor`` after T (0: the exact exponential time)."""
    K = first_order_rate(d, tables, fl.species, fl.internal_energy)
    if K != fl.rate[d] or always:
        fl.rate[d] = K
        if K > 0.0:
            fl.t_reaction[d] = T + max(-math.log1p(-rng.random()) / K, floor)
        else:
            fl.t_reaction[d] = INF


@njit(cache=True, inline="always")
def _scan_range(cx, cy, ncx, ncy, entered):
    """Cells (qx0, qx1, qy0, qy1), half open, to scan for contacts from cell (cx, cy): all
    3 x 3 around (``entered`` 0), or the strip that has just become adjacent after a crossing
    (``entered``: 1 +x, 2 -x, 3 +y, 4 -y)."""
    qx0 = max(cx - 1, 0)
    qx1 = min(cx + 2, ncx)
    qy0 = max(cy - 1, 0)
    qy1 = min(cy + 2, ncy)
    if entered == 1:
        qx0 = cx + 1
    elif entered == 2:
        qx1 = cx
    elif entered == 3:
        qy0 = cy + 1
    elif entered == 4:
        qy1 = cy
    return qx0, qx1, qy0, qy1


@njit(cache=True, inline="always")
def _exit_time(p, v, c, nc, p0, w):
    """Time until a coordinate p moving at v leaves cell c of a row of nc cells of width w
    from p0 (inf if it never does, or only out of the grid: a wall comes first)."""
    if v > 0.0:
        if c < nc - 1:
            return (p0 + (c + 1) * w - p) / v
    elif v < 0.0:
        if c > 0:
            return (p0 + c * w - p) / v
    return INF


@njit(cache=True, inline="always")
def _crossing_time(x, y, vx, vy, cx, cy, cells):
    """Time until disc at (x, y) with velocity v leaves cell (cx, cy), and the cell it
    enters (none out of the grid: a wall comes first; (inf, -1) if it never does)."""
    ncx = cells.ncx
    tx = _exit_time(x, vx, cx, ncx, cells.x0, cells.w)
    ty = _exit_time(y, vy, cy, cells.ncy, cells.y0, cells.h)
    c = cx + ncx * cy
    if tx <= ty:
        return tx, c + 1 if vx > 0.0 else c - 1
    return ty, c + ncx if vy > 0.0 else c - ncx


@njit(cache=True, inline="always")
def _earliest_contact(d, T, W, cells, span, best, code, aux):
    """The earliest contact of disc d (at time T) with the discs of the cells ``span`` =
    (qx0, qx1, qy0, qy1), half open, if before ``best`` (relative to T): ``(time, partner,
    0)``, else ``(best, code, aux)`` as given."""
    head, nxt, ncx = cells.head, cells.nxt, cells.ncx
    qx0, qx1, qy0, qy1 = span
    x = W[d, PX]
    y = W[d, PY]
    vx = W[d, PVX]
    vy = W[d, PVY]
    r = W[d, PR]
    for qy in range(qy0, qy1):
        for qx in range(qx0, qx1):
            k = head[qx + ncx * qy]
            while k >= 0:
                if k != d:
                    dtk = T - W[k, PT]
                    wx = W[k, PVX] - vx
                    wy = W[k, PVY] - vy
                    rx = W[k, PX] + dtk * W[k, PVX] - x
                    ry = W[k, PY] + dtk * W[k, PVY] - y
                    b = rx * wx + ry * wy
                    vv = wx * wx + wy * wy
                    rr = rx * rx + ry * ry
                    if b < 0.0 and b * b > APPROACH2 * rr * vv:
                        R = r + W[k, PR]
                        cc = rr - R * R
                        D = b * b - vv * cc
                        if D > 0.0:
                            tk = cc / (math.sqrt(D) - b)
                            if tk < best:
                                best = max(tk, 0.0)
                                code = k
                                aux = 0
                k = nxt[k]
    return best, code, aux


@kernel(_nrt=False, inline_code=True)  # (see _event_loop)
def predict(d, T, fl, cells, queue, run, entered):
    """Find disc d's earliest event after T (d must be at time T: ``path[d, PT] == T``),
    store it in ``event[d, NEXT_*]`` and in the heap.

    ``event[d, KEPT_*]`` keeps the earliest event other than a cell crossing, so that after a
    crossing (``entered`` the direction, see :func:`_scan_range`; 0 for a full prediction)
    only the 3 cells that have just become adjacent need a scan, unless that event's partner
    has changed since.
    """
    W = fl.path
    stamp = fl.stamp
    Ev = queue.event
    ncx = cells.ncx
    x = W[d, PX]
    y = W[d, PY]
    vx = W[d, PVX]
    vy = W[d, PVY]
    r = W[d, PR]
    c = cells.cell[d]
    cx = c % ncx
    cy = c // ncx
    if entered != 0:
        q = int(Ev[d, KEPT_CODE])
        if q >= 0 and stamp[q] != int(Ev[d, KEPT_STAMP]):
            entered = 0  # the kept event is stale: predict afresh
    if entered == 0:
        best = fl.t_reaction[d] - T  # times relative to T from here on
        code = EV_REACT if best < INF else EV_NONE
        aux = 0
        if run.bounds_kind == 0:
            tw, axis = box_next(x, y, vx, vy, r, run.b0, run.b1, run.b2, run.b3)
        else:
            tw, axis = circle_next(x, y, vx, vy, r, run.b0, run.b1, run.b2)
        if tw < best:
            best = tw
            code = EV_WALL
            aux = axis
    else:
        best = Ev[d, KEPT_T] - T
        code = int(Ev[d, KEPT_CODE])
        aux = int(Ev[d, KEPT_AUX])
    collide = run.collide
    if collide:
        # contacts with the discs of the cells around (all 3 x 3, or the new strip)
        span = _scan_range(cx, cy, ncx, cells.ncy, entered)
        best, code, aux = _earliest_contact(d, T, W, cells, span, best, code, aux)
    t = T + best
    Ev[d, KEPT_T] = t
    Ev[d, KEPT_CODE] = code
    Ev[d, KEPT_STAMP] = stamp[code] if code >= 0 else 0
    Ev[d, KEPT_AUX] = aux
    if collide:
        tx, a = _crossing_time(x, y, vx, vy, cx, cy, cells)
        if tx < best:
            best = max(tx, 0.0)
            code = EV_CELL
            aux = a
        t = T + best
    Ev[d, NEXT_T] = t
    Ev[d, NEXT_CODE] = code
    Ev[d, NEXT_STAMP] = stamp[code] if code >= 0 else 0
    Ev[d, NEXT_AUX] = aux
    heap_set(queue.heap, d, t)


@kernel
def has_room(x, y, r, ex1, ex2, T, fl, cells, run):
    """Does a disc of radius r fit at (x, y) at time T: inside the bounds and overlapping no
    live disc but ex1 and ex2 (touching is not overlapping)?"""
    if not inside(x, y, r, run.bounds_kind, run.bounds_params):
        return False
    if not run.collide:
        return True
    W = fl.path
    head, nxt, ncx = cells.head, cells.nxt, cells.ncx
    rmax = run.rmax
    reach = r + rmax + CELL_MARGIN * (r + rmax) + 1e-12
    c0 = cell_of(x - reach, y - reach, cells)
    c1 = cell_of(x + reach, y + reach, cells)
    for qy in range(c0 // ncx, c1 // ncx + 1):
        for qx in range(c0 % ncx, c1 % ncx + 1):
            k = head[qx + ncx * qy]
            while k >= 0:
                if k != ex1 and k != ex2:
                    dtk = T - W[k, PT]
                    dx = W[k, PX] + dtk * W[k, PVX] - x
                    dy = W[k, PY] + dtk * W[k, PVY] - y
                    R = r + W[k, PR]
                    if dx * dx + dy * dy < R * R:
                        return False
                k = nxt[k]
    return True
