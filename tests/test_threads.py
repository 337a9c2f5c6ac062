"""The thread chooser (discgym.threads): which counts it runs calls on, given what the calls
cost (a fake clock: no test here times anything), and that whatever it picks a Simulation
and a vector env give the same bits."""

import math

import numba
import numpy as np
import pytest

import discgym as dg
from discgym import threads as T
from discgym.bench import bench_scene
from discgym.kernels import drift as DR
from discgym.vector import DiscReactorVectorEnv


@pytest.fixture(autouse=True)
def adaptive(monkeypatch):
    monkeypatch.delenv(T.ENV_VAR, raising=False)


def drive(chooser, most, calls, cost, share):
    """Make ``calls`` calls: a call on t threads takes ``cost(t)`` seconds per unit of work
    and gets ``share(t)`` of its threads' cores. Returns the counts picked."""
    picked = []
    for _ in range(calls):
        t = chooser.pick(most)
        picked.append(t)
        seconds = cost(t) * 0.01  # (a call of 10 ms on the cheapest count)
        chooser.clock = getattr(chooser, "clock", 0.0) + seconds
        chooser.record(seconds, share(t) * seconds * t, 1000.0, chooser.clock)
    return picked


IDLE = dict(cost={1: 1.5, 2: 1.0}.get, share=lambda t: 1.0)
# one core taken: two threads get 2/3 of their cores and step 2.5x slower than one
BUSY = dict(cost={1: 1.0, 2: 2.5}.get, share=lambda t: 1.0 if t == 1 else 0.66)


def _tries(picked, count):
    """How many runs of consecutive calls on ``count`` ``picked`` holds."""
    return sum(1 for i, t in enumerate(picked) if t == count and (i == 0 or picked[i - 1] != t))


def _spent(picked, cost):
    """The time of the calls ``picked`` over that of the same calls on the best count."""
    return sum(cost(t) for t in picked) / (len(picked) * min(map(cost, set(picked))))


def test_the_ladder_of_counts():
    assert T.ladder(1) == [1]
    assert T.ladder(2) == [1, 2]
    assert T.ladder(6) == [1, 2, 4, 6]
    assert T.ladder(8) == [1, 2, 4, 8]


def test_idle_cores_keep_every_thread_trying_one_ever_more_rarely():
    c = T.ThreadChooser()
    picked = drive(c, 2, 2000, **IDLE)
    assert c.threads == 2 and picked[:T.PROBE_START] == [2] * T.PROBE_START
    assert _tries(picked[-1000:], 1) <= 1000 // T.PROBE_MAX + 1
    assert c.interval[-1] >= T.PROBE_MAX
    assert _spent(picked[-1000:], IDLE["cost"]) < 1.0 + 1.5 * T.OVERHEAD  # (the start aside)


def test_a_busy_core_moves_to_one_thread_and_tries_two_ever_more_rarely():
    c = T.ThreadChooser()
    picked = drive(c, 2, 2000, **BUSY)
    # one thread tried after PROBE_START calls: its first call not measured (it may
    # compile), nor the next while two threads spin on (10 ms calls), then TRY_CALLS decide
    n = T.PROBE_START + 2 + T.TRY_CALLS
    assert picked[:n] == [2] * T.PROBE_START + [1] * (n - T.PROBE_START)
    assert c.threads == 1 and picked[n:n + 20].count(2) <= 2 * T.TRY_CALLS
    assert _tries(picked[-1000:], 2) <= 1000 // T.PROBE_MAX + 1
    assert c.interval[+1] >= T.PROBE_MAX
    assert _spent(picked[-1000:], BUSY["cost"]) < 1.0 + 1.5 * T.OVERHEAD


def test_a_core_taken_after_a_lost_try_is_noticed_at_once():
    # a fresh process: its first calls on two threads get both cores (the other process
    # waits), so the first try of one thread loses; then the core is taken
    c = T.ThreadChooser()
    drive(c, 2, T.PROBE_START + 20, **IDLE)
    assert c.threads == 2 and c.wait[-1] > 20
    picked = drive(c, 2, 20, **BUSY)
    assert c.threads == 1 and picked[-5:] == [1] * 5


def test_freed_cores_bring_every_thread_back():
    c = T.ThreadChooser()
    drive(c, 2, 1000, **BUSY)
    assert c.threads == 1
    drive(c, 2, c.wait[+1] + T.TRY_CALLS + 10, **IDLE)
    assert c.threads == 2


def test_a_dear_try_is_made_rarely_at_once():
    c = T.ThreadChooser()
    cost = {1: 1.0, 2: 10.0}.get  # (a core taken from a simulation whose threads spin)
    picked = drive(c, 2, 3000, cost, share=lambda t: 1.0 if t == 1 else 0.3)
    assert c.interval[+1] == math.ceil(T.TRY_CALLS * 9.0 / T.OVERHEAD)
    assert _spent(picked[-1500:], cost) < 1.0 + 2 * T.OVERHEAD  # (the start aside)


def test_one_lucky_or_slow_call_does_not_move_it():
    c = T.ThreadChooser()
    noisy = iter(range(10**6))
    # every third call on one thread is as fast as two threads' (the median holds)
    for _ in range(1000):
        drive(c, 2, 1, lambda t: 1.0 if t == 2 or next(noisy) % 3 else 0.5,
              share=lambda t: 1.0)
        assert c.threads == 2


def test_a_count_that_would_compile_is_tried_only_on_a_busy_sign():
    compiled = set()

    def run(c, calls, cost, share):  # (a call on one thread compiles the serial code)
        for _ in range(calls):
            compiled.update(drive(c, 2, 1, cost, share))

    c = T.ThreadChooser(compiles=lambda t: t not in compiled)
    run(c, 300, **IDLE)
    assert compiled == {2}
    run(c, 12, **BUSY)  # (busy calls, then one thread: its first call, the try)
    assert compiled == {1, 2} and c.threads == 1


def test_on_eight_threads_it_settles_on_the_cheapest_count():
    cost = {1: 4.0, 2: 2.2, 4: 1.5, 8: 1.9}.get  # (four cores free of eight)
    share = {1: 1.0, 2: 1.0, 4: 0.95, 8: 0.55}.get
    c = T.ThreadChooser()
    drive(c, 8, 300, cost, share)
    assert c.threads == 4


def test_switched_off_or_one_thread_it_gives_numbas_count(monkeypatch):
    c = T.ThreadChooser()
    assert drive(c, 1, 20, **BUSY) == [1] * 20
    monkeypatch.setenv(T.ENV_VAR, "0")
    c = T.ThreadChooser()
    assert drive(c, 2, 50, **BUSY) == [2] * 50


def test_a_new_thread_count_starts_over():
    c = T.ThreadChooser()
    drive(c, 2, 50, **BUSY)
    assert c.threads == 1
    assert c.pick(4) == 4 and c.arms == [1, 2, 4]


def test_calls_while_the_threads_of_more_spin_on_are_not_measured():
    c = T.ThreadChooser()
    for end in (1.0, 1.004, 1.008, 1.012):  # (the first on two threads is not measured)
        c.pick(2)
        c.record(0.004, 0.008, 1.0, end=end)
    assert c.recent == [0.004] * 3
    c.trying = 0  # a try of one thread: its first call, then calls in the spin's time
    for end in (1.016, 1.020, 1.024, 1.028):
        c.pick(2)
        c.record(0.004, 0.004, 1.0, end=end)
    assert c.tried == [] and c.try_calls == 4
    c.pick(2)
    c.record(0.004, 0.004, 1.0, end=1.012 + T.SETTLE + 0.0041)
    assert c.tried == [0.004]


def test_calls_without_work_teach_nothing():
    c = T.ThreadChooser()
    for _ in range(20):
        c.pick(2)
        c.record(1.0, 0.1, 0.0)
    assert c.recent == [] and c.threads == 2


def _alternating(monkeypatch) -> list:
    """Make every chooser alternate between one thread and numba's count, call by call;
    returns the list of the counts given."""
    given = []
    monkeypatch.setattr(T.ThreadChooser, "pick",
                        lambda self, most: given.append(most if len(given) % 2 else 1)
                        or given[-1])
    return given


@pytest.mark.skipif(numba.get_num_threads() < 2, reason="numba has one thread here")
def test_a_simulation_gives_the_same_bits_whatever_the_counts(monkeypatch):
    sim = dg.Simulation(bench_scene(DR.PARALLEL_MIN + 2000), seed=21)
    fixed = sim.copy()
    monkeypatch.setenv(T.ENV_VAR, "0")
    for _ in range(4):
        fixed.step(3)
    monkeypatch.delenv(T.ENV_VAR)
    given = _alternating(monkeypatch)
    for _ in range(4):
        sim.step(3)
    assert given == [1, 2, 1, 2]
    for a, b in ((sim.positions, fixed.positions), (sim.velocities, fixed.velocities)):
        assert np.array_equal(a, b)
    assert sim.counters() == fixed.counters() and np.array_equal(sim._fsum, fixed._fsum)


@pytest.mark.skipif(numba.get_num_threads() < 2, reason="numba has one thread here")
def test_a_vector_env_gives_the_same_bits_whatever_the_counts(monkeypatch):
    kw = dict(num_envs=5, n_discs=60, episode_steps=8)
    one = DiscReactorVectorEnv(threads=1, **kw)
    given = _alternating(monkeypatch)
    many = DiscReactorVectorEnv(**kw)
    rng = np.random.default_rng(3)
    o1, _ = one.reset(seed=4)
    o2, _ = many.reset(seed=4)
    assert np.array_equal(o1, o2)
    for _ in range(12):  # (through an autoreset)
        a = rng.uniform(-1, 1, one.action_space.shape).astype(np.float32)
        r1, r2 = one.step(a), many.step(a)
        for x, y in zip(r1[:4], r2[:4]):
            assert np.array_equal(x, y)
    assert set(given) == {1, 2} and len(given) == 11  # (the 9th step only resets)
