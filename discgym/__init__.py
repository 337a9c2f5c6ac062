"""discgym: a reactive hard-disc simulator and a Gymnasium environment on top of it.

The physics (``discgym.scene``, ``discgym.simulation``, ``discgym.kernels``) imports neither
gymnasium nor any renderer; the environment lives in ``discgym.env``.
"""

from . import scenes
from .scene import (
    Box,
    Circle,
    Combination,
    Decomposition,
    Exchange,
    Scene,
    SceneError,
    Species,
    Transformation,
)
from .simulation import PlacementError, Simulation

__version__ = "0.1.0"

__all__ = [
    "Box",
    "Circle",
    "Combination",
    "Decomposition",
    "Exchange",
    "PlacementError",
    "Scene",
    "SceneError",
    "Simulation",
    "Species",
    "Transformation",
    "scenes",
]
