"""Checkpoints that run no code: one :class:`~discgym.Simulation`, or several (the reactors of
a batch), saved as a NumPy ``.npz`` archive of plain arrays and one JSON document, and read
back with ``allow_pickle=False``. Loading executes nothing from the file: the scene is built
from its plain-dict form (:meth:`Scene.from_dict <discgym.Scene.from_dict>`, checked as a
TOML scene is) and the state goes through :meth:`Simulation.set_state
<discgym.Simulation.set_state>`, which checks every key before anything changes, so a
damaged or hand-edited file raises ``ValueError`` naming what is wrong. A loaded simulation
continues bit for bit where the saved one would have.

>>> import discgym as dg, tempfile, os
>>> sim = dg.Simulation("reactor", seed=1); sim.step(5)
>>> path = os.path.join(tempfile.mkdtemp(), "reactor.npz")
>>> dg.checkpoint.save(path, sim)
>>> back = dg.checkpoint.load(path)
>>> sim.step(5); back.step(5)
>>> bool((back.positions == sim.positions).all())
True

``pickle`` still copies a ``Simulation`` (in-process copies, multiprocessing); a pickle file
runs code when loaded, so only this format is for files that are shared or kept.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .scene import Scene, SceneError, bounds_from_dict, bounds_to_dict
from .simulation import Simulation

__all__ = ["save", "load", "FORMAT", "VERSION"]

#: The ``format`` and ``version`` of the JSON document a checkpoint carries.
FORMAT = "discgym-checkpoint"
VERSION = 1
#: The state's keys (:meth:`Simulation.get_state`) kept as arrays of the archive.
ARRAY_KEYS = ("positions", "velocities", "species", "internal_energy", "ids", "icnt", "fsum",
              "ch_count", "outflow")
#: The archive's entry holding the JSON document.
META = "meta"


def save(path: str | os.PathLike, sims: Simulation | Sequence[Simulation]) -> None:
    """Write ``sims`` (a ``Simulation`` or a non-empty sequence of them) to ``path`` (an
    ``.npz`` file, replaced whole: a failed write leaves no partial file)."""
    single = isinstance(sims, Simulation)
    items = [sims] if single else list(sims)
    if not items or not all(isinstance(s, Simulation) for s in items):
        raise TypeError("checkpoint.save(sims): expected a Simulation or a non-empty sequence "
                        f"of them, got {type(sims).__name__}")
    arrays, reactors = {}, []
    for r, sim in enumerate(items):
        state = sim.get_state()
        for k in ARRAY_KEYS:
            arrays[f"{r}/{k}"] = state.pop(k)
        state["bounds"] = bounds_to_dict(state["bounds"])
        state["rng"] = _plain(state["rng"])
        state["wall_temperature"] = [[side, t] for side, t in
                                     state["wall_temperature"].items()]
        reactors.append({"scene": sim.scene.to_dict(), "state": state})
    doc = {"format": FORMAT, "version": VERSION, "single": single, "reactors": reactors}
    arrays[META] = np.array(json.dumps(doc, allow_nan=False))
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent or ".")
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)  # (mkstemp's 0600 would keep a shared file private)
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
            f.flush()
            os.fsync(f.fileno())  # (on disk before it replaces a good checkpoint)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load(path: str | os.PathLike) -> Simulation | list[Simulation]:
    """The simulation(s) :func:`save` wrote to ``path``: one ``Simulation`` if one was
    saved, else a list. A file that cannot be read raises ``OSError``; anything else that
    is wrong (not a checkpoint, another format version, a missing or damaged array, a state
    ``set_state`` refuses) raises ``ValueError`` naming the file and the fault."""
    name = os.fspath(path)
    with open(path, "rb") as f:  # (OSError: missing, a directory, no permission)
        f.read(1)
    try:
        z = np.load(path, allow_pickle=False)
    except Exception as exc:  # (empty, truncated, not an archive: numpy's and zipfile's own)
        raise ValueError(f"{name}: not a discgym checkpoint ({_why(exc)})") from None
    if not isinstance(z, np.lib.npyio.NpzFile):  # (a lone .npy array)
        raise ValueError(f"{name}: not a discgym checkpoint (one array, not an archive)")
    with z:
        if META not in z.files:
            raise ValueError(f"{name}: not a discgym checkpoint (no {META!r} entry)")
        try:
            doc = json.loads(str(z[META][()]))
        except Exception as exc:  # (an object array, a damaged member, not JSON, too deep)
            raise ValueError(f"{name}: its {META!r} entry is not a JSON document "
                             f"({_why(exc)})") from None
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise ValueError(f"{name}: not a discgym checkpoint (format {_get(doc, 'format')!r})")
        if doc.get("version") != VERSION:
            raise ValueError(f"{name}: a checkpoint of format version "
                             f"{_get(doc, 'version')!r}; this discgym reads version {VERSION}")
        reactors = doc.get("reactors")
        if not isinstance(reactors, list) or not reactors:
            raise ValueError(f"{name}: 'reactors' must be a non-empty list")
        single = doc.get("single")
        if single not in (True, False) or (single and len(reactors) != 1):
            raise ValueError(f"{name}: 'single' must be true (one reactor) or false, got "
                             f"{single!r} with {len(reactors)} reactors")
        sims = [_reactor(name, z, r, entry) for r, entry in enumerate(reactors)]
    return sims[0] if single else sims


def _reactor(name: str, z, r: int, entry) -> Simulation:
    where = f"{name}: reactor {r}"
    if not isinstance(entry, dict) or set(entry) != {"scene", "state"} or \
            not isinstance(entry["state"], dict):
        raise ValueError(f"{where}: expected {{'scene': ..., 'state': {{...}}}}")
    try:
        scene = Scene.from_dict(entry["scene"])
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{where}: its scene: {exc}") from None
    state = dict(entry["state"])
    for k in ARRAY_KEYS:
        key = f"{r}/{k}"
        if key not in z.files:
            raise ValueError(f"{where}: the array {key!r} is missing")
        try:
            state[k] = z[key]
        except Exception as exc:  # (damaged, an object array, a header beyond memory)
            raise ValueError(f"{where}: the array {key!r} cannot be read ({_why(exc)})") \
                from None
    try:
        state["bounds"] = bounds_from_dict(state.get("bounds"))
    except SceneError as exc:
        raise ValueError(f"{where}: state['bounds']: {exc}") from None
    try:
        walls = state.get("wall_temperature", [])
        state["wall_temperature"] = {side: t for side, t in walls}
        state["rng"] = _unplain(state.get("rng"))
    except Exception as exc:
        raise ValueError(f"{where}: {_why(exc)}") from None
    if "scene_fingerprint" in state:  # (JSON has lists where the fingerprint has tuples)
        state["scene_fingerprint"] = _tuples(state["scene_fingerprint"])
    if "clock" in state and isinstance(state["clock"], list):
        state["clock"] = tuple(state["clock"])
    # (the state's integrator is set_state's to check, with the state's bounds)
    sim = Simulation(scene, counts={}, seed=0)
    try:
        sim.set_state(state)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    return sim


def _why(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _plain(v):
    """A generator state as JSON values (numpy arrays and integers as lists and ints)."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, np.ndarray):
        return {"array": v.tolist(), "dtype": v.dtype.str}
    if isinstance(v, np.integer):
        return int(v)
    return v


def _unplain(v):
    """:func:`_plain`'s inverse (its errors are the caller's to word)."""
    if isinstance(v, dict):
        if set(v) == {"array", "dtype"}:
            return np.array(v["array"], dtype=np.dtype(v["dtype"]))
        return {k: _unplain(x) for k, x in v.items()}
    return v


def _tuples(v):
    if isinstance(v, dict):
        return {k: _tuples(x) for k, x in v.items()}
    if isinstance(v, list):
        return tuple(_tuples(x) for x in v)
    return v


def _get(doc, key):
    return doc.get(key) if isinstance(doc, dict) else None
