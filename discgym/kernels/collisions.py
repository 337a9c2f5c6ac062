"""Disc-disc contacts (docs/physics.md, section 4).

With r = r_j - r_i and v = v_j - v_i at the end of the step, the pair touched at the earlier
root of |r + t v| = R_i + R_j, computed here in the cancellation-free form
t = c / (-r.v + sqrt((r.v)^2 - |v|^2 c)), c = |r|^2 - R^2 < 0. The pair is rewound to t, the
impulse dp = -(1 + e) v_r / (1/m_i + 1/m_j) is exchanged along n = (r_j - r_i)/|r_j - r_i|
(v_r = (v_i - v_j).n), and both are wound forward by -t.

Internal energy (carried by combination products) relaxes at every non-reactive collision: a
fraction kappa (the scene's ``internal_relaxation``) of the two discs' internal energy is
released into their separating speed along n. Momentum and total energy are conserved; this is
the rule that lets a hot product cool and survive.
"""

import math

from .jit import kernel

SEPARATING_OVERLAP = 1e-10  # a separating pair overlapping deeper than this fraction of its
# contact distance was left overlapping by a graze the step missed (see contact_time)


@kernel
def contact_time(rx, ry, vx, vy, R, lo):
    """Contact time in [lo, 0] of a pair overlapping now (|r| < R), or nan if there is none.

    The contact is the earlier root t1 of |r + t v| = R. A pair that is separating now
    (r.v > 0) only had a contact in this step if its closest approach, at t* = -r.v/|v|^2,
    came after ``lo`` (the start of the step, or the pair's latest event): otherwise it has
    been separating all along and is left alone (an overlap left by round-off is not a
    collision): nan, or +inf if it overlaps deeper than ``SEPARATING_OVERLAP`` of R, which
    round-off cannot do. Such an overlap is left by a graze inside an earlier step or substep
    (both ends of it outside contact, so not seen) during which an event turned one of the
    discs; the caller repairs it (:mod:`.resolve`). A contact before ``lo`` is moved to
    ``lo``. No relative motion: nan.
    """
    vv = vx * vx + vy * vy
    if vv == 0.0:
        return math.nan
    b = rx * vx + ry * vy
    c = rx * rx + ry * ry - R * R
    if b > 0.0 and -b / vv <= lo:
        if c < -2.0 * SEPARATING_OVERLAP * R * R:
            return math.inf
        return math.nan
    disc = b * b - vv * c
    if disc < 0.0:
        disc = 0.0
    if b <= 0.0:
        den = -b + math.sqrt(disc)
        t = c / den if den > 0.0 else 0.0
    else:
        t = (-b - math.sqrt(disc)) / vv
    return max(t, lo)


@kernel
def pair_time(xi, yi, vxi, vyi, ri, ti, xj, yj, vxj, vyj, rj, tj):
    """Contact time of discs i and j if they overlap now and touched in this step, else nan
    (+inf: left overlapping, see :func:`contact_time`).

    ``ti``, ``tj``: each disc's latest event time (the start of the step if none)."""
    rx = xj - xi
    ry = yj - yi
    R = ri + rj
    if rx * rx + ry * ry >= R * R:
        return math.nan
    return contact_time(rx, ry, vxj - vxi, vyj - vyi, R, max(ti, tj))


@kernel
def normal_at(xi, yi, vxi, vyi, xj, yj, vxj, vyj, t):
    """Positions of i and j at time t and the unit normal n from i to j there."""
    xi = xi + t * vxi
    yi = yi + t * vyi
    xj = xj + t * vxj
    yj = yj + t * vyj
    nx = xj - xi
    ny = yj - yi
    d = math.sqrt(nx * nx + ny * ny)
    if d > 0.0:
        nx /= d
        ny /= d
    else:  # coincident centres: the normal is the direction of approach
        rvx = vxi - vxj
        rvy = vyi - vyj
        s = math.sqrt(rvx * rvx + rvy * rvy)
        if s > 0.0:
            nx = rvx / s
            ny = rvy / s
        else:
            nx = 1.0
            ny = 0.0
    return xi, yi, xj, yj, nx, ny


@kernel
def bounce(vxi, vyi, vxj, vyj, mi, mj, nx, ny, e, kappa, ui, uj):
    """Impulse exchange along n (from i to j), for a pair with v_r = (v_i - v_j).n > 0.

    Returns the new velocities and internal energies and the kinetic energy dissipated:
    ``(vxi, vyi, vxj, vyj, ui, uj, lost)``.
    """
    vr = (vxi - vxj) * nx + (vyi - vyj) * ny
    inv = 1.0 / mi + 1.0 / mj
    mu = 1.0 / inv
    dp = -(1.0 + e) * vr / inv
    vxi += dp / mi * nx
    vyi += dp / mi * ny
    vxj -= dp / mj * nx
    vyj -= dp / mj * ny
    lost = 0.5 * (1.0 - e * e) * mu * vr * vr
    if kappa > 0.0:
        released = kappa * (ui + uj)
        if released > 0.0:
            ui -= kappa * ui
            uj -= kappa * uj
            s = e * vr  # separating speed along n after the impulse
            k = math.sqrt(s * s + 2.0 * released / mu) - s
            vxi -= k * mu / mi * nx
            vyi -= k * mu / mi * ny
            vxj += k * mu / mj * nx
            vyj += k * mu / mj * ny
    return vxi, vyi, vxj, vyj, ui, uj, lost
