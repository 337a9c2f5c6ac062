"""The learners across the tasks: each task's evaluation put on one scale, and one table and
one figure over all of them.

    python agents/aggregate.py --evaluation results/*/evaluation.json \
        --ladder docs/data/ladder_*.json --out results/aggregate

Each ``--evaluation`` is an ``evaluation.json`` written by ``agents/evaluate.py``, one per
task, holding the task's baselines and its trained runs (several training seeds of each
learner: ``--run A B C ...``). Every return is mapped to the task's normalised score: the
mean of uniform random actions 0, the searched controller's 1 (``discgym.baselines.
normalised_scores``), on the same evaluation seeds.

- A learner (a :func:`evaluate.variant`: an algorithm and its hyperparameter folder) scores,
  on each task, one number per training run: the run's mean normalised score over the
  evaluation seeds. Its aggregate is the interquartile mean (IQM) of those numbers over the
  tasks, with the stratified bootstrap interval over runs of Agarwal et al. (2021), as
  ``rliable`` computes it (``discgym.baselines.aggregate_iqm``): the interval is over
  training seeds, the randomness a reader's own run would meet.
- A controller (best constant, the simple rule, the searched controller) has no training
  seed: its scores are per evaluation seed, and its interval is over those.
- With ``--ladder`` (the JSON files of ``benchmarks/ladder.py``), the planner and the oracle
  join, each on its ladder's seeds and mapped with that ladder's random and searched
  controller.

Writes ``aggregate.json`` (every score), ``aggregate.md`` (the table, the per-task cells and
the budgets: each learner's training steps and wall time beside the search that found the
task's controller) and ``aggregate.png`` into ``--out``. Every argument is checked before
anything is written; a bad one is refused in one line, exit status 2.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from argcheck import usage, write_text_atomic  # noqa: E402

CONTROLLERS = (("best constant", "best constant"), ("hand-written", "simple rule"),
               ("searched", "searched controller"))
REFERENCES = (("planner", "planner (no foresight)"), ("oracle", "oracle (foresees every "
                                                                 "random draw: the ceiling)"))
NAMES = {"ppo": "PPO", "ppo, residual_searched": "PPO correcting the searched controller",
         "ppo, residual": "PPO correcting the simple rule", "sac": "SAC",
         "recurrent_ppo": "RecurrentPPO"}


@dataclass
class Args:
    """Aggregation arguments; each is also a flag."""

    evaluation: list[Path] = field(default_factory=list)
    """evaluation.json files of agents/evaluate.py, one per task"""
    ladder: list[Path] = field(default_factory=list)
    """ladder JSON files of benchmarks/ladder.py (the planner's and the oracle's rows)"""
    out: Path = Path("results/aggregate")
    """folder for aggregate.json, aggregate.md and aggregate.png"""


def _load(path: Path, name: str, keys: set) -> dict:
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise usage(name, f"no file {path}") from None
    except (OSError, ValueError) as e:
        raise usage(name, f"{path} is not readable JSON ({e})") from None
    if not isinstance(data, dict) or not keys <= set(data):
        raise usage(name, f"{path} has no {', '.join(sorted(keys))} (not written by "
                          f"{'agents/evaluate.py' if name == 'evaluation' else 'ladder.py'})")
    return data


def _check_scale(data: dict, path: Path, name: str) -> None:
    rand, top = (np.mean(data["policies"][k]["returns"]) for k in ("random", "searched"))
    if not top > rand:
        raise usage(name, f"{path}: the searched controller ({top:.4g}) is not above random "
                          f"({rand:.4g}) on its seeds: no scale to normalise on")


def check_args(a: Args) -> tuple[list, dict]:
    """The evaluations (one per task, each with the random and searched rows) and the
    ladders by task, read and checked before anything is written."""
    if not a.evaluation:
        raise usage("evaluation", "name at least one evaluation.json of agents/evaluate.py")
    evals = [_load(p, "evaluation", {"env_id", "policies"}) for p in a.evaluation]
    tasks = [e["env_id"] for e in evals]
    for k, t in enumerate(tasks):
        if t in tasks[:k]:
            raise usage("evaluation", f"two evaluations of {t} ({a.evaluation[tasks.index(t)]}"
                                      f" and {a.evaluation[k]}): give one per task, with all "
                                      f"its runs")
        missing = {"random", "searched"} - set(evals[k]["policies"])
        if missing:
            raise usage("evaluation", f"{a.evaluation[k]} has no {', '.join(sorted(missing))}"
                                      f" row")
        _check_scale(evals[k], a.evaluation[k], "evaluation")
    ladders = {}
    for p in a.ladder:
        d = _load(p, "ladder", {"env_id", "policies"})
        if d["env_id"] in ladders:
            raise usage("ladder", f"two ladders of {d['env_id']}")
        if not {"random", "searched"} <= set(d["policies"]):
            raise usage("ladder", f"{p} has no random and searched rows")
        _check_scale(d, p, "ladder")
        ladders[d["env_id"]] = d
    out = Path(a.out)
    if out.exists() and not out.is_dir():
        raise usage("out", f"{out} exists and is not a folder")
    return evals, ladders


def _scores(rows: dict, key: str) -> np.ndarray:
    from discgym.baselines import normalised_scores

    r = rows[key]["returns"]
    n = len(r)
    return normalised_scores(r, rows["random"]["returns"][:n], rows["searched"]["returns"][:n])


def normalise(evals: list, ladders: dict) -> dict:
    """``{policy: {task: scores}}``: a learner's per-run means, a controller's or a
    reference's per-seed scores; plus, for each learner, its runs' training budgets."""
    from evaluate import variant

    out: dict = {"tasks": [e["env_id"] for e in evals], "policies": {}, "budgets": {}}
    pol = out["policies"]
    for e in evals:
        task, rows = e["env_id"], e["policies"]
        for key, _ in CONTROLLERS:
            if key in rows:
                pol.setdefault(key, {})[task] = _scores(rows, key).tolist()
        for name, row in rows.items():
            if "algo" not in row or "pooled" in row:
                continue
            kind = row.get("variant") or variant({"algo": row["algo"]})
            pol.setdefault(kind, {}).setdefault(task, []).append(
                float(np.mean(_scores(rows, name))))
            t = row.get("train") or {}
            out["budgets"].setdefault(kind, {}).setdefault(task, []).append(
                {"env_steps": t.get("env_steps", t.get("timesteps")),
                 "wall_seconds": t.get("wall_seconds")})
        lad = ladders.get(task)
        for key, _ in REFERENCES:
            if lad is not None and key in lad["policies"]:
                pol.setdefault(key, {})[task] = _scores(lad["policies"], key).tolist()
    return out


def learners(norm: dict) -> list:
    return [k for k in norm["policies"] if k not in dict(CONTROLLERS) and
            k not in dict(REFERENCES)]


def label(key: str) -> str:
    return dict(CONTROLLERS + REFERENCES).get(key) or NAMES.get(key, key)


def aggregate(norm: dict) -> dict:
    """Each policy's IQM over the tasks it was measured on, with its stratified interval
    (none, ``low`` and ``high`` None, where a task has a single run: nothing to resample)."""
    from scipy import stats

    from discgym.baselines import aggregate_iqm

    out = {}
    for k, v in norm["policies"].items():
        xs = list(v.values())
        if min(len(x) for x in xs) > 1:
            out[k] = {"tasks": list(v), **aggregate_iqm(xs).as_dict()}
        else:
            out[k] = {"tasks": list(v), "low": None, "high": None, "method": None,
                      "value": float(stats.trim_mean(np.concatenate(xs), 0.25))}
    return out


def _order(norm: dict) -> list:
    keys = [k for k, _ in CONTROLLERS if k in norm["policies"]]
    keys += learners(norm)
    return keys + [k for k, _ in REFERENCES if k in norm["policies"]]


def table(norm: dict, agg: dict) -> str:
    tasks = norm["tasks"]
    short = [t.removesuffix("-v0").removeprefix("Disc") for t in tasks]
    lines = ["| policy | IQM over the tasks [95% CI] | " + " | ".join(short) + " |",
             "|---|---|" + "---|" * len(tasks)]
    for k in _order(norm):
        a = agg[k]
        cells = []
        for t in tasks:
            x = norm["policies"][k].get(t)
            if x is None:
                cells.append("")
            elif k in learners(norm):  # (the runs' mean, and their range)
                cells.append(f"{np.mean(x):.3f} ({min(x):.3f} - {max(x):.3f}, {len(x)} runs)"
                             if len(x) > 1 else f"{x[0]:.3f} (1 run)")
            else:
                cells.append(f"{np.mean(x):.3f}")
        ci = (f"{a['value']:.3f} [{a['low']:.3f}, {a['high']:.3f}]" if a["low"] is not None
              else f"{a['value']:.3f} (no interval: a task with one run)")
        if len(a["tasks"]) < len(tasks):
            ci += f" ({len(a['tasks'])} task{'s' * (len(a['tasks']) > 1)})"
        lines.append(f"| {label(k)} | {ci} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def budget_table(norm: dict) -> str:
    """Each learner's training beside the search that found each task's controller."""
    from discgym.searched import SEARCHED

    tasks = norm["tasks"]
    short = [t.removesuffix("-v0").removeprefix("Disc") for t in tasks]
    lines = ["| budget: env steps, wall time | " + " | ".join(short) + " |",
             "|---|" + "---|" * len(tasks)]

    def cell(steps, secs):
        return f"{steps / 1e6:.2f} M, {secs / 60:.0f} min"

    row = [cell(SEARCHED[t]["budget"]["env_steps"], SEARCHED[t]["budget"]["wall_seconds"])
           if t in SEARCHED else "" for t in tasks]
    lines.append("| searched controller: CMA-ES and re-scoring | " + " | ".join(row) + " |")
    for k in learners(norm):
        cells = []
        for t in tasks:
            b = [x for x in norm["budgets"][k].get(t, []) if x["env_steps"] is not None]
            cells.append(cell(np.mean([x["env_steps"] for x in b]),
                              np.mean([x["wall_seconds"] for x in b])) if b else "")
        lines.append(f"| {label(k)}: training, per run | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot(norm: dict, agg: dict, path: Path) -> Path:
    """Per task, each policy's mean normalised score (a dot per run for the learners), and
    the IQM over the tasks with its stratified interval."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = _order(norm)
    tasks = norm["tasks"]
    groups = [t.removesuffix("-v0") for t in tasks] + ["IQM over\nthe tasks"]
    width = 0.8 / len(keys)
    colors = plt.get_cmap("tab10")
    fig, ax = plt.subplots(figsize=(max(8.0, 1.6 * len(groups) + 4), 4.2), dpi=110)
    for i, k in enumerate(keys):
        x0 = np.arange(len(groups)) - 0.4 + (i + 0.5) * width
        vals = [np.mean(norm["policies"][k][t]) if t in norm["policies"][k] else np.nan
                for t in tasks]
        a = agg[k]
        ax.bar(x0[:-1], vals, width, color=colors(i), label=label(k))
        err = (None if a["low"] is None else
               [[a["value"] - a["low"]], [a["high"] - a["value"]]])
        ax.bar(x0[-1], a["value"], width, color=colors(i), yerr=err, capsize=3)
        if k in learners(norm):
            for j, t in enumerate(tasks):
                runs = norm["policies"][k].get(t, [])
                ax.plot(np.full(len(runs), x0[j]), runs, "k.", ms=4)
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xticks(np.arange(len(groups)), groups, fontsize=8)
    ax.set_ylabel("normalised score (random 0, searched 1)")
    ax.set_title("Learners and controllers across the tasks (dots: training runs; "
                 "interval: stratified 95% bootstrap)", fontsize=9)
    lo = min(np.nanmin([np.mean(v) for p in norm["policies"].values() for v in p.values()]),
             0.0)
    ax.set_ylim(max(lo - 0.05, -0.5), None)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    import argcheck

    a = argcheck.parse(Args, argv, description=__doc__.split("\n\n")[0])
    evals, ladders = check_args(a)
    norm = normalise(evals, ladders)
    agg = aggregate(norm)
    seeds = {e["env_id"]: [e["eval_seeds"][0], e["eval_seeds"][-1]] for e in evals}
    text = (f"Normalised scores (random 0, the searched controller 1) on each task's "
            f"evaluation seeds ({', '.join(f'{t} {s[0]}-{s[1]}' for t, s in seeds.items())})"
            f"; a learner's cell is its runs' mean (their range), its interval over training "
            f"runs, a controller's over evaluation seeds.\n\n{table(norm, agg)}\n\n"
            f"{budget_table(norm)}\n")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "aggregate.json", json.dumps(
        {"normalised": norm, "aggregate": agg, "eval_seeds": seeds,
         "sources": [str(p) for p in a.evaluation + a.ladder]}, indent=1) + "\n")
    write_text_atomic(out / "aggregate.md", text)
    print(text)
    print(f"wrote {out / 'aggregate.md'}, {plot(norm, agg, out / 'aggregate.png')}")
    return 0


if __name__ == "__main__":
    import argcheck

    argcheck.run(main)
