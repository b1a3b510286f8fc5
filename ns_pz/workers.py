"""Process pools whose workers never outlive the run that started them.

A run interrupted by SIGTERM or Ctrl-C stops its workers at once instead of waiting for their
work (a trial, a network's training) to finish, and a worker whose parent was killed outright
(``kill -9``) ends by itself within a second.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import multiprocessing.context
import os
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from typing import Any

#: The thread-pool sizes numerical libraries read once, when they load: OpenBLAS under NumPy,
#: OpenMP under torch, MKL. A worker is one of many on the machine, so it gets one thread each.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def single_threaded_children() -> Iterator[None]:
    """Processes started in the block load their numerical libraries with one thread each.

    The variables are set in this process's environment only while the block runs (a child
    copies it when it starts); one the user set already is left as it is.
    """
    added = [name for name in THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = "1"
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


class _SingleThreadedProcess(multiprocessing.context.SpawnProcess):
    def start(self) -> None:
        with single_threaded_children():
            super().start()


class _SingleThreadedSpawn(multiprocessing.context.SpawnContext):
    Process = _SingleThreadedProcess


def worker_context() -> multiprocessing.context.SpawnContext:
    """The spawn context workers start from, each with one thread per numerical library.

    A variable set inside the worker would come too late for NumPy: spawn imports the parent's
    main module, and with it NumPy, before the worker's own code runs.
    """
    return _SingleThreadedSpawn()


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
        mp_context=worker_context(),
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
