"""Copies of a DiscReactorEnv mid-episode (``copy.deepcopy``, pickle, ``clone()``) continue bit
for bit as the original would under the same actions: observations, rewards, infos, the
episode's end and the next unseeded reset (the env's own ``np_random``). The planner of
``discgym.oracle`` relies on it."""

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

import discgym  # noqa: F401  (registers the env)
from discgym.env import DiscReactorEnv

KW = dict(n_discs=80, episode_steps=40)
COPIERS = {
    "deepcopy": copy.deepcopy,
    "pickle": lambda e: pickle.loads(pickle.dumps(e)),
    "clone": lambda e: e.clone(),
}


def same(a, b):
    """Exact equality of nested step outputs (arrays by bytes and dtype, floats by ==)."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    return type(a) is type(b) and a == b


def actions(n, seed):
    """Random actions that heat and cool, move the wall both ways and inject."""
    return np.random.default_rng(seed).uniform(-1, 1, (n, 4)).astype(np.float32)


def rest_of_episode(env, acts):
    out = [env.step(a) for a in acts]
    # the next unseeded reset draws from the env's np_random
    out.append(env.reset())
    out.append(env.step(acts[0]))
    return out


@pytest.mark.parametrize("how", sorted(COPIERS))
def test_a_copy_mid_episode_continues_bit_for_bit(how):
    acts = actions(KW["episode_steps"], 7)
    k = 25  # copy after 25 steps: injections and wall moves both ways have happened
    ref = DiscReactorEnv(**KW)
    ref.reset(seed=11)
    infos = [ref.step(a)[4] for a in acts[:k]]
    assert sum(v for i in infos for k, v in i.items() if k.startswith("injected_")) > 0
    sizes = [i["size"] for i in infos]
    assert min(sizes) < 1.0 and np.any(np.diff(sizes) > 0) and np.any(np.diff(sizes) < 0)
    expected = rest_of_episode(ref, acts[k:])
    assert expected[-3][3] is True  # the episode's last step truncates

    env = DiscReactorEnv(**KW)
    env.reset(seed=11)
    for a in acts[:k]:
        env.step(a)
    twin = COPIERS[how](env)
    assert twin.simulation is not env.simulation and twin.np_random is not env.np_random
    # the copy runs first: it must not disturb the original, nor the original it
    got_twin = rest_of_episode(twin, acts[k:])
    got_env = rest_of_episode(env, acts[k:])
    assert same(got_twin, expected)
    assert same(got_env, expected)


def test_copies_of_copies_and_of_the_wrapped_env():
    """A clone of a clone, and a deepcopy of the gymnasium.make stack's unwrapped env."""
    env = gym.make("DiscReactor-v0", **KW)
    env.reset(seed=3)
    acts = actions(20, 1)
    for a in acts[:5]:
        env.step(a)
    u = env.unwrapped
    twins = [u.clone().clone(), copy.deepcopy(u)]
    expected = [u.step(a) for a in acts[5:]]
    for t in twins:
        assert same([t.step(a) for a in acts[5:]], expected)


def test_a_clone_shares_only_the_frozen_config():
    env = DiscReactorEnv(**KW)
    env.reset(seed=0)
    env.step(actions(1, 0)[0])
    c = env.clone()
    assert c.config is env.config
    assert c.simulation.scene is env.simulation.scene
    for name, value in vars(env).items():
        if isinstance(value, np.ndarray):
            assert getattr(c, name) is not value, name
    assert c.action_space is not env.action_space
    assert c.action_space.np_random is not env.action_space.np_random
    # stepping the clone leaves the original where it was
    before = env.simulation.get_state()
    c.step(actions(1, 1)[0])
    after = env.simulation.get_state()
    assert same({k: v for k, v in before.items() if k != "bounds"},
                {k: v for k, v in after.items() if k != "bounds"})


def test_a_clone_before_reset_needs_a_reset():
    c = DiscReactorEnv(**KW).clone()
    with pytest.raises(gym.error.ResetNeeded):
        c.step(np.zeros(4, np.float32))
    obs, _ = c.reset(seed=0)
    assert obs.shape == (len(c.observation_names),)
