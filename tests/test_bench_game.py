"""The game benchmark still runs (a smoke run; its figures are read by people)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_game.py"


def test_game_benchmark_smoke_run(tmp_path):
    """bench_game.py --smoke prints a timing row per env and a planner row per env."""
    out = subprocess.run(
        [sys.executable, str(BENCH), "--smoke"],
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
    ).stdout
    assert out.count("CliffWalking ") == 2 and "FrozenLake 4x4" in out
    assert "Bridge      0.10" in out and "FrozenLake  0.10" in out
