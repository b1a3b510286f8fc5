"""The exact-solver benchmark still runs (a smoke run; its figures are read by people)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_exact.py"


def test_exact_benchmark_smoke_run(tmp_path):
    """bench_exact.py --smoke prints every RATS variant, the VI timing and the optimum row."""
    out = subprocess.run(
        [sys.executable, str(BENCH), "--smoke"],
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
    ).stdout
    for variant in ("dirac_support", "wasserstein_direct", "wasserstein_lp"):
        assert out.count(variant) == 2  # FrozenLake and Bridge
    assert "backward induction alone" in out
    assert out.count("CliffWalking-v0     1.0  200") == 3
