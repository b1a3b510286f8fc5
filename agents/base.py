"""The one interface every decision agent implements.

An agent acts from the observation and, where given, the planning model the environment hands
over at that step (a stationary snapshot: θ_0 at notification levels ``none`` and ``basic``,
the current θ at ``detailed``). It may learn from transitions through :meth:`Agent.observe`, and
is reset with its own generator at the start of every episode, so one seed reproduces a run.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np


class Agent(ABC):
    """Base of every decision agent."""

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode; all of the agent's randomness must come from ``rng``."""
        self.rng = rng

    @abstractmethod
    def act(self, observation: dict[str, Any], model: Any | None = None) -> Any:
        """The action for ``observation``; ``model`` is the planning model handed over, if any."""

    def observe(  # noqa: B027 - optional hook, most agents do not learn
        self,
        observation: dict[str, Any],
        action: Any,
        reward: float,
        next_observation: dict[str, Any],
        terminated: bool,
    ) -> None:
        """Learn from one transition (default: nothing)."""

    @property
    def needs_model(self) -> bool:
        """Whether :meth:`act` uses the planning model (the loop skips building it if not)."""
        return False
