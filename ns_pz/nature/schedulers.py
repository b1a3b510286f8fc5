"""Schedulers: *when* nature changes a parameter.

A scheduler is called once per time step with the step index ``t`` (the number of transitions
completed since reset) and nature's generator, and answers whether the parameter changes at that
step. A change that fires at step ``t`` applies to transition ``t``: ``DiscreteScheduler({1})``
leaves the first transition (t=0) under θ_0 and changes θ for the second one, which is what the
NS-Gym paper calls "after the first decision epoch".

Every scheduler takes its timing explicitly (``start``, ``event_list`` or ``windows``); none
assumes a default, so the timing of an experiment is always written in its configuration.
Schedulers that count in periods or decay (:class:`PeriodicScheduler`, :class:`BurstScheduler`,
:class:`DecayingProbabilityScheduler`, :class:`MemorylessScheduler`) count from ``start``.

Schedulers hold no state: random ones draw from the generator they are handed (nature's, seeded
at reset), so one scheduler can serve many environments and the same seed gives the same firing
times. A step that is never asked about changes nothing for the steps that are.
"""

from __future__ import annotations

import inspect
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable

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
    """Changes exactly at the listed steps (an empty list: never)."""

    def __init__(self, event_list: Iterable[int]) -> None:
        if isinstance(event_list, (str, bytes)) or not isinstance(event_list, Iterable):
            raise TypeError(f"event_list={event_list!r} must be an iterable of step indices")
        self.event_list = frozenset(check_step("event_list element", t) for t in event_list)

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """True when ``t`` is one of the listed steps."""
        return t in self.event_list


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


class MemorylessScheduler(_WindowedScheduler):
    """Changes after waiting times drawn from Geometric(``p``), counted from ``start``.

    The first change comes ``G_1 >= 1`` steps after ``start``, the next ``G_2`` steps after
    that, and so on. Geometric waiting times are exactly the gaps of a Bernoulli process, so the
    scheduler is implemented as one: each step after ``start`` (never ``start`` itself) fires
    independently with probability ``p``. It keeps no "next firing time", which is why it never
    stops firing when some step is not asked about (NS-Gym's version does).
    """

    def __init__(self, p: float, start: int, end: int | None = None) -> None:
        super().__init__(start, end)
        self.p = check_probability("p", p)

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """A Bernoulli(p) draw on the steps after ``start`` up to ``end``; False elsewhere."""
        return t > self.start and self._active(t) and rng.random() < self.p


class DecayingProbabilityScheduler(_WindowedScheduler):
    """Changes with a probability that decays exponentially from ``start``.

    At step ``t`` of the window the probability is
    ``initial_probability * exp(-decay_rate * (t - start))``; one uniform number is drawn from
    nature's generator at every step of the window.
    """

    def __init__(
        self, initial_probability: float, decay_rate: float, start: int, end: int | None = None
    ) -> None:
        super().__init__(start, end)
        self.initial_probability = check_probability("initial_probability", initial_probability)
        self.decay_rate = check_non_negative("decay_rate", decay_rate)

    def probability(self, t: int) -> float:
        """The firing probability at step ``t`` of the window."""
        return self.initial_probability * math.exp(-self.decay_rate * (t - self.start))

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """A Bernoulli(probability(t)) draw on the window's steps; False outside it."""
        return self._active(t) and rng.random() < self.probability(t)


class BurstScheduler(_WindowedScheduler):
    """Alternates ``on_duration`` firing steps with ``off_duration`` quiet ones from ``start``.

    ``BurstScheduler(2, 3, start=0)`` fires at 0, 1, 5, 6, 10, 11, ...
    """

    def __init__(
        self, on_duration: int, off_duration: int, start: int, end: int | None = None
    ) -> None:
        super().__init__(start, end)
        self.on_duration = check_step("on_duration", on_duration)
        if self.on_duration < 1:
            raise ValueError(f"on_duration={on_duration!r} must be >= 1")
        self.off_duration = check_step("off_duration", off_duration)

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """True in the "on" part of each cycle of the window."""
        cycle = self.on_duration + self.off_duration
        return self._active(t) and (t - self.start) % cycle < self.on_duration


class WindowScheduler(Scheduler):
    """Changes at every step inside any of the inclusive windows ``(first, last)``."""

    def __init__(self, windows: Iterable[tuple[int, int]]) -> None:
        if isinstance(windows, (str, bytes)) or not isinstance(windows, Iterable):
            raise TypeError(f"windows={windows!r} must be an iterable of (first, last) pairs")
        checked = []
        for i, window in enumerate(windows):
            if isinstance(window, (str, bytes)) or not isinstance(window, Iterable):
                raise TypeError(f"windows[{i}]={window!r} must be a (first, last) pair")
            pair = tuple(window)
            if len(pair) != 2:
                raise ValueError(f"windows[{i}]={window!r} must have 2 elements (first, last)")
            first = check_step(f"windows[{i}] first", pair[0])
            last = check_step(f"windows[{i}] last", pair[1])
            if last < first:
                raise ValueError(
                    f"windows[{i}]={window!r} ends before it starts; need first <= last"
                )
            checked.append((first, last))
        self.windows = tuple(checked)

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """True when ``t`` lies in one of the windows."""
        return any(first <= t <= last for first, last in self.windows)


class CustomScheduler(Scheduler):
    """Changes when a function of the step says so.

    Args:
        event_function: Called as ``event_function(t, rng)`` and returns a bool. ``rng`` is
            nature's generator: draw any randomness from it, never from a generator of your own,
            so that a seed reproduces the run.
    """

    def __init__(self, event_function: Callable[[int, np.random.Generator], bool]) -> None:
        if not callable(event_function):
            raise TypeError(f"event_function={event_function!r} must be callable as f(t, rng)")
        try:
            inspect.signature(event_function).bind(0, None)
        except TypeError:
            raise TypeError(
                f"event_function={event_function!r} must accept two arguments (t, rng)"
            ) from None
        except ValueError:  # some builtins have no signature; let the first call tell
            pass
        self.event_function = event_function

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """The function's answer.

        Raises:
            TypeError: The function returned something that is not a bool (or 0/1).
        """
        result = self.event_function(t, rng)
        if isinstance(result, (bool, np.bool_)):
            return bool(result)
        if isinstance(result, (int, np.integer)) and result in (0, 1):
            return bool(result)
        raise TypeError(
            f"event_function returned {result!r} at t={t}; it must return a bool (or 0 / 1)"
        )


def check_step(name: str, value: object) -> int:
    """Validate a non-negative whole step count and return it as ``int``.

    Raises:
        TypeError: ``value`` is not an integer.
        ValueError: ``value`` is negative.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        endless = isinstance(value, float) and math.isinf(value)
        hint = " (no end: end=None)" if name == "end" and endless else ""
        raise TypeError(f"{name}={value!r} must be an int (a step index){hint}")
    if value < 0:
        raise ValueError(f"{name}={value!r} must be >= 0")
    return int(value)


def check_non_negative(name: str, value: object) -> float:
    """Validate a finite real number >= 0 and return it as ``float``.

    Raises:
        TypeError: ``value`` is not a real number.
        ValueError: ``value`` is NaN, infinite or negative.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}={value!r} must be a real number")
    number = float(value)
    if not math.isfinite(number) or number < 0.0:
        raise ValueError(f"{name}={value!r} must be a finite number >= 0")
    return number


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
