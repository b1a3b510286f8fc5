"""How long a run takes on ``N`` workers, from the time of its networks and of its trials.

:func:`project` plays the runner's schedule (:mod:`ns_pz.experiments.work`) on paper: the
networks to train start first, largest first, one per worker; a trial starts on the first free
worker once the networks it needs are ready, trials needing none at once. Every worker pays a
start-up cost first (starting a process and importing). Nothing here depends on the machine it
runs on: project for 16 workers on a laptop, from times measured there.
"""

from __future__ import annotations

import heapq
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

#: Trials are played in chunks of at most this many units, so a run of a million trials is
#: projected in a fraction of a second.
_MOST_UNITS = 100_000


@dataclass(frozen=True)
class GroupTime:
    """Trials that cost alike: one agent in one cell.

    Attributes:
        seconds: Seconds per trial.
        trials: How many.
        needs: Keys of the networks they wait for.
    """

    seconds: float
    trials: int
    needs: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Projection:
    """A run's projected time on ``workers`` workers.

    Attributes:
        workers: Worker processes.
        networks: Networks trained.
        training_seconds: Their training time, summed (each trains on one core).
        networks_ready: Seconds from the start until the last of them is ready.
        trials: Trials played.
        trial_seconds: Their time, summed.
        wall: Seconds from the start until the last trial ends.
    """

    workers: int
    networks: int
    training_seconds: float
    networks_ready: float
    trials: int
    trial_seconds: float
    wall: float

    def text(self) -> str:
        """One line: training and trials apart, then the wall time."""
        training = "no network to train"
        if self.networks:
            training = (
                f"training {self.networks} network(s), {_duration(self.training_seconds)} of "
                f"work, all ready after {_duration(self.networks_ready)}"
            )
        return (
            f"{training}; {self.trials:,} trials, {_duration(self.trial_seconds)} of work; "
            f"wall {_duration(self.wall)}"
        )


def project(
    networks: Sequence[tuple[str, float]],
    groups: Sequence[GroupTime],
    workers: int,
    startup: float = 0.0,
) -> Projection:
    """The run's time on ``workers`` workers.

    Args:
        networks: ``(key, seconds)`` of each network to train (cached ones are not listed).
        groups: The trials.
        workers: Worker processes.
        startup: Seconds each worker takes before its first job.

    Raises:
        ValueError: ``workers`` < 1 or ``startup`` < 0.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers={workers!r} must be an integer >= 1")
    if not startup >= 0:
        raise ValueError(f"startup={startup!r} must be >= 0 seconds")
    free = [startup] * workers  # when each worker is next free (a heap)
    ready: dict[str, float] = {}
    for key, seconds in sorted(networks, key=lambda network: -network[1]):
        start = heapq.heappop(free)
        ready[key] = start + seconds
        heapq.heappush(free, ready[key])
    total = sum(group.trials for group in groups)
    chunk = max(1, math.ceil(total / _MOST_UNITS))
    units = []  # (when its networks are ready, order, seconds)
    for order, group in enumerate(groups):
        at = max((ready.get(key, 0.0) for key in group.needs), default=0.0)
        left = group.trials
        while left > 0:
            size = min(chunk, left)
            units.append((at, order, group.seconds * size))
            left -= size
    units.sort(key=lambda unit: (unit[0], unit[1]))
    end = max(ready.values(), default=startup)
    for at, _, seconds in units:
        start = max(heapq.heappop(free), at)
        heapq.heappush(free, start + seconds)
        end = max(end, start + seconds)
    return Projection(
        workers,
        len(networks),
        sum(seconds for _, seconds in networks),
        max(ready.values(), default=0.0),
        total,
        sum(group.seconds * group.trials for group in groups),
        end,
    )


def combined(parts: Sequence[Projection]) -> Projection:
    """Runs made one after the other (specs): counts and times added up.

    ``networks_ready`` adds up too: each run's networks are ready that long after its start.

    Raises:
        ValueError: No parts.
    """
    if not parts:
        raise ValueError("parts=[] must hold at least one projection")
    return Projection(
        parts[0].workers,
        sum(p.networks for p in parts),
        sum(p.training_seconds for p in parts),
        sum(p.networks_ready for p in parts),
        sum(p.trials for p in parts),
        sum(p.trial_seconds for p in parts),
        sum(p.wall for p in parts),
    )


def _duration(seconds: float) -> str:
    """``"4.2 s"``, ``"42 s"``, ``"12.5 min"`` or ``"3.20 h"``."""
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.2f} h"


class Forecast:
    """The rest of a run, projected once every agent × cell has finished one trial.

    The runner plays each group's first trial first (:func:`samples_first`), so the projection
    comes early in the run, from the wall times of the trials played so far (this machine, its
    present load), and needs no estimate beforehand.

    Args:
        trials: The trials the run plays.
        workers: Its worker processes.
        long: Say nothing if the rest takes less than this many seconds.
    """

    def __init__(self, trials: Sequence[Any], workers: int, long: float = 60.0) -> None:
        self.left = Counter(_group(trial) for trial in trials)
        self.times: dict[tuple[int, str, str], list[float]] = {}
        self.workers, self.long = workers, long
        self.done = False

    def add(self, trial: Any, row: Mapping[str, Any]) -> str | None:
        """Count ``trial``'s row; the projection once every group has a time, else ``None``."""
        group = _group(trial)
        self.left[group] -= 1
        if row.get("wall_time") is not None:
            self.times.setdefault(group, []).append(float(row["wall_time"]))
        if self.done or any(n > 0 and g not in self.times for g, n in self.left.items()):
            return None
        self.done = True
        groups = [
            GroupTime(sum(self.times[g]) / len(self.times[g]), n)
            for g, n in self.left.items()
            if n > 0
        ]
        rest = project([], groups, self.workers)
        if rest.wall < self.long:
            return None
        return (
            f"projected, from the trials so far: the other {rest.trials:,} trials take "
            f"{_duration(rest.trial_seconds)} of work; on {self.workers} worker(s) at this "
            f"machine's present load, wall {_duration(rest.wall)} more"
        )


def samples_first(trials: Sequence[Any]) -> list[Any]:
    """``trials`` with the first of each agent × cell moved to the front (order kept otherwise)."""
    seen: set[tuple[int, str, str]] = set()
    first: list[Any] = []
    rest: list[Any] = []
    for trial in trials:
        group = _group(trial)
        (rest if group in seen else first).append(trial)
        seen.add(group)
    return first + rest


def _group(trial: Any) -> tuple[int, str, str]:
    return trial.cell.index, trial.cell.notification, trial.agent.label
