"""Disc-wall contacts (physics.md 1.1, with the corrections of notes.md).

A disc that has crossed a wall during the last step is rewound to its contact time t <= 0,
reflected specularly and wound forward by -t: for the box this is exactly the document's
"negate the component and move by 2l"; for the circle the contact is the root of
|d + t v| = L (d = r - M, L = R_m - R_c) nearer to zero, with outward normal d_c / |d_c|.

Times are relative to the end of the current (sub)step: a contact at t happened -t ago.
"""

import math

from numba import njit

INF = math.inf


@njit(cache=True)
def box_contact(x, y, vx, vy, r, b0, b1, b2, b3):
    """Earliest past wall contact of a disc in the box (xmin, ymin, xmax, ymax) = b0..b3.

    Returns ``(t, axis, inward)``: t (<= 0) and axis (0: x, 1: y) of the earliest contact with
    a wall the disc has crossed while moving outward, t = inf if none; ``inward`` is True when
    the disc overlaps a wall while moving away from it (no contact to rewind to).
    """
    t = INF
    axis = -1
    inward = False
    lo = b0 + r
    hi = b2 - r
    if x < lo:
        if vx < 0.0:
            tc = (lo - x) / vx
            if tc < t:
                t, axis = tc, 0
        else:
            inward = True
    elif x > hi:
        if vx > 0.0:
            tc = (hi - x) / vx
            if tc < t:
                t, axis = tc, 0
        else:
            inward = True
    lo = b1 + r
    hi = b3 - r
    if y < lo:
        if vy < 0.0:
            tc = (lo - y) / vy
            if tc < t:
                t, axis = tc, 1
        else:
            inward = True
    elif y > hi:
        if vy > 0.0:
            tc = (hi - y) / vy
            if tc < t:
                t, axis = tc, 1
        else:
            inward = True
    return t, axis, inward


@njit(cache=True)
def circle_contact(x, y, vx, vy, r, b0, b1, b2):
    """Past contact of a disc with the circle of centre (b0, b1), radius b2: (t, 0, inward).

    t is the root of |d + t v| = L nearer to zero (notes.md), computed without cancellation.
    """
    dx = x - b0
    dy = y - b1
    L = b2 - r
    c = dx * dx + dy * dy - L * L
    if c <= 0.0:
        return INF, -1, False
    dv = dx * vx + dy * vy
    if dv <= 0.0:
        return INF, -1, True
    vv = vx * vx + vy * vy
    disc = dv * dv - vv * c
    if disc < 0.0:  # tangent within round-off
        disc = 0.0
    q = -dv - math.sqrt(disc)  # < 0: vv * (the root farther from zero)
    return c / q, 0, False


@njit(cache=True)
def contact(x, y, vx, vy, r, bkind, bp):
    """Wall contact of a disc in either bounds kind (``bp`` as in :mod:`discgym.compiled`)."""
    if bkind == 0:
        return box_contact(x, y, vx, vy, r, bp[0], bp[1], bp[2], bp[3])
    return circle_contact(x, y, vx, vy, r, bp[0], bp[1], bp[2])


@njit(cache=True)
def reflected(xc, yc, vx, vy, axis, bkind, b0, b1):
    """Specular reflection (pure) of a disc touching the wall at (xc, yc) with velocity v.

    Box: the ``axis`` component is negated. Circle of centre (b0, b1): v -> v - 2 (v.n) n
    with the outward normal n = (x_c - M)/|x_c - M|. Returns ``(vx, vy, |v.n|)``; the wall
    receives momentum 2 m |v.n|.
    """
    if bkind == 0:
        if axis == 0:
            return -vx, vy, abs(vx)
        return vx, -vy, abs(vy)
    nx = xc - b0
    ny = yc - b1
    d = math.sqrt(nx * nx + ny * ny)
    if d > 0.0:
        nx /= d
        ny /= d
    else:  # disc as large as the circle: bounce straight back
        s = math.sqrt(vx ** 2 + vy ** 2)
        nx = vx / s
        ny = vy / s
    vn = vx * nx + vy * ny
    return vx - 2.0 * vn * nx, vy - 2.0 * vn * ny, abs(vn)


@njit(cache=True)
def box_next(x, y, vx, vy, r, b0, b1, b2, b3):
    """Time until the next wall contact of a disc moving freely in the box (b0, b1, b2, b3)
    = (xmin, ymin, xmax, ymax), and the axis hit: ``(t, axis)``, t = inf if it never hits.

    Forward-time counterpart of :func:`box_contact` (for the event-driven integrator). A disc
    already past a wall (round-off) and moving out of it gets t = 0.
    """
    t = INF
    axis = -1
    if vx > 0.0:
        t = max((b2 - r - x) / vx, 0.0)
        axis = 0
    elif vx < 0.0:
        t = max((b0 + r - x) / vx, 0.0)
        axis = 0
    if vy > 0.0:
        ty = max((b3 - r - y) / vy, 0.0)
        if ty < t:
            t, axis = ty, 1
    elif vy < 0.0:
        ty = max((b1 + r - y) / vy, 0.0)
        if ty < t:
            t, axis = ty, 1
    return t, axis


@njit(cache=True)
def circle_next(x, y, vx, vy, r, b0, b1, b2):
    """Time until a disc moving freely inside the circle of centre (b0, b1), radius b2 next
    touches it: the root t >= 0 of |d + t v| = L (d = r - M, L = b2 - r) at which it would
    leave, computed without cancellation; inf if it does not move. Returns ``(t, 0)``."""
    vv = vx * vx + vy * vy
    if vv == 0.0:
        return INF, -1
    dx = x - b0
    dy = y - b1
    L = b2 - r
    c = dx * dx + dy * dy - L * L  # <= 0 inside
    b = dx * vx + dy * vy
    disc = b * b - vv * c
    if disc < 0.0:  # only if outside (round-off) and moving past: no contact ahead
        disc = 0.0
    if b > 0.0:
        if c >= 0.0:  # on or past the wall (round-off) and moving out: now
            return 0.0, 0
        return -c / (b + math.sqrt(disc)), 0
    return (-b + math.sqrt(disc)) / vv, 0


@njit(cache=True)
def reflect(i, t, axis, pos, vel, m, bkind, bp):
    """Reflect disc i at its contact time t; returns the momentum delivered to the wall."""
    xc = pos[i, 0] + t * vel[i, 0]
    yc = pos[i, 1] + t * vel[i, 1]
    vx, vy, vn = reflected(xc, yc, vel[i, 0], vel[i, 1], axis, bkind, bp[0], bp[1])
    dp = 2.0 * m * vn
    vel[i, 0] = vx
    vel[i, 1] = vy
    pos[i, 0] = xc - t * vel[i, 0]
    pos[i, 1] = yc - t * vel[i, 1]
    return dp


@njit(cache=True)
def push_inside(i, pos, r, bkind, bp):
    """Move disc i to the nearest point where it lies within the bounds (no velocity change).

    Only used for a disc overlapping a wall while moving inward, which a time step cannot
    rewind (it can be left by round-off or by an inelastic cluster pressed against a wall).
    """
    if bkind == 0:
        pos[i, 0] = min(max(pos[i, 0], bp[0] + r), bp[2] - r)
        pos[i, 1] = min(max(pos[i, 1], bp[1] + r), bp[3] - r)
    else:
        dx = pos[i, 0] - bp[0]
        dy = pos[i, 1] - bp[1]
        L = bp[2] - r
        d = math.sqrt(dx * dx + dy * dy)
        if d > L and d > 0.0:
            pos[i, 0] = bp[0] + dx * (L / d)
            pos[i, 1] = bp[1] + dy * (L / d)


@njit(cache=True)
def inside(x, y, r, bkind, bp):
    """Does a disc of radius r at (x, y) lie within the bounds?"""
    if bkind == 0:
        return bp[0] + r <= x <= bp[2] - r and bp[1] + r <= y <= bp[3] - r
    dx = x - bp[0]
    dy = y - bp[1]
    L = bp[2] - r
    return L >= 0.0 and dx * dx + dy * dy <= L * L
