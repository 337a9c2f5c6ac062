"""How many of numba's threads a compiled step runs on: measured, call by call.

Why: numba's OpenMP threads (libgomp) spin at the barriers of a parallel region before they
sleep. When another process holds one of the cores (a second seed run side by side, a
compile, a browser), the thread that shares that core runs at a fraction of its speed, and
the threads that wait for it at the barriers spin on the other cores: two threads then step
several times slower than one (docs/performance.md, "A busy machine"). A passive wait policy
does not fix it (every region's start then costs a wake-up: the idle step slows down, and
the work is still split evenly between a fast and a slow thread), and a process cannot know
how busy its cores will be. So the steps measure it.

:class:`ThreadChooser` runs each call on the count it has found cheapest (wall time per
unit of work), starting on every thread, as numba would. Now and then it tries the next
smaller and the next larger count of 1, 2, 4, ... up to numba's current count: a try runs
:data:`TRY_CALLS` calls on the other count, and the other count replaces the current one
when the median of their costs is lower than the median of the current count's last calls
by more than :data:`MARGIN`. The first try of fewer comes after :data:`PROBE_START` calls;
later tries after :data:`PROBE_MIN` calls, then twice as many
while they lose, up to :data:`PROBE_MAX`, and further apart where a try costs much more (the
tries take at most :data:`OVERHEAD` of the time); when the current count's calls get
dearer than :data:`CHANGE` times their cost at the last try (a core taken by another
process), both ways are tried at once. The first call
on each count is not measured (it may compile or load code), nor a call within
:data:`SETTLE` of one on more threads (whose idle threads spin on, taking cores), and a
count whose first call would compile code (a Simulation's serial entry) is tried only after
:data:`TRY_CALLS` calls in a row whose threads got less than :data:`BUSY_SHARE` of their
cores' time (the process's
CPU time over the wall time times the threads: numba's threads spin while they wait, so on
idle cores they fill them, and a much lower share means another process took part of
ours): an idle machine never compiles for a try. (The share alone does not decide: a short
call's threads also lose time waking up.)

The trajectory does not depend on the thread count (every parallel path gives the same
bits as the serial one), so the choice changes the speed only. ``DISCGYM_ADAPTIVE_THREADS=0``
fixes the count at numba's (the behaviour before the chooser).
"""

from __future__ import annotations

import contextlib
import math
import time

import numba

from .kernels.helper import switched_off

__all__ = ["ThreadChooser", "ENV_VAR", "BUSY_SHARE", "PROBE_START", "PROBE_MIN", "PROBE_MAX",
           "OVERHEAD", "MARGIN", "CHANGE", "TRY_CALLS", "SETTLE", "adaptive", "ladder",
           "numba_threads"]

#: The environment variable that turns the chooser off (0, false, no, off).
ENV_VAR = "DISCGYM_ADAPTIVE_THREADS"
#: After TRY_CALLS calls in a row whose threads got less than this share of their cores'
#: time, a count that compiles may be tried (measured on this VM, two threads of a
#: Simulation: 0.78-1.2 idle, 0.5-0.77 with one of the two cores taken).
BUSY_SHARE = 0.8
#: Calls between two tries of another count: from PROBE_MIN, doubling while they lose, to
#: PROBE_MAX; and at once at least as many as keep the tries' extra time under OVERHEAD of
#: the whole (after a try of 3 calls that took five times as long: 1,200 calls).
PROBE_MIN, PROBE_MAX, OVERHEAD = 4, 128, 0.01
#: Calls on every thread before the first try of fewer: a short run (a benchmark's ten
#: steps, an evaluation episode) pays nothing for tries on an idle machine.
PROBE_START = 32
#: A try measures TRY_CALLS calls on the other count; it replaces the current one when the
#: median of their costs is lower by more than MARGIN than the median of the current
#: count's last TRY_CALLS (a lucky call does not move it, nor a slow one keep it).
MARGIN, TRY_CALLS = 0.05, 3
#: When the current count's last TRY_CALLS calls cost more than CHANGE times what it cost
#: at the last try (the load changed: a core got taken), both ways are tried at once.
CHANGE = 1.3
#: Seconds after a call on more threads in which a call is not measured: numba's idle
#: threads spin on for a while (libgomp's spin count; about 8 ms on this VM), taking cores.
SETTLE = 0.02


def adaptive() -> bool:
    """Whether the chooser adapts (``DISCGYM_ADAPTIVE_THREADS`` not off)."""
    return not switched_off(ENV_VAR)


def ladder(most: int) -> list[int]:
    """The counts tried: 1, 2, 4, ... below ``most``, and ``most``."""
    out, k = [], 1
    while k < most:
        out.append(k)
        k *= 2
    return out + [most]


class ThreadChooser:
    """Chooses the thread count of each call of one stepper (a :class:`~discgym.Simulation`,
    a vector env) by measuring them (module docstring).

    ``pick(most)`` gives the count for the next call (at most ``most``, numba's current
    count); ``record(seconds, cpu_seconds, work)`` books that call: its wall time, the
    process's CPU time over it and the work it did (any measure proportional to the work of
    one thread: disc-substeps, say). :meth:`timed` does both around a call."""

    def __init__(self, compiles=None):
        #: ``compiles(t)``: whether a call on t threads would compile code this process has
        #: not loaded (a Simulation's serial entry, say); such a count is tried only when a
        #: call's threads were short of their cores, never on the schedule alone.
        self.compiles = compiles
        self._reset(1)

    def _reset(self, most: int) -> None:
        self.arms = ladder(most)
        self.current = len(self.arms) - 1  # (every thread, as numba would)
        self.recent: list[float] = []  # the current count's last TRY_CALLS costs
        self.trying: int | None = None  # the index under trial
        self.tried: list[float] = []  # its costs so far
        self.try_calls = 0  # calls made in the try, measured or not
        # calls until a larger count is tried (up) and a smaller one (down), and the
        # intervals they are reset to, growing while the tries lose
        self.wait = {+1: PROBE_MIN, -1: PROBE_START}
        self.interval = {+1: PROBE_MIN, -1: PROBE_MIN}
        self.seen: dict[int, int] = {}  # calls made on each count
        self.ended: dict[int, float] = {}  # when the last call on each count ended
        self.busy = 0  # the last calls in a row whose threads got less than BUSY_SHARE
        self.baseline: float | None = None  # the current count's cost at the last try

    @property
    def threads(self) -> int:
        """The count the calls run on, but for tries."""
        return self.arms[self.current]

    def pick(self, most: int) -> int:
        """The thread count of the next call (numba's current count being ``most``)."""
        most = max(int(most), 1)
        if most != self.arms[-1]:
            self._reset(most)
        if len(self.arms) == 1 or not adaptive():
            return most
        if self.trying is None:
            down = self.current - 1
            if down >= 0 and self.wait[-1] <= 0 and (
                    self.busy >= TRY_CALLS or self.compiles is None or
                    not self.compiles(self.arms[down])):
                self.trying = down
            elif self.wait[+1] <= 0 and self.current < len(self.arms) - 1:
                self.trying = self.current + 1
        return self.arms[self.current if self.trying is None else self.trying]

    def record(self, seconds: float, cpu_seconds: float, work: float,
               end: float | None = None) -> None:
        """Book the call :meth:`pick` chose the count of (``end``: when it ended, on
        ``time.perf_counter``'s clock; now by default)."""
        if len(self.arms) == 1 or not adaptive():
            return
        end = time.perf_counter() if end is None else end
        k = self.current if self.trying is None else self.trying
        t = self.arms[k]
        first = self.seen.get(t, 0) == 0
        # (the threads of a larger count spin on after it, taking this call's cores)
        settling = any(self.ended.get(u, -math.inf) > end - seconds - SETTLE
                       for u in self.arms[k + 1:])
        self.seen[t] = self.seen.get(t, 0) + 1
        self.ended[t] = end
        self.wait[+1] -= 1
        self.wait[-1] -= 1
        if self.trying is not None:
            self.try_calls += 1
        if work <= 0 or seconds <= 0:
            return
        # (calls in a row whose threads got less than BUSY_SHARE)
        self.busy = self.busy + 1 if t > 1 and cpu_seconds < BUSY_SHARE * seconds * t else 0
        if first or settling:  # (not measured)
            return
        c = seconds / work
        if self.trying is None:
            self.recent = (self.recent + [c])[-TRY_CALLS:]
            if self.baseline is not None and len(self.recent) == TRY_CALLS and \
                    _median(self.recent) > CHANGE * self.baseline:
                # (the load changed since the last try: both ways are tried again now)
                self.interval = {+1: PROBE_MIN, -1: PROBE_MIN}
                self.wait = {+1: 0, -1: 0}
                self.baseline = None
            return
        self.tried.append(c)
        if len(self.tried) < TRY_CALLS:
            return
        # the try's median against the current count's: the cheaper stays; a count that
        # lost is tried again later and later (at most OVERHEAD of the time on tries)
        way = +1 if k > self.current else -1
        mine = _median(self.recent) if self.recent else math.inf
        theirs = _median(self.tried)
        self.baseline = min(theirs, mine)
        if theirs < (1.0 - MARGIN) * mine:
            self.current = k
            self.recent = self.tried
            self.interval = {+1: PROBE_MIN, -1: PROBE_MIN}
            self.wait = dict(self.interval)
        else:
            lost = self.try_calls * (theirs / mine - 1.0)  # (in calls' time)
            self.interval[way] = max(min(2 * self.interval[way], PROBE_MAX),
                                     math.ceil(lost / OVERHEAD))
            self.wait[way] = self.interval[way]
        self.trying, self.tried, self.try_calls = None, [], 0

    def timed(self, most: int, call, work):
        """Run ``call(threads)`` on the chosen count and book it; ``work()`` (after the call)
        gives its work. Returns what ``call`` returns."""
        threads = self.pick(most)
        cpu0, t0 = time.process_time(), time.perf_counter()
        out = call(threads)
        end = time.perf_counter()
        cpu = time.process_time() - cpu0
        self.record(end - t0, cpu, work(), end)
        return out


def _median(values: list[float]) -> float:
    v = sorted(values)
    return 0.5 * (v[(len(v) - 1) // 2] + v[len(v) // 2])


@contextlib.contextmanager
def numba_threads(n: int):
    """numba's thread count of this thread set to ``n`` inside the block, restored after."""
    old = numba.get_num_threads()
    if n != old:
        numba.set_num_threads(n)
    try:
        yield
    finally:
        if n != old:
            numba.set_num_threads(old)
