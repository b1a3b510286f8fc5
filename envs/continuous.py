"""What the continuous-action families share: Gymnasium-style action checks and float32 rounding.

Gymnasium's continuous classic-control envs take any finite action and clip it inside ``step``;
:func:`check_box_action` accepts exactly those (right shape, finite) and refuses the rest with a
``ValueError``, leaving the clipping to the family's ``step`` so that the reward sees the action
as given, as Gymnasium's does.

Those envs also compute partly in float32: a float32 action, or a state stored as float32, makes
NumPy 2 round intermediate results to float32 (NEP 50: a Python float meeting a float32 is cast
to float32). :func:`f32` rounds a Python float to the nearest float32 value; because a double
holds more than twice float32's precision, ``f32(a op b)`` for float32 values ``a``, ``b`` and
``op`` in ``+ - * /`` is exactly the float32 result NumPy computes.
"""

from __future__ import annotations

import math
import struct
from typing import Any

import numpy as np
from gymnasium import spaces

_FLOAT32 = struct.Struct("f")
_pack = _FLOAT32.pack
_unpack = _FLOAT32.unpack


def f32(x: float) -> float:
    """``x`` rounded to the nearest float32 (ties to even), as a Python float.

    Raises:
        OverflowError: ``|x|`` is finite but beyond float32's range.
    """
    return _unpack(_pack(x))[0]  # type: ignore[no-any-return]


def check_box_action(space: spaces.Box, action: Any) -> np.ndarray:
    """``action`` as an array of the space's dtype and shape; finite, possibly out of bounds.

    Always a new array: the process keeps it as the last action (the monitor observes it), so it
    must not change when the caller reuses its own buffer for the next action.

    Args:
        space: The family's action space (a float Box).
        action: What the caller passed: an array, a list, a tuple.

    Raises:
        ValueError: ``action`` is not numeric, has another shape, or holds NaN or infinity.
    """
    if (  # the common case, checked cheaply
        type(action) is np.ndarray
        and action.dtype == space.dtype
        and action.shape == space.shape
        and action.size == 1
        and math.isfinite(action.item())
    ):
        return action.copy()
    clipping = f"low={space.low.tolist()}, high={space.high.tolist()}"
    try:
        array = np.array(action, dtype=space.dtype)  # a copy, even of a view or a subclass
    except (TypeError, ValueError):
        raise ValueError(
            f"action={action!r} is not a numeric array; allowed: finite values of shape "
            f"{space.shape} (the action space is {clipping})"
        ) from None
    if array.shape != space.shape:
        raise ValueError(
            f"action={action!r} has shape {array.shape}; allowed: shape {space.shape}, "
            f"e.g. np.array({[0.0] * space.shape[0]!r}, dtype=np.{space.dtype})"
        )
    finite = math.isfinite(array.item()) if array.size == 1 else bool(np.isfinite(array).all())
    if not finite:
        raise ValueError(
            f"action={action!r} is not finite; allowed: finite values of shape {space.shape} "
            f"(the action space is {clipping}; the dynamics decide what lies beyond it)"
        )
    return array
