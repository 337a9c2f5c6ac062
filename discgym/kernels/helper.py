"""A second process compiling part of a first compile.

numba compiles on one thread, in one process: an env's first step from an empty cache
compiles some 140 functions one after the other. Most of them are kernels (linked only,
:mod:`.jit`), which numba types, lowers and keeps in its cache as bitcode, ready for the
entry points to link. A kernel compiled by another process is loaded from the cache, so
two processes can share the kernels of a first compile.

**Plans.** Which kernels, with which argument types, an env's first step compiles is
recorded: :func:`record` (``main(["record"])``) writes ``plans.pkl`` beside this module,
and ``tests/test_compile_scope.py`` fails when a plan no longer matches what the envs
compile. A plan is the later :data:`SHARE` of that compile's kernel time, in the order
compiled (:func:`make_plan`): about what follows the reset's kernels, the step's controls,
the integrator's phases and the step's bookkeeping. Plans are used only with the numba they were
recorded with.

**The helper.** An env declares the plan of its integrator when it is made
(:func:`expect`). When the process then compiles a discgym function (the cache lacks it)
and may run on two CPUs or more, it starts a helper process (:func:`run`) that compiles
the plan's longest kernel, then the others from the last back, while the env's process
compiles its reset's kernels, then the plan from the first: each loads what the other has
compiled, and waits for a kernel the other is compiling. One helper per process and plan;
a helper that finds another at work on the same cache and plan exits.
``DISCGYM_COMPILE_HELPER=0`` starts none.

**Locks.** Two processes must not compile one kernel twice, and must not write one
function's cache index at once (numba rewrites a function's index at each save: two
writers can lose an entry, or point one at the other's code). So a kernel's version is
compiled, or loaded, under a lock of its own (``fcntl.flock`` on a ``.lock`` file beside
numba's ``.nbi`` index, named by the index and the argument types), and saved under the
lock of its function's index. A process reaching a kernel that another is compiling waits,
then loads it. Every process compiling discgym's kernels takes these locks, so the workers
of a vector env or of ``discgym compile`` that start on an empty cache share their
compile. A process waits only for a version below the one it holds, and holds an index's
lock only to write it, so two never wait for each other; a lock is released when its
process ends, whatever the way.

The code is the same: a kernel loaded from the cache is what its process would have
compiled (numba keys its cache by the argument types and the source file's stamp).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path

try:
    import fcntl
except ImportError:  # (not POSIX: no locks and no helper; each process compiles its own)
    fcntl = None

#: Set to 0 (or "false", "no", "off") to start no helper process.
ENV_VAR = "DISCGYM_COMPILE_HELPER"
#: The recorded plans: ``{"numba": version, "plans": {name: [(qualname, args pickle,
#: seconds)]}}``.
PLANS_FILE = Path(__file__).with_name("plans.pkl")
#: What each plan's recording runs: ``(env id, integrator)`` of a single env's reset and step.
RECORDED = {"env-step": ("DiscReactor-v0", "step"), "env-event": ("DiscReactor-v0", "event")}
#: The share of a recorded compile's kernel time a plan covers (what comes after the
#: reset's kernels: the helper and the env's process share it as they meet).
SHARE = 0.85
#: The longest a process waits for another's kernel before compiling it itself (seconds).
LOCK_TIMEOUT = 600.0

#: The helper's command (``-m`` would run this module a second time: the package imports it).
_MAIN = "import sys; from discgym.kernels.helper import main; sys.exit(main())"

_expected: list[str] = []
_helpers: list = []  # (the helpers started: kept, not collected while they run)
_started: set[str] = set()
_held: set = set()  # (the locks this process holds: their keys)


def switched_off(name: str) -> bool:
    """Whether the environment variable ``name`` is 0, "false", "no" or "off"."""
    return os.environ.get(name, "1").strip().lower() in ("0", "false", "no", "off")


def enabled() -> bool:
    """Whether this process may start a helper: ``DISCGYM_COMPILE_HELPER`` not off (a
    helper's own environment has it off), POSIX and at least two CPUs it may run on."""
    if fcntl is None or switched_off(ENV_VAR):
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
    import discgym

    root = str(Path(discgym.__file__).resolve().parent.parent)
    env = dict(os.environ, **{ENV_VAR: "0"})  # (a helper starts no helper)
    env["PYTHONPATH"] = os.pathsep.join([root] + [p for p in [env.get("PYTHONPATH")] if p])
    try:
        p = subprocess.Popen(
            [sys.executable, "-c", _MAIN, "run", plan, str(Path(discgym.__file__).resolve())],
            env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, start_new_session=True)
    except OSError:  # (no process to be had: this process compiles it all, as without one)
        return None
    _helpers.append(p)
    return p


def load_plans() -> dict:
    """The recorded plans usable with this numba: ``{}`` if none are, whatever the file
    holds (missing, unreadable, not a pickle or of an unknown protocol, another numba's,
    naming classes that no longer exist, or of another shape than :func:`record` writes).
    The plans only speed a first compile up: nothing in them may break the reset whose
    compile reads them."""
    import numba

    try:
        data = pickle.loads(PLANS_FILE.read_bytes())
    except Exception:  # (unpickling raises whatever the bytes make it raise)
        return {}
    if not isinstance(data, dict) or data.get("numba") != numba.__version__:
        return {}
    plans = data.get("plans")
    if not isinstance(plans, dict) or not all(
            isinstance(name, str) and isinstance(plan, list) and all(_is_kernel(k) for k in plan)
            for name, plan in plans.items()):
        return {}
    return plans


def _is_kernel(item) -> bool:
    """Whether ``item`` is a plan's entry as :func:`make_plan` writes it: ``(qualname, pickled
    argument types, seconds)``."""
    return (isinstance(item, tuple) and len(item) == 3 and isinstance(item[0], str)
            and isinstance(item[1], bytes) and isinstance(item[2], (int, float))
            and not isinstance(item[2], bool))


def _dispatcher(qualname: str):
    import importlib

    module, _, name = qualname.rpartition(".")
    return getattr(importlib.import_module(module), name)


def run(plan: str) -> int:
    """Compile ``plan``'s kernels (the helper process): the longest first, then the others
    from the last back, toward the env's process, which compiles them from the first; they
    meet where they meet, and a kernel the other has compiled is loaded. (The env's process
    reaches the longest only after its reset, its controls and the first phases; begun
    there, the meeting falls among short kernels, and the env's process waits little for
    one the helper is still compiling.) Exits at once if another helper holds the plan's
    lock on this cache."""
    kernels = load_plans().get(plan)
    if not kernels or fcntl is None:
        return 0
    path = _lock_path(getattr(_dispatcher(kernels[0][0]), "_cache", None))
    if path is None:
        return 0
    fd = os.open(path.with_name(f"discgym-helper-{plan}.lock"), os.O_RDWR | os.O_CREAT, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return 0
    longest = max(range(len(kernels)), key=lambda i: kernels[i][2])
    order = [longest] + [i for i in reversed(range(len(kernels))) if i != longest]
    for qualname, args, _seconds in (kernels[i] for i in order):
        try:
            _dispatcher(qualname).compile(pickle.loads(args))
        except Exception:  # (a stale plan: the process that needs the kernel compiles it)
            continue
    os.close(fd)
    return 0


def _lock_path(cache, sig=None) -> Path | None:
    """The lock file of a function's cache index (``cache``: its numba cache), or of one of
    its versions (``sig``: the argument types); None without a cache."""
    index = getattr(getattr(cache, "_cache_file", None), "_index_name", None)
    if index is None:
        return None
    if sig is not None:
        digest = hashlib.sha256(repr(tuple(sig)).encode()).hexdigest()[:16]
        index = f"{index}.{digest}"
    return Path(cache._cache_path) / f"{index}.lock"


@contextlib.contextmanager
def _flock(path: Path | None, key):
    """Within: this process holds the lock of ``path``, waiting for another process that
    holds it (at most :data:`LOCK_TIMEOUT`); nothing if ``path`` is None, if this process
    holds it already (``key``) or if the file cannot be opened."""
    if path is None or key in _held:
        yield
        return
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError:
        yield
        return
    try:
        deadline = time.monotonic() + LOCK_TIMEOUT
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:
                    break
                time.sleep(0.005)
        _held.add(key)
        try:
            yield
        finally:
            _held.discard(key)
    finally:
        os.close(fd)  # (releases the lock)


def compile_lock(disp, sig):
    """Within: this process holds the lock of ``disp``'s version for the argument types
    ``sig`` (module docstring), after waiting for another process that holds it."""
    if fcntl is None:
        return contextlib.nullcontext()
    return _flock(_lock_path(getattr(disp, "_cache", None), sig), (id(disp), tuple(sig)))


def index_lock(cache):
    """Within: this process holds the lock of the cache index of ``cache`` (a function's
    numba cache): while it saves a version there."""
    if fcntl is None:
        return contextlib.nullcontext()
    return _flock(_lock_path(cache), id(cache))


# -- recording the plans ------------------------------------------------------------------

def record_compile(env_id: str, integrator: str) -> list[dict]:
    """In this process (empty cache, no helper): reset and step ``env_id``'s single env on
    ``integrator``; every discgym kernel compiled, in the order numba began them, as dicts
    of ``qualname``, ``args`` (numba types), ``depth`` (of the compile stack), ``seconds``
    (inclusive)."""
    import gymnasium
    from numba.core import event

    import discgym  # noqa: F401  (registers the envs)
    from discgym.kernels.jit import KernelDispatcher

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
            item = {"qualname": f"{f.__module__}.{f.__qualname__}" if f else "?",
                    "args": tuple(ev.data.get("args") or ()), "depth": len(stack),
                    "kernel": isinstance(d, KernelDispatcher), "start": ts, "children": []}
            if stack:
                stack[-1]["children"].append(item)
            stack.append(item)
            out.append(item)
        else:
            item = stack.pop()
            item["seconds"] = ts - item["start"]
    return out


def make_plan(compiled: list[dict], share: float = SHARE) -> list[tuple[str, bytes, float]]:
    """The plan of a recorded compile: the units of work (each kernel an entry point
    calls; a kernel of more than a quarter of the whole split into the kernels it calls, its
    own lowering left to the process that needs it), in the order compiled; the plan is the
    last of them that add up to ``share`` of their seconds, as ``(qualname, pickled argument
    types, seconds)``."""
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
        plan.append((u["qualname"], pickle.dumps(u["args"]), round(u["seconds"], 3)))
    return plan[::-1]


def record(names=None) -> dict:
    """Record the plans (each in a child process with an empty cache) and write
    :data:`PLANS_FILE`."""
    import tempfile

    import numba

    plans = load_plans() if names else {}
    for name in names or RECORDED:
        env_id, integrator = RECORDED[name]
        with tempfile.TemporaryDirectory(prefix="discgym-plan-") as cache:
            out = Path(cache) / "plan.pkl"
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, DISCGYM_COMPILE_NOTICE="0",
                       **{ENV_VAR: "0"})
            subprocess.run([sys.executable, "-c", _MAIN, "record-one", env_id, integrator,
                            str(out)], env=env, check=True)
            plans[name] = pickle.loads(out.read_bytes())
    PLANS_FILE.write_bytes(pickle.dumps({"numba": numba.__version__, "plans": plans}))
    return plans


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["run"] and len(argv) == 3:
        import discgym

        if str(Path(discgym.__file__).resolve()) != argv[2]:
            return 0  # (another discgym than the process that started it: not its cache)
        return run(argv[1])
    if argv[:1] == ["record-one"] and len(argv) == 4:
        plan = make_plan(record_compile(argv[1], argv[2]))
        Path(argv[3]).write_bytes(pickle.dumps(plan))
        return 0
    if argv[:1] == ["record"]:
        for name, plan in record(argv[1:] or None).items():
            print(f"{name}: {len(plan)} kernels: {', '.join(q for q, _, _ in plan)}")
        return 0
    print("usage: main(['record', PLAN ...])", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
