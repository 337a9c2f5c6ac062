"""The exact, event-driven integrator (``Simulation(..., integrator="event")``): exact contact
times, conservation to round-off, reactions at the contact and at exactly sampled times, and
agreement with the time-stepped integrator as its time step shrinks."""

import math
import pickle

import numpy as np
import pytest

import discgym as dg
from discgym.compiled import kernel_bounds
from discgym.kernels import event_driven as ev
from discgym.kernels.structs import Bounds, Discs

A = dg.Species("A", 0.5, 1.0)
B = dg.Species("B", 0.5, 1.0)
AB = dg.Species("AB", 0.7, 2.0, formation_energy=-1.0)
C = dg.Species("C", 0.5, 1.0, formation_energy=0.4)
HOT = dg.Species("AB", 0.7, 2.0, formation_energy=1.0)  # decomposes exothermically


def event(scene, pos, vel, species, u=None, seed=0):
    return dg.Simulation.from_arrays(scene, np.asarray(pos, float), np.asarray(vel, float),
                                     species, internal_energy=u, seed=seed, integrator="event")


def totals(sim):
    return sim.masses.sum(), sim.momentum().copy(), sim.total_energy()


def assert_conserved(before, sim):
    m0, p0, e0 = before
    m1, p1, e1 = totals(sim)
    assert m1 == pytest.approx(m0, rel=1e-14)
    np.testing.assert_allclose(p1, p0, atol=1e-12)
    assert e1 == pytest.approx(e0, rel=1e-12, abs=1e-12)


def free_scene(reactions=(), species=(A, B, AB, C), **kw):
    # huge box, no walls in reach: momentum must be conserved exactly
    return dg.Scene(bounds=dg.Box(200.0, 200.0), species=list(species), reactions=reactions,
                    dt=0.02, **kw)


# ------------------------------------------------------------------- the switch itself
def test_integrator_switch_is_validated_and_kept_in_state():
    with pytest.raises(ValueError, match="integrator"):
        dg.Simulation("ideal_gas", integrator="exact")
    with pytest.raises(ValueError, match="integrator"):
        dg.Simulation.from_arrays("ideal_gas", [[5.0, 5.0]], [[1.0, 0.0]], ["A"],
                                  integrator=None)
    sim = dg.Simulation("ideal_gas", seed=1, integrator="event")
    assert sim.integrator == "event" and dg.Simulation("ideal_gas").integrator == "step"
    sim.advance(0.5)
    assert sim.get_state()["integrator"] == "event"
    for other in (pickle.loads(pickle.dumps(sim)), sim.copy()):
        assert other.integrator == "event"
        sim2 = sim.copy()
        other.advance(1.0)
        sim2.advance(1.0)
        np.testing.assert_array_equal(other.positions, sim2.positions)
    stepped = dg.Simulation("ideal_gas", seed=1)
    stepped.set_state(sim.get_state())
    assert stepped.integrator == "event"


def test_empty_reactor_and_everything_combined_away():
    sim = dg.Simulation("ideal_gas", counts={"A": 0}, integrator="event")
    sim.advance(1.0)
    assert len(sim) == 0 and sim.time == pytest.approx(1.0)
    sc = free_scene([dg.Combination("A", "B", "AB", activation_energy=0.0,
                                    reverse_probability=0.0)])
    pair = event(sc, [[99.0, 100.0], [101.0, 100.0]], [[1.0, 0.0], [-1.0, 0.0]], [0, 1])
    pair.advance(2.0)
    assert pair.counts()["AB"] == 1 and len(pair) == 1
    pair.advance(1.0)
    np.testing.assert_allclose(pair.positions[0], [100.0, 100.0], atol=1e-12)


def test_same_seed_same_trajectory_and_time_is_exact():
    a = dg.Simulation("combination", seed=5, integrator="event")
    b = dg.Simulation("combination", seed=5, integrator="event")
    a.step(50)
    b.step(50)
    assert a.time == pytest.approx(50 * a.scene.dt)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.velocities, b.velocities)
    np.testing.assert_array_equal(a.ids, b.ids)
    assert a.reactions() == b.reactions() and a.counters() == b.counters()


# ------------------------------------------------------------- exact contact times
@pytest.mark.parametrize("bounds", [dg.Box(50.0, 50.0, origin=(-25.0, -25.0)), dg.Circle(25.0)])
def test_two_disc_contact_time_is_exact_in_both_bounds(bounds):
    sc = dg.Scene(bounds=bounds, species=[A], dt=0.1)
    # r = (4, 0.6), v_rel = (-2, 0): |r + t v| = 1 at (4 - 2t)^2 + 0.36 = 1, t = 1.6;
    # the normal there is n = (0.8, 0.6) and equal masses exchange v_r n = 1.6 n
    p0 = [[-2.0, -0.3], [2.0, 0.3]]
    v0 = [[1.0, 0.0], [-1.0, 0.0]]
    before = event(sc, p0, v0, [0, 0])
    before.advance(1.6 - 1e-9)
    np.testing.assert_array_equal(before.velocities, v0)
    assert before.collisions == 0
    sim = event(sc, p0, v0, [0, 0])
    sim.advance(1.6 + 1e-9)
    assert sim.collisions == 1
    np.testing.assert_allclose(sim.velocities, [[-0.28, -0.96], [0.28, 0.96]], atol=1e-14)
    sim.advance(2.0 - 1e-9)  # 2.0 after the contact at x = -0.4 and 0.4
    np.testing.assert_allclose(sim.positions, [[-0.4 - 0.56, -0.3 - 1.92],
                                               [0.4 + 0.56, 0.3 + 1.92]], atol=1e-12)


def test_head_on_equal_masses_swap_velocities():
    sc = dg.Scene(bounds=dg.Box(50.0, 50.0), species=[A], dt=0.05)
    sim = event(sc, [[20.0, 25.0], [30.0, 25.0]], [[1.0, 0.0], [-2.0, 0.0]], [0, 0])
    sim.advance(5.0)  # contact at t = 9/3 = 3 (x = 23 and 24), then 2 apart swapped
    np.testing.assert_allclose(sim.velocities, [[-2.0, 0.0], [1.0, 0.0]], atol=1e-14)
    np.testing.assert_allclose(sim.positions[:, 0], [23.0 - 4.0, 24.0 + 2.0], atol=1e-12)


@pytest.mark.parametrize("bounds, start, vel, t_hit, after", [
    # box: contact at x = 9.5 after 0.5
    (dg.Box(10.0, 10.0), [9.0, 5.0], [1.0, 0.0], 0.5, [-1.0, 0.0]),
    # circle: contact at |x| = 4.5 after 0.6
    (dg.Circle(5.0), [3.9, 0.0], [1.0, 0.0], 0.6, [-1.0, 0.0]),
    # off-centre circle, radial hit at distance 4.5 after 0.9
    (dg.Circle(5.0, center=(1.0, -2.0)), [1.0, -2.0], [3.0, 4.0], 0.9, [-3.0, -4.0]),
    # off-axis circle: |(-1 + 2t, 2)| = 4.5 at t = (1 + sqrt(16.25))/2
    (dg.Circle(5.0), [-1.0, 2.0], [2.0, 0.0], (1 + math.sqrt(16.25)) / 2, None),
])
def test_wall_contact_time_is_exact(bounds, start, vel, t_hit, after):
    sc = dg.Scene(bounds=bounds, species=[A], dt=0.1)
    sim = event(sc, [start], [vel], [0])
    sim.advance(t_hit - 1e-9)
    assert sim.wall_hits == 0
    np.testing.assert_array_equal(sim.velocities[0], vel)
    sim.advance(2e-9)
    assert sim.wall_hits == 1
    if after is None:  # specular reflection about the normal at the contact point
        xc = np.array(start) + t_hit * np.array(vel)
        n = (xc - np.array(bounds.center)) / np.linalg.norm(xc - np.array(bounds.center))
        after = np.array(vel) - 2 * (np.array(vel) @ n) * n
    np.testing.assert_allclose(sim.velocities[0], after, atol=1e-12)
    sim.advance(0.3 - 1e-9)
    xc = np.array(start) + t_hit * np.array(vel)
    np.testing.assert_allclose(sim.positions[0], xc + 0.3 * np.array(after), atol=1e-12)


def test_few_discs_in_a_circle_follow_the_same_trajectory_as_the_stepped_integrator():
    """Few discs, a short run (before chaos could amplify round-off): a sparse scene has no
    grazing contacts for the stepped integrator to miss, so at every step size it follows the
    exact trajectory, contact for contact, to round-off."""
    sc = dg.Scene(bounds=dg.Circle(4.0), species=[A, dg.Species("L", 1.0, 3.0)], dt=0.05)
    pos = [[-2.5, 0.0], [2.5, 0.2], [0.0, 2.5], [0.2, -2.5], [0.0, 0.0], [1.7, 1.7],
           [-1.7, -1.6]]
    vel = 1.5 * np.random.default_rng(3).normal(size=(7, 2))
    spc = [0, 0, 0, 0, 1, 0, 0]
    ref = event(sc, pos, vel, spc)
    ref.advance(3.0)
    assert ref.collisions >= 10 and ref.wall_hits >= 10
    for dt in (0.05, 0.01, 0.002):
        s = dg.Simulation.from_arrays(sc.replace(dt=dt), pos, vel, spc)
        s.advance(3.0)
        assert s.collisions == ref.collisions and s.wall_hits == ref.wall_hits
        np.testing.assert_allclose(s.positions, ref.positions, atol=1e-9)
        np.testing.assert_allclose(s.velocities, ref.velocities, atol=1e-9)


# ---------------------------------------------------------------------- conservation
def test_elastic_gas_conserves_energy_to_round_off_over_1e5_collisions():
    sc = dg.Scene(bounds=dg.Box(24.0, 24.0), species=[A], counts={"A": 250}, dt=0.05)
    sim = dg.Simulation(sc, seed=1, integrator="event")
    e0 = sim.kinetic_energy()
    while sim.collisions < 100_000:
        sim.advance(20.0)
        assert sim.overlaps(1e-9) == 0
        assert sim.outside(1e-12) == 0
    assert abs(sim.kinetic_energy() - e0) / e0 < 1e-11
    assert sim.wall_hits > 1000


def test_polydisperse_circle_gas_conserves_and_never_overlaps():
    sc = dg.Scene(bounds=dg.Circle(12.0),
                  species=[dg.Species("s", 0.4, 1.0), dg.Species("l", 1.2, 9.0)],
                  counts={"s": 150, "l": 35}, dt=0.05)
    sim = dg.Simulation(sc, seed=3, integrator="event")
    e0 = sim.kinetic_energy()
    for _ in range(20):
        sim.advance(1.0)
        assert sim.overlaps(1e-9) == 0 and sim.outside(1e-12) == 0
    assert sim.collisions > 5000
    assert abs(sim.kinetic_energy() - e0) / e0 < 1e-12


def test_momentum_is_conserved_in_free_space():
    # a cloud of discs in the middle of a huge box: no wall within reach in the run
    rng = np.random.default_rng(0)
    sc = free_scene(species=(A, dg.Species("b", 1.3, 7.5)))
    xy = np.array([(x, y) for x in range(90, 112, 3) for y in range(90, 112, 3)], float)
    xy += rng.uniform(-0.2, 0.2, size=xy.shape)
    vel = rng.normal(size=xy.shape)
    spc = rng.integers(0, 2, size=len(xy))
    sim = event(sc, xy, vel, spc)
    p0, e0 = sim.momentum(), sim.kinetic_energy()
    sim.advance(4.0)
    assert sim.collisions > 50 and sim.wall_hits == 0
    np.testing.assert_allclose(sim.momentum(), p0, atol=1e-12)
    assert sim.kinetic_energy() == pytest.approx(e0, rel=1e-13)


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_inelastic_gas_stays_finite_and_books_the_dissipated_energy(e):
    sc = dg.Scene(bounds=dg.Box(20.0, 20.0), species=[A], counts={"A": 250}, restitution=e,
                  dt=0.05)
    sim = dg.Simulation(sc, seed=2, integrator="event")
    sim.advance(5.0)
    assert sim.dissipated_energy > 0
    assert abs(sim.energy_balance()) < 1e-10 * sim._energy_start
    assert sim.overlaps(1e-6) == 0 and sim.outside(1e-9) == 0


def test_points_without_collisions_only_meet_walls():
    sc = dg.Scene(bounds=dg.Box(20.0, 20.0), species=[A], counts={"A": 200}, collisions=False,
                  dt=0.05)
    sim = dg.Simulation(sc, seed=0, integrator="event")
    sim.advance(40.0)
    assert sim.collisions == 0 and sim.outside(1e-12) == 0
    # an ideal gas whose centres are confined to (20 - 2r)^2: force per unit length of that
    # square P = N kT / 19^2; sim.pressure() spreads the same force over the 80 of the walls
    p_ideal = 200 * sim.temperature() / 19.0**2
    assert sim.pressure() * 80.0 / 76.0 == pytest.approx(p_ideal, rel=0.05)


# ------------------------------------------------------------------------- reactions
def test_combination_fires_at_the_contact_and_conserves():
    sc = free_scene([dg.Combination("A", "B", "AB", activation_energy=1.0,
                                    reverse_probability=0.0)])
    sim = event(sc, [[99.0, 100.0], [101.0, 100.3]], [[1.5, 0.2], [-1.5, -0.1]], [0, 1])
    before = totals(sim)
    sim.advance(1.0)
    assert sim.counts()["AB"] == 1 and len(sim) == 1
    assert_conserved(before, sim)
    mu = 0.5
    assert sim.internal_energy[0] == pytest.approx(0.5 * mu * (3.0**2 + 0.3**2) + 1.0,
                                                   rel=1e-12)
    # the product sits at the pair's centre of mass, which moves at (0, 0.05)
    np.testing.assert_allclose(sim.positions[0], [100.0, 100.15 + 0.05], atol=1e-12)


def test_combination_below_activation_bounces():
    sc = free_scene([dg.Combination("A", "B", "AB", activation_energy=3.0)])
    sim = event(sc, [[99.0, 100.0], [101.0, 100.0]], [[1.5, 0.0], [-1.5, 0.0]], [0, 1])
    sim.advance(1.0)
    assert sim.counts()["AB"] == 0 and sim.collisions == 1


def test_exchange_conserves_and_respects_activation():
    D = dg.Species("D", 0.7, 2.0, formation_energy=-0.5)
    sc = free_scene([dg.Exchange("A", "AB", "D", "B", activation_energy=1.0)],
                    species=(A, B, AB, D))
    sim = event(sc, [[98.0, 100.0], [101.0, 100.4]], [[2.5, 0.3], [-1.0, 0.0]], [0, 2])
    before = totals(sim)
    sim.advance(2.0)
    assert sim.counts()["D"] == 1 and sim.counts()["B"] == 1
    assert_conserved(before, sim)
    assert sim.overlaps() == 0
    slow = event(sc, [[98.0, 100.0], [101.0, 100.4]], [[0.5, 0.0], [-0.2, 0.0]], [0, 2])
    slow.advance(8.0)
    assert slow.counts()["D"] == 0 and slow.collisions >= 1


def test_reverse_combination_only_while_above_its_barrier():
    sc = free_scene([dg.Combination("A", "B", "AB", activation_energy=1.0,
                                    reverse_probability=1.0)])
    hot = event(sc, [[100.0, 100.0]], [[0.3, -0.2]], ["AB"], u=[2.5])
    cold = event(sc, [[100.0, 100.0]], [[0.3, -0.2]], ["AB"], u=[1.9])
    before = totals(hot)
    hot.advance(2.0)
    cold.advance(20.0)
    assert hot.counts() == {"A": 1, "B": 1, "AB": 0, "C": 0}
    assert_conserved(before, hot)
    assert cold.counts()["AB"] == 1
    rel = hot.velocities[1] - hot.velocities[0]
    assert abs(rel @ np.array([0.3, -0.2])) < 1e-12


def test_reaction_rate_is_resampled_when_a_collision_drains_the_energy():
    """A hot AB may fall apart (slowly) only while its internal energy is above the barrier;
    its first collision relaxes that energy away (kappa = 1), after which it must never
    react: the rate has to be re-evaluated at the collision, not kept from before."""
    p = 1.0 - math.exp(-0.05)  # k = 0.05 per unit time
    sc = free_scene([dg.Combination("A", "B", "AB", activation_energy=1.0,
                                    reverse_probability=p)], internal_relaxation=1.0)
    fired = 0
    for seed in range(40):
        sim = event(sc, [[100.0, 100.0], [97.0, 100.0]], [[0.0, 0.0], [2.0, 0.0]],
                    ["AB", "A"], u=[2.5, 0.0], seed=seed)
        sim.advance(0.85)  # the collision comes at t = 0.9
        # fell apart before (w.p. 0.04; its fragment may even have recombined with the A)
        if sum(sim.reactions().values()) > 0:
            fired += 1
            continue
        sim.advance(24.15)  # without the rule it would now fire w.p. 0.7
        assert sim.collisions == 1
        fired += sim.counts()["AB"] == 0
    assert fired <= 8  # expected 40 (1 - exp(-0.045)) = 1.8


def test_decomposition_follows_exp_minus_kt_and_conserves():
    p = 0.3
    k = -math.log1p(-p)
    n0 = 2000
    sc = dg.Scene(bounds=dg.Box(120.0, 120.0), species=[HOT, A, B],
                  reactions=[dg.Decomposition("AB", "A", "B", probability=p)],
                  counts={"AB": n0}, dt=0.02, collisions=False)
    sim = dg.Simulation(sc, seed=0, integrator="event")
    e0, m0 = sim.total_energy(), sim.masses.sum()
    for t in (0.5, 1.0, 2.0, 4.0):
        sim.advance(t - sim.time)
        s = math.exp(-k * t)
        assert sim.counts()["AB"] / n0 == pytest.approx(s, abs=4 * math.sqrt(s * (1 - s) / n0))
    assert sim.masses.sum() == pytest.approx(m0, rel=1e-14)
    assert sim.total_energy() == pytest.approx(e0, rel=1e-12)
    assert len(set(sim.ids.tolist())) == len(sim)  # fragments got fresh identities


def test_decomposition_among_colliding_discs_grows_the_state_and_never_overlaps():
    sc = dg.Scene(bounds=dg.Box(30.0, 30.0), species=[HOT, A, B],
                  reactions=[dg.Decomposition("AB", "A", "B", probability=0.5)],
                  counts={"AB": 150}, dt=0.02)
    sim = dg.Simulation(sc, seed=4, integrator="event")
    e0 = sim.total_energy()
    sim.advance(10.0)
    assert sim.counts()["AB"] < 20 and len(sim) > 270
    assert sim.overlaps(1e-9) == 0 and sim.outside(1e-12) == 0
    assert sim.total_energy() == pytest.approx(e0, rel=1e-12)
    assert len(set(sim.ids.tolist())) == len(sim)


def test_decomposition_of_a_disc_at_rest_conserves_momentum():
    sc = free_scene([dg.Decomposition("AB", "A", "B", probability=1.0)], species=(A, B, HOT))
    sim = event(sc, [[100.0, 100.0]], [[0.0, 0.0]], ["AB"], seed=1)
    before = totals(sim)
    sim.step()
    assert sim.counts()["A"] == 1 and sim.counts()["B"] == 1
    assert_conserved(before, sim)
    assert sim.kinetic_energy() == pytest.approx(1.0, rel=1e-12)


def test_transformation_and_endothermic_channels_wait_for_energy():
    sc = free_scene([dg.Transformation("C", "A", probability=1.0)])
    sim = event(sc, [[100.0, 100.0]], [[0.5, 0.5]], ["C"])
    before = totals(sim)
    sim.step()
    assert sim.counts()["A"] == 1 and sim.internal_energy[0] == pytest.approx(0.4)
    assert_conserved(before, sim)
    cold = dg.Species("AB", 0.7, 2.0, formation_energy=0.0)
    sc2 = free_scene([dg.Decomposition("AB", "A", "C", probability=1.0)], species=(A, cold, C))
    s2 = event(sc2, [[100.0, 100.0]], [[0.1, 0.0]], ["AB"], u=[0.3])
    s2.advance(10.0)
    assert s2.counts()["AB"] == 1  # needs 0.4, has 0.3: must not fire


def test_no_room_means_no_reaction_and_no_overlap():
    big = dg.Species("big", 2.0, 2.0)
    sc = dg.Scene(bounds=dg.Box(4.2, 4.2), species=[A, B, big],
                  reactions=[dg.Combination("A", "B", "big", activation_energy=0.0)],
                  dt=0.01)
    sim = event(sc, [[0.6, 0.6], [1.8, 0.6]], [[1.0, 0.0], [-1.0, 0.0]], [0, 1])
    sim.advance(1.0)
    assert sim.counts()["big"] == 0
    assert sim.counters()["reactions_without_room"] >= 1
    assert sim.overlaps() == 0 and sim.outside() == 0


def test_activated_reacting_fraction_follows_boltzmann():
    """Collision theory in 2D: the fraction of collisions with 1/2 mu v_r^2 >= E_a is
    exp(-E_a / kT). The exchanges below change nothing but labels."""
    X = dg.Species("X", 0.5, 1.0)
    Y = dg.Species("Y", 0.5, 1.0)
    Ea = 1.5
    sc = dg.Scene(bounds=dg.Box(30.0, 30.0), species=[X, Y],
                  reactions=[dg.Exchange("X", "X", "Y", "Y", activation_energy=Ea),
                             dg.Exchange("Y", "Y", "X", "X", activation_energy=Ea),
                             dg.Exchange("X", "Y", "Y", "X", activation_energy=Ea)],
                  counts={"X": 150, "Y": 150}, dt=0.02)
    sim = dg.Simulation(sc, seed=7, integrator="event")
    sim.advance(80.0)
    fired = sum(sim.reactions().values())
    total = fired + sim.collisions
    assert total > 20000
    expected = math.exp(-Ea / sim.temperature())
    frac = fired / total
    assert frac == pytest.approx(expected, abs=4 * math.sqrt(expected * (1 - expected) / total))
    assert abs(sim.energy_balance()) < 1e-9


@pytest.mark.parametrize("name", dg.scenes.names())
def test_every_builtin_scene_conserves_everything(name):
    """Closed scenes keep their mass and energy; open ones (thermal walls exchange heat,
    outlets let discs out) keep them once the ledger's terms are counted: the mass that left
    through outlets, and energy_balance (input, wall heat, outflow energy)."""
    sim = dg.Simulation(name, seed=2, integrator="event")
    m0, e0 = sim.masses.sum(), sim.total_energy()
    sim.advance(10.0)
    mass = {sp.name: sp.mass for sp in sim.scene.species}
    gone = sum(mass[k] * v for k, v in sim.outflow().items())
    assert sim.masses.sum() + gone == pytest.approx(m0, rel=1e-13)
    if sim.scene.thermal_walls or sim.scene.outlets:
        assert abs(sim.energy_balance()) <= 1e-12 * max(abs(e0), 1.0) * 10
    else:
        assert abs(sim.total_energy() - e0) <= 1e-12 * max(abs(e0), 1.0) * 10
    assert sim.overlaps(1e-9) == 0 and sim.outside(1e-12) == 0


# --------------------------------------------------- agreement with the stepped integrator
def _one_step_counts(sc, states, dt):
    """Collisions in one step of length dt from each state: (exact, stepped) totals."""
    ce = cs = 0
    for st in states:
        for integ in ("event", "step"):
            s = dg.Simulation.from_arrays(sc.replace(dt=dt), st[0], st[1], st[2],
                                          integrator=integ)
            s.step(1)
            if integ == "event":
                ce += s.collisions
            else:
                cs += s.collisions
    return ce, cs


def test_stepped_collisions_converge_to_the_exact_count_as_the_step_shrinks():
    """From the same states, the collisions the stepped integrator misses in one step (its
    only error on an elastic gas) vanish as the step shrinks."""
    sc = dg.Scene(bounds=dg.Box(16.0, 16.0), species=[A], counts={"A": 160},
                  max_displacement=1.0)
    sim = dg.Simulation(sc, seed=0, integrator="event")
    states = []
    for _ in range(30):
        sim.advance(1.0)
        states.append((sim.positions, sim.velocities, sim.species))
    missed = []
    for dt in (1.0, 0.2, 0.05):  # dt = 1 is split into substeps moving discs <= 1 radius
        ce, cs = _one_step_counts(sc, states, dt)
        missed.append((ce - cs) / ce)
    # measured: 0.58%, 0.21%, 0 (of 16442, 3321, 821 collisions)
    assert missed[0] > 0.003 and missed[0] > missed[1] >= missed[2], missed
    assert missed[2] < 0.002, missed


def test_pressure_agrees_with_the_stepped_integrator():
    N, eta, r = 400, 0.35, 0.5
    L = math.sqrt(N * math.pi * r * r / eta)
    sc = dg.Scene(bounds=dg.Box(L, L), species=[A], counts={"A": N}, dt=0.02)
    ref = dg.Simulation(sc, seed=3, integrator="event")
    ref.advance(20.0)
    st = ref.get_state()
    out = {}
    for integ in ("event", "step"):
        s = dg.Simulation.from_arrays(sc, st["positions"], st["velocities"], st["species"],
                                      integrator=integ)
        s.advance(200.0)
        out[integ] = s.pressure()
    assert out["step"] == pytest.approx(out["event"], rel=0.03)


def test_controls_between_runs_are_picked_up():
    """Every run starts from the current state, so injections, heating and a new wall act on
    the next run like on the stepped integrator's."""
    sim = dg.Simulation("circle_gas", seed=3, integrator="event")
    sim.advance(1.0)
    assert sim.inject("small", 20) == 20
    sim.scale_temperature(2.0)
    sim.resize(dg.Circle(20.0))
    sim.advance(2.0)
    assert len(sim) == 380 and sim.overlaps(1e-9) == 0 and sim.outside(1e-12) == 0
    assert abs(sim.energy_balance()) < 1e-9 * sim.total_energy()


def test_event_statistics_and_restart_on_growth():
    """run_steps reports the work done; a decomposition beyond the capacity restarts."""
    sc = dg.Scene(bounds=dg.Box(30.0, 30.0), species=[HOT, A, B],
                  reactions=[dg.Decomposition("AB", "A", "B", probability=0.9)],
                  counts={"AB": 100}, dt=0.02)
    sim = dg.Simulation(sc, seed=0)
    cs = sim._cs
    stats = np.zeros(ev.N_STATS, dtype=np.int64)
    n = len(sim)
    pos, vel, spc = sim.positions, sim.velocities, sim.species
    uint = np.zeros(n)
    ids = np.arange(n, dtype=np.int64)
    idctr = np.array([n], dtype=np.int64)
    icnt = np.zeros_like(sim._icnt)
    fsum = np.zeros_like(sim._fsum)
    chc = np.zeros_like(sim._ch_count)
    discs, n = ev.run_steps(Discs(pos, vel, spc, uint, ids, idctr), n, 1, 5.0,
                            Bounds(*kernel_bounds(sim.bounds), sim._walls), cs.tables, cs.params,
                            cs.flags,
                            np.random.default_rng(1),
                            ev.EventCounters(icnt, fsum, chc, stats,
                                             np.zeros_like(sim._outflow)),
                            ev.CELLS_PER_DISC)
    pos, spc, ids = discs.pos, discs.species, discs.ids
    assert stats[ev.ST_RESTARTS] >= 1 and n > 150 and pos.shape[0] >= n
    assert stats[ev.ST_EVENTS] >= stats[ev.ST_CROSSINGS] > 0
    assert (spc[:n] >= 0).all() and len(set(ids[:n].tolist())) == n


def test_event_loop_is_compiled_without_reference_counting():
    """The event loop, the first predictions and the loading of the discs borrow every array
    and allocate nothing, so they are compiled without numba's reference counting (with it,
    the handlers inlined there took and dropped a reference to each array of each struct
    they were given: most of the time of an event; docs/performance.md, "The event-driven
    integrator's speed"). Growing the arrays stays outside, in _events."""
    for f in (ev._event_loop, ev._predict_all, ev._fill):
        assert f.targetoptions.get("_nrt") is False, f.__name__
    assert ev._events.targetoptions.get("_nrt", True) is not False
