"""DDQN with notification: the θ_0 Q-network, fine-tuned on each notified change (torch).

The NS-Gym paper's DDQN "with notification". When the observation flags a change, the agent collects
``model_steps`` transitions in the planning model handed over (at ``detailed`` it has the new
θ), ε-greedy from the current state, restarting from the current state whenever a simulated
episode ends, then makes ``gradient_steps`` Double-DQN updates on them; it then acts greedily.
The budget is counted in steps, not seconds, so results do not depend on the machine (the
paper used 0.4 s of wall-clock). Fixed from NS-Gym: ε is used (NS-Gym collects greedily), a
restart stays under the new θ at the current state (NS-Gym's ``env.reset()`` went back to θ_0),
and the target network is a separate copy.

The fine-tuned network lasts for the rest of the episode; :meth:`reset` restores the θ_0 one.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from ns_pz.agents.base import Agent
from ns_pz.agents.learning.config import DDQNArgs
from ns_pz.agents.learning.ddqn import double_dqn_target, soft_update
from ns_pz.agents.learning.features import features
from ns_pz.agents.learning.networks import mlp, one_thread
from ns_pz.agents.learning.q_agent import check_fine_tuning
from ns_pz.agents.learning.replay import ReplayBuffer


def network_from(weights: dict[str, np.ndarray], prefix: str) -> torch.nn.Sequential:
    """A torch MLP holding exported ``prefix.i.weight``/``prefix.i.bias`` arrays."""
    count = sum(1 for name in weights if name.startswith(prefix) and name.endswith(".weight"))
    shapes = [weights[f"{prefix}.{i}.weight"].shape for i in range(count)]
    network = mlp(shapes[0][1], [shape[0] for shape in shapes[:-1]], shapes[-1][0])
    linears = [m for m in network if isinstance(m, torch.nn.Linear)]
    with torch.no_grad():
        for i, layer in enumerate(linears):
            layer.weight.copy_(torch.from_numpy(np.asarray(weights[f"{prefix}.{i}.weight"])))
            layer.bias.copy_(torch.from_numpy(np.asarray(weights[f"{prefix}.{i}.bias"])))
    return network


class FineTunedDDQNAgent(Agent):
    """Greedy on a Q-network that is fine-tuned in the handed model after each notified change.

    Args:
        weights: The θ_0 Q-network (exported arrays).
        observation_space: The base environment's observation space.
        args: The DDQN settings (learning rate, γ, τ, batch size, weight decay).
        model_steps: Transitions simulated in the handed model per notified change.
        gradient_steps: Double-DQN updates per notified change.
        epsilon: Exploration of the simulated transitions.

    Raises:
        ValueError, TypeError: A budget below 0 or ε outside [0, 1].
    """

    def __init__(
        self,
        weights: dict[str, np.ndarray],
        observation_space: Any,
        args: DDQNArgs,
        *,
        model_steps: int,
        gradient_steps: int,
        epsilon: float,
    ) -> None:
        check_fine_tuning(model_steps, gradient_steps, epsilon)
        self.weights = weights
        self.space = observation_space
        self.args = args
        self.model_steps, self.gradient_steps, self.epsilon = model_steps, gradient_steps, epsilon
        self.fine_tunings = 0

    @property
    def needs_model(self) -> bool:
        """The handed model is what it fine-tunes in."""
        return True

    def reset(self, rng: np.random.Generator) -> None:
        """Back to the θ_0 network, with a fresh buffer."""
        super().reset(rng)
        self.online = network_from(self.weights, "q")
        self.target = copy.deepcopy(self.online)
        self.optimizer = torch.optim.Adam(
            self.online.parameters(),
            lr=self.args.learning_rate,
            weight_decay=self.args.weight_decay,
        )
        size = len(features(self.space, self.space.sample()))
        self.buffer = ReplayBuffer(max(1, self.model_steps * 50), size)
        self.fine_tunings = 0

    def act(self, observation: dict[str, Any], model: Any | None = None) -> int:
        """Fine-tune first if the observation flags a change, then act greedily.

        Raises:
            ValueError: A change is flagged and no model was handed over.
        """
        with one_thread():  # the caller's torch thread count is left as it was
            if np.any(observation["env_change"]):
                if model is None:
                    raise ValueError("DDQN-WN needs the planning model on a notified change")
                self._fine_tune(model)
            return self._greedy(features(self.space, observation["state"]))

    def _greedy(self, x: np.ndarray) -> int:
        with torch.no_grad():
            return int(self.online(torch.from_numpy(x)).argmax())

    def _fine_tune(self, model: Any) -> None:
        observe, start = model.family.observe, model.get_state()
        num_actions = int(model.action_space.n)
        state = start
        for _ in range(self.model_steps):
            x = features(self.space, observe(state))
            if self.rng.random() < self.epsilon:
                action = int(self.rng.integers(num_actions))
            else:
                action = self._greedy(x)
            next_state, reward, terminal = model.transition(state, action)
            next_x = features(self.space, observe(next_state))
            self.buffer.add(x, action, float(reward), next_x, bool(terminal))
            state = start if terminal else next_state
        for _ in range(self.gradient_steps if self.buffer.size else 0):
            self._update()
        self.fine_tunings += 1

    def _update(self) -> None:
        batch = self.buffer.sample(self.args.batch_size, self.rng)
        next_features = torch.from_numpy(batch.next_features)
        with torch.no_grad():
            target = double_dqn_target(
                self.online(next_features),
                self.target(next_features),
                torch.from_numpy(batch.rewards),
                torch.from_numpy(batch.terminated),
                self.args.gamma,
            )
        q_taken = self.online(torch.from_numpy(batch.features))
        q_taken = q_taken.gather(1, torch.from_numpy(batch.actions)[:, None]).squeeze(1)
        loss = F.mse_loss(q_taken, target)
        self.optimizer.zero_grad()
        loss.backward()
        self.optimizer.step()
        soft_update(self.target, self.online, self.args.tau)

    def __repr__(self) -> str:
        return (
            f"FineTunedDDQNAgent(model_steps={self.model_steps}, "
            f"gradient_steps={self.gradient_steps}, epsilon={self.epsilon})"
        )
