"""Ranges a float cannot map, controllers on every env the env accepts, and the SB3 adapter's
per-reactor calls.

- The env's maps that divide by an end of a range or by a ratio of its ends (the heat
  control's clamps ``low / kT`` and ``high / kT``, the jacket's ``low (high / low) ** u``,
  ``heat_rate ** a`` at a = -1) must stay finite and invertible in float64: a range's low end
  must be a normal float, with ``heating="jacket"`` ``high / low`` finite (and ``high`` within
  float32, the ``jacket_kT`` observation's bound), and ``heat_rate <= 1 / 2.2250738585072014e-308``.
  Beyond, construction refuses naming the argument; at the edges, every action steps finite.
- Every controller (and the heuristic, the setpoint interface and the rollout oracle built on
  them) gives finite actions inside the action space on the degenerate envs the env accepts:
  ``heat_rate=1`` (no heat action changes kT: the heat action is 0), a jacket range of one
  value (the jacket is fixed: 0), a fixed wall, no feed, one-step episodes.
- ``env_method("get_wrapper_attr", ...)`` and gymnasium's other ``*_wrapper_attr`` methods,
  ``get_attr``, ``set_attr`` and ``has_attr`` of the SB3 adapter answer as ``DummyVecEnv``'s
  over the single env do, with indices.
"""

import math
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import discgym  # noqa: F401  (registers the tasks)
from discgym.arguments import env_scene as _scene
from discgym.baselines import HeuristicPolicy, reactor_heuristic, reactor_oracle_candidates
from discgym.config import FLOAT_NORMAL_MIN, HEAT_RATE_MAX
from discgym.controllers import (
    AdaptiveThermostat,
    BandThermostat,
    JacketThermostat,
    SetpointActions,
    Thermostat,
    flow_thermostat,
)
from discgym.env import DiscReactorEnv
from discgym.oracle import RolloutOracle

TINY = FLOAT_NORMAL_MIN  # 2.2250738585072014e-308
SUBNORMALS = [5e-324, 1e-310, float(np.nextafter(TINY, 0.0))]
FAST = dict(n_discs=30, episode_steps=4, step_time=0.05)  # one kernel step per env step


def _routes(env_id, **kw):
    """The four ways of building an env (each a thunk)."""
    cls = gym.registry[env_id].entry_point
    return {
        "make": lambda: gym.make(env_id, **kw),
        "make_vec": lambda: gym.make_vec(env_id, num_envs=2, **kw),
        "class": lambda: gym.envs.registration.load_env_creator(cls)(**kw),
        "vector_class": lambda: gym.envs.registration.load_env_creator(
            gym.registry[env_id].vector_entry_point)(num_envs=2, **kw),
    }


def _sound_steps(env, actions):
    """Step ``env`` (a single env) with ``actions``: finite rewards, finite observations in
    the observation space."""
    obs, _ = env.reset(seed=0)
    assert np.isfinite(obs).all() and env.observation_space.contains(obs)
    for a in actions:
        obs, r, *_ = env.step(np.asarray(a, np.float32))
        assert math.isfinite(r), a
        assert np.isfinite(obs).all() and env.observation_space.contains(obs), a


# ------------------------------------------------------------------- ranges a float maps
@pytest.mark.parametrize("low", SUBNORMALS)
@pytest.mark.parametrize("env_id, name, high", [
    ("DiscJacket-v0", "temperature_range", 6.0),  # heating="jacket"
    ("DiscReactor-v0", "temperature_range", 8.0),  # heating="scale"
    ("DiscReactor-v0", "size_range", 1.4),
    ("DiscFlow-v0", "feed_temperature", 2.0),
])
@pytest.mark.parametrize("route", ["make", "make_vec", "class", "vector_class"])
def test_a_subnormal_low_end_is_refused_naming_the_range(low, env_id, name, high, route):
    with pytest.raises(ValueError, match=rf"^{name}: the low end .* is a subnormal float64; "
                                         r"need low >= 2\.2250738585072014e-308"):
        _routes(env_id, **{name: (low, high)})[route]()


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_the_reported_denormal_jacket_range_is_refused(integrator):
    # (accepted before: the jacket became inf on the first step and the reward NaN)
    with pytest.raises(ValueError, match=r"^temperature_range: the low end 1e-310"):
        gym.make("DiscJacket-v0", temperature_range=(1e-310, 6.0), integrator=integrator)


def test_a_jacket_ratio_beyond_float64_is_refused_and_the_largest_one_steps_finite():
    # the jacket scene's walls may reach 6.7e7: low 1e-301 makes high / low overflow
    with pytest.raises(ValueError, match=r"^temperature_range: with heating='jacket' the "
                                         r"jacket is set to low x \(high / low\)"):
        DiscReactorEnv(scene="jacket", heating="jacket", temperature_range=(1e-301, 6e7))
    low = 6e7 / sys.float_info.max  # the smallest low end of high 6e7: a finite ratio
    low = float(np.nextafter(low, 1.0))
    assert math.isfinite(6e7 / low) and low >= TINY
    env = DiscReactorEnv(scene="jacket", heating="jacket", temperature_range=(low, 6e7),
                         **FAST)
    # (the jacket's extremes, its geometric mean, a NaN that keeps the jacket)
    _sound_steps(env, [[-1, 0, 0, 0], [0, 0, 0, 0], [np.nan, 0, 0, 0], [0.999, 0, 0, 0],
                       [-0.3, 0, 1, 1]])


@pytest.mark.parametrize("integrator", ["step", "event"])
@pytest.mark.parametrize("heating, scene, rng", [
    ("scale", "reactor", (TINY, 8.0)),
    ("scale", "reactor", (TINY, 1e300)),  # (scale mode: no map by high / low)
    ("scale", "reactor", (1.5, 1.5)),
    ("jacket", "jacket", (6.0 / 1e308, 6.0)),
    ("jacket", "jacket", (1.5, 1.5)),
    ("jacket", "jacket", (0.3, 6.0)),
])
def test_accepted_ranges_at_their_edges_step_finite(integrator, heating, scene, rng):
    env = DiscReactorEnv(scene=scene, heating=heating, temperature_range=rng,
                         heat_rate=1e300 if heating == "scale" else 2.0,
                         integrator=integrator, **FAST)
    _sound_steps(env, [[-1, 0, 0, 0], [-1, 0, 0, 0], [0.5, 0, 0, 0], [np.nan, 0, 0, 0],
                       [-1, 0, 1, 1], [0.0, 1, 0, 0]])
    assert env.simulation.temperature() > 0.0  # (cooled to the low end, never to 0)


def test_heat_rate_up_to_one_over_the_smallest_normal_and_no_further():
    assert HEAT_RATE_MAX == 1.0 / TINY and 1.0 / HEAT_RATE_MAX >= TINY
    for bad in (float(np.nextafter(HEAT_RATE_MAX, math.inf)), 1e308, sys.float_info.max):
        for build in _routes("DiscReactor-v0", heat_rate=bad).values():
            with pytest.raises(ValueError, match=r"^heat_rate: need a number in \[1, "
                                                 r"4\.49423e\+307\].*normal float64"):
                build()
    env = DiscReactorEnv(heat_rate=HEAT_RATE_MAX, temperature_range=(1e-300, 1e300), **FAST)
    _sound_steps(env, [[-1, 0, 0, 0], [-1, 0, 0, 0], [1, 0, 0, 0], [0.01, 0, 0, 0]])


def test_a_jacket_range_beyond_float32_is_refused_as_an_observation_bound():
    import dataclasses

    s = _scene("jacket")
    heavy = s.replace(species=[dataclasses.replace(sp, mass=sp.mass * 1e35)
                               for sp in s.species])
    assert heavy.max_wall_temperature() > 1e39  # (the wall may be that hot)
    with pytest.raises(ValueError, match=r"^temperature_range: with heating='jacket' the "
                                         r"high end 1e\+39 is the bound of the jacket_kT"):
        DiscReactorEnv(scene=heavy, heating="jacket", temperature_range=(0.3, 1e39))
    env = DiscReactorEnv(scene=heavy, heating="jacket", temperature_range=(0.3, 3e38))
    assert np.isfinite(env.observation_space.high).all()


# --------------------------------------------------------- controllers on degenerate envs
def _setpoint_policy(env):
    return SetpointActions(env, hold=2).policy(lambda o: np.array([0.4, -1, 1, 1], np.float32))


def _residual_policy(env):
    law = SetpointActions(env, hold=2, base="discgym.controllers.Thermostat")
    return law.policy(lambda o: np.array([0.5, 0.0, 0.0, 0.0], np.float32))


CONTROLLERS = {
    "DiscReactor-v0": [Thermostat, reactor_heuristic, _setpoint_policy, _residual_policy],
    "DiscKinetics-v0": [AdaptiveThermostat],
    "DiscEconomic-v0": [BandThermostat],
    "DiscJacket-v0": [JacketThermostat],
    "DiscFlow-v0": [flow_thermostat],
}
#: env arguments the env accepts that make a controller's quantity zero or degenerate
DEGENERATE = {
    "heat_rate 1": dict(heat_rate=1.0),
    "heat_rate just above 1": dict(heat_rate=float(np.nextafter(1.0, 2.0))),
    # (a budget the reactor at size 1 can hold: DiscFlow-v0's 400 is for its largest size)
    "fixed wall": dict(size_range=(1.0, 1.0), feed_budget=300),
    "no feed": dict(inject_max=0, feed_budget=0),
    "one-step episodes": dict(episode_steps=1),
}
JACKET_DEGENERATE = {
    "one-value jacket": dict(temperature_range=(1.5, 1.5)),
    "jacket ratio one ulp": dict(temperature_range=(1.9999999999999998, 2.0)),
    "fixed wall": dict(size_range=(1.0, 1.0)),
    "no feed": dict(inject_max=0, feed_budget=0),
}
CASES = [(env_id, make, case, kw)
         for env_id, makers in CONTROLLERS.items() for make in makers
         for case, kw in (JACKET_DEGENERATE if env_id == "DiscJacket-v0"
                          else DEGENERATE).items()]


def _run_controller(env, policy, steps=4):
    """Actions of ``policy`` over ``steps`` steps (reset at an episode's end): each finite and
    in the action space, with numpy's warnings as errors (a division by zero there warns)."""
    obs, _ = env.reset(seed=3)
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for _ in range(steps):
            a = np.asarray(policy(obs))
            assert a.shape == env.action_space.shape and a.dtype == np.float32
            assert np.isfinite(a).all() and env.action_space.contains(a), a
            out.append(a)
            obs, r, term, trunc, _ = env.step(a)
            assert math.isfinite(r)
            if term or trunc:
                obs, _ = env.reset()
                if hasattr(policy, "reset"):
                    policy.reset()
    return np.array(out)


@pytest.mark.parametrize("env_id, make, case, kw", CASES,
                         ids=[f"{e}-{getattr(m, '__name__', m)}-{c}" for e, m, c, _ in CASES])
def test_every_controller_acts_finitely_on_every_degenerate_env(env_id, make, case, kw):
    env = gym.make(env_id, **{"n_discs": 30, "step_time": 0.05, **kw})
    acts = _run_controller(env, make(env))
    if case == "heat_rate 1" or case == "one-value jacket":
        # no heat action changes anything: the controllers' is 0 (no-op)
        assert (acts[:, 0] == 0.0).all()


def test_the_heuristic_policy_refuses_a_heat_rate_the_env_would():
    names = gym.make("DiscReactor-v0").unwrapped.observation_names
    for bad, exc in ((0.5, ValueError), (0.0, ValueError), (math.inf, ValueError),
                     (math.nan, ValueError), (True, TypeError), ("2", TypeError)):
        with pytest.raises(exc, match="^heat_rate: "):
            HeuristicPolicy(names, heat_rate=bad)
    # (0 used to mean the default silently; None still does)
    assert HeuristicPolicy(names, heat_rate=None).log_rate == math.log(2.0)
    pol = HeuristicPolicy(names, heat_rate=1.0)
    obs = gym.make("DiscReactor-v0").reset(seed=0)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a = pol(np.stack([obs, obs]))
    assert (a[:, 0] == 0.0).all() and np.isfinite(a).all()


def test_a_controller_that_needs_a_slot_the_env_lacks_refuses_naming_its_argument():
    env = gym.make("DiscReactor-v0")  # (no observe_reactions: no reaction counts)
    with pytest.raises(ValueError, match=r"^main: the env observes no slot "
                                         r"'reactions\[A \+ B -> C\]'.*observe_reactions"):
        AdaptiveThermostat(env)
    env = gym.make("DiscKinetics-v0")
    with pytest.raises(ValueError, match=r"^product: the env observes no slot 'fraction_Q'"):
        AdaptiveThermostat(env, product="Q")


@pytest.mark.parametrize("low, high", [(1e-310, 3.2), (5e-324, 1.0), (1e-300, 1e10)])
def test_the_setpoint_range_is_a_map_a_float_can_compute(low, high):
    env = gym.make("DiscReactor-v0")
    with pytest.raises(ValueError, match=r"^kT_low, kT_high: expected 2\.2250738585072014e-308"):
        SetpointActions(env, kT_low=low, kT_high=high)
    law = SetpointActions(env, kT_low=TINY, kT_high=1.0)
    assert np.isfinite(law.setpoint(np.linspace(-1, 1, 9))).all()


@pytest.mark.parametrize("env_id, kw", [
    ("DiscReactor-v0", dict(heat_rate=1.0)),
    ("DiscKinetics-v0", dict(heat_rate=1.0)),
    ("DiscJacket-v0", dict(temperature_range=(1.5, 1.5))),
])
def test_the_oracle_on_its_controller_acts_finitely_on_degenerate_envs(env_id, kw):
    from discgym.baselines import TASK_BASELINES

    env = gym.make(env_id, n_discs=30, step_time=0.05, episode_steps=3, **kw)
    base = TASK_BASELINES[env_id].controller(env)
    oracle = RolloutOracle(env, base, reactor_oracle_candidates, horizon=2)
    _run_controller(env, oracle, steps=3)
    assert oracle.stats["rollouts"] > 0


# ------------------------------------------------------------ SB3: DummyVecEnv's calls
SB3_KW = dict(n_discs=40, episode_steps=3, render_mode="rgb_array", render_size=24)


@pytest.fixture(scope="module")
def pair():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import DummyVecEnv

    from discgym.sb3 import DiscReactorSB3VecEnv

    ours = DiscReactorSB3VecEnv(num_envs=3, **SB3_KW)
    ref = DummyVecEnv([lambda: gym.make("DiscReactor-v0", **SB3_KW) for _ in range(3)])
    ours.seed(4)
    ref.seed(4)
    assert np.array_equal(ours.reset(), ref.reset())
    return ours, ref


INDICES = [None, 1, [2], [2, 0], [0, 1, 2]]
NAMES = ["render_mode", "render_size", "observation_names", "action_names",
         "observation_space", "action_space"]


def _same(x, y):
    if isinstance(x, np.ndarray):
        return np.array_equal(x, y)
    return x == y


@pytest.mark.parametrize("indices", INDICES, ids=str)
def test_get_wrapper_attr_through_env_method_as_dummy_vec_env(pair, indices):
    ours, ref = pair
    for name in NAMES:
        for call in (lambda v, n: v.env_method("get_wrapper_attr", n, indices=indices),
                     lambda v, n: v.get_attr(n, indices=indices)):
            got, want = call(ours, name), call(ref, name)
            assert len(got) == len(want) and all(map(_same, got, want)), name
    # per reactor: its own simulation, in the order of the indices
    sims = ours.env_method("get_wrapper_attr", "simulation", indices=indices)
    assert sims == [ours.venv.simulations[i] for i in ours._targets(indices)]
    assert [len(s) for s in sims] == \
        [len(s) for s in ref.env_method("get_wrapper_attr", "simulation", indices=indices)]
    for v in (ours, ref):
        with pytest.raises(AttributeError):
            v.env_method("get_wrapper_attr", "no_such_attribute", indices=indices)


@pytest.mark.parametrize("indices", INDICES, ids=str)
def test_has_and_set_wrapper_attr_as_dummy_vec_env(pair, indices):
    ours, ref = pair
    for v in (ours, ref):
        for name, has in (("simulation", True), ("render_size", True), ("nope", False)):
            assert v.env_method("has_wrapper_attr", name, indices=indices) == \
                [has] * len(v._get_indices(indices))
        assert v.has_attr("simulation") and not v.has_attr("nope")
    tag = "tag_" + "".join(c for c in str(indices) if c.isalnum())
    # without force nothing is set where the name does not exist, with it, per reactor
    results = [v.env_method("set_wrapper_attr", tag, 1, force=False, indices=indices)
               for v in (ours, ref)]
    assert results[0] == results[1] == [False] * len(ours._targets(indices))
    assert not ours.has_attr(tag) and not ref.has_attr(tag)
    results = [v.env_method("set_wrapper_attr", tag, 2, indices=indices) for v in (ours, ref)]
    assert results[0] == results[1] == [True] * len(ours._targets(indices))
    for v in (ours, ref):
        assert v.get_attr(tag, indices=indices) == [2] * len(ours._targets(indices))
        assert v.env_method("get_wrapper_attr", tag, indices=indices) == \
            [2] * len(ours._targets(indices))
        others = [i for i in range(3) if i not in ours._targets(indices)]
        if others:
            with pytest.raises(AttributeError):
                v.get_attr(tag, indices=others)
    # set_attr then get_wrapper_attr, and a method set per reactor
    for v in (ours, ref):
        v.set_attr("double", lambda x: 2 * x, indices=indices)
        assert v.env_method("double", 5, indices=indices) == [10] * len(ours._targets(indices))


def test_a_batch_setting_through_set_wrapper_attr_follows_set_attrs_rule(pair):
    ours, ref = pair
    with pytest.raises(ValueError, match=r"^attr_name: 'render_size' is one setting"):
        ours.env_method("set_wrapper_attr", "render_size", 16, indices=[0])
    assert ours.venv.render_size == 24
    assert ours.env_method("set_wrapper_attr", "render_size", 32) == [True] * 3
    assert ref.env_method("set_wrapper_attr", "render_size", 32) == [True] * 3
    assert ours.get_attr("render_size") == ref.get_attr("render_size") == [32] * 3
    assert [f.shape for f in ours.env_method("render", indices=[1, 2])] == \
        [f.shape for f in ref.env_method("render", indices=[1, 2])] == [(32, 32, 3)] * 2
    # a Reactor view (get_attr("unwrapped")) refuses a batch setting rather than shadow it
    reactor = ours.get_attr("unwrapped", indices=[1])[0]
    with pytest.raises(ValueError, match=r"^attr_name: 'render_size' is one setting"):
        reactor.render_size = 8
    with pytest.raises(ValueError, match=r"^attr_name: 'render_size' is one setting"):
        reactor.set_wrapper_attr("render_size", 8)
    with pytest.raises(AttributeError, match="cannot be set"):
        ours.env_method("set_wrapper_attr", "simulation", None, indices=[0])
    assert ours.get_attr("render_size") == [32] * 3


def test_batch_shaped_names_set_per_reactor_do_not_replace_the_batchs(pair):
    ours, ref = pair
    for v in (ours, ref):
        v.set_attr("num_envs", 7, indices=[1])
        assert v.get_attr("num_envs", indices=[1]) == [7]
    assert ours.num_envs == ours.venv.num_envs == 3
    for v in (ours, ref):  # (the others have none)
        with pytest.raises(AttributeError):
            v.get_attr("num_envs", indices=[0, 2])
    # ("step" set on every reactor is theirs; the batch still steps as DummyVecEnv's envs)
    ours.set_attr("step", "a reactor's")
    assert ours.get_attr("step") == ["a reactor's"] * 3
    o1, r1, d1, _ = ours.step(np.zeros((3, 4), np.float32))
    o2, r2, d2, _ = ref.step(np.zeros((3, 4), np.float32))
    assert np.array_equal(o1, o2) and np.array_equal(d1, d2)
