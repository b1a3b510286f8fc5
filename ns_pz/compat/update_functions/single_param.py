"""NS-Gym's scalar update functions (``ns_gym.update_functions.single_param``).

Each class computes with the native rule of the same name (:mod:`ns_pz.nature.scalar_updates`),
whose docstring states the formula; NS-Gym's formulas are kept, including the ones that
accumulate (``DeterministicTrend``, ``ExponentialDecay``, ``OscillatingUpdate``,
``PolynomialTrend``). Differences: a firing that leaves the value unchanged (``NoUpdate``, a
used-up ``StepWiseUpdate``) reports ``flag=0``; ``StepWiseUpdate`` does not consume the list you
pass; random functions take ``seed=`` for standalone calls and draw from the wrapper's seeded
generator inside a wrapper.
"""

from __future__ import annotations

from collections.abc import Sequence

from ns_pz.compat.base import Scheduler, UpdateFn, seeded_generator
from ns_pz.nature import scalar_updates as native

__all__ = [
    "BoundedRandomWalk",
    "CyclicUpdate",
    "DecrementUpdate",
    "DeterministicTrend",
    "ExponentialDecay",
    "GeometricProgression",
    "IncrementUpdate",
    "LinearInterpolation",
    "NoUpdate",
    "OrnsteinUhlenbeck",
    "OscillatingUpdate",
    "PolynomialTrend",
    "RandomWalk",
    "RandomWalkWithDrift",
    "RandomWalkWithDriftAndTrend",
    "SigmoidTransition",
    "StepWiseUpdate",
]


class NoUpdate(UpdateFn):
    """Leaves the value unchanged."""

    def __init__(self, scheduler: Scheduler) -> None:
        super().__init__(scheduler)
        self._set_rule(native.NoUpdate(scheduler.native()))


class IncrementUpdate(UpdateFn):
    """``param + k``."""

    def __init__(self, scheduler: Scheduler, k: float) -> None:
        super().__init__(scheduler)
        rule = native.IncrementUpdate(scheduler.native(), k)
        self.k = rule.k
        self._set_rule(rule)


class DecrementUpdate(UpdateFn):
    """``param - k``."""

    def __init__(self, scheduler: Scheduler, k: float) -> None:
        super().__init__(scheduler)
        rule = native.DecrementUpdate(scheduler.native(), k)
        self.k = rule.k
        self._set_rule(rule)


class StepWiseUpdate(UpdateFn):
    """The next value of ``param_list`` at each firing; unchanged once the list is used up."""

    def __init__(self, scheduler: Scheduler, param_list: Sequence[float]) -> None:
        super().__init__(scheduler)
        rule = native.StepWiseUpdate(scheduler.native(), param_list)
        self.param_list = list(rule.param_list)
        self._set_rule(rule)


class CyclicUpdate(UpdateFn):
    """The next value of ``value_list`` at each firing, wrapping around."""

    def __init__(self, scheduler: Scheduler, value_list: Sequence[float]) -> None:
        super().__init__(scheduler)
        rule = native.CyclicUpdate(scheduler.native(), value_list)
        self.value_list = list(rule.value_list)
        self._set_rule(rule)


class DeterministicTrend(UpdateFn):
    """``param + slope * t`` (accumulates: quadratic under a continuous schedule)."""

    def __init__(self, scheduler: Scheduler, slope: float) -> None:
        super().__init__(scheduler)
        rule = native.DeterministicTrend(scheduler.native(), slope)
        self.slope = rule.slope
        self._set_rule(rule)


class PolynomialTrend(UpdateFn):
    """``param + sum_i coeffs[i] * t**(i + 1)``."""

    def __init__(self, scheduler: Scheduler, coeffs: Sequence[float]) -> None:
        super().__init__(scheduler)
        rule = native.PolynomialTrend(scheduler.native(), coeffs)
        self.coeffs = list(rule.coeffs)
        self._set_rule(rule)


class OscillatingUpdate(UpdateFn):
    """``param + delta * sin(t)``."""

    def __init__(self, scheduler: Scheduler, delta: float) -> None:
        super().__init__(scheduler)
        rule = native.OscillatingUpdate(scheduler.native(), delta)
        self.delta = rule.delta
        self._set_rule(rule)


class ExponentialDecay(UpdateFn):
    """``param * exp(-decay_rate * t)`` (compounds on the current value, as in NS-Gym)."""

    def __init__(self, scheduler: Scheduler, decay_rate: float) -> None:
        super().__init__(scheduler)
        rule = native.ExponentialDecay(scheduler.native(), decay_rate)
        self.decay_rate = rule.decay_rate
        self._set_rule(rule)


class GeometricProgression(UpdateFn):
    """``param * r``."""

    def __init__(self, scheduler: Scheduler, r: float) -> None:
        super().__init__(scheduler)
        rule = native.GeometricProgression(scheduler.native(), r)
        self.r = rule.r
        self._set_rule(rule)


class SigmoidTransition(UpdateFn):
    """``a + (b - a) / (1 + exp(-k (t - t0)))``."""

    def __init__(self, scheduler: Scheduler, a: float, b: float, k: float, t0: float) -> None:
        super().__init__(scheduler)
        rule = native.SigmoidTransition(scheduler.native(), a, b, k, t0)
        self.a, self.b, self.k, self.t0 = rule.a, rule.b, rule.k, rule.t0
        self._set_rule(rule)


class LinearInterpolation(UpdateFn):
    """``start_val + (end_val - start_val) * min(t / T, 1)``."""

    def __init__(
        self,
        scheduler: Scheduler,
        start_val: float,
        end_val: float,
        T: int,  # noqa: N803 - NS-Gym's name
    ) -> None:
        super().__init__(scheduler)
        rule = native.LinearInterpolation(scheduler.native(), start_val, end_val, T)
        self.start_val, self.end_val, self.T = rule.start_val, rule.end_val, rule.T
        self._set_rule(rule)


class RandomWalk(UpdateFn):
    """``param + N(mu, sigma²)``."""

    def __init__(
        self, scheduler: Scheduler, mu: float = 0, sigma: float = 1, seed: int | None = None
    ) -> None:
        super().__init__(scheduler)
        rule = native.RandomWalk(scheduler.native(), mu, sigma)
        self.mu, self.sigma = rule.mu, rule.sigma
        self.rng = seeded_generator(self, seed)
        self._set_rule(rule)


class RandomWalkWithDrift(UpdateFn):
    """``alpha + param + N(mu, sigma²)``."""

    def __init__(
        self,
        scheduler: Scheduler,
        alpha: float,
        mu: float,
        sigma: float,
        seed: int | None = None,
    ) -> None:
        super().__init__(scheduler)
        rule = native.RandomWalkWithDrift(scheduler.native(), alpha, mu, sigma)
        self.alpha, self.mu, self.sigma = rule.alpha, rule.mu, rule.sigma
        self.rng = seeded_generator(self, seed)
        self._set_rule(rule)


class RandomWalkWithDriftAndTrend(UpdateFn):
    """``alpha + param + N(mu, sigma²) + slope * t``."""

    def __init__(
        self,
        scheduler: Scheduler,
        alpha: float,
        mu: float,
        sigma: float,
        slope: float,
        seed: int | None = None,
    ) -> None:
        super().__init__(scheduler)
        rule = native.RandomWalkWithDriftAndTrend(scheduler.native(), alpha, mu, sigma, slope)
        self.alpha, self.mu, self.sigma, self.slope = rule.alpha, rule.mu, rule.sigma, rule.slope
        self.rng = seeded_generator(self, seed)
        self._set_rule(rule)


class BoundedRandomWalk(UpdateFn):
    """``clip(param + N(mu, sigma²), lo, hi)``."""

    def __init__(
        self,
        scheduler: Scheduler,
        mu: float,
        sigma: float,
        lo: float,
        hi: float,
        seed: int | None = None,
    ) -> None:
        super().__init__(scheduler)
        rule = native.BoundedRandomWalk(scheduler.native(), mu, sigma, lo, hi)
        self.mu, self.sigma, self.lo, self.hi = rule.mu, rule.sigma, rule.lo, rule.hi
        self.rng = seeded_generator(self, seed)
        self._set_rule(rule)


class OrnsteinUhlenbeck(UpdateFn):
    """``param + theta (mu - param) + N(0, sigma²)``."""

    def __init__(
        self,
        scheduler: Scheduler,
        theta: float,
        mu: float,
        sigma: float = 0.0,
        seed: int | None = None,
    ) -> None:
        super().__init__(scheduler)
        rule = native.OrnsteinUhlenbeck(scheduler.native(), theta, mu, sigma)
        self.theta, self.mu, self.sigma = rule.theta, rule.mu, rule.sigma
        self.rng = seeded_generator(self, seed)
        self._set_rule(rule)
