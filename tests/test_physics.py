"""Physical invariants of the time-stepped integrator, checked with numbers."""

import math
import pickle

import numpy as np
import pytest
from conftest import two_disc

import discgym as dg

A = dg.Species("A", 0.5, 1.0)


def box_scene(**kw):
    base = dict(bounds=dg.Box(20.0, 20.0), species=[A], dt=0.05)
    base.update(kw)
    return dg.Scene(**base)


def test_elastic_gas_conserves_energy_over_1e5_collisions():
    sc = box_scene(bounds=dg.Box(24.0, 24.0), counts={"A": 250})
    sim = dg.Simulation(sc, seed=1)
    e0 = sim.kinetic_energy()
    while sim.collisions < 100_000:
        sim.step(200)
        assert sim.overlaps(1e-9) == 0
        assert sim.outside(1e-12) == 0
    rel = abs(sim.kinetic_energy() - e0) / e0
    assert rel < 1e-11, rel
    assert sim.wall_hits > 1000


def test_every_collision_conserves_momentum_and_energy():
    # two discs far from the walls: the pair's momentum must come out unchanged
    rng = np.random.default_rng(3)
    sc = dg.Scene(bounds=dg.Box(100.0, 100.0),
                  species=[dg.Species("a", 0.5, 1.0), dg.Species("b", 1.3, 7.5)], dt=0.05)
    for _ in range(200):
        # approach along x (random speeds, impact parameter and common drift in y)
        drift = rng.normal()
        b = rng.uniform(-1.75, 1.75)
        sim = two_disc(sc, [45.0, 50.0 + b], [55.0, 50.0], [3.0 + rng.random(), drift],
                       [-3.0 - rng.random(), drift], 0, 1)
        p0, e0 = sim.momentum(), sim.kinetic_energy()
        sim.advance(3.0)
        assert sim.collisions == 1
        np.testing.assert_allclose(sim.momentum(), p0, atol=1e-12)
        assert sim.kinetic_energy() == pytest.approx(e0, rel=1e-13)
        assert sim.overlaps() == 0


@pytest.mark.parametrize("e", [0.0, 0.3, 0.9])
def test_restitution_loses_exactly_the_booked_energy(e):
    sc = box_scene(restitution=e, counts={"A": 120})
    sim = dg.Simulation(sc, seed=2)
    sim.advance(5.0)
    assert sim.collisions > 100
    assert abs(sim.energy_balance()) < 1e-10 * sim._energy_start
    if e < 1:
        assert sim.dissipated_energy > 0


def test_head_on_equal_masses_swap_velocities():
    sc = box_scene(bounds=dg.Box(50.0, 50.0))
    sim = two_disc(sc, [20.0, 25.0], [30.0, 25.0], [1.0, 0.0], [-2.0, 0.0])
    sim.advance(5.0)
    v = sim.velocities
    assert v[0, 0] == pytest.approx(-2.0, abs=1e-14) and v[1, 0] == pytest.approx(1.0, abs=1e-14)
    # contact at t = 9/3 = 3 (x = 23 and 24), then 2 time units apart at the swapped speeds
    np.testing.assert_allclose(sim.positions[:, 0], [23.0 - 2 * 2.0, 24.0 + 2 * 1.0],
                               atol=1e-12)


def test_exact_contact_time_box_and_circle_walls():
    for bounds, start, vel, expect in [
        (dg.Box(10.0, 10.0), [9.0, 5.0], [1.0, 0.0], [9.5 - 0.3, 5.0]),
        (dg.Circle(5.0), [3.9, 0.0], [1.0, 0.0], [4.5 - 0.2, 0.0]),
    ]:
        sc = dg.Scene(bounds=bounds, species=[A], dt=0.1)
        sim = dg.Simulation.from_arrays(sc, [start], [vel], [0])
        # box: contact at x = 9.5 after 0.5, then 0.3 back; circle: at 4.5 after 0.6, 0.2 back
        sim.advance(0.8)
        np.testing.assert_allclose(sim.positions[0], expect, atol=1e-12)
        np.testing.assert_allclose(sim.velocities[0], [-1.0, 0.0], atol=1e-14)


def test_circle_reflection_is_specular_off_axis():
    sc = dg.Scene(bounds=dg.Circle(5.0, center=(1.0, -2.0)), species=[A], dt=0.05)
    sim = dg.Simulation.from_arrays(sc, [[1.0, -2.0]], [[3.0, 4.0]], [0])
    sim.advance(1.0)  # radial hit at distance 4.5 (t = 0.9), then 0.1 back at speed 5
    np.testing.assert_allclose(sim.velocities[0], [-3.0, -4.0], atol=1e-12)
    np.testing.assert_allclose(sim.positions[0], [1.0 + 0.6 * 4.0, -2.0 + 0.8 * 4.0],
                               atol=1e-12)


def test_no_overlap_and_nothing_outside_after_every_step_dense_polydisperse():
    sc = dg.Scene(bounds=dg.Circle(12.0),
                  species=[dg.Species("s", 0.4, 1.0), dg.Species("l", 1.2, 9.0)],
                  counts={"s": 150, "l": 35}, dt=0.05)
    sim = dg.Simulation(sc, seed=5, temperature=2.0)
    for _ in range(300):
        sim.step()
        assert sim.overlaps(1e-9) == 0
        assert sim.outside(1e-12) == 0


def test_same_seed_same_trajectory_and_chunking_does_not_matter():
    sc = dg.scenes.load("reactor")
    a = dg.Simulation(sc, seed=11)
    b = dg.Simulation(sc, seed=11)
    a.advance(200 * sc.dt)
    for _ in range(200):
        b.step()
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.velocities, b.velocities)
    assert a.reactions() == b.reactions()
    c = dg.Simulation(sc, seed=12)
    c.advance(200 * sc.dt)
    assert not np.array_equal(a.positions, c.positions)


def test_state_round_trip_and_pickle_continue_bit_identically():
    sc = dg.scenes.load("reactor")
    a = dg.Simulation(sc, seed=3)
    a.advance(1.0)
    state = a.get_state()
    b = pickle.loads(pickle.dumps(a))
    a.advance(2.0)
    b.advance(2.0)
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.internal_energy, b.internal_energy)
    a.set_state(state)
    a.advance(2.0)
    assert np.array_equal(a.positions, b.positions)
    assert a.time == b.time and a.reactions() == b.reactions()


def test_temperature_and_initial_conditions():
    sim = dg.Simulation(box_scene(counts={"A": 200}), temperature=2.5, seed=0)
    assert sim.temperature() == pytest.approx(2.5, rel=1e-12)
    np.testing.assert_allclose(sim.momentum(), 0.0, atol=1e-12)
    assert sim.overlaps() == 0 and sim.outside() == 0
    assert sim.counts() == {"A": 200}


def test_dense_initial_packing_uses_lattice():
    # packing 0.75: beyond random sequential addition, a lattice still fits
    n = int(0.75 * 400 / (math.pi * 0.25))
    sim = dg.Simulation(box_scene(counts={"A": n}), seed=0)
    assert len(sim) == n and sim.overlaps() == 0 and sim.outside() == 0
    sim.step(20)
    assert sim.overlaps(1e-9) == 0 and sim.outside(1e-12) == 0


def test_pressure_of_dilute_gas_is_ideal():
    # packing 0.02: P = n kT (1 + small) with n = N / area
    sc = dg.Scene(bounds=dg.Box(60.0, 60.0), species=[dg.Species("A", 0.3, 1.0)],
                  counts={"A": 500}, dt=0.05)
    sim = dg.Simulation(sc, seed=4)
    sim.advance(2.0)
    sim.reset_counters()
    sim.advance(60.0)
    eta = 500 * math.pi * 0.09 / 3600
    henderson = (1 + eta**2 / 8) / (1 - eta) ** 2
    ideal = 500 / 3600 * sim.temperature()
    assert sim.pressure() / ideal == pytest.approx(henderson, rel=0.03)


def test_from_arrays_rejects_bad_input():
    sc = box_scene()
    with pytest.raises(ValueError, match="overlap"):
        dg.Simulation.from_arrays(sc, [[5, 5], [5.5, 5]], [[0, 0], [0, 0]], ["A", "A"])
    with pytest.raises(ValueError, match="not inside"):
        dg.Simulation.from_arrays(sc, [[0.2, 5]], [[0, 0]], ["A"])
    with pytest.raises(ValueError, match="not finite"):
        dg.Simulation.from_arrays(sc, [[5, 5]], [[np.nan, 0]], ["A"])
    with pytest.raises(ValueError, match="unknown species"):
        dg.Simulation.from_arrays(sc, [[5, 5]], [[0, 0]], ["Q"])
    with pytest.raises(ValueError, match="advance"):
        dg.Simulation(sc).advance(math.nan)


def test_scratch_kept_between_calls_changes_nothing_as_the_state_grows():
    """A Simulation keeps the stepper's scratch buffers between calls (``kernels.step``
    ``empty_work``): 12 calls of one step give bit for bit what one call of 12 steps gives
    in a copy (which starts with no scratch), while decompositions double the capacity and
    the discs (above REORDER_MIN) are reordered in memory with the scratch as their copy."""
    sc = dg.Scene(bounds=dg.Box(400.0, 400.0),
                  species=[dg.Species("A", 0.5, 2.0), dg.Species("B", 0.5, 1.0)],
                  reactions=[dg.Decomposition("A", "B", "B", probability=0.3)],
                  counts={"A": 17000}, temperature=1.0)
    a = dg.Simulation(sc, seed=0)
    cap0 = a._pos.shape[0]
    b = a.copy()
    for _ in range(12):
        a.step()
    b.step(12)
    assert a._pos.shape[0] > cap0 and len(a) > 17000  # it grew
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities,
                                                                       b.velocities)
    assert np.array_equal(a.ids, b.ids) and a.counts() == b.counts()
    assert a.overlaps() == 0


def test_large_populations_are_reordered_in_memory_but_ids_follow_the_discs():
    n = 17000  # above REORDER_MIN: discs are put in cell order every 8 steps
    sc = dg.Scene(bounds=dg.Box(260.0, 260.0), species=[A], counts={"A": n}, dt=0.05)
    a = dg.Simulation(sc, seed=0)
    b = dg.Simulation(sc, seed=0)
    ids0, pos0 = a.ids, a.positions
    a.step(9)
    for _ in range(9):
        b.step()
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.ids, b.ids)
    assert not np.array_equal(a.ids, ids0)  # reordered...
    assert np.array_equal(np.sort(a.ids), np.arange(n))  # ...a permutation
    by_id = np.empty_like(pos0)
    by_id[a.ids] = a.positions
    moved = np.linalg.norm(by_id - pos0[np.argsort(ids0)], axis=1)
    assert moved.max() < 9 * 0.05 * 10  # each id is still the same disc (no teleports)
    assert a.overlaps() == 0


def test_a_state_of_the_previous_version_is_restored_and_continues_bit_for_bit():
    """Counters are only appended: a state saved before ``graze_repairs`` existed (11
    counters) is restored with the new counters at zero and continues bit for bit; a state
    with fewer or more counters than any version had is refused."""
    sc = dg.scenes.load("reactor")
    a = dg.Simulation(sc, seed=4)
    a.step(20)
    st = a.get_state()
    old = dict(st, icnt=st["icnt"][:11])
    b = dg.Simulation(sc, seed=99)
    b.set_state(old)
    assert b.counters()["graze_repairs"] == 0
    assert {k: v for k, v in b.counters().items() if k != "graze_repairs"} == \
        {k: v for k, v in a.counters().items() if k != "graze_repairs"}
    a.step(30)
    b.step(30)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities,
                                                                       b.velocities)
    for bad in (st["icnt"][:10], np.concatenate([st["icnt"], [0]])):
        with pytest.raises(ValueError, match="another version"):
            b.set_state(dict(st, icnt=bad))
