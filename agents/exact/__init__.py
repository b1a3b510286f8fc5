"""Exact solvers for the tabular envs: induction, the oracle, robust VI, the game with nature.

The game tools work on a finite θ grid: nature's and the agent's best responses, the Shapley
value and equilibrium at ``detailed``, and how exploitable a planner is.

These are the bounds every tabular benchmark cell is read against: the
oracle's value is the best any agent can do in expectation against the true θ trajectory.
"""

from ns_pz.agents.exact.best_response import (
    AgentResponse,
    NatureResponse,
    OpenLoopResponse,
    agent_best_response,
    nature_best_response,
    open_loop_best_response,
    play_values,
)
from ns_pz.agents.exact.exploitability import (
    Exploitability,
    exploitability,
    search_policy_on_grid,
    snapshot_policy_on_grid,
)
from ns_pz.agents.exact.game_value import GameSolution, solve_game
from ns_pz.agents.exact.induction import (
    FiniteHorizonSolution,
    backward_induction,
    evaluate_policy,
)
from ns_pz.agents.exact.matrix_game import MatrixGameSolutions, solve_matrix_games
from ns_pz.agents.exact.nature_grid import NatureGrid, nature_grid, slip_line_grid
from ns_pz.agents.exact.notification_value import (
    BlindValueBounds,
    averaged_equilibrium,
    blind_value_bounds,
)
from ns_pz.agents.exact.references import (
    PolicyAgent,
    oracle_agent,
    oracle_solution,
    outcome_tables,
    policy_values,
    snapshot_policy,
    stale_policy,
    start_value,
)
from ns_pz.agents.exact.regret_reference import OracleReference
from ns_pz.agents.exact.robust import (
    equal_split,
    robust_backward_induction,
    robust_slip_solution,
    slip_intervals,
)
from ns_pz.agents.exact.schedule import initial_theta, theta_trajectory

__all__ = [
    "AgentResponse",
    "BlindValueBounds",
    "Exploitability",
    "FiniteHorizonSolution",
    "OracleReference",
    "GameSolution",
    "MatrixGameSolutions",
    "NatureGrid",
    "NatureResponse",
    "OpenLoopResponse",
    "PolicyAgent",
    "agent_best_response",
    "averaged_equilibrium",
    "backward_induction",
    "blind_value_bounds",
    "equal_split",
    "evaluate_policy",
    "initial_theta",
    "exploitability",
    "nature_best_response",
    "nature_grid",
    "open_loop_best_response",
    "oracle_agent",
    "oracle_solution",
    "outcome_tables",
    "play_values",
    "policy_values",
    "robust_backward_induction",
    "robust_slip_solution",
    "search_policy_on_grid",
    "slip_intervals",
    "slip_line_grid",
    "snapshot_policy",
    "snapshot_policy_on_grid",
    "solve_game",
    "solve_matrix_games",
    "stale_policy",
    "start_value",
    "theta_trajectory",
]
