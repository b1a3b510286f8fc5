"""Checks on simulator states that callers hand to a planning model (``set_state``).

A planning model's own transitions only ever produce valid states, so search loops that feed
back what the model returned skip these checks (:meth:`~ns_pz.planning.PlanningModel.transition`
is the unchecked fast path). A state coming from outside is checked once, here: a grid state is
a cell index in range, a physical state a tuple of finite reals of the right length, inside the
bounds the dynamics keep it in. Errors are ``ValueError`` naming the state, the offending field
and what is allowed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

Bounds = tuple[float, float] | None
"""``(low, high)`` a field must lie in, or ``None`` for any finite value."""


def check_index_state(owner: object, state: Any, num_states: int) -> int:
    """``state`` as an ``int`` in ``[0, num_states)``.

    Args:
        owner: What the state belongs to (named in the message), e.g. the family.
        state: The candidate: an ``int`` or NumPy integer (``bool`` is refused).
        num_states: Number of states.

    Raises:
        ValueError: ``state`` is not an integer in range.
    """
    if type(state) is int and 0 <= state < num_states:
        return state
    if isinstance(state, (int, np.integer)) and not isinstance(state, (bool, np.bool_)):
        if 0 <= int(state) < num_states:
            return int(state)
    raise ValueError(
        f"state={state!r} is not a state of {owner!r}; allowed: an int in [0, {num_states})"
    )


def check_real_state(
    owner: object, state: Any, fields: Sequence[str], bounds: Sequence[Bounds] | None = None
) -> tuple[float, ...]:
    """``state`` as a tuple of Python floats, one per field, finite and inside ``bounds``.

    Args:
        owner: What the state belongs to (named in the message), e.g. the family.
        state: The candidate: a tuple, list or 1-D array of real numbers.
        fields: Name of each entry, in order.
        bounds: ``(low, high)`` or ``None`` per field; default: any finite value.

    Raises:
        ValueError: ``state`` has another length, an entry is not a real number, is NaN or
            infinite, or lies outside its bounds.
    """
    if (  # the common case, a state the model returned: checked cheaply
        type(state) is tuple
        and len(state) == len(fields)
        and all(type(value) is float for value in state)
        and math.isfinite(sum(state))  # NaN or infinity in any entry makes the sum so
    ):
        values: Sequence[float] = state
    else:
        values = _real_values(owner, state, fields)
    if bounds is not None:
        for name, number, limits in zip(fields, values, bounds, strict=True):
            if limits is not None and not limits[0] <= number <= limits[1]:
                raise ValueError(
                    f"state={state!r} of {owner!r}: {name}={number!r} is outside "
                    f"[{limits[0]}, {limits[1]}], where the dynamics keep it"
                )
    return tuple(values)


def _real_values(owner: object, state: Any, fields: Sequence[str]) -> list[float]:
    """The entries of ``state`` as finite floats, or a ``ValueError`` naming the bad one."""
    allowed = f"allowed: a tuple of {len(fields)} finite floats ({', '.join(fields)})"
    if isinstance(state, (str, bytes)) or not isinstance(state, (Sequence, np.ndarray)):
        raise ValueError(f"state={state!r} is not a state of {owner!r}; {allowed}")
    if len(state) != len(fields):
        raise ValueError(f"state={state!r} of {owner!r} has {len(state)} entries; {allowed}")
    values = []
    for name, value in zip(fields, state, strict=True):
        if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, float, np.integer, np.floating)
        ):
            raise ValueError(
                f"state={state!r} of {owner!r}: {name}={value!r} is not a real number; {allowed}"
            )
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(
                f"state={state!r} of {owner!r}: {name}={value!r} is not finite; {allowed}"
            )
        values.append(number)
    return values


def check_observable_state(family: Any, state: Any) -> Any:
    """``state`` unchanged if its observation lies in the family's observation space.

    The fallback for families that declare no check of their own.

    Raises:
        ValueError: ``family.observe(state)`` fails or falls outside the observation space.
    """
    try:
        observation = family.observe(state)
        inside = family.observation_space.contains(observation)
    except (TypeError, ValueError, IndexError, KeyError, AttributeError) as error:
        raise ValueError(
            f"state={state!r} is not a state of {family!r} ({type(error).__name__}: {error})"
        ) from None
    if not inside:
        raise ValueError(
            f"state={state!r} is not a state of {family!r}: its observation {observation!r} "
            f"is outside the observation space {family.observation_space}"
        )
    return state
