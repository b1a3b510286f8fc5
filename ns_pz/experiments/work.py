"""A run's work: the networks it trains, its trials, and which trials wait for which network.

Every network a run needs is known from its spec before the first trial. The backends start the
missing ones first, each in a worker of its own, and start a trial as soon as the networks its
agent needs are in the cache, while the others still train; a trial needing none starts at once.
Short trials go to a worker in batches (:class:`Batcher`), so the cost of handing one over does
not outweigh the trial.
"""

from __future__ import annotations

import sys
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence, Set
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.learning.artefacts import (
    ArtefactRequest,
    artefact_path,
    exists,
    load,
    load_or_train,
    read_manifest,
    save,
)
from ns_pz.agents.learning.ddqn import warm_up as warm_up_ddqn
from ns_pz.agents.learning.trained import Needed
from ns_pz.agents.search.compiled import warm_up
from ns_pz.experiments.progress import Progress
from ns_pz.experiments.spec import ExperimentSpec
from ns_pz.experiments.trials import Trial, error_row, run_trial


@dataclass(frozen=True)
class Training:
    """The networks a run's trials need, and which of them the run has to train.

    Attributes:
        networks: Every distinct network needed, by key (cached ones too: a Ray node that
            lacks one is sent it).
        missing: Keys of those not in the cache when the run started: the run trains them.
        requires: Agent label → keys of the networks its trials need (absent: none).
        shown: Each training draws plain progress lines on its worker's stderr.
    """

    networks: Mapping[str, Needed] = field(default_factory=dict)
    missing: tuple[str, ...] = ()
    requires: Mapping[str, frozenset[str]] = field(default_factory=dict)
    shown: bool = False

    def waits_for(self, trial: Trial) -> frozenset[str]:
        """Keys of the networks ``trial`` needs."""
        return self.requires.get(trial.agent.label, frozenset())


def plan_training(spec: ExperimentSpec, trials: Sequence[Trial], shown: bool = False) -> Training:
    """The networks ``trials`` need; those not cached now are to be trained, largest first.

    Largest first (by steps or episodes of training) so the longest training starts at once
    and the shorter ones fill the other workers. ``shown``: see :attr:`Training.shown`.
    """
    networks: dict[str, Needed] = {}
    requires: dict[str, set[str]] = {}
    seen: set[str] = set()
    for trial in trials:
        entry = agent_entry(trial.agent.name)
        if entry.artefacts is None or trial.agent.label in seen:
            continue
        seen.add(trial.agent.label)  # every cell of a spec shares θ_0 and the family
        for need in entry.artefacts(spec.make_env(trial.cell), trial.agent.hyper):
            networks.setdefault(need.request.key, need)
            requires.setdefault(trial.agent.label, set()).add(need.request.key)
    missing = [key for key, need in networks.items() if not exists(need.request)]
    missing.sort(key=lambda key: -networks[key].work[0])
    frozen = {label: frozenset(keys) for label, keys in requires.items()}
    return Training(networks, tuple(missing), frozen, shown)


@dataclass(frozen=True)
class Trained:
    """How getting one network ended.

    Attributes:
        key: The network's artefact key.
        label: What it is (learner, family, θ_0, budget).
        seconds: Seconds spent (training, or waiting for another process that trained it).
        trained: Whether this call trained it (False: it was in the cache by then).
        error: Why training failed (empty: it did not).
    """

    key: str
    label: str
    seconds: float
    trained: bool
    error: str = ""


def train_network(need: Needed, shown: bool = False) -> Trained:
    """Train ``need`` here (NumPy, one thread), unless it is cached; never raises.

    Runs in a worker process. ``shown``: draw plain progress lines on this process's stderr.
    The key's file lock makes concurrent runs sharing the cache train it once.
    """
    start = time.perf_counter()
    try:
        train = need.train
        if shown:
            train = _drawn(need)
        _, trained = load_or_train(need.request, train)
    except KeyboardInterrupt:
        raise
    except BaseException as error:  # noqa: BLE001 - recorded: its trials become error rows
        message = "".join(traceback.format_exception_only(error)).strip()
        return Trained(need.request.key, need.label, time.perf_counter() - start, False, message)
    return Trained(need.request.key, need.label, time.perf_counter() - start, trained)


def _drawn(need: Needed) -> Callable[[], Any]:
    """``need.train`` drawing plain progress lines (several workers share one stderr)."""

    def train() -> Any:
        total, unit = need.work
        bar = Progress(total, 0, f"training {need.label}", sys.stderr, unit=unit, in_place=False)

        def advance(done: int, total: int) -> bool:
            bar.advance(to=done)
            return False

        try:
            return need.train(advance)
        finally:
            bar.close()

    return train


def warm_up_worker() -> None:
    """A fresh worker's head start, before its first job: every agent's code, and numba.

    Importing this module imports the agents; numba starts in
    :func:`~ns_pz.agents.search.compiled.warm_up`, and Double DQN's compiled step loads in
    :func:`~ns_pz.agents.learning.ddqn.warm_up`. A worker started with
    :meth:`~ns_pz.experiments.backends.LocalBackend.start` does this while the runner still
    loads the spec, so the first network's training starts at once.
    """
    warm_up()
    warm_up_ddqn()


def run_batch(spec: ExperimentSpec, trials: Sequence[Trial]) -> list[dict[str, Any]]:
    """Play ``trials`` one after the other here; their rows, in order."""
    _one_thread_if_loaded()
    return [run_trial(spec, trial) for trial in trials]


def _one_thread_if_loaded() -> None:
    """An agent that uses torch while it acts (one of the user's) keeps to one thread too."""
    torch = sys.modules.get("torch")
    if torch is not None and torch.get_num_threads() != 1:
        torch.set_num_threads(1)


class Batcher:
    """Sizes batches of one agent's trials to about ``target`` seconds of work each.

    An agent's first batch is one trial; later ones follow the mean time of its trials so far,
    between 1 and ``most`` trials. A batch of ``target`` seconds is long enough that handing it
    to a worker costs little, and short enough that the last batches end close together.
    """

    def __init__(self, target: float = 0.25, most: int = 64) -> None:
        if not target > 0:
            raise ValueError(f"target={target!r} must be > 0 seconds")
        if isinstance(most, bool) or not isinstance(most, int) or most < 1:
            raise ValueError(f"most={most!r} must be an integer >= 1")
        self.target, self.most = target, most
        self._time: dict[str, tuple[float, int]] = {}

    def record(self, label: str, seconds: float) -> None:
        """One trial of agent ``label`` took ``seconds``."""
        total, count = self._time.get(label, (0.0, 0))
        self._time[label] = (total + seconds, count + 1)

    def mean(self, label: str) -> float | None:
        """Mean seconds of agent ``label``'s trials so far (``None``: none timed yet)."""
        total, count = self._time.get(label, (0.0, 0))
        return total / count if count else None

    def size(self, label: str) -> int:
        """How many trials of agent ``label`` the next batch holds."""
        total, count = self._time.get(label, (0.0, 0))
        if count == 0:
            return 1
        mean = total / count
        return max(1, min(self.most, int(self.target / max(mean, 1e-6))))

    def take(self, ready: deque[Trial]) -> list[Trial]:
        """Pop the next batch off ``ready``: its first trial and those after it of that agent."""
        label = ready[0].agent.label
        batch = [ready.popleft()]
        limit = self.size(label)
        while ready and len(batch) < limit and ready[0].agent.label == label:
            batch.append(ready.popleft())
        return batch


@dataclass(frozen=True)
class Job:
    """One piece of work for a worker: train one network, or play a batch of trials."""

    need: Needed | None = None
    trials: tuple[Trial, ...] = ()


class Schedule:
    """What a worker should do next.

    In this order: a trial to play again on its own (its batch was on a worker that died), a
    missing network, the first trial of an agent × cell not yet started (so every agent and
    cell has a time early: :class:`~ns_pz.experiments.projection.Forecast`), then a batch of
    ready trials: of an agent the worker has played before if it can (it has paid that agent's
    first-use cost: imports, compiled code, torch), else of the agent with the most work left
    per worker that has played it. Trials wait until the networks they need are trained.

    Args:
        spec: The experiment (for the error rows of trials whose network failed).
        trials: The trials to run.
        training: Their networks (``None``: none is trained first; an agent that needs a
            missing one trains it in its own trial, under the key's lock).
        batcher: Sizes trial batches (default: :class:`Batcher`).
    """

    def __init__(
        self,
        spec: ExperimentSpec,
        trials: Iterable[Trial],
        training: Training | None = None,
        batcher: Batcher | None = None,
    ) -> None:
        self.spec = spec
        self.training = training or Training()
        self.batcher = batcher or Batcher()
        self.to_train = deque(self.training.networks[key] for key in self.training.missing)
        self.training_now: set[str] = set(self.training.missing)
        self.alone: deque[Trial] = deque()
        self.samples: list[Trial] = []
        self.ready: dict[str, deque[Trial]] = {}
        self.blocked: dict[str, list[Trial]] = {}
        self._sampled: set[tuple[int, str, str]] = set()
        for trial in trials:
            self._place(trial)

    def _place(self, trial: Trial) -> None:
        waiting = self.training.waits_for(trial) & self.training_now
        if waiting:
            self.blocked.setdefault(trial.agent.label, []).append(trial)
            return
        group = (trial.cell.index, trial.cell.notification, trial.agent.label)
        if group not in self._sampled:
            self._sampled.add(group)
            self.samples.append(trial)
        else:
            self.ready.setdefault(trial.agent.label, deque()).append(trial)

    def next_job(
        self, warm: Set[str] = frozenset(), warm_counts: Mapping[str, int] | None = None
    ) -> Job | None:
        """The next job for a worker, or ``None`` (all started, or the rest wait).

        Args:
            warm: Agent labels the worker has played.
            warm_counts: Label → how many workers have played it.
        """
        if self.alone:
            return Job(trials=(self.alone.popleft(),))
        if self.to_train:
            return Job(need=self.to_train.popleft())
        if self.samples:
            index = next((i for i, t in enumerate(self.samples) if t.agent.label in warm), 0)
            return Job(trials=(self.samples.pop(index),))
        labels = [label for label, queue in self.ready.items() if queue]
        if not labels:
            return None
        mine = [label for label in labels if label in warm]
        if mine:
            label = mine[0]
        else:
            counts = warm_counts or {}
            label = max(labels, key=lambda name: self._work(name) / (1 + counts.get(name, 0)))
        return Job(trials=tuple(self.batcher.take(self.ready[label])))

    def _work(self, label: str) -> float:
        """Seconds of ready work of agent ``label`` (a trial counts 1 s until one is timed)."""
        mean = self.batcher.mean(label)
        return len(self.ready[label]) * (1.0 if mean is None else mean)

    def finished(self, trial: Trial, row: Mapping[str, Any]) -> None:
        """Record a trial's row (its time sizes the agent's later batches)."""
        if row.get("wall_time") is not None:
            self.batcher.record(trial.agent.label, float(row["wall_time"]))

    def trained(self, result: Trained) -> list[tuple[Trial, dict[str, Any]]]:
        """A network is ready (or failed): release its trials.

        Returns:
            Error rows of the trials that needed it, if its training failed.
        """
        self.training_now.discard(result.key)
        failed: list[tuple[Trial, dict[str, Any]]] = []
        for label in list(self.blocked):
            if result.key not in self.training.requires.get(label, ()):
                continue
            trials = self.blocked.pop(label)
            if result.error:
                message = f"its network {result.label} could not be trained: {result.error}"
                failed.extend((trial, error_row(self.spec, trial, message)) for trial in trials)
                continue
            for trial in trials:
                self._place(trial)
        return failed

    def retry_alone(self, trials: Iterable[Trial]) -> None:
        """Play each of ``trials`` again, one per job, before anything else."""
        self.alone.extend(trials)

    @property
    def done(self) -> bool:
        """Nothing left to start."""
        queued = self.alone or self.to_train or self.samples or self.blocked
        return not (queued or any(self.ready.values()))


# -- networks sent to machines that lack them (Ray) --------------------------------------------
Payload = tuple[ArtefactRequest, dict[str, np.ndarray], dict[str, Any]]
"""A network as data: its request, weights and manifest info."""


def payload(request: ArtefactRequest, root: Path | None = None) -> Payload:
    """The cached network of ``request`` as data, to send to a machine that lacks it."""
    info = read_manifest(artefact_path(request, root)).get("info", {})
    return request, load(request, root), dict(info)


def install(networks: Sequence[Payload], root: Path | None = None) -> None:
    """Put each network in this machine's cache unless it is there already."""
    for network in networks:
        if not exists(network[0], root):
            save(*network, root=root)


def train_and_ship(need: Needed) -> tuple[Trained, Payload | str]:
    """:func:`train_network`, then the network as data (or, if training failed, why)."""
    result = train_network(need)
    if result.error:
        return result, f"its network {result.label} could not be trained: {result.error}"
    return result, payload(need.request)
