"""The baseline ladder of a task: random < best constant < simple rule < searched controller
< planner < oracle, on the same evaluation seeds, with 95% bootstrap confidence intervals.

    python benchmarks/ladder.py --env DiscReactor-v0 --seeds 20 --plot
    python benchmarks/ladder.py --env all            # every task of TASK_BASELINES
    python benchmarks/ladder.py --table docs/data/ladder_Disc*-v0.json   # the docs' tables
    python benchmarks/ladder.py --table docs/data/ladder_Disc*-v0.json --plot \
        --plot-path docs/img/ladder_all.png                             # and their chart

For each env id of ``discgym.baselines.TASK_BASELINES``:
- random: ``env.action_space.sample()``, the space seeded with the episode's seed;
- best constant: the best of the task's constant grid by mean return on the *search* seeds
  (0 .. --search-seeds - 1, disjoint from the evaluation seeds);
- simple rule: the task's hand-written controller (its rule is its docstring);
- searched: the task's searched controller (``discgym.searched.SEARCHED``: CMA-ES along
  every control on tuning seeds 3000 and up, the command that found it in the JSON);
- planner: rollout MPC on the searched controller that does not foresee the random draws
  (``TaskBaselines.planner``: candidates over every control, each scored on
  --planner-futures fresh futures shared by all candidates);
- oracle: ``discgym.oracle.RolloutOracle`` on the searched controller, rollouts to the
  episode's end on exact clones of the true env (every random draw foreseen: the ceiling,
  never below the searched controller on any seed), re-planned every ``--replan-every``
  steps.
Each runs one episode per evaluation seed (--first-seed .. --first-seed + --seeds - 1) on a
fresh ``gymnasium.make(env_id)``. The table gives the mean and the IQM with BCa bootstrap
95% intervals (scipy.stats.bootstrap, fixed random_state) and the wall time per episode; the
ladder's steps are compared by paired differences over the seeds (separated: the interval
excludes 0). Writes JSON (--out: per-seed returns, the table, the planner's and the oracle's
budgets, date, machine, versions) and, with --plot, a bar chart (out/ladder_<env>.png, or
ladder_all.png with one panel per task; out/ is gitignored, the tracked charts in docs/img
change only when --plot-path names them).

``--table FILE...`` runs nothing: it prints (and with --plot draws) the ladders in JSON
files this script wrote: one Markdown table with a row per task (each policy's mean return
with its 95% interval, whether the ladder is ordered and every step separated by its paired
interval, the planner's and the oracle's wall time per episode), then every policy's
normalised IQM over the tasks (random 0, the searched controller 1: the IQM of its task
means) with the interval of resampling each task's seeds.

Every argument is checked before any work (:func:`check_args`; the ``--env-kwarg`` by making
each env without a reset, a few ms and no compile): a bad one is refused in one line
``ladder.py: error: --flag: ...``, exit status 2, nothing run or written. Each JSON is
written to a temporary file in its folder and renamed into place: whole or as it was.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import discgym  # noqa: F401  (registers the envs)
from discgym.baselines import (
    PLANNER_FUTURES,
    PLANNER_GATE,
    SEARCH_SEEDS,
    TASK_BASELINES,
    aggregate_task_means,
    check_disjoint,
    constant_factory,
    iqm_ci,
    mean_ci,
    normalised_scores,
    paired_difference,
    random_factory,
    run_episodes,
    search_constant,
)
from discgym.bench import machine_info
from discgym.searched import SEARCHED

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT / "agents") not in sys.path:  # (argcheck: what the command lines share)
    sys.path.insert(0, str(ROOT / "agents"))
from argcheck import MAX_SEED, UsageError, one_line, usage, write_text_atomic  # noqa: E402

LADDER = ("random", "best constant", "hand-written", "searched", "planner", "oracle")
#: The rows' names in the tables.
SHORT = ("random", "best constant", "simple rule", "searched", "planner", "oracle")


def machine() -> str:
    return f"{platform.machine()}, {os.cpu_count()} CPUs, {machine_info()['cpu']}"


def versions() -> dict:
    import gymnasium
    import numba
    import scipy

    out = {"python": platform.python_version(), "numpy": np.__version__,
           "numba": numba.__version__, "gymnasium": gymnasium.__version__,
           "scipy": scipy.__version__, "discgym": discgym.__version__}
    try:
        out["git"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                                    capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return out


def run_task(env_id: str, eval_seeds: list, search_seeds: list, env_kwargs: dict,
             replan_every: int | None = None, horizon: int | None = None,
             log=print, planner_futures: int = PLANNER_FUTURES,
             planner_gate: float | None = PLANNER_GATE) -> dict:
    """The ladder of one task: every policy's per-seed returns, the summaries, the paired
    differences between the ladder's steps, the planner's and the oracle's budgets."""
    tb = TASK_BASELINES[env_id]
    check_disjoint(eval_seeds, search_seeds)
    kw = {**dict(tb.env_kwargs), **env_kwargs}
    t0 = time.perf_counter()
    best, means = search_constant(env_id, tb.constant_grid, seeds=search_seeds, env_kwargs=kw,
                                  avoid=eval_seeds)
    search_s = time.perf_counter() - t0
    log(f"{env_id}: best constant {[round(float(x), 4) for x in best]} of {len(means)} on seeds "
        f"{search_seeds[0]}..{search_seeds[-1]} ({search_s:.0f} s)")
    factories = {"random": random_factory, "best constant": constant_factory(best),
                 "hand-written": tb.controller, "searched": tb.searched,
                 "planner": tb.planner(samples=planner_futures, replan_every=replan_every,
                                       gate=planner_gate),
                 "oracle": tb.oracle(replan_every=replan_every, horizon=horizon)}
    runs = {}
    for name, fac in factories.items():
        t = time.perf_counter()
        runs[name] = run_episodes(env_id, fac, eval_seeds, kw)
        log(f"{env_id}: {name} done ({time.perf_counter() - t:.0f} s)")
    rows = {}
    for name, r in runs.items():
        rows[name] = {"mean": mean_ci(r.returns).as_dict(), "iqm": iqm_ci(r.returns).as_dict(),
                      "seconds_per_episode": float(r.seconds.mean()),
                      "returns": [float(x) for x in r.returns]}
    steps = []
    for lo, hi in zip(LADDER[:-1], LADDER[1:]):
        d = paired_difference(runs[hi].returns, runs[lo].returns)
        steps.append({"step": f"{hi} - {lo}", "difference": d.as_dict(),
                      "ordered": bool(d.value > 0), "separated": bool(d.low > 0)})
    ep_steps = runs["oracle"].steps
    searched = SEARCHED[env_id]
    return {
        "env_id": env_id, "env_kwargs": kw, "eval_seeds": eval_seeds,
        "search_seeds": search_seeds, "episode_steps": [int(x) for x in ep_steps],
        "best_constant": {"action": [float(x) for x in best], "grid_size": len(means),
                          "search_means": [float(x) for x in means],
                          "search_seconds": search_s},
        "controller": {"name": tb.controller_name,
                       "rule": (tb.controller.__doc__ or "").strip()},
        "searched": {"params": dict(searched["params"]), "command": searched["command"]},
        "policies": rows, "ladder": steps,
        "ordered": all(s["ordered"] for s in steps),
        "planner_budget": {**budget(runs["planner"], ep_steps, tb, replan_every, None,
                                    futures=planner_futures),
                           "gate": planner_gate,
                           "gated_per_replan": float(np.mean(
                               [s["gated"] / s["replans"] for s in runs["planner"].stats]))},
        "oracle_budget": budget(runs["oracle"], ep_steps, tb, replan_every, horizon),
    }


def budget(run, ep_steps, tb, replan_every, horizon, futures: int = 1) -> dict:
    """A rollout planner's budget over the ladder's episodes (from its ``stats``)."""
    st = [s for s in run.stats if s]
    return {
        "candidates_per_replan": float(np.mean([s["rollouts"] / s["replans"] for s in st])
                                       / futures),
        "futures_per_candidate": futures,
        "candidate_rule": (tb.oracle_candidates.__doc__ or "").strip(),
        "replan_every": tb.oracle_replan_every if replan_every is None else replan_every,
        "horizon": "episode end" if (horizon or tb.oracle_horizon) is None
        else (horizon or tb.oracle_horizon),
        "replans_per_episode": float(np.mean([s["replans"] for s in st])),
        "rollouts_per_episode": float(np.mean([s["rollouts"] for s in st])),
        "simulated_steps_per_episode": float(np.mean([s["simulated_steps"] for s in st])),
        "simulated_steps_per_env_step": float(np.mean([s["simulated_steps"] for s in st])
                                              / np.mean(ep_steps)),
        "planning_seconds_per_episode": float(np.mean([s["planning_seconds"] for s in st])),
        "seconds_per_episode": float(run.seconds.mean()),
        "plan_mismatches": int(sum(s["plan_mismatches"] for s in st)),
    }


def seconds(s: float) -> str:
    return f"{s:.2f} s" if s >= 1.0 else f"{s * 1e3:.0f} ms"


def oracle_variants(env_id: str) -> dict:
    """Other planners and budgets on the task's searched controller (``--variants``),
    against the default oracle: re-planning every step or every 10, a 10-step horizon, and
    the sampling planner (:class:`discgym.oracle.ShootingOracle`)."""
    from discgym.oracle import ShootingOracle

    tb = TASK_BASELINES[env_id]
    return {
        "rollout, re-plan every step": tb.oracle(replan_every=1),
        "rollout, re-plan every 10": tb.oracle(replan_every=10),
        "rollout, horizon 10": tb.oracle(horizon=10),
        "CEM 2 x 8 sequences, segments of 10, re-plan every 10":
            lambda env: ShootingOracle(env, tb.searched(env), samples=8, iterations=2,
                                       elite=2, segment=10, replan_every=10, generator=0),
    }


def run_variants(res: dict, log=print) -> list:
    """Each of :func:`oracle_variants` on the ladder's seeds: mean [CI], time per episode,
    simulated steps per episode, and the paired difference to the default oracle."""
    env_id, seeds, kw = res["env_id"], res["eval_seeds"], res["env_kwargs"]
    ref = np.array(res["policies"]["oracle"]["returns"])
    out = []
    for name, fac in oracle_variants(env_id).items():
        t = time.perf_counter()
        r = run_episodes(env_id, fac, seeds, kw)
        log(f"{env_id}: {name} done ({time.perf_counter() - t:.0f} s)")
        out.append({"name": name, "mean": mean_ci(r.returns).as_dict(),
                    "minus_default": paired_difference(r.returns, ref).as_dict(),
                    "seconds_per_episode": float(r.seconds.mean()),
                    "simulated_steps_per_episode": float(np.mean(
                        [st["simulated_steps"] for st in r.stats])),
                    "returns": [float(x) for x in r.returns]})
    return out


def variants_table(res: dict) -> str:
    b = res["oracle_budget"]

    def ci(d):
        return f"{d['value']:.3f} [{d['low']:.3f}, {d['high']:.3f}]"

    lines = [f"| oracle ({len(res['eval_seeds'])} seeds) | mean [95% CI] | minus the default "
             "[95% CI] | simulated steps per episode | wall time per episode |",
             "|---|---|---|---|---|",
             f"| default: rollout, re-plan every {b['replan_every']} | "
             f"{ci(res['policies']['oracle']['mean'])} | | "
             f"{b['simulated_steps_per_episode']:.0f} | {seconds(b['seconds_per_episode'])} |"]
    for v in res["oracle_variants"]:
        lines.append(f"| {v['name']} | {ci(v['mean'])} | {ci(v['minus_default'])} | "
                     f"{v['simulated_steps_per_episode']:.0f} | "
                     f"{seconds(v['seconds_per_episode'])} |")
    return "\n".join(lines)


def table(res: dict) -> str:
    n = len(res["eval_seeds"])
    pb = res["planner_budget"]
    names = {"random": "random", "best constant": "best constant "
             f"`{[round(x, 3) for x in res['best_constant']['action']]}`",
             "hand-written": f"simple rule: {res['controller']['name']}",
             "searched": "searched controller",
             "planner": f"planner (rollout MPC on the searched controller, "
                        f"{pb['futures_per_candidate']} fresh futures per candidate"
                        + (f", gate {pb['gate']:g} SE)" if pb.get("gate") is not None else ")"),
             "oracle": "oracle (the same on exact copies, every random draw foreseen)"}
    lines = [f"| policy ({n} seeds) | mean [95% CI] | IQM [95% CI] | wall time per episode |",
             "|---|---|---|---|"]

    def ci(d):
        return f"{d['value']:.3f} [{d['low']:.3f}, {d['high']:.3f}]"

    for k in LADDER:
        r = res["policies"][k]
        lines.append(f"| {names[k]} | {ci(r['mean'])} | {ci(r['iqm'])} | "
                     f"{seconds(r['seconds_per_episode'])} |")
    lines += ["", "| ladder step | paired difference of means [95% CI] | separated (CI above 0) |",
              "|---|---|---|"]
    for s in res["ladder"]:
        lines.append(f"| {s['step']} | {ci(s['difference'])} | "
                     f"{'yes' if s['separated'] else 'no'} |")
    return "\n".join(lines)


def summary_row(res: dict) -> str:
    """One task's row of :func:`summary_table` (a result of :func:`run_task` or its JSON)."""
    pol = res["policies"]
    name = res["controller"]["name"]
    sep = all(s["separated"] for s in res["ladder"])
    below = ", ".join(s["step"] for s in res["ladder"] if not s["ordered"])
    ok = "yes" if res["ordered"] and sep else (
        "ordered" if res["ordered"] else f"**no** ({below} below 0)")

    def cell(p: dict) -> str:
        m = p["mean"]
        return f"{m['value']:.3f} [{m['low']:.3f}, {m['high']:.3f}]"

    return (f"| `{res['env_id']}` | {cell(pol['random'])} | {cell(pol['best constant'])} | "
            f"{cell(pol['hand-written'])} ({name}) | {cell(pol['searched'])} | "
            f"{cell(pol['planner'])} | **{cell(pol['oracle'])}** | {ok} | "
            f"{res['planner_budget']['seconds_per_episode']:.1f} s, "
            f"{res['oracle_budget']['seconds_per_episode']:.1f} s |")


def summary_table(results: list) -> str:
    """Every task's ladder in one Markdown table, a row per task (the docs' summary)."""
    return "\n".join(["| task | random | best constant | simple rule | searched | planner | "
                      "oracle | ordered, separated | planner, oracle per episode |",
                      "|---|---|---|---|---|---|---|---|---|", *map(summary_row, results)])


def normalised(results: list) -> tuple[dict, list]:
    """Each policy's per-seed normalised scores, task by task (random's mean 0, the searched
    controller's 1), and the tasks left out because their searched controller is not above
    random (no scale: a tiny test env, say)."""
    norm, left_out = {k: [] for k in LADDER}, []
    for res in results:
        pol = res["policies"]
        refs = pol["random"]["returns"], pol["searched"]["returns"]
        try:
            scores = {k: normalised_scores(pol[k]["returns"], *refs) for k in LADDER}
        except ValueError:  # (the searched controller not above random)
            left_out.append(res["env_id"])
            continue
        for k in LADDER:
            norm[k].append(scores[k])
    return norm, left_out


def aggregate_table(results: list) -> str:
    """Every policy's normalised score over the tasks (per task, random's mean 0 and the
    searched controller's 1; each seed's return so mapped), the IQM of its task means with
    the interval of resampling each task's seeds (:func:`discgym.baselines.
    aggregate_task_means`, as agents/aggregate.py scores a controller), and its lowest and
    highest task mean."""
    norm, left_out = normalised(results)
    note = ("" if not left_out else "\n\nLeft out (the searched controller not above "
            f"random: no scale): {', '.join(left_out)}.")
    n = len(norm["random"])
    if n == 0:
        return note.strip()
    lines = [f"| policy | normalised IQM over {n} task(s) [95% CI] | task means, lowest - "
             "highest |", "|---|---|---|"]
    for k, label in zip(LADDER, SHORT):
        agg = aggregate_task_means(norm[k])
        means = [round(float(np.mean(x)), 3) + 0.0 for x in norm[k]]  # (+ 0.0: no "-0.000")
        lines.append(f"| {label} | {agg.text()} | {min(means):.3f} - {max(means):.3f} |")
    return "\n".join(lines) + note


COLORS = ["0.7", "0.55", "tab:blue", "tab:orange", "tab:purple", "tab:green"]
TICKS = ["random", "best\nconstant", "simple\nrule", "searched", "planner", "oracle"]


def plot(results: list, path: Path) -> Path:
    """A panel per task (each policy's mean with its 95% interval, a dot per seed) and, for
    several tasks, one more: the normalised IQM over the tasks with its interval
    (:func:`aggregate_table`'s figures)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    norm, _ = normalised(results)
    both = len(results) > 1 and len(norm["random"]) > 0  # (the aggregate panel too)
    n = len(results) + both
    fig, axes = plt.subplots(1, n, figsize=(4.6 * n, 3.6), squeeze=False)
    x = np.arange(len(LADDER))
    for ax, res in zip(axes[0], results):
        rows = [res["policies"][k] for k in LADDER]
        m = np.array([r["mean"]["value"] for r in rows])
        lo = m - np.array([r["mean"]["low"] for r in rows])
        hi = np.array([r["mean"]["high"] for r in rows]) - m
        ax.bar(x, m, yerr=[lo, hi], capsize=4, color=COLORS)
        for i, r in enumerate(rows):
            pts = np.array(r["returns"])
            ax.plot(np.full(len(pts), i) + np.linspace(-0.25, 0.25, len(pts)), pts, ".",
                    color="k", ms=2, alpha=0.5)
        ax.set_ylabel("return (mean, 95% CI; dots: seeds)")
        ax.set_title(f"{res['env_id']} ({len(res['eval_seeds'])} seeds)")
    if both:
        ax = axes[0][-1]
        agg = [aggregate_task_means(norm[k]) for k in LADDER]
        m = np.array([a.value for a in agg])
        ax.bar(x, m, yerr=[m - [a.low for a in agg], [a.high for a in agg] - m], capsize=4,
               color=COLORS)
        ax.axhline(1.0, color="tab:orange", lw=0.8, ls="--")
        ax.set_ylabel("normalised score (random 0, searched 1)")
        ax.set_title(f"{len(norm['random'])} tasks: normalised IQM of task means, 95% CI")
    for ax in axes[0]:
        ax.set_xticks(x, TICKS, fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


class _Parser(argparse.ArgumentParser):
    """search_controller.py's parser: an error is one line, exit 2 (the project's
    command-line convention), worded ``--flag: ...`` as :func:`check_args` words its own."""

    def error(self, message):
        text = re.sub(r"^argument ([^:]+): ", r"\1: ", one_line(message))
        self.exit(2, f"{self.prog}: error: {text}\n")


def _kwarg(text: str):
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    k, v = text.split("=", 1)
    try:
        return k, json.loads(v)
    except json.JSONDecodeError:
        return k, v


def _check_file_out(path: Path, name: str) -> Path:
    """A file this script will write (a temporary file renamed into place): not a folder,
    in a folder that exists or can be made, writable (a probe in its nearest existing
    folder, removed at once)."""
    if path.name in ("", ".", "..") or path.is_dir():
        raise usage(name, f"{path} is a folder: name a file")
    parent = path.absolute().parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise usage(name, f"{parent} is not a folder")
    try:  # (a probe, removed at once: as root os.access passes even /proc)
        os.rmdir(tempfile.mkdtemp(prefix=".ladder-check-", dir=parent))
    except OSError as e:
        raise usage(name, f"cannot write in {parent} ({e.strerror or e})") from None
    return path


def _check_plot_path(given: str | None, default_name: str) -> Path:
    """The chart's path (``--plot-path``, else out/``default_name``): a file matplotlib can
    write, by its suffix."""
    path = Path(given) if given else ROOT / "out" / default_name
    try:
        from matplotlib.backend_bases import FigureCanvasBase
    except ImportError as e:
        raise usage("--plot", f"the chart needs matplotlib ({e})") from None
    kinds = FigureCanvasBase.get_supported_filetypes()
    suffix = path.suffix[1:].lower()
    if suffix and suffix not in kinds:
        raise usage("--plot-path", f"{path}: matplotlib writes no .{suffix} files (it writes "
                                   f"{', '.join(sorted(kinds))})")
    return _check_file_out(path, "--plot-path")


def _check_env_kwargs(env_id: str, kw: dict) -> None:
    """``gymnasium.make(env_id, **kw)`` as each of the ladder's episodes makes it, closed
    without a reset: the env checks its keyword arguments (names, types, ranges, a scene that
    loads, discs that fit; ``ReactorConfig.from_kwargs``) and Gymnasium its own
    (``max_episode_steps``, ...). A few ms an env; no kernel is compiled (the first reset
    does that)."""
    import gymnasium as gym

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # (Gymnasium's: the refusal is the one line)
            gym.make(env_id, **kw).close()
    except (TypeError, ValueError, AssertionError, OSError, gym.error.Error) as e:
        raise usage("--env-kwarg", f"{env_id}: {e}") from None


def _load_ladder(path: Path) -> dict:
    """A ladder's JSON as ``--out`` writes it (for ``--table``), else a refusal naming the
    file."""
    try:
        res = json.loads(path.read_text())
    except OSError as e:
        raise usage("--table", f"{path}: cannot read it ({e.strerror or e})") from None
    except ValueError as e:  # (not JSON, not UTF-8)
        raise usage("--table", f"{path}: not JSON ({e})") from None
    try:
        if not isinstance(res, dict):
            raise TypeError(f"a JSON {type(res).__name__}, not an object")
        for k in LADDER:
            r = res["policies"][k]["returns"]
            if not (isinstance(r, list) and r and all(
                    isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
                    for x in r)):
                raise ValueError(f"policies.{k}.returns: expected a list of finite numbers")
        len(res["eval_seeds"])
        summary_row(res)
    except (KeyError, IndexError, TypeError, ValueError) as e:
        raise usage("--table", f"{path}: not a ladder's JSON ({type(e).__name__}: {e})") from None
    return res


def check_args(a) -> dict:
    """Every argument of a run, before any work (the constant search, an episode, a file
    written): a bad one raises :class:`argcheck.UsageError` naming its flag. Returns what
    the run uses: ``envs``, ``eval_seeds``, ``search_seeds``, ``env_kwargs``, ``gate`` (the
    planner's, None: no gate), ``outs`` (env id -> JSON path) and ``plot_path`` (None
    without --plot)."""
    if a.env != "all" and a.env not in TASK_BASELINES:
        raise usage("--env", f"{a.env!r} has no baselines (known: {', '.join(TASK_BASELINES)}, "
                             "or all)")
    envs = list(TASK_BASELINES) if a.env == "all" else [a.env]
    if a.seeds < 2:
        raise usage("--seeds", f"expected an int >= 2 (a confidence interval), got {a.seeds}")
    if not 0 <= a.first_seed <= MAX_SEED:
        raise usage("--first-seed", f"expected an int in [0, {MAX_SEED}] (numpy's seeds), got "
                                    f"{a.first_seed}")
    last = a.first_seed + a.seeds - 1
    if last > MAX_SEED:
        raise usage("--seeds", f"the evaluation seeds {a.first_seed}..{last} pass numpy's "
                               f"largest seed, {MAX_SEED}")
    if not 1 <= a.search_seeds <= MAX_SEED + 1:
        raise usage("--search-seeds", f"expected an int in [1, {MAX_SEED + 1}] (seeds 0 .. n - "
                                      f"1), got {a.search_seeds}")
    if a.search_seeds > a.first_seed:  # (0 .. n - 1 meets first .. last)
        raise usage("--search-seeds", f"the search seeds 0..{a.search_seeds - 1} meet the "
                    f"evaluation seeds {a.first_seed}..{last} (--first-seed); a constant action "
                    "chosen on the evaluation seeds would be flattered")
    for name, value in (("--replan-every", a.replan_every), ("--horizon", a.horizon)):
        if value is not None and value < 1:
            raise usage(name, f"expected an int >= 1, got {value}")
    if a.planner_futures < 1:
        raise usage("--planner-futures", f"expected an int >= 1, got {a.planner_futures}")
    if not math.isfinite(a.planner_gate):
        raise usage("--planner-gate", "expected a finite number (standard errors; a negative "
                                      f"one: no gate), got {a.planner_gate}")
    gate = None if a.planner_gate < 0 else a.planner_gate
    if gate is not None and a.planner_futures < 2:
        raise usage("--planner-gate", f"a gate ({gate:g}) needs --planner-futures >= 2 (a "
                                      "standard error over the futures), or a negative gate: none")
    env_kwargs = dict(a.env_kwarg)
    if env_kwargs:
        for env_id in envs:
            _check_env_kwargs(env_id, {**dict(TASK_BASELINES[env_id].env_kwargs), **env_kwargs})
    if len(envs) > 1 and "{env}" not in a.out:
        raise usage("--out", f"with several envs the path must contain {{env}}, got {a.out!r}")
    outs = {}
    for env_id in envs:
        try:
            out = Path(a.out.format(env=env_id))
        except (KeyError, IndexError, ValueError, AttributeError, TypeError) as e:
            raise usage("--out", f"{a.out!r}: braces other than {{env}} ({type(e).__name__}: "
                                 f"{e})") from None
        outs[env_id] = _check_file_out(out, "--out")
    plot_path = None
    if a.plot:
        plot_path = _check_plot_path(a.plot_path, f"ladder_{envs[0]}.png" if len(envs) == 1
                                     else "ladder_all.png")
    return {"envs": envs, "eval_seeds": list(range(a.first_seed, last + 1)),
            "search_seeds": list(range(a.search_seeds)), "env_kwargs": env_kwargs,
            "gate": gate, "outs": outs, "plot_path": plot_path}


def main(argv=None) -> int:
    p = _Parser(prog="ladder.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--env", default="DiscReactor-v0",
                   help=f"an env id of TASK_BASELINES ({', '.join(TASK_BASELINES)}) or 'all'")
    p.add_argument("--seeds", type=int, default=20, help="evaluation seeds (>= 2; 20 for docs)")
    p.add_argument("--first-seed", type=int, default=1000, help="the first evaluation seed")
    p.add_argument("--search-seeds", type=int, default=len(SEARCH_SEEDS),
                   help="seeds 0 .. n-1 of the constant-action search")
    p.add_argument("--replan-every", type=int, default=None,
                   help="the oracle re-plans every k steps (default: the task's)")
    p.add_argument("--horizon", type=int, default=None,
                   help="the oracle's rollout length (default: the task's, the episode end)")
    p.add_argument("--env-kwarg", type=_kwarg, action="append", default=[],
                   metavar="KEY=VALUE", help="a keyword of gymnasium.make (JSON value), e.g. "
                   "episode_steps=10; repeatable")
    p.add_argument("--out", default="runs/ladder/{env}.json",
                   help="the JSON file ({env}: the env id)")
    p.add_argument("--plot", action="store_true", help="write the bar chart")
    p.add_argument("--plot-path", default=None,
                   help="default out/ladder_<env>.png (ladder_all.png for --env all); "
                   "docs/img/... for the charts of the docs")
    p.add_argument("--variants", action="store_true",
                   help="also run other oracle budgets and the sampling planner (slow)")
    p.add_argument("--planner-gate", type=float, default=PLANNER_GATE,
                   help="standard errors a planner's candidate must clear over the searched "
                   "controller's action (a negative value: no gate)")
    p.add_argument("--planner-futures", type=int, default=PLANNER_FUTURES,
                   help="the planner's fresh random futures per candidate (>= 1; its cost "
                   "grows with them)")
    p.add_argument("--check", action="store_true",
                   help="exit 1 if the means are not ordered as the ladder's rows")
    p.add_argument("--table", nargs="+", type=Path, metavar="JSON",
                   help="run nothing: print one Markdown table of the ladders in these JSON "
                   "files (written by --out)")
    a = p.parse_args(argv)
    try:  # (every argument checked before any work: one line, exit 2)
        if a.table:
            results = [_load_ladder(f) for f in a.table]
            try:
                tables = summary_table(results), aggregate_table(results)
            except (ValueError, KeyError, TypeError, IndexError) as e:
                raise usage("--table", f"not ladders' JSON ({type(e).__name__}: {e})") from None
            path = _check_plot_path(a.plot_path, "ladder_all.png") if a.plot else None
        else:
            plan = check_args(a)
    except UsageError as e:
        p.error(str(e))
    if a.table:
        print(tables[0])
        print("\nAcross the tasks (normalised per task: random 0, searched controller 1; "
              "IQM of the task means, interval over seeds within tasks):\n")
        print(tables[1])
        if path is not None:  # (the chart of these files, nothing run)
            print(f"wrote {plot(results, path)}")
        return 0
    envs, eval_seeds, search_seeds = plan["envs"], plan["eval_seeds"], plan["search_seeds"]
    env_kwargs, gate = plan["env_kwargs"], plan["gate"]
    date = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    cmd = "python benchmarks/ladder.py " + " ".join(sys.argv[1:] if argv is None else argv)
    results, ok = [], True
    for env_id in envs:
        t0 = time.perf_counter()
        res = run_task(env_id, eval_seeds, search_seeds, env_kwargs, a.replan_every,
                       a.horizon, log=lambda s: print(s, file=sys.stderr, flush=True),
                       planner_futures=a.planner_futures, planner_gate=gate)
        res.update(date=date, machine=machine(), versions=versions(), command=cmd,
                   total_seconds=time.perf_counter() - t0)
        res["table"] = table(res)
        if a.variants:
            res["oracle_variants"] = run_variants(
                res, log=lambda s: print(s, file=sys.stderr, flush=True))
            res["variants_table"] = variants_table(res)
        out = plan["outs"][env_id]
        out.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(out, json.dumps(res, indent=2) + "\n")  # (whole or as it was)
        print(f"\n## {env_id}\n\n{res['table']}\n")
        order = " < ".join(LADDER)
        print(f"ordered {order}: {'yes' if res['ordered'] else 'NO'}; separated by their "
              f"CIs: {', '.join(s['step'] for s in res['ladder'] if s['separated']) or 'none'}")
        for who in ("planner", "oracle"):
            b = res[f"{who}_budget"]
            print(f"{who} budget: {b['candidates_per_replan']:.1f} candidates per re-plan x "
                  f"{b['futures_per_candidate']} future(s), every {b['replan_every']} steps, "
                  f"rollouts to {b['horizon']}: {b['simulated_steps_per_episode']:.0f} "
                  f"simulated env steps per episode ({b['simulated_steps_per_env_step']:.0f} "
                  f"per step), {seconds(b['seconds_per_episode'])} per episode")
        print(f"seeds {eval_seeds[0]}..{eval_seeds[-1]} (search {search_seeds[0]}.."
              f"{search_seeds[-1]}), {date}, {res['machine']}, {res['total_seconds']:.0f} s; "
              f"wrote {out}")
        if a.variants:
            print(f"\n{res['variants_table']}\n")
        ok &= res["ordered"]
        results.append(res)
    if plan["plot_path"] is not None:
        print(f"wrote {plot(results, plan['plot_path'])}")
    return 1 if a.check and not ok else 0


if __name__ == "__main__":
    raise SystemExit(main())
