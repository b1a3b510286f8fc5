"""The exact optimum of a tabular cell: what no agent can beat in expectation.

For a tabular env and an open-loop nature (every shipped spec), the θ of every transition is
known before the episode (:func:`~ns_pz.agents.exact.theta_trajectory`; the shipped change
kinds are deterministic, so one trajectory serves every seed), so finite-horizon
backward induction over the time-indexed outcome tables gives the optimal expected
undiscounted return from the start state (Lecarpentier's "DP-NSMDP"). It is the same with and
without notification: the oracle knows the schedule either way.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

from ns_pz.agents.exact import oracle_solution, start_value, theta_trajectory
from ns_pz.experiments.report import Optimum
from ns_pz.experiments.spec import ExperimentSpec


def optimum_for(record: Mapping[str, Any]) -> Optimum | None:
    """``optimum(setting, notification)`` for a run's spec record; ``None`` if not tabular."""
    spec = ExperimentSpec.from_dict(record)
    if not spec.is_tabular():
        return None
    index = {setting: i for i, setting in enumerate(spec.settings())}

    @functools.cache
    def value(setting: str) -> float:
        cell = next(c for c in spec.cells() if c.index == index[setting])
        env = spec.make_env(cell)
        thetas = theta_trajectory(env, spec.first_seed, spec.horizon)
        return start_value(env.family, oracle_solution(env.family, thetas).values)

    def optimum(setting: str, notification: str) -> float | None:
        return value(setting) if setting in index else None

    return optimum
