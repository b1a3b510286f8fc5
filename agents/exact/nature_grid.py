"""Nature's action set as a finite grid of θ, with its Lipschitz bound and budget.

The exact game solvers need nature's choices to be finite. A :class:`NatureGrid` lists the θ
nature may put in force (``thetas``), the θ in force before the episode (``start``: θ_{-1}, the
environment's initial θ), which moves are allowed in one step (``allowed[i, j]``: θ^i → θ^j,
the Lipschitz bound as adjacency) and what each move costs (``costs[i, j]`` in budget units, the
budget as a resource with ``budget_levels`` values). Staying put is always allowed and free.

Sizes are measured as ns_pz's constraints measure them (:meth:`ns_pz.params.Params.change_sizes`:
``|Δ|`` for a scalar, total variation for a probability vector): a move is allowed when every
parameter's change is within its Lipschitz bound, and costs the sum of the changes. The budget
is exact on the grid when every move's cost is a whole number of ``budget_unit`` — true on
:func:`slip_line_grid` with the unit its step — and the builders refuse a grid where it is not.

Nature moves at every step ``t = 0 .. H-1`` (its move at ``t`` applies to transition ``t``), as
in :class:`~ns_pz.process.NSProcess`. A grid nature is a nature of the game: every move it makes
is one :func:`~ns_pz.nature.constraints.admit` grants unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from ns_pz.agents.exact.robust import equal_split
from ns_pz.agents.exact.solve_size import DEFAULT_MAX_POINTS, check_max_points

from ns_pz.nature.constraints import NatureConstraints
from ns_pz.params import SIMPLEX, Params

TOLERANCE = 1e-9
"""Slack on Lipschitz bounds and budget units (grid points are sums of float steps)."""


@dataclass(frozen=True, eq=False)
class NatureGrid:
    """A finite action set for nature (module docstring).

    Attributes:
        thetas: The grid points, distinct, all of one Params class.
        start: Index of θ_{-1}, the θ in force before nature's first move.
        allowed: ``[m, m]`` bool; ``allowed[i, j]``: nature may move from θ^i to θ^j in one step.
        costs: ``[m, m]`` int64; budget units a move uses. Every point needs an allowed move
            of cost 0; all 0 when there is no budget.
        budget_levels: Number of values the budget left can take (``0 .. budget_levels - 1``
            units): 1 when there is no budget, and also for a budget of less than one unit.
        budget_unit: Size of one budget unit; ``inf`` means there is no budget (moves are free).
    """

    thetas: tuple[Params, ...]
    start: int
    allowed: np.ndarray
    costs: np.ndarray
    budget_levels: int
    budget_unit: float

    def __post_init__(self) -> None:
        m = len(self.thetas)
        if m == 0:
            raise ValueError("thetas=() is empty; nature needs at least one θ")
        if len(set(self.thetas)) != m:
            raise ValueError("thetas holds a θ twice; grid points must be distinct")
        if isinstance(self.start, bool) or not isinstance(self.start, (int, np.integer)):
            raise TypeError(f"start={self.start!r} must be an int grid index in 0..{m - 1}")
        if not 0 <= self.start < m:
            raise ValueError(f"start={self.start!r} is outside 0..{m - 1}")
        object.__setattr__(self, "start", int(self.start))
        allowed = _move_table("allowed", self.allowed, m)
        costs = _move_table("costs", self.costs, m)
        _check_budget(self.budget_levels, self.budget_unit, costs)
        object.__setattr__(self, "budget_levels", int(self.budget_levels))
        object.__setattr__(self, "budget_unit", float(self.budget_unit))
        stuck = ~np.any(allowed & (costs == 0), axis=1)
        if np.any(stuck):
            raise ValueError(
                f"θ^{int(np.argmax(stuck))} has no move costing nothing; nature needs a move "
                "even with no budget left (staying put, in the game)"
            )
        for name, array in (("allowed", allowed), ("costs", costs)):
            array.flags.writeable = False
            object.__setattr__(self, name, array)

    @property
    def size(self) -> int:
        """Number of grid points ``m``."""
        return len(self.thetas)

    @property
    def has_budget(self) -> bool:
        """Whether moves spend a budget (``budget_unit`` finite); ``False``: they are free."""
        return math.isfinite(self.budget_unit)

    @property
    def full_budget(self) -> int:
        """Budget level at the start of an episode (units)."""
        return self.budget_levels - 1

    def index(self, theta: Params) -> int:
        """Position of ``theta`` on the grid.

        Raises:
            ValueError: ``theta`` is not a grid point.
        """
        try:
            return self.thetas.index(theta)
        except ValueError:
            raise ValueError(f"theta={theta!r} is not a point of the grid") from None

    def next_budget(self) -> np.ndarray:
        """``[m, levels, m]`` int64: budget left after moving i → j with ``b`` left; -1 if barred.

        A move is barred when it is not allowed or costs more than the budget left.
        """
        levels = np.arange(self.budget_levels)[None, :, None]
        after = levels - self.costs[:, None, :]
        barred = ~self.allowed[:, None, :] | (after < 0)
        if not self.has_budget:  # moves are free
            after = np.zeros_like(after)
            barred = ~self.allowed[:, None, :] | np.zeros_like(barred)
        return np.where(barred, -1, after)

    def schedule_of(self, indices: Sequence[int]) -> tuple[Params, ...]:
        """The θ schedule θ_0 .. θ_{H-1} of a path of grid indices."""
        return tuple(self.thetas[i] for i in indices)

    def feasible(self, indices: Sequence[int]) -> bool:
        """Whether nature may play this path of grid indices from :attr:`start`."""
        here, left = self.start, self.full_budget
        for j in indices:
            if not self.allowed[here, j]:
                return False
            if self.has_budget:
                left -= int(self.costs[here, j])
                if left < 0:
                    return False
            here = j
        return True

    def _budget_text(self) -> str:
        if not self.has_budget:
            return "none"
        return f"{self.full_budget} units of {self.budget_unit!r}"

    def __repr__(self) -> str:
        return (
            f"NatureGrid(size={self.size}, start={self.thetas[self.start]!r}, "
            f"moves={int(self.allowed.sum())}, budget={self._budget_text()})"
        )


def nature_grid(
    thetas: Sequence[Params],
    start: Params,
    constraints: NatureConstraints | None = None,
    *,
    budget_unit: float | None = None,
    max_points: int = DEFAULT_MAX_POINTS,
) -> NatureGrid:
    """A grid from a list of θ, with ns_pz's constraints as adjacency and resource.

    Args:
        thetas: The θ nature may choose (``start`` is added when missing).
        start: θ_{-1}, the environment's initial θ.
        constraints: Lipschitz bound and budget (``None``: neither).
        budget_unit: Size of one budget unit. Default: the smallest positive move cost. Every
            move's cost must be a whole multiple of it; the budget is rounded down to whole
            units (no sequence of moves can spend the remainder, so the grid stays exact).
        max_points: Refuse a grid of more points, before measuring its ``m²`` moves (default
            1000: about 8 s of measuring; any solve on such a grid needs ``m²`` payoffs per
            state, action and budget level at every step).

    Raises:
        TypeError: A θ is not a Params of ``start``'s class.
        ValueError: A cost is not a whole number of units, or the budget is per parameter or
            normalised.
    """
    points = list(dict.fromkeys(thetas))
    check_max_points(len(points) + (start not in points), max_points)
    for theta in points:
        if type(theta) is not type(start):
            raise TypeError(f"thetas holds {theta!r}; every θ must be a {type(start).__name__}")
    if start not in points:
        points.insert(0, start)
    constraints = constraints or NatureConstraints()
    names = start.names()
    sizes = np.array([[b.change_sizes(a) for b in points] for a in points]).reshape(
        len(points), len(points), len(names)
    )
    limits = np.array([_inf_if_none(constraints.lipschitz_of(n)) for n in names])
    allowed = np.all(sizes <= limits + TOLERANCE, axis=2)
    totals = sizes.sum(axis=2)
    if constraints.has_budget and constraints.total_budget is None:
        raise ValueError(
            f"constraints={constraints!r}: the grid takes one total budget; per-parameter and "
            "normalised budgets are not supported here"
        )
    budget = constraints.total_budget
    if budget is None:
        return NatureGrid(
            tuple(points),
            points.index(start),
            allowed,
            np.zeros(allowed.shape, np.int64),
            1,
            math.inf,
        )
    if budget_unit is None:
        positive = totals[allowed & (totals > TOLERANCE)]
        budget_unit = float(positive.min()) if positive.size else max(float(budget), 1.0)
    if not (
        isinstance(budget_unit, (int, float)) and math.isfinite(budget_unit) and budget_unit > 0
    ):
        raise ValueError(f"budget_unit={budget_unit!r} must be a finite number > 0")
    units = totals / budget_unit
    costs = np.rint(units).astype(np.int64)
    bad = allowed & (np.abs(units - costs) > 1e-6)
    if np.any(bad):
        i, j = np.argwhere(bad)[0]
        raise ValueError(
            f"the move {points[i]!r} -> {points[j]!r} costs {totals[i, j]!r}, not a whole "
            f"number of budget_unit={budget_unit!r}; pass a budget_unit dividing every move"
        )
    levels = math.floor(budget / budget_unit + 1e-6)
    return NatureGrid(tuple(points), points.index(start), allowed, costs, levels + 1, budget_unit)


def slip_line_grid(
    theta0: Params,
    step: float,
    constraints: NatureConstraints | None = None,
    *,
    field: str = "slip",
    low: float = 0.0,
    high: float = 1.0,
    max_points: int = DEFAULT_MAX_POINTS,
) -> NatureGrid:
    """Points on the slip line ``[p, (1-p)/(n-1), ...]`` every ``step`` from ``p_0``.

    The intended-move probability takes the values ``p_0 + k · step`` inside ``[low, high]``;
    the rest is split equally, as every shipped distribution rule does (see
    :mod:`ns_pz.agents.exact.robust`). On that line a move's total variation is ``|Δp|``, so
    with ``step`` as the budget unit the budget is exact when it is a multiple of ``step``.

    Args:
        theta0: θ_{-1}; its ``field`` must be on the line (tail split equally).
        step: Spacing of the grid, ``> 0``.
        constraints: Lipschitz bound and budget (``None``: neither).
        field: The probability-vector parameter nature moves.
        low: Smallest intended-move probability allowed.
        high: Largest.
        max_points: Refuse a grid of more points before building it (as :func:`nature_grid`).

    Raises:
        TypeError: ``field`` is not a probability vector of ``theta0``.
        ValueError: ``step`` is not positive, ``low``/``high`` are not ordered probabilities,
            ``theta0`` is off the line or outside ``[low, high]``, or ``step`` would put more
            than ``max_points`` points on the line (the message names the count).
    """
    spec = theta0.spec(field)
    if spec.kind != SIMPLEX:
        raise TypeError(f"field={field!r} is not a probability vector of {type(theta0).__name__}")
    if isinstance(step, bool) or not isinstance(step, (int, float)) or not step > 0:
        raise ValueError(f"step={step!r} must be a number > 0")
    if not 0.0 <= low <= high <= 1.0:
        raise ValueError(f"low={low!r}, high={high!r} must satisfy 0 <= low <= high <= 1")
    vector = getattr(theta0, field)
    p0 = vector[0]
    if not np.allclose(vector, equal_split(p0, len(vector)), atol=1e-12):
        raise ValueError(f"theta0.{field}={vector!r} is off the slip line (tail not split equally)")
    if not low - TOLERANCE <= p0 <= high + TOLERANCE:
        raise ValueError(f"p_0={p0!r} lies outside [low, high] = [{low!r}, {high!r}]")
    down = math.floor((p0 - low) / step + 1e-9)
    up = math.floor((high - p0) / step + 1e-9)
    check_max_points(down + up + 1, max_points)
    ps = [min(max(p0 + k * step, 0.0), 1.0) for k in range(-down, up + 1)]
    thetas = [
        theta0 if k == 0 else theta0.replace(**{field: equal_split(p, len(vector))})
        for k, p in zip(range(-down, up + 1), ps, strict=True)
    ]
    unit = step if constraints is not None and constraints.budget is not None else None
    return nature_grid(thetas, theta0, constraints, budget_unit=unit, max_points=max_points)


def _inf_if_none(value: float | None) -> float:
    return math.inf if value is None else value


def _move_table(name: str, table: object, m: int) -> np.ndarray:
    """``allowed`` as a bool copy or ``costs`` as an int64 copy, refusing any value a cast changes.

    Raises:
        ValueError: Wrong shape, ``allowed`` not 0/1, or a cost that is negative, NaN, infinite
            or not a whole number (casting would silently turn 0.5 into 0 and NaN into a huge
            negative integer).
    """
    array = np.asarray(table)
    if array.shape != (m, m):
        raise ValueError(f"{name} has shape {array.shape}; need ({m}, {m})")
    if array.dtype == object or not (
        np.issubdtype(array.dtype, np.number) or array.dtype == np.bool_
    ):
        raise TypeError(f"{name} has dtype {array.dtype}; need numbers")
    if name == "allowed":
        if not np.all((array == 0) | (array == 1)):
            bad = tuple(int(k) for k in np.argwhere((array != 0) & (array != 1))[0])
            raise ValueError(
                f"allowed{list(bad)}={array[bad].item()!r}; allowed holds only 0/1 or bools"
            )
        return np.array(array, dtype=np.bool_)
    whole = np.isfinite(array) & (array >= 0) & (array == np.floor(array))
    if not np.all(whole):
        bad = tuple(int(k) for k in np.argwhere(~whole)[0])
        raise ValueError(
            f"costs{list(bad)}={array[bad].item()!r}; costs are whole numbers of budget units >= 0"
        )
    if np.any(array > np.iinfo(np.int64).max):
        raise ValueError("costs hold a value beyond int64; use a larger budget_unit")
    return np.array(array, dtype=np.int64)


def _check_budget(levels: object, unit: object, costs: np.ndarray) -> None:
    """Refuse a budget description the grid cannot mean (see :class:`NatureGrid`).

    Raises:
        TypeError: ``levels`` is not an int or ``unit`` not a number.
        ValueError: ``levels < 1``, ``unit`` NaN or not > 0, or no budget (``unit = inf``)
            with more than one level or with a move that costs something.
    """
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)):
        raise TypeError(f"budget_levels={levels!r} must be an int >= 1")
    if levels < 1:
        raise ValueError(f"budget_levels={levels!r} must be >= 1")
    if isinstance(unit, bool) or not isinstance(unit, (int, float, np.floating, np.integer)):
        raise TypeError(f"budget_unit={unit!r} must be a number > 0 (inf: no budget)")
    if not unit > 0:  # NaN fails too
        raise ValueError(f"budget_unit={unit!r} must be > 0 (inf: no budget)")
    if math.isinf(unit) and (levels != 1 or np.any(costs != 0)):
        raise ValueError(
            f"budget_unit=inf means no budget, so budget_levels must be 1 and costs all 0 (got "
            f"budget_levels={levels!r}, largest cost {int(costs.max())}); give a finite "
            "budget_unit for a budget"
        )
