#!/usr/bin/env python
"""discgym against pymunk (Chipmunk2D) on the same scene and time step: particle-steps per
second and their ratio, each one's wall pressure against Henderson's equation of state, and
the overlaps each leaves. Needs pymunk (``pip install 'discgym[bench]'``); without it only
discgym's side is measured and a note says so.

    python benchmarks/bench_peers.py           # the full run quoted in docs/performance.md
    python benchmarks/bench_peers.py --quick   # N = 10^3 only (no figure written)

Prints plain-text tables and writes docs/img/perf_peers.png (unless ``--quick`` or
``--plot DIR``); ``--help`` lists the options, e.g. ``--peers 1e3@0.05,1e4@0.02``. The scene,
the timing and the tables are those of :mod:`discgym.bench`.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import figures
import numba
import numpy as np
from numba import njit

from discgym import Scene, Simulation
from discgym.bench import (
    DT,
    MASS,
    RADIUS,
    Report,
    Runner,
    bench_scene,
    format_table,
    interleave,
    mega,
    n_label,
    time_steps,
    timed_simulation,
)

IMG = Path(__file__).resolve().parents[1] / "docs" / "img"
OVERLAP_TOL = 0.01  #: pairs closer than (1 - OVERLAP_TOL) * contact distance count as overlaps
BULK_MARGIN = 10.0  #: discs this far (in radii) from every wall count for the bulk density

FULL_PEERS = ((1_000, 0.05), (10_000, 0.05), (100_000, 0.05), (1_000, 0.01), (10_000, 0.01))
QUICK_PEERS = ((1_000, 0.05),)


def _log(msg: str) -> None:
    print(msg, flush=True)


def henderson_z(eta: float) -> float:
    """Henderson's equation of state of hard discs: Z = P / (n kT) = (1 + eta^2/8)/(1-eta)^2."""
    return (1.0 + eta * eta / 8.0) / (1.0 - eta) ** 2


# ============================================================================ accuracy probes
@njit(cache=True)
def overlap_stats(pos, r, tol):
    """Overlaps among equal discs of radius ``r`` at ``pos`` (N, 2).

    Returns ``(count, deepest)``: the number of pairs closer than ``(1 - tol) * 2r`` and the
    largest overlap ``(2r - distance) / (2r)`` of any pair (0.0 if none touch).
    """
    n = pos.shape[0]
    if n < 2:
        return 0, 0.0
    d = 2.0 * r
    xmin = pos[:, 0].min()
    ymin = pos[:, 1].min()
    w = max(pos[:, 0].max() - xmin, d)
    h = max(pos[:, 1].max() - ymin, d)
    ncx = max(1, min(int(w / d), 1 << 13))
    ncy = max(1, min(int(h / d), 1 << 13))
    icx = ncx / w
    icy = ncy / h
    start = np.zeros(ncx * ncy + 1, dtype=np.int64)
    cell = np.empty(n, dtype=np.int64)
    items = np.empty(n, dtype=np.int64)
    for i in range(n):
        cx = min(int((pos[i, 0] - xmin) * icx), ncx - 1)
        cy = min(int((pos[i, 1] - ymin) * icy), ncy - 1)
        cell[i] = cx + ncx * cy
        start[cell[i] + 1] += 1
    for c in range(ncx * ncy):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    for i in range(n):
        items[fill[cell[i]]] = i
        fill[cell[i]] += 1
    lim2 = (d * (1.0 - tol)) ** 2
    count = 0
    deepest = 0.0
    for i in range(n):
        cx = cell[i] % ncx
        cy = cell[i] // ncx
        for oy in range(-1, 2):
            for ox in range(-1, 2):
                x = cx + ox
                y = cy + oy
                if x < 0 or y < 0 or x >= ncx or y >= ncy:
                    continue
                c = x + ncx * y
                for a in range(start[c], start[c + 1]):
                    j = items[a]
                    if j <= i:
                        continue
                    dx = pos[j, 0] - pos[i, 0]
                    dy = pos[j, 1] - pos[i, 1]
                    dd = dx * dx + dy * dy
                    if dd < d * d:
                        ov = (d - math.sqrt(dd)) / d
                        if ov > deepest:
                            deepest = ov
                        if dd < lim2:
                            count += 1
    return count, deepest


def bulk_packing(pos: np.ndarray, extent, r: float = RADIUS, margin: float = BULK_MARGIN
                 ) -> float:
    """Packing fraction of the discs whose centres lie at least ``margin * r`` from every
    wall of the box ``extent`` = (x0, y0, x1, y1) (the bulk, away from the wall layers).
    The margin shrinks to a quarter of the box for small boxes."""
    x0, y0, x1, y1 = extent
    m = min(margin * r, 0.25 * (x1 - x0), 0.25 * (y1 - y0))
    inside = ((pos[:, 0] >= x0 + m) & (pos[:, 0] <= x1 - m) &
              (pos[:, 1] >= y0 + m) & (pos[:, 1] <= y1 - m))
    area = (x1 - x0 - 2 * m) * (y1 - y0 - 2 * m)
    return float(inside.sum() * math.pi * r * r / area)


def wall_penetration(pos: np.ndarray, extent, r: float = RADIUS) -> float:
    """Deepest reach of a disc beyond a box wall, as a fraction of r (0 if none)."""
    x0, y0, x1, y1 = extent
    over = np.maximum.reduce([x0 + r - pos[:, 0], pos[:, 0] - (x1 - r),
                              y0 + r - pos[:, 1], pos[:, 1] - (y1 - r)])
    return float(max(over.max(initial=0.0), 0.0) / r)


# ==================================================================================== peers
def _have_pymunk() -> bool:
    try:
        import pymunk  # noqa: F401
    except ImportError:
        return False
    return True


def pymunk_version() -> str | None:
    """pymunk's version and Chipmunk's, or None if pymunk is not installed."""
    try:
        import pymunk
    except ImportError:
        return None
    return f"{pymunk.version} (Chipmunk {pymunk.chipmunk_version.split('-')[0]})"


class _PymunkBox:
    """The benchmark scene in pymunk: circles (elasticity 1, friction 0) in a box of four
    static segments whose inner faces are the box walls; no gravity, no damping; pymunk's
    other settings at their defaults (10 solver iterations, collision slop 0.1). ``index``:
    pymunk's bounding-box tree (its default) or its spatial hash (cell = one diameter). The
    wall pressure is the sum of the impulses pymunk applies on disc-wall contacts
    (``post_solve`` ``total_impulse``)."""

    DISC, WALL = 1, 2

    def __init__(self, pos: np.ndarray, vel: np.ndarray, extent, threads: int = 1,
                 index: str = "tree"):
        import pymunk

        self.extent = extent
        self.index = index
        x0, y0, x1, y1 = extent
        self.space = space = pymunk.Space(threaded=threads > 1)
        if threads > 1:
            space.threads = threads
        if index == "hash":
            space.use_spatial_hash(2.0 * RADIUS, 10 * len(pos))
        elif index != "tree":
            raise ValueError(f"index must be 'tree' or 'hash', got {index!r}")
        space.gravity = (0.0, 0.0)
        moment = pymunk.moment_for_circle(MASS, 0.0, RADIUS)
        self.bodies = []
        objs = []
        for p, v in zip(pos, vel):
            b = pymunk.Body(MASS, moment)
            b.position = (float(p[0]), float(p[1]))
            b.velocity = (float(v[0]), float(v[1]))
            s = pymunk.Circle(b, RADIUS)
            s.elasticity = 1.0
            s.friction = 0.0
            s.collision_type = self.DISC
            self.bodies.append(b)
            objs += [b, s]
        w = 2.0 * RADIUS  # wall half-thickness; inner face on the box edge
        corners = [(x0 - w, y0 - w), (x1 + w, y0 - w), (x1 + w, y1 + w), (x0 - w, y1 + w)]
        for k in range(4):
            s = pymunk.Segment(space.static_body, corners[k], corners[(k + 1) % 4], w)
            s.elasticity = 1.0
            s.friction = 0.0
            s.collision_type = self.WALL
            objs.append(s)
        space.add(*objs)
        self.impulse = 0.0
        self.time = 0.0

        def post_solve(arbiter, space, data):
            self.impulse += arbiter.total_impulse.length

        space.on_collision(self.DISC, self.WALL, post_solve=post_solve)

    def step(self, k: int, dt: float) -> None:
        st = self.space.step
        for _ in range(k):
            st(dt)
        self.time += k * dt

    def positions(self) -> np.ndarray:
        return np.array([tuple(b.position) for b in self.bodies], dtype=np.float64)

    def velocities(self) -> np.ndarray:
        return np.array([tuple(b.velocity) for b in self.bodies], dtype=np.float64)

    def temperature(self) -> float:
        v = self.velocities()
        return float(0.5 * MASS * (v * v).sum() / len(v))


def _accuracy(code, n, dt, extent, blocks, kts, etas, pos_end, t_start, t_end) -> dict:
    """Pressure (from the wall-impulse blocks), its error against Henderson, overlaps."""
    x0, y0, x1, y1 = extent
    perim = 2.0 * ((x1 - x0) + (y1 - y0))
    area = (x1 - x0) * (y1 - y0)
    kt = float(np.mean(kts))
    # merge short blocks (the probe steps) into their neighbours: blocks of about equal length
    durs = [d for _, d in blocks if d > 0]
    merged, acc_i, acc_d = [], 0.0, 0.0
    for imp, d in blocks:
        acc_i += imp
        acc_d += d
        if acc_d >= 0.5 * float(np.median(durs)):
            merged.append((acc_i, acc_d))
            acc_i, acc_d = 0.0, 0.0
    if acc_d > 0 and merged:
        merged[-1] = (merged[-1][0] + acc_i, merged[-1][1] + acc_d)
    zs = np.array([imp / (d * perim) * area / (n * kt) for imp, d in merged])
    dur = sum(d for _, d in blocks)
    z = sum(imp for imp, _ in blocks) / (dur * perim) * area / (n * kt)
    se = float(zs.std(ddof=1) / math.sqrt(len(zs))) if len(zs) > 1 else math.nan
    eta_box = n * math.pi * RADIUS ** 2 / area
    eta_bulk = float(np.mean(etas))
    count, deepest = overlap_stats(np.ascontiguousarray(pos_end), RADIUS, OVERLAP_TOL)
    return {"code": code, "n": n, "dt": dt, "sim_time": dur, "z": z, "z_se": se, "kt": kt,
            "kt_drift": t_end / t_start - 1.0, "eta_box": eta_box, "eta_bulk": eta_bulk,
            "err_box": z / henderson_z(eta_box) - 1.0,
            "err_bulk": z / henderson_z(eta_bulk) - 1.0,
            "overlaps": int(count), "max_overlap": float(deepest),
            "wall_penetration": wall_penetration(pos_end, extent),
            "escaped": int(((pos_end[:, 0] < x0) | (pos_end[:, 0] > x1) | (pos_end[:, 1] < y0)
                            | (pos_end[:, 1] > y1)).sum())}


class _WallPressure:
    """Pressure bookkeeping of one code: ``mark()`` closes a block of (impulse, duration)
    and takes a snapshot (temperature, bulk packing) between timed chunks."""

    def __init__(self, impulse: Callable[[], float], elapsed: Callable[[], float],
                 temperature: Callable[[], float], positions: Callable[[], np.ndarray],
                 extent):
        self.impulse, self.elapsed, self.temperature = impulse, elapsed, temperature
        self.positions, self.extent = positions, extent
        self.blocks, self.kts, self.etas = [], [], []
        self.t0 = temperature()
        self.last = (0.0, 0.0)

    def mark(self) -> None:
        t, p = self.elapsed(), self.impulse()
        if t > self.last[0]:
            self.blocks.append((p - self.last[1], t - self.last[0]))
        self.last = (t, p)
        self.kts.append(self.temperature())
        self.etas.append(bulk_packing(self.positions(), self.extent))

    def result(self, code: str, n: int, dt: float) -> dict:
        self.mark()
        return _accuracy(code, n, dt, self.extent, self.blocks, self.kts, self.etas,
                         self.positions(), self.t0, self.temperature())


def _sim_pressure(sim: Simulation, extent) -> _WallPressure:
    sim.reset_counters()
    t_reset = sim.time
    perim = sim.bounds.perimeter
    return _WallPressure(lambda: sim.pressure() * (sim.time - t_reset) * perim,
                         lambda: sim.time - t_reset, sim.temperature, lambda: sim.positions,
                         extent)


def _exact_run(scene: Scene, pos0, vel0, extent, seconds: float, chunks: int) -> dict | None:
    """The event-driven integrator from (pos0, vel0): pressure, overlaps, throughput in
    disc-steps of ``scene.dt`` per second. None if this discgym has no such integrator."""
    n = len(pos0)
    try:
        ev = Simulation.from_arrays(scene, pos0, vel0, np.zeros(n, dtype=np.int64),
                                    integrator="event")
    except (TypeError, ValueError):
        return None
    ev.step(1)  # warm-up
    wp = _sim_pressure(ev, extent)
    c0 = ev.counters()
    r = Runner("exact", ev.step, n, seconds, between=wp.mark)
    interleave([r], chunks)
    acc = wp.result("discgym event (exact)", n, scene.dt)
    acc.update(rate_one=r.timing.rate, rate_one_best=r.timing.rate_best,
               steps_one=r.timing.total_steps,
               collisions_per_second=(ev.collisions - c0["collisions"]) / r.timing.wall)
    return acc


def peer_run(n: int, dt: float = DT, seconds: float = 1.5, chunks: int = 6,
             pymunk_seconds: float | None = None, pymunk_min_steps: int = 1,
             pymunk_max_steps: int | None = None, equilibrate: float = 10.0,
             seed: int = 0, exact: bool = True, exact_ref: dict | None = None) -> dict:
    """discgym against pymunk at one (N, dt), from the same equilibrated state.

    discgym runs ``equilibrate`` time units from its placement; every code then starts from
    that state. pymunk is built with its bounding-box tree and with its spatial hash (cell =
    one diameter), each timed briefly, and the faster is kept. Then four contenders are timed
    in alternating chunks (:func:`interleave`, ``chunks`` rounds), so that load from other
    processes hits them alike: discgym on one thread and on all threads (``seconds`` each,
    one simulation: its pressure, temperature and overlaps come from both), pymunk on one
    thread (``pymunk_seconds``, default ``seconds``, within [``pymunk_min_steps``,
    ``pymunk_max_steps``] steps; its pressure and overlaps) and pymunk threaded
    (``Space(threaded=True)``, ``threads = nproc``; half as long; throughput only).

    With ``exact``, discgym's event-driven integrator (``integrator="event"``, if this version
    has it) runs from the same state for ``seconds``: the exact reference every pressure is
    also compared with (``exact_ref``: a result of an earlier run at the same N to reuse).
    """
    scene = bench_scene(n, dt=dt)
    sim, placed = timed_simulation(scene, seed)
    all_threads = sim.threads
    sim.step(1)
    sim.advance(equilibrate)
    pos0, vel0 = sim.positions, sim.velocities
    extent = sim.bounds.extent
    out = {"n": n, "dt": dt, "place_s": placed}

    if exact_ref is None and exact:
        exact_ref = _exact_run(scene, pos0, vel0, extent, seconds, chunks)
    out["exact"] = exact_ref
    if exact_ref:
        _log(f"    discgym event-driven (exact): Z = {exact_ref['z']:.4f} +- "
             f"{exact_ref['z_se']:.4f}; {exact_ref['sim_time']:.0f} time units")

    def set_threads(th):
        sim.threads = th

    dgp = _sim_pressure(sim, extent)
    c0, t_reset = sim.counters(), sim.time
    runners = [Runner("discgym one", sim.step, n, seconds, between=dgp.mark,
                      before=lambda: set_threads(1)),
               Runner("discgym all", sim.step, n, seconds, between=dgp.mark,
                      before=lambda: set_threads(all_threads))]

    pm = pmt = pmp = None
    if _have_pymunk():
        pm_seconds = seconds if pymunk_seconds is None else pymunk_seconds
        trial = {}
        for index in ("tree", "hash"):
            t0 = time.perf_counter()
            cand = _PymunkBox(pos0, vel0, extent, index=index)
            out[f"pymunk_build_s_{index}"] = time.perf_counter() - t0
            cand.step(1, dt)  # warm-up
            trial[index] = time_steps(lambda k, c=cand: c.step(k, dt), n,
                                      min(0.1 * pm_seconds, 2.0), chunks=1,
                                      max_steps=pymunk_max_steps).rate
            if pm is None or trial[index] > trial[pm.index]:
                pm = cand
            cand = None
        out["pymunk_index"] = pm.index
        out["pymunk_trial_rates"] = trial
        pm.impulse, pm.time = 0.0, 0.0
        pmp = _WallPressure(lambda: pm.impulse, lambda: pm.time, pm.temperature,
                            pm.positions, extent)
        lo = -(-pymunk_min_steps // chunks)
        hi = None if pymunk_max_steps is None else max(1, pymunk_max_steps // chunks)
        runners.append(Runner("pymunk one", lambda k: pm.step(k, dt), n, pm_seconds,
                              between=pmp.mark, lo=lo, hi=hi))
        threads = os.cpu_count() or 1
        if threads > 1:
            pmt = _PymunkBox(pos0, vel0, extent, threads=threads, index=pm.index)
            pmt.step(1, dt)
            runners.append(Runner("pymunk threaded", lambda k: pmt.step(k, dt), n,
                                  pm_seconds / 2, lo=max(1, lo // 2),
                                  hi=None if hi is None else max(1, hi // 2)))
    interleave(runners, chunks)
    tm = {r.name: r.timing for r in runners}

    c1 = sim.counters()
    acc = dgp.result("discgym", n, dt)
    acc.update(rate_one=tm["discgym one"].rate, rate_all=tm["discgym all"].rate,
               rate_one_best=tm["discgym one"].rate_best,
               rate_all_best=tm["discgym all"].rate_best,
               steps_one=tm["discgym one"].total_steps, steps_all=tm["discgym all"].total_steps,
               threads_all=numba.get_num_threads(),
               collisions_per_disc_step=(c1["collisions"] - c0["collisions"])
               / (n * round((sim.time - t_reset) / dt)))
    out["discgym"] = acc
    _log(f"    discgym: {acc['rate_one'] / 1e6:.2f} M/s (1 thread), "
         f"{acc['rate_all'] / 1e6:.2f} M/s (all); Z = {acc['z']:.4f}; "
         f"{acc['sim_time']:.0f} time units")
    if pm is None:
        out["pymunk"] = None
        return out
    acc = pmp.result("pymunk", n, dt)
    one = tm["pymunk one"]
    thr = tm.get("pymunk threaded", one)
    acc.update(rate_one=one.rate, rate_one_best=one.rate_best, steps_one=one.total_steps,
               rate_all=thr.rate, rate_all_best=thr.rate_best, steps_all=thr.total_steps,
               threads_all=os.cpu_count() if pmt is not None else 1, index=pm.index)
    out["pymunk"] = acc
    out["ratio_one"] = out["discgym"]["rate_one"] / acc["rate_one"]
    out["ratio_all"] = out["discgym"]["rate_all"] / acc["rate_all"]
    _log(f"    pymunk ({pm.index}): {acc['rate_one'] / 1e6:.2f} M/s (1 thread), "
         f"{acc['rate_all'] / 1e6:.2f} M/s (threaded); Z = {acc['z']:.4f}; "
         f"{acc['sim_time']:.0f} time units; ratio {out['ratio_one']:.1f}x")
    return out


def peers(cases: Sequence[tuple[int, float]] = FULL_PEERS, seconds: float = 1.5,
          pymunk_seconds: float | None = None, pymunk_min_steps: int = 40,
          pymunk_max_steps: int | None = 200, cap_from: int = 100_000,
          equilibrate: float = 10.0, seed: int = 0, exact: bool = True) -> list[dict]:
    """:func:`peer_run` for each (N, dt). At N >= ``cap_from`` (where pymunk is slow) its
    timed steps are held between ``pymunk_min_steps`` and ``pymunk_max_steps``. The exact
    (event-driven) reference is run once per N."""
    rows, exact_at = [], {}
    for n, dt in cases:
        _log(f"  N = {n}, dt = {dt}")
        big = n >= cap_from
        row = peer_run(n, dt, seconds, pymunk_seconds=pymunk_seconds,
                       pymunk_min_steps=pymunk_min_steps if big else 1,
                       pymunk_max_steps=pymunk_max_steps if big else None,
                       equilibrate=equilibrate, seed=seed, exact=exact,
                       exact_ref=exact_at.get(n))
        exact_at.setdefault(n, row.get("exact"))
        rows.append(row)
    return rows


def peers_tables(rows, markdown=False) -> str:
    h1 = ["N", "dt", "discgym M/s 1t", "pymunk M/s 1t", "ratio", "discgym M/s all",
          "pymunk M/s thr", "ratio", "pymunk index"]
    b1 = []
    for r in rows:
        d, p = r["discgym"], r.get("pymunk")
        b1.append([n_label(r["n"]), r["dt"], mega(d["rate_one"]), mega(p["rate_one"]) if p else "-",
                   f"{r['ratio_one']:.1f}x" if p else "-", mega(d["rate_all"]),
                   mega(p["rate_all"]) if p else "-", f"{r['ratio_all']:.1f}x" if p else "-",
                   r.get("pymunk_index", "-")])
    h2 = ["N", "dt", "code", "sim time", "Z meas", "+-", "err vs exact",
          "err vs Z_H(eta_bulk)", "err vs Z_H(eta_box)", "kT drift", "overlaps>1%",
          "max overlap", "wall pen."]
    b2 = []
    for r in rows:
        ex = r.get("exact")
        for code in ("exact", "discgym", "pymunk"):
            a = r.get(code)
            if not a:
                continue
            if code == "exact" and any(q is not r and q.get("exact") is ex and q["n"] == r["n"]
                                       for q in rows[:rows.index(r)]):
                continue  # the same reference, already listed
            if ex and code != "exact":
                e = a["z"] / ex["z"] - 1.0
                se = math.hypot(a["z_se"] / a["z"], ex["z_se"] / ex["z"])
                vs_exact = f"{100 * e:+.2f}% +- {100 * se:.2f}%"
            else:
                vs_exact = "-"
            b2.append([n_label(r["n"]), "-" if code == "exact" else r["dt"], a["code"],
                       f"{a['sim_time']:.1f}", f"{a['z']:.4f}", f"{a['z_se']:.4f}", vs_exact,
                       f"{100 * a['err_bulk']:+.2f}%", f"{100 * a['err_box']:+.2f}%",
                       f"{100 * a['kt_drift']:+.3f}%", a["overlaps"], f"{a['max_overlap']:.2e}",
                       f"{a['wall_penetration']:.2e}"])
    sep = "\n\n"
    return (format_table(h1, b1, markdown) + sep + format_table(h2, b2, markdown))


# ===================================================================================== main
def _ints(text: str) -> list[int]:
    return [int(float(x)) for x in text.split(",") if x.strip()]


def _cases(text: str) -> list[tuple[int, float]]:
    out = []
    for item in text.split(","):
        if item.strip():
            n, _, dt = item.partition("@")
            out.append((int(float(n)), float(dt) if dt else DT))
    return out


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="bench_peers.py",
        description="discgym against pymunk on the benchmark scene (discs r = 1, m = 1, "
                    "kT = 1, packing 0.3): throughput, wall pressure against Henderson's "
                    "equation of state, overlaps.")
    p.add_argument("--quick", action="store_true", help="N = 1e3 only, short timings")
    p.add_argument("--peers", type=_cases, default=None, dest="peer_cases",
                   help="N@dt list, e.g. 1e3@0.05,1e4@0.05 (default 1e3, 1e4, 1e5 at 0.05 and "
                        "1e3, 1e4 at 0.01; quick 1e3@0.05)")
    p.add_argument("--peer-seconds", type=float, default=None,
                   help="discgym's timed seconds per thread setting (default 3; quick 0.5)")
    p.add_argument("--pymunk-seconds", type=float, default=None,
                   help="pymunk's timed seconds on one thread (default 10; quick 1)")
    p.add_argument("--pymunk-steps", default=None, metavar="MIN,MAX",
                   help="at N >= 1e5, pymunk's timed steps are held in [MIN, MAX] "
                        "(default 40,200)")
    p.add_argument("--equilibrate", type=float, default=None,
                   help="simulated time run before measuring (default 10; quick 5)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--plot", default=None, metavar="DIR", help="write perf_peers.png into DIR")
    p.add_argument("--markdown", default=None, metavar="FILE",
                   help="also write the tables as Markdown to FILE")
    p.add_argument("--json", default=None, metavar="FILE", help="write all results as JSON")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the comparison, print its tables; returns 0."""
    args = _parser().parse_args(argv)
    q = args.quick
    report = Report(argv, q, pymunk=pymunk_version())
    if args.plot:
        os.makedirs(args.plot, exist_ok=True)
    cases = args.peer_cases or list(QUICK_PEERS if q else FULL_PEERS)
    _log("\n== peers: discgym against pymunk on the same scene and time step")
    if not _have_pymunk():
        _log("NOTE: pymunk is not installed (pip install 'discgym[bench]'); only discgym's "
             "side of the comparison is measured.")
    lo, hi = _ints(args.pymunk_steps) if args.pymunk_steps else (40, 200)
    rows = peers(cases, args.peer_seconds or (0.5 if q else 3.0),
                 pymunk_seconds=args.pymunk_seconds or (1.0 if q else 10.0),
                 pymunk_min_steps=lo, pymunk_max_steps=hi,
                 equilibrate=args.equilibrate or (5.0 if q else 10.0), seed=args.seed)
    report.section("peers", "discgym against pymunk", rows, peers_tables)
    _log("Z from the momentum given to the walls (pymunk: post_solve total_impulse on the "
         "wall segments); Henderson Z_H = (1 + eta^2/8)/(1 - eta)^2 at the bulk packing "
         f"(discs >= {BULK_MARGIN:g} r from the walls) and at N pi r^2 / box area; "
         f"overlaps: pairs closer than {1 - OVERLAP_TOL:g} x 2r at the end; max overlap and "
         "wall penetration as fractions of 2r and r.")
    if args.plot:
        figures.save(figures.plot_peers, rows, os.path.join(args.plot, "perf_peers.png"))
    report.finish(args.markdown, args.json)
    return 0


if __name__ == "__main__":
    args = sys.argv[1:]
    plot = [] if "--quick" in args or "--plot" in args else ["--plot", str(IMG)]
    sys.exit(main([*plot, *args]))
