"""One run per results directory: an operating-system lock on ``DIR/.lock``.

The lock is ``flock`` (``msvcrt.locking`` on Windows) on an open file, so the operating system
releases it when the holder ends in any way (normal exit, Ctrl-C, ``kill -9``, a crash): a stale
lock file never blocks a later run. The file holds the holder's PID, for the message of the run
that is refused. Within one process the lock is re-entrant (the CLI locks every output directory
before it checks them; :func:`~ns_pz.experiments.runner.run_spec` locks its own again).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ns_pz.experiments.spec import SpecError

LOCK_NAME = ".lock"

_HELD: dict[Path, tuple[int, int]] = {}  # resolved directory -> (file descriptor, depth)


class DirectoryLocked(SpecError):
    """Another process is running into the same results directory."""


@contextmanager
def locked(directory: str | Path) -> Iterator[None]:
    """Hold the lock of ``directory`` (created if needed) for the ``with`` block.

    Raises:
        DirectoryLocked: Another process holds it; the message names the directory and the PID
            written by the holder.
        SpecError: ``directory`` is a file.
    """
    root = Path(directory).resolve()
    if root in _HELD:
        fd, depth = _HELD[root]
        _HELD[root] = (fd, depth + 1)
        try:
            yield
        finally:
            fd, depth = _HELD[root]
            _HELD[root] = (fd, depth - 1)
        return
    if root.exists() and not root.is_dir():
        raise SpecError(f"--out {root} is a file, not a directory")
    root.mkdir(parents=True, exist_ok=True)
    path = root / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        if not _try_lock(fd):
            raise _locked_error(root, _read_pid(fd))
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, f"{os.getpid()}\n".encode())
    except OSError as error:  # a full disk: name the file
        os.close(fd)
        reason = error.strerror or str(error)
        raise OSError(error.errno, f"cannot write the lock file {path}: {reason}") from error
    except BaseException:
        os.close(fd)
        raise
    _HELD[root] = (fd, 1)
    try:
        yield
    finally:
        fd, depth = _HELD.pop(root)
        os.close(fd)  # closing the file releases the lock


def refuse_if_locked(directory: str | Path) -> None:
    """Raise :class:`DirectoryLocked` if another process holds ``directory``'s lock.

    Creates nothing. For a check that is about to refuse the directory for another reason
    (results already there): a run in progress is the reason to name, not ``--resume``.

    Raises:
        DirectoryLocked: Another process holds the lock; the message names the directory and
            the holder's PID.
    """
    root = Path(directory).resolve()
    if root in _HELD:
        return
    try:
        fd = os.open(root / LOCK_NAME, os.O_RDWR)
    except OSError:  # no lock file (never run), or not a directory: nobody holds it
        return
    try:
        if not _try_lock(fd):
            raise _locked_error(root, _read_pid(fd))
    finally:
        os.close(fd)  # releases the lock if the probe took it


def _locked_error(root: Path, holder: str) -> DirectoryLocked:
    return DirectoryLocked(
        f"{root} is in use by another run (PID {holder}); wait for it to end, or use "
        "another --out directory"
    )


def _read_pid(fd: int) -> str:
    """The PID the holder wrote (``"unknown"`` if it has not written it yet)."""
    os.lseek(fd, 0, os.SEEK_SET)
    try:
        text = os.read(fd, 32).decode(errors="replace").strip()
    except OSError:  # pragma: no cover - Windows: the locked byte cannot be read
        text = ""
    return text or "unknown"


def _try_lock(fd: int) -> bool:
    """Take an exclusive lock on ``fd`` without waiting; False if another process holds it."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        import msvcrt

        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)  # type: ignore[attr-defined]
        except OSError:
            return False
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    return True
