"""The observation's slots: their names and bounds (what
:func:`discgym.kernels.batch.observe_one` writes, in its order), and the edges of the
kinetic-energy histogram."""

from __future__ import annotations

import numpy as np

from .kernels.structs import FLOAT
from .scene import Combination, Exchange, Scene

#: Observations are clipped to these bounds (see the README, "Observation Space").
OBS_ENERGY_MAX = 20.0  # per-species kT, mean internal energy, |total energy per disc|
OBS_DISCS_MAX = 4.0  # discs now / discs at reset
OBS_YIELD_MAX = 4.0  # product / limiting reactant at reset
OBS_RATE_MAX = 4.0  # reactions of one channel in one step / limiting reactant at reset


def observation_slots(names, feed: tuple, size_min: float, size_max: float) -> tuple:
    """``(names, low, high)`` of the observation's slots (see
    :func:`~discgym.kernels.batch.observe_one`). Every slot's range contains 0: TorchRL fills
    the final observation of a vector env's reactors that did not finish with zeros and
    checks them against the space."""
    obs_names, lo, hi = [], [], []

    def slot(name, low, high):
        obs_names.append(name)
        lo.append(low)
        hi.append(high)

    for nm in names:
        slot(f"fraction_{nm}", 0.0, 1.0)
    for nm in names:
        slot(f"kT_{nm}", 0.0, OBS_ENERGY_MAX)
    for nm in names:
        slot(f"internal_{nm}", 0.0, OBS_ENERGY_MAX)
    slot("energy_per_disc", -OBS_ENERGY_MAX, OBS_ENERGY_MAX)
    slot("discs", 0.0, OBS_DISCS_MAX)
    slot("yield", 0.0, OBS_YIELD_MAX)
    # (the size never goes below size_min; a low of 0 clips to the same float32 values:
    # rounding to float32 is monotone and float32(size_min) is the rounded size_min)
    slot("size", 0.0, size_max)
    slot("time_left", 0.0, 1.0)
    for f in feed:
        slot(f"feed_left_{names[f]}", 0.0, 1.0)
    return obs_names, lo, hi


def energy_edges(scene: Scene, bins: int) -> np.ndarray:
    """The inner edges (B - 1,) of the kinetic-energy histogram of B bins, relative to the
    scene's activation energies: the distinct positive activation energies E_1 < E_2 < ...
    of its combinations and exchanges are edges (the tail above a barrier is what decides a
    reaction's rate), preceded by E_1 / 2, E_1 / 4, ... for the remaining edges (B - 1 fewer
    than the barriers: the lowest B - 1 of them). A scene without barriers uses its kT x 4
    as E_1."""
    if bins == 0:
        return np.zeros(0, dtype=FLOAT)
    barriers = sorted({float(r.activation_energy) for r in scene.reactions
                       if isinstance(r, (Combination, Exchange)) and r.activation_energy > 0})
    if not barriers:
        barriers = [4.0 * scene.temperature]
    m = bins - 1
    if m <= len(barriers):
        edges = barriers[:m]
    else:
        below = m - len(barriers)
        edges = [barriers[0] / 2.0 ** j for j in range(below, 0, -1)] + barriers
    return np.array(edges, dtype=FLOAT)


def extra_slots(obs_names, lo, hi, names, bins, edges, grid, labels, *, jacket=False,
                 t_max=0.0, feed_kT=False, outflow=False) -> None:
    """Append the optional blocks' slots (see :func:`discgym.kernels.batch.observe_one`)."""
    def slot(name, low, high):
        obs_names.append(name)
        lo.append(low)
        hi.append(high)

    if jacket:
        slot("jacket_kT", 0.0, t_max)
    if feed_kT:
        slot("feed_kT", 0.0, OBS_ENERGY_MAX)
    if outflow:
        for nm in names:
            slot(f"outflow_{nm}", 0.0, OBS_RATE_MAX)

    for nm in names:
        for b in range(bins):
            a = "0" if b == 0 else f"{edges[b - 1]:g}"
            z = "inf" if b == bins - 1 else f"{edges[b]:g}"
            slot(f"energy_{nm}[{a},{z})", 0.0, 1.0)
    for nm in names:
        for j in range(grid):
            for i in range(grid):
                slot(f"cell_{nm}_{i}_{j}", 0.0, 1.0)
    for j in range(grid):
        for i in range(grid):
            slot(f"cell_kT_{i}_{j}", 0.0, OBS_ENERGY_MAX)
    for lab in labels:
        slot(f"reactions[{lab}]", 0.0, OBS_RATE_MAX)
