"""The stages of the NS-MDP game on a nature grid, and the strategies played in them.

A stage is ``(t, s, i, b)``: step ``t``, the agent's state ``s``, θ_{t-1} = θ^i and nature's budget
left ``b`` (units of :class:`~ns_pz.agents.exact.nature_grid.NatureGrid`). Nature picks θ_t = θ^j
among the moves allowed from ``i`` with ``b`` left, the agent picks ``a`` without seeing ``j``
(within a step the two move simultaneously; see :mod:`ns_pz.game`), and the transition is drawn
under θ^j. Given the values ``V_{t+1}[s', j, b']`` after the stage, the payoff of the pair
``(a, j)`` is::

    G_t[i, b, j, s, a] = Σ_k P_j(k | s, a) · (r_k + γ (1 - terminal_k) V_{t+1}[s'_k, j, b - c_ij])

:func:`stage_payoffs` computes ``G_t`` for every stage of step ``t`` at once. Every solver of
the game (best responses, play, the Shapley induction) is a reduction of this array over ``a``
and ``j``.

Strategies are arrays of probabilities:

* the agent's ``[H, S, m, levels, A]`` (at ``detailed`` it sees θ_{t-1}, and the budget left,
  which the change sizes it is told add up to); :func:`agent_strategy` broadcasts the smaller
  policies agents actually play (``[H, S]`` at ``none``/``basic``, ``[H, S, m]`` at ``detailed``,
  integers or probabilities) to it without copying;
* nature's ``[H, S, m, levels, m]`` (it sees the state; a nature blind to the state is one whose
  rows agree across ``s``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from ns_pz.agents.exact.induction import check_gamma
from ns_pz.agents.exact.nature_grid import NatureGrid
from ns_pz.agents.exact.references import outcome_tables
from ns_pz.agents.exact.schedule import check_horizon
from ns_pz.agents.exact.solve_progress import SolveProgress
from ns_pz.agents.exact.solve_size import SolveSize

from ns_pz.planning import TabularOutcomes


def family_of(env: Any) -> Any:
    """The tabular family of an env, a game, a process or a family itself.

    Raises:
        TypeError: No family with an ``outcomes(theta)`` table is found.
    """
    for candidate in (
        env,
        getattr(env, "family", None),
        getattr(getattr(env, "unwrapped", None), "family", None),
        getattr(getattr(getattr(env, "unwrapped", env), "_process", None), "family", None),
    ):
        if candidate is not None and callable(getattr(candidate, "outcomes", None)):
            return candidate
    raise TypeError(f"env={env!r} is not tabular (no family with an outcomes(theta) table)")


def grid_tables(env: Any, grid: NatureGrid) -> list[TabularOutcomes]:
    """The outcome table of every grid point, in grid order.

    Raises:
        TypeError: ``env`` is not tabular or ``grid`` is not a :class:`NatureGrid`.
    """
    if not isinstance(grid, NatureGrid):
        raise TypeError(f"grid={grid!r} must be a NatureGrid (see slip_line_grid, nature_grid)")
    family = family_of(env)
    if not isinstance(grid.thetas[0], family.params_cls):
        raise TypeError(
            f"grid holds {type(grid.thetas[0]).__name__}; {family!r} takes "
            f"{family.params_cls.__name__}"
        )
    tables = outcome_tables(family, grid.thetas)
    for theta, table in zip(grid.thetas, tables, strict=True):
        _check_outcome_rows(family, theta, table)
    return tables


TABLE_TOLERANCE = 1e-9
"""How far an outcome table's row may be off the simplex (a family's rounding, no more)."""


def _check_outcome_rows(family: Any, theta: Any, table: TabularOutcomes) -> None:
    """Refuse a table whose (state, action) rows are not distributions: it would inflate values.

    A table is the family's model, not a strategy: it is never renormalised here.
    """
    probs = np.asarray(table.probs, dtype=np.float64)
    off = np.abs(probs.sum(axis=2) - 1.0)
    low = probs.min(axis=2)
    bad = (off > TABLE_TOLERANCE) | (low < -TABLE_TOLERANCE) | ~np.isfinite(off)
    if np.any(bad):
        s, a = (int(k) for k in np.argwhere(bad)[0])
        raise ValueError(
            f"{family!r}.outcomes({theta!r}).probs[{s}, {a}] = {probs[s, a].tolist()} is not a "
            f"distribution (sums to {float(probs[s, a].sum())!r}); every row must be >= 0 and "
            f"sum to 1 within {TABLE_TOLERANCE}"
        )


def check_game(horizon: object, gamma: object) -> tuple[int, float]:
    """Validate a horizon (int >= 1) and a discount in [0, 1]."""
    return check_horizon(horizon), check_gamma(gamma)


def stage_payoffs(
    tables: Sequence[TabularOutcomes],
    next_values: np.ndarray,
    next_budget: np.ndarray,
    gamma: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Payoffs ``G_t[i, b, j, s, a]`` of every stage of one step, and which ``j`` are allowed.

    Args:
        tables: Outcome table of each grid point (``m`` of them).
        next_values: ``[S, m, levels]``, the values ``V_{t+1}``.
        next_budget: ``[m, levels, m]`` from :meth:`NatureGrid.next_budget` (-1: barred).
        gamma: Discount.

    Returns:
        ``payoffs`` ``[m, levels, m, S, A]`` (barred moves hold the payoff at budget 0, to be
        masked) and ``allowed`` ``[m, levels, m]`` bool.
    """
    num_points, levels = next_values.shape[1:]
    first = tables[0]
    num_states, num_actions, _ = first.probs.shape
    after = np.empty((num_points, levels, num_states, num_actions))
    for j, table in enumerate(tables):
        future = next_values[table.next_states, j, :]  # [S, A, K, levels]
        future = np.where(table.terminals[..., None], 0.0, future)
        after[j] = np.einsum(
            "sak,sakb->bsa", table.probs, table.rewards[..., None] + gamma * future
        )
    allowed = next_budget >= 0
    points = np.arange(num_points)[None, None, :]
    return after[points, np.maximum(next_budget, 0)], allowed


StageRule = Callable[[int, np.ndarray, np.ndarray], np.ndarray]
"""``rule(t, payoffs, allowed) -> values[t]`` (``[S, m, levels]``) from one step's stages."""


def stage_induction(
    tables: Sequence[TabularOutcomes],
    grid: NatureGrid,
    horizon: int,
    gamma: float,
    rule: StageRule,
    progress: SolveProgress | None = None,
) -> np.ndarray:
    """Backward induction over the stages: ``values[t] = rule(t, G_t, allowed)``, ``V_H = 0``.

    Returns:
        ``[H + 1, S, m, levels]`` values.
    """
    next_budget = grid.next_budget()
    num_states = tables[0].probs.shape[0]
    values = np.zeros((horizon + 1, num_states, grid.size, grid.budget_levels))
    for t in range(horizon - 1, -1, -1):
        payoffs, allowed = stage_payoffs(tables, values[t + 1], next_budget, gamma)
        values[t] = rule(t, payoffs, allowed)
        del payoffs, allowed  # before the next step's are built (the size estimate counts one)
        if progress is not None:
            progress.step(horizon - t)
    return values


def start_solve(
    what: str,
    tables: Sequence[TabularOutcomes],
    grid: NatureGrid,
    horizon: int,
    *,
    held: int,
    copies: int,
    max_bytes: float,
    progress: bool,
    extra_bytes: int = 0,
) -> SolveProgress | None:
    """Estimate a solve's size, refuse it beyond ``max_bytes``, and start its progress line.

    Args:
        what: The solver, for messages.
        tables: The grid's outcome tables.
        grid: Nature's action set.
        horizon: ``H``.
        held: Numbers the solver keeps per stage besides values and choices.
        copies: Payoff-sized temporaries of one step.
        max_bytes: The caller's memory limit.
        progress: Whether to print the progress line on stderr.
        extra_bytes: Memory beyond the stages.

    Returns:
        The progress line, or ``None`` when not asked for.

    Raises:
        TypeError: ``progress`` is not a bool, or ``max_bytes`` not a number.
        ValueError: The estimate passes ``max_bytes`` (the message holds it).
    """
    num_states, num_actions, _ = tables[0].probs.shape
    size = SolveSize(
        what,
        horizon,
        num_states,
        num_actions,
        grid.size,
        grid.budget_levels,
        held,
        copies,
        extra_bytes,
    )
    size.check(max_bytes)
    if not isinstance(progress, bool):
        raise TypeError(f"progress={progress!r} must be a bool")
    return SolveProgress(what, horizon, size.describe()) if progress else None


def agent_strategy(
    policy: Any, horizon: int, num_states: int, num_actions: int, grid: NatureGrid
) -> np.ndarray:
    """The agent's policy as ``[H, S, m, levels, A]`` probabilities (a read-only broadcast).

    Accepted: integer actions of shape ``[H, S]`` (blind to θ: ``none``/``basic``),
    ``[H, S, m]`` (θ_{t-1} seen: ``detailed``) or ``[H, S, m, levels]``; or probabilities with
    a trailing action axis: ``[H, S, A]``, ``[H, S, m, A]``, ``[H, S, m, levels, A]``.

    Raises:
        ValueError: Another shape, an action out of range, or rows that are not distributions.
    """
    array = np.asarray(policy)
    m, levels = grid.size, grid.budget_levels
    base = (horizon, num_states)
    full = (horizon, num_states, m, levels, num_actions)
    if np.issubdtype(array.dtype, np.integer):
        shapes = {base, (*base, m), (*base, m, levels)}
        if array.shape not in shapes:
            raise ValueError(
                f"policy has integer shape {array.shape}; allowed: {sorted(shapes)} "
                "(horizon, states[, θ grid points[, budget levels]])"
            )
        if array.size and (array.min() < 0 or array.max() >= num_actions):
            raise ValueError(f"policy holds actions outside 0..{num_actions - 1}")
        array = np.eye(num_actions)[array]
    elif np.issubdtype(array.dtype, np.floating):
        float_shapes = {(*base, num_actions), (*base, m, num_actions), full}
        if array.shape not in float_shapes:
            raise ValueError(
                f"policy has float shape {array.shape}; allowed: {sorted(float_shapes)} "
                "(probabilities with a trailing action axis)"
            )
        array = probability_rows(array, "policy", "actions")
    else:
        raise TypeError(
            f"policy={policy!r:.80} is not an array of actions or probabilities (dtype "
            f"{array.dtype}); pass [H, S] or [H, S, m] integer actions or probabilities with a "
            "trailing action axis. exploitability() also takes a search agent such as "
            "MCTS(iterations=100) directly; elsewhere convert one with "
            "search_policy_on_grid(env, grid, horizon, agent.search, rng)"
        )
    while array.ndim < 5:
        array = array[:, :, None] if array.ndim == 3 else array[:, :, :, None]
    return np.broadcast_to(array, full)


def probability_rows(array: np.ndarray, name: str, over: str) -> np.ndarray:
    """``array`` in float64 with every row (last axis) on the simplex.

    A row may be off by the rounding of its own dtype (float32 strategies are off by ~1e-7):
    it is then clipped at 0 and divided by its sum, so that no row adds up to more than 1 and
    inflates a value. A row off by more (beyond ``8 · n · eps`` of the dtype, and at least
    1e-12) is the caller's mistake, not rounding, and is refused: renormalising it would answer
    a question the caller did not ask.

    Raises:
        ValueError: A value is not finite, or a row is off the simplex beyond rounding.
    """
    count = array.shape[-1]
    tolerance = max(8 * count * float(np.finfo(array.dtype).eps), 1e-12)
    rows = np.array(array, dtype=np.float64)
    if not np.all(np.isfinite(rows)):
        raise ValueError(f"{name} holds NaN or infinite probabilities")
    sums = rows.sum(axis=-1)
    worst = np.unravel_index(int(np.argmax(np.abs(sums - 1.0))), sums.shape)
    if rows.min() < -tolerance or abs(sums[worst] - 1.0) > tolerance:
        raise ValueError(
            f"{name} rows must be probabilities over {over} (>= 0, summing to 1): row "
            f"{list(map(int, worst))} sums to {float(sums[worst])!r}, the smallest entry is "
            f"{float(rows.min())!r}; allowed: off by at most {tolerance:.2g} (the rounding of "
            f"{array.dtype}). Normalise it: p / p.sum(axis=-1, keepdims=True)"
        )
    np.clip(rows, 0.0, None, out=rows)
    rows /= rows.sum(axis=-1, keepdims=True)
    return rows


def nature_strategy(nature: Any, horizon: int, num_states: int, grid: NatureGrid) -> np.ndarray:
    """Nature's policy as ``[H, S, m, levels, m]`` probabilities (a read-only broadcast).

    Accepted: integer grid indices of shape ``[H, m, levels]`` (blind to the state) or
    ``[H, S, m, levels]``; probabilities with a trailing axis over the grid,
    ``[H, m, levels, m]`` or ``[H, S, m, levels, m]``.

    Raises:
        ValueError: Another shape, an index out of range, rows that are not distributions, or
            weight on a move the grid bars.
    """
    array = np.asarray(nature)
    m, levels = grid.size, grid.budget_levels
    if np.issubdtype(array.dtype, np.integer):
        if array.shape not in ((horizon, m, levels), (horizon, num_states, m, levels)):
            raise ValueError(
                f"nature has integer shape {array.shape}; allowed: {(horizon, m, levels)} or "
                f"{(horizon, num_states, m, levels)}"
            )
        if array.size and (array.min() < 0 or array.max() >= m):
            raise ValueError(f"nature holds grid indices outside 0..{m - 1}")
        array = np.eye(m)[array]
    elif np.issubdtype(array.dtype, np.floating):
        if array.shape not in ((horizon, m, levels, m), (horizon, num_states, m, levels, m)):
            raise ValueError(
                f"nature has float shape {array.shape}; allowed: {(horizon, m, levels, m)} or "
                f"{(horizon, num_states, m, levels, m)}"
            )
        array = probability_rows(array, "nature", "the grid")
    else:
        raise ValueError(f"nature has dtype {array.dtype}; expected grid indices or floats")
    if array.ndim == 4:
        array = array[:, None]
    array = np.broadcast_to(array, (horizon, num_states, m, levels, m))
    barred = grid.next_budget() < 0  # [m, levels, m]
    if np.any(array[:, :, barred] > 1e-9):
        raise ValueError("nature puts weight on a move the grid bars (Lipschitz or budget)")
    return array


def start_value(family: Any, values: np.ndarray, grid: NatureGrid) -> float:
    """``values[0]`` at (θ_{-1}, full budget), averaged over the family's start states."""
    starts = list(family.start_states)
    return float(np.mean(values[0][starts, grid.start, grid.full_budget]))
