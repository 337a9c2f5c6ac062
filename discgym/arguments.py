"""The checks of a reactor environment's arguments (:class:`~discgym.config.ReactorConfig`,
the single and the vector env): each refuses a value with ``TypeError`` (a wrong type) or
``ValueError`` (out of range), naming the argument, as the env docstrings promise."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping

import numpy as np

from . import values
from .checks import as_scene, discs_inside, event_fit
from .compiled import kernel_bounds
from .scene import (
    HEX_PACKING,
    Box,
    Circle,
    Scene,
)

#: The kernels count steps (and discs) in int64.
INT_MAX = 2**63 - 1
INT_MAX_TEXT = "2**63 - 1"
#: Initial contents covering more of the area than this are not reliably placed by random
#: addition (its jamming limit for equal discs is 0.547); above it they must also fit the
#: hexagonal lattice that ``Simulation`` falls back to.
RANDOM_PLACEMENT_SHARE = 0.5
#: The smallest normal float64. A range's ends must be at least this: a subnormal has fewer
#: significant bits and its reciprocal overflows (1 / 1e-310 is inf), so the maps that divide
#: by an end or take a ratio of the ends (the heat control's clamps, the jacket's log-uniform
#: map, a controller inverting them) would give inf or NaN.
FLOAT_NORMAL_MIN = float(np.finfo(np.float64).tiny)


def choice(v, name: str, choices: tuple) -> str:
    if not isinstance(v, str):
        raise TypeError(f"{name}: expected one of {list(choices)}, got {v!r}")
    if v not in choices:
        raise ValueError(f"{name}: expected one of {list(choices)}, got {v!r}")
    return v


def flag(v, name: str) -> bool:
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    raise TypeError(f"{name}: expected True or False, got {v!r} ({type(v).__name__})")


def most_discs(mass: float, lightest: float) -> int:
    """The most discs a total ``mass`` can be split into (discs of mass ``lightest``)."""
    return int(math.floor(mass / lightest * (1.0 + 1e-12)))


def with_config(owner: str, config, kwargs: dict) -> dict:
    """The keyword arguments of a constructor called as ``Env(config, **kwargs)``: the
    mapping ``config`` (RLlib passes its ``EnvContext``, a dict, as the only positional
    argument) merged with ``kwargs``; a key in both raises Python's own ``TypeError``."""
    if config is None:
        return kwargs
    if not isinstance(config, Mapping):
        raise TypeError(f"config: {owner}() takes keyword arguments, or a mapping of them "
                        f"(e.g. RLlib's EnvContext) as its only positional argument, got "
                        f"{config!r} ({type(config).__name__})")
    merged = {}
    for k, v in config.items():
        if not isinstance(k, str):
            raise TypeError(f"config: keys must be argument names (str), got {k!r}")
        merged[k] = v
    for k, v in kwargs.items():
        if k in merged:
            raise TypeError(f"{owner}() got multiple values for argument {k!r}")
        merged[k] = v
    return merged


def check_keywords(owner: str, kw, allowed) -> None:
    """Refuse an unknown keyword argument with Python's own wording (which TorchRL and
    others recognise): ``DiscReactorEnv.__init__() got an unexpected keyword argument
    'frameskip'``."""
    for k in kw:
        if k not in allowed:
            raise TypeError(f"{owner}() got an unexpected keyword argument {k!r}")


def number(v, name: str, what: str = "a number"):
    """``v`` if it is a real number (Python or numpy, or a 0-d array of one; not a bool),
    else ``TypeError`` naming ``name``."""
    x = values.real(v)
    if x is None:
        raise TypeError(f"{name}: expected {what}, got {v!r} ({type(v).__name__})")
    return x


def int_text(k: int) -> str:
    return INT_MAX_TEXT if k == INT_MAX else str(k)


def whole(v, name: str, lo: int, hi: int = INT_MAX, why: str = "") -> int:
    """``v`` as an int in [lo, hi]: an integer or an integral float (numpy too)."""
    x = number(v, name, "a whole number")
    k = values.integer(x, integral_float=True)
    if k is None:
        raise ValueError(f"{name}: need a finite whole number, got {v!r}")
    if not lo <= k <= hi:
        more = f" ({why})" if why and k > hi else ""
        raise ValueError(f"{name}: need a whole number in [{lo}, {int_text(hi)}], got "
                         f"{v!r}{more}")
    return k


def real(v, name: str, lo: float = -math.inf, hi: float = math.inf, *,
          hi_open: bool = False, why: str = "") -> float:
    """``v`` as a finite float in [lo, hi] (or [lo, hi) with ``hi_open``)."""
    f = values.as_float(number(v, name))
    if not math.isfinite(f):
        raise ValueError(f"{name}: need a finite number, got {v!r}")
    if f < lo or f > hi or (hi_open and f == hi):
        rng = f"[{lo:g}, {hi:g}{')' if hi_open else ']'}" if hi < math.inf else f">= {lo:g}"
        raise ValueError(f"{name}: need a number {'in ' if hi < math.inf else ''}{rng}, got "
                         f"{v!r}{f' ({why})' if why else ''}")
    return f


def pair(v, name: str) -> tuple[float, float]:
    """``(low, high)``, finite, 0 < low <= high, low a normal float64 (>= FLOAT_NORMAL_MIN),
    from a list, tuple or 1-d array of two."""
    if isinstance(v, np.ndarray) and v.ndim == 1 or isinstance(v, (list, tuple)):
        items = list(v)
    else:
        raise TypeError(f"{name}: expected a (low, high) pair, got {v!r}")
    if len(items) != 2:
        raise ValueError(f"{name}: expected a (low, high) pair, got {len(items)} values {v!r}")
    lo = real(items[0], f"{name}[0]")
    hi = real(items[1], f"{name}[1]")
    if not 0 < lo <= hi:
        raise ValueError(f"{name}: need 0 < low <= high, got {v!r}")
    if lo < FLOAT_NORMAL_MIN:
        raise ValueError(f"{name}: the low end {lo!r} is a subnormal float64; need low >= "
                         f"{FLOAT_NORMAL_MIN!r}, the smallest normal one (a subnormal's "
                         f"reciprocal overflows: a map dividing by it gives inf)")
    return lo, hi


def env_scene(scene) -> Scene:
    if isinstance(scene, os.PathLike):
        scene = os.fspath(scene)
    if not isinstance(scene, (Scene, str)):
        raise TypeError(f"scene: expected a Scene, a built-in scene name or a TOML path, got "
                        f"{scene!r}")
    try:
        return as_scene(scene)
    except OSError as e:
        raise type(e)(f"scene: cannot read {scene!r}: {e.strerror or e}") from None


def steps_per_action(v, dt: float) -> int:
    """``step_time`` as a whole number of steps of the scene's ``dt`` (at most the
    simulation's int64 step counter); a float32 or float16 is taken at its own precision."""
    step_time = real(v, "step_time", 0.0)
    raw = v[()] if isinstance(v, np.ndarray) else v  # (its own dtype, for its precision)
    if step_time <= 0.0:
        raise ValueError(f"step_time: must be > 0, got {v!r}")
    q = step_time / dt
    if not q < INT_MAX:  # (inf too)
        raise ValueError(f"step_time: {step_time} is {q:.3g} steps of the scene's dt = {dt}, "
                         f"more than the simulation's step counter holds ({INT_MAX_TEXT})")
    spa = int(round(q))
    exact = abs(spa * dt - step_time) <= 1e-9 * step_time
    if not exact and isinstance(raw, np.floating) and np.finfo(raw.dtype).eps > 1e-9:
        exact = raw.dtype.type(spa * dt) == raw
    if spa < 1 or not exact:
        raise ValueError(f"step_time: {step_time} must be a whole number of the scene's "
                         f"time step dt = {dt}")
    return spa


def check_event_fit(scene: Scene, size_min: float) -> None:
    """The event-driven integrator refuses bounds that leave a species less free room than
    1e-3 of its radius along an axis (``Simulation``'s check: its wall contacts would almost
    never end). The room only shrinks with the size (a box's width, a circle's radius), so
    the scene's bounds and the reactor at ``size_range``'s low end are the ones to check: no
    wall move can then reach bounds the integrator refuses."""
    try:
        event_fit("event", scene, scene.bounds)
    except ValueError as e:
        raise ValueError(f"integrator: 'event' cannot run the scene's bounds: {e}") from None
    try:
        event_fit("event", scene, bounds_of(scene, size_min))
    except ValueError as e:
        raise ValueError(f"size_range: with integrator='event' the reactor at size {size_min} "
                         f"(the low end, the narrowest the wall can make it) is refused: "
                         f"{e}") from None


def bounds_of(scene: Scene, size: float):
    """The scene's bounds at ``size`` (box: the width scales, origin kept; circle: the
    radius)."""
    ref = scene.bounds
    if isinstance(ref, Box):
        return Box(ref.width * size, ref.height, ref.origin)
    return Circle(ref.radius * size, ref.center)


def lattice_sites(bounds, radius: float) -> int:
    """How many discs of ``radius`` the hexagonal lattice of ``Simulation``'s dense
    placement (``Simulation._place_lattice``: spacing one diameter, rows from the lower left
    corner) puts inside ``bounds``."""
    r = float(radius)
    a = 2.0 * r * (1.0 + 1e-9)
    x0, y0, x1, y1 = bounds.extent
    xs = np.arange(x0 + r, x1 - r + 1e-12, a)
    ys = np.arange(y0 + r, y1 - r + 1e-12, a * math.sqrt(3) / 2)
    shift = np.where(np.arange(len(ys)) % 2 == 1, 0.5 * a, 0.0)
    sites = np.empty((len(ys), len(xs), 2))
    sites[:, :, 0] = xs[None, :] + shift[:, None]
    sites[:, :, 1] = ys[:, None]
    sites = sites.reshape(-1, 2)
    bounds_kind, bounds_params = kernel_bounds(bounds)
    return int(discs_inside(sites, np.full(len(sites), r), bounds_kind, bounds_params).sum())


def check_placeable(scene: Scene, most: list, name: str) -> None:
    """Refuse contents (the most of each species a reset can draw) that ``Simulation``
    cannot place in the scene's bounds: more area than the densest packing holds, or, when
    they cover more than RANDOM_PLACEMENT_SHARE of the area (where random addition is no
    longer reliable), more discs than the sites of the hexagonal lattice it falls back to."""
    sp = scene.species
    area = sum(math.pi * sp[k].radius * sp[k].radius * c for k, c in enumerate(most))
    total = sum(most)
    bounds = scene.bounds
    what = (f"up to {total} discs ({'n_discs' if name == 'n_discs' else 'the scene counts'}"
            f" x (1 + count_jitter), rounded)")
    if area > HEX_PACKING * bounds.area:
        raise ValueError(f"{name}: {what} cannot fit in {bounds}: they cover {area:.4g}, more "
                         f"than the densest packing ({HEX_PACKING:.4f}) of its area "
                         f"{bounds.area:.4g}; lower n_discs or count_jitter")
    if area > RANDOM_PLACEMENT_SHARE * bounds.area:
        r = max(sp[k].radius for k, c in enumerate(most) if c)
        sites = lattice_sites(bounds, r)
        if total > sites:
            raise ValueError(
                f"{name}: {what} cannot be placed in {bounds}: they cover "
                f"{area / bounds.area:.3f} of its area (random placement is unreliable above "
                f"{RANDOM_PLACEMENT_SHARE}) and the hexagonal lattice the placement falls "
                f"back to has {sites} sites; lower n_discs or count_jitter")


def physical_memory() -> int | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def check_memory(need: int, name: str, what: str) -> None:
    """Refuse state that could not fit in this machine's memory (instead of a MemoryError, or
    the OOM killer on first touch, at reset)."""
    have = physical_memory()
    if have is not None and need > have:
        raise ValueError(f"{name}: {what} needs about {need / 2**30:.3g} GiB, more than this "
                         f"machine's memory ({have / 2**30:.3g} GiB)")


def check_render_mode(render_mode, modes) -> None:
    if render_mode is None:
        return
    if not isinstance(render_mode, str):
        raise TypeError(f"render_mode: expected one of {modes} or None, got {render_mode!r}")
    if render_mode not in modes:
        raise ValueError(f"render_mode: expected one of {modes} or None, got {render_mode!r}")
