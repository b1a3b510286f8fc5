"""Imperfect oracles for controlled studies: missed alarms, false alarms and delays on demand.

:class:`NoisyOracleMonitor` reads the true change (it is an oracle, ``reads_ground_truth``) and
degrades it: each true change is missed with probability ``miss_probability``, or reported
``delay`` transitions late; each transition without a true change raises a false alarm with
probability ``false_alarm_probability``, flagging one parameter drawn uniformly (size 0). It
draws exactly two uniforms per transition from the monitor's generator, whatever happens, so
its notifications depend on the seed and the change times only.

It must be asked at every transition, with the true sizes (zeros where nothing changed): its
class attribute :attr:`~ns_pz.monitor.Monitor.quiet_without_change` is ``False``. At
``detailed`` the agent's planner gets θ_0 with each parameter it has reported changed at its
value of the latest reported change (:meth:`NoisyOracleMonitor.told_changes`): a missed or not
yet reported change stays unknown to it, as to the agent.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from ns_pz.monitor.monitors import Flags, Monitor, Sizes, has_transition, silence


class NoisyOracleMemory:
    """One episode's pending (delayed) reports and the alarms raised."""

    __slots__ = ("pending", "alarms", "told")

    def __init__(self) -> None:
        self.pending: list[tuple[int, int, tuple[float, ...]]] = []
        """(transition at which to report, transition of the change, true sizes) of changes not
        reported yet."""
        self.alarms: list[int] = []
        """Transition indices whose notification raised an alarm."""
        self.told: dict[int, int] = {}
        """For each parameter index reported changed: the latest transition of a reported
        change to it."""


class NoisyOracleMonitor(Monitor):
    """The oracle with misses, false alarms and a delay (see the module doc).

    Args:
        miss_probability: Probability that a true change is never reported.
        false_alarm_probability: Probability, per transition without a true change, of a false
            alarm.
        delay: Transitions between a change and its report (0: as the oracle).

    Raises:
        ValueError: A probability outside [0, 1], a negative delay.
        TypeError: A delay that is not an int.
    """

    reads_ground_truth = True
    needs_observation = True
    quiet_without_change: ClassVar[bool] = False

    def __init__(
        self,
        miss_probability: float = 0.0,
        false_alarm_probability: float = 0.0,
        delay: int = 0,
    ) -> None:
        for name, value in (
            ("miss_probability", miss_probability),
            ("false_alarm_probability", false_alarm_probability),
        ):
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise TypeError(f"{name}={value!r} must be a number in [0, 1]")
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name}={value!r} must be in [0, 1]")
        if isinstance(delay, bool) or not isinstance(delay, (int, np.integer)):
            raise TypeError(f"delay={delay!r} must be an int >= 0")
        if delay < 0:
            raise ValueError(f"delay={delay!r} must be >= 0")
        self.miss_probability = float(miss_probability)
        self.false_alarm_probability = float(false_alarm_probability)
        self.delay = int(delay)

    def initial_memory(self) -> NoisyOracleMemory:
        """Nothing pending."""
        return NoisyOracleMemory()

    def told_changes(self, memory: NoisyOracleMemory) -> dict[int, int]:
        """Each parameter it has reported changed, with the transition of its latest report.

        A planner at ``detailed`` gets those parameters at their values of those transitions and
        θ_0 elsewhere: never a change it missed or has not reported yet.
        """
        return memory.told

    def notify(
        self,
        observation: dict[str, Any] | None,
        truth: Sequence[float] | None,
        memory: NoisyOracleMemory,
        rng: np.random.Generator,
    ) -> tuple[Flags, Sizes]:
        """Report due changes; maybe miss the new one; maybe raise a false alarm."""
        if truth is None:
            raise RuntimeError("NoisyOracleMonitor.notify needs the true change sizes (truth=None)")
        count = len(truth)
        if not has_transition(observation):
            return silence(count)
        assert observation is not None
        transition = int(observation["relative_time"][0]) - 1
        miss_draw, false_draw = rng.random(2)
        changed = any(size > 0.0 for size in truth)
        if changed and miss_draw >= self.miss_probability:
            report = (transition + self.delay, transition, tuple(float(s) for s in truth))
            memory.pending.append(report)
        due = [entry for entry in memory.pending if entry[0] <= transition]
        memory.pending = [entry for entry in memory.pending if entry[0] > transition]
        if due:
            for _, at, reported in due:
                for index, size in enumerate(reported):
                    if size > 0.0 and at > memory.told.get(index, -1):
                        memory.told[index] = at
            sizes = tuple(math.fsum(column) for column in zip(*(s for *_, s in due), strict=True))
            memory.alarms.append(transition)
            return tuple(int(s > 0.0) for s in sizes), sizes
        if not changed and false_draw < self.false_alarm_probability:
            flagged = int(false_draw / self.false_alarm_probability * count) % count
            memory.alarms.append(transition)
            return tuple(int(i == flagged) for i in range(count)), silence(count)[1]
        return silence(count)

    def __repr__(self) -> str:
        return (
            f"NoisyOracleMonitor(miss_probability={self.miss_probability}, "
            f"false_alarm_probability={self.false_alarm_probability}, delay={self.delay})"
        )
