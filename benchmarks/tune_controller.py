"""Tune a task's hand-written controller: a two-stage grid search of its keyword arguments.

Every combination of the values given (``--grid name=v1,v2,...``, one per argument) is
scored on the tuning seeds 500 .. 500 + ``--seeds`` - 1; the best ``--refine K`` of them
are scored again on ``N`` more seeds (the ones after), and the one with the best mean over
all the tuning seeds it met is the pick. The second stage is there because over many
settings and few seeds the first stage's winner is partly luck (docs/agents.md, "A stronger
bar"). The pick and the controller's current defaults (or the ``--against`` settings) are
then compared on the evaluation seeds 1000 .. (``--eval-seeds``): their means and the
paired difference with its 95% BCa interval.

``DiscFlow-v0``'s flow thermostat was tuned so (docs/tasks.md):

    python benchmarks/tune_controller.py --env DiscFlow-v0 \
        --grid setpoint=2.6,3.0,3.4,3.8,4.3,5.0 wall=-1,-0.6,-0.2,0.2,0.6,1 --refine 6 200 \
        --against setpoint=3.0

Run:  python benchmarks/tune_controller.py --env DiscFlow-v0 --grid setpoint=3.4,3.8 (~20 s)
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from functools import partial

import numpy as np

import discgym  # noqa: F401  (registers the tasks)
from discgym.baselines import mean_ci, paired_difference, run_episodes
from discgym.controllers import controller_for
from discgym.tasks import TASKS

TUNE_FIRST = 500
EVAL_FIRST = 1000


def _factory(kwargs, env):
    return controller_for(env, **kwargs)


def score(env_id: str, kwargs: dict, seeds, env_kwargs=None) -> np.ndarray:
    """The controller's return on each seed, with ``kwargs``."""
    return run_episodes(env_id, partial(_factory, kwargs), seeds, env_kwargs).returns


def parse_grid(items, flag="--grid") -> dict:
    """``["a=1,2", "b=x"]`` -> ``{"a": (1.0, 2.0), "b": ("x",)}`` (numbers where they parse)."""
    grid = {}
    for item in items:
        name, sep, values = item.partition("=")
        if not sep or not name or not values:
            raise SystemExit(f"{flag}: expected name=v1,v2,..., got {item!r}")
        vals = []
        for v in values.split(","):
            try:
                vals.append(float(v))
            except ValueError:
                vals.append(v)
        grid[name] = tuple(vals)
    return grid


def _score_all(env_id, settings, seeds, workers, env_kwargs=None):
    with ProcessPoolExecutor(workers) as ex:
        return list(ex.map(partial(score, env_id, env_kwargs=env_kwargs), settings,
                           [seeds] * len(settings)))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--env", required=True, choices=sorted(TASKS), help="the task")
    p.add_argument("--grid", nargs="+", required=True, metavar="NAME=V1,V2",
                   help="the controller's keyword arguments and the values to try")
    p.add_argument("--seeds", type=int, default=40, help="first-stage tuning seeds (from 500)")
    p.add_argument("--refine", type=int, nargs=2, default=(5, 100), metavar=("K", "N"),
                   help="re-score the best K settings on N more tuning seeds")
    p.add_argument("--eval-seeds", type=int, default=100,
                   help="evaluation seeds (from 1000) for the pick against the defaults")
    p.add_argument("--against", nargs="*", default=[], metavar="NAME=V",
                   help="the settings the pick is compared with (default: the controller's "
                        "defaults)")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--episode-steps", type=int, default=None, help="(tests) shorter episodes")
    a = p.parse_args(argv)
    grid = parse_grid(a.grid)
    against = parse_grid(a.against, "--against")
    if any(len(v) != 1 for v in against.values()):
        raise SystemExit(f"--against: one value per argument, got {a.against}")
    against = {k: v[0] for k, v in against.items()}
    k_best, n_more = a.refine
    if a.seeds < 1 or k_best < 1 or n_more < 0 or a.eval_seeds < 2:
        raise SystemExit("--seeds, --refine K must be >= 1, N >= 0, --eval-seeds >= 2")
    if TUNE_FIRST + a.seeds + n_more > EVAL_FIRST:
        raise SystemExit("tuning seeds would run into the evaluation seeds (1000 on)")
    env_kwargs = None if a.episode_steps is None else {"episode_steps": a.episode_steps}
    names = list(grid)
    settings = [dict(zip(names, vals)) for vals in itertools.product(*grid.values())]
    t0 = time.perf_counter()
    s1 = list(range(TUNE_FIRST, TUNE_FIRST + a.seeds))
    r1 = _score_all(a.env, settings, s1, a.workers, env_kwargs)
    order = np.argsort([-r.mean() for r in r1], kind="stable")
    print(f"{a.env}: {len(settings)} settings on tuning seeds {s1[0]}-{s1[-1]}; the best:")
    for k in order[:max(k_best, 5)]:
        print(f"  {settings[k]}: {r1[k].mean():.4f}")
    top = [int(k) for k in order[:k_best]]
    s2 = list(range(s1[-1] + 1, s1[-1] + 1 + n_more))
    if n_more:
        r2 = _score_all(a.env, [settings[k] for k in top], s2, a.workers, env_kwargs)
        print(f"the best {k_best} on seeds {s2[0]}-{s2[-1]}, and over all {len(s1) + len(s2)}:")
        both = []
        for k, r in zip(top, r2):
            both.append(np.concatenate([r1[k], r]).mean())
            print(f"  {settings[k]}: {r.mean():.4f}, {both[-1]:.4f}")
        pick = settings[top[int(np.argmax(both))]]
    else:
        pick = settings[top[0]]
    ev = list(range(EVAL_FIRST, EVAL_FIRST + a.eval_seeds))
    new, old = _score_all(a.env, [pick, against], ev, a.workers, env_kwargs)
    print(f"pick {pick}; on evaluation seeds {ev[0]}-{ev[-1]}:")
    print(f"  pick     {mean_ci(new).text()}")
    label = str(against) if against else "defaults"
    print(f"  {label} {mean_ci(old).text()}")
    print(f"  pick - {label} {paired_difference(new, old).text()}")
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
