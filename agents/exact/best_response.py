"""Best responses on a nature grid: nature's to a fixed agent, the agent's to a fixed nature.

**Nature, closed loop** (:func:`nature_best_response`). Against a fixed agent strategy nature
faces an MDP over ``(t, s, θ_{t-1}, budget left)``: by exact backward induction, ::

    V_t[s, i, b] = min_{j allowed from (i, b)} Σ_a π_t(a | s, i, b) · G_t[i, b, j, s, a]

with ``G_t`` the stage payoffs of :mod:`ns_pz.agents.exact.game_stages`. With
``sees_state=True`` (the default) this is nature's optimal policy when it sees the agent's
state; it also sees θ_{t-1} and its budget, which are its own doing.

**Nature, open loop** (:func:`open_loop_best_response`). A nature that does not see the state
learns nothing during an episode, so its best response is one schedule θ_0 .. θ_{H-1} fixed in
advance, found by searching the tree of feasible schedules: exactly when the tree has at most
``max_nodes`` nodes at every depth, otherwise by a beam of that width ranked by the cost so far
plus the closed-loop value to go (an optimistic completion for nature). The closed-loop value is
always a lower bound on the open-loop one (a nature that sees more can do no worse), the best
schedule found is an upper bound, and the result carries both.

**Agent** (:func:`agent_best_response`). Against a fixed nature strategy the agent faces an MDP
over the same stages (it sees θ_{t-1} and the budget: the ``detailed`` level): it maximises
``Σ_j y_t(j | s, i, b) G_t[i, b, j, s, a]`` over ``a``.

:func:`play_values` is the exact value of one agent strategy against one nature strategy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from ns_pz.agents.exact.game_stages import (
    agent_strategy,
    check_game,
    family_of,
    grid_tables,
    nature_strategy,
    stage_induction,
    start_solve,
    start_value,
)
from ns_pz.agents.exact.nature_grid import NatureGrid
from ns_pz.agents.exact.solve_size import DEFAULT_MAX_BYTES

from ns_pz.params import Params


@dataclass(frozen=True)
class NatureResponse:
    """Nature's closed-loop best response and the agent's values under it.

    Attributes:
        values: ``[H + 1, S, m, levels]`` agent values; ``values[H]`` is zero.
        choice: ``[H, S, m, levels]`` grid index nature picks (ties: lowest index).
        value: Expected value at reset (start states, θ_{-1}, full budget).
    """

    values: np.ndarray
    choice: np.ndarray
    value: float


@dataclass(frozen=True)
class AgentResponse:
    """The agent's best response to a fixed nature and its values.

    Attributes:
        values: ``[H + 1, S, m, levels]``.
        policy: ``[H, S, m, levels]`` int64 actions (ties: lowest index).
        value: Expected value at reset.
    """

    values: np.ndarray
    policy: np.ndarray
    value: float


@dataclass(frozen=True)
class OpenLoopResponse:
    """The schedule a state-blind nature plays against a fixed agent.

    Attributes:
        value: Agent's expected value against :attr:`schedule` (an upper bound on the open-loop
            best response's value, equal to it when :attr:`exact`).
        lower_bound: The closed-loop best response's value (a lower bound), or :attr:`value`
            itself when :attr:`exact`.
        indices: Grid index of θ_0 .. θ_{H-1}.
        schedule: θ_0 .. θ_{H-1}.
        exact: Whether the whole tree of schedules was searched.
        nodes: How many tree nodes were evaluated.
    """

    value: float
    lower_bound: float
    indices: tuple[int, ...]
    schedule: tuple[Params, ...]
    exact: bool
    nodes: int


def nature_best_response(
    env: Any,
    policy: Any,
    grid: NatureGrid,
    horizon: int,
    *,
    gamma: float = 1.0,
    sees_state: bool = True,
    max_nodes: int = 20_000,
    max_bytes: float = DEFAULT_MAX_BYTES,
    progress: bool = False,
) -> NatureResponse | OpenLoopResponse:
    """Nature's optimal response to a fixed agent policy, and the agent's value under it.

    Args:
        env: A tabular family, or an env / game / process built on one.
        policy: The agent's policy in any form
            :func:`~ns_pz.agents.exact.game_stages.agent_strategy` accepts (``[H, S]``
            actions at ``none``/``basic``, ``[H, S, m]`` at ``detailed``, or probabilities).
        grid: Nature's action set.
        horizon: ``H``, the number of transitions.
        gamma: Discount in ``[0, 1]``.
        sees_state: ``True``: closed loop, nature sees the state (exact DP, a
            :class:`NatureResponse`); ``False``: open loop (:func:`open_loop_best_response`).
        max_nodes: Tree width for the open-loop search.
        max_bytes: Refuse the solve when its estimated peak memory passes this
            (:mod:`ns_pz.agents.exact.solve_size`; default 4 GiB).
        progress: Print the size estimate, then the steps done and an ETA, on stderr.

    Raises:
        TypeError / ValueError: The env is not tabular, the grid is of another θ class, the
            policy has the wrong shape, ``horizon``/``gamma`` are invalid, or the solve is
            estimated beyond ``max_bytes``.
    """
    if not sees_state:
        return open_loop_best_response(
            env,
            policy,
            grid,
            horizon,
            gamma=gamma,
            max_nodes=max_nodes,
            max_bytes=max_bytes,
            progress=progress,
        )
    horizon, gamma = check_game(horizon, gamma)
    tables = grid_tables(env, grid)
    num_states, num_actions, _ = tables[0].probs.shape
    line = start_solve(
        "nature_best_response",
        tables,
        grid,
        horizon,
        held=num_actions,
        copies=3,
        max_bytes=max_bytes,
        progress=progress,
    )
    strategy = agent_strategy(policy, horizon, num_states, num_actions, grid)
    choice = np.empty((horizon, num_states, grid.size, grid.budget_levels), np.int64)

    def minimise(t: int, payoffs: np.ndarray, allowed: np.ndarray) -> np.ndarray:
        # [i, b, j, s]: the agent's expected payoff if nature picks j
        expected = np.einsum("ibjsa,siba->ibjs", payoffs, strategy[t])
        expected = np.where(allowed[..., None], expected, np.inf)
        choice[t] = expected.argmin(axis=2).transpose(2, 0, 1)
        return expected.min(axis=2).transpose(2, 0, 1)

    values = stage_induction(tables, grid, horizon, gamma, minimise, line)
    return NatureResponse(values, choice, start_value(family_of(env), values, grid))


def agent_best_response(
    env: Any,
    nature: Any,
    grid: NatureGrid,
    horizon: int,
    *,
    gamma: float = 1.0,
    max_bytes: float = DEFAULT_MAX_BYTES,
    progress: bool = False,
) -> AgentResponse:
    """The agent's optimal policy (at ``detailed``) against a fixed nature strategy.

    Args:
        env: A tabular family, or an env built on one.
        nature: Nature's strategy in any form
            :func:`~ns_pz.agents.exact.game_stages.nature_strategy` accepts.
        grid: Nature's action set.
        horizon: ``H``.
        gamma: Discount in ``[0, 1]``.
        max_bytes: Memory limit of the solve's estimate (as :func:`nature_best_response`).
        progress: Print the size estimate and the steps done on stderr.
    """
    horizon, gamma = check_game(horizon, gamma)
    tables = grid_tables(env, grid)
    num_states = tables[0].probs.shape[0]
    line = start_solve(
        "agent_best_response",
        tables,
        grid,
        horizon,
        held=grid.size,
        copies=3,
        max_bytes=max_bytes,
        progress=progress,
    )
    weights = nature_strategy(nature, horizon, num_states, grid)
    policy = np.empty((horizon, num_states, grid.size, grid.budget_levels), np.int64)

    def maximise(t: int, payoffs: np.ndarray, allowed: np.ndarray) -> np.ndarray:
        q = np.einsum("ibjsa,sibj->siba", payoffs, weights[t])
        policy[t] = q.argmax(axis=3)
        return q.max(axis=3)

    values = stage_induction(tables, grid, horizon, gamma, maximise, line)
    return AgentResponse(values, policy, start_value(family_of(env), values, grid))


def play_values(
    env: Any,
    policy: Any,
    nature: Any,
    grid: NatureGrid,
    horizon: int,
    *,
    gamma: float = 1.0,
    max_bytes: float = DEFAULT_MAX_BYTES,
    progress: bool = False,
) -> np.ndarray:
    """``[H + 1, S, m, levels]``: exact values of an agent strategy against a nature strategy.

    ``max_bytes`` and ``progress`` are as in :func:`nature_best_response`.
    """
    horizon, gamma = check_game(horizon, gamma)
    tables = grid_tables(env, grid)
    num_states, num_actions, _ = tables[0].probs.shape
    line = start_solve(
        "play_values",
        tables,
        grid,
        horizon,
        held=num_actions + grid.size,
        copies=3,
        max_bytes=max_bytes,
        progress=progress,
    )
    strategy = agent_strategy(policy, horizon, num_states, num_actions, grid)
    weights = nature_strategy(nature, horizon, num_states, grid)

    def expect(t: int, payoffs: np.ndarray, allowed: np.ndarray) -> np.ndarray:
        return np.einsum("ibjsa,sibj,siba->sib", payoffs, weights[t], strategy[t])

    return stage_induction(tables, grid, horizon, gamma, expect, line)


def open_loop_best_response(
    env: Any,
    policy: Any,
    grid: NatureGrid,
    horizon: int,
    *,
    gamma: float = 1.0,
    max_nodes: int = 20_000,
    max_bytes: float = DEFAULT_MAX_BYTES,
    progress: bool = False,
) -> OpenLoopResponse:
    """The best schedule fixed in advance against a fixed agent (module docstring).

    ``max_bytes`` and ``progress`` are as in :func:`nature_best_response`; the estimate adds
    the search's frontier (up to ``max_nodes`` times nature's most moves from a stage, each
    schedule with a state distribution and a path).

    Raises:
        ValueError: ``max_nodes < 1`` (and the errors of :func:`nature_best_response`).
    """
    if isinstance(max_nodes, bool) or not isinstance(max_nodes, int) or max_nodes < 1:
        raise ValueError(f"max_nodes={max_nodes!r} must be an int >= 1")
    horizon, gamma = check_game(horizon, gamma)
    tables = grid_tables(env, grid)
    num_states, num_actions, _ = tables[0].probs.shape
    # the frontier before pruning: each kept schedule times nature's moves from it
    moves = int((grid.next_budget() >= 0).sum(axis=2).max())
    nodes_at_most = min(max_nodes * moves, moves**horizon)
    chunk = 3 * 2048 * tables[0].probs.size  # the per-chunk outcome weights
    frontier = 8 * (nodes_at_most * (3 * num_states + horizon + 8) + chunk)
    line = start_solve(
        "open_loop_best_response",
        tables,
        grid,
        horizon,
        held=num_actions,
        copies=3,
        max_bytes=max_bytes,
        progress=progress,
        extra_bytes=frontier,
    )
    closed = nature_best_response(
        env, policy, grid, horizon, gamma=gamma, max_bytes=max_bytes - frontier
    )
    assert isinstance(closed, NatureResponse)  # sees_state=True returns one
    family = family_of(env)
    strategy = agent_strategy(policy, horizon, num_states, num_actions, grid)
    next_budget = grid.next_budget()
    # the frontier: one row per schedule prefix
    here = np.array([grid.start])
    left = np.array([grid.full_budget])
    mass = np.zeros((1, num_states))
    mass[0, list(family.start_states)] = 1.0 / len(family.start_states)
    gained = np.zeros(1)
    paths = np.zeros((1, 0), np.int64)
    exact, nodes = True, 0
    discount = 1.0
    for t in range(horizon):
        parent, move = np.nonzero(next_budget[here, left] >= 0)
        acting = strategy[t][:, here[parent], left[parent]].transpose(1, 0, 2)  # [n, S, A]
        here, left = move, next_budget[here[parent], left[parent], move]
        paths = np.concatenate([paths[parent], move[:, None]], axis=1)
        mass, gained = mass[parent], gained[parent]
        new_mass = np.zeros_like(mass)
        for j in np.unique(move):
            for rows in np.array_split(np.flatnonzero(move == j), 1 + np.sum(move == j) // 2048):
                table = tables[j]
                # probability of (node, s, a, k) this step
                weight = (mass[rows][:, :, None] * acting[rows])[..., None] * table.probs[None]
                gained[rows] += discount * np.einsum("nsak,sak->n", weight, table.rewards)
                alive = np.where(table.terminals, 0.0, weight)
                targets = np.arange(rows.size)[:, None] * num_states + table.next_states.ravel()
                new_mass[rows] = np.bincount(
                    targets.ravel(), weights=alive.ravel(), minlength=rows.size * num_states
                ).reshape(rows.size, num_states)
        mass = new_mass
        discount *= gamma
        nodes += here.size
        if line is not None:
            line.step(t + 1)
        if here.size > max_nodes and t < horizon - 1:
            exact = False
            to_go = np.einsum("ns,sn->n", mass, closed.values[t + 1][:, here, left])
            keep = np.argsort(gained + discount * to_go, kind="stable")[:max_nodes]
            here, left, mass, gained, paths = (
                here[keep],
                left[keep],
                mass[keep],
                gained[keep],
                paths[keep],
            )
    best = int(np.argmin(gained))
    indices = tuple(int(i) for i in paths[best])
    value = float(gained[best])
    return OpenLoopResponse(
        value=value,
        lower_bound=value if exact else closed.value,
        indices=indices,
        schedule=grid.schedule_of(indices),
        exact=exact,
        nodes=nodes,
    )
