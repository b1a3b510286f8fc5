"""A progress line for long runs: trials done, rate and time left, on stderr."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """Counts finished trials and redraws one status line.

    On a terminal the line is redrawn in place at most ten times a second; elsewhere (a log
    file, CI) a plain line is printed at most every ``interval`` seconds and at the end.

    Args:
        total: Trials in the run.
        done: Trials already finished before it started (a resumed run).
        label: What is running.
        stream: Where to write (default: stderr).
        interval: Seconds between plain lines when ``stream`` is not a terminal.
    """

    def __init__(
        self,
        total: int,
        done: int = 0,
        label: str = "",
        stream: TextIO | None = None,
        interval: float = 10.0,
    ) -> None:
        self.total, self.done, self.label = total, done, label
        self.stream = stream if stream is not None else sys.stderr
        self.interval = interval
        self.errors = 0
        self._start = time.monotonic()
        self._start_done = done
        self._last = -1e9
        self._drawn = -1
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def advance(self, ok: bool = True) -> None:
        """One more trial finished (``ok=False``: it failed)."""
        self.done += 1
        self.errors += not ok
        now = time.monotonic()
        if now - self._last >= (0.1 if self._tty else self.interval) or self.done == self.total:
            self._last = now
            self._draw(now)

    def line(self, now: float | None = None) -> str:
        """The status text."""
        now = time.monotonic() if now is None else now
        elapsed = max(now - self._start, 1e-9)
        rate = (self.done - self._start_done) / elapsed
        left = self.total - self.done
        eta = _clock(left / rate) if rate > 0 else "?"
        width = 24
        filled = width * self.done // max(self.total, 1)
        bar = "#" * filled + "." * (width - filled)
        errors = f"  {self.errors} failed" if self.errors else ""
        return (
            f"{self.label} [{bar}] {self.done}/{self.total} trials  {rate:.2f}/s  "
            f"elapsed {_clock(elapsed)}  ETA {eta}{errors}"
        )

    def close(self) -> None:
        """Draw the final state (unless just drawn) and end the line."""
        if self._drawn != self.done:
            self._draw(time.monotonic())
        if self._tty:
            self.stream.write("\n")
            self.stream.flush()

    def _draw(self, now: float) -> None:
        self._drawn = self.done
        text = self.line(now)
        self.stream.write(f"\r{text}" if self._tty else f"{text}\n")
        self.stream.flush()


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"
