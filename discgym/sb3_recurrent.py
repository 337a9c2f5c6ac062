"""sb3-contrib's ``RecurrentPPO`` LSTM policy, trained on whole sequences at once.

``RecurrentActorCriticPolicy._process_sequence`` steps the LSTM through a minibatch one time
step at a time whenever any sequence in it contains an episode start, so that the state can be
reset there (sb3-contrib issue #113). ``RecurrentRolloutBuffer`` cuts its sequences at every
episode start, so during training an episode start is only ever the *first* step of a
sequence; :class:`SequenceLstmPolicy` then resets those sequences' initial states and runs the
LSTM over the whole padded batch in one call, which is the same function (the step loop stays
for any other pattern, e.g. collecting rollouts). On DiscKinetics-v0's setting
(``hyperparams/recurrent_ppo.yml``) it cut the time of an update about 3x (measured
2026-12-02 on this project's 2-core VM; docs/agents.md).

In the hyperparameter files: ``policy: 'discgym.sb3_recurrent.SequenceLstmPolicy'``
(``agents/train_ppo.py`` imports a dotted policy name). Needs ``sb3-contrib`` (and torch):
``pip install torch==2.13.0 'discgym[agents]'``.
"""

from __future__ import annotations

import torch as th

try:
    from sb3_contrib.common.recurrent.policies import RecurrentActorCriticPolicy
except ImportError as exc:  # pragma: no cover - exercised only without sb3-contrib
    raise ImportError("discgym.sb3_recurrent needs sb3-contrib: "
                      "pip install torch==2.13.0 'discgym[agents]'") from exc

__all__ = ["SequenceLstmPolicy"]


class SequenceLstmPolicy(RecurrentActorCriticPolicy):
    """``MlpLstmPolicy`` whose LSTM runs a minibatch's sequences in one call when episodes
    start only at the sequences' first steps (always so in ``RecurrentPPO``'s updates)."""

    @staticmethod
    def _process_sequence(features: th.Tensor, lstm_states: tuple[th.Tensor, th.Tensor],
                          episode_starts: th.Tensor, lstm: th.nn.LSTM):
        n_seq = lstm_states[0].shape[1]
        starts = episode_starts.reshape((n_seq, -1))  # (n_seq, max length)
        if starts.shape[1] == 1 or th.any(starts[:, 1:] != 0.0):
            return RecurrentActorCriticPolicy._process_sequence(features, lstm_states,
                                                                episode_starts, lstm)
        keep = (1.0 - starts[:, 0]).view(1, n_seq, 1)
        sequence = features.reshape((n_seq, -1, lstm.input_size)).swapaxes(0, 1)
        out, states = lstm(sequence, (keep * lstm_states[0], keep * lstm_states[1]))
        return th.flatten(out.transpose(0, 1), start_dim=0, end_dim=1), states
