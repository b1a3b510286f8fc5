"""Agents that need no model: the uniform random policy."""

from __future__ import annotations

from typing import Any

from gymnasium import spaces
from ns_pz.agents.base import Agent


class RandomAgent(Agent):
    """Uniform over a discrete action space, drawing from the agent's generator."""

    def __init__(self, action_space: spaces.Discrete) -> None:
        if not isinstance(action_space, spaces.Discrete):
            raise TypeError(f"action_space={action_space!r} must be Discrete")
        self.num_actions = int(action_space.n)
        self.start = int(action_space.start)

    def act(self, observation: dict[str, Any], model: Any | None = None) -> int:
        """A uniformly random action."""
        return self.start + int(self.rng.integers(self.num_actions))

    def __repr__(self) -> str:
        return "RandomAgent()"
