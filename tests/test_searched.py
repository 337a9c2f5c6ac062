"""discgym/searched.py (the schedule family the search works on, its shipped parameters) and
benchmarks/search_controller.py (the CMA-ES search)."""

import json
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import discgym  # noqa: F401
from discgym.baselines import run_episodes
from discgym.controllers import BandThermostat, flow_thermostat
from discgym.env import DiscReactorEnv
from discgym.searched import (
    SEARCHED,
    ScheduleController,
    band_thermostat_params,
    flow_thermostat_params,
    run_batch,
    searched,
    task_id,
)
from discgym.tasks import TASKS

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import search_controller  # noqa: E402


def _random_vectors(env, n, rng):
    b = ScheduleController.bounds(env)
    lo = np.array([v[0] for v in b.values()])
    hi = np.array([v[1] for v in b.values()])
    X = rng.uniform(lo, hi, (n, len(b)))
    X[0], X[1] = lo, hi  # the corners too
    return X


@pytest.mark.parametrize("env_id", sorted(TASKS))
def test_every_vector_within_bounds_maps_to_actions_in_the_action_space(env_id):
    env = gym.make(env_id)
    rng = np.random.default_rng(0)
    X = _random_vectors(env, 40, rng)
    env.observation_space.seed(0)
    obs = np.array([env.observation_space.sample() for _ in range(len(X))])
    real, _ = env.reset(seed=0)
    obs[2] = real
    c = ScheduleController.batch(env, X)
    a = c(obs)
    assert a.shape == (len(X), env.action_space.shape[0]) and a.dtype == np.float32
    assert np.all(np.isfinite(a)) and all(env.action_space.contains(row) for row in a)
    for x, o, row in zip(X[:5], obs[:5], a[:5]):  # one controller per vector: the same action
        one = ScheduleController.from_vector(env, x)(o)
        assert one.dtype == np.float32 and env.action_space.contains(one)
        np.testing.assert_allclose(one, row, rtol=0, atol=1e-6)


def test_vector_round_trips():
    env = gym.make("DiscJacket-v0")  # (with jacket_gain)
    X = _random_vectors(env, 5, np.random.default_rng(1))
    for x in X:
        c = ScheduleController.from_vector(env, x)
        assert np.array_equal(c.to_vector(), x)
        assert list(c.params()) == ScheduleController.names(env)
        np.testing.assert_allclose(ScheduleController.from_unit(env, ScheduleController.to_unit(
            env, x)), x, rtol=1e-12, atol=1e-12)
    assert "jacket_gain" in ScheduleController.names(env)
    flow = ScheduleController.names(gym.make("DiscFlow-v0"))
    assert "inlet_gain" in flow and "jacket_gain" not in flow


def test_bad_parameters_are_refused_naming_them():
    env = gym.make("DiscFlow-v0")
    with pytest.raises(TypeError, match="unexpected keyword argument 'setpiont_0'"):
        ScheduleController(env, setpiont_0=3.0)
    with pytest.raises(ValueError, match="wall_1"):
        ScheduleController(env, wall_1=1.5)
    with pytest.raises(ValueError, match="setpoint_2"):
        ScheduleController(env, setpoint_2=float("nan"))
    with pytest.raises(ValueError, match=r"x: expected shape \(14,\)"):
        ScheduleController.from_vector(env, np.zeros(12))
    X = _random_vectors(env, 3, np.random.default_rng(2))
    X[2, 9] = 2.0
    with pytest.raises(ValueError, match="stop_A"):
        ScheduleController.batch(env, X)
    c = ScheduleController.batch(env, X[:2])
    with pytest.raises(ValueError, match="obs: expected shape"):
        c(np.zeros((3, 24)))


def test_the_family_holds_the_flow_thermostat():
    env = gym.make("DiscFlow-v0", episode_steps=20)
    c, th = ScheduleController(env, **flow_thermostat_params(env)), flow_thermostat(env)
    obs, _ = env.reset(seed=3)
    for _ in range(20):
        a = th(obs)
        assert np.array_equal(c(obs), a)
        assert c.setpoint == pytest.approx(th.setpoint, rel=1e-12)
        obs, *_ = env.step(a)


def test_the_family_holds_the_band_thermostat():
    # (the dead band: heat only outside [t_low, t_high], feed until 0.6 of the episode is left)
    env = gym.make("DiscEconomic-v0", episode_steps=40)
    c, th = ScheduleController(env, **band_thermostat_params(env)), BandThermostat(env)
    assert c.params()["band"] == pytest.approx(2 ** 0.5)
    obs, _ = env.reset(seed=3)
    idle = 0
    for _ in range(40):
        a = th(obs)
        np.testing.assert_allclose(c(obs), a, rtol=0, atol=1e-6)
        idle += a[0] == 0.0
        obs, *_ = env.step(a)
    assert 0 < idle < 40  # (both sides of the band's edge were met)
    with pytest.raises(ValueError, match="heat_cost > 0"):
        band_thermostat_params(gym.make("DiscReactor-v0"))
    assert "band" not in ScheduleController.names(gym.make("DiscReactor-v0"))


def test_batch_and_single_evaluations_agree():
    env_id, kw = "DiscFlow-v0", {"episode_steps": 8}
    env = gym.make(env_id, **kw)
    X = _random_vectors(env, 3, np.random.default_rng(3))
    seeds = [3004, 3001, 3002]
    # 9 pairs in calls of at most 5 reactors: two calls of 5, the second padded
    R = run_batch(env_id, X, seeds, kw, max_reactors=5)
    for x, row in zip(X, R):
        single = run_episodes(env_id, lambda e, x=x: ScheduleController.from_vector(e, x),
                              seeds, kw).returns
        assert np.array_equal(single, row)


def test_the_shipped_parameters_load():
    assert "DiscFlow-v0" in SEARCHED
    env = gym.make("DiscFlow-v0")
    c = searched(env)
    assert isinstance(c, ScheduleController)
    assert c.params() == pytest.approx(SEARCHED["DiscFlow-v0"]["params"], rel=0, abs=0)
    assert SEARCHED["DiscFlow-v0"]["command"].startswith("python benchmarks/search_controller")
    obs, _ = env.reset(seed=0)
    assert env.action_space.contains(c(obs))
    with pytest.raises(ValueError, match="no searched controller for None"):
        searched(DiscReactorEnv())  # (made directly: no registered id)
    # the returns docs/tasks.md's table averages, on its first two evaluation seeds
    returns = run_episodes("DiscFlow-v0", searched, [1000, 1001]).returns
    assert returns.tolist() == [2.365777850337153, 3.2454035969323374]


@pytest.mark.parametrize("env_id, first_two", [
    ("DiscReactor-v0", [0.9586776859504127, 0.8981481481481483]),
    ("DiscKinetics-v0", [0.9338842975206605, 0.6388888888888888]),
    ("DiscEconomic-v0", [0.6165905358003555, 0.5814285528534057]),
    ("DiscJacket-v0", [0.9338842975206606, 0.8981481481481483]),
])
def test_every_task_has_its_searched_controller(env_id, first_two):
    # every task of the suite; its returns on the first two evaluation seeds of docs/tasks.md
    assert set(SEARCHED) == set(TASKS)
    env = gym.make(env_id)
    assert list(searched(env).params()) == ScheduleController.names(env)
    assert run_episodes(env_id, searched, [1000, 1001]).returns.tolist() == first_two


def test_the_task_is_found_from_any_env_of_it():
    """searched() finds its task from a made env, an env or vector env built from the task's
    class (no spec), and a reactor of the SB3 adapter given the task's spec (as
    agents/train_ppo.py builds it); an env of no task is refused, naming it."""
    import dataclasses

    for env_id, (env_cls, vec_cls) in TASKS.items():
        assert task_id(gym.make(env_id)) == env_id
        # (the base classes built directly may be any task: no id)
        mine = None if env_id == "DiscReactor-v0" else env_id
        assert task_id(env_cls()) == mine and task_id(vec_cls(num_envs=2)) == mine
    assert task_id(object()) is None
    pytest.importorskip("stable_baselines3")  # (the SB3 adapter: the agents extra)
    from discgym.sb3 import DiscReactorSB3VecEnv

    kw = dict(TASKS["DiscFlow-v0"][0].defaults)
    sb3 = DiscReactorSB3VecEnv(num_envs=2, **kw)
    reactor = sb3.get_attr("unwrapped", [0])[0]
    assert task_id(reactor) is None  # (built by keywords: no task to tell)
    sb3.venv.spec = dataclasses.replace(gym.spec("DiscFlow-v0"), kwargs=kw)
    assert task_id(reactor) == "DiscFlow-v0"
    assert searched(reactor).params() == SEARCHED["DiscFlow-v0"]["params"]
    assert task_id(object()) is None
    with pytest.raises(ValueError, match="no searched controller for None"):
        searched(object())


@pytest.mark.parametrize("args, message", [
    (["--budget-steps", "0"], "--budget-steps: expected an int >= 1"),
    (["--budget-steps", "10", "--tune-seeds", "990", "20"], "meet the evaluation seeds"),
    (["--budget-steps", "10", "--refine", "2", "0"], "--refine"),
    (["--budget-steps", "10", "--sigma0", "nan"], "--sigma0"),
    (["--budget-steps", "10", "--cma-seed", "0"], "--cma-seed"),
    (["--budget-steps", "10", "--eval-seeds", "3010", "10"], "--eval-seeds"),
    (["--budget-steps", "x"], "invalid int value"),
])
def test_the_search_refuses_bad_arguments_in_one_line(args, message, tmp_path, capsys):
    out = tmp_path / "s.json"
    with pytest.raises(SystemExit) as e:
        search_controller.main(["--env", "DiscFlow-v0", *args, "--out", str(out)])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not out.exists()


def test_one_tiny_generation_writes_its_json(tmp_path):
    out = tmp_path / "s.json"
    # the start (2 seeds) and one generation of 2 candidates: 6 episodes of 4 steps
    assert search_controller.main([
        "--env", "DiscFlow-v0", "--budget-steps", "24", "--episode-steps", "4",
        "--tune-seeds", "3000", "2", "--popsize", "2", "--refine", "1", "2",
        "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["budget"]["search_env_steps"] == 24 and len(data["history"]) == 1
    assert set(data["params"]) == set(ScheduleController.names(gym.make("DiscFlow-v0")))
    ScheduleController(gym.make("DiscFlow-v0"), **data["params"])  # within bounds
    assert [p.name for p in tmp_path.iterdir()] == ["s.json"]  # no partial file left
