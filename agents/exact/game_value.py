"""The value and equilibrium of the NS-MDP game at ``detailed``, by Shapley's backward induction.

Each step nature picks θ_t on its grid and the agent picks ``a_t`` simultaneously: the agent sees
``s_t``, θ_{t-1} and (through the change sizes it is told) nature's budget left, not θ_t (it hears
of θ_t only after the transition). Nature sees ``t``, θ_{t-1}, its budget and ``s_t``. The game is
zero-sum (nature's payoff is minus the agent's return), finite and of perfect recall with observed
stages, so its value is computed stage by stage::

    V_t[s, i, b] = val( G_t[i, b, ·, s, ·] )        V_H = 0

where ``val`` is the value of the matrix game with payoffs ``G_t[i, b, j, s, a]`` over the
agent's actions ``a`` and nature's allowed moves ``j``
(:mod:`ns_pz.agents.exact.game_stages`, :mod:`ns_pz.agents.exact.matrix_game`). The per-stage
optimal strategies form a subgame-perfect equilibrium: neither side gains by deviating, which
the tests check by best responses.

**How this relates to the robust solution** (:mod:`ns_pz.agents.exact.robust`). The rectangular
robust induction lets nature pick its worst θ separately for every (state, action, step), after
seeing the agent's action, out of the whole interval reachable by step ``t`` (ignoring
θ_{t-1} and the budget already spent). That nature is strictly stronger than the game's (one θ
per step, chosen before the action, constrained by its own path), so the robust value is a lower
bound on the game value and the robust policy's value against the game's best-responding nature
(:func:`~ns_pz.agents.exact.exploitability.exploitability`) lies between the two.

At ``none`` / ``basic`` the agent does not see θ_{t-1}: its information sets join stages with
different ``i`` and ``b``, the stage decomposition fails, and this value is an upper bound
(more information cannot hurt the maximiser); see :mod:`ns_pz.agents.exact.openspiel_game`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from ns_pz.agents.exact.game_stages import (
    check_game,
    family_of,
    grid_tables,
    stage_induction,
    start_solve,
    start_value,
)
from ns_pz.agents.exact.matrix_game import solve_matrix_games
from ns_pz.agents.exact.nature_grid import NatureGrid
from ns_pz.agents.exact.solve_size import DEFAULT_MAX_BYTES


@dataclass(frozen=True)
class GameSolution:
    """Value and equilibrium strategies of the game on a grid.

    Attributes:
        values: ``[H + 1, S, m, levels]`` stage values; ``values[H]`` is zero.
        agent: ``[H, S, m, levels, A]`` the agent's equilibrium strategy (float64
            probabilities, as the LPs returned them: rounding them to float32 made the
            equilibrium's exploitability ~1e-8 instead of 0).
        nature: ``[H, S, m, levels, m]`` nature's equilibrium strategy (float64).
        value: The game's value at reset (start states, θ_{-1}, full budget).
        linear_programs: Stages that needed an LP (the others had a pure saddle point).
        stages: All stages solved.
        grid: The grid it was solved on.
        gamma: The discount it was solved with.
        family: ``repr`` of the family it was solved for.
    """

    values: np.ndarray
    agent: np.ndarray
    nature: np.ndarray
    value: float
    linear_programs: int
    stages: int
    grid: NatureGrid
    gamma: float
    family: str

    def check_reusable(self, env: Any, grid: NatureGrid, horizon: int, gamma: float) -> None:
        """Refuse to stand in for the game of another family, grid, horizon or discount.

        Raises:
            ValueError: One of them differs from what this solution was solved for (named).
        """
        family = repr(family_of(env))
        differences = [
            f"{name} {mine} here, {theirs} in the game"
            for name, mine, theirs in (
                ("family", family, self.family),
                ("horizon", horizon, self.agent.shape[0]),
                ("gamma", gamma, self.gamma),
            )
            if mine != theirs
        ]
        if not _same_grid(grid, self.grid):
            differences.append("another grid (points, moves, costs or budget)")
        if differences:
            raise ValueError(
                "game= was solved for another game: " + "; ".join(differences) + " (solve it "
                "again with solve_game for this one, or pass game=None)"
            )


def _same_grid(one: NatureGrid, other: NatureGrid) -> bool:
    """Whether two grids give nature the same action set (points, moves, costs and budget)."""
    return one is other or (
        one.thetas == other.thetas
        and one.start == other.start
        and np.array_equal(one.allowed, other.allowed)
        and np.array_equal(one.costs, other.costs)
        and one.budget_levels == other.budget_levels
        and one.budget_unit == other.budget_unit
    )


def solve_game(
    env: Any,
    grid: NatureGrid,
    horizon: int,
    *,
    gamma: float = 1.0,
    max_bytes: float = DEFAULT_MAX_BYTES,
    progress: bool = False,
) -> GameSolution:
    """Value and equilibrium of the game at ``detailed`` (module docstring).

    Args:
        env: A tabular family, or an env / game / process built on one.
        grid: Nature's action set.
        horizon: ``H``, the number of transitions.
        gamma: Discount in ``[0, 1]``.
        max_bytes: Refuse the solve when its estimated peak memory passes this
            (:mod:`ns_pz.agents.exact.solve_size`; default 4 GiB).
        progress: Print the size estimate, then the steps done and an ETA, on stderr.

    Raises:
        TypeError / ValueError: The env is not tabular, the grid is of another θ class,
            ``horizon``/``gamma`` are invalid, or the solve is estimated beyond ``max_bytes``.
    """
    horizon, gamma = check_game(horizon, gamma)
    tables = grid_tables(env, grid)
    num_states, num_actions, _ = tables[0].probs.shape
    m, levels = grid.size, grid.budget_levels
    line = start_solve(
        "solve_game",
        tables,
        grid,
        horizon,
        held=num_actions + m,
        copies=6,
        max_bytes=max_bytes,
        progress=progress,
    )
    # the strategies are the big arrays: nature's holds H·S·m·levels·m float64 numbers
    agent = np.empty((horizon, num_states, m, levels, num_actions))
    nature = np.empty((horizon, num_states, m, levels, m))
    linear_programs = 0

    def play_stage(t: int, payoffs: np.ndarray, allowed: np.ndarray) -> np.ndarray:
        nonlocal linear_programs
        games = payoffs.transpose(3, 0, 1, 4, 2).reshape(-1, num_actions, m)  # [(s,i,b), a, j]
        moves = np.broadcast_to(allowed, (num_states, m, levels, m)).reshape(-1, m)
        solved = solve_matrix_games(games, moves)
        agent[t] = solved.rows.reshape(num_states, m, levels, num_actions)
        nature[t] = solved.columns.reshape(num_states, m, levels, m)
        linear_programs += solved.linear_programs
        return solved.values.reshape(num_states, m, levels)

    values = stage_induction(tables, grid, horizon, gamma, play_stage, line)
    return GameSolution(
        values=values,
        agent=agent,
        nature=nature,
        value=start_value(family_of(env), values, grid),
        linear_programs=linear_programs,
        stages=horizon * num_states * m * levels,
        grid=grid,
        gamma=gamma,
        family=repr(family_of(env)),
    )
