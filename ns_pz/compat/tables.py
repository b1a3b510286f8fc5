"""NS-Gym's (and Gymnasium's toy-text) transition table, computed from a grid family and θ.

``P[s][a]`` is a sequence of ``(probability, next_state, reward, terminated)`` tuples, one per
slip outcome in the order of the slip vector; a state where the episode has ended has the one
entry ``(1.0, s, 0.0, True)``. The table is read-only (a view of θ, which only nature changes)
and is built once per (family, θ): reading ``P[s][a]`` in a loop costs a dictionary lookup.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import lru_cache
from types import MappingProxyType

from ns_pz.family import EnvFamily
from ns_pz.params import Params

Table = Mapping[int, Mapping[int, Sequence[tuple[float, int, float, bool]]]]


def transition_table(family: EnvFamily, theta: Params) -> Table:
    """``P[s][a]`` of a tabular family under ``theta``, as NS-Gym lays it out.

    Raises:
        TypeError: ``family`` has no explicit outcome table (not a grid world).
    """
    if not hasattr(family, "outcomes") or not hasattr(family, "is_terminal_state"):
        raise TypeError(f"{family!r} has no transition table (it is not a grid world)")
    return _table(family, theta)


@lru_cache(maxsize=16)
def _table(family: EnvFamily, theta: Params) -> Table:
    outcomes = family.outcomes(theta)  # type: ignore[attr-defined]
    num_states, num_actions, num_outcomes = outcomes.probs.shape
    probs = outcomes.probs.tolist()
    next_states = outcomes.next_states.tolist()
    rewards = outcomes.rewards.tolist()
    terminals = outcomes.terminals.tolist()
    table: dict[int, Mapping[int, Sequence[tuple[float, int, float, bool]]]] = {}
    for s in range(num_states):
        ended = family.is_terminal_state(s)  # type: ignore[attr-defined]
        row: dict[int, Sequence[tuple[float, int, float, bool]]] = {}
        for a in range(num_actions):
            if ended:
                row[a] = ((1.0, s, 0.0, True),)
            else:
                row[a] = tuple(
                    (
                        probs[s][a][k],
                        int(next_states[s][a][k]),
                        float(rewards[s][a][k]),
                        bool(terminals[s][a][k]),
                    )
                    for k in range(num_outcomes)
                )
        table[s] = MappingProxyType(row)
    return MappingProxyType(table)
