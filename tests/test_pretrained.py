"""The trained agents shipped with the package (``discgym.pretrained``): the flagship's three
training seeds load with numpy alone (no code run, no torch), act within their action
bounds, and reproduce the returns recorded with them when they were exported
(``agents/export_policy.py``, which also checked them against the trained models)."""

import json
from pathlib import Path

import golden
import gymnasium as gym
import numpy as np
import pytest

import discgym  # noqa: F401  (registers the tasks)
from discgym import pretrained

# (returns are float bits of whole trajectories: they hold where the golden fingerprints do)
_GOLDEN = json.loads((Path(__file__).parent / "golden.json").read_text())

AGENTS = [(e, s) for e, seeds in pretrained.available().items() for s in seeds]


def test_the_flagship_agents_ship():
    assert pretrained.available().get("DiscFlow-v0") == [0, 1, 2]


def test_their_files_hold_plain_arrays_only():
    for f in pretrained.FOLDER.glob("*/*.npz"):
        with np.load(f, allow_pickle=False) as z:  # (an object array would raise here)
            assert all(z[k].dtype.kind == "f" for k in z.files), f


def _episode(env_id, agent, seed):
    env = gym.make(env_id)
    obs, _ = env.reset(seed=seed)
    policy, total, done = agent.policy(env), 0.0, False
    while not done:
        obs, r, terminated, truncated, _ = env.step(policy(obs))
        total += float(r)
        done = terminated or truncated
    env.close()
    return total


@pytest.mark.parametrize("env_id, seed", AGENTS)
def test_an_agent_reproduces_its_recorded_returns(env_id, seed):
    if golden.platform_key() not in golden.verified_platforms(_GOLDEN):
        pytest.skip(f"trajectories are checked bit for bit on {golden.verified_platforms(_GOLDEN)}"
                    f" only, this is {golden.platform_key()}")
    agent = pretrained.load(env_id, seed)
    recorded = agent.info["returns"]
    assert len(recorded) >= 2
    for s in sorted(recorded)[:2]:
        assert _episode(env_id, agent, int(s)) == pytest.approx(recorded[s], rel=1e-9, abs=1e-12)


def test_an_agent_acts_within_its_bounds():
    agent = pretrained.load("DiscFlow-v0", 0)
    dim = agent.layers[0][0].shape[1]
    rng = np.random.default_rng(0)
    for o in rng.normal(0.0, 100.0, size=(50, dim)):
        a = agent.decide(o)
        assert a.dtype == np.float32 and np.all(np.abs(a) <= 1.0)
    assert repr(agent) == "<discgym.pretrained.Agent DiscFlow-v0 seed 0>"


def test_an_agent_refuses_another_task_and_a_wrong_shaped_observation():
    agent = pretrained.load("DiscFlow-v0", 0)
    with pytest.raises(ValueError, match="^env: .* DiscReactor-v0"):
        agent.policy(gym.make("DiscReactor-v0"))
    for bad in (np.zeros(1), np.zeros(agent.layers[0][0].shape[1] // 2),
                np.zeros((2, agent.layers[0][0].shape[1]))):
        with pytest.raises(ValueError, match="^agent_obs: expected shape"):
            agent.decide(bad)


@pytest.mark.parametrize("kwargs, field", [(dict(env_id="DiscNope-v0"), "env_id"),
                                           (dict(env_id=["DiscFlow-v0"]), "env_id"),
                                           (dict(seed=7), "seed"), (dict(seed=True), "seed"),
                                           (dict(seed="0"), "seed")])
def test_load_refuses_what_is_not_shipped_naming_it(kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}:"):
        pretrained.load(**kwargs)
