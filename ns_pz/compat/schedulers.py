"""NS-Gym's schedulers (``ns_gym.schedulers``) with NS-Gym's defaults and conventions.

Every scheduler is active on ``start <= t <= end`` (``start=0``, ``end=inf``) and counts in
absolute time: ``PeriodicScheduler(3, start=2)`` fires at 3, 6, 9, ... as in NS-Gym. Random
schedulers take ``seed=`` for standalone calls; inside a wrapper they draw from the generator the
wrapper's ``reset(seed=...)`` seeds (NS-Gym replays the same pattern every episode and ignores
the reset seed). ``MemorylessScheduler`` counts its geometric waiting times from ``start`` and
never stops firing when a step is skipped (NS-Gym's does).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from ns_pz.compat.base import Scheduler, seeded_generator
from ns_pz.nature import schedulers as native

__all__ = [
    "BurstScheduler",
    "ContinuousScheduler",
    "CustomScheduler",
    "DecayingProbabilityScheduler",
    "DiscreteScheduler",
    "MemorylessScheduler",
    "PeriodicScheduler",
    "RandomScheduler",
    "WindowScheduler",
]


class _NativeBacked(Scheduler):
    """A scheduler computed by a native rule (which counts from step 0)."""

    _rule: native.Scheduler
    rng: Any = None

    def _check(self, t: Any) -> bool:
        return self._rule(t, self.rng)

    def _native_rule(self) -> native.Scheduler:
        return self._rule

    def runs_natively(self) -> bool:
        """True unless a subclass overrides ``_check`` (then a wrapper runs a copy of it)."""
        return type(self)._check is _NativeBacked._check


class ContinuousScheduler(_NativeBacked):
    """Fires at every step of the window."""

    def __init__(self, start: int | float = 0, end: int | float = np.inf) -> None:
        super().__init__(start, end)
        self._rule = native.ContinuousScheduler(start=0)


class DiscreteScheduler(_NativeBacked):
    """Fires at the steps of ``event_list`` (which must lie inside the window)."""

    def __init__(
        self, event_list: Iterable[int], start: int | float = 0, end: int | float = np.inf
    ) -> None:
        super().__init__(start, end)
        self._rule = native.DiscreteScheduler(event_list)
        self.event_list = set(self._rule.event_list)
        outside = sorted(t for t in self.event_list if not self.start <= t <= self.end)
        if outside:
            raise ValueError(
                f"event_list has steps {outside} outside the window [start={start!r}, end={end!r}]"
            )


class PeriodicScheduler(_NativeBacked):
    """Fires when ``t % period == 0`` (absolute ``t``) inside the window."""

    def __init__(self, period: int, start: int | float = 0, end: int | float = np.inf) -> None:
        super().__init__(start, end)
        self._rule = native.PeriodicScheduler(period, start=0)
        self.period = self._rule.period


class RandomScheduler(_NativeBacked):
    """Fires with ``probability`` at each step of the window."""

    def __init__(
        self,
        probability: float = 0.5,
        start: int | float = 0,
        end: int | float = np.inf,
        seed: int | None = None,
    ) -> None:
        super().__init__(start, end)
        self._rule = native.RandomScheduler(probability, start=0)
        self.probability = self._rule.probability
        self.rng = seeded_generator(self, seed)


class MemorylessScheduler(_NativeBacked):
    """Fires after Geometric(``p``) waiting times counted from ``start`` (never at ``start``)."""

    def __init__(
        self, p: float, start: int | float = 0, end: int | float = np.inf, seed: int | None = None
    ) -> None:
        super().__init__(start, end)
        first = int(self.start) if float(self.start).is_integer() else int(self.start) + 1
        self._rule = native.MemorylessScheduler(p, start=first)
        self.p = self._rule.p
        self.rng = seeded_generator(self, seed)


class DecayingProbabilityScheduler(_NativeBacked):
    """Fires with probability ``initial_probability * exp(-decay_rate * t)`` (absolute ``t``)."""

    def __init__(
        self,
        initial_probability: float,
        decay_rate: float,
        start: int | float = 0,
        end: int | float = np.inf,
        seed: int | None = None,
    ) -> None:
        super().__init__(start, end)
        self._rule = native.DecayingProbabilityScheduler(initial_probability, decay_rate, start=0)
        self.initial_probability = self._rule.initial_probability
        self.decay_rate = self._rule.decay_rate
        self.rng = seeded_generator(self, seed)


class BurstScheduler(_NativeBacked):
    """Fires when ``t % (on_duration + off_duration) < on_duration`` (absolute ``t``)."""

    def __init__(
        self,
        on_duration: int,
        off_duration: int,
        start: int | float = 0,
        end: int | float = np.inf,
    ) -> None:
        super().__init__(start, end)
        self._rule = native.BurstScheduler(on_duration, off_duration, start=0)
        self.on_duration = self._rule.on_duration
        self.off_duration = self._rule.off_duration


class WindowScheduler(_NativeBacked):
    """Fires inside any of the inclusive ``(first, last)`` windows."""

    def __init__(
        self,
        windows: Iterable[tuple[int, int]],
        start: int | float = 0,
        end: int | float = np.inf,
    ) -> None:
        super().__init__(start, end)
        self._rule = native.WindowScheduler(windows)
        self.windows = list(self._rule.windows)


class CustomScheduler(_NativeBacked):
    """Fires when ``event_function(t)`` is true.

    Randomness inside ``event_function`` is the function's own business (NS-Gym's convention);
    to draw from the wrapper's seeded generator use the native
    :class:`ns_pz.nature.CustomScheduler`, whose function receives it.
    """

    def __init__(
        self,
        event_function: Callable[[int], bool],
        start: int | float = 0,
        end: int | float = np.inf,
    ) -> None:
        super().__init__(start, end)
        if not callable(event_function):
            raise TypeError(f"event_function={event_function!r} must be callable as f(t)")
        self.event_function = event_function
        self._rule = native.CustomScheduler(_OneArgument(event_function))


class _OneArgument:
    """Calls an NS-Gym event function ``f(t)`` with the native ``(t, rng)`` arguments."""

    def __init__(self, function: Callable[[int], bool]) -> None:
        self.function = function

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        return self.function(t)  # type: ignore[no-any-return]

    def __repr__(self) -> str:
        return repr(self.function)
