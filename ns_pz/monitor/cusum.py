"""CUSUM change detection on tabular families: log-likelihood ratios against θ_0's kernel.

Every observed transition ``(s, a, s')`` has a probability under any θ, read off the family's
explicit outcome table (:class:`~ns_pz.planning.TabularOutcomes`): the sum of the probabilities
of the outcomes of ``(s, a)`` that lead to ``s'``. The detector compares a reference with every
point θ_g of a grid over each parameter's domain (one parameter varied, the others at θ_0): one
CUSUM per grid point::

    W_g(t) = max(0, W_g(t-1) + log P_g(s'|s, a) - log P_ref(s'|s, a)),

and raises an alarm when ``max_g W_g`` exceeds the threshold ``h``. This is the generalised
likelihood ratio over the grid (the unknown post-change θ is the grid point that explains the
data best since its CUSUM last restarted), Lorden's multi-CUSUM.

The reference is θ_0's kernel until the first alarm. An alarm opens a segment for the parameter
whose CUSUM crossed: a posterior over that parameter's grid (uniform prior, the likelihood of
the transitions since the crossing CUSUM last stood at 0, the change-time estimate, then
updated by every transition), and the reference becomes the posterior predictive
``Σ_g w_g P_g``: the detector learns the new θ as data come instead of freezing a first guess.
Over a window starting at ``j``, a Bayesian mixture is beaten by a grid point ``g`` by at most
``log(1 / w_g(j))``, so while θ stays put the CUSUMs cross only on runs of unlikely data (the
same false alarms as before any change), and a later change, towards values the posterior had
ruled out, raises a new alarm, which opens a new segment.

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
opened, with the segment's parameter at its posterior mean. An alarm's notification flags that
parameter, with the family's change size (:meth:`~ns_pz.params.Params.change_sizes`) between
the θ believed before the alarm and after it: the first alarm's size is the estimated distance
from θ_0.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ns_pz.checks import count, positive_number
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
        "restarts",
        "recent",
        "segment",
        "segment_age",
        "alarms",
        "trace",
    )

    def __init__(self, theta0: Params, grids: tuple[_ParamGrid, ...], window: int) -> None:
        self.reference = theta0
        """θ believed when the current segment opened (θ_0 before any alarm)."""
        self.grids = grids
        """Each watched parameter's grid, built around :attr:`built_around`."""
        self.built_around = theta0
        """The θ the grids hold the other parameters at."""
        sizes = [len(grid.values) for grid in grids]
        self.statistics = [np.zeros(size) for size in sizes]
        """``W_g`` of each watched parameter's grid."""
        self.restarts = [np.zeros(size, np.int64) for size in sizes]
        """Transition index after which each ``W_g`` last stood at 0."""
        self.recent: deque[tuple[int, int, int, int]] = deque(maxlen=window)
        """The last transitions as (index, state, action, next state)."""
        self.segment: tuple[int, np.ndarray] | None = None
        """(grid index, log posterior weights over that grid) since the last alarm."""
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
            steps and mean delays of 22, 44, 44, 55 steps (30 runs each).
        grid_step: Spacing of the grid over a probability vector's simplex (every vector whose
            entries are multiples of ``grid_step``; must divide 1). ``0.05`` gives 231 points
            for 3 outcomes and 1,771 for 4.
        scalar_points: Number of evenly spaced grid values over a scalar parameter's bounds
            (which must be finite).
        window: Most recent transitions kept to start a segment's posterior at an alarm.
        params: Names of the parameters to watch; default every parameter.

    Raises:
        ValueError: A non-positive or non-finite threshold, a
            ``grid_step`` that does not divide 1, fewer than 2 ``scalar_points``.
    """

    def __init__(
        self,
        threshold: float = 10.0,
        grid_step: float = 0.05,
        scalar_points: int = 41,
        window: int = 1000,
        params: Sequence[str] | None = None,
    ) -> None:
        window = count("window", window)
        if not isinstance(grid_step, (int, float)) or not 0.0 < grid_step <= 1.0:
            raise ValueError(f"grid_step={grid_step!r} must be in (0, 1] and divide 1")
        if abs(round(1.0 / grid_step) * grid_step - 1.0) > 1e-9:
            raise ValueError(f"grid_step={grid_step!r} must divide 1 (0.1, 0.05, 0.02, ...)")
        if isinstance(scalar_points, bool) or not isinstance(scalar_points, int):
            raise TypeError(f"scalar_points={scalar_points!r} must be an int >= 2")
        if scalar_points < 2:
            raise ValueError(f"scalar_points={scalar_points!r} must be >= 2")
        self.threshold = positive_number("threshold", threshold)
        self.grid_step = float(grid_step)
        self.scalar_points = scalar_points
        self.window = window
        self.watched = watched_names(params)
        self._grids: tuple[_ParamGrid, ...] = ()
        self._names: tuple[str, ...] = ()
        self._positions: tuple[int, ...] = ()
        self._half_steps: tuple[float, ...] = ()
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
        self._family = family
        self._theta0 = theta0
        self._grid_values = tuple(
            _grid_values(family.params_cls.spec(name), self.grid_step, self.scalar_points)
            for name in names
        )
        self._names = tuple(names)
        all_names = family.params_cls.names()
        self._positions = tuple(all_names.index(name) for name in names)
        self._half_steps = tuple(
            0.5 * (self.grid_step if family.params_cls.spec(name).kind == SIMPLEX else _spacing(v))
            for name, v in zip(names, self._grid_values, strict=True)
        )
        self._value_arrays = tuple(np.asarray(v, np.float64) for v in self._grid_values)
        self._grids = self._grids_around(theta0)
        self._structure = reference.next_states
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
        return TabularCusumMemory(self._bound_theta0(), self._grids, self.window)

    def copy_memory(self, memory: TabularCusumMemory) -> TabularCusumMemory:
        """The belief alone, for a planning copy: the reference, grids and segment posterior.

        Without the episode's timeline (recent transitions, restarts, alarms, trace), which a
        deep copy would carry at a cost growing with the episode.
        """
        fresh = TabularCusumMemory(memory.reference, memory.grids, self.window)
        fresh.built_around = memory.built_around
        if memory.segment is not None:
            index, log_weights = memory.segment
            fresh.segment = (index, log_weights.copy())
            fresh.segment_age = memory.segment_age
        return fresh

    def believed_theta(self, memory: TabularCusumMemory) -> Params:
        """The θ believed at the last alarm, its parameter at its posterior mean (θ_0 before)."""
        if memory.segment is None:
            return memory.reference
        return self._posterior_mean(memory, *memory.segment)

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
        reached_state = int(observation["state"])
        transition = int(observation["relative_time"][0]) - 1
        memory.recent.append((transition, state, action, reached_state))
        assert self._theta0_probs is not None
        likelihoods = [self._likelihoods(g, state, action, reached_state) for g in memory.grids]
        reached = self._structure[state, action] == reached_state
        if memory.segment is None:
            p_ref = float(self._theta0_probs[state, action][reached].sum())
        else:
            index, log_weights = memory.segment
            weights = np.exp(log_weights - log_weights.max())
            p_ref = float(weights @ likelihoods[index] / weights.sum())
            with np.errstate(divide="ignore"):
                log_weights += np.log(likelihoods[index])
            if not np.isfinite(log_weights.max()):  # nothing on the grid explains the data
                log_weights[:] = 0.0
            memory.segment_age = age = memory.segment_age + 1
            if len(memory.grids) > 1 and age & (age - 1) == 0:  # 1, 2, 4, 8, ... in
                self._follow_segment(memory, index, log_weights)
        impossible = p_ref <= 0.0
        log_ref = math.log(max(p_ref, FLOOR))
        best, best_index = -1.0, -1
        for index, p_grid in enumerate(likelihoods):
            with np.errstate(divide="ignore"):
                ratio = np.log(p_grid) - log_ref
            stat = np.maximum(memory.statistics[index] + ratio, 0.0)
            memory.statistics[index] = stat
            memory.restarts[index][stat == 0.0] = transition
            top = float(stat.max())
            if top > best:
                best, best_index = top, index
        memory.trace.append(best)
        if not (impossible or best > self.threshold):
            return quiet
        return self._alarm(memory, best_index, transition)

    def _alarm(
        self, memory: TabularCusumMemory, index: int, transition: int
    ) -> tuple[Flags, Sizes]:
        """Open a segment for grid ``index``'s parameter; restart the CUSUMs; notify."""
        old = self.believed_theta(memory)
        stat = memory.statistics[index]
        start = int(memory.restarts[index][int(np.argmax(stat))])
        grid = memory.grids[index]
        log_weights = np.zeros(len(grid.values))
        with np.errstate(divide="ignore"):
            for when, state, action, reached in memory.recent:
                if when > start:
                    log_weights += np.log(self._likelihoods(grid, state, action, reached))
        if not np.isfinite(log_weights.max()):
            log_weights = stat.copy()
        memory.restarts = [np.full_like(r, transition) for r in memory.restarts]
        memory.segment = (index, log_weights)
        memory.segment_age = 0
        memory.reference = old
        memory.reference = new = self._posterior_mean(memory, index, log_weights)
        if len(memory.grids) > 1:  # one parameter's grid is the same around any θ
            memory.grids = self._grids_around(new)
            memory.built_around = new
        memory.statistics = [np.zeros_like(s) for s in memory.statistics]
        memory.alarms.append(transition)
        name = grid.name
        flags = tuple(int(n == name) for n in old.names())
        sizes = new.change_sizes(old)
        return flags, tuple(float(s) if f else 0.0 for s, f in zip(sizes, flags, strict=True))

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

    def _likelihoods(self, grid: _ParamGrid, state: int, action: int, reached: int) -> np.ndarray:
        """Probability of ``state --action--> reached`` under each grid point."""
        assert self._structure is not None
        hits = self._structure[state, action] == reached
        return grid.probs[state, action][:, hits].sum(axis=1)

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
            f"scalar_points={self.scalar_points}, params={self.watched!r})"
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
