"""Saving and restoring a reactor: ``get_state`` (copies of everything needed to continue
bit for bit), ``set_state`` (every key checked before anything changes, each error naming the
key), pickling and ``copy``; :class:`StateIO` gives them to :class:`~discgym.Simulation`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .checks import check_sides, discs_inside, event_fit
from .compiled import kernel_bounds, kernel_walls
from .kernels import controls as _controls
from .kernels import step as _step
from .kernels.structs import COUNT, FLOAT, INDEX
from .observables import wall_heat_of
from .scene import MAX_MAGNITUDE, Box, Circle, Scene, SceneError, check_bounds_scale
from .state import Row
from .values import as_float, integer, real

_OLDEST_ICOUNTERS = 11  # counters in states of discgym before graze_repairs


class StateIO(Row):
    """``get_state``, ``set_state``, pickling and ``copy`` of a reactor's row."""

    # ------------------------------------------------------------------ state
    # the keys of a state; "integrator" (default: the simulation's own) and "scene_fingerprint"
    # (not in states of versions before it) may be left out
    _STATE_KEYS = ("positions", "velocities", "species", "internal_energy", "ids", "next_id",
                   "steps", "time", "bounds", "rng", "icnt", "fsum", "ch_count", "since_reset",
                   "energy_input", "energy_start")
    _STATE_OPTIONAL = ("integrator", "scene_fingerprint", "clock", "wall_temperature",
                       "outflow")

    def get_state(self) -> dict:
        """Everything needed to continue bit-identically (copies), and the fingerprint of the
        scene that gives the numbers their meaning (see :meth:`set_state`)."""
        n = self._n
        return {
            "positions": self._pos[:n].copy(),
            "velocities": self._vel[:n].copy(),
            "species": self._species[:n].copy(),
            "internal_energy": self._internal_energy[:n].copy(),
            "ids": self._ids[:n].copy(),
            "next_id": int(self._idctr[0]),
            "steps": self._steps,
            "time": self._time,
            "bounds": self.bounds,
            "rng": self._rng.bit_generator.state,
            "icnt": self._icnt.copy(),
            "fsum": self._fsum.copy(),
            "ch_count": self._ch_count.copy(),
            "since_reset": self._since_reset,
            "clock": self._clock(),
            "energy_input": self._energy_input,
            "energy_start": self._energy_start,
            "integrator": self._integrator,
            "scene_fingerprint": self._scene_fingerprint(),
            "wall_temperature": self.wall_temperature,
            "outflow": self._outflow.copy(),
        }

    def _scene_fingerprint(self) -> dict:
        """The species (name, radius, mass, formation energy, in index order) and the reaction
        channels (labels, in ``ch_count`` order): what species indices, energies, positions
        and reaction counts of a state mean. Rates, barriers, dt, restitution are not in it:
        they govern what happens next, not what the state says."""
        return {"species": tuple((s.name, float(s.radius), float(s.mass),
                                  float(s.formation_energy)) for s in self.scene.species),
                "channels": tuple(self._cs.labels)}

    def set_state(self, state: Mapping) -> None:
        """Restore a state from :meth:`get_state` of a simulation with the same species and
        reactions (the state carries its own bounds and integrator; dt, restitution, rates and
        barriers are the scene's).

        Everything is checked before anything changes: a state this simulation could not hold
        raises ``ValueError`` naming the key (``state['time']``) and leaves the simulation
        exactly as it was (arrays, counters, random generator). Refused: a missing or unknown
        key; a wrong type, dtype or shape; a non-finite number; a negative count, time,
        internal energy or sum; a species index out of range; a disc outside the bounds or
        faster than :attr:`speed_limit`; duplicate ids, or a ``next_id`` not above every id
        (``inject`` would reuse an identity); ``since_reset`` beyond ``time``; energies beyond
        the float range; a generator state numpy would not restore as given; a
        ``scene_fingerprint`` of other species or reactions. Overlapping discs are allowed.
        A state of an earlier version (no ``scene_fingerprint``, 11 counters) is restored
        after all the other checks; without ``integrator``, the simulation keeps its own.
        """
        self._apply_state(self._checked_state(state))

    def _checked_state(self, state) -> dict:
        """The validated contents of ``state``, converted to the simulation's dtypes; nothing
        is assigned. Per-key checks first, then those that relate keys."""
        if not isinstance(state, Mapping):
            raise ValueError(f"set_state: expected a state dict (from get_state), got "
                             f"{type(state).__name__}")
        missing = [k for k in self._STATE_KEYS if k not in state]
        if missing:
            also = f" (missing too: {missing[1:]})" if len(missing) > 1 else ""
            raise _state_error(missing[0], f"is missing{also}")
        unknown = [k for k in state if k not in self._STATE_KEYS + self._STATE_OPTIONAL]
        if unknown:
            raise _state_error(unknown[0], f"is not a key of a state (unknown keys: {unknown}; "
                               f"a state has {list(self._STATE_KEYS + self._STATE_OPTIONAL)})")
        if "scene_fingerprint" in state:  # first: another scene explains every later mismatch
            self._check_fingerprint(state["scene_fingerprint"])
        cs = self._cs
        S = len(self.scene.species)
        s = {
            "positions": _state_array(state, "positions", (None, 2)),
            "velocities": _state_array(state, "velocities", (None, 2)),
            "species": _state_array(state, "species", (None,), integer=True),
            "internal_energy": _state_array(state, "internal_energy", (None,), nonneg=True),
            "ids": _state_array(state, "ids", (None,), integer=True),
        }
        lengths = {k: len(a) for k, a in s.items()}
        n = max(lengths.values(), key=list(lengths.values()).count)  # the most common
        odd = [k for k, m in lengths.items() if m != n]
        if odd:
            raise _state_error(odd[0], f"has {lengths[odd[0]]} discs, the other per-disc "
                               f"arrays {n} (lengths: {lengths})")
        spc = s["species"]
        if n and spc.max() >= S:
            k = int(np.argmax(spc))
            raise _state_error("species", f"of disc {k} is {spc[k]}, not an index of the "
                               f"scene's {S} species")
        s["species"] = np.ascontiguousarray(spc, dtype=INDEX)
        u = s["internal_energy"]
        if n and not u.max() <= MAX_MAGNITUDE:
            k = int(np.argmax(u))
            raise _state_error("internal_energy", f"of disc {k} is {u[k]:g}, above "
                               f"{MAX_MAGNITUDE:g}: the speeds it would release over- or "
                               "underflow float64")
        ids = s["ids"]
        if n > 1:
            srt = np.sort(ids)
            dup = srt[1:][srt[1:] == srt[:-1]]
            if len(dup):
                i, j = np.flatnonzero(ids == dup[0])[:2]
                raise _state_error("ids", f"has id {dup[0]} twice (discs {i} and {j}): ids "
                                   "identify discs")
        for key in ("next_id", "steps"):
            s[key] = _state_whole(state, key)
        for key, nonneg in (("time", True), ("since_reset", True), ("energy_input", False),
                            ("energy_start", False)):
            s[key] = _state_real(state, key, nonneg)
        s["clock"] = self._checked_clock(state, s["time"], s["since_reset"])
        bounds = state["bounds"]
        if not isinstance(bounds, (Box, Circle)):
            raise _state_error("bounds", f"must be a Box or Circle, got {_short(bounds)}")
        try:
            check_bounds_scale(bounds, self.scene.species, "bounds", "species")
            check_sides(self.scene, bounds)
        except SceneError as e:
            raise _state_error("bounds", str(e)) from None
        s["bounds"] = bounds
        s["bounds_kind"], s["bounds_params"] = kernel_bounds(bounds)
        integrator = state.get("integrator", self._integrator)
        if not isinstance(integrator, str) or integrator not in ("step", "event"):
            raise _state_error("integrator", f"must be 'step' or 'event', got "
                               f"{_short(integrator)}")
        s["integrator"] = integrator
        s["bit_generator"] = _checked_rng(state["rng"])
        s["rng"] = state["rng"]
        _state_counters(self, state, s)
        # relations between keys
        pos, vel = s["positions"], s["velocities"]
        r = cs.sp_radius[s["species"]]
        out = np.flatnonzero(~discs_inside(pos, r, s["bounds_kind"], s["bounds_params"]))
        if len(out):
            k = out[0]
            raise _state_error("positions", f"has disc {k} (radius {r[k]}) at {pos[k]}, not "
                               f"inside state['bounds'] = {bounds}")
        try:
            event_fit(integrator, self.scene, bounds)
        except ValueError as exc:
            raise _state_error("bounds", f"with state['integrator'] = {integrator!r}: "
                               f"{exc}") from None
        self._check_speeds(vel, "set_state: state['velocities']")
        if n and ids.max() >= s["next_id"]:
            raise _state_error("next_id", f"is {s['next_id']}, but disc "
                               f"{int(np.argmax(ids))} has id {ids.max()}: next_id must exceed "
                               "every id (injected discs take the next ones)")
        if s["since_reset"] > s["time"]:
            raise _state_error("since_reset", f"is {s['since_reset']}, beyond state['time'] = "
                               f"{s['time']} (the time since the last reset_counters)")
        kin, uin, form = _controls.energies(vel, s["species"], s["internal_energy"], cs.sp_mass,
                                            cs.sp_form, n)
        for key, e in (("velocities", kin), ("internal_energy", uin), ("species", form)):
            if not math.isfinite(e):
                raise _state_error(key, f"gives an energy of {e}, beyond the float range")
        if not math.isfinite(kin + uin + form):
            raise _state_error("velocities", "and state['internal_energy'] give a total "
                               f"energy of {kin + uin + form}, beyond the float range")
        if not math.isfinite(s["energy_start"] + s["energy_input"]
                             - float(s["fsum"][_step.FS_DISSIPATED])
                             + wall_heat_of(s["fsum"])
                             - float(s["fsum"][_step.FS_OUTFLOW])):
            raise _state_error("energy_start", "+ state['energy_input'] - state['fsum'] "
                               "(dissipated) is beyond the float range: no energy balance")
        s["n"] = n
        return s

    def _check_fingerprint(self, fp) -> None:
        """Refuse a fingerprint that is malformed or differs from this simulation's, saying
        what differs."""
        own = self._scene_fingerprint()
        try:
            species = tuple((nm, float(r), float(m), float(f)) for nm, r, m, f in fp["species"])
            channels = tuple(fp["channels"])
            ok = isinstance(fp, Mapping) and set(fp) == set(own) and \
                all(isinstance(x[0], str) for x in species) and \
                all(isinstance(c, str) for c in channels)
        except (TypeError, ValueError, KeyError, IndexError):
            ok = False
        if not ok:
            raise _state_error("scene_fingerprint", f"is not a scene fingerprint "
                               f"({_short(fp)}); get_state gives e.g. {own}")
        diff = []
        if [x[0] for x in species] != [x[0] for x in own["species"]]:
            diff.append(("species names", [x[0] for x in species],
                         [x[0] for x in own["species"]]))
        else:
            for k, what in ((1, "radii"), (2, "masses"), (3, "formation energies")):
                a, b = [x[k] for x in species], [x[k] for x in own["species"]]
                if a != b:
                    diff.append((what, a, b))
        if channels != own["channels"]:
            diff.append(("reactions", list(channels), list(own["channels"])))
        if diff:
            detail = "; ".join(f"{w}: {a} in the state, {b} here" for w, a, b in diff)
            raise _state_error(
                "scene_fingerprint", f"belongs to a scene with other "
                f"{', '.join(w for w, _, _ in diff)} ({detail}): a state restores only into a "
                "simulation of the same species and reactions (Simulation.from_arrays starts "
                "another scene from its discs)")

    def _checked_clock(self, state, time: float, since_reset: float) -> tuple:
        """The clocks ``(origin, steps since it, origin of since_reset, steps since it)``.
        ``time`` and ``since_reset`` are what a state says; a clock that does not give them
        with this scene's dt (a state continued under another dt) and a state of an earlier
        version (no clock) restart the clocks at those times."""
        restart = (time, 0, since_reset, 0)
        if "clock" not in state:
            return restart
        c = state["clock"]
        if not isinstance(c, (tuple, list)) or len(c) != 4:
            raise _state_error("clock", f"must be (origin, steps, reset origin, steps since "
                               f"reset), got {_short(c)}")
        t0, k0 = _state_real(c, 0, True, "clock"), _state_whole(c, 1, "clock")
        r0, k1 = _state_real(c, 2, True, "clock"), _state_whole(c, 3, "clock")
        h = self.scene.dt
        if t0 + k0 * h != time or r0 + k1 * h != since_reset:
            return restart
        return (t0, k0, r0, k1)

    def _apply_state(self, s: dict) -> None:
        """Assign a state checked by :meth:`_checked_state` (in place where arrays are big
        enough: the vector env holds views of them)."""
        n = s["n"]
        st, r = self._st, self._r
        st.set_bounds(r, s["bounds"])
        st.touch(r)
        self._n = 0
        self._reserve(n)
        self._pos[:n] = s["positions"]
        self._vel[:n] = s["velocities"]
        self._species[:n] = s["species"]
        self._species[n:] = -1
        self._internal_energy[:n] = s["internal_energy"]
        self._ids[:n] = s["ids"]
        self._idctr[0] = s["next_id"]
        self._steps = s["steps"]
        self._n = n
        if type(self._rng.bit_generator) is type(s["bit_generator"]):
            self._rng.bit_generator.state = s["rng"]
        else:
            self._set_rng(np.random.Generator(s["bit_generator"]))
        self._icnt[:] = 0
        self._icnt[:len(s["icnt"])] = s["icnt"]
        self._fsum[:] = s["fsum"]
        self._ch_count[:] = s["ch_count"]
        self._outflow[:] = s["outflow"]
        self._walls[:] = s["walls"]
        st.origin[r], st.steps[r], st.reset_origin[r], st.reset_steps[r] = s["clock"]
        self._energy_input = s["energy_input"]
        self._energy_start = s["energy_start"]
        self._integrator = s["integrator"]

    def __getstate__(self):
        return {"scene": self.scene, "state": self.get_state()}

    def __setstate__(self, d):
        if not isinstance(d, Mapping) or set(d) != {"scene", "state"} or \
                not isinstance(d["scene"], Scene):
            raise ValueError(f"Simulation.__setstate__: expected {{'scene': Scene, 'state': "
                             f"dict}} (from __getstate__), got {_short(d)}")
        self._setup(d["scene"], None)
        self.set_state(d["state"])

    def _clock(self) -> tuple:
        """(time origin, whole steps since it, the same for since_reset)."""
        st, r = self._st, self._r
        return (float(st.origin[r]), int(st.steps[r]), float(st.reset_origin[r]),
                int(st.reset_steps[r]))

    def copy(self):
        other = type(self).__new__(type(self))
        other.__setstate__(self.__getstate__())
        return other


# ------------------------------------------------------------------ set_state's checks
_INT64_MAX = int(np.iinfo(np.int64).max)
# numpy bit generators a state may name (a Generator made from a seed uses PCG64)
_BIT_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")


def _state_counters(sim: StateIO, state, s: dict) -> None:
    """Check and convert the counters of ``state`` (``icnt``, ``fsum``, ``wall_temperature``,
    ``outflow``, ``ch_count``) into ``s``, for :meth:`StateIO._checked_state`."""
    icnt = _state_array(state, "icnt", (None,), integer=True)
    # counters are only ever appended: a state of an older version has a prefix of them
    if not _OLDEST_ICOUNTERS <= len(icnt) <= len(sim._icnt):
        raise _state_error("icnt", f"has {len(icnt)} counters, this version "
                           f"{_OLDEST_ICOUNTERS} to {len(sim._icnt)}: the state comes "
                           "from another version of discgym")
    s["icnt"] = icnt
    # (a state of a version before the thermal walls and outlets has 2 sums; those two
    # are >= 0, the wall heat and the outflow energy may have either sign)
    fsum = _state_array(state, "fsum", (None,))
    if len(fsum) not in (2, len(sim._fsum)):
        raise _state_error("fsum", f"must have shape ({len(sim._fsum)},), got "
                           f"{fsum.shape}")
    if fsum[:2].min() < 0:
        k = int(np.argmin(fsum[:2]))
        raise _state_error("fsum", f"of entry {k} is negative: {fsum[k]}")
    s["fsum"] = np.zeros(len(sim._fsum), dtype=FLOAT)
    s["fsum"][:len(fsum)] = fsum
    walls = state.get("wall_temperature", None)
    if "wall_temperature" not in state:  # (a state of an earlier version)
        s["walls"] = kernel_walls(sim.scene)
    elif not isinstance(walls, Mapping):
        raise _state_error("wall_temperature", f"must be a dict {{side: kT}} of the "
                           f"scene's thermal walls, got {_short(walls)}")
    else:
        try:
            s["walls"] = sim._checked_walls(walls, "wall_temperature", partial=False)
        except ValueError as exc:
            raise _state_error("wall_temperature", str(exc).split(": ", 1)[-1]) from None
    S = len(sim.scene.species)
    if "outflow" in state:
        s["outflow"] = _state_array(state, "outflow", (S,), integer=True)
    else:
        s["outflow"] = np.zeros(S, dtype=COUNT)
    s["ch_count"] = _state_array(state, "ch_count", (None,), integer=True)
    if len(s["ch_count"]) != len(sim._cs.labels):
        raise _state_error("ch_count", f"has {len(s['ch_count'])} reaction channels, this "
                           f"scene {len(sim._cs.labels)}: the state belongs to a scene with "
                           "other reactions")


def _state_error(key, what: str, within: str | None = None) -> ValueError:
    """The error naming ``state[key]`` (or ``state[within][key]``, an entry of a key)."""
    name = f"[{within!r}][{key!r}]" if within else f"[{key!r}]"
    return ValueError(f"set_state: state{name} {what}")


def _short(v) -> str:
    r = repr(v)
    return r if len(r) <= 80 else r[:77] + "..."


def _state_array(state, key: str, shape: tuple, integer: bool = False,
                 nonneg: bool = False) -> np.ndarray:
    """``state[key]`` as an array of the given shape (None: any length) of finite real numbers
    (FLOAT) or of integers in [0, 2**63) (COUNT; an empty array of any number dtype too)."""
    v = state[key]
    try:
        a = np.asarray(v)
    except (TypeError, ValueError):  # ragged nesting
        a = None
    kinds = "iu" if integer else "fiu"
    if a is None or not (a.dtype.kind in kinds or a.size == 0 and a.dtype.kind == "f"):
        raise _state_error(key, f"must be an array of {'integers' if integer else 'numbers'}"
                           f", got {_short(v)}" + ("" if a is None else f" (dtype {a.dtype})"))
    if a.shape == (0,) and shape == (None, 2):
        a = a.reshape(0, 2)  # no discs: [] (from tolist()) is as good as an empty (0, 2)
    if a.ndim != len(shape) or any(w is not None and w != m for w, m in zip(shape, a.shape)):
        want = ", ".join("N" if w is None else str(w) for w in shape)
        raise _state_error(key, f"must have shape ({want}{',' if len(shape) == 1 else ''}), "
                           f"got {a.shape}")
    item = "disc" if shape[0] is None and key not in ("icnt", "ch_count", "fsum") else "entry"
    if integer:
        # (as Python ints: numpy 1.x compares uint64 with int64 as float64, 2**63 <= 2**63 - 1)
        if a.size and (int(a.min()) < 0 or int(a.max()) > _INT64_MAX):
            k = int(np.argmin(a)) if a.min() < 0 else int(np.argmax(a))
            raise _state_error(key, f"of {item} {k} is {a[k]}: must be in [0, 2**63)")
        return np.ascontiguousarray(a, dtype=COUNT)
    a = np.ascontiguousarray(a, dtype=FLOAT)
    if not np.isfinite(a).all():
        k = np.flatnonzero(~np.isfinite(a.reshape(len(a), -1)).all(axis=1))[0]
        raise _state_error(key, f"of {item} {k} is not finite: {a[k]}")
    if nonneg and a.size and a.min() < 0:
        k = int(np.argmin(a))
        raise _state_error(key, f"of {item} {k} is negative: {a[k]}")
    return a


def _state_whole(state, key, within: str | None = None) -> int:
    v = state[key]
    k = integer(v)
    if k is None:
        raise _state_error(key, f"must be an integer, got {_short(v)}", within)
    if not 0 <= k <= _INT64_MAX:
        raise _state_error(key, f"must be in [0, 2**63), got {v}", within)
    return k


def _state_real(state, key, nonneg: bool, within: str | None = None) -> float:
    v = state[key]
    r = real(v)
    if r is None:
        raise _state_error(key, f"must be a real number, got {_short(v)}", within)
    x = as_float(r)
    if not math.isfinite(x):
        raise _state_error(key, f"must be finite, got {_short(v)}", within)
    if nonneg and x < 0:
        raise _state_error(key, f"must be >= 0, got {x}", within)
    return x


def _is_whole(v, lo: int, hi: int) -> bool:
    k = integer(v)
    return k is not None and lo <= k < hi


def _same_value(a, b) -> bool:
    """Equal nested dicts / arrays / numbers (a generator state read back vs the given)."""
    if isinstance(a, Mapping) or isinstance(b, Mapping):
        return isinstance(a, Mapping) and isinstance(b, Mapping) and set(a) == set(b) and \
            all(_same_value(a[k], b[k]) for k in a)
    if isinstance(a, (np.ndarray, list, tuple)) or isinstance(b, (np.ndarray, list, tuple)):
        x, y = np.asarray(a), np.asarray(b)
        kinds = {x.dtype.kind, y.dtype.kind}
        return x.shape == y.shape and (len(kinds) == 1 or kinds <= set("iu")) and \
            bool((x == y).all())
    return type(a) is type(b) and a == b or (isinstance(a, (int, np.integer)) and
                                             isinstance(b, (int, np.integer)) and a == b)


def _checked_rng(value) -> np.random.BitGenerator:
    """A bit generator holding the generator state ``value``, after checking that numpy
    restores it exactly as given (its setters accept, and silently truncate, floats and
    out-of-range fields)."""
    name = value.get("bit_generator") if isinstance(value, Mapping) else None
    if not isinstance(name, str) or name not in _BIT_GENERATORS:
        raise _state_error("rng", f"must be a numpy bit-generator state (a dict from "
                           f"bit_generator.state, of {', '.join(_BIT_GENERATORS)}), got "
                           f"{_short(value)}")
    if name == "PCG64":
        st = value.get("state")
        ok = set(value) == {"bit_generator", "state", "has_uint32", "uinteger"} and \
            isinstance(st, Mapping) and set(st) == {"state", "inc"} and \
            _is_whole(st["state"], 0, 2 ** 128) and _is_whole(st["inc"], 0, 2 ** 128) and \
            st["inc"] % 2 == 1 and _is_whole(value["has_uint32"], 0, 2) and \
            _is_whole(value["uinteger"], 0, 2 ** 32)
        if not ok:  # (PCG64 streams have an odd increment)
            raise _state_error("rng", "is not a PCG64 state: need {'bit_generator': 'PCG64', "
                               "'state': {'state': int in [0, 2**128), 'inc': odd int in [0, "
                               "2**128)}, 'has_uint32': 0 or 1, 'uinteger': int in [0, 2**32)}"
                               f", got {_short(value)}")
    bg = getattr(np.random, name)(0)
    try:
        bg.state = value
        ok = _same_value(bg.state, value)
    except (TypeError, ValueError, KeyError, IndexError, OverflowError):
        ok = False
    if not ok:
        raise _state_error("rng", f"is not a state numpy restores as given: {_short(value)}")
    return bg
