"""Many reactors in one compiled call: the environment's whole step (controls, physics,
observation), and the per-species sums it observes.

A batch of R reactors of the same scene is a struct of padded arrays: ``pos`` (R, C, 2),
``vel`` (R, C, 2), ``spc`` (R, C) (-1 past the live discs), ``uint`` (R, C), ``ids`` (R, C)
disc identities, with ``n`` (R,) live discs each. :func:`env_step` applies one action to
every active reactor and advances it, one reactor after the other; :func:`env_step_parallel`
does the same in a ``prange`` over reactors (numba's threads). Both run the same
:func:`reactor_step` for each reactor, and each reactor draws from its own
``np.random.Generator`` (a ``numba.typed.List`` of them: a tuple would compile once per batch
size, and numba refuses tuples of more than 100 items in a parallel region), so a reactor of
a batch follows bit for bit the trajectory of a lone environment (``R = 1``) with the same
state, generator and actions. The physics of a step is
:func:`discgym.kernels.step.run_tracked`, the kernel :meth:`Simulation.step
<discgym.Simulation.step>` calls, single-threaded for each reactor.

One call per environment step: the environment's Python only checks the action's shape,
books the ``Simulation``'s clocks and builds ``info`` (measured on the default env,
2026-12-01, ``benchmarks/bench_env.py``: the Python layer of a step went from 18-23% with one
compiled call per control to 6-8%).

The capacity C must never be too small: ``run_tracked`` returns new, larger arrays when a
fission finds ``C < 2 n``, and those could not be written back into the batch; an injection
could not fit either. :func:`reactor_step` reports such a reactor in its status
(:data:`GREW`, :data:`FULL`) instead and the caller raises. Give each reactor
``C >= 2 * max_discs + 16`` (``max_discs``: the most discs a reactor can ever hold) and it
never happens.

Physics-free glue: this module imports numpy and numba only.
"""

import math

import numpy as np
from numba import njit, prange

from .._dtypes import INDEX
from .controls import energies, kinetic_and_fastest, scale
from .placement import place, relocate
from .step import empty_work, run_tracked
from .walls import inside

#: status of a reactor whose state arrays had to grow in a step (capacity too small).
GREW = 1
#: status of a reactor whose injection did not fit in its arrays (capacity too small).
FULL = 2

# Indices into ``cf``, the float constants of the environment (see ReactorConfig.kernel_consts)
(C_HEAT_RATE, C_T_MIN, C_T_MAX, C_SIZE_MIN, C_SIZE_MAX, C_WALL_SPEED, C_SPEED_LIMIT,
 C_REF0, C_REF1, C_REF2, C_REF3, C_TEMPERATURE, C_DT, C_PACKING) = range(14)
# ... and into ``ci``, its integer constants
CI_INJECT_MAX, CI_STEPS, CI_ATTEMPTS, CI_REORDER, CI_PRODUCT, CI_EPISODE = range(6)
# Columns of the outputs: ``fout`` (R, 2 + F) and ``iout`` (R, 3 + 2 F)
O_HEAT, O_ENERGY_HEAT = range(2)  # then the energy each feed species' injection put in (F)
O_STATUS, O_BLOCKED, O_INVALID = range(3)  # then injected (F), then refused (F)


@njit(cache=True)
def env_step(pos, vel, spc, uint, ids, idctr, n, ksteps, bkind, bp, tables, params, flags,
             rngs, icnt, fsum, chc, active, act, size, feed_left, steps, n_init, n_ref, temps,
             kin, stats, obs, cf, ci, feed, feed_budget, low, high, fout, iout):
    """One environment step of every active reactor, one after the other (see
    :func:`reactor_step` for the arguments)."""
    for r in range(pos.shape[0]):
        if active[r]:
            reactor_step(r, pos, vel, spc, uint, ids, idctr, n, ksteps, bkind, bp, tables,
                         params, flags, rngs, icnt, fsum, chc, act, size, feed_left, steps,
                         n_init, n_ref, temps, kin, stats, obs, cf, ci, feed, feed_budget,
                         low, high, fout, iout)


@njit(cache=True, parallel=True)
def env_step_parallel(pos, vel, spc, uint, ids, idctr, n, ksteps, bkind, bp, tables, params,
                      flags, rngs, icnt, fsum, chc, active, act, size, feed_left, steps, n_init,
                      n_ref, temps, kin, stats, obs, cf, ci, feed, feed_budget, low, high, fout,
                      iout, order, starts):
    """:func:`env_step` in parallel: a ``prange`` over T work lists, list t being the
    reactors ``order[starts[t]:starts[t + 1]]`` (see :func:`balance`; T = the number of
    threads gives each thread one list). Each reactor touches only its own rows, so there
    are no races, and the result is the same bits whatever the lists."""
    for t in prange(starts.shape[0] - 1):
        for q in range(starts[t], starts[t + 1]):
            r = order[q]
            if active[r]:
                reactor_step(r, pos, vel, spc, uint, ids, idctr, n, ksteps, bkind, bp,
                             tables, params, flags, rngs, icnt, fsum, chc, act, size,
                             feed_left, steps, n_init, n_ref, temps, kin, stats, obs, cf, ci,
                             feed, feed_budget, low, high, fout, iout)


@njit(cache=True)
def balance(cost, active, T, order, starts):
    """Split the active reactors into T work lists of consecutive reactors and about equal
    total ``cost`` (R,): list t ends where the running total of the costs first comes
    nearest to t / T of the whole (each list is then within the largest single cost of the
    even share). Writes ``order`` (R,) (the active reactors, in order) and ``starts``
    (T + 1,).

    Why: the reactors of a batch cost very different amounts (a hot, dense reactor has many
    more collisions and substeps than a cold, wide one; up to 4x within one step with random
    actions), so ``prange``'s blocks of equally many reactors can leave a thread idle. Why
    consecutive: neighbouring reactors share cache lines (their rows of the counters, their
    generators' states), and lists that interleave them (measured, with the longest-first
    rule) made two threads fight over those lines: 1.3x instead of 1.6-1.9x on 2 threads."""
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


@njit(cache=True)
def reactor_step(r, pos, vel, spc, uint, ids, idctr, n, ksteps, bkind, bp, tables, params,
                 flags, rngs, icnt, fsum, chc, act, size, feed_left, steps, n_init, n_ref,
                 temps, kin, stats, obs, cf, ci, feed, feed_budget, low, high, fout, iout):
    """Apply the action ``act[r]`` to reactor r (heat, then the wall, then injection), advance
    it ``ci[CI_STEPS]`` steps of ``cf[C_DT]``, count the episode step and observe it.

    State of the batch (rows r): ``pos``, ``vel`` (R, C, 2), ``spc``, ``uint``, ``ids``
    (R, C), ``idctr`` (R, 1), ``n``, ``ksteps`` (R,) live discs and kernel steps taken,
    ``bkind`` (R,), ``bp`` (R, 4) bounds, counters ``icnt``, ``fsum``, ``chc`` (R, ...);
    ``tables``, ``params``, ``flags`` the compiled scene; ``rngs`` a typed list of R
    generators. Episode state: ``size`` (R,) the reactor's size (relative to the scene's
    bounds), ``feed_left`` (R, F) int64, ``steps`` (R,) episode steps, ``n_init``, ``n_ref``
    (R,); ``temps``, ``kin`` (R,) kT and kinetic energy of the last observation (read by the
    heat control, then overwritten), ``stats`` (R, 3S+1) and ``obs`` (R, D) float32 (see
    :func:`observe_one`). Actions ``act`` (R, A) float64, as given: a NaN or infinite
    component does nothing (counted in ``iout[r, O_INVALID]``), others are clipped to
    [-1, 1]. Constants: ``cf``, ``ci`` (the ``C_*``, ``CI_*`` indices), ``feed`` (F,) the
    feed species, ``feed_budget`` (F,), ``low``, ``high`` (D,) the observation bounds.

    Outputs (row r overwritten): ``fout[r]`` = (heat energy ``(factor - 1) * kinetic``,
    energy put in by heating, then by each feed species' injection (F): the caller adds them
    to ``Simulation.energy_input`` one by one, as the ``Simulation`` controls do);
    ``iout[r]`` = (status, wall blocked, invalid components, discs injected per feed species
    (F), discs refused per feed species (F)).

    The controls, in the words of the README: heat multiplies every kinetic energy by
    ``heat_rate ** a0`` (kT kept within [t_min, t_max], and heating stops where a disc would
    pass the speed limit);
    the wall moves the size toward ``size_min + (a1 + 1) / 2 (size_max - size_min)`` by at most
    ``wall_speed``, discs left outside moved to free spots inside (if one finds no room, or
    the discs cannot fit, the wall stays: blocked); each feed component a > 0 injects
    ``round(a * inject_max)`` discs (at most the budget left) at free random spots, with
    Maxwell-Boltzmann velocities at the current kT (a full reactor places fewer).
    """
    F = feed.shape[0]
    A = act.shape[1]
    rng = rngs[r]
    sp_radius = tables[0]
    sp_mass = tables[1]
    sp_form = tables[2]
    for k in range(fout.shape[1]):
        fout[r, k] = 0.0
    for k in range(iout.shape[1]):
        iout[r, k] = 0
    # the action: non-finite components do nothing, the rest clipped to [-1, 1]
    a = np.zeros(A)
    bad_wall = False
    for k in range(A):
        x = act[r, k]
        if not math.isfinite(x):
            iout[r, O_INVALID] += 1
            if k == 1:
                bad_wall = True
        else:
            a[k] = min(max(x, -1.0), 1.0)
    m = n[r]
    p = pos[r]
    v = vel[r]
    s = spc[r]

    # heat: kinetic energy x heat_rate ** a0, kT kept inside [t_min, t_max]
    T = temps[r]
    if a[0] != 0.0 and T > 0.0:
        f = cf[C_HEAT_RATE] ** a[0]
        f = min(max(f, min(1.0, cf[C_T_MIN] / T)), max(1.0, cf[C_T_MAX] / T))
        sc = math.sqrt(f)
        ke0 = 0.0
        if f != 1.0:  # (the sums and the scaling of Simulation.scale_temperature)
            ke0, v2max = kinetic_and_fastest(v, s, sp_mass, m)
            vmax = math.sqrt(v2max)
            if sc > 1.0 and vmax * sc > cf[C_SPEED_LIMIT]:  # heat up to the speed limit
                sc = max(cf[C_SPEED_LIMIT] / vmax, 1.0)  # (a disc already past it: no heat)
                f = sc * sc
        if f != 1.0:
            scale(v, m, sc)
            ke1, _ = kinetic_and_fastest(v, s, sp_mass, m)
            fout[r, O_HEAT] = (f - 1.0) * kin[r]
            fout[r, O_ENERGY_HEAT] = ke1 - ke0

    # wall: toward the target size by at most wall_speed
    if not bad_wall:
        lo_s = cf[C_SIZE_MIN]
        hi_s = cf[C_SIZE_MAX]
        target = lo_s + 0.5 * (a[1] + 1.0) * (hi_s - lo_s)
        ws = cf[C_WALL_SPEED]
        new = min(max(size[r] + min(max(target - size[r], -ws), ws), lo_s), hi_s)
        if new != size[r]:
            if _resize(r, new, p, s, m, bkind, bp, sp_radius, params, cf, ci, rng):
                size[r] = new
            else:
                iout[r, O_BLOCKED] = 1

    # injection: round(a * inject_max) discs of each feed species for a > 0, within budget
    cap = p.shape[0]
    for k in range(F):
        x = a[2 + k]
        want = int(np.rint(x * ci[CI_INJECT_MAX])) if x > 0.0 else 0
        if want <= 0:
            continue
        todo = min(want, feed_left[r, k])
        placed = 0
        if todo > 0:
            if m + todo > cap:
                iout[r, O_STATUS] = FULL
                return
            placed = _inject(r, k, feed[k], todo, p, v, s, uint[r], ids[r], idctr[r], m,
                             bkind[r], bp[r], sp_radius, sp_mass, sp_form, cf, ci, rng, fout)
            m += placed
        feed_left[r, k] -= placed
        iout[r, 3 + k] = placed
        iout[r, 3 + F + k] = want - placed
    n[r] = m

    # the physics
    n_steps = ci[CI_STEPS]
    p2, v2_, s2, u2, d2, m2, _w = run_tracked(p, v, s, uint[r], m, n_steps, cf[C_DT], bkind[r],
                                              bp[r], tables, params, flags, rng, icnt[r],
                                              fsum[r], chc[r], 1, ids[r], idctr[r], ksteps[r],
                                              ci[CI_REORDER], empty_work())
    if p2.shape[0] != cap:
        iout[r, O_STATUS] = GREW
        return
    n[r] = m2
    ksteps[r] += n_steps
    steps[r] += 1
    observe_one(r, vel, spc, uint, n, sp_mass, sp_form, ci[CI_PRODUCT], size, steps,
                ci[CI_EPISODE], feed_left, feed_budget, n_init, n_ref, low, high, stats, temps,
                kin, obs)


@njit(cache=True)
def _resize(r, size, pos, spc, n, bkind, bp, sp_radius, params, cf, ci, rng):
    """Bounds of ``size`` x the scene's for reactor r (box: the width scales, origin kept;
    circle: the radius), as :meth:`Simulation.resize <discgym.Simulation.resize>` does it:
    refused (False, nothing changed) when the largest species or the discs' total area
    cannot fit, or a disc left outside finds no free spot (the generator has then been
    drawn from)."""
    nb = np.empty(4)
    if bkind[r] == 0:
        w = cf[C_REF2] * size
        h = cf[C_REF3]
        nb[0] = cf[C_REF0]
        nb[1] = cf[C_REF1]
        nb[2] = cf[C_REF0] + w
        nb[3] = cf[C_REF1] + h
        rfit = 0.5 * min(w, h)
        area = w * h
    else:
        rad = cf[C_REF2] * size
        nb[0] = cf[C_REF0]
        nb[1] = cf[C_REF1]
        nb[2] = rad
        nb[3] = 0.0
        rfit = rad
        area = math.pi * rad * rad
    if params[4] > rfit:  # P_RMAX: the largest species does not fit
        return False
    all_in = True
    for i in range(n):
        if not inside(pos[i, 0], pos[i, 1], sp_radius[spc[i]], bkind[r], nb):
            all_in = False
            break
    if not all_in:
        disc_area = 0.0
        for i in range(n):
            q = sp_radius[spc[i]]
            disc_area += math.pi * q * q
        if disc_area > cf[C_PACKING] * area:
            return False
        if relocate(pos, spc, n, sp_radius, bkind[r], nb, rng, ci[CI_ATTEMPTS]):
            return False
    for k in range(4):
        bp[r, k] = nb[k]
    return True


@njit(cache=True)
def _inject(r, k, sp, todo, pos, vel, spc, uint, ids, idctr, n, bkind, bp, sp_radius, sp_mass,
            sp_form, cf, ci, rng, fout):
    """Place up to ``todo`` discs of species ``sp`` after discs [0, n) (free random spots)
    with Maxwell-Boltzmann velocities at the current kT (the scene's if empty); returns how
    many were placed (all refused if one would pass the speed limit). Books the energy they
    add in ``fout[r, 2 + k]``. The same arithmetic as :meth:`Simulation.inject
    <discgym.Simulation.inject>` (the same energy sums, the same draws): the same bits, but for
    a refused injection, after which the generator has been drawn from (``inject`` puts its
    state back; compiled code cannot)."""
    ke, ui, fo = energies(vel, spc, uint, sp_mass, sp_form, n)
    e0 = ke + ui + fo
    T = ke / n if n > 0 else cf[C_TEMPERATURE]
    kinds = np.full(todo, sp, dtype=INDEX)
    targets = np.full((todo, 2), np.nan)
    placed = place(pos, spc, n, kinds, targets, sp_radius, bkind, bp, rng, ci[CI_ATTEMPTS])
    sd = math.sqrt(T / sp_mass[sp])
    ok = True
    for i in range(n, n + placed):
        vx = rng.standard_normal() * sd
        vy = rng.standard_normal() * sd
        vel[i, 0] = vx
        vel[i, 1] = vy
        if not math.sqrt(vx * vx + vy * vy) <= cf[C_SPEED_LIMIT]:
            ok = False
    if not ok:  # refused, as Simulation.inject refuses it
        for i in range(n, n + placed):
            spc[i] = -1
            vel[i, 0] = 0.0
            vel[i, 1] = 0.0
        return 0
    k0 = idctr[0]
    for i in range(n, n + placed):
        uint[i] = 0.0
        ids[i] = k0 + (i - n)
    idctr[0] = k0 + placed
    ke, ui, fo = energies(vel, spc, uint, sp_mass, sp_form, n + placed)
    fout[r, 2 + k] = ke + ui + fo - e0
    return placed


@njit(cache=True)
def species_stats(vel, spc, uint, n, sp_mass, sp_form, out):
    """Per-species sums of one reactor, in disc order (a fixed summation order, so a lone
    reactor and a reactor in a batch get the same bits).

    ``vel`` (C, 2), ``spc`` (C,), ``uint`` (C,), discs [0, n); ``sp_mass``, ``sp_form`` (S,).
    ``out`` (3 S + 1,) is overwritten: ``[0:S]`` disc counts, ``[S:2S]`` kinetic energy,
    ``[2S:3S]`` internal energy, ``[3S]`` formation energy of all discs.
    """
    S = sp_mass.shape[0]
    out[:] = 0.0
    for i in range(n):
        s = spc[i]
        vx = vel[i, 0]
        vy = vel[i, 1]
        out[s] += 1.0
        out[S + s] += 0.5 * sp_mass[s] * (vx * vx + vy * vy)
        out[2 * S + s] += uint[i]
        out[3 * S] += sp_form[s]


@njit(cache=True)
def observe_batch(vel, spc, uint, n, sp_mass, sp_form, product, size, steps, episode_steps,
                  feed_left, feed_budget, n_init, n_ref, low, high, stats, temperature, kinetic,
                  obs):
    """:func:`observe_one` for every reactor r of the batch."""
    for r in range(vel.shape[0]):
        observe_one(r, vel, spc, uint, n, sp_mass, sp_form, product, size, steps,
                    episode_steps, feed_left, feed_budget, n_init, n_ref, low, high, stats,
                    temperature, kinetic, obs)


@njit(cache=True)
def observe_one(r, vel, spc, uint, n, sp_mass, sp_form, product, size, steps, episode_steps,
                feed_left, feed_budget, n_init, n_ref, low, high, stats, temperature, kinetic,
                obs):
    """Per-species sums (into ``stats[r]`` (3S+1,), see :func:`species_stats`), the kinetic
    energy (into ``kinetic[r]``) and temperature kT (kinetic energy per disc, 0 if empty;
    into ``temperature[r]``), and the observation row ``obs[r]`` (D,) float32 of reactor r,
    clipped to [low, high] (D,).

    The slots (see the README): S species fractions, S kinetic temperatures (mean kinetic
    energy per disc of a species, 0 if absent), S mean internal energies, the total energy
    per disc, discs / ``n_init``, product count / ``n_ref``, ``size``, the fraction of
    ``episode_steps`` left, then ``feed_left / feed_budget`` per feed species (0 if the
    budget is 0). ``vel`` (R, C, 2), ``spc``, ``uint`` (R, C), ``n``, ``size``, ``steps``,
    ``n_init``, ``n_ref`` (R,), ``feed_left`` (R, F), ``feed_budget`` (F,).
    """
    S = sp_mass.shape[0]
    F = feed_budget.shape[0]
    st = stats[r]
    species_stats(vel[r], spc[r], uint[r], n[r], sp_mass, sp_form, st)
    tot = 0.0
    kin = 0.0
    energy = st[3 * S]
    for s in range(S):
        tot += st[s]
        kin += st[S + s]
        energy += st[S + s] + st[2 * S + s]
    nn = max(tot, 1.0)
    kinetic[r] = kin
    temperature[r] = kin / tot if tot > 0.0 else 0.0
    o = obs[r]
    for s in range(S):
        c = max(st[s], 1.0)
        o[s] = _clip(st[s] / nn, low[s], high[s])
        o[S + s] = _clip(st[S + s] / c, low[S + s], high[S + s])
        o[2 * S + s] = _clip(st[2 * S + s] / c, low[2 * S + s], high[2 * S + s])
    k = 3 * S
    o[k] = _clip(energy / nn, low[k], high[k])
    o[k + 1] = _clip(tot / max(n_init[r], 1.0), low[k + 1], high[k + 1])
    o[k + 2] = _clip(st[product] / n_ref[r], low[k + 2], high[k + 2])
    o[k + 3] = _clip(size[r], low[k + 3], high[k + 3])
    left = episode_steps - min(steps[r], episode_steps)
    o[k + 4] = _clip(left / episode_steps, low[k + 4], high[k + 4])
    for f in range(F):
        v = feed_left[r, f] / feed_budget[f] if feed_budget[f] > 0 else 0.0
        o[k + 5 + f] = _clip(v, low[k + 5 + f], high[k + 5 + f])


@njit(cache=True)
def _clip(v, lo, hi):
    return min(max(v, lo), hi)
