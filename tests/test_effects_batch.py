"""Thermal walls and outlets through the environments' compiled step (kernels.batch): a
reactor of a batch keeps its wall temperatures and outflow counts in rows of the batch
(``Reactors.bounds_walls``, ``Reactors.outflow``), and does to the bit what the Simulation
methods do."""

import copy

import numpy as np

import discgym as dg
from discgym.env import DiscReactorEnv
from discgym.kernels import controls
from discgym.vector import DiscReactorVectorEnv


def scene():
    sc = dg.scenes.load("reactor")
    return sc.replace(thermal_walls=(dg.ThermalWall("left", 2.0), dg.ThermalWall("top", 0.5)),
                      outlets=(dg.Outlet("right", 0.3, 0.7),))


def _same(a, b):
    sa, sb = a.get_state(), b.get_state()
    for k in sa:
        if isinstance(sa[k], np.ndarray):
            assert np.array_equal(sa[k], sb[k]), k
        else:
            assert sa[k] == sb[k], k


def test_a_lone_env_step_is_the_simulation_bit_for_bit():
    """The lone env's compiled step with thermal walls and an outlet does what
    scale_temperature, resize, inject and step do on a copy (heat, wall, feed actions)."""
    env = DiscReactorEnv(scene=scene(), episode_steps=30, feed_budget=[200, 200])
    env.reset(seed=4)
    cfg, sim = env.config, env.simulation
    sim.set_wall_temperature("left", 3.0)
    rng = np.random.default_rng(1)
    for _ in range(15):
        a = rng.uniform(-1, 1, 4).astype(np.float32)
        twin = copy.deepcopy(sim)
        T = env.unwrapped.core.episodes.temperature[0]
        *_, info = env.step(a)
        x = a.tolist()
        twin.scale_temperature(min(max(cfg.heat_rate ** x[0], min(1.0, cfg.t_min / T)),
                                   max(1.0, cfg.t_max / T)))
        new = cfg.bounds_of(info["size"])
        if new != twin.bounds:
            twin.resize(new)
        for j, f in enumerate(cfg.feed):
            want = int(round(max(x[2 + j], 0.0) * cfg.inject_max))
            if want:
                assert twin.inject(f, want) == info[f"injected_{cfg.species_names[f]}"]
        twin.step(cfg.steps_per_action)
        _same(sim, twin)
    assert sum(sim.outflow().values()) > 0 and sim.wall_heat != 0.0
    assert sim.wall_temperature == {"left": 3.0, "top": 0.5}
    assert abs(sim.energy_balance()) < 1e-9 * abs(sim.total_energy())


def test_a_batch_reactor_keeps_its_walls_and_outflow_in_the_batch_rows():
    """set_wall_temperature on ``env.simulations[r]`` writes the batch's row (the Simulation
    is a handle on it); the batch's reactors follow the lone
    env's trajectory bit for bit, outflow counts and wall heat included."""
    venv = DiscReactorVectorEnv(num_envs=2, scene=scene(), episode_steps=20)
    venv.reset(seed=7)
    lone = DiscReactorEnv(scene=scene(), episode_steps=20)
    lone.reset(seed=8)  # reactor 1 of the batch was seeded with seed + 1
    venv.simulations[1].set_wall_temperature("top", 1.5)
    lone.simulation.set_wall_temperature("top", 1.5)
    walls = venv.core.state.rx.bounds_walls
    assert walls[1][3] == 1.5 and walls[0][3] == 0.5
    acts = np.random.default_rng(3).uniform(-1, 1, (10, 2, 4)).astype(np.float32)
    for a in acts:
        venv.step(a)
        lone.step(a[1])
    _same(venv.simulations[1], lone.simulation)
    assert venv.simulations[1].outflow() == lone.simulation.outflow()
    assert list(venv.core.state.rx.outflow[1]) == list(venv.simulations[1].get_state()["outflow"])
    assert venv.simulations[0].wall_temperature == {"left": 2.0, "top": 0.5}


def test_the_compiled_wall_control():
    """controls.set_wall_temperatures: thermal sides take the new values (NaN: unchanged),
    clipped to (0, t_max]; specular sides stay specular."""
    walls = np.array([1.0, np.nan, 2.0, np.nan])
    n = controls.set_wall_temperatures(walls, np.array([3.0, 5.0, np.nan, 1.0]), 10.0)
    assert n == 1 and walls[0] == 3.0 and np.isnan(walls[1]) and walls[2] == 2.0
    n = controls.set_wall_temperatures(walls, np.array([50.0, np.nan, -1.0, np.nan]), 10.0)
    assert n == 2 and walls[0] == 10.0 and 0.0 < walls[2] < 1e-300
