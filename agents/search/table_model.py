"""A planning model over an explicit outcome table, for tables no family owns.

ADA-MCTS plans in a kernel it builds itself at every decision, and tests use hand-written
tables; :class:`OutcomeTableModel` makes such a table a planning model. It samples exactly as
the slip-grid families do (one uniform draw, the first outcome whose cumulative probability
exceeds it), so the reference and compiled searches agree on it bit for bit.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from ns_pz.planning import TabularOutcomes
from ns_pz.states import check_index_state


class OutcomeTableModel:
    """A stationary model that samples transitions from a :class:`TabularOutcomes` table.

    Args:
        outcomes: The table; ``probs`` rows must sum to 1.
        state: The state it starts at.
        rng: The generator its transitions draw from.

    Raises:
        ValueError: The arrays disagree in shape, or a row of ``probs`` is not a distribution.
    """

    def __init__(self, outcomes: TabularOutcomes, state: int, rng: np.random.Generator) -> None:
        check_outcomes(outcomes)
        self.outcomes = outcomes
        self.rng = rng
        self._state = check_index_state(self, state, outcomes.probs.shape[0])
        self.action_space = spaces.Discrete(outcomes.probs.shape[1])
        self._probs = outcomes.probs.tolist()
        self._next = outcomes.next_states.tolist()
        self._rewards = outcomes.rewards.tolist()
        self._terminals = outcomes.terminals.tolist()

    def get_state(self) -> int:
        """The current state."""
        return self._state

    def set_state(self, state: int) -> None:
        """Move to ``state``.

        Raises:
            ValueError: ``state`` is not an integer in ``[0, num_states)``.
        """
        self._state = check_index_state(self, state, len(self._probs))

    def step(self, action: int) -> tuple[int, float, bool]:
        """Advance from the current state: next state, reward, terminal.

        Raises:
            ValueError: ``action`` is not an integer in ``[0, num_actions)``.
        """
        if not (type(action) is int and 0 <= action < self.action_space.n):
            if not self.action_space.contains(action) or isinstance(action, (bool, np.bool_)):
                raise ValueError(
                    f"action={action!r} is outside the action space {self.action_space}"
                )
            action = int(action)
        result = self.transition(self._state, action)
        self._state = result[0]
        return result

    def transition(self, state: int, action: int) -> tuple[int, float, bool]:
        """One sampled transition from ``state`` (one uniform draw from :attr:`rng`).

        Unchecked, for search loops (``set_state`` and ``step`` check what they are given).
        """
        probs = self._probs[state][action]
        u = self.rng.random()
        total = 0.0
        pick = -1
        for k, p in enumerate(probs):
            total += p
            if u < total:
                pick = k
                break
        if pick < 0:  # rounding left the sum below u: the last outcome of positive probability
            pick = max(k for k, p in enumerate(probs) if p > 0.0)
        return (
            self._next[state][action][pick],
            self._rewards[state][action][pick],
            self._terminals[state][action][pick],
        )

    def clone(self) -> OutcomeTableModel:
        """A model at the same state, sharing the table and the generator."""
        return OutcomeTableModel(self.outcomes, self._state, self.rng)


def check_outcomes(outcomes: TabularOutcomes) -> None:
    """Check that a table's arrays agree in shape and its rows are distributions.

    Raises:
        ValueError: They do not.
    """
    shape = np.shape(outcomes.probs)
    if len(shape) != 3:
        raise ValueError(f"outcomes.probs has shape {shape}; expected [states, actions, outcomes]")
    for name in ("next_states", "rewards", "terminals"):
        if np.shape(getattr(outcomes, name)) != shape:
            raise ValueError(
                f"outcomes.{name} has shape {np.shape(getattr(outcomes, name))}, "
                f"probs has {shape}; they must agree"
            )
    probs = np.asarray(outcomes.probs, dtype=np.float64)
    if np.any(probs < 0) or not np.allclose(probs.sum(axis=2), 1.0, atol=1e-8):
        raise ValueError("outcomes.probs must be non-negative with rows summing to 1")
    next_states = np.asarray(outcomes.next_states)
    if np.any(next_states < 0) or np.any(next_states >= shape[0]):
        raise ValueError(f"outcomes.next_states must lie in [0, {shape[0]})")
