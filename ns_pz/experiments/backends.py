"""Where trials run: in this process, in a local process pool, or on a Ray cluster.

A backend takes the spec and the trials still to run and yields their result rows as they
finish, in any order. Trials are deterministic from their seeds, so every backend gives the same
rows (wall times aside). The local pool is the default and needs no server; Ray is an optional
extra (``pip install "ns_pz[ray]"``) and is imported only when chosen.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import tempfile
from abc import ABC, abstractmethod
from collections.abc import Generator, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import ns_pz
from ns_pz.experiments.spec import ExperimentSpec
from ns_pz.experiments.trials import Trial, error_row, run_trial
from ns_pz.workers import die_with_parent, new_pool, stop_pool

BACKENDS = ("local", "ray")


class Backend(ABC):
    """Runs trials and yields ``(trial, row)`` as each finishes."""

    @abstractmethod
    def run(self, spec: ExperimentSpec, trials: Sequence[Trial]) -> Iterator[tuple[Trial, dict]]:
        """Run every trial; yield each one's row as soon as it is done."""


class LocalBackend(Backend):
    """A pool of ``workers`` processes on this machine.

    Trials never run in the calling process, not even with one worker: a trial that kills its
    process (a crash in compiled code, an out-of-memory kill, an agent's ``os._exit``) must not
    take the run with it. Workers are started with ``spawn`` (no state inherited from the
    parent) and end themselves if the parent dies. If a worker dies, the trials that were in
    flight are re-run one at a time, each in a process of its own, so only the one that kills
    its process again is recorded as an error, with how the process ended; the pool restarts
    for the rest.

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

    def run(self, spec: ExperimentSpec, trials: Sequence[Trial]) -> Iterator[tuple[Trial, dict]]:
        """Run in a process pool; a trial whose process dies becomes an error row."""
        remaining = list(trials)
        while remaining:
            remaining, suspects = yield from self._pool_run(spec, remaining, self.workers)
            for trial in suspects:  # one at a time, so only the culprit is blamed
                yield trial, run_alone(spec, trial)

    def _pool_run(
        self, spec: ExperimentSpec, trials: list[Trial], workers: int
    ) -> Generator[tuple[Trial, dict], None, tuple[list[Trial], list[Trial]]]:
        """Run until done or the pool breaks.

        Returns:
            ``(not started, in flight when the pool broke)``: both empty after a clean run.
        """
        started = multiprocessing.get_context("spawn").Event()
        pool = new_pool(workers, started)
        pending: dict[Future[dict], Trial] = {}
        queue = list(reversed(trials))
        clean = False
        try:
            while queue or pending:
                broken = False
                while queue and len(pending) < 2 * workers and not broken:
                    try:
                        pending[pool.submit(run_trial, spec, queue[-1])] = queue[-1]
                        queue.pop()
                    except BrokenProcessPool:
                        broken = True
                done, _ = wait(pending, return_when=FIRST_COMPLETED) if pending else (set(), set())
                for future in done:
                    if isinstance(future.exception(), BrokenProcessPool):
                        broken = True
                        continue
                    yield pending.pop(future), future.result()
                if broken:
                    if not started.is_set():
                        raise RuntimeError(_CANNOT_START.format(how="before they started"))
                    # A worker died: which in-flight trial killed it cannot be known here.
                    return list(reversed(queue)), list(pending.values())
            clean = True
        finally:
            stop_pool(pool, clean)  # interrupted or broken: the workers stop now
        return [], []


def run_alone(spec: ExperimentSpec, trial: Trial) -> dict[str, Any]:
    """Run one trial in a fresh process of its own; its row, or an error row if it died.

    The error row says how the process ended (the signal that killed it, or its exit code).
    """
    context = multiprocessing.get_context("spawn")
    receiver, sender = context.Pipe(duplex=False)
    process = context.Process(
        target=_run_and_send, args=(spec, trial, sender, os.getpid()), daemon=True
    )
    process.start()
    sender.close()  # the child holds the only writing end: EOF when it dies
    clean = False
    try:
        started = row = None
        with contextlib.suppress(EOFError):
            started = receiver.recv()
            row = receiver.recv()
        process.join()
        clean = True
    finally:
        receiver.close()
        if not clean:  # interrupted: the child stops now
            process.terminate()
            process.join()
    if started is None:
        how = f"before it started ({_how_it_ended(process.exitcode)})"
        raise RuntimeError(_CANNOT_START.format(how=how))
    if row is None:
        return error_row(spec, trial, died_message(process.exitcode))
    return row


_CANNOT_START = (
    "the worker processes ended {how}, so no trial can run. Workers are started with spawn, "
    "which imports the script that called run_spec again: put that call under "
    "`if __name__ == '__main__':` (their own error is on stderr above)"
)


def _run_and_send(spec: ExperimentSpec, trial: Trial, sender: Connection, parent: int) -> None:
    """Child of :func:`run_alone`: say it started, run the trial, send its row back."""
    die_with_parent(parent)
    sender.send("started")
    sender.send(run_trial(spec, trial))
    sender.close()


def died_message(exitcode: int | None) -> str:
    """The error of a trial whose worker process ended without reporting, from its exit code."""
    return (
        f"its worker process died ({_how_it_ended(exitcode)}) while running this trial, "
        "without reporting a result: a crash in compiled code, an out-of-memory kill, or the "
        "agent ending the process (os._exit, a signal)"
    )


def _how_it_ended(exitcode: int | None) -> str:
    """``"killed by signal SIGSEGV"`` or ``"exited with code 3"``."""
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by signal {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exited with code {exitcode}"


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

    def run(self, spec: ExperimentSpec, trials: Sequence[Trial]) -> Iterator[tuple[Trial, dict]]:
        """Submit every trial, yield rows as tasks finish."""
        try:
            import ray
        except ImportError:
            raise RuntimeError(
                'the ray backend needs Ray: pip install "ns_pz[ray]" (or use --backend local)'
            ) from None
        started_here = not ray.is_initialized()
        if started_here:
            with _away_from_a_shadowing_checkout():
                self._init(ray)
        try:
            remote = ray.remote(run_trial)
            spec_ref = ray.put(spec)
            pending = {remote.remote(spec_ref, trial): trial for trial in trials}
            while pending:
                done, _ = ray.wait(list(pending), num_returns=1)
                for ref in done:
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
