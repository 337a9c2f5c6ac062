"""Checkpoints that run no code (``discgym.checkpoint``): a saved simulation continues bit for
bit, a batch round-trips as a list, and a file that is not a checkpoint, another version, a
damaged array or a pickle inside is refused with a ``ValueError`` naming it, before any code
from the file could run."""

import doctest
import json
import zipfile

import numpy as np
import pytest

import discgym as dg
from discgym import checkpoint


def _same(a: dg.Simulation, b: dg.Simulation) -> None:
    assert a.time == b.time and len(a) == len(b)
    for k in ("positions", "velocities", "species", "internal_energy", "ids"):
        assert np.array_equal(getattr(a, k), getattr(b, k)), k
    assert a.counters() == b.counters() and a.reactions() == b.reactions()
    assert a.energy_balance() == b.energy_balance()


@pytest.mark.parametrize("scene, integrator", [("reactor", "step"), ("flow", "step"),
                                                ("jacket", "event"), ("circle_gas", "step")])
def test_a_loaded_simulation_continues_bit_for_bit(tmp_path, scene, integrator):
    sim = dg.Simulation(scene, seed=3, integrator=integrator)
    sim.step(7)
    path = tmp_path / "s.npz"
    checkpoint.save(path, sim)
    back = checkpoint.load(path)
    assert isinstance(back, dg.Simulation) and back.integrator == integrator
    assert back.scene == sim.scene and back.bounds == sim.bounds
    _same(back, sim)
    sim.step(25)
    back.step(25)
    _same(back, sim)


def test_a_batch_round_trips_as_a_list_and_any_bit_generator(tmp_path):
    sims = [dg.Simulation("reactor", seed=np.random.Generator(np.random.MT19937(5))),
            dg.Simulation("flow", seed=np.random.Generator(np.random.Philox(6)))]
    for s in sims:
        s.step(3)
    path = tmp_path / "batch.npz"
    checkpoint.save(path, sims)
    back = checkpoint.load(path)
    assert isinstance(back, list) and len(back) == 2
    for a, b in zip(sims, back):
        a.step(4)
        b.step(4)
        _same(a, b)
    one = tmp_path / "one.npz"
    checkpoint.save(one, sims[:1])  # a sequence of one stays a list
    assert isinstance(checkpoint.load(one), list)


def test_the_file_holds_arrays_and_json_only(tmp_path):
    path = tmp_path / "s.npz"
    checkpoint.save(path, dg.Simulation("reactor", seed=1))
    with np.load(path, allow_pickle=False) as z:  # (would raise on an object array)
        doc = json.loads(str(z[checkpoint.META][()]))
        assert all(z[k].dtype != object for k in z.files)
    assert doc["format"] == checkpoint.FORMAT and doc["version"] == checkpoint.VERSION
    assert set(doc["reactors"][0]) == {"scene", "state"}


def _rewrite(path, out, change):
    """``path``'s archive with its JSON document passed through ``change`` (and its arrays
    through ``change`` too: ``change(doc, arrays)``)."""
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    doc = json.loads(str(arrays.pop(checkpoint.META)[()]))
    change(doc, arrays)
    np.savez(out, **arrays, **{checkpoint.META: np.array(json.dumps(doc))})


def test_damaged_and_foreign_files_are_refused_naming_the_fault(tmp_path):
    good = tmp_path / "good.npz"
    checkpoint.save(good, dg.Simulation("reactor", seed=1))
    bad = tmp_path / "bad.npz"
    cases = [
        (lambda d, a: d.update(version=99), "format version 99"),
        (lambda d, a: d.update(format="other"), "not a discgym checkpoint"),
        (lambda d, a: a.pop("0/species"), "'0/species' is missing"),
        (lambda d, a: a.update({"0/species": a["0/species"] + 50}), "state['species']"),
        (lambda d, a: d["reactors"][0]["state"].update(time=-1.0), "state['time']"),
        (lambda d, a: d["reactors"][0]["state"].update(bounds={"shape": "cube"}),
         "state['bounds']"),
        (lambda d, a: d["reactors"][0]["scene"]["species"][0].update(radius=-1.0), "scene"),
        (lambda d, a: d.update(reactors=[]), "non-empty list"),
        (lambda d, a: d["reactors"].append(d["reactors"][0]), "'single' must be"),
        (lambda d, a: d["reactors"][0]["state"].update(integrator="bogus"),
         "state['integrator']"),
        (lambda d, a: d["reactors"][0]["state"]["rng"].update(state={"array": [1],
                                                                     "dtype": "garbage"}),
         "reactor 0"),
        (lambda d, a: a.update({"0/ids": np.array([{"x": 1}] * len(a["0/ids"]),
                                                  dtype=object)}), "'0/ids' cannot be read"),
    ]
    for change, words in cases:
        _rewrite(good, bad, change)
        with pytest.raises(ValueError, match="bad.npz") as e:
            checkpoint.load(bad)
        assert words in str(e.value), (words, str(e.value))
    # an object array (a pickle inside the archive) is never unpickled
    np.savez(bad, **{checkpoint.META: np.array([{"format": checkpoint.FORMAT}], dtype=object)})
    with pytest.raises(ValueError, match="not a JSON document"):
        checkpoint.load(bad)
    (tmp_path / "text.npz").write_text("not a zip")
    (tmp_path / "empty.bin").write_bytes(b"")
    (tmp_path / "cut.npz").write_bytes(good.read_bytes()[:500])
    np.save(tmp_path / "one.npy", np.zeros(3))
    for f in ("text.npz", "empty.bin", "cut.npz", "one.npy"):
        with pytest.raises(ValueError, match=f"{f}: not a discgym checkpoint"):
            checkpoint.load(tmp_path / f)
    data = bytearray(good.read_bytes())  # a flipped byte inside a member: its CRC fails
    data[len(data) // 3] ^= 0xFF
    (tmp_path / "flip.npz").write_bytes(bytes(data))
    with pytest.raises(ValueError, match="flip.npz"):
        checkpoint.load(tmp_path / "flip.npz")
    with pytest.raises(FileNotFoundError):  # (cannot be read: not a damaged checkpoint)
        checkpoint.load(tmp_path / "missing.npz")
    with zipfile.ZipFile(tmp_path / "empty.npz", "w"):
        pass
    with pytest.raises(ValueError, match="not a discgym checkpoint"):
        checkpoint.load(tmp_path / "empty.npz")


def test_save_refuses_what_is_not_a_simulation_and_leaves_no_partial_file(tmp_path):
    with pytest.raises(TypeError, match="checkpoint.save"):
        checkpoint.save(tmp_path / "x.npz", [])
    with pytest.raises(TypeError, match="checkpoint.save"):
        checkpoint.save(tmp_path / "x.npz", "reactor")
    with pytest.raises(FileNotFoundError):
        checkpoint.save(tmp_path / "no_such_dir" / "x.npz", dg.Simulation("reactor", seed=1))
    assert list(tmp_path.iterdir()) == []


def test_a_checkpoint_is_readable_as_any_file_the_user_writes(tmp_path):
    import os

    path = tmp_path / "s.npz"
    checkpoint.save(path, dg.Simulation("reactor", seed=1))
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask


def test_the_module_example_runs():
    assert doctest.testmod(checkpoint).failed == 0
