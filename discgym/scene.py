"""The scene model: plain, frozen, validated data.

A :class:`Scene` says everything the simulator needs and nothing about how it runs: the bounds,
the species, the reactions, the restitution, the time step and the default initial contents.
It is validated once, when it is built; a malformed scene raises :class:`SceneError` naming the
offending field (``reactions[1].products``, ``species[0].radius``, ...), and nothing is
half-built. Scenes are built in code or loaded from TOML (:meth:`Scene.from_toml`), and written
back with :meth:`Scene.to_toml`.

Units: k_B = 1, so a temperature is an energy per disc (2D: mean kinetic energy = kT).
Probabilities of unimolecular reactions are chances per unit of simulated time, in [0, 1]
(docs/physics.md, section 5.1): over a step of length dt the chance is ``1 - (1 - p) ** dt``.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path

from .values import as_float, integer, plain, real

__all__ = [
    "SceneError",
    "Species",
    "Box",
    "Circle",
    "Transformation",
    "Decomposition",
    "Combination",
    "Exchange",
    "Scene",
    "ThermalWall",
    "Outlet",
    "HEX_PACKING",
]

#: Densest packing of equal discs in the plane; no population above it can ever fit.
HEX_PACKING = math.pi / (2.0 * math.sqrt(3.0))

#: Bounds whose coordinates exceed this many times their own size lose too much precision in
#: float64 (an offset of 1e6 sizes leaves ~1e-10 of a size as the resolution): refused.
MAX_OFFSET_RATIO = 1.0e6

#: The range of magnitudes the float64 arithmetic of the kernels can do. Every length (radii,
#: box width and height, circle radius), the time step and every mass must lie in
#: [MIN_MAGNITUDE, MAX_MAGNITUDE]; every energy (temperatures, formation and activation energies,
#: internal energies) is at most MAX_MAGNITUDE in magnitude; speeds are bounded by the speed
#: limit, 65536 * max_displacement * r_min / dt <= 3.3e84 (``Simulation.speed_limit``; r_min <=
#: 5e39 fits bounds <= 1e40). The largest products then stay normal doubles: the contact
#: quadratics' (d.v)^2 ~ L^2 v^2 <= 1e80 * (3.3e84)^2 = 1.1e249 (1.8e308 is the float64 limit),
#: a disc's kinetic energy m v^2 / 2 <= 5e208, mass x coordinate <= 1e86, m_i m_j >= 1e-80, and
#: a reaction's speed sqrt(2 E / m) <= 1.4e40 (why energies are bounded). Speeds have no
#: lower bound: a relative speed w whose products underflow (1e-20 L^2 w^2 below 2.2e-308,
#: L >= 1e-40: w < 1.5e-104) closes at most 1.5e-24 of the smallest radius per step of the
#: largest dt, so nothing it does is lost. Energies have no lower bound either: a small energy
#: only ever makes a small speed.
MIN_MAGNITUDE = 1.0e-40
MAX_MAGNITUDE = 1.0e40

#: Positions are resolved to 2^-52 of their magnitude; bounds reaching farther from the origin
#: than this many times the smallest radius would resolve contacts to worse than 2.2e-7 of it
#: (a head-on pair of discs of radius 1e-14 at x = 0.7 loses the oblique part of its collision):
#: refused, naming the smallest species' radius.
MAX_COORDINATE_RATIO = 1.0e9

_MASS_RTOL = 1e-9


class SceneError(ValueError):
    """A scene (or a scene file) is malformed. ``field`` names the offending entry."""

    def __init__(self, field_name: str, message: str):
        self.field = field_name
        super().__init__(f"{field_name}: {message}")


def finite_value(name: str, value, *, positive=False, nonneg=False, lo=None, hi=None,
            scale=False, energy=False) -> float:
    """``value`` as a float, checked: a real number (not a bool), finite, and the given
    bounds; ``scale`` and ``energy``: see :func:`check_magnitude`."""
    x = real(value)
    if x is None:
        raise SceneError(name, f"expected a number, got {plain(value)!r}")
    v = as_float(x)
    if math.isinf(v) and isinstance(x, int):
        raise SceneError(name, "must be finite, got an integer beyond the float range")
    if not math.isfinite(v):
        raise SceneError(name, f"must be finite, got {v}")
    if positive and v <= 0.0:
        raise SceneError(name, f"must be > 0, got {v}")
    if nonneg and v < 0.0:
        raise SceneError(name, f"must be >= 0, got {v}")
    if lo is not None and v < lo:
        raise SceneError(name, f"must be in [{lo}, {hi}], got {v}")
    if hi is not None and v > hi:
        raise SceneError(name, f"must be in [{lo}, {hi}], got {v}")
    return check_magnitude(name, v, scale=scale, energy=energy)


def check_magnitude(name: str, v: float, *, scale=False, energy=False) -> float:
    """``v``, refused (SceneError naming ``name``) outside the range the kernels' float64
    arithmetic can do: ``scale`` (a length, time or mass) in [MIN_MAGNITUDE, MAX_MAGNITUDE],
    ``energy`` at most MAX_MAGNITUDE in magnitude."""
    if scale and not MIN_MAGNITUDE <= abs(v) <= MAX_MAGNITUDE:
        raise SceneError(name, f"must be in [{MIN_MAGNITUDE:g}, {MAX_MAGNITUDE:g}], got {v}: "
                               "beyond, the contact arithmetic over- or underflows float64"
                               "; choose other units")
    if energy and not abs(v) <= MAX_MAGNITUDE:
        raise SceneError(name, f"must be at most {MAX_MAGNITUDE:g} in magnitude, got {v}: "
                               "beyond, the speeds it makes over- or underflow float64"
                               "; choose other units")
    return v


def _point(name: str, value) -> tuple[float, float]:
    try:
        x, y = value
    except (TypeError, ValueError):
        raise SceneError(name, f"expected a pair of numbers, got {value!r}") from None
    return (finite_value(f"{name}[0]", x), finite_value(f"{name}[1]", y))


def _name(name: str, value) -> str:
    if not isinstance(value, str) or not value.strip():
        raise SceneError(name, f"expected a non-empty species name, got {value!r}")
    return value


def _set(obj, **kw):
    for k, v in kw.items():
        object.__setattr__(obj, k, v)


# --------------------------------------------------------------------------------------------
# Species and bounds


@dataclass(frozen=True)
class Species:
    """A kind of disc. ``formation_energy`` is its chemical energy (added to the total energy)."""

    name: str
    radius: float
    mass: float
    formation_energy: float = 0.0

    def __post_init__(self):
        _set(
            self,
            name=_name("name", self.name),
            radius=finite_value("radius", self.radius, positive=True),
            mass=finite_value("mass", self.mass, positive=True),
            formation_energy=finite_value("formation_energy", self.formation_energy),
        )


@dataclass(frozen=True)
class Box:
    """Rectangular bounds ``[x0, x0 + width] x [y0, y0 + height]`` with ``origin = (x0, y0)``."""

    width: float
    height: float
    origin: tuple[float, float] = (0.0, 0.0)

    kind = "box"

    def __post_init__(self):
        _set(
            self,
            width=finite_value("width", self.width, positive=True),
            height=finite_value("height", self.height, positive=True),
            origin=_point("origin", self.origin),
        )
        size = max(self.width, self.height)
        if max(abs(self.origin[0]), abs(self.origin[1])) > MAX_OFFSET_RATIO * size:
            raise SceneError(
                "origin",
                f"{self.origin} is more than {MAX_OFFSET_RATIO:g} box sizes from (0, 0); "
                "float64 positions would lose their precision there: shift the scene",
            )

    @property
    def area(self) -> float:
        return self.width * self.height

    @property
    def perimeter(self) -> float:
        return 2.0 * (self.width + self.height)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax)"""
        x0, y0 = self.origin
        return (x0, y0, x0 + self.width, y0 + self.height)

    def max_radius(self) -> float:
        return 0.5 * min(self.width, self.height)


@dataclass(frozen=True)
class Circle:
    """Circular bounds of the given ``radius`` around ``center``."""

    radius: float
    center: tuple[float, float] = (0.0, 0.0)

    kind = "circle"

    def __post_init__(self):
        _set(
            self,
            radius=finite_value("radius", self.radius, positive=True),
            center=_point("center", self.center),
        )
        if max(abs(self.center[0]), abs(self.center[1])) > MAX_OFFSET_RATIO * 2 * self.radius:
            raise SceneError(
                "center",
                f"{self.center} is more than {MAX_OFFSET_RATIO:g} diameters from (0, 0); "
                "float64 positions would lose their precision there: shift the scene",
            )

    @property
    def area(self) -> float:
        return math.pi * self.radius * self.radius  # (r ** 2 raises OverflowError)

    @property
    def perimeter(self) -> float:
        return 2.0 * math.pi * self.radius

    @property
    def extent(self) -> tuple[float, float, float, float]:
        cx, cy = self.center
        return (cx - self.radius, cy - self.radius, cx + self.radius, cy + self.radius)

    def max_radius(self) -> float:
        return self.radius


Bounds = Box | Circle


# --------------------------------------------------------------------------------------------
# Reactions


class _FirstOrder:
    """What the first-order reactions share: one reactant, a chance per unit time."""

    def __post_init__(self):
        _set(self, probability=finite_value("probability", self.probability, lo=0.0, hi=1.0))

    @property
    def reactants(self) -> tuple[str, ...]:
        return (self.reactant,)


@dataclass(frozen=True)
class Transformation(_FirstOrder):
    """A -> B, first order: chance ``probability`` per unit time. Masses must be equal.

    The formation-energy difference goes into (or comes out of) the disc's internal energy; an
    endothermic transformation waits until the disc's internal energy can pay for it.
    """

    reactant: str
    product: str
    probability: float

    kind = "transformation"

    @property
    def products(self) -> tuple[str, ...]:
        return (self.product,)

    def label(self) -> str:
        return f"{self.reactant} -> {self.product}"


@dataclass(frozen=True)
class Decomposition(_FirstOrder):
    """A -> B + C, first order: chance ``probability`` per unit time.

    The fragments leave the parent's velocity in opposite directions perpendicular to it, with
    equal and opposite momenta carrying the released energy (internal + formation difference).
    An endothermic decomposition waits until the parent's internal energy can pay for it.
    """

    reactant: str
    product1: str
    product2: str
    probability: float

    kind = "decomposition"

    @property
    def products(self) -> tuple[str, ...]:
        return (self.product1, self.product2)

    def label(self) -> str:
        return f"{self.reactant} -> {self.product1} + {self.product2}"


@dataclass(frozen=True)
class Combination:
    """A + B -> C on a collision whose line-of-centres energy reaches ``activation_energy``.

    C stores the kinetic energy of the relative motion (plus the reactants' internal energy and
    the formation-energy difference) as internal energy. Its reverse, C -> A + B, happens with
    chance ``reverse_probability`` per unit time while C's internal energy is above the barrier
    (``activation_energy + F_A + F_B - F_C``); collisions drain internal energy (the scene's
    ``internal_relaxation``), which is what lets a product cool and survive.
    """

    reactant1: str
    reactant2: str
    product: str
    activation_energy: float = 0.0
    reverse_probability: float = 0.5

    kind = "combination"

    def __post_init__(self):
        _set(
            self,
            activation_energy=finite_value(
                "activation_energy", self.activation_energy, nonneg=True
            ),
            reverse_probability=finite_value(
                "reverse_probability", self.reverse_probability, lo=0.0, hi=1.0
            ),
        )

    @property
    def reactants(self) -> tuple[str, ...]:
        return (self.reactant1, self.reactant2)

    @property
    def products(self) -> tuple[str, ...]:
        return (self.product,)

    def label(self) -> str:
        return f"{self.reactant1} + {self.reactant2} -> {self.product}"


@dataclass(frozen=True)
class Exchange:
    """A + B -> C + D on a collision whose line-of-centres energy reaches ``activation_energy``.

    A reactive collision in the centre-of-mass frame: momentum and total energy conserved, the
    products' relative speed set by what the formation energies leave over.
    """

    reactant1: str
    reactant2: str
    product1: str
    product2: str
    activation_energy: float = 0.0

    kind = "exchange"

    def __post_init__(self):
        _set(
            self,
            activation_energy=finite_value(
                "activation_energy", self.activation_energy, nonneg=True
            ),
        )

    @property
    def reactants(self) -> tuple[str, ...]:
        return (self.reactant1, self.reactant2)

    @property
    def products(self) -> tuple[str, ...]:
        return (self.product1, self.product2)

    def label(self) -> str:
        return f"{self.reactant1} + {self.reactant2} -> {self.product1} + {self.product2}"


Reaction = Transformation | Decomposition | Combination | Exchange
REACTION_TYPES = {c.kind: c for c in (Transformation, Decomposition, Combination, Exchange)}


# --------------------------------------------------------------------------------------------
# Walls: thermal walls and outlets

#: The sides of each bounds kind, in the order of the kernels' wall arrays (docs/physics.md):
#: a box has four, a circle one ("wall").
BOX_SIDES = ("left", "right", "bottom", "top")
CIRCLE_SIDES = ("wall",)
SIDES = BOX_SIDES + CIRCLE_SIDES

#: A thermal wall at kT may draw a disc's speed up to this many thermal speeds sqrt(kT/m)
#: with non-negligible probability (a Rayleigh x Gaussian tail beyond it: ~1e-300): the
#: temperatures whose draws could pass the speed limit are refused.
THERMAL_SPEED_MARGIN = 40.0


def sides_of(bounds) -> tuple[str, ...]:
    """The side names of a Box or Circle (:data:`BOX_SIDES`, :data:`CIRCLE_SIDES`)."""
    return CIRCLE_SIDES if isinstance(bounds, Circle) else BOX_SIDES


def _side(name: str, value) -> str:
    if not isinstance(value, str) or value not in SIDES:
        raise SceneError(name, f"expected one of {list(SIDES)}, got {value!r}")
    return value


@dataclass(frozen=True)
class ThermalWall:
    """A side of the bounds held at temperature kT: a disc that hits it leaves with a velocity
    drawn from the flux-weighted Maxwell-Boltzmann distribution at that temperature (diffuse
    reflection, docs/physics.md). ``side``: "left", "right", "bottom", "top" of a Box, "wall"
    of a Circle. The temperature is the initial one; ``Simulation.set_wall_temperature``
    changes it."""

    side: str
    temperature: float

    def __post_init__(self):
        _set(self, side=_side("side", self.side),
             temperature=finite_value("temperature", self.temperature, positive=True, energy=True))


@dataclass(frozen=True)
class Outlet:
    """A segment of a side through which discs leave: a disc whose wall contact point lies on
    it is removed. ``start`` < ``end`` are fractions of the side's length from its lower
    coordinate (left and right sides: from the bottom; bottom and top: from the left); for
    a Circle, fractions of the full turn counter-clockwise from +x.

    ``species``: the names of the species that pass (a membrane); a disc of another species
    meets the segment as the side it lies on (reflected, or thermalised on a thermal side).
    Empty (the default): every species passes. A scene keeps the names in its species'
    order, and an outlet that lists every species as the plain one (``()``), so that scenes
    that behave alike compare equal."""

    side: str
    start: float
    end: float
    species: Sequence[str] = ()

    def __post_init__(self):
        _set(self, side=_side("side", self.side),
             start=finite_value("start", self.start, lo=0.0, hi=1.0),
             end=finite_value("end", self.end, lo=0.0, hi=1.0))
        if not self.start < self.end:
            raise SceneError("end", f"must exceed start ({self.start}), got {self.end}")
        names = self.species
        if isinstance(names, (str, Mapping)) or not isinstance(names, Sequence):
            raise SceneError("species", f"expected a list of species names, got {names!r}")
        names = tuple(names)
        for k, nm in enumerate(names):
            if not isinstance(nm, str):
                raise SceneError("species", f"expected species names, got {nm!r} at {k}")
            if nm in names[:k]:
                raise SceneError("species", f"{nm!r} is listed twice")
        _set(self, species=names)

    def passes(self, species: str) -> bool:
        """Whether a disc of ``species`` leaves through this outlet."""
        return not self.species or species in self.species


# --------------------------------------------------------------------------------------------
# Scene


@dataclass(frozen=True)
class Scene:
    """Everything the simulator needs to know about a reactor.

    Arguments:
        bounds: :class:`Box` or :class:`Circle`.
        species: the kinds of disc (unique names).
        reactions: any of :class:`Transformation`, :class:`Decomposition`,
            :class:`Combination`, :class:`Exchange`.
        restitution: coefficient of restitution e in [0, 1] of disc-disc collisions (walls are
            elastic, except thermal walls). The kinetic energy lost is counted
            (``Simulation.dissipated_energy``).
        dt: time step of the time-stepped integrator.
        internal_relaxation: fraction kappa in [0, 1] of the colliding discs' internal energy
            released into their relative motion at each non-reactive collision.
        max_displacement: largest move of any disc in one (sub)step, as a fraction of the
            smallest radius; a step whose fastest disc would move further is split into equal
            substeps, so no disc can tunnel through another.
        collisions: whether discs collide at all (False: an ideal gas of points with radii).
        counts: default initial population, ``{species name: count}``.
        temperature: default initial temperature (kT, k_B = 1).
        name, description: for listings.
        thermal_walls: :class:`ThermalWall` s, at most one per side.
        outlets: :class:`Outlet` s, not overlapping on a side.
    """

    bounds: Bounds
    species: Sequence[Species]
    reactions: Sequence[Reaction] = ()
    restitution: float = 1.0
    dt: float = 0.02
    internal_relaxation: float = 0.5
    max_displacement: float = 0.5
    collisions: bool = True
    counts: Mapping[str, int] = field(default_factory=dict)
    temperature: float = 1.0
    name: str = ""
    description: str = ""
    thermal_walls: Sequence[ThermalWall] = ()
    outlets: Sequence[Outlet] = ()

    def __post_init__(self):
        if not isinstance(self.bounds, (Box, Circle)):
            raise SceneError("bounds", f"expected Box or Circle, got {self.bounds!r}")
        species = tuple(self.species)
        if not species:
            raise SceneError("species", "a scene needs at least one species")
        names = {}
        for k, s in enumerate(species):
            if not isinstance(s, Species):
                raise SceneError(f"species[{k}]", f"expected Species, got {s!r}")
            if s.name in names:
                raise SceneError(f"species[{k}].name", f"duplicate species name {s.name!r}")
            names[s.name] = s
        check_bounds_scale(self.bounds, species, "bounds", "species")
        for k, s in enumerate(species):
            if s.radius > self.bounds.max_radius():
                raise SceneError(
                    f"species[{k}].radius",
                    f"a disc of radius {s.radius} does not fit in the bounds {self.bounds}",
                )
        for k, s in enumerate(species):
            check_magnitude(f"species[{k}].mass", s.mass, scale=True)
            check_magnitude(f"species[{k}].formation_energy", s.formation_energy, energy=True)
        reactions = tuple(self.reactions)
        pairs = {}
        labels = {}
        for k, r in enumerate(reactions):
            where = f"reactions[{k}]"
            if not isinstance(r, tuple(REACTION_TYPES.values())):
                raise SceneError(where, f"expected a reaction, got {r!r}")
            for role, lst in (("reactants", r.reactants), ("products", r.products)):
                for nm in lst:
                    if nm not in names:
                        raise SceneError(f"{where}.{role}", f"unknown species {nm!r}")
            m_in = sum(names[n].mass for n in r.reactants)
            m_out = sum(names[n].mass for n in r.products)
            if abs(m_in - m_out) > _MASS_RTOL * max(m_in, m_out):
                raise SceneError(
                    f"{where}.products",
                    f"{r.label()} does not conserve mass ({m_in} -> {m_out})",
                )
            if len(r.reactants) == 1 and r.label() in labels:  # (pairs: checked below)
                raise SceneError(
                    where, f"{r.label()} is already reactions[{labels[r.label()]}]; give one "
                    "reaction (with the combined probability) instead of two")
            labels[r.label()] = k
            if isinstance(r, (Combination, Exchange)):
                check_magnitude(f"{where}.activation_energy", r.activation_energy, energy=True)
            if len(r.reactants) == 2:
                key = tuple(sorted(r.reactants))
                if key in pairs:
                    raise SceneError(
                        f"{where}.reactants",
                        f"reactions[{pairs[key]}] already reacts {key[0]} with {key[1]}; "
                        "one bimolecular reaction per pair of species",
                    )
                pairs[key] = k
        counts = validated_counts(self.bounds, names, self.counts)
        _set(self, collisions=plain(self.collisions))
        if not isinstance(self.collisions, bool):
            raise SceneError("collisions", f"expected true or false, got {self.collisions!r}")
        for attr in ("name", "description"):
            if not isinstance(getattr(self, attr), str):
                raise SceneError(attr, f"expected a string, got {getattr(self, attr)!r}")
        _set(
            self,
            species=species,
            reactions=reactions,
            counts=counts,
            restitution=finite_value("restitution", self.restitution, lo=0.0, hi=1.0),
            dt=finite_value("dt", self.dt, positive=True, scale=True),
            internal_relaxation=finite_value(
                "internal_relaxation", self.internal_relaxation, lo=0.0, hi=1.0
            ),
            max_displacement=finite_value("max_displacement", self.max_displacement, positive=True),
            temperature=finite_value("temperature", self.temperature, nonneg=True, energy=True),
        )
        if self.max_displacement > 1.0:
            raise SceneError(
                "max_displacement",
                f"must be in (0, 1] (a fraction of the smallest radius), got "
                f"{self.max_displacement}",
            )
        self._check_walls(species)

    def _check_walls(self, species) -> None:
        """Thermal walls and outlets: of the right type, on sides this bounds kind has, one
        thermal wall per side, outlets not overlapping, wall temperatures within the speed
        limit (see :meth:`max_wall_temperature`)."""
        if isinstance(self.thermal_walls, (str, Mapping)) or \
                not isinstance(self.thermal_walls, Sequence):
            raise SceneError("thermal_walls", f"expected a sequence of ThermalWall, got "
                             f"{self.thermal_walls!r}")
        if isinstance(self.outlets, (str, Mapping)) or not isinstance(self.outlets, Sequence):
            raise SceneError("outlets", f"expected a sequence of Outlet, got {self.outlets!r}")
        walls = tuple(self.thermal_walls)
        outlets = tuple(self.outlets)
        sides = sides_of(self.bounds)
        seen = {}
        t_max = self.max_wall_temperature(species)
        for k, w in enumerate(walls):
            where = f"thermal_walls[{k}]"
            if not isinstance(w, ThermalWall):
                raise SceneError(where, f"expected ThermalWall, got {w!r}")
            check_side(where, w.side, sides, self.bounds.kind)
            if w.side in seen:
                raise SceneError(f"{where}.side", f"{w.side!r} is already thermal_walls"
                                 f"[{seen[w.side]}]")
            seen[w.side] = k
            if not w.temperature <= t_max:
                raise SceneError(f"{where}.temperature", too_hot_for_walls(w.temperature, t_max))
        spans = {}
        order = [sp.name for sp in species]
        outlets = list(outlets)
        for k, o in enumerate(outlets):
            where = f"outlets[{k}]"
            if not isinstance(o, Outlet):
                raise SceneError(where, f"expected Outlet, got {o!r}")
            check_side(where, o.side, sides, self.bounds.kind)
            for nm in o.species:
                if nm not in order:
                    raise SceneError(f"{where}.species", f"unknown species {nm!r}")
            if o.species:  # (in the scene's order; every species: the plain outlet, ())
                passing = tuple(nm for nm in order if nm in o.species)
                outlets[k] = o = Outlet(o.side, o.start, o.end,
                                        () if len(passing) == len(order) else passing)
            for q, (a, b) in spans.get(o.side, {}).items():
                if o.start < b and a < o.end:
                    raise SceneError(f"{where}.start", f"[{o.start}, {o.end}] overlaps outlets"
                                     f"[{q}] = [{a}, {b}] on side {o.side!r}")
            spans.setdefault(o.side, {})[k] = (o.start, o.end)
        _set(self, thermal_walls=walls, outlets=tuple(outlets))

    def max_wall_temperature(self, species=None) -> float:
        """The hottest a thermal wall may be: a draw of THERMAL_SPEED_MARGIN (40) thermal
        speeds sqrt(kT / m) of the lightest species stays within the speed limit
        (``Simulation.speed_limit``: 65536 substeps of max_displacement x the smallest radius
        per step of dt)."""
        species = self.species if species is None else species
        v_max = 65536 * self.max_displacement * min(s.radius for s in species) / self.dt
        m_min = min(s.mass for s in species)
        return m_min * (v_max / THERMAL_SPEED_MARGIN) ** 2

    # ---- lookups
    def species_index(self, name: str) -> int:
        for k, s in enumerate(self.species):
            if s.name == name:
                return k
        raise KeyError(f"unknown species {name!r}; this scene has {self.species_names}")

    @property
    def species_names(self) -> list[str]:
        return [s.name for s in self.species]

    def replace(self, **changes) -> Scene:
        """A copy with some fields changed (validated again)."""
        kw = {f.name: getattr(self, f.name) for f in fields(self)}
        kw.update(changes)
        return Scene(**kw)

    # ---- TOML
    @classmethod
    def from_toml(cls, path: str | Path) -> Scene:
        """Load a scene file. Errors name the key and its line in the file."""
        path = Path(path)
        text = path.read_text()
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(str(path), f"not valid TOML: {exc}") from None
        try:
            return cls.from_dict(data)
        except SceneError as exc:
            line = _line_of(text, exc.field)
            where = f"{path}:{line}" if line else str(path)
            raise SceneError(exc.field, f"{exc.args[0].split(': ', 1)[1]} ({where})") from None

    @classmethod
    def from_toml_string(cls, text: str) -> Scene:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError("<string>", f"not valid TOML: {exc}") from None
        return cls.from_dict(data)

    @classmethod
    def from_dict(cls, data: Mapping) -> Scene:
        """Build from the plain-dict form used by TOML files (unknown keys are errors)."""
        if not isinstance(data, Mapping):
            raise SceneError("<scene>", f"expected a table, got {type(data).__name__}")
        top = {
            "name", "description", "restitution", "dt", "internal_relaxation",
            "max_displacement", "collisions", "temperature", "bounds", "species",
            "reactions", "counts", "thermal_walls", "outlets",
        }
        _no_unknown("", data, top)
        for req in ("bounds", "species"):
            if req not in data:
                raise SceneError(req, "missing (required)")
        kw = {k: data[k] for k in top - {"bounds", "species", "reactions", "counts",
                                         "thermal_walls", "outlets"} if k in data}
        kw["bounds"] = bounds_from_dict(data["bounds"])
        sp = data["species"]
        if not isinstance(sp, list):
            raise SceneError("species", "expected an array of tables [[species]]")
        kw["species"] = [_obj_from_dict(Species, f"species[{k}]", d) for k, d in enumerate(sp)]
        rx = data.get("reactions", [])
        if not isinstance(rx, list):
            raise SceneError("reactions", "expected an array of tables [[reactions]]")
        kw["reactions"] = [_reaction_from_dict(f"reactions[{k}]", d) for k, d in enumerate(rx)]
        counts = data.get("counts", {})
        if not isinstance(counts, Mapping):
            raise SceneError("counts", "expected a table of species = count")
        kw["counts"] = dict(counts)
        for key, kind in (("thermal_walls", ThermalWall), ("outlets", Outlet)):
            lst = data.get(key, [])
            if not isinstance(lst, list):
                raise SceneError(key, f"expected an array of tables [[{key}]]")
            kw[key] = [_obj_from_dict(kind, f"{key}[{k}]", d) for k, d in enumerate(lst)]
        return cls(**kw)

    def to_dict(self) -> dict:
        bd = bounds_to_dict(self.bounds)
        out = {
            "name": self.name,
            "description": self.description,
            "restitution": self.restitution,
            "dt": self.dt,
            "internal_relaxation": self.internal_relaxation,
            "max_displacement": self.max_displacement,
            "collisions": self.collisions,
            "temperature": self.temperature,
            "bounds": bd,
            "species": [
                {"name": s.name, "radius": s.radius, "mass": s.mass,
                 "formation_energy": s.formation_energy}
                for s in self.species
            ],
            "reactions": [_reaction_to_dict(r) for r in self.reactions],
            "counts": dict(self.counts),
        }
        if self.thermal_walls:
            out["thermal_walls"] = [{"side": w.side, "temperature": w.temperature}
                                    for w in self.thermal_walls]
        if self.outlets:
            out["outlets"] = [{"side": o.side, "start": o.start, "end": o.end,
                               **({"species": list(o.species)} if o.species else {})}
                              for o in self.outlets]
        return out

    def to_toml(self) -> str:
        """The scene as an editable TOML document (round-trips through :meth:`from_toml`)."""
        d = self.to_dict()
        lines = [f"# discgym scene{': ' + self.name if self.name else ''}"]
        for k in ("name", "description", "restitution", "dt", "internal_relaxation",
                  "max_displacement", "collisions", "temperature"):
            lines.append(f"{k} = {_toml_value(d[k])}")
        lines += ["", "[bounds]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in d["bounds"].items()]
        for s in d["species"]:
            lines += ["", "[[species]]"] + [f"{k} = {_toml_value(v)}" for k, v in s.items()]
        for r in d["reactions"]:
            lines += ["", "[[reactions]]"] + [f"{k} = {_toml_value(v)}" for k, v in r.items()]
        for key in ("thermal_walls", "outlets"):
            for w in d.get(key, []):
                lines += ["", f"[[{key}]]"] + [f"{k} = {_toml_value(v)}" for k, v in w.items()]
        lines += ["", "[counts]"] + [f"{k} = {v}" for k, v in d["counts"].items()]
        return "\n".join(lines) + "\n"


def too_hot_for_walls(kT: float, t_max: float) -> str:
    return (f"{kT} is above {t_max:.4g}: a thermal wall this hot could draw a speed beyond "
            f"the speed limit ({THERMAL_SPEED_MARGIN:g} sqrt(kT / m) of the lightest species "
            "must stay within it); lower the temperature or dt")


def check_side(where: str, side: str, sides, kind: str) -> None:
    """A thermal wall's or outlet's side must be one the bounds have."""
    if side not in sides:
        raise SceneError(f"{where}.side", f"{side!r} is not a side of a {kind} (its sides: "
                         f"{list(sides)})")


def validated_counts(bounds, species_by_name: Mapping[str, Species], counts) -> dict:
    """``counts`` as ``{species name: int}``, checked: known species, whole numbers >= 0,
    discs that fit the bounds (:func:`check_fits`); else SceneError naming ``counts.X``."""
    out = {}
    for nm, c in dict(counts).items():
        if nm not in species_by_name:
            raise SceneError(f"counts.{nm}", f"unknown species {nm!r}")
        k = integer(c)
        if k is None or k < 0:
            raise SceneError(f"counts.{nm}", f"expected a count >= 0, got {plain(c)!r}")
        out[nm] = k
    check_fits(bounds, species_by_name, out, "counts")
    return out


def check_bounds_scale(bounds, species: Sequence[Species], bounds_field: str,
                       species_field: str) -> None:
    """Refuse bounds and radii outside the range of :func:`check_magnitude` (SceneError naming
    ``{bounds_field}.width`` etc. or ``{species_field}[k].radius``), and bounds reaching
    farther from the origin than MAX_COORDINATE_RATIO times the smallest radius (naming the
    smallest species' radius)."""
    sizes = (("width", "height") if isinstance(bounds, Box) else ("radius",))
    for nm in sizes:
        check_magnitude(f"{bounds_field}.{nm}", getattr(bounds, nm), scale=True)
    for k, s in enumerate(species):
        check_magnitude(f"{species_field}[{k}].radius", s.radius, scale=True)
    k = min(range(len(species)), key=lambda q: species[q].radius)
    far = max(abs(c) for c in bounds.extent)
    if far > MAX_COORDINATE_RATIO * species[k].radius:
        raise SceneError(
            f"{species_field}[{k}].radius",
            f"{species[k].radius} is below {1 / MAX_COORDINATE_RATIO:g} of the farthest "
            f"coordinate of the bounds {bounds} ({far:g}): float64 positions there are "
            f"resolved to {2.0 ** -52 * far:.3g}, too coarse for contacts of such discs",
        )


def check_fits(bounds, species_by_name: Mapping[str, Species], counts: Mapping[str, int],
               field_name: str) -> None:
    """Refuse a population whose discs cover more than the densest packing allows."""
    disc_area = sum(math.pi * species_by_name[n].radius * species_by_name[n].radius * c
                    for n, c in counts.items())
    if disc_area > HEX_PACKING * bounds.area:
        raise SceneError(
            field_name,
            f"the discs cannot fit: they cover {disc_area:.4g}, more than the densest packing "
            f"({HEX_PACKING:.4f}) of the bounds' area {bounds.area:.4g}",
        )


# --------------------------------------------------------------------------------------------
# dict / TOML helpers

_REACTION_FIELDS = {
    "transformation": (("reactant",), ("product",), ("probability",)),
    "decomposition": (("reactant",), ("product1", "product2"), ("probability",)),
    "combination": (("reactant1", "reactant2"), ("product",),
                    ("activation_energy", "reverse_probability")),
    "exchange": (("reactant1", "reactant2"), ("product1", "product2"), ("activation_energy",)),
}


def _no_unknown(prefix: str, data: Mapping, allowed: set) -> None:
    for key in data:
        if key not in allowed:
            where = f"{prefix}.{key}" if prefix else key
            raise SceneError(where, f"unknown key (allowed: {', '.join(sorted(allowed))})")


def _obj_from_dict(cls, where: str, d):
    if not isinstance(d, Mapping):
        raise SceneError(where, f"expected a table, got {d!r}")
    allowed = {f.name for f in fields(cls)}
    _no_unknown(where, d, allowed)
    return _built(where, cls, d)


def _built(where: str, cls, kw: Mapping):
    """``cls(**kw)``, its errors named within ``where`` (a missing required argument too)."""
    try:
        return cls(**kw)
    except SceneError as exc:
        raise SceneError(f"{where}.{exc.field}", exc.args[0].split(": ", 1)[1]) from None
    except TypeError as exc:  # a missing required argument
        missing = re.findall(r"'(\w+)'", str(exc))
        raise SceneError(f"{where}.{missing[0] if missing else '?'}", "missing (required)") \
            from None


def bounds_to_dict(b: Bounds) -> dict:
    """Bounds in the plain-dict form of TOML scenes (:func:`bounds_from_dict` reads it)."""
    if isinstance(b, Box):
        return {"shape": "box", "width": b.width, "height": b.height, "origin": list(b.origin)}
    return {"shape": "circle", "radius": b.radius, "center": list(b.center)}


def bounds_from_dict(d) -> Bounds:
    """Bounds from :func:`bounds_to_dict`'s form, checked (``SceneError`` naming the key)."""
    if not isinstance(d, Mapping):
        raise SceneError("bounds", f"expected a table, got {d!r}")
    shape = d.get("shape")
    rest = {k: v for k, v in d.items() if k != "shape"}
    if shape == "box":
        return _obj_from_dict(Box, "bounds", rest)
    if shape == "circle":
        return _obj_from_dict(Circle, "bounds", rest)
    raise SceneError("bounds.shape", f"expected 'box' or 'circle', got {shape!r}")


def _reaction_from_dict(where: str, d) -> Reaction:
    if not isinstance(d, Mapping):
        raise SceneError(where, f"expected a table, got {d!r}")
    kind = d.get("type")
    if not isinstance(kind, str) or kind not in _REACTION_FIELDS:
        raise SceneError(f"{where}.type", f"expected one of {sorted(_REACTION_FIELDS)}, "
                                          f"got {kind!r}")
    rnames, pnames, params = _REACTION_FIELDS[kind]
    _no_unknown(where, d, {"type", "reactants", "products", *params})
    kw = {}
    for role, names in (("reactants", rnames), ("products", pnames)):
        lst = d.get(role)
        if not isinstance(lst, list) or len(lst) != len(names):
            raise SceneError(f"{where}.{role}",
                             f"a {kind} takes {len(names)} {role}, got {lst!r}")
        for nm, v in zip(names, lst):
            kw[nm] = _name(f"{where}.{role}", v)
    for p in params:
        if p in d:
            kw[p] = d[p]
    return _built(where, REACTION_TYPES[kind], kw)


def _reaction_to_dict(r: Reaction) -> dict:
    rnames, pnames, params = _REACTION_FIELDS[r.kind]
    out = {"type": r.kind, "reactants": list(r.reactants), "products": list(r.products)}
    for p in params:
        out[p] = getattr(r, p)
    return out


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} to TOML")


def _line_of(text: str, field_path: str):
    """Best-effort line number of the key named last in ``field_path`` (1-based) or None."""
    m = re.match(r"(species|reactions|thermal_walls|outlets)\[(\d+)\]\.?(\w*)", field_path)
    lines = text.splitlines()
    if m:
        table, idx, key = m.group(1), int(m.group(2)), m.group(3)
        seen = -1
        for n, line in enumerate(lines, 1):
            if line.strip() == f"[[{table}]]":
                seen += 1
                if seen == idx:
                    if not key:
                        return n
                    for n2 in range(n, len(lines)):
                        s = lines[n2].strip()
                        if s.startswith("["):
                            break
                        if re.match(rf"{re.escape(key)}\s*=", s):
                            return n2 + 1
                    return n
        return None
    key = field_path.split(".")[-1]
    section = field_path.split(".")[0] if "." in field_path else None
    in_section = section is None
    for n, line in enumerate(lines, 1):
        s = line.strip()
        if s.startswith("["):
            in_section = section is not None and s == f"[{section}]"
            if section is None:
                break
            continue
        if in_section and re.match(rf"{re.escape(key)}\s*=", s):
            return n
    return None
