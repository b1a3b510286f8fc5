"""Update rules for probability-vector parameters (NS-Gym's ``distribution`` vocabulary).

A probability vector here is a slip vector: element 0 is the intended outcome, the others the
ways a move can go wrong (see each family). Every rule returns a probability vector when given
one, and every vector a user supplies is validated when the rule is built (NS-Gym accepts a
vector summing to 0.9 and silently samples from it).

Change sizes (the Lipschitz and budget bounds below) are measured as everywhere in ns_pz: W1 under
the discrete ground metric, i.e. the total variation ``0.5 * sum(|p - q|)``, which does not
depend on the order in which outcomes are listed.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ns_pz.nature.constraints import remaining
from ns_pz.nature.schedulers import Scheduler, check_non_negative, check_step
from ns_pz.nature.updates import (
    DistributionUpdateFn,
    Vector,
    check_distribution,
    check_distributions,
    check_in,
    check_real,
)


class DistributionNoUpdate(DistributionUpdateFn):
    """Leaves the vector as it is (nothing changes, so nothing is notified)."""

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
        _need_two(self, param, size)

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
        self.update_values = check_distributions("update_values", update_values)

    def check_size(self, param: str, size: int) -> None:
        """Every listed vector must have ``size`` elements."""
        _check_lengths("update_values", self.update_values, param, size)

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """The n-th listed vector, or ``value`` when the list is exhausted."""
        return self.update_values[n] if n < len(self.update_values) else value


class DistributionCyclicUpdate(DistributionUpdateFn):
    """Sets the vector to ``dist_list[n % len(dist_list)]``: the list, round and round."""

    def __init__(self, scheduler: Scheduler, dist_list: Sequence[Sequence[float]]) -> None:
        super().__init__(scheduler)
        self.dist_list = check_distributions("dist_list", dist_list)

    def check_size(self, param: str, size: int) -> None:
        """Every listed vector must have ``size`` elements."""
        _check_lengths("dist_list", self.dist_list, param, size)

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """The next listed vector, wrapping around."""
        return self.dist_list[n % len(self.dist_list)]


class RandomCategorical(DistributionUpdateFn):
    """Replaces the vector with a fresh draw, uniform over the simplex (Dirichlet(1, ..., 1))."""

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """A uniform random probability vector of the same length."""
        return tuple(rng.dirichlet(np.ones(len(value))).tolist())


class UniformDrift(DistributionUpdateFn):
    """Mixes the vector with the uniform one: ``(1 - rate) p + rate / n_outcomes``."""

    def __init__(self, scheduler: Scheduler, rate: float) -> None:
        super().__init__(scheduler)
        self.rate = check_in("rate", rate, 0.0, 1.0)

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """A step of size ``rate`` towards the uniform vector."""
        share = self.rate / len(value)
        keep = 1.0 - self.rate
        return tuple(keep * p + share for p in value)


class TargetReversion(DistributionUpdateFn):
    """Moves the vector a fraction ``theta`` of the way to ``target``: ``p + theta (target - p)``.

    ``target`` must be a probability vector and ``theta`` lie in [0, 1], so the result is one.
    """

    def __init__(self, scheduler: Scheduler, target: Sequence[float], theta: float) -> None:
        super().__init__(scheduler)
        self.target = check_distribution("target", target)
        self.theta = check_in("theta", theta, 0.0, 1.0)

    def check_size(self, param: str, size: int) -> None:
        """``target`` must have ``size`` elements."""
        _check_lengths("target", (self.target,), param, size, indexed=False)

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """The point ``theta`` of the way from ``value`` to ``target``."""
        return _towards(value, self.target, self.theta)


class DistributionLinearInterpolation(DistributionUpdateFn):
    """Sets the vector to ``start_dist + (end_dist - start_dist) * min(t / T, 1)``.

    ``t`` counts from reset, so the vector reaches ``end_dist`` at step ``T`` and stays there.
    """

    def __init__(
        self,
        scheduler: Scheduler,
        start_dist: Sequence[float],
        end_dist: Sequence[float],
        T: int,  # noqa: N803 - NS-Gym's name
    ) -> None:
        super().__init__(scheduler)
        self.start_dist = check_distribution("start_dist", start_dist)
        self.end_dist = check_distribution("end_dist", end_dist)
        if len(self.end_dist) != len(self.start_dist):
            raise ValueError(
                f"end_dist={end_dist!r} has {len(self.end_dist)} elements but start_dist has "
                f"{len(self.start_dist)}"
            )
        self.T = check_step("T", T)
        if self.T < 1:
            raise ValueError(f"T={T!r} must be >= 1 (the step at which end_dist is reached)")

    def check_size(self, param: str, size: int) -> None:
        """Both end points must have ``size`` elements."""
        _check_lengths("start_dist", (self.start_dist,), param, size, indexed=False)

    def update(self, value: Vector, t: int, n: int, rng: np.random.Generator) -> Vector:
        """The point of the segment at ``t`` (the current vector plays no part)."""
        return _towards(self.start_dist, self.end_dist, min(t / self.T, 1.0))


class LipschitzBoundedDistributionUpdate(DistributionUpdateFn):
    """Another rule's proposal, shortened so that one firing moves the vector by at most ``L``.

    NS-Gym's ``LCBoundedDistrubutionUpdate``. Where NS-Gym redraws the inner proposal until it
    lands within ``L`` (and fails after 100,000 tries when ``L`` is small), this rule takes the
    proposal once and, if it is farther than ``L`` (total variation), moves only ``L`` along the
    straight line towards it. The simplex is convex, so the result is always a probability
    vector, and it costs one proposal.

    Args:
        scheduler: When the rule fires (the inner rule's own scheduler is not consulted).
        L: Largest change per firing, >= 0.
        update_fn: The rule whose proposals are bounded (default: :class:`RandomCategorical`).
    """

    def __init__(
        self,
        scheduler: Scheduler,
        L: float,
        update_fn: DistributionUpdateFn | None = None,  # noqa: N803
    ) -> None:
        super().__init__(scheduler)
        self.L = check_non_negative("L", L)
        if update_fn is None:
            update_fn = RandomCategorical(scheduler)
        if not isinstance(update_fn, DistributionUpdateFn):
            raise TypeError(
                f"update_fn={update_fn!r} must be an ns_pz distribution update function "
                "(RandomCategorical, UniformDrift, ...)"
            )
        self.update_fn = update_fn
        self.stateful = update_fn.stateful  # type: ignore[misc]  # follows the inner rule

    def check_size(self, param: str, size: int) -> None:
        """Whatever the inner rule needs."""
        self.update_fn.check_size(param, size)

    def initial_memory(self) -> Any:
        """The inner rule's memory."""
        return self.update_fn.initial_memory()

    def update(
        self, value: Vector, t: int, n: int, rng: np.random.Generator, memory: Any = None
    ) -> Vector:
        """The inner proposal, at most ``L`` away from ``value``."""
        return self.bounded_update(value, t, n, rng, self.L, memory)

    def bounded_update(
        self,
        value: Vector,
        t: int,
        n: int,
        rng: np.random.Generator,
        limit: float,
        memory: Any = None,
    ) -> Vector:
        """The inner proposal, at most ``limit`` away from ``value``."""
        inner = self.update_fn
        if inner.stateful:
            proposal = inner.update(value, t, n, rng, memory)  # type: ignore[call-arg]
        else:
            proposal = inner.update(value, t, n, rng)
        size = total_variation(value, proposal)
        if size <= limit:
            return proposal
        return _towards(value, proposal, limit / size)


class BudgetBoundedIncrement(DistributionUpdateFn):
    """Raises the intended outcome by ``k`` per firing until a total change of ``B`` is spent.

    Each firing proposes what :class:`DistributionIncrementUpdate` would (``k < 0`` lowers it
    instead); the sizes of the changes it proposes (total variation) are added up over the
    episode, and the firing that would exceed ``B`` moves only as far as the budget left
    allows, along the line towards the proposal. After that the vector stays put (a remainder
    of rounding errors counts as spent). The rule counts what it proposes: a change the game's
    :class:`~ns_pz.nature.NatureConstraints` shorten is charged in full here; for a budget on
    what is granted, use ``NatureConstraints(budget=...)``. (NS-Gym's class of this name cannot
    be constructed.)
    """

    stateful = True

    def __init__(self, scheduler: Scheduler, k: float, B: float) -> None:  # noqa: N803
        super().__init__(scheduler)
        self.k = check_real("k", k)
        self.B = check_non_negative("B", B)

    def check_size(self, param: str, size: int) -> None:
        """The rule needs at least two outcomes to move mass between."""
        _need_two(self, param, size)

    def initial_memory(self) -> list[float]:
        """``[spent]``: the budget used so far this episode."""
        return [0.0]

    def update(  # type: ignore[override]  # stateful: nature passes the memory
        self, value: Vector, t: int, n: int, rng: np.random.Generator, memory: list[float]
    ) -> Vector:
        """The increment, shortened to the budget left; ``memory[0]`` is charged."""
        left = remaining(self.B, memory[0])
        if left <= 0.0:
            return value
        proposal = shift_first(value, self.k)
        size = total_variation(value, proposal)
        if size > left:
            proposal = _towards(value, proposal, left / size)
            size = left
        memory[0] += size
        return proposal


def shift_first(value: Vector, k: float) -> Vector:
    """Add ``k`` to the first element (clipped to [0, 1]) and share the rest equally."""
    first = value[0] + k
    if first < 0.0:
        first = 0.0
    elif first > 1.0:
        first = 1.0
    return (first,) + ((1.0 - first) / (len(value) - 1),) * (len(value) - 1)


def total_variation(a: Sequence[float], b: Sequence[float]) -> float:
    """``0.5 * sum(|a - b|)``: W1 between two probability vectors under the discrete metric."""
    return 0.5 * sum(abs(q - p) for p, q in zip(a, b, strict=True))


def _towards(old: Sequence[float], new: Sequence[float], fraction: float) -> Vector:
    """The point ``fraction`` (in [0, 1]) of the way from ``old`` to ``new``."""
    return tuple(p + fraction * (q - p) for p, q in zip(old, new, strict=True))


def _need_two(rule: DistributionUpdateFn, param: str, size: int) -> None:
    if size < 2:
        raise ValueError(
            f"{type(rule).__name__} needs a vector of >= 2 outcomes; {param!r} has {size}"
        )


def _check_lengths(
    name: str, vectors: Sequence[Vector], param: str, size: int, *, indexed: bool = True
) -> None:
    for i, vector in enumerate(vectors):
        if len(vector) != size:
            where = f"{name}[{i}]" if indexed else name
            raise ValueError(
                f"{where}={vector!r} has {len(vector)} elements but parameter {param!r} has {size}"
            )
