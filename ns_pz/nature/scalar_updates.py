"""Update rules for scalar parameters (NS-Gym's ``single_param`` vocabulary).

Each rule maps the value in force, the step ``t`` (transitions since reset) and the firing
count ``n`` to a proposed new value. Rules that add a term depending on ``t``
(:class:`DeterministicTrend`, :class:`PolynomialTrend`, :class:`OscillatingUpdate`,
:class:`ExponentialDecay`, :class:`RandomWalkWithDriftAndTrend`) apply it to the *current*
value at each firing, as NS-Gym does, so their effects accumulate; each docstring gives the
resulting path under a schedule that fires at every step from 0, and names the rule to use for
the non-accumulating path.

Nothing here clamps except :class:`BoundedRandomWalk`: the game projects every proposal onto the
parameter's bounds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ns_pz.nature.schedulers import Scheduler, check_non_negative, check_step
from ns_pz.nature.updates import UpdateFn, check_in, check_real, check_reals


class NoUpdate(UpdateFn):
    """Leaves the value as it is (a placeholder that still consults its scheduler).

    Nothing changes, so nothing is notified (NS-Gym flags the firing anyway).
    """

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
    """Sets the value to ``param_list[n]`` at the n-th firing of the episode.

    Once the list is used up the value stays, and as nothing changes nothing is notified (NS-Gym
    keeps reporting a change). The list is never consumed: every episode starts from its head.
    """

    def __init__(self, scheduler: Scheduler, param_list: Sequence[float]) -> None:
        super().__init__(scheduler)
        self.param_list = check_reals("param_list", param_list)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """The n-th listed value, or ``value`` when the list is exhausted."""
        return self.param_list[n] if n < len(self.param_list) else value


class CyclicUpdate(UpdateFn):
    """Sets the value to ``value_list[n % len(value_list)]``: the list, round and round."""

    def __init__(self, scheduler: Scheduler, value_list: Sequence[float]) -> None:
        super().__init__(scheduler)
        self.value_list = check_reals("value_list", value_list)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """The next listed value, wrapping around."""
        return self.value_list[n % len(self.value_list)]


class DeterministicTrend(UpdateFn):
    """Adds ``slope * t`` at each firing.

    The term grows with ``t`` and is added to the current value, so under a schedule firing at
    every step from 0 the path is ``θ_0 + slope * t (t + 1) / 2`` (quadratic), as in NS-Gym. For a
    straight line use :class:`IncrementUpdate` (``k=slope``) or :class:`LinearInterpolation`.
    """

    def __init__(self, scheduler: Scheduler, slope: float) -> None:
        super().__init__(scheduler)
        self.slope = check_real("slope", slope)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value + slope * t``."""
        return value + self.slope * t


class PolynomialTrend(UpdateFn):
    """Adds ``sum_i coeffs[i] * t**(i + 1)`` at each firing (accumulates like the trend above)."""

    def __init__(self, scheduler: Scheduler, coeffs: Sequence[float]) -> None:
        super().__init__(scheduler)
        self.coeffs = check_reals("coeffs", coeffs)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value + coeffs[0] t + coeffs[1] t² + ...``."""
        return value + math.fsum(c * float(t) ** (i + 1) for i, c in enumerate(self.coeffs))


class OscillatingUpdate(UpdateFn):
    """Adds ``delta * sin(t)`` at each firing (``t`` in radians, one per step).

    As in NS-Gym the term is added to the current value. Under a schedule firing at every step
    from 0 the value is ``θ_0 + delta * (cos(1/2) - cos(t + 1/2)) / (2 sin(1/2))``: an
    oscillation of period 2π steps and amplitude ``1.043 * delta`` around
    ``θ_0 + 0.915 * delta``, not around θ_0. For a wave centred on a value, use
    :class:`CyclicUpdate` with the values you want.
    """

    def __init__(self, scheduler: Scheduler, delta: float) -> None:
        super().__init__(scheduler)
        self.delta = check_real("delta", delta)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value + delta * sin(t)``."""
        return value + self.delta * math.sin(t)


class ExponentialDecay(UpdateFn):
    """Multiplies the value by ``exp(-decay_rate * t)`` at each firing.

    As in NS-Gym the factor depends on ``t`` and multiplies the current value, so under a
    schedule firing at every step from 0 the path is ``θ_0 exp(-decay_rate t (t + 1) / 2)``,
    faster than exponential. For the plain exponential ``θ_0 exp(-decay_rate t)`` use
    :class:`GeometricProgression` with ``r = exp(-decay_rate)``.
    """

    def __init__(self, scheduler: Scheduler, decay_rate: float) -> None:
        super().__init__(scheduler)
        self.decay_rate = check_non_negative("decay_rate", decay_rate)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value * exp(-decay_rate * t)``."""
        return value * math.exp(-self.decay_rate * t)


class GeometricProgression(UpdateFn):
    """Multiplies the value by ``r`` at each firing."""

    def __init__(self, scheduler: Scheduler, r: float) -> None:
        super().__init__(scheduler)
        self.r = check_real("r", r)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value * r``."""
        return value * self.r


class SigmoidTransition(UpdateFn):
    """Sets the value to ``a + (b - a) / (1 + exp(-k (t - t0)))``: a smooth switch from a to b."""

    def __init__(self, scheduler: Scheduler, a: float, b: float, k: float, t0: float) -> None:
        super().__init__(scheduler)
        self.a = check_real("a", a)
        self.b = check_real("b", b)
        self.k = check_real("k", k)
        self.t0 = check_real("t0", t0)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """The logistic curve at ``t`` (the current value plays no part)."""
        z = -self.k * (t - self.t0)
        if z > 700.0:  # exp would overflow; the curve is at ``a`` to double precision
            return self.a
        return self.a + (self.b - self.a) / (1.0 + math.exp(z))


class LinearInterpolation(UpdateFn):
    """Sets the value to ``start_val + (end_val - start_val) * min(t / T, 1)``.

    ``t`` counts from reset, so the value reaches ``end_val`` at step ``T`` and stays there.
    """

    def __init__(self, scheduler: Scheduler, start_val: float, end_val: float, T: int) -> None:  # noqa: N803 - NS-Gym's name
        super().__init__(scheduler)
        self.start_val = check_real("start_val", start_val)
        self.end_val = check_real("end_val", end_val)
        self.T = check_step("T", T)
        if self.T < 1:
            raise ValueError(f"T={T!r} must be >= 1 (the step at which end_val is reached)")

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """The point of the line at ``t`` (the current value plays no part)."""
        return self.start_val + (self.end_val - self.start_val) * min(t / self.T, 1.0)


class RandomWalk(UpdateFn):
    """Adds a Gaussian step N(mu, sigma²) drawn from nature's generator at each firing."""

    def __init__(self, scheduler: Scheduler, mu: float = 0.0, sigma: float = 1.0) -> None:
        super().__init__(scheduler)
        self.mu = check_real("mu", mu)
        self.sigma = check_non_negative("sigma", sigma)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``value + N(mu, sigma²)``."""
        return value + self.mu + self.sigma * float(rng.standard_normal())


class RandomWalkWithDrift(UpdateFn):
    """Adds ``alpha`` plus a Gaussian step N(mu, sigma²) at each firing."""

    def __init__(self, scheduler: Scheduler, alpha: float, mu: float, sigma: float) -> None:
        super().__init__(scheduler)
        self.alpha = check_real("alpha", alpha)
        self.mu = check_real("mu", mu)
        self.sigma = check_non_negative("sigma", sigma)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``alpha + value + N(mu, sigma²)``."""
        return self.alpha + value + self.mu + self.sigma * float(rng.standard_normal())


class RandomWalkWithDriftAndTrend(UpdateFn):
    """Adds ``alpha + slope * t`` plus a Gaussian step N(mu, sigma²) at each firing.

    The trend term accumulates as in :class:`DeterministicTrend`.
    """

    def __init__(
        self, scheduler: Scheduler, alpha: float, mu: float, sigma: float, slope: float
    ) -> None:
        super().__init__(scheduler)
        self.alpha = check_real("alpha", alpha)
        self.mu = check_real("mu", mu)
        self.sigma = check_non_negative("sigma", sigma)
        self.slope = check_real("slope", slope)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``alpha + value + N(mu, sigma²) + slope * t``."""
        noise = self.mu + self.sigma * float(rng.standard_normal())
        return self.alpha + value + noise + self.slope * t


class BoundedRandomWalk(UpdateFn):
    """A Gaussian random walk N(mu, sigma²) clipped to ``[lo, hi]`` after each step."""

    def __init__(self, scheduler: Scheduler, mu: float, sigma: float, lo: float, hi: float) -> None:
        super().__init__(scheduler)
        self.mu = check_real("mu", mu)
        self.sigma = check_non_negative("sigma", sigma)
        self.lo = check_real("lo", lo)
        self.hi = check_real("hi", hi)
        if self.hi < self.lo:
            raise ValueError(f"hi={hi!r} is below lo={lo!r}; need lo <= hi")

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """``clip(value + N(mu, sigma²), lo, hi)``."""
        moved = value + self.mu + self.sigma * float(rng.standard_normal())
        return min(max(moved, self.lo), self.hi)


class OrnsteinUhlenbeck(UpdateFn):
    """Mean reversion: ``value + theta (mu - value) + N(0, sigma²)`` at each firing.

    ``theta`` is the fraction of the gap to ``mu`` closed per firing; with ``sigma=0`` (the
    default) no random number is drawn and the value approaches ``mu`` geometrically.
    """

    def __init__(self, scheduler: Scheduler, theta: float, mu: float, sigma: float = 0.0) -> None:
        super().__init__(scheduler)
        self.theta = check_in("theta", theta, 0.0, 1.0)
        self.mu = check_real("mu", mu)
        self.sigma = check_non_negative("sigma", sigma)

    def update(self, value: float, t: int, n: int, rng: np.random.Generator) -> float:
        """One Euler step of the Ornstein-Uhlenbeck process."""
        moved = value + self.theta * (self.mu - value)
        if self.sigma > 0.0:
            moved += self.sigma * float(rng.standard_normal())
        return moved
