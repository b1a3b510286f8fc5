"""CUSUM change detection on tabular families: log-likelihood ratios against θ_0's kernel.

Every observed transition ``(s, a, s', r)`` has a probability under any θ, read off the family's
explicit outcome table (:class:`~ns_pz.planning.TabularOutcomes`): the sum of the probabilities
of the outcomes of ``(s, a)`` that lead to ``s'`` with reward ``r`` (the reward tells apart
outcomes that reach one state: on CliffWalking a bump into the wall next to the start and a fall
into the cliff both end on the start, with rewards -1 and -100; if no outcome of the θ_0 table
has the observed reward, ``s'`` alone is matched). The detector compares a reference with every
point θ_g of a grid over each parameter's domain (one parameter varied, the others at θ_0): one
CUSUM per grid point::

    W_g(t) = max(0, W_g(t-1) + log P_g(s'|s, a) - log P_ref(s'|s, a)),

and raises an alarm when ``max_g W_g`` exceeds the threshold ``h``. This is the generalised
likelihood ratio over the grid (the unknown post-change θ is the grid point that explains the
data best since its CUSUM last restarted), Lorden's multi-CUSUM.

The reference is θ_0's kernel until the first alarm. An alarm opens a segment for the parameter
whose CUSUM crossed, with two posteriors over that parameter's grid, which share one likelihood
(every transition since the last alarm, then every later one) and differ by their prior:

* The **tested** posterior, under a uniform prior, gives the reference: its predictive
  ``Σ_g w_g P_g``, so the detector learns the new θ as data come instead of freezing a first
  guess. Over a window starting at ``j``, a Bayesian mixture is beaten by a grid point ``g`` by
  at most ``log(1 / w_g(j))``, which a uniform prior keeps at most ``log G`` at the alarm: while
  θ stays put the CUSUMs cross only on runs of unlikely data (the same false alarms as before
  any change), and a later change, towards values the posterior had ruled out, raises a new
  alarm, which opens a new segment.
* The **believed** posterior, under a prior concentrated near the value believed before the
  alarm, gives what the detector reports and the planner at ``detailed`` plans with.

The likelihood at an alarm is that of every transition since the last alarm (or reset) with the
change time uniform over them: the Shiryaev–Roberts sum of the likelihood ratio over change
times, kept for every grid point as data come::

    R_g(t) = (1 + R_g(t-1)) · P_g(x_t) / P_ref(x_t),   R_g = 0 at a segment start.

The believed prior makes the change's size (:meth:`~ns_pz.params.Params.change_sizes`, in units
of the parameter's range: 1 for a probability vector) exponential with mean ``change_scale``,
uniform among the grid points of one size. Why: when θ_0 is deterministic (CliffWalking's shipped
specs) the first alarm comes with the first slip. A CUSUM's last-zero window keeps that one
transition alone, and under a uniform prior over the simplex the belief is then
p(intended) ≈ 0.2 whatever the truth (0.19 in every run of CliffWalking 1.0 → 0.8): one slip
cannot tell a change of 0.2 from one of 0.8. The sum over change times keeps the intended moves
that may have come after the change, and the prior says that small changes are likelier than
large ones. On CliffWalking 1.0 → 0.4 / 0.6 / 0.8 (a random walker, 100 runs) the median belief
at the first alarm is 0.66 / 0.68 / 0.70 (the last-zero window under a uniform prior: 0.19 in all
three), and 20 steps later 0.46 / 0.61 / 0.78 (0.35 / 0.49 / 0.69). Using the believed posterior
as the reference too raised re-alarms after a large change, whose value the prior had made
unlikely (``log(1 / w_g)`` above ``h``).

A transition impossible under the reference (``P_ref = 0``) is a certain change: it raises an
alarm at once, whatever ``h``. Its log-likelihood ratio is computed with ``P_ref`` floored at
``1e-12``, which ranks the grid points by how well they explain it.

Each parameter's grid varies that parameter with the others at the θ believed: at θ_0 until the
first alarm, then at the θ believed since. When more than one parameter is watched, the other
grids are rebuilt at each alarm and, 1, 2, 4, 8, ... transitions into a segment, when its
posterior mean has moved by more than half a grid step since they were built. So once two
parameters have changed, each parameter's CUSUM compares against the other's estimate, not its
θ_0 value (which kept alarming, alternately, forever), nor a stale early estimate (which slowed
the second detection).

The believed θ (:meth:`TabularCusumMonitor.believed_theta`) is the θ believed when the segment
opened, with the segment's parameter at its believed posterior mean. An alarm's notification
flags that parameter, with the family's change size (:meth:`~ns_pz.params.Params.change_sizes`)
between the θ believed before the alarm and after it: the first alarm's size is the estimated
distance from θ_0.
"""

from __future__ import annotations

import itertools
import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ns_pz.checks import positive_number
from ns_pz.family import EnvFamily
from ns_pz.monitor.monitors import (
    Detector,
    Flags,
    Sizes,
    has_transition,
    silence,
    watched_names,
)
from ns_pz.params import SIMPLEX, Params, ParamSpec

FLOOR = 1e-12
"""Probability a transition impossible under the reference is given in its log-likelihood ratio."""
MAX_GRID_BYTES = 2**28
"""Most memory the outcome tables of one parameter's grid may take (256 MiB)."""


@dataclass(frozen=True)
class _ParamGrid:
    """The grid of one parameter and the outcome probabilities of each grid point."""

    name: str
    values: tuple[Any, ...]
    probs: np.ndarray
    """``[S, A, G, K]`` outcome probabilities with the parameter at each grid value and the
    others at the θ the grid was built around (grid axis third, so one (state, action) is one
    contiguous block); read-only."""

    def __deepcopy__(self, memo: dict[int, Any]) -> _ParamGrid:
        return self  # immutable: a copied memory (a planning copy's) shares it


class TabularCusumMemory:
    """One episode's detector state."""

    __slots__ = (
        "reference",
        "grids",
        "built_around",
        "statistics",
        "mixtures",
        "segment",
        "segment_age",
        "alarms",
        "trace",
    )

    def __init__(self, theta0: Params, grids: tuple[_ParamGrid, ...]) -> None:
        self.reference = theta0
        """θ believed when the current segment opened (θ_0 before any alarm)."""
        self.grids = grids
        """Each watched parameter's grid, built around :attr:`built_around`."""
        self.built_around = theta0
        """The θ the grids hold the other parameters at."""
        sizes = [len(grid.values) for grid in grids]
        self.statistics = [np.zeros(size) for size in sizes]
        """``W_g`` of each watched parameter's grid."""
        self.mixtures = [np.full(size, -np.inf) for size in sizes]
        """``log R_g`` of each grid: the likelihood ratio summed over change times since the
        last alarm (see the module doc)."""
        self.segment: tuple[int, np.ndarray, np.ndarray] | None = None
        """(grid index, log likelihood, log prior) over that grid since the last alarm."""
        self.segment_age = 0
        """Transitions seen since the last alarm."""
        self.alarms: list[int] = []
        """Transition indices whose notification raised an alarm."""
        self.trace: list[float] = []
        """The statistic ``max_g W_g`` after each transition (before a restart)."""


class TabularCusumMonitor(Detector):
    """GLR-CUSUM over a grid of θ on a tabular family's outcome table (see the module doc).

    Args:
        threshold: The alarm threshold ``h`` on ``max_g W_g`` (nats). Larger: fewer false alarms,
            longer delays. On FrozenLake 4x4 (slip 0.7 → 0.4, uniform random states and
            actions) ``h = 6, 8, 10, 12`` gave about 13, 2.3, 0.4, 0 false alarms per 1,000
            steps and mean delays of 22, 44, 44, 55 steps (30 runs each). One CUSUM alone
            would guarantee ARL₀ ≥ ``e^h`` steps to a false alarm in an unchanging world; the
            maximum over a bank of ``G`` CUSUMs (231 grid points over 3 outcomes, 1,771 over 4)
            alarms sooner. Measured, FrozenLake 4x4 at slip (0.7, 0.15, 0.15), uniform random
            states and actions, 20 runs each: ``h = 4, 6, 8, 10`` gave ARL₀ ≈ 45, 170, 1,010,
            6,361 steps (``e^h`` = 55, 403, 2,981, 22,026): so for a target ARL₀ of a few
            hundred steps or more take ``h ≈ ln(ARL₀) + 1.3`` there; ``h = ln(G · ARL₀)`` (a
            union bound over the bank) is safe but conservative. A deterministic θ_0 raises no
            false alarm before a change.
        grid_step: Spacing of the grid over a probability vector's simplex (every vector whose
            entries are multiples of ``grid_step``; must divide 1). ``0.05`` gives 231 points
            for 3 outcomes and 1,771 for 4.
        scalar_points: Number of evenly spaced grid values over a scalar parameter's bounds
            (which must be finite).
        change_scale: Mean size of a change under the prior of the posterior an alarm opens,
            as a fraction of the parameter's range (1 for a probability vector, ``high - low``
            for a scalar); see the module doc. Smaller: a first alarm believes in a smaller
            change.
        params: Names of the parameters to watch; default every parameter.

    Raises:
        ValueError: A non-positive or non-finite threshold or ``change_scale``, a
            ``grid_step`` that does not divide 1, fewer than 2 ``scalar_points``; at
            :meth:`bind`, a grid whose outcome tables would take more than
            :data:`MAX_GRID_BYTES`.
    """

    def __init__(
        self,
        threshold: float = 10.0,
        grid_step: float = 0.05,
        scalar_points: int = 41,
        *,
        change_scale: float = 0.2,
        params: Sequence[str] | None = None,
    ) -> None:
        real = isinstance(grid_step, numbers.Real) and not isinstance(grid_step, bool)
        step = float(grid_step) if real else math.nan
        if not 0.0 < step <= 1.0:
            raise ValueError(f"grid_step={grid_step!r} must be a number in (0, 1] that divides 1")
        if abs(round(1.0 / step) * step - 1.0) > 1e-9:
            raise ValueError(
                f"grid_step={grid_step!r} must divide 1 (0.1, 0.05, 0.02, ...); as a float it "
                f"is {step!r}"
            )
        if isinstance(scalar_points, bool) or not isinstance(scalar_points, (int, np.integer)):
            raise TypeError(f"scalar_points={scalar_points!r} must be an int >= 2")
        if int(scalar_points) < 2:
            raise ValueError(f"scalar_points={scalar_points!r} must be >= 2")
        self.threshold = positive_number("threshold", threshold)
        self.grid_step = step
        self.scalar_points = int(scalar_points)
        self.change_scale = positive_number("change_scale", change_scale)
        self.watched = watched_names(params)
        self._grids: tuple[_ParamGrid, ...] = ()
        self._names: tuple[str, ...] = ()
        self._positions: tuple[int, ...] = ()
        self._half_steps: tuple[float, ...] = ()
        self._spacings: tuple[float, ...] = ()
        self._spans: tuple[float, ...] = ()
        self._rewards: np.ndarray | None = None
        self._grid_values: tuple[tuple[Any, ...], ...] = ()
        self._value_arrays: tuple[np.ndarray, ...] = ()
        self._structure: np.ndarray | None = None
        self._theta0_probs: np.ndarray | None = None

    def bind(self, family: EnvFamily, theta0: Params) -> None:
        """Read the outcome table under θ_0 and under every grid point.

        Raises:
            TypeError: The family has no explicit outcome table (use
                :class:`~ns_pz.monitor.PredictionErrorMonitor` on continuous families).
            UnknownParam: A watched name is not a parameter.
            ValueError: A watched scalar parameter has an infinite bound; already bound to
                another family or θ_0.
        """
        if self._already_bound(family, theta0):
            return
        names = family.params_cls.names() if self.watched is None else self.watched
        family.params_cls.check_names(names)
        reference = _outcome_table(family, theta0)
        for name in names:
            _check_grid_size(family.params_cls.spec(name), self.grid_step, reference.probs.size)
        self._family = family
        self._theta0 = theta0
        self._grid_values = tuple(
            _grid_values(family.params_cls.spec(name), self.grid_step, self.scalar_points)
            for name in names
        )
        self._names = tuple(names)
        all_names = family.params_cls.names()
        self._positions = tuple(all_names.index(name) for name in names)
        specs = [family.params_cls.spec(name) for name in names]
        self._spacings = tuple(
            self.grid_step if spec.kind == SIMPLEX else _spacing(values)
            for spec, values in zip(specs, self._grid_values, strict=True)
        )
        self._half_steps = tuple(0.5 * spacing for spacing in self._spacings)
        self._spans = tuple(1.0 if spec.kind == SIMPLEX else spec.high - spec.low for spec in specs)
        self._value_arrays = tuple(np.asarray(v, np.float64) for v in self._grid_values)
        self._grids = self._grids_around(theta0)
        self._structure = reference.next_states
        self._rewards = reference.rewards.astype(np.float32)  # as the observation shows them
        self._theta0_probs = reference.probs

    def _grids_around(self, theta: Params, skip: int | None = None) -> tuple[_ParamGrid, ...]:
        """Each watched parameter's grid, the other parameters at their values in ``theta``.

        The grid at index ``skip``, if given, is not built (an empty placeholder stands there).
        """
        family = self._family
        assert family is not None  # bound
        grids = []
        for i, (name, values) in enumerate(zip(self._names, self._grid_values, strict=True)):
            if i == skip:
                grids.append(_ParamGrid(name, values, np.empty(0)))
                continue
            probs = np.stack(
                [_outcome_table(family, theta.replace(**{name: v})).probs for v in values],
                axis=2,
            )
            probs.flags.writeable = False
            grids.append(_ParamGrid(name, values, probs))
        return tuple(grids)

    def initial_memory(self) -> TabularCusumMemory:
        """θ_0 as the reference, every CUSUM at 0."""
        return TabularCusumMemory(self._bound_theta0(), self._grids)

    def copy_memory(self, memory: TabularCusumMemory) -> TabularCusumMemory:
        """The belief alone, for a planning copy: the reference, grids and segment posterior.

        Without the episode's timeline (alarms, trace), which a deep copy would carry at a cost
        growing with the episode.
        """
        fresh = TabularCusumMemory(memory.reference, memory.grids)
        fresh.built_around = memory.built_around
        if memory.segment is not None:
            index, log_likelihood, log_prior = memory.segment
            fresh.segment = (index, log_likelihood.copy(), log_prior)
            fresh.segment_age = memory.segment_age
        return fresh

    def believed_theta(self, memory: TabularCusumMemory) -> Params:
        """The θ believed at the last alarm, its parameter at its posterior mean (θ_0 before)."""
        if memory.segment is None:
            return memory.reference
        index, log_likelihood, log_prior = memory.segment
        return self._posterior_mean(memory, index, log_likelihood + log_prior)

    def notify(
        self,
        observation: dict[str, Any] | None,
        truth: Sequence[float] | None,
        memory: TabularCusumMemory,
        rng: np.random.Generator,
    ) -> tuple[Flags, Sizes]:
        """Update every CUSUM with the last transition; flag a parameter when its crosses ``h``."""
        quiet = silence(len(memory.reference.names()))
        if not has_transition(observation):
            return quiet
        assert observation is not None and self._structure is not None  # has_transition
        state = int(observation["last_state"])
        action = int(observation["last_action"])
        hits = self._hits(state, action, int(observation["state"]), observation["last_reward"][0])
        transition = int(observation["relative_time"][0]) - 1
        assert self._theta0_probs is not None
        likelihoods = [grid.probs[state, action][:, hits].sum(axis=1) for grid in memory.grids]
        if memory.segment is None:
            p_ref = float(self._theta0_probs[state, action][hits].sum())
        else:
            index, log_likelihood, log_prior = memory.segment
            weights = np.exp(log_likelihood - log_likelihood.max())  # the uniform prior's
            p_ref = float(weights @ likelihoods[index] / weights.sum())
            with np.errstate(divide="ignore"):
                log_likelihood += np.log(likelihoods[index])
            if not np.isfinite(log_likelihood.max()):  # nothing on the grid explains the data
                log_likelihood[:] = 0.0
            memory.segment_age = age = memory.segment_age + 1
            if len(memory.grids) > 1 and age & (age - 1) == 0:  # 1, 2, 4, 8, ... in
                self._follow_segment(memory, index, log_likelihood + log_prior)
        impossible = p_ref <= 0.0
        log_ref = math.log(max(p_ref, FLOOR))
        best, best_index = -1.0, -1
        for index, p_grid in enumerate(likelihoods):
            with np.errstate(divide="ignore"):
                ratio = np.log(p_grid) - log_ref
            stat = np.maximum(memory.statistics[index] + ratio, 0.0)
            memory.statistics[index] = stat
            memory.mixtures[index] = np.logaddexp(memory.mixtures[index], 0.0) + ratio
            top = float(stat.max())
            if top > best:
                best, best_index = top, index
        memory.trace.append(best)
        if not (impossible or best > self.threshold):
            return quiet
        return self._alarm(memory, best_index, transition)

    def _hits(self, state: int, action: int, reached: int, reward: Any) -> np.ndarray:
        """Which outcomes of ``(state, action)`` give ``(reached, reward)`` (``[K]`` bools).

        Matched on the state alone if no outcome to ``reached`` has that reward.
        """
        assert self._structure is not None and self._rewards is not None
        to_state = self._structure[state, action] == reached
        exact = to_state & (self._rewards[state, action] == np.float32(reward))
        return exact if exact.any() else to_state

    def _alarm(
        self, memory: TabularCusumMemory, index: int, transition: int
    ) -> tuple[Flags, Sizes]:
        """Open a segment for grid ``index``'s parameter; restart the CUSUMs; notify."""
        old = self.believed_theta(memory)
        grid = memory.grids[index]
        log_likelihood = memory.mixtures[index]
        if not np.isfinite(log_likelihood.max()):  # nothing on the grid explains the data
            log_likelihood = np.zeros_like(log_likelihood)
        log_prior = self._log_prior(index, getattr(old, grid.name))
        memory.segment = (index, log_likelihood, log_prior)
        memory.segment_age = 0
        memory.reference = old
        memory.reference = new = self._posterior_mean(memory, index, log_likelihood + log_prior)
        if len(memory.grids) > 1:  # one parameter's grid is the same around any θ
            memory.grids = self._grids_around(new)
            memory.built_around = new
        memory.statistics = [np.zeros_like(s) for s in memory.statistics]
        memory.mixtures = [np.full_like(m, -np.inf) for m in memory.mixtures]
        memory.alarms.append(transition)
        name = grid.name
        flags = tuple(int(n == name) for n in old.names())
        sizes = new.change_sizes(old)
        return flags, tuple(float(s) if f else 0.0 for s, f in zip(sizes, flags, strict=True))

    def _log_prior(self, index: int, believed: Any) -> np.ndarray:
        """Log prior over grid ``index`` for a change from ``believed`` (see the module doc).

        The size of a change to each grid value, in units of the parameter's range, is
        exponential with mean ``change_scale``; the grid values of one size (rounded to the
        grid's spacing) share its weight equally.
        """
        values = self._value_arrays[index]
        here = np.asarray(believed, np.float64)
        if values.ndim == 2:  # a probability vector: total variation
            distance = 0.5 * np.abs(values - here).sum(axis=1)
        else:
            distance = np.abs(values - here)
        span, spacing = self._spans[index], self._spacings[index]
        shells = np.rint(distance / spacing).astype(np.int64) if spacing > 0 else distance * 0
        _, shell, members = np.unique(shells, return_inverse=True, return_counts=True)
        return -distance / (span * self.change_scale) - np.log(members[shell])

    def _follow_segment(
        self, memory: TabularCusumMemory, index: int, log_weights: np.ndarray
    ) -> None:
        """Rebuild the other grids once the segment's estimate has moved by half a grid step."""
        believed = self._posterior_mean(memory, index, log_weights)
        moved = believed.change_sizes(memory.built_around)[self._positions[index]]
        if moved <= self._half_steps[index]:
            return
        kept = memory.grids[index]  # it varies the segment's parameter: the same around both
        memory.grids = tuple(
            kept if i == index else grid
            for i, grid in enumerate(self._grids_around(believed, skip=index))
        )
        memory.built_around = believed

    def _posterior_mean(
        self, memory: TabularCusumMemory, index: int, log_weights: np.ndarray
    ) -> Params:
        """The memory's reference θ with grid ``index``'s parameter at its posterior mean."""
        theta = memory.reference
        grid = memory.grids[index]
        weights = np.exp(log_weights - log_weights.max())
        weights /= weights.sum()
        spec = theta.spec(grid.name)
        values = self._value_arrays[index]  # the grid's values, as floats
        if spec.kind == SIMPLEX:
            mean = values.T @ weights
            estimate: Any = tuple(float(p) for p in mean / mean.sum())
        else:
            estimate = float(values @ weights)
        return theta.replace(**{grid.name: spec.project(type(theta).__name__, estimate)})

    def __repr__(self) -> str:
        return (
            f"TabularCusumMonitor(threshold={self.threshold}, grid_step={self.grid_step}, "
            f"scalar_points={self.scalar_points}, change_scale={self.change_scale}, "
            f"params={self.watched!r})"
        )


def _outcome_table(family: EnvFamily, theta: Params) -> Any:
    """The family's explicit outcome table under ``theta`` (through its planning model)."""
    model = family.planning_model(theta, None, np.random.default_rng(0))
    outcomes = getattr(model, "outcomes", None)
    if outcomes is None:
        raise TypeError(
            f"{family!r} has no explicit outcome table; TabularCusumMonitor works on tabular "
            "families (FrozenLake, CliffWalking, Bridge); use PredictionErrorMonitor on others"
        )
    return outcomes


def _grid_values(spec: ParamSpec, step: float, points: int) -> tuple[Any, ...]:
    """The grid over one parameter's domain (see :class:`TabularCusumMonitor`)."""
    if spec.kind == SIMPLEX:
        units = round(1.0 / step)
        return tuple(tuple(c / units for c in counts) for counts in _compositions(units, spec.size))
    if not (math.isfinite(spec.low) and math.isfinite(spec.high)):
        raise ValueError(
            f"parameter {spec.name!r} has bounds {spec.allowed()}; a grid needs finite bounds "
            "(watch other parameters with params=[...])"
        )
    values = np.linspace(spec.low, spec.high, points)
    return tuple(float(v) for v in values if spec.contains(float(v)))


def _check_grid_size(spec: ParamSpec, step: float, table_size: int) -> None:
    """Refuse a simplex grid whose outcome tables would take more than :data:`MAX_GRID_BYTES`.

    Raises:
        ValueError: ``step`` too fine for ``spec``'s vector; the message names the number of
            grid points and the memory they would take.
    """
    if spec.kind != SIMPLEX:
        return
    points = math.comb(round(1.0 / step) + spec.size - 1, spec.size - 1)
    needed = points * table_size * 8
    if needed > MAX_GRID_BYTES:
        raise ValueError(
            f"grid_step={step!r} gives {points:,} grid points over {spec.name!r} "
            f"({spec.size} outcomes), whose outcome tables would take {needed / 2**30:,.1f} GiB "
            f"(at most {MAX_GRID_BYTES / 2**30:.2f} GiB); use a coarser grid_step"
        )


def _spacing(values: tuple[Any, ...]) -> float:
    """The smallest gap between neighbouring values of a scalar grid."""
    return float(np.diff(np.asarray(values, np.float64)).min()) if len(values) > 1 else 0.0


def _compositions(total: int, parts: int) -> list[tuple[int, ...]]:
    """Every tuple of ``parts`` non-negative integers summing to ``total``."""
    result = []
    for bars in itertools.combinations(range(total + parts - 1), parts - 1):
        edges = (-1, *bars, total + parts - 1)
        result.append(tuple(edges[i + 1] - edges[i] - 1 for i in range(parts)))
    return result
