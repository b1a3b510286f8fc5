"""Planning agents over the handed model: snapshot value iteration and random shooting.

Both plan in the stationary snapshot the environment hands over, so what they know of a change
is exactly what the notification level allows: at ``none`` and ``basic`` they plan with θ_0
(a perfect but stale planner), at ``detailed`` with the current θ (snapshot replanning).
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any

import numpy as np
from ns_pz.agents.base import Agent
from ns_pz.agents.exact.induction import backward_induction, check_gamma
from ns_pz.agents.exact.schedule import check_horizon

from ns_pz.checks import count
from ns_pz.params import Params
from ns_pz.planning import TabularOutcomes


def value_iteration(
    outcomes: TabularOutcomes, gamma: float, tolerance: float = 1e-9, max_sweeps: int = 10_000
) -> tuple[np.ndarray, np.ndarray]:
    """Discounted value iteration on an outcome table.

    Returns:
        ``(values, q_values)``: ``[num_states]`` and ``[num_states, num_actions]``. A terminal
        outcome contributes its reward and nothing after it.
    """
    continuation = gamma * (~outcomes.terminals)
    values = np.zeros(outcomes.probs.shape[0])
    for _ in range(max_sweeps):
        q_values = (
            outcomes.probs * (outcomes.rewards + continuation * values[outcomes.next_states])
        ).sum(axis=2)
        new_values = q_values.max(axis=1)
        if np.max(np.abs(new_values - values)) < tolerance:
            return new_values, q_values
        values = new_values
    return values, q_values


class SnapshotValueIteration(Agent):
    """Acts greedily on the value-iteration solution of the handed tabular model.

    Without a ``horizon`` it solves the discounted infinite-horizon problem. With one it solves
    the finite-horizon problem of ``horizon`` steps by backward induction (``gamma=1.0``
    allowed: the undiscounted episode return) and plays step ``relative_time`` of it, so near
    the end of an episode it acts for the steps that are left.

    Solutions are cached per (family, θ), the most recent ``cache_size`` of them, so replanning
    after a change costs one solve and acting otherwise costs a lookup.

    Args:
        gamma: Discount; in ``[0, 1)`` without a horizon, in ``[0, 1]`` with one.
        cache_size: How many solutions to keep.
        horizon: Episode length ``H`` the finite-horizon solution covers (``None``: discounted
            infinite horizon).
    """

    def __init__(
        self, gamma: float = 0.99, cache_size: int = 64, horizon: int | None = None
    ) -> None:
        gamma = check_gamma(gamma)  # a real number in [0, 1] (a bool refused) ...
        if horizon is not None:
            horizon = check_horizon(horizon)
        elif gamma == 1.0:  # ... and below 1 without a horizon
            raise ValueError(f"gamma={gamma!r} must lie in [0, 1) (or [0, 1] with a horizon)")
        cache_size = count("cache_size", cache_size)
        self.gamma = gamma
        self.cache_size = cache_size
        self.horizon = horizon
        self._policies: OrderedDict[tuple[object, Params], np.ndarray] = OrderedDict()

    @property
    def needs_model(self) -> bool:
        """It plans on every step."""
        return True

    def act(self, observation: dict[str, Any], model: Any | None = None) -> int:
        """The greedy action of the snapshot's optimal policy (ties: lowest index).

        Raises:
            ValueError: No tabular model was handed over, or (with a horizon) the episode has
                run past it.
        """
        if model is None or not hasattr(model, "outcomes"):
            raise ValueError(
                "SnapshotValueIteration needs a tabular planning model (model.outcomes)"
            )
        key = (model.family, model.theta)
        policy = self._policies.get(key)
        if policy is None:
            policy = self._solve(model.outcomes)
            self._policies[key] = policy
            if len(self._policies) > self.cache_size:
                self._policies.popitem(last=False)
        else:
            self._policies.move_to_end(key)
        if self.horizon is None:
            return int(policy[model.get_state()])
        t = int(observation["relative_time"][0])
        if t >= self.horizon:
            raise ValueError(f"relative_time={t} is beyond horizon={self.horizon}")
        return int(policy[t, model.get_state()])

    def _solve(self, outcomes: TabularOutcomes) -> np.ndarray:
        """``[num_states]`` (discounted) or ``[H, num_states]`` (finite horizon) actions."""
        if self.horizon is None:
            _, q_values = value_iteration(outcomes, self.gamma)
            return q_values.argmax(axis=1)
        return backward_induction([outcomes] * self.horizon, self.gamma).policy

    def __repr__(self) -> str:
        if self.horizon is None:
            return f"SnapshotValueIteration(gamma={self.gamma})"
        return f"SnapshotValueIteration(gamma={self.gamma}, horizon={self.horizon})"


class RandomShooting(Agent):
    """Tries each action followed by random rollouts in the model; picks the best mean return.

    Args:
        num_rollouts: Rollouts per first action.
        depth: Steps per rollout, the first action included.
        gamma: Discount of rewards within a rollout.
    """

    def __init__(self, num_rollouts: int = 8, depth: int = 30, gamma: float = 0.99) -> None:
        self.num_rollouts = count("num_rollouts", num_rollouts)
        self.depth = count("depth", depth)
        self.gamma = check_gamma(gamma)

    @property
    def needs_model(self) -> bool:
        """It plans on every step."""
        return True

    def act(self, observation: dict[str, Any], model: Any | None = None) -> int:
        """The first action with the highest mean discounted rollout return."""
        if model is None:
            raise ValueError("RandomShooting needs a planning model")
        num_actions = int(model.action_space.n)
        root = model.get_state()
        scores = np.zeros(num_actions)
        for action in range(num_actions):
            total = 0.0
            for _ in range(self.num_rollouts):
                state, reward, done = model.transition(root, action)
                ret, discount = reward, self.gamma
                for _ in range(self.depth - 1):
                    if done:
                        break
                    state, reward, done = model.transition(
                        state, int(self.rng.integers(num_actions))
                    )
                    ret += discount * reward
                    discount *= self.gamma
                total += ret
            scores[action] = total / self.num_rollouts
        best = np.flatnonzero(scores == scores.max())
        return int(best[self.rng.integers(len(best))])

    def __repr__(self) -> str:
        return f"RandomShooting(num_rollouts={self.num_rollouts}, depth={self.depth})"
