"""The batched env: bit-identical to the single env, autoreset modes, make_vec, the SB3 adapter."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import discgym as dg
from discgym.env import DiscReactorEnv
from discgym.vector import DiscReactorVectorEnv

KW = dict(n_discs=80, episode_steps=6)


def actions(n, R, seed=0):
    a = np.random.default_rng(seed).uniform(-1.1, 1.1, (n, R, 4)).astype(np.float32)
    a[2, 0, 0] = np.nan  # an invalid component somewhere
    a[4, -1, 1] = np.inf
    return a


def test_each_reactor_follows_the_single_env_bit_for_bit_across_autoresets():
    R, n = 3, 14  # episodes of 6 steps: two autoresets (NextStep) per reactor
    acts = actions(n, R)
    venv = DiscReactorVectorEnv(num_envs=R, **KW)
    assert venv.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    vo, vinfo0 = venv.reset(seed=10)
    traj = [venv.step(acts[k]) for k in range(n)]
    for i in range(R):
        env = DiscReactorEnv(**KW)
        o, info0 = env.reset(seed=10 + i)
        assert np.array_equal(o, vo[i])
        # reset: the step's keys too, as arrays with masks (as SyncVectorEnv gives them)
        assert set(vinfo0) == {k for key in info0 for k in (key, f"_{key}")}
        assert all(v == vinfo0[key][i] and vinfo0[f"_{key}"][i] for key, v in info0.items())
        done = False
        for k in range(n):
            vobs, vrew, vterm, vtrunc, vinfo = traj[k]
            if done:  # NextStep: this step resets the reactor, its action is ignored
                o, info = env.reset()
                assert np.array_equal(o, vobs[i]) and vrew[i] == 0.0
                # its reset's info (as Gymnasium's SyncVectorEnv reports it)
                assert all(v == vinfo[key][i] and vinfo[f"_{key}"][i]
                           for key, v in info.items())
                done = False
                continue
            o, r, term, trunc, info = env.step(acts[k, i])
            assert np.array_equal(o, vobs[i]), (i, k)
            assert r == vrew[i] and term == vterm[i] and trunc == vtrunc[i]
            assert info["invalid_action"] == vinfo["invalid_action"][i]
            assert info["temperature"] == vinfo["temperature"][i]
            # the same flat keys, each the reactor's entry of the batch's array
            assert set(vinfo) == {k for key in info for k in (key, f"_{key}")}
            for key, value in info.items():
                assert np.asarray(value).dtype == vinfo[key].dtype, key
                assert value == vinfo[key][i], key
            assert info["time"] == vinfo["time"][i]
            done = term or trunc
        # the reactor's Simulation is the same state as the single env's
        sim, vsim = env.simulation, venv.simulations[i]
        assert np.array_equal(sim.positions, vsim.positions)
        assert np.array_equal(sim.velocities, vsim.velocities)
        assert np.array_equal(sim.ids, vsim.ids)
        assert sim.counters() == vsim.counters() and sim.reactions() == vsim.reactions()
        assert sim.bounds == vsim.bounds and sim.time == vsim.time
        # heating is booked by the batch itself: the same energy up to rounding
        assert vsim.energy_input == pytest.approx(sim.energy_input, rel=1e-12, abs=1e-12)
        assert abs(vsim.energy_balance()) < 1e-9 * abs(vsim.total_energy())


def test_make_vec_uses_the_vector_entry_point():
    env = gym.make_vec("DiscReactor-v0", num_envs=4, n_discs=60)
    assert isinstance(env.unwrapped, DiscReactorVectorEnv)
    assert env.num_envs == 4 and env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    obs, info = env.reset(seed=0)
    assert obs.shape == (4, env.single_observation_space.shape[0]) and obs.dtype == np.float32
    assert env.observation_space.contains(obs)
    obs2, rew, term, trunc, info = env.step(env.action_space.sample())
    assert rew.shape == (4,) and rew.dtype == np.float64
    assert not np.shares_memory(obs, obs2)
    assert env.spec.kwargs["n_discs"] == 60
    env.close()


def test_max_episode_steps_of_make_vec_caps_the_episode():
    env = gym.make_vec("DiscReactor-v0", num_envs=2, n_discs=60, max_episode_steps=3)
    env.reset(seed=0)
    for _ in range(3):
        *_, trunc, _ = env.step(np.zeros((2, 4), np.float32))
    assert trunc.all()


def test_same_step_autoreset_gives_final_obs():
    R = 2
    venv = DiscReactorVectorEnv(num_envs=R, autoreset_mode="SameStep", **KW)
    assert venv.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    venv.reset(seed=3)
    twin = DiscReactorVectorEnv(num_envs=R, autoreset_mode="Disabled", **KW)
    twin.reset(seed=3)
    a = np.zeros((R, 4), np.float32)
    for _ in range(KW["episode_steps"]):
        obs, rew, term, trunc, info = venv.step(a)
        tobs, trew, *_ = twin.step(a)
    assert trunc.all() and info["_final_obs"].all()
    for i in range(R):
        assert np.array_equal(info["final_obs"][i], tobs[i])
    assert np.array_equal(rew, trew)
    assert info["final_info"]["_count_A"].all()
    # the observation returned is the first of the next episode
    obs_reset, _ = twin.reset(options={"reset_mask": np.ones(R, bool)})
    assert np.array_equal(obs, obs_reset)
    assert (obs[:, venv.observation_names.index("time_left")] == 1.0).all()


def test_disabled_autoreset_needs_a_partial_reset():
    venv = DiscReactorVectorEnv(num_envs=2, autoreset_mode="Disabled", **KW)
    venv.reset(seed=0)
    for _ in range(KW["episode_steps"]):
        venv.step(np.zeros((2, 4), np.float32))
    with pytest.raises(gym.error.ResetNeeded):
        venv.step(np.zeros((2, 4), np.float32))
    obs, _ = venv.reset(options={"reset_mask": np.array([True, True])})
    venv.step(np.zeros((2, 4), np.float32))


def test_full_feed_budgets_stay_within_capacity():
    venv = DiscReactorVectorEnv(num_envs=2, n_discs=80, inject_max=10, feed_budget=40,
                                episode_steps=12)
    venv.reset(seed=1)
    a = np.tile(np.array([0.3, -1.0, 1.0, 1.0], np.float32), (2, 1))
    for _ in range(10):
        obs, rew, term, trunc, info = venv.step(a)
    assert (obs[:, venv.observation_names.index("feed_left_A")] == 0).all()
    cap = venv.config.capacity
    for sim in venv.simulations:
        assert sim._pos.shape[0] == cap and sim.overlaps() == 0 and sim.outside() == 0


def test_a_decomposing_scene_grows_within_the_planned_capacity():
    # AB -> A + B doubles the discs: the capacity plan counts mass, not initial discs
    kw = dict(scene="decomposition", product="A", feed=["AB"], n_discs=60, inject_max=5,
              feed_budget=20, episode_steps=30)
    venv = DiscReactorVectorEnv(num_envs=2, **kw)
    assert venv.config.max_discs >= 2 * (66 + 20)
    venv.reset(seed=0)
    a = np.tile(np.array([1.0, 0.0, 1.0], np.float32), (2, 1))
    for _ in range(30):
        obs, rew, term, trunc, info = venv.step(a)
    assert (info["count_A"] > 60).all()  # most AB decomposed (and the fed AB too)
    env = DiscReactorEnv(**kw)
    env.reset(seed=0)
    for _ in range(30):
        o, *_ = env.step(a[0])
    assert np.array_equal(o, obs[0])


def test_render_rgb_array_frames():
    venv = DiscReactorVectorEnv(num_envs=2, render_mode="rgb_array", render_size=64, **KW)
    venv.reset(seed=0)
    frames = venv.render()
    assert len(frames) == 2 and frames[0].shape == (64, 64, 3)


def test_bad_arguments():
    with pytest.raises(ValueError, match="num_envs"):
        DiscReactorVectorEnv(num_envs=0)
    with pytest.raises(ValueError, match="render_mode"):
        DiscReactorVectorEnv(num_envs=1, render_mode="human")
    venv = DiscReactorVectorEnv(num_envs=2, **KW)
    with pytest.raises(gym.error.ResetNeeded):
        venv.step(np.zeros((2, 4), np.float32))
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        venv.step(np.zeros((2, 3), np.float32))


# ------------------------------------------------------------------ Stable-Baselines3


def test_sb3_vec_env_terminal_observation_and_truncation():
    pytest.importorskip("stable_baselines3")
    from discgym.sb3 import DiscReactorSB3VecEnv

    R = 3
    venv = DiscReactorSB3VecEnv(num_envs=R, **KW)
    venv.seed(5)
    obs = venv.reset()
    twin = DiscReactorVectorEnv(num_envs=R, autoreset_mode="Disabled", **KW)
    tobs, _ = twin.reset(seed=5)
    assert np.array_equal(obs, tobs)
    a = np.zeros((R, 4), np.float32)
    for _ in range(KW["episode_steps"]):
        obs, rew, dones, infos = venv.step(a)
        tobs, trew, *_ = twin.step(a)
        assert rew.dtype == np.float32 and np.allclose(rew, trew)
    assert dones.all() and len(infos) == R
    for i, info in enumerate(infos):
        assert np.array_equal(info["terminal_observation"], tobs[i])
        assert info["TimeLimit.truncated"] is True
        assert isinstance(info["count_A"], int)
    assert (obs[:, twin.observation_names.index("time_left")] == 1.0).all()


def test_sb3_vec_env_keeps_the_render_metadata():
    """VecVideoRecorder takes its frame rate from the adapter's metadata: the env's 10 fps,
    not SB3's default 30."""
    pytest.importorskip("stable_baselines3")
    from discgym.sb3 import DiscReactorSB3VecEnv

    venv = DiscReactorSB3VecEnv(num_envs=2, render_mode="rgb_array", **KW)
    assert venv.metadata["render_fps"] == DiscReactorVectorEnv.metadata["render_fps"] == 10
    assert venv.metadata["render_modes"] == ["rgb_array"]


def test_sb3_video_recorder_records_at_the_env_frame_rate(tmp_path):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("moviepy")  # (VecVideoRecorder needs it)
    from stable_baselines3.common.vec_env import VecVideoRecorder

    from discgym.sb3 import DiscReactorSB3VecEnv

    venv = DiscReactorSB3VecEnv(num_envs=2, render_mode="rgb_array", **KW)
    rec = VecVideoRecorder(venv, str(tmp_path), record_video_trigger=lambda step: False)
    assert rec.frames_per_sec == 10
    rec.close()


def test_sb3_ppo_trains_on_the_batched_env():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    from discgym.sb3 import DiscReactorSB3VecEnv

    venv = VecMonitor(DiscReactorSB3VecEnv(num_envs=4, **KW))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = PPO("MlpPolicy", venv, n_steps=8, batch_size=16, n_epochs=1, seed=0,
                    device="cpu")
        model.learn(total_timesteps=64)
    assert model.num_timesteps >= 64


def test_balance_splits_the_active_reactors_into_even_consecutive_work_lists():
    from discgym.kernels.batch import balance

    rng = np.random.default_rng(0)
    for R, T in ((1, 2), (7, 2), (64, 2), (33, 4)):
        cost = rng.exponential(size=R) * rng.integers(1, 5, size=R)
        active = rng.random(R) < 0.8
        order = np.full(R, -1, dtype=np.int64)
        starts = np.zeros(T + 1, dtype=np.int64)
        balance(cost, active, T, order, starts)
        m = starts[-1]
        assert order[:m].tolist() == np.flatnonzero(active).tolist()  # consecutive lists
        assert (np.diff(starts) >= 0).all()
        loads = [cost[order[starts[t]:starts[t + 1]]].sum() for t in range(T)]
        # each list within the largest single cost of the even share
        if active.any():
            share = cost[active].sum() / T
            assert max(abs(x - share) for x in loads) <= cost[active].max() + 1e-12


def test_reactors_changed_through_their_simulations_are_followed_or_refused():
    # count_jitter 0.5: the capacity plan holds up to 1.5x the scene's counts, so a reactor
    # drawn with fewer has room for a few more discs
    venv = DiscReactorVectorEnv(num_envs=3, n_discs=80, episode_steps=20, count_jitter=0.5)
    venv.reset(seed=0)
    zeros = np.zeros((3, 4), np.float32)
    venv.step(zeros)
    sim = venv.simulations[1]
    assert len(sim) < 100
    assert sim.inject("A", 5) == 5
    n = len(sim)
    sim.resize(dg.Box(27.0, 30.0))
    _, _, _, _, info = venv.step(zeros)
    assert info["count_A"][1] + info["count_B"][1] + info["count_C"][1] \
        + info["count_W"][1] == len(sim) == n
    assert sim.outside() == 0 and sim.overlaps() == 0
    assert abs(sim.energy_balance()) < 1e-9 * abs(sim.total_energy())
    # beyond the capacity plan: every row grows, the batch follows
    cap = venv.core.state.capacity
    assert sim.inject("A", 300) == 300
    _, _, _, _, info = venv.step(zeros)
    assert venv.core.state.capacity > cap
    assert sum(info[f"count_{k}"][1] for k in "ABCW") == len(sim) > 300
    assert sim.outside() == 0 and sim.overlaps() == 0
    venv.reset(seed=0)
    venv.step(zeros)
    sim = venv.simulations[2]
    st = sim.get_state()
    for key in ("positions", "velocities", "species", "internal_energy", "ids"):
        st[key] = st[key][:30]
    sim.set_state(st)  # (in place: the batch follows)
    _, _, _, _, info = venv.step(zeros)
    assert sum(info[f"count_{k}"][2] for k in "ABCW") == len(sim) <= 30
