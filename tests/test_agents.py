"""Smoke tests of agents/: train each algorithm on a tiny budget, evaluate, check the files;
the hyperparameter files; determinism; bad input."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")
pytest.importorskip("matplotlib")
pytest.importorskip("tyro")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "agents"))

import evaluate  # noqa: E402
import train_ppo  # noqa: E402

from discgym.tasks import TASKS  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TINY_HP = {
    "ppo": {"n_envs": 2, "n_timesteps": 256, "policy": "MlpPolicy", "n_steps": 64,
            "batch_size": 64, "n_epochs": 1,
            "normalize": "{'norm_obs': True, 'norm_reward': False}",
            "policy_kwargs": "dict(net_arch=[16, 16], log_std_init=-1.0)"},
    "sac": {"n_envs": 2, "n_timesteps": 200, "learning_starts": 64, "batch_size": 32,
            "buffer_size": 1000, "normalize": "{'norm_obs': True, 'norm_reward': False}",
            "policy_kwargs": "dict(net_arch=[16, 16])"},
    "recurrent_ppo": {"n_envs": 2, "n_timesteps": 256, "n_steps": 64, "batch_size": 64,
                      "n_epochs": 1, "normalize": True,
                      "policy_kwargs": "dict(net_arch=[16], lstm_hidden_size=8)"},
}


@pytest.fixture(scope="module")
def hp_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("hp")
    for algo, entry in TINY_HP.items():
        (d / f"{algo}.yml").write_text(yaml.safe_dump({"DiscReactor-v0": entry}))
    return d


def _args(hp_dir, out, **kw):
    base = dict(env_id="DiscReactor-v0", hyperparams=str(hp_dir), out=str(out),
                episode_steps=20, threads=1, eval_freq=128, progress_bar=False)
    base.update(kw)
    return train_ppo.Args(**base)


@pytest.fixture(scope="module")
def ppo_run(hp_dir, tmp_path_factory):
    return train_ppo.train(_args(hp_dir, tmp_path_factory.mktemp("runs") / "ppo"))


def test_train_writes_every_file(ppo_run):
    for name in ("model.zip", "vecnormalize.pkl", "best_model.zip", "best_vecnormalize.pkl",
                 "args.json", "hyperparams.json", "monitor.csv", "progress.csv",
                 "evaluations.npz", "train_summary.json"):
        assert (ppo_run / name).stat().st_size > 0, name
    s = json.loads((ppo_run / "train_summary.json").read_text())
    assert s["timesteps"] >= 256 and s["env_id"] == "DiscReactor-v0" and s["algo"] == "ppo"
    ev = np.load(ppo_run / "evaluations.npz")
    # EvalCallback: one validation episode per seed of VALIDATION_SEEDS at each evaluation
    assert ev["results"].shape[1] == len(train_ppo.VALIDATION_SEEDS)
    # ... and the same seeds every time: a policy that did not change scores the same
    hp = json.loads((ppo_run / "hyperparams.json").read_text())
    assert hp["policy_kwargs"]["net_arch"] == [16, 16]


def test_evaluate_table_has_every_policy_and_paired_differences(ppo_run):
    res = evaluate.evaluate_task("DiscReactor-v0", [ppo_run], [1000, 1001], [0],
                                 {"episode_steps": 20}, workers=1, oracle=True, mpc=True,
                                 log=lambda s: None)
    assert set(res["policies"]) == {"random", "best constant", "hand-written",
                                    f"ppo ({ppo_run.name})", "mpc", "oracle"}
    for name, row in res["policies"].items():
        assert len(row["returns"]) == 2 and np.isfinite(row["mean"]["value"])
        assert ("minus_hand_written" in row) == (name != "hand-written")
    ag = res["policies"][f"ppo ({ppo_run.name})"]
    hw = res["policies"]["hand-written"]
    d = np.array(ag["returns"]) - np.array(hw["returns"])
    assert ag["minus_hand_written"]["value"] == pytest.approx(d.mean())
    # the oracle plans on its controller: never below it on a seed
    assert np.all(np.array(res["policies"]["oracle"]["returns"])
                  >= np.array(hw["returns"]) - 1e-12)
    md = evaluate.table(res)
    assert "| **ppo (ppo)** |" in md and "IQM" in md and "oracle" in md
    png = evaluate.plot_curves(res, ppo_run / "curve.png")
    assert png.stat().st_size > 0


def test_oracles_on_the_first_seeds_only_are_compared_on_those(ppo_run):
    res = evaluate.evaluate_task("DiscReactor-v0", [ppo_run], [1000, 1001, 1002], [0],
                                 {"episode_steps": 20}, workers=1, oracle=True, mpc=False,
                                 oracle_seeds=2, log=lambda s: None)
    orc, hw = res["policies"]["oracle"], res["policies"]["hand-written"]
    assert len(orc["returns"]) == 2 and orc["seeds"] == [1000, 1001]
    assert len(hw["returns"]) == 3 and "seeds" not in hw
    d = np.array(orc["returns"]) - np.array(hw["returns"][:2])
    assert orc["minus_hand_written"]["value"] == pytest.approx(d.mean())
    assert "| oracle (rollout MPC" in evaluate.table(res)
    assert "(seeds 1000-1001 only)" in evaluate.table(res)


def test_several_runs_of_one_algorithm_get_a_row_of_their_mean(ppo_run, tmp_path):
    """Two runs (training seeds, say): each keeps its row, and a third row holds their mean
    return on each evaluation seed, paired against the controller like the others."""
    import shutil

    twin = tmp_path / "twin_run"
    shutil.copytree(ppo_run, twin)
    res = evaluate.evaluate_task("DiscReactor-v0", [ppo_run, twin], [1000, 1001, 1002], [0],
                                 {"episode_steps": 20}, workers=1, oracle=False,
                                 log=lambda s: None)
    P = res["policies"]
    a, b = P[f"ppo ({ppo_run.name})"], P["ppo (twin_run)"]
    pooled = P["ppo: mean of 2 runs"]
    mean = (np.array(a["returns"]) + np.array(b["returns"])) / 2
    assert np.allclose(pooled["returns"], mean) and pooled["pooled"] == [
        f"ppo ({ppo_run.name})", "ppo (twin_run)"]
    d = mean - np.array(P["hand-written"]["returns"])
    assert pooled["minus_hand_written"]["value"] == pytest.approx(d.mean())
    assert "| ppo: mean of 2 runs (each seed's mean over the runs) |" in evaluate.table(res)
    lone = evaluate.pooled_rows({k: v for k, v in P.items() if k != "ppo (twin_run)"},
                                np.array(P["hand-written"]["returns"]))
    assert lone == {}  # (one run: nothing to pool)


def test_evaluation_does_not_depend_on_the_worker_count(ppo_run):
    kw = dict(env_id="DiscReactor-v0", runs=[ppo_run], seeds=[1000, 1001, 1002],
              search_seeds=[0], env_kwargs={"episode_steps": 20}, oracle=False,
              log=lambda s: None)
    one = evaluate.evaluate_task(workers=1, **kw)
    two = evaluate.evaluate_task(workers=2, **kw)
    for name in one["policies"]:
        assert one["policies"][name]["returns"] == two["policies"][name]["returns"], name


def test_agent_factory_matches_vecnormalize_and_predict(ppo_run):
    """The evaluated policy is the saved model on VecNormalize.load's normalisation."""
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    fac = evaluate.agent_factory(ppo_run, "final")
    env = gym.make("DiscReactor-v0", episode_steps=20)
    obs, _ = env.reset(seed=3)
    vn = VecNormalize.load(str(ppo_run / "vecnormalize.pkl"),
                           DummyVecEnv([lambda: gym.make("DiscReactor-v0")]))
    want, _ = PPO.load(ppo_run / "model.zip").predict(vn.normalize_obs(obs[None]),
                                                      deterministic=True)
    np.testing.assert_array_equal(fac(env)(obs), want[0])


def test_sampled_actions_are_reproducible_per_episode(ppo_run):
    obs = np.linspace(0, 1, 19, dtype=np.float32)
    a1 = evaluate.agent_factory(ppo_run, "final", deterministic=False)(None)(obs)
    a2 = evaluate.agent_factory(ppo_run, "final", deterministic=False)(None)(obs)
    mean = evaluate.agent_factory(ppo_run, "final")(None)(obs)
    np.testing.assert_array_equal(a1, a2)  # seeded from the episode's first observation
    assert not np.array_equal(a1, mean)


@pytest.mark.parametrize("algo", ["sac", "recurrent_ppo"])
def test_other_algorithms_train_and_act(algo, hp_dir, tmp_path):
    if algo == "recurrent_ppo":
        pytest.importorskip("sb3_contrib")
    out = train_ppo.train(_args(hp_dir, tmp_path / algo, algo=algo))
    assert (out / "model.zip").exists() and (out / "best_model.zip").exists()
    import gymnasium as gym

    env = gym.make("DiscReactor-v0", episode_steps=20)
    obs, _ = env.reset(seed=0)
    runs = []
    for _ in range(2):  # a fresh episode (and LSTM state) each time: the same actions
        policy = evaluate.agent_factory(out)(env)
        acts = []
        o = obs
        for _ in range(3):
            a = policy(o)
            assert a.shape == env.action_space.shape and np.all(np.abs(a) <= 1)
            acts.append(a)
            o = o * 0.9
        runs.append(np.array(acts))
    np.testing.assert_array_equal(runs[0], runs[1])


def test_same_seed_same_policy(hp_dir, tmp_path):
    acts = []
    obs = np.linspace(0, 1, 19, dtype=np.float32)
    for k in range(2):
        out = train_ppo.train(_args(hp_dir, tmp_path / f"r{k}", seed=3, eval_freq=0))
        env = None
        acts.append(evaluate.agent_factory(out, "final")(env)(obs))
        assert json.loads((out / "args.json").read_text())["seed"] == 3
        assert not (out / "best_model.zip").exists()  # eval_freq=0: no EvalCallback
    np.testing.assert_array_equal(acts[0], acts[1])


@pytest.mark.parametrize("algo", train_ppo.ALGOS)
def test_every_task_has_hyperparameters_that_build_a_model(algo):
    """hyperparams/<algo>.yml names every task, and each entry builds its algorithm."""
    table = yaml.safe_load((ROOT / "hyperparams" / f"{algo}.yml").read_text())
    assert set(TASKS) <= set(table), set(TASKS) - set(table)
    if algo == "recurrent_ppo":
        pytest.importorskip("sb3_contrib")
    for env_id in TASKS:
        args = train_ppo.Args(env_id=env_id, algo=algo)
        hp = train_ppo.load_hyperparams(args)
        assert hp["n_timesteps"] > 0 and hp["n_envs"] >= 1
        n_envs = hp.pop("n_envs")
        hp.pop("n_timesteps")
        venv = train_ppo.make_vec_env(args, n_envs, hp.pop("normalize", False),
                                      hp.get("gamma", 0.99),
                                      wrappers=hp.pop("vec_env_wrapper", None))
        policy = train_ppo.policy_of(hp.pop("policy", None), algo)
        train_ppo.algo_class(algo)(policy, venv, device="cpu", **hp)
        venv.close()


def test_parse_args_and_bad_input(tmp_path):
    a = train_ppo.parse_args(["--env-id", "DiscJacket-v0", "--algo", "sac",
                              "--total-timesteps", "1000", "--threads", "1"])
    assert (a.env_id, a.algo, a.total_timesteps, a.threads) == ("DiscJacket-v0", "sac", 1000, 1)
    assert a.folder() == Path("runs/DiscJacket-v0_sac")
    with pytest.raises(SystemExit):
        train_ppo.parse_args(["--algo", "dqn"])
    with pytest.raises(ValueError, match="env_id"):
        train_ppo.load_hyperparams(train_ppo.Args(env_id="CartPole-v1"))
    with pytest.raises(FileNotFoundError, match="args.json"):
        evaluate.run_info(tmp_path)


def test_evaluate_main_writes_the_table_with_date_and_machine(ppo_run, tmp_path):
    out = tmp_path / "ev"
    assert evaluate.main(["--run", str(ppo_run), "--seeds", "2", "--search-seeds", "1",
                          "--no-oracle", "--workers", "1", "--out", str(out)]) == 0
    md = (out / "evaluation.md").read_text()
    assert "| **ppo (ppo)** |" in md and "CPUs" in md and "UTC" in md
    res = json.loads((out / "evaluation.json").read_text())
    assert res["policies"]["ppo (ppo)"]["train"]["timesteps"] >= 256
    assert len(res["best_constant"]) == 4
    from PIL import Image

    with Image.open(out / "episode.gif") as im:
        assert im.n_frames >= 4 and im.size[0] > im.size[1]


@pytest.mark.parametrize("n", [0, -1, 501, True, 2.0])
def test_bad_eval_episodes_is_refused_before_training(hp_dir, tmp_path, n):
    for eval_freq in (128, 0):  # (also when validation is off)
        with pytest.raises(ValueError, match="eval_episodes"):
            train_ppo.train(_args(hp_dir, tmp_path / "run", eval_episodes=n,
                                  eval_freq=eval_freq))
        assert not (tmp_path / "run").exists()  # (refused before anything is written)


def test_eval_episodes_sets_the_validation_batch(hp_dir, tmp_path):
    """--eval-episodes n: every validation runs n episodes, one reactor each, seeded from 500."""
    cb = train_ppo._callbacks(_args(hp_dir, tmp_path, eval_episodes=3), tmp_path, 2,
                              {"norm_obs": True}, 0.99)
    assert cb.n_eval_episodes == 3 and cb.eval_env.num_envs == 3
    cb.eval_env.close()
