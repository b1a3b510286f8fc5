"""Memory for a learned monitor: a normalised clock and running evidence since its last alarm.

The monitor observation (:func:`ns_pz.observations.monitor_observation_space`) shows one
transition and the step count. A policy over it has nothing to remember with: it cannot tell the
first surprising transition of an episode from the tenth, nor whether it has already raised an
alarm. :class:`MonitorFeatures` adds what a detector keeps, computed from the same stream and
from θ_0 only (never θ or the change times), so a learner can act like a detector:

* ``clock``: ``Box(0, 1, (1,))``, the transitions so far divided by the horizon given; it
  replaces the unnormalised ``relative_time``.
* ``memory``: ``Box(0, 1, (5,))``, in this order, each count ``n`` squashed to ``n / (1 + n)``
  (0 stays 0, 1 becomes 0.5: bounded inputs suit a network, and what a policy needs most,
  "none" or "at least one", stays plain):

  0. transitions since the monitor's last alarm (since reset before the first), divided by the
     horizon (not squashed; clipped at 1);
  1. alarms the monitor has raised this episode;
  2. transitions since the last alarm that are impossible under θ_0;
  3. transitions since the last alarm that are unlikely under θ_0 (probability below
     ``unlikely``, but not 0);
  4. the summed surprise of those transitions under θ_0: ``-log P_0(x) - H_0(s, a)`` (the
     transition's negative log-likelihood less its expectation under θ_0, so it drifts
     upwards only once θ has moved; ``P_0`` floored at ``1e-6``), clipped at 0 from below after
     each transition, a CUSUM of the surprise.

Entries 2-4 read θ_0's explicit outcome table (tabular families); ``evidence=False`` leaves them
at 0 on any family. A transition's probability is that of the outcomes of ``(s, a)`` reaching
``s'`` with reward ``r`` (as :class:`~ns_pz.monitor.TabularCusumMonitor` keys them).

The same object serves the learner's seat (``single_agent(..., monitor_features=...)``) and the
trained policy put back in the game (``PolicyMonitor(policy, features=...)``): both update one
memory per episode with :meth:`MonitorFeatures.update` and :meth:`MonitorFeatures.alarmed`, so
the policy sees in the game exactly what it saw in training.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from ns_pz.checks import count
from ns_pz.family import EnvFamily
from ns_pz.params import Params

MEMORY_FIELDS = ("since_alarm", "alarms", "impossible", "unlikely", "surprise")
"""The entries of the ``memory`` feature, in order."""
SURPRISE_FLOOR = 1e-6
"""Probability a transition impossible under θ_0 is given in its surprise."""


class FeatureMemory:
    """One episode's running statistics (see the module doc)."""

    __slots__ = ("t", "since_alarm", "alarms", "impossible", "unlikely", "surprise")

    def __init__(self) -> None:
        self.t = 0
        self.since_alarm = 0
        self.alarms = 0
        self.impossible = 0
        self.unlikely = 0
        self.surprise = 0.0


class MonitorFeatures:
    """The clock and evidence features of a learned monitor's observation (see the module doc).

    Args:
        horizon: What the clock and the steps since the last alarm are divided by: the
            episode's ``max_episode_steps``, usually (both are clipped at 1 beyond it).
        evidence: Count impossible and unlikely transitions and sum their surprise under θ_0
            (needs a tabular family); ``False``: those entries stay 0.
        unlikely: Probability under θ_0 below which a possible transition counts as unlikely,
            in (0, 1).

    Raises:
        TypeError: ``evidence`` is not a bool.
        ValueError: ``horizon`` not an int >= 1, ``unlikely`` outside (0, 1).
    """

    def __init__(self, horizon: int, *, evidence: bool = True, unlikely: float = 0.1) -> None:
        self.horizon = count("horizon", horizon)
        if not isinstance(evidence, bool):
            raise TypeError(f"evidence={evidence!r} must be a bool")
        if isinstance(unlikely, bool) or not (
            isinstance(unlikely, (int, float)) and 0.0 < unlikely < 1.0
        ):
            raise ValueError(f"unlikely={unlikely!r} must be a probability in (0, 1)")
        self.evidence = evidence
        self.unlikely = float(unlikely)
        self._table: Any = None
        self._entropy: np.ndarray | None = None
        self._rewards: np.ndarray | None = None
        self._bound: tuple[str, Params] | None = None

    def bind(self, family: EnvFamily, theta0: Params) -> None:
        """Read θ_0's outcome table for the evidence.

        Raises:
            TypeError: ``evidence=True`` on a family without an explicit outcome table.
            ValueError: Already bound to another family or θ_0 (give each its own instance).
        """
        key = (repr(family), theta0)
        if self._bound is not None:
            if self._bound == key:
                return
            raise ValueError(
                f"{self!r} is bound to {self._bound[0]} with θ_0 = {self._bound[1]!r}; give "
                f"{family!r} with θ_0 = {theta0!r} its own instance"
            )
        self._bound = key
        if not self.evidence:
            return
        model = family.planning_model(theta0, None, np.random.default_rng(0))
        table = getattr(model, "outcomes", None)
        if table is None:
            raise TypeError(
                f"{family!r} has no explicit outcome table; use MonitorFeatures(evidence=False) "
                "(the clock and alarm counts alone)"
            )
        self._table = table
        probs = table.probs
        with np.errstate(divide="ignore", invalid="ignore"):
            self._entropy = -np.where(probs > 0, probs * np.log(probs), 0.0).sum(axis=2)
        self._rewards = table.rewards.astype(np.float32)

    def observation_space(self, base: spaces.Dict) -> spaces.Dict:
        """``base`` (the monitor observation space) with the clock and memory for its clock."""
        kept = {key: space for key, space in base.spaces.items() if key != "relative_time"}
        return spaces.Dict(
            {
                **kept,
                "clock": spaces.Box(0.0, 1.0, (1,), np.float32),
                "memory": spaces.Box(0.0, 1.0, (len(MEMORY_FIELDS),), np.float32),
            }
        )

    def initial_memory(self) -> FeatureMemory:
        """Nothing seen, no alarm."""
        return FeatureMemory()

    def update(self, memory: FeatureMemory, observation: dict[str, Any]) -> None:
        """Count the transition in ``observation`` (nothing at reset, ``relative_time`` 0)."""
        t = int(observation["relative_time"][0])
        memory.t = t
        if t == 0:
            return
        memory.since_alarm += 1
        if self._table is None:
            return
        state, action = int(observation["last_state"]), int(observation["last_action"])
        reached = self._table.next_states[state, action] == int(observation["state"])
        assert self._rewards is not None  # bound with evidence
        reward = np.float32(observation["last_reward"][0])
        exact = reached & (self._rewards[state, action] == reward)
        chance = float(self._table.probs[state, action][exact if exact.any() else reached].sum())
        if chance <= 0.0:
            memory.impossible += 1
        elif chance < self.unlikely:
            memory.unlikely += 1
        assert self._entropy is not None  # bound with evidence
        excess = -math.log(max(chance, SURPRISE_FLOOR)) - float(self._entropy[state, action])
        memory.surprise = max(0.0, memory.surprise + excess)

    def alarmed(self, memory: FeatureMemory, flags: Any) -> None:
        """Record the monitor's answer: a raised flag restarts the evidence since the alarm."""
        if not any(flags):
            return
        memory.alarms += 1
        memory.since_alarm = memory.impossible = memory.unlikely = 0
        memory.surprise = 0.0

    def observation(self, observation: dict[str, Any], memory: FeatureMemory) -> dict[str, Any]:
        """``observation`` with the features of ``memory`` for its ``relative_time``."""
        kept = {key: value for key, value in observation.items() if key != "relative_time"}
        return {**kept, **self._arrays(memory)}

    def _arrays(self, memory: FeatureMemory) -> dict[str, np.ndarray]:
        horizon = self.horizon
        return {
            "clock": np.array([min(memory.t / horizon, 1.0)], np.float32),
            "memory": np.array(
                [
                    min(memory.since_alarm / horizon, 1.0),
                    _squash(memory.alarms),
                    _squash(memory.impossible),
                    _squash(memory.unlikely),
                    _squash(memory.surprise),
                ],
                np.float32,
            ),
        }

    def __repr__(self) -> str:
        return (
            f"MonitorFeatures(horizon={self.horizon}, evidence={self.evidence}, "
            f"unlikely={self.unlikely})"
        )


def _squash(value: float) -> float:
    """``value / (1 + value)`` for ``value >= 0``: in [0, 1), 0 at 0, 0.5 at 1."""
    return value / (1.0 + value)
