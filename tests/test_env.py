"""DiscReactor-v0: registration, the checkers, determinism, actions, observations, rewards."""

import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import discgym as dg
from discgym.baselines import (
    HeuristicPolicy,
    constant_policy,
    heuristic_policy,
    random_policy,
)
from discgym.env import DEFAULTS, DiscReactorEnv

SHORT = dict(n_discs=80, episode_steps=12)  # small and short: fast tests



def _discs(info) -> int:
    """The discs in the reactor, from a (flat) info's ``count_<species>`` entries."""
    return sum(v for k, v in info.items() if k.startswith("count_"))


def run(env, actions, seed):
    obs, info = env.reset(seed=seed)
    out = [(obs, None, False, False, info)]
    for a in actions:
        out.append(env.step(a))
    return out


def assert_same(a, b):
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            assert_same(a[k], b[k])
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            assert_same(x, y)
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    else:
        assert a == b or (a != a and b != b)


# ------------------------------------------------------------------ registration


def test_make_after_import_and_spec_kwargs():
    env = gym.make("DiscReactor-v0", n_discs=60, episode_steps=5, heat_cost=0.1)
    assert env.spec.max_episode_steps == DEFAULTS["episode_steps"]
    assert env.spec.kwargs["n_discs"] == 60 and env.spec.kwargs["heat_cost"] == 0.1
    assert isinstance(env.unwrapped, DiscReactorEnv)
    env.reset(seed=0)
    for _ in range(5):
        *_, truncated, _ = env.step(env.action_space.sample())
    assert truncated  # the env's own episode_steps
    assert isinstance(env.unwrapped.simulation, dg.Simulation)
    env.close()


def test_make_with_module_prefix_in_a_fresh_process_without_torch():
    code = (
        "import sys, gymnasium\n"
        "env = gymnasium.make('discgym:DiscReactor-v0')\n"
        "assert type(env.unwrapped).__name__ == 'DiscReactorEnv'\n"
        "assert 'torch' not in sys.modules and 'stable_baselines3' not in sys.modules\n"
        "assert 'matplotlib' not in sys.modules\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


@pytest.mark.parametrize("scene_arg", ["name", "path", "scene"])
def test_scene_argument_forms(scene_arg, tmp_path):
    sc = dg.scenes.load("reactor")
    arg = {"name": "reactor", "scene": sc}.get(scene_arg)
    if scene_arg == "path":
        arg = tmp_path / "r.toml"
        arg.write_text(sc.to_toml())
        arg = str(arg)
    env = DiscReactorEnv(scene=arg, n_discs=50)
    obs, _ = env.reset(seed=1)
    assert env.observation_space.contains(obs)


@pytest.mark.parametrize("kw, match", [
    (dict(n_discs=0), "n_discs"),
    (dict(episode_steps=0), "episode_steps"),
    (dict(step_time=0.013), "step_time"),
    (dict(heat_rate=0.5), "heat_rate"),
    (dict(size_range=(1.2, 0.8)), "size_range"),
    (dict(feed=("A", "Q")), "feed"),
    (dict(product="Q"), "product"),
    (dict(feed_budget=[1, 2, 3]), "feed_budget"),
    (dict(heat_cost=-1), "heat_cost"),
    (dict(nonsense=1), "nonsense"),
    (dict(scene="ideal_gas"), "product"),
    (dict(scene="no_such_scene_file.toml"), "no_such_scene"),
])
def test_bad_arguments_are_named(kw, match):
    with pytest.raises((ValueError, TypeError, OSError), match=match):
        DiscReactorEnv(**kw)


def test_circular_reactor_wall_scales_the_radius():
    sc = dg.scenes.load("reactor").replace(bounds=dg.Circle(17.0, (0.0, 0.0)))
    env = DiscReactorEnv(scene=sc, n_discs=80, wall_speed=0.1)
    env.reset(seed=0)
    *_, info = env.step(np.array([0, -1, 0, 0], np.float32))
    assert info["size"] == pytest.approx(0.9)
    assert env.simulation.bounds.radius == pytest.approx(0.9 * 17.0)
    assert env.simulation.outside() == 0 and env.simulation.overlaps() == 0


# ------------------------------------------------------------------ the checkers


def test_gymnasium_env_checker_without_warnings():
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make("DiscReactor-v0", render_mode="rgb_array", render_size=120, **SHORT)
        # (the render check also makes the env with render_mode="human": headless here)
        check_env(env.unwrapped, skip_render_check=False)


def test_gymnasium_checker_through_make_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make("DiscReactor-v0", render_mode="rgb_array", render_size=120, **SHORT)
        env.reset(seed=0)
        for _ in range(3):
            env.step(env.action_space.sample())
        env.render()


def test_sb3_env_checker_without_warnings():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_checker import check_env

    env = DiscReactorEnv(**SHORT)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env, warn=True)


# ------------------------------------------------------------------ determinism, copies


def test_same_seed_same_episode_and_seeds_differ():
    acts = np.random.default_rng(0).uniform(-1, 1, (12, 4)).astype(np.float32)
    e1, e2 = DiscReactorEnv(**SHORT), DiscReactorEnv(**SHORT)
    assert_same(run(e1, acts, 7), run(e2, acts, 7))
    # a reset without a seed continues the generator: same on both
    assert_same(run(e1, acts, None), run(e2, acts, None))
    o1, i1 = e1.reset(seed=1)
    o2, i2 = e1.reset(seed=2)
    assert not np.array_equal(o1, o2)


def test_reset_draws_contents_within_ranges():
    env = DiscReactorEnv()
    cfg = env.config
    seen = set()
    for seed in range(8):
        _, info = env.reset(seed=seed)
        for nm, t in zip(env.config.scene.species_names, cfg.template):
            lo, hi = t * (1 - cfg.count_jitter), t * (1 + cfg.count_jitter)
            assert lo - 1 <= info[f"count_{nm}"] <= hi + 1
        T0 = cfg.scene.temperature
        assert T0 * (1 - cfg.temperature_jitter) * 0.999 <= info["temperature"] \
            <= T0 * (1 + cfg.temperature_jitter) * 1.001
        seen.add((info["count_A"], info["count_B"]))
    assert len(seen) > 4


def test_pickle_continues_identically():
    env = DiscReactorEnv(**SHORT)
    env.reset(seed=3)
    acts = np.random.default_rng(1).uniform(-1, 1, (6, 4)).astype(np.float32)
    for a in acts[:3]:
        env.step(a)
    clone = pickle.loads(pickle.dumps(env))
    for a in acts[3:]:
        assert_same(env.step(a), clone.step(a))


def test_observations_are_fresh_copies():
    env, twin = DiscReactorEnv(**SHORT), DiscReactorEnv(**SHORT)
    o0, _ = env.reset(seed=0)
    twin.reset(seed=0)
    o1, *_ = env.step(np.zeros(4, np.float32))
    twin.step(np.zeros(4, np.float32))
    o2, *_ = env.step(np.zeros(4, np.float32))
    twin.step(np.zeros(4, np.float32))
    assert not np.shares_memory(o0, o1) and not np.shares_memory(o1, o2)
    assert o1 is not o2
    for o in (o0, o1, o2):
        o[:] = 123.0  # scribbling on observations changes nothing in the env
    o3, *_ = env.step(np.zeros(4, np.float32))
    t3, *_ = twin.step(np.zeros(4, np.float32))
    assert np.array_equal(o3, t3)


# ------------------------------------------------------------------ actions


def test_nan_and_inf_actions_are_ignored_and_reported():
    env = DiscReactorEnv(**SHORT)
    env.reset(seed=0)
    size0 = env.unwrapped.core.episodes.size
    obs, r, term, trunc, info = env.step(np.array([np.nan, np.inf, -np.inf, np.nan],
                                                  np.float32))
    assert info["invalid_action"] == 4
    assert info["heat_energy"] == 0.0 and info["size"] == size0
    assert info["injected_A"] + info["injected_B"] == 0
    sim = env.simulation
    assert np.isfinite(sim.positions).all() and np.isfinite(sim.velocities).all()
    assert sim.overlaps() == 0 and sim.outside() == 0
    assert np.isfinite(obs).all() and np.isfinite(r)
    # a NaN heat is the same as heat 0 (the rest of the action still applies)
    e1, e2 = DiscReactorEnv(**SHORT), DiscReactorEnv(**SHORT)
    e1.reset(seed=5)
    e2.reset(seed=5)
    a = np.array([np.nan, -0.5, 1.0, 0.0], np.float32)
    b = np.array([0.0, -0.5, 1.0, 0.0], np.float32)
    s1, s2 = e1.step(a), e2.step(b)
    assert s1[4]["invalid_action"] == 1 and s2[4]["invalid_action"] == 0
    assert np.array_equal(s1[0], s2[0])


def test_wrong_action_shape_is_an_error():
    env = DiscReactorEnv(**SHORT)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.zeros(3, np.float32))


def test_heat_and_cool_scale_the_temperature_within_limits():
    env = DiscReactorEnv(**SHORT, heat_rate=2.0, temperature_range=(0.5, 1.5))
    env.reset(seed=0)
    sim = env.simulation
    ke = sim.kinetic_energy()
    # heat +1 doubles the kinetic energy (up to t_max = 1.5); the energy added is booked
    factor = min(2.0, 1.5 / (ke / len(sim)))
    *_, info = env.step(np.array([1, 0, 0, 0], np.float32))
    assert info["heat_energy"] == pytest.approx(ke * (factor - 1), rel=1e-9)
    assert sim.energy_input == pytest.approx(info["heat_energy"], rel=1e-9)
    # ... and never beyond the temperature range
    for _ in range(4):
        env.step(np.array([1, 0, 0, 0], np.float32))
        assert sim.temperature() <= 1.5 * 1.3  # the reaction heat may add a little
    for _ in range(4):
        *_, info = env.step(np.array([-1, 0, 0, 0], np.float32))
        assert info["heat_energy"] <= 0.0
    assert sim.temperature() == pytest.approx(0.5, rel=0.3)


def test_wall_moves_at_wall_speed_within_limits():
    env = DiscReactorEnv(**SHORT, size_range=(0.7, 1.3), wall_speed=0.1)
    env.reset(seed=0)
    sizes = []
    for _ in range(5):
        *_, info = env.step(np.array([0, -1, 0, 0], np.float32))
        sizes.append(info["size"])
    assert np.allclose(sizes, [0.9, 0.8, 0.7, 0.7, 0.7])
    assert env.simulation.bounds.width == pytest.approx(0.7 * 30.0)
    assert env.simulation.overlaps() == 0 and env.simulation.outside() == 0
    obs, *_ = env.step(np.array([0, 1, 0, 0], np.float32))
    assert obs[env.unwrapped.observation_names.index("size")] == pytest.approx(0.8)


def test_wall_refused_when_the_discs_do_not_fit():
    # 560 discs in 30 x 30: a box half as wide cannot hold them
    env = DiscReactorEnv(n_discs=560, count_jitter=0.0, size_range=(0.5, 1.0),
                         wall_speed=0.5, episode_steps=3)
    env.reset(seed=0)
    before = env.simulation.get_state()
    *_, info = env.step(np.array([0, -1, 0, 0], np.float32))
    assert info["wall_blocked"] and info["size"] == 1.0
    assert env.simulation.bounds == before["bounds"]
    assert env.simulation.overlaps() == 0 and env.simulation.outside() == 0


def test_injection_rate_budget_and_report():
    env = DiscReactorEnv(**SHORT, inject_max=3, feed_budget=[5, 0])
    _, info0 = env.reset(seed=0)
    n0 = _discs(info0)
    *_, info = env.step(np.array([0, 0, 1, 1], np.float32))
    assert (info["injected_A"], info["injected_B"]) == (3, 0)
    assert (info["inject_refused_A"], info["inject_refused_B"]) == (0, 3)
    *_, info = env.step(np.array([0, 0, 1, 0], np.float32))
    assert info["injected_A"] == 2  # the budget of 5 is spent
    *_, info = env.step(np.array([0, 0, 0.1, 0], np.float32))  # round(0.3) = 0
    assert info["injected_A"] == 0 and info["inject_refused_A"] == 0
    assert len(env.simulation) <= n0 + 5


def _same_state(a, b):
    sa, sb = a.get_state(), b.get_state()
    assert sa.keys() == sb.keys()
    for k in sa:
        if isinstance(sa[k], np.ndarray):
            assert np.array_equal(sa[k], sb[k]), k
        else:
            assert sa[k] == sb[k], k


def test_the_compiled_step_is_the_simulation_controls_bit_for_bit():
    """One compiled call per env step (kernels.batch.env_step) does exactly what the
    Simulation methods do: scale_temperature, resize (pushing discs in), inject, step; same
    state, same generator state, same energy bookkeeping, to the last bit."""
    import copy

    pushed = 0
    for seed in range(3):
        pushed += _compare_with_the_simulation_methods(seed, copy)
    assert pushed >= 4  # the relocation path ran


def _compare_with_the_simulation_methods(seed, copy):
    env = DiscReactorEnv(n_discs=300, episode_steps=40, feed_budget=[200, 200],
                         wall_speed=0.2)
    env.reset(seed=seed)
    cfg, sim = env.config, env.simulation
    rng = np.random.default_rng(5 + seed)
    pushed = 0
    for k in range(24):
        a = rng.uniform(-1, 1, 4).astype(np.float32)
        if k % 4 == 0:
            a[1] = -1.0  # shrink: discs near the wall must be pushed in
        twin = copy.deepcopy(sim)
        T = env.core.episodes.temperature[0]
        *_, info = env.step(a)
        x = a.tolist()  # the float32 values, as float64
        twin.scale_temperature(min(max(cfg.heat_rate ** x[0], min(1.0, cfg.t_min / T)),
                                   max(1.0, cfg.t_max / T)))
        new = cfg.bounds_of(info["size"])
        if new != twin.bounds:
            before = twin.positions
            twin.resize(new)
            pushed += int((twin.positions != before).any())
        for j, f in enumerate(cfg.feed):
            want = int(round(max(x[2 + j], 0.0) * cfg.inject_max))
            if want:
                assert twin.inject(f, want) == info[f"injected_{cfg.species_names[f]}"]
        twin.step(cfg.steps_per_action)
        _same_state(sim, twin)
        assert sim.bounds == twin.bounds and sim.time == twin.time
    return pushed


def test_heating_stops_at_the_speed_limit():
    """Simulation.scale_temperature refuses a factor that would push a disc past the speed
    limit; the env's heat control instead heats only up to it (documented)."""
    dt = dg.scenes.load("reactor").dt
    env = DiscReactorEnv(n_discs=4, count_jitter=0.0, temperature_range=(0.2, 1e30),
                         step_time=dt, episode_steps=3)
    env.reset(seed=0)
    sim = env.simulation
    st = sim.get_state()
    st["velocities"][:] = 0.0
    st["velocities"][0] = (0.8 * sim.speed_limit, 0.0)
    sim.set_state(st)
    env.unwrapped.core.observe()  # (the heat control reads the last observation's kT)
    with pytest.raises(ValueError, match="speed limit"):
        copy_ = pickle.loads(pickle.dumps(sim))
        copy_.scale_temperature(2.0)
    ke = sim.kinetic_energy()
    *_, info = env.step(np.array([1, 0, 0, 0], np.float32))
    speeds = np.hypot(*sim.velocities.T)
    assert speeds.max() <= sim.speed_limit
    assert speeds.max() == pytest.approx(sim.speed_limit, rel=1e-9)
    # the energy put in: the factor that was applied, (limit / 0.8 limit)^2 = 1.5625
    assert info["heat_energy"] == pytest.approx(0.5625 * ke, rel=1e-9)
    assert sim.energy_input == pytest.approx(info["heat_energy"], rel=1e-9)


def test_injections_that_would_pass_the_speed_limit_are_refused():
    """kT so high that Maxwell-Boltzmann draws can pass the speed limit: such an injection
    is refused whole (counted in inject_refused), exactly when Simulation.inject refuses it
    (with ValueError)."""
    import copy

    # no reactions (their heat could change kT), two discs, one step
    scene = dg.Scene(bounds=dg.Box(30.0, 30.0),
                     species=[dg.Species("A", radius=0.5, mass=1.0),
                              dg.Species("B", radius=0.5, mass=1.0)],
                     counts={"A": 1, "B": 1})
    refused = 0
    for seed in range(8):
        env = DiscReactorEnv(scene=scene, feed=("A",), product="B", count_jitter=0.0,
                             temperature_range=(0.2, 1e30), step_time=scene.dt,
                             episode_steps=3, feed_budget=[50])
        env.reset(seed=seed)
        sim = env.simulation
        st = sim.get_state()
        st["velocities"][:] = (0.0, 0.95 * sim.speed_limit)
        sim.set_state(st)
        env.unwrapped.core.observe()
        twin = copy.deepcopy(sim)
        try:
            twin.inject("A", 4)
            expect = 0
        except ValueError as exc:
            assert "speed limit" in str(exc)
            expect = 4
        e0 = sim.total_energy()
        *_, info = env.step(np.array([0, 0, 1], np.float32))
        assert info["inject_refused_A"] == expect
        assert info["injected_A"] == 4 - expect
        if expect:  # refused: nothing was added
            assert sim.energy_input == 0.0 and len(sim) == 2
            assert sim.total_energy() == pytest.approx(e0, rel=1e-9)
        refused += expect > 0
    assert 0 < refused < 8  # both outcomes occurred


def test_discs_added_from_outside_get_room_in_the_arrays():
    """The compiled step never grows the arrays: a user who adds many discs between steps
    (beyond the env's capacity plan) gets them made room for, not an error."""
    env = DiscReactorEnv()
    env.reset(seed=0)
    sim = env.simulation
    cap = len(sim._species)
    assert sim.inject("C", 150) == 150  # C = A + B: each may split in two
    assert len(sim._species) == cap  # (no reallocation by inject itself)
    for _ in range(5):
        *_, info = env.step(np.zeros(4, np.float32))
    assert _discs(info) == len(sim)
    assert sim.overlaps() == 0 and abs(sim.energy_balance()) < 1e-9 * abs(sim.total_energy())


def test_the_simulation_may_be_changed_between_steps():
    """``env.unwrapped.simulation`` is the live reactor: what a user does to it between steps
    (inject, resize, set_state with fewer discs) is what the next step starts from."""
    env = DiscReactorEnv(**SHORT)
    env.reset(seed=2)
    sim = env.simulation
    env.step(np.zeros(4, np.float32))
    assert sim.inject("A", 7) == 7
    n = len(sim)
    *_, info = env.step(np.zeros(4, np.float32))
    assert _discs(info) == n == len(sim)
    sim.resize(dg.Box(28.0, 30.0))
    *_, info = env.step(np.array([0, np.nan, 0, 0], np.float32))  # (the wall stays)
    assert sim.bounds == dg.Box(28.0, 30.0) and sim.outside() == 0 and sim.overlaps() == 0
    assert info["size"] == 28.0 / 30.0  # the wall's size is the reactor's
    st = sim.get_state()
    for key in ("positions", "velocities", "species", "internal_energy", "ids"):
        st[key] = st[key][:20]
    sim.set_state(st)
    *_, info = env.step(np.zeros(4, np.float32))
    assert _discs(info) == len(sim) <= 20
    assert sim.overlaps() == 0 and sim.outside() == 0


# ------------------------------------------------------------------ observations, rewards


def test_observation_slots():
    env = DiscReactorEnv(**SHORT)
    names = env.observation_names
    obs, info = env.reset(seed=4)
    S = 4
    assert obs[:S].sum() == pytest.approx(1.0, abs=1e-6)
    assert obs[names.index("time_left")] == 1.0
    assert obs[names.index("size")] == 1.0
    assert obs[names.index("discs")] == 1.0
    sim = env.simulation
    T = obs[:S] @ obs[S:2 * S]
    assert T == pytest.approx(sim.temperature(), rel=1e-5)
    tl = [obs[names.index("time_left")]]
    for _ in range(SHORT["episode_steps"]):
        obs, *_ = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
        tl.append(obs[names.index("time_left")])
    assert tl[-1] == 0.0 and np.all(np.diff(tl) < 0)


def test_observations_are_clipped_to_the_bounds():
    env = DiscReactorEnv(**SHORT, temperature_range=(0.5, 40.0), heat_rate=8.0)
    env.reset(seed=0)
    for _ in range(4):
        obs, *_ = env.step(np.array([1, 0, 0, 0], np.float32))
    assert env.simulation.temperature() > 20.0
    assert env.observation_space.contains(obs)


def test_rewards_add_up_to_the_yield_and_costs_are_booked():
    env = DiscReactorEnv(**SHORT, heat_cost=0.01, feed_cost=0.5)
    _, info0 = env.reset(seed=2)
    p0 = info0["count_C"]
    total = 0.0
    rng = np.random.default_rng(0)
    for _ in range(SHORT["episode_steps"]):
        _, r, _, _, info = env.step(rng.uniform(-1, 1, 4).astype(np.float32))
        assert isinstance(r, float)
        assert r == pytest.approx(info["reward_product"] - info["cost_heat"] - info["cost_feed"])
        assert info["cost_heat"] == pytest.approx(0.01 * abs(info["heat_energy"]) / info0["n_ref"])
        assert info["cost_feed"] == pytest.approx(0.5 * (info["injected_A"] + info["injected_B"])
                                                  / info0["n_ref"])
        total += info["reward_product"]
    assert total == pytest.approx((info["count_C"] - p0) / info0["n_ref"])
    assert info["yield"] == pytest.approx(info["count_C"] / info0["n_ref"])


# ------------------------------------------------------------------ rendering


def test_render_rgb_array_and_metadata():
    env = gym.make("DiscReactor-v0", render_mode="rgb_array", render_size=160, **SHORT)
    assert env.metadata["render_fps"] > 0
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (160, 160, 3) and frame.dtype == np.uint8
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 4  # discs in several colours


def test_render_human_needs_matplotlib(monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(gym.error.DependencyNotInstalled, match="discgym\\[render\\]"):
        DiscReactorEnv(render_mode="human")


def test_bad_render_mode():
    with pytest.raises(ValueError, match="render_mode"):
        DiscReactorEnv(render_mode="ascii")


# ------------------------------------------------------------------ baselines


def test_baseline_policies_give_valid_actions():
    env = DiscReactorEnv(**SHORT)
    obs, _ = env.reset(seed=0)
    for pol in (heuristic_policy, HeuristicPolicy(env.observation_names),
                constant_policy([0.1, -1, 1, 0]), random_policy(4, seed=0)):
        a = pol(obs)
        assert env.action_space.contains(a)
        batch = pol(np.stack([obs, obs]))
        assert batch.shape == (2, 4)
