"""Built-in scenes, shipped as TOML files beside this module.

>>> import discgym as dg
>>> "reactor" in dg.scenes.names()
True
>>> dg.scenes.load("ideal_gas").bounds
Box(width=40.0, height=40.0, origin=(0.0, 0.0))
"""

from __future__ import annotations

from importlib import resources

from ..scene import Scene

__all__ = ["names", "load", "path", "describe"]


def names() -> list[str]:
    """Names of the built-in scenes, sorted."""
    return sorted(p.name[:-5] for p in resources.files(__name__).iterdir()
                  if p.name.endswith(".toml"))


def path(name: str):
    """The TOML file of a built-in scene."""
    if name not in names():
        raise KeyError(f"no built-in scene {name!r}; available: {', '.join(names())}")
    return resources.files(__name__) / f"{name}.toml"


def load(name: str) -> Scene:
    """Load a built-in scene by name."""
    return Scene.from_toml_string(path(name).read_text())


def describe() -> dict[str, str]:
    """``{name: one-line description}`` of every built-in scene."""
    return {n: load(n).description for n in names()}
