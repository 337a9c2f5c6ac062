"""The task suite (discgym/tasks.py): registrations, checkers, the native vector env bit for bit,
the observation blocks against a recomputation from the state, the per-episode kinetics, and the
hand-written controllers."""

import copy
import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import discgym as dg
from discgym.controllers import controller_for
from discgym.env import DEFAULTS, energy_edges
from discgym.tasks import TASKS

IDS = sorted(TASKS)
NEW = [i for i in IDS if i != "DiscReactor-v0"]
SHORT = dict(n_discs=80, episode_steps=6, max_episode_steps=6)


@pytest.mark.parametrize("env_id", IDS)
def test_every_task_is_made_by_id_by_module_id_and_as_a_vector_env(env_id):
    env = gym.make(env_id)
    assert env.spec.id == env_id and isinstance(env.unwrapped, TASKS[env_id][0])
    assert gym.make(f"discgym:{env_id}").unwrapped.config.obs_names == \
        env.unwrapped.config.obs_names
    venv = gym.make_vec(env_id, num_envs=2)
    assert isinstance(venv, TASKS[env_id][1])
    assert venv.single_observation_space == env.observation_space
    assert venv.single_action_space == env.action_space
    o, _ = venv.reset(seed=0)
    assert o.shape == (2,) + env.observation_space.shape and o.dtype == np.float32


@pytest.mark.parametrize("env_id", NEW)
def test_both_checkers_pass_on_every_task(env_id):
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id, **SHORT).unwrapped, skip_render_check=True)
    # (SB3's checker with the agents extra; gymnasium's above runs without it)
    sb3_check = pytest.importorskip("stable_baselines3.common.env_checker").check_env
    sb3_check(gym.make(env_id, **SHORT), warn=True)


@pytest.mark.parametrize("env_id", NEW)
def test_a_task_reactor_in_the_vector_env_is_the_single_env_bit_for_bit(env_id):
    env_cls, vec_cls = TASKS[env_id]
    kw = dict(n_discs=80, episode_steps=5)
    R, n = 3, 12  # two autoresets per reactor
    A = env_cls(**kw).action_space.shape[0]
    acts = np.random.default_rng(1).uniform(-1.1, 1.1, (n, R, A)).astype(np.float32)
    venv = vec_cls(num_envs=R, **kw)
    vo, _ = venv.reset(seed=20)
    traj = [venv.step(acts[k]) for k in range(n)]
    for i in range(R):
        env = env_cls(**kw)
        o, _ = env.reset(seed=20 + i)
        assert np.array_equal(o, vo[i])
        done = False
        for k in range(n):
            vobs, vrew, vterm, vtrunc, _ = traj[k]
            if done:
                o, _ = env.reset()
                assert np.array_equal(o, vobs[i]) and vrew[i] == 0.0
                done = False
                continue
            o, r, term, trunc, info = env.step(acts[k, i])
            assert np.array_equal(o, vobs[i]), (i, k)
            assert r == vrew[i] and trunc == vtrunc[i]
            vinfo = traj[k][4]
            for key, value in info.items():  # flat infos: the same values, reactor by reactor
                assert vinfo[f"_{key}"][i] and value == vinfo[key][i], (key, i, k)
            done = term or trunc
        sim, vsim = env.simulation, venv.simulations[i]
        assert np.array_equal(sim.positions, vsim.positions)
        assert np.array_equal(sim.velocities, vsim.velocities)
        assert sim.reactions() == vsim.reactions()
        assert sim.scene == vsim.scene  # the same drawn kinetics


def test_discreactor_v0_keeps_its_observation_and_defaults():
    env = gym.make("DiscReactor-v0")
    assert env.observation_space.shape == (19,)
    names = env.unwrapped.observation_names
    assert names[:4] == ("fraction_A", "fraction_B", "fraction_C", "fraction_W")
    assert names[-2:] == ("feed_left_A", "feed_left_B")
    cfg = env.unwrapped.config
    assert cfg.energy_bins == 0 and cfg.grid == 0 and not cfg.observe_reactions
    assert not cfg.uncertain
    assert env.unwrapped.simulation is None
    env.reset(seed=3)
    assert env.unwrapped.simulation.scene is cfg.scene  # no kinetics drawn, no new scene


def _observed(env, obs):
    """The optional blocks of ``obs`` recomputed with numpy from the env's simulation."""
    u = env.unwrapped
    cfg = u.config
    sim = u.simulation
    S = cfg.n_species
    m = sim.masses
    e = 0.5 * m * (sim.velocities ** 2).sum(axis=1)
    out = []
    B = cfg.energy_bins
    if B:
        b = np.searchsorted(cfg.energy_edges, e, side="right")
        for s in range(S):
            sel = sim.species == s
            h = np.bincount(b[sel], minlength=B) / max(sel.sum(), 1)
            out.append(h)
    G = cfg.grid
    if G:
        x0, y0, x1, y1 = sim.bounds.extent
        ci = np.clip(((sim.positions[:, 0] - x0) / (x1 - x0) * G).astype(int), 0, G - 1)
        cj = np.clip(((sim.positions[:, 1] - y0) / (y1 - y0) * G).astype(int), 0, G - 1)
        cell = cj * G + ci
        for s in range(S):
            sel = sim.species == s
            out.append(np.bincount(cell[sel], minlength=G * G) / max(sel.sum(), 1))
        cnt = np.bincount(cell, minlength=G * G)
        ke = np.bincount(cell, weights=e, minlength=G * G)
        out.append(np.where(cnt > 0, ke / np.maximum(cnt, 1), 0.0))
    return np.concatenate(out) if out else np.zeros(0)


def test_histogram_blocks_match_a_recomputation_from_the_state():
    env = gym.make("DiscReactor-v0", energy_bins=5, spatial_grid=3, size_range=(0.6, 1.0),
                   observe_reactions=True)
    cfg = env.unwrapped.config
    D0 = 19
    K = len(cfg.compiled.labels)
    assert env.observation_space.shape == (D0 + 4 * 5 + 5 * 9 + K,)
    assert list(cfg.energy_edges) == [1.0, 2.0, 4.0, 8.0]  # E1/4, E1/2, then the barriers
    obs, _ = env.reset(seed=5)
    rng = np.random.default_rng(0)
    sim = env.unwrapped.simulation
    for k in range(8):
        before = sim.reactions()
        n_ref = float(env.unwrapped.core.episodes.n_ref[0])
        a = np.array([1.0 if k < 3 else 0.0, rng.uniform(-1, 1), 1.0, 1.0], np.float32)
        obs, *_ = env.step(a)
        sim = env.unwrapped.simulation
        want = _observed(env, obs)
        got = obs[D0:D0 + len(want)]
        assert np.allclose(got, np.clip(want, 0.0, 20.0).astype(np.float32), atol=1e-6), k
        after = sim.reactions()
        fired = np.array([after[lab] - before.get(lab, 0) for lab in cfg.compiled.labels])
        assert np.allclose(obs[-K:], fired / n_ref, atol=1e-7)
        # per present species the energy shares sum to 1, and so do the cell shares
        for s in range(4):
            if np.count_nonzero(sim.species == s):
                assert math.isclose(obs[D0 + 5 * s:D0 + 5 * s + 5].sum(), 1.0, rel_tol=1e-5)
                c0 = D0 + 20 + 9 * s
                assert math.isclose(obs[c0:c0 + 9].sum(), 1.0, rel_tol=1e-5)
        assert env.observation_space.contains(obs)


def test_energy_edges_follow_the_barriers():
    sc = dg.scenes.load("reactor")  # activation energies 4 and 8
    assert energy_edges(sc, 0).shape == (0,)
    assert list(energy_edges(sc, 2)) == [4.0]
    assert list(energy_edges(sc, 3)) == [4.0, 8.0]
    assert list(energy_edges(sc, 6)) == [0.5, 1.0, 2.0, 4.0, 8.0]
    gas = dg.scenes.load("ideal_gas")  # no barrier: kT x 4 stands for one
    assert list(energy_edges(gas, 3)) == [2.0 * gas.temperature, 4.0 * gas.temperature]


def test_kinetics_are_drawn_per_episode_within_their_ranges_and_from_the_seed():
    env = gym.make("DiscKinetics-v0")
    cfg = env.unwrapped.config
    nominal = cfg.scene
    seen = []
    for seed in range(12):
        env.reset(seed=seed)
        sc = env.unwrapped.simulation.scene
        ea = [r.activation_energy for r in sc.reactions]
        scale = ea[0] / nominal.reactions[0].activation_energy
        assert 0.5 <= scale <= 1.5
        assert math.isclose(ea[1] / nominal.reactions[1].activation_energy, scale)
        rp = sc.reactions[0].reverse_probability / nominal.reactions[0].reverse_probability
        assert 10 ** -0.5 <= rp <= 10 ** 0.5
        for sp, sp0 in zip(sc.species, nominal.species):
            assert abs(sp.formation_energy - sp0.formation_energy) <= 0.3
            assert (sp.radius, sp.mass) == (sp0.radius, sp0.mass)
        # the compiled step reads this episode's tables
        u = env.unwrapped
        cs = dg.compiled.compile_scene(sc)
        assert np.array_equal(u.core.episodes.ch_energy[0], cs.ch_energy)
        assert np.array_equal(u.core.episodes.ch_rate[0], cs.ch_rate)
        assert np.array_equal(u.core.episodes.sp_form[0], cs.sp_form)
        seen.append(scale)
        env.reset(seed=seed)
        assert env.unwrapped.simulation.scene == sc  # the same seed, the same kinetics
    assert len(set(seen)) == len(seen)
    # the energy ledger holds with drawn formation energies
    env.reset(seed=1)
    for _ in range(10):
        env.step(np.array([0.5, -1.0, 1.0, 1.0], np.float32))
    sim = env.unwrapped.simulation
    assert abs(sim.energy_balance()) <= 1e-9 * max(1.0, abs(sim.total_energy()))


def test_unknown_keywords_of_a_task_get_pythons_wording():
    with pytest.raises(TypeError, match=r"DiscFlowEnv.__init__\(\) got an unexpected "
                                        r"keyword argument 'frameskip'"):
        gym.make("DiscFlow-v0", frameskip=1)
    for env_cls, _ in TASKS.values():
        assert set(env_cls.defaults) == set(DEFAULTS)


@pytest.mark.parametrize("env_id", IDS)
def test_each_task_has_a_hand_written_controller_that_copies_with_its_state(env_id):
    env = gym.make(env_id, **SHORT)
    ctl = controller_for(env)
    obs, _ = env.reset(seed=2)
    ctl.reset()
    for _ in range(3):
        a = ctl(obs)
        assert env.action_space.contains(a)
        obs, *_ = env.step(a)
    twin = copy.deepcopy(ctl)
    assert np.array_equal(twin(obs), ctl(obs))


def test_jacket_action_sets_the_thermal_walls_and_reports_their_heat():
    env = gym.make("DiscJacket-v0")
    u = env.unwrapped
    cfg = u.config
    names = u.observation_names
    obs, _ = env.reset(seed=1)
    sim = u.simulation
    assert obs[names.index("jacket_kT")] == np.float32(0.6)  # the scene's
    for a0, want in [(-1.0, cfg.t_min), (1.0, cfg.t_max),
                     (0.0, math.sqrt(cfg.t_min * cfg.t_max))]:
        heat0 = sim.wall_heat
        kin0 = sim.kinetic_energy()
        obs, r, _, _, info = env.step(np.array([a0, 0.0, 0.0, 0.0], np.float32))
        sim = u.simulation
        assert math.isclose(sim.wall_temperature["left"], want, rel_tol=1e-12)
        assert obs[names.index("jacket_kT")] == np.float32(sim.wall_temperature["left"])
        assert info["heat_energy"] == pytest.approx(sim.wall_heat - heat0, rel=1e-12, abs=1e-12)
        assert sim.energy_input == 0.0  # the velocities were never rescaled
        del kin0
    before = sim.wall_temperature["left"]
    env.step(np.array([np.nan, 0.0, 0.0, 0.0], np.float32))  # a NaN keeps the jacket
    assert u.simulation.wall_temperature["left"] == before
    sim = u.simulation
    assert abs(sim.energy_balance()) <= 1e-9 * max(1.0, abs(sim.total_energy()))


def test_flow_reward_is_the_product_leaving_and_the_inlet_temperature_switches():
    env = gym.make("DiscFlow-v0", episode_steps=40, max_episode_steps=40)
    u = env.unwrapped
    cfg = u.config
    names = u.observation_names
    obs, _ = env.reset(seed=4)
    sim = u.simulation
    ep = u.core.episodes
    kT0, kT1, switch = float(ep.feed_kT[0]), float(ep.feed_kT_next[0]), int(ep.feed_switch[0])
    assert 0.3 <= kT0 <= 2.0 and 0.3 <= kT1 <= 2.0 and 40 // 3 <= switch <= 2 * 40 // 3
    assert obs[names.index("feed_kT")] == np.float32(kT0)
    n_ref = float(u.core.episodes.n_ref[0])
    for k in range(40):
        out0 = sim.outflow()
        obs, r, _, trunc, info = env.step(np.array([0.3, 1.0, 1.0, 1.0], np.float32))
        sim = u.simulation
        out1 = sim.outflow()
        left = {s: out1[s] - out0.get(s, 0) for s in out1}
        injected = sum(v for key, v in info.items() if key.startswith("injected_"))
        want = left["C"] / n_ref - cfg.heat_cost * abs(info["heat_energy"]) / n_ref - \
            cfg.feed_cost * injected / n_ref
        assert r == pytest.approx(want, rel=1e-12, abs=1e-15)
        for nm in cfg.species_names:
            assert obs[names.index(f"outflow_{nm}")] == np.float32(min(left[nm] / n_ref, 4.0))
        kT = kT1 if k + 1 > switch else kT0  # (the change applies from step `switch` on)
        assert obs[names.index("feed_kT")] == np.float32(kT), k
    assert sum(sim.outflow().values()) > 0
    assert abs(sim.energy_balance()) <= 1e-9 * max(1.0, abs(sim.total_energy()))


def test_jacket_and_outflow_need_their_walls():
    with pytest.raises(ValueError, match="^heating"):
        gym.make("DiscReactor-v0", heating="jacket")
    with pytest.raises(ValueError, match="^reward"):
        gym.make("DiscReactor-v0", reward="outflow")
