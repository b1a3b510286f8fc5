"""Schedulers: *when* nature changes a parameter.

A scheduler is called once per time step with the step index ``t`` (the number of transitions
completed since reset) and nature's generator, and answers whether the parameter changes at that
step. A change that fires at step ``t`` applies to transition ``t``: ``DiscreteScheduler({1})``
leaves the first transition (t=0) under θ_0 and changes θ for the second one, which is what the
NS-Gym paper calls "after the first decision epoch".

Every scheduler takes its first active step explicitly (``start`` or ``event_times``); none
assumes a default, so the timing of an experiment is always written in its configuration.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Iterable

import numpy as np


class Scheduler(ABC):
    """Decides at which time steps a parameter changes."""

    @abstractmethod
    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """Whether the parameter changes at step ``t``; random schedulers draw from ``rng``."""

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in vars(self).items())
        return f"{type(self).__name__}({args})"


class _WindowedScheduler(Scheduler, ABC):
    """A scheduler active on the steps ``start <= t <= end`` (``end=None``: forever)."""

    def __init__(self, start: int, end: int | None) -> None:
        self.start = check_step("start", start)
        self.end = None if end is None else check_step("end", end)
        if self.end is not None and self.end < self.start:
            raise ValueError(f"end={end!r} is before start={start!r}; need end >= start")

    def _active(self, t: int) -> bool:
        return t >= self.start and (self.end is None or t <= self.end)


class ContinuousScheduler(_WindowedScheduler):
    """Changes at every step from ``start`` to ``end`` inclusive."""

    def __init__(self, start: int, end: int | None = None) -> None:
        super().__init__(start, end)

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """True on every step of the window."""
        return self._active(t)


class DiscreteScheduler(Scheduler):
    """Changes exactly at the listed steps."""

    def __init__(self, event_times: Iterable[int]) -> None:
        if isinstance(event_times, (str, bytes)) or not isinstance(event_times, Iterable):
            raise TypeError(f"event_times={event_times!r} must be an iterable of step indices")
        self.event_times = frozenset(check_step("event_times element", t) for t in event_times)

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """True when ``t`` is one of the event times."""
        return t in self.event_times


class PeriodicScheduler(_WindowedScheduler):
    """Changes every ``period`` steps, at ``start``, ``start + period``, ... up to ``end``."""

    def __init__(self, period: int, start: int, end: int | None = None) -> None:
        super().__init__(start, end)
        self.period = check_step("period", period)
        if self.period < 1:
            raise ValueError(f"period={period!r} must be >= 1")

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """True on the window's steps that are a whole number of periods after ``start``."""
        return self._active(t) and (t - self.start) % self.period == 0


class RandomScheduler(_WindowedScheduler):
    """Changes at each step of the window independently with ``probability``.

    Draws one uniform number from nature's generator at every step of the window, so the same
    seed gives the same change times.
    """

    def __init__(self, probability: float, start: int, end: int | None = None) -> None:
        super().__init__(start, end)
        self.probability = check_probability("probability", probability)

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """A Bernoulli(probability) draw on the window's steps; False outside it."""
        return self._active(t) and rng.random() < self.probability


def check_step(name: str, value: object) -> int:
    """Validate a non-negative whole step count and return it as ``int``.

    Raises:
        TypeError: ``value`` is not an integer.
        ValueError: ``value`` is negative.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name}={value!r} must be an int (a step index)")
    if value < 0:
        raise ValueError(f"{name}={value!r} must be >= 0")
    return int(value)


def check_probability(name: str, value: object) -> float:
    """Validate a probability in [0, 1] and return it as ``float``.

    Raises:
        TypeError: ``value`` is not a real number.
        ValueError: ``value`` is NaN or outside [0, 1].
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}={value!r} must be a real number")
    number = float(value)
    if math.isnan(number) or not 0.0 <= number <= 1.0:
        raise ValueError(f"{name}={value!r} must lie in [0, 1]")
    return number
