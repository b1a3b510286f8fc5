"""``bench estimate``: project a run's time in minutes, from a few training steps and trials.

Nothing is trained to the end and no trial need run to its end:

* **Training.** A network the run would train (one not in the cache) trains for ``probe_seconds``
  only; its remaining steps (DDQN) or episodes (AlphaZero) are projected at the rate measured
  over the later half of the time it trained past its warm-up (DDQN's first gradient steps start
  after ``learning_starts``): AlphaZero's episodes cost more as training goes, since its
  full-batch gradient steps grow with the data gathered, so the rate since its first episode
  projected the full FrozenLake network at 4.0 CPU-s where it trains in 6.6. AlphaZero's
  projection stays a lower bound, most on CartPole, where its self-play episodes lengthen as the
  network learns. The partly trained network is kept, in a temporary cache, as a stand-in: the
  learning agents' trials are timed with it (a decision costs the same with any weights), and
  the user's network cache is never written. A cached network costs the run nothing.
* **Trials.** Every agent × cell plays up to ``samples`` seeds, all of them within
  ``cell_seconds``: an episode still going at the cap is cut, and its time per step projected
  to the spec's horizon (an upper bound: the episode may have ended sooner). Trials of an agent
  playing a stand-in network are projected to the horizon too (an untrained network ends a
  CartPole episode early; a trained one balances to the limit). The cap cuts an episode only
  once it has played :data:`MIN_STEPS` steps (or :data:`OVERRUN` times the cap has passed), and
  the time per step is taken after its first quarter: a cost that comes in bursts (DDQN-WN
  fine-tunes every fourth step on CartPole's continuous change) is averaged over many bursts,
  not read off the one the cap fell in.
* **One-off costs.** What a process pays the first time an agent plays (compiling or loading its
  compiled kernels, which DDQN-WN does at its first fine-tuning, steps into the episode) a
  worker pays once, not per trial. So the first time an agent plays in an environment at a
  notification level in this process, one trial is played untimed first; and the
  temporary cache keeps the user's compiled kernels (:func:`stand_in_cache`). Without both, a
  kernel compiled at the third step of a cut episode was projected to the horizon: a quick
  FrozenLake table read 3.4 h of trials where they take about 50 s.

:func:`plan` says beforehand what this will do and the most it can take.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.evaluation import run_episode
from ns_pz.agents.learning.artefacts import (
    CACHE_ENV_VAR,
    artefact_path,
    exists,
    read_manifest,
    save,
)
from ns_pz.agents.learning.trained import Needed
from ns_pz.experiments.progress import Progress
from ns_pz.experiments.projection import GroupTime, combined, project
from ns_pz.experiments.runner import needed_networks
from ns_pz.experiments.spec import LEVEL_LABELS, ExperimentSpec
from ns_pz.experiments.trials import Trial, expand
from ns_pz.experiments.work import plan_training

CELL_SECONDS = 1.0
"""Default cap on the seconds spent timing one agent in one cell (all its sampled seeds)."""
MIN_STEPS = 32
"""Steps an episode plays before the cap may cut it, unless :data:`OVERRUN` caps pass first.

Measured on full-size DDQN-WN, CartPole continuous change, WN and WD columns (a 0.3-0.8 s
fine-tuning every fourth step, then in torch), on a 2-core machine shared with other jobs: cut at
one second (3 to 14 steps) the time per step came out 0.9 to 10 times that of the whole
episodes; from 23 to 32 steps, past the first quarter, 0.8 to 1.4 times. The horizon (2 500
steps against the 73 to 839 played) keeps the projection an upper bound all the same.
"""
OVERRUN = 5.0
"""A group's timing stops at this many times its cap, whatever :data:`MIN_STEPS` asks."""
PROBE_SECONDS = 5.0
"""Default seconds of training timed per network the run would train."""


@dataclass(frozen=True)
class CellCost:
    """Projected cost of one agent in one cell.

    ``seconds_per_trial`` is wall time, so it grows when other programs share the machine;
    ``cpu_seconds_per_trial`` (this process's CPU time) is what an otherwise idle core takes.
    ``at_horizon``: projected from the time per step to the spec's horizon (an episode cut at
    the cap, or a stand-in network), an upper bound; False: sampled episodes timed whole.
    """

    setting: str
    notification: str
    agent: str
    seconds_per_trial: float
    trials: int
    cpu_seconds_per_trial: float
    at_horizon: bool = False

    @property
    def total_seconds(self) -> float:
        """Projected wall time of all the cell's trials on one core, loaded as now."""
        return self.seconds_per_trial * self.trials

    @property
    def total_cpu_seconds(self) -> float:
        """Projected time of all the cell's trials on one otherwise idle core."""
        return self.cpu_seconds_per_trial * self.trials


@dataclass(frozen=True)
class TrainingCost:
    """One network the run needs and its projected training time.

    Attributes:
        key: The artefact's key (specs with the same θ_0 share it).
        label: What it is (learner, family, θ_0, budget).
        seconds: Projected training seconds (for a cached one: those it recorded).
        cached: In the cache: the run loads it, so it costs the run nothing.
        timed: Steps or episodes actually trained for the projection (0 when cached).
        total: Steps or episodes the full training takes.
        unit: ``"steps"`` or ``"episodes"``.
        cpu_seconds: Projected training seconds on an otherwise idle core, from this process's
            CPU time while it was timed (``seconds`` grows when other programs share the
            machine; this does not). For a cached one: ``seconds``.
    """

    key: str
    label: str
    seconds: float
    cached: bool
    timed: int
    total: int
    unit: str
    cpu_seconds: float = 0.0


@dataclass(frozen=True)
class Plan:
    """What an estimate will do, said before it starts."""

    groups: int
    """Agent × cell groups timed."""
    networks: int
    """Networks the run would train (each timed for ``probe_seconds``)."""
    cached: int
    """Networks already cached (nothing to time)."""
    samples: int
    cell_seconds: float
    probe_seconds: float
    warm_ups: int = 0
    """Groups that first play one trial untimed (an agent's first in this process)."""

    @property
    def most_seconds(self) -> float:
        """The longest the estimate should take (each group's limit can overrun by one step).

        A group stops at its cap once its episode has played :data:`MIN_STEPS` steps, so only
        groups with slow steps come near their limit, :data:`OVERRUN` times the cap.
        """
        timed = (self.groups + self.warm_ups) * self.cell_seconds * OVERRUN
        return timed + self.networks * self.probe_seconds

    def text(self) -> str:
        """One paragraph for the user."""
        return (
            f"estimate: {self.networks} network(s) to train timed for {self.probe_seconds:g} s "
            f"each ({self.cached} cached), then {self.groups} agent x cell group(s), up to "
            f"{self.samples} seed(s) each within {self.cell_seconds:g} s per group, "
            f"{self.warm_ups} of them after an untimed trial (up to "
            f"{OVERRUN:g}x that until an episode has played {MIN_STEPS} steps): at most about "
            f"{self.most_seconds / 60:.1f} min (a limit overruns by at most one step)"
        )


def _check(name: str, value: object, low: float, integer: bool) -> None:
    kinds = (int,) if integer else (int, float)
    if isinstance(value, bool) or not isinstance(value, kinds):
        kind = "an integer" if integer else "a number"
        raise TypeError(f"{name}={value!r} must be {kind} >= {low}")
    if not value >= low:  # NaN fails too
        raise ValueError(f"{name}={value!r} must be >= {low}")


def plan(
    specs: Sequence[ExperimentSpec],
    samples: int = 2,
    cell_seconds: float = CELL_SECONDS,
    probe_seconds: float = PROBE_SECONDS,
) -> Plan:
    """What :func:`estimate_training` and :func:`estimate` will do for ``specs``, and how long.

    Raises:
        TypeError, ValueError: ``samples`` not an integer >= 1, or a number of seconds <= 0.
    """
    _check("samples", samples, 1, integer=True)
    _check("cell_seconds", cell_seconds, 1e-3, integer=False)
    _check("probe_seconds", probe_seconds, 1e-3, integer=False)
    groups = sum(len(_groups(spec)) for spec in specs)
    keys = {
        need.request.key: need for spec in specs for _, need in needed_networks(spec, expand(spec))
    }
    missing = sum(not exists(need.request) for need in keys.values())
    firsts = {_first_play(spec, trials[0]) for spec in specs for trials in _groups(spec).values()}
    warm_ups = len(firsts - _PLAYED)
    return Plan(
        groups, missing, len(keys) - missing, samples, cell_seconds, probe_seconds, warm_ups
    )


@contextlib.contextmanager
def stand_in_cache() -> Iterator[Path]:
    """A temporary artefact cache for the estimate, made the process's cache while it lasts.

    :func:`estimate_training` links the user's cached networks into it and writes the
    partly trained stand-ins there, so the user's network cache is never written. The same
    variable moves numba's cache of ns_pz's compiled kernels, so the user's folder of those
    is linked in as it is (where numba is installed, and the folder can be made): the trials
    load the kernels compiled before, and what they compile is written there for the run.
    """
    previous = os.environ.get(CACHE_ENV_VAR)
    compiled = _compiled_kernels_folder()
    with tempfile.TemporaryDirectory(prefix="ns-pz-estimate-") as folder:
        if compiled is not None:
            try:
                compiled.mkdir(parents=True, exist_ok=True)
                (Path(folder) / "numba").symlink_to(compiled.resolve(), target_is_directory=True)
            except OSError:  # a folder that cannot be made or linked: numba's next locator
                pass  # serves, as it does for a run (the kernels are compiled in the estimate)
        os.environ[CACHE_ENV_VAR] = folder
        try:
            yield Path(folder) / "artefacts"
        finally:
            if previous is None:
                os.environ.pop(CACHE_ENV_VAR, None)
            else:
                os.environ[CACHE_ENV_VAR] = previous


def _compiled_kernels_folder() -> Path | None:
    """The folder numba keeps ns_pz's compiled kernels in now, or None without numba."""
    try:
        from ns_pz.agents.search import numba_cache
    except ImportError:  # no numba: nothing compiled to keep
        return None
    folder = numba_cache.cache_dir()
    if folder is None:  # NUMBA_CACHE_DIR decides
        from numba.core import config

        return Path(config.CACHE_DIR)
    return folder


def estimate_training(
    specs: Sequence[ExperimentSpec],
    stand_ins: Path,
    user_cache: Path,
    probe_seconds: float = PROBE_SECONDS,
    progress: TextIO | None = None,
) -> tuple[list[TrainingCost], set[tuple[str, str]]]:
    """Time a few seconds of every network ``specs`` would train; put a stand-in for each.

    Args:
        specs: The experiments.
        stand_ins: The temporary cache (:func:`stand_in_cache`) the trials will read.
        user_cache: The user's artefact cache (cached networks are linked from it).
        probe_seconds: Seconds of training timed per network (past its warm-up).
        progress: Where to draw each probe's progress line (``None``: none).

    Returns:
        The cost of each distinct network, and the ``(spec name, agent label)`` pairs whose
        agents play a stand-in.
    """
    _check("probe_seconds", probe_seconds, 1e-3, integer=False)
    costs: dict[str, TrainingCost] = {}
    stand_in_agents: set[tuple[str, str]] = set()
    for spec in specs:
        for label, need in needed_networks(spec, expand(spec)):
            key = need.request.key
            if key not in costs:
                costs[key] = _network(need, stand_ins, user_cache, probe_seconds, progress)
            if not costs[key].cached:
                stand_in_agents.add((spec.name, label))
    return list(costs.values()), stand_in_agents


def _network(
    need: Needed, stand_ins: Path, user_cache: Path, probe_seconds: float, progress: TextIO | None
) -> TrainingCost:
    total, unit = need.work
    key = need.request.key
    if exists(need.request, user_cache):
        source = artefact_path(need.request, user_cache)
        target = artefact_path(need.request, stand_ins)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.symlink_to(source.resolve(), target_is_directory=True)
        seconds = float(read_manifest(source).get("info", {}).get("seconds", 0.0))
        return TrainingCost(key, need.label, seconds, True, 0, total, unit, seconds)
    probe = _Probe(probe_seconds, getattr(need.args, "learning_starts", 0))
    bar = None
    if progress is not None:
        bar = Progress(total, 0, f"timing training {need.label}", progress, unit=unit)
    try:
        weights, info = need.train(probe.step if bar is None else probe.drawing(bar))
    finally:
        if bar is not None:
            bar.close()
    save(need.request, weights, {**info, "stand_in": True}, stand_ins)
    wall = probe.projected(total)
    cpu = wall * probe.cpu_share()
    return TrainingCost(key, need.label, wall, False, probe.done, total, unit, cpu)


MARK_SECONDS = 0.01
"""Least time between the probe's records of training progress."""


class _Probe:
    """Stops training after ``seconds``; projects the rest from the late rate after ``warm_up``.

    It stops once ``seconds`` have passed and the rate has been measured past the warm-up for
    at least half of them (or training ended). The rate projected is that of the later half of
    the time measured past the warm-up (work that grows as training goes is not averaged with
    its cheap start).
    """

    def __init__(self, seconds: float, warm_up: int) -> None:
        self.seconds, self.warm_up = seconds, warm_up
        self.start = time.perf_counter()
        self.cpu_start = time.process_time()
        self.done = 0
        self.elapsed = 0.0
        self.cpu = 0.0
        self._mark: tuple[float, int] | None = None  # (elapsed, done) once warmed up
        self._marks: list[tuple[float, int]] = []  # (elapsed, done) past it, 10 ms apart or more

    def step(self, done: int, total: int) -> bool:
        """Record ``done`` units now; True: enough is measured, stop training."""
        self.done, self.elapsed = done, time.perf_counter() - self.start
        self.cpu = time.process_time() - self.cpu_start
        if self._mark is None and done > self.warm_up:
            self._mark = (self.elapsed, done)
        if self._mark is not None and (
            not self._marks or self.elapsed - self._marks[-1][0] >= MARK_SECONDS
        ):
            self._marks.append((self.elapsed, done))
        if self._mark is None or self.elapsed < self.seconds:
            return False
        return self.elapsed - self._mark[0] >= self.seconds / 2

    def drawing(self, bar: Progress) -> Callable[[int, int], bool]:
        """:meth:`step`, also advancing ``bar``."""

        def step(done: int, total: int) -> bool:
            bar.advance(to=done)
            return self.step(done, total)

        return step

    def cpu_share(self) -> float:
        """CPU seconds per wall second while timed (below 1 on a busy machine), at most 1.

        At most 1: training runs on one core in a run's worker, whatever threads it used here.
        """
        return min(1.0, self.cpu / max(self.elapsed, 1e-9)) if self.elapsed > 0 else 1.0

    def projected(self, total: int) -> float:
        """Elapsed time plus the rest at the rate of the later half of the time measured."""
        if self.done >= total:
            return self.elapsed
        rate = self.done / max(self.elapsed, 1e-9)
        if self._mark is not None and self.done > self._mark[1]:
            rate = (self.done - self._mark[1]) / max(self.elapsed - self._mark[0], 1e-9)
            halfway = (self._mark[0] + self.elapsed) / 2
            since = next(m for m in reversed(self._marks) if m[0] <= halfway)
            if self.done > since[1]:
                rate = (self.done - since[1]) / max(self.elapsed - since[0], 1e-9)
            else:  # nothing finished in the later half: at most one unit in all of it
                rate = min(rate, 1.0 / max(self.elapsed - since[0], 1e-9))
        return self.elapsed + (total - self.done) / rate


def _groups(spec: ExperimentSpec) -> dict[tuple[int, str, str], list[Trial]]:
    groups: dict[tuple[int, str, str], list[Trial]] = {}
    for trial in expand(spec):
        key = (trial.cell.index, trial.cell.notification, trial.agent.label)
        groups.setdefault(key, []).append(trial)
    return groups


def estimate(
    spec: ExperimentSpec,
    samples: int = 2,
    progress: TextIO | None = None,
    cell_seconds: float = CELL_SECONDS,
    at_horizon: frozenset[str] | set[str] = frozenset(),
) -> list[CellCost]:
    """Time up to ``samples`` seeds of every agent × cell here, within ``cell_seconds`` each.

    The learning agents' networks must be in the cache (run inside :func:`stand_in_cache` after
    :func:`estimate_training`, or after ``ns-pz train``); a missing one would be trained here.

    Args:
        spec: The experiment.
        samples: Seeds timed per agent and cell.
        progress: Where to draw a progress line over the groups (``None``: none).
        cell_seconds: Cap on the seconds spent on one agent in one cell.
        at_horizon: Agent labels whose trials are projected to the horizon (stand-in networks).

    Raises:
        TypeError, ValueError: ``samples`` or ``cell_seconds`` out of range.
        RuntimeError: A sampled trial failed (its error is in the message).
    """
    _check("samples", samples, 1, integer=True)
    _check("cell_seconds", cell_seconds, 1e-3, integer=False)
    groups = _groups(spec)
    bar = None
    if progress is not None:
        label = f"estimate {spec.name} ({spec.size})"
        bar = Progress(len(groups), 0, label, progress, unit="cells")
    costs = []
    try:
        for trials in groups.values():
            horizon = trials[0].agent.label in at_horizon
            costs.append(_time_group(spec, trials, samples, cell_seconds, horizon))
            if bar is not None:
                bar.advance()
    finally:
        if bar is not None:
            bar.close()
    return costs


_PLAYED: set[tuple[str, str, str]] = set()
"""What has played in this process (:func:`_first_play`'s keys): its one-off costs are paid."""


def _first_play(spec: ExperimentSpec, trial: Trial) -> tuple[str, str, str]:
    """The agent, environment and notification level of ``trial``: what one-off costs follow.

    A kernel is compiled for a family (the environment) and an agent's code; DDQN-WN fine-tunes
    only when notified.
    """
    return (trial.agent.name, spec.env, trial.cell.notification)


def _time_group(
    spec: ExperimentSpec, trials: list[Trial], samples: int, cap: float, at_horizon: bool
) -> CellCost:
    """Time up to ``samples`` of ``trials`` (one agent, one cell) within ``cap`` seconds.

    A trial still going at ``cap`` runs on to :data:`MIN_STEPS` steps, or until the group has
    spent :data:`OVERRUN` times ``cap``. If this agent has not played in this environment at
    this notification level in this process, its first trial is played once untimed before
    (see the module docstring).
    """
    first_play = _first_play(spec, trials[0])
    if first_play not in _PLAYED:
        _time_trial(spec, trials[0], cap, at_horizon)
        _PLAYED.add(first_play)
    times: list[float] = []
    cpu_times: list[float] = []
    projected = at_horizon
    start = time.perf_counter()
    for trial in trials[:samples]:
        spent = time.perf_counter() - start
        if times and spent >= cap:
            break
        seconds, cpu, cut = _time_trial(spec, trial, cap - spent, at_horizon, cap * OVERRUN - spent)
        times.append(seconds)
        cpu_times.append(cpu)
        projected = projected or cut
        if cut:  # the cap is spent
            break
    first = trials[0]
    return CellCost(
        first.cell.setting,
        LEVEL_LABELS[first.cell.notification],
        first.agent.label,
        sum(times) / len(times),
        len(trials),
        sum(cpu_times) / len(cpu_times),
        projected,
    )


def _time_trial(
    spec: ExperimentSpec, trial: Trial, cap: float, at_horizon: bool, limit: float | None = None
) -> tuple[float, float, bool]:
    """``(wall s, CPU s, cut)`` of one trial: as played, or projected to the horizon.

    The episode is cut (``cut`` True) once ``cap`` seconds have passed and it has played
    :data:`MIN_STEPS` steps, or once ``limit`` seconds have passed (default ``OVERRUN * cap``)
    and it has played two. A cut episode, or any episode with ``at_horizon``, is projected to
    the horizon by :func:`projected_time`.
    """
    limit = cap * OVERRUN if limit is None else limit
    wall0, cpu0 = time.perf_counter(), time.process_time()
    ends: list[tuple[float, float]] = []  # (wall, CPU) when each step ended
    cut = False
    try:
        env = spec.make_env(trial.cell)
        agent = agent_entry(trial.agent.name).make(env, trial.agent.hyper)

        def stop(steps: int) -> bool:
            nonlocal cut
            now = time.perf_counter()
            ends.append((now - wall0, time.process_time() - cpu0))
            elapsed = now - wall0
            cut = steps >= 2 and elapsed >= cap and (steps >= MIN_STEPS or elapsed >= limit)
            return cut

        episode = run_episode(env, agent, trial.seed, stop)
    except KeyboardInterrupt:
        raise
    except Exception as error:
        raise RuntimeError(f"trial {trial.key} failed: {error!r}") from error
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    steps = episode.length
    if not (cut or at_horizon) or steps >= spec.horizon or steps < 2:
        return wall, cpu, cut
    if len(ends) < steps:  # the episode's last step ended it before `stop` was asked
        ends.append((wall, cpu))
    return (*projected_time(ends, spec.horizon), cut)


def projected_time(ends: Sequence[tuple[float, float]], horizon: int) -> tuple[float, float]:
    """``(wall s, CPU s)`` of an episode of ``horizon`` steps, from its first steps' times.

    The first quarter of the steps (at least the first step) counts as measured: it pays the
    one-off costs later steps do not repeat (loading compiled search kernels, a first
    fine-tuning's allocations). The rest of the horizon is projected at the time per step of
    the steps after it.

    Args:
        ends: ``[(wall, CPU)]`` seconds from the trial's start to the end of each step played,
            at least 2 steps and fewer than ``horizon``.
        horizon: Steps to project to.

    Raises:
        ValueError: Fewer than 2 steps, or not fewer than ``horizon``.
    """
    steps = len(ends)
    if not 2 <= steps < horizon:
        raise ValueError(f"len(ends)={steps} must lie in [2, horizon={horizon})")
    warm = max(1, steps // 4)
    scale = (horizon - warm) / (steps - warm)
    (wall_w, cpu_w), (wall_n, cpu_n) = ends[warm - 1], ends[-1]
    return wall_w + (wall_n - wall_w) * scale, cpu_w + (cpu_n - cpu_w) * scale


def worker_startup() -> float:
    """Seconds a fresh worker process takes to start and import what trials need, measured."""
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-c", "import ns_pz.experiments.work"], check=True, capture_output=True
    )
    return time.perf_counter() - start


def projection_lines(
    specs: Sequence[ExperimentSpec],
    networks: Sequence[TrainingCost],
    costs: Mapping[str, Sequence[CellCost]],
    workers: int,
    startup: float | None = None,
) -> list[str]:
    """The run's projected time on ``workers`` workers and on this machine, as text.

    Training and trials are given apart (:func:`~ns_pz.experiments.projection.project`). Specs
    run one after the other on the same workers (``bench run`` starts them once, so only the
    first spec waits for their start); a network several share is trained by the first. On
    ``workers`` workers the trials take their CPU time (idle cores); on this machine's cores,
    their wall time as measured (its present load).

    Args:
        specs: The experiments, in the order they run.
        networks: What :func:`estimate_training` gave (cached ones cost nothing).
        costs: Spec name → what :func:`estimate` gave.
        workers: Worker processes to project for.
        startup: Seconds a worker takes to start (``None``: measured, :func:`worker_startup`).
    """
    here = os.cpu_count() or 1
    startup = worker_startup() if startup is None else startup
    scenarios = [(f"on {workers} worker(s), idle cores (from CPU time)", workers, True)]
    scenarios.append((f"on this machine ({here} cores) at its present load", here, False))
    lines = [
        f"projected (specs one after the other; a worker starts in {startup:.1f} s, then trains "
        "or plays; a trial waits only for its own networks):"
    ]
    for label, count, cpu in scenarios:
        to_train = {n.key: n.cpu_seconds if cpu else n.seconds for n in networks if not n.cached}
        parts = []
        for index, spec in enumerate(specs):
            requires = plan_training(spec, expand(spec)).requires
            mine = {
                key: to_train.pop(key)
                for label_keys in requires.values()
                for key in label_keys
                if key in to_train
            }
            groups = [
                GroupTime(
                    cost.cpu_seconds_per_trial if cpu else cost.seconds_per_trial,
                    cost.trials,
                    requires.get(cost.agent, frozenset()) & set(mine),
                )
                for cost in costs.get(spec.name, ())
            ]
            started = startup if index == 0 else 0.0  # the workers stay up between specs
            parts.append(project(list(mine.items()), groups, count, started))
        lines.append(f"  {label}: {combined(parts).text()}")
    return lines
