"""A progress line for long exact solves, on stderr, only when asked for."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class SolveProgress:
    """Prints what a solve is when it starts, then the steps done, elapsed time and ETA.

    A line is printed at most every ``interval`` seconds and after the last step, so a solve
    of a second prints two lines and one of an hour a few hundred.

    Args:
        label: The solver (starts every line).
        total: Steps the solve runs.
        header: What the solve is (its size), printed first.
        stream: Where to write (default: stderr).
        interval: Least seconds between two lines.
    """

    def __init__(
        self,
        label: str,
        total: int,
        header: str,
        stream: TextIO | None = None,
        interval: float = 2.0,
    ) -> None:
        self.label, self.total = label, total
        self.stream = stream if stream is not None else sys.stderr
        self.interval = interval
        self._start = self._last = time.monotonic()
        self._write(f"{label}: {header}")

    def step(self, done: int) -> None:
        """``done`` of :attr:`total` steps are finished."""
        now = time.monotonic()
        if done < self.total and now - self._last < self.interval:
            return
        self._last = now
        elapsed = now - self._start
        eta = elapsed / done * (self.total - done) if done else float("nan")
        self._write(
            f"{self.label}: step {done}/{self.total}, {elapsed:.1f} s elapsed"
            + ("" if done == self.total else f", ETA {eta:.0f} s")
        )

    def _write(self, text: str) -> None:
        self.stream.write(text + "\n")
        self.stream.flush()
