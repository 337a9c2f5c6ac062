"""The checks a :class:`~discgym.Simulation`, its state I/O and the environments share:
real-number arguments, discs inside bounds, bounds that keep the scene's sides, what the
event-driven integrator can run, a scene given by name or path."""

from __future__ import annotations

import dataclasses

import numpy as np

from .compiled import CIRCLE
from .kernels import event_driven as _event
from .kernels import walls as _walls
from .scene import Circle, Scene, SceneError, check_side, sides_of
from .values import as_float, plain, real


def real_arg(what: str, value) -> float:
    """A real-number argument as a float: numpy scalars (and 0-d arrays) as the Python
    numbers they are; bools and non-numbers raise ValueError naming ``what``."""
    x = real(value)
    if x is None:
        shown = value[()] if isinstance(value, np.ndarray) and value.shape == () else value
        raise ValueError(f"{what}: expected a number, got {plain(shown)!r}")
    return as_float(x)


def discs_inside(pos: np.ndarray, r: np.ndarray, kind: int, params: np.ndarray) -> np.ndarray:
    if kind == CIRCLE:
        d2 = (pos[:, 0] - params[0]) ** 2 + (pos[:, 1] - params[1]) ** 2
        L = params[2] - r
        return (L >= 0) & (d2 <= L * L)
    return ((pos[:, 0] >= params[0] + r) & (pos[:, 0] <= params[2] - r) &
            (pos[:, 1] >= params[1] + r) & (pos[:, 1] <= params[3] - r))


def check_discs(pos, vel, species, u, sp_radius, bounds_kind, bounds_params, bounds,
                 what: str = "") -> None:
    """Finite positions, velocities and internal energies, no negative internal energy, every
    disc inside ``bounds``; else ``ValueError`` naming the first offending disc."""
    n = len(pos)
    if n == 0:
        return
    for name, arr in (("positions", pos), ("velocities", vel), ("internal_energy", u)):
        bad = np.flatnonzero(~np.isfinite(arr.reshape(n, -1)).all(axis=1))
        if len(bad):
            raise ValueError(f"{what}{name} of disc {bad[0]} is not finite: {arr[bad[0]]}")
    if (u < 0).any():
        raise ValueError(f"{what}internal_energy of disc {np.flatnonzero(u < 0)[0]} is "
                         "negative")
    r = sp_radius[species]
    outside = np.flatnonzero(~discs_inside(pos, r, bounds_kind, bounds_params))
    if len(outside):
        k = outside[0]
        raise ValueError(f"{what}positions: disc {k} (radius {r[k]}) at {pos[k]} is not "
                         f"inside the bounds {bounds}")


def check_sides(scene: Scene, bounds) -> None:
    """Refuse ``bounds`` replacing the scene's (:meth:`Simulation.resize`,
    :meth:`Simulation.set_state`) that lack a side a feature of the scene is on, by the rule
    ``Scene`` applies to its own bounds (``scene.check_side``): a box's "left" outlet must not
    become an arc of a circle, nor a circle's thermal wall a box's left side (the kernels index
    walls and outlets by side). Every entry with a ``side`` in a field of the scene (thermal
    walls, outlets) is checked; SceneError naming it, e.g. ``outlets[0].side``."""
    sides = sides_of(bounds)
    for f in dataclasses.fields(scene):
        items = getattr(scene, f.name)
        if not isinstance(items, tuple):
            continue
        for k, x in enumerate(items):
            if not hasattr(x, "side"):
                continue
            try:
                check_side(f"{f.name}[{k}]", x.side, sides, bounds.kind)
            except SceneError as e:
                why = str(e).removeprefix(f"{e.field}: ")
                raise SceneError(e.field, f"the scene's {x!r} cannot move to {bounds}: {why}; "
                                 "thermal walls and outlets keep their sides, so the bounds "
                                 f"keep their kind ({scene.bounds.kind})") from None


def event_fit(integrator: str, scene: Scene, bounds) -> str:
    """The event-driven integrator refuses bounds that leave a species less room than
    ``event_driven.FIT_MARGIN`` (1e-3) of its radius along an axis (box: width or height
    minus the diameter; circle: radius minus the disc's). A disc that fits exactly would meet
    both walls at once, forever, an event sequence with no end; one with a free gap g meets
    them every g / |v| (5e7 wall hits per unit time at g = 1e-8 radii), work without a
    practical bound. (The time-stepped integrator holds an exactly fitting disc in place.)"""
    if integrator == "event":
        for s in scene.species:
            if isinstance(bounds, Circle):
                gaps = [bounds.radius - s.radius]
            else:
                gaps = [bounds.width - 2 * s.radius, bounds.height - 2 * s.radius]
            if not min(gaps) >= _event.FIT_MARGIN * s.radius:
                what = "exactly" if min(gaps) <= _walls.FIT_TOL * s.radius else \
                    f"to within {min(gaps) / s.radius:.3g} of its radius"
                raise ValueError(
                    f"integrator='event': species {s.name!r} (radius {s.radius}) fits "
                    f"{bounds} {what}, with (almost) no room to move: its wall contacts "
                    "would (almost) never end. The event-driven integrator needs a free gap "
                    f"of at least {_event.FIT_MARGIN} of the radius along each axis. Use "
                    "the time-stepped integrator (the default), which holds such a disc in "
                    "place.")
    return integrator


def integrator_name(name) -> str:
    if name not in ("step", "event"):
        raise ValueError(f"integrator: expected 'step' or 'event', got {name!r}")
    return name


def as_scene(scene) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, str):
        from . import scenes

        if scene in scenes.names():
            return scenes.load(scene)
        return Scene.from_toml(scene)
    raise TypeError(f"expected a Scene, a built-in scene name or a TOML path, got {scene!r}")
