"""What every search algorithm returns, and the agent that plugs any of them into the env loop.

A search algorithm is a plain function ``search(model, root_state, rng) -> SearchResult`` with
its hyper-parameters bound (``functools.partial(uct, iterations=300, depth=100)``), so variants
(UCT, RATS, ADA-MCTS, ...) share one loop instead of each copying it. The function must draw
all of its randomness from ``rng`` and must leave ``model`` at ``root_state`` when it returns.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from ns_pz.agents.base import Agent


@dataclass(frozen=True)
class SearchResult:
    """One decision of a search algorithm.

    Attributes:
        action: The chosen action.
        values: ``[num_actions]`` value estimate of each root action (NaN where unvisited).
        visits: ``[num_actions]`` visit count of each root action (full-width searches that
            visit every action once report ones).
        stats: Algorithm-specific figures (iterations, nodes, simulated steps, ...).
    """

    action: Any
    values: np.ndarray
    visits: np.ndarray
    stats: Mapping[str, float] = field(default_factory=dict)


SearchFunction = Callable[[Any, Any, np.random.Generator], SearchResult]
"""``search(model, root_state, rng) -> SearchResult``: one decision of a search algorithm."""


class SearchAgent(Agent):
    """Acts by running a search function on the planning model handed over at each step.

    Args:
        search: ``search(model, root_state, rng) -> SearchResult``, hyper-parameters bound.
        name: How the agent is called in reports (default: the function's name).
    """

    def __init__(self, search: SearchFunction, name: str | None = None) -> None:
        if not callable(search):
            raise TypeError(f"search={search!r} must be a callable (model, state, rng) -> result")
        self.search = search
        self.name = name or getattr(search, "__name__", None) or type(search).__name__
        self.last_result: SearchResult | None = None

    @property
    def needs_model(self) -> bool:
        """Search plans on the handed model at every step."""
        return True

    def act(self, observation: dict[str, Any], model: Any | None = None) -> Any:
        """Search from the model's current state and play the chosen action.

        Raises:
            ValueError: No planning model was handed over.
        """
        if model is None:
            raise ValueError(f"{self.name} needs a planning model (model=None was given)")
        self.last_result = self.search(model, model.get_state(), self.rng)
        return self.last_result.action

    def __repr__(self) -> str:
        return f"SearchAgent({self.name})"
