"""The compile helper (discgym.kernels.helper): the plans, the choice of a plan from a
recorded compile, when a helper is started, and the locks that make two processes share a
compile. (That a helper shortens a first compile and leaves the step the same, and that
the plans match what the envs compile: tests/test_compile_scope.py.)"""

import os
import pickle
import subprocess
import sys

import numba
import pytest

from discgym.kernels import helper
from discgym.kernels.jit import KernelDispatcher


def test_plans_are_kernels_of_this_numba_in_compile_order():
    plans = helper.load_plans()
    if not plans:
        pytest.skip(f"the plans were recorded with another numba than {numba.__version__}")
    assert set(plans) == set(helper.RECORDED)
    for name, plan in plans.items():
        assert plan, name
        for qualname, args, seconds in plan:
            assert isinstance(helper._dispatcher(qualname), KernelDispatcher), qualname
            assert isinstance(pickle.loads(args), tuple) and seconds >= 0
    # the last kernel an env's step compiles is the helper's first
    assert plans["env-step"][-1][0] == "discgym.kernels.batch._book"


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
    assert pickle.loads(plan[0][1]) == ("a",) and plan[0][2] == 1.0
    assert [q for q, _, _ in helper.make_plan(flat, share=0.2)] == ["adv.c4", "adv.c5", "b"]


def test_the_helper_compiles_the_longest_kernel_first_then_from_the_last_back(
        monkeypatch, tmp_path):
    from types import SimpleNamespace

    order = []

    class Fake:
        _cache = SimpleNamespace(_cache_path=str(tmp_path),
                                 _cache_file=SimpleNamespace(_index_name="f.nbi"))

        def __init__(self, name):
            self.name = name

        def compile(self, sig):
            order.append((self.name, sig))

    plan = [(name, pickle.dumps((name,)), seconds)
            for name, seconds in [("a", 1.0), ("b", 5.0), ("c", 0.5), ("d", 2.0)]]
    monkeypatch.setattr(helper, "load_plans", lambda: {"p": plan})
    monkeypatch.setattr(helper, "_dispatcher", Fake)
    assert helper.run("p") == 0
    assert order == [("b", ("b",)), ("d", ("d",)), ("c", ("c",)), ("a", ("a",))]
    assert (tmp_path / "discgym-helper-p.lock").exists()


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
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    assert helper.enabled() == (on and cpus >= 2 and helper.fcntl is not None)


HOLDER = r"""
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT, 0o666)
fcntl.flock(fd, fcntl.LOCK_EX)
print("locked", flush=True)
time.sleep(1.0)
open(sys.argv[2], "w").close()  # (written before the lock is released)
os.close(fd)
"""


@pytest.mark.skipif(helper.fcntl is None, reason="no fcntl locks here")
def test_a_process_waits_for_the_kernel_another_holds(tmp_path):
    from discgym.kernels.batch import _book as kernel

    sig = helper.load_plans().get("env-step", [(None, pickle.dumps(("a type",)), 0.0)])[-1][1]
    sig = pickle.loads(sig)
    path = helper._lock_path(kernel._cache, sig)
    assert path is not None and path.name.endswith(".lock") and ".nbi." in path.name
    assert helper._lock_path(kernel._cache, sig[:-1]) != path  # (a lock per version)
    path.parent.mkdir(parents=True, exist_ok=True)
    released = tmp_path / "released"
    p = subprocess.Popen([sys.executable, "-c", HOLDER, str(path), str(released)],
                         stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "locked"
        with helper.compile_lock(kernel, sig):
            assert released.exists()  # (entered only once the other process let go)
            with helper.compile_lock(kernel, sig):  # (its own lock again: no wait on itself)
                pass
    finally:
        p.wait(timeout=60)
    assert p.returncode == 0


CORRUPT_PLANS = {
    "empty": b"",
    "not a pickle": b"plans",
    "unknown protocol": b"\x80\x09" + b"\x00" * 16,
    "truncated": pickle.dumps({"numba": numba.__version__, "plans": {}})[:-3],
    "a list": pickle.dumps([1, 2, 3]),
    "a number": pickle.dumps(7),
    "a missing class": b"cdiscgym_no_such_module\nThing\n.",
    "another numba": pickle.dumps({"numba": "0.0.1", "plans": {"env-step": []}}),
    "plans a list": pickle.dumps({"numba": numba.__version__, "plans": [1]}),
    "a plan a dict": pickle.dumps({"numba": numba.__version__, "plans": {"env-step": {}}}),
    "an entry of two": pickle.dumps({"numba": numba.__version__,
                                     "plans": {"env-step": [("a.b", b"x")]}}),
    "an entry's types": pickle.dumps({"numba": numba.__version__,
                                      "plans": {"env-step": [("a.b", "x", 1.0)]}}),
}


@pytest.mark.parametrize("case", CORRUPT_PLANS)
def test_a_corrupt_plans_file_is_no_plan_and_starts_no_helper(monkeypatch, tmp_path, case):
    path = tmp_path / "plans.pkl"
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


def test_a_plan_file_as_record_writes_it_is_read_back(monkeypatch, tmp_path):
    plan = [("discgym.kernels.batch._book", pickle.dumps(("a type",)), 0.25)]
    path = tmp_path / "plans.pkl"
    path.write_bytes(pickle.dumps({"numba": numba.__version__, "plans": {"env-step": plan}}))
    monkeypatch.setattr(helper, "PLANS_FILE", path)
    assert helper.load_plans() == {"env-step": plan}


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
    (tmp_path / "plans.pkl").write_bytes(CORRUPT_PLANS["unknown protocol"])
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    env[helper.ENV_VAR] = "1"
    out = subprocess.run([sys.executable, "-c", RESET_WITH, str(tmp_path / "plans.pkl")],
                         env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0 and "reset" in out.stdout, out.stderr[-2000:]
