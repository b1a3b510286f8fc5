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

Two options add to the observation:

* ``detector=``: a detector (:class:`~ns_pz.monitor.TabularCusumMonitor` or
  :class:`~ns_pz.monitor.PredictionErrorMonitor`) runs beside the learned monitor on the same
  transitions, and ``detector`` (``Box(0, 1, (3,))``) shows: 0. its statistic after the
  transition over its threshold (clipped at 1; the CUSUM's ``max_g W_g / h``); 1. whether it
  alarms at this transition (0/1); 2. its alarms since the learned monitor's last alarm,
  squashed. The detector restarts on its own alarms, not on the learned monitor's: it is the
  detector as it would run alone, which the learned monitor may follow, delay or overrule.
* ``stack=k``: the transitions of the ``k - 1`` turns before this one, newest first, as
  ``last_state_1``, ``last_action_1``, ``last_reward_1``, ``state_1``, ... ``state_{k-1}``
  (each in its field's space), and ``stacked`` (``Box(0, 1, (k - 1,))``: 1 where that past
  transition exists; the others are zeros). Frame stacking is memory of a fixed length; a
  recurrent policy (sb3-contrib's ``RecurrentPPO``, played back by ``PolicyMonitor(...,
  recurrent=True)``) is memory of any length.

The same object serves the learner's seat (``single_agent(..., monitor_features=...)``) and the
trained policy put back in the game (``PolicyMonitor(policy, features=...)``): both update one
memory per episode with :meth:`MonitorFeatures.update` and :meth:`MonitorFeatures.alarmed`, so
the policy sees in the game exactly what it saw in training.
"""

from __future__ import annotations

import math
import numbers
from collections import deque
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
DETECTOR_FIELDS = ("statistic", "alarm", "alarms_since")
"""The entries of the ``detector`` feature, in order."""
TRANSITION_FIELDS = ("last_state", "last_action", "last_reward", "state")
"""The monitor observation's fields that ``stack`` repeats for past turns."""


class FeatureMemory:
    """One episode's running statistics (see the module doc)."""

    __slots__ = (
        "t",
        "since_alarm",
        "alarms",
        "impossible",
        "unlikely",
        "surprise",
        "detector",
        "detector_rng",
        "statistic",
        "detector_alarm",
        "detector_alarms",
        "frames",
    )

    def __init__(self, detector: Any = None, stack: int = 1) -> None:
        self.t = 0
        self.since_alarm = 0
        self.alarms = 0
        self.impossible = 0
        self.unlikely = 0
        self.surprise = 0.0
        self.detector = detector
        """The detector's own memory (``None`` without a detector)."""
        self.detector_rng = np.random.default_rng(0)
        """The generator handed to the detector (the shipped ones draw nothing from it)."""
        self.statistic = 0.0
        self.detector_alarm = False
        self.detector_alarms = 0
        self.frames: deque[dict[str, Any]] = deque(maxlen=stack)
        """The last ``stack`` observations' transition fields, newest last."""


class MonitorFeatures:
    """The clock and evidence features of a learned monitor's observation (see the module doc).

    Args:
        horizon: What the clock and the steps since the last alarm are divided by: the
            episode's ``max_episode_steps``, usually (both are clipped at 1 beyond it).
        evidence: Count impossible and unlikely transitions and sum their surprise under θ_0
            (needs a tabular family); ``False``: those entries stay 0.
        unlikely: Probability under θ_0 below which a possible transition counts as unlikely,
            in (0, 1).
        detector: A detector whose statistic and alarms join the observation (see the
            module doc); it is bound with the features, so give it a fresh instance.
        stack: How many turns' transitions the observation shows (1: this one only).

    Raises:
        TypeError: ``evidence`` is not a bool; ``detector`` keeps no statistic (it needs a
            ``threshold`` and a memory with a ``trace``, as the shipped detectors have).
        ValueError: ``horizon`` or ``stack`` not an int >= 1, ``unlikely`` outside (0, 1).
    """

    def __init__(
        self,
        horizon: int,
        *,
        evidence: bool = True,
        unlikely: float = 0.1,
        detector: Any = None,
        stack: int = 1,
    ) -> None:
        from ns_pz.monitor.cusum import TabularCusumMonitor
        from ns_pz.monitor.drift import PredictionErrorMonitor

        if detector is not None and not isinstance(
            detector, (TabularCusumMonitor, PredictionErrorMonitor)
        ):
            raise TypeError(
                f"detector={detector!r} must be None, a TabularCusumMonitor or a "
                "PredictionErrorMonitor (a detector that keeps a statistic and a threshold)"
            )
        self.detector = detector
        self.stack = count("stack", stack)
        self.horizon = count("horizon", horizon)
        if not isinstance(evidence, bool):
            raise TypeError(f"evidence={evidence!r} must be a bool")
        real = isinstance(unlikely, numbers.Real) and not isinstance(unlikely, bool)
        if not 0.0 < (float(unlikely) if real else math.nan) < 1.0:
            raise ValueError(f"unlikely={unlikely!r} must be a probability in (0, 1)")
        self.evidence = evidence
        self.unlikely = float(unlikely)
        self._table: Any = None
        self._entropy: np.ndarray | None = None
        self._rewards: np.ndarray | None = None
        self._bound: tuple[str, Params] | None = None
        self._zero: dict[str, Any] = {}

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
        if self.detector is not None:
            self.detector.bind(family, theta0)
        if self.stack > 1:
            self._zero = {
                "last_state": _zero_of(family.observation_space),
                "last_action": _zero_of(family.action_space),
                "last_reward": np.zeros(1, np.float32),
                "state": _zero_of(family.observation_space),
            }
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
        extra: dict[str, spaces.Space[Any]] = {}
        if self.detector is not None:
            extra["detector"] = spaces.Box(0.0, 1.0, (len(DETECTOR_FIELDS),), np.float32)
        if self.stack > 1:
            for back in range(1, self.stack):
                extra.update({f"{name}_{back}": base.spaces[name] for name in TRANSITION_FIELDS})
            extra["stacked"] = spaces.Box(0.0, 1.0, (self.stack - 1,), np.float32)
        return spaces.Dict(
            {
                **kept,
                "clock": spaces.Box(0.0, 1.0, (1,), np.float32),
                "memory": spaces.Box(0.0, 1.0, (len(MEMORY_FIELDS),), np.float32),
                **extra,
            }
        )

    def initial_memory(self) -> FeatureMemory:
        """Nothing seen, no alarm (and the detector's memory at its start)."""
        detector = None if self.detector is None else self.detector.initial_memory()
        return FeatureMemory(detector, self.stack)

    def episode_memory(self, theta0: Params) -> FeatureMemory:
        """:meth:`initial_memory` for an episode from ``theta0`` (``reset`` options).

        The evidence is read from the bound θ_0's outcome table, and the detector's reference
        is its own: an episode from another θ_0 would be judged against the wrong model
        (transitions "impossible" that are not), so it is refused, as the detector refuses it.

        Raises:
            ValueError: ``theta0`` is not the bound θ_0 and the evidence or the detector
                depends on it.
        """
        if self.evidence and self._bound is not None and theta0 != self._bound[1]:
            raise ValueError(
                f"{self!r} reads its evidence from θ_0 = {self._bound[1]!r}; an episode from "
                f"θ_0 = {theta0!r} needs a MonitorFeatures instance bound to that θ_0"
            )
        detector = None if self.detector is None else self.detector.episode_memory(theta0)
        return FeatureMemory(detector, self.stack)

    def update(self, memory: FeatureMemory, observation: dict[str, Any]) -> None:
        """Count the transition in ``observation`` (nothing at reset, ``relative_time`` 0)."""
        t = int(observation["relative_time"][0])
        memory.t = t
        if t == 0:
            return
        if self.stack > 1:
            memory.frames.append({name: observation[name] for name in TRANSITION_FIELDS})
        memory.since_alarm += 1
        if self.detector is not None:
            self._run_detector(memory, observation)
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

    def _run_detector(self, memory: FeatureMemory, observation: dict[str, Any]) -> None:
        """Feed the transition to the detector; keep its statistic and whether it alarmed."""
        detector = self.detector
        assert detector is not None  # update() calls this only with one
        flags, _ = detector.notify(observation, None, memory.detector, memory.detector_rng)
        trace = memory.detector.trace
        memory.statistic = float(trace[-1]) if trace else 0.0
        memory.detector_alarm = any(flags)
        memory.detector_alarms += memory.detector_alarm

    def alarmed(self, memory: FeatureMemory, flags: Any) -> None:
        """Record the monitor's answer: a raised flag restarts the evidence since the alarm."""
        if not any(flags):
            return
        memory.alarms += 1
        memory.since_alarm = memory.impossible = memory.unlikely = 0
        memory.surprise = 0.0
        memory.detector_alarms = 0

    def observation(self, observation: dict[str, Any], memory: FeatureMemory) -> dict[str, Any]:
        """``observation`` with the features of ``memory`` for its ``relative_time``."""
        kept = {key: value for key, value in observation.items() if key != "relative_time"}
        return {**kept, **self._arrays(memory)}

    def _arrays(self, memory: FeatureMemory) -> dict[str, Any]:
        horizon = self.horizon
        extra: dict[str, Any] = {}
        if self.detector is not None:
            ratio = memory.statistic / self.detector.threshold
            extra["detector"] = np.array(
                [
                    min(ratio, 1.0) if math.isfinite(ratio) else 1.0,
                    float(memory.detector_alarm),
                    _squash(memory.detector_alarms),
                ],
                np.float32,
            )
        if self.stack > 1:
            past = list(memory.frames)[-2::-1]  # the turns before this one, newest first
            for back in range(1, self.stack):
                frame = past[back - 1] if back <= len(past) else None
                for name in TRANSITION_FIELDS:
                    value = self._zero[name] if frame is None else frame[name]
                    extra[f"{name}_{back}"] = _fresh(value)
            extra["stacked"] = np.array(
                [float(back <= len(past)) for back in range(1, self.stack)], np.float32
            )
        return {
            **extra,
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
            f"unlikely={self.unlikely}, detector={self.detector!r}, stack={self.stack})"
        )


def _fresh(value: Any) -> Any:
    """``value``, an array copied (an observation never shares data with an earlier one)."""
    return value.copy() if isinstance(value, np.ndarray) else value


def _zero_of(space: spaces.Space[Any]) -> Any:
    """The value a missing past transition shows: the space's first element, or 0 in a Box."""
    if isinstance(space, spaces.Discrete):
        return np.int64(space.start)
    if isinstance(space, spaces.Box):
        return np.clip(np.zeros(space.shape, space.dtype), space.low, space.high)
    raise TypeError(f"stack > 1 cannot show a past {space!r} (Discrete or Box only)")


def _squash(value: float) -> float:
    """``value / (1 + value)`` for ``value >= 0``: in [0, 1), 0 at 0, 0.5 at 1."""
    return value / (1.0 + value)
