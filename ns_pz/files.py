"""Files written atomically through ``tempfile`` get the permissions a plain ``open`` would give.

``tempfile`` creates files ``0600`` and folders ``0700`` (owner only); results and trained
networks are meant to be shared (a team's results folder, a cache on a cluster's shared disk), so
they are given ``0666`` / ``0777`` minus the user's umask, as ``open`` and ``mkdir`` do.
"""

from __future__ import annotations

import os
from pathlib import Path


def _read_umask() -> int:
    mask = os.umask(0)  # the only portable way to read it: set, then put back at once
    os.umask(mask)
    return mask


_UMASK = _read_umask()  # read at import, before any worker threads start


def as_if_created(path: str | os.PathLike[str], *, folder: bool = False) -> None:
    """Give ``path`` the permissions ``open`` (or ``mkdir`` for a folder) would have given."""
    os.chmod(Path(path), (0o777 if folder else 0o666) & ~_UMASK)
