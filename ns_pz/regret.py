"""Nature's payoff: zero-sum, cooperative, none, or the decision agent's regret.

With ``nature_reward="regret"`` nature earns the agent's shortfall against a reference that
faces the *same* θ trajectory from the same start state: ``-r_t`` at every transition and, when
the episode ends, the reference's value, so that nature's episode total is
``reference value - agent's return``. A nature cannot win by merely making the task impossible:
where the reference fails too, there is no regret to collect.

A reference is any callable ``reference(process) -> float`` called once on the finished episode.
Two are provided: :class:`ReplayReference` (a given policy replayed against the recorded θ
trajectory; any family) and :class:`ns_pz.agents.exact.OracleReference` (the exact optimum of
the recorded trajectory; tabular families). Against a nature that reacts to the state, the
recorded trajectory is the one nature chose against the agent, which is what the reference is
then measured on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ns_pz.nature.policies import TrajectoryNature
from ns_pz.seat_policies import DecisionPolicy

if TYPE_CHECKING:
    from ns_pz.family import EnvFamily
    from ns_pz.process import NSProcess

NATURE_REWARDS = ("zero_sum", "cooperative", "none", "regret")
"""The values ``nature_reward=`` takes: −r, +r, 0, or the shortfall against a reference."""
RegretReference = Callable[["NSProcess"], float]
"""``reference(process) -> float``, called once per finished episode: the regret baseline."""


class NatureReward:
    """Nature's reward for one transition and at the end of an episode.

    Args:
        mode: One of :data:`NATURE_REWARDS`.
        reference: The regret reference (needed for, and only taken with, ``"regret"``).

    Raises:
        ValueError: An unknown mode, ``"regret"`` without a reference, or a reference without
            ``"regret"``.
        TypeError: The reference is not callable.
    """

    def __init__(self, mode: str, reference: RegretReference | None = None) -> None:
        if mode not in NATURE_REWARDS:
            raise ValueError(f"nature_reward={mode!r}; allowed: {NATURE_REWARDS}")
        if mode == "regret":
            if reference is None:
                raise ValueError(
                    "nature_reward='regret' needs regret_reference= (e.g. "
                    "ns_pz.agents.exact.OracleReference() on a tabular family, or "
                    "ns_pz.regret.ReplayReference(policy))"
                )
            if not callable(reference):
                raise TypeError(f"regret_reference={reference!r} must be callable(process)")
        elif reference is not None:
            raise ValueError(
                f"regret_reference={reference!r} is only used with nature_reward='regret', "
                f"not {mode!r}"
            )
        self.mode = mode
        self.reference = reference
        self._sign = {"zero_sum": -1.0, "cooperative": 1.0, "none": 0.0, "regret": -1.0}[mode]

    def per_step(self, reward: float) -> float:
        """Nature's reward for a transition that paid the agent ``reward``."""
        return self._sign * reward

    def at_end(self, process: NSProcess) -> float:
        """Nature's extra reward when the episode ends (the reference's value for regret)."""
        if self.reference is None:
            return 0.0
        return float(self.reference(process))


class ReplayReference:
    """The return of a policy replayed against an episode's recorded θ trajectory.

    The replay starts from the episode's start state and θ_0, applies each recorded change at
    its step (θ stays at the last value after the recorded end), and is told of changes by the
    episode's monitor at the episode's notification level.

    Args:
        policy: A callable, an SB3-style model or an ns_pz ``Agent`` (see
            :mod:`ns_pz.seat_policies`).
        episodes: Replays to average (with different transition draws), >= 1.
        deterministic: Passed to ``predict`` of an SB3-style model.
    """

    def __init__(self, policy: Any, *, episodes: int = 1, deterministic: bool = True) -> None:
        if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
            raise ValueError(f"episodes={episodes!r} must be an int >= 1")
        self.decide = DecisionPolicy(policy, deterministic=deterministic)
        self.episodes = episodes

    def __call__(self, process: NSProcess) -> float:
        """The mean return of the replays of ``process``'s finished episode."""
        from ns_pz.process import NSProcess

        # Built on the base θ_0 (a monitor is bound to one), started from the episode's own.
        replay = NSProcess(
            process.family,
            params=process.base_theta0,
            nature=TrajectoryNature(process.change_times, process.change_values),
            monitor=process.monitor,
            notification=process.level,
            max_episode_steps=process.max_episode_steps,
        )
        rng = process.seat_rng()
        total = 0.0
        for _ in range(self.episodes):
            replay.seed(np.random.SeedSequence(rng.integers(2**63)))
            replay.reset({"params": process.theta0})
            replay.state = replay.initial_state = process.initial_state
            self.decide.reset(replay.seat_rng())
            episode_return, _ = replay.play_until(None, self.decide)
            total += episode_return
        return total / self.episodes


def default_reference(family: EnvFamily) -> RegretReference:
    """The exact oracle on a tabular family; elsewhere a reference must be named.

    Raises:
        ValueError: ``family`` is not tabular.
    """
    from ns_pz.agents.exact import OracleReference

    if not callable(getattr(family, "outcomes", None)):
        raise ValueError(
            f"nature_reward='regret' on {family!r} (not tabular) needs regret_reference= "
            "(e.g. ns_pz.regret.ReplayReference(reference_policy))"
        )
    return OracleReference()
