"""Malformed input, as a generated family: every malformed scene (dict or TOML file)
raises a clear :class:`discgym.SceneError` naming the offending field, and nothing reaches
the numba kernels.

The family is built from every built-in scene: each field of its dict form (top level,
bounds, every species, every reaction, the counts) is replaced by each value from a list of
bad values for that field, and structural damage (missing and unknown keys, wrong container
types, cross-field contradictions, truncated files) is added. Every mutant is checked twice:
through :meth:`Scene.from_dict` (the exact field path) and written as a TOML file through
:meth:`Scene.from_toml` (the same field, the file named in the message).

Beyond the scene: malformed initial arrays (``Simulation.from_arrays``) and malformed states
(``Simulation.set_state``) must raise ``ValueError`` before any kernel runs; and scenes that
validate but carry extreme magnitudes must either be refused or run soundly.
"""

import copy
import math
import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pytest

import discgym as dg
from discgym.scene import SceneError

NAN, INF = math.nan, math.inf
SCENES = dg.scenes.names()
BASE = {name: dg.scenes.load(name).to_dict() for name in SCENES}

# bad values per field (each one invalid for that field whatever the rest of the scene)
NUMBER_JUNK = ["1", True, [1.0], {"x": 1.0}]
BAD_TOP = {
    "restitution": [-0.1, 1.5, NAN, INF, *NUMBER_JUNK],
    "dt": [0.0, -0.02, NAN, INF, -INF, *NUMBER_JUNK],
    "internal_relaxation": [-0.5, 1.01, NAN, INF, *NUMBER_JUNK],
    "max_displacement": [0.0, -1.0, 1.5, NAN, INF, *NUMBER_JUNK],
    "temperature": [-1.0, NAN, INF, *NUMBER_JUNK],
    "collisions": [1, 0, 1.0, "yes", [True]],
    "name": [5, 1.5, ["a"], True],
    "description": [5, {"a": 1}, False],
}
BAD_POSITIVE = [0, 0.0, -1.0, NAN, INF, -INF, *NUMBER_JUNK]
BAD_BOUNDS = {
    "box": {"width": BAD_POSITIVE, "height": BAD_POSITIVE,
            "origin": [[NAN, 0.0], [0.0, INF], [1.0, 2.0, 3.0], [1.0], 5, "ab", [True, 0.0],
                       [1e12, 0.0]]},
    "circle": {"radius": BAD_POSITIVE,
               "center": [[NAN, 0.0], [0.0, -INF], [1.0], 5, [0.0, 1e12], ["x", 0.0]]},
}
BAD_SHAPE = ["hexagon", "Box", 5, True, ["box"]]
BAD_SPECIES = {
    "name": ["", "   ", 5, ["A"], True],
    "radius": [*BAD_POSITIVE, 1e6],  # 1e6: larger than any bounds
    "mass": BAD_POSITIVE,
    "formation_energy": [NAN, INF, -INF, *NUMBER_JUNK],
}
BAD_REACTION_PARAMS = {
    "probability": [-0.1, 1.1, NAN, INF, *NUMBER_JUNK],
    "activation_energy": [-1.0, NAN, INF, *NUMBER_JUNK],
    "reverse_probability": [-0.1, 2.0, NAN, *NUMBER_JUNK],
}
BAD_NAME_LISTS = [[], "A", [5], [""], ["no_such_species"]]
BAD_TYPES = ["fusion", 5, True, ["combination"]]
BAD_COUNTS = [-1, 1.5, "3", True, NAN, [3], 10**9]


# mutants that expose a bug today: (substring of the id, reason); marked xfail(strict=True)
KNOWN_BUGS: list = []  # (fixed: a reaction type that is a list raised TypeError)


def mutants():
    """(id, dict, expected field path) for the whole family."""
    out = []
    for name, base in BASE.items():
        def add(label, d, field, name=name):
            marks = [pytest.mark.xfail(strict=True, reason=why)
                     for key, why in KNOWN_BUGS if key in label]
            out.append(pytest.param(d, field, id=f"{name}:{label}", marks=marks))

        for key, values in BAD_TOP.items():
            for v in values:
                d = copy.deepcopy(base)
                d[key] = v
                add(f"{key}={v!r}", d, key)
        shape = base["bounds"]["shape"]
        for key, values in BAD_BOUNDS[shape].items():
            for v in values:
                d = copy.deepcopy(base)
                d["bounds"][key] = v
                add(f"bounds.{key}={v!r}", d, f"bounds.{key}")
            d = copy.deepcopy(base)
            del d["bounds"][key]
            if key in ("width", "height", "radius"):  # required
                add(f"bounds.{key} missing", d, f"bounds.{key}")
        for v in BAD_SHAPE:
            d = copy.deepcopy(base)
            d["bounds"]["shape"] = v
            add(f"bounds.shape={v!r}", d, "bounds.shape")
        d = copy.deepcopy(base)
        d["bounds"]["depth"] = 3.0
        add("bounds.depth unknown", d, "bounds.depth")
        for k, sp in enumerate(base["species"]):
            for key, values in BAD_SPECIES.items():
                for v in values:
                    d = copy.deepcopy(base)
                    d["species"][k][key] = v
                    add(f"species[{k}].{key}={v!r}", d, f"species[{k}].{key}")
                if key != "formation_energy":
                    d = copy.deepcopy(base)
                    del d["species"][k][key]
                    add(f"species[{k}].{key} missing", d, f"species[{k}].{key}")
            d = copy.deepcopy(base)
            d["species"][k]["spin"] = 0.5
            add(f"species[{k}].spin unknown", d, f"species[{k}].spin")
            d = copy.deepcopy(base)
            d["species"][k] = [sp["name"], sp["radius"]]
            add(f"species[{k}] not a table", d, f"species[{k}]")
            if k > 0:
                d = copy.deepcopy(base)
                d["species"][k]["name"] = base["species"][0]["name"]
                add(f"species[{k}].name duplicate", d, f"species[{k}].name")
        for k, rx in enumerate(base["reactions"]):
            where = f"reactions[{k}]"
            for key, values in BAD_REACTION_PARAMS.items():
                if key not in rx:
                    continue
                for v in values:
                    d = copy.deepcopy(base)
                    d["reactions"][k][key] = v
                    add(f"{where}.{key}={v!r}", d, f"{where}.{key}")
            for role in ("reactants", "products"):
                n = len(rx[role])
                bad = BAD_NAME_LISTS + [rx[role] + rx[role][:1]]  # one too many
                if n == 2:
                    bad.append(rx[role][:1])  # one too few
                for v in bad:
                    d = copy.deepcopy(base)
                    d["reactions"][k][role] = v
                    add(f"{where}.{role}={v!r}", d, f"{where}.{role}")
            for v in BAD_TYPES:
                d = copy.deepcopy(base)
                d["reactions"][k]["type"] = v
                add(f"{where}.type={v!r}", d, f"{where}.type")
            d = copy.deepcopy(base)
            d["reactions"][k]["rate"] = 1.0
            add(f"{where}.rate unknown", d, f"{where}.rate")
            d = copy.deepcopy(base)
            d["reactions"][k] = "A -> B"
            add(f"{where} not a table", d, where)
            if rx["type"] in ("transformation", "decomposition"):
                d = copy.deepcopy(base)
                del d["reactions"][k]["probability"]
                add(f"{where}.probability missing", d, f"{where}.probability")
            # mass no longer conserved: make the first product heavier
            d = copy.deepcopy(base)
            names = [s["name"] for s in d["species"]]
            prod = names.index(rx["products"][0])
            d["species"][prod]["mass"] = d["species"][prod]["mass"] * 1.5 + 0.25
            path = f"reactions[{k}].products"
            if any(prod == names.index(r) for r in rx["reactants"]):
                path = None  # the species is on both sides: another reaction may object
            add(f"{where} mass not conserved", d, path)
            if len(rx["reactants"]) == 2:  # a second reaction on the same pair
                d = copy.deepcopy(base)
                d["reactions"].append(copy.deepcopy(rx))
                add(f"{where} pair twice", d, f"reactions[{len(base['reactions'])}].reactants")
        counted = list(base["counts"]) or [base["species"][0]["name"]]
        for v in BAD_COUNTS:
            d = copy.deepcopy(base)
            d["counts"][counted[0]] = v
            add(f"counts.{counted[0]}={v!r}", d,
                "counts" if v == 10**9 else f"counts.{counted[0]}")
        d = copy.deepcopy(base)
        d["counts"]["no_such_species"] = 1
        add("counts unknown species", d, "counts.no_such_species")
        # structure
        for key in ("bounds", "species"):
            d = copy.deepcopy(base)
            del d[key]
            add(f"{key} missing", d, key)
        for key, v in [("species", {"A": 1}), ("species", []), ("species", "A"),
                       ("reactions", {"type": "combination"}), ("reactions", "none"),
                       ("counts", [1, 2]), ("counts", 5), ("bounds", [10.0, 10.0]),
                       ("bounds", "box")]:
            d = copy.deepcopy(base)
            d[key] = v
            add(f"{key}={v!r}", d, key)
        d = copy.deepcopy(base)
        d["colour"] = "red"
        add("unknown top-level key", d, "colour")
        d = copy.deepcopy(base)
        d["bounds"] = {"shape": "box", "width": 1e-3, "height": 1e-3}
        add("bounds smaller than the discs", d, "species[0].radius")
        # thermal walls and outlets (docs/physics.md): each field, structure, contradictions
        side = "left" if shape == "box" else "wall"
        other = "wall" if shape == "box" else "left"
        good_wall = {"side": side, "temperature": 1.0}
        good_outlet = {"side": side, "start": 0.25, "end": 0.5}
        for v in [other, "nowhere", "", 5, True, ["left"]]:
            d = copy.deepcopy(base)
            d["thermal_walls"] = [dict(good_wall, side=v)]
            add(f"thermal_walls[0].side={v!r}", d, "thermal_walls[0].side")
            d = copy.deepcopy(base)
            d["outlets"] = [dict(good_outlet, side=v)]
            add(f"outlets[0].side={v!r}", d, "outlets[0].side")
        for v in [0.0, -1.0, NAN, INF, 1e41, 1e30, *NUMBER_JUNK]:  # 1e30: past the speed limit
            d = copy.deepcopy(base)
            d["thermal_walls"] = [dict(good_wall, temperature=v)]
            add(f"thermal_walls[0].temperature={v!r}", d, "thermal_walls[0].temperature")
        for key, values in (("start", [-0.1, 1.5, NAN, 0.5, 0.75, *NUMBER_JUNK]),
                            ("end", [1.01, 0.25, 0.1, NAN, INF, *NUMBER_JUNK])):
            for v in values:
                d = copy.deepcopy(base)
                d["outlets"] = [dict(good_outlet, **{key: v})]
                # (a start at or past the end is reported on end)
                path = "outlets[0].end" if key == "start" and v in (0.5, 0.75) else \
                    f"outlets[0].{key}"
                add(f"outlets[0].{key}={v!r}", d, path)
        for key, good in (("thermal_walls", good_wall), ("outlets", good_outlet)):
            for field in good:
                d = copy.deepcopy(base)
                d[key] = [{a: b for a, b in good.items() if a != field}]
                add(f"{key}[0].{field} missing", d, f"{key}[0].{field}")
            d = copy.deepcopy(base)
            d[key] = [dict(good, colour="red")]
            add(f"{key}[0].colour unknown", d, f"{key}[0].colour")
            for v in [good, "left", 5]:
                d = copy.deepcopy(base)
                d[key] = v
                add(f"{key}={v!r}", d, key)
            d = copy.deepcopy(base)
            d[key] = ["left"]
            add(f"{key}[0] not a table", d, f"{key}[0]")
        d = copy.deepcopy(base)
        d["thermal_walls"] = [good_wall, dict(good_wall, temperature=2.0)]
        add("thermal_walls side twice", d, "thermal_walls[1].side")
        d = copy.deepcopy(base)
        d["outlets"] = [good_outlet, dict(good_outlet, start=0.4, end=0.6)]
        add("outlets overlapping", d, "outlets[1].start")
    return out


MUTANTS = mutants()


def test_the_family_is_large():
    """The generated family covers every built-in scene and >1000 mutants."""
    assert len(MUTANTS) > 1000
    assert {p.id.split(":")[0] for p in MUTANTS} == set(SCENES)


@pytest.mark.parametrize("data, field", MUTANTS)
def test_malformed_scene_dict_names_the_field(data, field):
    """Every mutant raises SceneError (a ValueError) from ``Scene.from_dict``, whose
    ``field`` is the mutated path (or starts with it: ``bounds.origin[0]``), and whose
    message starts with that field."""
    with pytest.raises(SceneError) as exc:
        dg.Scene.from_dict(data)
    if field is not None:
        assert exc.value.field == field or exc.value.field.startswith(field + "["), \
            f"field {exc.value.field!r}, expected {field!r}: {exc.value}"
    assert str(exc.value).startswith(exc.value.field)


# ------------------------------------------------------------------------------ TOML files
def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def to_toml(d):
    """Write a (possibly malformed) scene dict as TOML, tables as tables where possible."""
    top, tables = [], []
    for k, v in d.items():
        if k in ("bounds", "counts") and isinstance(v, dict):
            tables += ["", f"[{k}]"] + [f"{a} = {_toml_value(b)}" for a, b in v.items()]
        elif k in ("species", "reactions", "thermal_walls", "outlets") and \
                isinstance(v, list) and v and \
                all(isinstance(x, dict) for x in v):
            for x in v:
                tables += ["", f"[[{k}]]"] + [f"{a} = {_toml_value(b)}" for a, b in x.items()]
        else:
            top.append(f"{k} = {_toml_value(v)}")
    return "\n".join(top + tables) + "\n"


def test_toml_writer_round_trips_the_builtins(tmp_path):
    """The test's own TOML writer reproduces every built-in scene exactly."""
    for name, d in BASE.items():
        p = tmp_path / f"{name}.toml"
        p.write_text(to_toml(d))
        assert dg.Scene.from_toml(p) == dg.scenes.load(name)


@pytest.mark.parametrize("data, field", MUTANTS)
def test_malformed_scene_file_names_the_field_and_the_file(data, field, tmp_path):
    """Each mutant written as a TOML file: ``Scene.from_toml`` raises SceneError naming the
    same field, and the message names the file."""
    p = tmp_path / "bad.toml"
    p.write_text(to_toml(data))
    with pytest.raises(SceneError) as exc:
        dg.Scene.from_toml(p)
    if field is not None:
        assert exc.value.field == field or exc.value.field.startswith(field + "["), \
            f"field {exc.value.field!r}, expected {field!r}: {exc.value}"
    assert "bad.toml" in str(exc.value)


@pytest.mark.parametrize("name", SCENES)
def test_truncated_and_garbled_toml_files(name, tmp_path):
    """Every built-in scene file cut after each of its lines, and cut at 40 random
    characters, either loads as a valid scene or raises SceneError: never another
    exception. A line replaced by junk likewise."""
    text = dg.scenes.load(name).to_toml()
    lines = text.splitlines(keepends=True)
    rng = np.random.default_rng(0)
    cuts = ["".join(lines[:k]) for k in range(len(lines))]
    cuts += [text[:int(k)] for k in rng.integers(0, len(text), 40)]
    junk = ["= = =", "[bounds", "[[species]", "radius = ", "x = [1, 2", "\x00", "name = 'A",
            "[counts]\nA = -", "species = 5"]
    cuts += ["".join(lines[:k] + [j + "\n"] + lines[k + 1:])
             for k in range(0, len(lines), 3) for j in junk]
    p = tmp_path / "cut.toml"
    n_errors = 0
    for t in cuts:
        p.write_text(t)
        try:
            dg.Scene.from_toml(p)
        except SceneError as exc:
            assert "cut.toml" in str(exc)
            n_errors += 1
    assert n_errors > 0.8 * len(cuts)


def test_undecodable_toml_file_is_a_value_error(tmp_path):
    """A file that is not UTF-8 raises a ValueError (not a crash)."""
    p = tmp_path / "binary.toml"
    p.write_bytes(b"\xff\xfe\x00bounds = 1\n")
    with pytest.raises(ValueError):
        dg.Scene.from_toml(p)


@pytest.mark.parametrize("kw, field", [
    (dict(counts={"A": -1}), "counts.A"),
    (dict(counts={"Q": 1}), "counts.Q"),
    (dict(counts={"A": 10**9}), "counts"),
    (dict(counts={"A": 1.5}), "counts.A"),
    (dict(temperature=NAN), "temperature"),
    (dict(temperature=-INF), "temperature"),
    (dict(temperature=-1.0), "temperature"),
])
def test_simulation_arguments_are_validated_through_the_scene(kw, field):
    """``Simulation(scene, counts=..., temperature=...)`` validates through the scene model:
    a SceneError naming the field."""
    with pytest.raises(SceneError) as exc:
        dg.Simulation("ideal_gas", **kw)
    assert exc.value.field == field


# ------------------------------------------------------------------ from_arrays, set_state
SC = dg.Scene(bounds=dg.Box(10.0, 10.0), species=[dg.Species("A", 0.5, 1.0)], dt=0.05)
P, V, S = [[2.0, 2.0], [5.0, 5.0]], [[0.0, 0.0], [1.0, 1.0]], [0, 0]


@pytest.mark.parametrize("args, match", [
    ((np.zeros((2, 3)), V, S, None), "positions"),
    (([1.0, 2.0], V, S, None), "positions"),
    (([["a", "b"], [1, 2]], V, S, None), None),
    (([[1.0, 2.0], [3.0]], V, S, None), None),
    ((P, [[INF, 0.0], [0.0, 0.0]], S, None), "velocities"),
    ((P, [[NAN, 0.0], [0.0, 0.0]], S, None), "velocities"),
    (([[NAN, 5.0], [5.0, 5.0]], V, S, None), "positions"),
    ((P, [[0.0, 0.0]], S, None), "velocities"),
    ((P, V, [0.5, 0], None), "species"),
    ((P, V, [-1, 0], None), "species"),
    ((P, V, [3, 0], None), "species"),
    ((P, V, [0], None), "species"),
    ((P, V, ["B", "A"], None), "species"),
    ((P, V, S, [-1.0, 0.0]), "internal_energy"),
    ((P, V, S, [NAN, 0.0]), "internal_energy"),
    ((P, V, S, [0.0]), "internal_energy"),
    (([[20.0, 20.0], [5.0, 5.0]], V, S, None), "not inside"),
    (([[5.0, 5.2], [5.0, 5.0]], V, S, None), "overlap"),
    pytest.param((P, V, [None, 0], None), "species"),
])
def test_malformed_initial_arrays_raise_value_error(args, match):
    """``Simulation.from_arrays`` refuses malformed arrays with ValueError (naming the array
    where the message is the simulator's own) before any kernel runs."""
    p, v, s, u = args
    with pytest.raises(ValueError, match=match):
        dg.Simulation.from_arrays(SC, p, v, s, internal_energy=u)


def test_from_arrays_accepts_an_empty_reactor():
    """Zero discs is a valid (empty) reactor, as ``Simulation(scene, counts={})`` is."""
    sim = dg.Simulation.from_arrays(SC, np.zeros((0, 2)), np.zeros((0, 2)), [])
    assert len(sim) == 0
    sim.step(3)


def _state_mutants():
    out = []
    for key, idx, value in [
        ("positions", (0, 0), NAN), ("positions", (0, 1), INF), ("positions", (0,), [50, 50]),
        ("velocities", (0, 0), INF), ("velocities", (1, 1), NAN),
        ("species", (0,), 7), ("species", (0,), -1),
        ("internal_energy", (0,), -5.0), ("internal_energy", (0,), NAN),
    ]:
        out.append(pytest.param(key, idx, value, id=f"{key}{list(idx)}={value!r}"))
    return out


@pytest.mark.parametrize("key, idx, value", _state_mutants())
def test_malformed_state_is_refused_by_set_state(key, idx, value):
    """``set_state`` with a damaged state raises ValueError naming the key, and leaves the
    simulation as it was."""
    sim = dg.Simulation(SC.replace(counts={"A": 5}), seed=0)
    good = sim.get_state()
    bad = sim.get_state()
    bad[key] = np.array(bad[key], dtype=float if key != "species" else bad[key].dtype)
    bad[key][idx] = value
    with pytest.raises(ValueError, match=key):
        sim.set_state(bad)
    assert np.array_equal(sim.positions, good["positions"])


def _run_isolated(code: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter (a segfault must not take pytest down)."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=300)


def test_infinite_velocity_never_crashes_the_process():
    """An infinite velocity smuggled in through ``set_state`` is refused (ValueError), or the
    step and the diagnostics cope: the interpreter never dies inside numba. Run in a
    subprocess."""
    r = _run_isolated("""
        import numpy as np, discgym as dg
        sc = dg.Scene(bounds=dg.Box(10.0, 10.0), species=[dg.Species("A", 0.5, 1.0)],
                      counts={"A": 5}, dt=0.05)
        sim = dg.Simulation(sc, seed=0)
        st = sim.get_state()
        st["velocities"][0] = [np.inf, 0.0]
        try:
            sim.set_state(st)
        except ValueError:
            print("refused")
        else:
            sim.step(1)
            print(sim.outside(), sim.overlaps())
    """)
    assert r.returncode == 0, f"exit {r.returncode}: {r.stderr[-500:]}"


# --------------------------------------------------------- valid scenes, extreme magnitudes
def _sound(sim):
    return (np.isfinite(sim.positions).all() and np.isfinite(sim.velocities).all()
            and sim.outside(1e-9) == 0 and sim.overlaps(1e-9) == 0
            and math.isfinite(sim.energy_balance()))


_A = dg.Species("A", 0.5, 1.0)
EXTREME = [
    pytest.param(dict(dt=1e-300), id="dt=1e-300"),
    pytest.param(dict(temperature=1e-300), id="T=1e-300"),
    pytest.param(dict(species=[dg.Species("A", 0.5, 1e300)]), id="mass=1e300"),
    pytest.param(dict(species=[dg.Species("A", 1e-300, 1.0)]), id="radius=1e-300"),
    pytest.param(dict(bounds=dg.Box(1e-300, 1e-300), species=[dg.Species("A", 1e-301, 1.0)]),
                 id="box=1e-300"),
    pytest.param(dict(bounds=dg.Circle(1e-300), species=[dg.Species("A", 1e-301, 1.0)]),
                 id="circle=1e-300"),
    pytest.param(dict(bounds=dg.Box(1e300, 1e300)), id="box=1e300"),
    pytest.param(dict(species=[dg.Species("A", 0.5, 1.0, formation_energy=1e300)]),
                 id="F=1e300"),
    pytest.param(dict(dt=1e300), id="dt=1e300"),
    pytest.param(dict(temperature=1e300), id="T=1e300"),
    pytest.param(dict(species=[dg.Species("A", 0.5, 1e-300)]), id="mass=1e-300"),
    pytest.param(dict(species=[dg.Species("A", 0.5, 1.0, formation_energy=-1e308)]),
                 id="F=-1e308"),
]


@pytest.mark.parametrize("kw", EXTREME)
def test_valid_scene_with_extreme_magnitudes_is_refused_or_runs_soundly(kw):
    """A scene that passes validation but has extreme magnitudes (10 discs, 3 steps): either
    it is refused with a ValueError (SceneError) when built or simulated, or the run stays
    sound (finite, inside, no overlap, finite energy balance)."""
    base = dict(bounds=dg.Box(10.0, 10.0), species=[_A], counts={"A": 10}, dt=0.05)
    base.update(kw)
    warnings.simplefilter("ignore", RuntimeWarning)  # numpy overflow in the energy sums
    try:
        sim = dg.Simulation(dg.Scene(**base), seed=0)
        sim.step(3)
    except ValueError:
        return
    assert _sound(sim)


def test_huge_radius_is_a_scene_error():
    """A species radius of 1e200 in bounds of 1e300: validation either accepts it or raises
    SceneError; never OverflowError."""
    try:
        dg.Scene(bounds=dg.Box(1e300, 1e300), species=[dg.Species("A", 1e200, 1.0)],
                 counts={"A": 1})
    except SceneError:
        pass


@pytest.mark.parametrize("tol", [-0.1, 1.0, float("nan")])
def test_overlap_counter_refuses_a_tolerance_it_cannot_honour(tol):
    """``sim.overlaps(tol)`` counts pairs closer than (1 - tol) of their contact distance; a
    negative tol (closer than touching: its search reach would need widening), tol >= 1 or
    NaN raise ValueError instead of undercounting."""
    sim = dg.Simulation(SC.replace(counts={"A": 5}), seed=0)
    with pytest.raises(ValueError, match="tol"):
        sim.overlaps(tol)
