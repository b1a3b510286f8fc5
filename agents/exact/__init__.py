"""Exact solvers for the tabular envs: backward induction, the oracle, robust value iteration.

These are the bounds every tabular benchmark cell is read against (ALGORITHMS.md §7): the
oracle's value is the best any agent can do in expectation against the true θ trajectory.
"""

from ns_pz.agents.exact.induction import (
    FiniteHorizonSolution,
    backward_induction,
    evaluate_policy,
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
    "FiniteHorizonSolution",
    "OracleReference",
    "PolicyAgent",
    "backward_induction",
    "equal_split",
    "evaluate_policy",
    "initial_theta",
    "oracle_agent",
    "oracle_solution",
    "outcome_tables",
    "policy_values",
    "robust_backward_induction",
    "robust_slip_solution",
    "slip_intervals",
    "snapshot_policy",
    "stale_policy",
    "start_value",
    "theta_trajectory",
]
