"""Arguments of DiscReactor-v0 and its vector env, and the actions their ``step`` takes.

Every constructor argument is swept with bad values (NaN, +-inf, negative, zero where
invalid, huge, bool, wrong type, empty sequences) through every way of building the env
(``DiscReactorEnv``, ``DiscReactorVectorEnv``, ``gymnasium.make``, ``gymnasium.make_vec``):
each is refused at construction with ``TypeError`` / ``ValueError`` whose message starts with
the argument's name. The derived limits are checked at their edges (the largest accepted
value works, one more is refused), and numpy scalars are accepted as the numbers they are.
Actions of any shape or dtype but the expected ones are refused naming both shapes, and a
refused action changes nothing (a twin env stepped in lockstep sees the same next step).
"""

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import discgym as dg
from discgym.env import (
    DEFAULTS,
    FLOAT_EXACT,
    INT_MAX,
    MAX_RENDER_SIZE,
    DiscReactorEnv,
    ReactorConfig,
    lattice_sites,
)
from discgym.vector import DiscReactorVectorEnv

NAN, INF = float("nan"), float("inf")
SMALL = dict(n_discs=40, episode_steps=5)  # quick to build and to step

# ---------------------------------------------------------------------------- the sweep

# values that are bad for every numeric argument: (value, exception)
_NONFINITE = [(NAN, ValueError), (INF, ValueError), (-INF, ValueError),
              (np.float64(NAN), ValueError), (np.float32(INF), ValueError)]
_NOT_A_NUMBER = [(True, TypeError), (np.bool_(False), TypeError), ("1", TypeError),
                 ([1], TypeError), (1 + 0j, TypeError), ({1: 1}, TypeError)]
_WHOLE = _NONFINITE + _NOT_A_NUMBER + [(-1, ValueError), (2.5, ValueError),
                                       (np.float32(1.5), ValueError), (10**400, ValueError),
                                       (None, TypeError)]
_NOT_NONE = [v for v in _WHOLE if v[0] is not None]  # (for arguments that may be None)
_REAL = _NONFINITE + _NOT_A_NUMBER + [(None, TypeError), (10**400, ValueError)]
_PAIR = [((NAN, 8.0), ValueError), ((0.2, INF), ValueError), ((-1.0, 1.0), ValueError),
         ((0.0, 1.0), ValueError), ((2.0, 0.5), ValueError), ((0.5,), ValueError),
         ((0.5, 1.0, 2.0), ValueError), ([], ValueError), (np.zeros((2, 2)), TypeError),
         (1.0, TypeError), ("ab", TypeError), (None, TypeError), ((True, 2.0), TypeError),
         (("0.5", 2.0), TypeError), ({0.5, 2.0}, TypeError), ((0.5, 1 + 0j), TypeError)]

#: argument -> [(bad value, exception[, name the message starts with])]
BAD = {
    "scene": [(3, TypeError), (None, TypeError), (["reactor"], TypeError),
              ("no_such_scene_file.toml", OSError), ("ideal_gas", ValueError, "product")],
    "n_discs": _NOT_NONE + [(0, ValueError), (10**6, ValueError), (1e300, ValueError),
                         (987, ValueError), (1, ValueError)],
    "episode_steps": _WHOLE + [(0, ValueError), (2**63, ValueError),
                               (INT_MAX // 10 + 1, ValueError), (1e30, ValueError)],
    "step_time": _REAL + [(0.0, ValueError), (-0.5, ValueError), (0.013, ValueError),
                          (0.1 + 1e-8, ValueError), (1e300, ValueError), (1e308, ValueError),
                          (0.05 * 2**62, ValueError, "episode_steps")],
    "heat_rate": _REAL + [(0.0, ValueError), (-2.0, ValueError), (0.5, ValueError)],
    "temperature_range": _PAIR,
    "size_range": _PAIR + [((1.2, 1.4), ValueError), ((0.5, 0.9), ValueError),
                           ((0.5, 1e39), ValueError), ((0.5, 1e300), ValueError)],
    "wall_speed": _REAL + [(-0.1, ValueError)],
    "feed": [([], ValueError), ((), ValueError), (np.array([], dtype=str), ValueError),
             (3, TypeError), (["A", 3], TypeError), ({"A"}, TypeError), (b"A", TypeError),
             ({"A": 1}, TypeError), (["A", "Q"], ValueError), (["A", "A"], ValueError),
             ("Q", ValueError)],
    "inject_max": _WHOLE + [(FLOAT_EXACT + 1, ValueError), (2**63, ValueError)],
    "feed_budget": [v for v in _NOT_NONE if v[0] != [1]] + [([1], ValueError),
        (10**9, ValueError), (1899, ValueError), ([1, 2, 3], ValueError), ([], ValueError),
        ([NAN, 1], ValueError), ([1, True], TypeError), (np.zeros((2, 2)), ValueError),
        ([[1, 2]], ValueError), ({"A": 1}, TypeError)],
    "product": [(3, TypeError), ("Q", ValueError), (["C"], TypeError), (True, TypeError)],
    "count_jitter": _REAL + [(-0.1, ValueError), (1.0, ValueError), (1.5, ValueError)],
    "temperature_jitter": _REAL + [(-0.1, ValueError), (1.0, ValueError)],
    "heat_cost": _REAL + [(-1.0, ValueError), (1e300, ValueError)],
    "feed_cost": _REAL + [(-1.0, ValueError), (1e300, ValueError)],
    "energy_bins": _WHOLE + [(1, ValueError), (33, ValueError)],
    "spatial_grid": _WHOLE + [(17, ValueError)],
    "observe_reactions": [(1, TypeError), (None, TypeError), ("yes", TypeError),
                          (np.float64(1.0), TypeError)],
    "activation_jitter": _REAL + [(-0.1, ValueError), (1.0, ValueError)],
    "reverse_jitter": _REAL + [(-0.1, ValueError), (3.5, ValueError)],
    "formation_jitter": _REAL + [(-0.1, ValueError), (1e4, ValueError)],
    "heating": [(None, TypeError), (1, TypeError), ("hot", ValueError), ("jacket", ValueError)],
    "reward": [(None, TypeError), (0, TypeError), ("yield", ValueError),
               ("outflow", ValueError)],
    "observe_outflow": [(1, TypeError), (None, TypeError), ("no", TypeError)],
    "feed_temperature": [v for v in _PAIR if v[0] is not None] + [((0.3, 1e300), ValueError)],
    "integrator": [(None, TypeError), (1, TypeError), ("exact", ValueError)],
    "render_mode": [(3, TypeError), ("humans", ValueError), ("", ValueError)],
    "render_size": _WHOLE + [(0, ValueError), (MAX_RENDER_SIZE + 1, ValueError),
                             (10**6, ValueError)],
}
#: the vector env's own arguments
BAD_VECTOR = {
    "num_envs": _WHOLE + [(0, ValueError), (10**12, ValueError), (2**63, ValueError)],
    "max_episode_steps": _NOT_NONE + [
        (0, ValueError), (2**63, ValueError), (INT_MAX // 10 + 1, ValueError, "episode_steps")],
    "threads": _NOT_NONE + [(0, ValueError)],
    "autoreset_mode": [("Never", ValueError), (3, TypeError), (None, TypeError),
                       ("nextstep", ValueError)],
    "render_mode": [("human", ValueError), (3, TypeError)],
    "configs": [("heat_rate", TypeError), (3, TypeError), ({"heat_rate": 2.0}, TypeError),
                ([{}], ValueError), ([{}, {"feed": "A"}], ValueError),
                ([{}, {"heat_rate": 0.5}], ValueError), ([{}, 3], TypeError),
                ([{}, {"episode_steps": 2.5}], ValueError)],
}


def _cases(table):
    for name, rows in table.items():
        for k, row in enumerate(rows):
            value, exc = row[0], row[1]
            starts = row[2] if len(row) > 2 else name
            yield pytest.param(name, value, exc, starts, id=f"{name}-{k}-{value!r:.30}")


def _build(route, name, value):
    kw = {name: value}
    if name not in ("n_discs", "scene"):  # (a small reactor: quick)
        kw.setdefault("n_discs", 40)
    if route == "env":
        return DiscReactorEnv(**kw)
    if route == "vector":
        return DiscReactorVectorEnv(**({"num_envs": 2} | kw))
    if route == "make":
        return gym.make("DiscReactor-v0", **kw)
    return gym.make_vec("DiscReactor-v0", **({"num_envs": 2} | kw))


def _check_refused(route, name, value, exc, starts):
    with pytest.raises(exc) as info:
        _build(route, name, value)
    msg = str(info.value)
    assert msg.startswith(starts), msg  # (make appends its own words after ours)


@pytest.mark.filterwarnings("ignore:.*not in the possible render_modes:UserWarning")
@pytest.mark.parametrize("route", ["env", "vector", "make", "make_vec"])
@pytest.mark.parametrize("name, value, exc, starts", list(_cases(BAD)))
def test_bad_argument_is_refused_at_construction_naming_it(route, name, value, exc, starts):
    if name == "render_mode" and route in ("vector", "make_vec"):
        pytest.skip("the vector env's render_mode is swept in BAD_VECTOR")
    if name == "render_mode" and route == "make" and not isinstance(value, str):
        pytest.skip("gymnasium.make reads render_mode itself (AttributeError on a non-str)")
    _check_refused(route, name, value, exc, starts)


@pytest.mark.parametrize("route", ["vector", "make_vec"])
@pytest.mark.parametrize("name, value, exc, starts", list(_cases(BAD_VECTOR)))
def test_bad_vector_argument_is_refused_at_construction_naming_it(route, name, value, exc,
                                                                  starts):
    _check_refused(route, name, value, exc, starts)


def test_every_argument_is_swept():
    import inspect

    env_args = set(DEFAULTS) | {"render_mode", "render_size"}
    assert set(BAD) == env_args
    # (__init__ takes a config mapping or keywords and passes them on to _construct)
    sig = inspect.signature(DiscReactorVectorEnv._construct).parameters
    own = {p for p in sig if p not in ("self", "kwargs")}
    assert own - set(BAD) - set(BAD_VECTOR) == set()


# ---------------------------------------------------------------------------- unknown keywords


def _python_wording(owner):
    """What Python itself says for an unexpected keyword of ``owner.__init__``."""
    ns = {}
    exec(f"class {owner}:\n    def __init__(self, a=1):\n        pass\n", ns)
    with pytest.raises(TypeError) as info:
        ns[owner](frameskip=4)
    return str(info.value)


@pytest.mark.parametrize("route, owner", [("env", "DiscReactorEnv"),
                                          ("vector", "DiscReactorVectorEnv"),
                                          ("make", "DiscReactorEnv"),
                                          ("make_vec", "DiscReactorVectorEnv")])
def test_unknown_keyword_has_pythons_wording(route, owner):
    want = _python_wording(owner)
    assert want == f"{owner}.__init__() got an unexpected keyword argument 'frameskip'"
    with pytest.raises(TypeError) as info:
        _build(route, "frameskip", 4)
    # gymnasium.make appends "was raised from the environment creator ..."
    assert str(info.value).startswith(want), str(info.value)
    # the first unknown keyword, as Python reports it
    with pytest.raises(TypeError, match="argument 'zzz'$"):
        (DiscReactorEnv if owner == "DiscReactorEnv" else DiscReactorVectorEnv)(
            n_discs=40, zzz=1, frameskip=2)


def test_unknown_keyword_of_the_config_and_the_sb3_adapter():
    with pytest.raises(TypeError, match=r"^ReactorConfig\.from_kwargs\(\) got an unexpected "
                                        r"keyword argument 'frameskip'$"):
        ReactorConfig.from_kwargs(frameskip=4)
    pytest.importorskip("stable_baselines3")
    from discgym.sb3 import DiscReactorSB3VecEnv

    with pytest.raises(TypeError, match="__init__\\(\\) got an unexpected keyword argument "
                                        "'frameskip'"):
        DiscReactorSB3VecEnv(num_envs=2, frameskip=4)
    with pytest.raises(ValueError, match="^autoreset_mode"):
        DiscReactorSB3VecEnv(num_envs=2, autoreset_mode="NextStep", **SMALL)
    venv = DiscReactorSB3VecEnv(num_envs=np.int64(2), autoreset_mode="SameStep", **SMALL)
    assert venv.num_envs == 2 and type(venv.num_envs) is int


# ---------------------------------------------------------------------------- numpy scalars


_NUMERIC = {  # argument -> a valid value, as a Python number
    "n_discs": 40, "episode_steps": 7, "step_time": 0.5, "heat_rate": 2.0,
    "wall_speed": 0.25, "inject_max": 3, "feed_budget": 6, "count_jitter": 0.125,
    "temperature_jitter": 0.25, "heat_cost": 0.5, "feed_cost": 0.25,
}
_ATTR = {"n_discs": "template", "step_time": "steps_per_action", "count_jitter": "count_jitter",
         "temperature_jitter": "temperature_jitter"}


def _forms(v):
    """``v`` as numpy scalars (and an integral float for whole numbers); every form is
    exactly ``v`` (the values are exact in float32)."""
    if isinstance(v, int):
        return [np.int64(v), np.int32(v), np.uint16(v), np.int8(v), float(v), np.float64(v),
                np.float32(v), np.array(v)]
    return [np.float64(v), np.float32(v), np.float16(v), np.array(v, dtype=np.float32)]


@pytest.mark.parametrize("name", sorted(_NUMERIC))
def test_numpy_scalars_are_the_numbers_they_are(name):
    base = ReactorConfig.from_kwargs(**{name: _NUMERIC[name]})
    attr = _ATTR.get(name, name)
    for v in _forms(_NUMERIC[name]):
        cfg = ReactorConfig.from_kwargs(**{name: v})
        a, b = getattr(cfg, attr), getattr(base, attr)
        assert np.array_equal(a, b), (name, v)
        assert type(a) is type(b), (name, type(v))  # (Python numbers, whatever came in)


def _trajectory(env, steps=4):
    obs, _ = env.reset(seed=3)
    out = [obs]
    for k in range(steps):
        a = np.array([0.5 - 0.3 * k, -0.4, 1.0, 0.5], np.float32)
        o, r, *_ = env.step(a)
        out += [o, np.float64(r)]
    return out


def test_numpy_arguments_give_the_same_trajectory():
    py = dict(n_discs=60, episode_steps=9, step_time=0.5, heat_rate=2.0, wall_speed=0.25,
              inject_max=3, feed_budget=[6, 4], temperature_range=(0.25, 8.0),
              size_range=(0.5, 1.5), count_jitter=0.125, heat_cost=0.5)
    npy = dict(n_discs=np.int64(60), episode_steps=np.int32(9), step_time=np.float32(0.5),
               heat_rate=np.float16(2.0), wall_speed=np.float32(0.25), inject_max=np.uint8(3),
               feed_budget=np.array([6, 4]), temperature_range=np.array([0.25, 8.0]),
               size_range=[np.float32(0.5), np.float64(1.5)], count_jitter=np.float32(0.125),
               heat_cost=np.float64(0.5))
    a, b = _trajectory(DiscReactorEnv(**py)), _trajectory(DiscReactorEnv(**npy))
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    v1 = DiscReactorVectorEnv(num_envs=2, threads=1, **py)
    v2 = DiscReactorVectorEnv(num_envs=np.int64(2), threads=np.int8(1), **npy)
    o1, _ = v1.reset(seed=1)
    o2, _ = v2.reset(seed=1)
    assert np.array_equal(o1, o2)
    act = np.tile(np.array([0.5, -1.0, 1.0, 0.0], np.float32), (2, 1))
    assert np.array_equal(v1.step(act)[0], v2.step(act)[0])


def test_float32_step_time_at_its_own_precision():
    assert ReactorConfig.from_kwargs(step_time=np.float32(0.1)).steps_per_action == 2
    assert ReactorConfig.from_kwargs(step_time=np.float16(0.15)).steps_per_action == 3
    with pytest.raises(ValueError, match="^step_time"):  # a float64 this far off is refused
        ReactorConfig.from_kwargs(step_time=float(np.float32(0.1)))


def test_sequences_as_arrays():
    cfg = ReactorConfig.from_kwargs(feed=np.array(["B", "A"]), feed_budget=np.array([3, 5]),
                                    temperature_range=np.array([0.5, 4.0]))
    assert cfg.feed == (1, 0) and cfg.feed_budget.tolist() == [3, 5]
    assert (cfg.t_min, cfg.t_max) == (0.5, 4.0)


# ---------------------------------------------------------------------------- derived limits


def test_lattice_sites_are_those_of_the_simulation():
    """lattice_sites counts the sites of Simulation's dense placement: that many discs are
    placed, one more raises PlacementError (both far above random addition's reach)."""
    for bounds in (dg.Box(30.0, 30.0), dg.Circle(17.0, (0.0, 0.0)), dg.Box(13.3, 7.1, (2, 1))):
        sc = dg.scenes.load("reactor").replace(bounds=bounds, counts={"A": 10})
        n = lattice_sites(bounds, 0.5)
        sim = dg.Simulation(sc, counts={"A": n // 2, "B": n - n // 2}, seed=0)
        assert len(sim) == n and sim.overlaps() == 0 and sim.outside() == 0
        with pytest.raises(dg.PlacementError):
            dg.Simulation(sc, counts={"A": n // 2, "B": n + 1 - n // 2}, seed=0)


@pytest.mark.parametrize("jitter", [0.0, 0.1])
def test_the_largest_accepted_n_discs_resets(jitter):
    """The largest n_discs accepted at a count_jitter resets for every draw (the jitter's
    top included); one more is refused at construction."""
    sites = lattice_sites(dg.Box(30.0, 30.0), 0.5)
    n = 1
    for k in range(sites, 0, -1):  # (the first accepted from the top)
        try:
            ReactorConfig.from_kwargs(n_discs=k, count_jitter=jitter)
        except ValueError as e:
            assert str(e).startswith("n_discs")
            continue
        n = k
        break
    assert n > 0.85 * sites / (1 + jitter)
    with pytest.raises(ValueError, match="^n_discs"):
        DiscReactorEnv(n_discs=n + 1, count_jitter=jitter)
    env = DiscReactorEnv(n_discs=n, count_jitter=jitter, episode_steps=1)
    cfg = env.config
    # the largest draw itself (the top of the jitter) is placeable
    most = {nm: int(math.floor(t * (1 + jitter) + 0.5))
            for nm, t in zip(cfg.species_names, cfg.template) if t}
    assert sum(most.values()) <= sites
    sim = dg.Simulation(cfg.scene, counts=most, seed=0)
    assert sim.overlaps() == 0
    for seed in range(3):
        env.reset(seed=seed)
        assert env.simulation.overlaps() == 0


def test_scene_counts_beyond_the_lattice_name_count_jitter():
    sites = lattice_sites(dg.Box(30.0, 30.0), 0.5)
    sc = dg.scenes.load("reactor")
    sc = sc.replace(counts={"A": sites // 2, "B": sites - sites // 2})
    ReactorConfig.from_kwargs(scene=sc, count_jitter=0.0)  # exactly the lattice: fine
    with pytest.raises(ValueError, match="^count_jitter: .*n_discs or count_jitter"):
        ReactorConfig.from_kwargs(scene=sc)


def test_polydisperse_sparse_contents_are_not_held_to_the_lattice():
    """Few large discs among many small ones: the lattice of the large ones has fewer sites
    than there are discs, but they cover little area, so random placement takes them."""
    sc = dg.Scene(bounds=dg.Box(30.0, 30.0),
                  species=[dg.Species("s", 0.2, 1.0), dg.Species("L", 3.0, 1.0),
                           dg.Species("P", 3.0, 2.0)],
                  reactions=[dg.Combination("s", "L", "P", 1.0)], counts={"s": 500, "L": 3},
                  dt=0.05)
    assert lattice_sites(sc.bounds, 3.0) < 503
    env = DiscReactorEnv(scene=sc, episode_steps=2)
    env.reset(seed=0)
    assert len(env.simulation) in range(450, 560)


def test_episode_length_at_the_int64_limit():
    most = INT_MAX // 10  # (step_time 0.5 = 10 steps of dt)
    assert ReactorConfig.from_kwargs(episode_steps=most).episode_steps == most
    with pytest.raises(ValueError, match="^episode_steps, step_time"):
        ReactorConfig.from_kwargs(episode_steps=most + 1)
    spa = 2**61  # (3 x 2**61 <= 2**63 - 1 < 4 x 2**61)
    assert ReactorConfig.from_kwargs(step_time=spa * 0.05, episode_steps=3)
    with pytest.raises(ValueError, match="^episode_steps, step_time"):
        ReactorConfig.from_kwargs(step_time=spa * 0.05, episode_steps=4)
    # make_vec's max_episode_steps becomes the episode length: named too
    with pytest.raises(ValueError, match="^episode_steps.*max_episode_steps"):
        DiscReactorVectorEnv(num_envs=1, max_episode_steps=most + 1)
    venv = DiscReactorVectorEnv(num_envs=1, max_episode_steps=most + 1, episode_steps=5)
    assert (venv.limit == 5).all()


def test_feed_budget_and_inject_max_limits():
    top = 1898  # 30 x 42 at the densest mass per area (C: 2 / (pi 0.65^2)), / mass of A
    cfg = ReactorConfig.from_kwargs(feed_budget=top)
    assert cfg.feed_budget.tolist() == [top, top]
    with pytest.raises(ValueError, match="^feed_budget.*ever hold"):
        ReactorConfig.from_kwargs(feed_budget=[top + 1, 0])
    # the limit follows the largest size
    assert ReactorConfig.from_kwargs(size_range=(0.6, 2.0), feed_budget=2711)
    assert ReactorConfig.from_kwargs(inject_max=FLOAT_EXACT).inject_max == FLOAT_EXACT
    # the default budget is not held to the limit (25% of the initial counts)
    assert ReactorConfig.from_kwargs().feed_budget.tolist() == [30, 30]


def test_size_range_edges_and_bounds():
    assert ReactorConfig.from_kwargs(size_range=(1.0, 1.0)).size_max == 1.0
    with pytest.raises(ValueError, match="^size_range: must contain 1"):
        ReactorConfig.from_kwargs(size_range=(1.0000001, 2.0))
    # the reactor at the small end must be valid bounds: a circle's centre within 1e6
    # diameters of the origin
    sc = dg.scenes.load("reactor").replace(bounds=dg.Circle(17.0, (3.3e7, 0.0)))
    assert ReactorConfig.from_kwargs(scene=sc, size_range=(0.98, 1.2))
    with pytest.raises(ValueError, match="^size_range: the reactor at size 0.5"):
        ReactorConfig.from_kwargs(scene=sc, size_range=(0.5, 1.2))


@pytest.mark.parametrize("top", [1e9, 1e16, 1e30])
def test_size_range_reaching_beyond_what_a_simulation_holds_is_refused(top):
    """The compiled wall may reach the high end of size_range at once (a large wall_speed):
    there the reactor must still be bounds a Simulation holds (positions resolved finely
    enough for the smallest disc, the 1e-40..1e40 range), else refused at construction."""
    with pytest.raises(ValueError, match="^size_range: the reactor at size"):
        DiscReactorEnv(size_range=(0.6, top), wall_speed=1e39)


def test_the_largest_size_range_accepted_runs_at_full_wall_speed():
    env = DiscReactorEnv(size_range=(0.6, 1e7), wall_speed=1e39)
    env.reset(seed=0)
    for _ in range(3):
        obs, *_ = env.step(np.array([0, 1, 0, 0], np.float32))
    assert np.isfinite(obs).all() and env.observation_space.contains(obs)


def test_costs_and_rates_large_but_finite_work():
    # (one kernel step per env step: heated to the speed limit, a step takes 65536 substeps)
    env = DiscReactorEnv(**SMALL, step_time=0.05, heat_cost=1e200, feed_cost=1e200,
                         heat_rate=1e300, wall_speed=1e300, temperature_range=(1e-300, 1e300))
    env.reset(seed=0)
    for a in ([1, 1, 1, 1], [-1, -1, 0, 0]):
        obs, r, *_ = env.step(np.array(a, np.float32))
        assert math.isfinite(r) and np.isfinite(obs).all()
        assert env.simulation.overlaps() == 0 and env.simulation.outside() == 0


def test_too_much_state_for_the_memory_is_refused_before_allocating():
    with pytest.raises(ValueError, match="^num_envs: .* GiB, more than this machine's"):
        DiscReactorVectorEnv(num_envs=10**12, n_discs=40)
    with pytest.raises(ValueError, match="^num_envs"):
        gym.make_vec("DiscReactor-v0", num_envs=10**12)


def test_render_size_and_threads_edges():
    env = DiscReactorEnv(**SMALL, render_mode="rgb_array", render_size=1)
    env.reset(seed=0)
    assert env.render().shape == (1, 1, 3)
    assert DiscReactorEnv(**SMALL, render_size=np.int64(MAX_RENDER_SIZE)).render_size == 4096
    venv = DiscReactorVectorEnv(num_envs=2, threads=10**6, **SMALL)  # (all numba's threads)
    venv.reset(seed=0)
    venv.step(np.zeros((2, 4), np.float32))


# ---------------------------------------------------------------------------- actions

_DTYPES = [np.float64, np.float32, np.float16, np.int64, np.int8, np.uint8, np.bool_,
           np.complex128, np.complex64, object, np.str_]
_REAL = {np.float64, np.float32, np.float16, np.int64, np.int8, np.uint8, np.bool_}


def _array(rng, shape, dtype):
    x = rng.uniform(-1.5, 1.5, size=shape)
    if x.size and rng.random() < 0.3:
        x.flat[rng.integers(x.size)] = rng.choice([np.nan, np.inf, -np.inf])
    if dtype is np.bool_:
        return x > 0
    if dtype in (np.int64, np.int8, np.uint8):
        return np.nan_to_num(np.round(x), posinf=1, neginf=-1).astype(dtype)
    if dtype is np.str_:
        return x.astype(str)
    if dtype is object:
        return x.astype(object)
    return x.astype(dtype)


_SHAPES = st.one_of(st.lists(st.integers(0, 5), max_size=3).map(tuple),
                    st.sampled_from([(4,), (1, 4), (4, 1), (2, 2), (8,), (2, 4), (4, 2),
                                     (1, 8), (2, 2, 2), (3, 4), (2, 5), ()]))
_PAIRS = {}


def _pair(kind):
    if kind not in _PAIRS:
        if kind == "env":
            a, b = DiscReactorEnv(**SMALL), DiscReactorEnv(**SMALL)
        else:
            a, b = (DiscReactorVectorEnv(num_envs=2, threads=1, **SMALL) for _ in range(2))
        a.reset(seed=11)
        b.reset(seed=11)
        _PAIRS[kind] = (a, b)
    return _PAIRS[kind]


def _same_step(s1, s2):
    assert np.array_equal(s1[0], s2[0])  # observations, bit for bit
    assert np.array_equal(s1[1], s2[1])  # rewards
    assert np.array_equal(s1[3], s2[3])  # truncated


@pytest.mark.parametrize("kind", ["env", "vector"])
@settings(max_examples=120, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_actions_of_exactly_the_right_shape_and_dtype_are_taken(kind, data):
    """An action is taken iff its shape is (A,) (single env) or (num_envs, A) (vector env)
    and its dtype is real (bool, integer, float), given as an array or as (nested) lists;
    anything else raises naming the expected and the received shape (or the dtype), and
    changes nothing: the twin, which never saw the refused action, takes the next valid step
    with the refusing env bit for bit."""
    env, twin = _pair(kind)
    want = (4,) if kind == "env" else (2, 4)
    shape = data.draw(_SHAPES | st.just(want), label="shape")
    dtype = data.draw(st.sampled_from(_DTYPES), label="dtype")
    as_list = data.draw(st.booleans(), label="as a list")
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1), label="seed"))
    x = _array(rng, shape, dtype)
    given_ = x.tolist() if as_list else x
    # (tolist turns an object array of floats into Python floats: then real)
    real = dtype in _REAL or (as_list and dtype is object)
    if shape == want and real:
        s1 = env.step(given_)
        s2 = twin.step(np.asarray(x, dtype=np.float64))
        _same_step(s1, s2)
        return
    exc = ValueError if shape != want else TypeError
    with pytest.raises(exc) as info:
        env.step(given_)
    msg = str(info.value)
    assert msg.startswith("action"), msg
    if shape != want:
        got = np.asarray(given_).shape if as_list else shape  # ([] has lost (0, 3)'s 3)
        assert f"expected shape {want}" in msg and f"got {got}" in msg, msg
    else:
        assert "dtype" in msg, msg
    ok = np.tile(np.array([0.25, -0.5, 1.0, 0.0], np.float32), (1,) if kind == "env" else (2, 1))
    _same_step(env.step(ok), twin.step(ok))


@pytest.mark.parametrize("bad", [(4, 2), (8,), (1, 8), (2, 2, 2), (2,), (1, 4), (3, 4), ()])
def test_vector_env_refuses_the_reshapes_it_used_to_do(bad):
    venv, twin = _pair("vector")
    with pytest.raises(ValueError) as info:
        venv.step(np.zeros(bad, np.float32))
    msg = str(info.value)
    assert msg.startswith("actions: expected shape (2, 4) ") and msg.endswith(f"got {bad}")
    ok = np.zeros((2, 4), np.float32)
    _same_step(venv.step(ok), twin.step(ok))


def test_per_env_action_lists_and_ragged_input():
    venv, twin = _pair("vector")
    rows = [np.array([0.5, 0.0, 1.0, 0.0], np.float32), [0.0, -1.0, 0.0, 1.0]]
    _same_step(venv.step(rows), twin.step(np.array(rows, np.float64)))
    _same_step(venv.step(tuple(rows)), twin.step(np.array(rows, np.float64)))
    with pytest.raises(ValueError, match="^actions: expected shape"):
        venv.step(rows + [rows[0]])  # three actions for two reactors
    with pytest.raises(ValueError, match="^actions: not an array of one shape"):
        venv.step([rows[0], rows[0][:3]])
    env, twin1 = _pair("env")
    with pytest.raises(ValueError, match="^action: not an array of one shape"):
        env.step([[0.0, 0.0], [0.0]])
    with pytest.raises(ValueError, match="^action: expected shape"):
        env.step(0.5)  # a scalar
    with pytest.raises(TypeError, match="^action: expected real numbers"):
        env.step([0.0, None, 0.0, 0.0])
    ok = np.zeros(4, np.float32)
    _same_step(env.step(ok), twin1.step(ok))


def test_gymnasium_checkers_and_sb3_still_take_their_actions():
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(DiscReactorEnv(**SMALL), skip_render_check=True)
        env = gym.make("DiscReactor-v0", **SMALL)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        venv = gym.make_vec("DiscReactor-v0", num_envs=3, **SMALL)
        venv.reset(seed=0)
        venv.step(venv.action_space.sample())
        venv.step(list(venv.action_space.sample()))
    pytest.importorskip("stable_baselines3")
    from discgym.sb3 import DiscReactorSB3VecEnv

    sb = DiscReactorSB3VecEnv(num_envs=2, **SMALL)
    sb.reset()
    obs, rew, done, infos = sb.step(np.zeros((2, 4), np.float32))
    assert obs.shape == (2, 19)
    with pytest.raises(ValueError, match="^actions: expected shape"):
        sb.step(np.zeros(8, np.float32))
    sb.step(np.zeros((2, 4), np.float32))  # (the refused actions were not kept)
