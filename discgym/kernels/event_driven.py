"""The exact, event-driven integrator: the accuracy ceiling of the time-stepped one.

Between events a disc flies in a straight line: it is stored as its position at the time of
its own last event and its velocity (a row of :class:`~.event_structs.Flights`), and is
brought forward only when an event involves it (x += (t - t_last) v, t_last = t) and, at the
end of a call, to the common end time. Events are exactly predicted and processed in time
order:

- disc-disc contacts (the earlier root of |r + t v| = R_i + R_j, cancellation-free);
- disc-wall contacts (box: per axis; circle: the root of |d + t v| = R_m - R_c ahead);
- cell crossings: discs are kept in a grid of cells at least one largest diameter wide, so a
  disc only ever predicts contacts with the discs of its own and the 8 adjacent cells, and a
  crossing into a new cell is itself an event, after which only the 3 cells that have just
  become adjacent are scanned (prediction stays local: O(1) work per event);
- first-order reactions at exactly sampled exponential times: each disc carries the total
  rate K of its first-order channels whose energy condition holds now
  (:func:`~discgym.kernels.reactions.first_order_rate`, the same rule as the time-stepped
  integrator) and its next reaction time t + Exp(1)/K. K only changes when the disc's species
  or internal energy does (at collisions and reactions); it is recomputed then and the time
  resampled if K changed (exact, the exponential being memoryless).

The queue is an indexed binary min-heap holding ONE event per disc, its earliest (Isobe's
scheme): O(log N) per event, no heap growth. Each disc also has an event counter ``stamp``,
bumped whenever its trajectory changes; an event naming a partner whose counter has moved on
is stale and only makes its disc predict again.

Calls: a call of n steps is one exact run of n dt. It starts from the state alone (times
from 0, every disc's first event predicted afresh, O(N log N); reaction times drawn afresh,
exact since the exponential is memoryless; discs numbered in cell order for memory
locality) and ends with every disc brought to its end. So a copy or a restored state
continues bit for bit as the original does under the same calls, and the arrays' capacity
plays no part (a fission that finds them full grows them in place). A call boundary is a
synchronisation point: ``step(30); step(40)`` is two runs, the same physics as ``step(70)``
but not the same round-off and random stream. Predicting every disc afresh at every step
boundary would make them equal, at several times the cost of the run itself at ordinary
steps (docs/hard_cases.md, finding 19).

Bounds on the work of a call (no input may make a call run without end), per step of dt in
the call: a refused first-order reaction retries no sooner than one substep of the
time-stepped integrator later (``dt / k``, k its substep count for a step from the speeds at
the call's start: the pace at which it retries), a disc's first-order events past FO_EXACT
per step are delayed to the same pace (a cycle of certain reactions, A -> B -> A, has no end
at one instant), and a call stops at the time-stepped integrator's event bound for its
steps, ``n k (64 N + 1024)`` events, after which the time-stepped integrator finishes it
(``events_capped``). Bounds that leave a species less than
FIT_MARGIN radii of room are refused by :class:`~discgym.Simulation`.

Round-off: a pair counts as approaching only if its normal approach speed exceeds 1e-10 of
its relative speed (``event_predict.APPROACH2``); closer to tangential, the impulse would
vanish in round-off and the same contact would be predicted again at once. Nothing physical
is lost.

The physics is shared with the time-stepped integrator, not copied: impulses come from
:func:`~discgym.kernels.collisions.bounce`, wall reflections from
:func:`~discgym.kernels.walls.reflected`, reaction outcomes from the pure functions of
:mod:`~discgym.kernels.reactions` (``combine_outcome``, ``exchange_outcome``,
``fission_outcome``, ...) and what they write into the state from its ``apply_*`` functions
(given views of the per-disc rows as positions and velocities). Reactive collisions fire at
the contact when the energy along the line of centres, 1/2 mu v_r^2, is at least E_a (the
same trigger). Products are placed only
where they fit inside the bounds without overlapping any disc (no room: the collision
bounces, a first-order reaction waits an exponential time, but at least a substep, and tries
again); both count as ``reactions_without_room``.

Inelastic collapse (restitution e < 1) would make infinitely many collisions in finite time:
a collision of a disc that collided less than t_c ago is elastic (the TC model of Luding and
McNamara; the time-stepped integrator uses t_c = its substep), with t_c = ``TC_FRACTION``
times the time the smallest disc takes to move its radius at the root-mean-square speed
(taken at the start of each call). The energy booked as dissipated is exactly what was lost;
such collisions are counted as ``elastic_repeats``.

Counters (:class:`~.event_structs.EventCounters`) are those of :mod:`discgym.kernels.step`;
``events_capped`` counts the steps stopped at the event bound and the delayed first-order
events; ``substeps`` and the other counters of the time-stepped integrator count only what it
did finishing such steps (0 otherwise).

Where it is written: the grid and each disc's next event in :mod:`.event_predict`, what each
kind of event does in :mod:`.event_handlers`, the structs and the codes they hold in
:mod:`.event_structs`; here the run (loading the discs, the event loop, writing them back)
and its entry points.
"""

import math

import numpy as np
from numba import njit

from .event_handlers import (
    collision,
    crossing,
    first_order_event,
    may_split,
    wall_event,
)
from .event_predict import (
    cell_insert,
    cell_of,
    fly_to,
    make_cells,
    next_reaction,
    predict,
    set_kind,
)
from .event_structs import (
    EV_CELL,
    EV_REACT,
    EV_WALL,
    EVENT_COLUMNS,
    N_STATS,
    NEXT_CODE,
    NEXT_STAMP,
    PATH_COLUMNS,
    PT,
    PVX,
    PVY,
    PX,
    PY,
    ST_CELLS,
    ST_CROSSINGS,
    ST_EVENTS,
    ST_PREDICTIONS,
    ST_RESTARTS,
    ST_STALE,
    Cells,
    EventCounters,
    Flights,
    Queue,
    Run,
)
from .heap import IndexedHeap, heap_set
from .jit import kernel
from .reactions import grow1, grow2
from .step import (
    MAX_SUBSTEPS,
    advance,
    compact,
    empty_work,
)
from .structs import (
    COUNT,
    EVENTS_PER_DISC,
    F_BI,
    F_COLLISIONS,
    F_OUTLETS,
    F_THERMAL,
    F_UNI,
    FLOAT,
    IC_EVENTS_CAPPED,
    INDEX,
    P_MAXDISP,
    P_RELAX,
    P_RESTITUTION,
    P_RMAX,
    P_RMIN,
    Bounds,
    Call,
    Counters,
    Discs,
    Physics,
    Tables,
    fields,
)

# (the entry points and the constants the rest of discgym, the tests and benchmarks read)
__all__ = ["CELLS_PER_DISC", "EVENTS_PER_DISC", "EV_CELL", "EV_REACT", "EV_WALL", "FIT_MARGIN",
           "FO_EXACT", "N_STATS", "ST_CELLS", "ST_CROSSINGS", "ST_EVENTS", "ST_PREDICTIONS",
           "ST_RESTARTS", "ST_STALE", "EventCounters", "finish_capped", "finish_capped_rngs",
           "run_exact", "run_steps", "run_steps_rngs"]

INF = math.inf

FIT_MARGIN = 1e-3  # the free gap a species needs in its bounds, in radii (Simulation refuses
# less): a disc with gap g meets the walls |v| / g times per unit time
FO_EXACT = 16  # first-order events of one disc per step at exact times (event_handlers)
TC_FRACTION = 1e-3  # t_c of the TC model, in units of r_min / v_rms (e < 1 only)
CELLS_PER_DISC = 4.0  # grid cells per disc, when that makes cells larger than a diameter


@njit(cache=True, inline="always")
def _grow_fill(a, cap, fill):
    out = np.full(cap, fill, dtype=a.dtype)
    for i in range(a.shape[0]):  # (a loop: numba's slice assignment compiles an error)
        out[i] = a[i]
    return out


@kernel
def _grow_range(a, cap):
    out = np.arange(cap).astype(a.dtype)
    for i in range(a.shape[0]):  # (a loop: numba's slice assignment compiles an error)
        out[i] = a[i]
    return out


@kernel
def _grow(cap, state, fl, cells, queue):
    """Every per-disc array at capacity ``cap`` (the contents kept; new slots hold no disc,
    and heap key inf, so the order of the heap, and of the events, does not change)."""
    state = Discs(grow2(state.pos, cap), grow2(state.vel, cap),
                  _grow_fill(state.species, cap, -1), grow1(state.internal_energy, cap),
                  grow1(state.ids, cap), state.next_id)
    fl = Flights(grow2(fl.path, cap), _grow_fill(fl.species, cap, -1),
                 grow1(fl.internal_energy, cap), grow1(fl.stamp, cap),
                 _grow_fill(fl.t_collision, cap, -INF), _grow_fill(fl.t_reaction, cap, INF),
                 grow1(fl.rate, cap), grow1(fl.n_first_order, cap), _grow_range(fl.perm, cap))
    cells = Cells(cells.x0, cells.y0, cells.w, cells.h, cells.iw, cells.ih, cells.ncx,
                  cells.ncy, cells.head, _grow_fill(cells.nxt, cap, -1),
                  _grow_fill(cells.prv, cap, -1), _grow_fill(cells.cell, cap, -1))
    heap = queue.heap
    queue = Queue(grow2(queue.event, cap),
                  IndexedHeap(_grow_fill(heap.key, cap, INF), _grow_range(heap.disc, cap),
                              _grow_range(heap.slot, cap)))
    return state, fl, cells, queue


@kernel
def _run_constants(n, n_steps, step_dt, vel, species, tables, params, flags, bounds):
    """What a run of ``n_steps`` of ``step_dt`` fixes from the scene and the state at its
    start: the substep the time-stepped integrator would take (no disc moves more than
    max_displacement smallest radii), which is the shortest wait of a refused reaction and
    the unit of the event bound, and the TC model's t_c (inelastic scenes only)."""
    sp_mass = tables.sp_mass
    bounds_params = bounds.params
    e_rest = params[P_RESTITUTION]
    v2max = 0.0
    for d in range(n):
        if species[d] >= 0:
            v2max = max(v2max, vel[d, 0] * vel[d, 0] + vel[d, 1] * vel[d, 1])
    ksub = 1
    q = math.sqrt(v2max) * step_dt / (params[P_MAXDISP] * params[P_RMIN])
    if not q <= MAX_SUBSTEPS:
        ksub = MAX_SUBSTEPS
    elif q > 1.0:
        ksub = int(math.ceil(q))
    tc = 0.0
    if e_rest < 1.0:
        mv2 = 0.0
        msum = 0.0
        for d in range(n):
            if species[d] >= 0:
                m = sp_mass[species[d]]
                mv2 += m * (vel[d, 0] * vel[d, 0] + vel[d, 1] * vel[d, 1])
                msum += m
        if mv2 > 0.0:
            tc = TC_FRACTION * params[P_RMIN] / math.sqrt(mv2 / msum)
    return Run(n_steps * step_dt, n_steps * ksub * (EVENTS_PER_DISC * n + 1024),
               step_dt / ksub, n_steps * FO_EXACT, tc, e_rest, params[P_RELAX], params[P_RMAX],
               flags[F_COLLISIONS] != 0, flags[F_UNI] != 0, flags[F_BI] != 0, bounds.kind,
               bounds.params, bounds_params[0], bounds_params[1], bounds_params[2],
               bounds_params[3], flags[F_THERMAL] != 0, bounds.walls, flags[F_OUTLETS] != 0)


@kernel
def _load(n, cap, state, cells, tables):
    """The discs in the integrator's numbering: live ones in cell order (dead ones last),
    so that neighbours are near in memory; each at time 0 and in its cell."""
    perm = np.arange(cap).astype(INDEX)  # perm[a] = the caller's index of disc a
    fl = Flights(np.zeros((cap, PATH_COLUMNS), dtype=FLOAT), np.full(cap, -1, dtype=INDEX),
                 np.zeros(cap, dtype=FLOAT), np.zeros(cap, dtype=COUNT),
                 np.full(cap, -INF, dtype=FLOAT), np.full(cap, INF, dtype=FLOAT),
                 np.zeros(cap, dtype=FLOAT), np.zeros(cap, dtype=COUNT), perm)
    _fill(n, state, cells, tables, fl, np.zeros(cells.ncx * cells.ncy + 2, dtype=INDEX))
    return fl


@kernel(_nrt=False)
def _fill(n, state, cells, tables, fl, cstart):
    """:func:`_load`'s loops (``cstart`` zeros, one more than the cells and the dead), without
    reference counting (see :func:`_event_loop`)."""
    pos, vel, spc_ext = state.pos, state.vel, state.species
    ncells = cells.ncx * cells.ncy
    cell, perm, W = cells.cell, fl.perm, fl.path
    for e in range(n):
        c = cell_of(pos[e, 0], pos[e, 1], cells) if spc_ext[e] >= 0 else ncells
        cell[e] = c  # scratch: reset below
        cstart[c + 1] += 1
    for c in range(ncells + 1):
        cstart[c + 1] += cstart[c]
    for e in range(n):
        c = cell[e]
        perm[cstart[c]] = e
        cstart[c] += 1
    for d in range(n):
        e = perm[d]
        cell[d] = -1
        s = spc_ext[e]
        fl.species[d] = s
        fl.internal_energy[d] = state.internal_energy[e]
        if s < 0:
            continue
        W[d, PX] = pos[e, 0]
        W[d, PY] = pos[e, 1]
        W[d, PVX] = vel[e, 0]
        W[d, PVY] = vel[e, 1]
        W[d, PT] = 0.0
        set_kind(d, s, W, tables)
        cell_insert(d, cell_of(pos[e, 0], pos[e, 1], cells), cells)


@kernel
def _first_predictions(n, fl, cells, queue, run, tables, rng, stats):
    """Every disc's reaction time (drawn in the caller's order, independent of the grid) and
    first event."""
    if run.has_uni:
        inv = np.empty(n, dtype=INDEX)
        for d in range(n):
            inv[fl.perm[d]] = d
        for e in range(n):
            d = inv[e]
            if fl.species[d] >= 0:
                next_reaction(d, 0.0, fl, tables, rng, True, 0.0)
    _predict_all(n, fl, cells, queue, run)
    stats[ST_PREDICTIONS] += n


@kernel(_nrt=False)
def _predict_all(n, fl, cells, queue, run):
    """Every disc's first event (without reference counting: see :func:`_event_loop`)."""
    full = np.int64(0)  # (not the literal 0: numba would compile predict for it too)
    for d in range(n):
        if fl.species[d] >= 0:
            predict(d, 0.0, fl, cells, queue, run, full)


@kernel(_nrt=False)
def _event_loop(n, events, state, fl, cells, queue, run, tables, rng, counters):
    """Process events in time order until the end of the run, its event bound, or a
    first-order reaction that may split a disc while the arrays are full (checked before
    anything of that event is done). Returns ``(t, n, events, grow)``: the time reached (the
    first event not processed, at the bound or the growth), the discs, the events processed
    so far in the run, and whether the arrays must grow before the loop goes on.

    Compiled without numba's reference counting (``_nrt=False``): every array here is
    borrowed from the caller, which keeps it alive, nothing is allocated and none is
    returned. With it, the handlers inlined here took and dropped a reference to each array
    of the structs they are given (some 40 atomic updates per event, most of the time of
    an event at 10^4 discs; numba's pruning of such pairs gives up on a loop this size).
    The arithmetic is the same either way."""
    stats = counters.stats
    cap = fl.path.shape[0]
    t = 0.0
    while True:
        d = queue.heap.disc[0]
        t = queue.heap.key[0]
        if not t <= run.t1:
            t = run.t1
            break
        if events >= run.budget:  # (t: the event not processed)
            break
        code = int(queue.event[d, NEXT_CODE])
        # a fission needs a free slot: the caller makes one before anything is drawn
        if code == EV_REACT and n >= cap and may_split(fl.species[d], tables):
            return t, n, events, True
        events += 1
        stats[ST_EVENTS] += 1
        fly_to(d, t, fl.path)
        p0 = d  # the discs to predict afresh after this event (-1: none)
        p1 = -1
        entered = 0
        if code >= 0 and fl.stamp[code] != int(queue.event[d, NEXT_STAMP]):
            stats[ST_STALE] += 1  # stale: predict again
        elif code >= 0:
            p1 = collision(d, code, t, fl, cells, queue, run, tables, rng, counters)
        elif code == EV_CELL:
            entered = crossing(d, cells, queue, stats)
        elif code == EV_WALL:
            if not wall_event(d, fl, cells, queue, run, tables, counters, rng):
                p0 = -1
        elif code == EV_REACT:
            newd = first_order_event(d, n, t, fl, cells, state, run, tables, rng, counters)
            if newd >= 0:
                n += 1
                p1 = newd
        else:  # a disc with no event at all cannot be at the top below inf
            p0 = -1
            heap_set(queue.heap, d, INF)
        for q in range(2):  # the one place predictions are made in the loop (inlined)
            pd = p0 if q == 0 else p1
            if pd >= 0:
                predict(pd, t, fl, cells, queue, run, entered if q == 0 else 0)
                stats[ST_PREDICTIONS] += 1
    return t, n, events, False


@kernel
def _events(n, state, fl, cells, queue, run, tables, rng, counters):
    """Process events in time order until the end of the run or its event bound
    (:func:`_event_loop`), growing the arrays when a fission finds them full. Returns
    ``(t, n, state, fl)``: the time reached (the first event not processed, at the bound),
    and the arrays (new ones if a fission found them full)."""
    events = np.int64(0)  # (not the literal 0: numba would compile _event_loop for it too)
    while True:
        t, n, events, grow = _event_loop(n, events, state, fl, cells, queue, run, tables, rng,
                                         counters)
        if not grow:
            return t, n, state, fl
        counters.stats[ST_RESTARTS] += 1
        state, fl, cells, queue = _grow(2 * fl.path.shape[0] + 16, state, fl, cells, queue)


@kernel
def _write_back(n, t, fl, state):
    """Every disc brought to time t, into the caller's arrays (in the caller's numbering)."""
    W = fl.path
    pos, vel = state.pos, state.vel
    for d in range(n):
        e = fl.perm[d]
        state.species[e] = fl.species[d]
        state.internal_energy[e] = fl.internal_energy[d]
        if fl.species[d] >= 0:
            dt = t - W[d, PT]
            pos[e, 0] = W[d, PX] + dt * W[d, PVX]
            pos[e, 1] = W[d, PY] + dt * W[d, PVY]
            vel[e, 0] = W[d, PVX]
            vel[e, 1] = W[d, PVY]
        else:
            vel[e, 0] = 0.0
            vel[e, 1] = 0.0


@kernel(optimise=True)  # (see kernels.jit.kernel: an env's step runs it 10 % faster)
def _simulate(state, n, n_steps, step_dt, bounds, tables, params, flags, rng, counters,
              cells_per_disc):
    """Advance discs [0, n) by ``n_steps`` steps of ``step_dt`` in one run, from time 0 to
    t1 = n_steps step_dt.

    Everything is derived from the state at the start of the run (positions, velocities,
    species, internal energies, the generator): the grid, the TC model's t_c, the retry
    floor, the event bound, and the reaction times, drawn afresh (exact: the exponential is
    memoryless). So the outcome does not depend on the arrays' capacity: a fission that
    finds them full grows them (and the working arrays) in place and carries on.

    Returns ``(state, n, t)``: the state (new arrays if they grew), holding the discs at t;
    t = t1 unless the run reached its event bound (``n_steps k (64 n + 1024)`` events, the
    time-stepped integrator's bound for n_steps steps of k substeps): then t is the time of
    the first event not processed, and the caller finishes the run otherwise.
    Discs consumed by combinations are left with species -1 (the caller compacts).
    Fragments are appended with the same index inside and out.
    """
    if n == 0:
        return state, 0, n_steps * step_dt
    run = _run_constants(n, n_steps, step_dt, state.vel, state.species, tables, params, flags,
                         bounds)
    cap = state.pos.shape[0]
    cells = make_cells(n, cap, run, cells_per_disc)
    counters.stats[ST_CELLS] = cells.ncx * cells.ncy
    fl = _load(n, cap, state, cells, tables)
    queue = Queue(np.zeros((cap, EVENT_COLUMNS), dtype=FLOAT),
                  IndexedHeap(np.full(cap, INF, dtype=FLOAT), np.arange(cap).astype(INDEX),
                              np.arange(cap).astype(INDEX)))
    _first_predictions(n, fl, cells, queue, run, tables, rng, counters.stats)
    t, n, state, fl = _events(n, state, fl, cells, queue, run, tables, rng, counters)
    _write_back(n, t, fl, state)
    return state, n, t


@njit(cache=True, inline="always")
def run_exact(state, n, n_steps, dt, bounds, tables, params, flags, rng, counters,
              cells_per_disc):
    """The exact part of :func:`run_steps`: one event-driven run of ``n_steps`` steps of
    ``dt``, up to its event bound. Returns ``(state, n, rest)``: ``rest`` > 0 the time the
    run did not reach (it reached the bound), which :func:`finish_capped` finishes with the
    time-stepped integrator. Apart, so that an environment or a ``Simulation`` compiles that
    integrator only when a run first needs it (an env of the exact integrator otherwise
    never runs it)."""
    state, n, t = _simulate(state, n, n_steps, dt, bounds, tables, params, flags, rng,
                            counters, cells_per_disc)
    n = compact(n, state.pos, state.vel, state.species, state.internal_energy, state.ids)
    return state, n, n_steps * dt - t


@kernel
def finish_capped(state, n, n_steps, dt, rest, bounds, tables, params, flags, rng, cnt):
    """Finish a run of ``n_steps`` steps of ``dt`` whose exact part stopped ``rest`` before
    its end (:func:`run_exact`) with the time-stepped integrator (steps of ``dt``, the
    remainder in one shorter step), counted in ``events_capped``. ``cnt`` the time-stepped
    integrator's :class:`~discgym.kernels.structs.Counters` (the same arrays as the run's).
    Returns ``(state, n)``."""
    cnt.icnt[IC_EVENTS_CAPPED] += 1
    whole = min(int(rest / dt), n_steps)
    # int64, not literals, for n_steps, threads, step0 and reorder_every: the signature of
    # the batch's call (kernels.batch.reactor_step), so that numba compiles advance once
    zero = np.int64(0)
    one = np.int64(1)
    # (lists None: no pair list, as in a stepped env's step, whose advance this is; a rare
    # rescue, whose broad phase scans each substep)
    physics = Physics(tables, params, flags)
    if whole > 0:
        state, n, _w = advance(state, n, Call(whole, dt, one, zero, zero), bounds, physics,
                               rng, cnt, empty_work(), lists=None)
    if rest - whole * dt > 0.0:
        state, n, _w = advance(state, n, Call(one, rest - whole * dt, one, zero, zero), bounds,
                               physics, rng, cnt, empty_work(), lists=None)
    return state, n


@njit(cache=True, inline="always")
def run_steps(state, n, n_steps, dt, bounds, tables, params, flags, rng, counters,
              cells_per_disc):
    """Advance ``n_steps`` steps of ``dt`` in one exact run (every disc brought to the end).

    ``state`` a :class:`~discgym.kernels.structs.Discs` (capacity C >= n; discs [0, n)),
    ``bounds`` a :class:`~discgym.kernels.structs.Bounds`, ``tables``, ``params``, ``flags``
    the compiled scene, ``counters`` an :class:`~discgym.kernels.event_structs.EventCounters`
    (accumulated in place), ``cells_per_disc`` how many grid cells per disc at most (cells
    are never narrower than the largest diameter; :data:`CELLS_PER_DISC` by default).
    Single-threaded. A run that reaches its event bound (see :func:`_simulate`) is finished
    from the time of the bound by the time-stepped integrator (steps of ``dt``; counted in
    ``events_capped``), whose own bounds hold.

    Returns ``(state, n)``: new (larger) arrays when decompositions needed more capacity,
    else the ones passed in. Discs consumed by combinations are removed (the order of the
    others is kept); fragments are appended, taking the identity ``state.next_id[0]``.

    :func:`run_exact` then :func:`finish_capped` in one compiled call (the ``Simulation``
    and the environments call the two apart).
    """
    state, n, rest = run_exact(state, n, n_steps, dt, bounds, tables, params, flags, rng,
                               counters, cells_per_disc)
    if rest > 0.0:
        state, n = finish_capped(state, n, n_steps, dt, rest, bounds, tables, params, flags,
                                 rng, Counters(counters.icnt, counters.fsum,
                                                   counters.ch_count, counters.outflow))
    return state, n


@njit(cache=True)
def run_steps_rngs(discs, n, n_steps, dt, bounds, tables, params, flags, rngs, cnt):
    """:func:`run_exact` called from Python (the structs as plain tuples of their fields, the
    generator as ``rngs[0]``: see :func:`discgym.kernels.step.advance_rngs`), with the
    counters of the time-stepped integrator (``cnt``: the fields of a
    :class:`~discgym.kernels.structs.Counters`; the statistics are dropped): the entry point
    of :class:`~discgym.Simulation`. Returns ``(discs, n, rest)``; ``rest`` > 0: the run
    reached its event bound, and :func:`finish_capped_rngs` finishes it."""
    icnt, fsum, ch_count, outflow = cnt
    stats = np.zeros(N_STATS, dtype=COUNT)
    d, n, rest = run_exact(Discs(*discs), n, n_steps, dt, Bounds(*bounds), Tables(*tables),
                           params, flags, rngs[0],
                           EventCounters(icnt, fsum, ch_count, stats, outflow), CELLS_PER_DISC)
    return fields(d), n, rest


@njit(cache=True)
def finish_capped_rngs(discs, n, n_steps, dt, rest, bounds, tables, params, flags, rngs, cnt):
    """:func:`finish_capped` called from Python, as :func:`run_steps_rngs`. Returns
    ``(discs, n)``."""
    d, n = finish_capped(Discs(*discs), n, n_steps, dt, rest, Bounds(*bounds),
                         Tables(*tables), params, flags, rngs[0], Counters(*cnt))
    return fields(d), n
