"""Every reaction conserves mass, momentum and total energy; triggers and rates are right."""

import math

import numpy as np
import pytest
from conftest import two_disc

import discgym as dg

A = dg.Species("A", 0.5, 1.0)
B = dg.Species("B", 0.5, 1.0)
AB = dg.Species("AB", 0.7, 2.0, formation_energy=-1.0)
C = dg.Species("C", 0.5, 1.0, formation_energy=0.4)


def totals(sim):
    return (sim.masses.sum(), sim.momentum().copy(), sim.total_energy())


def assert_conserved(before, sim):
    m0, p0, e0 = before
    m1, p1, e1 = totals(sim)
    assert m1 == pytest.approx(m0, rel=1e-14)
    np.testing.assert_allclose(p1, p0, atol=1e-12)
    assert e1 == pytest.approx(e0, rel=1e-12, abs=1e-12)


def free_scene(reactions, species=(A, B, AB, C), **kw):
    # huge box, no walls in reach: momentum must be conserved exactly
    return dg.Scene(bounds=dg.Box(200.0, 200.0), species=list(species), reactions=reactions,
                    dt=0.02, **kw)


def test_combination_fires_above_activation_and_conserves():
    sc = free_scene([dg.Combination("A", "B", "AB", activation_energy=1.0,
                                    reverse_probability=0.0)])
    # line-of-centres energy 1/2 mu v_r^2 with mu = 1/2: v_r = 3 gives 2.25 >= 1
    sim = two_disc(sc, [99.0, 100.0], [101.0, 100.3], [1.5, 0.2], [-1.5, -0.1], 0, 1)
    before = totals(sim)
    sim.advance(1.0)
    assert sim.counts()["AB"] == 1 and len(sim) == 1
    assert_conserved(before, sim)
    # internal energy = relative KE + formation energy released (1.0)
    mu = 0.5
    rel_ke = 0.5 * mu * (3.0**2 + 0.3**2)
    assert sim.internal_energy[0] == pytest.approx(rel_ke + 1.0, rel=1e-12)


def test_combination_below_activation_bounces():
    sc = free_scene([dg.Combination("A", "B", "AB", activation_energy=3.0)])
    sim = two_disc(sc, [99.0, 100.0], [101.0, 100.0], [1.5, 0.0], [-1.5, 0.0], 0, 1)
    sim.advance(1.0)
    assert sim.counts()["AB"] == 0 and sim.collisions == 1


def test_reverse_combination_fires_only_above_barrier_and_conserves():
    sc = free_scene([dg.Combination("A", "B", "AB", activation_energy=1.0,
                                    reverse_probability=1.0)])
    # barrier = E_a + F_A + F_B - F_AB = 1 + 0 + 0 + 1 = 2
    hot = dg.Simulation.from_arrays(sc, [[100.0, 100.0]], [[0.3, -0.2]], ["AB"],
                                    internal_energy=[2.5])
    cold = dg.Simulation.from_arrays(sc, [[100.0, 100.0]], [[0.3, -0.2]], ["AB"],
                                     internal_energy=[1.9])
    before = totals(hot)
    hot.advance(2.0)
    cold.advance(2.0)
    assert hot.counts() == {"A": 1, "B": 1, "AB": 0, "C": 0}
    assert_conserved(before, hot)
    assert cold.counts()["AB"] == 1
    # fragments leave perpendicular to the parent's velocity, in its frame
    rel = hot.velocities[1] - hot.velocities[0]
    assert abs(rel @ np.array([0.3, -0.2])) < 1e-12


HOT = dg.Species("AB", 0.7, 2.0, formation_energy=1.0)  # decomposes exothermically


def test_decomposition_conserves_and_rate_matches_first_order():
    p = 0.3
    sc = dg.Scene(bounds=dg.Box(60.0, 60.0), species=[HOT, A, B],
                  reactions=[dg.Decomposition("AB", "A", "B", probability=p)],
                  counts={"AB": 400}, dt=0.02, collisions=False)
    sim = dg.Simulation(sc, seed=0)
    e0, m0 = sim.total_energy(), sim.masses.sum()
    sim.advance(2.0)
    assert sim.masses.sum() == pytest.approx(m0, rel=1e-14)
    assert sim.total_energy() == pytest.approx(e0, rel=1e-12)
    survivors = sim.counts()["AB"] / 400
    expected = (1 - p) ** 2.0
    assert survivors == pytest.approx(expected, abs=4 * math.sqrt(expected * (1 - expected) / 400))


def test_decomposition_of_a_disc_at_rest_conserves_momentum():
    sc = free_scene([dg.Decomposition("AB", "A", "B", probability=1.0)], species=(A, B, HOT))
    sim = dg.Simulation.from_arrays(sc, [[100.0, 100.0]], [[0.0, 0.0]], ["AB"], seed=1)
    before = totals(sim)
    sim.step()
    assert sim.counts()["A"] == 1 and sim.counts()["B"] == 1
    assert_conserved(before, sim)
    # the released formation energy (1.0) is now kinetic, in equal and opposite momenta
    assert sim.kinetic_energy() == pytest.approx(1.0, rel=1e-12)


def test_endothermic_decomposition_waits_for_energy():
    hot_ab = dg.Species("AB", 0.7, 2.0, formation_energy=1.0)
    sc = free_scene([dg.Decomposition("AB", "A", "C", probability=1.0)],
                    species=(A, hot_ab, C))
    # released = U + F_AB - F_A - F_C = U + 1 - 0.4: negative only if U < -0.6 -> fires
    sim = dg.Simulation.from_arrays(sc, [[100.0, 100.0]], [[0.1, 0.0]], ["AB"])
    sim.step()
    assert sim.counts()["C"] == 1
    cold = dg.Species("AB", 0.7, 2.0, formation_energy=0.0)
    sc2 = free_scene([dg.Decomposition("AB", "A", "C", probability=1.0)], species=(A, cold, C))
    s2 = dg.Simulation.from_arrays(sc2, [[100.0, 100.0]], [[0.1, 0.0]], ["AB"],
                                   internal_energy=[0.3])
    s2.advance(1.0)
    assert s2.counts()["AB"] == 1  # needs 0.4, has 0.3: must not fire


def test_transformation_moves_formation_energy_into_internal_energy():
    sc = free_scene([dg.Transformation("C", "A", probability=1.0)])
    sim = dg.Simulation.from_arrays(sc, [[100.0, 100.0]], [[0.5, 0.5]], ["C"])
    before = totals(sim)
    sim.step()
    assert sim.counts()["A"] == 1
    assert sim.internal_energy[0] == pytest.approx(0.4)
    assert_conserved(before, sim)


def test_exchange_conserves_and_respects_activation():
    D = dg.Species("D", 0.7, 2.0, formation_energy=-0.5)
    sc = free_scene([dg.Exchange("A", "AB", "D", "B", activation_energy=1.0)],
                    species=(A, B, AB, D))
    sim = two_disc(sc, [98.0, 100.0], [101.0, 100.4], [2.5, 0.3], [-1.0, 0.0], 0, 2)
    before = totals(sim)
    sim.advance(2.0)
    assert sim.counts()["D"] == 1 and sim.counts()["B"] == 1
    assert_conserved(before, sim)
    assert sim.overlaps() == 0
    slow = two_disc(sc, [98.0, 100.0], [101.0, 100.4], [0.5, 0.0], [-0.2, 0.0], 0, 2)
    slow.advance(8.0)
    assert slow.counts()["D"] == 0 and slow.collisions >= 1


def test_no_room_means_no_reaction_and_no_overlap():
    big = dg.Species("big", 2.0, 2.0)
    sc = dg.Scene(bounds=dg.Box(4.2, 4.2), species=[A, B, big],
                  reactions=[dg.Combination("A", "B", "big", activation_energy=0.0)],
                  dt=0.01)
    # A and B meet near a corner where a radius-2 product does not fit
    sim = two_disc(sc, [0.6, 0.6], [1.8, 0.6], [1.0, 0.0], [-1.0, 0.0], 0, 1)
    sim.advance(1.0)
    assert sim.counts()["big"] == 0
    assert sim.counters()["reactions_without_room"] >= 1
    assert sim.overlaps() == 0 and sim.outside() == 0


def test_activated_reacting_fraction_follows_boltzmann():
    """Collision theory in 2D: the fraction of collisions with 1/2 mu v_r^2 >= E_a is
    exp(-E_a / kT), at any density. Count it through a reaction that changes nothing else."""
    X = dg.Species("X", 0.5, 1.0)
    Y = dg.Species("Y", 0.5, 1.0)
    Ea = 1.5
    sc = dg.Scene(bounds=dg.Box(30.0, 30.0), species=[X, Y],
                  reactions=[dg.Exchange("X", "X", "Y", "Y", activation_energy=Ea),
                             dg.Exchange("Y", "Y", "X", "X", activation_energy=Ea),
                             dg.Exchange("X", "Y", "Y", "X", activation_energy=Ea)],
                  counts={"X": 150, "Y": 150}, dt=0.02)
    sim = dg.Simulation(sc, seed=7)
    sim.advance(80.0)
    fired = sum(sim.reactions().values())
    total = fired + sim.collisions
    frac = fired / total
    assert total > 20000
    expected = math.exp(-Ea / sim.temperature())
    assert frac == pytest.approx(expected, abs=4 * math.sqrt(expected * (1 - expected) / total))
    assert abs(sim.energy_balance()) < 1e-9
