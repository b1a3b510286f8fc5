"""Update functions: *how* nature changes a parameter when its scheduler fires.

An update function pairs a :class:`~ns_pz.nature.schedulers.Scheduler` with a rule
``update(value, t, n, rng) -> new value``, where ``t`` is the step index and ``n`` the number of
times this function has already fired in the episode. Update functions are immutable settings;
the per-episode count lives in the nature that uses them, so one instance can serve many
environments at once.

Scalar rules (:class:`UpdateFn`) act on a float, distribution rules
(:class:`DistributionUpdateFn`) on a probability vector (a tuple). A rule may propose a value
outside the parameter's bounds; the game projects every proposal onto the allowed set (see
:mod:`ns_pz.nature.constraints`), so bounds never need repeating here.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np

from ns_pz.nature.schedulers import Scheduler
from ns_pz.params import SIMPLEX_ATOL

Vector = tuple[float, ...]


class _Update:
    """Common part of scalar and distribution update functions: the scheduler."""

    def __init__(self, scheduler: Scheduler) -> None:
        if not isinstance(scheduler, Scheduler):
            raise TypeError(
                f"scheduler={scheduler!r} must be an ns_pz Scheduler "
                "(ContinuousScheduler, DiscreteScheduler, PeriodicScheduler, RandomScheduler, ...)"
            )
        self.scheduler = scheduler

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in vars(self).items())
        return f"{type(self).__name__}({args})"


class UpdateFn(_Update, ABC):
    """Changes a scalar parameter when its scheduler fires."""

    @abstractmethod
    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """The proposed new value; ``n`` counts earlier firings in this episode."""


class DistributionUpdateFn(_Update, ABC):
    """Changes a probability-vector parameter when its scheduler fires."""

    @abstractmethod
    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """The proposed new vector; ``n`` counts earlier firings in this episode."""

    def check_size(self, param: str, size: int) -> None:
        """Raise ``ValueError`` if the rule cannot produce vectors of ``size`` elements."""


class NoUpdate(UpdateFn):
    """Leaves the value as it is (a placeholder that still consults its scheduler)."""

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """The unchanged value."""
        return value


class IncrementUpdate(UpdateFn):
    """Adds ``k`` at each firing."""

    def __init__(self, scheduler: Scheduler, k: float) -> None:
        super().__init__(scheduler)
        self.k = check_real("k", k)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value + k``."""
        return value + self.k


class DecrementUpdate(UpdateFn):
    """Subtracts ``k`` at each firing."""

    def __init__(self, scheduler: Scheduler, k: float) -> None:
        super().__init__(scheduler)
        self.k = check_real("k", k)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value - k``."""
        return value - self.k


class StepWiseUpdate(UpdateFn):
    """Sets the value to ``param_list[n]`` at the n-th firing; no change once the list is spent."""

    def __init__(self, scheduler: Scheduler, param_list: Sequence[float]) -> None:
        super().__init__(scheduler)
        if isinstance(param_list, (str, bytes)) or not isinstance(param_list, Sequence):
            raise TypeError(f"param_list={param_list!r} must be a sequence of numbers")
        self.param_list = tuple(check_real(f"param_list[{i}]", v) for i, v in enumerate(param_list))
        if not self.param_list:
            raise ValueError("param_list=[] is empty; give at least one value")

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """The n-th listed value, or ``value`` when the list is exhausted."""
        return self.param_list[n] if n < len(self.param_list) else value


class RandomWalk(UpdateFn):
    """Adds a Gaussian step N(mu, sigma²) drawn from nature's generator at each firing."""

    def __init__(self, scheduler: Scheduler, mu: float = 0.0, sigma: float = 1.0) -> None:
        super().__init__(scheduler)
        self.mu = check_real("mu", mu)
        self.sigma = check_real("sigma", sigma)
        if self.sigma < 0:
            raise ValueError(f"sigma={sigma!r} must be >= 0")

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value + N(mu, sigma²)``."""
        return value + self.mu + self.sigma * float(rng.standard_normal())


class DistributionNoUpdate(DistributionUpdateFn):
    """Leaves the vector as it is."""

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """The unchanged vector."""
        return value


class DistributionIncrementUpdate(DistributionUpdateFn):
    """Raises the first element (the intended outcome) by ``k`` at each firing.

    The first element is clipped to [0, 1] and the mass left, ``1 - p[0]``, is split equally
    among the other outcomes (NS-Gym's rule; an uneven tail is evened out).
    """

    def __init__(self, scheduler: Scheduler, k: float) -> None:
        super().__init__(scheduler)
        self.k = check_real("k", k)

    def check_size(self, param: str, size: int) -> None:
        """The rule needs at least two outcomes to move mass between."""
        if size < 2:
            raise ValueError(
                f"{type(self).__name__} needs a vector of >= 2 outcomes; {param!r} has {size}"
            )

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """``p[0] + k`` (clipped), the rest shared equally."""
        return shift_first(value, self.k)


class DistributionDecrementUpdate(DistributionIncrementUpdate):
    """Lowers the first element (the intended outcome) by ``k``; see the increment rule."""

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """``p[0] - k`` (clipped), the rest shared equally."""
        return shift_first(value, -self.k)


class DistributionStepWiseUpdate(DistributionUpdateFn):
    """Sets the vector to ``update_values[n]`` at the n-th firing; no change once used up."""

    def __init__(self, scheduler: Scheduler, update_values: Sequence[Sequence[float]]) -> None:
        super().__init__(scheduler)
        if isinstance(update_values, (str, bytes)) or not isinstance(update_values, Sequence):
            raise TypeError(f"update_values={update_values!r} must be a sequence of vectors")
        if not update_values:
            raise ValueError("update_values=[] is empty; give at least one probability vector")
        self.update_values = tuple(
            check_distribution(f"update_values[{i}]", v) for i, v in enumerate(update_values)
        )

    def check_size(self, param: str, size: int) -> None:
        """Every listed vector must have ``size`` elements."""
        for i, vector in enumerate(self.update_values):
            if len(vector) != size:
                raise ValueError(
                    f"update_values[{i}]={vector!r} has {len(vector)} elements but parameter "
                    f"{param!r} has {size}"
                )

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """The n-th listed vector, or ``value`` when the list is exhausted."""
        return self.update_values[n] if n < len(self.update_values) else value


def shift_first(value: Vector, k: float) -> Vector:
    """Add ``k`` to the first element (clipped to [0, 1]) and share the rest equally."""
    first = value[0] + k
    if first < 0.0:
        first = 0.0
    elif first > 1.0:
        first = 1.0
    return (first,) + ((1.0 - first) / (len(value) - 1),) * (len(value) - 1)


def check_real(name: str, value: object) -> float:
    """Validate a finite real number and return it as ``float``.

    Raises:
        TypeError: ``value`` is not a real number.
        ValueError: ``value`` is NaN or infinite.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}={value!r} must be a real number")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name}={value!r} must be finite")
    return number


def check_distribution(name: str, value: object) -> Vector:
    """Validate a probability vector (finite, non-negative, sums to 1 within 1e-8).

    Raises:
        TypeError: ``value`` is not a sequence of numbers.
        ValueError: it is not a probability vector.
    """
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TypeError(f"{name}={value!r} must be a sequence of probabilities")
    vector = tuple(check_real(f"{name}[{i}]", p) for i, p in enumerate(value))
    if any(p < 0.0 for p in vector):
        raise ValueError(f"{name}={value!r} has a negative element")
    total = math.fsum(vector)
    if abs(total - 1.0) > SIMPLEX_ATOL:
        raise ValueError(f"{name}={value!r} sums to {total!r}, not 1 (tolerance {SIMPLEX_ATOL})")
    return vector
