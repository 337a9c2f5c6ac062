"""The rollout oracle (discgym.oracle) and the ladder's evaluation helpers (discgym.baselines):
the oracle never does worse than its base policy (rollouts to the episode's end on exact
copies), and the confidence-interval helpers on cases with known answers."""

import copy

import gymnasium as gym
import numpy as np
import pytest

import discgym  # noqa: F401  (registers the env)
from discgym.baselines import (
    EVAL_SEEDS,
    SEARCH_SEEDS,
    TASK_BASELINES,
    aggregate_iqm,
    aggregate_task_means,
    check_disjoint,
    constant_factory,
    iqm_ci,
    mean_ci,
    normalised_scores,
    paired_difference,
    planner_candidates,
    random_factory,
    reactor_heuristic,
    reactor_oracle_candidates,
    run_episodes,
    search_constant,
)
from discgym.oracle import RolloutOracle, ShootingOracle, component_offsets, steps_left

ENV = "DiscReactor-v0"
TINY = dict(n_discs=80, episode_steps=10, max_episode_steps=10)
SEEDS = [0, 1, 2, 3]


class NoisyHeuristic:
    """A base policy with internal state: the heuristic plus noise from its own generator
    (the oracle must copy it into each rollout for its rollouts to be exact)."""

    def __init__(self, env, seed):
        self.h = reactor_heuristic(env)
        self.rng = np.random.default_rng(seed)

    def __call__(self, obs):
        a = self.h(obs)
        a[0] = np.clip(a[0] + self.rng.normal(0, 0.3), -1, 1)
        return a.astype(np.float32)


def oracle_factory(base_factory, **kw):
    return lambda env: RolloutOracle(env, base_factory(env), reactor_oracle_candidates, **kw)


@pytest.mark.parametrize("replan_every", [1, 3])
def test_the_oracle_is_never_worse_than_its_base_policy(replan_every):
    base = run_episodes(ENV, reactor_heuristic, SEEDS, TINY)
    orc = run_episodes(ENV, oracle_factory(reactor_heuristic, replan_every=replan_every),
                       SEEDS, TINY)
    assert np.all(orc.returns >= base.returns), (orc.returns, base.returns)
    assert np.any(orc.returns > base.returns)  # and it does improve on some seed
    for st in orc.stats:
        assert st["plan_mismatches"] == 0
        assert st["decisions"] == 10 and st["replans"] == -(-10 // replan_every)
        assert st["rollouts"] >= st["replans"] and st["copies"] == st["rollouts"]


def test_the_oracle_improves_a_base_policy_with_internal_state():
    base = run_episodes(ENV, lambda env: NoisyHeuristic(env, 5), SEEDS[:3], TINY)
    orc = run_episodes(ENV, oracle_factory(lambda env: NoisyHeuristic(env, 5), replan_every=2),
                       SEEDS[:3], TINY)
    assert np.all(orc.returns >= base.returns)
    assert all(st["plan_mismatches"] == 0 for st in orc.stats)


def test_the_base_action_alone_reproduces_the_base_policy_bit_for_bit():
    base = run_episodes(ENV, reactor_heuristic, SEEDS[:2], TINY)
    orc = run_episodes(ENV, lambda env: RolloutOracle(env, reactor_heuristic(env)),
                       SEEDS[:2], TINY)
    assert orc.returns.tobytes() == base.returns.tobytes()
    # one rollout per decision, each to the end: 10 + 9 + ... + 1 simulated steps
    assert orc.stats[0]["simulated_steps"] == 55


def test_the_time_limit_and_the_horizon_bound_the_rollouts():
    # the env's own episode is 100 steps; the TimeLimit of gymnasium.make ends it at 6
    kw = dict(n_discs=80, max_episode_steps=6)
    env = gym.make(ENV, **kw)
    env.reset(seed=0)
    assert steps_left(env) == 6
    env.step(env.action_space.sample())
    assert steps_left(env) == 5
    assert steps_left(env.unwrapped) is None
    orc = run_episodes(ENV, lambda env: RolloutOracle(env, reactor_heuristic(env)), [0], kw)
    assert orc.stats[0]["simulated_steps"] == 6 + 5 + 4 + 3 + 2 + 1
    orc = run_episodes(ENV, lambda env: RolloutOracle(env, reactor_heuristic(env), horizon=2),
                       [0], kw)
    assert orc.stats[0]["simulated_steps"] == 2 * 5 + 1


def test_candidates_and_arguments_are_checked():
    env = gym.make(ENV, **TINY)
    obs, _ = env.reset(seed=0)
    h = reactor_heuristic(env)
    a = h(obs)
    cands = reactor_oracle_candidates(a, env)
    assert cands[0].tobytes() == a.tobytes()
    assert len({c.tobytes() for c in cands}) == len(cands) <= 11
    assert np.all(np.abs(cands) <= 1.0)
    wrong = RolloutOracle(env, h, lambda base, env: np.zeros((2, 4), np.float32) + 0.5)
    with pytest.raises(ValueError, match="candidates"):
        wrong(obs)
    with pytest.raises(ValueError, match="replan_every"):
        RolloutOracle(env, h, replan_every=0)
    with pytest.raises(ValueError, match="horizon"):
        RolloutOracle(env, h, horizon=0)
    with pytest.raises(TypeError, match="base"):
        RolloutOracle(env, None)
    with pytest.raises(ValueError, match="offsets"):
        component_offsets([(0.1,)] * 5)(a, env)


def test_a_reseeded_clone_continues_the_state_into_another_future():
    env = gym.make(ENV, **TINY)
    env.reset(seed=4)
    u = env.unwrapped
    a = np.array([0.3, 0.0, 1.0, 1.0], np.float32)

    def run(c):
        return np.stack([c.step(a)[0] for _ in range(4)])

    exact, same1, same2, other = (run(u.clone()), run(u.clone(reseed=7)),
                                  run(u.clone(reseed=7)), run(u.clone(reseed=8)))
    np.testing.assert_array_equal(same1, same2)  # a seed fixes the future
    assert not np.array_equal(exact, same1) and not np.array_equal(same1, other)
    assert u.clone(reseed=7).simulation.get_state()["positions"].tobytes() == \
        u.simulation.get_state()["positions"].tobytes()  # same state, only the future differs
    np.testing.assert_array_equal(run(u.clone()), exact)  # the env itself was not touched


def test_the_oracle_without_foresight_of_the_random_draws():
    """noise=seed: rollouts meet other futures than the env's, the same ones for every
    candidate; deterministic given the seed; the arguments are checked."""
    def fac(env):
        return RolloutOracle(env, reactor_heuristic(env), reactor_oracle_candidates,
                             replan_every=3, noise=11, samples=2)

    r1 = run_episodes(ENV, fac, SEEDS[:2], TINY)
    r2 = run_episodes(ENV, fac, SEEDS[:2], TINY)
    assert r1.returns.tobytes() == r2.returns.tobytes()
    # every candidate rolled out once per future: two copies per candidate and replan
    assert r1.stats[0]["rollouts"] == r1.stats[0]["copies"] > 2 * r1.stats[0]["replans"]
    env = gym.make(ENV, **TINY)
    env.reset(seed=0)
    h = reactor_heuristic(env)
    with pytest.raises(ValueError, match="samples"):
        RolloutOracle(env, h, samples=2)  # several samples of an exact copy are one
    with pytest.raises(ValueError, match="samples"):
        RolloutOracle(env, h, noise=1, samples=0)
    # one candidate, one future: a rollout per decision on a reseeded copy, executed as the
    # base policy would act (only the base action is a candidate)
    base = run_episodes(ENV, reactor_heuristic, SEEDS[:2], TINY)
    one = run_episodes(ENV, lambda env: RolloutOracle(env, reactor_heuristic(env), noise=3),
                       SEEDS[:2], TINY)
    assert one.returns.tobytes() == base.returns.tobytes()


def test_without_foresight_the_base_policy_acts_between_replans():
    """With noise, an imagined future's plan is not replayed: between two re-plans the
    executed action is the base policy's on the real observation, and a re-plan comes every
    ``replan_every`` decisions."""
    env = gym.make(ENV, **TINY)
    obs, _ = env.reset(seed=5)
    h = reactor_heuristic(env)
    o = RolloutOracle(env, reactor_heuristic(env), reactor_oracle_candidates, replan_every=3,
                      noise=2, samples=2)
    done, t = False, 0
    while not done:
        replans = o.stats["replans"]
        a = o(obs)
        if t % 3:
            assert o.stats["replans"] == replans
            np.testing.assert_array_equal(a, h(obs))
        else:
            assert o.stats["replans"] == replans + 1
        obs, _, term, trunc, _ = env.step(a)
        done, t = term or trunc, t + 1
    assert o.stats["replans"] == -(-TINY["episode_steps"] // 3)


def test_the_gate_takes_a_candidate_only_clear_of_the_noise():
    """gate=z: a candidate replaces the base action only when its mean advantage on the
    shared futures is z standard errors above 0 (an advantage with no spread always is);
    among those, the best mean. Rollout returns are set by hand: base (1.0, 1.2), A (1.5,
    1.3): advantage 0.3, standard error 0.2; B (1.05, 1.25): advantage 0.05, no spread."""
    env = gym.make(ENV, **TINY)
    obs, _ = env.reset(seed=0)
    h = reactor_heuristic(env)
    a0 = np.asarray(h(obs), np.float32)
    cands = np.stack([a0, a0 + np.float32(0.1), a0 - np.float32(0.1)])
    table = {cands[0].tobytes(): (1.0, 1.2), cands[1].tobytes(): (1.5, 1.3),
             cands[2].tobytes(): (1.05, 1.25)}

    def chosen(gate):
        o = RolloutOracle(env, h, lambda a, e: cands, noise=1, samples=2, gate=gate)
        calls = {}

        def rollout(u, first, limit, future=None):
            i = calls[first.tobytes()] = calls.get(first.tobytes(), -1) + 1
            return table[first.tobytes()][i], [first]

        o._rollout = rollout
        a = o(obs)
        return next(k for k in range(3) if cands[k].tobytes() == a.tobytes()), o.stats["gated"]

    assert chosen(None) == (1, 0) and chosen(0.0) == (1, 0) and chosen(1.0) == (1, 0)
    assert chosen(2.0) == (2, 1)  # A turned down (0.3 - 2 x 0.2 < 0); B has no spread
    assert chosen(1e9) == (2, 1)
    table[cands[2].tobytes()] = (1.0, 1.2)  # B no better than the base: the base kept
    assert chosen(2.0) == (0, 2)
    for bad in (-1.0, float("nan"), float("inf"), True, "2"):
        with pytest.raises(ValueError, match="gate"):
            RolloutOracle(env, h, noise=1, samples=2, gate=bad)
    with pytest.raises(ValueError, match="gate"):
        RolloutOracle(env, h, noise=1, samples=1, gate=1.0)
    # on real rollouts an unreachable gate turns candidates down, and gate 0 takes what the
    # ungated planner takes
    def planner(gate):
        return lambda env: RolloutOracle(env, reactor_heuristic(env), reactor_oracle_candidates,
                                         replan_every=3, noise=4, samples=2, gate=gate)

    free, zero, shut = (run_episodes(ENV, planner(g), SEEDS[:2], TINY) for g in (None, 0.0, 1e9))
    assert zero.returns.tobytes() == free.returns.tobytes()
    assert sum(st["gated"] for st in shut.stats) > sum(st["gated"] for st in zero.stats)


@pytest.mark.parametrize("env_id", list(TASK_BASELINES))
def test_the_planners_candidates_cover_every_control(env_id):
    """Row 0 the base action; every other row moves one component: the heat (or jacket)
    action by up to 0.6, the wall to -1, 0 or +1, a feed to 0 or 1; within the space, no
    duplicates; the planner plans on the searched controller with them."""
    env = gym.make(env_id)
    obs, _ = env.reset(seed=0)
    tb = TASK_BASELINES[env_id]
    base = np.asarray(tb.searched(env)(obs), np.float32)
    for b in (base, np.zeros_like(base), env.action_space.low, env.action_space.high):
        c = planner_candidates(b, env)
        b = np.clip(b, env.action_space.low, env.action_space.high)
        assert c.dtype == np.float32 and c[0].tobytes() == b.tobytes()
        assert len({r.tobytes() for r in c}) == len(c) <= 10 + 2 * (b.shape[0] - 2)
        assert np.all(c >= env.action_space.low) and np.all(c <= env.action_space.high)
        moved = set()
        for r in c[1:]:
            (j,) = np.flatnonzero(r != b)
            moved.add(int(j))
            if j == 0:
                assert abs(r[0] - b[0]) <= 0.6 + 1e-6
            else:
                assert r[j] in ((-1.0, 0.0, 1.0) if j == 1 else (0.0, 1.0))
        if b.tobytes() == np.zeros_like(b).tobytes():
            assert moved == set(range(b.shape[0]))  # (from 0 every control has a move)
    o = tb.planner(samples=2)(env)
    assert o.samples == 2 and o.candidates is planner_candidates
    assert type(o.base).__name__ == "ScheduleController"


def test_the_shooting_oracle_is_never_worse_than_its_base_policy():
    """The CEM planner keeps the incumbent sequence (first: the base policy's own actions)
    among its samples, so it too never falls below the base policy."""
    base = run_episodes(ENV, reactor_heuristic, SEEDS[:3], TINY)
    orc = run_episodes(ENV, lambda env: ShootingOracle(
        env, reactor_heuristic(env), samples=4, iterations=2, segment=3, replan_every=4,
        generator=0), SEEDS[:3], TINY)
    assert np.all(orc.returns >= base.returns), (orc.returns, base.returns)
    st = orc.stats[0]
    assert st["decisions"] == 10 and st["replans"] == 3
    assert st["rollouts"] == 3 * (1 + 2 * 4)
    env = gym.make(ENV, **TINY)
    h = reactor_heuristic(env)
    with pytest.raises(ValueError, match="elite"):
        ShootingOracle(env, h, samples=2, elite=3)
    with pytest.raises(ValueError, match="sigma"):
        ShootingOracle(env, h, sigma=-1.0)
    with pytest.raises(ValueError, match="segment"):
        ShootingOracle(env, h, segment=0)


def test_the_oracle_leaves_the_real_env_alone():
    """Planning only touches copies: the real env's state is the same before and after."""
    env = gym.make(ENV, **TINY)
    obs, _ = env.reset(seed=2)
    before = copy.deepcopy(env.unwrapped.simulation.get_state())
    RolloutOracle(env, reactor_heuristic(env), reactor_oracle_candidates)(obs)
    after = env.unwrapped.simulation.get_state()
    for k in before:
        if isinstance(before[k], np.ndarray):
            assert before[k].tobytes() == after[k].tobytes(), k
        elif k != "bounds":
            assert before[k] == after[k], k


# ---------------------------------------------------------------- evaluation and CIs


def test_run_episodes_and_the_constant_search():
    r1 = run_episodes(ENV, random_factory, [5, 6], TINY)
    r2 = run_episodes(ENV, random_factory, [5, 6], TINY)
    assert r1.returns.tobytes() == r2.returns.tobytes()  # seeded action space
    assert list(r1.steps) == [10, 10] and r1.seeds == (5, 6)
    grid = np.array([[0.0, -1, 1, 1], [0.05, -1, 1, 1], [-1, 1, 0, 0]], np.float32)
    best, means = search_constant(ENV, grid, seeds=[0, 1], env_kwargs=TINY)
    assert means.shape == (3,) and best.tobytes() == grid[np.argmax(means)].tobytes()
    # the search runs clones of the reset env: the same returns as fresh episodes
    direct = run_episodes(ENV, constant_factory(grid[1]), [0, 1], TINY)
    assert means[1] == pytest.approx(direct.returns.mean(), abs=1e-12)
    with pytest.raises(ValueError, match="search_seeds"):
        search_constant(ENV, grid, seeds=[0, 1], env_kwargs=TINY, avoid=[1, 7])
    with pytest.raises(ValueError, match="seeds"):
        run_episodes(ENV, random_factory, [1, 1], TINY)


def test_default_seeds_are_disjoint():
    check_disjoint(EVAL_SEEDS, SEARCH_SEEDS)
    assert len(EVAL_SEEDS) >= 20
    with pytest.raises(ValueError, match="search_seeds"):
        check_disjoint(EVAL_SEEDS, [3, 1005])


def test_constant_returns_give_a_zero_width_interval():
    x = np.full(20, 0.75)
    for s in (mean_ci(x), iqm_ci(x)):
        assert s.value == s.low == s.high == 0.75 and s.method == "percentile"
        assert s.separated()


def test_a_policy_against_itself_differs_by_exactly_zero():
    x = np.random.default_rng(0).normal(1.0, 0.1, 20)
    d = paired_difference(x, x)
    assert d.value == d.low == d.high == 0.0 and not d.separated()


def test_the_intervals_on_known_cases():
    x = np.random.default_rng(1).normal(2.0, 1.0, 400)
    s = mean_ci(x)
    half = 1.96 * x.std(ddof=1) / np.sqrt(len(x))  # the normal-theory interval
    assert s.method == "BCa" and s.low < s.value < s.high
    assert s.high - s.low == pytest.approx(2 * half, rel=0.1)
    assert s.value == pytest.approx(x.mean())
    assert mean_ci(x) == s  # reproducible: a fixed random_state
    # a shift moves the interval by the shift; a paired shift is separated
    t = mean_ci(x + 3.0)
    assert t.low == pytest.approx(s.low + 3.0) and t.high == pytest.approx(s.high + 3.0)
    d = paired_difference(x + 0.5 + 0.01 * np.sin(np.arange(400)), x)
    assert d.separated() and d.low > 0.49 and d.high < 0.51
    # the IQM: the mean of the middle half
    y = np.array([0, 1, 2, 3, 4, 5, 6, 7, 100, -100], float)
    assert iqm_ci(y).value == pytest.approx(np.mean([1, 2, 3, 4, 5, 6]))
    with pytest.raises(ValueError, match="returns"):
        mean_ci([1.0])
    with pytest.raises(ValueError, match="a, b"):
        paired_difference([1.0, 2.0], [1.0, 2.0, 3.0])


def test_the_registry_has_the_default_task():
    tb = TASK_BASELINES["DiscReactor-v0"]
    env = gym.make(ENV, **TINY)
    obs, _ = env.reset(seed=0)
    assert tb.constant_grid(env).shape == (120, 4)
    assert tb.controller(env)(obs).shape == (4,)
    assert tb.controller.__doc__ and tb.oracle_horizon is None
    assert isinstance(tb.oracle()(env), RolloutOracle)


def test_the_aggregate_iqm_is_a_stratified_bootstrap():
    """aggregate_iqm: the IQM of every task's scores pooled, its interval that of resampling
    each task's scores within the task (checked against a hand-rolled stratified bootstrap),
    narrower than resampling the pool (which mixes the tasks); normalised scores put the two
    references at 0 and 1."""
    from scipy.stats import trim_mean

    rng = np.random.default_rng(3)
    tasks = [rng.normal(0.0, 0.1, 15), rng.normal(1.0, 0.1, 25), rng.normal(2.0, 0.3, 10)]
    agg = aggregate_iqm(tasks)
    pool = np.concatenate(tasks)
    assert agg.value == pytest.approx(trim_mean(pool, 0.25))
    boot = np.array([trim_mean(np.concatenate([rng.choice(t, t.size) for t in tasks]), 0.25)
                     for _ in range(4000)])
    lo, hi = np.percentile(boot, [2.5, 97.5])
    assert agg.low == pytest.approx(lo, abs=0.02) and agg.high == pytest.approx(hi, abs=0.02)
    mixed = iqm_ci(pool, method="percentile")
    assert agg.high - agg.low < mixed.high - mixed.low
    assert aggregate_iqm([np.ones(4), np.ones(7)]).as_dict() == {
        "value": 1.0, "low": 1.0, "high": 1.0, "method": "stratified percentile"}
    np.testing.assert_allclose(normalised_scores([1.0, 3.0, 5.0], [1.0, 1.0], [3.0]),
                               [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="high_ref"):
        normalised_scores([1.0], [2.0], [1.0])
    with pytest.raises(ValueError, match="scores_by_task"):
        aggregate_iqm([np.ones(3), []])


def test_a_controller_aggregates_as_the_iqm_of_its_task_means():
    """aggregate_task_means: the IQM over the tasks of each task's mean score (the
    reference that sets the scale: 1 exactly, whatever its seeds' spread), its interval that
    of resampling each task's seeds within the task (a hand-rolled check); no interval from
    a task of one seed."""
    from scipy.stats import trim_mean

    rng = np.random.default_rng(4)
    tasks = [rng.normal(m, 0.2, n) for m, n in ((0.5, 20), (0.9, 30), (1.2, 25), (2.0, 20))]
    agg = aggregate_task_means(tasks)
    assert agg.value == pytest.approx(trim_mean([t.mean() for t in tasks], 0.25))
    boot = np.array([trim_mean([rng.choice(t, t.size).mean() for t in tasks], 0.25)
                     for _ in range(4000)])
    lo, hi = np.percentile(boot, [2.5, 97.5])
    assert agg.low == pytest.approx(lo, abs=0.02) and agg.high == pytest.approx(hi, abs=0.02)
    ref = [1.0 + t - t.mean() for t in tasks]  # (each task's mean exactly 1, seeds spread)
    assert aggregate_task_means(ref).value == pytest.approx(1.0, abs=1e-12)
    one = aggregate_task_means([np.ones(1), np.ones(3)])
    assert one.value == 1.0 and np.isnan(one.low) and np.isnan(one.high)
    with pytest.raises(ValueError, match="scores_by_task"):
        aggregate_task_means([np.ones(3), []])


def test_noise_is_a_seed_or_none_and_anything_else_is_refused_naming_it():
    env = gym.make(ENV, **TINY)
    env.reset(seed=0)
    h = reactor_heuristic(env)
    for bad in (-1, 1.5, True, "x", float("nan"), [-2]):
        with pytest.raises(ValueError, match="^noise: need None or a whole number >= 0"):
            RolloutOracle(env, h, noise=bad)
        # the planner's factory refuses it when made, not at its first episode
        with pytest.raises(ValueError, match="^noise: "):
            TASK_BASELINES[ENV].planner(noise=bad)
    for good in (None, 0, 7, np.int64(3), [1, 2]):
        RolloutOracle(env, h, noise=good)
