"""The dtypes of every array a kernel reads, and the structs that group those arrays.

Every array handed to a compiled kernel is created with one of the dtypes below, so a kernel
is compiled for exactly one signature and the on-disk numba cache is reused across runs.

The structs are ``typing.NamedTuple`` s of arrays (and, for the constants, scalars): numba
passes them as one argument and reads a field by name, so a kernel takes a few structs
instead of dozens of positional arrays, and no caller can pass them in the wrong order. Hot
kernels unpack the fields they use into locals once, at the top.

Across the boundary with Python the structs travel as plain tuples of their fields: the
entry points (``step.advance_rngs``, ``event_driven.run_steps_rngs``, ``batch.env_step``,
...) rebuild them with ``Struct(*fields)`` and return plain tuples (:func:`fields`). Numba
types a plain tuple of arrays in C, a NamedTuple field by field in Python, about 0.5 us per
field per call, and unpickles a NamedTuple's class whenever it boxes one: the environment's
step passes four structs of 56 fields (docs/performance.md).

Shapes: S species, K reaction channels, U unimolecular channel entries, R reactors of a
batch, C disc capacity per reactor, F feed species, D observation slots.
"""

from typing import NamedTuple

import numpy as np
from numba import njit, typed
from numba.extending import register_jitable

FLOAT = np.float64  #: positions, velocities, energies, times
INDEX = np.int32  #: species indices, disc indices in cell lists and event queues
COUNT = np.int64  #: event counters and stamps (never overflow in practice)

# Bounds kinds and the bounds parameter vector (4 floats):
#   box:    (xmin, ymin, xmax, ymax)
#   circle: (cx, cy, radius, 0)
BOX, CIRCLE = 0, 1
# How an environment's heat action heats: rescaling every velocity, or setting the
# temperature of the thermal walls (ReactorConsts.heating).
SCALE, JACKET = 0, 1
# Which integrator an environment step runs (ReactorConsts.integrator): the time-stepped one
# (kernels.step.advance) or the exact event-driven one (kernels.event_driven.run_steps).
STEPPED, EVENT = 0, 1

# Indices into a compiled scene's float parameter vector (params).
P_RESTITUTION, P_RELAX, P_MAXDISP, P_RMIN, P_RMAX = range(5)
# Indices into its flags vector.
F_COLLISIONS, F_UNI, F_BI, F_FISSION, F_THERMAL, F_OUTLETS = range(6)
# The sides of the bounds, indices into Bounds.walls and the side column of Tables.outlets:
# a box's left, right, bottom, top (x = xmin, x = xmax, y = ymin, y = ymax); a circle's one
# wall is side 0.
LEFT, RIGHT, BOTTOM, TOP = range(4)
N_SIDES = 4


# The stepped integrator's counters (indices into Counters.icnt and Counters.fsum) and the
# bounds of its event phase (kernels.step, kernels.clusters).
# Integer counters (icnt)
IC_COLLISIONS = 0  # non-reactive disc-disc collisions
IC_WALL_HITS = 1
IC_SUBSTEPS = 2
IC_EVENTS_CAPPED = 3  # substeps finished by the fallback (an event bound was reached)
IC_PUSHED_INSIDE = 4  # discs overlapping a wall while moving inward, moved inside
IC_NO_ROOM = 5  # reactions that could not place their products (they wait / bounce)
IC_SUBSTEPS_CAPPED = 6  # steps that needed more than MAX_SUBSTEPS substeps (or, when the rest
# of a step was split anew, substeps shorter than its share of them: see _resplit)
IC_REACTIVE = 7  # reactive collisions (also counted per channel)
IC_TC_ELASTIC = 8  # repeat collisions within a substep made elastic (TC model, e < 1 only)
IC_GLIDES = 9  # grazing discs advanced through many circle-wall reflections at once
IC_RESOLVED = 10  # discs moved in / pairs pushed apart by the fallback (resolve.py)
IC_GRAZE_REPAIRS = 11  # substeps repaired (and not event-capped) because a pair was found
# overlapping while separating: left by a missed graze, by an earlier repair or by set_state
IC_LEFT_OVERLAPPING = 12  # (internal) detections of such pairs: they trigger the repair
IC_RESPLITS = 13  # times the rest of a step was split anew: a reaction or a release of internal
# energy left a disc faster than the current substep allows (see advance)
IC_CUTS = 14  # substeps ended at such a reaction inside their event phase (each one re-split)
N_ICOUNTERS = 15
# Float accumulators (fsum)
FS_WALL_MOMENTUM = 0  # momentum delivered to the walls (for the pressure)
FS_DISSIPATED = 1  # kinetic energy lost to restitution e < 1
FS_WALL_HEAT = 2  # energy the thermal walls put into the discs (negative: taken out), per
# side: FS_WALL_HEAT + side (LEFT ... TOP of kernels.structs; a circle's wall: side 0)
FS_OUTFLOW = 6  # energy (kinetic + internal + formation) carried out through outlets
N_FSUMS = 7
VR_ROUNDOFF = 1e-13  # a pair whose approach speed is below this fraction of its speeds is not
# approaching: the impulse would be lost to round-off and the pair re-detected forever
EVENTS_PER_DISC = 64  # event budget per substep: EVENTS_PER_DISC * n + 1024
DISC_EVENTS = 1024  # events one disc may take part in per substep; past it, see resolve.py
OV_SLOTS = 4  # overlaps recorded per disc by the (parallel) broad phase; more: rescanned


class Tables(NamedTuple):
    """The per-species and per-channel tables of a compiled scene (built by
    :func:`discgym.compiled.compile_scene`); kernels read them by name."""

    sp_radius: np.ndarray  #: (S,) FLOAT, disc radius of each species
    sp_mass: np.ndarray  #: (S,) FLOAT
    sp_form: np.ndarray  #: (S,) FLOAT, formation energy
    ch_kind: np.ndarray  #: (K,) INDEX, TRANSFORMATION ... REVERSE (see discgym.compiled)
    ch_reac: np.ndarray  #: (K, 2) INDEX reactant species, -1 where unused
    ch_prod: np.ndarray  #: (K, 2) INDEX product species, -1 where unused
    ch_rate: np.ndarray  #: (K,) FLOAT, first-order rate per unit time
    ch_energy: np.ndarray  #: (K,) FLOAT, activation energy (bimolecular) or barrier
    uni_start: np.ndarray  #: (S + 1,) INDEX, CSR offsets into uni_chan per reactant species
    uni_chan: np.ndarray  #: (U,) INDEX, unimolecular channel indices
    bi_table: np.ndarray  #: (S, S) INDEX, bimolecular channel of a pair of species, or -1
    outlets: np.ndarray  #: (M, 3 + S) FLOAT outlet segments: side (LEFT ... TOP, 0 for a
    #: circle), start, end (fractions of the side, or of the circle's turn from +x), then
    #: per species 1.0 if it passes (a membrane passes some), else 0.0


class Discs(NamedTuple):
    """The discs of one reactor (capacity C >= n; discs [0, n) live, species -1 past them)."""

    pos: np.ndarray  #: (C, 2) FLOAT positions
    vel: np.ndarray  #: (C, 2) FLOAT velocities
    species: np.ndarray  #: (C,) INDEX species index, -1 for no disc
    internal_energy: np.ndarray  #: (C,) FLOAT
    ids: np.ndarray  #: (C,) COUNT disc identities
    next_id: np.ndarray  #: (1,) COUNT the identity the next new disc takes


class Bounds(NamedTuple):
    """The bounds of one reactor."""

    kind: int  #: BOX or CIRCLE
    params: np.ndarray  #: (4,) FLOAT box (xmin, ymin, xmax, ymax), circle (cx, cy, radius, 0)
    walls: np.ndarray  #: (N_SIDES,) FLOAT kT of each side's thermal wall (NaN: specular);
    #: read only where flags[F_THERMAL] is set


class Injection(NamedTuple):
    """Discs to add to a reactor (``kernels.controls.inject``)."""

    species: int  #: the species index
    targets: np.ndarray  #: (M, 2) FLOAT where each disc should go if free (NaN: anywhere)
    temperature: float  #: kT of their velocities (NaN: the reactor's own)


class Counters(NamedTuple):
    """The counters a run accumulates in place."""

    icnt: np.ndarray  #: (N_ICOUNTERS,) COUNT integer counters (IC_* of kernels.step)
    fsum: np.ndarray  #: (N_FSUMS,) FLOAT float sums (FS_* of kernels.step)
    ch_count: np.ndarray  #: (K,) COUNT reactions fired per channel
    outflow: np.ndarray  #: (S,) COUNT discs that left through an outlet, per species


class Scratch(NamedTuple):
    """The per-disc scratch arrays of the stepped integrator (ws >= n entries each; views of
    the work buffers, see ``kernels.step._carve``)."""

    stamp: np.ndarray  #: (ws,) COUNT a disc's event stamp (older stamps in the queue: stale)
    lastcol: np.ndarray  #: (ws,) COUNT the substep of a disc's last collision (TC model)
    tlast: np.ndarray  #: (ws,) FLOAT time of a disc's latest event in the substep
    wall_t: np.ndarray  #: (ws,) FLOAT a disc's wall contact time found by the drift
    wflag: np.ndarray  #: (ws,) INDEX 1 if the drift pushed the disc inside
    cell_of: np.ndarray  #: (ws,) INDEX a disc's cell
    cell_items: np.ndarray  #: (ws,) INDEX discs sorted by cell
    sx: np.ndarray  #: (ws,) FLOAT x of the sorted discs
    sy: np.ndarray  #: (ws,) FLOAT y of the sorted discs
    sr: np.ndarray  #: (ws,) FLOAT radius of the sorted discs
    ov_n: np.ndarray  #: (ws,) INDEX overlapping partners of a sorted disc (half stencil)
    ov_b: np.ndarray  #: (ws, OV_SLOTS) INDEX the first of them
    binx: np.ndarray  #: (ws,) FLOAT x where a disc was binned
    biny: np.ndarray  #: (ws,) FLOAT y where a disc was binned
    partner: np.ndarray  #: (ws,) INDEX a disc's latest collision partner in the substep, or -1
    nev: np.ndarray  #: (ws,) INDEX events a disc took part in in the substep
    cell_start: np.ndarray  #: (cells + 2,) INDEX CSR offsets of the cells into cell_items
    wl: np.ndarray  #: (ws,) INDEX discs with a wall contact or pushed inside (increasing)
    ol: np.ndarray  #: (ws,) INDEX sorted discs with overlapping partners (increasing)
    nlist: np.ndarray  #: (2,) INDEX how many discs wl and ol list (kernels.contacts)


class PairList(NamedTuple):
    """The stepped integrator's pair (Verlet) list, kept across the substeps of one call
    (``kernels.step``, "the pair list"): the pairs of small discs (radius <= the cell radius
    rcell) whose reference positions are closer than 2 rcell + skin, each pair once.

    Invariant at every broad phase, after the refresh: every small disc is listed and within
    skin / 2 of its reference position, and every pair of them whose reference positions are
    closer than 2 rcell + skin is in the list; so every overlapping pair of small discs is."""

    ref: np.ndarray  #: (ws, 2) FLOAT a disc's reference position (where it was listed)
    listed: np.ndarray  #: (ws,) INDEX 1 if the disc is listed (0: new, big, or list rebuilt)
    mark: np.ndarray  #: (ws,) INDEX 1 if the disc is refreshed (its pairs dropped) this substep
    todo: np.ndarray  #: (ws,) INDEX the discs refreshed in this substep (compact)
    pi: np.ndarray  #: (cap,) INDEX first disc of each listed pair (capacity doubled when full)
    pj: np.ndarray  #: (cap,) INDEX second disc
    ovi: np.ndarray  #: (cap,) INDEX first disc of each pair found overlapping in the substep
    ovj: np.ndarray  #: (cap,) INDEX second disc
    count: np.ndarray  #: (2,) int64 listed pairs, overlapping pairs


class Physics(NamedTuple):
    """What a reactor's physics reads of its compiled scene
    (:class:`~discgym.compiled.CompiledScene`)."""

    tables: Tables  #: the scene's tables (a reactor's kinetics: rows of Episodes)
    params: np.ndarray  #: FLOAT the scene's parameters (P_*)
    flags: np.ndarray  #: INDEX the scene's effects (F_*)


class Call(NamedTuple):
    """One call of the time-stepped integrator (``step.advance``): what it is asked to do."""

    n_steps: int  #: steps to take
    dt: float  #: the length of a step
    threads: int  #: work chunks for numba's threads (0 or 1: all on the calling thread)
    step0: int  #: the global index of the call's first step (for the memory reordering)
    reorder_every: int  #: steps between memory reorderings (0: none)


class RunConsts(NamedTuple):
    """What a stepped run reads from its scene and flags, once per call."""

    restitution: float  #: e
    relax: float  #: kappa, the share of internal energy a collision releases
    maxdisp: float  #: the most a disc may move in a substep (max_displacement x r_min)
    rcell: float  #: the cell radius of the grid
    collide: bool  #: the scene has disc-disc collisions
    has_bi: bool  #: ... and bimolecular reactions
    thermal: bool  #: the scene has thermal walls (flags[F_THERMAL])
    outlets: bool  #: ... outlets (flags[F_OUTLETS])


class Phase(NamedTuple):
    """What the phases of a stepped substep read and write, besides the counters: the state,
    its tables and bounds, the substep's grid and scratch, and the run's constants."""

    discs: Discs  #: the state
    tables: Tables
    bounds: Bounds
    grid: np.ndarray  #: (7,) FLOAT the cell grid (celllist.make_grid)
    sc: Scratch  #: the per-disc scratch
    rc: RunConsts


class ClusterRun(NamedTuple):
    """One cluster's run of the event loop (``events.run_cluster``, ``cl``; the
    clusters of ``kernels.clusters``)."""

    cid: int  #: the cluster
    dynamic: bool  #: claims free cells as it goes (the repair), else confined to its own
    own: np.ndarray  #: the owner blocks
    base: int
    ecl: np.ndarray  #: event q's cluster
    rep: int  #: the event free blocks are claimed for
    cparent: np.ndarray  #: the merged clusters (union-find; the repair's)
    lg: np.ndarray  #: (rows, 5) FLOAT the log: disc, velocity, stamp, lastcol
    rec: np.ndarray  #: (rows, 5) FLOAT the float terms: t, i, j, which sum, value
    fill: np.ndarray  #: (2,) int64 rows of ``lg`` and ``rec`` used


class Substep(NamedTuple):
    """One substep's constants, as its event phase reads them."""

    sub_id: int  #: its number in the call (a disc's last collision's, for the TC model)
    h: float  #: its length
    cut_after: float  #: a release of energy ends it early only with more than this left
    budget: int  #: the events it may take (EVENTS_PER_DISC * n + 1024)


class Marks(NamedTuple):
    """What a stepped substep's events mark on each disc (arrays of its
    :class:`Scratch`): what a collision reads and writes besides the discs."""

    tlast: np.ndarray  #: (ws,) FLOAT the time of the disc's last event in the substep
    stamp: np.ndarray  #: (ws,) COUNT its events so far (a queued event names them)
    partner: np.ndarray  #: (ws,) INDEX the disc its last event was with (-1: a wall)
    lastcol: np.ndarray  #: (ws,) COUNT the substep of its last inelastic collision


class Search(NamedTuple):
    """Where a check for room looks: the grid of the substep, the discs binned in it (by
    cell, [0, nbin)), the discs made since ([nbin, n)), and how far a binned disc may be from
    where it was binned (``reach``; the searched disc's radius is added to it)."""

    grid: np.ndarray  #: (7,) FLOAT
    cell_start: np.ndarray  #: (cells + 2,) INDEX
    cell_items: np.ndarray  #: (ws,) INDEX
    nbin: int
    n: int
    reach: float
    collide: bool  #: False: the discs do not collide, only the bounds are checked


# (the disc fields written once: a reactor's row of them is a Discs)
Reactors = NamedTuple("Reactors", [(f, np.ndarray) for f in Discs._fields + (
    "n", "ksteps", "bounds_kind", "bounds_params", "icnt", "fsum", "ch_count", "outflow",
    "bounds_walls")])
Reactors.__doc__ = """The state of R reactors of one scene, as padded rows: reactor r is row
r of each field (discs [0, n[r]) are live, species -1 past them).

The fields of :class:`Discs`, each with a leading axis of R (``pos`` (R, C, 2), ...,
``next_id`` (R, 1)), then: ``n`` (R,) int64 live discs; ``ksteps`` (R,) int64 kernel steps
taken (times the memory reordering); ``bounds_kind`` (R,) int64 BOX or CIRCLE and
``bounds_params`` (R, 4) FLOAT its parameters (see discgym.compiled); ``icnt``
(R, N_ICOUNTERS) COUNT integer counters (IC_*); ``fsum`` (R, N_FSUMS) FLOAT float sums
(FS_*); ``ch_count`` (R, K) COUNT reactions fired per channel; ``outflow`` (R, S) COUNT
discs that left through an outlet, per species; ``bounds_walls`` (R, N_SIDES) FLOAT wall
temperatures (see Bounds.walls)."""


class Episodes(NamedTuple):
    """The environment's per-episode state of R reactors, and the outputs of a step."""

    size: np.ndarray  #: (R,) FLOAT reactor size relative to the scene's bounds
    feed_left: np.ndarray  #: (R, F) int64 discs each feed species may still inject
    steps: np.ndarray  #: (R,) int64 episode steps taken
    n_init: np.ndarray  #: (R,) FLOAT discs at the reset
    n_ref: np.ndarray  #: (R,) FLOAT the reward's normaliser
    temperature: np.ndarray  #: (R,) FLOAT kT of the last observation
    kinetic: np.ndarray  #: (R,) FLOAT kinetic energy of the last observation
    stats: np.ndarray  #: (R, 3 S + 1) FLOAT per-species sums (see kernels.batch)
    obs: np.ndarray  #: (R, D) float32 observations
    fout: np.ndarray  #: (R, 2 + F) FLOAT float outputs of a step (O_HEAT, ...)
    iout: np.ndarray  #: (R, 3 + 2 F) int64 integer outputs of a step (O_STATUS, ...)
    sp_form: np.ndarray  #: (R, S) FLOAT each reactor's formation energies (drawn per episode
    #: where the kinetics are uncertain; else the scene's)
    ch_rate: np.ndarray  #: (R, K) FLOAT each reactor's first-order rates (as Tables.ch_rate)
    ch_energy: np.ndarray  #: (R, K) FLOAT each reactor's activation energies and barriers
    ch_last: np.ndarray  #: (R, K) int64 reactions fired per channel in the last step
    out_last: np.ndarray  #: (R, S) int64 discs that left through outlets in the last step
    feed_kT: np.ndarray  #: (R,) FLOAT kT of injected discs (NaN: the reactor's own kT)
    feed_kT_next: np.ndarray  #: (R,) FLOAT the inlet kT from step feed_switch on
    feed_switch: np.ndarray  #: (R,) int64 the step at which the inlet kT changes (-1: never)
    pending: np.ndarray  #: (R, 2) FLOAT a step left at its exact run's event bound: the time
    #: left and the thermal walls' heat before the step (kernels.batch.CAPPED)
    # each reactor's own settings (ReactorConfig's, set at its reset: a batch may mix them)
    heat_rate: np.ndarray  #: (R,) FLOAT kinetic energy x heat_rate ** a at heat action a
    t_min: np.ndarray  #: (R,) FLOAT kT the heat control keeps within [t_min, t_max]
    t_max: np.ndarray  #: (R,) FLOAT
    size_min: np.ndarray  #: (R,) FLOAT the range of the size (relative to the scene's bounds)
    size_max: np.ndarray  #: (R,) FLOAT
    wall_speed: np.ndarray  #: (R,) FLOAT the most the size changes per step
    inject_max: np.ndarray  #: (R,) int64 discs injected per step at injection action 1
    episode_steps: np.ndarray  #: (R,) int64 the episode's length
    feed_budget: np.ndarray  #: (R, F) int64 discs each feed species may inject per episode
    heat_cost: np.ndarray  #: (R,) FLOAT the reward's cost per unit of heat (read in Python)
    feed_cost: np.ndarray  #: (R,) FLOAT the reward's cost per disc fed (read in Python)


class ReactorConsts(NamedTuple):
    """The constants of a reactor environment that every reactor of a batch shares
    (:attr:`discgym.config.ReactorConfig.consts`; each reactor's own settings are rows of
    :class:`Episodes`)."""

    speed_limit: float  #: the fastest a disc may move (see :func:`speed_limit`)
    ref_bounds: np.ndarray  #: (4,) FLOAT the scene's bounds: box (x0, y0, width, height),
    #: circle (cx, cy, radius, 0)
    temperature: float  #: the scene's kT (injection into an empty reactor)
    dt: float  #: the step of the scene
    packing: float  #: the densest packing fraction a resize may ask of the discs
    steps_per_action: int  #: kernel steps per environment step
    attempts: int  #: placement attempts per disc
    reorder_every: int  #: kernel steps between memory reorderings
    product: int  #: species index of the product
    feed: np.ndarray  #: (F,) INDEX feed species
    obs_low: np.ndarray  #: (D,) float32 observation bounds
    obs_high: np.ndarray  #: (D,) float32
    energy_edges: np.ndarray  #: (B - 1,) FLOAT inner edges of the kinetic-energy histogram
    energy_bins: int  #: B, bins of the per-species kinetic-energy histogram (0: none)
    grid: int  #: G, cells per side of the spatial histogram (0: none)
    obs_reactions: int  #: 1: the observation counts the reactions of the last step
    heating: int  #: SCALE (velocities rescaled) or JACKET (thermal walls set)
    obs_feed_kT: int  #: 1: the observation shows the inlet temperature
    obs_outflow: int  #: 1: the observation counts the discs that left in the last step
    integrator: int  #: STEPPED (kernels.step.advance) or EVENT (one exact event-driven run)


@register_jitable
def speed_limit(max_substeps: int, max_displacement: float, r_min: float, dt: float) -> float:
    """The fastest a disc may move: a step of ``dt`` is split into at most ``max_substeps``
    substeps in which no disc moves more than ``max_displacement`` smallest radii ``r_min``."""
    return max_substeps * max_displacement * r_min / dt


@register_jitable
def fields(discs):
    """The fields of a :class:`Discs` as a plain tuple: what an entry point called from Python
    returns (numba unpickles a NamedTuple's class each time it boxes one)."""
    return (discs.pos, discs.vel, discs.species, discs.internal_energy, discs.ids,
            discs.next_id)


@register_jitable
def capacity_for_discs(n: int) -> int:
    """The capacity that holds ``n`` discs and one fission of each (2 n, plus a margin)."""
    return 2 * n + 16


# -- the random generators ----------------------------------------------------------------

@njit(cache=True)
def _list_of(generator):
    out = typed.List()
    out.append(generator)
    return out


@njit(cache=True)
def _append(out, generator):
    out.append(generator)


def generator_list(generators) -> typed.List:
    """The ``numpy.random.Generator`` s as the kernels take them: a ``numba.typed.List`` of
    them (the same objects: a kernel's draws advance their state), one type whatever their
    number. Built by two cached compiled functions: ``typed.List(generators)`` compiles
    numba's list constructor and append again in every process (about 0.3 s, half of
    a warm env's first step)."""
    generators = list(generators)
    if not generators:
        raise ValueError("generator_list: no generators")
    out = _list_of(generators[0])
    for g in generators[1:]:
        _append(out, g)
    return out
