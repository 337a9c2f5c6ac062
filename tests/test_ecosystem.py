"""What RL libraries that discgym did not write call: constructors with a config mapping,
Python's wording for an unknown keyword, flat infos with the same keys at reset and at step,
a vector env that pickles and deep-copies, and the SB3 adapter's per-reactor attributes.

The clients themselves (RLlib, TorchRL, RL Zoo, CleanRL-style scripts, video recorders) are
exercised in tests/test_clients.py."""

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import discgym  # noqa: F401  (registers the ids)
from discgym.env import DiscReactorEnv, ReactorConfig
from discgym.vector import DiscReactorVectorEnv

KW = dict(n_discs=60, episode_steps=5)


# ------------------------------------------------------------------ constructors
@pytest.mark.parametrize("cls", [DiscReactorEnv, DiscReactorVectorEnv])
def test_a_config_mapping_is_the_only_positional_argument(cls):
    """RLlib calls ``Env(env_config)`` with its EnvContext (a dict subclass)."""

    class EnvContext(dict):  # (what RLlib passes: a dict with extra attributes)
        worker_index = 1

    env = cls(EnvContext(KW, render_mode="rgb_array"))
    assert env.config.episode_steps == 5 and env.render_mode == "rgb_array"
    env = cls({"n_discs": 60}, episode_steps=5)  # a mapping and keywords together
    assert env.config.episode_steps == 5
    assert cls({}).config.episode_steps == 100  # RLlib's default env_config: {}
    name = cls.__name__
    with pytest.raises(TypeError, match=rf"^{name}.__init__\(\) got multiple values for "
                                        r"argument 'episode_steps'$"):
        cls({"episode_steps": 5}, episode_steps=6)
    with pytest.raises(TypeError, match=r"^config: .*mapping.*got 'rgb_array' \(str\)"):
        cls("rgb_array")
    with pytest.raises(TypeError, match=r"^config: keys must be argument names"):
        cls({1: 2})
    with pytest.raises(TypeError):
        cls({}, {})  # one positional argument only
    with pytest.raises(ValueError, match="^episode_steps"):  # checked as keywords are
        cls({"episode_steps": 0})


@pytest.mark.parametrize("make", [
    lambda **kw: DiscReactorEnv(**kw),
    lambda **kw: DiscReactorVectorEnv(**kw),
    lambda **kw: DiscReactorEnv({"frameskip": 1}),
    lambda **kw: DiscReactorVectorEnv({"frameskip": 1}),
    lambda **kw: gym.make("DiscReactor-v0", **kw),
    lambda **kw: gym.make_vec("DiscReactor-v0", num_envs=2,
                              vectorization_mode="vector_entry_point", **kw),
])
def test_an_unknown_keyword_gets_pythons_own_wording(make):
    """TorchRL passes ``frameskip=1`` and retries without it only on this wording
    (``gymnasium.make`` adds which id and kwargs it was)."""
    with pytest.raises(TypeError, match=r"Env.__init__\(\) got an unexpected keyword "
                                        r"argument 'frameskip'"):
        make(frameskip=1)


# ------------------------------------------------------------------ flat infos
def _check_flat(info: dict, cfg: ReactorConfig):
    assert list(info) == list(cfg.info_keys)
    for k, v in info.items():
        t = cfg.info_types[k]
        if t is np.bool_:  # (a 0-d array: see ReactorConfig.info_types)
            assert type(v) is np.ndarray and v.shape == () and v.dtype == np.bool_, (k, v)
        else:
            assert type(v) is t, (k, v)


@pytest.mark.parametrize("kw", [dict(KW), dict(scene="exchange", episode_steps=3),
                                dict(KW, feed="A")])
def test_infos_are_flat_with_the_same_keys_at_reset_and_step(kw):
    env = DiscReactorEnv(**kw)
    cfg = env.config
    names = cfg.species_names
    fed = [names[f] for f in cfg.feed]
    assert [k for k in cfg.info_keys if k.startswith("count_")] == [f"count_{s}" for s in names]
    assert [k for k in cfg.info_keys if k.startswith("injected_")] == [f"injected_{s}"
                                                                       for s in fed]
    assert [k for k in cfg.info_keys if k.startswith("inject_refused_")] == \
        [f"inject_refused_{s}" for s in fed]
    _, info = env.reset(seed=0)
    _check_flat(info, cfg)
    step_only = ["reward_product", "cost_heat", "cost_feed", "heat_energy", "wall_blocked",
                 "invalid_action"] + [f"injected_{s}" for s in fed] + \
        [f"inject_refused_{s}" for s in fed]
    assert all(info[k] == 0 for k in step_only)
    assert sum(info[f"count_{s}"] for s in names) == len(env.simulation)
    assert info["product"] == info[f"count_{names[cfg.product]}"]
    for _ in range(3):
        *_, info = env.step(env.action_space.sample())
        _check_flat(info, cfg)
        assert sum(info[f"count_{s}"] for s in names) == len(env.simulation)
        assert info["n_ref"] == env.unwrapped.core.episodes.n_ref[0]


def test_vector_env_infos_match_gymnasiums_sync_vector_env():
    """The native vector env's info has the keys SyncVectorEnv gives for the same reactors
    (the single env's, as arrays with ``_key`` masks), at reset and at step, in both
    autoreset modes that report."""
    for mode in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
        sync = gym.make_vec("DiscReactor-v0", num_envs=2, vectorization_mode="sync",
                            vector_kwargs={"autoreset_mode": mode}, **KW)
        native = gym.make_vec("DiscReactor-v0", num_envs=2,
                              vectorization_mode="vector_entry_point", autoreset_mode=mode,
                              **KW)
        so, si = sync.reset(seed=3)
        no, ni = native.reset(seed=3)
        seen_final = False
        assert np.array_equal(so, no)
        assert set(si) == set(ni)
        for k in ni:
            assert ni[k].dtype.kind == si[k].dtype.kind, k
            assert np.array_equal(ni[k], si[k]), k
        a = np.tile(np.array([0.5, 0.2, 1.0, 1.0], np.float32), (2, 1))
        for _ in range(KW["episode_steps"] + 1):
            so, sr, _, st, si = sync.step(a)
            no, nr, _, nt, ni = native.step(a)
            assert np.array_equal(so, no) and np.array_equal(sr, nr) and np.array_equal(st, nt)
            assert set(si) == set(ni)
            for k in ni:
                if k == "final_obs":
                    assert all(np.array_equal(p, q) for p, q in zip(ni[k], si[k]))
                elif k == "final_info":
                    assert set(ni[k]) == set(si[k])
                    for kk in ni[k]:
                        assert np.array_equal(ni[k][kk], si[k][kk]), kk
                else:
                    assert np.array_equal(ni[k], si[k]), k
            if mode == AutoresetMode.SAME_STEP and st.any():
                seen_final = True
        assert mode == AutoresetMode.NEXT_STEP or seen_final
        sync.close()
        native.close()


# ------------------------------------------------------------------ pickle, deepcopy
def _same(a, b):
    """Two step results (obs, reward, terminated, truncated, info) identical to the bit."""
    for x, y in zip(a[:4], b[:4]):
        assert np.array_equal(x, y)
    assert set(a[4]) == set(b[4])
    for k, v in a[4].items():
        w = b[4][k]
        if k == "final_info":
            _same((0,) * 4 + (v,), (0,) * 4 + (w,))
        elif k == "final_obs":
            assert all((p is None and q is None) or np.array_equal(p, q) for p, q in zip(v, w))
        else:
            assert np.array_equal(v, w), k


@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
def test_vector_env_pickles_and_deep_copies_and_continues_bit_identically(mode):
    venv = DiscReactorVectorEnv(num_envs=3, autoreset_mode=mode, **KW)
    acts = np.random.default_rng(1).uniform(-1, 1, (14, 3, 4)).astype(np.float32)
    with pytest.raises(gym.error.ResetNeeded):
        pickle.loads(pickle.dumps(venv)).step(acts[0])  # (before the first reset: picklable)
    venv.reset(seed=7)
    for a in acts[:4]:
        venv.step(a)
    twins = [pickle.loads(pickle.dumps(venv)), copy.deepcopy(venv)]
    for twin in twins:  # independent state: no array shared with the original
        assert not np.shares_memory(twin.core.state.rx.pos, venv.core.state.rx.pos)
        assert twin.simulations[1]._st is twin.core.state  # (handles on the twin's rows)
    # the first 10 steps cross two episode ends (5 steps each)
    for a in acts[4:]:
        ref = venv.step(a)
        for twin in twins:
            _same(ref, twin.step(a))
    for twin in twins:
        for s, t in zip(venv.simulations, twin.simulations):
            assert np.array_equal(s.positions, t.positions)
            assert s.get_state()["rng"] == t.get_state()["rng"]
    # and a reset with the same seed starts the same episode
    o, info = venv.reset(seed=2)
    for twin in twins:
        to, tinfo = twin.reset(seed=2)
        _same((o, 0, 0, 0, info), (to, 0, 0, 0, tinfo))


# ------------------------------------------------------------------ SB3 adapter
def test_sb3_adapter_attributes_and_methods_per_reactor_like_dummy_vec_env():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import DummyVecEnv

    from discgym.sb3 import DiscReactorSB3VecEnv

    ours = DiscReactorSB3VecEnv(num_envs=3, render_mode="rgb_array", render_size=32, **KW)
    ref = DummyVecEnv([lambda: gym.make("DiscReactor-v0", render_mode="rgb_array",
                                        render_size=32, **KW) for _ in range(3)])
    ours.seed(5)
    ref.seed(5)
    assert np.array_equal(ours.reset(), ref.reset())
    assert ours.reset_infos == ref.reset_infos  # flat, the same keys and values
    for name in ("render_mode", "observation_space", "action_space", "observation_names",
                 "action_names", "render_size"):
        got, want = ours.get_attr(name), ref.get_attr(name)
        assert len(got) == len(want) == 3
        assert all(g == w for g, w in zip(got, want)), name
    # per reactor: its own Simulation and generator, in the order of indices
    sims = ours.get_attr("simulation", indices=[2, 0])
    assert sims == [ours.venv.simulations[2], ours.venv.simulations[0]]
    assert [len(s) for s in ours.get_attr("simulation")] == \
        [len(s) for s in ref.get_attr("simulation")]
    assert ours.get_attr("np_random", 1)[0] is ours.venv.core.np_randoms[1]
    with pytest.raises(AttributeError):
        ours.get_attr("no_such_attribute")
    with pytest.raises(AttributeError):
        ours.get_attr("num_envs")  # (a batch's, not a reactor's, as in DummyVecEnv)
    # set_attr honours indices (kept per reactor, as DummyVecEnv keeps it on each env)
    ours.set_attr("tag", "x", indices=[1])
    ref.set_attr("tag", "x", indices=[1])
    assert ours.get_attr("tag", indices=1) == ref.get_attr("tag", indices=1) == ["x"]
    with pytest.raises(AttributeError):
        ours.get_attr("tag", indices=0)
    # a setting of the whole batch: all reactors at once, or a clear error
    with pytest.raises(ValueError, match="^attr_name: 'render_size' is one setting"):
        ours.set_attr("render_size", 16, indices=[0])
    ours.set_attr("render_size", 96)
    assert ours.venv.render_size == 96 and ours.get_attr("render_size") == [96] * 3
    with pytest.raises(AttributeError, match="cannot be set"):
        ours.set_attr("simulation", None)
    # env_method calls each reactor's method
    frames = ours.env_method("render", indices=[0, 2])
    assert len(frames) == 2 and frames[0].shape == (96, 96, 3)
    assert not np.array_equal(frames[0], frames[1])  # (different reactors)
    assert np.array_equal(frames[1], ours.venv.render()[2])
    assert ref.env_method("render", indices=[0])[0].shape == (32, 32, 3)
    with pytest.raises(AttributeError):
        ours.env_method("no_such_method")
    ours.set_attr("double", lambda x: 2 * x, indices=[0])
    assert ours.env_method("double", 4, indices=[0]) == [8]
    # the metadata stays the batch's (VecVideoRecorder reads render_fps)
    assert ours.metadata["render_fps"] == 10
    # an episode end: the same steps, terminal observations and autoreset infos
    a = np.tile(np.array([0.3, -0.2, 1.0, 0.5], np.float32), (3, 1))
    for _ in range(KW["episode_steps"]):
        o1, r1, d1, i1 = ours.step(a)
        o2, r2, d2, i2 = ref.step(a)
        assert np.array_equal(o1, o2) and np.allclose(r1, r2) and np.array_equal(d1, d2)
    assert d1.all()
    for x, y in zip(i1, i2):
        assert np.array_equal(x["terminal_observation"], y["terminal_observation"])
        assert x["TimeLimit.truncated"] == y["TimeLimit.truncated"]
        assert all(x[k] == y[k] for k in y if k not in ("terminal_observation",
                                                        "TimeLimit.truncated"))
    assert ours.reset_infos == ref.reset_infos
    assert ours.reset_infos[0]["time"] == 0.0
