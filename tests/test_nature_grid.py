"""Nature's grid: a budget below one unit is a budget, and a hand-built grid casts nothing."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from ns_pz.agents.exact import (
    NatureGrid,
    equal_split,
    exploitability,
    nature_best_response,
    nature_grid,
    oracle_solution,
    slip_line_grid,
    solve_game,
    stale_policy,
    start_value,
)
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

from ns_pz.nature import NatureConstraints


def theta(p: float) -> FrozenLakeParams:
    """FrozenLake θ with intended probability p, the tail split equally."""
    return FrozenLakeParams(slip=equal_split(p, 3))


def frozen_value(family: FrozenLakeFamily, theta0: FrozenLakeParams, horizon: int) -> float:
    """The optimal value when θ never moves."""
    return start_value(family, oracle_solution(family, [theta0] * horizon).values)


@pytest.mark.parametrize("budget", [0.0, 0.05, 0.0999])
def test_a_budget_below_one_unit_freezes_nature(budget):
    """The issue's FrozenLake case: budget 0 and 0.05 gave the unconstrained 0.0864, not 0.9015."""
    family, theta0, horizon = FrozenLakeFamily(), theta(0.9), 20
    grid = slip_line_grid(theta0, 0.1, NatureConstraints(budget=budget))
    assert grid.has_budget and grid.budget_levels == 1
    frozen = frozen_value(family, theta0, horizon)
    assert frozen == pytest.approx(0.9015133551634167, abs=1e-12)
    assert solve_game(family, grid, horizon).value == pytest.approx(frozen, abs=1e-12)
    stale = stale_policy(family, theta0, horizon)
    response = nature_best_response(family, stale, grid, horizon)
    assert response.value == pytest.approx(frozen, abs=1e-12)
    stays = np.arange(grid.size)[None, None, :, None]
    assert np.all(response.choice == stays)  # from every θ^i nature can only stay at i
    assert exploitability(family, stale, grid, horizon).exploitability == pytest.approx(
        0.0, abs=1e-12
    )
    assert not grid.feasible([grid.start + 1])


def test_no_budget_and_a_zero_budget_are_different_grids():
    """``has_budget`` is what tells them apart, not the number of levels."""
    free = slip_line_grid(theta(0.9), 0.1)
    broke = slip_line_grid(theta(0.9), 0.1, NatureConstraints(budget=0.0))
    assert free.budget_levels == broke.budget_levels == 1
    assert not free.has_budget and math.isinf(free.budget_unit)
    assert broke.has_budget and broke.budget_unit == 0.1
    assert np.all(free.next_budget() == 0)  # every move allowed, free
    barred = broke.next_budget() < 0
    assert not np.any(np.diag(barred[:, 0, :])) and np.sum(~barred) == free.size
    assert "budget=none" in repr(free) and "budget=0 units of 0.1" in repr(broke)


def test_the_game_value_falls_with_the_budget_to_the_unconstrained_value():
    """Monotone in the budget: frozen at 0, unconstrained once the budget outlasts the horizon."""
    family, theta0, horizon = FrozenLakeFamily(desc=("SF", "FG")), theta(0.8), 4
    values = [
        solve_game(
            family,
            slip_line_grid(theta0, 0.2, NatureConstraints(lipschitz=0.2, budget=budget)),
            horizon,
        ).value
        for budget in (0.0, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8)
    ]
    assert values[0] == pytest.approx(frozen_value(family, theta0, horizon), abs=1e-12)
    assert values[0] == values[1]  # 0.1 is half a unit: nothing to spend
    assert all(later <= earlier + 1e-12 for earlier, later in itertools.pairwise(values))
    assert values[-1] < values[0]
    unconstrained = solve_game(
        family, slip_line_grid(theta0, 0.2, NatureConstraints(lipschitz=0.2)), horizon
    ).value
    assert values[-1] == pytest.approx(unconstrained, abs=1e-12)  # 4 steps of 0.2 at most


def grid_of(costs: object, *, allowed: object = None, levels: int = 3, unit: float = 0.1):
    """A hand-built two-point grid."""
    allowed = np.ones((2, 2), bool) if allowed is None else allowed
    return NatureGrid((theta(0.5), theta(0.6)), 0, allowed, costs, levels, unit)


@pytest.mark.parametrize(
    ("costs", "shown"),
    [
        ([[0, 0.5], [1, 0]], "costs[0, 1]=0.5"),
        ([[0, np.nan], [1, 0]], "costs[0, 1]=nan"),
        ([[0, np.inf], [1, 0]], "costs[0, 1]=inf"),
        ([[0, -1], [1, 0]], "costs[0, 1]=-1"),
    ],
)
def test_a_hand_built_grid_refuses_costs_a_cast_would_change(costs, shown):
    """0.5 was cast to 0 and NaN to a huge negative integer after the check."""
    with pytest.raises(ValueError, match=re_escape(shown) + ".*whole numbers"):
        grid_of(np.array(costs, dtype=float))


def test_a_hand_built_grid_keeps_whole_float_costs_and_refuses_other_bad_fields():
    """Whole floats are exact; allowed must be 0/1; the budget fields must mean something."""
    grid = grid_of(np.array([[0.0, 1.0], [2.0, 0.0]]))
    assert grid.costs.dtype == np.int64 and grid.costs[1, 0] == 2
    with pytest.raises(ValueError, match=re_escape("allowed[0, 1]=0.5")):
        grid_of(np.zeros((2, 2)), allowed=np.array([[1.0, 0.5], [1.0, 1.0]]))
    with pytest.raises(ValueError, match="budget_unit=nan must be > 0"):
        grid_of(np.zeros((2, 2)), unit=math.nan)
    with pytest.raises(ValueError, match="budget_unit=inf means no budget"):
        grid_of(np.array([[0, 1], [1, 0]]), levels=1, unit=math.inf)
    with pytest.raises(ValueError, match="budget_unit=inf means no budget"):
        grid_of(np.zeros((2, 2)), levels=3, unit=math.inf)
    with pytest.raises(TypeError, match="start=0.5 must be an int"):
        NatureGrid((theta(0.5),), 0.5, np.ones((1, 1), bool), np.zeros((1, 1)), 1, 1.0)


def test_a_budget_unit_larger_than_the_budget_is_a_budget_of_zero_units():
    """Every move costs at least one unit, so none is affordable."""
    grid = nature_grid(
        [theta(0.5), theta(0.7)], theta(0.5), NatureConstraints(budget=0.1), budget_unit=0.2
    )
    assert grid.has_budget and grid.full_budget == 0
    assert grid.next_budget()[0, 0, 1] == -1 and grid.next_budget()[0, 0, 0] == 0


def re_escape(text: str) -> str:
    """``text`` as a literal regular expression."""
    import re

    return re.escape(text)
