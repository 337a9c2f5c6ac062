"""The two integrators in the environments: cost per env step and accuracy, on every task.

For every task of ``discgym.tasks.TASKS`` (its own defaults), the single env with
``integrator="step"`` (the default: ``step_time / dt`` steps of the time-stepped integrator)
and with ``integrator="event"`` (one exact event-driven run of ``step_time`` per env step)
runs whole episodes of one fixed sequence of uniform random actions (seeded, the same for
every episode and both integrators). Pair i resets both envs with seed ``1000 + i`` (``--seed``; the
same initial reactor) and times one episode of each, alternating which goes first (this
machine's speed drifts by 10-30% from minute to minute: a pair is two episodes a few tens of
milliseconds apart, so the ratio within a pair is what is compared). With ``--num-envs R``
the same with the task's native vector env of R reactors (reactor i of pair p seeded
``1000 + p R + i``, every reactor given the same action sequence): reactor-steps/s, the
compiled step's share of an env step larger (the Python around it is shared by R reactors),
and R episodes per pair member for the returns.

Columns:

- env steps/s: ``episode_steps`` over the time of the episode's ``env.step`` calls (the
  resets are not timed), the median over the pairs;
- cost event / step: the time of the event episode over the time of the step episode of the
  same pair, median and [min, max] over the pairs (< 1: the event-driven env is cheaper);
- return step, return event: the mean episode return (the task's own reward: the product
  yield for DiscReactor-v0 and DiscKinetics-v0, the yield less the costs for
  DiscEconomic-v0, ...) over the pairs' seeds;
- event - step: the mean over the seeds of the paired difference of the returns, with a 95%
  bootstrap confidence interval (``scipy.stats.bootstrap``, BCa). The event-driven
  integrator is exact (no time-step error: it is the accuracy ceiling of the stepped one),
  so a difference whose interval excludes 0 is the stepped integrator's error at the task's
  ``dt``, as seen by the task's reward; an interval around 0 means the two are equally
  accurate at what the task measures, to within the seed-to-seed spread (the two
  trajectories of a pair decorrelate within a few steps: both are chaotic);
- ledger: the largest relative error of the energy ledger at the end of an episode,
  ``|Simulation.energy_balance()| / |total energy|`` over every episode of both
  integrators (round-off: both conserve energy exactly, up to what the controls, the walls
  and the outlets book);
- capped: event runs finished by the time-stepped integrator at the event bound
  (``events_capped``, summed over the event episodes; 0 means every step was exact).

Run:  python benchmarks/bench_integrators.py              (~1-2 min on 2 shared cores)
      python benchmarks/bench_integrators.py --pairs 8    (a smoke test)
      python benchmarks/bench_integrators.py --write docs/performance.md
      python benchmarks/bench_integrators.py --num-envs 16 --pairs 25   (the vector env)
``--write`` replaces the table between the markers ``<!-- bench_integrators -->`` and
``<!-- /bench_integrators -->`` (with ``--num-envs R``: ``<!-- bench_integrators
num_envs=R -->`` and ``<!-- /bench_integrators num_envs=R -->``) of that file with this
run's (with its command, date and machine). Numbers depend on the machine and on its load:
quote them with both.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from scipy.stats import bootstrap

from discgym.bench import machine_info
from discgym.tasks import TASKS

INTEGRATORS = ("step", "event")
BEGIN, END = "<!-- bench_integrators -->", "<!-- /bench_integrators -->"


def episode(env, seed: int, acts: np.ndarray) -> tuple[float, list, float, int, list]:
    """One episode (R of them in a vector env of R reactors, seeds ``seed + r``) from
    ``reset(seed=seed)`` under the actions ``acts`` (T, A), or (T, R, A): ``(seconds of the
    step calls, returns, largest ledger error, events capped, discs at the end)``, the
    lists one entry per reactor."""
    env.reset(seed=seed)
    ret = 0.0
    step = env.step
    t0 = time.perf_counter()
    for a in acts:
        ret += step(a)[1]
    t = time.perf_counter() - t0
    sims = getattr(env, "simulations", None) or [env.simulation]
    ledger = max(abs(s.energy_balance()) / max(abs(s.total_energy()), 1e-300) for s in sims)
    return (t, np.atleast_1d(ret).tolist(), ledger,
            sum(s.counters()["events_capped"] for s in sims), [len(s) for s in sims])


def measure(env_id: str, pairs: int, num_envs: int = 1, threads: int = 1,
            seed: int = 1000) -> dict:
    env_cls, vec_cls = TASKS[env_id]
    R = num_envs
    if R == 1:
        envs = {i: env_cls(integrator=i) for i in INTEGRATORS}
        space = envs["step"].action_space
    else:
        envs = {i: vec_cls(num_envs=R, threads=threads, integrator=i) for i in INTEGRATORS}
        space = envs["step"].single_action_space
    T = envs["step"].config.episode_steps
    acts = np.random.default_rng(0).uniform(-1.0, 1.0, (T, space.shape[0])).astype(np.float32)
    if R > 1:  # (every reactor the same sequence, the single env's)
        acts = np.ascontiguousarray(np.broadcast_to(acts[:, None], (T, R, acts.shape[1])))
    for i in INTEGRATORS:  # (warm-up: compilation, caches)
        episode(envs[i], 999, acts[:5])
    res = {i: dict(t=[], ret=[], ledger=[], capped=0, discs=[]) for i in INTEGRATORS}
    for p in range(pairs):
        order = INTEGRATORS if p % 2 == 0 else INTEGRATORS[::-1]
        for i in order:
            t, ret, ledger, capped, n = episode(envs[i], seed + p * R, acts)
            r = res[i]
            r["t"].append(t)
            r["ret"] += ret
            r["ledger"].append(ledger)
            r["capped"] += capped
            r["discs"] += n
    ts, te = np.array(res["step"]["t"]), np.array(res["event"]["t"])
    ratio = te / ts
    T = T * R  # (reactor-steps per episode pair member)
    diff = np.array(res["event"]["ret"]) - np.array(res["step"]["ret"])
    ci = bootstrap((diff,), np.mean, confidence_level=0.95, n_resamples=4999, method="BCa",
                   random_state=np.random.default_rng(0)).confidence_interval
    return dict(task=env_id, steps=T // R, pairs=pairs,
                sps_step=float(np.median(T / ts)), sps_event=float(np.median(T / te)),
                ratio=float(np.median(ratio)), ratio_lo=float(ratio.min()),
                ratio_hi=float(ratio.max()),
                ret_step=float(np.mean(res["step"]["ret"])),
                ret_event=float(np.mean(res["event"]["ret"])),
                diff=float(diff.mean()), diff_lo=float(ci.low), diff_hi=float(ci.high),
                ledger=float(max(max(res[i]["ledger"]) for i in INTEGRATORS)),
                capped=res["event"]["capped"],
                discs=float(np.mean(res["step"]["discs"] + res["event"]["discs"])))


def table(rows: list, num_envs: int = 1) -> str:
    what = "env steps/s" if num_envs == 1 else "reactor-steps/s"
    out = [f"| task | steps/episode | discs at the end (mean) | step: {what} | "
           f"event: {what} | cost event / step: median [min, max] | return step | "
           "return event | event - step (95% CI) | ledger | capped |",
           "|:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(
            f"| {r['task']} | {r['steps']} | {r['discs']:.0f} | {r['sps_step']:.0f} | "
            f"{r['sps_event']:.0f} | {r['ratio']:.2f} [{r['ratio_lo']:.2f}, "
            f"{r['ratio_hi']:.2f}] | {r['ret_step']:.3f} | {r['ret_event']:.3f} | "
            f"{r['diff']:+.3f} [{r['diff_lo']:+.3f}, {r['diff_hi']:+.3f}] | "
            f"{r['ledger']:.0e} | {r['capped']} |")
    return "\n".join(out)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", type=int, default=200,
                    help="interleaved (step, event) episode pairs per task (default 200)")
    ap.add_argument("--tasks", nargs="*", default=sorted(TASKS), help="task ids")
    ap.add_argument("--seed", type=int, default=1000,
                    help="pair p resets with seed + p (R reactors: seed + p R + r)")
    ap.add_argument("--num-envs", type=int, default=1,
                    help="R > 1: the native vector env of R reactors (episodes of all R at "
                         "once, reactor i seeded 1000 + p R + i in pair p) instead of the "
                         "single env")
    ap.add_argument("--threads", type=int, default=1,
                    help="the vector env's threads (default 1: the integrators, not the "
                         "load balance, are compared)")
    ap.add_argument("--write", metavar="FILE",
                    help=f"replace the table between {BEGIN} and {END} in FILE")
    args = ap.parse_args(argv)
    R = args.num_envs
    begin, end = BEGIN, END
    if R > 1:
        begin = BEGIN.replace(" -->", f" num_envs={R} -->")
        end = END.replace(" -->", f" num_envs={R} -->")
    info0 = machine_info()
    t0 = time.perf_counter()
    rows = []
    for env_id in args.tasks:
        rows.append(measure(env_id, args.pairs, R, args.threads, args.seed))
        print(f"{env_id}: done ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    info1 = machine_info()
    text = table(rows, R)
    cmd = "python benchmarks/bench_integrators.py" + (
        f" --pairs {args.pairs}" if args.pairs != 200 else "") + (
        f" --seed {args.seed}" if args.seed != 1000 else "") + (
        f" --num-envs {R}" if R > 1 else "") + (
        f" --threads {args.threads}" if R > 1 and args.threads != 1 else "")
    env = "single env" if R == 1 else \
        f"vector env of {R} reactors on {args.threads} thread(s)"
    head = (f"`{cmd}`, {info0['date']} ({time.perf_counter() - t0:.0f} s), {info0['cpu']}, "
            f"nproc = {info0['nproc']}, numba {info0['numba']}, numpy {info0['numpy']}; load "
            f"average {info0['load_avg'][0]} at the start, {info1['load_avg'][0]} at the end; "
            f"{args.pairs} pairs of episodes per task, {env}.")
    print(head)
    print()
    print(text)
    if args.write:
        with open(args.write) as f:
            doc = f.read()
        if begin not in doc or end not in doc:
            raise SystemExit(f"--write: {args.write} has no {begin} ... {end} markers")
        a = doc.index(begin) + len(begin)
        b = doc.index(end)
        with open(args.write, "w") as f:
            f.write(doc[:a] + "\n" + head + "\n\n" + text + "\n" + doc[b:])


if __name__ == "__main__":
    main()
