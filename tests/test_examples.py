"""Every example script runs to completion (they are what newcomers copy)."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.name)
def test_example_runs(script):
    """The script exits 0 and prints something (learning examples need stable-baselines3)."""
    if "ns_pz.learn" in script.read_text() or "stable_baselines3" in script.read_text():
        if importlib.util.find_spec("stable_baselines3") is None:
            pytest.skip("needs the learn extra (stable-baselines3)")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip()
    assert "settotalmass" not in out.stdout + out.stderr  # MuJoCo's deprecation, silenced


def test_the_detection_example_writes_a_file_of_its_own(tmp_path):
    """Without an argument the plot goes to a new file, never a fixed name anyone may hold."""
    pytest.importorskip("matplotlib")
    script = next(path for path in EXAMPLES if path.name == "detect_change.py")
    fixed = tmp_path / "ns_pz_detect_change.png"
    fixed.write_text("someone else's")
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    out = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120, env=env
    )
    assert out.returncode == 0, out.stderr
    written = Path(out.stdout.split("plot: ")[-1].strip())
    assert written.parent == tmp_path and written != fixed and written.stat().st_size > 1000
    assert fixed.read_text() == "someone else's"


def test_the_migration_example_shows_equal_trajectories():
    """The NS-Gym migration example's point: compat and native give the same θ trajectory."""
    script = next(path for path in EXAMPLES if path.name == "nsgym_migration.py")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert "trajectories equal: True" in out.stdout, out.stdout + out.stderr
