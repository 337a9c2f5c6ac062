"""The per-step logic the single and the vector env share: reading an action, observing
reactors at reset, the checks after a compiled step."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .kernels.batch import (
    O_STATUS,
    observe_batch,
)
from .kernels.structs import (
    FLOAT,
    Episodes,
    Reactors,
)

if TYPE_CHECKING:
    from .config import ReactorConfig


# --------------------------------------------------------------------------------------------
# the per-step logic, shared with the vector env


def observe(cfg: ReactorConfig, rx: Reactors, ep: Episodes) -> None:
    """Fill ``ep.stats`` (R, 3S+1), ``ep.temperature`` and ``ep.kinetic`` (R,) and
    ``ep.obs`` (R, D) float32 for R reactors (see :func:`discgym.kernels.batch.observe_one`);
    a step observes inside :func:`discgym.kernels.batch.env_step`, this is for resets."""
    observe_batch(tuple(rx), tuple(ep), cfg.compiled.sp_mass, tuple(cfg.consts))


def check_status(cfg: ReactorConfig, iout: np.ndarray, active: np.ndarray) -> None:
    """Raise if an ``active`` reactor of the last :func:`~discgym.kernels.batch.env_step`
    outgrew its arrays (it cannot: the capacity plan bounds every reactor; this would be a
    bug)."""
    status = np.where(active, iout[:, O_STATUS], 0)
    if status.any():
        bad = np.flatnonzero(status).tolist()
        raise RuntimeError(f"reactors {bad}: the state outgrew the capacity {cfg.capacity} "
                           f"(status {status[bad].tolist()}); this is a bug in the capacity "
                           "plan")


def integrator_changed(cfg: ReactorConfig, now: str, who: str) -> RuntimeError:
    """The error of a step whose reactor's ``Simulation`` was switched to another integrator
    (by ``set_state``) than the env runs: the compiled step runs the env's, and the
    Simulation would no longer describe its own trajectory."""
    return RuntimeError(
        f"integrator: {who} now has integrator {now!r} (set_state with a state of another "
        f"integrator), the env was made with integrator={cfg.integrator!r} and steps with "
        f"it; set a state of integrator {cfg.integrator!r} (or without the key) or reset")


REAL_KINDS = frozenset("biuf")  # numpy dtype kinds of actions: bool, integers, floats


def as_actions(cfg: ReactorConfig, action, batch: int | None = None) -> np.ndarray:
    """``action`` as a float64 array of shape (A,), or (batch, A) for a batch (an array,
    or a list of per-reactor actions): exactly that shape, never reshaped; real numbers only
    (bool, integer or float dtypes). Anything else raises (``ValueError`` naming the expected
    and the received shape, ``TypeError`` naming the dtype) before anything is stepped."""
    what = "action" if batch is None else "actions"
    try:
        a = np.asarray(action)
    except ValueError as e:  # (ragged nested lists)
        raise ValueError(f"{what}: not an array of one shape ({e})") from None
    A = 2 + len(cfg.feed)
    want = (A,) if batch is None else (batch, A)
    if a.shape != want:
        raise ValueError(f"{what}: expected shape {want} ({'' if batch is None else 'num_envs, '}"
                         f"heat, wall, one injection per feed species), got {a.shape}")
    if a.dtype.kind not in REAL_KINDS:
        raise TypeError(f"{what}: expected real numbers, got an array of dtype {a.dtype}")
    return np.ascontiguousarray(a, dtype=FLOAT)
