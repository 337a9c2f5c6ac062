"""Many reactors in one compiled call: the environment's whole step (controls, physics,
observation), and the per-species sums it observes.

A batch of R reactors of the same scene is a :class:`~discgym.kernels.structs.Reactors`
(padded rows, one per reactor) with the environment's per-episode state in an
:class:`~discgym.kernels.structs.Episodes`, its constants in a
:class:`~discgym.kernels.structs.ReactorConsts` and its compiled scene in a :class:`Physics`.
:func:`env_step` applies one action to every active reactor and advances it, one reactor
after the other; :func:`env_step_parallel` does the same in a ``prange`` over reactors
(numba's threads). Both run the same :func:`reactor_step` for each reactor, and each
reactor draws from its own ``np.random.Generator`` (a ``numba.typed.List`` of them: a tuple
would compile once per batch size, and numba refuses tuples of more than 100 items in a
parallel region), so a reactor of a batch follows bit for bit the trajectory of a lone
environment (``R = 1``) with the same state, generator and actions. The physics of a step
is the kernel :meth:`Simulation.step <discgym.Simulation.step>` calls, single-threaded for
each reactor: the time-stepped :func:`discgym.kernels.step.advance` or, with
``consts.integrator`` = ``EVENT``, one exact run of
:func:`discgym.kernels.event_driven.run_steps` over the whole env step (as
``Simulation(..., integrator="event").step(steps_per_action)``); the controls are those of
:mod:`~discgym.kernels.controls`, which the ``Simulation`` methods call. Which integrator is
a compile-time choice, made in Python (:func:`env_step`): a stepped environment never
compiles the event-driven one.

One call per environment step: the environment's Python only checks the action's shape,
books the ``Simulation``'s clocks and builds ``info``.

The capacity C must never be too small: ``advance`` returns new, larger arrays when a
fission finds ``C < 2 n`` (``run_steps`` when it finds no free slot), and those could not be
written back into the batch; an injection could not fit either. :func:`reactor_step` reports
such a reactor in its status (:data:`GREW`, :data:`FULL`) instead and the caller raises.
Give each reactor ``capacity_for_discs(max_discs)`` (:mod:`~discgym.kernels.structs`;
``max_discs``: the most discs a reactor can ever hold) and it never happens.

Physics-free glue: this module imports numpy and numba only.
"""

import math

import numpy as np
from numba import njit, prange

from .controls import RESIZED, heat, inject, resize
from .event_driven import CELLS_PER_DISC, N_STATS, finish_capped, run_exact
from .event_structs import EventCounters
from .jit import kernel
from .step import FS_WALL_HEAT, advance, empty_work, lists_for
from .structs import (
    BOX,
    COUNT,
    EVENT,
    JACKET,
    N_SIDES,
    Bounds,
    Call,
    Counters,
    Discs,
    Episodes,
    Injection,
    Physics,
    ReactorConsts,
    Reactors,
    Tables,
)

#: status of a reactor whose state arrays had to grow in a step (capacity too small).
GREW = 1
#: status of a reactor whose injection did not fit in its arrays (capacity too small).
FULL = 2
#: status of a reactor whose exact run reached its event bound, within a compiled step only:
#: :func:`env_step` finishes its step (:func:`_finish_capped`) before it returns.
CAPPED = 3

# Columns of the outputs: ``fout`` (R, 2 + F) and ``iout`` (R, 3 + 2 F)
O_HEAT, O_ENERGY_HEAT = range(2)  # then the energy each feed species' injection put in (F)
O_STATUS, O_BLOCKED, O_INVALID, O_INJECTED = range(4)  # injected (F), then refused (F)


_INTEGRATOR = ReactorConsts._fields.index("integrator")
_STEPS = ReactorConsts._fields.index("steps_per_action")
_IOUT = Episodes._fields.index("iout")


def env_step(rx, ep, physics, consts, rngs, active, act):
    """One environment step of every active reactor, one after the other (see
    :func:`reactor_step` for the arguments; ``active`` (R,) bool). The structs ``rx``, ``ep``,
    ``physics`` (its tables too) and ``consts`` come as plain tuples of their fields: numba
    types those in C, a NamedTuple field by field in Python (about 0.5 us per field per
    call, some 30 us for these).

    The integrator is chosen here, in Python, as :class:`~discgym.Simulation` chooses its
    entry point: the compiled step is :func:`_env_step` with ``exact=None`` for a stepped
    environment and ``stepped=None`` for an exact one, and numba prunes the integrator given
    None and never compiles it (see :func:`reactor_step`). The time-stepped integrator that
    finishes an exact run which reached its event bound is a call of its own
    (:func:`_finish_capped`, compiled when a run first needs it). So is whether a step may
    keep a pair list (``lists``: ``steps_per_action`` of PAIR_MIN_STEPS or more), and numba
    compiles no pair-list code for an env of fewer steps per action."""
    exact, stepped = _integrators(consts)
    _env_step(rx, ep, physics, consts, rngs, active, act, exact, stepped,
              lists_for(consts[_STEPS]))
    if exact:
        _finish_capped_rows(rx, ep, physics, consts, rngs, active)


def env_step_parallel(rx, ep, physics, consts, rngs, active, act, order, starts):
    """:func:`env_step` in parallel: a ``prange`` over T work lists, list t being the
    reactors ``order[starts[t]:starts[t + 1]]``: the active ones, as :func:`balance` writes
    them (T = the number of threads gives each thread one list). Each reactor touches only
    its own rows, so there are no races, and the result is the same bits whatever the lists.
    The structs come as plain tuples, and the integrator is chosen, as for
    :func:`env_step`."""
    exact, stepped = _integrators(consts)
    _env_step_parallel(rx, ep, physics, consts, rngs, act, order, starts, exact, stepped,
                       lists_for(consts[_STEPS]))
    if exact:
        _finish_capped_rows(rx, ep, physics, consts, rngs, active)


def _integrators(consts) -> tuple:
    """``(exact, stepped)`` of :func:`reactor_step` for ``consts.integrator``: one True, the
    other None (numba prunes a branch on ``x is not None`` only where ``x`` is None)."""
    return (True, None) if consts[_INTEGRATOR] == EVENT else (None, True)


def _finish_capped_rows(rx, ep, physics, consts, rngs, active):
    """Finish the step of every active reactor whose exact run reached its event bound (one
    after the other; each has its own rows and generator, so the order changes nothing)."""
    capped = active & (ep[_IOUT][:, O_STATUS] == CAPPED)
    if capped.any():
        _finish_capped(rx, ep, physics, consts, rngs, capped)


@njit(cache=True)
def _finish_capped(rx, ep, physics, consts, rngs, capped):
    """The rest of the step of each reactor r with ``capped[r]``, which :func:`reactor_step`
    left at its exact run's event bound (``ep.pending[r]``: the time left, the thermal walls'
    heat before the step): the time-stepped integrator to the end of the step
    (:func:`~discgym.kernels.event_driven.finish_capped`, as ``run_steps`` would in one call),
    then what follows the physics (:func:`_book`)."""
    rx, ep, physics, consts = _structs(rx, ep, physics, consts)
    for r in range(capped.shape[0]):
        if capped[r]:
            discs, own, bounds = _views(r, rx, ep, physics.tables)
            ep.iout[r, O_STATUS] = 0
            after, m = finish_capped(discs, rx.n[r], consts.steps_per_action, consts.dt,
                                     ep.pending[r, 0], bounds, own, physics.params,
                                     physics.flags, rngs[r],
                                     Counters(rx.icnt[r], rx.fsum[r], rx.ch_count[r],
                                              rx.outflow[r]))
            _book(r, after.pos.shape[0] != discs.pos.shape[0], m, rx, ep, own.sp_mass, consts,
                  ep.pending[r, 1])


@njit(cache=True)
def _env_step(rx, ep, physics, consts, rngs, active, act, exact, stepped, lists):
    rx, ep, physics, consts = _structs(rx, ep, physics, consts)
    for r in range(rx.pos.shape[0]):
        if active[r]:
            reactor_step(r, rx, ep, physics, consts, rngs, act, exact, stepped, lists)


@njit(cache=True)
def _env_step_parallel(rx, ep, physics, consts, rngs, act, order, starts, exact, stepped,
                       lists):
    rx, ep, physics, consts = _structs(rx, ep, physics, consts)
    _in_parallel(rx, ep, physics, consts, rngs, act, order, starts, exact, stepped, lists)


@kernel(parallel=True)
def _in_parallel(rx, ep, physics, consts, rngs, act, order, starts, exact, stepped, lists):
    # (apart from _env_step_parallel: numba's parfor lowering fails on the unpacked structs.
    # It passes a struct into the loop body field by field, arrays and scalars only, and
    # needs the struct's class from the call that made it or from an argument: so the
    # tables go in as a struct rebuilt here, and physics is made inside the loop)
    tables = Tables(*physics.tables)
    params = physics.params
    flags = physics.flags
    for t in prange(starts.shape[0] - 1):
        for q in range(starts[t], starts[t + 1]):
            reactor_step(order[q], rx, ep, Physics(tables, params, flags), consts, rngs, act,
                         exact, stepped, lists)


@njit(cache=True, inline="always")
def _structs(rx, ep, physics, consts):
    return (Reactors(*rx), Episodes(*ep), Physics(Tables(*physics[0]), physics[1], physics[2]),
            ReactorConsts(*consts))


@njit(cache=True, inline="always")
def _views(r, rx, ep, tables):
    """Reactor r's :class:`~discgym.kernels.structs.Discs`, its
    :class:`~discgym.kernels.structs.Tables` (its kinetics: the scene's, or those drawn for
    its episode; the same values give the same bits, the shared tables being these rows'
    copies) and its :class:`~discgym.kernels.structs.Bounds`: views of its rows."""
    discs = Discs(rx.pos[r], rx.vel[r], rx.species[r], rx.internal_energy[r], rx.ids[r],
                  rx.next_id[r])
    own = Tables(tables.sp_radius, tables.sp_mass, ep.sp_form[r], tables.ch_kind,
                 tables.ch_reac, tables.ch_prod, ep.ch_rate[r], ep.ch_energy[r],
                 tables.uni_start, tables.uni_chan, tables.bi_table, tables.outlets)
    return discs, own, Bounds(rx.bounds_kind[r], rx.bounds_params[r], rx.bounds_walls[r])


@njit(cache=True)
def balance(cost, active, T, order, starts):
    """Split the active reactors into T work lists of consecutive reactors and about equal
    total ``cost`` (R,): list t ends where the running total of the costs first comes
    nearest to t / T of the whole (each list is then within the largest single cost of the
    even share). Writes ``order`` (R,) (the active reactors, in order) and ``starts``
    (T + 1,).

    Why: the reactors of a batch cost very different amounts (a hot, dense reactor has many
    more collisions and substeps than a cold, wide one), so ``prange``'s blocks of equally
    many reactors can leave a thread idle. Why consecutive: neighbouring reactors share cache
    lines (their rows of the counters, their generators' states), and lists that interleave
    them make threads fight over those lines."""
    R = cost.shape[0]
    m = 0
    total = 0.0
    for r in range(R):
        if active[r]:
            order[m] = r
            m += 1
            total += cost[r]
    starts[0] = 0
    q = 0
    run = 0.0
    for t in range(1, T):
        goal = total * t / T
        # advance while taking the next reactor brings the running total nearer the goal
        while q < m and abs(run + cost[order[q]] - goal) <= abs(run - goal):
            run += cost[order[q]]
            q += 1
        starts[t] = q
    starts[T] = m


# A kernel, not inlined: the serial loop and the prange body call the one compiled version
# (inlined into the prange body, numba's parfor lowering changed the results)
@kernel
def reactor_step(r, rx, ep, physics, consts, rngs, act, exact, stepped, lists):
    """Apply the action ``act[r]`` to reactor r (heat, then the wall, then injection), advance
    it ``consts.steps_per_action`` steps of ``consts.dt`` (``exact`` not None: one exact
    event-driven run of that time; ``stepped`` not None: the time-stepped integrator), count
    the episode step and observe it. One of the two is None, and numba prunes that
    integrator at compile time (:func:`env_step` passes ``(None, True)`` for
    ``consts.integrator`` = ``STEPPED``, ``(True, None)`` for ``EVENT``). An exact run that
    reaches its event bound leaves the rest of the step to :func:`_finish_capped` (status
    :data:`CAPPED`, ``ep.pending[r]``). ``lists``: the time-stepped integrator's
    (:func:`~discgym.kernels.step.advance`; :func:`env_step` passes
    :func:`~discgym.kernels.step.lists_for` the steps per action: None, no pair-list code
    compiled, below PAIR_MIN_STEPS).

    ``rx`` the batch's :class:`~discgym.kernels.structs.Reactors` (rows r), ``ep`` its
    :class:`~discgym.kernels.structs.Episodes` (``ep.temperature`` and ``ep.kinetic``, those
    of the last observation, are read by the heat control, then overwritten); ``physics``
    a :class:`Physics` (the compiled scene); ``consts`` a
    :class:`~discgym.kernels.structs.ReactorConsts`; ``rngs`` a typed list of R generators.
    Actions ``act`` (R, A) float64, as given: a NaN or infinite component does nothing
    (counted in ``iout[r, O_INVALID]``), others are clipped to [-1, 1].

    Outputs (row r overwritten): ``ep.fout[r]`` = (heat energy ``(factor - 1) * kinetic``,
    energy put in by heating, then by each feed species' injection (F): the caller adds them
    to ``Simulation.energy_input`` one by one, as the ``Simulation`` controls do);
    ``ep.iout[r]`` = (status, wall blocked, invalid components, discs injected per feed
    species (F), discs refused per feed species (F)).

    The controls, in the words of the README: heat multiplies every kinetic energy by
    ``heat_rate ** a0`` (kT kept within [t_min, t_max], and heating stops where a disc would
    pass the speed limit);
    the wall moves the size toward ``size_min + (a1 + 1) / 2 (size_max - size_min)`` by at most
    ``wall_speed``, discs left outside moved to free spots inside (if one finds no room, or
    the discs cannot fit, the wall stays: blocked); each feed component a > 0 injects
    ``round(a * inject_max)`` discs (at most the budget left) at free random spots, with
    Maxwell-Boltzmann velocities at the current kT (a full reactor places fewer).
    """
    fout = ep.fout
    iout = ep.iout
    for k in range(fout.shape[1]):
        fout[r, k] = 0.0
    for k in range(iout.shape[1]):
        iout[r, k] = 0
    discs, tables, bounds = _views(r, rx, ep, physics.tables)
    a, bad_heat, bad_wall = _read_action(r, act, iout)
    if consts.heating == JACKET:
        if not bad_heat:
            _jacket(r, a[0], rx.bounds_walls[r], ep)
    else:
        _heat(r, a[0], discs, rx.n[r], ep, tables.sp_mass, consts)
    if ep.steps[r] == ep.feed_switch[r]:  # the inlet temperature changes (flow tasks)
        ep.feed_kT[r] = ep.feed_kT_next[r]
    if not bad_wall:
        _wall(r, a[1], discs, rx.n[r], bounds, ep, tables.sp_radius, consts, rngs)
    if not _inject_feed(r, a, discs, bounds, rx, ep, tables, consts, rngs):
        return
    # the physics
    cap = discs.pos.shape[0]
    ch_count = rx.ch_count[r]
    ch_last = ep.ch_last[r]
    for k in range(ch_count.shape[0]):
        ch_last[k] = ch_count[k]
    outflow = rx.outflow[r]
    out_last = ep.out_last[r]
    for k in range(outflow.shape[0]):
        out_last[k] = outflow[k]
    fsum = rx.fsum[r]
    wall_heat0 = _wall_heat(fsum)
    if exact is not None:  # one exact run of the step (Simulation.step's call)
        after, m, rest = run_exact(discs, rx.n[r], consts.steps_per_action, consts.dt, bounds,
                                   tables, physics.params, physics.flags, rngs[r],
                                   EventCounters(rx.icnt[r], fsum, ch_count,
                                                 np.zeros(N_STATS, dtype=COUNT), outflow),
                                   CELLS_PER_DISC)
        if rest > 0.0 and after.pos.shape[0] == cap:  # its event bound: _finish_capped
            rx.n[r] = m
            ep.pending[r, 0] = rest
            ep.pending[r, 1] = wall_heat0
            iout[r, O_STATUS] = CAPPED
            return
    if stepped is not None:
        call = Call(consts.steps_per_action, consts.dt, np.int64(1), rx.ksteps[r],
                    consts.reorder_every)
        # (tables: reactor r's kinetics, not the scene's)
        after, m, _w = advance(discs, rx.n[r], call, bounds,
                               Physics(tables, physics.params, physics.flags), rngs[r],
                               Counters(rx.icnt[r], rx.fsum[r], ch_count, rx.outflow[r]),
                               empty_work(), lists=lists)
    _book(r, after.pos.shape[0] != cap, m, rx, ep, tables.sp_mass, consts, wall_heat0)


@kernel
def _book(r, grew, m, rx, ep, sp_mass, consts, wall_heat0):
    """What follows the physics of reactor r's step, ``m`` discs after it: the reactions and
    outflow of the step (``ep.ch_last[r]``, ``ep.out_last[r]``: the counts before it, made
    differences), the jacket's heat (what the thermal walls exchanged since ``wall_heat0``),
    the clocks, the observation. ``grew``: the arrays had to grow (status :data:`GREW`,
    nothing booked)."""
    if grew:
        ep.iout[r, O_STATUS] = GREW
        return
    ch_count = rx.ch_count[r]
    ch_last = ep.ch_last[r]
    for k in range(ch_count.shape[0]):
        ch_last[k] = ch_count[k] - ch_last[k]
    outflow = rx.outflow[r]
    out_last = ep.out_last[r]
    for k in range(outflow.shape[0]):
        out_last[k] = outflow[k] - out_last[k]
    if consts.heating == JACKET:  # the heat is what the thermal walls exchanged
        ep.fout[r, O_HEAT] = _wall_heat(rx.fsum[r]) - wall_heat0
    rx.n[r] = m
    rx.ksteps[r] += consts.steps_per_action
    ep.steps[r] += 1
    observe_one(r, rx, ep, sp_mass, consts)


@kernel
def _read_action(r, act, iout):
    """The action ``act[r]``: non-finite components do nothing (counted in
    ``iout[r, O_INVALID]``), the rest clipped to [-1, 1]. Returns ``(a, bad_heat,
    bad_wall)``: the components (A,) and whether the heat's and the wall's were
    non-finite."""
    A = act.shape[1]
    a = np.zeros(A)
    bad_heat = False
    bad_wall = False
    for k in range(A):
        x = act[r, k]
        if not math.isfinite(x):
            iout[r, O_INVALID] += 1
            if k == 0:
                bad_heat = True
            elif k == 1:
                bad_wall = True
        else:
            a[k] = min(max(x, -1.0), 1.0)
    return a, bad_heat, bad_wall


@kernel
def _jacket(r, a0, walls, ep):
    """Jacket control: every thermal wall (a side whose temperature is not NaN) to
    ``t_min (t_max / t_min) ** ((a0 + 1) / 2)``: log-uniform over [t_min, t_max]."""
    t_min, t_max = ep.t_min[r], ep.t_max[r]
    kT = t_min * (t_max / t_min) ** (0.5 * (a0 + 1.0))
    for k in range(walls.shape[0]):
        if walls[k] == walls[k]:
            walls[k] = kT


@kernel
def _wall_heat(fsum):
    """The energy the thermal walls have put in, all sides."""
    e = 0.0
    for k in range(N_SIDES):
        e += fsum[FS_WALL_HEAT + k]
    return e


@kernel
def _heat(r, a0, discs, n, ep, sp_mass, consts):
    """Heat control: kinetic energy x heat_rate ** a0, kT kept inside [t_min, t_max], and
    no further than the speed limit."""
    T = ep.temperature[r]
    if not (a0 != 0.0 and T > 0.0):
        return
    f = ep.heat_rate[r] ** a0
    f = min(max(f, min(1.0, ep.t_min[r] / T)), max(1.0, ep.t_max[r] / T))
    f, energy, _ = heat(discs.vel, discs.species, sp_mass, n, f, consts.speed_limit,
                          np.bool_(True))
    if f != 1.0:
        ep.fout[r, O_HEAT] = (f - 1.0) * ep.kinetic[r]
        ep.fout[r, O_ENERGY_HEAT] = energy


@kernel
def _wall(r, a1, discs, n, bounds, ep, sp_radius, consts, rngs):
    """Wall control: the size toward its target by at most wall_speed, the box's width (origin
    kept) or the circle's radius ``size`` x the scene's (blocked: the size stays and
    ``iout[r, O_BLOCKED]`` is set). ``bounds``: reactor r's (views of its rows)."""
    size = ep.size
    lo_s = ep.size_min[r]
    hi_s = ep.size_max[r]
    target = lo_s + 0.5 * (a1 + 1.0) * (hi_s - lo_s)
    ws = ep.wall_speed[r]
    new = min(max(size[r] + min(max(target - size[r], -ws), ws), lo_s), hi_s)
    if new == size[r]:
        return
    ref = consts.ref_bounds
    nb = np.empty(4)
    nb[0] = ref[0]
    nb[1] = ref[1]
    if bounds.kind == BOX:
        w = ref[2] * new
        h = ref[3]
        nb[2] = ref[0] + w
        nb[3] = ref[1] + h
        fit_radius = 0.5 * min(w, h)
        area = w * h
    else:
        rad = ref[2] * new
        nb[2] = rad
        nb[3] = 0.0
        fit_radius = rad
        area = math.pi * rad * rad
    done, _ = resize(discs, n, sp_radius, Bounds(bounds.kind, nb, bounds.walls), fit_radius,
                     area, consts.packing, rngs, r, consts.attempts)
    if done == RESIZED:
        for k in range(nb.shape[0]):  # (a loop: numba's slice assignment compiles an error)
            bounds.params[k] = nb[k]
        size[r] = new
    else:
        ep.iout[r, O_BLOCKED] = 1


@kernel
def _inject_feed(r, a, discs, bounds, rx, ep, tables, consts, rngs):
    """Injection control: round(a * inject_max) discs of each feed species for a > 0, within
    the budget left, at the current kT. Returns False when they do not fit the arrays
    (status FULL)."""
    feed = consts.feed
    F = feed.shape[0]
    iout = ep.iout
    feed_left = ep.feed_left
    m = rx.n[r]
    cap = discs.pos.shape[0]
    for k in range(F):
        x = a[2 + k]
        want = int(np.rint(x * ep.inject_max[r])) if x > 0.0 else 0
        if want <= 0:
            continue
        todo = min(want, feed_left[r, k])
        placed = 0
        if todo > 0:
            if m + todo > cap:
                iout[r, O_STATUS] = FULL
                return False
            # (the species as int64, as Simulation.inject gives it: one compiled inject)
            what = Injection(np.int64(feed[k]), np.full((todo, 2), np.nan), ep.feed_kT[r])
            placed, energy, _ = inject(discs, m, what, consts.temperature,
                                       consts.speed_limit, tables, bounds, rngs, r,
                                       consts.attempts)
            ep.fout[r, 2 + k] = energy
            m += placed
        feed_left[r, k] -= placed
        iout[r, 3 + k] = placed
        iout[r, 3 + F + k] = want - placed
    rx.n[r] = m
    return True


@kernel
def species_stats(vel, species, internal_energy, n, sp_mass, sp_form, out):
    """Per-species sums of one reactor, in disc order (a fixed summation order, so a lone
    reactor and a reactor in a batch get the same bits).

    ``vel`` (C, 2), ``species`` (C,), ``internal_energy`` (C,), discs [0, n); ``sp_mass``,
    ``sp_form`` (S,). ``out`` (3 S + 1,) is overwritten: ``[0:S]`` disc counts, ``[S:2S]``
    kinetic energy, ``[2S:3S]`` internal energy, ``[3S]`` formation energy of all discs.
    """
    S = sp_mass.shape[0]
    out[:] = 0.0
    for i in range(n):
        s = species[i]
        vx = vel[i, 0]
        vy = vel[i, 1]
        out[s] += 1.0
        out[S + s] += 0.5 * sp_mass[s] * (vx * vx + vy * vy)
        out[2 * S + s] += internal_energy[i]
        out[3 * S] += sp_form[s]


@njit(cache=True)
def observe_batch(rx, ep, sp_mass, consts):
    """:func:`observe_one` for every reactor r of the batch (``rx``, ``ep`` and ``consts`` as
    plain tuples of their fields, as for :func:`env_step`)."""
    rx = Reactors(*rx)
    ep = Episodes(*ep)
    consts = ReactorConsts(*consts)
    for r in range(rx.vel.shape[0]):
        observe_one(r, rx, ep, sp_mass, consts)


@kernel
def observe_one(r, rx, ep, sp_mass, consts):
    """Per-species sums (into ``ep.stats[r]`` (3S+1,), see :func:`species_stats`), the
    kinetic energy (into ``ep.kinetic[r]``) and temperature kT (kinetic energy per disc, 0 if
    empty; into ``ep.temperature[r]``), and the observation row ``ep.obs[r]`` (D,) float32 of
    reactor r, clipped to [obs_low, obs_high] (D,) of ``consts``. A function of the state
    alone: observing twice gives the same row.

    The slots (see the README and docs/tasks.md): S species fractions, S kinetic temperatures
    (mean kinetic energy per disc of a species, 0 if absent), S mean internal energies, the
    total energy per disc, discs / ``n_init``, product count / ``n_ref``, ``size``, the
    fraction of ``episode_steps`` left, then ``feed_left / feed_budget`` per feed species (0
    if the budget is 0); then the optional blocks, in this order: the kinetic-energy
    histogram (``consts.energy_bins`` B > 0: per species, the share of its discs in each of B
    bins of 1/2 m v^2 with inner edges ``consts.energy_edges``), the spatial histogram
    (``consts.grid`` G > 0: per species the share of its discs in each of G x G cells of the
    bounds' bounding box, row by row from the lower left; then kT of each cell, 0 if empty)
    and the reactions of the last step per channel / ``n_ref`` (``consts.obs_reactions``).
    ``rx`` the batch's :class:`~discgym.kernels.structs.Reactors`, ``ep`` its
    :class:`~discgym.kernels.structs.Episodes` (formation energies: ``ep.sp_form[r]``).
    """
    vel = rx.vel[r]
    species = rx.species[r]
    n = rx.n[r]
    low = consts.obs_low
    high = consts.obs_high
    feed_budget = ep.feed_budget[r]
    episode_steps = ep.episode_steps[r]
    S = sp_mass.shape[0]
    F = feed_budget.shape[0]
    st = ep.stats[r]
    species_stats(vel, species, rx.internal_energy[r], n, sp_mass, ep.sp_form[r], st)
    tot = 0.0
    kin = 0.0
    energy = st[3 * S]
    for s in range(S):
        tot += st[s]
        kin += st[S + s]
        energy += st[S + s] + st[2 * S + s]
    nn = max(tot, 1.0)
    ep.kinetic[r] = kin
    ep.temperature[r] = kin / tot if tot > 0.0 else 0.0
    o = ep.obs[r]
    for s in range(S):
        c = max(st[s], 1.0)
        o[s] = _clip(st[s] / nn, low[s], high[s])
        o[S + s] = _clip(st[S + s] / c, low[S + s], high[S + s])
        o[2 * S + s] = _clip(st[2 * S + s] / c, low[2 * S + s], high[2 * S + s])
    k = 3 * S
    o[k] = _clip(energy / nn, low[k], high[k])
    o[k + 1] = _clip(tot / max(ep.n_init[r], 1.0), low[k + 1], high[k + 1])
    o[k + 2] = _clip(st[consts.product] / ep.n_ref[r], low[k + 2], high[k + 2])
    o[k + 3] = _clip(ep.size[r], low[k + 3], high[k + 3])
    left = episode_steps - min(ep.steps[r], episode_steps)
    o[k + 4] = _clip(left / episode_steps, low[k + 4], high[k + 4])
    for f in range(F):
        v = ep.feed_left[r, f] / feed_budget[f] if feed_budget[f] > 0 else 0.0
        o[k + 5 + f] = _clip(v, low[k + 5 + f], high[k + 5 + f])
    k += 5 + F
    if consts.heating == JACKET:
        o[k] = _clip(_jacket_kT(rx.bounds_walls[r]), low[k], high[k])
        k += 1
    if consts.obs_feed_kT:
        v = ep.feed_kT[r] if ep.feed_kT[r] >= 0.0 else ep.temperature[r]
        o[k] = _clip(v, low[k], high[k])
        k += 1
    if consts.obs_outflow:
        last = ep.out_last[r]
        for s in range(S):
            o[k + s] = _clip(last[s] / ep.n_ref[r], low[k + s], high[k + s])
        k += S
    B = consts.energy_bins
    if B > 0:
        _energy_histogram(o, k, r, rx, sp_mass, st, consts)
        k += S * B
    G = consts.grid
    if G > 0:
        _spatial_histogram(o, k, r, rx, sp_mass, st, consts)
        k += (S + 1) * G * G
    if consts.obs_reactions:
        last = ep.ch_last[r]
        for c in range(last.shape[0]):
            o[k + c] = _clip(last[c] / ep.n_ref[r], low[k + c], high[k + c])


@kernel
def _jacket_kT(walls):
    """The temperature of the thermal walls (the first that is not NaN; 0 if none)."""
    for k in range(walls.shape[0]):
        if walls[k] == walls[k]:
            return walls[k]
    return 0.0


@kernel
def _energy_histogram(o, k, r, rx, sp_mass, st, consts):
    """Slots [k, k + S B) of ``o``: per species s, the share of reactor r's discs whose kinetic
    energy falls in each bin (bin b: edges[b - 1] <= E < edges[b], the first from 0, the last
    open; B and the edges of ``consts``). ``st``: its :func:`species_stats`."""
    vel = rx.vel[r]
    species = rx.species[r]
    edges = consts.energy_edges
    B = consts.energy_bins
    S = sp_mass.shape[0]
    for j in range(k, k + S * B):
        o[j] = 0.0
    for i in range(rx.n[r]):
        s = species[i]
        e = 0.5 * sp_mass[s] * (vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1])
        b = 0
        while b < B - 1 and e >= edges[b]:
            b += 1
        o[k + s * B + b] += 1.0
    _shares(o, k, S, B, st, consts)


@kernel
def _spatial_histogram(o, k, r, rx, sp_mass, st, consts):
    """Slots [k, k + (S + 1) G^2) of ``o``: per species the share of reactor r's discs in each
    cell of a G x G grid over its bounds' bounding box (cell (i, j): column i from the left,
    row j from the bottom, at k + s G^2 + j G + i), then the mean kinetic energy per disc of
    each cell (kT; 0 if empty). ``st``: its :func:`species_stats`."""
    pos = rx.pos[r]
    vel = rx.vel[r]
    species = rx.species[r]
    b = rx.bounds_params[r]
    G = consts.grid
    S = sp_mass.shape[0]
    GG = G * G
    if rx.bounds_kind[r] == BOX:
        x0 = b[0]
        y0 = b[1]
        w = b[2] - x0
        h = b[3] - y0
    else:
        x0 = b[0] - b[2]
        y0 = b[1] - b[2]
        w = 2.0 * b[2]
        h = w
    for j in range(k, k + (S + 1) * GG):
        o[j] = 0.0
    cnt = np.zeros(GG)
    ke = np.zeros(GG)
    for i in range(rx.n[r]):
        s = species[i]
        ci = min(max(int((pos[i, 0] - x0) / w * G), 0), G - 1)
        cj = min(max(int((pos[i, 1] - y0) / h * G), 0), G - 1)
        c = cj * G + ci
        o[k + s * GG + c] += 1.0
        cnt[c] += 1.0
        ke[c] += 0.5 * sp_mass[s] * (vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1])
    _shares(o, k, S, GG, st, consts)
    for c in range(GG):
        j = k + S * GG + c
        o[j] = _clip(ke[c] / cnt[c] if cnt[c] > 0.0 else 0.0, consts.obs_low[j],
                     consts.obs_high[j])


@kernel
def _shares(o, k, S, width, st, consts):
    """Slots [k, k + S width) of ``o``, counts of species s's discs at k + s width + b, made
    shares of its discs (``st[s]``, at least 1) and clipped to the observation's bounds."""
    for s in range(S):
        c = max(st[s], 1.0)
        for b in range(width):
            j = k + s * width + b
            o[j] = _clip(o[j] / c, consts.obs_low[j], consts.obs_high[j])


@kernel
def _clip(v, lo, hi):
    return min(max(v, lo), hi)
