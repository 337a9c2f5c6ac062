"""The episode core the single and the vector env share (:class:`EpisodeCore`: reset, step,
reward of R reactors), and its parts: reading an action, observing reactors at reset, the
checks after a compiled step."""

from __future__ import annotations

from functools import partial
from typing import TYPE_CHECKING, NamedTuple

import numba
import numpy as np

from .arguments import check_memory
from .config import SLOT_BYTES_BATCH
from .kernels.batch import (
    O_BLOCKED,
    O_ENERGY_HEAT,
    O_HEAT,
    O_INJECTED,
    O_INVALID,
    O_STATUS,
    balance,
    env_step,
    env_step_parallel,
    observe_batch,
)
from .kernels.step import IC_COLLISIONS, IC_REACTIVE, IC_SUBSTEPS, IC_WALL_HITS
from .kernels.structs import (
    FLOAT,
    Episodes,
)
from .simulation import Simulation
from .state import ReactorState
from .threads import ThreadChooser, numba_threads

if TYPE_CHECKING:
    from .config import ReactorConfig

# the counters of events (collisions, wall hits, reactive collisions): each costs about as
# much as 4 disc-substeps
_EVENTS = [IC_COLLISIONS, IC_WALL_HITS, IC_REACTIVE]


# --------------------------------------------------------------------------------------------
# the per-step logic, shared with the vector env


def check_status(capacity: int, iout: np.ndarray, active: np.ndarray) -> None:
    """Raise if an ``active`` reactor of the last :func:`~discgym.kernels.batch.env_step`
    outgrew its arrays of ``capacity`` discs (it cannot: the capacity plan bounds every
    reactor; this would be a bug)."""
    status = np.where(active, iout[:, O_STATUS], 0)
    if status.any():
        bad = np.flatnonzero(status).tolist()
        raise RuntimeError(f"reactors {bad}: the state outgrew the capacity {capacity} "
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


# --------------------------------------------------------------------------------------------
# the episode core


class StepOut(NamedTuple):
    """What a step of :class:`EpisodeCore` did: per reactor, (R,) arrays (zeros for the
    reactors it did not step), or for a core made with ``numbers`` Python numbers
    (``injected`` and ``refused`` lists of F)."""

    heat: np.ndarray  #: (R,) FLOAT energy the heat action put in (or took out)
    injected: np.ndarray  #: (R, F) int64 discs injected per feed species
    refused: np.ndarray  #: (R, F) int64 discs asked for but not placed
    blocked: np.ndarray  #: (R,) bool the wall could not move as far as asked
    invalid: np.ndarray  #: (R,) int64 NaN or infinite action components
    product: np.ndarray  #: (R,) FLOAT product discs after the step
    gain: np.ndarray  #: (R,) FLOAT the reward's gain (ReactorConfig.reward_terms)
    cost_heat: np.ndarray  #: (R,) FLOAT
    cost_feed: np.ndarray  #: (R,) FLOAT
    reward: np.ndarray  #: (R,) FLOAT


class EpisodeCore:
    """R reactors of one :class:`~discgym.config.ReactorConfig` through their episodes: the
    one reset, step and reward of the single env (R = 1), the vector env and a plant.

    It owns the :class:`~discgym.state.ReactorState` of the reactors (``state``), their
    episode rows (``episodes``, :class:`~discgym.kernels.structs.Episodes`) and a
    :class:`~discgym.Simulation` handle on each row (``simulations``). A step runs the
    actions, the physics and the observation of the active reactors in one compiled call
    (:func:`~discgym.kernels.batch.env_step`, or :func:`~discgym.kernels.batch.env_step_parallel`
    over numba's threads), then books the clocks, the energy put in and moved walls on the
    rows, and computes the reward. A reactor changed through its handle between steps
    (``inject``, ``resize``, ``set_state``, ``step``) is re-checked before it steps: more
    discs than the capacity plan holds grow every row, bounds give the wall its size
    (:meth:`~discgym.config.ReactorConfig.read_size`), another integrator is refused.

    ``config`` is the batch's configuration: what every reactor shares; ``configs`` (R
    :class:`~discgym.config.ReactorConfig` s, default ``config`` for every reactor), each
    reactor's own (its contents, ranges, budgets, costs, kinetics, episode length: checked by
    ``config.check_batch``), which :meth:`set_config` changes before a reset; ``low`` and
    ``high`` the observation's bounds (default ``config``'s). ``numbers``: a core of one
    reactor whose steps give Python numbers (the single env's), not arrays.
    """

    def __init__(self, config: ReactorConfig, rows: int, threads: int | None = None,
                 configs: list | None = None, low=None, high=None, numbers: bool = False):
        cfg = self.config = config
        R, S, F = int(rows), config.n_species, len(config.feed)
        K = len(config.compiled.labels)
        self.rows, self.threads = R, threads
        if numbers and R != 1:
            raise ValueError(f"numbers: a core of one reactor only, not {R}")
        self.numbers = numbers  # (a single env's: StepOut of Python numbers)
        self.low = config.obs_low if low is None else low
        self.high = config.obs_high if high is None else high
        self.configs = [config] * R if configs is None else list(configs)
        self.state = st = ReactorState(R, max(c.capacity for c in self.configs), S, K)
        for r in range(R):  # one generator per reactor, reseeded at each of its resets
            st.set_generator(r, np.random.Generator(np.random.PCG64(0)))
        self.episodes = Episodes(
            size=np.ones(R, dtype=FLOAT), feed_left=np.zeros((R, F), dtype=np.int64),
            steps=np.zeros(R, dtype=np.int64), n_init=np.ones(R, dtype=FLOAT),
            n_ref=np.ones(R, dtype=FLOAT), temperature=np.zeros(R, dtype=FLOAT),
            kinetic=np.zeros(R, dtype=FLOAT), stats=np.zeros((R, 3 * S + 1), dtype=FLOAT),
            obs=np.zeros((R, len(cfg.obs_names)), dtype=np.float32),
            fout=np.zeros((R, 2 + F), dtype=FLOAT),
            iout=np.zeros((R, O_INJECTED + 2 * F), dtype=np.int64),
            sp_form=np.zeros((R, S), dtype=FLOAT), ch_rate=np.zeros((R, K), dtype=FLOAT),
            ch_energy=np.zeros((R, K), dtype=FLOAT), ch_last=np.zeros((R, K), dtype=np.int64),
            out_last=np.zeros((R, S), dtype=np.int64), feed_kT=np.full(R, np.nan, dtype=FLOAT),
            feed_kT_next=np.full(R, np.nan, dtype=FLOAT),
            feed_switch=np.full(R, -1, dtype=np.int64), pending=np.zeros((R, 2), dtype=FLOAT),
            heat_rate=np.ones(R, dtype=FLOAT), t_min=np.ones(R, dtype=FLOAT),
            t_max=np.ones(R, dtype=FLOAT), size_min=np.ones(R, dtype=FLOAT),
            size_max=np.ones(R, dtype=FLOAT), wall_speed=np.zeros(R, dtype=FLOAT),
            inject_max=np.zeros(R, dtype=np.int64), episode_steps=np.ones(R, dtype=np.int64),
            feed_budget=np.zeros((R, F), dtype=np.int64), heat_cost=np.zeros(R, dtype=FLOAT),
            feed_cost=np.zeros(R, dtype=FLOAT))
        self.np_randoms: list = [None] * R  #: each reactor's episode generator (draws resets)
        self.simulations: list = [None] * R
        self.product = np.zeros(R, dtype=FLOAT)  #: product discs at the last observation
        self.act = np.zeros((R, 2 + F), dtype=FLOAT)  #: the actions of the next step
        self._cost = np.ones(R, dtype=FLOAT)  # each reactor's next step's cost (an estimate)
        self._chooser = ThreadChooser()  # (speed only: the bits do not depend on it)
        self._order = np.zeros(R, dtype=np.int64)
        self._starts = np.zeros(numba.config.NUMBA_NUM_THREADS + 1, dtype=np.int64)
        for r, c in enumerate(self.configs):  # (what a reset sets: known before one)
            c.settings_row(self.episodes, r)
        self._link()

    def _link(self) -> None:
        # (the structs as plain tuples of their fields: see kernels.batch.env_step)
        cfg = self.config
        cs = cfg.compiled
        consts = cfg.consts._replace(obs_low=self.low, obs_high=self.high)
        self._fixed = (tuple(self.episodes), (tuple(cfg.tables), cs.params, cs.flags),
                       tuple(consts))

    def set_config(self, r: int, config: ReactorConfig, who: str) -> None:
        """Reactor ``r``'s configuration from its next reset on (refused, naming ``who``,
        if it cannot share the batch: :meth:`~discgym.config.ReactorConfig.check_batch`)."""
        self.config.check_batch(config, self.low, self.high, who)
        self.configs[r] = config

    # ------------------------------------------------------------------ reset
    def reset(self, rows) -> None:
        """Start a new episode in each reactor of ``rows`` (indices), its contents drawn
        from its ``np_randoms[r]``; then observe every reactor."""
        st, ep = self.state, self.episodes
        for r in rows:
            cfg = self.configs[r]
            np_random = self.np_randoms[r]
            sim = cfg.new_simulation(np_random, generator=st.generator(r), row=(st, r))
            cfg.reset_row(ep, r, sim, np_random)
            self.simulations[r] = sim
            self._plan(r, sim)
            self._cost[r] = len(sim) * cfg.steps_per_action  # (no history: one substep a step)
        self.observe()
        self.product[rows] = ep.stats[rows, self.config.product]

    def observe(self) -> None:
        """Observe every reactor again (``episodes.obs``, ``stats``, ``temperature``,
        ``kinetic``): what a step ends with, for a reactor changed through its handle."""
        observe_batch(tuple(self.state.rx), self._fixed[0], self.config.compiled.sp_mass,
                      self._fixed[2])

    def _plan(self, r: int, sim: Simulation) -> None:
        """Room for all the discs reactor ``r``'s contents and feed left could ever split
        into (mass is conserved), twice over: the compiled step never grows arrays."""
        st = self.state
        need = self.configs[r].capacity_for(sim.species, self.episodes.feed_left[r])[0]
        if need > st.capacity:  # (every row grows: at least twice over)
            cap = max(need, 2 * st.capacity)
            check_memory(self.rows * (cap * SLOT_BYTES_BATCH + 4096), "capacity",
                         f"{self.rows} reactors of capacity {cap} discs (reactor {r} holds "
                         f"{len(sim)})")
            st.grow(need)
        st.touched[r] = False

    # ------------------------------------------------------------------ step
    def step(self, active: np.ndarray, act: np.ndarray | None = None) -> StepOut:
        """One step of the reactors ``active`` (R,) bool, with the actions ``act`` (R, A)
        (default :attr:`act`, filled by the caller)."""
        cfg, st, ep = self.config, self.state, self.episodes
        if act is None:
            act = self.act
        one = self.numbers
        every = one or active.all()
        # the rows stepped: a row index for one reactor (numbers, numpy's cheapest), a
        # slice for all of them, else the mask
        rows = 0 if one else slice(None) if every else active
        if st.any_touched:
            self._absorb(np.flatnonzero(st.touched & active).tolist())
        size0 = ep.size[0] if one else ep.size.copy()
        self._run(active, act)
        iout, fout = ep.iout, ep.fout
        if iout[0, O_STATUS] if one else iout[:, O_STATUS].any():
            check_status(st.capacity, iout, active)
        # what Simulation.step and its controls book: the clocks, the energy put in (in the
        # order the controls add it), bounds of a moved wall (built when asked for)
        st.tick(rows, cfg.steps_per_action)
        e = st.energy_input
        for j in range(O_ENERGY_HEAT, fout.shape[1]):
            e[rows] += fout[rows, j]
        moved = ([0] if ep.size[0] != size0 else ()) if one else \
            np.flatnonzero(ep.size != size0).tolist()
        for r in moved:
            st.defer_bounds(r, partial(cfg.bounds_of, float(ep.size[r])))
        F, p = len(cfg.feed), cfg.product
        if one:  # Python numbers: what the single env reports, and the cheapest arithmetic
            fo, io = fout[0].tolist(), iout[0].tolist()
            heat, injected, refused = fo[O_HEAT], io[O_INJECTED:O_INJECTED + F], \
                io[O_INJECTED + F:]
            blocked, invalid = io[O_BLOCKED] != 0, io[O_INVALID]
            product, before = ep.stats[0, p].item(), self.product[0].item()
            outflow, total, n_ref = ep.out_last[0, p].item(), sum(injected), ep.n_ref.item()
        else:  # fresh arrays; the rows of the reactors not stepped are zeros
            heat, injected, refused = fout[:, O_HEAT].copy(), \
                iout[:, O_INJECTED:O_INJECTED + F].copy(), iout[:, O_INJECTED + F:].copy()
            blocked, invalid = iout[:, O_BLOCKED] != 0, iout[:, O_INVALID].copy()
            if not every:
                for a in (heat, injected, refused, blocked, invalid):
                    a[~active] = 0
            product, before = ep.stats[:, p].copy(), self.product
            outflow, total, n_ref = ep.out_last[:, p], injected.sum(axis=1), ep.n_ref
        gain, cost_heat, cost_feed, reward = cfg.reward_terms(
            product, before, outflow, heat, total, n_ref,
            (ep.heat_cost.item(), ep.feed_cost.item()) if one else (ep.heat_cost, ep.feed_cost))
        self.product[0 if one else slice(None)] = product
        if not every:
            for a in (gain, cost_heat, cost_feed, reward):
                a[~active] = 0.0
        return StepOut(heat, injected, refused, blocked, invalid, product, gain, cost_heat,
                       cost_feed, reward)

    def _run(self, active: np.ndarray, act: np.ndarray) -> None:
        """The compiled step, in parallel over the reactors when more than one is active and
        more than one thread is allowed (each on the thread count measured fastest:
        :mod:`discgym.threads`; the same bits whatever the count)."""
        st = self.state
        ep_t, physics, consts = self._fixed
        args = (tuple(st.rx), ep_t, physics, consts, st.rngs, active, act)
        if self.rows == 1 or self.threads == 1 or np.count_nonzero(active) <= 1:
            env_step(*args)
            return
        icnt = st.rx.icnt
        sub0 = icnt[:, IC_SUBSTEPS].copy()
        ev0 = icnt[:, _EVENTS].sum(axis=1)
        most = numba.get_num_threads() if self.threads is None else \
            min(self.threads, numba.config.NUMBA_NUM_THREADS)

        def run(want: int) -> None:
            # one list of consecutive reactors per thread, of about equal cost (the last
            # step's work of each reactor: disc-substeps + 4 x events)
            balance(self._cost, active, want, self._order, self._starts[:want + 1])
            with numba_threads(want):
                env_step_parallel(*args, self._order, self._starts[:want + 1])

        work = float(self._cost[active].sum())
        self._chooser.timed(most, run, lambda: work)
        cost = st.rx.n * (icnt[:, IC_SUBSTEPS] - sub0) + 4 * (icnt[:, _EVENTS].sum(axis=1) - ev0)
        self._cost[active] = cost[active]

    def _absorb(self, rows: list) -> None:
        """Take over what the handles of ``rows`` changed since the last step (see the
        class's docstring); raise before anything is stepped where the env cannot follow."""
        ep = self.episodes
        for r in rows:
            cfg, sim = self.configs[r], self.simulations[r]
            who = "its Simulation" if self.numbers else f"reactor {r}'s Simulation"
            if sim.integrator != cfg.integrator:
                raise integrator_changed(cfg, sim.integrator, who)
            ep.size[r] = cfg.read_size(sim.bounds, float(ep.size[r]), who)
            self._plan(r, sim)
        self.state.any_touched = bool(self.state.touched.any())

    # ------------------------------------------------------------------ pickle, deepcopy
    def __getstate__(self):
        d = self.__dict__.copy()
        del d["_fixed"]
        # each handle is rebuilt on its row of the (pickled) state
        d["simulations"] = [None if s is None else (s.scene, s.integrator)
                            for s in self.simulations]
        return d

    def __setstate__(self, d):
        self.__dict__.update(d)
        self._link()
        self.simulations = [None if h is None else Simulation.attach(h[0], (self.state, r), h[1])
                            for r, h in enumerate(d["simulations"])]
        for s in self.simulations:
            if s is not None:
                s.threads = 1
