"""``Simulation.set_state`` is atomic: a state it cannot hold is refused with a ValueError
naming the key (``state['time']``) and the simulation is exactly as before (arrays, counters,
clocks, random generator: it continues bit for bit like a copy that never saw the state).
Valid states, including those of the previous version, restore bit for bit.

The sweep is generated: for every key of a state, missing, None, wrong type, wrong dtype,
wrong shape, non-finite, negative and out of range; duplicate ids; a ``next_id`` too small; a
state of another scene (other masses, radii, species names, formation energies, reactions);
and a hypothesis property over random mutations of a valid state.
"""

import functools
import math
import pickle
import re
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import discgym as dg

A = dg.Species("A", 0.5, 1.0)
B = dg.Species("B", 0.4, 2.0, formation_energy=0.5)
AB = dg.Species("AB", 0.7, 3.0, formation_energy=-0.5)
REACT = dg.Combination("A", "B", "AB", activation_energy=0.2, reverse_probability=0.3)


def scene(species=(A, B, AB), reactions=(REACT,), **kw):
    kw = {"bounds": dg.Box(12.0, 12.0), "counts": {"A": 10, "B": 10}, "dt": 0.05,
          "restitution": 0.9, **kw}
    return dg.Scene(species=list(species), reactions=list(reactions), **kw)


SC = scene()


@functools.cache
def _built():
    """A reactive state with every kind of entry non-trivial: reactions fired, energy
    dissipated and added, counters reset part way (since_reset < time)."""
    s = dg.Simulation(SC, seed=1)
    s.step(40)
    s.scale_temperature(2.0)
    s.reset_counters()
    s.step(20)
    assert sum(s.reactions().values()) > 0 and s.dissipated_energy > 0
    assert s.energy_input != 0 and s.internal_energy.max() > 0
    return s


def base() -> dg.Simulation:
    return _built().copy()


# ------------------------------------------------------------------ comparisons
def _bits(x):
    if isinstance(x, np.ndarray):
        return ("array", x.dtype.str, x.shape, x.tobytes())
    if isinstance(x, float):
        return ("float", struct.pack("<d", x))
    if isinstance(x, dict):
        return ("dict", sorted((k, _bits(v)) for k, v in x.items()))
    return (type(x).__name__, x)


def same_state(a: dict, b: dict) -> None:
    """Bit for bit: every key, dtypes, -0.0 vs 0.0, the generator state."""
    assert a.keys() == b.keys()
    for k in a:
        assert _bits(a[k]) == _bits(b[k]), k


def buffers(sim) -> tuple:
    """The simulation's whole storage (capacity included) and its generator object."""
    return tuple(getattr(sim, nm).tobytes() for nm in
                 ("_pos", "_vel", "_species", "_internal_energy", "_ids", "_idctr", "_icnt",
                  "_fsum", "_ch_count", "_outflow", "_walls")) + \
        (id(sim._rng), sim._n, sim._bounds_kind, sim._bounds_params.tobytes())


def assert_refused(sim, bad, key) -> str:
    """set_state(bad) raises ValueError naming state[key]; nothing changed, and the
    simulation continues exactly like a copy taken before."""
    twin = sim.copy()
    before, raw = sim.get_state(), buffers(sim)
    with pytest.raises(ValueError) as exc:
        sim.set_state(bad)
    msg = str(exc.value)
    assert f"state[{key!r}]" in msg, msg
    same_state(sim.get_state(), before)
    assert buffers(sim) == raw
    sim.step(5)
    twin.step(5)
    same_state(sim.get_state(), twin.get_state())
    return msg


# ------------------------------------------------------------------ the generated sweep
PER_DISC_FLOAT = {"positions": (None, 2), "velocities": (None, 2), "internal_energy": (None,)}
INT_ARRAYS = ("species", "ids", "icnt", "ch_count", "outflow")
FLOAT_ARRAYS = ("positions", "velocities", "internal_energy", "fsum")
WHOLE = ("next_id", "steps")
REAL = ("time", "since_reset", "energy_input", "energy_start")
OTHER = ("bounds", "rng", "integrator", "scene_fingerprint", "clock", "wall_temperature")
OPTIONAL = ("integrator", "scene_fingerprint", "clock", "wall_temperature", "outflow")


def _set(key, value):
    def f(s):
        s[key] = value(s) if callable(value) else value
    return f


def _item(key, idx, value, dtype=None):
    def f(s):
        a = np.array(s[key], dtype=dtype)
        a[idx] = value
        s[key] = a
    return f


def _cases():
    out = []

    def add(kind, key, mutate, named=None, label=""):
        out.append(pytest.param(named or key, mutate, kind,
                                id=f"{kind}-{key}{'-' + label if label else ''}"))

    for key in _built().get_state():
        if key not in OPTIONAL:
            add("missing", key, lambda s, k=key: s.pop(k))
        add("none", key, _set(key, None))
        add("type", key, _set(key, "text"), label="str")
        add("type", key, _set(key, object()), label="object")
        add("type", key, _set(key, np.zeros((2, 2))), label="2x2-array")
    for key in INT_ARRAYS + FLOAT_ARRAYS:
        add("type", key, _set(key, lambda s, k=key: np.ones_like(s[k], dtype=bool)),
            label="bool")
        add("type", key, _set(key, lambda s, k=key: np.asarray(s[k]) + 1j), label="complex")
        add("type", key, _set(key, lambda s, k=key: np.asarray(s[k]).astype(str)),
            label="strings")
        add("type", key, _set(key, lambda s, k=key: [list(np.atleast_1d(s[k][0])), []]),
            label="ragged")
        add("shape", key, _set(key, lambda s, k=key: np.asarray(s[k])[0]), label="0d")
        add("shape", key, _set(key, lambda s, k=key: np.stack([s[k], s[k]], axis=-1)),
            label="extra-axis")
    for key in INT_ARRAYS:
        add("type", key, _set(key, lambda s, k=key: np.asarray(s[k], dtype=float)),
            label="float")
        add("negative", key, _item(key, 0, -1))
        add("range", key, _item(key, 0, 2 ** 63, np.uint64), label="2**63")
    for key in FLOAT_ARRAYS:
        idx = (0, 0) if key in ("positions", "velocities") else 0
        for v in (math.nan, math.inf, -math.inf):
            add("nonfinite", key, _item(key, idx, v, float), label=repr(v))
        add("shape", key, _set(key, lambda s, k=key: np.asarray(s[k])[:-1]), label="shorter")
        add("shape", key, _set(key, lambda s, k=key: np.concatenate([s[k], s[k][:1]])),
            label="longer")
    for key in ("positions", "velocities"):
        add("shape", key, _set(key, lambda s, k=key: s[k][:, :1]), label="one-column")
        add("shape", key, _set(key, lambda s, k=key: s[k].T.copy()), label="transposed")
    for key in ("species", "ids"):
        add("shape", key, _set(key, lambda s, k=key: s[k][:-1]), label="shorter")
    add("shape", "icnt", _set("icnt", lambda s: s["icnt"][:10]), label="10-counters")
    add("shape", "icnt", _set("icnt", lambda s: np.append(s["icnt"], 0)), label="one-more")
    add("shape", "ch_count", _set("ch_count", lambda s: np.append(s["ch_count"], 0)),
        label="one-more")
    add("shape", "outflow", _set("outflow", lambda s: np.append(s["outflow"], 0)),
        label="one-more")
    add("shape", "outflow", _set("outflow", lambda s: s["outflow"][:-1]), label="shorter")
    add("shape", "fsum", _set("fsum", lambda s: s["fsum"][:3]), label="three-sums")
    add("range", "wall_temperature", _set("wall_temperature", {"left": 1.0}),
        label="not-thermal")
    add("type", "wall_temperature", _set("wall_temperature", [("left", 1.0)]), label="pairs")
    add("negative", "internal_energy", _item("internal_energy", 3, -1e-300))
    add("negative", "fsum", _item("fsum", 1, -1.0))
    add("negative", "positions", _item("positions", (2, 1), -1.0))
    add("range", "positions", _item("positions", 4, [50.0, 6.0]))
    add("range", "positions", _item("positions", 4, [11.9, 6.0]), label="wall")
    add("range", "velocities", _item("velocities", 1, [1e9, 0.0]), label="speed-limit")
    add("range", "species", _item("species", 0, 3))
    add("range", "internal_energy", _set("internal_energy",
                                         lambda s: np.full_like(s["internal_energy"], 1e308)),
        label="total-energy-overflows")
    for key in WHOLE:
        for v, lab in ((-1, "negative"), (2 ** 63, "range"), (1.5, "type"), (3.0, "type"),
                       (True, "type"), (np.array([3]), "shape"), (math.nan, "nonfinite")):
            add(lab, key, _set(key, v), label=repr(v))
    for key in REAL:
        for v, lab in ((math.nan, "nonfinite"), (math.inf, "nonfinite"),
                       (-math.inf, "nonfinite"), (10 ** 400, "range"), (True, "type"),
                       ("1.0", "type"), ([1.0], "shape"), (np.array([1.0]), "shape")):
            add(lab, key, _set(key, v), label=repr(v)[:12])
    for key in ("time", "since_reset"):
        add("negative", key, _set(key, -1.0))
    add("range", "since_reset", _set("since_reset", lambda s: s["time"] + 1.0),
        label="beyond-time")
    add("range", "time", _set("time", lambda s: s["since_reset"] / 2), named="since_reset",
        label="below-since_reset")
    add("range", "energy_start", lambda s: s.update(energy_start=1e308, energy_input=1e308),
        label="balance-overflows")

    def huge_dissipation(s):
        s["fsum"][1] = 1e308
        s["energy_start"] = -1e308

    add("range", "fsum", huge_dissipation, label="balance-overflows")
    add("type", "bounds", _set("bounds", (12.0, 12.0)), label="tuple")
    add("range", "bounds", _set("bounds", dg.Box(3.0, 3.0)), label="small-box")
    add("range", "bounds", _set("bounds", dg.Circle(2.0, (6.0, 6.0))), label="small-circle")
    add("range", "bounds", lambda s: s.update(bounds=dg.Box(12.0, 1.4),
                                              positions=np.full_like(s["positions"],
                                                                     [6.0, 0.7]),
                                              integrator="event"), label="event-fit")
    add("range", "integrator", _set("integrator", "exact"))
    add("type", "clock", _set("clock", (0.0, 1, 0.0)), label="three-parts")
    add("type", "clock", _set("clock", lambda s: (s["clock"][0], 1.5) + s["clock"][2:]),
        label="float-steps")
    add("negative", "clock", _set("clock", lambda s: (-1.0,) + s["clock"][1:]))
    add("range", "clock", _set("clock", lambda s: s["clock"][:3] + (2 ** 63,)), label="2**63")
    add("nonfinite", "clock", _set("clock", lambda s: (math.nan,) + s["clock"][1:]))
    add("type", "integrator", _set("integrator", 1))

    def rng(edit):
        def f(s):
            r = s["rng"]
            r["state"] = dict(r["state"])
            edit(r)
        return f

    for lab, edit in [
        ("no-inc", lambda r: r["state"].pop("inc")),
        ("even-inc", lambda r: r["state"].update(inc=r["state"]["inc"] - 1)),
        ("float-state", lambda r: r["state"].update(state=1.5)),
        ("bool-state", lambda r: r["state"].update(state=True)),
        ("negative-state", lambda r: r["state"].update(state=-1)),
        ("huge-state", lambda r: r["state"].update(state=2 ** 128)),
        ("has_uint32=2", lambda r: r.update(has_uint32=2)),
        ("uinteger=-1", lambda r: r.update(uinteger=-1)),
        ("uinteger=2**32", lambda r: r.update(uinteger=2 ** 32)),
        ("extra-field", lambda r: r.update(extra=0)),
        ("no-has_uint32", lambda r: r.pop("has_uint32")),
        ("unknown-generator", lambda r: r.update(bit_generator="Nope")),
        ("mt19937-name", lambda r: r.update(bit_generator="MT19937")),
        ("state-not-a-dict", lambda r: r.update(state=[1, 3])),
    ]:
        add("rng", "rng", rng(edit), label=lab)
    add("rng", "rng", _set("rng", lambda s: list(s["rng"].items())), label="list")
    add("dup", "ids", lambda s: s["ids"].__setitem__(1, s["ids"][0]), label="first-second")
    add("dup", "ids", lambda s: s["ids"].__setitem__(-1, s["ids"][0]), label="first-last")
    add("next_id", "next_id", _set("next_id", lambda s: int(s["ids"].max())), label="max-id")
    add("next_id", "next_id", _set("next_id", 0), label="zero")
    add("unknown", "extra", _set("extra", 1))
    add("unknown", "Positions", _set("Positions", lambda s: s["positions"]))

    def fp(edit):
        def f(s):
            d = s["scene_fingerprint"]
            s["scene_fingerprint"] = {"species": [list(x) for x in d["species"]],
                                      "channels": list(d["channels"])}
            edit(s["scene_fingerprint"])
        return f

    for lab, edit in [
        ("mass", lambda d: d["species"][1].__setitem__(2, 2.5)),
        ("radius", lambda d: d["species"][0].__setitem__(1, 0.6)),
        ("name", lambda d: d["species"][2].__setitem__(0, "C")),
        ("formation", lambda d: d["species"][2].__setitem__(3, 0.0)),
        ("nan-mass", lambda d: d["species"][0].__setitem__(2, math.nan)),
        ("channels", lambda d: d["channels"].pop()),
        ("species-count", lambda d: d["species"].pop()),
        ("arity", lambda d: d["species"][0].pop()),
        ("extra-field", lambda d: d.update(extra=1)),
        ("no-channels", lambda d: d.pop("channels")),
    ]:
        add("scene", "scene_fingerprint", fp(edit), label=lab)
    return out


CASES = _cases()


@pytest.mark.parametrize("key, mutate, kind", CASES)
def test_a_bad_state_is_refused_naming_the_key_and_nothing_changes(key, mutate, kind):
    """Each damaged state raises ValueError naming ``state[key]``; the simulation's storage,
    counters and generator are untouched and it continues like a copy taken before."""
    sim = base()
    bad = sim.get_state()
    mutate(bad)
    assert_refused(sim, bad, key)


def test_the_sweep_covers_every_key():
    """Every key of a state has its missing / None / wrong-type case, and every array, number
    and counter its non-finite / negative / shape cases (a key added to get_state without
    cases fails here)."""
    kinds = {}
    for p in CASES:
        kinds.setdefault(p.values[0], set()).add(p.values[2])
    keys = set(_built().get_state())
    for k in keys:
        need = {"none", "type"} | (set() if k in OPTIONAL else {"missing"})
        if k in INT_ARRAYS + WHOLE + ("time", "since_reset", "internal_energy", "fsum"):
            need |= {"negative", "range"}
        if k in INT_ARRAYS + FLOAT_ARRAYS:
            need |= {"shape"}
        if k in FLOAT_ARRAYS + REAL:
            need |= {"nonfinite"}
        assert need <= kinds.get(k, set()), (k, need - kinds.get(k, set()))
    assert keys == set(PER_DISC_FLOAT) | set(INT_ARRAYS) | set(FLOAT_ARRAYS) | set(WHOLE) | \
        set(REAL) | set(OTHER)


def test_a_state_that_is_not_a_dict_is_refused():
    sim = base()
    for bad in (None, [], "state", 3):
        twin, before = sim.copy(), sim.get_state()
        with pytest.raises(ValueError, match="state dict"):
            sim.set_state(bad)
        same_state(sim.get_state(), before)
        sim.step(2)
        twin.step(2)
        same_state(sim.get_state(), twin.get_state())


def test_every_missing_key_is_named():
    """With several keys missing the first is named and the others listed."""
    sim = base()
    bad = sim.get_state()
    del bad["rng"], bad["time"]
    msg = assert_refused(sim, bad, "time")
    assert "'rng'" in msg


# ------------------------------------------------------------------ other scenes
OTHER_SCENES = {
    "masses": scene([A, dg.Species("B", 0.4, 2.5, 0.5), dg.Species("AB", 0.7, 3.5, -0.5)]),
    "radii": scene([A, dg.Species("B", 0.45, 2.0, 0.5), AB]),
    "species names": scene([A, dg.Species("C", 0.4, 2.0, 0.5), dg.Species("AC", 0.7, 3.0,
                                                                         -0.5)],
                           [dg.Combination("A", "C", "AC", 0.2, 0.3)], counts={"A": 10, "C": 10}),
    "formation energies": scene([A, B, dg.Species("AB", 0.7, 3.0, -1.5)]),
    "reactions": scene(reactions=[dg.Combination("A", "B", "AB", 0.2, 0.0)]),
    "reactions, more": scene(reactions=[REACT, dg.Decomposition("AB", "A", "B", 0.1)]),
    "species order": scene([B, A, AB]),
    "a species more": scene([A, B, AB, dg.Species("D", 0.3, 1.0)]),
}


@pytest.mark.parametrize("what", list(OTHER_SCENES))
def test_a_state_of_another_scene_is_refused_both_ways(what):
    """A state of a scene with other species (masses, radii, names, formation energies, order)
    or other reactions is refused naming ``state['scene_fingerprint']`` and what differs, in
    both directions; nothing changes."""
    other = dg.Simulation(OTHER_SCENES[what], seed=2)
    other.step(5)
    sim = base()
    word = {"reactions, more": "reactions", "species order": "species names",
            "a species more": "species names"}.get(what, what)
    msg = assert_refused(sim, other.get_state(), "scene_fingerprint")
    assert word in msg, msg
    assert_refused(other, sim.get_state(), "scene_fingerprint")


def test_what_is_not_in_the_fingerprint_may_differ():
    """dt, restitution, rates, barriers, relaxation and the scene's own bounds govern what
    happens next, not what a state means: such a scene takes the state (and its bounds)."""
    sim = base()
    st = sim.get_state()
    other = scene(reactions=[dg.Combination("A", "B", "AB", 0.7, 0.9)], dt=0.01,
                  restitution=1.0, internal_relaxation=0.1, bounds=dg.Circle(9.0))
    o = dg.Simulation(other, seed=5)
    o.set_state(st)
    assert o.bounds == st["bounds"] and o.energy_balance() == sim.energy_balance()
    o.step(20)
    assert o.overlaps() == 0 and o.outside() == 0 and np.isfinite(o.energy_balance())


def test_a_state_without_fingerprint_still_checks_the_reaction_count():
    """States of the previous version carry no fingerprint: a different number of reaction
    channels is still refused (naming ``state['ch_count']``)."""
    other = dg.Simulation(OTHER_SCENES["reactions"], seed=2)
    st = other.get_state()
    del st["scene_fingerprint"]
    assert_refused(base(), st, "ch_count")


# ------------------------------------------------------------------ valid states
def test_round_trip_into_another_simulation_continues_bit_for_bit():
    """get_state -> set_state on a fresh simulation of the same scene (other seed, other
    integrator setting) -> both continue identically; pickle and copy too."""
    a = base()
    st = a.get_state()
    b = dg.Simulation(SC, seed=99, integrator="event")
    b.set_state(st)
    same_state(b.get_state(), st)
    c, d = pickle.loads(pickle.dumps(a)), a.copy()
    for s in (a, b, c, d):
        s.step(30)
    for s in (b, c, d):
        same_state(s.get_state(), a.get_state())


def test_event_states_round_trip():
    a = dg.Simulation(SC, seed=3, integrator="event")
    a.advance(1.0)
    b = dg.Simulation(SC, seed=4)
    b.set_state(a.get_state())
    assert b.integrator == "event"
    a.advance(1.0)
    b.advance(1.0)
    same_state(a.get_state(), b.get_state())


@pytest.mark.parametrize("n", [0, 1, 20])
def test_plain_python_containers_restore_bit_for_bit(n):
    """A state written as plain lists and ints (as to JSON: ``tolist()``, fingerprint as
    lists) restores exactly, empty reactor included."""
    a = dg.Simulation(SC, counts={"A": n // 2, "B": n - n // 2}, seed=7)
    a.step(10)
    st = a.get_state()
    plain = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in st.items()}
    plain["scene_fingerprint"] = {"species": [list(x) for x in st["scene_fingerprint"]["species"]],
                                  "channels": list(st["scene_fingerprint"]["channels"])}
    b = dg.Simulation(SC, seed=8)
    b.set_state(plain)
    same_state(b.get_state(), st)
    a.step(20)
    b.step(20)
    same_state(a.get_state(), b.get_state())


def test_a_state_of_the_previous_version_restores_bit_for_bit():
    """No ``scene_fingerprint``, 11 counters: restored (the new counters at zero) and
    continues bit for bit."""
    a = base()
    st = a.get_state()
    old = {k: v for k, v in st.items() if k != "scene_fingerprint"}
    old["icnt"] = st["icnt"][:11]
    b = dg.Simulation(SC, seed=5)
    b.set_state(old)
    assert b.counters()["graze_repairs"] == 0
    a.step(30)
    b.step(30)
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.velocities, b.velocities) and a.reactions() == b.reactions()
    assert pickle.loads(pickle.dumps(b)).get_state().keys() == st.keys()


def test_optional_keys_and_edge_values_are_accepted():
    """Without ``integrator`` the simulation keeps its own; negative energy input and start
    energies, float32/int arrays (exactly representable) and a ``next_id`` far above every id
    are valid, and injected discs then take ids from ``next_id`` on."""
    sim = base()
    st = sim.get_state()
    ev = dg.Simulation(SC, seed=1, integrator="event")
    ev.set_state({k: v for k, v in st.items() if k != "integrator"})
    assert ev.integrator == "event"
    st2 = dict(st, energy_input=-3.0, energy_start=-7.25, next_id=10 ** 12,
               internal_energy=st["internal_energy"].astype(np.float32),
               species=st["species"].astype(np.uint8))
    st2["velocities"] = np.round(st["velocities"]).astype(np.int16)
    sim.set_state(st2)
    assert sim.energy_input == -3.0 and sim.get_state()["energy_start"] == -7.25
    assert sim.velocities.dtype == np.float64 and sim.species.dtype == st["species"].dtype
    assert sim.inject("A", 2) == 2
    assert sorted(sim.ids[-2:]) == [10 ** 12, 10 ** 12 + 1]
    assert math.isfinite(sim.energy_balance())


def test_a_simulation_with_a_non_pcg64_generator_pickles_and_copies():
    """A simulation seeded with another numpy bit generator (MT19937) restores into a fresh
    one (pickle, copy) with that generator, bit for bit; a PCG64 simulation takes such a
    state too."""
    a = dg.Simulation(SC, seed=np.random.Generator(np.random.MT19937(3)))
    a.step(10)
    b, c = pickle.loads(pickle.dumps(a)), a.copy()
    d = dg.Simulation(SC, seed=0)
    d.set_state(a.get_state())
    for s in (a, b, c, d):
        s.step(40)
    for s in (b, c, d):
        assert isinstance(s._rng.bit_generator, np.random.MT19937)
        same_state(s.get_state(), a.get_state())
    bad = a.get_state()
    bad["rng"]["state"]["key"] = bad["rng"]["state"]["key"][:5]
    assert_refused(a, bad, "rng")


def test_a_corrupt_pickle_payload_is_refused():
    sim = base()
    d = sim.__getstate__()
    other = dg.Simulation.__new__(dg.Simulation)
    with pytest.raises(ValueError, match="__setstate__"):
        other.__setstate__({"scene": "reactor", "state": d["state"]})
    with pytest.raises(ValueError, match=re.escape("state['time']")):
        other.__setstate__({"scene": d["scene"], "state": dict(d["state"], time=math.nan)})


# ------------------------------------------------------------------ random mutations
_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-2 ** 70, 2 ** 70),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=3),
    st.lists(st.floats(-20, 20), max_size=3), st.just(np.zeros((2, 2))),
)
_NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                     st.floats(-15.0, 15.0), st.integers(-5, 2 ** 64))


@st.composite
def mutations(draw):
    s = _built().get_state()
    for key in draw(st.lists(st.sampled_from(list(s) + ["extra"]), min_size=1, max_size=3,
                             unique=True)):
        op = draw(st.sampled_from(["delete", "replace", "element", "rows", "dtype", "nested",
                                   "nudge", "nudge"]))
        v = s.get(key)
        if op == "nudge" and isinstance(v, np.ndarray) and v.dtype.kind == "f" and v.size:
            # small changes, mostly accepted: discs moved (maybe onto others), sped up
            a = v.copy()
            for _ in range(draw(st.integers(1, 4))):
                a[tuple(draw(st.integers(0, m - 1)) for m in a.shape)] += draw(
                    st.floats(-1.0, 1.0))
            s[key] = a
        elif op == "delete":
            s.pop(key, None)
        elif op == "replace" or v is None:
            s[key] = draw(_VALUES)
        elif isinstance(v, np.ndarray) and op == "element" and v.size:
            a = v.astype(float) if draw(st.booleans()) else v.copy()
            idx = tuple(draw(st.integers(0, m - 1)) for m in v.shape)
            x = draw(_NUMBERS)
            try:
                a[idx] = x
            except (OverflowError, ValueError):
                a = np.asarray(a, dtype=object)
                a[idx] = x
            s[key] = a
        elif isinstance(v, np.ndarray) and op == "rows":
            k = draw(st.integers(0, len(v)))
            s[key] = np.concatenate([v[:k], v[k + 1:]]) if draw(st.booleans()) else \
                np.concatenate([v[:k], v[k:k + 1], v[k:]])
        elif isinstance(v, np.ndarray) and op == "dtype":
            s[key] = v.astype(draw(st.sampled_from([bool, np.float32, np.int8, np.uint64,
                                                    np.complex128, str, object])))
        elif key == "ids" and op == "nested" and len(v) > 1:
            i, j = draw(st.integers(0, len(v) - 1)), draw(st.integers(0, len(v) - 1))
            v[i] = v[j]
        elif key == "bounds":
            w = draw(st.floats(0.5, 30.0))
            s[key] = dg.Box(w, draw(st.floats(0.5, 30.0)), (draw(st.floats(-5, 5)), 0.0)) \
                if draw(st.booleans()) else dg.Circle(w, (6.0, draw(st.floats(0.0, 12.0))))
        elif key == "rng":
            r = dict(v, state=dict(v["state"]))
            tgt = r["state"] if draw(st.booleans()) else r
            tgt[draw(st.sampled_from(sorted(tgt) + ["x"]))] = draw(
                st.one_of(_VALUES, st.integers(0, 2 ** 129)))
            s[key] = r
        elif key == "scene_fingerprint":
            sp = [list(x) for x in v["species"]]
            sp[draw(st.integers(0, 2))][draw(st.integers(0, 3))] = draw(_VALUES)
            s[key] = {"species": sp, "channels": list(v["channels"])}
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            s[key] = v + draw(st.sampled_from([-1, 1, 0.5, -0.5, 1e300])) * \
                draw(st.integers(1, 3))
        else:
            s[key] = draw(_VALUES)
    return s


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutations())
def test_random_mutations_are_refused_unchanged_or_accepted_and_run(bad):
    """A randomly damaged state is either refused (ValueError naming a ``state[...]`` key, the
    simulation exactly as before and continuing like a copy), or accepted, and then the
    simulation steps with no NaN, nothing outside, no overlap beyond what the state had, a
    finite energy balance, and ids that stay unique when discs are injected."""
    sim = base()
    twin, before, raw = sim.copy(), sim.get_state(), buffers(sim)
    try:
        sim.set_state(bad)
    except ValueError as exc:
        assert re.search(r"state\[|state dict", str(exc)), str(exc)
        same_state(sim.get_state(), before)
        assert buffers(sim) == raw
        sim.step(3)
        twin.step(3)
        same_state(sim.get_state(), twin.get_state())
        return
    had = sim.overlaps()
    sim.step(3)
    assert np.isfinite(sim.positions).all() and np.isfinite(sim.velocities).all()
    assert sim.outside() == 0 and sim.overlaps() <= had
    assert math.isfinite(sim.energy_balance())
    sim.inject("A", 2)
    ids = sim.ids
    assert len(np.unique(ids)) == len(ids)
    again = dg.Simulation(SC, seed=0)
    again.set_state(sim.get_state())  # what was accepted leads to states that are too
    same_state(again.get_state(), sim.get_state())


def test_state_outside_the_arithmetic_range_is_refused_and_changes_nothing():
    """The scale range of scenes (lengths 1e-40..1e40, internal energies <= 1e40) holds for
    restored states too: bounds too large, or too far from the origin for the smallest disc,
    and a larger internal energy are refused naming the key."""
    sim = dg.Simulation("ideal_gas", seed=0)
    before = sim.get_state()
    cases = [("bounds", dg.Box(1e41, 1e41), "bounds.width"),
             ("bounds", dg.Box(1000.0, 1000.0, origin=(6e8, 0.0)), "farthest coordinate"),
             ("internal_energy", np.full(len(sim), 1e41), "above 1e\\+40")]
    for key, value, why in cases:
        bad = dict(before, **{key: value})
        with pytest.raises(ValueError, match=rf"state\['{key}'\].*{why}"):
            sim.set_state(bad)
        after = sim.get_state()
        for k in before:
            if isinstance(before[k], np.ndarray):
                assert np.array_equal(before[k], after[k]), k
            else:
                assert before[k] == after[k], k


def test_a_clock_that_does_not_give_the_times_restarts_at_them():
    """``time`` and ``since_reset`` are what a state says: a clock that does not give them
    (edited times, another dt) restarts there, and the simulation then runs as one restored
    from a state without a clock (an earlier version's)."""
    sim = _built()
    st = sim.get_state()
    assert st["clock"] == (0.0, 60, 0.0, 20)  # 60 steps, the counters reset after 40
    edited = dict(st, time=st["time"] + 1.0)
    a, b = _built(), _built()
    a.set_state(edited)
    b.set_state({k: v for k, v in edited.items() if k != "clock"})
    assert a.get_state()["clock"] == (edited["time"], 0, st["since_reset"], 0)
    a.step(3)
    b.step(3)
    assert a.time == b.time and a.get_state()["clock"] == b.get_state()["clock"]
