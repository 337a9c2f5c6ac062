"""An oracle for the reactor tasks: a rollout-based model-predictive controller on copies of
the true simulation.

At a decision step, :class:`RolloutOracle` copies the environment (``env.unwrapped.clone()``,
or ``copy.deepcopy``: the simulation's state *and its random generators*, the env's
``np_random`` and episode bookkeeping), and for each candidate first action (the base policy's
own action first, then perturbations of it) steps the copy with that action and then with the
base policy (a copy of it too, if it keeps state) to the end of the episode (or ``horizon``
steps), summing the rewards. It executes the first action of the best rollout; ties go to the
earliest candidate, so to the base policy's own action. With ``replan_every=k`` it executes
the best rollout's next ``k - 1`` actions without planning again.

Because a copy continues bit for bit as the environment will (``tests/test_env_copy.py``), a
rollout's return is exactly what executing that action sequence returns. So with the base
action among the candidates and rollouts to the episode's end, the oracle's return is at
least the base policy's on every seed (Bertsekas' rollout, a policy-improvement step): at
each replan the best rollout is at least as good as following the base from there, which is
the plan the previous replan committed to. It sees everything (the random future included),
so it is an upper reference for a learned policy, not a policy one could deploy.

>>> import gymnasium as gym, discgym
>>> from discgym.baselines import HeuristicPolicy
>>> env = gym.make("DiscReactor-v0", episode_steps=10, max_episode_steps=10)
>>> oracle = RolloutOracle(env, HeuristicPolicy(env.unwrapped.observation_names),
...                        candidates=component_offsets([(-0.3, 0.3)]))  # doctest: +SKIP
"""

from __future__ import annotations

import copy
import time
from collections import deque
from collections.abc import Callable, Sequence

import gymnasium as gym
import numpy as np

from .values import integer

__all__ = ["RolloutOracle", "ShootingOracle", "clipped_unique", "component_offsets",
           "noise_seeds", "steps_left"]

Policy = Callable[[np.ndarray], np.ndarray]
#: ``candidates(base_action, env) -> (K, A)`` first actions to try; row 0 must be the base
#: action itself (the oracle checks).
CandidateFn = Callable[[np.ndarray, gym.Env], np.ndarray]


def component_offsets(offsets: Sequence[Sequence[float]]) -> CandidateFn:
    """Candidates: the base action, then the base action with *one* component moved by each
    of its offsets (``offsets[i]`` for component ``i``; components beyond ``len(offsets)``
    are not varied), clipped to the action space; duplicates (e.g. two offsets clipped to
    the same bound) dropped, the first kept. ``1 + sum(len(o) for o in offsets)`` at most."""
    offs = [tuple(float(x) for x in o) for o in offsets]
    for i, o in enumerate(offs):
        if not all(np.isfinite(o)):
            raise ValueError(f"offsets: component {i} has a non-finite offset {o}")

    def candidates(base: np.ndarray, env: gym.Env) -> np.ndarray:
        base = np.asarray(base, dtype=np.float32)
        if len(offs) > base.shape[-1]:
            raise ValueError(f"offsets: {len(offs)} components given, the action has "
                             f"{base.shape[-1]}")
        rows = [base]
        for i, o in enumerate(offs):
            for d in o:
                a = base.copy()
                a[i] = a[i] + d
                rows.append(a)
        return clipped_unique(rows, env.action_space)

    candidates.offsets = offs
    return candidates


def clipped_unique(rows, space) -> np.ndarray:
    """Candidate actions ``rows`` clipped to ``space`` (float32), each duplicate of an
    earlier row dropped (two offsets clipped to the same bound, say), as a (K, A) array."""
    out, seen = [], set()
    for r in rows:
        r = np.clip(r, space.low, space.high).astype(np.float32)
        if r.tobytes() not in seen:
            seen.add(r.tobytes())
            out.append(r)
    return np.stack(out)


def steps_left(env: gym.Env) -> int | None:
    """The steps a ``TimeLimit`` wrapper of ``env`` still allows in this episode (the
    smallest, if several), or None if there is none (the env's own truncation then ends the
    episode)."""
    left = None
    e = env
    while isinstance(e, gym.Wrapper):
        if isinstance(e, gym.wrappers.TimeLimit):
            k = e._max_episode_steps - e._elapsed_steps
            left = k if left is None else min(left, k)
        e = e.env
    return left


def _copy_env(u: gym.Env, reseed=None) -> gym.Env:
    if reseed is not None:
        if not hasattr(u, "clone"):
            raise TypeError("noise: needs an env whose clone() takes reseed (DiscReactorEnv)")
        c = u.clone(reseed=reseed)
    else:
        c = u.clone() if hasattr(u, "clone") else copy.deepcopy(u)
    # a rollout must not draw: no window, no frames
    c.render_mode = None
    return c


def noise_seeds(noise) -> np.random.SeedSequence | None:
    """The planner's ``noise`` argument as numpy's seed sequence: None stays None; a whole
    number >= 0 (or a sequence of them) is its entropy. Anything else is a ``ValueError``
    naming ``noise``."""
    if noise is None:
        return None
    try:
        if isinstance(noise, bool):
            raise TypeError("a bool")
        return np.random.SeedSequence(noise)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"noise: need None or a whole number >= 0 (the seed of the "
                         f"planner's futures), got {noise!r}") from exc


class RolloutOracle:
    """Rollout model-predictive control on copies of ``env`` (see the module's docstring).

    Args:
        env: the environment the oracle acts in (as made by ``gymnasium.make``: its
            ``TimeLimit`` is respected); the oracle copies ``env.unwrapped`` and plans on
            the unwrapped env's rewards.
        base: the base policy, observation -> action; deep-copied into every rollout, so
            a policy with internal state (a generator, a schedule) rolls out as it would
            act. The oracle keeps its own copy and calls it at every step.
        candidates: ``(base_action, env) -> (K, A)`` first actions, row 0 the base
            action (default: the base action alone, which reproduces the base policy).
        horizon: rollout length in steps (None: to the end of the episode; only then is
            the oracle guaranteed to return at least the base policy's return).
        replan_every: plan at every ``replan_every``-th step and execute the best
            rollout's actions in between.
        noise: None (default): every rollout runs on an exact copy and meets the env's
            own random future (clairvoyant). A seed: each rollout's copy gets fresh random
            generators (``clone(reseed=...)``), drawn from this seed, so the oracle knows
            the model and the exact state (every disc; the collisions themselves are
            deterministic) but not the random draws to come. Every candidate meets the same
            ``samples`` futures (common random numbers) and is scored by their mean; between
            re-plans the base policy acts on the real observations (a planned action after
            the first was the base policy's answer to an imagined future). The guarantee
            "never below the base policy" holds only without noise.
        samples: futures per candidate (only with ``noise``).
        gate: None (default), or (with ``samples`` >= 2) a number z: a candidate other than
            the base action is taken only if its mean advantage over the base action on the
            shared futures exceeds z standard errors of that advantage (their spread over
            the futures). Without it, the best of many noisy means is the one whose futures
            happened to favour it (the winner's curse), and the planner can fall below its
            base policy.

    ``stats`` holds the planning budget of the episode so far: decisions, replans,
    candidates rolled out, simulated env steps, copies, seconds spent planning, the
    steps where the base policy's action differed from the executed plan (0 unless copies
    are not exact or the base policy is random without its state in the copy), and the
    candidates the ``gate`` turned down.
    """

    def __init__(self, env: gym.Env, base: Policy, candidates: CandidateFn | None = None,
                 horizon: int | None = None, replan_every: int = 1, noise=None,
                 samples: int = 1, gate: float | None = None):
        if not callable(base):
            raise TypeError(f"base: expected a policy (observation -> action), got {base!r}")
        if candidates is not None and not callable(candidates):
            raise TypeError(f"candidates: expected a function (base_action, env) -> (K, A) "
                            f"actions, got {candidates!r}")
        if horizon is not None and (integer(horizon) is None or horizon < 1):
            raise ValueError(f"horizon: need None or a whole number >= 1, got {horizon!r}")
        if integer(replan_every) is None or replan_every < 1:
            raise ValueError(f"replan_every: need a whole number >= 1, got {replan_every!r}")
        if integer(samples) is None or samples < 1:
            raise ValueError(f"samples: need a whole number >= 1, got {samples!r}")
        if samples > 1 and noise is None:
            raise ValueError("samples: more than one rollout per candidate needs noise (an "
                             "exact copy repeats the same future)")
        if gate is not None and (isinstance(gate, bool) or not isinstance(
                gate, (int, float, np.integer, np.floating)) or not 0 <= gate < np.inf):
            raise ValueError(f"gate: need None or a finite number >= 0, got {gate!r}")
        if gate is not None and samples < 2:
            raise ValueError("gate: needs samples >= 2 (a standard error over the futures)")
        self.env = env
        self.base = base
        self.samples = int(samples)
        self.gate = None if gate is None else float(gate)
        self._noise = noise_seeds(noise)
        self.candidates = candidates or (lambda a, env: np.asarray(a, np.float32)[None])
        self.horizon = None if horizon is None else int(horizon)
        self.replan_every = int(replan_every)
        self._plan: deque = deque()
        self._follow = 0
        self.stats = dict(decisions=0, replans=0, rollouts=0, simulated_steps=0, copies=0,
                          planning_seconds=0.0, plan_mismatches=0, gated=0)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        st = self.stats
        st["decisions"] += 1
        a_base = np.asarray(self.base(obs), dtype=np.float32)
        if self._follow:  # (with noise: the base policy until the next re-plan)
            self._follow -= 1
            return a_base
        if self._plan:
            a = self._plan.popleft()
            if a.tobytes() != a_base.tobytes():
                st["plan_mismatches"] += 1
            return a.copy()
        t0 = time.perf_counter()
        u = self.env.unwrapped
        cands = np.asarray(self.candidates(a_base, self.env), dtype=np.float32)
        if cands.ndim != 2 or cands.shape[1:] != a_base.shape or \
                cands[0].tobytes() != a_base.tobytes():
            raise ValueError(f"candidates: must return (K, {a_base.shape[0]}) actions with the "
                             f"base action first, got shape {cands.shape}")
        left = steps_left(self.env)
        limit = self.horizon
        if left is not None:
            limit = left if limit is None else min(limit, left)
        best, best_plan = -np.inf, None
        best_k = 0
        # common random numbers: every candidate meets the same `samples` futures
        futures = [None] if self._noise is None else self._noise.spawn(self.samples)
        base_returns = None
        for k, first in enumerate(cands):
            total, plan, returns = 0.0, None, []
            for fut in futures:
                t, p = self._rollout(u, first, limit, fut)
                total += t / len(futures)
                plan = p if plan is None else plan
                returns.append(t)
            if k == 0:
                base_returns = np.array(returns)
            elif self.gate is not None:
                # the candidate's advantage over the base action on the shared futures must
                # stand `gate` standard errors above 0, else it is noise
                d = np.array(returns) - base_returns
                if not d.mean() - self.gate * d.std(ddof=1) / np.sqrt(d.size) > 0:
                    st["gated"] += 1
                    continue
            if total > best:  # strictly: a tie keeps the earlier candidate (row 0: the base)
                best, best_plan, best_k = total, plan, k
        if best_plan is None:  # (every rollout's return was NaN: follow the base policy)
            best_plan, best_k = [cands[0]], 0
        if self._noise is None:
            self._plan = deque(best_plan[1:])
        else:
            self._follow = self.replan_every - 1
        st["replans"] += 1
        st["planning_seconds"] += time.perf_counter() - t0
        return cands[best_k].copy()

    def _rollout(self, u: gym.Env, first: np.ndarray, limit: int | None,
                 future=None) -> tuple:
        """(return, the first ``replan_every`` actions) of ``first`` then the base policy on
        a copy of ``u`` (its random future drawn from ``future`` if given), up to the
        episode's end or ``limit`` steps."""
        st = self.stats
        env = _copy_env(u, future)
        pol = copy.deepcopy(self.base)
        st["copies"] += 1
        st["rollouts"] += 1
        keep = self.replan_every
        plan = [first]
        obs, r, term, trunc, _ = env.step(first)
        total, n = float(r), 1
        while not (term or trunc) and (limit is None or n < limit):
            a = np.asarray(pol(obs), dtype=np.float32)
            if len(plan) < keep:
                plan.append(a)
            obs, r, term, trunc, _ = env.step(a)
            total += float(r)
            n += 1
        st["simulated_steps"] += n
        return total, plan


class ShootingOracle:
    """A sampling planner (the cross-entropy method over piecewise-constant perturbations of
    an incumbent action sequence), the second oracle option; :class:`RolloutOracle` is the
    default one.

    At a re-plan the incumbent is the rest of the previous best sequence (at the first: the
    base policy's own actions to the end of the episode, found by a rollout on a copy). Each
    of ``iterations`` rounds samples ``samples`` sequences around the current mean: the
    mean plus Gaussian noise of scale ``sigma`` (one per action component) held constant over
    segments of ``segment`` steps, clipped to the action space; each is replayed open loop
    on a copy of the env to the episode's end (replaying a sequence on an exact copy is
    exact, so the incumbent's value is what following it will return). The mean moves to
    the ``elite`` best; the best sequence seen (the incumbent on ties) is kept, and its first
    ``replan_every`` actions executed. Since the incumbent is always among the sequences,
    the return never falls below the base policy's.

    ``generator``: a ``numpy.random.Generator`` (or seed) of the sampling, independent of the
    env's.
    """

    def __init__(self, env: gym.Env, base: Policy, samples: int = 8, iterations: int = 2,
                 elite: int = 2, segment: int = 10, sigma=0.3, replan_every: int = 10,
                 generator=None):
        if not callable(base):
            raise TypeError(f"base: expected a policy (observation -> action), got {base!r}")
        for name, v, lo in (("samples", samples, 1), ("iterations", iterations, 1),
                            ("elite", elite, 1), ("segment", segment, 1),
                            ("replan_every", replan_every, 1)):
            if integer(v) is None or v < lo:
                raise ValueError(f"{name}: need a whole number >= {lo}, got {v!r}")
        if elite > samples:
            raise ValueError(f"elite: need at most samples ({samples}), got {elite}")
        sigma = np.broadcast_to(np.asarray(sigma, dtype=np.float64),
                                env.action_space.shape).copy()
        if not np.all(np.isfinite(sigma)) or np.any(sigma < 0):
            raise ValueError(f"sigma: need finite scales >= 0, got {sigma}")
        self.env, self.base = env, base
        self.samples, self.iterations, self.elite = int(samples), int(iterations), int(elite)
        self.segment, self.sigma, self.replan_every = int(segment), sigma, int(replan_every)
        self.rng = np.random.default_rng(generator)
        self._best: np.ndarray | None = None  # (T, A) the rest of the best sequence
        self._todo = 0  # actions of it still to execute before the next re-plan
        self.stats = dict(decisions=0, replans=0, rollouts=0, simulated_steps=0, copies=0,
                          planning_seconds=0.0)

    def _replay(self, u: gym.Env, seq: np.ndarray) -> float:
        env = _copy_env(u)
        self.stats["copies"] += 1
        self.stats["rollouts"] += 1
        total, n = 0.0, 0
        for a in seq:
            _, r, term, trunc, _ = env.step(a)
            total += float(r)
            n += 1
            if term or trunc:
                break
        self.stats["simulated_steps"] += n
        return total

    def _base_sequence(self, u: gym.Env, obs, limit: int | None) -> np.ndarray:
        env = _copy_env(u)
        pol = copy.deepcopy(self.base)
        self.stats["copies"] += 1
        seq, done = [], False
        while not done and (limit is None or len(seq) < limit):
            a = np.asarray(pol(obs), dtype=np.float32)
            seq.append(a)
            obs, _, term, trunc, _ = env.step(a)
            done = term or trunc
        self.stats["simulated_steps"] += len(seq)
        return np.stack(seq)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        st = self.stats
        st["decisions"] += 1
        if self._best is not None and self._todo > 0 and len(self._best):
            a, self._best = self._best[0], self._best[1:]
            self._todo -= 1
            return a.copy()
        t0 = time.perf_counter()
        u = self.env.unwrapped
        limit = steps_left(self.env)
        if self._best is None or not len(self._best):
            self._best = self._base_sequence(u, obs, limit)
        inc = self._best if limit is None else self._best[:limit]
        best_v = self._replay(u, inc)
        best = inc
        mean = inc.astype(np.float64)
        space = self.env.action_space
        T, A = mean.shape
        n_seg = -(-T // self.segment)
        for _ in range(self.iterations):
            noise = self.rng.normal(0.0, 1.0, (self.samples, n_seg, A)) * self.sigma
            noise = np.repeat(noise, self.segment, axis=1)[:, :T]
            cands = np.clip(mean[None] + noise, space.low, space.high).astype(np.float32)
            vals = np.array([self._replay(u, c) for c in cands])
            k = int(np.argmax(vals))
            if vals[k] > best_v:  # strictly: the incumbent keeps ties
                best_v, best = vals[k], cands[k]
            elite = cands[np.argsort(-vals, kind="stable")[:self.elite]]
            mean = elite.astype(np.float64).mean(axis=0)
        st["replans"] += 1
        st["planning_seconds"] += time.perf_counter() - t0
        self._best = best[1:]
        self._todo = self.replan_every - 1
        return best[0].copy()
