"""benchmarks/tune_controller.py (the two-stage search of a controller's settings) and the
flow thermostat's settings."""

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import discgym  # noqa: F401
from discgym.controllers import Thermostat, controller_for, flow_thermostat

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import tune_controller  # noqa: E402


def test_flow_thermostat_setpoint_and_overrides():
    env = gym.make("DiscFlow-v0")
    c = controller_for(env)
    assert isinstance(c, Thermostat)
    assert (c.t_hot, c.t_cold, c.wall, c.inject) == (3.8, 3.8, 1.0, 1.0)
    c = flow_thermostat(env, setpoint=3.0, wall=0.2)
    assert (c.t_hot, c.t_cold, c.wall) == (3.0, 3.0, 0.2)
    assert flow_thermostat(env, t_hot=2.0).t_hot == 2.0  # t_hot overrides the setpoint
    with pytest.raises(TypeError):
        flow_thermostat(env, setpiont=3.0)


def _obs_at(env, time_left):
    from discgym.controllers import Slots

    obs, _ = env.reset(seed=0)
    obs = obs.copy()
    obs[Slots(env).i_time] = time_left
    return obs


def test_flow_thermostat_reads_the_clock():
    """The setpoint is the thermostat's until ramp_from of the episode has passed, then rises
    linearly to (1 + ramp) x at the end; ramp=0 is the thermostat without the clock, action
    for action."""
    env = gym.make("DiscFlow-v0")
    c = flow_thermostat(env)
    assert (c.ramp, c.ramp_from) == (0.7, 0.6)
    c = flow_thermostat(env, setpoint=3.0, ramp=0.5, ramp_from=0.6)
    for time_left, sp in ((1.0, 3.0), (0.5, 3.0), (0.4, 3.0), (0.2, 3.75), (0.0, 4.5)):
        a = c(_obs_at(env, time_left))
        assert c.setpoint == pytest.approx(sp, rel=1e-6), time_left  # (a float32 clock)
        plain = Thermostat(env, t_hot=c.setpoint, t_cold=c.setpoint, wall=1.0, inject=1.0)
        np.testing.assert_array_equal(a, plain(_obs_at(env, time_left)))
    off = flow_thermostat(env, ramp=0.0)
    plain = Thermostat(env, t_hot=3.8, t_cold=3.8, wall=1.0, inject=1.0)
    for time_left in (1.0, 0.3, 0.0):
        np.testing.assert_array_equal(off(_obs_at(env, time_left)),
                                      plain(_obs_at(env, time_left)))
        assert off.setpoint == 3.8


@pytest.mark.parametrize("kw", [dict(ramp=-0.1), dict(ramp=float("nan")), dict(ramp=True),
                                dict(ramp_from=1.0), dict(ramp_from=-0.1),
                                dict(ramp_from="0.5")])
def test_flow_thermostat_refuses_a_bad_clock(kw):
    with pytest.raises(ValueError, match=next(iter(kw))):
        flow_thermostat(gym.make("DiscFlow-v0"), **kw)


def test_search_picks_the_best_refined_setting(capsys, monkeypatch):
    """The pick is the refined setting with the best mean over all its tuning seeds, and the
    evaluation compares it with --against on seeds from 1000."""
    calls = []
    real = tune_controller.score

    def spy(env_id, kwargs, seeds, env_kwargs=None):
        calls.append((dict(kwargs), list(seeds), env_kwargs))
        return real(env_id, kwargs, seeds, env_kwargs)

    # a thread pool runs the spy in this process (the search itself is what is tested)
    from concurrent.futures import ThreadPoolExecutor
    monkeypatch.setattr(tune_controller, "score", spy)
    monkeypatch.setattr(tune_controller, "ProcessPoolExecutor", ThreadPoolExecutor)
    tune_controller.main(["--env", "DiscFlow-v0", "--grid", "setpoint=0.5,3.8",
                          "wall=1", "--seeds", "2", "--refine", "2", "2", "--eval-seeds", "2",
                          "--against", "setpoint=3.0", "--episode-steps", "12",
                          "--workers", "1"])
    out = capsys.readouterr().out
    tuned = {(c["setpoint"], tuple(s)) for c, s, _ in calls if "setpoint" in c and
             s[0] < 1000}
    assert tuned == {(0.5, (500, 501)), (3.8, (500, 501)), (0.5, (502, 503)), (3.8, (502, 503))}
    assert all(kw == {"episode_steps": 12} for _, _, kw in calls)
    evals = [(c, s) for c, s, _ in calls if s[0] >= 1000]
    assert [s for _, s in evals] == [[1000, 1001]] * 2 and evals[1][0] == {"setpoint": 3.0}
    # the pick has the best mean over the 4 tuning seeds
    means = {}
    for c, s, _ in calls:
        if s[0] < 1000:
            means.setdefault(c["setpoint"], []).extend(
                real("DiscFlow-v0", c, s, {"episode_steps": 12}))
    best = max(means, key=lambda k: np.mean(means[k]))
    assert f"pick {{'setpoint': {best}, 'wall': 1.0}}" in out
    assert "pick - {'setpoint': 3.0}" in out


def test_bad_arguments_exit_with_a_message():
    with pytest.raises(SystemExit, match="name=v1"):
        tune_controller.main(["--env", "DiscFlow-v0", "--grid", "setpoint"])
    with pytest.raises(SystemExit, match="evaluation seeds"):
        tune_controller.main(["--env", "DiscFlow-v0", "--grid", "setpoint=3", "--seeds",
                              "400", "--refine", "1", "200"])
    with pytest.raises(SystemExit):
        tune_controller.main(["--env", "NoSuchTask-v0", "--grid", "setpoint=3"])
    assert tune_controller.parse_grid(["a=1,x", "b=2"]) == {"a": (1.0, "x"), "b": (2.0,)}
    with pytest.raises(SystemExit, match="--against: one value"):  # before any episode
        tune_controller.main(["--env", "DiscFlow-v0", "--grid", "setpoint=3", "--against",
                              "setpoint=3,4", "--workers", "0"])


def test_refinement_overrules_a_lucky_first_stage(capsys, monkeypatch):
    """A setting best on the first seeds but poor on the refinement seeds is not the pick."""
    def fake(env_id, kwargs, seeds, env_kwargs=None):
        first = seeds[0] < 502
        if kwargs.get("setpoint") == 1.0:  # lucky on the first stage only
            return np.full(len(seeds), 1.0 if first else 0.0)
        return np.full(len(seeds), 0.9)

    from concurrent.futures import ThreadPoolExecutor
    monkeypatch.setattr(tune_controller, "score", fake)
    monkeypatch.setattr(tune_controller, "ProcessPoolExecutor", ThreadPoolExecutor)
    tune_controller.main(["--env", "DiscFlow-v0", "--grid", "setpoint=1,2", "--seeds", "2",
                          "--refine", "2", "2", "--eval-seeds", "2", "--workers", "1"])
    out = capsys.readouterr().out
    assert "{'setpoint': 1.0}: 1.0000" in out.split("the best 2")[0]  # stage 1's winner
    assert "pick {'setpoint': 2.0}" in out
