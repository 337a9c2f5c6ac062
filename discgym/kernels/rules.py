"""The event rules: what happens at an event, written once for every integrator that meets it.

The stepped integrator's event phase (:mod:`.events`, serial or by clusters) and the exact
integrator (:mod:`.event_driven`) call these; neither writes them again. Each is a few lines,
inlined where it is called, so that sharing them costs nothing at run time.

- :func:`stale`, :func:`out_of_events`, :func:`grazing` and :func:`rebound`: the stepped
  integrator's tests of a popped event (its heap keeps every contact queued in a substep, the
  exact integrator's one event per disc, so the exact integrator has tests of its own: a
  partner's stamp and an approach test by the arithmetic of its prediction).
- :func:`tc_restitution`: the TC model of inelastic collapse (Luding and McNamara): a
  collision that repeats within t_c is elastic, and is counted.
- :func:`book_outflow`: a disc that leaves through an outlet, its energy and its species.
- :func:`book_thermal`: what a thermal wall exchanges with a disc it redraws.
"""

from numba import njit

from .structs import (
    DISC_EVENTS,
    FS_OUTFLOW,
    FS_WALL_HEAT,
    FS_WALL_MOMENTUM,
    IC_TC_ELASTIC,
    VR_ROUNDOFF,
)


@njit(cache=True, inline="always")
def stale(stamp, i, j, si, sj):
    """Whether a queued event of disc i (and j >= 0), queued with their stamps si, sj, is
    stale: one of them has had another event since."""
    return stamp[i] != si or (j >= 0 and stamp[j] != sj)


@njit(cache=True, inline="always")
def out_of_events(nev, i, j):
    """Whether disc i (or j >= 0) has taken DISC_EVENTS events in the substep already (the
    event is dropped and the substep repaired: resolve.py)."""
    return nev[i] >= DISC_EVENTS or (j >= 0 and nev[j] >= DISC_EVENTS)


@njit(cache=True, inline="always")
def grazing(vr, vxi, vyi, vxj, vyj):
    """Whether a pair with normal approach speed ``vr`` is not approaching, to round-off: an
    impulse this small changes nothing, and without this test a pair whose impulse is lost to
    round-off (speeds ~1e2, approach ~1e-15) is re-detected at the same time until the event
    budget runs out. (Written as the test that skips, so that a NaN speed is not skipped.)"""
    return vr <= VR_ROUNDOFF * (abs(vxi) + abs(vyi) + abs(vxj) + abs(vyj))


@njit(cache=True, inline="always")
def rebound(partner, i, j):
    """Whether the latest events of discs i and j were with each other: two discs that have
    just bounced move apart on straight lines and cannot meet again before something else
    happens to one of them (a re-detection by round-off)."""
    return partner[i] == j and partner[j] == i


@njit(cache=True, inline="always")
def tc_restitution(e, repeat, icnt):
    """The restitution of a collision: ``e``, or 1 (counted in IC_TC_ELASTIC) when e < 1 and
    the collision ``repeat`` s one of either disc's within t_c (the stepped integrator's t_c is
    its substep, the exact integrator's a time from the speeds: each says what repeats)."""
    if e < 1.0 and repeat:
        icnt[IC_TC_ELASTIC] += 1
        return 1.0
    return e


@njit(cache=True, inline="always")
def book_outflow(s, m, vx, vy, u, sp_form, fsum, outflow):
    """A disc of species ``s`` (mass ``m``, velocity ``(vx, vy)``, internal energy ``u``)
    leaves through an outlet: its kinetic, internal and formation energy go to FS_OUTFLOW,
    and it is counted in ``outflow``."""
    fsum[FS_OUTFLOW] += 0.5 * m * (vx * vx + vy * vy) + u + sp_form[s]
    outflow[s] += 1


@njit(cache=True, inline="always")
def book_thermal(side, m, vx0, vy0, vx, vy, vn_in, vn_out, fsum):
    """A thermal wall on ``side`` redrew the velocity of a disc of mass ``m`` from ``(vx0,
    vy0)`` (normal speed in ``vn_in``) to ``(vx, vy)`` (``vn_out``): the momentum the wall took
    to FS_WALL_MOMENTUM, the energy it gave to FS_WALL_HEAT + side."""
    fsum[FS_WALL_MOMENTUM] += m * (vn_in + vn_out)
    fsum[FS_WALL_HEAT + side] += 0.5 * m * ((vx * vx + vy * vy) - (vx0 * vx0 + vy0 * vy0))
