"""How much room DiscKinetics-v0 leaves above its adaptive thermostat, and whether a trained
policy reads the hidden kinetics.

DiscKinetics-v0 draws each episode's activation energies as the nominal ones times one factor
s in [0.5, 1.5] and does not reveal it. Over the evaluation seeds this prints:

- the adaptive thermostat (``discgym.controllers.AdaptiveThermostat``, the task's
  hand-written controller, which infers the kinetics from the reactions it sees), with its
  defaults (tuned as ``--search`` below does) and with its first version's hand-picked
  settings;
- an *informed* thermostat, told s: the scheduled thermostat of DiscReactor-v0 with its two
  setpoints scaled with the kinetics (``t_hot x s^a``, ``t_cold x s^a``, for each exponent a
  given), and its paired difference to the adaptive one (95% BCa interval,
  ``scipy.stats.bootstrap``): the room a policy could take if it inferred s perfectly;
- with ``--run`` (a folder of ``agents/train_ppo.py``), the trained policy's return, its
  paired difference to the adaptive thermostat, and for both the mean kT over env steps 10-39
  and 40-99 against s (the correlation of the early kT with s: a policy that reads the
  kinetics heats more where they are slower).

With ``--search``, also the best of a grid of the adaptive thermostat's own settings
(``x_target`` x ``band`` x ``step`` x ``t_start`` x ``memory``, the values given by flags),
chosen on the tuning seeds 500-539 (``--search-seeds``; ``--refine K N`` re-scores the best
K on N more) and evaluated on the evaluation seeds. The thermostat's defaults were chosen so:

    python benchmarks/kinetics_room.py --search --seeds 300 --x-targets 0.065 0.08 0.10 \
        --bands 1.1 1.2 1.3 --steps 1.02 1.03 1.04 --t-starts 1.2 1.4 1.6 --refine 10 200

Run:  python benchmarks/kinetics_room.py                               (~30 s)
      python benchmarks/kinetics_room.py --run runs/DiscKinetics-v0_ppo --seeds 100
      python benchmarks/kinetics_room.py --search --seeds 100          (~5 min)
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import discgym  # noqa: F401  (registers the tasks)
from discgym.baselines import paired_difference
from discgym.controllers import AdaptiveThermostat, Slots, Thermostat

ENV_ID = "DiscKinetics-v0"
#: The first version's hand-picked AdaptiveThermostat settings (its defaults until 2026-12-02).
FIRST_VERSION = {"x_target": 0.12, "band": 1.3, "step": 1.05, "t_start": 1.6, "memory": 0.8}
#: --search's grid of AdaptiveThermostat settings: every combination of these values.
GRID = {"x_target": (0.08, 0.10, 0.12, 0.15), "band": (1.2, 1.3, 1.5),
        "step": (1.03, 1.05, 1.08), "t_start": (1.4, 1.6, 1.8), "memory": (0.8,)}


def activation_factor(env) -> float:
    """The episode's hidden factor s: A + B -> C's activation energy over its nominal 4."""
    reactions = env.unwrapped.simulation.scene.reactions
    return next(r for r in reactions if hasattr(r, "activation_energy")).activation_energy / 4.0


def episode(seed: int, make_policy, episode_steps=None):
    """(return, s, mean kT over steps 10-39, mean kT over steps 40-) of one episode."""
    kw = {} if episode_steps is None else {"episode_steps": episode_steps}
    env = gym.make(ENV_ID, **kw)
    obs, _ = env.reset(seed=seed)
    s, slots = activation_factor(env), Slots(env)
    policy = make_policy(env, s)
    total, temps = 0.0, []
    done = False
    while not done:
        obs, r, term, trunc, _ = env.step(policy(obs))
        total += float(r)
        temps.append(slots.temperature(obs))
        done = term or trunc
    env.close()
    t = np.asarray(temps)
    return total, s, float(t[10:40].mean()) if len(t) > 10 else np.nan, \
        float(t[40:].mean()) if len(t) > 40 else np.nan


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=20, help="evaluation seeds (default 20)")
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--exponents", type=float, nargs="*", default=[1.0, 0.8],
                    help="a in the informed setpoints 1.8 s^a, 1.6 s^a")
    ap.add_argument("--run", default=None, help="a trained run's folder (agents/train_ppo.py)")
    ap.add_argument("--checkpoint", choices=("best", "final"), default="best",
                    help="the run's best validation checkpoint (default) or its final policy")
    ap.add_argument("--episode-steps", type=int, default=None, help="(tests) shorter episodes")
    ap.add_argument("--search", action="store_true",
                    help="tune the adaptive thermostat on the search seeds first")
    ap.add_argument("--search-seeds", type=int, nargs=2, default=[500, 540],
                    metavar=("FIRST", "END"), help="tuning seeds FIRST..END-1 (default 500 540)")
    ap.add_argument("--refine", type=int, nargs=2, default=[0, 0], metavar=("K", "N"),
                    help="re-score --search's best K settings on N further tuning seeds "
                         "(from END on) and keep the best over all its tuning seeds: the "
                         "first stage's winner is partly luck (default 0 0: no refinement)")
    ap.add_argument("--grid", type=int, default=None, help="(tests) the first N settings only")
    for key, flag in zip(GRID, ("x-targets", "bands", "steps", "t-starts", "memories")):
        ap.add_argument(f"--{flag}", type=float, nargs="+", default=GRID[key], dest=key,
                        help=f"--search's values of {key} (default {GRID[key]})")
    ap.add_argument("--tuned", type=float, nargs="+", default=None,
                    metavar="X_TARGET BAND STEP T_START [MEMORY]",
                    help="a tuned adaptive thermostat's settings (skips --search)")
    a = ap.parse_args(argv)
    seeds = range(a.first_seed, a.first_seed + a.seeds)

    def table(make_policy):
        return np.array([episode(k, make_policy, a.episode_steps) for k in seeds])

    ad = table(lambda env, s: AdaptiveThermostat(env))
    rows = [("adaptive thermostat (the task's controller)", ad),
            ("adaptive thermostat, first version's settings",
             table(lambda env, s: AdaptiveThermostat(env, **FIRST_VERSION)))]
    for x in a.exponents:
        rows.append((f"informed thermostat, setpoints 1.8 s^{x:g}, 1.6 s^{x:g}",
                     table(lambda env, s, x=x: Thermostat(env, t_hot=1.8 * s ** x,
                                                          t_cold=1.6 * s ** x))))
    tuned = None
    if a.tuned is not None:
        if len(a.tuned) not in (4, 5):
            raise SystemExit("--tuned: expected X_TARGET BAND STEP T_START [MEMORY]")
        tuned = tuple(a.tuned) + (0.8,) * (5 - len(a.tuned))
    elif a.search:
        grid = list(itertools.product(*(getattr(a, k) for k in GRID)))[:a.grid]
        tune = range(*a.search_seeds)
        if set(tune) & set(seeds):
            raise SystemExit("--search-seeds: must not overlap the evaluation seeds")
        scores = []
        for values in grid:
            kw = dict(zip(GRID, values))
            scores.append(np.mean([episode(k, lambda env, s, kw=kw: AdaptiveThermostat(
                env, **kw), a.episode_steps)[0] for k in tune]))
        tuned = grid[int(np.argmax(scores))]
        for i in np.argsort(scores)[::-1][:5]:
            print(f"  {grid[i]}: {scores[i]:.4f}")
        k, n = a.refine
        if k > 0 and n > 0:
            more = range(tune[-1] + 1, tune[-1] + 1 + n)
            if set(more) & set(seeds):
                raise SystemExit("--refine: its seeds must not overlap the evaluation seeds")
            top = [int(i) for i in np.argsort(scores)[::-1][:k]]
            both = {}
            for i in top:
                kw = dict(zip(GRID, grid[i]))
                extra = np.mean([episode(j, lambda env, s, kw=kw: AdaptiveThermostat(
                    env, **kw), a.episode_steps)[0] for j in more])
                both[i] = (scores[i] * len(tune) + extra * n) / (len(tune) + n)
                print(f"  refined {grid[i]}: {extra:.4f} on seeds {more[0]}-{more[-1]}, "
                      f"{both[i]:.4f} on all {len(tune) + n}", flush=True)
            tuned = grid[max(both, key=both.get)]
        import inspect

        init = inspect.signature(AdaptiveThermostat).parameters
        nominal = tuple(init[k].default for k in GRID)
        default = grid.index(nominal) if nominal in grid else None
        print(f"best of {len(grid)} adaptive settings ({', '.join(GRID)}) on "
              f"seeds {tune[0]}-{tune[-1]}"
              + (f" (refined on {a.refine[1]} more)" if min(a.refine) > 0 else "")
              + f": {tuned}, {scores[grid.index(tuned)]:.3f} on the first stage's seeds"
              + ("" if default is None else f" (the default: {scores[default]:.3f})"),
              flush=True)
    if tuned is not None:
        best = dict(zip(GRID, tuned))
        rows.append((f"adaptive thermostat, tuned {tuned}",
                     table(lambda env, s: AdaptiveThermostat(env, **best))))
    if a.run is not None:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "agents"))
        import evaluate

        factory = evaluate.agent_factory(a.run, a.checkpoint)
        name = f"policy of {a.run}" + (" (final)" if a.checkpoint == "final" else "")
        rows.append((name, table(lambda env, s: factory(env))))

    print(f"{ENV_ID}, seeds {seeds[0]}-{seeds[-1]}; s = the hidden activation factor; "
          f"kT means over env steps 10-39 and 40-")
    print()
    ref = {"adaptive": ad}
    if tuned is not None:
        ref["tuned adaptive"] = next(t for n, t in rows if n.startswith("adaptive thermostat, "
                                                                       "tuned"))

    def diff(t, r):
        if t is r:
            return ""
        d = paired_difference(t[:, 0], r[:, 0])
        return f"{d.value:+.3f} [{d.low:+.3f}, {d.high:+.3f}]"

    print("| policy | mean return | " + "".join(f"minus {k} [95% CI] | " for k in ref)
          + "corr(s, early kT) | early kT at s < 0.8 / s > 1.2 |")
    print("|---|---:|" + "---:|" * len(ref) + "---:|---:|")
    for name, t in rows:
        lo, hi = t[:, 1] < 0.8, t[:, 1] > 1.2
        ends = " / ".join(f"{t[m, 2].mean():.2f}" if m.any() else "-" for m in (lo, hi))
        corr = np.corrcoef(t[:, 1], t[:, 2])[0, 1] if len(t) > 2 else np.nan
        print(f"| {name} | {t[:, 0].mean():.3f} | "
              + "".join(f"{diff(t, r)} | " for r in ref.values()) + f"{corr:.2f} | {ends} |")


if __name__ == "__main__":
    main()
