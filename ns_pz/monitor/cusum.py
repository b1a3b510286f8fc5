"""CUSUM change detection on tabular families: log-likelihood ratios against θ_0's kernel.

Every observed transition ``(s, a, s')`` has a probability under any θ, read off the family's
explicit outcome table (:class:`~ns_pz.planning.TabularOutcomes`): the sum of the probabilities
of the outcomes of ``(s, a)`` that lead to ``s'``. The detector compares the reference θ (θ_0
until a change is detected) with every point of a grid over each parameter's domain, the other
parameters held at the reference: one CUSUM per grid point θ_g,

    W_g(t) = max(0, W_g(t-1) + log P_g(s'|s, a) - log P_ref(s'|s, a)),

and raises an alarm when ``max_g W_g`` exceeds the threshold ``h``. This is the generalised
likelihood ratio over the grid (the unknown post-change θ is the grid point that explains the
data best since its CUSUM last restarted): with a grid of ``G`` points it is Lorden's multi-CUSUM,
whose false-alarm rate is at most ``G`` times that of one CUSUM, ``ARL ≳ e^h / G``.

A transition impossible under the reference (``P_ref = 0``) is a certain change: it raises an
alarm at once, whatever ``h``. Its log-likelihood ratio is computed with ``P_ref`` floored at
``1e-12``, which ranks the grid points by how well they explain it.

When a CUSUM crosses, the detector estimates the value of the parameter whose CUSUM crossed: the
posterior mean over that parameter's grid, with a uniform prior and the weights ``exp(W_g)``
(each grid point's likelihood ratio since its CUSUM last restarted: the recent estimate). It
then re-anchors: an estimate becomes the reference and every CUSUM restarts, so a later change
can be detected too. The first crossing is an alarm, and opens a segment: from then on each grid
point's log-likelihood ``L_g`` accumulates over the segment. A later crossing is

* a refinement, silent, when the recent estimate lies within ``min_size`` (in the family's
  change-size metric) of the segment's estimate (weights ``exp(L_g)``, all the segment's
  data): the reference becomes the segment's estimate, a better one than the first guess;
* an alarm otherwise: a new change; a new segment starts from the recent data.

The notification of an alarm flags the parameter; its size is the family's change size
(:meth:`~ns_pz.params.Params.change_sizes`) between the previous reference and the recent
estimate, so the first alarm's size is the estimated distance from θ_0.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ns_pz.family import EnvFamily
from ns_pz.monitor.monitors import Flags, Monitor, Sizes, has_transition
from ns_pz.params import SIMPLEX, Params, ParamSpec

FLOOR = 1e-12
"""Probability a transition impossible under the reference is given in its log-likelihood ratio."""


@dataclass(frozen=True)
class _ParamGrid:
    """The grid of one parameter and the outcome probabilities of each grid point."""

    name: str
    values: tuple[Any, ...]
    probs: np.ndarray
    """``[G, S, A, K]`` outcome probabilities with the parameter at each grid value."""


class TabularCusumMemory:
    """One episode's detector state."""

    __slots__ = ("reference", "reference_probs", "statistics", "segment", "alarms", "trace")

    def __init__(self, reference: Params, reference_probs: np.ndarray, sizes: list[int]) -> None:
        self.reference = reference
        self.reference_probs = reference_probs
        self.statistics = [np.zeros(size) for size in sizes]
        """``W_g`` of each watched parameter's grid."""
        self.segment: list[np.ndarray] | None = None
        """``L_g`` of each grid since the last alarm (``None`` before the first)."""
        self.alarms: list[int] = []
        """Transition indices whose notification raised an alarm."""
        self.trace: list[float] = []
        """The statistic ``max_g W_g`` after each transition (before a restart)."""


class TabularCusumMonitor(Monitor):
    """GLR-CUSUM over a grid of θ on a tabular family's outcome table (see the module doc).

    Args:
        threshold: The alarm threshold ``h`` on ``max_g W_g`` (nats). Larger: fewer false alarms,
            longer delays.
        grid_step: Spacing of the grid over a probability vector's simplex (every vector whose
            entries are multiples of ``grid_step``; must divide 1). ``0.05`` gives 231 points
            for 3 outcomes and 1,771 for 4.
        scalar_points: Number of evenly spaced grid values over a scalar parameter's bounds
            (which must be finite).
        min_size: Smallest change (family's change-size metric) between the recent and the
            segment's estimate that a crossing after the first alarm reports as a new change.
        params: Names of the parameters to watch; default every parameter.

    Raises:
        ValueError: A non-positive or non-finite threshold, a negative ``min_size``, a
            ``grid_step`` that does not divide 1, fewer than 2 ``scalar_points``.
    """

    def __init__(
        self,
        threshold: float = 6.0,
        grid_step: float = 0.05,
        scalar_points: int = 41,
        min_size: float = 0.25,
        params: Sequence[str] | None = None,
    ) -> None:
        if not (isinstance(min_size, (int, float)) and 0.0 <= min_size < math.inf):
            raise ValueError(f"min_size={min_size!r} must be a finite number >= 0")
        if not (isinstance(threshold, (int, float)) and 0.0 < threshold < math.inf):
            raise ValueError(f"threshold={threshold!r} must be a finite number > 0")
        if not isinstance(grid_step, (int, float)) or not 0.0 < grid_step <= 1.0:
            raise ValueError(f"grid_step={grid_step!r} must be in (0, 1] and divide 1")
        if abs(round(1.0 / grid_step) * grid_step - 1.0) > 1e-9:
            raise ValueError(f"grid_step={grid_step!r} must divide 1 (0.1, 0.05, 0.02, ...)")
        if isinstance(scalar_points, bool) or not isinstance(scalar_points, int):
            raise TypeError(f"scalar_points={scalar_points!r} must be an int >= 2")
        if scalar_points < 2:
            raise ValueError(f"scalar_points={scalar_points!r} must be >= 2")
        self.threshold = float(threshold)
        self.grid_step = float(grid_step)
        self.scalar_points = scalar_points
        self.min_size = float(min_size)
        self.watched = None if params is None else tuple(params)
        self._family: EnvFamily | None = None
        self._theta0: Params | None = None
        self._grids: tuple[_ParamGrid, ...] = ()
        self._structure: np.ndarray | None = None

    def bind(self, family: EnvFamily, theta0: Params) -> None:
        """Read the outcome table under θ_0 and under every grid point.

        Raises:
            TypeError: The family has no explicit outcome table (use
                :class:`~ns_pz.monitor.PredictionErrorMonitor` on continuous families).
            UnknownParam: A watched name is not a parameter.
            ValueError: A watched scalar parameter has an infinite bound.
        """
        if self._family is family and self._theta0 == theta0:
            return
        names = family.params_cls.names() if self.watched is None else self.watched
        family.params_cls.check_names(names)
        reference = _outcome_table(family, theta0)
        grids = []
        for name in names:
            spec = family.params_cls.spec(name)
            values = _grid_values(spec, self.grid_step, self.scalar_points)
            probs = np.stack(
                [_outcome_table(family, theta0.replace(**{name: v})).probs for v in values]
            )
            grids.append(_ParamGrid(name, values, probs))
        self._family = family
        self._theta0 = theta0
        self._grids = tuple(grids)
        self._structure = reference.next_states

    def initial_memory(self) -> TabularCusumMemory:
        """θ_0 as the reference, every CUSUM at 0."""
        if self._family is None or self._theta0 is None:
            raise RuntimeError(
                "TabularCusumMonitor is not bound to an environment; pass it as monitor= to "
                "an ns_pz environment (which calls bind(family, theta0))"
            )
        return TabularCusumMemory(
            self._theta0,
            _outcome_table(self._family, self._theta0).probs,
            [len(g.values) for g in self._grids],
        )

    def statistic(self, memory: TabularCusumMemory) -> float:
        """The detection statistic ``max_g W_g`` now (0 right after a reset or an alarm)."""
        return max(float(s.max()) for s in memory.statistics)

    def believed_theta(self, memory: TabularCusumMemory) -> Params:
        """θ_0 updated by every change detected so far."""
        return memory.reference

    def notify(
        self,
        observation: dict[str, Any] | None,
        truth: Sequence[float] | None,
        memory: TabularCusumMemory,
        rng: np.random.Generator,
    ) -> tuple[Flags, Sizes]:
        """Update every CUSUM with the last transition; flag a parameter when its crosses ``h``."""
        count = len(memory.reference.names())
        quiet: tuple[tuple[int, ...], tuple[float, ...]] = ((0,) * count, (0.0,) * count)
        if not has_transition(observation):
            return quiet
        assert observation is not None and self._structure is not None  # has_transition
        state = int(observation["last_state"])
        action = int(observation["last_action"])
        reached = self._structure[state, action] == int(observation["state"])
        p_ref = float(memory.reference_probs[state, action][reached].sum())
        impossible = p_ref <= 0.0
        log_ref = math.log(max(p_ref, FLOOR))
        best, best_index = -1.0, -1
        for index, grid in enumerate(self._grids):
            p_grid = grid.probs[:, state, action, :][:, reached].sum(axis=1)
            with np.errstate(divide="ignore"):
                ratio = np.log(p_grid) - log_ref
            stat = np.maximum(memory.statistics[index] + ratio, 0.0)
            memory.statistics[index] = stat
            if memory.segment is not None:
                memory.segment[index] = memory.segment[index] + ratio
            top = float(stat.max())
            if top > best:
                best, best_index = top, index
        memory.trace.append(best)
        if not (impossible or best > self.threshold):
            return quiet
        return self._crossing(memory, best_index, int(observation["relative_time"][0]) - 1)

    def _crossing(
        self, memory: TabularCusumMemory, index: int, transition: int
    ) -> tuple[Flags, Sizes]:
        """Refine silently or alarm (see the module doc); re-anchor; build the notification."""
        assert self._family is not None
        old = memory.reference
        name = self._grids[index].name
        recent = self._estimate(old, index, memory.statistics[index])
        alarm = True
        if memory.segment is not None:
            whole = self._estimate(old, index, memory.segment[index])
            spec = old.spec(name)
            if spec.distance(getattr(recent, name), getattr(whole, name)) < self.min_size:
                alarm = False
                new = whole
        if alarm:
            new = recent
            memory.segment = [s.copy() for s in memory.statistics]
            memory.alarms.append(transition)
        memory.reference = new
        memory.reference_probs = _outcome_table(self._family, new).probs
        memory.statistics = [np.zeros_like(s) for s in memory.statistics]
        count = len(old.names())
        if not alarm:
            return (0,) * count, (0.0,) * count
        flags = tuple(int(n == name) for n in old.names())
        sizes = new.change_sizes(old)
        return flags, tuple(float(s) if f else 0.0 for s, f in zip(sizes, flags, strict=True))

    def _estimate(self, reference: Params, index: int, log_weights: np.ndarray) -> Params:
        """``reference`` with grid ``index``'s parameter at the posterior mean of its grid."""
        grid = self._grids[index]
        top = float(log_weights.max())
        if not np.isfinite(top):  # every grid point excluded: no evidence on where θ went
            top, log_weights = 0.0, np.zeros_like(log_weights)
        weights = np.exp(log_weights - top)
        weights /= weights.sum()
        spec = reference.spec(grid.name)
        values = np.asarray(grid.values, np.float64)
        if spec.kind == SIMPLEX:
            mean = values.T @ weights
            estimate: Any = tuple(float(p) for p in mean / mean.sum())
        else:
            estimate = float(values @ weights)
        owner = type(reference).__name__
        return reference.replace(**{grid.name: spec.project(owner, estimate)})

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


def _compositions(total: int, parts: int) -> list[tuple[int, ...]]:
    """Every tuple of ``parts`` non-negative integers summing to ``total``."""
    result = []
    for bars in itertools.combinations(range(total + parts - 1), parts - 1):
        edges = (-1, *bars, total + parts - 1)
        result.append(tuple(edges[i + 1] - edges[i] - 1 for i in range(parts)))
    return result
