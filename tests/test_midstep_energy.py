"""Energy released inside a step of the time-stepped integrator (a fission, a reactive
collision, internal energy released at a collision) must not let the discs it speeds up
outrun the contact checks: the substeps of a step are sized by the speeds at its start, so
the rest of the step is split anew (``resplits``), and a reactive collision whose products
would move farther than ``max_displacement`` smallest radii before the end of their substep
ends that substep at the collision (``substeps_cut``).

The checks: the same collisions as the exact event-driven integrator where the outcome is
deterministic (discs on a line; first-order fissions with the targets placed symmetrically,
so the random sign of the fragments' direction does not matter), no disc escaping a corral of
heavy discs it could only leave by passing through one, and the substep counts the
displacement bound implies.
"""

import hashlib
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import discgym as dg
from discgym.kernels import step as _step

SETTINGS = settings(max_examples=30, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])


def _pair(scene, pos, vel, species, uint=None, steps=1):
    """The same start run by both integrators: (stepped, event-driven) simulations."""
    out = []
    for integ in ("step", "event"):
        sim = dg.Simulation.from_arrays(scene, pos, vel, species, internal_energy=uint, seed=0,
                                        integrator=integ)
        sim.step(steps)
        out.append(sim)
    return out


def _sound(sim, scale):
    assert sim.overlaps() == 0
    assert sim.outside() == 0
    assert abs(sim.energy_balance()) <= 1e-12 * scale


# ------------------------------------------------------------------------------ the reproducer
def test_fragments_of_a_fission_inside_a_step_hit_the_discs_in_their_path():
    """The issue's reproducer: a decomposition releasing 50 at the end of the first of two
    substeps sent its fragments (speed 10) through two resting discs 2.6 away in the second
    (0 collisions). The rest of the step is re-split for speed 10: the 3 collisions the
    event-driven integrator finds; the free disc moves v dt (to round-off: the substeps
    still add up to the step); 2 + ceil(10 * 0.5 / 0.25) = 22 substeps."""
    sp = [dg.Species("P", .5, 1, formation_energy=50), dg.Species("B", .5, .5),
          dg.Species("C", .5, .5), dg.Species("T", .5, 1)]
    sc = dg.Scene(bounds=dg.Box(40, 40), species=sp,
                  reactions=[dg.Decomposition("P", "B", "C", 1.0)], dt=1.0)
    pos = [[20, 20], [17.4, 20], [22.6, 20], [5, 35]]
    vel = [[0, 1e-3], [0, 0], [0, 0], [.5, 0]]
    s, ev = _pair(sc, pos, vel, ["P", "T", "T", "T"])
    c = s.counters()
    assert c["collisions"] == ev.counters()["collisions"] == 3
    assert c["resplits"] == 1 and c["substeps"] == 22 and c["substeps_capped"] == 0
    assert s.positions[3] == pytest.approx([5.5, 35.0], abs=1e-12)
    _sound(s, 50.0)


# ------------------------------------------------- generated lines: the exact integrator agrees
def _line_case(seed):
    """A fission, exchange, relaxation or reverse combination among resting targets: (kind,
    scene, axis, pos, vel, species, uint, energy scale).

    Even seeds: a line along a coordinate axis (exactly 1D in floating point: collinear
    discs keep exact normals, so a cascade of collisions is the same for both integrators)
    with 1-3 targets on each side at random spacing. Odd seeds: a line at a random angle with
    one target on each side, off the line by a random impact parameter (up to 0.8 of the
    contact distance; near-1D cascades at an angle would amplify round-off into different
    outcomes, as hard discs do). Targets are placed point-symmetrically, so the random sign
    of a fission's direction does not matter, and are at least as heavy as the fast discs.
    The parent of a fission moves at 1e-150 across the line: its fragments fly along it and
    it does not move before its fission (the two integrators fire it at different times).
    """
    rng = np.random.default_rng(seed)
    kind = ("decomposition", "exchange", "relaxation", "reverse")[(seed // 2) % 4]
    if seed % 2 == 0:
        ax = [np.array([1.0, 0.0]), np.array([0.0, 1.0])][(seed // 8) % 2]
        nt = int(rng.integers(1, 4))
        side = 0.0
    else:
        ang = rng.uniform(0, 2 * math.pi)
        ax = np.array([math.cos(ang), math.sin(ang)])
        nt = 1
        side = float(rng.uniform(-0.8, 0.8))
    perp = np.array([-ax[1], ax[0]])
    dt = float(rng.choice([0.05, 0.2, 1.0, 2.0]))
    # a release that makes discs 3-30 times faster than the first split allows (0.25 per
    # substep of dt / 3): E ~ v^2 for each kind here
    E = float((0.75 / dt * rng.uniform(3.0, 30.0)) ** 2)
    rT = float(rng.uniform(0.5, 1.0))
    mT = float(rng.uniform(1.0, 5.0))
    c0 = np.array([50000.0, 50000.0])
    sp = [dg.Species("T", rT, mT), dg.Species("S", .5, 1)]
    gaps = rng.uniform(0.3, 6.0, size=nt)
    dists = 1.2 + rT + np.cumsum(gaps + 2 * rT) - 2 * rT
    tpos = [c0 + s * (d * ax + side * (0.5 + rT) * perp) for d in dists for s in (1, -1)]
    still = [[0.0, 0.0]] * len(tpos)
    slow = 1e-150 * perp
    if kind == "decomposition":
        sp += [dg.Species("P", .5, 1, formation_energy=E), dg.Species("B", .5, .5),
               dg.Species("C", .5, .5)]
        rx = [dg.Decomposition("P", "B", "C", 1.0)]
        pos, vel, names, uint = [c0] + tpos, [slow] + still, ["P"] + ["T"] * len(tpos), None
    elif kind == "reverse":
        # C -> A + B releases u - F = Ea when u is the barrier Ea + F: A and B, back to
        # back, can never recombine (the targets keep some of it)
        F = 1.0
        sp += [dg.Species("A", .5, .5), dg.Species("B", .5, .5),
               dg.Species("C", .5, 1, formation_energy=-F)]
        rx = [dg.Combination("A", "B", "C", activation_energy=E, reverse_probability=1.0)]
        pos, vel, names = [c0] + tpos, [slow] + still, ["C"] + ["T"] * len(tpos)
        uint = [E + F] + [0.0] * len(tpos)
    elif kind == "exchange":
        # X and Y meet head-on at the centre (activation 0.5, energy 1) and leave as C and D
        # with the formation energy E released
        sp += [dg.Species("X", .5, 1), dg.Species("Y", .5, 1),
               dg.Species("Cp", .5, 1), dg.Species("Dp", .5, 1, formation_energy=-E)]
        rx = [dg.Exchange("X", "Y", "Cp", "Dp", activation_energy=0.5)]
        off = float(rng.uniform(0.55, 0.9))
        pos, vel = [c0 - off * ax, c0 + off * ax] + tpos, [ax, -ax] + still
        names, uint = ["X", "Y"] + ["T"] * len(tpos), None
    else:  # relaxation: a hot disc releases half its internal energy at each collision
        sp += [dg.Species("H", .5, 1), dg.Species("G", .5, 1)]
        rx = []
        off = float(rng.uniform(0.55, 0.9))
        pos, vel = [c0 - off * ax, c0 + off * ax] + tpos, [0.5 * ax, -0.5 * ax] + still
        names = ["H", "G"] + ["T"] * len(tpos)
        uint = [E, 0.0] + [0.0] * len(tpos)
    # a free disc far away makes the first split 3 substeps (a fission then comes at the
    # end of the first, with two left to re-split)
    pos.append([100.0, 100.0])
    vel.append([0.6 / dt, 0.0])
    names.append("S")
    if uint is not None:
        uint.append(0.0)
    sc = dg.Scene(bounds=dg.Box(100000, 100000), species=sp, reactions=rx, dt=dt,
                  internal_relaxation=0.5)
    return kind, sc, ax, np.array(pos, float), np.array(vel, float), names, uint, E


def _run_to_the_end(sim, ax, limit=40000):
    """Step until no two discs on the line approach each other any more (sorted along the
    line by position, their velocities along it are sorted too): no collision can follow.
    Returns the collisions counted."""
    for _ in range(limit):
        line = sim.species != sim.scene.species_index("S")
        p = sim.positions[line] @ ax
        u = sim.velocities[line] @ ax
        if (np.diff(u[np.argsort(p)]) >= 0).all() and sim.collisions + \
                sim.counters()["reactive_collisions"] > 0:
            break
        sim.step(1)
    else:
        raise AssertionError("the line did not come apart")
    assert sim.wall_hits == 0  # (the box is far larger than the line's spread)
    return sim.counters()


@pytest.mark.parametrize("seed", range(32))
def test_a_line_of_targets_sees_the_collisions_of_the_exact_integrator(seed):
    """Generated: each kind of release (making discs 3-30 times faster than the substeps
    allow) on a line of 2-6 resting targets
    (random angle, spacing, target size and mass), dt 0.05-2. Once the line has come apart
    for good (no wall reached), the stepped integrator has counted the same collisions (and
    reactive collisions) as the event-driven one, and no pair overlaps. Before the fix the
    fast discs passed through targets."""
    kind, sc, ax, pos, vel, names, uint, E = _line_case(seed)
    s, ev = _pair(sc, pos, vel, names, uint, 0)
    cs, ce = _run_to_the_end(s, ax), _run_to_the_end(ev, ax)
    assert (cs["collisions"], cs["reactive_collisions"]) == \
        (ce["collisions"], ce["reactive_collisions"]), kind
    assert cs["collisions"] >= 2  # the fast discs did reach the targets
    assert cs["resplits"] >= 1
    _sound(s, E)


# ------------------------------------------------------------------- corrals: crowds, dt, kinds
def _corral(kind, E, dt, n_crowd, seed, max_disp=0.5):
    """A ring of heavy discs (gaps far narrower than any disc) around a reaction that
    releases E and a thermal crowd: nothing can leave the ring without passing through one
    of its discs. Returns (simulation, ring radius, number of ring discs)."""
    rng = np.random.default_rng(seed)
    R_ring, r_ring = 9.0, 0.5
    n_ring = int(math.ceil(2 * math.pi * R_ring / (2 * r_ring + 0.1)))
    c0 = np.array([15.0, 15.0])
    sp = [dg.Species("Ring", r_ring, 1e6), dg.Species("A", .5, 1), dg.Species("B", .5, 1),
          dg.Species("P", .5, 2, formation_energy=E), dg.Species("Cp", .5, 1),
          dg.Species("Dp", .5, 1, formation_energy=-E), dg.Species("K", .5, 2,
                                                                      formation_energy=-1.0)]
    rx = {"decomposition": [dg.Decomposition("P", "A", "B", 1.0)],
          "exchange": [dg.Exchange("A", "B", "Cp", "Dp", activation_energy=0.0)],
          "relaxation": [],
          "reverse": [dg.Combination("A", "B", "K", activation_energy=E,
                                     reverse_probability=1.0)]}[kind]
    sc = dg.Scene(bounds=dg.Box(30, 30), species=sp, reactions=rx, dt=dt,
                  internal_relaxation=0.5, max_displacement=max_disp)
    phi = 2 * math.pi * np.arange(n_ring) / n_ring
    pos = [c0 + R_ring * np.array([math.cos(p), math.sin(p)]) for p in phi]
    names = ["Ring"] * n_ring
    uint = [0.0] * n_ring
    # the reacting discs, then a crowd at random free spots inside
    first = {"decomposition": ["P"], "exchange": ["A", "B"], "relaxation": ["A", "B"],
             "reverse": ["K"]}[kind]
    hot = {"relaxation": E, "reverse": E + 1.0}.get(kind, 0.0)
    crowd = first + ["A" if kind != "exchange" else "Cp"] * n_crowd
    ang = rng.uniform(0, 2 * math.pi)
    ax = np.array([math.cos(ang), math.sin(ang)])
    inner = [c0 - 0.6 * ax, c0 + 0.6 * ax] if len(first) == 2 else [c0]
    while len(inner) < len(crowd):
        p = c0 + rng.uniform(-R_ring + 1.6, R_ring - 1.6, 2)
        if np.linalg.norm(p - c0) < R_ring - 1.6 and \
                all(np.linalg.norm(p - q) > 1.05 for q in inner):
            inner.append(p)
    pos += inner
    names += crowd
    uint += [hot] + [0.0] * (len(crowd) - 1)  # (the first reacting disc is the hot one)
    vel = np.zeros((len(pos), 2))
    vel[n_ring:] = rng.normal(0, 1.0, (len(crowd), 2))
    if len(first) == 2:  # the reacting pair heads for each other (contact at t = 1 / 30)
        vel[n_ring] = 3.0 * ax
        vel[n_ring + 1] = -3.0 * ax
    sim = dg.Simulation.from_arrays(sc, pos, vel, names, internal_energy=uint, seed=seed)
    return sim, c0, R_ring, n_ring


def _inside(sim, c0, R_ring, n_ring):
    d = np.linalg.norm(sim.positions[sim.species != 0] - c0, axis=1)
    return bool((d < R_ring).all())


@SETTINGS
@given(kind=st.sampled_from(["decomposition", "exchange", "relaxation", "reverse"]),
       E=st.floats(20.0, 2e4), dt=st.sampled_from([0.02, 0.1, 0.5, 1.0]),
       n_crowd=st.integers(0, 25), seed=st.integers(0, 2 ** 16))
def test_nothing_leaves_a_corral_of_heavy_discs(kind, E, dt, n_crowd, seed):
    """Property: discs made fast by any kind of release (fission, exothermic exchange,
    relaxation of internal energy, the reverse of a combination) inside a closed ring of
    heavy discs, among a crowd, never end a step outside it, no pair overlaps, and the
    energy balance is exact to round-off; the ring does not open (its discs barely move).
    A disc that moved more than a ring disc's diameter between contact checks could cross
    the ring (before the fix, released energy of a few hundred did)."""
    sim, c0, R_ring, n_ring = _corral(kind, E, dt, n_crowd, seed)
    ring0 = sim.positions[:n_ring]
    for _ in range(max(2, int(0.6 / dt))):
        sim.step(1)
        assert _inside(sim, c0, R_ring, n_ring)
        _sound(sim, E + 100.0)
    assert np.abs(sim.positions[:n_ring] - ring0).max() < 0.05
    assert sim.counters()["substeps_capped"] == 0


def test_the_corral_catches_the_tunnelling_it_is_built_for():
    """The corral's own check: with energy released every kind of way, re-splits happen
    (the fix is what keeps the discs inside, not a ring too thick to cross)."""
    total = 0
    for k, kind in enumerate(("decomposition", "exchange", "relaxation", "reverse")):
        sim, c0, R_ring, n_ring = _corral(kind, 5000.0, 1.0, 5, 7 + k)
        sim.step(2)
        assert _inside(sim, c0, R_ring, n_ring)
        total += sim.counters()["resplits"] > 0
    assert total == 4


# -------------------------------------------------------- the displacement bound, by counters
@pytest.mark.parametrize("E", [50.0, 800.0, 2e4])
@pytest.mark.parametrize("dt", [0.1, 1.0])
def test_a_fission_resplits_the_rest_of_the_step_for_its_fragments(E, dt):
    """The rest of the step after a fission (at the end of the first of k0 = 3 substeps)
    is split so that its fragments move at most max_displacement smallest radii per
    substep: substeps = 1 + ceil(v (dt - h0) / (0.5 r)) (h0 = dt / k0), v the fragments'
    speed (sqrt(2 mu E) / m across the parent's velocity); one re-split, nothing capped."""
    sp = [dg.Species("P", .5, 1, formation_energy=E), dg.Species("B", .5, .5),
          dg.Species("C", .5, .5)]
    sc = dg.Scene(bounds=dg.Box(400, 400), species=sp,
                  reactions=[dg.Decomposition("P", "B", "C", 1.0)], dt=dt)
    v0 = 0.6 / dt
    sim = dg.Simulation.from_arrays(sc, [[200, 200]], [[0, v0]], ["P"], seed=1)
    sim.step(1)
    k0 = 3
    v = math.sqrt(2 * 0.25 * E) / 0.5
    vnow = float(np.linalg.norm(sim.velocities, axis=1).max())
    assert vnow == pytest.approx(math.hypot(v, v0), rel=1e-12)
    expect = 1 + math.ceil(vnow * (dt - dt / k0) / 0.25 - 1e-9)
    c = sim.counters()
    assert c["resplits"] == 1 and c["substeps_capped"] == 0
    assert expect <= c["substeps"] <= expect + 1
    _sound(sim, E)


@pytest.mark.parametrize("off", [0.6, 0.75, 0.9])
@pytest.mark.parametrize("E", [30.0, 3000.0])
def test_an_exothermic_exchange_ends_its_substep_at_the_contact(off, E):
    """Two discs meet head-on inside the first substep (at speed 1 each, contact at
    t_c = off - 0.5 of dt = 1) and an exchange releases E: its products would move farther
    than max_displacement before the substep's contact check, so the substep ends at the
    contact and the rest of the step is split for them: ceil(v_max (1 - t_c) / 0.25) more
    substeps (as their speed then allows), a wall of resting discs in their way is hit as the
    event-driven integrator hits it."""
    sp = [dg.Species("X", .5, 1), dg.Species("Y", .5, 1), dg.Species("Cp", .5, 1),
          dg.Species("Dp", .5, 1, formation_energy=-E), dg.Species("T", .5, 1)]
    sc = dg.Scene(bounds=dg.Box(400, 400), species=sp,
                  reactions=[dg.Exchange("X", "Y", "Cp", "Dp")], dt=1.0)
    pos = [[200 - off, 200], [200 + off, 200], [197, 200], [203, 200]]
    vel = [[1, 0], [-1, 0], [0, 0], [0, 0]]
    s, ev = _pair(sc, pos, vel, ["X", "Y", "T", "T"])
    c = s.counters()
    assert c["substeps_cut"] == 1 and c["resplits"] == 1 and c["reactive_collisions"] == 1
    vmax = math.sqrt(E + 1.0)  # equal masses: each product has half the energy E + 1
    t_c = off - 0.5
    k0 = 4  # speed 1, dt 1, 0.25 per substep
    expect = math.ceil(t_c / 0.25) + math.ceil(vmax * (1 - t_c) / 0.25 - 1e-9)
    assert k0 <= c["substeps"] and expect <= c["substeps"] <= expect + 1
    assert c["collisions"] == ev.counters()["collisions"] >= 2
    _sound(s, E)


def test_a_release_beyond_the_speed_limit_is_capped_and_counted():
    """A fission whose fragments would outrun the speed limit (65536 substeps of
    max_displacement per step) cannot be split finely enough: the rest of the step takes its
    share of MAX_SUBSTEPS substeps (never more), the step counts once in substeps_capped,
    and the state stays sound."""
    sp = [dg.Species("P", .5, 1, formation_energy=5e9), dg.Species("B", .5, .5),
          dg.Species("C", .5, .5)]
    sc = dg.Scene(bounds=dg.Box(400, 400), species=sp,
                  reactions=[dg.Decomposition("P", "B", "C", 1.0)], dt=1.0)
    sim = dg.Simulation.from_arrays(sc, [[200, 200]], [[0, 0.3]], ["P"], seed=1)
    assert sim.speed_limit < 1e5
    sim.step(1)
    c = sim.counters()
    assert c["substeps_capped"] == 1 and c["resplits"] == 1
    assert c["substeps"] <= _step.MAX_SUBSTEPS + 2
    assert sim.outside() == 0 and abs(sim.energy_balance()) <= 1e-12 * 5e9


def test_cut_substeps_add_up_to_the_step():
    """Cuts and re-splits keep the step's length: a free disc far from the reaction moves
    exactly v dt per step while exchanges cut substeps short."""
    sp = [dg.Species("X", .5, 1), dg.Species("Y", .5, 1), dg.Species("Cp", .5, 1),
          dg.Species("Dp", .5, 1, formation_energy=-200.0), dg.Species("F", .5, 1)]
    sc = dg.Scene(bounds=dg.Box(400, 400), species=sp,
                  reactions=[dg.Exchange("X", "Y", "Cp", "Dp")], dt=0.7)
    sim = dg.Simulation.from_arrays(sc, [[200 - .7, 200], [200 + .7, 200], [20, 20]],
                                    [[1, 0], [-1, 0], [0.375, 0.125]], ["X", "Y", "F"])
    sim.step(3)
    assert sim.counters()["substeps_cut"] == 1
    assert sim.positions[2] == pytest.approx([20 + 0.375 * 2.1, 20 + 0.125 * 2.1], abs=1e-12)


# ------------------------------------------------------------- what nothing re-splits keeps
def _hash(sim):
    h = hashlib.sha256()
    for a in (sim.positions, sim.velocities, sim.species, sim.internal_energy):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def test_the_reactor_scene_is_bit_identical_where_nothing_is_resplit():
    """The built-in reactor (cold start, 300 steps) re-splits nothing and ends in the state
    it ended in before the fix, bit for bit (the hash was computed on the unfixed code)."""
    sim = dg.Simulation("reactor", seed=0)
    sim.step(300)
    assert sim.counters()["resplits"] == 0 and sim.counters()["substeps_cut"] == 0
    assert _hash(sim) == "6d94c71ae6bfa0af"


def test_a_plain_gas_never_resplits():
    """Without reactions or internal energy nothing is checked, however fast collisions
    make a disc (a light disc hit by heavy ones)."""
    sp = [dg.Species("L", .5, .01), dg.Species("H", .5, 100)]
    sc = dg.Scene(bounds=dg.Box(20, 20), species=sp, counts={"L": 30, "H": 30}, dt=0.1)
    sim = dg.Simulation(sc, seed=3)
    sim.step(50)
    assert sim.counters()["resplits"] == 0 and sim.counters()["substeps_cut"] == 0
    assert sim.overlaps() == 0


def test_resplit_runs_do_not_depend_on_how_they_are_split_into_calls():
    """Re-splits and cuts stay inside their step: three steps in one call and one at a
    time end in the same state, bit for bit, with the same counters."""
    out = []
    for calls in ([3], [1, 1, 1]):
        sim, *_ = _corral("exchange", 3000.0, 0.5, 10, 5)
        for n in calls:
            sim.step(n)
        assert sim.counters()["substeps_cut"] > 0
        out.append((_hash(sim), sim.counters()))
    assert out[0] == out[1]
