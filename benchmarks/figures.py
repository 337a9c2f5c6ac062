"""The figures of docs/performance.md, drawn from the rows of bench_core.py and
bench_peers.py (matplotlib, the ``bench`` extra)."""

from __future__ import annotations

import math

import numba
import numpy as np


def save(fn, rows, path) -> None:
    """``fn(rows, path)``, or a note if matplotlib is missing."""
    try:
        fn(rows, path)
        print(f"wrote {path}", flush=True)
    except ImportError:
        print(f"matplotlib is not installed: {path} not written", flush=True)


def _log_axis(ax, values) -> None:
    """Whole decades around ``values`` on a log y axis, without minor-tick labels."""
    from matplotlib.ticker import NullFormatter

    lo = 10 ** math.floor(math.log10(min(values)))
    hi = 10 ** math.ceil(math.log10(max(values)))
    ax.set_ylim(lo, hi)
    ax.yaxis.set_minor_formatter(NullFormatter())


def plot_scaling(rows, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ns = [r["n"] for r in rows]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    a1.loglog(ns, [r["one"]["rate"] for r in rows], "o-", label="discgym, 1 thread")
    a1.loglog(ns, [r["all"]["rate"] for r in rows], "s-",
              label=f"discgym, all threads ({numba.get_num_threads()})")
    a1.axhline(12e6, color="gray", ls=":", label="target at N = 1e4: 12 M/s")
    _log_axis(a1, [r[k]["rate"] for r in rows for k in ("one", "all")] + [12e6])
    a1.set_xlabel("N discs")
    a1.set_ylabel("disc-steps per second")
    a1.set_title("Throughput (packing 0.3, dt = 0.05)")
    a1.grid(True, which="both", alpha=0.3)
    a1.legend()
    a2.semilogx(ns, [r["one"]["ns"] for r in rows], "o-", label="1 thread")
    a2.semilogx(ns, [r["all"]["ns"] for r in rows], "s-", label="all threads")
    a2.set_ylim(bottom=0)
    a2.set_xlabel("N discs")
    a2.set_ylabel("ns per disc-step")
    a2.set_title("Cost per disc-step")
    a2.grid(True, which="both", alpha=0.3)
    a2.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_peers(data, path) -> None:
    """Left: disc-steps per second against N, discgym (in each peer's pairs) and the peers.
    Right: wall seconds per unit of simulated time at equal accuracy (N = 10^4)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, acc = data["throughput"], data.get("accuracy") or []
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    dg = {}
    for r in rows:
        dg.setdefault(r["n"], []).append(r["rate_discgym"])
    ns = sorted(dg)
    ax.loglog(ns, [float(np.median(dg[n])) for n in ns], "o-", lw=2, label="discgym (stepped)")
    for peer, mark in zip(sorted({r["peer"] for r in rows}), "svD^"):
        pr = sorted((r for r in rows if r["peer"] == peer), key=lambda r: r["n"])
        ax.loglog([r["n"] for r in pr], [r["rate"] for r in pr], mark + "--", label=peer)
    _log_axis(ax, [r[k] for r in rows for k in ("rate", "rate_discgym")])
    ax.set_xlabel("N discs")
    ax.set_ylabel("disc-steps per second (one thread)")
    ax.set_title("raw throughput (each engine's own dt)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    chosen = [r for r in acc if r.get("chosen") or r.get("setting") == "exact"]
    if chosen:
        names = [f"{r['code']}\n{r['setting']}" for r in chosen]
        bx.barh(names, [r["cpu_per_time"] for r in chosen])
        bx.set_xscale("log")
        bx.invert_yaxis()
        bx.set_xlabel("wall seconds per unit of simulated time")
        bx.set_title(f"equal accuracy, N = {chosen[0]['n']}")
        bx.grid(True, axis="x", which="both", alpha=0.3)
    else:
        bx.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_effects(rows, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 0.45 * len(rows) + 1.2))
    y = np.arange(len(rows))[::-1]
    ax.barh(y, [r["ns_best"] for r in rows], color="#4c72b0")
    ax.set_yticks(y, [r["label"] for r in rows], fontsize=8)
    ax.set_xlabel(f"ns per disc-step (N = {rows[0]['n']}, one thread, best of the rounds)")
    ax.set_title("Cost of each effect")
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
