"""Process pools whose workers never outlive the run that started them.

A run interrupted by SIGTERM or Ctrl-C stops its workers at once instead of waiting for their
work (a trial, a network's training) to finish, and a worker whose parent was killed outright
(``kill -9``) ends by itself within a second.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any


def new_pool(workers: int, started: Any = None) -> ProcessPoolExecutor:
    """A spawn-context pool of ``workers`` processes that end if this process goes away.

    Stop it with :func:`stop_pool`.

    Args:
        workers: Processes in the pool.
        started: A ``multiprocessing.Event`` of the spawn context, set by each worker once it
            has started (imported the caller's ``__main__`` again, as spawn does): a pool that
            breaks with it unset never ran a task.
    """
    return ProcessPoolExecutor(
        workers,
        mp_context=multiprocessing.get_context("spawn"),
        initializer=_start_worker,
        initargs=(os.getpid(), started),
    )


def _start_worker(parent: int, started: Any) -> None:
    die_with_parent(parent)
    if started is not None:
        started.set()


def stop_pool(pool: ProcessPoolExecutor, clean: bool) -> None:
    """Shut ``pool`` down: after its work if ``clean``, else at once (workers terminated).

    Call it in a ``finally`` with ``clean`` set only where the work ran to its end, so an
    interruption (``KeyboardInterrupt``, the runner's SIGTERM) stops the workers now.
    """
    if not clean:
        processes = getattr(pool, "_processes", None) or {}  # None once shut down
        for process in list(processes.values()):
            process.terminate()
    pool.shutdown(wait=clean, cancel_futures=True)


def die_with_parent(parent: int) -> None:
    """Pool initializer: end this worker if the process that started it goes away (kill -9)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()
