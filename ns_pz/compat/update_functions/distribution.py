"""NS-Gym's probability-vector update functions (``ns_gym.update_functions.distribution``).

Each class computes with the native rule (:mod:`ns_pz.nature.distribution_updates`). Vectors
are passed and returned as lists, as in NS-Gym, but every vector is validated: a ``param``, an
``update_values`` entry, a ``target`` or an interpolation end point that is not a probability
vector raises ``ValueError``, and ``rate``/``theta`` must lie in [0, 1]. ``delta`` is the total
variation distance. ``LCBoundedDistrubutionUpdate`` (NS-Gym's spelling, kept as an alias of
``LCBoundedDistributionUpdate``) shortens a far proposal instead of redrawing it, and
``BudgetBoundedIncrement`` works (NS-Gym's cannot be constructed).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ns_pz.compat.base import Scheduler, UpdateDistributionFn, seeded_generator
from ns_pz.nature import distribution_updates as native
from ns_pz.nature import updates as native_updates

__all__ = [
    "BudgetBoundedIncrement",
    "DistributionCyclicUpdate",
    "DistributionDecrementUpdate",
    "DistributionIncrementUpdate",
    "DistributionLinearInterpolation",
    "DistributionNoUpdate",
    "DistributionStepWiseUpdate",
    "LCBoundedDistributionUpdate",
    "LCBoundedDistrubutionUpdate",
    "RandomCategorical",
    "TargetReversion",
    "UniformDrift",
]


class DistributionNoUpdate(UpdateDistributionFn):
    """Leaves the vector unchanged."""

    def __init__(self, scheduler: Scheduler) -> None:
        super().__init__(scheduler)
        self._set_rule(native.DistributionNoUpdate(scheduler.native()))


class DistributionIncrementUpdate(UpdateDistributionFn):
    """``p[0] <- min(1, p[0] + k)``, the rest shared equally among the other outcomes."""

    def __init__(self, scheduler: Scheduler, k: float) -> None:
        super().__init__(scheduler)
        rule = native.DistributionIncrementUpdate(scheduler.native(), k)
        self.k = rule.k
        self._set_rule(rule)


class DistributionDecrementUpdate(UpdateDistributionFn):
    """``p[0] <- max(0, p[0] - k)``, the rest shared equally among the other outcomes."""

    def __init__(self, scheduler: Scheduler, k: float) -> None:
        super().__init__(scheduler)
        rule = native.DistributionDecrementUpdate(scheduler.native(), k)
        self.k = rule.k
        self._set_rule(rule)


class DistributionStepWiseUpdate(UpdateDistributionFn):
    """The next vector of ``update_values`` at each firing; unchanged once used up."""

    def __init__(self, scheduler: Scheduler, update_values: Sequence[Sequence[float]]) -> None:
        super().__init__(scheduler)
        rule = native.DistributionStepWiseUpdate(scheduler.native(), update_values)
        self.update_values = [list(v) for v in rule.update_values]
        self._set_rule(rule)


class DistributionCyclicUpdate(UpdateDistributionFn):
    """The next vector of ``dist_list`` at each firing, wrapping around."""

    def __init__(self, scheduler: Scheduler, dist_list: Sequence[Sequence[float]]) -> None:
        super().__init__(scheduler)
        rule = native.DistributionCyclicUpdate(scheduler.native(), dist_list)
        self.dist_list = [list(v) for v in rule.dist_list]
        self._set_rule(rule)


class RandomCategorical(UpdateDistributionFn):
    """A fresh Dirichlet(1, ..., 1) draw of the same length."""

    def __init__(self, scheduler: Scheduler, seed: int | None = None) -> None:
        super().__init__(scheduler)
        self.rng = seeded_generator(self, seed)
        self._set_rule(native.RandomCategorical(scheduler.native()))


class UniformDrift(UpdateDistributionFn):
    """``(1 - rate) p + rate / n``."""

    def __init__(self, scheduler: Scheduler, rate: float) -> None:
        super().__init__(scheduler)
        rule = native.UniformDrift(scheduler.native(), rate)
        self.rate = rule.rate
        self._set_rule(rule)


class TargetReversion(UpdateDistributionFn):
    """``p + theta (target - p)``."""

    def __init__(self, scheduler: Scheduler, target: Sequence[float], theta: float) -> None:
        super().__init__(scheduler)
        rule = native.TargetReversion(scheduler.native(), target, theta)
        self.target, self.theta = list(rule.target), rule.theta
        self._set_rule(rule)


class DistributionLinearInterpolation(UpdateDistributionFn):
    """``start_dist + (end_dist - start_dist) * min(t / T, 1)``."""

    def __init__(
        self,
        scheduler: Scheduler,
        start_dist: Sequence[float],
        end_dist: Sequence[float],
        T: int,  # noqa: N803 - NS-Gym's name
    ) -> None:
        super().__init__(scheduler)
        rule = native.DistributionLinearInterpolation(scheduler.native(), start_dist, end_dist, T)
        self.start_dist, self.end_dist, self.T = list(rule.start_dist), list(rule.end_dist), rule.T
        self._set_rule(rule)


class LCBoundedDistributionUpdate(UpdateDistributionFn):
    """Another update's proposal, moved at most ``L * |t - prev_time|`` (total variation).

    Args:
        scheduler: When it fires.
        L: The Lipschitz constant, >= 0.
        update_fn: The inner update: an update class (NS-Gym's convention, built with
            ``scheduler``) or an instance; default :class:`RandomCategorical`.

    ``prev_time`` is the step of the previous call (-1 before the first), as in NS-Gym, so in a
    wrapper, which calls every step, the bound is ``L`` per step. A far proposal is shortened to
    the bound along the line towards it instead of being redrawn up to 100,000 times.
    """

    def __init__(self, scheduler: Scheduler, L: float, update_fn: Any = None) -> None:  # noqa: N803
        super().__init__(scheduler)
        if update_fn is None:
            update_fn = RandomCategorical
        if isinstance(update_fn, type):
            if not issubclass(update_fn, UpdateDistributionFn):
                raise TypeError(
                    f"update_fn={update_fn!r} must be an ns_pz.compat distribution update "
                    "(class or instance)"
                )
            update_fn = update_fn(scheduler)
        if not isinstance(update_fn, UpdateDistributionFn):
            raise TypeError(
                f"update_fn={update_fn!r} must be an ns_pz.compat distribution update "
                "(class or instance)"
            )
        self.inner = update_fn
        rule = native.LipschitzBoundedDistributionUpdate(scheduler.native(), L, update_fn.native())
        self.L = rule.L
        self.rng = getattr(update_fn, "rng", None) or seeded_generator(self, None)
        self._set_rule(rule)

    def _update(self, param: Any, t: Any) -> Any:
        rule = self._rule
        assert isinstance(rule, native.LipschitzBoundedDistributionUpdate)  # set in __init__
        n = self._fired
        self._fired = n + 1
        limit = self.L * abs(t - self.prev_time)
        return rule.bounded_update(tuple(param), t, n, self.rng, limit, self._memory)

    def native(self) -> native_updates.DistributionUpdateFn:  # type: ignore[override]
        """The native rule (``L`` per firing; a wrapper fires it at most once per step).

        With a user scheduler subclass (its own ``_check``), a copy of this object instead.
        """
        if self.scheduler.runs_natively() and self.inner.scheduler.runs_natively():
            return self._rule  # type: ignore[return-value]
        return super().native()


LCBoundedDistrubutionUpdate = LCBoundedDistributionUpdate
"""NS-Gym's (misspelt) name."""


class BudgetBoundedIncrement(UpdateDistributionFn):
    """``DistributionIncrementUpdate(k)`` until changes totalling ``B`` are spent, then nothing."""

    def __init__(self, scheduler: Scheduler, k: float, B: float) -> None:  # noqa: N803
        super().__init__(scheduler)
        rule = native.BudgetBoundedIncrement(scheduler.native(), k, B)
        self.k, self.B = rule.k, rule.B
        self._set_rule(rule)
