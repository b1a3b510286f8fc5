"""Run a spec: expand it into trials, skip what is done, run the rest, store every row."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.learning.artefacts import artefact_path, exists, read_manifest
from ns_pz.agents.learning.trained import Needed, prepare
from ns_pz.experiments.backends import Backend
from ns_pz.experiments.lock import locked
from ns_pz.experiments.progress import Progress
from ns_pz.experiments.projection import Forecast, samples_first
from ns_pz.experiments.spec import ExperimentSpec
from ns_pz.experiments.store import ResultStore
from ns_pz.experiments.trials import Trial, expand
from ns_pz.experiments.work import Trained, Training, plan_training


@dataclass(frozen=True)
class RunSummary:
    """What a run did."""

    out: Path
    total: int
    skipped: int
    ran: int
    failed: int


def run_spec(
    spec: ExperimentSpec,
    out: str | Path,
    backend: Backend,
    resume: bool = False,
    progress: TextIO | None = None,
    on_row: Callable[[dict], None] | None = None,
) -> RunSummary:
    """Run every trial of ``spec`` not yet finished in ``out``; write each row as it arrives.

    Args:
        spec: The experiment.
        out: Its results directory (created if needed).
        backend: Where trials run.
        resume: Continue a run in ``out`` (without it, a directory holding results is refused).
        progress: Where to draw a progress line (``None``: no progress line).
        on_row: Called with each new row after it is stored.

    A trial whose file cannot be read (cut short) counts as not done and runs again; the file is
    named on ``progress``, as is any file in ``trials/`` that the store did not name (ignored).
    ``out`` is locked for the run (:mod:`ns_pz.experiments.lock`). The networks the trials
    need and the cache lacks are trained by ``backend``'s workers, in parallel, and each trial
    starts as soon as its own networks are ready (:mod:`ns_pz.experiments.work`). Trials run in
    worker processes (see ``backend``); one whose process dies is recorded as an error row.
    Each agent × cell plays its first trial early; once all have, a run with more than a
    minute left says on ``progress`` how long the rest should take
    (:class:`~ns_pz.experiments.projection.Forecast`).

    Raises:
        SpecError: ``out`` holds results of another spec, or of this one without ``resume``.
        DirectoryLocked: Another process is running into ``out``.
    """
    store = ResultStore(out)
    with locked(store.root):
        store.prepare(spec, resume)
        trials = expand(spec)
        rows, unreadable, strays = store.scan()
        finished = store.finished(spec.digest(), rows)
        todo = [trial for trial in trials if trial.key not in finished]
        training = plan_training(spec, todo, shown=progress is not None)
        if progress is not None:
            _announce(spec, training, progress)
            for path, reason in unreadable:
                progress.write(f"{path} is unreadable ({reason}); its trial runs again\n")
            for path, reason in strays:
                progress.write(f"{path} is ignored: {reason}\n")
        bar = None
        if progress is not None:
            label = f"{spec.name} ({spec.size})"
            bar = Progress(len(trials), len(trials) - len(todo), label, progress)

        def note(text: str) -> None:
            if bar is not None:
                bar.note(text)

        def on_trained(result: Trained) -> None:
            if result.error:
                note(f"training {result.label} failed: {result.error}")
            elif result.trained:
                note(f"trained {result.label} in {result.seconds:.1f} s")

        forecast = Forecast(todo, getattr(backend, "workers", 1))
        failed = 0
        try:
            for trial, row in backend.run(spec, samples_first(todo), training, on_trained):
                store.write(row)
                said = forecast.add(trial, row)
                if said is not None:
                    note(said)
                ok = row["status"] == "ok"
                failed += not ok
                if bar is not None:
                    bar.advance(ok)
                if on_row is not None:
                    on_row(row)
        finally:
            store.write_csv()
            if bar is not None:
                bar.close()
    return RunSummary(store.root, len(trials), len(trials) - len(todo), len(todo), failed)


def _announce(spec: ExperimentSpec, training: Training, progress: TextIO) -> None:
    """Say how many networks the run trains (cached ones are only loaded: not announced)."""
    missing = len(training.missing)
    if missing:
        cached = len(training.networks) - missing
        more = f" ({cached} cached)" if cached else ""
        progress.write(
            f"{spec.name}: training {missing} network(s){more}, trials that need none start "
            "meanwhile\n"
        )


@dataclass(frozen=True)
class TrainingCost:
    """One trained network a spec needs, and what it cost.

    Attributes:
        key: The artefact's key (specs with the same θ_0 share artefacts).
        label: What was trained (learner, family, θ_0, budget).
        seconds: Training time (measured now, or recorded in the cached artefact).
        trained_now: Whether this run trained it (False: it was in the cache).
    """

    key: str
    label: str
    seconds: float
    trained_now: bool


def needed_networks(spec: ExperimentSpec, trials: list[Trial]) -> list[tuple[str, Needed]]:
    """The trained networks ``trials`` need, as ``(agent label, need)`` (a key may repeat)."""
    needs: list[tuple[str, Needed]] = []
    seen: set[str] = set()
    for trial in trials:
        entry = agent_entry(trial.agent.name)
        if entry.artefacts is None or trial.agent.label in seen:
            continue
        seen.add(trial.agent.label)  # every cell of a spec shares θ_0 and the family
        env = spec.make_env(trial.cell)
        needs.extend((trial.agent.label, need) for need in entry.artefacts(env, trial.agent.hyper))
    return needs


def train_artefacts(
    spec: ExperimentSpec, trials: list[Trial], progress: TextIO | None = None, workers: int = 1
) -> list[TrainingCost]:
    """Train, once each, the networks ``trials`` need, and play none (``ns-pz train``).

    Every distinct artefact is trained under its key's file lock (see
    :mod:`ns_pz.agents.learning.artefacts`), so concurrent runs sharing the cache train it once
    too. Cached ones report the training time they recorded. ``workers`` processes train
    distinct networks at once. (:func:`run_spec` trains the missing ones itself, in its
    backend's workers, while trials that need none already run.)
    """
    needs = [need for _, need in needed_networks(spec, trials)]
    costs = []

    def report(need: Needed, seconds: float, trained: bool) -> None:
        if not trained:
            info = read_manifest(artefact_path(need.request)).get("info", {})
            seconds = float(info.get("seconds", 0.0))
        costs.append(TrainingCost(need.request.key, need.label, seconds, trained))
        if progress is not None and trained:
            progress.write(f"trained {need.label} in {seconds:.1f} s\n")

    if needs and progress is not None:
        keys = {need.request.key: need for need in needs}
        missing = sum(not exists(need.request) for need in keys.values())
        if missing:  # cached ones are only loaded: nothing to announce
            cached = f" ({len(keys) - missing} cached)" if missing < len(keys) else ""
            progress.write(f"{spec.name}: training {missing} network(s){cached}\n")
    prepare(needs, report=report, workers=workers, progress=progress)
    return costs
