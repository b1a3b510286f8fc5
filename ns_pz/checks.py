"""Checks of caller input shared by every layer: a flag, a count, a number, a fraction, a seed.

Each returns the value in its plain Python type (a NumPy integer becomes an ``int``) or raises
an error naming the argument, its value and what is allowed. ``bool`` is refused where a number
is wanted, and anything but a ``bool`` where a flag is (``"false"`` would count as true).
"""

from __future__ import annotations

import math
import numbers
from typing import Any


def flag(name: str, value: Any) -> bool:
    """``value`` if it is a bool.

    Raises:
        TypeError: It is not.
    """
    if not isinstance(value, bool):
        raise TypeError(f"{name}={value!r} must be a bool")
    return value


def count(name: str, value: Any, low: int = 1) -> int:
    """``value`` as an int if it is an integer (NumPy's too, not a bool) >= ``low``.

    Raises:
        ValueError: Anything else.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name}={value!r} must be an int >= {low}")
    return int(value)


def positive_number(name: str, value: Any) -> float:
    """``value`` as a float if it is a finite real number > 0 (a bool is refused).

    Raises:
        ValueError: Anything else.
    """
    number = float(value) if isinstance(value, numbers.Real) and not isinstance(value, bool) else 0
    if not 0.0 < number < math.inf:
        raise ValueError(f"{name}={value!r} must be a finite number > 0")
    return number


def fraction(name: str, value: Any) -> float:
    """``value`` as a float if it is a real number strictly between 0 and 1 (not a bool).

    NumPy's floats are real numbers too (``np.float32(0.1)``).

    Raises:
        ValueError: Anything else.
    """
    number = float(value) if isinstance(value, numbers.Real) and not isinstance(value, bool) else 0
    if not 0.0 < number < 1.0:
        raise ValueError(f"{name}={value!r} must be a number in (0, 1)")
    return number


SB3_SEEDS = 2**32
"""Stable-Baselines3 seeds lie below this (they reach ``np.random.seed``)."""


def seed_value(name: str, value: Any, below: int | None = None) -> int:
    """``value`` as an int if it is an integer (NumPy's too, not a bool) >= 0 (and < ``below``).

    Raises:
        ValueError: Anything else (``None`` too: a seed asked for must be given).
    """
    allowed = "an int >= 0" if below is None else f"an int in [0, {below})"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name}={value!r} must be {allowed}")
    if int(value) < 0 or (below is not None and int(value) >= below):
        raise ValueError(f"{name}={value!r} must be {allowed}")
    return int(value)
