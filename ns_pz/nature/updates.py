"""Update functions: *how* nature changes a parameter when its scheduler fires.

An update function pairs a :class:`~ns_pz.nature.schedulers.Scheduler` with a rule
``update(value, t, n, rng) -> new value``, where ``t`` is the step index (transitions since
reset) and ``n`` the number of times this function has already fired in the episode. Update
functions are immutable settings: the per-episode count lives in the nature that uses them, so
one instance can serve many environments at once. A rule that must remember more than the count
(a spent budget) declares it with :attr:`stateful` and :meth:`initial_memory`; nature then keeps
that memory per episode too and passes it as a fifth argument.

Scalar rules (:class:`UpdateFn`, in :mod:`ns_pz.nature.scalar_updates`) act on a float,
distribution rules (:class:`DistributionUpdateFn`, in :mod:`ns_pz.nature.distribution_updates`)
on a probability vector (a tuple of floats). Distribution rules always return a probability
vector when given one. A scalar rule may propose a value outside the parameter's bounds; the game
projects every proposal onto the allowed set (see :mod:`ns_pz.nature.constraints`), so bounds
never need repeating here. Random rules draw only from the generator they are handed (nature's,
seeded at reset).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from ns_pz.nature.schedulers import Scheduler
from ns_pz.params import SIMPLEX_ATOL

Vector = tuple[float, ...]


class _Update:
    """Common part of scalar and distribution update functions: the scheduler and memory."""

    stateful: ClassVar[bool] = False
    """Whether :meth:`update` takes a per-episode memory as a fifth argument."""

    def __init__(self, scheduler: Scheduler) -> None:
        if not isinstance(scheduler, Scheduler):
            raise TypeError(
                f"scheduler={scheduler!r} must be an ns_pz Scheduler "
                "(ContinuousScheduler, DiscreteScheduler, PeriodicScheduler, RandomScheduler, ...)"
            )
        self.scheduler = scheduler

    def initial_memory(self) -> Any:
        """Fresh per-episode memory of a :attr:`stateful` rule (``None`` otherwise)."""
        return None

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


def check_in(name: str, value: object, low: float, high: float) -> float:
    """Validate a finite real number in ``[low, high]`` and return it as ``float``.

    Raises:
        TypeError: ``value`` is not a real number.
        ValueError: ``value`` is not finite or outside ``[low, high]``.
    """
    number = check_real(name, value)
    if not low <= number <= high:
        raise ValueError(f"{name}={value!r} must lie in [{low}, {high}]")
    return number


def check_reals(name: str, values: object) -> tuple[float, ...]:
    """Validate a non-empty sequence of finite real numbers and return it as a tuple.

    Raises:
        TypeError: ``values`` is not a sequence of real numbers.
        ValueError: it is empty, or an element is not finite.
    """
    if isinstance(values, (str, bytes)) or not isinstance(values, (Sequence, np.ndarray)):
        raise TypeError(f"{name}={values!r} must be a sequence of numbers")
    checked = tuple(check_real(f"{name}[{i}]", v) for i, v in enumerate(values))
    if not checked:
        raise ValueError(f"{name}=[] is empty; give at least one value")
    return checked


def check_distribution(name: str, value: object) -> Vector:
    """Validate a probability vector (finite, non-negative, sums to 1 within 1e-8).

    Raises:
        TypeError: ``value`` is not a sequence of numbers.
        ValueError: it is not a probability vector.
    """
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TypeError(f"{name}={value!r} must be a sequence of probabilities")
    vector = tuple(check_real(f"{name}[{i}]", p) for i, p in enumerate(value))
    if not vector:
        raise ValueError(f"{name}={value!r} is empty; a probability vector needs an element")
    if any(p < 0.0 for p in vector):
        raise ValueError(f"{name}={value!r} has a negative element")
    total = math.fsum(vector)
    if abs(total - 1.0) > SIMPLEX_ATOL:
        raise ValueError(f"{name}={value!r} sums to {total!r}, not 1 (tolerance {SIMPLEX_ATOL})")
    return vector


def check_distributions(name: str, values: object) -> tuple[Vector, ...]:
    """Validate a non-empty sequence of probability vectors of one common length.

    Raises:
        TypeError: ``values`` is not a sequence of sequences.
        ValueError: it is empty, a vector is invalid, or the lengths differ.
    """
    if isinstance(values, (str, bytes)) or not isinstance(values, (Sequence, np.ndarray)):
        raise TypeError(f"{name}={values!r} must be a sequence of probability vectors")
    if len(values) == 0:
        raise ValueError(f"{name}=[] is empty; give at least one probability vector")
    vectors = tuple(check_distribution(f"{name}[{i}]", v) for i, v in enumerate(values))
    if len({len(v) for v in vectors}) != 1:
        raise ValueError(f"{name}={values!r} mixes vectors of different lengths")
    return vectors
