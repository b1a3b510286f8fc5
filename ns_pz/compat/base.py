"""NS-Gym's base classes, as adapters over the native ns_pz vocabulary.

NS-Gym's calling conventions hold here: a scheduler is called as ``sched(t)`` and is active on
``start <= t <= end`` (``start=0``, ``end=inf`` by default); an update function is called as
``fn(param, t)`` and returns ``(new_value, flag, delta)``. Each concrete class builds the native
rule of the same name (:mod:`ns_pz.nature`) and computes through it, so the numbers are the
native ones. Inside a wrapper only the native rule runs, drawing from the wrapper's seeded
generator; the compat object itself is never mutated by an episode.

Random schedulers and update functions take NS-Gym's ``seed=``; it seeds their *standalone*
calls (``sched(t)``, ``fn(param, t)``), which draw from ``self.rng``, and a wrapper whose first
``reset`` has no seed. Subclasses written for NS-Gym work too: an update function overriding
``_update``, or one whose scheduler overrides ``_check``, runs in a wrapper as a per-episode deep
copy called as NS-Gym calls it (``fn(param, t)`` at every step), and every numpy generator that
copy or its scheduler holds as an attribute (``rng`` or any other name) is reseeded from the
wrapper's generator at the episode's first step. So ``reset(seed=...)`` reproduces them, and
episodes without a seed differ. Randomness a subclass creates afresh at each call is its own.
"""

from __future__ import annotations

import copy
import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ns_pz.nature import schedulers as native_schedulers
from ns_pz.nature import updates as native_updates
from ns_pz.nature.distribution_updates import total_variation
from ns_pz.nature.updates import check_distribution, check_real

__all__ = ["TUNABLE_PARAMS", "Reward", "Scheduler", "UpdateDistributionFn", "UpdateFn"]


def check_time(name: str, t: object) -> int | float:
    """Validate a time step (int or float, numpy scalars included, >= 0, not NaN).

    Returns ``t`` as a Python ``int`` when it is a whole number, else as a ``float``.

    Raises:
        TypeError: ``t`` is not a real number.
        ValueError: ``t`` is NaN or negative.
    """
    if isinstance(t, bool) or not isinstance(t, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}={t!r} must be an int or float time step")
    number = float(t)
    if math.isnan(number) or number < 0:
        raise ValueError(f"{name}={t!r} must be a time step >= 0")
    if isinstance(t, (int, np.integer)):
        return int(t)
    return int(number) if number.is_integer() else number


def seeded_generator(owner: object, seed: object) -> np.random.Generator:
    """``numpy.random.default_rng(seed)`` for ``owner``'s standalone calls, the seed recorded.

    The seed is kept as ``owner._seed``, so a wrapper can seed itself from it (see
    :func:`explicit_seeds`).

    Raises:
        TypeError: ``seed`` is neither ``None`` nor an int.
        ValueError: ``seed`` is negative.
    """
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))):
        raise TypeError(f"seed={seed!r} must be an int or None")
    if seed is not None and seed < 0:
        raise ValueError(f"seed={seed!r} must be >= 0")
    owner._seed = None if seed is None else int(seed)  # type: ignore[attr-defined]
    return np.random.default_rng(seed)


def explicit_seeds(fn: object) -> list[int]:
    """The ``seed=`` values given to ``fn``, its scheduler and the update it wraps, in order."""
    parts = [fn, getattr(fn, "scheduler", None)]
    inner = getattr(fn, "inner", None)
    if inner is not None:
        parts += [inner, getattr(inner, "scheduler", None)]
    seeds = [getattr(part, "_seed", None) for part in parts]
    return [seed for seed in seeds if seed is not None]


def scheduler_seeds(fn: object) -> list[int]:
    """The ``seed=`` values given to ``fn``'s scheduler and the scheduler of the update it wraps.

    NS-Gym's ``reset(seed=...)`` reseeds a wrapper's update functions but never their
    schedulers, which keep drawing from their own ``seed=``.
    """
    parts = [getattr(fn, "scheduler", None)]
    inner = getattr(fn, "inner", None)
    if inner is not None:
        parts.append(getattr(inner, "scheduler", None))
    seeds = [getattr(part, "_seed", None) for part in parts]
    return [seed for seed in seeds if seed is not None]


class Scheduler(ABC):
    """When a parameter changes: ``sched(t)`` is True at the steps it fires.

    Args:
        start: First active step (inclusive), default 0.
        end: Last active step (inclusive), default ``inf``.
    """

    def __init__(self, start: int | float = 0, end: int | float = np.inf) -> None:
        self.start = check_time("start", start)
        if isinstance(end, (int, float, np.integer, np.floating)) and end == math.inf:
            self.end: int | float = math.inf
        else:
            self.end = check_time("end", end)
        if self.end < self.start:
            raise ValueError(f"end={end!r} is before start={start!r}; need end >= start")

    def __call__(self, t: int | float) -> bool:
        """Whether the parameter changes at step ``t`` (False outside ``[start, end]``)."""
        t = check_time("t", t)
        if self.start <= t <= self.end:
            return bool(self._check(t))
        return False

    @abstractmethod
    def _check(self, t: Any) -> bool:
        """Whether to fire at ``t``, a step inside the window."""

    def native(self) -> native_schedulers.Scheduler:
        """The native scheduler with this one's window and rule.

        A wrapper runs it when :meth:`runs_natively`; otherwise it runs a copy of this object.
        """
        return _Windowed(self._native_rule(), self.start, self.end)

    def runs_natively(self) -> bool:
        """Whether :meth:`native` computes exactly what ``_check`` does (no user override)."""
        return False

    def _native_rule(self) -> native_schedulers.Scheduler:
        """The rule without the window; a subclass from NS-Gym runs through its ``_check``."""
        return _SubclassScheduler(self)

    def __repr__(self) -> str:
        shown = {k: v for k, v in vars(self).items() if not k.startswith("_") and k != "rng"}
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in shown.items())})"


class _Windowed(native_schedulers.Scheduler):
    """A native scheduler restricted to NS-Gym's inclusive window on absolute time."""

    def __init__(self, rule: native_schedulers.Scheduler, start: float, end: float) -> None:
        self.rule = rule
        self.start = start
        self.end = end

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """The rule's answer inside the window, False outside."""
        return self.start <= t <= self.end and self.rule(t, rng)


class _SubclassScheduler(native_schedulers.Scheduler):
    """Runs a user's NS-Gym-style scheduler subclass (its ``_check``) as a native scheduler."""

    def __init__(self, scheduler: Scheduler) -> None:
        self.scheduler = scheduler

    def __call__(self, t: int, rng: np.random.Generator) -> bool:
        """The subclass's ``_check(t)``."""
        return bool(self.scheduler._check(t))


class _Update:
    """What scalar and distribution update functions share."""

    def __init__(self, scheduler: Scheduler) -> None:
        if not isinstance(scheduler, Scheduler):
            hint = ""
            if isinstance(scheduler, native_schedulers.Scheduler):
                hint = " (this is a native ns_pz scheduler; use ns_pz.compat.schedulers here)"
            raise TypeError(
                f"scheduler={scheduler!r} must be an ns_pz.compat scheduler "
                f"(ContinuousScheduler(), PeriodicScheduler(period=3), ...){hint}"
            )
        self.scheduler = scheduler
        self.prev_param: Any = None
        self.prev_time: int | float = -1
        self._fired = 0
        self._rule: native_updates.UpdateFn | native_updates.DistributionUpdateFn | None = None
        self._memory: Any = None

    def _set_rule(
        self, rule: native_updates.UpdateFn | native_updates.DistributionUpdateFn
    ) -> None:
        self._rule = rule
        self._memory = rule.initial_memory()

    def seed(self, seed: int | None) -> None:
        """Reseed the generator of standalone calls (no effect inside a wrapper's episodes)."""
        if hasattr(self, "rng"):
            self.rng = np.random.default_rng(seed)

    def _native_update(self, value: Any, t: Any) -> Any:
        """The native rule's proposal for the next firing of a standalone call."""
        rule = self._rule
        if rule is None:
            raise NotImplementedError(f"{type(self).__name__} must implement _update(param, t)")
        n = self._fired
        self._fired = n + 1
        rng = getattr(self, "rng", None)
        if rule.stateful:
            return rule.update(value, t, n, rng, self._memory)  # type: ignore[arg-type, call-arg]
        return rule.update(value, t, n, rng)  # type: ignore[arg-type]

    def __repr__(self) -> str:
        shown = {k: v for k, v in vars(self).items() if not k.startswith("_") and k != "rng"}
        shown.pop("prev_param", None)
        shown.pop("prev_time", None)
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in shown.items())})"


class UpdateFn(_Update, ABC):
    """How a scalar parameter changes: ``fn(param, t) -> (new_value, flag, delta)``.

    ``flag`` is 1 when the value changed and 0 otherwise; ``delta`` is ``new - param`` (0.0
    when nothing changed). NS-Gym reports ``flag=1`` at every firing, even when the value stays.
    """

    def __call__(self, param: float, t: int | float) -> tuple[float, int, float]:
        """Apply the update if the scheduler fires at ``t``."""
        t = check_time("t", t)
        value = check_real("param", param)
        new = value
        if self.scheduler(t):
            new = float(self._update(value, t))
        self.prev_param = param
        self.prev_time = t
        if new == value:
            return param, 0, 0.0
        return new, 1, new - value

    def _update(self, param: float, t: Any) -> float:
        """The new value at a firing; concrete classes compute it with their native rule."""
        return float(self._native_update(param, t))

    def native(self) -> native_updates.UpdateFn:
        """The native rule a wrapper runs (with this function's scheduler, window included)."""
        if (
            isinstance(self._rule, native_updates.UpdateFn)
            and type(self)._update is UpdateFn._update
            and self.scheduler.runs_natively()
        ):
            return self._rule
        return _SubclassScalarRule(self)


class UpdateDistributionFn(UpdateFn):
    """How a probability vector changes: ``fn(param, t) -> (new_list, flag, delta)``.

    A subclass of :class:`UpdateFn`, as in NS-Gym, so ``isinstance(fn, UpdateFn)`` holds for
    every update function; tell the two kinds apart with ``isinstance(fn, UpdateDistributionFn)``.

    ``param`` is a list (or any sequence) that must be a probability vector; it is refused with
    ``ValueError`` otherwise (NS-Gym accepts a vector summing to 0.9). ``delta`` is the total
    variation distance between the old and new vectors (W1 under the discrete metric; NS-Gym
    uses W1 over positions 0..n-1, which depends on the order of the outcomes).
    """

    def __call__(  # type: ignore[override]  # a vector in and out, as in NS-Gym
        self, param: Any, t: int | float
    ) -> tuple[list[float], int, float]:
        """Apply the update if the scheduler fires at ``t``."""
        t = check_time("t", t)
        value = check_distribution("param", param)
        new = value
        if self.scheduler(t):
            new = tuple(check_distribution(f"{type(self).__name__} result", self._update(value, t)))
        self.prev_param = param
        self.prev_time = t
        if new == value:
            return list(value), 0, 0.0
        return list(new), 1, total_variation(value, new)

    def _update(self, param: Any, t: Any) -> Any:
        """The new vector at a firing; concrete classes compute it with their native rule."""
        return self._native_update(tuple(param), t)

    def native(self) -> native_updates.DistributionUpdateFn:  # type: ignore[override]
        """The native rule a wrapper runs (with this function's scheduler, window included)."""
        rule = self._rule
        if (
            isinstance(rule, native_updates.DistributionUpdateFn)
            and type(self)._update is UpdateDistributionFn._update
            and self.scheduler.runs_natively()
        ):
            return rule
        return _SubclassDistributionRule(self)


class _SubclassRuleMixin:
    """Runs an NS-Gym-style object (a user subclass, or a user scheduler) as a native rule.

    The rule fires at every step and calls a per-episode deep copy of the object as NS-Gym
    does, ``copy(param, t)``; a step where the copy's scheduler does not fire proposes the
    value unchanged, which nature records as no change. The copy is the rule's episode memory,
    so episodes and planning copies (which copy nature's memory) never share its state. At the
    episode's first step every numpy generator held by the copy or its scheduler is reseeded
    from nature's generator.
    """

    stateful = True

    def __init__(self, fn: _Update) -> None:
        super().__init__(native_schedulers.ContinuousScheduler(start=0))  # type: ignore[call-arg]
        self.fn = fn

    def initial_memory(self) -> list[Any]:
        """``[copy of the user's object, whether its generators have been reseeded]``."""
        return [copy.deepcopy(self.fn), False]

    def _apply(self, value: Any, t: int, rng: np.random.Generator, memory: list[Any]) -> Any:
        fn = memory[0]
        if not memory[1]:
            reseed_generators(fn, rng)
            reseed_generators(fn.scheduler, rng)
            memory[1] = True
        return fn(value, t)[0]


def reseed_generators(obj: object, rng: np.random.Generator) -> None:
    """Replace every numpy generator among ``obj``'s attributes by one seeded from ``rng``.

    Attributes are visited in definition order, so the result is a function of ``rng``'s state.
    ``numpy.random.RandomState`` attributes are reseeded too.
    """
    for name, value in list(vars(obj).items()):
        if isinstance(value, np.random.Generator):
            setattr(obj, name, np.random.default_rng(int(rng.integers(2**63))))
        elif isinstance(value, np.random.RandomState):
            setattr(obj, name, np.random.RandomState(int(rng.integers(2**32))))


class _SubclassScalarRule(_SubclassRuleMixin, native_updates.UpdateFn):
    def update(  # type: ignore[override]
        self, value: float, t: int, n: int, rng: np.random.Generator, memory: list[Any]
    ) -> float:
        """The copy's ``fn(value, t)`` value."""
        return check_real(
            f"{type(self.fn).__name__}._update result", self._apply(value, t, rng, memory)
        )


class _SubclassDistributionRule(_SubclassRuleMixin, native_updates.DistributionUpdateFn):
    def update(  # type: ignore[override]
        self, value: tuple[float, ...], t: int, n: int, rng: np.random.Generator, memory: list[Any]
    ) -> tuple[float, ...]:
        """The copy's ``fn(list(value), t)`` value, validated."""
        result = self._apply(list(value), t, rng, memory)
        return check_distribution(f"{type(self.fn).__name__}._update result", result)


@dataclass(frozen=True)
class Reward:
    """The reward with its notification, returned in place of a float if ``scalar_reward=False``."""

    reward: float
    env_change: Mapping[str, int]
    delta_change: Mapping[str, float]
    relative_time: int


class _TunableParams(Mapping[str, dict[str, Any]]):
    """NS-Gym's table: environment class name -> {parameter name: default}.

    Built on first access from the ns_pz families (classic-control families whose module is not
    installed are left out).
    """

    def __init__(self) -> None:
        self._table: dict[str, dict[str, Any]] | None = None

    def _load(self) -> dict[str, dict[str, Any]]:
        if self._table is None:
            from ns_pz.compat.families import tunable_defaults

            self._table = tunable_defaults()
        return self._table

    def __getitem__(self, key: str) -> dict[str, Any]:
        return copy.deepcopy(self._load()[key])

    def __iter__(self) -> Any:
        return iter(self._load())

    def __len__(self) -> int:
        return len(self._load())

    def __repr__(self) -> str:
        return f"TUNABLE_PARAMS({self._load()!r})"


TUNABLE_PARAMS = _TunableParams()
"""Environment class name -> {NS-Gym parameter name: default value}."""


def __getattr__(name: str) -> Any:
    """``NSWrapper``, which NS-Gym keeps in ``ns_gym.base`` (loaded on first use)."""
    if name == "NSWrapper":
        from ns_pz.compat.wrappers.core import NSWrapper

        return NSWrapper
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
