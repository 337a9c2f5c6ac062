"""Controllers found by black-box search: a parametric family over every control of a task.

:class:`ScheduleController` is a schedule with feedback, the kind of controller a process
engineer writes, with every control a function of the episode clock ``u = 1 - time_left``
(0 at reset, 1 at the end) and of what the observation shows:

- heat: a kT setpoint, piecewise linear in ``u`` through the values ``setpoint_0`` ..
  ``setpoint_4`` at ``u`` = :data:`SETPOINT_KNOTS`, times ``(feed_kT / inlet_ref) **
  inlet_gain`` where the env observes the inlet temperature (``feed_kT``; ``inlet_ref`` the
  geometric mean of the env's ``feed_temperature`` range): the setpoint may follow the feed's
  temperature, which changes within an episode. It is held by the thermostats' heating law
  (the env's own law inverted, :meth:`discgym.controllers.Slots.heat_actions`); with
  ``heating="jacket"`` by :class:`~discgym.controllers.JacketThermostat`'s proportional law,
  the jacket at ``target + jacket_gain (target - kT)``. Where the reward charges the heat
  moved (``heat_cost`` > 0), a dead band ``band`` >= 1: the law heats or cools toward the
  nearest point of ``[target / band, target x band]`` and leaves kT alone inside it
  (``band`` = 1: the plain setpoint), as :class:`~discgym.controllers.BandThermostat` does.
- wall: the action, piecewise linear in ``u`` through ``wall_0``, ``wall_1``, ``wall_2`` at
  ``u`` = :data:`WALL_KNOTS`.
- each feed species X: the action ``feed_X`` while ``u < stop_X``, 0 after (``stop_X`` = 1:
  fed to the end).

The parameter vector (:meth:`ScheduleController.names`, in that order) depends on the env:
``inlet_gain`` only where ``feed_kT`` is observed, ``jacket_gain`` only with a jacket, ``band``
only where heat costs, one ``feed_X, stop_X`` pair per feed species.
:meth:`~ScheduleController.bounds` gives each parameter's range and scale ("log" for the
setpoints: the search works on ``log kT``);
:meth:`~ScheduleController.from_vector` and :meth:`~ScheduleController.to_vector` convert,
:meth:`~ScheduleController.batch` makes one controller for a batch of reactors with one
parameter vector per row (the search scores a whole population in one vector env:
:func:`run_batch`). The family holds ``DiscFlow-v0``'s flow thermostat exactly
(:func:`flow_thermostat_params`) and ``DiscEconomic-v0``'s band thermostat
(:func:`band_thermostat_params`).

:data:`SEARCHED` has the parameters found by ``benchmarks/search_controller.py``, per task, and
the command that found them; :func:`searched` makes that controller (docs/tasks.md,
"Searched controllers").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from .controllers import Slots
from .tasks import task_id
from .values import number_in

__all__ = ["ScheduleController", "SETPOINT_KNOTS", "WALL_KNOTS", "SEARCHED", "searched",
           "flow_thermostat_params", "band_thermostat_params", "HELD", "run_batch"]

#: The clock values ``u`` of the setpoint's knots (0.6 and 0.8: the flow thermostat's ramp
#: starts at 0.6, so the family holds it exactly; denser late, where the schedules differ).
SETPOINT_KNOTS = (0.0, 0.3, 0.6, 0.8, 1.0)
#: The clock values ``u`` of the wall's knots.
WALL_KNOTS = (0.0, 0.5, 1.0)


def _interp(u: np.ndarray, knots: Sequence[float], values: np.ndarray) -> np.ndarray:
    """Piecewise-linear interpolation of each row's ``values`` (R or 1, K) at ``u`` (R,)."""
    k = np.asarray(knots, dtype=np.float64)
    u = np.clip(u, k[0], k[-1])
    j = np.clip(np.searchsorted(k, u, side="right") - 1, 0, len(k) - 2)
    w = (u - k[j]) / (k[j + 1] - k[j])
    v = np.broadcast_to(values, (len(u), values.shape[1]))
    rows = np.arange(len(u))
    return (1.0 - w) * v[rows, j] + w * v[rows, j + 1]


class ScheduleController:
    """Every control of a task as a schedule over the episode clock with feedback (the module
    docstring has the law and the parameters).

    ``ScheduleController(env, **params)``: parameters not given take :meth:`defaults` (hold
    kT 1.6, the wall at -1, every feed full to the end: the thermostats' settings); a name
    the env's vector has not is a ``TypeError``, a value outside :meth:`bounds` (or not a
    finite number) a ``ValueError`` naming it. Called with one observation (D,) it returns
    the action (A,) (float32, within the action space); a :meth:`batch` controller maps
    observations (R, D) to actions (R, A). Stateless: the action depends on the observation
    alone (:meth:`reset` does nothing); ``setpoint`` is the last kT setpoint (a float, or
    (R,) for a batch), so the controller can be a residual agent's base.

    ``setpoint_scale`` (1 by default; a float, or (R,) for a batch) multiplies the setpoint
    after its clip to the env's temperature range, before the heating law holds it: a
    residual agent's correction (:class:`~discgym.controllers.SetpointActions` sets it),
    which the controller's own law then follows, the jacket's or the dead band's included.
    At 1 the law is unchanged, bit for bit."""

    #: The residual agent's factor on the setpoint (see the class docstring).
    setpoint_scale = 1.0

    def __init__(self, env, **params):
        self.s = Slots(env)
        u = getattr(env, "unwrapped", env)
        cfg = u.config
        names = self.names(env)
        unknown = [k for k in params if k not in names]
        if unknown:
            raise TypeError(f"ScheduleController() got an unexpected keyword argument "
                            f"{unknown[0]!r} (this env's parameters: {', '.join(names)})")
        values = dict(self.defaults(env), **params)
        self._names = names
        self.x = self._check(np.array([values[k] for k in names], dtype=object), env)[None]
        self.feeds = [nm[len("feed_left_"):] for nm in self.s.names
                      if nm.startswith("feed_left_")]
        self.jacket = cfg.heating == "jacket"
        self.t_min, self.t_max = float(cfg.t_min), float(cfg.t_max)
        self.i_inlet = self.s.names.index("feed_kT") if "feed_kT" in self.s.names else None
        if self.i_inlet is not None:
            lo, hi = cfg.feed_temperature
            self.inlet_ref = math.sqrt(float(lo) * float(hi))
        self._col = {k: j for j, k in enumerate(names)}
        self.setpoint = float("nan")

    # ------------------------------------------------------------------ the parameter vector

    @staticmethod
    def names(env) -> list[str]:
        """The names of the env's parameter vector, in order."""
        s = Slots(env)
        u = getattr(env, "unwrapped", env)
        names = [f"setpoint_{k}" for k in range(len(SETPOINT_KNOTS))]
        names += [f"wall_{k}" for k in range(len(WALL_KNOTS))]
        for nm in s.names:
            if nm.startswith("feed_left_"):
                x = nm[len("feed_left_"):]
                names += [f"feed_{x}", f"stop_{x}"]
        if "feed_kT" in s.names:
            names.append("inlet_gain")
        if u.config.heating == "jacket":
            names.append("jacket_gain")
        elif u.config.heat_cost > 0:
            names.append("band")
        return names

    @classmethod
    def bounds(cls, env) -> dict[str, tuple[float, float, str]]:
        """``{name: (low, high, scale)}``: a setpoint within the env's temperature range (log
        scale), a wall action in [-1, 1], a feed action in [0, 1] (a negative one feeds
        nothing, as 0), a feed's stop in [0, 1] (a fraction of the episode), ``inlet_gain`` in
        [-1, 1], ``jacket_gain`` in [0, 10], ``band`` in [1, 4] (linear scales)."""
        cfg = getattr(env, "unwrapped", env).config
        out = {}
        for k in cls.names(env):
            if k.startswith("setpoint_"):
                out[k] = (float(cfg.t_min), float(cfg.t_max), "log")
            elif k.startswith("wall_") or k == "inlet_gain":
                out[k] = (-1.0, 1.0, "linear")
            elif k.startswith(("feed_", "stop_")):
                out[k] = (0.0, 1.0, "linear")
            elif k == "band":
                out[k] = (1.0, 4.0, "linear")
            else:  # jacket_gain
                out[k] = (0.0, 10.0, "linear")
        return out

    @classmethod
    def defaults(cls, env) -> dict[str, float]:
        """Hold kT 1.6 (clipped into the env's range), the wall at -1, every feed full to the
        end, no inlet feedback, jacket gain 4, no dead band
        (:class:`~discgym.controllers.Thermostat`'s and
        :class:`~discgym.controllers.JacketThermostat`'s settings)."""
        b = cls.bounds(env)
        out = {}
        for k, (lo, hi, _) in b.items():
            out[k] = (min(max(1.6, lo), hi) if k.startswith("setpoint_") else
                      -1.0 if k.startswith("wall_") else 1.0 if k.startswith(("feed_", "stop_"))
                      else 0.0 if k == "inlet_gain" else 1.0 if k == "band" else 4.0)
        return out

    @classmethod
    def _check(cls, values: np.ndarray, env) -> np.ndarray:
        """``values`` (P,) as float64, each a finite number within its bounds."""
        b = cls.bounds(env)
        out = np.empty(len(b))
        for j, (k, (lo, hi, _)) in enumerate(b.items()):
            v = number_in(values[j], lo, hi)
            if v is None:
                raise ValueError(f"{k}: expected a finite number in [{lo}, {hi}], got "
                                 f"{values[j]!r}")
            out[j] = v
        return out

    @classmethod
    def from_vector(cls, env, x) -> ScheduleController:
        """The controller of parameter vector ``x`` (P,), in :meth:`names`' order."""
        x = np.asarray(x)
        names = cls.names(env)
        if x.shape != (len(names),):
            raise ValueError(f"x: expected shape ({len(names)},) ({', '.join(names)}), got "
                             f"{x.shape}")
        if x.dtype.kind not in "iuf":
            raise TypeError(f"x: expected real numbers, got an array of dtype {x.dtype}")
        return cls(env, **dict(zip(names, x.tolist())))

    def to_vector(self) -> np.ndarray:
        """The parameter vector (P,) (a batch controller: its first row)."""
        return self.x[0].copy()

    def params(self) -> dict[str, float]:
        """``{name: value}`` (a batch controller: its first row)."""
        return dict(zip(self._names, self.x[0].tolist()))

    @classmethod
    def batch(cls, env, X) -> ScheduleController:
        """One controller for a batch of reactors, row r of ``X`` (R, P) the parameters of
        reactor r; it maps observations (R, D) to actions (R, A)."""
        X = np.asarray(X)
        names = cls.names(env)
        if X.ndim != 2 or X.shape[1] != len(names) or X.shape[0] < 1:
            raise ValueError(f"X: expected shape (R, {len(names)}) ({', '.join(names)}), got "
                             f"{X.shape}")
        c = cls.from_vector(env, X[0])
        for row in X[1:]:
            cls._check(np.asarray(row, dtype=object), env)
        c.x = np.array(X, dtype=np.float64)
        return c

    @staticmethod
    def to_unit(env, x) -> np.ndarray:
        """Parameters ``x`` (..., P) on [0, 1] per component (log scale for the setpoints):
        the coordinates the search works in."""
        b = list(ScheduleController.bounds(env).values())
        x = np.asarray(x, dtype=np.float64)
        out = np.empty_like(x)
        for j, (lo, hi, scale) in enumerate(b):
            out[..., j] = (np.log(x[..., j] / lo) / math.log(hi / lo) if scale == "log"
                           else (x[..., j] - lo) / (hi - lo))
        return out

    @staticmethod
    def from_unit(env, z) -> np.ndarray:
        """The inverse of :meth:`to_unit` (``z`` clipped into [0, 1] first)."""
        b = list(ScheduleController.bounds(env).values())
        z = np.clip(np.asarray(z, dtype=np.float64), 0.0, 1.0)
        out = np.empty_like(z)
        for j, (lo, hi, scale) in enumerate(b):
            out[..., j] = (lo * (hi / lo) ** z[..., j] if scale == "log"
                           else lo + z[..., j] * (hi - lo))
            out[..., j] = np.clip(out[..., j], lo, hi)  # (rounding at the ends)
        return out

    # ------------------------------------------------------------------ the law

    def reset(self) -> None:
        pass

    def _cols(self, prefix: str) -> list[int]:
        return [j for k, j in self._col.items() if k.startswith(prefix)]

    def __call__(self, obs) -> np.ndarray:
        one = np.ndim(obs) == 1
        if self.x.shape[0] > 1 and (np.ndim(obs) != 2 or np.shape(obs)[0] != self.x.shape[0]):
            raise ValueError(f"obs: expected shape ({self.x.shape[0]}, {len(self.s.names)}), "
                             f"got {np.shape(obs)}")
        o = self.s.check(obs, batch=True)
        X, s = self.x, self.s
        u = 1.0 - o[:, s.i_time]
        target = _interp(u, SETPOINT_KNOTS, X[:, self._cols("setpoint_")])
        if self.i_inlet is not None:
            inlet = np.maximum(o[:, self.i_inlet], 1e-6) / self.inlet_ref
            target = target * inlet ** X[:, self._col["inlet_gain"]]
        target = np.clip(target, self.t_min, self.t_max) * self.setpoint_scale
        T = s.temperatures(o)
        a = np.empty((o.shape[0], 2 + s.n_feed), dtype=np.float32)
        if self.jacket:
            span = math.log(self.t_max / self.t_min)
            jacket = target + X[:, self._col["jacket_gain"]] * (target - T)
            jacket = np.clip(jacket, self.t_min, self.t_max)
            a[:, 0] = 0.0 if span == 0.0 else \
                np.clip(2.0 * np.log(jacket / self.t_min) / span - 1.0, -1.0, 1.0)
        elif "band" in self._col:
            # (toward the band's nearest point: inside it the goal is T itself, action 0)
            b = X[:, self._col["band"]]
            a[:, 0] = s.heat_actions(np.clip(T, target / b, target * b), T)
        else:
            a[:, 0] = s.heat_actions(target, T)
        a[:, 1] = np.clip(_interp(u, WALL_KNOTS, X[:, self._cols("wall_")]), -1.0, 1.0)
        for f, x in enumerate(self.feeds):
            on = u < X[:, self._col[f"stop_{x}"]]
            a[:, 2 + f] = np.where(on, X[:, self._col[f"feed_{x}"]], 0.0)
        self.setpoint = float(target[0]) if one else target
        return a[0] if one else a


def _holding(env, setpoints, *, wall, inject, stop, **extra) -> dict[str, float]:
    """:meth:`ScheduleController.defaults` with these setpoints (one per knot), a constant
    wall, every feed at ``inject`` until ``stop``, and ``extra``."""
    p = ScheduleController.defaults(env)
    p.update({f"setpoint_{k}": float(v) for k, v in enumerate(setpoints)})
    p.update({f"wall_{k}": wall for k in range(len(WALL_KNOTS))})
    for nm in p:
        if nm.startswith("feed_"):
            p[nm] = inject
        elif nm.startswith("stop_"):
            p[nm] = stop
    p.update(extra)
    return p


def flow_thermostat_params(env, *, setpoint=3.8, wall=1.0, inject=1.0, ramp=0.7,
                           ramp_from=0.6) -> dict[str, float]:
    """The parameters that make :class:`ScheduleController` the flow thermostat
    (:func:`discgym.controllers.flow_thermostat` with these settings; ``ramp_from`` must be
    one of :data:`SETPOINT_KNOTS`, the ramp is then piecewise linear through the knots)."""
    if ramp_from not in SETPOINT_KNOTS[:-1]:
        raise ValueError(f"ramp_from: expected one of {SETPOINT_KNOTS[:-1]}, got {ramp_from!r}")
    setpoints = [setpoint * (1.0 + ramp * max(knot - ramp_from, 0.0) / (1.0 - ramp_from))
                 for knot in SETPOINT_KNOTS]
    return _holding(env, setpoints, wall=wall, inject=inject, stop=1.0)


def band_thermostat_params(env, *, t_low=1.0, t_high=2.0, wall=-1.0, inject=1.0,
                           feed_until=0.6) -> dict[str, float]:
    """The parameters that make :class:`ScheduleController` the band thermostat
    (:class:`discgym.controllers.BandThermostat` with these settings and ``margin=0``, the
    band kept by a constant setpoint ``sqrt(t_low t_high)`` and ``band = sqrt(t_high /
    t_low)``); the env must charge heat (``heat_cost`` > 0: the family has ``band``)."""
    if "band" not in ScheduleController.names(env):
        raise ValueError("env: the band thermostat's dead band needs heat_cost > 0")
    if not 0 < t_low <= t_high:
        raise ValueError(f"t_low, t_high: expected 0 < t_low <= t_high, got {t_low!r}, "
                         f"{t_high!r}")
    return _holding(env, [math.sqrt(t_low * t_high)] * len(SETPOINT_KNOTS), wall=wall,
                    inject=inject, stop=1.0 - feed_until, band=math.sqrt(t_high / t_low))


#: The tasks whose hand-written controller (``discgym.baselines.TASK_BASELINES``) the family
#: holds exactly: the function giving its parameters (the search starts there).
HELD = {"DiscFlow-v0": flow_thermostat_params, "DiscEconomic-v0": band_thermostat_params}


def run_batch(env_id: str, X, seeds: Sequence[int], env_kwargs: Mapping | None = None,
              max_reactors: int = 1024) -> np.ndarray:
    """The return of :class:`ScheduleController` with each parameter vector of ``X`` (N, P)
    on each seed: (N, S). Every (vector, seed) pair is one reactor of the native vector env
    (``gymnasium.make_vec(env_id, vectorization_mode="vector_entry_point")``, reactor i reset
    with its seed: bit for bit the single env reset with it), at most ``max_reactors`` per
    call, each run for the episode's steps."""
    import gymnasium as gym

    X = np.asarray(X, dtype=np.float64)
    seeds = [int(s) for s in seeds]
    if X.ndim != 2 or X.shape[0] < 1 or not seeds:
        raise ValueError(f"X, seeds: need X (N, P) with N >= 1 and at least one seed, got "
                         f"{X.shape} and {len(seeds)} seeds")
    pairs = [(i, j) for i in range(len(X)) for j in range(len(seeds))]
    out = np.full((len(X), len(seeds)), np.nan)
    # (as few calls as max_reactors allows, of one size: a short last call is padded)
    size = -(-len(pairs) // -(-len(pairs) // max(int(max_reactors), 1)))
    venv = gym.make_vec(env_id, num_envs=size, vectorization_mode="vector_entry_point",
                        **dict(env_kwargs or {}))
    try:
        steps = venv.unwrapped.config.episode_steps
        for start in range(0, len(pairs), size):
            chunk = pairs[start:start + size]
            rows = [i for i, _ in chunk]
            # (a short last chunk is padded with its first pair; the padding is not read)
            pad = chunk + [chunk[0]] * (size - len(chunk))
            c = ScheduleController.batch(venv, X[[i for i, _ in pad]])
            obs, _ = venv.reset(seed=[seeds[j] for _, j in pad])
            total = np.zeros(size)
            for k in range(steps):
                obs, r, term, trunc, _ = venv.step(c(obs))
                total += r
                if np.any(term) or (k < steps - 1 and np.any(trunc)):
                    raise RuntimeError(f"{env_id}: an episode ended before step {steps}")
            out[rows, [j for _, j in chunk]] = total[:len(chunk)]
    finally:
        venv.close()
    return out


#: Parameters found by ``benchmarks/search_controller.py``, per task: ``{"params": {name:
#: value}, "budget": {"env_steps": simulated env steps of the search and its re-scoring,
#: "wall_seconds": its wall time}, "command": the command that found them}``.
SEARCHED: dict[str, dict] = {
    # 2,892,800 env steps of CMA-ES (28,928 episodes, 41 generations of 11) on seeds
    # 3000-3063, the best 5 and CMA's mean re-scored on seeds 3000-3163 (98,400 more);
    # 28 min of wall time
    # (2026-12-04, the 2-core AMD EPYC VM shared with other jobs). docs/tasks.md, "Searched
    # controllers", has its returns on the evaluation seeds.
    "DiscFlow-v0": {
        "params": {
            "setpoint_0": 3.4008929261464953,
            "setpoint_1": 3.2716757214562806,
            "setpoint_2": 3.678019269824317,
            "setpoint_3": 4.283531634595485,
            "setpoint_4": 7.658128473487598,
            "wall_0": 0.9609504303228531,
            "wall_1": 0.9414608291108986,
            "wall_2": 0.0967354489338117,
            "feed_A": 0.9942715609946601,
            "stop_A": 0.9070913389414008,
            "feed_B": 0.9990449593872636,
            "stop_B": 0.9020333492575564,
            "inlet_gain": -0.10781558901620825,
            "band": 1.0,  # (the search ran before the family had a dead band)
        },
        "budget": {"env_steps": 2_991_200, "wall_seconds": 1680},
        "command": ("python benchmarks/search_controller.py --env DiscFlow-v0 "
                    "--budget-steps 2900000 --sigma0 0.05 --tune-seeds 3000 64 --compare"),
    },
    # 1,484,800 env steps of CMA-ES from the family's defaults on seeds 3000-3063,
    # the best 5 and CMA's mean re-scored on seeds 3000-3163: 1,583,200 env steps,
    # 9 min wall, 8 min CPU (2026-12-04, the 2-core AMD EPYC VM, one thread).
    "DiscReactor-v0": {
        "params": {
            "setpoint_0": 1.2960786310199233,
            "setpoint_1": 1.5148291857786393,
            "setpoint_2": 1.7300091347866524,
            "setpoint_3": 1.3380506448625915,
            "setpoint_4": 1.9453303761446745,
            "wall_0": -0.957003857715691,
            "wall_1": -0.8538880268122928,
            "wall_2": -0.8266450206475631,
            "feed_A": 0.9589247851405938,
            "stop_A": 0.9742629608118973,
            "feed_B": 0.7837558844819702,
            "stop_B": 0.8641790882861077,
        },
        "budget": {"env_steps": 1_583_200, "wall_seconds": 540},
        "command": ("python benchmarks/search_controller.py --env DiscReactor-v0 "
                    "--budget-steps 1500000 "
                    "--tune-seeds 3000 64 --compare"),
    },
    # 1,484,800 env steps of CMA-ES from the family's defaults on seeds 3000-3063,
    # the best 5 and CMA's mean re-scored on seeds 3000-3163: 1,583,200 env steps,
    # 9 min wall, 8 min CPU (2026-12-04, the 2-core AMD EPYC VM, one thread).
    "DiscKinetics-v0": {
        "params": {
            "setpoint_0": 1.2812482519451125,
            "setpoint_1": 1.2370707811000736,
            "setpoint_2": 1.9406096067118481,
            "setpoint_3": 1.9532856716806535,
            "setpoint_4": 2.35766414248731,
            "wall_0": -0.8706879832191803,
            "wall_1": -0.6541903948867474,
            "wall_2": -0.7806019185107913,
            "feed_A": 0.9552228599054727,
            "stop_A": 0.8682755406143703,
            "feed_B": 0.9450413027832495,
            "stop_B": 0.9929395850222468,
        },
        "budget": {"env_steps": 1_583_200, "wall_seconds": 540},
        "command": ("python benchmarks/search_controller.py --env DiscKinetics-v0 "
                    "--budget-steps 1500000 "
                    "--tune-seeds 3000 64 --compare"),
    },
    # 1,484,800 env steps of CMA-ES from the band thermostat on seeds 3000-3063,
    # the best 5 and CMA's mean re-scored on seeds 3000-3163: 1,583,200 env steps,
    # 9 min wall, 9 min CPU (2026-12-04, the 2-core AMD EPYC VM, one thread).
    "DiscEconomic-v0": {
        "params": {
            "setpoint_0": 2.339887800837987,
            "setpoint_1": 1.8953084964468634,
            "setpoint_2": 1.7182976159273062,
            "setpoint_3": 1.1954146906242287,
            "setpoint_4": 3.4722585484748656,
            "wall_0": -0.9824250916078937,
            "wall_1": -0.8649258058852812,
            "wall_2": -0.7160083419323668,
            "feed_A": 0.9994886824657672,
            "stop_A": 0.48593731070989366,
            "feed_B": 0.726771128532769,
            "stop_B": 0.5865961812790057,
            "band": 2.3137216932844,
        },
        "budget": {"env_steps": 1_583_200, "wall_seconds": 540},
        "command": ("python benchmarks/search_controller.py --env DiscEconomic-v0 "
                    "--budget-steps 1500000 "
                    "--tune-seeds 3000 64 --compare"),
    },
    # 1,484,800 env steps of CMA-ES from the family's defaults on seeds 3000-3063,
    # the best 5 and CMA's mean re-scored on seeds 3000-3163: 1,583,200 env steps,
    # 11 min wall, 9 min CPU (2026-12-04, the 2-core AMD EPYC VM, one thread).
    "DiscJacket-v0": {
        "params": {
            "setpoint_0": 1.4561503589237237,
            "setpoint_1": 1.0863660426768673,
            "setpoint_2": 1.472356522174832,
            "setpoint_3": 1.7894490648091703,
            "setpoint_4": 1.864600851196697,
            "wall_0": -0.9884534743002755,
            "wall_1": -0.9019767480387595,
            "wall_2": -0.9787273911596293,
            "feed_A": 0.8628770082313321,
            "stop_A": 0.7542655037370193,
            "feed_B": 0.7900759295174381,
            "stop_B": 0.9984303728783593,
            "jacket_gain": 3.5248711372497796,
        },
        "budget": {"env_steps": 1_583_200, "wall_seconds": 660},
        "command": ("python benchmarks/search_controller.py --env DiscJacket-v0 "
                    "--budget-steps 1500000 "
                    "--tune-seeds 3000 64 --compare"),
    },
}


def searched(env) -> ScheduleController:
    """The searched controller of the task ``env`` (an env or a vector env of it, found by
    :func:`task_id` in :data:`SEARCHED`)."""
    env_id = task_id(env)
    if env_id not in SEARCHED:
        raise ValueError(f"env: no searched controller for {env_id!r} (searched: "
                         f"{', '.join(sorted(SEARCHED)) or 'none'})")
    return ScheduleController(env, **SEARCHED[env_id]["params"])
