"""The runner and its results directory under faults and misuse."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from ns_pz.experiments import LocalBackend, ResultStore, load_spec, run_spec
from ns_pz.experiments.backends import died_message

TINY = """
version = 1
name = "tiny"
title = "tiny FrozenLake"
env = "ns_pz/FrozenLake-v0"
params = { slip = 0.7 }
notifications = ["detailed", "none"]

[change]
kind = "single"
param = "slip"
first_step = 1
to = [0.4, 0.9]

[sizes.quick]
episodes = 4
horizon = 30

[[agents]]
name = "random"
"""
"""16 trials: 2 settings × 2 levels × 1 agent × 4 seeds."""


def write(folder: Path, text: str = TINY, name: str = "tiny.toml") -> Path:
    """Write a spec file and return its path."""
    path = folder / name
    path.write_text(text)
    return path


def without_times(rows: list[dict]) -> list[dict]:
    """Rows without what may differ between runs (wall times, tracebacks' file paths)."""
    return [{k: v for k, v in r.items() if k not in ("wall_time", "traceback")} for r in rows]


# -- a trial that kills its process ------------------------------------------------------------
def test_one_worker_survives_a_trial_that_kills_its_process_and_resume_goes_on(
    tmp_path: Path,
) -> None:
    """--workers 1 ran trials in the runner's own process: os._exit ended the run, no row.

    Now each such trial is an error row saying how its process ended, every other trial runs,
    and --resume re-runs the failed ones (failing again, recorded again) instead of dying.
    """
    crash = TINY.replace('name = "random"', 'name = "agents_for_tests:exits_on_cell"\nlabel = "x"')
    twin = TINY.replace('name = "random"', 'name = "agents_for_tests:raises_on_cell"\nlabel = "x"')
    experiment = load_spec(write(tmp_path, crash), "quick")
    summary = run_spec(experiment, tmp_path / "out", LocalBackend(1))
    rows = ResultStore(tmp_path / "out").rows()
    assert summary.ran == len(rows) == 16
    crashed = {r["trial"] for r in rows if r["status"] == "error"}
    assert crashed and summary.failed == len(crashed) < 16
    for row in rows:
        if row["trial"] in crashed:
            assert "worker process died (exited with code 3)" in row["error"]
    run_spec(load_spec(write(tmp_path, twin, "twin.toml")), tmp_path / "twin", LocalBackend(1))
    twin_rows = ResultStore(tmp_path / "twin").rows()
    assert {r["trial"] for r in twin_rows if r["status"] == "error"} == crashed
    ok = [{**r, "spec_hash": ""} for r in without_times(rows) if r["status"] == "ok"]
    assert ok == [{**r, "spec_hash": ""} for r in without_times(twin_rows) if r["status"] == "ok"]
    again = run_spec(experiment, tmp_path / "out", LocalBackend(1), resume=True)
    assert (again.ran, again.failed) == (len(crashed), len(crashed))


UNGUARDED = """
import sys
from ns_pz.experiments import LocalBackend, load_spec, run_spec
run_spec(load_spec(sys.argv[1]), sys.argv[2], LocalBackend(1))
"""


def test_a_script_without_a_main_guard_is_told_so_not_given_error_rows(tmp_path: Path) -> None:
    """Spawned workers import the script again and die; that is named, and no trial runs."""
    script = tmp_path / "unguarded.py"
    script.write_text(UNGUARDED)
    done = subprocess.run(
        [sys.executable, str(script), str(write(tmp_path)), str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert done.returncode == 1
    assert "RuntimeError: the worker processes ended before they started" in done.stderr
    assert "if __name__ == '__main__':" in done.stderr
    assert not list((tmp_path / "out" / "trials").glob("*.json"))


def test_a_killed_worker_is_described_by_its_signal() -> None:
    """A negative exit code is the signal that killed the process (a segfault, the OOM killer)."""
    assert "killed by signal SIGSEGV" in died_message(-11)
    assert "killed by signal SIGKILL" in died_message(-9)
    assert "exited with code 3" in died_message(3)
