"""Planning models: what search agents simulate, thousands of times per decision.

A :class:`PlanningModel` is stationary (θ is frozen inside it: planning never sees future
changes) and cheap to save and restore, because the simulator state is a small immutable value.
Search code either drives it statefully (``set_state`` / ``step``, the NS-Gym interface, which
validate what they are given) or calls the pure :meth:`PlanningModel.transition`, the unchecked
fast path for loops that only pass back states and actions the model itself produced.

Tabular families also hand out the explicit outcome table (:class:`TabularOutcomes`): outcome
``k`` of action ``a`` in state ``s`` has probability ``probs[s, a, k]`` and leads to
``next_states[s, a, k]`` with ``rewards[s, a, k]`` and ``terminals[s, a, k]``. Only ``probs``
depends on θ; the other arrays belong to the map and are shared by every snapshot.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ns_pz.params import Params

if TYPE_CHECKING:
    from ns_pz.family import EnvFamily, State


class PlanningModel:
    """A stationary generative model of one family under a fixed θ.

    Args:
        family: The environment family.
        theta: The θ the model assumes, frozen for its lifetime.
        state: The state it starts at.
        rng: The generator its transitions draw from.
    """

    __slots__ = ("family", "theta", "rng", "_state", "_step")

    def __init__(
        self, family: EnvFamily, theta: Params, state: State, rng: np.random.Generator
    ) -> None:
        self.family = family
        self.theta = theta
        self.rng = rng
        self._state = state
        self._step = family.step

    @property
    def action_space(self) -> Any:
        """The family's action space."""
        return self.family.action_space

    def get_state(self) -> State:
        """The current simulator state (immutable: keep it to restore later)."""
        return self._state

    def set_state(self, state: State) -> None:
        """Restore a state returned by :meth:`get_state` (or any valid state of the family).

        Raises:
            ValueError: ``state`` is not a state of the family (see ``family.check_state``):
                e.g. a cell index out of range, or a physical state with NaN in it.
        """
        self._state = self.family.check_state(state)

    def step(self, action: Any) -> tuple[State, float, bool]:
        """Advance from the current state: next state, reward, terminal.

        Raises:
            ValueError: ``action`` is not in the family's action space.
        """
        action = self.family.check_action(action)
        result = self._step(self._state, action, self.theta, self.rng)
        self._state = result[0]
        return result

    def transition(self, state: State, action: Any) -> tuple[State, float, bool]:
        """One sampled transition from ``state``, leaving the model's own state alone.

        Unchecked, for search loops: ``state`` must come from this model (:meth:`get_state`,
        an earlier transition) and ``action`` must be in the action space; anything else gives
        undefined results. Use :meth:`set_state` and :meth:`step` for values from elsewhere.
        """
        return self._step(state, action, self.theta, self.rng)

    def clone(self) -> PlanningModel:
        """A model at the same state, θ and generator (sharing them: state values are immutable)."""
        return type(self)(self.family, self.theta, self._state, self.rng)


@dataclass(frozen=True)
class TabularOutcomes:
    """The explicit transition table of a tabular family under one θ.

    Attributes:
        probs: ``[num_states, num_actions, num_outcomes]`` float64, rows sum to 1.
        next_states: ``[num_states, num_actions, num_outcomes]`` int64.
        rewards: ``[num_states, num_actions, num_outcomes]`` float64, reward of that outcome.
        terminals: ``[num_states, num_actions, num_outcomes]`` bool, whether it ends the episode.
        landing_cells: ``[num_states, num_actions, num_outcomes]`` int64, the grid cell the
            outcome's move enters before the family's rule moves the agent on (CliffWalking: a
            cliff cell, where ``next_states`` holds the start it sends the agent back to). A
            ground metric between outcomes is measured between these. ``None``: the next
            states are those cells.
    """

    probs: np.ndarray
    next_states: np.ndarray
    rewards: np.ndarray
    terminals: np.ndarray
    landing_cells: np.ndarray | None = None

    @property
    def cells(self) -> np.ndarray:
        """``landing_cells``, or ``next_states`` where the table has none."""
        return self.next_states if self.landing_cells is None else self.landing_cells


class TabularModel(PlanningModel):
    """A planning model that also exposes its explicit outcome table."""

    __slots__ = ("_outcomes",)

    def __init__(
        self, family: EnvFamily, theta: Params, state: State, rng: np.random.Generator
    ) -> None:
        super().__init__(family, theta, state, rng)
        self._outcomes: TabularOutcomes | None = None

    @property
    def outcomes(self) -> TabularOutcomes:
        """The outcome table under this model's θ (built on first use, then kept)."""
        if self._outcomes is None:
            self._outcomes = self.family.outcomes(self.theta)  # type: ignore[attr-defined]
        return self._outcomes
