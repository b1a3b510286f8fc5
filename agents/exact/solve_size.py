"""How big an exact solve is before it starts, and a refusal that names the estimate.

Every solver on a nature grid runs over ``H × S × m × levels`` stages (steps, the agent's
states, grid points, budget levels) and, one step at a time, builds the payoffs
``G_t[i, b, j, s, a]``: ``m · levels · m · S · A`` float64 numbers, the largest array by far
(:mod:`ns_pz.agents.exact.game_stages`). Its peak memory is about::

    8 bytes · (H · S · m · levels · (2 + held) + copies · m · levels · m · S · A)

with ``held`` the numbers kept per stage besides the values and choices (the equilibrium's
``A + m`` probabilities for :func:`~ns_pz.agents.exact.game_value.solve_game`, the fixed
strategy's for the best responses) and ``copies`` the payoff-sized temporaries (6 for the
matrix games, 3 for the best responses: measured with ``tracemalloc`` on FrozenLake 8x8,
21 points, 13 levels). A solve whose estimate passes ``max_bytes`` is refused before it
allocates anything, with the estimate in the message: a grid step of 0.00625 with a budget
once spent minutes before running out of memory in its first step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

DEFAULT_MAX_BYTES = 4 * 2**30
"""Largest estimated peak memory a solve may take unless the caller allows more (4 GiB)."""

DEFAULT_MAX_POINTS = 1000
"""Most grid points a grid builder makes unless the caller allows more (``m²`` moves are
measured one by one, about 8 µs each: 1000 points take ~8 s)."""


@dataclass(frozen=True)
class SolveSize:
    """The size of one solve on a grid.

    Attributes:
        what: The solver, for messages.
        horizon: ``H``.
        states: ``S``.
        actions: ``A``.
        points: ``m``, grid points.
        levels: Budget levels.
        held: Numbers kept per stage besides values and choices.
        copies: Payoff-sized temporaries of one step.
        extra_bytes: Memory beyond the stages (an open-loop search's frontier).
    """

    what: str
    horizon: int
    states: int
    actions: int
    points: int
    levels: int
    held: int
    copies: int
    extra_bytes: int = 0

    @property
    def stages(self) -> int:
        """``H · S · m · levels``."""
        return self.horizon * self.states * self.points * self.levels

    @property
    def step_payoffs(self) -> int:
        """Numbers in one step's payoff array ``m · levels · m · S · A``."""
        return self.points * self.levels * self.points * self.states * self.actions

    @property
    def bytes(self) -> int:
        """Estimated peak memory (module docstring)."""
        values = self.stages + self.states * self.points * self.levels  # V_0 .. V_H
        kept = values + self.stages * (1 + self.held)  # and a choice per stage
        return 8 * (kept + self.copies * self.step_payoffs) + self.extra_bytes

    def describe(self) -> str:
        """The estimate in words, as the refusal and progress lines print it."""
        return (
            f"{self.states} states × {self.points} θ × {self.levels} budget levels × "
            f"{self.horizon} steps = {self.stages:,} stages, {self.step_payoffs:,} payoffs a "
            f"step, about {_gib(self.bytes)} at peak"
        )

    def check(self, max_bytes: float) -> None:
        """Refuse the solve when its estimate passes ``max_bytes``.

        Raises:
            TypeError: ``max_bytes`` is not a number.
            ValueError: ``max_bytes`` is not > 0, or the estimate is beyond it.
        """
        check_max_bytes(max_bytes)
        if self.bytes > max_bytes:
            raise ValueError(
                f"{self.what} is too large: {self.describe()}, beyond max_bytes="
                f"{max_bytes!r} ({_gib(max_bytes)}). Coarsen the grid (a larger step, fewer "
                "points), shorten the horizon or the budget (fewer levels), or pass a larger "
                "max_bytes if the machine has the memory"
            )


def check_max_bytes(max_bytes: object) -> float:
    """Validate a memory limit (a number > 0; ``inf`` allowed).

    Raises:
        TypeError: Not a number.
        ValueError: Not > 0 (NaN included).
    """
    if isinstance(max_bytes, bool) or not isinstance(max_bytes, (int, float)):
        raise TypeError(f"max_bytes={max_bytes!r} must be a number of bytes > 0")
    if not max_bytes > 0:
        raise ValueError(f"max_bytes={max_bytes!r} must be > 0")
    return float(max_bytes)


def check_max_points(points: int, max_points: object) -> None:
    """Refuse a grid of more than ``max_points`` points before it is built.

    Raises:
        TypeError: ``max_points`` is not an int.
        ValueError: ``max_points < 1``, or ``points`` is beyond it.
    """
    if isinstance(max_points, bool) or not isinstance(max_points, int):
        raise TypeError(f"max_points={max_points!r} must be an int >= 1")
    if max_points < 1:
        raise ValueError(f"max_points={max_points!r} must be >= 1")
    if points > max_points:
        raise ValueError(
            f"the grid would have {points:,} points, beyond max_points={max_points}: its "
            f"{points:,}² = {points * points:,} moves take about {_duration(8e-6 * points**2)} "
            f"to measure, and one solve step on it needs {_gib(8.0 * points**2)} per state, "
            "action and budget level. Use a larger step, or pass a larger max_points"
        )


def _gib(size: float) -> str:
    if math.isinf(size):
        return "unlimited"
    if size < 2**20:
        return f"{size / 2**10:.1f} KiB"
    if size < 2**30:
        return f"{size / 2**20:.1f} MiB"
    return f"{size / 2**30:.1f} GiB"


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
