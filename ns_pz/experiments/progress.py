"""A progress line for long runs: items done (trials, training steps), rate and time left."""

from __future__ import annotations

import sys
import time
from typing import TextIO

#: A rate (and the time left from it) is shown only once this many seconds have passed and
#: this many items have finished since the start: one fast first trial (a random agent in a
#: few milliseconds) would otherwise claim hundreds per second and no time left.
WARM_UP_SECONDS = 2.0
WARM_UP_ITEMS = 2


class Progress:
    """Counts finished items and redraws one status line.

    In place (a terminal) the line is redrawn at most ten times a second; otherwise (a log file,
    CI, several processes writing to one terminal) a plain line is printed at most every
    ``interval`` seconds and at the end.

    Args:
        total: Items in the run.
        done: Items already finished before it started (a resumed run).
        label: What is running.
        stream: Where to write (default: stderr).
        interval: Seconds between plain lines when not drawing in place.
        unit: What an item is, for the text (``"trials"``, ``"steps"``, ``"episodes"``).
        in_place: Redraw one line in place; ``None``: when ``stream`` is a terminal.
    """

    def __init__(
        self,
        total: int,
        done: int = 0,
        label: str = "",
        stream: TextIO | None = None,
        interval: float = 10.0,
        unit: str = "trials",
        in_place: bool | None = None,
    ) -> None:
        self.total, self.done, self.label, self.unit = total, done, label, unit
        self.stream = stream if stream is not None else sys.stderr
        self.interval = interval
        self.errors = 0
        self._start = time.monotonic()
        self._start_done = done
        self._last = -1e9
        self._drawn = -1
        if in_place is None:
            in_place = bool(getattr(self.stream, "isatty", lambda: False)())
        self._tty = in_place

    def advance(self, ok: bool = True, to: int | None = None) -> None:
        """One more item finished (``ok=False``: it failed), or all up to ``to`` did."""
        self.done = self.done + 1 if to is None else to
        self.errors += not ok
        now = time.monotonic()
        if now - self._last >= (0.1 if self._tty else self.interval) or self.done == self.total:
            self._last = now
            self._draw(now)

    def line(self, now: float | None = None) -> str:
        """The status text (rate and ETA as ``?`` until :data:`WARM_UP_SECONDS` have passed)."""
        now = time.monotonic() if now is None else now
        elapsed = max(now - self._start, 1e-9)
        finished = self.done - self._start_done
        warm = elapsed >= WARM_UP_SECONDS and finished >= WARM_UP_ITEMS
        rate = finished / elapsed if warm else 0.0
        left = self.total - self.done
        eta = _clock(left / rate) if rate > 0 else ("0:00" if left == 0 else "?")
        width = 24
        filled = width * self.done // max(self.total, 1)
        bar = "#" * filled + "." * (width - filled)
        errors = f"  {self.errors} failed" if self.errors else ""
        return (
            f"{self.label} [{bar}] {self.done:,}/{self.total:,} {self.unit}  "
            f"{_rate_text(rate, self.unit)}  elapsed {_clock(elapsed)}  ETA {eta}{errors}"
        )

    def note(self, text: str) -> None:
        """Write one line of ``text`` above the status line (which is drawn again after it)."""
        if self._tty:
            width = len(self.line())
            self.stream.write(f"\r{text:<{width}}\n")
            self._draw(time.monotonic())
        else:
            self.stream.write(f"{text}\n")
            self.stream.flush()

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


def _rate_text(rate: float, unit: str) -> str:
    """``12.3 trials/s``, or ``4.2 s/trial`` below one a second; ``?`` before the warm-up."""
    if rate <= 0:
        return f"? {unit}/s"
    if rate >= 1:
        return f"{rate:,.1f} {unit}/s"
    return f"{1 / rate:.1f} s/{unit.removesuffix('s')}"


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"
