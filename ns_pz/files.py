"""Files written atomically through ``tempfile`` get the permissions a plain ``open`` would give.

``tempfile`` creates files ``0600`` and folders ``0700`` (owner only); results and trained
networks are meant to be shared (a team's results folder, a cache on a cluster's shared disk).
A new file gets ``0666`` (a folder ``0777``) minus the user's umask, as ``open`` and ``mkdir``
give; a file that replaces another keeps the mode the old one had, as rewriting it in place
would.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path


def umask() -> int:
    """The process's umask, read without changing it where the system allows (Linux)."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)  # elsewhere: set and put back at once
    os.umask(mask)
    return mask


def as_if_created(
    path: str | os.PathLike[str],
    *,
    folder: bool = False,
    replacing: str | os.PathLike[str] | None = None,
) -> None:
    """Give ``path`` the permissions ``open`` (``mkdir`` for a folder) would have given it.

    Args:
        path: The file or folder ``tempfile`` made.
        folder: It is a folder.
        replacing: The file ``path`` is about to replace, if any: its mode is kept.
    """
    if replacing is not None:
        try:
            os.chmod(Path(path), stat.S_IMODE(os.stat(replacing).st_mode))
            return
        except FileNotFoundError:
            pass
    os.chmod(Path(path), (0o777 if folder else 0o666) & ~umask())
