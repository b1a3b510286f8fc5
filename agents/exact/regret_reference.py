"""The exact oracle as the reference of nature's regret (``nature_reward="regret"``)."""

from __future__ import annotations

from ns_pz.agents.exact.references import oracle_solution

from ns_pz.params import Params
from ns_pz.process import NSProcess


class OracleReference:
    """The optimum, in expectation, against an episode's recorded θ trajectory (tabular).

    Called on a finished episode, it solves the time-indexed problem in which transition ``t``
    runs under the θ nature chose for it (the last one after the recorded end), over the
    episode's time limit, and returns the value at the episode's start state. Nature's regret
    is then this value minus the agent's return: no agent can expect to do better.

    Args:
        gamma: Discount of the solution (1: the undiscounted return the game pays).
    """

    def __init__(self, gamma: float = 1.0) -> None:
        self.gamma = gamma

    def __call__(self, process: NSProcess) -> float:
        """The oracle's value at the episode's start state.

        Raises:
            ValueError: The process has no time limit (no horizon to solve for).
            TypeError: The family is not tabular.
        """
        horizon = process.max_episode_steps
        if horizon is None:
            raise ValueError("OracleReference needs an episode time limit (max_episode_steps)")
        solution = oracle_solution(process.family, recorded_thetas(process, horizon), self.gamma)
        return float(solution.values[0, process.initial_state])


def recorded_thetas(process: NSProcess, horizon: int) -> list[Params]:
    """θ of each transition ``0 .. horizon-1`` of the episode, from its recorded changes."""
    changes = dict(zip(process.change_times, process.change_values, strict=True))
    thetas, theta = [], process.theta0
    for t in range(horizon):
        theta = changes.get(t, theta)
        thetas.append(theta)
    return thetas
