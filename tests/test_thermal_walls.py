"""Thermal walls (docs/physics.md, "Thermal walls"): the draw rule, relaxation to the wall
temperature, the heat flux between a hot and a cold wall, the energy ledger, the controls,
the state and the refusals.

The statistical tests are seeded and their tolerances come from the statistics (4-5 standard
errors, each derived in the test's docstring), not from what the runs happened to give.
"""

import math
import pickle

import numpy as np
import pytest
from numba import njit

import discgym as dg
from discgym.kernels.walls import thermal_velocity

A = dg.Species("A", 0.1, 1.0)
SIDES = ("left", "right", "bottom", "top")


def box(walls, **kw):
    base = dict(bounds=dg.Box(10.0, 10.0), species=[A], dt=0.02,
                thermal_walls=[dg.ThermalWall(s, t) for s, t in walls.items()])
    base.update(kw)
    return dg.Scene(**base)


@njit(cache=True)
def _draws(n, kT, m, side, kind, params, rng):
    out = np.empty((n, 2))
    for k in range(n):
        vx, vy, _vin, _vout = thermal_velocity(0.0, 0.0, 1.0, -1.0, side, kT, m, kind,
                                               params, rng)
        out[k, 0] = vx
        out[k, 1] = vy
    return out


@pytest.mark.parametrize("side, normal", [(0, (1.0, 0.0)), (1, (-1.0, 0.0)),
                                          (2, (0.0, 1.0)), (3, (0.0, -1.0))])
def test_the_draw_is_the_flux_weighted_maxwell_boltzmann(side, normal):
    """Outgoing velocities at a wall of kT = 2, m = 0.5 (s^2 = kT/m = 4), n = 200000 draws:
    the normal speed v_n is Rayleigh(s): mean s sqrt(pi/2), variance (2 - pi/2) s^2, and
    always inward; the tangential speed v_t is N(0, s^2): mean 0 (sd s / sqrt(n)), <v_t^2> =
    s^2 (sd s^2 sqrt(2 / n)). Each mean within 5 of its standard errors, and the whole
    distribution: a Kolmogorov-Smirnov test of v_n against Rayleigh and of v_t against the
    normal law (p > 1e-4)."""
    from scipy import stats

    kT, m, n = 2.0, 0.5, 200_000
    s = math.sqrt(kT / m)
    v = _draws(n, kT, m, side, 0, np.array([0.0, 0.0, 10.0, 10.0]),
               np.random.default_rng(side))
    nx, ny = normal
    vn = v[:, 0] * nx + v[:, 1] * ny
    vt = -v[:, 0] * ny + v[:, 1] * nx
    assert (vn > 0).all()
    se_n = math.sqrt(2 - math.pi / 2) * s / math.sqrt(n)
    assert abs(vn.mean() - s * math.sqrt(math.pi / 2)) < 5 * se_n
    assert abs(vt.mean()) < 5 * s / math.sqrt(n)
    assert abs((vt ** 2).mean() - s * s) < 5 * s * s * math.sqrt(2 / n)
    assert stats.kstest(vn, stats.rayleigh(scale=s).cdf).pvalue > 1e-4
    assert stats.kstest(vt, stats.norm(scale=s).cdf).pvalue > 1e-4


def test_the_draw_on_a_circle_points_inward():
    """On a circle the normal speed is along the inward normal at the contact point, the
    tangential one along the wall: at the contact point (0, 5) of the circle of radius 5 about
    the origin the inward normal is -y; the same moments as on a box wall."""
    kT, m, n = 1.0, 1.0, 100_000
    out = _draws_circle(n, kT, m, np.random.default_rng(7))
    vn = -out[:, 1]
    assert (vn > 0).all()
    assert abs(vn.mean() - math.sqrt(math.pi / 2)) < 5 * math.sqrt(2 - math.pi / 2) / \
        math.sqrt(n)
    assert abs(out[:, 0].mean()) < 5 / math.sqrt(n)


@njit(cache=True)
def _draws_circle(n, kT, m, rng):
    out = np.empty((n, 2))
    params = np.array([0.0, 0.0, 5.0, 0.0])
    for k in range(n):
        vx, vy, _a, _b = thermal_velocity(0.0, 5.0, 0.3, 1.0, 0, kT, m, 1, params, rng)
        out[k, 0] = vx
        out[k, 1] = vy
    return out


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_a_gas_relaxes_to_the_wall_temperature(integrator):
    """100 colliding discs (packing 0.03) started at kT = 0.5 between four walls at kT_w = 2
    relax to kT_w: after t = 100 (the energy relaxation time is ~ the time between a disc's
    wall hits, L / <|v_x|> ~ 10), the temperature sampled every 2 for t = 400 averages kT_w
    within 5 standard errors. In equilibrium with the walls each disc's kinetic energy is
    exponential with mean kT_w; the standard error of the time average is estimated from 20
    batch means of 20 time units (longer than the correlation time), and must itself be
    small (< 3 % of kT_w) so that the test could fail. The energy ledger stays exact."""
    sc = box({s: 2.0 for s in SIDES}, counts={"A": 100}, temperature=0.5)
    sim = dg.Simulation(sc, seed=3, integrator=integrator)
    sim.advance(100.0)
    temps = []
    for _ in range(200):
        sim.advance(2.0)
        temps.append(sim.temperature())
    temps = np.array(temps)
    means = temps.reshape(20, 10).mean(axis=1)
    se = means.std(ddof=1) / math.sqrt(len(means))
    assert se < 0.03 * 2.0, se
    assert abs(temps.mean() - 2.0) < 5 * se, (temps.mean(), se)
    assert abs(sim.energy_balance()) < 1e-12 * sim.total_energy() * 10
    assert sim.wall_heat > 0  # the walls heated the gas: N (kT_w - kT_0) = 150 on average
    assert sim.overlaps() == 0 and sim.outside() == 0


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_heat_flows_from_the_hot_wall_to_the_cold_one_at_the_knudsen_rate(integrator):
    """A collisionless gas (N = 400, Knudsen limit) between a hot left wall (kT_h = 2) and a
    cold right wall (kT_c = 0.5), specular top and bottom: each disc shuttles between them,
    its normal speed Rayleigh with s_h = sqrt(kT_h / m) after a hot hit and s_c after a cold
    one. A cycle (hot wall -> cold -> hot) lasts on average d (<1/v>_h + <1/v>_c) =
    d sqrt(pi/2) (1/s_h + 1/s_c) (d = width - 2 r: the centres' range; <1/v> of
    Rayleigh(s) is sqrt(pi/2) / s), and the hot wall gives it the flux-weighted mean energy
    3/2 kT_h minus what the cold wall gave it, 3/2 kT_c. By the renewal-reward theorem the
    steady heat flux into the gas at the hot wall is Q_h = N 3/2 (kT_h - kT_c) / <cycle>
    (34.5 here), and -Q_h at the cold wall. Measured over t = 400 after t = 60 of transient,
    within 5 standard errors (from 20 batch means) of the theory; the per-side heat is
    ``wall_heat_by_side``."""
    kh, kc, N = 2.0, 0.5, 400
    sc = box({"left": kh, "right": kc}, counts={"A": N}, temperature=1.0, collisions=False)
    sim = dg.Simulation(sc, seed=11, integrator=integrator)
    sim.advance(60.0)
    d = 10.0 - 2 * A.radius
    cycle = d * math.sqrt(math.pi / 2) * (1 / math.sqrt(kh) + 1 / math.sqrt(kc))
    q_theory = N * 1.5 * (kh - kc) / cycle
    hot, cold = [], []
    h0 = sim.wall_heat_by_side()
    for _ in range(20):
        sim.advance(20.0)
        h1 = sim.wall_heat_by_side()
        hot.append((h1["left"] - h0["left"]) / 20.0)
        cold.append((h1["right"] - h0["right"]) / 20.0)
        h0 = h1
    hot, cold = np.array(hot), np.array(cold)
    assert h1["top"] == 0.0 and h1["bottom"] == 0.0  # specular walls exchange nothing
    se_h = hot.std(ddof=1) / math.sqrt(len(hot))
    se_c = cold.std(ddof=1) / math.sqrt(len(cold))
    assert se_h < 0.05 * q_theory and se_c < 0.05 * q_theory
    assert hot.mean() > 0 > cold.mean()
    assert abs(hot.mean() - q_theory) < 5 * se_h, (hot.mean(), q_theory, se_h)
    assert abs(cold.mean() + q_theory) < 5 * se_c, (cold.mean(), q_theory, se_c)
    assert abs(sim.energy_balance()) < 1e-11 * sim.total_energy()


def test_pressure_counts_the_momentum_of_a_thermal_bounce():
    """A collisionless gas at kT_w between four thermal walls at kT_w: the wall receives
    m (v_n,in + v_n,out) per hit, which in equilibrium gives the ideal-gas pressure
    P = n kT (n = N / the centres' area). Within 5 % (the pressure of 2000 discs over t = 50,
    ~5e4 wall hits, is known to ~1 %)."""
    N, kT = 2000, 1.5
    sc = box({s: kT for s in SIDES}, counts={"A": N}, temperature=kT, collisions=False)
    sim = dg.Simulation(sc, seed=5)
    sim.advance(10.0)
    sim.reset_counters()
    sim.advance(50.0)
    d = 10.0 - 2 * A.radius
    # the walls' perimeter (40) sees the centres' box (d x d) at contact
    p_theory = N / (d * d) * kT * (4 * d) / 40.0
    assert abs(sim.pressure() / p_theory - 1) < 0.05, (sim.pressure(), p_theory)


def test_wall_temperature_control_validates_and_changes_the_physics():
    sc = box({"left": 1.0, "right": 1.0}, counts={"A": 50})
    sim = dg.Simulation(sc, seed=1)
    assert sim.wall_temperature == {"left": 1.0, "right": 1.0}
    sim.set_wall_temperature("left", 3.0)
    sim.set_wall_temperature({"right": 0.25})
    assert sim.wall_temperature == {"left": 3.0, "right": 0.25}
    before = sim.wall_temperature
    for args, match in [(("top", 1.0), "not a thermal wall"), (("nowhere", 1.0), "not a thermal"),
                        (("left", 0.0), "finite temperature > 0"),
                        (("left", -1.0), "finite temperature > 0"),
                        (("left", math.nan), "finite temperature > 0"),
                        (("left", math.inf), "finite temperature > 0"),
                        (("left", "hot"), "expected a number"),
                        (("left", True), "expected a number"),
                        (("left", 10 * sim.max_wall_temperature()), "speed limit"),
                        (("left",), "missing"), (({"left": 1.0}, 2.0), "not both"),
                        (({"left": 1.0, "top": 2.0},), "not a thermal wall")]:
        with pytest.raises(ValueError, match=match) as exc:
            sim.set_wall_temperature(*args)
        assert str(exc.value).startswith("set_wall_temperature(")
        assert sim.wall_temperature == before  # nothing changed, even partly
    # the limit: 40 thermal speeds of the lightest species within the speed limit
    t_max = sim.max_wall_temperature()
    assert 40 * math.sqrt(t_max / A.mass) == pytest.approx(sim.speed_limit)
    sim.set_wall_temperature("left", t_max)


def test_a_hot_draw_does_not_tunnel():
    """Walls far hotter than the gas (kT_w = 2e4 vs kT = 1: drawn speeds ~ 140, some 60 times
    the substep's speed) put discs faster than the substeps of their step allow: the rest of
    the step is split anew (``resplits``), the substep cut at the draw (``substeps_cut``),
    and no disc leaves the box or overlaps another."""
    sc = box({"left": 2e4}, counts={"A": 150}, temperature=1.0)
    sim = dg.Simulation(sc, seed=2)
    for _ in range(20):
        sim.step(10)
        assert sim.outside(1e-9) == 0 and sim.overlaps(1e-9) == 0
    c = sim.counters()
    assert c["resplits"] > 0 and c["substeps_cut"] > 0
    assert abs(sim.energy_balance()) < 1e-11 * sim.total_energy()


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_inelastic_gas_between_thermal_walls_reaches_a_steady_state(e):
    """Restitution e < 1 with thermal walls: the walls feed the energy the collisions
    dissipate; the ledger (wall heat in, dissipation out) stays exact, the temperature
    stays between 0 and the walls', and nothing escapes or overlaps."""
    sc = box({s: 1.0 for s in SIDES}, counts={"A": 300}, restitution=e)
    sim = dg.Simulation(sc, seed=4)
    sim.advance(30.0)
    assert 0 < sim.temperature() < 1.0
    assert sim.dissipated_energy > 0 and sim.wall_heat > 0
    assert abs(sim.energy_balance()) < 1e-12 * max(sim.dissipated_energy, 1.0) * 100
    assert sim.outside(1e-9) == 0 and sim.overlaps(1e-6) == 0


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_a_circle_with_a_thermal_wall_relaxes_and_keeps_its_discs(integrator):
    sc = dg.Scene(bounds=dg.Circle(5.0), species=[A], dt=0.02, counts={"A": 200},
                  temperature=0.3, thermal_walls=[dg.ThermalWall("wall", 1.5)])
    sim = dg.Simulation(sc, seed=8, integrator=integrator)
    sim.advance(80.0)
    temps = []
    for _ in range(40):
        sim.advance(2.0)
        temps.append(sim.temperature())
    # 200 discs, 40 samples: the standard error is ~ 1.5 / sqrt(200 x ~10 independent) ~ 0.03
    assert abs(np.mean(temps) - 1.5) < 0.2
    assert sim.outside(1e-9) == 0 and sim.overlaps(1e-9) == 0
    assert abs(sim.energy_balance()) < 1e-11 * sim.total_energy()


def test_the_event_integrator_does_thermal_walls_and_continues_bit_for_bit():
    """The event-driven integrator draws at the exact wall contact (a thermal hit on a circle
    keeps the integrator's grazing floor, walls.graze_floor); the ledger stays exact, the
    state and a pickle continue bit for bit, and a state moves between the integrators."""
    sc = box({"left": 3.0, "bottom": 0.5}, counts={"A": 120})
    sim = dg.Simulation(sc, seed=0, integrator="event")
    sim.advance(5.0)
    assert sim.wall_heat_by_side()["left"] > 0 > sim.wall_heat_by_side()["bottom"]
    assert abs(sim.energy_balance()) < 1e-11 * sim.total_energy()
    twin = pickle.loads(pickle.dumps(sim))
    sim.advance(3.0)
    twin.advance(3.0)
    assert np.array_equal(sim.positions, twin.positions) and sim.wall_heat == twin.wall_heat
    stepped = dg.Simulation(sc, seed=1)
    stepped.set_state(dict(sim.get_state(), integrator="step"))
    stepped.advance(2.0)
    assert abs(stepped.energy_balance()) < 1e-11 * stepped.total_energy()
    assert sim.overlaps() == 0 and sim.outside() == 0


def test_state_pickle_and_copy_continue_bit_for_bit():
    """The wall temperatures are state: get_state / set_state, pickle and copy carry them
    (and the heat booked), and the copies continue bit for bit."""
    sc = box({"left": 1.0, "top": 2.0}, counts={"A": 80}, outlets=[dg.Outlet("right", 0.3, 0.7)])
    sim = dg.Simulation(sc, seed=9)
    sim.advance(5.0)
    sim.set_wall_temperature("left", 4.0)
    st = sim.get_state()
    assert st["wall_temperature"] == {"left": 4.0, "top": 2.0}
    twins = [pickle.loads(pickle.dumps(sim)), sim.copy(), dg.Simulation(sc, seed=1)]
    twins[2].set_state(st)
    sim.advance(5.0)
    for t in twins:
        assert t.wall_temperature == {"left": 4.0, "top": 2.0}
        t.advance(5.0)
        assert np.array_equal(t.positions, sim.positions)
        assert np.array_equal(t.velocities, sim.velocities)
        assert t.wall_heat == sim.wall_heat and t.outflow() == sim.outflow()
    # a state of the version before (no wall_temperature): the scene's temperatures
    old = {k: v for k, v in st.items() if k not in ("wall_temperature", "outflow")}
    old["fsum"] = st["fsum"][:2]
    b = dg.Simulation(sc, seed=1)
    b.set_state(old)
    assert b.wall_temperature == {"left": 1.0, "top": 2.0} and b.wall_heat == 0.0


@pytest.mark.parametrize("bad, match", [
    ({"left": 1.0}, "no temperature for the thermal walls"),
    ({"left": 1.0, "top": 2.0, "right": 1.0}, "not a thermal wall"),
    ({"left": -1.0, "top": 2.0}, "finite temperature > 0"),
    ({"left": math.nan, "top": 2.0}, "finite temperature > 0"),
    ({"left": 1e30, "top": 2.0}, "speed limit"),
    ({"left": "1", "top": 2.0}, "expected a number"),
    ([("left", 1.0)], "must be a dict"),
])
def test_a_bad_wall_temperature_state_is_refused(bad, match):
    sc = box({"left": 1.0, "top": 2.0}, counts={"A": 20})
    sim = dg.Simulation(sc, seed=0)
    st = dict(sim.get_state(), wall_temperature=bad)
    with pytest.raises(ValueError, match=match) as exc:
        sim.set_state(st)
    assert "state['wall_temperature']" in str(exc.value)
    assert sim.wall_temperature == {"left": 1.0, "top": 2.0}


def test_toml_round_trip_and_scene_errors():
    sc = box({"left": 1.0, "bottom": 0.5}, outlets=[dg.Outlet("top", 0.0, 0.25),
                                                    dg.Outlet("top", 0.25, 1.0)])
    assert dg.Scene.from_toml_string(sc.to_toml()) == sc
    with pytest.raises(dg.SceneError, match=r"thermal_walls\[0\].side"):
        box({"wall": 1.0})
    with pytest.raises(dg.SceneError, match=r"thermal_walls\[0\].side"):
        dg.Scene(bounds=dg.Circle(3.0), species=[A], thermal_walls=[dg.ThermalWall("left", 1)])
    with pytest.raises(dg.SceneError, match=r"thermal_walls\[0\]"):
        box({}, thermal_walls=["left"])
    with pytest.raises(dg.SceneError, match="thermal_walls"):
        box({}, thermal_walls="left")
