"""discgym: a reactive hard-disc simulator and a Gymnasium environment on top of it.

The physics (``discgym.scene``, ``discgym.simulation``, ``discgym.kernels``) imports neither
gymnasium nor any renderer; the environment lives in ``discgym.env``, its batched form in
``discgym.vector`` and the baseline policies in ``discgym.baselines`` (imported on demand).
"""

from . import (
    checkpoint,
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


def _find_version() -> str:
    """The version pyproject.toml gives, read from the installed distribution's metadata.

    A source tree imported where no discgym is installed (``PYTHONPATH=<tree>``) has no
    metadata: there, the pyproject.toml beside the package, the single source the metadata is
    built from (so a checkout still names its version); with neither, ``0+unknown``, a valid
    version below every release rather than a guess. (Where one discgym is installed and
    another tree imported, the metadata is the installed one's.)
    """
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("discgym")
    except PackageNotFoundError:
        pass
    import tomllib
    from pathlib import Path

    try:
        project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml")
                                .read_text(encoding="utf-8"))["project"]
        if project["name"] == "discgym":
            return str(project["version"])
    except (OSError, tomllib.TOMLDecodeError, KeyError, TypeError):
        pass
    return "0+unknown"


__version__ = _find_version()

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
    "checkpoint",
    "scenes",
]
