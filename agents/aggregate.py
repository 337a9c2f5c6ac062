"""The learners across the tasks: each task's evaluation put on one scale, and one table and
one figure over all of them.

    python agents/aggregate.py --evaluation results/*/evaluation.json \
        --ladder docs/data/ladder_Disc*.json --out results/aggregate

Each ``--evaluation`` is an ``evaluation.json`` written by ``agents/evaluate.py``, one per
task, holding the task's baselines and its trained runs (several training seeds of each
learner: ``--run A B C ...``). Every return is mapped to the task's normalised score: the
mean of uniform random actions 0, the searched controller's 1 (``discgym.baselines.
normalised_scores``), on the same evaluation seeds, which are required: a row's returns
are mapped with the references' means over that row's seeds. Every row this scores (the
controllers and each run) must be on the evaluation's ``eval_seeds``, those of its random
and searched rows; a ladder's planner and oracle on that ladder's ``eval_seeds``, those of
its own random and searched rows. A row on more, fewer or other seeds is refused (the rows
this does not score, evaluate.py's planner and oracle, may be on the first of the seeds,
as evaluate.py records them).

- A learner (an ``evaluate.variant``: an algorithm, its hyperparameter folder and its
  non-default training settings) scores, on each task, one number per training run: the
  run's mean normalised score over the evaluation seeds. Its aggregate is the interquartile
  mean (IQM) of those numbers over the tasks, with the stratified bootstrap interval over
  runs of Agarwal et al. (2021), as ``rliable`` computes it (``discgym.baselines.
  aggregate_iqm``): the interval is over training seeds, the randomness a reader's own run
  would meet. As in rliable, it needs the same number of runs on every task it was run on.
- A controller (best constant, the simple rule, the searched controller) has no training
  seed: it is a learner with one run per task, whose score is its mean over the evaluation
  seeds; its IQM is over the task means, its interval from resampling the evaluation seeds
  within each task (``discgym.baselines.aggregate_task_means``; the searched controller is
  1 and random 0 exactly).
- With ``--ladder`` (the JSON files of ``benchmarks/ladder.py``; its
  ``ladder_variants_*.json`` are another kind), the planner and the oracle join as
  controllers do, each on its ladder's seeds and mapped with that ladder's random and
  searched controller.

Writes ``aggregate.json`` (every score), ``aggregate.md`` (the table, the per-task cells and
the budgets: each learner's training steps and wall time beside the search that found the
task's controller) and ``aggregate.png`` into ``--out``. Every argument is checked before
anything is written, each file's whole structure included (the fields this reads, of the
kinds it reads: lists of finite returns, seeds that are integers each once, ...); a bad one
is refused in one line naming the file and the field, exit status 2.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
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


# ------------------------------------------------------------- what the files must hold
#
# A schema is one of: ``Is`` (a value passing a test), ``ListOf`` (a non-empty list whose
# every item passes a test), ``Record`` (an object with named fields, a name ending in "?"
# optional: absent or null, and a schema for every other key). :func:`_misfit` walks a file
# along one and names the first field that does not fit.


@dataclass(frozen=True)
class Is:
    what: str
    test: Callable


@dataclass(frozen=True)
class ListOf:
    what: str
    item: Callable
    unique: bool = False


@dataclass(frozen=True)
class Record:
    fields: dict
    rest: object = None


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _count(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool) and x >= 0


TEXT = Is("a string", lambda x: isinstance(x, str))
SEEDS = ListOf("a non-empty list of seeds (integers >= 0, each once)", _count, unique=True)
ROW = Record({
    "returns": ListOf("a non-empty list of finite numbers", _finite),
    "seeds?": SEEDS,  # (evaluate.py: a row on fewer seeds, its oracles', names them)
    "variant?": TEXT, "run?": TEXT,
    "train?": Record({"wall_seconds": Is("a number >= 0", lambda x: _finite(x) and x >= 0),
                      "env_steps?": Is("an integer >= 0", _count),
                      "timesteps?": Is("an integer >= 0", _count)})})
TASK_FILE = Record({  # (evaluate.py's evaluation.json and ladder.py's JSON alike)
    "env_id": Is("a task's id", lambda x: isinstance(x, str) and x != ""),
    "env_kwargs?": Is("an object", lambda x: isinstance(x, dict)),
    "eval_seeds": SEEDS,
    "policies": Record({"random": ROW, "searched": ROW}, rest=ROW)})


def _at(where: str, key: str) -> str:
    return f"{where}[{json.dumps(key)}]" if where else key


def _short(x) -> str:
    s = json.dumps(x)
    return s if len(s) <= 40 else s[:37] + "..."


def _misfit(value, schema, where: str = "") -> str | None:
    """The first field of ``value`` (named from ``where``) that does not fit ``schema``, in a
    refusal's words; None if all fit."""
    name = where or "the file"
    if isinstance(schema, Is):
        return None if schema.test(value) else f"{name} is not {schema.what} ({_short(value)})"
    if isinstance(schema, ListOf):
        if not isinstance(value, list) or not value:
            return f"{name} is not {schema.what} ({_short(value)})"
        for i, v in enumerate(value):
            if not schema.item(v):
                return f"{name} is not {schema.what} (item {i}: {_short(v)})"
        if schema.unique and len(set(value)) < len(value):
            twice = next(v for i, v in enumerate(value) if v in value[:i])
            return f"{name} is not {schema.what} ({twice} is there twice)"
        return None
    if not isinstance(value, dict):
        return f"{name} is not an object ({_short(value)})"
    named = {k.removesuffix("?"): (sub, k.endswith("?")) for k, sub in schema.fields.items()}
    for key, (sub, optional) in named.items():
        if key not in value or (optional and value[key] is None):
            if optional:
                continue
            return f"{_at(where, key)} is missing"
        bad = _misfit(value[key], sub, _at(where, key))
        if bad:
            return bad
    for key, v in value.items():
        if key not in named and schema.rest is not None:
            bad = _misfit(v, schema.rest, _at(where, key))
            if bad:
                return bad
    return None


def _load(path: Path, name: str) -> dict:
    """A task file, read and walked along :data:`TASK_FILE`."""
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise usage(name, f"no file {path}") from None
    except (OSError, ValueError) as e:
        raise usage(name, f"{path} is not readable JSON ({e})") from None
    bad = _misfit(data, TASK_FILE)
    if bad:
        kind = "agents/evaluate.py" if name == "evaluation" else "benchmarks/ladder.py"
        top = {k for k in TASK_FILE.fields if not k.endswith("?")}  # (another file's kind)
        hint = (f" (not written by {kind})" if not isinstance(data, dict) or
                not top <= set(data) else "")
        raise usage(name, f"{path}: {bad}{hint}")
    return data


def _seeds(data: dict, key: str) -> list:
    """The seeds of a row: those it names (evaluate.py's rows on fewer seeds), else the
    file's first, one per return."""
    row = data["policies"][key]
    if row.get("seeds") is not None:
        return row["seeds"]
    return data["eval_seeds"][:len(row["returns"])]


def _differ(a: list, b: list) -> str:
    """Two seed lists, briefly: their sizes and the first place they differ."""
    i = next((k for k, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    x, y = (s[i] if i < len(s) else "none" for s in (a, b))
    return (f"{len(a)} seed{'s' * (len(a) != 1)} against {len(b)}; the first difference, at "
            f"position {i}: {x} against {y}")


def _check_seeds(data: dict, path: Path, name: str, used: set) -> None:
    """Scores are per evaluation seed, mapped with the references' means on the same seeds:
    random and searched must be on every one of ``eval_seeds``, each row in ``used`` (those
    this scores) on exactly those, every other row (evaluate.py's oracle, say) on the first
    of them, as evaluate.py records such rows."""
    rows, seeds = data["policies"], data["eval_seeds"]
    for key, row in rows.items():  # (a seed for each return: its own, or eval_seeds')
        n, where = len(row["returns"]), f"policies[{json.dumps(key)}]"
        if row.get("seeds") is not None:
            given, m, fits = f'{where}["seeds"]', len(row["seeds"]), n == len(row["seeds"])
        else:
            given, m, fits = "eval_seeds", len(seeds), n <= len(seeds)
        if not fits:
            raise usage(name, f'{path}: {where}["returns"] holds {n} returns, {given} {m} '
                              f'seed{"s" * (m != 1)}')
    ref = _seeds(data, "random")
    for key in ["searched", *(k for k in rows if k in used)]:
        if _seeds(data, key) != ref:
            raise usage(name, f"{path}: policies[{json.dumps(key)}] is not on the seeds of "
                              f"the references random and searched it is normalised with "
                              f"({_differ(_seeds(data, key), ref)}): evaluate them on the "
                              f"same seeds")
    if ref != seeds:
        raise usage(name, f"{path}: the references random and searched are not on eval_seeds "
                          f"({_differ(ref, seeds)})")
    for key in rows:
        if _seeds(data, key) != seeds[:len(rows[key]["returns"])]:
            raise usage(name, f"{path}: policies[{json.dumps(key)}] is not on the first "
                              f"eval_seeds ({_differ(_seeds(data, key), seeds)})")


def _learner(row: dict) -> bool:
    """A trained run's row (evaluate.py's pooled rows of several runs are not)."""
    return "algo" in row and "pooled" not in row


def _check_scale(data: dict, path: Path, name: str) -> None:
    """Each row's seeds must give a scale: the searched controller above random on them."""
    rows = data["policies"]
    for key, row in rows.items():
        n = len(row["returns"])
        rand, top = (np.mean(rows[k]["returns"][:n]) for k in ("random", "searched"))
        if not top > rand:
            raise usage(name, f"{path}: the searched controller ({top:.4g}) is not above "
                              f"random ({rand:.4g}) on the seeds of {key!r}: no scale to "
                              f"normalise on")


def _variant(row: dict, path: Path) -> str:
    """A learner row's variant; rebuilt from its run folder for an evaluation.json written
    before evaluate.py recorded it."""
    from evaluate import run_info, variant

    if row.get("variant"):
        return row["variant"]
    if row.get("run") and Path(row["run"]).is_dir():
        return variant(run_info(Path(row["run"])))
    raise usage("evaluation", f"{path}: the row {row.get('label')!r} has no variant and its "
                              f"run folder is gone (an older evaluate.py): evaluate it again")


def check_args(a: Args) -> tuple[list, dict]:
    """The evaluations (one per task, each with the random and searched rows) and the
    ladders by task, read and checked before anything is written; each learner row gets its
    ``variant``."""
    if not a.evaluation:
        raise usage("evaluation", "name at least one evaluation.json of agents/evaluate.py")
    evals = [_load(p, "evaluation") for p in a.evaluation]
    tasks = [e["env_id"] for e in evals]
    for k, t in enumerate(tasks):
        if t in tasks[:k]:
            raise usage("evaluation", f"two evaluations of {t} ({a.evaluation[tasks.index(t)]}"
                                      f" and {a.evaluation[k]}): give one per task, with all "
                                      f"its runs")
        rows = evals[k]["policies"]
        scored = {key for key, row in rows.items() if key in dict(CONTROLLERS) or _learner(row)}
        _check_seeds(evals[k], a.evaluation[k], "evaluation", scored)
        _check_scale(evals[k], a.evaluation[k], "evaluation")
        for row in rows.values():
            if _learner(row):
                row["variant"] = _variant(row, a.evaluation[k])
    runs: dict = {}  # (rliable's stratified bootstrap: as many runs on each task)
    for e in evals:
        for row in e["policies"].values():
            if _learner(row):
                runs.setdefault(row["variant"], {}).setdefault(e["env_id"], 0)
                runs[row["variant"]][e["env_id"]] += 1
    for kind, by_task in runs.items():
        if len(set(by_task.values())) > 1:
            counts = ", ".join(f"{n} on {t}" for t, n in by_task.items())
            raise usage("evaluation", f"{kind}: {counts}: give each task the same number of "
                                      f"runs (training seeds)")
    ladders, where = {}, {}
    for p in a.ladder:
        d = _load(p, "ladder")
        if d["env_id"] in ladders:
            raise usage("ladder", f"two ladders of {d['env_id']} ({where[d['env_id']]} and {p})"
                                  f": give one per task")
        if d["env_id"] not in tasks:
            raise usage("ladder", f"{p} is a ladder of {d['env_id']}, which no --evaluation "
                                  f"has")
        e = evals[tasks.index(d["env_id"])]
        kw, kw_e = d.get("env_kwargs"), e.get("env_kwargs")
        if kw is not None and kw_e is not None and kw != kw_e:
            raise usage("ladder", f"{p} ran {d['env_id']} with {d['env_kwargs']}, its "
                                  f"evaluation with {e['env_kwargs']}: not one task")
        _check_seeds(d, p, "ladder", {k for k, _ in REFERENCES})
        _check_scale(d, p, "ladder")
        ladders[d["env_id"]], where[d["env_id"]] = d, p
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
    reference's per-seed scores; plus, for each learner, its runs' training budgets, and
    each ladder's seeds."""
    out: dict = {"tasks": [e["env_id"] for e in evals], "policies": {}, "budgets": {}}
    pol = out["policies"]
    for e in evals:
        task, rows = e["env_id"], e["policies"]
        for key, _ in CONTROLLERS:
            if key in rows:
                pol.setdefault(key, {})[task] = _scores(rows, key).tolist()
        for name, row in rows.items():
            if not _learner(row):
                continue
            kind = row["variant"]
            pol.setdefault(kind, {}).setdefault(task, []).append(
                float(np.mean(_scores(rows, name))))
            t = row.get("train") or {}
            out["budgets"].setdefault(kind, {}).setdefault(task, []).append(
                {"env_steps": t.get("env_steps", t.get("timesteps")),
                 "wall_seconds": t.get("wall_seconds")})
        lad = ladders.get(task)
        if lad is not None:
            out.setdefault("ladder_seeds", {})[task] = len(lad["policies"]["random"]["returns"])
        for key, _ in REFERENCES:
            if lad is not None and key in lad["policies"]:
                pol.setdefault(key, {})[task] = _scores(lad["policies"], key).tolist()
    return out


def learners(norm: dict) -> list:
    return [k for k in norm["policies"] if k not in dict(CONTROLLERS) and
            k not in dict(REFERENCES)]


def label(key: str) -> str:
    """A row's name: the controllers' and references' own; a learner's from its variant
    (its settings, ``k=v``, in brackets)."""
    if key in dict(CONTROLLERS + REFERENCES):
        return dict(CONTROLLERS + REFERENCES)[key]
    parts = key.split(", ")
    head = ", ".join(p for p in parts if "=" not in p)
    settings = [p for p in parts if "=" in p]
    return NAMES.get(head, head) + (f" ({', '.join(settings)})" if settings else "")


def aggregate(norm: dict) -> dict:
    """Each policy's IQM over the tasks it was measured on, with its interval: a learner's
    over its runs (stratified bootstrap over runs; none, ``low`` and ``high`` None, with a
    single run per task), a controller's or reference's over its task means."""
    from scipy import stats

    from discgym.baselines import aggregate_iqm, aggregate_task_means

    out = {}
    for k, v in norm["policies"].items():
        xs = list(v.values())
        if k not in learners(norm):
            a = aggregate_task_means(xs).as_dict()
            if np.isnan(a["low"]):  # (a task with one seed: no interval)
                a.update(low=None, high=None, method=None)
            out[k] = {"tasks": list(v), **a}
        elif min(len(x) for x in xs) > 1:
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
              else f"{a['value']:.3f} (no interval: one run per task)")
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
        extra = ", on top of the search" if "residual_searched" in k else ""
        lines.append(f"| {label(k)}: training, per run{extra} | " + " | ".join(cells) + " |")
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
    fig, ax = plt.subplots(figsize=(max(7.0, 1.4 * len(groups) + 2), 4.2), dpi=110)
    shown = [0.0]  # (every plotted value, for the axis: nothing clipped)
    for i, k in enumerate(keys):
        x0 = np.arange(len(groups)) - 0.4 + (i + 0.5) * width
        vals = [np.mean(norm["policies"][k][t]) if t in norm["policies"][k] else np.nan
                for t in tasks]
        a = agg[k]
        name = label(k)
        if len(a["tasks"]) < len(tasks):
            name += f" [IQM over {len(a['tasks'])} task{'s' * (len(a['tasks']) > 1)}]"
        if a["low"] is None:
            name += " [no interval: one run]"
        ax.bar(x0[:-1], vals, width, color=colors(i), label=name)
        err = (None if a["low"] is None else
               [[a["value"] - a["low"]], [a["high"] - a["value"]]])
        ax.bar(x0[-1], a["value"], width, color=colors(i), yerr=err, capsize=3)
        shown += [v for v in vals if np.isfinite(v)] + [a["value"]]
        shown += [] if a["low"] is None else [a["low"], a["high"]]
        if k in learners(norm):
            for j, t in enumerate(tasks):
                runs = norm["policies"][k].get(t, [])
                ax.plot(np.full(len(runs), x0[j]), runs, "k.", ms=4)
                shown += list(runs)
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xticks(np.arange(len(groups)), groups, fontsize=8)
    ax.set_ylabel("normalised score (random 0, searched 1)")
    ax.set_title("Across the tasks (dots: training runs)\n95% bootstrap intervals: a "
                 "learner's over its runs, a controller's over evaluation seeds", fontsize=8)
    pad = 0.03 * (max(shown) - min(shown))
    ax.set_ylim(min(shown) - pad, max(shown) + pad)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    fig.savefig(path, bbox_inches="tight")  # (the legend below the axes included)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    import argcheck

    a = argcheck.parse(Args, argv, description=__doc__.split("\n\n")[0])
    evals, ladders = check_args(a)
    norm = normalise(evals, ladders)
    agg = aggregate(norm)
    seeds = {e["env_id"]: [e["eval_seeds"][0], e["eval_seeds"][-1]] for e in evals}
    lad = norm.get("ladder_seeds", {})
    text = (f"Normalised scores (random 0, the searched controller 1) on each task's "
            f"evaluation seeds ({', '.join(f'{t} {s[0]}-{s[1]}' for t, s in seeds.items())})"
            + (f"; the planner and the oracle on their ladders' first seeds "
               f"({', '.join(f'{t} {n}' for t, n in lad.items())}), each mapped with its "
               f"ladder's random and searched controller" if lad else "")
            + f". A learner's cell is its runs' mean (their range); its IQM is over runs and "
            f"tasks, its interval over runs. A controller's IQM is over its task means, its "
            f"interval over evaluation seeds.\n\n{table(norm, agg)}\n\n"
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
