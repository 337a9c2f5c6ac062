"""Smoke tests of agents/: train on a tiny budget, evaluate, check the files; determinism."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("matplotlib")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "agents"))

import evaluate  # noqa: E402
import train_ppo  # noqa: E402

TINY = dict(total_timesteps=256, num_envs=2, n_steps=64, batch_size=64, n_epochs=1,
            episode_steps=40, progress_bar=False, threads=1)


def _two_constants():
    n = len(evaluate.ReactorConfig.from_kwargs().action_names)
    return [[0.0] * n, [1.0] * n]


def test_train_and_evaluate_end_to_end(tmp_path):
    args = train_ppo.Args(out=str(tmp_path / "run"), **TINY)
    out = train_ppo.train(args)
    for name in ("model.zip", "vecnormalize.pkl", "learning_curve.png", "progress.csv",
                 "args.json", "train_summary.json"):
        assert (out / name).stat().st_size > 0, name
    res = evaluate.compare(out, episodes=2, env_kwargs={"episode_steps": 40}, threads=1,
                           search_episodes=1, grid=_two_constants())
    assert set(res) == {"random", "best constant", "heuristic", "PPO", "_meta"}
    for name in ("random", "best constant", "heuristic", "PPO"):
        assert len(res[name]["returns"]) == 2
        assert np.isfinite(res[name]["mean"])
    assert "| PPO |" in evaluate.table(res)
    gif = evaluate.animate(out, tmp_path / "ep.gif", env_kwargs={"episode_steps": 40},
                           every=10, size=120)
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames >= 4 and im.size[0] > im.size[1]


def test_cli_parses_every_argument():
    a = train_ppo.parse_args(["--total-timesteps", "1000", "--no-normalize", "--net-arch", "32",
                              "32", "--product", "C", "--threads", "1"])
    assert a.total_timesteps == 1000 and a.normalize is False and a.net_arch == [32, 32]
    assert a.product == "C" and a.threads == 1


def test_same_seed_same_first_actions(tmp_path):
    acts = []
    for k in range(2):
        out = train_ppo.train(train_ppo.Args(out=str(tmp_path / f"r{k}"), seed=3, **TINY))
        policy = evaluate.load_policy(out)
        dim = len(evaluate.ReactorConfig.from_kwargs().obs_names)
        obs = np.linspace(0, 1, dim, dtype=np.float32)[None].repeat(3, 0)
        acts.append(policy(obs))
        assert json.loads((out / "args.json").read_text())["seed"] == 3
    np.testing.assert_array_equal(acts[0], acts[1])


def test_evaluate_main_writes_the_table_with_date_and_machine(tmp_path):
    out = train_ppo.train(train_ppo.Args(out=str(tmp_path / "run"), **TINY))
    assert evaluate.main(["--run", str(out), "--episodes", "2", "--no-gif",
                          "--search-episodes", "1", "--threads", "1"]) == 0
    md = (out / "evaluation.md").read_text()
    assert "| PPO |" in md and "CPUs" in md and "UTC" in md
    res = json.loads((out / "evaluation.json").read_text())
    assert res["_meta"]["train"]["timesteps"] == TINY["total_timesteps"]
    assert len(res["best constant"]["action"]) == len(res["_meta"]["action_names"])
