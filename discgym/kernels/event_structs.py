"""The structs of the event-driven integrator (:mod:`discgym.kernels.event_driven`) and the
codes stored in them.

NamedTuples of arrays and scalars, so the kernels take a few named arguments; C is the
capacity of the state arrays, discs [0, n) are in use. The reactor's own state is the shared
:class:`discgym.kernels.structs.Discs`; :class:`EventCounters` adds the integrator's
statistics to the counters of :class:`discgym.kernels.structs.Counters`. The per-disc tables
are one row per disc, so that a prediction, which reads a neighbour's whole row, touches one
cache line.
"""

from typing import NamedTuple

import numpy as np

from .heap import IndexedHeap

# Columns of Flights.path: a disc's position (PX, PY) at the time PT of its last event, its
# velocity (PVX, PVY), radius PR and mass PM (column 7 pads the row to 64 bytes).
PX, PY, PVX, PVY, PT, PR, PM = range(7)
PATH_COLUMNS = 8

# Columns of Queue.event: a disc's next event (time, partner code, the partner's stamp when it
# was predicted, aux: the wall axis or the cell being entered) and the earliest of its events
# other than a cell crossing (KEPT_*), kept so a crossing needs only a partial prediction.
NEXT_T, NEXT_CODE, NEXT_STAMP, NEXT_AUX, KEPT_T, KEPT_CODE, KEPT_STAMP, KEPT_AUX = range(8)
EVENT_COLUMNS = 8

# Event codes (NEXT_CODE, KEPT_CODE: the partner of a disc's event): >= 0 is a disc.
EV_WALL = -1
EV_CELL = -2
EV_REACT = -3
EV_NONE = -4

# Statistics (columns of EventCounters.stats).
ST_EVENTS = 0  # events popped (valid or stale)
ST_STALE = 1  # events found stale (partner changed since the prediction)
ST_CROSSINGS = 2  # cell crossings
ST_PREDICTIONS = 3  # disc predictions
ST_RESTARTS = 4  # growths of the state arrays in a step (a fission found them full)
ST_GRAZES = 5  # predicted contacts found tangential at the contact (round-off); no impulse
ST_CELLS = 6  # cells in the grid (last restart)
N_STATS = 7


class EventCounters(NamedTuple):
    """Accumulated in place: icnt (IC_*,) int64 and fsum (FS_*,) float64 of
    :mod:`discgym.kernels.structs`; ch_count (channels,) int64 reactions fired per channel;
    stats (N_STATS,) int64 the integrator's own statistics (ST_*); outflow (S,) int64 discs
    that left through an outlet, per species (the fields of
    :class:`~discgym.kernels.structs.Counters` with ``stats`` added)."""

    icnt: np.ndarray
    fsum: np.ndarray
    ch_count: np.ndarray
    stats: np.ndarray
    outflow: np.ndarray


class Flights(NamedTuple):
    """The discs in the integrator's own numbering (live discs in cell order at the start).

    path: (C, 8) float64, columns PX ... PM (a disc is at path[PX:PY] + (t - path[PT])
        path[PVX:PVY] at time t until its next event);
    species: (C,) int32 (-1: no disc); internal_energy: (C,) float64;
    stamp: (C,) int64, bumped whenever the disc's path changes (events naming an older
        stamp are stale);
    t_collision: (C,) float64 its last collision (-inf: none; the TC model);
    t_reaction: (C,) float64 its next first-order reaction (inf: none);
    rate: (C,) float64 the total rate K of its first-order channels whose energy condition
        holds;
    n_first_order: (C,) int64 its first-order events in this run;
    perm: (C,) int32 the caller's index of each disc (fragments: their own index).
    """

    path: np.ndarray
    species: np.ndarray
    internal_energy: np.ndarray
    stamp: np.ndarray
    t_collision: np.ndarray
    t_reaction: np.ndarray
    rate: np.ndarray
    n_first_order: np.ndarray
    perm: np.ndarray


class Cells(NamedTuple):
    """The grid: ncx x ncy cells of w x h from (x0, y0) (iw = 1 / w, ih = 1 / h; floats and
    ints), each disc in the doubly linked list of its cell, so a crossing moves it in O(1).

    head: (ncx ncy,) int32 the first disc of each cell (-1: empty);
    nxt, prv: (C,) int32 the next and previous disc in the same cell (-1: none);
    cell: (C,) int32 the cell of each disc (-1: none).
    """

    x0: float
    y0: float
    w: float
    h: float
    iw: float
    ih: float
    ncx: int
    ncy: int
    head: np.ndarray
    nxt: np.ndarray
    prv: np.ndarray
    cell: np.ndarray


class Queue(NamedTuple):
    """One event per disc: event (C, 8) float64 (columns NEXT_T ... KEPT_AUX) and the
    indexed min-heap of the discs by the time of their next event."""

    event: np.ndarray
    heap: IndexedHeap


class Run(NamedTuple):
    """What a run fixes at its start (scalars; bounds_params the (4,) float64 bounds vector).

    t1: its end time; budget: its event bound; hsub: the substep of the time-stepped
    integrator for its speeds (the shortest wait of a refused reaction); fo_exact:
    first-order events per disc at exact times; tc: the TC model's t_c (0: elastic);
    e_rest, kappa, rmax: restitution, relaxation, the largest radius; collide, has_uni,
    has_bi: which effects the scene has; bounds_kind, bounds_params, b0 ... b3: the
    bounds.
    """

    t1: float
    budget: int
    hsub: float
    fo_exact: int
    tc: float
    e_rest: float
    kappa: float
    rmax: float
    collide: bool
    has_uni: bool
    has_bi: bool
    bounds_kind: int
    bounds_params: np.ndarray
    b0: float
    b1: float
    b2: float
    b3: float
    thermal: bool  #: the scene has thermal walls (their kT per side: walls, NaN: specular)
    walls: np.ndarray
    outlets: bool  #: the scene has outlets (tables.outlets)
