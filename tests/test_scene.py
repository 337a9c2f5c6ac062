"""The scene model: validation errors name the field; TOML round trip; built-in scenes."""

import math

import pytest

import discgym as dg
from discgym.scene import SceneError

A = dg.Species("A", 0.5, 1.0)
B = dg.Species("B", 0.5, 1.0)
C = dg.Species("C", 0.7, 2.0)


def scene(**kw):
    base = dict(bounds=dg.Box(10.0, 10.0), species=[A, B, C])
    base.update(kw)
    return dg.Scene(**base)


@pytest.mark.parametrize(
    "build, field",
    [
        (lambda: dg.Species("A", -1.0, 1.0), "radius"),
        (lambda: dg.Species("A", 0.5, 0.0), "mass"),
        (lambda: dg.Species("A", math.nan, 1.0), "radius"),
        (lambda: dg.Species("A", 0.5, 1.0, formation_energy=math.inf), "formation_energy"),
        (lambda: dg.Species("", 0.5, 1.0), "name"),
        (lambda: dg.Box(-1.0, 2.0), "width"),
        (lambda: dg.Box(1.0, math.nan), "height"),
        (lambda: dg.Circle(0.0), "radius"),
        (lambda: dg.Box(1.0, 1.0, origin=(1e9, 0.0)), "origin"),
        (lambda: dg.Transformation("A", "B", probability=1.5), "probability"),
        (lambda: dg.Combination("A", "B", "C", activation_energy=-1.0), "activation_energy"),
        (lambda: scene(restitution=1.2), "restitution"),
        (lambda: scene(restitution=math.nan), "restitution"),
        (lambda: scene(dt=0.0), "dt"),
        (lambda: scene(internal_relaxation=-0.1), "internal_relaxation"),
        (lambda: scene(max_displacement=2.0), "max_displacement"),
        (lambda: scene(temperature=-1.0), "temperature"),
        (lambda: scene(species=[]), "species"),
        (lambda: scene(species=[A, A]), "species[1].name"),
        (lambda: scene(species=[dg.Species("big", 6.0, 1.0)]), "species[0].radius"),
        (lambda: scene(reactions=[dg.Transformation("A", "X", 0.1)]), "reactions[0].products"),
        (lambda: scene(reactions=[dg.Transformation("Q", "A", 0.1)]), "reactions[0].reactants"),
        (lambda: scene(reactions=[dg.Transformation("A", "C", 0.1)]), "reactions[0].products"),
        (lambda: scene(reactions=[dg.Combination("A", "A", "B")]), "reactions[0].products"),
        (lambda: scene(reactions=[dg.Decomposition("C", "A", "A", 0.1),
                                  dg.Exchange("A", "B", "B", "A"),
                                  dg.Combination("B", "A", "C")]), "reactions[2].reactants"),
        (lambda: scene(counts={"Z": 3}), "counts.Z"),
        (lambda: scene(counts={"A": -3}), "counts.A"),
        (lambda: scene(counts={"A": 1000}), "counts"),
        (lambda: scene(bounds="box"), "bounds"),
    ],
)
def test_validation_names_the_field(build, field):
    with pytest.raises(SceneError) as exc:
        build()
    assert exc.value.field == field
    assert str(exc.value).startswith(field)


def test_toml_round_trip_every_builtin(tmp_path):
    for name in dg.scenes.names():
        s = dg.scenes.load(name)
        p = tmp_path / f"{name}.toml"
        p.write_text(s.to_toml())
        assert dg.Scene.from_toml(p) == s
        assert s.description


def test_builtin_scenes_cover_every_reaction_type():
    kinds = {r.kind for n in dg.scenes.names() for r in dg.scenes.load(n).reactions}
    assert kinds == {"transformation", "decomposition", "combination", "exchange"}
    assert {"ideal_gas", "reactor"} <= set(dg.scenes.names())
    assert any(isinstance(dg.scenes.load(n).bounds, dg.Circle) for n in dg.scenes.names())


@pytest.mark.parametrize(
    "text, field, line",
    [
        ("colour = 3\n[bounds]\nshape='box'\nwidth=5\nheight=5\n[[species]]\nname='A'\n"
         "radius=0.5\nmass=1\n", "colour", 1),
        ("[bounds]\nshape='box'\nwidth=5\nheight=5\n[[species]]\nname='A'\nradius=0.5\n"
         "mass=1\nspin=2\n", "species[0].spin", 9),
        ("[bounds]\nshape='hexagon'\n[[species]]\nname='A'\nradius=0.5\nmass=1\n",
         "bounds.shape", None),
        ("[bounds]\nshape='box'\nwidth=5\nheight=5\n[[species]]\nname='A'\nradius=-0.5\n"
         "mass=1\n", "species[0].radius", 7),
        ("[bounds]\nshape='box'\nwidth=5\nheight=5\n[[species]]\nname='A'\nmass=1\n",
         "species[0].radius", None),
        ("[bounds]\nshape='box'\nwidth=5\nheight=5\n[[species]]\nname='A'\nradius=0.5\nmass=1\n"
         "[[reactions]]\ntype='fusion'\n", "reactions[0].type", None),
        ("[bounds]\nshape='box'\nwidth=5\nheight=5\n[[species]]\nname='A'\nradius=0.5\nmass=1\n"
         "[[reactions]]\ntype='transformation'\nreactants=['A']\nproducts=['A', 'A']\n"
         "probability=0.1\n", "reactions[0].products", None),
        ("[bounds]\nshape='box'\nwidth=5\n", "species", None),
        ("this is = not toml [", None, None),
    ],
)
def test_toml_errors_name_key_and_line(tmp_path, text, field, line):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(SceneError) as exc:
        dg.Scene.from_toml(p)
    if field is not None:
        assert exc.value.field == field
    if line is not None:
        assert f"bad.toml:{line}" in str(exc.value)


def test_scene_is_frozen():
    s = scene()
    with pytest.raises(AttributeError):
        s.dt = 1.0
    assert isinstance(s.species, tuple)
