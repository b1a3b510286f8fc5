"""Exact references for the tabular envs: the oracle, snapshot replanning, the stale policy.

All three are time-indexed policies solved by backward induction over the horizon:

* **oracle** (Lecarpentier's "DP-NSMDP"): knows θ_0 .. θ_{H-1} and solves the time-indexed
  problem. Its value at the start state is the exact optimum in expectation: no agent, whatever
  it observes, can do better in expectation against that θ trajectory.
* **snapshot replanning** ("DP-snapshot", a perfect planner at notification ``detailed``):
  before transition ``t`` it knows θ_{t-1}, the θ of the transition it last saw (an agent hears of a
  change one step after the transition it drove), and acts as if that θ held until the horizon.
  Before transition 0 it knows only the θ at reset, which is not ``thetas[0]`` when nature changes θ
  at step 0.
* **stale** (a perfect planner at ``none`` / ``basic``): acts optimally for the θ at reset
  throughout.

Here ``thetas[t]`` is the θ in force during transition ``t`` (nature has moved at step ``t``),
as :func:`~ns_pz.agents.exact.schedule.theta_trajectory` returns it, and the θ at reset is
:func:`~ns_pz.agents.exact.schedule.initial_theta`: the two differ at ``t = 0`` exactly when
nature's first move is at step 0.

:func:`policy_values` evaluates any of them exactly against the true θ trajectory, and
:class:`PolicyAgent` plays one in an environment (it reads the step from ``relative_time``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from ns_pz.agents.base import Agent
from ns_pz.agents.exact.induction import (
    FiniteHorizonSolution,
    backward_induction,
    evaluate_policy,
)
from ns_pz.agents.exact.schedule import theta_trajectory

from ns_pz.family import EnvFamily
from ns_pz.params import Params
from ns_pz.planning import TabularOutcomes


def outcome_tables(family: EnvFamily, thetas: Sequence[Params]) -> list[TabularOutcomes]:
    """The outcome table of each θ in ``thetas`` (one table built per distinct θ).

    Raises:
        TypeError: ``family`` has no explicit outcome table (it is not tabular).
        ValueError: ``thetas`` is empty.
    """
    outcomes_fn = getattr(family, "outcomes", None)
    if not callable(outcomes_fn):
        raise TypeError(f"family={family!r} is not tabular (it has no outcomes(theta) table)")
    if len(thetas) == 0:
        raise ValueError("thetas is empty; give θ_0 .. θ_{H-1}, one per step")
    built: dict[Params, TabularOutcomes] = {}
    tables = []
    for theta in thetas:
        table = built.get(theta)
        if table is None:
            table = built[theta] = outcomes_fn(theta)
        tables.append(table)
    return tables


def oracle_solution(
    family: EnvFamily, thetas: Sequence[Params], gamma: float = 1.0
) -> FiniteHorizonSolution:
    """Optimal time-indexed solution when transition ``t`` runs under ``thetas[t]``."""
    return backward_induction(outcome_tables(family, thetas), gamma)


def stale_policy(family: EnvFamily, theta0: Params, horizon: int, gamma: float = 1.0) -> np.ndarray:
    """``[H, num_states]``: the optimal policy for ``theta0`` held fixed over ``horizon`` steps.

    For the stale planner pass the θ at reset (:func:`~.schedule.initial_theta`), not
    ``thetas[0]``, which already holds a change nature makes at step 0.
    """
    return oracle_solution(family, [theta0] * horizon, gamma).policy


def snapshot_policy(
    family: EnvFamily, theta0: Params, thetas: Sequence[Params], gamma: float = 1.0
) -> np.ndarray:
    """``[H, num_states]``: what snapshot replanning plays against ``thetas``.

    Before transition ``t >= 1`` the planner knows ``thetas[t - 1]``; before transition 0 it
    knows ``theta0``. At each step it plays step ``t`` of the optimal policy for the θ it knows
    held fixed over the whole horizon, exactly as
    :class:`~ns_pz.agents.planners.SnapshotValueIteration` with a ``horizon`` does at
    notification level ``detailed``.

    Args:
        family: A tabular family.
        theta0: The θ at reset, before nature's move at step 0
            (:func:`~ns_pz.agents.exact.schedule.initial_theta`). It differs from ``thetas[0]``
            when nature changes θ at step 0, which the planner cannot know before acting.
        thetas: θ of transitions ``0 .. H-1``.
        gamma: Discount in ``[0, 1]``.
    """
    horizon = len(thetas)
    known = [theta0, *thetas[:-1]]
    per_theta = {
        theta: oracle_solution(family, [theta] * horizon, gamma).policy for theta in set(known)
    }
    return np.stack([per_theta[theta][t] for t, theta in enumerate(known)])


def policy_values(
    family: EnvFamily, thetas: Sequence[Params], policy: np.ndarray, gamma: float = 1.0
) -> np.ndarray:
    """``[H + 1, num_states]``: exact values of a time-indexed policy against ``thetas``."""
    return evaluate_policy(outcome_tables(family, thetas), policy, gamma)


def start_value(family: EnvFamily, values: np.ndarray) -> float:
    """Expected value at reset: ``values[0]`` averaged over the family's start states.

    Args:
        family: A family with ``start_states`` (drawn uniformly at reset, as the grid worlds).
        values: ``[H + 1, num_states]`` or ``[num_states]`` values.
    """
    starts = getattr(family, "start_states", None)
    if not starts:
        raise TypeError(f"family={family!r} has no start_states to average over")
    row = values[0] if values.ndim == 2 else values
    return float(np.mean(row[list(starts)]))


class PolicyAgent(Agent):
    """Plays a fixed time-indexed policy: ``policy[relative_time, state]``.

    Args:
        policy: ``[H, num_states]`` actions (e.g. ``oracle_solution(...).policy``).
        name: How the agent is called in reports.
    """

    def __init__(self, policy: np.ndarray, name: str = "policy") -> None:
        policy = np.asarray(policy)
        if policy.ndim != 2 or not np.issubdtype(policy.dtype, np.integer):
            raise ValueError(
                f"policy has shape {policy.shape} and dtype {policy.dtype}; expected integer "
                "actions of shape (horizon, num_states)"
            )
        self.policy = policy
        self.name = name

    def act(self, observation: dict[str, Any], model: Any | None = None) -> int:
        """The policy's action at the observed step and state.

        Raises:
            ValueError: The episode runs past the policy's horizon.
        """
        t = int(observation["relative_time"][0])
        if t >= self.policy.shape[0]:
            raise ValueError(
                f"relative_time={t} is beyond the policy's horizon {self.policy.shape[0]}"
            )
        return int(self.policy[t, int(observation["state"])])

    def __repr__(self) -> str:
        return f"PolicyAgent({self.name}, horizon={self.policy.shape[0]})"


def oracle_agent(
    env: Any, seed: int, horizon: int | None = None, gamma: float = 1.0
) -> tuple[PolicyAgent, FiniteHorizonSolution]:
    """The oracle for the episode ``env.reset(seed=seed)`` starts, and its solution.

    The solution's :func:`start_value` is the exact optimal expected return of that episode.
    For a nature without randomness the trajectory, hence the oracle, is the same for every
    seed.

    Raises:
        TypeError: The nature may depend on the state or agent (see
            :func:`~ns_pz.agents.exact.schedule.theta_trajectory`), or the env is not tabular.
    """
    thetas = theta_trajectory(env, seed, horizon)
    family = getattr(env, "unwrapped", env).family
    solution = oracle_solution(family, thetas, gamma)
    return PolicyAgent(solution.policy, name="oracle"), solution
