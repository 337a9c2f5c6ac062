"""What every controller family does with an observation it cannot act on, per task, and which
controller a task env built from its class gets.

The families: the hand-written controllers (``controller_for``), the searched controllers
(``discgym.searched.searched``), the setpoint interface (``SetpointActions``, alone and
correcting a controller) and the scheduled heuristic (``HeuristicPolicy``). Each refuses,
with a ``ValueError`` and before it changes any state of its own, an observation of another
shape than its env's (naming the shape it expects) and one with a NaN or infinite slot
(naming the slot); an env never emits either.
"""

import gymnasium as gym
import numpy as np
import pytest

import discgym  # noqa: F401  (registers the tasks)
from discgym.baselines import HeuristicPolicy
from discgym.controllers import CONTROLLERS, SetpointActions, Thermostat, controller_for
from discgym.env import DiscReactorEnv
from discgym.searched import searched
from discgym.tasks import TASKS
from discgym.vector import DiscReactorVectorEnv

TASK_IDS = list(TASKS)


@pytest.fixture(scope="module")
def observed():
    """{env id: (env, a first observation)}."""
    out = {}
    for env_id in TASK_IDS:
        env = gym.make(env_id)
        obs, _ = env.reset(seed=0)
        out[env_id] = (env, obs)
    yield out
    for env, _ in out.values():
        env.close()


def _families(env):
    """{name: (policy obs -> action, takes a batch)} of every controller family on ``env``."""
    u = env.unwrapped
    out = {
        "hand-written": (controller_for(env), False),
        "searched": (searched(env), True),
        "heuristic": (HeuristicPolicy(u.observation_names, heat_rate=u.config.heat_rate),
                      True),
        "setpoint": (SetpointActions(env).policy(lambda o: np.zeros(4, np.float32)), False),
    }
    base = SetpointActions(env, base="discgym.searched.ScheduleController")
    bases = base.new_bases(1)
    out["residual"] = (lambda o: base.env_actions(np.zeros(base.action_dim), o, bases), True)
    out["residual"][0].state = bases  # (what a refusal must leave as it was)
    return out


def _state(policy):
    """What a policy keeps between calls (its attributes, or its closure's cells), as a
    string."""
    held = getattr(policy, "state", None) or policy
    cells = getattr(held, "__closure__", None)
    if cells:
        held = [c.cell_contents for c in cells if not callable(c.cell_contents)]
    return repr(_plain(held))


def _plain(x, depth=0):
    if isinstance(x, gym.Env | gym.vector.VectorEnv) or depth > 3:
        return type(x).__name__
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, list | tuple):
        return [_plain(v, depth + 1) for v in x]
    if isinstance(x, dict):
        return {k: _plain(v, depth + 1) for k, v in x.items()}
    if hasattr(x, "__dict__") and not isinstance(x, type):
        return type(x).__name__, _plain(vars(x), depth + 1)
    return x


def _bad_observations(obs, other):
    D = len(obs)
    out = {"short": obs[:-1], "long": np.append(obs, 0.0), "column": obs[:, None],
           "scalar": obs[0], "another task's": other}
    for value in (np.nan, np.inf, -np.inf):
        for k in (0, D // 2, D - 1):
            o = obs.copy()
            o[k] = value
            out[f"{value} at {k}"] = o
    return out


@pytest.mark.parametrize("env_id", TASK_IDS)
def test_every_family_refuses_a_bad_observation_before_changing_its_state(env_id, observed):
    env, obs = observed[env_id]
    names = env.unwrapped.observation_names
    other = next(o for k, (_, o) in observed.items() if len(o) != len(obs))
    for family, (policy, _) in _families(env).items():
        policy(obs)  # (a first step: stateful controllers now hold something)
        for case, bad in _bad_observations(obs, other).items():
            before = _state(policy)
            with pytest.raises(ValueError, match="^obs: ") as err:
                policy(bad)
            msg = str(err.value)
            if "at" in case.split():
                k = int(case.split()[-1])
                assert f"slot {names[k]!r} (index {k}) is {float(bad[k])!r}" in msg, \
                    (family, case, msg)
            else:
                assert "expected shape" in msg and str(np.shape(bad)) in msg, (family, msg)
            assert _state(policy) == before, (family, case)
        # a good observation after the refusals acts as a twin that saw none of them
        a = policy(obs)
        assert a.shape == env.action_space.shape and env.action_space.contains(a), family


@pytest.mark.parametrize("env_id", TASK_IDS)
def test_a_batch_with_one_bad_row_is_refused_naming_the_row(env_id, observed):
    env, obs = observed[env_id]
    batch = np.stack([obs, obs, obs])
    batch[1, 2] = np.nan
    for policy, takes_batch in _families(env).values():
        if not takes_batch:
            continue
        with pytest.raises(ValueError, match=r"^obs: row 1, slot .* \(index 2\) is nan"):
            policy(batch)


@pytest.mark.parametrize("env_id", TASK_IDS)
def test_a_task_env_built_from_its_class_gets_its_own_controller(env_id):
    env_cls, vec_cls = TASKS[env_id]
    want = CONTROLLERS[env_id]
    want = want if isinstance(want, type) else type(want(gym.make(env_id)))
    for env in (env_cls(), vec_cls(num_envs=2), gym.make(env_id)):
        assert type(controller_for(env)) is want, (env_id, type(env))
        env.close()


def test_the_base_env_built_directly_gets_the_reactors_thermostat_and_others_are_refused():
    for env in (DiscReactorEnv(), DiscReactorVectorEnv(num_envs=2)):
        assert type(controller_for(env)) is Thermostat
    with pytest.raises(ValueError, match="^env: no hand-written controller for 'CartPole-v1'"):
        controller_for(gym.make("CartPole-v1"))
    with pytest.raises(ValueError, match="^env: no hand-written controller for None"):
        controller_for(object())
