"""Bounds on the game's value when the agent is blind to θ, hence on the value of notification.

At ``none`` the agent sees only its states (and the clock); its value ``V_none`` is exact only on
tiny instances (:mod:`ns_pz.agents.exact.openspiel_game`). For any size, two bounds hold:

* **lower**: any blind policy ``π`` (a ``[H, S]`` array) guarantees its value against nature's
  best response, so ``V_none >= max_π min_ν V(π, ν)`` over the candidates tried;
* **upper**: any nature strategy caps what every agent gets, and against one fixed schedule the
  best blind agent is the oracle (its time-indexed policy needs no θ), so
  ``V_none <= min_σ oracle(σ)`` over the schedules tried; also ``V_none <= V_detailed`` (more
  information never hurts the maximiser).

Besides the caller's candidates, one blind policy is always tried: the agent's equilibrium
strategy at ``detailed`` averaged over θ_{t-1} and the budget with the probabilities they have
in ``(t, s)`` under equilibrium play (:func:`averaged_equilibrium`).

The schedules tried are nature's open-loop best responses to each candidate, then alternately
the oracle for the last schedule and nature's open-loop best response to it (``rounds`` times);
every oracle found is also tried as a blind candidate. The value of notification
``V_detailed - V_none`` then lies in ``[V_detailed - upper, V_detailed - lower]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from ns_pz.agents.exact.best_response import (
    NatureResponse,
    nature_best_response,
    open_loop_best_response,
)
from ns_pz.agents.exact.game_stages import check_game, family_of, grid_tables
from ns_pz.agents.exact.game_value import GameSolution, solve_game
from ns_pz.agents.exact.nature_grid import NatureGrid
from ns_pz.agents.exact.references import oracle_solution, start_value
from ns_pz.agents.exact.solve_size import DEFAULT_MAX_BYTES

ROUNDING = 1e-12
"""Relative gap by which float64 rounding may put the lower bound above the upper one."""


@dataclass(frozen=True)
class BlindValueBounds:
    """Bounds on the value at ``none`` and on the value of notification.

    Attributes:
        detailed: The game's value at ``detailed``.
        lower: Best blind candidate's value against nature's best response (lowered to
            :attr:`upper` when rounding alone puts it above, by at most 1e-12 relative).
        upper: ``min(detailed, smallest oracle value over the schedules tried)``.
        best_candidate: Name of the candidate reaching :attr:`lower`.
        schedule: Grid indices of the schedule reaching the smallest oracle value.
        candidate_values: Each candidate's value against nature's best response.
    """

    detailed: float
    lower: float
    upper: float
    best_candidate: str
    schedule: tuple[int, ...]
    candidate_values: dict[str, float]

    @property
    def notification_value(self) -> tuple[float, float]:
        """``(low, high)`` bounds on ``V_detailed - V_none``."""
        return self.detailed - self.upper, self.detailed - self.lower


def blind_value_bounds(
    env: Any,
    grid: NatureGrid,
    horizon: int,
    candidates: Mapping[str, np.ndarray],
    *,
    gamma: float = 1.0,
    game: GameSolution | None = None,
    rounds: int = 1,
    max_nodes: int = 500,
    max_bytes: float = DEFAULT_MAX_BYTES,
    progress: bool = False,
) -> BlindValueBounds:
    """Bound ``V_none`` with blind candidates and with the oracles of schedules (module doc).

    Args:
        env: A tabular family, or an env built on one.
        grid: Nature's action set.
        horizon: ``H``.
        candidates: Blind policies by name, each ``[H, S]`` actions or ``[H, S, A]``
            probabilities (e.g. the stale and the robust policies).
        gamma: Discount in ``[0, 1]``.
        game: The game's solution for the same family, grid, horizon and discount, to reuse.
        rounds: Oracle / open-loop best-response alternations after the first schedules.
        max_nodes: Beam width of the open-loop searches.
        max_bytes: Memory limit of each solve's estimate
            (:mod:`ns_pz.agents.exact.solve_size`; default 4 GiB).
        progress: Print each solve's size estimate and steps done on stderr.

    Raises:
        ValueError: No candidate, a candidate that reads θ (wrong shape), ``rounds < 0``, or a
            ``game`` solved for another family, grid, horizon or discount.
    """
    horizon, gamma = check_game(horizon, gamma)
    if not candidates:
        raise ValueError("candidates is empty; give at least one blind policy by name")
    if isinstance(rounds, bool) or not isinstance(rounds, int) or rounds < 0:
        raise ValueError(f"rounds={rounds!r} must be an int >= 0")
    family = family_of(env)
    for name, policy in candidates.items():
        integer = np.issubdtype(np.asarray(policy).dtype, np.integer)
        if np.ndim(policy) != (2 if integer else 3):
            raise ValueError(
                f"candidates[{name!r}] has shape {np.shape(policy)}; a blind policy is "
                f"[H, S] actions or [H, S, A] probabilities"
            )
    limits = {"max_bytes": max_bytes, "progress": progress}
    if game is None:
        game = solve_game(env, grid, horizon, gamma=gamma, **limits)
    else:
        game.check_reusable(env, grid, horizon, gamma)
    candidates = {
        **candidates,
        "equilibrium averaged over θ": averaged_equilibrium(env, grid, game),
    }
    values: dict[str, float] = {}

    def guaranteed(name: str, policy: np.ndarray) -> None:
        response = nature_best_response(env, policy, grid, horizon, gamma=gamma, **limits)
        assert isinstance(response, NatureResponse)
        values[name] = response.value

    best_schedule: tuple[int, ...] = ()
    smallest = np.inf

    def try_schedule(indices: tuple[int, ...]) -> np.ndarray:
        nonlocal best_schedule, smallest
        oracle = oracle_solution(family, grid.schedule_of(indices), gamma)
        value = start_value(family, oracle.values)
        if value < smallest:
            smallest, best_schedule = value, indices
        return oracle.policy

    for name, policy in candidates.items():
        guaranteed(name, policy)
        schedule = open_loop_best_response(
            env, policy, grid, horizon, gamma=gamma, max_nodes=max_nodes, **limits
        ).indices
        for round_ in range(rounds + 1):
            oracle_policy = try_schedule(schedule)
            guaranteed(f"oracle of the schedule against {name}, round {round_}", oracle_policy)
            if round_ < rounds:
                schedule = open_loop_best_response(
                    env, oracle_policy, grid, horizon, gamma=gamma, max_nodes=max_nodes, **limits
                ).indices
    best = max(values, key=values.__getitem__)
    lower, upper = values[best], min(game.value, float(smallest))
    if upper < lower <= upper + ROUNDING * max(1.0, abs(upper)):
        lower = upper  # the same sums in another order: rounding must not invert the bracket
    return BlindValueBounds(
        detailed=game.value,
        lower=lower,
        upper=upper,
        best_candidate=best,
        schedule=best_schedule,
        candidate_values=values,
    )


def averaged_equilibrium(env: Any, grid: NatureGrid, game: GameSolution) -> np.ndarray:
    """``[H, S, A]``: the equilibrium agent strategy averaged over (θ_{t-1}, budget) per (t, s).

    The weights are the probabilities of the stages under equilibrium play from reset; a
    ``(t, s)`` never reached gets the unweighted mean.

    Raises:
        ValueError: ``game`` was solved for another family or grid.
    """
    game.check_reusable(env, grid, game.agent.shape[0], game.gamma)
    tables = grid_tables(env, grid)
    family = family_of(env)
    horizon, num_states, m, levels, num_actions = game.agent.shape
    after = grid.next_budget()
    mass = np.zeros((num_states, m, levels))
    mass[list(family.start_states), grid.start, grid.full_budget] = 1.0 / len(family.start_states)
    blind = np.empty((horizon, num_states, num_actions))
    for t in range(horizon):
        agent, nature = game.agent[t], game.nature[t]
        weight = mass.reshape(num_states, -1)
        total = weight.sum(axis=1, keepdims=True)
        mixed = agent.reshape(num_states, -1, num_actions)
        averaged = np.einsum("sc,sca->sa", weight, mixed)
        unweighted = mixed.mean(axis=1)
        blind[t] = np.where(total > 0, averaged / np.where(total > 0, total, 1.0), unweighted)
        following = np.zeros(num_states * m * levels)
        for j, table in enumerate(tables):
            reach = np.flatnonzero(after[:, :, j].ravel() >= 0)  # (i, b) with j allowed
            if reach.size == 0:
                continue
            # [s, (i,b), a, k] probability of moving to (s'_k, j, b')
            step = (
                mass.reshape(num_states, -1)[:, reach]
                * nature.reshape(num_states, -1, m)[:, reach, j]
            )
            step = step[:, :, None, None] * mixed[:, reach, :, None] * table.probs[:, None]
            step = np.where(table.terminals[:, None], 0.0, step)
            budget_after = after[:, :, j].ravel()[reach]  # [(i,b)]
            target = (
                table.next_states[:, None] * (m * levels)
                + j * levels
                + budget_after[None, :, None, None]
            )
            following += np.bincount(target.ravel(), weights=step.ravel(), minlength=following.size)
        mass = following.reshape(num_states, m, levels)
    return blind / blind.sum(axis=2, keepdims=True)  # exact rows: averaging rounds
