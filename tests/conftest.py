"""Shared fixtures. The numba kernels compile once per machine (cached in __pycache__), so
tests share them simply by importing discgym; scenes here are small to keep CI fast."""

import numpy as np
import pytest

import discgym as dg
from discgym import threads


@pytest.fixture(autouse=True)
def fixed_thread_count(monkeypatch):
    """Every test runs its parallel calls on numba's threads, as it names them: the thread
    chooser (discgym.threads) would measure this machine's load and may take another path
    (the same bits, but not the path a test means to exercise or compile).
    tests/test_threads.py switches it back on."""
    monkeypatch.setenv(threads.ENV_VAR, "0")


@pytest.fixture
def gas_scene():
    return dg.Scene(bounds=dg.Box(20.0, 20.0), species=[dg.Species("A", 0.5, 1.0)],
                    counts={"A": 100}, dt=0.02)


def two_disc(scene, p1, p2, v1, v2, s1=0, s2=0, u=None, seed=0):
    return dg.Simulation.from_arrays(scene, np.array([p1, p2], float), np.array([v1, v2], float),
                                     [s1, s2], internal_energy=u, seed=seed)


@pytest.fixture(autouse=True, scope="session")
def sb3_logs_in_pytests_temp(tmp_path_factory):
    """Stable-Baselines3's ``learn`` makes a log folder even when it logs nothing
    (``$SB3_LOGDIR``, else a new ``SB3-<date>`` folder in the system's temporary folder,
    left there): keep those of the test run, its subprocesses' too, in pytest's own."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SB3_LOGDIR", str(tmp_path_factory.mktemp("sb3-logs")))
        yield
