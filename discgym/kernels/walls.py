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
def reflect(i, t, axis, pos, vel, m, bkind, bp):
    """Reflect disc i at its contact time t; returns the momentum delivered to the wall."""
    xc = pos[i, 0] + t * vel[i, 0]
    yc = pos[i, 1] + t * vel[i, 1]
    if bkind == 0:
        if axis == 0:
            dp = 2.0 * m * abs(vel[i, 0])
            vel[i, 0] = -vel[i, 0]
        else:
            dp = 2.0 * m * abs(vel[i, 1])
            vel[i, 1] = -vel[i, 1]
    else:
        nx = xc - bp[0]
        ny = yc - bp[1]
        d = math.sqrt(nx * nx + ny * ny)
        if d > 0.0:
            nx /= d
            ny /= d
        else:  # disc as large as the circle: bounce straight back
            s = math.sqrt(vel[i, 0] ** 2 + vel[i, 1] ** 2)
            nx = vel[i, 0] / s
            ny = vel[i, 1] / s
        vn = vel[i, 0] * nx + vel[i, 1] * ny
        dp = 2.0 * m * abs(vn)
        vel[i, 0] -= 2.0 * vn * nx
        vel[i, 1] -= 2.0 * vn * ny
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
