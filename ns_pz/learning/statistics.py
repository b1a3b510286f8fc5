"""Robust summaries of returns with bootstrap confidence intervals.

Two levels, as robust-RL results need them:

* Over the episodes of one policy: the mean, the lower ``alpha``-quantile, the conditional
  value at risk (CVaR: the mean of the worst ``alpha`` fraction of episodes) and the worst
  condition's mean. Episodes of different conditions that share a seed are paired (common
  random numbers), so their bootstrap resamples the same seeds in every condition.
* Over training seeds (runs): the interquartile mean (IQM, the mean of the middle half, as
  rliable recommends for few runs) with a percentile bootstrap over runs.

Computed with NumPy alone (rliable's definitions: IQM is the 25 %-trimmed mean, the bootstrap
resamples runs with replacement), so no extra package is needed.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ns_pz.checks import count, fraction, seed_value


@dataclass(frozen=True)
class Estimate:
    """A statistic with its bootstrap confidence interval."""

    value: float
    low: float
    high: float

    def format(self, decimals: int) -> str:
        """``value [low, high]`` with ``decimals`` digits after the point."""
        return f"{self.value:.{decimals}f} [{self.low:.{decimals}f}, {self.high:.{decimals}f}]"

    def __str__(self) -> str:
        return self.format(decimals_for(abs(self.value)))


def decimals_for(magnitude: float) -> int:
    """Digits after the point that show a return of this size: 3 below 10, else 1."""
    return 3 if magnitude < 10 else 1


def lower_quantile(returns: np.ndarray, alpha: float) -> np.ndarray | float:
    """The ``alpha``-quantile of ``returns`` (NumPy's linear interpolation) along the last axis."""
    return np.quantile(returns, alpha, axis=-1)


def cvar(returns: np.ndarray, alpha: float) -> np.ndarray | float:
    """The lower-tail CVaR along the last axis: the mean of the worst ``ceil(alpha * n)``.

    Raises:
        ValueError: ``alpha`` is not a number in (0, 1] (1: the mean), or there are no returns.
    """
    if isinstance(alpha, bool) or not isinstance(alpha, numbers.Real) or not 0 < alpha <= 1:
        raise ValueError(f"alpha={alpha!r} must be a number in (0, 1]")
    returns = np.asarray(returns, dtype=float)
    if returns.ndim == 0 or returns.shape[-1] == 0:
        raise ValueError(f"returns has shape {returns.shape}; it needs at least one return")
    worst = max(1, math.ceil(alpha * returns.shape[-1]))
    return np.sort(returns, axis=-1)[..., :worst].mean(axis=-1)


def interquartile_mean(values: Sequence[float] | np.ndarray) -> np.ndarray | float:
    """The mean of the middle half along the last axis (the 25 % trimmed mean).

    ``floor(n / 4)`` values are cut from each end.

    Raises:
        ValueError: There are no values.
    """
    ordered = np.sort(np.asarray(values, dtype=float), axis=-1)
    if ordered.ndim == 0 or ordered.shape[-1] == 0:
        raise ValueError(f"values has shape {ordered.shape}; the IQM needs at least one value")
    n = ordered.shape[-1]
    cut = n // 4
    return ordered[..., cut : n - cut].mean(axis=-1)


def bootstrap(
    samples: np.ndarray,
    statistic: Callable[[np.ndarray], np.ndarray],
    *,
    confidence: float = 0.95,
    reps: int = 2000,
    rng: np.random.Generator,
) -> Estimate:
    """``statistic`` of ``samples`` with a percentile bootstrap interval.

    Args:
        samples: ``[n]`` or ``[n, conditions]``: rows are resampled with replacement, so the
            columns of one row (the conditions of one seed) stay paired.
        statistic: Maps a batch of arrays shaped like ``samples``, ``[batch, n, ...]``, to
            ``[batch]`` numbers.
        confidence: The interval's coverage, in (0, 1).
        reps: Bootstrap resamples.
        rng: The generator of the resampling.
    """
    confidence = fraction("confidence", confidence)
    reps = count("reps", reps)
    samples = np.asarray(samples, dtype=float)
    value = float(np.asarray(statistic(samples[None]))[0])
    n = len(samples)
    if n < 2:
        return Estimate(value, value, value)
    draws = np.asarray(statistic(samples[rng.integers(n, size=(reps, n))]))
    tail = (1.0 - confidence) / 2.0
    low, high = np.quantile(draws, [tail, 1.0 - tail])
    return Estimate(value, float(low), float(high))


def aggregate_runs(
    scores: Sequence[float],
    *,
    confidence: float = 0.95,
    reps: int = 5000,
    seed: int = 0,
) -> Estimate:
    """The interquartile mean over training runs with a percentile bootstrap over runs.

    Raises:
        ValueError: Scores that are not a non-empty list of finite numbers, ``confidence``
            outside (0, 1), ``reps`` below 1 or a negative ``seed``.
    """
    values = np.asarray(scores, dtype=float)
    if values.ndim != 1 or len(values) == 0 or not np.all(np.isfinite(values)):
        raise ValueError(f"scores={scores!r} must be a non-empty list of finite numbers")
    reps = count("reps", reps)
    rng = np.random.default_rng(seed_value("seed", seed))
    return bootstrap(values, interquartile_mean, confidence=confidence, reps=reps, rng=rng)
