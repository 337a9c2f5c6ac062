"""discgym.sb3_recurrent.SequenceLstmPolicy computes what sb3-contrib's MlpLstmPolicy computes
(values, log-probabilities, entropies and their gradients on RecurrentPPO's own minibatches),
in one LSTM call per minibatch instead of one per time step; and train_ppo.py's
``--train-integrator``."""

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")
import torch as th  # noqa: E402
from sb3_contrib import RecurrentPPO  # noqa: E402

from discgym.sb3 import DiscReactorSB3VecEnv  # noqa: E402
from discgym.sb3_recurrent import SequenceLstmPolicy  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "agents"))
import train_ppo  # noqa: E402


class _Count:
    """Counts the LSTM's forward calls."""

    def __init__(self, lstm):
        self.n = 0
        lstm.register_forward_hook(self)

    def __call__(self, *_):
        self.n += 1


@pytest.fixture(scope="module")
def rollout():
    """A RecurrentPPO (episodes of 20 steps, rollouts of 48: episodes start inside them) after
    one rollout, and one minibatch of it (sequences cut at episode starts, padded)."""
    venv = DiscReactorSB3VecEnv(num_envs=3, threads=1, episode_steps=20)
    venv.seed(0)
    model = RecurrentPPO("MlpLstmPolicy", venv, n_steps=48, batch_size=72, seed=1,
                         device="cpu", policy_kwargs=dict(net_arch=[16], lstm_hidden_size=8))
    model.learn(48 * 3)  # one rollout (the update on it is irrelevant here)
    batch = next(model.rollout_buffer.get(72))
    yield model, batch
    venv.close()


def _evaluate(policy, batch):
    policy.zero_grad()
    values, log_prob, entropy = policy.evaluate_actions(
        batch.observations, batch.actions, batch.lstm_states, batch.episode_starts)
    loss = (values.flatten() * batch.mask).sum() + (log_prob * batch.mask).sum()
    loss.backward()
    grads = [p.grad.clone() for p in policy.parameters()]
    return values.detach(), log_prob.detach(), entropy.detach(), grads


def test_the_same_function_in_one_lstm_call(rollout):
    model, batch = rollout
    starts = batch.episode_starts.reshape(batch.lstm_states.pi[0].shape[1], -1)
    # the minibatch has sequences that start an episode, and episode starts only there
    assert starts[:, 0].any() and not starts[:, 1:].any() and starts.shape[1] > 1
    base = model.policy
    fast = SequenceLstmPolicy(base.observation_space, base.action_space,
                              lambda _: 3e-4, net_arch=[16], lstm_hidden_size=8)
    fast.load_state_dict(base.state_dict())
    calls = {k: _Count(p.lstm_actor) for k, p in (("base", base), ("fast", fast))}
    ref, got = _evaluate(base, batch), _evaluate(fast, batch)
    assert calls["base"].n == starts.shape[1] and calls["fast"].n == 1
    for r, g in zip(ref[:3], got[:3]):
        np.testing.assert_allclose(g.numpy(), r.numpy(), rtol=1e-5, atol=1e-6)
    for r, g in zip(ref[3], got[3]):
        np.testing.assert_allclose(g.numpy(), r.numpy(), rtol=1e-4, atol=1e-6)


def test_episode_starts_inside_a_sequence_take_the_step_loop(rollout):
    """Another pattern (a reset in the middle of a sequence) falls back to sb3-contrib's
    loop, so the policy is right for any input, not only RecurrentPPO's minibatches."""
    model, batch = rollout
    n_seq = batch.lstm_states.pi[0].shape[1]
    starts = batch.episode_starts.reshape(n_seq, -1).clone()
    starts[0, starts.shape[1] // 2] = 1.0
    lstm = model.policy.lstm_actor
    feats = th.randn(starts.numel(), lstm.input_size, generator=th.Generator().manual_seed(0))
    states = tuple(th.randn_like(s) for s in batch.lstm_states.pi)
    out_base, _ = type(model.policy)._process_sequence(feats, states, starts.flatten(), lstm)
    n = _Count(lstm)
    out, _ = SequenceLstmPolicy._process_sequence(feats, states, starts.flatten(), lstm)
    assert n.n == starts.shape[1]
    np.testing.assert_array_equal(out.detach().numpy(), out_base.detach().numpy())


def test_train_integrator_is_the_training_reactors_only():
    args = train_ppo.Args(env_id="DiscKinetics-v0", train_integrator="event", threads=1)
    train = train_ppo.make_vec_env(args, 2, False, 0.98, training=True)
    valid = train_ppo.make_vec_env(args, 2, False, 0.98)
    assert train.get_attr("config", [0])[0].integrator == "event"
    assert valid.get_attr("config", [0])[0].integrator == "step"  # the task's own
    train.close()
    valid.close()
    with pytest.raises(SystemExit):
        train_ppo.parse_args(["--train-integrator", "verlet"])
    assert train_ppo.parse_args(["--train-integrator", "event"]).train_integrator == "event"
    assert train_ppo.policy_of("discgym.sb3_recurrent.SequenceLstmPolicy",
                               "recurrent_ppo") is SequenceLstmPolicy
    assert train_ppo.policy_of(None, "recurrent_ppo") == "MlpLstmPolicy"
