#!/usr/bin/env python
"""What accuracy costs in time: the time-stepped integrator's settings against the exact,
event-driven one (``Simulation(..., integrator="event")``) and against theory.

    python benchmarks/bench_accuracy.py            # the full run quoted in docs/accuracy.md
    python benchmarks/bench_accuracy.py --plot docs/img/accuracy.png   # and its figure
    python benchmarks/bench_accuracy.py --quick    # a smoke run, under a minute (warm cache)

The figure goes to ``out/accuracy.png`` (gitignored) unless ``--plot PATH`` says where: the
tracked one changes only when asked to.

Scenes: hard discs (r = 1, m = 1, kT = 1) in a box at packing fractions 0.1 to 0.6, and one
scene per reaction type (transformation, decomposition, combination, exchange). Every run of a
scene starts from the same equilibrated state. Settings: the exact integrator, and the
time-stepped one with time steps dt such that the mean displacement per step is a given
fraction of the radius (``step/r`` = <|v|> dt / r, <|v|> = sqrt(pi kT / 2m)), with
``max_displacement = 1`` (the loosest substep cap allowed: no disc ever moves more than its
radius in one substep).

Measures, for each scene and setting:

- ``s/t``: wall-clock seconds per unit of simulated time (one thread; the machine's load is
  printed: the numbers are only comparable within one run);
- ``dE/E``: relative drift of the total energy over the run;
- ``missed``: collisions the stepped integrator misses, from pairs of one-step runs (stepped
  and exact) from the same snapshots: 1 - C_step / C_exact (its only error on an elastic gas;
  0 for the exact one by construction);
- ``overlap``: the largest overlap left between two discs at the end of any chunk, relative to
  their contact distance;
- gas: ``Z-Z_H``: the compressibility factor Z = P / (n_b kT) against Henderson's equation of
  state Z_H = (1 + eta^2/8) / (1 - eta)^2, with P the pressure on the walls (the contact
  theorem: it is the bulk pressure) and n_b the density in the interior (farther than 5
  diameters from the walls), eta_b = n_b pi r^2; ``P-P_ex``: against the exact integrator's
  pressure; ``w-w_E``: the collision frequency per disc against Enskog's,
  2 sqrt(pi kT/m) sigma n_b g(sigma), g = (1 - 7 eta/16) / (1 - eta)^2 (Henderson);
- reactions: ``k-k_th``: the measured rate against its analytic expectation: first order,
  k from the scene's probability per unit time (events / integral of N(t) dt); activated
  bimolecular, exp(-E_a/kT) times the Enskog collision rate of the reacting pairs (summed over
  chunks with the measured composition, temperature and interior densities); ``k-k_ex``:
  against the exact integrator's rate.

The ``+-`` columns are one standard error (batch means over chunks; Poisson for counts). The
exact integrator's own errors against theory are the floor of what this box size and run
length can resolve (finite size, statistics, the approximation in the theory).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

import discgym as dg

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out"  # (gitignored)
R = 1.0  # disc radius
M = 1.0  # disc mass
KT = 1.0
VMEAN = math.sqrt(math.pi * KT / (2.0 * M))  # mean speed in 2D
MARGIN = 10.0 * R  # interior: farther than 5 diameters from the walls


# ------------------------------------------------------------------------------ theory
def z_henderson(eta):
    return (1.0 + eta * eta / 8.0) / (1.0 - eta) ** 2


def g_henderson(eta):
    """Contact value of the pair correlation function (Henderson)."""
    return (1.0 - 7.0 * eta / 16.0) / (1.0 - eta) ** 2


def enskog_pair_rate(n_partner, sigma, mu, kT, eta):
    """Collisions per unit time of one disc with partners of density ``n_partner``
    (Enskog: 2 sigma n g(sigma) <|v_rel|>, <|v_rel|> = sqrt(pi kT / (2 mu)) in 2D)."""
    return 2.0 * sigma * n_partner * g_henderson(eta) * math.sqrt(math.pi * kT / (2.0 * mu))


@njit(cache=True)
def max_overlap(pos, rad, x0, y0, cell):
    """Largest (R_i + R_j - d_ij) / (R_i + R_j) over all pairs (0 if none overlap)."""
    n = pos.shape[0]
    ncx = 1
    ncy = 1
    for i in range(n):
        ncx = max(ncx, int((pos[i, 0] - x0) / cell) + 1)
        ncy = max(ncy, int((pos[i, 1] - y0) / cell) + 1)
    head = np.full(ncx * ncy, -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    cx = np.empty(n, np.int64)
    cy = np.empty(n, np.int64)
    for i in range(n):
        cx[i] = max(0, int((pos[i, 0] - x0) / cell))
        cy[i] = max(0, int((pos[i, 1] - y0) / cell))
        c = cx[i] + ncx * cy[i]
        nxt[i] = head[c]
        head[c] = i
    worst = 0.0
    for i in range(n):
        for qy in range(max(cy[i] - 1, 0), min(cy[i] + 2, ncy)):
            for qx in range(max(cx[i] - 1, 0), min(cx[i] + 2, ncx)):
                k = head[qx + ncx * qy]
                while k >= 0:
                    if k > i:
                        s = rad[i] + rad[k]
                        d = math.hypot(pos[k, 0] - pos[i, 0], pos[k, 1] - pos[i, 1])
                        if s - d > worst * s:
                            worst = (s - d) / s
                    k = nxt[k]
    return worst


# ------------------------------------------------------------------------------ scenes
def box_for(n_discs_area, eta):
    L = math.sqrt(n_discs_area / eta)
    return dg.Box(L, L)


def gas_scene(n, eta):
    return dg.Scene(bounds=box_for(n * math.pi * R * R, eta), species=[dg.Species("A", R, M)],
                    counts={"A": n}, temperature=KT, max_displacement=1.0,
                    name=f"gas eta={eta:g}")


K_FIRST = 0.1  # first-order rate per unit time
P_FIRST = -math.expm1(-K_FIRST)  # the scene's probability per unit time
# the built-in scenes' dt = 0.02 at r = 0.5, kT = m = 1 moves a disc 0.05 r per step on average
DEFAULT = 0.05
E_A = 2.0  # activation energy of the bimolecular scenes (in kT)


def transformation_scene(n, eta):
    sp = [dg.Species("A", R, M, formation_energy=1.0), dg.Species("B", R, M)]
    return dg.Scene(bounds=box_for(n * math.pi * R * R, eta), species=sp,
                    reactions=[dg.Transformation("A", "B", probability=P_FIRST)],
                    counts={"A": n}, temperature=KT, max_displacement=1.0,
                    name="transformation A->B")


def decomposition_scene(n, eta):
    sp = [dg.Species("AB", R, 2 * M, formation_energy=1.0), dg.Species("A", R / 2, M),
          dg.Species("B", R / 2, M)]
    return dg.Scene(bounds=box_for(n * math.pi * R * R, eta), species=sp,
                    reactions=[dg.Decomposition("AB", "A", "B", probability=P_FIRST)],
                    counts={"AB": n}, temperature=KT, max_displacement=1.0,
                    name="decomposition AB->A+B")


def combination_scene(n, eta):
    sp = [dg.Species("A", R, M), dg.Species("B", R, M), dg.Species("C", R, 2 * M)]
    return dg.Scene(bounds=box_for(n * math.pi * R * R, eta), species=sp,
                    reactions=[dg.Combination("A", "B", "C", activation_energy=E_A * KT,
                                              reverse_probability=0.0)],
                    counts={"A": n // 2, "B": n - n // 2}, temperature=KT,
                    max_displacement=1.0, name="combination A+B->C")


def exchange_scene(n, eta):
    # every collision may react, and a reaction changes nothing but labels: the reacting
    # fraction is exactly exp(-E_a/kT) of the collisions
    sp = [dg.Species("X", R, M), dg.Species("Y", R, M)]
    rx = [dg.Exchange("X", "X", "Y", "Y", activation_energy=E_A * KT),
          dg.Exchange("Y", "Y", "X", "X", activation_energy=E_A * KT),
          dg.Exchange("X", "Y", "Y", "X", activation_energy=E_A * KT)]
    return dg.Scene(bounds=box_for(n * math.pi * R * R, eta), species=sp, reactions=rx,
                    counts={"X": n // 2, "Y": n - n // 2}, temperature=KT,
                    max_displacement=1.0, name="exchange X+X->Y+Y ...")


# ------------------------------------------------------------------------------ runs
def equilibrated(scene, t_eq, seed):
    """A state of the scene's discs after t_eq of exact dynamics without reactions."""
    inert = scene.replace(reactions=())
    sim = dg.Simulation(inert, seed=seed, integrator="event")
    sim.advance(t_eq)
    return sim.positions, sim.velocities, sim.species, sim.internal_energy


def interior(sim):
    """Per species: number of discs whose centre lies in the interior, and its area."""
    x0, y0, x1, y1 = sim.bounds.extent
    p = sim.positions
    inside = ((p[:, 0] > x0 + MARGIN) & (p[:, 0] < x1 - MARGIN) & (p[:, 1] > y0 + MARGIN)
              & (p[:, 1] < y1 - MARGIN))
    counts = np.bincount(sim.species[inside], minlength=len(sim.scene.species))
    return counts, (x1 - x0 - 2 * MARGIN) * (y1 - y0 - 2 * MARGIN)


def run(scene, state, integrator, dt, chunks, chunk_len):
    """Run from ``state``; per chunk record what the measures need."""
    sc = scene.replace(dt=dt)
    pos, vel, spc, u = state
    sim = dg.Simulation.from_arrays(sc, pos, vel, spc, internal_energy=u, seed=11,
                                    integrator=integrator)
    sim.threads = 1
    e0 = sim.total_energy()
    wall = 0.0
    cpu = 0.0
    rec = []
    x0, y0 = sim.bounds.extent[:2]
    for _ in range(chunks):
        sim.reset_counters()
        c0 = sim.counters()
        r0 = sim.reactions()
        n0 = np.bincount(sim.species, minlength=len(sc.species))
        t = time.perf_counter()
        tc = time.process_time()
        sim.advance(chunk_len)
        cpu += time.process_time() - tc
        wall += time.perf_counter() - t
        c1 = sim.counters()
        r1 = sim.reactions()
        inner, area = interior(sim)
        rec.append({
            "P": sim.pressure(),
            "coll": c1["collisions"] - c0["collisions"],
            "reactive": c1["reactive_collisions"] - c0["reactive_collisions"],
            "fired": {k: r1[k] - r0[k] for k in r1},
            "noroom": c1["reactions_without_room"] - c0["reactions_without_room"],
            "kT": sim.temperature(),
            "n_start": n0,
            "n_end": np.bincount(sim.species, minlength=len(sc.species)),
            "inner": inner,
            "inner_area": area,
            "N": len(sim),
            "overlap": max_overlap(sim.positions, sim.radii, x0, y0,
                                   2.0 * float(sim.radii.max())),
        })
    return {
        "wall_per_t": wall / (chunks * chunk_len),
        "cpu_per_t": cpu / (chunks * chunk_len),
        "h": chunks * chunk_len / max(sim.counters()["substeps"], 1),
        "drift": abs(sim.total_energy() - e0) / abs(e0),
        "chunks": rec,
        "sim": sim,
    }


class Snapshots:
    """States along an exact run of the scene without its reactions, made as needed."""

    def __init__(self, scene, state, spacing=0.25):
        pos, vel, spc, u = state
        self.sim = dg.Simulation.from_arrays(scene.replace(reactions=()), pos, vel, spc,
                                             internal_energy=u, seed=5, integrator="event")
        self.spacing = spacing
        self.states = []

    def __getitem__(self, k):
        while len(self.states) <= k:
            self.sim.advance(self.spacing)
            s = self.sim
            self.states.append((s.positions, s.velocities, s.species, s.internal_energy))
        return self.states[k]


def missed_collisions(scene, snaps, dt, target, max_snaps):
    """1 - (stepped collisions) / (exact collisions) in one step of dt from each snapshot
    (the scene with its reactions), over snapshots until the exact ones reach ``target``
    collisions; returns that and the number of exact collisions it is based on."""
    tot = {"event": 0, "step": 0}
    k = 0
    while tot["event"] < target and k < max_snaps:
        pos, vel, spc, u = snaps[k]
        k += 1
        for integ in tot:
            s = dg.Simulation.from_arrays(scene.replace(dt=dt), pos, vel, spc,
                                          internal_energy=u, seed=3, integrator=integ)
            s.threads = 1
            s.step(1)
            c = s.counters()
            tot[integ] += c["collisions"] + c["reactive_collisions"]
    if tot["event"] == 0:
        return float("nan"), 0
    return 1.0 - tot["step"] / tot["event"], tot["event"]


def batch(values):
    v = np.asarray(values, float)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else 0.0


# ------------------------------------------------------------------------------ measures
def gas_measures(res, scene):
    ch = res["chunks"]
    area_in = ch[0]["inner_area"]
    nb = np.array([c["inner"].sum() / area_in for c in ch])
    kT = np.array([c["kT"] for c in ch])
    P = np.array([c["P"] for c in ch])
    eta_b = nb.mean() * math.pi * R * R
    z, z_se = batch(P / (nb * kT))
    zh = z_henderson(eta_b)
    N = ch[0]["N"]
    chunk_len = res["chunk_len"]
    w = np.array([2.0 * c["coll"] / (N * chunk_len) for c in ch])
    w_mean, w_se = batch(w)
    w_e = enskog_pair_rate(nb.mean(), 2 * R, M / 2, kT.mean(), eta_b)
    P_mean, P_se = batch(P)
    return {"eta_b": eta_b, "Z_err": z / zh - 1, "Z_se": z_se / zh, "P": P_mean, "P_se": P_se,
            "w_err": w_mean / w_e - 1, "w_se": w_se / w_e, "w": w_mean}


def reaction_measures(res, scene, kind):
    """Measured rate / analytic expectation and its standard error."""
    ch = res["chunks"]
    L = res["chunk_len"]
    fired = sum(sum(c["fired"].values()) for c in ch)
    if kind in ("transformation", "decomposition"):
        exposure = sum(0.5 * (c["n_start"][0] + c["n_end"][0]) * L for c in ch)
        k = fired / exposure if exposure else float("nan")
        theory = K_FIRST
    else:
        expected = 0.0
        for c in ch:
            kT = c["kT"]
            n_in = c["inner"] / c["inner_area"]
            eta = float(n_in.sum()) * math.pi * R * R
            # per unit area in the bulk, times the box area
            area = scene.bounds.area
            if kind == "combination":
                pair = n_in[0] * n_in[1] * enskog_pair_rate(1.0, 2 * R, M / 2, kT, eta)
            else:  # exchange: every pair reacts; n^2/2 pairs per unit area
                nt = float(n_in.sum())
                pair = 0.5 * nt * nt * enskog_pair_rate(1.0, 2 * R, M / 2, kT, eta)
            expected += L * area * pair * math.exp(-E_A * KT / kT)
        k = fired / expected if expected else float("nan")
        theory = 1.0
    se = k / math.sqrt(fired) if fired else float("nan")
    return {"k": k, "k_err": k / theory - 1, "k_se": se / theory, "fired": fired,
            "noroom": sum(c["noroom"] for c in ch)}


# ------------------------------------------------------------------------------ driver
def settings(quick):
    fr = [0.2, 0.05] if quick else [0.2, 0.1, 0.05, 0.02, 0.01]
    return [("exact", None)] + [(f"step/r={f:g}" + (" (default)" if f == DEFAULT else ""), f)
                                for f in fr]


def dt_for(f, chunk_len):
    """The time step with mean displacement f r per step, rounded to divide the chunk."""
    steps = max(1, round(chunk_len / (f * R / VMEAN)))
    return chunk_len / steps


def fmt_pct(x, se=None, digits=2):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    s = f"{100 * x:+.{digits}f}"
    if se is not None and not math.isnan(se):
        s += f" ±{100 * se:.{digits}f}"
    return s


def table(title, head, rows):
    w = [max(len(str(h)), *(len(str(r[i])) for r in rows)) for i, h in enumerate(head)]
    out = [f"\n{title}", "| " + " | ".join(str(h).ljust(w[i]) for i, h in enumerate(head)) + " |",
           "|" + "|".join("-" * (x + 2) for x in w) + "|"]
    for r in rows:
        out.append("| " + " | ".join(str(c).ljust(w[i]) for i, c in enumerate(r)) + " |")
    return "\n".join(out)


def event_speed(n=10_000, eta=0.3, duration=3.0, repeats=5):
    """Collisions per second of the exact integrator (best of ``repeats``, one thread), by
    wall clock and by CPU time."""
    sim = dg.Simulation(gas_scene(n, eta), seed=0, integrator="event")
    sim.advance(2.0)
    best_wall = best_cpu = 0.0
    for _ in range(repeats):
        s = sim.copy()
        c0 = s.collisions
        t = time.perf_counter()
        tc = time.process_time()
        s.advance(duration)
        cpu = time.process_time() - tc
        wall = time.perf_counter() - t
        best_wall = max(best_wall, (s.collisions - c0) / wall)
        best_cpu = max(best_cpu, (s.collisions - c0) / cpu)
    return best_wall, best_cpu


def builtin_step_cost(steps=300):
    """CPU ms per ``step(1)`` (one scene.dt) of each built-in scene, both integrators: the
    way the Gymnasium environment drives the simulator."""
    rows = []
    for name in dg.scenes.names():
        ms = {}
        for integ in ("step", "event"):
            sim = dg.Simulation(name, seed=0, integrator=integ)
            sim.threads = 1
            sim.step(20)
            tc = time.process_time()
            for _ in range(steps):
                sim.step(1)
            ms[integ] = 1e3 * (time.process_time() - tc) / steps
        sc = dg.scenes.load(name)
        rows.append([name, str(sum(sc.counts.values())), f"{sc.dt:g}", f"{ms['step']:.3f}",
                     f"{ms['event']:.3f}", f"{ms['event'] / ms['step']:.2f}"])
    return table(f"Built-in scenes: CPU ms per step(1) of scene.dt ({steps} steps after 20; "
                 "one thread)", ["scene", "N", "dt", "step ms", "event ms", "event/step"],
                 rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small and short: under a minute")
    ap.add_argument("--plot", default=None,
                    help=f"where to write the figure (default {OUT / 'accuracy.png'}; "
                         "'none' for no figure; --quick writes none unless given; "
                         "docs/img/accuracy.png for the figure of docs/accuracy.md)")
    ap.add_argument("--markdown", default=None, help="also write the tables to this file")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    quick = args.quick
    n_gas = 400 if quick else 3000
    n_rx = 300 if quick else 4000
    etas = [0.1, 0.5] if quick else [0.1, 0.3, 0.5, 0.6]
    chunks = 5 if quick else 30
    miss_target = (300, 40) if quick else (3000, 400)  # exact collisions, max snapshots
    t_eq = 5.0 if quick else 30.0
    plot = args.plot
    if plot is None:
        plot = "none" if quick else str(OUT / "accuracy.png")

    t_start = time.time()
    print(f"discgym {dg.__version__}: accuracy against time "
          f"({'quick' if quick else 'full'} run; load average {os.getloadavg()[0]:.2f} "
          f"on {os.cpu_count()} cores; one thread)")
    # (kind, scene, chunk length): a dilute gas hits the walls rarely, so runs longer
    scenes = [("gas", gas_scene(n_gas, eta), 4.0 if eta < 0.2 and not quick else 1.0)
              for eta in etas]
    scenes += [("transformation", transformation_scene(n_rx, 0.2), 1.0),
               ("decomposition", decomposition_scene(n_rx, 0.2), 1.0),
               ("combination", combination_scene(n_rx, 0.2), 1.0),
               ("exchange", exchange_scene(n_rx, 0.2), 1.0)]
    warm = gas_scene(50, 0.3)  # load both kernels (numba cache) before timing anything
    for integ in ("event", "step"):
        dg.Simulation(warm, seed=0, integrator=integ).advance(0.1)
    results = []  # (kind, scene, label, f, dt, res, measures, missed)
    for kind, scene, chunk_len in scenes:
        state = equilibrated(scene, t_eq, args.seed)
        snaps = Snapshots(scene, state)
        # missed collisions: with the bimolecular reactions (they fire at contacts); without
        # the first-order ones (their random draws would differ between the two runs)
        miss_scene = scene.replace(reactions=()) if kind in ("transformation",
                                                             "decomposition") else scene
        for label, f in settings(quick):
            dt = dt_for(f, chunk_len) if f is not None else chunk_len
            integ = "event" if f is None else "step"
            res = run(scene, state, integ, dt, chunks, chunk_len)
            res["chunk_len"] = chunk_len
            if kind == "gas":
                meas = gas_measures(res, scene)
            else:
                meas = reaction_measures(res, scene, kind)
            missed = (0.0, 0) if f is None else missed_collisions(miss_scene, snaps, dt,
                                                                  *miss_target)
            results.append((kind, scene, label, f, dt, res, meas, missed))
            print(f"  {scene.name:24s} {label:22s} {res['cpu_per_t']:.4f} CPU s/t "
                  f"({res['wall_per_t']:.4f} wall)", flush=True)

    # ---- tables
    exact = {r[1].name: r[6] for r in results if r[3] is None}
    gas_rows, rx_rows = [], []
    for kind, scene, label, f, dt, res, meas, missed in results:
        ovl = max(c["overlap"] for c in res["chunks"])
        base = [scene.name, label, "-" if f is None else f"{dt:.3g}",
                "-" if f is None else f"{res['h']:.3g}", f"{res['cpu_per_t']:.4f}",
                f"{res['drift']:.0e}",
                "0 (exact)" if f is None else (f"0 of {missed[1]}" if missed[0] == 0 else
                                               f"{100 * missed[0]:.3f}% of {missed[1]}"),
                f"{ovl:.0e}"]
        ex = exact[scene.name]
        if kind == "gas":
            gas_rows.append(base + [f"{meas['eta_b']:.3f}", fmt_pct(meas["Z_err"], meas["Z_se"]),
                                    "-" if f is None else fmt_pct(meas["P"] / ex["P"] - 1),
                                    fmt_pct(meas["w_err"], meas["w_se"])])
        else:
            rx_rows.append(base + [str(meas["fired"]), str(meas["noroom"]),
                                   fmt_pct(meas["k_err"], meas["k_se"]),
                                   "-" if f is None else fmt_pct(meas["k"] / ex["k"] - 1)])
    n_line = (f"N = {n_gas}, r = 1, m = 1, kT = 1; {chunks} chunks of 1 time unit (4 at "
              f"eta = 0.1) per run; missed: one step from each of up to {miss_target[1]} "
              "snapshots)")
    head = ["scene", "integrator", "dt", "h", "CPU s/t", "dE/E", "missed", "overlap"]
    t1 = table("Ideal gas of hard discs (" + n_line,
               head + ["eta_b", "Z-Z_H %", "P-P_ex %", "w-w_E %"], gas_rows)
    t2 = table(f"Reactions (N = {n_rx} at packing 0.2; first order: k = {K_FIRST:g}; "
               f"activated: E_a = {E_A:g} kT; {chunks} time units per run)",
               head + ["fired", "no room", "k-k_th %", "k-k_ex %"], rx_rows)
    print(t1)
    print(t2)
    extra = ""
    if not quick:
        wall, cpu = event_speed()
        extra = (f"\nExact integrator throughput: {wall:.3g} collisions per second of wall "
                 f"time ({cpu:.3g} per CPU second; N = 10^4, packing 0.3, r = 1, m = 1, "
                 "kT = 1, one thread, best of 5)\n")
        extra += builtin_step_cost() + "\n"
        print(extra)
    print(f"\n(total {time.time() - t_start:.0f} s; load average now "
          f"{os.getloadavg()[0]:.2f})")
    if args.markdown:
        with open(args.markdown, "w") as fh:
            fh.write(t1 + "\n" + t2 + "\n" + extra)
    if plot != "none":
        write_plot(results, exact, plot)
        print(f"wrote {plot}")
    return 0


def write_plot(results, exact, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    names = []
    for r in results:
        if r[1].name not in names:
            names.append(r[1].name)
    cols = 4
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.7 * rows), squeeze=False)
    floor = 1e-3  # % (a zero error is drawn here)
    for ax, name in zip(axes.flat, names):
        rs = [r for r in results if r[1].name == name]
        kind = rs[0][0]
        x = np.array([r[5]["cpu_per_t"] for r in rs])
        curves = {"missed collisions": ([100 * r[7][0] for r in rs], None)}
        if kind == "gas":
            curves["|P - P_exact|"] = ([100 * abs(r[6]["P"] / exact[name]["P"] - 1)
                                        for r in rs], None)
            curves["|Z - Henderson|"] = ([100 * abs(r[6]["Z_err"]) for r in rs],
                                         [100 * r[6]["Z_se"] for r in rs])
            curves["|w - Enskog|"] = ([100 * abs(r[6]["w_err"]) for r in rs],
                                      [100 * r[6]["w_se"] for r in rs])
        else:
            curves["|k - k_exact|"] = ([100 * abs(r[6]["k"] / exact[name]["k"] - 1)
                                        for r in rs], None)
            curves["|k - theory|"] = ([100 * abs(r[6]["k_err"]) for r in rs],
                                      [100 * r[6]["k_se"] for r in rs])
        order = np.argsort(x[1:]) + 1
        for lab, (ys, se) in curves.items():
            ys = np.maximum(np.array(ys, float), floor)
            line, = ax.plot(x[order], ys[order], "o-", ms=4, lw=1, label=lab)
            if se is not None:  # the statistical noise of this measure
                ax.plot(x[order], np.maximum(np.array(se, float), floor)[order], "--", lw=0.8,
                        color=line.get_color(), alpha=0.6)
            ax.plot(x[:1], ys[:1], "*", ms=12, color=line.get_color())
        for r, xx in zip(rs[1:], x[1:]):
            ax.annotate(f"{r[3]:g}", (xx, floor), fontsize=6, ha="center", va="bottom",
                        color="0.35")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("CPU s per unit simulated time", fontsize=8)
        ax.set_ylabel("error, %", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6, loc="upper right")
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    fig.suptitle("Time-stepped integrator (dots, labelled by the mean step / r) against the "
                 "exact one (stars); dashed: one standard error (statistics) of the measure "
                 "of that colour; 1e-3 % stands for 0", fontsize=10)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
