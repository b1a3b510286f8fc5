"""Finite-horizon backward induction over time-indexed outcome tables.

Step ``t`` of an episode (``t = 0 .. H-1``) draws its transition from table ``tables[t]``; the
episode is cut after ``H`` transitions, so ``V_H ≡ 0``, and an outcome that ends the episode
contributes its reward and nothing after it::

    Q_t(s, a) = Σ_k probs_t[s, a, k] · (rewards[s, a, k] + γ · (1 - terminals[s, a, k]) ·
                                          V_{t+1}(next_states[s, a, k]))
    V_t(s)    = max_a Q_t(s, a)

The default ``γ = 1`` is the NS-Gym paper's metric (the undiscounted episode return). Every
backup is one vectorised numpy expression over all states, actions and outcomes, so a
200-step CliffWalking solve costs milliseconds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ns_pz.planning import TabularOutcomes


@dataclass(frozen=True)
class FiniteHorizonSolution:
    """Values and a time-indexed policy.

    Attributes:
        values: ``[H + 1, num_states]``; ``values[t, s]`` is the value of being in ``s`` before
            transition ``t``; ``values[H]`` is zero.
        q_values: ``[H, num_states, num_actions]``.
        policy: ``[H, num_states]`` int64, a maximising action (ties: lowest index).
        gamma: The discount the solution was computed with.
    """

    values: np.ndarray
    q_values: np.ndarray
    policy: np.ndarray
    gamma: float

    @property
    def horizon(self) -> int:
        """Number of transitions ``H`` the solution covers."""
        return int(self.policy.shape[0])


def backward_induction(
    tables: Sequence[TabularOutcomes], gamma: float = 1.0
) -> FiniteHorizonSolution:
    """Optimal values and policy when transition ``t`` follows ``tables[t]``.

    Args:
        tables: One outcome table per step (length ``H >= 1``); entries may repeat (a
            stationary model is ``[table] * H``). All must have the same shape.
        gamma: Discount in ``[0, 1]``.

    Raises:
        TypeError / ValueError: ``tables`` is empty, holds something else than
            :class:`~ns_pz.planning.TabularOutcomes`, or has tables of different shapes;
            ``gamma`` is outside ``[0, 1]``.
    """
    shape = check_tables(tables)
    gamma = check_gamma(gamma)
    horizon, (num_states, num_actions, _) = len(tables), shape
    values = np.zeros((horizon + 1, num_states))
    q_values = np.empty((horizon, num_states, num_actions))
    for t in range(horizon - 1, -1, -1):
        q_values[t] = backup(tables[t], values[t + 1], gamma)
        values[t] = q_values[t].max(axis=1)
    return FiniteHorizonSolution(values, q_values, q_values.argmax(axis=2), gamma)


def evaluate_policy(
    tables: Sequence[TabularOutcomes], policy: np.ndarray, gamma: float = 1.0
) -> np.ndarray:
    """Exact expected return of a time-indexed policy when transition ``t`` follows ``tables[t]``.

    Args:
        tables: One outcome table per step, as for :func:`backward_induction`.
        policy: ``[H, num_states]`` actions, ``H = len(tables)``.
        gamma: Discount in ``[0, 1]``.

    Returns:
        ``[H + 1, num_states]`` values; ``values[H]`` is zero.

    Raises:
        ValueError: ``policy`` does not have shape ``[H, num_states]`` or holds an action out
            of range (and the errors of :func:`backward_induction`).
    """
    num_states, num_actions, _ = check_tables(tables)
    gamma = check_gamma(gamma)
    horizon = len(tables)
    policy = np.asarray(policy)
    if policy.shape != (horizon, num_states) or not np.issubdtype(policy.dtype, np.integer):
        raise ValueError(
            f"policy has shape {policy.shape} and dtype {policy.dtype}; expected integer "
            f"actions of shape ({horizon}, {num_states})"
        )
    if policy.size and (policy.min() < 0 or policy.max() >= num_actions):
        raise ValueError(f"policy holds actions outside 0..{num_actions - 1}")
    values = np.zeros((horizon + 1, num_states))
    rows = np.arange(num_states)
    for t in range(horizon - 1, -1, -1):
        table = tables[t]
        chosen = TabularOutcomes(
            table.probs[rows, policy[t]][:, None, :],
            table.next_states[rows, policy[t]][:, None, :],
            table.rewards[rows, policy[t]][:, None, :],
            table.terminals[rows, policy[t]][:, None, :],
        )
        values[t] = backup(chosen, values[t + 1], gamma)[:, 0]
    return values


def backup(table: TabularOutcomes, next_values: np.ndarray, gamma: float) -> np.ndarray:
    """``[num_states, num_actions]`` Q-values of one step given the values after it."""
    continuation = np.where(table.terminals, 0.0, next_values[table.next_states])
    return np.einsum("sak,sak->sa", table.probs, table.rewards + gamma * continuation)


def check_tables(tables: Sequence[TabularOutcomes]) -> tuple[int, int, int]:
    """Validate a non-empty sequence of same-shaped outcome tables; return their shape.

    Raises:
        TypeError: ``tables`` is not a sequence of :class:`~ns_pz.planning.TabularOutcomes`.
        ValueError: It is empty or the shapes differ.
    """
    if isinstance(tables, TabularOutcomes) or not isinstance(tables, Sequence):
        raise TypeError(
            f"tables={tables!r} must be a sequence of TabularOutcomes, one per step "
            "(a stationary model: [table] * horizon)"
        )
    if not tables:
        raise ValueError("tables=[] is empty; give one outcome table per step (horizon >= 1)")
    for t, table in enumerate(tables):
        if not isinstance(table, TabularOutcomes):
            raise TypeError(f"tables[{t}]={table!r} is not a TabularOutcomes")
    shape = tables[0].probs.shape
    for t, table in enumerate(tables):
        if table.probs.shape != shape:
            raise ValueError(
                f"tables[{t}] has shape {table.probs.shape}, tables[0] has {shape}; "
                "all steps must share one state and action space"
            )
    return shape


def check_gamma(gamma: object) -> float:
    """Validate a discount in ``[0, 1]``.

    Raises:
        TypeError: ``gamma`` is not a real number.
        ValueError: It lies outside ``[0, 1]``.
    """
    if isinstance(gamma, bool) or not isinstance(gamma, (int, float, np.integer, np.floating)):
        raise TypeError(f"gamma={gamma!r} must be a real number in [0, 1]")
    if not 0.0 <= float(gamma) <= 1.0:
        raise ValueError(f"gamma={gamma!r} must lie in [0, 1]")
    return float(gamma)
