"""Outlets (docs/physics.md, "Outlets"): two-dimensional effusion, per-species counts, the
energy ledger, edge cases (corners, a whole side, a circle), both integrators, the state and
the refusals.

Seeded; tolerances from the statistics (Poisson counts, 5 standard deviations)."""

import math
import pickle

import numpy as np
import pytest

import discgym as dg

A = dg.Species("A", 0.05, 1.0)
B = dg.Species("B", 0.05, 4.0)


def ideal_gas(n_each, kT, rng, width=10.0, r=0.05):
    """Uniform positions in the centres' square and Maxwell-Boltzmann velocities, drawn
    directly (no rescaling): an exact ideal gas (a collisionless scene allows overlaps)."""
    pos, vel, spc = [], [], []
    for k, (m, n) in enumerate(n_each):
        pos.append(rng.uniform(r, width - r, size=(n, 2)))
        vel.append(rng.standard_normal((n, 2)) * math.sqrt(kT / m))
        spc += [k] * n
    return np.concatenate(pos), np.concatenate(vel), spc


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_effusion_rate_per_species_is_n_L_sqrt_kT_over_2_pi_m(integrator):
    """Two-dimensional effusion. A collisionless gas, uniform and Maxwellian (species A of
    mass 1 and B of mass 4, 20000 discs each, kT = 1, centres in a 9.9 x 9.9 square: number
    density n = 20000 / 9.9^2 per species), outlets [0.25, 0.75] on the left and the right
    sides (length L = 5 each, away from the corners). The wall flux of a Maxwellian gas is
    n sqrt(kT / (2 pi m)) per unit length: over t = 3 the expected count is
    2 n L t sqrt(kT / (2 pi m)) (2430 for A, 1215 for B). Specular walls mirror a uniform
    Maxwellian gas into itself, so the flux onto the outlets stays exact until discs that
    met an outlet's part of the wall would have come back to it (two crossings, 19.8, in
    t = 3: speeds above 6.6 sqrt(kT / m), a fraction 3e-10). Each disc leaves or not
    independently: the counts are binomial, variance <= mean; within 5 sigma. The energy
    they carry: the flux-weighted mean kinetic energy, 3/2 kT per disc (sd sqrt(3/2) kT)."""
    rng = np.random.default_rng(12)
    n_each = 20000
    pos, vel, spc = ideal_gas([(1.0, n_each), (4.0, n_each)], 1.0, rng)
    sc = dg.Scene(bounds=dg.Box(10.0, 10.0), species=[A, B], dt=0.02, collisions=False,
                  outlets=[dg.Outlet("left", 0.25, 0.75), dg.Outlet("right", 0.25, 0.75)])
    sim = dg.Simulation.from_arrays(sc, pos, vel, spc, seed=0, integrator=integrator)
    e0 = sim.total_energy()
    t = 3.0
    sim.advance(t)
    n = n_each / 9.9 ** 2
    out = sim.outflow()
    for name, m in (("A", 1.0), ("B", 4.0)):
        mean = 2 * n * 5.0 * t * math.sqrt(1.0 / (2 * math.pi * m))
        assert abs(out[name] - mean) < 5 * math.sqrt(mean), (name, out[name], mean)
    k = sum(out.values())
    assert abs(sim.outflow_energy / k - 1.5) < 5 * math.sqrt(1.5 / k)
    assert len(sim) == 2 * n_each - k
    assert abs(sim.energy_balance()) < 1e-12 * e0
    assert sim.outside(1e-9) == 0


def test_effusion_of_a_colliding_gas_follows_the_contact_density():
    """With collisions (packing 0.04) the density of centres at a wall is the contact value
    n_w = P / kT (the contact theorem of a hard wall: P is the momentum the reflecting walls
    receive per unit time and per unit of the length the centres can touch), a little above
    the bulk density: the outflow rate is n_w L sqrt(kT / (2 pi m)) = P L / sqrt(2 pi m kT).
    2000 discs in a 40 x 40 box, outlets [0.25, 0.75] on the left and right sides (L = 20
    each), t = 10: the gas loses ~11 % of its discs, and P and kT are averaged over the same
    window (the count and P are both linear in the density, so its decay cancels to first
    order). Within 5 Poisson sigma (~7 % of ~220: a consistency check of the colliding case;
    the exact effusion test is the collisionless one above)."""
    sp = dg.Species("A", 0.2, 1.0)
    W = 40.0
    sc = dg.Scene(bounds=dg.Box(W, W), species=[sp], dt=0.05, counts={"A": 2000},
                  outlets=[dg.Outlet("left", 0.25, 0.75), dg.Outlet("right", 0.25, 0.75)])
    sim = dg.Simulation(sc, seed=21)
    temps = []
    for _ in range(20):
        sim.advance(0.5)
        temps.append(sim.temperature())
    kT = float(np.mean(temps))
    k = sim.outflow()["A"]
    L = 2 * 20.0
    reflecting = 4 * (W - 2 * sp.radius) - L  # where the centres touch a reflecting wall
    P = sim.get_state()["fsum"][0] / (10.0 * reflecting)
    mean = P * L * 10.0 / math.sqrt(2 * math.pi * kT)
    assert abs(k - mean) < 5 * math.sqrt(mean), (k, mean)
    assert abs(sim.energy_balance()) < 1e-12 * sim.total_energy() * 10


@pytest.mark.parametrize("integrator", ["step", "event"])
@pytest.mark.parametrize("outlet", [dg.Outlet("left", 0.0, 0.1), dg.Outlet("top", 0.9, 1.0),
                                    dg.Outlet("bottom", 0.0, 1.0)])
def test_outlets_at_corners_and_whole_sides_keep_the_rest_sound(outlet, integrator):
    sp = dg.Species("A", 0.3, 1.0)
    sc = dg.Scene(bounds=dg.Box(10.0, 8.0), species=[sp], dt=0.02, counts={"A": 150},
                  outlets=[outlet])
    sim = dg.Simulation(sc, seed=3, integrator=integrator)
    e0 = sim.total_energy()
    for _ in range(10):
        sim.advance(1.0)
        assert sim.outside(1e-9) == 0 and sim.overlaps(1e-9) == 0
    assert sim.outflow()["A"] > 0 and len(sim) == 150 - sim.outflow()["A"]
    assert abs(sim.energy_balance()) < 1e-12 * e0 * 10


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_a_circle_with_a_thermal_wall_and_an_outlet(integrator):
    """A circle whose wall is thermal, with an outlet on a quarter of it (a turn from +x):
    discs leave only there (the positions where they left are not kept, but every disc that
    leaves counted, energy booked), the rest stays inside."""
    sp = dg.Species("A", 0.1, 1.0)
    sc = dg.Scene(bounds=dg.Circle(4.0, (1.0, -1.0)), species=[sp], dt=0.02,
                  counts={"A": 200}, thermal_walls=[dg.ThermalWall("wall", 2.0)],
                  outlets=[dg.Outlet("wall", 0.0, 0.25)])
    sim = dg.Simulation(sc, seed=6, integrator=integrator)
    e0 = sim.total_energy()
    for _ in range(10):
        sim.advance(1.0)
        assert sim.outside(1e-9) == 0 and sim.overlaps(1e-9) == 0
    assert 0 < sim.outflow()["A"] < 200 and len(sim) == 200 - sim.outflow()["A"]
    assert sim.wall_heat != 0.0
    assert abs(sim.energy_balance()) < 1e-12 * e0 * 10


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_where_discs_leave(integrator):
    """Discs leave only through the outlet segment: a disc moving straight at the left wall
    at heights inside [0.4, 0.6] of it leaves, one outside it (or at the bottom) reflects."""
    sp = dg.Species("A", 0.1, 1.0)
    sc = dg.Scene(bounds=dg.Box(10.0, 10.0), species=[sp], dt=0.02,
                  outlets=[dg.Outlet("left", 0.4, 0.6)])
    ys = [4.1, 4.5, 5.9, 3.85, 6.15]
    sim = dg.Simulation.from_arrays(sc, [[1.0, y] for y in ys], [[-1.0, 0.0]] * 5,
                                    ["A"] * 5, seed=0, integrator=integrator)
    sim.advance(2.0)
    assert sim.outflow() == {"A": 3}
    assert sorted(sim.positions[:, 1].tolist()) == [3.85, 6.15]
    assert (sim.velocities[:, 0] > 0).all()
    # the pressure counts only the reflections: 2 discs, m 2 |v_x| each
    assert sim.get_state()["fsum"][0] == pytest.approx(4.0)


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_outflow_of_reaction_products_is_counted_per_species(integrator):
    """A -> B (first order) with an outlet: both species leave, each counted as itself, the
    formation energy booked with the outflow; the ledger stays exact."""
    a = dg.Species("A", 0.1, 1.0, formation_energy=0.5)
    b = dg.Species("B", 0.1, 1.0, formation_energy=-0.25)
    sc = dg.Scene(bounds=dg.Box(8.0, 8.0), species=[a, b], dt=0.02, counts={"A": 200},
                  reactions=[dg.Transformation("A", "B", 0.3)],
                  outlets=[dg.Outlet("top", 0.0, 1.0)])
    sim = dg.Simulation(sc, seed=1, integrator=integrator)
    e0 = sim.total_energy()
    sim.advance(10.0)
    out = sim.outflow()
    assert out["A"] > 0 and out["B"] > 0
    assert sum(out.values()) + len(sim) == 200
    assert abs(sim.energy_balance()) < 1e-12 * abs(e0) * 100


def test_the_event_integrator_removes_at_the_exact_contact_and_continues_bit_for_bit():
    """The event-driven integrator removes a disc at its predicted wall contact on an outlet
    (out of its cell and the queue, compacted at the end of the run); a pickle continues bit
    for bit, and the state moves to the time-stepped integrator with its counts."""
    sc = dg.Scene(bounds=dg.Box(6.0, 6.0), species=[A, B], counts={"A": 60, "B": 60},
                  outlets=[dg.Outlet("left", 0.2, 0.8)], thermal_walls=[dg.ThermalWall("top", 2)])
    sim = dg.Simulation(sc, seed=4, integrator="event")
    sim.advance(4.0)
    assert 0 < sum(sim.outflow().values()) < 120
    assert len(sim) == 120 - sum(sim.outflow().values())
    assert abs(sim.energy_balance()) < 1e-11 * sim.total_energy()
    twin = pickle.loads(pickle.dumps(sim))
    sim.advance(2.0)
    twin.advance(2.0)
    assert np.array_equal(sim.positions, twin.positions) and sim.outflow() == twin.outflow()
    stepped = dg.Simulation(sc, seed=0)
    stepped.set_state(dict(sim.get_state(), integrator="step"))
    assert stepped.outflow() == sim.outflow()
    stepped.advance(1.0)
    assert abs(stepped.energy_balance()) < 1e-11 * stepped.total_energy()


def test_outflow_state_round_trip_and_refusals():
    sc = dg.Scene(bounds=dg.Box(5.0, 5.0), species=[A, B], counts={"A": 40, "B": 40},
                  outlets=[dg.Outlet("left", 0.0, 1.0)])
    sim = dg.Simulation(sc, seed=2)
    sim.advance(3.0)
    st = sim.get_state()
    assert list(st["outflow"]) == [sim.outflow()["A"], sim.outflow()["B"]]
    other = pickle.loads(pickle.dumps(sim))
    assert other.outflow() == sim.outflow()
    other.advance(1.0)
    sim.advance(1.0)
    assert np.array_equal(other.positions, sim.positions) and other.outflow() == sim.outflow()
    for bad in ([1], [1, 2, 3], [-1, 0], [1.5, 0], "x"):
        with pytest.raises(ValueError, match=r"state\['outflow'\]"):
            sim.set_state(dict(st, outflow=bad))
    sim.reset_counters()  # (cumulative: not reset with the pressure average)
    assert sum(sim.outflow().values()) > 0


def test_scene_validation_and_toml():
    for kw, field in [(dict(side="left", start=0.5, end=0.5), "end"),
                      (dict(side="left", start=-0.5, end=0.5), "start"),
                      (dict(side="left", start=0.5, end=1.5), "end"),
                      (dict(side="up", start=0.0, end=0.5), "side")]:
        with pytest.raises(dg.SceneError) as exc:
            dg.Outlet(**kw)
        assert exc.value.field == field
    with pytest.raises(dg.SceneError, match=r"outlets\[1\].start"):
        dg.Scene(bounds=dg.Box(5.0, 5.0), species=[A],
                 outlets=[dg.Outlet("left", 0.0, 0.5), dg.Outlet("left", 0.4, 1.0)])
    with pytest.raises(dg.SceneError, match=r"outlets\[0\].side"):
        dg.Scene(bounds=dg.Circle(5.0), species=[A], outlets=[dg.Outlet("left", 0.0, 0.5)])
    sc = dg.Scene(bounds=dg.Circle(5.0), species=[A], outlets=[dg.Outlet("wall", 0.9, 1.0),
                                                               dg.Outlet("wall", 0.0, 0.1)])
    assert dg.Scene.from_toml_string(sc.to_toml()) == sc


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_a_membrane_passes_only_its_species(integrator):
    """A selective outlet passing B only (the whole left side): every A disc meets it as a
    wall and stays, B discs leave; with A -> B running, the product leaves and the reactant is
    kept. A disc refused by the membrane counts in the pressure as a reflection; the energy
    ledger stays exact."""
    a = dg.Species("A", 0.1, 1.0, formation_energy=0.5)
    b = dg.Species("B", 0.1, 1.0, formation_energy=-0.25)
    sc = dg.Scene(bounds=dg.Box(6.0, 6.0), species=[a, b], dt=0.02,
                  counts={"A": 150, "B": 50}, reactions=[dg.Transformation("A", "B", 0.05)],
                  outlets=[dg.Outlet("left", 0.0, 1.0, species=["B"])])
    sim = dg.Simulation(sc, seed=5, integrator=integrator)
    e0 = sim.total_energy()
    sim.advance(8.0)
    out = sim.outflow()
    assert out["A"] == 0 and out["B"] > 10
    counts = sim.counts()
    assert counts["A"] > 0 and counts["A"] + counts["B"] + out["B"] == 200
    assert sim.outside(1e-9) == 0 and sim.overlaps(1e-9) == 0
    assert abs(sim.energy_balance()) < 1e-12 * abs(e0) * 100
    plain = dg.Simulation(sc.replace(outlets=[dg.Outlet("left", 0.0, 1.0)]), seed=5,
                          integrator=integrator)
    plain.advance(8.0)
    assert plain.outflow()["A"] > 10  # (the same gas loses its A without the membrane)


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_where_a_membrane_refuses_a_disc_it_reflects(integrator):
    """Discs moving straight at a membrane on the left wall that passes B: the B discs on
    the segment leave, the A discs on it come back as off the wall (the pressure counts
    them), the discs beside it reflect as before."""
    sc = dg.Scene(bounds=dg.Box(10.0, 10.0), species=[A, B], dt=0.02,
                  outlets=[dg.Outlet("left", 0.4, 0.6, species=("B",))])
    ys, sp = [4.1, 4.5, 5.0, 5.9, 3.85], ["B", "A", "B", "A", "B"]
    sim = dg.Simulation.from_arrays(sc, [[1.0, y] for y in ys], [[-1.0, 0.0]] * 5, sp,
                                    seed=0, integrator=integrator)
    sim.advance(2.0)
    assert sim.outflow() == {"A": 0, "B": 2}
    assert sorted(sim.positions[:, 1].tolist()) == [3.85, 4.5, 5.9]
    assert (sim.velocities[:, 0] > 0).all()
    masses = {"A": 1.0, "B": 4.0}
    assert sim.get_state()["fsum"][0] == pytest.approx(2 * (2 * masses["A"]) + 2 * masses["B"])


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_a_membrane_passing_every_species_present_is_the_plain_outlet_bit_for_bit(integrator):
    """A gas of B alone: a membrane passing B (its table refuses A, which is absent) runs the
    plain outlet's trajectory bit for bit; a membrane listing every species is the plain
    outlet itself (the same scene)."""
    sc = dg.Scene(bounds=dg.Box(6.0, 6.0), species=[A, B], counts={"B": 120},
                  outlets=[dg.Outlet("left", 0.2, 0.8)], thermal_walls=[dg.ThermalWall("top", 2)])
    membrane = sc.replace(outlets=[dg.Outlet("left", 0.2, 0.8, species=["B"])])
    assert membrane != sc
    runs = []
    for scene in (sc, membrane):
        sim = dg.Simulation(scene, seed=4, integrator=integrator)
        sim.advance(3.0)
        runs.append((sim.positions.tobytes(), sim.velocities.tobytes(), sim.outflow()))
    assert runs[0] == runs[1] and runs[0][2]["B"] > 0
    every = sc.replace(outlets=[dg.Outlet("left", 0.2, 0.8, species=["B", "A"])])
    assert every == sc and every.outlets[0].species == ()


def test_membrane_validation_and_toml():
    for bad in ("B", 3, ["B", "B"], [1], {"B": 1}):
        with pytest.raises(dg.SceneError) as exc:
            dg.Outlet("left", 0.0, 0.5, species=bad)
        assert exc.value.field == "species"
    with pytest.raises(dg.SceneError, match=r"outlets\[0\].species: unknown species 'C'"):
        dg.Scene(bounds=dg.Box(5.0, 5.0), species=[A, B],
                 outlets=[dg.Outlet("left", 0.0, 0.5, species=["C"])])
    sc = dg.Scene(bounds=dg.Box(5.0, 5.0), species=[A, B],
                  outlets=[dg.Outlet("left", 0.0, 0.5, species=["B"]), dg.Outlet("top", 0, 1)])
    assert sc.outlets[0].species == ("B",) and sc.outlets[1].species == ()
    three = [A, B, dg.Species("C", 0.05, 2.0)]
    one = dg.Scene(bounds=dg.Box(5.0, 5.0), species=three,
                   outlets=[dg.Outlet("left", 0.0, 0.5, species=["C", "A"])])
    other = dg.Scene(bounds=dg.Box(5.0, 5.0), species=three,
                     outlets=[dg.Outlet("left", 0.0, 0.5, species=("A", "C"))])
    assert one == other and one.outlets[0].species == ("A", "C")
    assert sc.outlets[0].passes("B") and not sc.outlets[0].passes("A")
    assert sc.outlets[1].passes("A")
    text = sc.to_toml()
    assert 'species = ["B"]' in text
    assert dg.Scene.from_toml_string(text) == sc
    with pytest.raises(dg.SceneError, match=r"outlets\[0\].species"):
        dg.Scene.from_toml_string(text.replace('species = ["B"]', 'species = ["X"]'))
