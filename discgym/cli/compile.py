"""``discgym bench`` and ``discgym compile``: the benchmark suite, and the kernels compiled
ahead of first use."""

from __future__ import annotations

import importlib
import os
import sys
import time

from .common import (
    BENCH_EXTRA,
    EXIT_OK,
    CLIError,
    note,
    say,
)

# --------------------------------------------------------------------------------------------
# discgym bench


def cmd_bench(args) -> int:
    try:
        bench = importlib.import_module("discgym.bench")
    except ImportError as exc:
        missing = getattr(exc, "name", None) or ""
        if missing in ("discgym.bench", "discgym"):
            raise CLIError("the benchmark suite (discgym.bench) is not available in this "
                           "version of discgym") from None
        raise CLIError(f"the benchmark suite needs {missing or exc}, which is not installed: "
                       f"{BENCH_EXTRA}") from None
    argv = ([] if args.full else ["--quick"]) + list(args.bench_args)
    try:
        code = bench.main(argv)
    except ImportError as exc:
        raise CLIError(f"the benchmark suite needs {getattr(exc, 'name', None) or exc}, "
                       f"which is not installed: {BENCH_EXTRA}") from None
    return int(code or 0)


# --------------------------------------------------------------------------------------------
# discgym compile


def _env_ids() -> list:
    from ..tasks import TASKS

    return list(TASKS)


#: the job warming a Simulation's kernels (the ``discgym run`` path), as an "env id"
SIMULATION = "Simulation"


def _warm(env_id: str, integrator: str) -> float:
    """Build ``env_id``'s env and its vector env of 2 reactors on ``integrator``, reset and
    step each once (numba compiles what they run, or loads it from its cache); or, for
    :data:`SIMULATION`, a Simulation of the reactor scene. The seconds taken. Run in a worker
    process of :func:`cmd_compile`."""
    import numpy as np

    t0 = time.perf_counter()
    if env_id == SIMULATION:
        from ..simulation import Simulation

        Simulation("reactor", seed=0, integrator=integrator).step(2)
        return time.perf_counter() - t0
    from ..tasks import TASKS

    env_cls, vec_cls = TASKS[env_id]
    env = env_cls(integrator=integrator)
    env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, env.action_space.dtype))
    env.close()
    venv = vec_cls(num_envs=2, integrator=integrator)  # (the parallel step over reactors)
    venv.reset(seed=0)
    venv.step(np.zeros((2,) + venv.single_action_space.shape, venv.single_action_space.dtype))
    venv.close()
    return time.perf_counter() - t0


def _warm_quietly(env_id: str, integrator: str) -> float:
    from ..kernels import notice

    level = notice.LOGGER.level
    notice.LOGGER.setLevel("ERROR")  # (the command reports its own progress)
    try:
        return _warm(env_id, integrator)
    finally:
        notice.LOGGER.setLevel(level)


def cmd_compile(args) -> int:
    known = _env_ids()
    unknown = [e for e in args.env or () if e not in known]
    if unknown:
        raise CLIError(f"unknown env id{'s' if len(unknown) > 1 else ''} "
                       f"{', '.join(map(repr, unknown))} (known: {', '.join(known)})")
    if args.jobs is not None and args.jobs < 1:
        raise CLIError(f"--jobs: need at least 1, got {args.jobs}")
    ids = known + [SIMULATION] if args.all else list(dict.fromkeys(args.env or [known[0]]))
    integrators = [args.integrator] if args.integrator else ["step", "event"]
    todo = [(e, i) for e in ids for i in integrators]
    # The envs share their kernels: the first env of each integrator (and the Simulation)
    # compiles them, the others then mostly load them. So two waves: those first, at once,
    # then the rest (two processes compiling the same kernels would only race).
    heads = [(e, i) for e, i in todo if e in (ids[0], SIMULATION)]
    waves = [w for w in (heads, [j for j in todo if j not in heads]) if w]
    jobs = min(args.jobs or os.cpu_count() or 1, max(len(w) for w in waves))
    note(f"compiling discgym's kernels for {len(todo)} configuration(s) in {jobs} "
          f"process(es); cached afterwards")
    bar = _JobBar(len(todo), quiet=args.quiet)
    t0 = time.perf_counter()
    if jobs == 1:
        for env_id, integrator in todo:
            bar.done(f"{env_id} {integrator}", _warm_quietly(env_id, integrator))
    else:
        import concurrent.futures as cf
        import multiprocessing

        from ..kernels import helper

        # (the workers fill the CPUs and share their kernels through the cache's locks: no
        # compile helper of their own)
        os.environ[helper.ENV_VAR] = "0"

        # (spawned, not forked: a fresh interpreter each, whatever numba's threads have done)
        with cf.ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) \
                as pool:
            for wave in waves:
                futures = {pool.submit(_warm_quietly, e, i): f"{e} {i}" for e, i in wave}
                for f in cf.as_completed(futures):
                    bar.done(futures[f], f.result())
    bar.close()
    say(f"compiled or loaded the kernels of {len(todo)} configuration(s) in "
         f"{time.perf_counter() - t0:.1f} s")
    return EXIT_OK


class _JobBar:
    """Jobs done out of the total on stderr: a tqdm bar when tqdm is installed, else one
    line per job."""

    def __init__(self, total: int, quiet: bool = False):
        self.total = total
        self.n = 0
        self.quiet = quiet
        self._bar = None
        if quiet:
            return
        try:
            from tqdm import tqdm
        except ImportError:
            return
        self._bar = tqdm(total=total, file=sys.stderr, unit="env", leave=True)

    def done(self, label: str, seconds: float) -> None:
        self.n += 1
        if self.quiet:
            return
        if self._bar is not None:
            self._bar.set_postfix_str(f"{label} {seconds:.0f} s", refresh=False)
            self._bar.update(1)
        else:
            note(f"[{self.n}/{self.total}] {label}: {seconds:.1f} s")

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
