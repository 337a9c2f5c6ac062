"""Smoke tests of agents/: train each algorithm on a tiny budget, evaluate, check the files;
the hyperparameter files; determinism; bad input: every flag of the three scripts refused in
one line before anything is written (the scripts run as subprocesses for those cases only:
they refuse before any kernel compiles), run folders complete or absent."""

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")  # (the agents extra)
pytest.importorskip("matplotlib")
pytest.importorskip("tyro")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "agents"))

import argcheck  # noqa: E402
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
                                 {"episode_steps": 20}, workers=1, oracle=True, planner=True,
                                 log=lambda s: None)
    assert set(res["policies"]) == {"random", "best constant", "hand-written", "searched",
                                    f"ppo ({ppo_run.name})", "planner", "oracle"}
    for name, row in res["policies"].items():
        assert len(row["returns"]) == 2 and np.isfinite(row["mean"]["value"])
        assert ("minus_hand_written" in row) == (name != "hand-written")
        assert ("minus_searched" in row) == (name != "searched")
    ag = res["policies"][f"ppo ({ppo_run.name})"]
    hw = res["policies"]["hand-written"]
    sc = res["policies"]["searched"]
    d = np.array(ag["returns"]) - np.array(hw["returns"])
    assert ag["minus_hand_written"]["value"] == pytest.approx(d.mean())
    d = np.array(ag["returns"]) - np.array(sc["returns"])
    assert ag["minus_searched"]["value"] == pytest.approx(d.mean())
    # the normalised score: random 0, searched 1, a policy's mean on that scale
    rnd = res["policies"]["random"]["mean"]["value"]
    if sc["mean"]["value"] > rnd:
        assert res["policies"]["random"]["normalised"]["value"] == pytest.approx(0.0)
        assert sc["normalised"]["value"] == pytest.approx(1.0)
        assert ag["normalised"]["value"] == pytest.approx(
            (ag["mean"]["value"] - rnd) / (sc["mean"]["value"] - rnd))
    # the oracle plans on the searched controller: never below it on a seed
    assert np.all(np.array(res["policies"]["oracle"]["returns"])
                  >= np.array(sc["returns"]) - 1e-12)
    md = evaluate.table(res)
    assert "| **ppo (ppo)** |" in md and "IQM" in md and "oracle" in md
    assert "| planner (rollout MPC on the searched controller" in md
    assert md.index("| searched controller |") < md.index("| **ppo (ppo)** |") \
        < md.index("| planner")
    png = evaluate.plot_curves(res, ppo_run / "curve.png")
    assert png.stat().st_size > 0


def test_oracles_on_the_first_seeds_only_are_compared_on_those(ppo_run):
    res = evaluate.evaluate_task("DiscReactor-v0", [ppo_run], [1000, 1001, 1002], [0],
                                 {"episode_steps": 20}, workers=1, oracle=True, planner=False,
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
    kind = evaluate.variant(evaluate.run_info(ppo_run))  # (its hyperparams: a temporary folder)
    assert kind.startswith("ppo, ")
    pooled = P[f"{kind}: mean of 2 runs"]
    mean = (np.array(a["returns"]) + np.array(b["returns"])) / 2
    assert np.allclose(pooled["returns"], mean) and pooled["pooled"] == [
        f"ppo ({ppo_run.name})", "ppo (twin_run)"]
    d = mean - np.array(P["hand-written"]["returns"])
    assert pooled["minus_hand_written"]["value"] == pytest.approx(d.mean())
    d = mean - np.array(P["searched"]["returns"])
    assert pooled["minus_searched"]["value"] == pytest.approx(d.mean())
    assert pooled["run_means"] == pytest.approx([np.mean(a["returns"]), np.mean(b["returns"])])
    spread = ", ".join(f"{m:.3f}" for m in pooled["run_means"])
    assert (f"| {kind}: mean of 2 runs (each seed's mean over the runs; the runs' means "
            f"{spread}) |") in evaluate.table(res)
    lone = evaluate.pooled_rows({k: v for k, v in P.items() if k != "ppo (twin_run)"},
                                np.array(P["hand-written"]["returns"]),
                                np.array(P["searched"]["returns"]))
    assert lone == {}  # (one run: nothing to pool)
    # runs of other hyperparameters are another variant: pooled apart, never together
    other = dict(b, variant="ppo, residual_searched")
    apart = evaluate.pooled_rows({"ppo (a)": a, "ppo (b)": dict(b), "res (c)": other,
                                  "res (d)": dict(other)},
                                 np.array(P["hand-written"]["returns"]),
                                 np.array(P["searched"]["returns"]))
    assert set(apart) == {f"{kind}: mean of 2 runs", "ppo, residual_searched: mean of 2 runs"}
    assert apart["ppo, residual_searched: mean of 2 runs"]["pooled"] == ["res (c)", "res (d)"]
    info = {"algo": "ppo"}
    assert evaluate.variant(info) == "ppo" == evaluate.variant(
        dict(info, hyperparams="/x/hyperparams"))
    assert evaluate.variant(dict(info, hyperparams="hyperparams/residual")) == "ppo, residual"
    # a setting that changes what a run learns makes another variant; its seed does not
    assert evaluate.variant(dict(info, train_integrator="event", seed=3, eval_episodes=10,
                                 total_timesteps=1000)) == \
        "ppo, total_timesteps=1000, train_integrator=event"


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


def test_export_policy_ships_a_run_that_acts_as_its_model(ppo_run, hp_dir, tmp_path,
                                                          monkeypatch):
    """agents/export_policy.py writes a run as a numpy agent (discgym.pretrained) whose
    actions are the model's within --atol at every decision, with returns on evaluation
    seeds that the loaded agent reproduces; bad arguments, and a run trained on another env
    than the registered task (ppo_run's 20-step episodes), write nothing."""
    import export_policy
    import gymnasium as gym

    from discgym import pretrained

    run = train_ppo.train(_args(hp_dir, tmp_path / "run", episode_steps=None))
    for bad, field in (([], "runs"), (["--runs", str(run), "--seeds", "5"], "seeds"),
                       (["--runs", str(run), str(run)], "runs"),
                       (["--runs", str(ppo_run)], "runs")):
        with pytest.raises(argcheck.UsageError, match=f"--{field}"):
            export_policy.main([*bad, "--out", str(tmp_path / "out")])
    assert not (tmp_path / "out").exists()
    assert export_policy.main(["--runs", str(run), "--out", str(tmp_path / "out"),
                               "--seeds", "1000", "1001"]) == 0
    tmp_path = tmp_path / "out"
    meta = json.loads((tmp_path / "DiscReactor-v0" / "agents.json").read_text())
    rec = meta["agents"]["0"]
    assert rec["largest_action_difference"] <= 1e-4 and rec["decisions_compared"] == 100
    monkeypatch.setattr(pretrained, "FOLDER", tmp_path)
    assert pretrained.available() == {"DiscReactor-v0": [0]}
    agent = pretrained.load("DiscReactor-v0", 0)
    assert agent.interface == {} and agent.info["returns"] == rec["returns"]
    env = gym.make("DiscReactor-v0")
    obs, _ = env.reset(seed=1000)
    policy, total, done = agent.policy(env), 0.0, False
    while not done:
        obs, r, terminated, truncated, _ = env.step(policy(obs))
        total += float(r)
        done = terminated or truncated
    assert total == pytest.approx(rec["returns"]["1000"], rel=1e-9, abs=1e-12)


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
    with pytest.raises(ValueError, match="--env-id"):
        train_ppo.load_hyperparams(train_ppo.Args(env_id="CartPole-v1"))
    with pytest.raises(argcheck.UsageError, match="--run: .* has no args.json"):
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
    # the evaluation is aggregate.py's input as it is
    import aggregate

    rows = res["policies"]
    lo, hi = (np.mean(rows[k]["returns"]) for k in ("random", "searched"))
    assert hi > lo  # (on these two seeds: a scale)
    assert aggregate.main(["--evaluation", str(out / "evaluation.json"),
                           "--out", str(tmp_path / "agg")]) == 0
    got = json.loads((tmp_path / "agg" / "aggregate.json").read_text())["normalised"]
    kind = evaluate.variant(evaluate.run_info(ppo_run))
    want = (np.mean(rows["ppo (ppo)"]["returns"]) - lo) / (hi - lo)
    assert got["policies"][kind]["DiscReactor-v0"] == pytest.approx([want])
    from PIL import Image

    with Image.open(out / "episode.gif") as im:
        assert im.n_frames >= 4 and im.size[0] > im.size[1]


@pytest.mark.parametrize("n", [0, -1, 501, True, 2.0])
def test_bad_eval_episodes_is_refused_before_training(hp_dir, tmp_path, n):
    for eval_freq in (128, 0):  # (also when validation is off)
        with pytest.raises(ValueError, match="--eval-episodes"):
            train_ppo.train(_args(hp_dir, tmp_path / "run", eval_episodes=n,
                                  eval_freq=eval_freq))
        assert not (tmp_path / "run").exists()  # (refused before anything is written)


def test_eval_episodes_sets_the_validation_batch(hp_dir, tmp_path):
    """--eval-episodes n: every validation runs n episodes, one reactor each, seeded from 500."""
    cb = train_ppo._callbacks(_args(hp_dir, tmp_path, eval_episodes=3), tmp_path, 2,
                              {"norm_obs": True}, 0.99)
    assert cb.n_eval_episodes == 3 and cb.eval_env.num_envs == 3
    cb.eval_env.close()


# ------------------------------------------------------------- refused before anything is written
AGENTS = ROOT / "agents"


def _tree(folder: Path) -> set:
    return {(str(p.relative_to(folder)), p.stat().st_size) for p in folder.rglob("*")}


def _refused(cwd: Path, argv: list, flag: str, code: list | None = None):
    """Run a script of agents/ (or ``python -c code``) in ``cwd``: refused with exit status
    2, one line of stderr naming ``flag``, nothing written under ``cwd``."""
    before = _tree(cwd)
    cmd = [sys.executable, *(code or [str(AGENTS / argv[0])]), *argv[1:]]
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=300)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1 and "error: " in lines[0] and flag in lines[0], r.stderr
    assert "Traceback" not in r.stderr and r.stdout == ""
    assert _tree(cwd) == before  # (not an empty run folder either)
    return lines[0]


@pytest.mark.parametrize("argv, flag", [
    (["--total-timesteps", "-100"], "--total-timesteps"),
    (["--env-id", "NoSuchEnv-v0"], "--env-id"),
    (["--hyperparams", "no_such_folder"], "--hyperparams"),
    (["--n-envs", "0"], "--n-envs"),
    (["--n-envs", "abc"], "--n-envs"),  # (tyro's own parse error, cut to one line)
    (["--algo", "dqn"], "--algo"),
    (["--out", "a_file"], "--out"),
])
def test_train_ppo_refuses_bad_flags_in_one_line(tmp_path, argv, flag):
    (tmp_path / "a_file").write_text("not a folder")
    _refused(tmp_path, ["train_ppo.py", *argv], flag)


def _fake_run(folder: Path, model: bytes = b"not a zip", **args) -> Path:
    folder.mkdir(parents=True)
    (folder / "args.json").write_text(json.dumps({"env_id": "DiscReactor-v0", "algo": "ppo",
                                                  **args}))
    (folder / "train_summary.json").write_text(json.dumps({"timesteps": 1,
                                                           "wall_seconds": 0.0}))
    (folder / "model.zip").write_bytes(model)
    return folder


@pytest.mark.parametrize("case, flag", [
    ("search seeds 0", "--search-seeds"),
    ("missing", "--run: no folder"),
    ("corrupted model", "model.zip cannot be loaded"),
    ("unknown env id", "'NoSuchEnv-v0', which has no baselines"),
    ("no summary", "unfinished run"),  # (what train_ppo.py once left after --n-envs 0)
    ("staging folder", "unfinished run"),
    ("seeds overlap", "--first-seed"),
])
def test_evaluate_refuses_bad_flags_and_runs_in_one_line(tmp_path, case, flag):
    run = _fake_run(tmp_path / "run", env_id="NoSuchEnv-v0" if case == "unknown env id"
                    else "DiscReactor-v0")
    argv = {"search seeds 0": ["--run", "run", "--search-seeds", "0"],
            "missing": ["--run", "no_such_run"],
            "seeds overlap": ["--run", "run", "--first-seed", "5"]}.get(case, ["--run", "run"])
    if case == "no summary":
        (run / "train_summary.json").unlink()
    if case == "staging folder":
        run = run.rename(tmp_path / ".run.partial-x1y2")
        argv = ["--run", run.name]
    _refused(tmp_path, ["evaluate.py", *argv, "--no-oracle", "--workers", "1"], flag)


def test_an_interrupted_run_is_refused_by_evaluate(ppo_run, tmp_path):
    """A run folder without its last file (training interrupted, or from a version that wrote
    args.json first) is refused with one line, before any episode; the finished run is not."""
    import shutil

    half = tmp_path / "half"
    shutil.copytree(ppo_run, half)
    (half / "train_summary.json").unlink()
    with pytest.raises(argcheck.UsageError, match="--run: .*half is an unfinished run"):
        evaluate.main(["--run", str(half), "--seeds", "2", "--no-oracle", "--workers", "1"])
    assert not (half / "evaluation.json").exists()
    assert evaluate.check_run(ppo_run)["env_id"] == "DiscReactor-v0"


def test_train_rllib_refuses_bad_flags_in_one_line(tmp_path):
    _refused(tmp_path, ["train_rllib.py", "--iterations", "0"], "--iterations")
    _refused(tmp_path, ["train_rllib.py", "--env-id", "NoSuchEnv-v0"], "--env-id")


def test_train_rllib_without_ray_says_how_to_install_it(tmp_path):
    """``import ray`` made to fail (None in sys.modules): one line with the pip command."""
    code = ["-c", "import runpy, sys; sys.modules['ray'] = None; "
            "sys.argv = ['train_rllib.py', '--iterations', '1']; "
            f"runpy.run_path({str(AGENTS / 'train_rllib.py')!r}, run_name='__main__')"]
    line = _refused(tmp_path, ["train_rllib.py"], "pip install -e '.[rllib]'", code=code)
    assert "Ray RLlib is not installed" in line


# every flag of the three scripts, in process (the same validation pass the scripts run)
PPO_BAD = [
    ("total_timesteps", 0, "--total-timesteps"), ("total_timesteps", 1.5, "--total-timesteps"),
    ("seed", -1, "--seed"), ("seed", 2**32, "--seed"), ("n_envs", -2, "--n-envs"),
    ("episode_steps", 0, "--episode-steps"), ("threads", 0, "--threads"),
    ("torch_threads", 0, "--torch-threads"), ("eval_freq", -1, "--eval-freq"),
    ("eval_episodes", 501, "--eval-episodes"), ("algo", "dqn", "--algo"),
    ("train_integrator", "verlet", "--train-integrator"), ("progress_bar", 1, "--progress-bar"),
    ("env_id", "CartPole-v1", "--env-id: 'CartPole-v1' is a Gymnasium env but not a discgym"),
    ("env_id", "DiscFlow-v9", "--env-id: 'DiscFlow-v9'"),
    ("scene", "no_such_scene", "--scene: cannot read"),
    ("device", "gpu", "--device"), ("out", ".", "--out"),
    ("hyperparams", "HP/missing", "--hyperparams: no folder"),
]


@pytest.mark.parametrize("field, value, match", PPO_BAD, ids=[f"{f}={v!r}" for f, v, _ in PPO_BAD])
def test_train_ppo_checks_every_flag(hp_dir, tmp_path, field, value, match):
    value = value.replace("HP", str(hp_dir)) if isinstance(value, str) else value
    kw = {field: value}
    args = _args(hp_dir, kw.pop("out", tmp_path / "run"), **kw)
    with pytest.raises(argcheck.UsageError, match=match):
        train_ppo.train(args)
    assert list(tmp_path.iterdir()) == []


def test_train_ppo_checks_the_hyperparameters_file(tmp_path):
    """The entry of --hyperparams: the file parses, has the task, counts >= 1, keys the
    algorithm takes, expressions that evaluate, a policy that imports."""
    hp = tmp_path / "hp"
    hp.mkdir()
    cases = [("ppo: [unclosed", "is not valid YAML"),
             ("DiscFlow-v0: {n_envs: 2, n_timesteps: 64}", "--env-id: 'DiscReactor-v0' has "
                                                           "no entry"),
             ("DiscReactor-v0: {n_envs: 0, n_timesteps: 64}", "n_envs: expected a whole"),
             ("DiscReactor-v0: {n_envs: 2}", "has no n_timesteps"),
             ("DiscReactor-v0: {n_envs: 2, n_timesteps: 64, n_stepz: 8}",
              "keys PPO does not take: n_stepz"),
             ("DiscReactor-v0: {n_envs: 2, n_timesteps: 64, policy_kwargs: 'dict(net_arch='}",
              "policy_kwargs .* does not evaluate"),
             ("DiscReactor-v0: {n_envs: 2, n_timesteps: 64, policy: no_such.Policy}",
              "policy or vec_env_wrapper")]
    for text, match in cases:
        (hp / "ppo.yml").write_text(text)
        with pytest.raises(argcheck.UsageError, match=match):
            train_ppo.check_args(_args(hp, tmp_path / "run"))
    with pytest.raises(argcheck.UsageError, match="has no sac.yml"):
        train_ppo.check_args(_args(hp, tmp_path / "run", algo="sac"))
    (hp / "ppo.yml").write_text("DiscReactor-v0: {n_envs: 2, n_timesteps: 64}")
    # (--n-envs and --total-timesteps replace the file's counts, checked with them)
    assert train_ppo.check_args(_args(hp, tmp_path / "run", n_envs=3))["n_envs"] == 3
    with pytest.raises(argcheck.UsageError, match="--episode-steps: need a whole number"):
        train_ppo.check_args(_args(hp, tmp_path / "run", episode_steps=2**63))
    assert list(tmp_path.iterdir()) == [hp]


def test_evaluate_checks_every_flag(ppo_run, tmp_path):
    ok = ["--no-oracle", "--workers", "1", "--run", str(ppo_run)]
    for extra, match in [(["--seeds", "1"], "--seeds"), (["--first-seed", "-1"], "--first-seed"),
                         (["--search-seeds", "0"], "--search-seeds"),
                         (["--oracle-seeds", "1"], "--oracle-seeds"),
                         (["--workers", "0"], "--workers"),
                         (["--out", str(ppo_run / "args.json")], "--out"),
                         ([str(ppo_run)], "two runs would share the row")]:
        a = argcheck.parse(evaluate.Args, ok + extra)
        with pytest.raises(argcheck.UsageError, match=match):
            evaluate.check_args(a)
    with pytest.raises(argcheck.UsageError, match="--run: name at least one"):
        evaluate.check_args(evaluate.Args())
    other = _fake_run(tmp_path / "other", episode_steps=7)
    with pytest.raises(argcheck.UsageError, match="must share a task"):
        evaluate.check_args(argcheck.parse(evaluate.Args, ok + [str(other)]))
    with pytest.raises(SystemExit):
        argcheck.parse(evaluate.Args, ["--checkpoint", "middle"])


def test_train_rllib_checks_every_flag_and_takes_every_task(tmp_path):
    pytest.importorskip("ray.rllib")
    import train_rllib

    def check(*argv):
        return train_rllib.check_args(train_rllib.parse([*argv, "--out", str(tmp_path / "r")]))

    for argv, match in [(["--env-runners", "-1"], "--env-runners"),
                        (["--envs-per-runner", "0"], "--envs-per-runner"),
                        (["--cpus-per-runner", "0"], "--cpus-per-runner"),
                        (["--rollout", "0"], "--rollout"), (["--epochs", "0"], "--epochs"),
                        (["--minibatch", "0"], "--minibatch: expected"),
                        (["--minibatch", "5000"], "--minibatch: 5000 is more than"),
                        (["--num-cpus", "0"], "--num-cpus"), (["--seed", "-1"], "--seed"),
                        (["--env-config", "{"], "--env-config: not JSON"),
                        (["--env-config", '{"threads": 2}'], "set by --cpus-per-runner"),
                        (["--env-config", '{"n_discs": 0}'], "--env-config: n_discs"),
                        (["--env-config", '{"frameskip": 1}'], "unexpected keyword"),
                        (["--address", "nowhere"], "--address"),
                        (["--address", "auto", "--num-cpus", "2"], "--num-cpus"),
                        (["--env-runners", "3", "--num-cpus", "2"], "--env-runners: 3 runners"),
                        (["--env-id", "Pendulum-v1"], "not a discgym task")]:
        with pytest.raises(argcheck.UsageError, match=match):
            check(*argv)
    for env_id in TASKS:  # (each task: its config, id for the env runners, warm-up env)
        args = train_rllib.parse(["--env-id", env_id, "--env-config", '{"n_discs": 40}'])
        cfg = train_rllib.check_args(args)
        assert train_rllib.build_config(args, cfg).env == f"discgym:{env_id}"
    assert train_rllib.parse([]).env_id == "DiscReactor-v0"
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ complete or absent
def test_an_interrupted_training_leaves_no_folder(hp_dir, tmp_path, monkeypatch):
    """Ctrl-C (or a crash) after the first files: neither the run folder nor its staging
    sibling nor the parent made for it remain; a previous run folder stays as it was."""
    def interrupt(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(train_ppo, "_callbacks", interrupt)  # (after args.json, the venv)
    with pytest.raises(KeyboardInterrupt):
        train_ppo.train(_args(hp_dir, tmp_path / "new" / "run"))
    assert list(tmp_path.iterdir()) == []
    old = _fake_run(tmp_path / "old")
    before = _tree(old)
    with pytest.raises(KeyboardInterrupt):
        train_ppo.train(_args(hp_dir, old))
    assert _tree(old) == before and list(tmp_path.iterdir()) == [old]


def test_staged_folder_replaces_a_previous_run_only_when_complete(tmp_path):
    final = _fake_run(tmp_path / "run")
    with argcheck.staged_folder(final) as out:
        assert out.parent == tmp_path and out.name.startswith(".run.partial-")
        (out / "new.txt").write_text("x")
        assert (final / "model.zip").exists()  # (the old one, until the end)
    assert [p.name for p in final.iterdir()] == ["new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    assert oct(final.stat().st_mode & 0o777) == oct(0o777 & ~argcheck._umask())


def test_sigterm_cleans_up_like_ctrl_c(tmp_path, capsys):
    """argcheck.run turns SIGTERM into KeyboardInterrupt (the staging folder is removed),
    exit 130 with one line; the previous handler is restored."""
    previous = signal.getsignal(signal.SIGTERM)

    def main():
        with argcheck.staged_folder(tmp_path / "run"):
            os.kill(os.getpid(), signal.SIGTERM)

    with pytest.raises(SystemExit) as e:
        argcheck.run(main)
    assert e.value.code == 130 and list(tmp_path.iterdir()) == []
    assert capsys.readouterr().err.strip().endswith("interrupted")
    assert signal.getsignal(signal.SIGTERM) is previous


def test_expected_errors_are_one_line_and_bugs_keep_their_traceback(capsys):
    with pytest.raises(SystemExit) as e:
        argcheck.run(lambda: (_ for _ in ()).throw(argcheck.usage("n_envs", "bad\nvalue")))
    assert e.value.code == 2
    assert capsys.readouterr().err.strip().endswith("error: --n-envs: bad value")
    with pytest.raises(ZeroDivisionError):  # (a bug: not turned into a usage line)
        argcheck.run(lambda: 1 / 0)


_THREADS_PROBE = """
import sys
sys.path.insert(0, {agents!r})
import numba, numpy as np, torch
from train_ppo import set_torch_threads
if {helper}:
    set_torch_threads(1)
else:
    torch.set_num_threads(1)
torch.get_num_threads()  # (torch re-applies its count once per thread, at its first call)

@numba.njit(parallel=True)
def total(x):
    s = 0.0
    for i in numba.prange(x.size):
        s += x[i]
    return s

total(np.ones(1000))  # (on all of numba's threads, as the env's own parallel kernels run)
print(torch.get_num_threads(), numba.threading_layer())
"""


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: nothing to undo")
def test_set_torch_threads_survives_numbas_thread_pool():
    """numba's OpenMP layer, started after torch.set_num_threads(1), sets OpenMP's count
    back to every core (an LSTM's oneDNN kernels then spin a second thread); the helper
    starts numba's pool first. Each case in a fresh process: the pool starts once."""
    agents = str(Path(__file__).resolve().parents[1] / "agents")

    def probe(helper: bool) -> tuple[int, str]:
        out = subprocess.run([sys.executable, "-c", _THREADS_PROBE.format(
            agents=agents, helper=helper)], capture_output=True, text=True, check=True)
        n, layer = out.stdout.split()
        return int(n), layer

    assert probe(helper=True)[0] == 1
    plain, layer = probe(helper=False)
    if layer == "omp":  # (the control: what the helper guards against happens here)
        assert plain > 1
