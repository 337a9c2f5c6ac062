"""Search a task's controller along every control: CMA-ES over ScheduleController's parameters.

The family (:class:`discgym.searched.ScheduleController`): a kT setpoint profile over the
episode held by the thermostats' heating law, a wall profile, a feed level and a stop time
per feed, the setpoint's response to the inlet temperature. CMA-ES (the ``cma`` library,
fixed seed: reproducible) works on the parameters mapped to [0, 1] (log kT for the
setpoints), starting from the task's hand-written controller where the family holds it
(``DiscFlow-v0``'s flow thermostat, ``DiscEconomic-v0``'s band thermostat) or from the
family's defaults; each candidate is scored
by its mean return on the tuning seeds ``--tune-seeds FIRST N`` (3000-3047 by default:
disjoint from the thermostats' tuning seeds 500-739 and the evaluation seeds 1000-1299 and
2000-2299), a whole generation in one native vector env (one reactor per candidate and seed,
bit for bit the single env). The search stops before a generation would pass
``--budget-steps`` env steps. The best ``--refine K`` candidates (and CMA's final mean) are
then scored on ``N`` more seeds (after the tuning seeds); the pick is the best mean over all
the tuning seeds it met.

``--compare`` then scores the pick and the task's hand-written controller (its ladder's,
``discgym.baselines.TASK_BASELINES``) on the evaluation seeds ``--eval-seeds`` (and
``--also-seeds``); on ``DiscFlow-v0`` also the reviewer's kind of schedule, four parameters (a
constant setpoint, one feed stop for every feed, the wall's start and end, linear in between)
picked by a 40-point grid on the same tuning seeds with the same refine stage: means and
paired differences with 95% BCa intervals (:func:`discgym.baselines.mean_ci`,
:func:`~discgym.baselines.paired_difference`).

Writes the pick, the history of every generation, the budget spent (env steps, episodes, wall
and CPU seconds) and the comparison as JSON to ``--out`` (default ``out/search_<env>.json``,
untracked). One process.

Run:  python benchmarks/search_controller.py --env DiscFlow-v0 --budget-steps 60000 \
          --tune-seeds 3000 8 --refine 2 16   (6 generations of 88 episodes)
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

import discgym  # noqa: F401  (registers the tasks)
from discgym.baselines import TASK_BASELINES, mean_ci, paired_difference, run_episodes
from discgym.searched import HELD, ScheduleController, flow_thermostat_params, run_batch
from discgym.tasks import TASKS

ROOT = Path(__file__).resolve().parents[1]

#: Seed ranges the search's seeds must not meet: the evaluation seeds.
EVAL_RANGES = ((1000, 1299), (2000, 2299))
#: The hand-written controllers' tuning and validation seeds (avoided by default, not
#: refused: the search never sees the evaluation seeds either way).
THERMOSTAT_RANGE = (500, 739)

#: The reviewer's kind of schedule: a grid of 4 x 2 x 5 = 40 points.
GRID_SETPOINT = (3.4, 3.8, 4.3, 5.0)
GRID_STOP = (0.8, 0.9)
GRID_WALL = ((1.0, 1.0), (1.0, 0.0), (1.0, -1.0), (0.5, -0.5), (0.5, -1.0))


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (the project's command-line convention)
        self.exit(2, f"{self.prog}: error: {' '.join(str(message).split())}\n")


def _refuse(message: str):
    print(f"search_controller.py: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def four_parameter(env, setpoint, stop, wall_start, wall_end) -> dict:
    """The reviewer's kind of schedule in the family: kT ``setpoint`` all episode, every feed
    full until ``stop``, the wall from ``wall_start`` to ``wall_end``."""
    p = {k: v for k, v in flow_thermostat_params(env).items()}
    for k in p:
        if k.startswith("setpoint_"):
            p[k] = setpoint
        elif k.startswith("stop_"):
            p[k] = stop
    p["wall_0"], p["wall_1"], p["wall_2"] = wall_start, (wall_start + wall_end) / 2, wall_end
    return p


def _seeds(first, n):
    return list(range(first, first + n))


def _meets(seeds, lo, hi):
    return any(lo <= s <= hi for s in seeds)


def check_args(a) -> None:
    if a.budget_steps < 1:
        _refuse(f"--budget-steps: expected an int >= 1, got {a.budget_steps}")
    first, n = a.tune_seeds
    if first < 0 or n < 2:
        _refuse(f"--tune-seeds: expected FIRST >= 0 and N >= 2, got {first} {n}")
    k, m = a.refine
    if k < 0 or m < 0 or (k > 0) != (m > 0):
        _refuse(f"--refine: expected K, N both >= 1 (or both 0: no refine stage), got {k} {m}")
    search = _seeds(first, n + m)
    for lo, hi in EVAL_RANGES:
        if _meets(search, lo, hi):
            _refuse(f"--tune-seeds, --refine: the search's seeds {search[0]}-{search[-1]} "
                    f"meet the evaluation seeds {lo}-{hi}")
    if a.popsize is not None and a.popsize < 2:
        _refuse(f"--popsize: expected an int >= 2, got {a.popsize}")
    if not (math.isfinite(a.sigma0) and 0.0 < a.sigma0 <= 0.5):
        _refuse(f"--sigma0: expected a step in (0, 0.5] (the parameters live on [0, 1]), "
                f"got {a.sigma0}")
    if a.cma_seed < 1:
        _refuse(f"--cma-seed: expected an int >= 1 (cma draws a random seed for 0), got "
                f"{a.cma_seed}")
    if a.max_reactors < 1:
        _refuse(f"--max-reactors: expected an int >= 1, got {a.max_reactors}")
    if a.episode_steps is not None and a.episode_steps < 1:
        _refuse(f"--episode-steps: expected an int >= 1, got {a.episode_steps}")
    for flag, (f, m2) in (("--eval-seeds", a.eval_seeds), ("--also-seeds", a.also_seeds)):
        if f < 0 or (m2 != 0 and m2 < 2):
            _refuse(f"{flag}: expected FIRST >= 0 and N >= 2 (or 0: none), got {f} {m2}")
        if m2 and set(_seeds(f, m2)) & set(search):
            _refuse(f"{flag}: the evaluation seeds meet the search's seeds "
                    f"{search[0]}-{search[-1]}")
    out = Path(a.out) if a.out else None
    if out is not None and (out.is_dir() or not out.parent.is_dir()):
        _refuse(f"--out: {out} is a folder or its folder does not exist")


def _summary(r) -> dict:
    return mean_ci(r).as_dict()


def _write(path: Path, data: dict) -> None:
    tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)  # complete or absent


def main(argv=None) -> int:
    p = _Parser(description=__doc__.split("\n\n")[0])
    p.add_argument("--env", required=True, choices=sorted(TASKS), help="the task")
    p.add_argument("--budget-steps", type=int, required=True,
                   help="env steps the CMA-ES stage may spend (a generation costs popsize x "
                        "tuning seeds x episode steps)")
    p.add_argument("--tune-seeds", type=int, nargs=2, default=(3000, 48), metavar=("FIRST", "N"))
    p.add_argument("--refine", type=int, nargs=2, default=(5, 100), metavar=("K", "N"),
                   help="re-score the best K candidates and CMA's mean on N more seeds")
    p.add_argument("--popsize", type=int, default=None, help="CMA-ES population (default: "
                   "cma's, 4 + 3 ln P)")
    p.add_argument("--sigma0", type=float, default=0.1, help="CMA-ES initial step on [0, 1]")
    p.add_argument("--cma-seed", type=int, default=1)
    p.add_argument("--max-reactors", type=int, default=1024,
                   help="reactors per vector env (memory)")
    p.add_argument("--compare", action="store_true",
                   help="score the pick and the task's hand-written controller on the "
                        "evaluation seeds (DiscFlow-v0: the reviewer's 4-parameter schedule "
                        "too)")
    p.add_argument("--eval-seeds", type=int, nargs=2, default=(1000, 300), metavar=("FIRST", "N"))
    p.add_argument("--also-seeds", type=int, nargs=2, default=(2000, 300),
                   metavar=("FIRST", "N"))
    p.add_argument("--episode-steps", type=int, default=None, help="(tests) shorter episodes")
    p.add_argument("--out", default=None, help="the JSON (default out/search_<env>.json)")
    a = p.parse_args(argv)
    check_args(a)
    import cma
    import gymnasium as gym

    out = Path(a.out) if a.out else ROOT / "out" / f"search_{a.env}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    env_kwargs = {} if a.episode_steps is None else {"episode_steps": a.episode_steps}
    env = gym.make(a.env, **env_kwargs)
    steps = env.unwrapped.config.episode_steps
    names = ScheduleController.names(env)
    # (from the task's hand-written controller where the family holds it exactly)
    start = HELD[a.env](env) if a.env in HELD else ScheduleController.defaults(env)
    x0 = np.array([start[k] for k in names])
    tune = _seeds(*a.tune_seeds)
    more = _seeds(tune[-1] + 1, a.refine[1])
    opts = {"bounds": [0.0, 1.0], "seed": a.cma_seed, "verbose": -9}
    if a.popsize is not None:
        opts["popsize"] = a.popsize
    es = cma.CMAEvolutionStrategy(ScheduleController.to_unit(env, x0), a.sigma0, opts)
    gen_cost = es.popsize * len(tune) * steps
    print(f"{a.env}: CMA-ES on {len(names)} parameters ({', '.join(names)}), popsize "
          f"{es.popsize}, sigma0 {a.sigma0}, seed {a.cma_seed}; tuning seeds {tune[0]}-"
          f"{tune[-1]}; {gen_cost} env steps per generation, budget {a.budget_steps}",
          flush=True)
    t0, c0 = time.perf_counter(), time.process_time()
    spent = 0
    start_ret = run_batch(a.env, x0[None], tune, env_kwargs, a.max_reactors)[0]
    spent += len(tune) * steps
    print(f"start: {start_ret.mean():.4f} on the tuning seeds", flush=True)
    evaluated = [(float(start_ret.mean()), x0.tolist())]
    history = []
    while spent + gen_cost <= a.budget_steps:
        Z = es.ask()
        X = ScheduleController.from_unit(env, np.array(Z))
        R = run_batch(a.env, X, tune, env_kwargs, a.max_reactors).mean(axis=1)
        spent += gen_cost
        es.tell(Z, (-R).tolist())
        evaluated += [(float(r), x.tolist()) for r, x in zip(R, X)]
        best = max(evaluated, key=lambda e: e[0])
        history.append({"generation": len(history) + 1, "env_steps": spent,
                        "seconds": time.perf_counter() - t0, "best": best[0],
                        "generation_best": float(R.max()), "generation_mean": float(R.mean()),
                        "sigma": float(es.sigma)})
        print(f"gen {len(history):3d}  steps {spent:9d}  {time.perf_counter() - t0:7.0f} s  "
              f"best {best[0]:.4f}  this gen {R.max():.4f} / mean {R.mean():.4f}  "
              f"sigma {es.sigma:.3f}", flush=True)
    search_steps, search_seconds = spent, time.perf_counter() - t0
    # the refine stage: the best K distinct candidates and CMA's final mean on more seeds
    order = sorted(evaluated, key=lambda e: -e[0])
    top = []
    for r, x in order:
        if all(x != y for _, y in top):
            top.append((r, x))
        if len(top) == a.refine[0]:
            break
    mean_x = ScheduleController.from_unit(env, es.result.xfavorite)
    cand = [np.array(x) for _, x in top] + ([mean_x] if a.refine[0] else [])
    if a.refine[0]:
        r_tune = run_batch(a.env, np.array(cand), tune, env_kwargs, a.max_reactors).mean(1)
        r_more = run_batch(a.env, np.array(cand), more, env_kwargs, a.max_reactors).mean(1)
        spent += len(cand) * (len(tune) + len(more)) * steps
        both = (r_tune * len(tune) + r_more * len(more)) / (len(tune) + len(more))
        refine = [{"params": dict(zip(names, c.tolist())), "tune": float(t), "more": float(m),
                   "all": float(b)} for c, t, m, b in zip(cand, r_tune, r_more, both)]
        print(f"refine: the best {a.refine[0]} and CMA's mean on seeds {more[0]}-{more[-1]}:")
        for row in refine:
            print(f"  tune {row['tune']:.4f}  more {row['more']:.4f}  all {row['all']:.4f}")
        pick = cand[int(np.argmax(both))]
    else:
        refine, pick = [], np.array(top[0][1])
    pick_params = dict(zip(names, (float(v) for v in pick)))
    data = {
        "env": a.env, "command": "python benchmarks/search_controller.py "
        + " ".join(sys.argv[1:] if argv is None else argv),
        "names": names, "bounds": ScheduleController.bounds(env), "start": dict(start),
        "start_return": float(start_ret.mean()), "params": pick_params,
        "tune_seeds": [tune[0], tune[-1]],
        "refine_seeds": [more[0], more[-1]] if more else None,
        "cma": {"popsize": es.popsize, "sigma0": a.sigma0, "seed": a.cma_seed,
                "version": cma.__version__},
        "budget": {"budget_steps": a.budget_steps, "search_env_steps": search_steps,
                   "search_episodes": search_steps // steps, "search_seconds": search_seconds,
                   "env_steps": spent, "episodes": spent // steps,
                   "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0},
        "history": history, "refine": refine,
    }
    print(f"pick: {pick_params}")
    print(f"budget: {spent} env steps ({spent // steps} episodes) in "
          f"{time.perf_counter() - t0:.0f} s wall, {time.process_time() - c0:.0f} s CPU",
          flush=True)
    if a.compare:
        data["compare"] = compare(a, env, pick, tune, more, env_kwargs)
    _write(out, data)
    print(f"wrote {out}")
    return 0


def compare(a, env, pick, tune, more, env_kwargs) -> dict:
    """The pick and the task's hand-written controller (``TASK_BASELINES``) on the evaluation
    seeds; on ``DiscFlow-v0`` also the reviewer's kind of schedule (grid on the tuning seeds,
    the same refine stage)."""
    rule = TASK_BASELINES[a.env].controller_name
    res: dict = {"hand_written": rule}
    batch = {"searched": pick}
    pairs = [("searched", rule)]
    if a.env == "DiscFlow-v0":
        batch["schedule4"] = _reviewer_schedule(a, env, tune, more, env_kwargs, res)
        pairs += [("schedule4", rule), ("searched", "schedule4")]
    for label, (first, n) in (("eval", a.eval_seeds), ("also", a.also_seeds)):
        if not n:
            continue
        seeds = _seeds(first, n)
        R = run_batch(a.env, np.array(list(batch.values())), seeds, env_kwargs, a.max_reactors)
        ret = dict(zip(batch, R))
        # the hand-written controller as the ladder runs it: one env per seed
        ret[rule] = run_episodes(a.env, TASK_BASELINES[a.env].controller, seeds,
                                 env_kwargs).returns
        diffs = {f"{x} - {y}": paired_difference(ret[x], ret[y]).as_dict() for x, y in pairs}
        res[label] = {"seeds": [seeds[0], seeds[-1]],
                      "mean": {c: _summary(r) for c, r in ret.items()},
                      "difference": diffs, "returns": {c: r.tolist() for c, r in ret.items()}}
        print(f"seeds {seeds[0]}-{seeds[-1]}:")
        for c, r in ret.items():
            print(f"  {c:22s} {mean_ci(r).text()}")
        for d, s in diffs.items():
            print(f"  {d:40s} {s['value']:+.3f} [{s['low']:+.3f}, {s['high']:+.3f}]",
                  flush=True)
    return res


def _reviewer_schedule(a, env, tune, more, env_kwargs, res) -> np.ndarray:
    """DiscFlow-v0: the 4-parameter schedule picked by a 40-point grid on the tuning seeds."""
    names = ScheduleController.names(env)
    t0, c0 = time.perf_counter(), time.process_time()

    def vec(p):
        return np.array([p[k] for k in names])

    grid = list(itertools.product(GRID_SETPOINT, GRID_STOP, GRID_WALL))
    G = np.array([vec(four_parameter(env, sp, st, w0, w1)) for sp, st, (w0, w1) in grid])
    r_tune = run_batch(a.env, G, tune, env_kwargs, a.max_reactors).mean(1)
    k = a.refine[0]
    if k:
        top = np.argsort(-r_tune, kind="stable")[:k]
        r_more = run_batch(a.env, G[top], more, env_kwargs, a.max_reactors).mean(1)
        both = (r_tune[top] * len(tune) + r_more * len(more)) / (len(tune) + len(more))
        best = int(top[int(np.argmax(both))])
    else:
        best = int(np.argmax(r_tune))
    sp, st, (w0, w1) = grid[best]
    reviewer = {"setpoint": sp, "stop": st, "wall_start": w0, "wall_end": w1}
    grid_seconds, grid_cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"the reviewer's kind of schedule: {len(grid)}-point grid on seeds {tune[0]}-"
          f"{tune[-1]} (+ refine): {reviewer} ({r_tune[best]:.4f} on the tuning seeds; "
          f"{grid_seconds:.0f} s wall, {grid_cpu:.0f} s CPU)", flush=True)
    res.update({"reviewer_grid": {"setpoint": list(GRID_SETPOINT), "stop": list(GRID_STOP),
                                  "wall": [list(w) for w in GRID_WALL]},
                "reviewer_pick": reviewer, "grid_seconds": grid_seconds, "grid_cpu": grid_cpu})
    return G[best]


if __name__ == "__main__":
    sys.exit(main())
