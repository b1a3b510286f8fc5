"""The progress line: no rate or ETA from a first fast tick; units; plain lines when asked."""

from __future__ import annotations

import io

from ns_pz.experiments.progress import WARM_UP_SECONDS, Progress


def test_the_first_tick_claims_no_rate_and_no_eta() -> None:
    """One random-agent trial in 2 ms once read as 500 trials/s with nothing left to wait."""
    bar = Progress(38, stream=io.StringIO())
    bar.done = 1
    early = bar.line(now=bar._start + 0.002)
    assert "1/38 trials" in early and "? trials/s" in early and "ETA ?" in early
    bar.done = 10
    later = bar.line(now=bar._start + WARM_UP_SECONDS + 18.0)
    assert "2.0 s/trial" in later and "ETA 0:56" in later  # 10 in 20 s: 28 left, 56 s


def test_training_steps_show_a_rate_per_second_and_plain_lines() -> None:
    """Training counts steps; not in place, each draw is a plain line."""
    stream = io.StringIO()
    bar = Progress(200_000, 0, "training DDQN", stream, interval=0.0, unit="steps", in_place=False)
    bar.advance(to=1000)
    bar.advance(to=200_000)
    bar.close()
    lines = stream.getvalue().splitlines()
    assert lines[-1].startswith("training DDQN [") and "200,000/200,000 steps" in lines[-1]
    assert "ETA 0:00" in lines[-1] and "\r" not in stream.getvalue()


def test_a_note_goes_above_a_line_drawn_in_place() -> None:
    """In place, a note clears the status line, ends with a newline, and the line is redrawn."""
    stream = io.StringIO()
    bar = Progress(10, 0, "run", stream, in_place=True)
    bar.advance()
    bar.note("trained DDQN in 3.0 s")
    text = stream.getvalue()
    before, _, after = text.rpartition("trained DDQN in 3.0 s")
    assert before.endswith("\r") and after.startswith(" ") and "\n\rrun [" in after
    plain = io.StringIO()
    Progress(10, 0, "run", plain, in_place=False).note("hello")
    assert plain.getvalue() == "hello\n"
