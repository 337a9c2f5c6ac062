"""A configuration per reactor in one batch: ``DiscReactorVectorEnv(configs=...)``.

Each reactor of a batch made with a sequence of configurations follows, bit for bit, a lone
``DiscReactorEnv`` made with the batch's arguments and its own; a callable draws a
configuration per episode from a generator of its own (so the reactor's own draws stay those
of its single env); a configuration that cannot share the batch is refused naming it.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import discgym  # noqa: F401  (registers the envs)
from discgym.config import ROW_ARGUMENTS
from discgym.env import DiscReactorEnv
from discgym.vector import DiscReactorVectorEnv

BASE = dict(episode_steps=12, n_discs=60)
ROWS = [dict(heat_rate=1.5, size_range=(0.8, 1.2), count_jitter=0.3),
        dict(episode_steps=7, feed_budget=3, heat_cost=0.01, feed_cost=0.02),
        dict(temperature_range=(0.3, 4.0), wall_speed=0.1, inject_max=2, n_discs=40,
             activation_jitter=0.2),
        {}]


def _lockstep(venv, envs, seed, steps, rng):
    """Step ``venv`` and the single ``envs`` with the same actions; every observation,
    reward, truncation and info entry equal (NextStep autoreset: a reactor whose episode
    ended is reset by the next step, its single env by ``reset()``)."""
    R = venv.num_envs
    obs, info = venv.reset(seed=seed)
    for r, e in enumerate(envs):
        o, i = e.reset(seed=seed + r)
        assert np.array_equal(obs[r], o)
        assert all(info[k][r] == v for k, v in i.items())
    done = np.zeros(R, dtype=bool)
    A = venv.single_action_space.shape[0]
    ends = 0
    for _ in range(steps):
        a = rng.uniform(-1, 1, (R, A)).astype(np.float32)
        o, rew, term, trunc, info = venv.step(a)
        for r, e in enumerate(envs):
            if done[r]:
                so, si = e.reset()
                sr, st = 0.0, False
            else:
                so, sr, _, st, si = e.step(a[r])
            assert np.array_equal(o[r], so)
            assert rew[r] == sr and trunc[r] == st
            assert all(info[k][r] == v for k, v in si.items())
        done = term | trunc
        ends += int(done.sum())
    return ends


def test_each_reactor_of_a_mixed_batch_is_its_single_env_bit_for_bit():
    venv = DiscReactorVectorEnv(num_envs=len(ROWS), configs=ROWS, **BASE)
    envs = [DiscReactorEnv(**{**BASE, **row}) for row in ROWS]
    ends = _lockstep(venv, envs, 10, 30, np.random.default_rng(0))
    assert ends >= 5  # (episodes of 12 and 7 steps: the rows' own lengths)
    assert venv.limit.tolist() == [12, 7, 12, 12]
    # the batch's observation space holds every reactor's
    for e in envs:
        assert (venv.single_observation_space.low <= e.observation_space.low).all()
        assert (venv.single_observation_space.high >= e.observation_space.high).all()


def test_a_mixed_batch_is_the_same_bits_on_several_threads():
    a = DiscReactorVectorEnv(num_envs=4, configs=ROWS, threads=1, **BASE)
    b = DiscReactorVectorEnv(num_envs=4, configs=ROWS, **BASE)
    a.reset(seed=3)
    b.reset(seed=3)
    rng = np.random.default_rng(1)
    for _ in range(15):
        act = rng.uniform(-1, 1, (4, 4)).astype(np.float32)
        oa, ra, *_ = a.step(act)
        ob, rb, *_ = b.step(act)
        assert np.array_equal(oa, ob) and np.array_equal(ra, rb)


def test_a_callable_draws_a_configuration_per_episode_from_its_own_generator():
    drawn = []

    def draw(rng):
        row = dict(heat_rate=float(rng.uniform(1.2, 3.0)), episode_steps=int(rng.integers(4, 9)))
        drawn.append(row)
        return row

    venv = DiscReactorVectorEnv(num_envs=3, configs=draw, **BASE)
    venv.reset(seed=5)
    first = list(drawn)
    assert len(first) == 3
    rng = np.random.default_rng(2)
    for _ in range(20):
        venv.step(rng.uniform(-1, 1, (3, 4)).astype(np.float32))
    assert len(drawn) > 6  # every reset of a reactor drew again
    assert all(1.2 <= d["heat_rate"] <= 3.0 and 4 <= d["episode_steps"] <= 8 for d in drawn)
    # the same seed draws the same configurations, and each reactor is the single env made
    # with the configuration it drew
    drawn.clear()
    venv.reset(seed=5)
    assert drawn == first
    venv2 = DiscReactorVectorEnv(num_envs=3, configs=lambda rng: first[0], **BASE)
    _lockstep(venv2, [DiscReactorEnv(**{**BASE, **first[0]}) for _ in range(3)], 5, 12,
              np.random.default_rng(4))


def test_make_vec_passes_the_configurations():
    venv = gym.make_vec("DiscReactor-v0", num_envs=2, vectorization_mode="vector_entry_point",
                        configs=ROWS[:2], **BASE)
    venv.reset(seed=0)
    assert venv.unwrapped.limit.tolist() == [12, 7]
    venv.close()


@pytest.mark.parametrize("configs, error, match", [
    ([{"feed": "A"}, {}], ValueError, r"configs\[0\]: 'feed' cannot differ"),
    ([{"scene": "ideal_gas"}, {}], ValueError, r"configs\[0\]: 'scene' cannot differ"),
    ([{}, {"heat_rate": 0.5}], ValueError, r"configs\[1\]: heat_rate"),
    ([{}, {"episode_steps": True}], TypeError, r"configs\[1\]: episode_steps"),
    ([{}], ValueError, r"configs: need one mapping per reactor \(2\), got 1"),
    ([{}, ["heat_rate", 2.0]], TypeError, r"configs\[1\]: expected a mapping"),
    ({"heat_rate": 2.0}, TypeError, r"configs: expected None, a sequence"),
    ("heat_rate", TypeError, r"configs: expected None, a sequence"),
])
def test_a_configuration_that_cannot_share_the_batch_is_refused_naming_it(configs, error,
                                                                           match):
    with pytest.raises(error, match=match):
        DiscReactorVectorEnv(num_envs=2, configs=configs, **BASE)


def test_a_drawn_configuration_outside_the_batchs_observation_space_is_refused():
    venv = DiscReactorVectorEnv(num_envs=2, configs=lambda rng: {"size_range": (0.5, 1.6)},
                                **BASE)
    with pytest.raises(ValueError, match=r"configs\(\.\.\.\) for reactor 0: its observation "
                                         r"slot 'size' spans"):
        venv.reset(seed=0)
    ok = DiscReactorVectorEnv(num_envs=2, size_range=(0.5, 1.6),
                              configs=lambda rng: {"size_range": (0.7, 1.3)}, **BASE)
    ok.reset(seed=0)
    assert ok.core.episodes.size_max.tolist() == [1.3, 1.3]


def test_the_row_arguments_are_the_documented_ones():
    from pathlib import Path

    text = (Path(__file__).parents[1] / "docs" / "env.md").read_text()
    for name in ROW_ARGUMENTS:
        assert f"`{name}`" in text, name


def test_a_batch_of_one_reactor_takes_its_own_costs():
    row = dict(heat_cost=0.05, feed_cost=0.1)
    venv = DiscReactorVectorEnv(num_envs=1, configs=[row], **BASE)
    _lockstep(venv, [DiscReactorEnv(**{**BASE, **row})], 2, 8, np.random.default_rng(6))


def test_a_list_of_configurations_widens_the_observation_space():
    venv = DiscReactorVectorEnv(num_envs=2, configs=[{"size_range": (0.6, 2.0)}, {}], **BASE)
    k = venv.observation_names.index("size")
    assert venv.single_observation_space.high[k] == 2.0
    _lockstep(venv, [DiscReactorEnv(**{**BASE, "size_range": (0.6, 2.0)}), DiscReactorEnv(**BASE)],
              0, 6, np.random.default_rng(7))


@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
def test_a_refused_draw_changes_nothing(mode):
    calls = []

    def draw(rng):
        calls.append(1)
        return {"heat_rate": 1.5} if len(calls) <= 3 else {"feed": "A"}

    venv = DiscReactorVectorEnv(num_envs=2, configs=draw, autoreset_mode=mode,
                                **{**BASE, "episode_steps": 3})
    venv.reset(seed=0)  # draws 1 and 2
    a = np.zeros((2, 4), np.float32)
    for _ in range(2):
        venv.step(a)
    ep = venv.core.episodes
    if mode == "NextStep":
        venv.step(a)  # the episodes end
    steps, obs = ep.steps.copy(), ep.obs.copy()
    costs, configs = venv.core.episodes.heat_cost.copy(), list(venv.core.configs)
    with pytest.raises(ValueError, match=r"configs\(\.\.\.\) for reactor 1: 'feed' cannot"):
        venv.step(a)  # resets both: draw 3 is fine, draw 4 is refused
    assert np.array_equal(ep.steps, steps) and np.array_equal(ep.obs, obs)
    assert np.array_equal(venv.core.episodes.heat_cost, costs) and venv.core.configs == configs


def test_a_reset_after_a_state_of_another_generator_kind():
    import numpy.random as npr

    env = DiscReactorEnv(**BASE)
    env.reset(seed=0)
    s = env.unwrapped.simulation.get_state()
    s["rng"] = npr.MT19937(1).state
    env.unwrapped.simulation.set_state(s)
    env.step(np.zeros(4, np.float32))
    o1, _ = env.reset(seed=3)
    o2, _ = DiscReactorEnv(**BASE).reset(seed=3)
    assert np.array_equal(o1, o2)
