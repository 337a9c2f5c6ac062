"""A busy machine: the default thread count against one thread, with one core taken by
another process, for a Simulation and for the native vector env.

    python benchmarks/bench_busy.py                        # 8 rounds of 4 s a run
    python benchmarks/bench_busy.py --rounds 12 --plot out/busy.png

Each case runs in three settings: the default (on numba's threads, the count chosen call by
call: ``discgym.threads``), one thread (``threads = 1``) and every thread fixed
(``DISCGYM_ADAPTIVE_THREADS=0``: the behaviour before the chooser). Each run is a fresh
process that warms up (its kernels loaded, 2 s of calls, in which the default settles its
count), then counts its work over ``--seconds`` of calls. A round runs every case in every
setting, the settings in turn (each first in one round of three), so that the machine's
drift hits them alike. The load is "idle" (nothing else running) or "busy" (one plain
Python loop, ``while True: pass``, through all the rounds: one core of another process, as a
second run side by side would take).

Prints a table per load of the median rate of each setting and the median and lowest, over
the rounds, of the default over one thread and over every thread fixed. The goal it shows:
busy, the default never more than 10 % slower than one thread; idle, as fast as every
thread fixed. Nothing here asserts a time.

Cases: ``sim``, a Simulation of 10^4 discs of the benchmark scene (dt 0.05, 20 steps a
call); ``vector``, ``DiscReactor-v0``'s native vector env of 16 reactors (one env step of
random actions a call).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

CASES = ("sim", "vector")
SETTINGS = ("default", "one thread", "fixed")
LOADS = ("idle", "busy")


def stepper(case: str, setting: str):
    """A function making one call of ``case`` in ``setting``, returning its work (disc-steps
    or env steps)."""
    import numpy as np

    if case == "sim":
        from discgym import Simulation
        from discgym.bench import bench_scene

        n, k = 10_000, 20
        sim = Simulation(bench_scene(n), seed=3)
        if setting == "one thread":
            sim.threads = 1

        def call():
            sim.step(k)
            return n * k
        return call
    import gymnasium as gym

    import discgym  # noqa: F401

    R = 16
    env = gym.make_vec("DiscReactor-v0", num_envs=R, vectorization_mode="vector_entry_point",
                       threads=1 if setting == "one thread" else None)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    shape = env.action_space.shape

    def call():
        env.step(rng.uniform(-1.0, 1.0, shape).astype(np.float32))
        return R
    return call


def child(case: str, setting: str, seconds: float) -> float:
    """The rate of ``case`` in ``setting`` (work per second) over ``seconds`` of calls,
    after 2 s of calls to warm up (the kernels loaded, the thread count settled)."""
    call = stepper(case, setting)
    end = time.perf_counter() + 2.0
    while time.perf_counter() < end:
        call()
    work, t0 = 0, time.perf_counter()
    while (t := time.perf_counter()) - t0 < seconds:
        work += call()
    return work / (t - t0)


def run_one(case: str, setting: str, seconds: float) -> float:
    env = dict(os.environ)
    if setting == "fixed":
        env["DISCGYM_ADAPTIVE_THREADS"] = "0"
    out = subprocess.run([sys.executable, __file__, "--child", case, setting, str(seconds)],
                         env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def measure(cases, loads, rounds: int, seconds: float, log=print) -> dict:
    """{load: {case: {setting: [rate per round]}}}: each round runs every case in every
    setting, each in a fresh process, the settings in turn (each first in one round of
    three), so that the machine's drift hits them alike."""
    res = {load: {c: {s: [] for s in SETTINGS} for c in cases} for load in loads}
    for load in loads:
        busy = subprocess.Popen([sys.executable, "-c", "while True: pass"]) \
            if load == "busy" else None
        try:
            for r in range(rounds):
                for c in cases:
                    for s in SETTINGS[r % 3:] + SETTINGS[:r % 3]:
                        res[load][c][s].append(run_one(c, s, seconds))
                log(f"  {load} round {r + 1}/{rounds}: " + "; ".join(
                    f"{c} " + ", ".join(f"{s} {res[load][c][s][-1]:.4g}" for s in SETTINGS)
                    for c in cases))
        finally:
            if busy is not None:
                busy.kill()
                busy.wait()
    return res


def table(res: dict, markdown: bool = False) -> str:
    from discgym.bench import format_table

    rows = []
    for load, by_case in res.items():
        for c, by in by_case.items():
            d, one, fixed = by["default"], by["one thread"], by["fixed"]
            over_one = [a / b for a, b in zip(d, one)]
            over_fixed = [a / b for a, b in zip(d, fixed)]
            unit = "M disc-steps/s" if c == "sim" else "env steps/s"
            scale = 1e-6 if c == "sim" else 1.0
            rows.append([load, c, unit] + [f"{statistics.median(by[s]) * scale:.3g}"
                                           for s in SETTINGS] +
                        [f"{statistics.median(over_one):.2f} ({min(over_one):.2f})",
                         f"{statistics.median(over_fixed):.2f} ({min(over_fixed):.2f})"])
    return format_table(["load", "case", "unit", "default", "one thread", "every thread fixed",
                         "default / one (lowest)", "default / fixed (lowest)"], rows, markdown)


def plot(res: dict, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(next(iter(res.values())))
    fig, axes = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 3.6), squeeze=False)
    for ax, c in zip(axes[0], cases):
        for j, s in enumerate(SETTINGS):
            for i, load in enumerate(res):
                one = statistics.median(res[load][c]["one thread"])
                vals = [v / one for v in res[load][c][s]]
                x = i + (j - 1) * 0.25
                ax.bar(x, statistics.median(vals), 0.23, color=f"C{j}",
                       label=s if i == 0 else None)
                ax.plot([x] * len(vals), vals, "k.", ms=3)
        ax.axhline(1.0, color="gray", lw=0.8)
        ax.axhline(0.9, color="gray", lw=0.8, ls=":")
        ax.set_xticks(range(len(res)), list(res))
        ax.set_title({"sim": "Simulation, 10^4 discs", "vector": "vector env, 16 reactors"}[c])
        ax.set_ylabel("speed / one thread's (median)")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        print(child(argv[1], argv[2], float(argv[3])))
        return 0
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rounds", type=int, default=8)
    p.add_argument("--seconds", type=float, default=4.0, help="measured seconds of a run")
    p.add_argument("--cases", default=",".join(CASES), help=f"of {', '.join(CASES)}")
    p.add_argument("--loads", default=",".join(LOADS), help=f"of {', '.join(LOADS)}")
    p.add_argument("--plot", type=Path, default=None, help="write the bar chart here")
    p.add_argument("--json", type=Path, default=None, help="write the rates here")
    p.add_argument("--markdown", action="store_true")
    a = p.parse_args(argv)
    cases = [c.strip() for c in a.cases.split(",") if c.strip()]
    loads = [x.strip() for x in a.loads.split(",") if x.strip()]
    if a.rounds < 1 or not a.seconds > 0 or not cases or not set(cases) <= set(CASES) \
            or not loads or not set(loads) <= set(LOADS):
        p.error(f"--rounds >= 1, --seconds > 0, --cases of {', '.join(CASES)} and --loads of "
                f"{', '.join(LOADS)}")
    for path in (a.plot, a.json):
        if path is not None and (path.is_dir() or not path.absolute().parent.is_dir()):
            p.error(f"{path}: not a file in an existing folder")
    from discgym.bench import machine_info, machine_line

    res = measure(cases, loads, a.rounds, a.seconds)
    print(machine_line(machine_info()))
    print(table(res, a.markdown))
    if a.json is not None:
        a.json.write_text(json.dumps(res, indent=1))
    if a.plot is not None:
        print(f"wrote {plot(res, a.plot)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
