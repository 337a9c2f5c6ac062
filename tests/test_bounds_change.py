"""Bounds replaced after construction, by ``Simulation.resize`` or ``set_state``.

1. Thermal walls and outlets are keyed by side, and a Box and a Circle have no side in
   common: bounds of another kind would reinterpret them (a box's "left" outlet as an arc of
   the circle, its "right" thermal wall as nothing while ``wall_temperature`` still reports
   it). Bounds lacking a side a feature of the scene is on are refused the way ``Scene``
   refuses them (``ValueError`` naming the feature and the side), by every route that
   replaces the bounds, with nothing changed; same-kind changes, and any change in a scene
   without such features, are taken.
2. The envs keep the wall's size: bounds replaced from outside between steps give the wall
   its size (the ``size`` observation and the next wall move start from it), in the single
   and the vector env alike; bounds the wall cannot make (another kind, height, origin or
   centre, a size outside ``size_range``) raise ``RuntimeError`` at the next step, before
   anything is stepped.
"""

import pickle

import gymnasium as gym
import numpy as np
import pytest
from test_set_state import same_state as _same  # bit for bit, every key

import discgym as dg
from discgym.env import DiscReactorEnv
from discgym.vector import DiscReactorVectorEnv

A = dg.Species("A", 0.3, 1.0)
B = dg.Species("B", 0.25, 2.0)
BOX = dg.Box(10.0, 10.0)
CIRCLE = dg.Circle(5.0, (5.0, 5.0))


def _scene(bounds, walls=(), outlets=()):
    return dg.Scene(bounds=bounds, species=[A, B], dt=0.02, counts={"A": 30, "B": 10},
                    thermal_walls=[dg.ThermalWall(s, 2.0) for s in walls],
                    outlets=[dg.Outlet(s, a, b) for s, a, b in outlets])


# ------------------------------------------------------------------ comparisons
def _storage(sim) -> tuple:
    return tuple(getattr(sim, nm).tobytes() for nm in
                 ("_pos", "_vel", "_species", "_internal_energy", "_ids", "_walls", "_fsum",
                  "_outflow")) + (sim._bounds_kind, sim._bounds_params.tobytes(), sim._n)


# ------------------------------------------------------------------ 1. the simulation
# (scene bounds, thermal walls, outlets as (side, start, end), bounds of the other kind);
# every side of either kind carries a feature in some case, alone or with others
BOX_CASES = [(w, o) for w, o in [
    (("left",), ()), (("right",), ()), (("bottom",), ()), (("top",), ()),
    ((), (("left", 0.0, 0.1),)), ((), (("right", 0.2, 0.9),)), ((), (("bottom", 0.0, 1.0),)),
    ((), (("top", 0.4, 0.5),)), (("left", "top"), (("right", 0.0, 0.5),)),
    ((), (("left", 0.0, 0.2), ("left", 0.5, 0.6))),
]]
CIRCLE_CASES = [(("wall",), ()), ((), (("wall", 0.0, 0.25),)), ((), (("wall", 0.9, 1.0),)),
                (("wall",), (("wall", 0.3, 0.4), ("wall", 0.6, 0.7)))]
CASES = [(BOX, w, o, nb) for w, o in BOX_CASES
         for nb in (dg.Circle(4.5, (5.0, 5.0)), dg.Circle(20.0, (-3.0, 7.0)))] + \
        [(CIRCLE, w, o, nb) for w, o in CIRCLE_CASES
         for nb in (dg.Box(10.0, 10.0), dg.Box(7.0, 9.0, (1.0, 0.5)))]


def _first_feature(sc):
    """The field name and side the refusal must name: Scene's order (thermal walls, then
    outlets)."""
    if sc.thermal_walls:
        return "thermal_walls[0].side", sc.thermal_walls[0].side
    return "outlets[0].side", sc.outlets[0].side


def _alien_state(sim, bounds) -> dict:
    """A state of ``sim`` that differs only in its bounds (and discs placed inside them):
    as a simulation of the same species without walls or outlets would give it."""
    other = dg.Simulation(sim.scene.replace(bounds=bounds, thermal_walls=(), outlets=()), seed=5)
    st, o = sim.get_state(), other.get_state()
    for k in ("positions", "velocities", "species", "internal_energy", "ids", "next_id",
              "bounds"):
        st[k] = o[k]
    return st


def _refused_unchanged(sim, call, field, side, prefix):
    twin = sim.copy()
    before, raw = sim.get_state(), _storage(sim)
    with pytest.raises(ValueError) as exc:
        call()
    msg = str(exc.value)
    assert msg.startswith(prefix), msg
    assert field in msg and repr(side) in msg, msg
    _same(sim.get_state(), before)
    assert _storage(sim) == raw
    sim.step(5)
    twin.step(5)
    _same(sim.get_state(), twin.get_state())
    return msg


@pytest.mark.parametrize("bounds, walls, outlets, new", CASES)
@pytest.mark.parametrize("route", ["resize", "set_state"])
def test_bounds_lacking_a_featured_side_are_refused_naming_it_and_nothing_changes(
        bounds, walls, outlets, new, route):
    sc = _scene(bounds, walls, outlets)
    sim = dg.Simulation(sc, seed=1)
    sim.step(10)
    field, side = _first_feature(sc)
    if route == "resize":
        msg = _refused_unchanged(sim, lambda: sim.resize(new), field, side, "resize(bounds)")
    else:
        st = _alien_state(sim, new)
        msg = _refused_unchanged(sim, lambda: sim.set_state(st), field, side,
                                 "set_state: state['bounds']")
        # the same state is taken by the scene without walls and outlets: only they refuse it
        plain = dg.Simulation(sc.replace(thermal_walls=(), outlets=()), seed=1)
        plain.set_state({k: v for k, v in st.items() if k != "wall_temperature"})
        assert plain.bounds == new
    assert f"not a side of a {new.kind}" in msg, msg


def test_the_reported_case_is_refused():
    sc = dg.Scene(bounds=dg.Box(10, 10), species=[dg.Species("A", .3, 1.)], dt=.02,
                  counts={"A": 40}, outlets=[dg.Outlet("left", 0, .1)],
                  thermal_walls=[dg.ThermalWall("right", 5.)])
    s = dg.Simulation(sc, seed=1)
    with pytest.raises(ValueError, match=r"thermal_walls\[0\]\.side.*'right' is not a side of "
                                         r"a circle"):
        s.resize(dg.Circle(4.5, (5, 5)))
    s.advance(20)
    assert s.bounds == dg.Box(10, 10)
    assert s.wall_heat != 0.0  # the right wall still exchanges heat
    only_outlet = sc.replace(thermal_walls=())
    with pytest.raises(ValueError, match=r"outlets\[0\]\.side.*'left'"):
        dg.Simulation(only_outlet, seed=1).resize(dg.Circle(4.5, (5, 5)))


def test_a_pickle_payload_of_another_kind_is_refused():
    sc = _scene(BOX, ("left",))
    sim = dg.Simulation(sc, seed=2)
    payload = {"scene": sc, "state": _alien_state(sim, dg.Circle(4.5, (5.0, 5.0)))}
    with pytest.raises(ValueError, match=r"state\['bounds'\].*thermal_walls\[0\]\.side"):
        dg.Simulation.__new__(dg.Simulation).__setstate__(payload)
    good = pickle.loads(pickle.dumps(sim))
    _same(good.get_state(), sim.get_state())


@pytest.mark.parametrize("route", ["resize", "set_state"])
def test_same_kind_bounds_keep_the_features_on_their_sides(route):
    # an outlet on the left and a hot right wall: after the box changes, discs still leave
    # on the left only and the right wall still heats
    sc = _scene(BOX, ("right",), (("left", 0.0, 1.0),))
    sim = dg.Simulation(sc, seed=3)
    new = dg.Box(12.0, 8.0, (-1.0, 1.0))
    if route == "resize":
        sim.resize(new)
    else:
        big = dg.Simulation(sc.replace(bounds=new, counts={"A": 30, "B": 10}), seed=4)
        sim.set_state(big.get_state())
    assert sim.bounds == new
    sim.advance(10.0)
    assert sum(sim.outflow().values()) > 0 and sim.wall_heat_by_side()["right"] != 0.0
    assert sim.wall_heat_by_side()["left"] == 0.0 and sim.outside(1e-12) == 0
    assert abs(sim.energy_balance()) < 1e-9 * max(1.0, abs(sim.total_energy()))
    # a circle into another circle likewise
    circ = dg.Simulation(_scene(CIRCLE, ("wall",), (("wall", 0.0, 0.1),)), seed=3)
    circ.resize(dg.Circle(6.0, (4.0, 5.0)))
    circ.advance(10.0)
    assert circ.wall_heat != 0.0 and sum(circ.outflow().values()) > 0


@pytest.mark.parametrize("route", ["resize", "set_state"])
@pytest.mark.parametrize("old, new", [(BOX, dg.Circle(4.5, (5.0, 5.0))), (CIRCLE, BOX)])
def test_without_side_features_the_kind_may_change_and_the_sides_follow(route, old, new):
    sc = _scene(old)
    sim = dg.Simulation(sc, seed=6)
    if route == "resize":
        sim.resize(new)
    else:
        sim.set_state(_alien_state(sim, new))
    assert sim.bounds == new
    sim.step(20)
    assert sim.outside(1e-12) == 0 and sim.overlaps() == 0
    # the sides reported are the bounds' own, not the scene's original ones
    assert list(sim.wall_heat_by_side()) == list(dg.scene.sides_of(new))
    assert sim.wall_temperature == {} and sim.outflow() == {"A": 0, "B": 0}


def test_every_side_feature_of_a_scene_is_checked():
    # every Scene field holding objects with a side is covered by the check: a scene with
    # one of each kind of such feature has each named in turn as the others are removed
    sc = _scene(BOX, ("top",), (("bottom", 0.0, 0.5),))
    fields = [f for f in ("thermal_walls", "outlets") if getattr(sc, f)]
    side_fields = {name for name in vars(sc) if isinstance(getattr(sc, name), tuple) and
                   any(hasattr(x, "side") for x in getattr(sc, name))}
    assert side_fields == set(fields)
    for f in fields:
        one = sc.replace(**{g: () for g in fields if g != f})
        with pytest.raises(ValueError, match=rf"{f}\[0\]\.side"):
            dg.Simulation(one, seed=0).resize(dg.Circle(4.0, (5.0, 5.0)))


# ------------------------------------------------------------------ 2. the envs
FLOW = dict(episode_steps=50)
NAN_WALL = np.array([0.0, np.nan, 0.0, 0.0])
ZERO = np.zeros(4)


def _single(task="DiscFlow-v0", **kw):
    env = gym.make(task, **{**FLOW, **kw}).unwrapped
    env.reset(seed=0)
    return env, [env.simulation]


def _vector(task="DiscFlow-v0", **kw):
    env = gym.make_vec(task, num_envs=2, vectorization_mode="vector_entry_point",
                       **{**FLOW, **kw}).unwrapped
    env.reset(seed=0)
    return env, env.simulations


def _step(env, a):
    if isinstance(env, DiscReactorVectorEnv):
        obs, rew, term, trunc, info = env.step(np.stack([a] * env.num_envs))
        return obs[0], info["size"][0]
    obs, rew, term, trunc, info = env.step(a)
    return obs, info["size"]


def _moved(cfg, s, a1=0.0):
    """The size after a wall action a1 from size s (DiscReactorEnv's action docs)."""
    lo, hi, ws = cfg.size_min, cfg.size_max, cfg.wall_speed
    target = lo + 0.5 * (a1 + 1.0) * (hi - lo)
    return min(max(s + min(max(target - s, -ws), ws), lo), hi)


def _route(sim, bounds, how):
    if how == "resize":
        sim.resize(bounds)
    else:  # a state of these bounds, from a copy resized to them
        c = sim.copy()
        c.resize(bounds)
        sim.set_state(c.get_state())


SIZES = [0.6, 0.8, 0.95, 1.0, 1.2, 1.4]


@pytest.mark.parametrize("make", [_single, _vector], ids=["single", "vector"])
@pytest.mark.parametrize("how", ["resize", "set_state"])
@pytest.mark.parametrize("size", SIZES)
def test_the_env_reads_bounds_changed_from_outside_back(make, how, size):
    env, sims = make()
    cfg = env.config
    i = cfg.obs_names.index("size")
    new = cfg.bounds_of(size)
    _route(sims[0], new, how)
    obs, info_size = _step(env, NAN_WALL)  # the wall does nothing: the size is the new one
    assert sims[0].bounds == new
    assert info_size == size and obs[i] == np.float32(size)
    obs, info_size = _step(env, ZERO)  # the next move starts from it
    s = _moved(cfg, size)
    assert info_size == s and obs[i] == np.float32(s)
    assert sims[0].bounds == cfg.bounds_of(s)
    if isinstance(env, DiscReactorVectorEnv):  # the other reactor: untouched, as ever
        moved = _moved(cfg, 1.0)
        assert env.core.episodes.size[1] == moved and sims[1].bounds == cfg.bounds_of(moved)


def test_the_reported_vector_case():
    env = gym.make_vec("DiscFlow-v0", num_envs=2, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    u = env.unwrapped
    u.simulations[0].resize(dg.Box(12.8, 16))
    i = u.observation_names.index("size")
    obs, *_ = env.step(np.array([NAN_WALL, NAN_WALL]))
    assert obs[0, i] == np.float32(0.8)
    env.step(np.zeros((2, 4)))
    assert u.simulations[0].bounds.width == pytest.approx(13.6, rel=1e-15)


@pytest.mark.parametrize("how", ["resize", "set_state"])
def test_single_and_vector_env_follow_the_same_outside_change_bit_for_bit(how):
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (8, 4))
    acts[2, 1] = np.nan
    single, (sim,) = _single()
    vec, sims = _vector()
    for k in range(8):
        if k in (2, 5):
            b = single.config.bounds_of(0.7 + 0.1 * k)
            _route(sim, b, how)
            _route(sims[0], b, how)
        o1, r1, *_, i1 = single.step(acts[k])
        o2, r2, *_, i2 = vec.step(np.stack([acts[k], acts[k]]))
        assert np.array_equal(o1, o2[0]) and r1 == r2[0] and i1["size"] == i2["size"][0]
        assert i1["size"] == single.config.size_of(sim.bounds)  # (16 s / 16 == s)
    _same(sim.get_state(), sims[0].get_state())


@pytest.mark.parametrize("task", ["DiscFlow-v0", "DiscReactor-v0"])
def test_an_unchanged_size_changes_nothing(task):
    # bounds replaced by the same bounds (resize to them, a state of the same size), and
    # copies of the env: bit for bit the run without (DiscReactor-v0's width of 30 does not
    # give back every size exactly: 30 s / 30 != s)
    a, _ = _single(task)
    b, _ = _single(task)
    acts = np.random.default_rng(1).uniform(-1, 1, (6, 4))
    # the wall to a size s that 30 s / 30 does not give back, then held there
    acts[0, 1], acts[1:5, 1] = -0.07990972138180785, np.nan
    for k in range(6):
        if k == 2:
            b.simulation.resize(b.simulation.bounds)
        if k == 3:
            b.simulation.set_state(b.simulation.get_state())
        if k == 4:
            b = b.clone()
        oa, ra, *_, ia = a.step(acts[k])
        ob, rb, *_, ib = b.step(acts[k])
        assert np.array_equal(oa, ob) and ra == rb and ia["size"] == ib["size"]
    _same(a.simulation.get_state(), b.simulation.get_state())
    v, _ = _vector(task)
    w = pickle.loads(pickle.dumps(v))
    for k in range(3):
        ov, *_ = v.step(np.stack([acts[k]] * 2))
        ow, *_ = w.step(np.stack([acts[k]] * 2))
        assert np.array_equal(ov, ow)


def _bad_bounds(cfg):
    ref = cfg.scene.bounds
    return {
        "below size_range": (cfg.bounds_of(0.5), "outside size_range"),
        "above size_range": (cfg.bounds_of(1.45), "outside size_range"),
        "other height": (dg.Box(ref.width, ref.height * 0.9, ref.origin), "height"),
        "other origin": (dg.Box(ref.width, ref.height, (0.5, 0.0)), "origin"),
        "a circle": (dg.Circle(0.45 * ref.width, (0.5 * ref.width, 0.5 * ref.height)),
                     "a circle, not a box"),
    }


BAD = ["below size_range", "above size_range", "other height", "other origin", "a circle"]


@pytest.mark.parametrize("make", [_single, _vector], ids=["single", "vector"])
@pytest.mark.parametrize("bad", BAD)
def test_bounds_the_wall_cannot_make_are_refused_before_anything_is_stepped(make, bad):
    # DiscReactor-v0's box has no outlets, so the simulation takes a circle; the env cannot
    env, sims = make("DiscReactor-v0", n_discs=60)
    cfg = env.config
    bounds, why = _bad_bounds(cfg)[bad]
    sims[0].resize(bounds)
    before = [s.get_state() for s in sims]
    with pytest.raises(RuntimeError) as exc:
        _step(env, ZERO)
    msg = str(exc.value)
    assert msg.startswith("bounds: ") and why in msg and str(bounds) in msg, msg
    for s, st in zip(sims, before):
        _same(s.get_state(), st)
    with pytest.raises(RuntimeError):  # still refused, until the bounds are the wall's
        _step(env, ZERO)
    sims[0].resize(cfg.bounds_of(1.1))
    obs, size = _step(env, NAN_WALL)
    space = getattr(env, "single_observation_space", env.observation_space)
    assert size == 1.1 and space.contains(obs)


@pytest.mark.parametrize("make", [_single, _vector], ids=["single", "vector"])
def test_the_edges_of_size_range_as_the_wall_makes_them_are_taken(make):
    # (a width of 30: 30 x 0.71 / 30 is below 0.71, 30 x 1.33 / 30 above 1.33)
    env, sims = make("DiscReactor-v0", n_discs=60, size_range=(0.71, 1.33))
    cfg = env.config
    for s in (cfg.size_min, cfg.size_max):
        sims[0].resize(cfg.bounds_of(s))
        _, size = _step(env, NAN_WALL)
        assert size == s


def test_a_circular_reactor_reads_its_radius_back():
    sc = dg.scenes.load("reactor").replace(bounds=dg.Circle(17.0, (0.0, 0.0)))
    env = DiscReactorEnv(scene=sc, n_discs=80, wall_speed=0.1)
    env.reset(seed=0)
    env.simulation.resize(dg.Circle(17.0 * 0.75, (0.0, 0.0)))
    *_, info = env.step(NAN_WALL)
    assert info["size"] == 0.75
    *_, info = env.step(np.array([0.0, 1.0, 0.0, 0.0]))
    assert info["size"] == 0.85 and env.simulation.bounds == dg.Circle(17.0 * 0.85, (0.0, 0.0))
    env.simulation.resize(dg.Circle(17.0, (1.0, 0.0)))
    with pytest.raises(RuntimeError, match="centre"):
        env.step(ZERO)
