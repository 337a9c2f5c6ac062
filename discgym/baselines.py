"""Baselines for the reactor tasks: a scheduled heuristic, constant actions, random actions,
the per-task registry the baseline ladder reads, and evaluation with confidence intervals.

Policies here map an observation (D,) or a batch (R, D) to an action (A,) or (R, A);
:func:`evaluate` runs one on a :class:`~discgym.vector.DiscReactorVectorEnv`, one episode per
reactor. They see only what the env shows (observations, its names and defaults), never the
physics; their returns on the default env are in ``docs/env.md``.

>>> from discgym.baselines import evaluate, heuristic_policy
>>> returns = evaluate(heuristic_policy, episodes=2, episode_steps=5)  # doctest: +SKIP

The baseline ladder (``benchmarks/ladder.py``, ``docs/tasks.md``) runs, for every env id of
:data:`TASK_BASELINES`, random actions, the best constant action (searched on
:data:`SEARCH_SEEDS`), the task's hand-written controller, its searched controller
(:mod:`discgym.searched`), the planner and the rollout oracle of :mod:`discgym.oracle` on
the searched controller (:meth:`TaskBaselines.planner`, :meth:`TaskBaselines.oracle`) on
:data:`EVAL_SEEDS` (disjoint from the search seeds), one fresh
``gymnasium.make`` env per seed (:func:`run_episodes`), and summarises the per-seed returns
with bootstrap confidence intervals (:func:`mean_ci`, :func:`iqm_ci`,
:func:`paired_difference`: ``scipy.stats.bootstrap``), and over tasks by
:func:`aggregate_task_means` of :func:`normalised_scores` (:func:`aggregate_iqm` for
learners, over their training runs).
"""

from __future__ import annotations

import copy
import itertools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from .config import DEFAULTS, ReactorConfig
from .kernels.structs import FLOAT
from .values import integer, number_in, real
from .vector import DiscReactorVectorEnv

__all__ = [
    "HeuristicPolicy",
    "heuristic_policy",
    "constant_policy",
    "random_policy",
    "evaluate",
    "best_constant_action",
    "reactor_constant_grid",
    "EVAL_SEEDS",
    "SEARCH_SEEDS",
    "Summary",
    "TaskBaselines",
    "TASK_BASELINES",
    "PLANNER_FUTURES",
    "PLANNER_GATE",
    "planner_candidates",
    "run_episodes",
    "search_constant",
    "mean_ci",
    "iqm_ci",
    "paired_difference",
    "normalised_scores",
    "aggregate_iqm",
    "aggregate_task_means",
    "check_disjoint",
]


class HeuristicPolicy:
    """The scheduled heuristic: a thermostat on the observed temperature that heats the cold
    reactor over the activation barrier to ``t_hot`` and holds it there until the product
    yield reaches ``switch_yield`` (or the fraction ``switch_time`` of the episode is over),
    then holds ``t_cold``, cooling against the reaction heat. It also sets the wall action to
    ``wall`` (-1: the smallest reactor) and the injection actions to ``inject`` (one value
    per feed species, or one for all).

    Works on one observation (D,) or a batch (R, D) (refusing others as the controllers of
    :mod:`discgym.controllers` do); reads the slots by name, so give it the
    ``observation_names`` of the env (default: those of the default env) and the env's
    ``heat_rate`` if it is not the default. At ``heat_rate`` = 1 (which the env accepts) no
    heat action changes kT, and the heat action is 0.
    """

    def __init__(self, observation_names: Sequence[str] | None = None, *, t_hot=1.8,
                 t_cold=1.6, switch_yield=0.2, switch_time=1.0, wall=-1.0, inject=1.0,
                 heat_rate=None):
        if observation_names is None:
            observation_names = _default_config().obs_names
        names = list(observation_names)
        self.names = names
        self.frac = [k for k, nm in enumerate(names) if nm.startswith("fraction_")]
        self.kT = [k for k, nm in enumerate(names) if nm.startswith("kT_")]
        self.i_yield = names.index("yield")
        self.i_time = names.index("time_left")
        self.n_feed = sum(nm.startswith("feed_left_") for nm in names)
        self.t_hot, self.t_cold = float(t_hot), float(t_cold)
        self.switch_yield, self.switch_time = float(switch_yield), float(switch_time)
        self.wall = float(wall)
        self.inject = np.broadcast_to(np.asarray(inject, dtype=FLOAT), (self.n_feed,))
        rate = DEFAULTS["heat_rate"] if heat_rate is None else heat_rate
        if real(rate) is None:
            raise TypeError(f"heat_rate: expected None or a number, got {heat_rate!r}")
        rate = number_in(rate, 1.0, math.inf)
        if rate is None:
            raise ValueError(f"heat_rate: expected None (the default env's) or the env's "
                             f"heat_rate, a finite number >= 1, got {heat_rate!r}")
        self.log_rate = math.log(rate)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        one = np.ndim(obs) == 1
        o = check_observation(obs, self.names, batch=True)
        T = (o[:, self.frac] * o[:, self.kT]).sum(axis=1)
        late = (o[:, self.i_yield] >= self.switch_yield) | \
            (o[:, self.i_time] <= 1.0 - self.switch_time)
        target = np.where(late, self.t_cold, self.t_hot)
        a = np.empty((len(o), 2 + self.n_feed), dtype=np.float32)
        if self.log_rate == 0.0:  # (heat_rate 1: the heating law has no inverse)
            a[:, 0] = 0.0
        else:
            a[:, 0] = np.clip(np.log(target / np.maximum(T, 1e-6)) / self.log_rate, -1.0,
                              1.0)
        a[:, 1] = self.wall
        a[:, 2:] = self.inject
        return a[0] if one else a


def heuristic_policy(obs: np.ndarray) -> np.ndarray:
    """The default :class:`HeuristicPolicy` on observations of the default env."""
    global _HEURISTIC
    if _HEURISTIC is None:
        _HEURISTIC = HeuristicPolicy()
    return _HEURISTIC(obs)


_HEURISTIC = None
_CONFIG = None


def _default_config() -> ReactorConfig:
    global _CONFIG
    if _CONFIG is None:
        _CONFIG = ReactorConfig.from_kwargs()
    return _CONFIG


def constant_policy(action) -> Callable[[np.ndarray], np.ndarray]:
    """A policy that always takes ``action`` (A,) (for a batch: the same row for each)."""
    act = np.asarray(action, dtype=np.float32)

    def policy(obs):
        o = np.asarray(obs)
        return act.copy() if o.ndim == 1 else np.tile(act, (len(o), 1))

    return policy


def random_policy(n_actions: int = 4, seed=None) -> Callable[[np.ndarray], np.ndarray]:
    """Uniform random actions in [-1, 1]^n_actions from its own generator."""
    rng = np.random.default_rng(seed)

    def policy(obs):
        o = np.asarray(obs)
        shape = (n_actions,) if o.ndim == 1 else (len(o), n_actions)
        return rng.uniform(-1.0, 1.0, size=shape).astype(np.float32)

    return policy


def evaluate(policy: Callable[[np.ndarray], np.ndarray], episodes: int = 10, seed: int = 0,
             threads: int | None = None, **env_kwargs) -> np.ndarray:
    """Returns (episodes,) undiscounted returns of ``policy`` (a batch of observations ->
    a batch of actions), one episode per reactor of a vector env, seeds ``seed + k``."""
    venv = DiscReactorVectorEnv(num_envs=episodes, autoreset_mode="Disabled", threads=threads,
                                **env_kwargs)
    obs, _ = venv.reset(seed=seed)
    total = np.zeros(episodes)
    for _ in range(venv.config.episode_steps):
        obs, r, term, trunc, _ = venv.step(policy(obs))
        total += r
        if (term | trunc).all():
            break
    venv.close()
    return total


def best_constant_action(candidates: Sequence[Sequence[float]], episodes: int = 10,
                         seed: int = 0, threads: int | None = None,
                         **env_kwargs) -> tuple[np.ndarray, np.ndarray]:
    """Evaluate each constant action of ``candidates`` (K, A) on the same seeds; returns
    ``(best action (A,), mean returns (K,))``."""
    cand = np.asarray(candidates, dtype=np.float32)
    means = np.array([evaluate(constant_policy(c), episodes, seed, threads, **env_kwargs)
                      .mean() for c in cand])
    return cand[int(np.argmax(means))], means



# --------------------------------------------------------------------------------------------
# the baseline ladder: seeds, per-seed evaluation, confidence intervals, the per-task registry

#: Default evaluation seeds of the ladder (20 episodes).
EVAL_SEEDS: tuple = tuple(range(1000, 1020))
#: Default seeds of the constant-action search: disjoint from :data:`EVAL_SEEDS`, so the
#: selection does not flatter the chosen action.
SEARCH_SEEDS: tuple = tuple(range(0, 10))

PolicyFactory = Callable[[object], Callable[[np.ndarray], np.ndarray]]


def check_disjoint(eval_seeds: Sequence[int], search_seeds: Sequence[int]) -> None:
    """``ValueError`` if the search seeds share a seed with the evaluation seeds."""
    common = sorted(set(int(s) for s in eval_seeds) & set(int(s) for s in search_seeds))
    if common:
        raise ValueError(f"search_seeds: {len(common)} seed(s) also among the evaluation seeds "
                         f"({common[:5]}{' ...' if len(common) > 5 else ''}); a constant action "
                         "chosen on the evaluation seeds would be flattered")


def _seeds(seeds, name: str) -> list:
    out = []
    for s in seeds:
        k = integer(s)
        if k is None or k < 0:
            raise ValueError(f"{name}: need whole numbers >= 0, got {s!r}")
        out.append(k)
    if len(set(out)) != len(out):
        raise ValueError(f"{name}: repeated seeds in {out}")
    if not out:
        raise ValueError(f"{name}: need at least one seed")
    return out


@dataclass(frozen=True)
class RunResult:
    """Per-seed results of :func:`run_episodes`: ``returns`` (E,) undiscounted, ``seconds``
    (E,) wall time of each episode (reset excluded), ``steps`` (E,) and ``stats`` (the
    policy's ``stats`` dict after each episode, if it has one, e.g. the oracle's budget)."""

    seeds: tuple
    returns: np.ndarray
    seconds: np.ndarray
    steps: np.ndarray
    stats: tuple


def run_episodes(env_id: str, factory: PolicyFactory, seeds: Sequence[int] = EVAL_SEEDS,
                 env_kwargs: Mapping | None = None) -> RunResult:
    """One episode per seed, each on a fresh ``gymnasium.make(env_id, **env_kwargs)``:
    ``policy = factory(env)``, then ``env.reset(seed=s)`` (and ``env.action_space.seed(s)``,
    so that a policy sampling the action space is reproducible) and ``policy(obs)`` until the
    episode terminates or is truncated."""
    import gymnasium as gym

    seeds = _seeds(seeds, "seeds")
    rets, secs, steps, stats = [], [], [], []
    for s in seeds:
        env = gym.make(env_id, **dict(env_kwargs or {}))
        try:
            policy = factory(env)
            obs, _ = env.reset(seed=s)
            env.action_space.seed(s)
            total, n, done = 0.0, 0, False
            t0 = time.perf_counter()
            while not done:
                obs, r, term, trunc, _ = env.step(policy(obs))
                total += float(r)
                n += 1
                done = term or trunc
            secs.append(time.perf_counter() - t0)
        finally:
            env.close()
        rets.append(total)
        steps.append(n)
        stats.append(dict(policy.stats) if isinstance(getattr(policy, "stats", None), dict)
                     else None)
    return RunResult(tuple(seeds), np.array(rets), np.array(secs), np.array(steps),
                     tuple(stats))


def search_constant(env_id: str, grid, seeds: Sequence[int] = SEARCH_SEEDS,
                    env_kwargs: Mapping | None = None,
                    avoid: Sequence[int] = EVAL_SEEDS) -> tuple[np.ndarray, np.ndarray]:
    """The best constant action of ``grid`` ((K, A) actions, or ``env -> (K, A)``) by mean
    return over ``seeds``; returns ``(best action (A,), mean returns (K,))``. ``seeds`` must
    not meet ``avoid`` (the evaluation seeds). Each seed is reset once and every candidate
    runs on a ``clone()`` of the reset env (bit for bit what a reset would give, without its
    cost); ties go to the first candidate."""
    import gymnasium as gym

    from .oracle import steps_left

    seeds = _seeds(seeds, "seeds")
    check_disjoint(avoid, seeds)
    totals = None
    for s in seeds:
        env = gym.make(env_id, **dict(env_kwargs or {}))
        try:
            env.reset(seed=s)
            cand = np.asarray(grid(env) if callable(grid) else grid, dtype=np.float32)
            if cand.ndim != 2 or cand.shape[1:] != env.action_space.shape:
                raise ValueError(f"grid: need (K, {env.action_space.shape[0]}) actions, got "
                                 f"shape {cand.shape}")
            limit = steps_left(env)
            u = env.unwrapped
            if totals is None:
                totals = np.zeros(len(cand))
            for k, a in enumerate(cand):
                c = u.clone() if hasattr(u, "clone") else copy.deepcopy(u)
                n, done = 0, False
                while not done and (limit is None or n < limit):
                    _, r, term, trunc, _ = c.step(a)
                    totals[k] += float(r)
                    n += 1
                    done = term or trunc
        finally:
            env.close()
    means = totals / len(seeds)
    return cand[int(np.argmax(means))].copy(), means


# ---------------------------------------------------------------- confidence intervals


@dataclass(frozen=True)
class Summary:
    """A statistic of per-seed values and its bootstrap confidence interval."""

    value: float
    low: float
    high: float
    method: str  # the scipy.stats.bootstrap method that gave the interval

    def separated(self) -> bool:
        """The interval excludes 0 (for a difference: the two policies are separated)."""
        return self.low > 0.0 or self.high < 0.0

    def text(self, digits: int = 3) -> str:
        v, lo, hi = (round(x, digits) + 0.0 for x in (self.value, self.low, self.high))
        return f"{v:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"  # (+ 0.0: no "-0.000")

    def as_dict(self) -> dict:
        return {"value": self.value, "low": self.low, "high": self.high, "method": self.method}


def _bootstrap(x, statistic, confidence: float, n_resamples: int, random_state: int,
               method: str, name: str) -> Summary:
    """``scipy.stats.bootstrap`` of one sample. A sample of identical values has a point as
    its bootstrap distribution: BCa is undefined there (scipy returns NaN), so such a sample
    (and any other where BCa fails) gets the percentile interval, a point for a constant."""
    from scipy import stats

    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1 or len(x) < 2:
        raise ValueError(f"{name}: need a 1-d array of at least 2 values, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: non-finite values in {x}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence: need a number in (0, 1), got {confidence!r}")
    value = float(statistic(x, axis=-1))
    methods = [method] if np.ptp(x) > 0 else []
    if "percentile" not in methods:
        methods.append("percentile")
    for m in methods:
        res = stats.bootstrap((x,), statistic, n_resamples=n_resamples, vectorized=True,
                              confidence_level=confidence, method=m,
                              rng=np.random.default_rng(random_state))
        lo, hi = (float(v) for v in res.confidence_interval)
        if np.isfinite(lo) and np.isfinite(hi):
            return Summary(value, lo, hi, m)
    raise ValueError(f"{name}: no finite bootstrap interval for {x}")


def _mean(x, axis=-1):
    return np.mean(x, axis=axis)


def _iqm(x, axis=-1):
    from scipy.stats import trim_mean

    return trim_mean(x, 0.25, axis=axis)


def mean_ci(returns, confidence: float = 0.95, n_resamples: int = 9999,
            random_state: int = 0, method: str = "BCa") -> Summary:
    """The mean of ``returns`` (E,) with its bootstrap confidence interval
    (``scipy.stats.bootstrap``, BCa by default; fixed ``random_state``: reproducible)."""
    return _bootstrap(returns, _mean, confidence, n_resamples, random_state, method, "returns")


def iqm_ci(returns, confidence: float = 0.95, n_resamples: int = 9999,
           random_state: int = 0, method: str = "BCa") -> Summary:
    """The interquartile mean (``scipy.stats.trim_mean(x, 0.25)``: the mean of the middle
    half) of ``returns`` with its bootstrap confidence interval."""
    return _bootstrap(returns, _iqm, confidence, n_resamples, random_state, method, "returns")


def paired_difference(a, b, confidence: float = 0.95, n_resamples: int = 9999,
                      random_state: int = 0, method: str = "BCa") -> Summary:
    """Mean of ``a - b`` over the same seeds (a paired bootstrap: seeds resampled together)
    with its confidence interval; :meth:`Summary.separated` when it excludes 0."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"a, b: need returns on the same seeds, got shapes {a.shape} and "
                         f"{b.shape}")
    return _bootstrap(a - b, _mean, confidence, n_resamples, random_state, method, "a - b")


def normalised_scores(returns, low_ref, high_ref) -> np.ndarray:
    """Per-seed returns on a task mapped linearly so that ``low_ref``'s mean is 0 and
    ``high_ref``'s 1 (the ladder: random 0, the searched controller 1)."""
    r = np.asarray(returns, dtype=np.float64)
    lo, hi = float(np.mean(low_ref)), float(np.mean(high_ref))
    if not hi > lo:
        raise ValueError(f"high_ref: its mean ({hi:.6g}) must be above low_ref's ({lo:.6g})")
    return (r - lo) / (hi - lo)


def aggregate_iqm(scores_by_task, confidence: float = 0.95, n_resamples: int = 9999,
                  random_state: int = 0) -> Summary:
    """The interquartile mean of normalised scores pooled over tasks, with the *stratified*
    bootstrap interval of Agarwal et al. (2021), as ``rliable`` computes it: each task's
    scores (one per seed or run) resampled within that task, the IQM taken over all of them
    (``scipy.stats.bootstrap`` of several samples, which it resamples independently;
    percentile intervals, as rliable's). ``rliable`` itself is not used: version 1.2 runs
    neither on arch 7 with pandas 3 nor on arch 8 (it passes ``random_state=None``)."""
    from scipy import stats

    xs = [np.asarray(x, dtype=np.float64).ravel() for x in scores_by_task]
    if not xs or any(x.size == 0 for x in xs):
        raise ValueError("scores_by_task: need at least one task, each with scores")

    def iqm(*samples, axis=-1):
        return stats.trim_mean(np.concatenate(samples, axis=axis), 0.25, axis=axis)

    value = float(iqm(*xs))
    res = stats.bootstrap(xs, iqm, confidence_level=confidence, n_resamples=n_resamples,
                          method="percentile", random_state=random_state, vectorized=True)
    ci = res.confidence_interval
    return Summary(value, float(ci.low), float(ci.high), "stratified percentile")


def aggregate_task_means(scores_by_task, confidence: float = 0.95, n_resamples: int = 9999,
                         random_state: int = 0) -> Summary:
    """The interquartile mean over tasks of a policy without training seeds (a controller, a
    planner): its mean normalised score on each task is its one "run" there, and the IQM is
    taken over those task means (so the reference that defines the scale scores exactly 1),
    as :func:`aggregate_iqm` takes it over runs. The interval is that of resampling each
    task's seeds within the task (percentile). A task with one seed gives no interval
    (``low`` and ``high`` NaN)."""
    from scipy import stats

    xs = [np.asarray(x, dtype=np.float64).ravel() for x in scores_by_task]
    if not xs or any(x.size == 0 for x in xs):
        raise ValueError("scores_by_task: need at least one task, each with scores")

    def iqm_of_means(*samples, axis=-1):
        means = np.stack([np.mean(x, axis=axis) for x in samples], axis=-1)
        return stats.trim_mean(means, 0.25, axis=-1)

    value = float(iqm_of_means(*xs))
    if min(x.size for x in xs) < 2:
        return Summary(value, float("nan"), float("nan"), "none (a task with one seed)")
    ci = stats.bootstrap(xs, iqm_of_means, confidence_level=confidence,
                         n_resamples=n_resamples, method="percentile",
                         random_state=random_state, vectorized=True).confidence_interval
    return Summary(value, float(ci.low), float(ci.high), "percentile over seeds within tasks")


# ---------------------------------------------------------------- the per-task registry


def reactor_constant_grid(n_actions: int) -> np.ndarray:
    """Candidate constant actions of the reactor tasks: heat x wall x each feed on or off
    (120 for the default env). A constant heat action is a constant *rate* of heating, so
    the heat levels are dense near 0, where the useful ones are (a slow ramp through the
    activation window)."""
    heat = [-0.1, -0.02, 0.0, 0.005, 0.01, 0.02, 0.03, 0.05, 0.1, 0.3]
    wall = [-1.0, 0.0, 1.0]
    feeds = list(itertools.product([0.0, 1.0], repeat=n_actions - 2))
    rows = [[h, w, *f] for h, w, f in itertools.product(heat, wall, feeds)]
    return np.array(rows, dtype=np.float32)


def reactor_grid(env) -> np.ndarray:
    """:func:`reactor_constant_grid` for ``env``'s action size."""
    return reactor_constant_grid(env.action_space.shape[0])


def reactor_heuristic(env) -> HeuristicPolicy:
    """The scheduled heuristic (:class:`HeuristicPolicy`, default settings) for ``env``:
    a thermostat on the observed temperature, hot (kT 1.8) until the product yield reaches
    0.2, then 1.6; smallest reactor; full injection. Reads the env's observation names and
    heat rate."""
    u = env.unwrapped
    return HeuristicPolicy(u.observation_names, heat_rate=u.config.heat_rate)


def reactor_oracle_candidates(base: np.ndarray, env) -> np.ndarray:
    """The oracle's first actions on a reactor task (11 for the default env): the base
    action; its heat action moved by -0.6, -0.3, -0.1, +0.1, +0.3, +0.6; its wall action
    moved by +1 and +2 (from the heuristic's -1: hold the size, expand); each feed's
    injection moved by -1 (from the heuristic's 1: none this step). Clipped to [-1, 1],
    duplicates dropped."""
    from .oracle import component_offsets

    n_feed = env.action_space.shape[0] - 2
    offsets = [(-0.6, -0.3, -0.1, 0.1, 0.3, 0.6), (1.0, 2.0)] + [(-1.0,)] * n_feed
    return component_offsets(offsets)(base, env)


def random_factory(env):
    """Uniform random actions: ``env.action_space.sample()`` (seeded by
    :func:`run_episodes` with the episode's seed)."""
    return lambda obs: env.action_space.sample()


def constant_factory(action) -> PolicyFactory:
    """A factory of :func:`constant_policy` ``(action)``."""
    action = np.asarray(action, dtype=np.float32)
    return lambda env: constant_policy(action)


def planner_candidates(base: np.ndarray, env) -> np.ndarray:
    """The planner's first actions on every task, over every control: the base action; its
    heat (or jacket) action moved by -0.6, -0.3, -0.1, +0.1, +0.3, +0.6; its wall action set
    to -1, 0 and +1; each feed's action set to 0 (none this step) and 1 (full). Clipped to
    the action space, duplicates of an earlier row dropped (at most ``10 + 2 x feeds``)."""
    from .oracle import clipped_unique

    base = np.asarray(base, dtype=np.float32)
    rows = [base]
    for d in (-0.6, -0.3, -0.1, 0.1, 0.3, 0.6):
        a = base.copy()
        a[0] += d
        rows.append(a)
    for j, values in [(1, (-1.0, 0.0, 1.0))] + [(j, (0.0, 1.0))
                                                  for j in range(2, base.shape[0])]:
        for v in values:
            a = base.copy()
            a[j] = v
            rows.append(a)
    return clipped_unique(rows, env.action_space)


#: The planner's futures per candidate (:meth:`TaskBaselines.planner`).
PLANNER_FUTURES = 4
#: The planner's gate: a candidate replaces the searched controller's action only when its
#: advantage on the shared futures is this many standard errors above 0 (fixed before any
#: evaluation, not tuned).
PLANNER_GATE = 2.0


@dataclass(frozen=True)
class TaskBaselines:
    """The baselines of one task (an env id) for the ladder of ``benchmarks/ladder.py``.

    - ``controller``: the hand-written controller, ``env -> policy`` (obs -> action); its
      rule is its docstring (shown in docs/tasks.md).
    - ``constant_grid``: candidate constant actions, ``env -> (K, A)`` (or an array),
      searched on :data:`SEARCH_SEEDS`.
    - ``oracle_candidates``: ``(base_action, env) -> (K, A)`` first actions of the oracle
      and the planner (:class:`discgym.oracle.RolloutOracle`), row 0 the base action
      (default :func:`planner_candidates`, over every control).
    - ``oracle_replan_every``, ``oracle_horizon``: the oracle's defaults (horizon None: to
      the episode's end, which guarantees oracle >= its base policy on every seed).
    - ``env_kwargs``: keyword arguments of ``gymnasium.make`` for the ladder (usually none).
    - ``controller_name``: the controller's name in the ladder's table.
    """

    controller: PolicyFactory
    constant_grid: Callable | np.ndarray
    oracle_candidates: Callable = planner_candidates
    oracle_replan_every: int = 5
    oracle_horizon: int | None = None
    env_kwargs: Mapping = field(default_factory=dict)
    controller_name: str = "hand-written"

    def oracle(self, replan_every: int | None = None, horizon: int | None = None,
               base: PolicyFactory | None = None,
               candidates: Callable | None = None) -> PolicyFactory:
        """A factory of the rollout oracle, the ladder's ceiling (``replan_every`` and
        ``horizon``: the task's defaults when None), on ``base`` with first actions
        ``candidates`` (defaults: the searched controller, :meth:`searched`, and
        ``oracle_candidates``)."""
        from .oracle import RolloutOracle

        k = self.oracle_replan_every if replan_every is None else replan_every
        h = self.oracle_horizon if horizon is None else horizon
        base = self.searched if base is None else base
        cands = self.oracle_candidates if candidates is None else candidates

        def factory(env):
            return RolloutOracle(env, base(env), cands, horizon=h, replan_every=k)

        return factory

    @staticmethod
    def searched(env):
        """The task's searched controller (:func:`discgym.searched.searched`), a policy
        factory."""
        from .searched import searched

        return searched(env)

    def planner(self, samples: int = PLANNER_FUTURES, noise: int = 12345,
                replan_every: int | None = None,
                gate: float | None = PLANNER_GATE) -> PolicyFactory:
        """A factory of the planner *without foresight of the random draws*: rollout MPC
        (:class:`~discgym.oracle.RolloutOracle` with ``noise``) on the searched controller,
        its first actions over every control (``oracle_candidates``), each scored by
        its mean return over ``samples`` fresh random futures that every candidate meets
        (common random numbers) and taken only if its advantage over the searched
        controller's action stands ``gate`` standard errors above 0 (``RolloutOracle``'s
        ``gate``), re-planned every ``replan_every`` steps (the task's default when None)
        with the searched controller acting in between. It knows the
        model and the exact microstate (every disc's position and velocity), far more than
        an observation shows, but not the injections and reverse reactions to come: the
        fair upper reference of a policy that sees the state but not the noise. The
        oracle's margin over it is the value of foreseeing the random draws."""
        from .oracle import RolloutOracle, noise_seeds

        noise_seeds(noise)  # (refused here, not at the first episode)
        k = self.oracle_replan_every if replan_every is None else replan_every

        def factory(env):
            return RolloutOracle(env, self.searched(env), self.oracle_candidates,
                                 horizon=self.oracle_horizon, replan_every=k, noise=noise,
                                 samples=samples, gate=gate)

        return factory


#: The baselines of every task, keyed by env id (extend it when you register a task).
TASK_BASELINES: dict[str, TaskBaselines] = {
    "DiscReactor-v0": TaskBaselines(
        controller=reactor_heuristic,
        constant_grid=reactor_grid,
        controller_name="scheduled heuristic",
    ),
}


# --------------------------------------------------------------------------------------------
# the other tasks of the suite (discgym/tasks.py; their controllers: discgym/controllers.py)


def jacket_grid(env) -> np.ndarray:
    """Constant actions of ``DiscJacket-v0``: the jacket's setpoint (an absolute temperature,
    log-uniform over the range) x wall x each feed on or off."""
    heat = [-1.0, -0.6, -0.3, -0.2, -0.1, 0.0, 0.1, 0.2, 0.3, 0.6]
    wall = [-1.0, 0.0, 1.0]
    feeds = list(itertools.product([0.0, 1.0], repeat=env.action_space.shape[0] - 2))
    return np.array([[h, w, *f] for h, w, f in itertools.product(heat, wall, feeds)],
                    dtype=np.float32)


from .controllers import (  # noqa: E402  (the suite's controllers; no import circle)
    AdaptiveThermostat,
    BandThermostat,
    JacketThermostat,
    check_observation,
    flow_thermostat,
)

TASK_BASELINES.update({
    "DiscKinetics-v0": TaskBaselines(
        controller=AdaptiveThermostat, constant_grid=reactor_grid,
        controller_name="adaptive thermostat"),
    "DiscEconomic-v0": TaskBaselines(
        controller=BandThermostat, constant_grid=reactor_grid,
        controller_name="band thermostat"),
    "DiscJacket-v0": TaskBaselines(
        controller=JacketThermostat, constant_grid=jacket_grid,
        controller_name="jacket thermostat"),
    "DiscFlow-v0": TaskBaselines(
        controller=flow_thermostat, constant_grid=reactor_grid,
        controller_name="flow thermostat"),
})
