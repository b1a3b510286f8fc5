"""Values and optimal mixed strategies of many small zero-sum matrix games at once.

Game ``g`` has payoff ``M_g[a, j]`` to the row player (the agent, maximising) when the row
player plays ``a`` and the column player (nature, minimising) plays ``j``; only the columns with
``allowed[g, j]`` exist. Each game is solved in two passes:

1. **Pure saddle points**, vectorised over all games: when ``max_a min_j M = min_j max_a M``,
   that number is the value and the two pure maximin / minimax choices are optimal. Terminal
   states (all payoffs equal), dominant actions and monotone natures all end here.
2. **Linear programming** for the rest, with scipy's HiGHS: ``max v`` subject to
   ``Σ_a x_a M[a, j] >= v`` for every allowed ``j``, ``x`` a distribution. The games are
   independent, so many are stacked into one block-diagonal sparse LP (its optimum is the sum
   of theirs and every optimal solution is optimal block by block); nature's optimal strategy
   is read from the duals of the ``j`` constraints.

scipy is imported on first use (``import ns_pz`` must stay light); without it (the ``game``
extra) the first mixed game raises :class:`~ns_pz.errors.MissingExtra` saying so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ns_pz.extras import require

SADDLE_TOLERANCE = 1e-12
"""Largest gap between the pure maximin and minimax accepted as a pure saddle point."""

GAMES_PER_LP = 4000
"""How many games one stacked LP holds (HiGHS time grows faster than linearly beyond)."""


@dataclass(frozen=True)
class MatrixGameSolutions:
    """Solutions of a batch of matrix games.

    Attributes:
        values: ``[N]`` game values.
        rows: ``[N, A]`` optimal row (agent) strategies.
        columns: ``[N, J]`` optimal column (nature) strategies, 0 on barred columns.
        linear_programs: How many of the ``N`` games needed the LP (the rest had a pure saddle).
    """

    values: np.ndarray
    rows: np.ndarray
    columns: np.ndarray
    linear_programs: int


def solve_matrix_games(
    payoffs: np.ndarray, allowed: np.ndarray | None = None
) -> MatrixGameSolutions:
    """Solve ``N`` zero-sum games ``payoffs[g]`` (``[N, A, J]``) over their allowed columns.

    Args:
        payoffs: ``[N, A, J]`` finite payoffs to the maximising row player.
        allowed: ``[N, J]`` bool, the columns that exist (default: all). Every game needs one.

    Raises:
        ValueError: Shapes disagree, a payoff is not finite, a game has no allowed column, or
            HiGHS fails on a block (it should not: every block is feasible and bounded).
    """
    payoffs = np.asarray(payoffs, dtype=np.float64)
    if payoffs.ndim != 3 or 0 in payoffs.shape:
        raise ValueError(f"payoffs has shape {payoffs.shape}; expected non-empty [N, A, J]")
    count, num_rows, num_columns = payoffs.shape
    allowed = np.ones((count, num_columns), bool) if allowed is None else np.asarray(allowed, bool)
    if allowed.shape != (count, num_columns):
        raise ValueError(f"allowed has shape {allowed.shape}; expected {(count, num_columns)}")
    if not np.all(allowed.any(axis=1)):
        raise ValueError("a game has no allowed column (nature must have a move)")
    if not np.all(np.isfinite(payoffs[np.broadcast_to(allowed[:, None, :], payoffs.shape)])):
        raise ValueError("payoffs must be finite on allowed columns")
    worst = np.where(allowed[:, None, :], payoffs, np.inf).min(axis=2)  # [N, A]
    best = np.where(allowed, payoffs.max(axis=1), np.inf)  # [N, J]; barred: never chosen
    lower, upper = worst.max(axis=1), best.min(axis=1)
    row_choice, column_choice = worst.argmax(axis=1), best.argmin(axis=1)
    values = lower.copy()
    rows = np.eye(num_rows)[row_choice]
    columns = np.eye(num_columns)[column_choice]
    # HiGHS's tolerances are absolute: every LP game is solved shifted by its maximin (value
    # near 0, whatever the payoffs' offset) and, if its payoffs span less than 1, magnified to
    # span 1 (the same strategies); the saddle test is relative to that span (capped at 1). A
    # wider game is not shrunk: that would let the tolerance swallow the differences that
    # decide it when one payoff lies far from the others.
    low = worst.min(axis=1)
    span = np.where(allowed[:, None, :], payoffs, -np.inf).max(axis=(1, 2)) - low
    shift, size = lower, np.where(span < 1.0, span, 1.0)
    mixed = np.flatnonzero(upper - lower > SADDLE_TOLERANCE * size)
    for start in range(0, mixed.size, GAMES_PER_LP):
        chunk = mixed[start : start + GAMES_PER_LP]
        moved, sized = shift[chunk, None, None], size[chunk, None, None]
        unit_values, rows[chunk], columns[chunk] = _solve_stacked(
            (payoffs[chunk] - moved) / sized, allowed[chunk]
        )
        values[chunk] = shift[chunk] + size[chunk] * unit_values
    return MatrixGameSolutions(values, rows, columns, int(mixed.size))


def _solve_stacked(
    payoffs: np.ndarray, allowed: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One block-diagonal LP for a batch of games without a pure saddle point."""
    why = "solving a matrix game without a pure saddle point (solve_game, exploitability)"
    linprog = require("scipy.optimize", why).linprog
    coo_matrix = require("scipy.sparse", why).coo_matrix

    count, num_rows, num_columns = payoffs.shape
    width = num_rows + 1  # x_0 .. x_{A-1}, v per game
    game, column = np.nonzero(allowed)  # one inequality per allowed (game, column)
    num_ineq = game.size
    # v_g - Σ_a x_ga M_g[a, j] <= 0
    ineq_rows = np.repeat(np.arange(num_ineq), width)
    ineq_cols = (game[:, None] * width + np.arange(width)[None, :]).ravel()
    ineq_vals = np.concatenate([-payoffs[game, :, column], np.ones((num_ineq, 1))], axis=1).ravel()
    a_ub = coo_matrix((ineq_vals, (ineq_rows, ineq_cols)), shape=(num_ineq, count * width))
    eq_rows = np.repeat(np.arange(count), num_rows)
    eq_cols = (np.arange(count)[:, None] * width + np.arange(num_rows)[None, :]).ravel()
    a_eq = coo_matrix((np.ones(eq_rows.size), (eq_rows, eq_cols)), shape=(count, count * width))
    cost = np.zeros(count * width)
    cost[num_rows::width] = -1.0
    bounds = np.zeros((count * width, 2))
    bounds[:, 1] = np.inf
    bounds[num_rows::width] = (-np.inf, np.inf)
    result = linprog(
        cost,
        A_ub=a_ub.tocsr(),
        b_ub=np.zeros(num_ineq),
        A_eq=a_eq.tocsr(),
        b_eq=np.ones(count),
        bounds=bounds,
        method="highs",
    )
    if result.status != 0:
        raise ValueError(f"HiGHS failed on a batch of {count} matrix games: {result.message}")
    solution = result.x.reshape(count, width)
    rows = np.clip(solution[:, :num_rows], 0.0, None)
    rows /= rows.sum(axis=1, keepdims=True)
    columns = np.zeros((count, num_columns))
    columns[game, column] = np.clip(-result.ineqlin.marginals, 0.0, None)
    columns /= columns.sum(axis=1, keepdims=True)
    return solution[:, num_rows], rows, columns
