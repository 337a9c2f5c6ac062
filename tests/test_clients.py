"""The examples of docs/ecosystem.md, each with the real client (skipped only where that
client is not installed; CI installs all of them:
``pip install -e ".[test,agents,ecosystem,docs]"``):
Stable-Baselines3 (make_vec_env, SubprocVecEnv, EvalCallback with VecNormalize,
VecVideoRecorder), Ray RLlib (every way to name the env; agents/train_rllib.py on a local Ray),
TorchRL (GymEnv, its info reader, ParallelEnv, the native vector env), CleanRL-style loops
(final_info in SameStep mode), Gymnasium's RecordVideo and RL Baselines3 Zoo.

Sizes are tiny: these check that each client runs the env without a workaround, not that
it learns."""

import csv
import importlib.util
import os
import subprocess
import sys
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import discgym  # noqa: F401  (registers DiscReactor-v0)
from discgym.env import DiscReactorEnv
from discgym.vector import DiscReactorVectorEnv

ROOT = Path(__file__).resolve().parents[1]
KW = dict(n_discs=40, episode_steps=4)
SMALL = dict(KW, max_episode_steps=4)  # (through gymnasium.make: the registration's TimeLimit)


# ------------------------------------------------------------------ Stable-Baselines3
def test_sb3_make_vec_env_with_subprocesses_and_eval_callback_with_vecnormalize(tmp_path):
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import EvalCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecNormalize

    from discgym.sb3 import DiscReactorSB3VecEnv

    # SB3's own helpers with the registered id (one process per env: "discgym:" makes each
    # process import discgym, which registers the id there)
    sub = make_vec_env("discgym:DiscReactor-v0", n_envs=2, seed=0, vec_env_cls=SubprocVecEnv,
                       env_kwargs=SMALL)
    try:
        obs = sub.reset()
        assert obs.shape == (2, 19)
        for _ in range(4):
            obs, rew, done, infos = sub.step(np.zeros((2, 4), np.float32))
        assert done.all() and "terminal_observation" in infos[0]
        assert infos[0]["count_A"] >= 0 and "episode" in infos[0]  # (Monitor's statistics)
        assert sub.get_attr("metadata")[0]["render_fps"] == 10
    finally:
        sub.close()
    # training on the batched adapter, evaluated on SB3's DummyVecEnv, both normalised
    train = VecNormalize(DiscReactorSB3VecEnv(num_envs=2, **KW), norm_reward=False)
    evaluation = VecNormalize(make_vec_env("DiscReactor-v0", n_envs=1, env_kwargs=SMALL),
                              training=False, norm_reward=False)
    cb = EvalCallback(evaluation, eval_freq=8, n_eval_episodes=2,
                      best_model_save_path=str(tmp_path), log_path=str(tmp_path),
                      verbose=0)
    model = PPO("MlpPolicy", train, n_steps=8, batch_size=16, n_epochs=1, seed=0,
                device="cpu")
    model.learn(total_timesteps=32, callback=cb)
    assert len(cb.evaluations_results) >= 1 and (tmp_path / "best_model.zip").exists()
    # the evaluation env uses the training env's statistics (sync_envs_normalization)
    assert np.array_equal(evaluation.obs_rms.mean, train.obs_rms.mean)


def test_sb3_vec_video_recorder_writes_a_video_at_10_fps(tmp_path):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("moviepy")
    from stable_baselines3.common.vec_env import VecVideoRecorder

    from discgym.sb3 import DiscReactorSB3VecEnv

    venv = DiscReactorSB3VecEnv(num_envs=2, render_mode="rgb_array", render_size=64, **KW)
    rec = VecVideoRecorder(venv, str(tmp_path), record_video_trigger=lambda step: step == 0,
                           video_length=6, name_prefix="reactor")
    assert rec.frames_per_sec == 10
    rec.reset()
    for _ in range(6):
        rec.step(np.zeros((2, 4), np.float32))
    rec.close()
    videos = list(tmp_path.glob("reactor*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 0


# ------------------------------------------------------------------ Ray RLlib
def test_rllib_env_runner_builds_the_env_every_way():
    """The id, register_env with a lambda, and the classes themselves (RLlib calls
    ``cls(env_config)``; with "vector_entry_point", ``cls(env_config | {"num_envs": n})``)."""
    pytest.importorskip("ray.rllib")
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.env.single_agent_env_runner import SingleAgentEnvRunner
    from ray.tune.registry import register_env

    register_env("discgym-by-lambda", lambda cfg: DiscReactorEnv(cfg))
    ways = [("discgym:DiscReactor-v0", "sync", gym.vector.SyncVectorEnv),
            ("discgym:DiscReactor-v0", "vector_entry_point", DiscReactorVectorEnv),
            ("discgym-by-lambda", "sync", gym.vector.SyncVectorEnv),
            (DiscReactorEnv, "sync", gym.vector.SyncVectorEnv),
            (DiscReactorVectorEnv, "vector_entry_point", DiscReactorVectorEnv)]
    for env, mode, vec_cls in ways:
        config = (PPOConfig().environment(env, env_config=dict(KW))
                  .env_runners(num_envs_per_env_runner=2, gym_env_vectorize_mode=mode))
        runner = SingleAgentEnvRunner(config=config)
        try:
            assert isinstance(runner.env.unwrapped, vec_cls), (env, mode)
            episodes = runner.sample(num_timesteps=12, random_actions=True)
            assert sum(len(e) for e in episodes) >= 12
            done = [e for e in episodes if e.is_done]
            assert done, (env, mode)  # (4-step episodes)
            infos = done[0].get_infos()
            # the flat infos of every step, the reset's too, with the same keys
            assert len(infos) == 5 and all(set(i) == set(infos[0]) for i in infos)
            assert "count_A" in infos[0] and "injected_A" in infos[-1]
        finally:
            runner.stop()


@pytest.fixture
def local_ray():
    """A local Ray of 2 CPUs listening on 127.0.0.1 only, shut down after the test."""
    ray = pytest.importorskip("ray")
    pytest.importorskip("ray.rllib")
    sys.path.insert(0, str(ROOT / "agents"))
    import train_rllib

    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    with train_rllib.local_ray(num_cpus=2, env_vars={"NUMBA_NUM_THREADS": "1"}):
        nodes = [n for n in ray.nodes() if n["Alive"]]
        assert [n["NodeManagerAddress"] for n in nodes] == ["127.0.0.1"]
        assert ray.get_runtime_context().gcs_address.startswith("127.0.0.1:")
        yield train_rllib
    assert not ray.is_initialized()


#: One tiny iteration of agents/train_rllib.py per env runner: 4 reactors x 32 steps
#: (episodes of 8 steps), one epoch (tests/test_ray_cluster.py runs it on two nodes).
RLLIB_ONE_ITERATION = ["--iterations", "1", "--envs-per-runner", "4", "--rollout", "32",
                       "--minibatch", "64", "--epochs", "1",
                       "--env-config", '{"n_discs": 40, "episode_steps": 8}']


def test_rllib_train_script_runs_one_iteration_on_a_local_ray(local_ray, tmp_path):
    rows = local_ray.main([*RLLIB_ONE_ITERATION, "--env-runners", "1", "--out", str(tmp_path)])
    assert len(rows) == 1 and rows[0]["env_steps"] >= 4 * 32
    assert rows[0]["episodes"] >= 4 * 32 // 8 - 4  # (episodes of 8 steps ended in 32)
    assert np.isfinite(rows[0]["episode_return_mean"])
    with open(tmp_path / "progress.csv") as f:
        assert [int(r["env_steps"]) for r in csv.DictReader(f)] == [rows[0]["env_steps"]]


# ------------------------------------------------------------------ TorchRL
def test_torchrl_gym_env_and_its_info_reader():
    pytest.importorskip("torchrl")
    from torchrl.envs import GymEnv, check_env_specs

    env = GymEnv("discgym:DiscReactor-v0", **SMALL)  # (passes frameskip=1 first)
    check_env_specs(env)
    env = env.auto_register_info_dict()  # reads every info key, at reset and at step
    td = env.rollout(4)
    for key in ("count_A", "product", "injected_A", "inject_refused_B", "wall_blocked",
                "n_ref"):
        assert td["next", key].shape == (4,), key
    assert td["next", "count_A"].dtype.is_floating_point is False
    assert td["next", "truncated"][-1].item()
    # the info at reset fills the root of the first step
    assert td["count_A"][0] >= 0 and not td["wall_blocked"][0]


def test_torchrl_vectorised_gym_env_and_parallel_env():
    pytest.importorskip("torchrl")
    from torchrl.envs import GymEnv, ParallelEnv, check_env_specs

    # num_envs: TorchRL's own AsyncVectorEnv; its final observations are zeros where a
    # reactor did not finish (inside the observation space: every slot's range holds 0)
    env = GymEnv("discgym:DiscReactor-v0", num_envs=2, **SMALL)
    try:
        check_env_specs(env)
        td = env.rollout(6, break_when_any_done=False)
        assert td.batch_size == (2, 6) and td["next", "count_A"].shape == (2, 6)
    finally:
        env.close()
    par = ParallelEnv(2, partial(GymEnv, "discgym:DiscReactor-v0", **SMALL))
    try:
        td = par.rollout(5, break_when_any_done=False)
        assert td.batch_size == (2, 5)
        assert td["next", "truncated"][:, 3].all()
    finally:
        par.close()


@pytest.mark.parametrize("mode", ["SameStep", "Disabled"])
def test_torchrl_wraps_the_native_vector_env(mode):
    """TorchRL takes a vector env in SameStep (reading final_obs / final_info) or Disabled
    mode (resetting finished reactors itself with reset_mask), the latter its preferred."""
    pytest.importorskip("torchrl")
    from torchrl.envs import GymWrapper, check_env_specs

    env = GymWrapper(DiscReactorVectorEnv(num_envs=3, autoreset_mode=mode, **KW))
    assert env.batch_size == (3,)
    if mode == "Disabled":
        env = env.auto_register_info_dict()
    check_env_specs(env)
    td = env.rollout(10, break_when_any_done=False)  # two episode ends per reactor
    assert td.batch_size == (3, 10)
    assert td["next", "done"].sum().item() == 3 * 2
    assert (td["next", "count_A"] > 0).all()
    # after an end, the next step starts from a fresh episode: time_left is back near 1
    i = env.observation_spec["observation"].shape[-1] - 3  # (time_left; 2 feed slots after)
    assert (td["observation"][:, 4, i] == 1.0).all()


# ------------------------------------------------------------------ CleanRL-style scripts
def test_cleanrl_style_loop_reads_final_info_in_same_step_mode():
    """The loop of CleanRL's PPO scripts: episode statistics of finished episodes from
    ``infos["final_info"]`` (SameStep autoreset), with Gymnasium's SyncVectorEnv and with
    the native vector env."""
    sync = gym.vector.SyncVectorEnv(
        [lambda: gym.wrappers.RecordEpisodeStatistics(gym.make("DiscReactor-v0", **SMALL))
         for _ in range(2)], autoreset_mode=AutoresetMode.SAME_STEP)
    native = gym.wrappers.vector.RecordEpisodeStatistics(gym.make_vec(
        "DiscReactor-v0", num_envs=2, vectorization_mode="vector_entry_point",
        autoreset_mode=AutoresetMode.SAME_STEP, **SMALL))
    for envs, where in ((sync, "final_info"), (native, None)):
        envs.reset(seed=0)
        returns, yields = [], []
        for _ in range(8):
            _, _, term, trunc, infos = envs.step(envs.action_space.sample())
            if "final_info" in infos:
                final = infos["final_info"]
                stats = final["episode"] if where else infos["episode"]
                mask = final["_episode"] if where else infos["_episode"]
                for i in np.flatnonzero(mask):
                    returns.append(float(stats["r"][i]))
                    yields.append(float(final["yield"][i]))
        assert len(returns) == 4  # two 4-step episodes per env
        # an episode's return is its product yield (with the default zero costs)
        assert np.allclose(returns, yields, atol=1e-5)
        envs.close()


# ------------------------------------------------------------------ RecordVideo
def test_gymnasium_record_video(tmp_path):
    pytest.importorskip("moviepy")
    env = gym.wrappers.RecordVideo(
        gym.make("DiscReactor-v0", render_mode="rgb_array", render_size=64, **SMALL),
        str(tmp_path), episode_trigger=lambda ep: ep == 0, name_prefix="reactor")
    assert env.frames_per_sec == 10
    env.reset(seed=0)
    done = False
    while not done:
        *_, term, trunc, _ = env.step(env.action_space.sample())
        done = term or trunc
    env.close()
    videos = list(tmp_path.glob("reactor*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 0


# ------------------------------------------------------------------ RL Baselines3 Zoo
def test_rl_zoo_trains_with_the_hyperparameter_file(tmp_path):
    # (not imported here: importing rl_zoo3 patches Gymnasium's TimeLimit for the whole
    # process, adding "TimeLimit.truncated" to every later test's infos)
    if importlib.util.find_spec("rl_zoo3") is None:
        pytest.skip("rl_zoo3 is not installed")
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "DiscReactor-v0",
           "--gym-packages", "discgym", "--conf-file", str(ROOT / "hyperparams" / "ppo.yml"),
           "-n", "64", "--hyperparams", "n_envs:2", "n_steps:16", "batch_size:32",
           "n_epochs:1", "--env-kwargs", "n_discs:40", "--eval-freq", "-1",
           "--device", "cpu", "--seed", "0", "-f", str(tmp_path)]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    res = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-3000:]
    saved = list(tmp_path.glob("ppo/DiscReactor-v0_*/DiscReactor-v0.zip"))
    assert len(saved) == 1, res.stdout[-2000:]
