"""Scale and numbers: the magnitudes the float64 kernels can do, and numpy scalars.

Scale (``discgym.scene.MIN_MAGNITUDE`` .. ``MAX_MAGNITUDE``): every length, the time step and
every mass in [1e-40, 1e40], every energy at most 1e40 in magnitude, bounds reaching at most
``MAX_COORDINATE_RATIO`` (1e9) smallest radii from the origin. Inside, a scene simulates as it
does at unit scale (the same collisions, positions and velocities to 1e-12 relative, in both
integrators); just outside, it is refused with a SceneError naming the field (in code, as a
dict and from a TOML file with the file and line), or a ValueError naming the argument.

Numbers: numpy scalars (np.float64, np.float32, np.float16, np.int64, np.int32, np.uint16;
np.bool_ where a bool is expected) are accepted wherever the Python number is, and give
exactly what the Python number (``value.item()``) gives; where the Python number is refused
(a bool where a number is needed, a non-integral count, NaN, inf) they are refused too, naming
the same field or argument.
"""

import itertools
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import discgym as dg
from discgym.scene import MAX_COORDINATE_RATIO, MAX_MAGNITUDE, MIN_MAGNITUDE, SceneError

LO, HI = MIN_MAGNITUDE, MAX_MAGNITUDE
OUT = 1.0 + 1e-9  # just outside the range: a value times OUT (above) or divided by it (below)


# ===================================================================================== scale
def _head_on(sL, sT, sM, kind, integrator):
    """An oblique collision of discs of radius 0.5 and 0.25 (masses 1, 2) in a 32-wide box or
    a circle of radius 16, followed by wall hits over 16 time units (dt = 0.0625), with every
    length scaled by sL, time by sT and mass by sM. Returns the positions and velocities in
    unit-scale units, the counters and the kinetic energy in units of sM sL^2 / sT^2."""
    v = sL / sT
    species = [dg.Species("A", 0.5 * sL, 1.0 * sM), dg.Species("B", 0.25 * sL, 2.0 * sM)]
    if kind == "box":
        bounds, c = dg.Box(32.0 * sL, 32.0 * sL), 16.0
    else:
        bounds, c = dg.Circle(16.0 * sL), 0.0
    sc = dg.Scene(bounds=bounds, species=species, dt=0.0625 * sT, temperature=0.0)
    pos = np.array([[c - 10.0, c], [c, c + 0.3]]) * sL
    vel = np.array([[1.0, 0.0], [-2.0, 0.1]]) * v
    sim = dg.Simulation.from_arrays(sc, pos, vel, [0, 1], integrator=integrator)
    ke0 = sim.kinetic_energy()
    sim.advance(16.0 * sT)
    assert sim.overlaps(1e-9) == 0 and sim.outside(1e-12) == 0
    return (sim.positions / sL, sim.velocities / v, sim.collisions, sim.wall_hits,
            ke0 / (sM * v * v), sim.kinetic_energy() / (sM * v * v))


# the extreme scale factors a valid scene of _head_on allows: the smaller radius (0.25 sL)
# at 1e-40, the box width (32 sL) or the circle's radius (16 sL) at 1e40, dt (0.0625 sT) at
# 1e-40 and 1e40, the masses (1 sM, 2 sM) at 1e-40 and 1e40
S_L = {"box": (4e-40, 1.0, 1e40 / 32.0), "circle": (4e-40, 1.0, 1e40 / 16.0)}
S_T = (1.6e-39, 1.0, 1.6e41)
S_M = (1e-40, 1.0, 5e39)


@pytest.mark.parametrize("integrator", ["step", "event"])
@pytest.mark.parametrize("kind", ["box", "circle"])
def test_collision_at_the_edges_of_the_range_is_the_one_at_unit_scale(kind, integrator):
    """Every combination of length, time and mass scales at the edges of the accepted range
    (27 per bounds kind, lengths, dt and masses at 1e-40 or 1e40, speeds from 3e-81 to 4e77):
    the same collisions and wall hits as at unit scale, positions to 1e-12 of the box,
    velocities and kinetic energy to 1e-12 relative, no overlap, nothing outside. (Beyond
    1e+-77 in lengths, before the range was enforced, positions ended 3-10% of a radius off
    and the event-driven integrator missed every collision.)"""
    ref = _head_on(1.0, 1.0, 1.0, kind, integrator)
    assert ref[2] >= 1 and ref[3] >= 1  # a collision and wall hits happen
    for sL, sT, sM in itertools.product(S_L[kind], S_T, S_M):
        got = _head_on(sL, sT, sM, kind, integrator)
        where = f"sL={sL:g} sT={sT:g} sM={sM:g}"
        assert got[2:4] == ref[2:4], where
        np.testing.assert_allclose(got[0], ref[0], rtol=0, atol=1e-12 * 32, err_msg=where)
        np.testing.assert_allclose(got[1], ref[1], rtol=0, atol=1e-12 * 2, err_msg=where)
        np.testing.assert_allclose(got[4:], ref[4:], rtol=1e-12, err_msg=where)


@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(kind=st.sampled_from(["box", "circle"]), integrator=st.sampled_from(["step", "event"]),
       eL=st.floats(math.log10(4e-40) + 1e-9, math.log10(1e40 / 32.0) - 1e-9),
       eT=st.floats(math.log10(1.6e-39) + 1e-9, math.log10(1.6e41) - 1e-9),
       eM=st.floats(-40.0 + 1e-9, math.log10(5e39) - 1e-9))
def test_collision_anywhere_in_the_range_is_the_one_at_unit_scale(kind, integrator, eL, eT,
                                                                   eM):
    """The collision of the edge test at random (log-uniform) length, time and mass scales
    inside the range: the same counts, positions to 1e-12 of the box, velocities and kinetic
    energy to 1e-12."""
    ref = _head_on(1.0, 1.0, 1.0, kind, integrator)
    got = _head_on(10.0 ** eL, 10.0 ** eT, 10.0 ** eM, kind, integrator)
    assert got[2:4] == ref[2:4]
    np.testing.assert_allclose(got[0], ref[0], rtol=0, atol=1e-12 * 32)
    np.testing.assert_allclose(got[1], ref[1], rtol=0, atol=1e-12 * 2)
    np.testing.assert_allclose(got[4:], ref[4:], rtol=1e-12)


@pytest.mark.parametrize("integrator", ["step", "event"])
@pytest.mark.parametrize("s", [1e-30, 1e30])
def test_gas_at_scale_1e30_matches_unit_scale(s, integrator):
    """A gas of 40 discs with every length and speed scaled by 1e-30 or 1e30 (time and mass
    unchanged: the quadratics' terms scale by s^4 = 1e+-120) makes the same collisions and
    ends at the same positions (1e-12 of the box, 20 steps) as at unit scale."""
    def run(f):
        sc = dg.Scene(bounds=dg.Box(20.0 * f, 20.0 * f), species=[dg.Species("A", 0.5 * f, 1.0)],
                      dt=0.05)
        ref = dg.Simulation(dg.Scene(bounds=dg.Box(20.0, 20.0), species=[dg.Species("A", 0.5,
                                                                                    1.0)],
                                     counts={"A": 40}, dt=0.05), seed=3)
        sim = dg.Simulation.from_arrays(sc, ref.positions * f, ref.velocities * f, [0] * 40,
                                        integrator=integrator)
        sim.step(20)
        assert sim.overlaps(1e-9) == 0 and sim.outside(1e-12) == 0
        return sim.positions / f, sim.collisions

    p0, c0 = run(1.0)
    p1, c1 = run(s)
    assert c1 == c0 > 0
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-12 * 20)


def _scene_dict(sL=1.0, sT=1.0, sM=1.0, sE=None, shape="box"):
    """A valid scene dict (three species, a combination, an exchange) at the given scales of
    length, time, mass and energy (default: the energy of the mass at the speed sL / sT)."""
    sE = sM * (sL / sT) ** 2 if sE is None else sE
    if shape == "box":
        bounds = {"shape": "box", "width": 8.0 * sL, "height": 6.0 * sL,
                  "origin": [0.0, 0.0]}
    else:
        bounds = {"shape": "circle", "radius": 4.0 * sL, "center": [0.0, 0.0]}
    return {
        "name": "scaled", "dt": 0.05 * sT, "temperature": 1.0 * sE,
        "bounds": bounds,
        "species": [
            {"name": "A", "radius": 0.5 * sL, "mass": 1.0 * sM, "formation_energy": 0.5 * sE},
            {"name": "B", "radius": 0.25 * sL, "mass": 1.0 * sM, "formation_energy": -sE},
            {"name": "C", "radius": 0.5 * sL, "mass": 2.0 * sM, "formation_energy": 0.0},
        ],
        "reactions": [
            {"type": "combination", "reactants": ["A", "B"], "products": ["C"],
             "activation_energy": 1.0 * sE, "reverse_probability": 0.5},
            {"type": "exchange", "reactants": ["A", "A"], "products": ["B", "B"],
             "activation_energy": 2.0 * sE},
        ],
        "counts": {"A": 2, "B": 2},
    }


def _set(d, path, value):
    """d with the entry at ``path`` (e.g. "species[1].radius", "bounds.width") set."""
    out = {k: (v.copy() if isinstance(v, dict) else [dict(x) for x in v]
               if isinstance(v, list) else v) for k, v in d.items()}
    m = re.fullmatch(r"(\w+)\[(\d+)\]\.(\w+)", path)
    if m:
        out[m.group(1)][int(m.group(2))][m.group(3)] = value
    elif "." in path:
        a, b = path.split(".")
        out[a][b] = value
    else:
        out[path] = value
    return out


# (field path, its value in a scene at the scales given, which put it at the edge of the
# range: speeds stay below the speed limit and the other fields inside the range)
EDGES = [
    ("species[1].radius", 0.25 * 4e-40, dict(sL=4e-40, sT=2e-39)),  # (radius 0.25 sL)
    ("bounds.width", HI, dict(sL=HI / 8.0, sT=HI / 8.0)),  # (width 8 sL)
    ("dt", LO, dict(sL=2e-39, sT=2e-39)),  # (dt 0.05 sT)
    ("dt", HI, dict(sL=1e39, sT=HI / 0.05)),
    ("species[0].mass", LO, dict(sM=LO)),  # (masses 1, 1, 2 sM)
    ("species[2].mass", HI, dict(sM=HI / 2.0)),
    ("bounds.radius", HI, dict(sL=HI / 4.0, sT=HI / 4.0, shape="circle")),  # (radius 4 sL)
]
ENERGY_FIELDS = [  # (field, its value at sE = 1): |value| <= HI; smaller values are fine
    ("temperature", 1.0), ("species[0].formation_energy", 0.5),
    ("species[1].formation_energy", -1.0), ("reactions[0].activation_energy", 1.0),
    ("reactions[1].activation_energy", 2.0),
]


def _get(d, path):
    m = re.fullmatch(r"(\w+)\[(\d+)\]\.(\w+)", path)
    if m:
        return d[m.group(1)][int(m.group(2))][m.group(3)]
    if "." in path:
        a, b = path.split(".")
        return d[a][b]
    return d[path]


def _range_cases():
    """(id, scene dict, field that must be named, or None when the dict is valid)."""
    cases = []
    for path, end, scales in EDGES:
        inside = _scene_dict(**scales)
        if path == "bounds.width":
            inside = _set(inside, "bounds.height", HI / 2.0)
        assert math.isclose(_get(inside, path), end, rel_tol=1e-15), path
        inside = _set(inside, path, end)
        cases.append((f"{path}={end:g}", inside, None))
        beyond = end * OUT if end >= 1.0 else end / OUT
        cases.append((f"{path}={beyond!r}", _set(inside, path, beyond), path))
    # the height at HI, and a box below LO (it holds no disc of radius >= LO: the bounds are
    # named, being checked first)
    d = _set(_scene_dict(sL=HI / 8.0, sT=HI / 8.0), "bounds.height", HI)
    cases.append(("bounds.height=1e40", d, None))
    cases.append(("bounds.height>1e40", _set(d, "bounds.height", HI * OUT), "bounds.height"))
    cases.append(("bounds.width<1e-40", _set(_scene_dict(sL=LO, sT=1e-38), "bounds.width",
                                             LO / OUT), "bounds.width"))
    cases.append(("bounds.radius<1e-40", _set(_scene_dict(sL=LO, sT=1e-38, shape="circle"),
                                              "bounds.radius", LO / OUT), "bounds.radius"))
    for path, unit in ENERGY_FIELDS:
        sign = math.copysign(1.0, unit)
        d = _set(_scene_dict(sM=HI / 4.0, sE=HI / 2.0), path, sign * HI)  # (speeds ~ 1)
        cases.append((f"{path}={sign * HI:g}", d, None))
        cases.append((f"{path}={sign * HI * OUT!r}", _set(d, path, sign * HI * OUT), path))
    cases.append(("energies=1e-300", _scene_dict(sE=1e-300), None))  # no lower bound
    # the resolution ratio: bounds reaching 1e9 smallest radii (0.25) from the origin, and
    # beyond: a wide box, and a small one far from the origin
    far = MAX_COORDINATE_RATIO * 0.25
    d = _set(_scene_dict(), "bounds.width", far)
    cases.append(("coordinates=1e9 radii", d, None))
    cases.append(("coordinates>1e9 radii", _set(d, "bounds.width", far * OUT),
                  "species[1].radius"))
    d = _set(_set(_scene_dict(), "bounds.width", 300.0), "bounds.origin", [far - 300.0, 0.0])
    cases.append(("coordinates=1e9 radii (offset)", d, None))
    cases.append(("coordinates>1e9 radii (offset)",
                  _set(d, "bounds.origin", [(far - 300.0) * OUT, 0.0]), "species[1].radius"))
    return cases


RANGE_CASES = _range_cases()


def _toml(d):
    def val(v):
        if isinstance(v, str):
            return '"' + v + '"'
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)
    top = [f"{k} = {val(v)}" for k, v in d.items() if not isinstance(v, (dict, list))]
    lines = top + ["", "[bounds]"] + [f"{k} = {val(v)}" for k, v in d["bounds"].items()]
    for table in ("species", "reactions"):
        for x in d[table]:
            lines += ["", f"[[{table}]]"] + [f"{k} = {val(v)}" for k, v in x.items()]
    lines += ["", "[counts]"] + [f"{k} = {v}" for k, v in d["counts"].items()]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("d, field", [pytest.param(d, f, id=i) for i, d, f in RANGE_CASES])
def test_scales_at_the_boundary_are_accepted_and_beyond_refused_naming_the_field(
        d, field, tmp_path):
    """Each field at the edge of the range is accepted (and the scene simulates 3 steps with
    nothing outside and no overlap); just beyond (1e-9 relative) it raises SceneError naming
    the field, as a dict and from a TOML file whose message names the file and the line of
    that key."""
    p = tmp_path / "scene.toml"
    p.write_text(_toml(d))
    if field is None:
        sc = dg.Scene.from_dict(d)
        assert dg.Scene.from_toml(p) == sc
        for integrator in ("step", "event"):
            sim = dg.Simulation(sc, seed=1, integrator=integrator)
            sim.step(3)
            assert sim.outside(1e-12) == 0 and sim.overlaps(1e-9) == 0
        return
    with pytest.raises(SceneError) as e:
        dg.Scene.from_dict(d)
    assert e.value.field == field, str(e.value)
    with pytest.raises(SceneError) as e:
        dg.Scene.from_toml(p)
    assert e.value.field == field, str(e.value)
    m = re.search(r"\(([^()]*):(\d+)\)$", str(e.value))
    assert m and m.group(1) == str(p), str(e.value)
    key = field.split(".")[-1]
    assert p.read_text().splitlines()[int(m.group(2)) - 1].startswith(key), str(e.value)


def _scene_in_code(d):
    """The dict's scene built from objects (not from_dict): the same SceneError fields."""
    b = d["bounds"]
    bounds = (dg.Box(b["width"], b["height"], tuple(b["origin"])) if b["shape"] == "box"
              else dg.Circle(b["radius"], tuple(b["center"])))
    species = [dg.Species(**s) for s in d["species"]]
    r0, r1 = d["reactions"]
    reactions = [dg.Combination(*r0["reactants"], *r0["products"], r0["activation_energy"],
                                r0["reverse_probability"]),
                 dg.Exchange(*r1["reactants"], *r1["products"], r1["activation_energy"])]
    return dg.Scene(bounds=bounds, species=species, reactions=reactions, dt=d["dt"],
                    temperature=d["temperature"], counts=d["counts"])


@pytest.mark.parametrize("d, field", [pytest.param(d, f, id=i) for i, d, f in RANGE_CASES
                                      if f is not None])
def test_out_of_range_scene_built_in_code_names_the_same_field(d, field):
    """The same out-of-range scenes built from Species/Box/... objects: the objects are
    accepted (their own checks are only finiteness and sign); the Scene raises SceneError
    naming the same field path."""
    with pytest.raises(SceneError) as e:
        _scene_in_code(d)
    assert e.value.field == field


def _small_sim(**kw):
    sc = dg.Scene(bounds=dg.Box(8.0, 8.0), species=[dg.Species("A", 0.5, 1.0)], dt=0.05,
                  counts={"A": 3})
    return dg.Simulation(sc, seed=0, **kw)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_simulation_arguments_beyond_the_energy_range_are_refused(sign):
    """``Simulation(temperature=)``, ``inject(temperature=)`` and ``from_arrays``'s internal
    energies above 1e40 are refused naming the argument, and nothing changes; at 1e40 (with
    masses that keep the speeds under the speed limit) they are accepted."""
    if sign < 0:  # negative: refused as before
        with pytest.raises(ValueError, match="temperature"):
            _small_sim(temperature=-HI)
        return
    with pytest.raises(SceneError) as e:
        _small_sim(temperature=HI * OUT)
    assert e.value.field == "temperature"
    heavy = dg.Scene(bounds=dg.Box(8.0, 8.0), species=[dg.Species("A", 0.5, HI)], dt=0.05)
    sim = dg.Simulation(heavy.replace(counts={"A": 2}), temperature=HI, seed=0)
    assert math.isclose(sim.temperature(), HI, rel_tol=1e-12)
    st = sim.get_state()
    with pytest.raises(ValueError, match=r"inject\(temperature\)"):
        sim.inject("A", 1, temperature=HI * OUT)
    assert len(sim) == 2 and sim.get_state()["rng"] == st["rng"]
    assert sim.inject("A", 1, temperature=HI) == 1
    pos, vel = [[2.0, 2.0], [5.0, 5.0]], [[0.0, 0.0], [0.0, 0.0]]
    dg.Simulation.from_arrays(heavy, pos, vel, [0, 0], internal_energy=[HI, 0.0])
    with pytest.raises(ValueError, match="internal_energy of disc 1"):
        dg.Simulation.from_arrays(heavy, pos, vel, [0, 0], internal_energy=[0.0, HI * OUT])


def test_resize_beyond_the_range_is_refused_and_changes_nothing():
    """``resize`` to bounds beyond the length range or reaching more than 1e9 smallest radii
    from the origin raises ValueError naming ``resize(bounds)`` and the field; the state is
    unchanged. Up to the limits it is accepted."""
    sim = _small_sim()
    st = sim.get_state()
    for bounds, field in [(dg.Box(HI * OUT, 8.0), "bounds.width"),
                          (dg.Box(8.0, HI * OUT), "bounds.height"),
                          (dg.Circle(HI * OUT), "bounds.radius"),
                          (dg.Box(0.5e9 * OUT, 8.0), "species[0].radius"),
                          (dg.Circle(0.5e9 * OUT), "species[0].radius")]:
        with pytest.raises(ValueError, match=re.escape(f"resize(bounds): {field}")):
            sim.resize(bounds)
        assert sim.bounds == st["bounds"]
    sim.resize(dg.Box(0.5e9, 8.0))
    sim.resize(dg.Circle(0.25e9))
    sim.step(2)
    assert sim.outside(1e-12) == 0


# =================================================================================== numbers
FLOAT_TYPES = [np.float64, np.float32, np.float16, np.int64, np.int32, np.uint16]
INT_TYPES = [np.int64, np.int32, np.uint16, np.uint64, np.float64, np.float32]


def _outcome(f):
    """("ok", result) or ("error", exception type, field or message head): comparable
    between the numpy and the Python argument."""
    try:
        return ("ok", f())
    except Exception as exc:  # (compared, not swallowed: the test asserts what it got)
        field = getattr(exc, "field", None)
        return ("error", type(exc).__name__, field or str(exc).split(":")[0])


def _state(sim):
    st = sim.get_state()
    return tuple((k, v.tobytes() if isinstance(v, np.ndarray) else repr(v))
                 for k, v in sorted(st.items()))


SC = dict(bounds=dg.Box(8.0, 6.0), dt=0.05, counts={"A": 3, "B": 2},
          species=[dg.Species("A", 0.3, 1.0, 0.5), dg.Species("B", 0.3, 1.0, 0.0)],
          reactions=[dg.Transformation("A", "B", 0.3), dg.Exchange("A", "B", "B", "A", 0.7)])


def _scene_with(**kw):
    return dg.Scene(**{**SC, **kw})


def _run_scene(sc):
    sim = dg.Simulation(sc, seed=2)
    sim.step(3)
    return sc, _state(sim)


# (id, Python value, float or int, function of the value -> comparable result)
SCENE_ARGS = [
    ("Species.radius", 0.3, "float",
     lambda v: _run_scene(_scene_with(species=[dg.Species("A", v, 1.0, 0.5), SC["species"][1]]))),
    ("Species.mass", 1.3, "float",
     lambda v: _run_scene(_scene_with(species=[dg.Species("A", 0.3, v), dg.Species("B", 0.3,
                                                                                     v)]))),
    ("Species.formation_energy", 0.7, "float",
     lambda v: _run_scene(_scene_with(species=[dg.Species("A", 0.3, 1.0, v),
                                               SC["species"][1]]))),
    ("Box.width", 8.3, "float", lambda v: _run_scene(_scene_with(bounds=dg.Box(v, 6.0)))),
    ("Box.height", 6.3, "float", lambda v: _run_scene(_scene_with(bounds=dg.Box(8.0, v)))),
    ("Box.origin", 2.7, "float",
     lambda v: _run_scene(_scene_with(bounds=dg.Box(8.0, 6.0, origin=(v, 1.0))))),
    ("Circle.radius", 4.1, "float",
     lambda v: _run_scene(_scene_with(bounds=dg.Circle(v)))),
    ("Circle.center", 1.9, "float",
     lambda v: _run_scene(_scene_with(bounds=dg.Circle(4.0, center=(v, v))))),
    ("Transformation.probability", 0.3, "float",
     lambda v: _run_scene(_scene_with(reactions=[dg.Transformation("A", "B", v)]))),
    ("Decomposition.probability", 0.3, "float",
     lambda v: _run_scene(_scene_with(
         species=[dg.Species("A", 0.3, 2.0, 1.0), dg.Species("B", 0.3, 1.0, 0.0)],
         reactions=[dg.Decomposition("A", "B", "B", v)]))),
    ("Combination.activation_energy", 0.3, "float",
     lambda v: _run_scene(_scene_with(
         species=[dg.Species("A", 0.3, 1.0), dg.Species("B", 0.3, 2.0)],
         counts={"A": 6}, reactions=[dg.Combination("A", "A", "B", v, 0.3)]))),
    ("Combination.reverse_probability", 0.3, "float",
     lambda v: _run_scene(_scene_with(
         species=[dg.Species("A", 0.3, 1.0), dg.Species("B", 0.3, 2.0)],
         counts={"A": 6}, reactions=[dg.Combination("A", "A", "B", 0.0, v)]))),
    ("Exchange.activation_energy", 0.3, "float",
     lambda v: _run_scene(_scene_with(reactions=[dg.Exchange("A", "B", "B", "A", v)]))),
    ("Scene.restitution", 0.7, "float", lambda v: _run_scene(_scene_with(restitution=v))),
    ("Scene.dt", 0.03, "float", lambda v: _run_scene(_scene_with(dt=v))),
    ("Scene.internal_relaxation", 0.3, "float",
     lambda v: _run_scene(_scene_with(internal_relaxation=v))),
    ("Scene.max_displacement", 0.3, "float",
     lambda v: _run_scene(_scene_with(max_displacement=v))),
    ("Scene.temperature", 1.7, "float", lambda v: _run_scene(_scene_with(temperature=v))),
    ("Scene.counts", 4, "int", lambda v: _run_scene(_scene_with(counts={"A": v, "B": 1}))),
]


def _sim():
    return dg.Simulation(_scene_with(), seed=4)


def _after(f):
    """Run f on a fresh simulation, then one step: its return value and the final state."""
    sim = _sim()
    out = f(sim)
    sim.step(1)
    return out, _state(sim)


SIM_ARGS = [
    ("Simulation.counts", 4, "int",
     lambda v: _state(dg.Simulation(_scene_with(), counts={"A": v}, seed=1))),
    ("Simulation.temperature", 1.7, "float",
     lambda v: _state(dg.Simulation(_scene_with(), temperature=v, seed=1))),
    ("Simulation.seed", 12345, "int", lambda v: _state(dg.Simulation(_scene_with(), seed=v))),
    ("from_arrays.positions", 2.3, "float",
     lambda v: _state(dg.Simulation.from_arrays(_scene_with(), [[v, 1.0], [5.0, v]],
                                                [[0.5, 0.0], [0.0, 0.5]], [0, 1], seed=0))),
    ("from_arrays.velocities", 0.7, "float",
     lambda v: _state(dg.Simulation.from_arrays(_scene_with(), [[2.0, 1.0], [5.0, 3.0]],
                                                [[v, 0.0], [0.0, v]], [0, 1], seed=0))),
    ("from_arrays.species", 1, "int",
     lambda v: _state(dg.Simulation.from_arrays(_scene_with(), [[2.0, 1.0], [5.0, 3.0]],
                                                [[0.3, 0.0], [0.0, 0.3]], [v, 0], seed=0))),
    ("from_arrays.internal_energy", 0.7, "float",
     lambda v: _state(dg.Simulation.from_arrays(_scene_with(), [[2.0, 1.0], [5.0, 3.0]],
                                                [[0.3, 0.0], [0.0, 0.3]], [0, 1],
                                                internal_energy=[v, 0.0], seed=0))),
    ("from_arrays.seed", 99, "int",
     lambda v: _state(dg.Simulation.from_arrays(_scene_with(), [[2.0, 1.0], [5.0, 3.0]],
                                                [[0.3, 0.0], [0.0, 0.3]], [0, 1], seed=v))),
    ("step.n", 3, "int", lambda v: _after(lambda s: s.step(v))),
    ("advance.duration", 0.13, "float", lambda v: _after(lambda s: s.advance(v))),
    ("inject.species", 1, "int", lambda v: _after(lambda s: s.inject(v, 2))),
    ("inject.n", 3, "int", lambda v: _after(lambda s: s.inject("A", v))),
    ("inject.temperature", 1.3, "float",
     lambda v: _after(lambda s: s.inject("A", 2, temperature=v))),
    ("inject.near", 2.2, "float", lambda v: _after(lambda s: s.inject("A", 2, near=(v, v)))),
    ("scale_temperature.factor", 1.7, "float",
     lambda v: _after(lambda s: s.scale_temperature(v))),
    ("resize.Box", 7.3, "float", lambda v: _after(lambda s: s.resize(dg.Box(v, v)))),
    ("resize.Circle", 3.3, "float", lambda v: _after(lambda s: s.resize(dg.Circle(v)))),
    ("overlaps.tol", 0.3, "float", lambda v: _after(lambda s: s.overlaps(v))),
    ("outside.tol", 0.3, "float", lambda v: _after(lambda s: s.outside(v))),
    ("threads", 2, "int", lambda v: _after(lambda s: setattr(s, "threads", v))),
]
ARGS = SCENE_ARGS + SIM_ARGS


def _number_cases():
    """(function, numpy value, must be accepted): each argument x each numpy type, with a
    valid value of that type (an integral one for integer types)."""
    for name, value, kind, f in ARGS:
        for t in (FLOAT_TYPES if kind == "float" else INT_TYPES):
            integral = np.issubdtype(t, np.integer)
            v = t(0 if name.endswith(".tol") else round(value) or 1) if integral else t(value)
            # a float where an int is needed is accepted or refused as the Python float is
            yield pytest.param(f, v, kind == "float" or integral, id=f"{name}-{t.__name__}")


@pytest.mark.parametrize("f, v, accepted", list(_number_cases()))
def test_numpy_scalars_are_the_numbers_they_are(f, v, accepted):
    """Every numeric argument of the scene model and the Simulation API, given as each numpy
    scalar type: accepted, with exactly the result of the Python number ``v.item()`` (the
    same Scene, the same state bit for bit); a float where an int is needed (np.float64(4.0)
    as a count) behaves as the Python float does (a count refuses it, ``step`` takes it),
    with the same error type and field."""
    a, b = _outcome(lambda: f(v)), _outcome(lambda: f(v.item()))
    assert a == b
    if accepted:
        assert a[0] == "ok", a


def test_numpy_values_are_stored_as_python_numbers():
    """What the scene model stores from numpy scalars is the Python number (a float32
    radius becomes float(value), an int64 count an int, np.bool_ a bool), so scenes compare
    equal, hash the same and write to TOML."""
    sc = dg.Scene(bounds=dg.Box(np.float32(8.1), np.int64(6), origin=(np.float16(1.5), 0)),
                  species=[dg.Species("A", np.float32(0.3), np.int32(1), np.float64(0.5))],
                  dt=np.float32(0.05), counts={"A": np.int64(3)}, collisions=np.bool_(True),
                  temperature=np.float32(1.5), restitution=np.float64(0.9))
    values = [sc.bounds.width, sc.bounds.height, *sc.bounds.origin, sc.species[0].radius,
              sc.species[0].mass, sc.species[0].formation_energy, sc.dt, sc.temperature,
              sc.restitution]
    assert all(type(x) is float for x in values)
    assert type(sc.counts["A"]) is int and sc.collisions is True
    assert sc.species[0].radius == float(np.float32(0.3))
    assert dg.Scene.from_toml_string(sc.to_toml()) == sc
    assert dg.Scene(bounds=dg.Box(8.0, 6.0), species=[dg.Species("A", 0.3, 1.0)],
                    collisions=np.bool_(False)).collisions is False


@pytest.mark.parametrize("name, value, f", [pytest.param(c[0], c[1], c[3], id=c[0])
                                            for c in ARGS if not c[0].endswith(".seed")])
def test_zero_dimensional_arrays_are_the_numbers_they_hold(name, value, f):
    """Every numeric argument given as a 0-d array: the outcome of the number it holds
    (one rule for what a number is, ``discgym.values``; seeds go to numpy as given)."""
    v = 0 if name.endswith(".tol") else value
    assert _outcome(lambda: f(np.asarray(v))) == _outcome(lambda: f(v))


BAD = [(np.bool_(True), "bool"), (np.float64(np.nan), "nan"), (np.float32(np.inf), "inf"),
       (np.float64(-np.inf), "-inf")]
# accept a bool as the Python bool is accepted: seeds (an int), and coordinates inside arrays
# (numpy converts them)
BOOL_TAKEN = {"Simulation.seed", "from_arrays.seed", "from_arrays.positions",
              "from_arrays.velocities", "from_arrays.internal_energy"}


@pytest.mark.parametrize("name, f", [pytest.param(c[0], c[3], id=c[0]) for c in ARGS])
@pytest.mark.parametrize("bad, label", BAD, ids=[b[1] for b in BAD])
def test_numpy_bools_and_non_finite_numbers_are_refused_like_python_ones(name, f, bad,
                                                                        label):
    """np.bool_ where a number is needed, and NaN or inf as numpy floats, are refused as the
    Python True, nan and inf are (ValueError naming the field or argument; the same error
    for both), except where the Python bool is taken as a number too (``BOOL_TAKEN``)."""
    a, b = _outcome(lambda: f(bad)), _outcome(lambda: f(bad.item()))
    assert a == b
    if label == "bool" and name in BOOL_TAKEN:
        return
    assert a[0] == "error", a
    assert a[1] in ("ValueError", "SceneError") or name.endswith(".seed"), a


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_a_disc_at_the_speed_limit_at_the_largest_scale_is_the_one_at_unit_scale(integrator):
    """The largest products the range allows: a box 1e40 wide, dt = 1e-40, a disc of radius
    1e39 at 0.9 of the speed limit (2.9e83: (d.v)^2 ~ 1e247) bouncing along a line between
    the walls and a resting disc for one step (4916 collisions, 4915 wall hits, 58983
    substeps): the same counts as at unit scale and the same positions to 1e-9 of the box."""
    def run(sL, sT):
        sc = dg.Scene(bounds=dg.Box(10.0 * sL, 10.0 * sL), species=[dg.Species("A", sL, 1.0)],
                      dt=0.01 * sT, temperature=0.0)
        sim = dg.Simulation.from_arrays(sc, [[2.0 * sL, 5.0 * sL], [7.0 * sL, 5.0 * sL]],
                                        [[0.0, 0.0], [0.0, 0.0]], [0, 0],
                                        integrator=integrator)
        v = 0.9 * sim.speed_limit
        sim = dg.Simulation.from_arrays(sc, sim.positions, [[v, 0.0], [0.0, 0.0]], [0, 0],
                                        integrator=integrator)
        sim.step(1)
        assert sim.outside(1e-12) == 0 and sim.overlaps(1e-9) == 0
        assert math.isclose(sim.kinetic_energy(), 0.5 * v * v, rel_tol=1e-12)
        return sim.positions / sL, sim.collisions, sim.wall_hits

    p0, c0, w0 = run(1.0, 1.0)
    p1, c1, w1 = run(1e39, 1e-38)
    assert c0 > 500 and w0 > 500
    assert (c1, w1) == (c0, w0)
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-9 * 10)


@pytest.mark.parametrize("value", [math.inf, math.nan, 1.5, "2", None, True, np.bool_(False)])
def test_threads_refuses_what_is_not_a_whole_number(value):
    sim = dg.Simulation("ideal_gas", seed=0)
    with pytest.raises(ValueError, match="threads"):
        sim.threads = value
    assert sim.threads >= 1


@pytest.mark.parametrize("value", [np.int64(2), np.int32(1), 2.0, 0])
def test_threads_takes_whole_numbers_of_any_type(value):
    sim = dg.Simulation("ideal_gas", seed=0)
    sim.threads = value
    assert sim.threads == max(int(value), 1) and type(sim.threads) is int
