"""The DDQN agent: greedy on a Q-network trained on θ_0 (numpy forward, no torch)."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from ns_pz.agents.base import Agent
from ns_pz.agents.learning.config import DDQNArgs, nested_args
from ns_pz.agents.learning.features import NumpyMLP, features
from ns_pz.agents.learning.trained import ddqn_needed, obtain

from ns_pz.checks import count, flag, positive_number
from ns_pz.views import NSGymEnv


class QNetwork:
    """A trained Q-network over one observation space: ``q(observation) -> [num_actions]``.

    Args:
        weights: Exported arrays ``q.i.weight``/``q.i.bias``.
        observation_space: The base environment's observation space (``Discrete``: one-hot).

    Raises:
        ValueError: The network's input does not fit ``observation_space``.
    """

    def __init__(self, weights: Mapping[str, np.ndarray], observation_space: spaces.Space) -> None:
        self.mlp = NumpyMLP(weights, "q")
        self.space = observation_space
        size = len(features(observation_space, observation_space.sample()))
        if self.mlp.input_size != size:
            raise ValueError(
                f"the Q-network takes {self.mlp.input_size} inputs; "
                f"{observation_space} gives {size}"
            )

    def __call__(self, observation: Any) -> np.ndarray:
        """``[num_actions]`` action values of one base observation."""
        return self.mlp(features(self.space, observation))


class DDQNAgent(Agent):
    """Plays ``argmax_a Q(s, a)`` (lowest index on ties); needs no planning model.

    Without fine-tuning this is the paper's DDQN "without notification" at every level.
    """

    def __init__(self, q_network: QNetwork) -> None:
        self.q_network = q_network

    def act(self, observation: dict[str, Any], model: Any | None = None) -> int:
        """The greedy action for ``observation["state"]``."""
        return int(np.argmax(self.q_network(observation["state"])))

    def __repr__(self) -> str:
        return f"DDQNAgent(layers={len(self.q_network.mlp.layers)})"


def ddqn_q_network(env: NSGymEnv, args: DDQNArgs) -> QNetwork:
    """The Q-network of ``env``'s θ_0 (trained now, once, if it is not cached)."""
    return QNetwork(obtain(ddqn_needed(env, args)), env.family.observation_space)


def build_ddqn(env: NSGymEnv, **hyper: Any) -> DDQNAgent:
    """The DDQN agent for ``env``; ``hyper`` are :class:`DDQNArgs` fields."""
    return DDQNAgent(ddqn_q_network(env, DDQNArgs(**hyper)))


def check_fine_tuning(
    model_steps: Any,
    gradient_steps: Any,
    epsilon: Any,
    time_budget: Any = None,
    checks: Any = 1,
    evaluation_episodes: Any = 2,
    validate: Any = True,
    interval: Any = 1,
) -> None:
    """Validate DDQN-WN's fine-tuning budget.

    Raises:
        ValueError: A count that is not an int >= 0, ``checks`` or ``interval`` below 1,
            ``evaluation_episodes`` below 2, ``epsilon`` outside [0, 1], or a ``time_budget``
            (when not None) that is not a finite number > 0.
        TypeError: ``epsilon`` is not a real number, or ``validate`` not a bool.
    """
    flag("validate", validate)
    count("model_steps", model_steps, 0)
    count("gradient_steps", gradient_steps, 0)
    count("checks", checks, 1)
    count("interval", interval, 1)
    count("evaluation_episodes", evaluation_episodes, 2)
    if time_budget is not None:
        positive_number("time_budget", time_budget)
    if isinstance(epsilon, bool) or not isinstance(epsilon, (int, float)):
        raise TypeError(f"epsilon={epsilon!r} must be a real number in [0, 1]")
    if not 0.0 <= epsilon <= 1.0:
        raise ValueError(f"epsilon={epsilon!r} must lie in [0, 1]")


def build_ddqn_wn(
    env: NSGymEnv,
    *,
    model_steps: int = 200,
    gradient_steps: int = 50,
    epsilon: float = 0.1,
    time_budget: float | None = None,
    checks: int = 5,
    evaluation_episodes: int = 16,
    validate: bool = True,
    interval: int = 1,
    ddqn: Mapping[str, Any] | None = None,
) -> Agent:
    """DDQN-WN for ``env``: the ``ddqn`` agent's network, fine-tuned on notified changes.

    Each fine-tuning is validated in the handed model (see
    :class:`ns_pz.agents.learning.ddqn_wn.FineTunedDDQNAgent`): the network kept is the best
    scored of the pre-change one and ``checks`` candidates.

    Args:
        env: The environment it will act in.
        model_steps: Transitions simulated in the handed model per notified change.
        gradient_steps: Double-DQN updates per notified change.
        epsilon: Exploration of the simulated transitions.
        time_budget: Seconds of simulation and updates per notified change instead of the step
            counts (the paper: 0.4); None: the step counts.
        checks: Rounds of the budget, each ending with a scored candidate.
        evaluation_episodes: Greedy episodes in the handed model that score a candidate.
        validate: False: keep the last fine-tuned network unscored (the paper's fine-tuning).
        interval: Fewest steps between fine-tunings (1: every notified change); a change
            notified sooner is fine-tuned for once the interval has passed.
        ddqn: :class:`DDQNArgs` of the network (as the ``ddqn`` agent's, to share it); its
            learning rate, γ, τ, batch size and weight decay also drive the fine-tuning.
    """
    args = nested_args(DDQNArgs, ddqn, "ddqn").for_family(env.family)
    weights = obtain(ddqn_needed(env, args))
    module = importlib.import_module("ns_pz.agents.learning.ddqn_wn")  # it imports this module
    return module.FineTunedDDQNAgent(
        weights,
        env.family.observation_space,
        args,
        model_steps=model_steps,
        gradient_steps=gradient_steps,
        epsilon=epsilon,
        time_budget=time_budget,
        checks=checks,
        evaluation_episodes=evaluation_episodes,
        validate=validate,
        interval=interval,
    )
