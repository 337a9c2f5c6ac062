"""The named hard cases of docs/hard_cases.md, one test (or one small group) per case, each
stating the expected outcome in its docstring; the page summarises what the simulator does in
each case and the tolerances used here.

All tests run the time-stepped integrator (``Simulation(..., integrator="step")``, the
default). Tolerances: overlaps are counted relative to the contact distance R_i + R_j
(``sim.overlaps(1e-9)``), escapes relative to the radius (``sim.outside(1e-12)``), energies
relative to the total.
"""

import math

import numpy as np
import pytest

import discgym as dg
from discgym.kernels.collisions import SEPARATING_OVERLAP, contact_time, normal_at
from discgym.kernels.walls import circle_contact

A = dg.Species("A", 0.5, 1.0)
B = dg.Species("B", 0.5, 1.0)

OVERLAP_TOL = 1e-9  # relative to the contact distance
OUTSIDE_TOL = 1e-12  # relative to the radius


def box(w=10.0, h=None, species=(A,), **kw):
    kw.setdefault("dt", 0.05)
    return dg.Scene(bounds=dg.Box(w, w if h is None else h), species=list(species), **kw)


def make(scene, pos, vel, spc=None, **kw):
    spc = [0] * len(pos) if spc is None else spc
    return dg.Simulation.from_arrays(scene, np.asarray(pos, float), np.asarray(vel, float), spc,
                                     **kw)


def forced(scene, pos, vel, spc=None):
    """A simulation whose state holds ``pos``/``vel`` verbatim (overlaps allowed): built from
    a valid placement, then ``set_state`` with the given arrays."""
    n = len(pos)
    spc = [0] * n if spc is None else spc
    x0, y0, x1, y1 = scene.bounds.extent
    free = [[x0 + 0.5 + 1.1 * k, y0 + 0.5] for k in range(n)]
    sim = make(scene, free, np.zeros((n, 2)), spc)
    st = sim.get_state()
    st["positions"] = np.asarray(pos, float)
    st["velocities"] = np.asarray(vel, float)
    sim.set_state(st)
    return sim


def finite(sim):
    return (np.isfinite(sim.positions).all() and np.isfinite(sim.velocities).all()
            and np.isfinite(sim.internal_energy).all())


def sound(sim, overlap_tol=OVERLAP_TOL):
    """Finite, nothing outside, no overlap deeper than ``overlap_tol``."""
    return finite(sim) and sim.outside(OUTSIDE_TOL) == 0 and sim.overlaps(overlap_tol) == 0


def brute_overlaps(sim, tol):
    """O(N^2) reference for ``sim.overlaps(tol)``."""
    p = sim.positions
    r = sim.radii
    d2 = ((p[:, None, :] - p[None, :, :]) ** 2).sum(-1)
    R = (r[:, None] + r[None, :]) * (1.0 - tol)
    iu = np.triu_indices(len(p), 1)
    return int((d2[iu] < (R * R)[iu]).sum())


# ------------------------------------------------------------------------------------------ 1
def test_01_overlapping_pair_with_zero_relative_velocity_is_left_alone():
    """Case 1. ``from_arrays`` refuses an initial overlap (ValueError naming "overlap"). An
    overlapping pair made with ``set_state`` whose relative velocity is zero has no contact
    time (the formula would divide by |v|^2 = 0): it is left alone. It translates rigidly
    (separation vector unchanged to 1e-12), no collision is counted, no NaN appears, the
    energy is exactly unchanged and the overlap remains (nothing pushes it apart)."""
    sc = box()
    with pytest.raises(ValueError, match="overlap"):
        make(sc, [[4.0, 5.0], [4.6, 5.0]], [[0, 0], [0, 0]])
    for v in ([0.0, 0.0], [0.3, 0.1]):
        sim = forced(sc, [[4.0, 5.0], [4.6, 5.0]], [v, v])
        e0 = sim.total_energy()
        sim.step(200)  # 10 time units: moves 3 in x at most, no wall reached
        assert finite(sim)
        assert sim.collisions == 0 and sim.counters()["events_capped"] == 0
        assert sim.total_energy() == e0
        p = sim.positions
        np.testing.assert_allclose(p[1] - p[0], [0.6, 0.0], atol=1e-12)
        np.testing.assert_allclose(p[0], np.array([4.0, 5.0]) + 10.0 * np.array(v), atol=1e-12)
        assert sim.overlaps() == 1


def test_01_overlapping_pair_moving_together_into_a_wall_stays_finite():
    """Case 1 (continued). The same pair moving together into a wall: the wall reflects the
    leading disc, the pair then meets as an overlapping, approaching pair and collides. No
    NaN, energy exactly conserved, nothing outside, no event-budget cap. (What the overlap
    does afterwards is not physics; observed: the pair stays overlapped and bounces as one.)"""
    sim = forced(box(), [[4.0, 5.0], [4.6, 5.0]], [[1.0, 0.3], [1.0, 0.3]])
    e0 = sim.total_energy()
    for _ in range(400):
        sim.step()
        assert finite(sim) and sim.outside(OUTSIDE_TOL) == 0
    assert sim.wall_hits > 0
    assert abs(sim.total_energy() - e0) <= 1e-14 * e0
    assert sim.counters()["events_capped"] == 0


# ------------------------------------------------------------------------------------------ 2
@pytest.mark.parametrize("v1, v2", [([1.0, 0.0], [-1.0, 0.0]), ([1.0, 0.0], [0.0, 0.0]),
                                    ([0.3, 0.7], [-0.2, 0.1])])
def test_02_coincident_centres_give_no_nan_and_conserve(v1, v2):
    """Case 2. Two discs with exactly coincident centres (set_state) and a relative velocity:
    the collision normal (r_j - r_i)/|r_j - r_i| is 0/0. The normal falls back to another
    direction; nothing becomes NaN, momentum and energy are conserved to round-off, and the
    pair separates (no overlap after 100 steps of free flight)."""
    sim = forced(box(), [[5.0, 5.0], [5.0, 5.0]], [v1, v2])
    e0, p0 = sim.total_energy(), sim.momentum()
    sim.step(1)
    assert finite(sim)
    assert abs(sim.total_energy() - e0) <= 1e-15 * e0
    np.testing.assert_allclose(sim.momentum(), p0, atol=1e-15)
    sim.step(99)
    assert finite(sim) and sim.outside(OUTSIDE_TOL) == 0 and sim.overlaps() == 0


def test_02_coincident_centres_do_not_exhaust_the_event_budget():
    """Case 2 (work bound). Coincident centres approaching along x: at most one collision in
    the first step, and the event budget is never the thing that ends it
    (``events_capped == 0``). Before the fix: 1152 collisions (the whole budget of a
    2-disc step)."""
    sim = forced(box(), [[5.0, 5.0], [5.0, 5.0]], [[1.0, 0.0], [-1.0, 0.0]])
    sim.step(1)
    assert sim.counters()["events_capped"] == 0
    assert sim.collisions <= 1


def test_02_normal_fallback_kernel_is_a_unit_vector():
    """Case 2 (kernel). ``normal_at`` with coincident centres returns a finite unit normal
    for any relative velocity, zero included."""
    for vi, vj in [((1.0, 0.0), (-1.0, 0.0)), ((0.0, 0.0), (0.0, 0.0)), ((2.0, -3.0), (0, 0))]:
        *_, nx, ny = normal_at(5.0, 5.0, *vi, 5.0, 5.0, *vj, 0.0)
        assert math.isfinite(nx) and math.isfinite(ny)
        assert math.hypot(nx, ny) == pytest.approx(1.0, abs=1e-15)


# ------------------------------------------------------------------------------------------ 3
def test_03_exactly_touching_discs_approaching_collide_separating_do_not():
    """Case 3. Discs exactly touching (distance = R_i + R_j): approaching head-on, they
    collide at once (equal masses: velocities swap exactly, one collision); separating, moving
    together or sliding tangentially, nothing happens (no collision, velocities untouched)."""
    sc = box()
    sim = make(sc, [[4.0, 5.0], [5.0, 5.0]], [[1.0, 0.0], [-1.0, 0.0]])
    sim.step()
    assert sim.collisions == 1
    assert sim.velocities.tolist() == [[-1.0, 0.0], [1.0, 0.0]]
    np.testing.assert_allclose(sim.positions, [[3.95, 5.0], [5.05, 5.0]], atol=1e-14)
    for v in ([[-1.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [0.0, -1.0]]):
        sim = make(sc, [[4.0, 5.0], [5.0, 5.0]], v)
        sim.step()
        assert sim.collisions == 0
        assert sim.velocities.tolist() == v
        assert sim.overlaps() == 0


def test_03_grazing_contacts_stay_finite_and_conserve():
    """Case 3 (grazing). 400 pairs passing at impact parameter R(1 + d), d within a few 1e-16
    of 0 (the contact is decided by round-off): every outcome is finite, kinetic energy and
    momentum are conserved to 1e-13 relative (far from the walls), no overlap remains."""
    sc = box(200.0)
    rng = np.random.default_rng(0)
    for _ in range(400):
        ang = rng.uniform(0.0, 2.0 * np.pi)
        d = np.array([np.cos(ang), np.sin(ang)])
        perp = np.array([-d[1], d[0]])
        b = 1.0 + rng.integers(-4, 5) * 1.1e-16
        c = np.array([100.0, 100.0])
        speed = rng.uniform(0.5, 3.0)
        sim = make(sc, [c - 2.0 * d + b * perp, c], [speed * d, rng.normal(size=2) * 1e-9])
        e0, p0 = sim.kinetic_energy(), sim.momentum()
        sim.step(60)
        assert finite(sim)
        assert abs(sim.kinetic_energy() - e0) <= 1e-13 * e0
        np.testing.assert_allclose(sim.momentum(), p0, atol=1e-13 * speed)
        assert sim.overlaps(OVERLAP_TOL) == 0


def test_03_negative_discriminant_by_round_off_is_clamped():
    """Case 3 (kernels). Where the discriminant of a contact time is negative only by
    round-off (a disc that crossed the circle wall while moving tangentially), the kernel
    clamps it to zero and returns a finite contact time in the past (t <= 0). Disc-disc
    contacts of pairs overlapping by one ulp, moving tangentially, likewise return a finite
    time within the step."""
    rng = np.random.default_rng(1)
    negative = 0
    for _ in range(20000):
        ang = rng.uniform(0.0, 2.0 * np.pi)
        L, h, s = 4.5, rng.uniform(1e-9, 1e-3), rng.uniform(0.1, 10.0)
        vx, vy = -s * math.sin(ang), s * math.cos(ang)
        x, y = L * math.cos(ang) + h * vx, L * math.sin(ang) + h * vy
        c = x * x + y * y - L * L
        dv = x * vx + y * vy
        if c > 0.0 and dv > 0.0 and dv * dv - (vx * vx + vy * vy) * c < 0.0:
            negative += 1
            t, _, _ = circle_contact(x, y, vx, vy, 0.5, 0.0, 0.0, 5.0)
            assert math.isfinite(t) and t <= 0.0
    assert negative > 1000  # the round-off case really is exercised
    for _ in range(2000):
        ang = rng.uniform(0.0, 2.0 * np.pi)
        rr = 1.0 - 2.3e-16
        rx, ry = rr * math.cos(ang), rr * math.sin(ang)
        vx, vy = -math.sin(ang), math.cos(ang)
        t = contact_time(rx, ry, vx, vy, 1.0, -0.05)
        assert math.isnan(t) or -0.05 <= t <= 0.0


# ------------------------------------------------------------------------------------------ 4
def test_04_head_on_equal_masses_swap_velocities_exactly():
    """Case 4. Head-on, equal masses, e = 1: the velocities swap bit for bit (dyadic speeds)
    and the contact time is exact (positions to 1e-12)."""
    for v1, v2 in [(1.0, -2.0), (0.5, -0.25), (3.0, 0.0), (1.5, 0.5)]:
        sim = make(box(50.0), [[20.0, 25.0], [30.0, 25.0]], [[v1, 0.0], [v2, 0.0]])
        tc = 9.0 / (v1 - v2)
        sim.advance(tc + 2.0)
        assert sim.collisions == 1
        assert sim.velocities.tolist() == [[v2, 0.0], [v1, 0.0]]
        xc = (20.0 + v1 * tc, 30.0 + v2 * tc)
        np.testing.assert_allclose(sim.positions[:, 0], [xc[0] + 2 * v2, xc[1] + 2 * v1],
                                   atol=1e-12)


@pytest.mark.parametrize("ratio", [1e-6, 1e-4, 1e-2, 1.0, 1e2, 1e4, 1e6])
def test_04_extreme_mass_ratios_create_no_energy(ratio):
    """Case 4 (mass ratios 1e-6 .. 1e6). 40 oblique collisions per ratio: each conserves
    kinetic energy to 1e-13 relative and momentum to 1e-13 of the momentum scale (measured
    worst: ~1e-15); exactly one collision each."""
    sc = dg.Scene(bounds=dg.Box(100.0, 100.0), dt=0.05,
                  species=[dg.Species("a", 0.5, 1.0), dg.Species("b", 0.5, ratio)])
    rng = np.random.default_rng(0)
    for _ in range(40):
        b = rng.uniform(-0.99, 0.99)
        drift = rng.normal() * 0.2
        v1 = [rng.uniform(0.5, 3.0), drift]
        v2 = [-rng.uniform(0.5, 3.0), drift]
        sim = make(sc, [[47.0, 50.0 + b], [50.0, 50.0]], [v1, v2], [0, 1])
        e0, p0 = sim.kinetic_energy(), sim.momentum()
        scale = 3.0 * (1.0 + ratio)
        sim.advance(5.0)
        assert sim.collisions == 1
        assert abs(sim.kinetic_energy() - e0) <= 1e-13 * e0
        assert np.abs(sim.momentum() - p0).max() <= 1e-13 * scale


# ------------------------------------------------------------------------------------------ 5
def test_05_disc_crossing_the_whole_reactor_in_one_step_does_not_tunnel():
    """Case 5. Speed 1000 in a 10 x 10 box with dt = 0.05 (50 box widths per step). The step
    is split into ceil(1000 * 0.05 / (0.5 * 0.5)) = 200 substeps (``counters()["substeps"]``),
    so the fast disc never passes through the resting one: in 1D the outcome is exact (the
    two discs act as ghost particles that pass through each other): 6 collisions, 6 wall hits,
    final positions (3, 5) and (5, 5), velocities (1000, 0) and (0, 0)."""
    sim = make(box(), [[1.0, 5.0], [5.0, 5.0]], [[1000.0, 0.0], [0.0, 0.0]])
    sim.step(1)
    c = sim.counters()
    assert c["substeps"] == 200 and c["substeps_capped"] == 0
    assert c["collisions"] == 6 and c["wall_hits"] == 6
    np.testing.assert_allclose(sim.positions, [[3.0, 5.0], [5.0, 5.0]], atol=1e-9)
    np.testing.assert_allclose(sim.velocities, [[1000.0, 0.0], [0.0, 0.0]], atol=1e-9)


def test_05_fast_disc_in_a_crowd_stays_inside_and_conserves():
    """Case 5 (2D, crowd). One disc at speed ~1070 among 29 thermal ones: after every one of
    50 steps nothing is outside, nothing overlaps, and the kinetic energy (~5.7e5) is
    conserved to 1e-11 relative; the fast disc collides (it cannot slip through)."""
    sim = dg.Simulation(box(counts={"A": 30}), seed=0)
    st = sim.get_state()
    st["velocities"][0] = [1000.0, 377.0]
    sim.set_state(st)
    e0 = sim.kinetic_energy()
    for _ in range(50):
        sim.step()
        assert sound(sim)
    assert sim.collisions > 1000 and sim.counters()["substeps"] > 50 * 20
    assert abs(sim.kinetic_energy() - e0) <= 1e-11 * e0


# ------------------------------------------------------------------------------------------ 6
@pytest.mark.parametrize("dt", [
    0.05,
    0.07,
    0.3,
])
def test_06_corner_hit_reflects_both_components_exactly(dt):
    """Case 6 (box corner). A disc aimed exactly at the corner, (8.5, 8.5) -> (1, 1), touches
    both walls at t = 1: both velocity components reflect, and at t = 1.3 it is at (9.2, 9.2)
    (to 1e-9) moving (-1, -1), after exactly 2 wall hits, without any ``pushed_inside``
    correction. With dt = 0.05 the contact falls on a step boundary; with 0.07 and 0.3 it
    falls inside a step (both walls crossed in the same step)."""
    sim = make(box(dt=dt), [[8.5, 8.5]], [[1.0, 1.0]])
    sim.advance(1.3)
    np.testing.assert_allclose(sim.velocities, [[-1.0, -1.0]], atol=1e-14)
    np.testing.assert_allclose(sim.positions, [[9.2, 9.2]], atol=1e-9)
    assert sim.wall_hits == 2
    assert sim.counters()["pushed_inside"] == 0


def test_06_disc_resting_in_a_corner_is_hit():
    """Case 6 (found by the property test). Five discs in a 5 x 5 box, then two injected at
    kT = 0 near the corner (5, 0): one lands exactly in the corner, at rest. Over 20 steps
    the others knock it about: no overlap, nothing outside, no ``pushed_inside`` fix-up.
    Before the fix an overlap appeared at step 3, right after a push_inside."""
    sc = dg.Scene(bounds=dg.Box(5.0, 5.0), species=[A], dt=0.0625, internal_relaxation=0.0,
                  counts={"A": 5})
    sim = dg.Simulation(sc, seed=0)
    assert sim.inject("A", 2, temperature=0.0, near=(5.0, 0.0)) == 2
    assert sim.positions[5].tolist() == [4.5, 0.5]
    for _ in range(20):
        sim.step()
        assert sound(sim)
    assert sim.counters()["pushed_inside"] == 0


def test_06_tangential_motion_along_a_wall_and_resting_in_a_corner():
    """Case 6. A disc touching the bottom wall and moving parallel to it slides freely (no
    wall hit, y exactly unchanged, x to 1e-12); a disc at rest in a corner stays put."""
    sim = make(box(), [[1.0, 0.5]], [[1.0, 0.0]])
    sim.step(100)
    assert sim.wall_hits == 0 and sim.positions[0, 1] == 0.5
    assert sim.positions[0, 0] == pytest.approx(6.0, abs=1e-12)
    sim = make(box(), [[0.5, 0.5]], [[0.0, 0.0]])
    sim.step(100)
    assert sim.positions.tolist() == [[0.5, 0.5]] and sim.wall_hits == 0


def test_06_circle_centre_full_size_disc_and_tangential_motion():
    """Case 6 (circle). (a) A disc at rest at the exact centre stays there. (b) Leaving the
    exact centre, it hits the wall radially and comes straight back (one wall hit, exact to
    1e-12). (c) A disc whose radius equals the circle's (off-origin centre too) stays at the
    centre, is never reported outside (``outside(0) == 0`` after every step) and keeps its
    kinetic energy exactly. (d) A disc touching the wall and moving tangentially creeps
    along it through hundreds of reflections: always inside, kinetic energy conserved to
    1e-13 relative."""
    sc = dg.Scene(bounds=dg.Circle(5.0), species=[A], dt=0.05)
    sim = make(sc, [[0.0, 0.0]], [[0.0, 0.0]])
    sim.step(100)
    assert sim.positions.tolist() == [[0.0, 0.0]]
    sim = make(sc, [[0.0, 0.0]], [[0.6, 0.8]])
    sim.advance(5.0)  # hit at distance 4.5 (t = 4.5), then 0.5 back
    assert sim.wall_hits == 1
    np.testing.assert_allclose(sim.positions, [[2.4, 3.2]], atol=1e-12)
    np.testing.assert_allclose(sim.velocities, [[-0.6, -0.8]], atol=1e-12)
    for centre in [(0.0, 0.0), (3.3, -1.7)]:
        big = dg.Scene(bounds=dg.Circle(5.0, center=centre), species=[dg.Species("B", 5.0, 1.0)],
                       dt=0.05)
        sim = make(big, [centre], [[0.6, 0.8]])
        for _ in range(100):
            sim.step()
            assert sim.outside(0.0) == 0 and finite(sim)
        assert sim.positions.tolist() == [list(centre)]
        assert sim.kinetic_energy() == 0.5
    sim = make(sc, [[4.5, 0.0]], [[0.0, 1.0]])
    for _ in range(1000):
        sim.step()
        assert sim.outside(0.0) == 0
    assert sim.wall_hits > 100
    assert abs(sim.kinetic_energy() - 0.5) <= 1e-13 * 0.5


# ------------------------------------------------------------------------------------------ 7
@pytest.mark.parametrize("n_line", [1, 2, 3, 5, 10])
@pytest.mark.parametrize("dt", [0.05, 0.013])
def test_07_newtons_cradle(n_line, dt):
    """Case 7. A disc at speed 1 hits a line of ``n_line`` touching discs at rest: all the
    momentum ends up in the last disc (velocity exactly (1, 0)), the others stop exactly, the
    disc positions are exact to 1e-9, with exactly ``n_line`` collisions."""
    sc = box(40.0, 10.0, dt=dt)
    pos = [[5.0, 5.0]] + [[10.0 + k, 5.0] for k in range(n_line)]
    vel = [[1.0, 0.0]] + [[0.0, 0.0]] * n_line
    sim = make(sc, pos, vel)
    sim.advance(6.0)  # contact at t = 4, then 2 time units
    assert sim.collisions == n_line
    v = sim.velocities
    assert v[-1].tolist() == [1.0, 0.0]
    assert (v[:-1] == 0.0).all()
    expect = [9.0 + k for k in range(n_line)] + [12.0 + n_line - 1]
    np.testing.assert_allclose(sim.positions[:, 0], expect, atol=1e-9)


def test_07_simultaneous_multi_body_contacts():
    """Case 7 (simultaneous contacts). (a) Two discs hit a resting middle one from both sides
    at the same instant: the outer ones bounce back at speed 1 and the middle one stays at
    rest (1D ghost-particle result, exact). (b) Three discs converge on a resting central one
    at 120 degrees, (c) four converge on a point: momentum conserved to 1e-15, energy to 1e-14
    relative, no overlap, no NaN, no event cap."""
    sc = box(20.0)
    sim = make(sc, [[7.0, 10.0], [10.0, 10.0], [13.0, 10.0]],
               [[1.0, 0.0], [0.0, 0.0], [-1.0, 0.0]])
    sim.advance(4.0)
    np.testing.assert_allclose(sim.velocities, [[-1, 0], [0, 0], [1, 0]], atol=1e-15)
    np.testing.assert_allclose(sim.positions, [[7.0, 10.0], [10.0, 10.0], [13.0, 10.0]],
                               atol=1e-12)
    c = np.array([10.0, 10.0])
    for central, k in [(True, 3), (False, 4)]:
        pos, vel = ([c], [[0.0, 0.0]]) if central else ([], [])
        for q in range(k):
            a = 2.0 * math.pi * q / k
            d = np.array([math.cos(a), math.sin(a)])
            pos.append(c + 3.0 * d)
            vel.append(-d)
        sim = make(sc, pos, vel)
        e0, p0 = sim.kinetic_energy(), sim.momentum()
        sim.advance(4.0)
        assert sim.collisions >= k
        assert sound(sim) and sim.counters()["events_capped"] == 0
        assert abs(sim.kinetic_energy() - e0) <= 1e-14 * e0
        np.testing.assert_allclose(sim.momentum(), p0, atol=1e-15)


def test_07_dense_packing_near_jamming_box():
    """Case 7 (jamming). Packing fraction 0.8 in a 20 x 20 box (407 discs: random addition
    fails, so they are placed on a hexagonal lattice automatically). After every one of 60
    steps: nothing outside, no overlap deeper than 1e-9 of a diameter, no event cap; kinetic
    energy conserved to 1e-11 relative (~2e4 collisions per step)."""
    bounds = dg.Box(20.0, 20.0)
    n = int(0.8 * bounds.area / (math.pi * 0.25))
    sim = dg.Simulation(box(20.0, counts={"A": n}), seed=0)
    assert len(sim) == n and sim.packing_fraction() == pytest.approx(0.8, abs=0.002)
    e0 = sim.kinetic_energy()
    for _ in range(60):
        sim.step()
        assert sound(sim)
    assert sim.counters()["events_capped"] == 0
    assert abs(sim.kinetic_energy() - e0) <= 1e-11 * e0


def test_07_dense_packing_near_jamming_circle():
    """Case 7 (jamming, circle: no corners). Packing 0.75 in a circle of radius 10: after
    every one of 60 steps, nothing outside, no overlap, no event cap, energy to 1e-11."""
    b = dg.Circle(10.0)
    n = int(0.75 * b.area / (math.pi * 0.25))
    sim = dg.Simulation(dg.Scene(bounds=b, species=[A], counts={"A": n}, dt=0.05), seed=0)
    e0 = sim.kinetic_energy()
    for _ in range(60):
        sim.step()
        assert sound(sim)
    assert sim.counters()["events_capped"] == 0 and sim.collisions > 10000
    assert abs(sim.kinetic_energy() - e0) <= 1e-11 * e0


# ------------------------------------------------------------------------------------------ 8
def test_08_restitution_zero_does_not_hang():
    """Case 8 (inelastic collapse). 300 discs, e = 0, 24 x 24 box, 400 steps: the step never
    runs out of its event budget (``events_capped == 0``) because a disc's second and later
    collisions within one substep are elastic (TC model, counted in ``elastic_repeats`` > 0);
    no overlap, nothing outside after every step; the energy balance (start + input -
    dissipated - now) is 0 to 1e-10 of the initial energy."""
    sim = dg.Simulation(box(24.0, counts={"A": 300}, restitution=0.0), seed=0)
    e0 = sim.total_energy()
    for _ in range(400):
        sim.step()
        assert sound(sim)
    c = sim.counters()
    assert c["events_capped"] == 0 and c["elastic_repeats"] > 0
    assert sim.dissipated_energy > 0.5 * e0  # it did collapse: most energy is gone
    assert abs(sim.energy_balance()) <= 1e-10 * e0


def test_08_dense_inelastic_box_pumped_by_heating():
    """Case 8 (collapse against heating). Packing 0.6, e = 0, the kinetic energy restored to
    kT = 1 every 10 steps (an agent heating a collapsing cluster): 400 steps with no event
    cap, no overlap, nothing outside, and energy input and dissipation accounted to 1e-12 of
    the energy that went through."""
    n = int(0.6 * 400 / (math.pi * 0.25))
    sim = dg.Simulation(box(20.0, counts={"A": n}, restitution=0.0), seed=0)
    for k in range(400):
        if k % 10 == 0 and sim.temperature() > 0:
            sim.scale_temperature(min(1e3, 1.0 / sim.temperature()))
        sim.step()
        assert sound(sim)
    assert sim.counters()["events_capped"] == 0
    assert abs(sim.energy_balance()) <= 1e-12 * (sim.energy_input + sim.total_energy())


def _heated_inelastic_circle(species, counts, factor):
    sc = dg.Scene(bounds=dg.Circle(3.0), species=species, restitution=0.0, dt=0.0625,
                  internal_relaxation=0.0, counts=counts)
    sim = dg.Simulation(sc, seed=0)
    sim.step(10)
    sim.scale_temperature(factor)
    return sim


def test_08_heated_inelastic_cluster_in_a_circle_stays_inside():
    """Case 8 (found by the long-mode property test). 28 discs (radii 0.2-0.42, packing 0.2)
    at e = 0 in a circle of radius 3, heated 1e6 times after 10 steps: 10 more steps keep
    every disc inside and free of overlap, with the energy accounted after every step.

    The e = 0 cluster presses discs onto the curved wall, where a disc sliding along it is
    wedged by its neighbour: its reflections come at the same instant with no finite end.
    Such discs glide along the wall in closed form where nothing is in the way
    (``wall_glides``); a disc that stays wedged, or runs out of its per-substep events, has
    the rest of its substep repaired by the documented fallback (``events_capped`` substeps,
    ``fallback_repairs``; kernels/resolve.py), which keeps the invariants. Before the fix the
    dropped events left 15 discs outside by step 6 and overlaps up to 1e-3."""
    sp = [dg.Species("S0", 0.25, 1.0), dg.Species("S1", 0.422466104992845, 1.0),
          dg.Species("S2", 0.2, 2.0)]
    sim = _heated_inelastic_circle(sp, {"S0": 4, "S1": 4, "S2": 20}, 1e6)
    for _ in range(10):
        sim.step()
        assert abs(sim.energy_balance()) <= 1e-10 * sim.total_energy()
        assert sound(sim)
    c = sim.counters()
    assert c["wall_glides"] > 0
    assert (c["events_capped"] > 0) == (c["fallback_repairs"] > 0)
    assert c["events_capped"] < c["substeps"] / 2  # the fallback is the exception


def test_08_glide_stops_for_a_neighbour_that_changes_course():
    """Case 8 (found by the long-mode property test). An e = 0 pair of species in a circle
    of radius 3.75, cooled to rest, fed, then heated 1000 times: a disc gliding along the
    wall met a neighbour whose trajectory changed after the glide was computed (an overlap of
    5e-3 remained). A glide with a disc near now stops at the next queued event. 10 steps,
    sound after each."""
    sc = dg.Scene(bounds=dg.Circle(3.75), restitution=0.0, dt=0.0625, internal_relaxation=0.0,
                  max_displacement=0.25, counts={"S0": 4, "S1": 4},
                  species=[dg.Species("S0", 0.6796875, 1.0), dg.Species("S1", 0.625, 1.0)])
    sim = dg.Simulation(sc, seed=0)
    sim.scale_temperature(0.0)
    sim.step(10)
    sim.inject("S0", 4, temperature=1.0)
    sim.step(26)
    sim.scale_temperature(0.5)
    sim.step(22)
    sim.scale_temperature(1000.0)
    for _ in range(10):
        sim.step()
        assert sound(sim)


def test_08_inelastic_cluster_pressed_on_the_circle_wall():
    """Case 8 (found by the long-mode property test). 17 discs at e = 0 in a circle of radius
    3 (packing 0.28), heated 1000 times after 10 steps: 10 more steps with no overlap deeper
    than 1e-9 and nothing outside. Before the fix an overlap of > 1e-5 appeared at step 5 after 5
    ``pushed_inside`` fix-ups."""
    sp = [dg.Species("S0", 0.5, 1.0), dg.Species("S1", 0.5, 1.0), dg.Species("S2", 0.25, 2.0)]
    sim = _heated_inelastic_circle(sp, {"S0": 4, "S1": 4, "S2": 9}, 1e3)
    for _ in range(10):
        sim.step()
        assert sound(sim)


def test_08_restitution_zero_pair_sticks_and_books_the_loss():
    """Case 8 (single pair). e = 0 head-on: both discs leave with the centre-of-mass
    velocity, and the kinetic energy lost, 1/2 mu v_r^2 = 1/4 * 4 = 1, is booked exactly in
    ``dissipated_energy``."""
    sim = make(box(20.0, restitution=0.0), [[5.0, 10.0], [8.0, 10.0]],
               [[1.0, 0.0], [-1.0, 0.0]])
    sim.advance(2.0)
    assert sim.velocities.tolist() == [[0.0, 0.0], [0.0, 0.0]]
    assert sim.dissipated_energy == 1.0 and sim.energy_balance() == 0.0


# ------------------------------------------------------------------------------------------ 9
def test_09_cell_radius_follows_the_small_discs_when_the_large_are_few():
    """Case 9 (no cost cliff). The cell grid is sized by the small discs when the much larger
    ones are few (``celllist.cell_radius``): 20 discs of radius 5 among 20000 of radius 0.1
    give cells for r = 0.1 (the large discs go to the big cell, searched by every query), so
    the cells do not grow 50-fold; when the large discs are many, or the radii are close, the
    cells are sized by the largest radius as before."""
    from discgym.kernels.celllist import cell_radius

    radius = np.array([0.1, 5.0])
    few = np.r_[np.zeros(20000), np.ones(20)].astype(np.int32)
    many = np.r_[np.zeros(200), np.ones(200)].astype(np.int32)
    assert cell_radius(few, len(few), radius) == 0.1
    assert cell_radius(many, len(many), radius) == 5.0
    assert cell_radius(few, len(few), np.array([0.5, 0.65])) == 0.65  # close radii
    assert cell_radius(few[:0], 0, radius) == 0.1  # no large disc at all


@pytest.mark.parametrize("bounds", [dg.Box(60.0, 60.0), dg.Circle(36.0)])
def test_09_polydisperse_1_to_50_neighbour_search(bounds):
    """Case 9. Radii 0.1 and 5 (ratio 1:50), 600 small and 20 large discs: after every one
    of 60 steps ``sim.overlaps(1e-9)`` is 0, and so is an O(N^2) brute-force count every 10
    steps (the step's cell list missed no pair); nothing is outside; energy is conserved to
    1e-11.
    Then 200 small discs are moved (``set_state``) onto random points, many inside the large
    discs and across cell boundaries: ``sim.overlaps(tol)`` still equals the brute-force
    count for tol = 1e-9 and 0.01 (the overlap counter's own grid misses nothing).

    Performance is not asserted here (no wall-clock in tests); docs/hard_cases.md gives the
    measured cost and the command."""
    sc = dg.Scene(bounds=bounds, dt=0.05, counts={"s": 600, "L": 20},
                  species=[dg.Species("s", 0.1, 1.0), dg.Species("L", 5.0, 2500.0)])
    sim = dg.Simulation(sc, seed=0)
    e0 = sim.kinetic_energy()
    for k in range(60):
        sim.step()
        assert sim.outside(OUTSIDE_TOL) == 0 and sim.overlaps(OVERLAP_TOL) == 0
        if k % 10 == 9:
            assert brute_overlaps(sim, OVERLAP_TOL) == 0
    assert sim.collisions > 100
    assert abs(sim.kinetic_energy() - e0) <= 1e-11 * e0
    st = sim.get_state()
    rng = np.random.default_rng(1)
    small = np.flatnonzero(st["species"] == 0)[:200]
    x0, y0, x1, y1 = bounds.extent
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    ang = rng.uniform(0, 2 * np.pi, 200)
    rad = 0.6 * (x1 - x0) / 2 * np.sqrt(rng.random(200))
    st["positions"][small] = np.c_[cx + rad * np.cos(ang), cy + rad * np.sin(ang)]
    sim.set_state(st)
    for tol in (OVERLAP_TOL, 0.01):
        k = sim.overlaps(tol)
        assert k == brute_overlaps(sim, tol) and k > 10


# ----------------------------------------------------------------------------------------- 10
def test_10_temperature_scaled_to_zero_freezes_everything():
    """Case 10. ``scale_temperature(0)``: every velocity becomes exactly 0, the energy removed
    is booked (balance 0 to 1e-12); 50 further steps move nothing (positions bit-identical),
    take one substep each, count no collision or wall hit, and produce no NaN."""
    sim = dg.Simulation(box(20.0, counts={"A": 100}), seed=0)
    sim.step(20)
    sim.scale_temperature(0.0)
    assert (sim.velocities == 0.0).all() and sim.kinetic_energy() == 0.0
    assert abs(sim.energy_balance()) <= 1e-12 * 100
    p0, c0 = sim.positions, sim.counters()
    sim.step(50)
    c = sim.counters()
    assert np.array_equal(sim.positions, p0) and finite(sim)
    assert c["substeps"] - c0["substeps"] == 50
    assert c["collisions"] == c0["collisions"] and c["wall_hits"] == c0["wall_hits"]


def test_10_all_discs_at_rest_from_the_start():
    """Case 10. ``Simulation(scene, temperature=0)``: all velocities exactly 0, and 20 steps
    change nothing (kinetic energy stays exactly 0)."""
    sim = dg.Simulation(box(20.0, counts={"A": 100}), temperature=0.0, seed=0)
    assert (sim.velocities == 0.0).all()
    p0 = sim.positions
    sim.step(20)
    assert np.array_equal(sim.positions, p0) and sim.kinetic_energy() == 0.0


def test_10_temperature_scaled_a_million_times():
    """Case 10. The reactor scene heated by 1e6 (speeds x1000): 5 steps each take hundreds of
    substeps; after every step everything is finite, inside, free of overlap, and the
    energy balance is 0 to 1e-12 of the total energy (~2e8)."""
    sim = dg.Simulation("reactor", seed=0)
    sim.step(20)
    sim.scale_temperature(1e6)
    for _ in range(5):
        before = sim.counters()["substeps"]
        sim.step()
        assert sim.counters()["substeps"] - before > 100
        assert sound(sim)
        assert abs(sim.energy_balance()) <= 1e-12 * sim.total_energy()
    assert sim.counters()["substeps_capped"] == 0


def test_10_absurd_heating_is_refused_or_kept_sound():
    """Case 10 (beyond the extreme). ``scale_temperature(1e40)`` (speeds ~1e20): either the
    control refuses it with ValueError, or the next step keeps every disc inside and free of
    overlap (the step's work being bounded by MAX_SUBSTEPS, counted in ``substeps_capped``).
    Before the fix, neither: the substep count overflowed and 11 pairs overlapped after one
    step. Now the control refuses a speed above ``Simulation.speed_limit``."""
    sim = dg.Simulation(box(20.0, counts={"A": 30}), seed=0)
    try:
        sim.scale_temperature(1e40)
    except ValueError:
        return
    sim.step(1)
    assert sound(sim)


def test_10_decomposition_of_a_disc_at_rest():
    """Case 10 (decomposing disc at rest). AB (formation energy 2) -> A + B, certain, parent
    at rest: the fragments leave back to back in a direction that depends on the seed
    (random), with momentum exactly balanced (total |p| <= 1e-15) and total energy conserved
    to 1e-15 relative (the formation energy 2 becomes kinetic energy)."""
    AB = dg.Species("AB", 0.7, 2.0, formation_energy=2.0)
    sc = dg.Scene(bounds=dg.Box(10.0, 10.0), species=[AB, A, B], dt=0.05,
                  reactions=[dg.Decomposition("AB", "A", "B", 1.0)])
    directions = []
    for seed in range(6):
        sim = make(sc, [[5.0, 5.0]], [[0.0, 0.0]], ["AB"], seed=seed)
        e0 = sim.total_energy()
        sim.step(1)
        assert sim.counts() == {"AB": 0, "A": 1, "B": 1}
        assert np.abs(sim.momentum()).max() <= 1e-15
        assert sim.total_energy() == pytest.approx(e0, rel=1e-15)
        assert sim.kinetic_energy() == pytest.approx(2.0, rel=1e-15)
        v = sim.velocities
        directions.append(math.atan2(v[0, 1], v[0, 0]))
    assert len({round(d, 6) for d in directions}) == len(directions)


# ----------------------------------------------------------------------------------------- 11
C = dg.Species("C", 0.65, 2.0, formation_energy=-1.0)
W = dg.Species("W", 0.65, 2.0, formation_energy=-1.5)


def chem(**kw):
    kw.setdefault("dt", 0.05)
    kw.setdefault("bounds", dg.Box(10.0, 10.0))
    kw.setdefault("species", [A, B, C, W, dg.Species("D", 0.5, 1.0)])
    kw.setdefault("reactions", [dg.Combination("A", "B", "C", 0.0, 0.0),
                                dg.Exchange("C", "A", "W", "B", 0.0)])
    return dg.Scene(**kw)


def test_11_reaction_at_a_wall_without_room_bounces():
    """Case 11 (wall). A and B meet head-on while sliding along the bottom wall; the product
    C (radius 0.65) would stick out of the wall, so the combination does not happen: the pair
    bounces elastically (velocities swapped), one ``reactions_without_room`` is counted, and
    nothing is outside."""
    sim = make(chem(), [[4.0, 0.5], [5.2, 0.5]], [[1.0, 0.0], [-1.0, 0.0]], ["A", "B"])
    sim.step(3)
    assert sim.counts()["C"] == 0
    assert sim.counters()["reactions_without_room"] == 1 and sim.collisions == 1
    assert sim.velocities.tolist() == [[-1.0, 0.0], [1.0, 0.0]]
    assert sim.outside(0.0) == 0


def test_11_decomposition_with_no_room_waits_and_is_counted():
    """Case 11 (wall). AB fills a 1.4 x 1.4 box exactly; its fragments can never fit, so the
    certain decomposition never fires: AB stays, one ``reactions_without_room`` per substep,
    nothing outside. Against a single wall (room only in some directions) it fires within a
    few steps, fragments inside."""
    AB = dg.Species("AB", 0.7, 2.0, formation_energy=2.0)
    kw = dict(species=[AB, A, B], reactions=[dg.Decomposition("AB", "A", "B", 1.0)], dt=0.05)
    sim = make(dg.Scene(bounds=dg.Box(1.4, 1.4), **kw), [[0.7, 0.7]], [[0.0, 0.0]], ["AB"])
    sim.step(20)
    assert sim.counts() == {"AB": 1, "A": 0, "B": 0}
    assert sim.counters()["reactions_without_room"] == 20 and sim.outside(0.0) == 0
    sim = make(dg.Scene(bounds=dg.Box(10.0, 10.0), **kw), [[0.7, 5.0]], [[0.0, 0.0]], ["AB"],
               seed=1)
    sim.step(20)
    assert sim.counts() == {"AB": 0, "A": 1, "B": 1}
    assert sound(sim)


def test_11_reaction_in_a_crowd_without_room_bounces():
    """Case 11 (crowd). A and B collide where a third disc D occupies the product's spot:
    no C is made (it would overlap D), the pair bounces elastically, one
    ``reactions_without_room``, no overlap. Without D the same collision makes C."""
    sim = make(chem(), [[4.0, 5.0], [5.2, 5.0], [4.6, 5.9]],
               [[1.0, 0.0], [-1.0, 0.0], [0.0, 0.0]], ["A", "B", "D"])
    sim.step(3)
    assert sim.counts()["C"] == 0 and sim.counters()["reactions_without_room"] == 1
    assert sim.overlaps() == 0
    sim = make(chem(), [[4.0, 5.0], [5.2, 5.0], [4.6, 6.5]],
               [[1.0, 0.0], [-1.0, 0.0], [0.0, 0.0]], ["A", "B", "D"])
    sim.step(3)
    assert sim.counts()["C"] == 1 and sim.overlaps() == 0


def test_11_dense_reacting_crowd_stays_sound():
    """Case 11 (crowd). The reactor scene squeezed into a 16 x 16 box (packing ~0.75) at
    kT = 4: 300 steps with reactions refused for lack of room (counted), no overlap, nothing
    outside after every step, total energy balance 0 to 1e-11 relative."""
    sc = dg.scenes.load("reactor").replace(bounds=dg.Box(16.0, 16.0))
    sim = dg.Simulation(sc, seed=1, temperature=4.0)
    for _ in range(300):
        sim.step()
        assert sound(sim)
    assert sim.counters()["reactions_without_room"] > 0
    assert sum(sim.reactions().values()) > 0
    assert abs(sim.energy_balance()) <= 1e-11 * abs(sim.total_energy())


@pytest.mark.parametrize("kind", ["transformation", "decomposition", "combination",
                                  "exchange"])
def test_11_endothermic_reaction_without_enough_energy_never_fires(kind):
    """Case 11 (endothermic). Each reaction type made far too endothermic for the available
    energy (kT = 1 or 3, formation energies +5 .. +200, certain or barrier-free): over 200
    steps it never fires, counts are unchanged, and total energy is conserved to 1e-12."""
    X = dg.Species("X", 0.5, 1.0)
    if kind == "transformation":
        sp = [X, dg.Species("Y", 0.5, 1.0, formation_energy=50.0)]
        rx, counts = [dg.Transformation("X", "Y", 1.0)], {"X": 20}
    elif kind == "decomposition":
        sp = [dg.Species("AB", 0.7, 2.0), dg.Species("A", 0.5, 1.0, formation_energy=50.0), B]
        rx, counts = [dg.Decomposition("AB", "A", "B", 1.0)], {"AB": 20}
    elif kind == "combination":
        sp = [A, B, dg.Species("C", 0.6, 2.0, formation_energy=200.0)]
        rx, counts = [dg.Combination("A", "B", "C", 0.0, 0.0)], {"A": 15, "B": 15}
    else:
        sp = [A, B, dg.Species("C", 0.5, 1.0, formation_energy=100.0), dg.Species("D", 0.5, 1.0)]
        rx, counts = [dg.Exchange("A", "B", "C", "D", 0.0)], {"A": 15, "B": 15}
    sc = dg.Scene(bounds=dg.Box(10.0, 10.0), species=sp, reactions=rx, dt=0.05,
                  counts=counts, temperature=3.0 if len(rx[0].reactants) == 1 else 1.0)
    sim = dg.Simulation(sc, seed=0)
    e0 = sim.total_energy()
    sim.step(200)
    assert sum(sim.reactions().values()) == 0
    assert {k: v for k, v in sim.counts().items() if v} == counts
    assert sim.total_energy() == pytest.approx(e0, rel=1e-12)
    if len(rx[0].reactants) == 2:
        assert sim.collisions > 100  # the reactants did meet


def test_11_energy_refusals_are_not_counted_as_no_room():
    """Case 11 (counter semantics). An energetically impossible combination in an open box is
    not a reaction 'without room': ``reactions_without_room`` stays 0 (as it does for
    first-order reactions). Before the fix it counted every such collision (124 in this run)."""
    sc = dg.Scene(bounds=dg.Box(10.0, 10.0), dt=0.05, counts={"A": 15, "B": 15},
                  species=[A, B, dg.Species("C", 0.6, 2.0, formation_energy=200.0)],
                  reactions=[dg.Combination("A", "B", "C", 0.0, 0.0)])
    sim = dg.Simulation(sc, seed=0)
    sim.step(200)
    assert sim.collisions > 100
    assert sim.counters()["reactions_without_room"] == 0


def test_11_chains_of_first_order_reactions_advance_one_stage_per_substep():
    """Case 11 (chains). X -> Y and Y -> Z, both certain: a disc present at the start of a
    substep reacts at most once in it, so one step (one substep, discs at rest) turns every
    X into Y and none into Z; the next step turns them all into Z. Likewise the fragments of
    AB -> A + B do not undergo the certain A -> A2 in the substep they are made in."""
    X, Y, Z = (dg.Species(n, 0.5, 1.0) for n in "XYZ")
    sc = dg.Scene(bounds=dg.Box(10.0, 10.0), species=[X, Y, Z], dt=0.05, counts={"X": 10},
                  reactions=[dg.Transformation("X", "Y", 1.0), dg.Transformation("Y", "Z", 1.0)])
    sim = dg.Simulation(sc, seed=0, temperature=0.0)
    sim.step(1)
    assert sim.counts() == {"X": 0, "Y": 10, "Z": 0}
    sim.step(1)
    assert sim.counts() == {"X": 0, "Y": 0, "Z": 10}
    AB = dg.Species("AB", 0.7, 2.0)
    sc = dg.Scene(bounds=dg.Box(20.0, 20.0), species=[AB, A, B, dg.Species("A2", 0.5, 1.0)],
                  dt=0.05, counts={"AB": 10},
                  reactions=[dg.Decomposition("AB", "A", "B", 1.0),
                             dg.Transformation("A", "A2", 1.0)])
    sim = dg.Simulation(sc, seed=0, temperature=0.0)
    sim.step(1)
    c = sim.counts()
    assert c["A2"] == 0 and c["A"] == c["B"] == 10 - c["AB"] > 0
    sim.step(1)
    assert sim.counts()["A2"] == c["A"]


@pytest.mark.parametrize("y2, chained", [(6.2, True), (6.19, False)])
def test_11_bimolecular_product_is_placed_clear_of_the_discs_at_the_contact(y2, chained):
    """Case 11 (chains, bimolecular). A + B -> C is checked for room against where the other
    discs are at the moment of the contact, not at the end of the substep (where they have
    moved on). A meets B 0.05 into a 0.1 step; a third disc A2 falls towards C's spot. From
    y = 6.2 it just touches C there: C is made, and C + A2 -> W + B follows in the same
    substep. From y = 6.19 it would overlap C at the contact: the combination is refused
    (counted as no room) and the pair bounces. Either way no overlap is left and energy and
    momentum are conserved. (Checking at the end of the substep, as before, refused the
    first case and accepted products that overlapped a disc at the contact.)"""
    sc = chem(dt=0.1, species=[A, B, C, W])
    sim = make(sc, [[4.0, 5.0], [5.1, 5.0], [4.55, y2]], [[1, 0], [-1, 0], [0, -1]],
               ["A", "B", "A"])
    e0, p0 = sim.total_energy(), sim.momentum()
    sim.step(1)
    if chained:
        assert sim.counts() == {"A": 0, "B": 1, "C": 0, "W": 1}
        assert sim.counters()["reactions_without_room"] == 0
    else:
        assert sim.counts() == {"A": 2, "B": 1, "C": 0, "W": 0}
        assert sim.counters()["reactions_without_room"] == 1
    assert sim.overlaps() == 0
    assert sim.total_energy() == pytest.approx(e0, rel=1e-14)
    np.testing.assert_allclose(sim.momentum(), p0, atol=1e-14)


# ----------------------------------------------------------------------------------------- 12
def _state_equal(a, b):
    for k, v in a.items():
        w = b[k]
        if isinstance(v, np.ndarray):
            if not np.array_equal(v, w):
                return False
        elif v != w:
            return False
    return True


def test_12_shrinking_the_walls_until_the_discs_cannot_fit():
    """Case 12. The reactor (30 x 30, 240 discs) is shrunk step by step: each resize either
    succeeds (no overlap, nothing outside afterwards, energy unchanged) or raises
    ``dg.PlacementError`` and leaves the state exactly unchanged (``get_state`` identical).
    Past the densest packing it is refused up front, and bounds smaller than a disc too."""
    sim = dg.Simulation("reactor", seed=0)
    sim.step(10)
    refused = 0
    for w in [25.0, 20.0, 18.0, 16.0, 15.0, 14.0, 10.0, 1.0, 0.9]:
        before = sim.get_state()
        e0 = sim.total_energy()
        try:
            sim.resize(dg.Box(w, w))
        except dg.PlacementError:
            refused += 1
            after = sim.get_state()
            del after["rng"], before["rng"]  # see the next test
            assert _state_equal(before, after)
            assert sim.bounds == before["bounds"]
        else:
            assert sim.bounds == dg.Box(w, w)
            assert sim.overlaps() == 0 and sim.outside(0.0) == 0
            assert sim.total_energy() == e0
            sim.step(5)
            assert sound(sim)
    assert refused >= 5
    assert sim.bounds == dg.Box(20.0, 20.0)


def test_12_a_refused_resize_does_not_change_the_future():
    """Case 12 (determinism). A resize that is refused with PlacementError is a no-op: the
    random generator is untouched, so the simulation (here the decomposition scene, whose
    reactions draw random numbers) continues bit-identically to a copy that never tried
    it."""
    a = dg.Simulation("decomposition", seed=0)
    a.step(10)
    b = a.copy()
    with pytest.raises(dg.PlacementError):
        a.resize(dg.Box(18.0, 18.0))  # refused at placement (50 discs find no spot)
    assert a.get_state()["rng"] == b.get_state()["rng"]
    a.step(50)
    b.step(50)
    assert np.array_equal(a.positions, b.positions)


def test_12_injecting_into_a_full_reactor():
    """Case 12. Injection into a box at packing 0.8 places nothing (returns 0 < asked), adds
    no energy and no disc, creates no overlap; near a point, likewise. Into a nearly empty
    box, all requested discs are placed and exactly their kinetic energy is booked."""
    n = int(0.8 * 400 / (math.pi * 0.25))
    sim = dg.Simulation(box(20.0, counts={"A": n}), seed=0)
    for near in (None, (10.0, 10.0)):
        assert sim.inject("A", 50, near=near) == 0
    assert len(sim) == n and sim.energy_input == 0.0 and sim.overlaps() == 0
    sim = dg.Simulation(box(20.0, counts={"A": 5}), seed=0)
    e0 = sim.total_energy()
    assert sim.inject("A", 20, temperature=2.0) == 20
    assert len(sim) == 25 and sim.overlaps() == 0 and sim.outside() == 0
    assert sim.energy_input == pytest.approx(sim.total_energy() - e0, rel=1e-14)


def test_12_injecting_until_full_returns_fewer_than_asked():
    """Case 12. Asking for 2000 discs in a 12 x 12 box: fewer are placed (random addition
    stops well below the densest packing), the return value equals the number added, and
    there is no overlap; stepping afterwards stays sound."""
    sim = dg.Simulation(box(12.0, counts={"A": 10}), seed=0)
    placed = sim.inject("A", 2000)
    assert 0 < placed < 2000 and len(sim) == 10 + placed
    assert sim.overlaps() == 0 and sim.outside() == 0
    sim.step(20)
    assert sound(sim)


# ----------------------------------------------------------------------------------------- 14
@pytest.mark.parametrize("kind", ["box", "circle"])
def test_14_far_from_the_origin_keeps_the_accuracy(kind):
    """Case 14. The same 100 discs (same relative positions and velocities) in bounds at the
    origin and offset by 1e6 bounds sizes (the largest offset validation accepts): over 400
    steps both conserve kinetic energy to 1e-12 relative, stay inside (1e-12 of a radius),
    keep overlaps below 1e-6 of a diameter (position resolution there: ~4e-9), and count
    collisions within 5% of each other (chaos separates the trajectories after a few
    hundred collisions; identical before)."""
    if kind == "box":
        def bounds(o):
            return dg.Box(20.0, 20.0, origin=(o, o))
        far = 1e6 * 20.0 - 20.0
    else:
        def bounds(o):
            return dg.Circle(10.0, center=(o, o))
        far = 1e6 * 20.0
    ref = dg.Simulation(dg.Scene(bounds=bounds(0.0), species=[A], counts={"A": 100},
                                 dt=0.05), seed=5)
    p, v = ref.positions, ref.velocities
    out = []
    for off in (0.0, far):
        sim = make(dg.Scene(bounds=bounds(off), species=[A], dt=0.05), p + off, v)
        e0 = sim.kinetic_energy()
        cols = []
        for _ in range(8):
            sim.step(50)
            assert finite(sim) and sim.outside(OUTSIDE_TOL) == 0 and sim.overlaps(1e-6) == 0
            cols.append(sim.collisions)
        assert abs(sim.kinetic_energy() - e0) <= 1e-12 * e0
        out.append(cols)
    assert out[0][0] == out[1][0]  # the first 50 steps: the same collisions
    assert abs(out[0][-1] - out[1][-1]) <= 0.05 * out[0][-1]


def test_14_offsets_beyond_1e6_sizes_are_refused():
    """Case 14. Bounds more than 1e6 sizes from the origin are refused by validation with a
    SceneError naming ``origin`` (box) or ``center`` (circle), in code and from TOML."""
    with pytest.raises(dg.SceneError) as e:
        dg.Box(20.0, 20.0, origin=(2.0000001e7, 0.0))
    assert e.value.field == "origin"
    with pytest.raises(dg.SceneError) as e:
        dg.Circle(10.0, center=(0.0, -2.0000001e7))
    assert e.value.field == "center"
    d = dg.scenes.load("ideal_gas").to_dict()
    d["bounds"] = {"shape": "box", "width": 10.0, "height": 10.0, "origin": [1e12, 0.0]}
    with pytest.raises(dg.SceneError) as e:
        dg.Scene.from_dict(d)
    assert e.value.field == "bounds.origin"


# ------------------------------------------------------------ the event-driven integrator
# The same hard cases through ``integrator="event"`` (exact event-driven dynamics): the
# geometry must come out exact at any dt, and no configuration may hang it.
EVENT = dict(integrator="event")


def test_event_driven_exact_geometry():
    """Event-driven: a dyadic head-on swap is bit-exact; Newton's cradle of 5 gives all the
    velocity to the last disc; a corner hit inside a step (dt = 0.07) reflects both
    components at the exact time ((9.2, 9.2) at t = 1.3); the speed-1000 disc of case 5 ends
    at the exact ghost-particle positions with 6 collisions and 6 wall hits; a disc leaving
    the exact centre of a circle comes straight back."""
    sim = make(box(50.0), [[20.0, 25.0], [30.0, 25.0]], [[1.0, 0.0], [-2.0, 0.0]], **EVENT)
    sim.advance(5.0)
    assert sim.velocities.tolist() == [[-2.0, 0.0], [1.0, 0.0]]
    np.testing.assert_allclose(sim.positions, [[19.0, 25.0], [26.0, 25.0]], atol=1e-12)
    sim = make(box(40.0, 10.0), [[5.0, 5.0]] + [[10.0 + k, 5.0] for k in range(5)],
               [[1.0, 0.0]] + [[0.0, 0.0]] * 5, **EVENT)
    sim.advance(6.0)
    assert sim.velocities[-1].tolist() == [1.0, 0.0] and (sim.velocities[:-1] == 0).all()
    np.testing.assert_allclose(sim.positions[:, 0], [9, 10, 11, 12, 13, 16], atol=1e-9)
    sim = make(box(dt=0.07), [[8.5, 8.5]], [[1.0, 1.0]], **EVENT)
    sim.advance(1.3)
    np.testing.assert_allclose(sim.positions, [[9.2, 9.2]], atol=1e-9)
    np.testing.assert_allclose(sim.velocities, [[-1.0, -1.0]], atol=1e-14)
    sim = make(box(), [[1.0, 5.0], [5.0, 5.0]], [[1000.0, 0.0], [0.0, 0.0]], **EVENT)
    sim.step(1)
    assert sim.collisions == 6 and sim.wall_hits == 6
    np.testing.assert_allclose(sim.positions, [[3.0, 5.0], [5.0, 5.0]], atol=1e-9)
    sc = dg.Scene(bounds=dg.Circle(5.0), species=[A], dt=0.05)
    sim = make(sc, [[0.0, 0.0]], [[0.6, 0.8]], **EVENT)
    sim.advance(5.0)
    np.testing.assert_allclose(sim.positions, [[2.4, 3.2]], atol=1e-12)


def test_event_driven_degenerate_pairs():
    """Event-driven: overlapping pairs (set_state) at zero relative velocity, moving
    together into a wall, and coincident centres with a relative velocity: no NaN, energy
    exactly conserved, nothing outside, and the coincident pairs separate."""
    def forced_event(pos, vel):
        sim = forced(box(), pos, vel)
        st = sim.get_state()
        st["integrator"] = "event"
        sim.set_state(st)
        assert sim.integrator == "event"
        return sim

    for pos, vel in [([[4.0, 5.0], [4.6, 5.0]], [[0.3, 0.1], [0.3, 0.1]]),
                     ([[4.0, 5.0], [4.6, 5.0]], [[1.0, 0.3], [1.0, 0.3]]),
                     ([[5.0, 5.0], [5.0, 5.0]], [[1.0, 0.0], [-1.0, 0.0]]),
                     ([[5.0, 5.0], [5.0, 5.0]], [[0.3, 0.7], [-0.2, 0.1]])]:
        sim = forced_event(pos, vel)
        e0 = sim.total_energy()
        sim.step(200)
        assert finite(sim) and sim.outside(OUTSIDE_TOL) == 0
        assert abs(sim.total_energy() - e0) <= 1e-14 * e0
        if pos[0] == pos[1]:
            assert sim.overlaps() == 0


def test_event_driven_collapse_jamming_and_heating_stay_sound():
    """Event-driven: 300 discs at e = 0 (TC model) for 100 steps, packing 0.8 in a box for
    30 steps, and the reactor heated a million times for 3 steps: after every step finite,
    inside, no overlap; energy balance 0 to 1e-10 (e = 0) and 1e-12 (heated)."""
    sim = dg.Simulation(box(24.0, counts={"A": 300}, restitution=0.0), seed=0, **EVENT)
    e0 = sim.total_energy()
    for _ in range(100):
        sim.step()
        assert sound(sim)
    assert abs(sim.energy_balance()) <= 1e-10 * e0 and sim.dissipated_energy > 0
    n = int(0.8 * 400 / (math.pi * 0.25))
    sim = dg.Simulation(box(20.0, counts={"A": n}), seed=0, **EVENT)
    for _ in range(30):
        sim.step()
        assert sound(sim)
    sim = dg.Simulation("reactor", seed=0, **EVENT)
    sim.step(20)
    sim.scale_temperature(1e6)
    for _ in range(3):
        sim.step()
        assert sound(sim)
        assert abs(sim.energy_balance()) <= 1e-12 * sim.total_energy()


ZENO = {
    "tangential at the circle wall": """
        sc = dg.Scene(bounds=dg.Circle(5.0), species=[dg.Species("A", 0.5, 1.0)], dt=0.05)
        sim = dg.Simulation.from_arrays(sc, [[4.5, 0.0]], [[0.0, 1.0]], [0],
                                        integrator="event")""",
    "grazing the circle wall": """
        sc = dg.Scene(bounds=dg.Circle(5.0), species=[dg.Species("A", 0.5, 1.0)], dt=0.05)
        sim = dg.Simulation.from_arrays(sc, [[4.5, 0.0]], [[-1e-13, 1.0]], [0],
                                        integrator="event")""",
}


def test_event_driven_zeno_configurations_do_not_hang():
    """Event-driven (cases 6 and 3). A disc touching the circle wall and moving exactly
    tangentially, or grazing it at 1e-13 rad, would meet the wall again at once (or after
    ever shorter chords) forever; with the grazing floor (``walls.graze_floor``) it follows a
    polygon inscribed in the wall: 10 steps (each in its own subprocess, 20 s allowed in
    all; a healthy run takes ~2 s), inside after every step, kinetic energy kept to 1e-12,
    never more than 1e-9 of the radius from the wall."""
    import subprocess
    import sys
    import textwrap
    import time

    make(box(), [[5.0, 5.0]], [[1.0, 0.0]], **EVENT).step(1)  # compiled and cached on disk
    procs = {}
    for name, setup in ZENO.items():
        code = "import discgym as dg, math\n" + textwrap.dedent(setup) + textwrap.dedent("""
            for _ in range(10):
                sim.step(1)
                assert sim.outside(0.0) == 0 and abs(sim.kinetic_energy() - 0.5) < 1e-12
                assert 4.5 - math.hypot(*sim.positions[0]) < 1e-9 * 5.0
            assert sim.wall_hits > 10
            print("ok")
        """)
        procs[name] = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                                       stderr=subprocess.PIPE, text=True)
    failed = []
    deadline = time.monotonic() + 20.0
    for name, p in procs.items():
        try:
            out, err = p.communicate(timeout=max(deadline - time.monotonic(), 0.1))
        except subprocess.TimeoutExpired:
            p.kill()
            p.communicate()
            failed.append(f"{name}: hangs")
            continue
        if p.returncode != 0 or out.strip() != "ok":
            failed.append(f"{name}: {err[-300:]}")
    assert not failed, failed


@pytest.mark.parametrize("bounds, radius", [(dg.Circle(5.0), 5.0), (dg.Box(1.0, 10.0), 0.5),
                                            (dg.Box(10.0, 3.0), 1.5)])
def test_event_driven_refuses_a_disc_that_fits_its_bounds_exactly(bounds, radius):
    """Event-driven (case 6). A disc exactly as large as the circle, or as wide (tall) as the
    box, has no room to move: it would meet both walls at once, forever. The event-driven
    integrator refuses such a scene with a ValueError naming the species (also when a
    resize or a restored state would create one); the time-stepped integrator holds the disc
    in place (tested above)."""
    sc = dg.Scene(bounds=bounds, species=[dg.Species("B", radius, 1.0)], dt=0.05)
    x0, y0, x1, y1 = (bounds.center[0] - bounds.radius, bounds.center[1] - bounds.radius,
                      bounds.center[0] + bounds.radius, bounds.center[1] + bounds.radius) \
        if isinstance(bounds, dg.Circle) else bounds.extent
    mid = [[(x0 + x1) / 2, (y0 + y1) / 2]]
    with pytest.raises(ValueError, match="'B'.*fits"):
        dg.Simulation.from_arrays(sc, mid, [[0.6, 0.8]], [0], integrator="event")
    with pytest.raises(ValueError, match="'B'.*fits"):
        dg.Simulation(sc, counts={}, integrator="event")  # even with no disc yet
    sim = dg.Simulation.from_arrays(sc, mid, [[0.6, 0.8]], [0])  # stepped: fine
    st = sim.get_state()
    st["integrator"] = "event"
    with pytest.raises(ValueError, match="'B'.*fits"):
        sim.set_state(st)
    assert sim.integrator == "step"


def test_a_pair_left_overlapping_while_separating_is_pushed_apart():
    """A missed graze can leave a pair overlapping while it separates: two discs pass within
    one (sub)step (both ends outside contact, so not seen) while an event turns one of them
    inside the overlap. Such a pair (overlap deeper than ``SEPARATING_OVERLAP`` = 1e-10 of
    the contact distance, which round-off cannot make) is pushed apart by the repair pass at
    the end of the substep (``graze_repairs``), positions only: the energy is exactly
    unchanged, the momentum and the centre of mass too. An overlap of round-off size is left
    alone."""
    assert SEPARATING_OVERLAP == 1e-10
    assert contact_time(0.9, 0.0, 0.02, 0.0, 1.0, -0.05) == math.inf  # separating, deep
    assert math.isnan(contact_time(1.0 - 1e-13, 0.0, 0.02, 0.0, 1.0, -0.05))  # round-off
    assert contact_time(0.9, 0.0, -0.02, 0.0, 1.0, -0.05) == -0.05  # approaching: at once
    sim = forced(box(), [[4.0, 5.0], [4.9, 5.0]], [[-0.01, 0.003], [0.01, -0.001]])
    e0, p0 = sim.total_energy(), sim.momentum()
    assert sim.overlaps() == 1
    sim.step()
    c = sim.counters()
    assert sim.overlaps(0.0) == 0 and c["graze_repairs"] == 1 and c["fallback_repairs"] == 1
    assert c["events_capped"] == 0 and sim.collisions == 0
    assert sim.total_energy() == e0
    np.testing.assert_allclose(sim.momentum(), p0, atol=1e-16)
    p = sim.positions
    d = np.linalg.norm(p[1] - p[0])
    # pushed apart by 1.5 x its overlap (resolve's over-relaxation) of 0.1 minus what the
    # pair separated in the step (0.02 x 0.05 along x), about the centre of mass
    assert d == pytest.approx(1.0 + 0.5 * (0.1 - 0.001), abs=1e-6)
    np.testing.assert_allclose(p.mean(axis=0), [4.45, 5.0 + 0.001 * 0.05], atol=1e-12)
    sim = forced(box(), [[4.0, 5.0], [5.0 - 1e-13, 5.0]], [[-0.01, 0.0], [0.01, 0.0]])
    sim.step()
    assert sim.counters()["graze_repairs"] == 0 and sim.counters()["fallback_repairs"] == 0


def test_inelastic_discs_at_a_hot_circle_wall_keep_apart():
    """Found by the long-mode property test: 23 discs at e = 0 in a circle of radius 3,
    heated to kT = 1e6. A disc sliding along the wall grazed a neighbour inside a substep
    (not seen: both ends of the graze outside contact) and hit the wall inside the graze; the
    pair, turned while overlapping, left the substep overlapping by 5e-7 of its contact
    distance while separating. The repair pass now pushes such pairs apart (graze_repairs)."""
    scene = dg.Scene(bounds=dg.Circle(radius=3.0),
                     species=[dg.Species("S0", radius=0.2, mass=1.0),
                              dg.Species("S1", radius=0.6552669444531722, mass=1.0)],
                     reactions=[dg.Exchange("S0", "S1", "S0", "S0", activation_energy=0.0)],
                     restitution=0.0, dt=0.02, internal_relaxation=0.0, max_displacement=0.25,
                     counts={"S0": 19, "S1": 4}, temperature=1.0)
    sim = dg.Simulation(scene, seed=0)
    sim.scale_temperature(10.0)
    for _ in range(30):
        sim.step()
        assert sim.overlaps(1e-9) == 0
    sim.scale_temperature(1e6 / sim.temperature())  # kT = 1e6, as the property test caps it
    for _ in range(10):
        sim.step()
        assert sim.overlaps(1e-9) == 0 and sim.outside(OUTSIDE_TOL) == 0
    assert sim.counters()["graze_repairs"] > 0  # (7 with seed 0: the case it was found in)
    assert abs(sim.energy_balance()) <= 1e-9 * abs(sim.total_energy())


@pytest.mark.parametrize("radius, counts, injected", [(3.5, {"S0": 4, "S1": 4}, 1),
                                                      (4.5, {"S0": 5, "S1": 5}, 8)])
def test_inelastic_discs_pressed_against_a_circle_wall_are_untangled(radius, counts, injected):
    """Found by the long-mode property test (2026-12-01, after finding 10): e = 0 discs in a
    circle heated twice by 1000x. Substeps that reach the event bound end with the repair pass,
    and here the discs form a ring pressed against the wall whose perimeter they fill: the pass
    that split every push by mass and left the wall to the next pass converged by 5% per pass
    and stopped at its 64 passes with 17 pairs overlapping by up to 7e-6 of their contact
    distance and 12 discs outside by 1e-6. Now the wall is rigid in the pair push, the push is
    over-relaxed and the pass bound is a work bound (2^20 disc-passes, 4096 passes here)."""
    scene = dg.Scene(bounds=dg.Circle(radius=radius),
                     species=[dg.Species("S0", 0.6875, 1.0), dg.Species("S1", 0.625, 1.0)],
                     restitution=0.0, dt=0.0625, internal_relaxation=0.0, max_displacement=0.5,
                     counts=counts, temperature=1.0)
    sim = dg.Simulation(scene, seed=1)
    sim.inject("S0", injected)
    sim.step(10)
    for _ in range(2):
        sim.scale_temperature(min(1000.0, 1e6 / sim.temperature()))
        for _ in range(10):
            sim.step()
            assert sim.overlaps(OVERLAP_TOL) == 0 and sim.outside(OUTSIDE_TOL) == 0
            assert abs(sim.energy_balance()) <= 1e-9 * abs(sim.total_energy())
    assert sim.counters()["events_capped"] > 0  # the repair pass was exercised
