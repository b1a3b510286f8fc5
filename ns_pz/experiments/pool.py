"""Worker processes that the caller hands jobs to one by one, each to a worker it chooses.

Unlike :class:`concurrent.futures.ProcessPoolExecutor`, the caller knows which worker runs
what: it can give a worker more of the work it has already paid the first-use cost of (imports,
compiled code, torch's start), and when a worker dies it knows the job that was running there.
Workers are started with ``spawn`` and end themselves if the parent dies.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from ns_pz.workers import die_with_parent, worker_context


class Worker:
    """One worker process: what it runs now and what it has run (its warm labels).

    ``warm_up`` (a module-level function) is pickled by reference, so the new process imports
    its module as it starts, before it says it has started; it calls the function afterwards,
    before its first job.
    """

    def __init__(self, index: int, warm_up: Callable[[], None] | None = None) -> None:
        context = worker_context()
        self.index = index
        self.conn, child = context.Pipe(duplex=True)
        self.process = context.Process(
            target=_serve, args=(child, os.getpid(), warm_up), daemon=True
        )
        self.process.start()
        child.close()  # the worker holds the only other end: EOF when it dies
        self.started = False
        self.used = False  # given a job once
        self.job: Any = None
        self.warm: set[str] = set()

    def exitcode(self) -> int | None:
        """How it ended (waits for it): a negative signal number or an exit code."""
        self.process.join()
        return self.process.exitcode


def _serve(conn: Connection, parent: int, warm_up: Callable[[], None] | None) -> None:
    """A worker's loop: say it started, warm up, then call each ``(function, args)``."""
    die_with_parent(parent)
    # The parent starts workers as daemons (ended at its exit); in here the flag would forbid
    # a trial's own processes (an SB3 SubprocVecEnv, a pool of its own), so it is cleared.
    multiprocessing.current_process().daemon = False
    conn.send(None)
    if warm_up is not None:
        # Only a head start: whatever fails here fails again in the job that needs it, which
        # reports it as that job's error.
        with contextlib.suppress(Exception):
            warm_up()
    while True:
        try:
            message = conn.recv()
        except EOFError:
            return
        if message is None:
            return
        function, args = message
        conn.send(function(*args))


@dataclass(frozen=True)
class Outcome:
    """How one job ended: its result, or its worker died (``exitcode`` says how)."""

    worker: Worker
    job: Any
    result: Any = None
    died: bool = False
    exitcode: int | None = None


class Pool:
    """``size`` workers; :meth:`submit` a job to an idle one, :meth:`wait` for results.

    Each worker first calls ``warm_up`` (see :class:`Worker`); jobs submitted meanwhile wait for
    it. A worker started in place of a dead one does not: the warm-up is only a head start, and
    one that killed its process would otherwise kill every replacement too.

    Raises (from :meth:`wait`):
        RuntimeError: A worker ended before any worker started (see ``cannot_start``).
    """

    def __init__(
        self, size: int, cannot_start: str, warm_up: Callable[[], None] | None = None
    ) -> None:
        self.workers = [Worker(index, warm_up) for index in range(size)]
        self.cannot_start = cannot_start
        self._any_started = False

    def idle(self) -> list[Worker]:
        """Workers running nothing."""
        return [worker for worker in self.workers if worker.job is None]

    @property
    def busy(self) -> bool:
        """Whether any worker is running a job."""
        return any(worker.job is not None for worker in self.workers)

    def submit(self, worker: Worker, job: Any, function: Callable[..., Any], *args: Any) -> Worker:
        """Run ``function(*args)`` on ``worker`` (idle), remembering ``job`` as its work.

        Returns:
            The worker that took it: ``worker``, or a fresh one in its place if it had died.
        """
        try:
            worker.conn.send((function, args))
        except OSError:  # it died while idle: a fresh one takes the job
            worker.exitcode()
            worker.conn.close()
            worker = self.workers[worker.index] = Worker(worker.index)
            worker.conn.send((function, args))
        worker.job, worker.used = job, True
        return worker

    def wait(self) -> list[Outcome]:
        """Block until a worker sends a result or dies; what ended (a dead one is replaced)."""
        while True:
            watched = {worker.conn: worker for worker in self.workers}
            finished = []
            for conn in wait(list(watched)):
                worker = watched[conn]  # type: ignore[index]
                try:
                    result = worker.conn.recv()
                except (EOFError, OSError):
                    outcome = self._died(worker)
                    if outcome.job is not None:  # an idle one is only replaced
                        finished.append(outcome)
                    continue
                if not worker.started:  # its first message: it has started
                    worker.started = self._any_started = True
                    continue
                job, worker.job = worker.job, None
                finished.append(Outcome(worker, job, result))
            if finished:
                return finished

    def _died(self, worker: Worker) -> Outcome:
        code = worker.exitcode()
        if not worker.started and not self._any_started:
            how = f"before they started (one {how_it_ended(code)})"
            raise RuntimeError(self.cannot_start.format(how=how))
        worker.conn.close()
        self.workers[worker.index] = Worker(worker.index)
        return Outcome(worker, worker.job, died=True, exitcode=code)

    def close(self, clean: bool) -> None:
        """Stop every worker: after telling it to end if ``clean``, else at once (terminate).

        A worker that was never given a job is stopped at once either way: it may still be
        warming up, which a clean end would wait for.
        """
        for worker in self.workers:
            if clean and worker.used:
                with contextlib.suppress(OSError):
                    worker.conn.send(None)
            else:
                worker.process.terminate()
        for worker in self.workers:
            worker.process.join()
            worker.conn.close()


def how_it_ended(exitcode: int | None) -> str:
    """``"killed by signal SIGSEGV"`` or ``"exited with code 3"``, from a process's exit code."""
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by signal {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exited with code {exitcode}"
