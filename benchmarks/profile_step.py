#!/usr/bin/env python
"""Where the time-stepped integrator's time goes, phase by phase, on the benchmark gas
(elastic discs r = 1, m = 1, kT = 1, packing 0.3, square box, dt = 0.05, one thread).

    python benchmarks/profile_step.py                  # N = 1e3, 1e4, 1e5
    python benchmarks/profile_step.py --sizes 1e6 --reps 3
    python benchmarks/profile_step.py --compare 0,1 --reps 5   # the scan against the list

numba has no profiler inside compiled code, so this runs a copy of the substep loop of
``kernels.step.advance`` for a scene without reactions (the same phase kernels, in the same
order, on a ``Simulation``'s own arrays) with a monotonic clock (``clock_gettime``, called
through ctypes from compiled code, about 40 ns a call) read between the phases. The
trajectory is the one ``Simulation.step`` would compute; the sum of the phases matches the
wall time of the run to within the clock's cost. Prints ns per disc-step for each phase,
median over ``--reps`` runs (each from its own fresh equilibrated simulation). Each run is
one call of at least 100 steps, so its broad phase is advance's pair list (kernels.step,
from PAIR_MIN_STEPS steps per call), built once at the start; ``--skin 0`` profiles the
per-substep scan that shorter calls take, ``--compare`` runs both interleaved. (Above
PAIR_MAX_DISCS discs advance takes the scan; the profile still runs the list unless told
``--skin 0``, to measure what it would cost there.)
"""

from __future__ import annotations

import argparse
import ctypes
import math
import time

import numpy as np
from numba import njit

from discgym import Simulation
from discgym.bench import bench_scene, format_table, n_label
from discgym.kernels import drift as DR
from discgym.kernels import events as EV
from discgym.kernels import pairlist as PL
from discgym.kernels import step as S
from discgym.kernels.celllist import cell_radius, make_grid
from discgym.kernels.heap import new_heap
from discgym.kernels.structs import (
    F_BI,
    F_COLLISIONS,
    F_OUTLETS,
    F_THERMAL,
    P_MAXDISP,
    P_RELAX,
    P_RESTITUTION,
    P_RMIN,
    Bounds,
    Counters,
    Discs,
    Phase,
    RunConsts,
    Substep,
)

PHASES = ("reorder in memory", "substep split", "drift, walls, binning", "cell sort",
          "gather", "broad phase scan", "pair list: stale discs", "pair list: refresh",
          "pair list: pair test", "initial event queue", "events", "repair")
# the counts PROFILED_ADVANCE also returns (per disc-step in profile())
COUNTS = ("substeps", "discs refreshed", "listed pairs")

_clock_gettime = ctypes.CDLL(None).clock_gettime
_clock_gettime.argtypes = [ctypes.c_int, ctypes.c_void_p]
_clock_gettime.restype = ctypes.c_int
CLOCK_MONOTONIC = 1


@njit
def _now(buf):
    _clock_gettime(CLOCK_MONOTONIC, buf.ctypes.data)
    return buf[0] * 1e9 + buf[1]


@njit
def profiled_advance(discs, n, n_steps, dt, bounds, tables, params, flags, rng, cnt, step0,
                     work, T, clk, C, skin_factor=PL.PAIR_SKIN):
    """kernels.step.advance for a scene without reactions (one thread), adding the ns
    spent in each phase of PHASES to T and the COUNTS to C. The broad phase is the one
    advance takes for a call of ``n_steps`` steps (the pair list from PAIR_MIN_STEPS on, its
    skin ``skin_factor`` cell radii: advance's PAIR_SKIN unless a probe asks otherwise; 0:
    the scan, as for a shorter call)."""
    pos, vel, species, internal_energy = discs.pos, discs.vel, discs.species, discs.internal_energy
    ids, idctr = discs.ids, discs.next_id
    bounds_kind, bounds_params = bounds.kind, bounds.params
    icnt = cnt.icnt
    sp_radius = tables.sp_radius
    e = params[P_RESTITUTION]
    maxdisp = params[P_MAXDISP] * params[P_RMIN]
    collide = flags[F_COLLISIONS] != 0
    H = new_heap(256)
    rcell = cell_radius(species, n, sp_radius)
    rc = RunConsts(e, params[P_RELAX], maxdisp, rcell, collide, flags[F_BI] != 0,
                   flags[F_THERMAL] != 0, flags[F_OUTLETS] != 0)
    grid = make_grid(bounds_kind, bounds_params, rcell, max(n, 1))
    ncy = int(grid[5])
    nstart = int(grid[4]) * ncy + 2
    rgrid = make_grid(bounds_kind, bounds_params, sp_radius.max(), S.REORDER_CELLS)
    ws = pos.shape[0]
    work = S._fit_work(work, ws, nstart)
    sc = S._carve(work, ws, nstart)
    listed = collide and n_steps >= S.PAIR_MIN_STEPS and skin_factor > 0.0  # (and any n:
    # advance takes the scan above PAIR_MAX_DISCS, a profile may still ask for the list)
    pl = PL.new_pairlist(ws if listed else 0, PL.PAIR_CAP * ws if listed else 0)
    big = sp_radius.max() > rcell
    skin = skin_factor * rcell
    cut = 2.0 * rcell + skin
    for s in range(n_steps):
        t0 = _now(clk)
        if n >= S.REORDER_MIN and (step0 + s) % S.REORDER_EVERY == 0:
            S._reorder(n, pos, vel, species, internal_energy, ids, rgrid, work)
            if listed:
                PL.pl_permute(n, work[1][n:2 * n], pl, work[1][0:n], work[0])
        t1 = _now(clk)
        T[0] += t1 - t0
        k, capped, vfast = S._first_split(vel, n, dt, maxdisp, icnt)
        t0 = _now(clk)
        T[1] += t0 - t1
        h = dt / k
        for _ in range(k):
            icnt[S.IC_SUBSTEPS] += 1
            t0 = _now(clk)
            sc.nlist[0] = DR.drift_range(0, n, h, Discs(pos, vel, species, internal_energy, ids,
                                                        idctr), sp_radius, bounds, grid, sc,
                                         collide)
            t1 = _now(clk)
            T[2] += t1 - t0
            DR.sort_cells(n, sc.cell_of, sc.cell_start, sc.cell_items)
            t0 = _now(clk)
            T[3] += t0 - t1
            C[0] += 1
            if listed:  # PL.pl_broad, phase by phase
                m = PL.pl_stale(n, pos, species, sp_radius, rcell, 0.5 * skin, big, pl)
                t1 = _now(clk)
                T[6] += t1 - t0
                PL.pl_test(pos, species, sp_radius, PL.mono_radius(sp_radius, rcell), pl)
                t0 = _now(clk)
                T[8] += t0 - t1
                p0 = pl.count[0]
                o0 = pl.count[1]
                while not PL.pl_refresh(m, pos, species, sp_radius, pl, grid, sc.cell_start,
                                        sc.cell_items, cut, cut + 0.5 * skin):
                    pl.count[0] = p0
                    pl.count[1] = o0
                    pl = PL.pl_resize(pl, pl.ref.shape[0], 2 * pl.pi.shape[0])
                nbc = int(grid[4]) * ncy
                DR.gather(sc.cell_start[nbc], sc.cell_start[nbc + 1], sc.cell_items, pos,
                          species, sp_radius, sc.sx, sc.sy, sc.sr)
                C[1] += m
                t1 = _now(clk)
                T[7] += t1 - t0
                t0 = t1
            else:
                DR.gather(0, n, sc.cell_items, pos, species, sp_radius, sc.sx, sc.sy, sc.sr)
                t1 = _now(clk)
                T[4] += t1 - t0
                sc.nlist[1] = DR.scan_rows(0, ncy, grid, sc.cell_start, sc.sx, sc.sy, sc.sr,
                                           sc.ov_n, sc.ov_b, sc.ol)
                t0 = _now(clk)
                T[5] += t0 - t1
            left0 = icnt[S.IC_LEFT_OVERLAPPING]
            ph = Phase(Discs(pos, vel, species, internal_energy, ids, idctr), tables, bounds,
                       grid, sc, rc)
            H, size = EV.queue_initial(n, ph, H, icnt, pl, listed)
            t1 = _now(clk)
            T[9] += t1 - t0
            sub = Substep(icnt[S.IC_SUBSTEPS], h, math.inf, S.EVENTS_PER_DISC * n + 1024)
            _c, _o, H, _e, n_dead, delta, dropped, vfast, vrel, t_cut = EV.run_events(
                H, size, n, ph, cnt, sub, vfast, rng, None)
            t0 = _now(clk)
            T[10] += t0 - t1
            if dropped or icnt[S.IC_LEFT_OVERLAPPING] != left0:
                S._repair(dropped, n, ph, cnt)
            T[11] += _now(clk) - t0
    C[2] += pl.count[0]  # the list's pairs at the end
    return work


def profile(n: int, steps: int, seed: int = 0, equilibrate: float = 5.0,
            skin: float = PL.PAIR_SKIN):
    """ns per disc-step of each phase over ``steps`` steps, and of the whole run."""
    sim = Simulation(bench_scene(n), seed=seed)
    sim.threads = 1
    sim.step(1)
    sim.advance(equilibrate)
    cs = sim._cs
    args = (Discs(sim._pos, sim._vel, sim._species, sim._internal_energy, sim._ids,
                  sim._idctr), sim._n)
    rest = (Bounds(sim._bounds_kind, sim._bounds_params, sim._walls), cs.tables, cs.params,
            cs.flags, sim._rngs[0], Counters(sim._icnt, sim._fsum, sim._ch_count, sim._outflow))
    T = np.zeros(len(PHASES))
    C = np.zeros(len(COUNTS))
    clk = np.zeros(2, dtype=np.int64)
    work = profiled_advance(*args, 1, sim.scene.dt, *rest, 0, S.empty_work(), T, clk, C,
                            skin)  # warm
    T[:] = 0.0
    C[:] = 0.0
    t0 = time.perf_counter()
    profiled_advance(*args, steps, sim.scene.dt, *rest, 1, work, T, clk, C, skin)
    wall = time.perf_counter() - t0
    counts = {"substeps per step": C[0] / steps, "discs refreshed per disc-substep":
              C[1] / (n * C[0]), "listed pairs per disc": C[2] / n}
    return T / (n * steps), wall * 1e9 / (n * steps), counts


def compare(n: int, steps: int, reps: int, skins: list[float], markdown: bool) -> None:
    """Print the phases of runs with each of ``skins`` (0: the scan), interleaved: rep r
    runs every skin in turn from seed r, so load from other processes hits them alike."""
    runs = {s: [] for s in skins}
    for r in range(reps):
        for s in skins:
            T, wall, counts = profile(n, steps, seed=r, skin=s)
            runs[s].append((T, wall, counts))
    name = [("scan" if s <= 0.0 else f"list, skin {s:g}") for s in skins]
    head = [f"N = {n_label(n)}, ns per disc-step"] + name
    body = []
    for p, ph in enumerate(PHASES):
        body.append([ph] + [f"{np.median([x[0][p] for x in runs[s]]):.1f}" for s in skins])
    body.append(["whole run (wall)"] + [f"{np.median([x[1] for x in runs[s]]):.1f}"
                                        for s in skins])
    for s in skins[1:]:
        q = [a[1] / b[1] for a, b in zip(runs[s], runs[skins[0]])]
        body.append([f"whole run / {name[0]}: median [min, max]"] + [""] * skins.index(s)
                    + [f"{np.median(q):.3f} [{min(q):.3f}, {max(q):.3f}]"]
                    + [""] * (len(skins) - 1 - skins.index(s)))
    for key in runs[skins[0]][0][2]:
        body.append([key] + [f"{np.median([x[2][key] for x in runs[s]]):.3f}" for s in skins])
    print(format_table(head, body, markdown))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="profile_step.py", description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="1e3,1e4,1e5", help="numbers of discs, comma-separated")
    ap.add_argument("--disc-steps", type=float, default=3e6,
                    help="disc-steps per run (steps = this / N, at least 100: one call,"
                    " so the pair list's build at its start is spread thin)")
    ap.add_argument("--reps", type=int, default=3, help="runs per N (median reported)")
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    ap.add_argument("--skin", type=float, default=PL.PAIR_SKIN,
                    help="the pair list's skin in cell radii (default: the integrator's; 0: the "
                    "per-substep scan that shorter calls take)")
    ap.add_argument("--compare", default=None, metavar="SKINS",
                    help="comma-separated skins (0: the scan) run interleaved, rep by rep, on "
                    "the same states: a table per N, and the whole run's ratio to the first")
    args = ap.parse_args(argv)
    sizes = [int(float(x)) for x in args.sizes.split(",") if x.strip()]
    if args.compare:
        for n in sizes:
            compare(n, max(100, int(args.disc_steps / n)), args.reps,
                    [float(x) for x in args.compare.split(",")], args.markdown)
        return 0
    cols = {}
    for n in sizes:
        runs = [profile(n, max(100, int(args.disc_steps / n)), seed=r, skin=args.skin)
                for r in range(args.reps)]
        cols[n] = (np.median([r[0] for r in runs], axis=0), float(np.median([r[1] for r in runs])),
                   {k: float(np.median([r[2][k] for r in runs])) for k in runs[0][2]})
    head = ["phase"] + [f"N = {n_label(n)}: ns" for n in sizes] + [f"{n_label(n)} %" for n in sizes]
    body = []
    for p, name in enumerate(PHASES):
        body.append([name] + [f"{cols[n][0][p]:.1f}" for n in sizes]
                    + [f"{100 * cols[n][0][p] / cols[n][0].sum():.0f}%" for n in sizes])
    body.append(["sum of the phases"] + [f"{cols[n][0].sum():.1f}" for n in sizes]
                + ["100%" for _ in sizes])
    body.append(["whole run (wall)"] + [f"{cols[n][1]:.1f}" for n in sizes] + ["" for _ in sizes])
    for key in cols[sizes[0]][2]:
        body.append([key] + [f"{cols[n][2][key]:.3f}" for n in sizes] + ["" for _ in sizes])
    print(format_table(head, body, args.markdown))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
