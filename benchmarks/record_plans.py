"""Record the compile helper's plans (``discgym/kernels/plans.json``, see
``discgym/kernels/helper.py``): for each plan, a child process with an empty numba cache
and no helper resets and steps the env, and numba's ``numba:compile`` events say which
kernels it compiled, with which argument types, in which order and for how long.

    python benchmarks/record_plans.py --write              # every plan
    python benchmarks/record_plans.py --write env-event    # one, the others kept

Run it with the numba the plans are for (CI's latest, a version of
``discgym.kernels.jit.TESTED_NUMBA``); ``tests/test_compile_scope.py`` fails when a plan no
longer matches what the envs compile.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

# from a checkout, the checkout's discgym
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from discgym.kernels import helper, jit  # noqa: E402

#: What each plan's recording runs: ``(env id, integrator)`` of a single env's reset and step.
RECORDED = {"env-step": ("DiscReactor-v0", "step"), "env-event": ("DiscReactor-v0", "event")}


def record_compile(env_id: str, integrator: str) -> list[dict]:
    """In this process (empty cache, no helper): reset and step ``env_id``'s single env on
    ``integrator``; every discgym function compiled, in the order numba began them, as dicts
    of ``qualname``, ``args`` (numba types), ``depth`` (of the compile
    stack), ``kernel``, ``seconds`` (inclusive) and ``children``."""
    import gymnasium
    from numba.core import event

    import discgym  # noqa: F401  (registers the envs)

    out, stack = [], []
    with event.install_recorder("numba:compile") as rec:
        env = gymnasium.make(env_id, integrator=integrator)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
    for ts, ev in rec.buffer:
        if ev.is_start:
            d = ev.data.get("dispatcher")
            f = getattr(d, "py_func", None)
            kernel = jit.is_kernel(d)
            args = tuple(ev.data.get("args") or ())
            item = {"qualname": f"{f.__module__}.{f.__qualname__}" if f else "?",
                    "args": args,
                    "depth": len(stack), "kernel": kernel, "start": ts, "children": []}
            if stack:
                stack[-1]["children"].append(item)
            stack.append(item)
            out.append(item)
        else:
            item = stack.pop()
            item["seconds"] = ts - item["start"]
    return out


def record(names=None, write: bool = True) -> dict:
    """Record the plans ``names`` (all by default; each in a child process with an empty
    cache) and, with ``write``, write them into :data:`helper.PLANS_FILE`."""
    if jit.LAYER != jit.LINK_ONLY:
        raise SystemExit(f"the plans are for the linked-only layer, not in effect here "
                         f"(numba {helper.numba_version()}, {jit.ENV_VAR})")
    plans = helper.load_plans() if names else {}
    for name in names or RECORDED:
        env_id, integrator = RECORDED[name]
        with tempfile.TemporaryDirectory(prefix="discgym-plan-") as cache:
            out = Path(cache) / "plan.json"
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, DISCGYM_COMPILE_NOTICE="0",
                       **{helper.ENV_VAR: "0"})
            subprocess.run([sys.executable, __file__, "--one", env_id, integrator, str(out)],
                           env=env, check=True)
            plans[name] = [tuple(k) for k in json.loads(out.read_text())]
    if write:
        helper.write_plans(plans)
    return plans


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("plans", nargs="*", metavar="PLAN",
                    help=f"the plans to record ({', '.join(RECORDED)}; default: all)")
    ap.add_argument("--write", action="store_true",
                    help=f"write them into {helper.PLANS_FILE.name} (else only print them)")
    ap.add_argument("--one", nargs=3, metavar=("ENV", "INTEGRATOR", "OUT"),
                    help=argparse.SUPPRESS)  # (the child process recording one plan)
    a = ap.parse_args(argv)
    unknown = [p for p in a.plans if p not in RECORDED]
    if unknown:
        ap.error(f"no plan {', '.join(unknown)} (plans: {', '.join(RECORDED)})")
    if a.one:
        env_id, integrator, out = a.one
        plan = helper.make_plan(record_compile(env_id, integrator))
        Path(out).write_text(json.dumps(
            [(q, [helper.encode_type(t) for t in args], s) for q, args, s in plan]))
        return 0
    for name, plan in record(a.plans or None, write=a.write).items():
        print(f"{name}: {len(plan)} kernels: {', '.join(q for q, _, _ in plan)}")
    if not a.write:
        print(f"(not written: --write writes {helper.PLANS_FILE})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
