"""The compiled parts of the controls of a :class:`~discgym.Simulation` (heating, moving a
wall, injecting): one pass over the discs each, so a control costs a few microseconds from
Python instead of a dozen numpy calls (what a reinforcement-learning loop pays every step).

Energy sums run in disc order with Neumaier's compensated summation (accurate to about one
rounding of the result, whatever N), and are what ``Simulation``'s energy observables report.
"""

from numba import njit


@njit(cache=True)
def energies(vel, species, internal_energy, sp_mass, sp_form, n):
    """``(kinetic, internal, formation)`` energy of discs [0, n), each a compensated sum."""
    k = 0.0
    kc = 0.0
    u = 0.0
    uc = 0.0
    f = 0.0
    fc = 0.0
    for i in range(n):
        s = species[i]
        x = 0.5 * sp_mass[s] * (vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1])
        t = k + x
        kc += (k - t) + x if abs(k) >= abs(x) else (x - t) + k
        k = t
        x = internal_energy[i]
        t = u + x
        uc += (u - t) + x if abs(u) >= abs(x) else (x - t) + u
        u = t
        x = sp_form[s]
        t = f + x
        fc += (f - t) + x if abs(f) >= abs(x) else (x - t) + f
        f = t
    return k + kc, u + uc, f + fc


@njit(cache=True)
def kinetic_and_fastest(vel, species, sp_mass, n):
    """``(kinetic energy, largest squared speed)`` of discs [0, n); ``vel`` (C, 2)."""
    ke = 0.0
    v2max = 0.0
    for i in range(n):
        v2 = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1]
        ke += 0.5 * sp_mass[species[i]] * v2
        if v2 > v2max:
            v2max = v2
    return ke, v2max


@njit(cache=True)
def scale(vel, n, s):
    """``vel[:n] *= s`` in place."""
    for i in range(n):
        vel[i, 0] *= s
        vel[i, 1] *= s


@njit(cache=True)
def all_inside(pos, species, sp_radius, n, bounds_kind, b0, b1, b2, b3):
    """Do all discs [0, n) lie within the bounds (box: (x0, y0, x1, y1) = b0..b3; circle:
    centre (b0, b1), radius b2)? Touching counts as inside."""
    for i in range(n):
        r = sp_radius[species[i]]
        x = pos[i, 0]
        y = pos[i, 1]
        if bounds_kind == 0:
            if not (b0 + r <= x <= b2 - r and b1 + r <= y <= b3 - r):
                return False
        else:
            L = b2 - r
            dx = x - b0
            dy = y - b1
            if L < 0.0 or dx * dx + dy * dy > L * L:
                return False
    return True
