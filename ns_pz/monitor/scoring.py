"""Scoring change detection: delays, false alarms, misses, and per-step rewards for a monitor.

Times are transition indices. A change at ``τ`` (:attr:`~ns_pz.process.GroundTruth.change_times`)
applies to transition ``τ``. An alarm at ``α`` is a notification with at least one flag raised
once transition ``α`` has been observed: the agent gets it in the observation whose
``relative_time`` is ``α + 1``. The exact oracle therefore alarms at ``α = τ``: delay 0.

When an alarm is a detection, and when a false alarm:

* Change ``i`` owns the interval ``[τ_i, τ_{i+1})`` (up to the episode's end for the last
  change). The first alarm inside that interval, and no later than ``τ_i + max_delay`` when a
  ``max_delay`` is given, detects change ``i``; its delay is ``α - τ_i``.
* Every other alarm is a false alarm: one before the first change, a second alarm for the same
  change, one after ``max_delay`` has run out. An alarm at reset, before any transition
  (``α = -1``: the observation at ``relative_time`` 0), is one too (as for
  :func:`detection_reward`).
* A change with no detecting alarm is missed (it may simply come too close to the episode's end).
* False alarms per 1,000 steps = ``1000 * false alarms / steps``, ``steps`` being the episode's
  transitions.

False alarms come in two kinds, reported apart. **Pre-change** false alarms are raised before
the first change (or in an episode without one): what the change-detection literature calls false
alarms, whose rate in an unchanging world is ``1 / ARL₀`` (ARL₀: the average run length to a
false alarm). Their rate is per 1,000 *pre-change* steps (the transitions before the first
change, or all of them). **Post-change** false alarms are the rest: a detector re-alarming after
it has detected a change (while it learns the new θ), or an alarm later than ``max_delay``. With
a change at transition 1, as in the shipped specs, nearly every false alarm is post-change.

The delay convention: ``α - τ``, the number of transitions observed after the change's first
one before the alarm is raised (an alarm on the change's first transition: 0). Lorden's
detection delay counts the observations from the change's first one up to and including the
alarm's, ``α - τ + 1``, and takes the worst case over change times and pre-change histories;
the figures here are the empirical distribution over runs (mean, median and 90th percentile,
which differ a lot: delays are heavy-tailed).
"""

from __future__ import annotations

import copy
import math
import numbers
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

if TYPE_CHECKING:
    from ns_pz.process import NSProcess


@dataclass(frozen=True)
class EpisodeDetection:
    """How one episode's alarms score against its true changes.

    Attributes:
        steps: Transitions in the episode.
        changes: True changes.
        delays: Delay of each detected change, in change order.
        missed: Changes never detected.
        false_alarms: Alarms that detected nothing.
        pre_change_steps: Transitions before the first change (all of them without a change).
        pre_change_false_alarms: False alarms raised before the first change.
    """

    steps: int
    changes: int
    delays: tuple[int, ...]
    missed: int
    false_alarms: int
    pre_change_steps: int = 0
    pre_change_false_alarms: int = 0

    @property
    def post_change_false_alarms(self) -> int:
        """False alarms after the first change (re-alarms, alarms past ``max_delay``)."""
        return self.false_alarms - self.pre_change_false_alarms

    @property
    def false_alarms_per_1000(self) -> float:
        """False alarms per 1,000 transitions (0 for an empty episode)."""
        return 1000.0 * self.false_alarms / self.steps if self.steps else 0.0


@dataclass(frozen=True)
class DetectionSummary:
    """Detection scores aggregated over episodes.

    Attributes:
        episodes: Episodes scored.
        steps: Transitions over all episodes.
        changes: True changes over all episodes.
        detected: Changes detected.
        missed: Changes missed.
        false_alarms: False alarms over all episodes.
        mean_delay: Mean delay over detected changes (NaN if none was detected).
        false_alarms_per_1000: ``1000 * false_alarms / steps`` over all episodes pooled.
        per_episode: Each episode's score, in input order.
        median_delay: Median delay over detected changes (NaN if none).
        p90_delay: 90th percentile of the delays (linear interpolation; NaN if none).
        pre_change_steps: Transitions before each episode's first change, summed.
        pre_change_false_alarms: False alarms before each episode's first change, summed.
        post_change_false_alarms: The other false alarms (re-alarms after a detection, alarms
            past ``max_delay``).
        pre_change_false_alarms_per_1000: ``1000 * pre_change_false_alarms /
            pre_change_steps`` (NaN without pre-change steps): ``1000 / ARL₀`` in an
            unchanging world.
    """

    episodes: int
    steps: int
    changes: int
    detected: int
    missed: int
    false_alarms: int
    mean_delay: float
    false_alarms_per_1000: float
    per_episode: tuple[EpisodeDetection, ...]
    median_delay: float = math.nan
    p90_delay: float = math.nan
    pre_change_steps: int = 0
    pre_change_false_alarms: int = 0
    post_change_false_alarms: int = 0
    pre_change_false_alarms_per_1000: float = math.nan


def score_episode(
    change_times: Sequence[int],
    alarm_times: Sequence[int],
    steps: int,
    max_delay: int | None = None,
) -> EpisodeDetection:
    """Score one episode (see the module doc for the rules).

    Args:
        change_times: Transition index of each true change, increasing.
        alarm_times: Transition index of each alarm, increasing (``-1``: at reset).
        steps: Transitions in the episode (changes are at ``0 .. steps - 1``, alarms at
            ``-1 .. steps - 1``).
        max_delay: Longest delay that still counts as a detection; ``None``: any.

    Raises:
        ValueError: Times not strictly increasing, outside their ranges, a negative
            ``steps`` or ``max_delay``.
    """
    if isinstance(steps, bool) or not isinstance(steps, numbers.Integral) or steps < 0:
        raise ValueError(f"steps={steps!r} must be an int >= 0")
    steps = int(steps)
    if max_delay is not None and (
        isinstance(max_delay, bool) or not isinstance(max_delay, numbers.Integral) or max_delay < 0
    ):
        raise ValueError(f"max_delay={max_delay!r} must be an int >= 0 or None")
    changes = _check_times("change_times", change_times, steps)
    alarms = _check_times("alarm_times", alarm_times, steps, first=-1)
    delays = []
    detecting = 0
    for i, start in enumerate(changes):
        end = changes[i + 1] if i + 1 < len(changes) else steps
        if max_delay is not None:
            end = min(end, start + max_delay + 1)
        inside = [a for a in alarms if start <= a < end]
        if inside:
            delays.append(inside[0] - start)
            detecting += 1
    quiet_until = changes[0] if changes else steps
    return EpisodeDetection(
        steps=steps,
        changes=len(changes),
        delays=tuple(delays),
        missed=len(changes) - len(delays),
        false_alarms=len(alarms) - detecting,
        pre_change_steps=quiet_until,
        pre_change_false_alarms=sum(1 for a in alarms if a < quiet_until),
    )


def detection_metrics(
    episodes: Iterable[tuple[Sequence[int], Sequence[int], int]],
    max_delay: int | None = None,
) -> DetectionSummary:
    """Detection delay, false alarms per 1,000 steps and missed changes, per episode and pooled.

    Args:
        episodes: One ``(change_times, alarm_times, steps)`` per episode: the true change times
            (``env.ground_truth().change_times``), the alarm times (transition ``t - 1`` for
            each observation at ``relative_time == t`` that has a flag raised) and the number
            of transitions.
        max_delay: Longest delay that still counts as a detection; ``None``: any.

    Returns:
        The pooled summary, with each episode's :class:`EpisodeDetection` in ``per_episode``.

    Raises:
        ValueError: See :func:`score_episode`.
    """
    scored = tuple(
        score_episode(*_episode(i, episode), max_delay) for i, episode in enumerate(episodes)
    )
    delays = [d for e in scored for d in e.delays]
    steps = sum(e.steps for e in scored)
    false_alarms = sum(e.false_alarms for e in scored)
    quiet_steps = sum(e.pre_change_steps for e in scored)
    quiet_alarms = sum(e.pre_change_false_alarms for e in scored)
    median, p90 = (
        (float(np.median(delays)), float(np.percentile(delays, 90))) if delays else (math.nan,) * 2
    )
    return DetectionSummary(
        episodes=len(scored),
        steps=steps,
        changes=sum(e.changes for e in scored),
        detected=len(delays),
        missed=sum(e.missed for e in scored),
        false_alarms=false_alarms,
        mean_delay=math.fsum(delays) / len(delays) if delays else math.nan,
        false_alarms_per_1000=1000.0 * false_alarms / steps if steps else 0.0,
        per_episode=scored,
        median_delay=median,
        p90_delay=p90,
        pre_change_steps=quiet_steps,
        pre_change_false_alarms=quiet_alarms,
        post_change_false_alarms=false_alarms - quiet_alarms,
        pre_change_false_alarms_per_1000=(
            1000.0 * quiet_alarms / quiet_steps if quiet_steps else math.nan
        ),
    )


def detection_reward(
    undetected_change: bool, alarm: bool, false_alarm_cost: float = 10.0
) -> tuple[float, bool]:
    """The monitor's reward for one transition, and whether a change is still undetected after it.

    A dense per-step score for a learnable monitor, paid at each transition ``t`` once the
    monitor has (or has not) raised an alarm about it:

    * ``-1`` while a true change is undetected and the monitor stays silent: summed, each
      detected change costs its delay, and a missed one the transitions it stayed undetected;
    * ``-false_alarm_cost`` for an alarm when no change is undetected (a false alarm);
    * ``0`` otherwise (silence with nothing to report, or the alarm that detects a change).

    Over an episode the rewards sum to ``-(sum of delays + undetected time of missed changes)
    - false_alarm_cost * false alarms``, the rules of :func:`score_episode` without
    ``max_delay``. Wiring it (``pending`` starts ``False`` at reset)::

        if t in change_times:           # a true change at transition t
            pending = True
        reward, pending = detection_reward(pending, alarm_about_t, false_alarm_cost)

    Args:
        undetected_change: Whether a true change at or before this transition has not been
            detected yet (including one at this very transition).
        alarm: Whether the monitor raised a flag about this transition.
        false_alarm_cost: ``λ``: how many steps of delay one false alarm is worth.

    Returns:
        ``(reward, undetected_change after this transition)``.

    Raises:
        TypeError: ``undetected_change`` or ``alarm`` is not a bool (NumPy's too).
        ValueError: A negative or non-finite ``false_alarm_cost``.
    """
    for name, value in (("undetected_change", undetected_change), ("alarm", alarm)):
        if not isinstance(value, (bool, np.bool_)):
            raise TypeError(f"{name}={value!r} must be a bool")
    if isinstance(false_alarm_cost, bool) or not (
        isinstance(false_alarm_cost, numbers.Real) and 0.0 <= false_alarm_cost < math.inf
    ):
        raise ValueError(f"false_alarm_cost={false_alarm_cost!r} must be a finite number >= 0")
    if alarm:
        return (0.0, False) if undetected_change else (-float(false_alarm_cost), False)
    return (-1.0, True) if undetected_change else (0.0, False)


MonitorRewardFn = Callable[["NSProcess", tuple], float]
"""``fn(process, flags) -> reward``: what the monitor earns for the flags it just sent."""


class DetectionReward:
    """The monitor's detection score as a per-turn reward (:func:`ns_pz.monitor.detection_reward`).

    At the monitor's turn of step ``t`` its flags speak about transition ``t - 1``: the reward is
    -1 per step a true change stays undetected, ``-false_alarm_cost`` per alarm with no change
    to detect (an alarm at ``t = 0``, before any transition, is one), 0 otherwise; summed over an
    episode, ``-(delays + undetected time of missed changes) - false_alarm_cost × false
    alarms``. Call :meth:`reset` at every episode start.

    Args:
        false_alarm_cost: How many steps of delay one false alarm is worth (``λ``), >= 0.
    """

    def __init__(self, false_alarm_cost: float = 10.0) -> None:
        detection_reward(False, False, false_alarm_cost)  # validates the cost
        self.false_alarm_cost = float(false_alarm_cost)
        self._pending = False

    def reset(self) -> None:
        """Start an episode: no change pending."""
        self._pending = False

    def __call__(self, process: NSProcess, flags: tuple) -> float:
        """The reward for ``flags`` sent at the monitor's turn of the current step."""
        about = process.t - 1
        if about >= 0 and about in process.change_times:
            self._pending = True
        reward, self._pending = detection_reward(self._pending, any(flags), self.false_alarm_cost)
        return reward


def monitor_reward_of(monitor_reward: Any) -> MonitorRewardFn | None:
    """What a learning monitor earns, from the ``monitor_reward=`` argument of a game or seat.

    ``"detection"`` becomes a fresh :class:`DetectionReward`; a reward with episode state (a
    ``reset`` method) is deep-copied, so each environment keeps its own; ``None`` stays
    ``None``.

    Raises:
        ValueError: Anything else than ``None``, ``"detection"`` or a callable.
    """
    if monitor_reward is None:
        return None
    if isinstance(monitor_reward, str) and monitor_reward == "detection":
        return DetectionReward()
    if not callable(monitor_reward):
        raise ValueError(
            f"monitor_reward={monitor_reward!r}; allowed: None, 'detection' or a function "
            "fn(process, flags) -> float"
        )
    if callable(getattr(monitor_reward, "reset", None)):
        return copy.deepcopy(monitor_reward)  # its episode state is ours
    return cast(MonitorRewardFn, monitor_reward)


def monitor_reward_value(
    monitor_reward: MonitorRewardFn, process: NSProcess, flags: tuple
) -> float:
    """Call a learning monitor's reward function and check what it gives.

    Returns:
        The reward as a float.

    Raises:
        TypeError: It returned something that is not a real number (a string, ``None``, a
            complex number, an array).
        ValueError: It returned NaN or an infinity, which would reach the learner unnoticed.
    """
    value = monitor_reward(process, flags)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(
            f"monitor_reward={monitor_reward!r} returned {value!r} "
            f"({type(value).__name__}); it must return a finite real number"
        )
    reward = float(value)
    if not math.isfinite(reward):
        raise ValueError(
            f"monitor_reward={monitor_reward!r} returned {value!r} at t={process.t}; it must "
            "return a finite real number"
        )
    return reward


def _episode(index: int, episode: Any) -> tuple[Any, Any, Any]:
    """``(changes, alarms, steps)`` of the ``index``-th episode given to detection_metrics."""
    if isinstance(episode, (str, bytes)) or not isinstance(episode, Sequence) or len(episode) != 3:
        raise ValueError(
            f"episodes[{index}]={episode!r} must be (change times, alarm times, steps)"
        )
    return episode[0], episode[1], episode[2]


def _check_times(name: str, times: Sequence[int], steps: int, first: int = 0) -> list[int]:
    if isinstance(times, (str, bytes)) or not isinstance(times, (Sequence, np.ndarray)):
        raise TypeError(f"{name}={times!r} must be a sequence of transition indices")
    result: list[int] = []
    for value in times:
        if (
            isinstance(value, bool)
            or not isinstance(value, numbers.Real)
            or not math.isfinite(value)
            or int(value) != value
        ):
            raise ValueError(f"{name}={list(times)!r} must hold integers")
        result.append(int(value))
    if any(b <= a for a, b in zip(result, result[1:], strict=False)):
        raise ValueError(f"{name}={list(times)!r} must be strictly increasing")
    if result and (result[0] < first or result[-1] >= steps):
        raise ValueError(f"{name}={list(times)!r} must lie in [{first}, steps) with steps={steps}")
    return result
