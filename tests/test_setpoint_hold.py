"""The agents' setpoint interface (discgym.controllers.SetpointActions) and its two users: the
SB3 wrapper that trains through it (discgym.sb3.SetpointHold) and the one-env policy that
agents/evaluate.py evaluates through it; they must apply the same law."""

import json
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")  # (the agents extra)

from discgym.baselines import run_episodes  # noqa: E402
from discgym.controllers import SetpointActions, Slots  # noqa: E402
from discgym.sb3 import DiscReactorSB3VecEnv, SetpointHold  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def env():
    e = gym.make("DiscReactor-v0", episode_steps=8)
    yield e
    e.close()


def _decide(obs):
    """A fixed, deterministic agent: some function of the observation in [-1, 1]."""
    o = np.asarray(obs, dtype=np.float64)
    w = np.cos(np.arange(o.shape[-1] * 4)).reshape(o.shape[-1], 4)
    return np.tanh(o @ w).astype(np.float32)


def test_setpoint_scale_is_log_spaced_over_the_range(env):
    sa = SetpointActions(env, kT_low=0.8, kT_high=3.2)
    np.testing.assert_allclose(sa.setpoint([-1.0, 0.0, 1.0, 5.0, -5.0]),
                               [0.8, 1.6, 3.2, 3.2, 0.8])


def test_heat_is_the_controllers_law_and_the_rest_passes_through(env):
    obs, _ = env.reset(seed=1)
    sa = SetpointActions(env)
    a = np.array([0.0, 0.3, -0.5, 1.0], dtype=np.float32)
    out = sa.env_actions(a, obs)
    assert out.shape == (4,) and out.dtype == np.float32
    assert out[0] == np.float32(Slots(env).heat_toward(obs, 1.6))  # kT 0.36-0.84 -> heat
    assert 0 < out[0] <= 1
    np.testing.assert_array_equal(out[1:], a[1:])
    batch = sa.env_actions(np.stack([a, a]), np.stack([obs, obs]))
    np.testing.assert_array_equal(batch, np.stack([out, out]))
    np.testing.assert_array_equal(a, np.float32([0.0, 0.3, -0.5, 1.0]))  # input untouched


@pytest.mark.parametrize("kw, match", [
    (dict(hold=0), "hold"), (dict(hold=2.0), "hold"), (dict(hold=True), "hold"),
    (dict(kT_low=2.0, kT_high=1.0), "kT_low"), (dict(kT_low=0.0), "kT_low"),
    (dict(kT_high=float("inf")), "kT_low"),
    (dict(average=1.0), "average"), (dict(average=0.0), "average"),
    (dict(average=True), "average"), (dict(average="0.8"), "average"),
])
def test_bad_arguments_name_what_is_wrong(env, kw, match):
    with pytest.raises(ValueError, match=match):
        SetpointActions(env, **kw)


def test_batch_size_mismatch_is_refused(env):
    obs, _ = env.reset(seed=1)
    with pytest.raises(ValueError, match="2 actions for 3 observations"):
        SetpointActions(env).env_actions(np.zeros((2, 4)), np.stack([obs] * 3))


@pytest.mark.parametrize("average", [None, 0.75])
def test_one_agent_step_is_hold_env_steps_of_the_same_law(average):
    """The wrapper against the same reactors stepped by hand, env step by env step (and,
    with ``average``, the running mean of the observations computed by hand)."""
    kw = dict(num_envs=3, episode_steps=8, threads=1)
    w = SetpointHold(DiscReactorSB3VecEnv(**kw), hold=4, average=average)
    ref = DiscReactorSB3VecEnv(**kw)
    w.seed(7)
    ref.seed(7)
    obs_w, obs_r = w.reset(), ref.reset()
    mean = obs_r.astype(np.float64)
    width = obs_r.shape[1]
    assert w.observation_space.shape == ((2 if average else 1) * width,)
    assert w.observation_space.contains(obs_w[0])
    law = SetpointActions(ref.get_attr("unwrapped", [0])[0], hold=4)
    rng = np.random.default_rng(0)
    for k in range(2):  # two agent steps: the 8-step episode
        a = rng.uniform(-1, 1, (3, 4)).astype(np.float32)
        obs_w, r_w, done_w, info_w = w.step(a)
        total = np.zeros(3, dtype=np.float32)
        for _ in range(4):
            obs_r, r, done_r, info_r = ref.step(law.env_actions(a, obs_r))
            last = info_r[0]["terminal_observation"] if done_r.all() else obs_r
            if average:
                mean = average * mean + (1 - average) * np.asarray(
                    [i["terminal_observation"] for i in info_r] if done_r.all() else obs_r,
                    dtype=np.float64)
            total += r
        np.testing.assert_array_equal(obs_w[:, :width], obs_r)
        np.testing.assert_array_equal(r_w, total)
        np.testing.assert_array_equal(done_w, done_r)
        assert done_w.all() == (k == 1)
        if average and k == 0:
            np.testing.assert_array_equal(obs_w[:, width:], mean.astype(np.float32))
    np.testing.assert_array_equal(info_w[0]["terminal_observation"][:width], last)
    if average:
        # the episode's last observation with its mean; the next episode's starts afresh
        np.testing.assert_array_equal(info_w[0]["terminal_observation"][width:],
                                      mean[0].astype(np.float32))
        np.testing.assert_array_equal(obs_w[:, width:], obs_r)
    else:
        assert info_w[0]["terminal_observation"].shape == (width,)


def test_hold_must_divide_the_episode():
    with pytest.raises(ValueError, match="hold: 3 does not divide the episode's 8"):
        SetpointHold(DiscReactorSB3VecEnv(num_envs=2, episode_steps=8, threads=1), hold=3)


def test_wrong_batch_shape_is_refused():
    w = SetpointHold(DiscReactorSB3VecEnv(num_envs=2, episode_steps=8, threads=1), hold=4)
    w.reset()
    with pytest.raises(ValueError, match=r"expected shape \(2, 4\), got \(4,\)"):
        w.step_async(np.zeros(4, dtype=np.float32))


@pytest.mark.parametrize("average", [None, 0.75])
def test_evaluation_policy_plays_the_training_wrappers_episodes(average):
    """What evaluate.py runs on one env is what the wrapper trained on: same returns."""
    venv = SetpointHold(DiscReactorSB3VecEnv(num_envs=2, episode_steps=8, threads=1), hold=4,
                        average=average)
    venv.seed(11)
    obs, total = venv.reset(), np.zeros(2)
    for _ in range(2):
        obs, r, done, _ = venv.step(_decide(obs))
        total += r
    assert done.all()
    calls = []

    def factory(env):
        def decide(o):
            calls.append(1)
            return _decide(o)
        return SetpointHold.episode_policy(env, decide, hold=4, average=average)

    res = run_episodes("DiscReactor-v0", factory, [11, 12], {"episode_steps": 8})
    np.testing.assert_allclose(res.returns, total, rtol=1e-5, atol=1e-6)
    assert len(calls) == 4  # two decisions per 8-step episode


@pytest.mark.parametrize("average", [None, 0.8])
def test_train_and_evaluate_through_the_wrapper(tmp_path, average):
    """A tiny run with RL Zoo's vec_env_wrapper key; evaluate.py applies the interface (and,
    with ``average``, normalises the wider observation with the run's statistics)."""
    sys.path.insert(0, str(ROOT / "agents"))
    import evaluate
    import train_ppo

    entry = {"n_envs": 2, "n_timesteps": 64, "policy": "MlpPolicy", "n_steps": 16,
             "batch_size": 32, "n_epochs": 1, "gamma": 0.98,
             "normalize": "{'norm_obs': True, 'norm_reward': False}",
             "policy_kwargs": "dict(net_arch=[16, 16])",
             "vec_env_wrapper": [{"discgym.sb3.SetpointHold": {"hold": 4, "average": average}}]}
    (tmp_path / "ppo.yml").write_text(yaml.safe_dump({"DiscReactor-v0": entry}))
    out = train_ppo.train(train_ppo.Args(hyperparams=str(tmp_path), out=str(tmp_path / "run"),
                                         episode_steps=20, threads=1, eval_freq=32,
                                         progress_bar=False))
    summary = json.loads((out / "train_summary.json").read_text())
    assert summary["timesteps"] == 64 and summary["env_steps"] == 256
    # eval_freq counts env steps: 32 // (2 reactors x 4) = a validation every 4 decisions
    assert len(np.load(out / "evaluations.npz")["timesteps"]) == 8
    # the validation episodes ran through the wrapper too; VecMonitor, under it, counts
    # their length in env steps
    ev = np.load(out / "evaluations.npz")
    assert (ev["ep_lengths"] == 20).all()
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    env = gym.make("DiscReactor-v0", episode_steps=20)
    policy = evaluate.agent_factory(out, "final")(env)
    vn = VecNormalize.load(str(out / "vecnormalize.pkl"), SetpointHold(
        DummyVecEnv([lambda: gym.make("DiscReactor-v0")]), hold=4, average=average))
    assert vn.obs_rms.mean.shape == ((2 if average else 1) * env.observation_space.shape[0],)
    model = PPO.load(out / "model.zip")
    obs, _ = env.reset(seed=0)
    sa = SetpointActions(env, average=average)
    seen = sa.agent_obs(obs, sa.update_mean(None, obs) if average else None)
    decision, _ = model.predict(vn.normalize_obs(seen[None]), deterministic=True)
    a0 = policy(obs)
    np.testing.assert_array_equal(a0, sa.env_actions(decision[0], obs))
    obs2, *_ = env.step(a0)
    a1 = policy(obs2)  # still the first block: the same decision, the heat law re-applied
    np.testing.assert_array_equal(a1, sa.env_actions(decision[0], obs2))


def test_a_wrapper_without_an_episode_policy_cannot_be_evaluated(tmp_path):
    sys.path.insert(0, str(ROOT / "agents"))
    import evaluate

    (tmp_path / "args.json").write_text(json.dumps({"env_id": "DiscReactor-v0", "algo": "ppo"}))
    (tmp_path / "hyperparams.json").write_text(json.dumps(
        {"vec_env_wrapper": ["stable_baselines3.common.vec_env.VecFrameStack"]}))
    with pytest.raises(ValueError, match="VecFrameStack, which has no episode_policy"):
        evaluate.agent_factory(tmp_path, "final")


@pytest.mark.parametrize("folder, env_id, wrapper", [
    ("hyperparams", "DiscKinetics-v0", {"hold": 4, "average": 0.8}),  # the flagship until 12-03
    ("hyperparams", "DiscReactor-v0", {"hold": 4}),
    ("hyperparams/residual", "DiscKinetics-v0", {
        "hold": 4, "average": 0.8, "base": "discgym.controllers.AdaptiveThermostat",
        "span": 1.5, "correct": "setpoint"}),
    ("hyperparams/fixed_feed", "DiscKinetics-v0", {
        "hold": 4, "average": 0.8, "base": "discgym.controllers.Thermostat", "span": 2.0,
        "correct": "setpoint"}),
    ("hyperparams", "DiscFlow-v0", {"hold": 1, "kT_low": 1.5, "kT_high": 6.0, "average": 0.8}),
    ("hyperparams/residual", "DiscFlow-v0", {  # the README's main run
        "hold": 4, "average": 0.8, "base": "discgym.controllers.flow_thermostat", "span": 1.3,
        "correct": "setpoint,wall"}),
])
def test_the_setpoint_entries_train_through_the_wrapper(folder, env_id, wrapper):
    """hyperparams/ppo.yml's setpoint entries (and the residual one) build PPO through
    SetpointHold, and validate every 50,000 env steps (781 calls of 16 x 4 env steps at hold
    4)."""
    sys.path.insert(0, str(ROOT / "agents"))
    import train_ppo

    args = train_ppo.Args(env_id=env_id, threads=1, hyperparams=str(ROOT / folder))
    hp = train_ppo.load_hyperparams(args)
    assert hp["vec_env_wrapper"] == [{"discgym.sb3.SetpointHold": wrapper}]
    wrappers = hp.pop("vec_env_wrapper")
    venv = train_ppo.make_vec_env(args, 2, hp.pop("normalize"), hp["gamma"], wrappers=wrappers)
    hold = wrapper["hold"]
    assert train_ppo.env_steps_per_step(venv) == hold
    cb = train_ppo._callbacks(args, Path("unused"), 16, False, hp["gamma"], wrappers, hold)
    assert cb.eval_freq == 50_000 // (16 * hold)
    for key in ("n_envs", "n_timesteps", "policy"):
        hp.pop(key)
    train_ppo.algo_class("ppo")("MlpPolicy", venv, device="cpu", **hp)
    venv.close()
    cb.eval_env.close()


def test_the_table_and_curve_count_env_steps_for_a_held_run(tmp_path):
    """A run that decides every 4 env steps is reported in decisions and env steps, and its
    learning curve is drawn against env steps, like the other runs'."""
    sys.path.insert(0, str(ROOT / "agents"))
    import evaluate

    ci = {"value": 0.9, "low": 0.8, "high": 1.0}
    run = tmp_path / "run"
    run.mkdir()
    (run / "args.json").write_text(json.dumps({"env_id": "DiscReactor-v0", "algo": "ppo"}))
    summary = {"timesteps": 1000, "env_steps": 4000, "wall_seconds": 12.0}
    (run / "train_summary.json").write_text(json.dumps(summary))
    np.savez(run / "evaluations.npz", timesteps=np.array([500, 1000]),
             results=np.array([[0.5, 0.6], [0.7, 0.8]]))
    base = {k: {"label": k, "mean": ci, "iqm": ci}
            for k in ("random", "best constant", "hand-written")}
    res = {"env_id": "DiscReactor-v0", "eval_seeds": [1000, 1001], "policies": {
        **base, "agent": {"label": "ppo", "mean": ci, "iqm": ci, "minus_hand_written": ci,
                          "train": summary, "run": str(run)}}}
    assert "1,000 decisions = 4,000 env steps, 12 s" in evaluate.table(res)
    import matplotlib.pyplot as plt

    plotted = []
    real = plt.Axes.plot
    plt.Axes.plot = lambda self, x, *a, **k: plotted.append(np.asarray(x)) or real(
        self, x, *a, **k)
    try:
        evaluate.plot_curves(res, tmp_path / "curve.png")
    finally:
        plt.Axes.plot = real
    np.testing.assert_array_equal(plotted[0], [2000, 4000])


def test_kinetics_room_probe_prints_the_room_and_the_policys_reading(tmp_path, capsys):
    """benchmarks/kinetics_room.py: the informed thermostat's kT follows s exactly, and a
    trained run's row appears beside it (a tiny run, short episodes)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    sys.path.insert(0, str(ROOT / "agents"))
    import kinetics_room
    import train_ppo

    entry = {"n_envs": 2, "n_timesteps": 32, "policy": "MlpPolicy", "n_steps": 16,
             "batch_size": 32, "n_epochs": 1, "gamma": 0.98,
             "normalize": "{'norm_obs': True, 'norm_reward': False}",
             "policy_kwargs": "dict(net_arch=[8, 8])",
             "vec_env_wrapper": [{"discgym.sb3.SetpointHold": {"hold": 4, "average": 0.8}}]}
    (tmp_path / "ppo.yml").write_text(yaml.safe_dump({"DiscKinetics-v0": entry}))
    out = train_ppo.train(train_ppo.Args(env_id="DiscKinetics-v0", hyperparams=str(tmp_path),
                                         out=str(tmp_path / "run"), episode_steps=48,
                                         threads=1, eval_freq=0, progress_bar=False))
    kinetics_room.main(["--seeds", "4", "--episode-steps", "48", "--exponents", "1",
                        "--run", str(out)])
    lines = capsys.readouterr().out.splitlines()
    rows = {ln.split(" | ")[0].lstrip("| "): ln.split(" | ") for ln in lines if ln.startswith("| ")}
    assert set(rows) >= {"adaptive thermostat (the task's controller)",
                         "informed thermostat, setpoints 1.8 s^1, 1.6 s^1", f"policy of {out}"}
    # the informed thermostat's early kT is 1.8 s (its hot phase, reached by step 10)
    assert float(rows["informed thermostat, setpoints 1.8 s^1, 1.6 s^1"][3]) > 0.9


def test_kinetics_room_search_refines_its_best_settings_on_more_seeds(capsys):
    """--search over a given grid, --refine re-scores the best K on N more tuning seeds; the
    winner becomes the table's tuned row; --tuned takes 4 or 5 values."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import kinetics_room

    kinetics_room.main(["--seeds", "2", "--episode-steps", "24", "--exponents", "1",
                        "--search", "--search-seeds", "500", "502", "--x-targets", "0.08", "0.2",
                        "--bands", "1.2", "--steps", "1.03", "--t-starts", "1.4",
                        "--memories", "0.8", "--refine", "2", "2"])
    out = capsys.readouterr().out
    assert out.count("  refined (") == 2 and "seeds 502-503" in out
    assert "best of 2 adaptive settings" in out and "(refined on 2 more)" in out
    assert "| adaptive thermostat, tuned (0.08, 1.2, 1.03, 1.4, 0.8) |" in out \
        or "| adaptive thermostat, tuned (0.2, 1.2, 1.03, 1.4, 0.8) |" in out
    kinetics_room.main(["--seeds", "2", "--episode-steps", "8", "--exponents", "1",
                        "--tuned", "0.08", "1.2", "1.03", "1.4"])
    assert "| adaptive thermostat, tuned (0.08, 1.2, 1.03, 1.4, 0.8) |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        kinetics_room.main(["--seeds", "1", "--tuned", "0.08", "1.2", "1.03"])
    with pytest.raises(SystemExit):  # refinement seeds must not reach the evaluation seeds
        kinetics_room.main(["--seeds", "1", "--first-seed", "503", "--search", "--grid", "1",
                            "--search-seeds", "500", "502", "--refine", "1", "5",
                            "--episode-steps", "8"])


ADAPTIVE = "discgym.controllers.AdaptiveThermostat"


def test_residual_zero_is_the_controller_bit_for_bit():
    """With ``base``, an agent that always answers 0 plays the hand-written controller's
    episode exactly; another action moves its setpoint by span**a0 and adds to the rest."""
    from discgym.controllers import AdaptiveThermostat

    env = gym.make("DiscKinetics-v0", episode_steps=24)
    law = SetpointActions(env, hold=4, average=0.8, base=ADAPTIVE, span=1.5)
    res = [run_episodes("DiscKinetics-v0", lambda e: SetpointActions(
        e, hold=4, base=ADAPTIVE).policy(lambda o: np.zeros(4, np.float32)), [3, 4],
        {"episode_steps": 24}),
        run_episodes("DiscKinetics-v0", AdaptiveThermostat, [3, 4], {"episode_steps": 24})]
    np.testing.assert_array_equal(res[0].returns, res[1].returns)
    obs, _ = env.reset(seed=5)
    ref, bases = AdaptiveThermostat(env), law.new_bases(1)
    a = law.env_actions(np.array([0.5, 0.4, -0.5, 0.2], np.float32), obs, bases)
    b = ref(obs)
    T = Slots(env).temperature(obs)
    sp = bases[0].setpoint * 1.5 ** 0.5
    assert bases[0].setpoint == ref.setpoint
    assert a[0] == pytest.approx(np.clip(np.log(sp / T) / Slots(env).log_rate, -1, 1),
                                 abs=1e-6)
    np.testing.assert_allclose(a[1:], np.clip(b[1:] + [0.4, -0.5, 0.2], -1, 1), atol=1e-7)
    env.close()


def test_residual_wrapper_resets_its_controllers_and_matches_the_episode_policy():
    """SetpointHold with ``base`` keeps one controller per reactor, reset with each episode:
    two episodes in a row of the wrapper give the one-env policy's returns on their seeds."""
    venv = SetpointHold(DiscReactorSB3VecEnv(num_envs=2, episode_steps=8, threads=1,
                                             **_kinetics()), hold=4, average=0.8, base=ADAPTIVE)
    venv.seed(21)
    obs, total, firsts = venv.reset(), np.zeros(2), []
    for k in range(4):  # two 8-step episodes per reactor; the second starts from autoreset
        obs, r, done, _ = venv.step(_decide(obs))
        total += r
        if k == 1:
            firsts, total = total.copy(), np.zeros(2)
            assert done.all()  # the controllers start the next episodes afresh
            assert [c.setpoint for c in venv._bases] == [c.t_start for c in venv._bases]
    seeds = [21, 22]

    def factory(env):
        return SetpointHold.episode_policy(env, _decide, hold=4, average=0.8, base=ADAPTIVE)

    res = run_episodes("DiscKinetics-v0", factory, seeds, {"episode_steps": 8})
    np.testing.assert_allclose(res.returns, firsts, rtol=1e-5, atol=1e-6)
    assert venv._bases[0] is not venv._bases[1] and np.all(np.isfinite(total))


def _kinetics():
    from discgym.tasks import TASKS

    kw = dict(TASKS["DiscKinetics-v0"][0].defaults)
    kw.pop("episode_steps", None)
    return kw


@pytest.mark.parametrize("kw, match", [
    (dict(base="discgym.controllers.NoSuchController"), "base: cannot import"),
    (dict(base="discgym.controllers.BandThermostat"), "keeps no setpoint"),
    (dict(base=ADAPTIVE, span=1.0), "span"), (dict(base=ADAPTIVE, span=True), "span"),
    (dict(correct="setpoint"), "correct"), (dict(base=ADAPTIVE, correct="heat"), "correct"),
    (dict(base=ADAPTIVE, correct="wall,wall"), "correct"),
    (dict(base=ADAPTIVE, correct=""), "correct"), (dict(base=ADAPTIVE, correct=1), "correct"),
    (dict(base=ADAPTIVE, correct="setpoint,heat"), "correct"),
])
def test_bad_residual_arguments_name_what_is_wrong(kw, match):
    env = gym.make("DiscKinetics-v0")
    with pytest.raises(ValueError, match=match):
        SetpointActions(env, **kw)
    law = SetpointActions(env, base=ADAPTIVE)
    obs, _ = env.reset(seed=0)
    with pytest.raises(ValueError, match="bases: expected 1 controllers"):
        law.env_actions(np.zeros(4), obs)


def test_setpoint_only_correction_keeps_the_controllers_wall_and_feeds():
    """correct='setpoint': the agent's action is one factor on the controller's setpoint; the
    wrapper's action space is (1,), the env gets the controller's wall and feeds, and the
    one-env policy plays the wrapper's episodes."""
    from discgym.controllers import AdaptiveThermostat

    env = gym.make("DiscKinetics-v0", episode_steps=8)
    law = SetpointActions(env, base=ADAPTIVE, correct="setpoint", span=2.0)
    obs, _ = env.reset(seed=2)
    a = law.env_actions(np.array([1.0], np.float32), obs, law.new_bases(1))
    b = AdaptiveThermostat(env)(obs)
    np.testing.assert_array_equal(a[1:], b[1:])
    T = Slots(env).temperature(obs)
    assert a[0] == pytest.approx(np.clip(np.log(2.0 * 1.2 / T) / Slots(env).log_rate, -1, 1),
                                 abs=1e-6)
    bases = law.new_bases(1)
    bases[0].setpoint = 2.5
    with pytest.raises(ValueError, match="takes 1 component"):
        law.env_actions(np.zeros(4, np.float32), obs, bases)
    assert bases[0].setpoint == 2.5  # refused before the controller was called
    venv = SetpointHold(DiscReactorSB3VecEnv(num_envs=2, episode_steps=8, threads=1,
                                             **_kinetics()), hold=4, average=0.8, base=ADAPTIVE,
                        correct="setpoint")
    assert venv.action_space.shape == (1,)
    venv.seed(31)
    o, total = venv.reset(), np.zeros(2)

    def decide(x):
        return np.tanh(_decide(x)[..., :1])

    for _ in range(2):
        o, r, done, _ = venv.step(decide(o))
        total += r
    res = run_episodes("DiscKinetics-v0", lambda e: SetpointHold.episode_policy(
        e, decide, hold=4, average=0.8, base=ADAPTIVE, correct="setpoint"), [31, 32],
        {"episode_steps": 8})
    np.testing.assert_allclose(res.returns, total, rtol=1e-5, atol=1e-6)
    env.close()


SEARCHED_BASE = "discgym.searched.searched"


@pytest.mark.parametrize("env_id", ["DiscReactor-v0", "DiscKinetics-v0", "DiscEconomic-v0",
                                    "DiscJacket-v0", "DiscFlow-v0"])
def test_residual_zero_is_the_searched_controller_on_every_task(env_id):
    """With the searched controller as the base, an agent that answers 0 plays its episode
    bit for bit on every task (hyperparams/residual_searched), the jacket's law and the dead
    band included; a correction of the setpoint is held by the controller's own law (its
    ``setpoint_scale``)."""
    from discgym.searched import searched

    kw = {"episode_steps": 24}

    def residual(e):
        return SetpointActions(e, hold=4, average=0.8, base=SEARCHED_BASE, span=1.3,
                               correct="setpoint,wall").policy(lambda o: np.zeros(2, np.float32))

    np.testing.assert_array_equal(run_episodes(env_id, residual, [1000, 1001], kw).returns,
                                  run_episodes(env_id, searched, [1000, 1001], kw).returns)
    env = gym.make(env_id, **kw)
    obs, _ = env.reset(seed=7)
    law = SetpointActions(env, base=SEARCHED_BASE, span=1.3, correct="setpoint,wall")
    got = law.env_actions(np.array([1.0, 0.25], np.float32), obs, law.new_bases(1))
    ref = searched(env)
    ref.setpoint_scale = 1.3
    want = ref(obs)
    assert got[0] == want[0] and got[2:].tolist() == want[2:].tolist()
    assert got[1] == pytest.approx(min(want[1] + 0.25, 1.0))
    env.close()


FLOW_BASE = "discgym.controllers.flow_thermostat"


@pytest.mark.parametrize("correct, columns", [
    ("wall", [1]), ("setpoint,wall", [0, 1]), ("wall, setpoint", [0, 1]), ("feeds", [2, 3]),
    ("all", [0, 1, 2, 3]),
])
def test_a_correction_of_some_components_leaves_the_others_to_the_controller(correct,
                                                                              columns):
    """correct names a subset of setpoint, wall and feeds: the agent's action holds those
    components in the env action's order, and the env gets the controller's value of the
    others (DiscFlow-v0's flow thermostat, whose action has two feeds)."""
    from discgym.controllers import flow_thermostat

    env = gym.make("DiscFlow-v0", episode_steps=8)
    law = SetpointActions(env, base=FLOW_BASE, correct=correct, span=2.0)
    assert law.action_dim == len(columns)
    obs, _ = env.reset(seed=3)
    a = np.full(len(columns), -0.5, np.float32)
    got = law.env_actions(a, obs, law.new_bases(1))
    ref = flow_thermostat(env)(obs)
    slots = Slots(env)
    setpoint = 3.8 * (2.0 ** -0.5 if 0 in columns else 1.0)
    heat = np.clip(np.log(setpoint / slots.temperature(obs)) / slots.log_rate, -1, 1)
    assert got[0] == pytest.approx(heat, abs=1e-6)
    for k in range(1, 4):
        assert got[k] == pytest.approx(ref[k] - 0.5 if k in columns else ref[k])
    from discgym.tasks import TASKS

    kw = dict(TASKS["DiscFlow-v0"][0].defaults, episode_steps=8)
    venv = SetpointHold(DiscReactorSB3VecEnv(num_envs=2, threads=1, **kw), hold=1,
                        base=FLOW_BASE, correct=correct)
    assert venv.action_space.shape == (len(columns),)
    venv.reset()
    with pytest.raises(ValueError, match="actions: expected shape"):
        venv.step(np.zeros((2, len(columns) + 1), np.float32))
    env.close()
