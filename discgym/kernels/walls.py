"""Disc-wall contacts (docs/physics.md, section 3).

A disc that has crossed a wall during the last step is rewound to its contact time t <= 0,
reflected specularly and wound forward by -t: for the box this is exactly the document's
"negate the component and move by 2l"; for the circle the contact is the root of
|d + t v| = L (d = r - M, L = R_m - R_c) nearer to zero, with outward normal d_c / |d_c|.

Times are relative to the end of the current (sub)step: a contact at t happened -t ago.
"""

import math

from .jit import kernel

INF = math.inf


@kernel
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


@kernel
def circle_contact(x, y, vx, vy, r, b0, b1, b2):
    """Past contact of a disc with the circle of centre (b0, b1), radius b2: (t, 0, inward).

    t: the root of |d + t v| = L nearer to zero, no cancellation (docs/physics.md, section 3.2).
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


@kernel
def contact(x, y, vx, vy, r, bounds_kind, bounds_params):
    """Wall contact of a disc in either bounds kind (``bounds_kind``, ``bounds_params`` as in
    :class:`~discgym.kernels.structs.Bounds`)."""
    if bounds_kind == 0:
        return box_contact(x, y, vx, vy, r, bounds_params[0], bounds_params[1], bounds_params[2],
                           bounds_params[3])
    return circle_contact(x, y, vx, vy, r, bounds_params[0], bounds_params[1], bounds_params[2])


@kernel
def reflected(xc, yc, vx, vy, axis, bounds_kind, b0, b1):
    """Specular reflection (pure) of a disc touching the wall at (xc, yc) with velocity v.

    Box: the ``axis`` component is negated. Circle of centre (b0, b1): v -> v - 2 (v.n) n
    with the outward normal n = (x_c - M)/|x_c - M|. Returns ``(vx, vy, |v.n|)``; the wall
    receives momentum 2 m |v.n|.
    """
    if bounds_kind == 0:
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


@kernel
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


@kernel
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


GLIDE_CHORDS = 8  # a disc that would reflect more often than this in the rest of a step glides


@kernel
def circle_chord(xc, yc, vx, vy, r, b0, b1, b2):
    """The chord a disc just reflected at (xc, yc) off the circle wall (centre (b0, b1),
    radius b2) crosses with velocity (vx, vy): ``(tau, psi, vn)``, the time it takes
    (2 L v_n / |v|^2, L = b2 - r), the angle it turns the disc about the centre, and the
    inward speed v_n. ``tau`` is inf for a disc at rest."""
    vv = vx * vx + vy * vy
    dx = xc - b0
    dy = yc - b1
    L = b2 - r
    if vv == 0.0 or L <= 0.0:
        return INF, 0.0, 0.0
    vn = -(dx * vx + dy * vy) / L  # inward speed (>= 0 after a reflection, up to round-off)
    if vn < 0.0:
        vn = 0.0
    tau = 2.0 * L * vn / vv
    ex = dx + tau * vx
    ey = dy + tau * vy
    psi = math.atan2(dx * ey - dy * ex, dx * ex + dy * ey)
    return tau, psi, vn


@kernel
def circle_glide(xc, yc, vx, vy, r, b0, b1, b2, tau, psi, vn, s):
    """A disc grazing the circle wall, advanced in closed form through its reflections.

    The disc has just been reflected at (xc, yc) on the wall of the circle of centre (b0, b1),
    radius b2, and moves with (vx, vy) along a chord ``(tau, psi, vn)`` of
    :func:`circle_chord`. Each chord turns its position and velocity by the same angle psi
    about the centre (the circle billiard is integrable), so after a time s it has crossed
    m = floor(s / tau) chords: its position and velocity are turned by m psi, followed by a
    straight flight of s - m tau. As v_n -> 0 (a disc sliding along the wall) this tends to
    sliding at constant speed along the wall, turned by |v| s / L, which is used when m
    would be astronomically large.

    Returns ``(x, y, vx, vy, rest, impulse)`` at time s after the contact: ``rest`` = s - m
    tau, the time since its last reflection, and the momentum per unit mass the m
    reflections gave the wall, 2 v_n m (-> |v|^2 s / L, the centripetal impulse, sliding).
    """
    vv = vx * vx + vy * vy
    dx = xc - b0
    dy = yc - b1
    L = b2 - r
    m = math.floor(s / tau) if tau > 0.0 else INF
    if m < 1e15:
        ang = m * psi
        rest = s - m * tau
        impulse = 2.0 * vn * m
    else:  # sliding: the limit of infinitely many vanishing chords
        turn = 1.0 if dx * vy - dy * vx >= 0.0 else -1.0  # sense of rotation
        ang = turn * math.sqrt(vv) * s / L
        rest = 0.0
        impulse = vv * s / L
    c = math.cos(ang)
    sn = math.sin(ang)
    px = c * dx - sn * dy
    py = sn * dx + c * dy
    ux = c * vx - sn * vy
    uy = sn * vx + c * vy
    px += rest * ux
    py += rest * uy
    d2 = px * px + py * py
    if d2 > L * L:  # on the wall up to round-off: keep it inside
        k = L / math.sqrt(d2) * (1.0 - 4e-16)
        px *= k
        py *= k
    return b0 + px, b1 + py, ux, uy, rest, impulse


GRAZE = 4.5e-5  # least inward angle (radians) of a reflection off the circle, event-driven


@kernel
def graze_floor(x, y, vx, vy, b0, b1):
    """The velocity of a disc just reflected at (x, y) off the circle of centre (b0, b1),
    turned (speed kept) so that it leaves the wall at an angle of at least ``GRAZE``.

    For the event-driven integrator: a disc moving exactly along the curved wall would meet
    it again at once, forever, and one grazing it meets it again after ever shorter chords.
    With this floor the chords are never shorter than 2 GRAZE (R_m - R_c): the disc follows
    a polygon inscribed in the wall whose sides stray at most GRAZE^2 / 2 (1e-9) of the
    circle's radius from it, its kinetic energy is unchanged, and the wall takes the change
    of momentum. (The time-stepped integrator glides such discs in closed form instead.)
    """
    nx = x - b0
    ny = y - b1
    d = math.sqrt(nx * nx + ny * ny)
    if d == 0.0:
        return vx, vy
    nx /= d
    ny /= d
    speed = math.sqrt(vx * vx + vy * vy)
    vin = -(vx * nx + vy * ny)  # inward speed
    a = GRAZE * speed
    if vin >= a or speed == 0.0:
        return vx, vy
    tx = vx + vin * nx  # the tangential part
    ty = vy + vin * ny
    t = math.sqrt(tx * tx + ty * ty)
    if t == 0.0:
        return vx, vy
    b = math.sqrt(speed * speed - a * a) / t
    return -a * nx + b * tx, -a * ny + b * ty


@kernel
def reflect(i, t, axis, pos, vel, m, bounds_kind, bounds_params):
    """Reflect disc i at its contact time t; returns the momentum delivered to the wall."""
    xc = pos[i, 0] + t * vel[i, 0]
    yc = pos[i, 1] + t * vel[i, 1]
    vx, vy, vn = reflected(xc, yc, vel[i, 0], vel[i, 1], axis, bounds_kind, bounds_params[0],
                           bounds_params[1])
    dp = 2.0 * m * vn
    vel[i, 0] = vx
    vel[i, 1] = vy
    pos[i, 0] = xc - t * vel[i, 0]
    pos[i, 1] = yc - t * vel[i, 1]
    return dp


@kernel
def push_inside(i, pos, r, bounds_kind, bounds_params):
    """Move disc i to the nearest point where it lies within the bounds (no velocity change).

    Only used for a disc overlapping a wall while moving inward, which a time step cannot
    rewind (it can be left by round-off or by an inelastic cluster pressed against a wall).
    """
    if bounds_kind == 0:
        pos[i, 0] = min(max(pos[i, 0], bounds_params[0] + r), bounds_params[2] - r)
        pos[i, 1] = min(max(pos[i, 1], bounds_params[1] + r), bounds_params[3] - r)
    else:
        dx = pos[i, 0] - bounds_params[0]
        dy = pos[i, 1] - bounds_params[1]
        L = bounds_params[2] - r
        d = math.sqrt(dx * dx + dy * dy)
        if d > L and d > 0.0:
            pos[i, 0] = bounds_params[0] + dx * (L / d)
            pos[i, 1] = bounds_params[1] + dy * (L / d)


FIT_TOL = 1e-9  # a free gap below this fraction of the radius counts as an exact fit


@kernel
def settle_after_reflection(i, axis, pos, r, bounds_kind, bounds_params):
    """After a reflection, hold a disc that fits its bounds exactly where it must be; returns
    True if it was moved.

    A disc with no room to move along the reflected axis (box: ``hi - lo`` below ``FIT_TOL``
    radii, a disc as wide as the box) or at all (circle: ``R_m - R_c`` below ``FIT_TOL``
    radii) is put in the middle of that axis / at the centre: winding it forward from the
    contact would carry it past the opposite wall at once, and the next contact would be at
    the same instant, forever. Any other disc is left where the reflection put it, even if
    that is beyond a wall: a corner (the other axis' wall) or a grazing disc that meets the
    curved circle wall again within the step; that contact is its next event.
    """
    if bounds_kind == 0:
        k = 0 if axis == 0 else 1
        lo = bounds_params[k] + r
        hi = bounds_params[k + 2] - r
        if hi - lo > FIT_TOL * r:
            return False
        mid = 0.5 * (lo + hi)
        if pos[i, k] == mid:
            return False
        pos[i, k] = mid
        return True
    if bounds_params[2] - r > FIT_TOL * r:
        return False
    if pos[i, 0] == bounds_params[0] and pos[i, 1] == bounds_params[1]:
        return False
    pos[i, 0] = bounds_params[0]
    pos[i, 1] = bounds_params[1]
    return True


@kernel
def inside(x, y, r, bounds_kind, bounds_params):
    """Does a disc of radius r at (x, y) lie within the bounds?"""
    if bounds_kind == 0:
        b = bounds_params
        return b[0] + r <= x <= b[2] - r and b[1] + r <= y <= b[3] - r
    dx = x - bounds_params[0]
    dy = y - bounds_params[1]
    L = bounds_params[2] - r
    return L >= 0.0 and dx * dx + dy * dy <= L * L


# ------------------------------------------------------------ thermal walls and outlets
@kernel
def side_of(xc, yc, axis, vx, vy, bounds_kind, bounds_params):
    """The side a disc touching the wall at (xc, yc) (its centre at the contact) meets, moving
    with (vx, vy) along ``axis`` (of :func:`contact`), and where on it: ``(side, frac)``.

    Box: side LEFT, RIGHT (axis 0, by the sign of vx), BOTTOM, TOP (axis 1), ``frac`` the
    contact point's coordinate along the side as a fraction of its length from its lower end
    (the contact point and the centre share that coordinate). Circle: side 0, ``frac`` the
    angle of the contact point counter-clockwise from +x, in turns [0, 1).
    """
    b0, b1, b2, b3 = bounds_params[0], bounds_params[1], bounds_params[2], bounds_params[3]
    if bounds_kind == 0:
        if axis == 0:
            return (0 if vx < 0.0 else 1), (yc - b1) / (b3 - b1)
        return (2 if vy < 0.0 else 3), (xc - b0) / (b2 - b0)
    f = math.atan2(yc - b1, xc - b0) / (2.0 * math.pi)
    if f < 0.0:
        f += 1.0
    return 0, f


@kernel
def on_outlet(side, frac, s, outlets):
    """Does a disc of species ``s`` at the point ``frac`` of ``side`` leave through one of
    the outlet segments ``outlets`` ((M, 3 + S) rows side, start, end, then whether each
    species passes; ends included)? Outlets do not overlap: the one it lies on decides."""
    for k in range(outlets.shape[0]):
        if int(outlets[k, 0]) == side and outlets[k, 1] <= frac <= outlets[k, 2]:
            return outlets[k, 3 + s] != 0.0
    return False


@kernel
def thermal_velocity(xc, yc, vx, vy, side, kT, m, bounds_kind, bounds_params, rng):
    """The velocity a disc of mass m leaves a thermal wall at temperature kT with, having
    met it at (xc, yc) with (vx, vy): diffuse reflection, the flux-weighted Maxwell-Boltzmann
    distribution of the wall. With s = sqrt(kT / m): inward normal speed s sqrt(-2 ln(1 - u))
    (Rayleigh, u uniform in [0, 1): drawn first), tangential speed s g (g standard normal:
    drawn second), both from ``rng``. The inward normal: box +x (LEFT), -x (RIGHT), +y
    (BOTTOM), -y (TOP); circle towards the centre.

    Returns ``(vx, vy, vn_in, vn_out)``: the new velocity, the normal speed with which the
    disc arrived and the one with which it leaves (the wall receives m (vn_in + vn_out))."""
    if bounds_kind == 0:
        nx = 0.0
        ny = 0.0
        if side == 0:
            nx = 1.0
        elif side == 1:
            nx = -1.0
        elif side == 2:
            ny = 1.0
        else:
            ny = -1.0
    else:
        nx = bounds_params[0] - xc
        ny = bounds_params[1] - yc
        d = math.sqrt(nx * nx + ny * ny)
        if d > 0.0:
            nx /= d
            ny /= d
        else:  # disc as large as the circle: back along its path
            sp = math.sqrt(vx * vx + vy * vy)
            nx = -vx / sp if sp > 0.0 else 1.0
            ny = -vy / sp if sp > 0.0 else 0.0
    vn_in = abs(vx * nx + vy * ny)
    s = math.sqrt(kT / m)
    u = rng.random()
    vn = s * math.sqrt(-2.0 * math.log1p(-u))
    vt = s * rng.standard_normal()
    # tangent (-ny, nx)
    return vn * nx - vt * ny, vn * ny + vt * nx, vn_in, vn
