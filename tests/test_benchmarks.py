"""The benchmark script still runs (a smoke run; its figures are read by people, not asserted)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_core.py"


def test_core_benchmark_smoke_run():
    """bench_core.py --smoke finishes and prints a ratio for every case."""
    out = subprocess.run(
        [sys.executable, str(BENCH), "--smoke"], capture_output=True, text=True, check=True
    ).stdout
    for case in ("view, change every step", "AEC cycle, change every step", "save + restore"):
        assert case in out
