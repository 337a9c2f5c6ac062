"""The environments with ``integrator="event"``: each env step's physics is one exact
event-driven run of ``step_time`` inside the compiled batch step. A reactor of the vector
env is the single env bit for bit (every task, autoresets, any ``threads``); the env is a
``Simulation(integrator="event")`` driven by the same controls; determinism, copies,
pickling, the checkers and the argument's errors. Small reactors and few steps: the
compiled step is shared with every other env test."""

import copy
import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest

import discgym as dg
from discgym.env import DEFAULTS, DiscReactorEnv
from discgym.tasks import TASKS
from discgym.vector import DiscReactorVectorEnv

IDS = sorted(TASKS)
KW = dict(n_discs=80, episode_steps=5, integrator="event")


def _acts(n, R, A, seed=1):
    return np.random.default_rng(seed).uniform(-1.1, 1.1, (n, R, A)).astype(np.float32)


def test_the_default_stays_the_stepped_integrator():
    assert DEFAULTS["integrator"] == "step"
    for env_cls, _ in TASKS.values():
        assert env_cls.defaults["integrator"] == "step"
    env = DiscReactorEnv(n_discs=40)
    env.reset(seed=0)
    assert env.config.integrator == "step" and env.simulation.integrator == "step"


@pytest.mark.parametrize("env_id", IDS)
def test_a_reactor_of_the_vector_env_is_the_single_env_bit_for_bit(env_id):
    env_cls, vec_cls = TASKS[env_id]
    R, n = 3, 12  # episodes of 5 steps: two autoresets (NextStep) per reactor
    A = env_cls(**KW).action_space.shape[0]
    acts = _acts(n, R, A)
    acts[2, 0, 0] = np.nan  # an invalid component somewhere
    # one thread for one task, numba's setting (parallel over the reactors) for the others
    venv = vec_cls(num_envs=R, threads=1 if env_id == "DiscJacket-v0" else None, **KW)
    vo, _ = venv.reset(seed=30)
    traj = [venv.step(acts[k]) for k in range(n)]
    for i in range(R):
        env = env_cls(**KW)
        o, _ = env.reset(seed=30 + i)
        assert env.simulation.integrator == "event"
        assert np.array_equal(o, vo[i])
        done = False
        for k in range(n):
            vobs, vrew, vterm, vtrunc, vinfo = traj[k]
            if done:
                o, _ = env.reset()
                assert np.array_equal(o, vobs[i]) and vrew[i] == 0.0
                done = False
                continue
            o, r, term, trunc, info = env.step(acts[k, i])
            assert np.array_equal(o, vobs[i]), (i, k)
            assert r == vrew[i] and trunc == vtrunc[i]
            for key, value in info.items():
                assert vinfo[f"_{key}"][i] and value == vinfo[key][i], (key, i, k)
            done = term or trunc
        sim, vsim = env.simulation, venv.simulations[i]
        assert vsim.integrator == "event"
        assert np.array_equal(sim.positions, vsim.positions)
        assert np.array_equal(sim.velocities, vsim.velocities)
        assert np.array_equal(sim.ids, vsim.ids)
        assert sim.counters() == vsim.counters() and sim.reactions() == vsim.reactions()
        assert sim.outflow() == vsim.outflow() and sim.wall_heat == vsim.wall_heat
        assert sim.bounds == vsim.bounds and sim.time == vsim.time


def test_the_vector_env_gives_the_same_bits_for_any_threads():
    R, n = 4, 6
    acts = _acts(n, R, 4, seed=3)
    runs = []
    for threads in (1, 2):
        venv = DiscReactorVectorEnv(num_envs=R, threads=threads, **KW)
        venv.reset(seed=7)
        runs.append([venv.step(acts[k])[:2] for k in range(n)])
    for (o1, r1), (o2, r2) in zip(*runs):
        assert np.array_equal(o1, o2) and np.array_equal(r1, r2)


def _same_state(a, b):
    sa, sb = a.get_state(), b.get_state()
    assert sa.keys() == sb.keys()
    for k in sa:
        if isinstance(sa[k], np.ndarray):
            assert np.array_equal(sa[k], sb[k]), k
        else:
            assert sa[k] == sb[k], k


@pytest.mark.parametrize("env_id, seed", [("DiscReactor-v0", 0), ("DiscReactor-v0", 1),
                                          ("DiscJacket-v0", 0), ("DiscFlow-v0", 0),
                                          ("DiscKinetics-v0", 0)])
def test_the_env_step_is_the_event_driven_simulation_under_the_same_controls(env_id, seed):
    """Each env step does exactly what the Simulation's controls (scale_temperature or the
    jacket's wall temperature, resize, inject) and ``step(steps_per_action)`` of a
    ``Simulation(integrator="event")`` do: the same state, counters, generator and energy
    ledger, to the last bit; wall moves (discs pushed in), injections, thermal walls,
    outlets and drawn kinetics included."""
    # (few discs: a wall move refused for want of room has drawn from the generator, which
    # compiled code cannot put back, so the Simulation could not follow it)
    env = TASKS[env_id][0](n_discs=60, episode_steps=30, feed_budget=200, wall_speed=0.2,
                           integrator="event")
    env.reset(seed=seed)
    cfg, sim = env.config, env.simulation
    names = cfg.species_names
    rng = np.random.default_rng(10 + seed)
    moved = pushed = out = 0
    for k in range(16):
        a = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        if k % 4 == 0:
            a[1] = -1.0  # shrink: discs near the wall must be pushed in
        twin = copy.deepcopy(sim)
        T = env.unwrapped.core.episodes.temperature[0]
        *_, info = env.step(a)
        assert not info["wall_blocked"]
        x = a.tolist()  # the float32 values, as float64
        if cfg.heating == "scale":
            twin.scale_temperature(min(max(cfg.heat_rate ** x[0], min(1.0, cfg.t_min / T)),
                                       max(1.0, cfg.t_max / T)))
        else:  # the jacket: a setting (no draw); its value is the env's
            twin.set_wall_temperature(sim.wall_temperature)
        new = cfg.bounds_of(info["size"])
        if new != twin.bounds:
            before = twin.positions
            twin.resize(new)
            moved += 1
            pushed += int((twin.positions != before).any())
        feed_kT = float(env.unwrapped.core.episodes.feed_kT[0])
        for j, f in enumerate(cfg.feed):
            want = int(round(max(x[2 + j], 0.0) * cfg.inject_max))
            if want:
                got = twin.inject(f, want, temperature=None if math.isnan(feed_kT) else feed_kT)
                assert got == info[f"injected_{names[f]}"]
        twin.step(cfg.steps_per_action)
        _same_state(sim, twin)
        assert sim.bounds == twin.bounds and sim.time == twin.time
        assert twin.integrator == "event"
        out += sum(sim.outflow().values())
    assert moved >= 4 and pushed >= 1  # the wall moved and pushed discs in
    if env_id == "DiscFlow-v0":
        assert out > 0  # discs left through the outlets
    if env_id == "DiscJacket-v0":
        assert sim.wall_heat != 0.0  # the thermal wall exchanged heat
    assert abs(sim.energy_balance()) < 1e-9 * max(abs(sim.total_energy()), 1.0)


def test_same_seed_same_trajectory_and_copies_continue_bit_for_bit():
    """Determinism: the same seed and actions give the same bits; a clone, a pickle and a
    restored state (get_state / set_state) continue as the original does."""
    kw = dict(KW, episode_steps=20)
    acts = _acts(12, 1, 4, seed=5)[:, 0]

    def run(env, lo, hi):
        return [env.step(acts[k])[:2] for k in range(lo, hi)]

    a, b = DiscReactorEnv(**kw), DiscReactorEnv(**kw)
    a.reset(seed=3)
    b.reset(seed=3)
    ra, rb = run(a, 0, 6), run(b, 0, 6)
    assert all(np.array_equal(x[0], y[0]) and x[1] == y[1] for x, y in zip(ra, rb))
    clone = a.clone()
    pickled = pickle.loads(pickle.dumps(a))
    assert clone.simulation.integrator == pickled.simulation.integrator == "event"
    restored = DiscReactorEnv(**kw)
    restored.reset(seed=99)
    state = a.simulation.get_state()
    assert state["integrator"] == "event"
    rest = run(a, 6, 12)
    for other in (clone, pickled, b):
        assert all(np.array_equal(x[0], y[0]) and x[1] == y[1]
                   for x, y in zip(rest, run(other, 6, 12)))
    # a Simulation's restored state continues as the original did (the env's own
    # bookkeeping, e.g. the steps left, is not the Simulation's: compare the physics)
    sim = a.simulation.copy()
    sim.set_state(state)
    twin = dg.Simulation("reactor", counts={"A": 1}, seed=0, integrator="event")
    twin.set_state(state)
    sim.step(3)
    twin.step(3)
    _same_state(sim, twin)


@pytest.mark.parametrize("env_id", IDS)
def test_both_checkers_pass_with_the_event_integrator(env_id):
    from gymnasium.utils.env_checker import check_env

    short = dict(n_discs=60, episode_steps=4, max_episode_steps=4, integrator="event")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id, **short).unwrapped, skip_render_check=True)
    # (SB3's checker with the agents extra; gymnasium's above runs without it)
    sb3_check = pytest.importorskip("stable_baselines3.common.env_checker").check_env
    sb3_check(gym.make(env_id, **short), warn=True)


def test_the_sb3_adapter_takes_the_integrator():
    pytest.importorskip("stable_baselines3")
    from discgym.sb3 import DiscReactorSB3VecEnv

    sb = DiscReactorSB3VecEnv(num_envs=2, n_discs=60, episode_steps=3, integrator="event")
    venv = DiscReactorVectorEnv(num_envs=2, n_discs=60, episode_steps=3,
                                   integrator="event", autoreset_mode="SameStep")
    sb.seed(4)
    o = sb.reset()
    vo, _ = venv.reset(seed=4)
    assert np.array_equal(o, vo)
    assert all(s.integrator == "event" for s in sb.venv.simulations)
    acts = _acts(4, 2, 4, seed=6)
    for k in range(4):  # an autoreset at the third step
        sb.step_async(acts[k])
        o, rew, dones, infos = sb.step_wait()
        vo, vrew, *_ = venv.step(acts[k])
        assert np.array_equal(o, vo) and np.array_equal(rew, vrew.astype(np.float32))


@pytest.mark.parametrize("value, exc", [(None, TypeError), (1, TypeError),
                                        ("exact", ValueError), ("Event", ValueError)])
def test_a_bad_integrator_is_refused_naming_it(value, exc):
    for build in (lambda: DiscReactorEnv(integrator=value),
                  lambda: DiscReactorVectorEnv(num_envs=2, integrator=value),
                  lambda: gym.make("DiscFlow-v0", integrator=value)):
        with pytest.raises(exc, match=r"^integrator: expected one of \['step', 'event'\]"):
            build()


def _channel(width):
    """A box of ``width`` x 10 with three discs of radius 0.5."""
    return dg.Scene(bounds=dg.Box(width, 10.0), species=[dg.Species("A", 0.5, 1.0)],
                    counts={"A": 3}, dt=0.05)


def test_wall_moves_the_event_integrator_refuses_are_refused_at_construction():
    """The event integrator refuses bounds leaving a species less than 1e-3 of its radius
    of free room. The env checks the narrowest bounds the wall can reach (size_range's low
    end) at construction, with the stepped integrator's rules otherwise unchanged; within
    an accepted range every wall move runs, the narrowest included."""
    kw = dict(scene=_channel(10.0), feed="A", product="A", count_jitter=0.0, wall_speed=1.0,
              episode_steps=6)
    # width 10 x 0.1 = 1.0: exactly one diameter
    DiscReactorEnv(size_range=(0.1, 1.0), **kw)  # (the stepped integrator holds it)
    with pytest.raises(ValueError, match=r"^size_range: with integrator='event' the reactor "
                                         r"at size 0\.1 .*species 'A'"):
        DiscReactorEnv(size_range=(0.1, 1.0), integrator="event", **kw)
    with pytest.raises(ValueError, match=r"^size_range: with integrator='event'"):
        DiscReactorVectorEnv(num_envs=2, size_range=(0.1, 1.0), integrator="event", **kw)
    # the scene's own bounds: refused naming the integrator
    with pytest.raises(ValueError, match=r"^integrator: 'event' cannot run the scene's bounds"):
        DiscReactorEnv(**dict(kw, scene=_channel(1.0)), size_range=(1.0, 2.0),
                       integrator="event")
    # 2e-3 radii of room at the low end: accepted, and the wall gets there and runs
    env = DiscReactorEnv(size_range=(0.1001, 1.0), integrator="event", **kw)
    env.reset(seed=0)
    for _ in range(3):
        *_, info = env.step(np.array([0.0, -1.0, 0.0], np.float32))
    assert info["size"] == 0.1001 and not info["wall_blocked"]
    assert env.simulation.bounds.width == pytest.approx(1.001)
    assert len(env.simulation) == 3 and env.simulation.outside() == 0


def test_a_simulation_set_to_another_integrator_is_refused_at_the_next_step():
    """The compiled step runs the env's integrator: a Simulation switched to the other one
    by set_state would no longer describe its own trajectory, so the next step raises
    (nothing stepped); a state of the env's integrator steps on."""
    a = np.zeros(4, np.float32)
    for made, other in (("event", "step"), ("step", "event")):
        env = DiscReactorEnv(n_discs=40, integrator=made)
        env.reset(seed=0)
        st = env.simulation.get_state()
        env.simulation.set_state(dict(st, integrator=other))
        t = env.simulation.time
        with pytest.raises(RuntimeError, match=f"^integrator: its Simulation now has "
                                               f"integrator '{other}'.*integrator='{made}'"):
            env.step(a)
        assert env.simulation.time == t
        env.simulation.set_state(st)
        env.step(a)
    venv = DiscReactorVectorEnv(num_envs=2, n_discs=40, integrator="event")
    venv.reset(seed=0)
    sim = venv.simulations[1]
    sim.set_state(dict(sim.get_state(), integrator="step"))
    with pytest.raises(RuntimeError, match="^integrator: reactor 1's Simulation now has "
                                           "integrator 'step'"):
        venv.step(np.zeros((2, 4)))


def test_a_decomposing_scene_stays_within_the_planned_capacity():
    """Fissions (AB -> A + B, which doubles the discs) in the event-driven runs of the
    compiled step: within the capacity plan, the vector env still the single env."""
    kw = dict(scene="decomposition", product="A", feed=["AB"], n_discs=60, inject_max=5,
              feed_budget=20, episode_steps=30, integrator="event")
    venv = DiscReactorVectorEnv(num_envs=2, **kw)
    venv.reset(seed=0)
    a = np.tile(np.array([1.0, 0.0, 1.0], np.float32), (2, 1))
    for _ in range(30):
        obs, rew, term, trunc, info = venv.step(a)
    assert (info["count_A"] > 60).all()  # most AB decomposed (and the fed AB too)
    cap = venv.config.capacity
    for sim in venv.simulations:
        assert sim._pos.shape[0] == cap
        assert sim.overlaps() == 0 and sim.outside() == 0
    env = DiscReactorEnv(**kw)
    env.reset(seed=0)
    for _ in range(30):
        o, *_ = env.step(a[0])
    assert np.array_equal(o, obs[0])
    assert np.array_equal(env.simulation.positions, venv.simulations[0].positions)


