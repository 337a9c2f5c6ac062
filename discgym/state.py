"""The state of R reactors of one scene's species, as rows: what a :class:`~discgym.Simulation`
(a handle on one row), the single env (one row), the vector env (R rows) and a plant all hold.

The arrays the kernels step are a :class:`~discgym.kernels.structs.Reactors` struct, row r
for reactor r, with a capacity C of discs per row that only :meth:`ReactorState.grow`
changes (for every row at once). Beside them, per row, what Python books around a kernel
call: the clocks, the energy the controls put in, the energy at the start, the
:class:`~discgym.Box` or :class:`~discgym.Circle` of the bounds and the random generator.

A row changed from outside an environment's step (a handle's ``inject``, ``resize`` or
``set_state``, or its own ``step``) is flagged in :attr:`ReactorState.touched`, so that an
environment re-checks only those rows (its capacity plan, the wall's size, the integrator)
before it steps them; nothing is copied back and forth.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .compiled import kernel_bounds
from .kernels import step as _step
from .kernels.structs import COUNT, FLOAT, INDEX, Reactors, generator_list

__all__ = ["ReactorState", "Row"]


class ReactorState:
    """R reactor rows of discs, counters, bounds and clocks (see the module's docstring).

    Arguments: ``rows`` R >= 1; ``capacity`` C, discs per row; ``n_species`` and
    ``n_channels``, the scene's species and reaction channels (the widths of ``outflow`` and
    ``ch_count``). Every row starts empty: no discs, zero counters and clocks; a
    :class:`~discgym.Simulation` made on a row (``Simulation(..., row=(state, r))``) fills it.
    """

    def __init__(self, rows: int, capacity: int, n_species: int, n_channels: int):
        R, C = int(rows), max(int(capacity), 1)
        self.rows = R
        self.rx = Reactors(
            pos=np.zeros((R, C, 2), dtype=FLOAT), vel=np.zeros((R, C, 2), dtype=FLOAT),
            species=np.full((R, C), -1, dtype=INDEX),
            internal_energy=np.zeros((R, C), dtype=FLOAT), ids=np.zeros((R, C), dtype=COUNT),
            next_id=np.zeros((R, 1), dtype=COUNT), n=np.zeros(R, dtype=np.int64),
            ksteps=np.zeros(R, dtype=np.int64), bounds_kind=np.zeros(R, dtype=np.int64),
            bounds_params=np.zeros((R, 4), dtype=FLOAT),
            icnt=np.zeros((R, _step.N_ICOUNTERS), dtype=COUNT),
            fsum=np.zeros((R, _step.N_FSUMS), dtype=FLOAT),
            ch_count=np.zeros((R, n_channels), dtype=COUNT),
            outflow=np.zeros((R, n_species), dtype=COUNT),
            bounds_walls=np.zeros((R, 4), dtype=FLOAT))
        #: the clocks: time = origin + steps x dt after whole steps of the row's scene's
        #: ``dt`` since the origin (so that the time does not depend on how steps are split
        #: into calls); the time since the start, and since the last ``reset_counters``
        self.origin = np.zeros(R, dtype=FLOAT)
        self.steps = np.zeros(R, dtype=np.int64)
        self.reset_origin = np.zeros(R, dtype=FLOAT)
        self.reset_steps = np.zeros(R, dtype=np.int64)
        self.dt = np.ones(R, dtype=FLOAT)  #: each row's scene's dt
        self.energy_input = np.zeros(R, dtype=FLOAT)  #: put in by the controls
        self.energy_start = np.zeros(R, dtype=FLOAT)  #: the total energy at the start
        self.touched = np.zeros(R, dtype=bool)  #: changed from outside an env's step
        self.any_touched = False  #: touched.any(), kept (cheaper to read than to compute)
        self._bounds: list = [None] * R
        self._bounds_factory: list = [None] * R
        self._generators: list = [None] * R
        self._rngs = None  # (the typed lists, built when first asked for)
        self._row_rngs: list = [None] * R
        self.generation = 0  #: bumped whenever :meth:`grow` replaces the arrays

    @property
    def capacity(self) -> int:
        return self.rx.species.shape[1]

    # ------------------------------------------------------------------ capacity
    def grow(self, capacity: int) -> None:
        """Make room for at least ``capacity`` discs per row (at least doubling: amortised
        O(1) per disc added); every row keeps its discs. Replaces the disc arrays: their
        users read them from :attr:`rx` again (:attr:`generation` tells when)."""
        C = self.capacity
        if capacity <= C:
            return
        C = max(int(capacity), 2 * C)
        new = {}
        for name in ("pos", "vel", "species", "internal_energy", "ids"):
            a = getattr(self.rx, name)
            b = np.full((a.shape[0], C) + a.shape[2:], -1 if name == "species" else 0,
                        dtype=a.dtype)
            b[:, :a.shape[1]] = a
            new[name] = b
        self.rx = self.rx._replace(**new)
        self.generation += 1

    def adopt(self, r: int, discs: tuple, n: int) -> None:
        """Row ``r``'s discs are now ``discs`` (pos, vel, species, internal_energy, ids, ...),
        ``n`` live: what a kernel that had to grow a row's arrays returned."""
        if len(discs[2]) > self.capacity:  # (a kernel reallocates only to grow)
            self.grow(len(discs[2]))
            for name, a in zip(("pos", "vel", "species", "internal_energy", "ids"), discs):
                row = getattr(self.rx, name)[r]
                row[:len(a)] = a
                row[len(a):] = -1 if name == "species" else 0
        self.rx.n[r] = n

    # ------------------------------------------------------------------ clocks
    def tick(self, rows, n_steps: int, dt: float | None = None) -> None:
        """Book ``n_steps`` steps on the clocks of ``rows`` (an index, a slice or a mask):
        whole steps of each row's ``dt`` (``dt`` None, or the row's) add to the step counts;
        steps of another length (an ``advance``'s remainder; one row) start new origins."""
        if dt is None or dt == self.dt[rows]:
            self.steps[rows] += n_steps
            self.reset_steps[rows] += n_steps
        else:
            h = self.dt[rows]
            for o, k in ((self.origin, self.steps), (self.reset_origin, self.reset_steps)):
                o[rows] = o[rows] + k[rows] * h + n_steps * dt
                k[rows] = 0

    def time(self, rows=slice(None)):
        """The simulated time of ``rows`` since their start (a Python float for one row)."""
        if isinstance(rows, int):  # (Python numbers: the same bits, cheaper)
            return self.origin.item(rows) + self.steps.item(rows) * self.dt.item(rows)
        return self.origin[rows] + self.steps[rows] * self.dt[rows]

    def since_reset(self, rows=slice(None)):
        """The simulated time of ``rows`` since their last ``reset_counters``."""
        return self.reset_origin[rows] + self.reset_steps[rows] * self.dt[rows]

    # ------------------------------------------------------------------ bounds
    def bounds(self, r: int):
        """Row ``r``'s bounds (a :class:`~discgym.Box` or :class:`~discgym.Circle`)."""
        b = self._bounds[r]
        if b is None:  # (a wall moved by an env's compiled step: built when first asked for)
            b = self._bounds[r] = self._bounds_factory[r]()
        return b

    def set_bounds(self, r: int, bounds) -> None:
        """Give row ``r`` the bounds ``bounds`` (their kernel form too)."""
        self._bounds[r] = bounds
        self.rx.bounds_kind[r], self.rx.bounds_params[r] = kernel_bounds(bounds)

    def defer_bounds(self, r: int, factory: Callable) -> None:
        """Row ``r``'s bounds were moved by compiled code (its ``bounds_params`` are set);
        their object is ``factory()``, built only when asked for (building it costs a
        noticeable share of a reinforcement-learning step)."""
        self._bounds[r] = None
        self._bounds_factory[r] = factory

    # ------------------------------------------------------------------ generators
    def generator(self, r: int) -> np.random.Generator:
        return self._generators[r]

    def set_generator(self, r: int, generator: np.random.Generator) -> None:
        """Row ``r`` draws from ``generator`` from now on."""
        if generator is not self._generators[r]:
            self._generators[r] = generator
            self._rngs = None
            self._row_rngs[r] = None

    @property
    def rngs(self):
        """Every row's generator as the batched kernels take them (a ``numba.typed.List``:
        the same objects, the same states)."""
        if self._rngs is None:
            self._rngs = generator_list(self._generators)
        return self._rngs

    def row_rngs(self, r: int):
        """Row ``r``'s generator as the kernels of one reactor take it (a one-item typed
        list: far cheaper to pass than the generator itself, see
        ``kernels.step.advance_rngs``)."""
        lst = self._row_rngs[r]
        if lst is None:
            lst = self._row_rngs[r] = generator_list([self._generators[r]])
        return lst

    # ------------------------------------------------------------------ rows
    def touch(self, r: int) -> None:
        """Flag row ``r`` as changed from outside an env's step."""
        self.touched[r] = True
        self.any_touched = True

    def clear(self, r: int) -> None:
        """Empty row ``r``: no discs, zero counters, clocks and energies."""
        rx = self.rx
        rx.species[r] = -1
        for a in (rx.pos, rx.vel, rx.internal_energy, rx.ids, rx.next_id, rx.icnt, rx.fsum,
                  rx.ch_count, rx.outflow, rx.bounds_walls, self.origin, self.steps,
                  self.reset_origin, self.reset_steps):
            a[r] = 0
        rx.n[r] = rx.ksteps[r] = 0
        self.energy_input[r] = self.energy_start[r] = 0.0
        self.touched[r] = False

    def __getstate__(self):
        d = self.__dict__.copy()
        d["_rngs"] = None  # (numba objects: rebuilt from the generators)
        d["_row_rngs"] = [None] * self.rows
        d["_bounds"] = [self.bounds(r) if self._bounds_factory[r] is not None or b is not None
                        else None for r, b in enumerate(self._bounds)]
        d["_bounds_factory"] = [None] * self.rows
        return d


def _number(array: Callable, cast: type) -> property:
    """A handle's number in its row of ``array(state)``, as ``cast``; assigned in place."""
    def get(self):
        return cast(array(self._st)[self._r])

    def put(self, value) -> None:
        array(self._st)[self._r] = value

    return property(get, put)


class Row:
    """A handle's row of a :class:`ReactorState`: ``_st`` the state, ``_r`` the row; its
    arrays (views, written in place) and numbers under the names the handle's code uses. The
    base of :class:`~discgym.Simulation` and of its parts (:mod:`discgym.observables`,
    :mod:`discgym.state_io`)."""

    _st: ReactorState
    _r: int

    _pos = property(lambda self: self._st.rx.pos[self._r])
    _vel = property(lambda self: self._st.rx.vel[self._r])
    _species = property(lambda self: self._st.rx.species[self._r])
    _internal_energy = property(lambda self: self._st.rx.internal_energy[self._r])
    _ids = property(lambda self: self._st.rx.ids[self._r])
    _idctr = property(lambda self: self._st.rx.next_id[self._r])  # the next disc identity
    _icnt = property(lambda self: self._st.rx.icnt[self._r])
    _fsum = property(lambda self: self._st.rx.fsum[self._r])
    _ch_count = property(lambda self: self._st.rx.ch_count[self._r])
    _outflow = property(lambda self: self._st.rx.outflow[self._r])
    _walls = property(lambda self: self._st.rx.bounds_walls[self._r])  # (Bounds.walls)
    _bounds_kind = property(lambda self: int(self._st.rx.bounds_kind[self._r]))
    _bounds_params = property(lambda self: self._st.rx.bounds_params[self._r])
    _time = property(lambda self: float(self._st.time(self._r)))
    _rng = property(lambda self: self._st.generator(self._r))
    _rngs = property(lambda self: self._st.row_rngs(self._r))  # (the kernels' form)
    _since_reset = property(lambda self: float(self._st.since_reset(self._r)))

    # (numbers of the row, read and written in place)
    _n = _number(lambda st: st.rx.n, int)  # live discs
    _steps = _number(lambda st: st.rx.ksteps, int)  # kernel steps (times the reordering)
    _energy_input = _number(lambda st: st.energy_input, float)
    _energy_start = _number(lambda st: st.energy_start, float)
