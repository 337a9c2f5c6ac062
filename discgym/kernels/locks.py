"""Locks shared between processes: one file per lock, ``fcntl.flock`` on it, the file
removed by its holder when it lets go.

Removing a lock file is safe only if no process can end up holding the lock of a file
that is no longer the one at the path (a waiter that opened the old file would get its
lock while a newcomer locks the new one). So the holder removes the file *while holding
it*, and a process that has taken a lock checks that the path still names the file it
locked, and starts again otherwise. A lock file is left behind only by a process that
was killed while holding it (the lock itself goes with the process): the next process
to take that lock removes it, and :func:`sweep` removes those that nobody holds.

A wait that lasts :data:`TIMEOUT` warns, naming what it waited for, and goes on without
the lock (two processes may then compile one kernel twice; numba's cache stays valid).
Without ``fcntl`` (not POSIX) there are no locks. Pure Python: no numba here.
"""

from __future__ import annotations

import contextlib
import os
import time
import warnings
from pathlib import Path

try:
    import fcntl
except ImportError:  # (not POSIX)
    fcntl = None

#: The longest a process waits for a lock before it goes on without it (seconds).
TIMEOUT = 600.0
#: How often a waiting process tries again (seconds).
POLL = 0.005
#: What a lock file's name ends with.
SUFFIX = ".lock"

_held: set[str] = set()  # (the paths of the locks this process holds)


class LockTimeoutWarning(RuntimeWarning):
    """A lock wait timed out and the process went on without the lock."""


def _same_file(fd: int, path: Path) -> bool:
    try:
        st = os.stat(path)
    except OSError:
        return False
    mine = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (mine.st_dev, mine.st_ino)


def _acquire(path: Path, deadline: float) -> int | None:
    """An open descriptor of ``path`` whose lock this process holds, the file still at
    ``path``; None at the deadline. Raises OSError if the file cannot be opened."""
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:
                    os.close(fd)
                    return None
                time.sleep(POLL)
        if _same_file(fd, path):
            return fd
        os.close(fd)  # (its holder removed it before letting go: lock the file there now)


def _release(fd: int, path: Path) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)  # (while holding it: see the module docstring)
    os.close(fd)


@contextlib.contextmanager
def hold(path: Path | None, what: str = ""):
    """Within: this process holds the lock ``path``, after waiting for another process
    that holds it (at most :data:`TIMEOUT`; then a :class:`LockTimeoutWarning` naming
    ``what`` and no lock); the file is removed on leaving. Nothing if ``path`` is None,
    without ``fcntl``, if this process holds the lock already or if the file cannot be
    opened."""
    key = None if path is None else os.fspath(path)
    if fcntl is None or key is None or key in _held:
        yield
        return
    try:
        fd = _acquire(Path(key), time.monotonic() + TIMEOUT)
    except OSError:  # (a cache folder this process cannot write: nothing to share)
        yield
        return
    if fd is None:
        warnings.warn(f"discgym: waited {TIMEOUT:g} s for another process to finish "
                      f"{what or key} (lock {key}); going on without it",
                      LockTimeoutWarning, stacklevel=3)
        yield
        return
    _held.add(key)
    try:
        yield
    finally:
        _held.discard(key)
        _release(fd, Path(key))


def try_hold(path: Path) -> int | None:
    """The lock ``path`` if no process holds it (an open descriptor: pass it to
    :func:`release`), else None; never waits."""
    if fcntl is None:
        return None
    try:
        return _acquire(path, -1.0)
    except OSError:
        return None


def release(fd: int, path: Path) -> None:
    """Let go of a lock taken with :func:`try_hold`, removing its file."""
    _release(fd, path)


def sweep(folder: Path, pattern: str = "*" + SUFFIX) -> int:
    """Remove the lock files in ``folder`` that no process holds (left by killed
    processes); returns how many."""
    if fcntl is None:
        return 0
    removed = 0
    for path in Path(folder).glob(pattern):
        if os.fspath(path) in _held:
            continue
        fd = try_hold(path)
        if fd is not None:
            release(fd, path)
            removed += 1
    return removed
