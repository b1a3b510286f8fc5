"""Strategies on the grid: float64 equilibria, and probability rows exact or refused."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents.exact import (
    blind_value_bounds,
    equal_split,
    exploitability,
    nature_best_response,
    nature_grid,
    play_values,
    solve_game,
    stale_policy,
)
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams


def tiny():
    """A 2x2 lake, nature free between p = 0.2 and 0.9 (from 0.9), three steps."""
    family = FrozenLakeFamily(desc=("SF", "HG"))
    points = [FrozenLakeParams(slip=equal_split(p, 3)) for p in (0.2, 0.9)]
    return family, nature_grid(points, points[1]), 3


def test_the_equilibrium_is_kept_in_float64_and_is_exactly_unexploitable():
    """In float32 it was exploitable by -1.7e-8 and put the blind bounds 1.7e-8 out of order."""
    family, grid, horizon = tiny()
    game = solve_game(family, grid, horizon)
    assert game.agent.dtype == game.nature.dtype == np.float64
    assert exploitability(family, game.agent, grid, horizon, game=game).exploitability == (
        pytest.approx(0.0, abs=1e-14)
    )
    stale = stale_policy(family, grid.thetas[grid.start], horizon)
    bounds = blind_value_bounds(family, grid, horizon, {"stale": stale}, game=game)
    assert bounds.lower <= bounds.upper <= bounds.detailed
    low, high = bounds.notification_value
    assert 0.0 <= low <= high


def uniform_policy(grid, horizon, num_states=4, num_actions=4, dtype=np.float64):
    """``[H, S, m, A]`` uniform probabilities."""
    return np.full((horizon, num_states, grid.size, num_actions), 1.0 / num_actions, dtype)


@pytest.mark.parametrize("excess", [1e-6, 1e-9])
def test_probability_rows_off_by_more_than_rounding_are_refused(excess):
    """Rows off by up to 1e-6 were taken as they were and inflated the values."""
    family, grid, horizon = tiny()
    policy = uniform_policy(grid, horizon)
    policy[1, 0, 1, 2] += excess
    with pytest.raises(
        ValueError, match=r"policy rows must be probabilities over actions.*\[1, 0, 1\]"
    ):
        nature_best_response(family, policy, grid, horizon)
    nature = np.full((horizon, grid.size, 1, grid.size), 0.5)
    nature[0, 0, 0] = (0.5, 0.5 + excess)
    with pytest.raises(ValueError, match="nature rows must be probabilities over the grid"):
        play_values(family, uniform_policy(grid, horizon), nature, grid, horizon)
    policy = uniform_policy(grid, horizon)
    policy[0, 0, 0] = (-excess, 0.5, 0.5, excess)
    with pytest.raises(ValueError, match="smallest entry is -"):
        nature_best_response(family, policy, grid, horizon)


def test_rows_within_rounding_are_renormalised_so_values_are_never_inflated():
    """A float32 row is off by ~1e-7: it counts as the distribution it rounds."""
    family, grid, horizon = tiny()
    rng = np.random.default_rng(0)
    weights = rng.random((horizon, 4, grid.size, 4))
    exact = weights / weights.sum(axis=-1, keepdims=True)
    rounded = exact.astype(np.float32)
    assert np.abs(rounded.astype(np.float64).sum(axis=-1) - 1.0).max() > 1e-9
    renormalised = rounded.astype(np.float64)
    renormalised /= renormalised.sum(axis=-1, keepdims=True)
    got = nature_best_response(family, rounded, grid, horizon).value
    assert got == nature_best_response(family, renormalised, grid, horizon).value
    assert got == pytest.approx(nature_best_response(family, exact, grid, horizon).value, abs=1e-6)
    with pytest.raises(ValueError, match="NaN or infinite"):
        nature_best_response(family, np.full_like(exact, np.nan), grid, horizon)


class InflatedFamily:
    """FrozenLake 2x2 whose outcome rows sum to 1 + ``excess``: a family's own bug."""

    params_cls = FrozenLakeParams
    start_states = (0,)

    def __init__(self, excess: float) -> None:
        self.lake, self.excess = FrozenLakeFamily(desc=("SF", "HG")), excess

    def outcomes(self, theta):
        """The lake's table with the first outcome of (0, 0) raised."""
        table = self.lake.outcomes(theta)
        probs = table.probs.copy()
        probs[0, 0, 0] += self.excess
        return type(table)(probs, table.next_states, table.rewards, table.terminals)


def test_an_outcome_table_off_the_simplex_is_refused_not_solved():
    """A family whose rows sum to 1 + 1e-6 made every value larger, silently."""
    _, grid, horizon = tiny()
    with pytest.raises(ValueError, match=r"probs\[0, 0\] = .* is not a distribution"):
        solve_game(InflatedFamily(1e-6), grid, horizon)
    solve_game(InflatedFamily(1e-12), grid, horizon)  # rounding passes
