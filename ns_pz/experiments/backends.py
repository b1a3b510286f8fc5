"""Where trials run: in this process, in a local process pool, or on a Ray cluster.

A backend takes the spec and the trials still to run and yields their result rows as they
finish, in any order. Trials are deterministic from their seeds, so every backend gives the same
rows (wall times aside). The local pool is the default and needs no server; Ray is an optional
extra (``pip install "ns_pz[ray]"``) and is imported only when chosen.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from abc import ABC, abstractmethod
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import ns_pz
from ns_pz.agents.learning.trained import Needed
from ns_pz.experiments.pool import Outcome, Pool, how_it_ended
from ns_pz.experiments.spec import ExperimentSpec
from ns_pz.experiments.trials import Trial, error_row
from ns_pz.experiments.work import (
    Job,
    Schedule,
    Trained,
    Training,
    install,
    payload,
    run_batch,
    train_and_ship,
    train_network,
    warm_up_worker,
)

BACKENDS = ("local", "ray")


class Backend(ABC):
    """Runs trials (after the networks they need) and yields ``(trial, row)`` as each finishes."""

    @abstractmethod
    def run(
        self,
        spec: ExperimentSpec,
        trials: Sequence[Trial],
        training: Training | None = None,
        on_trained: Callable[[Trained], None] | None = None,
    ) -> Iterator[tuple[Trial, dict]]:
        """Run every trial; yield each one's row as soon as it is done.

        Args:
            spec: The experiment.
            trials: The trials to run.
            training: The networks they need (:func:`~ns_pz.experiments.work.plan_training`):
                the missing ones train first, in parallel, and a trial starts as soon as its
                own are ready. A trial whose network failed to train is an error row.
                ``None``: none is trained first.
            on_trained: Called with each missing network's outcome as it ends.
        """

    def start(self) -> None:  # noqa: B027 - a no-op unless a backend has workers to start
        """Start the workers now, so they start while the caller still prepares the run.

        Optional: :meth:`run` starts them if this was not called. Without a ``with`` block,
        workers started here stop at the end of the next run (or at :meth:`close`).
        """

    def close(self) -> None:  # noqa: B027 - a no-op unless a backend keeps something
        """Release what the backend keeps between runs (nothing, unless it says otherwise)."""

    def __enter__(self) -> Backend:
        """Keep what can be kept between runs until the ``with`` block ends."""
        return self

    def __exit__(self, *exc: object) -> None:
        """:meth:`close`."""
        self.close()


class LocalBackend(Backend):
    """A pool of ``workers`` processes on this machine, started once for the run.

    The pool first trains the networks the run is missing, one per worker, single-threaded;
    trials start as soon as their networks are ready, the others while training goes on. A
    worker keeps its imports and compiled code from one job to the next and is given more of
    the agent it has already played where it can (see :class:`~ns_pz.experiments.work.Schedule`),
    and short trials reach it in batches (:class:`~ns_pz.experiments.work.Batcher`).

    Trials never run in the calling process, not even with one worker: a trial that kills its
    process (a crash in compiled code, an out-of-memory kill, an agent's ``os._exit``) must not
    take the run with it. Workers are started with ``spawn`` (no state inherited from the
    parent) and end themselves if the parent dies. A worker that dies is replaced; the trial it
    was playing is recorded as an error saying how the process ended (a batch's trials are each
    played again on their own first, so only the one that kills its process is blamed).

    Used as a context manager (``with LocalBackend(16) as backend:``), it keeps its workers,
    warm, from one run to the next (the specs of ``ns-pz bench run paper``) until the block
    ends; otherwise they stop at the end of each run.

    As with any ``spawn`` pool, a script that runs a spec must do so under
    ``if __name__ == "__main__":`` (each worker imports the script again), and agents it
    registers must be registered at its top level. Workers that end before they start (the
    script ran the spec again while being imported) stop the run with a :class:`RuntimeError`
    saying so, instead of failing every trial.
    """

    def __init__(self, workers: int) -> None:
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ValueError(f"workers={workers!r} must be an integer >= 1")
        self.workers = workers
        self._keep = False
        self._pool: Pool | None = None

    def __enter__(self) -> LocalBackend:
        """Keep the workers between runs until the block ends."""
        self._keep = True
        return self

    def __exit__(self, *exc: object) -> None:
        """Stop the workers: at once if the block ended in an exception, else after their jobs.

        A spec that fails to load should not wait for workers still warming up.
        """
        self._stop(clean=exc[0] is None)

    def start(self) -> None:
        """Start the workers now (each imports the agents' code and starts numba as it starts).

        ``ns-pz bench run`` calls this before it loads the specs, so the workers' start-up
        (about a second each, in parallel) overlaps the runner's own.
        """
        if self._pool is None:
            self._pool = Pool(self.workers, _CANNOT_START, warm_up_worker)

    def close(self) -> None:
        """Stop the workers kept between runs or started by :meth:`start`, if any."""
        self._stop(clean=True)

    def _stop(self, clean: bool) -> None:
        self._keep = False
        if self._pool is not None:
            pool, self._pool = self._pool, None
            pool.close(clean)

    def run(
        self,
        spec: ExperimentSpec,
        trials: Sequence[Trial],
        training: Training | None = None,
        on_trained: Callable[[Trained], None] | None = None,
    ) -> Iterator[tuple[Trial, dict]]:
        """Run in a process pool; a trial whose process dies becomes an error row."""
        schedule = Schedule(spec, trials, training)
        shown = training is not None and training.shown
        if schedule.done:
            if not self._keep:  # workers from start() stop at the end of this run, as promised
                self._stop(clean=True)
            return
        pool, self._pool = self._pool or Pool(self.workers, _CANNOT_START, warm_up_worker), None
        clean = False
        try:
            while True:
                _hand_out(pool, schedule, spec, shown)
                if not pool.busy:
                    if not schedule.done:  # every trial left waits for a network none trains
                        raise RuntimeError("the schedule stalled with trials left (a bug)")
                    break
                rows = [row for o in pool.wait() for row in _collect(spec, schedule, o, on_trained)]
                _hand_out(pool, schedule, spec, shown)  # before the rows are stored: no idling
                yield from rows
            clean = True
        finally:
            if clean and self._keep:
                self._pool = pool  # warm for the next run
            else:
                pool.close(clean)  # interrupted: the workers stop now


def _hand_out(pool: Pool, schedule: Schedule, spec: ExperimentSpec, shown: bool) -> None:
    """Give each idle worker its next job, while there is one."""
    counts = Counter(label for worker in pool.workers for label in worker.warm)
    for worker in pool.idle():
        job = schedule.next_job(worker.warm, counts)
        if job is None:
            return
        if job.need is not None:
            pool.submit(worker, job, train_network, job.need, shown)
            continue
        worker = pool.submit(worker, job, run_batch, spec, job.trials)
        label = job.trials[0].agent.label
        if label not in worker.warm:
            worker.warm.add(label)
            counts[label] += 1


def _collect(
    spec: ExperimentSpec,
    schedule: Schedule,
    outcome: Outcome,
    on_trained: Callable[[Trained], None] | None,
) -> Iterator[tuple[Trial, dict]]:
    """The rows of one ended job (error rows if its worker died)."""
    job: Job = outcome.job
    if job.need is not None:
        result = outcome.result
        if outcome.died:
            message = died_message(outcome.exitcode)
            result = Trained(job.need.request.key, job.need.label, 0.0, False, message)
        if on_trained is not None:
            on_trained(result)
        yield from schedule.trained(result)
    elif not outcome.died:
        for trial, row in zip(job.trials, outcome.result, strict=True):
            schedule.finished(trial, row)
            yield trial, row
    elif len(job.trials) == 1:
        yield job.trials[0], error_row(spec, job.trials[0], died_message(outcome.exitcode))
    else:  # which of them killed it cannot be known: each plays again on its own
        schedule.retry_alone(job.trials)


_CANNOT_START = (
    "the worker processes ended {how}, so no trial can run. Workers are started with spawn, "
    "which imports the script that called run_spec again: put that call under "
    "`if __name__ == '__main__':` (their own error is on stderr above)"
)


def died_message(exitcode: int | None) -> str:
    """The error of a trial whose worker process ended without reporting, from its exit code."""
    return (
        f"its worker process died ({how_it_ended(exitcode)}) while running this trial, "
        "without reporting a result: a crash in compiled code, an out-of-memory kill, or the "
        "agent ending the process (os._exit, a signal)"
    )


class RayBackend(Backend):
    """Trials as Ray tasks, on a local Ray started here or on the cluster at ``address``.

    Args:
        workers: CPUs of the local Ray instance (ignored when joining a cluster).
        address: A running cluster (``"auto"``, ``"ray://host:10001"``); ``None`` joins the
            cluster of ``RAY_ADDRESS`` if that is set, else starts Ray on this machine.
    """

    def __init__(self, workers: int, address: str | None = None) -> None:
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ValueError(f"workers={workers!r} must be an integer >= 1")
        self.workers = workers
        self.address = address

    def run(
        self,
        spec: ExperimentSpec,
        trials: Sequence[Trial],
        training: Training | None = None,
        on_trained: Callable[[Trained], None] | None = None,
    ) -> Iterator[tuple[Trial, dict]]:
        """Train the missing networks as tasks, then each trial as a task once its are ready.

        A trial task takes its networks as arguments, so Ray starts it only once they exist and
        sends them to the node that runs it; there they are put in that node's cache unless it
        has them (and each trained one in this machine's cache too). A task whose worker
        process dies is run again by Ray (up to three times), so a lost worker neither loses
        nor repeats a row.
        """
        try:
            import ray
        except ImportError:
            raise RuntimeError(
                'the ray backend needs Ray: pip install "ns_pz[ray]" (or use --backend local)'
            ) from None
        training = training or Training()
        started_here = not ray.is_initialized()
        if started_here:
            with _away_from_a_shadowing_checkout():
                self._init(ray)
        try:
            train: Any = ray.remote(num_returns=2, max_retries=3)(train_and_ship)
            play = ray.remote(max_retries=3)(_play_with)
            spec_ref = ray.put(spec)
            networks: dict[str, Any] = {}
            trainings: dict[Any, Needed] = {}
            for key, need in training.networks.items():
                if key in training.missing:
                    outcome, networks[key] = train.remote(need)
                    trainings[outcome] = need
                else:  # cached here: sent to the nodes that run its trials
                    networks[key] = ray.put(payload(need.request))
            pending = {
                play.remote(
                    spec_ref, trial, *(networks[k] for k in sorted(training.waits_for(trial)))
                ): trial
                for trial in trials
            }
            while pending or trainings:
                done, _ = ray.wait([*trainings, *pending], num_returns=1)
                for ref in done:
                    if ref in trainings:
                        need = trainings.pop(ref)
                        try:
                            result = ray.get(ref)
                        except Exception as error:  # noqa: BLE001 - a lost worker or node
                            message = f"Ray task failed: {error}"
                            result = Trained(need.request.key, need.label, 0.0, False, message)
                        if not result.error:  # kept here too: a later run here finds it
                            install([ray.get(networks[need.request.key])])
                        if on_trained is not None:
                            on_trained(result)
                        continue
                    trial = pending.pop(ref)
                    try:
                        row = ray.get(ref)
                    except Exception as error:  # noqa: BLE001 - a lost worker or node
                        row = error_row(spec, trial, f"Ray task failed: {error}")
                    yield trial, row
        finally:
            if started_here:
                ray.shutdown()

    def _init(self, ray: Any) -> None:
        if self.address is not None:
            ray.init(address=self.address, log_to_driver=False)
        elif os.environ.get("RAY_ADDRESS"):  # inside `ray job submit` or a configured cluster
            ray.init(log_to_driver=False)
        else:
            ray.init(num_cpus=self.workers, include_dashboard=False, log_to_driver=False)


def _play_with(spec: ExperimentSpec, trial: Trial, *networks: Any) -> dict[str, Any]:
    """A Ray task: cache the trial's networks on this node if missing, then play the trial.

    A network that failed to train arrives as the text saying why: the trial's error.
    """
    for network in networks:
        if isinstance(network, str):
            return error_row(spec, trial, network)
    install(networks)
    return run_batch(spec, [trial])[0]


@contextlib.contextmanager
def _away_from_a_shadowing_checkout() -> Iterator[None]:
    """Start Ray outside a source checkout of ns_pz other than the one running.

    Ray puts the driver's working directory first on its workers' ``sys.path``; run from a
    checkout while an installed ns_pz is the one in use, the workers would import the
    checkout's tree instead of the code the driver runs.
    """
    here = Path.cwd()
    running = Path(ns_pz.__file__).resolve().parent
    shadowing = (here / "ns_pz" / "__init__.py").is_file() and running != (here / "ns_pz").resolve()
    if shadowing:
        os.chdir(tempfile.gettempdir())
    try:
        yield
    finally:
        if shadowing:
            os.chdir(here)


def make_backend(name: str, workers: int, address: str | None = None) -> Backend:
    """The backend called ``name``.

    Raises:
        ValueError: An unknown name, or an address given to the local backend.
    """
    if name == "local":
        if address is not None:
            raise ValueError(f"address={address!r} applies to the ray backend only")
        return LocalBackend(workers)
    if name == "ray":
        return RayBackend(workers, address)
    raise ValueError(f"backend={name!r}; allowed: {', '.join(BACKENDS)}")
