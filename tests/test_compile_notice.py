"""The line logged when a process compiles discgym's kernels (discgym.kernels.notice): once,
at the first compile, and not when the kernels come from numba's cache."""

import logging

from numba import njit

from discgym.kernels import batch, notice
from discgym.kernels.jit import python_twin


def _probe(module: str):
    """A new dispatcher (never compiled) of a function that numba sees in ``module``."""

    def probe(x):
        return x + 1

    probe.__module__ = module
    return njit(probe)


def _notices(caplog) -> list:
    return [r for r in caplog.records if r.name == "discgym" and r.message == notice.MESSAGE]


def test_the_first_compile_in_a_process_says_so_once(caplog, monkeypatch):
    monkeypatch.delenv(notice.ENV_VAR, raising=False)
    notice.rearm()
    with caplog.at_level(logging.INFO, logger="discgym"):
        assert _probe("some_other_package")(1) == 2  # not discgym's: not ours to announce
        assert not _notices(caplog)
        assert _probe("discgym.kernels.probe")(1) == 2
        assert _probe("discgym.kernels.probe")(2) == 3  # a second compile: said already
    (rec,) = _notices(caplog)
    assert rec.levelno == logging.WARNING


def test_the_notice_can_be_switched_off(caplog, monkeypatch):
    monkeypatch.setenv(notice.ENV_VAR, "0")
    notice.rearm()
    with caplog.at_level(logging.INFO, logger="discgym"):
        assert _probe("discgym.kernels.probe")(1) == 2
    assert not _notices(caplog)


def test_nothing_is_said_when_the_kernels_come_from_the_cache(caplog, monkeypatch):
    monkeypatch.delenv(notice.ENV_VAR, raising=False)
    batch._clip(1.5, 0.0, 1.0)  # compiled, or loaded, and in numba's cache on disk now
    # a new dispatcher of what Python called (the kernel's twin): loads that version
    again = njit(cache=True)(python_twin(batch._clip).py_func)
    notice.rearm()
    with caplog.at_level(logging.INFO, logger="discgym"):
        assert again(1.5, 0.0, 1.0) == 1.0
    assert sum(again.stats.cache_hits.values()) == 1  # (the warm path was taken)
    assert not sum(again.stats.cache_misses.values())
    assert not _notices(caplog)
