"""The compile helper (discgym.kernels.helper) and the locks (discgym.kernels.locks): the
plans and the JSON of their argument types, the choice of a plan from a recorded compile,
when a helper is started and that it ends with the process that started it, and the locks
that make two processes share a compile. (That a helper shortens a first compile and leaves
the step the same, and that the plans match what the envs compile:
tests/test_compile_scope.py.)"""

import contextlib
import json
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
import pytest

from discgym.kernels import helper, jit, locks
from discgym.kernels.structs import Discs

linked_only = pytest.mark.skipif(jit.LAYER != jit.LINK_ONLY,
                                 reason="the plain kernel layer is in effect: no helper")


def test_plans_are_kernels_of_this_numba_in_compile_order():
    plans = helper.load_plans()
    if not plans:
        pytest.skip(f"the plans were recorded with another numba than {numba.__version__}")
    assert set(plans) == {"env-step", "env-event"}
    for name, plan in plans.items():
        assert plan, name
        for qualname, args, seconds in plan:
            assert jit.is_kernel(helper._dispatcher(qualname)), qualname
            types = [helper.decode_type(a) for a in args]
            assert [helper.encode_type(t) for t in types] == args and seconds >= 0
    # the last kernel an env's step compiles is the helper's first
    assert plans["env-step"][-1][0] == "discgym.kernels.batch._book"


def test_a_kernel_made_under_another_name_is_found_by_its_functions_name():
    """numba's compile events, so the plans, name a kernel's function: ``run_events =
    kernel(run_events_py)`` is found as ``events.run_events_py``; a plain function is not."""
    from discgym.kernels import events

    assert helper._dispatcher("discgym.kernels.events.run_events_py") is events.run_events
    assert helper._dispatcher("discgym.kernels.events.run_events") is events.run_events
    with pytest.raises(LookupError, match="not a kernel"):
        helper._dispatcher("discgym.kernels.events._run_inline")


def test_argument_types_read_back_from_their_json():
    from numba import typed, typeof, types

    discs = Discs(np.zeros((4, 2)), np.zeros((4, 2)), np.zeros(4, np.int32), np.zeros(4),
                  np.zeros(4, np.int64), np.zeros(1, np.int64))
    rngs = typed.List([np.random.default_rng(0)])
    ro = np.zeros(3)
    ro.flags.writeable = False
    for ty in (types.int64, types.boolean, types.none, types.float32, typeof(discs),
               typeof((np.zeros(2), np.zeros(2, np.int32))), typeof((1.0, 2.0)), typeof(rngs),
               typeof(np.zeros((2, 2))[:, 0]), typeof(ro), types.literal(False),
               types.Tuple([types.int64, types.float64[:, :]])):
        data = helper.encode_type(ty)
        assert helper.decode_type(json.loads(json.dumps(data))) == ty, ty
    with pytest.raises(TypeError):
        helper.encode_type(types.unicode_type)


@pytest.mark.parametrize("data", [
    {"namedtuple": "collections.OrderedDict", "fields": []},  # (not discgym's kernels)
    {"namedtuple": "os.system", "fields": []},
    {"namedtuple": "discgym.kernels.structs.FLOAT", "fields": []},  # (not a class)
    {"array": "float64", "ndim": 2, "layout": "Z"},
    {"array": "float64", "ndim": "2", "layout": "C"},
    {"array": "int128", "ndim": 1, "layout": "C"},
    "float128", 7, None, ["int64"], {"literal": 1.5},
])
def test_json_that_is_no_plan_type_is_refused(data):
    with pytest.raises((TypeError, ValueError, LookupError)):
        helper.decode_type(data)


def _item(name, seconds, children=(), kernel=True, depth=1):
    return {"qualname": name, "args": (name,), "seconds": seconds, "kernel": kernel,
            "depth": depth, "children": list(children)}


def test_make_plan_takes_the_later_share_splitting_a_large_kernel():
    leaves = [_item(f"adv.c{i}", 1.0, depth=2) for i in range(6)]
    entry = _item("entry", 12.0, [_item("a", 1.0), _item("adv", 7.0, leaves),
                                  _item("b", 1.0)], kernel=False, depth=0)
    reset = _item("reset", 3.0, [_item("r", 3.0)], kernel=False, depth=0)
    flat = [reset, *reset["children"], entry, *entry["children"], *leaves]
    # units in compile order: r 3, a 1, c0..c5 1 each, b 1 (adv is over a quarter: split);
    # 11 s of units, the later 0.7 of them: b, c5 ... c0 (7 s), then a (8 s >= 7.7)
    plan = helper.make_plan(flat, share=0.7)
    assert [q for q, _, _ in plan] == ["a"] + [f"adv.c{i}" for i in range(6)] + ["b"]
    assert plan[0][1] == ("a",) and plan[0][2] == 1.0
    assert [q for q, _, _ in helper.make_plan(flat, share=0.2)] == ["adv.c4", "adv.c5", "b"]


def test_the_helper_compiles_the_longest_kernel_first_then_from_the_last_back(
        monkeypatch, tmp_path):
    order = []

    class Fake:
        def __init__(self, name):
            self.name = name

        def compile(self, sig):
            order.append((self.name, sig))
            # (what it holds while it works: the plan's lock)
            assert (tmp_path / "discgym-helper-p.lock").exists()

    from numba import types

    plan = [(name, ["int64"], seconds)
            for name, seconds in [("a", 1.0), ("b", 5.0), ("c", 0.5), ("d", 2.0)]]
    stale = tmp_path / "x.nbi.0123.lock"  # (left by a process killed while it held it)
    stale.touch()
    monkeypatch.setattr(helper, "load_plans", lambda: {"p": plan})
    monkeypatch.setattr(helper, "_dispatcher", Fake)
    monkeypatch.setattr(jit, "lock_folder", lambda disp: tmp_path)
    if locks.fcntl is None:
        pytest.skip("no fcntl locks here")
    assert helper.run("p") == 0
    assert order == [(n, (types.int64,)) for n in "bdca"]
    assert not list(tmp_path.glob("*.lock"))  # (its own removed, and the one nobody held)


def test_a_helper_starts_once_per_expected_plan(monkeypatch):
    started = []
    monkeypatch.setattr(helper, "_expected", [])
    monkeypatch.setattr(helper, "_started", set())
    monkeypatch.setattr(helper, "_start", started.append)
    monkeypatch.setattr(helper, "enabled", lambda: True)
    helper.on_compile()
    assert started == []  # (nothing expected)
    helper.expect("env-step")
    helper.expect("env-step")
    helper.on_compile()
    helper.on_compile()
    helper.expect("env-event")
    helper.on_compile()
    assert started == ["env-step", "env-event"]


@pytest.mark.parametrize("value, on", [("0", False), ("off", False), ("no", False),
                                       ("1", True)])
def test_the_environment_variable_turns_the_helper_off(monkeypatch, value, on):
    monkeypatch.setenv(helper.ENV_VAR, value)
    assert helper.enabled() == (on and _cpus() >= 2 and locks.fcntl is not None
                                and jit.LAYER == jit.LINK_ONLY)


def test_there_is_no_helper_under_the_plain_layer(monkeypatch):
    monkeypatch.setenv(helper.ENV_VAR, "1")
    monkeypatch.setattr(jit, "LAYER", jit.PLAIN)
    assert not helper.enabled()


HOLDER = r"""
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT, 0o666)
fcntl.flock(fd, fcntl.LOCK_EX)
print("locked", flush=True)
time.sleep(float(sys.argv[3]))
open(sys.argv[2], "w").close()  # (written before the lock is released)
os.close(fd)
"""

needs_fcntl = pytest.mark.skipif(locks.fcntl is None, reason="no fcntl locks here")


@contextlib.contextmanager
def _holder(tmp_path, seconds: str, kill: bool = False):
    """Another process holding the lock ``k.nbi.0123.lock`` for ``seconds``, then writing
    the file ``released``: yields ``(path, released, process)`` once it holds the lock;
    waited for (killed first if ``kill``) on the way out."""
    path = tmp_path / "k.nbi.0123.lock"
    released = tmp_path / "released"
    p = subprocess.Popen([sys.executable, "-c", HOLDER, str(path), str(released), seconds],
                         stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "locked"
        yield path, released, p
    finally:
        if kill:
            p.kill()
        p.wait(timeout=60)


@needs_fcntl
def test_a_process_waits_for_the_lock_another_holds_and_removes_it(tmp_path):
    with _holder(tmp_path, "1.0") as (path, released, p):
        with locks.hold(path, "k"):
            assert released.exists()  # (entered only once the other process let go)
            assert path.exists()
            with locks.hold(path, "k"):  # (its own lock again: no wait on itself)
                pass
        assert not path.exists()  # (removed by its holder)
    assert p.returncode == 0


@needs_fcntl
def test_a_lock_wait_that_times_out_warns_naming_the_kernel(tmp_path, monkeypatch):
    with _holder(tmp_path, "30", kill=True) as (path, released, _p):
        monkeypatch.setattr(locks, "TIMEOUT", 0.3)
        entered = False
        with pytest.warns(locks.LockTimeoutWarning, match=r"discgym\.kernels\.events\.run_events"):
            with locks.hold(path, "compiling discgym.kernels.events.run_events(int64,)"):
                entered = True
        assert entered and not released.exists()  # (went on without the lock)


@linked_only
def test_a_kernel_compiles_under_a_lock_that_names_it(monkeypatch):
    from numba import types

    from discgym.kernels import linkonly

    held, hold = [], locks.hold

    def spy(path, what=""):
        held.append((path, what))
        return hold(path, what)

    monkeypatch.setattr(locks, "hold", spy)

    @jit.kernel
    def probe_kernel(x):
        return x + 1

    probe_kernel.compile((types.int64,))
    names = [(p.name if p else None, what) for p, what in held]
    assert any(what.startswith("compiling ") and "probe_kernel" in what
               and n and n.endswith(".lock") for n, what in names), names
    assert linkonly.lock_folder(probe_kernel) == Path(held[0][0]).parent


CONTENDER = r"""
import os, sys
sys.path.insert(0, sys.argv[1])
from discgym.kernels import locks
lock, inside = sys.argv[2], sys.argv[3]
for _ in range(int(sys.argv[4])):
    with locks.hold(lock, "contended"):
        fd = os.open(inside, os.O_CREAT | os.O_EXCL | os.O_WRONLY)  # (fails if another is in)
        os.close(fd)
        os.unlink(inside)
"""


@needs_fcntl
def test_removing_lock_files_keeps_one_holder_at_a_time(tmp_path):
    """Three processes take and let go of one lock (each removing its file) many times:
    never two inside at once (a waiter that opened a removed file locks the new one)."""
    root = str(Path(__file__).resolve().parents[1])
    lock, inside = tmp_path / "c.lock", tmp_path / "inside"
    procs = [subprocess.Popen([sys.executable, "-c", CONTENDER, root, str(lock), str(inside),
                               "300"], stderr=subprocess.PIPE, text=True) for _ in range(3)]
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err[-2000:]
    assert not lock.exists() and not inside.exists()


@needs_fcntl
def test_sweep_removes_only_the_lock_files_nobody_holds(tmp_path):
    free, held = tmp_path / "a.lock", tmp_path / "b.lock"
    free.touch()
    released = tmp_path / "released"
    p = subprocess.Popen([sys.executable, "-c", HOLDER, str(held), str(released), "30"],
                         stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "locked"
        (tmp_path / "numba.nbi").touch()
        assert locks.sweep(tmp_path) == 1
        assert not free.exists() and held.exists() and (tmp_path / "numba.nbi").exists()
    finally:
        p.kill()
        p.wait(timeout=60)


CORRUPT_PLANS = {
    "empty": b"",
    "not json": b"plans",
    "a pickle": pickle.dumps({"numba": numba.__version__, "plans": {}}),
    "truncated": json.dumps({"format": 1, "numba": numba.__version__,
                             "plans": {}}).encode()[:-3],
    "a list": b"[1, 2, 3]",
    "a number": b"7",
    "another numba": json.dumps({"format": 1, "numba": "0.0.1",
                                 "plans": {"env-step": []}}).encode(),
    "another format": json.dumps({"format": 99, "numba": numba.__version__,
                                  "plans": {"env-step": []}}).encode(),
    "plans a list": json.dumps({"format": 1, "numba": numba.__version__,
                                "plans": [1]}).encode(),
    "a plan a dict": json.dumps({"format": 1, "numba": numba.__version__,
                                 "plans": {"env-step": {"a": 1}}}).encode(),
    "an entry without args": json.dumps({"format": 1, "numba": numba.__version__, "plans": {
        "env-step": [{"kernel": "a.b", "seconds": 1.0}]}}).encode(),
    "an entry's types": json.dumps({"format": 1, "numba": numba.__version__, "plans": {
        "env-step": [{"kernel": "a.b", "args": "x", "seconds": 1.0}]}}).encode(),
    "seconds a bool": json.dumps({"format": 1, "numba": numba.__version__, "plans": {
        "env-step": [{"kernel": "a.b", "args": [], "seconds": True}]}}).encode(),
    "not utf-8": b"\xff\xfe\x00",
}


@pytest.mark.parametrize("case", CORRUPT_PLANS)
def test_a_corrupt_plans_file_is_no_plan_and_starts_no_helper(monkeypatch, tmp_path, case):
    path = tmp_path / "plans.json"
    path.write_bytes(CORRUPT_PLANS[case])
    monkeypatch.setattr(helper, "PLANS_FILE", path)
    assert helper.load_plans() == {}
    # the path a first compile takes (kernels.notice's listener): nothing raises, no process
    monkeypatch.setattr(helper, "_expected", ["env-step"])
    monkeypatch.setattr(helper, "_started", set())
    monkeypatch.setattr(helper, "enabled", lambda: True)
    monkeypatch.setattr(subprocess, "Popen", lambda *a, **k: pytest.fail("a helper started"))
    helper.on_compile()
    assert helper._started == {"env-step"}
    assert helper.run("env-step") == 0


def test_a_plan_file_as_write_plans_writes_it_is_read_back(monkeypatch, tmp_path):
    plan = [("discgym.kernels.batch._book", ["int64", {"array": "float64", "ndim": 1,
                                                        "layout": "C"}], 0.25)]
    path = tmp_path / "plans.json"
    helper.write_plans({"env-step": plan, "env-event": []}, path)
    monkeypatch.setattr(helper, "PLANS_FILE", path)
    assert helper.load_plans() == {"env-step": plan, "env-event": []}


def test_a_stale_plan_entry_is_skipped_by_the_helper(monkeypatch, tmp_path):
    compiled = []

    class Fake:
        def __init__(self, name):
            if name == "gone":
                raise LookupError(name)
            self.name = name

        def compile(self, sig):
            compiled.append(self.name)

    plan = [("first", ["int64"], 1.0), ("gone", ["int64"], 1.0),
            ("bad types", [{"namedtuple": "os.system", "fields": []}], 1.0),
            ("last", ["float64"], 1.0)]
    monkeypatch.setattr(helper, "load_plans", lambda: {"p": plan})
    monkeypatch.setattr(helper, "_dispatcher", Fake)
    monkeypatch.setattr(jit, "lock_folder", lambda disp: tmp_path)
    if locks.fcntl is None:
        pytest.skip("no fcntl locks here")
    assert helper.run("p") == 0
    assert compiled == ["first", "last"]


RESET_WITH = r"""
import sys
from pathlib import Path
from discgym.kernels import helper
helper.PLANS_FILE = Path(sys.argv[1])
import gymnasium as gym, discgym
env = gym.make("DiscReactor-v0", n_discs=20)
env.reset(seed=0)
print("reset", flush=True)
"""


def test_a_reset_that_compiles_survives_a_corrupt_plans_file(tmp_path):
    # a fresh cache, so that the reset compiles and the compile listener reads the plans
    (tmp_path / "plans.json").write_bytes(CORRUPT_PLANS["not utf-8"])
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    env[helper.ENV_VAR] = "1"
    out = subprocess.run([sys.executable, "-c", RESET_WITH, str(tmp_path / "plans.json")],
                         env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0 and "reset" in out.stdout, out.stderr[-2000:]


def test_the_helper_imports_the_kernels_without_the_package_above_them():
    code = helper._MAIN.replace("sys.exit(main())",
                                "import json; print(json.dumps(sorted(sys.modules)))")
    env = dict(os.environ, PYTHONPATH=str(Path(helper.__file__).resolve().parents[2]))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    modules = json.loads(out.stdout.strip().splitlines()[-1])
    assert "discgym.kernels.helper" in modules and "discgym.kernels.jit" in modules
    assert not [m for m in modules if m.startswith(("gymnasium", "discgym.env",
                                                    "discgym.simulation", "discgym.vector"))]


def _helpers_of(parent: int) -> list[int]:
    """The pids of the discgym helper processes started by ``parent`` (their command line
    names the helper module and, last, the parent's pid)."""
    found = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            argv = (proc / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        argv = [a.decode(errors="replace") for a in argv if a]
        if (len(argv) >= 4 and "discgym.kernels.helper" in " ".join(argv)
                and argv[-4] == "run" and argv[-1] == str(parent)):
            found.append(int(proc.name))
    return found


def _gone_within(parent: int, seconds: float) -> list[int]:
    """The helpers of ``parent`` still there after ``seconds`` (killed then: cleaned up)."""
    deadline = time.monotonic() + seconds
    while (left := _helpers_of(parent)) and time.monotonic() < deadline:
        time.sleep(0.1)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    return left


def _cpus() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1


helper_here = pytest.mark.skipif(
    jit.LAYER != jit.LINK_ONLY or locks.fcntl is None or _cpus() < 2
    or not helper.load_plans() or not Path("/proc/self/cmdline").exists(),
    reason="no compile helper here (plain layer, one CPU, no plans for this numba or no "
           "/proc)")

STARTER = r"""
import sys, time
from discgym.kernels import helper
p = helper._start("env-step")
print(p.pid, flush=True)
time.sleep(float(sys.argv[1]))
"""

KILLED = r"""
import gymnasium as gym, discgym
env = gym.make("DiscReactor-v0", n_discs=20)
print("made", flush=True)
env.reset(seed=0)
env.step(env.action_space.sample())
"""


@helper_here
def test_a_helper_ends_when_the_process_that_started_it_exits(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), **{helper.ENV_VAR: "1"})
    p = subprocess.Popen([sys.executable, "-c", STARTER, "3"], env=env,
                         stdout=subprocess.PIPE, text=True)
    try:
        pid = int(p.stdout.readline())
        deadline = time.monotonic() + 10  # (its command line shows once it has started)
        while not _helpers_of(p.pid) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert _helpers_of(p.pid) == [pid]  # (at work on its plan: an empty cache)
        assert p.wait(timeout=60) == 0
        assert _gone_within(p.pid, 5.0) == []
    finally:
        p.kill()
        p.wait()
        _gone_within(p.pid, 0.0)


@helper_here
def test_no_helper_is_left_once_a_killed_envs_process_has_ended(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), **{helper.ENV_VAR: "1"})
    p = subprocess.Popen([sys.executable, "-c", KILLED], env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True)
    try:
        assert p.stdout.readline().strip() == "made"
        deadline = time.monotonic() + 120
        while not _helpers_of(p.pid):  # (started at the reset's first compile)
            assert p.poll() is None and time.monotonic() < deadline, "no helper started"
            time.sleep(0.05)
        p.kill()
        p.wait(timeout=60)
        assert _gone_within(p.pid, 5.0) == []
    finally:
        p.kill()
        p.wait()
        _gone_within(p.pid, 0.0)
