"""Scene -> the flat arrays the kernels read.

Nothing here runs physics; it lays a validated :class:`~discgym.scene.Scene` out as
struct-of-arrays tables with the dtypes of :mod:`discgym.kernels.structs`, and decides which effects
the compiled step has to run (``CompiledScene.flags``).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from .kernels.structs import (  # noqa: F401 (the constants are re-exported)
    BOX,
    CIRCLE,
    F_BI,
    F_COLLISIONS,
    F_FISSION,
    F_OUTLETS,
    F_THERMAL,
    F_UNI,
    FLOAT,
    INDEX,
    N_SIDES,
    P_MAXDISP,
    P_RELAX,
    P_RESTITUTION,
    P_RMAX,
    P_RMIN,
    Tables,
)
from .scene import (
    Box,
    Circle,
    Combination,
    Decomposition,
    Exchange,
    Scene,
    Transformation,
    sides_of,
)

# Reaction channel kinds (ch_kind). A Combination yields two channels: forward and REVERSE.
TRANSFORMATION, DECOMPOSITION, COMBINATION, EXCHANGE, REVERSE = 0, 1, 2, 3, 4

# Bounds kinds (BOX, CIRCLE), the indices into params (P_*) and flags (F_*): see
# discgym.kernels.structs, where the kernels read them.

_K_MAX = 1e300  # rate standing for a certain reaction (probability 1 per unit time)


def kernel_bounds(bounds) -> tuple[int, np.ndarray]:
    """``(kind, params)`` of :class:`~discgym.kernels.structs.Bounds` for a Box or Circle:
    BOX and (xmin, ymin, xmax, ymax), or CIRCLE and (cx, cy, radius, 0)."""
    if isinstance(bounds, Box):
        return BOX, np.array(bounds.extent, dtype=FLOAT)
    if isinstance(bounds, Circle):
        return CIRCLE, np.array([bounds.center[0], bounds.center[1], bounds.radius, 0.0],
                                dtype=FLOAT)
    raise TypeError(f"unknown bounds {bounds!r}")


def kernel_walls(scene: Scene) -> np.ndarray:
    """The wall temperatures of :class:`~discgym.kernels.structs.Bounds` (``walls``, (4,)):
    each thermal wall's kT at its side's index (the order of ``scene.sides_of``), NaN for a
    specular side."""
    walls = np.full(N_SIDES, np.nan, dtype=FLOAT)
    sides = sides_of(scene.bounds)
    for w in scene.thermal_walls:
        walls[sides.index(w.side)] = w.temperature
    return walls


def kernel_outlets(scene: Scene) -> np.ndarray:
    """The outlets as rows (side index, start, end, then 1.0 or 0.0 for each species: does
    it pass) (M, 3 + S) FLOAT."""
    sides = sides_of(scene.bounds)
    names = [sp.name for sp in scene.species]
    return np.array([[sides.index(o.side), o.start, o.end, *(float(o.passes(nm)) for nm in names)]
                     for o in scene.outlets],
                    dtype=FLOAT).reshape(len(scene.outlets), 3 + len(names))


def rate_from_probability(p: float) -> float:
    """First-order rate k with 1 - exp(-k t) = 1 - (1 - p)^t (docs/physics.md, section 5.1)."""
    if p >= 1.0:
        return _K_MAX
    return -math.log1p(-p)


@dataclass(frozen=True, eq=False)
class CompiledScene:
    """The scene as arrays: its :class:`~discgym.kernels.structs.Tables` (S species, K
    reaction channels; each also read by name: ``cs.sp_mass`` is ``cs.tables.sp_mass``),
    ``params`` (see P_*), ``flags`` (see F_*) and one label per channel."""

    scene: Scene
    tables: Tables
    params: np.ndarray  # float vector, see P_*
    flags: np.ndarray  # int vector, see F_*
    labels: tuple  # (K,) str, one per channel

    def __getattr__(self, name):  # (only names that are not attributes: the tables')
        if name in Tables._fields:
            return getattr(self.tables, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")


_CACHE: OrderedDict = OrderedDict()  # id(scene) -> CompiledScene (which holds the scene)
_CACHE_SIZE = 32


def compile_scene(scene: Scene) -> CompiledScene:
    """The scene's tables, built once per scene object (scenes are immutable): a reactor
    environment builds a new Simulation of the same scene at every reset."""
    key = id(scene)
    cs = _CACHE.get(key)
    if cs is not None and cs.scene is scene:  # (the cache holds the scene: ids stay unique)
        _CACHE.move_to_end(key)
        return cs
    cs = _compile(scene)
    _CACHE[key] = cs
    if len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return cs


def _compile(scene: Scene) -> CompiledScene:
    names = scene.species_names
    idx = {n: k for k, n in enumerate(names)}
    S = len(names)
    sp_radius = np.array([s.radius for s in scene.species], dtype=FLOAT)
    sp_mass = np.array([s.mass for s in scene.species], dtype=FLOAT)
    sp_form = np.array([s.formation_energy for s in scene.species], dtype=FLOAT)

    kinds, reac, prod, rate, energy, labels = [], [], [], [], [], []

    def add(kind, r, p, k, e, label):
        kinds.append(kind)
        reac.append([idx[x] for x in r] + [-1] * (2 - len(r)))
        prod.append([idx[x] for x in p] + [-1] * (2 - len(p)))
        rate.append(k)
        energy.append(e)
        labels.append(label)

    for r in scene.reactions:
        if isinstance(r, Transformation):
            add(TRANSFORMATION, r.reactants, r.products, rate_from_probability(r.probability),
                0.0, r.label())
        elif isinstance(r, Decomposition):
            add(DECOMPOSITION, r.reactants, r.products, rate_from_probability(r.probability),
                0.0, r.label())
        elif isinstance(r, Combination):
            add(COMBINATION, r.reactants, r.products, 0.0, r.activation_energy, r.label())
            if r.reverse_probability > 0.0:
                a, b, c = (scene.species[idx[x]] for x in (r.reactant1, r.reactant2, r.product))
                barrier = r.activation_energy + a.formation_energy + b.formation_energy \
                    - c.formation_energy
                add(REVERSE, r.products, r.reactants,
                    rate_from_probability(r.reverse_probability), max(barrier, 0.0),
                    f"{r.product} -> {r.reactant1} + {r.reactant2} (reverse)")
        elif isinstance(r, Exchange):
            add(EXCHANGE, r.reactants, r.products, 0.0, r.activation_energy, r.label())
    C = len(kinds)
    ch_kind = np.array(kinds, dtype=INDEX).reshape(C)
    ch_reac = np.array(reac, dtype=INDEX).reshape(C, 2)
    ch_prod = np.array(prod, dtype=INDEX).reshape(C, 2)
    ch_rate = np.array(rate, dtype=FLOAT).reshape(C)
    ch_energy = np.array(energy, dtype=FLOAT).reshape(C)

    uni = [[] for _ in range(S)]
    bi_table = np.full((S, S), -1, dtype=INDEX)
    for c in range(C):
        if ch_kind[c] in (TRANSFORMATION, DECOMPOSITION, REVERSE):
            if ch_rate[c] > 0.0:
                uni[ch_reac[c, 0]].append(c)
        else:
            a, b = ch_reac[c]
            bi_table[a, b] = bi_table[b, a] = c
    uni_start = np.zeros(S + 1, dtype=INDEX)
    for s in range(S):
        uni_start[s + 1] = uni_start[s] + len(uni[s])
    uni_chan = np.array([c for lst in uni for c in lst], dtype=INDEX)

    params = np.array(
        [scene.restitution, scene.internal_relaxation, scene.max_displacement,
         sp_radius.min(), sp_radius.max()],
        dtype=FLOAT,
    )
    fission = any(ch_kind[c] in (DECOMPOSITION, REVERSE) for c in uni_chan)
    flags = np.array(
        [int(scene.collisions), int(len(uni_chan) > 0),
         int(scene.collisions and bool((bi_table >= 0).any())), int(fission),
         int(len(scene.thermal_walls) > 0), int(len(scene.outlets) > 0)],
        dtype=INDEX,
    )
    tables = Tables(sp_radius, sp_mass, sp_form, ch_kind, ch_reac, ch_prod, ch_rate,
                    ch_energy, uni_start, uni_chan, bi_table, kernel_outlets(scene))
    return CompiledScene(scene, tables, params, flags, tuple(labels))
