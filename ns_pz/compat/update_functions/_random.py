"""The generator of a compat update function's standalone calls."""

from __future__ import annotations

import numpy as np


def seeded(seed: int | None) -> np.random.Generator:
    """``numpy.random.default_rng(seed)``, with the seed checked.

    Raises:
        TypeError: ``seed`` is neither ``None`` nor a non-negative int.
    """
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))):
        raise TypeError(f"seed={seed!r} must be an int or None")
    if seed is not None and seed < 0:
        raise ValueError(f"seed={seed!r} must be >= 0")
    return np.random.default_rng(seed)
