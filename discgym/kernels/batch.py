"""Many reactors in one compiled call, and the per-species sums the environment observes.

A batch of R reactors of the same scene is a struct of padded arrays: ``pos`` (R, C, 2),
``vel`` (R, C, 2), ``spc`` (R, C) (-1 past the live discs), ``uint`` (R, C), ``ids`` (R, C)
disc identities, with ``n`` (R,) live discs each. :func:`run_batch` advances every reactor by
the same number of steps with :func:`discgym.kernels.step.run_tracked` (the kernel that
:meth:`Simulation.step <discgym.Simulation.step>` calls), single-threaded for each reactor
(``threads=1``), in a ``prange`` over reactors: the reactors run in parallel on numba's
threads. Each reactor draws from its own ``np.random.Generator``, passed as a
``numba.typed.List`` of generators (a tuple would compile once per batch size, and numba
refuses tuples of more than 100 items in a parallel region), so a reactor follows bit for bit
the trajectory that a lone :class:`~discgym.Simulation` with the same state and generator
follows.

The capacity C must never be too small: ``run_tracked`` returns new, larger arrays when a
fission finds ``C < 2 n``, and those could not be written back into the batch.
:func:`run_batch` reports such a reactor in ``status`` (:data:`GREW`) instead; the caller
raises. Give each reactor ``C >= 2 * max_discs + 16`` (``max_discs``: the most discs a reactor
can ever hold) and it never happens.

Physics-free glue: this module imports numpy and numba only.
"""

import numpy as np
from numba import njit, prange

from .step import run_tracked

#: ``status`` value of a reactor whose state arrays had to grow (capacity too small).
GREW = 1


@njit(cache=True, parallel=True)
def run_batch(pos, vel, spc, uint, ids, idctr, n, steps, n_steps, dt, bkind, bp, tables, params,
              flags, rngs, icnt, fsum, ch_count, reorder_every, active, status):
    """Advance every reactor of the batch by ``n_steps`` steps of ``dt``, in parallel.

    State: ``pos``, ``vel`` (R, C, 2); ``spc`` (R, C) int32; ``uint`` (R, C); ``ids`` (R, C)
    int64 disc identities; ``idctr`` (R, 1) the next identity of each reactor; ``n`` (R,)
    int64 live discs (updated in place); ``steps`` (R,) int64 steps taken by each reactor
    (the memory-reordering clock of ``run_tracked``, updated in place). ``bkind`` (R,) int64
    and ``bp`` (R, 4): the bounds of each reactor. ``tables``, ``params``, ``flags``: the
    (shared) compiled scene. ``rngs``: a ``numba.typed.List`` of R ``np.random.Generator``.
    Counters accumulated in place: ``icnt`` (R, N_ICOUNTERS), ``fsum`` (R, 2), ``ch_count``
    (R, channels). ``reorder_every``: as in ``run_tracked``. ``active`` (R,) bool: the
    reactors to advance (the others are left alone). ``status`` (R,) int64: set to
    :data:`GREW` for a reactor whose capacity was too small (its new state is lost).
    """
    R = pos.shape[0]
    cap = pos.shape[1]
    for r in prange(R):
        i = np.int64(r)
        if not active[i]:
            continue
        p, v, s, u, d, m = run_tracked(pos[i], vel[i], spc[i], uint[i], n[i], n_steps, dt,
                                       bkind[i], bp[i], tables, params, flags, rngs[i], icnt[i],
                                       fsum[i], ch_count[i], 1, ids[i], idctr[i], steps[i],
                                       reorder_every)
        if p.shape[0] != cap:
            status[i] = GREW
        else:
            n[i] = m
            steps[i] += n_steps


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
    """Per-species sums (into ``stats`` (R, 3S+1), see :func:`species_stats`), the kinetic
    energy (into ``kinetic`` (R,)) and temperature kT (kinetic energy per disc, 0 if empty;
    into ``temperature`` (R,)), and the observation rows ``obs`` (R, D) float32 of R
    reactors, clipped to [low, high] (D,).

    The slots (see ``docs/env.md``): S species fractions, S kinetic temperatures (mean
    kinetic energy per disc of a species, 0 if absent), S mean internal energies, the total
    energy per disc, discs / ``n_init``, product count / ``n_ref``, ``size``, the fraction of
    ``episode_steps`` left, then ``feed_left / feed_budget`` per feed species (0 if the
    budget is 0). ``vel`` (R, C, 2), ``spc``, ``uint`` (R, C), ``n``, ``size``, ``steps``,
    ``n_init``, ``n_ref`` (R,), ``feed_left`` (R, F), ``feed_budget`` (F,).
    """
    R = vel.shape[0]
    S = sp_mass.shape[0]
    F = feed_budget.shape[0]
    for r in range(R):
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
def scale_velocities(vel, n, scale):
    """``vel[r, :n[r]] *= scale[r]`` for each reactor with ``scale[r] != 1`` (the operation
    of :meth:`Simulation.scale_temperature <discgym.Simulation.scale_temperature>`, with
    ``scale`` = sqrt(factor), for a batch)."""
    for r in range(vel.shape[0]):
        s = scale[r]
        if s == 1.0:
            continue
        for i in range(n[r]):
            vel[r, i, 0] *= s
            vel[r, i, 1] *= s


@njit(cache=True)
def _clip(v, lo, hi):
    return min(max(v, lo), hi)
