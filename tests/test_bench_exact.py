"""The exact-solver benchmarks still run (smoke runs; their figures are read by people)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def smoke_output(script: str, folder: Path) -> str:
    """What ``benchmarks/<script> --smoke`` prints, run from ``folder``."""
    return subprocess.run(
        [sys.executable, str(BENCHMARKS / script), "--smoke"],
        capture_output=True,
        text=True,
        check=True,
        cwd=folder,
    ).stdout


def test_exact_benchmark_smoke_run(tmp_path):
    """bench_exact.py --smoke prints every RATS variant, the VI timing and the optimum row."""
    out = smoke_output("bench_exact.py", tmp_path)
    for variant in ("dirac_support", "wasserstein_direct", "wasserstein_lp"):
        assert out.count(variant) == 2  # FrozenLake and Bridge
    assert "backward induction alone" in out
    assert out.count("CliffWalking-v0     1.0  200") == 3


def test_game_benchmark_smoke_run(tmp_path):
    """bench_game.py --smoke prints a timing row per env and a planner row per env."""
    out = smoke_output("bench_game.py", tmp_path)
    assert out.count("CliffWalking ") == 2 and "FrozenLake 4x4" in out
    assert "Bridge      0.10" in out and "FrozenLake  0.10" in out
