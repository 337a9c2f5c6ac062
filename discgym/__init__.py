"""discgym: a reactive hard-disc simulator and a Gymnasium environment on top of it.

The physics (``discgym.scene``, ``discgym.simulation``, ``discgym.kernels``) imports neither
gymnasium nor any renderer; the environment lives in ``discgym.env``, its batched form in
``discgym.vector`` and the baseline policies in ``discgym.baselines`` (imported on demand).
"""

from . import (
    scenes,
    tasks,  # noqa: E402  (the task suite: env classes and their registrations)
)
from .env import register_envs
from .scene import (
    Box,
    Circle,
    Combination,
    Decomposition,
    Exchange,
    Outlet,
    Scene,
    SceneError,
    Species,
    ThermalWall,
    Transformation,
)
from .simulation import PlacementError, Simulation

register_envs()  # DiscReactor-v0 (discgym.env imports gymnasium, never torch or SB3)
tasks.register_tasks()  # the rest of the suite (discgym/tasks.py)

__version__ = "0.1.0"

__all__ = [
    "Box",
    "Circle",
    "Combination",
    "Decomposition",
    "Exchange",
    "Outlet",
    "PlacementError",
    "Scene",
    "SceneError",
    "Simulation",
    "Species",
    "ThermalWall",
    "Transformation",
    "scenes",
]
