"""A second process compiling part of a first compile (linked-only layer only, :mod:`.jit`).

numba compiles on one thread, in one process: an env's first step from an empty cache
compiles some 140 functions one after the other. Most of them are kernels (linked only,
:mod:`.linkonly`), which numba types, lowers and keeps in its cache as bitcode, ready for
the entry points to link. A kernel compiled by another process is loaded from the cache,
so two processes can share the kernels of a first compile.

**Plans.** Which kernels, with which argument types, an env's first step compiles is
recorded in ``plans.json`` beside this module (``python benchmarks/record_plans.py
--write``; ``tests/test_compile_scope.py`` fails when a plan no longer matches what the
envs compile). A plan is the later :data:`SHARE` of that compile's kernel time, in the order
compiled (:func:`make_plan`): about what follows the reset's kernels, the step's controls,
the integrator's phases and the step's bookkeeping. Each kernel is named by its qualified
name and its argument types are written as JSON (:func:`encode_type`), read back into numba
types only by the helper process. A plan file of another numba, or one that cannot be
read, is no plan: nothing in it can break the reset whose first compile reads it.

**The helper.** An env declares the plan of its integrator when it is made
(:func:`expect`). When the process then compiles a discgym function (the cache lacks it)
and may run on two CPUs or more, it starts a helper process (:func:`run`) that compiles
the plan's longest kernel, then the others from the last back, while the env's process
compiles its reset's kernels, then the plan from the first: each loads what the other has
compiled, and waits for a kernel the other is compiling. One helper per process and plan;
a helper that finds another at work on the same cache and plan exits. The helper imports
the kernels only, not the package above them, and ends when its plan is done or when the
process that started it has ended (the pipe it holds reaches its end, or it has a new
parent), whichever comes first. ``DISCGYM_COMPILE_HELPER=0`` starts none; there is none
under the plain layer, nor without ``fcntl`` (not POSIX).

**Locks** (:mod:`.locks`). Two processes must not compile one kernel twice, and must not
write one function's cache index at once (numba rewrites a function's index at each save:
two writers can lose an entry, or point one at the other's code). So a kernel's version is
compiled, or loaded, under a lock of its own (a ``.lock`` file in the cache folder, named
by the index and the argument types), and saved under the lock of its function's index.
A process reaching a kernel that another is compiling waits, then loads it. Every process
compiling discgym's kernels takes these locks, so the workers of a vector env or of
``discgym compile`` that start on an empty cache share their compile. A process waits only
for a version below the one it holds, and holds an index's lock only to write it, so two
never wait for each other. A lock's file is removed by its holder; a helper, when done,
removes those that processes killed while holding them left behind.

The code is the same: a kernel loaded from the cache is what its process would have
compiled (numba keys its cache by the argument types and the source file's stamp).
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import json
import os
import select
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

from . import jit, locks

#: Set to 0 (or "false", "no", "off") to start no helper process.
ENV_VAR = "DISCGYM_COMPILE_HELPER"
#: The recorded plans: ``{"format": 1, "numba": version, "plans": {name: [{"kernel":
#: qualname, "args": [type, ...], "seconds": s}]}}`` (types as :func:`encode_type` writes).
PLANS_FILE = Path(__file__).with_name("plans.json")
FORMAT = 1
#: The share of a recorded compile's kernel time a plan covers (what comes after the
#: reset's kernels: the helper and the env's process share it as they meet).
SHARE = 0.85
#: The helper's command: the kernels without the package above them (whose ``__init__``
#: would import the envs and gymnasium), then :func:`main`.
_MAIN = ("import importlib.util as u, sys; s = u.find_spec('discgym'); "
         "sys.modules['discgym'] = u.module_from_spec(s); "
         "from discgym.kernels.helper import main; sys.exit(main())")
#: The package's folder and the file that identifies it (a helper works on its cache only).
_PACKAGE = Path(__file__).resolve().parents[1]
_ORIGIN = str(_PACKAGE / "__init__.py")

_expected: list[str] = []
_helpers: list = []  # (the helpers started: kept, with the write end of their pipes)
_started: set[str] = set()


def switched_off(name: str) -> bool:
    """Whether the environment variable ``name`` is 0, "false", "no" or "off"."""
    return os.environ.get(name, "1").strip().lower() in ("0", "false", "no", "off")


def enabled() -> bool:
    """Whether this process may start a helper: the linked-only layer, ``fcntl`` (POSIX),
    ``DISCGYM_COMPILE_HELPER`` not off (a helper's own environment has it off) and at least
    two CPUs it may run on."""
    if jit.LAYER != jit.LINK_ONLY or locks.fcntl is None or switched_off(ENV_VAR):
        return False
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:
        cpus = os.cpu_count() or 1
    return cpus >= 2


def expect(plan: str) -> None:
    """Declare that this process is about to compile (or load) ``plan``'s kernels: if it
    compiles any discgym function, a helper is started for the plan (module docstring)."""
    if plan not in _expected:
        _expected.append(plan)


def on_compile() -> None:
    """Called when this process starts compiling a discgym function: start the helpers of
    the expected plans not started yet."""
    if len(_started) == len(_expected) or not enabled():
        return
    for plan in _expected:
        if plan not in _started:
            _started.add(plan)
            _start(plan)


def _start(plan: str) -> subprocess.Popen | None:
    if plan not in load_plans():
        return None
    env = dict(os.environ, **{ENV_VAR: "0"})  # (a helper starts no helper)
    root = str(_PACKAGE.parent)
    env["PYTHONPATH"] = os.pathsep.join([root] + [p for p in [env.get("PYTHONPATH")] if p])
    try:
        # (its own session: a Ctrl-C meant for this process's group does not reach it; it
        # ends with this process all the same: the pipe)
        p = subprocess.Popen(
            [sys.executable, "-c", _MAIN, "run", plan, _ORIGIN, str(os.getpid())],
            env=env, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, start_new_session=True)
    except OSError:  # (no process to be had: this process compiles it all, as without one)
        return None
    if not _helpers:
        atexit.register(_end_helpers)
    _helpers.append(p)
    return p


def _end_helpers(timeout: float = 2.0) -> None:
    """At this process's exit: close the helpers' pipes (each ends at that), and reap them."""
    deadline = time.monotonic() + timeout
    for p in _helpers:
        with contextlib.suppress(OSError):
            p.stdin.close()
    for p in _helpers:
        with contextlib.suppress(subprocess.TimeoutExpired):
            p.wait(max(0.0, deadline - time.monotonic()))


# -- the plans ----------------------------------------------------------------------------

def load_plans() -> dict:
    """The recorded plans usable with this numba, ``{name: [(qualname, args, seconds)]}``
    (``args``: the JSON of the argument types): ``{}`` if none are, whatever the file holds
    (missing, unreadable, not JSON, of another format or numba, or of another shape than
    :func:`write_plans` writes)."""
    try:
        data = json.loads(PLANS_FILE.read_text())
        if data["format"] != FORMAT or data["numba"] != numba_version():
            return {}
        plans = {name: [(k["kernel"], k["args"], k["seconds"]) for k in plan]
                 for name, plan in data["plans"].items()}
    except Exception:  # (whatever the text makes it raise: no plan)
        return {}
    if not all(isinstance(name, str) and all(
            isinstance(q, str) and isinstance(a, list) and isinstance(s, (int, float))
            and not isinstance(s, bool) for q, a, s in plan) for name, plan in plans.items()):
        return {}
    return plans


def write_plans(plans: dict, path: Path = PLANS_FILE) -> None:
    """Write ``plans`` (``{name: [(qualname, args, seconds)]}``) as :func:`load_plans`
    reads them, for this numba."""
    head = json.dumps({"format": FORMAT, "numba": numba_version()})[:-1]
    parts = []
    for name, plan in plans.items():  # (a kernel a line: diffs read as the plan changes)
        rows = ",\n  ".join(json.dumps({"kernel": q, "args": a, "seconds": s})
                            for q, a, s in plan)
        parts.append(f" {json.dumps(name)}: [\n  {rows}\n ]")
    path.write_text(f'{head}, "plans": {{\n' + ",\n".join(parts) + "\n}}\n")


def numba_version() -> str:
    import numba

    return numba.__version__


def make_plan(compiled: list[dict], share: float = SHARE) -> list[tuple[str, list, float]]:
    """The plan of a recorded compile (dicts of ``qualname``, ``args``, ``depth`` of the
    compile stack, ``kernel``, ``seconds`` inclusive and ``children``, in the order numba
    began them): the units of work (each kernel an entry point calls; a kernel of more
    than a quarter of the whole split into the kernels it calls, its own lowering left to
    the process that needs it), in the order compiled; the plan is the last of them that
    add up to ``share`` of their seconds, as ``(qualname, args, seconds)``."""
    entries = [c for c in compiled if c["depth"] == 0]
    units: list[dict] = []
    total = sum(c["seconds"] for c in entries)

    def add(item):
        if not item["kernel"]:
            for child in item["children"]:
                add(child)
        elif item["seconds"] > total / 4 and item["children"]:
            for child in item["children"]:
                add(child)
        else:
            units.append(item)

    for e in entries:
        for child in e["children"]:
            add(child)
    work = sum(u["seconds"] for u in units)
    plan, got = [], 0.0
    for u in reversed(units):
        if got >= share * work:
            break
        got += u["seconds"]
        plan.append((u["qualname"], u["args"], round(u["seconds"], 3)))
    return plan[::-1]


# -- argument types as JSON ---------------------------------------------------------------

@functools.cache
def _scalars() -> dict:
    import numpy as np
    from numba import typeof, types

    known = (types.boolean, types.none, *types.number_domain,
             typeof(np.random.default_rng(0)))
    return {str(t): t for t in known}


def encode_type(ty):
    """The JSON of a numba type as the plans hold it: a scalar's name, or a dict for an
    array, a tuple, a named tuple (a struct of :mod:`.structs` and the like), a typed
    list or a literal bool or int. Raises
    TypeError for any other type, and for one that does not read back equal."""
    from numba import types

    if isinstance(ty, types.Array):
        out = {"array": encode_type(ty.dtype), "ndim": ty.ndim, "layout": ty.layout}
        if not ty.mutable:
            out["readonly"] = True
    elif isinstance(ty, types.BaseNamedTuple):
        cls = ty.instance_class
        out = {"namedtuple": f"{cls.__module__}.{cls.__qualname__}",
               "fields": [encode_type(t) for t in ty.types]}
    elif isinstance(ty, types.BaseTuple):
        out = {"tuple": [encode_type(t) for t in ty.types]}
    elif isinstance(ty, types.ListType):  # (a numba.typed.List: the generators)
        out = {"list": encode_type(ty.item_type)}
    elif isinstance(ty, types.Literal) and type(ty.literal_value) in (bool, int):
        out = {"literal": ty.literal_value}  # (a constant argument: a flag)
    elif str(ty) in _scalars():
        out = str(ty)
    else:
        raise TypeError(f"no JSON for the numba type {ty!r}")
    try:
        back = decode_type(out)
    except (TypeError, ValueError, KeyError, LookupError) as e:
        raise TypeError(f"the JSON of the numba type {ty!r} does not read back: {e}") from e
    if back != ty:
        raise TypeError(f"the JSON of the numba type {ty!r} reads back as {back!r}")
    return out


def decode_type(x):
    """The numba type of :func:`encode_type`'s JSON; raises TypeError, ValueError or
    LookupError for anything else (a named tuple only of a module of discgym's kernels)."""
    from numba import types

    if isinstance(x, str):
        return _scalars()[x]
    if isinstance(x, dict) and len(x) <= 4:
        if "array" in x and x.get("layout") in ("C", "F", "A") and type(x["ndim"]) is int:
            return types.Array(decode_type(x["array"]), x["ndim"], x["layout"],
                               readonly=x.get("readonly", False) is True)
        if "literal" in x and len(x) == 1 and type(x["literal"]) in (bool, int):
            return types.literal(x["literal"])
        if "list" in x and len(x) == 1:
            return types.ListType(decode_type(x["list"]))
        if "tuple" in x and isinstance(x["tuple"], list):
            return types.BaseTuple.from_types([decode_type(t) for t in x["tuple"]])
        if "namedtuple" in x and isinstance(x.get("fields"), list):
            cls = _kernels_attr(x["namedtuple"], type)
            if not (issubclass(cls, tuple) and hasattr(cls, "_fields")):
                raise LookupError(f"{x['namedtuple']}: not a named tuple")
            return types.BaseTuple.from_types([decode_type(t) for t in x["fields"]], cls)
    raise TypeError(f"not a type of a plan: {x!r}")


def _kernels_attr(qualname: str, kind):
    """The object ``qualname`` names in a module of ``discgym.kernels``, if a ``kind``."""
    import importlib

    module, _, name = str(qualname).rpartition(".")
    if not module.startswith("discgym.kernels."):
        raise LookupError(f"{qualname}: not in discgym's kernels")
    obj = getattr(importlib.import_module(module), name)
    if not isinstance(obj, kind):
        raise LookupError(f"{qualname}: not a {kind.__name__}")
    return obj


def _dispatcher(qualname: str):
    """The kernel compiled from the function ``qualname`` names: that name's own kernel, or
    one its module made from the function under another name (``run_events =
    kernel(run_events_py)``; numba's compile events name the function)."""
    disp = _kernels_attr(qualname, object)
    if not jit.is_kernel(disp):
        module = sys.modules[qualname.rpartition(".")[0]]
        disp = next((k for k in vars(module).values()
                     if jit.is_kernel(k) and k.py_func is disp), None)
        if disp is None:
            raise LookupError(f"{qualname}: not a kernel")
    return disp


# -- the helper process -------------------------------------------------------------------

def _end_with(parent: int) -> None:
    """End this process (at once: numba writes its cache files whole or not at all) when
    ``parent`` has ended: this process has another parent then, and the pipe its stdin
    reads from (if one) reaches its end."""
    try:
        pipe = stat.S_ISFIFO(os.fstat(0).st_mode)
    except OSError:
        pipe = False

    def watch():
        while True:
            if os.getppid() != parent:
                os._exit(0)
            if pipe and select.select([0], [], [], 0.2)[0]:
                if not os.read(0, 4096):
                    os._exit(0)
            elif not pipe:
                time.sleep(0.2)

    threading.Thread(target=watch, name="discgym-helper-parent", daemon=True).start()


def run(plan: str) -> int:
    """Compile ``plan``'s kernels (the helper process): the longest first, then the others
    from the last back, toward the env's process, which compiles them from the first; they
    meet where they meet, and a kernel the other has compiled is loaded. (The env's process
    reaches the longest only after its reset, its controls and the first phases; begun
    there, the meeting falls among short kernels, and the env's process waits little for
    one the helper is still compiling.) Exits at once if another helper holds the plan's
    lock on this cache. Done, it removes the lock files nobody holds."""
    kernels = load_plans().get(plan)
    if not kernels or locks.fcntl is None:
        return 0
    try:
        folder = jit.lock_folder(_dispatcher(kernels[0][0]))
    except Exception:  # (a stale plan)
        return 0
    if folder is None:
        return 0
    path = folder / f"discgym-helper-{plan}{locks.SUFFIX}"
    fd = locks.try_hold(path)
    if fd is None:
        return 0
    try:
        longest = max(range(len(kernels)), key=lambda i: kernels[i][2])
        order = [longest] + [i for i in reversed(range(len(kernels))) if i != longest]
        for qualname, args, _seconds in (kernels[i] for i in order):
            try:
                _dispatcher(qualname).compile(tuple(decode_type(a) for a in args))
            except Exception:  # (a stale plan: the process that needs the kernel compiles it)
                continue
    finally:
        locks.release(fd, path)
        locks.sweep(folder)
    return 0


def main(argv=None) -> int:
    """``run PLAN ORIGIN PARENT``: the helper process, for the discgym whose
    ``__init__.py`` is ``ORIGIN``, started by the process ``PARENT``."""
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["run"] and len(argv) == 4:
        _end_with(int(argv[3]))
        if _ORIGIN != argv[2]:
            return 0  # (another discgym than the process that started it: not its cache)
        return run(argv[1])
    print("usage: main(['run', PLAN, ORIGIN, PARENT_PID]); plans are recorded by "
          "benchmarks/record_plans.py", file=sys.stderr)
    return 2
